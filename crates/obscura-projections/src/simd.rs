//! Run-time choice of the widest SIMD the CPU has, for the batch kernels.
//!
//! A kernel is written once as a plain loop over the batch and handed to [`run`] as a closure. On
//! x86-64 with AVX2 and FMA the closure is inlined into a function compiled for those features, so the
//! loop is vectorised 8 wide; elsewhere it runs as compiled for the baseline target (SSE2 on x86-64).
//! Results are identical on both paths: Rust never contracts `a*b + c` into an FMA on its own.
//!
//! The implementation lives in the SDK ([`obscura_sdk::simd`]) so every crate of projections
//! (`obscura-calibration` too) shares it; this module re-exports it under its old path.

pub use obscura_sdk::simd::*;
