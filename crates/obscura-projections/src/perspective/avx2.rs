//! `PxrPerspective`'s pinhole eight rays at a time in AVX2, for CPUs without AVX-512: LLVM's loop
//! vectoriser declines the plain loop (it stays scalar, a fifth of this kernel's rate).
//!
//! [`PerspectiveRays::pinhole`] operation for operation (exact `div` and `sqrt`, no fused multiply-add,
//! [`quarter_root`]'s integer seed and Newton steps), so the rays are bit-identical to the portable
//! tier's. The lanes go through a small array on the stack into the 40-byte records.
//!
//! [`quarter_root`]: obscura_sdk::optics::quarter_root

use std::arch::x86_64::*;

use obscura_sdk::optics::{PerspectiveRays, QUARTER_ROOT_SEED};
use obscura_sdk::{Point2, RayGeometry, Vec3};

/// [`PerspectiveRays::pinhole`] over a batch.
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn pinhole(rays: &PerspectiveRays, screen: &[Point2], d: f32, out: &mut [RayGeometry]) {
    let n = screen.len().min(out.len());
    let blocks = n / 8;
    let (vd, d2) = (_mm256_set1_ps(d), _mm256_set1_ps(d * d));
    let (half, near, far, one) = (
        _mm256_set1_ps(rays.half_pixel),
        _mm256_set1_ps(rays.near / d),
        _mm256_set1_ps(rays.far / d),
        _mm256_set1_ps(1.0),
    );
    let (seed, quarter, five_quarters) = (
        _mm256_set1_epi32(QUARTER_ROOT_SEED as i32),
        _mm256_set1_ps(0.25),
        _mm256_set1_ps(1.25),
    );
    let mut lanes = [[0.0f32; 8]; 6];
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
            let inv_l2 = _mm256_mul_ps(inv_l, inv_l);
            let w = _mm256_mul_ps(
                _mm256_mul_ps(_mm256_add_ps(sx2, d2), inv_l2),
                _mm256_mul_ps(_mm256_add_ps(sy2, d2), inv_l2),
            );
            let quarter_w = _mm256_mul_ps(quarter, w);
            let mut r = _mm256_castsi256_ps(_mm256_sub_epi32(
                seed,
                _mm256_srli_epi32::<2>(_mm256_castps_si256(w)),
            ));
            for _ in 0..3 {
                let r2 = _mm256_mul_ps(r, r);
                r = _mm256_mul_ps(
                    r,
                    _mm256_sub_ps(five_quarters, _mm256_mul_ps(_mm256_mul_ps(quarter_w, r2), r2)),
                );
            }
            let root = _mm256_mul_ps(w, _mm256_mul_ps(_mm256_mul_ps(r, r), r));
            _mm256_storeu_ps(lanes[0].as_mut_ptr(), _mm256_mul_ps(x, inv_l));
            _mm256_storeu_ps(lanes[1].as_mut_ptr(), _mm256_mul_ps(y, inv_l));
            _mm256_storeu_ps(lanes[2].as_mut_ptr(), _mm256_mul_ps(vd, inv_l));
            _mm256_storeu_ps(
                lanes[3].as_mut_ptr(),
                _mm256_mul_ps(_mm256_mul_ps(half, root), inv_l),
            );
            _mm256_storeu_ps(lanes[4].as_mut_ptr(), _mm256_mul_ps(near, l));
            _mm256_storeu_ps(lanes[5].as_mut_ptr(), _mm256_mul_ps(far, l));
        }
        for (i, o) in out[b * 8..b * 8 + 8].iter_mut().enumerate() {
            *o = RayGeometry {
                origin: Vec3::ZERO,
                origin_radius: 0.0,
                direction: Vec3::new(lanes[0][i], lanes[1][i], lanes[2][i]),
                ray_spread: lanes[3][i],
                min_dist: lanes[4][i],
                max_dist: lanes[5][i],
            };
        }
    }
    for i in blocks * 8..n {
        out[i] = rays.pinhole(screen[i], d);
    }
}
