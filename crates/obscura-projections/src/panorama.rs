//! What the panoramic projections share: the cameras whose rays leave one centre and may point
//! anywhere, not just ahead (`PxrSphereCamera`, `PxrCylinderCamera`, `PxrPanini`,
//! `OmnidirectionalStereo`, `Fisheye`, `MirrorBall`, `EquiangularCubemapFace`, `Octahedral`).
//!
//! # Window coordinates
//!
//! With the screen window `(l, r, b, t)`, its centre `(cx, cy) = ((l + r)/2, (b + t)/2)` and half sizes
//! `hw = (r − l)/2`, `hh = (t − b)/2`, a screen sample `(sx, sy)` has the window coordinates
//!
//! ```text
//! u = (sx − cx)/hw,   v = (sy − cy)/hh          (both in [−1, 1] across the window)
//! ```
//!
//! ([`SweepWindow`], conventions.md "panoramic projections"); the inverse maps `(u, v)` back to
//! `(cx + u·hw, cy + v·hh)`, refusing points more than [`EDGE_TOLERANCE`] of the half window outside.
//!
//! # Azimuth and elevation
//!
//! A sweep of `hsweep` degrees across the window's width has the azimuth `φ = u·hsweep/2`
//! ([`AzimuthSweep`]); the half sweeps are rounded toward zero in `f32` ([`radians_toward_zero`]) so a
//! 360° window's edges stay on their own side of the seam. A direction `D = (x, y, z)` has
//!
//! ```text
//! φ = atan2(x, z),   θ = atan2(y, sqrt(x² + z²))     D = (sin φ·cos θ, sin θ, cos φ·cos θ)
//! ```
//!
//! ([`direction_angles`]): azimuth 0 is +Z, positive azimuth turns toward +X, positive elevation toward
//! +Y.
//!
//! # Radial maps
//!
//! A map that is symmetric about the view axis (the fisheyes, the mirror ball) sends the screen point
//! `s` at radius `r = |s|` to the angle `θ(r)` from its centre direction, with the azimuth of `s`:
//! `D = (B·sx, B·sy, cos θ)` with `B = sin θ/r`. With `A = dθ/dr`, a pixel of `Δx × Δy` screen units
//! turns the direction by
//!
//! ```text
//! αx = Δx·sqrt(A²·sx² + B²·sy²)/r,   αy = Δy·sqrt(A²·sy² + B²·sx²)/r,   ray_spread = ½·sqrt(αx·αy)
//! ```
//!
//! (`αx = Δx·A`, `αy = Δy·A` at `r = 0`), computed by [`radial_lane`] with `Δx = Δy = sqrt(Δx·Δy)` taken
//! out as the half-pixel factor. Where `A` is infinite at a rim (`A = k/cos` with the cosine reaching 0
//! at radius `1/k`), the cosine is held at its value a hundredth of a pixel inside the rim,
//! [`rim_cos_floor`]`(k·ε) = sqrt(k·ε·(2 − k·ε))`.
//!
//! # Batch lanes
//!
//! A camera whose rays leave its centre states its ray as a branch-free [`CentredLane`] (valid,
//! direction, spread; [`radial_lane`] for the radial maps); [`crate::screen::map_centred_rays`] runs a
//! batch of them structure-of-arrays at the widest SIMD tier, and [`SphericalClip::lane_ray`] turns one
//! into its ray. Sines and cosines come from [`sin_cos`], a polynomial that vectorises (libm's does
//! not).
//!
//! # Properties and clipping
//!
//! The panoramic cameras answer DicingHint Spherical and DeepMetric RayLength ([`spherical_property`];
//! `PxrPanini` at compression 0 is a pinhole and answers as one). Their FieldOfView makes the host's
//! dicing rate `2s/fov` pixels per radian (`s = max(W/(r − l), H/(t − b))` pixels per screen unit)
//! equal the finest angular resolution of the image ([`spherical_field_of_view`]). Clipping is by spheres around the camera: `min_dist = near`,
//! `max_dist = far` ([`SphericalClip`]).

use obscura_sdk::{
    DeepMetric, DicingHint, ParamDecl, Params, PluginError, Point2, Projection, ProjectionEnvironment,
    ProjectionProperty, PropertyValue, RayGeometry, ScreenWindow, ValueRange, Vec3,
};

/// How far outside the window (in units of its half size) [`Projection::unproject`] still answers.
pub const EDGE_TOLERANCE: f64 = 1e-5;

/// Window coordinates farther out than this are clamped (64 half windows: no pixel filter reaches
/// there), which keeps the angle reduction of [`sin_cos`] exact.
const FAR_OUTSIDE: f32 = 64.0;

/// The screen window's centre and half sizes: `u = (sx − cx)/hw`, `v = (sy − cy)/hh`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepWindow {
    /// Centre x, `(l + r)/2`.
    pub cx: f32,
    /// Centre y, `(b + t)/2`.
    pub cy: f32,
    /// Half width, `(r − l)/2`.
    pub hw: f32,
    /// Half height, `(t − b)/2`.
    pub hh: f32,
}

impl SweepWindow {
    /// The window coordinates of `window`. With a window centred on the origin (the default) `u` is
    /// exactly ±1 on the left and right edges.
    #[must_use]
    pub fn new(window: ScreenWindow) -> Self {
        SweepWindow {
            cx: 0.5 * (window.left + window.right),
            cy: 0.5 * (window.bottom + window.top),
            hw: 0.5 * (window.right - window.left),
            hh: 0.5 * (window.top - window.bottom),
        }
    }

    /// The window coordinates of `window` when it has an area ([`SweepWindow::is_usable`]), else `None`.
    #[must_use]
    pub fn usable(window: ScreenWindow) -> Option<Self> {
        Some(SweepWindow::new(window)).filter(SweepWindow::is_usable)
    }

    /// True when both half sizes are finite and non-zero.
    #[must_use]
    pub fn is_usable(&self) -> bool {
        self.hw.is_finite() && self.hh.is_finite() && self.hw != 0.0 && self.hh != 0.0
    }

    /// Half the geometric mean of one pixel of `env` in window coordinates, `½·sqrt(Δu·Δv)` with
    /// `Δu = 2Δx/(r − l)`, `Δv = 2Δy/(t − b)`.
    #[must_use]
    pub fn half_pixel(env: &ProjectionEnvironment) -> f32 {
        let w = env.screen_window();
        let (dx, dy) = env.pixel_size();
        let (du, dv) = (2.0 * dx / w.width(), 2.0 * dy / w.height());
        0.5 * (du * dv).sqrt()
    }

    /// `(u, v)` of a screen point, unclamped: for maps that handle far-outside points themselves (the
    /// octahedral fold, the cube face's own clip), where the clamp of [`SweepWindow::uv`] would cost
    /// time for nothing.
    #[inline(always)]
    #[must_use]
    pub fn uv_unclamped(&self, s: Point2) -> (f32, f32) {
        ((s.x - self.cx) / self.hw, (s.y - self.cy) / self.hh)
    }

    /// `(u, v)` of a screen point, each clamped to ±64 (NaN stays NaN).
    #[inline(always)]
    #[must_use]
    pub fn uv(&self, s: Point2) -> (f32, f32) {
        (
            ((s.x - self.cx) / self.hw).clamp(-FAR_OUTSIDE, FAR_OUTSIDE),
            ((s.y - self.cy) / self.hh).clamp(-FAR_OUTSIDE, FAR_OUTSIDE),
        )
    }

    /// The screen point of window coordinates `(u, v)`, wherever they are.
    #[must_use]
    pub fn screen_point(&self, u: f64, v: f64) -> Point2 {
        Point2::new(
            (f64::from(self.cx) + u * f64::from(self.hw)) as f32,
            (f64::from(self.cy) + v * f64::from(self.hh)) as f32,
        )
    }

    /// The screen point of window coordinates `(u, v)`; `None` when either is farther than
    /// [`EDGE_TOLERANCE`] outside `[−1, 1]` or not finite.
    #[must_use]
    pub fn screen(&self, u: f64, v: f64) -> Option<Point2> {
        let lim = 1.0 + EDGE_TOLERANCE;
        (u.abs() <= lim && v.abs() <= lim).then(|| self.screen_point(u, v))
    }
}

/// The window of a panorama whose azimuth is linear across the width: `φ = u·hsweep/2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AzimuthSweep {
    /// The window coordinates.
    pub window: SweepWindow,
    /// `hsweep/2` in radians, rounded toward zero.
    pub half_h: f32,
}

impl AzimuthSweep {
    /// `hsweep` degrees across `window`'s width; `None` when the window has no area.
    #[must_use]
    pub fn new(window: ScreenWindow, hsweep: f32) -> Option<Self> {
        Some(AzimuthSweep {
            window: SweepWindow::usable(window)?,
            half_h: radians_toward_zero(0.5 * f64::from(hsweep)),
        })
    }

    /// The azimuth `φ` (radians) and the window coordinate `v` of screen point `s`; `None` when either
    /// coordinate is NaN.
    #[inline(always)]
    #[must_use]
    pub fn azimuth_and_v(&self, s: Point2) -> Option<(f32, f32)> {
        let (u, v) = self.window.uv(s);
        (!u.is_nan() && !v.is_nan()).then_some((u * self.half_h, v))
    }

    /// The screen point at azimuth `phi` (radians) and window coordinate `v`; `None` outside the window
    /// (tolerance [`EDGE_TOLERANCE`]).
    #[must_use]
    pub fn screen(&self, phi: f64, v: f64) -> Option<Point2> {
        self.window.screen(phi / f64::from(self.half_h), v)
    }
}

/// The azimuth and elevation `(φ, θ)` of the direction `(x, y, z)`: `φ = atan2(x, z)`,
/// `θ = atan2(y, sqrt(x² + z²))`.
#[must_use]
pub fn direction_angles(x: f64, y: f64, z: f64) -> (f64, f64) {
    (x.atan2(z), y.atan2(x.hypot(z)))
}

/// The angle in radians between the directions `a` and `b`, not necessarily unit:
/// `atan2(|a × b|, a·b)`, accurate at every size (`acos` of the dot product is not, near 0 and π).
#[must_use]
pub fn angle_between(a: [f64; 3], b: [f64; 3]) -> f64 {
    let cross = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let sin = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
    let cos = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    sin.atan2(cos)
}

/// The components of `point` in f64; `None` when one is not finite (every inverse starts here).
#[must_use]
pub fn finite_f64(point: Vec3) -> Option<(f64, f64, f64)> {
    point
        .is_finite()
        .then(|| (f64::from(point.x), f64::from(point.y), f64::from(point.z)))
}

/// `degrees` in radians as the `f32` nearest to it on the side of zero, so the edge of a sweep never
/// lands past the exact angle (360° stays short of the seam, 180° short of the poles).
#[must_use]
pub fn radians_toward_zero(degrees: f64) -> f32 {
    let exact = degrees.to_radians();
    let r = exact as f32;
    if (r as f64).abs() > exact.abs() {
        if r > 0.0 { r.next_down() } else { r.next_up() }
    } else {
        r
    }
}

/// Sine and cosine of `x` in one go, accurate to a few 10⁻⁸ for `|x| < 10⁴`, without a library call
/// (so the batch loops vectorise): Cody–Waite reduction by π/2 to `[−π/4, π/4]`, Taylor polynomials to
/// degree 9 (sine) and 10 (cosine), quadrant fix-up by bit operations. The signs are right to the last
/// bit near the quadrant boundaries: `sin_cos(−π)` with `π` rounded toward zero has a negative sine.
#[inline(always)]
#[must_use]
pub fn sin_cos(x: f32) -> (f32, f32) {
    // 1.5·2²³: adding it rounds to an integer held in the low mantissa bits.
    const MAGIC: f32 = 12_582_912.0;
    // π/2 split into three parts; q·C1 and q·C2 are exact for |q| < 2¹².
    const C1: f32 = 1.570_312_5;
    const C2: f32 = 4.837_513e-4;
    const C3: f32 = 7.549_79e-8;
    let y = x * std::f32::consts::FRAC_2_PI + MAGIC;
    let quadrant = y.to_bits() & 3;
    let q = y - MAGIC;
    let r = ((x - q * C1) - q * C2) - q * C3;
    let r2 = r * r;
    let s =
        r * (1.0 + r2 * (-1.0 / 6.0 + r2 * (1.0 / 120.0 + r2 * (-1.0 / 5040.0 + r2 * (1.0 / 362_880.0)))));
    let c = 1.0
        + r2 * (-0.5
            + r2 * (1.0 / 24.0 + r2 * (-1.0 / 720.0 + r2 * (1.0 / 40_320.0 + r2 * (-1.0 / 3_628_800.0)))));
    let (sin, cos) = if quadrant & 1 == 0 { (s, c) } else { (c, s) };
    let sin = f32::from_bits(sin.to_bits() ^ ((quadrant & 2) << 30));
    let cos = f32::from_bits(cos.to_bits() ^ (((quadrant + 1) & 2) << 30));
    (sin, cos)
}

/// The FieldOfView a Spherical dicing hint needs so the host's rate `2s/fov` pixels per radian equals
/// `pixels_per_degree`, the finest angular resolution of the image: `2·s/pixels_per_degree` degrees,
/// `s = max(W/(r − l), H/(t − b))`.
#[must_use]
pub fn spherical_field_of_view(env: &ProjectionEnvironment, pixels_per_degree: f64) -> f32 {
    let w = env.screen_window();
    let s = (env.width() as f64 / w.width().abs() as f64).max(env.height() as f64 / w.height().abs() as f64);
    (2.0 * s / pixels_per_degree) as f32
}

/// The FieldOfView of a latitude–longitude grid of `hsweep × vsweep` degrees over `env`'s image: its
/// finest resolution is the equator's, `max(W/hsweep, H/vsweep)` pixels per degree.
#[must_use]
pub fn lat_long_field_of_view(env: &ProjectionEnvironment, hsweep: f32, vsweep: f32) -> f32 {
    let (w, h) = (env.width() as f64, env.height() as f64);
    spherical_field_of_view(env, (w / f64::from(hsweep)).max(h / f64::from(vsweep)))
}

/// The property answers of a camera whose rays may leave +Z: DicingHint Spherical, DeepMetric RayLength
/// and FieldOfView `fov` degrees; `None` for everything else.
#[must_use]
pub fn spherical_property(property: ProjectionProperty, fov: f32) -> Option<PropertyValue> {
    match property {
        ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(DicingHint::Spherical)),
        ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(DeepMetric::RayLength)),
        ProjectionProperty::FieldOfView => Some(PropertyValue::Float(fov)),
        _ => None,
    }
}

/// The clipping of a camera whose rays may leave +Z: spheres around the camera, `min_dist = near`,
/// `max_dist = far` (conventions.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphericalClip {
    /// The environment's near clipping distance.
    pub near: f32,
    /// The environment's far clipping distance.
    pub far: f32,
}

impl SphericalClip {
    /// The clipping distances of `env`.
    #[must_use]
    pub fn new(env: &ProjectionEnvironment) -> Self {
        SphericalClip {
            near: env.clipping_near(),
            far: env.clipping_far(),
        }
    }

    /// A ray from the camera's centre (`O = 0`, no origin radius) along the unit `direction`, clipped by
    /// these spheres.
    #[inline(always)]
    #[must_use]
    pub fn centred_ray(self, direction: Vec3, ray_spread: f32) -> RayGeometry {
        RayGeometry {
            origin: Vec3::ZERO,
            origin_radius: 0.0,
            direction,
            ray_spread,
            min_dist: self.near,
            max_dist: self.far,
        }
    }
}

/// One lane of a centred camera's batch ([`crate::screen::map_centred_rays`]): the ray from the camera's
/// centre computed without branches, whether it exists, its unit direction and its spread (meaningless
/// where `valid` is false).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CentredLane {
    /// The screen sample has a ray (else it is culled).
    pub valid: bool,
    /// The unit direction.
    pub direction: Vec3,
    /// The ray spread.
    pub ray_spread: f32,
}

impl SphericalClip {
    /// The ray of `lane`: [`SphericalClip::centred_ray`] where it is valid, else the culled ray.
    #[inline(always)]
    #[must_use]
    pub fn lane_ray(self, lane: CentredLane) -> RayGeometry {
        if lane.valid {
            self.centred_ray(lane.direction, lane.ray_spread)
        } else {
            RayGeometry::CULLED
        }
    }
}

/// The ray of a radial map (see the module documentation) at screen point `s`, `r2 = |s|²`, as a
/// valid [`CentredLane`]: `D = (b·sx, b·sy, cos_theta)` with `b = B = sin θ/r`, `a = A = dθ/dr`, and
/// the footprint `ray_spread = half_pixel·(αx·αy/Δ²)^¼` with `half_pixel = ½·sqrt(Δx·Δy)`.
#[inline(always)]
#[must_use]
pub fn radial_lane(half_pixel: f32, s: Point2, r2: f32, (b, cos_theta, a): (f32, f32, f32)) -> CentredLane {
    let (x2, y2) = (s.x * s.x, s.y * s.y);
    let (a2, b2) = (a * a, b * b);
    let inv = 1.0 / r2;
    let (ax2, ay2) = if r2 > 0.0 {
        ((a2 * x2 + b2 * y2) * inv, (a2 * y2 + b2 * x2) * inv)
    } else {
        (a2, a2)
    };
    CentredLane {
        valid: true,
        direction: Vec3::new(b * s.x, b * s.y, cos_theta),
        ray_spread: half_pixel * (ax2 * ay2).sqrt().sqrt(),
    }
}

/// The cosine a radial map reaches `step` (in units of the rim's radius) inside a rim where it falls
/// to 0 as `sqrt(1 − (k·r)²)`: `sqrt(step·(2 − step))`. Holding the cosine there keeps `A = k/cos`
/// finite at the rim itself.
#[must_use]
pub fn rim_cos_floor(step: f64) -> f32 {
    (step * (2.0 - step)).max(0.0).sqrt() as f32
}

/// The error for a screen window without area.
pub(crate) fn degenerate_window(plugin: &str, w: ScreenWindow) -> PluginError {
    crate::invalid(
        plugin,
        format!(
            "the screen window ({}, {}, {}, {}) has no area; a panoramic projection needs one",
            w.left, w.right, w.bottom, w.top
        ),
    )
}

/// The end of a panoramic factory's `create`: `camera`, boxed, with DeepMetric RayLength set in `env`;
/// `None` (a window without area) is the error naming `plugin` and the window.
///
/// # Errors
/// [`PluginError::Invalid`] when `camera` is `None`.
pub fn boxed_spherical<P: Projection + 'static>(
    plugin: &str,
    env: &mut ProjectionEnvironment,
    camera: Option<P>,
) -> Result<Box<dyn Projection>, PluginError> {
    let camera = camera.ok_or_else(|| degenerate_window(plugin, env.screen_window()))?;
    env.set_deep_metric(DeepMetric::RayLength);
    Ok(Box::new(camera))
}

/// The end of the factory of a panorama made from `hsweep` and `vsweep` alone (the latitude–longitude
/// grid, the cylinder): `new` of the two sweeps in degrees, then [`boxed_spherical`].
///
/// # Errors
/// A parameter lookup error when `p` lacks either sweep, and those of [`boxed_spherical`].
pub fn boxed_sweep<P: Projection + 'static>(
    plugin: &str,
    env: &mut ProjectionEnvironment,
    p: &Params,
    new: fn(&ProjectionEnvironment, f32, f32) -> Option<P>,
) -> Result<Box<dyn Projection>, PluginError> {
    let camera = new(env, p.float("hsweep")?, p.float("vsweep")?);
    boxed_spherical(plugin, env, camera)
}

/// The `hsweep` parameter: degrees of azimuth across the window's width, in `(0, 360]`, default 360.
#[must_use]
pub fn hsweep_param() -> ParamDecl {
    ParamDecl::float("hsweep", 360.0)
        .range(ValueRange {
            min: 0.0,
            max: 360.0,
            min_inclusive: false,
            max_inclusive: true,
        })
        .doc("horizontal sweep in degrees across the screen window's width (azimuth ±hsweep/2)")
}

/// The `vsweep` parameter of a latitude–longitude grid: degrees of elevation across the window's
/// height, in `(0, 180]`, default 180.
#[must_use]
pub fn vsweep_param() -> ParamDecl {
    ParamDecl::float("vsweep", 180.0)
        .range(ValueRange {
            min: 0.0,
            max: 180.0,
            min_inclusive: false,
            max_inclusive: true,
        })
        .doc("vertical sweep in degrees across the screen window's height (elevation ±vsweep/2)")
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn sin_cos_matches_the_library_to_a_few_ulp(x in -200.0f32..200.0) {
            let (s, c) = sin_cos(x);
            let (es, ec) = (x as f64).sin_cos();
            prop_assert!((s as f64 - es).abs() < 2e-7 * (1.0 + x.abs() as f64 / 100.0), "sin {x}: {s} vs {es}");
            prop_assert!((c as f64 - ec).abs() < 2e-7 * (1.0 + x.abs() as f64 / 100.0), "cos {x}: {c} vs {ec}");
        }
    }
}
