//! glTF 2.0 reader: `.gltf` (JSON, with `data:` or external buffers) and `.glb` (binary).
//!
//! The loader fills geometry, materials, lights and the camera *transform*; format, windows, shutter
//! and clipping come from the caller's [`CameraDesc`], and the CLI may override the projection.
//!
//! What is read:
//!
//! - the default scene (or the first one) and every node under its roots, each node's world matrix
//!   being the product of its ancestors' local matrices;
//! - every `TRIANGLES` primitive of every mesh node, as one [`Object`] with [`Shape::Mesh`]: positions,
//!   normals when present, indices (or the implicit `0, 1, 2, …`); other modes are skipped with a
//!   warning;
//! - materials, from `pbrMetallicRoughness` factors (textures are ignored, with one warning);
//! - the first camera met in a depth-first walk of the scene: its node's world matrix gives the
//!   world-to-camera transform, its projection `PxrPerspective` with `"float fov"` or
//!   `PxrOrthographic` with a screen window;
//! - `KHR_lights_punctual` lights (see [`load_gltf`]).
//!
//! Spaces: glTF is right-handed, +Y up, and a camera looks down its −Z with +X right. Obscura's camera
//! space looks down +Z with +Y up and +X right, so
//! `world_to_camera = S · inverse(camera node world)` with `S = diag(1, 1, −1, 1)`: the flip turns
//! glTF's viewing direction into ours and leaves right right and up up.
//!
//! The file's bytes are checked before they reach code that assumes them valid (GLB header lengths,
//! accessor types, strides and extents, percent-encoded buffer URIs, the node hierarchy), so a
//! malformed file gives a [`GltfError`] naming it, never a panic.
//!
//! [`Object`]: crate::types::Object
//! [`Shape::Mesh`]: crate::types::Shape::Mesh

//!
//! # Layout
//!
//! This file holds the entry point and the node walk; `container.rs` checks and reads the bytes (GLB
//! header, buffers, what validation misses), `mesh.rs` the triangle primitives, `camera.rs`,
//! `lights.rs` and `materials.rs` convert those to ours.

mod animation;
mod camera;
mod container;
mod lights;
mod materials;
mod mesh;
mod textures;

#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use obscura_host::CameraDesc;

use crate::types::Scene;
use container::{
    check_before_validation, check_glb_header, check_required_extensions, json_chunk, load_buffers,
};
use lights::PunctualLights;

pub use animation::Animation;

/// A glTF file could not be loaded. Every message starts with the file's path.
#[derive(Debug, thiserror::Error)]
pub enum GltfError {
    /// The file could not be read.
    #[error("cannot read glTF file {}: {source}", .path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The binary container (`.glb`) is malformed.
    #[error("{}: not a valid binary glTF (.glb) file: {what}", .path.display())]
    Binary {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// The JSON is malformed, or the document fails glTF validation (dangling indices, bad enums).
    #[error("{}: not a valid glTF 2.0 file: {source}", .path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// The glTF crate's diagnosis.
        source: gltf::Error,
    },
    /// A buffer could not be loaded: missing external file, bad `data:` URI, too short.
    #[error("{}: buffer {buffer}: {what}", .path.display())]
    Buffer {
        /// The file.
        path: PathBuf,
        /// The buffer's index in the document.
        buffer: usize,
        /// What is wrong.
        what: String,
    },
    /// A mesh primitive's data is inconsistent: an accessor of the wrong type or past the end of its
    /// buffer, or an index out of range.
    #[error("{}: mesh {mesh} primitive {primitive}: {what}", .path.display())]
    Primitive {
        /// The file.
        path: PathBuf,
        /// The mesh's index.
        mesh: usize,
        /// The primitive's index within the mesh.
        primitive: usize,
        /// What is wrong.
        what: String,
    },
    /// The document is inconsistent in a way glTF validation does not catch.
    #[error("{}: {what}", .path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// The node hierarchy is not a set of trees (a cycle, or a node with two parents).
    #[error("{}: node {node}: {what}", .path.display())]
    Node {
        /// The file.
        path: PathBuf,
        /// The node's index.
        node: usize,
        /// What is wrong.
        what: String,
    },
}

/// Loads a `.gltf` or `.glb` file into a [`Scene`] for `camera`.
///
/// `camera` supplies format, windows, shutter, clipping and aperture; its `world_to_camera` is
/// replaced by one motion sample at shutter open of the file's first camera (see the module
/// documentation). A file without one keeps `camera`'s and records its world bounds in
/// [`Scene::auto_camera`] for the renderer's staging to frame. The projection is `PxrPerspective` with `"float fov"` (degrees, across the
/// smaller image side, derived from the glTF `yfov` and the format's frame aspect `a`:
/// `fov = yfov` when `a ≥ 1`, else `2·atan(tan(yfov/2)·a)`), or `PxrOrthographic` with the screen
/// window `(−ymag·a, ymag·a, −ymag, ymag)`.
///
/// Materials: glTF material `i` is [`Scene::materials`]`[i + 1]`; a primitive without one uses the
/// default material 0. A non-zero `emissiveFactor` gives [`Material::Constant`]; roughness 1 and
/// metallic 0 give [`Material::Diffuse`] of the base colour; anything else [`Material::Surface`] with
/// `diffuse = base·(1 − metallic)`, `specular = lerp(0.04, base, metallic)` and glTF's roughness
/// (both are perceptual, α = roughness²).
///
/// Lights (`KHR_lights_punctual`, read from the document's JSON because the `gltf` crate exposes the
/// extension only behind a feature): `directional` → [`Light::Distant`] with the light node's world
/// matrix times `S` (glTF's light shines down its −Z, ours along +Z) and the illuminance as
/// intensity; `point` and `spot` → [`Light::Sphere`] at the node's world position, 1 % of the scene's
/// diagonal across, with the radiance that makes its radiant intensity equal the glTF intensity
/// (candela read as W/sr); a spot light's cone is dropped with a warning. A scene with no light is
/// recorded in [`Scene::auto_light`]: the renderer's staging lights it, as it would otherwise render
/// black.
///
/// [`Material::Constant`]: crate::types::Material::Constant
/// [`Material::Diffuse`]: crate::types::Material::Diffuse
/// [`Material::Surface`]: crate::types::Material::Surface
/// [`Light::Distant`]: crate::types::Light::Distant
/// [`Light::Sphere`]: crate::types::Light::Sphere
///
/// # Errors
/// A [`GltfError`] naming the file: unreadable, malformed JSON or GLB, missing or short buffers,
/// accessors of the wrong type or outside their buffers, indices out of range, node cycles.
///
/// An animated file is posed at time 0 (see [`load_gltf_at`] for any other time).
pub fn load_gltf(path: &Path, camera: CameraDesc) -> Result<Scene, GltfError> {
    load_posed(path, camera, &[(0.0, 0.0)])
}

/// Loads a `.gltf` or `.glb` file posed by its animations (node translation, rotation and scale,
/// glTF's interpolation modes; see [`Animation`]) at `seconds`, with the shutter's motion: camera and
/// objects get one motion sample at shutter open (animation time `seconds + open/fps`) and, when the
/// shutter has a length, one at close (`seconds + close/fps`). The shutter is thus read in frames, as
/// RenderMan's `Shutter 0 0.5` is half a frame. [`Scene::animation_seconds`] is the animation's length.
///
/// # Errors
/// As [`load_gltf`], and [`GltfError::Invalid`] for a malformed animation channel.
pub fn load_gltf_at(path: &Path, camera: CameraDesc, seconds: f32, fps: f32) -> Result<Scene, GltfError> {
    let (open, close) = camera.shutter;
    let mut times = vec![(open, seconds + open / fps)];
    if close > open {
        times.push((close, seconds + close / fps));
    }
    load_posed(path, camera, &times)
}

/// [`load_gltf`] posed at `times`: `(shutter time, animation seconds)`, the first for everything that
/// does not move (materials, lights, framing), all of them as motion samples of moving objects and the
/// camera.
fn load_posed(path: &Path, camera: CameraDesc, times: &[(f32, f32)]) -> Result<Scene, GltfError> {
    let bytes = std::fs::read(path).map_err(|source| GltfError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    check_glb_header(path, &bytes)?;
    let parse = |source| GltfError::Parse {
        path: path.to_path_buf(),
        source,
    };
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(&bytes).map_err(parse)?;
    let mut root = document.into_json();
    check_required_extensions(path, &mut root)?;
    check_before_validation(path, &root)?;
    let document = gltf::Document::from_json(root).map_err(parse)?;
    let base = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let buffers = load_buffers(path, &document, base, blob)?;
    let punctual = json_chunk(&bytes).and_then(PunctualLights::parse);

    let mut loader = Loader {
        path,
        file: path.display().to_string(),
        buffers: &buffers,
        base,
        scene: Scene::new(camera),
        bounds: None,
    };
    let animation = loader.read_animation(&document)?;
    let mut poses = Vec::with_capacity(times.len());
    for &(_, seconds) in times {
        poses.push(loader.walk(&document, &|node| animation.local(node, seconds))?);
    }
    let placed = poses[0].clone();
    loader.read_materials(&document);
    // The node of every object, to give each its motion.
    let mut object_nodes = Vec::new();
    for (i, (node, world)) in placed.iter().enumerate() {
        if let Some(mesh) = node.mesh() {
            loader.read_mesh(node, &mesh, *world)?;
            object_nodes.resize(loader.scene.objects.len(), i);
        }
    }
    if !animation.is_empty() {
        loader.scene.animation_seconds = Some(animation.duration());
    }
    let first_camera = placed
        .iter()
        .find_map(|(node, world)| node.camera().map(|c| (node, c, *world)));
    let mut camera_set = false;
    let mut camera_at = None;
    if let Some((node, cam, world)) = first_camera {
        camera_set = loader.apply_camera(node.index(), &cam, world);
        camera_at = placed.iter().position(|(n, _)| n.index() == node.index());
    }
    animation::add_motion(
        &mut loader.scene,
        times,
        &poses,
        &object_nodes,
        camera_at.filter(|_| camera_set),
    );
    loader.scene.warnings.dedup();
    if !camera_set {
        loader.scene.auto_camera = Some(loader.bounds.unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0))));
    }
    loader.read_lights(&placed, punctual, &document);
    loader.scene.auto_light = loader.scene.lights.is_empty();
    Ok(loader.scene)
}

/// What loading one file accumulates.
struct Loader<'a> {
    /// The file.
    path: &'a Path,
    /// The file, as messages name it.
    file: String,
    /// The document's buffers, by index.
    buffers: &'a [Vec<u8>],
    /// The folder relative URIs are taken from.
    base: &'a Path,
    /// The scene so far.
    scene: Scene,
    /// World-space bounds of every vertex read so far.
    bounds: Option<(Vec3, Vec3)>,
}

impl Loader<'_> {
    /// Records a warning about the file.
    fn warn(&mut self, what: String) {
        self.scene.warnings.push(format!("{}: {what}", self.file));
    }

    /// Every node under the scene's roots with its world matrix (from each node's `local` matrix), depth
    /// first, parents before children.
    fn walk<'d>(
        &mut self,
        document: &'d gltf::Document,
        local: &dyn Fn(&gltf::Node<'_>) -> Mat4,
    ) -> Result<Vec<(gltf::Node<'d>, Mat4)>, GltfError> {
        let roots: Vec<gltf::Node<'d>> = match document.default_scene().or_else(|| document.scenes().next()) {
            Some(scene) => scene.nodes().collect(),
            None => {
                let mut has_parent = vec![false; document.nodes().len()];
                for node in document.nodes() {
                    for child in node.children() {
                        has_parent[child.index()] = true;
                    }
                }
                if document.nodes().len() > 0 {
                    self.warn("the file has no scene; using every node without a parent as a root".into());
                }
                document.nodes().filter(|n| !has_parent[n.index()]).collect()
            }
        };
        let mut visited = vec![false; document.nodes().len()];
        let mut stack: Vec<(gltf::Node<'d>, Mat4)> =
            roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY)).collect();
        let mut placed = Vec::new();
        while let Some((node, parent)) = stack.pop() {
            if visited[node.index()] {
                return Err(GltfError::Node {
                    path: self.path.to_path_buf(),
                    node: node.index(),
                    what: "reached twice: glTF nodes must form trees (a cycle, or a node with two parents)"
                        .into(),
                });
            }
            visited[node.index()] = true;
            let world = parent * local(&node);
            let children: Vec<gltf::Node<'d>> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world)));
            placed.push((node, world));
        }
        Ok(placed)
    }
}
