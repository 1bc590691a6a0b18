//! The hierarchy's storage: axis-aligned boxes, the 32-byte [`Node`], the 64-byte [`NodePair`] that
//! keeps two siblings on one cache line, and the packed [`Tree`] (root, then sibling pairs).

use glam::Vec3A;

/// An axis-aligned box; empty when `lo > hi` on some axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Aabb {
    pub(super) lo: Vec3A,
    pub(super) hi: Vec3A,
}

impl Aabb {
    /// The empty box: growing it by anything gives that thing.
    pub(super) const EMPTY: Self = Self {
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
    };

    /// Grows to enclose `other`.
    #[inline]
    pub(super) fn grow(&mut self, other: &Self) {
        self.lo = self.lo.min(other.lo);
        self.hi = self.hi.max(other.hi);
    }

    /// Grows to enclose `p`.
    #[inline]
    pub(super) fn grow_point(&mut self, p: Vec3A) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }

    /// Half the surface area; zero for an empty box. In `f64`: a box reaching toward `f32::MAX`
    /// (`Sphere 3e38`) has extents and areas `f32` cannot hold, and an infinite area would make every
    /// split cost the same (∞), so the builder would find none.
    #[inline]
    pub(super) fn half_area(&self) -> f64 {
        let e = (self.hi.as_dvec3() - self.lo.as_dvec3()).max(glam::DVec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// The centre, `lo/2 + hi/2`: unlike `(lo + hi)/2` it cannot overflow for finite corners.
    #[inline]
    pub(super) fn centre(&self) -> Vec3A {
        self.lo * 0.5 + self.hi * 0.5
    }

    /// True when both corners are finite (an empty box is not).
    pub(super) fn is_finite(&self) -> bool {
        self.lo.is_finite() && self.hi.is_finite()
    }

    /// The box grown by `pad` on every side.
    pub(super) fn padded(&self, pad: f32) -> Self {
        Self {
            lo: self.lo - Vec3A::splat(pad),
            hi: self.hi + Vec3A::splat(pad),
        }
    }

    /// The eight corners; bit 0 of the index picks `hi.x`, bit 1 `hi.y`, bit 2 `hi.z`.
    pub(super) fn corners(&self) -> [Vec3A; 8] {
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
pub(super) struct Node {
    pub(super) lo: [f32; 3],
    pub(super) first: u32,
    pub(super) hi: [f32; 3],
    pub(super) count: u32,
}

impl Node {
    /// A node over box `b`.
    pub(super) fn new(b: &Aabb, first: u32, count: u32) -> Self {
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
pub(super) struct NodePair(pub(super) [Node; 2]);

// The AVX2 kernel loads a pair as two 8-lane vectors: no padding, exact sizes.
const _: () = assert!(size_of::<Node>() == 32 && size_of::<NodePair>() == 64 && align_of::<NodePair>() == 64);

/// A built hierarchy: the root, then child pairs.
#[derive(Debug, Clone, Default)]
pub(super) struct Tree {
    pub(super) root: Node,
    pub(super) pairs: Vec<NodePair>,
}

impl Tree {
    /// Nodes in the tree, the root included.
    pub(super) fn node_count(&self) -> usize {
        1 + 2 * self.pairs.len()
    }

    /// The root's box; empty for an empty tree.
    pub(super) fn root_bounds(&self) -> Aabb {
        if self.root.count == 0 && self.pairs.is_empty() {
            return Aabb::EMPTY;
        }
        Aabb {
            lo: Vec3A::from_array(self.root.lo),
            hi: Vec3A::from_array(self.root.hi),
        }
    }

    /// The most primitives in one leaf.
    #[cfg(test)]
    pub(super) fn largest_leaf(&self) -> u32 {
        std::iter::once(self.root)
            .chain(self.pairs.iter().flat_map(|p| p.0))
            .map(|n| n.count)
            .max()
            .unwrap_or(0)
    }

    /// Depth of the deepest leaf (the root is depth 0).
    #[cfg(test)]
    pub(super) fn depth(&self) -> usize {
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
