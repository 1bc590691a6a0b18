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
mod tests;
