//! 2D and 3D boxes per object and instance, through the exact camera; COCO-style JSON per frame.
//!
//! For each instance (a scene object, `instanceId = index + 1`) of one frame of one camera:
//!
//! - **`bbox`**, the tight box of its visible pixels: the pixels of the rendered `instanceId` AOV
//!   (the sample nearest each pixel centre) equal to its ID; pixel `(i, j)` covers `[i, i+1] × [j, j+1]`,
//!   so `bbox = [i_min, j_min, i_max + 1 − i_min, j_max + 1 − j_min]` in raster pixels. `None` when no
//!   pixel shows it.
//! - **`bbox_full`**, the box of the whole object, occluded parts included: its surface — the
//!   triangles the render diced, in object space — seen through the camera with
//!   [`super::reproject::locate`] (each point at its own row time under a rolling shutter). First every
//!   vertex; then each triangle that could reach the box's edge (its vertices' box within
//!   `s/2 + 1` px of an extreme that lies inside the image, `s` its projected size, or a vertex
//!   outside the projection's domain), and that box grown by the same margin meets the image, is
//!   sampled on a barycentric grid of `n = clamp(⌈2s⌉, 2, 128)` steps per edge (16 for a triangle
//!   crossing the domain's edge), since a projection bends straight edges (a fisheye's box is not its
//!   corners'). The box is clipped to
//!   the image `[0, W] × [0, H]` (`bbox_full_clipped` says it was) and is `None` when no point is
//!   in the projection's domain; `crosses_domain` is true when part of the surface is outside the
//!   domain (behind a pinhole, beyond a fisheye's field of view), where the box covers only the part
//!   inside. The box is the diced surface's, within the dicing tolerance of the exact one.
//! - **`bbox3d`**, the oriented 3D box: the object-space bounds `[lo, hi]` of the diced surface placed
//!   by the object-to-world transform `M(t)` at the time `t` the projection gives the image centre's
//!   chief ray (for canonical time `τ`, 0 by default); its 8 corners in world space `M(t)·c` and camera
//!   space `C(t)⁻¹·M(t)·c` (Obscura's camera space: +x right, +y up, +z forward), and each corner's
//!   raster position through the exact camera (at its own row time) where it is in the projection's
//!   domain, `None` elsewhere. Corner `k` takes `hi` on axis `a` when bit `a` of `k` is set
//!   (`k = x + 2y + 4z`).
//!
//! # JSON ([`coco_json`])
//!
//! One COCO-style object per frame and camera:
//!
//! ```text
//! { "info": {"description", "version": "1.0", "camera", "frame"},
//!   "images": [{"id": 1, "file_name", "width", "height", "camera", "frame"}],
//!   "categories": [{"id": objectId, "name": object name, "supercategory": "object"}],
//!   "annotations": [{
//!       "id": instanceId, "image_id": 1, "category_id": objectId, "iscrowd": 0,
//!       "object_id", "object_name", "instance_id", "instance_name",
//!       "bbox": [x, y, w, h] | null, "area": visible pixel count,
//!       "bbox_full": [x, y, w, h] | null, "bbox_full_clipped": bool, "crosses_domain": bool,
//!       "bbox3d": {"time", "object_min": [3], "object_max": [3],
//!                  "corners_world": [8][3], "corners_camera": [8][3],
//!                  "corners_raster": [8]([x, y] | null)} }] }
//! ```
//!
//! An instance appears when it has a `bbox` or a `bbox_full`. `id` is unique within the file (it is
//! the instanceId); a dataset-wide COCO file must renumber.

use std::path::Path;

use glam::Vec3A;
use obscura_image::atomic::write_atomically;
use obscura_image::film::Film;
use obscura_render::flow::{FlowTarget, ObjectPoint};
use obscura_render::render::Prepared;
use obscura_render::truth::IdTable;
use obscura_scene::Scene;
use serde_json::{Value, json};

use super::AnnotateError;
use super::reproject::{Located, Status, locate};

/// Most grid steps per triangle edge in the refinement of `bbox_full`.
const MAX_STEPS: usize = 128;

/// A 2D box `[x, y, w, h]` in raster pixels.
pub type Box2 = [f64; 4];

/// The oriented 3D box of an instance (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct Box3 {
    /// The shutter-normalised time the box is placed at.
    pub time: f32,
    /// Object-space minimum corner.
    pub object_min: [f64; 3],
    /// Object-space maximum corner.
    pub object_max: [f64; 3],
    /// The 8 corners in world space (corner `k = x + 2y + 4z`).
    pub corners_world: [[f64; 3]; 8],
    /// The 8 corners in camera space.
    pub corners_camera: [[f64; 3]; 8],
    /// Each corner's raster position where it is in the projection's domain.
    pub corners_raster: [Option<[f64; 2]>; 8],
}

/// The boxes of one instance in one frame of one camera.
#[derive(Debug, Clone, PartialEq)]
pub struct InstanceBoxes {
    /// `instanceId` (index in the scene's objects + 1).
    pub instance_id: u32,
    /// `objectId`.
    pub object_id: u32,
    /// The instance's name.
    pub instance_name: String,
    /// The object's name.
    pub object_name: String,
    /// How many pixels show it.
    pub visible_pixels: u64,
    /// Tight box of its visible pixels.
    pub bbox: Option<Box2>,
    /// Box of the whole object through the camera, clipped to the image.
    pub bbox_full: Option<Box2>,
    /// True when `bbox_full` was clipped by the image's edge.
    pub bbox_full_clipped: bool,
    /// True when part of the surface is outside the projection's domain.
    pub crosses_domain: bool,
    /// The oriented 3D box; `None` for an instance without a surface.
    pub bbox3d: Option<Box3>,
}

/// The boxes of every instance of the frame `prepared` of `scene` whose render is `film` (which must
/// hold the instance IDs: any render's film does), at canonical time sample `time_sample` (0 unless
/// the tracks use another).
///
/// # Errors
/// [`AnnotateError::Render`] for a singular camera transform; [`AnnotateError::Mismatch`] when the
/// film is not the size of the camera's image.
pub fn frame_boxes(
    prepared: &Prepared,
    scene: &Scene,
    film: &Film,
    time_sample: f32,
) -> Result<Vec<InstanceBoxes>, AnnotateError> {
    let format = prepared.stage().camera().format;
    if film.size() != (format.width, format.height) {
        return Err(AnnotateError::Mismatch(format!(
            "the film is {}×{} but the camera's image is {}×{}",
            film.size().0,
            film.size().1,
            format.width,
            format.height
        )));
    }
    let motion = FlowTarget::new(scene, time_sample)?;
    let ids = prepared.ids();
    let count = ids.instance_count();
    let (pixels, visible) = visible_boxes(film, count);
    let centre = (format.width as f64 / 2.0, format.height as f64 / 2.0);
    let box_time = prepared
        .trace_chief(&[centre], time_sample)
        .first()
        .copied()
        .flatten()
        .map_or(time_sample, |r| r.time);
    let mut out = Vec::with_capacity(count);
    for instance in 0..count as u32 {
        let (object_id, instance_id, _) = ids.ids(instance);
        let mesh = prepared
            .accel()
            .instance_mesh(instance)
            .filter(|m| !m.is_empty() && instance < motion.object_count() as u32);
        let (full, crosses) = match mesh {
            Some(m) => full_box(prepared, &motion, instance, m),
            None => (None, false),
        };
        let (w, h) = (format.width as f64, format.height as f64);
        let clipped = full.map(|[x0, y0, x1, y1]| [x0.max(0.0), y0.max(0.0), x1.min(w), y1.min(h)]);
        let bbox_full = clipped
            .filter(|[x0, y0, x1, y1]| x0 <= x1 && y0 <= y1)
            .map(|[x0, y0, x1, y1]| [x0, y0, x1 - x0, y1 - y0]);
        out.push(InstanceBoxes {
            instance_id,
            object_id,
            instance_name: ids.instance_name(instance_id).unwrap_or_default().to_string(),
            object_name: ids.object_name(object_id).unwrap_or_default().to_string(),
            visible_pixels: pixels[instance as usize],
            bbox: visible[instance as usize],
            bbox_full,
            bbox_full_clipped: full != clipped,
            crosses_domain: crosses,
            bbox3d: mesh.map(|m| box3(prepared, &motion, instance, m, box_time)),
        });
    }
    Ok(out)
}

/// Per instance: how many pixels show it and the tight box of those pixels.
fn visible_boxes(film: &Film, instances: usize) -> (Vec<u64>, Vec<Option<Box2>>) {
    let crop = film.crop();
    let mut count = vec![0u64; instances];
    let mut bounds: Vec<Option<[u32; 4]>> = vec![None; instances];
    for y in crop.y0..crop.y1 {
        for x in crop.x0..crop.x1 {
            let id = film.pixel(x, y).truth.instance_id;
            let Some(i) = (id as usize).checked_sub(1).filter(|&i| i < instances) else {
                continue;
            };
            count[i] += 1;
            let b = bounds[i].get_or_insert([x, y, x, y]);
            *b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
        }
    }
    let boxes = bounds
        .into_iter()
        .map(|b| {
            b.map(|[x0, y0, x1, y1]| {
                [
                    f64::from(x0),
                    f64::from(y0),
                    f64::from(x1 + 1 - x0),
                    f64::from(y1 + 1 - y0),
                ]
            })
        })
        .collect();
    (count, boxes)
}

/// Raster extent `[x0, y0, x1, y1]` of points, grown by more.
#[derive(Debug, Clone, Copy)]
struct Extent([f64; 4]);

impl Extent {
    const EMPTY: Extent = Extent([f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY]);

    fn add(&mut self, r: [f64; 2]) {
        let e = &mut self.0;
        *e = [e[0].min(r[0]), e[1].min(r[1]), e[2].max(r[0]), e[3].max(r[1])];
    }

    fn is_empty(&self) -> bool {
        self.0[0] > self.0[2]
    }
}

/// Whether a located point is in the projection's domain (in or out of the frame).
fn in_domain(l: &Located) -> bool {
    l.status != Status::OutsideDomain
}

/// The unclipped `[x0, y0, x1, y1]` of an instance's whole surface through the camera, and whether
/// part of it is outside the domain (see the module documentation).
fn full_box(
    prepared: &Prepared,
    motion: &FlowTarget,
    instance: u32,
    mesh: &obscura_geometry::ray::TriangleMesh,
) -> (Option<[f64; 4]>, bool) {
    let point = |p: Vec3A| ObjectPoint {
        instance,
        position: p,
    };
    let format = prepared.stage().camera().format;
    let (w, h) = (format.width as f64, format.height as f64);
    let vertices: Vec<ObjectPoint> = mesh.positions.iter().map(|&p| point(p)).collect();
    let seen = locate(prepared, motion, &vertices, false);
    let mut extent = Extent::EMPTY;
    let mut crosses = false;
    for l in &seen {
        if in_domain(l) {
            extent.add(l.raster);
        } else {
            crosses = true;
        }
    }
    // Refinement: triangles that may reach an extreme, or straddle the domain's edge.
    let mut samples = Vec::new();
    for t in &mesh.triangles {
        let l = t.map(|i| seen[i as usize]);
        let inside = l.iter().filter(|l| in_domain(l)).count();
        if inside == 0 {
            continue;
        }
        let mut tri = Extent::EMPTY;
        for v in l.iter().filter(|l| in_domain(l)) {
            tri.add(v.raster);
        }
        let size = (tri.0[2] - tri.0[0]).max(tri.0[3] - tri.0[1]);
        let margin = size / 2.0 + 1.0;
        // Only the clipped box matters: a triangle that cannot reach the image is left alone, and a
        // side of the box already beyond the image's edge is settled.
        if tri.0[0] - margin > w
            || tri.0[2] + margin < 0.0
            || tri.0[1] - margin > h
            || tri.0[3] + margin < 0.0
        {
            continue;
        }
        let near = (extent.0[0] > 0.0 && tri.0[0] < extent.0[0] + margin)
            || (extent.0[1] > 0.0 && tri.0[1] < extent.0[1] + margin)
            || (extent.0[2] < w && tri.0[2] > extent.0[2] - margin)
            || (extent.0[3] < h && tri.0[3] > extent.0[3] - margin);
        if inside < 3 || near {
            let n = if inside < 3 {
                16
            } else {
                ((2.0 * size).ceil() as usize).clamp(2, MAX_STEPS)
            };
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            for i in 0..=n {
                for j in 0..=(n - i) {
                    let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                    samples.push(point(a * (1.0 - u - v) + b * u + c * v));
                }
            }
        }
    }
    for l in locate(prepared, motion, &samples, false) {
        if in_domain(&l) {
            extent.add(l.raster);
        } else {
            crosses = true;
        }
    }
    ((!extent.is_empty()).then_some(extent.0), crosses)
}

/// The oriented 3D box of an instance at `time` (see the module documentation).
fn box3(
    prepared: &Prepared,
    motion: &FlowTarget,
    instance: u32,
    mesh: &obscura_geometry::ray::TriangleMesh,
    time: f32,
) -> Box3 {
    let (lo, hi) = mesh.positions.iter().fold(
        (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let corners: Vec<Vec3A> = (0..8)
        .map(|k| {
            Vec3A::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            )
        })
        .collect();
    let to_world = motion.object_to_world(instance, time).unwrap_or_default();
    let to_camera = motion.camera_to_world(time).inverse();
    let d3 = |v: Vec3A| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
    let mut out = Box3 {
        time,
        object_min: d3(lo),
        object_max: d3(hi),
        corners_world: [[0.0; 3]; 8],
        corners_camera: [[0.0; 3]; 8],
        corners_raster: [None; 8],
    };
    let points: Vec<ObjectPoint> = corners
        .iter()
        .map(|&c| ObjectPoint {
            instance,
            position: c,
        })
        .collect();
    let seen = locate(prepared, motion, &points, false);
    for (k, c) in corners.iter().enumerate() {
        let w = to_world.transform_point3a(*c);
        out.corners_world[k] = d3(w);
        out.corners_camera[k] = d3(to_camera.transform_point3a(w));
        out.corners_raster[k] = in_domain(&seen[k]).then_some(seen[k].raster);
    }
    out
}

/// What the COCO file says about the image the boxes belong to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImageInfo<'a> {
    /// The image's file name, relative to the dataset (e.g. `images/left/0001.exr`).
    pub file_name: &'a str,
    /// The camera's name.
    pub camera: &'a str,
    /// The frame number, if any.
    pub frame: Option<i64>,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

/// The COCO-style JSON of one frame's boxes (see the module documentation for the keys); `ids` is the
/// frame's ID table (for the categories).
#[must_use]
pub fn coco_json(image: &ImageInfo<'_>, ids: &IdTable, boxes: &[InstanceBoxes]) -> Value {
    let categories: Vec<Value> = (1u32..)
        .map_while(|id| ids.object_name(id).map(|n| (id, n)))
        .map(|(id, name)| json!({"id": id, "name": name, "supercategory": "object"}))
        .collect();
    let annotations: Vec<Value> = boxes
        .iter()
        .filter(|b| b.bbox.is_some() || b.bbox_full.is_some())
        .map(|b| {
            json!({
                "id": b.instance_id,
                "image_id": 1,
                "category_id": b.object_id,
                "iscrowd": 0,
                "object_id": b.object_id,
                "object_name": b.object_name,
                "instance_id": b.instance_id,
                "instance_name": b.instance_name,
                "bbox": b.bbox,
                "area": b.visible_pixels,
                "bbox_full": b.bbox_full,
                "bbox_full_clipped": b.bbox_full_clipped,
                "crosses_domain": b.crosses_domain,
                "bbox3d": b.bbox3d.as_ref().map(|d| json!({
                    "time": d.time,
                    "object_min": d.object_min,
                    "object_max": d.object_max,
                    "corners_world": d.corners_world,
                    "corners_camera": d.corners_camera,
                    "corners_raster": d.corners_raster,
                })),
            })
        })
        .collect();
    json!({
        "info": {
            "description": "Obscura annotations: boxes through the exact camera",
            "version": "1.0",
            "camera": image.camera,
            "frame": image.frame,
        },
        "images": [{
            "id": 1,
            "file_name": image.file_name,
            "width": image.width,
            "height": image.height,
            "camera": image.camera,
            "frame": image.frame,
        }],
        "categories": categories,
        "annotations": annotations,
    })
}

/// Writes `json` (pretty-printed) to `path`, atomically.
///
/// # Errors
/// [`AnnotateError::Write`] naming the file.
pub fn write_json(path: &Path, json: &Value) -> Result<(), AnnotateError> {
    write_atomically(path, |w| {
        serde_json::to_writer_pretty(&mut *w, json).map_err(std::io::Error::other)?;
        std::io::Write::write_all(w, b"\n")
    })?;
    Ok(())
}
