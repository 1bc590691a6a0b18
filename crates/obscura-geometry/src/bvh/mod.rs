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
//! An [`Instance`] carries object-to-world samples at shutter times in `[0, 1]`, interpolated by
//! [`Motion`](crate::motion::Motion) (scale and translation linearly, rotation by slerp). World rays
//! are moved into object space with the inverse transform *without* renormalising the direction, so
//! `t` means the same thing in both spaces. The top-level box of a moving instance is conservative
//! for that interpolation (the bound is derived in `scene`).
//!
//! # Files
//!
//! | module | holds |
//! |---|---|
//! | `tree` | boxes, the 32-byte node, the 64-byte node pair, the packed tree |
//! | `build` | the binned-SAH builder (sequential and on rayon's pool) |
//! | `traverse` | the ray/box-pair kernels (scalar; AVX2 in `avx2`) and the stack traversal |
//! | `triangle` | the watertight ray/triangle test, skipped triangles, world-space hit records |
//! | `mesh` | [`MeshBvh`]: one mesh's hierarchy, nearest hit and any hit |
//! | `scene` | [`SceneAccel`] and [`Instance`]: the two-level, motion-blurred accelerator |

#[cfg(target_arch = "x86_64")]
mod avx2;
mod build;
mod mesh;
mod scene;
#[cfg(test)]
mod tests;
mod traverse;
mod tree;
mod triangle;
mod wide;

pub use mesh::{BvhLayout, MeshBvh};
pub use scene::{Instance, SceneAccel};
