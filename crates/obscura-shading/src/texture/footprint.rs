//! From a ray's cone to an ellipse in texture space.
//!
//! A ray carries a cone: radius `r(t) = r₀ + s·t` (the projection's `originRadius` and `raySpread`,
//! half a pixel across for camera rays). At a hit at distance `t` on a triangle with normal `n`, the
//! cone's circular cross-section of radius `r = r(t)` (perpendicular to the ray direction `d`) lands on
//! the surface as an ellipse with semi-axes
//!
//! - `r·t₁`, `t₁ = normalize(n × d)` (across the ray, unchanged), and
//! - `(r / |n·d|)·t₂`, `t₂ = normalize(d − (d·n) n)` (along the ray's trace on the surface, stretched
//!   by the grazing angle; `|n·d|` is kept above 10⁻³).
//!
//! Each surface vector `Δp = α e₁ + β e₂` in the triangle's plane (`e₁ = p₁ − p₀`, `e₂ = p₂ − p₀`) maps
//! to texture space as `Δuv = α (uv₁ − uv₀) + β (uv₂ − uv₀)`, with `(α, β)` from the normal equations
//! `[e₁·e₁ e₁·e₂; e₁·e₂ e₂·e₂] (α, β) = (e₁·Δp, e₂·Δp)`: the affine map the triangle's texture
//! coordinates define. The two semi-axes map to two conjugate semi-axes of the texture-space ellipse,
//! which is what [`Texture::filter`](super::Texture::filter) reads. Nothing here depends on the
//! projection: a plugin or calibrated camera's footprint is used exactly as it fills the fields.

use glam::{Vec2, Vec3A};

/// An ellipse in texture coordinates: centre and two conjugate semi-axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    /// Centre (texture coordinates).
    pub center: Vec2,
    /// First semi-axis.
    pub a: Vec2,
    /// Second semi-axis.
    pub b: Vec2,
}

impl Footprint {
    /// A point: no filtering beyond the texture's own reconstruction.
    #[must_use]
    pub fn point(center: Vec2) -> Self {
        Footprint {
            center,
            a: Vec2::ZERO,
            b: Vec2::ZERO,
        }
    }

    /// The footprint after the affine coordinate map `[a, b, c, d, e, f]`
    /// (`s' = a·s + b·t + c`, `t' = d·s + e·t + f`; `KHR_texture_transform`).
    #[must_use]
    pub fn transformed(&self, m: &[f32; 6]) -> Self {
        let lin = |v: Vec2| Vec2::new(m[0] * v.x + m[1] * v.y, m[3] * v.x + m[4] * v.y);
        Footprint {
            center: lin(self.center) + Vec2::new(m[2], m[5]),
            a: lin(self.a),
            b: lin(self.b),
        }
    }
}

/// The surface's texture-coordinate derivatives on one triangle: the map from a world-space offset
/// in the triangle's plane to a texture-space offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UvMap {
    e1: Vec3A,
    e2: Vec3A,
    /// Inverse of the Gram matrix `[e₁·e₁ e₁·e₂; e₁·e₂ e₂·e₂]`, row-major.
    gram_inv: [f32; 4],
    duv1: Vec2,
    duv2: Vec2,
}

impl UvMap {
    /// The map of a triangle with world-space edges `e1 = p₁ − p₀`, `e2 = p₂ − p₀` and texture
    /// coordinates `uv[0..3]`; `None` for a degenerate triangle.
    #[must_use]
    pub fn new(e1: Vec3A, e2: Vec3A, uv: [Vec2; 3]) -> Option<Self> {
        let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let det = g11 * g22 - g12 * g12;
        if !(det > 0.0 && det.is_finite()) {
            return None;
        }
        Some(UvMap {
            e1,
            e2,
            gram_inv: [g22 / det, -g12 / det, -g12 / det, g11 / det],
            duv1: uv[1] - uv[0],
            duv2: uv[2] - uv[0],
        })
    }

    /// The texture-space offset of the world-space offset `dp` (projected onto the triangle's plane).
    #[must_use]
    pub fn apply(&self, dp: Vec3A) -> Vec2 {
        let (x, y) = (self.e1.dot(dp), self.e2.dot(dp));
        let g = self.gram_inv;
        let alpha = g[0] * x + g[1] * y;
        let beta = g[2] * x + g[3] * y;
        self.duv1 * alpha + self.duv2 * beta
    }

    /// `(∂p/∂u, ∂p/∂v)`: the world-space directions in which `u` and `v` grow by one, in the
    /// triangle's plane; `None` when the texture coordinates are degenerate.
    #[must_use]
    pub fn dp_duv(&self) -> Option<(Vec3A, Vec3A)> {
        let det = self.duv1.x * self.duv2.y - self.duv1.y * self.duv2.x;
        if !(det.abs() > 0.0 && det.is_finite()) {
            return None;
        }
        let dpdu = (self.e1 * self.duv2.y - self.e2 * self.duv1.y) / det;
        let dpdv = (self.e2 * self.duv1.x - self.e1 * self.duv2.x) / det;
        Some((dpdu, dpdv))
    }
}

/// The footprint of a cone of radius `radius` arriving along unit `direction` at a surface of unit
/// normal `normal`, centred on `center` in texture space (see the module documentation).
#[must_use]
pub fn cone_footprint(center: Vec2, radius: f32, direction: Vec3A, normal: Vec3A, map: &UvMap) -> Footprint {
    if !(radius > 0.0 && radius.is_finite()) {
        return Footprint::point(center);
    }
    let cos = direction.dot(normal);
    let along = direction - normal * cos;
    let (t1, t2) = match along.try_normalize() {
        Some(t2) => (normal.cross(t2), t2),
        None => {
            let t1 = normal.any_orthonormal_vector();
            (t1, normal.cross(t1))
        }
    };
    let stretch = 1.0 / cos.abs().max(1e-3);
    Footprint {
        center,
        a: map.apply(t1 * radius),
        b: map.apply(t2 * (radius * stretch)),
    }
}
