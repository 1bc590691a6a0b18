//! What every projection does with the host's screen samples before its own mapping: walk the batch
//! (each ray from its screen sample `s = (sx, sy)`, and its aperture sample `a` where a lens needs one)
//! in the vectorised loop of [`crate::simd`], and size the footprint by the pixel of the image format
//! over the screen window, `Δx = (r − l)/W`, `Δy = (t − b)/H` screen units.
//!
//! Window coordinates `u, v ∈ [−1, 1]`, the panoramas' normalised form of `s`, are
//! [`crate::panorama::SweepWindow`]'s.

use obscura_sdk::{Point2, ProjectionContext, ProjectionEnvironment, RayGeometry, Vec3};

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
    let (mut valid, mut d) = ([false; LANES], [[0.0f32; LANES]; 4]);
    for (out, s) in (&mut out_chunks).zip(&mut in_chunks) {
        let sx: [f32; LANES] = std::array::from_fn(|i| s[i].x);
        let sy: [f32; LANES] = std::array::from_fn(|i| s[i].y);
        for i in 0..LANES {
            let l = lane(Point2::new(sx[i], sy[i]));
            valid[i] = l.valid;
            (d[0][i], d[1][i], d[2][i], d[3][i]) =
                (l.direction.x, l.direction.y, l.direction.z, l.ray_spread);
        }
        for (i, r) in out.iter_mut().enumerate() {
            *r = clip.lane_ray(CentredLane {
                valid: valid[i],
                direction: Vec3::new(d[0][i], d[1][i], d[2][i]),
                ray_spread: d[3][i],
            });
        }
    }
    for (r, s) in out_chunks.into_remainder().iter_mut().zip(in_chunks.remainder()) {
        *r = clip.lane_ray(lane(*s));
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
