//! The ray/triangle test on its own: against an independent `f64` solve, its `t` range, and exact
//! edge signs.

use glam::Vec3A;

use super::SplitMix;
use crate::bvh::triangle::TriRay;

#[test]
fn triangle_test_agrees_with_an_independent_f64_solve() {
    let mut rng = SplitMix(3);
    let mut checked = 0;
    for _ in 0..2000 {
        let tri = [rng.vec(1.0), rng.vec(1.0), rng.vec(1.0)];
        let to64 = |v: Vec3A| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
        let [a, b, c] = tri.map(to64);
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let cross = |p: [f64; 3], q: [f64; 3]| {
            [
                p[1] * q[2] - p[2] * q[1],
                p[2] * q[0] - p[0] * q[2],
                p[0] * q[1] - p[1] * q[0],
            ]
        };
        let dot = |p: [f64; 3], q: [f64; 3]| p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
        let n = cross(e1, e2);
        if dot(n, n).sqrt() < 0.05 {
            continue;
        }
        let origin = rng.vec(3.0);
        let direction = rng.vec(1.0);
        let (o, d) = (to64(origin), to64(direction));
        // Plane: dot(n, o + t d - a) = 0; then Cramer's rule for (u, v) in the plane.
        let denom = dot(n, d);
        if denom.abs() < 1e-3 {
            continue;
        }
        let oa = [a[0] - o[0], a[1] - o[1], a[2] - o[2]];
        let t = dot(n, oa) / denom;
        let p = [
            o[0] + t * d[0] - a[0],
            o[1] + t * d[1] - a[1],
            o[2] + t * d[2] - a[2],
        ];
        let (d00, d01, d11) = (dot(e1, e1), dot(e1, e2), dot(e2, e2));
        let (d20, d21) = (dot(p, e1), dot(p, e2));
        let den = d00 * d11 - d01 * d01;
        let u = (d11 * d20 - d01 * d21) / den;
        let v = (d00 * d21 - d01 * d20) / den;
        let margin = u.min(v).min(1.0 - u - v);
        if margin.abs() < 1e-3 || t.abs() < 1e-3 {
            continue;
        }
        let got = TriRay::new(origin, direction).intersect(&tri, f32::NEG_INFINITY, f32::INFINITY);
        if margin > 0.0 {
            let (gt, gu, gv) = got.expect("a hit well inside the triangle");
            assert!(
                (f64::from(gt) - t).abs() < 1e-4 * (1.0 + t.abs()),
                "t {gt} vs {t}"
            );
            assert!((f64::from(gu) - u).abs() < 1e-4 && (f64::from(gv) - v).abs() < 1e-4);
        } else {
            assert!(got.is_none(), "a hit well outside the triangle: {got:?}");
        }
        checked += 1;
    }
    assert!(checked > 1000);
}

#[test]
fn t_range_is_strict_and_two_sided() {
    let tri = [
        Vec3A::new(-1.0, -1.0, 0.0),
        Vec3A::new(1.0, -1.0, 0.0),
        Vec3A::new(0.0, 1.0, 0.0),
    ];
    let front = TriRay::new(Vec3A::new(0.0, 0.0, 2.0), Vec3A::NEG_Z);
    let back = TriRay::new(Vec3A::new(0.0, 0.0, -2.0), Vec3A::Z);
    assert_eq!(front.intersect(&tri, 0.0, 10.0).map(|h| h.0), Some(2.0));
    assert_eq!(back.intersect(&tri, 0.0, 10.0).map(|h| h.0), Some(2.0));
    assert_eq!(front.intersect(&tri, 2.0, 10.0), None);
    assert_eq!(front.intersect(&tri, 0.0, 2.0), None);
}

#[test]
fn edge_signs_are_exact_when_f32_rounds_them_to_zero() {
    // Along +z the shear is the identity, so the edge function of B–C at the origin is
    // C.x·B.y − C.y·B.x = −(1 + 2⁻²²) + (1 + 2⁻²³)² = +2⁻⁴⁶, which f32 rounds to 0. The other two
    // edge functions are negative, so the ray passes just outside edge B–C: a miss. Taking the
    // rounded 0 at face value would call it a hit on the edge.
    let e = f32::EPSILON; // 2⁻²³
    let tri = [
        Vec3A::new(1.0, -1.0, 1.0),
        Vec3A::new(1.0 + e, 1.0, 1.0),
        Vec3A::new(-(1.0 + 2.0 * e), -(1.0 + e), 1.0),
    ];
    assert_eq!(
        -(1.0 + 2.0 * e) * 1.0 - (-(1.0 + e)) * (1.0 + e),
        0.0,
        "the premise: f32 rounds it to zero"
    );
    let r = TriRay::new(Vec3A::ZERO, Vec3A::Z);
    assert_eq!(r.intersect(&tri, 0.0, f32::INFINITY), None);
    // Moved a hair (2⁻²⁰) across that edge, the same ray hits.
    let inside = tri.map(|p| p - Vec3A::new(2f32.powi(-20), -(2f32.powi(-20)), 0.0));
    assert!(r.intersect(&inside, 0.0, f32::INFINITY).is_some());
}
