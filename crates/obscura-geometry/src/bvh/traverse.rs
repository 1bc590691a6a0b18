//! Ray traversal: the ray/box-pair kernels behind [`BoxKernel`] (scalar here, AVX2 in `avx2`), the
//! [`LeafVisitor`] that decides what a leaf does, and the stack-based, near-child-first [`traverse`].

use glam::Vec3A;

use super::tree::{Node, NodePair, Tree};
use super::wide::{PortableWide, WideKernel};

/// Traversal stack entries. A node at depth `d` has at most `d` pending siblings on the stack; median
/// splits from the builder's `SAH_DEPTH_LIMIT` (40) on halve the primitive count (at most
/// `u32::MAX`) per level, so no leaf is deeper than `SAH_DEPTH_LIMIT + 33 = 73`.
pub(super) const STACK_SIZE: usize = 80;
/// Relative padding of a box's far distance; it covers the rounding of the slab test and of the
/// triangle test's `t` (Ize 2013 uses `2γ₃ ≈ 3.6e-7`).
pub(super) const FAR_PAD: f32 = 1e-6;

/// `x` grown by [`FAR_PAD`] of its magnitude (works for negative `x`; infinities stay put).
#[inline(always)]
pub(super) fn pad_far(x: f32) -> f32 {
    x + x.abs() * FAR_PAD
}

/// A ray/box-pair test. Implementations are zero-sized tokens: holding one proves that the CPU can
/// run it.
pub(super) trait BoxKernel: Copy {
    /// The per-ray constants the kernel precomputes.
    type Ray;
    /// Precomputes the per-ray constants for `[t_min, ..]`.
    fn prepare(self, origin: Vec3A, direction: Vec3A, t_min: f32) -> Self::Ray;
    /// Tests both boxes of `pair` against `[t_min, t_far]`. Returns a mask (bit 0: first child, bit 1:
    /// second) and the entry distances.
    fn test_pair(self, ray: &Self::Ray, pair: &NodePair, t_far: f32) -> (u32, f32, f32);
    /// The wide kernel of the same tier, for mesh hierarchies.
    type Wide: WideKernel;
    /// That kernel's token.
    fn wide(self) -> Self::Wide;
}

/// The portable kernel: Williams et al.'s slab test, one box at a time.
#[derive(Clone, Copy)]
pub(super) struct ScalarKernel;

/// The scalar kernel's per-ray constants (also the portable wide kernel's).
pub(super) struct ScalarBoxRay {
    pub(super) origin: [f32; 3],
    pub(super) inv_dir: [f32; 3],
    pub(super) negative: [bool; 3],
    pub(super) t_min: f32,
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
    type Wide = PortableWide;

    #[inline(always)]
    fn wide(self) -> PortableWide {
        PortableWide
    }

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

/// What a traversal does at a leaf. Implementations inline completely (`visit` is
/// `#[inline(always)]`), so inside an AVX2 entry point all of the traversal is AVX2 code.
pub(super) trait LeafVisitor {
    /// True when the first hit ends the query (any-hit): the wide traversal then skips ordering
    /// the children by distance.
    const ANY_HIT: bool = false;
    /// Tests primitives `first..first + count`; may shrink `t_far`; returns `true` to stop.
    fn visit(&mut self, first: usize, count: usize, t_far: &mut f32) -> bool;
    /// Hints that the leaf starting at `first` will be visited soon (the wide traversal calls it for
    /// leaves it puts on its stack); by default nothing.
    #[inline(always)]
    fn prefetch(&self, first: usize) {
        let _ = first;
    }
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
pub(super) fn traverse<K: BoxKernel, L: LeafVisitor>(
    tree: &Tree,
    kernel: K,
    ray: &K::Ray,
    t_far: f32,
    leaf: &mut L,
) {
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
