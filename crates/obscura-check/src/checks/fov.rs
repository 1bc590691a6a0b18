//! The field-of-view check: the FieldOfView property against angular extents (and, for a Spherical
//! camera, angular rates) measured on lens-centre rays at several times over the shutter. See the
//! crate docs for the exact measures.

use obscura_sdk::{DicingHint, Point2, ProjectionProperty, PropertyValue, Vec3};

use super::{Checker, angle};
use crate::run::Runner;
use crate::{Case, CheckKind};

/// The times at which the extents are measured: a zoom passes with any value its field of view takes
/// during the shutter.
const TIMES: [f32; 5] = [0.0, 0.25, 0.5, 0.75, 1.0 - 1.0 / 16_777_216.0];

/// One measure of the field of view: its description, and its value in degrees at each time it was
/// taken (`None` where the rays needed were culled or invalid).
type Measure = (&'static str, Vec<Option<f64>>);

/// Radial lines from the window's centre to its edge in [`Checker::radial_widest`].
const AZIMUTHS: usize = 256;

impl Checker<'_> {
    /// Measures the extents the dicing hint calls for and compares the answered FieldOfView with them.
    pub(super) fn field_of_view(&mut self, runner: &Runner<'_>) {
        let Some(fov) = self.fov_to_check() else {
            return;
        };
        let hint = self.report.dicing_hint;
        let measures = if hint == DicingHint::Spherical {
            let mut m = self.spherical_extents(runner);
            m.extend(self.spherical_rates());
            m
        } else {
            self.perspective_extents(runner)
        };
        self.judge_fov(fov, &measures);
    }

    /// The answered FieldOfView when there is one to check; else notes (or fails) why not.
    fn fov_to_check(&mut self) -> Option<f32> {
        let hint = self.report.dicing_hint;
        let answer = self
            .report
            .properties
            .iter()
            .find(|(p, _)| *p == ProjectionProperty::FieldOfView)
            .and_then(|(_, v)| *v);
        let r = self.report.at(CheckKind::FieldOfView);
        let fov = match answer {
            None => {
                r.notes.push("FieldOfView not answered".into());
                return None;
            }
            Some(PropertyValue::Float(f)) => f,
            Some(_) => {
                r.notes
                    .push("answered with the wrong type (see property_type)".into());
                return None;
            }
        };
        if hint == DicingHint::Orthographic {
            r.notes.push(format!(
                "answered {fov} with DicingHint Orthographic, which has no field of view: not checked"
            ));
            return None;
        }
        r.examined = 1;
        if !(fov.is_finite() && fov > 0.0) {
            r.fail(f64::INFINITY, || Case {
                sample: None,
                what: "k_FieldOfView".into(),
                expected: "a positive, finite angle in degrees".into(),
                got: format!("{fov}"),
                severity: 0.0,
            });
            return None;
        }
        Some(fov)
    }

    /// Perspective (or no hint): the angles across the `[−1, 1]` square in x and in y, and across the
    /// window's width, height and diagonal, at each of [`TIMES`].
    fn perspective_extents(&mut self, runner: &Runner<'_>) -> Vec<Measure> {
        let unit = self.opts.unit_tolerance;
        let w = self.window;
        let (cx, cy) = (0.5 * (w.left + w.right), 0.5 * (w.bottom + w.top));
        let pairs: [(&str, Point2, Point2); 5] = [
            (
                "across the [-1, 1] square in x",
                Point2::new(-1.0, 0.0),
                Point2::new(1.0, 0.0),
            ),
            (
                "across the [-1, 1] square in y",
                Point2::new(0.0, -1.0),
                Point2::new(0.0, 1.0),
            ),
            (
                "across the window's width",
                Point2::new(w.left, cy),
                Point2::new(w.right, cy),
            ),
            (
                "across the window's height",
                Point2::new(cx, w.bottom),
                Point2::new(cx, w.top),
            ),
            (
                "across the window's diagonal",
                Point2::new(w.left, w.bottom),
                Point2::new(w.right, w.top),
            ),
        ];
        let points: Vec<Point2> = pairs.iter().flat_map(|(_, a, b)| [*a, *b]).collect();
        let mut per_time: Vec<Vec<Option<f64>>> = vec![Vec::new(); pairs.len()];
        for t in TIMES {
            let d = runner.directions(&points, t, self.report.lost(), unit);
            for (k, values) in per_time.iter_mut().enumerate() {
                values.push(match (d[2 * k], d[2 * k + 1]) {
                    (Some(a), Some(b)) => Some(angle(a, b).to_degrees()),
                    _ => None,
                });
            }
        }
        pairs
            .into_iter()
            .zip(per_time)
            .map(|((name, _, _), values)| (name, values))
            .collect()
    }

    /// Spherical: twice the widest angle from the central ray over the window, along its horizontal
    /// midline and along its vertical midline (a half-pixel grid, then [`Checker::radial_widest`]), at
    /// each of [`TIMES`].
    fn spherical_extents(&mut self, runner: &Runner<'_>) -> Vec<Measure> {
        let unit = self.opts.unit_tolerance;
        let w = self.window;
        let (cx, cy) = (0.5 * (w.left + w.right), 0.5 * (w.bottom + w.top));
        let (nx, ny) = (
            2 * self.format.width as usize + 1,
            2 * self.format.height as usize + 1,
        );
        let mut points = vec![Point2::new(cx, cy)];
        for y in 0..ny {
            for x in 0..nx {
                points.push(w.raster_to_screen(self.format, x as f64 * 0.5, y as f64 * 0.5));
            }
        }
        let names = [
            "2x the widest angle from the central ray over the window",
            "2x the widest angle from the central ray along the horizontal midline",
            "2x the widest angle from the central ray along the vertical midline",
        ];
        let mut per_time = [Vec::new(), Vec::new(), Vec::new()];
        for t in TIMES {
            let d = runner.directions(&points, t, self.report.lost(), unit);
            let mut widest = [None::<f64>; 3];
            if let Some(centre) = d[0] {
                for y in 0..ny {
                    for x in 0..nx {
                        let Some(dir) = d[1 + y * nx + x] else { continue };
                        let a = angle(centre, dir).to_degrees() * 2.0;
                        let on = [true, y == ny / 2, x == nx / 2];
                        for k in 0..3 {
                            if on[k] {
                                widen(&mut widest[k], a);
                            }
                        }
                    }
                }
                let radial = self.radial_widest(runner, t, centre);
                for k in 0..3 {
                    if let Some(a) = radial[k] {
                        widen(&mut widest[k], a);
                    }
                }
            }
            for k in 0..3 {
                per_time[k].push(widest[k]);
            }
        }
        names.into_iter().zip(per_time).collect()
    }

    /// Spherical: the angular rates a host dices at, written as a field of view. A host dices a
    /// Spherical camera at 2s/fov pixels per radian (s pixels per screen unit), so a FieldOfView chosen
    /// for the finest (or the central) angular resolution is honest too. Uses the per-pixel angles of
    /// the spread check, at time 0.
    fn spherical_rates(&self) -> Vec<Measure> {
        let mut measures: Vec<Measure> = Vec::new();
        let w = self.window;
        let (ww, hh) = (self.format.width as usize, self.format.height as usize);
        let s = (f64::from(self.format.width) / f64::from(w.width()).abs())
            .max(f64::from(self.format.height) / f64::from(w.height()).abs());
        let as_fov = |a: f64| vec![Some((2.0 * s * a).to_degrees())];
        let finest = self
            .alphas
            .iter()
            .flatten()
            .map(|(ax, ay)| ax.min(*ay))
            .fold(f64::INFINITY, f64::min);
        if finest.is_finite() {
            measures.push((
                "2s x the finest per-pixel angle in the window (s pixels per screen unit)",
                as_fov(finest),
            ));
        }
        let rows = [(hh - 1) / 2, hh / 2];
        let cols = [(ww - 1) / 2, ww / 2];
        let finest_on = |pixels: &mut dyn Iterator<Item = usize>| {
            pixels
                .filter_map(|i| self.alphas.get(i).copied().flatten())
                .map(|(ax, ay)| ax.min(ay))
                .fold(f64::INFINITY, f64::min)
        };
        let horizon = finest_on(&mut rows.into_iter().flat_map(|y| (0..ww).map(move |x| y * ww + x)));
        let meridian = finest_on(&mut cols.into_iter().flat_map(|x| (0..hh).map(move |y| y * ww + x)));
        for (name, a) in [
            (
                "2s x the finest per-pixel angle along the horizontal midline",
                horizon,
            ),
            (
                "2s x the finest per-pixel angle along the vertical midline",
                meridian,
            ),
        ] {
            if a.is_finite() {
                measures.push((name, as_fov(a)));
            }
        }
        let centre: Vec<(f64, f64)> = rows
            .into_iter()
            .flat_map(|y| cols.into_iter().map(move |x| y * ww + x))
            .filter_map(|i| self.alphas.get(i).copied().flatten())
            .collect();
        if !centre.is_empty() {
            let n = centre.len() as f64;
            let ax = centre.iter().map(|a| a.0).sum::<f64>() / n;
            let ay = centre.iter().map(|a| a.1).sum::<f64>() / n;
            measures.push((
                "2s x the per-pixel angle at the window's centre (the finer axis)",
                as_fov(ax.min(ay)),
            ));
        }
        measures
    }

    /// Passes when `fov` is within `max(tolerance·fov, tolerance in degrees)` of any measure at any
    /// time, or between a measure's smallest and largest value over the shutter.
    fn judge_fov(&mut self, fov: f32, measures: &[Measure]) {
        let hint = self.report.dicing_hint;
        let fov64 = f64::from(fov);
        let tol = (self.opts.fov_tolerance * fov64).max(self.opts.fov_tolerance_degrees);
        let mut best = f64::INFINITY;
        let mut described = Vec::new();
        for (name, values) in measures {
            let got: Vec<f64> = values.iter().flatten().copied().collect();
            if got.is_empty() {
                continue;
            }
            let lo = got.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = got.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let d = if (lo..=hi).contains(&fov64) {
                0.0
            } else {
                (fov64 - lo).abs().min((fov64 - hi).abs())
            };
            best = best.min(d);
            described.push(if hi - lo < 1e-3 {
                format!("{lo:.3}° {name}")
            } else {
                format!("{lo:.3}°..{hi:.3}° {name} over the shutter")
            });
        }
        let r = self.report.at(CheckKind::FieldOfView);
        if described.is_empty() {
            r.examined = 0;
            r.skipped = 1;
            r.notes
                .push("could not measure: the rays needed were culled or invalid".into());
            return;
        }
        if best > tol {
            r.fail(best, || Case {
                sample: None,
                what: format!("k_FieldOfView with DicingHint {hint:?}"),
                expected: format!("within {tol:.3}° of one of: {}", described.join("; ")),
                got: format!("{fov}°"),
                severity: 0.0,
            });
        }
    }

    /// Twice the widest angle (degrees) from `centre`, the ray at the window's centre, along
    /// [`AZIMUTHS`] radial lines from the centre to the window's edge: 64 steps each, then 24
    /// bisections of the step where the rays stop being valid, so a field of view reached only at a
    /// singular rim (a mirror ball's) is measured to within a hair. Over all lines, the horizontal ones,
    /// and the vertical ones.
    fn radial_widest(&mut self, runner: &Runner<'_>, t: f32, centre: Vec3) -> [Option<f64>; 3] {
        let mut search = RadialSearch::new(self, t, centre);
        let bracket = self.radial_scan(runner, &mut search);
        self.radial_bisect(runner, &mut search, bracket);
        let widest = search.widest;
        let max_of = |ks: &mut dyn Iterator<Item = usize>| {
            ks.filter_map(|k| widest[k])
                .fold(None, |m: Option<f64>, a| Some(m.map_or(a, |b| b.max(a))))
                .map(|a| 2.0 * a.to_degrees())
        };
        [
            max_of(&mut (0..AZIMUTHS)),
            max_of(&mut [0, AZIMUTHS / 2].into_iter()),
            max_of(&mut [AZIMUTHS / 4, 3 * AZIMUTHS / 4].into_iter()),
        ]
    }

    /// Walks every radial line in [`RadialSearch::STEPS`] steps, widening the search with each valid
    /// ray; returns, per line, the (last valid, first invalid) fractions where it stops being valid.
    fn radial_scan(&mut self, runner: &Runner<'_>, search: &mut RadialSearch) -> Vec<Option<(f64, f64)>> {
        const STEPS: usize = RadialSearch::STEPS;
        let points: Vec<Point2> = (0..AZIMUTHS)
            .flat_map(|k| (0..=STEPS).map(move |j| (k, j)))
            .map(|(k, j)| search.at(k, j as f64 / STEPS as f64))
            .collect();
        let d = runner.directions(&points, search.t, self.report.lost(), self.opts.unit_tolerance);
        let mut bracket: Vec<Option<(f64, f64)>> = vec![None; AZIMUTHS];
        for k in 0..AZIMUTHS {
            for j in 0..=STEPS {
                match d[k * (STEPS + 1) + j] {
                    Some(dir) => search.widen(k, dir),
                    None => {
                        if j > 0 {
                            bracket[k] = Some(((j - 1) as f64 / STEPS as f64, j as f64 / STEPS as f64));
                        }
                        break;
                    }
                }
            }
        }
        bracket
    }

    /// [`RadialSearch::ROUNDS`] bisections of every line's `bracket`, widening the search with each
    /// valid midpoint.
    fn radial_bisect(
        &mut self,
        runner: &Runner<'_>,
        search: &mut RadialSearch,
        mut bracket: Vec<Option<(f64, f64)>>,
    ) {
        for _ in 0..RadialSearch::ROUNDS {
            let active: Vec<(usize, f64, f64)> = bracket
                .iter()
                .enumerate()
                .filter_map(|(k, b)| b.map(|(lo, hi)| (k, lo, hi)))
                .collect();
            if active.is_empty() {
                break;
            }
            let mids: Vec<Point2> = active
                .iter()
                .map(|&(k, lo, hi)| search.at(k, 0.5 * (lo + hi)))
                .collect();
            let d = runner.directions(&mids, search.t, self.report.lost(), self.opts.unit_tolerance);
            for (&(k, lo, hi), dir) in active.iter().zip(d) {
                let mid = 0.5 * (lo + hi);
                bracket[k] = match dir {
                    Some(dir) => {
                        search.widen(k, dir);
                        Some((mid, hi))
                    }
                    None => Some((lo, mid)),
                };
            }
        }
    }
}

/// The search along [`AZIMUTHS`] lines from the window's centre to its edge, evenly spaced in
/// azimuth, for the widest angle from the central ray at one time.
struct RadialSearch {
    /// The time of the rays.
    t: f32,
    /// The direction of the ray at the window's centre.
    centre_ray: Vec3,
    /// The window's centre.
    centre: (f64, f64),
    /// Each line's far end, relative to the centre.
    ends: Vec<(f64, f64)>,
    /// The widest angle (radians) from `centre_ray` found on each line so far.
    widest: [Option<f64>; AZIMUTHS],
}

impl RadialSearch {
    /// Steps along each line in the first scan.
    const STEPS: usize = 64;
    /// Bisections of the step where a line stops being valid.
    const ROUNDS: usize = 24;

    fn new(checker: &Checker<'_>, t: f32, centre_ray: Vec3) -> Self {
        let w = checker.window;
        let centre = (
            0.5 * (f64::from(w.left) + f64::from(w.right)),
            0.5 * (f64::from(w.bottom) + f64::from(w.top)),
        );
        let (hw, hh) = (
            0.5 * f64::from(w.width()).abs(),
            0.5 * f64::from(w.height()).abs(),
        );
        let ends = (0..AZIMUTHS)
            .map(|k| {
                let (sin, cos) = (std::f64::consts::TAU * k as f64 / AZIMUTHS as f64).sin_cos();
                let reach_x = if cos.abs() > 1e-12 {
                    hw / cos.abs()
                } else {
                    f64::INFINITY
                };
                let reach_y = if sin.abs() > 1e-12 {
                    hh / sin.abs()
                } else {
                    f64::INFINITY
                };
                let reach = reach_x.min(reach_y);
                (cos * reach, sin * reach)
            })
            .collect();
        RadialSearch {
            t,
            centre_ray,
            centre,
            ends,
            widest: [None; AZIMUTHS],
        }
    }

    /// The point a fraction `f` of the way along line `k`.
    fn at(&self, k: usize, f: f64) -> Point2 {
        let (cx, cy) = self.centre;
        Point2::new((cx + self.ends[k].0 * f) as f32, (cy + self.ends[k].1 * f) as f32)
    }

    /// Widens line `k`'s widest angle with the ray direction `dir`.
    fn widen(&mut self, k: usize, dir: Vec3) {
        widen(&mut self.widest[k], angle(self.centre_ray, dir));
    }
}

/// Raises `slot` to `a` (or sets it, when empty).
fn widen(slot: &mut Option<f64>, a: f64) {
    *slot = Some(slot.map_or(a, |b| b.max(a)));
}
