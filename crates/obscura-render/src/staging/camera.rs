//! The automatic camera: the scene's own camera for a file without one ([`frame_bounds`],
//! [`place_camera`]), and the bounds framed again for the projection rendered through
//! ([`auto_camera`], [`auto_camera_for`]), from outside or inside an interior.

use glam::{Mat4, Vec3};
use obscura_host::{CameraDesc, CameraStage};
use obscura_scene::Scene;
use obscura_scene::convert::{flip_z, set_fov, set_world_to_camera};
use obscura_sdk::{DicingHint, Matrix4, ScreenWindow};

use super::interior::Interior;

/// The field of view, in degrees, used to frame a scene that has no camera of its own.
pub const FRAMING_FOV_DEG: f32 = 45.0;

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

/// The scene's own camera when its file has none ([`Scene::auto_camera`] set): a 45°
/// `PxrPerspective` ([`FRAMING_FOV_DEG`], its `"float fov"` said to come from `file`) at
/// [`frame_bounds`] of the recorded bounds. A scene with a camera is left alone.
///
/// The renderer frames the bounds again for the projection it ends up using ([`auto_camera_for`]);
/// this camera is what the overrides of a job start from and what the camera metadata reports.
pub fn place_camera(scene: &mut Scene, file: &str) {
    let Some((min, max)) = scene.auto_camera else {
        return;
    };
    set_world_to_camera(scene, frame_bounds(min, max, FRAMING_FOV_DEG));
    scene.projection = "PxrPerspective".into();
    set_fov(
        scene,
        FRAMING_FOV_DEG,
        format!("{file}: framing (no camera in the file)"),
    );
}

/// What the automatic camera is framing for: the projection's kind, from its dicing hint and field
/// of view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AutoView {
    /// A perspective camera spanning `fov` degrees across the smaller image side.
    Perspective {
        /// Field of view, degrees.
        fov: f32,
    },
    /// Parallel rays: the screen window is fitted to the bounds.
    Orthographic,
    /// A panorama or fisheye (FieldOfView ≥ 150° or a Spherical dicing hint).
    Wide {
        /// Field of view, degrees (360 for a full panorama).
        fov: f32,
    },
}

/// An automatic camera: where it stands and what it shows.
#[derive(Debug, Clone, PartialEq)]
pub struct AutoCamera {
    /// World-to-camera (column vectors, RenderMan camera space).
    pub world_to_camera: Mat4,
    /// The screen window an orthographic view needs; `None` keeps the default.
    pub screen_window: Option<ScreenWindow>,
    /// Distance from the camera to the bounds' centre: a near clipping plane should stay well in
    /// front of it.
    pub distance: f32,
    /// One line saying what was chosen.
    pub description: String,
}

/// How wide the asset's bounding box should appear for each view: the whole view minus a margin for
/// a perspective camera; 140° (or 80 % of a narrower field of view) for a wide one, so a fisheye or
/// panorama stands close and the asset fills a useful part of the picture.
fn target_angle(view: AutoView) -> f32 {
    match view {
        AutoView::Perspective { fov } => 0.9 * fov,
        AutoView::Wide { fov } => (0.8 * fov).min(140.0),
        AutoView::Orthographic => 0.0,
    }
}

/// An automatic camera for the bounds `min..max` (world, glTF's +Y up, the asset's front toward +Z).
///
/// - **Direction.** When the bounds' thinnest side is less than half the middle one (a flat asset),
///   the camera looks straight at its broad face: from +Y down (image up = −Z) for an asset lying
///   flat, from +X or +Z for one standing; otherwise from the front, raised and turned a little,
///   along `normalize(0.35, 0.3, 1)`, so three faces show.
/// - **Distance.** The nearest distance at which every corner of the box lies within the target
///   angle `θ` (`target_angle`: 90 % of a perspective field of view, 140° for a wide view) across
///   both image axes: `d = max over corners (max(|x|, |y|)/tan(θ/2) − z)`, with `(x, y, z)` the
///   corner's offset from the centre along the camera's right, up and forward axes.
/// - **Orthographic.** The camera stands `2R` away and the screen window is `±R` in y and `±R·a`
///   in x (`a` the frame aspect ≥ 1, else the other way round).
/// - **Interiors.** When `interior` is given (the geometry is closed around the bounds' centre:
///   [`probe`](super::probe)), a perspective or wide view stands inside, looking along the long
///   horizontal side with +Y up: a panorama that sees all around (360°) at the centre eye, any
///   other view (perspective, fisheye) at the end eye, so the space recedes in front of it. An
///   orthographic view frames the bounds from outside as above.
#[must_use]
pub fn auto_camera(
    min: Vec3,
    max: Vec3,
    view: AutoView,
    aspect: f32,
    interior: Option<&Interior>,
) -> AutoCamera {
    let (min, max) = if min.is_finite() && max.is_finite() && min.cmple(max).all() {
        (min, max)
    } else {
        (Vec3::splat(-1.0), Vec3::splat(1.0))
    };
    let centre = 0.5 * (min + max);
    let ext = max - min;
    let radius = (0.5 * ext.length()).max(1e-3);
    if let Some(inside) = interior.filter(|_| view != AutoView::Orthographic) {
        return interior_camera(inside, view, ext, radius);
    }
    let mut sides = [(ext.x, 0usize), (ext.y, 1), (ext.z, 2)];
    sides.sort_by(|a, b| a.0.total_cmp(&b.0));
    let flat = sides[0].0 < 0.5 * sides[1].0;
    let (toward_eye, up, side) = match (flat, sides[0].1) {
        (true, 1) => (Vec3::Y, Vec3::NEG_Z, "top"),
        (true, 0) => (Vec3::X, Vec3::Y, "side (+X)"),
        (true, _) => (Vec3::Z, Vec3::Y, "front"),
        (false, _) => (
            Vec3::new(0.35, 0.3, 1.0).normalize(),
            Vec3::Y,
            "front, raised and turned",
        ),
    };
    let forward = -toward_eye;
    let right = forward.cross(up).normalize();
    let cam_up = right.cross(forward);
    let (distance, window) = match view {
        AutoView::Orthographic => {
            let (wx, wy) = if aspect >= 1.0 {
                (radius * aspect, radius)
            } else {
                (radius, radius / aspect.max(1e-3))
            };
            (
                2.0 * radius,
                Some(ScreenWindow {
                    left: -wx,
                    right: wx,
                    bottom: -wy,
                    top: wy,
                }),
            )
        }
        AutoView::Perspective { .. } | AutoView::Wide { .. } => {
            // The nearest distance at which every corner of the box is inside the target angle.
            let t = (0.5 * target_angle(view)).clamp(1.0, 89.0).to_radians().tan();
            let d = (0..8)
                .map(|i| {
                    let corner = Vec3::new(
                        if i & 1 == 0 { min.x } else { max.x },
                        if i & 2 == 0 { min.y } else { max.y },
                        if i & 4 == 0 { min.z } else { max.z },
                    ) - centre;
                    let (x, y, z) = (corner.dot(right), corner.dot(cam_up), corner.dot(forward));
                    x.abs().max(y.abs()) / t - z
                })
                .fold(0.0f32, f32::max);
            (d.max(1e-3 * radius), None)
        }
    };
    let eye = centre + toward_eye * distance;
    let what = describe(view);
    AutoCamera {
        world_to_camera: look_along(eye, right, cam_up, forward),
        screen_window: window,
        distance,
        description: format!(
            "automatic camera for a {what} view: {side} view of the bounds ({:.3} × {:.3} × {:.3}) from {:.3} away",
            ext.x, ext.y, ext.z, distance
        ),
    }
}

/// The world-to-camera transform of a camera at `eye` with world-space unit axes `right`, `up` and
/// `forward` (RenderMan camera space: +Z forward, +Y up, +X right; `right = forward × up`).
fn look_along(eye: Vec3, right: Vec3, up: Vec3, forward: Vec3) -> Mat4 {
    Mat4::from_cols(
        right.extend(0.0),
        up.extend(0.0),
        forward.extend(0.0),
        eye.extend(1.0),
    )
    .inverse()
}

/// The view's kind for the info line: "perspective (45°)", "orthographic", "wide (180°)".
fn describe(view: AutoView) -> String {
    match view {
        AutoView::Perspective { fov } => format!("perspective ({fov:.0}°)"),
        AutoView::Orthographic => "orthographic".to_string(),
        AutoView::Wide { fov } => format!("wide ({fov:.0}°)"),
    }
}

/// The automatic camera of [`auto_camera`] inside `inside` (bounds of extent `ext` and radius
/// `radius`).
fn interior_camera(inside: &Interior, view: AutoView, ext: Vec3, radius: f32) -> AutoCamera {
    let all_around = matches!(view, AutoView::Wide { fov } if fov >= 300.0);
    let (eye, place) = if all_around {
        (inside.centre_eye, "at the centre")
    } else {
        (inside.end_eye, "toward one end")
    };
    let forward = inside.along;
    let right = forward.cross(Vec3::Y).normalize();
    let world_to_camera = look_along(eye, right, right.cross(forward), forward);
    let what = describe(view);
    let axis = if forward.x != 0.0 { "+X" } else { "+Z" };
    AutoCamera {
        world_to_camera,
        screen_window: None,
        distance: radius,
        description: format!(
            "automatic camera for a {what} view: inside an interior (the bounds {:.3} × {:.3} × {:.3} face inward around their centre), \
             standing {place} at ({:.3}, {:.3}, {:.3}) looking along {axis}",
            ext.x, ext.y, ext.z, eye.x, eye.y, eye.z
        ),
    }
}

/// The scene's camera with the automatic framing of the bounds `min..max` for the projection of
/// `stage` (see [`auto_camera`]): orthographic for an Orthographic dicing hint, wide for a
/// Spherical hint or a field of view of 150° or more, perspective otherwise. The camera's
/// description is pushed onto `info`.
#[must_use]
pub fn auto_camera_for(
    stage: &CameraStage,
    min: Vec3,
    max: Vec3,
    interior: Option<&Interior>,
    info: &mut Vec<String>,
) -> CameraDesc {
    let props = stage.properties();
    let fov = props.field_of_view.filter(|f| f.is_finite() && *f > 0.0);
    let mut camera = stage.camera().clone();
    let w = camera.screen_window();
    let aspect = ((w.right - w.left) / (w.top - w.bottom)).abs();
    let aspect = if aspect.is_finite() && aspect > 0.0 {
        aspect
    } else {
        1.0
    };
    let view = match (props.dicing_hint, fov) {
        (DicingHint::Orthographic, _) => AutoView::Orthographic,
        // FieldOfView spans the shorter side; a spherical mapping's angle grows with screen
        // distance, so the longer side sees that times the aspect (a 2:1 lat-long: 360°).
        (DicingHint::Spherical, f) => AutoView::Wide {
            fov: f.map_or(360.0, |f| f * aspect.max(1.0 / aspect)).min(360.0),
        },
        (_, Some(f)) if f >= 150.0 => AutoView::Wide { fov: f.min(360.0) },
        (_, f) => AutoView::Perspective {
            fov: f.unwrap_or(45.0),
        },
    };
    let auto = auto_camera(min, max, view, aspect, interior);
    camera.world_to_camera = vec![obscura_sdk::MotionSample {
        time: camera.shutter.0,
        world_to_camera: Matrix4(auto.world_to_camera.to_cols_array_2d()),
    }];
    if auto.screen_window.is_some() {
        camera.screen_window = auto.screen_window;
    }
    // A wide view stands close: keep the near plane in front of the asset (RenderMan's default of
    // 0.1 would cut a small asset open).
    let near = camera.clipping.0.min(1e-3 * auto.distance);
    if near > 0.0 {
        camera.clipping.0 = near;
    }
    info.push(auto.description);
    camera
}
