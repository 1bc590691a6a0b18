//! `cargo bench -p obscura-projections`: rays/s of `project` per projection and batch size, beside two
//! same-run references: a scalar per-ray loop (one non-inlined call per ray, baseline instruction set)
//! and a store-bandwidth kernel that writes the same 40 bytes per ray and computes nothing.
//!
//! divan reports items/s: each item is one ray.

use std::hint::black_box;

use divan::{Bencher, counter::ItemsCount};
use obscura_projections::panorama::SphericalClip;
use obscura_sdk::optics::{PerspectiveRays, screen_distance};
use obscura_sdk::{Point2, RayGeometry, Vec3};

mod common;
use common::{Aperture, Batch, projection};

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
