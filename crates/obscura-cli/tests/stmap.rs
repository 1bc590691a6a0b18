//! End to end: `obscura stmap` as a user runs it, and `obscura plugins --names`.

use std::process::Command;

use exr::prelude::read_all_flat_layers_from_file;

mod support;

use support::{channel, fixture, obscura, screen, text_attribute};

#[test]
fn stmap_exr_holds_the_closed_form_perspective_map() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("map.exr");
    let run = obscura(&[
        "stmap",
        "--from",
        "PxrPerspective",
        "--from-param",
        "float fov=60",
        "--to",
        "PxrPerspective",
        "--to-param",
        "fov=90",
        "--format",
        "48x32",
        "--from-format",
        "96x54",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(stdout.contains("48x32 from 96x54"), "{stdout}");
    let image = read_all_flat_layers_from_file(&out).unwrap();
    let layer = &image.layer_data[0];
    assert_eq!((layer.size.0, layer.size.1), (48, 32));
    let (s, t, b, a) = (
        channel(&image, "R"),
        channel(&image, "G"),
        channel(&image, "B"),
        channel(&image, "A"),
    );
    assert_eq!(
        text_attribute(&image, "obscura:stmapFrom").as_deref(),
        Some("PxrPerspective")
    );
    assert_eq!(
        text_attribute(&image, "obscura:stmapFromFormat").as_deref(),
        Some("96x54")
    );
    // A's screen point is B's times tan 45° / tan 30°; A's window is ±16/9 × ±1.
    let k = 1.0 / 30f64.to_radians().tan();
    let aa = 96.0 / 54.0;
    let (mut inside, mut outside) = (0, 0);
    for j in 0..32 {
        for i in 0..48 {
            let n = (j * 48 + i) as usize;
            let (sx, sy) = screen(48, 32, i, j);
            let (es, et) = ((sx * k + aa) / (2.0 * aa), (sy * k + 1.0) / 2.0);
            assert!((s[n] as f64 - es).abs() < 1e-5, "s at {i},{j}: {} vs {es}", s[n]);
            assert!((t[n] as f64 - et).abs() < 1e-5, "t at {i},{j}: {} vs {et}", t[n]);
            assert_eq!(b[n], 0.0);
            let holds = (0.0..=1.0).contains(&es) && (0.0..=1.0).contains(&et);
            assert_eq!(a[n], if holds { 1.0 } else { 0.0 }, "alpha at {i},{j}");
            if holds {
                inside += 1;
            } else {
                outside += 1;
            }
        }
    }
    assert!(inside > 0 && outside > 0);
}

#[test]
fn the_same_projection_at_another_resolution_maps_pixel_centres_to_themselves() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("identity.exr");
    let run = obscura(&[
        "stmap",
        "--from",
        "PxrPerspective",
        "--to",
        "PxrPerspective",
        "--format",
        "40x30",
        "--from-format",
        "160x120",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let image = read_all_flat_layers_from_file(&out).unwrap();
    let (s, t, a) = (channel(&image, "R"), channel(&image, "G"), channel(&image, "A"));
    for j in 0..30u32 {
        for i in 0..40u32 {
            let n = (j * 40 + i) as usize;
            let (es, et) = ((i as f64 + 0.5) / 40.0, 1.0 - (j as f64 + 0.5) / 30.0);
            assert!(
                (s[n] as f64 - es).abs() < 1e-5 && (t[n] as f64 - et).abs() < 1e-5,
                "{i},{j}"
            );
            assert_eq!(a[n], 1.0);
        }
    }
}

#[test]
fn bad_requests_are_clear_errors_and_leave_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("never.exr");
    let o = out.to_str().unwrap();
    for (args, needle) in [
        (
            vec![
                "stmap",
                "--from",
                "PxrPerspectve",
                "--to",
                "PxrPerspective",
                "-o",
                o,
            ],
            "--from PxrPerspectve: unknown projection \"PxrPerspectve\" (did you mean \"PxrPerspective\"?)",
        ),
        (
            vec!["stmap", "--from", "PxrPerspective", "--to", "Nope", "-o", o],
            "--to Nope: unknown projection",
        ),
        (
            vec![
                "stmap",
                "--from",
                "PxrPerspective",
                "--from-param",
                "fvo=60",
                "--to",
                "PxrPerspective",
                "-o",
                o,
            ],
            "did you mean \"fov\"",
        ),
        (
            vec![
                "stmap",
                "--from",
                "PxrPerspective",
                "--to",
                "PxrPerspective",
                "--to-param",
                "fov=500",
                "-o",
                o,
            ],
            "--to PxrPerspective: PxrPerspective: parameter \"fov\"",
        ),
        (
            vec![
                "stmap",
                "--from",
                "PxrPerspective",
                "--to",
                "PxrPerspective",
                "--distance",
                "-1",
                "-o",
                o,
            ],
            "--distance -1: expected a positive finite distance",
        ),
        (
            vec![
                "stmap",
                "--from",
                "PxrPerspective",
                "--to",
                "PxrPerspective",
                "--format",
                "0x10",
                "-o",
                o,
            ],
            "expected WIDTHxHEIGHT",
        ),
    ] {
        let run = obscura(&args);
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{args:?} succeeded");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!out.exists());
    }
    let run = obscura(&[
        "stmap",
        "--from",
        "PxrPerspective",
        "--to",
        "PxrPerspective",
        "--format",
        "8x8",
        "-o",
        "/nonexistent-dir/map.exr",
    ]);
    assert!(!run.status.success());
    assert!(
        String::from_utf8_lossy(&run.stderr)
            .contains("output /nonexistent-dir/map.exr: the directory /nonexistent-dir does not exist")
    );
}

#[test]
fn plugins_names_lists_every_registered_projection_one_per_line() {
    let run = obscura(&["plugins", "--names"]);
    assert!(run.status.success());
    let listed: Vec<String> = String::from_utf8_lossy(&run.stdout)
        .lines()
        .map(str::to_string)
        .collect();
    assert_eq!(listed, obscura_plugins::builtin_registry().names());
}

/// Reads an identity map with OpenEXR's own library through its Python binding (CI installs it and
/// sets OBSCURA_REQUIRE_INDEPENDENT_EXR=1, so there a missing reader is a failure, not a skip).
#[test]
fn an_independent_reader_sees_nukes_convention() {
    if !support::python_has("OpenEXR, numpy", "OBSCURA_REQUIRE_INDEPENDENT_EXR") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("identity.exr");
    let run = obscura(&[
        "stmap",
        "--from",
        "PxrOrthographic",
        "--to",
        "PxrOrthographic",
        "--format",
        "24x12",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    // Nuke: s = (i + ½)/W from the left, t = (row-from-the-bottom + ½)/H; the file's first row is the top.
    let script = r#"
import sys, numpy as np, OpenEXR
ch = OpenEXR.File(sys.argv[1], separate_channels=True).parts[0].channels
s, t, a = ch["R"].pixels, ch["G"].pixels, ch["A"].pixels
h, w = s.shape
i, j = np.meshgrid(np.arange(w), np.arange(h))
ok = (np.abs(s - (i + 0.5) / w).max() < 1e-6 and np.abs(t - (h - j - 0.5) / h).max() < 1e-6
      and (a == 1).all() and (ch["B"].pixels == 0).all() and (w, h) == (24, 12))
print("ok" if ok else f"mismatch: s {s[0, :3]} t {t[:3, 0]}")
sys.exit(0 if ok else 1)
"#;
    let r = Command::new("python3")
        .args(["-c", script, out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        r.status.success(),
        "independent reader: {}{}",
        String::from_utf8_lossy(&r.stdout),
        String::from_utf8_lossy(&r.stderr)
    );
}

/// opencv_calibration.yml's camera for opencv_stmap.py: MODEL FX FY CX CY W H, then k1 k2 p1 p2 k3.
const OPENCV_YML: &str = "pinhole 5.3591573396163199e+02 5.3591573396163199e+02 3.4228315473308373e+02 \
     2.3557082909788173e+02 640 480 -2.6637260909660682e-01 -3.8588898922304653e-02 \
     1.7831947042852964e-03 -2.8122100441115472e-04 2.3839153080878486e-01";

/// The lens-removal map a compositor asks for, checked against OpenCV's own undistortion maps
/// (`cv2.initUndistortRectifyMap` and `cv2.fisheye.initUndistortRectifyMap`: forward distortion,
/// code we did not write). CI installs OpenCV and sets OBSCURA_REQUIRE_OPENCV=1.
#[test]
fn undistortion_maps_of_calibration_files_match_opencvs() {
    if !support::python_has("cv2, numpy, OpenEXR", "OBSCURA_REQUIRE_OPENCV") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let checker = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/opencv_stmap.py");
    // (file, camera, B's fov, the checker's MODEL FX FY CX CY W H, coefficients): the fixtures' values.
    let cases: [(&str, &str, &str, &str); 3] = [
        ("opencv_calibration.yml", "", "40", OPENCV_YML),
        // Wider than the plate: the map must leave the pixels it cannot fill unmapped, as OpenCV does.
        ("opencv_calibration.yml", "", "70", OPENCV_YML),
        (
            "camchain.yaml",
            "cam1",
            "150",
            "fisheye 190.97847715128717 190.9733070521226 254.93170605935475 256.8974428996504 \
             512 512 0.0034823894022493434 0.0007150348452162257 -0.0020532361418706202 \
             0.00020293673591811182",
        ),
    ];
    for (file, camera, fov, model) in cases {
        let out = dir.path().join(format!("{file}-{fov}.exr"));
        let path = fixture(file);
        let fov_param = format!("fov={fov}");
        let mut args = vec![
            "stmap",
            "--from-calibration",
            &path,
            "--to",
            "PxrPerspective",
            "--to-param",
            &fov_param,
            "-o",
            out.to_str().unwrap(),
        ];
        if !camera.is_empty() {
            args.extend(["--from-camera", camera]);
        }
        let run = obscura(&args);
        assert!(
            run.status.success(),
            "{file}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        // The map takes the plate's size when no --format is given.
        let mut words: Vec<&str> = model.split_whitespace().collect();
        words.insert(7, fov);
        let r = Command::new("python3")
            .arg(checker)
            .arg(&out)
            .args(&words)
            .output()
            .unwrap();
        assert!(
            r.status.success(),
            "{file} {camera} fov {fov}: {}{}",
            String::from_utf8_lossy(&r.stdout),
            String::from_utf8_lossy(&r.stderr)
        );
    }
}

/// Both sides may be calibrations; the EXR records which camera of which file, and messages name
/// the side's own options.
#[test]
fn calibration_sides_are_recorded_and_their_errors_name_the_option() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c2c.exr");
    let cameras = fixture("cameras.txt");
    let camchain = fixture("camchain.yaml");
    let run = obscura(&[
        "stmap",
        "--from-calibration",
        &cameras,
        "--from-camera",
        "2",
        "--to-calibration",
        &camchain,
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("using the first, cam0 (choose with --to-camera)"),
        "{err}"
    );
    let stdout = String::from_utf8_lossy(&run.stdout);
    // B takes its own calibration's size, A its own.
    assert!(stdout.contains("752x480 from 1600x1200"), "{stdout}");
    let image = read_all_flat_layers_from_file(&out).unwrap();
    let from = text_attribute(&image, "obscura:stmapFrom").unwrap();
    let to = text_attribute(&image, "obscura:stmapTo").unwrap();
    assert!(
        from.starts_with("camera 2 (") && from.contains("cameras.txt"),
        "{from}"
    );
    assert!(
        to.starts_with("camera cam0 (") && to.contains("camchain.yaml"),
        "{to}"
    );

    let never = dir.path().join("never.exr");
    let malformed = fixture("malformed_cameras.txt");
    for (args, needle) in [
        (
            vec![
                "--from-calibration",
                "/no/such/cameras.txt",
                "--to",
                "PxrPerspective",
            ],
            "--from-calibration: /no/such/cameras.txt: cannot read",
        ),
        (
            vec!["--from", "PxrPerspective", "--to-calibration", &malformed],
            "--to-calibration: ",
        ),
        (
            vec![
                "--from-calibration",
                &camchain,
                "--from-camera",
                "cam9",
                "--to",
                "PxrPerspective",
            ],
            "cam9",
        ),
        (
            vec![
                "--from-calibration",
                &cameras,
                "--from-param",
                "fvo=1",
                "--to",
                "PxrPerspective",
            ],
            "--from-param: ",
        ),
    ] {
        let mut all = vec!["stmap", "-o", never.to_str().unwrap()];
        all.extend(args.iter().copied());
        let run = obscura(&all);
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{args:?} succeeded");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!never.exists());
    }
}
