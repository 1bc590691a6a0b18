//! Emissive triangles as lights: every triangle of a surface that emits (a `PxrConstant` — what a
//! glTF `emissiveFactor` or an OBJ `Ke` becomes — or a textured material with a non-zero emissive
//! factor) is sampled by next-event estimation, as well as found by BSDF rays.
//!
//! **Sampling.** A triangle is picked with probability proportional to its world-space area, then a
//! point uniformly on it (`b₁ = √ξ₁(1 − ξ₂)`, `b₂ = √ξ₁ ξ₂`), so the area density is `1 / A` for
//! every emitter point, `A` the total area; seen from `p` at distance `d` under the emitter's
//! cosine `cos θ_l`, the solid-angle density is `p = d² / (|cos θ_l| · A)` (emitters are two-sided,
//! as the path tracer's hits are). The radiance at the sampled point is the one a BSDF ray hitting it
//! would find (the emission texture looked up there), so the two strategies see the same integrand
//! and are weighted by the power heuristic.
//!
//! **Black triangles.** A triangle whose emissive map is black over all its texture coordinates
//! ([`Texturing::emission_is_black`]) is left out of the distribution: light samples go where light
//! is (a helmet's emissive map is black but for its lamps) and no lookup is spent on the rest. A ray
//! that hits a left-out triangle counts its emission with weight 1, so a texel the test misjudged
//! is still counted, once.
//!
//! **What is left to BSDF rays alone.** Moving instances (the sampled point would be at shutter
//! open while the ray has its own time) and emitters with alpha cut-outs or blending (a light sample
//! through a hole would count light that is not there): their emission keeps weight 1 when hit, as
//! before.

use glam::{Affine3A, Vec3A};
use obscura_host::distribution::Distribution1D;
use obscura_scene::Material;

use crate::material::textured::Texturing;
use obscura_geometry::ray::{Hit, TriangleMesh};

/// One emissive triangle, world space.
#[derive(Debug, Clone, Copy)]
struct Triangle {
    p0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
    /// Unit geometric normal.
    n: Vec3A,
    instance: u32,
    primitive: u32,
}

/// The scene's emissive triangles, for light sampling.
#[derive(Debug, Clone, Default)]
pub struct EmissiveTriangles {
    triangles: Vec<Triangle>,
    /// Picks a triangle in proportion to its area.
    pick: Option<Distribution1D<f64>>,
    /// Total area `A`.
    area: f32,
    /// Per instance: whether its triangles are sampled.
    sampled: Vec<bool>,
    /// Per instance, when some of its triangles are left out (black under the emissive map): which.
    left_out: Vec<Option<Vec<bool>>>,
}

/// One point sampled on an emissive triangle, seen from a shading point.
#[derive(Debug, Clone, Copy)]
pub struct EmitterSample {
    /// Unit direction from the shading point toward the emitter point.
    pub wi: Vec3A,
    /// Distance to the emitter point.
    pub dist: f32,
    /// The emitter point (for the shadow ray's end).
    pub point: Vec3A,
    /// The emitter's unit geometric normal at `point`, turned toward the shading point.
    pub normal: Vec3A,
    /// The emitted radiance toward the shading point.
    pub radiance: Vec3A,
    /// Solid-angle density of `wi` (`d² / (|cos θ_l| · A)`).
    pub pdf: f32,
}

/// One instance as [`EmissiveTriangles::new`] reads it.
pub struct EmitterCandidate<'a> {
    /// The instance's mesh, object space.
    pub mesh: &'a TriangleMesh,
    /// Its object-to-world samples; only instances with one transform (or all equal) are sampled.
    pub transform: &'a [(f32, Affine3A)],
    /// Its material and the material's index.
    pub material: Material,
    /// The index of `material` in the scene.
    pub material_index: u32,
}

impl EmissiveTriangles {
    /// Collects the emissive triangles of `instances` (indexed as the accelerator's instances).
    #[must_use]
    pub fn new(instances: &[EmitterCandidate<'_>], texturing: &Texturing) -> Self {
        let mut triangles = Vec::new();
        let mut sampled = vec![false; instances.len()];
        let mut left_out = vec![None; instances.len()];
        for (i, c) in instances.iter().enumerate() {
            let emits = match c.material {
                Material::Constant { color } => {
                    color.r.max(color.g).max(color.b) > 0.0 && !texturing.has_maps(c.material_index)
                }
                _ => false,
            } || texturing.opaque_emitter(c.material_index);
            let Some(&(_, m)) = c.transform.first() else {
                continue;
            };
            let fixed = c.transform.iter().all(|(_, x)| *x == m);
            if !emits || !fixed || c.mesh.is_empty() {
                continue;
            }
            let before = triangles.len();
            for (k, t) in c.mesh.triangles.iter().enumerate() {
                let vertex = |v: u32| c.mesh.positions.get(v as usize).map(|x| m.transform_point3a(*x));
                let (Some(q0), Some(q1), Some(q2)) = (vertex(t[0]), vertex(t[1]), vertex(t[2])) else {
                    continue;
                };
                let q = [q0, q1, q2];
                let (e1, e2) = (q[1] - q[0], q[2] - q[0]);
                let cross = e1.cross(e2);
                let area = 0.5 * cross.length();
                if !(area > 0.0 && area.is_finite()) {
                    continue;
                }
                if texturing.emission_is_black(c.material_index, i as u32, k as u32) {
                    left_out[i].get_or_insert_with(|| vec![false; c.mesh.triangles.len()])[k] = true;
                    continue;
                }
                triangles.push(Triangle {
                    p0: q[0],
                    e1,
                    e2,
                    n: cross.normalize(),
                    instance: i as u32,
                    primitive: k as u32,
                });
            }
            sampled[i] = triangles.len() > before;
        }
        let areas: Vec<f64> = triangles
            .iter()
            .map(|t| 0.5 * f64::from(t.e1.cross(t.e2).length()))
            .collect();
        let total: f64 = areas.iter().sum();
        let pick = Distribution1D::new(areas).ok();
        if pick.is_none() || !(total > 0.0 && total.is_finite()) {
            return EmissiveTriangles::default();
        }
        EmissiveTriangles {
            triangles,
            pick,
            area: total as f32,
            sampled,
            left_out,
        }
    }

    /// True when there is nothing to sample.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Number of emissive triangles.
    #[must_use]
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// The solid-angle density with which [`EmissiveTriangles::sample`] would pick the point a ray
    /// hit on triangle `primitive` of `instance` at distance `dist` with unit direction `d` and unit
    /// geometric normal `n`; `None` when that triangle is not sampled (its emission then has weight
    /// 1, so a triangle left out as black is still counted in full by the rays that hit it).
    #[must_use]
    pub fn pdf(&self, instance: u32, primitive: u32, dist: f32, d: Vec3A, n: Vec3A) -> Option<f32> {
        if !self.sampled.get(instance as usize).copied().unwrap_or(false) {
            return None;
        }
        if let Some(Some(out)) = self.left_out.get(instance as usize)
            && out.get(primitive as usize).copied().unwrap_or(false)
        {
            return None;
        }
        let cos = n.dot(d).abs();
        (cos > 0.0).then(|| dist * dist / (cos * self.area))
    }

    /// Samples a point on an emitter as seen from `p`: `u_pick` chooses the triangle, `u` the point.
    /// `None` when there is no emitter, the point is seen edge-on or coincides with `p`.
    #[must_use]
    pub fn sample(
        &self,
        p: Vec3A,
        u: (f32, f32),
        u_pick: f32,
        scene_materials: &dyn Fn(u32) -> (Material, Option<u32>),
        texturing: &Texturing,
    ) -> Option<EmitterSample> {
        let pick = self.pick.as_ref()?;
        let (k, _, _) = pick.sample_discrete(f64::from(u_pick));
        let t = self.triangles.get(k)?;
        let s = u.0.max(0.0).sqrt();
        let (b1, b2) = (s * (1.0 - u.1), s * u.1);
        let point = t.p0 + t.e1 * b1 + t.e2 * b2;
        let to = point - p;
        let dist = to.length();
        if !(dist > 0.0 && dist.is_finite()) {
            return None;
        }
        let wi = to / dist;
        let cos = t.n.dot(wi).abs();
        if cos <= 1e-7 {
            return None;
        }
        let n = if t.n.dot(wi) > 0.0 { -t.n } else { t.n };
        let hit = Hit {
            t: dist,
            position: point,
            geometric_normal: n,
            shading_normal: n,
            uv: (b1, b2),
            instance: t.instance,
            primitive: t.primitive,
            edges: [t.e1, t.e2],
        };
        let (material, index) = scene_materials(t.instance);
        let radiance = texturing.emission(&hit, material, index);
        Some(EmitterSample {
            wi,
            dist,
            point,
            normal: n,
            radiance,
            pdf: dist * dist / (cos * self.area),
        })
    }
}

#[cfg(test)]
mod tests;
