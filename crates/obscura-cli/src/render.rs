//! `obscura render`: the scene opened frame by frame, the command line's overrides, and each frame
//! through the library's one frame pipeline ([`obscura_render::pipeline::render_frame`]). What is
//! here is the command's own: which frames, the terminal's reporter, the summaries.
//!
//! An animated scene (glTF) is posed at each frame, its flow reaching the neighbouring frames, and a
//! complete frame is skipped, so an interrupted sequence resumes where it stopped. A file's own images
//! (RIB's worlds) render once each and are written as every frame that selects them.

use std::collections::HashSet;
use std::io::IsTerminal;
use std::sync::Mutex;
use std::sync::atomic::AtomicBool;

use obscura_host::Registry;
use obscura_plugins::cli_registry;
use obscura_plugins::loader::{PluginSearch, ensure};
use obscura_render::frame::{Neighbours, add_aovs, is_complete, without_backward_flow};
use obscura_render::job::{self, Calibrated, Overrides};
use obscura_render::limits::{self, OutputKind};
use obscura_render::pipeline::{
    FrameJob, FrameResult, FrameWrite, Message, Reporter, Sidecars, render_frame,
};
use obscura_render::render::RenderOptions;
use obscura_render::sequence::{FrameSpec, frame_displays, sequence_displays};
use obscura_scene::source::SceneSource;
use obscura_scene::{Aov, Display, Scene};
use obscura_sdk::{Format, ParamList};
use obscura_sensor::SensorConfig;
use obscura_shading::integrator::PathOptions;

use crate::args::{crop_window, load_calibration};
use crate::farm::Tile;
use crate::overscan::Plan;
use crate::params::param_list;
use crate::stdout::outln;
use crate::{RenderArgs, signals, size_source};

/// Reads `--aov`: one AOV name of the table, or `all` for every ground-truth AOV and the texture
/// AOVs.
pub fn parse_aovs(text: &str) -> Result<Vec<Aov>, String> {
    if text == "all" {
        return Ok(Aov::all_extra().collect());
    }
    Aov::from_name(text).map(|a| vec![a]).ok_or_else(|| {
        let names: Vec<&str> = Aov::all_extra().map(Aov::name).collect();
        format!(
            "unknown AOV '{text}'; expected one of {}, or all",
            names.join(", ")
        )
    })
}

/// Reads `--fps`: a positive finite number.
pub fn parse_fps(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("'{text}' is not a positive number of frames per second")),
    }
}

/// How progress is shown besides the terminal's bar (`--progress`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ProgressMode {
    /// `progress: frame 7 (2 of 4) 50%, overall 37.5%` on stderr, every few seconds and at the end of
    /// each frame.
    Plain,
    /// Open Job Description's lines on stdout: `openjd_status: frame 7 (2 of 4)` as a frame
    /// starts, `openjd_progress: 37.5` (the task's percentage) as it renders.
    Openjd,
    /// Tractor's `TR_PROGRESS 37%` on stdout.
    Tractor,
    /// No progress lines.
    None,
}

/// Seconds between two progress lines within a frame.
const LINE_INTERVAL: f64 = 2.0;

/// Where the progress lines are.
struct Lines {
    mode: ProgressMode,
    state: Mutex<LineState>,
}

/// The frame being rendered and the last line printed.
struct LineState {
    /// The frame's number, its position (from 0) and how many the task renders.
    frame: Option<u32>,
    index: usize,
    count: usize,
    last: Option<std::time::Instant>,
    /// The last overall percentage printed, so that the end of a frame is printed once.
    printed: f64,
}

impl Lines {
    /// The line for `done` of `total` tiles of the current frame, if one is due.
    fn line(&self, done: usize, total: usize) -> Option<String> {
        let mut s = self
            .state
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let frame_part = if total == 0 {
            0.0
        } else {
            done as f64 / total as f64
        };
        let overall = 100.0 * (s.index as f64 + frame_part) / s.count.max(1) as f64;
        let due = s.last.is_none_or(|t| t.elapsed().as_secs_f64() >= LINE_INTERVAL);
        if !(due || done == total) || overall <= s.printed {
            return None;
        }
        s.last = Some(std::time::Instant::now());
        s.printed = overall;
        let frame = s.frame.map_or(String::new(), |n| {
            format!("frame {n} ({} of {}) ", s.index + 1, s.count)
        });
        Some(match self.mode {
            ProgressMode::Plain => format!(
                "progress: {frame}{:.0}%, overall {overall:.1}%",
                100.0 * frame_part
            ),
            ProgressMode::Openjd => format!("openjd_progress: {overall:.1}"),
            ProgressMode::Tractor => format!("TR_PROGRESS {:.0}%", overall.floor()),
            ProgressMode::None => return None,
        })
    }
}

/// The terminal's reporter: messages on stderr (warnings even with `--quiet`, which silences progress
/// and summaries only), a progress bar when stderr is a terminal, otherwise (or as `--progress` asks)
/// progress lines a farm reads, the signal handler's cancel flag.
/// Texture warnings and notes are told once per run: they are the same at every frame.
struct Terminal {
    bar: Option<indicatif::ProgressBar>,
    lines: Option<Lines>,
    told: Mutex<HashSet<String>>,
    /// While set, a signal cancels the render instead of ending the process: from the first frame's
    /// tiles until the reporter is dropped, after the last file is written.
    cancellable: Mutex<Option<signals::Cancellable>>,
}

impl Terminal {
    /// The reporter of `a`: a bar when `bar` and stderr is a terminal and no `--progress` mode is
    /// asked for; progress lines as `--progress` says, by default plain lines when stderr is not a
    /// terminal (none with `--quiet`).
    fn new(a: &RenderArgs, bar: bool) -> Self {
        let terminal = std::io::stderr().is_terminal();
        let mode = match a.progress {
            Some(m) => m,
            None if a.quiet || terminal => ProgressMode::None,
            None => ProgressMode::Plain,
        };
        let bar = (bar && !a.quiet && terminal && a.progress.is_none()).then(|| {
            let b = indicatif::ProgressBar::new(0);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{bar:40} {pos}/{len} tiles  {elapsed} elapsed, ETA {eta}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b
        });
        Terminal {
            bar,
            lines: (mode != ProgressMode::None).then(|| Lines {
                mode,
                state: Mutex::new(LineState {
                    frame: None,
                    index: 0,
                    count: 1,
                    last: None,
                    printed: -1.0,
                }),
            }),
            told: Mutex::new(HashSet::new()),
            cancellable: Mutex::new(None),
        }
    }

    /// A frame starts: frame `number`, the `index`-th (from 0) of `count` this task renders.
    fn start_frame(&self, number: Option<u32>, index: usize, count: usize) {
        let Some(lines) = &self.lines else { return };
        {
            let mut s = lines
                .state
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            s.frame = number;
            s.index = index;
            s.count = count;
            s.last = None;
        }
        if lines.mode == ProgressMode::Openjd {
            let what = number.map_or("image".to_string(), |n| format!("frame {n}"));
            outln!("openjd_status: rendering {what} ({} of {count})", index + 1);
        }
    }
}

impl Reporter for Terminal {
    fn message(&self, kind: Message, text: &str) {
        if matches!(kind, Message::Texture | Message::Info) {
            let mut told = self
                .told
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            if !told.insert(text.to_string()) {
                return;
            }
        }
        eprintln!("{}", kind.line(text));
    }

    fn progress(&self, done: usize, total: usize) {
        if let Some(b) = &self.bar {
            b.set_length(total as u64);
            b.set_position(done as u64);
        }
        if let Some(lines) = &self.lines
            && let Some(line) = lines.line(done, total)
        {
            if lines.mode == ProgressMode::Plain {
                eprintln!("{line}");
            } else {
                outln!("{line}");
            }
        }
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

    fn rendered(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// Where an image is in the task's list, for progress lines.
#[derive(Debug, Clone, Copy)]
struct Position {
    /// Its frame number, if the scene numbers it.
    number: Option<u32>,
    /// Its position in the task's list, from 0.
    index: usize,
    /// How many images the task renders.
    count: usize,
}

/// The tile of `--tile` or `--tiles`/`--tile-index`, if any.
fn tile_of(a: &RenderArgs) -> Result<Option<Tile>, String> {
    Tile::of_args(a.tile, a.tiles, a.tile_index)
}

/// `obscura render`.
pub fn render(a: &RenderArgs, search: &PluginSearch) -> Result<(), String> {
    if let Some(n) = a.threads {
        limits::check_threads(n).map_err(|e| e.to_string())?;
    }
    if let Some(output) = &a.output {
        // Before the scene is read: a bad -o is known at once.
        let kind = OutputKind::of_path(output).unwrap_or(OutputKind::Exr);
        limits::check_output(output, kind).map_err(|e| e.to_string())?;
    }
    let (width, height) = a.format.unwrap_or(job::DEFAULT_FORMAT);
    let is_usd = a.scene.as_deref().is_some_and(obscura_usd::is_usd);
    if a.camera.is_some() && a.calibration.is_none() && !is_usd {
        return Err(
            "--camera names the camera of a calibration file (--calibration) or of a USD stage".into(),
        );
    }
    let usd = obscura_usd::Options {
        camera: a.camera.clone().filter(|_| a.calibration.is_none()),
        // Without --format (or a calibration's size) the stage's RenderProduct sets the image size.
        product_resolution: a.format.is_none() && a.calibration.is_none(),
    };
    let source = job::open_scene_with(a.scene.as_deref(), Format::new(width, height), a.fps, &usd)
        .map_err(|e| e.to_string())?;
    let calibration = a
        .calibration
        .as_deref()
        .map(|path| load_calibration(path, a.camera.as_deref(), a.quiet))
        .transpose()?;
    if let Some(n) = a.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(|e| e.to_string())?;
    }
    if source.animation().is_some() {
        return render_animation(a, search, source.as_ref(), calibration);
    }
    let jobs = frame_jobs(a.frames.as_ref(), source.as_ref())?;
    let images = source.images();
    // The displays of each image, read from its scene once (a still selected as many frames is one
    // image); the scene itself is read again when it renders, so one at a time is held.
    let mut displays_of: Vec<Option<Vec<Display>>> = vec![None; images.len()];
    for &(_, i) in &jobs {
        if displays_of[i].is_none() {
            let scene = source.image(i).map_err(|e| e.to_string())?;
            displays_of[i] = Some(image_displays(a, &scene));
        }
    }
    let lists = sequence_displays(
        &(jobs.iter())
            .map(|&(n, i)| (n, displays_of[i].clone().unwrap_or_default()))
            .collect::<Vec<_>>(),
    );
    let tile = tile_of(a)?;
    let lists: Vec<Vec<Display>> = match tile {
        Some(t) => lists.iter().map(|l| t.displays(l)).collect(),
        None => lists,
    };
    // An animated lens (a Nuke script's curves): every selected frame renders through the lens
    // of that frame.
    if let (Some(path), Some(c)) = (a.calibration.as_deref(), calibration.as_ref())
        && c.calibration.animated
    {
        for (index, (job, list)) in jobs.iter().zip(&lists).enumerate() {
            if !a.quiet {
                outln!(
                    "frame {}: through the lens of {} at that frame",
                    job.0,
                    path.display()
                );
            }
            let lens = Calibrated::load_frame(path, a.camera.as_deref(), Some(f64::from(job.0)))
                .map_err(|e| e.to_string())?;
            let writes = [FrameWrite {
                number: a.frames.is_some().then_some(job.0),
                displays: list.as_slice(),
            }];
            let scene = source.image(job.1).map_err(|e| e.to_string())?;
            let at = Position {
                number: Some(job.0),
                index,
                count: jobs.len(),
            };
            render_image(a, search, scene, source.base_dir(), Some(lens), &writes, at)?;
        }
        return Ok(());
    }
    // Each image renders once; a still selected as several frames is written as each of them.
    let mut order: Vec<usize> = jobs.iter().map(|&(_, i)| i).collect();
    order.dedup();
    let mut exported: Vec<(u32, Scene)> = Vec::new();
    let count = order.len();
    for (position, image) in order.into_iter().enumerate() {
        if !a.quiet && images.len() > 1 {
            outln!("frame {} ({})", images[image].number, images[image].label);
        }
        let writes: Vec<FrameWrite<'_>> = (jobs.iter().zip(&lists))
            .filter(|(j, _)| j.1 == image)
            .map(|(j, l)| FrameWrite {
                number: a.frames.is_some().then_some(j.0),
                displays: l.as_slice(),
            })
            .collect();
        // A rerun skips what an earlier run completed (its camera JSON says so).
        if writes.iter().all(|w| is_complete(w.displays)) {
            if !a.quiet {
                outln!("frame {} complete: skipped", images[image].number);
            }
            continue;
        }
        let scene = source.image(image).map_err(|e| e.to_string())?;
        let number = images[image].numbered.then_some(images[image].number);
        let at = Position {
            number,
            index: position,
            count,
        };
        let rendered = render_image(
            a,
            search,
            scene,
            source.base_dir(),
            calibration.clone(),
            &writes,
            at,
        )?;
        if a.export_usd.is_some() {
            exported.push((images[image].number, rendered));
        }
    }
    if let Some(path) = &a.export_usd {
        export_usd(path, &exported, a.fps)?;
    }
    Ok(())
}

/// `--export-usd`: the camera of the rendered frames (time code = frame number) as a `.usda` layer,
/// written atomically.
fn export_usd(path: &std::path::Path, rendered: &[(u32, Scene)], fps: f32) -> Result<(), String> {
    let frames: Vec<obscura_usd::export::Frame<'_>> = rendered
        .iter()
        .map(|(n, scene)| obscura_usd::export::Frame {
            time_code: f64::from(*n),
            scene,
        })
        .collect();
    let text = obscura_usd::export::camera_usda(&frames, f64::from(fps))
        .map_err(|e| format!("--export-usd {}: {e}", path.display()))?;
    obscura_image::atomic::write_atomically(path, |w| std::io::Write::write_all(w, text.as_bytes()))
        .map_err(|e| format!("--export-usd {}: {e}", path.display()))
}

/// The displays of one image: the scene's (or `-o`'s) with the `--aov`s added; a still has no
/// previous frame, so no backward flow.
fn image_displays(a: &RenderArgs, scene: &Scene) -> Vec<Display> {
    let mut displays = job::displays(scene, a.output.as_deref());
    let aovs: Vec<Aov> = a.aovs.iter().flatten().copied().collect();
    add_aovs(&mut displays, &aovs);
    if scene.sensor.is_some() || a.sensor.is_some() || !a.sensor_params.is_empty() || a.raw.is_some() {
        job::sensor_displays(&mut displays, a.raw.as_deref());
    }
    if scene.animation_seconds.is_none() {
        displays = without_backward_flow(&displays, false);
    }
    displays
}

/// The sensor of `--sensor FILE.json` and `--sensor-param KEY=VALUE`, when either is given.
fn cli_sensor(a: &RenderArgs) -> Result<Option<SensorConfig>, String> {
    if a.sensor.is_none() && a.sensor_params.is_empty() {
        return Ok(None);
    }
    let mut config = match &a.sensor {
        Some(path) => {
            let text =
                std::fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
            SensorConfig::from_json(&text, &path.display().to_string()).map_err(|e| e.to_string())?
        }
        None => SensorConfig::default(),
    };
    let mut entries = Vec::new();
    for p in &a.sensor_params {
        let Some((key, value)) = p.split_once('=') else {
            return Err(format!("--sensor-param {p}: expected KEY=VALUE (iso=800)"));
        };
        let value =
            serde_json::from_str(value.trim()).unwrap_or_else(|_| serde_json::Value::from(value.trim()));
        entries.push((key.trim().to_string(), value));
    }
    config
        .set_all(&entries)
        .map_err(|e| format!("--sensor-param: {e}"))?;
    Ok(Some(config))
}

/// The render options of the command line (the pipeline sets `deep` from the displays).
fn render_options(a: &RenderArgs) -> RenderOptions {
    RenderOptions {
        samples_per_pixel: a.spp,
        seed: a.seed,
        path: PathOptions {
            max_depth: a.max_depth,
            ..PathOptions::default()
        },
        max_triangles: a.max_triangles,
        ..RenderOptions::default()
    }
}

/// The most frames a still scene is written as: each is a file.
const MAX_STILL_FRAMES: u64 = 100_000;

/// The images to render as (frame number, index into the source's images), in file order: with
/// `--frames`, the images of the frames it selects; a still (one image the file does not number) is
/// each selected frame; without `--frames`, every image.
fn frame_jobs(spec: Option<&FrameSpec>, source: &dyn SceneSource) -> Result<Vec<(u32, usize)>, String> {
    let images = source.images();
    if let [still] = images
        && !still.numbered
    {
        if let Some(s) = spec.filter(|s| s.len() > MAX_STILL_FRAMES) {
            return Err(format!(
                "--frames {s} selects {} frames of a scene without frames of its own (at most {MAX_STILL_FRAMES}: each is written as a file)",
                s.len()
            ));
        }
        return Ok(match spec {
            Some(s) => s.non_negative()?.map(|n| (n, 0)).collect(),
            None => vec![(still.number, 0)],
        });
    }
    let numbers: Vec<u32> = images.iter().map(|f| f.number).collect();
    let picked = match spec {
        Some(s) => s.select(&numbers)?,
        None => numbers.clone(),
    };
    Ok((images.iter().enumerate())
        .filter(|(_, f)| picked.contains(&f.number))
        .map(|(i, f)| (f.number, i))
        .collect())
}

/// The command line's overrides applied to `scene` (its projection loaded first, so that `--param`
/// is read against its table); warnings printed even with `--quiet`.
fn configure(
    a: &RenderArgs,
    search: &PluginSearch,
    scene: &mut Scene,
    calibration: Option<Calibrated>,
    displays: &[Display],
) -> Result<(Registry, Overrides, Option<Plan>), String> {
    let mut registry = cli_registry();
    let mut overrides = Overrides {
        format: a.format,
        crop: a.crop.as_deref().map(crop_window),
        projection: a.projection.clone(),
        calibration,
        params: ParamList::new(),
        sensor: cli_sensor(a)?,
    };
    // RIB `Option "searchpath" "string rixplugin"` directories join the search after --plugin-path.
    let search = &search.with_scene_dirs(&scene.plugin_path);
    let projection = ensure(&mut registry, overrides.projection(scene), search)
        .map_err(|e| overrides.locate_projection_error(scene, e))?;
    let factory = registry.find(&projection).map_err(|e| e.to_string())?;
    overrides.params =
        param_list(&a.params, factory.name(), factory.param_table()).map_err(|e| e.to_string())?;
    overrides.apply(scene).map_err(|e| e.to_string())?;
    if let Some(t) = tile_of(a)? {
        t.apply(scene)?;
    }
    scene.projection = projection;
    if let Some(w) = (overrides.calibration.as_ref()).and_then(|c| c.aspect_warning(scene.camera.format)) {
        eprintln!("warning: {w}");
    }
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let plan = (a.overscan)
        .map(|arg| Plan::new(arg, scene, overrides.calibration.as_ref(), displays))
        .transpose()?;
    if let Some(p) = &plan {
        p.apply(scene);
        if !a.quiet {
            outln!("{}", p.describe());
        }
    }
    Ok((registry, overrides, plan))
}

/// What set the image size of `a`'s scene, for the limit messages.
fn scene_size_source(a: &RenderArgs) -> String {
    let scene_size = match &a.scene {
        Some(path) => format!("{}: Format", path.display()),
        None => "the built-in scene's Format".to_string(),
    };
    size_source(a.format, a.calibration.as_deref(), &scene_size)
}

/// Renders one image and writes it as each of `writes`: the scene with the command line's
/// overrides, through its projection, with its flow pass and ground-truth sidecars.
fn render_image(
    a: &RenderArgs,
    search: &PluginSearch,
    mut scene: Scene,
    base_dir: &std::path::Path,
    calibration: Option<Calibrated>,
    writes: &[FrameWrite<'_>],
    at: Position,
) -> Result<Scene, String> {
    let displays = writes.first().map_or(&[][..], |w| w.displays);
    let (mut registry, _, plan) = configure(a, search, &mut scene, calibration, displays)?;
    let source = scene_size_source(a);
    let opts = render_options(a);
    let job = FrameJob {
        scene: &scene,
        base_dir,
        writes,
        also: &[],
        neighbours: Neighbours::default(),
        options: &opts,
        header_frame: None,
        sidecars: if a.camera_json {
            Sidecars::Always
        } else {
            Sidecars::WithGroundTruth
        },
        size_source: &source,
    };
    let reporter = Terminal::new(a, true);
    reporter.start_frame(at.number, at.index, at.count);
    let result = render_frame(&job, &mut registry, &reporter).map_err(|e| e.to_string())?;
    drop(reporter);
    let s = &result.output.stats;
    if let Some(p) = plan.as_ref().filter(|_| !s.cancelled) {
        p.place(&result.written)?;
    }
    if !a.quiet {
        print_summary(&scene, &result);
    }
    if s.cancelled {
        return Err(format!(
            "interrupted: wrote the {} of {} tiles that were rendered (marked in the EXR header as obscura:partial)",
            s.tiles.0, s.tiles.1
        ));
    }
    if let Some(signal) = signals::received() {
        eprintln!("note: signal {signal} arrived after every tile was rendered; the outputs are complete");
    }
    Ok(scene)
}

/// The summary of one image: size, projection, times, the camera stage's share, the files written.
fn print_summary(scene: &Scene, result: &FrameResult) {
    let s = &result.output.stats;
    let frame = s.render_seconds.max(1e-9);
    let thread_time = (s.camera_stage_seconds + s.sampling_seconds + s.shading_seconds).max(1e-9);
    outln!(
        "rendered {}x{} through {} in {:.2} s (+{:.2} s setup: {} triangles): {} camera samples, {} culled, {} lost to failed project calls, \
         {:.2} Mrays/s traced ({:.2} M camera, {:.2} M bounce, {:.2} M shadow rays); \
         camera stage {:.1} % of thread time (+{:.1} % generating samples){}",
        scene.camera.pixels().width(),
        scene.camera.pixels().height(),
        scene.projection,
        frame,
        s.setup_seconds,
        s.triangles,
        s.contract.samples,
        s.contract.culled,
        s.contract.lost(),
        s.rays_traced as f64 / frame * 1e-6,
        s.rays.camera as f64 * 1e-6,
        s.rays.bounce as f64 * 1e-6,
        s.rays.shadow as f64 * 1e-6,
        100.0 * s.camera_stage_seconds / thread_time,
        100.0 * s.sampling_seconds / thread_time,
        if s.cancelled {
            format!("; interrupted after {} of {} tiles", s.tiles.0, s.tiles.1)
        } else if s.flow_seconds > 0.0 {
            format!("; flow pass {:.3} s", s.flow_seconds)
        } else {
            String::new()
        }
    );
    if let Some(sensor) = &result.output.sensor {
        let megapixels = f64::from(sensor.frame.width) * f64::from(sensor.frame.height) * 1e-6;
        outln!(
            "sensor stage (exposure, noise, ISP) {:.3} s: {:.3} s per megapixel",
            sensor.seconds,
            sensor.seconds / megapixels.max(1e-12)
        );
    }
    for p in &result.written {
        outln!("wrote {}", p.display());
    }
}

/// Renders the selected frames of an animated scene in order (frame 1 without `--frames`); a frame
/// whose files are complete is skipped. Flow crosses to the neighbouring frames of the animation,
/// selected or not: `flowForward` to frame N + 1's shutter open, `flowBackward` to frame N − 1's,
/// written from frame 2 on (frame 1 is the animation's start).
fn render_animation(
    a: &RenderArgs,
    search: &PluginSearch,
    source: &dyn SceneSource,
    calibration: Option<Calibrated>,
) -> Result<(), String> {
    let mut first = source.frame(1).map_err(|e| e.to_string())?;
    let displays = image_displays(a, &first);
    let (mut registry, overrides, plan) = configure(a, search, &mut first, calibration, &displays)?;
    let projection = first.projection.clone();
    let opts = render_options(a);
    let size = scene_size_source(a);
    let frames: Vec<u32> = match &a.frames {
        Some(f) => f.non_negative()?.collect(),
        None => vec![1],
    };
    let scene = |n: u32| -> Result<Scene, String> {
        let mut s = source.frame(n).map_err(|e| e.to_string())?;
        overrides.apply(&mut s).map_err(|e| e.to_string())?;
        if let Some(t) = tile_of(a)? {
            t.apply(&mut s)?;
        }
        s.projection.clone_from(&projection);
        if let Some(p) = &plan {
            p.apply(&mut s);
        }
        Ok(s)
    };
    let reporter = Terminal::new(a, false);
    let tile = tile_of(a)?;
    let several = frames.len() > 1;
    let mut skipped = 0;
    for (index, &n) in frames.iter().enumerate() {
        let displays = without_backward_flow(&frame_displays(&displays, n, several), n > 1);
        let displays = match tile {
            Some(t) => t.displays(&displays),
            None => displays,
        };
        if is_complete(&displays) {
            skipped += 1;
            continue;
        }
        reporter.start_frame(Some(n), index, frames.len());
        let this = scene(n)?;
        let previous = (n > 1).then(|| scene(n - 1)).transpose()?;
        let next = n.checked_add(1).map(scene).transpose()?;
        let writes = [FrameWrite {
            number: Some(n),
            displays: &displays,
        }];
        let job = FrameJob {
            scene: &this,
            base_dir: source.base_dir(),
            writes: &writes,
            also: &[],
            neighbours: Neighbours {
                previous: previous.as_ref(),
                next: next.as_ref(),
            },
            options: &opts,
            header_frame: Some(n),
            sidecars: Sidecars::Always,
            size_source: &size,
        };
        let result = render_frame(&job, &mut registry, &reporter).map_err(|e| e.to_string())?;
        let stats = &result.output.stats;
        if stats.cancelled {
            return Err(format!(
                "interrupted in frame {n}: its files are marked incomplete; run the same command again to resume"
            ));
        }
        if let Some(p) = &plan {
            p.place(&result.written)?;
        }
        if !a.quiet {
            let written: Vec<String> = result.written.iter().map(|p| p.display().to_string()).collect();
            outln!(
                "frame {n}: {:.2} s (flow {:.3} s), wrote {}",
                stats.render_seconds,
                stats.flow_seconds,
                written.join(", ")
            );
        }
    }
    registry.end_render();
    if !a.quiet && skipped > 0 {
        outln!("{skipped} complete frame(s) skipped");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aov_all_adds_the_ground_truth_and_the_texture_aovs() {
        let all = parse_aovs("all").unwrap();
        let ground_truth: Vec<Aov> = obscura_scene::AOVS
            .iter()
            .filter(|s| s.group == obscura_scene::AovGroup::GroundTruth)
            .map(|s| s.aov)
            .collect();
        assert_eq!(ground_truth.len(), 10);
        assert_eq!(&all[..10], &ground_truth[..]);
        assert_eq!(&all[10..], &[Aov::Albedo, Aov::Uv]);
        assert_eq!(parse_aovs("uv").unwrap(), [Aov::Uv]);
        let err = parse_aovs("Cs").unwrap_err();
        assert!(err.ends_with("flowValid, albedo, uv, or all"), "{err}");
    }
}
