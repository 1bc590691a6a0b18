//! One tabulated 1-D distribution, built from weights and inverted by its CDF: the table behind the
//! aperture's angular warp, the shutter's time warp and the renderer's dome-light importance sampling
//! (pbrt-v4's `PiecewiseConstant1D`).
//!
//! # Definition
//!
//! `n` weights `w₀ … w_{n−1}` are the values of a piecewise-constant function `f` on the `n` equal cells
//! `[i/n, (i+1)/n)` of `[0, 1)`. Then:
//!
//! 1. the integral is `I = Σ wᵢ / n`;
//! 2. the CDF table is `F₀ = 0`, `F_{i+1} = (Σ_{k≤i} w_k / n) / I`, its last entry pinned to exactly 1;
//! 3. the density on cell i is `p = wᵢ / I` (so `∫₀¹ p = 1`), the probability of cell i is `wᵢ / (n·I)`;
//! 4. sampling inverts the CDF, which is linear on each cell because the density is constant there: for
//!    `u ∈ [0, 1)` the cell i with `Fᵢ ≤ u < F_{i+1}` is found by binary search, and
//!    `x = (i + (u − Fᵢ)/(F_{i+1} − Fᵢ)) / n`. The search is narrowed by a guide table (below); it
//!    finds the same cell as a search over the whole table. This is the exact inverse of the tabulated CDF, so
//!    `F(x) = u` up to rounding, and the map from u to x is monotone (stratified samples stay
//!    stratified).
//!
//! A caller with cell *masses* `mᵢ` (integrals over cells of width `1/n`) passes `wᵢ = mᵢ·n`; when n is a
//! power of two that scaling is exact, and the table's running sums are those of the masses bit for bit.
//!
//! # The guide table
//!
//! With `G = min(n, 2¹⁶)` buckets `[j/G, (j+1)/G)` of `u`, `gⱼ` (for `j = 0..=G`) is the first
//! index `k` with `F_k > j/G`. For `u` in bucket `j` (`j = ⌊u·G⌋`), every entry before `g_{j−1}` is
//! `≤ (j−1)/G ≤ u` and every entry from `g_{j+2}` on is `> (j+2)/G > u`, so the cell lies between
//! them and the binary search runs over `F[g_{j−1} .. g_{j+2}]` only (one bucket of margin on each
//! side covers the rounding of `u·G` and of `j/G`, which is far below `1/G`). A lamp of 10⁴
//! emissive triangles is then searched over a handful of entries instead of 14 levels of a table
//! that does not fit in L1.
//!
//! # Precision
//!
//! The table is stored and searched in `T`, `f32` or `f64` ([`Real`]); the running sums of step 1 and 2
//! are always accumulated in `f64` and rounded to `T` entry by entry, then divided by `I` in `T`.
//!
//! # Degenerate weights
//!
//! - No weights, or a negative or NaN weight: [`Distribution1D::new`] returns a [`DistributionError`].
//! - Zero weights are allowed (their cells are never sampled), and so is `+∞`.
//! - When `I` is not a positive finite number (every weight 0, or a weight `+∞`), the table falls back
//!   to the uniform distribution: `Fᵢ = i/n` and density 1 on every cell.
//!   [`Distribution1D::integral`] still reports `I`, so a caller for which that is an error (the shutter:
//!   "the shutter never opens") can say so.
//!
//! Sample inputs are clamped to `[0, 1]` (NaN reads as 0); `u = 1` gives the right end of the last cell
//! with positive weight.

use std::fmt::Debug;
use std::ops::{Add, Div, Mul, Sub};

/// The float type a [`Distribution1D`] is stored and searched in: `f32` or `f64` (sealed).
pub trait Real:
    Copy
    + Debug
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + private::Sealed
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// The nearest value to `v` (`as` conversion).
    fn from_f64(v: f64) -> Self;
    /// `self` widened to `f64` (exact).
    fn to_f64(self) -> f64;
    /// The nearest value to `v` (`as` conversion).
    fn from_usize(v: usize) -> Self;
    /// `self` truncated toward zero to an index (`as` conversion: saturating, NaN gives 0).
    fn to_usize(self) -> usize;
    /// Neither infinite nor NaN.
    fn is_finite(self) -> bool;
    /// Is NaN.
    fn is_nan(self) -> bool;
}

mod private {
    /// Keeps [`super::Real`] to the two float types the tables are written for.
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

macro_rules! impl_real {
    ($t:ty) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            #[inline]
            fn from_f64(v: f64) -> Self {
                v as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                f64::from(self)
            }
            #[inline]
            fn from_usize(v: usize) -> Self {
                v as $t
            }
            #[inline]
            fn to_usize(self) -> usize {
                self as usize
            }
            #[inline]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline]
            fn is_nan(self) -> bool {
                <$t>::is_nan(self)
            }
        }
    };
}

impl_real!(f32);
impl_real!(f64);

/// Weights that [`Distribution1D::new`] rejects.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum DistributionError {
    /// There were no weights: a distribution needs at least one cell.
    #[error("a tabulated distribution needs at least one weight, got none")]
    Empty,
    /// A weight was negative or NaN.
    #[error("weight {index} of a tabulated distribution is {value}: expected a number >= 0")]
    InvalidWeight {
        /// Position of the weight.
        index: usize,
        /// The rejected value (widened to `f64`).
        value: f64,
    },
}

/// A piecewise-constant density on `[0, 1)` over `n` equal cells, with its CDF tabulated for inversion
/// (see the [module documentation](self) for the formulas and the degenerate cases).
///
/// Immutable after [`Distribution1D::new`], so one table may be shared by every rendering thread.
#[derive(Debug, Clone)]
pub struct Distribution1D<T: Real = f64> {
    /// The weights `wᵢ`, one per cell.
    func: Vec<T>,
    /// `Fᵢ` for `i = 0..=n`: 0 first, exactly 1 last.
    cdf: Vec<T>,
    /// `I = Σ wᵢ / n`, as accumulated (possibly 0 or infinite).
    integral: T,
    /// `I` is a positive finite number: the table is normalised by it (otherwise it is uniform).
    normalised: bool,
    /// The guide table `g₀ … g_G` (see the [module documentation](self)).
    guide: Vec<u32>,
}

/// Most buckets of the guide table: `1/G` stays far above the rounding of `u·G` even in `f32`.
const GUIDE_BUCKETS: usize = 1 << 16;

impl<T: Real> Distribution1D<T> {
    /// Tabulates the CDF of the piecewise-constant function whose value on cell i of `n = weights.len()`
    /// equal cells of `[0, 1)` is `weights[i]`.
    ///
    /// All-zero (or overflowing) weights give the uniform distribution; see the
    /// [module documentation](self).
    ///
    /// # Errors
    /// [`DistributionError::Empty`] for no weights, [`DistributionError::InvalidWeight`] for the first
    /// negative or NaN weight.
    pub fn new(weights: Vec<T>) -> Result<Self, DistributionError> {
        if weights.is_empty() {
            return Err(DistributionError::Empty);
        }
        if let Some((index, &w)) = weights
            .iter()
            .enumerate()
            .find(|(_, w)| w.is_nan() || **w < T::ZERO)
        {
            return Err(DistributionError::InvalidWeight {
                index,
                value: w.to_f64(),
            });
        }
        let n = weights.len();
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(T::ZERO);
        let mut running = 0.0f64;
        for &w in &weights {
            running += w.to_f64() / n as f64;
            cdf.push(T::from_f64(running));
        }
        let integral = T::from_f64(running);
        let normalised = integral > T::ZERO && integral.is_finite();
        if normalised {
            for c in &mut cdf {
                *c = *c / integral;
            }
        } else {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = T::from_usize(i) / T::from_usize(n);
            }
        }
        if let Some(last) = cdf.last_mut() {
            *last = T::ONE;
        }
        let guide = guide_table(&cdf, n.min(GUIDE_BUCKETS));
        Ok(Distribution1D {
            func: weights,
            cdf,
            integral,
            normalised,
            guide,
        })
    }

    /// The number of cells n (at least 1).
    #[must_use]
    pub fn cell_count(&self) -> usize {
        self.func.len()
    }

    /// `I = Σ wᵢ / n`, the integral of the weights' function over `[0, 1)`, as accumulated: 0 when every
    /// weight is 0, `+∞` when one is (the table is then uniform).
    #[must_use]
    pub fn integral(&self) -> T {
        self.integral
    }

    /// Whether the weights could be normalised (`I` positive and finite); `false` means the table is
    /// the uniform fallback.
    #[must_use]
    pub fn is_normalised(&self) -> bool {
        self.normalised
    }

    /// The CDF table `F₀ … F_n` (`n + 1` entries, `F₀ = 0`, `F_n = 1`, non-decreasing).
    #[must_use]
    pub fn cdf(&self) -> &[T] {
        &self.cdf
    }

    /// The cell containing `x`: `⌊x·n⌋`, clamped to `0..n` (NaN gives cell 0).
    #[must_use]
    pub fn cell(&self, x: T) -> usize {
        (x * T::from_usize(self.cell_count()))
            .to_usize()
            .min(self.cell_count() - 1)
    }

    /// The density on cell `index`, `wᵢ / I` (1 for the uniform fallback, 0 past the last cell).
    #[must_use]
    pub fn cell_pdf(&self, index: usize) -> T {
        if self.normalised {
            self.func.get(index).map_or(T::ZERO, |&w| w / self.integral)
        } else if index < self.cell_count() {
            T::ONE
        } else {
            T::ZERO
        }
    }

    /// The probability of cell `index`, `wᵢ / (n·I)`: what [`Distribution1D::sample_discrete`] reports.
    #[must_use]
    pub fn cell_probability(&self, index: usize) -> T {
        self.cell_pdf(index) / T::from_usize(self.cell_count())
    }

    /// The density at `x` with respect to `dx` on `[0, 1]`: the density of the cell containing x, 0
    /// outside `[0, 1]` and for NaN.
    #[must_use]
    pub fn pdf(&self, x: T) -> T {
        if x >= T::ZERO && x <= T::ONE {
            self.cell_pdf(self.cell(x))
        } else {
            T::ZERO
        }
    }

    /// The tabulated CDF at `x`, linear within each cell: `Fᵢ + (x·n − i)·(F_{i+1} − Fᵢ)`; 0 below
    /// `[0, 1]` (and for NaN), 1 above. The inverse of [`Distribution1D::sample_continuous`].
    #[must_use]
    pub fn cdf_at(&self, x: T) -> T {
        if x.is_nan() || x <= T::ZERO {
            return T::ZERO;
        }
        if x >= T::ONE {
            return T::ONE;
        }
        let i = self.cell(x);
        let (c0, c1) = (self.cdf[i], self.cdf[i + 1]);
        let within = x * T::from_usize(self.cell_count()) - T::from_usize(i);
        c0 + within * (c1 - c0)
    }

    /// Draws `x ∈ [0, 1]` with density [`Distribution1D::pdf`] by inverting the CDF at `u`; returns
    /// `(x, density at x, cell index)`.
    ///
    /// `u` is clamped to `[0, 1]` (NaN reads as 0). For `u < 1` the result lies in the cell's half-open
    /// range `[i/n, (i+1)/n)` up to rounding of the final division (in `f32`, `x` may round up to 1).
    #[must_use]
    pub fn sample_continuous(&self, u: T) -> (T, T, usize) {
        let (index, within) = self.locate(u);
        let x = (T::from_usize(index) + within) / T::from_usize(self.cell_count());
        (x, self.cell_pdf(index), index)
    }

    /// Picks a cell with probability [`Distribution1D::cell_probability`]; returns
    /// `(cell index, its probability, u remapped to [0, 1] within the cell)`, the remapped value being
    /// fresh enough to reuse for a further decision.
    ///
    /// `u` is clamped to `[0, 1]` (NaN reads as 0).
    #[must_use]
    pub fn sample_discrete(&self, u: T) -> (usize, T, T) {
        let (index, within) = self.locate(u);
        (index, self.cell_probability(index), within)
    }

    /// The cell i with `Fᵢ ≤ u < F_{i+1}` (for `u = 1`, the last cell with `Fᵢ < 1`) and the fraction
    /// `(u − Fᵢ)/(F_{i+1} − Fᵢ) ∈ [0, 1]` of the way through it.
    fn locate(&self, u: T) -> (usize, T) {
        let u = if u.is_nan() { T::ZERO } else { clamp_unit(u) };
        // F₀ = 0 ≤ u, so both searches find at least one entry; F_n = 1 bounds the first one for u < 1,
        // and the second one stops at the first entry equal to 1, so zero-weight trailing cells are
        // never chosen.
        let after = if u < T::ONE {
            // The same index as `self.cdf.partition_point(|&c| c <= u)`, searched between the guide
            // table's bounds (module documentation).
            let buckets = self.guide.len() - 1;
            let j = (u * T::from_usize(buckets)).to_usize().min(buckets - 1);
            let lo = self.guide[j.saturating_sub(1)] as usize;
            let hi = (self.guide[(j + 2).min(buckets)] as usize).max(lo);
            lo + self.cdf[lo..hi].partition_point(|&c| c <= u)
        } else {
            self.cdf.partition_point(|&c| c < T::ONE)
        };
        let i = after.saturating_sub(1).min(self.cell_count() - 1);
        let (c0, c1) = (self.cdf[i], self.cdf[i + 1]);
        // Always true for the cell found above; kept so that no division by zero can happen.
        let within = if c1 > c0 {
            clamp_unit((u - c0) / (c1 - c0))
        } else {
            T::ZERO
        };
        (i, within)
    }
}

/// `gⱼ` for `j = 0..=buckets`: the first index `k` of `cdf` (non-decreasing) with `F_k > j/buckets`
/// (`cdf.len()` when there is none).
fn guide_table<T: Real>(cdf: &[T], buckets: usize) -> Vec<u32> {
    let mut guide = Vec::with_capacity(buckets + 1);
    let mut k = 0usize;
    for j in 0..=buckets {
        let bound = T::from_usize(j) / T::from_usize(buckets);
        while k < cdf.len() && cdf[k] <= bound {
            k += 1;
        }
        guide.push(k as u32);
    }
    guide
}

/// `v` clamped to `[0, 1]` (NaN stays NaN, as with `f32::clamp`).
#[inline]
fn clamp_unit<T: Real>(v: T) -> T {
    if v < T::ZERO {
        T::ZERO
    } else if v > T::ONE {
        T::ONE
    } else {
        v
    }
}

/// Deterministic uniform samples for the tests of this table and of the warps built on it.
#[cfg(test)]
pub(crate) mod test_samples {
    /// A small deterministic generator (SplitMix64) for uniform test samples in `[0, 1)`; the state is
    /// the seed.
    pub(crate) struct Rng(pub(crate) u64);

    impl Rng {
        /// The next uniform `f32` in `[0, 1)`, on the 2⁻²⁴ grid.
        pub(crate) fn next_f32(&mut self) -> f32 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            (z >> 40) as f32 / (1u64 << 24) as f32
        }
    }
}

#[cfg(test)]
mod tests {
    use super::test_samples::Rng;
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn piecewise_constant_distribution_samples_its_density() {
        let d = Distribution1D::<f32>::new(vec![0.0, 3.0, 0.0, 1.0]).expect("valid");
        let mut hist = [0usize; 4];
        let n = 100_000;
        let mut rng = Rng(2);
        for _ in 0..n {
            let (x, pdf, i) = d.sample_continuous(rng.next_f32());
            assert_eq!(i, (x * 4.0) as usize);
            assert!(pdf > 0.0);
            hist[i] += 1;
        }
        assert_eq!(hist[0] + hist[2], 0);
        assert!((hist[1] as f64 / n as f64 - 0.75).abs() < 0.01);
        assert_eq!(d.cell_pdf(1), 3.0);
    }

    #[test]
    fn table_matches_the_closed_form() {
        // w = [1, 3]: I = 2, F = [0, 1/4, 1], density 1/2 then 3/2.
        let d = Distribution1D::<f64>::new(vec![1.0, 3.0]).expect("valid");
        assert_eq!(d.integral(), 2.0);
        assert_eq!(d.cdf(), &[0.0, 0.25, 1.0]);
        assert_eq!((d.cell_pdf(0), d.cell_pdf(1)), (0.5, 1.5));
        assert_eq!((d.cell_probability(0), d.cell_probability(1)), (0.25, 0.75));
        // The inverse in closed form: x = u/(1/2) for u < 1/4, x = 1/2 + (u − 1/4)/(3/2) above.
        for k in 0..1000 {
            let u = f64::from(k) / 1000.0;
            let expected = if u < 0.25 { u / 0.5 } else { 0.5 + (u - 0.25) / 1.5 };
            let (x, pdf, i) = d.sample_continuous(u);
            assert!((x - expected).abs() < 1e-12, "u = {u}: {x} vs {expected}");
            assert_eq!(pdf, if u < 0.25 { 0.5 } else { 1.5 });
            assert_eq!(i, usize::from(u >= 0.25));
        }
        assert_eq!(d.pdf(0.3), 0.5);
        assert_eq!(d.pdf(0.7), 1.5);
        assert_eq!(d.pdf(-0.1), 0.0);
        assert_eq!(d.pdf(1.5), 0.0);
        assert_eq!(d.pdf(f64::NAN), 0.0);
    }

    #[test]
    fn uniform_weights_give_the_identity() {
        let d = Distribution1D::<f64>::new(vec![2.5; 8]).expect("valid");
        for k in 0..=64 {
            let u = f64::from(k) / 64.0;
            let (x, pdf, _) = d.sample_continuous(u);
            assert!((x - u).abs() < 1e-15, "u = {u}: {x}");
            assert!((pdf - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn zero_and_overflowing_weights_fall_back_to_uniform() {
        for weights in [vec![0.0f32; 5], vec![1.0, f32::INFINITY, 0.0, 2.0, 1.0]] {
            let d = Distribution1D::new(weights.clone()).expect("allowed");
            assert!(!d.is_normalised(), "{weights:?}");
            assert_eq!(d.cdf(), &[0.0, 0.2, 0.4, 0.6, 0.8, 1.0]);
            for i in 0..5 {
                assert_eq!(d.cell_pdf(i), 1.0);
            }
            assert_eq!(d.cell_pdf(5), 0.0);
            assert_eq!(d.sample_continuous(0.5).0, 0.5);
        }
        assert_eq!(
            Distribution1D::new(vec![0.0f64; 3]).expect("allowed").integral(),
            0.0
        );
        assert_eq!(
            Distribution1D::new(vec![1.0, f64::INFINITY])
                .expect("allowed")
                .integral(),
            f64::INFINITY
        );
    }

    #[test]
    fn invalid_weights_are_errors_naming_the_weight() {
        assert_eq!(
            Distribution1D::<f64>::new(Vec::new()).unwrap_err(),
            DistributionError::Empty
        );
        assert_eq!(
            Distribution1D::new(vec![1.0f32, -0.5, 2.0]).unwrap_err(),
            DistributionError::InvalidWeight {
                index: 1,
                value: -0.5
            }
        );
        let err = Distribution1D::new(vec![1.0f64, 2.0, f64::NAN]).unwrap_err();
        assert!(matches!(err, DistributionError::InvalidWeight { index: 2, value } if value.is_nan()));
        assert!(err.to_string().contains("weight 2"), "{err}");
        // Zero weights and a negative zero are fine.
        assert!(Distribution1D::new(vec![0.0f64, -0.0, 1.0]).is_ok());
    }

    #[test]
    fn zero_weight_cells_are_never_sampled_even_at_the_ends() {
        let d = Distribution1D::<f32>::new(vec![0.0, 0.0, 2.0, 0.0, 1.0, 0.0, 0.0]).expect("valid");
        for u in [
            0.0f32,
            -1.0,
            f32::NAN,
            1.0,
            2.0,
            f32::INFINITY,
            1.0 - f32::EPSILON / 2.0,
        ] {
            let (x, pdf, i) = d.sample_continuous(u);
            assert!(i == 2 || i == 4, "u = {u}: cell {i}");
            assert!(pdf > 0.0);
            assert!((0.0..=1.0).contains(&x));
        }
        // The ends of the range map to the ends of the positive cells.
        assert_eq!(d.sample_continuous(0.0).0, 2.0 / 7.0);
        assert_eq!(d.sample_continuous(1.0).0, 5.0 / 7.0);
        assert_eq!(d.sample_continuous(f32::NAN), d.sample_continuous(0.0));
    }

    #[test]
    fn discrete_sampling_picks_cells_by_probability_and_remaps_u() {
        let d = Distribution1D::<f64>::new(vec![1.0, 0.0, 3.0]).expect("valid");
        assert_eq!(d.sample_discrete(0.0), (0, 0.25, 0.0));
        assert_eq!(d.sample_discrete(0.125), (0, 0.25, 0.5));
        assert_eq!(d.sample_discrete(0.25), (2, 0.75, 0.0));
        assert_eq!(d.sample_discrete(0.625), (2, 0.75, 0.5));
        assert_eq!(d.sample_discrete(1.0), (2, 0.75, 1.0));
        let total: f64 = (0..d.cell_count()).map(|i| d.cell_probability(i)).sum();
        assert!((total - 1.0).abs() < 1e-15);
    }

    #[test]
    fn f32_and_f64_tables_agree_to_f32_precision() {
        let weights: Vec<f64> = (0..37).map(|i| f64::from((i * 7919) % 13)).collect();
        let d64 = Distribution1D::new(weights.clone()).expect("valid");
        let d32 = Distribution1D::new(weights.iter().map(|&w| w as f32).collect()).expect("valid");
        for k in 0..1000 {
            let u = f64::from(k) / 1000.0;
            let (x64, p64, _) = d64.sample_continuous(u);
            let (x32, p32, _) = d32.sample_continuous(u as f32);
            assert!((f64::from(x32) - x64).abs() < 1e-5, "u = {u}");
            assert!((f64::from(p32) - p64).abs() < 1e-5 * p64.max(1.0), "u = {u}");
        }
    }

    fn weights() -> impl Strategy<Value = Vec<f64>> {
        // Some exact zeros, so that empty cells are exercised, and at least one positive weight.
        proptest::collection::vec(prop_oneof![Just(0.0), 1e-3f64..1e3], 1..48)
            .prop_filter("some mass", |w| w.iter().any(|&v| v > 0.0))
    }

    proptest! {
        #[test]
        fn inverse_cdf_round_trips_and_stays_in_range(w in weights(), u in 0.0f64..1.0) {
            let d = Distribution1D::new(w.clone()).expect("valid by construction");
            let (x, pdf, i) = d.sample_continuous(u);
            let n = w.len() as f64;
            prop_assert!((0.0..=1.0).contains(&x), "x = {}", x);
            prop_assert!(i < w.len());
            prop_assert!(w[i] > 0.0, "sampled empty cell {}", i);
            prop_assert!(x >= i as f64 / n - 1e-12 && x <= (i + 1) as f64 / n + 1e-12);
            prop_assert!(pdf > 0.0 && (pdf - d.cell_pdf(i)).abs() == 0.0);
            prop_assert!((d.cdf_at(x) - u).abs() < 1e-9, "F(x) = {} for u = {}", d.cdf_at(x), u);
        }

        #[test]
        fn pdf_integrates_to_one(w in weights()) {
            let d = Distribution1D::new(w.clone()).expect("valid by construction");
            let n = w.len();
            let integral: f64 = (0..n).map(|i| d.cell_pdf(i) / n as f64).sum();
            prop_assert!((integral - 1.0).abs() < 1e-12, "∫ pdf = {}", integral);
            // The CDF table is the running integral of the density.
            let mut running = 0.0;
            for i in 0..n {
                prop_assert!((d.cdf()[i] - running).abs() < 1e-12);
                running += d.cell_probability(i);
            }
            prop_assert_eq!(d.cdf()[n], 1.0);
            // And the integral is the weights' mean.
            let mean = w.iter().sum::<f64>() / n as f64;
            prop_assert!((d.integral() - mean).abs() <= 1e-12 * mean);
        }

        /// The guided search finds the cell a search over the whole table finds, for `f64` and `f32`
        /// tables, at random `u` and at `u` within an ulp of the bucket bounds `j/G`.
        #[test]
        fn the_guide_table_finds_the_cell_the_full_search_finds(
            w in proptest::collection::vec(prop_oneof![Just(0.0), 1e-6f64..1e6], 1..300),
            us in proptest::collection::vec(0.0f64..1.0, 64),
            edges in proptest::collection::vec(any::<prop::sample::Index>(), 16),
        ) {
            let d64 = Distribution1D::new(w.clone()).expect("valid by construction");
            let d32 = Distribution1D::new(w.iter().map(|&v| v as f32).collect()).expect("valid");
            let g = w.len().min(GUIDE_BUCKETS);
            let near_edges = edges.iter().flat_map(|e| {
                let b = e.index(g + 1) as f64 / g as f64;
                [b, b.next_down(), b.next_up(), f64::from((b as f32).next_down()), f64::from((b as f32).next_up())]
            });
            for u in us.iter().copied().chain(near_edges).filter(|u| (0.0..1.0).contains(u)) {
                let full = d64.cdf().partition_point(|&c| c <= u).saturating_sub(1).min(w.len() - 1);
                prop_assert_eq!(d64.sample_discrete(u).0, full, "f64, u = {}", u);
                let u32_ = u as f32;
                if u32_ < 1.0 {
                    let full = d32.cdf().partition_point(|&c| c <= u32_).saturating_sub(1).min(w.len() - 1);
                    prop_assert_eq!(d32.sample_discrete(u32_).0, full, "f32, u = {}", u32_);
                }
            }
        }

        #[test]
        fn sampling_is_monotone_in_u(w in weights(), a in 0.0f64..1.0, b in 0.0f64..1.0) {
            let d = Distribution1D::new(w).expect("valid by construction");
            let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
            prop_assert!(d.sample_continuous(lo).0 <= d.sample_continuous(hi).0);
        }
    }
}
