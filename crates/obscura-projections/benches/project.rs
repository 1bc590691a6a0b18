//! `cargo bench -p obscura-projections --bench project`: rays/s of `project` per projection and batch
//! size, per SIMD tier for the perspective kernels, beside same-run references: a scalar per-ray loop
//! (one non-inlined call per ray, baseline instruction set) and two rooflines for the 40 bytes each
//! ray stores — the *store roofline* (the same buffer, in cache, written with the widest aligned
//! stores the CPU has, computing nothing) and the *streaming roofline* (a batch of 16M rays, 640 MB, far
//! beyond L2 and L3, written with non-temporal stores, and with ordinary stores).
//!
//! `soa_records` and `soa_arrays` run the projections that offer `project_soa` both ways in one run,
//! batch 4096: `project` into 40-byte records and `project_soa` into ten arrays (the same 40 bytes
//! a ray), against the same store roofline.
//!
//! divan reports items/s: each item is one ray.

use std::hint::black_box;

use divan::{Bencher, counter::ItemsCount};
use obscura_projections::panorama::SphericalClip;
use obscura_sdk::optics::{PerspectiveRays, screen_distance};
use obscura_sdk::simd::{self, Level};
use obscura_sdk::{Point2, RayGeometry, Vec3};

mod common;
use common::{Aperture, Batch, PERSPECTIVE, projection};

const BATCHES: [usize; 3] = [64, 256, 4096];

fn main() {
    divan::main();
}

fn bench_projection(bencher: Bencher, n: usize, name: &str, params: &[(&str, &str)]) {
    let p = projection(name, params);
    let mut batch = Batch::new(n, Aperture::Square);
    bencher.counter(ItemsCount::new(n)).bench_local(|| {
        batch.run(black_box(p.as_ref()));
        black_box(&batch.rays);
    });
}

#[divan::bench(args = BATCHES)]
fn perspective_pinhole(bencher: Bencher, n: usize) {
    bench_projection(bencher, n, "PxrPerspective", &[("float fov", "60")]);
}

#[divan::bench(args = BATCHES)]
fn perspective_thin_lens(bencher: Bencher, n: usize) {
    bench_projection(
        bencher,
        n,
        "PxrPerspective",
        &[
            ("float fov", "60"),
            ("float fStop", "2.8"),
            ("float focalLength", "0.05"),
            ("float focalDistance", "4"),
        ],
    );
}

#[divan::bench(args = BATCHES)]
fn perspective_zoom(bencher: Bencher, n: usize) {
    bench_projection(
        bencher,
        n,
        "PxrPerspective",
        &[("float fov", "60"), ("float fovEnd", "40")],
    );
}

#[divan::bench(args = BATCHES)]
fn orthographic(bencher: Bencher, n: usize) {
    bench_projection(bencher, n, "PxrOrthographic", &[]);
}

#[divan::bench(args = BATCHES)]
fn orthographic_thin_lens(bencher: Bencher, n: usize) {
    bench_projection(
        bencher,
        n,
        "PxrOrthographic",
        &[
            ("float fStop", "2"),
            ("float focalLength", "0.5"),
            ("float focalDistance", "4"),
        ],
    );
}

/// A library entry: its label, the projection's name and its parameters.
type Entry = (
    &'static str,
    &'static str,
    &'static [(&'static str, &'static str)],
);

/// The projection library (issues 4 and 6) at batch 4096: one configuration per model, by label.
const LIBRARY: &[Entry] = &[
    ("sphere", "PxrSphereCamera", &[]),
    ("cylinder", "PxrCylinderCamera", &[]),
    (
        "panini",
        "PxrPanini",
        &[("float fov", "150"), ("float compression", "1")],
    ),
    ("ods", "OmnidirectionalStereo", &[]),
    (
        "rolling_shutter",
        "PxrRollingShutter",
        &[("float duration", "0.2")],
    ),
    (
        "fisheye_equidistant",
        "Fisheye",
        &[("string mapping", "equidistant")],
    ),
    ("fisheye_equisolid", "Fisheye", &[("string mapping", "equisolid")]),
    (
        "fisheye_stereographic",
        "Fisheye",
        &[("string mapping", "stereographic")],
    ),
    (
        "fisheye_orthographic",
        "Fisheye",
        &[("string mapping", "orthographic")],
    ),
    (
        "fisheye_polynomial",
        "Fisheye",
        &[("string mapping", "polynomial")],
    ),
    ("mirror_ball", "MirrorBall", &[]),
    ("cube_face", "EquiangularCubemapFace", &[]),
    ("octahedral", "Octahedral", &[]),
    (
        "pxrcamera_pinhole",
        "PxrCamera",
        &[("float fov", "60"), ("float fStop", "0")],
    ),
    (
        "pxrcamera_distortion_dof",
        "PxrCamera",
        &[
            ("float fov", "60"),
            ("float radial1", "-0.1"),
            ("float radial2", "0.02"),
            ("float fStop", "2.8"),
            ("float focalLength", "0.05"),
            ("float focalDistance", "4"),
        ],
    ),
    (
        "pxrcamera_everything",
        "PxrCamera",
        &[
            ("float fov", "60"),
            ("float radial1", "-0.1"),
            ("float assymX", "0.05"),
            ("float squeeze", "1.3"),
            ("float fStop", "2.8"),
            ("float focalLength", "0.05"),
            ("float focalDistance", "4"),
            ("float tilt", "5"),
            ("color transverse", "0.99 1 1.01"),
            ("float natural", "1"),
            ("float optical", "0.5"),
            ("float duration", "0.5"),
        ],
    ),
];

#[divan::bench(args = LIBRARY.iter().map(|e| e.0))]
fn library(bencher: Bencher, label: &str) {
    let (_, name, params) = LIBRARY.iter().find(|e| e.0 == label).expect("a label of LIBRARY");
    bench_projection(bencher, 4096, name, params);
}

/// Reference: the pinhole ray computed one call per ray, never inlined, baseline instruction set.
#[divan::bench(args = BATCHES)]
fn reference_scalar_per_ray(bencher: Bencher, n: usize) {
    #[inline(never)]
    fn one(rays: &PerspectiveRays, s: Point2, d: f32) -> RayGeometry {
        rays.pinhole(s, d)
    }
    let rays = PerspectiveRays::new((0.00185, 0.00185), (0.1, f32::INFINITY), 0.0, 1.0);
    let d = screen_distance(60.0);
    let mut batch = Batch::new(n, Aperture::Square);
    bencher.counter(ItemsCount::new(n)).bench_local(|| {
        for (r, s) in batch.rays.iter_mut().zip(&batch.screen) {
            *r = one(black_box(&rays), *s, d);
        }
        black_box(&batch.rays);
    });
}

/// Reference: store bandwidth. Writes the same 40 bytes per ray, computing nothing.
#[divan::bench(args = BATCHES)]
fn reference_store_bandwidth(bencher: Bencher, n: usize) {
    let mut batch = Batch::new(n, Aperture::Square);
    let clip = SphericalClip {
        near: 0.1,
        far: f32::INFINITY,
    };
    let ray = clip.centred_ray(Vec3::Z, 0.001);
    bencher.counter(ItemsCount::new(n)).bench_local(|| {
        batch.rays.fill(black_box(ray));
        black_box(&batch.rays);
    });
}

/// `PxrPerspective` pinhole and thin lens at batch 4096 at each dispatch tier (`simd::with_level`);
/// a tier the CPU lacks reports nothing.
#[divan::bench(args = ["pinhole/portable", "pinhole/avx2", "pinhole/avx512", "thin_lens/portable", "thin_lens/avx2", "thin_lens/avx512"])]
fn perspective_tier(bencher: Bencher, case: &str) {
    let (model, tier) = case.split_once('/').expect("model/tier");
    let level = Level::parse(tier).expect("a tier name");
    if !level.is_available() {
        return;
    }
    let params = PERSPECTIVE.iter().find(|p| p.0 == model).expect("a model").1;
    let p = projection("PxrPerspective", params);
    let mut batch = Batch::new(4096, Aperture::Square);
    bencher.counter(ItemsCount::new(4096usize)).bench_local(|| {
        simd::with_level(level, || batch.run(black_box(p.as_ref())));
        black_box(&batch.rays);
    });
}

/// Reference: the store roofline. The batch's own 40 bytes per ray written with the widest aligned
/// stores the CPU has (64-byte `vmovaps` with AVX-512, masked at the unaligned ends), ordinary
/// (not non-temporal) stores into a buffer that stays in cache: what a kernel that computed nothing
/// could reach.
#[divan::bench(args = BATCHES)]
fn reference_store_roofline(bencher: Bencher, n: usize) {
    let mut batch = Batch::new(n, Aperture::Square);
    bencher.counter(ItemsCount::new(n)).bench_local(|| {
        roofline::store(black_box(&mut batch.rays), false);
        black_box(&batch.rays);
    });
}

/// Rays in the streaming benches: 16M, 640 MB of rays, beyond L2 and the L3 this machine reports.
const STREAM: usize = 1 << 24;

/// Reference: the streaming roofline. 16M rays (640 MB) written to memory with 64-byte non-temporal
/// stores (`vmovntps`), which skip the read-for-ownership of ordinary stores.
#[divan::bench(sample_count = 10, sample_size = 1)]
fn reference_stream_roofline_nontemporal(bencher: Bencher) {
    let mut rays = vec![RayGeometry::CULLED; STREAM];
    bencher.counter(ItemsCount::new(STREAM)).bench_local(|| {
        roofline::store(black_box(&mut rays), true);
        black_box(&rays);
    });
}

/// Reference: 16M rays written to memory with ordinary 64-byte stores (the read-for-ownership
/// included): the ceiling of any kernel that writes a batch that large with ordinary stores.
#[divan::bench(sample_count = 10, sample_size = 1)]
fn reference_stream_roofline_ordinary(bencher: Bencher) {
    let mut rays = vec![RayGeometry::CULLED; STREAM];
    bencher.counter(ItemsCount::new(STREAM)).bench_local(|| {
        roofline::store(black_box(&mut rays), false);
        black_box(&rays);
    });
}

/// The pinhole and thin lens over one batch of 16M rays: what `project` makes of the streaming roofline.
#[divan::bench(args = ["pinhole", "thin_lens"], sample_count = 10, sample_size = 1)]
fn perspective_stream(bencher: Bencher, model: &str) {
    let params = PERSPECTIVE.iter().find(|p| p.0 == model).expect("a model").1;
    let p = projection("PxrPerspective", params);
    let mut batch = Batch::new(STREAM, Aperture::Square);
    bencher.counter(ItemsCount::new(STREAM)).bench_local(|| {
        batch.run(black_box(p.as_ref()));
        black_box(&batch.rays);
    });
}

/// The store kernels of the rooflines.
mod roofline {
    use obscura_sdk::RayGeometry;

    /// Writes every byte of `rays` (a constant pattern), non-temporally when `nt`.
    pub fn store(rays: &mut [RayGeometry], nt: bool) {
        let len = std::mem::size_of_val(rays) / 4;
        // SAFETY: `RayGeometry` is ten `f32` (`repr(C)`, checked by the SDK's layout test); the
        // slice covers exactly the records.
        let floats = unsafe { std::slice::from_raw_parts_mut(rays.as_mut_ptr().cast::<f32>(), len) };
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has AVX-512 F, checked just above.
                unsafe { avx512(floats, nt) };
                return;
            }
        }
        floats.fill(1.0);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn avx512(f: &mut [f32], nt: bool) {
        use std::arch::x86_64::*;
        let v = _mm512_set1_ps(1.0);
        let p = f.as_mut_ptr();
        let head = (p.align_offset(64)).min(f.len());
        // SAFETY: every store is within `f`: a masked head up to the first 64-byte boundary, aligned
        // 16-float blocks, a masked tail.
        unsafe {
            _mm512_mask_storeu_ps(p, ((1u32 << head) - 1) as u16, v);
            let body = (f.len() - head) / 16;
            let mut q = p.add(head);
            for _ in 0..body {
                if nt {
                    _mm512_stream_ps(q, v);
                } else {
                    _mm512_store_ps(q, v);
                }
                q = q.add(16);
            }
            let tail = f.len() - head - 16 * body;
            _mm512_mask_storeu_ps(q, ((1u32 << tail) - 1) as u16, v);
            if nt {
                _mm_sfence();
            }
        }
    }
}

/// The projections that offer `project_soa` (the perspective kernels and the centred panoramas), by
/// their label in `PERSPECTIVE` or `LIBRARY`: `soa_records` and `soa_arrays` run each.
const SOA: [&str; 12] = [
    "pinhole",
    "thin_lens",
    "sphere",
    "cylinder",
    "fisheye_equidistant",
    "fisheye_equisolid",
    "fisheye_stereographic",
    "fisheye_orthographic",
    "fisheye_polynomial",
    "mirror_ball",
    "cube_face",
    "octahedral",
];

/// The projection and parameters of an `SOA` label.
fn soa_entry(label: &str) -> (&'static str, &'static [(&'static str, &'static str)]) {
    match PERSPECTIVE.iter().find(|p| p.0 == label) {
        Some(p) => ("PxrPerspective", p.1),
        None => {
            let e = LIBRARY.iter().find(|e| e.0 == label).expect("a label of LIBRARY");
            (e.1, e.2)
        }
    }
}

/// `project` of an `SOA` projection into 40-byte records, batch 4096.
#[divan::bench(args = SOA)]
fn soa_records(bencher: Bencher, label: &str) {
    let (name, params) = soa_entry(label);
    bench_projection(bencher, 4096, name, params);
}

/// `project_soa` of an `SOA` projection into ten arrays (every field), batch 4096.
#[divan::bench(args = SOA)]
fn soa_arrays(bencher: Bencher, label: &str) {
    let (name, params) = soa_entry(label);
    let p = projection(name, params);
    let mut batch = Batch::new(4096, Aperture::Square);
    assert!(
        batch.run_soa(p.as_ref(), obscura_sdk::SoaFields::ALL),
        "{label} offers project_soa"
    );
    bencher.counter(ItemsCount::new(4096usize)).bench_local(|| {
        black_box(batch.run_soa(black_box(p.as_ref()), obscura_sdk::SoaFields::ALL));
    });
}
