//! EMVA 1288 characterisation of the sensor model: flat fields of a uniform radiance at 12
//! illumination levels plus dark frames, each a pair of 256×256 frames read through
//! [`Sensor::capture`] (the same call the renderer makes after the film resolves); the photon-transfer
//! analysis ([`obscura_sensor::emva`]) must recover the configured system gain (2 %), read noise (5 %),
//! dark current (5 %) and saturation at the full well; shot noise must be Poisson (χ² test, and a
//! wrong law rejected by the same test).

use obscura_sensor::emva::{Level, linear_fit, pair_statistics, photon_transfer};
use obscura_sensor::{Cfa, Sensor, SensorConfig};

const SIZE: u32 = 256;

fn frame(sensor: &Sensor, radiance: f32, frame: u64) -> Vec<f64> {
    let rgb = vec![[radiance; 3]; (SIZE * SIZE) as usize];
    let f = sensor.capture(&rgb, SIZE, SIZE, (0, 0), SIZE, frame, None);
    f.raw.iter().map(|&c| f64::from(c)).collect()
}

fn config(iso: f64) -> SensorConfig {
    SensorConfig {
        iso,
        gain_e_per_dn: 2.0,
        read_noise_e: 3.0,
        dark_current_e_per_s: 400.0,
        full_well_e: 9_000.0,
        black_level_dn: 256.0,
        bit_depth: 16,
        exposure_time_s: 0.01,
        f_number: Some(2.8),
        cfa: Cfa::Rggb,
        seed: 1288,
        ..SensorConfig::default()
    }
}

/// Gain, read noise and saturation at two ISOs (two system gains).
#[test]
fn photon_transfer_recovers_gain_read_noise_and_saturation() {
    for iso in [100.0, 400.0] {
        let config = config(iso);
        let sensor = Sensor::new(config.clone(), None);
        let k_true = config.system_gain_dn_per_e();
        // Radiance of one electron per pixel on average, then 12 levels from ~1 % to ~150 % of the
        // full well (the last ones saturate).
        let per_radiance = sensor.expected_electrons([1.0; 3], Some(1), 1.0);
        let (d_mean, d_var) = pair_statistics(&frame(&sensor, 0.0, 0), &frame(&sensor, 0.0, 1));
        let mut levels = Vec::new();
        for (i, fraction) in [0.01, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.85, 1.1, 1.5]
            .iter()
            .enumerate()
        {
            let radiance = (fraction * config.full_well_e / per_radiance) as f32;
            let seed = 10 + 2 * i as u64;
            let (mean, variance) = pair_statistics(
                &frame(&sensor, radiance, seed),
                &frame(&sensor, radiance, seed + 1),
            );
            levels.push(Level {
                mean,
                variance,
                dark_mean: d_mean,
                dark_variance: d_var,
            });
        }
        let ptc = photon_transfer(&levels);
        let gain_err = (ptc.gain_dn_per_e / k_true - 1.0).abs();
        assert!(gain_err < 0.02, "ISO {iso}: K {} vs {k_true}", ptc.gain_dn_per_e);
        // EMVA's temporal dark noise holds the dark current's own shot noise, σ²_d = σ²_read + μ_dark
        // (the dark electrons, from the dark frames' mean, as a data sheet would take them).
        let dark_e = (d_mean - config.black_level_dn) / ptc.gain_dn_per_e;
        let read_noise = (ptc.read_noise_e.powi(2) - dark_e).sqrt();
        let read_err = (read_noise / config.read_noise_e - 1.0).abs();
        assert!(read_err < 0.05, "ISO {iso}: read noise {read_noise}");
        // Saturation: the variance collapses at the full well; the saturation capacity is the full
        // well less the dark electrons already in the pixel.
        let sat_err = (ptc.saturation_e / (config.full_well_e - dark_e) - 1.0).abs();
        assert!(sat_err < 0.02, "ISO {iso}: saturation {} e", ptc.saturation_e);
        assert!(levels.last().unwrap().variance < 0.25 * levels[ptc.saturation_level].variance);
        eprintln!(
            "ISO {iso}: K {:.5} (true {k_true}), read noise {read_noise:.4} e, saturation {:.1} e",
            ptc.gain_dn_per_e, ptc.saturation_e
        );
    }
}

/// Dark current from dark frames at 10 exposure times: the slope of the dark mean against time.
#[test]
fn dark_frames_recover_dark_current() {
    let base = config(100.0);
    let mut points = Vec::new();
    for (i, t) in [0.01, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6]
        .iter()
        .enumerate()
    {
        let sensor = Sensor::new(
            SensorConfig {
                exposure_time_s: *t,
                ..base.clone()
            },
            None,
        );
        let (mean, _) = pair_statistics(
            &frame(&sensor, 0.0, 100 + 2 * i as u64),
            &frame(&sensor, 0.0, 101 + 2 * i as u64),
        );
        points.push((*t, mean));
    }
    let (slope, intercept) = linear_fit(&points);
    let dark = slope / base.system_gain_dn_per_e();
    assert!(
        (dark / base.dark_current_e_per_s - 1.0).abs() < 0.05,
        "dark current {dark} e/s"
    );
    assert!(
        (intercept - base.black_level_dn).abs() < 1.0,
        "offset {intercept}"
    );
}

/// χ² statistic of integer samples against the Poisson law of mean `mu` over bins `lo..=hi`, the two
/// tails merged into the end bins.
fn chi_square(samples: &[u16], mu: f64, lo: u32, hi: u32) -> f64 {
    let pmf =
        |k: u32| (-mu + f64::from(k) * mu.ln() - obscura_sensor::noise::ln_factorial(u64::from(k))).exp();
    let n = samples.len() as f64;
    let mut observed = vec![0.0; (hi - lo + 1) as usize];
    for &s in samples {
        let k = u32::from(s).clamp(lo, hi);
        observed[(k - lo) as usize] += 1.0;
    }
    let mut expected: Vec<f64> = (lo..=hi).map(pmf).collect();
    expected[0] = (0..=lo).map(pmf).sum();
    let last = expected.len() - 1;
    expected[last] = 1.0 - (0..hi).map(pmf).sum::<f64>();
    observed
        .iter()
        .zip(&expected)
        .map(|(o, e)| (o - n * e).powi(2) / (n * e))
        .sum()
}

/// Shot noise is Poisson: with K = 1 DN/e⁻ and no read noise, dark current or offset, the codes are the
/// electron counts. χ² over 15 bins (14 degrees of freedom; 0.999 quantile 36.12) at a mean on the
/// inversion branch (5 e⁻) and one on the rejection branch (40 e⁻); the same test rejects Poisson counts
/// of a mean 3 % off. Variance = mean in electrons at 2 000 e⁻.
#[test]
fn shot_noise_is_poisson() {
    let config = SensorConfig {
        gain_e_per_dn: 1.0,
        read_noise_e: 0.0,
        dark_current_e_per_s: 0.0,
        black_level_dn: 0.0,
        full_well_e: 100_000.0,
        bit_depth: 16,
        f_number: Some(2.8),
        cfa: Cfa::None,
        seed: 42,
        ..SensorConfig::default()
    };
    let sensor = Sensor::new(config, None);
    let per_radiance = sensor.expected_electrons([1.0; 3], None, 1.0);
    let codes = |mu: f64, f: u64| {
        let rgb = vec![[(mu / per_radiance) as f32; 3]; (SIZE * SIZE) as usize];
        sensor.capture(&rgb, SIZE, SIZE, (0, 0), SIZE, f, None)
    };
    const CRITICAL_14_DOF_P001: f64 = 36.12;
    for (mu, lo) in [(5.0, 0u32), (40.0, 33)] {
        let f = codes(mu, 7);
        let true_mu = f64::from(f.electrons[0]);
        let chi = chi_square(&f.raw, true_mu, lo, lo + 14);
        assert!(chi < CRITICAL_14_DOF_P001, "mean {mu}: χ² {chi}");
        let wrong = chi_square(&f.raw, true_mu * 1.03, lo, lo + 14);
        assert!(
            wrong > CRITICAL_14_DOF_P001,
            "mean {mu}: a 3 % wrong law passes (χ² {wrong})"
        );
        eprintln!("Poisson mean {mu}: χ² {chi:.2} (wrong law {wrong:.1})");
    }
    let f = codes(2_000.0, 9);
    let xs: Vec<f64> = f.raw.iter().map(|&c| f64::from(c)).collect();
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    // Standard error of var/mean ≈ √(2/n) = 0.55 %.
    assert!((var / mean - 1.0).abs() < 0.02, "variance {var} mean {mean}");
    assert!((mean / f64::from(f.electrons[0]) - 1.0).abs() < 1e-3);
}
