//! Conversions the readers share: glTF's and OBJ's camera and light frames to RenderMan's, glam's
//! column-vector matrices to the SDK's row-vector ones, storing a world-to-camera transform and a
//! field of view in a [`Scene`], and growing a bounding box (the RIB reader uses `to_row_vector` too).
//!
//! Nothing here decides anything about a scene the file left incomplete (a camera, lights): that is
//! the renderer's staging (`obscura_render::staging`), which uses [`set_world_to_camera`] and
//! [`set_fov`] to store what it chose.

use glam::{Mat4, Vec3};
use obscura_sdk::{Matrix4, MotionSample, ParamValue};

use crate::types::Scene;

/// `S = diag(1, 1, −1, 1)`: glTF's camera and light frames (looking down −Z) to Obscura's (+Z).
pub fn flip_z() -> Mat4 {
    Mat4::from_scale(Vec3::new(1.0, 1.0, -1.0))
}

/// The row-vector [`Matrix4`] of a column-vector `glam` matrix: the transpose, which is exactly glam's
/// column-major storage read row by row (`[p 1]·Mᵀ = (M·[p 1]ᵀ)ᵀ`).
pub(crate) fn to_row_vector(m: Mat4) -> Matrix4 {
    Matrix4(m.to_cols_array_2d())
}

/// Replaces the camera's world-to-camera motion with one sample of `world_to_camera` (column-vector
/// glam) at shutter open.
pub fn set_world_to_camera(scene: &mut Scene, world_to_camera: Mat4) {
    scene.camera.world_to_camera = vec![MotionSample {
        time: scene.camera.shutter.0,
        world_to_camera: to_row_vector(world_to_camera),
    }];
}

/// Sets `"float fov"` (degrees) in the projection parameters, replacing an earlier one; `origin` says
/// where it came from, for messages about it.
pub fn set_fov(scene: &mut Scene, fov_deg: f32, origin: String) {
    if let Err(e) = scene
        .projection_params
        .push("float fov", ParamValue::Floats(vec![fov_deg]), Some(origin))
    {
        scene.warnings.push(e.to_string());
    }
}

/// Grows `bounds` to hold `p` (non-finite points are left out).
pub(crate) fn grow_bounds(bounds: &mut Option<(Vec3, Vec3)>, p: Vec3) {
    if !p.is_finite() {
        return;
    }
    *bounds = Some(match *bounds {
        Some((lo, hi)) => (lo.min(p), hi.max(p)),
        None => (p, p),
    });
}
