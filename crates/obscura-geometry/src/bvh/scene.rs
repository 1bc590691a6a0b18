//! [`SceneAccel`]: the two-level scene accelerator. A top-level binned-SAH tree over the world boxes
//! of [`Instance`]s, each placing a [`MeshBvh`] by a [`Motion`] over the shutter; world rays are
//! moved into object space (direction not renormalised, so `t` carries over) and traced there.
//!
//! # Flattened static instances
//!
//! In the default [`SceneLayout::Flat`], an instance that does not move (one transform sample,
//! finite, invertible), whose mesh no other instance places, and that every ray sees (both sides,
//! seen by camera rays, casting shadows) is *flattened*: its vertices are taken to world space
//! (`p_w = M·p`) and its triangles join one shared [`MeshBvh`] over all flattened instances, in
//! instance order. A ray is traced through that hierarchy first, in world space (no top level, no
//! ray transform), then through the top level over the remaining instances, bounded by the nearest
//! hit so far. Each world triangle keeps `(instance, triangle)`, so a hit reports the same instance
//! and triangle index as the instanced layout, and the world-space [`Hit`] is assembled on the
//! object-space mesh with the instance's transform, as before. Because the flattened triangles are
//! ordered by instance, then triangle, the hierarchy's tie rule (lowest triangle at equal `t`) is
//! the scene's (lowest instance, then lowest triangle), between flattened and traced instances too.
//!
//! The triangle test then runs on `M·p` rounded to `f32` against the world ray, where the instanced
//! layout runs it on `p` against `M⁻¹·ray` rounded to `f32`: the two differ by rounding only (`t`
//! by a few ulps; a ray within ~10⁻⁶ of a shared edge may pick the other triangle). Under the
//! identity both are exactly the same test, bit for bit. A triangle that only degenerates (zero
//! area, non-finite) after the transform is skipped in the flattened layout.
//!
//! Camera rays may see less than other rays: one-sided instances show them one side, clipping
//! planes hide half-spaces ([`SceneAccel::with_camera_visibility`]). Such hits are refused inside
//! the leaf test, so the traversal goes on to the next hit; a scene with neither traces camera rays
//! exactly as every other ray.
//!
//! # Bounds of a moving instance
//!
//! The top-level box of a moving instance is conservative for [`Motion`]'s interpolation (scale and
//! translation linear, rotation by shortest-path slerp, the nearest sample held outside the sampled
//! range). The transformed
//! object lies in the convex hull of its transformed box corners, so it suffices to bound the corner
//! paths `w(f) = T(f) + R(f)·S(f)·x`. Per segment each corner is transformed at 17 evenly spaced
//! times; between two samples a path strays from the chord (which the box of samples contains) by at
//! most `h²/8 · max|w''|` (the linear-interpolation error bound, `h = 1/16`), and with `T` and `S`
//! linear and `R` turning at the constant rate `θ` (the segment's rotation angle),
//! `|w''| <= θ²·|s_max ∘ X| + 2θ·|Δscale ∘ X|`, where `s_max` is the larger absolute scale at the
//! segment's ends and `X` the largest absolute object-space corner coordinates. The box of samples
//! grown by that bound, then by `4e-6` of its largest coordinate for rounding (which also covers
//! glam's slerp switching to a normalised lerp below ~1e-3 rad, where the two differ by ~θ³), contains
//! the instance at every time.

use core::fmt;

use glam::{Affine3A, Vec3A};
use rayon::prelude::*;

#[cfg(target_arch = "x86_64")]
use super::avx2;
use super::build::build_tree;
use super::mesh::MeshBvh;
use super::traverse::{BoxKernel, LeafVisitor, ScalarKernel, traverse};
use super::tree::{Aabb, Tree};
use super::triangle::SceneHit;
use crate::motion::{Motion, interpolate};
use crate::ray::{Hit, Ray, Tracer, TriangleMesh};
use obscura_scene::Sides;

/// Most instances in a top-level leaf: an instance visit costs a whole mesh traversal, so split fully.
const INSTANCE_LEAF_SIZE: usize = 1;
/// Samples per motion segment for the conservative instance bounds.
const MOTION_STEPS: usize = 16;
/// Padding of instance boxes for the rounding of transforms, relative to their largest coordinate.
const BOUNDS_REL_PAD: f32 = 4e-6;

/// One placement of a mesh: object-to-world motion samples at shutter-normalised times in `[0, 1]`.
///
/// Samples are expected sorted by time, with at least one; [`SceneAccel::build`] sorts them anyway,
/// drops samples whose time is not finite, and places an instance with no samples by the identity.
/// With several samples each transform is decomposed into scale, rotation and translation (see
/// [`Motion`]), so it should be invertible and free of shear; a single sample is used exactly as given.
#[derive(Debug, Clone)]
pub struct Instance {
    /// Index of the mesh in the list given to [`SceneAccel::build`]. An out-of-range index makes an
    /// instance that is never hit.
    pub mesh: u32,
    /// `(time, object-to-world)` samples.
    pub transform: Vec<(f32, Affine3A)>,
}

/// How [`SceneAccel`] stores static objects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SceneLayout {
    /// The static instances whose mesh is placed once and which every ray sees (both sides, seen by
    /// camera rays, casting shadows) are flattened: their triangles, moved to world space, share one
    /// [`MeshBvh`] traced without a top level or a ray transform, each triangle remembering its
    /// instance and its index in that instance's mesh. Moving instances, meshes placed more than
    /// once and instances that some rays do not see stay instances under the top level (the
    /// default: the faster one). Hits differ from [`SceneLayout::Instanced`]'s by rounding only
    /// (the triangle test on `M·p` against the world ray rather than on `p` against `M⁻¹·ray`;
    /// bit for bit the same under the identity), with the same instance and triangle indices.
    #[default]
    Flat,
    /// Every instance under the top level, its ray moved to object space. Kept as the reference
    /// the tests and benchmarks compare the flat layout against.
    Instanced,
}

impl SceneLayout {
    /// [`SceneLayout::Instanced`] when the environment variable `OBSCURA_SCENE_LAYOUT` is
    /// `instanced`, else the default.
    #[must_use]
    pub fn from_env() -> Self {
        match std::env::var("OBSCURA_SCENE_LAYOUT") {
            Ok(v) if v.eq_ignore_ascii_case("instanced") => Self::Instanced,
            _ => Self::default(),
        }
    }
}

/// What each kind of ray sees of each instance, indexed like the instances given to
/// [`SceneAccel::build_with`]; missing entries take the default (both sides, seen, casting shadows).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RayVisibility {
    /// Which sides of each instance camera rays see ([`SceneAccel::with_camera_visibility`]).
    pub sides: Vec<Sides>,
    /// Whether camera rays see each instance at all (`Attribute "visibility" "int camera"`).
    pub camera: Vec<bool>,
    /// Whether each instance blocks shadow rays (`Attribute "visibility" "int transmission"`).
    pub shadows: Vec<bool>,
    /// World-space clipping planes `(point, normal)` for camera rays: what lies on the side the
    /// normal points to is hidden. Planes that are not finite or have a zero normal are ignored.
    pub clip_planes: Vec<(Vec3A, Vec3A)>,
}

impl RayVisibility {
    /// True when every ray sees instance `i` whole: both sides, seen by camera rays, casting shadows.
    fn sees_all_of(&self, i: usize) -> bool {
        self.sides.get(i).is_none_or(|s| *s == Sides::Both)
            && self.camera.get(i).copied().unwrap_or(true)
            && self.shadows.get(i).copied().unwrap_or(true)
    }
}

/// One instance as the accelerator keeps it.
#[derive(Debug, Clone)]
pub(super) struct Placement {
    /// Index into `SceneAccel::meshes`, if valid.
    pub(super) mesh: Option<usize>,
    motion: Motion,
    /// Flattened into the world-space mesh ([`SceneLayout::Flat`]) rather than traced as an instance.
    pub(super) flat: bool,
    /// A static placement by the identity: its rays need no transform.
    identity: bool,
}

/// A mesh of the scene, in object space: with its own hierarchy when some instance traces it, bare
/// when only flattened instances place it (hits are still assembled on it).
// One per mesh, looked up once per instance visit: unboxed, the hierarchy is one load closer.
#[allow(clippy::large_enum_variant)]
pub(super) enum SceneMesh {
    /// Traced per instance.
    Traced(MeshBvh),
    /// Placed only by flattened instances.
    Bare(TriangleMesh),
}

impl SceneMesh {
    /// The object-space triangles.
    pub(super) fn mesh(&self) -> &TriangleMesh {
        match self {
            SceneMesh::Traced(bvh) => bvh.mesh(),
            SceneMesh::Bare(mesh) => mesh,
        }
    }
}

/// The flattened instances: one hierarchy over their world-space triangles.
struct FlatMeshes {
    bvh: MeshBvh,
    /// `(instance, triangle of that instance's mesh)` of each world-space triangle; ordered by
    /// instance, then triangle, so the hierarchy's tie rule (lowest triangle) is the scene's (lowest
    /// instance, then lowest triangle).
    source: Vec<(u32, u32)>,
}

/// The scene accelerator: a top-level binned-SAH BVH over instance boxes (conservative over the
/// shutter for moving instances), each instance referring to a [`MeshBvh`], and (in the
/// [`SceneLayout::Flat`] layout) one world-space [`MeshBvh`] over the flattened static instances.
pub struct SceneAccel {
    pub(super) meshes: Vec<SceneMesh>,
    pub(super) placements: Vec<Placement>,
    layout: SceneLayout,
    flat: Option<FlatMeshes>,
    top: Tree,
    /// Instance index of each top-level leaf entry.
    top_ids: Vec<u32>,
    triangle_count: usize,
    /// What each kind of ray sees, as given.
    visibility: RayVisibility,
    /// What camera rays may not see (see [`SceneAccel::with_camera_visibility`]).
    camera: CameraVisibility,
    shadow: ShadowVisibility,
}

/// What camera rays may not see: one-sided instances' backs and clipped half-spaces.
#[derive(Debug, Clone, Default)]
struct CameraVisibility {
    /// Per instance; missing entries see both sides.
    sides: Vec<Sides>,
    /// Per instance: camera rays do not see it at all (`Attribute "visibility" "int camera" [0]`);
    /// missing entries are seen.
    hidden: Vec<bool>,
    /// World-space planes `(n, c)`: a point `p` with `n·p > c` is clipped.
    clip_planes: Vec<(Vec3A, f32)>,
    /// True when any instance is one-sided or hidden or any plane clips: camera rays then take the
    /// filtered traversal; otherwise they take exactly the traversal of every other ray.
    any: bool,
}

impl CameraVisibility {
    fn new(v: &RayVisibility) -> Self {
        let clip_planes: Vec<(Vec3A, f32)> = (v.clip_planes.iter())
            .filter(|(p, n)| p.is_finite() && n.is_finite() && *n != Vec3A::ZERO)
            .map(|&(p, n)| (n, n.dot(p)))
            .collect();
        let hidden: Vec<bool> = v.camera.iter().map(|&seen| !seen).collect();
        let any =
            !clip_planes.is_empty() || v.sides.iter().any(|s| *s != Sides::Both) || hidden.iter().any(|&h| h);
        CameraVisibility {
            sides: v.sides.clone(),
            hidden,
            clip_planes,
            any,
        }
    }

    /// True when camera rays see point `p` (no clipping plane hides it).
    #[inline(always)]
    fn unclipped(&self, p: Vec3A) -> bool {
        self.clip_planes.iter().all(|&(n, c)| n.dot(p) <= c)
    }
}

/// Which instances shadow rays pass through (they cast no shadow).
#[derive(Debug, Clone, Default)]
struct ShadowVisibility {
    /// Per instance; missing entries cast shadows.
    none: Vec<bool>,
    /// True when any instance casts no shadow.
    any: bool,
}

impl ShadowVisibility {
    fn new(v: &RayVisibility) -> Self {
        let none: Vec<bool> = v.shadows.iter().map(|&casts| !casts).collect();
        ShadowVisibility {
            any: none.iter().any(|&n| n),
            none,
        }
    }

    #[inline(always)]
    fn skips(&self, instance: u32) -> bool {
        self.any && self.none.get(instance as usize).copied().unwrap_or(false)
    }
}

impl SceneAccel {
    /// Builds the accelerator over `instances` of `meshes`, every ray seeing every instance, in the
    /// layout `OBSCURA_SCENE_LAYOUT` asks for ([`SceneLayout::from_env`]; flat by default).
    ///
    /// Instances whose mesh index is out of range, or whose world box is not finite (non-finite or
    /// singular motion samples), are kept — their indices still count — but never hit.
    #[must_use]
    pub fn build(meshes: Vec<TriangleMesh>, instances: Vec<Instance>) -> Self {
        Self::build_with(
            meshes,
            instances,
            RayVisibility::default(),
            SceneLayout::from_env(),
        )
    }

    /// [`SceneAccel::build`] with what each kind of ray sees given at once (an instance that some
    /// rays do not see is not flattened, so giving this here rather than through
    /// [`SceneAccel::with_camera_visibility`] and [`SceneAccel::with_ray_visibility`] saves
    /// rebuilding the flattened hierarchy) and the layout chosen. Both layouts give the same hits
    /// up to the rounding of the triangle test in object or world space ([`SceneLayout::Flat`]
    /// says which instances are flattened). The per-mesh hierarchies and the flattened one are
    /// built in parallel (rayon).
    #[must_use]
    pub fn build_with(
        meshes: Vec<TriangleMesh>,
        instances: Vec<Instance>,
        visibility: RayVisibility,
        layout: SceneLayout,
    ) -> Self {
        let n_meshes = meshes.len();
        let placements: Vec<Placement> = instances
            .iter()
            .map(|inst| {
                let motion = Motion::new(&inst.transform);
                Placement {
                    mesh: ((inst.mesh as usize) < n_meshes).then_some(inst.mesh as usize),
                    identity: matches!(motion, Motion::Static { to_world, .. } if to_world == Affine3A::IDENTITY),
                    motion,
                    flat: false,
                }
            })
            .collect();
        Self::assemble(
            meshes.into_iter().map(SceneMesh::Bare).collect(),
            placements,
            visibility,
            layout,
        )
    }

    /// Decides which placements are flattened, builds the hierarchies that are missing and the
    /// top level. Meshes that already have a hierarchy keep it.
    fn assemble(
        meshes: Vec<SceneMesh>,
        mut placements: Vec<Placement>,
        visibility: RayVisibility,
        layout: SceneLayout,
    ) -> Self {
        let n = placements.len().min(u32::MAX as usize);
        placements.truncate(n);
        let mut uses = vec![0usize; meshes.len()];
        for p in &placements {
            if let Some(m) = p.mesh {
                uses[m] += 1;
            }
        }
        // Vertex and triangle indices of the flattened mesh are `u32`: past that, instances stay.
        let (mut flat_vertices, mut flat_triangles) = (0usize, 0usize);
        for (i, p) in placements.iter_mut().enumerate() {
            p.flat = false;
            let Some(m) = p.mesh.filter(|&m| uses[m] == 1) else {
                continue;
            };
            let eligible = layout == SceneLayout::Flat
                && matches!(p.motion, Motion::Static { to_world, to_object }
                    if to_world.is_finite() && to_object.is_finite())
                && visibility.sees_all_of(i);
            let mesh = meshes[m].mesh();
            let (v, t) = (
                flat_vertices + mesh.positions.len(),
                flat_triangles + mesh.triangles.len(),
            );
            if eligible && v < u32::MAX as usize && t < u32::MAX as usize {
                (flat_vertices, flat_triangles) = (v, t);
                p.flat = true;
            }
        }
        let mut traced = vec![false; meshes.len()];
        for p in placements.iter().filter(|p| !p.flat) {
            if let Some(m) = p.mesh {
                traced[m] = true;
            }
        }
        // The flattened mesh is gathered before the meshes move into their builder.
        let flattened = placements
            .iter()
            .any(|p| p.flat)
            .then(|| flatten(&meshes, &placements));
        let build_meshes = || -> Vec<SceneMesh> {
            meshes
                .into_par_iter()
                .zip(traced)
                .map(|(mesh, traced)| match mesh {
                    SceneMesh::Bare(mesh) if traced => SceneMesh::Traced(MeshBvh::build(mesh)),
                    other => other,
                })
                .collect()
        };
        let (meshes, flat) = if let Some((world, source)) = flattened {
            let (meshes, bvh) = rayon::join(build_meshes, || MeshBvh::build(world));
            (meshes, Some(FlatMeshes { bvh, source }))
        } else {
            (build_meshes(), None)
        };
        let boxes: Vec<Aabb> = placements
            .iter()
            .map(|p| match p.mesh.map(|m| &meshes[m]) {
                Some(SceneMesh::Traced(mesh)) if !p.flat && mesh.triangle_count() > 0 => {
                    world_bounds(&p.motion, &mesh.root_bounds())
                }
                _ => Aabb::EMPTY,
            })
            .collect();
        let mut top_ids: Vec<u32> = (0..n as u32).filter(|&i| boxes[i as usize].is_finite()).collect();
        let triangle_count = top_ids
            .iter()
            .filter_map(|&i| placements[i as usize].mesh)
            .map(|m| match &meshes[m] {
                SceneMesh::Traced(bvh) => bvh.triangle_count(),
                SceneMesh::Bare(_) => 0,
            })
            .sum::<usize>()
            + flat.as_ref().map_or(0, |f| f.bvh.triangle_count());
        let top = build_tree(&boxes, &mut top_ids, INSTANCE_LEAF_SIZE);
        Self {
            meshes,
            placements,
            layout,
            flat,
            top,
            top_ids,
            triangle_count,
            camera: CameraVisibility::new(&visibility),
            shadow: ShadowVisibility::new(&visibility),
            visibility,
        }
    }

    /// The accelerator with `visibility`: the same one when every flattened instance is still seen
    /// by every ray, otherwise rebuilt so that the instances some rays do not see are instances.
    fn with_visibility(mut self, visibility: RayVisibility) -> Self {
        let unflatten =
            (self.placements.iter().enumerate()).any(|(i, p)| p.flat && !visibility.sees_all_of(i));
        if unflatten {
            return Self::assemble(self.meshes, self.placements, visibility, self.layout);
        }
        self.camera = CameraVisibility::new(&visibility);
        self.shadow = ShadowVisibility::new(&visibility);
        self.visibility = visibility;
        self
    }

    /// Sets what camera rays ([`Tracer::intersect_camera`]) may not see: `sides[i]` says which sides
    /// of instance `i` they see — [`Sides::Front`] only where the ray meets a triangle from the side
    /// `(v₁ − v₀)×(v₂ − v₀)` points to (in object space, so a mirroring transform keeps the side),
    /// [`Sides::Back`] only the other side — and each plane `(point, normal)` (world space) hides
    /// what lies on the side its normal points to. A hit camera rays may not see is passed: the ray
    /// goes on to the next. Other rays ([`Tracer::intersect`], [`Tracer::occluded`]) see everything.
    /// Planes that are not finite or have a zero normal are ignored. A flattened instance made
    /// one-sided here is taken out of the flattened hierarchy, which is rebuilt
    /// ([`SceneAccel::build_with`] avoids that).
    #[must_use]
    pub fn with_camera_visibility(self, sides: Vec<Sides>, clip_planes: &[(Vec3A, Vec3A)]) -> Self {
        let visibility = RayVisibility {
            sides,
            clip_planes: clip_planes.to_vec(),
            ..self.visibility.clone()
        };
        self.with_visibility(visibility)
    }

    /// Per instance (missing entries: seen, casting shadows): whether camera rays see it at all
    /// (`camera`) and whether shadow rays ([`Tracer::occluded`], [`Tracer::intersect_shadow`]) are
    /// blocked by it (`shadows`). Reflection and bounce rays see every instance. As for
    /// [`SceneAccel::with_camera_visibility`], a flattened instance that some rays do not see is
    /// taken out of the flattened hierarchy.
    #[must_use]
    pub fn with_ray_visibility(self, camera: &[bool], shadows: &[bool]) -> Self {
        let visibility = RayVisibility {
            camera: camera.to_vec(),
            shadows: shadows.to_vec(),
            ..self.visibility.clone()
        };
        self.with_visibility(visibility)
    }

    /// The layout the static instances are stored in.
    #[must_use]
    pub fn layout(&self) -> SceneLayout {
        self.layout
    }

    /// How many instances are flattened into the world-space hierarchy (0 in the
    /// [`SceneLayout::Instanced`] layout) and how many are traced as instances under the top level.
    #[must_use]
    pub fn instance_counts(&self) -> (usize, usize) {
        let flat = self.placements.iter().filter(|p| p.flat).count();
        (flat, self.top_ids.len())
    }

    /// The number of triangles that can be hit, summed over instances (a mesh placed twice counts
    /// twice; instances that are never hit count nothing).
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// The world-space box `(min, max)` enclosing every instance over the whole shutter. An empty
    /// scene gives an empty box: `min = +∞`, `max = −∞`.
    #[must_use]
    pub fn bounds(&self) -> (Vec3A, Vec3A) {
        let mut b = self.top.root_bounds();
        if let Some(flat) = &self.flat {
            b.grow(&flat.bvh.root_bounds());
        }
        (b.lo, b.hi)
    }

    /// The triangles of `instance` in its object space (as diced for the render), or `None` for an
    /// instance that is out of range or has no mesh.
    #[must_use]
    pub fn instance_mesh(&self, instance: u32) -> Option<&TriangleMesh> {
        let mesh = self.placements.get(instance as usize)?.mesh?;
        Some(self.meshes[mesh].mesh())
    }

    /// The object-to-world transform of `instance` at shutter time `time` (clamped to the sampled
    /// range; NaN means the first sample).
    ///
    /// # Panics
    ///
    /// Panics if `instance` is not an index into the instances given to [`SceneAccel::build`].
    #[must_use]
    pub fn instance_transform_at(&self, instance: u32, time: f32) -> Affine3A {
        self.placements[instance as usize].motion.object_to_world(time)
    }

    /// The nearest hit, with the AVX2 kernel unless `scalar_only` (the tests run both).
    pub(super) fn closest_dispatch(&self, ray: &Ray, scalar_only: bool) -> Option<SceneHit> {
        #[cfg(target_arch = "x86_64")]
        if !scalar_only && let Some(k) = avx2::Avx2Kernel::detect() {
            // SAFETY: the token from `detect` proves the CPU supports AVX2 and FMA.
            return unsafe { self.closest_avx2(k, ray) };
        }
        let _ = scalar_only;
        self.closest::<_, false>(ScalarKernel, ray, false)
    }

    /// The nearest hit among the instances that cast shadows, with the AVX2 kernel unless
    /// `scalar_only`.
    pub(super) fn closest_shadow_dispatch(&self, ray: &Ray, scalar_only: bool) -> Option<SceneHit> {
        if !self.shadow.any {
            return self.closest_dispatch(ray, scalar_only);
        }
        #[cfg(target_arch = "x86_64")]
        if !scalar_only && let Some(k) = avx2::Avx2Kernel::detect() {
            // SAFETY: the token from `detect` proves the CPU supports AVX2 and FMA.
            return unsafe { self.closest_shadow_avx2(k, ray) };
        }
        let _ = scalar_only;
        self.closest::<_, false>(ScalarKernel, ray, true)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn closest_shadow_avx2(&self, k: avx2::Avx2Kernel, ray: &Ray) -> Option<SceneHit> {
        self.closest::<_, false>(k, ray, true)
    }

    /// True when anything is hit, with the AVX2 kernel unless `scalar_only`.
    pub(super) fn any_dispatch(&self, ray: &Ray, scalar_only: bool) -> bool {
        #[cfg(target_arch = "x86_64")]
        if !scalar_only && let Some(k) = avx2::Avx2Kernel::detect() {
            // SAFETY: the token from `detect` proves the CPU supports AVX2 and FMA.
            return unsafe { self.any_avx2(k, ray) };
        }
        let _ = scalar_only;
        self.any(ScalarKernel, ray)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn closest_avx2(&self, k: avx2::Avx2Kernel, ray: &Ray) -> Option<SceneHit> {
        self.closest::<_, false>(k, ray, false)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn any_avx2(&self, k: avx2::Avx2Kernel, ray: &Ray) -> bool {
        self.any(k, ray)
    }

    /// The mesh of `instance` and `ray`'s origin and direction in its object space (`None` for an
    /// instance without a mesh); the direction is not renormalised, so `t` carries over unchanged.
    #[inline(always)]
    fn object_ray(&self, instance: u32, ray: &Ray) -> Option<(usize, Vec3A, Vec3A)> {
        let placement = &self.placements[instance as usize];
        let mesh = placement.mesh?;
        if placement.identity {
            return Some((mesh, ray.origin, ray.direction));
        }
        let to_object = placement.motion.world_to_object(ray.time);
        Some((
            mesh,
            to_object.transform_point3a(ray.origin),
            to_object.transform_vector3a(ray.direction),
        ))
    }

    /// The nearest hit; with `CAMERA`, the nearest a camera ray sees; with `shadow`, the nearest
    /// that casts shadows.
    #[inline(always)]
    fn closest<K: BoxKernel, const CAMERA: bool>(
        &self,
        kernel: K,
        ray: &Ray,
        shadow: bool,
    ) -> Option<SceneHit> {
        let mut best = None;
        let mut lim = ray.t_max;
        if let Some(flat) = &self.flat {
            // Flattened instances cast shadows and show camera rays both sides; only clipping
            // planes can hide their hits.
            let found = if CAMERA && !self.camera.clip_planes.is_empty() {
                let camera = &self.camera;
                (flat.bvh).closest_accepted(kernel, ray.origin, ray.direction, ray.t_min, lim, |t, _| {
                    camera.unclipped(ray.at(t))
                })
            } else {
                flat.bvh
                    .closest(kernel, ray.origin, ray.direction, ray.t_min, lim)
            };
            if let Some((t, id, u, v)) = found {
                let (instance, primitive) = flat.source[id as usize];
                best = Some(SceneHit {
                    t,
                    instance,
                    mesh: self.placements[instance as usize].mesh.unwrap_or_default(),
                    primitive,
                    u,
                    v,
                });
                lim = t.next_up();
            }
        }
        if self.top_ids.is_empty() {
            return best;
        }
        let box_ray = kernel.prepare(ray.origin, ray.direction, ray.t_min);
        let mut visitor = SceneClosest::<K, CAMERA> {
            accel: self,
            kernel,
            ray,
            lim,
            best,
            shadow,
        };
        traverse(&self.top, kernel, &box_ray, lim, &mut visitor);
        visitor.best
    }

    /// The nearest hit a camera ray sees, with the AVX2 kernel unless `scalar_only`.
    pub(super) fn closest_camera_dispatch(&self, ray: &Ray, scalar_only: bool) -> Option<SceneHit> {
        if !self.camera.any {
            return self.closest_dispatch(ray, scalar_only);
        }
        #[cfg(target_arch = "x86_64")]
        if !scalar_only && let Some(k) = avx2::Avx2Kernel::detect() {
            // SAFETY: the token from `detect` proves the CPU supports AVX2 and FMA.
            return unsafe { self.closest_camera_avx2(k, ray) };
        }
        let _ = scalar_only;
        self.closest::<_, true>(ScalarKernel, ray, false)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn closest_camera_avx2(&self, k: avx2::Avx2Kernel, ray: &Ray) -> Option<SceneHit> {
        self.closest::<_, true>(k, ray, false)
    }

    #[inline(always)]
    fn any<K: BoxKernel>(&self, kernel: K, ray: &Ray) -> bool {
        if let Some(flat) = &self.flat
            && flat
                .bvh
                .any(kernel, ray.origin, ray.direction, ray.t_min, ray.t_max)
        {
            return true;
        }
        if self.top_ids.is_empty() {
            return false;
        }
        let box_ray = kernel.prepare(ray.origin, ray.direction, ray.t_min);
        let mut visitor = SceneAny {
            accel: self,
            kernel,
            ray,
            found: false,
        };
        traverse(&self.top, kernel, &box_ray, ray.t_max, &mut visitor);
        visitor.found
    }

    /// The world-space [`Hit`] for `h` at the ray's time (see [`SceneHit::world_hit`]).
    pub(super) fn make_hit(&self, ray: &Ray, h: SceneHit) -> Hit {
        let to_world = self.placements[h.instance as usize]
            .motion
            .object_to_world(ray.time);
        h.world_hit(self.meshes[h.mesh].mesh(), &to_world, ray)
    }
}

/// The nearest-hit visitor; with `CAMERA`, one-sided instances and clipping planes refuse hits
/// (camera rays), otherwise every hit counts.
struct SceneClosest<'a, K, const CAMERA: bool> {
    accel: &'a SceneAccel,
    kernel: K,
    ray: &'a Ray,
    lim: f32,
    best: Option<SceneHit>,
    /// Shadow rays: instances that cast no shadow are passed.
    shadow: bool,
}

impl<K: BoxKernel, const CAMERA: bool> SceneClosest<'_, K, CAMERA> {
    /// The nearest hit on `mesh` (instance `instance`, ray `o + t·d` in its object space) below the
    /// current limit that this visitor's rays see.
    #[inline(always)]
    fn mesh_hit(&self, instance: u32, mesh: usize, o: Vec3A, d: Vec3A) -> Option<(f32, u32, f32, f32)> {
        let ray = self.ray;
        let SceneMesh::Traced(bvh) = &self.accel.meshes[mesh] else {
            return None;
        };
        if !CAMERA {
            return bvh.closest(self.kernel, o, d, ray.t_min, self.lim);
        }
        if self
            .accel
            .camera
            .hidden
            .get(instance as usize)
            .copied()
            .unwrap_or(false)
        {
            return None;
        }
        let planes = &self.accel.camera.clip_planes;
        let sides = (self.accel.camera.sides.get(instance as usize))
            .copied()
            .unwrap_or_default();
        if sides == Sides::Both && planes.is_empty() {
            return bvh.closest(self.kernel, o, d, ray.t_min, self.lim);
        }
        // `t` is the same along the object-space and the world-space ray.
        let visible = |t: f32, det: f32| {
            let facing = match sides {
                Sides::Both => true,
                Sides::Front => det > 0.0,
                Sides::Back => det < 0.0,
            };
            facing && self.accel.camera.unclipped(ray.at(t))
        };
        bvh.closest_accepted(self.kernel, o, d, ray.t_min, self.lim, visible)
    }
}

impl<K: BoxKernel, const CAMERA: bool> LeafVisitor for SceneClosest<'_, K, CAMERA> {
    #[inline(always)]
    fn visit(&mut self, first: usize, count: usize, t_far: &mut f32) -> bool {
        let ray = self.ray;
        for &instance in &self.accel.top_ids[first..first + count] {
            if self.shadow && self.accel.shadow.skips(instance) {
                continue;
            }
            let Some((mesh, o, d)) = self.accel.object_ray(instance, ray) else {
                continue;
            };
            if let Some((t, primitive, u, v)) = self.mesh_hit(instance, mesh, o, d)
                && self.best.is_none_or(|b| t < b.t || instance < b.instance)
            {
                self.best = Some(SceneHit {
                    t,
                    instance,
                    mesh,
                    primitive,
                    u,
                    v,
                });
                self.lim = t.next_up();
                *t_far = t;
            }
        }
        false
    }
}

struct SceneAny<'a, K> {
    accel: &'a SceneAccel,
    kernel: K,
    ray: &'a Ray,
    found: bool,
}

impl<K: BoxKernel> LeafVisitor for SceneAny<'_, K> {
    #[inline(always)]
    fn visit(&mut self, first: usize, count: usize, _: &mut f32) -> bool {
        let ray = self.ray;
        for &instance in &self.accel.top_ids[first..first + count] {
            if self.accel.shadow.skips(instance) {
                continue;
            }
            let Some((mesh, o, d)) = self.accel.object_ray(instance, ray) else {
                continue;
            };
            if let SceneMesh::Traced(bvh) = &self.accel.meshes[mesh]
                && bvh.any(self.kernel, o, d, ray.t_min, ray.t_max)
            {
                self.found = true;
                return true;
            }
        }
        false
    }
}

impl Tracer for SceneAccel {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.closest_dispatch(ray, false).map(|h| self.make_hit(ray, h))
    }

    fn intersect_camera(&self, ray: &Ray) -> Option<Hit> {
        self.closest_camera_dispatch(ray, false)
            .map(|h| self.make_hit(ray, h))
    }

    fn intersect_shadow(&self, ray: &Ray) -> Option<Hit> {
        self.closest_shadow_dispatch(ray, false)
            .map(|h| self.make_hit(ray, h))
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.any_dispatch(ray, false)
    }
}

impl fmt::Debug for SceneAccel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SceneAccel")
            .field("meshes", &self.meshes.len())
            .field("instances", &self.placements.len())
            .field("layout", &self.layout)
            .field("flattened", &self.instance_counts().0)
            .field("triangles", &self.triangle_count)
            .field("bounds", &self.bounds())
            .finish()
    }
}

/// The world-space triangles of the flattened placements, in placement order (each mesh's triangles
/// in its order), and the `(instance, triangle)` each came from. A vertex index out of its mesh's
/// range stays out of range (the triangle is skipped, as it is in the mesh's own hierarchy).
fn flatten(meshes: &[SceneMesh], placements: &[Placement]) -> (TriangleMesh, Vec<(u32, u32)>) {
    let mut world = TriangleMesh::default();
    let mut source = Vec::new();
    for (i, p) in placements.iter().enumerate() {
        let (true, Some(m), Motion::Static { to_world, .. }) = (p.flat, p.mesh, &p.motion) else {
            continue;
        };
        let mesh = meshes[m].mesh();
        let base = world.positions.len() as u32;
        let len = mesh.positions.len() as u32;
        world
            .positions
            .extend(mesh.positions.iter().map(|&x| to_world.transform_point3a(x)));
        world
            .triangles
            .extend((mesh.triangles.iter()).map(|t| t.map(|v| if v < len { base + v } else { u32::MAX })));
        source.extend((0..mesh.triangles.len() as u32).map(|k| (i as u32, k)));
    }
    (world, source)
}

/// A world box containing the object box `b` at every time under `motion` (see the module docs).
fn world_bounds(motion: &Motion, b: &Aabb) -> Aabb {
    let corners = b.corners();
    let mut out = Aabb::EMPTY;
    match motion {
        Motion::Static { to_world, .. } => {
            for c in corners {
                out.grow_point(to_world.transform_point3a(c));
            }
        }
        Motion::Moving { keys } => {
            let reach = b.lo.abs().max(b.hi.abs());
            for seg in keys.windows(2) {
                let (k0, k1) = (&seg[0], &seg[1]);
                let mut seg_box = Aabb::EMPTY;
                for step in 0..=MOTION_STEPS {
                    let m = interpolate(k0, k1, step as f32 / MOTION_STEPS as f32);
                    for c in corners {
                        seg_box.grow_point(m.transform_point3a(c));
                    }
                }
                let theta = 2.0 * k0.rotation.dot(k1.rotation).abs().min(1.0).acos();
                let s_max = k0.scale.abs().max(k1.scale.abs());
                let bend = theta * theta * (s_max * reach).length()
                    + 2.0 * theta * ((k1.scale - k0.scale) * reach).length();
                let steps = MOTION_STEPS as f32;
                out.grow(&seg_box.padded(bend / (8.0 * steps * steps)));
            }
        }
    }
    let magnitude = out.lo.abs().max(out.hi.abs()).max_element();
    out.padded(BOUNDS_REL_PAD * magnitude)
}
