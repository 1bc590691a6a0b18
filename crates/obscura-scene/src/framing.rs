//! What the glTF and OBJ readers share about cameras and lighting: the framing camera for a scene
//! without one ([`frame_bounds`] when reading; [`auto_camera`], which the renderer calls again for the
//! projection it renders through), storing a world-to-camera transform and a field of view, the
//! default lights (a soft sky and a key light), and glam ↔ SDK matrix conventions (the RIB reader
//! uses `to_row_vector` too).

use glam::{Mat4, Vec3, Vec4};
use obscura_sdk::{Matrix4, MotionSample, ParamValue, Rgb, ScreenWindow};

use crate::interior::Interior;
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

/// Frames the scene's world bounds (or `[−1, 1]³` when it has no geometry) with a 45° perspective,
/// and records the bounds in [`Scene::auto_camera`] so the renderer frames them again for the
/// projection it ends up using ([`auto_camera`]).
pub(crate) fn frame_scene(scene: &mut Scene, bounds: Option<(Vec3, Vec3)>, file: &str) {
    let (min, max) = bounds.unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    scene.auto_camera = Some((min, max));
    scene.auto_interior = bounds.and_then(|_| crate::interior::probe(&scene.objects, min, max));
    set_world_to_camera(scene, frame_bounds(min, max, FRAMING_FOV_DEG));
    scene.projection = "PxrPerspective".into();
    set_fov(
        scene,
        FRAMING_FOV_DEG,
        format!("{file}: framing (no camera in the file)"),
    );
}

/// The colour of the default sky: a light blue-grey, so a white asset stands out against it.
pub const DEFAULT_SKY: Rgb = Rgb {
    r: 0.42,
    g: 0.48,
    b: 0.58,
};

/// The direction the default key light travels (world space, glTF's +Y up and +Z front): from
/// above, in front and to the left of a camera looking at the front.
pub const DEFAULT_KEY_DIRECTION: Vec3 = Vec3::new(0.45, -0.75, -0.5);

/// The default lights of a scene without any: a soft sky (a uniform dome of [`DEFAULT_SKY`]) and a
/// distant key light along [`DEFAULT_KEY_DIRECTION`] (intensity 2.2, 5° wide), so surfaces show their
/// shape and the backdrop is not the asset's white. In a scene of classic RenderMan shaders
/// ([`Scene::local_shading`] not empty) the key light casts no shadows, as the classic lights it
/// stands in for do: a scene closed by a star-field sphere is still lit. The choice is recorded in
/// [`Scene::auto_light`] for the renderer's info line.
pub(crate) fn add_default_dome_if_unlit(scene: &mut Scene, _file: &str) {
    if scene.lights.is_empty() {
        scene.lights.push(Light::Dome {
            color: DEFAULT_SKY,
            intensity: 1.0,
            exposure: 0.0,
            map: None,
            transform: Mat4::IDENTITY,
        });
        let interior = scene.auto_interior;
        let z = interior
            .and_then(|i| i.key)
            .unwrap_or(DEFAULT_KEY_DIRECTION)
            .normalize();
        let x = z.any_orthonormal_vector();
        let y = z.cross(x);
        scene.lights.push(Light::Distant {
            color: Rgb::WHITE,
            intensity: 2.2,
            exposure: 0.0,
            angle_extent: 5.0,
            enable_shadows: scene.local_shading.is_empty(),
            transform: Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), Vec4::W),
        });
        // A closed interior lets neither in: a lamp under its ceiling shows the room.
        if let (Some(i), Some((min, max))) = (interior, scene.auto_camera)
            && i.open_above == 0.0
        {
            let ext = max - min;
            let radius = (0.04 * ext.x.min(ext.z)).max(1e-3);
            let at = Vec3::new(i.centre_eye.x, min.y + 0.8 * ext.y, i.centre_eye.z);
            scene.lights.push(Light::Sphere {
                color: Rgb::WHITE,
                intensity: ROOM_LAMP_RADIANCE,
                exposure: 0.0,
                transform: Mat4::from_translation(at) * Mat4::from_scale(Vec3::splat(2.0 * radius)),
            });
        }
        scene.auto_light = true;
    }
}

/// Radiance of the lamp a closed interior gets: a sphere of radius `r` = 4 % of the room's
/// narrower side gives irradiance `π·L·(r/d)²`, so `L = 156` gives π (a white wall's radiance 1)
/// at half that side's width, `d = 12.5 r`.
const ROOM_LAMP_RADIANCE: f32 = 156.25;

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
///   [`crate::interior::probe`]), a perspective or wide view stands inside, looking along the long
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The bounding box's corners in camera space.
    fn corners(m: Mat4, min: Vec3, max: Vec3) -> Vec<Vec3> {
        (0..8)
            .map(|i| {
                let p = Vec3::new(
                    if i & 1 == 0 { min.x } else { max.x },
                    if i & 2 == 0 { min.y } else { max.y },
                    if i & 4 == 0 { min.z } else { max.z },
                );
                m.transform_point3(p)
            })
            .collect()
    }

    #[test]
    fn a_flat_asset_lying_down_is_seen_from_above_and_whole() {
        // A rug: 4 × 0.05 × 2. Looking down −Y, the rug's front (+Z) at the bottom of the image.
        let (min, max) = (Vec3::new(-2.0, 0.0, -1.0), Vec3::new(2.0, 0.05, 1.0));
        let cam = auto_camera(min, max, AutoView::Perspective { fov: 45.0 }, 1.5, None);
        let forward = cam.world_to_camera.inverse().transform_vector3(Vec3::Z);
        assert!((forward - Vec3::NEG_Y).length() < 1e-5, "{forward}");
        let front = cam.world_to_camera.transform_point3(Vec3::new(0.0, 0.0, 1.0));
        assert!(front.y < 0.0, "the front edge is low in the picture: {front}");
        let t = (22.5f32).to_radians().tan();
        for c in corners(cam.world_to_camera, min, max) {
            assert!(c.z > 0.0 && (c.x / c.z).abs() < t && (c.y / c.z).abs() < t, "{c}");
        }
        assert!(cam.description.contains("top"));
    }

    #[test]
    fn an_interior_gets_a_camera_inside_looking_along_its_length() {
        let (min, max) = (Vec3::new(-6.0, 0.0, -2.0), Vec3::new(6.0, 3.0, 2.0));
        let inside = Interior {
            centre_eye: Vec3::new(0.0, 1.2, 0.0),
            end_eye: Vec3::new(-4.8, 1.2, 0.0),
            along: Vec3::X,
            open_above: 0.0,
            key: None,
        };
        let eye_and_forward = |view| {
            let cam = auto_camera(min, max, view, 1.5, Some(&inside));
            let to_world = cam.world_to_camera.inverse();
            (
                to_world.transform_point3(Vec3::ZERO),
                to_world.transform_vector3(Vec3::Z),
                to_world.transform_vector3(Vec3::Y),
                cam.description,
            )
        };
        // Perspective and fisheye stand at the end eye, a full panorama at the centre; all look
        // along +X with +Y up.
        for (view, eye) in [
            (AutoView::Perspective { fov: 40.0 }, inside.end_eye),
            (AutoView::Wide { fov: 180.0 }, inside.end_eye),
            (AutoView::Wide { fov: 360.0 }, inside.centre_eye),
        ] {
            let (at, forward, up, what) = eye_and_forward(view);
            assert!((at - eye).length() < 1e-5, "{view:?}: {at}");
            assert!((forward - Vec3::X).length() < 1e-5 && (up - Vec3::Y).length() < 1e-5);
            assert!(what.contains("inside an interior"), "{what}");
        }
        // An orthographic view still frames the bounds from outside.
        let ortho = auto_camera(min, max, AutoView::Orthographic, 1.5, Some(&inside));
        for c in corners(ortho.world_to_camera, min, max) {
            assert!(c.z > 0.0, "{c}");
        }
    }

    #[test]
    fn a_wide_view_stands_closer_and_an_orthographic_one_fits_its_window() {
        let (min, max) = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let dist = |v| {
            let m: Mat4 = auto_camera(min, max, v, 1.0, None).world_to_camera;
            m.inverse().transform_point3(Vec3::ZERO).length()
        };
        let persp = dist(AutoView::Perspective { fov: 45.0 });
        let fisheye = dist(AutoView::Wide { fov: 180.0 });
        assert!(fisheye < 0.6 * persp, "{fisheye} vs {persp}");
        // The cube's corners fit 140° of a fisheye: the nearest corner offsets give
        // d = max(max(|x|, |y|)/tan 70° − z) over the corners.
        assert!(fisheye > 1.0 && fisheye < 2.0, "{fisheye}");
        let wide = auto_camera(min, max, AutoView::Wide { fov: 180.0 }, 1.0, None);
        let t = 70f32.to_radians().tan();
        let worst = corners(wide.world_to_camera, min, max)
            .iter()
            .map(|c| (c.x / c.z).abs().max((c.y / c.z).abs()))
            .fold(0.0f32, f32::max);
        assert!(worst <= t * (1.0 + 1e-5) && worst > 0.99 * t, "{worst} vs {t}");
        let ortho = auto_camera(min, max, AutoView::Orthographic, 2.0, None);
        let w = ortho.screen_window.unwrap();
        assert!((w.top - 3f32.sqrt()).abs() < 1e-5 && (w.right - 2.0 * 3f32.sqrt()).abs() < 1e-5);
        for c in corners(ortho.world_to_camera, min, max) {
            assert!(c.z > 0.0 && c.x.abs() <= w.right && c.y.abs() <= w.top, "{c}");
        }
    }
}
