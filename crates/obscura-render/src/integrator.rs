//! The path tracer: unidirectional, with next-event estimation and multiple importance sampling.
//!
//! For a camera ray, [`trace_path`] estimates the radiance `L` arriving at the camera:
//!
//! - At every vertex, light found along the incoming ray is added: the emission of a PxrConstant
//!   surface (with weight 1: constant surfaces are unlit emitters that light sampling never aims
//!   at), a rect or sphere light ([`Lights::intersect_area`]), or, when the ray escapes, the domes
//!   and wide distant lights ([`Lights::escaped`]). On the camera ray (and after a mirror bounce)
//!   the weight is 1; after a BSDF sample it is the power heuristic
//!   `w_bsdf = p_bsdf² / (p_bsdf² + p_light²)`. A camera ray that escapes sees the domes only
//!   ([`Lights::background`]).
//! - At each surface vertex `k < max_depth` (PxrConstant surfaces end the path), one light is
//!   sampled ([`Lights::sample`]) and a shadow ray traced ([`Tracer::occluded`]); the contribution
//!   `β · f · |n·wi| · L / p_light` is weighted by `w_light = p_light² / (p_light² + p_bsdf²)` when
//!   the light can also be found by BSDF rays, by 1 otherwise (delta-like distant lights).
//! - The BSDF then draws the next direction; the throughput becomes `β ← β · f |n·wi| / p_bsdf`.
//!   From vertex `rr_start` on, Russian roulette continues the path with probability
//!   `q = clamp(max(β), 0.05, 1)` and divides `β` by `q`.
//!
//! `max_depth` is the number of scattering events: with 1, only direct lighting at the first hit
//! (plus what the camera sees directly). Secondary and shadow rays start from the hit point offset
//! along the geometric normal by `ε = 10⁻⁴ · max(|p|_∞, t, 10⁻³)` (scale-aware: the rounding error
//! of a hit grows with the coordinates and the distance it was found at, `t` being the length of
//! the segment that reached the hit; about a thousand times f32's relative precision), use
//! `t_min = ε`, and keep the camera ray's `time` (motion blur). Shadow rays toward area lights stop
//! `2ε` short of the light.
//!
//! Alpha is 1 when the camera ray hits geometry or an area light, 0 when it escapes. Every
//! contribution is checked: NaN, infinite and negative values never reach the result.

use glam::Vec3A;
use obscura_scene::Material;

use crate::light::Lights;
use crate::material::{Bsdf, sanitize};
use crate::ray::{Hit, Ray, Tracer};
use crate::rng::Rng;

/// What [`trace_path`] shades against: materials, which instance uses which, and the lights.
#[derive(Debug, Clone, Default)]
pub struct ShadingScene {
    /// Materials; an instance whose index is out of range uses [`Material::default`].
    pub materials: Vec<Material>,
    /// For each instance (the [`Hit::instance`] index), its index into `materials`.
    pub instance_material: Vec<u32>,
    /// The scene's lights.
    pub lights: Lights,
}

impl ShadingScene {
    /// The material of instance `instance` (the default PxrDiffuse when unknown).
    #[must_use]
    pub fn material(&self, instance: u32) -> Material {
        self.instance_material
            .get(instance as usize)
            .and_then(|&m| self.materials.get(m as usize))
            .copied()
            .unwrap_or_default()
    }
}

/// What one camera path found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathResult {
    /// Radiance arriving at the camera along the ray: finite, every channel ≥ 0.
    pub radiance: Vec3A,
    /// 1 when the camera ray hit geometry or an area light, 0 when it escaped.
    pub alpha: f32,
    /// The camera ray's nearest geometry hit, for the z / N / P outputs; `None` when it escaped or
    /// an area light lies in front of the geometry.
    pub first_hit: Option<Hit>,
}

/// Path-tracing options.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PathOptions {
    /// Maximum number of scattering events (bounces) per path. Default 6.
    pub max_depth: u32,
    /// The first vertex index at which Russian roulette may end a path. Default 3.
    pub rr_start: u32,
}

impl Default for PathOptions {
    fn default() -> Self {
        PathOptions {
            max_depth: 6,
            rr_start: 3,
        }
    }
}

/// The power heuristic (β = 2) weight of a strategy with density `a` against one with density
/// `b`: `a² / (a² + b²)`, computed as `1 / (1 + (b/a)²)` so huge densities do not overflow.
/// 0 when `a` is not positive, 1 when `b` is not positive.
#[must_use]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    if a.is_nan() || a <= 0.0 {
        return 0.0;
    }
    if b.is_nan() || b <= 0.0 {
        return 1.0;
    }
    let r = b / a;
    if r.is_nan() {
        return 0.0;
    }
    1.0 / (1.0 + r * r)
}

/// The self-intersection offset for a hit at `p` reached over a segment of length `t_len`.
fn epsilon(p: Vec3A, t_len: f32) -> f32 {
    let scale = p.abs().max_element().max(t_len).max(1e-3);
    if scale.is_finite() { 1e-4 * scale } else { 1e-4 }
}

/// Adds `c` to `acc` unless it has a NaN or infinite channel; negative channels count as 0.
fn accumulate(acc: &mut Vec3A, c: Vec3A) {
    if c.is_finite() {
        *acc += sanitize(c);
    }
}

/// Traces one camera path through `scene` and returns the radiance arriving along `ray` (world
/// space), its alpha and the camera ray's hit. `ray` is used as given (its `t_min`, `t_max`,
/// `time`); every later ray keeps its `time`. Deterministic for a given `rng` state.
pub fn trace_path(
    scene: &ShadingScene,
    tracer: &dyn Tracer,
    ray: &Ray,
    rng: &mut Rng,
    opts: &PathOptions,
) -> PathResult {
    let lights = &scene.lights;
    let mut radiance = Vec3A::ZERO;
    let mut throughput = Vec3A::ONE;
    let mut alpha = 0.0;
    let mut first_hit = None;
    let mut ray = *ray;
    // The BSDF density of the current ray's direction; `None` for the camera ray and after a
    // mirror bounce (no MIS: weight 1).
    let mut bsdf_pdf: Option<f32> = None;
    let mut depth = 0u32;

    loop {
        let dir_len = ray.direction.length();
        if !(dir_len > 0.0 && dir_len.is_finite()) {
            break;
        }
        let hit = tracer.intersect(&ray);
        let t_geometry = hit.map_or(ray.t_max, |h| h.t);

        if let Some(area) = lights.intersect_area(&ray, t_geometry) {
            let w = bsdf_pdf.map_or(1.0, |p| power_heuristic(p, area.pdf));
            accumulate(&mut radiance, throughput * area.radiance * w);
            if depth == 0 {
                alpha = 1.0;
            }
            break;
        }

        let Some(hit) = hit else {
            let light = match bsdf_pdf {
                None if depth == 0 => lights.background(ray.direction),
                None => lights.escaped(ray.direction).0,
                Some(p) => {
                    let (l, light_pdf) = lights.escaped(ray.direction);
                    l * power_heuristic(p, light_pdf)
                }
            };
            accumulate(&mut radiance, throughput * light);
            break;
        };

        if depth == 0 {
            alpha = 1.0;
            first_hit = Some(hit);
        }

        let wo = -ray.direction / dir_len;
        let mut n_g = hit.geometric_normal.try_normalize().unwrap_or(wo);
        if n_g.dot(wo) < 0.0 {
            n_g = -n_g;
        }
        let mut n_s = hit.shading_normal.try_normalize().unwrap_or(n_g);
        if n_s.dot(n_g) < 0.0 {
            n_s = -n_s;
        }
        if n_s.dot(wo) <= 0.0 {
            n_s = n_g;
        }
        let bsdf = Bsdf::new(&scene.material(hit.instance), n_s);
        accumulate(&mut radiance, throughput * bsdf.emission());

        if depth >= opts.max_depth || !bsdf.reflects() {
            break;
        }

        let p = hit.position;
        let eps = epsilon(p, hit.t * dir_len);
        let origin = p + n_g * eps;

        // Next-event estimation.
        let (u_light, u_pick) = (rng.next_2d(), rng.next_f32());
        if let Some(ls) = lights.sample(p, n_s, u_light, u_pick)
            && ls.wi.dot(n_g) > 0.0
        {
            let (f, pdf_b) = bsdf.eval(wo, ls.wi);
            if f != Vec3A::ZERO {
                let t_max = if ls.dist.is_finite() {
                    ls.dist - 2.0 * eps
                } else {
                    f32::INFINITY
                };
                let shadow = Ray {
                    origin,
                    direction: ls.wi,
                    t_min: eps,
                    t_max,
                    time: ray.time,
                };
                if t_max > eps && !tracer.occluded(&shadow) {
                    let w = if ls.mis {
                        power_heuristic(ls.pdf, pdf_b)
                    } else {
                        1.0
                    };
                    let cos = n_s.dot(ls.wi).abs();
                    accumulate(&mut radiance, throughput * f * ls.radiance * (cos * w / ls.pdf));
                }
            }
        }

        // BSDF sampling for the next direction.
        let (u_dir, u_lobe) = (rng.next_2d(), rng.next_f32());
        let Some(s) = bsdf.sample(wo, u_dir, u_lobe) else {
            break;
        };
        if s.wi.dot(n_g) <= 0.0 {
            break;
        }
        throughput *= s.weight;
        if !throughput.is_finite() || throughput.max_element() <= 0.0 {
            break;
        }
        bsdf_pdf = (!s.specular).then_some(s.pdf);
        depth += 1;

        if depth >= opts.rr_start {
            let q = throughput.max_element().clamp(0.05, 1.0);
            if rng.next_f32() >= q {
                break;
            }
            throughput /= q;
        }

        ray = Ray {
            origin,
            direction: s.wi,
            t_min: eps,
            t_max: f32::INFINITY,
            time: ray.time,
        };
    }

    PathResult {
        radiance: sanitize(radiance),
        alpha,
        first_hit,
    }
}

#[cfg(test)]
mod tests;
