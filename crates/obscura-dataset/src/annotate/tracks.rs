//! Point tracks (TAP-Vid / Kubric style): surface points sampled on each object, followed through
//! every frame of a camera, exact through any projection with `unproject`.
//!
//! # Sampling
//!
//! [`TrackPoints::sample`] draws `N` points on each instance's surface, uniform by area, from the
//! triangles the render diced in the instance's object space: a triangle is chosen with probability
//! proportional to its area, then a point in it with barycentrics `(1 − √u, √u·(1 − v), √u·v)` for
//! `u, v` uniform in `[0, 1)`. The generator is PCG32 seeded by the seed and the instance index, so
//! the points are the same for the same scene, camera (the dicing rate depends on it) and seed. Each
//! point stays in its object's space (`local`) and moves with it.
//!
//! # Each frame
//!
//! [`track_frame`] sees every point through the frame's camera with the frame's motion
//! ([`super::reproject::locate`]): its raster position (each at its own row time under a rolling
//! shutter) and status 0 visible, 1 occluded, 2 out of frame, 3 outside the projection's domain.
//!
//! # File
//!
//! [`write_tracks_npz`] writes `tracks/<camera>.npz` with (N points, T frames):
//!
//! | array | dtype | shape | meaning |
//! |---|---|---|---|
//! | `points` | `float32` | N×T×2 | raster position, x right, y down, top-left pixel centre (0.5, 0.5); NaN when status is 3 |
//! | `status` | `uint8` | N×T | 0 visible, 1 occluded, 2 out of frame, 3 outside the domain |
//! | `object` | `uint32` | N | `objectId` of the point's object |
//! | `instance` | `uint32` | N | `instanceId` of the point's instance |
//! | `local` | `float32` | N×3 | the point in its instance's object space |
//! | `frames` | `int32` | T | the frame numbers, in the order of the T axis |

use std::path::Path;

use glam::Vec3A;
use obscura_geometry::rng::Rng;
use obscura_render::flow::{FlowTarget, ObjectPoint};
use obscura_render::render::Prepared;
use obscura_scene::Scene;

use super::AnnotateError;
use super::npz::{Array, write_npz};
use super::reproject::{Status, locate};

/// Surface points to track, each in its instance's object space.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TrackPoints {
    /// The points, instance by instance.
    pub points: Vec<ObjectPoint>,
    /// `objectId` of each point's object.
    pub object_ids: Vec<u32>,
}

impl TrackPoints {
    /// `per_object` points on each instance of `prepared`'s scene with a surface, uniform by area
    /// (see the module documentation); instances without triangles get none.
    #[must_use]
    pub fn sample(prepared: &Prepared, per_object: usize, seed: u64) -> TrackPoints {
        let mut out = TrackPoints::default();
        let ids = prepared.ids();
        for instance in 0..ids.instance_count() as u32 {
            let Some(mesh) = prepared.accel().instance_mesh(instance) else {
                continue;
            };
            let tri = |t: &[u32; 3]| {
                let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
                (a, b, c)
            };
            let mut cumulative = Vec::with_capacity(mesh.triangles.len());
            let mut total = 0.0f64;
            for t in &mesh.triangles {
                let (a, b, c) = tri(t);
                total += 0.5 * f64::from((b - a).cross(c - a).length());
                cumulative.push(total);
            }
            if !(total > 0.0 && total.is_finite()) {
                continue;
            }
            let mut rng = Rng::new(seed, u64::from(instance));
            let object_id = ids.ids(instance).0;
            for _ in 0..per_object {
                let pick = f64::from(rng.next_u32()) / f64::from(u32::MAX) * total;
                let k = cumulative
                    .partition_point(|&c| c < pick)
                    .min(cumulative.len() - 1);
                let (a, b, c) = tri(&mesh.triangles[k]);
                let su = rng.next_f32().sqrt();
                let v = rng.next_f32();
                let p: Vec3A = a * (1.0 - su) + b * (su * (1.0 - v)) + c * (su * v);
                out.points.push(ObjectPoint {
                    instance,
                    position: p,
                });
                out.object_ids.push(object_id);
            }
        }
        out
    }

    /// How many points.
    #[must_use]
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True without points.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

/// The tracks' positions and statuses in one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackFrame {
    /// Raster position of each point (NaN outside the domain).
    pub points: Vec<[f32; 2]>,
    /// Status of each point.
    pub status: Vec<Status>,
}

/// Every point of `tracks` seen through the frame `prepared` of `scene` at canonical time sample
/// `time_sample` (0: the chief ray's time, shutter open or a rolling shutter's row start).
///
/// # Errors
/// [`AnnotateError::Render`] for a singular camera transform; [`AnnotateError::Mismatch`] when the
/// scene has other objects than the points were sampled on.
pub fn track_frame(
    prepared: &Prepared,
    scene: &Scene,
    tracks: &TrackPoints,
    time_sample: f32,
) -> Result<TrackFrame, AnnotateError> {
    let motion = FlowTarget::new(scene, time_sample)?;
    if let Some(p) = tracks
        .points
        .iter()
        .find(|p| p.instance as usize >= motion.object_count())
    {
        return Err(AnnotateError::Mismatch(format!(
            "a track lies on instance {} but the frame's scene has {} objects: every frame needs the same objects in the same order",
            p.instance + 1,
            motion.object_count()
        )));
    }
    let located = locate(prepared, &motion, &tracks.points, true);
    Ok(TrackFrame {
        points: located
            .iter()
            .map(|l| [l.raster[0] as f32, l.raster[1] as f32])
            .collect(),
        status: located.iter().map(|l| l.status).collect(),
    })
}

/// Writes the tracks of `frames` (numbered `numbers`) to `path` as the `.npz` of the module
/// documentation.
///
/// # Errors
/// [`AnnotateError::Mismatch`] when a frame has another number of points than `tracks` or `numbers`
/// another length than `frames`; [`AnnotateError::Write`] naming the file.
pub fn write_tracks_npz(
    path: &Path,
    tracks: &TrackPoints,
    frames: &[TrackFrame],
    numbers: &[i32],
) -> Result<(), AnnotateError> {
    let (n, t) = (tracks.len(), frames.len());
    if numbers.len() != t {
        return Err(AnnotateError::Mismatch(format!(
            "{}: {t} frames of tracks but {} frame numbers",
            path.display(),
            numbers.len()
        )));
    }
    if let Some((i, f)) = frames
        .iter()
        .enumerate()
        .find(|(_, f)| f.points.len() != n || f.status.len() != n)
    {
        return Err(AnnotateError::Mismatch(format!(
            "{}: frame {} has {} track positions, the tracks have {n} points",
            path.display(),
            numbers[i],
            f.points.len()
        )));
    }
    let mut points = Vec::with_capacity(n * t * 2);
    let mut status = Vec::with_capacity(n * t);
    for i in 0..n {
        for f in frames {
            points.extend_from_slice(&f.points[i]);
            status.push(f.status[i] as u8);
        }
    }
    let local: Vec<f32> = tracks.points.iter().flat_map(|p| p.position.to_array()).collect();
    let instance: Vec<u32> = tracks.points.iter().map(|p| p.instance + 1).collect();
    write_npz(
        path,
        &[
            Array::f32("points", &[n, t, 2], &points),
            Array::u8("status", &[n, t], &status),
            Array::u32("object", &[n], &tracks.object_ids),
            Array::u32("instance", &[n], &instance),
            Array::f32("local", &[n, 3], &local),
            Array::i32("frames", &[t], numbers),
        ],
    )?;
    Ok(())
}
