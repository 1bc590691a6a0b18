//! # obscura-calibration
//!
//! Render through a real camera's calibration: the camera models of COLMAP, OpenCV, Kalibr, OCamCalib,
//! NVIDIA's f-theta and 3DEqualizer's lens-distortion models ([`lens3de`]) as one Obscura projection,
//! `CalibratedCamera`, exact in both directions, a lens given only as an ST-map ([`stmap`]:
//! `StMapCamera`), and readers for the calibration files those tools write (with Nuke scripts'
//! `LD_3DE*` nodes and 3DE's lens export).

#![forbid(unsafe_code)]

pub mod files;

mod distortion;
pub mod lens3de;
mod lift;
pub mod models;
pub mod projection;
mod solve;
pub mod stmap;
#[cfg(test)]
mod tests;

pub use models::{CameraModel, MODEL_NAMES, MODELS, ModelInfo, PixelConvention, PixelRay, model_info};
pub use projection::{CalibratedCamera, CalibratedCameraFactory};

/// The name scenes use for the calibrated-camera projection.
pub const NAME: &str = "CalibratedCamera";
