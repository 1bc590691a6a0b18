use std::path::Path;

use glam::{DMat4, DVec3, DVec4};
use obscura_host::CameraDesc;
use obscura_plugins::builtin_registry;
use obscura_sdk::{Format, Matrix4, MotionSample, Vec3};

use super::*;
use crate::render::{Prepared, RenderOptions, prepare};

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

/// A scene through `projection` with a camera that moves from `open` to `close` (camera-to-world).
fn scene(projection: &str, params: &[(&str, &[&str])], format: Format) -> Scene {
    let mut cam = CameraDesc::new(format);
    cam.shutter = (0.0, 1.0);
    let open = DMat4::from_translation(DVec3::new(0.5, -0.2, 1.0)) * DMat4::from_rotation_y(0.3);
    let close = DMat4::from_translation(DVec3::new(0.7, -0.2, 1.0)) * DMat4::from_rotation_y(0.35);
    cam.world_to_camera = [(0.0, open), (1.0, close)]
        .iter()
        .map(|(t, m)| MotionSample {
            time: *t,
            world_to_camera: Matrix4(m.inverse().as_mat4().to_cols_array_2d()),
        })
        .collect();
    let mut s = Scene::new(cam);
    s.projection = projection.into();
    for (decl, values) in params {
        s.projection_params.push_text(decl, values, None).unwrap();
    }
    s
}

fn matrix(v: &Value) -> DMat4 {
    let r: Vec<Vec<f64>> = serde_json::from_value(v.clone()).unwrap();
    DMat4::from_cols_array_2d(&[
        [r[0][0], r[1][0], r[2][0], r[3][0]],
        [r[0][1], r[1][1], r[2][1], r[3][1]],
        [r[0][2], r[1][2], r[2][2], r[3][2]],
        [r[0][3], r[1][3], r[2][3], r[3][3]],
    ])
}

/// Projects `world` with the JSON's OpenCV camera (K, dist as OpenCV's k1 k2 p1 p2 k3, the OpenCV
/// world-to-camera at `when`): the pixel OpenCV's `projectPoints` would give.
fn opencv_project(j: &Value, world: DVec3, when: &str) -> (f64, f64) {
    let m = matrix(&j["opencv"]["world_to_camera"][when]);
    let p = m * DVec4::new(world.x, world.y, world.z, 1.0);
    let (x, y) = (p.x / p.z, p.y / p.z);
    let k: Vec<f64> = serde_json::from_value(j["opencv"]["dist"].clone()).unwrap();
    let k = |i: usize| k.get(i).copied().unwrap_or(0.0);
    let r2 = x * x + y * y;
    let radial = 1.0 + k(0) * r2 + k(1) * r2 * r2 + k(4) * r2 * r2 * r2;
    let xd = x * radial + 2.0 * k(2) * x * y + k(3) * (r2 + 2.0 * x * x);
    let yd = y * radial + k(2) * (r2 + 2.0 * y * y) + 2.0 * k(3) * x * y;
    let kk: Vec<Vec<f64>> = serde_json::from_value(j["opencv"]["K"].clone()).unwrap();
    (kk[0][0] * xd + kk[0][2], kk[1][1] * yd + kk[1][2])
}

/// Where the projection itself sees `world` at `time`, in OpenCV's pixel convention (raster − ½).
fn renderer_sees(prepared: &Prepared, j: &Value, world: DVec3, when: &str, time: f32) -> (f64, f64) {
    let m = matrix(&j["world_to_camera"][when]);
    let p = m * DVec4::new(world.x, world.y, world.z, 1.0);
    let s = (prepared.stage().projection())
        .unproject(Vec3::new(p.x as f32, p.y as f32, p.z as f32), time)
        .unwrap();
    let cam = prepared.stage().camera();
    let (x, y) = cam.screen_window().screen_to_raster(cam.format, s);
    (x - 0.5, y - 0.5)
}

fn reprojects(projection: &str, params: &[(&str, &[&str])], format: Format) -> Value {
    let s = scene(projection, params, format);
    let prepared = prepared(&s);
    let j = camera_json(&s, &prepared, Some(7)).unwrap();
    assert_eq!(j["schema"], SCHEMA);
    assert_eq!(j["frame"], 7);
    for (when, time) in [("open", 0.0), ("close", 1.0)] {
        for world in [
            DVec3::new(0.4, 0.1, 4.0),
            DVec3::new(-0.3, -0.4, 3.0),
            DVec3::new(1.2, 0.5, 6.0),
        ] {
            let want = renderer_sees(&prepared, &j, world, when, time);
            let got = opencv_project(&j, world, when);
            assert!(
                (got.0 - want.0).abs() < 2e-3 && (got.1 - want.1).abs() < 2e-3,
                "{projection} {when} {world}: OpenCV {got:?}, renderer {want:?}"
            );
        }
    }
    j
}

#[test]
fn opencv_intrinsics_of_a_pinhole_reproject_as_the_renderer_sees() {
    let j = reprojects("PxrPerspective", &[("float fov", &["50"])], Format::new(64, 48));
    assert_eq!(j["colmap"]["model"], "PINHOLE");
    let k = &j["opencv"]["K"];
    let p = &j["colmap"]["params"];
    assert_eq!(p[0], k[0][0]);
    assert!((p[2].as_f64().unwrap() - k[0][2].as_f64().unwrap() - 0.5).abs() < 1e-12);
    assert_eq!(j["parameters"]["fov"][0], 50.0);
    assert_eq!(j["image"]["width"], 64);
}

#[test]
fn a_calibrated_opencv_camera_keeps_its_model_and_reprojects_at_another_size() {
    let k = ["700", "720", "320", "240", "-0.1", "0.02", "0.001", "-0.002"];
    let params = [
        ("string model", &["OPENCV"][..]),
        ("float[8] params", &k[..]),
        ("int[2] resolution", &["640", "480"][..]),
    ];
    let j = reprojects("CalibratedCamera", &params, Format::new(640, 480));
    assert_eq!(j["colmap"]["model"], "OPENCV");
    assert_eq!(j["colmap"]["params"][2], 320.0);
    assert_eq!(j["opencv"]["K"][0][2], 319.5);
    let j = reprojects("CalibratedCamera", &params, Format::new(320, 240));
    assert_eq!(j["colmap"]["params"][0], 350.0);
}

#[test]
fn a_projection_without_a_pinhole_equivalent_has_no_intrinsics() {
    let s = scene("Fisheye", &[], Format::new(32, 32));
    let prepared = prepared(&s);
    let j = camera_json(&s, &prepared, None).unwrap();
    assert!(j.get("opencv").is_none() && j.get("colmap").is_none());
    assert_eq!(j["deep_metric"], "RayLength");
    assert_eq!(j["frame"], Value::Null);
    assert_eq!(j["clipping"][1], Value::Null);
}

/// Every calibration model at every parameter count gives an `equivalents` section (an exact model or
/// a reason) without panicking, whatever its parameter values.
#[test]
fn every_calibration_model_has_an_equivalents_answer() {
    for info in obscura_calibration::models::MODELS.iter() {
        for &n in info.counts {
            for value in ["0", "0.5", "-3", "1e30"] {
                let values: Vec<&str> = vec![value; n];
                let decl = format!("float[{n}] params");
                let s = scene(
                    "CalibratedCamera",
                    &[
                        ("string model", &[info.name]),
                        (&decl, &values),
                        ("int[2] resolution", &["640", "480"]),
                    ],
                    Format::new(320, 240),
                );
                let (model, eq) = equivalents::sections(&s, Some(60.0));
                assert_eq!(model["projection"], "CalibratedCamera");
                for format in ["colmap", "opencv", "gsplat"] {
                    let e = &eq[format];
                    assert!(
                        e["model"].is_string()
                            || e["reason"].as_str().is_some_and(|r| r.contains("obscura rays")),
                        "{} {format}: {e}",
                        info.name
                    );
                }
                let e = &eq["nerfstudio"];
                assert!(
                    e["camera_model"].is_string() || e["reason"].is_string(),
                    "{}: {e}",
                    info.name
                );
            }
        }
    }
}

/// A projection with no closed form says so in every format, pointing to `obscura rays`.
#[test]
fn a_projection_without_a_closed_form_says_so_in_every_format() {
    let s = scene("PxrCylinderCamera", &[], Format::new(64, 32));
    let j = camera_json(&s, &prepared(&s), None).unwrap();
    assert!(j["camera_model"]["lens"].is_null());
    for format in ["colmap", "opencv", "nerfstudio", "gsplat"] {
        let reason = j["equivalents"][format]["reason"].as_str().unwrap();
        assert!(
            reason.contains("PxrCylinderCamera") && reason.contains("obscura rays"),
            "{reason}"
        );
    }
}

/// An overscanned render's camera JSON, placed on its plate, states the plate as its image, the
/// overscanned box as its data window and the plate's screen window; the margins' screen window
/// comes back from the plate's through `Overscan::screen_window`.
#[test]
fn an_overscanned_camera_json_states_the_plate_and_its_data_window() {
    use obscura_image::tiles::Overscan;
    let o = Overscan {
        left: 7,
        top: 3,
        right: 5,
        bottom: 11,
    };
    let (w, h) = (64, 36);
    let plate = [-16.0 / 9.0, 16.0 / 9.0, -1.0, 1.0];
    let rendered = o.screen_window(plate, w, h);
    let (rw, rh) = o.render_size(w, h);
    let text = serde_json::to_string_pretty(&json!({
        "schema": SCHEMA,
        "image": {"width": rw, "height": rh, "pixel_aspect": 1.0,
                  "screen_window": rendered, "data_window": [0, 0, rw, rh]},
        "shutter": [0.0, 1.0],
    }))
    .unwrap()
        + "\n";
    let out = with_overscan(&text, o, w, h).unwrap();
    assert!(
        out.ends_with("}\n") && out.contains("\n  "),
        "stays pretty: {out}"
    );
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["image"]["width"], 64);
    assert_eq!(v["image"]["height"], 36);
    assert_eq!(v["image"]["data_window"], json!([-7, -3, 69, 47]));
    assert_eq!(v["image"]["overscan"], json!([7, 3, 5, 11]));
    assert_eq!(v["shutter"], json!([0.0, 1.0]));
    let win: Vec<f64> = (v["image"]["screen_window"].as_array().unwrap().iter())
        .map(|x| x.as_f64().unwrap())
        .collect();
    for (got, want) in win.iter().zip(plate) {
        assert!((got - want).abs() < 1e-12, "{win:?} vs {plate:?}");
    }
    // Compact stays compact; a JSON of another size is not rewritten.
    let compact = serde_json::to_string(&serde_json::from_str::<Value>(&text).unwrap()).unwrap();
    assert!(!with_overscan(&compact, o, w, h).unwrap().contains('\n'));
    assert_eq!(with_overscan(&compact, o, w + 1, h), None);
}
