//! The edges of a run (issue 16, point 5): SIGINT and SIGTERM during a render write the rendered part,
//! marked partial, and exit 130 and 143; a closed stdout ends a command quietly; every output file is
//! the same bytes run to run.

mod support;

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use exr::prelude::read_all_flat_layers_from_file;
use support::{fixture, text, text_attribute};

fn obscura_in(dir: &std::path::Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_obscura"));
    c.current_dir(dir).env_remove("OBSCURA_PLUGIN_PATH");
    c
}

/// A scene that prepares at once and renders for many seconds.
const SLOW_SCENE: &str = "Format 512 384 1\nHider \"raytrace\" \"int maxsamples\" [128]\n\
    Display \"slow.exr\" \"openexr\" \"rgba\"\nWorldBegin\nLight \"PxrDomeLight\" \"d\"\n\
    Translate 0 0 5\nSphere 1 -1 1 360\nWorldEnd\n";

/// Starts the slow render, waits `wait`, sends `signal` with `kill`, and returns the exit status, stderr and the EXR's `obscura:partial` attribute.
fn interrupt(signal: &str, wait: Duration) -> (Option<i32>, String, Option<String>) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("slow.rib"), SLOW_SCENE).unwrap();
    let child = obscura_in(dir.path())
        .args(["render", "slow.rib", "--threads", "2", "--quiet"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(wait);
    let killed = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let start = Instant::now();
    let out = child.wait_with_output().unwrap();
    assert!(
        start.elapsed() < Duration::from_secs(120),
        "the tiles in flight take long"
    );
    let partial = read_all_flat_layers_from_file(dir.path().join("slow.exr"))
        .ok()
        .and_then(|image| text_attribute(&image, "obscura:partial"));
    // Nothing but the outputs: no temporary file is left.
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(names.is_empty(), "{names:?}");
    (out.status.code(), text(&out.stderr), partial)
}

#[test]
fn sigint_and_sigterm_write_the_rendered_part_marked_partial_and_exit_130_and_143() {
    for (signal, code) in [("INT", 130), ("TERM", 143)] {
        // The signal should reach the render while it renders; on a loaded machine loading and
        // preparing may still run, and then the process must end at once with the same status.
        for wait in [2500, 6000, 15000] {
            let (status, stderr, partial) = interrupt(signal, Duration::from_millis(wait));
            assert_eq!(status, Some(code), "SIG{signal}: {stderr}");
            if !stderr.contains("interrupted (") {
                assert!(partial.is_none() && !stderr.contains("panicked"), "{stderr}");
                continue;
            }
            assert!(stderr.contains(&format!("interrupted (SIG{signal})")), "{stderr}");
            assert!(
                stderr.contains("(marked in the EXR header as obscura:partial)"),
                "{stderr}"
            );
            let partial =
                partial.unwrap_or_else(|| panic!("SIG{signal}: no obscura:partial attribute; {stderr}"));
            assert!(
                partial.starts_with("interrupted: ")
                    && partial.contains("tiles rendered; missing tiles (x0-x1,y0-y1, end exclusive): "),
                "{partial}"
            );
            // 16-pixel tiles of a 512x384 image: the last one is missing unless it was rendered.
            assert!(
                partial.contains(",368-384") || partial.contains("0-16,"),
                "{partial}"
            );
            break;
        }
    }
}

#[test]
fn a_closed_stdout_ends_a_command_quietly() {
    let dir = tempfile::tempdir().unwrap();
    for args in [
        &["plugins"][..],
        &["plugins", "--names"],
        &["check", "PxrPerspective", "--format", "16x12"],
    ] {
        let mut child = obscura_in(dir.path())
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // The reader goes away before anything is written: every write meets a broken pipe.
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {stderr}");
        assert!(
            !stderr.contains("panicked") && !stderr.contains("Broken pipe"),
            "{args:?}: {stderr}"
        );
    }
}

/// Issue 16: `rays` and `stmap` EXRs differed run to run (header attributes in hash order).
#[test]
fn every_output_is_the_same_bytes_run_to_run() {
    let dir = tempfile::tempdir().unwrap();
    let cameras = fixture("cameras.txt");
    let runs: [&[&str]; 3] = [
        &[
            "rays",
            "--format",
            "32x24",
            "--param",
            "fov=40",
            "--param",
            "fStop=2.8",
            "--samples",
            "1",
            "-o",
            "OUT.exr",
        ],
        &[
            "rays",
            "--calibration",
            &cameras,
            "--camera",
            "2",
            "--format",
            "32x24",
            "-o",
            "OUT.exr",
        ],
        &[
            "stmap",
            "--from",
            "Fisheye",
            "--from-param",
            "fov=180",
            "--to",
            "PxrSphereCamera",
            "--format",
            "32x16",
            "-o",
            "OUT.exr",
        ],
    ];
    for args in runs {
        let mut files = Vec::new();
        for k in 0..3 {
            let name = format!("out{k}.exr");
            let args: Vec<&str> = args
                .iter()
                .map(|a| if *a == "OUT.exr" { name.as_str() } else { a })
                .collect();
            let out = obscura_in(dir.path()).args(&args).output().unwrap();
            assert!(out.status.success(), "{args:?}: {}", text(&out.stderr));
            files.push(std::fs::read(dir.path().join(&name)).unwrap());
        }
        assert!(files.iter().all(|f| f == &files[0]), "{args:?}: the files differ");
    }
}
