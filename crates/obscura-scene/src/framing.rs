//! What the glTF and OBJ readers share about cameras and lighting: the framing camera for a scene
//! without one ([`frame_bounds`]), storing a world-to-camera transform and a field of view, the default
//! dome light, and glam ↔ SDK matrix conventions (the RIB reader uses [`to_row_vector`] too).

use glam::{Mat4, Vec3};
use obscura_sdk::{Matrix4, MotionSample, ParamValue, Rgb};

use crate::types::{Light, Scene};

/// The vertical field of view, in degrees, used to frame a scene that has no camera of its own.
pub(crate) const FRAMING_FOV_DEG: f32 = 45.0;

/// How far outside the tightest fit [`frame_bounds`] places the camera (10 % of the half-extent), so
/// that the geometry does not touch the image edges.
const FRAMING_MARGIN: f32 = 1.1;

/// A world-to-camera transform (RenderMan camera space: +Z forward, +Y up, +X right) that frames the
/// box `min`..`max` (world points) from its +Z side, looking toward −Z in world with +Y up (glTF's
/// default viewing direction), for a field of view of `fov_deg` degrees.
///
/// The camera sits on the box's centre line at `z = max.z + 1.1·max(hx, hy)/tan(fov/2)` (`h` the
/// half-extents), the closest distance at which every corner satisfies `|x/z| ≤ tan(fov/2)` and
/// `|y/z| ≤ tan(fov/2)` in camera space, plus a 10 % margin; so the whole box is in view across both
/// image sides whenever the field of view spans the smaller side. A box flat in x and y (a line
/// along z, a point) is treated as at least a quarter of its depth wide, or 1 unit for a point.
/// Non-finite or inverted bounds frame the box `[−1, 1]³`; a field of view outside (0°, 180°) is
/// taken as 45°.
///
/// Returns a `glam` matrix acting on column vectors (`p_camera = M · p_world`).
#[must_use]
pub fn frame_bounds(min: Vec3, max: Vec3, fov_deg: f32) -> Mat4 {
    let (min, max) = if min.is_finite() && max.is_finite() && min.cmple(max).all() {
        (min, max)
    } else {
        (Vec3::splat(-1.0), Vec3::splat(1.0))
    };
    let fov = if fov_deg.is_finite() && fov_deg > 0.0 && fov_deg < 180.0 {
        fov_deg
    } else {
        FRAMING_FOV_DEG
    };
    let tan_half = (0.5 * fov.to_radians()).tan();
    let centre = 0.5 * (min + max);
    let half = 0.5 * (max - min);
    let floor = if half.max_element() > 0.0 {
        0.25 * half.max_element()
    } else {
        1.0
    };
    let across = half.x.max(half.y).max(floor);
    let distance = half.z + FRAMING_MARGIN * across / tan_half;
    let eye = centre + Vec3::new(0.0, 0.0, distance);
    flip_z() * Mat4::from_translation(-eye)
}

/// `S = diag(1, 1, −1, 1)`: glTF's camera and light frames (looking down −Z) to Obscura's (+Z).
pub(crate) fn flip_z() -> Mat4 {
    Mat4::from_scale(Vec3::new(1.0, 1.0, -1.0))
}

/// The row-vector [`Matrix4`] of a column-vector `glam` matrix: the transpose, which is exactly glam's
/// column-major storage read row by row (`[p 1]·Mᵀ = (M·[p 1]ᵀ)ᵀ`).
pub(crate) fn to_row_vector(m: Mat4) -> Matrix4 {
    Matrix4(m.to_cols_array_2d())
}

/// Replaces the camera's world-to-camera motion with one sample of `world_to_camera` (column-vector
/// glam) at shutter open.
pub(crate) fn set_world_to_camera(scene: &mut Scene, world_to_camera: Mat4) {
    scene.camera.world_to_camera = vec![MotionSample {
        time: scene.camera.shutter.0,
        world_to_camera: to_row_vector(world_to_camera),
    }];
}

/// Sets `"float fov"` (degrees) in the projection parameters, replacing an earlier one.
pub(crate) fn set_fov(scene: &mut Scene, fov_deg: f32, origin: String) {
    if let Err(e) = scene
        .projection_params
        .push("float fov", ParamValue::Floats(vec![fov_deg]), Some(origin))
    {
        scene.warnings.push(e.to_string());
    }
}

/// Frames the scene's world bounds (or `[−1, 1]³` when it has no geometry) with a 45° perspective.
pub(crate) fn frame_scene(scene: &mut Scene, bounds: Option<(Vec3, Vec3)>, file: &str) {
    let (min, max) = bounds.unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    set_world_to_camera(scene, frame_bounds(min, max, FRAMING_FOV_DEG));
    scene.projection = "PxrPerspective".into();
    set_fov(
        scene,
        FRAMING_FOV_DEG,
        format!("{file}: framing (no camera in the file)"),
    );
}

/// Adds a white dome light when the scene has no light at all, with a warning saying so.
pub(crate) fn add_default_dome_if_unlit(scene: &mut Scene, file: &str) {
    if scene.lights.is_empty() {
        scene.lights.push(Light::Dome {
            color: Rgb::WHITE,
            intensity: 1.0,
            exposure: 0.0,
            map: None,
            transform: Mat4::IDENTITY,
        });
        scene.warnings.push(format!(
            "{file}: the file has no light; added a white dome light (intensity 1) so the render is not black"
        ));
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
