//! The eight-wide mesh hierarchy: [`WideNode`] (eight children's boxes in structure-of-arrays form,
//! 256 bytes, four cache lines), leaf blocks of up to four triangles ([`Tri4`]), [`collapse`] from the
//! binary SAH tree, the [`WideKernel`] box and triangle tests (portable here, AVX2 boxes and SSE
//! triangles in [`Avx2Wide`] on x86-64) and the front-to-back stack traversal [`traverse`].
//!
//! A binary tree's traversal fetches one 64-byte node pair and tests two boxes per step; the wide
//! tree tests eight boxes per step with one instruction per operation and has a third to a half as
//! many levels, so an incoherent ray takes fewer steps and fewer dependent cache misses. The boxes
//! are exactly the binary tree's (collapsing only removes levels), the box test performs the same
//! operations in the same order as [`ScalarKernel`](super::traverse::ScalarKernel)'s, and leaves are
//! the binary tree's triangle ranges (whole subtrees of at most four triangles merged), tested with
//! the same operations, so a ray gets the same hit, bit for bit (ties in `t` are broken by triangle
//! index, not by order).

use glam::Vec3A;

use super::traverse::{BoxKernel, FAR_PAD, LeafVisitor, ScalarBoxRay, ScalarKernel, pad_far};
use super::tree::{Aabb, Node, Tree};
use super::triangle::TriRay;

/// Children per node.
pub(super) const WIDTH: usize = 8;
/// Triangles per leaf block.
pub(super) const LANES: usize = 4;
/// Marks a leaf child in [`WideNode::meta`]; the low bits hold its primitive count.
pub(super) const LEAF: u32 = 1 << 31;
/// Traversal stack entries: each level leaves at most `WIDTH − 1` siblings pending, and the wide
/// tree is no deeper than the binary one (at most 73 levels, see
/// [`STACK_SIZE`](super::traverse::STACK_SIZE)): `7·73 + 1 < 520`.
const WIDE_STACK: usize = 520;

/// One node of the wide tree: the boxes of up to eight children, coordinate by coordinate
/// (`lo[axis][child]`), then what each child is. 256 bytes, aligned to a cache line.
///
/// A child is interior when `meta == 0` (then `child` is its node index) or a leaf when `meta`
/// has [`LEAF`] set (then `child` is its first primitive in leaf order and `meta & !LEAF` the
/// count). An unused slot is an empty leaf (`LEAF | 0`) with an empty box (`lo = +∞`, `hi = −∞`),
/// which no ray with a finite origin enters.
#[repr(C, align(64))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct WideNode {
    pub(super) lo: [[f32; WIDTH]; 3],
    pub(super) hi: [[f32; WIDTH]; 3],
    pub(super) child: [u32; WIDTH],
    pub(super) meta: [u32; WIDTH],
}

const _: () = assert!(size_of::<WideNode>() == 256 && align_of::<WideNode>() == 64);

impl WideNode {
    /// A node with every slot unused.
    const EMPTY: Self = Self {
        lo: [[f32::INFINITY; WIDTH]; 3],
        hi: [[f32::NEG_INFINITY; WIDTH]; 3],
        child: [0; WIDTH],
        meta: [LEAF; WIDTH],
    };
}

/// Up to four triangles of one leaf, coordinate by coordinate (`v[vertex][axis][lane]`), and their
/// mesh triangle indices: 160 bytes, read by the leaf test in one go. Unused lanes repeat lane 0
/// and are masked off by the leaf's count.
#[repr(C, align(16))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Tri4 {
    pub(super) v: [[[f32; LANES]; 3]; 3],
    pub(super) id: [u32; LANES],
}

const _: () = assert!(size_of::<Tri4>() == 160);

impl Tri4 {
    /// The vertices of lane `k`.
    #[inline(always)]
    pub(super) fn triangle(&self, k: usize) -> [Vec3A; 3] {
        [0, 1, 2].map(|j| Vec3A::new(self.v[j][0][k], self.v[j][1][k], self.v[j][2][k]))
    }
}

/// A wide tree: the root is `nodes[0]`; empty when `nodes` is. Leaves index `leaves`.
#[derive(Debug, Clone, Default)]
pub(super) struct WideTree {
    pub(super) nodes: Vec<WideNode>,
    pub(super) leaves: Vec<Tri4>,
}

impl WideTree {
    /// Bytes the nodes and leaf blocks take.
    pub(super) fn node_bytes(&self) -> usize {
        self.nodes.len() * size_of::<WideNode>() + self.leaves.len() * size_of::<Tri4>()
    }

    /// Depth of the deepest leaf (the root's children are at depth 1).
    #[cfg(test)]
    pub(super) fn depth(&self) -> usize {
        let mut deepest = 0;
        let mut todo = if self.nodes.is_empty() {
            vec![]
        } else {
            vec![(0usize, 1usize)]
        };
        while let Some((n, d)) = todo.pop() {
            deepest = deepest.max(d);
            let node = &self.nodes[n];
            for k in 0..WIDTH {
                if node.meta[k] == 0 {
                    todo.push((node.child[k] as usize, d + 1));
                }
            }
        }
        deepest
    }

    /// The tree's SAH cost: the expected number of node and leaf-block tests for a ray through the
    /// root's box, `Σ_nodes A(node)/A(root) + Σ_leaves A(leaf)/A(root)` (one 8-box test and one
    /// 4-triangle test cost about the same), areas from the boxes the parents store.
    #[cfg(test)]
    pub(super) fn sah_cost(&self) -> f64 {
        let (nodes, leaves) = self.sah_cost_parts();
        nodes + leaves
    }

    /// [`WideTree::sah_cost`]'s two terms: `(nodes, leaves)`.
    #[cfg(test)]
    pub(super) fn sah_cost_parts(&self) -> (f64, f64) {
        if self.nodes.is_empty() {
            return (0.0, 0.0);
        }
        let slot = |node: &WideNode, k: usize| Aabb {
            lo: Vec3A::new(node.lo[0][k], node.lo[1][k], node.lo[2][k]),
            hi: Vec3A::new(node.hi[0][k], node.hi[1][k], node.hi[2][k]),
        };
        let root = &self.nodes[0];
        let mut root_box = Aabb::EMPTY;
        for k in (0..WIDTH).filter(|&k| root.meta[k] != LEAF) {
            root_box.grow(&slot(root, k));
        }
        let (mut nodes, mut leaves) = (root_box.half_area(), 0.0);
        for node in &self.nodes {
            for k in (0..WIDTH).filter(|&k| node.meta[k] != LEAF) {
                let a = slot(node, k).half_area();
                if node.meta[k] == 0 {
                    nodes += a;
                } else {
                    leaves += a;
                }
            }
        }
        (nodes / root_box.half_area(), leaves / root_box.half_area())
    }
}

/// Cost of testing one wide node's eight boxes, relative to one leaf block's four triangles, in the
/// collapse's SAH.
const NODE_COST: f64 = 1.0;
/// Cost of testing one leaf block.
const BLOCK_COST: f64 = 1.0;

/// The binary tree seen by the collapse: node `0` is the root, the children of an interior node with
/// pair index `p` are nodes `1 + 2p` and `2 + 2p` (so a child's index is always above its parent's).
pub(super) struct Binary<'t> {
    tree: &'t Tree,
    /// Each node's triangles in leaf order, `first..end` (a subtree's leaves are contiguous).
    range: Vec<(u32, u32)>,
}

impl<'t> Binary<'t> {
    /// Indexes `tree` and finds each node's triangle range.
    pub(super) fn new(tree: &'t Tree) -> Self {
        let n = tree.node_count();
        let mut binary = Self {
            tree,
            range: vec![(0, 0); n],
        };
        // Children sit above their parent, so a backward sweep sees them first.
        for i in (0..n).rev() {
            let node = binary.node(i);
            binary.range[i] = if node.count > 0 {
                (node.first, node.first + node.count)
            } else {
                let [l, r] = binary.children(i);
                debug_assert!(l > i && r > i, "child below its parent");
                (binary.range[l].0, binary.range[r].1)
            };
        }
        binary
    }

    /// Binary node `i`.
    pub(super) fn node(&self, i: usize) -> Node {
        if i == 0 {
            self.tree.root
        } else {
            self.tree.pairs[(i - 1) / 2].0[(i - 1) % 2]
        }
    }

    /// The two children of interior node `i`.
    pub(super) fn children(&self, i: usize) -> [usize; 2] {
        let first = self.node(i).first as usize;
        [1 + 2 * first, 2 + 2 * first]
    }

    /// True when node `i`'s subtree fits one leaf block: it becomes a leaf (never opened, so leaf
    /// blocks stay as full as the builder made them).
    pub(super) fn is_leaf(&self, i: usize) -> bool {
        let (first, end) = self.range[i];
        end - first <= LANES as u32
    }

    /// Half the surface area of node `i`'s box.
    pub(super) fn area(&self, i: usize) -> f64 {
        area(&self.node(i))
    }
}

/// The collapse's dynamic programme (Ylitie, Karras and Laine, "Efficient Incoherent Ray Traversal
/// on GPUs Through Compressed Wide BVHs", HPG 2017, adapted to leaves of one block): `cost[i][k−1]`
/// is the least SAH cost of node `i`'s subtree when it may fill `k` slots of its parent, as one leaf
/// (`BLOCK_COST·A`), one wide node (`NODE_COST·A` plus its children's best use of eight slots), or
/// its two children sharing the `k` slots. Subtrees of at most [`LANES`] triangles are always one
/// leaf, so the leaves' term is the same for every choice and the programme in effect minimises the
/// total area of the wide nodes (the two costs' ratio does not change the tree). `O(n·WIDTH²)`.
pub(super) struct Plan<'t> {
    pub(super) binary: Binary<'t>,
    pub(super) cost: Vec<[f64; WIDTH]>,
}

impl<'t> Plan<'t> {
    /// Runs the programme bottom-up over `tree`.
    pub(super) fn new(tree: &'t Tree) -> Self {
        let binary = Binary::new(tree);
        let n = binary.range.len();
        let mut cost = vec![[0.0; WIDTH]; n];
        for i in (0..n).rev() {
            let a = binary.area(i);
            cost[i] = if binary.is_leaf(i) {
                [BLOCK_COST * a; WIDTH]
            } else {
                let [l, r] = binary.children(i);
                // split[k−1]: the two children in at most k slots (k ≥ 2).
                let mut split = [f64::INFINITY; WIDTH];
                for k in 2..=WIDTH {
                    split[k - 1] = (1..k)
                        .map(|j| cost[l][j - 1] + cost[r][k - j - 1])
                        .fold(f64::INFINITY, f64::min);
                }
                let mut c = [0.0; WIDTH];
                c[0] = NODE_COST * a + split[WIDTH - 1];
                for k in 2..=WIDTH {
                    c[k - 1] = c[k - 2].min(split[k - 1]);
                }
                c
            };
        }
        Self { binary, cost }
    }

    /// Appends the slots node `i` fills when given at most `k` of them: itself (a leaf or a wide
    /// node) when that is cheapest, else its children's share.
    fn slots(&self, i: usize, k: usize, out: &mut Vec<usize>) {
        let mut k = k;
        while k > 1 && self.cost[i][k - 2] <= self.cost[i][k - 1] {
            k -= 1;
        }
        if k == 1 {
            out.push(i);
        } else {
            self.share(i, k, out);
        }
    }

    /// Appends the slots of node `i`'s two children sharing at most `k` slots, as cheaply as the
    /// programme found.
    fn share(&self, i: usize, k: usize, out: &mut Vec<usize>) {
        let [l, r] = self.binary.children(i);
        let mut best = (f64::INFINITY, 1);
        for j in 1..k {
            let c = self.cost[l][j - 1] + self.cost[r][k - j - 1];
            if c < best.0 {
                best = (c, j);
            }
        }
        self.slots(l, best.1, out);
        self.slots(r, k - best.1, out);
    }
}

/// Collapses a binary tree into a wide one. Which binary nodes become wide nodes and which are
/// opened into their parent's slots is chosen by the SAH ([`Plan`]: each wide node costs
/// [`NODE_COST`] times its area, each leaf block [`BLOCK_COST`] times its area, and the programme
/// finds the cheapest tree), not by a fixed rule. A binary subtree over at most [`LANES`] triangles
/// becomes one leaf (its triangles are contiguous in leaf order), whose triangles `tris[i]` /
/// `ids[i]` are packed into one [`Tri4`]. Nodes are laid out depth first, each node's interior
/// children contiguous, and a node's leaf blocks are contiguous too.
pub(super) fn collapse(tree: &Tree, tris: &[[Vec3A; 3]], ids: &[u32]) -> WideTree {
    if tree.root.count == 0 && tree.pairs.is_empty() {
        return WideTree::default();
    }
    let plan = Plan::new(tree);
    let binary = &plan.binary;
    let mut out = WideTree {
        nodes: vec![WideNode::EMPTY],
        leaves: Vec::new(),
    };
    let wide_children = |i: usize| {
        let mut kids = Vec::with_capacity(WIDTH);
        plan.share(i, WIDTH, &mut kids);
        kids
    };
    // (wide node to fill, the binary nodes in its slots)
    let mut todo: Vec<(usize, Vec<usize>)> = vec![(
        0,
        if binary.is_leaf(0) {
            vec![0]
        } else {
            wide_children(0)
        },
    )];
    while let Some((slot, kids)) = todo.pop() {
        debug_assert!(!kids.is_empty() && kids.len() <= WIDTH);
        let mut node = WideNode::EMPTY;
        let mut pending = Vec::new();
        for (k, &i) in kids.iter().enumerate() {
            let n = binary.node(i);
            for axis in 0..3 {
                node.lo[axis][k] = n.lo[axis];
                node.hi[axis][k] = n.hi[axis];
            }
            if binary.is_leaf(i) {
                let (first, end) = binary.range[i];
                node.child[k] = out.leaves.len() as u32;
                node.meta[k] = LEAF | (end - first);
                out.leaves
                    .push(pack(tris, ids, first as usize, (end - first) as usize));
            } else {
                let index = out.nodes.len() + pending.len();
                node.child[k] = index as u32;
                node.meta[k] = 0;
                pending.push(wide_children(i));
            }
        }
        let base = out.nodes.len();
        out.nodes[slot] = node;
        out.nodes
            .extend(std::iter::repeat_n(WideNode::EMPTY, pending.len()));
        // Reversed, so the first child is built (and laid out) first.
        todo.extend(pending.into_iter().enumerate().rev().map(|(j, k)| (base + j, k)));
    }
    out
}

/// The leaf block of triangles `first..first + count` (at most [`LANES`]).
#[expect(
    clippy::needless_range_loop,
    reason = "lanes, vertices and axes index three arrays at once"
)]
fn pack(tris: &[[Vec3A; 3]], ids: &[u32], first: usize, count: usize) -> Tri4 {
    let mut block = Tri4 {
        v: [[[0.0; LANES]; 3]; 3],
        id: [0; LANES],
    };
    for k in 0..LANES {
        // Unused lanes repeat the first triangle; the count masks them off.
        let i = first + if k < count { k } else { 0 };
        for j in 0..3 {
            for axis in 0..3 {
                block.v[j][axis][k] = tris[i][j][axis];
            }
        }
        block.id[k] = ids[i];
    }
    block
}

/// Half the surface area of a binary node's box (the collapse's priority).
fn area(n: &Node) -> f64 {
    Aabb {
        lo: Vec3A::from_array(n.lo),
        hi: Vec3A::from_array(n.hi),
    }
    .half_area()
}

/// A ray/wide-node test. Implementations are zero-sized tokens: holding one proves the CPU can run
/// it.
pub(super) trait WideKernel: Copy {
    /// The per-ray constants the kernel precomputes.
    type Ray;
    /// Precomputes the per-ray constants for `[t_min, ..]`.
    fn prepare(self, origin: Vec3A, direction: Vec3A, t_min: f32) -> Self::Ray;
    /// Tests the [`WIDTH`] boxes of `node` against `[t_min, t_far]`: a mask (bit `k` for child `k`) and
    /// the entry distances.
    fn test(self, ray: &Self::Ray, node: &WideNode, t_far: f32) -> (u32, [f32; WIDTH]);
    /// The per-ray constants of the leaf test.
    type LeafRay;
    /// Precomputes them from the triangle test's constants.
    fn prepare_leaf(self, ray: TriRay) -> Self::LeafRay;
    /// The watertight test ([`TriRay::intersect_det`]) on the first `count` triangles of `block`
    /// with `t_min < t < lim`: a mask of the lanes hit and each lane's `(t, u, v, det)`, bit for bit
    /// what the scalar test gives.
    fn leaf(self, ray: &Self::LeafRay, block: &Tri4, count: usize, t_min: f32, lim: f32) -> (u32, LeafHits);
}

/// Per-lane `t`, `u`, `v`, `det` of a leaf test (meaningful in the lanes of its mask).
pub(super) type LeafHits = [[f32; LANES]; 4];

/// The leaf test one lane at a time, with the scalar test itself.
#[inline(always)]
fn leaf_scalar(ray: &TriRay, block: &Tri4, lanes: u32, t_min: f32, lim: f32, hits: &mut LeafHits) -> u32 {
    let mut mask = 0;
    let mut bits = lanes;
    while bits != 0 {
        let k = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        if let Some((t, u, v, det)) = ray.intersect_det(&block.triangle(k), t_min, lim) {
            mask |= 1 << k;
            hits[0][k] = t;
            hits[1][k] = u;
            hits[2][k] = v;
            hits[3][k] = det;
        }
    }
    mask
}

/// The portable kernel: the binary tree's scalar slab test, one child at a time.
#[derive(Clone, Copy)]
pub(super) struct PortableWide;

/// Per-ray constants of [`PortableWide`]: the scalar kernel's, prepared by it.
pub(super) type PortableWideRay = ScalarBoxRay;

impl WideKernel for PortableWide {
    type Ray = PortableWideRay;
    type LeafRay = TriRay;

    #[inline(always)]
    fn prepare_leaf(self, ray: TriRay) -> TriRay {
        ray
    }

    #[inline(always)]
    fn prepare(self, origin: Vec3A, direction: Vec3A, t_min: f32) -> PortableWideRay {
        BoxKernel::prepare(ScalarKernel, origin, direction, t_min)
    }

    #[inline(always)]
    #[expect(
        clippy::needless_range_loop,
        reason = "the child index picks a lane of six arrays"
    )]
    fn test(self, ray: &PortableWideRay, node: &WideNode, t_far: f32) -> (u32, [f32; WIDTH]) {
        let mut mask = 0;
        let mut entry = [0.0; WIDTH];
        for c in 0..WIDTH {
            let mut t0 = ray.t_min;
            let mut t1 = t_far;
            for k in 0..3 {
                let (near, far) = if ray.negative[k] {
                    (node.hi[k][c], node.lo[k][c])
                } else {
                    (node.lo[k][c], node.hi[k][c])
                };
                let a = (near - ray.origin[k]) * ray.inv_dir[k];
                let b = (far - ray.origin[k]) * ray.inv_dir[k];
                // A NaN (`0·∞`: origin on a slab plane of an axis-parallel ray) loses both
                // comparisons, so that axis does not constrain the interval.
                t0 = if a > t0 { a } else { t0 };
                t1 = if b < t1 { b } else { t1 };
            }
            mask |= u32::from(t0 <= pad_far(t1)) << c;
            entry[c] = t0;
        }
        (mask, entry)
    }

    #[inline(always)]
    fn leaf(self, ray: &TriRay, block: &Tri4, count: usize, t_min: f32, lim: f32) -> (u32, LeafHits) {
        let mut hits = [[0.0; LANES]; 4];
        let mask = leaf_scalar(ray, block, (1 << count) - 1, t_min, lim, &mut hits);
        (mask, hits)
    }
}

/// The AVX2 kernel (its token comes from [`Avx2Kernel`](super::avx2::Avx2Kernel), which checks the
/// CPU): the portable kernel's operations on all eight children at once, and on the four triangles
/// of a leaf in SSE. `vmaxps`/`vminps` return their second operand when either is NaN, which is the
/// portable kernel's `if a > t0 { a } else { t0 }`, so both give the same bits.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(super) struct Avx2Wide;

/// Per-ray constants of [`Avx2Wide`]: each broadcast to eight lanes, and the offsets (in `f32`s from
/// the node's start) of the near and far planes of each axis, picked by the direction's signs.
#[cfg(target_arch = "x86_64")]
pub(super) struct Avx2WideRay {
    origin: [core::arch::x86_64::__m256; 3],
    inv_dir: [core::arch::x86_64::__m256; 3],
    near: [usize; 3],
    far: [usize; 3],
    t_min: core::arch::x86_64::__m256,
}

/// Per-ray constants of [`Avx2Wide`]'s leaf test: the origin's and the shear's components (in
/// [`TriRay::sheared`]'s order: `kx`, `ky`, `kz`) broadcast to four lanes, and the offsets (in
/// `f32`s from a vertex's rows) of the rows `kx`, `ky`, `kz`.
#[cfg(target_arch = "x86_64")]
pub(super) struct Avx2LeafRay {
    tri: TriRay,
    origin: [core::arch::x86_64::__m128; 3],
    shear: [core::arch::x86_64::__m128; 3],
    rows: [usize; 3],
}

#[cfg(target_arch = "x86_64")]
impl WideKernel for Avx2Wide {
    type Ray = Avx2WideRay;
    type LeafRay = Avx2LeafRay;

    #[inline(always)]
    fn prepare_leaf(self, ray: TriRay) -> Avx2LeafRay {
        use core::arch::x86_64::_mm_set1_ps;
        let axes = ray.axes;
        // SAFETY: SSE is part of the x86-64 baseline; these intrinsics only touch registers.
        unsafe {
            Avx2LeafRay {
                origin: axes.map(|k| _mm_set1_ps(ray.origin[k])),
                shear: ray.shear.map(|s| _mm_set1_ps(s)),
                rows: axes.map(|k| LANES * k),
                tri: ray,
            }
        }
    }

    #[inline(always)]
    fn prepare(self, origin: Vec3A, direction: Vec3A, t_min: f32) -> Avx2WideRay {
        use core::arch::x86_64::_mm256_set1_ps as _mm_set1_ps;
        let inv = Vec3A::ONE / direction;
        let lo = |k: usize| WIDTH * k;
        let hi = |k: usize| WIDTH * (3 + k);
        // `if_negative` when the direction's component `k` is negative (−0 included), else `other`.
        let pick = |k: usize, if_negative: usize, other: usize| {
            if direction[k].is_sign_negative() {
                if_negative
            } else {
                other
            }
        };
        // SAFETY: the token proves AVX2; these intrinsics only touch registers.
        unsafe {
            Avx2WideRay {
                origin: [
                    _mm_set1_ps(origin.x),
                    _mm_set1_ps(origin.y),
                    _mm_set1_ps(origin.z),
                ],
                inv_dir: [_mm_set1_ps(inv.x), _mm_set1_ps(inv.y), _mm_set1_ps(inv.z)],
                near: [
                    pick(0, hi(0), lo(0)),
                    pick(1, hi(1), lo(1)),
                    pick(2, hi(2), lo(2)),
                ],
                far: [
                    pick(0, lo(0), hi(0)),
                    pick(1, lo(1), hi(1)),
                    pick(2, lo(2), hi(2)),
                ],
                t_min: _mm_set1_ps(t_min),
            }
        }
    }

    #[inline(always)]
    fn test(self, ray: &Avx2WideRay, node: &WideNode, t_far: f32) -> (u32, [f32; WIDTH]) {
        use core::arch::x86_64::{
            _CMP_LE_OQ, _mm256_add_ps, _mm256_and_ps, _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_load_ps,
            _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_set1_epi32,
            _mm256_set1_ps, _mm256_storeu_ps, _mm256_sub_ps,
        };
        // SAFETY: the token proves AVX2. `near`/`far` are offsets of 32-byte aligned rows of eight
        // `f32` inside the 64-byte aligned, 256-byte node (at most 40 + 8 ≤ 48 of its 64 words), so
        // every aligned load is in bounds.
        unsafe {
            let p = (node as *const WideNode).cast::<f32>();
            let mut t0 = ray.t_min;
            let mut t1 = _mm256_set1_ps(t_far);
            for k in 0..3 {
                let a = _mm256_mul_ps(
                    _mm256_sub_ps(_mm256_load_ps(p.add(ray.near[k])), ray.origin[k]),
                    ray.inv_dir[k],
                );
                let b = _mm256_mul_ps(
                    _mm256_sub_ps(_mm256_load_ps(p.add(ray.far[k])), ray.origin[k]),
                    ray.inv_dir[k],
                );
                t0 = _mm256_max_ps(a, t0);
                t1 = _mm256_min_ps(b, t1);
            }
            let abs = _mm256_and_ps(t1, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff)));
            let t1 = _mm256_add_ps(t1, _mm256_mul_ps(abs, _mm256_set1_ps(FAR_PAD)));
            let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32;
            let mut entry = [0.0f32; WIDTH];
            _mm256_storeu_ps(entry.as_mut_ptr(), t0);
            (mask, entry)
        }
    }

    /// The scalar test's operations, in its order, on four lanes: the shear
    /// ([`TriRay::sheared`]: `A[kx] − Sx·A[kz]`, `A[ky] − Sy·A[kz]`, `Sz·A[kz]`, the axes picked
    /// by the ray, so the rows are loaded straight from the block), the edge functions, their
    /// signs, `det = (e0 + e1) + e2`, `t = ((e0·az + e1·bz) + e2·cz)/det`, `u = e1/det`,
    /// `v = e2/det`. The divisions are skipped when no lane is inside all three edges (most leaf
    /// tests). A lane with an edge function exactly zero and no two others of opposite signs goes
    /// through the scalar test (it redoes the edges in `f64`).
    #[inline(always)]
    fn leaf(self, ray: &Avx2LeafRay, block: &Tri4, count: usize, t_min: f32, lim: f32) -> (u32, LeafHits) {
        use core::arch::x86_64::{
            __m128, _mm_add_ps, _mm_and_ps, _mm_cmpeq_ps, _mm_cmpgt_ps, _mm_cmplt_ps, _mm_cmpneq_ps,
            _mm_div_ps, _mm_load_ps, _mm_movemask_ps, _mm_mul_ps, _mm_or_ps, _mm_set1_ps, _mm_setzero_ps,
            _mm_storeu_ps, _mm_sub_ps,
        };
        let lanes = (1u32 << count) - 1;
        let mut hits = [[0.0; LANES]; 4];
        let [kx, ky, kz] = ray.rows;
        debug_assert!(kx <= 2 * LANES && ky <= 2 * LANES && kz <= 2 * LANES);
        // SAFETY: SSE is part of the x86-64 baseline; `block` is 16-byte aligned and every row of
        // four `f32` in it is too; the row offsets are `LANES·k` with `k < 3` (`TriRay::new` makes
        // the axes so), so every row pointer is inside the vertex's three rows.
        unsafe {
            let [ox, oy, oz] = ray.origin;
            let [sx, sy, sz] = ray.shear;
            let sheared = |j: usize| -> [__m128; 3] {
                let v = block.v.as_ptr().add(j).cast::<f32>();
                let x = _mm_sub_ps(_mm_load_ps(v.add(kx)), ox);
                let y = _mm_sub_ps(_mm_load_ps(v.add(ky)), oy);
                let z = _mm_sub_ps(_mm_load_ps(v.add(kz)), oz);
                [
                    _mm_sub_ps(x, _mm_mul_ps(sx, z)),
                    _mm_sub_ps(y, _mm_mul_ps(sy, z)),
                    _mm_mul_ps(sz, z),
                ]
            };
            let (a, b, cc) = (sheared(0), sheared(1), sheared(2));
            let e0 = _mm_sub_ps(_mm_mul_ps(cc[0], b[1]), _mm_mul_ps(cc[1], b[0]));
            let e1 = _mm_sub_ps(_mm_mul_ps(a[0], cc[1]), _mm_mul_ps(a[1], cc[0]));
            let e2 = _mm_sub_ps(_mm_mul_ps(b[0], a[1]), _mm_mul_ps(b[1], a[0]));
            let zero = _mm_setzero_ps();
            let any_zero = _mm_or_ps(
                _mm_or_ps(_mm_cmpeq_ps(e0, zero), _mm_cmpeq_ps(e1, zero)),
                _mm_cmpeq_ps(e2, zero),
            );
            let neg = _mm_or_ps(
                _mm_or_ps(_mm_cmplt_ps(e0, zero), _mm_cmplt_ps(e1, zero)),
                _mm_cmplt_ps(e2, zero),
            );
            let pos = _mm_or_ps(
                _mm_or_ps(_mm_cmpgt_ps(e0, zero), _mm_cmpgt_ps(e1, zero)),
                _mm_cmpgt_ps(e2, zero),
            );
            // Two nonzero edge functions of opposite signs are final (the `f64` redo keeps the sign
            // of a nonzero `f32` one), so those lanes miss whatever the zero ones become.
            let mixed = _mm_movemask_ps(_mm_and_ps(neg, pos)) as u32;
            let exact = _mm_movemask_ps(any_zero) as u32 & lanes & !mixed;
            let inside = lanes & !mixed & !exact;
            let mut mask = 0;
            if inside != 0 {
                let det = _mm_add_ps(_mm_add_ps(e0, e1), e2);
                let t = _mm_div_ps(
                    _mm_add_ps(
                        _mm_add_ps(_mm_mul_ps(e0, a[2]), _mm_mul_ps(e1, b[2])),
                        _mm_mul_ps(e2, cc[2]),
                    ),
                    det,
                );
                let ok = _mm_and_ps(
                    _mm_cmpneq_ps(det, zero),
                    _mm_and_ps(
                        _mm_cmpgt_ps(t, _mm_set1_ps(t_min)),
                        _mm_cmplt_ps(t, _mm_set1_ps(lim)),
                    ),
                );
                mask = _mm_movemask_ps(ok) as u32 & inside;
                if mask != 0 {
                    _mm_storeu_ps(hits[0].as_mut_ptr(), t);
                    _mm_storeu_ps(hits[1].as_mut_ptr(), _mm_div_ps(e1, det));
                    _mm_storeu_ps(hits[2].as_mut_ptr(), _mm_div_ps(e2, det));
                    _mm_storeu_ps(hits[3].as_mut_ptr(), det);
                }
            }
            if exact != 0 {
                mask |= leaf_scalar(&ray.tri, block, exact, t_min, lim, &mut hits);
            }
            (mask, hits)
        }
    }
}

/// Asks the CPU to start loading the cache lines of `value` (a hint: no effect on results; a no-op
/// off x86-64).
#[inline(always)]
pub(super) fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let p = (value as *const T).cast::<i8>();
        // SAFETY: prefetching is a hint and never faults; SSE is part of the x86-64 baseline.
        unsafe {
            _mm_prefetch::<_MM_HINT_T0>(p);
            if size_of::<T>() > 64 {
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64));
            }
            if size_of::<T>() > 128 {
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(128));
            }
            if size_of::<T>() > 192 {
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(192));
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

/// Stack-based traversal of `tree` over `[t_min, t_far]` (`t_min` is in `ray`): at each node the
/// children the ray enters are visited nearest entry first (the others wait on the stack, and are
/// dropped when popped if a hit has since moved `t_far` in front of them); `leaf` may stop the
/// traversal. Any-hit visitors ([`LeafVisitor::ANY_HIT`]) stop at the first hit, so for them the
/// children are taken in index order, unsorted.
#[inline(always)]
pub(super) fn traverse<K: WideKernel, L: LeafVisitor>(
    tree: &WideTree,
    kernel: K,
    ray: &K::Ray,
    t_far: f32,
    leaf: &mut L,
) {
    if tree.nodes.is_empty() {
        return;
    }
    let mut t_far = t_far;
    // Uninitialised: zeroing 2.7 kB per ray cost 4 % of an incoherent ray's time. Entries below
    // `sp` are always written before they are read.
    let mut stack = [core::mem::MaybeUninit::<(u32, u32, f32)>::uninit(); WIDE_STACK];
    let mut sp = 0usize;
    // (child, meta) of the node being visited: the root is interior node 0.
    let (mut child, mut meta) = (0u32, 0u32);
    loop {
        if meta == 0 {
            let node = &tree.nodes[child as usize];
            let (mask, entry) = kernel.test(ray, node, t_far);
            if mask != 0 {
                let first = mask.trailing_zeros() as usize;
                let rest = mask & (mask - 1);
                if rest == 0 {
                    (child, meta) = (node.child[first], node.meta[first]);
                    continue;
                }
                // Starts fetching a child that waits on the stack while the nearest is visited: an
                // incoherent ray's time is mostly these cache misses (without it, incoherent rays
                // take 12 % longer).
                let fetch = |c: usize| {
                    if node.meta[c] == 0 {
                        prefetch(&tree.nodes[node.child[c] as usize]);
                    } else {
                        leaf.prefetch(node.child[c] as usize);
                    }
                };
                if L::ANY_HIT {
                    // Any hit ends the query, so the order does not matter: the first child is
                    // visited, the others wait in index order (`t_far` never shrinks, so none is
                    // dropped when popped).
                    let mut bits = rest;
                    while bits != 0 {
                        let c = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        fetch(c);
                        stack[sp].write((node.child[c], node.meta[c], entry[c]));
                        sp += 1;
                    }
                    (child, meta) = (node.child[first], node.meta[first]);
                    continue;
                }
                if rest & (rest - 1) == 0 {
                    // Two children (the most frequent case after one): the nearer is visited, the
                    // other waits.
                    let second = rest.trailing_zeros() as usize;
                    let (near, far) = if entry[second] < entry[first] {
                        (second, first)
                    } else {
                        (first, second)
                    };
                    fetch(far);
                    stack[sp].write((node.child[far], node.meta[far], entry[far]));
                    sp += 1;
                    (child, meta) = (node.child[near], node.meta[near]);
                    continue;
                }
                // Three or more: sort by entry (farthest first), push all but the nearest.
                let mut hits = [(0.0f32, 0usize); WIDTH];
                let mut n = 0;
                let mut bits = mask;
                while bits != 0 {
                    let c = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let mut j = n;
                    while j > 0 && hits[j - 1].0 < entry[c] {
                        hits[j] = hits[j - 1];
                        j -= 1;
                    }
                    hits[j] = (entry[c], c);
                    n += 1;
                }
                for &(t, c) in &hits[..n - 1] {
                    fetch(c);
                    stack[sp].write((node.child[c], node.meta[c], t));
                    sp += 1;
                }
                let c = hits[n - 1].1;
                (child, meta) = (node.child[c], node.meta[c]);
                continue;
            }
        } else if leaf.visit(child as usize, (meta & !LEAF) as usize, &mut t_far) {
            return;
        }
        // Pop the next pending child still in front of `t_far`.
        let limit = pad_far(t_far);
        loop {
            if sp == 0 {
                return;
            }
            sp -= 1;
            // SAFETY: every entry below the stack pointer was written by a push.
            let (c, m, t) = unsafe { stack[sp].assume_init() };
            if t <= limit {
                (child, meta) = (c, m);
                break;
            }
        }
    }
}
