//! Rays, hits and the tracing interface the shading code is written against.

use glam::Vec3A;

/// A ray in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: Vec3A,
    /// Direction; unit length for camera rays, any non-zero length elsewhere.
    pub direction: Vec3A,
    /// Hits nearer than this are ignored.
    pub t_min: f32,
    /// Hits farther than this are ignored.
    pub t_max: f32,
    /// Shutter-normalised time in `[0, 1)`: moving instances are placed at this time.
    pub time: f32,
}

impl Ray {
    /// The ray from `origin` along `direction` over the whole line ahead (`t_min` 0, `t_max` ∞), at
    /// shutter open.
    #[must_use]
    pub fn new(origin: Vec3A, direction: Vec3A) -> Ray {
        Ray {
            origin,
            direction,
            t_min: 0.0,
            t_max: f32::INFINITY,
            time: 0.0,
        }
    }

    /// The point at parameter `t`.
    #[inline]
    #[must_use]
    pub fn at(&self, t: f32) -> Vec3A {
        self.origin + self.direction * t
    }
}

/// The nearest intersection of a ray with the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// World-space position.
    pub position: Vec3A,
    /// World-space geometric normal, unit length, facing the ray's origin (two-sided).
    pub geometric_normal: Vec3A,
    /// World-space shading normal, unit length, on the same side as `geometric_normal`.
    pub shading_normal: Vec3A,
    /// Barycentric coordinates (u, v) within the triangle.
    pub uv: (f32, f32),
    /// Which instance was hit (index into the instances the accelerator was built from).
    pub instance: u32,
    /// Which triangle of that instance's mesh.
    pub primitive: u32,
    /// The triangle's world-space edges `p₁ − p₀`, `p₂ − p₀` (zero where the surface is not a
    /// triangle): with the vertices' texture coordinates they give the texture-space footprint.
    pub edges: [Vec3A; 2],
}

/// What the shading code needs from geometry: nearest hit and any-hit (shadow) queries.
pub trait Tracer: Send + Sync {
    /// The nearest hit with `t_min < t < t_max`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// The nearest hit a camera ray sees: as [`Tracer::intersect`], but past the backs of one-sided
    /// surfaces and what clipping planes hide (`Sides 1`, `ClippingPlane`). Secondary and shadow rays
    /// see everything.
    fn intersect_camera(&self, ray: &Ray) -> Option<Hit> {
        self.intersect(ray)
    }
    /// The nearest hit a shadow ray sees: as [`Tracer::intersect`], but past what casts no shadow
    /// (`Attribute "visibility" "int transmission" [0]`).
    fn intersect_shadow(&self, ray: &Ray) -> Option<Hit> {
        self.intersect(ray)
    }
    /// True when anything that casts shadows lies on the ray with `t_min < t < t_max`.
    fn occluded(&self, ray: &Ray) -> bool;
}

/// A triangle mesh in object space, ready to build an accelerator over.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3A>,
    /// Per-vertex shading normals (same length as `positions`), if smooth.
    pub normals: Option<Vec<Vec3A>>,
    /// Triangles.
    pub triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// Number of triangles.
    #[must_use]
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// True when there are no triangles.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }
}
