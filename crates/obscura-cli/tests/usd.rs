//! `obscura render` on USD stages, `--export-usd` and `obscura usd-cameras`.

mod support;

use std::path::PathBuf;

use support::{obscura, text};

fn stage(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../obscura-usd/tests/data")
        .join(name)
        .display()
        .to_string()
}

#[test]
fn a_stage_renders_its_time_codes_and_exports_its_camera() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("shot.####.exr");
    let cam = dir.path().join("cam.usda");
    let run = obscura(&[
        "render",
        &stage("cameras.usda"),
        "--frames",
        "2-3",
        "--format",
        "24x16",
        "--spp",
        "1",
        "-q",
        "-o",
        out.to_str().unwrap(),
        "--export-usd",
        cam.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    assert!(dir.path().join("shot.0002.exr").is_file() && dir.path().join("shot.0003.exr").is_file());
    let usda = std::fs::read_to_string(&cam).unwrap();
    assert!(usda.starts_with("#usda 1.0"), "{usda}");
    assert!(
        usda.contains("xformOp:transform.timeSamples") && usda.contains("2:") && usda.contains("3:"),
        "{usda}"
    );
}

#[test]
fn camera_names_a_usd_prim_and_is_refused_elsewhere() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.exr");
    let run = obscura(&[
        "render",
        &stage("ri_projection.usda"),
        "--camera",
        "Nope",
        "-q",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!run.status.success());
    let e = text(&run.stderr);
    assert!(
        e.contains("ri_projection.usda") && e.contains("--camera Nope") && e.contains("/World/Pano"),
        "{e}"
    );
    let run = obscura(&["render", "--camera", "Cam", "-q", "-o", out.to_str().unwrap()]);
    assert!(!run.status.success());
    assert!(
        text(&run.stderr).contains("--camera names the camera of a calibration file"),
        "{}",
        text(&run.stderr)
    );
}

#[test]
fn usd_cameras_prints_every_camera_as_json() {
    let run = obscura(&["usd-cameras", &stage("lenses.usda"), "--time", "0"]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    let paths: Vec<&str> = json["cameras"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["path"].as_str().unwrap())
        .collect();
    assert_eq!(
        paths,
        ["/Rig/Pinhole", "/Rig/Fisheye", "/Rig/Ftheta", "/Rig/IsaacLegacy"]
    );
    assert_eq!(json["cameras"][2]["samples"][0]["lens"]["model"], "FTHETA");
    assert_eq!(
        json["cameras"][0]["samples"][0]["attributes"]["focalLength"],
        50.0
    );
}
