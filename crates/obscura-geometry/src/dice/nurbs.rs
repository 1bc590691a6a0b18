//! `NuPatch` → triangles: the rational B-spline surface evaluated on a grid over
//! `[umin, umax] × [vmin, vmax]`.
//!
//! With `Nᵢ` the B-spline basis of order `k` (Cox–de Boor) and `(X, Y, Z, W)` the homogeneous
//! control points, `A(u, v) = Σ Nᵢ(u) Nⱼ(v) (X, Y, Z)ᵢⱼ`, `w(u, v) = Σ Nᵢ(u) Nⱼ(v) Wᵢⱼ` and
//! `S = A/w`; the partials are `S_u = (A_u − w_u S)/w` (likewise `v`) and the normal is
//! `S_u × S_v` normalised. The rate comes from the bounding sphere of the control points; each
//! direction gets `⌈A·k/m⌉` segments (`A` the longest control polyline in that direction, never
//! shorter than the curve), and at least one per non-empty knot span in the range. A grid of more
//! than [`UNIFORM_GRID_QUADS`](super::UNIFORM_GRID_QUADS) quads is then fitted cell by cell as the
//! quadrics' are (`quadric::tessellate_fitted`): each cell measured on the surface itself, whose
//! arcs a wavy control net overstates many times, at its own distance.

use glam::DVec3;
use obscura_scene::{NuPatch, NurbsAxis};

use super::DicingContext;
use super::patch::{bounding_sphere, fit_all, surface_normal};
use super::quadric::{Grid, Rate, tessellate_fitted};
use crate::ray::TriangleMesh;

/// The knot span holding `t`: the largest `s` in `[order − 1, count − 1]` with `knots[s] ≤ t`.
fn span(axis: &NurbsAxis, t: f64) -> usize {
    let (lo, hi) = (axis.order as usize - 1, axis.count as usize - 1);
    let mut s = lo;
    while s < hi && f64::from(axis.knots[s + 1]) <= t {
        s += 1;
    }
    s
}

/// The `order` basis functions non-zero at `t` (indices `s − order + 1 ..= s`) and their
/// derivatives, by the Cox–de Boor recurrence.
fn basis(axis: &NurbsAxis, t: f64) -> (usize, Vec<f64>, Vec<f64>) {
    let k = axis.order as usize;
    let s = span(axis, t);
    let knot = |i: usize| f64::from(axis.knots[i]);
    // n[j] = N_{s−d+j, d} for the current degree d.
    let mut n = vec![1.0];
    let mut below = vec![1.0];
    for d in 1..k {
        below.clone_from(&n);
        let mut next = vec![0.0; d + 1];
        for (j, out) in next.iter_mut().enumerate() {
            let i = s + j - d; // function N_{i, d}
            let left = if j >= 1 { n[j - 1] } else { 0.0 }; // N_{i, d−1}
            let right = if j < d { n[j] } else { 0.0 }; // N_{i+1, d−1}
            let a = knot(i + d) - knot(i);
            let b = knot(i + d + 1) - knot(i + 1);
            let mut v = 0.0;
            if a > 0.0 {
                v += (t - knot(i)) / a * left;
            }
            if b > 0.0 {
                v += (knot(i + d + 1) - t) / b * right;
            }
            *out = v;
        }
        n = next;
    }
    let p = k - 1;
    let mut dn = vec![0.0; k];
    if p > 0 {
        for (j, out) in dn.iter_mut().enumerate() {
            let i = s + j - p;
            let left = if j >= 1 { below[j - 1] } else { 0.0 };
            let right = if j < p { below[j] } else { 0.0 };
            let a = knot(i + p) - knot(i);
            let b = knot(i + p + 1) - knot(i + 1);
            let mut v = 0.0;
            if a > 0.0 {
                v += p as f64 / a * left;
            }
            if b > 0.0 {
                v -= p as f64 / b * right;
            }
            *out = v;
        }
    }
    (s + 1 - k, n, dn)
}

/// Position and partials of the surface at `(u, v)`.
fn evaluate(patch: &NuPatch, u: f64, v: f64) -> (DVec3, DVec3, DVec3) {
    let (iu, nu, dnu) = basis(&patch.u, u);
    let (iv, nv, dnv) = basis(&patch.v, v);
    let cols = patch.u.count as usize;
    let (mut a, mut au, mut av) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
    let (mut w, mut wu, mut wv) = (0.0, 0.0, 0.0);
    for (j, (&bv, &dbv)) in nv.iter().zip(&dnv).enumerate() {
        for (i, (&bu, &dbu)) in nu.iter().zip(&dnu).enumerate() {
            let q = patch.points[(iv + j) * cols + iu + i];
            let (xyz, ww) = (
                DVec3::new(f64::from(q[0]), f64::from(q[1]), f64::from(q[2])),
                f64::from(q[3]),
            );
            a += bu * bv * xyz;
            au += dbu * bv * xyz;
            av += bu * dbv * xyz;
            w += bu * bv * ww;
            wu += dbu * bv * ww;
            wv += bu * dbv * ww;
        }
    }
    let s = a / w;
    (s, (au - wu * s) / w, (av - wv * s) / w)
}

/// Non-empty knot spans within `[min, max]`.
fn spans_in_range(axis: &NurbsAxis) -> u32 {
    let (lo, hi) = (axis.order as usize - 1, axis.count as usize);
    (lo..hi)
        .filter(|&s| {
            axis.knots[s + 1] > axis.knots[s] && axis.knots[s + 1] > axis.min && axis.knots[s] < axis.max
        })
        .count()
        .max(1) as u32
}

/// The NURBS patch as triangles; an empty mesh when its description is inconsistent.
pub(super) fn nu_patch(patch: &NuPatch, ctx: &DicingContext) -> TriangleMesh {
    let (cu, cv) = (patch.u.count as usize, patch.v.count as usize);
    let consistent = |a: &NurbsAxis| {
        a.order >= 1
            && a.order <= a.count
            && a.knots.len() == (a.count + a.order) as usize
            && a.min < a.max
            && a.knots.windows(2).all(|w| w[1] >= w[0])
    };
    if !consistent(&patch.u) || !consistent(&patch.v) || patch.points.len() != cu * cv {
        return TriangleMesh::default();
    }
    let points: Vec<DVec3> = patch
        .points
        .iter()
        .map(|q| DVec3::new(f64::from(q[0]), f64::from(q[1]), f64::from(q[2])) / f64::from(q[3]))
        .collect();
    if !points.iter().all(|p| p.is_finite()) {
        return TriangleMesh::default();
    }
    let (centre, radius) = bounding_sphere(points.iter().copied());
    let rate = Rate::new(ctx, centre, radius);
    let mut au: f64 = 0.0;
    for j in 0..cv {
        au = au.max(
            (1..cu)
                .map(|i| points[j * cu + i].distance(points[j * cu + i - 1]))
                .sum(),
        );
    }
    let mut av: f64 = 0.0;
    for i in 0..cu {
        av = av.max(
            (1..cv)
                .map(|j| points[j * cu + i].distance(points[(j - 1) * cu + i]))
                .sum(),
        );
    }
    let mut counts = [(
        rate.segments(au, 0.0).max(spans_in_range(&patch.u)),
        rate.segments(av, 0.0).max(spans_in_range(&patch.v)),
    )];
    fit_all(
        &mut counts,
        super::quad_budget(ctx, centre.as_vec3(), radius as f32),
    );
    let grid = Grid {
        nu: counts[0].0,
        nv: counts[0].1,
        wrap_u: false,
        wrap_v: false,
        pole0: None,
        pole1: None,
    };
    let (u0, u1) = (f64::from(patch.u.min), f64::from(patch.u.max));
    let (v0, v1) = (f64::from(patch.v.min), f64::from(patch.v.max));
    let eval = |s: f64, t: f64| evaluate(patch, u0 + s * (u1 - u0), v0 + t * (v1 - v0));
    tessellate_fitted(&grid, &rate, ctx, |s, t| {
        (eval(s, t).0, surface_normal(eval, s, t))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(count: u32, order: u32, knots: &[f32]) -> NurbsAxis {
        NurbsAxis {
            count,
            order,
            knots: knots.to_vec(),
            min: knots[order as usize - 1],
            max: knots[count as usize],
        }
    }

    #[test]
    fn the_basis_sums_to_one_and_its_derivative_to_zero() {
        let a = axis(6, 4, &[0.0, 0.0, 0.0, 0.0, 1.0, 2.5, 3.0, 3.0, 3.0, 3.0]);
        for k in 0..=30 {
            let t = 3.0 * f64::from(k) / 30.0;
            let (_, n, dn) = basis(&a, t);
            assert!((n.iter().sum::<f64>() - 1.0).abs() < 1e-12, "t {t}");
            assert!(dn.iter().sum::<f64>().abs() < 1e-9, "t {t}");
        }
    }

    #[test]
    fn a_rational_quadratic_patch_draws_an_exact_cylinder_quarter() {
        // u: the quarter circle of radius 1 as a rational quadratic (weights 1, √½, 1); v: a line.
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let ring = [[1.0, 0.0, 1.0], [h, h, h], [0.0, 1.0, 1.0]];
        let mut points = Vec::new();
        for z in [0.0f32, 2.0] {
            for [x, y, w] in ring {
                points.push([x, y, z * w, w]);
            }
        }
        let patch = NuPatch {
            u: axis(3, 3, &[0.0, 0.0, 0.0, 1.0, 1.0, 1.0]),
            v: axis(2, 2, &[0.0, 0.0, 1.0, 1.0]),
            points,
        };
        for k in 0..=10 {
            let (p, pu, pv) = evaluate(&patch, f64::from(k) / 10.0, 0.3);
            assert!((p.truncate().length() - 1.0).abs() < 1e-6, "radius at {k}: {p}");
            assert!((p.z - 0.6).abs() < 1e-6);
            let n = pu.cross(pv).normalize();
            assert!((n - p.with_z(0.0)).length() < 1e-5, "normal {n} at {p}");
        }
    }

    #[test]
    fn a_wavy_control_net_is_diced_by_its_surface_not_by_its_net() {
        // A cubic B-spline patch on the plane z = 2 filling a 90° view: its control points zig-zag
        // across u and v (±0.4 around an even spread), so the control polygon is several times the
        // surface's arc. Diced by the net, the grid hits the on-screen budget; fitted cell by cell
        // on the surface, it needs a fraction of that, stays on the plane and reaches its edges.
        use glam::{Mat4, Vec3};
        use obscura_sdk::{DicingHint, Format};
        let n = 12u32;
        let knots: Vec<f32> = (0..n + 4).map(|k| k as f32).collect();
        let mut points = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let zig = |k: u32| if k.is_multiple_of(2) { 0.4 } else { -0.4 };
                let x = -1.0 + 2.0 * i as f32 / (n - 1) as f32 + zig(i);
                let y = -1.0 + 2.0 * j as f32 / (n - 1) as f32 + zig(j);
                points.push([x, y, 0.0, 1.0]);
            }
        }
        let patch = NuPatch {
            u: axis(n, 4, &knots),
            v: axis(n, 4, &knots),
            points,
        };
        let mut ctx = DicingContext::new(DicingHint::Perspective, 90.0, Format::new(64, 48));
        ctx.object_to_camera = Mat4::from_translation(Vec3::new(0.0, 0.0, 2.0));
        let mesh = nu_patch(&patch, &ctx);
        // The budget the net alone reaches: F·P quads for the whole image, two triangles each.
        let budget = 2.0 * f64::from(crate::dice::COVERAGE_FACTOR) * 64.0 * 48.0;
        let triangles = mesh.triangles.len() as f64;
        assert!(
            triangles <= budget / 4.0,
            "{triangles} triangles against a budget of {budget}"
        );
        assert!(triangles >= 2.0 * 64.0 * 48.0 / 16.0, "too coarse: {triangles}");
        // On the surface (the plane), and reaching the surface's corners.
        assert!(mesh.positions.iter().all(|p| p.z.abs() < 1e-5));
        let corner = evaluate(&patch, f64::from(patch.u.max), f64::from(patch.v.max)).0;
        let reach = mesh
            .positions
            .iter()
            .map(|p| (p.x as f64 - corner.x).hypot(p.y as f64 - corner.y))
            .fold(f64::INFINITY, f64::min);
        assert!(
            reach < 1e-5,
            "the far corner {corner} is {reach} from the nearest vertex"
        );
        // Quad sides on screen stay near a pixel (a triangle's longest edge is the quad's diagonal):
        // s·d/z = 16 px per unit at z = 2 (the plane itself).
        let longest = mesh
            .triangles
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .map(|(a, b)| mesh.positions[a as usize].distance(mesh.positions[b as usize]) * 16.0)
            .fold(0.0f32, f32::max);
        assert!(
            longest <= 1.5 * std::f32::consts::SQRT_2,
            "longest edge {longest} px"
        );
    }
}
