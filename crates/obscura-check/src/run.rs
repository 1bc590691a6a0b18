//! Running a projection as a host does: the checker's random samples ([`SplitMix64`],
//! [`concentric_disk`]), the batches ([`Runner`]) and what a run gives back ([`Run`], [`Output`]).

use obscura_host::contract::{DefaultRays, Loss, call_project};
use obscura_host::driver::output_values;
use obscura_sdk::contract;
use obscura_sdk::{Point2, Projection, ProjectionContext, RayGeometry, Rgb, Vec3};

use crate::{Case, CheckResult, Sample};

/// SplitMix64 (Steele, Lea, Flood 2014): tiny, fast, and the same on every platform.
#[derive(Debug, Clone)]
pub(crate) struct SplitMix64(pub(crate) u64);

impl SplitMix64 {
    /// The next 64 random bits.
    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`: the top 24 bits, exactly representable.
    pub(crate) fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / 16_777_216.0)
    }
}

/// Shirley and Chiu's concentric map of `[0, 1)²` onto the unit disk (the host's circular aperture).
pub(crate) fn concentric_disk(u: Point2) -> Point2 {
    let (a, b) = (2.0 * u.x - 1.0, 2.0 * u.y - 1.0);
    if a == 0.0 && b == 0.0 {
        return Point2::ZERO;
    }
    let quarter = std::f32::consts::FRAC_PI_4;
    let (r, phi) = if a.abs() > b.abs() {
        (a, quarter * (b / a))
    } else {
        (b, 2.0 * quarter - quarter * (a / b))
    };
    Point2::new(r * phi.cos(), r * phi.sin())
}

/// The inputs `project` is handed for one sample.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Input {
    /// Screen position.
    pub(crate) screen: Point2,
    /// Canonical lens sample in `[0, 1)²`.
    pub(crate) lens: Point2,
    /// The lens sample warped to the unit disk.
    pub(crate) aperture: Point2,
    /// Time in `[0, 1)`.
    pub(crate) time: f32,
}

impl Input {
    /// The lens-centre sample at `screen` and `time`.
    pub(crate) fn chief(screen: Point2, time: f32) -> Self {
        Input {
            screen,
            lens: Point2::new(0.5, 0.5),
            aperture: Point2::ZERO,
            time,
        }
    }

    /// The sample as a report shows it.
    pub(crate) fn sample(&self) -> Sample {
        Sample {
            screen: self.screen,
            lens: self.lens,
            time: self.time,
        }
    }
}

/// What `project` wrote for one sample.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Output {
    /// The ray.
    pub(crate) ray: RayGeometry,
    /// The output time.
    pub(crate) time: f32,
    /// The tint.
    pub(crate) tint: Rgb,
}

/// The names of [`Output::values`], for messages.
pub(crate) use obscura_host::driver::OUTPUT_FIELDS as FIELDS;

impl Output {
    /// Every output number, in [`FIELDS`] order.
    pub(crate) fn values(&self) -> [f32; 14] {
        output_values(&self.ray, self.time, self.tint)
    }

    /// `None` when bit-identical, else (first differing field, largest difference).
    pub(crate) fn differs(&self, other: &Output) -> Option<(usize, f64)> {
        let (a, b) = (self.values(), other.values());
        let mut first = None;
        let mut worst = 0.0f64;
        for i in 0..a.len() {
            if a[i].to_bits() != b[i].to_bits() {
                first.get_or_insert(i);
                let d = (f64::from(a[i]) - f64::from(b[i])).abs();
                worst = worst.max(if d.is_nan() { f64::INFINITY } else { d });
            }
        }
        first.map(|f| (f, worst))
    }

    /// The first per-ray contract breach, if any: the host's own rule.
    pub(crate) fn breach(&self, unit_tolerance: f32) -> Option<contract::Breach> {
        contract::check_ray_with(&self.ray, self.time, self.tint, unit_tolerance)
    }
}

/// One run over all batches: the outputs (`None` for samples of a lost batch) and the losses as
/// (first sample of the batch, why).
pub(crate) struct Run {
    pub(crate) outputs: Vec<Option<Output>>,
    pub(crate) losses: Vec<(usize, Loss)>,
    /// `project` calls made.
    pub(crate) calls: u64,
}

/// Runs batches of samples through one projection as a host does: default rays and white tints
/// pre-filled, `project` called with panics caught.
pub(crate) struct Runner<'a> {
    /// The projection checked.
    pub(crate) projection: &'a dyn Projection,
    /// The host's default rays, pre-filled before `project`.
    pub(crate) prefill: DefaultRays,
    /// Samples per `project` call.
    pub(crate) batch_size: usize,
}

impl Runner<'_> {
    /// Projects one batch; `Err` when `project` panicked or reported an error.
    pub(crate) fn project(&self, inputs: &[Input]) -> Result<Vec<Output>, Loss> {
        let screen: Vec<Point2> = inputs.iter().map(|i| i.screen).collect();
        let lens: Vec<Point2> = inputs.iter().map(|i| i.lens).collect();
        let aperture: Vec<Point2> = inputs.iter().map(|i| i.aperture).collect();
        let mut time: Vec<f32> = inputs.iter().map(|i| i.time).collect();
        let mut rays: Vec<RayGeometry> = inputs
            .iter()
            .map(|i| self.prefill.ray(i.screen, i.aperture))
            .collect();
        let mut tint = vec![Rgb::WHITE; inputs.len()];
        let mut ctx = ProjectionContext::new(&screen, &lens, &aperture, &mut time, &mut rays, &mut tint)
            .expect("the batch's arrays are made alike just above");
        call_project(self.projection, &mut ctx)?;
        Ok(rays
            .into_iter()
            .zip(time)
            .zip(tint)
            .map(|((ray, time), tint)| Output { ray, time, tint })
            .collect())
    }

    /// Every batch of `inputs` once, starting with batch `start` and wrapping around.
    pub(crate) fn run_all(&self, inputs: &[Input], start: usize) -> Run {
        let n_batches = inputs.len().div_ceil(self.batch_size);
        let mut run = Run {
            outputs: vec![None; inputs.len()],
            losses: Vec::new(),
            calls: 0,
        };
        for k in 0..n_batches {
            let b = (start + k) % n_batches;
            let lo = b * self.batch_size;
            let hi = (lo + self.batch_size).min(inputs.len());
            run.calls += 1;
            match self.project(&inputs[lo..hi]) {
                Ok(out) => {
                    for (slot, o) in run.outputs[lo..hi].iter_mut().zip(out) {
                        *slot = Some(o);
                    }
                }
                Err(loss) => run.losses.push((lo, loss)),
            }
        }
        run
    }

    /// Lens-centre rays through `points` at time `t`: the valid, non-culled directions. A lost batch is
    /// recorded in `lost` (the report's Panic and Error results).
    pub(crate) fn directions(
        &self,
        points: &[Point2],
        t: f32,
        lost: &mut [CheckResult; 2],
        unit: f32,
    ) -> Vec<Option<Vec3>> {
        let inputs: Vec<Input> = points.iter().map(|&s| Input::chief(s, t)).collect();
        let mut out = vec![None; points.len()];
        for (chunk, slots) in inputs
            .chunks(self.batch_size)
            .zip(out.chunks_mut(self.batch_size))
        {
            lost[0].examined += 1;
            lost[1].examined += 1;
            match self.project(chunk) {
                Ok(rays) => {
                    for (slot, o) in slots.iter_mut().zip(rays) {
                        if o.breach(unit).is_none() && !o.ray.is_culled() {
                            *slot = Some(o.ray.direction);
                        }
                    }
                }
                Err(loss) => record_loss(lost, Some(chunk[0].sample()), &loss),
            }
        }
        out
    }
}

/// Records a lost `project` batch under Panic (`lost[0]`) or Error (`lost[1]`).
pub(crate) fn record_loss(lost: &mut [CheckResult; 2], sample: Option<Sample>, loss: &Loss) {
    match loss {
        Loss::Panicked(msg) => record_panic(&mut lost[0], sample, "project", msg),
        Loss::Failed(msg) => lost[1].fail(f64::INFINITY, || Case {
            sample,
            what: "project".into(),
            expected: "no error".into(),
            got: format!("returned an error: {msg}"),
            severity: 0.0,
        }),
    }
}

/// Records a panic in `call` as a Panic failure.
pub(crate) fn record_panic(panic: &mut CheckResult, sample: Option<Sample>, call: &str, msg: &str) {
    panic.fail(f64::INFINITY, || Case {
        sample,
        what: call.to_string(),
        expected: "no panic".into(),
        got: format!("panicked: {msg}"),
        severity: 0.0,
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix_matches_the_reference_and_stays_in_the_unit_interval() {
        // The reference implementation's first outputs for seed 0.
        let mut g = SplitMix64(0);
        assert_eq!(g.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(g.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        let mut g = SplitMix64(7);
        for _ in 0..10_000 {
            let x = g.next_f32();
            assert!((0.0..1.0).contains(&x));
        }
    }

    #[test]
    fn the_concentric_map_fills_the_disk_and_keeps_the_centre() {
        assert_eq!(concentric_disk(Point2::new(0.5, 0.5)), Point2::ZERO);
        let mut g = SplitMix64(1);
        for _ in 0..10_000 {
            let p = concentric_disk(Point2::new(g.next_f32(), g.next_f32()));
            assert!(p.x.hypot(p.y) <= 1.0 + 1e-6);
        }
        // The square's edge midpoint lands on the circle.
        let e = concentric_disk(Point2::new(1.0, 0.5));
        assert!((e.x - 1.0).abs() < 1e-6 && e.y.abs() < 1e-6);
    }
}
