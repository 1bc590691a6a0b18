//! Staging: what the renderer supplies when a scene file leaves it out — a camera for a file
//! without one, where that camera stands inside an interior, and lights for a file without any.
//!
//! The readers (`obscura-scene`) only record what is missing: [`Scene::auto_camera`] (no camera;
//! the world bounds of the geometry) and [`Scene::auto_light`] (no light the renderer uses). Every
//! decision is taken here, in two steps:
//!
//! | step | when | what | module |
//! |---|---|---|---|
//! | the scene's own camera | right after reading: [`load`], [`load_frames`], [`load_gltf_at`] ([`place_camera`]) | a 45° `PxrPerspective` framing the bounds from +Z ([`frame_bounds`]) | `camera.rs` |
//! | the interior probe | [`Staged::new`], from `prepare` | is the bounds' centre inside the geometry (a room)? where a camera stands inside, whether light gets in ([`probe`]) | `interior.rs` |
//! | the automatic camera | [`Staged::new`] | the bounds framed again for the projection rendered through, inside an interior when there is one ([`auto_camera`]) | `camera.rs` |
//! | the default lights | [`Staged::new`] | a soft sky, a key light, a lamp in a closed interior ([`default_lights`]) | `lights.rs` |
//!
//! The scene's own camera is placed when the file is read, not in `prepare`, because what happens
//! in between reads it: the user's `--param` and `--projection` override its `"float fov"` (the job's
//! overrides), and the camera metadata written beside the images reports its transform. Everything
//! else waits for `prepare`, so a scene reaches the render lit and framed however it was loaded.
//!
//! **The interior probe and the BVH.** The probe casts its rays with the renderer's intersector,
//! [`obscura_geometry::bvh::SceneAccel`]: it builds its own accelerator over the scene's triangle
//! meshes ([`obscura_scene::Shape::Mesh`], the only shape the glTF and OBJ readers produce), each
//! posed by its first transform sample and taken to world space vertex by vertex, one identity
//! instance over them all (see `interior.rs`). It does not reuse the dicing `prepare` does: that
//! dicing depends on the camera, which the probe decides.

mod camera;
mod interior;
mod lights;

#[cfg(test)]
mod reference;
#[cfg(test)]
mod tests;

use std::borrow::Cow;
use std::path::Path;

use glam::Vec3;
use obscura_host::{CameraDesc, CameraStage};
use obscura_scene::gltf_scene::GltfError;
use obscura_scene::rib::Frame;
use obscura_scene::source::{Animation, ImageInfo, SceneSource};
use obscura_scene::{Light, LoadError, Scene};
use obscura_sdk::Rgb;

pub use camera::{
    AutoCamera, AutoView, FRAMING_FOV_DEG, auto_camera, auto_camera_for, frame_bounds, place_camera,
};
pub use interior::{Interior, probe};
pub use lights::{default_light_note, default_lights, lights};

/// The colour of the default sky: a light blue-grey, so a white asset stands out against it.
pub const DEFAULT_SKY: Rgb = Rgb {
    r: 0.42,
    g: 0.48,
    b: 0.58,
};

/// The direction the default key light travels (world space, glTF's +Y up and +Z front): from
/// above, in front and to the left of a camera looking at the front.
pub const DEFAULT_KEY_DIRECTION: Vec3 = Vec3::new(0.45, -0.75, -0.5);

/// Reads a scene file ([`obscura_scene::load`]) and places the camera of a file without one
/// ([`place_camera`]).
///
/// # Errors
/// As [`obscura_scene::load`].
pub fn load(path: &Path, camera: CameraDesc) -> Result<Scene, LoadError> {
    let mut scene = obscura_scene::load(path, camera)?;
    place_camera(&mut scene, &path.display().to_string());
    Ok(scene)
}

/// Reads a scene file as the images it holds ([`obscura_scene::load_frames`]) and places the camera
/// of each that has none ([`place_camera`]).
///
/// # Errors
/// As [`obscura_scene::load_frames`].
pub fn load_frames(path: &Path, camera: CameraDesc) -> Result<Vec<Frame>, LoadError> {
    let mut frames = obscura_scene::load_frames(path, camera)?;
    let file = path.display().to_string();
    for frame in &mut frames {
        place_camera(&mut frame.scene, &file);
    }
    Ok(frames)
}

/// Reads a glTF file posed at `seconds` ([`obscura_scene::gltf_scene::load_gltf_at`]) and places the
/// camera when it has none ([`place_camera`]).
///
/// # Errors
/// As [`obscura_scene::gltf_scene::load_gltf_at`].
pub fn load_gltf_at(path: &Path, camera: CameraDesc, seconds: f32, fps: f32) -> Result<Scene, GltfError> {
    let mut scene = obscura_scene::gltf_scene::load_gltf_at(path, camera, seconds, fps)?;
    place_camera(&mut scene, &path.display().to_string());
    Ok(scene)
}

/// A scene file's frames ([`SceneSource`]) with the camera of each scene without one placed
/// ([`place_camera`]): what every staged loader above does, for every reader's source.
pub struct Placed {
    inner: Box<dyn SceneSource>,
    file: String,
}

impl Placed {
    /// Stages the scenes of `inner`, read from `path` (named in the camera's note).
    #[must_use]
    pub fn new(inner: Box<dyn SceneSource>, path: &Path) -> Self {
        Placed {
            inner,
            file: path.display().to_string(),
        }
    }

    fn placed(&self, scene: Result<Scene, LoadError>) -> Result<Scene, LoadError> {
        let mut scene = scene?;
        place_camera(&mut scene, &self.file);
        Ok(scene)
    }
}

impl SceneSource for Placed {
    fn base_dir(&self) -> &Path {
        self.inner.base_dir()
    }

    fn images(&self) -> &[ImageInfo] {
        self.inner.images()
    }

    fn image(&self, index: usize) -> Result<Scene, LoadError> {
        self.placed(self.inner.image(index))
    }

    fn animation(&self) -> Option<Animation> {
        self.inner.animation()
    }

    fn frame(&self, number: u32) -> Result<Scene, LoadError> {
        self.placed(self.inner.frame(number))
    }
}

/// The interior of a scene without a camera of its own: [`probe`] of the bounds recorded in
/// [`Scene::auto_camera`] (a scene without geometry has no triangle to be inside); `None` for a
/// scene with a camera.
#[must_use]
pub fn probe_scene(scene: &Scene) -> Option<Interior> {
    scene
        .auto_camera
        .and_then(|(min, max)| probe(&scene.objects, min, max))
}

/// What staging adds to one render of a scene (see the module documentation).
#[derive(Debug, Clone)]
pub struct Staged<'a> {
    /// The camera framed for the projection ([`auto_camera_for`]) when the file has none; `None`
    /// keeps the scene's.
    pub camera: Option<CameraDesc>,
    /// The interior the bounds' centre is inside, if any ([`probe`]).
    pub interior: Option<Interior>,
    /// The lights to render with: the scene's, after the default ones when it has none of its own
    /// ([`lights`]).
    pub lights: Cow<'a, [Light]>,
    /// One line per choice made (the automatic camera, the default lights), for the render's info.
    pub notes: Vec<String>,
}

impl<'a> Staged<'a> {
    /// Stages `scene` for the projection of `stage` (created from the scene's own camera): probes
    /// for an interior, frames the automatic camera and adds the default lights, as the scene's
    /// [`Scene::auto_camera`] and [`Scene::auto_light`] ask.
    #[must_use]
    pub fn new(scene: &'a Scene, stage: &CameraStage) -> Self {
        let interior = probe_scene(scene);
        let mut notes = Vec::new();
        let camera = scene
            .auto_camera
            .map(|(min, max)| auto_camera_for(stage, min, max, interior.as_ref(), &mut notes));
        if scene.auto_light {
            notes.push(default_light_note());
        }
        Staged {
            camera,
            lights: lights(scene, interior.as_ref()),
            interior,
            notes,
        }
    }
}
