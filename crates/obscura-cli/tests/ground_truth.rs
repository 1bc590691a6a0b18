//! End to end: ground-truth AOVs and sidecars, and a 24-frame glTF animation rendered with `--frames`,
//! interrupted and resumed.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod support;

use support::obscura_in as obscura;

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/animated/boxes.gltf")
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The channel names of an EXR.
fn channels(path: &Path) -> Vec<String> {
    let meta = exr::meta::MetaData::read_from_file(path, false).unwrap();
    meta.headers[0]
        .channels
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect()
}

/// The channel `name` of an EXR as f32s (integers converted).
fn channel(path: &Path, name: &str) -> Vec<f32> {
    use exr::prelude::{FlatSamples, ReadChannels, ReadLayers, read};
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap();
    let c = (image.layer_data.channel_data.list.iter())
        .find(|c| c.name.to_string() == name)
        .unwrap_or_else(|| panic!("{}: no channel {name}", path.display()));
    match &c.sample_data {
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
        FlatSamples::U32(v) => v.iter().map(|&u| u as f32).collect(),
    }
}

const ANIMATION: [&str; 9] = [
    "render",
    "--format",
    "32x24",
    "--spp",
    "1",
    "--aov",
    "all",
    "-o",
    "anim.####.exr",
];

#[test]
fn an_unknown_aov_is_named_with_the_known_ones() {
    let dir = tempfile::tempdir().unwrap();
    let out = obscura(&["render", "--aov", "depth"], dir.path());
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("unknown AOV 'depth'; expected one of cameraZ, distance"),
        "{err}"
    );
}

#[test]
fn aov_all_writes_the_texture_aovs_beside_the_ground_truth() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "render", "--format", "24x16", "--spp", "1", "-q", "--aov", "all", "-o", "all.exr",
    ];
    let out = obscura(&args, dir.path());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let exr = dir.path().join("all.exr");
    for name in [
        "objectId", "cameraZ", "albedo.R", "albedo.G", "albedo.B", "uv.X", "uv.Y",
    ] {
        assert_eq!(channel(&exr, name).len(), 24 * 16, "{name}");
    }
    // The built-in scene's surfaces are coloured: the albedo of the hit pixels is not black.
    let ids = channel(&exr, "objectId");
    let albedo = channel(&exr, "albedo.R");
    assert!(ids.iter().zip(&albedo).any(|(&id, &a)| id > 0.0 && a > 0.0));
}

#[test]
fn a_still_render_with_ground_truth_writes_ids_and_camera_sidecars() {
    let dir = tempfile::tempdir().unwrap();
    let out = obscura(
        &[
            "render",
            "--format",
            "24x16",
            "--spp",
            "1",
            "-q",
            "--aov",
            "objectId,flowForward",
            "-o",
            "gt.exr",
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let ids = json(&dir.path().join("gt.ids.json"));
    assert_eq!(ids["background"], 0);
    let camera = json(&dir.path().join("gt.camera.json"));
    assert_eq!(camera["projection"], "PxrPerspective");
    assert_eq!(camera["complete"], true);
    assert_eq!(camera["colmap"]["model"], "PINHOLE");
    let objects = channel(&dir.path().join("gt.exr"), "objectId");
    let names = ids["objects"].as_object().unwrap();
    for id in objects.iter().filter(|&&o| o > 0.0) {
        assert!(
            names.contains_key(&(*id as u32).to_string()),
            "id {id} has no name"
        );
    }
}

#[test]
fn a_24_frame_gltf_animation_renders_and_resumes_after_an_interruption() {
    let dir = tempfile::tempdir().unwrap();
    let scene = example();
    let scene = scene.to_str().unwrap();
    // Interrupt a render of all 24 frames once a few are done.
    let mut child = Command::new(env!("CARGO_BIN_EXE_obscura"))
        .args(ANIMATION)
        .args([scene, "--frames", "1-24"])
        .current_dir(dir.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let mut done = 0;
    let start = Instant::now();
    for line in BufReader::new(stdout).lines() {
        let line = line.unwrap();
        if line.starts_with("frame ") {
            done += 1;
        }
        if done == 3 {
            let pid = child.id().to_string();
            Command::new("kill").args(["-INT", &pid]).status().unwrap();
        }
        // Reading goes on to the end: a closed pipe would fail the child's next line instead.
        assert!(start.elapsed() < Duration::from_secs(120), "too slow");
    }
    let status = child.wait().unwrap();
    let rendered: Vec<u32> = (1..=24)
        .filter(|n| dir.path().join(format!("anim.{n:04}.camera.json")).is_file())
        .collect();
    assert!(rendered.len() >= 3, "{rendered:?}");
    if !status.success() {
        // Interrupted mid-frame: the frame in flight is written but marked incomplete.
        let last = *rendered.last().unwrap();
        assert_eq!(
            json(&dir.path().join(format!("anim.{last:04}.camera.json")))["complete"],
            false
        );
    }

    // Restarted: the complete frames are skipped, the rest rendered.
    let out = obscura(
        &[&ANIMATION[..], &[scene, "--frames", "1-24"]].concat(),
        dir.path(),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    let rerendered = text.lines().filter(|l| l.starts_with("frame ")).count();
    assert!(rerendered < 24 && rerendered >= 24 - rendered.len(), "{text}");
    assert!(text.contains("complete frame(s) skipped"), "{text}");
    for n in 1..=24 {
        let camera = json(&dir.path().join(format!("anim.{n:04}.camera.json")));
        assert_eq!(camera["complete"], true, "frame {n}");
        assert_eq!(camera["frame"], n);
        assert!(dir.path().join(format!("anim.{n:04}.exr")).is_file());
    }
    // The camera moves between frames: world-to-camera differs.
    let (a, b) = (
        json(&dir.path().join("anim.0001.camera.json")),
        json(&dir.path().join("anim.0024.camera.json")),
    );
    assert_ne!(a["world_to_camera"]["open"], b["world_to_camera"]["open"]);
    // Flow crosses frames: backward only where a previous frame exists; the hero box moves right.
    let valid_back = channel(&dir.path().join("anim.0001.exr"), "flowValid.backward");
    assert!(valid_back.iter().all(|&v| v == 0.0));
    assert!(!channels(&dir.path().join("anim.0001.exr")).contains(&"flowBackward.X".to_string()));
    let f = dir.path().join("anim.0012.exr");
    let (valid, fx, ids) = (
        channel(&f, "flowValid.forward"),
        channel(&f, "flowForward.X"),
        channel(&f, "instanceId"),
    );
    assert!(channel(&f, "flowValid.backward").contains(&1.0));
    let ids_json = json(&dir.path().join("anim.0012.ids.json"));
    let hero = (ids_json["instances"].as_object().unwrap().iter())
        .find(|(_, v)| v["name"] == "hero")
        .map(|(k, _)| k.parse::<f32>().unwrap())
        .unwrap();
    let hero_flow: Vec<f32> = (0..fx.len())
        .filter(|&i| valid[i] == 1.0 && ids[i] == hero)
        .map(|i| fx[i])
        .collect();
    assert!(!hero_flow.is_empty());
    // The box moves 3 units/s right, the camera 0.5: at 24 fps the box drifts right on screen.
    let mean = hero_flow.iter().sum::<f32>() / hero_flow.len() as f32;
    assert!(mean > 0.1, "{mean}");
}

#[test]
fn an_animated_scene_without_frames_is_frame_one_and_flows_to_frame_two() {
    let dir = tempfile::tempdir().unwrap();
    let scene = example();
    let out = obscura(
        &[
            &ANIMATION[..5],
            &[
                "-q",
                "--aov",
                "flowForward,instanceId",
                "-o",
                "one.exr",
                scene.to_str().unwrap(),
            ],
        ]
        .concat(),
        dir.path(),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let camera = json(&dir.path().join("one.camera.json"));
    assert_eq!(camera["frame"], 1);
    let f = dir.path().join("one.exr");
    let fx = channel(&f, "flowForward.X");
    assert!(
        fx.iter().any(|&x| x.abs() > 0.01),
        "the boxes move between frames 1 and 2"
    );
}
