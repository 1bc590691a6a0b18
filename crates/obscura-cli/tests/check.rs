//! End to end: `obscura check` as a plugin author runs it.

use std::process::Command;

mod support;

use support::{fixture, obscura, text};

#[test]
fn a_builtin_passes_with_exit_code_zero_and_an_ok_line_per_check() {
    let run = obscura(&["check", "PxrPerspective", "--format", "48x36"]);
    let (out, err) = (text(&run.stdout), text(&run.stderr));
    assert_eq!(run.status.code(), Some(0), "{out}\n{err}");
    assert!(
        out.starts_with("obscura check PxrPerspective: 48x36 pixels"),
        "{out}"
    );
    for line in [
        "ok           finite directions: ",
        "ok           no errors returned by project: ",
        "ok           min_dist/max_dist at the clipping planes (CameraZ) or spheres (RayLength): ",
        "ok           ray_spread is half the angle between neighbouring pixels: 1728 pixels",
        "ok           FieldOfView matches the measured extent: 1 property",
        "ok           unproject inverts project: ",
        "ok           same outputs on several threads at once: ",
    ] {
        assert!(out.contains(line), "missing {line:?} in\n{out}");
    }
    assert_eq!(out.lines().filter(|l| l.starts_with("ok ")).count(), 18, "{out}");
    assert!(out.trim_end().ends_with("clean: no check failed"), "{out}");
    assert!(err.is_empty(), "{err}");
}

#[test]
fn parameters_reach_the_projection() {
    let run = obscura(&[
        "check",
        "PxrPerspective",
        "--format",
        "32x24",
        "--param",
        "float fov=40",
        "--param",
        "fovEnd=20",
    ]);
    let out = text(&run.stdout);
    assert_eq!(run.status.code(), Some(0), "{out}\n{}", text(&run.stderr));
    assert!(out.contains("k_FieldOfView 20"), "{out}");
}

#[test]
fn json_output_parses_and_says_the_same() {
    let run = obscura(&[
        "check",
        "PxrOrthographic",
        "--json",
        "--format",
        "32x24",
        "--seed",
        "7",
    ]);
    assert_eq!(run.status.code(), Some(0), "{}", text(&run.stderr));
    let json = text(&run.stdout);
    // Python's json module is an independent reader; fall back to a structural check without it.
    let py = Command::new("python3")
        .args([
            "-c",
            "import json, sys\n\
             d = json.load(sys.stdin)\n\
             assert d['projection'] == 'PxrOrthographic' and d['clean'] is True, d\n\
             assert d['format'] == {'width': 32, 'height': 24, 'pixel_aspect': 1}, d['format']\n\
             assert d['seed'] == 7\n\
             ids = [c['check'] for c in d['checks']]\n\
             assert len(ids) == 18 and ids[:2] == ['panic', 'error'] and 'ray_spread' in ids and 'clipping' in ids, ids\n\
             fov = [c for c in d['checks'] if c['check'] == 'field_of_view'][0]\n\
             assert fov['status'] == 'not_checked' and fov['notes'] == ['FieldOfView not answered'], fov\n\
             assert all(c['failures'] == 0 and c['worst'] is None for c in d['checks'])\n\
             print('parsed')",
        ])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn();
    match py {
        Ok(mut child) => {
            use std::io::Write;
            child.stdin.take().unwrap().write_all(json.as_bytes()).unwrap();
            let out = child.wait_with_output().unwrap();
            assert!(out.status.success(), "{}\n{json}", text(&out.stderr));
            assert_eq!(text(&out.stdout).trim(), "parsed");
        }
        Err(_) => {
            assert!(
                json.starts_with("{\"projection\":\"PxrOrthographic\",\"clean\":true,"),
                "{json}"
            );
            assert_eq!(json.trim_end().chars().last(), Some('}'));
        }
    }
}

#[test]
fn a_bad_param_is_a_clear_error() {
    // Exit 2: the check could not run (1 is kept for a projection that broke the contract).
    let run = obscura(&["check", "PxrPerspective", "--param", "fvo=60"]);
    let err = text(&run.stderr);
    assert_eq!(run.status.code(), Some(2));
    assert!(run.stdout.is_empty(), "{}", text(&run.stdout));
    assert!(
        err.contains("--param 'fvo=60': PxrPerspective has no parameter \"fvo\" (did you mean \"fov\"?)"),
        "{err}"
    );
    let run = obscura(&["check", "PxrPerspective", "--param", "fov=200"]);
    let err = text(&run.stderr);
    assert_eq!(run.status.code(), Some(2));
    assert!(err.contains("\"fov\"") && err.contains("out of range"), "{err}");
    // With --json, a script reads the reason from stdout too.
    let run = obscura(&["check", "PxrPerspective", "--param", "fov=200", "--json"]);
    assert_eq!(run.status.code(), Some(2));
    let out = text(&run.stdout);
    assert!(
        out.starts_with("{\"error\": \"") && out.contains("out of range"),
        "{out}"
    );
}

#[test]
fn an_unknown_projection_is_a_clear_error() {
    let run = obscura(&["check", "PxrPerspectve"]);
    let err = text(&run.stderr);
    assert_eq!(run.status.code(), Some(2));
    assert!(err.contains("did you mean \"PxrPerspective\""), "{err}");
}

#[test]
fn bad_sampling_options_are_refused() {
    for args in [
        &["check", "PxrPerspective", "--format", "0x10"][..],
        &["check", "PxrPerspective", "--threads", "0"][..],
        &["check", "PxrPerspective", "--screen-window", "1", "-1", "-1", "1"][..],
        &["check", "PxrPerspective", "--pixel-aspect", "-2"][..],
    ] {
        let run = obscura(args);
        assert_ne!(run.status.code(), Some(0), "{args:?}");
        assert!(!text(&run.stderr).is_empty(), "{args:?}");
    }
}

/// Every camera of every calibration fixture keeps the contract (its fold regions culled, its
/// properties honest), checked straight from the file, sampled in the calibration image's aspect.
#[test]
fn every_fixture_calibration_passes_from_its_file() {
    let cases: [(&str, &[&str]); 5] = [
        ("cameras.txt", &["1", "2", "3", "7"]),
        ("camchain.yaml", &["cam0", "cam1", "cam2", "cam3", "cam4"]),
        ("opencv_calibration.yml", &[""]),
        ("opencv_calibration.json", &[""]),
        ("calib_results.txt", &[""]),
    ];
    for (file, cameras) in cases {
        for camera in cameras.iter().copied() {
            let path = fixture(file);
            let mut args = vec!["check", "--calibration", &path, "--samples", "1"];
            if !camera.is_empty() {
                args.extend(["--camera", camera]);
            }
            let run = obscura(&args);
            let (out, err) = (text(&run.stdout), text(&run.stderr));
            assert_eq!(run.status.code(), Some(0), "{file} {camera}:\n{out}\n{err}");
            assert!(out.starts_with("obscura check CalibratedCamera: 96x"), "{out}");
            assert!(out.trim_end().ends_with("clean: no check failed"), "{out}");
        }
    }
    // 1600x1200 (COLMAP camera 2) is sampled 96x72; a 752x480 one 96x61.
    let run = obscura(&["check", "--calibration", &fixture("cameras.txt"), "--camera", "2"]);
    assert!(text(&run.stdout).contains(": 96x72 pixels"));
    let run = obscura(&[
        "check",
        "--calibration",
        &fixture("camchain.yaml"),
        "--camera",
        "cam0",
    ]);
    assert!(text(&run.stdout).contains(": 96x61 pixels"));
    // A missing file names itself; a projection and a calibration together are refused.
    let run = obscura(&["check", "--calibration", &fixture("nope.yml")]);
    assert_eq!(run.status.code(), Some(2));
    assert!(text(&run.stderr).contains("nope.yml"), "{}", text(&run.stderr));
    let run = obscura(&[
        "check",
        "PxrPerspective",
        "--calibration",
        &fixture("cameras.txt"),
    ]);
    assert!(!run.status.success());
}
