//! Catmull–Clark subdivision surfaces → triangles: the control mesh checked as level 0, the level
//! chosen from the rate, uniform steps with semi-sharp creases, then the limit surface.
//!
//! The level is the smallest `j ≥ 1` with `L·k / 2^j ≤ m` (`L` the control mesh's longest edge, `k`
//! for the control points' bounding sphere), i.e. `j = clamp(⌈log₂(L·k/m)⌉, 1, 6)`, lowered while
//! the result would exceed the primitive's [`quad_budget`] (the quads its on-screen coverage
//! allows, at most [`MAX_QUADS_PER_PRIMITIVE`](super::MAX_QUADS_PER_PRIMITIVE)). After `j` uniform steps (the first turns an
//! n-gon into n quads) every vertex moves to its limit position:
//!
//! - smooth interior vertex of valence `n`: `(n²·S + 4·Σ eᵢ + Σ fᵢ) / (n·(n + 5))` (`eᵢ` the edge
//!   neighbours, `fᵢ` the opposite corners of the incident quads);
//! - crease or boundary vertex: `(e_a + 4·S + e_b)/6`, the cubic B-spline limit of the crease curve;
//! - corner (three or more sharp edges, or a boundary vertex with one face): fixed.
//!
//! Creases follow DeRose, Kass and Truong (1998): sharpness ≥ 10 is infinitely sharp; a semi-sharp
//! edge uses the sharp rules while its sharpness is ≥ 1, blends smooth and sharp rules by the
//! fractional sharpness on the step where it drops below 1, and its children's sharpness falls by
//! one per step, averaged Chaikin-style with the neighbouring semi-sharp edges
//! (`s' = ¾·s + ¼·mean(s_neighbours) − 1`). An edge still semi-sharp after the last step is
//! approximated at the limit: sharp limit rules when `s ≥ 1`, else smooth and sharp blended by `s`
//! (exact when the level is at least the sharpness). Boundary edges are infinitely sharp: every boundary is
//! treated as interpolated, with or without `"interpolateboundary"` (RenderMan would drop the
//! outer ring of boundary faces without it). Smooth interior vertices get exact limit normals from
//! the tangent masks of Halstead, Kass and DeRose (1993); crease, boundary and corner vertices get
//! the area-weighted average of the adjacent limit triangles' normals. Normals follow the control
//! faces' winding by the right-hand rule. Quads are split along their shorter diagonal.

mod limit;
mod topology;

use glam::DVec3;
use obscura_scene::SubdivMesh;
use rayon::prelude::*;

use self::limit::limit_surface;
/// Also named by the tests, which build a level's topology directly.
pub(super) use self::topology::Topology;
use super::{
    DiceError, DicingContext, INFINITE_SHARPNESS, MAX_SUBDIVISION_LEVEL, check_finite, micropolygon_length,
    pixels_per_unit, quad_budget,
};
use crate::ray::TriangleMesh;

/// A polygon mesh between subdivision steps.
#[derive(Debug, Clone)]
pub(crate) struct Level {
    pub(crate) positions: Vec<DVec3>,
    /// Face `f` is `face_verts[face_start[f]..face_start[f + 1]]`.
    pub(crate) face_start: Vec<usize>,
    pub(crate) face_verts: Vec<u32>,
    /// Sharp interior edges `(lo, hi, sharpness)`, `lo < hi`, sorted; infinite sharpness is `f32::INFINITY`.
    pub(crate) creases: Vec<(u32, u32, f32)>,
}

impl Level {
    /// The number of faces.
    pub(crate) fn face_count(&self) -> usize {
        self.face_start.len().saturating_sub(1)
    }

    /// The vertices of face `f`, in winding order.
    pub(crate) fn face(&self, f: usize) -> &[u32] {
        &self.face_verts[self.face_start[f]..self.face_start[f + 1]]
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rule {
    Smooth,
    Crease,
    Corner,
}

fn rule(sharp_edges: usize, corner: bool) -> Rule {
    match sharp_edges {
        _ if corner => Rule::Corner,
        0 | 1 => Rule::Smooth,
        2 => Rule::Crease,
        _ => Rule::Corner,
    }
}

/// The control mesh, checked, as level 0.
pub(super) fn control_level(mesh: &SubdivMesh) -> Result<Level, DiceError> {
    let n = mesh.positions.len();
    check_finite(&mesh.positions)?;
    let expected: u64 = mesh.face_counts.iter().map(|&c| u64::from(c)).sum();
    if expected != mesh.face_indices.len() as u64 {
        return Err(DiceError::FaceIndexCount {
            expected,
            found: mesh.face_indices.len(),
        });
    }
    let mut face_start = Vec::with_capacity(mesh.face_counts.len() + 1);
    face_start.push(0usize);
    let mut sorted = Vec::new();
    for (face, &count) in mesh.face_counts.iter().enumerate() {
        let start = *face_start.last().unwrap_or(&0);
        let verts = &mesh.face_indices[start..start + count as usize];
        if count < 3 {
            return Err(DiceError::FaceTooSmall {
                face,
                vertices: count,
            });
        }
        if let Some(&index) = verts.iter().find(|&&i| i as usize >= n) {
            return Err(DiceError::IndexOutOfRange {
                face,
                index,
                vertex_count: n,
            });
        }
        sorted.clear();
        sorted.extend_from_slice(verts);
        sorted.sort_unstable();
        if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
            return Err(DiceError::RepeatedVertex { face, vertex: w[0] });
        }
        face_start.push(start + count as usize);
    }
    let mut creases = Vec::new();
    for (crease, &(a, b, s)) in mesh.creases.iter().enumerate() {
        if let Some(&index) = [a, b].iter().find(|&&i| i as usize >= n) {
            return Err(DiceError::CreaseIndexOutOfRange {
                crease,
                index,
                vertex_count: n,
            });
        }
        if a == b {
            return Err(DiceError::CreaseNotAnEdge { crease, a, b });
        }
        if s > 0.0 {
            let s = if s >= INFINITE_SHARPNESS { f32::INFINITY } else { s };
            creases.push((a.min(b), a.max(b), s));
        }
    }
    creases.sort_unstable_by(|x, y| (x.0, x.1).cmp(&(y.0, y.1)).then(y.2.total_cmp(&x.2)));
    creases.dedup_by_key(|c| (c.0, c.1));
    Ok(Level {
        positions: mesh.positions.iter().map(|p| p.as_dvec3()).collect(),
        face_start,
        face_verts: mesh.face_indices.clone(),
        creases,
    })
}

/// Dices a subdivision mesh at the level the rate asks for.
pub(super) fn subdivision(mesh: &SubdivMesh, ctx: &DicingContext) -> Result<TriangleMesh, DiceError> {
    let level = control_level(mesh)?;
    if level.face_count() == 0 {
        return Ok(TriangleMesh::default());
    }
    let topology = Topology::build(&level)?;
    for (crease, &(a, b, _)) in mesh.creases.iter().enumerate() {
        let key = (a.min(b), a.max(b));
        if topology
            .edges
            .binary_search_by(|e| (e.lo, e.hi).cmp(&key))
            .is_err()
        {
            return Err(DiceError::CreaseNotAnEdge { crease, a, b });
        }
    }
    let levels = subdivision_level(&level, &topology, ctx);
    subdivide_to_limit(level, topology, levels)
}

/// `clamp(⌈log₂(L·k/m)⌉, 1, 6)`, lowered to fit the primitive's [`quad_budget`] (at most
/// [`MAX_QUADS_PER_PRIMITIVE`](super::MAX_QUADS_PER_PRIMITIVE)).
pub(super) fn subdivision_level(level: &Level, topology: &Topology, ctx: &DicingContext) -> u32 {
    let used = || level.face_verts.iter().map(|&v| level.positions[v as usize]);
    let lo = used().fold(DVec3::splat(f64::INFINITY), DVec3::min);
    let hi = used().fold(DVec3::splat(f64::NEG_INFINITY), DVec3::max);
    let (centre, radius) = ((0.5 * (lo + hi)).as_vec3(), (0.5 * (hi - lo).length()) as f32);
    let k = f64::from(pixels_per_unit(ctx, centre, radius));
    let longest = topology
        .edges
        .iter()
        .map(|e| level.positions[e.lo as usize].distance(level.positions[e.hi as usize]))
        .fold(0.0, f64::max);
    let pixels = longest * k / micropolygon_length(ctx);
    let mut levels = if pixels.is_nan() || pixels <= 2.0 {
        1
    } else {
        pixels.log2().ceil().clamp(1.0, f64::from(MAX_SUBDIVISION_LEVEL)) as u32
    };
    let first = level.face_verts.len() as u64;
    let budget = quad_budget(ctx, centre, radius);
    while levels > 1 && first.saturating_mul(1 << (2 * (levels - 1))) > budget {
        levels -= 1;
    }
    levels
}

/// `levels` Catmull–Clark steps (at least one), then the limit surface as triangles.
pub(super) fn subdivide_to_limit(
    mut level: Level,
    mut topology: Topology,
    levels: u32,
) -> Result<TriangleMesh, DiceError> {
    for _ in 0..levels.max(1) {
        level = subdivide(&level, &topology)?;
        topology = Topology::build(&level)?;
    }
    Ok(limit_surface(&level, &topology))
}

/// One Catmull–Clark step with DeRose et al.'s semi-sharp creases.
pub(super) fn subdivide(level: &Level, topology: &Topology) -> Result<Level, DiceError> {
    let (nv, ne, nf) = (level.positions.len(), topology.edges.len(), level.face_count());
    let vertices = (nv + ne + nf) as u64;
    if vertices > u64::from(u32::MAX) {
        return Err(DiceError::TooLarge { vertices });
    }
    let p = &level.positions;
    let face_points: Vec<DVec3> = (0..nf)
        .into_par_iter()
        .map(|f| {
            let face = level.face(f);
            face.iter().map(|&v| p[v as usize]).sum::<DVec3>() / face.len() as f64
        })
        .collect();
    let edge_points: Vec<DVec3> = topology
        .edges
        .par_iter()
        .map(|e| {
            let mid = 0.5 * (p[e.lo as usize] + p[e.hi as usize]);
            if e.is_boundary() || e.sharpness >= 1.0 {
                return mid;
            }
            let smooth =
                0.5 * mid + 0.25 * (face_points[e.faces[0] as usize] + face_points[e.faces[1] as usize]);
            if e.sharpness > 0.0 {
                smooth.lerp(mid, f64::from(e.sharpness))
            } else {
                smooth
            }
        })
        .collect();
    let vertex_points: Vec<DVec3> = (0..nv as u32)
        .into_par_iter()
        .map(|v| vertex_point(level, topology, &face_points, v))
        .collect();

    let (face_start, face_verts) = child_faces(level, topology);
    let creases = child_creases(topology, nv as u32);
    let positions = vertex_points
        .into_iter()
        .chain(edge_points)
        .chain(face_points)
        .collect();
    Ok(Level {
        positions,
        face_start,
        face_verts,
        creases,
    })
}

/// The faces of the next level as `(face_start, face_verts)`: each n-gon becomes n quads
/// `(corner, edge point, face point, previous edge point)`, numbered vertices, then edges, then faces.
fn child_faces(level: &Level, topology: &Topology) -> (Vec<usize>, Vec<u32>) {
    let mut face_start = Vec::with_capacity(level.face_verts.len() + 1);
    let mut face_verts = Vec::with_capacity(4 * level.face_verts.len());
    face_start.push(0);
    let (nv, ne) = (level.positions.len() as u32, topology.edges.len() as u32);
    for f in 0..level.face_count() {
        let start = level.face_start[f];
        let n = level.face_start[f + 1] - start;
        for i in 0..n {
            let (c, prev) = (start + i, start + (i + n - 1) % n);
            face_verts.extend_from_slice(&[
                level.face_verts[c],
                nv + topology.corner_edge[c],
                nv + ne + f as u32,
                nv + topology.corner_edge[prev],
            ]);
            face_start.push(face_verts.len());
        }
    }
    (face_start, face_verts)
}

/// The creases of the next level: each semi-sharp or sharp interior edge's two halves, with the
/// sharpness [`Topology::child_sharpness`] gives them, sorted; `nv` is the old vertex count.
fn child_creases(topology: &Topology, nv: u32) -> Vec<(u32, u32, f32)> {
    let mut creases = Vec::new();
    for (id, e) in topology.edges.iter().enumerate() {
        if e.is_boundary() || e.sharpness <= 0.0 {
            continue;
        }
        for end in [e.lo, e.hi] {
            let s = topology.child_sharpness(id as u32, end);
            if s > 0.0 {
                creases.push((end, nv + id as u32, s));
            }
        }
    }
    creases.sort_unstable_by_key(|x| (x.0, x.1));
    creases
}

/// The new position of an old vertex.
fn vertex_point(level: &Level, topology: &Topology, face_points: &[DVec3], v: u32) -> DVec3 {
    let p = &level.positions;
    let s = p[v as usize];
    let faces = topology.faces_of(v);
    if faces.is_empty() {
        return s;
    }
    let edges = topology.edges_of(v);
    let corner = topology.is_boundary_corner(v);
    let sharp = |e: &&u32| topology.edges[**e as usize].sharpness > 0.0;
    let child_sharp = |e: &&u32| topology.child_sharpness(**e, v) > 0.0;
    let parent_rule = rule(edges.iter().filter(sharp).count(), corner);
    let child_rule = rule(edges.iter().filter(child_sharp).count(), corner);
    let apply = |rule: Rule, child: bool| match rule {
        Rule::Smooth => {
            let n = edges.len() as f64;
            let q = faces.iter().map(|&f| face_points[f as usize]).sum::<DVec3>() / faces.len() as f64;
            let r = edges
                .iter()
                .map(|&e| 0.5 * (s + p[topology.edges[e as usize].other(v) as usize]))
                .sum::<DVec3>()
                / n;
            (q + 2.0 * r + (n - 3.0) * s) / n
        }
        Rule::Crease => {
            let ends: DVec3 = edges
                .iter()
                .filter(|e| if child { child_sharp(e) } else { sharp(e) })
                .map(|&e| p[topology.edges[e as usize].other(v) as usize])
                .sum();
            (ends + 6.0 * s) / 8.0
        }
        Rule::Corner => s,
    };
    if parent_rule == child_rule {
        return apply(parent_rule, false);
    }
    // The step on which semi-sharp edges fade: blend by their fractional sharpness.
    let (sum, count) = edges
        .iter()
        .filter(|e| sharp(e) && !child_sharp(e))
        .map(|&e| topology.edges[e as usize].sharpness.min(1.0))
        .fold((0.0f64, 0u32), |(sum, count), w| (sum + f64::from(w), count + 1));
    let w = if count == 0 { 1.0 } else { sum / f64::from(count) };
    apply(child_rule, true).lerp(apply(parent_rule, false), w)
}
