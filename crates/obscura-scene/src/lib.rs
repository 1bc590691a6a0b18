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

#![forbid(unsafe_code)]

pub mod framing;
pub mod gltf_scene;
pub mod obj;
pub mod rib;
pub mod texture;
pub mod types;

#[cfg(test)]
mod test_support;

pub use types::*;

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
    #[error("{0}: unknown scene format; expected .rib, .gltf, .glb or .obj")]
    Format(String),
}

/// Reads a scene by its extension: `.rib` (camera and all from the file), `.gltf`/`.glb`/`.obj`
/// (geometry, materials, lights and the file's camera; format and the rest from `camera`).
///
/// # Errors
/// A [`LoadError`] naming the file (and line, where the format has lines).
pub fn load(path: &Path, camera: CameraDesc) -> Result<Scene, LoadError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "rib" => Ok(rib::parse_file(path)?),
        "gltf" | "glb" => Ok(gltf_scene::load_gltf(path, camera)?),
        "obj" => Ok(obj::load_obj(path, camera)?),
        _ => Err(LoadError::Format(path.display().to_string())),
    }
}
