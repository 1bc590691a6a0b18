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
//! A mesh's hierarchy is built as a binary SAH tree and, by default ([`BvhLayout::Wide`]), stored
//! eight-wide: each 256-byte node holds its eight children's boxes coordinate by coordinate
//! (`lo.x[8], lo.y[8], … hi.z[8]`), so one ray/box slab test covers all eight with one AVX2
//! instruction per operation (detected at run time; without AVX2 a portable loop does the same
//! operations). The binary tree's SAH counts a leaf's cost in blocks of four triangles (what one leaf
//! test covers), so leaves come out full; it is collapsed by a dynamic programme over the SAH
//! (which binary nodes become wide nodes and which are opened into their parent's eight slots, for
//! the least total area of wide nodes), which divides the number of levels by up to three, and any
//! subtree of at most four triangles becomes one leaf whose triangles are packed coordinate by
//! coordinate (`Tri4`, 160 bytes) and go through the watertight test four lanes at once. Children are visited nearest entry first; those
//! waiting on the stack are prefetched, since an incoherent ray's time is mostly cache misses on
//! nodes and leaves; any-hit queries (shadow rays) stop at the first hit and so skip the ordering.
//!
//! The wide layout gives the same hits as the binary one bit for bit: the boxes are the binary
//! tree's, the slab test does the same operations in the same order (`maxps`/`minps` keep the NaN
//! rule of the scalar test), the SIMD triangle test repeats the scalar one's operations in its order
//! (a lane whose edge function is exactly zero is redone by the scalar test, which recomputes it in
//! `f64`), and ties in `t` go to the lowest triangle index whatever the visiting order.
//!
//! The binary layout ([`BvhLayout::Binary`], or `OBSCURA_BVH_LAYOUT=binary` for [`MeshBvh::build`])
//! is kept as the reference the benchmarks and tests compare against. Static objects placed once
//! are flattened into one world-space mesh hierarchy ([`SceneLayout::Flat`], the default; see
//! `scene`), so a ray pays no top level and no ray transform for them; the scene's top level over
//! the remaining instances (moving or shared meshes) stays binary: nodes are 32 bytes (`min`, child-or-first, `max`, count),
//! the two children of a node sit side by side in one 64-byte-aligned pair, and with AVX2 (detected
//! at run time) one `vpermps` per child selects the near and far planes by the ray's direction signs
//! so both boxes go through the slab test in one 8-lane register. Without AVX2 the same test runs in
//! scalar code, and the wide layout's portable kernels with it.
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
//! | `traverse` | the ray/box-pair kernels (scalar; AVX2 in `avx2`) and the binary stack traversal |
//! | `wide` | the eight-wide node and the four-triangle leaf block, the collapse, the eight-box and four-triangle kernels, the wide traversal |
//! | `triangle` | the watertight ray/triangle test, skipped triangles, world-space hit records |
//! | `mesh` | [`MeshBvh`]: one mesh's hierarchy, nearest hit and any hit |
//! | `scene` | [`SceneAccel`] and [`Instance`]: the two-level, motion-blurred accelerator; [`SceneLayout`] (static objects flattened into one world-space hierarchy) and [`RayVisibility`] |

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
pub use scene::{Instance, RayVisibility, SceneAccel, SceneLayout};
