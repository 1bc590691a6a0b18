//! `cargo bench -p obscura-plugins --bench rman_overhead`: the cost of a RenderMan-style C++ projection
//! plugin (`examples/rman-plugins/bench/RmanFisheye.cpp`, built by the same code as `obscura build-plugin`
//! at -O2, the glue copying each batch into `RtRayGeometry`) against the same equidistant fisheye through
//! the C ABI (`examples/plugins/c-fisheye/fisheye.c`, `cc -O2`) and as the built-in `Fisheye`, at batches
//! of 256 samples on one core:
//!
//! - `project`: the projection call alone;
//! - `camera_stage`: the host's whole camera stage (warps, default rays, `project`, validation).
//!
//! divan reports items/s (one item is one ray). The target: the C++ path within 5 % of the C ABI path.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use divan::{Bencher, counter::ItemsCount};
use obscura_host::{CameraStage, Registry};
use obscura_plugins::builtin_registry;
use obscura_plugins::loader::{PluginSearch, ensure};
use obscura_plugins::rman::{BuildRequest, build};
use obscura_sdk::{ParamList, ParamValue, Projection, ProjectionContext, RayGeometry, Rgb};

const BATCH: usize = 256;
const WAYS: [&str; 3] = ["builtin", "c_abi", "rman_cpp"];

mod common;

use common::{camera, samples};

fn main() {
    divan::main();
}

/// `CFisheye.so` and `RmanFisheye.so`, built once into a directory of their own.
fn plugin_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rman-bench");
        std::fs::create_dir_all(&dir).unwrap();
        let ext = std::env::consts::DLL_EXTENSION;
        let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
        let status = Command::new(cc)
            .args(["-std=c11", "-O2", "-fPIC", "-shared", "-I"])
            .arg(root.join("include"))
            .arg("-o")
            .arg(dir.join(format!("CFisheye.{ext}")))
            .arg(root.join("examples/plugins/c-fisheye/fisheye.c"))
            .arg("-lm")
            .status()
            .expect("cannot run the C compiler");
        assert!(status.success(), "compiling the C fisheye failed");
        let req = BuildRequest {
            sources: vec![root.join("examples/rman-plugins/bench/RmanFisheye.cpp")],
            output: Some(dir.join(format!("RmanFisheye.{ext}"))),
            ..BuildRequest::default()
        };
        build(&req).unwrap_or_else(|e| panic!("building RmanFisheye failed: {e}"));
        dir
    })
}

/// The projection's name in its registry, and the registry.
fn registry(way: &str) -> (&'static str, Registry) {
    let mut reg = builtin_registry();
    let name = match way {
        "builtin" => "Fisheye",
        "c_abi" => "CFisheye",
        _ => "RmanFisheye",
    };
    if way != "builtin" {
        ensure(
            &mut reg,
            name,
            &PluginSearch::new(vec![plugin_dir().to_path_buf()]),
        )
        .unwrap();
    }
    (name, reg)
}

fn params() -> ParamList {
    let mut p = ParamList::new();
    p.push("float fov", ParamValue::Floats(vec![180.0]), None)
        .unwrap();
    p
}

#[divan::bench(args = WAYS)]
fn project(bencher: Bencher, way: &str) {
    let cam = camera();
    let mut env = cam.environment();
    let (name, mut reg) = registry(way);
    let p: Box<dyn Projection> = reg.create(name, &mut env, &params()).unwrap();
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
    let (name, mut reg) = registry(way);
    let stage = CameraStage::new(&mut reg, name, &params(), &cam).unwrap();
    let template = samples(&cam, BATCH);
    let mut b = template.clone();
    bencher.counter(ItemsCount::new(BATCH)).bench_local(|| {
        b.time.clone_from(&template.time);
        let report = stage.run(black_box(&mut b));
        black_box((&b.rays, report.samples));
    });
}
