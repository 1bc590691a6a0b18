//! Ground truth against independent computations: optical flow through five kinds of camera (a
//! pinhole, a fisheye, a calibrated OpenCV camera, an equirectangular panorama and a C plugin) against
//! the analytic sphere points projected with each camera's closed form written here; both depths and
//! camera-space position on a finely diced sphere; IDs.

mod common;
#[path = "../../obscura-plugins/tests/support/plugin_build.rs"]
mod plugin_build;

use std::path::Path;
use std::sync::atomic::AtomicBool;

use common::{full_sphere, white_dome};
use glam::{DMat4, DVec3, Mat4};
use obscura_host::CameraDesc;
use obscura_host::Registry;
use obscura_plugins::builtin_registry;
use obscura_render::flow::{FlowTarget, SHUTTER_CLOSE};
use obscura_render::render::{Prepared, RenderOptions, prepare};
use obscura_scene::{Identity, Material, MotionTransform, Object, Scene, Shape};
use obscura_sdk::{Format, Matrix4, MotionSample, Rgb};

/// `scene` prepared with the built-in projections.
fn prepared(scene: &Scene) -> Prepared {
    prepare(
        scene,
        &mut builtin_registry(),
        Path::new("."),
        &RenderOptions::default(),
    )
    .unwrap()
}

/// A moving sphere: centre at shutter open and close, radius.
#[derive(Clone, Copy)]
struct Ball {
    open: DVec3,
    close: DVec3,
    radius: f64,
}

const BALLS: [Ball; 3] = [
    Ball {
        open: DVec3::new(-0.8, 0.2, 5.0),
        close: DVec3::new(-0.4, 0.1, 5.3),
        radius: 1.0,
    },
    Ball {
        open: DVec3::new(1.2, -0.3, 7.0),
        close: DVec3::new(0.9, -0.1, 6.5),
        radius: 1.3,
    },
    Ball {
        open: DVec3::new(0.0, 1.6, 9.0),
        close: DVec3::new(0.0, 1.6, 9.0),
        radius: 1.2,
    },
];

/// Camera-to-world at shutter close (identity at open): a dolly with a small pan.
fn camera_close() -> DMat4 {
    DMat4::from_translation(DVec3::new(0.3, 0.1, -0.2)) * DMat4::from_rotation_y(4f64.to_radians())
}

fn sphere(radius: f64) -> Shape {
    full_sphere(radius as f32)
}

/// A camera over the shutter `[0, 1]` whose camera-to-world goes from identity at open to `close`.
fn moving_camera(format: Format, close: DMat4) -> CameraDesc {
    let mut cam = CameraDesc::new(format);
    cam.shutter = (0.0, 1.0);
    let w2c = |m: DMat4| Matrix4(m.inverse().as_mat4().to_cols_array_2d());
    cam.world_to_camera = vec![
        MotionSample {
            time: 0.0,
            world_to_camera: w2c(DMat4::IDENTITY),
        },
        MotionSample {
            time: 1.0,
            world_to_camera: w2c(close),
        },
    ];
    cam
}

/// The moving-spheres scene with a moving camera over the shutter `[0, 1]`.
fn scene(projection: &str, params: &[(&str, &[&str])], format: Format, mpl: f32) -> Scene {
    let mut s = Scene::new(moving_camera(format, camera_close()));
    s.projection = projection.into();
    for (decl, values) in params {
        s.projection_params.push_text(decl, values, None).unwrap();
    }
    for (i, b) in BALLS.iter().enumerate() {
        s.objects.push(Object {
            shape: sphere(b.radius),
            transform: MotionTransform {
                samples: vec![
                    (0.0, Mat4::from_translation(b.open.as_vec3())),
                    (1.0, Mat4::from_translation(b.close.as_vec3())),
                ],
            },
            material: 0,
            micropolygon_length: mpl,
            source: format!("ball {i}"),
            sides: Default::default(),
            visibility: Default::default(),
            identity: Identity {
                object: format!("ball{i}"),
                instance: format!("ball{i}"),
            },
        });
    }
    s.samples_per_pixel = 1;
    s
}

/// A camera's closed forms, written here: raster position → camera-space direction, and camera-space
/// point → raster position (`None` outside the domain).
struct ClosedForm {
    ray: Box<dyn Fn(f64, f64) -> Option<DVec3>>,
    raster: Box<dyn Fn(DVec3) -> Option<(f64, f64)>>,
}

/// Screen ↔ raster for the default screen window of a landscape format.
fn window(format: Format) -> (f64, f64, f64, f64) {
    let a = format.width as f64 / format.height as f64;
    (format.width as f64, format.height as f64, a, 1.0)
}

fn to_screen(format: Format, x: f64, y: f64) -> (f64, f64) {
    let (w, h, a, t) = window(format);
    (-a + x / w * 2.0 * a, t - y / h * 2.0 * t)
}

fn to_raster(format: Format, sx: f64, sy: f64) -> (f64, f64) {
    let (w, h, a, t) = window(format);
    ((sx + a) / (2.0 * a) * w, (t - sy) / (2.0 * t) * h)
}

fn perspective(format: Format, fov: f64) -> ClosedForm {
    let d = 1.0 / (fov.to_radians() / 2.0).tan();
    ClosedForm {
        ray: Box::new(move |x, y| {
            let (sx, sy) = to_screen(format, x, y);
            Some(DVec3::new(sx, sy, d).normalize())
        }),
        raster: Box::new(move |p| (p.z > 0.0).then(|| to_raster(format, d * p.x / p.z, d * p.y / p.z))),
    }
}

/// An angular fisheye: `θ = law(r)` on the unit circle of screen space, `r = inverse(θ)`.
fn fisheye(format: Format, law: fn(f64) -> f64, inverse: fn(f64) -> f64) -> ClosedForm {
    ClosedForm {
        ray: Box::new(move |x, y| {
            let (sx, sy) = to_screen(format, x, y);
            let r = sx.hypot(sy);
            if r > 1.0 || r == 0.0 {
                return None;
            }
            let th = law(r);
            Some(DVec3::new(th.sin() * sx / r, th.sin() * sy / r, th.cos()))
        }),
        raster: Box::new(move |p| {
            let th = (p.z / p.length()).acos();
            let r = inverse(th);
            let q = p.x.hypot(p.y);
            (r <= 1.0 && q > 0.0).then(|| to_raster(format, r * p.x / q, r * p.y / q))
        }),
    }
}

/// `PxrSphereCamera` at 360 × 180 on a 2:1 format.
fn latlong(format: Format) -> ClosedForm {
    ClosedForm {
        ray: Box::new(move |x, y| {
            let (sx, sy) = to_screen(format, x, y);
            let (az, el) = (sx / 2.0 * std::f64::consts::PI, sy * std::f64::consts::FRAC_PI_2);
            Some(DVec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos()))
        }),
        raster: Box::new(move |p| {
            let az = p.x.atan2(p.z);
            let el = (p.y / p.length()).asin();
            Some(to_raster(
                format,
                az / std::f64::consts::PI * 2.0,
                el / std::f64::consts::FRAC_PI_2,
            ))
        }),
    }
}

/// OpenCV's `OPENCV` model (COLMAP's name, so COLMAP's pixel convention: raster = pixel coordinates),
/// with OpenCV's +Y-down camera; the inverse by fixed-point undistortion iterated to convergence.
fn opencv(k: [f64; 8]) -> ClosedForm {
    let [fx, fy, cx, cy, k1, k2, p1, p2] = k;
    let distort = move |x: f64, y: f64| {
        let r2 = x * x + y * y;
        let radial = 1.0 + k1 * r2 + k2 * r2 * r2;
        (
            x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
        )
    };
    ClosedForm {
        ray: Box::new(move |u, v| {
            let (xd, yd) = ((u - cx) / fx, (v - cy) / fy);
            let (mut x, mut y) = (xd, yd);
            for _ in 0..200 {
                let (dx, dy) = distort(x, y);
                x += xd - dx;
                y += yd - dy;
            }
            let (dx, dy) = distort(x, y);
            assert!((dx - xd).hypot(dy - yd) < 1e-12, "undistortion converges");
            Some(DVec3::new(x, -y, 1.0).normalize())
        }),
        raster: Box::new(move |p| {
            (p.z > 0.0).then(|| {
                let (xd, yd) = distort(p.x / p.z, -p.y / p.z);
                (fx * xd + cx, fy * yd + cy)
            })
        }),
    }
}

/// The nearest analytic sphere hit along `dir` from the origin at shutter open: (ball, distance), and
/// whether the ray stays clear of every silhouette (so a tessellated sphere agrees on what is hit).
fn analytic_hit(dir: DVec3) -> (Option<(usize, f64)>, bool) {
    let mut best: Option<(usize, f64)> = None;
    let mut clear = true;
    for (i, b) in BALLS.iter().enumerate() {
        let along = b.open.dot(dir);
        let miss = (b.open - dir * along).length() / b.radius;
        if (0.97..1.03).contains(&miss) {
            clear = false;
        }
        if miss < 1.0 && along > 0.0 {
            let t = along - (b.radius * b.radius - (b.open - dir * along).length_squared()).sqrt();
            if best.is_none_or(|(_, bt)| t < bt) {
                best = Some((i, t));
            }
        }
    }
    (best, clear)
}

/// Renders nothing: prepares the scene, runs the flow pass toward shutter close, and compares every
/// clear pixel with the closed-form flow. Returns how many pixels were compared.
fn check_flow(scene: &Scene, registry: &mut Registry, cf: &ClosedForm) -> usize {
    let prepared = prepare(scene, registry, Path::new("."), &RenderOptions::default()).unwrap();
    let target = FlowTarget::new(scene, SHUTTER_CLOSE).unwrap();
    let out = prepared.flow(Some(&target), None);
    assert!(out.warnings.is_empty(), "{:?}", out.warnings);
    let format = scene.camera.format;
    let (w, h) = (format.width, format.height);
    let world_to_close = camera_close().inverse();
    let (mut compared, mut worst) = (0, 0.0f64);
    for y in 0..h {
        for x in 0..w {
            let got = out.pixels[(y * w + x) as usize];
            let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
            let Some(dir) = (cf.ray)(cx, cy) else {
                assert_eq!(got.forward_valid, 0.0, "pixel ({x}, {y}) is outside the domain");
                continue;
            };
            let (hit, clear) = analytic_hit(dir);
            if !clear {
                continue;
            }
            let Some((i, t)) = hit else {
                assert_eq!(got.forward_valid, 0.0, "pixel ({x}, {y}) sees nothing");
                continue;
            };
            let b = BALLS[i];
            let moved = dir * t - b.open + b.close;
            let seen = (cf.raster)(world_to_close.transform_point3(moved))
                .filter(|r| (0.0..=w as f64).contains(&r.0) && (0.0..=h as f64).contains(&r.1));
            let Some((rx, ry)) = seen else {
                // Leaving the frame near its edge is decided by the tessellation; well outside it is not.
                continue;
            };
            assert_eq!(got.forward_valid, 1.0, "pixel ({x}, {y}) should have a flow");
            let err = (got.forward[0] as f64 - (rx - cx)).hypot(got.forward[1] as f64 - (ry - cy));
            worst = worst.max(err);
            assert!(
                err < 0.01,
                "pixel ({x}, {y}): flow {:?}, expected ({}, {}), error {err} px",
                got.forward,
                rx - cx,
                ry - cy
            );
            compared += 1;
        }
    }
    eprintln!(
        "{}: {compared} pixels, worst error {worst:.2e} px",
        scene.projection
    );
    compared
}

/// [`check_flow`] of the moving-spheres scene (micropolygon length ½) through the built-in
/// projection `projection` with `params`.
fn builtin_flow(projection: &str, params: &[(&str, &[&str])], format: Format, cf: &ClosedForm) -> usize {
    check_flow(
        &scene(projection, params, format, 0.5),
        &mut builtin_registry(),
        cf,
    )
}

#[test]
fn flow_through_a_pinhole_equals_the_closed_form() {
    let format = Format::new(64, 48);
    let n = builtin_flow(
        "PxrPerspective",
        &[("float fov", &["60"])],
        format,
        &perspective(format, 60.0),
    );
    assert!(n > 300, "{n}");
}

#[test]
fn flow_through_a_stereographic_fisheye_equals_the_closed_form() {
    let format = Format::new(160, 120);
    let cf = fisheye(
        format,
        |r| 2.0 * (r * (200f64.to_radians() / 4.0).tan()).atan(),
        |th| (th / 2.0).tan() / (200f64.to_radians() / 4.0).tan(),
    );
    let n = builtin_flow(
        "Fisheye",
        &[("string mapping", &["stereographic"]), ("float fov", &["200"])],
        format,
        &cf,
    );
    assert!(n > 100, "{n}");
}

#[test]
fn flow_through_a_calibrated_opencv_camera_equals_the_closed_form() {
    let format = Format::new(80, 60);
    let k = [70.0, 72.0, 41.0, 29.5, -0.12, 0.03, 0.002, -0.001];
    let params: Vec<String> = k.iter().map(|v| v.to_string()).collect();
    let params: Vec<&str> = params.iter().map(String::as_str).collect();
    let n = builtin_flow(
        "CalibratedCamera",
        &[
            ("string model", &["OPENCV"]),
            ("float[8] params", &params),
            ("int[2] resolution", &["80", "60"]),
        ],
        format,
        &opencv(k),
    );
    assert!(n > 500, "{n}");
}

#[test]
fn flow_through_an_equirectangular_panorama_equals_the_closed_form() {
    let format = Format::new(96, 48);
    let n = builtin_flow(
        "PxrSphereCamera",
        &[("float hsweep", &["360"]), ("float vsweep", &["180"])],
        format,
        &latlong(format),
    );
    assert!(n > 50, "{n}");
}

#[test]
fn flow_through_a_c_plugin_equals_the_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let lib = plugin_build::compile_c_fisheye(dir.path());
    let mut registry = builtin_registry();
    let name = obscura_plugins::loader::load_file(&mut registry, &lib).unwrap();
    let format = Format::new(160, 120);
    let s = scene(&name, &[("float fov", &["180"])], format, 0.5);
    let cf = fisheye(
        format,
        |r| r * std::f64::consts::FRAC_PI_2,
        |th| th / std::f64::consts::FRAC_PI_2,
    );
    let n = check_flow(&s, &mut registry, &cf);
    assert!(n > 100, "{n}");
}

/// A static sphere in front of a pinhole, diced finely (`micropolygonlength` 0.25), lit by a dome.
fn depth_scene(projection: &str, params: &[(&str, &[&str])]) -> (Scene, DVec3, f64) {
    let centre = DVec3::new(0.3, -0.2, 4.0);
    let radius = 1.2;
    let mut s = Scene::new(CameraDesc::new(Format::new(96, 72)));
    s.projection = projection.into();
    for (decl, values) in params {
        s.projection_params.push_text(decl, values, None).unwrap();
    }
    s.materials.push(Material::Diffuse {
        color: Rgb::new(0.5, 0.5, 0.5),
    });
    s.objects.push(Object {
        shape: sphere(radius),
        transform: MotionTransform::fixed(Mat4::from_translation(centre.as_vec3())),
        material: 1,
        micropolygon_length: 0.25,
        source: "sphere".into(),
        sides: Default::default(),
        visibility: Default::default(),
        identity: Identity {
            object: "ball".into(),
            instance: "ball".into(),
        },
    });
    s.lights.push(white_dome());
    s.samples_per_pixel = 4;
    (s, centre, radius)
}

/// `distance` and `cameraZ` of every pixel on the sphere equal, to 1e-4 relative, the analytic sphere's
/// along the ray through that pixel's `Pcamera`, and `Pcamera` lies in that pixel.
fn check_depths(projection: &str, params: &[(&str, &[&str])], cf: &ClosedForm) {
    let (s, centre, radius) = depth_scene(projection, params);
    let prepared = prepared(&s);
    let out = prepared.render(&RenderOptions::default(), &|_, _| {}, &AtomicBool::new(false));
    let (mut checked, mut worst) = (0, 0.0f64);
    for y in 0..72 {
        for x in 0..96 {
            let v = out.film.pixel(x, y);
            let t = v.truth;
            if t.object_id == 0 {
                assert_eq!(t.distance, f32::INFINITY);
                continue;
            }
            assert_eq!((t.object_id, t.instance_id, t.material_id), (1, 1, 2));
            let p = t.p_camera.as_dvec3();
            let dir = p.normalize();
            let along = centre.dot(dir);
            let miss2 = (centre - dir * along).length_squared();
            assert!(miss2 < radius * radius, "pixel ({x}, {y}) hit beside the sphere");
            let exact = along - (radius * radius - miss2).sqrt();
            // The cosine of the incidence angle: a tessellation error off the surface grows along the
            // ray as 1/cos toward the silhouette, so the 1e-4 holds over the sphere's face and is
            // scaled by that factor on its limb.
            let cos = (1.0 - miss2 / (radius * radius)).sqrt();
            let tol = 1e-4 / cos.clamp(0.02, 0.5) * 0.5;
            let rel = |got: f32, want: f64| (got as f64 - want).abs() / want.abs();
            worst = worst.max(rel(t.distance, exact) * cos.min(0.5) * 2.0);
            assert!(
                rel(t.distance, exact) < tol,
                "({x}, {y}): distance {} vs {exact} (cos {cos})",
                t.distance
            );
            assert!(
                rel(t.camera_z, exact * dir.z) < tol,
                "({x}, {y}): cameraZ {} vs {}",
                t.camera_z,
                exact * dir.z
            );
            assert!(rel(t.distance, p.length()) < 1e-5);
            let (rx, ry) = (cf.raster)(p).unwrap();
            assert!(
                rx >= x as f64 - 1e-3
                    && rx <= x as f64 + 1.001
                    && ry >= y as f64 - 1e-3
                    && ry <= y as f64 + 1.001,
                "({x}, {y}): Pcamera seen at ({rx}, {ry})"
            );
            let n = t.n_camera.as_dvec3();
            assert!(
                (n - (p - centre) / radius).length() < 2e-2,
                "({x}, {y}): Ncamera {n}"
            );
            checked += 1;
        }
    }
    eprintln!("{projection}: {checked} pixels, worst relative distance error (limb-scaled) {worst:.2e}");
    assert!(checked > 100, "{checked}");
}

#[test]
fn distance_and_camera_z_are_the_analytic_spheres_through_a_pinhole() {
    check_depths(
        "PxrPerspective",
        &[("float fov", &["60"])],
        &perspective(Format::new(96, 72), 60.0),
    );
}

#[test]
fn distance_and_camera_z_are_the_analytic_spheres_through_a_fisheye() {
    let cf = fisheye(
        Format::new(96, 72),
        |r| r * std::f64::consts::FRAC_PI_2,
        |th| th / std::f64::consts::FRAC_PI_2,
    );
    check_depths(
        "Fisheye",
        &[("string mapping", &["equidistant"]), ("float fov", &["180"])],
        &cf,
    );
}

#[test]
fn a_static_scene_has_zero_flow_and_the_same_point_at_both_ends() {
    let format = Format::new(32, 24);
    let mut s = scene("PxrPerspective", &[("float fov", &["60"])], format, 1.0);
    s.camera.world_to_camera.truncate(1);
    for o in &mut s.objects {
        o.transform.samples.truncate(1);
    }
    let prepared = prepared(&s);
    let target = FlowTarget::new(&s, SHUTTER_CLOSE).unwrap();
    let out = prepared.flow(Some(&target), Some(&target));
    let valid: Vec<_> = out.pixels.iter().filter(|p| p.forward_valid == 1.0).collect();
    assert!(valid.len() > 100);
    for p in valid {
        assert!(p.forward[0].hypot(p.forward[1]) < 1e-4, "{p:?}");
        assert!(p.backward[0].hypot(p.backward[1]) < 1e-4, "{p:?}");
        assert_eq!(p.backward_valid, 1.0);
    }
}

/// A quad in the plane z = `z` spanning `x0..x1` × `y0..y1`, facing the camera.
fn quad(x0: f32, x1: f32, y0: f32, y1: f32, z: f32, name: &str) -> Object {
    Object {
        shape: Shape::Mesh(obscura_scene::Mesh {
            positions: vec![
                glam::Vec3::new(x0, y0, z),
                glam::Vec3::new(x1, y0, z),
                glam::Vec3::new(x1, y1, z),
                glam::Vec3::new(x0, y1, z),
            ],
            normals: None,
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            uvs: Vec::new(),
            colors: None,
        }),
        transform: MotionTransform::default(),
        material: 0,
        micropolygon_length: 1.0,
        source: name.into(),
        sides: Default::default(),
        visibility: Default::default(),
        identity: Identity {
            object: name.into(),
            instance: name.into(),
        },
    }
}

/// A camera translating by `travel` over the shutter through `PxrRollingShutter` (fov 90, sweep down).
fn rolling_scene(duration: &str, travel: DVec3, format: Format) -> Scene {
    let mut s = Scene::new(moving_camera(format, DMat4::from_translation(travel)));
    s.projection = "PxrRollingShutter".into();
    for (decl, v) in [
        ("float fov", "90"),
        ("float duration", duration),
        ("string sweep", "down"),
    ] {
        s.projection_params.push_text(decl, &[v], None).unwrap();
    }
    s.samples_per_pixel = 4;
    s
}

/// A camera panning fast past a vertical pole under an ideal rolling shutter (each line read at one
/// instant, top first): the pole leans, each row showing it where the camera was when that row was read.
#[test]
fn a_rolling_shutter_renders_the_skew_of_a_fast_pan() {
    let format = Format::new(64, 64);
    let mut s = rolling_scene("0", DVec3::new(2.0, 0.0, 0.0), format);
    s.objects.push(quad(-0.2, 0.2, -10.0, 10.0, 4.0, "pole"));
    s.objects.push(quad(-50.0, 50.0, -50.0, 50.0, 8.0, "wall"));
    s.lights.push(white_dome());
    let prepared = prepared(&s);
    let out = prepared.render(&RenderOptions::default(), &|_, _| {}, &AtomicBool::new(false));
    for y in (4..60).step_by(4) {
        let columns: Vec<f64> = (0..64)
            .filter(|&x| out.film.pixel(x, y).truth.object_id == 1)
            .map(|x| x as f64 + 0.5)
            .collect();
        assert!(!columns.is_empty(), "row {y} does not see the pole");
        let seen = columns.iter().sum::<f64>() / columns.len() as f64;
        // Row y is read at t = (y + ½)/H; the camera is then at x = 2t, so the pole (x = 0, z = 4) is
        // at screen x = −2t/4 (d = 1 at fov 90), raster 32·(1 + sx).
        let t = (y as f64 + 0.5) / 64.0;
        let want = 32.0 * (1.0 - 2.0 * t / 4.0);
        assert!(
            (seen - want).abs() < 1.0,
            "row {y}: pole at {seen}, expected {want}"
        );
    }
}

/// Under a rolling shutter with exposure `duration` 0.5 and a camera moving diagonally, each pixel's
/// flow goes from its own line's open to the close of the line the point lands in: the closed form
/// solves that line's time, written here, against the renderer's fixed point.
#[test]
fn rolling_shutter_flow_uses_each_pixels_own_time() {
    let format = Format::new(48, 48);
    let (vx, vy) = (0.8, 0.6);
    let mut s = rolling_scene("0.5", DVec3::new(vx, vy, 0.0), format);
    s.objects.push(quad(-50.0, 50.0, -50.0, 50.0, 5.0, "wall"));
    let prepared = prepared(&s);
    let target = FlowTarget::new(&s, SHUTTER_CLOSE).unwrap();
    let flow = prepared.flow(Some(&target), None);
    let (d, z, dur) = (1.0f64, 5.0f64, 0.5f64);
    let mut worst = 0.0f64;
    for y in 0..48u32 {
        for x in 0..48u32 {
            let got = flow.pixels[(y * 48 + x) as usize];
            let (sx, sy) = to_screen(format, x as f64 + 0.5, y as f64 + 0.5);
            // Reference: the line's open, t0 = p·(1 − duration) with p = (1 − sy)/2; the wall point.
            let t0 = (1.0 - sy) / 2.0 * (1.0 - dur);
            let (px, py) = (vx * t0 + sx * z / d, vy * t0 + sy * z / d);
            // Target line p' and its close t1 = p'(1 − duration) + duration, where
            // p' = (1 − d(py − vy·t1)/z)/2: linear in p'.
            let a = (1.0 - d * py / z) / 2.0;
            let k = d * vy / (2.0 * z);
            let p1 = (a + k * dur) / (1.0 - k * (1.0 - dur));
            let t1 = p1 * (1.0 - dur) + dur;
            let (tx, ty) = (d * (px - vx * t1) / z, d * (py - vy * t1) / z);
            let (rx, ry) = to_raster(format, tx, ty);
            if !(0.5..47.5).contains(&rx) || !(0.5..47.5).contains(&ry) {
                continue;
            }
            assert_eq!(got.forward_valid, 1.0, "({x}, {y})");
            let err = (got.forward[0] as f64 - (rx - x as f64 - 0.5))
                .hypot(got.forward[1] as f64 - (ry - y as f64 - 0.5));
            worst = worst.max(err);
            assert!(
                err < 0.01,
                "({x}, {y}): {:?} vs ({}, {})",
                got.forward,
                rx - x as f64 - 0.5,
                ry - y as f64 - 0.5
            );
        }
    }
    eprintln!("rolling shutter flow: worst error {worst:.2e} px");
}

/// PxrPerspective without its inverse.
struct NoInverse(Box<dyn obscura_sdk::Projection>);

impl obscura_sdk::Projection for NoInverse {
    fn property(&self, p: obscura_sdk::ProjectionProperty) -> Option<obscura_sdk::PropertyValue> {
        self.0.property(p)
    }
    fn project(&self, ctx: &mut obscura_sdk::ProjectionContext<'_>) {
        self.0.project(ctx);
    }
}

struct NoInverseFactory;

impl obscura_sdk::ProjectionFactory for NoInverseFactory {
    fn name(&self) -> &str {
        "NoInverse"
    }
    fn summary(&self) -> &str {
        "a pinhole without unproject"
    }
    fn param_table(&self) -> &[obscura_sdk::ParamDecl] {
        &[]
    }
    fn create_projection(
        &self,
        env: &mut obscura_sdk::ProjectionEnvironment,
        _: &obscura_sdk::ParamList,
    ) -> Result<Box<dyn obscura_sdk::Projection>, obscura_sdk::PluginError> {
        let p =
            obscura_projections::PerspectiveFactory.create_projection(env, &obscura_sdk::ParamList::new())?;
        Ok(Box::new(NoInverse(p)))
    }
}

#[test]
fn a_projection_without_unproject_gets_a_warning_and_no_flow() {
    let mut registry = builtin_registry();
    registry.register(Box::new(NoInverseFactory), "").unwrap();
    let s = scene("NoInverse", &[], Format::new(24, 16), 1.0);
    let prepared = prepare(&s, &mut registry, Path::new("."), &RenderOptions::default()).unwrap();
    let out = prepared.flow(Some(&FlowTarget::new(&s, SHUTTER_CLOSE).unwrap()), None);
    assert_eq!(
        out.warnings,
        ["warning: NoInverse has no unproject (or it failed for every pixel): no flow (flowValid is 0)"]
    );
    assert!(out.pixels.iter().all(|p| p.forward_valid == 0.0));
}
