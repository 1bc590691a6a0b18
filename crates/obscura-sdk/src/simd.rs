//! Run-time choice of the widest SIMD the CPU has, for the batch kernels of projections.
//!
//! A kernel is written once as a plain loop over the batch and handed to [`run`] as a closure. The
//! closure is inlined into a trampoline compiled for one of three **tiers** ([`Level`]):
//!
//! | tier | x86-64 features the trampoline is compiled with | lanes of `f32` |
//! |---|---|---|
//! | [`Level::Portable`] | the baseline target (SSE2 on x86-64; whatever the target has elsewhere) | 4 |
//! | [`Level::Avx2Fma`] | `avx2`, `fma` | 8 |
//! | [`Level::Avx512`] | `avx512f`, `avx512bw`, `avx512cd`, `avx512dq`, `avx512vl`, `avx2`, `fma` | 16 |
//!
//! [`level`] is the tier [`run`] takes: the widest the CPU has ([`Level::detected`]), capped by the
//! environment variable **`OBSCURA_SIMD`** = `portable` | `avx2` | `avx512`, read once per process (an
//! unknown value, or a tier above what the CPU has, prints a warning on stderr and keeps the detected
//! tier). [`with_level`] caps the tier for one thread and one closure (tests and benchmarks run every
//! tier in one process that way); [`run_at`] runs one kernel at a given tier. A tier the CPU lacks is
//! never run: it falls back to the widest one below it.
//!
//! **Bit identity.** Every tier gives the same bits. Rust never contracts `a*b + c` into a fused
//! multiply-add on its own, and the vectoriser only widens IEEE operations (add, mul, div, sqrt,
//! comparisons, selects), which round the same in every lane width. Hand-written kernels follow the
//! same rule: exact `div` and `sqrt` (never the `rcp`/`rsqrt` approximations), and the portable code
//! they mirror computes the same expression in the same order. A fused multiply-add is allowed only
//! where the portable code asks for it with [`f32::mul_add`] (correctly rounded everywhere: in hardware,
//! or in libm's `fmaf` on a CPU without FMA), as [`crate::optics::quarter_root`]'s Newton steps do; a
//! kernel that fuses where the portable code does not must say so and be tested to 1 ulp instead.
//!
//! Benchmarks and the tests against the portable tier: `BENCHMARKS.md` ("SIMD tiers") and the
//! `tiers_*` tests of `obscura-projections`.

use std::cell::Cell;
use std::sync::OnceLock;

use crate::{Point2, RayGeometry};

/// One tier of the run-time dispatch, narrowest first (so `a < b` means `a` is narrower).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Level {
    /// The baseline target's instruction set, no run-time features.
    Portable,
    /// AVX2 with fused multiply-add (x86-64): 256-bit vectors.
    Avx2Fma,
    /// AVX-512 F/BW/CD/DQ/VL (x86-64): 512-bit vectors with masked loads and stores.
    Avx512,
}

impl Level {
    /// The three tiers, narrowest first.
    pub const ALL: [Level; 3] = [Level::Portable, Level::Avx2Fma, Level::Avx512];

    /// The name `OBSCURA_SIMD` takes for this tier: `portable`, `avx2` or `avx512`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Level::Portable => "portable",
            Level::Avx2Fma => "avx2",
            Level::Avx512 => "avx512",
        }
    }

    /// The tier named `name` (as [`Level::name`] spells it, case-insensitive), if any.
    #[must_use]
    pub fn parse(name: &str) -> Option<Level> {
        Level::ALL
            .into_iter()
            .find(|l| l.name().eq_ignore_ascii_case(name.trim()))
    }

    /// True when this CPU can run the tier.
    #[must_use]
    pub fn is_available(self) -> bool {
        self <= Level::detected()
    }

    /// The widest tier this CPU supports (checked once per call; cheap after the first).
    #[must_use]
    pub fn detected() -> Level {
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx512f")
                && std::is_x86_feature_detected!("avx512bw")
                && std::is_x86_feature_detected!("avx512cd")
                && std::is_x86_feature_detected!("avx512dq")
                && std::is_x86_feature_detected!("avx512vl")
                && std::is_x86_feature_detected!("avx2")
                && std::is_x86_feature_detected!("fma")
            {
                return Level::Avx512;
            }
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                return Level::Avx2Fma;
            }
        }
        Level::Portable
    }
}

impl std::fmt::Display for Level {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The process-wide tier: detected, capped by `OBSCURA_SIMD` (read once).
fn process_level() -> Level {
    static LEVEL: OnceLock<Level> = OnceLock::new();
    *LEVEL.get_or_init(|| {
        let detected = Level::detected();
        match std::env::var("OBSCURA_SIMD") {
            Err(std::env::VarError::NotPresent) => detected,
            Err(std::env::VarError::NotUnicode(v)) => {
                eprintln!(
                    "obscura: OBSCURA_SIMD={v:?} is not one of portable, avx2, avx512; using {detected}"
                );
                detected
            }
            Ok(v) if v.trim().is_empty() => detected,
            Ok(v) => match Level::parse(&v) {
                Some(wanted) if wanted <= detected => wanted,
                Some(wanted) => {
                    eprintln!(
                        "obscura: OBSCURA_SIMD={v}: this CPU lacks the {wanted} tier; using {detected}"
                    );
                    detected
                }
                None => {
                    eprintln!(
                        "obscura: OBSCURA_SIMD={v:?} is not one of portable, avx2, avx512; using {detected}"
                    );
                    detected
                }
            },
        }
    })
}

thread_local! {
    /// The cap [`with_level`] sets on this thread, if any.
    static THREAD_CAP: Cell<Option<Level>> = const { Cell::new(None) };
}

/// The tier [`run`] takes on this thread: the CPU's widest, capped by `OBSCURA_SIMD` and by any
/// enclosing [`with_level`].
#[inline]
#[must_use]
pub fn level() -> Level {
    let process = process_level();
    match THREAD_CAP.with(Cell::get) {
        Some(cap) => cap.min(process),
        None => process,
    }
}

/// Runs `f` with the tier capped at `cap` on this thread (restored afterwards, also on unwinding): every
/// [`run`] inside takes `min(cap, level())`. For tests and benchmarks that compare tiers in one process.
pub fn with_level<R>(cap: Level, f: impl FnOnce() -> R) -> R {
    struct Restore(Option<Level>);
    impl Drop for Restore {
        fn drop(&mut self) {
            THREAD_CAP.with(|c| c.set(self.0));
        }
    }
    let _restore = Restore(THREAD_CAP.with(|c| c.replace(Some(cap))));
    f()
}

/// Runs `kernel` at tier `level`, or at the widest tier below it that the CPU has.
///
/// Mark a large kernel `#[inline(always)]` (`run_at(l, #[inline(always)] || …)`): the wide tiers only
/// apply to code inlined into their trampoline, and LLVM's inliner may otherwise leave a big closure as
/// a baseline-compiled call.
#[inline(always)]
pub fn run_at<R>(level: Level, kernel: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        let level = level.min(Level::detected());
        match level {
            // SAFETY: `Level::detected` found every feature of the tier on this CPU.
            Level::Avx512 => return unsafe { run_avx512(kernel) },
            // SAFETY: as above.
            Level::Avx2Fma => return unsafe { run_avx2(kernel) },
            Level::Portable => {}
        }
    }
    let _ = level;
    kernel()
}

/// Runs `kernel` at [`level`]: the widest tier this CPU supports unless capped.
///
/// Mark a large kernel `#[inline(always)]` (`run(#[inline(always)] || …)`), as for [`run_at`].
#[inline(always)]
pub fn run<R>(kernel: impl FnOnce() -> R) -> R {
    run_at(level(), kernel)
}

/// Sets every ray from its screen sample with `ray`, at [`level`]: the batch loop of a projection whose
/// rays depend on the screen position alone. `ray` is inlined into the loop.
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

/// True when [`run`] takes the AVX2 + FMA tier or a wider one on this thread.
#[must_use]
pub fn has_avx2_fma() -> bool {
    level() >= Level::Avx2Fma
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2<R>(kernel: impl FnOnce() -> R) -> R {
    kernel()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512cd,avx512dq,avx512vl,avx2,fma")]
unsafe fn run_avx512<R>(kernel: impl FnOnce() -> R) -> R {
    kernel()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kernel(xs: &[f32]) -> Vec<f32> {
        xs.iter().map(|x| (x * x + 1.0).sqrt() / (x + 3.0)).collect()
    }

    #[test]
    fn every_tier_gives_the_portable_answer() {
        let xs: Vec<f32> = (0..1000).map(|i| i as f32 * 0.37 - 100.0).collect();
        let base = kernel(&xs);
        for l in Level::ALL {
            let got: Vec<f32> = run_at(l, || kernel(&xs));
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got), bits(&base), "tier {l}");
        }
    }

    #[test]
    fn names_round_trip_and_order_is_by_width() {
        for l in Level::ALL {
            assert_eq!(Level::parse(l.name()), Some(l));
            assert_eq!(Level::parse(&l.name().to_uppercase()), Some(l));
        }
        assert_eq!(Level::parse("sse4"), None);
        assert!(Level::Portable < Level::Avx2Fma && Level::Avx2Fma < Level::Avx512);
        assert!(Level::Portable.is_available());
    }

    #[test]
    fn with_level_caps_this_thread_and_restores() {
        let outer = level();
        with_level(Level::Portable, || {
            assert_eq!(level(), Level::Portable);
            assert!(!has_avx2_fma());
            with_level(Level::Avx512, || assert!(level() <= outer));
            assert_eq!(level(), Level::Portable);
        });
        assert_eq!(level(), outer);
    }

    /// The test machines of this project have AVX-512: the tiers are not silently narrower there.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn detection_matches_the_cpu_flags() {
        let avx512 = std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512vl");
        assert_eq!(
            Level::detected() == Level::Avx512,
            avx512 && std::is_x86_feature_detected!("avx512dq")
        );
    }
}
