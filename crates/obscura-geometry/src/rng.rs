//! A small, fast, seedable random number generator for path sampling (PCG-XSH-RR 64/32, O'Neill 2014).

/// PCG32: 64-bit state, 32-bit output. Each path gets its own stream, seeded from pixel and sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    /// A generator for `(seed, stream)`; different streams are independent sequences.
    #[must_use]
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut r = Rng {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A float uniform in `[0, 1)`.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Two floats uniform in `[0, 1)`.
    #[inline]
    pub fn next_2d(&mut self) -> (f32, f32) {
        (self.next_f32(), self.next_f32())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_mean_and_variance_and_range() {
        let mut r = Rng::new(42, 7);
        let n = 200_000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let x = r.next_f32() as f64;
            assert!((0.0..1.0).contains(&x));
            s += x;
            s2 += x * x;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!((mean - 0.5).abs() < 0.005, "{mean}");
        assert!((var - 1.0 / 12.0).abs() < 0.002, "{var}");
    }

    #[test]
    fn streams_differ() {
        let a: Vec<u32> = (0..8).scan(Rng::new(1, 1), |r, _| Some(r.next_u32())).collect();
        let b: Vec<u32> = (0..8).scan(Rng::new(1, 2), |r, _| Some(r.next_u32())).collect();
        assert_ne!(a, b);
        let c: Vec<u32> = (0..8).scan(Rng::new(1, 1), |r, _| Some(r.next_u32())).collect();
        assert_eq!(a, c);
    }
}
