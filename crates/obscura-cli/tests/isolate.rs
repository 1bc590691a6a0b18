//! End to end: `--isolate-plugins` and `OBSCURA_ISOLATE_PLUGINS` (issue 16). A plugin that crashes,
//! aborts or hangs while projecting costs the batches it was given — counted in the summary and named
//! in a warning — and the render completes with exit 0; a library that aborts while loading is named
//! and the other plugins are listed; an isolated plugin's rays are the in-process ones.
//!
//! The hostile plugin is `crates/obscura-plugins/tests/plugins/hostile.c`: it strikes on batches holding
//! a sample right of screen x = 0, so the left tiles of a render survive.

#![cfg(target_os = "linux")]

use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::{Command, Output};

#[path = "../../obscura-plugins/tests/support/plugin_build.rs"]
mod plugin_build;

use plugin_build::{compile_c, compile_c_fisheye};

fn hostile(define: &str, dir: &Path, name: &str) {
    let src = plugin_build::workspace().join("crates/obscura-plugins/tests/plugins/hostile.c");
    compile_c(&src, &[define], dir, name, true);
}

fn obscura(args: &[&str], dir: &Path, isolate_var: Option<&str>) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_obscura"));
    cmd.args(args)
        .current_dir(dir)
        .env_remove("OBSCURA_PLUGIN_PATH")
        .env_remove("OBSCURA_ISOLATE_PLUGINS");
    if let Some(v) = isolate_var {
        cmd.env("OBSCURA_ISOLATE_PLUGINS", v);
    }
    cmd.output().expect("the obscura binary runs")
}

/// The number before `what` in `text` (`… 1234 lost to failed project calls …`).
fn count_before(text: &str, what: &str) -> u64 {
    let at = text
        .find(what)
        .unwrap_or_else(|| panic!("no \"{what}\" in {text}"));
    text[..at]
        .split_whitespace()
        .last()
        .and_then(|n| n.trim_matches(',').parse().ok())
        .unwrap_or_else(|| panic!("no count before \"{what}\" in {text}"))
}

#[test]
fn a_render_survives_a_plugin_that_segfaults_aborts_or_hangs() {
    for (define, signature) in [
        (
            "SEGV_PROJECT",
            "killed by signal 11 (SIGSEGV: segmentation fault)",
        ),
        ("ABORT_PROJECT", "killed by signal 6 (SIGABRT: abort)"),
        ("HANG_PROJECT", "did not return within 0.200 s"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        hostile(define, dir.path(), "Hostile");
        let pp = dir.path().to_str().unwrap();
        let r = obscura(
            &[
                "render",
                "--isolate-plugins",
                "--plugin-timeout",
                "0.2",
                "--plugin-path",
                pp,
                "-p",
                "Hostile",
                "--format",
                "64x32",
                "--spp",
                "1",
                "--threads",
                "2",
                "-o",
                "h.exr",
            ],
            dir.path(),
            None,
        );
        let (out, err) = (
            String::from_utf8_lossy(&r.stdout),
            String::from_utf8_lossy(&r.stderr),
        );
        assert!(r.status.success(), "{define}: {err}");
        assert!(dir.path().join("h.exr").exists());
        // About half the 2048 samples are lost (the right tiles, and left ones whose filter margin
        // crosses x = 0); the rest rendered.
        let (samples, lost) = (
            count_before(&out, "camera samples"),
            count_before(&out, "lost to failed project calls"),
        );
        assert!(
            lost >= samples / 2 && lost < samples,
            "{define}: {lost} of {samples}: {out}"
        );
        assert!(
            err.contains("warning: projection Hostile broke the projection contract on"),
            "{err}"
        );
        assert!(
            err.contains(&format!("{lost} samples lost to a failed project call")),
            "{define}: {err}"
        );
        assert!(err.contains(signature), "{define}: {err}");
    }
}

/// Regression (issue 16): the summary said "0 culled" when a plugin's failing batches lost the
/// samples; it now counts them, in process as isolated.
#[test]
fn the_summary_counts_samples_lost_to_failed_project_calls() {
    let dir = tempfile::tempdir().unwrap();
    let src = plugin_build::workspace().join("crates/obscura-plugins/tests/plugins/broken.c");
    compile_c(&src, &["PROJECT_ERROR"], dir.path(), "Broken", false);
    let pp = dir.path().to_str().unwrap();
    for extra in [None, Some("--isolate-plugins")] {
        let mut args = vec![
            "render",
            "--plugin-path",
            pp,
            "-p",
            "Broken",
            "--format",
            "16x8",
            "--spp",
            "2",
            "-o",
            "b.exr",
        ];
        args.extend(extra);
        let r = obscura(&args, dir.path(), None);
        let out = String::from_utf8_lossy(&r.stdout);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        assert!(
            out.contains("256 camera samples, 0 culled, 256 lost to failed project calls"),
            "{extra:?}: {out}"
        );
        let r = obscura(
            &[
                "rays",
                "--plugin-path",
                pp,
                "-p",
                "Broken",
                "--format",
                "16x8",
                "-o",
                "r.exr",
            ],
            dir.path(),
            None,
        );
        let out = String::from_utf8_lossy(&r.stdout);
        assert!(
            out.contains("0 culled by the projection, 128 lost to failed project calls, 0 culled for breaking the contract"),
            "{out}"
        );
    }
}

#[test]
fn isolated_rays_are_the_in_process_rays() {
    let dir = tempfile::tempdir().unwrap();
    compile_c_fisheye(dir.path());
    let pp = dir.path().to_str().unwrap();
    let base = [
        "rays",
        "--plugin-path",
        pp,
        "-p",
        "CFisheye",
        "--param",
        "fov=190",
        "--format",
        "40x30",
    ];
    let a = obscura(&[&base[..], &["-o", "a.exr"]].concat(), dir.path(), None);
    let b = obscura(
        &[&base[..], &["--isolate-plugins", "-o", "b.exr"]].concat(),
        dir.path(),
        None,
    );
    assert!(
        a.status.success() && b.status.success(),
        "{}",
        String::from_utf8_lossy(&b.stderr)
    );
    let read = |f: &str| {
        let image = exr::prelude::read_all_flat_layers_from_file(dir.path().join(f)).unwrap();
        let mut v: Vec<(String, Vec<u32>)> = image.layer_data[0]
            .channel_data
            .list
            .iter()
            .map(|c| {
                (
                    c.name.to_string(),
                    c.sample_data.values_as_f32().map(f32::to_bits).collect(),
                )
            })
            .collect();
        v.sort();
        v
    };
    assert_eq!(read("a.exr"), read("b.exr"));
}

/// Without isolation a library whose constructor aborts takes `obscura plugins` down (the system
/// loader runs it; nothing can be checked first). Isolated — for every plugin, or for that one by
/// name — it is a warning naming the file and the signal, and the other plugins are listed.
#[test]
fn a_library_that_aborts_while_loading_is_named_and_the_listing_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    compile_c_fisheye(dir.path());
    hostile("ABORT_CONSTRUCTOR", dir.path(), "Aborting");
    let truncated = std::fs::read(dir.path().join("CFisheye.so")).unwrap();
    std::fs::write(dir.path().join("Cut.so"), &truncated[..truncated.len() / 2]).unwrap();
    let pp = dir.path().to_str().unwrap();
    let r = obscura(&["plugins", "--names", "--plugin-path", pp], dir.path(), None);
    assert_eq!(
        r.status.signal(),
        Some(6),
        "the abort is the library's, in this process"
    );
    for (flag, var) in [(Some("--isolate-plugins"), None), (None, Some("Aborting"))] {
        let mut args = vec!["plugins", "--names", "--plugin-path", pp];
        args.extend(flag);
        let r = obscura(&args, dir.path(), var);
        let (out, err) = (
            String::from_utf8_lossy(&r.stdout),
            String::from_utf8_lossy(&r.stderr),
        );
        assert!(r.status.success(), "{err}");
        assert!(out.lines().any(|l| l == "CFisheye"), "{out}");
        assert!(!out.lines().any(|l| l == "Aborting"), "{out}");
        let warnings: Vec<&str> = err.lines().filter(|l| l.starts_with("warning: ")).collect();
        assert_eq!(warnings.len(), 2, "{err}");
        assert!(
            warnings[0].ends_with("Aborting.so: the plugin's worker process was killed by signal 6 (SIGABRT: abort) while loading the library"),
            "{err}"
        );
        assert!(
            warnings[1].contains("Cut.so: not loaded: it is truncated"),
            "{err}"
        );
    }
}

#[test]
fn check_and_stmap_run_an_isolated_plugin() {
    let dir = tempfile::tempdir().unwrap();
    compile_c_fisheye(dir.path());
    let pp = dir.path().to_str().unwrap();
    let r = obscura(
        &[
            "check",
            "--isolate-plugins",
            "--plugin-path",
            pp,
            "CFisheye",
            "--format",
            "32x32",
            "--threads",
            "2",
        ],
        dir.path(),
        None,
    );
    assert!(
        r.status.success(),
        "{}{}",
        String::from_utf8_lossy(&r.stdout),
        String::from_utf8_lossy(&r.stderr)
    );
    let r = obscura(
        &[
            "stmap",
            "--isolate-plugins",
            "--plugin-path",
            pp,
            "--from",
            "CFisheye",
            "--to",
            "PxrPerspective",
            "--format",
            "24x16",
            "-o",
            "m.exr",
        ],
        dir.path(),
        None,
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(dir.path().join("m.exr").exists());
}

/// `obscura check` of a crashing plugin, isolated, is a failed check naming the signal (exit 1), not a
/// crashed checker.
#[test]
fn check_reports_an_isolated_crash_as_a_failed_check() {
    let dir = tempfile::tempdir().unwrap();
    hostile("SEGV_PROJECT", dir.path(), "Hostile");
    let pp = dir.path().to_str().unwrap();
    let r = obscura(
        &[
            "check",
            "--isolate-plugins",
            "--plugin-path",
            pp,
            "Hostile",
            "--format",
            "16x16",
            "--threads",
            "2",
        ],
        dir.path(),
        None,
    );
    let out = String::from_utf8_lossy(&r.stdout);
    assert_eq!(r.status.code(), Some(1), "{out}");
    let line = out
        .lines()
        .find(|l| l.starts_with("FAILED       no errors returned by project"))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(
        line.contains("killed by signal 11 (SIGSEGV: segmentation fault) in project"),
        "{line}"
    );
}

#[test]
fn a_plugin_timeout_that_is_not_positive_seconds_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let r = obscura(&["plugins", "--names", "--plugin-timeout", "0"], dir.path(), None);
    assert_eq!(r.status.code(), Some(2));
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.contains("'0': expected a number of seconds in (0, 86400]"),
        "{err}"
    );
}

/// The worker processes that have `marker` (a path) among their mapped files.
fn workers_mapping(marker: &str) -> Vec<u32> {
    std::fs::read_dir("/proc")
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok())
        .filter(|pid| std::fs::read_to_string(format!("/proc/{pid}/maps")).is_ok_and(|m| m.contains(marker)))
        .collect()
}

/// A worker stuck in a plugin's infinite loop does not outlive its host: killed with SIGKILL (no
/// chance to clean up), the host's workers end within moments anyway.
#[test]
fn a_hung_worker_does_not_outlive_a_killed_host() {
    let dir = tempfile::tempdir().unwrap();
    hostile("HANG_PROJECT", dir.path(), "Hostile");
    let pp = dir.path().to_str().unwrap();
    let mut host = Command::new(env!("CARGO_BIN_EXE_obscura"))
        .args([
            "render",
            "--isolate-plugins",
            "--plugin-timeout",
            "600",
            "--plugin-path",
            pp,
            "-p",
            "Hostile",
            "--format",
            "32x32",
            "--spp",
            "1",
            "--threads",
            "1",
            "-o",
            "h.exr",
        ])
        .current_dir(dir.path())
        .env_remove("OBSCURA_ISOLATE_PLUGINS")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let marker = dir.path().join("Hostile.so").display().to_string();
    let start = std::time::Instant::now();
    while workers_mapping(&marker).is_empty() {
        assert!(start.elapsed().as_secs() < 30, "no worker started");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // Wait until a worker is in the loop: it has spent 0.3 s of CPU time (utime + stime, in clock
    // ticks of 1/100 s, fields 14 and 15 of /proc/PID/stat).
    let cpu_ticks = |pid: u32| -> u64 {
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
        let after_name = stat.rsplit_once(')').map_or("", |(_, rest)| rest);
        let fields: Vec<&str> = after_name.split_whitespace().collect();
        fields.get(11).and_then(|u| u.parse::<u64>().ok()).unwrap_or(0)
            + fields.get(12).and_then(|s| s.parse::<u64>().ok()).unwrap_or(0)
    };
    while !workers_mapping(&marker)
        .into_iter()
        .any(|pid| cpu_ticks(pid) >= 30)
    {
        assert!(start.elapsed().as_secs() < 60, "no worker entered the loop");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    host.kill().unwrap();
    host.wait().unwrap();
    let killed = std::time::Instant::now();
    while !workers_mapping(&marker).is_empty() {
        assert!(
            killed.elapsed().as_secs() < 5,
            "workers still running: {:?}",
            workers_mapping(&marker)
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}
