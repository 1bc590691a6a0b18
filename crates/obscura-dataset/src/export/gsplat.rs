//! gsplat/3DGUT camera arguments (`gsplat/cameras.json`), one entry per frame with what
//! `gsplat.rendering.rasterization` takes for it (`gsplat/rendering.py`; the models in
//! `gsplat/cuda/include/Cameras.cuh`):
//!
//! - `camera_model` `pinhole` | `fisheye` | `ftheta`, `width`, `height`, `Ks` (3×3, raster pixels:
//!   gsplat's pixel `(j, i)` is at `(j + 0.5, i + 0.5)`, the top-left pixel's centre at (0.5, 0.5));
//! - `radial_coeffs` (pinhole: k1…k6, OpenCV's rational model; fisheye: k1…k4, Kannala–Brandt),
//!   `tangential_coeffs` p1 p2, `thin_prism_coeffs` s1…s4, `ftheta_coeffs` (the fields of
//!   `FThetaCameraDistortionParameters`: `reference_poly`, `pixeldist_to_angle_poly`,
//!   `angle_to_pixeldist_poly`, `max_angle`, `linear_cde`);
//! - `viewmats`: world-to-camera in OpenCV's axes (x right, y down, z forward), `diag(1, −1, 1)·M`;
//! - `rolling_shutter`: a `RollingShutterType` name (`GLOBAL`, `ROLLING_TOP_TO_BOTTOM`,
//!   `ROLLING_LEFT_TO_RIGHT`, `ROLLING_BOTTOM_TO_TOP`, `ROLLING_RIGHT_TO_LEFT`) and, when rolling,
//!   `viewmats_rs`, the end pose.
//!
//! # Rolling shutter
//!
//! gsplat gives row `i` (sweep down) the time `t = i/(H − 1)` between `viewmats` (t = 0) and
//! `viewmats_rs` (t = 1), interpolating translation linearly and rotation by slerp. Obscura's
//! `PxrRollingShutter` exposes the line at `p` (0 top edge, 1 bottom edge) from `p·(1 − d)` to
//! `p·(1 − d) + d` of the shutter (`d` = `duration`), and its camera moves by the same lerp/slerp
//! (`obscura_geometry::motion`). The line of row `i` has `p = (i + ½)/H`, its exposure centre
//! `T(i) = p·(1 − d) + d/2` is affine in `i`, so writing the poses at `T(0)` and `T(H − 1)` makes
//! gsplat's pose of every row the pose at the centre of that row's exposure: exact at the row
//! centres. A camera that moves during a global shutter (motion blur) has no single pose: the
//! start pose is written and a warning returned.

use std::path::Path;

use glam::DMat4;
use obscura_render::metadata::write_json;
use serde_json::{Value, json};

use super::{ExportCamera, ExportError, ExportFormat, FLIP_Y, Item, rows};

/// Writes `root/gsplat/cameras.json`.
pub(crate) fn write(
    root: &Path,
    cameras: &[ExportCamera],
    world: DMat4,
    warnings: &mut Vec<String>,
) -> Result<(), ExportError> {
    let mut out = Vec::new();
    for camera in cameras {
        let mut frames = Vec::new();
        for frame in &camera.frames {
            frames.push(entry(&Item { camera, frame }, world, warnings)?);
        }
        out.push(json!({"name": camera.name, "frames": frames}));
    }
    let dir = root.join("gsplat");
    super::create_dir(&dir)?;
    let doc = json!({
        "schema": "obscura-gsplat/1",
        "convention": "Ks in raster pixels (top-left pixel centre at (0.5, 0.5), gsplat's); viewmats world-to-camera, OpenCV axes (x right, y down, z forward)",
        "world": if world == DMat4::IDENTITY { json!("Obscura's world") } else { json!(super::WORLD_FLIPPED) },
        "cameras": out,
    });
    Ok(write_json(&dir.join("cameras.json"), &doc)?)
}

/// One frame's arguments.
fn entry(item: &Item<'_>, world: DMat4, warnings: &mut Vec<String>) -> Result<Value, ExportError> {
    let base = json!({"frame": item.frame.frame, "image": item.image_name()});
    let e = match item.equivalent(ExportFormat::Gsplat)? {
        Ok(e) => e,
        Err(reason) => {
            warnings.push(format!(
                "gsplat: camera \"{}\" frame {} not exported: {reason}",
                item.camera.name, item.frame.frame
            ));
            let mut j = base;
            j["camera_model"] = Value::Null;
            j["reason"] = json!(reason);
            return Ok(j);
        }
    };
    let mut j = base;
    for key in [
        "camera_model",
        "width",
        "height",
        "radial_coeffs",
        "tangential_coeffs",
        "thin_prism_coeffs",
        "ftheta_coeffs",
    ] {
        if let Some(v) = e.get(key) {
            j[key] = v.clone();
        }
    }
    j["Ks"] = e["K"].clone();
    let open = item.world_to_camera("open")?;
    let close = item.world_to_camera("close")?;
    let rs = &item.frame.camera["rolling_shutter"];
    let duration = rs["duration"].as_f64().unwrap_or(1.0);
    if rs.is_object() && duration < 1.0 && !item.still()? {
        let sweep = rs["sweep"].as_str().unwrap_or("down");
        let (kind, lines) = match sweep {
            "down" => ("ROLLING_TOP_TO_BOTTOM", e["height"].as_f64()),
            "up" => ("ROLLING_BOTTOM_TO_TOP", e["height"].as_f64()),
            "right" => ("ROLLING_LEFT_TO_RIGHT", e["width"].as_f64()),
            "left" => ("ROLLING_RIGHT_TO_LEFT", e["width"].as_f64()),
            other => {
                return Err(item.error(format!(
                    "rolling_shutter.sweep \"{other}\": expected down, up, right or left"
                )));
            }
        };
        let n = lines.ok_or_else(|| item.error("equivalents.gsplat: expected width and height"))?;
        let time = |line: f64| (line + 0.5) / n * (1.0 - duration) + duration / 2.0;
        let at = |t: f64| FLIP_Y * pose_at(open, close, t) * world;
        j["rolling_shutter"] = json!(kind);
        j["viewmats"] = rows(at(time(0.0)));
        j["viewmats_rs"] = rows(at(time(n - 1.0)));
    } else {
        if !item.still()? {
            warnings.push(format!(
                "gsplat: camera \"{}\" frame {} moves during a global shutter; viewmats is its pose at shutter open",
                item.camera.name, item.frame.frame
            ));
        }
        j["rolling_shutter"] = json!("GLOBAL");
        j["viewmats"] = rows(FLIP_Y * open * world);
    }
    Ok(j)
}

/// World-to-camera at shutter time `t` between `open` and `close`: camera-to-world interpolated as
/// Obscura's camera motion does (translation and scale linearly, rotation by shortest-path slerp).
#[must_use]
pub fn pose_at(open: DMat4, close: DMat4, t: f64) -> DMat4 {
    let (s0, r0, t0) = open.inverse().to_scale_rotation_translation();
    let (s1, r1, t1) = close.inverse().to_scale_rotation_translation();
    let r1 = if r0.dot(r1) < 0.0 { -r1 } else { r1 };
    DMat4::from_scale_rotation_translation(s0.lerp(s1, t), r0.slerp(r1, t), t0.lerp(t1, t)).inverse()
}
