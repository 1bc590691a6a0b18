//! Optical flow (motion vectors) for any camera, through the projection's exact inverse.
//!
//! # What a pixel's flow is
//!
//! Each pixel's reference is its **chief ray**: through the pixel centre `c`, from the lens centre
//! (aperture sample (0, 0)), at canonical time 0 (shutter open) — the main layer of `obscura rays`. The
//! projection may rewrite that time (a rolling shutter gives each line its own); call the ray's time
//! `t₀`. The ray is traced at `t₀`; the surface point `P` it hits is carried in its object's space,
//! `P_o = M(t₀)⁻¹·P` with `M` the instance's object-to-world motion.
//!
//! The same point seen at another time: `P(t) = M'(t)·P_o` with the target's object motion `M'`,
//! taken to the target's camera space `C'(t)⁻¹·P(t)` and through `unproject(·, t)` to a screen position,
//! then to raster space. The target time `t` is the time the projection gives the target pixel for the
//! target's canonical time (`τ = 1⁻`, the largest `f32` below 1, for shutter close; 0 for another
//! frame's shutter open): a fixed point `s = unproject(C'(t(s))⁻¹·M'(t(s))·P_o, t(s))`, iterated from the
//! reference position until the time stops changing (one step for a global shutter) or the position
//! moves less than 10⁻⁵ pixel (or, far outside the image, four `f32` steps of its distance from the
//! image centre, the precision of the screen coordinates), at most 16 steps.
//!
//! `flow = raster(target) − raster(unproject(C(t₀)⁻¹·P, t₀))`, in pixels, +x right, +y down. The
//! reference position goes through `unproject` as well (rather than being taken as `c`), so both ends
//! carry the same rounding and a static point has a flow of 0 to `f32` precision (10⁻⁶ pixel).
//!
//! `flowValid` is 0 where nothing was hit, where the reference or target position is outside the
//! projection's domain (`unproject` gives `None`, or the projection culls the target's ray), where the
//! target lies outside the image (the full format, `[0, W] × [0, H]`), and where the fixed point does
//! not converge. Occlusion at the target time does not invalidate a flow. A projection without
//! `unproject` gets a warning and no flow.

use std::time::Instant;

use glam::Vec3A;
use obscura_host::Batch;
use obscura_scene::Scene;
use obscura_sdk::{Point2, Vec3};
use rayon::prelude::*;

use obscura_geometry::motion::Motion;
use obscura_geometry::motion::{camera_motion, object_motion};
use obscura_geometry::ray::Tracer;
use obscura_image::samples::FlowPixel;

use crate::render::{Prepared, RenderError};

/// The canonical time sample of shutter close: the largest `f32` below 1 (times stay in `[0, 1)`).
pub const SHUTTER_CLOSE: f32 = 1.0 - f32::EPSILON / 2.0;

/// Steps of the target fixed point before a pixel is declared not converged.
const MAX_STEPS: usize = 16;

/// Raster distance below which the fixed point has converged.
const CONVERGED_PX: f64 = 1e-5;

/// The scene's motion at the other end of a flow: camera and objects over a shutter (the render's own
/// for shutter close, another frame's for a sequence), and the canonical time handed to the projection.
#[derive(Debug, Clone)]
pub struct FlowTarget {
    camera_to_world: Motion,
    objects: Vec<Motion>,
    time_sample: f32,
}

impl FlowTarget {
    /// The motion of `scene` (its camera and objects, in its own shutter-normalised time), seen at the
    /// canonical time `time_sample` ([`SHUTTER_CLOSE`] for this frame's close, 0 for another frame's
    /// open).
    ///
    /// # Errors
    /// [`RenderError::Camera`] when a camera transform is singular.
    pub fn new(scene: &Scene, time_sample: f32) -> Result<Self, RenderError> {
        let shutter = scene.camera.shutter;
        let camera_to_world = camera_motion(scene.camera.environment().world_to_camera(), shutter)
            .map_err(RenderError::Camera)?;
        let objects = scene
            .objects
            .iter()
            .map(|o| Motion::new(&object_motion(&o.transform.samples, shutter)))
            .collect();
        Ok(FlowTarget {
            camera_to_world,
            objects,
            time_sample,
        })
    }

    /// The canonical time sample handed to the projection.
    #[must_use]
    pub fn time_sample(&self) -> f32 {
        self.time_sample
    }

    /// Camera-to-world at shutter-normalised `time`.
    #[must_use]
    pub fn camera_to_world(&self, time: f32) -> glam::Affine3A {
        self.camera_to_world.object_to_world(time)
    }

    /// Object-to-world of instance `instance` (an index into the scene's objects) at shutter-normalised
    /// `time`; `None` when there is no such instance.
    #[must_use]
    pub fn object_to_world(&self, instance: u32, time: f32) -> Option<glam::Affine3A> {
        self.objects
            .get(instance as usize)
            .map(|m| m.object_to_world(time))
    }

    /// How many objects the target has: a sequence's frames must keep the same objects in the same
    /// order for flow to cross frames.
    #[must_use]
    pub fn object_count(&self) -> usize {
        self.objects.len()
    }
}

/// The flow pass's result.
#[derive(Debug, Clone)]
pub struct FlowOutput {
    /// One pixel per crop pixel, row by row.
    pub pixels: Vec<FlowPixel>,
    /// What the user should know (a projection without `unproject`).
    pub warnings: Vec<String>,
    /// Wall-clock seconds of the pass.
    pub seconds: f64,
}

/// A surface point carried in its object's space: the instance it lies on (an index into the scene's
/// objects, `instanceId − 1`) and its position in that instance's object space. Object motion carries
/// it to world space at any time: `P(t) = M(t)·position`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectPoint {
    /// Index of the instance in the scene's objects.
    pub instance: u32,
    /// Object-space position.
    pub position: Vec3A,
}

/// Where [`Prepared::reproject`] put a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reprojection {
    /// Seen through the projection at `raster` (pixels, x right, y down, the top-left pixel's centre at
    /// (0.5, 0.5); possibly outside the image) at shutter-normalised `time`, the time the projection
    /// gives that raster position (a rolling shutter's row time).
    Seen {
        /// Raster position.
        raster: (f64, f64),
        /// The time the point is seen at.
        time: f32,
    },
    /// Outside the projection's domain: `unproject` gives `None` (or a non-finite position), or the
    /// projection culls the ray at the position `unproject` gives.
    OutsideDomain,
    /// The fixed point between the position and the projection's time for it did not converge in 16
    /// steps.
    NotConverged,
}

/// A chief ray (lens centre, one raster position) taken to world space and traced: see
/// [`Prepared::trace_chief`].
#[derive(Debug, Clone, Copy)]
pub struct ChiefRay {
    /// The shutter-normalised time the projection gave the ray.
    pub time: f32,
    /// World-space origin.
    pub origin: Vec3A,
    /// World-space unit direction.
    pub direction: Vec3A,
    /// The nearest surface camera rays see along it, if any.
    pub hit: Option<ChiefHit>,
}

/// What a chief ray hit.
#[derive(Debug, Clone, Copy)]
pub struct ChiefHit {
    /// World-space distance from the ray's origin.
    pub distance: f32,
    /// World-space position.
    pub position: Vec3A,
    /// World-space geometric normal, unit length, facing the ray's origin.
    pub normal: Vec3A,
    /// Camera-space position, with the camera at the ray's time.
    pub camera_position: Vec3A,
    /// The point carried in its object's space (the instance's motion inverted at the ray's time).
    pub object: ObjectPoint,
}

/// Counts over the pass, for the warning.
#[derive(Debug, Default, Clone, Copy)]
struct Counts {
    hits: u64,
    no_inverse: u64,
}

impl Prepared {
    /// Computes each crop pixel's flow toward `forward` and `backward` (see the module documentation).
    /// Without a target that side stays invalid.
    #[must_use]
    pub fn flow(&self, forward: Option<&FlowTarget>, backward: Option<&FlowTarget>) -> FlowOutput {
        let start = Instant::now();
        let cam = self.stage().camera();
        let crop = cam.pixels();
        let mut warnings = Vec::new();
        let objects = self.ids().instance_count();
        fn usable<'t>(
            t: Option<&'t FlowTarget>,
            objects: usize,
            side: &str,
            warnings: &mut Vec<String>,
        ) -> Option<&'t FlowTarget> {
            t.filter(|t| {
                let same = t.object_count() == objects;
                if !same {
                    warnings.push(format!(
                        "warning: no {side} flow: that frame has {} objects, this one {objects}; flow needs the same objects in the same order",
                        t.object_count()
                    ));
                }
                same
            })
        }
        let forward = usable(forward, objects, "forward", &mut warnings);
        let backward = usable(backward, objects, "backward", &mut warnings);
        let rows: Vec<(Vec<FlowPixel>, Counts)> = (crop.y0..crop.y1)
            .into_par_iter()
            .map(|y| self.flow_row(y, forward, backward))
            .collect();
        let mut counts = Counts::default();
        let mut pixels = Vec::with_capacity(crop.len());
        for (row, c) in rows {
            pixels.extend(row);
            counts.hits += c.hits;
            counts.no_inverse += c.no_inverse;
        }
        if counts.hits > 0 && counts.no_inverse == counts.hits {
            warnings.push(format!(
                "warning: {} has no unproject (or it failed for every pixel): no flow (flowValid is 0)",
                self.stage().name()
            ));
        }
        FlowOutput {
            pixels,
            warnings,
            seconds: start.elapsed().as_secs_f64(),
        }
    }

    /// One row of the crop: the chief rays, their hits, and both targets.
    fn flow_row(
        &self,
        y: u32,
        forward: Option<&FlowTarget>,
        backward: Option<&FlowTarget>,
    ) -> (Vec<FlowPixel>, Counts) {
        let crop = self.stage().camera().pixels();
        let n = crop.width() as usize;
        let rasters: Vec<(f64, f64)> = (crop.x0..crop.x1)
            .map(|x| (x as f64 + 0.5, y as f64 + 0.5))
            .collect();
        let mut out = vec![FlowPixel::NONE; n];
        let mut counts = Counts::default();
        // (column, the point, its reference raster position)
        let mut tracked = Vec::with_capacity(n);
        for (column, chief) in self.trace_chief(&rasters, 0.0).into_iter().enumerate() {
            let Some(hit) = chief.and_then(|c| c.hit.map(|h| (c.time, h))) else {
                continue;
            };
            counts.hits += 1;
            let Some(reference) = self.unproject_raster(hit.1.camera_position, hit.0) else {
                counts.no_inverse += 1;
                continue;
            };
            tracked.push((column, hit.1.object, reference));
        }
        let points: Vec<ObjectPoint> = tracked.iter().map(|t| t.1).collect();
        let starts: Vec<(f64, f64)> = tracked.iter().map(|t| t.2).collect();
        let cam = self.stage().camera();
        let (w, h) = (cam.format.width as f64, cam.format.height as f64);
        for (target, forward) in [(forward, true), (backward, false)] {
            let Some(target) = target else { continue };
            let moved = self.reproject(&points, Some(&starts), target);
            for ((column, _, reference), m) in tracked.iter().zip(moved) {
                let Reprojection::Seen { raster: r, .. } = m else {
                    continue;
                };
                if !((0.0..=w).contains(&r.0) && (0.0..=h).contains(&r.1)) {
                    continue;
                }
                let flow = [(r.0 - reference.0) as f32, (r.1 - reference.1) as f32];
                let pixel = &mut out[*column];
                if forward {
                    pixel.forward = flow;
                    pixel.forward_valid = 1.0;
                } else {
                    pixel.backward = flow;
                    pixel.backward_valid = 1.0;
                }
            }
        }
        (out, counts)
    }

    /// The chief rays (lens centre) through the raster positions `rasters` (pixels, possibly outside the
    /// image) at canonical time `time_sample`, each at the time the projection gives it, taken to world
    /// space with the camera's motion and traced to the nearest surface camera rays see (one-sided
    /// objects, clipping planes and `visibility camera` as in the render). `None` where the projection
    /// culls the ray or the camera transform collapses it.
    #[must_use]
    pub fn trace_chief(&self, rasters: &[(f64, f64)], time_sample: f32) -> Vec<Option<ChiefRay>> {
        let cam = self.stage().camera();
        let mut batch = Batch::with_capacity(rasters.len());
        for r in rasters {
            batch.push(cam.raster_to_screen(r.0, r.1), Point2::new(0.5, 0.5), time_sample);
            batch.aperture.push(Point2::ZERO);
        }
        self.stage().run_prepared(&mut batch);
        (batch.rays.iter().zip(&batch.time))
            .map(|(ray, &time)| {
                if ray.is_culled() {
                    return None;
                }
                let world = self.world_ray(ray, time)?;
                let hit = self.accel().intersect_camera(&world.ray).map(|hit| {
                    let to_object = self.accel().instance_transform_at(hit.instance, time).inverse();
                    ChiefHit {
                        distance: hit.t,
                        position: hit.position,
                        normal: hit.geometric_normal,
                        camera_position: world.origin_cam + world.direction_cam * (hit.t / world.stretch),
                        object: ObjectPoint {
                            instance: hit.instance,
                            position: to_object.transform_point3a(hit.position),
                        },
                    }
                });
                Some(ChiefRay {
                    time,
                    origin: world.ray.origin,
                    direction: world.ray.direction,
                    hit,
                })
            })
            .collect()
    }

    /// `unproject` of a camera-space point at `time`, in raster coordinates.
    fn unproject_raster(&self, p: Vec3A, time: f32) -> Option<(f64, f64)> {
        let s = self
            .stage()
            .projection()
            .unproject(Vec3::new(p.x, p.y, p.z), time)?;
        let cam = self.stage().camera();
        (s.x.is_finite() && s.y.is_finite()).then(|| cam.screen_window().screen_to_raster(cam.format, s))
    }

    /// Where each of `points` is seen through this camera with the scene's motion `target` (its camera
    /// and objects) at the canonical time `target` carries: the fixed point of the module documentation,
    /// `s = unproject(C(t(s))⁻¹·M(t(s))·P_o, t(s))` with `t(s)` the time the projection gives the raster
    /// position `s`, iterated from `start` (one raster position per point; the image centre when
    /// `None`) until the time stops changing (one step for a global shutter) or the position moves less
    /// than 10⁻⁵ pixel (far outside the image: four `f32` steps of its distance from the centre), at
    /// most 16 steps. The position may lie outside the image; checking the frame is
    /// the caller's.
    ///
    /// This is the one place the renderer maps object-space points through a camera's exact inverse:
    /// flow, point tracks, boxes and cross-camera correspondences all use it.
    ///
    /// # Panics
    /// When `start` is given with another length than `points`, or a point's instance is not one of
    /// `target`'s objects.
    #[must_use]
    pub fn reproject(
        &self,
        points: &[ObjectPoint],
        start: Option<&[(f64, f64)]>,
        target: &FlowTarget,
    ) -> Vec<Reprojection> {
        let cam = self.stage().camera();
        let centre = (cam.format.width as f64 / 2.0, cam.format.height as f64 / 2.0);
        if let Some(start) = start {
            assert_eq!(start.len(), points.len(), "one start per point");
        }
        let mut out = vec![Reprojection::NotConverged; points.len()];
        let mut batch = Batch::with_capacity(points.len());
        // (index, current raster position, the time that position was computed for)
        let mut pending: Vec<(usize, (f64, f64), Option<f32>)> = (0..points.len())
            .map(|i| (i, start.map_or(centre, |s| s[i]), None))
            .collect();
        for _ in 0..MAX_STEPS {
            if pending.is_empty() {
                break;
            }
            batch.clear();
            for (_, r, _) in &pending {
                batch.push(
                    cam.raster_to_screen(r.0, r.1),
                    Point2::new(0.5, 0.5),
                    target.time_sample,
                );
                batch.aperture.push(Point2::ZERO);
            }
            self.stage().run_prepared(&mut batch);
            let mut next = Vec::with_capacity(pending.len());
            for (k, (i, r, previous)) in pending.into_iter().enumerate() {
                if batch.rays[k].is_culled() {
                    out[i] = Reprojection::OutsideDomain;
                    continue;
                }
                let time = batch.time[k];
                if previous == Some(time) {
                    out[i] = Reprojection::Seen { raster: r, time };
                    continue;
                }
                let p = points[i];
                let object = target.objects[p.instance as usize].object_to_world(time);
                let p_world = object.transform_point3a(p.position);
                let p_camera = target
                    .camera_to_world
                    .world_to_object(time)
                    .transform_point3a(p_world);
                let Some(moved) = self.unproject_raster(p_camera, time) else {
                    out[i] = Reprojection::OutsideDomain;
                    continue;
                };
                let step = (moved.0 - r.0).hypot(moved.1 - r.1);
                // f32 screen positions far outside the image are coarser than 10⁻⁵ px.
                let precision = 4.0
                    * f64::from(f32::EPSILON)
                    * (moved.0 - centre.0).abs().max((moved.1 - centre.1).abs());
                if previous.is_some() && step < CONVERGED_PX.max(precision) {
                    out[i] = Reprojection::Seen { raster: moved, time };
                } else {
                    next.push((i, moved, Some(time)));
                }
            }
            pending = next;
        }
        out
    }
}
