//! Camera rigs: several cameras rendered from one scene at one time, each with its own projection and
//! its own pose relative to the scene's camera (the **rig base**).
//!
//! # The pose convention
//!
//! Every pose is held as `camera_to_base`, a rigid 4×4 matrix acting on column vectors in
//! RenderMan's camera space (+X right, +Y up, looking down +Z, left-handed as RenderMan's is): a point
//! `p` in the rig camera's space is `camera_to_base · p` in the base camera's space. The rig camera's
//! world-to-camera at each motion sample of the scene's camera is therefore
//!
//! ```text
//! world_to_camera_rig(t) = camera_to_base⁻¹ · world_to_camera_base(t)
//! ```
//!
//! (column vectors; the renderer's row-vector matrices are the transposes).
//!
//! # Rig files
//!
//! | file | recognised by | cameras |
//! |---|---|---|
//! | Obscura rig (JSON) | `"schema": "obscura-rig/1"` | `cameras`: named, each a projection + parameters or a calibration file, `translation` and `rotation` relative to the base; `ring`: N cameras about +Y |
//! | Kalibr `camchain.yaml` | a mapping `cam0`, `cam1`, … with `camera_model` | each `camN` through its calibration (`CalibratedCamera`), posed by the chain of `T_cn_cnm1`; `cam0` is the base |
//! | COLMAP `rig_config.json` (COLMAP ≥ 3.12, `colmap rig_configurator`) | a JSON list of `{ "cameras": [ … ] }` | each camera named by its `image_prefix`, posed by `cam_from_rig_rotation` (w, x, y, z) and `cam_from_rig_translation`; the `ref_sensor` is the base; intrinsics from `camera_model_name` + `camera_params` when given |
//!
//! ## Obscura rig file
//!
//! ```json
//! {
//!   "schema": "obscura-rig/1",
//!   "cameras": [
//!     {"name": "left",  "translation": [-0.06, 0, 0]},
//!     {"name": "right", "translation": [0.06, 0, 0], "rotation": {"axis": [0, 1, 0], "degrees": 2},
//!      "projection": "PxrFisheye", "params": {"fov": 200}},
//!     {"name": "lab",   "calibration": "cal/camera.yaml", "camera": "cam0", "rotation": [[1,0,0],[0,1,0],[0,0,1]]}
//!   ]
//! }
//! ```
//!
//! or a ring, `{"schema": "obscura-rig/1", "ring": {"count": 6, "radius": 0.1, "projection": …,
//! "params": …}}`: camera `ringK` (K from 0) turned `K·360°/count` about +Y (from +Z towards +X) and
//! moved `radius` along its own +Z. `translation` is in scene units in the base camera's space;
//! `rotation` is a 3×3 matrix (rows, column vectors: the rig camera's axes are its columns), an
//! `{"axis", "degrees"}` pair (Rodrigues' formula: about +Y a positive angle turns +Z towards +X), or a
//! quaternion `{"wxyz": [w, x, y, z]}`. A camera without a projection or calibration renders through
//! the dataset's own (the scene's, or `--projection`/`--calibration`). Relative paths are read from
//! the rig file's directory.
//!
//! ## From Kalibr and COLMAP (+Y down)
//!
//! Kalibr and COLMAP use OpenCV's camera frame (+X right, **+Y down**, looking down +Z). With
//! `F = diag(1, −1, 1, 1)` (its own inverse), a pose `T_cv` between two OpenCV camera frames is
//! `F · T_cv · F` between the same cameras in RenderMan's space. Kalibr's `T_cn_cnm1` maps camera
//! n−1's points to camera n's, so `T_cn_c0 = T_cn_cnm1 · … · T_c1_c0` and
//! `camera_to_base(n) = F · T_cn_c0⁻¹ · F`. COLMAP's `cam_from_rig` maps rig points to the camera, and
//! the reference sensor is the base: `camera_to_base = F · ref_from_rig · cam_from_rig⁻¹ · F`.

use std::path::{Path, PathBuf};

use glam::{DMat3, DMat4, DQuat, DVec3};
use obscura_render::job::Calibrated;
use serde_json::Value;

use crate::layout::check_camera_name;

/// The schema an Obscura rig file names.
pub const RIG_SCHEMA: &str = "obscura-rig/1";

/// What a rig camera renders through.
#[derive(Debug, Clone)]
pub enum Lens {
    /// The dataset's own projection (the scene's, or the command line's).
    Base,
    /// A projection by name (a built-in or a plugin) with parameters given as JSON (name → number,
    /// list or string), read against the projection's table when it is loaded.
    Projection {
        /// The projection's name or plugin path.
        name: String,
        /// Its parameters.
        params: serde_json::Map<String, Value>,
    },
    /// A real camera from a calibration file (`CalibratedCamera`).
    Calibration(Box<Calibrated>),
}

/// One camera of a rig.
#[derive(Debug, Clone)]
pub struct RigCamera {
    /// Its name: the directory its images are written to.
    pub name: String,
    /// What it renders through.
    pub lens: Lens,
    /// Its pose: the rigid transform from its camera space to the base camera's (column vectors,
    /// RenderMan's camera space; see the module documentation).
    pub camera_to_base: DMat4,
}

/// A rig: its cameras in order, and where it was read from.
#[derive(Debug, Clone)]
pub struct Rig {
    /// The cameras, names unique.
    pub cameras: Vec<RigCamera>,
    /// The file it came from, or `None` for the one-camera rig of a dataset without `--rig`.
    pub file: Option<PathBuf>,
}

/// A rig file could not be read: the file, the line when one is to blame, the key and what was
/// expected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct RigError {
    /// The file.
    pub file: String,
    /// The 1-based line, when known.
    pub line: Option<usize>,
    /// What is wrong, naming the key.
    pub message: String,
}

/// `diag(1, −1, 1, 1)`: OpenCV's camera frame ↔ RenderMan's.
#[must_use]
pub fn flip_y() -> DMat4 {
    DMat4::from_diagonal(glam::DVec4::new(1.0, -1.0, 1.0, 1.0))
}

/// A pose between two OpenCV (+Y down) camera frames as the same pose between RenderMan frames:
/// `F · m · F`.
#[must_use]
pub fn from_opencv(m: DMat4) -> DMat4 {
    flip_y() * m * flip_y()
}

impl Rig {
    /// The rig of a dataset without `--rig`: one camera, [`crate::layout::DEFAULT_CAMERA`], at the
    /// base through the dataset's projection.
    #[must_use]
    pub fn single() -> Self {
        Rig {
            cameras: vec![RigCamera {
                name: crate::layout::DEFAULT_CAMERA.to_string(),
                lens: Lens::Base,
                camera_to_base: DMat4::IDENTITY,
            }],
            file: None,
        }
    }

    /// Reads the rig file at `path` (see the module documentation for the kinds).
    ///
    /// # Errors
    /// A [`RigError`] naming the file, the line or key, and what was expected.
    pub fn load(path: &Path) -> Result<Self, RigError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| RigError {
            file: file.clone(),
            line: None,
            message: format!("cannot read the rig file: {e}"),
        })?;
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default();
        let rig = if matches!(ext.as_str(), "yaml" | "yml") {
            kalibr(path, &text)?
        } else {
            let value: Value = serde_json::from_str(&text).map_err(|e| RigError {
                file: file.clone(),
                line: Some(e.line()),
                message: format!(
                    "not JSON ({e}); expected an Obscura rig (\"schema\": \"{RIG_SCHEMA}\"), a COLMAP rig_config.json, or a Kalibr camchain .yaml"
                ),
            })?;
            let base = path.parent().unwrap_or(Path::new(""));
            let r = Reader {
                file: &file,
                text: &text,
                base,
            };
            match &value {
                Value::Array(_) => r.colmap(&value)?,
                Value::Object(o) if o.get("schema").and_then(Value::as_str) == Some(RIG_SCHEMA) => {
                    r.obscura(o)?
                }
                _ => {
                    return Err(RigError {
                        file,
                        line: Some(1),
                        message: format!(
                            "schema: expected \"schema\": \"{RIG_SCHEMA}\" (an Obscura rig) or a JSON list of rigs (COLMAP's rig_config.json)"
                        ),
                    });
                }
            }
        };
        let mut seen = std::collections::HashSet::new();
        for c in &rig {
            if !seen.insert(c.name.as_str()) {
                return Err(RigError {
                    file: file.clone(),
                    line: None,
                    message: format!(
                        "two cameras are named '{}'; each camera needs its own name (its image directory)",
                        c.name
                    ),
                });
            }
        }
        if rig.is_empty() {
            return Err(RigError {
                file,
                line: None,
                message: "the rig has no camera".into(),
            });
        }
        Ok(Rig {
            cameras: rig,
            file: Some(path.to_path_buf()),
        })
    }
}

/// Reads JSON rig files, keeping the file's text to find lines for errors.
struct Reader<'a> {
    file: &'a str,
    text: &'a str,
    base: &'a Path,
}

impl Reader<'_> {
    /// An error at the line where `needle` (a quoted key or name) first appears, if it does.
    fn err(&self, needle: &str, message: String) -> RigError {
        let line = self.text.lines().position(|l| l.contains(needle)).map(|i| i + 1);
        RigError {
            file: self.file.to_string(),
            line,
            message,
        }
    }

    fn numbers(&self, v: &Value, n: usize, key: &str, near: &str) -> Result<Vec<f64>, RigError> {
        let list = v
            .as_array()
            .filter(|a| a.len() == n)
            .and_then(|a| a.iter().map(Value::as_f64).collect::<Option<Vec<_>>>());
        list.filter(|l| l.iter().all(|x| x.is_finite()))
            .ok_or_else(|| self.err(near, format!("{key}: expected a list of {n} numbers, got {v}")))
    }

    /// A rotation as the Obscura rig file spells it (see the module documentation).
    fn rotation(&self, v: &Value, key: &str, near: &str) -> Result<DMat3, RigError> {
        if let Some(rows) = v.as_array() {
            let rows: Vec<Vec<f64>> = rows
                .iter()
                .map(|r| self.numbers(r, 3, key, near))
                .collect::<Result<_, _>>()
                .ok()
                .filter(|r: &Vec<Vec<f64>>| r.len() == 3)
                .ok_or_else(|| {
                    self.err(
                        near,
                        format!("{key}: expected a 3x3 matrix (three rows of three numbers), got {v}"),
                    )
                })?;
            let m = DMat3::from_cols_array_2d(&[
                [rows[0][0], rows[1][0], rows[2][0]],
                [rows[0][1], rows[1][1], rows[2][1]],
                [rows[0][2], rows[1][2], rows[2][2]],
            ]);
            let orthonormal = (m.transpose() * m - DMat3::IDENTITY)
                .to_cols_array()
                .iter()
                .all(|x| x.abs() < 1e-6);
            if !orthonormal || (m.determinant() - 1.0).abs() > 1e-6 {
                return Err(self.err(
                    near,
                    format!("{key}: the matrix is not a rotation (orthonormal with determinant 1, to 1e-6)"),
                ));
            }
            return Ok(m);
        }
        if let Some(q) = v.get("wxyz") {
            let q = self.numbers(q, 4, &format!("{key}.wxyz"), near)?;
            let quat = DQuat::from_xyzw(q[1], q[2], q[3], q[0]);
            if (quat.length() - 1.0).abs() > 1e-6 {
                return Err(self.err(
                    near,
                    format!(
                        "{key}.wxyz: the quaternion's length is {}; expected 1 (to 1e-6)",
                        quat.length()
                    ),
                ));
            }
            return Ok(DMat3::from_quat(quat));
        }
        if let (Some(axis), Some(deg)) = (v.get("axis"), v.get("degrees")) {
            let a = self.numbers(axis, 3, &format!("{key}.axis"), near)?;
            let deg = deg
                .as_f64()
                .filter(|d| d.is_finite())
                .ok_or_else(|| self.err(near, format!("{key}.degrees: expected a number, got {deg}")))?;
            let axis = DVec3::new(a[0], a[1], a[2]);
            if axis.length() < 1e-12 {
                return Err(self.err(near, format!("{key}.axis: the axis is zero")));
            }
            return Ok(rotate(axis.normalize(), deg));
        }
        Err(self.err(near, format!("{key}: expected a 3x3 matrix, {{\"axis\": [x, y, z], \"degrees\": d}} or {{\"wxyz\": [w, x, y, z]}}, got {v}")))
    }

    /// The lens of an Obscura rig camera (or ring) entry.
    fn lens(&self, o: &serde_json::Map<String, Value>, key: &str, near: &str) -> Result<Lens, RigError> {
        let params =
            match o.get("params") {
                None => serde_json::Map::new(),
                Some(Value::Object(p)) => p.clone(),
                Some(v) => return Err(self.err(
                    near,
                    format!(
                        "{key}.params: expected an object of parameter values (e.g. {{\"fov\": 60}}), got {v}"
                    ),
                )),
            };
        match (o.get("projection"), o.get("calibration")) {
            (Some(_), Some(_)) => Err(self.err(
                near,
                format!("{key}: give either projection or calibration, not both"),
            )),
            (Some(p), None) => {
                let name = p.as_str().ok_or_else(|| {
                    self.err(
                        near,
                        format!("{key}.projection: expected a projection name, got {p}"),
                    )
                })?;
                Ok(Lens::Projection {
                    name: name.to_string(),
                    params,
                })
            }
            (None, Some(c)) => {
                let rel = c.as_str().ok_or_else(|| {
                    self.err(near, format!("{key}.calibration: expected a file path, got {c}"))
                })?;
                if !params.is_empty() {
                    return Err(self.err(
                        near,
                        format!("{key}.params: a calibrated camera takes its parameters from its file"),
                    ));
                }
                let camera = o.get("camera").and_then(Value::as_str);
                let cal = Calibrated::load(&self.base.join(rel), camera)
                    .map_err(|e| self.err(near, format!("{key}.calibration: {e}")))?;
                Ok(Lens::Calibration(Box::new(cal)))
            }
            (None, None) if !params.is_empty() => {
                Err(self.err(near, format!("{key}.params: parameters need a projection")))
            }
            (None, None) => Ok(Lens::Base),
        }
    }

    fn obscura(&self, o: &serde_json::Map<String, Value>) -> Result<Vec<RigCamera>, RigError> {
        for k in o.keys() {
            if !matches!(k.as_str(), "schema" | "cameras" | "ring") {
                return Err(self.err(
                    &format!("\"{k}\""),
                    format!("{k}: unknown key; expected schema, cameras or ring"),
                ));
            }
        }
        let mut out = Vec::new();
        if let Some(ring) = o.get("ring") {
            let r = ring.as_object().ok_or_else(|| {
                self.err(
                    "\"ring\"",
                    format!("ring: expected an object {{count, radius, projection, params}}, got {ring}"),
                )
            })?;
            let count = r
                .get("count")
                .and_then(Value::as_u64)
                .filter(|&n| (1..=360).contains(&n))
                .ok_or_else(|| {
                    self.err(
                        "\"count\"",
                        "ring.count: expected an integer from 1 to 360".to_string(),
                    )
                })?;
            let radius = match r.get("radius") {
                None => 0.0,
                Some(v) => v.as_f64().filter(|x| x.is_finite() && *x >= 0.0).ok_or_else(|| {
                    self.err(
                        "\"radius\"",
                        format!("ring.radius: expected a number >= 0, got {v}"),
                    )
                })?,
            };
            for k in r.keys() {
                if !matches!(
                    k.as_str(),
                    "count" | "radius" | "projection" | "params" | "calibration" | "camera"
                ) {
                    return Err(self.err(&format!("\"{k}\""), format!("ring.{k}: unknown key; expected count, radius, projection, params, calibration, camera")));
                }
            }
            let lens = self.lens(r, "ring", "\"ring\"")?;
            for k in 0..count {
                let turn = rotate(DVec3::Y, 360.0 * k as f64 / count as f64);
                let pose = DMat4::from_mat3(turn) * DMat4::from_translation(DVec3::new(0.0, 0.0, radius));
                out.push(RigCamera {
                    name: format!("ring{k}"),
                    lens: lens.clone(),
                    camera_to_base: pose,
                });
            }
        }
        if let Some(cams) = o.get("cameras") {
            let list = cams.as_array().ok_or_else(|| {
                self.err(
                    "\"cameras\"",
                    format!("cameras: expected a list of cameras, got {cams}"),
                )
            })?;
            for (i, c) in list.iter().enumerate() {
                let key = format!("cameras[{i}]");
                let c = c.as_object().ok_or_else(|| self.err("\"cameras\"", format!("{key}: expected an object {{name, projection, params, translation, rotation}}, got {c}")))?;
                let name = c.get("name").and_then(Value::as_str).ok_or_else(|| {
                    self.err(
                        "\"cameras\"",
                        format!("{key}.name: missing; every camera needs a name"),
                    )
                })?;
                let near = format!("\"{name}\"");
                check_camera_name(name).map_err(|e| self.err(&near, format!("{key}.name: {e}")))?;
                for k in c.keys() {
                    if !matches!(
                        k.as_str(),
                        "name"
                            | "projection"
                            | "params"
                            | "calibration"
                            | "camera"
                            | "translation"
                            | "rotation"
                    ) {
                        return Err(self.err(&format!("\"{k}\""), format!("{key}.{k}: unknown key; expected name, projection, params, calibration, camera, translation, rotation")));
                    }
                }
                let t = match c.get("translation") {
                    None => DVec3::ZERO,
                    Some(v) => {
                        let t = self.numbers(v, 3, &format!("{key}.translation"), &near)?;
                        DVec3::new(t[0], t[1], t[2])
                    }
                };
                let r = match c.get("rotation") {
                    None => DMat3::IDENTITY,
                    Some(v) => self.rotation(v, &format!("{key}.rotation"), &near)?,
                };
                let lens = self.lens(c, &key, &near)?;
                out.push(RigCamera {
                    name: name.to_string(),
                    lens,
                    camera_to_base: DMat4::from_translation(t) * DMat4::from_mat3(r),
                });
            }
        }
        if o.get("cameras").is_none() && o.get("ring").is_none() {
            return Err(self.err(
                "\"schema\"",
                "expected cameras (a list) or ring (an object)".to_string(),
            ));
        }
        Ok(out)
    }

    /// COLMAP's `rig_config.json`: one rig (the first, the only one a dataset renders).
    fn colmap(&self, value: &Value) -> Result<Vec<RigCamera>, RigError> {
        let rigs = value.as_array().map(Vec::as_slice).unwrap_or_default();
        let [rig] = rigs else {
            return Err(self.err(
                "[",
                format!("expected one rig in COLMAP's rig_config.json, got {}", rigs.len()),
            ));
        };
        let cams = rig.get("cameras").and_then(Value::as_array).ok_or_else(|| {
            self.err(
                "\"cameras\"",
                "[0].cameras: expected a list of cameras".to_string(),
            )
        })?;
        let mut posed = Vec::new();
        let mut reference = None;
        for (i, c) in cams.iter().enumerate() {
            let key = format!("[0].cameras[{i}]");
            let prefix = c.get("image_prefix").and_then(Value::as_str).ok_or_else(|| {
                self.err(
                    "\"cameras\"",
                    format!("{key}.image_prefix: missing; it names the camera"),
                )
            })?;
            let near = format!("\"{prefix}\"");
            let name = prefix
                .trim_matches('/')
                .rsplit('/')
                .next()
                .unwrap_or_default()
                .to_string();
            check_camera_name(&name).map_err(|e| self.err(&near, format!("{key}.image_prefix: {e}")))?;
            let is_ref = c.get("ref_sensor").and_then(Value::as_bool).unwrap_or(false);
            let cam_from_rig = match (c.get("cam_from_rig_rotation"), c.get("cam_from_rig_translation")) {
                (Some(q), Some(t)) => {
                    let q = self.numbers(q, 4, &format!("{key}.cam_from_rig_rotation"), &near)?;
                    let t = self.numbers(t, 3, &format!("{key}.cam_from_rig_translation"), &near)?;
                    let quat = DQuat::from_xyzw(q[1], q[2], q[3], q[0]);
                    if (quat.length() - 1.0).abs() > 1e-6 {
                        return Err(self.err(&near, format!("{key}.cam_from_rig_rotation: the quaternion [w, x, y, z] has length {}; expected 1", quat.length())));
                    }
                    DMat4::from_translation(DVec3::new(t[0], t[1], t[2])) * DMat4::from_quat(quat)
                }
                (None, None) if is_ref => DMat4::IDENTITY,
                _ => return Err(self.err(&near, format!("{key}: cam_from_rig_rotation and cam_from_rig_translation are needed for every camera but the reference sensor (a dataset renders known poses)"))),
            };
            if is_ref {
                if reference.is_some() {
                    return Err(self.err(
                        &near,
                        format!("{key}.ref_sensor: a second reference sensor; a rig has one"),
                    ));
                }
                reference = Some(cam_from_rig);
            }
            let lens = match (
                c.get("camera_model_name").and_then(Value::as_str),
                c.get("camera_params"),
            ) {
                (Some(model), Some(params)) => {
                    let params: Vec<f64> = params
                        .as_array()
                        .and_then(|a| a.iter().map(Value::as_f64).collect())
                        .ok_or_else(|| {
                            self.err(&near, format!("{key}.camera_params: expected a list of numbers"))
                        })?;
                    let size = c.get("obscura_image_size").map(|s| self.numbers(s, 2, &format!("{key}.obscura_image_size"), &near)).transpose()?
                        .ok_or_else(|| self.err(&near, format!("{key}: camera_params are for an image size COLMAP's rig_config.json does not hold; add \"obscura_image_size\": [width, height]")))?;
                    let line = format!(
                        "1 {model} {} {} {}",
                        size[0],
                        size[1],
                        params
                            .iter()
                            .map(|p| format!("{p:?}"))
                            .collect::<Vec<_>>()
                            .join(" ")
                    );
                    let calibration = obscura_calibration::files::parse_as(
                        obscura_calibration::files::FileFormat::Colmap,
                        &line,
                        &format!("{} ({key})", self.file),
                        None,
                    )
                    .map_err(|e| self.err(&near, format!("{key}: {e}")))?;
                    let params = calibration
                        .param_list()
                        .map_err(|e| self.err(&near, format!("{key}: {e}")))?;
                    Lens::Calibration(Box::new(Calibrated { calibration, params }))
                }
                (None, None) => Lens::Base,
                _ => {
                    return Err(self.err(
                        &near,
                        format!("{key}: camera_model_name and camera_params go together"),
                    ));
                }
            };
            posed.push((name, lens, cam_from_rig));
        }
        let ref_from_rig = reference.ok_or_else(|| {
            self.err(
                "\"cameras\"",
                "[0].cameras: no camera has \"ref_sensor\": true; the reference sensor is the rig's base"
                    .to_string(),
            )
        })?;
        Ok(posed
            .into_iter()
            .map(|(name, lens, cam_from_rig)| RigCamera {
                name,
                lens,
                camera_to_base: from_opencv(ref_from_rig * cam_from_rig.inverse()),
            })
            .collect())
    }
}

/// A rotation by `degrees` about the unit `axis` (Rodrigues' formula on the coordinates): about +Y a
/// positive angle turns +Z towards +X.
#[must_use]
pub fn rotate(axis: DVec3, degrees: f64) -> DMat3 {
    DMat3::from_axis_angle(axis, degrees.to_radians())
}

/// A Kalibr camchain: every camera through its calibration, posed by the chain of `T_cn_cnm1`.
fn kalibr(path: &Path, text: &str) -> Result<Vec<RigCamera>, RigError> {
    let file = path.display().to_string();
    let chain = obscura_calibration::files::kalibr::chain(text, &file).map_err(|e| RigError {
        file: e.file.clone(),
        line: e.line,
        message: e.message.clone(),
    })?;
    let mut cn_from_c0 = DMat4::IDENTITY;
    let mut out = Vec::new();
    for cam in chain {
        if let Some(t) = cam.t_cn_cnm1 {
            let m = DMat4::from_cols_array_2d(&t).transpose();
            cn_from_c0 = m * cn_from_c0;
        }
        check_camera_name(&cam.id).map_err(|e| RigError {
            file: file.clone(),
            line: Some(cam.line),
            message: e,
        })?;
        let cal = Calibrated::load(path, Some(&cam.id)).map_err(|e| RigError {
            file: e.file.clone(),
            line: e.line,
            message: e.message.clone(),
        })?;
        out.push(RigCamera {
            name: cam.id,
            lens: Lens::Calibration(Box::new(cal)),
            camera_to_base: from_opencv(cn_from_c0.inverse()),
        });
    }
    Ok(out)
}
