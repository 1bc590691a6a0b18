//! `OmnidirectionalStereo`: one eye of an omni-directional stereo (ODS) panorama for VR.
//!
//! Each column of the panorama is seen by an eye standing on the *viewing circle* (radius half the
//! interpupillary distance) at the place where that column's view direction is tangent to it, so every
//! direction is seen with the right parallax for a head turned toward it.
//!
//! # Mapping
//!
//! With the window coordinates `u, v ∈ [−1, 1]` of conventions.md ([`crate::panorama::SweepWindow`]):
//!
//! - azimuth `φ = u·hsweep/2`, elevation `θ = v·vsweep/2` (equirectangular at the defaults 360 × 180);
//!   the centre direction `Dc = (sin φ·cos θ, sin θ, cos φ·cos θ)`;
//! - eye offset `R(θ) = σ·(IPD/2)·w(θ)` with `σ = +1` for the left eye, −1 for the right, 0 for
//!   `"center"`, and the pole merge `w(θ) = 1 − smoothstep((|θ| − from)/(to − from))`
//!   (`smoothstep(t) = 3t² − 2t³` on `[0, 1]`, a step when `from = to`): full separation below
//!   `poleMergeFrom`, none above `poleMergeTo`, so the eyes meet at the poles and the panorama has no
//!   swirl there;
//! - origin `O = R·(−cos φ, 0, sin φ)`: the camera's right for azimuth `φ` is `(cos φ, 0, −sin φ)` in
//!   this left-handed, +Y-up space, so the left eye sits at `−(IPD/2)·right` — for the forward column at
//!   `x = −IPD/2`. This is renderman-projection-api.md §3.3's `O = (IPD/2)(−sin β, 0, −cos β)`,
//!   `β = φ ± π/2` (+ left);
//! - direction: parallel eyes (`convergenceDistance` 0 or ∞, the default) `D = Dc`; converged at
//!   distance `C`: `D = normalize(C·Dc − O)`, so the two eyes' rays of a pixel meet at the point
//!   `C·Dc` (toe-in). `|C·Dc − O| = Λ = sqrt(C² + R²)` because `O ⊥ Dc`;
//! - clipping: spheres around each ray's origin, `min_dist = near`, `max_dist = far`.
//!
//! # Footprint
//!
//! With `Δφ = hsweep/W`, `Δθ = vsweep/H` (radians per pixel) and `R' = dR/dθ`, one pixel turns `D` by
//! `αx = Δφ·sqrt(C²cos²θ + R²)/Λ` and `αy = Δθ·C·sqrt(Λ² + R'²)/Λ²` (parallel: `αx = Δφ·|cos θ|`,
//! `αy = Δθ`), and moves the origin *across the ray* by `ox = Δφ·|R|·sqrt(C² sin²θ + R²)/Λ` and
//! `oy = Δθ·|R'|·C/Λ` (parallel: `Δφ·|R sin θ|` and `Δθ·|R'|`; along a column the origin only moves
//! inside the pole-merge band). The cone `origin_radius + ray_spread·t` is then
//! `origin_radius = ½·sqrt(ox·oy)` and `ray_spread = ½·sqrt(αx·αy)`: the same half-pixel geometric mean
//! as every other projection, taken separately for the spread of the origins and of the directions.
//!
//! # Inverse
//!
//! For a point `P` (azimuth `ψ`, horizontal distance `ρ`, height `y`), write `δ = ψ − φ`. In the frame
//! of azimuth `φ` the point is `(ρ sin δ, y, ρ cos δ)` (right, up, forward) and the ray
//! `(−R, 0, 0) + s·(R, C sin θ, C cos θ)`, so `θ = atan2(y, ρ cos δ)` and δ solves
//! `g(δ) = ρ·sin δ + R(θ(δ))·q(δ) = 0`, `q = 1 − sqrt(y² + ρ² cos² δ)/C` (1 for parallel eyes). Without
//! pole merging and convergence this is the tangent construction `sin δ = −R/ρ` in closed form; that is
//! the start of a Newton iteration (f64) which converges in a few steps. `φ` and `θ` are finally read
//! off `Dc ∝ (P − O)·Λ/|P − O| + O`, which keeps the seam's two sides apart. `None` for points inside
//! the viewing circle's reach (no ray passes through them) and outside the sweep.
//!
//! # Properties
//!
//! DicingHint Spherical, DeepMetric RayLength (also set in the environment), FieldOfView as
//! `PxrSphereCamera` (the equator's resolution): the eye offset is a few centimetres and does not change
//! the angular density.

use std::sync::LazyLock;

use obscura_sdk::{ParamDecl, Point2, ProjectionEnvironment, RayGeometry, ValueRange, Vec3};

use crate::panorama::{
    AzimuthSweep, SphericalClip, boxed_spherical, direction_angles, hsweep_param, lat_long_field_of_view,
    radians_toward_zero, sin_cos, vsweep_param,
};

/// The name scenes use.
pub const NAME: &str = "OmnidirectionalStereo";

/// Which eye the panorama is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Eye {
    /// The left eye: offset to the left of each view direction.
    #[default]
    Left,
    /// The right eye.
    Right,
    /// No offset: a monoscopic panorama from the centre of the head.
    Center,
}

impl Eye {
    /// `+1` left, `−1` right, `0` centre: the sign of the offset along `(−cos φ, 0, sin φ)`.
    #[must_use]
    pub fn sign(self) -> f32 {
        match self {
            Eye::Left => 1.0,
            Eye::Right => -1.0,
            Eye::Center => 0.0,
        }
    }
}

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    let angle = ValueRange::closed(0.0, 90.0);
    vec![
        ParamDecl::float("interpupilaryDistance", 0.0635)
            .range(ValueRange {
                min: 0.0,
                max: f64::INFINITY,
                min_inclusive: true,
                max_inclusive: false,
            })
            .doc("distance between the eyes in scene units; the eyes sit on a circle of half this radius"),
        ParamDecl::string("eye", "left")
            .choices(&["left", "right", "center"])
            .doc("which eye this panorama is for; center = no offset (mono)"),
        ParamDecl::float("convergenceDistance", f32::INFINITY)
            .range(ValueRange::at_least(0.0))
            .doc("distance at which the two eyes' rays of a pixel meet (toe-in); 0 or inf = parallel"),
        ParamDecl::float("poleMergeFrom", 60.0)
            .range(angle)
            .doc("elevation in degrees where the eye offset starts fading out toward the poles"),
        ParamDecl::float("poleMergeTo", 75.0)
            .range(angle)
            .doc("elevation in degrees from which the eyes coincide (no swirl at the poles)"),
        hsweep_param(),
        vsweep_param(),
    ]
});

/// Creates [`OmnidirectionalStereo`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct OmnidirectionalStereoFactory;

projection_factory!(
    OmnidirectionalStereoFactory,
    "omni-directional stereo panorama: equirectangular directions from eyes on the viewing circle, pole merging",
    |env, p| {
        let invalid = |message: String| crate::invalid(NAME, message);
        let eye = match p.string("eye")? {
            "right" => Eye::Right,
            "center" => Eye::Center,
            _ => Eye::Left,
        };
        let ipd = p.float("interpupilaryDistance")?;
        let (from, to) = (p.float("poleMergeFrom")?, p.float("poleMergeTo")?);
        if from > to {
            return Err(invalid(format!(
                "\"poleMergeFrom\" = {from} is above \"poleMergeTo\" = {to}: expected poleMergeFrom ≤ poleMergeTo"
            )));
        }
        let c = p.float("convergenceDistance")?;
        let convergence = (c > 0.0 && c.is_finite()).then_some(c);
        if let Some(c) = convergence
            && c <= 0.5 * ipd
        {
            return Err(invalid(format!(
                "\"convergenceDistance\" = {c} must exceed half the interpupilaryDistance ({}), or be 0/inf for parallel eyes",
                0.5 * ipd
            )));
        }
        let settings = OdsSettings {
            ipd,
            eye,
            convergence,
            pole_merge: (from, to),
            hsweep: p.float("hsweep")?,
            vsweep: p.float("vsweep")?,
        };
        let ods = OmnidirectionalStereo::new(env, &settings);
        boxed_spherical(NAME, env, ods)
    }
);

/// The parameters of an [`OmnidirectionalStereo`] camera, angles in degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdsSettings {
    /// Interpupillary distance, scene units.
    pub ipd: f32,
    /// Which eye.
    pub eye: Eye,
    /// Convergence distance; `None` for parallel eyes.
    pub convergence: Option<f32>,
    /// `(poleMergeFrom, poleMergeTo)`, degrees of elevation, `from ≤ to`.
    pub pole_merge: (f32, f32),
    /// Horizontal sweep.
    pub hsweep: f32,
    /// Vertical sweep.
    pub vsweep: f32,
}

/// One eye's ODS panorama (see the module documentation for its mapping).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OmnidirectionalStereo {
    sweep: AzimuthSweep,
    /// `vsweep/2` in radians, rounded toward zero.
    half_v: f32,
    /// `σ·IPD/2`.
    offset: f32,
    /// Pole merge start and end, radians.
    merge_from: f32,
    merge_to: f32,
    /// Convergence distance, `None` = parallel.
    convergence: Option<f32>,
    /// Radians per pixel along x and y.
    dphi: f32,
    dtheta: f32,
    clip: SphericalClip,
    fov: f32,
}

impl OmnidirectionalStereo {
    /// One eye's panorama over `env`'s screen window; `None` when the window has no area.
    #[must_use]
    pub fn new(env: &ProjectionEnvironment, s: &OdsSettings) -> Option<Self> {
        let (w, h) = (env.width() as f64, env.height() as f64);
        let (hs, vs) = (s.hsweep as f64, s.vsweep as f64);
        Some(OmnidirectionalStereo {
            sweep: AzimuthSweep::new(env.screen_window(), s.hsweep)?,
            half_v: radians_toward_zero(0.5 * vs),
            offset: s.eye.sign() * 0.5 * s.ipd,
            merge_from: s.pole_merge.0.to_radians(),
            merge_to: s.pole_merge.1.to_radians(),
            convergence: s.convergence,
            dphi: (hs.to_radians() / w) as f32,
            dtheta: (vs.to_radians() / h) as f32,
            clip: SphericalClip::new(env),
            fov: lat_long_field_of_view(env, s.hsweep, s.vsweep),
        })
    }

    /// The signed eye offset `R(θ)` and its derivative `dR/dθ`.
    #[inline(always)]
    #[must_use]
    pub fn offset_at(&self, theta: f32) -> (f32, f32) {
        let a = theta.abs();
        let span = self.merge_to - self.merge_from;
        if span <= 0.0 {
            let r = if a < self.merge_from { self.offset } else { 0.0 };
            return (r, 0.0);
        }
        let t = ((a - self.merge_from) / span).clamp(0.0, 1.0);
        let w = 1.0 - t * t * (3.0 - 2.0 * t);
        let dw = -6.0 * t * (1.0 - t) / span * theta.signum();
        (self.offset * w, self.offset * dw)
    }

    /// The ray through screen point `s`.
    #[inline(always)]
    #[must_use]
    pub fn ray(&self, s: Point2) -> RayGeometry {
        let Some((phi, v)) = self.sweep.azimuth_and_v(s) else {
            return RayGeometry::CULLED;
        };
        let theta = v * self.half_v;
        let (sp, cp) = sin_cos(phi);
        let (st, ct) = sin_cos(theta);
        let (r, dr) = self.offset_at(theta);
        let origin = Vec3::new(-r * cp, 0.0, r * sp);
        let centre = Vec3::new(sp * ct, st, cp * ct);
        let (direction, ax, ay, ox, oy) = match self.convergence {
            None => (centre, ct.abs(), 1.0, (r * st).abs(), dr.abs()),
            Some(c) => {
                let v = centre * c - origin;
                let lambda2 = c * c + r * r;
                let lambda = lambda2.sqrt();
                (
                    v * (1.0 / v.length()),
                    (c * c * ct * ct + r * r).sqrt() / lambda,
                    c * (lambda2 + dr * dr).sqrt() / lambda2,
                    r.abs() * (c * c * st * st + r * r).sqrt() / lambda,
                    dr.abs() * c / lambda,
                )
            }
        };
        let (px, py) = (self.dphi, self.dtheta);
        RayGeometry {
            origin,
            origin_radius: 0.5 * (ox * px * oy * py).sqrt(),
            direction,
            ray_spread: 0.5 * (ax * px * ay * py).sqrt(),
            min_dist: self.clip.near,
            max_dist: self.clip.far,
        }
    }

    /// `R(θ)` and `dR/dθ` in f64, for the inverse.
    fn offset_at_f64(&self, theta: f64) -> (f64, f64) {
        let (from, to, off) = (self.merge_from as f64, self.merge_to as f64, self.offset as f64);
        let a = theta.abs();
        let span = to - from;
        if span <= 0.0 {
            return (if a < from { off } else { 0.0 }, 0.0);
        }
        let t = ((a - from) / span).clamp(0.0, 1.0);
        (
            off * (1.0 - t * t * (3.0 - 2.0 * t)),
            -off * 6.0 * t * (1.0 - t) / span * theta.signum(),
        )
    }
}

spherical_projection!(OmnidirectionalStereo, |camera: &OmnidirectionalStereo| camera.fov);

impl OmnidirectionalStereo {
    /// The screen point that sees the camera-space point `(px, py, pz)`, finite: the inverse.
    fn screen_of(&self, px: f64, py: f64, pz: f64) -> Option<Point2> {
        let p = [px, py, pz];
        let (rho, y) = (p[0].hypot(p[2]), p[1]);
        let psi = p[0].atan2(p[2]);
        let inv_c = self.convergence.map_or(0.0, |c| 1.0 / c as f64);
        // g(δ) = ρ sin δ + R(θ(δ))·q(δ) and its derivative.
        let eval = |delta: f64| {
            let (sd, cd) = delta.sin_cos();
            let fwd = rho * cd;
            let m2 = y * y + fwd * fwd;
            let m = m2.sqrt();
            let theta = y.atan2(fwd);
            let (r, dr) = self.offset_at_f64(theta);
            let q = 1.0 - m * inv_c;
            let dtheta = if m2 > 0.0 { y * rho * sd / m2 } else { 0.0 };
            let dq = if m > 0.0 {
                rho * rho * cd * sd * inv_c / m
            } else {
                0.0
            };
            (rho * sd + r * q, rho * cd + dr * dtheta * q + r * dq, r)
        };
        // Start: the tangent construction with the offset and q at the point's own elevation.
        let (r0, _) = self.offset_at_f64(y.atan2(rho));
        let q0 = 1.0 - y.hypot(rho) * inv_c;
        let mut delta = if rho > 0.0 {
            (-r0 * q0 / rho).clamp(-1.0, 1.0).asin()
        } else {
            0.0
        };
        for _ in 0..32 {
            let (g, dg, _) = eval(delta);
            if dg == 0.0 || !dg.is_finite() {
                break;
            }
            let step = g / dg;
            delta = (delta - step).clamp(-std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2);
            if step.abs() < 1e-15 {
                break;
            }
        }
        let (g, _, r) = eval(delta);
        let solved = g.abs() <= 1e-9 * (rho + r.abs() + y.abs());
        if !solved || delta.cos() < 0.0 {
            return None;
        }
        // Read φ, θ off Dc ∝ (P − O)·Λ/|P − O| + O, seam-safe.
        let phi = psi - delta;
        let theta = y.atan2(rho * delta.cos());
        let (r, _) = self.offset_at_f64(theta);
        let o = [-r * phi.cos(), 0.0, r * phi.sin()];
        let d = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if len == 0.0 {
            return None;
        }
        // Parallel eyes: Dc = (P − O)/|P − O|, the O term vanishing against Λ = ∞.
        let w = match self.convergence {
            None => d,
            Some(c) => {
                let k = (c as f64).hypot(r) / len;
                [d[0] * k + o[0], d[1] * k, d[2] * k + o[2]]
            }
        };
        let (phi, theta) = direction_angles(w[0], w[1], w[2]);
        self.sweep.screen(phi, theta / self.half_v as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{self, assert_refused, assert_spherical_ray_length, keeps_contract, ray_at};
    use obscura_sdk::{DeepMetric, Format, Projection};
    use proptest::prelude::*;

    fn make(params: &[(&str, &str)], format: Format) -> (Box<dyn Projection>, ProjectionEnvironment) {
        testing::make_env(&OmnidirectionalStereoFactory, params, format)
    }

    const R: f32 = 0.5 * 0.0635;

    #[test]
    fn the_left_eye_is_on_the_left() {
        let (left, _) = make(&[("string eye", "left")], Format::new(64, 32));
        let (right, _) = make(&[("string eye", "right")], Format::new(64, 32));
        let l = ray_at(left.as_ref(), Point2::ZERO);
        let r = ray_at(right.as_ref(), Point2::ZERO);
        assert!((l.direction - Vec3::Z).length() < 1e-7);
        assert!((l.origin - Vec3::new(-R, 0.0, 0.0)).length() < 1e-8, "{l:?}");
        assert!((r.origin - Vec3::new(R, 0.0, 0.0)).length() < 1e-8, "{r:?}");
        // Looking right (+X, azimuth 90°) the left eye is in front of the head (+Z).
        let l90 = ray_at(left.as_ref(), Point2::new(1.0, 0.0));
        assert!((l90.direction - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-6);
        assert!((l90.origin - Vec3::new(0.0, 0.0, R)).length() < 1e-8, "{l90:?}");
        // Mono has no offset.
        let (mono, _) = make(&[("string eye", "center")], Format::new(64, 32));
        assert_eq!(ray_at(mono.as_ref(), Point2::new(0.3, 0.2)).origin, Vec3::ZERO);
    }

    proptest! {
        #[test]
        fn eyes_are_mirror_images_on_the_viewing_circle(sx in -2.0f32..2.0, sy in -0.6f32..0.6) {
            let format = Format::new(64, 32);
            let (left, _) = make(&[("string eye", "left")], format);
            let (right, _) = make(&[("string eye", "right")], format);
            let s = Point2::new(sx, sy);
            let (l, r) = (ray_at(left.as_ref(), s), ray_at(right.as_ref(), s));
            // Below poleMergeFrom (|sy| ≤ 0.6 → |θ| ≤ 54°) both sit on the circle of radius IPD/2,
            // opposite each other, perpendicular to the shared direction.
            prop_assert!((l.origin.length() - R).abs() < 1e-7 && (r.origin.length() - R).abs() < 1e-7);
            prop_assert!((l.origin + r.origin).length() < 1e-8);
            prop_assert_eq!(l.origin.y, 0.0);
            prop_assert!(l.direction.dot(l.origin).abs() < 1e-7);
            prop_assert_eq!(l.direction, r.direction);
            // The independent form of §3.3: β = φ + π/2 for the left eye, O = R(−sin β, 0, −cos β).
            let phi = (sx as f64 / 2.0) * std::f64::consts::PI;
            let beta = phi + std::f64::consts::FRAC_PI_2;
            let e = [-(beta.sin()) * R as f64, 0.0, -(beta.cos()) * R as f64];
            prop_assert!((l.origin.x as f64 - e[0]).abs() < 1e-8 && (l.origin.z as f64 - e[2]).abs() < 1e-8);
        }

        #[test]
        fn converged_rays_of_both_eyes_meet_at_the_convergence_point(
            sx in -2.0f32..2.0, sy in -1.0f32..1.0, c in 0.2f32..50.0,
        ) {
            let format = Format::new(64, 32);
            let cs = c.to_string();
            let (left, _) = make(&[("string eye", "left"), ("float convergenceDistance", &cs)], format);
            let (right, _) = make(&[("string eye", "right"), ("float convergenceDistance", &cs)], format);
            let s = Point2::new(sx, sy);
            let (l, r) = (ray_at(left.as_ref(), s), ray_at(right.as_ref(), s));
            let phi = (sx as f64 / 2.0) * std::f64::consts::PI;
            let theta = sy as f64 * std::f64::consts::FRAC_PI_2;
            let target = [c as f64 * phi.sin() * theta.cos(), c as f64 * theta.sin(), c as f64 * phi.cos() * theta.cos()];
            for ray in [l, r] {
                // Distance from the target to the ray's line.
                let o = [ray.origin.x as f64, ray.origin.y as f64, ray.origin.z as f64];
                let d = [ray.direction.x as f64, ray.direction.y as f64, ray.direction.z as f64];
                let v = [target[0] - o[0], target[1] - o[1], target[2] - o[2]];
                let t = v[0] * d[0] + v[1] * d[1] + v[2] * d[2];
                prop_assert!(t > 0.0);
                let miss = ((v[0] - t * d[0]).powi(2) + (v[1] - t * d[1]).powi(2) + (v[2] - t * d[2]).powi(2)).sqrt();
                prop_assert!(miss < 2e-6 * c as f64, "{miss}");
                prop_assert!((ray.direction.length() - 1.0).abs() < 1e-6);
            }
        }

        #[test]
        fn unproject_inverts_project(
            u in -1.0f32..=1.0, v in -1.0f32..=1.0, depth in 0.3f32..1000.0, eye in 0usize..3,
            c in prop_oneof![Just(0.0f32), 0.5f32..20.0],
        ) {
            let format = Format::new(256, 128);
            let eye = ["left", "right", "center"][eye];
            let (p, env) = make(&[("string eye", eye), ("float convergenceDistance", &c.to_string())], format);
            let w = env.screen_window();
            let s = Point2::new(u * w.right, v * w.top);
            let r = ray_at(p.as_ref(), s);
            let back = p.unproject(r.origin + r.direction * depth, 0.0);
            prop_assert!(back.is_some(), "{s:?} {r:?}");
            let back = back.unwrap();
            let (px, py) = env.pixel_size();
            prop_assert!(((back.x - s.x) / px).abs() < 1e-4 && ((back.y - s.y) / py).abs() < 1e-4, "{s:?} -> {back:?}");
        }
    }

    #[test]
    fn the_eyes_merge_smoothly_toward_the_poles() {
        let (p, env) = make(&[], Format::new(64, 32));
        let top = env.screen_window().top;
        let radius_at = |deg: f32| {
            ray_at(p.as_ref(), Point2::new(0.7, top * deg / 90.0))
                .origin
                .length()
        };
        assert!((radius_at(59.0) - R).abs() < 1e-8);
        assert!(
            (radius_at(67.5) - 0.5 * R).abs() < 1e-7,
            "halfway through the band: half the offset"
        );
        assert_eq!(radius_at(75.0), 0.0);
        assert_eq!(radius_at(90.0), 0.0);
        let mut last = R;
        for i in 0..=60 {
            let r = radius_at(60.0 + 15.0 * i as f32 / 60.0);
            assert!(r <= last + 1e-9);
            last = r;
        }
        // Without merging the offset stays to the pole.
        let (q, _) = make(
            &[("float poleMergeFrom", "90"), ("float poleMergeTo", "90")],
            Format::new(64, 32),
        );
        assert!((ray_at(q.as_ref(), Point2::new(0.7, 0.99 * top)).origin.length() - R).abs() < 1e-8);
    }

    #[test]
    fn origin_radius_and_spread_match_finite_differences() {
        let format = Format::new(256, 128);
        for c in ["0", "3"] {
            let (p, env) = make(
                &[
                    ("float convergenceDistance", c),
                    ("float interpupilaryDistance", "0.5"),
                ],
                format,
            );
            let (px, py) = env.pixel_size();
            for (sx, sy) in [(0.3f32, 0.2f32), (-1.2, 0.75), (1.7, -0.8), (0.1, 0.7)] {
                let h = 0.01f32;
                let at = |dx: f32, dy: f32| ray_at(p.as_ref(), Point2::new(sx + dx * px, sy + dy * py));
                let r = at(0.0, 0.0);
                let (xp, xm, yp, ym) = (at(h, 0.0), at(-h, 0.0), at(0.0, h), at(0.0, -h));
                // Origin motion across the ray, per pixel.
                let across = |a: &RayGeometry, b: &RayGeometry| {
                    let d = (a.origin - b.origin) * (1.0 / (2.0 * h));
                    (d - r.direction * d.dot(r.direction)).length() as f64
                };
                let expected_radius = 0.5 * (across(&xp, &xm) * across(&yp, &ym)).sqrt();
                assert!(
                    (r.origin_radius as f64 - expected_radius).abs() <= 0.02 * expected_radius + 1e-7,
                    "c {c} at ({sx}, {sy}): {} vs {expected_radius}",
                    r.origin_radius
                );
                let ang = |a: &RayGeometry, b: &RayGeometry| {
                    (a.direction - b.direction).length() as f64 / (2.0 * h as f64)
                };
                let expected_spread = 0.5 * (ang(&xp, &xm) * ang(&yp, &ym)).sqrt();
                assert!(
                    (r.ray_spread as f64 / expected_spread - 1.0).abs() < 0.02,
                    "c {c} at ({sx}, {sy})"
                );
            }
        }
    }

    #[test]
    fn keeps_the_contract() {
        let cases = [
            (Format::new(48, 24), vec![]),
            (
                Format::new(48, 24),
                vec![("string eye", "right"), ("float convergenceDistance", "2")],
            ),
            (
                Format::new(40, 30),
                vec![
                    ("float hsweep", "200"),
                    ("float vsweep", "120"),
                    ("float interpupilaryDistance", "0.3"),
                ],
            ),
        ];
        for (env, stats) in keeps_contract(&OmnidirectionalStereoFactory, &cases) {
            assert_eq!(env.deep_metric(), DeepMetric::RayLength);
            stats.assert_complete(1000);
        }
    }

    #[test]
    fn properties_are_honest() {
        let (p, _) = make(&[], Format::new(2048, 1024));
        assert_spherical_ray_length(p.as_ref(), None, Some(180.0));
    }

    #[test]
    fn points_no_ray_reaches_are_not_seen() {
        let (p, _) = make(&[("float interpupilaryDistance", "1")], Format::new(64, 32));
        // Inside the viewing circle (radius 0.5) on the horizon: every ray starts on the circle, tangent to it.
        assert_eq!(p.unproject(Vec3::new(0.1, 0.0, 0.2), 0.0), None);
        assert_eq!(p.unproject(Vec3::new(f32::NAN, 0.0, 1.0), 0.0), None);
    }

    #[test]
    fn bad_parameters_are_explained() {
        let cases = [
            ("float poleMergeFrom", "80", "poleMergeFrom"),
            ("float convergenceDistance", "0.01", "convergenceDistance"),
            ("string eye", "both", "\"eye\""),
            ("float poleMergeTo", "95", "poleMergeTo"),
        ];
        assert_refused(
            &OmnidirectionalStereoFactory,
            "OmnidirectionalStereo",
            Format::new(8, 4),
            &cases,
        );
    }
}
