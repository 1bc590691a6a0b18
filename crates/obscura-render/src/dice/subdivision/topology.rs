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
        // Bucket the face corners by the lower end of their edge (a counting sort), then sort each
        // small bucket by the upper end: edges come out sorted by (lo, hi) without a global sort.
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
        let mut bucket_start = vec![0usize; n + 1];
        for c in 0..corners {
            bucket_start[ends(c).0 as usize + 1] += 1;
        }
        for v in 0..n {
            bucket_start[v + 1] += bucket_start[v];
        }
        let mut fill = bucket_start.clone();
        let mut entries = vec![(0u32, 0u32); corners];
        for c in 0..corners {
            let (lo, hi) = ends(c);
            entries[fill[lo as usize]] = (hi, c as u32);
            fill[lo as usize] += 1;
        }
        let mut edges: Vec<Edge> = Vec::with_capacity(corners / 2 + n);
        let mut corner_edge = vec![0u32; corners];
        for lo in 0..n {
            let bucket = &mut entries[bucket_start[lo]..bucket_start[lo + 1]];
            bucket.sort_unstable();
            for group in bucket.chunk_by(|x, y| x.0 == y.0) {
                let (lo, hi) = (lo as u32, group[0].0);
                if group.len() > 2 {
                    return Err(DiceError::NonManifoldEdge {
                        a: lo,
                        b: hi,
                        faces: group.len(),
                    });
                }
                let id = edges.len() as u32;
                let mut faces = [u32::MAX; 2];
                for (slot, &(_, c)) in group.iter().enumerate() {
                    faces[slot] = corner_face[c as usize];
                    corner_edge[c as usize] = id;
                }
                let sharpness = if group.len() < 2 {
                    f32::INFINITY
                } else {
                    level
                        .creases
                        .binary_search_by(|c| (c.0, c.1).cmp(&(lo, hi)))
                        .map_or(0.0, |i| level.creases[i].2)
                };
                edges.push(Edge {
                    lo,
                    hi,
                    faces,
                    face_count: group.len() as u32,
                    sharpness,
                });
            }
        }
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

/// A compressed adjacency list from `(vertex, item)` pairs.
fn adjacency(n: usize, pairs: impl Iterator<Item = (u32, u32)> + Clone) -> (Vec<usize>, Vec<u32>) {
    let mut start = vec![0usize; n + 1];
    for (v, _) in pairs.clone() {
        start[v as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut items = vec![0u32; start[n]];
    for (v, item) in pairs {
        items[fill[v as usize]] = item;
        fill[v as usize] += 1;
    }
    (start, items)
}
