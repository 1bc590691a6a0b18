//! # obscura-render
//!
//! Obscura's images from cameras: the renderer — the host that drives a projection the way RenderMan's
//! document says and turns the rays into pictures — and the camera's own maps (ray map, ST-map).
//!
//! | module | job |
//! |---|---|
//! | [`ray`] | the ray, the hit, the [`ray::Tracer`] interface, triangle meshes |
//! | [`rng`] | the per-path random number generator |
//! | [`dice`] | quadrics and subdivision surfaces → triangles, at a rate from the dicing hint |
//! | [`bvh`] | binned-SAH BVH per mesh, and the two-level motion-blurred scene accelerator |
//! | [`motion`] | transforms keyed in time (camera and instances), interpolated at a ray's time |
//! | [`material`], [`light`], [`integrator`] | shading: BSDFs, the four lights, the path tracer |
//! | [`texture`] | images as mip pyramids, filtered by each ray's footprint (EWA) |
//! | [`filter`], [`film`], [`output`], [`deep`] | pixel filters, AOV accumulation, EXR/PNG/deep EXR |
//! | [`atomic`] | the one way every output file is written: temporary file, sync, rename |
//! | [`render`] | the render loop: camera stage → world rays → trace → film |
//! | [`job`] | one `obscura render` from files to files |
//! | [`truth`], [`flow`], [`metadata`], [`frame`] | ground truth: both depths, camera-space P and N, IDs; optical flow through `unproject`; per-frame camera JSON and ID sidecar; complete frames |
//! | [`limits`] | image size, memory, threads, samples and output files, checked before any work |
//! | [`sequence`] | frame selections (`--frames 1-24`) and each frame's output path |
//! | [`raymap`], [`stmap`] | the per-pixel ray map of `obscura rays`; the ST-map of `obscura stmap` |

pub mod atomic;
pub mod bvh;
pub mod deep;
pub mod dice;
pub mod film;
pub mod filter;
pub mod flow;
pub mod frame;
pub mod integrator;
pub mod job;
pub mod light;
pub mod limits;
pub mod material;
pub mod metadata;
pub mod motion;
pub mod output;
pub mod ray;
pub mod raymap;
pub mod render;
pub mod rng;
pub mod sequence;
pub mod stmap;
pub mod texture;
pub mod truth;
