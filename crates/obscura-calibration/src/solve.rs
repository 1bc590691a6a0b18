//! Small f64 numerics shared by the models: polynomials, 2×2 matrices, and the one-dimensional
//! solvers every model uses: a safeguarded Newton for monotone functions and a bisection.

/// A 2×2 matrix, row-major: `[[a, b], [c, d]]`.
pub(crate) type Mat2 = [[f64; 2]; 2];

/// The identity.
pub(crate) const I2: Mat2 = [[1.0, 0.0], [0.0, 1.0]];

/// `a·b`.
#[inline]
pub(crate) fn mul2(a: &Mat2, b: &Mat2) -> Mat2 {
    [
        [
            a[0][0] * b[0][0] + a[0][1] * b[1][0],
            a[0][0] * b[0][1] + a[0][1] * b[1][1],
        ],
        [
            a[1][0] * b[0][0] + a[1][1] * b[1][0],
            a[1][0] * b[0][1] + a[1][1] * b[1][1],
        ],
    ]
}

/// The determinant.
#[inline]
pub(crate) fn det2(a: &Mat2) -> f64 {
    a[0][0] * a[1][1] - a[0][1] * a[1][0]
}

/// The inverse, or `None` when the matrix is singular (or not finite).
#[inline]
pub(crate) fn inv2(a: &Mat2) -> Option<Mat2> {
    let det = det2(a);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let k = 1.0 / det;
    Some([[a[1][1] * k, -a[0][1] * k], [-a[1][0] * k, a[0][0] * k]])
}

/// `a·v`.
#[inline]
pub(crate) fn apply2(a: &Mat2, v: [f64; 2]) -> [f64; 2] {
    [a[0][0] * v[0] + a[0][1] * v[1], a[1][0] * v[0] + a[1][1] * v[1]]
}

/// A 3×2 matrix (the derivative of a 3-vector by a 2-vector), row-major.
pub(crate) type Mat32 = [[f64; 2]; 3];

/// `a·b` for a 3×2 times a 2×2.
#[inline]
pub(crate) fn mul32(a: &Mat32, b: &Mat2) -> Mat32 {
    let row = |r: [f64; 2]| [r[0] * b[0][0] + r[1] * b[1][0], r[0] * b[0][1] + r[1] * b[1][1]];
    [row(a[0]), row(a[1]), row(a[2])]
}

/// A polynomial `c[0] + c[1]·x + c[2]·x² + …` and its derivative at `x` (Horner).
#[inline(always)]
pub(crate) fn poly(c: &[f64], x: f64) -> (f64, f64) {
    let mut p = 0.0;
    let mut dp = 0.0;
    for &a in c.iter().rev() {
        dp = dp * x + p;
        p = p * x + a;
    }
    (p, dp)
}

/// Largest number of iterations any solver takes: bisection halves the bracket each time, so this
/// many steps reach the last bit of an f64 bracket of any width the models use.
pub(crate) const MAX_ITERATIONS: usize = 100;

/// Solves `f(x) = target` for `x ∈ [lo, hi]` where `f` is increasing on the bracket, starting at
/// `guess`: Newton steps, falling back to bisection whenever a step leaves the shrinking bracket or
/// the derivative is not positive. `f` returns the value and the derivative.
///
/// `hi` may be infinite: the bracket is then grown by doubling (up to 1e12) until it holds the
/// target. Returns `None` when the target is outside `[f(lo), f(hi)]` or nothing is finite.
pub(crate) fn solve_increasing(
    f: impl Fn(f64) -> (f64, f64),
    target: f64,
    mut lo: f64,
    mut hi: f64,
    guess: f64,
) -> Option<f64> {
    if !target.is_finite() {
        return None;
    }
    let (f_lo, _) = f(lo);
    if f_lo > target || f_lo.is_nan() {
        return (f_lo == target).then_some(lo);
    }
    if hi.is_infinite() {
        let mut h = guess.max(lo + 1.0).max(1e-3);
        loop {
            let (fh, _) = f(h);
            if !fh.is_finite() || h > 1e12 {
                return None;
            }
            if fh >= target {
                break;
            }
            lo = h;
            h *= 2.0;
        }
        hi = h;
    } else {
        let (f_hi, _) = f(hi);
        if f_hi < target || f_hi.is_nan() {
            return None;
        }
    }
    Some(solve_bracketed(f, target, lo, hi, guess))
}

/// The Newton–bisection loop of [`solve_increasing`] for a bracket `[lo, hi]` (finite) already known
/// to hold the target (`f(lo) ≤ target ≤ f(hi)`, `f` increasing): iterates to the last bits.
#[inline]
pub(crate) fn solve_bracketed(
    f: impl Fn(f64) -> (f64, f64),
    target: f64,
    lo: f64,
    hi: f64,
    guess: f64,
) -> f64 {
    let start = if guess > lo && guess < hi {
        guess
    } else {
        0.5 * (lo + hi)
    };
    let f = |x| {
        let (fx, dfx) = f(x);
        (fx, dfx, ())
    };
    match newton_1d(f, target, [lo, hi], start, to_last_bits) {
        Ok((x, ())) | Err(x) => x,
    }
}

/// [`newton_1d`]'s stopping rule for solutions to the last bits: the step, or the bracket, is
/// within a few ulps of the next iterate.
#[inline(always)]
pub(crate) fn to_last_bits(x: f64, next: f64, lo: f64, hi: f64) -> bool {
    let tol = 4.0 * f64::EPSILON * next.abs().max(1e-300);
    (next - x).abs() <= tol || hi - lo <= tol
}

/// The safeguarded Newton iteration every one-dimensional solve of the crate runs: `f(x) = target`
/// on `bracket`, where `f` (value, derivative and whatever the caller wants kept from that
/// evaluation) is increasing, from `x` inside the bracket.
///
/// Each evaluation shrinks the bracket to the side the root is on; a Newton step that would leave
/// it (or a derivative that is not positive) is replaced by bisection, which is what guarantees
/// convergence where Newton alone would overshoot a fold. An infinite upper end is pushed out by
/// doubling instead. `stop(x, next, lo, hi)` ends the iteration at `next`.
///
/// Returns the root with the extra data of the last evaluation (at `x`, not at the root: callers
/// that want the derivative there accept its first-order error rather than pay for one more
/// evaluation), or `Err` with the last iterate after [`MAX_ITERATIONS`].
#[inline]
pub(crate) fn newton_1d<T>(
    f: impl Fn(f64) -> (f64, f64, T),
    target: f64,
    [mut lo, mut hi]: [f64; 2],
    mut x: f64,
    stop: impl Fn(f64, f64, f64, f64) -> bool,
) -> Result<(f64, T), f64> {
    for _ in 0..MAX_ITERATIONS {
        let (fx, dfx, kept) = f(x);
        let r = fx - target;
        if r == 0.0 {
            return Ok((x, kept));
        }
        if r < 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        let newton = x - r / dfx;
        let next = if dfx > 0.0 && newton > lo && newton < hi {
            newton
        } else if hi.is_finite() {
            0.5 * (lo + hi)
        } else {
            2.0 * x.max(1.0)
        };
        if stop(x, next, lo, hi) {
            return Ok((next, kept));
        }
        x = next;
    }
    Err(x)
}

/// Bisects `[lo, hi]` `steps` times toward the boundary of `ok`, which holds at `lo` and fails at
/// `hi`; returns the last point known to hold.
pub(crate) fn bisect(mut lo: f64, mut hi: f64, steps: usize, ok: impl Fn(f64) -> bool) -> f64 {
    for _ in 0..steps {
        let mid = 0.5 * (lo + hi);
        if ok(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// The first point where `ok` fails: `points` (increasing, after 0) are scanned for the first
/// failure, then the gap before it is bisected to the last bits. `None` when `ok` holds at every
/// point. A scan comes first because `ok` need not fail monotonically: bisecting the whole range
/// could land past a first, narrow failure.
pub(crate) fn first_failure(points: impl IntoIterator<Item = f64>, ok: impl Fn(f64) -> bool) -> Option<f64> {
    let mut prev = 0.0;
    for x in points {
        if !ok(x) {
            return Some(bisect(prev, x, 60, ok));
        }
        prev = x;
    }
    None
}

/// Samples of the inverse of an increasing function with their slopes: `x_i` with
/// `f(x_i) = y_max·i/n` and `dx/dy = 1/f'(x_i)`, to seed the exact solvers. Cubic Hermite
/// interpolation between samples is within `~h⁴·|x⁽⁴⁾|/384` of the root (about 1e-13 for the
/// models' tables), so a single Newton step confirms it. A sample without a preimage (beyond a
/// fold) or with an infinite slope (at a fold) is NaN and gives no seed.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct InverseTable {
    /// Samples per unit of `y`.
    scale: f64,
    /// `(x_i, h·dx/dy)`, `h = 1/scale`.
    samples: Vec<[f64; 2]>,
}

impl InverseTable {
    /// Samples `n + 1` values of `y ∈ [0, y_max]`; `invert(y, previous x)` solves one exactly,
    /// `f` gives the function's value and derivative.
    pub fn new(
        y_max: f64,
        n: usize,
        f: impl Fn(f64) -> (f64, f64),
        invert: impl Fn(f64, f64) -> Option<f64>,
    ) -> Self {
        let h = y_max / n as f64;
        let mut samples = Vec::with_capacity(n + 1);
        let mut prev = 0.0;
        for i in 0..=n {
            let sample = invert(y_max * i as f64 / n as f64, prev)
                .map(|x| [x, h / f(x).1])
                .filter(|s| s[0].is_finite() && s[1].is_finite() && s[1] > 0.0);
            if let Some(s) = sample {
                prev = s[0];
            }
            samples.push(sample.unwrap_or([f64::NAN; 2]));
        }
        InverseTable {
            scale: 1.0 / h,
            samples,
        }
    }

    /// The interpolated inverse at `y ≥ 0`, or `None` beyond the table or next to a sample without
    /// a preimage.
    #[inline]
    pub fn seed(&self, y: f64) -> Option<f64> {
        let (ok, x) = self.seed_lane(y);
        ok.then_some(x)
    }

    /// [`InverseTable::seed`] without branches, for loops over lanes: `(false, _)` for `None`.
    #[inline(always)]
    pub fn seed_lane(&self, y: f64) -> (bool, f64) {
        let t = y * self.scale;
        let last = self.samples.len() - 1;
        let inside = (t >= 0.0) & (t < last as f64);
        // Outside the table: any node (the result is discarded); `as` saturates, NaN gives 0.
        let i = (t as usize).min(last - 1);
        let u = t - i as f64;
        let ([x0, s0], [x1, s1]) = (self.samples[i], self.samples[i + 1]);
        // Cubic Hermite in Horner form: x0 + u·(s0 + u·(c2 + u·c3)).
        let d = x1 - x0;
        let c2 = 3.0 * d - 2.0 * s0 - s1;
        let c3 = s0 + s1 - 2.0 * d;
        let x = x0 + u * (s0 + u * (c2 + u * c3));
        (inside & x.is_finite(), x)
    }
}

/// `(sin x, cos x)` to within an ulp or two, several times faster than the C library's: the
/// quadrant by rounding `x·2/π`, a two-part Cody–Waite reduction to `|r| ≤ π/4`, and the Taylor
/// series of sin to `r¹⁵` and cos to `r¹⁶` (truncation below 5e-17 there). For `|x| > 1e5` (never
/// reached by the models, whose angles are below 2π) it defers to the C library.
#[inline]
pub(crate) fn sin_cos(x: f64) -> (f64, f64) {
    if x.abs() > 1e5 || x.is_nan() {
        return x.sin_cos();
    }
    sin_cos_kernel(x)
}

/// [`sin_cos`] without the range check: exact to an ulp or two for `|x| ≤ 1e5`, meaningless
/// beyond. Branch-free (the quadrant is read from the rounded value's bits), so a loop over
/// independent arguments vectorises.
#[inline(always)]
pub(crate) fn sin_cos_kernel(x: f64) -> (f64, f64) {
    // Round to nearest by the 1.5·2⁵² trick (no SSE4.1 `round` on the baseline instruction set);
    // the low mantissa bits of the shifted value are k in two's complement.
    const SHIFTER: f64 = 6_755_399_441_055_744.0;
    let shifted = x * std::f64::consts::FRAC_2_PI + SHIFTER;
    let k = shifted - SHIFTER;
    // π/2 split (1.5707963267341256 + 6.077100506506192e-11): the high part has 33 significant bits, so k·PIO2_HI is exact for |k| < 2²⁰.
    const PIO2_HI: f64 = f64::from_bits(0x3FF9_21FB_5440_0000);
    const PIO2_LO: f64 = f64::from_bits(0x3DD0_B461_1A62_6331);
    let r = (x - k * PIO2_HI) - k * PIO2_LO;
    let r2 = r * r;
    let s = r + r
        * r2
        * (-1.0 / 6.0
            + r2 * (1.0 / 120.0
                + r2 * (-1.0 / 5_040.0
                    + r2 * (1.0 / 362_880.0
                        + r2 * (-1.0 / 39_916_800.0
                            + r2 * (1.0 / 6_227_020_800.0 + r2 * (-1.0 / 1_307_674_368_000.0)))))));
    let c = 1.0
        + r2 * (-0.5
            + r2 * (1.0 / 24.0
                + r2 * (-1.0 / 720.0
                    + r2 * (1.0 / 40_320.0
                        + r2 * (-1.0 / 3_628_800.0
                            + r2 * (1.0 / 479_001_600.0
                                + r2 * (-1.0 / 87_178_291_200.0 + r2 * (1.0 / 20_922_789_888_000.0))))))));
    let q = shifted.to_bits() & 3;
    let (a, b) = if q & 1 == 0 { (s, c) } else { (c, s) };
    let sin_sign = if q & 2 == 0 { 1.0 } else { -1.0 };
    let cos_sign = if (q + 1) & 2 == 0 { 1.0 } else { -1.0 };
    (sin_sign * a, cos_sign * b)
}

/// [`poly`] for a fixed number of coefficients (the polynomial padded with zeros at the top):
/// the same value and derivative bit for bit at any finite `x ≥ 0` (the padding contributes exact
/// zeros), and a fixed trip count, so a loop over lanes vectorises.
#[inline(always)]
pub(crate) fn poly_fixed<const N: usize>(c: &[f64; N], x: f64) -> (f64, f64) {
    // `poly` inlined on a slice of constant length: the trip count is known.
    poly(c, x)
}

/// `c` padded with zeros to `N` coefficients, or `None` when it has more.
pub(crate) fn padded<const N: usize>(c: &[f64]) -> Option<[f64; N]> {
    let mut out = [0.0; N];
    out.get_mut(..c.len())?.copy_from_slice(c);
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn horner_gives_value_and_derivative() {
        let (p, dp) = poly(&[1.0, -2.0, 3.0, 0.5], 2.0);
        assert_eq!(p, 1.0 - 4.0 + 12.0 + 4.0);
        assert_eq!(dp, -2.0 + 12.0 + 6.0);
        assert_eq!(poly(&[], 3.0), (0.0, 0.0));
    }

    #[test]
    fn the_solver_inverts_a_monotone_function_from_a_bad_guess() {
        let f = |x: f64| {
            (
                x + x.powi(3) * 0.2 - x.powi(5) * 0.01,
                1.0 + 0.6 * x * x - 0.05 * x.powi(4),
            )
        };
        for target in [0.0, 0.1, 1.0, 2.5] {
            for guess in [-5.0, 0.0, 0.3, 10.0] {
                let x = solve_increasing(f, target, 0.0, 2.5, guess).unwrap();
                assert!((f(x).0 - target).abs() < 1e-14, "{target} {guess} {x}");
            }
        }
        assert!(solve_increasing(f, 1e3, 0.0, 2.5, 1.0).is_none());
        let x = solve_increasing(|x| (x * x, 2.0 * x), 1e6, 0.0, f64::INFINITY, 1.0).unwrap();
        assert!((x - 1e3).abs() < 1e-9);
    }

    #[test]
    fn matrices_invert() {
        let a = [[2.0, 1.0], [0.5, 3.0]];
        let p = mul2(&a, &inv2(&a).unwrap());
        for (i, row) in p.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                assert!((v - I2[i][j]).abs() < 1e-15);
            }
        }
        assert!(inv2(&[[1.0, 2.0], [2.0, 4.0]]).is_none());
        assert_eq!(apply2(&a, [1.0, 1.0]), [3.0, 3.5]);
    }

    #[test]
    fn the_inverse_table_interpolates_the_inverse() {
        // f(x) = x + x³ on [0, 2]: the seed is within h²·max|x''|/8 of the exact inverse.
        let f = |x: f64| (x + x * x * x, 1.0 + 3.0 * x * x);
        let t = InverseTable::new(10.0, 256, f, |y, g| solve_increasing(f, y, 0.0, 2.0, g));
        for y in [0.0, 0.013, 1.7, 5.0, 9.99] {
            let x = t.seed(y).unwrap();
            // Cubic Hermite, h = 10/256: the error is of the order of h⁴.
            assert!((f(x).0 - y).abs() < 1e-6, "{y}: {x}");
        }
        assert!(t.seed(10.0).is_none() && t.seed(-1.0).is_none() && t.seed(f64::NAN).is_none());
        // Beyond the range of f, the samples are NaN and give no seed.
        let short = InverseTable::new(20.0, 64, f, |y, g| solve_increasing(f, y, 0.0, 2.0, g));
        assert!(short.seed(5.0).is_some() && short.seed(15.0).is_none());
    }

    #[test]
    fn the_seeded_solver_converges_to_the_last_bits() {
        let f = |x: f64| (x.exp_m1(), x.exp());
        for target in [1e-9, 0.3, 5.0, 100.0] {
            for guess in [-1.0, 0.0, 1.0, 4.0, 10.0] {
                let x = solve_bracketed(f, target, 0.0, 5.0, guess);
                assert!(
                    (x - target.ln_1p()).abs() <= 8.0 * f64::EPSILON * x,
                    "{target} {guess}"
                );
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn sin_cos_matches_the_c_library(x in -20.0f64..20.0) {
            let (s, c) = sin_cos(x);
            let (s0, c0) = x.sin_cos();
            proptest::prop_assert!((s - s0).abs() <= 4e-16 && (c - c0).abs() <= 4e-16, "{x}: {s} {c} vs {s0} {c0}");
            proptest::prop_assert!((s * s + c * c - 1.0).abs() <= 6e-16);
        }
    }

    proptest::proptest! {
        #[test]
        fn the_padded_polynomial_is_the_polynomial(
            c in proptest::collection::vec(-10.0f64..10.0, 0..7),
            x in 0.0f64..50.0,
        ) {
            let fixed = poly_fixed(&padded::<8>(&c).unwrap(), x);
            let (p, dp) = poly(&c, x);
            proptest::prop_assert_eq!(fixed.0.to_bits(), p.to_bits());
            proptest::prop_assert_eq!(fixed.1.to_bits(), dp.to_bits());
        }

        #[test]
        fn the_sin_cos_kernel_is_sin_cos_over_its_range(x in -1e5f64..1e5) {
            let (s, c) = sin_cos_kernel(x);
            let (s0, c0) = x.sin_cos();
            let tol = 4e-16 + 1e-22 * x.abs();
            proptest::prop_assert!((s - s0).abs() <= tol && (c - c0).abs() <= tol, "{x}: {s} {c} vs {s0} {c0}");
        }
    }

    #[test]
    fn padding_refuses_a_longer_polynomial() {
        assert!(padded::<2>(&[1.0, 2.0, 3.0]).is_none());
        assert_eq!(padded::<3>(&[1.0]), Some([1.0, 0.0, 0.0]));
    }

    #[test]
    fn sin_cos_is_exact_at_the_quadrant_boundaries_and_huge_arguments() {
        use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
        for x in [
            0.0,
            -0.0,
            1e-300,
            FRAC_PI_4,
            FRAC_PI_2,
            PI,
            1.5 * PI,
            -PI,
            2.0 * PI,
            3.0,
            1e6,
            -1e7,
        ] {
            let (s, c) = sin_cos(x);
            let (s0, c0) = x.sin_cos();
            assert!((s - s0).abs() <= 4e-16 && (c - c0).abs() <= 4e-16, "{x}");
        }
        assert!(sin_cos(f64::NAN).0.is_nan() && sin_cos(f64::INFINITY).1.is_nan());
    }
}
