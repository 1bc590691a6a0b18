//! The interior probe's former intersector, kept only as the tests' reference: runs of 64
//! consecutive triangles of one object with their bounds, and a Möller–Trumbore test inside each
//! run the ray's slab test does not skip. The probe itself casts its rays through the renderer's
//! BVH (`interior.rs`); `tests/mod.rs` checks the two agree ray by ray on the tests' scenes.

use glam::{Mat4, Vec3};
use obscura_scene::{Object, Shape};

use super::interior::Facing;

/// Triangles per bounded run.
const CHUNK: usize = 64;

/// World-space triangles of a scene in runs of up to [`CHUNK`] consecutive triangles of one object,
/// each run with its bounds.
pub(super) struct Triangles {
    groups: Vec<(Vec3, Vec3, Vec<Facing>)>,
}

/// The first hit along a ray: distance and whether the triangle faces the ray's origin.
#[derive(Debug, Clone, Copy)]
struct Hit {
    t: f32,
    front: bool,
}

impl Triangles {
    /// The meshes of `objects`, each posed by its first transform sample.
    pub(super) fn new(objects: &[Object]) -> Self {
        let groups = objects
            .iter()
            .filter_map(|o| {
                let Shape::Mesh(mesh) = &o.shape else {
                    return None;
                };
                let m = o.transform.samples.first().map_or(Mat4::IDENTITY, |s| s.1);
                let p: Vec<Vec3> = mesh.positions.iter().map(|&v| m.transform_point3(v)).collect();
                let normal_matrix = m.inverse().transpose();
                let normals = mesh.normals.as_ref().filter(|n| n.len() == p.len());
                let tris: Vec<Facing> = (mesh.triangles.iter())
                    .filter_map(|t| {
                        let v = [
                            p.get(t[0] as usize)?,
                            p.get(t[1] as usize)?,
                            p.get(t[2] as usize)?,
                        ];
                        let tri = [*v[0], *v[1], *v[2]];
                        // The file's normals when it has them (they survive a flipped winding),
                        // else the counter-clockwise winding.
                        let front = match normals {
                            Some(n) => normal_matrix
                                .transform_vector3(n[t[0] as usize] + n[t[1] as usize] + n[t[2] as usize]),
                            None => (tri[1] - tri[0]).cross(tri[2] - tri[0]),
                        };
                        (tri.iter().all(|x| x.is_finite()) && front.is_finite()).then_some((tri, front))
                    })
                    .collect();
                Some(tris)
            })
            .flat_map(|tris| {
                // Runs of consecutive triangles (files keep neighbours together), each with its
                // bounds, so a ray skips most of a large mesh.
                tris.chunks(CHUNK)
                    .map(|c| {
                        let points = || c.iter().flat_map(|(tri, _)| tri);
                        let lo = points().fold(Vec3::INFINITY, |a, &b| a.min(b));
                        let hi = points().fold(Vec3::NEG_INFINITY, |a, &b| a.max(b));
                        (lo, hi, c.to_vec())
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        Triangles { groups }
    }

    /// The nearest hit from `o` along unit `d` (Möller–Trumbore), if any.
    fn hit(&self, o: Vec3, d: Vec3) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let inv = d.recip();
        for (lo, hi, tris) in &self.groups {
            // Slab test against the group's bounds.
            let (t0, t1) = ((*lo - o) * inv, (*hi - o) * inv);
            let near = t0.min(t1).max_element().max(0.0);
            let far = t0.max(t1).min_element();
            if near > far || best.is_some_and(|b| near > b.t) {
                continue;
            }
            for ([p0, p1, p2], facing) in tris {
                let (e1, e2) = (*p1 - *p0, *p2 - *p0);
                let q = d.cross(e2);
                let det = e1.dot(q);
                if det.abs() < 1e-12 {
                    continue;
                }
                let s = o - *p0;
                let u = s.dot(q) / det;
                if !(0.0..=1.0).contains(&u) {
                    continue;
                }
                let r = s.cross(e1);
                let v = d.dot(r) / det;
                if v < 0.0 || u + v > 1.0 {
                    continue;
                }
                let t = e2.dot(r) / det;
                if t > 1e-6 && best.is_none_or(|b| t < b.t) {
                    best = Some(Hit {
                        t,
                        front: facing.dot(d) < 0.0,
                    });
                }
            }
        }
        best
    }

    /// The nearest hit from `o` along unit `d`, if any: whether the triangle faces `o` (the
    /// verdict the probe takes from it).
    pub(super) fn first_hit(&self, o: Vec3, d: Vec3) -> Option<bool> {
        self.hit(o, d).map(|h| h.front)
    }
}
