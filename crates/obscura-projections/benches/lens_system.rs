//! `cargo bench -p obscura-projections --bench lens_system`: rays/s of `LensSystem` per core, batch
//! 4096 over a 1920×1080 frame with stratified aperture samples over the unit disk, beside the
//! same-run reference of `PxrPerspective`'s thin lens (a closed form) and the fraction of samples the
//! glass blocks. divan reports items/s: each item is one ray (pupil sampling, trace and tint).

use std::hint::black_box;

use divan::{Bencher, counter::ItemsCount};
mod common;
use common::{Aperture, Batch, projection};

const N: usize = 4096;

fn main() {
    divan::main();
}

/// A case: its label, the projection's name and its parameters.
type Case = (
    &'static str,
    &'static str,
    &'static [(&'static str, &'static str)],
);

/// The lens cases (the double Gauss by default) and the closed-form reference, by label.
const CASES: &[Case] = &[
    ("dgauss_dispersion", "LensSystem", &[("float focusDistance", "4")]),
    (
        "dgauss_d_line",
        "LensSystem",
        &[("float focusDistance", "4"), ("int dispersion", "0")],
    ),
    (
        "fisheye_d_line",
        "LensSystem",
        &[("string lens", "fisheye.10mm"), ("int dispersion", "0")],
    ),
    (
        "fisheye16_d_line",
        "LensSystem",
        &[("string lens", "fisheye.16mm"), ("int dispersion", "0")],
    ),
    (
        "reference_perspective_thin_lens",
        "PxrPerspective",
        &[
            ("float fov", "40"),
            ("float fStop", "2"),
            ("float focalLength", "0.05"),
            ("float focalDistance", "4"),
        ],
    ),
];

#[divan::bench(args = CASES.iter().map(|c| c.0))]
fn lens(bencher: Bencher, label: &str) {
    let (_, name, params) = CASES.iter().find(|c| c.0 == label).expect("a label of CASES");
    let p = projection(name, params);
    let mut batch = Batch::new(N, Aperture::Disk);
    batch.run(p.as_ref());
    let blocked = batch
        .tint
        .iter()
        .filter(|t| t.r == 0.0 && t.g == 0.0 && t.b == 0.0)
        .count();
    eprintln!(
        "  {label}: blocked {:.1} % of the batch",
        100.0 * blocked as f64 / N as f64
    );
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        batch.run(black_box(p.as_ref()));
        black_box(&batch.rays);
    });
}
