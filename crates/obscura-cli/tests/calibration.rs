//! End to end: `obscura rays --calibration` and `obscura render --calibration` with each calibration
//! file format, as a user runs them.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use exr::prelude::{FlatImage, read_all_flat_layers_from_file};

mod support;

use support::{channel, fixture, obscura};

fn stderr(o: &Output) -> String {
    support::text(&o.stderr)
}

/// Runs `obscura rays` with `args` into `out` and reads the result back.
fn rays(out: &Path, args: &[&str]) -> FlatImage {
    let mut all = vec!["rays", "-o", out.to_str().unwrap()];
    all.extend_from_slice(args);
    let run = obscura(&all);
    assert!(run.status.success(), "obscura {all:?}: {}", stderr(&run));
    read_all_flat_layers_from_file(out).unwrap()
}

fn direction(image: &FlatImage, i: usize) -> [f64; 3] {
    [
        f64::from(channel(image, "direction.X")[i]),
        f64::from(channel(image, "direction.Y")[i]),
        f64::from(channel(image, "direction.Z")[i]),
    ]
}

#[test]
fn rays_from_every_fixture_and_camera() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rays.exr");
    // Formats at each calibration's aspect, 16 to 40 times smaller.
    let cases: [(&str, Option<&str>, &str); 12] = [
        ("cameras.txt", None, "47x30"),
        ("cameras.txt", Some("2"), "32x24"),
        ("cameras.txt", Some("3"), "40x32"),
        ("cameras.txt", Some("7"), "32x32"),
        ("opencv_calibration.yml", None, "32x24"),
        ("opencv_calibration.json", None, "32x24"),
        ("camchain.yaml", Some("cam0"), "47x30"),
        ("camchain.yaml", Some("cam1"), "32x32"),
        ("camchain.yaml", Some("cam2"), "32x24"),
        ("camchain.yaml", Some("cam3"), "32x32"),
        ("camchain.yaml", Some("cam4"), "32x32"),
        ("calib_results.txt", None, "32x24"),
    ];
    for (file, camera, format) in cases {
        let path = fixture(file);
        let mut args = vec!["--calibration", path.as_str(), "--format", format];
        if let Some(c) = camera {
            args.extend(["--camera", c]);
        }
        let image = rays(&out, &args);
        let (w, h) = format.split_once('x').unwrap();
        let (w, h): (usize, usize) = (w.parse().unwrap(), h.parse().unwrap());
        let size = image.layer_data[0].size;
        assert_eq!((size.0, size.1), (w, h), "{file} {camera:?}");
        let valid = channel(&image, "valid");
        let n_valid = valid.iter().filter(|v| **v == 1.0).count();
        assert!(
            n_valid * 2 > w * h,
            "{file} {camera:?}: only {n_valid} of {} rays valid",
            w * h
        );
        // The pixel nearest the image centre looks forward, and every valid ray is unit length.
        let centre = (h / 2) * w + w / 2;
        assert_eq!(valid[centre], 1.0, "{file} {camera:?}");
        assert!(
            direction(&image, centre)[2] > 0.9,
            "{file} {camera:?}: {:?}",
            direction(&image, centre)
        );
        for i in (0..w * h).filter(|&i| valid[i] == 1.0) {
            let d = direction(&image, i);
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            assert!(
                (len - 1.0).abs() < 1e-5,
                "{file} {camera:?} pixel {i}: |d| = {len}"
            );
        }
    }
}

/// OpenCV's rad-tan model undistorted independently: fixed-point iteration run to convergence in f64.
fn opencv_undistort(xd: f64, yd: f64, k: &[f64; 5]) -> (f64, f64) {
    let (k1, k2, p1, p2, k3) = (k[0], k[1], k[2], k[3], k[4]);
    let (mut x, mut y) = (xd, yd);
    for _ in 0..500 {
        let r2 = x * x + y * y;
        let radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
        let dx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let dy = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        (x, y) = ((xd - dx) / radial, (yd - dy) / radial);
    }
    (x, y)
}

#[test]
// The values are the fixture's text, digit for digit.
#[allow(clippy::excessive_precision)]
fn opencv_rays_match_an_independent_undistortion() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rays.exr");
    let path = fixture("opencv_calibration.yml");
    let image = rays(&out, &["--calibration", &path, "--format", "32x24"]);
    let (fx, fy, cx, cy) = (
        5.3591573396163199e+02,
        5.3591573396163199e+02,
        3.4228315473308373e+02,
        2.3557082909788173e+02,
    );
    let k = [
        -2.6637260909660682e-01,
        -3.8588898922304653e-02,
        1.7831947042852964e-03,
        -2.8122100441115472e-04,
        2.3839153080878486e-01,
    ];
    for (i, j) in [(0, 0), (31, 0), (16, 12), (5, 20), (31, 23)] {
        // The 640x480 calibration image spans the 32x24 frame; OpenCV puts pixel centres at integers.
        let u = (f64::from(i) + 0.5) * 20.0 - 0.5;
        let v = (f64::from(j) + 0.5) * 20.0 - 0.5;
        let (x, y) = opencv_undistort((u - cx) / fx, (v - cy) / fy, &k);
        // OpenCV's +Y is down, camera space's +Y up.
        let len = (x * x + y * y + 1.0).sqrt();
        let want = [x / len, -y / len, 1.0 / len];
        let got = direction(&image, (j * 32 + i) as usize);
        for c in 0..3 {
            assert!(
                (got[c] - want[c]).abs() < 1e-5,
                "pixel ({i}, {j}): {got:?} vs {want:?}"
            );
        }
    }
}

#[test]
fn the_format_defaults_to_the_calibration_and_param_overrides_it() {
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("cameras.txt");
    std::fs::write(&cal, "# one small pinhole\n4 PINHOLE 64 48 50 50 32 24\n").unwrap();
    let cal = cal.to_str().unwrap();
    let out = dir.path().join("rays.exr");
    let colmap = rays(&out, &["--calibration", cal]);
    assert_eq!(colmap.layer_data[0].size.0, 64);
    assert_eq!(colmap.layer_data[0].size.1, 48);
    let opencv = rays(&out, &["--calibration", cal, "--param", "pixelConvention=opencv"]);
    for (i, j) in [(0usize, 0usize), (40, 10), (63, 47)] {
        for (image, offset) in [(&colmap, 0.5), (&opencv, 0.0)] {
            // COLMAP: pixel (i, j)'s centre is at (i + 0.5, j + 0.5); OpenCV: at (i, j).
            let (x, y) = (
                (i as f64 + offset - 32.0) / 50.0,
                (j as f64 + offset - 24.0) / 50.0,
            );
            let len = (x * x + y * y + 1.0).sqrt();
            let want = [x / len, -y / len, 1.0 / len];
            let got = direction(image, j * 64 + i);
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < 1e-6,
                    "offset {offset}, pixel ({i}, {j}): {got:?} vs {want:?}"
                );
            }
        }
    }
}

#[test]
fn several_cameras_without_camera_take_the_first_and_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rays.exr");
    let path = fixture("camchain.yaml");
    let run = obscura(&[
        "rays",
        "--calibration",
        &path,
        "--format",
        "16x10",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let err = stderr(&run);
    assert!(
        err.contains("5 cameras (cam0, cam1, cam2, cam3, cam4); using the first, cam0"),
        "{err}"
    );
    let out_text = String::from_utf8_lossy(&run.stdout);
    assert!(out_text.contains("CalibratedCamera"), "{out_text}");
}

#[test]
fn malformed_files_and_unknown_cameras_are_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rays.exr");
    let out = out.to_str().unwrap();
    let path = fixture("malformed_cameras.txt");
    let run = obscura(&["rays", "--calibration", &path, "-o", out]);
    assert!(!run.status.success());
    let err = stderr(&run);
    assert!(
        err.contains("malformed_cameras.txt:4: PARAMS: OPENCV takes 8 parameters"),
        "{err}"
    );
    let path = fixture("cameras.txt");
    let run = obscura(&["rays", "--calibration", &path, "--camera", "9", "-o", out]);
    assert!(!run.status.success());
    assert!(
        stderr(&run).contains("its cameras are: 1, 2, 3, 7"),
        "{}",
        stderr(&run)
    );
    let run = obscura(&["render", "--calibration", &path, "--camera", "9", "-o", out]);
    assert!(!run.status.success());
    assert!(stderr(&run).contains("no camera \"9\""), "{}", stderr(&run));
    assert!(!Path::new(out).exists());
}

#[test]
fn calibration_conflicts_with_projection_and_camera_needs_it() {
    let path = fixture("cameras.txt");
    let run = obscura(&["rays", "--calibration", &path, "--projection", "PxrPerspective"]);
    assert!(!run.status.success());
    assert!(stderr(&run).contains("cannot be used with"), "{}", stderr(&run));
    let run = obscura(&["render", "--calibration", &path, "-p", "PxrPerspective"]);
    assert!(!run.status.success());
    assert!(stderr(&run).contains("cannot be used with"), "{}", stderr(&run));
    let run = obscura(&["rays", "--camera", "1"]);
    assert!(!run.status.success());
    assert!(stderr(&run).contains("--calibration"), "{}", stderr(&run));
}

#[test]
fn render_through_a_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("render.exr");
    for (file, camera) in [
        ("camchain.yaml", Some("cam1")),
        ("calib_results.txt", None),
        ("opencv_calibration.json", None),
    ] {
        let path = fixture(file);
        let mut args = vec![
            "render",
            "--calibration",
            path.as_str(),
            "--format",
            "16x12",
            "--spp",
            "1",
            "--max-depth",
            "1",
            "-o",
            out.to_str().unwrap(),
        ];
        if let Some(c) = camera {
            args.extend(["--camera", c]);
        }
        let run = obscura(&args);
        assert!(run.status.success(), "{file}: {}", stderr(&run));
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(
            stdout.contains("rendered 16x12 through CalibratedCamera"),
            "{stdout}"
        );
        if file == "camchain.yaml" {
            // 512x512 resampled to 16x12: the same camera with non-square pixels, said once.
            assert!(
                stderr(&run).contains("each pixel covers 32.000 x 42.667"),
                "{}",
                stderr(&run)
            );
        }
        let image = read_all_flat_layers_from_file(&out).unwrap();
        assert_eq!(image.layer_data[0].size.0, 16);
        assert_eq!(image.layer_data[0].size.1, 12);
        assert!(out.with_extension("png").exists());
    }
}

/// An OpenCV FileStorage calibration with `coefficients` (and `fisheye_model: 1` when `fisheye`).
fn opencv_yaml(k: [f64; 4], coefficients: &[f64], fisheye: bool) -> String {
    let [fx, fy, cx, cy] = k;
    let list = |v: &[f64]| v.iter().map(f64::to_string).collect::<Vec<_>>().join(", ");
    format!(
        "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n{}camera_matrix: !!opencv-matrix\n   rows: 3\n   \
         cols: 3\n   dt: d\n   data: [ {} ]\ndistortion_coefficients: !!opencv-matrix\n   rows: {}\n   cols: 1\n   \
         dt: d\n   data: [ {} ]\n",
        if fisheye { "fisheye_model: 1\n" } else { "" },
        list(&[fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]),
        coefficients.len(),
        list(coefficients)
    )
}

/// Every ray of three OpenCV calibrations (the 5-coefficient fixture, 14 coefficients with thin prism
/// and tilted sensor, and the fisheye model) against OpenCV's own `undistortPoints`, run to
/// convergence, through `tests/opencv_rays.py`. CI installs `opencv-python-headless` and sets
/// OBSCURA_REQUIRE_OPENCV=1, so there a missing OpenCV is a failure, not a skip.
#[test]
// The fixture's values are its text, digit for digit.
#[allow(clippy::excessive_precision)]
fn every_ray_matches_opencvs_own_undistortion() {
    if !support::python_has("cv2, numpy, OpenEXR", "OBSCURA_REQUIRE_OPENCV") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let fixture_k = [
        5.3591573396163199e+02,
        5.3591573396163199e+02,
        3.4228315473308373e+02,
        2.3557082909788173e+02,
    ];
    let fixture_d = [
        -2.6637260909660682e-01,
        -3.8588898922304653e-02,
        1.7831947042852964e-03,
        -2.8122100441115472e-04,
        2.3839153080878486e-01,
    ];
    let pinhole_k = [500.0, 490.0, 322.0, 241.0];
    let pinhole_d = [
        -0.28, 0.07, 0.001, -0.0005, -0.002, 0.01, 0.003, 0.0002, 0.001, -0.0002, 0.0008, 0.0001, 0.01,
        -0.008,
    ];
    let fisheye_k = [300.0, 300.0, 320.0, 240.0];
    let fisheye_d = [-0.01, 0.02, -0.003, 0.0005];
    /// (name, calibration file text (None: the fixture), fx fy cx cy, coefficients, OpenCV model).
    type Case<'a> = (&'a str, Option<String>, [f64; 4], &'a [f64], &'a str);
    let cases: [Case; 3] = [
        ("five", None, fixture_k, &fixture_d, "pinhole"),
        (
            "fourteen",
            Some(opencv_yaml(pinhole_k, &pinhole_d, false)),
            pinhole_k,
            &pinhole_d,
            "pinhole",
        ),
        (
            "fisheye",
            Some(opencv_yaml(fisheye_k, &fisheye_d, true)),
            fisheye_k,
            &fisheye_d,
            "fisheye",
        ),
    ];
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/opencv_rays.py");
    for (name, yaml, k, d, model) in cases {
        let cal = match yaml {
            Some(text) => {
                let p = dir.path().join(format!("{name}.yml"));
                std::fs::write(&p, text).unwrap();
                p.to_str().unwrap().to_string()
            }
            None => fixture("opencv_calibration.yml"),
        };
        let out = dir.path().join(format!("{name}.exr"));
        rays(&out, &["--calibration", &cal, "--format", "160x120"]);
        let mut args = vec![
            script.to_str().unwrap().to_string(),
            out.to_str().unwrap().into(),
            model.into(),
        ];
        args.extend(k.iter().map(f64::to_string));
        args.extend(["640".into(), "480".into()]);
        args.extend(d.iter().map(f64::to_string));
        let r = Command::new("python3").args(&args).output().unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&r.stdout),
            String::from_utf8_lossy(&r.stderr)
        );
        assert!(r.status.success(), "{name}: {text}");
        assert!(text.contains("19200 rays"), "{name}: {text}");
    }
}

/// `obscura plugins CalibratedCamera` names every model's parameters in order, not just the list's
/// type: a user reads there what `params` holds for the model they chose.
#[test]
fn the_listing_names_every_models_parameters() {
    let run = Command::new(env!("CARGO_BIN_EXE_obscura"))
        .args(["plugins", "CalibratedCamera"])
        .output()
        .unwrap();
    assert!(run.status.success());
    let out = String::from_utf8_lossy(&run.stdout);
    for (i, m) in obscura_calibration::MODELS.iter().enumerate() {
        let line = out
            .lines()
            // Names may hold spaces (3DE's `3DE4 Radial - Standard, Degree 4`); columns are two apart.
            .find(|l| (l.trim_start().strip_prefix(m.name)).is_some_and(|rest| rest.starts_with("  ")))
            .unwrap_or_else(|| panic!("no line for {} in\n{out}", m.name));
        assert!(line.contains(m.params), "{line}");
        assert_eq!(line.contains(&format!("COLMAP {i:>2}")), i < 18, "{line}");
    }
}
