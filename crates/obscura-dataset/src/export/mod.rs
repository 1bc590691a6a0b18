//! Camera exports: a dataset's cameras in the file formats vision tools train with.
//!
//! [`write_exports`] takes each camera of a dataset (one, or several for a rig) with its frames —
//! each frame's image path and its camera JSON as `obscura_render::metadata::camera_json` writes it
//! — and writes, under the dataset root:
//!
//! | format | files | module |
//! |---|---|---|
//! | [`ExportFormat::Colmap`] | `colmap/cameras.txt`, `images.txt`, `points3D.txt` (empty), `rigs.txt`, `frames.txt` | [`colmap`] |
//! | [`ExportFormat::Nerfstudio`] | `transforms.json` (one camera) or `nerfstudio/<camera>/transforms.json` (a rig) | [`nerfstudio`] |
//! | [`ExportFormat::Gsplat`] | `gsplat/cameras.json` | [`gsplat`] |
//!
//! # Exactness
//!
//! Each format's intrinsics are read from the camera JSON's `equivalents` section, the project's one
//! equivalence table (`obscura_render::metadata::equivalents`, whose documentation gives each mapping
//! as a formula and the exactness table). An entry is either the format's exact model or
//! `{"model": null, "reason": …}`; the exporters never approximate: a camera with no exact
//! equivalent is written as a statement of that (a comment in COLMAP's text files, a `reason` key in
//! the JSON files, pointing to `obscura rays`) and a warning is returned.
//!
//! # Poses
//!
//! All three formats need proper rotations in a right-handed world. RenderMan's camera space is
//! left-handed, so a scene whose world-to-camera matrices are rotations has a left-handed world;
//! the exports then use Obscura's world with z negated (`S = diag(1, 1, −1)`, [`world_flip`]) and
//! say so in each file and in a warning ([`WORLD_FLIPPED`]). Below, `M` is the world-to-camera
//! matrix composed with `S`.
//!
//! The camera JSON's `world_to_camera` is Obscura's camera space (x right, y up, z forward) at shutter
//! open and close. COLMAP and gsplat take world-to-camera in OpenCV's axes, `diag(1, −1, 1)·M`;
//! nerfstudio takes camera-to-world in OpenGL's (x right, y up, z back), `M⁻¹·diag(1, 1, −1)`. A
//! frame whose camera moves during the shutter has no single pose: COLMAP and nerfstudio get the
//! pose at shutter open with a warning; gsplat gets both (`viewmats` and, for a rolling shutter,
//! `viewmats_rs` at the first and last rows' exposure centres).

pub mod colmap;
pub mod gsplat;
pub mod nerfstudio;

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use glam::{DMat3, DMat4, DQuat, DVec3};
use serde_json::Value;

/// A file format [`write_exports`] writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExportFormat {
    /// COLMAP's sparse model text files (`colmap/`).
    Colmap,
    /// nerfstudio's `transforms.json`.
    Nerfstudio,
    /// gsplat/3DGUT's camera arguments (`gsplat/cameras.json`).
    Gsplat,
}

impl ExportFormat {
    /// Every format, in the order of their names.
    pub const ALL: [ExportFormat; 3] = [
        ExportFormat::Colmap,
        ExportFormat::Nerfstudio,
        ExportFormat::Gsplat,
    ];

    /// The name `FromStr` and `--exports` use.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ExportFormat::Colmap => "colmap",
            ExportFormat::Nerfstudio => "nerfstudio",
            ExportFormat::Gsplat => "gsplat",
        }
    }
}

impl fmt::Display for ExportFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An unknown format name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown export format \"{0}\": expected one of colmap, nerfstudio, gsplat")]
pub struct UnknownFormat(pub String);

impl FromStr for ExportFormat {
    type Err = UnknownFormat;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ExportFormat::ALL
            .into_iter()
            .find(|f| f.name() == s.trim())
            .ok_or_else(|| UnknownFormat(s.to_string()))
    }
}

/// One frame of one camera.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportFrame {
    /// The frame number.
    pub frame: i32,
    /// The image, relative to the dataset root.
    pub image: PathBuf,
    /// That frame's camera JSON as `obscura_render::metadata::camera_json` writes it.
    pub camera: Value,
}

/// One camera of a dataset (of a rig) and its frames.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportCamera {
    /// The camera's name (a directory name in the dataset layout).
    pub name: String,
    /// Its frames, in order.
    pub frames: Vec<ExportFrame>,
}

/// Why an export could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// A camera JSON lacks what the export needs.
    #[error("camera \"{camera}\", frame {frame}: {message}")]
    Camera {
        /// The camera's name.
        camera: String,
        /// The frame number.
        frame: i32,
        /// What is wrong, and what was expected.
        message: String,
    },
    /// A file could not be written.
    #[error(transparent)]
    Write(#[from] obscura_image::atomic::AtomicWriteError),
    /// A directory could not be created.
    #[error("cannot create {path}: {source}")]
    Dir {
        /// The directory.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// Writes each of `formats` for `cameras` under `root` (the layout in the module documentation);
/// returns the warnings: every camera or frame that a format cannot describe exactly, and every pose
/// that is not one pose (a camera moving during the shutter).
///
/// # Errors
/// [`ExportError`] naming the camera and frame whose JSON lacks a field, or the file that could not
/// be written.
pub fn write_exports(
    root: &Path,
    cameras: &[ExportCamera],
    formats: &[ExportFormat],
) -> Result<Vec<String>, ExportError> {
    let mut warnings = Vec::new();
    let world = world_flip(cameras)?;
    if world != DMat4::IDENTITY && !formats.is_empty() {
        warnings.push(format!("exports: {WORLD_FLIPPED}"));
    }
    let mut done = Vec::new();
    for &format in formats {
        if done.contains(&format) {
            continue;
        }
        done.push(format);
        match format {
            ExportFormat::Colmap => colmap::write(root, cameras, world, &mut warnings)?,
            ExportFormat::Nerfstudio => nerfstudio::write(root, cameras, world, &mut warnings)?,
            ExportFormat::Gsplat => gsplat::write(root, cameras, world, &mut warnings)?,
        }
    }
    let mut seen = std::collections::HashSet::new();
    warnings.retain(|w| seen.insert(w.clone()));
    Ok(warnings)
}

/// Creates `dir` and its parents.
pub(crate) fn create_dir(dir: &Path) -> Result<(), ExportError> {
    std::fs::create_dir_all(dir).map_err(|source| ExportError::Dir {
        path: dir.to_path_buf(),
        source,
    })
}

/// A frame being exported, with its camera's name for messages.
pub(crate) struct Item<'a> {
    pub camera: &'a ExportCamera,
    pub frame: &'a ExportFrame,
}

impl Item<'_> {
    /// An [`ExportError::Camera`] for this frame.
    pub fn error(&self, message: impl Into<String>) -> ExportError {
        ExportError::Camera {
            camera: self.camera.name.clone(),
            frame: self.frame.frame,
            message: message.into(),
        }
    }

    /// The format's entry of `equivalents`: `Ok(entry)` when exact, `Err(reason)` when the format has
    /// no exact equivalent (`model`/`camera_model` null).
    pub fn equivalent(&self, format: ExportFormat) -> Result<Result<&Value, String>, ExportError> {
        let entry = &self.frame.camera["equivalents"][format.name()];
        if entry.is_null() {
            return Err(self.error(format!(
                "the camera JSON has no equivalents.{format} (written by an Obscura older than the exports; re-render)"
            )));
        }
        let key = if format == ExportFormat::Nerfstudio {
            "camera_model"
        } else {
            "model"
        };
        if entry[key].is_null() {
            let reason = entry["reason"]
                .as_str()
                .unwrap_or("no exact equivalent")
                .to_string();
            return Ok(Err(reason));
        }
        Ok(Ok(entry))
    }

    /// The world-to-camera matrix at `when` ("open" or "close"), Obscura's camera axes.
    pub fn world_to_camera(&self, when: &str) -> Result<DMat4, ExportError> {
        let v = &self.frame.camera["world_to_camera"][when];
        let rows: Option<Vec<Vec<f64>>> = v.as_array().map(|rows| {
            rows.iter()
                .filter_map(|r| r.as_array().map(|r| r.iter().filter_map(Value::as_f64).collect()))
                .collect()
        });
        match rows {
            Some(r) if r.len() == 4 && r.iter().all(|r| r.len() == 4) => Ok(DMat4::from_cols_array_2d(&[
                [r[0][0], r[1][0], r[2][0], r[3][0]],
                [r[0][1], r[1][1], r[2][1], r[3][1]],
                [r[0][2], r[1][2], r[2][2], r[3][2]],
                [r[0][3], r[1][3], r[2][3], r[3][3]],
            ])),
            _ => Err(self.error(format!(
                "world_to_camera.{when}: expected a 4×4 matrix as 4 rows of 4 numbers"
            ))),
        }
    }

    /// True when the camera does not move during the shutter.
    pub fn still(&self) -> Result<bool, ExportError> {
        Ok(self
            .world_to_camera("open")?
            .abs_diff_eq(self.world_to_camera("close")?, 1e-12))
    }

    /// The image path with `/` separators.
    pub fn image_name(&self) -> String {
        let parts: Vec<String> = (self.frame.image.components())
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect();
        parts.join("/")
    }

    /// World-to-camera in OpenCV's camera axes and the export's world (`world` from [`world_flip`]).
    pub fn opencv_matrix(&self, when: &str, world: DMat4) -> Result<DMat4, ExportError> {
        Ok(FLIP_Y * self.world_to_camera(when)? * world)
    }

    /// A rigid world-to-camera pose in OpenCV's axes at `when`, in the export's world.
    pub fn opencv_pose(&self, when: &str, world: DMat4) -> Result<Pose, ExportError> {
        let m = self.opencv_matrix(when, world)?;
        Pose::from_matrix(m).ok_or_else(|| {
            self.error(format!(
                "world_to_camera.{when} is not a rotation and a translation (scaled or sheared camera transform)"
            ))
        })
    }
}

/// What the exports say about their world when it is Obscura's with z negated.
pub const WORLD_FLIPPED: &str = "the scene's world is left-handed (RenderMan's convention: det(world_to_camera) > 0 with a +Y-up, +Z-forward camera), and COLMAP, nerfstudio and gsplat need right-handed rotations: the exported world is Obscura's with z negated, a world point (x, y, z) is (x, y, -z) here";

/// The matrix from Obscura's world to the exports' world: the identity when the scene's camera
/// transforms are right-handed rotations after the camera-axis flip, else `diag(1, 1, −1)`
/// ([`WORLD_FLIPPED`]). RenderMan's camera space (+Y up, +Z forward) is left-handed, so a scene
/// whose world-to-camera is a proper rotation has a left-handed world; one written with RenderMan's
/// usual `Scale 1 1 -1` (from a right-handed application) has a right-handed one.
///
/// # Errors
/// [`ExportError::Camera`] when the frames disagree (some left-handed, some right-handed).
pub fn world_flip(cameras: &[ExportCamera]) -> Result<DMat4, ExportError> {
    let mut flip = None;
    for camera in cameras {
        for frame in &camera.frames {
            let item = Item { camera, frame };
            let left = DMat3::from_mat4(item.world_to_camera("open")?).determinant() > 0.0;
            match flip {
                None => flip = Some(left),
                Some(f) if f != left => {
                    return Err(item.error(
                        "its world_to_camera's handedness differs from the first frame's: one world cannot hold both",
                    ));
                }
                Some(_) => {}
            }
        }
    }
    Ok(if flip == Some(true) {
        DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0))
    } else {
        DMat4::IDENTITY
    })
}

/// `diag(1, −1, 1, 1)`: Obscura's camera axes to OpenCV's (and back).
pub(crate) const FLIP_Y: DMat4 = DMat4::from_cols_array(&[
    1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
]);

/// A rigid transform `x ↦ R·x + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// The rotation, unit quaternion.
    pub rotation: DQuat,
    /// The translation.
    pub translation: DVec3,
}

impl Pose {
    /// The rigid part of `m`, or `None` when its 3×3 block is not a rotation (to 1e-6).
    #[must_use]
    pub fn from_matrix(m: DMat4) -> Option<Pose> {
        let r = DMat3::from_mat4(m);
        let should_be_identity = r.transpose() * r;
        if !should_be_identity.abs_diff_eq(DMat3::IDENTITY, 1e-6) || r.determinant() <= 0.0 {
            return None;
        }
        Some(Pose {
            rotation: DQuat::from_mat3(&r).normalize(),
            translation: m.w_axis.truncate(),
        })
    }

    /// `self ∘ other`.
    #[must_use]
    pub fn compose(&self, other: &Pose) -> Pose {
        Pose {
            rotation: (self.rotation * other.rotation).normalize(),
            translation: self.rotation * other.translation + self.translation,
        }
    }

    /// The inverse transform.
    #[must_use]
    pub fn inverse(&self) -> Pose {
        let r = self.rotation.conjugate();
        Pose {
            rotation: r,
            translation: -(r * self.translation),
        }
    }

    /// As a 4×4 matrix.
    #[must_use]
    pub fn matrix(&self) -> DMat4 {
        DMat4::from_rotation_translation(self.rotation, self.translation)
    }

    /// The quaternion as COLMAP writes it: `qw qx qy qz`, with `qw ≥ 0`.
    #[must_use]
    pub fn colmap_quaternion(&self) -> [f64; 4] {
        let q = if self.rotation.w < 0.0 {
            -self.rotation
        } else {
            self.rotation
        };
        [q.w, q.x, q.y, q.z]
    }
}

/// A 4×4 matrix as rows (column-vector convention), for JSON.
pub(crate) fn rows(m: DMat4) -> Value {
    serde_json::json!((0..4).map(|r| m.row(r).to_array()).collect::<Vec<_>>())
}

#[cfg(test)]
mod tests;
