//! `Blobby` → triangles: the iso-surface `field = 27/64` cut from a grid of cubes, each split into
//! six tetrahedra (marching tetrahedra: no ambiguous cases, a closed surface wherever the grid
//! covers it).
//!
//! The grid covers the union of the leaves' bounds (each ellipsoid's unit sphere, each segment's
//! capsule, under their matrices). Its cell size is `m/k` (`k` the rate of the bounds' sphere, `m`
//! the micropolygon length), but never finer than [`MAX_CELLS_PER_AXIS`] cells along the longest
//! side: a blob surface is smooth, so the grid's edges only need to be about a micropolygon long.
//! Vertices sit where the field crosses the level along each tetrahedron edge (linear
//! interpolation); normals are the normalised negative field gradient (central differences).

use std::collections::HashMap;

use glam::{DVec3, Mat4, Vec3};
use obscura_scene::{BlobOp, Blobby};

use super::DicingContext;
use super::quadric::Rate;
use crate::ray::TriangleMesh;

/// The level of the surface.
pub(super) const BLOBBY_LEVEL: f64 = 27.0 / 64.0;

/// The most grid cells along the longest side of a blobby's bounds.
pub(super) const MAX_CELLS_PER_AXIS: u32 = 96;

/// `(1 − r²)³` inside the unit ball, 0 outside.
fn falloff(r2: f64) -> f64 {
    if r2 < 1.0 {
        let s = 1.0 - r2;
        s * s * s
    } else {
        0.0
    }
}

/// A leaf or operation, ready to evaluate.
enum Node {
    Constant(f64),
    Ellipsoid(glam::DMat4),
    Segment {
        inverse: glam::DMat4,
        start: DVec3,
        end: DVec3,
        radius: f64,
    },
    Op(BlobOp),
}

/// The field of `nodes` at `p` (object space).
fn field(nodes: &[Node], combined: bool, p: DVec3, values: &mut Vec<f64>) -> f64 {
    values.clear();
    let mut leaves = 0.0;
    for node in nodes {
        let v = match node {
            Node::Constant(c) => *c,
            Node::Ellipsoid(inverse) => falloff(inverse.transform_point3(p).length_squared()),
            Node::Segment {
                inverse,
                start,
                end,
                radius,
            } => {
                let q = inverse.transform_point3(p);
                let d = *end - *start;
                let t = if d.length_squared() > 0.0 {
                    ((q - *start).dot(d) / d.length_squared()).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                falloff((q - (*start + t * d)).length_squared() / (radius * radius))
            }
            Node::Op(op) => {
                let at = |k: &u32| values.get(*k as usize).copied().unwrap_or(0.0);
                match op {
                    BlobOp::Combine { kind, operands } => {
                        let it = operands.iter().map(at);
                        match kind {
                            0 => it.sum(),
                            1 => it.product(),
                            2 => it.fold(f64::NEG_INFINITY, f64::max),
                            _ => it.fold(f64::INFINITY, f64::min),
                        }
                    }
                    BlobOp::Binary { kind: 4, a, b } => at(a) - at(b),
                    BlobOp::Binary { a, b, .. } => at(a) / at(b),
                    BlobOp::Unary { kind: 6, a } => -at(a),
                    BlobOp::Unary { a, .. } => at(a),
                    _ => 0.0,
                }
            }
        };
        if !matches!(node, Node::Op(_)) {
            leaves += v;
        }
        values.push(if v.is_finite() { v } else { 0.0 });
    }
    if combined {
        values.last().copied().unwrap_or(0.0)
    } else {
        leaves
    }
}

/// Corner `k` of the cube [−1, 1]³: at the `k & 1`, `k >> 1 & 1`, `k >> 2 & 1` ends of x, y and z.
pub(super) fn cube_corner(k: usize) -> Vec3 {
    Vec3::new(
        if k & 1 == 0 { -1.0 } else { 1.0 },
        if k & 2 == 0 { -1.0 } else { 1.0 },
        if k & 4 == 0 { -1.0 } else { 1.0 },
    )
}

/// The object-space box of a leaf: the unit cube under `m` (holds the unit ball).
fn leaf_box(m: Mat4, extra: f32) -> (DVec3, DVec3) {
    let mut lo = DVec3::INFINITY;
    let mut hi = DVec3::NEG_INFINITY;
    for k in 0..8 {
        let c = cube_corner(k) * (1.0 + extra);
        let p = m.transform_point3(c).as_dvec3();
        lo = lo.min(p);
        hi = hi.max(p);
    }
    (lo, hi)
}

/// True when the program's field is the sum of its leaves: no operations, or one final `add` of
/// every leaf exactly once.
fn additive(ops: &[BlobOp]) -> bool {
    let leaves: Vec<u32> = (0..ops.len() as u32)
        .filter(|&k| {
            matches!(
                ops[k as usize],
                BlobOp::Constant(_) | BlobOp::Ellipsoid(_) | BlobOp::Segment { .. }
            )
        })
        .collect();
    match ops.split_last() {
        _ if leaves.len() == ops.len() => true,
        Some((BlobOp::Combine { kind: 0, operands }, rest)) if leaves.len() == rest.len() => {
            let mut sorted = operands.clone();
            sorted.sort_unstable();
            sorted == leaves
        }
        _ => false,
    }
}

/// The object-space box of a segment blob: the boxes of the balls at its two ends, joined.
fn segment_box(start: Vec3, end: Vec3, radius: f32, matrix: Mat4) -> (DVec3, DVec3) {
    let r = Mat4::from_scale(Vec3::splat(radius.abs()));
    let (a0, b0) = leaf_box(matrix * Mat4::from_translation(start) * r, 0.0);
    let (a1, b1) = leaf_box(matrix * Mat4::from_translation(end) * r, 0.0);
    (a0.min(a1), b0.max(b1))
}

/// The six tetrahedra of a cube, as corner indices (corner `k` is at `(k&1, k>>1&1, k>>2&1)`),
/// all sharing the diagonal 0–7.
const TETRAHEDRA: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 3, 2, 7],
    [0, 2, 6, 7],
    [0, 6, 4, 7],
    [0, 4, 5, 7],
    [0, 5, 1, 7],
];

/// The blobby's surface as triangles.
pub(super) fn blobby(blob: &Blobby, ctx: &DicingContext) -> TriangleMesh {
    let (nodes, lo, hi) = compile(&blob.ops);
    if !(lo.is_finite() && hi.is_finite()) || lo.cmpge(hi).any() {
        return TriangleMesh::default();
    }
    let grid = Grid::new(lo, hi, ctx);
    let values = if additive(&blob.ops) {
        grid.sum_of_leaves(&nodes, &blob.ops)
    } else {
        let combined = blob.ops.iter().any(|o| {
            matches!(
                o,
                BlobOp::Combine { .. } | BlobOp::Binary { .. } | BlobOp::Unary { .. }
            )
        });
        grid.field(&nodes, combined)
    };
    Polygoniser::new(&grid, &values).run()
}

/// The program's instructions ready to evaluate, and the object-space box of its leaves.
fn compile(ops: &[BlobOp]) -> (Vec<Node>, DVec3, DVec3) {
    let mut lo = DVec3::INFINITY;
    let mut hi = DVec3::NEG_INFINITY;
    let mut nodes = Vec::with_capacity(ops.len());
    for op in ops {
        let node = match op {
            BlobOp::Constant(c) => Node::Constant(f64::from(*c)),
            BlobOp::Ellipsoid(m) => {
                let (a, b) = leaf_box(*m, 0.0);
                lo = lo.min(a);
                hi = hi.max(b);
                Node::Ellipsoid(m.as_dmat4().inverse())
            }
            BlobOp::Segment {
                start,
                end,
                radius,
                matrix,
            } => {
                let (a, b) = segment_box(*start, *end, *radius, *matrix);
                lo = lo.min(a);
                hi = hi.max(b);
                Node::Segment {
                    inverse: matrix.as_dmat4().inverse(),
                    start: start.as_dvec3(),
                    end: end.as_dvec3(),
                    radius: f64::from(radius.abs()),
                }
            }
            other => Node::Op(other.clone()),
        };
        nodes.push(node);
    }
    (nodes, lo, hi)
}

/// The points the field is sampled at: `nx × ny × nz` of them, `cell` apart from `lo` on, point
/// `(i, j, k)` stored at `(k·ny + j)·nx + i`.
struct Grid {
    lo: DVec3,
    cell: f64,
    nx: usize,
    ny: usize,
    nz: usize,
}

impl Grid {
    /// The grid over the box `lo`–`hi`, with a margin of one cell to keep the surface inside it.
    fn new(lo: DVec3, hi: DVec3, ctx: &DicingContext) -> Grid {
        let extent = hi - lo;
        let longest = extent.max_element();
        let rate = Rate::new(ctx, 0.5 * (lo + hi), 0.5 * extent.length());
        let wanted = rate.segments(longest, 0.0).clamp(4, MAX_CELLS_PER_AXIS);
        let cell = longest / f64::from(wanted);
        let counts = ((extent + DVec3::splat(2.0 * cell)) / cell)
            .ceil()
            .as_uvec3()
            .max(glam::UVec3::ONE);
        Grid {
            lo: lo - DVec3::splat(cell),
            cell,
            nx: counts.x as usize + 1,
            ny: counts.y as usize + 1,
            nz: counts.z as usize + 1,
        }
    }

    /// Grid point `(i, j, k)`, object space.
    fn at(&self, i: usize, j: usize, k: usize) -> DVec3 {
        self.lo + DVec3::new(i as f64, j as f64, k as f64) * self.cell
    }

    /// The index of grid point `(i, j, k)`.
    fn id(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.ny + j) * self.nx + i
    }

    /// The position of the grid point of index `g`.
    fn position(&self, g: usize) -> DVec3 {
        let (x, rest) = (g % self.nx, g / self.nx);
        self.at(x, rest % self.ny, rest / self.ny)
    }

    /// `field − level` at every grid point, for a sum of leaves: each leaf adds itself over the
    /// grid points of its own box only.
    fn sum_of_leaves(&self, nodes: &[Node], ops: &[BlobOp]) -> Vec<f64> {
        let (lo, cell) = (self.lo, self.cell);
        let (nx, ny, nz) = (self.nx, self.ny, self.nz);
        let mut values = vec![-BLOBBY_LEVEL; nx * ny * nz];
        for (node, op) in nodes.iter().zip(ops) {
            let (a, b) = match op {
                BlobOp::Ellipsoid(m) => leaf_box(*m, 0.0),
                BlobOp::Segment {
                    start,
                    end,
                    radius,
                    matrix,
                } => segment_box(*start, *end, *radius, *matrix),
                BlobOp::Constant(c) => {
                    values.iter_mut().for_each(|v| *v += f64::from(*c));
                    continue;
                }
                _ => continue,
            };
            let index = |x: f64, n: usize| ((x / cell).floor().max(0.0) as usize).min(n - 1);
            let (i0, j0, k0) = (
                index(a.x - lo.x, nx),
                index(a.y - lo.y, ny),
                index(a.z - lo.z, nz),
            );
            let (i1, j1, k1) = (
                index(b.x - lo.x + cell, nx),
                index(b.y - lo.y + cell, ny),
                index(b.z - lo.z + cell, nz),
            );
            let one = std::slice::from_ref(node);
            let mut scratch = Vec::new();
            for k in k0..=k1 {
                for j in j0..=j1 {
                    for i in i0..=i1 {
                        values[self.id(i, j, k)] += field(one, false, self.at(i, j, k), &mut scratch);
                    }
                }
            }
        }
        values
    }

    /// `field − level` at every grid point, the whole program evaluated at each.
    fn field(&self, nodes: &[Node], combined: bool) -> Vec<f64> {
        let mut values = vec![-BLOBBY_LEVEL; self.nx * self.ny * self.nz];
        let mut scratch = Vec::new();
        for k in 0..self.nz {
            for j in 0..self.ny {
                for i in 0..self.nx {
                    values[self.id(i, j, k)] += field(nodes, combined, self.at(i, j, k), &mut scratch);
                }
            }
        }
        values
    }

    /// The gradient of `values` at grid point `g`, by central differences on the grid.
    fn gradient(&self, values: &[f64], g: usize) -> DVec3 {
        let (nx, ny, nz) = (self.nx, self.ny, self.nz);
        let (i, rest) = (g % nx, g / nx);
        let (j, k) = (rest % ny, rest / ny);
        let v = |i: usize, j: usize, k: usize| values[self.id(i, j, k)];
        let d = |lo_v: f64, hi_v: f64, span: f64| (hi_v - lo_v) / span;
        let (il, ih) = (i.saturating_sub(1), (i + 1).min(nx - 1));
        let (jl, jh) = (j.saturating_sub(1), (j + 1).min(ny - 1));
        let (kl, kh) = (k.saturating_sub(1), (k + 1).min(nz - 1));
        DVec3::new(
            d(v(il, j, k), v(ih, j, k), (ih - il).max(1) as f64),
            d(v(i, jl, k), v(i, jh, k), (jh - jl).max(1) as f64),
            d(v(i, j, kl), v(i, j, kh), (kh - kl).max(1) as f64),
        )
    }
}

/// Marching tetrahedra over a grid's values: the triangles where they cross 0, each crossing's
/// vertex shared by the tetrahedra around its edge.
struct Polygoniser<'a> {
    grid: &'a Grid,
    values: &'a [f64],
    /// The vertex on each grid edge crossed so far, by its two grid points (lower index first).
    edge_vertex: HashMap<(usize, usize), u32>,
    out: TriangleMesh,
}

impl<'a> Polygoniser<'a> {
    fn new(grid: &'a Grid, values: &'a [f64]) -> Self {
        Polygoniser {
            grid,
            values,
            edge_vertex: HashMap::new(),
            out: TriangleMesh {
                normals: Some(Vec::new()),
                ..TriangleMesh::default()
            },
        }
    }

    /// The surface through every cube the level crosses.
    fn run(mut self) -> TriangleMesh {
        let (nx, ny, nz) = (self.grid.nx, self.grid.ny, self.grid.nz);
        for k in 0..nz - 1 {
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    let ids: [usize; 8] = std::array::from_fn(|c| {
                        self.grid.id(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1))
                    });
                    let inside = ids.iter().filter(|&&g| self.values[g] > 0.0).count();
                    if inside == 0 || inside == 8 {
                        continue;
                    }
                    for tet in TETRAHEDRA {
                        self.tetrahedron(tet.map(|c| ids[c]));
                    }
                }
            }
        }
        self.out
    }

    /// The vertex where the level crosses the edge from grid point `a` to `b` (one inside, one
    /// outside), made once per edge.
    fn vertex(&mut self, a: usize, b: usize) -> u32 {
        let key = (a.min(b), a.max(b));
        if let Some(&v) = self.edge_vertex.get(&key) {
            return v;
        }
        let (grid, values) = (self.grid, self.values);
        let (fa, fb) = (values[a], values[b]);
        let t = (fa / (fa - fb)).clamp(0.0, 1.0);
        let p = grid.position(a).lerp(grid.position(b), t);
        let n = -grid.gradient(values, a).lerp(grid.gradient(values, b), t);
        let v = self.out.positions.len() as u32;
        self.out.positions.push(p.as_vec3a());
        if let Some(ns) = self.out.normals.as_mut() {
            ns.push(n.normalize_or(DVec3::Z).as_vec3a());
        }
        self.edge_vertex.insert(key, v);
        v
    }

    /// The triangles of the tetrahedron of grid points `g`, wound to face along their normals.
    fn tetrahedron(&mut self, g: [usize; 4]) {
        let values = self.values;
        let (ins, outs): (Vec<usize>, Vec<usize>) = g.iter().partition(|&&x| values[x] > 0.0);
        let tris: Vec<[u32; 3]> = match (ins.len(), outs.len()) {
            (1, 3) => vec![[
                self.vertex(ins[0], outs[0]),
                self.vertex(ins[0], outs[1]),
                self.vertex(ins[0], outs[2]),
            ]],
            (3, 1) => vec![[
                self.vertex(outs[0], ins[0]),
                self.vertex(outs[0], ins[1]),
                self.vertex(outs[0], ins[2]),
            ]],
            (2, 2) => {
                let a = self.vertex(ins[0], outs[0]);
                let b = self.vertex(ins[0], outs[1]);
                let c = self.vertex(ins[1], outs[1]);
                let d = self.vertex(ins[1], outs[0]);
                vec![[a, b, c], [a, c, d]]
            }
            _ => Vec::new(),
        };
        let out = &mut self.out;
        for mut t in tris {
            let p = |v: u32| out.positions[v as usize];
            let n = out.normals.as_ref().map_or(glam::Vec3A::Z, |ns| {
                ns[t[0] as usize] + ns[t[1] as usize] + ns[t[2] as usize]
            });
            if (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])).dot(n) < 0.0 {
                t.swap(1, 2);
            }
            out.triangles.push(t);
        }
    }
}

#[cfg(test)]
mod tests {
    use obscura_sdk::{DicingHint, Format};

    use super::*;

    #[test]
    fn a_lone_unit_blob_is_a_sphere_of_radius_one_half() {
        let mut ctx = DicingContext::new(DicingHint::Perspective, 90.0, Format::new(64, 48));
        ctx.object_to_camera = Mat4::from_translation(Vec3::new(0.0, 0.0, 3.0));
        let blob = Blobby {
            ops: vec![BlobOp::Ellipsoid(Mat4::IDENTITY)],
        };
        let m = blobby(&blob, &ctx);
        assert!(m.triangles.len() > 50);
        for (p, n) in m.positions.iter().zip(m.normals.as_ref().unwrap()) {
            assert!((p.length() - 0.5).abs() < 0.02, "{p}");
            assert!(n.dot(p.normalize()) > 0.99, "outward normal {n} at {p}");
        }
        // Two blobs side by side merge into one surface that reaches between them.
        let two = Blobby {
            ops: vec![
                BlobOp::Ellipsoid(Mat4::from_translation(Vec3::new(-0.4, 0.0, 0.0))),
                BlobOp::Ellipsoid(Mat4::from_translation(Vec3::new(0.4, 0.0, 0.0))),
                BlobOp::Combine {
                    kind: 0,
                    operands: vec![0, 1],
                },
            ],
        };
        let m = blobby(&two, &ctx);
        let mid = m.positions.iter().filter(|p| p.x.abs() < 0.05).count();
        assert!(mid > 0, "the blobs join at x = 0");
        // With `max` instead of `add` (the general evaluator) they stay two spheres of radius ½.
        let mut apart = two.clone();
        apart.ops[2] = BlobOp::Combine {
            kind: 2,
            operands: vec![0, 1],
        };
        assert!(!additive(&apart.ops) && additive(&two.ops));
        let m = blobby(&apart, &ctx);
        for p in &m.positions {
            let c = Vec3::new(0.4f32.copysign(p.x), 0.0, 0.0);
            assert!((Vec3::from(*p).distance(c) - 0.5).abs() < 0.03, "{p}");
        }
    }
}
