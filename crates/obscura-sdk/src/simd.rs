//! Run-time choice of the widest SIMD the CPU has, for the batch kernels of projections.
//!
//! A kernel is written once as a plain loop over the batch and handed to [`run`] as a closure. On
//! x86-64 with AVX2 and FMA the closure is inlined into a function compiled for those features, so the
//! loop is vectorised 8 wide; elsewhere it runs as compiled for the baseline target (SSE2 on x86-64).
//! Results are identical on both paths: Rust never contracts `a*b + c` into an FMA on its own.

use crate::{Point2, RayGeometry};

/// Runs `kernel` in the widest instruction set this CPU supports.
///
/// Mark a large kernel `#[inline(always)]` (`run(#[inline(always)] || …)`): the wide path only
/// applies to code inlined into the AVX2 trampoline, and LLVM's inliner may otherwise leave a big
/// closure as a baseline-compiled call.
#[inline(always)]
pub fn run<R>(kernel: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        if has_avx2_fma() {
            // SAFETY: the CPU supports AVX2 and FMA, checked just above.
            return unsafe { run_avx2(kernel) };
        }
    }
    kernel()
}

/// Sets every ray from its screen sample with `ray`, in the widest instruction set: the batch loop of a
/// projection whose rays depend on the screen position alone. `ray` is inlined into the loop.
#[inline(always)]
pub fn map_screen(rays: &mut [RayGeometry], screen: &[Point2], ray: impl Fn(Point2) -> RayGeometry) {
    run(
        #[inline(always)]
        || {
            for (r, s) in rays.iter_mut().zip(screen) {
                *r = ray(*s);
            }
        },
    );
}

/// True when the AVX2 + FMA path is taken on this machine.
#[must_use]
pub fn has_avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2<R>(kernel: impl FnOnce() -> R) -> R {
    kernel()
}

#[cfg(test)]
mod tests {
    #[test]
    fn both_paths_give_the_same_answer() {
        let xs: Vec<f32> = (0..1000).map(|i| i as f32 * 0.37).collect();
        let fast: Vec<f32> = super::run(|| xs.iter().map(|x| (x * x + 1.0).sqrt()).collect());
        let base: Vec<f32> = xs.iter().map(|x| (x * x + 1.0).sqrt()).collect();
        assert_eq!(fast, base);
    }
}
