//! End to end: a frame rendered as tiles and merged is the one-process render byte for byte;
//! `obscura merge` names what does not belong or is missing; progress lines a farm reads; sidecars
//! that name their images relative to themselves.

use std::path::{Path, PathBuf};

mod support;

use support::{obscura_in as obscura, text};

fn classic() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/scenes/classic.rib")
        .to_string_lossy()
        .into_owned()
}

fn boxes() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/animated/boxes.gltf")
        .to_string_lossy()
        .into_owned()
}

/// Asserts that `haystack` holds `needle`, showing it when not.
fn assert_has(haystack: &str, needle: &str) {
    assert!(haystack.contains(needle), "expected {needle:?} in:\n{haystack}");
}

fn run(args: &[&str], dir: &Path) -> std::process::Output {
    let out = obscura(args, dir);
    assert!(out.status.success(), "{args:?}: {}", text(&out.stderr));
    out
}

/// The files of `dir`, sorted.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}

fn assert_same_files(full: &Path, merged: &Path) {
    let names = files(full);
    assert!(!names.is_empty());
    for f in names {
        let name = f.file_name().unwrap();
        let same = std::fs::read(&f).unwrap() == std::fs::read(merged.join(name)).unwrap();
        assert!(same, "{} differs", name.to_string_lossy());
    }
}

#[test]
fn a_rib_frame_in_2x2_tiles_merges_to_the_one_process_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("full")).unwrap();
    std::fs::create_dir_all(d.join("tiles")).unwrap();
    let scene = classic();
    let common = [
        "render", &scene, "--format", "40x30", "--spp", "2", "--aov", "all", "-q",
    ];
    run(&[&common[..], &["-o", "full/c.exr"]].concat(), d);
    for i in ["0", "1", "2", "3"] {
        run(
            &[
                &common[..],
                &["-o", "tiles/c.exr", "--tiles", "2x2", "--tile-index", i],
            ]
            .concat(),
            d,
        );
    }
    let out = run(&["merge", "tiles/c.exr", "--tiles", "2x2"], d);
    assert_has(&text(&out.stdout), "1 frame(s) complete");
    for f in files(&d.join("full")) {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        let same = std::fs::read(&f).unwrap() == std::fs::read(d.join("tiles").join(&name)).unwrap();
        assert!(same, "{name} differs");
    }
    // The camera sidecar names its images relative to itself.
    let camera: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("full/c.camera.json")).unwrap()).unwrap();
    assert_eq!(camera["images"], serde_json::json!(["c.exr", "c.png"]));
}

#[test]
fn an_animation_in_bands_merges_frame_by_frame_with_its_flow() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("full")).unwrap();
    std::fs::create_dir_all(d.join("bands")).unwrap();
    let scene = boxes();
    let common = [
        "render", &scene, "--format", "32x18", "--spp", "1", "--aov", "all", "--frames", "2-4", "-q",
    ];
    run(&[&common[..], &["-o", "full/b.####.exr"]].concat(), d);
    for t in ["0/3", "1/3", "2/3"] {
        run(
            &[&common[..], &["-o", "bands/b.####.exr", "--tile", t]].concat(),
            d,
        );
    }
    run(
        &[
            "merge",
            "bands/b.####.exr",
            "--tiles",
            "1x3",
            "--frames",
            "2-4",
            "-q",
        ],
        d,
    );
    assert_same_files(&d.join("full"), &d.join("bands"));
}

#[test]
fn merge_names_missing_incomplete_and_odd_tiles_and_keeps_a_good_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = classic();
    let common = ["render", &scene, "--format", "24x16", "--spp", "1", "-q"];
    for i in ["0", "1"] {
        run(
            &[&common[..], &["-o", "c.exr", "--tiles", "2x1", "--tile-index", i]].concat(),
            d,
        );
    }
    // Another size in tile 1.
    run(
        &[
            "render",
            &scene,
            "--format",
            "26x16",
            "--spp",
            "1",
            "-q",
            "-o",
            "odd.exr",
            "--tiles",
            "2x1",
            "--tile-index",
            "1",
        ],
        d,
    );
    std::fs::copy(d.join("c.tile1-2x1.exr"), d.join("good1.exr")).unwrap();
    std::fs::copy(d.join("odd.tile1-2x1.exr"), d.join("c.tile1-2x1.exr")).unwrap();
    let out = obscura(&["merge", "c.exr", "--tiles", "2x1"], d);
    assert_eq!(out.status.code(), Some(1));
    let e = text(&out.stderr);
    assert!(
        e.contains("c.tile1-2x1.exr: does not belong with c.tile0-2x1.exr: its frame is 26×16"),
        "{e}"
    );
    assert!(!d.join("c.exr").exists());
    // A good merge, then a truncated tile: the error names it and the good image stays.
    std::fs::copy(d.join("good1.exr"), d.join("c.tile1-2x1.exr")).unwrap();
    run(&["merge", "c.exr", "--tiles", "2x1"], d);
    let good = std::fs::read(d.join("c.exr")).unwrap();
    let bytes = std::fs::read(d.join("good1.exr")).unwrap();
    std::fs::write(d.join("c.tile1-2x1.exr"), &bytes[..bytes.len() / 3]).unwrap();
    let out = obscura(&["merge", "c.exr", "--tiles", "2x1"], d);
    assert_eq!(out.status.code(), Some(1));
    assert_has(&text(&out.stderr), "c.tile1-2x1.exr: cannot read this tile");
    assert_eq!(std::fs::read(d.join("c.exr")).unwrap(), good);
    // A missing tile is named with its index.
    std::fs::remove_file(d.join("c.tile1-2x1.exr")).unwrap();
    let out = obscura(&["merge", "c.exr", "--tiles", "2x1"], d);
    assert_has(
        &text(&out.stderr),
        "missing tile(s) of 2x1: tile 1 (c.tile1-2x1.exr)",
    );
}

#[test]
fn collect_without_tiles_lists_incomplete_frames() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = boxes();
    run(
        &[
            "render",
            &scene,
            "--format",
            "16x9",
            "--spp",
            "1",
            "--frames",
            "1-3",
            "-o",
            "b.####.exr",
            "-q",
        ],
        d,
    );
    run(&["merge", "b.####.exr", "--frames", "1-3"], d);
    // Frame 2 marked incomplete, frame 3 gone.
    let camera = d.join("b.0002.camera.json");
    let t = std::fs::read_to_string(&camera)
        .unwrap()
        .replace("\"complete\": true", "\"complete\": false");
    std::fs::write(&camera, t).unwrap();
    std::fs::remove_file(d.join("b.0003.exr")).unwrap();
    let out = obscura(&["merge", "b.####.exr", "--frames", "1-3"], d);
    assert_eq!(out.status.code(), Some(1));
    let e = text(&out.stderr);
    assert!(
        e.contains("b.0002.camera.json: incomplete") && e.contains("b.0003.exr: missing"),
        "{e}"
    );
    assert!(e.contains("2 of 3 frame(s) incomplete: 2,3"), "{e}");
}

#[test]
fn progress_lines_for_openjd_tractor_and_logs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = boxes();
    let common = [
        "render",
        &scene,
        "--format",
        "16x9",
        "--spp",
        "1",
        "--frames",
        "1-2",
        "-o",
        "b.####.exr",
    ];
    let out = run(&[&common[..], &["--progress", "openjd", "-q"]].concat(), d);
    let lines: Vec<String> = text(&out.stdout).lines().map(str::to_string).collect();
    assert_eq!(lines[0], "openjd_status: rendering frame 1 (1 of 2)", "{lines:?}");
    assert!(lines.contains(&"openjd_progress: 50.0".to_string()), "{lines:?}");
    assert_eq!(lines.last().unwrap(), "openjd_progress: 100.0");
    let values: Vec<f64> = (lines.iter())
        .filter_map(|l| l.strip_prefix("openjd_progress: "))
        .map(|v| v.parse().unwrap())
        .collect();
    assert!(values.windows(2).all(|w| w[0] < w[1]), "{values:?}");
    std::fs::remove_file(d.join("b.0002.camera.json")).unwrap();
    let out = run(&[&common[..], &["--progress", "tractor", "-q"]].concat(), d);
    assert_eq!(
        text(&out.stdout).lines().last(),
        Some("TR_PROGRESS 100%"),
        "{}",
        text(&out.stdout)
    );
    // stderr is a pipe here: plain lines by default.
    std::fs::remove_file(d.join("b.0002.camera.json")).unwrap();
    let out = run(&common, d);
    assert_has(
        &text(&out.stderr),
        "progress: frame 2 (2 of 2) 100%, overall 100.0%",
    );
}

#[test]
fn deep_and_flat_displays_of_a_rib_merge_to_the_one_process_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rib = "Format 20 14 1\nPixelSamples 1 1\nProjection \"perspective\" \"fov\" [50]\nTranslate 0 0 4\n\
               Display \"beauty.exr\" \"openexr\" \"rgba\"\nDisplay \"+deep.exr\" \"deepexr\" \"rgba\"\n\
               WorldBegin\nSphere 1 -1 1 360\nTranslate 1 0.5 1\nSphere 0.6 -0.6 0.6 360\nWorldEnd\n";
    for sub in ["full", "tiles"] {
        std::fs::create_dir_all(d.join(sub)).unwrap();
        std::fs::write(d.join(sub).join("scene.rib"), rib).unwrap();
    }
    run(&["render", "scene.rib", "-q"], &d.join("full"));
    for i in ["0", "1", "2", "3", "4", "5"] {
        run(
            &["render", "scene.rib", "-q", "--tiles", "3x2", "--tile-index", i],
            &d.join("tiles"),
        );
    }
    run(
        &["merge", "beauty.exr", "deep.exr", "--tiles", "3x2", "-q"],
        &d.join("tiles"),
    );
    assert_eq!(
        files(&d.join("full"))
            .iter()
            .map(|f| f.file_name().unwrap().to_owned())
            .collect::<Vec<_>>(),
        ["beauty.exr", "beauty.png", "deep.exr", "scene.rib"]
    );
    assert_same_files(&d.join("full"), &d.join("tiles"));
}

/// The most threads the process `child` had at once, polled until it exits.
fn peak_threads(mut child: std::process::Child) -> usize {
    let tasks = PathBuf::from(format!("/proc/{}/task", child.id()));
    let mut peak = 0;
    while child.try_wait().unwrap().is_none() {
        if let Ok(list) = std::fs::read_dir(&tasks) {
            peak = peak.max(list.count());
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    peak
}

#[test]
fn without_threads_the_render_uses_the_cpus_of_its_affinity_mask() {
    let available = std::thread::available_parallelism().unwrap().get();
    if available < 2 {
        eprintln!("one CPU: nothing to restrict");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = classic();
    let args = [
        "render", &scene, "--format", "96x72", "--spp", "4", "-q", "-o", "a.exr",
    ];
    let spawn = |taskset: bool| {
        let mut c = if taskset {
            let mut c = std::process::Command::new("taskset");
            c.args(["-c", "0", env!("CARGO_BIN_EXE_obscura")]);
            c
        } else {
            std::process::Command::new(env!("CARGO_BIN_EXE_obscura"))
        };
        c.args(args)
            .current_dir(dir.path())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("taskset (util-linux) and obscura run")
    };
    let all = peak_threads(spawn(false));
    let one = peak_threads(spawn(true));
    // The worker pool shrinks from one thread per CPU to one (and any other per-CPU pool with it).
    assert!(
        all - one >= available - 1,
        "threads: {all} unrestricted, {one} on one CPU"
    );
}
