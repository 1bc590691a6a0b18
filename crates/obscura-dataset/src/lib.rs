//! Datasets for computer vision that stay exact through any lens.
//!
//! A dataset is a set of rendered frames, one or more cameras (a rig) each with its own projection,
//! and what a training tool needs beside the pixels: the cameras in the tool's own file format
//! (COLMAP, nerfstudio, gsplat/3DGUT, Obscura's `camera.json`), 2D and 3D boxes per object and
//! instance, point tracks and cross-camera correspondences. Every annotation goes through the camera's
//! exact inverse (`Projection::unproject`), so it is exact for fisheyes, calibrated lenses, panoramas
//! and plugins alike; an export that cannot be exact in a format says so in the file.

pub mod annotate;
pub mod export;
pub mod layout;
pub mod rig;
pub mod run;
