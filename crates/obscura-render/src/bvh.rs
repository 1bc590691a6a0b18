//! Binned-SAH bounding volume hierarchies: one per mesh ([`MeshBvh`]) and a two-level, motion-blurred
//! scene accelerator over placements of those meshes ([`SceneAccel`]).
//!
//! # Guarantees
//!
//! - **Same answers as a brute-force loop.** Triangles are tested with the watertight ray/triangle
//!   test of Woop, Benthin and Wald (JCGT 2013), two-sided, with `t_min < t < t_max` strictly. Box
//!   tests are conservative (the far distance is padded, after Ize, "Robust BVH Ray Traversal", 2013),
//!   so the hierarchy never culls a triangle the test would have hit. Ties in `t` go to the lowest
//!   triangle index (and, between instances, the lowest instance index), so the answer does not depend
//!   on traversal order.
//! - **Skipped triangles.** A triangle whose vertex indices are out of range, whose vertices are not
//!   finite, or whose edge cross product is exactly zero in `f32` (zero area) is left out: it is never
//!   hit. Such triangles are not counted by `triangle_count`.
//! - **No panics on odd rays.** NaN or zero directions, NaN or inverted `t` ranges simply miss.
//!
//! # Layout (why it is fast)
//!
//! Nodes are 32 bytes (`min`, child-or-first, `max`, count). The two children of a node sit side by
//! side in one 64-byte-aligned pair, so one cache line is fetched per traversal step and both
//! children are slab-tested at once: with AVX2 (detected at run time) one `vpermps` per child selects
//! the near and far planes by the ray's direction signs, and the two boxes go through the slab test in
//! one 8-lane register. Without AVX2 the same test runs in scalar code. Leaf triangles are copied into
//! leaf order (48 bytes each) so a leaf is one contiguous read.
//!
//! # Motion
//!
//! An [`Instance`] carries object-to-world samples at shutter times in `[0, 1]`. Between two samples
//! the transform is decomposed into scale, rotation and translation; scale and translation are
//! interpolated linearly and rotation by shortest-path slerp. Outside the sampled range the nearest
//! sample holds. World rays are moved into object space with the inverse transform *without*
//! renormalising the direction, so `t` means the same thing in both spaces.
//!
//! The top-level box of a moving instance is conservative for that interpolation. The transformed
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

use glam::{Affine3A, Mat3A, Quat, Vec3A};
use rayon::prelude::*;

use crate::ray::{Hit, Ray, Tracer, TriangleMesh};

/// Bins per axis of the binned SAH.
const BINS: usize = 16;
/// Most triangles in a mesh leaf.
const MESH_LEAF_SIZE: usize = 4;
/// Most instances in a top-level leaf: an instance visit costs a whole mesh traversal, so split fully.
const INSTANCE_LEAF_SIZE: usize = 1;
/// Cost of one traversal step relative to one primitive test, for the SAH.
const TRAVERSAL_COST: f32 = 1.0;
/// Below this depth the SAH chooses splits; from it on, median splits bound the depth (see
/// [`STACK_SIZE`]).
const SAH_DEPTH_LIMIT: u32 = 40;
/// Traversal stack entries. A node at depth `d` has at most `d` pending siblings on the stack; median
/// splits from [`SAH_DEPTH_LIMIT`] on halve the primitive count (at most `u32::MAX`) per level, so no
/// leaf is deeper than `SAH_DEPTH_LIMIT + 33 = 73`.
const STACK_SIZE: usize = 80;
/// Meshes with at least this many triangles build their lower subtrees on rayon's pool.
const PARALLEL_BUILD_MIN: usize = 16_384;
/// Relative padding of a box's far distance; it covers the rounding of the slab test and of the
/// triangle test's `t` (Ize 2013 uses `2γ₃ ≈ 3.6e-7`).
const FAR_PAD: f32 = 1e-6;
/// Samples per motion segment for the conservative instance bounds.
const MOTION_STEPS: usize = 16;
/// Padding of instance boxes for the rounding of transforms, relative to their largest coordinate.
const BOUNDS_REL_PAD: f32 = 4e-6;

// ---------------------------------------------------------------------------------------------------
// Boxes and nodes

#[derive(Debug, Clone, Copy, PartialEq)]
struct Aabb {
    lo: Vec3A,
    hi: Vec3A,
}

impl Aabb {
    const EMPTY: Self = Self {
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
    };

    #[inline]
    fn grow(&mut self, other: &Self) {
        self.lo = self.lo.min(other.lo);
        self.hi = self.hi.max(other.hi);
    }

    #[inline]
    fn grow_point(&mut self, p: Vec3A) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }

    /// Half the surface area; zero for an empty box.
    #[inline]
    fn half_area(&self) -> f32 {
        let e = (self.hi - self.lo).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    fn is_finite(&self) -> bool {
        self.lo.is_finite() && self.hi.is_finite()
    }

    fn padded(&self, pad: f32) -> Self {
        Self {
            lo: self.lo - Vec3A::splat(pad),
            hi: self.hi + Vec3A::splat(pad),
        }
    }

    fn corners(&self) -> [Vec3A; 8] {
        let (l, h) = (self.lo, self.hi);
        [
            Vec3A::new(l.x, l.y, l.z),
            Vec3A::new(h.x, l.y, l.z),
            Vec3A::new(l.x, h.y, l.z),
            Vec3A::new(h.x, h.y, l.z),
            Vec3A::new(l.x, l.y, h.z),
            Vec3A::new(h.x, l.y, h.z),
            Vec3A::new(l.x, h.y, h.z),
            Vec3A::new(h.x, h.y, h.z),
        ]
    }
}

/// One BVH node: 32 bytes. An interior node has `count == 0` and `first` = index of its children's
/// [`NodePair`]; a leaf has `count > 0` primitives starting at `first` in leaf order.
#[repr(C, align(32))]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Node {
    lo: [f32; 3],
    first: u32,
    hi: [f32; 3],
    count: u32,
}

impl Node {
    fn new(b: &Aabb, first: u32, count: u32) -> Self {
        Self {
            lo: b.lo.to_array(),
            first,
            hi: b.hi.to_array(),
            count,
        }
    }
}

/// The two children of an interior node, on one cache line.
#[repr(C, align(64))]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct NodePair([Node; 2]);

// The AVX2 kernel loads a pair as two 8-lane vectors: no padding, exact sizes.
const _: () = assert!(size_of::<Node>() == 32 && size_of::<NodePair>() == 64 && align_of::<NodePair>() == 64);

/// A built hierarchy: the root, then child pairs.
#[derive(Debug, Clone, Default)]
struct Tree {
    root: Node,
    pairs: Vec<NodePair>,
}

impl Tree {
    fn node_count(&self) -> usize {
        1 + 2 * self.pairs.len()
    }

    fn root_bounds(&self) -> Aabb {
        if self.root.count == 0 && self.pairs.is_empty() {
            return Aabb::EMPTY;
        }
        Aabb {
            lo: Vec3A::from_array(self.root.lo),
            hi: Vec3A::from_array(self.root.hi),
        }
    }

    /// Depth of the deepest leaf (the root is depth 0).
    #[cfg(test)]
    fn depth(&self) -> usize {
        let mut deepest = 0;
        let mut todo = vec![(self.root, 0usize)];
        while let Some((node, d)) = todo.pop() {
            deepest = deepest.max(d);
            if node.count == 0 && !self.pairs.is_empty() {
                let pair = &self.pairs[node.first as usize];
                todo.push((pair.0[0], d + 1));
                todo.push((pair.0[1], d + 1));
            }
        }
        deepest
    }
}

// ---------------------------------------------------------------------------------------------------
// Binned SAH builder

#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    count: u32,
}

impl Bin {
    const EMPTY: Self = Self {
        bounds: Aabb::EMPTY,
        count: 0,
    };
}

#[inline]
fn bin_index(x: f32) -> usize {
    // `as` saturates and maps NaN to 0, so any input gives a valid bin.
    (x as usize).min(BINS - 1)
}

/// Nodes with at most this many primitives get an exact SAH (sort and sweep each axis) instead of
/// binning: cheaper than filling 48 bins, and better splits.
const SWEEP_MAX: usize = 16;

/// What the builder knows about a node's primitives.
#[derive(Clone, Copy)]
struct Span {
    /// Union of the primitive boxes.
    bounds: Aabb,
    /// Bounds of the primitive centroids.
    centroids: Aabb,
    depth: u32,
}

/// A subtree left for the parallel phase.
struct Task {
    slot: usize,
    offset: usize,
    len: usize,
    span: Span,
}

/// Builds over primitive boxes; nodes live in a flat vector (root at 0, children allocated in pairs,
/// so every left child has an odd index) until [`Builder::finish`] packs them into [`NodePair`]s.
struct Builder<'a> {
    boxes: &'a [Aabb],
    centroids: &'a [Vec3A],
    max_leaf: usize,
}

impl Builder<'_> {
    fn span(&self, refs: &[u32], depth: u32) -> Span {
        let (mut bounds, mut centroids) = (Aabb::EMPTY, Aabb::EMPTY);
        for &r in refs {
            bounds.grow(&self.boxes[r as usize]);
            centroids.grow_point(self.centroids[r as usize]);
        }
        Span {
            bounds,
            centroids,
            depth,
        }
    }

    /// Partitions `refs` for a split and returns the split point and both children, or `None` to make
    /// a leaf.
    fn split(&self, refs: &mut [u32], span: &Span) -> Option<(usize, Span, Span)> {
        let n = refs.len();
        if n <= 1 {
            return None;
        }
        let extent = span.centroids.hi - span.centroids.lo;
        if span.depth >= SAH_DEPTH_LIMIT || extent.max_element() <= 0.0 {
            return (n > self.max_leaf).then(|| self.median_split(refs, span));
        }
        let (cost, split) = if n <= SWEEP_MAX {
            self.sweep(refs)
        } else {
            self.binned(refs, span)
        }?;
        let parent_area = span.bounds.half_area();
        let split_cost = TRAVERSAL_COST
            + if parent_area > 0.0 {
                cost / parent_area
            } else {
                n as f32
            };
        if n <= self.max_leaf && n as f32 <= split_cost {
            return None;
        }
        let mid = match split {
            Split::Sorted { axis, at } => {
                self.sort(refs, axis);
                at
            }
            Split::Bin { axis, bin, lo, scale } => {
                let goes_left = |r: u32| bin_index((self.centroids[r as usize][axis] - lo) * scale) < bin;
                let (mut i, mut j) = (0, n);
                while i < j {
                    if goes_left(refs[i]) {
                        i += 1;
                    } else {
                        j -= 1;
                        refs.swap(i, j);
                    }
                }
                i
            }
        };
        if mid == 0 || mid == n {
            // Cannot happen (the partition repeats the binning), but stay total.
            return Some(self.median_split(refs, span));
        }
        let depth = span.depth + 1;
        Some((
            mid,
            self.span(&refs[..mid], depth),
            self.span(&refs[mid..], depth),
        ))
    }

    /// Sorts by centroid along `axis`, ties by index, so the order is deterministic.
    fn sort(&self, refs: &mut [u32], axis: usize) {
        refs.sort_unstable_by(|&a, &b| {
            self.centroids[a as usize][axis]
                .total_cmp(&self.centroids[b as usize][axis])
                .then(a.cmp(&b))
        });
    }

    /// Exact SAH over the sorted centroids of a small node: `(cost, split)`.
    fn sweep(&self, refs: &[u32]) -> Option<(f32, Split)> {
        let n = refs.len();
        let mut keyed = [(0.0f32, 0u32); SWEEP_MAX];
        let keyed = &mut keyed[..n];
        let mut best: Option<(f32, Split)> = None;
        for axis in 0..3 {
            for (k, &r) in keyed.iter_mut().zip(refs) {
                *k = (self.centroids[r as usize][axis], r);
            }
            // The same order as `sort`: by centroid, ties by index.
            keyed.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let mut right = [0.0f32; SWEEP_MAX];
            let mut acc = Aabb::EMPTY;
            for i in (1..n).rev() {
                acc.grow(&self.boxes[keyed[i].1 as usize]);
                right[i] = acc.half_area() * (n - i) as f32;
            }
            let mut acc = Aabb::EMPTY;
            for i in 1..n {
                acc.grow(&self.boxes[keyed[i - 1].1 as usize]);
                let cost = acc.half_area() * i as f32 + right[i];
                if best.as_ref().is_none_or(|b| cost < b.0) {
                    best = Some((cost, Split::Sorted { axis, at: i }));
                }
            }
        }
        best
    }

    /// Binned SAH (16 bins per axis over the centroid bounds): `(cost, split)`.
    fn binned(&self, refs: &[u32], span: &Span) -> Option<(f32, Split)> {
        let cb = &span.centroids;
        // Axes with zero extent get an infinite scale; 0·∞ = NaN lands in bin 0, so they offer no split.
        let scale = Vec3A::splat(BINS as f32) / (cb.hi - cb.lo);
        let mut bins = [[Bin::EMPTY; BINS]; 3];
        for &r in refs {
            let b = (self.centroids[r as usize] - cb.lo) * scale;
            let bx = &self.boxes[r as usize];
            for (axis_bins, coord) in bins.iter_mut().zip([b.x, b.y, b.z]) {
                let bin = &mut axis_bins[bin_index(coord)];
                bin.bounds.grow(bx);
                bin.count += 1;
            }
        }
        let mut best: Option<(f32, Split)> = None;
        for (axis, axis_bins) in bins.iter().enumerate() {
            let mut right = [0.0f32; BINS];
            let mut right_count = [0u32; BINS];
            let (mut acc, mut count) = (Aabb::EMPTY, 0u32);
            for i in (1..BINS).rev() {
                acc.grow(&axis_bins[i].bounds);
                count += axis_bins[i].count;
                right[i] = acc.half_area() * count as f32;
                right_count[i] = count;
            }
            let (mut acc, mut count) = (Aabb::EMPTY, 0u32);
            for i in 1..BINS {
                acc.grow(&axis_bins[i - 1].bounds);
                count += axis_bins[i - 1].count;
                if count == 0 || right_count[i] == 0 {
                    continue;
                }
                let cost = acc.half_area() * count as f32 + right[i];
                if best.as_ref().is_none_or(|b| cost < b.0) {
                    best = Some((
                        cost,
                        Split::Bin {
                            axis,
                            bin: i,
                            lo: cb.lo[axis],
                            scale: scale[axis],
                        },
                    ));
                }
            }
        }
        best
    }

    /// Splits at the median centroid along the widest axis (or by order when all centroids coincide).
    fn median_split(&self, refs: &mut [u32], span: &Span) -> (usize, Span, Span) {
        let mid = refs.len() / 2;
        let e = span.centroids.hi - span.centroids.lo;
        if e.max_element() > 0.0 {
            let axis = if e.x >= e.y && e.x >= e.z {
                0
            } else if e.y >= e.z {
                1
            } else {
                2
            };
            refs.select_nth_unstable_by(mid, |&a, &b| {
                self.centroids[a as usize][axis].total_cmp(&self.centroids[b as usize][axis])
            });
        }
        let depth = span.depth + 1;
        (
            mid,
            self.span(&refs[..mid], depth),
            self.span(&refs[mid..], depth),
        )
    }

    fn build_seq(&self, refs: &mut [u32], offset: usize, slot: usize, span: Span, nodes: &mut Vec<Node>) {
        match self.split(refs, &span) {
            None => nodes[slot] = Node::new(&span.bounds, offset as u32, refs.len() as u32),
            Some((mid, left, right)) => {
                let l = nodes.len();
                nodes.extend([Node::default(); 2]);
                nodes[slot] = Node::new(&span.bounds, l as u32, 0);
                let (a, b) = refs.split_at_mut(mid);
                self.build_seq(a, offset, l, left, nodes);
                self.build_seq(b, offset + mid, l + 1, right, nodes);
            }
        }
    }

    /// Like [`Builder::build_seq`], but subtrees of at most `grain` primitives become [`Task`]s.
    #[allow(clippy::too_many_arguments)]
    fn build_top(
        &self,
        refs: &mut [u32],
        offset: usize,
        slot: usize,
        span: Span,
        nodes: &mut Vec<Node>,
        tasks: &mut Vec<Task>,
        grain: usize,
    ) {
        if refs.len() <= grain {
            tasks.push(Task {
                slot,
                offset,
                len: refs.len(),
                span,
            });
            return;
        }
        match self.split(refs, &span) {
            None => nodes[slot] = Node::new(&span.bounds, offset as u32, refs.len() as u32),
            Some((mid, left, right)) => {
                let l = nodes.len();
                nodes.extend([Node::default(); 2]);
                nodes[slot] = Node::new(&span.bounds, l as u32, 0);
                let (a, b) = refs.split_at_mut(mid);
                self.build_top(a, offset, l, left, nodes, tasks, grain);
                self.build_top(b, offset + mid, l + 1, right, nodes, tasks, grain);
            }
        }
    }

    /// Builds over `refs` (indices into `boxes`), reordering them into leaf order.
    fn build(&self, refs: &mut [u32]) -> Tree {
        if refs.is_empty() {
            return Tree::default();
        }
        let span = self.span(refs, 0);
        let mut nodes = vec![Node::default()];
        if refs.len() < PARALLEL_BUILD_MIN {
            self.build_seq(refs, 0, 0, span, &mut nodes);
            return Self::finish(&nodes);
        }

        let grain = (refs.len() / 16).max(4096);
        let mut tasks = Vec::new();
        self.build_top(refs, 0, 0, span, &mut nodes, &mut tasks, grain);
        // Tasks come out in depth-first order, so their ranges are increasing and disjoint.
        let mut jobs = Vec::with_capacity(tasks.len());
        let mut rest: &mut [u32] = refs;
        let mut pos = 0;
        for task in &tasks {
            let (_, tail) = core::mem::take(&mut rest).split_at_mut(task.offset - pos);
            let (chunk, tail) = tail.split_at_mut(task.len);
            jobs.push((task, chunk));
            rest = tail;
            pos = task.offset + task.len;
        }
        let subtrees: Vec<Vec<Node>> = jobs
            .into_par_iter()
            .map(|(task, chunk)| {
                let mut local = vec![Node::default()];
                self.build_seq(chunk, 0, 0, task.span, &mut local);
                local
            })
            .collect();
        for (task, local) in tasks.iter().zip(subtrees) {
            // Local index j >= 1 lands at base + j - 1; `base` is odd, so pairs stay aligned.
            let base = nodes.len();
            let fix = |mut n: Node| {
                if n.count == 0 {
                    n.first = (base + n.first as usize - 1) as u32;
                } else {
                    n.first += task.offset as u32;
                }
                n
            };
            nodes[task.slot] = fix(local[0]);
            nodes.extend(local[1..].iter().map(|&n| fix(n)));
        }
        Self::finish(&nodes)
    }

    /// Packs the flat node vector (root, then sibling pairs) into [`NodePair`]s.
    fn finish(nodes: &[Node]) -> Tree {
        let convert = |mut n: Node| {
            if n.count == 0 {
                n.first = (n.first - 1) / 2;
            }
            n
        };
        Tree {
            root: convert(nodes[0]),
            pairs: nodes[1..]
                .chunks_exact(2)
                .map(|c| NodePair([convert(c[0]), convert(c[1])]))
                .collect(),
        }
    }
}

/// A chosen split plane.
enum Split {
    /// Sort by centroid along `axis` and cut before position `at`.
    Sorted { axis: usize, at: usize },
    /// Centroids whose bin along `axis` is below `bin` go left.
    Bin {
        axis: usize,
        bin: usize,
        lo: f32,
        scale: f32,
    },
}

/// Builds a tree over the primitives listed in `refs` (reordered into leaf order on return).
fn build_tree(boxes: &[Aabb], refs: &mut [u32], max_leaf: usize) -> Tree {
    let centroids: Vec<Vec3A> = if boxes.len() >= PARALLEL_BUILD_MIN {
        boxes.par_iter().map(|b| (b.lo + b.hi) * 0.5).collect()
    } else {
        boxes.iter().map(|b| (b.lo + b.hi) * 0.5).collect()
    };
    Builder {
        boxes,
        centroids: &centroids,
        max_leaf,
    }
    .build(refs)
}

// ---------------------------------------------------------------------------------------------------
// Ray/box kernels and traversal

/// `x` grown by [`FAR_PAD`] of its magnitude (works for negative `x`; infinities stay put).
#[inline(always)]
fn pad_far(x: f32) -> f32 {
    x + x.abs() * FAR_PAD
}

/// A ray/box-pair test. Implementations are zero-sized tokens: holding one proves that the CPU can
/// run it.
trait BoxKernel: Copy {
    type Ray;
    fn prepare(self, origin: Vec3A, direction: Vec3A, t_min: f32) -> Self::Ray;
    /// Tests both boxes of `pair` against `[t_min, t_far]`. Returns a mask (bit 0: first child, bit 1:
    /// second) and the entry distances.
    fn test_pair(self, ray: &Self::Ray, pair: &NodePair, t_far: f32) -> (u32, f32, f32);
}

#[derive(Clone, Copy)]
struct ScalarKernel;

struct ScalarBoxRay {
    origin: [f32; 3],
    inv_dir: [f32; 3],
    negative: [bool; 3],
    t_min: f32,
}

impl ScalarKernel {
    /// Williams et al.'s slab test: the near and far planes are picked by the sign of the direction,
    /// `1/±0 = ±∞` handles axis-parallel rays, and the NaN from `0·∞` (origin exactly on a slab plane
    /// of a parallel axis) loses every comparison, so that axis does not constrain the interval.
    #[inline(always)]
    fn slab(ray: &ScalarBoxRay, node: &Node, t_far: f32) -> (bool, f32) {
        let mut t0 = ray.t_min;
        let mut t1 = t_far;
        for k in 0..3 {
            let (near, far) = if ray.negative[k] {
                (node.hi[k], node.lo[k])
            } else {
                (node.lo[k], node.hi[k])
            };
            let a = (near - ray.origin[k]) * ray.inv_dir[k];
            let b = (far - ray.origin[k]) * ray.inv_dir[k];
            t0 = if a > t0 { a } else { t0 };
            t1 = if b < t1 { b } else { t1 };
        }
        (t0 <= pad_far(t1), t0)
    }
}

impl BoxKernel for ScalarKernel {
    type Ray = ScalarBoxRay;

    #[inline(always)]
    fn prepare(self, origin: Vec3A, direction: Vec3A, t_min: f32) -> ScalarBoxRay {
        ScalarBoxRay {
            origin: origin.to_array(),
            inv_dir: (Vec3A::ONE / direction).to_array(),
            negative: [
                direction.x.is_sign_negative(),
                direction.y.is_sign_negative(),
                direction.z.is_sign_negative(),
            ],
            t_min,
        }
    }

    #[inline(always)]
    fn test_pair(self, ray: &ScalarBoxRay, pair: &NodePair, t_far: f32) -> (u32, f32, f32) {
        let (h0, t0) = Self::slab(ray, &pair.0[0], t_far);
        let (h1, t1) = Self::slab(ray, &pair.0[1], t_far);
        (u32::from(h0) | (u32::from(h1) << 1), t0, t1)
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    //! The slab test for two boxes in one AVX2 register.

    use core::arch::x86_64::{
        __m256, __m256i, _CMP_LE_OQ, _mm_cvtss_f32, _mm256_add_ps, _mm256_and_ps, _mm256_castsi256_ps,
        _mm256_cmp_ps, _mm256_cvtss_f32, _mm256_extractf128_ps, _mm256_load_ps, _mm256_max_ps, _mm256_min_ps,
        _mm256_movemask_ps, _mm256_mul_ps, _mm256_permute_ps, _mm256_permute2f128_ps,
        _mm256_permutevar8x32_ps, _mm256_set1_epi32, _mm256_set1_ps, _mm256_setr_epi32, _mm256_setr_ps,
        _mm256_sub_ps,
    };

    use glam::Vec3A;

    use super::{BoxKernel, FAR_PAD, NodePair};

    /// Proof that the CPU has AVX2 and FMA; only [`Avx2Kernel::detect`] makes one.
    #[derive(Clone, Copy)]
    pub(super) struct Avx2Kernel {
        _private: (),
    }

    impl Avx2Kernel {
        #[inline]
        pub(super) fn detect() -> Option<Self> {
            (is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"))
                .then_some(Self { _private: () })
        }
    }

    pub(super) struct Avx2BoxRay {
        /// `[ox, oy, oz, ox]` twice: lane 3 of each half repeats x so no lane holds garbage.
        origin: __m256,
        inv_dir: __m256,
        /// Picks `[near x, near y, near z, near x | far x, far y, far z, far x]` out of a node's
        /// `[lo, first, hi, count]`.
        select: __m256i,
        t_min: __m256,
    }

    impl BoxKernel for Avx2Kernel {
        type Ray = Avx2BoxRay;

        #[inline(always)]
        fn prepare(self, origin: Vec3A, direction: Vec3A, t_min: f32) -> Avx2BoxRay {
            let o = origin.to_array();
            let i = (Vec3A::ONE / direction).to_array();
            let near = |k: usize, d: f32| {
                if d.is_sign_negative() {
                    4 + k as i32
                } else {
                    k as i32
                }
            };
            let far = |k: usize, d: f32| {
                if d.is_sign_negative() {
                    k as i32
                } else {
                    4 + k as i32
                }
            };
            let (dx, dy, dz) = (direction.x, direction.y, direction.z);
            // SAFETY: `self` proves AVX2 is available; these intrinsics only touch registers.
            unsafe {
                Avx2BoxRay {
                    origin: _mm256_setr_ps(o[0], o[1], o[2], o[0], o[0], o[1], o[2], o[0]),
                    inv_dir: _mm256_setr_ps(i[0], i[1], i[2], i[0], i[0], i[1], i[2], i[0]),
                    select: _mm256_setr_epi32(
                        near(0, dx),
                        near(1, dy),
                        near(2, dz),
                        near(0, dx),
                        far(0, dx),
                        far(1, dy),
                        far(2, dz),
                        far(0, dx),
                    ),
                    t_min: _mm256_set1_ps(t_min),
                }
            }
        }

        /// The scalar kernel's test on both children at once (same operations, same NaN rules).
        #[inline(always)]
        fn test_pair(self, ray: &Avx2BoxRay, pair: &NodePair, t_far: f32) -> (u32, f32, f32) {
            // SAFETY: `self` proves AVX2 is available. `NodePair` is 64-byte aligned and holds two
            // 32-byte `Node`s of eight 4-byte fields each, so both aligned 8-lane loads are in bounds.
            unsafe {
                let p = pair.0.as_ptr().cast::<f32>();
                let c0 = _mm256_permutevar8x32_ps(_mm256_load_ps(p), ray.select);
                let c1 = _mm256_permutevar8x32_ps(_mm256_load_ps(p.add(8)), ray.select);
                let near = _mm256_permute2f128_ps::<0x20>(c0, c1);
                let far = _mm256_permute2f128_ps::<0x31>(c0, c1);
                let tn = _mm256_mul_ps(_mm256_sub_ps(near, ray.origin), ray.inv_dir);
                let tf = _mm256_mul_ps(_mm256_sub_ps(far, ray.origin), ray.inv_dir);
                // max/min return the second operand when either is NaN: NaN lanes drop out here.
                let tn = _mm256_max_ps(tn, ray.t_min);
                let tf = _mm256_min_ps(tf, _mm256_set1_ps(t_far));
                let tn = _mm256_max_ps(tn, _mm256_permute_ps::<0b10_11_00_01>(tn));
                let tn = _mm256_max_ps(tn, _mm256_permute_ps::<0b01_00_11_10>(tn));
                let tf = _mm256_min_ps(tf, _mm256_permute_ps::<0b10_11_00_01>(tf));
                let tf = _mm256_min_ps(tf, _mm256_permute_ps::<0b01_00_11_10>(tf));
                let abs = _mm256_and_ps(tf, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff)));
                let tf = _mm256_add_ps(tf, _mm256_mul_ps(abs, _mm256_set1_ps(FAR_PAD)));
                let bits = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32;
                let mask = (bits & 1) | ((bits >> 3) & 2);
                (
                    mask,
                    _mm256_cvtss_f32(tn),
                    _mm_cvtss_f32(_mm256_extractf128_ps::<1>(tn)),
                )
            }
        }
    }
}

/// What a traversal does at a leaf. Implementations inline completely (`visit` is
/// `#[inline(always)]`), so inside an AVX2 entry point all of the traversal is AVX2 code.
trait LeafVisitor {
    /// Tests primitives `first..first + count`; may shrink `t_far`; returns `true` to stop.
    fn visit(&mut self, first: usize, count: usize, t_far: &mut f32) -> bool;
}

/// Pops the next stacked node whose entry distance is still within `t_far`.
#[inline(always)]
fn pop(stack: &[(u32, f32); STACK_SIZE], sp: &mut usize, t_far: f32) -> Option<usize> {
    let limit = pad_far(t_far);
    while *sp > 0 {
        *sp -= 1;
        let (node, t_near) = stack[*sp];
        if t_near <= limit {
            return Some(node as usize);
        }
    }
    None
}

/// Stack-based, near-child-first traversal of `tree` over `[t_min, t_far]` (`t_min` is in `ray`).
#[inline(always)]
fn traverse<K: BoxKernel, L: LeafVisitor>(tree: &Tree, kernel: K, ray: &K::Ray, t_far: f32, leaf: &mut L) {
    let mut t_far = t_far;
    let root = &tree.root;
    if root.count > 0 {
        leaf.visit(root.first as usize, root.count as usize, &mut t_far);
        return;
    }
    if tree.pairs.is_empty() {
        return;
    }
    let mut stack = [(0u32, 0.0f32); STACK_SIZE];
    let mut sp = 0usize;
    let mut pair = root.first as usize;
    'pairs: loop {
        let (mask, t0, t1) = kernel.test_pair(ray, &tree.pairs[pair], t_far);
        let base = 2 * pair;
        let mut cur = match mask {
            0b11 => {
                let (near, far, t_far_child) = if t1 < t0 {
                    (base + 1, base, t0)
                } else {
                    (base, base + 1, t1)
                };
                stack[sp] = (far as u32, t_far_child);
                sp += 1;
                near
            }
            0b01 => base,
            0b10 => base + 1,
            _ => match pop(&stack, &mut sp, t_far) {
                Some(n) => n,
                None => return,
            },
        };
        loop {
            let node = &tree.pairs[cur >> 1].0[cur & 1];
            if node.count == 0 {
                pair = node.first as usize;
                continue 'pairs;
            }
            if leaf.visit(node.first as usize, node.count as usize, &mut t_far) {
                return;
            }
            match pop(&stack, &mut sp, t_far) {
                Some(n) => cur = n,
                None => return,
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// Triangles

/// Per-ray constants of the watertight test: the ray origin and the shear that maps `v - origin` to
/// `(A[kx] - Sx·A[kz], A[ky] - Sy·A[kz], Sz·A[kz])` (Woop et al. 2013, with `kz` the dominant axis).
/// As a matrix product each row has one unit entry, one shear entry and one exact zero, so it rounds
/// exactly like the paper's scalar formulas.
#[derive(Clone, Copy)]
struct TriRay {
    origin: Vec3A,
    shear: Mat3A,
}

impl TriRay {
    #[inline(always)]
    fn new(origin: Vec3A, direction: Vec3A) -> Self {
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
        let mut rows = [[0.0f32; 3]; 3];
        rows[0][kx] = 1.0;
        rows[0][kz] = -(direction[kx] / dz);
        rows[1][ky] = 1.0;
        rows[1][kz] = -(direction[ky] / dz);
        rows[2][kz] = 1.0 / dz;
        let col = |j: usize| Vec3A::new(rows[0][j], rows[1][j], rows[2][j]);
        Self {
            origin,
            shear: Mat3A::from_cols(col(0), col(1), col(2)),
        }
    }

    /// Two-sided watertight test: `(t, u, v)` with `t_min < t < t_max`, where the hit point is
    /// `(1 - u - v)·v0 + u·v1 + v·v2`.
    #[inline(always)]
    fn intersect(&self, tri: &[Vec3A; 3], t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        let a = self.shear * (tri[0] - self.origin);
        let b = self.shear * (tri[1] - self.origin);
        let c = self.shear * (tri[2] - self.origin);
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
            Some((t, e1 / det, e2 / det))
        } else {
            None
        }
    }
}

/// The vertices of triangle `tri` of `mesh`, or `None` when it is skipped (see the module docs).
fn triangle_vertices(mesh: &TriangleMesh, tri: [u32; 3]) -> Option<[Vec3A; 3]> {
    let p = |i: u32| mesh.positions.get(i as usize).copied();
    let v = [p(tri[0])?, p(tri[1])?, p(tri[2])?];
    let finite = v.iter().all(|p| p.is_finite());
    (finite && (v[1] - v[0]).cross(v[2] - v[0]) != Vec3A::ZERO).then_some(v)
}

// ---------------------------------------------------------------------------------------------------
// MeshBvh

/// A binned-SAH BVH over one mesh's triangles, in object space.
///
/// Leaves hold at most four triangles. Skipped triangles (bad indices, non-finite or zero-area
/// vertices) are left out and never hit.
pub struct MeshBvh {
    mesh: TriangleMesh,
    tree: Tree,
    /// Triangle vertices in leaf order.
    tris: Vec<[Vec3A; 3]>,
    /// Mesh triangle index of each entry of `tris`.
    tri_ids: Vec<u32>,
}

impl MeshBvh {
    /// Builds the hierarchy: binned SAH (16 bins per axis) down to 16 triangles, an exact sorted
    /// sweep below that, leaves of at most 4. Meshes of 16k triangles or more build their subtrees on
    /// rayon's thread pool; the tree does not depend on the number of threads.
    #[must_use]
    pub fn build(mesh: TriangleMesh) -> Self {
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
        let tree = build_tree(&boxes, &mut refs, MESH_LEAF_SIZE);
        // Every ref passed this same check, so none is dropped and `tris` stays aligned with `tri_ids`.
        let tris = refs
            .iter()
            .filter_map(|&i| triangle_vertices(&mesh, mesh.triangles[i as usize]))
            .collect();
        Self {
            mesh,
            tree,
            tris,
            tri_ids: refs,
        }
    }

    /// The object-space bounding box `(min, max)` of the triangles that can be hit. An empty mesh
    /// gives an empty box: `min = +∞`, `max = −∞`.
    #[must_use]
    pub fn bounds(&self) -> (Vec3A, Vec3A) {
        let b = self.tree.root_bounds();
        (b.lo, b.hi)
    }

    /// The number of triangles that can be hit (skipped triangles are not counted).
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// The mesh the hierarchy was built over, unchanged.
    #[must_use]
    pub fn mesh(&self) -> &TriangleMesh {
        &self.mesh
    }

    /// The nearest hit in object space as `(t, triangle index, u, v)`, with `ray.t_min < t <
    /// ray.t_max`; `ray.time` is ignored. Barycentrics follow [`Hit::uv`]: the point is
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

    fn intersect_with(&self, ray: &Ray, scalar_only: bool) -> Option<(f32, u32, f32, f32)> {
        #[cfg(target_arch = "x86_64")]
        if !scalar_only && let Some(k) = avx2::Avx2Kernel::detect() {
            // SAFETY: the token from `detect` proves the CPU supports AVX2 and FMA.
            return unsafe { self.closest_avx2(k, ray.origin, ray.direction, ray.t_min, ray.t_max) };
        }
        let _ = scalar_only;
        self.closest(ScalarKernel, ray.origin, ray.direction, ray.t_min, ray.t_max)
    }

    fn occluded_with(&self, ray: &Ray, scalar_only: bool) -> bool {
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
    fn closest<K: BoxKernel>(
        &self,
        kernel: K,
        origin: Vec3A,
        direction: Vec3A,
        t_min: f32,
        t_lim: f32,
    ) -> Option<(f32, u32, f32, f32)> {
        let box_ray = kernel.prepare(origin, direction, t_min);
        let mut visitor = MeshClosest {
            bvh: self,
            ray: TriRay::new(origin, direction),
            t_min,
            lim: t_lim,
            best: None,
        };
        traverse(&self.tree, kernel, &box_ray, t_lim, &mut visitor);
        visitor.best
    }

    #[inline(always)]
    fn any<K: BoxKernel>(&self, kernel: K, origin: Vec3A, direction: Vec3A, t_min: f32, t_max: f32) -> bool {
        let box_ray = kernel.prepare(origin, direction, t_min);
        let mut visitor = MeshAny {
            bvh: self,
            ray: TriRay::new(origin, direction),
            t_min,
            t_max,
            found: false,
        };
        traverse(&self.tree, kernel, &box_ray, t_max, &mut visitor);
        visitor.found
    }
}

struct MeshClosest<'a> {
    bvh: &'a MeshBvh,
    ray: TriRay,
    t_min: f32,
    /// Exclusive upper limit: the ray's `t_max`, then just above the best `t` (so ties still count).
    lim: f32,
    best: Option<(f32, u32, f32, f32)>,
}

impl LeafVisitor for MeshClosest<'_> {
    #[inline(always)]
    fn visit(&mut self, first: usize, count: usize, t_far: &mut f32) -> bool {
        let range = first..first + count;
        for (tri, &id) in self.bvh.tris[range.clone()].iter().zip(&self.bvh.tri_ids[range]) {
            if let Some((t, u, v)) = self.ray.intersect(tri, self.t_min, self.lim) {
                // `t < lim` already means `t <= best t`.
                if self.best.is_none_or(|b| t < b.0 || id < b.1) {
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

impl fmt::Debug for MeshBvh {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MeshBvh")
            .field("triangles", &self.tris.len())
            .field("nodes", &self.tree.node_count())
            .field("bounds", &self.bounds())
            .finish()
    }
}

// ---------------------------------------------------------------------------------------------------
// Instances and motion

/// One placement of a mesh: object-to-world motion samples at shutter-normalised times in `[0, 1]`.
///
/// Samples are expected sorted by time, with at least one; [`SceneAccel::build`] sorts them anyway,
/// drops samples whose time is not finite, and places an instance with no samples by the identity.
/// With several samples each transform is decomposed into scale, rotation and translation (see the
/// module docs), so it should be invertible and free of shear; a single sample is used exactly as given.
#[derive(Debug, Clone)]
pub struct Instance {
    /// Index of the mesh in the list given to [`SceneAccel::build`]. An out-of-range index makes an
    /// instance that is never hit.
    pub mesh: u32,
    /// `(time, object-to-world)` samples.
    pub transform: Vec<(f32, Affine3A)>,
}

/// One decomposed motion sample.
#[derive(Debug, Clone, Copy)]
pub struct Key {
    time: f32,
    scale: Vec3A,
    rotation: Quat,
    translation: Vec3A,
}

impl Key {
    fn new(time: f32, m: &Affine3A) -> Self {
        let (scale, rotation, translation) = m.to_scale_rotation_translation();
        Self {
            time,
            scale: scale.into(),
            rotation,
            translation: translation.into(),
        }
    }
}

/// SRT interpolation between two keys, `f` in `[0, 1]`.
#[inline]
fn interpolate(a: &Key, b: &Key, f: f32) -> Affine3A {
    Affine3A::from_scale_rotation_translation(
        a.scale.lerp(b.scale, f).into(),
        a.rotation.slerp(b.rotation, f),
        a.translation.lerp(b.translation, f).into(),
    )
}

/// A transform over the shutter, ready to evaluate at any time: one matrix, or decomposed keys
/// interpolated by scale/rotation/translation (used for instances here and for the camera by the
/// render loop).
#[derive(Debug, Clone)]
pub enum Motion {
    /// Does not move.
    Static {
        /// The transform.
        to_world: Affine3A,
        /// Its inverse.
        to_object: Affine3A,
    },
    /// Moves: keys sorted by time.
    Moving {
        /// The decomposed samples.
        keys: Vec<Key>,
    },
}

impl Motion {
    /// From `(time, transform)` samples (sorted here; non-finite times dropped; none = identity).
    #[must_use]
    pub fn new(samples: &[(f32, Affine3A)]) -> Self {
        let mut samples: Vec<(f32, Affine3A)> = samples.iter().copied().filter(|s| s.0.is_finite()).collect();
        samples.sort_by(|a, b| a.0.total_cmp(&b.0));
        match samples.as_slice() {
            [] => Self::Static {
                to_world: Affine3A::IDENTITY,
                to_object: Affine3A::IDENTITY,
            },
            [(_, m)] => Self::Static {
                to_world: *m,
                to_object: m.inverse(),
            },
            many => Self::Moving {
                keys: many.iter().map(|(t, m)| Key::new(*t, m)).collect(),
            },
        }
    }

    /// The transform at `time` (clamped to the sampled range).
    #[must_use]
    pub fn object_to_world(&self, time: f32) -> Affine3A {
        match self {
            Self::Static { to_world, .. } => *to_world,
            Self::Moving { keys } => {
                let (first, last) = (&keys[0], &keys[keys.len() - 1]);
                // NaN times take the first sample, like times before the shutter opens.
                if time.is_nan() || time <= first.time {
                    return interpolate(first, first, 0.0);
                }
                if time >= last.time {
                    return interpolate(last, last, 0.0);
                }
                // first.time < time < last.time, so 1 <= i < keys.len().
                let i = keys.partition_point(|k| k.time <= time);
                let (a, b) = (&keys[i - 1], &keys[i]);
                interpolate(a, b, (time - a.time) / (b.time - a.time))
            }
        }
    }

    #[inline]
    fn world_to_object(&self, time: f32) -> Affine3A {
        match self {
            Self::Static { to_object, .. } => *to_object,
            Self::Moving { .. } => self.object_to_world(time).inverse(),
        }
    }

    /// A world box containing the object box `b` at every time (see the module docs).
    fn world_bounds(&self, b: &Aabb) -> Aabb {
        let corners = b.corners();
        let mut out = Aabb::EMPTY;
        match self {
            Self::Static { to_world, .. } => {
                for c in corners {
                    out.grow_point(to_world.transform_point3a(c));
                }
            }
            Self::Moving { keys } => {
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
}

/// One instance as the accelerator keeps it.
#[derive(Debug, Clone)]
struct Placement {
    /// Index into `SceneAccel::meshes`, if valid.
    mesh: Option<usize>,
    motion: Motion,
}

/// A scene hit before the world-space [`Hit`] is assembled.
#[derive(Debug, Clone, Copy)]
struct SceneHit {
    t: f32,
    instance: u32,
    mesh: usize,
    primitive: u32,
    u: f32,
    v: f32,
}

// ---------------------------------------------------------------------------------------------------
// SceneAccel

/// The scene accelerator: a top-level binned-SAH BVH over instance boxes (conservative over the
/// shutter for moving instances), each instance referring to a [`MeshBvh`].
pub struct SceneAccel {
    meshes: Vec<MeshBvh>,
    placements: Vec<Placement>,
    top: Tree,
    /// Instance index of each top-level leaf entry.
    top_ids: Vec<u32>,
    triangle_count: usize,
}

impl SceneAccel {
    /// Builds one [`MeshBvh`] per mesh (in parallel) and the top-level hierarchy over `instances`.
    ///
    /// Instances whose mesh index is out of range, or whose world box is not finite (non-finite or
    /// singular motion samples), are kept — their indices still count — but never hit.
    #[must_use]
    pub fn build(meshes: Vec<TriangleMesh>, instances: Vec<Instance>) -> Self {
        let meshes: Vec<MeshBvh> = meshes.into_par_iter().map(MeshBvh::build).collect();
        let placements: Vec<Placement> = instances
            .iter()
            .map(|inst| Placement {
                mesh: ((inst.mesh as usize) < meshes.len()).then_some(inst.mesh as usize),
                motion: Motion::new(&inst.transform),
            })
            .collect();
        let n = placements.len().min(u32::MAX as usize);
        let boxes: Vec<Aabb> = placements[..n]
            .iter()
            .map(|p| match p.mesh.map(|m| &meshes[m]) {
                Some(mesh) if mesh.triangle_count() > 0 => p.motion.world_bounds(&mesh.tree.root_bounds()),
                _ => Aabb::EMPTY,
            })
            .collect();
        let mut top_ids: Vec<u32> = (0..n as u32).filter(|&i| boxes[i as usize].is_finite()).collect();
        let triangle_count = top_ids
            .iter()
            .filter_map(|&i| placements[i as usize].mesh)
            .map(|m| meshes[m].triangle_count())
            .sum();
        let top = build_tree(&boxes, &mut top_ids, INSTANCE_LEAF_SIZE);
        Self {
            meshes,
            placements,
            top,
            top_ids,
            triangle_count,
        }
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
        let b = self.top.root_bounds();
        (b.lo, b.hi)
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

    fn closest_dispatch(&self, ray: &Ray, scalar_only: bool) -> Option<SceneHit> {
        #[cfg(target_arch = "x86_64")]
        if !scalar_only && let Some(k) = avx2::Avx2Kernel::detect() {
            // SAFETY: the token from `detect` proves the CPU supports AVX2 and FMA.
            return unsafe { self.closest_avx2(k, ray) };
        }
        let _ = scalar_only;
        self.closest(ScalarKernel, ray)
    }

    fn any_dispatch(&self, ray: &Ray, scalar_only: bool) -> bool {
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
        self.closest(k, ray)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn any_avx2(&self, k: avx2::Avx2Kernel, ray: &Ray) -> bool {
        self.any(k, ray)
    }

    /// The object-space ray of `placement` for `ray`; the direction is not renormalised, so `t` carries
    /// over unchanged.
    #[inline(always)]
    fn object_ray(placement: &Placement, ray: &Ray) -> (Vec3A, Vec3A) {
        let to_object = placement.motion.world_to_object(ray.time);
        (
            to_object.transform_point3a(ray.origin),
            to_object.transform_vector3a(ray.direction),
        )
    }

    #[inline(always)]
    fn closest<K: BoxKernel>(&self, kernel: K, ray: &Ray) -> Option<SceneHit> {
        let box_ray = kernel.prepare(ray.origin, ray.direction, ray.t_min);
        let mut visitor = SceneClosest {
            accel: self,
            kernel,
            ray,
            lim: ray.t_max,
            best: None,
        };
        traverse(&self.top, kernel, &box_ray, ray.t_max, &mut visitor);
        visitor.best
    }

    #[inline(always)]
    fn any<K: BoxKernel>(&self, kernel: K, ray: &Ray) -> bool {
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

    /// Assembles the world-space hit: position from the barycentrics, geometric normal from the
    /// world-space triangle, shading normal through the inverse transpose.
    fn make_hit(&self, ray: &Ray, h: SceneHit) -> Hit {
        let mesh = self.meshes[h.mesh].mesh();
        let to_world = self.placements[h.instance as usize]
            .motion
            .object_to_world(ray.time);
        let [i0, i1, i2] = mesh.triangles[h.primitive as usize].map(|i| i as usize);
        let (w0, w1, w2) = (1.0 - h.u - h.v, h.u, h.v);
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
            t: h.t,
            position,
            geometric_normal: geometric,
            shading_normal: shading,
            uv: (h.u, h.v),
            instance: h.instance,
            primitive: h.primitive,
        }
    }
}

struct SceneClosest<'a, K> {
    accel: &'a SceneAccel,
    kernel: K,
    ray: &'a Ray,
    lim: f32,
    best: Option<SceneHit>,
}

impl<K: BoxKernel> LeafVisitor for SceneClosest<'_, K> {
    #[inline(always)]
    fn visit(&mut self, first: usize, count: usize, t_far: &mut f32) -> bool {
        let ray = self.ray;
        for &instance in &self.accel.top_ids[first..first + count] {
            let placement = &self.accel.placements[instance as usize];
            let Some(mesh) = placement.mesh else { continue };
            let (o, d) = SceneAccel::object_ray(placement, ray);
            if let Some((t, primitive, u, v)) =
                self.accel.meshes[mesh].closest(self.kernel, o, d, ray.t_min, self.lim)
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
            let placement = &self.accel.placements[instance as usize];
            let Some(mesh) = placement.mesh else { continue };
            let (o, d) = SceneAccel::object_ray(placement, ray);
            if self.accel.meshes[mesh].any(self.kernel, o, d, ray.t_min, ray.t_max) {
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

    fn occluded(&self, ray: &Ray) -> bool {
        self.any_dispatch(ray, false)
    }
}

impl fmt::Debug for SceneAccel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SceneAccel")
            .field("meshes", &self.meshes.len())
            .field("instances", &self.placements.len())
            .field("triangles", &self.triangle_count)
            .field("bounds", &self.bounds())
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use core::f32::consts::FRAC_PI_2;

    use proptest::prelude::*;

    use super::*;

    /// `(t, triangle, u, v)`.
    type MeshHit = (f32, u32, f32, f32);

    fn ray(origin: Vec3A, direction: Vec3A) -> Ray {
        Ray {
            origin,
            direction,
            t_min: 0.0,
            t_max: f32::INFINITY,
            time: 0.0,
        }
    }

    /// Both traversal kernels (`true` = scalar only); without AVX2 both runs use the scalar one.
    const KERNELS: [bool; 2] = [false, true];

    fn brute_closest(mesh: &TriangleMesh, ray: &Ray) -> Option<MeshHit> {
        let tri_ray = TriRay::new(ray.origin, ray.direction);
        let mut best: Option<MeshHit> = None;
        for (i, &tri) in mesh.triangles.iter().enumerate() {
            let Some(v) = triangle_vertices(mesh, tri) else {
                continue;
            };
            if let Some((t, u, w)) = tri_ray.intersect(&v, ray.t_min, ray.t_max)
                && best.is_none_or(|b| t < b.0)
            {
                best = Some((t, i as u32, u, w));
            }
        }
        best
    }

    fn brute_any(mesh: &TriangleMesh, ray: &Ray) -> bool {
        let tri_ray = TriRay::new(ray.origin, ray.direction);
        mesh.triangles
            .iter()
            .filter_map(|&tri| triangle_vertices(mesh, tri))
            .any(|v| tri_ray.intersect(&v, ray.t_min, ray.t_max).is_some())
    }

    /// Checks a BVH against brute force on one ray, with both kernels.
    fn check_mesh_ray(bvh: &MeshBvh, ray: &Ray, scale: f32) -> Result<(), TestCaseError> {
        let expected = brute_closest(bvh.mesh(), ray);
        let any = brute_any(bvh.mesh(), ray);
        for scalar in KERNELS {
            let got = bvh.intersect_with(ray, scalar);
            match (got, expected) {
                (None, None) => {}
                (Some(g), Some(e)) => {
                    prop_assert!(
                        g.2 >= 0.0 && g.3 >= 0.0 && g.2 + g.3 <= 1.0 + 1e-6,
                        "barycentrics {:?}",
                        g
                    );
                    prop_assert_eq!(g.1, e.1, "triangle (scalar kernel: {}) for {:?}", scalar, ray);
                    prop_assert!((g.0 - e.0).abs() <= 1e-4 * scale, "t {} vs {}", g.0, e.0);
                    prop_assert!((g.2 - e.2).abs() <= 1e-4 && (g.3 - e.3).abs() <= 1e-4);
                }
                _ => prop_assert!(
                    false,
                    "BVH {:?} vs brute force {:?} (scalar kernel: {}) for {:?}",
                    got,
                    expected,
                    scalar,
                    ray
                ),
            }
            prop_assert_eq!(
                bvh.occluded_with(ray, scalar),
                any,
                "occluded (scalar kernel: {}) for {:?}",
                scalar,
                ray
            );
        }
        Ok(())
    }

    fn vec3(r: f32) -> impl Strategy<Value = Vec3A> {
        (-r..r, -r..r, -r..r).prop_map(|(x, y, z)| Vec3A::new(x, y, z))
    }

    /// Ordinary, sliver, exactly degenerate, collinear and axis-aligned (flat box) triangles.
    fn triangle() -> impl Strategy<Value = [Vec3A; 3]> {
        (
            vec3(1.0),
            vec3(1.0),
            vec3(1.0),
            0u8..8,
            0.0f32..1.0,
            -1e-5f32..1e-5,
        )
            .prop_map(|(a, b, c, kind, s, eps)| {
                let snap = |v: Vec3A| Vec3A::new(v.x, v.y, (a.z * 4.0).round() / 4.0);
                match kind {
                    0 => [a, b, a + (b - a) * s + c * eps],
                    1 => [a, a, c],
                    2 => [a, b, a + (b - a) * s],
                    3 => [snap(a), snap(b), snap(c)],
                    _ => [a, b, c],
                }
            })
    }

    /// Well-shaped triangles only (area at least 1% of the longest edge squared): for the world-vs-object
    /// comparisons, where a sliver's plane (and so `t`) is too ill-conditioned to compare across spaces.
    fn solid_triangle() -> impl Strategy<Value = [Vec3A; 3]> {
        (vec3(1.0), vec3(1.0), vec3(1.0))
            .prop_map(|(a, b, c)| [a, b, c])
            .prop_filter("sliver", |[a, b, c]| {
                let longest = (b - a)
                    .length_squared()
                    .max((c - b).length_squared())
                    .max((a - c).length_squared());
                (b - a).cross(c - a).length() * 0.5 >= 0.01 * longest
            })
    }

    fn soup(triangles: &[[Vec3A; 3]], scale: f32) -> TriangleMesh {
        TriangleMesh {
            positions: triangles.iter().flatten().map(|&p| p * scale).collect(),
            normals: None,
            triangles: (0..triangles.len() as u32)
                .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
                .collect(),
        }
    }

    #[derive(Debug, Clone)]
    struct RaySpec {
        origin: Vec3A,
        snap_origin: bool,
        aim: Option<(prop::sample::Index, f32, f32)>,
        direction: Vec3A,
        zero_axis: u8,
        t_min: f32,
        t_max: Option<f32>,
    }

    fn ray_spec() -> impl Strategy<Value = RaySpec> {
        (
            vec3(2.0),
            any::<bool>(),
            prop::option::weighted(0.7, (any::<prop::sample::Index>(), 0.0f32..1.0, 0.0f32..1.0)),
            vec3(1.0),
            0u8..6,
            prop_oneof![Just(0.0f32), 0.0f32..1.0],
            prop::option::of(0.1f32..5.0),
        )
            .prop_map(
                |(origin, snap_origin, aim, direction, zero_axis, t_min, t_max)| RaySpec {
                    origin,
                    snap_origin,
                    aim,
                    direction,
                    zero_axis,
                    t_min,
                    t_max,
                },
            )
    }

    /// A world ray from `spec`, aimed (when asked) at a point of one of `targets` (world-space
    /// triangles); `interior` keeps that point at least 5% (in barycentrics) away from the edges.
    fn make_ray(spec: &RaySpec, targets: &[[Vec3A; 3]], scale: f32, interior: bool) -> Ray {
        let mut origin = spec.origin * scale;
        if spec.snap_origin {
            origin = (spec.origin * 4.0).round() / 4.0 * scale;
        }
        let mut direction = match (&spec.aim, targets.is_empty()) {
            (Some((index, s, t)), false) => {
                let [a, b, c] = targets[index.index(targets.len())];
                let (s, t) = if s + t > 1.0 { (1.0 - s, 1.0 - t) } else { (*s, *t) };
                let (s, t) = if interior {
                    (0.05 + 0.85 * s, 0.05 + 0.85 * t)
                } else {
                    (s, t)
                };
                a + (b - a) * s + (c - a) * t - origin
            }
            _ => spec.direction,
        };
        if spec.zero_axis < 3 {
            direction[spec.zero_axis as usize] = 0.0;
        }
        Ray {
            origin,
            direction,
            t_min: spec.t_min * scale,
            t_max: spec.t_max.map_or(f32::INFINITY, |t| t * scale),
            time: 0.0,
        }
    }

    /// No regression files in the source tree; failures print their minimal input instead.
    fn config(cases: u32) -> ProptestConfig {
        ProptestConfig {
            cases,
            failure_persistence: None,
            ..ProptestConfig::default()
        }
    }

    proptest! {
        #![proptest_config(config(256))]
        #[test]
        fn proptest_mesh_bvh_matches_brute_force(
            triangles in prop::collection::vec(triangle(), 1..=200),
            scale in prop::sample::select(vec![1e-3f32, 1.0, 1e3]),
            rays in prop::collection::vec(ray_spec(), 24),
        ) {
            let mesh = soup(&triangles, scale);
            let targets: Vec<[Vec3A; 3]> = triangles.iter().map(|t| t.map(|p| p * scale)).collect();
            let bvh = MeshBvh::build(mesh);
            for spec in &rays {
                check_mesh_ray(&bvh, &make_ray(spec, &targets, scale, false), scale)?;
            }
        }
    }

    /// An indexed heightfield: shared vertices, so rays through shared edges test watertightness too.
    fn heightfield(n: u32, seed: u64) -> TriangleMesh {
        let mut rng = SplitMix(seed);
        let mut mesh = TriangleMesh::default();
        for j in 0..=n {
            for i in 0..=n {
                mesh.positions.push(Vec3A::new(
                    i as f32 / n as f32,
                    0.2 * rng.next_f32(),
                    j as f32 / n as f32,
                ));
            }
        }
        for j in 0..n {
            for i in 0..n {
                let v = |a: u32, b: u32| b * (n + 1) + a;
                mesh.triangles.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
                mesh.triangles.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
            }
        }
        mesh
    }

    #[test]
    fn heightfield_rays_through_grid_lines_match_brute_force_and_never_leak() {
        let n = 16;
        let bvh = MeshBvh::build(heightfield(n, 7));
        for j in 0..=n {
            for i in 0..=n {
                // Straight down through every grid vertex and along grid lines: exactly on shared
                // vertices and edges, where a non-watertight test can miss both neighbours.
                for (dx, dz) in [(0.0, 0.0), (0.5, 0.0), (0.0, 0.5), (0.5, 0.5)] {
                    let (x, z) = ((i as f32 + dx) / n as f32, (j as f32 + dz) / n as f32);
                    if x > 1.0 || z > 1.0 {
                        continue;
                    }
                    let r = ray(Vec3A::new(x, 1.0, z), Vec3A::NEG_Y);
                    check_mesh_ray(&bvh, &r, 1.0).unwrap();
                    assert!(
                        bvh.intersect(&r).is_some(),
                        "leaked through the surface at ({x}, {z})"
                    );
                }
            }
        }
    }

    /// SplitMix64 for the deterministic large tests.
    struct SplitMix(u64);

    impl SplitMix {
        fn next_f32(&mut self) -> f32 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
        }

        fn vec(&mut self, r: f32) -> Vec3A {
            Vec3A::new(self.next_f32(), self.next_f32(), self.next_f32()) * (2.0 * r) - Vec3A::splat(r)
        }
    }

    #[test]
    fn large_mesh_matches_brute_force() {
        // Debug builds are ~50× slower: keep the test under a few seconds there.
        let (tris, rays) = if cfg!(debug_assertions) {
            (20_000, 100)
        } else {
            (50_000, 1000)
        };
        let mut rng = SplitMix(42);
        let mut triangles = Vec::with_capacity(tris);
        for _ in 0..tris {
            let c = rng.vec(1.0);
            triangles.push([c + rng.vec(0.03), c + rng.vec(0.03), c + rng.vec(0.03)]);
        }
        let mesh = soup(&triangles, 1.0);
        let bvh = MeshBvh::build(mesh);
        assert!(
            bvh.triangle_count() >= PARALLEL_BUILD_MIN,
            "exercise the parallel build"
        );
        assert!(bvh.tree.depth() < STACK_SIZE);
        let mut hits = 0;
        for k in 0..rays {
            let origin = rng.vec(1.5);
            let direction = if k % 2 == 0 {
                let [a, b, c] = triangles[(rng.next_f32() * tris as f32) as usize % tris];
                (a + b + c) / 3.0 - origin
            } else {
                rng.vec(1.0)
            };
            let r = ray(origin, direction);
            check_mesh_ray(&bvh, &r, 1.0).unwrap();
            hits += usize::from(bvh.intersect(&r).is_some());
        }
        assert!(hits > rays / 2, "most rays should hit ({hits} of {rays})");
    }

    #[test]
    fn rays_through_vertices_and_edges_match_brute_force() {
        // Vertices are box corners and edges lie on box faces, where rounding in the slab test and in
        // the triangle test disagree most: the far-distance padding must keep these boxes.
        let mut rng = SplitMix(17);
        let triangles: Vec<[Vec3A; 3]> = (0..300)
            .map(|_| {
                let c = rng.vec(1.0);
                [c + rng.vec(0.2), c + rng.vec(0.2), c + rng.vec(0.2)]
            })
            .collect();
        let bvh = MeshBvh::build(soup(&triangles, 1.0));
        for [a, b, c] in &triangles {
            for target in [*a, *b, *c, (*a + *b) * 0.5, (*b + *c) * 0.5, (*c + *a) * 0.5] {
                let origin = rng.vec(3.0);
                check_mesh_ray(&bvh, &ray(origin, target - origin), 1.0).unwrap();
            }
        }
    }

    #[test]
    fn triangle_test_agrees_with_an_independent_f64_solve() {
        let mut rng = SplitMix(3);
        let mut checked = 0;
        for _ in 0..2000 {
            let tri = [rng.vec(1.0), rng.vec(1.0), rng.vec(1.0)];
            let to64 = |v: Vec3A| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
            let [a, b, c] = tri.map(to64);
            let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let cross = |p: [f64; 3], q: [f64; 3]| {
                [
                    p[1] * q[2] - p[2] * q[1],
                    p[2] * q[0] - p[0] * q[2],
                    p[0] * q[1] - p[1] * q[0],
                ]
            };
            let dot = |p: [f64; 3], q: [f64; 3]| p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
            let n = cross(e1, e2);
            if dot(n, n).sqrt() < 0.05 {
                continue;
            }
            let origin = rng.vec(3.0);
            let direction = rng.vec(1.0);
            let (o, d) = (to64(origin), to64(direction));
            // Plane: dot(n, o + t d - a) = 0; then Cramer's rule for (u, v) in the plane.
            let denom = dot(n, d);
            if denom.abs() < 1e-3 {
                continue;
            }
            let oa = [a[0] - o[0], a[1] - o[1], a[2] - o[2]];
            let t = dot(n, oa) / denom;
            let p = [
                o[0] + t * d[0] - a[0],
                o[1] + t * d[1] - a[1],
                o[2] + t * d[2] - a[2],
            ];
            let (d00, d01, d11) = (dot(e1, e1), dot(e1, e2), dot(e2, e2));
            let (d20, d21) = (dot(p, e1), dot(p, e2));
            let den = d00 * d11 - d01 * d01;
            let u = (d11 * d20 - d01 * d21) / den;
            let v = (d00 * d21 - d01 * d20) / den;
            let margin = u.min(v).min(1.0 - u - v);
            if margin.abs() < 1e-3 || t.abs() < 1e-3 {
                continue;
            }
            let got = TriRay::new(origin, direction).intersect(&tri, f32::NEG_INFINITY, f32::INFINITY);
            if margin > 0.0 {
                let (gt, gu, gv) = got.expect("a hit well inside the triangle");
                assert!(
                    (f64::from(gt) - t).abs() < 1e-4 * (1.0 + t.abs()),
                    "t {gt} vs {t}"
                );
                assert!((f64::from(gu) - u).abs() < 1e-4 && (f64::from(gv) - v).abs() < 1e-4);
            } else {
                assert!(got.is_none(), "a hit well outside the triangle: {got:?}");
            }
            checked += 1;
        }
        assert!(checked > 1000);
    }

    #[test]
    fn t_range_is_strict_and_two_sided() {
        let tri = [
            Vec3A::new(-1.0, -1.0, 0.0),
            Vec3A::new(1.0, -1.0, 0.0),
            Vec3A::new(0.0, 1.0, 0.0),
        ];
        let front = TriRay::new(Vec3A::new(0.0, 0.0, 2.0), Vec3A::NEG_Z);
        let back = TriRay::new(Vec3A::new(0.0, 0.0, -2.0), Vec3A::Z);
        assert_eq!(front.intersect(&tri, 0.0, 10.0).map(|h| h.0), Some(2.0));
        assert_eq!(back.intersect(&tri, 0.0, 10.0).map(|h| h.0), Some(2.0));
        assert_eq!(front.intersect(&tri, 2.0, 10.0), None);
        assert_eq!(front.intersect(&tri, 0.0, 2.0), None);
    }

    #[test]
    fn duplicate_triangles_report_the_lower_index() {
        let t = [
            Vec3A::new(-1.0, -1.0, 0.0),
            Vec3A::new(1.0, -1.0, 0.0),
            Vec3A::new(0.0, 1.0, 0.0),
        ];
        let mut triangles = vec![[Vec3A::splat(5.0), Vec3A::splat(6.0), Vec3A::new(5.0, 6.0, 7.0)]; 40];
        triangles[17] = t;
        triangles[31] = t;
        triangles[9] = t.map(|p| p + Vec3A::Z);
        let bvh = MeshBvh::build(soup(&triangles, 1.0));
        for scalar in KERNELS {
            assert_eq!(
                bvh.intersect_with(&ray(Vec3A::new(0.1, 0.0, -3.0), Vec3A::Z), scalar)
                    .map(|h| h.1),
                Some(17)
            );
            assert_eq!(
                bvh.intersect_with(&ray(Vec3A::new(0.1, 0.0, 3.0), Vec3A::NEG_Z), scalar)
                    .map(|h| h.1),
                Some(9)
            );
        }
    }

    #[test]
    fn skipped_triangles_are_never_hit() {
        let mesh = TriangleMesh {
            positions: vec![
                Vec3A::new(-1.0, -1.0, 0.0),
                Vec3A::new(1.0, -1.0, 0.0),
                Vec3A::new(0.0, 1.0, 0.0),
                Vec3A::new(f32::NAN, 0.0, 0.0),
                Vec3A::new(f32::INFINITY, 0.0, 0.0),
                Vec3A::new(2.0, 2.0, 0.0),
            ],
            normals: None,
            triangles: vec![
                [0, 0, 2],  // repeated vertex
                [0, 1, 99], // index out of range
                [0, 1, 3],  // NaN vertex
                [0, 1, 4],  // infinite vertex
                [0, 5, 5],  // repeated vertex
                [0, 2, 5],  // valid, but out of the way of the ray below
            ],
        };
        let bvh = MeshBvh::build(mesh);
        assert_eq!(bvh.triangle_count(), 1);
        assert_eq!(bvh.mesh().len(), 6, "the mesh is kept as given");
        let r = ray(Vec3A::new(0.0, -0.5, 1.0), Vec3A::NEG_Z);
        for scalar in KERNELS {
            assert_eq!(bvh.intersect_with(&r, scalar), None);
            assert!(!bvh.occluded_with(&r, scalar));
        }
        // The one valid triangle is still found.
        assert_eq!(
            bvh.intersect(&ray(Vec3A::new(0.5, 0.9, 1.0), Vec3A::NEG_Z))
                .map(|h| h.1),
            Some(5)
        );
    }

    #[test]
    fn odd_rays_miss_without_panicking() {
        let mesh = soup(
            &[[
                Vec3A::new(-1.0, -1.0, 0.0),
                Vec3A::new(1.0, -1.0, 0.0),
                Vec3A::new(0.0, 1.0, 0.0),
            ]; 9],
            1.0,
        );
        let bvh = MeshBvh::build(mesh.clone());
        let moving = Instance {
            mesh: 0,
            transform: vec![
                (0.0, Affine3A::IDENTITY),
                (1.0, Affine3A::from_translation(glam::Vec3::X)),
            ],
        };
        let accel = SceneAccel::build(vec![mesh], vec![moving]);
        let nan = f32::NAN;
        let rays = [
            ray(Vec3A::new(0.0, 0.0, 1.0), Vec3A::new(nan, 0.0, -1.0)),
            ray(Vec3A::new(nan, 0.0, 1.0), Vec3A::NEG_Z),
            ray(Vec3A::new(0.0, 0.0, 1.0), Vec3A::ZERO),
            ray(Vec3A::new(0.0, 0.0, 1.0), Vec3A::splat(nan)),
            Ray {
                t_min: nan,
                ..ray(Vec3A::new(0.0, 0.0, 1.0), Vec3A::NEG_Z)
            },
            Ray {
                t_max: nan,
                ..ray(Vec3A::new(0.0, 0.0, 1.0), Vec3A::NEG_Z)
            },
            Ray {
                t_min: 5.0,
                t_max: 1.0,
                ..ray(Vec3A::new(0.0, 0.0, 1.0), Vec3A::NEG_Z)
            },
            Ray {
                time: nan,
                t_max: nan,
                ..ray(Vec3A::new(0.0, 0.0, 1.0), Vec3A::NEG_Z)
            },
            ray(Vec3A::splat(f32::INFINITY), Vec3A::NEG_Z),
        ];
        for r in &rays {
            for scalar in KERNELS {
                assert_eq!(bvh.intersect_with(r, scalar), None, "{r:?}");
                assert!(!bvh.occluded_with(r, scalar), "{r:?}");
                assert!(accel.closest_dispatch(r, scalar).is_none(), "{r:?}");
                assert!(!accel.any_dispatch(r, scalar), "{r:?}");
            }
        }
        // A NaN time alone is the first sample.
        let r = Ray {
            time: nan,
            ..ray(Vec3A::new(0.0, 0.0, 1.0), Vec3A::NEG_Z)
        };
        assert_eq!(accel.intersect(&r).map(|h| h.t), Some(1.0));
    }

    #[test]
    fn empty_inputs_build_and_miss() {
        let empty = MeshBvh::build(TriangleMesh::default());
        assert_eq!(empty.triangle_count(), 0);
        assert_eq!(empty.bounds(), (Vec3A::INFINITY, Vec3A::NEG_INFINITY));
        let r = ray(Vec3A::ZERO, Vec3A::Z);
        assert_eq!(empty.intersect(&r), None);
        assert!(!empty.occluded(&r));

        let scene = SceneAccel::build(vec![], vec![]);
        assert_eq!(scene.triangle_count(), 0);
        assert_eq!(scene.bounds(), (Vec3A::INFINITY, Vec3A::NEG_INFINITY));
        assert!(scene.intersect(&r).is_none() && !scene.occluded(&r));

        // A bad mesh index is never hit but keeps its slot; an empty sample list is the identity.
        let tri = soup(
            &[[
                Vec3A::new(-1.0, -1.0, 1.0),
                Vec3A::new(1.0, -1.0, 1.0),
                Vec3A::new(0.0, 1.0, 1.0),
            ]],
            1.0,
        );
        let scene = SceneAccel::build(
            vec![tri],
            vec![
                Instance {
                    mesh: 7,
                    transform: vec![],
                },
                Instance {
                    mesh: 0,
                    transform: vec![],
                },
            ],
        );
        assert_eq!(scene.triangle_count(), 1);
        assert_eq!(scene.instance_transform_at(1, 0.3), Affine3A::IDENTITY);
        assert_eq!(scene.intersect(&r).map(|h| (h.instance, h.t)), Some((1, 1.0)));
    }

    #[test]
    fn tree_depth_stays_bounded_on_adversarial_input() {
        // 240 nested, coplanar right triangles of sizes 2^-120 .. 2^119 sharing the corner at the
        // origin: the SAH peels the largest off a few at a time and, left alone, builds a tree ~57
        // deep. From depth SAH_DEPTH_LIMIT = 40 on, median splits must take over.
        let triangles: Vec<[Vec3A; 3]> = (-120..120)
            .map(|i| {
                let x = 2f32.powi(i);
                [Vec3A::ZERO, Vec3A::new(x, 0.0, 0.0), Vec3A::new(0.0, x, 0.0)]
            })
            .collect();
        let bvh = MeshBvh::build(soup(&triangles, 1.0));
        let depth = bvh.tree.depth();
        assert!((41..=48).contains(&depth), "depth {depth}");
        for (k, i) in (-120..120).enumerate() {
            // All triangles containing the point lie at the same t; the smallest has the lowest index.
            let p = 0.3 * 2f32.powi(i);
            let r = ray(Vec3A::new(p, p, 1.0), Vec3A::NEG_Z);
            check_mesh_ray(&bvh, &r, 1.0).unwrap();
            // Beyond 2^±60 the edge functions (products of two coordinates) leave the f32 range.
            if (-60..60).contains(&i) {
                assert_eq!(bvh.intersect(&r).map(|h| h.1), Some(k as u32), "size 2^{i}");
            }
        }
    }

    #[test]
    fn edge_signs_are_exact_when_f32_rounds_them_to_zero() {
        // Along +z the shear is the identity, so the edge function of B–C at the origin is
        // C.x·B.y − C.y·B.x = −(1 + 2⁻²²) + (1 + 2⁻²³)² = +2⁻⁴⁶, which f32 rounds to 0. The other two
        // edge functions are negative, so the ray passes just outside edge B–C: a miss. Taking the
        // rounded 0 at face value would call it a hit on the edge.
        let e = f32::EPSILON; // 2⁻²³
        let tri = [
            Vec3A::new(1.0, -1.0, 1.0),
            Vec3A::new(1.0 + e, 1.0, 1.0),
            Vec3A::new(-(1.0 + 2.0 * e), -(1.0 + e), 1.0),
        ];
        assert_eq!(
            -(1.0 + 2.0 * e) * 1.0 - (-(1.0 + e)) * (1.0 + e),
            0.0,
            "the premise: f32 rounds it to zero"
        );
        let r = TriRay::new(Vec3A::ZERO, Vec3A::Z);
        assert_eq!(r.intersect(&tri, 0.0, f32::INFINITY), None);
        // Moved a hair (2⁻²⁰) across that edge, the same ray hits.
        let inside = tri.map(|p| p - Vec3A::new(2f32.powi(-20), -(2f32.powi(-20)), 0.0));
        assert!(r.intersect(&inside, 0.0, f32::INFINITY).is_some());
    }

    // -----------------------------------------------------------------------------------------------
    // Instances

    /// Brute force over world-space triangles: `(t, instance, primitive, u, v)`.
    fn brute_scene(
        meshes: &[TriangleMesh],
        instances: &[Instance],
        accel: &SceneAccel,
        ray: &Ray,
    ) -> Option<(f32, u32, u32, f32, f32)> {
        let tri_ray = TriRay::new(ray.origin, ray.direction);
        let mut best: Option<(f32, u32, u32, f32, f32)> = None;
        for (k, inst) in instances.iter().enumerate() {
            let Some(mesh) = meshes.get(inst.mesh as usize) else {
                continue;
            };
            let m = accel.instance_transform_at(k as u32, ray.time);
            for (i, &tri) in mesh.triangles.iter().enumerate() {
                let Some(v) = triangle_vertices(mesh, tri) else {
                    continue;
                };
                if let Some((t, u, w)) =
                    tri_ray.intersect(&v.map(|p| m.transform_point3a(p)), ray.t_min, ray.t_max)
                    && best.is_none_or(|b| t < b.0)
                {
                    best = Some((t, k as u32, i as u32, u, w));
                }
            }
        }
        best
    }

    /// The world-space triangle `primitive` of `instance` at `time`.
    fn world_triangle(accel: &SceneAccel, instance: u32, primitive: u32, time: f32) -> [Vec3A; 3] {
        let mesh = accel.meshes[accel.placements[instance as usize].mesh.unwrap()].mesh();
        let m = accel.instance_transform_at(instance, time);
        mesh.triangles[primitive as usize].map(|i| m.transform_point3a(mesh.positions[i as usize]))
    }

    /// True when the point at `t` on `ray` lies on the plane of `tri` (to 1e-4 of the coordinates'
    /// size). Unlike `t` itself this is well conditioned for grazing rays.
    fn on_plane(tri: &[Vec3A; 3], ray: &Ray, t: f32) -> bool {
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
        let p = ray.at(t);
        n.dot(p - tri[0]).abs() <= 1e-4 * (1.0 + p.length() + tri[0].length())
    }

    /// Compares the accelerator with brute force over world triangles. Object- and world-space
    /// tests round differently, so where rounding can flip the answer the check accepts either: a
    /// hit within 1e-3 of a triangle edge (in barycentrics), or two hits at the same depth (the `t`
    /// values agree, or one hit point lies on the other's plane). Returns how many hits differed.
    fn check_scene_ray(
        meshes: &[TriangleMesh],
        instances: &[Instance],
        accel: &SceneAccel,
        ray: &Ray,
    ) -> Result<usize, TestCaseError> {
        let expected = brute_scene(meshes, instances, accel, ray);
        let near_edge = |u: f32, v: f32| u.min(v).min(1.0 - u - v) < 1e-3;
        let mut borderline = 0;
        for scalar in KERNELS {
            let got = accel
                .closest_dispatch(ray, scalar)
                .map(|h| accel.make_hit(ray, h));
            match (got, expected) {
                (None, None) => {}
                (Some(g), Some(e)) => {
                    let e_tri = world_triangle(accel, e.1, e.2, ray.time);
                    let same_depth =
                        (g.t - e.0).abs() <= 1e-4 * (1.0 + e.0.abs()) || on_plane(&e_tri, ray, g.t);
                    if (g.instance, g.primitive) == (e.1, e.2) {
                        prop_assert!(same_depth, "t {} vs {} for {:?}", g.t, e.0, ray);
                    } else {
                        prop_assert!(
                            same_depth || near_edge(g.uv.0, g.uv.1) || near_edge(e.3, e.4),
                            "hit {:?} vs brute force {:?} for {:?}",
                            g,
                            e,
                            ray
                        );
                        borderline += 1;
                    }
                    check_hit_frame(&g, ray, accel)?;
                }
                (Some(g), None) => {
                    prop_assert!(
                        near_edge(g.uv.0, g.uv.1),
                        "hit {:?}, brute force misses, for {:?}",
                        g,
                        ray
                    );
                    borderline += 1;
                }
                (None, Some(e)) => {
                    prop_assert!(
                        near_edge(e.3, e.4),
                        "miss, brute force hits {:?}, for {:?}",
                        e,
                        ray
                    );
                    borderline += 1;
                }
            }
            let any = accel.any_dispatch(ray, scalar);
            if any != expected.is_some() {
                prop_assert!(
                    expected.is_none_or(|e| near_edge(e.3, e.4)),
                    "occluded {} for {:?}",
                    any,
                    ray
                );
            }
        }
        Ok(borderline)
    }

    /// Normals unit and facing the ray; the geometric normal is perpendicular to the world triangle;
    /// the position lies on the ray.
    fn check_hit_frame(hit: &Hit, ray: &Ray, accel: &SceneAccel) -> Result<(), TestCaseError> {
        let ng = hit.geometric_normal;
        prop_assert!((ng.length() - 1.0).abs() < 1e-5, "|n| = {}", ng.length());
        prop_assert!((hit.shading_normal.length() - 1.0).abs() < 1e-5);
        prop_assert!(
            ng.dot(ray.direction) < 0.0,
            "normal {:?} does not face {:?}",
            ng,
            ray.direction
        );
        prop_assert!(hit.shading_normal.dot(ng) >= 0.0);
        let p = world_triangle(accel, hit.instance, hit.primitive, ray.time);
        for e in [p[1] - p[0], p[2] - p[0]] {
            prop_assert!(
                ng.dot(e).abs() <= 1e-3 * e.length(),
                "normal not perpendicular to the triangle"
            );
        }
        let at = ray.at(hit.t);
        prop_assert!(
            (hit.position - at).length() <= 1e-4 * (1.0 + at.length() + hit.t * ray.direction.length())
        );
        Ok(())
    }

    fn affine() -> impl Strategy<Value = Affine3A> {
        (
            vec3(1.0),
            -3.0f32..3.0,
            (0.3f32..3.0, 0.3f32..3.0, 0.3f32..3.0),
            vec3(3.0),
            any::<bool>(),
            -0.5f32..0.5,
        )
            .prop_map(|(axis, angle, (sx, sy, sz), t, shear, k)| {
                let rotation = Quat::from_axis_angle(axis.normalize_or(Vec3A::Y).into(), angle);
                let mut m = Affine3A::from_scale_rotation_translation(
                    glam::Vec3::new(sx, sy, sz),
                    rotation,
                    t.into(),
                );
                if shear {
                    m.matrix3.y_axis += m.matrix3.x_axis * k;
                }
                m
            })
    }

    proptest! {
        #![proptest_config(config(128))]
        #[test]
        fn proptest_static_instances_match_brute_force(
            mesh_a in prop::collection::vec(solid_triangle(), 1..=40),
            mesh_b in prop::collection::vec(solid_triangle(), 1..=40),
            placements in prop::collection::vec((0u32..3, affine()), 1..=6),
            rays in prop::collection::vec(ray_spec(), 24),
        ) {
            let meshes = vec![soup(&mesh_a, 1.0), soup(&mesh_b, 1.0)];
            // Mesh index 2 does not exist: such instances must be ignored.
            let instances: Vec<Instance> =
                placements.iter().map(|(mesh, m)| Instance { mesh: *mesh, transform: vec![(0.0, *m)] }).collect();
            let accel = SceneAccel::build(meshes.clone(), instances.clone());
            let targets: Vec<[Vec3A; 3]> = instances
                .iter()
                .filter_map(|inst| meshes.get(inst.mesh as usize).map(|mesh| (mesh, inst.transform[0].1)))
                .flat_map(|(mesh, m)| mesh.triangles.iter().map(move |t| t.map(|i| m.transform_point3a(mesh.positions[i as usize]))))
                .collect();
            let mut borderline = 0;
            for spec in &rays {
                borderline += check_scene_ray(&meshes, &instances, &accel, &make_ray(spec, &targets, 2.0, true))?;
            }
            prop_assert!(borderline <= 4, "{} borderline disagreements in {} rays", borderline, rays.len());
        }
    }

    /// A box-shaped mesh (12 triangles) spanning `lo..hi`.
    fn cuboid(lo: Vec3A, hi: Vec3A) -> TriangleMesh {
        let b = Aabb { lo, hi };
        let faces: [[u32; 4]; 6] = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        TriangleMesh {
            positions: b.corners().to_vec(),
            normals: None,
            triangles: faces
                .iter()
                .flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]])
                .collect(),
        }
    }

    #[test]
    fn translated_triangle_is_hit_only_mid_shutter() {
        // A thin triangle around x = 0 moving to x = 2: the ray at x = 1 sees it only near time 0.5.
        let half = 0.05;
        let tri = TriangleMesh {
            positions: vec![
                Vec3A::new(-half, -1.0, 0.0),
                Vec3A::new(half, -1.0, 0.0),
                Vec3A::new(0.0, 1.0, 0.0),
            ],
            normals: None,
            triangles: vec![[0, 1, 2]],
        };
        let instance = Instance {
            mesh: 0,
            transform: vec![
                (0.0, Affine3A::IDENTITY),
                (1.0, Affine3A::from_translation(glam::Vec3::new(2.0, 0.0, 0.0))),
            ],
        };
        let accel = SceneAccel::build(vec![tri.clone()], vec![instance.clone()]);
        let at = |time: f32| Ray {
            time,
            ..ray(Vec3A::new(1.0, -0.9, 5.0), Vec3A::NEG_Z)
        };
        let hit = accel.intersect(&at(0.5)).expect("hit at mid-shutter");
        assert!((hit.t - 5.0).abs() < 1e-5);
        for k in 0..=1000 {
            let time = k as f32 / 1000.0;
            // At y = -0.9 the triangle spans x ∈ 2·time ± 0.0475.
            let expect = (2.0 * time - 1.0).abs() < 0.0475;
            let clear = ((2.0 * time - 1.0).abs() - 0.0475).abs() > 1e-3;
            if clear {
                assert_eq!(accel.intersect(&at(time)).is_some(), expect, "time {time}");
                assert_eq!(accel.occluded(&at(time)), expect, "time {time}");
            }
        }
        for time in [0.48, 0.49, 0.5, 0.51, 0.52, 0.0, 1.0, 0.3] {
            check_scene_ray(
                std::slice::from_ref(&tri),
                std::slice::from_ref(&instance),
                &accel,
                &at(time),
            )
            .unwrap();
        }
        // Clamped outside the samples.
        assert_eq!(accel.instance_transform_at(0, -1.0), Affine3A::IDENTITY);
        assert!(
            accel
                .instance_transform_at(0, 7.0)
                .translation
                .abs_diff_eq(Vec3A::new(2.0, 0.0, 0.0), 1e-6)
        );
    }

    /// The independent motion model for the rotating tests: `Ry(90°·time)` then a translation.
    fn rotating_transform(time: f32) -> Affine3A {
        let s = time.clamp(0.0, 1.0);
        Affine3A::from_translation(glam::Vec3::new(0.5 * s, 0.0, -s))
            * Affine3A::from_rotation_y(FRAC_PI_2 * s)
    }

    fn rotating_scene() -> (Vec<TriangleMesh>, Vec<Instance>) {
        // Long in x and off the rotation axis, so mid-rotation corners leave both end boxes.
        let mesh = cuboid(Vec3A::new(1.0, -0.2, -0.3), Vec3A::new(3.0, 0.4, 0.1));
        let instance = Instance {
            mesh: 0,
            transform: vec![(0.0, rotating_transform(0.0)), (1.0, rotating_transform(1.0))],
        };
        (vec![mesh], vec![instance])
    }

    #[test]
    fn instance_transform_at_follows_slerp_and_lerp() {
        let (meshes, instances) = rotating_scene();
        let accel = SceneAccel::build(meshes, instances);
        let mut rng = SplitMix(11);
        for _ in 0..100 {
            let time = rng.next_f32() * 1.4 - 0.2;
            let got = accel.instance_transform_at(0, time);
            assert!(
                got.abs_diff_eq(rotating_transform(time), 1e-5),
                "time {time}: {got:?}"
            );
        }
    }

    #[test]
    fn rotating_instance_matches_brute_force_at_random_times() {
        let (meshes, instances) = rotating_scene();
        let accel = SceneAccel::build(meshes.clone(), instances.clone());
        let mut rng = SplitMix(5);
        let (mut hits, mut borderline) = (0, 0);
        for _ in 0..400 {
            let time = rng.next_f32();
            // Aim at a point of the independently transformed box, so most rays hit.
            let m = rotating_transform(time);
            let target = m.transform_point3a(Vec3A::new(
                1.0 + 2.0 * rng.next_f32(),
                -0.2 + 0.6 * rng.next_f32(),
                -0.1,
            ));
            let origin = rng.vec(6.0);
            let r = Ray {
                time,
                ..ray(origin, target - origin)
            };
            borderline += check_scene_ray(&meshes, &instances, &accel, &r).unwrap();
            hits += usize::from(accel.intersect(&r).is_some());
        }
        assert!(hits > 300, "{hits} hits");
        assert!(borderline < 8, "{borderline} borderline cases");
    }

    #[test]
    fn motion_bounds_enclose_the_instance_at_random_times() {
        let (meshes, mut instances) = rotating_scene();
        // A second instance with three samples, scaling and a half turn about a tilted axis.
        let spin = |a: f32| Quat::from_axis_angle(glam::Vec3::new(1.0, 1.0, 0.0).normalize(), a);
        instances.push(Instance {
            mesh: 0,
            transform: vec![
                (
                    0.0,
                    Affine3A::from_scale_rotation_translation(glam::Vec3::ONE, spin(0.0), glam::Vec3::ZERO),
                ),
                (
                    0.4,
                    Affine3A::from_scale_rotation_translation(
                        glam::Vec3::new(2.0, 1.0, 0.5),
                        spin(1.5),
                        glam::Vec3::X,
                    ),
                ),
                (
                    1.0,
                    Affine3A::from_scale_rotation_translation(
                        glam::Vec3::splat(0.7),
                        spin(3.0),
                        glam::Vec3::Y,
                    ),
                ),
            ],
        });
        for instances in [&instances[..1], &instances[1..]] {
            let accel = SceneAccel::build(meshes.clone(), instances.to_vec());
            let (lo, hi) = accel.bounds();
            let mut rng = SplitMix(99);
            for _ in 0..100 {
                let time = rng.next_f32();
                let m = accel.instance_transform_at(0, time);
                for &p in &meshes[0].positions {
                    let w = m.transform_point3a(p);
                    assert!(
                        w.cmpge(lo).all() && w.cmple(hi).all(),
                        "time {time}: {w:?} outside {lo:?}..{hi:?}"
                    );
                }
            }
            // Conservative but not loose: compare with the box swept at 2001 times.
            let mut swept = Aabb::EMPTY;
            for k in 0..=2000 {
                let m = accel.instance_transform_at(0, k as f32 / 2000.0);
                for &p in &meshes[0].positions {
                    swept.grow_point(m.transform_point3a(p));
                }
            }
            let ratio = Aabb { lo, hi }.half_area() / swept.half_area();
            assert!(ratio < 1.25, "bounds {ratio}× the swept box's area");
        }
    }

    // -----------------------------------------------------------------------------------------------
    // Normals

    /// A flat quad in z = 0 over x, y ∈ [-1, 1] whose vertex normals lean ±0.5 in x.
    fn tilted_quad() -> (TriangleMesh, impl Fn(f32) -> Vec3A) {
        let left = Vec3A::new(-0.5, 0.0, 1.0).normalize();
        let right = Vec3A::new(0.5, 0.0, 1.0).normalize();
        let mesh = TriangleMesh {
            positions: vec![
                Vec3A::new(-1.0, -1.0, 0.0),
                Vec3A::new(1.0, -1.0, 0.0),
                Vec3A::new(1.0, 1.0, 0.0),
                Vec3A::new(-1.0, 1.0, 0.0),
            ],
            normals: Some(vec![left, right, right, left]),
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        };
        // Barycentric interpolation is linear in x here.
        let expected = move |x: f32| (left * (1.0 - x) / 2.0 + right * (1.0 + x) / 2.0).normalize();
        (mesh, expected)
    }

    #[test]
    fn shading_normals_interpolate_vertex_normals() {
        let (mesh, expected) = tilted_quad();
        let scale = Affine3A::from_scale(glam::Vec3::new(2.0, 1.0, 1.0));
        let accel = SceneAccel::build(
            vec![mesh],
            vec![
                Instance {
                    mesh: 0,
                    transform: vec![(0.0, Affine3A::IDENTITY)],
                },
                Instance {
                    mesh: 0,
                    transform: vec![(0.0, Affine3A::from_translation(glam::Vec3::Z * -10.0) * scale)],
                },
            ],
        );
        for x in [-0.9f32, -0.3, 0.0, 0.5, 0.8] {
            // From above: normals point up (+z).
            let hit = accel
                .intersect(&ray(Vec3A::new(x, 0.3, 3.0), Vec3A::new(0.0, 0.0, -2.0)))
                .unwrap();
            assert_eq!(hit.instance, 0);
            assert!(hit.geometric_normal.abs_diff_eq(Vec3A::Z, 1e-6));
            assert!(
                hit.shading_normal.abs_diff_eq(expected(x), 1e-5),
                "x {x}: {:?}",
                hit.shading_normal
            );
            // From below: both flip.
            let hit = accel.intersect(&ray(Vec3A::new(x, 0.3, -3.0), Vec3A::Z)).unwrap();
            assert_eq!(hit.instance, 0);
            assert!(hit.geometric_normal.abs_diff_eq(Vec3A::NEG_Z, 1e-6));
            assert!(hit.shading_normal.abs_diff_eq(-expected(x), 1e-5));
            // The scaled copy: world x = 2·object x, and normals go through the inverse transpose
            // diag(1/2, 1, 1).
            let hit = accel
                .intersect(&ray(Vec3A::new(2.0 * x, 0.3, -5.0), Vec3A::NEG_Z))
                .unwrap();
            assert_eq!(hit.instance, 1);
            let n = expected(x);
            let want = Vec3A::new(n.x * 0.5, n.y, n.z).normalize();
            assert!(
                hit.shading_normal.abs_diff_eq(want, 1e-5),
                "x {x}: {:?} vs {want:?}",
                hit.shading_normal
            );
            assert!(
                (hit.t - 5.0).abs() < 1e-5 && hit.position.abs_diff_eq(Vec3A::new(2.0 * x, 0.3, -10.0), 1e-5)
            );
        }
    }

    #[test]
    fn geometric_normals_are_unit_and_face_the_ray() {
        let (meshes, instances) = rotating_scene();
        let accel = SceneAccel::build(meshes, instances);
        let mut rng = SplitMix(8);
        let mut hits = 0;
        for _ in 0..500 {
            let time = rng.next_f32();
            let r = Ray {
                time,
                ..ray(rng.vec(5.0), rng.vec(1.0))
            };
            // Also from inside the box, where the ray meets back faces.
            let inside = Ray {
                time,
                ..ray(
                    rotating_transform(time).transform_point3a(Vec3A::new(2.0, 0.1, -0.1)),
                    rng.vec(1.0),
                )
            };
            for r in [r, inside] {
                if let Some(hit) = accel.intersect(&r) {
                    check_hit_frame(&hit, &r, &accel).unwrap();
                    assert_eq!(
                        hit.shading_normal, hit.geometric_normal,
                        "no vertex normals: shading = geometric"
                    );
                    hits += 1;
                }
            }
        }
        assert!(hits > 500, "{hits} hits");
    }
}
