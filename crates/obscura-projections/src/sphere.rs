//! `PxrSphereCamera`: the spherical (latitude–longitude) panorama; equirectangular at its defaults.
//!
//! # Mapping
//!
//! With the screen window `(l, r, b, t)` and a screen sample `(sx, sy)`, the window coordinates
//! `u = (sx − cx)/hw`, `v = (sy − cy)/hh` (`cx, cy` the window's centre, `hw, hh` its half width and
//! height) run over `[−1, 1]` across the window (conventions.md, "panoramic projections";
//! [`crate::panorama`]):
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

use std::sync::LazyLock;

use obscura_sdk::{ParamDecl, Point2, ProjectionEnvironment, RayGeometry, Vec3};

use crate::panorama::{
    AzimuthSweep, CentredLane, SphericalClip, boxed_sweep, direction_angles, hsweep_param,
    lat_long_field_of_view, radians_toward_zero, sin_cos, vsweep_param,
};

/// The name scenes use.
pub const NAME: &str = "PxrSphereCamera";

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| vec![hsweep_param(), vsweep_param()]);

/// Creates [`SphereCamera`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct SphereCameraFactory;

projection_factory!(
    SphereCameraFactory,
    "latitude-longitude panorama: azimuth u*hsweep/2, elevation v*vsweep/2 over the window (equirectangular)",
    |env, p| boxed_sweep(NAME, env, p, SphereCamera::new)
);

/// The spherical panorama (see the module documentation for its mapping).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereCamera {
    sweep: AzimuthSweep,
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
        let (w, h) = (env.width() as f64, env.height() as f64);
        let (hs, vs) = (hsweep as f64, vsweep as f64);
        Some(SphereCamera {
            sweep: AzimuthSweep::new(env.screen_window(), hsweep)?,
            half_v: radians_toward_zero(0.5 * vs),
            spread: (0.5 * (hs.to_radians() * vs.to_radians() / (w * h)).sqrt()) as f32,
            clip: SphericalClip::new(env),
            fov: lat_long_field_of_view(env, hsweep, vsweep),
        })
    }

    /// The ray through screen point `s`.
    #[inline(always)]
    #[must_use]
    pub fn ray(&self, s: Point2) -> RayGeometry {
        self.clip.lane_ray(self.lane(s))
    }

    /// [`SphereCamera::ray`] without branches, for the batch loop.
    #[inline(always)]
    fn lane(&self, s: Point2) -> CentredLane {
        let (u, v) = self.sweep.window.uv(s);
        let (sp, cp) = sin_cos(u * self.sweep.half_h);
        let (st, ct) = sin_cos(v * self.half_v);
        CentredLane {
            valid: !u.is_nan() & !v.is_nan(),
            direction: Vec3::new(sp * ct, st, cp * ct),
            ray_spread: self.spread * ct.abs().sqrt(),
        }
    }
}

spherical_projection!(SphereCamera, |camera: &SphereCamera| camera.fov, lanes);

impl SphereCamera {
    /// The screen point that sees the camera-space point `(x, y, z)`, finite: the inverse.
    fn screen_of(&self, x: f64, y: f64, z: f64) -> Option<Point2> {
        if x == 0.0 && y == 0.0 && z == 0.0 {
            return None;
        }
        let (phi, theta) = direction_angles(x, y, z);
        self.sweep.screen(phi, theta / self.half_v as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{
        self, assert_refused, assert_spherical_ray_length, assert_sweeps_keep_contract,
        check_sweep_roundtrip, ray_at,
    };
    use obscura_sdk::{
        Format, ParamList, Projection, ProjectionFactory, ProjectionProperty, PropertyValue, ScreenWindow,
    };
    use proptest::prelude::*;

    fn make(params: &[(&str, &str)], format: Format) -> (Box<dyn Projection>, ProjectionEnvironment) {
        testing::make_env(&SphereCameraFactory, params, format)
    }

    proptest! {
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
            check_sweep_roundtrip(&SphereCameraFactory, (hsweep, vsweep), u, v, depth)?;
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
        assert_sweeps_keep_contract(&SphereCameraFactory, [("120", "90"), ("360", "30")]);
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
