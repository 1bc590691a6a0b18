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
//! moves less than 10⁻⁵ pixel, at most 16 steps.
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

/// A reference point on its way to a target: its object, its object-space position, its reference
/// raster position, and the iteration's state.
#[derive(Debug, Clone, Copy)]
struct Tracked {
    /// Index in the row.
    column: usize,
    instance: u32,
    p_object: Vec3A,
    reference: (f64, f64),
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
        let cam = self.stage().camera();
        let crop = cam.pixels();
        let n = crop.width() as usize;
        let mut batch = Batch::with_capacity(n);
        for x in crop.x0..crop.x1 {
            batch.push(
                cam.raster_to_screen(x as f64 + 0.5, y as f64 + 0.5),
                Point2::new(0.5, 0.5),
                0.0,
            );
            batch.aperture.push(Point2::ZERO);
        }
        self.stage().run_prepared(&mut batch);
        let mut out = vec![FlowPixel::NONE; n];
        let mut counts = Counts::default();
        let mut tracked = Vec::with_capacity(n);
        for (column, ray) in batch.rays.iter().enumerate() {
            if ray.is_culled() {
                continue;
            }
            let time = batch.time[column];
            let Some(world) = self.world_ray(ray, time) else {
                continue;
            };
            let Some(hit) = self.accel().intersect_camera(&world.ray) else {
                continue;
            };
            counts.hits += 1;
            let p_camera = world.origin_cam + world.direction_cam * (hit.t / world.stretch);
            let Some(reference) = self.unproject_raster(p_camera, time) else {
                counts.no_inverse += 1;
                continue;
            };
            let to_object = self.accel().instance_transform_at(hit.instance, time).inverse();
            tracked.push(Tracked {
                column,
                instance: hit.instance,
                p_object: to_object.transform_point3a(hit.position),
                reference,
            });
        }
        if let Some(target) = forward {
            for (column, flow) in self.follow(&tracked, target, &mut batch) {
                out[column].forward = flow;
                out[column].forward_valid = 1.0;
            }
        }
        if let Some(target) = backward {
            for (column, flow) in self.follow(&tracked, target, &mut batch) {
                out[column].backward = flow;
                out[column].backward_valid = 1.0;
            }
        }
        (out, counts)
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

    /// The flows of `tracked` toward `target`: `(column, flow)` for each point whose target position
    /// converged inside the image.
    fn follow(&self, tracked: &[Tracked], target: &FlowTarget, batch: &mut Batch) -> Vec<(usize, [f32; 2])> {
        let cam = self.stage().camera();
        let (w, h) = (cam.format.width as f64, cam.format.height as f64);
        let mut done = Vec::with_capacity(tracked.len());
        // (point, current raster position, the time that position was computed for)
        let mut pending: Vec<(Tracked, (f64, f64), Option<f32>)> =
            tracked.iter().map(|t| (*t, t.reference, None)).collect();
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
            self.stage().run_prepared(batch);
            let mut next = Vec::with_capacity(pending.len());
            for (i, (t, r, previous)) in pending.into_iter().enumerate() {
                if batch.rays[i].is_culled() {
                    continue;
                }
                let time = batch.time[i];
                if previous == Some(time) {
                    done.push((t, r));
                    continue;
                }
                let object = target.objects[t.instance as usize].object_to_world(time);
                let p_world = object.transform_point3a(t.p_object);
                let p_camera = target
                    .camera_to_world
                    .world_to_object(time)
                    .transform_point3a(p_world);
                let Some(moved) = self.unproject_raster(p_camera, time) else {
                    continue;
                };
                let step = (moved.0 - r.0).hypot(moved.1 - r.1);
                if previous.is_some() && step < CONVERGED_PX {
                    done.push((t, moved));
                } else {
                    next.push((t, moved, Some(time)));
                }
            }
            pending = next;
        }
        done.into_iter()
            .filter(|(_, r)| (0.0..=w).contains(&r.0) && (0.0..=h).contains(&r.1))
            .map(|(t, r)| {
                (
                    t.column,
                    [(r.0 - t.reference.0) as f32, (r.1 - t.reference.1) as f32],
                )
            })
            .collect()
    }
}
