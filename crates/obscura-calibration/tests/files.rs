//! Calibration files in: each format read from a small hand-written fixture (values typed from the
//! fixture, not from the reader), the parameter lists they become, and the errors malformed files get.

use std::path::PathBuf;

use obscura_calibration::files::{
    Calibration, CalibrationFileError, FileFormat, PixelConvention, colmap, load, parse, parse_as,
};
use obscura_sdk::{ParamType, ParamValue};
use proptest::prelude::*;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

fn values(c: &Calibration) -> Vec<f64> {
    c.params.iter().map(|n| n.value).collect()
}

fn texts(c: &Calibration) -> Vec<&str> {
    c.params.iter().map(|n| n.text.as_str()).collect()
}

fn error(text: &str, file: &str, camera: Option<&str>) -> CalibrationFileError {
    match parse(text, file, camera) {
        Ok(c) => panic!("{file} should not load, got {c:?}"),
        Err(e) => e,
    }
}

/// The error names `file:line` and says each of `words`.
fn assert_error(e: &CalibrationFileError, file: &str, line: usize, words: &[&str]) {
    let text = e.to_string();
    assert!(
        text.starts_with(&format!("{file}:{line}: ")),
        "expected {file}:{line}, got: {text}"
    );
    for w in words {
        assert!(text.contains(w), "expected \"{w}\" in: {text}");
    }
}

/// The EuRoC MAV dataset's cam0 (fx fy cx cy k1 k2 p1 p2) as the COLMAP, ROS and Kalibr fixtures
/// write it.
const EUROC_CAM0: [f64; 8] = [
    458.654,
    457.296,
    367.215,
    248.375,
    -0.28340811,
    0.07395907,
    0.00019359,
    1.76187114e-05,
];

// ----- COLMAP -------------------------------------------------------------------------------------

#[test]
fn colmap_takes_the_first_camera_and_says_which() {
    let path = fixture("cameras.txt");
    let c = load(&path, None).unwrap();
    assert_eq!(c.format, FileFormat::Colmap);
    assert_eq!(c.camera.as_deref(), Some("1"));
    assert_eq!(c.cameras, ["1", "2", "3", "7"]);
    assert!(c.first_by_default);
    let note = c.selection_note().unwrap();
    assert!(
        note.contains("4 cameras (1, 2, 3, 7)") && note.contains("--camera"),
        "{note}"
    );
    assert_eq!(c.model, "OPENCV");
    assert_eq!((c.width, c.height), (752, 480));
    assert_eq!(values(&c), EUROC_CAM0);
    assert_eq!(texts(&c)[7], "1.76187114e-05");
    assert_eq!(c.pixel_convention, PixelConvention::Colmap);
    assert_eq!(c.source, format!("{}:4", path.display()));
}

#[test]
fn colmap_cameras_are_chosen_by_id_past_blank_lines_and_comments() {
    let path = fixture("cameras.txt");
    let c = load(&path, Some("3")).unwrap();
    assert!(!c.first_by_default && c.selection_note().is_none());
    assert_eq!(c.model, "OPENCV_FISHEYE");
    assert_eq!((c.width, c.height), (1280, 1024));
    assert_eq!(
        values(&c),
        [380.81, 380.81, 639.5, 511.5, 0.0183, -0.0043, 0.0012, -0.0002]
    );
    assert_eq!(c.source, format!("{}:8", path.display()));
    let c = load(&path, Some("2")).unwrap();
    assert_eq!(c.model, "SIMPLE_RADIAL");
    assert_eq!(values(&c), [1384.2130466, 800.0, 600.0, -0.013218]);
    let c = load(&path, Some("7")).unwrap();
    assert_eq!(c.model, "EUCM");
    assert_eq!(values(&c), [157.0, 157.0, 254.9, 256.9, 0.6, 1.1]);
}

#[test]
fn colmap_unknown_camera_lists_the_ids() {
    let e = load(&fixture("cameras.txt"), Some("5")).unwrap_err();
    assert!(e.line.is_none());
    assert!(
        e.message.contains("no camera \"5\"") && e.message.contains("1, 2, 3, 7"),
        "{e}"
    );
    assert!(e.file.ends_with("cameras.txt"));
}

#[test]
fn colmap_errors_name_the_line_and_field() {
    let head = "# Camera list\n# CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
    let e = error(
        &format!("{head}1 PINHOLE 640 480 500 500 320 240\n2 OPENCV 640 480 1 2 3 4 5 6 7\n"),
        "cams.txt",
        None,
    );
    assert_error(
        &e,
        "cams.txt",
        4,
        &[
            "OPENCV takes 8 parameters",
            "fx, fy, cx, cy, k1, k2, p1, p2",
            "got 7",
        ],
    );
    let e = error(
        &format!("{head}1 OPENCV_FISHEY 640 480 1 2 3 4 5 6 7 8\n"),
        "c.txt",
        None,
    );
    assert_error(
        &e,
        "c.txt",
        3,
        &["MODEL", "did you mean OPENCV_FISHEYE", "EQUIRECTANGULAR"],
    );
    let e = error(&format!("{head}1 PINHOLE 640 -480 1 2 3 4\n"), "c.txt", None);
    assert_error(&e, "c.txt", 3, &["HEIGHT", "positive whole number", "\"-480\""]);
    let e = error(&format!("{head}1 PINHOLE 640 480 1 2 x 4\n"), "c.txt", None);
    assert_error(&e, "c.txt", 3, &["PARAMS cx", "\"x\""]);
    let e = error(
        &format!("{head}1 PINHOLE 640 480 1 2 3 4\n\n01 PINHOLE 640 480 1 2 3 4\n"),
        "c.txt",
        None,
    );
    assert_error(&e, "c.txt", 5, &["CAMERA_ID 01 is given twice", "line 3"]);
    let e = error(&format!("{head}1 PINHOLE 640\n"), "c.txt", None);
    assert_error(
        &e,
        "c.txt",
        3,
        &["CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]", "3 columns"],
    );
    let e = error(head, "c.txt", None);
    assert!(e.to_string().contains("no camera"), "{e}");
}

#[test]
fn colmap_model_table_is_colmaps() {
    // Parameter counts of COLMAP's models, ids 0..17 (peer-camera-models.md §8.1).
    let counts = [3, 4, 4, 5, 8, 8, 12, 5, 4, 5, 12, 16, 4, 5, 3, 4, 6, 2];
    for ((name, params), n) in colmap::MODELS.iter().zip(counts) {
        assert_eq!(params.len(), n, "{name}");
    }
    assert_eq!(colmap::MODELS[16].0, "EUCM");
    assert_eq!(
        colmap::model_params("EUCM").unwrap(),
        ["fx", "fy", "cx", "cy", "alpha", "beta"]
    );
}

fn model_and_values() -> impl Strategy<Value = (usize, Vec<f64>)> {
    (0..colmap::MODELS.len()).prop_flat_map(|m| {
        let n = colmap::MODELS[m].1.len();
        (Just(m), prop::collection::vec(-1.0e6f64..1.0e6, n))
    })
}

proptest! {
    /// Any COLMAP line written with Rust's shortest round-trip formatting reads back bit for bit, in
    /// order; one parameter fewer is an error on that line.
    #[test]
    fn colmap_lines_read_back_exactly((m, vals) in model_and_values(), id in 0u32..100_000,
                                       w in 1u32..20_000, h in 1u32..20_000, blank in 0usize..3) {
        let (name, _) = colmap::MODELS[m];
        let params: Vec<String> = vals.iter().map(|v| format!("{v}")).collect();
        let text = format!("# header\n{}{id} {name} {w} {h} {}\n", "\n".repeat(blank), params.join(" "));
        let c = parse(&text, "p.txt", None).unwrap();
        prop_assert_eq!(&c.model, name);
        prop_assert_eq!((c.width, c.height), (w, h));
        prop_assert_eq!(values(&c), vals.clone());
        prop_assert_eq!(c.camera.clone(), Some(id.to_string()));
        let short = format!("{id} {name} {w} {h} {}\n", params[..params.len() - 1].join(" "));
        let e = parse_as(FileFormat::Colmap, &short, "p.txt", None).unwrap_err();
        prop_assert_eq!(e.line, Some(1));
    }
}

// ----- OpenCV -------------------------------------------------------------------------------------

/// fx fy cx cy k1 k2 p1 p2 k3 as the fixtures write them (more digits than an f64 holds).
#[allow(clippy::excessive_precision)]
const OPENCV_K_D: [f64; 9] = [
    5.3591573396163199e+02,
    5.3591573396163199e+02,
    3.4228315473308373e+02,
    2.3557082909788173e+02,
    -2.6637260909660682e-01,
    -3.8588898922304653e-02,
    1.7831947042852964e-03,
    -2.8122100441115472e-04,
    2.3839153080878486e-01,
];

#[test]
fn opencv_yaml_as_the_calibration_sample_writes_it() {
    let path = fixture("opencv_calibration.yml");
    let c = load(&path, None).unwrap();
    assert_eq!(c.format, FileFormat::OpenCv);
    assert_eq!(c.model, "OPENCV_PINHOLE");
    assert_eq!((c.width, c.height), (640, 480));
    assert_eq!(values(&c), OPENCV_K_D);
    assert_eq!(texts(&c)[0], "5.3591573396163199e+02");
    assert_eq!(c.params[4].line, 22, "k1 is on line 22");
    assert_eq!(c.pixel_convention, PixelConvention::OpenCv);
    assert_eq!(c.camera, None);
    assert_eq!(c.source, format!("{}:12", path.display()));
}

#[test]
fn opencv_json_reads_as_the_yaml_does() {
    let yaml = load(&fixture("opencv_calibration.yml"), None).unwrap();
    let json = load(&fixture("opencv_calibration.json"), None).unwrap();
    assert_eq!(json.format, FileFormat::OpenCv);
    assert_eq!(json.model, yaml.model);
    assert_eq!((json.width, json.height), (yaml.width, yaml.height));
    assert_eq!(values(&json), values(&yaml));
    assert_eq!(json.params[0].line, 15);
}

fn opencv_text(dist: &str, extra: &str) -> String {
    format!(
        "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n{extra}camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 500., 0., 320., 0., 501., 240., 0., 0., 1. ]\n\
         distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: {n}\n   dt: d\n   data: [ {dist} ]\n",
        n = dist.split(',').filter(|s| !s.trim().is_empty()).count()
    )
}

#[test]
fn opencv_coefficient_counts_choose_the_model() {
    let coeffs = |n: usize| {
        (1..=n)
            .map(|i| format!("{}e-3", i))
            .collect::<Vec<_>>()
            .join(", ")
    };
    for n in [4, 5, 8, 12, 14] {
        let c = parse(&opencv_text(&coeffs(n), ""), "c.yml", None).unwrap();
        assert_eq!(c.model, "OPENCV_PINHOLE", "{n}");
        assert_eq!(c.params.len(), 4 + n);
        assert_eq!(c.params[4 + n - 1].value, n as f64 * 1e-3);
        assert_eq!(&values(&c)[..4], [500.0, 501.0, 320.0, 240.0]);
    }
    let c = parse(&opencv_text("", ""), "c.yml", None).unwrap();
    assert_eq!(c.model, "PINHOLE");
    for n in [1, 3, 6, 7, 13, 15] {
        let e = error(&opencv_text(&coeffs(n), ""), "c.yml", None);
        assert_error(
            &e,
            "c.yml",
            10,
            &[
                "distortion_coefficients",
                "4, 5, 8, 12 or 14",
                &format!("got {n}"),
            ],
        );
    }
    let c = parse(&opencv_text(&coeffs(4), "fisheye_model: 1\n"), "c.yml", None).unwrap();
    assert_eq!(c.model, "OPENCV_FISHEYE");
    assert_eq!(values(&c)[4..], [1e-3, 2e-3, 3e-3, 4e-3]);
    let e = error(&opencv_text(&coeffs(5), "fisheye_model: 1\n"), "c.yml", None);
    assert_error(&e, "c.yml", 11, &["fisheye", "4 coefficients", "got 5"]);
}

#[test]
fn opencv_errors_name_the_line_and_field() {
    let good = opencv_text("0.1, 0.01, 0., 0.", "");
    let skewed = good.replace("500., 0., 320.", "500., 0.5, 320.");
    assert_error(
        &error(&skewed, "k.yml", None),
        "k.yml",
        9,
        &["camera_matrix", "skew", "0.5"],
    );
    let short = good.replace("0., 0., 1. ]", "0., 1. ]");
    assert_error(
        &error(&short, "k.yml", None),
        "k.yml",
        9,
        &["camera_matrix.data", "needs 9 values, got 8"],
    );
    let nan = good.replace("320.", ".Nan");
    assert_error(
        &error(&nan, "k.yml", None),
        "k.yml",
        9,
        &["camera_matrix.data[2]", "finite number"],
    );
    let no_width = good.replace("image_width: 640\n", "");
    assert_error(
        &error(&no_width, "k.yml", None),
        "k.yml",
        3,
        &["image_width: missing"],
    );
    let bad_height = good.replace("image_height: 480", "image_height: 480.5");
    assert_error(
        &error(&bad_height, "k.yml", None),
        "k.yml",
        4,
        &["image_height", "\"480.5\""],
    );
    let two_channel = good.replace(
        "rows: 1\n   cols: 4\n   dt: d",
        "rows: 1\n   cols: 4\n   dt: \"2d\"",
    );
    assert_error(
        &error(&two_channel, "k.yml", None),
        "k.yml",
        13,
        &["distortion_coefficients.dt", "single-channel"],
    );
    let broken = good.replace("data: [ 500.", "data: [[ 500.");
    let e = error(&broken, "k.yml", None);
    assert!(e.to_string().starts_with("k.yml:"), "{e}");
    assert!(e.line.is_some(), "{e}");
    let e = error(&good, "k.yml", Some("cam0"));
    assert!(e.message.contains("single camera"), "{e}");
}

#[test]
fn ros_camera_info_reads_as_opencv() {
    let text = "image_width: 752\nimage_height: 480\ncamera_name: cam0\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: [458.654, 0, 367.215, 0, 457.296, 248.375, 0, 0, 1]\n\
                distortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0]\n";
    let c = parse(text, "cam0.yaml", None).unwrap();
    assert_eq!(c.model, "OPENCV_PINHOLE");
    assert_eq!(values(&c), [&EUROC_CAM0[..], &[0.0]].concat());
    let fisheye = text
        .replace("plumb_bob", "equidistant")
        .replace("cols: 5", "cols: 4")
        .replace(", 0]", "]");
    assert_eq!(
        parse(&fisheye, "cam0.yaml", None).unwrap().model,
        "OPENCV_FISHEYE"
    );
}

// ----- Kalibr -------------------------------------------------------------------------------------

/// Camera id, model, resolution, params.
type KalibrCase = (&'static str, &'static str, (u32, u32), &'static [f64]);

#[test]
fn kalibr_models_are_reordered_into_the_models_order() {
    let path = fixture("camchain.yaml");
    let cases: [KalibrCase; 5] = [
        ("cam0", "OPENCV", (752, 480), &EUROC_CAM0),
        (
            "cam1",
            "OPENCV_FISHEYE",
            (512, 512),
            &[
                190.97847715128717,
                190.9733070521226,
                254.93170605935475,
                256.8974428996504,
                0.0034823894022493434,
                0.0007150348452162257,
                -0.0020532361418706202,
                0.00020293673591811182,
            ],
        ),
        (
            "cam2",
            "OPENCV_OMNIDIR",
            (640, 480),
            // fx fy cx cy s xi k1 k2 p1 p2 from Kalibr's [xi fu fv pu pv] and [k1 k2 r1 r2]
            &[
                380.2, 379.8, 320.4, 239.6, 0.0, 0.9, -0.0521, 0.0113, 0.00021, -0.00011,
            ],
        ),
        (
            "cam3",
            "DOUBLE_SPHERE",
            (512, 512),
            // fx fy cx cy xi alpha from Kalibr's [xi alpha fu fv pu pv]
            &[158.3, 158.2, 254.9, 256.9, -0.17, 0.59],
        ),
        (
            "cam4",
            "EUCM",
            (512, 512),
            // COLMAP's fx fy cx cy alpha beta from Kalibr's [alpha beta fu fv pu pv]
            &[157.0, 157.0, 254.9, 256.9, 0.6, 1.1],
        ),
    ];
    for (id, model, size, params) in cases {
        let c = load(&path, Some(id)).unwrap();
        assert_eq!(c.format, FileFormat::Kalibr);
        assert_eq!(c.camera.as_deref(), Some(id));
        assert_eq!(c.model, model, "{id}");
        assert_eq!((c.width, c.height), size, "{id}");
        assert_eq!(values(&c), params, "{id}");
        assert_eq!(c.pixel_convention, PixelConvention::OpenCv);
    }
    let first = load(&path, None).unwrap();
    assert_eq!(first.camera.as_deref(), Some("cam0"));
    assert!(
        first
            .selection_note()
            .unwrap()
            .contains("cam0, cam1, cam2, cam3, cam4")
    );
    let cam1 = load(&path, Some("cam1")).unwrap();
    assert!(
        cam1.notes.iter().any(|n| n.contains("extrinsics")),
        "{:?}",
        cam1.notes
    );
    assert_eq!(
        cam1.params[7].line, 18,
        "the wrapped last coefficient is on line 18"
    );
    let e = load(&path, Some("cam9")).unwrap_err();
    assert!(e.message.contains("cam0, cam1, cam2, cam3, cam4"), "{e}");
}

#[test]
fn kalibr_errors_name_the_line_and_field() {
    let cam = |model: &str, dist: &str, intr: &str, coeffs: &str| {
        format!(
            "cam0:\n  camera_model: {model}\n  distortion_model: {dist}\n  intrinsics: [{intr}]\n  distortion_coeffs: [{coeffs}]\n  resolution: [640, 480]\n"
        )
    };
    let e = error(&cam("pinhole", "radtan", "1, 2, 3", "0, 0, 0, 0"), "k.yaml", None);
    assert_error(&e, "k.yaml", 4, &["cam0.intrinsics", "[fu fv pu pv]", "got 3"]);
    let e = error(
        &cam("pinhole", "equidistant", "1, 2, 3, 4", "0, 0"),
        "k.yaml",
        None,
    );
    assert_error(
        &e,
        "k.yaml",
        5,
        &["cam0.distortion_coeffs", "[k1 k2 k3 k4]", "got 2"],
    );
    let e = error(
        &cam("ds", "radtan", "0, 0.5, 1, 2, 3, 4", "0, 0, 0, 0"),
        "k.yaml",
        None,
    );
    assert_error(&e, "k.yaml", 3, &["ds-radtan is not supported", "eucm-none"]);
    let e = error(&cam("fisheye", "none", "1, 2, 3, 4", ""), "k.yaml", None);
    assert_error(
        &e,
        "k.yaml",
        2,
        &["cam0.camera_model", "\"fisheye\"", "pinhole, omni, ds or eucm"],
    );
    let e = error(&cam("pinhole", "none", "1, 2, x, 4", ""), "k.yaml", None);
    assert_error(&e, "k.yaml", 4, &["cam0.intrinsics[2]", "\"x\""]);
    let no_res = cam("pinhole", "none", "1, 2, 3, 4", "").replace("  resolution: [640, 480]\n", "");
    assert_error(
        &error(&no_res, "k.yaml", None),
        "k.yaml",
        2,
        &["cam0.resolution: missing"],
    );
    let flat = cam("pinhole", "none", "1, 2, 3, 4", "").replace("[640, 480]", "[640]");
    assert_error(&error(&flat, "k.yaml", None), "k.yaml", 6, &["[width, height]"]);
    // `equi` (Kalibr's command-line spelling) and an absent distortion model are accepted.
    let c = parse(
        &cam("pinhole", "equi", "1, 2, 3, 4", "0.1, 0.2, 0.3, 0.4"),
        "k.yaml",
        None,
    )
    .unwrap();
    assert_eq!(c.model, "OPENCV_FISHEYE");
    let c = parse(&cam("omni", "none", "1.2, 10, 11, 12, 13", ""), "k.yaml", None).unwrap();
    assert_eq!(c.model, "OPENCV_OMNIDIR");
    assert_eq!(values(&c), [10.0, 11.0, 12.0, 13.0, 0.0, 1.2, 0.0, 0.0, 0.0, 0.0]);
    let c = parse(&cam("pinhole", "fov", "1, 2, 3, 4", "0.9"), "k.yaml", None).unwrap();
    assert_eq!(
        (c.model.as_str(), values(&c)),
        ("FOV", vec![1.0, 2.0, 3.0, 4.0, 0.9])
    );
}

#[test]
fn unknown_structured_files_say_what_was_expected() {
    let e = error("foo: 1\nbar: [1, 2]\n", "x.yaml", None);
    assert!(e.line.is_none());
    assert!(
        e.message.contains("camera_matrix") && e.message.contains("camera_model"),
        "{e}"
    );
    let e = load(&fixture("does_not_exist.yaml"), None).unwrap_err();
    assert!(e.message.contains("cannot read"), "{e}");
}

// ----- OCamCalib ----------------------------------------------------------------------------------

#[test]
fn ocamcalib_calib_results() {
    let path = fixture("calib_results.txt");
    let c = load(&path, None).unwrap();
    assert_eq!(c.format, FileFormat::OCamCalib);
    assert_eq!(c.model, "OCAMCALIB");
    assert_eq!(
        (c.width, c.height),
        (640, 480),
        "the file says height 480, width 640"
    );
    assert_eq!(values(&c), [240.3, 320.7, 1.000165, 0.000115, -0.000106]);
    let pol: Vec<f64> = c.polynomial.iter().map(|n| n.value).collect();
    assert_eq!(pol, [-200.0, 0.0, 1.6e-3, 1.2e-7, 2.5e-9]);
    assert_eq!(c.polynomial[0].text, "-2.000000e+02");
    assert_eq!(c.inverse_polynomial.len(), 13);
    assert_eq!(c.inverse_polynomial[0].value, 324.287521);
    assert_eq!(c.inverse_polynomial[12].value, 0.018392);
    assert_eq!(
        (
            c.polynomial[0].line,
            c.inverse_polynomial[0].line,
            c.params[0].line
        ),
        (3, 7, 11)
    );
    assert_eq!(c.pixel_convention, PixelConvention::OpenCv);

    // The fixture's invpol was fitted to its pol: world2cam(cam2world(ρ)) = ρ to the fit's accuracy.
    let eval = |p: &[f64], x: f64| p.iter().rev().fold(0.0, |acc, a| acc * x + a);
    let inv: Vec<f64> = c.inverse_polynomial.iter().map(|n| n.value).collect();
    for rho in [1.0, 50.0, 150.0, 250.0, 399.0] {
        let theta = (eval(&pol, rho) / rho).atan();
        assert!((eval(&inv, theta) - rho).abs() < 1e-3, "rho {rho}");
    }
}

#[test]
fn ocamcalib_errors_name_the_line_and_field() {
    let good = std::fs::read_to_string(fixture("calib_results.txt")).unwrap();
    // Regression: a wrong length used to shift every later number and blame a later line.
    let e = error(&good.replace("13 324.287521", "14 324.287521"), "r.txt", None);
    assert_error(&e, "r.txt", 7, &["invpol", "says 14", "holds 13"]);
    let e = error(&good.replace("13 324.287521", "12 324.287521"), "r.txt", None);
    assert_error(&e, "r.txt", 7, &["invpol", "says 12", "holds 13"]);
    let e = error(&good.replace("5 -2.000000e+02", "6 -2.000000e+02"), "r.txt", None);
    assert_error(&e, "r.txt", 3, &["pol", "says 6", "holds 5"]);
    let e = error(&good.replace("5 -2.000000e+02", "x -2.000000e+02"), "r.txt", None);
    assert_error(&e, "r.txt", 3, &["pol", "number of coefficients", "\"x\""]);
    let e = error(&good.replace("1.000165", "1,000165"), "r.txt", None);
    assert_error(&e, "r.txt", 15, &["affine c", "\"1,000165\""]);
    let e = error(&good.replace("480 640", "480 640 12"), "r.txt", None);
    assert_error(&e, "r.txt", 19, &["unexpected \"12\""]);
    let e = error(&good.replace("480 640", "480 0"), "r.txt", None);
    assert_error(&e, "r.txt", 19, &["image width", "\"0\""]);
    let e = error(
        &good.replace("1.000165 0.000115 -0.000106", "0 1 0"),
        "r.txt",
        None,
    );
    assert_error(&e, "r.txt", 15, &["no inverse"]);
    let e = error(&good, "r.txt", Some("1"));
    assert!(e.message.contains("single camera"), "{e}");
    // Issue 16: a bad a0 was blamed on the centre's line (11), not pol's (3).
    for a0 in ["0.000000e+00", "2.0e+02"] {
        let c = parse(
            &good.replace("5 -2.000000e+02", &format!("5 {a0}")),
            "r.txt",
            None,
        )
        .unwrap();
        let e = c.param_list().unwrap_err();
        assert_error(&e, "r.txt", 3, &["pol's a0 must be < 0"]);
    }
}

// ----- Parameter lists ----------------------------------------------------------------------------

#[test]
fn param_lists_carry_the_files_text_and_lines() {
    let path = fixture("cameras.txt");
    let c = load(&path, Some("1")).unwrap();
    let list = c.param_list().unwrap();
    let names: Vec<&str> = list.entries().iter().map(|e| e.name.as_str()).collect();
    assert_eq!(names, ["model", "params", "resolution", "pixelConvention"]);
    let model = list.get("model").unwrap();
    assert_eq!(model.value, ParamValue::Strings(vec!["OPENCV".into()]));
    let params = list.get("params").unwrap();
    assert_eq!(params.ty, ParamType::Float);
    assert_eq!(
        params.origin.as_deref(),
        Some(format!("{}:4", path.display()).as_str())
    );
    let ParamValue::Floats(p) = &params.value else {
        panic!("{params:?}")
    };
    let want: Vec<f32> = texts(&c).iter().map(|t| t.parse::<f32>().unwrap()).collect();
    assert_eq!(p, &want);
    assert_eq!(
        list.get("resolution").unwrap().value,
        ParamValue::Ints(vec![752, 480])
    );
    assert_eq!(list.get("resolution").unwrap().array_len, Some(2));
    assert_eq!(
        list.get("pixelConvention").unwrap().value,
        ParamValue::Strings(vec!["colmap".into()])
    );

    let o = load(&fixture("calib_results.txt"), None)
        .unwrap()
        .param_list()
        .unwrap();
    let names: Vec<&str> = o.entries().iter().map(|e| e.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "model",
            "params",
            "polynomial",
            "inversePolynomial",
            "resolution",
            "pixelConvention"
        ]
    );
    assert_eq!(o.get("polynomial").unwrap().value.len(), 5);
    assert_eq!(o.get("inversePolynomial").unwrap().value.len(), 13);
    assert!(
        o.get("inversePolynomial")
            .unwrap()
            .origin
            .as_deref()
            .unwrap()
            .ends_with(":7")
    );
    assert_eq!(
        o.get("pixelConvention").unwrap().value,
        ParamValue::Strings(vec!["opencv".into()])
    );
}

#[test]
fn every_fixture_loads_and_summarises() {
    for (name, camera) in [
        ("cameras.txt", None),
        ("opencv_calibration.yml", None),
        ("opencv_calibration.json", None),
        ("camchain.yaml", Some("cam2")),
        ("calib_results.txt", None),
    ] {
        let c = load(&fixture(name), camera).unwrap();
        let s = c.summary();
        assert!(s.contains(&c.model) && s.contains(name), "{s}");
        c.param_list().unwrap();
    }
}

#[test]
fn the_malformed_fixture_names_its_line() {
    let e = load(&fixture("malformed_cameras.txt"), None).unwrap_err();
    assert_eq!(e.line, Some(4));
    assert!(
        e.to_string()
            .contains("malformed_cameras.txt:4: PARAMS: OPENCV takes 8 parameters"),
        "{e}"
    );
}

/// Regression: values out of a model's range (not just malformed text) were reported by the
/// projection later, without the file or the line.
#[test]
fn values_out_of_range_name_the_file_and_line() {
    let colmap = "# cameras\n\n1 PINHOLE 640 480 -500 500 320 240\n2 FOV 640 480 500 500 320 240 4.0\n";
    for (camera, words) in [
        ("1", &["PINHOLE", "fx", "-500"][..]),
        ("2", &["FOV", "omega", "4"][..]),
    ] {
        let c = parse(colmap, "cameras.txt", Some(camera)).unwrap();
        let e = c.param_list().unwrap_err();
        let line = if camera == "1" { 3 } else { 4 };
        assert_error(&e, "cameras.txt", line, words);
    }
    let kalibr = "cam0:\n  camera_model: ds\n  distortion_coeffs: []\n  distortion_model: none\n  \
                  intrinsics: [-1.5, 0.59, 158.3, 158.2, 254.9, 256.9]\n  resolution: [512, 512]\n";
    let e = parse(kalibr, "camchain.yaml", None)
        .unwrap()
        .param_list()
        .unwrap_err();
    assert_error(&e, "camchain.yaml", 5, &["DOUBLE_SPHERE", "xi", "-1.5"]);
}
