//! The slab test for two boxes in one AVX2 register (x86-64 only; chosen at run time).

use core::arch::x86_64::{
    __m256, __m256i, _CMP_LE_OQ, _mm_cvtss_f32, _mm256_add_ps, _mm256_and_ps, _mm256_castsi256_ps,
    _mm256_cmp_ps, _mm256_cvtss_f32, _mm256_extractf128_ps, _mm256_load_ps, _mm256_max_ps, _mm256_min_ps,
    _mm256_movemask_ps, _mm256_mul_ps, _mm256_permute_ps, _mm256_permute2f128_ps, _mm256_permutevar8x32_ps,
    _mm256_set1_epi32, _mm256_set1_ps, _mm256_setr_epi32, _mm256_setr_ps, _mm256_sub_ps,
};

use glam::Vec3A;

use super::traverse::{BoxKernel, FAR_PAD};
use super::tree::NodePair;
use super::wide::Avx2Wide;

/// Proof that the CPU has AVX2 and FMA; only [`Avx2Kernel::detect`] makes one.
#[derive(Clone, Copy)]
pub(super) struct Avx2Kernel {
    _private: (),
}

impl Avx2Kernel {
    /// The token, when the CPU has AVX2 and FMA.
    #[inline]
    pub(super) fn detect() -> Option<Self> {
        (is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")).then_some(Self { _private: () })
    }
}

/// The AVX2 kernel's per-ray constants, laid out for both children at once.
pub(super) struct Avx2BoxRay {
    /// `[ox, oy, oz, ox]` twice: lane 3 of each half repeats x so no lane holds garbage.
    origin: __m256,
    inv_dir: __m256,
    /// Picks `[near x, near y, near z, near x | far x, far y, far z, far x]` out of a node's
    /// `[lo, first, hi, count]`.
    select: __m256i,
    t_min: __m256,
}

impl BoxKernel for Avx2Kernel {
    type Ray = Avx2BoxRay;
    type Wide = Avx2Wide;

    #[inline(always)]
    fn wide(self) -> Avx2Wide {
        Avx2Wide
    }

    #[inline(always)]
    fn prepare(self, origin: Vec3A, direction: Vec3A, t_min: f32) -> Avx2BoxRay {
        let o = origin.to_array();
        let i = (Vec3A::ONE / direction).to_array();
        let near = |k: usize, d: f32| {
            if d.is_sign_negative() {
                4 + k as i32
            } else {
                k as i32
            }
        };
        let far = |k: usize, d: f32| {
            if d.is_sign_negative() {
                k as i32
            } else {
                4 + k as i32
            }
        };
        let (dx, dy, dz) = (direction.x, direction.y, direction.z);
        // SAFETY: `self` proves AVX2 is available; these intrinsics only touch registers.
        unsafe {
            Avx2BoxRay {
                origin: _mm256_setr_ps(o[0], o[1], o[2], o[0], o[0], o[1], o[2], o[0]),
                inv_dir: _mm256_setr_ps(i[0], i[1], i[2], i[0], i[0], i[1], i[2], i[0]),
                select: _mm256_setr_epi32(
                    near(0, dx),
                    near(1, dy),
                    near(2, dz),
                    near(0, dx),
                    far(0, dx),
                    far(1, dy),
                    far(2, dz),
                    far(0, dx),
                ),
                t_min: _mm256_set1_ps(t_min),
            }
        }
    }

    /// The scalar kernel's test on both children at once (same operations, same NaN rules).
    #[inline(always)]
    fn test_pair(self, ray: &Avx2BoxRay, pair: &NodePair, t_far: f32) -> (u32, f32, f32) {
        // SAFETY: `self` proves AVX2 is available. `NodePair` is 64-byte aligned and holds two
        // 32-byte `Node`s of eight 4-byte fields each, so both aligned 8-lane loads are in bounds.
        unsafe {
            let p = pair.0.as_ptr().cast::<f32>();
            let c0 = _mm256_permutevar8x32_ps(_mm256_load_ps(p), ray.select);
            let c1 = _mm256_permutevar8x32_ps(_mm256_load_ps(p.add(8)), ray.select);
            let near = _mm256_permute2f128_ps::<0x20>(c0, c1);
            let far = _mm256_permute2f128_ps::<0x31>(c0, c1);
            let tn = _mm256_mul_ps(_mm256_sub_ps(near, ray.origin), ray.inv_dir);
            let tf = _mm256_mul_ps(_mm256_sub_ps(far, ray.origin), ray.inv_dir);
            // max/min return the second operand when either is NaN: NaN lanes drop out here.
            let tn = _mm256_max_ps(tn, ray.t_min);
            let tf = _mm256_min_ps(tf, _mm256_set1_ps(t_far));
            let tn = _mm256_max_ps(tn, _mm256_permute_ps::<0b10_11_00_01>(tn));
            let tn = _mm256_max_ps(tn, _mm256_permute_ps::<0b01_00_11_10>(tn));
            let tf = _mm256_min_ps(tf, _mm256_permute_ps::<0b10_11_00_01>(tf));
            let tf = _mm256_min_ps(tf, _mm256_permute_ps::<0b01_00_11_10>(tf));
            let abs = _mm256_and_ps(tf, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff)));
            let tf = _mm256_add_ps(tf, _mm256_mul_ps(abs, _mm256_set1_ps(FAR_PAD)));
            let bits = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32;
            let mask = (bits & 1) | ((bits >> 3) & 2);
            (
                mask,
                _mm256_cvtss_f32(tn),
                _mm_cvtss_f32(_mm256_extractf128_ps::<1>(tn)),
            )
        }
    }
}
