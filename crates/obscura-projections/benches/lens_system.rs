//! `cargo bench -p obscura-projections --bench lens_system`: rays/s of `LensSystem` per core, batch
//! 4096 over a 1920×1080 frame with stratified aperture samples over the unit disk, beside the
//! same-run reference of `PxrPerspective`'s thin lens (a closed form) and the fraction of samples the
//! glass blocks. divan reports items/s: each item is one ray (pupil sampling, trace and tint).

use std::hint::black_box;

use divan::{Bencher, counter::ItemsCount};
use obscura_sdk::{
    Format, ParamList, Point2, Projection, ProjectionContext, ProjectionEnvironment, ProjectionFactory,
    RayGeometry, Rgb, ScreenWindow,
};

const N: usize = 4096;

fn main() {
    divan::main();
}

struct Batch {
    screen: Vec<Point2>,
    lens: Vec<Point2>,
    aperture: Vec<Point2>,
    time: Vec<f32>,
    rays: Vec<RayGeometry>,
    tint: Vec<Rgb>,
}

impl Batch {
    fn new(n: usize) -> Self {
        let format = Format::new(1920, 1080);
        let w = ScreenWindow::default_for(format);
        let side = (n as f64).sqrt().ceil() as usize;
        let screen = (0..n)
            .map(|i| {
                let (x, y) = ((i % side) as f64 + 0.5, (i / side) as f64 + 0.5);
                w.raster_to_screen(format, x / side as f64 * 1920.0, y / side as f64 * 1080.0)
            })
            .collect();
        let lens: Vec<Point2> = (0..n)
            .map(|i| Point2::new(((i * 37) % n) as f32 / n as f32, ((i * 91) % n) as f32 / n as f32))
            .collect();
        // Concentric-free polar map of the lens samples onto the unit disk (the host's default disk).
        let aperture = lens
            .iter()
            .map(|l| {
                let (r, phi) = (l.x.sqrt(), std::f32::consts::TAU * l.y);
                Point2::new(r * phi.cos(), r * phi.sin())
            })
            .collect();
        Batch {
            screen,
            lens,
            aperture,
            time: vec![0.0; n],
            rays: vec![RayGeometry::CULLED; n],
            tint: vec![Rgb::WHITE; n],
        }
    }

    fn run(&mut self, p: &dyn Projection) {
        let mut ctx = ProjectionContext::new(
            &self.screen,
            &self.lens,
            &self.aperture,
            &mut self.time,
            &mut self.rays,
            &mut self.tint,
        )
        .expect("equal lengths");
        p.project(&mut ctx);
    }
}

fn make(factory: &dyn ProjectionFactory, params: &[(&str, &str)]) -> Box<dyn Projection> {
    let mut list = ParamList::new();
    for (decl, v) in params {
        list.push_text(decl, &[v], None).expect("valid bench parameter");
    }
    let mut env = ProjectionEnvironment::for_format(Format::new(1920, 1080));
    factory
        .create_projection(&mut env, &list)
        .expect("valid bench projection")
}

fn bench(bencher: Bencher, p: &dyn Projection) {
    let mut batch = Batch::new(N);
    batch.run(p);
    let blocked = batch
        .tint
        .iter()
        .filter(|t| t.r == 0.0 && t.g == 0.0 && t.b == 0.0)
        .count();
    eprintln!(
        "  blocked: {:.1} % of the batch",
        100.0 * blocked as f64 / N as f64
    );
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        batch.run(black_box(p));
        black_box(&batch.rays);
    });
}

#[divan::bench]
fn dgauss_dispersion(bencher: Bencher) {
    let p = make(
        &obscura_projections::LensSystemFactory,
        &[("float focusDistance", "4")],
    );
    bench(bencher, p.as_ref());
}

#[divan::bench]
fn dgauss_d_line(bencher: Bencher) {
    let p = make(
        &obscura_projections::LensSystemFactory,
        &[("float focusDistance", "4"), ("int dispersion", "0")],
    );
    bench(bencher, p.as_ref());
}

#[divan::bench]
fn fisheye_d_line(bencher: Bencher) {
    let p = make(
        &obscura_projections::LensSystemFactory,
        &[("string lens", "fisheye.10mm"), ("int dispersion", "0")],
    );
    bench(bencher, p.as_ref());
}

#[divan::bench]
fn reference_perspective_thin_lens(bencher: Bencher) {
    let p = make(
        &obscura_projections::PerspectiveFactory,
        &[
            ("float fov", "40"),
            ("float fStop", "2"),
            ("float focalLength", "0.05"),
            ("float focalDistance", "4"),
        ],
    );
    bench(bencher, p.as_ref());
}
