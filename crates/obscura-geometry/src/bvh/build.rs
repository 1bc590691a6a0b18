//! The binned-SAH builder: 16 bins per axis over the centroid bounds, an exact sorted sweep for
//! nodes of at most [`SWEEP_MAX`] primitives, leaf costs counted in blocks of primitives tested
//! together ([`build_tree_in_blocks`]), median splits from [`SAH_DEPTH_LIMIT`] on, and the
//! lower subtrees of large inputs built on rayon's pool. The tree depends only on the input, never on
//! the number of threads.

use glam::Vec3A;
use rayon::prelude::*;

use super::tree::{Aabb, Node, NodePair, Tree};

/// Bins per axis of the binned SAH.
const BINS: usize = 16;
/// Cost of one traversal step relative to one leaf-block test, for the SAH.
const TRAVERSAL_COST: f64 = 1.0;
/// Below this depth the SAH chooses splits; from it on, median splits bound the depth (see
/// [`STACK_SIZE`](super::traverse::STACK_SIZE)).
const SAH_DEPTH_LIMIT: u32 = 40;
/// Inputs with at least this many primitives build their lower subtrees on rayon's pool.
pub(super) const PARALLEL_BUILD_MIN: usize = 16_384;

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

/// Half the extent `hi − lo`, as `hi/2 − lo/2`: finite for any finite corners, where `hi − lo`
/// overflows to ∞ once the box spans more than `f32::MAX` (geometry near ±3·10³⁸). Binning scales by
/// this and measures positions as [`half_offset`], so the bins cover such boxes too.
#[inline]
fn half_extent(b: &Aabb) -> Vec3A {
    b.hi * 0.5 - b.lo * 0.5
}

/// Half the offset of `x` from `lo` (see [`half_extent`]).
#[inline]
fn half_offset(x: f32, lo: f32) -> f32 {
    x * 0.5 - lo * 0.5
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

/// A node still to build.
struct Subtree<'r> {
    /// Its primitives: the part of the leaf order that starts at `offset`.
    refs: &'r mut [u32],
    offset: usize,
    /// Its index in the flat node vector.
    slot: usize,
    span: Span,
}

impl<'r> Subtree<'r> {
    /// The root (slot 0) over all of `refs`.
    fn root(refs: &'r mut [u32], span: Span) -> Self {
        Self {
            refs,
            offset: 0,
            slot: 0,
            span,
        }
    }
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
    /// Primitives tested together in a leaf: the SAH counts a leaf's cost in blocks of this many.
    block: usize,
}

impl Builder<'_> {
    /// The SAH's intersection cost of `n` primitives: the blocks they fill.
    #[inline]
    fn blocks(&self, n: usize) -> f64 {
        n.div_ceil(self.block) as f64
    }

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
        let extent = half_extent(&span.centroids);
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
                self.blocks(n)
            };
        if n <= self.max_leaf && self.blocks(n) <= split_cost {
            return None;
        }
        let mid = match split {
            Split::Sorted { axis, at } => {
                self.sort(refs, axis);
                at
            }
            Split::Bin { axis, bin, lo, scale } => {
                let goes_left =
                    |r: u32| bin_index(half_offset(self.centroids[r as usize][axis], lo) * scale) < bin;
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
    fn sweep(&self, refs: &[u32]) -> Option<(f64, Split)> {
        let n = refs.len();
        let mut keyed = [(0.0f32, 0u32); SWEEP_MAX];
        let keyed = &mut keyed[..n];
        let mut best: Option<(f64, Split)> = None;
        for axis in 0..3 {
            for (k, &r) in keyed.iter_mut().zip(refs) {
                *k = (self.centroids[r as usize][axis], r);
            }
            // The same order as `sort`: by centroid, ties by index.
            keyed.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let mut right = [0.0f64; SWEEP_MAX];
            let mut acc = Aabb::EMPTY;
            for i in (1..n).rev() {
                acc.grow(&self.boxes[keyed[i].1 as usize]);
                right[i] = acc.half_area() * self.blocks(n - i);
            }
            let mut acc = Aabb::EMPTY;
            for i in 1..n {
                acc.grow(&self.boxes[keyed[i - 1].1 as usize]);
                let cost = acc.half_area() * self.blocks(i) + right[i];
                if best.as_ref().is_none_or(|b| cost < b.0) {
                    best = Some((cost, Split::Sorted { axis, at: i }));
                }
            }
        }
        best
    }

    /// Binned SAH (16 bins per axis over the centroid bounds): `(cost, split)`.
    fn binned(&self, refs: &[u32], span: &Span) -> Option<(f64, Split)> {
        let cb = &span.centroids;
        // Axes with zero extent get an infinite scale; 0·∞ = NaN lands in bin 0, so they offer no split.
        let scale = Vec3A::splat(BINS as f32) / half_extent(cb);
        let mut bins = [[Bin::EMPTY; BINS]; 3];
        for &r in refs {
            let b = (self.centroids[r as usize] * 0.5 - cb.lo * 0.5) * scale;
            let bx = &self.boxes[r as usize];
            for (axis_bins, coord) in bins.iter_mut().zip([b.x, b.y, b.z]) {
                let bin = &mut axis_bins[bin_index(coord)];
                bin.bounds.grow(bx);
                bin.count += 1;
            }
        }
        let mut best: Option<(f64, Split)> = None;
        for (axis, axis_bins) in bins.iter().enumerate() {
            let mut right = [0.0f64; BINS];
            let mut right_count = [0u32; BINS];
            let (mut acc, mut count) = (Aabb::EMPTY, 0u32);
            for i in (1..BINS).rev() {
                acc.grow(&axis_bins[i].bounds);
                count += axis_bins[i].count;
                right[i] = acc.half_area() * self.blocks(count as usize);
                right_count[i] = count;
            }
            let (mut acc, mut count) = (Aabb::EMPTY, 0u32);
            for i in 1..BINS {
                acc.grow(&axis_bins[i - 1].bounds);
                count += axis_bins[i - 1].count;
                if count == 0 || right_count[i] == 0 {
                    continue;
                }
                let cost = acc.half_area() * self.blocks(count as usize) + right[i];
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
        let e = half_extent(&span.centroids);
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

    /// Makes `node` a leaf, or splits it: then allocates its two children in `nodes` and returns them,
    /// left first.
    fn split_node<'r>(&self, node: Subtree<'r>, nodes: &mut Vec<Node>) -> Option<[Subtree<'r>; 2]> {
        let Subtree {
            refs,
            offset,
            slot,
            span,
        } = node;
        match self.split(refs, &span) {
            None => {
                nodes[slot] = Node::new(&span.bounds, offset as u32, refs.len() as u32);
                None
            }
            Some((mid, left, right)) => {
                let l = nodes.len();
                nodes.extend([Node::default(); 2]);
                nodes[slot] = Node::new(&span.bounds, l as u32, 0);
                let (a, b) = refs.split_at_mut(mid);
                Some([
                    Subtree {
                        refs: a,
                        offset,
                        slot: l,
                        span: left,
                    },
                    Subtree {
                        refs: b,
                        offset: offset + mid,
                        slot: l + 1,
                        span: right,
                    },
                ])
            }
        }
    }

    /// Builds `node` and everything below it.
    fn build_seq(&self, node: Subtree<'_>, nodes: &mut Vec<Node>) {
        for child in self.split_node(node, nodes).into_iter().flatten() {
            self.build_seq(child, nodes);
        }
    }

    /// Like [`Builder::build_seq`], but subtrees of at most `grain` primitives become [`Task`]s.
    fn build_top(&self, node: Subtree<'_>, nodes: &mut Vec<Node>, tasks: &mut Vec<Task>, grain: usize) {
        if node.refs.len() <= grain {
            tasks.push(Task {
                slot: node.slot,
                offset: node.offset,
                len: node.refs.len(),
                span: node.span,
            });
            return;
        }
        for child in self.split_node(node, nodes).into_iter().flatten() {
            self.build_top(child, nodes, tasks, grain);
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
            self.build_seq(Subtree::root(refs, span), &mut nodes);
            return Self::finish(&nodes);
        }

        let grain = (refs.len() / 16).max(4096);
        let mut tasks = Vec::new();
        self.build_top(Subtree::root(&mut *refs, span), &mut nodes, &mut tasks, grain);
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
                self.build_seq(Subtree::root(chunk, task.span), &mut local);
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
    /// Centroids whose bin along `axis` (`half_offset(c, lo)·scale`) is below `bin` go left.
    Bin {
        axis: usize,
        bin: usize,
        lo: f32,
        scale: f32,
    },
}

/// Builds a tree over the primitives listed in `refs` (reordered into leaf order on return), with
/// leaves of at most `max_leaf` primitives whose SAH cost is counted in blocks of `max_leaf` (see
/// [`build_tree_in_blocks`]).
pub(super) fn build_tree(boxes: &[Aabb], refs: &mut [u32], max_leaf: usize) -> Tree {
    build_tree_in_blocks(boxes, refs, max_leaf, max_leaf)
}

/// [`build_tree`], with the SAH counting a leaf's intersection cost in blocks of `block` primitives,
/// `⌈n/block⌉` (Embree's `sahBlockSize`): a leaf test covers four triangles at once, so three
/// triangles cost what four do, and the split that leaves full blocks wins where areas are close.
/// `block = 1` is the classic per-primitive SAH.
pub(super) fn build_tree_in_blocks(boxes: &[Aabb], refs: &mut [u32], max_leaf: usize, block: usize) -> Tree {
    let centroids: Vec<Vec3A> = if boxes.len() >= PARALLEL_BUILD_MIN {
        boxes.par_iter().map(Aabb::centre).collect()
    } else {
        boxes.iter().map(Aabb::centre).collect()
    };
    Builder {
        boxes,
        centroids: &centroids,
        max_leaf,
        block: block.max(1),
    }
    .build(refs)
}
