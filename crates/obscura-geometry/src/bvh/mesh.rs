//! [`MeshBvh`]: one mesh's hierarchy in object space, with the nearest-hit and any-hit queries
//! that the scene accelerator runs per instance.

use core::fmt;

use glam::Vec3A;
use rayon::prelude::*;

#[cfg(target_arch = "x86_64")]
use super::avx2;
use super::build::{PARALLEL_BUILD_MIN, build_tree};
use super::traverse::{BoxKernel, LeafVisitor, ScalarKernel, traverse};
use super::tree::{Aabb, Tree};
use super::triangle::{TriRay, triangle_vertices};
use super::wide;
use super::wide::{Tri4, WideKernel, WideTree, collapse};
use crate::ray::{Ray, TriangleMesh};

/// Most triangles in a mesh leaf.
const MESH_LEAF_SIZE: usize = 4;

/// How a [`MeshBvh`] stores its hierarchy. Both give the same hits, bit for bit (see the
/// [module docs](super)); they differ in speed and memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BvhLayout {
    /// Eight children per node (four triangles per leaf), their boxes tested together (the default: the faster one).
    #[default]
    Wide,
    /// The binary tree the builder makes, two children per cache line. Kept as the reference the
    /// benchmarks and tests compare the wide layout against.
    Binary,
}

impl BvhLayout {
    /// [`BvhLayout::Binary`] when the environment variable `OBSCURA_BVH_LAYOUT` is `binary`, else the
    /// default.
    #[must_use]
    pub fn from_env() -> Self {
        match std::env::var("OBSCURA_BVH_LAYOUT") {
            Ok(v) if v.eq_ignore_ascii_case("binary") => Self::Binary,
            _ => Self::default(),
        }
    }
}

/// A binned-SAH BVH over one mesh's triangles, in object space.
///
/// Leaves hold at most four triangles. Skipped triangles (bad indices, non-finite or zero-area
/// vertices) are left out and never hit.
pub struct MeshBvh {
    mesh: TriangleMesh,
    layout: BvhLayout,
    bounds: Aabb,
    /// The binary tree; only its root is kept in the [`BvhLayout::Wide`] layout.
    pub(super) tree: Tree,
    /// The wide tree; empty in the [`BvhLayout::Binary`] layout.
    pub(super) wide: WideTree,
    /// Triangle vertices in leaf order (binary layout only).
    pub(super) tris: Vec<[Vec3A; 3]>,
    /// Mesh triangle index of each entry of `tris`.
    tri_ids: Vec<u32>,
}

impl MeshBvh {
    /// Builds the hierarchy: binned SAH (16 bins per axis) down to 16 triangles, an exact sorted
    /// sweep below that, leaves of at most 4. Meshes of 16k triangles or more build their subtrees on
    /// rayon's thread pool; the tree does not depend on the number of threads.
    #[must_use]
    ///
    /// The layout is [`BvhLayout::Wide`] unless the environment variable `OBSCURA_BVH_LAYOUT` is
    /// `binary` (a switch for measuring a whole render with the former layout; the hits are the
    /// same).
    pub fn build(mesh: TriangleMesh) -> Self {
        Self::build_with_layout(mesh, BvhLayout::from_env())
    }

    /// [`MeshBvh::build`] with the hierarchy stored in `layout`.
    #[must_use]
    pub fn build_with_layout(mesh: TriangleMesh, layout: BvhLayout) -> Self {
        let n = mesh.triangles.len().min(u32::MAX as usize);
        let bound = |i: usize| match triangle_vertices(&mesh, mesh.triangles[i]) {
            Some([a, b, c]) => Aabb {
                lo: a.min(b).min(c),
                hi: a.max(b).max(c),
            },
            None => Aabb::EMPTY,
        };
        let boxes: Vec<Aabb> = if n >= PARALLEL_BUILD_MIN {
            (0..n).into_par_iter().map(bound).collect()
        } else {
            (0..n).map(bound).collect()
        };
        // Skipped triangles have empty boxes; everything else has a finite one.
        let mut refs: Vec<u32> = (0..n as u32)
            .filter(|&i| boxes[i as usize].lo.x <= boxes[i as usize].hi.x)
            .collect();
        let mut tree = build_tree(&boxes, &mut refs, MESH_LEAF_SIZE);
        let bounds = tree.root_bounds();
        let wide = match layout {
            BvhLayout::Wide => {
                let tris: Vec<[Vec3A; 3]> = refs
                    .iter()
                    .filter_map(|&i| triangle_vertices(&mesh, mesh.triangles[i as usize]))
                    .collect();
                let wide = collapse(&tree, &tris, &refs);
                tree.pairs = Vec::new();
                wide
            }
            BvhLayout::Binary => WideTree::default(),
        };
        // Every ref passed this same check, so none is dropped and `tris` stays aligned with `tri_ids`.
        // The wide layout keeps its triangles in its leaf blocks instead.
        let tris = match layout {
            BvhLayout::Binary => refs
                .iter()
                .filter_map(|&i| triangle_vertices(&mesh, mesh.triangles[i as usize]))
                .collect(),
            BvhLayout::Wide => Vec::new(),
        };
        Self {
            mesh,
            layout,
            bounds,
            tree,
            wide,
            tris,
            tri_ids: refs,
        }
    }

    /// The layout the hierarchy is stored in.
    #[must_use]
    pub fn layout(&self) -> BvhLayout {
        self.layout
    }

    /// Bytes the hierarchy takes beyond the mesh itself: nodes, triangles copied into leaf order
    /// and their indices.
    #[must_use]
    pub fn memory_bytes(&self) -> usize {
        size_of::<Tree>()
            + self.tree.pairs.len() * size_of::<super::tree::NodePair>()
            + self.wide.node_bytes()
            + self.tris.len() * size_of::<[Vec3A; 3]>()
            + self.tri_ids.len() * size_of::<u32>()
    }

    /// The object-space box of the hittable triangles (empty for none).
    pub(super) fn root_bounds(&self) -> Aabb {
        self.bounds
    }

    /// The object-space bounding box `(min, max)` of the triangles that can be hit. An empty mesh
    /// gives an empty box: `min = +∞`, `max = −∞`.
    #[must_use]
    pub fn bounds(&self) -> (Vec3A, Vec3A) {
        (self.bounds.lo, self.bounds.hi)
    }

    /// The number of triangles that can be hit (skipped triangles are not counted).
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.tri_ids.len()
    }

    /// The mesh the hierarchy was built over, unchanged.
    #[must_use]
    pub fn mesh(&self) -> &TriangleMesh {
        &self.mesh
    }

    /// The nearest hit in object space as `(t, triangle index, u, v)`, with `ray.t_min < t <
    /// ray.t_max`; `ray.time` is ignored. Barycentrics follow [`Hit::uv`](crate::ray::Hit::uv): the point is
    /// `(1 - u - v)·v0 + u·v1 + v·v2`. Equal `t` goes to the lower triangle index.
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, u32, f32, f32)> {
        self.intersect_with(ray, false)
    }

    /// True when any triangle is hit with `ray.t_min < t < ray.t_max`; stops at the first one found.
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, false)
    }

    /// [`MeshBvh::intersect`], with the AVX2 kernel unless `scalar_only` (the tests run both).
    pub(super) fn intersect_with(&self, ray: &Ray, scalar_only: bool) -> Option<(f32, u32, f32, f32)> {
        #[cfg(target_arch = "x86_64")]
        if !scalar_only && let Some(k) = avx2::Avx2Kernel::detect() {
            // SAFETY: the token from `detect` proves the CPU supports AVX2 and FMA.
            return unsafe { self.closest_avx2(k, ray.origin, ray.direction, ray.t_min, ray.t_max) };
        }
        let _ = scalar_only;
        self.closest(ScalarKernel, ray.origin, ray.direction, ray.t_min, ray.t_max)
    }

    /// [`MeshBvh::occluded`], with the AVX2 kernel unless `scalar_only`.
    pub(super) fn occluded_with(&self, ray: &Ray, scalar_only: bool) -> bool {
        #[cfg(target_arch = "x86_64")]
        if !scalar_only && let Some(k) = avx2::Avx2Kernel::detect() {
            // SAFETY: the token from `detect` proves the CPU supports AVX2 and FMA.
            return unsafe { self.any_avx2(k, ray.origin, ray.direction, ray.t_min, ray.t_max) };
        }
        let _ = scalar_only;
        self.any(ScalarKernel, ray.origin, ray.direction, ray.t_min, ray.t_max)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn closest_avx2(
        &self,
        k: avx2::Avx2Kernel,
        origin: Vec3A,
        direction: Vec3A,
        t_min: f32,
        t_lim: f32,
    ) -> Option<(f32, u32, f32, f32)> {
        self.closest(k, origin, direction, t_min, t_lim)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn any_avx2(&self, k: avx2::Avx2Kernel, origin: Vec3A, direction: Vec3A, t_min: f32, t_max: f32) -> bool {
        self.any(k, origin, direction, t_min, t_max)
    }

    /// Nearest hit with `t_min < t < t_lim`; on equal `t` the lowest triangle index wins.
    #[inline(always)]
    pub(super) fn closest<K: BoxKernel>(
        &self,
        kernel: K,
        origin: Vec3A,
        direction: Vec3A,
        t_min: f32,
        t_lim: f32,
    ) -> Option<(f32, u32, f32, f32)> {
        self.closest_accepted(kernel, origin, direction, t_min, t_lim, |_, _| true)
    }

    /// [`MeshBvh::closest`] among the hits `accept(t, det)` takes (`det` of
    /// [`TriRay::intersect_det`]: positive on the triangle's front); a refused hit is passed and the
    /// traversal goes on to the next. With an `accept` that is always true this is `closest` itself.
    #[inline(always)]
    pub(super) fn closest_accepted<K: BoxKernel, F: Fn(f32, f32) -> bool>(
        &self,
        kernel: K,
        origin: Vec3A,
        direction: Vec3A,
        t_min: f32,
        t_lim: f32,
        accept: F,
    ) -> Option<(f32, u32, f32, f32)> {
        let ray = TriRay::new(origin, direction);
        match self.layout {
            BvhLayout::Wide => {
                let k = kernel.wide();
                let mut visitor = WideClosest {
                    blocks: &self.wide.leaves,
                    kernel: k,
                    ray: k.prepare_leaf(ray),
                    t_min,
                    lim: t_lim,
                    best: None,
                    accept,
                };
                wide::traverse(
                    &self.wide,
                    k,
                    &k.prepare(origin, direction, t_min),
                    t_lim,
                    &mut visitor,
                );
                visitor.best
            }
            BvhLayout::Binary => {
                let mut visitor = MeshClosest {
                    bvh: self,
                    ray,
                    t_min,
                    lim: t_lim,
                    best: None,
                    accept,
                };
                let box_ray = kernel.prepare(origin, direction, t_min);
                traverse(&self.tree, kernel, &box_ray, t_lim, &mut visitor);
                visitor.best
            }
        }
    }

    /// True when a triangle is hit with `t_min < t < t_max`.
    #[inline(always)]
    pub(super) fn any<K: BoxKernel>(
        &self,
        kernel: K,
        origin: Vec3A,
        direction: Vec3A,
        t_min: f32,
        t_max: f32,
    ) -> bool {
        let ray = TriRay::new(origin, direction);
        match self.layout {
            BvhLayout::Wide => {
                let k = kernel.wide();
                let mut visitor = WideAny {
                    blocks: &self.wide.leaves,
                    kernel: k,
                    ray: k.prepare_leaf(ray),
                    t_min,
                    t_max,
                    found: false,
                };
                wide::traverse(
                    &self.wide,
                    k,
                    &k.prepare(origin, direction, t_min),
                    t_max,
                    &mut visitor,
                );
                visitor.found
            }
            BvhLayout::Binary => {
                let mut visitor = MeshAny {
                    bvh: self,
                    ray,
                    t_min,
                    t_max,
                    found: false,
                };
                let box_ray = kernel.prepare(origin, direction, t_min);
                traverse(&self.tree, kernel, &box_ray, t_max, &mut visitor);
                visitor.found
            }
        }
    }
}

struct MeshClosest<'a, F> {
    bvh: &'a MeshBvh,
    ray: TriRay,
    t_min: f32,
    /// Exclusive upper limit: the ray's `t_max`, then just above the best `t` (so ties still count).
    lim: f32,
    best: Option<(f32, u32, f32, f32)>,
    /// Which hits count (`(t, det)`).
    accept: F,
}

impl<F: Fn(f32, f32) -> bool> LeafVisitor for MeshClosest<'_, F> {
    #[inline(always)]
    fn visit(&mut self, first: usize, count: usize, t_far: &mut f32) -> bool {
        let range = first..first + count;
        for (tri, &id) in self.bvh.tris[range.clone()].iter().zip(&self.bvh.tri_ids[range]) {
            if let Some((t, u, v, det)) = self.ray.intersect_det(tri, self.t_min, self.lim) {
                // `t < lim` already means `t <= best t`.
                if self.best.is_none_or(|b| t < b.0 || id < b.1) && (self.accept)(t, det) {
                    self.best = Some((t, id, u, v));
                    self.lim = t.next_up();
                    *t_far = t;
                }
            }
        }
        false
    }
}

struct MeshAny<'a> {
    bvh: &'a MeshBvh,
    ray: TriRay,
    t_min: f32,
    t_max: f32,
    found: bool,
}

impl LeafVisitor for MeshAny<'_> {
    #[inline(always)]
    fn visit(&mut self, first: usize, count: usize, _: &mut f32) -> bool {
        for tri in &self.bvh.tris[first..first + count] {
            if self.ray.intersect(tri, self.t_min, self.t_max).is_some() {
                self.found = true;
                return true;
            }
        }
        false
    }
}

/// [`MeshClosest`] for the wide layout: a leaf is one [`Tri4`] block, tested four lanes at once.
struct WideClosest<'a, K: WideKernel, F> {
    blocks: &'a [Tri4],
    kernel: K,
    ray: K::LeafRay,
    t_min: f32,
    lim: f32,
    best: Option<(f32, u32, f32, f32)>,
    accept: F,
}

impl<K: WideKernel, F: Fn(f32, f32) -> bool> LeafVisitor for WideClosest<'_, K, F> {
    #[inline(always)]
    fn visit(&mut self, first: usize, count: usize, t_far: &mut f32) -> bool {
        let block = &self.blocks[first];
        let (mut mask, hits) = self.kernel.leaf(&self.ray, block, count, self.t_min, self.lim);
        // Lanes in triangle order, each against the limit as it is then: the scalar loop's rule.
        while mask != 0 {
            let k = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let (t, u, v, det, id) = (hits[0][k], hits[1][k], hits[2][k], hits[3][k], block.id[k]);
            if t < self.lim && self.best.is_none_or(|b| t < b.0 || id < b.1) && (self.accept)(t, det) {
                self.best = Some((t, id, u, v));
                self.lim = t.next_up();
                *t_far = t;
            }
        }
        false
    }

    #[inline(always)]
    fn prefetch(&self, first: usize) {
        wide::prefetch(&self.blocks[first]);
    }
}

/// [`MeshAny`] for the wide layout.
struct WideAny<'a, K: WideKernel> {
    blocks: &'a [Tri4],
    kernel: K,
    ray: K::LeafRay,
    t_min: f32,
    t_max: f32,
    found: bool,
}

impl<K: WideKernel> LeafVisitor for WideAny<'_, K> {
    const ANY_HIT: bool = true;

    #[inline(always)]
    fn visit(&mut self, first: usize, count: usize, _: &mut f32) -> bool {
        let (mask, _) = self
            .kernel
            .leaf(&self.ray, &self.blocks[first], count, self.t_min, self.t_max);
        self.found = mask != 0;
        self.found
    }

    #[inline(always)]
    fn prefetch(&self, first: usize) {
        wide::prefetch(&self.blocks[first]);
    }
}

impl fmt::Debug for MeshBvh {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MeshBvh")
            .field("triangles", &self.tri_ids.len())
            .field("layout", &self.layout)
            .field(
                "nodes",
                &match self.layout {
                    BvhLayout::Wide => self.wide.nodes.len(),
                    BvhLayout::Binary => self.tree.node_count(),
                },
            )
            .field("bounds", &self.bounds())
            .finish()
    }
}
