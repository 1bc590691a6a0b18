//! # obscura-image
//!
//! Images and the files they go to: the film that accumulates samples, the pixel filters, and every
//! writer of the renderer and of the camera tools.
//!
//! | module | job |
//! |---|---|
//! | [`samples`] | what a camera sample carries besides colour: ground truth, and each pixel's flow |
//! | [`filter`], [`film`] | RenderMan's pixel filters; AOV accumulation into pixels |
//! | [`output`], [`deep`] | EXR, PNG and TIFF from a film; our own deep-scanline EXR writer |
//! | [`tiles`] | a frame split in a grid of tiles; stitching their EXRs and PNGs back (`obscura merge`) |
//! | [`atomic`] | the one way every output file is written: temporary file, sync, rename |
//! | [`raymap`], [`stmap`] | the per-pixel ray map of `obscura rays`; the ST-map of `obscura stmap` |
//!
//! It depends on neither the geometry nor the shading: writing an image does not link the path
//! tracer, and the camera tools (ray maps, ST-maps) use it with the camera stage alone.

pub mod atomic;
pub mod deep;
pub mod film;
pub mod filter;
pub mod output;
pub mod raymap;
pub mod samples;
pub mod stmap;
pub mod tiles;

#[cfg(test)]
pub(crate) mod testing;
