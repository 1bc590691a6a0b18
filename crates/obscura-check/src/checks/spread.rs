//! The ray-spread check: each chief ray's `ray_spread` against half the measured angle between the
//! chief rays of neighbouring pixel centres, `½·sqrt(αx·αy)`. Pairs across a discontinuity and pixels
//! where the angle changes too fast are left out, and counted in the notes. The per-pixel angles are
//! kept for the field-of-view check.

use obscura_sdk::{Point2, Vec3};

use super::{Checker, Grid, angle};
use crate::run::Run;
use crate::{Case, CheckKind, CheckResult, Sample};

/// The angles between neighbouring chief rays along one axis, `[row][column]`; `None` where either ray
/// is culled or invalid, or (after [`drop_discontinuities`]) the pair straddles a discontinuity.
type Pairs = Vec<Vec<Option<f64>>>;

impl Checker<'_> {
    /// Compares every window pixel's chief-ray spread with its measured neighbour angles, and stores
    /// those angles in `self.alphas`.
    pub(super) fn ray_spread(&mut self, g: &Grid, run: &Run, valid: &[bool]) {
        let (h, v) = neighbour_angles(g, run, valid);
        let ratio = self.opts.discontinuity_ratio;
        let mut discontinuities = 0u64;
        let h = drop_discontinuities(&h, ratio, &mut discontinuities);
        let v = drop_discontinuities(&v, ratio, &mut discontinuities);
        let mut axes = AxisAngles {
            curvature: self.opts.curvature_ratio,
            missing: 0,
            curved: 0,
        };
        let tol = self.opts.spread_tolerance;
        let idx = |gx: usize, gy: usize| gy * g.gw + gx;
        self.alphas = vec![None; g.w * g.h];
        let r = &mut self.report.checks[CheckKind::RaySpread.index()];
        for gy in 0..g.gh {
            for gx in 0..g.gw {
                if !g.in_window(gx, gy) || !valid[idx(gx, gy)] {
                    continue;
                }
                let Some(o) = run.outputs[idx(gx, gy)] else {
                    continue;
                };
                let ax = axes.at([
                    gx.checked_sub(1).and_then(|x| h[gy][x]),
                    h[gy].get(gx).copied().flatten(),
                ]);
                let ay = axes.at([
                    gy.checked_sub(1).and_then(|y| v[y][gx]),
                    v.get(gy).and_then(|row| row[gx]),
                ]);
                let (Some(ax), Some(ay)) = (ax, ay) else {
                    r.skipped += 1;
                    continue;
                };
                r.examined += 1;
                self.alphas[(gy - g.margin) * g.w + (gx - g.margin)] = Some((ax, ay));
                let at = g.centre(&self.window, self.format, gx, gy);
                compare_spread(r, at, (ax, ay), f64::from(o.ray.ray_spread), tol);
            }
        }
        if r.skipped > 0 {
            r.notes.push(format!(
                "{} pixels skipped: {} pixel axes lack a usable neighbour on one side (culled, invalid, \
                 or across a discontinuity), {} change angle by more than {}x from one side to \
                 the other (too curved to measure)",
                r.skipped, axes.missing, axes.curved, axes.curvature
            ));
        }
        if discontinuities > 0 {
            r.notes.push(format!(
                "{discontinuities} neighbour pairs left out as discontinuities (angle > {ratio}x the local median)"
            ));
        }
    }
}

/// `(h, v)`: `h[gy][gx]` between the chief rays of `(gx, gy)` and `(gx + 1, gy)`, `v[gy][gx]` between
/// `(gx, gy)` and `(gx, gy + 1)`.
fn neighbour_angles(g: &Grid, run: &Run, valid: &[bool]) -> (Pairs, Pairs) {
    let dir = |gx: usize, gy: usize| {
        let i = gy * g.gw + gx;
        run.outputs[i].filter(|_| valid[i]).map(|o| o.ray.direction)
    };
    let pair = |a: Option<Vec3>, b: Option<Vec3>| match (a, b) {
        (Some(a), Some(b)) => Some(angle(a, b)),
        _ => None,
    };
    let h = (0..g.gh)
        .map(|gy| {
            (0..g.gw.saturating_sub(1))
                .map(|gx| pair(dir(gx, gy), dir(gx + 1, gy)))
                .collect()
        })
        .collect();
    let v = (0..g.gh.saturating_sub(1))
        .map(|gy| (0..g.gw).map(|gx| pair(dir(gx, gy), dir(gx, gy + 1))).collect())
        .collect();
    (h, v)
}

/// `pairs` without the angles more than `ratio` times the median of the same axis's pairs within two
/// pixels; counts them in `dropped`.
fn drop_discontinuities(pairs: &Pairs, ratio: f64, dropped: &mut u64) -> Pairs {
    let rows = pairs.len();
    (0..rows)
        .map(|y| {
            let cols = pairs[y].len();
            (0..cols)
                .map(|x| {
                    let a = pairs[y][x]?;
                    let mut near: Vec<f64> = (y.saturating_sub(2)..(y + 3).min(rows))
                        .flat_map(|yy| {
                            (x.saturating_sub(2)..(x + 3).min(cols)).filter_map(move |xx| pairs[yy][xx])
                        })
                        .collect();
                    near.sort_by(f64::total_cmp);
                    let n = near.len();
                    let median = if n % 2 == 1 {
                        near[n / 2]
                    } else {
                        0.5 * (near[n / 2 - 1] + near[n / 2])
                    };
                    if a > ratio * median {
                        *dropped += 1;
                        None
                    } else {
                        Some(a)
                    }
                })
                .collect()
        })
        .collect()
}

/// The per-pixel angle on one axis, and how many pixel axes had none.
struct AxisAngles {
    /// The largest factor between the two sides' angles.
    curvature: f64,
    /// Pixel axes with no usable pair on one side.
    missing: u64,
    /// Pixel axes whose two sides differ by more than `curvature`.
    curved: u64,
}

impl AxisAngles {
    /// The mean of the pairs on either side of a pixel, when both are usable and agree within the
    /// curvature ratio (else the finite difference says little about the derivative at the pixel: a
    /// singular rim, a fold).
    fn at(&mut self, sides: [Option<f64>; 2]) -> Option<f64> {
        let [Some(p), Some(q)] = sides else {
            self.missing += 1;
            return None;
        };
        if p.max(q) > self.curvature * p.min(q) {
            self.curved += 1;
            return None;
        }
        Some(0.5 * (p + q))
    }
}

/// Advice for the classic RenderMan mistakes a spread `got` against `expected` betrays (empty when none
/// fits): unset (0), a quarter-pixel step (RenderMan's perspective example computes `xyStep` as a
/// quarter of a pixel, half of the half-pixel footprint), a whole pixel's angle, or degrees for
/// radians.
fn spread_advice(got: f64, expected: f64) -> &'static str {
    if expected <= 0.0 || !got.is_finite() {
        return "";
    }
    let ratio = got / expected;
    if got == 0.0 {
        "; raySpread is 0: unset, or an orthographic camera's (a camera with one centre must give the footprint's growth per unit distance)"
    } else if (0.4..0.6).contains(&ratio) {
        "; half the footprint: a quarter-pixel step (RenderMan's example's xyStep = 0.25·pixel) where the footprint's radius is half a pixel: use 0.5·pixel"
    } else if (1.7..2.3).contains(&ratio) {
        "; twice the footprint: a whole pixel's angle where the radius is half of it"
    } else if (45.0..70.0).contains(&ratio) {
        "; about 57x: the angle in degrees where radians are expected"
    } else {
        ""
    }
}

/// Records a failure in `r` when the spread `got` of the chief ray at screen `at` is more than `tol`
/// (relative) off half of `sqrt(ax·ay)`.
fn compare_spread(r: &mut CheckResult, at: Point2, (ax, ay): (f64, f64), got: f64, tol: f64) {
    let expected = 0.5 * (ax * ay).sqrt();
    let err = (got - expected).abs();
    // Not `err <= …`: a NaN error is no failure here (a NaN spread is the per-ray check's).
    let off = err > tol * expected + 1e-7;
    if !off {
        return;
    }
    let severity = if expected > 0.0 {
        err / expected
    } else {
        f64::INFINITY
    };
    r.fail(severity, || Case {
        sample: Some(Sample {
            screen: at,
            lens: Point2::new(0.5, 0.5),
            time: 0.0,
        }),
        what: "ray_spread of the chief ray".into(),
        expected: format!(
            "{expected:.6e} ± {:.0} % (half of sqrt(ax·ay), the measured angles between \
             neighbouring pixel centres' rays ax = {ax:.6e}, ay = {ay:.6e} rad)",
            tol * 100.0
        ),
        got: format!(
            "{got:.6e} ({:+.1} %){}",
            if expected > 0.0 {
                (got / expected - 1.0) * 100.0
            } else {
                f64::INFINITY
            },
            spread_advice(got, expected)
        ),
        severity: 0.0,
    });
}

#[cfg(test)]
mod advice_tests {
    use super::spread_advice;

    #[test]
    fn the_classic_spread_mistakes_are_named() {
        assert!(spread_advice(0.0, 0.01).contains("unset"));
        assert!(spread_advice(0.005, 0.01).contains("quarter-pixel"));
        assert!(spread_advice(0.02, 0.01).contains("twice"));
        assert!(spread_advice(0.573, 0.01).contains("degrees"));
        assert_eq!(spread_advice(0.013, 0.01), "");
        assert_eq!(spread_advice(0.005, 0.0), "");
    }
}
