//! Cross-camera correspondences: for each pixel of camera A, where the surface point it sees lands in
//! camera B, and whether B sees it.
//!
//! Both cameras look at one scene at one time (a rig: each camera its own projection and pose, the
//! objects shared). For pixel `(i, j)` of A, its chief ray through the centre `(i + ½, j + ½)` (lens
//! centre, canonical time `τ`, at the time A's projection gives it) is traced with A's tracer; the
//! point `P` it hits is carried in its object's space, `P_o = M(t_A)⁻¹·P`, and seen through B with
//! [`super::reproject::locate`]: `target = s_B`, the fixed point
//! `s_B = unproject_B(C_B(t_B)⁻¹·M(t_B)·P_o, t_B)` with `t_B` B's time for `s_B` (exact through B's
//! inverse and pose, each at its own row time), and
//!
//! | status | meaning |
//! |---|---|
//! | 0 | B sees the point at `target` |
//! | 1 | occluded in B (the chief ray of B through `target` hits something else first, [`super::OCCLUSION_TOLERANCE`]) |
//! | 2 | outside B's image (`target` kept) |
//! | 3 | outside B's projection domain (`target` NaN) |
//! | 4 | A's ray hit nothing or was culled (`target` NaN) |
//!
//! # File
//!
//! [`Correspondences::write_npz`] writes `correspondences/<A>__<B>/<frame>.npz`: `target` (`float32`,
//! H×W×2, raster pixels in B: x right, y down, the top-left pixel's centre at (0.5, 0.5)) and `status`
//! (`uint8`, H×W), with H×W A's image size.

use std::path::Path;

use obscura_render::flow::{FlowTarget, ObjectPoint};
use obscura_render::render::Prepared;
use obscura_scene::Scene;
use rayon::prelude::*;

use super::AnnotateError;
use super::npz::{Array, write_npz};
use super::reproject::{Status, locate};

/// Correspondences from every pixel of camera A to camera B (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct Correspondences {
    /// A's image width.
    pub width: u32,
    /// A's image height.
    pub height: u32,
    /// Raster position in B of each pixel of A, row by row (NaN with status 3 and 4).
    pub target: Vec<[f32; 2]>,
    /// Status of each pixel.
    pub status: Vec<Status>,
}

/// The correspondences from every pixel of `a` (camera A's prepared frame) to `b` (camera B's, of
/// `scene_b`: the same objects in the same order) at canonical time sample `time_sample`.
///
/// # Errors
/// [`AnnotateError::Render`] for a singular camera transform; [`AnnotateError::Mismatch`] when the two
/// scenes do not have the same objects.
pub fn correspond(
    a: &Prepared,
    b: &Prepared,
    scene_b: &Scene,
    time_sample: f32,
) -> Result<Correspondences, AnnotateError> {
    let motion = FlowTarget::new(scene_b, time_sample)?;
    if motion.object_count() != a.ids().instance_count() {
        return Err(AnnotateError::Mismatch(format!(
            "camera A's scene has {} objects, camera B's {}: a rig's cameras need the same objects",
            a.ids().instance_count(),
            motion.object_count()
        )));
    }
    let format = a.stage().camera().format;
    let (w, h) = (format.width, format.height);
    let rows: Vec<(Vec<[f32; 2]>, Vec<Status>)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let rasters: Vec<(f64, f64)> = (0..w).map(|x| (x as f64 + 0.5, y as f64 + 0.5)).collect();
            let hits: Vec<Option<ObjectPoint>> = a
                .trace_chief(&rasters, time_sample)
                .into_iter()
                .map(|r| r.and_then(|r| r.hit).map(|h| h.object))
                .collect();
            let points: Vec<ObjectPoint> = hits.iter().flatten().copied().collect();
            let mut seen = locate(b, &motion, &points, true).into_iter();
            let mut target = Vec::with_capacity(w as usize);
            let mut status = Vec::with_capacity(w as usize);
            for hit in &hits {
                match hit.and_then(|_| seen.next()) {
                    Some(l) => {
                        target.push([l.raster[0] as f32, l.raster[1] as f32]);
                        status.push(l.status);
                    }
                    None => {
                        target.push([f32::NAN; 2]);
                        status.push(Status::NoSurface);
                    }
                }
            }
            (target, status)
        })
        .collect();
    let mut out = Correspondences {
        width: w,
        height: h,
        target: Vec::with_capacity((w * h) as usize),
        status: Vec::with_capacity((w * h) as usize),
    };
    for (t, s) in rows {
        out.target.extend(t);
        out.status.extend(s);
    }
    Ok(out)
}

impl Correspondences {
    /// Writes the `.npz` of the module documentation to `path`, atomically.
    ///
    /// # Errors
    /// [`AnnotateError::Write`] naming the file.
    pub fn write_npz(&self, path: &Path) -> Result<(), AnnotateError> {
        let (h, w) = (self.height as usize, self.width as usize);
        let target: Vec<f32> = self.target.iter().flatten().copied().collect();
        let status: Vec<u8> = self.status.iter().map(|s| *s as u8).collect();
        write_npz(
            path,
            &[
                Array::f32("target", &[h, w, 2], &target),
                Array::u8("status", &[h, w], &status),
            ],
        )?;
        Ok(())
    }
}
