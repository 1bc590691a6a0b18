//! `cargo bench -p obscura-plugins --bench plugin_overhead`: the cost of calling a projection through the
//! plugin ABI. The same `TinyPlanet` code runs built in (the example crate linked as an rlib) and loaded
//! from its `cdylib` through `obscura_projection_entry` (built here with `cargo build --release` into
//! `target/plugin-bench`, the same optimisation settings as this bench), at batches of 256 samples:
//!
//! - `project`: the projection call alone;
//! - `camera_stage`: the host's whole camera stage (aperture and shutter warps, default rays,
//!   `project`, validation), which is what a render pays per batch.
//!
//! divan reports items/s: each item is one ray. The target is at most 3 % more time through the ABI.
//!
//! `isolation` runs the camera stage at a batch of 4096 through the same library loaded in process
//! (`plugin`) and in a worker process (`isolated`, `--isolate-plugins`: the batch copied into and out of
//! the shared memory, one request and reply over the socket). The target is at most 15 % more time
//! per batch than in process.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use divan::{Bencher, counter::ItemsCount};
use obscura_example_tiny_planet::TinyPlanetFactory;
use obscura_host::{CameraStage, Registry};
use obscura_plugins::isolate::{Isolation, WorkerCommand};
use obscura_plugins::loader::{PluginSearch, ensure};
use obscura_sdk::{ParamList, Projection, ProjectionContext, ProjectionFactory, RayGeometry, Rgb};

const BATCH: usize = 256;
const WAYS: [&str; 2] = ["builtin", "plugin"];
const ISOLATION_BATCH: usize = 4096;
const ISOLATION_WAYS: [&str; 2] = ["plugin", "isolated"];

mod common;

use common::{camera, samples};

fn main() {
    divan::main();
}

/// The release cdylib of the tiny-planet example, as `TinyPlanet.so` in a directory of its own.
fn plugin_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let target = Path::new(env!("CARGO_TARGET_TMPDIR"))
            .parent()
            .expect("CARGO_TARGET_TMPDIR is under the target directory")
            .join("plugin-bench");
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(cargo)
            .current_dir(&root)
            .args([
                "build",
                "--quiet",
                "--release",
                "--lib",
                "-p",
                "obscura-example-tiny-planet",
            ])
            .arg("--target-dir")
            .arg(&target)
            .status()
            .expect("cannot run cargo");
        assert!(status.success(), "building the tiny-planet plugin failed");
        let built = target.join("release").join(format!(
            "{}obscura_example_tiny_planet.{}",
            std::env::consts::DLL_PREFIX,
            std::env::consts::DLL_EXTENSION
        ));
        let dir = target.join("plugins");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::copy(
            &built,
            dir.join(format!("TinyPlanet.{}", std::env::consts::DLL_EXTENSION)),
        )
        .unwrap();
        dir
    })
}

/// A registry where `TinyPlanet` is the built-in factory or the loaded plugin.
fn registry(way: &str) -> Registry {
    let mut reg = Registry::new();
    if way == "builtin" {
        reg.register(Box::new(TinyPlanetFactory), "").unwrap();
    } else {
        let mut search = PluginSearch::new(vec![plugin_dir().to_path_buf()]);
        if way == "isolated" {
            let worker = WorkerCommand {
                program: env!("CARGO_BIN_EXE_obscura-plugin-worker").into(),
                args: Vec::new(),
            };
            search = search.with_isolation(Some(Isolation::all(worker, std::time::Duration::from_secs(10))));
        }
        ensure(&mut reg, "TinyPlanet", &search).unwrap();
    }
    assert_eq!(reg.get("TinyPlanet").unwrap().name(), TinyPlanetFactory.name());
    reg
}

#[divan::bench(args = WAYS)]
fn project(bencher: Bencher, way: &str) {
    let cam = camera();
    let mut env = cam.environment();
    let p: Box<dyn Projection> = registry(way)
        .create("TinyPlanet", &mut env, &ParamList::new())
        .unwrap();
    let b = samples(&cam, BATCH);
    let mut time = b.time.clone();
    let mut rays = vec![RayGeometry::CULLED; BATCH];
    let mut tint = vec![Rgb::WHITE; BATCH];
    bencher.counter(ItemsCount::new(BATCH)).bench_local(|| {
        let mut ctx =
            ProjectionContext::new(&b.screen, &b.lens, &b.lens, &mut time, &mut rays, &mut tint).unwrap();
        p.project(black_box(&mut ctx));
        black_box(&rays);
    });
}

#[divan::bench(args = WAYS)]
fn camera_stage(bencher: Bencher, way: &str) {
    let cam = camera();
    let stage = CameraStage::new(&mut registry(way), "TinyPlanet", &ParamList::new(), &cam).unwrap();
    let template = samples(&cam, BATCH);
    let mut b = template.clone();
    bencher.counter(ItemsCount::new(BATCH)).bench_local(|| {
        b.time.clone_from(&template.time);
        let report = stage.run(black_box(&mut b));
        black_box((&b.rays, report.samples));
    });
}

#[divan::bench(args = ISOLATION_WAYS)]
fn isolation(bencher: Bencher, way: &str) {
    let cam = camera();
    let stage = CameraStage::new(&mut registry(way), "TinyPlanet", &ParamList::new(), &cam).unwrap();
    let template = samples(&cam, ISOLATION_BATCH);
    let mut b = template.clone();
    bencher.counter(ItemsCount::new(ISOLATION_BATCH)).bench_local(|| {
        b.time.clone_from(&template.time);
        let report = stage.run(black_box(&mut b));
        assert!(report.is_clean());
        black_box((&b.rays, report.samples));
    });
}
