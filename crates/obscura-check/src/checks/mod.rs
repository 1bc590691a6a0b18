//! The checks, one file per family, as methods of one [`Checker`] that holds the projection, the
//! environment, the options and the report being written.
//!
//! [`Checker::run`] asks the properties, samples the window, runs every batch twice in order and once
//! on each of several threads, then hands the runs to each check in turn. The per-ray checks decide
//! which samples are valid; only those reach the geometric checks, so each fault is reported once.

mod fov;
mod metric_hint;
mod per_ray;
mod properties;
mod repeatability;
mod spread;
mod unproject;

use obscura_sdk::{Format, Point2, Projection, ProjectionEnvironment, ScreenWindow, Vec3};

use crate::run::{Input, Run, Runner, SplitMix64, concentric_disk, record_loss};
use crate::{CheckOptions, CheckReport};

/// One projection being checked, and its report so far.
pub(crate) struct Checker<'a> {
    p: &'a dyn Projection,
    env: &'a ProjectionEnvironment,
    opts: &'a CheckOptions,
    format: Format,
    window: ScreenWindow,
    /// Pixel size in screen units.
    pixel: (f64, f64),
    report: CheckReport,
    /// `(αx, αy)`, the measured per-pixel angles at each window pixel (row by row), from the spread check.
    alphas: Vec<Option<(f64, f64)>>,
}

/// The chief-ray grid: `gw × gh` pixel centres, the window's pixels plus `margin` on every side.
struct Grid {
    gw: usize,
    gh: usize,
    margin: usize,
    w: usize,
    h: usize,
}

impl Grid {
    fn in_window(&self, gx: usize, gy: usize) -> bool {
        (self.margin..self.margin + self.w).contains(&gx) && (self.margin..self.margin + self.h).contains(&gy)
    }

    /// The screen position of the centre of grid pixel `(gx, gy)`.
    fn centre(&self, window: &ScreenWindow, format: Format, gx: usize, gy: usize) -> Point2 {
        window.raster_to_screen(
            format,
            gx as f64 - self.margin as f64 + 0.5,
            gy as f64 - self.margin as f64 + 0.5,
        )
    }
}

/// The runs every check reads: the first sequential run, a second one for determinism, and one per
/// thread of the concurrency check.
struct Runs {
    first: Run,
    second: Run,
    concurrent: Vec<Run>,
}

impl<'a> Checker<'a> {
    /// A checker of `p`, created in `env`, with the sampling and tolerances of `opts`.
    pub(crate) fn new(p: &'a dyn Projection, env: &'a ProjectionEnvironment, opts: &'a CheckOptions) -> Self {
        let f = env.format();
        let format = Format {
            width: f.width.max(1),
            height: f.height.max(1),
            pixel_aspect: f.pixel_aspect,
        };
        let window = env.screen_window();
        Checker {
            p,
            env,
            opts,
            format,
            window,
            pixel: (
                f64::from(window.width()) / f64::from(format.width),
                f64::from(window.height()) / f64::from(format.height),
            ),
            report: CheckReport::empty("", env, opts),
            alphas: Vec::new(),
        }
    }

    /// Every check, in the order that lets later checks use what earlier ones measured.
    pub(crate) fn run(mut self) -> CheckReport {
        let prefill = self.properties();
        let runner = Runner {
            projection: self.p,
            prefill,
            batch_size: self.opts.batch_size.max(1),
        };
        let m = self.opts.margin as usize;
        let grid = Grid {
            gw: self.format.width as usize + 2 * m,
            gh: self.format.height as usize + 2 * m,
            margin: m,
            w: self.format.width as usize,
            h: self.format.height as usize,
        };
        let (inputs, lens_centre) = self.samples(&grid);
        self.report.samples = inputs.len() as u64;
        let Runs {
            first,
            second,
            concurrent,
        } = self.run_batches(&runner, &inputs);

        let valid = self.per_ray(&inputs, &first);
        self.repeatability(&inputs, &first, &second, &concurrent);
        self.clipping(&inputs, &first, &valid);
        self.deep_metric(&inputs, &first, &valid);
        self.dicing_hint(&inputs, &grid, &first, &valid);
        self.ray_spread(&grid, &first, &valid);
        self.field_of_view(&runner);
        self.unproject(&inputs, &lens_centre, &first, &valid);
        self.report
    }

    /// Runs every batch twice in order, then on [`CheckOptions::threads`] threads at once, each
    /// starting at a different batch; records the lost batches of every run.
    fn run_batches(&mut self, runner: &Runner<'_>, inputs: &[Input]) -> Runs {
        let first = runner.run_all(inputs, 0);
        let second = runner.run_all(inputs, 0);
        let n_batches = inputs.len().div_ceil(runner.batch_size);
        let threads = self.opts.threads.max(1);
        let concurrent: Vec<Run> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..threads)
                .map(|t| s.spawn(move || runner.run_all(inputs, t * n_batches / threads)))
                .collect();
            handles.into_iter().filter_map(|h| h.join().ok()).collect()
        });
        for run in std::iter::once(&first)
            .chain(std::iter::once(&second))
            .chain(&concurrent)
        {
            let lost = self.report.lost();
            lost[0].examined += run.calls;
            lost[1].examined += run.calls;
            for (i, loss) in &run.losses {
                record_loss(lost, Some(inputs[*i].sample()), loss);
            }
        }
        Runs {
            first,
            second,
            concurrent,
        }
    }

    /// The chief grid (index `gy·gw + gx`) followed by the random samples, and the indices of the
    /// lens-centre samples inside the window.
    fn samples(&self, g: &Grid) -> (Vec<Input>, Vec<usize>) {
        let spp = self.opts.samples_per_pixel as usize;
        let mut inputs = Vec::with_capacity(g.gw * g.gh * (1 + spp));
        let mut lens_centre = Vec::new();
        let raster = |gx: usize, gy: usize, jx: f32, jy: f32| {
            self.window.raster_to_screen(
                self.format,
                gx as f64 - g.margin as f64 + f64::from(jx),
                gy as f64 - g.margin as f64 + f64::from(jy),
            )
        };
        for gy in 0..g.gh {
            for gx in 0..g.gw {
                if g.in_window(gx, gy) {
                    lens_centre.push(inputs.len());
                }
                inputs.push(Input::chief(raster(gx, gy, 0.5, 0.5), 0.0));
            }
        }
        let mut rng = SplitMix64(self.opts.seed);
        for gy in 0..g.gh {
            for gx in 0..g.gw {
                for k in 0..spp {
                    let (jx, jy) = (rng.next_f32(), rng.next_f32());
                    let screen = raster(gx, gy, jx, jy);
                    let time = rng.next_f32();
                    if k == 0 {
                        if g.in_window(gx, gy) {
                            lens_centre.push(inputs.len());
                        }
                        inputs.push(Input::chief(screen, time));
                    } else {
                        let lens = Point2::new(rng.next_f32(), rng.next_f32());
                        inputs.push(Input {
                            screen,
                            lens,
                            aperture: concentric_disk(lens),
                            time,
                        });
                    }
                }
            }
        }
        (inputs, lens_centre)
    }
}

/// `|got − want| / max(|want|, 10⁻³)`; 0 when equal (both infinite included), ∞ when only one is
/// infinite or either is NaN.
fn relative_error(got: f32, want: f32) -> f64 {
    if got == want {
        return 0.0;
    }
    let (g, w) = (f64::from(got), f64::from(want));
    let e = (g - w).abs() / w.abs().max(1e-3);
    if e.is_finite() { e } else { f64::INFINITY }
}

/// `(x, y, z)`, for messages.
fn v3(v: Vec3) -> String {
    format!("({}, {}, {})", v.x, v.y, v.z)
}

/// The length of `v`, in f64.
fn norm(v: Vec3) -> f64 {
    let (x, y, z) = (f64::from(v.x), f64::from(v.y), f64::from(v.z));
    (x * x + y * y + z * z).sqrt()
}

/// The distance between two points, in f64.
fn dist(a: Vec3, b: Vec3) -> f64 {
    let (x, y, z) = (
        f64::from(a.x) - f64::from(b.x),
        f64::from(a.y) - f64::from(b.y),
        f64::from(a.z) - f64::from(b.z),
    );
    (x * x + y * y + z * z).sqrt()
}

/// The angle between two directions in radians, accurate for tiny and near-π angles:
/// `atan2(|a × b|, a · b)` in f64 (independent of the vectors' lengths).
fn angle(a: Vec3, b: Vec3) -> f64 {
    let (ax, ay, az) = (f64::from(a.x), f64::from(a.y), f64::from(a.z));
    let (bx, by, bz) = (f64::from(b.x), f64::from(b.y), f64::from(b.z));
    let (cx, cy, cz) = (ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx);
    (cx * cx + cy * cy + cz * cz)
        .sqrt()
        .atan2(ax * bx + ay * by + az * bz)
}
