//! `PxrSphereCamera`: the spherical (latitude–longitude) panorama; equirectangular at its defaults.
//!
//! # Mapping
//!
//! With the screen window `(l, r, b, t)` and a screen sample `(sx, sy)`, the window coordinates
//! `u = (sx − cx)/hw`, `v = (sy − cy)/hh` (`cx, cy` the window's centre, `hw, hh` its half width and
//! height) run over `[−1, 1]` across the window (conventions.md, "panoramic projections"):
//!
//! - azimuth `φ = u·hsweep/2`, elevation `θ = v·vsweep/2`;
//! - `O = 0`, `D = (sin φ·cos θ, sin θ, cos φ·cos θ)`: azimuth 0 is +Z, positive azimuth turns toward
//!   +X, positive elevation toward +Y;
//! - footprint: moving one pixel turns `D` by `αx = cos θ·hsweep/W` along x and `αy = vsweep/H` along y
//!   (angles in radians), so `origin_radius = 0` and `ray_spread = ½·sqrt(αx·αy) =
//!   ½·sqrt(hsweep·vsweep/(W·H))·sqrt(|cos θ|)`; it is zero at the poles, where a pixel's column
//!   collapses to a point;
//! - clipping: spheres around the camera, `min_dist = near`, `max_dist = far`.
//!
//! Samples the pixel filter takes from outside the window continue the same formula (past the seam the
//! azimuth wraps around, past a pole the direction goes over it), so nothing is culled. The half sweeps
//! are rounded toward zero when converted to `f32` radians, so the window's edges stay on their own side
//! of the seam and the poles (the left edge of a 360° panorama looks a hair right of −Z, the right edge a
//! hair left of it) and the inverse returns each edge to itself.
//!
//! # Inverse
//!
//! A camera-space point `P ≠ 0` has `φ = atan2(P.x, P.z)`, `θ = atan2(P.y, sqrt(P.x² + P.z²))` and is
//! seen at `u = φ/(hsweep/2)`, `v = θ/(vsweep/2)`; `None` when that lies outside the sweep (the field
//! of view), with a tolerance of 10⁻⁵ of the half window so the edges themselves map.
//!
//! # Properties
//!
//! DicingHint Spherical; DeepMetric RayLength (also set in the environment); FieldOfView the angle whose
//! dicing rate matches the finest angular resolution of the image, the equator:
//! `2·s/max(W/hsweep, H/vsweep)` degrees with `s = max(W/(r − l), H/(t − b))` pixels per screen unit
//! (the host dices at `2s/fov` pixels per radian). With square pixels that is
//! `2·min(hsweep/(r − l), vsweep/(t − b))`: 180° for the default 2:1 equirectangular image.
//!
//! The module also holds what the other panoramic projections share: the window coordinates
//! ([`SweepWindow`]), a fast `sin_cos`, sweep angles rounded toward zero, the FieldOfView rule, the
//! property answers of a Spherical camera ([`spherical_property`]) and spherical clipping
//! ([`SphericalClip`]).

use std::sync::LazyLock;

use obscura_sdk::{
    DeepMetric, DicingHint, ParamDecl, ParamList, Params, PluginError, Point2, Projection, ProjectionContext,
    ProjectionEnvironment, ProjectionFactory, ProjectionProperty, PropertyValue, RayGeometry, ScreenWindow,
    ValueRange, Vec3,
};

use crate::simd;

/// The name scenes use.
pub const NAME: &str = "PxrSphereCamera";

/// How far outside the window (in units of its half size) [`Projection::unproject`] still answers.
pub(crate) const EDGE_TOLERANCE: f64 = 1e-5;

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

    /// `(u, v)` of a screen point, each clamped to ±64 (NaN stays NaN).
    #[inline(always)]
    #[must_use]
    pub fn uv(&self, s: Point2) -> (f32, f32) {
        (
            ((s.x - self.cx) / self.hw).clamp(-FAR_OUTSIDE, FAR_OUTSIDE),
            ((s.y - self.cy) / self.hh).clamp(-FAR_OUTSIDE, FAR_OUTSIDE),
        )
    }

    /// The screen point of window coordinates `(u, v)`; `None` when either is farther than
    /// [`EDGE_TOLERANCE`] outside `[−1, 1]` or not finite.
    #[must_use]
    pub fn screen(&self, u: f64, v: f64) -> Option<Point2> {
        let lim = 1.0 + EDGE_TOLERANCE;
        (u.abs() <= lim && v.abs() <= lim).then(|| {
            Point2::new(
                (self.cx as f64 + u * self.hw as f64) as f32,
                (self.cy as f64 + v * self.hh as f64) as f32,
            )
        })
    }
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

/// The error for a screen window without area.
pub(crate) fn degenerate_window(plugin: &str, w: ScreenWindow) -> PluginError {
    PluginError::Invalid {
        plugin: plugin.to_string(),
        message: format!(
            "the screen window ({}, {}, {}, {}) has no area; a panoramic projection needs one",
            w.left, w.right, w.bottom, w.top
        ),
    }
}

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    vec![
        ParamDecl::float("hsweep", 360.0)
            .range(ValueRange {
                min: 0.0,
                max: 360.0,
                min_inclusive: false,
                max_inclusive: true,
            })
            .doc("horizontal sweep in degrees across the screen window's width (azimuth ±hsweep/2)"),
        ParamDecl::float("vsweep", 180.0)
            .range(ValueRange {
                min: 0.0,
                max: 180.0,
                min_inclusive: false,
                max_inclusive: true,
            })
            .doc("vertical sweep in degrees across the screen window's height (elevation ±vsweep/2)"),
    ]
});

/// Creates [`SphereCamera`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct SphereCameraFactory;

impl ProjectionFactory for SphereCameraFactory {
    fn name(&self) -> &str {
        NAME
    }

    fn summary(&self) -> &str {
        "latitude-longitude panorama: azimuth u*hsweep/2, elevation v*vsweep/2 over the window (equirectangular)"
    }

    fn param_table(&self) -> &[ParamDecl] {
        &TABLE
    }

    fn create_projection(
        &self,
        env: &mut ProjectionEnvironment,
        params: &ParamList,
    ) -> Result<Box<dyn Projection>, PluginError> {
        let p = Params::resolve(NAME, &TABLE, params)?;
        let sphere = SphereCamera::new(env, p.float("hsweep")?, p.float("vsweep")?)
            .ok_or_else(|| degenerate_window(NAME, env.screen_window()))?;
        env.set_deep_metric(DeepMetric::RayLength);
        Ok(Box::new(sphere))
    }
}

/// The spherical panorama (see the module documentation for its mapping).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereCamera {
    window: SweepWindow,
    /// `hsweep/2` in radians, rounded toward zero.
    half_h: f32,
    /// `vsweep/2` in radians, rounded toward zero.
    half_v: f32,
    /// `½·sqrt(αx·αy)` at the equator.
    spread: f32,
    clip: SphericalClip,
    fov: f32,
}

impl SphereCamera {
    /// A panorama of `hsweep × vsweep` degrees over `env`'s screen window; `None` when the window has
    /// no area.
    #[must_use]
    pub fn new(env: &ProjectionEnvironment, hsweep: f32, vsweep: f32) -> Option<Self> {
        let window = SweepWindow::usable(env.screen_window())?;
        let (w, h) = (env.width() as f64, env.height() as f64);
        let (hs, vs) = (hsweep as f64, vsweep as f64);
        Some(SphereCamera {
            window,
            half_h: radians_toward_zero(0.5 * hs),
            half_v: radians_toward_zero(0.5 * vs),
            spread: (0.5 * (hs.to_radians() * vs.to_radians() / (w * h)).sqrt()) as f32,
            clip: SphericalClip::new(env),
            fov: spherical_field_of_view(env, (w / hs).max(h / vs)),
        })
    }

    /// The ray through screen point `s`.
    #[inline(always)]
    #[must_use]
    pub fn ray(&self, s: Point2) -> RayGeometry {
        let (u, v) = self.window.uv(s);
        if u.is_nan() || v.is_nan() {
            return RayGeometry::CULLED;
        }
        let (sp, cp) = sin_cos(u * self.half_h);
        let (st, ct) = sin_cos(v * self.half_v);
        self.clip
            .centred_ray(Vec3::new(sp * ct, st, cp * ct), self.spread * ct.abs().sqrt())
    }
}

impl Projection for SphereCamera {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        spherical_property(property, self.fov)
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        simd::map_screen(c.rays, c.screen, |s| self.ray(s));
    }

    fn unproject(&self, point: Vec3, _time: f32) -> Option<Point2> {
        let (x, y, z) = (point.x as f64, point.y as f64, point.z as f64);
        if !point.is_finite() || point == Vec3::ZERO {
            return None;
        }
        let phi = x.atan2(z);
        let theta = y.atan2(x.hypot(z));
        self.window
            .screen(phi / self.half_h as f64, theta / self.half_v as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{
        self, assert_refused, assert_spherical_ray_length, check_centred_roundtrip, keeps_contract, ray_at,
    };
    use obscura_sdk::Format;
    use proptest::prelude::*;

    fn make(params: &[(&str, &str)], format: Format) -> (Box<dyn Projection>, ProjectionEnvironment) {
        testing::make_env(&SphereCameraFactory, params, format)
    }

    proptest! {
        #[test]
        fn sin_cos_matches_the_library_to_a_few_ulp(x in -200.0f32..200.0) {
            let (s, c) = sin_cos(x);
            let (es, ec) = (x as f64).sin_cos();
            prop_assert!((s as f64 - es).abs() < 2e-7 * (1.0 + x.abs() as f64 / 100.0), "sin {x}: {s} vs {es}");
            prop_assert!((c as f64 - ec).abs() < 2e-7 * (1.0 + x.abs() as f64 / 100.0), "cos {x}: {c} vs {ec}");
        }

        #[test]
        fn directions_match_the_closed_form(
            sx in -2.2f32..2.2, sy in -1.1f32..1.1, hsweep in 10.0f32..=360.0, vsweep in 10.0f32..=180.0,
        ) {
            let format = Format::new(200, 100);
            let (p, _) = make(&[("float hsweep", &hsweep.to_string()), ("float vsweep", &vsweep.to_string())], format);
            let r = ray_at(p.as_ref(), Point2::new(sx, sy));
            // Default window (−2, 2, −1, 1): u = sx/2, v = sy.
            let phi = (sx as f64 / 2.0) * (hsweep as f64).to_radians() / 2.0;
            let theta = sy as f64 * (vsweep as f64).to_radians() / 2.0;
            let e = [phi.sin() * theta.cos(), theta.sin(), phi.cos() * theta.cos()];
            let d = [r.direction.x as f64, r.direction.y as f64, r.direction.z as f64];
            for k in 0..3 {
                prop_assert!((d[k] - e[k]).abs() < 1e-6, "{d:?} vs {e:?}");
            }
            prop_assert!((r.direction.length() - 1.0).abs() < 1e-6);
            prop_assert_eq!(r.origin, Vec3::ZERO);
        }

        #[test]
        fn unproject_inverts_project(
            u in -1.0f32..=1.0, v in -1.0f32..=1.0, depth in 0.01f32..1000.0,
            hsweep in 1.0f32..=360.0, vsweep in 1.0f32..=180.0,
        ) {
            let format = Format::new(300, 200);
            let (p, env) = make(&[("float hsweep", &hsweep.to_string()), ("float vsweep", &vsweep.to_string())], format);
            check_centred_roundtrip(p.as_ref(), &env, u, v, depth)?;
        }
    }

    #[test]
    fn centre_looks_down_z_and_edges_are_half_the_sweep() {
        let (p, env) = make(
            &[("float hsweep", "200"), ("float vsweep", "120")],
            Format::new(90, 60),
        );
        let w = env.screen_window();
        let c = ray_at(p.as_ref(), Point2::ZERO);
        assert!((c.direction - Vec3::Z).length() < 1e-7);
        let right = ray_at(p.as_ref(), Point2::new(w.right, 0.0));
        assert!((right.direction.x.atan2(right.direction.z).to_degrees() - 100.0).abs() < 1e-4);
        let top = ray_at(p.as_ref(), Point2::new(0.0, w.top));
        assert!((top.direction.y.asin().to_degrees() - 60.0).abs() < 1e-4);
        // Positive azimuth turns toward +X; positive elevation toward +Y.
        assert!(ray_at(p.as_ref(), Point2::new(0.5, 0.0)).direction.x > 0.0);
        assert!(ray_at(p.as_ref(), Point2::new(0.0, 0.5)).direction.y > 0.0);
    }

    #[test]
    fn the_seam_and_the_poles_keep_their_sides() {
        let format = Format::new(64, 32);
        let (p, env) = make(&[], format);
        let w = env.screen_window();
        for y in [-1.0, -0.3, 0.0, 0.8, 1.0] {
            for (x, sign) in [(w.left, -1.0f32), (w.right, 1.0)] {
                let r = ray_at(p.as_ref(), Point2::new(x, y));
                assert!(r.direction.is_finite() && (r.direction.length() - 1.0).abs() < 1e-6);
                assert!(r.direction.x * sign >= 0.0, "edge {x} at y {y}: {r:?}");
                let back = p.unproject(r.direction * 3.0, 0.0).unwrap();
                assert!((back.x - x).abs() < 1e-5, "edge {x}, y {y}: back at {back:?}");
            }
        }
        // Straight up and down: unit, and the horizontal part still points along the column's azimuth.
        for x in [-1.7f32, -0.4, 0.9] {
            let up = ray_at(p.as_ref(), Point2::new(x, 1.0));
            assert!(up.direction.y > 0.999_999 && (up.direction.length() - 1.0).abs() < 1e-6);
            assert!((up.direction.x.atan2(up.direction.z) - x / 2.0 * std::f32::consts::PI).abs() < 1e-4);
            // The spread shrinks as sqrt(cos θ): a thousandth of the equator's at cos θ ≈ 10⁻⁷.
            let equator = ray_at(p.as_ref(), Point2::new(x, 0.0)).ray_spread;
            assert!(
                up.ray_spread >= 0.0 && up.ray_spread < 1e-3 * equator,
                "{} vs {equator}",
                up.ray_spread
            );
        }
    }

    #[test]
    fn keeps_the_contract() {
        let cases = [
            (Format::new(48, 24), vec![]),
            (
                Format::new(40, 30),
                vec![("float hsweep", "120"), ("float vsweep", "90")],
            ),
            (
                Format::new(30, 40),
                vec![("float hsweep", "360"), ("float vsweep", "30")],
            ),
        ];
        for (_, stats) in keeps_contract(&SphereCameraFactory, &cases) {
            stats.assert_complete(1000);
        }
    }

    #[test]
    fn properties_are_honest() {
        let (p, env) = make(&[], Format::new(2048, 1024));
        assert_spherical_ray_length(p.as_ref(), Some(&env), Some(180.0));
        assert_eq!(p.property(ProjectionProperty::FStop), None);
        // A 90° × 90° view on a 2:1 image: 1024 pixels span 90° across, the finer axis.
        let (q, _) = make(
            &[("float hsweep", "90"), ("float vsweep", "90")],
            Format::new(2048, 1024),
        );
        // Host rate 2s/fov with s = 512 pixels per screen unit must be 2048/90 pixels per degree.
        let Some(PropertyValue::Float(fov)) = q.property(ProjectionProperty::FieldOfView) else {
            panic!()
        };
        assert!((2.0 * 512.0 / fov - 2048.0 / 90.0).abs() < 1e-3, "{fov}");
    }

    #[test]
    fn clipping_is_spherical() {
        let mut env = ProjectionEnvironment::new(
            Format::new(8, 4),
            ScreenWindow::default_for(Format::new(8, 4)),
            (0.0, 1.0),
            (0.5, 20.0),
            Vec::new(),
        );
        let p = SphereCameraFactory
            .create_projection(&mut env, &ParamList::new())
            .unwrap();
        let r = ray_at(p.as_ref(), Point2::new(1.9, 0.2));
        assert!(r.direction.z < 0.0);
        assert_eq!((r.min_dist, r.max_dist), (0.5, 20.0));
    }

    #[test]
    fn bad_parameters_name_the_plugin_and_parameter() {
        let cases = [
            ("float hsweep", "0", "hsweep"),
            ("float hsweep", "400", "hsweep"),
            ("float vsweep", "181", "vsweep"),
        ];
        assert_refused(&SphereCameraFactory, "PxrSphereCamera", Format::new(8, 8), &cases);
    }
}
