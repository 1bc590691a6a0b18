//! What textures cost: renders a scene with its textures, again with every texture slot removed
//! (the materials' factors alone, the same shading path) and again with every texture read as its
//! mean (the same colours on average, no filtering), and prints the frame times and the texture
//! memory, each frame's wall and CPU time (the fastest of `REPS` interleaved frames, 5 by default).
//! `cargo run --release -p obscura-render --example texture_cost -- scene.glb 640 480 16 [REPS]`

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use obscura_host::CameraDesc;
use obscura_render::render::{Prepared, RenderOptions, prepare};
use obscura_scene::Scene;
use obscura_sdk::Format;
use obscura_shading::material::textured::TextureLookup;

/// Prepares `scene`: the prepared render and its setup time.
fn prepared(scene: &Scene, base: &Path, opts: &RenderOptions) -> (Prepared, f64) {
    let start = Instant::now();
    let p = prepare(scene, &mut obscura_plugins::builtin_registry(), base, opts).expect("prepares");
    (p, start.elapsed().as_secs_f64())
}

/// The process's CPU time (user + system, every thread) in seconds, from `/proc/self/stat`; 0
/// where there is no such file.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the parenthesised command name: utime and stime are the 12th and 13th.
    let after = stat.rsplit_once(')').map_or("", |(_, rest)| rest);
    let fields: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok());
    match (ticks(11), ticks(12)) {
        (Some(u), Some(s)) => (u + s) / 100.0,
        _ => 0.0,
    }
}

/// One frame's wall time and CPU time (all threads). On a machine shared with other work the CPU
/// time is the steadier measure of the work a frame does.
fn frame(p: &Prepared, opts: &RenderOptions) -> (f64, f64) {
    let (t, c) = (Instant::now(), cpu_seconds());
    p.render(opts, &|_, _| {}, &AtomicBool::new(false));
    (t.elapsed().as_secs_f64(), cpu_seconds() - c)
}

/// The fastest of several `(wall, cpu)` frames, each measure on its own.
fn fastest(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0.min(b.0), a.1.min(b.1))
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = Path::new(args.get(1).expect("usage: texture_cost SCENE [W H SPP]"));
    let num = |i: usize, d: u32| args.get(i).and_then(|a| a.parse().ok()).unwrap_or(d);
    let (w, h, spp) = (num(2, 640), num(3, 480), num(4, 16));
    let scene = obscura_render::staging::load(path, CameraDesc::new(Format::new(w, h))).expect("loads");
    let base = path.parent().unwrap_or(Path::new("."));
    let mut plain = scene.clone();
    for maps in plain.material_maps.values_mut() {
        maps.base_color = None;
        maps.metallic_roughness = None;
        maps.normal = None;
        maps.emissive = None;
        maps.specular_map = None;
        maps.opacity = None;
    }
    let opts = RenderOptions {
        samples_per_pixel: Some(spp),
        ..RenderOptions::default()
    };
    let (with, setup_t) = prepared(&scene, base, &opts);
    let (without, setup_u) = prepared(&plain, base, &opts);
    // Interleaved, the fastest of N each: on a shared machine the minimum is the least disturbed.
    let reps = num(5, 5);
    let none = (f64::INFINITY, f64::INFINITY);
    let (mut textured, mut untextured) = (none, none);
    for _ in 0..reps {
        textured = fastest(textured, frame(&with, &opts));
        untextured = fastest(untextured, frame(&without, &opts));
    }
    // The same textures read as their means: the shading is the same on average, only the
    // filtering is gone.
    let mean_opts = RenderOptions {
        texture_lookup: TextureLookup::Mean,
        ..opts.clone()
    };
    let (flat, _) = prepared(&scene, base, &mean_opts);
    let mut mean = none;
    for _ in 0..reps {
        mean = fastest(mean, frame(&flat, &mean_opts));
    }
    let memory = with.texture_memory_bytes();
    let share = |t: f64, u: f64| 100.0 * (t - u) / t;
    println!(
        "{}: {w}x{h}, {spp} spp, fastest of {reps} interleaved frames: textured {:.3} s ({:.2} s CPU), \
         untextured {:.3} s ({:.2} s CPU): textures {:.1} % of the textured frame ({:.1} % of its CPU time); \
         textures read as their means {:.3} s ({:.2} s CPU); setup {setup_t:.2} s vs {setup_u:.2} s; \
         texture memory {:.1} MiB",
        path.display(),
        textured.0,
        textured.1,
        untextured.0,
        untextured.1,
        share(textured.0, untextured.0),
        share(textured.1, untextured.1),
        mean.0,
        mean.1,
        memory as f64 / (1024.0 * 1024.0)
    );
}
