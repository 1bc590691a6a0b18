//! The path tracer: unidirectional, with next-event estimation and multiple importance sampling.
//!
//! For a camera ray, [`trace_path`] estimates the radiance `L` arriving at the camera:
//!
//! - At every vertex, light found along the incoming ray is added: the emission of a surface (a
//!   PxrConstant, which is what a glTF `emissiveFactor` or an OBJ `Ke` becomes, or a textured
//!   emissive map), a rect or sphere light ([`Lights::intersect_area`]), or, when the ray escapes, the domes
//!   and wide distant lights ([`Lights::escaped`]). On the camera ray (and after a mirror bounce)
//!   the weight is 1; after a BSDF sample it is the power heuristic
//!   `w_bsdf = p_bsdf² / (p_bsdf² + p_light²)`. A camera ray that escapes sees the domes only
//!   ([`Lights::background`]).
//! - At each surface vertex `k < max_depth` (PxrConstant surfaces end the path), the classic ambient
//!   lights' unshadowed radiance `A` ([`Lights::ambient`]) is reflected by the surface's ambient
//!   reflectance: `β · ρ_a · A`, `ρ_a` = `Ka·Cs` for a classic shader's surface, the diffuse albedo
//!   for any other. Then one light is
//!   sampled ([`Lights::sample`]) and a shadow ray traced ([`Tracer::occluded`]); the contribution
//!   `β · f · |n·wi| · L / p_light` is weighted by `w_light = p_light² / (p_light² + p_bsdf²)` when
//!   the light can also be found by BSDF rays, by 1 otherwise (delta-like distant lights).
//! - At the same vertex, one point on the emissive triangles is sampled too, in proportion to area
//!   ([`EmissiveTriangles::sample`], a second shadow ray), weighted by the power heuristic against
//!   the BSDF's density; a BSDF ray that hits such a triangle weights its emission the other way
//!   ([`EmissiveTriangles::pdf`]). Emitters light sampling cannot aim at (moving, cut out) keep
//!   weight 1 when hit.
//! - A classic shader's surface ([`LocalShading`]: local illumination) ends the path here: its
//!   light samples above take weight 1 (no BSDF ray will find those lights), it samples no emissive
//!   triangles, and nothing reaches it by way of other surfaces, as in the RI's standard shaders
//!   (only light sources light them).
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

use glam::{Vec2, Vec3A};
use obscura_scene::{AmbientReflectance, LocalShading, Material};

use crate::light::Lights;
use crate::light::emissive::EmissiveTriangles;
use crate::material::textured::Texturing;
use crate::material::{Bsdf, sanitize};
use obscura_geometry::ray::{Hit, Ray, Tracer};
use obscura_geometry::rng::Rng;

/// What [`trace_path`] shades against: materials, which instance uses which, and the lights.
#[derive(Debug, Clone, Default)]
pub struct ShadingScene {
    /// Materials; an instance whose index is out of range uses [`Material::default`].
    pub materials: Vec<Material>,
    /// For each instance (the [`Hit::instance`] index), its index into `materials`.
    pub instance_material: Vec<u32>,
    /// The scene's lights.
    pub lights: Lights,
    /// Textures, textured materials and the meshes' texture coordinates.
    pub texturing: Texturing,
    /// The emissive triangles light sampling aims at (empty: emission is found by BSDF rays only).
    pub emissive: EmissiveTriangles,
    /// For each material (index into `materials`), how it shades when it is a classic RenderMan
    /// shader's: by local illumination ([`LocalShading`]). `None`, or an index past the end: path
    /// traced.
    pub local_shading: Vec<Option<LocalShading>>,
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

    /// How instance `instance`'s material shades when it is a classic shader's (local illumination).
    #[must_use]
    pub fn local_shading(&self, instance: u32) -> Option<LocalShading> {
        let m = self.material_index(instance)?;
        self.local_shading.get(m as usize).copied().flatten()
    }

    /// The index of instance `instance`'s material, when it is a known one.
    #[must_use]
    pub fn material_index(&self, instance: u32) -> Option<u32> {
        self.instance_material
            .get(instance as usize)
            .copied()
            .filter(|&m| (m as usize) < self.materials.len())
    }
}

/// A ray's footprint cone in world units: radius `width + spread·t` at distance `t` (the
/// projection's `originRadius` and `raySpread` for a camera ray, in world units).
///
/// Secondary rays start with the radius the cone had at the hit and widen by the lobe they were
/// drawn from (ray cones, Akenine-Möller et al. 2019/2021, without the curvature term): a mirror keeps
/// the spread, a GGX lobe adds `α/2` radians, a diffuse lobe `1/4` radian (about the angle one of the
/// lobe's directions stands for when a few rays represent the hemisphere). Textures seen after a
/// bounce are therefore looked up from coarser mip levels, which is both faster and what a pixel's
/// worth of indirect rays would average to.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RayCone {
    /// Radius at the ray's origin.
    pub width: f32,
    /// Growth of the radius per unit distance (radians, small-angle).
    pub spread: f32,
}

impl RayCone {
    /// The radius at distance `t` (0 when the cone is not finite).
    #[must_use]
    pub fn radius_at(&self, t: f32) -> f32 {
        let r = self.width + self.spread * t;
        if r.is_finite() { r.max(0.0) } else { 0.0 }
    }

    /// The cone of a ray leaving a hit at distance `t`, drawn from a lobe of material `m`.
    #[must_use]
    pub fn bounce(&self, t: f32, m: &Material, specular: bool) -> RayCone {
        let widen = match *m {
            _ if specular => 0.0,
            Material::Surface { roughness, .. } => 0.5 * roughness.clamp(0.0, 1.0).powi(2),
            _ => 0.25,
        };
        RayCone {
            width: self.radius_at(t),
            spread: self.spread.max(0.0) + widen,
        }
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
    /// The base colour at the first hit (linear; footprint-filtered when textured); 0 without a hit.
    pub albedo: Vec3A,
    /// The first texture coordinate set at the first hit; 0 without one.
    pub uv: Vec2,
}

/// How many times a path may pass through cut-out or transparent surfaces before it is stopped.
const MAX_PASS_THROUGH: u32 = 64;

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
/// `time`); every later ray keeps its `time`. Deterministic for a given `rng` state. Textures are
/// looked up without a footprint; [`trace_path_cone`] gives the camera ray's cone.
pub fn trace_path(
    scene: &ShadingScene,
    tracer: &dyn Tracer,
    ray: &Ray,
    rng: &mut Rng,
    opts: &PathOptions,
) -> PathResult {
    trace_path_cone(scene, tracer, ray, RayCone::default(), rng, opts)
}

/// [`trace_path`] for a camera ray with footprint cone `cone` (world units): every texture lookup
/// is filtered over the cone's footprint at the hit, widened at each bounce ([`RayCone`]).
pub fn trace_path_cone(
    scene: &ShadingScene,
    tracer: &dyn Tracer,
    ray: &Ray,
    cone: RayCone,
    rng: &mut Rng,
    opts: &PathOptions,
) -> PathResult {
    let ctx = PathContext {
        scene,
        tracer,
        cutouts: scene.texturing.has_cutouts(),
    };
    let mut path = PathState {
        radiance: Vec3A::ZERO,
        throughput: Vec3A::ONE,
        bsdf_pdf: None,
        cone,
        depth: 0,
        passes: 0,
    };
    let mut result = PathResult {
        radiance: Vec3A::ZERO,
        alpha: 0.0,
        first_hit: None,
        albedo: Vec3A::ZERO,
        uv: Vec2::ZERO,
    };
    let mut ray = *ray;
    while let Some(next) = ctx.vertex(&mut path, &mut result, &ray, rng, opts) {
        ray = next;
    }
    result.radiance = sanitize(path.radiance);
    result
}

/// What every vertex of a path is traced and shaded against.
struct PathContext<'a> {
    scene: &'a ShadingScene,
    tracer: &'a dyn Tracer,
    /// The scene has cut-out or transparent surfaces, which hits and shadow rays pass through.
    cutouts: bool,
}

/// What a path carries from one vertex to the next.
struct PathState {
    /// The radiance gathered so far (each contribution checked by [`accumulate`]).
    radiance: Vec3A,
    /// `β`, the path's throughput.
    throughput: Vec3A,
    /// The BSDF density of the current ray's direction; `None` for the camera ray and after a
    /// mirror bounce (no MIS: weight 1).
    bsdf_pdf: Option<f32>,
    /// The current ray's footprint.
    cone: RayCone,
    /// The scattering events so far; 0 on the camera ray.
    depth: u32,
    /// The surfaces passed through so far ([`MAX_PASS_THROUGH`] at most).
    passes: u32,
}

impl PathState {
    fn add(&mut self, c: Vec3A) {
        accumulate(&mut self.radiance, c);
    }
}

/// A surface vertex, as the light-sampling strategies and the next bounce see it.
struct Vertex {
    /// The hit point.
    p: Vec3A,
    /// Where rays leaving the vertex start: `p` moved `eps` off the surface, on `wo`'s side.
    origin: Vec3A,
    /// The self-intersection offset ([`epsilon`]).
    eps: f32,
    /// The unit direction back along the incoming ray.
    wo: Vec3A,
    /// The unit geometric normal, on `wo`'s side.
    n_g: Vec3A,
    /// The unit shading normal the BSDF uses.
    n_s: Vec3A,
    /// The path's time (motion blur).
    time: f32,
}

impl Vertex {
    /// A ray leaving the vertex along `direction` (unit), up to `t_max`.
    fn ray(&self, direction: Vec3A, t_max: f32) -> Ray {
        Ray {
            origin: self.origin,
            direction,
            t_min: self.eps,
            t_max,
            time: self.time,
        }
    }
}

impl PathContext<'_> {
    /// Follows `ray` to the path's next vertex and adds the light found there (recording the
    /// camera ray's hit in `result`); the ray the path goes on along, `None` where it ends.
    fn vertex(
        &self,
        path: &mut PathState,
        result: &mut PathResult,
        ray: &Ray,
        rng: &mut Rng,
        opts: &PathOptions,
    ) -> Option<Ray> {
        let dir_len = ray.direction.length();
        if !(dir_len > 0.0 && dir_len.is_finite()) {
            return None;
        }
        // The camera ray sees what camera rays see (one-sided surfaces, clipping planes).
        let camera = path.depth == 0;
        let hit = self.nearest_hit(ray, camera, rng, &mut path.passes);
        let t_geometry = hit.map_or(ray.t_max, |h| h.t);
        let lights = &self.scene.lights;

        if let Some(area) = lights.intersect_area(ray, t_geometry) {
            let w = path.bsdf_pdf.map_or(1.0, |p| power_heuristic(p, area.pdf));
            path.add(path.throughput * area.radiance * w);
            if camera {
                result.alpha = 1.0;
            }
            return None;
        }
        let Some(hit) = hit else {
            path.add(path.throughput * escaped_light(lights, ray.direction, path.bsdf_pdf, camera));
            return None;
        };
        if camera {
            result.alpha = 1.0;
            result.first_hit = Some(hit);
        }

        let t_len = hit.t * dir_len;
        let wo = -ray.direction / dir_len;
        let (n_g, n_s) = facing_normals(&hit, wo);
        let d = ray.direction / dir_len;
        let surface = self.scene.texturing.surface(
            &hit,
            self.scene.material(hit.instance),
            self.scene.material_index(hit.instance),
            d,
            n_s,
            path.cone.radius_at(t_len),
            camera,
        );
        if camera {
            result.albedo = surface.albedo;
            result.uv = surface.uv;
        }
        let n_s = surface.normal;
        let bsdf = Bsdf::new(&surface.material, n_s);
        let emitted = bsdf.emission() + surface.emission;
        if emitted != Vec3A::ZERO {
            self.add_emission(path, &hit, emitted, t_len, d, n_g);
        }

        if path.depth >= opts.max_depth || !bsdf.reflects() {
            return None;
        }
        let eps = epsilon(hit.position, t_len);
        let v = Vertex {
            p: hit.position,
            origin: hit.position + n_g * eps,
            eps,
            wo,
            n_g,
            n_s,
            time: ray.time,
        };
        // A classic shader's surface: its lights (weight 1, as no BSDF ray follows), its ambient
        // term, and the path ends; it samples no emissive triangles, as only light sources light it
        // (a `constant` surface lights nothing in the RI).
        let local = self.scene.local_shading(hit.instance);
        classic_ambient(path, lights, local, &bsdf);
        self.sample_lights(path, &v, &bsdf, local.is_none(), rng);
        if local.is_some() {
            return None;
        }
        self.sample_emissive(path, &v, &bsdf, rng);
        path.scatter(&v, &bsdf, t_len, &surface.material, rng, opts)
    }

    /// The nearest hit along `ray` that is there (past cut-outs), as camera rays or as secondary
    /// rays see the scene.
    fn nearest_hit(&self, ray: &Ray, camera: bool, rng: &mut Rng, passes: &mut u32) -> Option<Hit> {
        let hit = if camera {
            self.tracer.intersect_camera(ray)
        } else {
            self.tracer.intersect(ray)
        };
        match hit {
            Some(h) if self.cutouts => {
                let rays = if camera { Rays::Camera } else { Rays::Secondary };
                pass_cutouts(self.scene, self.tracer, ray, h, rays, rng, passes)
            }
            h => h,
        }
    }

    /// Adds a surface's emission `emitted`, seen along `d` at distance `t_len`: weighted against
    /// emissive-triangle sampling after a BSDF sample when light sampling also aims at it.
    fn add_emission(
        &self,
        path: &mut PathState,
        hit: &Hit,
        emitted: Vec3A,
        t_len: f32,
        d: Vec3A,
        n_g: Vec3A,
    ) {
        let light_pdf = self
            .scene
            .emissive
            .pdf(hit.instance, hit.primitive, t_len, d, n_g);
        let w = match (path.bsdf_pdf, light_pdf) {
            (Some(p), Some(light_pdf)) => power_heuristic(p, light_pdf),
            _ => 1.0,
        };
        path.add(path.throughput * emitted * w);
    }

    /// Next-event estimation on the lights: one light sample and its shadow ray, weighted against
    /// the BSDF's density when `mis` (a BSDF ray may follow) and the light can be found by BSDF rays.
    fn sample_lights(&self, path: &mut PathState, v: &Vertex, bsdf: &Bsdf, mis: bool, rng: &mut Rng) {
        let (u_light, u_pick) = (rng.next_2d(), rng.next_f32());
        let Some(ls) = self
            .scene
            .lights
            .sample(v.p, v.n_s, u_light, u_pick)
            .filter(|ls| ls.wi.dot(v.n_g) > 0.0)
        else {
            return;
        };
        let (f, pdf_b) = bsdf.eval(v.wo, ls.wi);
        if f == Vec3A::ZERO {
            return;
        }
        let t_max = if ls.dist.is_finite() {
            ls.dist - 2.0 * v.eps
        } else {
            f32::INFINITY
        };
        let shadow = v.ray(ls.wi, t_max);
        if t_max > v.eps && !(ls.shadows && self.blocked(&shadow, rng)) {
            let w = if ls.mis && mis {
                power_heuristic(ls.pdf, pdf_b)
            } else {
                1.0
            };
            let cos = v.n_s.dot(ls.wi).abs();
            path.add(path.throughput * f * ls.radiance * (cos * w / ls.pdf));
        }
    }

    /// Next-event estimation on the emissive triangles: one point, in proportion to area, and its
    /// shadow ray, weighted against the BSDF's density.
    fn sample_emissive(&self, path: &mut PathState, v: &Vertex, bsdf: &Bsdf, rng: &mut Rng) {
        let scene = self.scene;
        if scene.emissive.is_empty() {
            return;
        }
        let (u_point, u_tri) = (rng.next_2d(), rng.next_f32());
        let materials = |i: u32| (scene.material(i), scene.material_index(i));
        let Some(es) = scene
            .emissive
            .sample(v.p, u_point, u_tri, &materials, &scene.texturing)
            .filter(|es| es.wi.dot(v.n_g) > 0.0 && es.radiance != Vec3A::ZERO)
        else {
            return;
        };
        let (f, pdf_b) = bsdf.eval(v.wo, es.wi);
        // Both ends offset off their surfaces, each toward the other's side: the segment cannot
        // reach the emitter's own plane, whatever the angles.
        let target = es.point + es.normal * epsilon(es.point, es.dist);
        let to = target - v.origin;
        let length = to.length();
        if f != Vec3A::ZERO && length > v.eps {
            let shadow = v.ray(to / length, length);
            if !self.blocked(&shadow, rng) {
                let w = power_heuristic(es.pdf, pdf_b);
                let cos = v.n_s.dot(es.wi).abs();
                path.add(path.throughput * f * es.radiance * (cos * w / es.pdf));
            }
        }
    }

    /// [`shadow_blocked`] in this context.
    fn blocked(&self, shadow: &Ray, rng: &mut Rng) -> bool {
        shadow_blocked(self.scene, self.tracer, shadow, self.cutouts, rng)
    }
}

impl PathState {
    /// The BSDF-sampled continuation: draws the next direction from `bsdf` at `v`, updates `β`,
    /// the MIS density and the cone (from a hit at distance `t_len` on `material`), and plays
    /// Russian roulette from `rr_start` on; the next ray, `None` where the path ends.
    fn scatter(
        &mut self,
        v: &Vertex,
        bsdf: &Bsdf,
        t_len: f32,
        material: &Material,
        rng: &mut Rng,
        opts: &PathOptions,
    ) -> Option<Ray> {
        let (u_dir, u_lobe) = (rng.next_2d(), rng.next_f32());
        let s = bsdf.sample(v.wo, u_dir, u_lobe)?;
        if s.wi.dot(v.n_g) <= 0.0 {
            return None;
        }
        self.throughput *= s.weight;
        if !self.throughput.is_finite() || self.throughput.max_element() <= 0.0 {
            return None;
        }
        self.bsdf_pdf = (!s.specular).then_some(s.pdf);
        self.cone = self.cone.bounce(t_len, material, s.specular);
        self.depth += 1;

        if self.depth >= opts.rr_start {
            let q = self.throughput.max_element().clamp(0.05, 1.0);
            if rng.next_f32() >= q {
                return None;
            }
            self.throughput /= q;
        }
        Some(v.ray(s.wi, f32::INFINITY))
    }
}

/// The light a ray that escapes the scene brings, before `β`: the domes for the camera ray, the
/// infinite lights BSDF rays find otherwise, weighted against light sampling after a BSDF sample.
fn escaped_light(lights: &Lights, direction: Vec3A, bsdf_pdf: Option<f32>, camera: bool) -> Vec3A {
    match bsdf_pdf {
        None if camera => lights.background(direction),
        None => lights.escaped(direction).0,
        Some(p) => {
            let (l, light_pdf) = lights.escaped(direction);
            l * power_heuristic(p, light_pdf)
        }
    }
}

/// The unit geometric and shading normals of `hit`, both on `wo`'s side; a shading normal that
/// still faces away from `wo` gives way to the geometric one.
fn facing_normals(hit: &Hit, wo: Vec3A) -> (Vec3A, Vec3A) {
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
    (n_g, n_s)
}

/// The classic ambient term: the ambient lights' unshadowed radiance reflected by the surface's
/// ambient reflectance (`Ka·Cs` or a scaled diffuse albedo for a classic shader's surface, the
/// diffuse albedo for any other).
fn classic_ambient(path: &mut PathState, lights: &Lights, local: Option<LocalShading>, bsdf: &Bsdf) {
    let ambient = lights.ambient();
    if ambient == Vec3A::ZERO {
        return;
    }
    let reflectance = match local.map(|l| l.ambient) {
        Some(AmbientReflectance::Color(c)) => Vec3A::new(c.r, c.g, c.b),
        Some(AmbientReflectance::DiffuseScaled(k)) => k * bsdf.diffuse_albedo(),
        None => bsdf.diffuse_albedo(),
    };
    path.add(path.throughput * reflectance * ambient);
}

/// The surface opacity of `hit` (1 unless its material is MASK or BLEND).
fn opacity(scene: &ShadingScene, hit: &Hit) -> f32 {
    scene.texturing.opacity(hit, scene.material_index(hit.instance))
}

/// Which rays a search for the next hit is for: each sees what [`Tracer`] lets it see.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rays {
    /// [`Tracer::intersect_camera`].
    Camera,
    /// [`Tracer::intersect`].
    Secondary,
    /// [`Tracer::intersect_shadow`].
    Shadow,
}

/// The first hit along `ray` from `hit` on that is there: a cut-out (opacity 0) is passed, a
/// transparent surface (0 < opacity < 1) is passed with probability `1 − opacity`. At most
/// [`MAX_PASS_THROUGH`] surfaces are passed per path; then the next one counts as opaque.
fn pass_cutouts(
    scene: &ShadingScene,
    tracer: &dyn Tracer,
    ray: &Ray,
    mut hit: Hit,
    rays: Rays,
    rng: &mut Rng,
    passes: &mut u32,
) -> Option<Hit> {
    loop {
        let o = opacity(scene, &hit);
        if o >= 1.0 || *passes >= MAX_PASS_THROUGH || (o > 0.0 && rng.next_f32() < o) {
            return Some(hit);
        }
        *passes += 1;
        let next = Ray {
            t_min: hit.t.next_up().max(hit.t * (1.0 + 1e-6)),
            ..*ray
        };
        hit = match rays {
            Rays::Camera => tracer.intersect_camera(&next)?,
            Rays::Secondary => tracer.intersect(&next)?,
            Rays::Shadow => tracer.intersect_shadow(&next)?,
        };
    }
}

/// True when a shadow ray is blocked: by anything when the scene has no cut-outs, else by a surface
/// that is there ([`pass_cutouts`]'s rule, with its own budget).
fn shadow_blocked(
    scene: &ShadingScene,
    tracer: &dyn Tracer,
    ray: &Ray,
    cutouts: bool,
    rng: &mut Rng,
) -> bool {
    if !cutouts {
        return tracer.occluded(ray);
    }
    let mut passes = 0;
    tracer
        .intersect_shadow(ray)
        .and_then(|h| pass_cutouts(scene, tracer, ray, h, Rays::Shadow, rng, &mut passes))
        .is_some()
}

#[cfg(test)]
mod tests;
