//! # obscura-usd
//!
//! OpenUSD stages as Obscura scenes, and Obscura's camera back out as USD.
//!
//! - [`open`] opens a stage (`.usda`, `.usdc`, `.usdz`, `.usd`; composed: sublayers, references,
//!   payloads, variants, inherits, specializes, instancing) as a [`SceneSource`]: one image per time
//!   code of `startTimeCode…endTimeCode` (frame `N` is time code `N`), or one still at
//!   `startTimeCode` (0) when the stage authors no range.
//! - [`camera`]: every `UsdGeomCamera` attribute with its fallback, and the rendered camera.
//! - [`lens`]: NVIDIA's `OmniLensDistortion*API` onto `CalibratedCamera`.
//! - [`ri`]: RenderMan's projection wiring (`ri:projection`, RenderSettings `ri:projection:name`).
//! - [`scene`]: meshes, UsdGeom primitives, materials and lights.
//! - [`export`]: a camera as `.usda`.
//!
//! The USD crate (`openusd`, pinned) is used here and nowhere else, so an upgrade touches this crate.

#![forbid(unsafe_code)]

pub mod camera;
pub mod export;
pub mod inspect;
pub mod lens;
pub mod ri;
pub mod scene;
mod shading;
mod values;
pub mod xform;

use std::path::{Path, PathBuf};

use obscura_host::CameraDesc;
use obscura_scene::source::{ImageInfo, SceneSource};
use obscura_scene::{LoadError, Scene};
use openusd::usd;

pub use camera::UsdCamera;
pub use values::Time;

/// A USD error, located: the file, the prim when one is to blame, and what was expected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}: {}{what}", prim.as_ref().map(|p| format!("prim <{p}>: ")).unwrap_or_default())]
pub struct UsdError {
    /// The stage's root file.
    pub file: String,
    /// The prim at fault, if one is.
    pub prim: Option<String>,
    /// What went wrong and what was expected.
    pub what: String,
}

impl UsdError {
    /// An error about prim `prim` of `file`.
    pub fn at(file: &str, prim: &str, what: impl Into<String>) -> Self {
        UsdError {
            file: file.into(),
            prim: Some(prim.into()),
            what: what.into(),
        }
    }

    /// An error about the file as a whole.
    pub fn file(file: &str, what: impl Into<String>) -> Self {
        UsdError {
            file: file.into(),
            prim: None,
            what: what.into(),
        }
    }
}

impl From<UsdError> for LoadError {
    fn from(e: UsdError) -> Self {
        LoadError::Usd(e.to_string())
    }
}

/// True when `path` names a USD file by its extension (`.usd`, `.usda`, `.usdc`, `.usdz`).
#[must_use]
pub fn is_usd(path: &Path) -> bool {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    matches!(ext.as_str(), "usd" | "usda" | "usdc" | "usdz")
}

/// What a user chooses when opening a stage.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Options {
    /// The camera prim to render through (`--camera PRIM`): a path, or a prim name found anywhere.
    pub camera: Option<String>,
    /// Take the image size from the stage: the RenderSettings' first product's `resolution` and
    /// `pixelAspectRatio` (else the RenderSettings' own), where authored. The command line sets it
    /// when it is given no `--format`; otherwise the caller's size stands.
    pub product_resolution: bool,
}

/// An opened stage: its metadata and cameras.
pub struct Stage {
    pub(crate) stage: usd::Stage,
    pub(crate) file: String,
    /// `upAxis` (`Y` unless authored).
    pub up_axis: String,
    /// `metersPerUnit` (0.01 unless authored).
    pub meters_per_unit: f64,
    /// `timeCodesPerSecond` (then `framesPerSecond`, then 24).
    pub time_codes_per_second: f64,
    /// `(startTimeCode, endTimeCode)` when both are authored.
    pub time_range: Option<(f64, f64)>,
    /// Composition problems found while opening (a missing sublayer, …), each naming the layer and
    /// the arc; [`Stage::composition_warnings`] has those found since, while prims were composed.
    pub warnings: Vec<String>,
}

impl Stage {
    /// Opens and composes the stage at `path`.
    ///
    /// # Errors
    /// A located [`UsdError`]: the file cannot be read or parsed (openusd's message names the construct).
    pub fn open(path: &Path) -> Result<Self, UsdError> {
        let file = path.display().to_string();
        if !path.is_file() {
            return Err(UsdError::file(&file, "no such file"));
        }
        let stage = usd::Stage::open(&file)
            .map_err(|e| UsdError::file(&file, format!("cannot open the stage: {e:#}")))?;
        let warnings = stage
            .composition_errors()
            .iter()
            .map(|e| format!("{file}: {e}"))
            .collect();
        let meta = |k: &str| stage.stage_metadata(k).ok().flatten();
        let up_axis = meta("upAxis")
            .and_then(|v| values::text(&v))
            .unwrap_or_else(|| "Y".into());
        if up_axis != "Y" && up_axis != "Z" {
            return Err(UsdError::file(
                &file,
                format!("upAxis {up_axis:?}: expected \"Y\" or \"Z\""),
            ));
        }
        let meters_per_unit = meta("metersPerUnit")
            .and_then(|v| values::scalar(&v))
            .unwrap_or(0.01);
        let time_codes_per_second = stage.time_codes_per_second();
        if !(time_codes_per_second.is_finite() && time_codes_per_second > 0.0) {
            return Err(UsdError::file(
                &file,
                format!("timeCodesPerSecond {time_codes_per_second}: expected a positive number"),
            ));
        }
        let time_range = stage
            .has_authored_time_code_range()
            .then(|| (stage.start_time_code(), stage.end_time_code()));
        Ok(Stage {
            stage,
            file,
            up_axis,
            meters_per_unit,
            time_codes_per_second,
            time_range,
            warnings,
        })
    }

    /// Every composition problem found so far (a missing reference or payload is found when the prim
    /// holding it is composed), each naming the stage's file.
    #[must_use]
    pub fn composition_warnings(&self) -> Vec<String> {
        self.stage
            .composition_errors()
            .iter()
            .map(|e| format!("{}: {e}", self.file))
            .collect()
    }

    pub(crate) fn values(&self) -> values::Values<'_> {
        values::Values {
            stage: &self.stage,
            file: &self.file,
        }
    }

    /// The stage's prims in traversal order (active, loaded, defined, not abstract; through
    /// instances), with their type names.
    ///
    /// # Errors
    /// The traversal's error, located at the file.
    pub fn prims(&self) -> Result<Vec<(String, String)>, UsdError> {
        self.prims_with(usd::PrimPredicate::DEFAULT_PROXIES)
    }

    /// Every composed prim, `over`s included (a point instancer's prototypes may sit under `over`
    /// prims and still render as its instances).
    pub(crate) fn all_prims(&self) -> Result<Vec<(String, String)>, UsdError> {
        self.prims_with(usd::PrimPredicate::ALL.with_instance_proxies(true))
    }

    fn prims_with(&self, predicate: usd::PrimPredicate) -> Result<Vec<(String, String)>, UsdError> {
        let mut paths = Vec::new();
        self.stage
            .traverse(predicate, |p| paths.push(p.as_str().to_string()))
            .map_err(|e| UsdError::file(&self.file, format!("cannot traverse the stage: {e:#}")))?;
        Ok(paths
            .into_iter()
            .map(|p| {
                let ty = self
                    .stage
                    .prim(p.as_str())
                    .type_name()
                    .ok()
                    .flatten()
                    .map(|t| t.as_str().to_string())
                    .unwrap_or_default();
                (p, ty)
            })
            .collect())
    }

    /// The paths of every `Camera` prim, in traversal order.
    ///
    /// # Errors
    /// As [`Stage::prims`].
    pub fn cameras(&self) -> Result<Vec<String>, UsdError> {
        Ok(self
            .prims()?
            .into_iter()
            .filter(|(_, t)| t == "Camera")
            .map(|(p, _)| p)
            .collect())
    }

    /// The applied API schemas of `prim`.
    #[must_use]
    pub fn api_schemas(&self, prim: &str) -> Vec<String> {
        self.stage
            .prim(prim)
            .api_schemas()
            .unwrap_or_default()
            .iter()
            .map(|t| t.as_str().to_string())
            .collect()
    }

    /// Camera `path` at `time`.
    ///
    /// # Errors
    /// A located [`UsdError`] for a value of the wrong type or out of its domain.
    pub fn camera(&self, path: &str, time: Time) -> Result<UsdCamera, UsdError> {
        UsdCamera::read(&self.values(), path, time)
    }

    /// The lens-distortion model of camera `path` at `time` (`None`: undistorted).
    ///
    /// # Errors
    /// A located [`UsdError`] for an unknown model or a missing intrinsic.
    pub fn lens(&self, path: &str, time: Time) -> Result<Option<lens::LensModel>, UsdError> {
        lens::read(&self.values(), path, time, &self.api_schemas(path))
    }

    /// The RenderSettings prim: the stage's `renderSettingsPrimPath`, else the first one found.
    #[must_use]
    pub fn render_settings(&self) -> Option<String> {
        let authored = self
            .stage
            .stage_metadata("renderSettingsPrimPath")
            .ok()
            .flatten()
            .and_then(|v| values::text(&v))
            .filter(|p| !p.is_empty());
        authored.or_else(|| {
            self.prims()
                .ok()?
                .into_iter()
                .find(|(_, t)| t == "RenderSettings")
                .map(|(p, _)| p)
        })
    }

    /// Sets `format` from the RenderSettings' first product's `resolution` (int2) and
    /// `pixelAspectRatio`, each where authored (a product's value over the settings'); the schema's
    /// fallbacks (2048 × 1080, 1) are not applied, so a stage that states no size keeps `format`.
    ///
    /// # Errors
    /// A located [`UsdError`]: a resolution that is not two whole numbers in 1…65536, a pixel aspect
    /// that is not positive and finite.
    pub fn product_format(&self, format: &mut obscura_sdk::Format) -> Result<(), UsdError> {
        let Some(settings) = self.render_settings() else {
            return Ok(());
        };
        let values = self.values();
        let mut prims = values.targets(&settings, "products");
        prims.truncate(1);
        prims.push(settings);
        for prim in &prims {
            if let Some(r) = values.reals_opt(prim, "resolution", Time::Default, 2)? {
                let whole = |v: f64| v.fract() == 0.0 && (1.0..=65536.0).contains(&v);
                if !(whole(r[0]) && whole(r[1])) {
                    return Err(values.error(
                        prim,
                        "resolution",
                        format!(
                            "expected two whole numbers of pixels in 1…65536, found ({}, {})",
                            r[0], r[1]
                        ),
                    ));
                }
                format.width = r[0] as u32;
                format.height = r[1] as u32;
                break;
            }
        }
        for prim in &prims {
            if let Some(a) = values.real_opt(prim, "pixelAspectRatio", Time::Default)? {
                if !(a.is_finite() && a > 0.0) {
                    return Err(values.error(
                        prim,
                        "pixelAspectRatio",
                        format!("expected a positive pixel aspect, found {a}"),
                    ));
                }
                format.pixel_aspect = a as f32;
                break;
            }
        }
        Ok(())
    }

    /// The camera to render through: `--camera` (a path, or a prim name), else the RenderSettings'
    /// `camera` (or its first product's), else a camera named `main_cam` (USD's primary camera
    /// name), else the first camera; `None` when the stage has none. The note says which was
    /// chosen when the stage has several and none was named.
    ///
    /// # Errors
    /// An unknown `--camera`, naming the stage's cameras.
    pub fn choose_camera(&self, wanted: Option<&str>) -> Result<(Option<String>, Option<String>), UsdError> {
        let cameras = self.cameras()?;
        if let Some(w) = wanted {
            let found = cameras
                .iter()
                .find(|c| c.as_str() == w)
                .or_else(|| cameras.iter().find(|c| c.rsplit('/').next() == Some(w)));
            return match found {
                Some(c) => Ok((Some(c.clone()), None)),
                None => Err(UsdError::file(
                    &self.file,
                    format!(
                        "--camera {w}: no Camera prim of that path or name; the stage's cameras: {}",
                        if cameras.is_empty() {
                            "none".to_string()
                        } else {
                            cameras.join(", ")
                        }
                    ),
                )),
            };
        }
        let values = self.values();
        if let Some(settings) = self.render_settings() {
            let mut targets = values.targets(&settings, "camera");
            for product in values.targets(&settings, "products") {
                targets.extend(values.targets(&product, "camera"));
            }
            if let Some(t) = targets.into_iter().next() {
                if !cameras.contains(&t) {
                    return Err(UsdError::at(
                        &self.file,
                        &settings,
                        format!("rel camera: <{t}> is not a Camera prim of the stage"),
                    ));
                }
                return Ok((Some(t), None));
            }
        }
        let chosen = cameras
            .iter()
            .find(|c| c.rsplit('/').next() == Some("main_cam"))
            .or(cameras.first())
            .cloned();
        let note = (cameras.len() > 1).then(|| {
            format!(
                "{}: rendering through {} (of {}); choose another with --camera",
                self.file,
                chosen.as_deref().unwrap_or_default(),
                cameras.join(", ")
            )
        });
        Ok((chosen, note))
    }
}

/// A USD stage frame by frame: the [`SceneSource`] of [`open`].
pub struct UsdSource {
    stage: Stage,
    camera: CameraDesc,
    camera_prim: Option<String>,
    info: Vec<ImageInfo>,
    base_dir: PathBuf,
    notes: Vec<String>,
}

impl UsdSource {
    /// The time code of image `index`.
    #[must_use]
    pub fn time_code(&self, index: usize) -> f64 {
        match self.stage.time_range {
            Some(_) => f64::from(self.info[index].number),
            None => 0.0,
        }
    }

    /// The stage.
    #[must_use]
    pub fn stage(&self) -> &Stage {
        &self.stage
    }

    /// The camera prim rendered through (`None`: the stage has none; staging frames the scene).
    #[must_use]
    pub fn camera_prim(&self) -> Option<&str> {
        self.camera_prim.as_deref()
    }
}

/// Opens the stage at `path` frame by frame; `camera` gives the image size and what the stage does
/// not set.
///
/// # Errors
/// A located [`UsdError`] (as a [`LoadError`]).
pub fn open(path: &Path, camera: CameraDesc, options: &Options) -> Result<UsdSource, LoadError> {
    let stage = Stage::open(path)?;
    let mut camera = camera;
    if options.product_resolution {
        stage.product_format(&mut camera.format)?;
    }
    let (camera_prim, note) = stage.choose_camera(options.camera.as_deref())?;
    let mut notes = stage.warnings.clone();
    notes.extend(note);
    let info = match stage.time_range {
        Some((start, end)) => {
            if !(start.is_finite()
                && end.is_finite()
                && start >= 0.0
                && end >= start
                && end <= f64::from(u32::MAX))
            {
                return Err(UsdError::file(
                    &stage.file,
                    format!("startTimeCode {start}, endTimeCode {end}: expected 0 ≤ start ≤ end"),
                )
                .into());
            }
            let (first, last) = (start.ceil() as u32, end.floor() as u32);
            (first..=last.max(first))
                .map(|n| ImageInfo {
                    number: n,
                    numbered: true,
                    label: format!("time code {n}"),
                })
                .collect()
        }
        None => vec![ImageInfo {
            number: 1,
            numbered: false,
            label: String::new(),
        }],
    };
    Ok(UsdSource {
        base_dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        stage,
        camera,
        camera_prim,
        info,
        notes,
    })
}

impl SceneSource for UsdSource {
    fn base_dir(&self) -> &Path {
        &self.base_dir
    }

    fn images(&self) -> &[ImageInfo] {
        &self.info
    }

    fn image(&self, index: usize) -> Result<Scene, LoadError> {
        let t = self.time_code(index);
        let mut scene = scene::build(&self.stage, self.camera.clone(), self.camera_prim.as_deref(), t)?;
        let mut notes = self.notes.clone();
        for w in self.stage.composition_warnings() {
            if !notes.contains(&w) {
                notes.push(w);
            }
        }
        scene.warnings.splice(0..0, notes);
        Ok(scene)
    }
}
