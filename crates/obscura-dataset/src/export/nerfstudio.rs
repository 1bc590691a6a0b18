//! nerfstudio's `transforms.json`, as its `nerfstudio-data` parser reads it
//! (`nerfstudio/data/dataparsers/nerfstudio_dataparser.py`).
//!
//! - `camera_model`: a key of nerfstudio's `CAMERA_MODEL_TO_TYPE` (`nerfstudio/cameras/cameras.py`):
//!   `OPENCV` (perspective), `OPENCV_FISHEYE`, `FISHEYE624`, `EQUIRECTANGULAR`;
//! - intrinsics `fl_x fl_y cx cy w h` in raster pixels: nerfstudio casts its rays through
//!   `((x + 0.5 − cx)/fl_x, (y + 0.5 − cy)/fl_y)` for pixel `(x, y)` (`get_image_coords` with
//!   `pixel_offset = 0.5`), so the top-left pixel's centre is at (0.5, 0.5), as in COLMAP;
//! - distortion `k1 k2 k3 k4 p1 p2` (`camera_utils.get_distortion_params`), or `distortion_params`
//!   (FISHEYE624's twelve k0…k5 p0 p1 s0…s3);
//! - per frame `file_path` (relative to the directory of `transforms.json`) and `transform_matrix`,
//!   camera-to-world in OpenGL's camera axes (x right, y up, z back; `cameras.py` flips y and
//!   looks down −z): `M⁻¹·diag(1, 1, −1, 1)` of Obscura's world-to-camera `M`.
//!
//! Intrinsics the frames share are written once at the top; otherwise in each frame (the parser
//! reads each key from the top when present there, else from every frame). A camera with no exact
//! nerfstudio model gets `"camera_model": null`, the reason, and no frames.

use std::path::{Path, PathBuf};

use obscura_render::metadata::write_json;
use serde_json::{Map, Value, json};

use super::{ExportCamera, ExportError, ExportFormat, Item, rows};

/// The intrinsic keys a camera's entry can have.
const KEYS: [&str; 14] = [
    "camera_model",
    "fl_x",
    "fl_y",
    "cx",
    "cy",
    "w",
    "h",
    "k1",
    "k2",
    "k3",
    "k4",
    "p1",
    "p2",
    "distortion_params",
];

/// Writes `root/transforms.json` (one camera) or `root/nerfstudio/<camera>/transforms.json`.
pub(crate) fn write(
    root: &Path,
    cameras: &[ExportCamera],
    world: glam::DMat4,
    warnings: &mut Vec<String>,
) -> Result<(), ExportError> {
    for camera in cameras {
        let (dir, up) = if cameras.len() == 1 {
            (root.to_path_buf(), PathBuf::new())
        } else {
            (root.join("nerfstudio").join(&camera.name), PathBuf::from("../.."))
        };
        super::create_dir(&dir)?;
        write_json(
            &dir.join("transforms.json"),
            &transforms(camera, &up, world, warnings)?,
        )?;
    }
    Ok(())
}

/// The `transforms.json` of one camera; image paths are prefixed with `up`, and `world` is the
/// matrix from Obscura's world to the export's ([`super::world_flip`]).
///
/// # Errors
/// [`ExportError::Camera`] when a frame's camera JSON lacks a field.
pub fn transforms(
    camera: &ExportCamera,
    up: &Path,
    world: glam::DMat4,
    warnings: &mut Vec<String>,
) -> Result<Value, ExportError> {
    let mut intrinsics: Vec<Map<String, Value>> = Vec::new();
    let mut frames = Vec::new();
    for frame in &camera.frames {
        let item = Item { camera, frame };
        let entry = match item.equivalent(ExportFormat::Nerfstudio)? {
            Ok(e) => e,
            Err(reason) => {
                warnings.push(format!(
                    "nerfstudio: camera \"{}\" frame {} not exported: {reason}",
                    camera.name, frame.frame
                ));
                return Ok(json!({"camera_model": null, "reason": reason, "frames": []}));
            }
        };
        let keys: Map<String, Value> = KEYS
            .iter()
            .filter_map(|k| entry.get(*k).map(|v| (k.to_string(), v.clone())))
            .collect();
        if !item.still()? {
            warnings.push(format!(
                "nerfstudio: camera \"{}\" frame {} moves during the shutter; transform_matrix is its pose at shutter open",
                camera.name, frame.frame
            ));
        }
        let c2w = (item.world_to_camera("open")? * world).inverse() * OPENGL;
        let path = up.join(&frame.image);
        let name: Vec<String> = path
            .components()
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect();
        intrinsics.push(keys);
        frames.push(json!({"file_path": name.join("/"), "transform_matrix": rows(c2w)}));
    }
    let mut top = Map::new();
    let Some(first) = intrinsics.first() else {
        return Ok(json!({"frames": []}));
    };
    let models: Vec<&Value> = intrinsics.iter().map(|k| &k["camera_model"]).collect();
    if models.iter().any(|m| *m != models[0]) {
        let reason = "nerfstudio has one camera_model per transforms.json, and this camera's model changes between frames";
        warnings.push(format!(
            "nerfstudio: camera \"{}\" not exported: {reason}",
            camera.name
        ));
        return Ok(json!({"camera_model": null, "reason": reason, "frames": []}));
    }
    for key in KEYS {
        let shared = intrinsics.iter().all(|k| k.get(key) == first.get(key));
        if shared {
            if let Some(v) = first.get(key) {
                top.insert(key.to_string(), v.clone());
            }
        } else {
            for (frame, k) in frames.iter_mut().zip(&intrinsics) {
                if let Some(v) = k.get(key) {
                    frame[key] = v.clone();
                }
            }
        }
    }
    if world != glam::DMat4::IDENTITY {
        top.insert("obscura_world".into(), json!(super::WORLD_FLIPPED));
    }
    top.insert("frames".into(), Value::Array(frames));
    Ok(Value::Object(top))
}

/// `diag(1, 1, −1, 1)`: OpenGL's camera axes to Obscura's.
const OPENGL: glam::DMat4 = glam::DMat4::from_cols_array(&[
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
]);
