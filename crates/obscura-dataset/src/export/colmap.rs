//! COLMAP's sparse model as text (`colmap/`), in the format of COLMAP ≥ 3.12 (read by pycolmap 4.x's
//! `Reconstruction(path)`):
//!
//! - `cameras.txt`: `CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]`, one camera per distinct intrinsics, the
//!   model and parameters of the camera JSON's `equivalents.colmap` (COLMAP's pixel convention:
//!   the top-left pixel's centre at (0.5, 0.5), raster coordinates);
//! - `images.txt`: `IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME` and an empty line of 2D points:
//!   `cam_from_world`, the world-to-camera rotation (Hamilton quaternion, `qw ≥ 0`) and translation
//!   in COLMAP's camera axes (x right, y down, z forward): `diag(1, −1, 1)·M_open`;
//! - `rigs.txt`: `RIG_ID NUM_SENSORS REF_SENSOR_TYPE REF_SENSOR_ID SENSORS[] as (SENSOR_TYPE,
//!   SENSOR_ID, HAS_POSE, [QW QX QY QZ TX TY TZ])`; `frames.txt`: `FRAME_ID RIG_ID
//!   RIG_FROM_WORLD[QW QX QY QZ TX TY TZ] NUM_DATA_IDS DATA_IDS[] as (SENSOR_TYPE SENSOR_ID
//!   DATA_ID)`. Several cameras whose relative poses are the same in every frame (a rigid rig) are
//!   one rig, the first camera its reference sensor (`sensor_from_rig = cam_from_world ·
//!   ref_from_world⁻¹`), one COLMAP frame per frame number; otherwise every camera is a rig of its
//!   own and every image a frame of its own;
//! - `points3D.txt`: no points (a model COLMAP loads, for tools that triangulate or train from poses).
//!
//! A camera with no exact COLMAP model gets no `cameras.txt` entry and no images; a comment in
//! `cameras.txt` names it with the reason.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use obscura_image::atomic::write_atomically;
use serde_json::Value;

use super::{ExportCamera, ExportError, ExportFormat, Item, Pose, WORLD_FLIPPED, create_dir};
use glam::DMat4;

/// How close (radians, and units per unit of distance) the cameras' relative poses must be in every
/// frame to be one rigid rig: the precision of the `f32` transforms scenes hold.
const RIGID: f64 = 2e-6;

/// One image of the model.
struct Image {
    id: usize,
    camera_id: usize,
    /// Index of its [`ExportCamera`].
    source: usize,
    frame: i32,
    name: String,
    pose: Pose,
}

/// Writes `root/colmap/`.
pub(crate) fn write(
    root: &Path,
    cameras: &[ExportCamera],
    world: DMat4,
    warnings: &mut Vec<String>,
) -> Result<(), ExportError> {
    let dir = root.join("colmap");
    create_dir(&dir)?;
    let mut intrinsics: Vec<(String, u64, u64, Vec<f64>)> = Vec::new();
    let mut camera_of: Vec<Vec<usize>> = vec![Vec::new(); cameras.len()];
    let mut images: Vec<Image> = Vec::new();
    let mut notes = String::new();
    if world != DMat4::IDENTITY {
        let _ = writeln!(notes, "# World: {WORLD_FLIPPED}");
    }
    for (ci, camera) in cameras.iter().enumerate() {
        for frame in &camera.frames {
            let item = Item { camera, frame };
            let entry = match item.equivalent(ExportFormat::Colmap)? {
                Ok(e) => e,
                Err(reason) => {
                    let _ = writeln!(
                        notes,
                        "# camera \"{}\" frame {}: no exact COLMAP camera model: {reason}",
                        camera.name, frame.frame
                    );
                    warnings.push(format!(
                        "colmap: camera \"{}\" frame {} not exported: {reason}",
                        camera.name, frame.frame
                    ));
                    continue;
                }
            };
            let key = parse_camera(&item, entry)?;
            let fov = frame.camera["field_of_view"].as_f64().unwrap_or(0.0);
            if entry.get("domain").is_some() && fov > 180.0 {
                let _ = writeln!(
                    notes,
                    "# camera \"{}\" frame {}: a {fov}° field of view; {}",
                    camera.name,
                    frame.frame,
                    entry["domain"].as_str().unwrap_or_default()
                );
                warnings.push(format!(
                    "colmap: camera \"{}\" frame {}: the {fov}° field of view is wider than COLMAP's fisheye models reach (θ < 90°); pixels past 90° have no COLMAP ray",
                    camera.name, frame.frame
                ));
            }
            let id = match intrinsics.iter().position(|k| *k == key) {
                Some(i) => i + 1,
                None => {
                    intrinsics.push(key);
                    intrinsics.len()
                }
            };
            if !camera_of[ci].contains(&id) {
                camera_of[ci].push(id);
            }
            if !item.still()? {
                warnings.push(format!(
                    "colmap: camera \"{}\" frame {} moves during the shutter; images.txt has its pose at shutter open",
                    camera.name, frame.frame
                ));
            }
            let name = item.image_name();
            if name.chars().any(char::is_whitespace) {
                return Err(item.error(format!(
                    "image \"{name}\": COLMAP's images.txt separates fields by spaces, so an image name cannot contain whitespace"
                )));
            }
            images.push(Image {
                id: images.len() + 1,
                camera_id: id,
                source: ci,
                frame: frame.frame,
                name,
                pose: item.opencv_pose("open", world)?,
            });
        }
    }

    let mut text = String::from(
        "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n",
    );
    let _ = writeln!(text, "# Number of cameras: {}", intrinsics.len());
    text.push_str(&notes);
    for (i, (model, w, h, params)) in intrinsics.iter().enumerate() {
        let _ = write!(text, "{} {model} {w} {h}", i + 1);
        for p in params {
            let _ = write!(text, " {}", num(*p));
        }
        text.push('\n');
    }
    put(&dir.join("cameras.txt"), &text)?;

    let mut text = String::from(
        "# Image list with two lines of data per image:\n#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n",
    );
    let _ = writeln!(
        text,
        "# Number of images: {}, mean observations per image: 0",
        images.len()
    );
    for im in &images {
        let _ = writeln!(
            text,
            "{} {} {} {}\n",
            im.id,
            pose_text(&im.pose),
            im.camera_id,
            im.name
        );
    }
    put(&dir.join("images.txt"), &text)?;

    put(
        &dir.join("points3D.txt"),
        "# 3D point list with one line of data per point:\n#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n# Number of points: 0, mean track length: 0\n",
    )?;

    let (rigs, frames) = match rig(cameras, &camera_of, &images) {
        Some(rig) => rig,
        None => trivial_rigs(&intrinsics, &images),
    };
    put(&dir.join("rigs.txt"), &rigs)?;
    put(&dir.join("frames.txt"), &frames)
}

/// `(model, width, height, params)` of an `equivalents.colmap` entry.
fn parse_camera(item: &Item<'_>, e: &Value) -> Result<(String, u64, u64, Vec<f64>), ExportError> {
    let model = e["model"]
        .as_str()
        .ok_or_else(|| item.error("equivalents.colmap.model: expected a string"))?;
    let (w, h) = (e["width"].as_u64(), e["height"].as_u64());
    let params: Option<Vec<f64>> = e["params"]
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_f64).collect());
    match (w, h, params) {
        (Some(w), Some(h), Some(p)) if p.len() == e["params"].as_array().map_or(0, Vec::len) => {
            Ok((model.to_string(), w, h, p))
        }
        _ => Err(item.error("equivalents.colmap: expected width, height (integers) and params (numbers)")),
    }
}

/// The rigs and frames of a rigid multi-camera rig, or `None` when the cameras are not one.
fn rig(cameras: &[ExportCamera], camera_of: &[Vec<usize>], images: &[Image]) -> Option<(String, String)> {
    if cameras.len() < 2 || camera_of.iter().any(|c| c.len() != 1) {
        return None;
    }
    let frame_numbers: Vec<i32> = images.iter().filter(|i| i.source == 0).map(|i| i.frame).collect();
    let find = |source: usize, frame: i32| images.iter().find(|i| i.source == source && i.frame == frame);
    let mut sensor_from_rig: Vec<Option<Pose>> = vec![None; cameras.len()];
    for &f in &frame_numbers {
        let reference = find(0, f)?;
        for (s, slot) in sensor_from_rig.iter_mut().enumerate().skip(1) {
            let relative = find(s, f)?.pose.compose(&reference.pose.inverse());
            match slot {
                None => *slot = Some(relative),
                Some(first) => {
                    // The same to the precision of the f32 transforms the scene holds.
                    let scale = 1.0 + first.translation.length();
                    let same = first.translation.abs_diff_eq(relative.translation, RIGID * scale)
                        && first.rotation.angle_between(relative.rotation) < RIGID;
                    if !same {
                        return None;
                    }
                }
            }
        }
    }
    if (1..cameras.len()).any(|s| images.iter().filter(|i| i.source == s).count() != frame_numbers.len()) {
        return None;
    }
    let mut rigs = rigs_header(1);
    let _ = write!(rigs, "1 {} CAMERA {}", cameras.len(), camera_of[0][0]);
    for (s, pose) in sensor_from_rig.iter().enumerate().skip(1) {
        let _ = write!(
            rigs,
            " CAMERA {} 1 {}",
            camera_of[s][0],
            pose_text(pose.as_ref()?)
        );
    }
    rigs.push('\n');
    let mut frames = frames_header(frame_numbers.len());
    for (k, &f) in frame_numbers.iter().enumerate() {
        let _ = write!(
            frames,
            "{} 1 {} {}",
            k + 1,
            pose_text(&find(0, f)?.pose),
            cameras.len()
        );
        for s in 0..cameras.len() {
            let im = find(s, f)?;
            let _ = write!(frames, " CAMERA {} {}", im.camera_id, im.id);
        }
        frames.push('\n');
    }
    Some((rigs, frames))
}

/// One rig per COLMAP camera, one frame per image.
fn trivial_rigs(intrinsics: &[(String, u64, u64, Vec<f64>)], images: &[Image]) -> (String, String) {
    let mut rigs = rigs_header(intrinsics.len());
    for id in 1..=intrinsics.len() {
        let _ = writeln!(rigs, "{id} 1 CAMERA {id}");
    }
    let mut frames = frames_header(images.len());
    for im in images {
        let _ = writeln!(
            frames,
            "{} {} {} 1 CAMERA {} {}",
            im.id,
            im.camera_id,
            pose_text(&im.pose),
            im.camera_id,
            im.id
        );
    }
    (rigs, frames)
}

fn rigs_header(n: usize) -> String {
    format!(
        "# Rig calib list with one line of data per calib:\n#   RIG_ID, NUM_SENSORS, REF_SENSOR_TYPE, REF_SENSOR_ID, SENSORS[] as (SENSOR_TYPE, SENSOR_ID, HAS_POSE, [QW, QX, QY, QZ, TX, TY, TZ])\n# Number of rigs: {n}\n"
    )
}

fn frames_header(n: usize) -> String {
    format!(
        "# Frame list with one line of data per frame:\n#   FRAME_ID, RIG_ID, RIG_FROM_WORLD[QW, QX, QY, QZ, TX, TY, TZ], NUM_DATA_IDS, DATA_IDS[] as (SENSOR_TYPE, SENSOR_ID, DATA_ID)\n# Number of frames: {n}\n"
    )
}

/// `QW QX QY QZ TX TY TZ`.
fn pose_text(p: &Pose) -> String {
    let q = p.colmap_quaternion();
    let t = p.translation;
    [q[0], q[1], q[2], q[3], t.x, t.y, t.z].map(num).join(" ")
}

/// A number with every digit an `f64` has (Rust's shortest round-trip form).
fn num(x: f64) -> String {
    format!("{x:?}")
}

fn put(path: &Path, text: &str) -> Result<(), ExportError> {
    Ok(write_atomically(path, |out| out.write_all(text.as_bytes()))?)
}
