//! What every projection does with the host's screen samples before its own mapping: walk the batch
//! (each ray from its screen sample `s = (sx, sy)`, and its aperture sample `a` where a lens needs one)
//! in the vectorised loop of [`crate::simd`], and size the footprint by the pixel of the image format
//! over the screen window, `Δx = (r − l)/W`, `Δy = (t − b)/H` screen units.
//!
//! Window coordinates `u, v ∈ [−1, 1]`, the panoramas' normalised form of `s`, are
//! [`crate::panorama::SweepWindow`]'s.

use obscura_sdk::{Point2, ProjectionContext, ProjectionEnvironment, RayGeometry};

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
