//! Annotations that stay exact through any camera: 2D and 3D boxes per object and instance
//! ([`boxes`]), point tracks ([`tracks`]) and cross-camera correspondences ([`correspondences`]).
//!
//! # Conventions
//!
//! - **Raster positions** are in pixels of the full image (the format, not a crop window): x right,
//!   y down, the top-left pixel's centre at (0.5, 0.5), so pixel `(i, j)` covers `[i, i+1] × [j, j+1]`.
//!   A box `[x, y, w, h]` is in the same units (COCO's convention).
//! - **IDs** are the renderer's ([`obscura_render::truth`]): `instanceId = index in the scene's
//!   objects + 1`, `objectId` numbers object names from 1; 0 is the background.
//! - **Time.** Every point is seen at the time the projection gives the raster position it lands on,
//!   for a canonical time sample `τ` (0, shutter open, unless the caller says otherwise): a rolling
//!   shutter sees each point at its own row time. The position `s` is the fixed point
//!   `s = unproject(C(t(s))⁻¹·M(t(s))·P_o, t(s))` with `P_o` the point in its object's space, `M` the
//!   object's motion, `C` the camera's and `t(s)` the projection's time for `s`: one function,
//!   [`obscura_render::render::Prepared::reproject`], shared with optical flow.
//! - **Status** of a point seen through a camera ([`Status`]): 0 visible, 1 occluded, 2 out of frame,
//!   3 outside the projection's domain, 4 (correspondences only) nothing hit in the source camera.
//!   Occlusion is decided by the renderer's own tracer ([`reproject::locate`]) with the tolerance
//!   [`OCCLUSION_TOLERANCE`].
//!
//! Files: [`boxes::coco_json`] (COCO-style JSON per frame), [`tracks::write_tracks_npz`] and
//! [`correspondences::Correspondences::write_npz`] (NumPy `.npz`, written by [`npz`]).

pub mod boxes;
pub mod correspondences;
pub mod npz;
pub mod reproject;
pub mod tracks;

pub use reproject::{OCCLUSION_TOLERANCE, Status};

/// Why an annotation could not be made or written.
#[derive(Debug, thiserror::Error)]
pub enum AnnotateError {
    /// The scene's motion could not be set up (a singular camera transform).
    #[error(transparent)]
    Render(#[from] obscura_render::render::RenderError),
    /// A file could not be written.
    #[error(transparent)]
    Write(#[from] obscura_image::atomic::AtomicWriteError),
    /// The inputs do not fit together (the message says which and why).
    #[error("{0}")]
    Mismatch(String),
}
