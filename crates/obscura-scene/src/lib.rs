//! # obscura-scene
//!
//! The scene description every Obscura reader produces and the renderer consumes, and the readers:
//! RenderMan RIB (ASCII) in [`rib`], glTF 2.0 in [`gltf_scene`], Wavefront OBJ in [`obj`].
//!
//! Spaces and conventions follow RenderMan: camera space looks down +Z with +Y up; a transform in the
//! scene is a `glam::Mat4` acting on **column** vectors (`p' = M·p`). A RIB matrix written row-major for
//! RenderMan's row vectors is therefore read with `Mat4::from_cols_array(&rib16)` — the same sixteen
//! numbers. Times in motion samples are in the scene's own units (those of `Shutter`); the renderer
//! normalises them to the shutter interval.
//!
//! Every reader is opened frame by frame through [`source::SceneSource`] ([`source::open`]), and every
//! output a display can ask for is a row of the AOV table ([`aov::AOVS`]).

#![forbid(unsafe_code)]

pub mod aov;
pub mod classic;
pub mod convert;
pub mod gltf_scene;
pub mod obj;
pub mod rib;
pub mod source;
pub mod texture;
pub mod types;
pub mod visibility;

#[cfg(any(test, feature = "fixtures"))]
pub mod fixtures;
#[cfg(test)]
mod test_support;

pub use aov::{AOVS, Aov, AovGroup, AovKind, AovSource, AovSpec};
pub use classic::*;
pub use types::*;
pub use visibility::{ClipPlane, ClipSpace, Exposure, Sides, Visibility};

use std::path::Path;

use obscura_host::CameraDesc;

/// A scene file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// A RIB error (file:line: what).
    #[error(transparent)]
    Rib(#[from] rib::RibError),
    /// A glTF error.
    #[error(transparent)]
    Gltf(#[from] gltf_scene::GltfError),
    /// An OBJ error.
    #[error(transparent)]
    Obj(#[from] obj::ObjError),
    /// The extension names no format we read.
    #[error("{0}: unknown scene format; expected .rib (.ribz, .rib.gz), .gltf, .glb or .obj")]
    Format(String),
    /// A USD stage's error, located by the USD reader (`obscura-usd`): file, prim, what was expected.
    #[error("{0}")]
    Usd(String),
    /// A frame the file does not hold was asked for.
    #[error("the scene holds no frame {0}")]
    NoFrame(u32),
}

/// Reads a scene file as the images it holds: a RIB file's worlds, each with its frame (see
/// [`rib::Frame`]); a glTF or OBJ file is one image, frame 1, not numbered by the file.
///
/// # Errors
/// As [`load`].
pub fn load_frames(path: &Path, camera: CameraDesc) -> Result<Vec<rib::Frame>, LoadError> {
    if is_rib(path) {
        let mut frames = rib::parse_file_frames(path)?;
        for frame in &mut frames {
            light_if_unlit(&mut frame.scene, path);
        }
        return Ok(frames);
    }
    Ok(vec![rib::Frame {
        number: 1,
        numbered: false,
        world: String::new(),
        scene: load(path, camera)?,
    }])
}

/// A classic scene often has no light (or only ones the renderer skips): recorded in
/// [`Scene::auto_light`], so the renderer lights it as it lights glTF and OBJ scenes, with a warning
/// saying so.
fn light_if_unlit(scene: &mut Scene, path: &Path) {
    if scene.lights.is_empty() {
        scene.auto_light = true;
        // Worded for the whole program: the renderer's staging adds them before it renders.
        scene.warnings.push(format!(
            "{}: the scene has no light the renderer uses; added the default sky and key light \
             (as for glTF and OBJ); any LightSource in the file replaces them",
            path.display()
        ));
    }
}

/// True when `path` names a RIB file by its extension (`.rib`, `.ribz`, `.rib.gz`).
fn is_rib(path: &Path) -> bool {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    [".rib", ".ribz", ".rib.gz"].iter().any(|e| name.ends_with(e))
}

/// Reads a scene by its extension: `.rib`, `.ribz` or `.rib.gz` (camera and all from the file; ASCII
/// or binary, gzip-compressed or not, whatever the extension says), `.gltf`/`.glb`/`.obj`
/// (geometry, materials, lights and the file's camera; format and the rest from `camera`).
///
/// The scene is what the file says: a file without a camera or without a light records that
/// ([`Scene::auto_camera`], [`Scene::auto_light`]) and the renderer's staging
/// (`obscura_render::staging`) supplies them.
///
/// # Errors
/// A [`LoadError`] naming the file (and line, where the format has lines).
pub fn load(path: &Path, camera: CameraDesc) -> Result<Scene, LoadError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if is_rib(path) {
        let mut scene = rib::parse_file(path)?;
        light_if_unlit(&mut scene, path);
        return Ok(scene);
    }
    match ext.as_str() {
        "gltf" | "glb" => Ok(gltf_scene::load_gltf(path, camera)?),
        "obj" => Ok(obj::load_obj(path, camera)?),
        _ => Err(LoadError::Format(path.display().to_string())),
    }
}
