//! `PxrPerspective`'s pinhole and thin lens sixteen rays at a time in AVX-512.
//!
//! Each kernel is [`PerspectiveRays::pinhole`] / [`PerspectiveRays::thin_lens`] operation for operation
//! (exact `div` and `sqrt`, a fused multiply-add only where the portable code has `mul_add`,
//! [`quarter_root`]'s integer seed and Newton steps), so the rays are bit-identical to the portable
//! tier's. The screen and aperture samples are loaded 32 floats at a time and split into x and y
//! lanes with one two-source permute each; a batch whose length is not a multiple of 16 ends with
//! masked loads.
//!
//! The rays go to a [`Sink`]: [`Aos`] writes RenderMan's 40-byte `RtRayGeometry` records (two stores
//! per ray from 128-bit lanes shuffled into record order; see `store_records`); [`Soa`] writes one
//! array per field (`project_soa`, numpy's layout): each register straight to its array, ten 64-byte
//! stores per sixteen rays and no shuffle at all. Both sinks prefetch the lines they will write four
//! groups ahead ([`AHEAD`]): the renderer's batch is in L2, not L1; and the kernels prefetch their
//! samples 256 ahead ([`SAMPLES_AHEAD`]).
//!
//! [`quarter_root`]: obscura_sdk::optics::quarter_root

use std::arch::x86_64::*;

use obscura_sdk::optics::{PINHOLE_W_MAX, PerspectiveRays};
use obscura_sdk::{Point2, RayGeometry, RaysSoa, SoaFields};

/// Sixteen rays, one register per field (`origin.z` and `origin_radius` are 0 for both models).
pub(crate) struct Lanes {
    ox: __m512,
    oy: __m512,
    dx: __m512,
    dy: __m512,
    dz: __m512,
    spread: __m512,
    min: __m512,
    max: __m512,
}

/// Where a kernel puts its rays.
pub(crate) trait Sink {
    /// Stores rays `i .. i + n` (`n ≤ 16`) from lanes `0 .. n`.
    ///
    /// # Safety
    /// The CPU has AVX-512 F/VL; `i + n` is within the sink.
    unsafe fn put(&mut self, i: usize, n: usize, rays: &Lanes);

    /// False when the sink never stores `ray_spread`: the kernel then skips computing it.
    fn wants_spread(&self) -> bool {
        true
    }
}

/// The renderer's array of `RtRayGeometry` records.
pub(crate) struct Aos<'a>(pub &'a mut [RayGeometry]);

impl Sink for Aos<'_> {
    #[inline(always)]
    unsafe fn put(&mut self, i: usize, n: usize, rays: &Lanes) {
        if n == 16 {
            prefetch_lines(self.0.as_ptr().wrapping_add(i + AHEAD).cast(), 10);
            // SAFETY: 16 records from `i` are in the slice (the caller's promise).
            unsafe { store_records(self.0.as_mut_ptr().add(i).cast(), rays) };
        } else {
            let mut tail = [RayGeometry::CULLED; 16];
            // SAFETY: `tail` holds 16 records.
            unsafe { store_records(tail.as_mut_ptr().cast(), rays) };
            self.0[i..i + n].copy_from_slice(&tail[..n]);
        }
    }
}

/// The ten arrays of a [`RaysSoa`], field `k` of ray `i` at `fields[k] + i`; only the fields in
/// `wanted` are stored ([`obscura_sdk::SoaContext::fields`]).
pub(crate) struct Soa<'a> {
    fields: [*mut f32; 10],
    wanted: SoaFields,
    len: usize,
    _rays: std::marker::PhantomData<&'a mut [f32]>,
}

impl<'a> Soa<'a> {
    /// The arrays of `rays`, borrowed for as long as the sink lives.
    pub(crate) fn new(rays: &'a mut RaysSoa<'_>, wanted: SoaFields) -> Self {
        let len = rays.len();
        Soa {
            fields: rays.fields_mut().map(<[f32]>::as_mut_ptr),
            wanted,
            len,
            _rays: std::marker::PhantomData,
        }
    }
}

impl Sink for Soa<'_> {
    #[inline(always)]
    unsafe fn put(&mut self, i: usize, n: usize, r: &Lanes) {
        debug_assert!(i + n <= self.len);
        // SAFETY: every array holds `len ≥ i + n` floats (`RaysSoa` checks the ten lengths agree);
        // a masked store touches lanes `0 .. n` only.
        unsafe {
            let zero = _mm512_setzero_ps();
            let values = [r.ox, r.oy, zero, zero, r.dx, r.dy, r.dz, r.spread, r.min, r.max];
            for (k, (field, v)) in self.fields.iter().zip(values).enumerate() {
                if !self.wanted.has(k) {
                    continue;
                }
                if n == 16 {
                    prefetch_lines(field.wrapping_add(i + AHEAD), 1);
                    _mm512_storeu_ps(field.add(i), v);
                } else {
                    _mm512_mask_storeu_ps(field.add(i), mask(n), v);
                }
            }
        }
    }

    fn wants_spread(&self) -> bool {
        self.wanted.contains(SoaFields::RAY_SPREAD)
    }
}

/// Sixteen 40-byte records `[O.x, O.y, O.z, r, D.x, D.y, D.z, spread, min, max]` at `out`.
///
/// Within each 128-bit lane `j` of the registers, unpacks gather ray `4j + k`'s `(O.x, O.y, 0, 0)`,
/// `(D, spread)` and `(min, max)`; one two-source permute per pair of rays joins origin and direction
/// into a 32-byte store (bytes 0–31), and a masked 16-byte store puts the `(min, max)` pair at bytes
/// 32–39: two stores per ray (the store port, not the arithmetic, bounded the three-store version).
#[inline(always)]
unsafe fn store_records(out: *mut f32, r: &Lanes) {
    // SAFETY: only inlined into the kernels, which have AVX-512 F/VL; the stores are the caller's.
    unsafe {
        let zero = _mm512_setzero_ps();
        let dxy_lo = _mm512_unpacklo_ps(r.dx, r.dy);
        let dxy_hi = _mm512_unpackhi_ps(r.dx, r.dy);
        let zs_lo = _mm512_unpacklo_ps(r.dz, r.spread);
        let zs_hi = _mm512_unpackhi_ps(r.dz, r.spread);
        let dir = [
            _mm512_castpd_ps(_mm512_unpacklo_pd(
                _mm512_castps_pd(dxy_lo),
                _mm512_castps_pd(zs_lo),
            )),
            _mm512_castpd_ps(_mm512_unpackhi_pd(
                _mm512_castps_pd(dxy_lo),
                _mm512_castps_pd(zs_lo),
            )),
            _mm512_castpd_ps(_mm512_unpacklo_pd(
                _mm512_castps_pd(dxy_hi),
                _mm512_castps_pd(zs_hi),
            )),
            _mm512_castpd_ps(_mm512_unpackhi_pd(
                _mm512_castps_pd(dxy_hi),
                _mm512_castps_pd(zs_hi),
            )),
        ];
        let oxy_lo = _mm512_unpacklo_ps(r.ox, r.oy);
        let oxy_hi = _mm512_unpackhi_ps(r.ox, r.oy);
        let origin = [
            _mm512_castpd_ps(_mm512_unpacklo_pd(
                _mm512_castps_pd(oxy_lo),
                _mm512_castps_pd(zero),
            )),
            _mm512_castpd_ps(_mm512_unpackhi_pd(
                _mm512_castps_pd(oxy_lo),
                _mm512_castps_pd(zero),
            )),
            _mm512_castpd_ps(_mm512_unpacklo_pd(
                _mm512_castps_pd(oxy_hi),
                _mm512_castps_pd(zero),
            )),
            _mm512_castpd_ps(_mm512_unpackhi_pd(
                _mm512_castps_pd(oxy_hi),
                _mm512_castps_pd(zero),
            )),
        ];
        // Lane j, element pairs: rays 4j, 4j+1 in `clip[0]`, rays 4j+2, 4j+3 in `clip[1]`.
        let clip = [_mm512_unpacklo_ps(r.min, r.max), _mm512_unpackhi_ps(r.min, r.max)];
        // `[O, D]` of rays k and 4 + k (lanes 0 and 1 of `origin[k]`, `dir[k]`), and of 8 + k and
        // 12 + k (lanes 2 and 3): one two-source permute per pair of rays, then a 32-byte store each.
        const LO: [i32; 16] = [0, 1, 2, 3, 16, 17, 18, 19, 4, 5, 6, 7, 20, 21, 22, 23];
        const HI: [i32; 16] = [8, 9, 10, 11, 24, 25, 26, 27, 12, 13, 14, 15, 28, 29, 30, 31];
        let (lo, hi) = (
            _mm512_loadu_si512(LO.as_ptr().cast()),
            _mm512_loadu_si512(HI.as_ptr().cast()),
        );
        for k in 0..4 {
            let rec = |ray: usize| out.add(10 * ray);
            let p = _mm512_permutex2var_ps(origin[k], lo, dir[k]);
            let q = _mm512_permutex2var_ps(origin[k], hi, dir[k]);
            _mm256_storeu_ps(rec(k), _mm512_castps512_ps256(p));
            _mm256_storeu_ps(rec(4 + k), _mm512_extractf32x8_ps::<1>(p));
            _mm256_storeu_ps(rec(8 + k), _mm512_castps512_ps256(q));
            _mm256_storeu_ps(rec(12 + k), _mm512_extractf32x8_ps::<1>(q));
        }
        // `(min, max)` of ray 4j + k: lane j of `clip[k / 2]`, elements 0–1 (k even) or 2–3 (k odd),
        // a masked store that writes floats 8–9 of the record only.
        macro_rules! lane {
            ($j:literal) => {
                for k in 0..4 {
                    let rec = out.add(10 * (4 * $j + k));
                    let c = _mm512_extractf32x4_ps::<$j>(clip[k / 2]);
                    if k % 2 == 0 {
                        _mm_mask_storeu_ps(rec.add(8), 0b0011, c);
                    } else {
                        _mm_mask_storeu_ps(rec.add(6), 0b1100, c);
                    }
                }
            };
        }
        lane!(0);
        lane!(1);
        lane!(2);
        lane!(3);
    }
}

/// Sixteen records at `out` from a centred camera's structure-of-arrays lanes (`d`: direction x, y, z
/// and spread; `clipping`: `min_dist`, `max_dist`; origin and origin radius 0): the write-out of
/// [`crate::screen::map_centred_rays`] at the AVX-512 tier, `store_records` and the output prefetch of
/// the perspective kernels in place of four SSE transposes.
///
/// # Safety
/// The CPU has AVX-512 F/BW/CD/DQ/VL (the caller's tier is [`obscura_sdk::simd::Level::Avx512`]); `out`
/// points at 16 writable records.
#[target_feature(enable = "avx512f,avx512bw,avx512cd,avx512dq,avx512vl,avx2,fma")]
pub(crate) unsafe fn store_centred_records(
    out: *mut RayGeometry,
    d: &[[f32; 16]; 4],
    clipping: &[[f32; 16]; 2],
) {
    prefetch_lines(out.wrapping_add(AHEAD).cast_const().cast(), 10);
    let load = |a: &[f32; 16]| {
        // SAFETY: sixteen floats from a reference to sixteen.
        unsafe { _mm512_loadu_ps(a.as_ptr()) }
    };
    let zero = _mm512_setzero_ps();
    let lanes = Lanes {
        ox: zero,
        oy: zero,
        dx: load(&d[0]),
        dy: load(&d[1]),
        dz: load(&d[2]),
        spread: load(&d[3]),
        min: load(&clipping[0]),
        max: load(&clipping[1]),
    };
    // SAFETY: `out` holds 16 records (the caller's promise).
    unsafe { store_records(out.cast(), &lanes) };
}

/// How many rays ahead of the one being stored the sinks prefetch their output: four groups of 16.
///
/// The renderer's batch (4096 rays, 160 KB of records) lives in L2, not L1, and a store that misses L1
/// waits in the store buffer for its line; fetching the lines four groups ahead takes that wait off the
/// kernel (on the Xeon of BENCHMARKS.md the pinhole's `project_soa` went from about 630 to 900 Mrays/s).
const AHEAD: usize = 64;

/// How many samples ahead of the group being computed the kernels prefetch their screen and aperture
/// samples: 256 (2 KB of each). A batch cut from a frame's samples streams them from memory, and with
/// this prefetch on top of the hardware's the pinhole's and the thin lens's `project` ran 11 % faster
/// (`project_rate`; 128 and 512–1024 ahead measured 1–5 % below 256).
const SAMPLES_AHEAD: usize = 256;

/// Prefetches the two cache lines of samples `i + SAMPLES_AHEAD ..` (16 points) of `samples`.
#[inline(always)]
fn prefetch_samples(samples: &[Point2], i: usize) {
    prefetch_lines(samples.as_ptr().wrapping_add(i + SAMPLES_AHEAD).cast(), 2);
}

/// Prefetches `lines` cache lines from `p` into L1. `p` may lie past the end of the output (the last
/// groups' lines): a prefetch never faults, and the address is only formed with wrapping arithmetic.
#[inline(always)]
fn prefetch_lines(p: *const f32, lines: usize) {
    for k in 0..lines {
        // SAFETY: a prefetch is a hint; it reads nothing the program sees and cannot fault.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(16 * k).cast()) };
    }
}

/// The mask of the first `n ≤ 16` lanes.
#[inline(always)]
fn mask(n: usize) -> __mmask16 {
    if n >= 16 { 0xFFFF } else { ((1u32 << n) - 1) as u16 }
}

/// Loads up to 16 points (`n` of them) as x and y lanes; missing lanes are 0.
#[inline(always)]
unsafe fn load_points(p: *const Point2, n: usize) -> (__m512, __m512) {
    const EVEN: [i32; 16] = [0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30];
    const ODD: [i32; 16] = [1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31];
    let f = p.cast::<f32>();
    // SAFETY: `n` points (2n floats) from `p` are readable; masked lanes are not touched.
    unsafe {
        let (a, b) = if n == 16 {
            (_mm512_loadu_ps(f), _mm512_loadu_ps(f.add(16)))
        } else {
            (
                _mm512_maskz_loadu_ps(mask((2 * n).min(16)), f),
                _mm512_maskz_loadu_ps(mask((2 * n).saturating_sub(16)), f.add(16)),
            )
        };
        (
            _mm512_permutex2var_ps(a, _mm512_loadu_si512(EVEN.as_ptr().cast()), b),
            _mm512_permutex2var_ps(a, _mm512_loadu_si512(ODD.as_ptr().cast()), b),
        )
    }
}

/// [`obscura_sdk::optics::quarter_root`] in sixteen lanes, the same operations in the same order.
#[inline(always)]
unsafe fn quarter_root(w: __m512) -> __m512 {
    // SAFETY: only inlined into the kernels, which have AVX-512 F.
    unsafe {
        let seed = _mm512_set1_epi32(obscura_sdk::optics::QUARTER_ROOT_SEED as i32);
        let quarter_w = _mm512_mul_ps(_mm512_set1_ps(0.25), w);
        let mut r = _mm512_castsi512_ps(_mm512_sub_epi32(
            seed,
            _mm512_srli_epi32::<2>(_mm512_castps_si512(w)),
        ));
        let five_quarters = _mm512_set1_ps(1.25);
        for _ in 0..3 {
            let r2 = _mm512_mul_ps(r, r);
            r = _mm512_fnmadd_ps(
                _mm512_mul_ps(quarter_w, r2),
                _mm512_mul_ps(r2, r),
                _mm512_mul_ps(five_quarters, r),
            );
        }
        _mm512_mul_ps(_mm512_mul_ps(w, r), _mm512_mul_ps(r, r))
    }
}

/// `(sx² + d², sy² + d², L²)` with `L² = (sx² + sy²) + d²`, in that order of additions.
#[inline(always)]
unsafe fn squares(x: __m512, y: __m512, d2: __m512) -> (__m512, __m512, __m512) {
    // SAFETY: only inlined into the kernels, which have AVX-512 F.
    unsafe {
        let sx2 = _mm512_mul_ps(x, x);
        let sy2 = _mm512_mul_ps(y, y);
        (
            _mm512_add_ps(sx2, d2),
            _mm512_add_ps(sy2, d2),
            _mm512_add_ps(_mm512_add_ps(sx2, sy2), d2),
        )
    }
}

/// `W = min(((sx² + d²)·(1/d²))·((sy² + d²)·(1/d²)), 2¹²⁰)`, the footprint's fourth-root argument of
/// [`PerspectiveRays::pinhole`]; `min_ps` returns its second operand for a NaN, as `f32::min` does.
#[inline(always)]
unsafe fn footprint_w(a: __m512, b: __m512, inv_d2: __m512) -> __m512 {
    // SAFETY: only inlined into the kernels, which have AVX-512 F.
    unsafe {
        _mm512_min_ps(
            _mm512_mul_ps(_mm512_mul_ps(a, inv_d2), _mm512_mul_ps(b, inv_d2)),
            _mm512_set1_ps(PINHOLE_W_MAX),
        )
    }
}

/// Software pipelining: `front` of the group of up to 16 samples at `i + n` runs before `back` of the
/// group at `i`, so the long-latency chain of one group (`sqrt`, `div`, the fourth root) is already
/// under way while the previous group's rays are assembled and stored. Without it the scheduler filled
/// with the chain's waiting operations and the stores waited behind them (pinhole `project` +12 %).
/// The last `front` is of an empty group (`n = 0`: masked loads that read nothing).
#[inline(always)]
fn pipelined<T: Copy>(len: usize, front: impl Fn(usize, usize) -> T, mut back: impl FnMut(usize, usize, T)) {
    let mut i = 0;
    let mut n = len.min(16);
    let mut cur = front(0, n);
    while i < len {
        let (next_i, next_n) = (i + n, (len - i - n).min(16));
        let next = front(next_i, next_n);
        back(i, n, cur);
        (i, n, cur) = (next_i, next_n, next);
    }
}

/// [`PerspectiveRays::pinhole`] over a batch, into `sink`.
///
/// # Safety
/// The CPU has AVX-512 F/BW/CD/DQ/VL; `sink` holds `screen.len()` rays.
#[target_feature(enable = "avx512f,avx512bw,avx512cd,avx512dq,avx512vl,avx2,fma")]
pub(crate) unsafe fn pinhole(rays: &PerspectiveRays, screen: &[Point2], d: f32, sink: &mut impl Sink) {
    let (vd, d2, inv_d2) = (
        _mm512_set1_ps(d),
        _mm512_set1_ps(d * d),
        _mm512_set1_ps(1.0 / (d * d)),
    );
    let (half_d, near, far) = (
        _mm512_set1_ps(rays.half_pixel * d),
        _mm512_set1_ps(rays.near / d),
        _mm512_set1_ps(rays.far / d),
    );
    let one = _mm512_set1_ps(1.0);
    let zero = _mm512_setzero_ps();
    let spread_on = sink.wants_spread();
    let len = screen.len();
    // The long-latency part of group `i` (`sqrt`, `div`, the fourth root), started one group early.
    let front = |i: usize, n: usize| {
        prefetch_samples(screen, i);
        // SAFETY: points i .. i + n exist (n = 0 reads nothing).
        let (x, y) = unsafe { load_points(screen.as_ptr().add(i), n) };
        // SAFETY: this kernel has the features the helper's intrinsics need.
        let (a, b, l2) = unsafe { squares(x, y, d2) };
        let l = _mm512_sqrt_ps(l2);
        let inv_l = _mm512_div_ps(one, l);
        let q = if spread_on {
            // SAFETY: as for `squares`.
            unsafe { quarter_root(footprint_w(a, b, inv_d2)) }
        } else {
            zero
        };
        (x, y, l, inv_l, q)
    };
    pipelined(len, front, |i, n, (x, y, l, inv_l, q)| {
        let spread = if spread_on {
            _mm512_mul_ps(q, _mm512_mul_ps(half_d, _mm512_mul_ps(inv_l, inv_l)))
        } else {
            zero
        };
        let lanes = Lanes {
            ox: zero,
            oy: zero,
            dx: _mm512_mul_ps(x, inv_l),
            dy: _mm512_mul_ps(y, inv_l),
            dz: _mm512_mul_ps(vd, inv_l),
            spread,
            min: _mm512_mul_ps(near, l),
            max: _mm512_mul_ps(far, l),
        };
        // SAFETY: the sink holds rays i .. i + n.
        unsafe { sink.put(i, n, &lanes) };
    });
}

/// [`PerspectiveRays::thin_lens`] over a batch, into `sink`.
///
/// # Safety
/// The CPU has AVX-512 F/BW/CD/DQ/VL; `aperture` and `sink` hold `screen.len()` samples and rays.
#[target_feature(enable = "avx512f,avx512bw,avx512cd,avx512dq,avx512vl,avx2,fma")]
pub(crate) unsafe fn thin_lens(
    rays: &PerspectiveRays,
    screen: &[Point2],
    aperture: &[Point2],
    d: f32,
    sink: &mut impl Sink,
) {
    let f = rays.focal_distance;
    let k = f / d;
    let (vk, vf, f2, d2, inv_d2) = (
        _mm512_set1_ps(k),
        _mm512_set1_ps(f),
        _mm512_set1_ps(f * f),
        _mm512_set1_ps(d * d),
        _mm512_set1_ps(1.0 / (d * d)),
    );
    let (half_kd, near, far, radius) = (
        _mm512_set1_ps(rays.half_pixel * k * d),
        _mm512_set1_ps(rays.near / f),
        _mm512_set1_ps(rays.far / f),
        _mm512_set1_ps(rays.lens_radius),
    );
    let one = _mm512_set1_ps(1.0);
    let spread_on = sink.wants_spread();
    let len = screen.len().min(aperture.len());
    let mut i = 0;
    while i < len {
        let n = (len - i).min(16);
        prefetch_samples(screen, i);
        prefetch_samples(aperture, i);
        // SAFETY: samples i .. i + n exist in both.
        let ((x, y), (ax, ay)) = unsafe {
            (
                load_points(screen.as_ptr().add(i), n),
                load_points(aperture.as_ptr().add(i), n),
            )
        };
        // SAFETY: this kernel has the features the helper's intrinsics need.
        let (a, b, l2) = unsafe { squares(x, y, d2) };
        let (ox, oy) = (_mm512_mul_ps(radius, ax), _mm512_mul_ps(radius, ay));
        let tx = _mm512_sub_ps(_mm512_mul_ps(x, vk), ox);
        let ty = _mm512_sub_ps(_mm512_mul_ps(y, vk), oy);
        let t2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(tx, tx), _mm512_mul_ps(ty, ty)), f2);
        let t = _mm512_sqrt_ps(t2);
        let l = _mm512_sqrt_ps(l2);
        let inv_lt = _mm512_div_ps(one, _mm512_mul_ps(l, t));
        let inv_t = _mm512_mul_ps(l, inv_lt);
        let spread = if spread_on {
            let scale = _mm512_mul_ps(half_kd, inv_lt);
            // SAFETY: as for `squares`.
            _mm512_mul_ps(unsafe { quarter_root(footprint_w(a, b, inv_d2)) }, scale)
        } else {
            _mm512_setzero_ps()
        };
        let lanes = Lanes {
            ox,
            oy,
            dx: _mm512_mul_ps(tx, inv_t),
            dy: _mm512_mul_ps(ty, inv_t),
            dz: _mm512_mul_ps(vf, inv_t),
            spread,
            min: _mm512_mul_ps(near, t),
            max: _mm512_mul_ps(far, t),
        };
        // SAFETY: the sink holds rays i .. i + n.
        unsafe { sink.put(i, n, &lanes) };
        i += n;
    }
}
