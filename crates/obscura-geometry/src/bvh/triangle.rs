//! Triangles: the watertight ray/triangle test ([`TriRay`], two-sided, with the facing it found), which triangles are skipped
//! ([`triangle_vertices`]), and the hit record ([`SceneHit`]) that becomes a world-space [`Hit`].

use glam::{Affine3A, Vec3A};

use crate::ray::{Hit, Ray, TriangleMesh};

/// Per-ray constants of the watertight test (Woop et al. 2013): the ray origin, the axes `kx`, `ky`,
/// `kz` (`kz` the direction's dominant axis; `kx`, `ky` swapped when `D[kz] < 0`, which keeps the
/// triangles' winding) and the shear `(Sx, Sy, Sz) = (D[kx]/D[kz], D[ky]/D[kz], 1/D[kz])`, which
/// maps `A = v − origin` to `(A[kx] − Sx·A[kz], A[ky] − Sy·A[kz], Sz·A[kz])`: the ray becomes the
/// `+z` axis.
#[derive(Clone, Copy)]
pub(super) struct TriRay {
    pub(super) origin: Vec3A,
    /// `[kx, ky, kz]`.
    pub(super) axes: [usize; 3],
    /// `[Sx, Sy, Sz]`.
    pub(super) shear: [f32; 3],
}

impl TriRay {
    /// The constants for a ray from `origin` along `direction`.
    #[inline(always)]
    pub(super) fn new(origin: Vec3A, direction: Vec3A) -> Self {
        let a = direction.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        let dz = direction[kz];
        if dz < 0.0 {
            core::mem::swap(&mut kx, &mut ky);
        }
        Self {
            origin,
            axes: [kx, ky, kz],
            shear: [direction[kx] / dz, direction[ky] / dz, 1.0 / dz],
        }
    }

    /// `v − origin` sheared: `(A[kx] − Sx·A[kz], A[ky] − Sy·A[kz], Sz·A[kz])`, one rounding per
    /// operation in this order (the SIMD leaf tests repeat it lane by lane).
    #[inline(always)]
    pub(super) fn sheared(&self, v: Vec3A) -> Vec3A {
        let [kx, ky, kz] = self.axes;
        let [sx, sy, sz] = self.shear;
        let d = v - self.origin;
        let z = d[kz];
        Vec3A::new(d[kx] - sx * z, d[ky] - sy * z, sz * z)
    }

    /// Two-sided watertight test: `(t, u, v)` with `t_min < t < t_max`, where the hit point is
    /// `(1 - u - v)·v0 + u·v1 + v·v2`.
    #[inline(always)]
    pub(super) fn intersect(&self, tri: &[Vec3A; 3], t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        self.intersect_det(tri, t_min, t_max)
            .map(|(t, u, v, _)| (t, u, v))
    }

    /// [`TriRay::intersect`] with the determinant `det` of the test: `det > 0` exactly when the ray
    /// meets the triangle's front, the side `(v1 − v0)×(v2 − v0)` points to (`D·n < 0`); the sign
    /// is decided by the same exact edge functions as the hit itself, so it never disagrees with it.
    #[inline(always)]
    pub(super) fn intersect_det(
        &self,
        tri: &[Vec3A; 3],
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, f32, f32, f32)> {
        let a = self.sheared(tri[0]);
        let b = self.sheared(tri[1]);
        let c = self.sheared(tri[2]);
        let mut e0 = c.x * b.y - c.y * b.x;
        let mut e1 = a.x * c.y - a.y * c.x;
        let mut e2 = b.x * a.y - b.y * a.x;
        if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
            // The edge lies (nearly) on the ray: decide the sign exactly (products of two f32 are exact
            // in f64), as the paper does.
            let edge = |p: f32, q: f32, r: f32, s: f32| {
                (f64::from(p) * f64::from(q) - f64::from(r) * f64::from(s)) as f32
            };
            e0 = edge(c.x, b.y, c.y, b.x);
            e1 = edge(a.x, c.y, a.y, c.x);
            e2 = edge(b.x, a.y, b.y, a.x);
        }
        if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
            return None;
        }
        let det = e0 + e1 + e2;
        if det == 0.0 {
            return None;
        }
        let t = (e0 * a.z + e1 * b.z + e2 * c.z) / det;
        if t > t_min && t < t_max {
            // Divide rather than multiply by 1/det: for triangles near the bottom of the f32 range
            // det can be denormal and 1/det infinite, and 0·∞ would make the barycentrics NaN.
            Some((t, e1 / det, e2 / det, det))
        } else {
            None
        }
    }
}

/// The vertices of triangle `tri` of `mesh`, or `None` when it is skipped (see the module docs).
pub(super) fn triangle_vertices(mesh: &TriangleMesh, tri: [u32; 3]) -> Option<[Vec3A; 3]> {
    let p = |i: u32| mesh.positions.get(i as usize).copied();
    let v = [p(tri[0])?, p(tri[1])?, p(tri[2])?];
    let finite = v.iter().all(|p| p.is_finite());
    (finite && (v[1] - v[0]).cross(v[2] - v[0]) != Vec3A::ZERO).then_some(v)
}

/// A scene hit in the instance's object space, before the world-space [`Hit`] is assembled.
#[derive(Debug, Clone, Copy)]
pub(super) struct SceneHit {
    pub(super) t: f32,
    pub(super) instance: u32,
    /// Index of the instance's [`MeshBvh`](super::MeshBvh) in the scene.
    pub(super) mesh: usize,
    pub(super) primitive: u32,
    pub(super) u: f32,
    pub(super) v: f32,
}

impl SceneHit {
    /// Assembles the world-space hit on `mesh` placed by `to_world`: position from the barycentrics,
    /// geometric normal from the world-space triangle (turned to face the ray), shading normal from the
    /// vertex normals through the inverse transpose (the geometric one when there are none).
    pub(super) fn world_hit(self, mesh: &TriangleMesh, to_world: &Affine3A, ray: &Ray) -> Hit {
        let [i0, i1, i2] = mesh.triangles[self.primitive as usize].map(|i| i as usize);
        let (w0, w1, w2) = (1.0 - self.u - self.v, self.u, self.v);
        let p = [mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]];
        let position = to_world.transform_point3a(p[0] * w0 + p[1] * w1 + p[2] * w2);
        let q = p.map(|x| to_world.transform_point3a(x));
        let mut geometric = (q[1] - q[0]).cross(q[2] - q[0]).normalize_or_zero();
        if geometric == Vec3A::ZERO {
            // A triangle too small for f32 after transforming: face the ray.
            geometric = (-ray.direction).normalize_or(Vec3A::Z);
        }
        if geometric.dot(ray.direction) > 0.0 {
            geometric = -geometric;
        }
        let shading = mesh
            .normals
            .as_ref()
            .filter(|n| n.len() == mesh.positions.len())
            .map(|n| {
                let local = n[i0] * w0 + n[i1] * w1 + n[i2] * w2;
                (to_world.matrix3.inverse().transpose() * local).normalize_or_zero()
            })
            .filter(|n| *n != Vec3A::ZERO)
            .map_or(geometric, |n| if n.dot(geometric) < 0.0 { -n } else { n });
        Hit {
            t: self.t,
            position,
            geometric_normal: geometric,
            shading_normal: shading,
            uv: (self.u, self.v),
            instance: self.instance,
            primitive: self.primitive,
            edges: [q[1] - q[0], q[2] - q[0]],
        }
    }
}
