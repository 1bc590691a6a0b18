//! Lens distortion on a 2-D normalised plane, forward with its Jacobian, inverted exactly, and the
//! fold radius beyond which the forward map stops being one-to-one.
//!
//! One struct covers every polynomial distortion of the calibration libraries. With `q = |m|²` for
//! the undistorted point `m = (x, y)`:
//!
//! - radial factor `R(q) = (1 + k₁q + k₂q² + … + k₆q⁶)/(1 + d₁q + d₂q² + d₃q³)` (OpenCV's rational
//!   model; COLMAP's radial and fisheye models use only the numerator, on the θ-plane for fisheyes);
//! - **OpenCV order** (`tangential_after_radial = false`): tangential and thin-prism terms are
//!   evaluated on the undistorted point:
//!   `x_d = x·R + 2p₁xy + p₂(q + 2x²) + s₁q + s₂q²`, `y_d = y·R + p₁(q + 2y²) + 2p₂xy + s₃q + s₄q²`;
//! - **Aria order** (`tangential_after_radial = true`, COLMAP's RAD_TAN_THIN_PRISM_FISHEYE): first
//!   `(x', y') = R·(x, y)`, then the same tangential and thin-prism terms on `(x', y')` with
//!   `q' = x'² + y'²`.
//!
//! The inverse is exact to the last bits: a one-dimensional safeguarded Newton on the radius for
//! purely radial maps (the map is monotone up to the fold, so it always converges), and a
//! two-dimensional Newton with the analytic Jacobian started from the radial inverse otherwise.

use crate::solve::{self, InverseTable, Mat2, apply2, det2, inv2, mul2};

/// A polynomial (rational) radial, tangential and thin-prism distortion.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Distortion {
    /// Numerator coefficients of `q, q², …, q⁶`.
    pub num: [f64; 6],
    /// Denominator coefficients of `q, q², q³`.
    pub den: [f64; 3],
    /// OpenCV's `p₁, p₂`.
    pub p: [f64; 2],
    /// OpenCV's thin prism `s₁, s₂, s₃, s₄`.
    pub s: [f64; 4],
    /// Tangential and prism terms act on the radially distorted point (Aria), not the undistorted one.
    pub tangential_after_radial: bool,
    /// Numerator terms up to the last non-zero one (the rest are skipped).
    num_len: usize,
    /// Largest undistorted radius where the map is still one-to-one (the fold), or where the model's
    /// plane ends; computed by [`Distortion::finish`].
    pub max_radius: f64,
    /// Largest radius where the radial part alone is still increasing.
    radial_max: f64,
    /// `f(radial_max)`: no distorted radius beyond it has a preimage (∞ without a fold).
    radial_fold_image: f64,
    /// The radial inverse `r(r_d)` sampled over the image ([`Distortion::tabulate`]), seeding the
    /// exact solve.
    radial_table: Option<InverseTable>,
}

impl Distortion {
    /// A distortion with the given coefficients; call [`Distortion::finish`] before use.
    pub fn new(num: [f64; 6], den: [f64; 3], p: [f64; 2], s: [f64; 4], after_radial: bool) -> Self {
        Distortion {
            num,
            den,
            p,
            s,
            tangential_after_radial: after_radial,
            num_len: num.iter().rposition(|&k| k != 0.0).map_or(0, |i| i + 1),
            max_radius: f64::INFINITY,
            radial_max: f64::INFINITY,
            radial_fold_image: f64::INFINITY,
            radial_table: None,
        }
    }

    /// True when the map is the identity (all coefficients zero).
    pub fn is_identity(&self) -> bool {
        self.num
            .iter()
            .chain(&self.den)
            .chain(&self.p)
            .chain(&self.s)
            .all(|&c| c == 0.0)
    }

    /// True when the map has no tangential or prism terms (its inverse is one-dimensional).
    pub fn is_radial(&self) -> bool {
        self.p == [0.0; 2] && self.s == [0.0; 4]
    }

    /// `R(q)` and `dR/dq`.
    #[inline(always)]
    fn radial(&self, q: f64) -> (f64, f64) {
        self.radial_terms(&self.num[..self.num_len], self.den != [0.0; 3], q)
    }

    /// `R(q)` and `dR/dq` from the numerator terms `num` (the leading ones, or all six: leading zero
    /// terms leave Horner's result bit for bit unchanged at any finite `q`), with the denominator
    /// when `rational`.
    #[inline(always)]
    fn radial_terms(&self, num: &[f64], rational: bool, q: f64) -> (f64, f64) {
        let (mut n, mut dn) = (0.0, 0.0);
        for &k in num.iter().rev() {
            dn = dn * q + n;
            n = n * q + k;
        }
        // n holds Σ kᵢ q^(i−1); numerator N = 1 + q·n.
        let (num, dnum) = (1.0 + q * n, n + q * dn);
        if !rational {
            return (num, dnum);
        }
        let [d1, d2, d3] = self.den;
        let den = 1.0 + q * (d1 + q * (d2 + q * d3));
        let dden = d1 + q * (2.0 * d2 + 3.0 * q * d3);
        (num / den, (dnum * den - num * dden) / (den * den))
    }

    /// Radius after the radial part, `f(r) = r·R(r²)`, and `f'(r)`.
    #[inline]
    fn radial_radius(&self, r: f64) -> (f64, f64) {
        let q = r * r;
        let (rr, drr) = self.radial(q);
        (r * rr, rr + 2.0 * q * drr)
    }

    /// Tangential and prism terms added to `(x, y)` with radial factor `rr` and `drr = dR/dq`; value
    /// and Jacobian by `(x, y)`.
    #[inline(always)]
    fn tangential(&self, x: f64, y: f64, rr: f64, drr: f64) -> ([f64; 2], Mat2) {
        let [p1, p2] = self.p;
        let [s1, s2, s3, s4] = self.s;
        let q = x * x + y * y;
        let xd = x * rr + 2.0 * p1 * x * y + p2 * (q + 2.0 * x * x) + s1 * q + s2 * q * q;
        let yd = y * rr + p1 * (q + 2.0 * y * y) + 2.0 * p2 * x * y + s3 * q + s4 * q * q;
        let (sx, sy) = (s1 + 2.0 * s2 * q, s3 + 2.0 * s4 * q);
        let cross = 2.0 * x * y * drr + 2.0 * p1 * x + 2.0 * p2 * y;
        let j = [
            [
                rr + 2.0 * x * x * drr + 2.0 * p1 * y + 6.0 * p2 * x + 2.0 * x * sx,
                cross + 2.0 * y * sx,
            ],
            [
                cross + 2.0 * x * sy,
                rr + 2.0 * y * y * drr + 6.0 * p1 * y + 2.0 * p2 * x + 2.0 * y * sy,
            ],
        ];
        ([xd, yd], j)
    }

    /// The distorted point of `m` and the Jacobian `∂m_d/∂m`.
    #[inline(always)]
    pub fn forward(&self, m: [f64; 2]) -> ([f64; 2], Mat2) {
        self.forward_with(m, |q| self.radial(q), self.tangential_after_radial)
    }

    /// [`Distortion::forward`] with the radial factor and the order given (so a batch kernel can fix
    /// both at compile time and run the same operations).
    #[inline(always)]
    fn forward_with(&self, m: [f64; 2], radial: impl Fn(f64) -> (f64, f64), aria: bool) -> ([f64; 2], Mat2) {
        let (rr, drr) = radial(m[0] * m[0] + m[1] * m[1]);
        if !aria {
            return self.tangential(m[0], m[1], rr, drr);
        }
        let r = [m[0] * rr, m[1] * rr];
        let jr = [
            [rr + 2.0 * m[0] * m[0] * drr, 2.0 * m[0] * m[1] * drr],
            [2.0 * m[0] * m[1] * drr, rr + 2.0 * m[1] * m[1] * drr],
        ];
        let (d, jt) = self.tangential(r[0], r[1], 1.0, 0.0);
        (d, mul2(&jt, &jr))
    }

    /// Inverts the radial part alone: the point `m` with `R(|m|²)·m = md`, within the radial fold,
    /// and the Jacobian of the radial map there.
    ///
    /// Newton on the radius from the table's seed (else `r = r_d`), kept inside the bracket
    /// `[0, r_fold]` (where the radius map is increasing) by bisection; stops when a step is below
    /// 1e-12 of the radius (the error is then of the order of its square). The Jacobian is the one
    /// at the last iterate before that step.
    #[inline]
    fn invert_radial(&self, md: [f64; 2]) -> Option<([f64; 2], Mat2)> {
        let rd = (md[0] * md[0] + md[1] * md[1]).sqrt();
        if rd == 0.0 {
            return Some(([0.0, 0.0], solve::I2));
        }
        if rd >= self.radial_fold_image || rd.is_nan() {
            return None;
        }
        let (lo, hi) = (0.0, self.radial_max);
        let r = match self.radial_table.as_ref().and_then(|t| t.seed(rd)) {
            Some(seed) if seed < hi => seed,
            _ => rd.min(0.5 * hi),
        };
        let radius = |r: f64| {
            let q = r * r;
            let (rr, drr) = self.radial(q);
            (r * rr, rr + 2.0 * q * drr, (rr, drr))
        };
        let stop = |r: f64, next: f64, _, _| (next - r).abs() <= 1e-12 * next;
        let (r, (rr, drr)) = solve::newton_1d(radius, rd, [lo, hi], r, stop).ok()?;
        let k = r / rd;
        let m = [md[0] * k, md[1] * k];
        let cross = 2.0 * m[0] * m[1] * drr;
        let j = [
            [rr + 2.0 * m[0] * m[0] * drr, cross],
            [cross, rr + 2.0 * m[1] * m[1] * drr],
        ];
        Some((m, j))
    }

    /// Two-dimensional Newton for `g(m) = target`, `g` given with its Jacobian, from `m`, with
    /// COLMAP's trust region and iterates kept within `limit`. Returns the solution and the Jacobian
    /// of `g` there once a step is below 1e-12 of `|m|` and the residual before it below 1e-9 of the
    /// target.
    #[inline]
    fn newton(
        g: impl Fn([f64; 2]) -> ([f64; 2], Mat2),
        target: [f64; 2],
        mut m: [f64; 2],
        limit: f64,
    ) -> Option<([f64; 2], Mat2)> {
        let scale = 1.0 + target[0].abs() + target[1].abs();
        for _ in 0..NEWTON_2D_ITERATIONS {
            let (v, j) = g(m);
            let r = [v[0] - target[0], v[1] - target[1]];
            if !(r[0].is_finite() && r[1].is_finite()) {
                return None;
            }
            let mut step = apply2(&inv2(&j)?, r);
            // Trust region as COLMAP: no step longer than max(|m|/2, 0.1).
            let len = (step[0] * step[0] + step[1] * step[1]).sqrt();
            let radius = (0.5 * (m[0] * m[0] + m[1] * m[1]).sqrt()).max(0.1);
            if len > radius {
                step = [step[0] * radius / len, step[1] * radius / len];
            }
            m = [m[0] - step[0], m[1] - step[1]];
            let mr = (m[0] * m[0] + m[1] * m[1]).sqrt();
            if mr > limit {
                m = [m[0] * limit / mr, m[1] * limit / mr];
            }
            if len <= 1e-12 * (1.0 + m[0].abs() + m[1].abs()) {
                let err = r[0].abs() + r[1].abs();
                return (err <= 1e-9 * scale).then_some((m, j));
            }
        }
        None
    }

    /// The undistorted point of `md` and the Jacobian `∂m/∂m_d`, or `None` when `md` lies beyond the
    /// image of the fold (or the solve does not converge).
    #[inline]
    pub fn inverse(&self, md: [f64; 2]) -> Option<([f64; 2], Mat2)> {
        if let Some(solved) = self.seed(md).and_then(|seed| self.inverse_from(md, seed)) {
            return Some(solved);
        }
        let (m, j) = if self.is_radial() {
            self.invert_radial(md)?
        } else if self.tangential_after_radial {
            let t = |x: [f64; 2]| self.tangential(x[0], x[1], 1.0, 0.0);
            let (r, jt) = Self::newton(t, md, md, f64::INFINITY)?;
            let (m, jr) = self.invert_radial(r)?;
            (m, mul2(&jt, &jr))
        } else {
            let guess = self.invert_radial(md).map(|(m, _)| m).unwrap_or_else(|| {
                let rd = (md[0] * md[0] + md[1] * md[1]).sqrt().max(1e-300);
                let k = (0.9 * self.max_radius).min(rd) / rd;
                [md[0] * k, md[1] * k]
            });
            Self::newton(|x| self.forward(x), md, guess, self.max_radius)?
        };
        if m[0] * m[0] + m[1] * m[1] > self.max_radius * self.max_radius {
            return None;
        }
        Some((m, inv2(&j)?))
    }

    /// The undistorted point of `md` and `∂m/∂m_d`, by plain Newton steps from `seed`, a point
    /// already close to the solution (from a table of the inverse): `None` when four steps do not
    /// converge, a step leaves the region where the map is one-to-one, or the result lies beyond
    /// the fold. The caller then takes the safeguarded path.
    ///
    /// A step `s_k = J(m_k)⁻¹·(f(m_k) − m_d)` is, to first order, the error of `m_k`; `m_k − s_k` is
    /// accepted once `|s_k|₁ ≤ 1e-9` (and the residual is below 1e-9·(1 + |m_d|₁)): the error of
    /// `m_k` is then below 1e-9, and that of `m_k − s_k`, by Newton's quadratic convergence, of the
    /// order of `|s_k|²` (1e-18). The Jacobian returned is the inverse of
    /// `J(m_k)`, which differs from the one at the solution by `O(|s_k|)`.
    #[inline]
    pub fn inverse_from(&self, md: [f64; 2], seed: [f64; 2]) -> Option<([f64; 2], Mat2)> {
        let scale = 1.0 + md[0].abs() + md[1].abs();
        let mut m = seed;
        for _ in 0..SEEDED_ITERATIONS {
            match self.newton_step(md, scale, m) {
                Step::Failed => return None,
                Step::Converged(m, ji) => return self.inside(m).then_some((m, ji)),
                Step::Moved(next) => m = next,
            }
        }
        None
    }

    /// One step of [`Distortion::inverse_from`] from `m` toward `md` (`scale = 1 + |md|₁`).
    #[inline(always)]
    pub fn newton_step(&self, md: [f64; 2], scale: f64, m: [f64; 2]) -> Step {
        match Self::newton_core(self.forward(m), md, scale, m) {
            (false, ..) => Step::Failed,
            (true, true, m, ji) => Step::Converged(m, ji),
            (true, false, m, _) => Step::Moved(m),
        }
    }

    /// [`Distortion::newton_step`] without branches for a batch loop over lanes, with the shape
    /// fixed at compile time: `RATIONAL` is "the denominator is not 1", `ARIA` the order; the
    /// numerator is evaluated with all six terms (the same bits at finite arguments). Returns
    /// (Jacobian usable, converged, next iterate, `∂m/∂m_d`).
    #[inline(always)]
    pub fn newton_lane<const RATIONAL: bool, const ARIA: bool>(
        &self,
        md: [f64; 2],
        scale: f64,
        m: [f64; 2],
    ) -> (bool, bool, [f64; 2], Mat2) {
        debug_assert!(RATIONAL == (self.den != [0.0; 3]) && ARIA == self.tangential_after_radial);
        let forward = self.forward_with(m, |q| self.radial_terms(&self.num, RATIONAL, q), ARIA);
        Self::newton_core(forward, md, scale, m)
    }

    /// The step from `m` given the forward map there: (Jacobian usable, converged, next iterate,
    /// `∂m/∂m_d`). Inside the fold the determinant is positive; NaN (a seed next to an invalid table
    /// node) is unusable too.
    #[inline(always)]
    fn newton_core(
        (v, j): ([f64; 2], Mat2),
        md: [f64; 2],
        scale: f64,
        m: [f64; 2],
    ) -> (bool, bool, [f64; 2], Mat2) {
        let r = [v[0] - md[0], v[1] - md[1]];
        let det = det2(&j);
        let usable = (det > 0.0) & det.is_finite();
        let k = 1.0 / det;
        let ji = [[j[1][1] * k, -j[0][1] * k], [-j[1][0] * k, j[0][0] * k]];
        let step = apply2(&ji, r);
        let next = [m[0] - step[0], m[1] - step[1]];
        let converged = (step[0].abs() + step[1].abs() <= SEEDED_TOLERANCE)
            & (r[0].abs() + r[1].abs() <= SEEDED_TOLERANCE * scale);
        (usable, converged, next, ji)
    }

    /// The compile-time shape of [`Distortion::newton_lane`] that fits this distortion:
    /// `(rational, aria)`.
    pub fn shape(&self) -> (bool, bool) {
        (self.den != [0.0; 3], self.tangential_after_radial)
    }

    /// `m` lies within the fold.
    #[inline(always)]
    pub fn inside(&self, m: [f64; 2]) -> bool {
        m[0] * m[0] + m[1] * m[1] <= self.max_radius * self.max_radius
    }

    /// The radial inverse from the table alone (Hermite interpolation, ~1e-13 from the root), or
    /// `false` beyond the table (branch-free; the point is meaningless then).
    #[inline(always)]
    fn radial_seed_lane(&self, md: [f64; 2]) -> (bool, [f64; 2]) {
        let Some(table) = self.radial_table.as_ref() else {
            return (false, [0.0; 2]);
        };
        let rd = (md[0] * md[0] + md[1] * md[1]).sqrt();
        let (ok, r) = table.seed_lane(rd);
        let k = r / rd;
        let at_centre = rd == 0.0;
        let m = if at_centre {
            [0.0, 0.0]
        } else {
            [md[0] * k, md[1] * k]
        };
        (ok | at_centre, m)
    }

    /// A starting point for the two-dimensional inverse, a few 1e-6 from the root for real
    /// calibrations (branch-free; `false` when there is none): the tabulated radial inverse of `md`
    /// with the tangential and prism displacement `δ` taken out once. OpenCV order
    /// (`md = R·m + δ(m)`): `m₀ = R⁻¹(md)`, seed `R⁻¹(md − δ(m₀))`; Aria order (`md = x + δ(x)`,
    /// `x = R·m`): seed `R⁻¹(md − δ(md))`. The error is of the order of `|∂δ|·|δ|`. A purely radial
    /// map's seed is `R⁻¹(md)`.
    #[inline(always)]
    fn seed_lane(&self, md: [f64; 2]) -> (bool, [f64; 2]) {
        let (ok0, at) = self.seed_first(md);
        let (ok1, m) = self.seed_second(md, at);
        (ok0 & ok1, m)
    }

    /// The first half of [`Distortion::seed_lane`] (split so a batch can run each half over all its
    /// lanes): the point where `δ` is evaluated.
    #[inline(always)]
    pub fn seed_first(&self, md: [f64; 2]) -> (bool, [f64; 2]) {
        if self.is_radial() || self.tangential_after_radial {
            (true, md)
        } else {
            self.radial_seed_lane(md)
        }
    }

    /// The second half of [`Distortion::seed_lane`], from [`Distortion::seed_first`]'s point.
    #[inline(always)]
    pub fn seed_second(&self, md: [f64; 2], at: [f64; 2]) -> (bool, [f64; 2]) {
        if self.is_radial() {
            return self.radial_seed_lane(md);
        }
        // δ(x): the tangential and prism terms alone (radial factor 1).
        let (t, _) = self.tangential(at[0], at[1], 1.0, 0.0);
        let d = [t[0] - at[0], t[1] - at[1]];
        self.radial_seed_lane([md[0] - d[0], md[1] - d[1]])
    }

    /// [`Distortion::seed_lane`] as an option.
    #[inline(always)]
    pub fn seed(&self, md: [f64; 2]) -> Option<[f64; 2]> {
        let (ok, m) = self.seed_lane(md);
        ok.then_some(m)
    }

    /// Tabulates the radial inverse over distorted radii `[0, rd_max]` (the image's extent), to seed
    /// [`Distortion::invert_radial`] within ~1e-13 of the root, where one Newton step confirms it.
    /// Call after [`Distortion::finish`].
    pub fn tabulate(&mut self, rd_max: f64) {
        const SAMPLES: usize = 512;
        let end = rd_max.min(self.radial_fold_image);
        self.radial_table = None;
        if !(end > 0.0 && end.is_finite()) {
            return;
        }
        let table = InverseTable::new(
            end,
            SAMPLES,
            |r| self.radial_radius(r),
            |rd, _| self.invert_radial([rd, 0.0]).map(|(m, _)| m[0]),
        );
        self.radial_table = Some(table);
    }

    /// Finds the fold: the smallest radius (≤ `limit`, the end of the model's plane) where the
    /// forward map's Jacobian determinant stops being positive in some direction, by a geometric
    /// scan then bisection. Sets `max_radius` to it (or `limit` when there is none before).
    pub fn finish(&mut self, limit: f64) {
        let this = self.clone();
        let radial_ok = |r: f64| {
            let (f, df) = this.radial_radius(r);
            f.is_finite() && df > 0.0
        };
        let radial_max = fold(limit, radial_ok);
        const ANGLES: usize = 48;
        let dirs: Vec<[f64; 2]> = (0..ANGLES)
            .map(|i| {
                let a = std::f64::consts::TAU * (i as f64 + 0.5) / ANGLES as f64;
                [a.cos(), a.sin()]
            })
            .collect();
        let ok = |r: f64| {
            radial_ok(r)
                && dirs.iter().all(|d| {
                    let (v, j) = this.forward([d[0] * r, d[1] * r]);
                    let det = det2(&j);
                    v[0].is_finite() && v[1].is_finite() && det > 0.0 && det.is_finite()
                })
        };
        self.max_radius = fold(radial_max, ok);
        self.radial_max = radial_max;
        self.radial_fold_image = if radial_max.is_finite() {
            self.radial_radius(radial_max).0
        } else {
            f64::INFINITY
        };
    }
}

/// The outcome of one [`Distortion::newton_step`].
#[derive(Debug, Clone, Copy)]
pub(crate) enum Step {
    /// The Jacobian is singular or not finite there: the seeded solve gives up.
    Failed,
    /// The step was below the tolerance: the point after it, and `∂m/∂m_d` from before it.
    Converged([f64; 2], Mat2),
    /// Not yet converged: the next iterate.
    Moved([f64; 2]),
}

/// Newton steps [`Distortion::inverse_from`] takes from a seed before giving up (two suffice from
/// [`Distortion::seed`] for real calibrations).
pub(crate) const SEEDED_ITERATIONS: usize = 4;

/// Step (and residual) size, in normalised coordinates, after which [`Distortion::inverse_from`]
/// takes one last step and stops.
const SEEDED_TOLERANCE: f64 = 1e-9;

/// Iterations of the two-dimensional Newton: from the radial inverse it converges in a few; a point
/// beyond the fold's image never does, and is given up after this many.
const NEWTON_2D_ITERATIONS: usize = 40;

/// The first radius in `(0, limit]` where `ok` fails (scanned geometrically from 1e-4, then
/// bisected), or `limit` when it never does. The scan ends at 1e6 at the latest: on the perspective
/// plane that is 0.00006° short of 90°, and a distortion polynomial extrapolated that far is no
/// calibration any more, so the valid set ends there.
fn fold(limit: f64, ok: impl Fn(f64) -> bool) -> f64 {
    let end = limit.min(1e6);
    let radii = std::iter::successors(Some(1e-4f64.min(end)), |&r| {
        (r < end).then(|| (r * 1.02).min(end))
    });
    solve::first_failure(radii, ok).unwrap_or(end)
}

/// OpenCV's tilted-sensor projection (`computeTiltProjectionMatrix`): a homography of the
/// distorted normalised plane for the sensor tilts `τx`, `τy` (radians).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Tilt {
    h: [[f64; 3]; 3],
    inv: [[f64; 3]; 3],
}

impl Tilt {
    /// The tilt of `τx`, `τy`: `R = R_y(τy)·R_x(τx)`, `H = [[R₂₂, 0, −R₀₂], [0, R₂₂, −R₁₂], [0, 0, 1]]·R`.
    pub fn new(tau_x: f64, tau_y: f64) -> Option<Self> {
        let (sx, cx) = tau_x.sin_cos();
        let (sy, cy) = tau_y.sin_cos();
        let rx = [[1.0, 0.0, 0.0], [0.0, cx, sx], [0.0, -sx, cx]];
        let ry = [[cy, 0.0, -sy], [0.0, 1.0, 0.0], [sy, 0.0, cy]];
        let r = mul3(&ry, &rx);
        let proj = [
            [r[2][2], 0.0, -r[0][2]],
            [0.0, r[2][2], -r[1][2]],
            [0.0, 0.0, 1.0],
        ];
        let h = mul3(&proj, &r);
        Some(Tilt { h, inv: inv3(&h)? })
    }

    #[inline(always)]
    fn map(h: &[[f64; 3]; 3], p: [f64; 2]) -> Option<([f64; 2], Mat2)> {
        let a = h[0][0] * p[0] + h[0][1] * p[1] + h[0][2];
        let b = h[1][0] * p[0] + h[1][1] * p[1] + h[1][2];
        let c = h[2][0] * p[0] + h[2][1] * p[1] + h[2][2];
        if c <= 0.0 {
            return None;
        }
        // One division: a batch of tilted pixels is bound by their latency.
        let w = 1.0 / c;
        let (x, y) = (a * w, b * w);
        let j = [
            [(h[0][0] - x * h[2][0]) * w, (h[0][1] - x * h[2][1]) * w],
            [(h[1][0] - y * h[2][0]) * w, (h[1][1] - y * h[2][1]) * w],
        ];
        Some(([x, y], j))
    }

    /// Distorted point → point on the tilted sensor, with the Jacobian.
    pub fn forward(&self, p: [f64; 2]) -> Option<([f64; 2], Mat2)> {
        Self::map(&self.h, p)
    }

    /// Point on the tilted sensor → distorted point, with the Jacobian.
    #[inline(always)]
    pub fn inverse(&self, p: [f64; 2]) -> Option<([f64; 2], Mat2)> {
        Self::map(&self.inv, p)
    }
}

fn mul3(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

fn inv3(a: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let c = |i: usize, j: usize| {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
        a[i1][j1] * a[i2][j2] - a[i1][j2] * a[i2][j1]
    };
    let det = a[0][0] * c(0, 0) + a[0][1] * c(0, 1) + a[0][2] * c(0, 2);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = c(j, i) / det;
        }
    }
    Some(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn opencv14() -> Distortion {
        let mut d = Distortion::new(
            [-0.28, 0.07, -0.002, 0.0, 0.0, 0.0],
            [0.01, 0.002, 0.0003],
            [0.0012, -0.0007],
            [0.001, -0.0002, 0.0008, 0.0001],
            false,
        );
        d.finish(f64::INFINITY);
        d
    }

    #[test]
    fn the_jacobian_matches_finite_differences() {
        for after in [false, true] {
            let mut d = opencv14();
            d.tangential_after_radial = after;
            for m in [[0.3, -0.2], [-0.5, 0.41], [0.05, 0.7]] {
                let (_, j) = d.forward(m);
                let h = 1e-6;
                for k in 0..2 {
                    let mut a = m;
                    let mut b = m;
                    a[k] += h;
                    b[k] -= h;
                    let (fa, _) = d.forward(a);
                    let (fb, _) = d.forward(b);
                    for i in 0..2 {
                        let fd = (fa[i] - fb[i]) / (2.0 * h);
                        assert!(
                            (fd - j[i][k]).abs() < 1e-8,
                            "after {after} m {m:?} ∂{i}/∂{k}: {fd} vs {}",
                            j[i][k]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn a_barrel_polynomial_folds_where_its_derivative_vanishes() {
        // r·(1 − 0.3r²): derivative 1 − 0.9r² vanishes at r = 1/sqrt(0.9).
        let mut d = Distortion::new(
            [-0.3, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0; 3],
            [0.0; 2],
            [0.0; 4],
            false,
        );
        d.finish(f64::INFINITY);
        assert!(
            (d.max_radius - 1.0 / 0.9f64.sqrt()).abs() < 1e-9,
            "{}",
            d.max_radius
        );
        // Beyond the fold's image (r_d > f(r_fold)) nothing inverts.
        let rf = d.max_radius;
        let fmax = rf * (1.0 - 0.3 * rf * rf);
        assert!(d.inverse([fmax * 1.001, 0.0]).is_none());
        // Inside it, the inverse is the root inside the fold, not the one beyond.
        let (m, _) = d.inverse([fmax * 0.99, 0.0]).unwrap();
        assert!(m[0] < rf && (m[0] * (1.0 - 0.3 * m[0] * m[0]) - fmax * 0.99).abs() < 1e-14);
        // A pincushion never folds: its valid set ends only where the scan does, 0.00006° short of 90°.
        let mut p = Distortion::new(
            [0.1, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0; 3],
            [0.0; 2],
            [0.0; 4],
            false,
        );
        p.finish(f64::INFINITY);
        assert_eq!(p.max_radius, 1e6);
    }

    #[test]
    fn the_tilt_homography_inverts_and_is_the_identity_at_zero() {
        let t = Tilt::new(0.0, 0.0).unwrap();
        let (p, j) = t.forward([0.3, -0.2]).unwrap();
        assert!((p[0] - 0.3).abs() < 1e-15 && (p[1] + 0.2).abs() < 1e-15 && (j[0][0] - 1.0).abs() < 1e-15);
        let t = Tilt::new(0.02, -0.015).unwrap();
        let (p, _) = t.forward([0.3, -0.2]).unwrap();
        let (q, _) = t.inverse(p).unwrap();
        assert!((q[0] - 0.3).abs() < 1e-14 && (q[1] + 0.2).abs() < 1e-14);
        assert!((p[0] - 0.3).abs() > 1e-4, "a tilt moves points");
    }

    proptest! {
        #[test]
        fn inverse_undoes_forward_within_the_fold(x in -1.2f64..1.2, y in -1.2f64..1.2, after in any::<bool>()) {
            let mut d = opencv14();
            d.tangential_after_radial = after;
            d.finish(f64::INFINITY);
            prop_assume!(x * x + y * y < 0.95 * d.max_radius * d.max_radius);
            let (md, j) = d.forward([x, y]);
            let (m, ji) = d.inverse(md).unwrap();
            prop_assert!((m[0] - x).abs() < 1e-12 && (m[1] - y).abs() < 1e-12, "{:?} vs {:?}", m, [x, y]);
            let p = mul2(&j, &ji);
            prop_assert!((p[0][0] - 1.0).abs() < 1e-9 && p[0][1].abs() < 1e-9);
        }
    }
}
