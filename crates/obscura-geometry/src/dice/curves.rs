//! `Curves` and `Points` → triangles that face the camera.
//!
//! **Curves.** Each segment (a cubic Bézier `C(t)`, widths `w₀ → w₁`) becomes a ribbon of `n`
//! quads: at `t = i/n` the two vertices `C(t) ± ½·w(t)·b(t)`, where `w` is linear in `t` and the
//! side vector `b = normalize(C'(t) × d)`, with `d` the ribbon's normal (`"N"`, interpolated) or,
//! without one, the direction from the curve toward the camera (the camera's position in object
//! space; for an orthographic hint the camera's −Z axis). The shading normal is `b × C'`, turned
//! toward `d`. `n = ⌈A·k/m⌉` for the control polyline's length `A` (clamped to `[1, 4096]`).
//!
//! **Points.** Each point is a disc of diameter `width` facing the camera, a fan of `s` triangles
//! with `s = ⌈π·w·k/m⌉` clamped to `[3, 16]` (`k` the rate of the whole cloud's bounding sphere).
//! Both scale their counts down together to stay within the per-primitive budget.

use std::f64::consts::{PI, TAU};

use glam::{DVec3, Vec3};
use obscura_scene::{Curves, Points};
use obscura_sdk::DicingHint;

use super::patch::{append, bernstein, bounding_sphere};
use super::quadric::Rate;
use super::{DicingContext, MAX_QUADS_PER_PRIMITIVE};
use crate::ray::TriangleMesh;

/// Where the camera is, seen from object space: `(position, None)` for a perspective or spherical
/// camera, `(_, Some(direction toward the camera))` for an orthographic one.
fn camera_in_object_space(ctx: &DicingContext) -> (DVec3, Option<DVec3>) {
    let inverse = ctx.object_to_camera.as_dmat4().inverse();
    let eye = inverse.transform_point3(DVec3::ZERO);
    let toward = (ctx.hint == DicingHint::Orthographic)
        .then(|| inverse.transform_vector3(-DVec3::Z).normalize_or(DVec3::Z));
    (eye, toward)
}

/// The ribbons of `curves`.
pub(super) fn curves(curves: &Curves, ctx: &DicingContext) -> TriangleMesh {
    let segments: Vec<_> = curves
        .segments
        .iter()
        .filter(|s| s.points.iter().all(|p| p.is_finite()) && s.widths.iter().all(|w| w.is_finite()))
        .collect();
    if segments.is_empty() {
        return TriangleMesh::default();
    }
    let all = segments
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.as_dvec3()));
    let (centre, radius) = bounding_sphere(all);
    let widest = segments
        .iter()
        .flat_map(|s| s.widths)
        .fold(0.0f32, |a, w| a.max(w.abs()));
    let rate = Rate::new(ctx, centre, radius + f64::from(widest));
    let mut counts: Vec<u32> = segments
        .iter()
        .map(|s| {
            let arc: f64 = s
                .points
                .windows(2)
                .map(|w| w[0].as_dvec3().distance(w[1].as_dvec3()))
                .sum();
            rate.segments(arc, 0.0)
        })
        .collect();
    let total: u64 = counts.iter().map(|&n| u64::from(n)).sum();
    if total > MAX_QUADS_PER_PRIMITIVE {
        let scale = MAX_QUADS_PER_PRIMITIVE as f64 / total as f64;
        for n in &mut counts {
            *n = ((f64::from(*n) * scale).floor() as u32).max(1);
        }
    }
    let (eye, ortho) = camera_in_object_space(ctx);
    let mut out = TriangleMesh {
        normals: Some(Vec::new()),
        ..TriangleMesh::default()
    };
    for (s, &n) in segments.iter().zip(&counts) {
        let p = s.points.map(Vec3::as_dvec3);
        let mut m = TriangleMesh {
            normals: Some(Vec::new()),
            ..TriangleMesh::default()
        };
        for i in 0..=n {
            let t = f64::from(i) / f64::from(n);
            let (b, db) = bernstein(t);
            let c: DVec3 = (0..4).map(|k| b[k] * p[k]).sum();
            let mut tangent: DVec3 = (0..4).map(|k| db[k] * p[k]).sum();
            if tangent.length_squared() == 0.0 {
                tangent = p[3] - p[0];
            }
            let facing = match (s.normals, ortho) {
                (Some([n0, n1]), _) => (n0.as_dvec3() * (1.0 - t) + n1.as_dvec3() * t).normalize_or_zero(),
                (None, Some(toward)) => toward,
                (None, None) => (eye - c).normalize_or_zero(),
            };
            let side = tangent.cross(facing).normalize_or_zero();
            let width = f64::from(s.widths[0]) * (1.0 - t) + f64::from(s.widths[1]) * t;
            let mut normal = side.cross(tangent).normalize_or(facing);
            if normal.dot(facing) < 0.0 {
                normal = -normal;
            }
            let half = 0.5 * width.abs() * side;
            m.positions.push((c - half).as_vec3a());
            m.positions.push((c + half).as_vec3a());
            if let Some(ns) = m.normals.as_mut() {
                ns.extend([normal.as_vec3a(); 2]);
            }
        }
        for i in 0..n {
            let a = 2 * i;
            m.triangles.push([a, a + 1, a + 3]);
            m.triangles.push([a, a + 3, a + 2]);
        }
        append(&mut out, m);
    }
    out
}

/// The discs of `points`.
pub(super) fn points(points: &Points, ctx: &DicingContext) -> TriangleMesh {
    let valid: Vec<(DVec3, f64)> = points
        .positions
        .iter()
        .zip(&points.widths)
        .filter(|(p, w)| p.is_finite() && w.is_finite() && **w != 0.0)
        .map(|(p, w)| (p.as_dvec3(), f64::from(w.abs())))
        .collect();
    if valid.is_empty() {
        return TriangleMesh::default();
    }
    let widest = valid.iter().fold(0.0f64, |a, v| a.max(v.1));
    let (centre, radius) = bounding_sphere(valid.iter().map(|v| v.0));
    let rate = Rate::new(ctx, centre, radius + widest);
    let budget = (MAX_QUADS_PER_PRIMITIVE / valid.len() as u64).clamp(3, 16) as u32;
    let (eye, ortho) = camera_in_object_space(ctx);
    let mut out = TriangleMesh {
        normals: Some(Vec::new()),
        ..TriangleMesh::default()
    };
    let normals = out.normals.get_or_insert_with(Vec::new);
    for &(c, w) in &valid {
        let sides = rate.segments(PI * w, 0.0).clamp(3, budget);
        let facing = ortho.unwrap_or_else(|| (eye - c).normalize_or(DVec3::Z));
        let (x, y) = facing.any_orthonormal_pair();
        let base = out.positions.len() as u32;
        out.positions.push(c.as_vec3a());
        normals.push(facing.as_vec3a());
        for k in 0..sides {
            let a = TAU * f64::from(k) / f64::from(sides);
            out.positions
                .push((c + 0.5 * w * (a.cos() * x + a.sin() * y)).as_vec3a());
            normals.push(facing.as_vec3a());
        }
        for k in 0..sides {
            let (i, j) = (base + 1 + k, base + 1 + (k + 1) % sides);
            out.triangles.push([base, i, j]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use obscura_scene::CurveSegment;
    use obscura_sdk::Format;

    use super::*;

    fn ctx() -> DicingContext {
        let mut c = DicingContext::new(DicingHint::Perspective, 90.0, Format::new(64, 48));
        c.object_to_camera = glam::Mat4::from_translation(glam::Vec3::new(0.0, 0.0, 4.0));
        c
    }

    #[test]
    fn a_ribbon_faces_the_camera_and_has_its_width() {
        let a = Vec3::new(-1.0, 0.0, 0.0);
        let b = Vec3::new(1.0, 0.0, 0.0);
        let c = Curves {
            segments: vec![CurveSegment {
                points: [a, a.lerp(b, 1.0 / 3.0), a.lerp(b, 2.0 / 3.0), b],
                widths: [0.2, 0.4],
                normals: None,
            }],
        };
        let m = curves(&c, &ctx());
        assert!(m.triangles.len() >= 2);
        for pair in m.positions.chunks(2) {
            let across = pair[1] - pair[0];
            let x = 0.5 * (pair[0].x + pair[1].x);
            let width = 0.2 + 0.2 * (x + 1.0) / 2.0;
            assert!((across.length() - width).abs() < 1e-4, "{across} at {x}");
            // Across the curve and across the view (the camera is at z = −4 in object space).
            assert!(across.x.abs() < 1e-5 && across.z.abs() < 1e-3 * across.length());
        }
        for n in m.normals.unwrap() {
            assert!(n.z < -0.99, "faces the camera: {n}");
        }
    }

    #[test]
    fn points_are_discs_of_their_width() {
        let p = Points {
            positions: vec![Vec3::ZERO, Vec3::X],
            widths: vec![0.5, 1.0],
        };
        let m = points(&p, &ctx());
        let first_fan = m.triangles.iter().take_while(|t| t[0] == 0).count() as u32;
        for k in 1..=first_fan {
            assert!((m.positions[k as usize].length() - 0.25).abs() < 1e-5);
        }
        assert!(m.triangles.len() as u32 > first_fan);
    }
}
