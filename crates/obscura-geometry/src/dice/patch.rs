//! Bicubic Bézier patches (every `Patch`, `PatchMesh` and the teapot) → triangles.
//!
//! A patch that would dice into more than 1024 quads is first split in half (de Casteljau, exact)
//! across its longer direction, up to 12 times in a row, so each piece is measured at its own
//! distance (REYES's split-then-dice): a floor running from the camera to the horizon dices finely
//! only near the camera. Each piece gets its own rate from the bounding sphere of its control points, and
//! `n = ⌈A·k/m⌉` segments per direction (clamped to `[1, 4096]`), `A` the longest control-polygon
//! row (for `u`) or column (for `v`): the control polygon is never shorter than the curve, so the
//! surface's edges come out at most `m` pixels long. Under an orthographic camera (`DicingHint` of
//! `Orthographic`) `A` is first scaled by the fraction of it the image shows, the polyline's length in
//! the camera's x-y plane over its length in camera space: depth does not move a point on an
//! orthographic image, so a patch running away from the camera dices by its span on screen (aqsis's
//! `tenpatch.rib`: 590 k triangles a patch at 160×120 before, 102 k after). When the patches of one primitive together
//! exceed [`MAX_QUADS_PER_PRIMITIVE`](super::MAX_QUADS_PER_PRIMITIVE) quads, every count is scaled
//! down by the same factor. Vertices lie on the surface (Bernstein form, `f64`), normals are
//! `∂P/∂u × ∂P/∂v` normalised (at a collapsed edge, the normal a small step inside the patch).
//! Each vertex also gets its texture coordinates `(s, t)`: the patch's corner values interpolated
//! bilinearly at the vertex's `(u, v)` in the whole patch (a piece remembers the part it covers).

use glam::{DVec3, Vec2, Vec3};
use obscura_scene::BezierPatch;
use obscura_sdk::DicingHint;

use super::quadric::{Grid, Rate, tessellate};
use super::{DicingContext, MAX_QUADS_PER_PRIMITIVE};
use crate::ray::TriangleMesh;

/// Cubic Bernstein values and derivatives at `t`.
pub(super) fn bernstein(t: f64) -> ([f64; 4], [f64; 4]) {
    let s = 1.0 - t;
    (
        [s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t],
        [
            -3.0 * s * s,
            3.0 * s * (s - 2.0 * t),
            3.0 * t * (2.0 * s - t),
            3.0 * t * t,
        ],
    )
}

/// Position and the two partial derivatives of `p` at `(u, v)`.
fn evaluate(p: &[DVec3; 16], u: f64, v: f64) -> (DVec3, DVec3, DVec3) {
    let (bu, du) = bernstein(u);
    let (bv, dv) = bernstein(v);
    let (mut pos, mut pu, mut pv) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
    for j in 0..4 {
        for i in 0..4 {
            let c = p[4 * j + i];
            pos += bu[i] * bv[j] * c;
            pu += du[i] * bv[j] * c;
            pv += bu[i] * dv[j] * c;
        }
    }
    (pos, pu, pv)
}

/// The unit normal `∂u × ∂v` at `(u, v)`, stepping toward the centre where it vanishes.
pub(super) fn surface_normal<F>(eval: F, u: f64, v: f64) -> DVec3
where
    F: Fn(f64, f64) -> (DVec3, DVec3, DVec3),
{
    let mut n = DVec3::ZERO;
    for step in [0.0, 1e-4, 1e-3, 1e-2] {
        let (_, pu, pv) = eval(u + step * (0.5 - u).signum(), v + step * (0.5 - v).signum());
        n = pu.cross(pv).normalize_or_zero();
        if n != DVec3::ZERO {
            break;
        }
    }
    if n == DVec3::ZERO { DVec3::Z } else { n }
}

/// The longest control polyline along `u` (rows) and along `v` (columns).
fn hull_arcs(p: &[DVec3; 16]) -> (f64, f64) {
    let mut au: f64 = 0.0;
    let mut av: f64 = 0.0;
    for k in 0..4 {
        let row: f64 = (0..3).map(|i| p[4 * k + i].distance(p[4 * k + i + 1])).sum();
        let col: f64 = (0..3).map(|j| p[4 * j + k].distance(p[4 * (j + 1) + k])).sum();
        au = au.max(row);
        av = av.max(col);
    }
    (au, av)
}

/// The centre and radius of a sphere holding `points` (their box's centre and farthest point).
pub(super) fn bounding_sphere(points: impl Iterator<Item = DVec3> + Clone) -> (DVec3, f64) {
    let (lo, hi) = points
        .clone()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
    let centre = 0.5 * (lo + hi);
    let radius = points.map(|p| p.distance(centre)).fold(0.0, f64::max);
    (centre, radius)
}

/// Scales every `(nu, nv)` down by one factor so their quads fit `budget` (at most the per-primitive
/// budget): the quads the primitive's on-screen coverage allows ([`super::quad_budget`]).
pub(super) fn fit_all(counts: &mut [(u32, u32)], budget: u64) {
    let budget = budget.clamp(1, MAX_QUADS_PER_PRIMITIVE);
    let total: u64 = counts.iter().map(|&(a, b)| u64::from(a) * u64::from(b)).sum();
    if total <= budget {
        return;
    }
    let scale = (budget as f64 / total as f64).sqrt();
    for c in counts {
        c.0 = ((f64::from(c.0) * scale).floor() as u32).max(1);
        c.1 = ((f64::from(c.1) * scale).floor() as u32).max(1);
    }
}

/// Appends `m` to `out`.
pub(super) fn append(out: &mut TriangleMesh, m: TriangleMesh) {
    let base = out.positions.len() as u32;
    out.positions.extend(m.positions);
    if let (Some(o), Some(n)) = (out.normals.as_mut(), m.normals) {
        o.extend(n);
    }
    out.triangles.extend(
        m.triangles
            .into_iter()
            .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
    );
}

/// Patches are split (de Casteljau, exactly) while one would dice into more than this many quads …
const SPLIT_ABOVE_QUADS: u32 = 1024;

/// … at most this many times in a row (a patch becomes at most `2^MAX_SPLIT_DEPTH` pieces).
const MAX_SPLIT_DEPTH: u32 = 12;

/// The halves of a cubic Bézier curve (de Casteljau at ½).
fn halve(p: [DVec3; 4]) -> ([DVec3; 4], [DVec3; 4]) {
    let m = |a: DVec3, b: DVec3| 0.5 * (a + b);
    let (p01, p12, p23) = (m(p[0], p[1]), m(p[1], p[2]), m(p[2], p[3]));
    let (p012, p123) = (m(p01, p12), m(p12, p23));
    let mid = m(p012, p123);
    ([p[0], p01, p012, mid], [mid, p123, p23, p[3]])
}

/// The two halves of a patch across `u` (`along_u`) or `v`.
fn split(p: &[DVec3; 16], along_u: bool) -> ([DVec3; 16], [DVec3; 16]) {
    let mut a = [DVec3::ZERO; 16];
    let mut b = [DVec3::ZERO; 16];
    for k in 0..4 {
        let at = |i: usize| if along_u { 4 * k + i } else { 4 * i + k };
        let (x, y) = halve([p[at(0)], p[at(1)], p[at(2)], p[at(3)]]);
        for i in 0..4 {
            a[at(i)] = x[i];
            b[at(i)] = y[i];
        }
    }
    (a, b)
}

/// A patch's segment counts from its own rate.
fn counts(p: &[DVec3; 16], ctx: &DicingContext) -> (u32, u32) {
    let (centre, radius) = bounding_sphere(p.iter().copied());
    let rate = Rate::new(ctx, centre, radius);
    let (au, av) = hull_arcs(p);
    let (fu, fv) = on_screen_fractions(p, ctx);
    (rate.segments(au * fu, 0.0), rate.segments(av * fv, 0.0))
}

/// The fraction of a patch's control polylines, along `u` and along `v`, that an orthographic camera
/// sees: the longest row's (column's) length in the camera's x-y plane over its length in camera
/// space. Depth does not move a point on an orthographic image, so a patch running away from the
/// camera is diced by what it spans on screen, as RenderMan dices by raster size; (1, 1) for every
/// other dicing hint, whose rate already holds the nearest point's depth.
fn on_screen_fractions(p: &[DVec3; 16], ctx: &DicingContext) -> (f64, f64) {
    if ctx.hint != DicingHint::Orthographic {
        return (1.0, 1.0);
    }
    let m = ctx.object_to_camera.as_dmat4();
    let q = p.map(|x| m.transform_point3(x));
    let lengths = |at: &dyn Fn(usize, usize) -> usize| {
        let (mut flat, mut full) = (0.0f64, 0.0f64);
        for k in 0..4 {
            let (mut a, mut b) = (0.0, 0.0);
            for i in 0..3 {
                let d = q[at(k, i + 1)] - q[at(k, i)];
                a += d.truncate().length();
                b += d.length();
            }
            flat = flat.max(a);
            full = full.max(b);
        }
        let f = flat / full;
        if f.is_finite() { f.clamp(0.0, 1.0) } else { 1.0 }
    };
    (lengths(&|k, i| 4 * k + i), lengths(&|k, j| 4 * j + k))
}

/// A piece of a patch: its control points, the part `[u0, u1] × [v0, v1]` of its patch it covers,
/// the patch's index, and its segment counts.
struct Piece {
    points: [DVec3; 16],
    range: [f64; 4],
    patch: usize,
    counts: (u32, u32),
}

/// Splits `p` until each piece dices into at most [`SPLIT_ABOVE_QUADS`] quads (or the depth runs
/// out), so the near part of a large patch dices finely and its far part coarsely: each piece is
/// measured at its own distance.
fn split_to_fit(p: Piece, ctx: &DicingContext, depth: u32, out: &mut Vec<Piece>) {
    let (nu, nv) = counts(&p.points, ctx);
    if u64::from(nu) * u64::from(nv) <= u64::from(SPLIT_ABOVE_QUADS) || depth >= MAX_SPLIT_DEPTH {
        out.push(Piece {
            counts: (nu, nv),
            ..p
        });
        return;
    }
    let along_u = nu >= nv;
    let (a, b) = split(&p.points, along_u);
    let [u0, u1, v0, v1] = p.range;
    let (ra, rb) = if along_u {
        let um = 0.5 * (u0 + u1);
        ([u0, um, v0, v1], [um, u1, v0, v1])
    } else {
        let vm = 0.5 * (v0 + v1);
        ([u0, u1, v0, vm], [u0, u1, vm, v1])
    };
    for (points, range) in [(a, ra), (b, rb)] {
        let piece = Piece {
            points,
            range,
            patch: p.patch,
            counts: (0, 0),
        };
        split_to_fit(piece, ctx, depth + 1, out);
    }
}

/// The patches as one triangle mesh.
pub(super) fn patches(list: &[BezierPatch], ctx: &DicingContext) -> TriangleMesh {
    patches_with_st(list, ctx).0
}

/// The patches as one triangle mesh, and each vertex's texture coordinates `(s, t)`.
pub(super) fn patches_with_st(list: &[BezierPatch], ctx: &DicingContext) -> (TriangleMesh, Vec<Vec2>) {
    let mut pieces = Vec::new();
    for (k, p) in list
        .iter()
        .enumerate()
        .filter(|(_, p)| p.points.iter().all(|q| q.is_finite()))
    {
        let whole = Piece {
            points: p.points.map(Vec3::as_dvec3),
            range: [0.0, 1.0, 0.0, 1.0],
            patch: k,
            counts: (0, 0),
        };
        split_to_fit(whole, ctx, 0, &mut pieces);
    }
    let mut counts: Vec<(u32, u32)> = pieces.iter().map(|p| p.counts).collect();
    let (centre, radius) = bounding_sphere(pieces.iter().flat_map(|p| p.points.iter().copied()));
    fit_all(
        &mut counts,
        super::quad_budget(ctx, centre.as_vec3(), radius as f32),
    );
    let mut out = TriangleMesh {
        normals: Some(Vec::new()),
        ..TriangleMesh::default()
    };
    let mut st = Vec::new();
    for (piece, &(nu, nv)) in pieces.iter().zip(&counts) {
        let p = &piece.points;
        let grid = Grid {
            nu,
            nv,
            wrap_u: false,
            wrap_v: false,
            pole0: None,
            pole1: None,
        };
        let eval = |u: f64, v: f64| evaluate(p, u, v);
        let mesh = tessellate(&grid, |u, v| (eval(u, v).0, surface_normal(eval, u, v)));
        // Without poles or wrapping, the grid's vertices are row by row: (i, j) at j·(nu + 1) + i.
        debug_assert_eq!(mesh.positions.len(), (nu as usize + 1) * (nv as usize + 1));
        let [u0, u1, v0, v1] = piece.range;
        let patch = &list[piece.patch];
        for j in 0..=nv {
            let v = v0 + (v1 - v0) * f64::from(j) / f64::from(nv);
            for i in 0..=nu {
                let u = u0 + (u1 - u0) * f64::from(i) / f64::from(nu);
                st.push(patch.st_at(u as f32, v as f32));
            }
        }
        append(&mut out, mesh);
    }
    (out, st)
}

#[cfg(test)]
mod tests {
    use obscura_sdk::{DicingHint, Format};

    use super::*;

    fn ctx(distance: f32) -> DicingContext {
        let mut c = DicingContext::new(DicingHint::Perspective, 90.0, Format::new(64, 48));
        c.object_to_camera = glam::Mat4::from_translation(glam::Vec3::new(0.0, 0.0, distance));
        c
    }

    /// A patch whose Bézier points lie on `z = x² + y²` sampled so the surface is exactly that
    /// paraboloid over the unit square (degree 2 in each direction, elevated to cubic).
    fn bowl() -> BezierPatch {
        // Quadratic Bézier of x² on [0, 1]: (0, 0, 1) → cubic (0, 0, 1/3, 1); x itself: thirds.
        let f = [0.0, 0.0, 1.0 / 3.0, 1.0];
        let points = std::array::from_fn(|k| {
            let (i, j) = (k % 4, k / 4);
            Vec3::new(i as f32 / 3.0, j as f32 / 3.0, f[i] + f[j])
        });
        BezierPatch::new(points)
    }

    #[test]
    fn patch_vertices_lie_on_the_surface_and_normals_are_its_normals() {
        let m = patches(&[bowl()], &ctx(3.0));
        assert!(m.triangles.len() >= 8);
        for (p, n) in m.positions.iter().zip(m.normals.as_ref().unwrap()) {
            assert!((p.z - (p.x * p.x + p.y * p.y)).abs() < 1e-5, "{p}");
            let want = Vec3::new(-2.0 * p.x, -2.0 * p.y, 1.0).normalize();
            assert!((Vec3::from(*n) - want).length() < 1e-4, "{n} vs {want}");
        }
    }

    #[test]
    fn split_halves_are_the_same_surface() {
        let p = bowl().points.map(Vec3::as_dvec3);
        for along_u in [true, false] {
            let (a, b) = split(&p, along_u);
            for t in [0.0, 0.3, 1.0] {
                for s in [0.0, 0.6, 1.0] {
                    // (t along the split direction, s across it)
                    let uv = |x: f64| if along_u { (x, s) } else { (s, x) };
                    let (ua, va) = uv(t);
                    let (u0, v0) = uv(0.5 * t);
                    let (u1, v1) = uv(0.5 + 0.5 * t);
                    assert!(evaluate(&a, ua, va).0.distance(evaluate(&p, u0, v0).0) < 1e-12);
                    assert!(evaluate(&b, ua, va).0.distance(evaluate(&p, u1, v1).0) < 1e-12);
                }
            }
        }
    }

    #[test]
    fn a_large_floor_dices_finely_only_near_the_camera() {
        // A 40-unit floor from 1 unit in front of the camera to 41 units away: each piece is diced at
        // its own distance, so triangles near the camera are far smaller than those at the back, and
        // the whole stays within what its on-screen coverage allows.
        let floor = BezierPatch::new(std::array::from_fn(|k| {
            let (i, j) = ((k % 4) as f32 / 3.0, (k / 4) as f32 / 3.0);
            Vec3::new(40.0 * i - 20.0, -1.0, 1.0 + 40.0 * j)
        }));
        let ctx = DicingContext::new(DicingHint::Perspective, 90.0, Format::new(160, 120));
        let mesh = patches(&[floor], &ctx);
        let mean_edge = |near: bool| {
            let edges: Vec<f32> = mesh
                .triangles
                .iter()
                .map(|t| t.map(|i| mesh.positions[i as usize]))
                .filter(|p| {
                    let z = (p[0].z + p[1].z + p[2].z) / 3.0;
                    if near { z < 3.0 } else { z > 30.0 }
                })
                .map(|p| p[0].distance(p[1]).max(p[1].distance(p[2])))
                .collect();
            assert!(!edges.is_empty());
            edges.iter().sum::<f32>() / edges.len() as f32
        };
        let (near, far) = (mean_edge(true), mean_edge(false));
        assert!(4.0 * near < far, "near edges {near}, far edges {far}");
        let (centre, radius) = bounding_sphere(floor.points.iter().map(|p| p.as_dvec3()));
        let budget = super::super::quad_budget(&ctx, centre.as_vec3(), radius as f32);
        assert!(
            mesh.triangles.len() as u64 <= 2 * budget,
            "{} triangles, budget {budget} quads",
            mesh.triangles.len()
        );
    }

    #[test]
    fn an_orthographic_camera_dices_a_patch_by_its_span_on_screen() {
        // A unit square seen face on, and the same square as a ramp whose far edge is 4 units deeper:
        // on an orthographic image the two cover the same pixels, so they dice alike (the ramp's
        // v polyline is 4.1 units long, which would give it four times the rows). A perspective
        // camera still measures the ramp's whole length.
        let square = |depth: f32| {
            std::array::from_fn(|k| {
                let (i, j) = ((k % 4) as f32 / 3.0, (k / 4) as f32 / 3.0);
                glam::DVec3::new(f64::from(i - 0.5), f64::from(j - 0.5), f64::from(2.0 + depth * j))
            })
        };
        let (flat, ramp) = (square(0.0), square(4.0));
        let ortho = DicingContext::new(DicingHint::Orthographic, 90.0, Format::new(64, 48));
        let (f, r) = (counts(&flat, &ortho), counts(&ramp, &ortho));
        assert!(f.1 >= 20, "{f:?}");
        assert_eq!(r.0, f.0, "{r:?} against {f:?}");
        assert!(r.1.abs_diff(f.1) <= 1, "{r:?} against {f:?}");
        assert_eq!(on_screen_fractions(&flat, &ortho), (1.0, 1.0));
        let (fu, fv) = on_screen_fractions(&ramp, &ortho);
        assert_eq!(fu, 1.0);
        assert!((fv - 1.0 / 17f64.sqrt()).abs() < 1e-12, "{fv}");
        let perspective = DicingContext::new(DicingHint::Perspective, 90.0, Format::new(64, 48));
        assert_eq!(on_screen_fractions(&ramp, &perspective), (1.0, 1.0));
    }

    #[test]
    fn a_nearer_patch_dices_finer() {
        let near = patches(&[bowl()], &ctx(2.0)).triangles.len();
        let far = patches(&[bowl()], &ctx(50.0)).triangles.len();
        assert!(near > 4 * far, "{near} vs {far}");
    }
}
