//! Every camera export against the pixels the render itself gives.
//!
//! For each camera model — PxrPerspective (with an off-centre, non-square screen window), a 200°
//! equidistant Fisheye, a strongly distorted calibrated OpenCV camera, OpenCV's rational model, a
//! Fisheye624 (COLMAP's RAD_TAN_THIN_PRISM_FISHEYE) and a Kannala–Brandt calibration, an f-theta
//! fisheye, PxrSphereCamera — known world points are seen through the projection's own exact
//! inverse (`Projection::unproject`, the pixel the render puts them at), then through each written
//! file, read back with the format's formulas written here independently from the tools' sources
//! (COLMAP's `models.h`, nerfstudio's `cameras.py`/`camera_utils.py`, gsplat's `Cameras.cuh`), and —
//! for COLMAP — by pycolmap itself (`Reconstruction(path)`, then `camera.img_from_cam` of
//! `image.cam_from_world` times the point). Every pixel must agree to 1e-3 px. Models with no
//! equivalent must say so in the file and in a warning.

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::{DMat4, DQuat, DVec3, DVec4};
use obscura_dataset::export::{ExportCamera, ExportFormat, ExportFrame, write_exports};
use obscura_host::CameraDesc;
use obscura_plugins::builtin_registry;
use obscura_render::metadata::camera_json;
use obscura_render::render::{RenderOptions, prepare};
use obscura_scene::Scene;
use obscura_sdk::{Format, Matrix4, MotionSample, ScreenWindow, Vec3};
use serde_json::{Value, json};

const TOL: f64 = 1e-3;

/// One camera model under test.
struct Case {
    name: &'static str,
    projection: &'static str,
    params: Vec<(&'static str, Vec<&'static str>)>,
    size: (u32, u32),
    window: Option<ScreenWindow>,
    /// Largest angle from the axis of the test points, degrees (None: the whole sphere).
    max_angle: Option<f64>,
    /// The formats with an exact equivalent.
    exact: &'static [ExportFormat],
}

use ExportFormat::{Colmap, Gsplat, Nerfstudio};

fn cases() -> Vec<Case> {
    let calibrated = |model: &'static str, params: Vec<&'static str>, n: &'static str| {
        vec![
            ("string model", vec![model]),
            (n, params),
            ("int[2] resolution", vec!["640", "480"]),
        ]
    };
    vec![
        Case {
            name: "perspective",
            projection: "PxrPerspective",
            params: vec![("float fov", vec!["50"])],
            size: (640, 360),
            window: Some(ScreenWindow::new(-1.3, 0.9, -0.55, 0.7)),
            max_angle: Some(20.0),
            exact: &[Colmap, Nerfstudio, Gsplat],
        },
        Case {
            name: "fisheye200",
            projection: "Fisheye",
            params: vec![
                ("string mapping", vec!["equidistant"]),
                ("float fov", vec!["200"]),
            ],
            size: (480, 480),
            window: None,
            max_angle: Some(99.0),
            exact: &[Colmap, Nerfstudio, Gsplat],
        },
        Case {
            name: "opencv",
            projection: "CalibratedCamera",
            params: calibrated(
                "OPENCV",
                vec!["500", "510", "322", "238", "-0.32", "0.11", "0.002", "-0.0015"],
                "float[8] params",
            ),
            size: (640, 480),
            window: None,
            max_angle: Some(35.0),
            exact: &[Colmap, Nerfstudio, Gsplat],
        },
        Case {
            name: "rational",
            projection: "CalibratedCamera",
            params: calibrated(
                "OPENCV_PINHOLE",
                vec![
                    "500", "505", "319.5", "239.5", "-0.2", "0.05", "0.001", "-0.001", "0.01", "0.1", "0.02",
                    "0.005",
                ],
                "float[12] params",
            ),
            size: (640, 480),
            window: None,
            max_angle: Some(30.0),
            exact: &[Colmap, Gsplat],
        },
        Case {
            name: "fisheye624",
            projection: "CalibratedCamera",
            params: calibrated(
                "RAD_TAN_THIN_PRISM_FISHEYE",
                vec![
                    "240", "241", "320", "240", "0.02", "-0.01", "0.003", "-0.0005", "0.0001", "-0.00001",
                    "0.0005", "-0.0003", "0.0004", "-0.0002", "0.0003", "0.0001",
                ],
                "float[16] params",
            ),
            size: (640, 480),
            window: None,
            max_angle: Some(80.0),
            exact: &[Colmap, Nerfstudio],
        },
        Case {
            name: "kannala_brandt",
            projection: "CalibratedCamera",
            params: calibrated(
                "KANNALA_BRANDT",
                vec![
                    "260", "262", "319.5", "239.5", "0.03", "-0.01", "0.002", "-0.0003",
                ],
                "float[8] params",
            ),
            size: (640, 480),
            window: None,
            max_angle: Some(85.0),
            exact: &[Colmap, Nerfstudio, Gsplat],
        },
        Case {
            name: "ftheta",
            projection: "Fisheye",
            params: vec![
                ("string mapping", vec!["polynomial"]),
                ("float fov", vec!["190"]),
                ("float[5] polynomial", vec!["0", "-0.09", "0", "-0.0001", "0"]),
            ],
            size: (480, 480),
            window: None,
            max_angle: Some(90.0),
            exact: &[Gsplat],
        },
        Case {
            name: "sphere",
            projection: "PxrSphereCamera",
            params: vec![],
            size: (720, 360),
            window: None,
            max_angle: None,
            exact: &[Colmap, Nerfstudio],
        },
        Case {
            name: "opencv_at_half_size",
            projection: "CalibratedCamera",
            params: calibrated(
                "OPENCV",
                vec!["500", "510", "322", "238", "-0.32", "0.11", "0.002", "-0.0015"],
                "float[8] params",
            ),
            size: (320, 240),
            window: None,
            max_angle: Some(35.0),
            exact: &[Colmap, Nerfstudio, Gsplat],
        },
        calibrated_case(
            "SIMPLE_RADIAL",
            vec!["400", "320", "240", "-0.05"],
            40.0,
            &[Colmap, Nerfstudio, Gsplat],
        ),
        calibrated_case(
            "RADIAL",
            vec!["400", "320", "240", "-0.05", "0.01"],
            40.0,
            &[Colmap, Nerfstudio, Gsplat],
        ),
        calibrated_case("FOV", vec!["400", "410", "320", "240", "0.8"], 40.0, &[Colmap]),
        calibrated_case(
            "SIMPLE_RADIAL_FISHEYE",
            vec!["300", "320", "240", "0.02"],
            85.0,
            &[Colmap, Nerfstudio, Gsplat],
        ),
        calibrated_case(
            "RADIAL_FISHEYE",
            vec!["300", "320", "240", "0.02", "-0.005"],
            85.0,
            &[Colmap, Nerfstudio, Gsplat],
        ),
        calibrated_case(
            "THIN_PRISM_FISHEYE",
            vec![
                "300", "305", "320", "240", "0.02", "-0.01", "0.001", "-0.0005", "0.003", "-0.0005",
                "0.0005", "-0.0003",
            ],
            85.0,
            &[Colmap],
        ),
        calibrated_case(
            "SIMPLE_DIVISION",
            vec!["400", "320", "240", "-0.1"],
            40.0,
            &[Colmap],
        ),
        calibrated_case(
            "DIVISION",
            vec!["400", "410", "320", "240", "-0.1"],
            40.0,
            &[Colmap],
        ),
        calibrated_case(
            "SIMPLE_FISHEYE",
            vec!["300", "320", "240"],
            85.0,
            &[Colmap, Nerfstudio, Gsplat],
        ),
        calibrated_case(
            "FISHEYE",
            vec!["300", "305", "320", "240"],
            85.0,
            &[Colmap, Nerfstudio, Gsplat],
        ),
        calibrated_case(
            "EUCM",
            vec!["300", "305", "320", "240", "0.6", "1.1"],
            85.0,
            &[Colmap],
        ),
        calibrated_case(
            "UCM",
            vec!["300", "305", "319.5", "239.5", "0.6"],
            85.0,
            &[Colmap],
        ),
        calibrated_case(
            "OPENCV_PINHOLE",
            vec![
                "500", "505", "319.5", "239.5", "-0.2", "0.05", "0.001", "-0.001", "0.01", "0.1", "0.02",
                "0.005", "0.001", "-0.0005", "0.0008", "0.0002",
            ],
            30.0,
            &[Gsplat],
        ),
        Case {
            name: "calibrated_equirectangular",
            projection: "CalibratedCamera",
            params: calibrated("EQUIRECTANGULAR", vec!["640", "480"], "float[2] params"),
            size: (640, 480),
            window: None,
            max_angle: None,
            exact: &[Colmap, Nerfstudio],
        },
        Case {
            name: "calibrated_ftheta",
            projection: "CalibratedCamera",
            params: vec![
                ("string model", vec!["FTHETA"]),
                ("float[3] params", vec!["319.5", "239.5", "1.6"]),
                ("float[4] polynomial", vec!["0", "0.004", "0", "2e-9"]),
                ("int[2] resolution", vec!["640", "480"]),
            ],
            size: (640, 480),
            window: None,
            max_angle: Some(80.0),
            exact: &[Gsplat],
        },
        Case {
            name: "stereographic",
            projection: "Fisheye",
            params: vec![
                ("string mapping", vec!["stereographic"]),
                ("float fov", vec!["170"]),
            ],
            size: (256, 256),
            window: None,
            max_angle: Some(60.0),
            exact: &[],
        },
    ]
}

/// A calibrated camera of `model` at its calibration size, 640 × 480.
fn calibrated_case(
    model: &'static str,
    params: Vec<&'static str>,
    max_angle: f64,
    exact: &'static [ExportFormat],
) -> Case {
    let decl: &'static str = Box::leak(format!("float[{}] params", params.len()).into_boxed_str());
    Case {
        name: model,
        projection: "CalibratedCamera",
        params: vec![
            ("string model", vec![model]),
            (decl, params),
            ("int[2] resolution", vec!["640", "480"]),
        ],
        size: (640, 480),
        window: None,
        max_angle: Some(max_angle),
        exact,
    }
}

/// Camera-to-world of frame `k`: the camera walks and turns.
fn camera_to_world(k: i32) -> DMat4 {
    let k = f64::from(k);
    DMat4::from_translation(DVec3::new(0.3 * k, -0.2 + 0.1 * k, 1.0 - 0.2 * k))
        * DMat4::from_quat(DQuat::from_rotation_y(0.3 + 0.2 * k) * DQuat::from_rotation_x(-0.1 * k))
}

fn scene(case: &Case, frame: i32) -> Scene {
    let mut cam = CameraDesc::new(Format::new(case.size.0, case.size.1));
    cam.screen_window = case.window;
    cam.world_to_camera = vec![MotionSample {
        time: 0.0,
        world_to_camera: Matrix4(camera_to_world(frame).inverse().as_mat4().to_cols_array_2d()),
    }];
    let mut s = Scene::new(cam);
    s.projection = case.projection.into();
    for (decl, values) in &case.params {
        s.projection_params.push_text(decl, values, None).unwrap();
    }
    s
}

/// A deterministic spread of camera-space points (Obscura's axes) within `max_angle` of +Z.
fn camera_points(max_angle: Option<f64>, n: usize) -> Vec<DVec3> {
    (0..n)
        .map(|i| {
            let a = (i as f64 + 0.5) / n as f64;
            let b = (i as f64 * 0.618_033_988_75).fract();
            let dir = match max_angle {
                Some(m) => {
                    let theta = m.to_radians() * a.sqrt();
                    let phi = std::f64::consts::TAU * b;
                    DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
                }
                None => {
                    let az = (2.0 * b - 1.0) * 3.1;
                    let el = (2.0 * a - 1.0) * 1.45;
                    DVec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos())
                }
            };
            dir * (1.0 + 7.0 * b)
        })
        .collect()
}

/// Matrix from the JSON's rows.
fn matrix(v: &Value) -> DMat4 {
    let r: Vec<Vec<f64>> = serde_json::from_value(v.clone()).unwrap();
    DMat4::from_cols_array_2d(&[
        [r[0][0], r[1][0], r[2][0], r[3][0]],
        [r[0][1], r[1][1], r[2][1], r[3][1]],
        [r[0][2], r[1][2], r[2][2], r[3][2]],
        [r[0][3], r[1][3], r[2][3], r[3][3]],
    ])
}

/// One frame written: its camera JSON and, per world point, the render's raster pixel.
struct Rendered {
    camera: Value,
    points: Vec<(DVec3, [f64; 2])>,
}

fn render_frame(case: &Case, frame: i32) -> Rendered {
    let s = scene(case, frame);
    let prepared = prepare(
        &s,
        &mut builtin_registry(),
        Path::new("."),
        &RenderOptions::default(),
    )
    .unwrap();
    let camera = camera_json(&s, &prepared, Some(i64::from(frame))).unwrap();
    let c2w = camera_to_world(frame);
    let stage = prepared.stage();
    let cam = stage.camera();
    let points = camera_points(case.max_angle, 60)
        .into_iter()
        .filter_map(|p| {
            let screen = stage
                .projection()
                .unproject(Vec3::new(p.x as f32, p.y as f32, p.z as f32), 0.0)?;
            let (x, y) = cam.screen_window().screen_to_raster(cam.format, screen);
            Some((c2w.transform_point3(p), [x, y]))
        })
        .collect::<Vec<_>>();
    assert!(
        points.len() > 40,
        "{}: only {} points project",
        case.name,
        points.len()
    );
    Rendered { camera, points }
}

fn assert_close(case: &str, format: &str, got: [f64; 2], want: [f64; 2], world: DVec3) {
    let err = (got[0] - want[0]).abs().max((got[1] - want[1]).abs());
    assert!(
        err <= TOL,
        "{case} {format}: {world} at {got:?}, the render at {want:?} (error {err} px)"
    );
}

// --- the formats' own formulas, written from their sources -----------------------------------

/// COLMAP's `ImgFromCam` for the models the exports use (`src/colmap/sensor/models.h`).
fn colmap_project(model: &str, p: &[f64], x: DVec3) -> Option<[f64; 2]> {
    let fisheye_theta = |x: DVec3| {
        let (u, v) = (x.x / x.z, x.y / x.z);
        let r = u.hypot(v);
        (r.atan(), u, v, r)
    };
    Some(match model {
        "PINHOLE" => [p[0] * x.x / x.z + p[2], p[1] * x.y / x.z + p[3]],
        "OPENCV" | "FULL_OPENCV" => {
            let (u, v) = (x.x / x.z, x.y / x.z);
            let g = |i: usize| p.get(i).copied().unwrap_or(0.0);
            let (k1, k2, p1, p2, k3, k4, k5, k6) = (g(4), g(5), g(6), g(7), g(8), g(9), g(10), g(11));
            let r2 = u * u + v * v;
            let radial = (1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2)
                / (1.0 + k4 * r2 + k5 * r2 * r2 + k6 * r2 * r2 * r2);
            let du = u * radial + 2.0 * p1 * u * v + p2 * (r2 + 2.0 * u * u);
            let dv = v * radial + 2.0 * p2 * u * v + p1 * (r2 + 2.0 * v * v);
            [p[0] * du + p[2], p[1] * dv + p[3]]
        }
        "OPENCV_FISHEYE" => {
            let (theta, u, v, r) = fisheye_theta(x);
            let t2 = theta * theta;
            let td = theta * (1.0 + p[4] * t2 + p[5] * t2 * t2 + p[6] * t2.powi(3) + p[7] * t2.powi(4));
            [p[0] * td * u / r + p[2], p[1] * td * v / r + p[3]]
        }
        "RAD_TAN_THIN_PRISM_FISHEYE" => {
            let (theta, u, v, r) = fisheye_theta(x);
            let t2 = theta * theta;
            let k = &p[4..10];
            let radial = 1.0 + (0..6).map(|i| k[i] * t2.powi(i as i32 + 1)).sum::<f64>();
            let (a, b) = (theta * u / r, theta * v / r);
            let (a, b) = (a * radial, b * radial);
            let (p0, p1) = (p[10], p[11]);
            let s = &p[12..16];
            let r2 = a * a + b * b;
            let du = a + 2.0 * p1 * a * b + p0 * (r2 + 2.0 * a * a) + s[0] * r2 + s[1] * r2 * r2;
            let dv = b + 2.0 * p0 * a * b + p1 * (r2 + 2.0 * b * b) + s[2] * r2 + s[3] * r2 * r2;
            [p[0] * du + p[2], p[1] * dv + p[3]]
        }
        "EQUIRECTANGULAR" => {
            let az = x.x.atan2(x.z);
            let el = (-x.y).atan2(x.x.hypot(x.z));
            [
                p[0] * (az / std::f64::consts::TAU + 0.5),
                p[1] * (0.5 - el / std::f64::consts::PI),
            ]
        }
        // the other models are checked by pycolmap alone
        _ => return None,
    })
}

/// nerfstudio's pixel of a camera-space point in OpenGL axes (the inverse of
/// `Cameras._generate_rays_from_coords`: pixel → `(x − cx)/fl_x, (y − cy)/fl_y` → distort → flip y →
/// ray).
fn nerfstudio_project(t: &Value, f: &Value, x: DVec3) -> [f64; 2] {
    let key = |k: &str| {
        t.get(k)
            .or_else(|| f.get(k))
            .and_then(Value::as_f64)
            .unwrap_or(0.0)
    };
    let (fx, fy, cx, cy) = (key("fl_x"), key("fl_y"), key("cx"), key("cy"));
    let distort = |a: f64, b: f64| {
        // camera_utils._compute_residual_and_jacobian's forward model
        let (k1, k2, k3, k4, p1, p2) = (key("k1"), key("k2"), key("k3"), key("k4"), key("p1"), key("p2"));
        let r = a * a + b * b;
        let d = 1.0 + r * (k1 + r * (k2 + r * (k3 + r * k4)));
        (
            a * d + 2.0 * p1 * a * b + p2 * (r + 2.0 * a * a),
            b * d + 2.0 * p2 * a * b + p1 * (r + 2.0 * b * b),
        )
    };
    match t["camera_model"].as_str().unwrap() {
        "OPENCV" => {
            // direction (a, −b, −1): a = x/−z, b = −y/−z
            let (a, b) = distort(x.x / -x.z, x.y / x.z);
            [fx * a + cx, fy * b + cy]
        }
        "OPENCV_FISHEYE" => {
            // direction (a·sinθ/θ, −b·sinθ/θ, −cosθ) with θ = |(a, b)|
            let rho = x.x.hypot(x.y);
            let theta = rho.atan2(-x.z);
            let (a, b) = distort(theta * x.x / rho, -theta * x.y / rho);
            [fx * a + cx, fy * b + cy]
        }
        "EQUIRECTANGULAR" => {
            // theta = −π·a, phi = π(½ − b'), b' = −b; direction (−sinθ sinφ, cosφ, −cosθ sinφ)
            let d = x.normalize();
            let phi = d.y.acos();
            let theta = (-d.x).atan2(-d.z);
            let a = -theta / std::f64::consts::PI;
            let b = -(0.5 - phi / std::f64::consts::PI);
            [fx * a + cx, fy * b + cy]
        }
        "FISHEYE624" => {
            let dp: Vec<f64> = serde_json::from_value(
                t.get("distortion_params")
                    .or(f.get("distortion_params"))
                    .unwrap()
                    .clone(),
            )
            .unwrap();
            // fisheye624_project: OpenCV axes
            let y = DVec3::new(x.x, -x.y, -x.z);
            let mut p = vec![fx, fy, cx, cy];
            p.extend(dp);
            colmap_project("RAD_TAN_THIN_PRISM_FISHEYE", &p, y).unwrap()
        }
        other => panic!("no formula for {other}"),
    }
}

/// gsplat's projection of a camera-space point (OpenCV axes) (`Cameras.cuh`).
fn gsplat_project(f: &Value, x: DVec3) -> [f64; 2] {
    let k = matrix_3(&f["Ks"]);
    let coeffs = |key: &str, n: usize| -> Vec<f64> {
        f.get(key)
            .map_or(vec![0.0; n], |v| serde_json::from_value(v.clone()).unwrap())
    };
    match f["camera_model"].as_str().unwrap() {
        "pinhole" => {
            let (u, v) = (x.x / x.z, x.y / x.z);
            let rc = coeffs("radial_coeffs", 6);
            let tc = coeffs("tangential_coeffs", 2);
            let sc = coeffs("thin_prism_coeffs", 4);
            let r2 = u * u + v * v;
            let icd = (1.0 + r2 * (rc[0] + r2 * (rc[1] + r2 * rc[2])))
                / (1.0 + r2 * (rc[3] + r2 * (rc[4] + r2 * rc[5])));
            let (a1, a2, a3) = (2.0 * u * v, r2 + 2.0 * u * u, r2 + 2.0 * v * v);
            let dx = tc[0] * a1 + tc[1] * a2 + r2 * (sc[0] + r2 * sc[1]);
            let dy = tc[0] * a3 + tc[1] * a1 + r2 * (sc[2] + r2 * sc[3]);
            [
                k[0][0] * (icd * u + dx) + k[0][2],
                k[1][1] * (icd * v + dy) + k[1][2],
            ]
        }
        "fisheye" => {
            let rc = coeffs("radial_coeffs", 4);
            let rho = x.x.hypot(x.y);
            let th = rho.atan2(x.z);
            let t2 = th * th;
            let d = th * (1.0 + t2 * (rc[0] + t2 * (rc[1] + t2 * (rc[2] + t2 * rc[3]))));
            [
                k[0][0] * d * x.x / rho + k[0][2],
                k[1][1] * d * x.y / rho + k[1][2],
            ]
        }
        "ftheta" => {
            let c = &f["ftheta_coeffs"];
            assert_eq!(c["reference_poly"], "PIXELDIST_TO_ANGLE");
            let bw: Vec<f64> = serde_json::from_value(c["pixeldist_to_angle_poly"].clone()).unwrap();
            let rho = x.x.hypot(x.y);
            let th = rho.atan2(x.z);
            // invert θ = bw(δ) by bisection (a monotonic polynomial over the image)
            let (mut lo, mut hi) = (0.0_f64, 2000.0_f64);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                let val: f64 = bw.iter().enumerate().map(|(i, c)| c * mid.powi(i as i32)).sum();
                if val < th { lo = mid } else { hi = mid }
            }
            let d = 0.5 * (lo + hi);
            [d * x.x / rho + k[0][2], d * x.y / rho + k[1][2]]
        }
        other => panic!("no formula for {other}"),
    }
}

fn matrix_3(v: &Value) -> [[f64; 3]; 3] {
    serde_json::from_value(v.clone()).unwrap()
}

// --- reading the written files ---------------------------------------------------------------

/// `cameras.txt` and `images.txt`: per image name, (model, params, cam_from_world).
fn read_colmap(dir: &Path) -> Vec<(String, String, Vec<f64>, DMat4)> {
    let cams = std::fs::read_to_string(dir.join("cameras.txt")).unwrap();
    let cams: Vec<(u64, String, Vec<f64>)> = cams
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            (
                f[0].parse().unwrap(),
                f[1].to_string(),
                f[4..].iter().map(|x| x.parse().unwrap()).collect(),
            )
        })
        .collect();
    let images = std::fs::read_to_string(dir.join("images.txt")).unwrap();
    images
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            let n: Vec<f64> = f[1..8].iter().map(|x| x.parse().unwrap()).collect();
            let q = DQuat::from_xyzw(n[1], n[2], n[3], n[0]);
            let m = DMat4::from_rotation_translation(q, DVec3::new(n[4], n[5], n[6]));
            let id: u64 = f[8].parse().unwrap();
            let cam = cams.iter().find(|c| c.0 == id).unwrap();
            (f[9].to_string(), cam.1.clone(), cam.2.clone(), m)
        })
        .collect()
}

fn python_has_pycolmap() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import pycolmap"])
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        ok || std::env::var("OBSCURA_REQUIRE_PYCOLMAP").as_deref() != Ok("1"),
        "OBSCURA_REQUIRE_PYCOLMAP=1 but `python3 -c 'import pycolmap'` fails"
    );
    ok
}

/// pycolmap reads `colmap/` and projects every point of `expected` (image name → [(X, pixel)]);
/// returns the largest error in pixels.
const PYCOLMAP_CHECK: &str = r#"
import json, sys
import numpy as np
import pycolmap
rec = pycolmap.Reconstruction(sys.argv[1])
expected = json.load(open(sys.argv[2]))
worst, n = 0.0, 0
for image in rec.images.values():
    cam = rec.cameras[image.camera_id]
    for X, want in expected[image.name]:
        got = cam.img_from_cam(image.cam_from_world() * np.array(X, dtype=float))
        assert got is not None, (image.name, X)
        worst = max(worst, float(np.abs(np.asarray(got) - np.asarray(want)).max()))
        n += 1
assert n == sum(len(v) for v in expected.values()), (n, "points checked")
assert len(rec.images) == len(expected), (len(rec.images), len(expected))
if len(sys.argv) > 3:
    rigs, frames = map(int, sys.argv[3:5])
    assert (len(rec.rigs), len(rec.frames)) == (rigs, frames), (len(rec.rigs), len(rec.frames))
    for rig in rec.rigs.values():
        assert rig.num_sensors() == 2 if callable(rig.num_sensors) else rig.num_sensors == 2
print(worst)
"#;

fn pycolmap_worst(
    colmap: &Path,
    expected: &Value,
    scratch: &Path,
    rigs_frames: Option<(usize, usize)>,
) -> f64 {
    let file = scratch.join("expected.json");
    std::fs::write(&file, expected.to_string()).unwrap();
    let mut cmd = Command::new("python3");
    cmd.arg("-c")
        .arg(PYCOLMAP_CHECK.replace("image.cam_from_world()", CAM_FROM_WORLD))
        .arg(colmap)
        .arg(&file);
    if let Some((r, f)) = rigs_frames {
        cmd.arg(r.to_string()).arg(f.to_string());
    }
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "pycolmap: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).trim().parse().unwrap()
}

/// pycolmap 4 made `Image.cam_from_world` a method; 3.x had a property.
const CAM_FROM_WORLD: &str =
    "(image.cam_from_world() if callable(image.cam_from_world) else image.cam_from_world)";

#[test]
fn every_export_reprojects_like_the_render() {
    let check_pycolmap = python_has_pycolmap();
    for case in cases() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path();
        let rendered: Vec<Rendered> = (0..2).map(|k| render_frame(&case, k)).collect();
        let frames: Vec<ExportFrame> = (rendered.iter().enumerate())
            .map(|(k, r)| ExportFrame {
                frame: k as i32,
                image: PathBuf::from(format!("images/main/{k:04}.exr")),
                camera: r.camera.clone(),
            })
            .collect();
        let cameras = [ExportCamera {
            name: "main".into(),
            frames,
        }];
        let warnings = write_exports(root, &cameras, &ExportFormat::ALL).unwrap();
        let name = case.name;
        // The test's camera transforms are rotations: RenderMan's left-handed world, exported with
        // z negated (and said so).
        assert!(
            warnings.iter().any(|w| w.contains("(x, y, -z)")),
            "{name}: {warnings:?}"
        );
        let s = DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0));
        let rendered: Vec<Rendered> = rendered
            .into_iter()
            .map(|r| Rendered {
                points: r
                    .points
                    .into_iter()
                    .map(|(w, px)| (s.transform_point3(w), px))
                    .collect(),
                camera: r.camera,
            })
            .collect();
        for format in ExportFormat::ALL {
            let warned = warnings
                .iter()
                .any(|w| w.starts_with(&format!("{format}:")) && w.contains("not exported"));
            assert_eq!(
                warned,
                !case.exact.contains(&format),
                "{name} {format}: warnings {warnings:?}"
            );
            if warned {
                assert!(
                    warnings.iter().any(|w| w.contains("obscura rays")),
                    "{name}: {warnings:?}"
                );
            }
        }

        // COLMAP, read back with its formulas and with pycolmap
        let images = read_colmap(&root.join("colmap"));
        if case.exact.contains(&Colmap) {
            assert_eq!(images.len(), 2, "{name}");
            let mut expected = serde_json::Map::new();
            for (k, r) in rendered.iter().enumerate() {
                let (image, model, params, cam_from_world) = &images[k];
                let mut list = Vec::new();
                for &(world, want) in &r.points {
                    let x = cam_from_world.transform_point3(world);
                    if model.contains("FISHEYE") && x.z <= 0.0 {
                        continue; // COLMAP's fisheyes stop at 90° (the file says so)
                    }
                    if let Some(got) = colmap_project(model, params, x) {
                        assert_close(name, "colmap", got, want, world);
                    }
                    list.push(json!([world.to_array(), want]));
                }
                expected.insert(image.clone(), Value::Array(list));
            }
            if check_pycolmap {
                let worst = pycolmap_worst(&root.join("colmap"), &Value::Object(expected), root, None);
                assert!(
                    worst <= TOL,
                    "{name}: pycolmap reprojects {worst} px from the render"
                );
                eprintln!("{name}: pycolmap within {worst:.2e} px");
            }
        } else {
            assert!(images.is_empty());
            let text = std::fs::read_to_string(root.join("colmap/cameras.txt")).unwrap();
            assert!(text.contains("# World:") && text.contains("(x, y, -z)"), "{text}");
            assert!(
                text.contains("no exact COLMAP camera model") && text.contains("obscura rays"),
                "{text}"
            );
        }

        // nerfstudio: transforms.json with nerfstudio's ray conventions
        let t: Value =
            serde_json::from_str(&std::fs::read_to_string(root.join("transforms.json")).unwrap()).unwrap();
        if case.exact.contains(&Nerfstudio) {
            let frames = t["frames"].as_array().unwrap();
            assert_eq!(frames.len(), 2);
            for (f, r) in frames.iter().zip(&rendered) {
                let w2c = matrix(&f["transform_matrix"]).inverse();
                for &(world, want) in &r.points {
                    let x = w2c.transform_point3(world);
                    assert_close(name, "nerfstudio", nerfstudio_project(&t, f, x), want, world);
                }
            }
        } else {
            assert!(
                t["camera_model"].is_null() && t["reason"].as_str().unwrap().contains("obscura rays"),
                "{t}"
            );
        }

        // gsplat: the rasterizer's camera models
        let g: Value =
            serde_json::from_str(&std::fs::read_to_string(root.join("gsplat/cameras.json")).unwrap())
                .unwrap();
        let frames = g["cameras"][0]["frames"].as_array().unwrap();
        for (f, r) in frames.iter().zip(&rendered) {
            if !case.exact.contains(&Gsplat) {
                assert!(
                    f["camera_model"].is_null() && f["reason"].as_str().unwrap().contains("obscura rays"),
                    "{f}"
                );
                continue;
            }
            assert_eq!(f["rolling_shutter"], "GLOBAL");
            let view = matrix(&f["viewmats"]);
            for &(world, want) in &r.points {
                let x = view * DVec4::from((world, 1.0));
                if x.z <= 0.0 && f["camera_model"] != "ftheta" {
                    continue;
                }
                assert_close(name, "gsplat", gsplat_project(f, x.truncate()), want, world);
            }
        }
    }
}

/// A rigid two-camera rig (a pinhole and a 180° fisheye beside it) over three frames: one COLMAP rig
/// of two sensors and three frames (`rigs.txt`, `frames.txt`) that pycolmap turns back into every
/// image's pose, and one nerfstudio `transforms.json` per camera.
#[test]
fn a_rigid_rig_is_one_colmap_rig_and_one_transforms_json_per_camera() {
    let check_pycolmap = python_has_pycolmap();
    let all = cases();
    let left = all.iter().find(|c| c.name == "perspective").unwrap();
    let right = all.iter().find(|c| c.name == "fisheye200").unwrap();
    let offset = DMat4::from_translation(DVec3::new(0.12, 0.0, 0.01)) * DMat4::from_rotation_y(0.25);
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let mut cameras = Vec::new();
    let mut expected = serde_json::Map::new();
    let s = DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0));
    for (name, case, rig) in [("left", left, DMat4::IDENTITY), ("right", right, offset)] {
        let mut frames = Vec::new();
        for k in 0..3 {
            let mut sc = scene(case, k);
            let c2w = camera_to_world(k) * rig;
            sc.camera.world_to_camera[0].world_to_camera =
                Matrix4(c2w.inverse().as_mat4().to_cols_array_2d());
            let prepared = prepare(
                &sc,
                &mut builtin_registry(),
                Path::new("."),
                &RenderOptions::default(),
            )
            .unwrap();
            let camera = camera_json(&sc, &prepared, Some(i64::from(k))).unwrap();
            let image = format!("images/{name}/{k:04}.exr");
            let stage = prepared.stage();
            let list: Vec<Value> = camera_points(Some(60.0), 20)
                .into_iter()
                .filter_map(|p| {
                    let screen = stage
                        .projection()
                        .unproject(Vec3::new(p.x as f32, p.y as f32, p.z as f32), 0.0)?;
                    let (x, y) = stage
                        .camera()
                        .screen_window()
                        .screen_to_raster(stage.camera().format, screen);
                    Some(json!([
                        s.transform_point3(c2w.transform_point3(p)).to_array(),
                        [x, y]
                    ]))
                })
                .collect();
            expected.insert(image.clone(), Value::Array(list));
            frames.push(ExportFrame {
                frame: k,
                image: image.into(),
                camera,
            });
        }
        cameras.push(ExportCamera {
            name: name.into(),
            frames,
        });
    }
    write_exports(root, &cameras, &[Colmap, Nerfstudio]).unwrap();
    let rigs = std::fs::read_to_string(root.join("colmap/rigs.txt")).unwrap();
    assert!(
        rigs.contains("# Number of rigs: 1") && rigs.contains("\n1 2 CAMERA 1 CAMERA 2 1 "),
        "{rigs}"
    );
    let frames = std::fs::read_to_string(root.join("colmap/frames.txt")).unwrap();
    assert!(frames.contains("# Number of frames: 3"), "{frames}");
    if check_pycolmap {
        let worst = pycolmap_worst(&root.join("colmap"), &Value::Object(expected), root, Some((1, 3)));
        assert!(
            worst <= TOL,
            "rig: pycolmap reprojects {worst} px from the render"
        );
    }
    for name in ["left", "right"] {
        let t: Value = serde_json::from_str(
            &std::fs::read_to_string(root.join(format!("nerfstudio/{name}/transforms.json"))).unwrap(),
        )
        .unwrap();
        assert_eq!(
            t["frames"][2]["file_path"],
            format!("../../images/{name}/0002.exr")
        );
    }
    assert!(!root.join("transforms.json").exists());
}

/// A rolling shutter: gsplat's pose of row `i` (`viewmats` to `viewmats_rs` at `i/(H − 1)`, lerp and
/// slerp) is the render's camera at the centre of that row's exposure, so a point seen through that
/// row's pose lands on the same pixel.
#[test]
fn a_rolling_shutter_gives_gsplat_the_pose_of_every_row() {
    for duration in ["0", "0.3"] {
        let (w, h) = (96_u32, 64_u32);
        let mut cam = CameraDesc::new(Format::new(w, h));
        cam.shutter = (0.0, 1.0);
        let open = camera_to_world(0);
        let close = camera_to_world(1);
        cam.world_to_camera = [(0.0, open), (1.0, close)]
            .iter()
            .map(|(t, m)| MotionSample {
                time: *t,
                world_to_camera: Matrix4(m.inverse().as_mat4().to_cols_array_2d()),
            })
            .collect();
        let mut sc = Scene::new(cam);
        sc.projection = "PxrRollingShutter".into();
        for (decl, values) in [
            ("float fov", &["55"][..]),
            ("string sweep", &["down"]),
            ("float duration", &[duration]),
        ] {
            sc.projection_params.push_text(decl, values, None).unwrap();
        }
        let prepared = prepare(
            &sc,
            &mut builtin_registry(),
            Path::new("."),
            &RenderOptions::default(),
        )
        .unwrap();
        let camera = camera_json(&sc, &prepared, Some(0)).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let cameras = [ExportCamera {
            name: "rs".into(),
            frames: vec![ExportFrame {
                frame: 0,
                image: "images/rs/0000.exr".into(),
                camera: camera.clone(),
            }],
        }];
        let warnings = write_exports(dir.path(), &cameras, &[Gsplat]).unwrap();
        assert!(
            !warnings.iter().any(|w| w.contains("moves during")),
            "{warnings:?}"
        );
        let g: Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("gsplat/cameras.json")).unwrap())
                .unwrap();
        let f = &g["cameras"][0]["frames"][0];
        assert_eq!(f["rolling_shutter"], "ROLLING_TOP_TO_BOTTOM");
        let (v0, v1) = (matrix(&f["viewmats"]), matrix(&f["viewmats_rs"]));
        let d: f64 = duration.parse().unwrap();
        let s = DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0));
        let stage = prepared.stage();
        for row in [0_u32, 17, 40, h - 1] {
            // gsplat: t = row/(H − 1), camera-to-world interpolated by lerp and slerp
            let t = f64::from(row) / f64::from(h - 1);
            let (_, r0, t0) = v0.inverse().to_scale_rotation_translation();
            let (_, r1, t1) = v1.inverse().to_scale_rotation_translation();
            let view = DMat4::from_rotation_translation(r0.slerp(r1, t), t0.lerp(t1, t)).inverse();
            // the render: the row's exposure centre
            let time = (f64::from(row) + 0.5) / f64::from(h) * (1.0 - d) + d / 2.0;
            let motion =
                obscura_geometry::motion::camera_motion(stage.environment().world_to_camera(), (0.0, 1.0))
                    .unwrap();
            let w2c = glam::Mat4::from(motion.object_to_world(time as f32).inverse()).as_dmat4();
            for p in camera_points(Some(20.0), 12) {
                let world = w2c.inverse().transform_point3(p);
                let screen = stage
                    .projection()
                    .unproject(Vec3::new(p.x as f32, p.y as f32, p.z as f32), time as f32)
                    .unwrap();
                let (x, y) = stage
                    .camera()
                    .screen_window()
                    .screen_to_raster(stage.camera().format, screen);
                let xc = view * DVec4::from((s.transform_point3(world), 1.0));
                let got = gsplat_project(f, xc.truncate());
                let err = (got[0] - x).abs().max((got[1] - y).abs());
                assert!(
                    err < 2e-3,
                    "duration {duration} row {row}: gsplat {got:?}, render ({x}, {y}), error {err}"
                );
            }
        }
    }
}

/// nerfstudio's ray of pixel `(x, y)` of an `OMNIDIRECTIONALSTEREO_L/R` camera, in OpenGL camera
/// axes (`cameras.py`, `_compute_rays_for_omnidirectional_stereo`: equirectangular directions,
/// origins `σ·(0.064/2)·(x_axis·cos θ + z_axis·sin θ)` with `z_axis = (0, 0, −1)`, σ = +1 right).
fn nerfstudio_ods_ray(t: &Value, x: f64, y: f64) -> (DVec3, DVec3) {
    let key = |k: &str| t[k].as_f64().unwrap();
    let a = (x - key("cx")) / key("fl_x");
    let b = -(y - key("cy")) / key("fl_y");
    let theta = -std::f64::consts::PI * a;
    let phi = std::f64::consts::PI * (0.5 - b);
    let dir = DVec3::new(-theta.sin() * phi.sin(), phi.cos(), -theta.cos() * phi.sin());
    let sigma = if t["camera_model"] == "OMNIDIRECTIONALSTEREO_R" {
        1.0
    } else {
        -1.0
    };
    let origin = sigma * 0.032 * (DVec3::X * theta.cos() + DVec3::NEG_Z * theta.sin());
    (origin, dir)
}

/// Both eyes of an omnidirectional-stereo panorama with nerfstudio's geometry (IPD 0.064 m, parallel,
/// no pole merging) export as OMNIDIRECTIONALSTEREO_L/R: nerfstudio's ray of the pixel the render puts
/// a point at passes through that point (to 1e-3 px of angle); the centre eye is EQUIRECTANGULAR;
/// the default eye (IPD 0.0635, merged poles) has no equivalent, said in the file.
#[test]
fn omnidirectional_stereo_eyes_are_nerfstudio_ods_cameras() {
    for (eye, ipd, merge, model) in [
        ("left", "0.064", "90", Some("OMNIDIRECTIONALSTEREO_L")),
        ("right", "0.064", "90", Some("OMNIDIRECTIONALSTEREO_R")),
        ("center", "0.064", "60", Some("EQUIRECTANGULAR")),
        ("left", "0.0635", "60", None),
    ] {
        let case = Case {
            name: "ods",
            projection: "OmnidirectionalStereo",
            params: vec![
                ("string eye", vec![eye]),
                ("float interpupilaryDistance", vec![ipd]),
                ("float poleMergeFrom", vec![merge]),
                ("float poleMergeTo", vec![merge]),
            ],
            size: (512, 256),
            window: None,
            max_angle: None,
            exact: &[],
        };
        let r = render_frame(&case, 1);
        let dir = tempfile::tempdir().unwrap();
        let cameras = [ExportCamera {
            name: "eye".into(),
            frames: vec![ExportFrame {
                frame: 1,
                image: "images/eye/0001.exr".into(),
                camera: r.camera.clone(),
            }],
        }];
        let warnings = write_exports(dir.path(), &cameras, &[Nerfstudio]).unwrap();
        let t: Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("transforms.json")).unwrap())
                .unwrap();
        let Some(model) = model else {
            assert!(
                t["camera_model"].is_null() && t["reason"].as_str().unwrap().contains("0.064"),
                "{t}"
            );
            assert!(
                warnings
                    .iter()
                    .any(|w| w.contains("nerfstudio") && w.contains("obscura rays"))
            );
            continue;
        };
        assert_eq!(t["camera_model"], model);
        let c2w = matrix(&t["frames"][0]["transform_matrix"]);
        let s = DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0));
        let rad_per_px = std::f64::consts::PI / t["fl_x"].as_f64().unwrap();
        for &(world, [x, y]) in &r.points {
            let (origin, direction) = if model == "EQUIRECTANGULAR" {
                let (_, d) = nerfstudio_ods_ray(
                    &json!({"camera_model": "", "cx": t["cx"], "cy": t["cy"], "fl_x": t["fl_x"], "fl_y": t["fl_y"]}),
                    x,
                    y,
                );
                (DVec3::ZERO, d)
            } else {
                nerfstudio_ods_ray(&t, x, y)
            };
            let to_point = s.transform_point3(world) - c2w.transform_point3(origin);
            let angle = to_point.angle_between(c2w.transform_vector3(direction));
            assert!(
                angle < 1e-3 * rad_per_px,
                "{eye}: {world} is {} px off nerfstudio's ray",
                angle / rad_per_px
            );
        }
    }
}
