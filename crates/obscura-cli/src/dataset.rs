//! `obscura dataset`: the command line of the dataset driver ([`obscura_dataset::run`]). What is here
//! is the command's own: its options, the terminal's reporter and the summary.

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::AtomicBool;

use clap::Args;
use obscura_dataset::export::ExportFormat;
use obscura_dataset::run::{
    ANNOTATION_NAMES, Annotation, DEFAULT_TRACKS, DatasetOptions, Finalize, ParamReader, RenderSettings,
    Session, export_names, parse_names,
};
use obscura_plugins::builtin_registry;
use obscura_plugins::loader::PluginSearch;
use obscura_render::job;
use obscura_render::pipeline::{Message, Reporter};
use obscura_render::sequence::FrameSpec;
use obscura_sdk::{ParamDecl, ParamList};

use crate::args::parse_format;
use crate::params::param_list;
use crate::signals;
use crate::stdout::outln;

/// Reads one name of `--exports`.
fn parse_export(text: &str) -> Result<ExportFormat, String> {
    parse_names("--exports", text, &export_names())?
        .first()
        .copied()
        .ok_or_else(|| "--exports: an empty name; expected colmap, nerfstudio or gsplat".to_string())
}

/// Reads one name of `--annotations`.
fn parse_annotation(text: &str) -> Result<Annotation, String> {
    parse_names("--annotations", text, &ANNOTATION_NAMES)?
        .first()
        .copied()
        .ok_or_else(|| "--annotations: an empty name; expected boxes, tracks or correspondences".to_string())
}

/// `obscura dataset`'s options.
#[derive(Args, Debug)]
pub struct DatasetArgs {
    /// A scene: .rib, .gltf, .glb, .obj or USD. Without one, the built-in scene.
    scene: Option<PathBuf>,
    /// The dataset directory (layout: docs/datasets.md).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Frames to render, as `obscura render --frames` (1-24, 1-24:2, 1-3,5). A farm task renders its
    /// frames into the same DIR; run --finalize after the last.
    #[arg(long = "frames", visible_alias = "frame", value_name = "SPEC")]
    frames: Option<FrameSpec>,
    /// A rig: an Obscura rig (.json, "schema": "obscura-rig/1"), a Kalibr camchain (.yaml) or COLMAP's
    /// rig_config.json. Each camera renders into images/<camera>/.
    #[arg(long, value_name = "FILE")]
    rig: Option<PathBuf>,
    /// Camera exports: colmap, nerfstudio, gsplat (comma-separated).
    #[arg(long, value_name = "LIST", value_parser = parse_export, value_delimiter = ',')]
    exports: Vec<ExportFormat>,
    /// Annotations: boxes, tracks, correspondences (comma-separated).
    #[arg(long, value_name = "LIST", value_parser = parse_annotation, value_delimiter = ',')]
    annotations: Vec<Annotation>,
    /// Track points sampled per object (--annotations tracks).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_TRACKS, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    tracks: u32,
    /// Render nothing: assemble the exports, tracks and dataset.json from the frames on disk (every
    /// frame of --frames, or of the scene, must be complete). The last step of a farm job.
    #[arg(long)]
    finalize: bool,
    /// Render through this projection instead of the scene's (the rig base's lens).
    #[arg(short, long, conflicts_with = "calibration")]
    projection: Option<String>,
    /// A projection parameter: 'float fov=60', 'fov=60' or RIB's '"float fov" [60]'. Repeatable.
    #[arg(long = "param", value_name = "PARAM")]
    params: Vec<String>,
    /// Render through a real camera's calibration file (as `obscura render --calibration`).
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// The camera of a calibration file holding several.
    #[arg(long, value_name = "ID", requires = "calibration")]
    camera: Option<String>,
    /// Image size WIDTHxHEIGHT (default: the scene's, or the calibration's).
    #[arg(long, value_parser = parse_format)]
    format: Option<(u32, u32)>,
    /// Samples per pixel (default: the scene's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    spp: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Maximum path depth.
    #[arg(long, default_value_t = 6)]
    max_depth: u32,
    /// Seed of the sample sequences.
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// Frames per second of an animated scene (glTF).
    #[arg(long, default_value_t = 24.0, value_parser = crate::render::parse_fps)]
    fps: f32,
    /// Print only warnings and errors.
    #[arg(short, long)]
    quiet: bool,
}

/// `--param` arguments, read against the projection's table as `obscura render` reads them.
struct CliParams<'a>(&'a [String]);

impl ParamReader for CliParams<'_> {
    fn read(&self, projection: &str, table: &[ParamDecl]) -> Result<ParamList, String> {
        param_list(self.0, projection, table).map_err(|e| e.to_string())
    }

    fn describe(&self) -> Vec<String> {
        self.0.to_vec()
    }
}

/// Messages on stderr (texture and info notes once per run), the signal handler's cancel flag.
struct Terminal {
    told: Mutex<HashSet<String>>,
    cancellable: Mutex<Option<signals::Cancellable>>,
}

impl Reporter for Terminal {
    fn message(&self, kind: Message, text: &str) {
        let once = matches!(kind, Message::Texture | Message::Info | Message::Setup);
        if once
            && !self
                .told
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .insert(text.to_string())
        {
            return;
        }
        eprintln!("{}", kind.line(text));
    }

    fn cancel(&self) -> &AtomicBool {
        &job::CANCEL
    }

    fn rendering(&self) {
        let mut phase = self
            .cancellable
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        phase.get_or_insert_with(signals::Cancellable::enter);
    }
}

/// `list` with repeated entries kept once, in order.
fn dedup<T: Copy + PartialEq>(list: &[T]) -> Vec<T> {
    let mut out = Vec::new();
    for &x in list {
        if !out.contains(&x) {
            out.push(x);
        }
    }
    out
}

/// `obscura dataset`.
pub fn run(a: &DatasetArgs, search: &PluginSearch) -> Result<(), String> {
    if let Some(n) = a.threads {
        obscura_render::limits::check_threads(n).map_err(|e| e.to_string())?;
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(|e| e.to_string())?;
    }
    let options = DatasetOptions {
        scene: a.scene.clone(),
        output: a.output.clone(),
        frames: a.frames.clone(),
        rig: a.rig.clone(),
        exports: dedup(&a.exports),
        annotations: dedup(&a.annotations),
        tracks: a.tracks,
        render: RenderSettings {
            format: a.format,
            projection: a.projection.clone(),
            calibration: a.calibration.clone(),
            camera: a.camera.clone(),
            spp: a.spp,
            seed: a.seed,
            max_depth: a.max_depth,
            fps: a.fps,
        },
        finalize: if a.finalize {
            Finalize::Only
        } else {
            Finalize::Auto
        },
    };
    let mut registry = builtin_registry();
    let reporter = Terminal {
        told: Mutex::new(HashSet::new()),
        cancellable: Mutex::new(None),
    };
    let params = CliParams(&a.params);
    let mut session = Session {
        registry: &mut registry,
        search,
        reporter: &reporter,
        params: &params,
    };
    let summary = obscura_dataset::run::run(&options, &mut session).map_err(|e| e.to_string())?;
    drop(reporter);
    for w in &summary.warnings {
        eprintln!("warning: {w}");
    }
    if !a.quiet {
        outln!(
            "{}: rendered {} camera frame(s) in {:.2} s, annotations {:.3} s, {} already complete (skipped){}",
            a.output.display(),
            summary.rendered.len(),
            summary.render_seconds,
            summary.annotation_seconds,
            summary.skipped.len(),
            if summary.finalized {
                "; finalized (dataset.json complete)".to_string()
            } else {
                "; not finalized: run the same command with --finalize once every frame is rendered"
                    .to_string()
            }
        );
    }
    Ok(())
}
