//! The Rust reference for the Python `project` benchmark (BENCHMARKS.md, "Python"): the same
//! projection through the host's camera stage, from Rust, on the same number of screen samples, in
//! the same batches of 4096 (`CameraStage::run_prepared`, the chief-ray path `project` takes without
//! lens or time samples), on 1 or more threads. Output is the stage's own AoS rays; no numpy arrays.
//! With `MODE` = `keep`, every call also allocates N rays and tints and copies each batch's there (the
//! work a caller that keeps its rays does, as `project` must); with `batch`, the batch is all.
//!
//! ```sh
//! cargo run --release -p obscura-python --example project_reference -- PxrPerspective 1000000 1 keep
//! ```
//!
//! Prints the best of five runs in Mrays/s.

use std::time::Instant;

use obscura_host::driver::Batch;
use obscura_host::{CameraDesc, CameraStage};
use obscura_plugins::builtin_registry;
use obscura_sdk::{Format, ParamList, Point2, RayGeometry, Rgb};
use rayon::prelude::*;

const CHUNK: usize = 4096;

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    let [_, name, n, threads, mode, params @ ..] = args.as_slice() else {
        return Err(
            "usage: project_reference PROJECTION N THREADS keep|batch ['type name' value ...]".into(),
        );
    };
    let keep = match mode.as_str() {
        "keep" => true,
        "batch" => false,
        other => return Err(format!("MODE {other:?}: expected keep or batch")),
    };
    let n: usize = n.parse().map_err(|e| format!("N: {e}"))?;
    let threads: usize = threads.parse().map_err(|e| format!("THREADS: {e}"))?;
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
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| e.to_string())?;
    let mut best = f64::INFINITY;
    let mut culled = 0;
    for _ in 0..5 {
        let start = Instant::now();
        culled = pool.install(|| {
            let (mut rays, mut tints) = if keep {
                (vec![RayGeometry::CULLED; n], vec![Rgb::WHITE; n])
            } else {
                (Vec::new(), Vec::new())
            };
            let out: Vec<(&mut [RayGeometry], &mut [Rgb])> = if keep {
                rays.chunks_mut(CHUNK).zip(tints.chunks_mut(CHUNK)).collect()
            } else {
                Vec::new()
            };
            let run = |b: &mut Batch, chunk: &[Point2]| {
                b.clear();
                for s in chunk {
                    b.push(*s, Point2::new(0.5, 0.5), 0.0);
                    b.aperture.push(Point2::ZERO);
                }
                stage.run_prepared(b).culled
            };
            if keep {
                screen
                    .par_chunks(CHUNK)
                    .zip(out)
                    .map_init(
                        || Batch::with_capacity(CHUNK),
                        |b, (chunk, (r, t))| {
                            let c = run(b, chunk);
                            r.copy_from_slice(&b.rays);
                            t.copy_from_slice(&b.tint);
                            c
                        },
                    )
                    .sum::<u64>()
            } else {
                screen
                    .par_chunks(CHUNK)
                    .map_init(|| Batch::with_capacity(CHUNK), |b, chunk| run(b, chunk))
                    .sum::<u64>()
            }
        });
        best = best.min(start.elapsed().as_secs_f64());
    }
    println!(
        "{name} N={n} threads={threads}: {:.1} Mrays/s (best of 5: {:.4} s, {culled} culled)",
        n as f64 / best * 1e-6,
        best
    );
    Ok(())
}
