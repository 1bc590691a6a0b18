//! # obscura-host
//!
//! The host side of the projection contract, shared by every Obscura job that makes camera rays
//! (`obscura rays`, `obscura stmap`, the renderer), and light enough for a scene reader to use (no
//! plugin loading, no image files):
//!
//! - [`camera`]: a camera description (format, screen and crop windows, shutter, clipping, camera
//!   motion, aperture and shutter-opening descriptions) and the raster → screen mapping;
//! - [`sampler`]: Owen-scrambled Sobol pixel, lens and time samples;
//! - [`aperture`]: the aperture warp of lens samples into `[−1, 1]²` (bokeh shape, density, anamorphic);
//! - [`shutter`]: the shutter-opening warp of time samples;
//! - [`distribution`]: the tabulated 1-D distribution (built from weights, sampled by inverse CDF) behind
//!   the aperture and shutter warps and the renderer's dome-light importance sampling;
//! - [`registry`]: the projections a host knows by name ([`Registry`]), with each factory's lifecycle;
//! - [`contract`]: the host's half of the projection contract — asking a projection's properties with
//!   their defaults, the default rays a host pre-fills, calling `project` with a lost batch classed;
//! - [`driver`]: the camera stage — fills a batch, pre-fills the renderer's default rays, calls
//!   `project`, validates every ray and culls what breaks the contract, counting it (the rules
//!   themselves are [`obscura_sdk::contract`]).

#![forbid(unsafe_code)]

pub mod aperture;
pub mod camera;
pub mod contract;
pub mod distribution;
pub mod driver;
pub mod registry;
pub mod sampler;
pub mod shutter;

pub use camera::{CameraDesc, CameraError, CropWindow, PixelRect};
pub use driver::{Batch, CameraStage, ContractReport, HostError, SoaScratch, Violation};
pub use registry::{DuplicateName, Registry};
