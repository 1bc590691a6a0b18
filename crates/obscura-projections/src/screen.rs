//! What every projection does with the host's screen samples before its own mapping: walk the batch
//! (each ray from its screen sample `s = (sx, sy)`, and its aperture sample `a` where a lens needs one)
//! in the vectorised loop of [`crate::simd`], and size the footprint by the pixel of the image format
//! over the screen window, `Δx = (r − l)/W`, `Δy = (t − b)/H` screen units.
//!
//! The centred panoramas (every [`CentredLane`] camera) also write their rays one array per field
//! ([`map_centred_rays_soa`], their `project_soa`): the lanes are already structure-of-arrays, so
//! that path is one vectorised loop storing each field where it belongs, with no write-out.
//!
//! Window coordinates `u, v ∈ [−1, 1]`, the panoramas' normalised form of `s`, are
//! [`crate::panorama::SweepWindow`]'s.

use obscura_sdk::{Point2, ProjectionContext, ProjectionEnvironment, RayGeometry, RaysSoa, SoaContext};

use crate::panorama::{CentredLane, SphericalClip};

use crate::simd;

/// Half the geometric mean of one pixel of `env` in screen units, `½·sqrt(Δx·Δy)`: the factor every
/// footprint `ray_spread = ½·sqrt(αx·αy)` takes out of the per-pixel turns.
#[must_use]
pub fn half_pixel(env: &ProjectionEnvironment) -> f32 {
    let (dx, dy) = env.pixel_size();
    0.5 * (dx * dy).sqrt()
}

/// A hundredth of the smaller pixel side of `env`, in screen units: how close to a rim where a radial
/// map's derivative is infinite the footprint still follows it ([`crate::panorama::rim_cos_floor`]).
#[must_use]
pub fn rim_step(env: &ProjectionEnvironment) -> f64 {
    let (dx, dy) = env.pixel_size();
    0.01 * f64::from(dx.min(dy))
}

/// `project` for a camera whose ray depends on the screen sample alone: `rays[i] = ray(screen[i])`.
#[inline(always)]
pub fn map_rays(ctx: &mut ProjectionContext<'_>, ray: impl Fn(Point2) -> RayGeometry) {
    let c = ctx.parts_mut();
    simd::map_screen(c.rays, c.screen, ray);
}

/// Lanes per chunk of [`map_centred_rays`]: a multiple of every tier's `f32` width (4, 8 and 16).
pub const LANES: usize = 16;

/// `project` for a camera whose rays leave its centre and depend on the screen sample alone, given as
/// a branch-free `lane` ([`CentredLane`]): `rays[i] = clip.lane_ray(lane(screen[i]))`.
///
/// Structure-of-arrays, a chunk of [`LANES`] samples at a time, at the widest SIMD tier: the samples'
/// coordinates into two arrays, `lane` of every sample into five (a loop LLVM vectorises: no
/// branches, no calls), then the 40-byte records. Written as one loop over the records, the
/// interleaved stores and the culling branch keep LLVM's vectoriser away and every ray is computed
/// one at a time. The tail of a batch that is not a multiple of [`LANES`] runs the same `lane` one
/// sample at a time; the bits are the same either way (IEEE operations only, never contracted into
/// fused multiply-adds).
#[inline(always)]
pub fn map_centred_rays(
    ctx: &mut ProjectionContext<'_>,
    clip: SphericalClip,
    lane: impl Fn(Point2) -> CentredLane,
) {
    let c = ctx.parts_mut();
    let (rays, screen) = (c.rays, c.screen);
    simd::run(
        #[inline(always)]
        move || centred_lanes(rays, screen, clip, lane),
    );
}

/// The loop of [`map_centred_rays`], inlined into the tier's trampoline.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lockstep loops over several lane arrays vectorise
fn centred_lanes(
    rays: &mut [RayGeometry],
    screen: &[Point2],
    clip: SphericalClip,
    lane: impl Fn(Point2) -> CentredLane,
) {
    let n = rays.len().min(screen.len());
    let (rays, screen) = (&mut rays[..n], &screen[..n]);
    let mut out_chunks = rays.chunks_exact_mut(LANES);
    let mut in_chunks = screen.chunks_exact(LANES);
    // Direction and spread, then the clipping distances, of every lane: the culled ray's values where
    // the lane is not valid (so the write-out only moves data).
    let mut d = [[0.0f32; LANES]; 4];
    let mut clipping = [[0.0f32; LANES]; 2];
    let culled = RayGeometry::CULLED;
    // The AVX-512 tier writes the records with the perspective kernels' write-out (this closure runs
    // inside `simd::run`, which took the tier `simd::level()` names).
    #[cfg(target_arch = "x86_64")]
    let widest = simd::level() == simd::Level::Avx512;
    for (out, s) in (&mut out_chunks).zip(&mut in_chunks) {
        let sx: [f32; LANES] = std::array::from_fn(|i| s[i].x);
        let sy: [f32; LANES] = std::array::from_fn(|i| s[i].y);
        for i in 0..LANES {
            let l = lane(Point2::new(sx[i], sy[i]));
            let v = l.valid;
            d[0][i] = if v { l.direction.x } else { culled.direction.x };
            d[1][i] = if v { l.direction.y } else { culled.direction.y };
            d[2][i] = if v { l.direction.z } else { culled.direction.z };
            d[3][i] = if v { l.ray_spread } else { culled.ray_spread };
            clipping[0][i] = if v { clip.near } else { culled.min_dist };
            clipping[1][i] = if v { clip.far } else { culled.max_dist };
        }
        #[cfg(target_arch = "x86_64")]
        if widest {
            // SAFETY: `simd::level()` is never above the CPU's tier, so the CPU has AVX-512; `out` is
            // a chunk of LANES = 16 records.
            unsafe { crate::perspective::store_centred_records(out.as_mut_ptr(), &d, &clipping) };
            continue;
        }
        write_centred(out, &d, &clipping);
    }
    for (r, s) in out_chunks.into_remainder().iter_mut().zip(in_chunks.remainder()) {
        *r = clip.lane_ray(lane(*s));
    }
}

/// Writes [`LANES`] records from structure-of-arrays lanes: origin and origin radius zero, direction and
/// spread from `d`, the clipping distances from `clipping`.
#[inline(always)]
fn write_centred(out: &mut [RayGeometry], d: &[[f32; LANES]; 4], clipping: &[[f32; LANES]; 2]) {
    assert_eq!(out.len(), LANES);
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            _MM_TRANSPOSE4_PS, _mm_castps_si128, _mm_loadu_ps, _mm_setzero_ps, _mm_storeu_ps,
            _mm_storeu_si64, _mm_unpackhi_epi64, _mm_unpackhi_ps, _mm_unpacklo_ps,
        };
        // Four lanes at a time: a 4×4 transpose turns the four arrays of direction and spread into four
        // records' middle 16 bytes; interleaving the two clipping arrays gives their last 8. Three stores
        // per record (SSE2, part of the x86-64 baseline, so every tier runs it), moving bits unchanged.
        let base = out.as_mut_ptr().cast::<f32>();
        for g in (0..LANES).step_by(4) {
            // SAFETY: `g + 4 ≤ LANES`, the length of every lane array, so the unaligned 16-byte loads
            // stay inside them. `out` holds LANES records of ten `f32`s (`RayGeometry` is `repr(C)`,
            // 40 bytes, no padding): record `g + k` occupies floats `10(g + k) … 10(g + k) + 9` of
            // `base`, and the stores below write floats 0–3, 4–7 and 8–9 of it, inside `out`, which
            // is borrowed mutably here; unaligned stores need no alignment.
            unsafe {
                let mut r0 = _mm_loadu_ps(d[0].as_ptr().add(g));
                let mut r1 = _mm_loadu_ps(d[1].as_ptr().add(g));
                let mut r2 = _mm_loadu_ps(d[2].as_ptr().add(g));
                let mut r3 = _mm_loadu_ps(d[3].as_ptr().add(g));
                _MM_TRANSPOSE4_PS(&mut r0, &mut r1, &mut r2, &mut r3);
                let near = _mm_loadu_ps(clipping[0].as_ptr().add(g));
                let far = _mm_loadu_ps(clipping[1].as_ptr().add(g));
                // [near, far] of lanes g, g + 1 in `lo`, of g + 2, g + 3 in `hi`.
                let lo = _mm_castps_si128(_mm_unpacklo_ps(near, far));
                let hi = _mm_castps_si128(_mm_unpackhi_ps(near, far));
                let zero = _mm_setzero_ps();
                let record = |k: usize| base.add(10 * (g + k));
                for (k, middle) in [r0, r1, r2, r3].into_iter().enumerate() {
                    _mm_storeu_ps(record(k), zero);
                    _mm_storeu_ps(record(k).add(4), middle);
                }
                _mm_storeu_si64(record(0).add(8).cast::<u8>(), lo);
                _mm_storeu_si64(record(1).add(8).cast::<u8>(), _mm_unpackhi_epi64(lo, lo));
                _mm_storeu_si64(record(2).add(8).cast::<u8>(), hi);
                _mm_storeu_si64(record(3).add(8).cast::<u8>(), _mm_unpackhi_epi64(hi, hi));
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    for (i, r) in out.iter_mut().enumerate() {
        *r = RayGeometry {
            origin: obscura_sdk::Vec3::ZERO,
            origin_radius: 0.0,
            direction: obscura_sdk::Vec3::new(d[0][i], d[1][i], d[2][i]),
            ray_spread: d[3][i],
            min_dist: clipping[0][i],
            max_dist: clipping[1][i],
        };
    }
}

/// `project_soa` of a camera that [`map_centred_rays`] serves: the same rays, bit for bit, written one
/// array per field ([`RaysSoa`]). Always returns `true` (every field of every ray is written).
///
/// No chunks and no write-out: the loop computes `lane` for each sample and stores its direction,
/// spread and clipping distances (the culled ray's where the lane is not valid) straight into the
/// arrays, and zero into the origin and origin radius. Each store is a contiguous run of one field,
/// so LLVM vectorises the loop at the tier's width as it is; the tail needs no scalar loop of its own.
#[inline(always)]
pub fn map_centred_rays_soa(
    ctx: &mut SoaContext<'_>,
    clip: SphericalClip,
    lane: impl Fn(Point2) -> CentredLane,
) -> bool {
    let screen = ctx.screen;
    let rays = &mut ctx.rays;
    simd::run(
        #[inline(always)]
        move || centred_lanes_soa(rays, screen, clip, lane),
    );
    true
}

/// The loop of [`map_centred_rays_soa`], inlined into the tier's trampoline.
#[inline(always)]
fn centred_lanes_soa(
    rays: &mut RaysSoa<'_>,
    screen: &[Point2],
    clip: SphericalClip,
    lane: impl Fn(Point2) -> CentredLane,
) {
    let n = rays.len().min(screen.len());
    let culled = RayGeometry::CULLED;
    let [ox, oy, oz, radius, dx, dy, dz, spread, min, max] = rays.fields_mut();
    let (ox, oy, oz, radius) = (&mut ox[..n], &mut oy[..n], &mut oz[..n], &mut radius[..n]);
    let (dx, dy, dz, spread) = (&mut dx[..n], &mut dy[..n], &mut dz[..n], &mut spread[..n]);
    let (min, max, screen) = (&mut min[..n], &mut max[..n], &screen[..n]);
    for i in 0..n {
        let l = lane(screen[i]);
        let v = l.valid;
        ox[i] = 0.0;
        oy[i] = 0.0;
        oz[i] = 0.0;
        radius[i] = 0.0;
        dx[i] = if v { l.direction.x } else { culled.direction.x };
        dy[i] = if v { l.direction.y } else { culled.direction.y };
        dz[i] = if v { l.direction.z } else { culled.direction.z };
        spread[i] = if v { l.ray_spread } else { culled.ray_spread };
        min[i] = if v { clip.near } else { culled.min_dist };
        max[i] = if v { clip.far } else { culled.max_dist };
    }
}

/// Writes `ray(i)` as ray `i` of `rays` for every `i < n`, field by field (`project_soa` of a
/// camera whose rays are computed one at a time). Inline it into a [`simd::run`] kernel: the loop has
/// no branches of its own, so LLVM widens it where `ray` allows.
#[inline(always)]
pub fn write_soa(rays: &mut RaysSoa<'_>, n: usize, ray: impl Fn(usize) -> RayGeometry) {
    let [ox, oy, oz, radius, dx, dy, dz, spread, min, max] = rays.fields_mut();
    let (ox, oy, oz, radius) = (&mut ox[..n], &mut oy[..n], &mut oz[..n], &mut radius[..n]);
    let (dx, dy, dz, spread) = (&mut dx[..n], &mut dy[..n], &mut dz[..n], &mut spread[..n]);
    let (min, max) = (&mut min[..n], &mut max[..n]);
    for i in 0..n {
        let r = ray(i);
        ox[i] = r.origin.x;
        oy[i] = r.origin.y;
        oz[i] = r.origin.z;
        radius[i] = r.origin_radius;
        dx[i] = r.direction.x;
        dy[i] = r.direction.y;
        dz[i] = r.direction.z;
        spread[i] = r.ray_spread;
        min[i] = r.min_dist;
        max[i] = r.max_dist;
    }
}

/// `project` for a camera whose ray depends on the screen and aperture samples:
/// `rays[i] = ray(screen[i], aperture[i])`.
#[inline(always)]
pub fn map_rays_with_aperture(ctx: &mut ProjectionContext<'_>, ray: impl Fn(Point2, Point2) -> RayGeometry) {
    let c = ctx.parts_mut();
    // Inlined into the wide trampoline with `ray` moved in: behind a call, or calling `ray` through a
    // reference, the loop stays baseline code (a thin lens ran four times slower).
    simd::run(
        #[inline(always)]
        move || {
            for ((r, s), a) in c.rays.iter_mut().zip(c.screen).zip(c.aperture) {
                *r = ray(*s, *a);
            }
        },
    );
}

#[cfg(test)]
mod tests {
    use obscura_sdk::simd::{Level, with_level};
    use obscura_sdk::{Format, Point2, ProjectionFactory, RayGeometry, ScreenWindow};
    use proptest::prelude::*;

    use crate::testing::{angle, make, project_points};

    /// The panoramas whose batch runs [`super::map_centred_rays`], one configuration per branch of
    /// their lanes (360° and narrower sweeps, every fisheye law with and without a ring, both mirror-ball
    /// orientations).
    /// A panorama of the tests: label, factory, parameters.
    type Panorama = (
        &'static str,
        Box<dyn ProjectionFactory>,
        Vec<(&'static str, &'static str)>,
    );

    fn panoramas() -> Vec<Panorama> {
        use crate::{
            cubemap::CubemapFaceFactory, cylinder::CylinderCameraFactory, fisheye::FisheyeFactory,
            mirrorball::MirrorBallFactory, octahedral::OctahedralFactory, sphere::SphereCameraFactory,
        };
        let fisheye = |m: &'static str, fov: &'static str| vec![("string mapping", m), ("float fov", fov)];
        vec![
            ("sphere 360x180", Box::new(SphereCameraFactory), vec![]),
            (
                "sphere 120x90",
                Box::new(SphereCameraFactory),
                vec![("float hsweep", "120"), ("float vsweep", "90")],
            ),
            ("cylinder", Box::new(CylinderCameraFactory), vec![]),
            (
                "fisheye equidistant 360",
                Box::new(FisheyeFactory),
                fisheye("equidistant", "360"),
            ),
            (
                "fisheye equidistant 180",
                Box::new(FisheyeFactory),
                fisheye("equidistant", "180"),
            ),
            (
                "fisheye equisolid",
                Box::new(FisheyeFactory),
                fisheye("equisolid", "180"),
            ),
            (
                "fisheye stereographic",
                Box::new(FisheyeFactory),
                fisheye("stereographic", "220"),
            ),
            (
                "fisheye orthographic",
                Box::new(FisheyeFactory),
                fisheye("orthographic", "180"),
            ),
            (
                "fisheye polynomial",
                Box::new(FisheyeFactory),
                vec![("string mapping", "polynomial")],
            ),
            ("mirror ball", Box::new(MirrorBallFactory), vec![]),
            (
                "mirror ball, light probe",
                Box::new(MirrorBallFactory),
                vec![("string orientation", "lightprobe")],
            ),
            ("cube face", Box::new(CubemapFaceFactory), vec![]),
            ("octahedral", Box::new(OctahedralFactory), vec![]),
        ]
    }

    /// Screen samples over the whole window of `format` and three window sizes around it (beyond
    /// every fisheye circle, the mirror ball's rim, the cube face's cut-off and the octahedral fold),
    /// plus far-away, infinite and NaN samples; 1003 of them, so the batch ends in a partial chunk.
    fn samples(format: Format) -> Vec<Point2> {
        let w = ScreenWindow::default_for(format);
        let (fw, fh) = (f64::from(format.width), f64::from(format.height));
        let mut s: Vec<Point2> = (0..990)
            .map(|i| {
                let fx = (i as f64 * 0.618_033_988_75).fract();
                let fy = (i as f64 * 0.754_877_666_25).fract();
                w.raster_to_screen(format, (7.0 * fx - 3.0) * fw, (7.0 * fy - 3.0) * fh)
            })
            .collect();
        s.extend([
            Point2::ZERO,
            Point2::new(w.left, 0.0),
            Point2::new(w.right, w.top),
            Point2::new(0.0, w.bottom),
            Point2::new(1e30, -1e30),
            Point2::new(f32::INFINITY, 0.0),
            Point2::new(0.0, f32::NEG_INFINITY),
            Point2::new(f32::NAN, 0.0),
            Point2::new(0.3, f32::NAN),
            Point2::new(1e-30, -1e-30),
            Point2::new(-0.0, 0.0),
            Point2::new(0.5 * w.right, 0.25 * w.top),
            Point2::new(-0.999 * w.right, 0.999 * w.bottom),
        ]);
        s
    }

    fn bits(rays: &[RayGeometry]) -> Vec<[u32; 10]> {
        rays.iter().map(RayGeometry::to_bits).collect()
    }

    /// The rays of `screen` at tier `level` (capped to what the CPU has).
    fn rays_at(level: Level, p: &dyn obscura_sdk::Projection, screen: &[Point2]) -> Vec<RayGeometry> {
        let n = screen.len();
        with_level(level, || {
            project_points(p, screen, &vec![Point2::ZERO; n], &vec![0.0; n])
        })
    }

    /// Every SIMD tier gives the portable tier's rays bit for bit (the lanes use IEEE operations only,
    /// never contracted into fused multiply-adds), the chunked loop gives what the one-sample tail gives,
    /// and culled samples are exactly the culled ray. Tiers above the CPU's run as the widest it has
    /// ([`Level::detected`] says which ran; the project's machines have all three).
    #[test]
    fn tiers_panoramas_every_tier_is_the_portable_tier_bit_for_bit() {
        let format = Format::new(320, 160);
        let screen = samples(format);
        for (label, factory, params) in panoramas() {
            let p = make(factory.as_ref(), &params, format);
            let portable = rays_at(Level::Portable, p.as_ref(), &screen);
            for level in Level::ALL {
                let wide = rays_at(level, p.as_ref(), &screen);
                assert_eq!(bits(&wide), bits(&portable), "{label}: tier {level}");
                // One sample per batch: the scalar tail of the loop.
                for (i, s) in screen.iter().enumerate().step_by(7) {
                    let one = rays_at(level, p.as_ref(), &[*s]);
                    assert_eq!(
                        bits(&one),
                        bits(&portable[i..=i]),
                        "{label}: tier {level}, tail at {s:?}"
                    );
                }
            }
            let culled = portable.iter().filter(|r| r.is_culled()).count();
            assert!(
                portable
                    .iter()
                    .all(|r| !r.is_culled() || bits(&[*r]) == bits(&[RayGeometry::CULLED])),
                "{label}: a culled ray that is not RayGeometry::CULLED"
            );
            assert!(culled < screen.len(), "{label}: everything culled");
        }
    }

    /// `project_soa` of every panorama branch is its `project` bit for bit at every tier, culled
    /// samples included (the samples reach beyond every rim), every tail length.
    #[test]
    fn tiers_panoramas_project_soa_is_project_bit_for_bit() {
        let format = Format::new(320, 160);
        let screen = samples(format);
        let n = screen.len();
        for (label, factory, params) in panoramas() {
            let p = make(factory.as_ref(), &params, format);
            crate::testing::assert_soa_is_project(
                label,
                p.as_ref(),
                &screen,
                &vec![Point2::ZERO; n],
                &vec![0.0; n],
            );
            let culled = rays_at(Level::Portable, p.as_ref(), &screen)
                .iter()
                .filter(|r| r.is_culled())
                .count();
            assert!(
                culled > 0 || !label.starts_with("fisheye"),
                "{label}: no culled sample among the tests"
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Random batches of random length over and far beyond the window (culled samples among
        /// them), at every tier: every panorama's `project_soa` is its `project` bit for bit.
        #[test]
        fn tiers_panoramas_project_soa_is_project_on_random_batches(
            points in proptest::collection::vec((-3.0f64..4.0, -3.0f64..4.0), 0..50),
        ) {
            let format = Format::new(320, 160);
            let w = ScreenWindow::default_for(format);
            let screen: Vec<Point2> = points.iter().map(|&(fx, fy)| w.raster_to_screen(format, fx * 320.0, fy * 160.0)).collect();
            let n = screen.len();
            let (aperture, time) = (vec![Point2::ZERO; n], vec![0.0; n]);
            for (label, factory, params) in panoramas() {
                let p = make(factory.as_ref(), &params, format);
                for level in Level::ALL.into_iter().filter(|l| l.is_available()) {
                    let check = with_level(level, || obscura_sdk::check_project_soa(p.as_ref(), &screen, &aperture, &time));
                    prop_assert_eq!(check, Ok(true), "{} tier {}", label, level);
                }
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Over the whole screen (and far beyond it), at every tier: the ray is the portable tier's
        /// bit for bit, unit where valid, and comes back to its screen point through `unproject`
        /// within 10⁻³ of a pixel wherever the camera's inverse claims the point.
        #[test]
        fn tiers_panoramas_random_points_match_and_round_trip(fx in -3.0f64..4.0, fy in -3.0f64..4.0) {
            let format = Format::new(320, 160);
            let w = ScreenWindow::default_for(format);
            let s = w.raster_to_screen(format, fx * 320.0, fy * 160.0);
            let (px, py) = w.pixel_size(format);
            for (label, factory, params) in panoramas() {
                let p = make(factory.as_ref(), &params, format);
                let portable = rays_at(Level::Portable, p.as_ref(), &[s]);
                for level in Level::ALL {
                    prop_assert_eq!(bits(&rays_at(level, p.as_ref(), &[s; 17])[16..]), bits(&portable), "{} tier {}", label, level);
                }
                let r = portable[0];
                if r.is_culled() {
                    continue;
                }
                prop_assert!((r.direction.length() - 1.0).abs() < 1e-6, "{}: {:?}", label, r);
                let inside = (0.0..=1.0).contains(&fx) && (0.0..=1.0).contains(&fy);
                if let Some(back) = p.unproject(r.direction * 2.5, 0.0) {
                    // A panorama's inverse answers inside its window; samples outside it that it maps
                    // back land on the point the same direction has inside (the seam, a pole, a fold).
                    if inside {
                        let err = f64::from((back.x - s.x) / px).hypot(f64::from((back.y - s.y) / py));
                        prop_assert!(err < 1e-3,
                            "{}: {:?} came back as {:?} ({} px)", label, s, back, err);
                    }
                    let again = rays_at(Level::Portable, p.as_ref(), &[back])[0];
                    prop_assert!(angle(again.direction, r.direction) < 1e-5,
                        "{}: {:?} → {:?} → {:?}", label, r.direction, back, again.direction);
                } else {
                    prop_assert!(!inside || label.starts_with("fisheye"), "{}: {:?} inside the window does not unproject", label, s);
                }
            }
        }
    }
}
