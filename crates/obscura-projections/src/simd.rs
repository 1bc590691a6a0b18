//! Run-time choice of the widest SIMD the CPU has, for the batch kernels.
//!
//! A kernel is written once as a plain loop over the batch and handed to [`run`] as a closure, which
//! inlines it into a trampoline for the widest tier ([`Level`]) the CPU has — AVX-512 (16 lanes),
//! AVX2 + FMA (8 lanes) or the baseline target — capped by `OBSCURA_SIMD`. Every tier gives the same
//! bits (see [`obscura_sdk::simd`] for the policy).
//!
//! The implementation lives in the SDK ([`obscura_sdk::simd`]) so every crate of projections
//! (`obscura-calibration` too) shares it; this module re-exports it under its old path.

pub use obscura_sdk::simd::*;
