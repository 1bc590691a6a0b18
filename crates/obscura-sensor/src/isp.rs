//! A simple image signal processor: raw mosaic → processed RGB.
//!
//! 1. **Linearise**: `x = (expand(code) − black)/(code_max_linear − black)` (`expand` the inverse of the
//!    companding curve, when there is one): 0 at black, 1 at the ADC's top.
//! 2. **Demosaic** ([`Demosaic`]): *bilinear*, each missing channel the mean of the 3×3 neighbours that
//!    carry it; or *Malvar–He–Cutler* (2004), the bilinear estimate corrected by the Laplacian of the
//!    pixel's own channel, with their 5×5 kernels (gains ½, ⅝, ¾ of the Laplacian). Borders mirror
//!    (`−1 → 1`, `W → W − 2`), which keeps the pattern's phase.
//! 3. **White balance**: multipliers `g` with green's 1. As shot: `g_c = n_G/n_c` with the camera neutral
//!    `n = M·(1, 1, 1)`; grey world: `g_c = mean_G/mean_c`; or given.
//! 4. **Colour correction**: linear sRGB `= CCM·(g ⊙ rgb)`, with `CCM = M⁻¹·diag(n)/n_G` by default
//!    (rows sum to 1: white stays white), or a given matrix; then times `gain`.
//! 5. **Tone**: sRGB's transfer function, a gamma `v^(1/γ)`, or none; clamped to [0, 1] and rounded to
//!    8 or 16 bits.
//!
//! A monochrome sensor skips 2–4: its grey value goes to all three channels.

use rayon::prelude::*;

use crate::capture::SensorFrame;
use crate::cfa::Cfa;
use crate::color::{Mat3, apply, inverse};
use crate::config::{Demosaic, SensorConfig, Tone, WhiteBalance};

/// The ISP's result.
#[derive(Debug, Clone, PartialEq)]
pub struct Processed {
    /// Linear sRGB before the tone curve, row by row.
    pub linear: Vec<[f32; 3]>,
    /// After the tone curve, in codes of `bits` bits, RGB interleaved, row by row.
    pub encoded: Vec<u16>,
    /// 8 or 16.
    pub bits: u32,
    /// The white-balance multipliers used.
    pub white_balance: [f64; 3],
    /// The colour-correction matrix used.
    pub ccm: Mat3,
}

/// The camera neutral `M·(1, 1, 1)` normalised to its largest component (DNG's AsShotNeutral).
#[must_use]
pub fn as_shot_neutral(response: &Mat3) -> [f64; 3] {
    let n = apply(response, [1.0; 3]);
    let peak = n.iter().copied().fold(f64::MIN, f64::max);
    n.map(|v| v / peak)
}

/// The default colour-correction matrix `M⁻¹·diag(n)/n_G` (identity when `M` is singular).
#[must_use]
pub fn default_ccm(response: &Mat3) -> Mat3 {
    let n = apply(response, [1.0; 3]);
    let Some(inv) = inverse(response) else {
        return crate::color::IDENTITY;
    };
    [0, 1, 2].map(|r| [0, 1, 2].map(|c| inv[r][c] * n[c] / n[1]))
}

/// The linearised values `x` of a mosaic (step 1).
#[must_use]
pub fn linearise(config: &SensorConfig, raw: &[u16]) -> Vec<f32> {
    let black = config.black_level_dn;
    let range = config.linear_max_code() - black;
    raw.iter()
        .map(|&code| {
            let lin = config
                .companding
                .as_ref()
                .map_or(f64::from(code), |c| c.expand(f64::from(code)));
            ((lin - black) / range) as f32
        })
        .collect()
}

fn mirror(i: i64, n: i64) -> usize {
    let mut i = i;
    if n == 1 {
        return 0;
    }
    if i < 0 {
        i = -i;
    }
    if i >= n {
        i = 2 * (n - 1) - i;
    }
    i.clamp(0, n - 1) as usize
}

/// Demosaics the linearised mosaic `x` (`width × height`, top-left pixel at `origin` of the full
/// image) into camera RGB.
#[must_use]
pub fn demosaic(
    x: &[f32],
    width: u32,
    height: u32,
    origin: (u32, u32),
    cfa: Cfa,
    method: Demosaic,
) -> Vec<[f32; 3]> {
    let (w, h) = (i64::from(width), i64::from(height));
    if cfa == Cfa::None {
        return x.iter().map(|&v| [v; 3]).collect();
    }
    let at = |i: i64, j: i64| x[mirror(j, h) * width as usize + mirror(i, w)];
    let chan = |i: i64, j: i64| {
        let (i, j) = (mirror(i, w) as u32, mirror(j, h) as u32);
        cfa.channel(origin.0 + i, origin.1 + j).unwrap_or(1)
    };
    (0..h)
        .into_par_iter()
        .flat_map_iter(|j| {
            (0..w).map(move |i| {
                let own = chan(i, j);
                let mut out = [0.0f32; 3];
                for (c, slot) in out.iter_mut().enumerate() {
                    let c = c as u8;
                    *slot = if c == own {
                        at(i, j)
                    } else {
                        let (mut sum, mut n) = (0.0f32, 0.0f32);
                        for dj in -1..=1 {
                            for di in -1..=1 {
                                if chan(i + di, j + dj) == c {
                                    sum += at(i + di, j + dj);
                                    n += 1.0;
                                }
                            }
                        }
                        let bilinear = sum / n;
                        match method {
                            Demosaic::Bilinear => bilinear,
                            Demosaic::MalvarHeCutler => bilinear + mhc_correction(&at, i, j, own, c, &chan),
                        }
                    };
                }
                out
            })
        })
        .collect()
}

/// Malvar–He–Cutler's correction of the bilinear estimate of channel `c` at a pixel of channel
/// `own`: `α·ΔR` (`α = ½`) for green at red/blue, `β·ΔG` (`β = ⅝`) for red/blue at green, `γ·ΔB`
/// (`γ = ¾`) for red at blue and blue at red, with their discrete Laplacians (over the same channel's
/// samples at distance 2, and for red/blue at green the anisotropic form of the paper's kernels).
fn mhc_correction(
    at: &impl Fn(i64, i64) -> f32,
    i: i64,
    j: i64,
    own: u8,
    c: u8,
    chan: &impl Fn(i64, i64) -> u8,
) -> f32 {
    let centre = at(i, j);
    if c == 1 {
        // G at R or B: kernel [0 0 -1 0 0; 0 0 2 0 0; -1 2 4 2 -1; ...]/8 = bilinear + ½·(centre − mean of 4 at distance 2)·... .
        let lap = 4.0 * centre - at(i - 2, j) - at(i + 2, j) - at(i, j - 2) - at(i, j + 2);
        return lap / 8.0;
    }
    if own == 1 {
        // R or B at G. The kernel for R at a G whose row neighbours are R (and its transpose):
        //   [0 0 ½ 0 0; 0 −1 0 −1 0; −1 4 5 4 −1; 0 −1 0 −1 0; 0 0 ½ 0 0]/8.
        // Bilinear gives the 4s (as (4+4)/8 = ½ each); the rest is the correction.
        let row_has_c = chan(i - 1, j) == c;
        let (along, across) = if row_has_c {
            (at(i - 2, j) + at(i + 2, j), at(i, j - 2) + at(i, j + 2))
        } else {
            (at(i, j - 2) + at(i, j + 2), at(i - 2, j) + at(i + 2, j))
        };
        let diag = at(i - 1, j - 1) + at(i + 1, j - 1) + at(i - 1, j + 1) + at(i + 1, j + 1);
        return (5.0 * centre - along - diag + 0.5 * across) / 8.0;
    }
    // R at B or B at R: [0 0 −3/2 0 0; 0 2 0 2 0; −3/2 0 6 0 −3/2; 0 2 0 2 0; 0 0 −3/2 0 0]/8;
    // bilinear gives the 2s (4·2/8 = mean of the diagonals).
    let ring = at(i - 2, j) + at(i + 2, j) + at(i, j - 2) + at(i, j + 2);
    (6.0 * centre - 1.5 * ring) / 8.0
}

/// The sRGB transfer function of `v` in [0, 1].
#[must_use]
pub fn srgb_oetf(v: f64) -> f64 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Runs the ISP on a frame's raw mosaic with `config`'s `isp` settings and response `response`.
#[must_use]
pub fn process(config: &SensorConfig, response: &Mat3, frame: &SensorFrame) -> Processed {
    process_mosaic(
        config,
        response,
        &frame.raw,
        frame.width,
        frame.height,
        frame.origin,
    )
}

/// [`process`] on a mosaic given by its parts.
#[must_use]
pub fn process_mosaic(
    config: &SensorConfig,
    response: &Mat3,
    raw: &[u16],
    width: u32,
    height: u32,
    origin: (u32, u32),
) -> Processed {
    process_linear(config, response, &linearise(config, raw), width, height, origin)
}

/// The noise-free image of a frame through the same ISP: its noise-free DN (clipped by the ADC)
/// linearised and processed as the raw mosaic is. The clean half of a training pair.
#[must_use]
pub fn process_clean(config: &SensorConfig, response: &Mat3, frame: &SensorFrame) -> Processed {
    let black = config.black_level_dn;
    let top = config.linear_max_code();
    let x: Vec<f32> = frame
        .clean_dn
        .iter()
        .map(|&dn| ((f64::from(dn).min(top) - black) / (top - black)) as f32)
        .collect();
    process_linear(config, response, &x, frame.width, frame.height, frame.origin)
}

/// Steps 2–5 on linearised values `x` (step 1's output).
#[must_use]
pub fn process_linear(
    config: &SensorConfig,
    response: &Mat3,
    x: &[f32],
    width: u32,
    height: u32,
    origin: (u32, u32),
) -> Processed {
    let isp = &config.isp;
    let rgb = demosaic(x, width, height, origin, config.cfa, isp.demosaic);
    let mono = config.cfa == Cfa::None;
    let neutral = apply(response, [1.0; 3]);
    let white_balance = if mono {
        [1.0; 3]
    } else {
        match isp.white_balance {
            WhiteBalance::AsShot => neutral.map(|n| neutral[1] / n),
            WhiteBalance::GreyWorld => {
                let mut sum = [0.0f64; 3];
                for p in &rgb {
                    for c in 0..3 {
                        sum[c] += f64::from(p[c]);
                    }
                }
                sum.map(|s| if s > 0.0 { sum[1] / s } else { 1.0 })
            }
            WhiteBalance::Gains(g) => g,
            WhiteBalance::Off => [1.0; 3],
        }
    };
    let ccm = if mono {
        crate::color::IDENTITY
    } else {
        isp.ccm.unwrap_or_else(|| default_ccm(response))
    };
    let max = f64::from((1u32 << isp.output_bits) - 1);
    let tone = isp.tone;
    let gain = isp.gain;
    let linear: Vec<[f32; 3]> = rgb
        .par_iter()
        .map(|p| {
            let balanced = [0, 1, 2].map(|c| f64::from(p[c]) * white_balance[c]);
            apply(&ccm, balanced).map(|v| (v * gain) as f32)
        })
        .collect();
    let encoded = linear
        .par_iter()
        .flat_map_iter(|p| {
            p.map(|v| {
                let v = f64::from(v).clamp(0.0, 1.0);
                let t = match tone {
                    Tone::Srgb => srgb_oetf(v),
                    Tone::Gamma(g) => v.powf(1.0 / g),
                    Tone::Linear => v,
                };
                (t * max).round() as u16
            })
        })
        .collect();
    Processed {
        linear,
        encoded,
        bits: isp.output_bits,
        white_balance,
        ccm,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mosaic a smooth RGB field, demosaic it, compare with the field.
    fn field(i: u32, j: u32) -> [f32; 3] {
        let (x, y) = (i as f32 / 31.0, j as f32 / 23.0);
        [0.2 + 0.5 * x, 0.3 + 0.4 * y * y, 0.6 - 0.3 * x * y]
    }

    fn mosaic(cfa: Cfa, w: u32, h: u32) -> Vec<f32> {
        (0..h)
            .flat_map(|j| (0..w).map(move |i| field(i, j)[cfa.channel(i, j).unwrap() as usize]))
            .collect()
    }

    #[test]
    fn demosaic_keeps_samples_and_reproduces_flat_and_linear_fields() {
        for cfa in [Cfa::Rggb, Cfa::Bggr, Cfa::Grbg, Cfa::Gbrg] {
            let (w, h) = (32, 24);
            // A flat field is exact for both methods, borders included.
            let flat: Vec<f32> = (0..w * h).map(|_| 0.4).collect();
            for m in [Demosaic::Bilinear, Demosaic::MalvarHeCutler] {
                for p in demosaic(&flat, w, h, (0, 0), cfa, m) {
                    for v in p {
                        assert!((v - 0.4).abs() < 1e-6, "{cfa:?} {m:?}");
                    }
                }
            }
            let x = mosaic(cfa, w, h);
            for m in [Demosaic::Bilinear, Demosaic::MalvarHeCutler] {
                let out = demosaic(&x, w, h, (0, 0), cfa, m);
                let mut worst = 0.0f32;
                for j in 3..h - 3 {
                    for i in 3..w - 3 {
                        let p = out[(j * w + i) as usize];
                        let c = cfa.channel(i, j).unwrap() as usize;
                        assert_eq!(p[c], x[(j * w + i) as usize]);
                        for (v, t) in p.iter().zip(field(i, j)) {
                            worst = worst.max((v - t).abs());
                        }
                    }
                }
                assert!(worst < 0.01, "{cfa:?} {m:?}: {worst}");
            }
        }
    }

    /// Malvar–He–Cutler beats bilinear on an edge between two colours (its reason to exist): the
    /// error over the pixels near a vertical edge is smaller.
    #[test]
    fn malvar_beats_bilinear_at_edges() {
        let (w, h) = (32u32, 16u32);
        let truth = |i: u32| {
            if i < 16 {
                [0.8f32, 0.7, 0.6]
            } else {
                [0.2, 0.25, 0.3]
            }
        };
        let x: Vec<f32> = (0..h)
            .flat_map(|j| (0..w).map(move |i| truth(i)[Cfa::Rggb.channel(i, j).unwrap() as usize]))
            .collect();
        let err = |m| {
            let out = demosaic(&x, w, h, (0, 0), Cfa::Rggb, m);
            let mut e = 0.0f64;
            for j in 2..h - 2 {
                for i in 12..20 {
                    for (v, t) in out[(j * w + i) as usize].iter().zip(truth(i)) {
                        e += f64::from(v - t).powi(2);
                    }
                }
            }
            e
        };
        let (b, m) = (err(Demosaic::Bilinear), err(Demosaic::MalvarHeCutler));
        assert!(m < b, "malvar {m} bilinear {b}");
    }

    #[test]
    fn default_ccm_keeps_white_and_inverts_the_response() {
        let m = crate::color::srgb_response_of_color_matrix(
            crate::color::camera_preset("canon_eos_5d_mark_ii").unwrap(),
        );
        let ccm = default_ccm(&m);
        let n = apply(&m, [1.0; 3]);
        let g = n.map(|v| n[1] / v);
        // A colour seen by the camera, white balanced, corrected: the colour again.
        let colour = [0.3, 0.5, 0.2];
        let cam = apply(&m, colour);
        let back = apply(&ccm, [0, 1, 2].map(|c| cam[c] * g[c]));
        for c in 0..3 {
            assert!((back[c] - colour[c]).abs() < 1e-9, "{back:?}");
        }
        for row in ccm {
            assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-9);
        }
    }
}
