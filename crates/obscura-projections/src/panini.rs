//! `PxrPanini`: the generalised Panini projection (Sharpless, Gennarelli and Kopf, 2010) — a wide view
//! that keeps verticals and radial lines through the centre straight.
//!
//! # Forward model
//!
//! A direction of azimuth `φ` and elevation `θ` (conventions.md: `D = (sin φ·cos θ, sin θ,
//! cos φ·cos θ)`) goes first to the unit cylinder around the vertical axis, at `(sin φ, tan θ, cos φ)`,
//! and from there by a perspective projection from the point `(0, 0, −d)` onto the plane `z = 1`:
//!
//! `S = (d + 1)/(d + cos φ)`, `X = S·sin φ`, `Y = S·tan θ`,
//!
//! `d` = `compression`: 0 is the rectilinear (pinhole) camera, 1 the classic Panini (a stereographic
//! cylinder), larger values compress the periphery further. `fov` is the angle across the image
//! **width**: the window's left and right edges sit at `X = ∓x_max`, `x_max = S(φm)·sin φm`,
//! `φm = fov/2`, and screen space maps to the Panini plane with one uniform scale
//! `g = x_max/hw` about the window's centre: `X = g·(sx − cx)`, `Y = g·(sy − cy)`.
//!
//! # Mapping (the exact inverse of the model, per screen sample)
//!
//! With `k = X/(d + 1)`, the model's `X` equation `sin φ = k·(d + cos φ)` with `sin² + cos² = 1` is a
//! quadratic in `cos φ`: `(1 + k²)·cos² φ + 2k²d·cos φ + k²d² − 1 = 0`, discriminant (over 4)
//! `Δ = 1 + k²(1 − d²)`. The root on the branch through `φ = 0` gives, without cancellation,
//!
//! - `e = d + cos φ = (d + √Δ)/(1 + k²)`, `cos φ = e − d`, `sin φ = k·e`;
//! - `tan θ = Y/S = (Y/(d + 1))·e`;
//! - `O = 0`, `D = normalize(sin φ, tan θ, cos φ)` (the cylinder point).
//!
//! Valid region: for `d ≤ 1`, `Δ > 0` for every `k` and the whole plane maps onto azimuths
//! `|φ| < acos(−d)` (90° for the rectilinear camera, 180° for the classic Panini), so nothing is culled.
//! For `d > 1` the model folds back at `cos φ = −1/d`: only `|k| < 1/sqrt(d² − 1)` is reached, and
//! samples beyond (`Δ ≤ 0`, possible only outside the window) are culled. Hence `fov` must stay below
//! `2·acos(−d)` for `d ≤ 1` (180° rectilinear, 360° classic Panini) and below `2·acos(−1/d)` for `d > 1`;
//! a larger one is an error naming the limit.
//!
//! Footprint: with `T = tan θ`, `Q = 1 + T² + (Y·sin φ/(d + 1))²`, the per-pixel turns of `D` are
//! `αx = g·Δx·(∂φ/∂X)·sqrt(Q)/(1 + T²)` with `∂φ/∂X = e/((d + 1)·√Δ)`, and
//! `αy = g·Δy·e/((d + 1)(1 + T²))`, so `origin_radius = 0` and
//! `ray_spread = ½·sqrt(αx·αy) = ½·g·sqrt(Δx·Δy)/(d + 1) · e·(Q/Δ)^¼/(1 + T²)`.
//! (For `d = 0` this is exactly `PxrPerspective`'s spread.)
//!
//! Clipping: spheres `min_dist = near`, `max_dist = far`; for `d = 0` the rectilinear camera's planes,
//! `near/D.z`, `far/D.z`.
//!
//! # Inverse
//!
//! `P` with `ρ = sqrt(P.x² + P.z²) > 0`: `cos φ = P.z/ρ`, `sin φ = P.x/ρ`, `tan θ = P.y/ρ`; visible when
//! `d + cos φ > 0` (and `cos φ ≥ −1/d` for `d > 1`), at `X`, `Y` from the model and screen
//! `(cx + X/g, cy + Y/g)`; `None` otherwise and outside the window (tolerance 10⁻⁵ of the half window).
//!
//! # Properties
//!
//! `d > 0`: DicingHint Spherical, DeepMetric RayLength (rays may point behind the camera once
//! `fov > 180°`), FieldOfView `2g/m` radians (in degrees) with `m = max(1, ∂X/∂φ, S)` at the window's
//! side edge on the horizon, `∂X/∂φ = (d + 1)(1 + d·cos φm)/(d + cos φm)²`: the host then dices at the
//! finest angular resolution found along the horizon (the periphery is stretched).
//! `d = 0`: the camera *is* a pinhole, so DicingHint Perspective, DeepMetric CameraZ and FieldOfView
//! `2·atan(g)` across the window's `[−1, 1]` square, as `PxrPerspective` reports.
//!
//! Defaults are ours (RenderMan documents none): `fov` 120°, `compression` 1.

use std::sync::LazyLock;

use obscura_sdk::{
    DeepMetric, DicingHint, ParamDecl, Point2, Projection, ProjectionContext, ProjectionEnvironment,
    ProjectionProperty, PropertyValue, RayGeometry, ValueRange, Vec3,
};

use crate::panorama::{SphericalClip, SweepWindow, degenerate_window, finite_f64};
use crate::screen;

/// The name scenes use.
pub const NAME: &str = "PxrPanini";

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    vec![
        ParamDecl::float("fov", 120.0)
            .range(ValueRange::open(0.0, 360.0))
            .doc("field of view in degrees across the image width; below 180 at compression 0, 360 at 1"),
        ParamDecl::float("compression", 1.0)
            .range(ValueRange {
                min: 0.0,
                max: f64::INFINITY,
                min_inclusive: true,
                max_inclusive: false,
            })
            .doc(
                "Panini distance d: 0 = rectilinear, 1 = classic Panini, more squeezes the periphery further",
            ),
    ]
});

/// The widest `fov` (degrees, exclusive) compression `d` can show: `2·acos(−d)` for `d ≤ 1`,
/// `2·acos(−1/d)` beyond.
#[must_use]
pub fn max_fov(d: f64) -> f64 {
    let c = if d <= 1.0 { -d } else { -1.0 / d };
    2.0 * c.acos().to_degrees()
}

/// Creates [`Panini`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct PaniniFactory;

projection_factory!(
    PaniniFactory,
    "generalised Panini: cylinder then perspective from distance d; fov across the width, d = compression",
    |env, p| {
        let (fov, d) = (p.float("fov")?, p.float("compression")?);
        let limit = max_fov(d as f64);
        if fov as f64 >= limit {
            return Err(crate::invalid(
                NAME,
                format!(
                    "\"fov\" = {fov} is too wide for \"compression\" = {d}: expected less than {limit:.4} degrees \
                 (2·acos(−d) for d ≤ 1, 2·acos(−1/d) beyond; raise the compression or narrow the fov)"
                ),
            ));
        }
        let panini = Panini::new(env, fov, d).ok_or_else(|| degenerate_window(NAME, env.screen_window()))?;
        env.set_deep_metric(panini.deep_metric());
        Ok(Box::new(panini))
    }
);

/// The generalised Panini camera (see the module documentation for its mapping).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Panini {
    window: SweepWindow,
    /// `d`.
    d: f32,
    /// `1 − d²`.
    one_minus_d2: f32,
    /// `g/(d + 1)`: screen units to `k` (and to `Y/(d + 1)`).
    k_scale: f32,
    /// Panini-plane units per screen unit.
    g: f64,
    /// `½·g·sqrt(Δx·Δy)/(d + 1)`.
    spread: f32,
    clip: SphericalClip,
    fov: f32,
}

impl Panini {
    /// A Panini camera of `fov` degrees across `env`'s window width with compression `d`; `fov` must be
    /// below [`max_fov`]`(d)`. `None` when the window has no area.
    #[must_use]
    pub fn new(env: &ProjectionEnvironment, fov: f32, d: f32) -> Option<Self> {
        let window = SweepWindow::usable(env.screen_window())?;
        let (dd, phi_m) = (d as f64, 0.5 * (fov as f64).to_radians());
        let x_max = (dd + 1.0) * phi_m.sin() / (dd + phi_m.cos());
        let g = x_max / window.hw as f64;
        let (px, py) = env.pixel_size();
        let field_of_view = if d == 0.0 {
            2.0 * g.atan()
        } else {
            let cm = phi_m.cos();
            let stretch = (dd + 1.0) * (1.0 + dd * cm) / (dd + cm).powi(2);
            let s = (dd + 1.0) / (dd + cm);
            2.0 * g / stretch.max(s).max(1.0)
        };
        Some(Panini {
            window,
            d,
            one_minus_d2: (1.0 - dd * dd) as f32,
            k_scale: (g / (dd + 1.0)) as f32,
            g,
            spread: (0.5 * g * (px as f64 * py as f64).sqrt() / (dd + 1.0)) as f32,
            clip: SphericalClip::new(env),
            fov: field_of_view.to_degrees() as f32,
        })
    }

    /// CameraZ for the rectilinear `d = 0`, RayLength otherwise.
    #[must_use]
    pub fn deep_metric(&self) -> DeepMetric {
        if self.d == 0.0 {
            DeepMetric::CameraZ
        } else {
            DeepMetric::RayLength
        }
    }

    /// The ray through screen point `s`; culled beyond the fold (`d > 1` only).
    #[inline(always)]
    #[must_use]
    pub fn ray(&self, s: Point2) -> RayGeometry {
        let k = (s.x - self.window.cx) * self.k_scale;
        let yn = (s.y - self.window.cy) * self.k_scale;
        let k2 = k * k;
        let disc = 1.0 + k2 * self.one_minus_d2;
        // Also false for NaN input.
        let usable = disc > 0.0 && yn.is_finite();
        if !usable {
            return RayGeometry::CULLED;
        }
        let root = disc.sqrt();
        let e = (self.d + root) / (1.0 + k2);
        let (sin_phi, cos_phi, tan_theta) = (k * e, e - self.d, yn * e);
        let t2 = 1.0 + tan_theta * tan_theta;
        let inv = 1.0 / (sin_phi * sin_phi + cos_phi * cos_phi + tan_theta * tan_theta).sqrt();
        let q = t2 + (yn * sin_phi) * (yn * sin_phi);
        let direction = Vec3::new(sin_phi * inv, tan_theta * inv, cos_phi * inv);
        let (min_dist, max_dist) = if self.d == 0.0 {
            (self.clip.near / direction.z, self.clip.far / direction.z)
        } else {
            (self.clip.near, self.clip.far)
        };
        RayGeometry {
            origin: Vec3::ZERO,
            origin_radius: 0.0,
            direction,
            ray_spread: self.spread * e * (q / disc).sqrt().sqrt() / t2,
            min_dist,
            max_dist,
        }
    }
}

impl Projection for Panini {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        let planar = self.d == 0.0;
        match property {
            ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(if planar {
                DicingHint::Perspective
            } else {
                DicingHint::Spherical
            })),
            ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(self.deep_metric())),
            ProjectionProperty::FieldOfView => Some(PropertyValue::Float(self.fov)),
            _ => None,
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        screen::map_rays(ctx, |s| self.ray(s));
    }

    fn unproject(&self, point: Vec3, _time: f32) -> Option<Point2> {
        let (x, y, z) = finite_f64(point)?;
        let d = self.d as f64;
        let rho = x.hypot(z);
        if rho == 0.0 {
            return None;
        }
        let (sin_phi, cos_phi) = (x / rho, z / rho);
        let e = d + cos_phi;
        if e <= 0.0 || (d > 1.0 && cos_phi < -1.0 / d) {
            return None;
        }
        let scale = (d + 1.0) / e;
        let (big_x, big_y) = (scale * sin_phi, scale * y / rho);
        let (hw, hh) = (self.window.hw as f64, self.window.hh as f64);
        self.window.screen(big_x / self.g / hw, big_y / self.g / hh)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{
        self, ContractTest, assert_camera_z, assert_contract, check_centred_roundtrip, ray_at,
    };
    use obscura_sdk::{Format, ParamList, ProjectionFactory};
    use proptest::prelude::*;

    fn make(fov: f32, d: f32, format: Format) -> (Box<dyn Projection>, ProjectionEnvironment) {
        let (fov, d) = (fov.to_string(), d.to_string());
        testing::make_env(
            &PaniniFactory,
            &[("float fov", &fov), ("float compression", &d)],
            format,
        )
    }

    /// The forward model in f64: direction → Panini plane.
    fn forward(dir: [f64; 3], d: f64) -> (f64, f64) {
        let rho = dir[0].hypot(dir[2]);
        let (phi, tan_theta) = (dir[0].atan2(dir[2]), dir[1] / rho);
        let s = (d + 1.0) / (d + phi.cos());
        (s * phi.sin(), s * tan_theta)
    }

    proptest! {
        #[test]
        fn rays_land_where_the_forward_model_puts_them(
            u in -1.0f32..=1.0, v in -1.0f32..=1.0, d in 0.0f32..3.0, f in 0.05f32..0.99,
        ) {
            let fov = (max_fov(d as f64) as f32 * f).min(359.0);
            let format = Format::new(96, 64);
            let (p, env) = make(fov, d, format);
            let w = env.screen_window();
            let s = Point2::new(u * w.right, v * w.top);
            let r = ray_at(p.as_ref(), s);
            prop_assert!((r.direction.length() - 1.0).abs() < 1e-6, "{r:?}");
            let dir = [r.direction.x as f64, r.direction.y as f64, r.direction.z as f64];
            let (x, y) = forward(dir, d as f64);
            // The window's width spans fov: x_max = S(φm)·sin φm.
            let phi_m = (fov as f64 / 2.0).to_radians();
            let x_max = (d as f64 + 1.0) * phi_m.sin() / (d as f64 + phi_m.cos());
            let g = x_max / w.right as f64;
            let tol = 2e-5 * (1.0 + g * (s.x.abs() + s.y.abs()) as f64);
            prop_assert!((x - g * s.x as f64).abs() < tol && (y - g * s.y as f64).abs() < tol,
                "({x}, {y}) vs ({}, {})", g * s.x as f64, g * s.y as f64);
        }

        #[test]
        fn unproject_inverts_project(
            u in -1.0f32..=1.0, v in -1.0f32..=1.0, d in 0.0f32..3.0, f in 0.05f32..0.95, depth in 0.01f32..1000.0,
        ) {
            let fov = (max_fov(d as f64) as f32 * f).min(359.0);
            let format = Format::new(300, 200);
            let (p, env) = make(fov, d, format);
            check_centred_roundtrip(p.as_ref(), &env, u, v, depth)?;
        }
    }

    #[test]
    fn compression_zero_is_the_rectilinear_camera_of_the_same_horizontal_fov() {
        let format = Format::new(64, 40);
        let (pan, env) = make(100.0, 0.0, format);
        // PxrPerspective's fov spans the [−1, 1] square: tan(fov_p/2) = tan(50°)/a.
        let a = env.screen_window().right as f64;
        let fov_p = 2.0 * (50f64.to_radians().tan() / a).atan().to_degrees();
        let mut list = ParamList::new();
        list.push_text("float fov", &[&fov_p.to_string()], None).unwrap();
        let persp = crate::PerspectiveFactory
            .create_projection(&mut ProjectionEnvironment::for_format(format), &list)
            .unwrap();
        for s in [
            Point2::new(0.0, 0.0),
            Point2::new(1.6, 1.0),
            Point2::new(-0.7, -0.9),
            Point2::new(1.5, -0.2),
        ] {
            let (a, b) = (ray_at(pan.as_ref(), s), ray_at(persp.as_ref(), s));
            assert!(
                (a.direction - b.direction).length() < 2e-6,
                "{s:?}: {a:?} vs {b:?}"
            );
            assert!((a.ray_spread / b.ray_spread - 1.0).abs() < 1e-4, "{s:?}");
            assert!((a.min_dist / b.min_dist - 1.0).abs() < 1e-5, "{s:?}");
        }
        assert_camera_z(pan.as_ref(), DicingHint::Perspective, None);
        let Some(PropertyValue::Float(f)) = pan.property(ProjectionProperty::FieldOfView) else {
            panic!()
        };
        assert!((f as f64 - fov_p).abs() < 1e-3, "{f} vs {fov_p}");
    }

    #[test]
    fn classic_panini_keeps_the_horizon_and_verticals() {
        let (p, env) = make(300.0, 1.0, Format::new(120, 40));
        let w = env.screen_window();
        // The window's right edge on the horizon is at azimuth fov/2 — behind the camera.
        let edge = ray_at(p.as_ref(), Point2::new(w.right, 0.0)).direction;
        assert!(
            (edge.x.atan2(edge.z).to_degrees() - 150.0).abs() < 1e-3,
            "{edge:?}"
        );
        assert!(edge.z < 0.0);
        // A screen column is one azimuth (verticals stay vertical); d = 1: φ = 2·atan(X/2).
        let g = (2.0 * 150f64.to_radians().sin() / (1.0 + 150f64.to_radians().cos())) / w.right as f64;
        for sy in [-1.0f32, 0.0, 0.6] {
            let d = ray_at(p.as_ref(), Point2::new(0.8, sy)).direction;
            let expected = 2.0 * (g * 0.8 / 2.0).atan();
            assert!((d.x.atan2(d.z) as f64 - expected).abs() < 2e-6);
        }
        assert_eq!(
            p.property(ProjectionProperty::DeepMetric),
            Some(PropertyValue::DeepMetric(DeepMetric::RayLength))
        );
    }

    #[test]
    fn beyond_the_fold_is_culled_and_nothing_is_nan() {
        // d = 2 folds at cos φ = −1/2 (±120°): fov 200 leaves the fold 40° past each side edge.
        let (p, env) = make(200.0, 2.0, Format::new(40, 40));
        let w = env.screen_window();
        let mut culled = 0;
        for i in 0..=400 {
            let sx = -12.0 + 24.0 * i as f32 / 400.0;
            let r = ray_at(p.as_ref(), Point2::new(sx, 0.3));
            assert!(r.direction.is_finite() && r.ray_spread.is_finite());
            if r.is_culled() {
                culled += 1;
                assert!(sx.abs() > w.right);
            } else {
                assert!((r.direction.length() - 1.0).abs() < 1e-6);
                assert!(r.direction.x.atan2(r.direction.z).abs().to_degrees() <= 120.001);
            }
        }
        assert!(culled > 100);
        assert_eq!(
            ray_at(p.as_ref(), Point2::new(f32::NAN, 0.0)),
            RayGeometry::CULLED
        );
        // Directions past the fold are not seen.
        assert_eq!(p.unproject(Vec3::new(1.0, 0.0, -1.0), 0.0), None);
        assert_eq!(p.unproject(Vec3::new(0.0, 1.0, 0.0), 0.0), None);
    }

    #[test]
    fn keeps_the_contract() {
        for (fov, d, format) in [
            (120.0, 1.0, Format::new(48, 32)),
            (170.0, 0.0, Format::new(40, 30)),
            (300.0, 1.0, Format::new(60, 24)),
            (90.0, 0.5, Format::new(30, 40)),
            (150.0, 3.0, Format::new(40, 30)),
        ] {
            let (p, _) = make(fov, d, format);
            let stats = assert_contract(p.as_ref(), &ContractTest::new(format));
            assert!(
                stats.roundtrips > 1000 && stats.spread_checked > 1000,
                "{fov} {d}: {stats:?}"
            );
        }
    }

    #[test]
    fn too_wide_a_fov_names_the_limit() {
        for (fov, d, limit) in [
            ("180", "0", "180.0000"),
            ("300", "0.5", "240.0000"),
            ("250", "2", "240.0000"),
        ] {
            let mut list = ParamList::new();
            list.push_text("float fov", &[fov], None).unwrap();
            list.push_text("float compression", &[d], None).unwrap();
            let mut env = ProjectionEnvironment::for_format(Format::new(8, 8));
            let err = PaniniFactory
                .create_projection(&mut env, &list)
                .err()
                .unwrap()
                .to_string();
            assert!(err.starts_with("PxrPanini: \"fov\""), "{err}");
            assert!(err.contains(limit), "{err}");
        }
        let mut list = ParamList::new();
        list.push_text("float compression", &["-1"], None).unwrap();
        let err = PaniniFactory
            .create_projection(&mut ProjectionEnvironment::for_format(Format::new(8, 8)), &list)
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("\"compression\""), "{err}");
    }
}
