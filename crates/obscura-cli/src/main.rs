//! The `obscura` command. Argument parsing only: every job lives in the library crates.

#![forbid(unsafe_code)]
// The argument structs' doc comments are clap's `--help` text, shown as written: `[60]` and `<Name>`
// there are RIB and shell notation, not rustdoc links or HTML.
#![allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)]

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use crate::args::{crop_window, load_calibration, parse_format};
use crate::params::merge_param_args;
use clap::{Args, Parser, Subcommand};
use obscura_host::aperture::ApertureDesc;
use obscura_host::shutter::ShutterDesc;
use obscura_host::{CameraDesc, CameraStage};
use obscura_image::raymap::{trace_ray_map, write_exr};
use obscura_plugins::listing;
use obscura_plugins::loader::{PluginSearch, ensure, load_all};
use obscura_plugins::{builtin_registry, isolate};
use obscura_render::job::{self, CALIBRATED, Calibrated};
use obscura_render::limits::{self, OutputKind};
use obscura_render::sequence::FrameSpec;
use obscura_sdk::{Format, ScreenWindow};

mod args;
mod build_plugin;
mod check;
mod dataset;
mod farm;
mod lens;
mod nuke_export;
mod overscan;
mod params;
mod render;
mod signals;
mod stdout;
mod stmap;
mod usd;

use crate::stdout::{out, outln};

/// Obscura: RenderMan-style camera projection plugins, and the host that drives them.
#[derive(Parser, Debug)]
#[command(name = "obscura", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// A directory holding projection plugins (<Name>.so), searched before OBSCURA_PLUGIN_PATH.
    /// Repeatable.
    #[arg(long = "plugin-path", value_name = "DIR", global = true)]
    plugin_path: Vec<PathBuf>,
    /// Run every plugin library in worker processes: a crash, abort or hang in a plugin costs the
    /// batch it was projecting (counted and reported), never the run. OBSCURA_ISOLATE_PLUGINS=Name,…
    /// isolates only the plugins named (`*`: all).
    #[arg(long, global = true)]
    isolate_plugins: bool,
    /// Seconds an isolated plugin's call may take before its worker is killed and the batch lost.
    #[arg(long, value_name = "SECONDS", global = true, default_value = "10", value_parser = args::parse_timeout)]
    plugin_timeout: std::time::Duration,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Write every pixel's camera ray (origin, direction, radius, spread, tint, valid) as OpenEXR.
    Rays(Box<RaysArgs>),
    /// Render a scene (RIB, glTF, OBJ, or the built-in one) through any projection: EXR + PNG.
    Render(Box<RenderArgs>),
    /// List the projections and their parameter tables: the built-ins and every plugin library on the
    /// plugin path (--plugin-path, OBSCURA_PLUGIN_PATH), or the one named.
    Plugins {
        /// Show only this projection.
        name: Option<String>,
        /// Print only the projections' names, one per line.
        #[arg(long, conflicts_with = "name")]
        names: bool,
    },
    /// Write the ST-map (Nuke's STMap convention) that turns images of one projection into another.
    Stmap(Box<stmap::StmapArgs>),
    /// Check a projection against the contract (directions, times, spread, field of view, deep metric,
    /// dicing hint, unproject, determinism, thread safety, property types); exit 0 when clean, 1 when a check failed, 2 when it could not run.
    Check(Box<check::CheckArgs>),
    /// A lens prescription's paraxial data, field, distortion and vignetting (--json), and its
    /// drawing with traced ray fans (--diagram out.svg|png).
    Lens(Box<lens::LensArgs>),
    /// Write a calibrated camera as a Nuke LD_3DE4_* node (a 3DE lens as it is; COLMAP's and
    /// OpenCV's pinhole models fitted with 3DE4 Radial - Standard, Degree 4, the residual printed).
    ExportNuke(Box<nuke_export::ExportNukeArgs>),
    /// A USD stage's cameras as JSON: every UsdGeomCamera attribute (authored or its schema fallback),
    /// the world transform and the lens-distortion model, at Default and at time codes.
    UsdCameras(Box<usd::UsdCamerasArgs>),
    /// The collect step of a farm job: check that every frame of a shot is complete (its camera JSON
    /// says "complete": true) and, with --tiles, stitch each frame's tiles into the image a
    /// one-process render writes (EXR, PNG, sidecars), atomically. Lists what is missing; exit 1 if
    /// anything is.
    Merge(Box<farm::MergeArgs>),
    /// Write a farm job for a shot (a Slurm job array over frame chunks × tiles and a collect job, or
    /// an Open Job Description template) and submit it (sbatch / openjd run), printing the job ids.
    Submit(Box<farm::SubmitArgs>),
    /// Compile a RenderMan projection plugin's C++ sources, as they are written (RenderMan 19-21, 22 or
    /// 23-27), into an Obscura plugin with the embedded RenderMan-compatible headers.
    BuildPlugin(Box<build_plugin::BuildPluginArgs>),
    /// Render a dataset for vision: images of every camera of a rig with ground truth, camera exports
    /// (COLMAP, nerfstudio, gsplat), boxes, point tracks and correspondences, in the layout of
    /// docs/datasets.md. Resumable; splittable by frame (--frames, then --finalize).
    Dataset(Box<dataset::DatasetArgs>),
}

#[derive(Args, Debug)]
struct RenderArgs {
    /// A scene: .rib, .gltf, .glb, .obj or USD (.usd, .usda, .usdc, .usdz). Without one, the built-in scene.
    scene: Option<PathBuf>,
    /// Output EXR (beauty, alpha, z, N, P, cameraDirection) plus a PNG preview beside it. Default: the
    /// scene's Display, else render.exr.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Use this projection instead of the scene's.
    #[arg(short, long, conflicts_with = "calibration")]
    projection: Option<String>,
    /// The frames to render: N, A-B, A-B:S or A-BxS (every S-th frame), or a comma list of them such as
    /// 1-3,5,7-20:2 (the forms Slurm, OpenJD and OpenCue write). A run of # in an output's file name
    /// becomes the zero-padded frame number (out.####.exr); without one, several frames write
    /// out.0001.exr, out.0002.exr, … by frame number.
    #[arg(long = "frames", visible_alias = "frame", value_name = "SPEC")]
    frames: Option<FrameSpec>,
    /// Render through a real camera's calibration file (COLMAP cameras.txt, OpenCV YAML/JSON, Kalibr
    /// camchain.yaml, OCamCalib calib_results.txt, a Nuke script with 3DE LD nodes, a 3DE lens export) with CalibratedCamera. The image size defaults to
    /// the calibration's; --format resamples the same camera. --param adds to or replaces its parameters.
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// The camera of a calibration file holding several (a COLMAP CAMERA_ID, Kalibr's cam0, a Nuke LD
    /// node's name, …), or of a USD stage (a Camera prim's path or name; default: the RenderSettings'
    /// camera).
    #[arg(long, value_name = "ID")]
    camera: Option<String>,
    /// Also write the camera rendered with (transform over the frames, gate, lens-distortion schema)
    /// as a USD layer (.usda).
    #[arg(long, value_name = "FILE")]
    export_usd: Option<PathBuf>,
    /// A projection parameter: 'float fov=60', 'fov=60' or RIB's '"float fov" [60]'. Repeatable.
    #[arg(long = "param", value_name = "PARAM")]
    params: Vec<String>,
    /// Image size in pixels, WIDTHxHEIGHT (default: the scene's — RIB Format, a USD stage's
    /// RenderProduct resolution — else 640x480).
    #[arg(long, value_parser = parse_format)]
    format: Option<(u32, u32)>,
    /// Samples per pixel (default: the scene's Hider maxsamples).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    spp: Option<u32>,
    /// Worker threads, 1 to 1024 (default: one per CPU this process may run on: its affinity mask, as
    /// Slurm, a cgroup cpuset or taskset set it).
    #[arg(long)]
    threads: Option<usize>,
    /// CropWindow xmin xmax ymin ymax, in NDC (y down).
    #[arg(long, num_args = 4, value_names = ["XMIN", "XMAX", "YMIN", "YMAX"])]
    crop: Option<Vec<f32>>,
    /// Maximum path depth.
    #[arg(long, default_value_t = 6)]
    max_depth: u32,
    /// The most triangles the scene may dice into; beyond it the render stops with a message naming
    /// the primitive (up to 450 bytes each with the BVH). Lowered to what the memory the job may use
    /// holds (`OBSCURA_MEMORY_LIMIT`, `MemAvailable`, the cgroup's and the address-space limit).
    #[arg(long, default_value_t = obscura_geometry::dice::DEFAULT_SCENE_TRIANGLES, value_name = "N")]
    max_triangles: u64,
    /// Seed of the sample sequences.
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// No progress bar, summary or notes. Warnings and errors are still printed.
    #[arg(short, long)]
    quiet: bool,
    /// AOVs to add to every EXR: cameraZ, distance, Pcamera, Ncamera, objectId, instanceId,
    /// materialId, flowForward, flowBackward, flowValid (ground truth), albedo, uv (textures), or all
    /// of them with 'all'.
    /// Repeatable or comma-separated. IDs and flow also write <image>.ids.json and <image>.camera.json.
    #[arg(long = "aov", value_name = "NAME", value_delimiter = ',', value_parser = render::parse_aovs)]
    aovs: Vec<Vec<obscura_scene::Aov>>,
    /// Frames per second of an animated scene (glTF): frame N is posed at (N − 1)/fps seconds.
    #[arg(long, default_value_t = 24.0, value_parser = render::parse_fps)]
    fps: f32,
    // Farm options (issue 27): tiles and progress lines.
    /// Render only tile I (from 0) of N horizontal bands of each frame; its files are named
    /// NAME.tileI-1xN.EXT. `obscura merge --tiles 1xN` stitches them.
    #[arg(long, value_name = "I/N", value_parser = farm::parse_tile, conflicts_with_all = ["tiles", "crop"])]
    tile: Option<(u32, obscura_image::tiles::TileGrid)>,
    /// Split each frame in a grid of COLSxROWS tiles and render only --tile-index I (row-major from
    /// the top left, from 0); files are named NAME.tileI-CxR.EXT.
    #[arg(long, value_name = "CxR", value_parser = farm::parse_grid, conflicts_with = "crop")]
    tiles: Option<obscura_image::tiles::TileGrid>,
    /// The tile of --tiles this task renders, from 0.
    #[arg(long, value_name = "I")]
    tile_index: Option<u32>,
    /// Progress lines for a farm: plain (a line every few seconds on stderr, the default when stderr
    /// is not a terminal), openjd (openjd_progress / openjd_status on stdout), tractor (TR_PROGRESS
    /// on stdout), or none.
    #[arg(long, value_enum, value_name = "MODE")]
    progress: Option<render::ProgressMode>,
    /// Always write <image>.camera.json beside each frame's first image, with "complete": true once
    /// every file of the frame is written (false when interrupted): what `obscura merge` checks, and
    /// how a rerun knows which frames to skip. Written anyway with ground-truth AOVs and for animations.
    /// May be repeated (a farm job adds it to the user's arguments).
    #[arg(long, overrides_with = "camera_json")]
    camera_json: bool,
    // The image sensor (issue 30): exposure, noise, CFA, raw and ISP after the film.
    /// An image sensor after the lens, described in JSON (keys: docs/sensor.md): the beauty becomes
    /// the ISP's processed image, every EXR gains the raw and electrons channels, and the camera JSON
    /// records the sensor. Replaces the scene's Option "sensor".
    #[arg(long, value_name = "FILE.json")]
    sensor: Option<PathBuf>,
    /// One key of the sensor description, KEY=VALUE with VALUE in JSON (a bare word is a string):
    /// iso=800, cfa=BGGR, isp.demosaic=bilinear, rolling_shutter.line_time_s=1e-5. Repeatable; over
    /// --sensor's file, else over the defaults.
    #[arg(long = "sensor-param", value_name = "KEY=VALUE")]
    sensor_params: Vec<String>,
    /// Write the sensor's raw mosaic as a DNG file (needs a sensor).
    #[arg(long, value_name = "OUT.dng")]
    raw: Option<PathBuf>,
    // Overscan (issue 26): the CG for a plate, larger than the plate.
    /// Render past the plate (the --format, else the calibration's size) by PIXELS on every side,
    /// LEFT,TOP,RIGHT,BOTTOM, or auto: the margins of Nuke's LD_3DE4_* bounding box of the
    /// undistorted plate (needs --calibration with a 3DEqualizer lens). With a 3DE lens the render is
    /// its undistorted pinhole; otherwise the scene's camera with its screen window pushed out at
    /// the same pixel pitch. Each EXR's display window is the plate and its data window the
    /// overscanned box; the PNG preview shows the plate; the camera JSON records both.
    #[arg(long, value_name = "PIXELS|L,T,R,B|auto", value_parser = overscan::parse_overscan,
          conflicts_with_all = ["tile", "tiles", "crop", "sensor", "sensor_params", "raw"])]
    overscan: Option<overscan::OverscanArg>,
}

#[derive(Args, Debug)]
struct RaysArgs {
    /// The projection, e.g. PxrPerspective, PxrOrthographic.
    #[arg(short, long, default_value = "PxrPerspective", conflicts_with = "calibration")]
    projection: String,
    /// A projection parameter: 'float fov=60', 'fov=60' or RIB's '"float fov" [60]'. Repeatable.
    #[arg(long = "param", value_name = "PARAM")]
    params: Vec<String>,
    /// Trace through a real camera's calibration file (COLMAP cameras.txt, OpenCV YAML/JSON, Kalibr
    /// camchain.yaml, OCamCalib calib_results.txt, a Nuke script with 3DE LD nodes, a 3DE lens export) with CalibratedCamera. --param adds to or replaces
    /// its parameters.
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// The camera of a calibration file holding several (a COLMAP CAMERA_ID, Kalibr's cam0, a Nuke LD node's name, …).
    #[arg(long, value_name = "ID", requires = "calibration")]
    camera: Option<String>,
    /// Image size in pixels, WIDTHxHEIGHT (default: the calibration's resolution, else 640x480).
    #[arg(long, value_parser = parse_format)]
    format: Option<(u32, u32)>,
    /// Pixel aspect ratio (pixel width / height).
    #[arg(long, default_value_t = 1.0)]
    pixel_aspect: f32,
    /// ScreenWindow left right bottom top (default: from the frame aspect).
    #[arg(long, num_args = 4, value_names = ["L", "R", "B", "T"], allow_negative_numbers = true)]
    screen_window: Option<Vec<f32>>,
    /// CropWindow xmin xmax ymin ymax, in NDC (y down).
    #[arg(long, num_args = 4, value_names = ["XMIN", "XMAX", "YMIN", "YMAX"])]
    crop: Option<Vec<f32>>,
    /// Shutter open close (scene time).
    #[arg(long, num_args = 2, value_names = ["OPEN", "CLOSE"], allow_negative_numbers = true)]
    shutter: Option<Vec<f32>>,
    /// Clipping near far.
    #[arg(long, num_args = 2, value_names = ["NEAR", "FAR"])]
    clipping: Option<Vec<f32>>,
    /// Also write N sampled rays of every pixel, as layers sample1..sampleN.
    #[arg(long, default_value_t = 0)]
    samples: u32,
    /// Seed of the sample sequence.
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// Camera option apertureNSides (< 3: circular).
    #[arg(long, default_value_t = 0)]
    aperture_sides: i32,
    /// Camera option apertureAngle, degrees.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    aperture_angle: f32,
    /// Camera option apertureRoundness, -1..1.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    aperture_roundness: f32,
    /// Camera option apertureDensity, -1..1.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    aperture_density: f32,
    /// Camera option dofaspect.
    #[arg(long, default_value_t = 1.0)]
    dof_aspect: f32,
    /// Camera option shutterOpenTime, 0..1.
    #[arg(long, default_value_t = 0.0)]
    shutter_open_time: f32,
    /// Camera option shutterCloseTime, 0..1.
    #[arg(long, default_value_t = 1.0)]
    shutter_close_time: f32,
    /// Camera option shutteropening: eight Bézier control values c1 c2 d1 d2 e1 e2 f1 f2.
    #[arg(long, num_args = 8, value_name = "V")]
    shutter_opening: Option<Vec<f32>>,
    /// Output file.
    #[arg(short, long, default_value = "rays.exr")]
    output: PathBuf,
}

/// The camera `obscura rays` traces: the options as given; the image size is `--format`, else the
/// calibration's, else 640x480.
fn camera(a: &RaysArgs, calibration: Option<&Calibrated>) -> CameraDesc {
    let (width, height) = a
        .format
        .or(calibration.map(Calibrated::size))
        .unwrap_or((640, 480));
    let mut cam = CameraDesc::new(Format {
        width,
        height,
        pixel_aspect: a.pixel_aspect,
    });
    cam.screen_window = a
        .screen_window
        .as_ref()
        .map(|w| ScreenWindow::new(w[0], w[1], w[2], w[3]));
    if let Some(c) = &a.crop {
        cam.crop_window = crop_window(c);
    }
    if let Some(s) = &a.shutter {
        cam.shutter = (s[0], s[1]);
    }
    if let Some(c) = &a.clipping {
        cam.clipping = (c[0], c[1]);
    }
    cam.aperture = ApertureDesc {
        n_sides: a.aperture_sides,
        angle_deg: a.aperture_angle,
        roundness: a.aperture_roundness,
        density: a.aperture_density,
        dof_aspect: a.dof_aspect,
    };
    cam.shutter_opening = ShutterDesc {
        open_time: a.shutter_open_time,
        close_time: a.shutter_close_time,
        opening: a
            .shutter_opening
            .as_ref()
            .map(|v| std::array::from_fn(|i| v[i]))
            .unwrap_or(ShutterDesc::default().opening),
    };
    cam
}

/// What set the image size, for messages: `--format`, a calibration file, or `default`.
fn size_source(format: Option<(u32, u32)>, calibration: Option<&Path>, default: &str) -> String {
    match (format, calibration) {
        (Some(_), _) => "--format".to_string(),
        (None, Some(path)) => format!("{}: the calibration's image size", path.display()),
        (None, None) => default.to_string(),
    }
}

fn rays(a: &RaysArgs, search: &PluginSearch) -> Result<(), String> {
    limits::check_output(&a.output, OutputKind::Exr).map_err(|e| e.to_string())?;
    let mut registry = obscura_plugins::cli_registry();
    let calibration = a
        .calibration
        .as_deref()
        .map(|path| load_calibration(path, a.camera.as_deref(), false))
        .transpose()?;
    let projection = match calibration {
        Some(_) => CALIBRATED.to_string(),
        None => ensure(&mut registry, &a.projection, search).map_err(|e| e.to_string())?,
    };
    let factory = registry.find(&projection).map_err(|e| e.to_string())?;
    let mut params = calibration.as_ref().map(|c| c.params.clone()).unwrap_or_default();
    merge_param_args(&mut params, &a.params, factory.name(), factory.param_table())?;
    let cam = camera(a, calibration.as_ref());
    if a.samples > obscura_host::sampler::MAX_SAMPLES {
        return Err(obscura_image::raymap::RayMapError::TooManySamples(a.samples).to_string());
    }
    let source = size_source(a.format, a.calibration.as_deref(), "the default size");
    limits::check_image_size(cam.format.width, cam.format.height, &source).map_err(|e| e.to_string())?;
    limits::check_memory(
        limits::ray_map_bytes(cam.pixels().len() as u64, a.samples),
        &format!(
            "a {}x{} ray map with {} sample layer(s)",
            cam.format.width, cam.format.height, a.samples
        ),
    )
    .map_err(|e| e.to_string())?;
    if let Some(w) = calibration.as_ref().and_then(|c| c.aspect_warning(cam.format)) {
        eprintln!("warning: {w}");
    }
    let stage = CameraStage::new(&mut registry, &projection, &params, &cam).map_err(|e| e.to_string())?;
    for w in stage.setup_warnings() {
        eprintln!("{w}");
    }
    let (map, report) = trace_ray_map(&stage, a.samples, a.seed).map_err(|e| e.to_string())?;
    if let Some(w) = report.warning(stage.name()) {
        eprintln!("{w}");
    }
    let mut attributes = vec![
        ("obscura:projection", projection.clone()),
        ("obscura:parameters", a.params.join("; ")),
    ];
    if let Some(c) = &calibration {
        attributes.push(("obscura:calibration", c.calibration.summary()));
    }
    write_exr(&map, cam.format, cam.screen_window(), &attributes, &a.output).map_err(|e| e.to_string())?;
    outln!(
        "wrote {}: {} rays of {} ({}x{} pixels, {} layer{}), {} culled by the projection, {} lost to failed project calls, {} culled for breaking the contract",
        a.output.display(),
        report.samples,
        projection,
        map.pixels.width(),
        map.pixels.height(),
        map.layers.len(),
        if map.layers.len() == 1 { "" } else { "s" },
        report.culled,
        report.lost(),
        report.breaches()
    );
    Ok(())
}

/// `obscura plugins [NAME]`: a NAME that is not built in (or a path) is loaded as a plugin first.
/// `obscura plugins [NAME] [--names]`: one projection (a built-in, or a plugin found by name or
/// path), or every built-in and every plugin library along the plugin path. A library that does not
/// load is a warning naming it; the others are still listed.
fn plugins(name: Option<&str>, names_only: bool, search: &PluginSearch) -> Result<(), String> {
    // One projection: any name `rays`/`render`/`check` accept, StMapCamera included. The full
    // listing (and `--names`, which `.ci/run` checks each of with its defaults) is the built-ins and
    // plugins only: the file projections have no usable defaults (see FILE_PROJECTIONS).
    let mut registry = if name.is_some() {
        obscura_plugins::cli_registry()
    } else {
        builtin_registry()
    };
    let name = match name {
        Some(n) => Some(ensure(&mut registry, n, search).map_err(|e| e.to_string())?),
        None => {
            for e in load_all(&mut registry, search).1 {
                eprintln!("warning: {e}");
            }
            None
        }
    };
    if names_only {
        registry.names().iter().for_each(|n| outln!("{n}"));
        return Ok(());
    }
    let text = listing::list(&registry, name.as_deref()).map_err(|e| e.to_string())?;
    out!("{text}");
    Ok(())
}

/// Warns about `--plugin-path` directories and `OBSCURA_PLUGIN_PATH` entries that are not directories.
fn check_plugin_path(cli: &Cli) {
    let given = cli.plugin_path.iter().map(|d| ("--plugin-path", d.clone()));
    let env = std::env::var_os("OBSCURA_PLUGIN_PATH")
        .map(|list| std::env::split_paths(&list).collect::<Vec<_>>())
        .unwrap_or_default();
    let env = env
        .into_iter()
        .filter(|d| !d.as_os_str().is_empty())
        .map(|d| ("OBSCURA_PLUGIN_PATH entry", d));
    for (label, dir) in given.chain(env) {
        if !dir.is_dir() {
            let what = if dir.exists() {
                "not a directory"
            } else {
                "no such directory"
            };
            eprintln!("warning: {label} {}: {what}", dir.display());
        }
    }
}

fn main() -> ExitCode {
    if std::env::args_os()
        .nth(1)
        .is_some_and(|a| a == isolate::WORKER_ARG)
    {
        // A host started this process to run a plugin for it (`--isolate-plugins`).
        return ExitCode::from(u8::try_from(isolate::worker_main()).unwrap_or(2));
    }
    signals::install();
    let cli = Cli::parse();
    check_plugin_path(&cli);
    let isolation = match isolate::Isolation::from_env(cli.isolate_plugins, cli.plugin_timeout) {
        Ok(i) => i,
        Err(e) => {
            eprintln!("error: --isolate-plugins: cannot find this executable to run plugin workers: {e}");
            return ExitCode::from(2);
        }
    };
    let search = PluginSearch::from_env(&cli.plugin_path).with_isolation(isolation);
    let result = match &cli.command {
        Command::Rays(a) => rays(a, &search),
        Command::Render(a) => render::render(a, &search),
        Command::Stmap(a) => stmap::run(a, &mut obscura_plugins::cli_registry(), &search),
        Command::Lens(a) => lens::run(a),
        Command::ExportNuke(a) => nuke_export::run(a),
        Command::UsdCameras(a) => usd::run(a),
        Command::Merge(a) => farm::merge(a),
        Command::Submit(a) => farm::submit(a),
        Command::Dataset(a) => dataset::run(a, &search),
        Command::BuildPlugin(a) => build_plugin::run(a).map_err(|e| e.to_string()),
        Command::Check(a) => match check::run(a, &search) {
            check::Outcome::Clean => Ok(()),
            check::Outcome::Broken(e) => Err(e),
            check::Outcome::CouldNotRun(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(2);
            }
        },
        Command::Plugins { name, names } => plugins(name.as_deref(), *names, &search),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            match signals::received() {
                Some(signal) if job::CANCEL.load(std::sync::atomic::Ordering::SeqCst) => {
                    ExitCode::from(signals::exit_status(signal))
                }
                _ => ExitCode::FAILURE,
            }
        }
    }
}
