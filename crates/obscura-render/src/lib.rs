//! # obscura-render
//!
//! The renderer proper: the host that drives a projection the way RenderMan's document says and
//! turns the rays into pictures, frame by frame. Geometry (`obscura-geometry`), shading
//! (`obscura-shading`) and images and their files (`obscura-image`) are crates of their own; this one
//! joins them.
//!
//! | module | job |
//! |---|---|
//! | [`render`] | setup and the render loop: camera stage → world rays → trace → film |
//! | [`staging`] | what a scene file leaves out: the automatic camera, interiors, the default lights |
//! | [`sensor`] | the image sensor after the film: exposure, noise, raw mosaic, ISP, DNG |
//! | [`flow`] | optical flow through the projection's `unproject` |
//! | [`truth`] | the scene's object, instance and material IDs |
//! | [`metadata`], [`frame`] | per-frame camera JSON and ID sidecar; complete frames |
//! | [`pipeline`] | one frame from a scene to its files, for every front end, with a [`pipeline::Reporter`] |
//! | [`job`] | what `obscura render` changes in a scene, its displays, the checks before any work |
//! | [`limits`] | image size, memory, threads, samples and output files, checked before any work |
//! | [`sequence`] | frame selections (`--frames 1-24`) and each frame's output path |

pub mod flow;
pub mod frame;
pub mod job;
pub mod limits;
pub mod metadata;
pub mod pipeline;
pub mod render;
pub mod sensor;
pub mod sequence;
pub mod staging;
pub mod truth;
