//! Camera samples: Owen-scrambled Sobol points, per pixel.
//!
//! Each pixel draws its samples from its own scramble of the Sobol sequence (Burley's hash-based Owen
//! scrambling, the `sobol_burley` crate), so every pixel's first `2^k` samples are stratified in each
//! pair of dimensions — better than jittered strata for any sample count, with no visible pattern
//! across pixels. The pixel position uses one scramble (Sobol dimensions 0, 1); the lens sample and the
//! time use another (dimensions 0, 1 and 2), so pixel and lens are independent (padding) while the lens
//! pair keeps Sobol's (0, 2) stratification and time its 1-D stratification. Each scramble is one
//! four-wide `sample_4d` call.

/// The largest number of samples per pixel the sequence supports.
pub const MAX_SAMPLES: u32 = 1 << 16;

/// One camera sample of one pixel, before any warp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraSample {
    /// Position inside the pixel, `[0, 1)²` (x right, y down, as raster space).
    pub pixel: (f32, f32),
    /// Canonical lens sample, `[0, 1)²`.
    pub lens: (f32, f32),
    /// Canonical time sample, `[0, 1)`.
    pub time: f32,
}

/// Produces [`CameraSample`]s for any pixel and sample index, in any order and on any thread.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sampler {
    seed: u32,
}

const PIXEL_STREAM: u32 = 0x9e37_79b9;
const LENS_STREAM: u32 = 0x85eb_ca6b;

/// A 32-bit mixing hash (the "lowbias32" finaliser): decorrelates nearby pixel coordinates.
fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

impl Sampler {
    /// A sampler; different seeds give independent sample sets (e.g. one per frame).
    #[must_use]
    pub fn new(seed: u32) -> Self {
        Sampler { seed }
    }

    /// Sample `index` (< [`MAX_SAMPLES`]) of pixel `(x, y)`.
    #[must_use]
    pub fn sample(&self, x: u32, y: u32, index: u32) -> CameraSample {
        let pixel_seed = hash(hash(x ^ hash(y ^ self.seed)) ^ self.seed.rotate_left(7));
        let p = sobol_burley::sample_4d(index, 0, hash(pixel_seed ^ PIXEL_STREAM));
        let l = sobol_burley::sample_4d(index, 0, hash(pixel_seed ^ LENS_STREAM));
        CameraSample {
            pixel: (p[0], p[1]),
            lens: (l[0], l[1]),
            time: l[2],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_power_of_two_prefix_is_stratified_in_each_pair() {
        let s = Sampler::new(7);
        for (px, py) in [(0, 0), (13, 900), (1919, 1079)] {
            let pts: Vec<CameraSample> = (0..256).map(|i| s.sample(px, py, i)).collect();
            // 256 points in a 16×16 grid of strata: exactly one per stratum, for each pair.
            for pick in [|c: &CameraSample| c.pixel, |c: &CameraSample| c.lens] {
                let mut seen = [false; 256];
                for c in &pts {
                    let (u, v) = pick(c);
                    let cell = (u * 16.0) as usize + 16 * (v * 16.0) as usize;
                    assert!(!seen[cell], "two samples in one stratum at pixel ({px}, {py})");
                    seen[cell] = true;
                }
            }
            // And 1-D: one time sample in each of 256 intervals.
            let mut seen = [false; 256];
            for c in &pts {
                let cell = (c.time * 256.0) as usize;
                assert!(!seen[cell]);
                seen[cell] = true;
            }
        }
    }

    #[test]
    fn pixels_and_dimensions_are_decorrelated() {
        let s = Sampler::new(1);
        let a = s.sample(10, 10, 0);
        let b = s.sample(11, 10, 0);
        assert_ne!(a.pixel, b.pixel);
        // Lens and pixel samples of the same index differ (independent scrambles).
        let n = 4096;
        let mut corr = 0.0f64;
        for i in 0..n {
            let c = s.sample(3, 4, i);
            corr += (c.pixel.0 as f64 - 0.5) * (c.lens.0 as f64 - 0.5);
        }
        // Uniform on [0,1): variance 1/12; a correlation of 0.1 would give 34 here.
        assert!(
            (corr / n as f64 * 12.0).abs() < 0.05,
            "correlation {}",
            corr / n as f64 * 12.0
        );
    }

    #[test]
    fn samples_are_reproducible_and_in_range() {
        let s = Sampler::new(3);
        for i in 0..1000 {
            let c = s.sample(5, 6, i);
            assert_eq!(c, s.sample(5, 6, i));
            for v in [c.pixel.0, c.pixel.1, c.lens.0, c.lens.1, c.time] {
                assert!((0.0..1.0).contains(&v));
            }
        }
    }
}
