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

pub mod gltf_scene;
pub mod obj;
pub mod rib;
pub mod types;

pub use types::*;
