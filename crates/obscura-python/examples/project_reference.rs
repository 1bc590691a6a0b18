//! The Rust references for the Python `project` benchmark (BENCHMARKS.md, "Python"): the same
//! projection through the host's camera stage, from Rust, on the same screen samples, in the same
//! batches of 4096 on the same number of rayon threads, with the chief-ray inputs `project` uses
//! without lens or time samples (lens centre, aperture centre, time 0). Each MODE (several may be
//! given, comma-separated; they run interleaved, best of five each):
//!
//! - `soa`: `CameraStage::run_soa_prepared` into fourteen `f32` arrays of N and N valid flags
//!   allocated by each call (the arrays Python's `project` hands back, made the same way: fresh
//!   memory every call);
//! - `soa-prealloc`: the same into arrays allocated once, before the timing (no page faults);
//! - `soa-batch`: the same into one 4096-sample set of arrays per thread that stays in the cache
//!   (nothing kept: the stage's own rate on this path);
//! - `keep`: the array-of-structs stage (`run_prepared`) with each batch copied into N rays and tints
//!   allocated by each call;
//! - `batch`: the array-of-structs stage alone, one batch buffer reused;
//! - `parts`: one thread, one 4096-sample batch, the stage's pieces apart: the default-ray pre-fill
//!   as a plain loop and at the widest SIMD tier, `project` alone, the validation as a loop of
//!   `check_ray` (the stage's former validation) and as the stage's `validate_batch`.
//!
//! ```sh
//! cargo run --release -p obscura-python --example project_reference -- PxrPerspective 1000000 1 soa,soa-batch
//! ```
//!
//! Prints one line per mode in Mrays/s.

use std::hint::black_box;
use std::time::Instant;

use obscura_host::contract::DefaultRays;
use obscura_host::driver::{Batch, validate_batch};
use obscura_host::{CameraDesc, CameraStage, ContractReport, SoaScratch};
use obscura_plugins::builtin_registry;
use obscura_sdk::contract::check_ray;
use obscura_sdk::{
    Format, ParamList, Point2, ProjectionContext, RayGeometry, RaysSoa, Rgb, SoaContext, Vec3, simd,
};
use rayon::prelude::*;

const CHUNK: usize = 4096;
const FIELDS: usize = 14;

/// One run of `mode` over `screen`: the culled count (so the work cannot be optimised away).
fn run_once(
    stage: &CameraStage,
    screen: &[Point2],
    mode: &str,
    prealloc: &mut [Vec<f32>],
    valid: &mut [bool],
) -> u64 {
    let n = screen.len();
    let soa_chunk = |w: &mut Worker, s: &[Point2], fields: [&mut [f32]; FIELDS], valid: &mut [bool]| {
        w.inputs(s);
        let [
            ox,
            oy,
            oz,
            radius,
            dx,
            dy,
            dz,
            spread,
            near,
            far,
            time,
            tr,
            tg,
            tb,
        ] = fields;
        time.fill(0.0);
        let rays = RaysSoa::new([ox, oy, oz], radius, [dx, dy, dz], spread, near, far).unwrap();
        let mut ctx = SoaContext::new(&w.screen, &w.lens, &w.aperture, time, rays, [tr, tg, tb]).unwrap();
        let culled = stage.run_soa_prepared(&mut ctx, &mut w.scratch).culled;
        let [dx, dy, dz] = &ctx.rays.direction;
        for (i, v) in valid.iter_mut().enumerate() {
            *v = dx[i] != 0.0 || dy[i] != 0.0 || dz[i] != 0.0;
        }
        culled
    };
    let into_arrays = |fields: &mut [Vec<f32>], valid: &mut [bool]| -> u64 {
        let mut parts: Vec<_> = fields.iter_mut().map(|f| f.chunks_mut(CHUNK)).collect();
        let chunks: Vec<([&mut [f32]; FIELDS], &mut [bool])> = valid
            .chunks_mut(CHUNK)
            .map(|v| (std::array::from_fn(|k| parts[k].next().unwrap()), v))
            .collect();
        screen
            .par_chunks(CHUNK)
            .zip(chunks)
            .map_init(Worker::default, |w, (s, (f, v))| soa_chunk(w, s, f, v))
            .sum()
    };
    match mode {
        "soa" => {
            let mut fields: Vec<Vec<f32>> = (0..FIELDS).map(|_| vec![0.0; n]).collect();
            let mut valid = vec![false; n];
            into_arrays(&mut fields, &mut valid)
        }
        "soa-prealloc" => into_arrays(prealloc, valid),
        "soa-batch" => screen
            .par_chunks(CHUNK)
            .map_init(
                || {
                    (
                        Worker::default(),
                        vec![0.0f32; FIELDS * CHUNK],
                        vec![false; CHUNK],
                    )
                },
                |(w, buf, valid), s| {
                    let m = s.len();
                    let mut parts = buf[..FIELDS * m].chunks_exact_mut(m);
                    let fields = std::array::from_fn(|_| parts.next().unwrap());
                    soa_chunk(w, s, fields, &mut valid[..m])
                },
            )
            .sum(),
        "keep" => {
            let mut rays = vec![RayGeometry::CULLED; n];
            let mut tints = vec![Rgb::WHITE; n];
            screen
                .par_chunks(CHUNK)
                .zip(rays.par_chunks_mut(CHUNK).zip(tints.par_chunks_mut(CHUNK)))
                .map_init(
                    || Batch::with_capacity(CHUNK),
                    |b, (s, (r, t))| {
                        let c = aos_chunk(stage, b, s);
                        r.copy_from_slice(&b.rays);
                        t.copy_from_slice(&b.tint);
                        c
                    },
                )
                .sum()
        }
        "batch" => screen
            .par_chunks(CHUNK)
            .map_init(|| Batch::with_capacity(CHUNK), |b, s| aos_chunk(stage, b, s))
            .sum(),
        other => panic!("unknown mode {other:?}"),
    }
}

/// The per-thread inputs of the SoA modes.
#[derive(Default)]
struct Worker {
    screen: Vec<Point2>,
    lens: Vec<Point2>,
    aperture: Vec<Point2>,
    scratch: SoaScratch,
}

impl Worker {
    fn inputs(&mut self, s: &[Point2]) {
        self.screen.clear();
        self.screen.extend_from_slice(s);
        self.lens.clear();
        self.lens.resize(s.len(), Point2::new(0.5, 0.5));
        self.aperture.clear();
        self.aperture.resize(s.len(), Point2::ZERO);
    }
}

fn aos_chunk(stage: &CameraStage, b: &mut Batch, chunk: &[Point2]) -> u64 {
    b.clear();
    for s in chunk {
        b.push(*s, Point2::new(0.5, 0.5), 0.0);
        b.aperture.push(Point2::ZERO);
    }
    stage.run_prepared(b).culled
}

/// Best time of one call of `f` (one 4096-sample batch) over 400 calls, in ns per ray: each call is
/// short enough to run between two preemptions on a shared machine.
fn per_ray(mut f: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..400 {
        let t = Instant::now();
        f();
        best = best.min(t.elapsed().as_secs_f64() / CHUNK as f64 * 1e9);
    }
    best
}

/// The stage's pieces on one 4096-sample batch, one thread.
fn parts(stage: &CameraStage, screen: &[Point2]) {
    let mut b = Batch::with_capacity(CHUNK);
    aos_chunk(stage, &mut b, &screen[..CHUNK.min(screen.len())]);
    let defaults = DefaultRays::new(stage.properties(), stage.environment());
    let (s, a) = (b.screen.clone(), b.aperture.clone());
    let mut rays = vec![RayGeometry::CULLED; s.len()];
    let plain = per_ray(|| {
        for ((r, s), a) in rays.iter_mut().zip(&s).zip(&a) {
            *r = defaults.ray(*s, *a);
        }
        black_box(&mut rays);
    });
    let wide = per_ray(|| {
        simd::run(
            #[inline(always)]
            || {
                for ((r, s), a) in rays.iter_mut().zip(&s).zip(&a) {
                    *r = defaults.ray(*s, *a);
                }
            },
        );
        black_box(&mut rays);
    });
    let project = per_ray(|| {
        let mut ctx = ProjectionContext::new(
            &b.screen,
            &b.lens,
            &b.aperture,
            &mut b.time,
            &mut b.rays,
            &mut b.tint,
        )
        .unwrap();
        stage.projection().project(&mut ctx);
        black_box(&mut b.rays);
    });
    let check = per_ray(|| {
        let mut culled = 0u64;
        for i in 0..b.rays.len() {
            match check_ray(&b.rays[i], b.time[i], b.tint[i]) {
                Some(_) => b.rays[i].direction = Vec3::ZERO,
                None if b.rays[i].direction == Vec3::ZERO => culled += 1,
                None => {}
            }
        }
        black_box(culled);
    });
    let validate = per_ray(|| {
        let mut report = ContractReport::default();
        validate_batch(&mut b, &mut report);
        black_box(report.culled);
    });
    let stage_ns = per_ray(|| {
        black_box(aos_chunk(stage, &mut b, &s));
    });
    println!(
        "parts, ns/ray: pre-fill plain loop {plain:.2}, pre-fill widest tier {wide:.2}, project {project:.2}, \
         validation check_ray loop {check:.2}, validate_batch {validate:.2}, whole AoS stage {stage_ns:.2} \
         (SIMD tier {})",
        simd::level().name()
    );
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    let [_, name, n, threads, modes, params @ ..] = args.as_slice() else {
        return Err(
            "usage: project_reference PROJECTION N THREADS MODE[,MODE...] ['type name' value ...]".into(),
        );
    };
    let n: usize = n.parse().map_err(|e| format!("N: {e}"))?;
    let threads: usize = threads.parse().map_err(|e| format!("THREADS: {e}"))?;
    let modes: Vec<&str> = modes.split(',').collect();
    for m in &modes {
        if !["soa", "soa-prealloc", "soa-batch", "keep", "batch", "parts"].contains(m) {
            return Err(format!(
                "MODE {m:?}: expected soa, soa-prealloc, soa-batch, keep, batch or parts"
            ));
        }
    }
    let mut list = ParamList::new();
    for pair in params.chunks(2) {
        if let [decl, value] = pair {
            let values: Vec<&str> = value.split_whitespace().collect();
            list.push_text(decl, &values, None).map_err(|e| e.to_string())?;
        }
    }
    let mut registry = builtin_registry();
    let cam = CameraDesc::new(Format::new(1920, 1080));
    let stage = CameraStage::new(&mut registry, name, &list, &cam).map_err(|e| e.to_string())?;
    // The benchmark's screen samples: a uniform grid over the screen window, as the Python script.
    let side = (n as f64).sqrt().ceil() as usize;
    let w = cam.screen_window();
    let screen: Vec<Point2> = (0..n)
        .map(|i| {
            let (x, y) = ((i % side) as f32 + 0.5, (i / side) as f32 + 0.5);
            Point2::new(
                w.left + x / side as f32 * (w.right - w.left),
                w.top - y / side as f32 * (w.top - w.bottom),
            )
        })
        .collect();
    if modes.contains(&"parts") {
        parts(&stage, &screen);
    }
    let modes: Vec<&str> = modes.into_iter().filter(|m| *m != "parts").collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| e.to_string())?;
    let (mut prealloc, mut valid) = if modes.contains(&"soa-prealloc") {
        ((0..FIELDS).map(|_| vec![0.0f32; n]).collect(), vec![false; n])
    } else {
        (Vec::new(), Vec::new())
    };
    let mut best = vec![f64::INFINITY; modes.len()];
    let mut culled = vec![0; modes.len()];
    for _ in 0..5 {
        for (k, mode) in modes.iter().enumerate() {
            let start = Instant::now();
            culled[k] = pool.install(|| run_once(&stage, &screen, mode, &mut prealloc, &mut valid));
            best[k] = best[k].min(start.elapsed().as_secs_f64());
        }
    }
    for (k, mode) in modes.iter().enumerate() {
        println!(
            "{name} N={n} threads={threads} {mode}: {:.1} Mrays/s (best of 5: {:.4} s, {} culled)",
            n as f64 / best[k] * 1e-6,
            best[k],
            culled[k]
        );
    }
    Ok(())
}
