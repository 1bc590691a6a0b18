//! `PxrCylinderCamera`: the cylindrical panorama — azimuth linear in screen x, screen y linear in the
//! tangent of the elevation (a pinhole's vertical mapping wrapped around a vertical axis).
//!
//! # Mapping
//!
//! With the window coordinates `u, v ∈ [−1, 1]` of conventions.md (see [`crate::panorama::SweepWindow`]):
//!
//! - azimuth `φ = u·hsweep/2`; height on the unit cylinder `y = v·tan(vsweep/2)`, so the elevation is
//!   `θ = atan(y)` and the window's top and bottom edges are at `±vsweep/2`;
//! - `O = 0`, `D = (sin φ, y, cos φ)/L` with `L = sqrt(1 + y²)`;
//! - footprint: one pixel turns `D` by `αx = (hsweep/W)/L` along x and `αy = (2·tan(vsweep/2)/H)/L²`
//!   along y (radians), so `origin_radius = 0` and
//!   `ray_spread = ½·sqrt(αx·αy) = sqrt(hsweep·tan(vsweep/2)/(2·W·H))·L^(−3/2)` (hsweep in radians);
//! - clipping: spheres around the camera, `min_dist = near`, `max_dist = far`.
//!
//! `vsweep` must be below 180°: the cylinder's height grows as `tan(vsweep/2)`. Samples from outside the
//! window continue the formula (the azimuth wraps past the seam); nothing is culled.
//!
//! # Inverse
//!
//! `P` with horizontal distance `ρ = sqrt(P.x² + P.z²) > 0` is seen at `u = atan2(P.x, P.z)/(hsweep/2)`,
//! `v = (P.y/ρ)/tan(vsweep/2)`; `None` on the axis and outside the sweep (tolerance 10⁻⁵ of the half
//! window).
//!
//! # Properties
//!
//! DicingHint Spherical; DeepMetric RayLength (also set in the environment); FieldOfView from the finest
//! angular resolution, at the image centre: `max(W/hsweep, H/(2·tan(vsweep/2)))` pixels per radian, as
//! `2·s/that` (see [`crate::panorama::spherical_field_of_view`]).

use std::sync::LazyLock;

use obscura_sdk::{ParamDecl, Point2, ProjectionEnvironment, RayGeometry, ValueRange, Vec3};

use crate::panorama::{
    AzimuthSweep, CentredLane, SphericalClip, boxed_sweep, hsweep_param, sin_cos, spherical_field_of_view,
};

/// The name scenes use.
pub const NAME: &str = "PxrCylinderCamera";

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    vec![
        hsweep_param(),
        ParamDecl::float("vsweep", 90.0)
            .range(ValueRange::open(0.0, 180.0))
            .doc("vertical field of view in degrees across the window's height; screen y is linear in tan(elevation)"),
    ]
});

/// Creates [`CylinderCamera`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct CylinderCameraFactory;

projection_factory!(
    CylinderCameraFactory,
    "cylindrical panorama: azimuth u*hsweep/2, height v*tan(vsweep/2) on the unit cylinder",
    |env, p| boxed_sweep(NAME, env, p, CylinderCamera::new)
);

/// The cylindrical panorama (see the module documentation for its mapping).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CylinderCamera {
    sweep: AzimuthSweep,
    /// `tan(vsweep/2)`.
    tan_v: f32,
    /// `½·sqrt(αx·αy)` at the horizon.
    spread: f32,
    clip: SphericalClip,
    fov: f32,
}

impl CylinderCamera {
    /// A cylinder of `hsweep` degrees around and `vsweep < 180` degrees up and down over `env`'s screen
    /// window; `None` when the window has no area.
    #[must_use]
    pub fn new(env: &ProjectionEnvironment, hsweep: f32, vsweep: f32) -> Option<Self> {
        let sweep = AzimuthSweep::new(env.screen_window(), hsweep)?;
        let (w, h) = (env.width() as f64, env.height() as f64);
        let hs = (hsweep as f64).to_radians();
        let tan_v = (0.5 * (vsweep as f64).to_radians()).tan();
        let pixels_per_radian = (w / hs).max(h / (2.0 * tan_v));
        Some(CylinderCamera {
            sweep,
            tan_v: tan_v as f32,
            spread: (hs * tan_v / (2.0 * w * h)).sqrt() as f32,
            clip: SphericalClip::new(env),
            fov: spherical_field_of_view(env, pixels_per_radian.to_radians()),
        })
    }

    /// The ray through screen point `s`.
    #[inline(always)]
    #[must_use]
    pub fn ray(&self, s: Point2) -> RayGeometry {
        self.clip.lane_ray(self.lane(s))
    }

    /// [`CylinderCamera::ray`] without branches, for the batch loop.
    #[inline(always)]
    fn lane(&self, s: Point2) -> CentredLane {
        let (u, v) = self.sweep.window.uv(s);
        let (sp, cp) = sin_cos(u * self.sweep.half_h);
        let y = v * self.tan_v;
        let inv_l = 1.0 / (1.0 + y * y).sqrt();
        CentredLane {
            valid: !u.is_nan() & !v.is_nan(),
            direction: Vec3::new(sp * inv_l, y * inv_l, cp * inv_l),
            ray_spread: self.spread * inv_l * inv_l.sqrt(),
        }
    }
}

spherical_projection!(CylinderCamera, |camera: &CylinderCamera| camera.fov, lanes);

impl CylinderCamera {
    /// The screen point that sees the camera-space point `(x, y, z)`, finite: the inverse.
    fn screen_of(&self, x: f64, y: f64, z: f64) -> Option<Point2> {
        let rho = x.hypot(z);
        if rho == 0.0 {
            return None;
        }
        self.sweep.screen(x.atan2(z), y / rho / self.tan_v as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{
        self, assert_refused, assert_spherical_ray_length, assert_sweeps_keep_contract,
        check_sweep_roundtrip, ray_at,
    };
    use obscura_sdk::{Format, Projection, ProjectionProperty, PropertyValue};
    use proptest::prelude::*;

    fn make(params: &[(&str, &str)], format: Format) -> (Box<dyn Projection>, ProjectionEnvironment) {
        testing::make_env(&CylinderCameraFactory, params, format)
    }

    proptest! {
        #[test]
        fn directions_match_the_closed_form(
            sx in -2.2f32..2.2, sy in -1.1f32..1.1, hsweep in 10.0f32..=360.0, vsweep in 10.0f32..170.0,
        ) {
            let (p, _) = make(&[("float hsweep", &hsweep.to_string()), ("float vsweep", &vsweep.to_string())], Format::new(200, 100));
            let r = ray_at(p.as_ref(), Point2::new(sx, sy));
            // Independent form: azimuth and elevation, then the spherical direction.
            let phi = (sx as f64 / 2.0) * (hsweep as f64).to_radians() / 2.0;
            let theta = (sy as f64 * (vsweep as f64 / 2.0).to_radians().tan()).atan();
            let e = [phi.sin() * theta.cos(), theta.sin(), phi.cos() * theta.cos()];
            let d = [r.direction.x as f64, r.direction.y as f64, r.direction.z as f64];
            for k in 0..3 {
                prop_assert!((d[k] - e[k]).abs() < 1e-6, "{d:?} vs {e:?}");
            }
        }

        #[test]
        fn unproject_inverts_project(
            u in -1.0f32..=1.0, v in -1.0f32..=1.0, depth in 0.01f32..1000.0,
            hsweep in 1.0f32..=360.0, vsweep in 1.0f32..175.0,
        ) {
            check_sweep_roundtrip(&CylinderCameraFactory, (hsweep, vsweep), u, v, depth)?;
        }
    }

    #[test]
    fn edges_are_at_half_the_sweeps_and_verticals_stay_straight() {
        let (p, env) = make(
            &[("float hsweep", "180"), ("float vsweep", "100")],
            Format::new(80, 40),
        );
        let w = env.screen_window();
        assert!((ray_at(p.as_ref(), Point2::ZERO).direction - Vec3::Z).length() < 1e-7);
        let right = ray_at(p.as_ref(), Point2::new(w.right, 0.0)).direction;
        assert!((right - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-6, "{right:?}");
        let top = ray_at(p.as_ref(), Point2::new(0.0, w.top)).direction;
        assert!((top.y.asin().to_degrees() - 50.0).abs() < 1e-4);
        // A screen column is one azimuth: every ray of it lies in one vertical plane.
        for sy in [-1.0f32, -0.2, 0.7, 1.0] {
            let d = ray_at(p.as_ref(), Point2::new(0.6, sy)).direction;
            assert!(
                (d.x.atan2(d.z) - 0.15 * std::f32::consts::PI).abs() < 1e-6,
                "{d:?}"
            );
        }
        // Screen y is linear in tan(elevation): halfway up is at half the top's tangent.
        let mid = ray_at(p.as_ref(), Point2::new(0.0, 0.5)).direction;
        assert!((mid.y / mid.z - 0.5 * 50f32.to_radians().tan()).abs() < 1e-6);
    }

    #[test]
    fn keeps_the_contract() {
        assert_sweeps_keep_contract(&CylinderCameraFactory, [("150", "160"), ("360", "20")]);
    }

    #[test]
    fn properties_are_honest() {
        let (p, env) = make(&[], Format::new(1024, 256));
        assert_spherical_ray_length(p.as_ref(), Some(&env), None);
        // Host rate 2s/fov (s = 128 px per screen unit) equals the finer of 1024/2π and 256/(2·tan 45°).
        let Some(PropertyValue::Float(fov)) = p.property(ProjectionProperty::FieldOfView) else {
            panic!()
        };
        let host = 2.0 * 128.0 / fov.to_radians() as f64;
        let finest = (1024.0 / std::f64::consts::TAU).max(128.0);
        assert!((host - finest).abs() < 1e-3, "{host} vs {finest}");
    }

    #[test]
    fn bad_parameters_name_the_plugin_and_parameter() {
        let cases = [
            ("float hsweep", "-5", "hsweep"),
            ("float vsweep", "180", "vsweep"),
            ("float vsweep", "0", "vsweep"),
        ];
        assert_refused(
            &CylinderCameraFactory,
            "PxrCylinderCamera",
            Format::new(8, 8),
            &cases,
        );
    }
}
