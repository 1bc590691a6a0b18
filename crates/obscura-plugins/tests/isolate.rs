//! Plugin isolation's promises: an isolated plugin behaves exactly like the same library in process
//! (rays bit for bit at every batch size, properties, the deep metric, parameters, unproject, the
//! lifecycle: tests/lifecycle.rs), and a plugin that crashes, aborts, exits or hangs costs the call it was serving —
//! counted — never the host, with a new worker taking the next call.
//!
//! The worker is this crate's `obscura-plugin-worker` binary (the `obscura` binary is its own worker).

#![cfg(target_os = "linux")]

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use obscura_host::driver::output_values;
use obscura_host::{Batch, CameraDesc, CameraStage, Registry, Violation};
use obscura_plugins::isolate::{Isolation, WorkerCommand};
use obscura_plugins::loader::{PluginSearch, ensure, load_all, load_file};
use obscura_sdk::{Format, ParamList, Point2, Vec3};

#[path = "support/plugin_build.rs"]
mod plugin_build;

use plugin_build::{compile_c, compile_c_fisheye};

fn isolation(timeout: Duration) -> Isolation {
    Isolation::all(
        WorkerCommand {
            program: env!("CARGO_BIN_EXE_obscura-plugin-worker").into(),
            args: Vec::new(),
        },
        timeout,
    )
}

fn isolated(dir: &Path, timeout: Duration) -> PluginSearch {
    PluginSearch::new(vec![dir.to_path_buf()]).with_isolation(Some(isolation(timeout)))
}

/// `tests/plugins/<file>.c` compiled with `defines` into `<dir>/<name>.so`.
fn compile(file: &str, defines: &[&str], dir: &Path, name: &str) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/plugins")
        .join(file);
    compile_c(&src, defines, dir, name, true)
}

/// The hostile plugin compiled with `defines` as `Hostile.so`, in a registry that runs it isolated.
fn isolated_hostile(defines: &[&str], timeout: Duration) -> (tempfile::TempDir, Registry) {
    let dir = tempfile::tempdir().unwrap();
    compile("hostile.c", defines, dir.path(), "Hostile");
    let mut reg = Registry::new();
    ensure(&mut reg, "Hostile", &isolated(dir.path(), timeout)).unwrap();
    (dir, reg)
}

fn camera(w: u32, h: u32) -> CameraDesc {
    let mut c = CameraDesc::new(Format::new(w, h));
    c.shutter = (0.0, 1.0);
    c
}

/// `n` samples spread over the screen window with varied lens and time samples.
fn batch(cam: &CameraDesc, n: usize, seed: usize) -> Batch {
    let p = cam.pixels();
    let mut b = Batch::with_capacity(n);
    for i in 0..n {
        let k = i * 7919 + seed * 104_729;
        let x = (k % 997) as f64 / 997.0 * f64::from(p.width());
        let y = (k / 997 % 991) as f64 / 991.0 * f64::from(p.height());
        b.push(
            cam.raster_to_screen(x, y),
            Point2::new((i % 13) as f32 / 13.0, (i % 17) as f32 / 17.0),
            (i % 97) as f32 / 97.0,
        );
    }
    b
}

fn bits(b: &Batch) -> Vec<u32> {
    let mut v = Vec::new();
    for ((r, t), c) in b.rays.iter().zip(&b.time).zip(&b.tint) {
        v.extend(output_values(r, *t, *c).map(f32::to_bits));
    }
    v
}

#[test]
fn an_isolated_plugin_gives_the_same_rays_properties_and_inverse_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let path = compile_c_fisheye(dir.path());
    let cam = camera(96, 64);
    let mut params = ParamList::new();
    params
        .push_text("float fov", &["200"], Some("--param".into()))
        .unwrap();

    let mut inproc = Registry::new();
    load_file(&mut inproc, &path).unwrap();
    let mut iso = Registry::new();
    let search = isolated(dir.path(), Duration::from_secs(10));
    assert_eq!(ensure(&mut iso, "CFisheye", &search).unwrap(), "CFisheye");
    assert_eq!(
        iso.get("CFisheye").unwrap().param_table(),
        inproc.get("CFisheye").unwrap().param_table()
    );
    let a = CameraStage::new(&mut inproc, "CFisheye", &params, &cam).unwrap();
    let b = CameraStage::new(&mut iso, "CFisheye", &params, &cam).unwrap();
    assert_eq!(a.properties(), b.properties());
    assert_eq!(a.environment(), b.environment(), "the deep metric create set");
    // 5000 rays outgrow the worker's first shared memory (4096 rays).
    for (seed, n) in [1usize, 7, 4096, 5000, 3].into_iter().enumerate() {
        let (mut x, mut y) = (batch(&cam, n, seed), batch(&cam, n, seed));
        let (rx, ry) = (a.run(&mut x), b.run(&mut y));
        assert_eq!(rx, ry);
        assert_eq!(bits(&x), bits(&y), "batch of {n}");
    }
    for p in [Vec3::new(0.3, -0.2, 1.0), Vec3::new(0.0, 0.0, -1.0), Vec3::ZERO] {
        let (u, v) = (
            a.projection().unproject(p, 0.25),
            b.projection().unproject(p, 0.25),
        );
        assert_eq!(
            u.map(|q| (q.x.to_bits(), q.y.to_bits())),
            v.map(|q| (q.x.to_bits(), q.y.to_bits()))
        );
    }
    // The host checks parameters against the table the worker sent: the same message.
    let mut bad = ParamList::new();
    bad.push_text("float fvo", &["90"], None).unwrap();
    let e1 = CameraStage::new(&mut inproc, "CFisheye", &bad, &cam)
        .unwrap_err()
        .to_string();
    let e2 = CameraStage::new(&mut iso, "CFisheye", &bad, &cam)
        .unwrap_err()
        .to_string();
    assert_eq!(e1, e2);
    assert!(e2.contains("did you mean \"fov\""), "{e2}");
}

/// Two threads project at once: each gets a worker, and the rays are still the in-process ones.
#[test]
fn concurrent_batches_each_get_a_worker_and_the_same_rays() {
    let dir = tempfile::tempdir().unwrap();
    let path = compile_c_fisheye(dir.path());
    let cam = camera(64, 64);
    let mut inproc = Registry::new();
    load_file(&mut inproc, &path).unwrap();
    let mut iso = Registry::new();
    ensure(
        &mut iso,
        "CFisheye",
        &isolated(dir.path(), Duration::from_secs(10)),
    )
    .unwrap();
    let a = CameraStage::new(&mut inproc, "CFisheye", &ParamList::new(), &cam).unwrap();
    let b = CameraStage::new(&mut iso, "CFisheye", &ParamList::new(), &cam).unwrap();
    std::thread::scope(|s| {
        for t in 0..3 {
            let (a, b, cam) = (&a, &b, &cam);
            s.spawn(move || {
                for k in 0..20 {
                    let (mut x, mut y) = (batch(cam, 300, t * 100 + k), batch(cam, 300, t * 100 + k));
                    a.run(&mut x);
                    assert!(b.run(&mut y).is_clean());
                    assert_eq!(bits(&x), bits(&y));
                }
            });
        }
    });
}

/// One hazard: a batch left of centre passes, one right of it is lost with `expect` in the report,
/// and the next batch (on a new worker) passes again.
fn survives(define: &str, timeout: Duration, expect: &str) {
    let (_dir, mut reg) = isolated_hostile(&[define], timeout);
    let cam = camera(32, 32);
    let stage = CameraStage::new(&mut reg, "Hostile", &ParamList::new(), &cam).unwrap();
    assert_eq!(stage.properties().field_of_view, Some(90.0));
    let left = |n: usize| {
        let mut b = Batch::with_capacity(n);
        for i in 0..n {
            b.push(
                Point2::new(-0.5, i as f32 / n as f32 - 0.5),
                Point2::new(0.5, 0.5),
                0.0,
            );
        }
        b
    };
    let mut good = left(64);
    assert!(stage.run(&mut good).is_clean());
    assert!(good.rays.iter().all(|r| !r.is_culled()));
    let mut bad = left(64);
    bad.screen[10].x = 0.25;
    let r = stage.run(&mut bad);
    assert_eq!(
        r.count(Violation::Failed),
        64,
        "{define}: {:?}",
        r.warning("Hostile")
    );
    assert!(bad.rays.iter().all(|r| r.is_culled()));
    let detail = &r.example(Violation::Failed).unwrap().detail;
    assert!(detail.contains(expect), "{define}: {detail}");
    assert!(detail.contains("the batch of 64 samples is lost"), "{detail}");
    let mut again = left(64);
    assert!(
        stage.run(&mut again).is_clean(),
        "{define}: a new worker serves the next batch"
    );
    assert_eq!(bits(&again), bits(&good));
}

#[test]
fn a_segfault_in_project_costs_its_batch() {
    survives(
        "SEGV_PROJECT",
        Duration::from_secs(10),
        "killed by signal 11 (SIGSEGV: segmentation fault)",
    );
}

#[test]
fn an_abort_in_project_costs_its_batch() {
    survives(
        "ABORT_PROJECT",
        Duration::from_secs(10),
        "killed by signal 6 (SIGABRT: abort)",
    );
}

#[test]
fn an_exit_in_project_costs_its_batch() {
    survives("EXIT_PROJECT", Duration::from_secs(10), "exited with status 3");
}

#[test]
fn an_infinite_loop_in_project_costs_its_batch_after_the_timeout() {
    let start = Instant::now();
    survives(
        "HANG_PROJECT",
        Duration::from_millis(300),
        "did not return within 0.300 s",
    );
    assert!(start.elapsed() < Duration::from_secs(8), "{:?}", start.elapsed());
}

/// A worker that cannot come up again (its `init` now crashes) costs the batch; after three such
/// starts in a row the factory stops starting workers, and each later batch fails at once.
#[test]
fn workers_that_cannot_come_up_are_not_started_forever() {
    let (_dir, mut reg) = isolated_hostile(&["SEGV_PROJECT", "INIT_ONCE"], Duration::from_secs(10));
    let cam = camera(8, 8);
    let stage = CameraStage::new(&mut reg, "Hostile", &ParamList::new(), &cam).unwrap();
    let run = |x: f32| {
        let mut b = Batch::with_capacity(4);
        for _ in 0..4 {
            b.push(Point2::new(x, 0.0), Point2::new(0.5, 0.5), 0.0);
        }
        let r = stage.run(&mut b);
        r.example(Violation::Failed).map(|e| e.detail.clone())
    };
    assert_eq!(run(-0.5), None);
    let crash = run(0.5).unwrap();
    assert!(crash.contains("SIGSEGV"), "{crash}");
    for _ in 0..3 {
        let e = run(-0.5).unwrap();
        assert!(
            e.contains("killed by signal 11 (SIGSEGV: segmentation fault) while catching up with the host"),
            "{e}"
        );
    }
    let start = Instant::now();
    let e = run(-0.5).unwrap();
    assert!(
        e.contains("no worker is started any more: the last 3 could not be brought up"),
        "{e}"
    );
    assert!(start.elapsed() < Duration::from_millis(50), "fails at once");
}

#[test]
fn a_crash_in_property_is_a_warning_and_rays_still_flow() {
    let (_dir, mut reg) = isolated_hostile(&["SEGV_PROPERTY"], Duration::from_secs(10));
    let stage = CameraStage::new(&mut reg, "Hostile", &ParamList::new(), &camera(8, 8)).unwrap();
    let warnings = stage.setup_warnings().join("\n");
    assert!(warnings.contains("SIGSEGV"), "{warnings}");
    let mut b = batch(&camera(8, 8), 50, 0);
    assert!(stage.run(&mut b).is_clean());
}

/// A library that dies while loading takes only itself: listing names it with the signal and lists
/// the rest.
#[test]
fn a_library_that_crashes_while_loading_is_named_and_the_others_listed() {
    let dir = tempfile::tempdir().unwrap();
    compile_c_fisheye(dir.path());
    compile("hostile.c", &["ABORT_CONSTRUCTOR"], dir.path(), "Aborting");
    compile("hostile.c", &["CRASH_ENTRY"], dir.path(), "Crashing");
    let mut reg = Registry::new();
    let (loaded, failed) = load_all(&mut reg, &isolated(dir.path(), Duration::from_secs(10)));
    assert_eq!(loaded, ["CFisheye"]);
    let text: Vec<String> = failed.iter().map(ToString::to_string).collect();
    assert_eq!(text.len(), 2, "{text:?}");
    assert!(
        text[0].contains("Aborting.so: the plugin's worker process was killed by signal 6 (SIGABRT: abort) while loading the library"),
        "{}",
        text[0]
    );
    assert!(
        text[1].contains("Crashing.so: the plugin's worker process was killed by signal 11"),
        "{}",
        text[1]
    );
}

/// A descriptor the loader refuses is refused in the worker with the in-process message, word for word.
#[test]
fn a_refused_descriptor_reads_the_same_from_a_worker() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/plugins/broken.c");
    for defect in ["BAD_VERSION", "NULL_PROJECT", "BAD_DEFAULT", "NULL_DESCRIPTOR"] {
        let dir = tempfile::tempdir().unwrap();
        let p = compile_c(&src, &[defect], dir.path(), "Broken", false);
        let e1 = load_file(&mut Registry::new(), &p).unwrap_err().to_string();
        let e2 = ensure(
            &mut Registry::new(),
            "Broken",
            &isolated(dir.path(), Duration::from_secs(10)),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(e1, e2, "{defect}");
    }
}

/// Validation runs in the host before any worker starts: the same message as in process.
#[test]
fn an_isolated_search_still_refuses_broken_files_with_the_same_message() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("Text.so");
    std::fs::write(&p, "hello\n").unwrap();
    let mut reg = Registry::new();
    let e1 = load_file(&mut reg, &p).unwrap_err().to_string();
    let e2 = ensure(&mut reg, "Text", &isolated(dir.path(), Duration::from_secs(10)))
        .unwrap_err()
        .to_string();
    assert_eq!(e1, e2);
    assert!(e2.contains("not loaded: it is a text file"), "{e2}");
}
