//! The shutter-opening warp of time: canonical samples `u ∈ [0, 1)` → shutter-normalised times
//! `t ∈ [0, 1)` distributed with density proportional to the shutter's efficiency `e(t)`.
//!
//! The camera parameters are `shutterOpenTime` (a, default 0), `shutterCloseTime` (b, default 1) and
//! the eight floats of `shutteropening`, `c1 c2 d1 d2 e1 e2 f1 f2` (default `0 0 0 0 1 1 1 1`).
//! RenderMan describes the curve but not its exact parametrisation; this module is Obscura's
//! documented model.
//!
//! # Efficiency
//!
//! `e(t)` rises from 0 to 1 over `[0, a]`, stays at 1 on `[a, b]` and falls from 1 to 0 over `[b, 1]`;
//! it is 0 outside `[0, 1]`. Each edge is a cubic Bézier `P(s) = Σ Bᵢ(s)·Pᵢ`, `s ∈ [0, 1]`, whose two
//! inner control points are given in coordinates normalised to the edge, `(0, 0)` being the edge's
//! start point and `(1, 1)` its end point:
//!
//! - opening, from `P0 = (0, 0)` to `P3 = (a, 1)`: `P1 = (c1·a, c2)`, `P2 = (d1·a, d2)`;
//! - closing, from `P0 = (b, 1)` to `P3 = (1, 0)`: `P1 = (b + e1·(1 − b), 1 − e2)`,
//!   `P2 = (b + f1·(1 − b), 1 − f2)`.
//!
//! With the default control points every edge is a straight line (its inner control points sit on its
//! end points), so `a = b = 0` closes linearly over the whole interval (`e = 1 − t`) and `a = 0, b = 1`
//! is the instantaneous box shutter, for which the warp is the identity. RenderMan's example
//! `a = b = 1`, `0.8 0.1 0.9 0.2 1 1 1 1` opens slowly and then snaps open.
//!
//! Each edge's x control values `0, x₁, x₂, 1` (normalised) lie in `[0, 1]`, and the Bernstein form
//! of `x'(s)/3`, with coefficients `x₁, x₂ − x₁, 1 − x₂`, is then never negative
//! (`(x₁ − x₂)² ≤ x₁·(1 − x₂)` whenever `x₂ ≤ x₁`), so `x(s)` increases strictly and `e(t)` is a
//! function of t. It is evaluated by solving `x(s) = t` with safeguarded Newton iteration (bisection
//! fallback, to ~10⁻¹⁵) and returning `y(s)`.
//!
//! # Warp
//!
//! The CDF `F(t) = ∫₀ᵗ e / ∫₀¹ e` is tabulated at `t_j = j/4096`, each cell integrated with 5-point
//! Gauss–Legendre after splitting it at a and b (where e has kinks), in a
//! [`Distribution1D`] (whose weights are the cells' mean
//! efficiencies). The warp is its inverse: a binary search for the cell with `F(t_j) ≤ u < F(t_{j+1})`
//! and linear interpolation within it: `t = (j + (u − F_j)/(F_{j+1} − F_j)) / 4096`, clamped to
//! `[0, 1 − 2⁻²⁴]` so it never reaches 1. The box shutter skips the table and returns u bit for bit.
//!
//! # Validation
//!
//! `0 ≤ a ≤ b ≤ 1`, every control value finite and in `[0, 1]` (each control point inside its edge's
//! box), and `∫₀¹ e > 0`. Under the first two conditions the last always holds (`e > 0` on `(0, 1)`);
//! it is checked anyway so that a table that could not be normalised is never built.

use std::fmt;

use crate::distribution::Distribution1D;

/// Cells of the CDF table over `[0, 1]`.
const CELLS: usize = 4096;

/// The largest `f32` below 1: the upper bound of every warped time.
const ONE_MINUS_ULP: f32 = 1.0 - f32::EPSILON / 2.0;

/// 5-point Gauss–Legendre nodes on `[−1, 1]`.
const GL_NODES: [f64; 5] = [
    -0.906_179_845_938_664,
    -0.538_469_310_105_683_1,
    0.0,
    0.538_469_310_105_683_1,
    0.906_179_845_938_664,
];

/// 5-point Gauss–Legendre weights (they sum to 2).
const GL_WEIGHTS: [f64; 5] = [
    0.236_926_885_056_189_1,
    0.478_628_670_499_366_5,
    0.568_888_888_888_888_9,
    0.478_628_670_499_366_5,
    0.236_926_885_056_189_1,
];

/// Names of the eight `shutteropening` values, in order.
const OPENING_NAMES: [&str; 8] = ["c1", "c2", "d1", "d2", "e1", "e2", "f1", "f2"];

/// The camera's shutter description, in RenderMan's parameter terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShutterDesc {
    /// `shutterOpenTime` (a): the normalised time at which the shutter is fully open.
    pub open_time: f32,
    /// `shutterCloseTime` (b): the normalised time at which the shutter starts closing.
    pub close_time: f32,
    /// `shutteropening`: the Bézier control values `c1 c2 d1 d2 e1 e2 f1 f2`, each normalised to its
    /// edge (see the [module documentation](self)).
    pub opening: [f32; 8],
}

impl Default for ShutterDesc {
    /// RenderMan's defaults: `shutterOpenTime 0`, `shutterCloseTime 1`,
    /// `shutteropening [0 0 0 0 1 1 1 1]`: an instantaneous (box) shutter.
    fn default() -> Self {
        ShutterDesc {
            open_time: 0.0,
            close_time: 1.0,
            opening: [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0],
        }
    }
}

/// A [`ShutterDesc`] that [`ShutterWarp::new`] rejects; the message names the RenderMan parameter.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ShutterError {
    /// `shutterOpenTime` was not a finite number in `[0, 1]`.
    #[error("shutterOpenTime must be a finite number in [0, 1], got {value}")]
    OpenTime {
        /// The rejected value.
        value: f32,
    },
    /// `shutterCloseTime` was not a finite number in `[0, 1]`.
    #[error("shutterCloseTime must be a finite number in [0, 1], got {value}")]
    CloseTime {
        /// The rejected value.
        value: f32,
    },
    /// `shutterOpenTime` was later than `shutterCloseTime`.
    #[error(
        "shutterOpenTime ({open}) must not be later than shutterCloseTime ({close}): expected \
         0 <= shutterOpenTime <= shutterCloseTime <= 1"
    )]
    OpenAfterClose {
        /// The rejected `shutterOpenTime`.
        open: f32,
        /// The rejected `shutterCloseTime`.
        close: f32,
    },
    /// A `shutteropening` value was not a finite number in `[0, 1]`.
    #[error(
        "shutteropening[{index}] ({name}) must be a finite number in [0, 1] (control points are \
         normalised to their edge's box), got {value}"
    )]
    Opening {
        /// Position in the 8-float array.
        index: usize,
        /// Its name: `c1 c2 d1 d2 e1 e2 f1 f2`.
        name: &'static str,
        /// The rejected value.
        value: f32,
    },
    /// The efficiency integrates to zero (or to a non-finite value): the shutter never opens.
    #[error(
        "the shutter never opens: the integral of its efficiency over [0, 1] is {area}, expected > 0 \
         (check shutterOpenTime, shutterCloseTime and shutteropening)"
    )]
    NeverOpens {
        /// The integral that was found.
        area: f64,
    },
}

/// One edge of the efficiency curve in normalised coordinates: a cubic Bézier whose x control values
/// run from 0 to 1.
#[derive(Debug, Clone, Copy)]
struct Edge {
    /// x control values `0, x₁, x₂, 1`.
    x: [f64; 4],
    /// y (efficiency) control values.
    y: [f64; 4],
}

impl Edge {
    /// The efficiency at normalised position `x ∈ [0, 1]` along the edge.
    fn y_at(&self, x: f64) -> f64 {
        bezier(&self.y, self.solve(x))
    }

    /// The Bézier parameter s with `x(s) = x`.
    fn solve(&self, x: f64) -> f64 {
        if x <= 0.0 {
            return 0.0;
        }
        if x >= 1.0 {
            return 1.0;
        }
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        let mut s = x;
        for _ in 0..100 {
            let f = bezier(&self.x, s) - x;
            if f.abs() <= 1e-15 {
                break;
            }
            if f < 0.0 {
                lo = s;
            } else {
                hi = s;
            }
            if hi - lo <= 1e-15 {
                break;
            }
            let slope = bezier_derivative(&self.x, s);
            let newton = s - f / slope;
            s = if slope > 0.0 && newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
        }
        s
    }
}

/// A cubic Bézier in Bernstein form at parameter `s`.
#[inline]
fn bezier(p: &[f64; 4], s: f64) -> f64 {
    let r = 1.0 - s;
    r * r * r * p[0] + 3.0 * r * r * s * p[1] + 3.0 * r * s * s * p[2] + s * s * s * p[3]
}

/// The derivative of [`bezier`] with respect to `s`.
#[inline]
fn bezier_derivative(p: &[f64; 4], s: f64) -> f64 {
    let r = 1.0 - s;
    3.0 * (r * r * (p[1] - p[0]) + 2.0 * r * s * (p[2] - p[1]) + s * s * (p[3] - p[2]))
}

/// A validated shutter description with its CDF table precomputed; warps canonical time samples (see
/// the [module documentation](self) for the formulas).
///
/// Immutable after [`ShutterWarp::new`], so one warp may be shared by every rendering thread.
#[derive(Clone)]
pub struct ShutterWarp {
    /// `shutterOpenTime` a.
    open: f64,
    /// `shutterCloseTime` b.
    close: f64,
    /// The opening edge, over `[0, a]`.
    rise: Edge,
    /// The closing edge, over `[b, 1]`.
    fall: Edge,
    /// `∫₀¹ e` (1 for the identity).
    area: f64,
    /// The tabulated CDF over `CELLS` cells; `None` when `a = 0` and `b = 1` (the efficiency is 1 on
    /// `[0, 1]`, the warp the identity).
    table: Option<Distribution1D>,
}

impl fmt::Debug for ShutterWarp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ShutterWarp")
            .field("open", &self.open)
            .field("close", &self.close)
            .field("rise", &self.rise)
            .field("fall", &self.fall)
            .field("identity", &self.is_identity())
            .field("area", &self.area)
            .finish_non_exhaustive()
    }
}

impl ShutterWarp {
    /// Validates `desc` and tabulates the CDF of its efficiency.
    ///
    /// # Errors
    /// When `shutterOpenTime` or `shutterCloseTime` is not a finite number in `[0, 1]`, the open time
    /// is later than the close time, a `shutteropening` value is not a finite number in `[0, 1]`, or
    /// the efficiency integrates to zero.
    pub fn new(desc: &ShutterDesc) -> Result<Self, ShutterError> {
        let (a, b) = (desc.open_time, desc.close_time);
        if !(0.0..=1.0).contains(&a) {
            return Err(ShutterError::OpenTime { value: a });
        }
        if !(0.0..=1.0).contains(&b) {
            return Err(ShutterError::CloseTime { value: b });
        }
        if a > b {
            return Err(ShutterError::OpenAfterClose { open: a, close: b });
        }
        for (index, (&value, name)) in desc.opening.iter().zip(OPENING_NAMES).enumerate() {
            if !(0.0..=1.0).contains(&value) {
                return Err(ShutterError::Opening { index, name, value });
            }
        }
        let o = desc.opening.map(f64::from);
        let mut warp = ShutterWarp {
            open: f64::from(a),
            close: f64::from(b),
            rise: Edge {
                x: [0.0, o[0], o[2], 1.0],
                y: [0.0, o[1], o[3], 1.0],
            },
            fall: Edge {
                x: [0.0, o[4], o[6], 1.0],
                y: [1.0, 1.0 - o[5], 1.0 - o[7], 0.0],
            },
            area: 1.0,
            table: None,
        };
        if !(a == 0.0 && b == 1.0) {
            let table = warp.tabulate()?;
            warp.area = table.integral();
            warp.table = Some(table);
        }
        Ok(warp)
    }

    /// The CDF table of the efficiency: each cell's integral times `CELLS` as its weight (a power of two,
    /// so the table's running sums are the cells' integrals bit for bit).
    fn tabulate(&self) -> Result<Distribution1D, ShutterError> {
        let weights = (0..CELLS)
            .map(|j| self.integral(j as f64 / CELLS as f64, (j + 1) as f64 / CELLS as f64) * CELLS as f64)
            .collect();
        // The efficiency is clamped to [0, 1], so every weight is a number ≥ 0 and the table is built;
        // NaN stands for the impossible rejection.
        let table = Distribution1D::new(weights).map_err(|_| ShutterError::NeverOpens { area: f64::NAN })?;
        let area = table.integral();
        if !(area.is_finite() && area > 0.0) {
            return Err(ShutterError::NeverOpens { area });
        }
        Ok(table)
    }

    /// Whether the efficiency is 1 on all of `[0, 1]` (`shutterOpenTime 0`, `shutterCloseTime 1`, the
    /// default): [`ShutterWarp::warp`] then returns every `u ∈ [0, 1)` unchanged, bit for bit.
    #[inline]
    #[must_use]
    pub fn is_identity(&self) -> bool {
        self.table.is_none()
    }

    /// The efficiency `e(t) ∈ [0, 1]`: the fraction of the shutter that is open at normalised time t
    /// (0 outside `[0, 1]` and for NaN).
    #[must_use]
    pub fn efficiency(&self, t: f32) -> f32 {
        self.efficiency_f64(f64::from(t)) as f32
    }

    /// The normalised CDF `∫₀ᵗ e / ∫₀¹ e`: 0 for `t ≤ 0` (and NaN), 1 for `t ≥ 1`.
    #[must_use]
    pub fn cdf(&self, t: f32) -> f32 {
        if t.is_nan() || t <= 0.0 {
            return 0.0;
        }
        if t >= 1.0 {
            return 1.0;
        }
        let Some(table) = &self.table else {
            return t;
        };
        let t = f64::from(t);
        let j = table.cell(t);
        let value = table.cdf()[j] + self.integral(j as f64 / CELLS as f64, t) / self.area;
        value.clamp(0.0, 1.0) as f32
    }

    /// Warps a canonical sample `u ∈ [0, 1)` to a time distributed with density `e(t)/∫e`: the inverse
    /// of the tabulated CDF. The result is in `[0, 1)`, never 1. Inputs outside `[0, 1)` are clamped
    /// (NaN reads as 0); the identity shutter returns `u ∈ [0, 1)` unchanged.
    #[must_use]
    pub fn warp(&self, u: f32) -> f32 {
        let u = if u.is_nan() {
            0.0
        } else {
            u.clamp(0.0, ONE_MINUS_ULP)
        };
        let Some(table) = &self.table else {
            return u;
        };
        let (t, _, _) = table.sample_continuous(f64::from(u));
        (t as f32).clamp(0.0, ONE_MINUS_ULP)
    }

    /// Warps every time sample in place with [`ShutterWarp::warp`].
    pub fn warp_batch(&self, time: &mut [f32]) {
        for t in time {
            *t = self.warp(*t);
        }
    }

    /// `e(t)` in double precision.
    fn efficiency_f64(&self, t: f64) -> f64 {
        // Written so that NaN falls through to 0.
        if !(0.0..=1.0).contains(&t) {
            return 0.0;
        }
        let e = if t < self.open {
            self.rise.y_at(t / self.open)
        } else if t <= self.close {
            1.0
        } else {
            self.fall.y_at((t - self.close) / (1.0 - self.close))
        };
        e.clamp(0.0, 1.0)
    }

    /// `∫ e` over `[t0, t1]` (`t0 ≤ t1`), split at a and b, 5-point Gauss–Legendre on each piece.
    fn integral(&self, t0: f64, t1: f64) -> f64 {
        let mut cuts = [t0, t1, t1, t1];
        let mut n = 1;
        for k in [self.open, self.close] {
            if k > cuts[n - 1] && k < t1 {
                cuts[n] = k;
                n += 1;
            }
        }
        cuts[n] = t1;
        let mut sum = 0.0;
        for w in cuts[..=n].windows(2) {
            let (lo, hi) = (w[0], w[1]);
            let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
            let piece: f64 = GL_NODES
                .iter()
                .zip(GL_WEIGHTS)
                .map(|(&x, w)| w * self.efficiency_f64(mid + half * x))
                .sum();
            sum += half * piece;
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distribution::test_samples::Rng;
    use proptest::prelude::*;

    fn shutter(a: f32, b: f32, opening: [f32; 8]) -> ShutterWarp {
        ShutterWarp::new(&ShutterDesc {
            open_time: a,
            close_time: b,
            opening,
        })
        .expect("valid shutter")
    }

    const STRAIGHT: [f32; 8] = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
    const SLOW_OPEN_SNAP: [f32; 8] = [0.8, 0.1, 0.9, 0.2, 1.0, 1.0, 1.0, 1.0];
    const CUSTOM: [f32; 8] = [0.3, 0.7, 0.6, 0.95, 0.2, 0.1, 0.7, 0.6];

    /// Reference CDF built independently of the library: the area under each Bézier edge is
    /// accumulated in the curve parameter, `∫ y(s)·x'(s) ds`, with Simpson's rule on a fine s grid,
    /// giving monotone `(t, area)` knots that are interpolated linearly.
    struct ReferenceCdf {
        t: Vec<f64>,
        area: Vec<f64>,
    }

    impl ReferenceCdf {
        fn new(a: f64, b: f64, o: [f32; 8]) -> Self {
            let o = o.map(f64::from);
            let cubic = |p: [f64; 4], s: f64| {
                let r = 1.0 - s;
                p[0] * r.powi(3) + 3.0 * p[1] * r.powi(2) * s + 3.0 * p[2] * r * s.powi(2) + p[3] * s.powi(3)
            };
            let slope = |p: [f64; 4], s: f64| {
                let r = 1.0 - s;
                3.0 * (p[1] - p[0]) * r.powi(2)
                    + 6.0 * (p[2] - p[1]) * r * s
                    + 3.0 * (p[3] - p[2]) * s.powi(2)
            };
            let mut t = vec![0.0];
            let mut area = vec![0.0];
            let edge = |xs: [f64; 4], ys: [f64; 4], t: &mut Vec<f64>, area: &mut Vec<f64>| {
                let steps = 40_000;
                let h = 1.0 / steps as f64;
                let g = |s: f64| cubic(ys, s) * slope(xs, s);
                let mut acc = *area.last().expect("non-empty");
                for i in 0..steps {
                    let s0 = i as f64 * h;
                    acc += h / 6.0 * (g(s0) + 4.0 * g(s0 + 0.5 * h) + g(s0 + h));
                    t.push(cubic(xs, s0 + h));
                    area.push(acc);
                }
            };
            if a > 0.0 {
                edge(
                    [0.0, o[0] * a, o[2] * a, a],
                    [0.0, o[1], o[3], 1.0],
                    &mut t,
                    &mut area,
                );
            }
            if b > a {
                t.push(b);
                let last = *area.last().expect("non-empty");
                area.push(last + (b - a));
            }
            if b < 1.0 {
                let w = 1.0 - b;
                edge(
                    [b, b + o[4] * w, b + o[6] * w, 1.0],
                    [1.0, 1.0 - o[5], 1.0 - o[7], 0.0],
                    &mut t,
                    &mut area,
                );
            }
            let total = *area.last().expect("non-empty");
            for v in &mut area {
                *v /= total;
            }
            ReferenceCdf { t, area }
        }

        fn at(&self, x: f64) -> f64 {
            let i = self.t.partition_point(|&v| v <= x);
            if i == 0 {
                return 0.0;
            }
            if i >= self.t.len() {
                return 1.0;
            }
            let (t0, t1, a0, a1) = (self.t[i - 1], self.t[i], self.area[i - 1], self.area[i]);
            if t1 > t0 {
                a0 + (a1 - a0) * (x - t0) / (t1 - t0)
            } else {
                a1
            }
        }
    }

    /// The Kolmogorov–Smirnov statistic of `samples` (sorted in place) against `cdf`.
    fn ks_statistic(samples: &mut [f32], cdf: impl Fn(f64) -> f64) -> f64 {
        samples.sort_by(f32::total_cmp);
        let n = samples.len() as f64;
        samples
            .iter()
            .enumerate()
            .map(|(i, &x)| {
                let f = cdf(f64::from(x));
                (f - i as f64 / n).max((i + 1) as f64 / n - f)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn default_desc_is_renderman_default() {
        let d = ShutterDesc::default();
        assert_eq!(d.open_time, 0.0);
        assert_eq!(d.close_time, 1.0);
        assert_eq!(d.opening, STRAIGHT);
    }

    #[test]
    fn default_is_identity_bit_for_bit() {
        let mut rng = Rng(1);
        let mut inputs: Vec<f32> = (0..20_000).map(|_| rng.next_f32()).collect();
        inputs.extend([0.0, -0.0, f32::MIN_POSITIVE, 1e-30, 0.5, 0.999_999, ONE_MINUS_ULP]);
        for opening in [STRAIGHT, SLOW_OPEN_SNAP, CUSTOM] {
            let w = shutter(0.0, 1.0, opening);
            assert!(w.is_identity());
            for &u in &inputs {
                assert_eq!(w.warp(u).to_bits(), u.to_bits(), "u = {u}");
            }
            let mut batch = inputs.clone();
            w.warp_batch(&mut batch);
            assert!(batch.iter().zip(&inputs).all(|(a, b)| a.to_bits() == b.to_bits()));
            assert_eq!(w.efficiency(0.0), 1.0);
            assert_eq!(w.efficiency(1.0), 1.0);
            assert_eq!(w.cdf(0.25), 0.25);
        }
        assert!(!shutter(0.01, 1.0, STRAIGHT).is_identity());
        assert!(!shutter(0.0, 0.99, STRAIGHT).is_identity());
    }

    #[test]
    fn trapezoid_efficiency_matches_closed_form() {
        let (a, b) = (0.25f32, 0.75f32);
        let w = shutter(a, b, STRAIGHT);
        for i in 0..=1000 {
            let t = i as f32 / 1000.0;
            let expected = if t < a {
                t / a
            } else if t <= b {
                1.0
            } else {
                (1.0 - t) / (1.0 - b)
            };
            assert!(
                (w.efficiency(t) - expected).abs() < 1e-6,
                "t = {t}: {} vs {expected}",
                w.efficiency(t)
            );
        }
        assert_eq!(w.efficiency(-0.1), 0.0);
        assert_eq!(w.efficiency(1.1), 0.0);
        assert_eq!(w.efficiency(f32::NAN), 0.0);
    }

    #[test]
    fn trapezoid_cdf_matches_closed_form() {
        let (a, b) = (0.25f64, 0.75f64);
        let w = shutter(a as f32, b as f32, STRAIGHT);
        let total = 0.5 * a + (b - a) + 0.5 * (1.0 - b);
        let integral = |t: f64| {
            if t < a {
                t * t / (2.0 * a)
            } else if t <= b {
                0.5 * a + (t - a)
            } else {
                0.5 * a + (b - a) + ((1.0 - b).powi(2) - (1.0 - t).powi(2)) / (2.0 * (1.0 - b))
            }
        };
        for i in 0..=2000 {
            let t = i as f64 / 2000.0;
            let expected = integral(t) / total;
            let got = f64::from(w.cdf(t as f32));
            assert!((got - expected).abs() < 1e-4, "t = {t}: {got} vs {expected}");
        }
    }

    #[test]
    fn linear_close_has_density_two_times_one_minus_t() {
        let w = shutter(0.0, 0.0, STRAIGHT);
        for i in 0..=100 {
            let t = i as f32 / 100.0;
            assert!((w.efficiency(t) - (1.0 - t)).abs() < 1e-6);
            let cdf = 1.0 - (1.0 - f64::from(t)).powi(2);
            assert!((f64::from(w.cdf(t)) - cdf).abs() < 1e-5, "t = {t}");
        }
        let n = 100_000;
        let mean = (0..n)
            .map(|i| f64::from(w.warp((i as f32 + 0.5) / n as f32)))
            .sum::<f64>()
            / n as f64;
        assert!((mean - 1.0 / 3.0).abs() < 1e-4, "mean {mean}");
        // The reverse, a = b = 1: density 2t, mean 2/3.
        let w = shutter(1.0, 1.0, STRAIGHT);
        let mean = (0..n)
            .map(|i| f64::from(w.warp((i as f32 + 0.5) / n as f32)))
            .sum::<f64>()
            / n as f64;
        assert!((mean - 2.0 / 3.0).abs() < 1e-4, "mean {mean}");
    }

    #[test]
    fn efficiency_follows_the_bezier_edges() {
        // Forward evaluation of each edge at its own parameter must agree with the library's
        // inversion: e(x(s)) = y(s).
        let (a, b) = (0.2f64, 0.6f64);
        let w = shutter(a as f32, b as f32, CUSTOM);
        let o = CUSTOM.map(f64::from);
        let cubic = |p: [f64; 4], s: f64| {
            let r = 1.0 - s;
            p[0] * r.powi(3) + 3.0 * p[1] * r.powi(2) * s + 3.0 * p[2] * r * s.powi(2) + p[3] * s.powi(3)
        };
        for i in 0..=200 {
            let s = i as f64 / 200.0;
            let (x, y) = (
                cubic([0.0, o[0] * a, o[2] * a, a], s),
                cubic([0.0, o[1], o[3], 1.0], s),
            );
            assert!(
                (f64::from(w.efficiency(x as f32)) - y).abs() < 1e-4,
                "rise s = {s}"
            );
            let wd = 1.0 - b;
            let x = cubic([b, b + o[4] * wd, b + o[6] * wd, 1.0], s);
            let y = cubic([1.0, 1.0 - o[5], 1.0 - o[7], 0.0], s);
            assert!(
                (f64::from(w.efficiency(x as f32)) - y).abs() < 1e-4,
                "fall s = {s}"
            );
        }
        for t in [0.2f32, 0.3, 0.45, 0.6] {
            assert_eq!(w.efficiency(t), 1.0);
        }
        // RenderMan's example opens slowly: e stays low for most of the interval, then snaps to 1.
        let slow = shutter(1.0, 1.0, SLOW_OPEN_SNAP);
        assert!(slow.efficiency(0.5) < 0.2, "{}", slow.efficiency(0.5));
        assert!(slow.efficiency(0.999) > 0.9, "{}", slow.efficiency(0.999));
    }

    fn ks_case(a: f32, b: f32, opening: [f32; 8], seed: u64) {
        let w = shutter(a, b, opening);
        let reference = ReferenceCdf::new(f64::from(a), f64::from(b), opening);
        let n = 20_000;
        let critical = 1.36 / (n as f64).sqrt();
        let mut rng = Rng(seed);
        let mut samples: Vec<f32> = (0..n).map(|_| w.warp(rng.next_f32())).collect();
        let d_ref = ks_statistic(&mut samples, |t| reference.at(t));
        assert!(
            d_ref < critical,
            "KS against the reference: D = {d_ref} >= {critical}"
        );
        let d_uniform = ks_statistic(&mut samples, |t| t.clamp(0.0, 1.0));
        assert!(
            d_uniform > critical,
            "KS against uniform has no power: D = {d_uniform}"
        );
        // Stratified samples pin the inverse much tighter: F_ref(warp(u)) = u.
        for i in 0..n {
            let u = (i as f32 + 0.5) / n as f32;
            let err = (reference.at(f64::from(w.warp(u))) - f64::from(u)).abs();
            assert!(err < 2e-4, "u = {u}: F_ref(warp(u)) off by {err}");
        }
    }

    #[test]
    fn ks_slow_open_then_snap() {
        ks_case(1.0, 1.0, SLOW_OPEN_SNAP, 21);
    }

    #[test]
    fn ks_custom_curve() {
        ks_case(0.2, 0.6, CUSTOM, 22);
    }

    #[test]
    fn ks_vertical_tangent_edges() {
        // x control values 1, 0 give x'(s) = 0 at s = 1/2: a vertical tangent in the middle of the edge.
        ks_case(0.4, 0.5, [1.0, 0.2, 0.0, 0.9, 1.0, 0.5, 0.0, 0.5], 23);
    }

    #[test]
    fn cdf_inverts_warp_and_warp_is_monotone() {
        for (a, b, o) in [
            (0.25, 0.75, STRAIGHT),
            (1.0, 1.0, SLOW_OPEN_SNAP),
            (0.2, 0.6, CUSTOM),
            (0.0, 0.3, CUSTOM),
        ] {
            let w = shutter(a, b, o);
            let mut last = -1.0f32;
            for i in 0..5000 {
                let u = i as f32 / 5000.0;
                let t = w.warp(u);
                assert!(t >= last, "not monotone at u = {u}");
                last = t;
                assert!(
                    (w.cdf(t) - u).abs() < 1e-4,
                    "a = {a}, b = {b}: cdf(warp({u})) = {}",
                    w.cdf(t)
                );
            }
        }
    }

    #[test]
    fn extreme_inputs_map_into_the_half_open_interval() {
        for w in [
            shutter(0.0, 1.0, STRAIGHT),
            shutter(0.0, 0.0, STRAIGHT),
            shutter(1.0, 1.0, SLOW_OPEN_SNAP),
        ] {
            for u in [
                0.0f32,
                -0.0,
                -1.0,
                ONE_MINUS_ULP,
                1.0,
                2.0,
                f32::NAN,
                f32::INFINITY,
                f32::NEG_INFINITY,
            ] {
                let t = w.warp(u);
                assert!((0.0..1.0).contains(&t), "warp({u}) = {t}");
            }
            assert!(w.warp(ONE_MINUS_ULP) < 1.0);
        }
        // A very late, very slow opening still has positive area and a usable table.
        let w = shutter(1.0, 1.0, [1.0, 0.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0]);
        assert!(w.cdf(0.5) < 0.5);
        assert!((0.0..1.0).contains(&w.warp(0.5)));
    }

    #[test]
    fn gauss_legendre_is_exact_for_degree_nine() {
        let sum: f64 = GL_NODES
            .iter()
            .zip(GL_WEIGHTS)
            .map(|(&x, w)| w * (x.powi(8) + x.powi(9) + 1.0))
            .sum();
        assert!((sum - (2.0 / 9.0 + 2.0)).abs() < 1e-14, "{sum}");
    }

    #[test]
    fn invalid_descs_name_the_parameter() {
        let d = ShutterDesc::default();
        let mut bad_c = d;
        bad_c.opening[0] = 1.5;
        let mut bad_f2 = d;
        bad_f2.opening[7] = f32::NAN;
        let mut negative_e1 = d;
        negative_e1.opening[4] = -0.1;
        let cases = [
            (
                ShutterDesc {
                    open_time: 0.6,
                    close_time: 0.4,
                    ..d
                },
                ["shutterOpenTime", "shutterCloseTime"],
            ),
            (
                ShutterDesc { open_time: -0.1, ..d },
                ["shutterOpenTime", "[0, 1]"],
            ),
            (
                ShutterDesc {
                    open_time: f32::NAN,
                    ..d
                },
                ["shutterOpenTime", "finite"],
            ),
            (
                ShutterDesc { close_time: 1.5, ..d },
                ["shutterCloseTime", "[0, 1]"],
            ),
            (
                ShutterDesc {
                    close_time: f32::INFINITY,
                    ..d
                },
                ["shutterCloseTime", "finite"],
            ),
            (bad_c, ["shutteropening[0]", "c1"]),
            (bad_f2, ["shutteropening[7]", "f2"]),
            (negative_e1, ["shutteropening[4]", "[0, 1]"]),
        ];
        for (desc, words) in cases {
            match ShutterWarp::new(&desc) {
                Ok(_) => panic!("{desc:?} accepted"),
                Err(e) => {
                    let msg = e.to_string();
                    for word in words {
                        assert!(msg.contains(word), "{desc:?}: {msg:?} lacks {word:?}");
                    }
                }
            }
        }
        assert!(matches!(
            ShutterWarp::new(&ShutterDesc {
                open_time: 0.6,
                close_time: 0.4,
                ..d
            }),
            Err(ShutterError::OpenAfterClose { .. })
        ));
        assert!(matches!(
            ShutterWarp::new(&bad_c),
            Err(ShutterError::Opening { index: 0, .. })
        ));
    }

    #[test]
    fn warp_is_send_sync_clone() {
        fn check<T: Send + Sync + Clone>() {}
        check::<ShutterWarp>();
        let w = shutter(0.2, 0.6, CUSTOM);
        assert_eq!(w.clone().warp(0.37).to_bits(), w.warp(0.37).to_bits());
    }

    fn valid_desc() -> impl Strategy<Value = ShutterDesc> {
        (
            0.0f32..=1.0,
            0.0f32..=1.0,
            proptest::array::uniform8(0.0f32..=1.0),
        )
            .prop_map(|(x, y, opening)| ShutterDesc {
                open_time: x.min(y),
                close_time: x.max(y),
                opening,
            })
    }

    proptest! {
        #[test]
        fn warp_output_is_in_the_half_open_unit_interval(d in valid_desc(), u in 0.0f32..1.0) {
            let w = ShutterWarp::new(&d).expect("valid by construction");
            let t = w.warp(u);
            prop_assert!((0.0..1.0).contains(&t), "warp({}) = {}", u, t);
            let e = w.efficiency(t);
            prop_assert!((0.0..=1.0).contains(&e));
            let c = w.cdf(t);
            prop_assert!((0.0..=1.0).contains(&c));
        }
    }
}
