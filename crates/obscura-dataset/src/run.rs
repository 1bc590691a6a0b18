//! The dataset driver: `obscura dataset` and Python's `render_dataset` both run [`run`].
//!
//! For each selected frame and each camera of the rig, the scene is posed at that frame, given the
//! camera's projection and pose, and rendered through the one frame pipeline
//! ([`obscura_render::pipeline::render_frame`]) into `images/<camera>/<frame>.exr` (beauty and the
//! ground truth of [`crate::layout::IMAGE_AOVS`]) and `.png`, with the camera JSON marking the frame
//! complete. The per-frame annotations follow the frame. The files that span frames (the exports,
//! point tracks) and the manifest are assembled by the **finalize** step.
//!
//! # Resuming and farms
//!
//! A camera's frame whose camera JSON says `"complete": true` and whose images exist is skipped, as
//! `obscura render` skips a complete sequence frame; every file is written atomically. A run without
//! `--frames` renders every frame and finalizes. A farm splits the frames: each task runs
//! `--frames A-B` into the same directory (rendering and per-frame annotations only), then one task
//! runs the same command with `--finalize`, which renders nothing and assembles the exports, tracks
//! and manifest from the frames on disk (every frame of its `--frames`, or every frame the scene
//! has, must be complete). Every run checks that `dataset.json`'s options are its own, so two
//! different datasets never mix in one directory.

use std::path::{Path, PathBuf};

use glam::DMat4;
use obscura_host::Registry;
use obscura_plugins::loader::{PluginSearch, ensure};
use obscura_render::frame::is_complete;
use obscura_render::job::{self, Calibrated, Overrides};
use obscura_render::pipeline::{FrameJob, FrameWrite, Reporter, Sidecars, render_frame};
use obscura_render::render::RenderOptions;
use obscura_render::sequence::FrameSpec;
use obscura_scene::source::SceneSource;
use obscura_scene::{Aov, Display, DisplayDriver, Scene};
use obscura_sdk::{Format, Matrix4, MotionSample, ParamDecl, ParamList, ParamType, ParamValue, did_you_mean};
use serde_json::{Value, json};

use crate::export::{ExportCamera, ExportFormat, ExportFrame, write_exports};
use crate::layout::{IMAGE_AOVS, LAYOUT_VERSION, Layout};
use crate::rig::{Lens, Rig, RigCamera};

/// An annotation kind (`--annotations`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Annotation {
    /// COCO-style 2D and 3D boxes per frame: `annotations/<camera>/<frame>.json`.
    Boxes,
    /// Point tracks over the frames: `tracks/<camera>.npz`.
    Tracks,
    /// Cross-camera correspondences per frame: `correspondences/<a>__<b>/<frame>.npz`.
    Correspondences,
}

/// The names `--exports` takes, in order: [`ExportFormat::name`] of each format.
#[must_use]
pub fn export_names() -> Vec<(&'static str, ExportFormat)> {
    ExportFormat::ALL.iter().map(|&f| (f.name(), f)).collect()
}

/// The names `--annotations` takes, in order.
pub const ANNOTATION_NAMES: [(&str, Annotation); 3] = [
    ("boxes", Annotation::Boxes),
    ("tracks", Annotation::Tracks),
    ("correspondences", Annotation::Correspondences),
];

/// Reads a comma-separated list of names from `table` (`--exports colmap,gsplat`); repeated names
/// are kept once, in the table's order.
///
/// # Errors
/// A message naming the option, the unknown name and the valid ones.
pub fn parse_names<T: Copy + PartialEq>(
    option: &str,
    text: &str,
    table: &[(&str, T)],
) -> Result<Vec<T>, String> {
    let mut picked = Vec::new();
    for word in text.split(',').map(str::trim).filter(|w| !w.is_empty()) {
        let Some(&(_, v)) = table.iter().find(|(n, _)| *n == word) else {
            let names: Vec<&str> = table.iter().map(|(n, _)| *n).collect();
            let hint = did_you_mean(word, names.iter().copied())
                .map(|s| format!(" (did you mean '{s}'?)"))
                .unwrap_or_default();
            return Err(format!(
                "{option} '{word}': unknown name{hint}; expected one or more of {} (comma-separated)",
                names.join(", ")
            ));
        };
        if !picked.contains(&v) {
            picked.push(v);
        }
    }
    Ok(table
        .iter()
        .map(|&(_, v)| v)
        .filter(|v| picked.contains(v))
        .collect())
}

/// The name of `value` in `table`.
fn name_of<T: PartialEq>(table: &[(&'static str, T)], value: &T) -> &'static str {
    table.iter().find(|(_, v)| v == value).map_or("", |(n, _)| n)
}

/// The render options a dataset takes, as `obscura render` takes them.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// `--format`: the image size (default: the scene's, or a calibration's).
    pub format: Option<(u32, u32)>,
    /// `--projection`: the projection of the base camera.
    pub projection: Option<String>,
    /// `--calibration`: the base camera through a calibration file.
    pub calibration: Option<PathBuf>,
    /// `--camera`: the camera of the calibration file.
    pub camera: Option<String>,
    /// `--spp`: samples per pixel (default: the scene's).
    pub spp: Option<u32>,
    /// `--seed`.
    pub seed: u32,
    /// `--max-depth`: path depth.
    pub max_depth: u32,
    /// `--fps` of an animated scene.
    pub fps: f32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            format: None,
            projection: None,
            calibration: None,
            camera: None,
            spp: None,
            seed: 0,
            max_depth: obscura_shading::integrator::PathOptions::default().max_depth,
            fps: 24.0,
        }
    }
}

/// What the run does with the files that span frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Finalize {
    /// Render, then finalize when the run covers the whole dataset (no `--frames`).
    Auto,
    /// Render nothing; assemble the exports, tracks and manifest from the frames on disk
    /// (`--finalize`).
    Only,
}

/// Everything one dataset run is given.
#[derive(Debug, Clone)]
pub struct DatasetOptions {
    /// The scene file (`None`: the built-in scene).
    pub scene: Option<PathBuf>,
    /// The dataset directory.
    pub output: PathBuf,
    /// `--frames`: the frames of this run (default: every frame of the scene; frame 1 of an
    /// animation).
    pub frames: Option<FrameSpec>,
    /// `--rig`: the rig file.
    pub rig: Option<PathBuf>,
    /// `--exports`.
    pub exports: Vec<ExportFormat>,
    /// `--annotations`.
    pub annotations: Vec<Annotation>,
    /// `--tracks`: points per object for the tracks.
    pub tracks: u32,
    /// The render options.
    pub render: RenderSettings,
    /// What to do with the files spanning frames.
    pub finalize: Finalize,
}

/// The default number of track points per object.
pub const DEFAULT_TRACKS: u32 = 256;

/// Reads the base camera's projection parameters (`--param`, or Python's keywords) against the
/// table of the projection the scene renders through, once it is known.
pub trait ParamReader {
    /// The parameters for `projection` whose table is `table`.
    ///
    /// # Errors
    /// A message naming the parameter and what was expected.
    fn read(&self, projection: &str, table: &[ParamDecl]) -> Result<ParamList, String>;
    /// The parameters as given, for the manifest (`fov=60`).
    fn describe(&self) -> Vec<String>;
}

/// What the front end gives the driver: the projection registry, the plugin search path, the
/// reporter of each frame's messages and progress, and the parameter reader.
pub struct Session<'a> {
    /// Projections by name; plugins are loaded into it as cameras need them.
    pub registry: &'a mut Registry,
    /// Where plugins are found.
    pub search: &'a PluginSearch,
    /// Each frame's messages, progress and cancel flag.
    pub reporter: &'a dyn Reporter,
    /// The base camera's parameters.
    pub params: &'a dyn ParamReader,
}

/// What a run did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Summary {
    /// (camera, frame) rendered by this run.
    pub rendered: Vec<(String, u32)>,
    /// (camera, frame) found complete and skipped.
    pub skipped: Vec<(String, u32)>,
    /// Seconds spent rendering.
    pub render_seconds: f64,
    /// Seconds spent on annotations.
    pub annotation_seconds: f64,
    /// True when the run finalized the dataset.
    pub finalized: bool,
    /// Warnings (an export that cannot be exact, …).
    pub warnings: Vec<String>,
}

/// Why a dataset run stopped; each message names the file, option, camera or frame at fault.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// Bad input: an option, a rig file, a scene, a camera.
    #[error("{0}")]
    Input(String),
    /// A frame could not be rendered or written.
    #[error("frame {frame}, camera {camera}: {message}")]
    Frame {
        /// The frame.
        frame: u32,
        /// The camera.
        camera: String,
        /// The pipeline's error.
        message: String,
    },
    /// The render was interrupted; what is complete stays, a rerun resumes.
    #[error("interrupted in frame {frame}, camera {camera}: run the same command again to resume")]
    Cancelled {
        /// The frame.
        frame: u32,
        /// The camera.
        camera: String,
    },
    /// A file could not be written.
    #[error("{0}")]
    Output(String),
}

/// One camera ready to render: its rig entry and the overrides that give the scene its lens.
struct Prepared {
    rig: RigCamera,
    overrides: Overrides,
    projection: String,
}

/// The frames a scene has and how to pose it at one.
struct Frames<'a> {
    source: &'a dyn SceneSource,
    /// (frame number, image index; `usize::MAX` for an animation's frame).
    list: Vec<(u32, usize)>,
}

impl Frames<'_> {
    fn scene(&self, frame: u32, index: usize) -> Result<Scene, DatasetError> {
        let r = if index == usize::MAX {
            self.source.frame(frame)
        } else {
            self.source.image(index)
        };
        r.map_err(|e| DatasetError::Input(e.to_string()))
    }
}

/// The frames of `source` that `spec` selects (every frame without one: every image, or frame 1 of
/// an animation).
fn select_frames<'a>(
    source: &'a dyn SceneSource,
    spec: Option<&FrameSpec>,
) -> Result<Frames<'a>, DatasetError> {
    let input = DatasetError::Input;
    let list = if source.animation().is_some() {
        match spec {
            Some(s) => s
                .non_negative()
                .map_err(input)?
                .map(|n| (n, usize::MAX))
                .collect(),
            None => vec![(1, usize::MAX)],
        }
    } else {
        let images = source.images();
        match images {
            [still] if !still.numbered => match spec {
                Some(s) => s.non_negative().map_err(input)?.map(|n| (n, 0)).collect(),
                None => vec![(still.number, 0)],
            },
            _ => {
                let numbers: Vec<u32> = images.iter().map(|f| f.number).collect();
                let picked = match spec {
                    Some(s) => s.select(&numbers).map_err(input)?,
                    None => numbers,
                };
                let mut list: Vec<(u32, usize)> = (images.iter().enumerate())
                    .filter(|(_, f)| picked.contains(&f.number))
                    .map(|(i, f)| (f.number, i))
                    .collect();
                list.dedup_by_key(|(n, _)| *n);
                list
            }
        }
    };
    Ok(Frames { source, list })
}

/// Reads JSON parameter values (a rig file's `params`) against `table` of `projection`: a number,
/// a list of numbers, a string or a list of strings per parameter, typed by the table.
///
/// # Errors
/// A message naming the parameter and what was expected.
pub fn json_params(
    projection: &str,
    table: &[ParamDecl],
    params: &serde_json::Map<String, Value>,
) -> Result<ParamList, String> {
    let mut list = ParamList::new();
    for (name, v) in params {
        let Some(decl) = table.iter().find(|d| d.name == name.as_str()) else {
            let hint = did_you_mean(name, table.iter().map(|d| d.name.as_ref()))
                .map(|s| format!(" (did you mean \"{s}\"?)"))
                .unwrap_or_default();
            return Err(format!(
                "params.{name}: {projection} has no parameter \"{name}\"{hint}; see `obscura plugins {projection}`"
            ));
        };
        let items: Vec<&Value> = match v {
            Value::Array(a) => a.iter().collect(),
            other => vec![other],
        };
        let bad = |what: &str| {
            format!(
                "params.{name}: expected {what} for {projection}'s {} {name}, got {v}",
                decl.ty
            )
        };
        let value = match decl.ty {
            ParamType::String => ParamValue::Strings(
                items
                    .iter()
                    .map(|i| i.as_str().map(str::to_string))
                    .collect::<Option<_>>()
                    .ok_or_else(|| bad("strings"))?,
            ),
            ParamType::Int => ParamValue::Ints(
                items
                    .iter()
                    .map(|i| i.as_i64().and_then(|x| i32::try_from(x).ok()))
                    .collect::<Option<_>>()
                    .ok_or_else(|| bad("32-bit integers"))?,
            ),
            _ => ParamValue::Floats(
                items
                    .iter()
                    .map(|i| i.as_f64().map(|x| x as f32))
                    .collect::<Option<_>>()
                    .ok_or_else(|| bad("numbers"))?,
            ),
        };
        list.push(&decl.rib_declaration(), value, Some(format!("params.{name}")))
            .map_err(|e| format!("params.{name}: {e}"))?;
    }
    Ok(list)
}

/// The rig camera's world-to-camera: `camera_to_base⁻¹ · world_to_camera_base` at every motion sample
/// of the base camera (an empty list is the identity at shutter open).
#[must_use]
pub fn rig_world_to_camera(
    base: &[MotionSample],
    shutter_open: f32,
    camera_to_base: DMat4,
) -> Vec<MotionSample> {
    let samples = if base.is_empty() {
        vec![MotionSample {
            time: shutter_open,
            world_to_camera: Matrix4::IDENTITY,
        }]
    } else {
        base.to_vec()
    };
    let base_to_camera = camera_to_base.inverse();
    samples
        .into_iter()
        .map(|s| {
            // Row-vector storage is the column-vector matrix's transpose: its rows are our columns.
            let cols = s.world_to_camera.0.map(|r| r.map(f64::from));
            let m = base_to_camera * DMat4::from_cols_array_2d(&cols);
            MotionSample {
                time: s.time,
                world_to_camera: Matrix4(m.to_cols_array_2d().map(|r| r.map(|x| x as f32))),
            }
        })
        .collect()
}

/// The displays of one camera's frame: the EXR with beauty and ground truth, and the PNG preview.
#[must_use]
pub fn frame_displays(layout: &Layout, camera: &str, frame: u32) -> Vec<Display> {
    vec![
        Display {
            path: layout.at(&Layout::exr(camera, frame)),
            driver: DisplayDriver::OpenExr,
            aovs: IMAGE_AOVS.to_vec(),
            half: false,
        },
        Display {
            path: layout.at(&Layout::png(camera, frame)),
            driver: DisplayDriver::Png,
            aovs: vec![Aov::Ci, Aov::Alpha],
            half: false,
        },
    ]
}

/// The options as the manifest records them; two runs into one directory must agree on them.
fn options_json(o: &DatasetOptions, params: &[String]) -> Value {
    let path = |p: &Option<PathBuf>| p.as_ref().map(|p| p.display().to_string());
    let r = &o.render;
    json!({
        "scene": path(&o.scene),
        "rig": path(&o.rig),
        "format": r.format.map(|(w, h)| format!("{w}x{h}")),
        "projection": r.projection,
        "params": params,
        "calibration": path(&r.calibration),
        "camera": r.camera,
        "spp": r.spp,
        "seed": r.seed,
        "max_depth": r.max_depth,
        "fps": r.fps,
        "exports": o.exports.iter().map(|e| e.name()).collect::<Vec<_>>(),
        "annotations": o.annotations.iter().map(|a| name_of(&ANNOTATION_NAMES, a)).collect::<Vec<_>>(),
        "tracks": o.tracks,
    })
}

/// Writes `value` as pretty JSON with a final newline, atomically, creating its directory.
fn write_json(path: &Path, value: &Value) -> Result<(), DatasetError> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| {
            DatasetError::Output(format!("{}: cannot create the directory: {e}", dir.display()))
        })?;
    }
    obscura_render::metadata::write_json(path, value).map_err(|e| DatasetError::Output(e.to_string()))
}

/// Checks the manifest at `path`, if any, was written with `options`.
fn check_manifest(path: &Path, options: &Value) -> Result<(), DatasetError> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Ok(());
    };
    let old: Value = serde_json::from_str(&text).map_err(|e| {
        DatasetError::Input(format!(
            "{}:{}: not a dataset manifest ({e}); use another -o or remove it",
            path.display(),
            e.line()
        ))
    })?;
    if old["layout"] != LAYOUT_VERSION {
        return Err(DatasetError::Input(format!(
            "{}: layout {} is not this version's {LAYOUT_VERSION}; use another -o",
            path.display(),
            old["layout"]
        )));
    }
    if let (Some(was), Some(now)) = (old["options"].as_object(), options.as_object()) {
        for (k, v) in now {
            let before = was.get(k).unwrap_or(&Value::Null);
            if before != v {
                return Err(DatasetError::Input(format!(
                    "{}: this dataset was made with {k} = {before}, this run has {k} = {v}; a directory holds one dataset (use another -o, or the same options)",
                    path.display()
                )));
            }
        }
    }
    Ok(())
}

/// The cameras as the manifest lists them.
fn cameras_json(cameras: &[Prepared]) -> Value {
    Value::Array(
        cameras
            .iter()
            .map(|c| {
                let m = c.rig.camera_to_base;
                json!({
                    "name": c.rig.name,
                    "projection": c.projection,
                    "camera_to_base": (0..4).map(|r| m.row(r).to_array()).collect::<Vec<_>>(),
                })
            })
            .collect(),
    )
}

/// Runs a dataset (see the module documentation).
///
/// # Errors
/// A [`DatasetError`] naming what is to blame; complete frames stay on disk.
pub fn run(options: &DatasetOptions, session: &mut Session<'_>) -> Result<Summary, DatasetError> {
    let input = DatasetError::Input;
    let layout = Layout::new(&options.output);
    let r = &options.render;
    let (w, h) = r.format.unwrap_or(job::DEFAULT_FORMAT);
    let source = job::open_scene(options.scene.as_deref(), Format::new(w, h), r.fps)
        .map_err(|e| input(e.to_string()))?;
    let rig = match &options.rig {
        Some(path) => Rig::load(path).map_err(|e| input(e.to_string()))?,
        None => Rig::single(),
    };
    let frames = select_frames(source.as_ref(), options.frames.as_ref())?;
    let calibration = r
        .calibration
        .as_deref()
        .map(|p| Calibrated::load(p, r.camera.as_deref()))
        .transpose()
        .map_err(|e| input(e.to_string()))?;
    let (&(first_frame, first_index), _) = frames
        .list
        .split_first()
        .ok_or_else(|| input("no frame selected".into()))?;
    let first = frames.scene(first_frame, first_index)?;
    let mut cameras = Vec::new();
    for cam in &rig.cameras {
        cameras.push(prepare_camera(
            cam,
            &first,
            calibration.as_ref(),
            options,
            session,
        )?);
    }
    let annotations_need_unproject = options
        .annotations
        .iter()
        .any(|a| matches!(a, Annotation::Tracks | Annotation::Correspondences));
    if annotations_need_unproject {
        for c in &cameras {
            check_unproject(session.registry, &first, c)?;
        }
    }
    let options_value = options_json(options, &session.params.describe());
    check_manifest(&layout.manifest(), &options_value)?;
    let mut summary = Summary::default();
    if options.finalize == Finalize::Auto {
        write_json(
            &layout.manifest(),
            &json!({"layout": LAYOUT_VERSION, "complete": false, "options": options_value, "cameras": cameras_json(&cameras)}),
        )?;
        render_frames(&layout, &frames, &cameras, options, session, &mut summary)?;
    }
    if options.finalize == Finalize::Only || options.frames.is_none() {
        finalize(
            &layout,
            &frames,
            &cameras,
            options,
            &options_value,
            session,
            &mut summary,
        )?;
    }
    Ok(summary)
}

/// Loads a rig camera's projection and reads its parameters against it, on the first frame's scene.
fn prepare_camera(
    cam: &RigCamera,
    first: &Scene,
    calibration: Option<&Calibrated>,
    options: &DatasetOptions,
    session: &mut Session<'_>,
) -> Result<Prepared, DatasetError> {
    let input = |e: String| DatasetError::Input(format!("camera {}: {e}", cam.name));
    let r = &options.render;
    let mut overrides = Overrides {
        format: r.format,
        ..Overrides::default()
    };
    let search = session.search.with_scene_dirs(&first.plugin_path);
    match &cam.lens {
        Lens::Base => {
            overrides.projection.clone_from(&r.projection);
            overrides.calibration = calibration.cloned();
        }
        Lens::Projection { name, .. } => overrides.projection = Some(name.clone()),
        Lens::Calibration(c) => overrides.calibration = Some((**c).clone()),
    }
    let projection = ensure(session.registry, overrides.projection(first), &search)
        .map_err(|e| input(overrides.locate_projection_error(first, e)))?;
    let factory = session
        .registry
        .find(&projection)
        .map_err(|e| input(e.to_string()))?;
    overrides.params = match &cam.lens {
        Lens::Base => session
            .params
            .read(factory.name(), factory.param_table())
            .map_err(input)?,
        Lens::Projection { params, .. } => {
            json_params(factory.name(), factory.param_table(), params).map_err(input)?
        }
        Lens::Calibration(_) => ParamList::new(),
    };
    if overrides.projection.is_some() {
        overrides.projection = Some(projection.clone());
    }
    Ok(Prepared {
        rig: cam.clone(),
        overrides,
        projection,
    })
}

/// Checks that camera `c`'s projection has an exact inverse (`unproject`), which tracks and
/// correspondences need: created on `first` (the first frame), it must invert at least one of 26
/// directions around the camera (the cube's faces, edges and corners).
fn check_unproject(registry: &mut Registry, first: &Scene, c: &Prepared) -> Result<(), DatasetError> {
    let scene = camera_scene(first.clone(), c)?;
    let stage = obscura_host::CameraStage::new(
        registry,
        &scene.projection,
        &scene.projection_params,
        &scene.camera,
    )
    .map_err(|e| DatasetError::Input(format!("camera {}: {e}", c.rig.name)))?;
    let mut directions = Vec::new();
    for x in -1i8..=1 {
        for y in -1i8..=1 {
            for z in -1i8..=1 {
                if (x, y, z) != (0, 0, 0) {
                    directions.push(obscura_sdk::Vec3::new(f32::from(x), f32::from(y), f32::from(z)));
                }
            }
        }
    }
    if directions
        .iter()
        .any(|&d| stage.projection().unproject(d, 0.0).is_some())
    {
        return Ok(());
    }
    Err(DatasetError::Input(format!(
        "camera {}: its projection {} has no unproject (an exact inverse) for any direction; --annotations tracks and correspondences need one. Use another projection for this camera, or leave tracks and correspondences out",
        c.rig.name, c.projection
    )))
}

/// The scene of `frame` posed for camera `c`.
fn camera_scene(mut scene: Scene, c: &Prepared) -> Result<Scene, DatasetError> {
    c.overrides
        .apply(&mut scene)
        .map_err(|e| DatasetError::Input(e.to_string()))?;
    scene.projection.clone_from(&c.projection);
    let cam = &mut scene.camera;
    cam.world_to_camera = rig_world_to_camera(&cam.world_to_camera, cam.shutter.0, c.rig.camera_to_base);
    Ok(scene)
}

/// The renderer's options of a dataset.
fn render_options(options: &DatasetOptions) -> RenderOptions {
    let r = &options.render;
    RenderOptions {
        samples_per_pixel: r.spp,
        seed: r.seed,
        path: obscura_shading::integrator::PathOptions {
            max_depth: r.max_depth,
            ..Default::default()
        },
        ..RenderOptions::default()
    }
}

/// Where the scene's relative paths are read from.
fn base_dir(options: &DatasetOptions) -> PathBuf {
    options
        .scene
        .as_deref()
        .and_then(Path::parent)
        .map(Path::to_path_buf)
        .unwrap_or_default()
}

/// The seed of the track points' sampling (fixed: every run and every farm task samples the same
/// points).
pub const TRACK_SEED: u64 = 0x0b5c_0a7a;

/// The point tracks of camera `c` over `frames`, written to `tracks/<camera>.npz`: the points are
/// sampled on the first frame's surfaces and followed through every frame's exact camera.
fn write_tracks(
    layout: &Layout,
    frames: &Frames<'_>,
    c: &Prepared,
    options: &DatasetOptions,
    registry: &mut Registry,
) -> Result<(), DatasetError> {
    let opts = render_options(options);
    let dir = base_dir(options);
    let name = &c.rig.name;
    let mut points = None;
    let mut seen = Vec::new();
    let mut numbers = Vec::new();
    for &(frame, index) in &frames.list {
        let failed = |message: String| DatasetError::Frame {
            frame,
            camera: name.clone(),
            message,
        };
        let scene = camera_scene(frames.scene(frame, index)?, c)?;
        let prepared = obscura_render::render::prepare(&scene, registry, &dir, &opts)
            .map_err(|e| failed(e.to_string()))?;
        let points = points.get_or_insert_with(|| {
            crate::annotate::tracks::TrackPoints::sample(&prepared, options.tracks as usize, TRACK_SEED)
        });
        seen.push(
            crate::annotate::tracks::track_frame(&prepared, &scene, points, 0.0)
                .map_err(|e| failed(e.to_string()))?,
        );
        numbers.push(
            i32::try_from(frame)
                .map_err(|_| failed("the frame number does not fit the tracks' int32 frame list".into()))?,
        );
    }
    let path = layout.at(&Layout::tracks(name));
    create_parent(&path)?;
    crate::annotate::tracks::write_tracks_npz(&path, &points.unwrap_or_default(), &seen, &numbers)
        .map_err(|e| DatasetError::Output(e.to_string()))
}

/// Renders every selected frame of every camera that is not complete yet.
fn render_frames(
    layout: &Layout,
    frames: &Frames<'_>,
    cameras: &[Prepared],
    options: &DatasetOptions,
    session: &mut Session<'_>,
    summary: &mut Summary,
) -> Result<(), DatasetError> {
    let r = &options.render;
    let opts = render_options(options);
    let size_source = match (&r.format, &options.scene) {
        (Some(_), _) => "--format".to_string(),
        (None, Some(p)) => format!("{}: Format", p.display()),
        (None, None) => "the built-in scene's Format".to_string(),
    };
    let base_dir = base_dir(options);
    let boxes = options.annotations.contains(&Annotation::Boxes);
    let correspondences = options.annotations.contains(&Annotation::Correspondences) && cameras.len() > 1;
    for &(frame, index) in &frames.list {
        // A camera's frame is done when its images are complete and its per-frame annotations exist;
        // otherwise it renders again (annotations need the render's film and prepared scene).
        let done = |c: &Prepared| {
            let name = &c.rig.name;
            is_complete(&frame_displays(layout, name, frame))
                && (!boxes || layout.at(&Layout::annotations(name, frame)).is_file())
                && (!correspondences
                    || cameras.iter().filter(|b| b.rig.name != *name).all(|b| {
                        layout
                            .at(&Layout::correspondences(name, &b.rig.name, frame))
                            .is_file()
                    }))
        };
        if cameras.iter().all(done) {
            summary
                .skipped
                .extend(cameras.iter().map(|c| (c.rig.name.clone(), frame)));
            continue;
        }
        let mut rendered = Vec::new();
        for c in cameras {
            let name = &c.rig.name;
            let displays = frame_displays(layout, name, frame);
            let dir = layout.at(&Layout::images_dir(name));
            std::fs::create_dir_all(&dir).map_err(|e| {
                DatasetError::Output(format!("{}: cannot create the directory: {e}", dir.display()))
            })?;
            let scene = camera_scene(frames.scene(frame, index)?, c)?;
            let writes = [FrameWrite {
                number: Some(frame),
                displays: &displays,
            }];
            let job = FrameJob {
                scene: &scene,
                base_dir: &base_dir,
                writes: &writes,
                also: &[],
                neighbours: obscura_render::frame::Neighbours::default(),
                options: &opts,
                header_frame: Some(frame),
                sidecars: Sidecars::Always,
                size_source: &size_source,
            };
            let result =
                render_frame(&job, session.registry, session.reporter).map_err(|e| DatasetError::Frame {
                    frame,
                    camera: name.clone(),
                    message: e.to_string(),
                })?;
            if result.output.stats.cancelled {
                return Err(DatasetError::Cancelled {
                    frame,
                    camera: name.clone(),
                });
            }
            summary.render_seconds += result.output.stats.render_seconds;
            summary.rendered.push((name.clone(), frame));
            rendered.push((scene, result));
        }
        let start = std::time::Instant::now();
        let failed = |camera: &str, e: crate::annotate::AnnotateError| DatasetError::Frame {
            frame,
            camera: camera.to_string(),
            message: e.to_string(),
        };
        if boxes {
            for (c, (scene, result)) in cameras.iter().zip(&rendered) {
                let name = &c.rig.name;
                let found =
                    crate::annotate::boxes::frame_boxes(&result.prepared, scene, &result.output.film, 0.0)
                        .map_err(|e| failed(name, e))?;
                let format = scene.camera.format;
                let file_name = Layout::exr(name, frame).to_string_lossy().replace('\\', "/");
                let info = crate::annotate::boxes::ImageInfo {
                    file_name: &file_name,
                    camera: name,
                    frame: Some(i64::from(frame)),
                    width: format.width,
                    height: format.height,
                };
                let coco = crate::annotate::boxes::coco_json(&info, result.prepared.ids(), &found);
                write_json(&layout.at(&Layout::annotations(name, frame)), &coco)?;
            }
        }
        if correspondences {
            for (a, (_, ra)) in cameras.iter().zip(&rendered) {
                for (b, (scene_b, rb)) in cameras.iter().zip(&rendered) {
                    if a.rig.name == b.rig.name {
                        continue;
                    }
                    let found = crate::annotate::correspondences::correspond(
                        &ra.prepared,
                        &rb.prepared,
                        scene_b,
                        0.0,
                    )
                    .map_err(|e| failed(&a.rig.name, e))?;
                    let path = layout.at(&Layout::correspondences(&a.rig.name, &b.rig.name, frame));
                    create_parent(&path)?;
                    found.write_npz(&path).map_err(|e| failed(&a.rig.name, e))?;
                }
            }
        }
        summary.annotation_seconds += start.elapsed().as_secs_f64();
    }
    Ok(())
}

/// The files under `root/dir`, relative to `root`, sorted.
fn files_under(root: &Path, dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(root.join(&d)) else {
            continue;
        };
        for e in entries.flatten() {
            let rel = d.join(e.file_name());
            if e.path().is_dir() {
                stack.push(rel);
            } else {
                out.push(rel);
            }
        }
    }
    out.sort();
    out
}

/// Creates the directory `path` is written into.
fn create_parent(path: &Path) -> Result<(), DatasetError> {
    match path.parent() {
        Some(dir) => std::fs::create_dir_all(dir).map_err(|e| {
            DatasetError::Output(format!("{}: cannot create the directory: {e}", dir.display()))
        }),
        None => Ok(()),
    }
}

/// Assembles the files spanning frames and the manifest from the frames on disk.
fn finalize(
    layout: &Layout,
    frames: &Frames<'_>,
    cameras: &[Prepared],
    options: &DatasetOptions,
    options_value: &Value,
    session: &mut Session<'_>,
    summary: &mut Summary,
) -> Result<(), DatasetError> {
    let mut missing = Vec::new();
    for &(frame, _) in &frames.list {
        for c in cameras {
            if !is_complete(&frame_displays(layout, &c.rig.name, frame)) {
                missing.push(format!("{} {}", c.rig.name, frame));
            }
        }
    }
    if !missing.is_empty() {
        let shown: Vec<&str> = missing.iter().take(8).map(String::as_str).collect();
        return Err(DatasetError::Input(format!(
            "{}: cannot finalize, {} camera frame(s) are not rendered yet ({}{}); render them (the same command with their --frames) first",
            layout.root().display(),
            missing.len(),
            shown.join(", "),
            if missing.len() > shown.len() { ", …" } else { "" }
        )));
    }
    let start = std::time::Instant::now();
    let mut files: Vec<PathBuf> = Vec::new();
    for &(frame, _) in &frames.list {
        for c in cameras {
            let n = &c.rig.name;
            files.extend([
                Layout::exr(n, frame),
                Layout::png(n, frame),
                Layout::ids_json(n, frame),
                Layout::camera_json(n, frame),
            ]);
            if options.annotations.contains(&Annotation::Boxes) {
                files.push(Layout::annotations(n, frame));
            }
            if options.annotations.contains(&Annotation::Correspondences) {
                files.extend(
                    cameras
                        .iter()
                        .filter(|b| b.rig.name != *n)
                        .map(|b| Layout::correspondences(n, &b.rig.name, frame)),
                );
            }
        }
    }
    if options.annotations.contains(&Annotation::Tracks) {
        for c in cameras {
            write_tracks(layout, frames, c, options, session.registry)?;
            files.push(Layout::tracks(&c.rig.name));
        }
    }
    summary.annotation_seconds += start.elapsed().as_secs_f64();
    if !options.exports.is_empty() {
        let mut export_cameras = Vec::new();
        for c in cameras {
            let mut list = Vec::new();
            for &(frame, _) in &frames.list {
                let path = layout.at(&Layout::camera_json(&c.rig.name, frame));
                let text = std::fs::read_to_string(&path)
                    .map_err(|e| DatasetError::Input(format!("{}: {e}", path.display())))?;
                let camera: Value = serde_json::from_str(&text)
                    .map_err(|e| DatasetError::Input(format!("{}:{}: {e}", path.display(), e.line())))?;
                list.push(ExportFrame {
                    frame: i32::try_from(frame).map_err(|_| {
                        DatasetError::Input(format!(
                            "frame {frame}: beyond the exports' 32-bit frame numbers"
                        ))
                    })?,
                    image: Layout::exr(&c.rig.name, frame),
                    camera,
                });
            }
            export_cameras.push(ExportCamera {
                name: c.rig.name.clone(),
                frames: list,
            });
        }
        let warnings = write_exports(layout.root(), &export_cameras, &options.exports)
            .map_err(|e| DatasetError::Output(e.to_string()))?;
        summary.warnings.extend(warnings);
        for dir in ["colmap", "gsplat", "nerfstudio"] {
            files.extend(files_under(layout.root(), Path::new(dir)));
        }
        if layout.root().join("transforms.json").is_file() {
            files.push(PathBuf::from("transforms.json"));
        }
    }
    let missing: Vec<String> = files
        .iter()
        .filter(|f| !layout.at(f).is_file())
        .map(|f| f.display().to_string())
        .collect();
    if let Some(first) = missing.first() {
        return Err(DatasetError::Input(format!(
            "{}: cannot finalize, {} file(s) of the rendered frames are missing (first: {first}); run the same command again (without --finalize) to make them",
            layout.root().display(),
            missing.len()
        )));
    }
    let manifest = json!({
        "layout": LAYOUT_VERSION,
        "complete": true,
        "options": options_value,
        "cameras": cameras_json(cameras),
        "frames": frames.list.iter().map(|f| f.0).collect::<Vec<_>>(),
        "files": files.iter().map(|p| p.to_string_lossy().replace('\\', "/")).collect::<Vec<_>>(),
        "warnings": summary.warnings,
    });
    write_json(&layout.manifest(), &manifest)?;
    summary.finalized = true;
    Ok(())
}
