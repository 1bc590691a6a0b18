//! What textures cost: renders a scene with its textures and again with every texture slot removed
//! (the same materials' factors, the same shading path), and prints both frame times and the texture
//! memory. `cargo run --release -p obscura-render --example texture_cost -- scene.glb 640 480 16`

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use obscura_host::CameraDesc;
use obscura_render::render::{RenderOptions, prepare};
use obscura_scene::Scene;
use obscura_sdk::Format;

fn frame_seconds(scene: &Scene, base: &Path, spp: u32, runs: usize) -> (f64, f64, usize) {
    let opts = RenderOptions {
        samples_per_pixel: Some(spp),
        ..RenderOptions::default()
    };
    let start = Instant::now();
    let prepared = prepare(scene, &mut obscura_plugins::builtin_registry(), base, &opts).expect("prepares");
    let setup = start.elapsed().as_secs_f64();
    let mut times: Vec<f64> = (0..runs)
        .map(|_| {
            let t = Instant::now();
            prepared.render(&opts, &|_, _| {}, &AtomicBool::new(false));
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    (times[runs / 2], setup, prepared.texture_memory_bytes())
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
        maps.occlusion = None;
        maps.specular_map = None;
        maps.opacity = None;
    }
    let (textured, setup_t, memory) = frame_seconds(&scene, base, spp, 3);
    let (untextured, setup_u, _) = frame_seconds(&plain, base, spp, 3);
    println!(
        "{}: {w}x{h}, {spp} spp, median of 3 frames: textured {textured:.3} s, untextured {untextured:.3} s \
         (textures +{:.1} % of the textured frame); setup {setup_t:.2} s vs {setup_u:.2} s; texture memory {:.1} MiB",
        path.display(),
        100.0 * (textured - untextured) / textured,
        memory as f64 / (1024.0 * 1024.0)
    );
}
