//! The camera stage's structure-of-arrays run (`CameraStage::run_soa`, what Python's `project` uses)
//! against its array-of-structs run (`CameraStage::run`, what the renderer uses), for every built-in
//! projection with its default parameters (the test walks the registry, so a new projection is covered
//! as soon as it is registered): the same rays, times and tints bit for bit, and the same contract
//! report, whether the projection writes the arrays itself (`project_soa`) or the stage falls back to
//! `project`.

use obscura_host::driver::{Batch, output_values};
use obscura_host::{CameraDesc, CameraStage, SoaScratch};
use obscura_plugins::builtin_registry;
use obscura_sdk::{Format, ParamList, Point2, RaysSoa, Rgb};

/// A small deterministic generator (the test needs spread, not statistics).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// `n` samples over (and a little beyond) the screen window, with lens and time samples.
fn batch(cam: &CameraDesc, n: usize) -> Batch {
    let w = cam.screen_window();
    let mut rng = Lcg(29);
    let mut b = Batch::with_capacity(n);
    for _ in 0..n {
        let (u, v) = (rng.next() * 1.1 - 0.05, rng.next() * 1.1 - 0.05);
        let s = Point2::new(w.left + u * (w.right - w.left), w.bottom + v * (w.top - w.bottom));
        b.push(s, Point2::new(rng.next(), rng.next()), rng.next());
    }
    b
}

#[test]
fn every_builtin_gives_the_same_rays_and_report_through_run_soa_as_through_run() {
    let mut registry = builtin_registry();
    let names = registry.names();
    assert!(names.len() >= 10, "{names:?}");
    let mut cam = CameraDesc::new(Format::new(64, 48));
    cam.shutter = (0.0, 1.0);
    cam.aperture.n_sides = 6;
    // Not a multiple of the fallback's sub-batch or of any SIMD width.
    let n = 1003;
    let input = batch(&cam, n);
    for name in &names {
        let stage = CameraStage::new(&mut registry, name, &ParamList::new(), &cam)
            .unwrap_or_else(|e| panic!("{name} refused its own defaults: {e}"));
        let mut aos = input.clone();
        let aos_report = stage.run(&mut aos);

        let mut fields = vec![f32::NAN; 10 * n];
        let mut tint = vec![f32::NAN; 3 * n];
        let mut time = input.time.clone();
        let soa_report = {
            let (r, gb) = tint.split_at_mut(n);
            let (g, b) = gb.split_at_mut(n);
            stage
                .run_soa(
                    &input.screen,
                    &input.lens,
                    &mut time,
                    RaysSoa::from_fields(&mut fields).unwrap(),
                    [r, g, b],
                    &mut SoaScratch::default(),
                )
                .unwrap()
        };
        let soa = RaysSoa::from_fields(&mut fields).unwrap();
        for i in 0..n {
            let t = Rgb::new(tint[i], tint[n + i], tint[2 * n + i]);
            assert_eq!(
                output_values(&aos.rays[i], aos.time[i], aos.tint[i]).map(f32::to_bits),
                output_values(&soa.get(i), time[i], t).map(f32::to_bits),
                "{name}: sample {i}"
            );
        }
        assert_eq!(aos_report, soa_report, "{name}");
        assert_eq!(aos_report.samples, n as u64);
    }
}
