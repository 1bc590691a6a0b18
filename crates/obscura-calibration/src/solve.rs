//! Small f64 numerics shared by the models: polynomials, 2×2 matrices, and a safeguarded Newton
//! solver for monotone functions of one variable.

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
#[inline]
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
    let mut x = if guess > lo && guess < hi {
        guess
    } else {
        0.5 * (lo + hi)
    };
    for _ in 0..MAX_ITERATIONS {
        let (fx, dfx) = f(x);
        let r = fx - target;
        if r == 0.0 {
            return Some(x);
        }
        if r < 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        let newton = x - r / dfx;
        let next = if dfx > 0.0 && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        let tol = 4.0 * f64::EPSILON * next.abs().max(1e-300);
        if (next - x).abs() <= tol || hi - lo <= tol {
            return Some(next);
        }
        x = next;
    }
    Some(x)
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
}
