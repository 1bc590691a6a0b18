//! `PxrPerspective`'s pinhole eight rays at a time in AVX2, for CPUs without AVX-512: LLVM's loop
//! vectoriser declines the plain loop (it stays scalar, a fifth of this kernel's rate).
//!
//! [`PerspectiveRays::pinhole`] operation for operation (exact `div` and `sqrt`, a fused multiply-add
//! only where the portable code has `mul_add`, [`quarter_root`]'s integer seed and Newton steps), so
//! the rays are bit-identical to the portable tier's. The lanes go to a [`Sink`]: through a small
//! array on the stack into the 40-byte records ([`Aos`]), or each register straight into its array
//! ([`Soa`], `project_soa`).
//!
//! [`quarter_root`]: obscura_sdk::optics::quarter_root

use std::arch::x86_64::*;

use obscura_sdk::optics::{PINHOLE_W_MAX, PerspectiveRays, QUARTER_ROOT_SEED};
use obscura_sdk::{Point2, RayGeometry, RaysSoa, SoaFields, Vec3};

/// Eight rays' direction `x`, `y`, `z`, spread, `min_dist` and `max_dist`, one register each (the
/// pinhole's origin and origin radius are 0).
pub(crate) type Lanes = [__m256; 6];

/// Where the kernel puts its rays.
pub(crate) trait Sink {
    /// Stores rays `i .. i + 8` from `lanes`.
    ///
    /// # Safety
    /// The CPU has AVX2; `i + 8` is within the sink.
    unsafe fn put(&mut self, i: usize, lanes: &Lanes);
    /// Stores `ray` as ray `i` (the batch's tail, fewer than eight rays).
    fn put_one(&mut self, i: usize, ray: &RayGeometry);

    /// False when the sink never stores `ray_spread`: the kernel then skips computing it.
    fn wants_spread(&self) -> bool {
        true
    }
}

/// The renderer's array of `RtRayGeometry` records.
pub(crate) struct Aos<'a>(pub &'a mut [RayGeometry]);

impl Sink for Aos<'_> {
    #[inline(always)]
    unsafe fn put(&mut self, i: usize, lanes: &Lanes) {
        let mut f = [[0.0f32; 8]; 6];
        for (a, v) in f.iter_mut().zip(lanes) {
            // SAFETY: an unaligned store of eight f32 into a local array of eight.
            unsafe { _mm256_storeu_ps(a.as_mut_ptr(), *v) };
        }
        for (k, o) in self.0[i..i + 8].iter_mut().enumerate() {
            *o = RayGeometry {
                origin: Vec3::ZERO,
                origin_radius: 0.0,
                direction: Vec3::new(f[0][k], f[1][k], f[2][k]),
                ray_spread: f[3][k],
                min_dist: f[4][k],
                max_dist: f[5][k],
            };
        }
    }

    #[inline(always)]
    fn put_one(&mut self, i: usize, ray: &RayGeometry) {
        self.0[i] = *ray;
    }
}

/// The ten arrays of a [`RaysSoa`]; the vector stores skip the fields outside the set
/// ([`obscura_sdk::SoaContext::fields`]).
pub(crate) struct Soa<'s, 'a>(pub &'s mut RaysSoa<'a>, pub SoaFields);

impl Sink for Soa<'_, '_> {
    #[inline(always)]
    unsafe fn put(&mut self, i: usize, lanes: &Lanes) {
        // SAFETY: only inlined into the kernel, which has AVX2.
        let zero = unsafe { _mm256_setzero_ps() };
        let [dx, dy, dz, spread, min, max] = *lanes;
        let values = [zero, zero, zero, zero, dx, dy, dz, spread, min, max];
        let wanted = self.1;
        for (k, (field, v)) in self.0.fields_mut().into_iter().zip(values).enumerate() {
            if wanted.has(k) {
                let out = &mut field[i..i + 8];
                // SAFETY: an unaligned store of eight f32 into a slice of eight.
                unsafe { _mm256_storeu_ps(out.as_mut_ptr(), v) };
            }
        }
    }

    #[inline(always)]
    fn put_one(&mut self, i: usize, ray: &RayGeometry) {
        self.0.set(i, ray);
    }

    fn wants_spread(&self) -> bool {
        self.1.contains(SoaFields::RAY_SPREAD)
    }
}

/// [`PerspectiveRays::pinhole`] over a batch of `n` rays, into `sink`.
///
/// # Safety
/// The CPU has AVX2 and FMA; `screen` and `sink` hold `n` samples and rays.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn pinhole(
    rays: &PerspectiveRays,
    screen: &[Point2],
    d: f32,
    n: usize,
    sink: &mut impl Sink,
) {
    let blocks = n / 8;
    let (vd, d2, inv_d2) = (
        _mm256_set1_ps(d),
        _mm256_set1_ps(d * d),
        _mm256_set1_ps(1.0 / (d * d)),
    );
    let (half_d, near, far, one, w_max) = (
        _mm256_set1_ps(rays.half_pixel * d),
        _mm256_set1_ps(rays.near / d),
        _mm256_set1_ps(rays.far / d),
        _mm256_set1_ps(1.0),
        _mm256_set1_ps(PINHOLE_W_MAX),
    );
    let (seed, quarter, five_quarters) = (
        _mm256_set1_epi32(QUARTER_ROOT_SEED as i32),
        _mm256_set1_ps(0.25),
        _mm256_set1_ps(1.25),
    );
    let spread_on = sink.wants_spread();
    for b in 0..blocks {
        let s = &screen[b * 8..b * 8 + 8];
        let xs: [f32; 8] = std::array::from_fn(|i| s[i].x);
        let ys: [f32; 8] = std::array::from_fn(|i| s[i].y);
        // SAFETY: unaligned loads and stores of eight f32 from and to local arrays of eight.
        unsafe {
            let x = _mm256_loadu_ps(xs.as_ptr());
            let y = _mm256_loadu_ps(ys.as_ptr());
            let sx2 = _mm256_mul_ps(x, x);
            let sy2 = _mm256_mul_ps(y, y);
            let l = _mm256_sqrt_ps(_mm256_add_ps(_mm256_add_ps(sx2, sy2), d2));
            let inv_l = _mm256_div_ps(one, l);
            let spread = if spread_on {
                // `min_ps` returns its second operand for a NaN, as `f32::min` does.
                let w = _mm256_min_ps(
                    _mm256_mul_ps(
                        _mm256_mul_ps(_mm256_add_ps(sx2, d2), inv_d2),
                        _mm256_mul_ps(_mm256_add_ps(sy2, d2), inv_d2),
                    ),
                    w_max,
                );
                let quarter_w = _mm256_mul_ps(quarter, w);
                let mut r = _mm256_castsi256_ps(_mm256_sub_epi32(
                    seed,
                    _mm256_srli_epi32::<2>(_mm256_castps_si256(w)),
                ));
                for _ in 0..3 {
                    let r2 = _mm256_mul_ps(r, r);
                    r = _mm256_fnmadd_ps(
                        _mm256_mul_ps(quarter_w, r2),
                        _mm256_mul_ps(r2, r),
                        _mm256_mul_ps(five_quarters, r),
                    );
                }
                let root = _mm256_mul_ps(_mm256_mul_ps(w, r), _mm256_mul_ps(r, r));
                _mm256_mul_ps(root, _mm256_mul_ps(half_d, _mm256_mul_ps(inv_l, inv_l)))
            } else {
                _mm256_setzero_ps()
            };
            let lanes = [
                _mm256_mul_ps(x, inv_l),
                _mm256_mul_ps(y, inv_l),
                _mm256_mul_ps(vd, inv_l),
                spread,
                _mm256_mul_ps(near, l),
                _mm256_mul_ps(far, l),
            ];
            // SAFETY: rays b·8 .. b·8 + 8 are in the sink (`b < n / 8`).
            sink.put(b * 8, &lanes);
        }
    }
    for (i, s) in screen.iter().enumerate().take(n).skip(blocks * 8) {
        sink.put_one(i, &rays.pinhole(*s, d));
    }
}
