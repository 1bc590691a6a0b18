//! Mrays/s of `PxrPerspective`'s `project` and `project_soa` (pinhole and thin lens) on the calling
//! thread, for scripts that compare it with another renderer in the same run
//! (`scripts/bench/mitsuba_vs_obscura.py`).
//!
//! ```sh
//! cargo run --release -p obscura-projections --example project_rate -- [--batch 4096] [--total N] [--seconds 1]
//! ```
//!
//! Screen samples cover a `--width`×`--height` frame (default 1920×1080) in raster order, lens samples
//! are stratified over the aperture square, as in `benches/project.rs`. `--batch` rays are projected
//! per call into one reused buffer until `--total` rays (default: one frame) are done; a round is
//! one such pass, and the figure is the best round within `--seconds` (at least three rounds). Prints
//! one line per model and layout: `<model> batch=<b> total=<n> tier=<tier> mrays_per_s=<x>` for
//! `project` (40-byte records), and `<model>_soa …` for `project_soa` (all ten fields, each its own
//! array: ten arrays of `--batch` floats cut from one buffer from a 64-byte boundary, so with a batch that is
//! a multiple of 16 every array starts on a cache line), and
//! `<model>_soa_like …` for `project_soa` asked for the fields Mitsuba's `sample_ray` stores
//! ([`SoaFields`]: direction and `max_dist`, and the origin for the thin lens; the other arrays are
//! not written).

#[path = "../benches/common/mod.rs"]
mod common;

use std::hint::black_box;
use std::time::{Duration, Instant};

use obscura_sdk::{
    Format, ParamList, Point2, Projection, ProjectionContext, ProjectionEnvironment, RayGeometry, RaysSoa,
    Rgb, ScreenWindow, SoaContext, SoaFields, simd,
};

fn main() {
    if let Err(e) = run() {
        eprintln!("project_rate: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let mut width = 1920u32;
    let mut height = 1080u32;
    let mut batch = 4096usize;
    let mut total = None;
    let mut seconds = 1.0f64;
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let mut value = |what: &str| {
            args.next()
                .ok_or_else(|| format!("{flag}: expected {what} after it"))
        };
        let num = |v: String| {
            v.parse::<f64>()
                .map_err(|_| format!("{flag}: expected a number, got {v:?}"))
        };
        match flag.as_str() {
            "--width" => width = num(value("a width")?)? as u32,
            "--height" => height = num(value("a height")?)? as u32,
            "--batch" => batch = num(value("a batch size")?)? as usize,
            "--total" => total = Some(num(value("a ray count")?)? as usize),
            "--seconds" => seconds = num(value("seconds")?)?,
            other => {
                return Err(format!(
                    "unknown argument {other:?} (expected --width, --height, --batch, --total, --seconds)"
                ));
            }
        }
    }
    if width == 0 || height == 0 || batch == 0 {
        return Err("--width, --height and --batch must be positive".into());
    }
    let format = Format::new(width, height);
    let total = total.unwrap_or((width * height) as usize);
    let batch = batch.min(total);
    let window = ScreenWindow::default_for(format);
    let screen: Vec<Point2> = (0..total)
        .map(|i| {
            let (x, y) = (
                (i % width as usize) as f64 + 0.5,
                ((i / width as usize) % height as usize) as f64 + 0.5,
            );
            window.raster_to_screen(format, x, y)
        })
        .collect();
    let lens: Vec<Point2> = (0..total)
        .map(|i| {
            Point2::new(
                ((i * 37) % total) as f32 / total as f32,
                ((i * 91) % total) as f32 / total as f32,
            )
        })
        .collect();
    let aperture: Vec<Point2> = lens
        .iter()
        .map(|l| Point2::new(2.0 * l.x - 1.0, 2.0 * l.y - 1.0))
        .collect();
    for (model, params) in common::PERSPECTIVE {
        let p = projection(format, params)?;
        let mut rays = vec![RayGeometry::CULLED; batch];
        let mut tint = vec![Rgb::WHITE; batch];
        let mut time = vec![0.0f32; batch];
        let mut pass = || {
            for start in (0..total).step_by(batch) {
                let end = (start + batch).min(total);
                let m = end - start;
                let mut ctx = ProjectionContext::new(
                    &screen[start..end],
                    &lens[start..end],
                    &aperture[start..end],
                    &mut time[..m],
                    &mut rays[..m],
                    &mut tint[..m],
                )
                .expect("equal lengths");
                p.project(&mut ctx);
                black_box(&rays);
            }
        };
        let aos = best_round(seconds, &mut pass);
        // Ten arrays of `batch` floats from the first 64-byte boundary of one allocation.
        let mut buffer = vec![0.0f32; 10 * batch + 16];
        let skip = buffer.as_ptr().align_offset(64);
        let mut tints = vec![1.0f32; 3 * batch];
        let mut soa_pass = |wanted: SoaFields| {
            let mut fields = buffer[skip..skip + 10 * batch].chunks_exact_mut(batch);
            let mut next = || fields.next().expect("ten arrays of one batch");
            let mut arrays: [&mut [f32]; 10] = std::array::from_fn(|_| next());
            let mut tint = tints.chunks_exact_mut(batch);
            let [r, g, b] = std::array::from_fn(|_| tint.next().expect("three arrays"));
            for start in (0..total).step_by(batch) {
                let end = (start + batch).min(total);
                let m = end - start;
                let [ox, oy, oz, radius, dx, dy, dz, spread, min, max] =
                    arrays.each_mut().map(|a| &mut a[..m]);
                let rays = RaysSoa::new([ox, oy, oz], radius, [dx, dy, dz], spread, min, max)
                    .expect("equal lengths");
                let mut ctx = SoaContext::new(
                    &screen[start..end],
                    &lens[start..end],
                    &aperture[start..end],
                    &mut time[..m],
                    rays,
                    [&mut r[..m], &mut g[..m], &mut b[..m]],
                )
                .expect("equal lengths")
                .with_fields(wanted);
                assert!(p.project_soa(&mut ctx), "PxrPerspective offers project_soa");
                black_box(&ctx);
            }
        };
        let soa = best_round(seconds, &mut || soa_pass(SoaFields::ALL));
        // What Mitsuba's `sample_ray` stores: direction and maxt, and the thin lens's origin.
        let like = match model {
            "pinhole" => SoaFields::DIRECTION | SoaFields::MAX_DIST,
            _ => SoaFields::ORIGIN | SoaFields::DIRECTION | SoaFields::MAX_DIST,
        };
        let soa_like = best_round(seconds, &mut || soa_pass(like));
        let rows = [
            (model.to_string(), aos),
            (format!("{model}_soa"), soa),
            (format!("{model}_soa_like"), soa_like),
        ];
        for (name, best) in rows {
            println!(
                "{name} batch={batch} total={total} tier={} mrays_per_s={:.1}",
                simd::level(),
                total as f64 / best.as_secs_f64() / 1e6
            );
        }
    }
    Ok(())
}

/// The fastest of at least three runs of `pass`, running for `seconds` in all.
fn best_round(seconds: f64, pass: &mut impl FnMut()) -> Duration {
    let mut best = Duration::MAX;
    let begin = Instant::now();
    let mut rounds = 0;
    while rounds < 3 || begin.elapsed().as_secs_f64() < seconds {
        let t = Instant::now();
        pass();
        best = best.min(t.elapsed());
        rounds += 1;
    }
    best
}

fn projection(format: Format, params: &[(&str, &str)]) -> Result<Box<dyn Projection>, String> {
    let mut list = ParamList::new();
    for (decl, v) in params {
        list.push_text(decl, &[v], None).map_err(|e| e.to_string())?;
    }
    let mut env = ProjectionEnvironment::for_format(format);
    let mut registry = obscura_host::Registry::new();
    for factory in obscura_projections::factories() {
        registry.register(factory, "").map_err(|e| e.to_string())?;
    }
    registry
        .create("PxrPerspective", &mut env, &list)
        .map_err(|e| e.to_string())
}
