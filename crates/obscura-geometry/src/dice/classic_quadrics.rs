//! The two quadrics of the RenderMan Interface beyond `quadric`'s five: `Hyperboloid` and
//! `Paraboloid`, on the same (u, v) grid and rate.
//!
//! | quadric | `P(u, v)` (θ = u·thetamax) | around z (`u`) | along (`v`) |
//! |---|---|---|---|
//! | hyperboloid `p₁`, `p₂` | `Rz(θ)·((1 − v)p₁ + v·p₂)` | `max(r₁, r₂)·Δθ` | `‖p₂ − p₁‖` |
//! | paraboloid `rmax`, `zmin`, `zmax` | `(r cos θ, r sin θ, z)`, `z = zmin + v(zmax − zmin)`, `r = rmax·√(z/zmax)` | `rmax·Δθ` | `√(Δz² + rmax²)` |
//!
//! Normals are analytic and point away from the z axis (the paraboloid's apex normal is −z).

use std::f64::consts::TAU;

use glam::{DVec2, DVec3, Vec2};

use super::DicingContext;
use super::quadric::{
    Grid, Rate, finite, fit_budget, min_segments, radius_z_sweep, sweep, tessellate_fitted_st,
};
use crate::ray::TriangleMesh;

/// `Hyperboloid x1 y1 z1 x2 y2 z2 thetamax`.
pub(super) fn hyperboloid(
    p1: glam::Vec3,
    p2: glam::Vec3,
    theta_max: f32,
    ctx: &DicingContext,
    with_st: bool,
) -> (TriangleMesh, Option<Vec<Vec2>>) {
    let (a, b) = (p1.as_dvec3(), p2.as_dvec3());
    let Some(theta) = sweep(theta_max) else {
        return Default::default();
    };
    if !finite(&[a.x, a.y, a.z, b.x, b.y, b.z]) || a == b {
        return Default::default();
    }
    let (r1, r2) = (a.truncate().length(), b.truncate().length());
    let r = r1.max(r2);
    if r == 0.0 {
        return Default::default();
    }
    let rate = Rate::new(
        ctx,
        DVec3::new(0.0, 0.0, 0.5 * (a.z + b.z)),
        r.hypot(0.5 * (b.z - a.z)),
    );
    let turn = theta.abs() / TAU;
    let nu = rate.segments(r * theta.abs(), turn);
    let nv = rate.segments(a.distance(b), 0.0);
    let (nu, nv) = fit_budget(nu, nv, min_segments(turn), 1);
    let grid = Grid {
        nu,
        nv,
        wrap_u: theta.abs() >= TAU,
        wrap_v: false,
        pole0: None,
        pole1: None,
    };
    let along = b - a;
    tessellate_fitted_st(&grid, &rate, ctx, with_st, |u, v| {
        let t = u * theta;
        let (c, s) = (t.cos(), t.sin());
        let rot = |p: DVec3| DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
        let q = rot(a + v * along);
        let du = DVec3::new(-q.y, q.x, 0.0);
        let dv = rot(along);
        let mut n = du.cross(dv).normalize_or_zero();
        if n == DVec3::ZERO {
            // On the axis: the normal of the nearest ring, or z.
            n = if q.truncate() == DVec2::ZERO {
                DVec3::Z
            } else {
                q.with_z(0.0).normalize()
            };
        }
        if n.truncate().dot(q.truncate()) < 0.0 {
            n = -n;
        }
        (q, n)
    })
}

/// `Paraboloid rmax zmin zmax thetamax`.
pub(super) fn paraboloid(
    radius: f32,
    z_min: f32,
    z_max: f32,
    theta_max: f32,
    ctx: &DicingContext,
    with_st: bool,
) -> (TriangleMesh, Option<Vec<Vec2>>) {
    let Some((rmax, z0, z1, theta)) = radius_z_sweep(radius, z_min, z_max, theta_max) else {
        return Default::default();
    };
    if z1 == 0.0 || z0 == z1 || z0 / z1 < 0.0 {
        return Default::default();
    }
    let dz = z1 - z0;
    let rate = Rate::new(ctx, DVec3::new(0.0, 0.0, 0.5 * (z0 + z1)), rmax.hypot(0.5 * dz));
    let turn = theta.abs() / TAU;
    let nu = rate.segments(rmax * theta.abs(), turn);
    let nv = rate.segments(rmax.hypot(dz), 0.0);
    let (nu, nv) = fit_budget(nu, nv.max(2), min_segments(turn), 2);
    let apex = (z0 == 0.0).then(|| (DVec3::ZERO, DVec3::new(0.0, 0.0, -z1.signum())));
    let grid = Grid {
        nu,
        nv,
        wrap_u: theta.abs() >= TAU,
        wrap_v: false,
        pole0: apex,
        pole1: None,
    };
    tessellate_fitted_st(&grid, &rate, ctx, with_st, |u, v| {
        let t = u * theta;
        let z = z0 + v * dz;
        let ratio = (z / z1).max(0.0);
        let r = rmax * ratio.sqrt();
        // Outward normal ∝ (cos θ, sin θ, −dr/dz), scaled by 2√(z·zmax)/rmax so the apex stays finite.
        let k = 2.0 * (z * z1).abs().sqrt() / rmax;
        let n = DVec3::new(k * t.cos(), k * t.sin(), -z1.signum()).normalize();
        (DVec3::new(r * t.cos(), r * t.sin(), z), n)
    })
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use obscura_sdk::{DicingHint, Format};

    use super::*;

    fn ctx() -> DicingContext {
        let mut c = DicingContext::new(DicingHint::Perspective, 90.0, Format::new(64, 48));
        c.object_to_camera = glam::Mat4::from_translation(glam::Vec3::new(0.0, 0.0, 5.0));
        c
    }

    #[test]
    fn hyperboloid_vertices_lie_on_the_swept_line() {
        let (p1, p2) = (Vec3::new(1.0, 0.0, -1.0), Vec3::new(0.0, 1.0, 1.0));
        let m = hyperboloid(p1, p2, 360.0, &ctx(), false).0;
        assert!(m.triangles.len() > 16);
        for p in &m.positions {
            // On the line at v = (z + 1)/2, at the line's distance from the axis.
            let v = (p.z + 1.0) / 2.0;
            let q = p1.lerp(p2, v);
            assert!(
                (p.truncate().length() - q.truncate().length()).abs() < 1e-4,
                "{p}"
            );
        }
    }

    #[test]
    fn paraboloid_vertices_follow_r_rmax_sqrt_z_over_zmax() {
        let m = paraboloid(2.0, 0.0, 4.0, 360.0, &ctx(), false).0;
        assert!(m.triangles.len() > 16);
        for (p, n) in m.positions.iter().zip(m.normals.as_ref().unwrap()) {
            let r = 2.0 * (p.z / 4.0).max(0.0).sqrt();
            assert!((p.truncate().length() - r).abs() < 1e-4, "{p}");
            // The normal is perpendicular to the profile's tangent (dr/dz, 1) turned about z.
            let t = if p.truncate().length() > 1e-3 {
                let dir = p.truncate().normalize();
                Vec3::new(dir.x, dir.y, 0.0) * (1.0 / (p.z * 4.0).sqrt()) + Vec3::Z
            } else {
                continue;
            };
            assert!(Vec3::from(*n).dot(t).abs() < 1e-3, "normal {n} at {p}");
        }
    }
}
