//! The EMVA 1288 photon-transfer analysis (release 4.0, the linear model): what a camera's data sheet
//! reports, computed from flat fields and dark frames.
//!
//! For each illumination level two frames `A`, `B` of a uniform field and two dark frames at the same
//! exposure time give
//!
//! ```text
//! μ_y = (mean A + mean B)/2                 σ²_y = var(A − B)/2       (removes fixed-pattern noise)
//! ```
//!
//! and the model `σ²_y − σ²_y.dark = K·(μ_y − μ_y.dark)`: the **system gain** `K` (DN/e⁻) is the slope
//! of the photon-transfer line through the origin, fitted over the levels below 70 % of saturation.
//! The **temporal dark noise** is `σ_d = √(σ²_y.dark − σ²_q)/K` electrons (`σ²_q = 1/12` DN², the
//! quantisation noise). The **dark current** is the slope of `μ_y.dark` against exposure time, divided
//! by `K`. **Saturation**: EMVA takes the level where `σ²_y` peaks (which bounds the linear range);
//! the saturation capacity reported here is the plateau the mean reaches once the variance has
//! collapsed, `μ_e.sat = (max μ_y − μ_y.dark)/K` — the full well, which the variance peak approaches
//! from below as the levels get denser.

/// Mean and temporal variance of a pair of frames of the same level: `((ā + b̄)/2, var(a − b)/2)`.
///
/// # Panics
/// When the frames differ in length or are empty (a bug of the caller).
#[must_use]
pub fn pair_statistics(a: &[f64], b: &[f64]) -> (f64, f64) {
    assert!(!a.is_empty() && a.len() == b.len(), "two frames of the same size");
    let n = a.len() as f64;
    let mean = (a.iter().sum::<f64>() + b.iter().sum::<f64>()) / (2.0 * n);
    let d_mean = a.iter().zip(b).map(|(x, y)| x - y).sum::<f64>() / n;
    let var = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y - d_mean).powi(2))
        .sum::<f64>()
        / (n - 1.0)
        / 2.0;
    (mean, var)
}

/// Least-squares line `y = slope·x + intercept` through `points`.
#[must_use]
pub fn linear_fit(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    let (sx, sy) = points.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
    let (mx, my) = (sx / n, sy / n);
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let slope = sxy / sxx;
    (slope, my - slope * mx)
}

/// Least-squares slope of `y = slope·x` (a line through the origin).
#[must_use]
pub fn slope_through_origin(points: &[(f64, f64)]) -> f64 {
    let sxy: f64 = points.iter().map(|p| p.0 * p.1).sum();
    let sxx: f64 = points.iter().map(|p| p.0 * p.0).sum();
    sxy / sxx
}

/// One illumination level: its pair statistics and those of the dark pair at the same exposure time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Level {
    /// `μ_y`, DN.
    pub mean: f64,
    /// `σ²_y`, DN².
    pub variance: f64,
    /// `μ_y.dark`, DN.
    pub dark_mean: f64,
    /// `σ²_y.dark`, DN².
    pub dark_variance: f64,
}

/// What the photon-transfer analysis finds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhotonTransfer {
    /// System gain `K`, DN per electron.
    pub gain_dn_per_e: f64,
    /// Temporal dark noise, electrons.
    pub read_noise_e: f64,
    /// Saturation capacity `μ_e.sat`, electrons (the plateau of the mean).
    pub saturation_e: f64,
    /// The level index where the variance peaks.
    pub saturation_level: usize,
}

/// Analyses levels sorted by increasing illumination (see the module documentation).
///
/// # Panics
/// When fewer than two levels lie below 70 % of saturation (not enough to fit).
#[must_use]
pub fn photon_transfer(levels: &[Level]) -> PhotonTransfer {
    let saturation_level = levels
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.variance.total_cmp(&b.1.variance))
        .map_or(0, |(i, _)| i);
    let sat = levels[saturation_level];
    let range = sat.mean - sat.dark_mean;
    let points: Vec<(f64, f64)> = levels
        .iter()
        .filter(|l| l.mean - l.dark_mean <= 0.7 * range)
        .map(|l| (l.mean - l.dark_mean, l.variance - l.dark_variance))
        .collect();
    assert!(points.len() >= 2, "at least two levels below 70 % of saturation");
    let k = slope_through_origin(&points);
    let dark_var = levels[0].dark_variance;
    PhotonTransfer {
        gain_dn_per_e: k,
        read_noise_e: (dark_var - 1.0 / 12.0).max(0.0).sqrt() / k,
        saturation_e: levels
            .iter()
            .map(|l| l.mean - l.dark_mean)
            .fold(f64::MIN, f64::max)
            / k,
        saturation_level,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_recover_exact_lines() {
        let pts: Vec<(f64, f64)> = (0..5).map(|i| (f64::from(i), 3.0 * f64::from(i) - 2.0)).collect();
        let (s, c) = linear_fit(&pts);
        assert!((s - 3.0).abs() < 1e-12 && (c + 2.0).abs() < 1e-12);
        let pts: Vec<(f64, f64)> = (1..5).map(|i| (f64::from(i), 0.5 * f64::from(i))).collect();
        assert!((slope_through_origin(&pts) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn pair_statistics_removes_a_fixed_pattern() {
        // The same fixed pattern in both frames plus ±1 alternating noise of variance 1 per frame.
        let pattern: Vec<f64> = (0..1000).map(|i| f64::from(i % 7) * 10.0).collect();
        let a: Vec<f64> = pattern
            .iter()
            .enumerate()
            .map(|(i, p)| p + if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let b: Vec<f64> = pattern
            .iter()
            .enumerate()
            .map(|(i, p)| p - if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let (_, var) = pair_statistics(&a, &b);
        assert!((var - 2.0 * 1000.0 / 999.0).abs() < 1e-9, "{var}");
    }
}
