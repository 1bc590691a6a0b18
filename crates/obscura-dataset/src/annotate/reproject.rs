//! The shared piece of every annotation: object-space points seen through one camera, with their
//! status.
//!
//! [`locate`] takes surface points carried in their objects' spaces ([`ObjectPoint`]) through
//! [`Prepared::reproject`] (the renderer's exact inverse with the rolling-shutter fixed point, shared
//! with optical flow) and classifies each:
//!
//! 1. **outside the projection's domain** ([`Status::OutsideDomain`]) when `unproject` has no answer,
//!    the projection culls the ray at the position it gives, or the row-time fixed point does not
//!    converge; the position is NaN;
//! 2. **out of frame** ([`Status::OutOfFrame`]) when the position lies outside `[0, W] × [0, H]`; the
//!    position is kept;
//! 3. otherwise **visible** or **occluded**: the chief ray through the position (lens centre, the same
//!    canonical time, so the same row time) is traced by the renderer's tracer, seeing what camera rays
//!    see (one-sided objects, clipping planes, `visibility camera`). With `d = (P − o)·d̂` the point's
//!    distance along the ray (`P` the point in world space at the ray's time, `o`, `d̂` the ray's origin
//!    and direction), the point is visible when the ray hits at a distance `t` with
//!    `|t − d| ≤ OCCLUSION_TOLERANCE · d / max(|n̂·d̂|, 0.05)` (`n̂` the hit's geometric normal),
//!    occluded otherwise (something nearer, nothing at all — the back of a one-sided surface, a point
//!    beyond a clipping plane —, or a surface behind).
//!
//! The tolerance (10⁻³ of the distance, divided by the cosine of incidence since a surface offset
//! along its normal moves the hit along a grazing ray by the offset over that cosine) covers rounding
//! and the difference between two dicings of one smooth surface (a point found through camera A,
//! tested against camera B's tessellation); an occluder closer to the point than that is not seen as
//! one.

use glam::Vec3A;
use obscura_render::flow::{FlowTarget, ObjectPoint, Reprojection};
use obscura_render::render::Prepared;
use rayon::prelude::*;

/// Relative tolerance of the occlusion test: a point is visible when the chief ray through its
/// position hits within `OCCLUSION_TOLERANCE × distance` of it along the ray.
pub const OCCLUSION_TOLERANCE: f32 = 1e-3;

/// The smallest cosine of incidence the tolerance is divided by (20× at grazing rays).
const MIN_INCIDENCE: f32 = 0.05;

/// Points per parallel task.
const CHUNK: usize = 256;

/// What a camera sees of a point (the `status` arrays of tracks and correspondences, as `u8`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Status {
    /// In the frame and the nearest surface along its ray.
    Visible = 0,
    /// In the frame, behind another surface (or its own surface is not seen from this side).
    Occluded = 1,
    /// In the projection's domain but outside the image `[0, W] × [0, H]`.
    OutOfFrame = 2,
    /// Outside the projection's domain (no inverse, a culled ray, a row time that does not converge).
    OutsideDomain = 3,
    /// Correspondences only: the source camera's ray hit nothing (or was culled).
    NoSurface = 4,
}

/// A point seen through a camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Located {
    /// Raster position (NaN outside the domain).
    pub raster: [f64; 2],
    /// What the camera sees of it.
    pub status: Status,
    /// The shutter-normalised time it is seen at (NaN outside the domain).
    pub time: f32,
}

impl Located {
    /// A point outside the domain.
    pub const OUTSIDE: Located = Located {
        raster: [f64::NAN; 2],
        status: Status::OutsideDomain,
        time: f32::NAN,
    };
}

/// Each of `points` seen through `prepared`'s camera with the scene's motion `motion` (see the module
/// documentation). Without `occlusion` an in-frame point is reported [`Status::Visible`] without
/// tracing (boxes of the whole object need no visibility). Runs in parallel.
///
/// # Panics
/// When a point's instance is not one of `motion`'s objects.
#[must_use]
pub fn locate(
    prepared: &Prepared,
    motion: &FlowTarget,
    points: &[ObjectPoint],
    occlusion: bool,
) -> Vec<Located> {
    let format = prepared.stage().camera().format;
    let (w, h) = (format.width as f64, format.height as f64);
    points
        .par_chunks(CHUNK)
        .flat_map_iter(|chunk| {
            let seen = prepared.reproject(chunk, None, motion);
            let mut out: Vec<Located> = seen
                .iter()
                .map(|s| match *s {
                    Reprojection::Seen { raster, time } => Located {
                        raster: [raster.0, raster.1],
                        status: if (0.0..=w).contains(&raster.0) && (0.0..=h).contains(&raster.1) {
                            Status::Visible
                        } else {
                            Status::OutOfFrame
                        },
                        time,
                    },
                    Reprojection::OutsideDomain | Reprojection::NotConverged => Located::OUTSIDE,
                })
                .collect();
            if occlusion {
                occlude(prepared, motion, chunk, &mut out);
            }
            out
        })
        .collect()
}

/// Marks the in-frame points of `located` that the chief ray through their position does not reach
/// first as [`Status::Occluded`].
fn occlude(prepared: &Prepared, motion: &FlowTarget, points: &[ObjectPoint], located: &mut [Located]) {
    let in_frame: Vec<usize> = (0..located.len())
        .filter(|&i| located[i].status == Status::Visible)
        .collect();
    let rasters: Vec<(f64, f64)> = in_frame
        .iter()
        .map(|&i| (located[i].raster[0], located[i].raster[1]))
        .collect();
    let rays = prepared.trace_chief(&rasters, motion.time_sample());
    for (&i, ray) in in_frame.iter().zip(rays) {
        let Some(ray) = ray else {
            located[i] = Located::OUTSIDE;
            continue;
        };
        let p = points[i];
        let Some(to_world) = motion.object_to_world(p.instance, ray.time) else {
            located[i].status = Status::Occluded;
            continue;
        };
        let world: Vec3A = to_world.transform_point3a(p.position);
        let d = (world - ray.origin).dot(ray.direction);
        let visible = ray.hit.is_some_and(|hit| {
            let incidence = hit.normal.dot(ray.direction).abs().max(MIN_INCIDENCE);
            (hit.distance - d).abs() <= OCCLUSION_TOLERANCE * d.abs() / incidence
        });
        if !visible {
            located[i].status = Status::Occluded;
        }
    }
}
