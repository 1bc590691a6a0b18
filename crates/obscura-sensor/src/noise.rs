//! The two random laws of a sensor: photon arrival (Poisson) and read-out (Gaussian).
//!
//! - Poisson of mean `μ < 10`: inversion by sequential search,
//!   `k = min{k : Σ_{i≤k} e^{−μ}μ^i/i! > U}` (exact).
//! - Poisson of mean `μ ≥ 10`: Hörmann's transformed rejection with squeeze ("PTRS", 1993), exact, with
//!   `b = 0.931 + 2.53·√μ`, `a = −0.059 + 0.02483·b`, `1/α = 1.1239 + 1.1328/(b − 3.4)`,
//!   `v_r = 0.9277 − 3.6224/(b − 2)`; a candidate `k = ⌊(2a/u_s + b)·U + μ + 0.43⌋` with `U ∈ [−½, ½)`,
//!   `u_s = ½ − |U|` is accepted at once when `u_s ≥ 0.07` and `V ≤ v_r`, otherwise when
//!   `ln V + ln(1/α) − ln(a/u_s² + b) ≤ −μ + k·ln μ − ln k!`.
//! - Gaussian: Box–Muller, `z = √(−2 ln U₁)·cos(2π U₂)`.

use crate::rng::PixelRng;

/// `ln k!`: a table below 32, Stirling's series with three correction terms above
/// (`(k+½)ln(k+1) − (k+1) + ½ln 2π + 1/(12(k+1)) − 1/(360(k+1)³) + 1/(1260(k+1)⁵)`, error < 1e-12).
#[must_use]
pub fn ln_factorial(k: u64) -> f64 {
    if k < 32 {
        let mut acc = 0.0f64;
        for i in 2..=k {
            acc += (i as f64).ln();
        }
        return acc;
    }
    let n = k as f64 + 1.0;
    (n - 0.5) * n.ln() - n + 0.5 * (2.0 * std::f64::consts::PI).ln() + 1.0 / (12.0 * n)
        - 1.0 / (360.0 * n.powi(3))
        + 1.0 / (1260.0 * n.powi(5))
}

/// A Poisson variate of mean `mu` (0 for `mu ≤ 0` or NaN).
pub fn poisson(rng: &mut PixelRng, mu: f64) -> u64 {
    if mu.is_nan() || mu <= 0.0 {
        return 0;
    }
    if mu < 10.0 {
        return poisson_inversion(rng, mu);
    }
    poisson_ptrs(rng, mu)
}

fn poisson_inversion(rng: &mut PixelRng, mu: f64) -> u64 {
    let u = rng.uniform();
    let mut k = 0u64;
    let mut p = (-mu).exp();
    let mut cdf = p;
    while u >= cdf {
        k += 1;
        p *= mu / k as f64;
        cdf += p;
        if p < 1e-300 && k as f64 > mu {
            break;
        }
    }
    k
}

fn poisson_ptrs(rng: &mut PixelRng, mu: f64) -> u64 {
    let slam = mu.sqrt();
    let log_mu = mu.ln();
    let b = 0.931 + 2.53 * slam;
    let a = -0.059 + 0.02483 * b;
    let inv_alpha = 1.1239 + 1.1328 / (b - 3.4);
    let vr = 0.9277 - 3.6224 / (b - 2.0);
    loop {
        let u = rng.uniform() - 0.5;
        let v = rng.uniform_open0();
        let us = 0.5 - u.abs();
        let k = ((2.0 * a / us + b) * u + mu + 0.43).floor();
        if us >= 0.07 && v <= vr {
            return k as u64;
        }
        if k < 0.0 || (us < 0.013 && v > us) {
            continue;
        }
        let lhs = v.ln() + inv_alpha.ln() - (a / (us * us) + b).ln();
        let rhs = -mu + k * log_mu - ln_factorial(k as u64);
        if lhs <= rhs {
            return k as u64;
        }
    }
}

/// A standard normal variate (Box–Muller).
pub fn gaussian(rng: &mut PixelRng) -> f64 {
    let u1 = rng.uniform_open0();
    let u2 = rng.uniform();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_factorial_matches_the_product() {
        let mut acc = 0.0f64;
        for k in 1..200u64 {
            acc += (k as f64).ln();
            assert!((ln_factorial(k) - acc).abs() < 1e-9 * acc.max(1.0), "{k}");
        }
    }

    /// Mean and variance of both branches equal μ (standard error of the variance ≈ μ·√(2/n)).
    #[test]
    fn poisson_moments_both_branches() {
        for &mu in &[0.3f64, 4.5, 9.99, 10.0, 37.0, 1234.5, 60_000.0] {
            let n = 100_000;
            let mut r = PixelRng::new(3, 1, mu.to_bits(), 0);
            let xs: Vec<f64> = (0..n).map(|_| poisson(&mut r, mu) as f64).collect();
            let mean = xs.iter().sum::<f64>() / n as f64;
            let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
            let se_mean = (mu / n as f64).sqrt();
            assert!((mean - mu).abs() < 5.0 * se_mean, "mu {mu}: mean {mean}");
            let se_var = mu * (2.0 / n as f64).sqrt() + (mu / n as f64).sqrt();
            assert!((var - mu).abs() < 5.0 * se_var, "mu {mu}: var {var}");
        }
    }

    #[test]
    fn gaussian_moments() {
        let mut r = PixelRng::new(5, 0, 0, 0);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| gaussian(&mut r)).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        let kurt = xs.iter().map(|x| (x - mean).powi(4)).sum::<f64>() / n as f64 / (var * var);
        assert!(mean.abs() < 0.012, "{mean}");
        assert!((var - 1.0).abs() < 0.015, "{var}");
        assert!((kurt - 3.0).abs() < 0.06, "{kurt}");
    }
}
