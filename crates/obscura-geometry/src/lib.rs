//! # obscura-geometry
//!
//! What the renderer traces against: the scene's surfaces as triangles and the accelerator that finds
//! the nearest one along a ray, at the ray's time.
//!
//! | module | job |
//! |---|---|
//! | [`ray`] | the ray, the hit, the [`ray::Tracer`] interface, triangle meshes |
//! | [`rng`] | the per-path random number generator |
//! | [`motion`] | transforms keyed in time (camera and instances), interpolated at a ray's time |
//! | [`dice`] | quadrics, patches, NURBS, curves, blobs and subdivision surfaces → triangles, at a rate from the dicing hint |
//! | [`bvh`] | binned-SAH BVH per mesh, and the two-level motion-blurred scene accelerator |
//!
//! It knows the scene description (`obscura-scene`) and nothing of shading or images: a scene reader's
//! staging (automatic framing, telling an interior) and the path tracer use the same intersector.

pub mod bvh;
pub mod dice;
pub mod motion;
pub mod ray;
pub mod rng;

#[cfg(test)]
pub(crate) mod testing;
