//! One wavelength per ray and the RGB weight it carries.
//!
//! A ray's wavelength is `λ = 400 + 300·u` nm, `u ∈ [0, 1)`, uniform. Its tint is `w(λ)`, the linear
//! sRGB of the CIE 1931 colour matching functions at λ (the multi-lobe Gaussian fit of Wyman, Sloan and
//! Shirley, JCGT 2(2), 2013, through the XYZ → linear sRGB matrix of IEC 61966-2-1), negative parts
//! set to zero and each channel divided by its mean over 400–700 nm: the mean of `w` over the
//! wavelengths is exactly white, so a white scene stays white on average and a lens without
//! dispersion gives the image of the d line.

use std::sync::LazyLock;

/// Shortest wavelength sampled, nm.
pub const LAMBDA_MIN: f64 = 400.0;
/// Longest wavelength sampled, nm.
pub const LAMBDA_MAX: f64 = 700.0;
const STEPS: usize = 300;

fn g(x: f64, mu: f64, s1: f64, s2: f64) -> f64 {
    let t = (x - mu) / if x < mu { s1 } else { s2 };
    (-0.5 * t * t).exp()
}

/// CIE 1931 `(x̄, ȳ, z̄)` at `lambda` nm (Wyman–Sloan–Shirley multi-lobe fit).
#[must_use]
pub fn cie_xyz(lambda: f64) -> [f64; 3] {
    let x = 1.056 * g(lambda, 599.8, 37.9, 31.0) + 0.362 * g(lambda, 442.0, 16.0, 26.7)
        - 0.065 * g(lambda, 501.1, 20.4, 26.2);
    let y = 0.821 * g(lambda, 568.8, 46.9, 40.5) + 0.286 * g(lambda, 530.9, 16.3, 31.1);
    let z = 1.217 * g(lambda, 437.0, 11.8, 36.0) + 0.681 * g(lambda, 459.0, 26.0, 13.8);
    [x, y, z]
}

fn rgb_raw(lambda: f64) -> [f64; 3] {
    let [x, y, z] = cie_xyz(lambda);
    [
        (3.2406 * x - 1.5372 * y - 0.4986 * z).max(0.0),
        (-0.9689 * x + 1.8758 * y + 0.0415 * z).max(0.0),
        (0.0557 * x - 0.2040 * y + 1.0570 * z).max(0.0),
    ]
}

/// `w(λ)` tabulated at 1 nm from 400 to 700 nm, normalised to a white mean.
static TABLE: LazyLock<Vec<[f32; 3]>> = LazyLock::new(|| {
    let raw: Vec<[f64; 3]> = (0..=STEPS)
        .map(|i| rgb_raw(LAMBDA_MIN + (LAMBDA_MAX - LAMBDA_MIN) * i as f64 / STEPS as f64))
        .collect();
    // The mean of the piecewise-linear interpolant over [400, 700] (trapezoid rule).
    let mut mean = [0.0; 3];
    for w in raw.windows(2) {
        for c in 0..3 {
            mean[c] += 0.5 * (w[0][c] + w[1][c]) / STEPS as f64;
        }
    }
    raw.iter()
        .map(|v| {
            [
                (v[0] / mean[0]) as f32,
                (v[1] / mean[1]) as f32,
                (v[2] / mean[2]) as f32,
            ]
        })
        .collect()
});

/// The wavelength, nm, of the uniform sample `u ∈ [0, 1)`.
#[inline]
#[must_use]
pub fn wavelength(u: f64) -> f64 {
    LAMBDA_MIN + (LAMBDA_MAX - LAMBDA_MIN) * u
}

/// The RGB weight `w(λ)` of the uniform sample `u ∈ [0, 1)` (its wavelength is [`wavelength`]`(u)`).
#[inline]
#[must_use]
pub fn weight(u: f64) -> [f32; 3] {
    let x = (u.clamp(0.0, 1.0) * STEPS as f64).min(STEPS as f64 - 1e-9);
    let i = x as usize;
    let f = (x - i as f64) as f32;
    let (a, b) = (TABLE[i], TABLE[(i + 1).min(STEPS)]);
    [
        a[0] + (b[0] - a[0]) * f,
        a[1] + (b[1] - a[1]) * f,
        a[2] + (b[2] - a[2]) * f,
    ]
}

/// A uniform number in `[0, 1)` from the bits of a sample: a ray's wavelength dimension, decorrelated
/// from its screen and lens position (a 64-bit finaliser of the four coordinates' bits).
#[inline]
#[must_use]
pub fn hash_unit(a: f32, b: f32, c: f32, d: f32) -> f64 {
    let mut h = (u64::from(a.to_bits()) << 32 | u64::from(b.to_bits()))
        ^ (u64::from(c.to_bits()) << 32 | u64::from(d.to_bits())).rotate_left(17);
    h ^= h >> 33;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^= h >> 33;
    h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    h ^= h >> 33;
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_stays_white_on_average_over_uniform_wavelengths() {
        let n = 100_000;
        let mut sum = [0.0f64; 3];
        for i in 0..n {
            let w = weight((i as f64 + 0.5) / n as f64);
            for c in 0..3 {
                sum[c] += f64::from(w[c]) / n as f64;
            }
        }
        for c in sum {
            assert!((c - 1.0).abs() < 1e-3, "{sum:?}");
        }
        // Red at 650 nm, blue at 450 nm: the table is not flat.
        assert!(weight(250.0 / 300.0)[0] > 1.0 && weight(250.0 / 300.0)[2] < 0.1);
        assert!(weight(50.0 / 300.0)[2] > 2.0 && weight(50.0 / 300.0)[0] < 0.5);
    }

    #[test]
    fn the_hash_is_uniform() {
        let n = 40_000;
        let mut bins = [0u32; 10];
        for i in 0..n {
            let u = hash_unit(i as f32 * 0.001, 0.5, (i % 97) as f32 / 97.0, 0.25);
            assert!((0.0..1.0).contains(&u));
            bins[(u * 10.0) as usize] += 1;
        }
        for b in bins {
            assert!((b as f64 - 4000.0).abs() < 300.0, "{bins:?}");
        }
    }
}
