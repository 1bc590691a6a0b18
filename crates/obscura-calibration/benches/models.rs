//! `project` throughput of `CalibratedCamera` for each model family: one batch of 4096 screen
//! samples spread over the calibration image (valid and culled samples alike).
//!
//! `OBSCURA_BENCH_CASES=OPENCV,FOV cargo bench -p obscura-calibration --bench models` runs only the
//! listed cases.

use obscura_calibration::CalibratedCameraFactory;
use obscura_sdk::{
    Format, ParamList, Point2, Projection, ProjectionContext, ProjectionEnvironment, ProjectionFactory,
    RayGeometry, RaysSoa, Rgb, ScreenWindow, SoaContext,
};

const BATCH: usize = 4096;

/// (label, model, params, polynomial, inversePolynomial).
type Case = (
    &'static str,
    &'static str,
    &'static [f32],
    &'static [f32],
    &'static [f32],
);

const CASES: &[Case] = &[
    ("PINHOLE", "PINHOLE", &[500.0, 490.0, 320.0, 240.0], &[], &[]),
    (
        "OPENCV",
        "OPENCV",
        &[500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005],
        &[],
        &[],
    ),
    ("RADIAL", "RADIAL", &[500.0, 320.0, 240.0, -0.2, 0.05], &[], &[]),
    (
        "FULL_OPENCV",
        "FULL_OPENCV",
        &[
            500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005, -0.002, 0.01, 0.003, 0.0002,
        ],
        &[],
        &[],
    ),
    (
        "OPENCV_PINHOLE_14",
        "OPENCV_PINHOLE",
        &[
            500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005, -0.002, 0.01, 0.003, 0.0002, 0.001,
            -0.0002, 0.0008, 0.0001, 0.01, -0.008,
        ],
        &[],
        &[],
    ),
    (
        "KANNALA_BRANDT",
        "KANNALA_BRANDT",
        &[300.0, 300.0, 320.0, 240.0, -0.01, 0.02, -0.003, 0.0005],
        &[],
        &[],
    ),
    (
        "RAD_TAN_THIN_PRISM_FISHEYE",
        "RAD_TAN_THIN_PRISM_FISHEYE",
        &[
            240.0, 241.0, 320.0, 240.0, 0.02, -0.004, 0.0005, -0.0001, 0.00002, -0.000003, 0.0008, -0.0006,
            0.0004, -0.0001, 0.0003, 0.00005,
        ],
        &[],
        &[],
    ),
    ("FISHEYE", "FISHEYE", &[200.0, 210.0, 320.0, 240.0], &[], &[]),
    ("FOV", "FOV", &[300.0, 300.0, 320.0, 240.0, 0.9], &[], &[]),
    (
        "DIVISION",
        "DIVISION",
        &[400.0, 405.0, 320.0, 240.0, -0.15],
        &[],
        &[],
    ),
    ("EUCM", "EUCM", &[350.0, 350.0, 320.0, 240.0, 0.6, 1.1], &[], &[]),
    ("UCM", "UCM", &[300.0, 300.0, 320.0, 240.0, 0.58], &[], &[]),
    (
        "DOUBLE_SPHERE",
        "DOUBLE_SPHERE",
        &[250.0, 250.0, 320.0, 240.0, -0.2, 0.59],
        &[],
        &[],
    ),
    (
        "OPENCV_OMNIDIR",
        "OPENCV_OMNIDIR",
        &[400.0, 400.0, 320.0, 240.0, 0.5, 1.2, -0.1, 0.02, 0.001, -0.0005],
        &[],
        &[],
    ),
    ("EQUIRECTANGULAR", "EQUIRECTANGULAR", &[640.0, 480.0], &[], &[]),
    (
        "OCAMCALIB",
        "OCAMCALIB",
        &[239.5, 319.5, 1.00033, 0.000219, 0.000257],
        &[-206.517, 0.0, 2.207161e-03, -4.879622e-06, 1.865656e-08],
        &[],
    ),
    (
        "FTHETA_backward",
        "FTHETA",
        &[319.5, 239.5],
        &[0.0, 0.004, 1e-7, -2e-10],
        &[],
    ),
    (
        "3DE_CLASSIC",
        "3DE Classic LD Model",
        &[
            3.5, 2.4, 1.8, 0.03, -0.02, 1.0, 0.0, 1.0, 0.0, 1.0, -0.04, 1.3, 0.01, -0.01, 0.005,
        ],
        &[],
        &[],
    ),
    (
        "3DE_RADIAL_STANDARD_4",
        "3DE4 Radial - Standard, Degree 4",
        &[
            3.5, 2.4, 1.8, 0.03, -0.02, 1.0, 0.0, 1.0, 0.0, 1.0, -0.04, 0.002, -0.001, 0.01, 0.0005, 0.0003,
            25.0, 0.03,
        ],
        &[],
        &[],
    ),
    (
        "3DE_ANAMORPHIC_STANDARD_4",
        "3DE4 Anamorphic - Standard, Degree 4",
        &[
            3.5, 3.2, 1.2, 0.03, -0.02, 2.0, 0.0, 1.0, 0.0, 1.0, -0.04, -0.03, 0.01, 0.008, 0.005, 0.004,
            0.002, 0.001, -0.001, 0.0005, 1.5, 1.02, 0.98,
        ],
        &[],
        &[],
    ),
    (
        "3DE_ANAMORPHIC_STANDARD_6",
        "3DE4 Anamorphic - Standard, Degree 6",
        &[
            3.5, 3.2, 1.2, 0.03, -0.02, 2.0, 0.0, 1.0, 0.0, 1.0, -0.04, -0.03, 0.01, 0.008, 0.005, 0.004,
            0.002, 0.001, -0.001, 0.0005, 0.0003, 0.0002, -0.0001, 0.0001, 0.0001, -0.0001, 0.00005, 0.00005,
            1.5, 1.02, 0.98,
        ],
        &[],
        &[],
    ),
    (
        "3DE_RADIAL_FISHEYE_8",
        "3DE4 Radial - Fisheye, Degree 8",
        &[
            1.5, 2.4, 1.8, 0.03, -0.02, 1.0, 0.0, 1.0, 0.0, 1.0, 0.01, -0.001, 0.0001, 0.0001,
        ],
        &[],
        &[],
    ),
    (
        "FTHETA_forward_only",
        "FTHETA",
        &[319.5, 239.5, 1.7],
        &[],
        &[0.0, 250.0, -5.0, 1.0],
    ),
];

fn main() {
    divan::main();
}

fn list(model: &str, params: &[f32], pol: &[f32], inv: &[f32]) -> ParamList {
    let mut l = ParamList::new();
    let text = |v: &[f32]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    let push = |l: &mut ParamList, decl: &str, vals: Vec<String>| {
        let vals: Vec<&str> = vals.iter().map(String::as_str).collect();
        l.push_text(decl, &vals, None).unwrap();
    };
    push(&mut l, "string model", vec![model.to_string()]);
    push(&mut l, "float[] params", text(params));
    if !pol.is_empty() {
        push(&mut l, "float[] polynomial", text(pol));
    }
    if !inv.is_empty() {
        push(&mut l, "float[] inversePolynomial", text(inv));
    }
    push(&mut l, "int[2] resolution", vec!["640".into(), "480".into()]);
    l
}

/// The case labels to run: all, or those listed (comma-separated) in `OBSCURA_BENCH_CASES` (for
/// profiling one model at a time).
fn labels() -> Vec<&'static str> {
    let only = std::env::var("OBSCURA_BENCH_CASES").unwrap_or_default();
    let only: Vec<&str> = only.split(',').map(str::trim).filter(|s| !s.is_empty()).collect();
    CASES
        .iter()
        .map(|c| c.0)
        .filter(|l| only.is_empty() || only.contains(l))
        .collect()
}

/// The projection of case `label` and its batch of screen samples.
fn setup(label: &str) -> (Box<dyn Projection>, Vec<Point2>) {
    let (_, model, params, pol, inv) = *CASES.iter().find(|c| c.0 == label).unwrap();
    let format = Format::new(640, 480);
    let mut env = ProjectionEnvironment::for_format(format);
    let p: Box<dyn Projection> = CalibratedCameraFactory
        .create_projection(&mut env, &list(model, params, pol, inv))
        .unwrap();
    let w = ScreenWindow::default_for(format);
    let screen: Vec<Point2> = (0..BATCH)
        .map(|i| {
            let fx = (i as f64 * 0.618_033_988_75).fract();
            let fy = (i as f64 * 0.754_877_666_25).fract();
            w.raster_to_screen(format, fx * 640.0, fy * 480.0)
        })
        .collect();
    (p, screen)
}

#[divan::bench(args = labels())]
fn project(bencher: divan::Bencher, label: &str) {
    let (p, screen) = setup(label);
    let lens = vec![Point2::new(0.5, 0.5); BATCH];
    let aperture = vec![Point2::ZERO; BATCH];
    let mut time = vec![0.0f32; BATCH];
    let mut rays = vec![RayGeometry::CULLED; BATCH];
    let mut tint = vec![Rgb::WHITE; BATCH];
    bencher
        .counter(divan::counter::ItemsCount::new(BATCH))
        .bench_local(|| {
            let mut ctx =
                ProjectionContext::new(&screen, &lens, &aperture, &mut time, &mut rays, &mut tint).unwrap();
            p.project(divan::black_box(&mut ctx));
        });
}

/// `project_soa` of the same batch into ten arrays (every field) cut from one buffer at a 64-byte
/// boundary, so each array starts on a cache line.
#[divan::bench(args = labels())]
fn project_soa(bencher: divan::Bencher, label: &str) {
    let (p, screen) = setup(label);
    let lens = vec![Point2::new(0.5, 0.5); BATCH];
    let aperture = vec![Point2::ZERO; BATCH];
    let mut time = vec![0.0f32; BATCH];
    let mut buffer = vec![0.0f32; 10 * BATCH + 16];
    let skip = buffer.as_ptr().align_offset(64);
    let mut tint = vec![1.0f32; 3 * BATCH];
    bencher
        .counter(divan::counter::ItemsCount::new(BATCH))
        .bench_local(|| {
            let rays = RaysSoa::from_fields(&mut buffer[skip..skip + 10 * BATCH]).unwrap();
            let (r, gb) = tint.split_at_mut(BATCH);
            let (g, b) = gb.split_at_mut(BATCH);
            let mut ctx = SoaContext::new(&screen, &lens, &aperture, &mut time, rays, [r, g, b]).unwrap();
            assert!(p.project_soa(divan::black_box(&mut ctx)));
        });
}
