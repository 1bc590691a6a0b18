//! Traces the ray sets of a trace-vs-Embree dump (`target/trace-vs-embree/rays.bin`, format in
//! `bench/embree/README.md`) with [`MeshBvh`] on this thread and prints `obscura-wide SET Mrays/s`
//! lines, the fastest of five passes (`PASSES` to change it) in this thread's CPU time, and how
//! many answers differ from the dump's; a profiling aid (`perf record` on this binary) that
//! rebuilds only this crate. `OBSCURA_BVH_LAYOUT=binary` traces the binary layout.
//! Usage: `trace_dump FILE [SET]` (SET: primary, incoherent or shadow; default all three).

use glam::Vec3A;
use obscura_geometry::bvh::{BvhLayout, MeshBvh};
use obscura_geometry::ray::{Ray, TriangleMesh};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: trace_dump FILE [primary|incoherent|shadow]");
        std::process::exit(2);
    };
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let only = args.get(2).cloned();
    let mut at = 8usize;
    let u32_ = |at: &mut usize| {
        let v = u32::from_le_bytes(bytes[*at..*at + 4].try_into().unwrap());
        *at += 4;
        v
    };
    let nv = u32_(&mut at) as usize;
    let nt = u32_(&mut at) as usize;
    let mut positions = Vec::with_capacity(nv);
    for _ in 0..nv {
        let p = [0; 3].map(|_| f32::from_bits(u32_(&mut at)));
        positions.push(Vec3A::from_array(p));
    }
    let mut triangles = Vec::with_capacity(nt);
    for _ in 0..nt {
        triangles.push([0; 3].map(|_| u32_(&mut at)));
    }
    let mut sets = Vec::new();
    for _ in 0..3 {
        let n = u32_(&mut at) as usize;
        let mut rays = Vec::with_capacity(n);
        let mut expect = Vec::with_capacity(n);
        for _ in 0..n {
            let v: Vec<f32> = (0..9).map(|_| f32::from_bits(u32_(&mut at))).collect();
            let id = u32_(&mut at);
            rays.push(Ray {
                origin: Vec3A::new(v[0], v[1], v[2]),
                direction: Vec3A::new(v[3], v[4], v[5]),
                t_min: v[6],
                t_max: v[7],
                time: 0.0,
            });
            expect.push((v[8], id));
        }
        sets.push((rays, expect));
    }
    let mesh = TriangleMesh {
        positions,
        normals: None,
        triangles,
    };
    let layout = if std::env::var("OBSCURA_BVH_LAYOUT").is_ok_and(|v| v == "binary") {
        BvhLayout::Binary
    } else {
        BvhLayout::Wide
    };
    let bvh = MeshBvh::build_with_layout(mesh, layout);
    let passes: usize = std::env::var("PASSES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5);
    for (name, (rays, expect)) in ["primary", "incoherent", "shadow"].iter().zip(&sets) {
        if only.as_deref().is_some_and(|o| o != *name) {
            continue;
        }
        let shadow = *name == "shadow";
        let mut differ = 0;
        for (r, e) in rays.iter().zip(expect) {
            let got = if shadow {
                (if bvh.occluded(r) { 1.0 } else { 0.0 }, 0)
            } else {
                bvh.intersect(r).map_or((f32::INFINITY, u32::MAX), |h| (h.0, h.1))
            };
            differ += usize::from(got.0.to_bits() != e.0.to_bits() || got.1 != e.1);
        }
        let best = fastest_trace_pass(&bvh, rays, shadow, passes);
        println!(
            "obscura-wide {name} {:.3} Mrays/s (differ from dump: {differ})",
            rays.len() as f64 / best / 1e6
        );
    }
}

include!("../../../bench/thread_clock.rs");
