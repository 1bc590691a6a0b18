//! What textures cost: renders a scene with its textures, again with every texture slot removed
//! (the materials' factors alone, the same shading path) and again with every texture read as its
//! mean (the same colours on average, no filtering), and prints the frame times and the texture
//! memory. `cargo run --release -p obscura-render --example texture_cost -- scene.glb 640 480 16`

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use obscura_host::CameraDesc;
use obscura_render::material::textured::TextureLookup;
use obscura_render::render::{Prepared, RenderOptions, prepare};
use obscura_scene::Scene;
use obscura_sdk::Format;

/// Prepares `scene`: the prepared render and its setup time.
fn prepared(scene: &Scene, base: &Path, opts: &RenderOptions) -> (Prepared, f64) {
    let start = Instant::now();
    let p = prepare(scene, &mut obscura_plugins::builtin_registry(), base, opts).expect("prepares");
    (p, start.elapsed().as_secs_f64())
}

/// One frame's wall time.
fn frame(p: &Prepared, opts: &RenderOptions) -> f64 {
    let t = Instant::now();
    p.render(opts, &|_, _| {}, &AtomicBool::new(false));
    t.elapsed().as_secs_f64()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = Path::new(args.get(1).expect("usage: texture_cost SCENE [W H SPP]"));
    let num = |i: usize, d: u32| args.get(i).and_then(|a| a.parse().ok()).unwrap_or(d);
    let (w, h, spp) = (num(2, 640), num(3, 480), num(4, 16));
    let scene = obscura_scene::load(path, CameraDesc::new(Format::new(w, h))).expect("loads");
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
    // Interleaved, the fastest of five each: on a shared machine the minimum is the least disturbed.
    let (mut textured, mut untextured) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..5 {
        textured = textured.min(frame(&with, &opts));
        untextured = untextured.min(frame(&without, &opts));
    }
    // The same textures read as their means: the shading is the same on average, only the
    // filtering is gone.
    let mean_opts = RenderOptions {
        texture_lookup: TextureLookup::Mean,
        ..opts.clone()
    };
    let (flat, _) = prepared(&scene, base, &mean_opts);
    let mut mean = f64::INFINITY;
    for _ in 0..5 {
        mean = mean.min(frame(&flat, &mean_opts));
    }
    let memory = with.texture_memory_bytes();
    println!(
        "{}: {w}x{h}, {spp} spp, fastest of 5 interleaved frames: textured {textured:.3} s, untextured {untextured:.3} s \
         (+{:.1} % of the textured frame); textures read as their means {mean:.3} s (filtering {:.1} % of the \
         textured frame); setup {setup_t:.2} s vs {setup_u:.2} s; texture memory {:.1} MiB",
        path.display(),
        100.0 * (textured - untextured) / textured,
        100.0 * (textured - mean) / textured,
        memory as f64 / (1024.0 * 1024.0)
    );
}
