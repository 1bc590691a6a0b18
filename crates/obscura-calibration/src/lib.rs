//! # obscura-calibration
//!
//! Render through a real camera's calibration: the camera models of COLMAP, OpenCV, Kalibr, OCamCalib
//! and NVIDIA's f-theta as one Obscura projection, `CalibratedCamera`, exact in both directions, and
//! readers for the calibration files those tools write.
