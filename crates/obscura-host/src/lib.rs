//! # obscura-host
//!
//! The host side of the projection contract, shared by every Obscura job that makes camera rays
//! (`obscura rays`, `obscura stmap`, `obscura check`, the renderer):
//!
//! - [`camera`]: a camera description (format, screen and crop windows, shutter, clipping, camera
//!   motion, aperture and shutter-opening descriptions) and the raster → screen mapping;
//! - [`sampler`]: Owen-scrambled Sobol pixel, lens and time samples;
//! - [`aperture`]: the aperture warp of lens samples into `[−1, 1]²` (bokeh shape, density, anamorphic);
//! - [`shutter`]: the shutter-opening warp of time samples;
//! - [`distribution`]: the tabulated 1-D distribution (built from weights, sampled by inverse CDF) behind
//!   the aperture and shutter warps and the renderer's dome-light importance sampling;
//! - [`driver`]: the camera stage — fills a batch, pre-fills the renderer's default rays, calls
//!   `project`, validates every ray and culls what breaks the contract, counting it;
//! - [`raymap`]: the per-pixel ray map written by `obscura rays`;
//! - [`stmap`]: the ST-map between two projections written by `obscura stmap` (Nuke's convention);
//! - [`plugins`]: finding and loading projection plugins from shared libraries (the C ABI of
//!   `include/obscura/projection.h`) into a [`obscura_sdk::Registry`];
//! - [`listing`]: the text of `obscura plugins`;
//! - [`cli_params`]: reading `--param` arguments against a projection's table.

pub mod aperture;
pub mod camera;
pub mod cli_params;
pub mod distribution;
pub mod driver;
pub mod listing;
pub mod plugins;
pub mod raymap;
pub mod sampler;
pub mod shutter;
pub mod stmap;

pub use camera::{CameraDesc, CameraError, CropWindow, PixelRect};
pub use driver::{Batch, CameraStage, ContractReport, HostError, Violation};
