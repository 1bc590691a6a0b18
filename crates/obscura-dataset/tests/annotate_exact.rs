//! Boxes, point tracks and correspondences against closed forms written here: spheres and a box
//! moving under a moving camera, seen through PxrPerspective, a 200° equidistant fisheye, a calibrated
//! OpenCV camera with strong distortion, a Fisheye624 calibration, PxrSphereCamera and a C plugin.
//! Each camera's projection is written here independently (camera-space point → raster), the
//! occlusion test is analytic (ray–sphere, ray–box), and the scene's motion is written in closed form
//! (linear translation, rotation about y at a constant rate).

#[path = "../../obscura-plugins/tests/support/plugin_build.rs"]
mod plugin_build;

use std::path::Path;
use std::sync::atomic::AtomicBool;

use glam::{DMat4, DVec3, Mat4};
use obscura_dataset::annotate::Status;
use obscura_dataset::annotate::boxes::frame_boxes;
use obscura_dataset::annotate::correspondences::correspond;
use obscura_dataset::annotate::tracks::{TrackPoints, track_frame};
use obscura_host::{CameraDesc, Registry};
use obscura_plugins::builtin_registry;
use obscura_render::render::{Prepared, RenderOptions, prepare};
use obscura_scene::{Identity, Mesh, MotionTransform, Object, Scene, Shape};
use obscura_sdk::{Format, Matrix4, MotionSample};

/// A body of the scene: a sphere of radius `size` or an axis-aligned cube of half-side `size`, its
/// centre moving linearly from `open` to `close` over the shutter.
#[derive(Clone, Copy, Debug)]
struct Body {
    cube: bool,
    size: f64,
    open: DVec3,
    close: DVec3,
}

impl Body {
    fn centre(&self, t: f64) -> DVec3 {
        self.open + (self.close - self.open) * t
    }
}

const BODIES: [Body; 5] = [
    Body {
        cube: false,
        size: 1.0,
        open: DVec3::new(-0.8, 0.2, 5.0),
        close: DVec3::new(-0.4, 0.1, 5.3),
    },
    Body {
        cube: false,
        size: 1.3,
        open: DVec3::new(1.2, -0.3, 7.0),
        close: DVec3::new(0.9, -0.1, 6.5),
    },
    Body {
        cube: true,
        size: 0.6,
        open: DVec3::new(0.2, 1.3, 6.0),
        close: DVec3::new(0.5, 1.1, 6.3),
    },
    // Far to the side: inside the wide cameras' domains, outside the pinhole's image.
    Body {
        cube: false,
        size: 0.5,
        open: DVec3::new(-3.0, 0.0, 1.0),
        close: DVec3::new(-3.0, 0.2, 1.2),
    },
    // Behind the camera: outside every fisheye's domain, in the panorama's.
    Body {
        cube: true,
        size: 0.5,
        open: DVec3::new(0.5, 0.0, -3.0),
        close: DVec3::new(0.4, 0.1, -3.2),
    },
];

/// The camera's translation over the shutter and its rotation about +y at close (degrees).
const CAMERA_TRAVEL: DVec3 = DVec3::new(0.3, 0.1, -0.2);
const CAMERA_TURN: f64 = 4.0;

/// Camera-to-world at shutter-normalised `t` (identity at open): translation and rotation both at a
/// constant rate, the interpolation a two-sample motion has.
fn camera_to_world(t: f64, travel: DVec3, turn: f64, base: DMat4) -> DMat4 {
    base * DMat4::from_translation(travel * t) * DMat4::from_rotation_y((turn * t).to_radians())
}

/// The scene through `projection`: the bodies moving from `t0` to `t1` of their paths over the
/// shutter, the camera from `base·camera(t0)` to `base·camera(t1)`.
fn scene(
    projection: &str,
    params: &[(&str, &[&str])],
    format: Format,
    base: DMat4,
    span: (f64, f64),
) -> Scene {
    let mut cam = CameraDesc::new(format);
    cam.shutter = (0.0, 1.0);
    let w2c = |t: f64| {
        let m = camera_to_world(t, CAMERA_TRAVEL, CAMERA_TURN, base);
        Matrix4(m.inverse().as_mat4().to_cols_array_2d())
    };
    cam.world_to_camera = vec![
        MotionSample {
            time: 0.0,
            world_to_camera: w2c(span.0),
        },
        MotionSample {
            time: 1.0,
            world_to_camera: w2c(span.1),
        },
    ];
    let mut s = Scene::new(cam);
    s.projection = projection.into();
    for (decl, values) in params {
        s.projection_params.push_text(decl, values, None).unwrap();
    }
    for (i, b) in BODIES.iter().enumerate() {
        let shape = if b.cube {
            Shape::Mesh(Mesh::cube(2.0 * b.size as f32))
        } else {
            Shape::Sphere {
                radius: b.size as f32,
                z_min: -b.size as f32,
                z_max: b.size as f32,
                theta_max: 360.0,
            }
        };
        s.objects.push(Object {
            shape,
            transform: MotionTransform {
                samples: vec![
                    (0.0, Mat4::from_translation(b.centre(span.0).as_vec3())),
                    (1.0, Mat4::from_translation(b.centre(span.1).as_vec3())),
                ],
            },
            material: 0,
            micropolygon_length: 0.5,
            source: format!("body {i}"),
            sides: Default::default(),
            visibility: Default::default(),
            identity: Identity {
                object: if b.cube { "box".into() } else { "ball".into() },
                instance: format!("body{i}"),
            },
        });
    }
    s.samples_per_pixel = 1;
    s
}

/// Raster position → camera-space direction.
type RayForm = Box<dyn Fn(f64, f64) -> Option<DVec3>>;

/// A camera: its projection's name and parameters, image size and closed form.
type Camera<'a> = (&'a str, &'a [(&'a str, &'a [&'a str])], Format, &'a ClosedForm);

/// A camera's projection written here: camera-space point (Obscura's: +y up, +z forward) → raster
/// position, `None` outside the domain; and, where easy, raster position → camera-space direction.
struct ClosedForm {
    raster: Box<dyn Fn(DVec3) -> Option<(f64, f64)>>,
    ray: Option<RayForm>,
}

/// Screen ↔ raster for the default screen window (the shorter side spans [−1, 1]).
fn screen_window(format: Format) -> (f64, f64, f64, f64) {
    let (w, h) = (format.width as f64, format.height as f64);
    if w >= h {
        (w, h, w / h, 1.0)
    } else {
        (w, h, 1.0, h / w)
    }
}

fn to_raster(format: Format, sx: f64, sy: f64) -> (f64, f64) {
    let (w, h, a, t) = screen_window(format);
    ((sx + a) / (2.0 * a) * w, (t - sy) / (2.0 * t) * h)
}

fn to_screen(format: Format, x: f64, y: f64) -> (f64, f64) {
    let (w, h, a, t) = screen_window(format);
    (-a + x / w * 2.0 * a, t - y / h * 2.0 * t)
}

fn perspective(format: Format, fov: f64) -> ClosedForm {
    let d = 1.0 / (fov.to_radians() / 2.0).tan();
    ClosedForm {
        raster: Box::new(move |p| (p.z > 0.0).then(|| to_raster(format, d * p.x / p.z, d * p.y / p.z))),
        ray: Some(Box::new(move |x, y| {
            let (sx, sy) = to_screen(format, x, y);
            Some(DVec3::new(sx, sy, d).normalize())
        })),
    }
}

/// An equidistant fisheye of full field of view `fov` degrees: `θ = r·fov/2` on the unit circle.
fn equidistant(format: Format, fov: f64) -> ClosedForm {
    let half = fov.to_radians() / 2.0;
    ClosedForm {
        raster: Box::new(move |p| {
            let th = (p.z / p.length()).clamp(-1.0, 1.0).acos();
            let r = th / half;
            let q = p.x.hypot(p.y);
            (r <= 1.0 && q > 0.0).then(|| to_raster(format, r * p.x / q, r * p.y / q))
        }),
        ray: Some(Box::new(move |x, y| {
            let (sx, sy) = to_screen(format, x, y);
            let r = sx.hypot(sy);
            (r <= 1.0 && r > 0.0).then(|| {
                let th = r * half;
                DVec3::new(th.sin() * sx / r, th.sin() * sy / r, th.cos())
            })
        })),
    }
}

/// PxrSphereCamera at 360° × 180°: azimuth from +z toward +x across the width, elevation up.
fn latlong(format: Format) -> ClosedForm {
    use std::f64::consts::{FRAC_PI_2, PI};
    ClosedForm {
        raster: Box::new(move |p| {
            let az = p.x.atan2(p.z);
            let el = (p.y / p.length()).asin();
            Some(to_raster(format, az / PI * 2.0, el / FRAC_PI_2))
        }),
        ray: Some(Box::new(move |x, y| {
            let (sx, sy) = to_screen(format, x, y);
            let (az, el) = (sx / 2.0 * PI, sy * FRAC_PI_2);
            Some(DVec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos()))
        })),
    }
}

/// COLMAP's `OPENCV` (fx, fy, cx, cy, k1, k2, p1, p2), pixel = raster (COLMAP's convention), camera
/// +y down.
fn opencv(k: [f64; 8]) -> ClosedForm {
    let [fx, fy, cx, cy, k1, k2, p1, p2] = k;
    ClosedForm {
        raster: Box::new(move |p| {
            (p.z > 0.0).then(|| {
                let (x, y) = (p.x / p.z, -p.y / p.z);
                let r2 = x * x + y * y;
                let radial = 1.0 + k1 * r2 + k2 * r2 * r2;
                let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
                let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
                (fx * xd + cx, fy * yd + cy)
            })
        }),
        ray: None,
    }
}

/// Project Aria's Fisheye624 (COLMAP's `RAD_TAN_THIN_PRISM_FISHEYE`): `θ = atan2(|(x, y)|, z)`,
/// `θ_d = θ·(1 + k0θ² + k1θ⁴ + … + k5θ¹²)`, `u = θ_d·(x, y)/|(x, y)|`; then, with `r² = |u|²`,
/// `u_x += p0(r² + 2u_x²) + 2p1·u_x·u_y + s0·r² + s1·r⁴`,
/// `u_y += p1(r² + 2u_y²) + 2p0·u_x·u_y + s2·r² + s3·r⁴`; pixel = `(fx·u_x + cx, fy·u_y + cy)`,
/// camera +y down, `θ` limited to `theta_max`.
fn fisheye624(p: [f64; 16], theta_max: f64) -> ClosedForm {
    ClosedForm {
        raster: Box::new(move |q| {
            let (x, y, z) = (q.x, -q.y, q.z);
            let rho = x.hypot(y);
            let th = rho.atan2(z);
            if th > theta_max || rho == 0.0 {
                return None;
            }
            let t2 = th * th;
            let mut poly = 0.0;
            for k in (0..6).rev() {
                poly = (poly + p[4 + k]) * t2;
            }
            let thd = th * (1.0 + poly);
            let (ux, uy) = (thd * x / rho, thd * y / rho);
            let r2 = ux * ux + uy * uy;
            let (p0, p1) = (p[10], p[11]);
            let dx = p0 * (r2 + 2.0 * ux * ux) + 2.0 * p1 * ux * uy + p[12] * r2 + p[13] * r2 * r2;
            let dy = p1 * (r2 + 2.0 * uy * uy) + 2.0 * p0 * ux * uy + p[14] * r2 + p[15] * r2 * r2;
            Some((p[0] * (ux + dx) + p[2], p[1] * (uy + dy) + p[3]))
        }),
        ray: None,
    }
}

/// Where the segment from `o` to `p` first enters the body scaled by `grow`, as a fraction of the
/// segment in `[0, 1]` (`None` when it does not).
fn entry(b: &Body, centre: DVec3, grow: f64, o: DVec3, p: DVec3) -> Option<f64> {
    let d = p - o;
    let size = b.size * grow;
    let (lo, hi): (f64, f64) = (0.0, 1.0);
    if b.cube {
        let (mut t0, mut t1) = (lo, hi);
        for a in 0..3 {
            let (oa, da, ca) = (o[a], d[a], centre[a]);
            if da.abs() < 1e-300 {
                if (oa - ca).abs() > size {
                    return None;
                }
                continue;
            }
            let (s0, s1) = ((ca - size - oa) / da, (ca + size - oa) / da);
            t0 = t0.max(s0.min(s1));
            t1 = t1.min(s0.max(s1));
        }
        (t0 <= t1).then_some(t0)
    } else {
        let oc = o - centre;
        let (a, bq, c) = (d.dot(d), 2.0 * oc.dot(d), oc.dot(oc) - size * size);
        let disc = bq * bq - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        let (s0, s1) = ((-bq - disc.sqrt()) / (2.0 * a), (-bq + disc.sqrt()) / (2.0 * a));
        (s1 >= lo && s0 <= hi).then_some(s0.max(lo))
    }
}

/// Whether the segment from `o` to `p` (its last 10⁻⁶ excepted) enters the body scaled by `grow`.
fn blocks(b: &Body, centre: DVec3, grow: f64, o: DVec3, p: DVec3) -> bool {
    entry(b, centre, grow, o, p).is_some_and(|e| e < 1.0 - 1e-6)
}

/// The analytic visibility of the point `p` on body `own` (outward normal `n`) from `o` at time `t`,
/// as the renderer decides it with its tolerance (a surface of the point's own body less than 10⁻³ of
/// the distance in front of it does not hide it): `Some(visible)`, or `None` when the point is too
/// close to a silhouette, an occluder's edge or the tolerance to call.
fn analytic_visible(own: usize, n: DVec3, p: DVec3, o: DVec3, t: f64) -> Option<bool> {
    let cos = n.dot((o - p).normalize());
    if cos.abs() < 0.15 {
        return None;
    }
    let mut visible = cos > 0.0;
    if !visible {
        // Seen from behind: hidden by its own body's front, unless that is within the tolerance.
        let b = &BODIES[own];
        let gap = entry(b, b.centre(t), 1.0, o, p).map_or(0.0, |e| 1.0 - e);
        if (0.5e-3..2e-3).contains(&gap) {
            return None;
        }
        visible = gap < 0.5e-3;
    }
    for (i, b) in BODIES.iter().enumerate() {
        if i == own {
            continue;
        }
        let (small, big) = (
            blocks(b, b.centre(t), 0.98, o, p),
            blocks(b, b.centre(t), 1.02, o, p),
        );
        if small != big {
            return None;
        }
        visible &= !big;
    }
    Some(visible)
}

/// The outward normal of body `b` at the object-space point `local`.
fn normal(b: &Body, local: DVec3) -> DVec3 {
    if b.cube {
        let a = local.abs();
        let axis = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut n = DVec3::ZERO;
        n[axis] = local[axis].signum();
        n
    } else {
        local.normalize()
    }
}

/// Whether `cf` decides the domain the same way for `p` rotated by ±2 mrad about x and y: a point
/// that close to the domain's edge is not called.
fn domain_clear(cf: &ClosedForm, p: DVec3) -> bool {
    let inside = (cf.raster)(p).is_some();
    [
        DMat4::from_rotation_x(2e-3),
        DMat4::from_rotation_x(-2e-3),
        DMat4::from_rotation_y(2e-3),
        DMat4::from_rotation_y(-2e-3),
    ]
    .iter()
    .all(|m| (cf.raster)(m.transform_point3(p)).is_some() == inside)
}

fn prepared(scene: &Scene, registry: &mut Registry) -> Prepared {
    prepare(scene, registry, Path::new("."), &RenderOptions::default()).unwrap()
}

/// Tracks of 150 points per body at three times of the shutter against the closed form: every
/// position within 1e-3 px, every status equal to the analytic one (points on a silhouette, an
/// occluder's edge or the domain's edge excepted). Returns the statuses counted.
fn check_tracks(
    projection: &str,
    params: &[(&str, &[&str])],
    format: Format,
    cf: &ClosedForm,
    registry: &mut Registry,
) -> [usize; 4] {
    let s = scene(projection, params, format, DMat4::IDENTITY, (0.0, 1.0));
    let p = prepared(&s, registry);
    let tracks = TrackPoints::sample(&p, 150, 7);
    assert_eq!(tracks.len(), 150 * BODIES.len());
    let (w, h) = (format.width as f64, format.height as f64);
    let mut counts = [0usize; 4];
    let mut worst = 0.0f64;
    for tau in [0.0f32, 0.4, 0.8] {
        let frame = track_frame(&p, &s, &tracks, tau).unwrap();
        let t = f64::from(tau);
        let c2w = camera_to_world(t, CAMERA_TRAVEL, CAMERA_TURN, DMat4::IDENTITY);
        let w2c = c2w.inverse();
        let origin = c2w.transform_point3(DVec3::ZERO);
        for (i, point) in tracks.points.iter().enumerate() {
            let b = BODIES[point.instance as usize];
            let local = point.position.as_dvec3();
            let world = b.centre(t) + local;
            let cam = w2c.transform_point3(world);
            let got = frame.status[i];
            counts[got as usize] += 1;
            let Some((x, y)) = (cf.raster)(cam) else {
                if domain_clear(cf, cam) {
                    assert_eq!(
                        got,
                        Status::OutsideDomain,
                        "{projection}: point {i} at τ {tau} {cam}"
                    );
                    assert!(frame.points[i][0].is_nan());
                }
                continue;
            };
            if !domain_clear(cf, cam) {
                continue;
            }
            assert_ne!(
                got,
                Status::OutsideDomain,
                "{projection}: point {i} at τ {tau} {cam} should be in the domain"
            );
            let err = (f64::from(frame.points[i][0]) - x).hypot(f64::from(frame.points[i][1]) - y);
            worst = worst.max(err);
            // 1e-3 px in the image; outside it, f32 precision of the screen coordinates (2e-6 relative).
            let tol = if (0.0..=w).contains(&x) && (0.0..=h).contains(&y) {
                1e-3
            } else {
                1e-3f64.max(x.abs().max(y.abs()) * 2e-6)
            };
            assert!(
                err <= tol,
                "{projection}: point {i} at τ {tau}: {:?} vs ({x}, {y}): {err} px",
                frame.points[i]
            );
            let inside = (0.0..=w).contains(&x) && (0.0..=h).contains(&y);
            if !inside {
                assert_eq!(
                    got,
                    Status::OutOfFrame,
                    "{projection}: point {i} at τ {tau} at ({x}, {y})"
                );
                continue;
            }
            let Some(visible) =
                analytic_visible(point.instance as usize, normal(&b, local), world, origin, t)
            else {
                continue;
            };
            let want = if visible {
                Status::Visible
            } else {
                Status::Occluded
            };
            assert_eq!(
                got, want,
                "{projection}: point {i} (body {}) at τ {tau} at ({x}, {y}), local {local}, world {world}, origin {origin}",
                point.instance
            );
        }
    }
    eprintln!("{projection}: statuses {counts:?}, worst error {worst:.2e} px");
    assert!(counts[0] > 100 && counts[1] > 100, "{projection}: {counts:?}");
    counts
}

/// The whole-object boxes of a still frame (the scene at the middle of its paths, not moving) against
/// the closed-form extent of the exact surfaces (a dense sampling of each sphere and of each cube's
/// edges), to one pixel; and the visible boxes against the analytic first hit at each pixel centre,
/// to one pixel, where the camera's ray is written here.
fn check_boxes(
    projection: &str,
    params: &[(&str, &[&str])],
    format: Format,
    cf: &ClosedForm,
    registry: &mut Registry,
) {
    let s = scene(projection, params, format, DMat4::IDENTITY, (0.5, 0.5));
    let p = prepared(&s, registry);
    let out = p.render(&RenderOptions::default(), &|_, _| {}, &AtomicBool::new(false));
    let boxes = frame_boxes(&p, &s, &out.film, 0.0).unwrap();
    assert_eq!(boxes.len(), BODIES.len());
    let c2w = camera_to_world(0.5, CAMERA_TRAVEL, CAMERA_TURN, DMat4::IDENTITY);
    let w2c = c2w.inverse();
    let (w, h) = (format.width as f64, format.height as f64);
    for (i, b) in BODIES.iter().enumerate() {
        let centre = b.centre(0.5);
        let mut samples = Vec::new();
        if b.cube {
            for k in 0..8u32 {
                for a in 0..3 {
                    if k & (1 << a) != 0 {
                        continue;
                    }
                    let corner = |k: u32| {
                        DVec3::new(
                            if k & 1 == 0 { -b.size } else { b.size },
                            if k & 2 == 0 { -b.size } else { b.size },
                            if k & 4 == 0 { -b.size } else { b.size },
                        )
                    };
                    let (c0, c1) = (corner(k), corner(k | (1 << a)));
                    for j in 0..=1000 {
                        samples.push(c0 + (c1 - c0) * (j as f64 / 1000.0));
                    }
                }
            }
        } else {
            for u in 0..=200 {
                for v in 0..400 {
                    let th = std::f64::consts::PI * u as f64 / 200.0;
                    let ph = std::f64::consts::TAU * v as f64 / 400.0;
                    samples.push(b.size * DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()));
                }
            }
        }
        let mut ext = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
        let mut outside = false;
        for q in samples {
            match (cf.raster)(w2c.transform_point3(centre + q)) {
                Some((x, y)) => ext = [ext[0].min(x), ext[1].min(y), ext[2].max(x), ext[3].max(y)],
                None => outside = true,
            }
        }
        let got = &boxes[i];
        assert_eq!(got.instance_id, i as u32 + 1);
        assert_eq!(got.instance_name, format!("body{i}"));
        assert_eq!(got.crosses_domain, outside, "{projection}: body {i}");
        let clipped = [ext[0].max(0.0), ext[1].max(0.0), ext[2].min(w), ext[3].min(h)];
        if ext[0] > ext[2] || clipped[0] > clipped[2] || clipped[1] > clipped[3] {
            assert!(
                got.bbox_full.is_none(),
                "{projection}: body {i}: {:?}",
                got.bbox_full
            );
            continue;
        }
        let full = got
            .bbox_full
            .unwrap_or_else(|| panic!("{projection}: body {i} has no bbox_full"));
        let full = [full[0], full[1], full[0] + full[2], full[1] + full[3]];
        for k in 0..4 {
            assert!(
                (full[k] - clipped[k]).abs() <= 1.0,
                "{projection}: body {i}: bbox_full {full:?} vs closed form {clipped:?}"
            );
        }
        // The 3D box: the cube's or sphere's exact bounds (to the dicing), corners placed at τ 0.5.
        let b3 = got.bbox3d.as_ref().unwrap();
        for a in 0..3 {
            assert!(
                (b3.object_max[a] - b.size).abs() < 0.02 * b.size,
                "{:?}",
                b3.object_max
            );
        }
        for k in 0..8 {
            let world = DVec3::from(b3.corners_world[k]);
            let local = world - centre;
            assert!(
                (local.abs() - DVec3::splat(b.size)).abs().max_element() < 0.02 * b.size,
                "{local}"
            );
            let cam = w2c.transform_point3(world);
            assert!((DVec3::from(b3.corners_camera[k]) - cam).length() < 1e-4 * cam.length().max(1.0));
            match ((cf.raster)(cam), b3.corners_raster[k]) {
                (Some((x, y)), Some([gx, gy])) => assert!((gx - x).hypot(gy - y) < 1e-3, "corner {k}"),
                (None, None) => {}
                (want, got) if domain_clear(cf, cam) => {
                    panic!("{projection}: corner {k}: {want:?} vs {got:?}")
                }
                _ => {}
            }
        }
    }
    // Visible boxes: the analytic nearest body at each pixel centre.
    let Some(ray) = &cf.ray else { return };
    let origin = c2w.transform_point3(DVec3::ZERO);
    let mut want: Vec<Option<[u32; 4]>> = vec![None; BODIES.len()];
    for y in 0..format.height {
        for x in 0..format.width {
            let Some(d) = ray(x as f64 + 0.5, y as f64 + 0.5) else {
                continue;
            };
            let far = origin + c2w.transform_vector3(d) * 1e3;
            let mut best: Option<(usize, f64)> = None;
            for (i, b) in BODIES.iter().enumerate() {
                // Bisect the entry distance along the ray with the segment test.
                if !blocks(b, b.centre(0.5), 1.0, origin, far) {
                    continue;
                }
                let (mut lo, mut hi) = (0.0, 1.0);
                for _ in 0..40 {
                    let mid = (lo + hi) / 2.0;
                    if blocks(b, b.centre(0.5), 1.0, origin, origin + (far - origin) * mid) {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                if best.is_none_or(|(_, t)| hi < t) {
                    best = Some((i, hi));
                }
            }
            if let Some((i, _)) = best {
                let e = want[i].get_or_insert([x, y, x, y]);
                *e = [e[0].min(x), e[1].min(y), e[2].max(x), e[3].max(y)];
            }
        }
    }
    for (i, w) in want.iter().enumerate() {
        let got = boxes[i].bbox;
        match (w, got) {
            (Some([x0, y0, x1, y1]), Some(g)) => {
                let want = [*x0 as f64, *y0 as f64, (x1 + 1) as f64, (y1 + 1) as f64];
                let g = [g[0], g[1], g[0] + g[2], g[1] + g[3]];
                for k in 0..4 {
                    assert!(
                        (g[k] - want[k]).abs() <= 1.0,
                        "{projection}: body {i}: bbox {g:?} vs {want:?}"
                    );
                }
            }
            (None, None) => {}
            (w, g) => {
                // A body seen in a pixel or two only may fall either way.
                let small = |b: Option<[f64; 4]>| b.is_none_or(|b| b[2] * b[3] <= 2.0);
                let small_want = w.is_none_or(|[x0, y0, x1, y1]| (x1 - x0 + 1) * (y1 - y0 + 1) <= 2);
                assert!(
                    small(g) && small_want,
                    "{projection}: body {i}: bbox {g:?} vs {w:?}"
                );
            }
        }
    }
}

/// Correspondences from camera A (`a`, the scene's camera at the middle of its path) to camera B (the
/// scene seen from `base_b`), both still: each pixel's target is B's closed form of the surface point
/// A's chief ray hits (which lies on A's ray through the pixel centre, checked with A's closed form),
/// within 1e-3 px, and each status the analytic one.
#[allow(clippy::too_many_arguments)]
fn check_correspondences(a: Camera<'_>, b: Camera<'_>, base_b: DMat4, registry: &mut Registry) {
    let sa = scene(a.0, a.1, a.2, DMat4::IDENTITY, (0.5, 0.5));
    let sb = scene(b.0, b.1, b.2, base_b, (0.5, 0.5));
    let pa = prepared(&sa, registry);
    let pb = prepared(&sb, registry);
    let c = correspond(&pa, &pb, &sb, 0.0).unwrap();
    let (wa, ha) = (a.2.width, a.2.height);
    assert_eq!((c.width, c.height), (wa, ha));
    let a2w = camera_to_world(0.5, CAMERA_TRAVEL, CAMERA_TURN, DMat4::IDENTITY);
    let b2w = camera_to_world(0.5, CAMERA_TRAVEL, CAMERA_TURN, base_b);
    let (w2a, w2b) = (a2w.inverse(), b2w.inverse());
    let origin_b = b2w.transform_point3(DVec3::ZERO);
    let (wb, hb) = (b.2.width as f64, b.2.height as f64);
    let mut counts = [0usize; 5];
    let mut worst = 0.0f64;
    for y in 0..ha {
        let rasters: Vec<(f64, f64)> = (0..wa).map(|x| (x as f64 + 0.5, y as f64 + 0.5)).collect();
        let rays = pa.trace_chief(&rasters, 0.0);
        for x in 0..wa {
            let i = (y * wa + x) as usize;
            let got = c.status[i];
            counts[got as usize] += 1;
            let Some(hit) = rays[x as usize].and_then(|r| r.hit) else {
                assert_eq!(got, Status::NoSurface, "pixel ({x}, {y})");
                continue;
            };
            let world = hit.position.as_dvec3();
            let (ax, ay) = (a.3.raster)(w2a.transform_point3(world)).expect("A's hit is in A's domain");
            assert!(
                (ax - (x as f64 + 0.5)).hypot(ay - (y as f64 + 0.5)) < 1e-3,
                "A's hit lies on A's ray"
            );
            let cam = w2b.transform_point3(world);
            if !domain_clear(b.3, cam) {
                continue;
            }
            let Some((bx, by)) = (b.3.raster)(cam) else {
                assert_eq!(got, Status::OutsideDomain, "pixel ({x}, {y})");
                continue;
            };
            let t = c.target[i];
            let err = (f64::from(t[0]) - bx).hypot(f64::from(t[1]) - by);
            worst = worst.max(err);
            let tol = 1e-3f64.max(bx.abs().max(by.abs()) * 1e-6);
            assert!(err <= tol, "pixel ({x}, {y}): {t:?} vs ({bx}, {by}): {err} px");
            if !((0.0..=wb).contains(&bx) && (0.0..=hb).contains(&by)) {
                assert_eq!(got, Status::OutOfFrame, "pixel ({x}, {y})");
                continue;
            }
            let own = hit.object.instance as usize;
            let local = world - BODIES[own].centre(0.5);
            let Some(visible) = analytic_visible(own, normal(&BODIES[own], local), world, origin_b, 0.5)
            else {
                continue;
            };
            let want = if visible {
                Status::Visible
            } else {
                Status::Occluded
            };
            assert_eq!(
                got, want,
                "pixel ({x}, {y}) → ({bx}, {by}): body {own}, local {local}, world {world}, B at {origin_b}"
            );
        }
    }
    eprintln!(
        "{} → {}: statuses {counts:?}, worst error {worst:.2e} px",
        a.0, b.0
    );
    assert!(counts[0] > 200 && counts[4] > 50, "{counts:?}");
}

const PERSPECTIVE: (&str, &[(&str, &[&str])]) = ("PxrPerspective", &[("float fov", &["60"])]);
const FISHEYE: (&str, &[(&str, &[&str])]) = (
    "Fisheye",
    &[("string mapping", &["equidistant"]), ("float fov", &["200"])],
);
const SPHERE: (&str, &[(&str, &[&str])]) = (
    "PxrSphereCamera",
    &[("float hsweep", &["360"]), ("float vsweep", &["180"])],
);
const OPENCV_K: [f64; 8] = [60.0, 62.0, 48.5, 35.5, -0.32, 0.09, 0.004, -0.003];
const OPENCV: (&str, &[(&str, &[&str])]) = (
    "CalibratedCamera",
    &[
        ("string model", &["OPENCV"]),
        (
            "float[8] params",
            &["60", "62", "48.5", "35.5", "-0.32", "0.09", "0.004", "-0.003"],
        ),
        ("int[2] resolution", &["96", "72"]),
    ],
);
const F624_K: [f64; 16] = [
    38.0, 38.5, 64.2, 47.8, 0.04, -0.012, 0.002, 0.0, 0.0, 0.0, 0.0006, -0.0004, 0.001, -0.0005, 0.0008,
    0.0002,
];
const F624: (&str, &[(&str, &[&str])]) = (
    "CalibratedCamera",
    &[
        ("string model", &["RAD_TAN_THIN_PRISM_FISHEYE"]),
        (
            "float[16] params",
            &[
                "38", "38.5", "64.2", "47.8", "0.04", "-0.012", "0.002", "0", "0", "0", "0.0006", "-0.0004",
                "0.001", "-0.0005", "0.0008", "0.0002",
            ],
        ),
        ("int[2] resolution", &["128", "96"]),
    ],
);

#[test]
fn tracks_and_boxes_through_a_pinhole() {
    let format = Format::new(96, 72);
    let cf = perspective(format, 60.0);
    let mut r = builtin_registry();
    check_tracks(PERSPECTIVE.0, PERSPECTIVE.1, format, &cf, &mut r);
    check_boxes(PERSPECTIVE.0, PERSPECTIVE.1, format, &cf, &mut r);
}

#[test]
fn tracks_and_boxes_through_a_200_degree_equidistant_fisheye() {
    let format = Format::new(128, 96);
    let cf = equidistant(format, 200.0);
    let mut r = builtin_registry();
    let counts = check_tracks(FISHEYE.0, FISHEYE.1, format, &cf, &mut r);
    assert!(
        counts[3] > 50,
        "points behind the camera are outside the domain: {counts:?}"
    );
    check_boxes(FISHEYE.0, FISHEYE.1, format, &cf, &mut r);
}

#[test]
fn tracks_and_boxes_through_a_calibrated_opencv_camera_with_strong_distortion() {
    let format = Format::new(96, 72);
    let cf = opencv(OPENCV_K);
    let mut r = builtin_registry();
    check_tracks(OPENCV.0, OPENCV.1, format, &cf, &mut r);
    check_boxes(OPENCV.0, OPENCV.1, format, &cf, &mut r);
}

#[test]
fn tracks_and_boxes_through_a_fisheye624_calibration() {
    let format = Format::new(128, 96);
    let cf = fisheye624(F624_K, std::f64::consts::PI);
    let mut r = builtin_registry();
    check_tracks(F624.0, F624.1, format, &cf, &mut r);
    check_boxes(F624.0, F624.1, format, &cf, &mut r);
}

#[test]
fn tracks_and_boxes_through_an_equirectangular_panorama() {
    let format = Format::new(96, 48);
    let cf = latlong(format);
    let mut r = builtin_registry();
    let counts = check_tracks(SPHERE.0, SPHERE.1, format, &cf, &mut r);
    assert_eq!(counts[3], 0, "a full panorama has no outside: {counts:?}");
    check_boxes(SPHERE.0, SPHERE.1, format, &cf, &mut r);
}

#[test]
fn tracks_boxes_and_correspondences_through_a_c_plugin() {
    let dir = tempfile::tempdir().unwrap();
    let lib = plugin_build::compile_c_fisheye(dir.path());
    let mut r = builtin_registry();
    let name = obscura_plugins::loader::load_file(&mut r, &lib).unwrap();
    let format = Format::new(128, 96);
    let cf = equidistant(format, 180.0);
    let params: &[(&str, &[&str])] = &[("float fov", &["180"])];
    check_tracks(&name, params, format, &cf, &mut r);
    check_boxes(&name, params, format, &cf, &mut r);
    let persp = perspective(Format::new(96, 72), 60.0);
    check_correspondences(
        (PERSPECTIVE.0, PERSPECTIVE.1, Format::new(96, 72), &persp),
        (&name, params, format, &cf),
        rig_offset(),
        &mut r,
    );
}

/// Camera B of the rigs: 0.6 to the right, turned 12° toward the left.
fn rig_offset() -> DMat4 {
    DMat4::from_translation(DVec3::new(0.6, 0.0, 0.0)) * DMat4::from_rotation_y(-12f64.to_radians())
}

#[test]
fn correspondences_from_a_pinhole_to_a_fisheye_and_a_calibrated_camera() {
    let mut r = builtin_registry();
    let fa = Format::new(96, 72);
    let pa = perspective(fa, 60.0);
    let fb = Format::new(128, 96);
    let fish = equidistant(fb, 200.0);
    check_correspondences(
        (PERSPECTIVE.0, PERSPECTIVE.1, fa, &pa),
        (FISHEYE.0, FISHEYE.1, fb, &fish),
        rig_offset(),
        &mut r,
    );
    let cv = opencv(OPENCV_K);
    check_correspondences(
        (PERSPECTIVE.0, PERSPECTIVE.1, fa, &pa),
        (OPENCV.0, OPENCV.1, fa, &cv),
        rig_offset(),
        &mut r,
    );
}

#[test]
fn correspondences_from_a_fisheye_to_a_fisheye624() {
    let mut r = builtin_registry();
    let fa = Format::new(128, 96);
    let fish = equidistant(fa, 200.0);
    let f624 = fisheye624(F624_K, std::f64::consts::PI);
    check_correspondences(
        (FISHEYE.0, FISHEYE.1, fa, &fish),
        (F624.0, F624.1, fa, &f624),
        rig_offset(),
        &mut r,
    );
}

/// Under an ideal rolling shutter read top to bottom (`PxrRollingShutter`, `duration` 0), each track
/// is seen at its own row's time: the closed form solves `y = f_y(y/H)` (`f` the pinhole of the scene
/// at time `t`) by iteration, and every position is within 1e-3 px of `f(y/H)`, every status the
/// analytic one at that time.
#[test]
fn tracks_under_a_rolling_shutter_are_seen_at_their_own_row_time() {
    let format = Format::new(96, 72);
    let params: &[(&str, &[&str])] = &[
        ("float fov", &["60"]),
        ("float duration", &["0"]),
        ("string sweep", &["down"]),
    ];
    let mut r = builtin_registry();
    let s = scene("PxrRollingShutter", params, format, DMat4::IDENTITY, (0.0, 1.0));
    let p = prepared(&s, &mut r);
    let tracks = TrackPoints::sample(&p, 150, 11);
    let frame = track_frame(&p, &s, &tracks, 0.0).unwrap();
    let cf = perspective(format, 60.0);
    let (w, h) = (format.width as f64, format.height as f64);
    let last = f64::from(1.0f32 - f32::EPSILON / 2.0);
    let (mut checked, mut worst, mut spread) = (0, 0.0f64, (f64::INFINITY, 0.0f64));
    for (i, point) in tracks.points.iter().enumerate() {
        let b = BODIES[point.instance as usize];
        let local = point.position.as_dvec3();
        let at = |t: f64| {
            let c2w = camera_to_world(t, CAMERA_TRAVEL, CAMERA_TURN, DMat4::IDENTITY);
            let world = b.centre(t) + local;
            (
                (cf.raster)(c2w.inverse().transform_point3(world)),
                world,
                c2w.transform_point3(DVec3::ZERO),
            )
        };
        let mut t = 0.5;
        let mut solved = None;
        for _ in 0..200 {
            let Some((_, y)) = at(t).0 else { break };
            let next = (y / h).clamp(0.0, last);
            if (next - t).abs() < 1e-13 {
                solved = Some(next);
                break;
            }
            t = next;
        }
        let got = frame.status[i];
        let Some(t) = solved else {
            assert_eq!(got, Status::OutsideDomain, "point {i}");
            continue;
        };
        let (Some((x, y)), world, origin) = at(t) else {
            unreachable!()
        };
        if !(0.0..=w).contains(&x) || !(0.0..=h).contains(&y) {
            assert_eq!(got, Status::OutOfFrame, "point {i} at ({x}, {y})");
            continue;
        }
        let err = (f64::from(frame.points[i][0]) - x).hypot(f64::from(frame.points[i][1]) - y);
        worst = worst.max(err);
        assert!(
            err <= 1e-3,
            "point {i}: {:?} vs ({x}, {y}) at t {t}: {err} px",
            frame.points[i]
        );
        spread = (spread.0.min(t), spread.1.max(t));
        checked += 1;
        if let Some(visible) = analytic_visible(point.instance as usize, normal(&b, local), world, origin, t)
        {
            let want = if visible {
                Status::Visible
            } else {
                Status::Occluded
            };
            assert_eq!(got, want, "point {i} at ({x}, {y}), t {t}");
        }
    }
    eprintln!("rolling shutter: {checked} tracks, worst {worst:.2e} px, row times {spread:?}");
    assert!(checked > 200 && spread.1 - spread.0 > 0.3, "{checked} {spread:?}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// Over the whole image of a moving fisheye: the surface point a chief ray hits, carried in its
    /// object's space, reprojects to the raster position the ray came from (within 1e-4 px) and is
    /// located visible there.
    #[test]
    fn locate_inverts_the_chief_ray_trace(x in 0.0f64..128.0, y in 0.0f64..96.0, tau in 0.0f32..0.9) {
        use obscura_dataset::annotate::reproject::locate;
        use obscura_render::flow::FlowTarget;
        static FRAME: std::sync::OnceLock<(Scene, Prepared)> = std::sync::OnceLock::new();
        let (s, p) = FRAME.get_or_init(|| {
            let s = scene(FISHEYE.0, FISHEYE.1, Format::new(128, 96), DMat4::IDENTITY, (0.0, 1.0));
            let p = prepared(&s, &mut builtin_registry());
            (s, p)
        });
        let Some(hit) = p.trace_chief(&[(x, y)], tau)[0].and_then(|r| r.hit) else {
            return Ok(());
        };
        let motion = FlowTarget::new(s, tau).unwrap();
        let l = locate(p, &motion, &[hit.object], true)[0];
        proptest::prop_assert!((l.raster[0] - x).hypot(l.raster[1] - y) < 1e-4, "{:?} vs ({x}, {y})", l.raster);
        proptest::prop_assert_eq!(l.status, Status::Visible);
    }
}
