//! The topology of one subdivision level: its edges (sorted by their ends, with the faces on either
//! side and their crease sharpness), which edges and faces meet at each vertex, and how a crease's
//! sharpness passes to its children.

use super::Level;
use crate::dice::DiceError;

/// One edge of a level, `lo < hi`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Edge {
    pub(crate) lo: u32,
    pub(crate) hi: u32,
    pub(crate) faces: [u32; 2],
    pub(crate) face_count: u32,
    /// Boundary edges are infinitely sharp.
    pub(crate) sharpness: f32,
}

impl Edge {
    /// The end that is not `v`.
    pub(crate) fn other(&self, v: u32) -> u32 {
        if self.lo == v { self.hi } else { self.lo }
    }

    /// True when fewer than two faces use the edge.
    pub(crate) fn is_boundary(&self) -> bool {
        self.face_count < 2
    }
}

/// Edges (sorted by their ends) and vertex adjacency of a [`Level`].
pub(crate) struct Topology {
    pub(crate) edges: Vec<Edge>,
    /// Parallel to `face_verts`: the edge from each face corner to the next.
    pub(crate) corner_edge: Vec<u32>,
    pub(crate) vertex_edge_start: Vec<usize>,
    pub(crate) vertex_edges: Vec<u32>,
    pub(crate) vertex_face_start: Vec<usize>,
    pub(crate) vertex_faces: Vec<u32>,
}

impl Topology {
    /// The topology of `level`; fails on an edge shared by more than two faces.
    pub(crate) fn build(level: &Level) -> Result<Topology, DiceError> {
        let n = level.positions.len();
        let (edges, corner_edge) = sorted_edges(level)?;
        let (vertex_edge_start, vertex_edges) = adjacency(
            n,
            edges
                .iter()
                .enumerate()
                .flat_map(|(i, e)| [(e.lo, i as u32), (e.hi, i as u32)]),
        );
        let (vertex_face_start, vertex_faces) = adjacency(
            n,
            (0..level.face_count()).flat_map(|f| level.face(f).iter().map(move |&v| (v, f as u32))),
        );
        Ok(Topology {
            edges,
            corner_edge,
            vertex_edge_start,
            vertex_edges,
            vertex_face_start,
            vertex_faces,
        })
    }

    /// The edges at vertex `v`.
    pub(crate) fn edges_of(&self, v: u32) -> &[u32] {
        &self.vertex_edges[self.vertex_edge_start[v as usize]..self.vertex_edge_start[v as usize + 1]]
    }

    /// The faces at vertex `v`.
    pub(crate) fn faces_of(&self, v: u32) -> &[u32] {
        &self.vertex_faces[self.vertex_face_start[v as usize]..self.vertex_face_start[v as usize + 1]]
    }

    /// A boundary vertex with one face: RenderMan's `interpolateboundary` makes it a corner.
    pub(crate) fn is_boundary_corner(&self, v: u32) -> bool {
        self.faces_of(v).len() == 1
            && self
                .edges_of(v)
                .iter()
                .any(|&e| self.edges[e as usize].is_boundary())
    }

    /// The sharpness the child of edge `e` at end `v` gets: one less per step, averaged Chaikin-style
    /// with the other semi-sharp edges at `v`.
    pub(crate) fn child_sharpness(&self, e: u32, v: u32) -> f32 {
        let s = self.edges[e as usize].sharpness;
        if s <= 0.0 || s.is_infinite() {
            return s.max(0.0);
        }
        let (sum, count) = self
            .edges_of(v)
            .iter()
            .filter(|&&o| o != e)
            .map(|&o| self.edges[o as usize].sharpness)
            .filter(|o| *o > 0.0 && o.is_finite())
            .fold((0.0f32, 0u32), |(sum, count), o| (sum + o, count + 1));
        let base = if count == 0 {
            s
        } else {
            0.75 * s + 0.25 * sum / count as f32
        };
        (base - 1.0).max(0.0)
    }
}

/// A compressed adjacency list from `(vertex, item)` pairs (a counting sort by vertex): vertex `v`'s
/// items, in the order given, are `items[start[v]..start[v + 1]]`.
fn adjacency<T: Copy + Default>(
    n: usize,
    pairs: impl Iterator<Item = (u32, T)> + Clone,
) -> (Vec<usize>, Vec<T>) {
    let mut start = vec![0usize; n + 1];
    for (v, _) in pairs.clone() {
        start[v as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut items = vec![T::default(); start[n]];
    for (v, item) in pairs {
        items[fill[v as usize]] = item;
        fill[v as usize] += 1;
    }
    (start, items)
}

/// The edges of `level`, sorted by `(lo, hi)`, and the edge from each face corner to the next.
///
/// The face corners are bucketed by the lower end of their edge (a counting sort), then each small
/// bucket is sorted by the upper end: edges come out sorted by `(lo, hi)` without a global sort.
fn sorted_edges(level: &Level) -> Result<(Vec<Edge>, Vec<u32>), DiceError> {
    let n = level.positions.len();
    let corners = level.face_verts.len();
    let mut corner_face = vec![0u32; corners];
    let mut corner_next = vec![0u32; corners];
    for f in 0..level.face_count() {
        let face = level.face(f);
        for i in 0..face.len() {
            corner_face[level.face_start[f] + i] = f as u32;
            corner_next[level.face_start[f] + i] = face[(i + 1) % face.len()];
        }
    }
    let ends = |c: usize| {
        let (a, b) = (level.face_verts[c], corner_next[c]);
        (a.min(b), a.max(b))
    };
    let (bucket_start, mut entries) = adjacency(
        n,
        (0..corners).map(|c| {
            let (lo, hi) = ends(c);
            (lo, (hi, c as u32))
        }),
    );
    let mut edges: Vec<Edge> = Vec::with_capacity(corners / 2 + n);
    let mut corner_edge = vec![0u32; corners];
    for lo in 0..n {
        let bucket = &mut entries[bucket_start[lo]..bucket_start[lo + 1]];
        bucket.sort_unstable();
        for group in bucket.chunk_by(|x, y| x.0 == y.0) {
            let id = edges.len() as u32;
            for &(_, c) in group {
                corner_edge[c as usize] = id;
            }
            edges.push(edge(level, lo as u32, group, &corner_face)?);
        }
    }
    Ok((edges, corner_edge))
}

/// The edge from `lo` to the common upper end of `group`'s `(hi, corner)` entries: its faces, and its
/// sharpness (infinite on the boundary, else the level's crease sharpness, 0 without one).
fn edge(level: &Level, lo: u32, group: &[(u32, u32)], corner_face: &[u32]) -> Result<Edge, DiceError> {
    let hi = group[0].0;
    if group.len() > 2 {
        return Err(DiceError::NonManifoldEdge {
            a: lo,
            b: hi,
            faces: group.len(),
        });
    }
    let mut faces = [u32::MAX; 2];
    for (slot, &(_, c)) in group.iter().enumerate() {
        faces[slot] = corner_face[c as usize];
    }
    let sharpness = if group.len() < 2 {
        f32::INFINITY
    } else {
        level
            .creases
            .binary_search_by(|c| (c.0, c.1).cmp(&(lo, hi)))
            .map_or(0.0, |i| level.creases[i].2)
    };
    Ok(Edge {
        lo,
        hi,
        faces,
        face_count: group.len() as u32,
        sharpness,
    })
}
