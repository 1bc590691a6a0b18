//! Per-frame camera metadata and the ID sidecar: what a vision user needs to reproject a render with
//! their own tools.
//!
//! # The camera JSON (`<image>.camera.json`, and the EXR header attribute `obscura:camera`)
//!
//! ```json
//! {
//!   "schema": "obscura-camera/1",
//!   "frame": 12,                                  // null outside a sequence
//!   "projection": "PxrPerspective",
//!   "parameters": {"fov": [50.0]},                // as given (scene, --param, calibration)
//!   "image": {"width": 640, "height": 360, "pixel_aspect": 1.0,
//!             "screen_window": [l, r, b, t], "data_window": [x0, y0, x1, y1]},
//!   "shutter": [open, close], "clipping": [near, far],   // far null when infinite
//!   "deep_metric": "CameraZ" | "RayLength", "field_of_view": 50.0,
//!   "world_to_camera": {"open": M, "close": M},   // 4×4, rows, column vectors: p_cam = M·p_world
//!   "opencv": {"K": 3×3, "dist": [..], "model": "pinhole" | "fisheye",
//!              "world_to_camera": {"open": M, "close": M}},
//!   "colmap": {"model": "PINHOLE", "width": 640, "height": 360, "params": [fx, fy, cx, cy]},
//!   "camera_model": {"projection": "PxrPerspective", "lens": "pinhole", "fx": …, "fy": …, "cx": …,
//!                    "cy": …, "k": [6], "p": [2], "s": [4], "formula": "…", "convention": "…",
//!                    "width": 640, "height": 360},          // or {"lens": null, "reason": …}
//!   "equivalents": {"convention": "…",
//!                   "colmap": {"model", "width", "height", "params"[, "domain"]},
//!                   "opencv": {"model": "pinhole" | "fisheye", "K", "dist"},
//!                   "nerfstudio": {"camera_model", "fl_x", "fl_y", "cx", "cy", "w", "h", "k1"…},
//!                   "gsplat": {"camera_model": "pinhole" | "fisheye" | "ftheta", "K", …}},
//!   "rolling_shutter": {"sweep": "down", "duration": 0.0}   // PxrRollingShutter only
//! }
//! ```
//!
//! `camera_model` and `equivalents` (added keys; the schema stays `obscura-camera/1`) are the exact
//! description of every model and its equivalent in each training format, or `{"model": null,
//! "reason": …}` (nerfstudio: `camera_model` null) pointing to `obscura rays` — never an
//! approximation. [`equivalents`] documents each mapping as a formula and the exactness table; the
//! exports of `obscura-dataset` only format these entries. Intrinsics there are in raster pixels of
//! the render (top-left pixel centre at (0.5, 0.5)) with OpenCV's camera axes.
//!
//! An overscanned render (`obscura render --overscan`, [`with_overscan`]) states the plate as
//! `image.width`/`height` and `screen_window`, the overscanned box as `data_window` (from a negative
//! origin) and its margins as `"overscan": [left, top, right, bottom]`.
//!
//! Camera space is RenderMan's (+X right, +Y up, looking down +Z); OpenCV's and COLMAP's camera has +Y
//! down, so their world-to-camera is `diag(1, −1, 1, 1)·M`. `opencv` and `colmap` are present only for a
//! pinhole-equivalent camera: `PxrPerspective` without a `fovEnd` zoom (its chief rays,
//! `fx = d·W/(r − l)`, `fy = d·H/(t − b)`, `cx = −l·W/(r − l)`, `cy = t·H/(t − b)` in raster
//! coordinates, `d = 1/tan(fov/2)`) and a
//! `CalibratedCamera` whose model is one of COLMAP's pinhole-family or OpenCV's (`SIMPLE_PINHOLE`,
//! `PINHOLE`, `SIMPLE_RADIAL`, `RADIAL`, `OPENCV`, `FULL_OPENCV`, `OPENCV_FISHEYE`, `OPENCV_PINHOLE`),
//! rescaled to the render's size. COLMAP puts the centre of the top-left pixel at (0.5, 0.5) (raster
//! coordinates), OpenCV at (0, 0): OpenCV's `cx` is COLMAP's minus ½.
//!
//! # The ID sidecar (`<image>.ids.json`, and `obscura:ids`)
//!
//! [`crate::truth::IdTable::to_json`]: names of every object, instance and material ID.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use glam::{Affine3A, Mat4};
use obscura_scene::Scene;
use obscura_sdk::{DeepMetric, ParamValue};
use serde_json::{Value, json};

use obscura_geometry::motion::camera_motion;
use obscura_image::atomic::{AtomicWriteError, write_atomically};

use crate::render::{Prepared, RenderError};

pub mod equivalents;

/// The schema name written into every camera JSON.
pub const SCHEMA: &str = "obscura-camera/1";

/// `image.exr` → `image.<suffix>` (`image.camera.json`, `image.ids.json`).
#[must_use]
pub fn sidecar_path(image: &Path, suffix: &str) -> PathBuf {
    image.with_extension(suffix)
}

/// The camera JSON `text` (compact as the EXR header's `obscura:camera` holds it, or pretty as in
/// `<image>.camera.json`) with its `image.data_window` set to `rect`, every other byte kept; `None`
/// when `text` has no data window of four numbers. What `obscura merge` writes for tiles stitched
/// back into one image. Edited as text, not parsed and printed again: a number read into an `f64`
/// and printed back need not keep its digits.
#[must_use]
pub fn with_data_window(text: &str, rect: obscura_host::PixelRect) -> Option<String> {
    let key = text.find("\"data_window\"")?;
    let open = key + text[key..].find('[')?;
    let close = open + text[open..].find(']')?;
    let parts: Vec<&str> = text[open + 1..close].split(',').collect();
    if parts.len() != 4 || parts.iter().any(|p| p.trim().parse::<u64>().is_err()) {
        return None;
    }
    let values = [rect.x0, rect.y0, rect.x1, rect.y1];
    let inner: Vec<String> = (parts.iter().zip(values))
        .map(|(p, v)| {
            let lead = p.len() - p.trim_start().len();
            let end = p.trim_end().len();
            format!("{}{v}{}", &p[..lead], &p[end..])
        })
        .collect();
    Some(format!("{}{}{}", &text[..=open], inner.join(","), &text[close..]))
}

/// The camera JSON `text` (compact as in the EXR header, or pretty as in the sidecar, kept so) of
/// an overscanned render placed on its `width × height` plate
/// ([`obscura_image::tiles::place_overscan`]): `image.width`/`height` become the plate's (the
/// display window), `image.data_window` the overscanned box `[−left, −top, width + right,
/// height + bottom]` in the plate's pixels, `image.screen_window` the plate's (the rendered window
/// less the margins, at the same pixel pitch), and `image.overscan` records `[left, top, right,
/// bottom]`. The `opencv`/`colmap` intrinsics stay those of the rendered pixels, whose `(0, 0)` is
/// the data window's origin. `None` when `text` is not a camera JSON of the overscanned size.
#[must_use]
pub fn with_overscan(
    text: &str,
    overscan: obscura_image::tiles::Overscan,
    width: u32,
    height: u32,
) -> Option<String> {
    let mut v: Value = serde_json::from_str(text).ok()?;
    let image = v.get_mut("image")?.as_object_mut()?;
    let (rw, rh) = overscan.render_size(width, height);
    if image.get("width")?.as_u64()? != u64::from(rw) || image.get("height")?.as_u64()? != u64::from(rh) {
        return None;
    }
    let win: Vec<f64> = (image.get("screen_window")?.as_array()?.iter())
        .map(Value::as_f64)
        .collect::<Option<_>>()?;
    let [l, r, b, t] = win[..] else { return None };
    let (sx, sy) = ((r - l) / f64::from(rw), (t - b) / f64::from(rh));
    let o = overscan;
    image.insert("width".into(), json!(width));
    image.insert("height".into(), json!(height));
    image.insert(
        "screen_window".into(),
        json!([
            l + sx * f64::from(o.left),
            r - sx * f64::from(o.right),
            b + sy * f64::from(o.bottom),
            t - sy * f64::from(o.top)
        ]),
    );
    image.insert(
        "data_window".into(),
        json!([
            -i64::from(o.left),
            -i64::from(o.top),
            i64::from(width) + i64::from(o.right),
            i64::from(height) + i64::from(o.bottom)
        ]),
    );
    image.insert("overscan".into(), json!([o.left, o.top, o.right, o.bottom]));
    if text.contains('\n') {
        let mut out = serde_json::to_string_pretty(&v).ok()?;
        if text.ends_with('\n') {
            out.push('\n');
        }
        Some(out)
    } else {
        serde_json::to_string(&v).ok()
    }
}

/// Writes `value` (pretty-printed, with a final newline) to `path` atomically.
///
/// # Errors
/// An [`AtomicWriteError`] naming `path`.
pub fn write_json(path: &Path, value: &Value) -> Result<(), AtomicWriteError> {
    let mut text = serde_json::to_string_pretty(value).unwrap_or_default();
    text.push('\n');
    write_atomically(path, |out| out.write_all(text.as_bytes()))
}

/// A matrix as rows (column-vector convention).
fn rows(m: Mat4) -> Value {
    json!((0..4).map(|r| m.row(r).to_array()).collect::<Vec<_>>())
}

/// A number, or `null` when it is not finite (JSON has no infinity).
fn num(v: f64) -> Value {
    if v.is_finite() { json!(v) } else { Value::Null }
}

/// The camera metadata of one frame (see the module documentation).
///
/// # Errors
/// [`RenderError::Camera`] when a camera transform is singular.
pub fn camera_json(scene: &Scene, prepared: &Prepared, frame: Option<i64>) -> Result<Value, RenderError> {
    let cam = &scene.camera;
    let motion =
        camera_motion(cam.environment().world_to_camera(), cam.shutter).map_err(RenderError::Camera)?;
    let w2c = |t: f32| Mat4::from(motion.object_to_world(t).inverse());
    let (open, close) = (w2c(0.0), w2c(1.0));
    let parameters: serde_json::Map<String, Value> = (scene.projection_params.entries().iter())
        .map(|e| {
            let v = match &e.value {
                ParamValue::Floats(v) => json!(v),
                ParamValue::Ints(v) => json!(v),
                ParamValue::Strings(v) => json!(v),
            };
            (e.name.clone(), v)
        })
        .collect();
    let win = cam.screen_window();
    let crop = cam.pixels();
    let props = prepared.stage().properties();
    let mut j = json!({
        "schema": SCHEMA,
        "frame": frame,
        "projection": scene.projection,
        "parameters": parameters,
        "image": {
            "width": cam.format.width,
            "height": cam.format.height,
            "pixel_aspect": cam.format.pixel_aspect,
            "screen_window": [win.left, win.right, win.bottom, win.top],
            "data_window": [crop.x0, crop.y0, crop.x1, crop.y1],
        },
        "shutter": [cam.shutter.0, cam.shutter.1],
        "clipping": [num(cam.clipping.0 as f64), num(cam.clipping.1 as f64)],
        "deep_metric": match props.deep_metric {
            DeepMetric::CameraZ => "CameraZ",
            DeepMetric::RayLength => "RayLength",
        },
        "field_of_view": props.field_of_view.map(f64::from).map(num),
        "world_to_camera": {"open": rows(open), "close": rows(close)},
    });
    let (model, equivalents) = equivalents::sections(scene, props.field_of_view);
    j["camera_model"] = model;
    j["equivalents"] = equivalents;
    if scene.projection == "PxrRollingShutter" {
        let list = &scene.projection_params;
        let text = |n: &str, d: &str| match list.get(n).map(|e| &e.value) {
            Some(ParamValue::Strings(v)) => v.first().cloned().unwrap_or_else(|| d.to_string()),
            _ => d.to_string(),
        };
        let duration = match list.get("duration").map(|e| &e.value) {
            Some(ParamValue::Floats(v)) => v.first().map(|&x| f64::from(x)).unwrap_or(1.0),
            _ => 1.0,
        };
        j["rolling_shutter"] = json!({"sweep": text("sweep", "down"), "duration": duration});
    }
    if let Some(config) = &scene.sensor {
        j["sensor"] = crate::sensor::record(config, props, (cam.format.width, cam.format.height));
    }
    if let Some(intr) = intrinsics(scene, props.field_of_view) {
        let flip = Mat4::from(Affine3A::from_scale(glam::Vec3::new(1.0, -1.0, 1.0)));
        let [fx, fy, cx, cy] = intr.pinhole;
        j["opencv"] = json!({
            "model": intr.opencv_model,
            "K": [[fx, 0.0, cx - 0.5], [0.0, fy, cy - 0.5], [0.0, 0.0, 1.0]],
            "dist": intr.opencv_dist,
            "world_to_camera": {"open": rows(flip * open), "close": rows(flip * close)},
        });
        if !intr.colmap_model.is_empty() {
            j["colmap"] = json!({
                "model": intr.colmap_model,
                "width": cam.format.width,
                "height": cam.format.height,
                "params": intr.colmap_params,
            });
        }
    }
    Ok(j)
}

/// A pinhole-equivalent camera's intrinsics at the render's size.
struct Intrinsics {
    /// `fx, fy, cx, cy` in raster coordinates (COLMAP's convention).
    pinhole: [f64; 4],
    opencv_model: &'static str,
    opencv_dist: Vec<f64>,
    colmap_model: String,
    colmap_params: Vec<f64>,
}

/// The intrinsics of `scene`'s camera when it is pinhole-equivalent (see the module documentation).
fn intrinsics(scene: &Scene, field_of_view: Option<f32>) -> Option<Intrinsics> {
    match scene.projection.as_str() {
        "PxrPerspective" => {
            let Ok(equivalents::Lens::Pinhole { f, c, .. }) = equivalents::lens(scene, field_of_view) else {
                return None;
            };
            let p = [f[0], f[1], c[0], c[1]];
            Some(Intrinsics {
                pinhole: p,
                opencv_model: "pinhole",
                opencv_dist: Vec::new(),
                colmap_model: "PINHOLE".into(),
                colmap_params: p.to_vec(),
            })
        }
        "CalibratedCamera" => {
            let format = scene.camera.format;
            calibrated(scene, format.width as f64, format.height as f64)
        }
        _ => None,
    }
}

/// A calibrated camera's own model in COLMAP's and OpenCV's terms, rescaled to `w × h`.
fn calibrated(scene: &Scene, w: f64, h: f64) -> Option<Intrinsics> {
    let list = &scene.projection_params;
    let string = |n: &str| match &list.get(n)?.value {
        ParamValue::Strings(v) => v.first().cloned(),
        _ => None,
    };
    let model = string("model")?;
    let params: Vec<f64> = match &list.get("params")?.value {
        ParamValue::Floats(v) => v.iter().map(|&x| x as f64).collect(),
        _ => return None,
    };
    let (rw, rh) = match &list.get("resolution")?.value {
        ParamValue::Ints(v) if v.len() == 2 => (v[0] as f64, v[1] as f64),
        _ => return None,
    };
    let colmap_family = model != "OPENCV_PINHOLE";
    // Pixel centres: COLMAP's models default to COLMAP's convention, OPENCV_PINHOLE to OpenCV's.
    let shift = match string("pixelConvention").as_deref().unwrap_or("auto") {
        "colmap" => 0.0,
        "opencv" => 0.5,
        "matlab" => -0.5,
        _ if colmap_family => 0.0,
        _ => 0.5,
    };
    // (focal parameters, principal point index, OpenCV model, distortion parameter range)
    let (single_f, c, opencv_model, dist): (bool, usize, &str, std::ops::Range<usize>) = match model.as_str()
    {
        "SIMPLE_PINHOLE" => (true, 1, "pinhole", 3..3),
        "PINHOLE" => (false, 2, "pinhole", 4..4),
        "SIMPLE_RADIAL" => (true, 1, "pinhole", 3..4),
        "RADIAL" => (true, 1, "pinhole", 3..5),
        "OPENCV" | "FULL_OPENCV" | "OPENCV_PINHOLE" => (false, 2, "pinhole", 4..params.len()),
        "OPENCV_FISHEYE" => (false, 2, "fisheye", 4..8),
        _ => return None,
    };
    if params.len() < dist.end.max(c + 2) {
        return None;
    }
    let (sx, sy) = (w / rw, h / rh);
    let (fx, fy) = if single_f {
        (params[0] * sx, params[0] * sy)
    } else {
        (params[0] * sx, params[1] * sy)
    };
    let (cx, cy) = ((params[c] + shift) * sx, (params[c + 1] + shift) * sy);
    let k: Vec<f64> = params[dist.clone()].to_vec();
    // OpenCV's order: k1 k2 p1 p2 k3 k4 k5 k6 ...; COLMAP's radial models give k1 (k2) only.
    let opencv_dist = match model.as_str() {
        "SIMPLE_RADIAL" => vec![k[0], 0.0, 0.0, 0.0],
        "RADIAL" => vec![k[0], k[1], 0.0, 0.0],
        _ => k.clone(),
    };
    let mut colmap_params = if single_f && sx == sy {
        vec![fx, cx, cy]
    } else if single_f {
        return None;
    } else {
        vec![fx, fy, cx, cy]
    };
    colmap_params.extend(&k);
    let colmap_model = if model == "OPENCV_PINHOLE" {
        match k.len() {
            0 => "PINHOLE",
            4 => "OPENCV",
            8 => "FULL_OPENCV",
            _ => "",
        }
        .to_string()
    } else {
        model.clone()
    };
    Some(Intrinsics {
        pinhole: [fx, fy, cx, cy],
        opencv_model,
        opencv_dist,
        colmap_model,
        colmap_params,
    })
}

#[cfg(test)]
mod tests;
