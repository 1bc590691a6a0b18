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
use obscura_plugins::builtin_registry;
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
use obscura_shading::integrator::PathOptions;

use crate::args::{crop_window, load_calibration};
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

/// The terminal's reporter: messages on stderr (warnings even with `--quiet`, which silences progress
/// and summaries only), a progress bar when stderr is a terminal, the signal handler's cancel flag.
/// Texture warnings and notes are told once per run: they are the same at every frame.
struct Terminal {
    bar: Option<indicatif::ProgressBar>,
    told: Mutex<HashSet<String>>,
    /// While set, a signal cancels the render instead of ending the process: from the first frame's
    /// tiles until the reporter is dropped, after the last file is written.
    cancellable: Mutex<Option<signals::Cancellable>>,
}

impl Terminal {
    fn new(bar: bool) -> Self {
        let bar = (bar && std::io::stderr().is_terminal()).then(|| {
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
            told: Mutex::new(HashSet::new()),
            cancellable: Mutex::new(None),
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
    let source =
        job::open_scene(a.scene.as_deref(), Format::new(width, height), a.fps).map_err(|e| e.to_string())?;
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
    // Each image renders once; a still selected as several frames is written as each of them.
    let mut order: Vec<usize> = jobs.iter().map(|&(_, i)| i).collect();
    order.dedup();
    for image in order {
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
        let scene = source.image(image).map_err(|e| e.to_string())?;
        render_image(a, search, scene, source.base_dir(), calibration.clone(), &writes)?;
    }
    Ok(())
}

/// The displays of one image: the scene's (or `-o`'s) with the `--aov`s added; a still has no
/// previous frame, so no backward flow.
fn image_displays(a: &RenderArgs, scene: &Scene) -> Vec<Display> {
    let mut displays = job::displays(scene, a.output.as_deref());
    let aovs: Vec<Aov> = a.aovs.iter().flatten().copied().collect();
    add_aovs(&mut displays, &aovs);
    if scene.animation_seconds.is_none() {
        displays = without_backward_flow(&displays, false);
    }
    displays
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
            Some(s) => s.frames().map(|n| (n, 0)).collect(),
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
) -> Result<(Registry, Overrides), String> {
    let mut registry = builtin_registry();
    let mut overrides = Overrides {
        format: a.format,
        crop: a.crop.as_deref().map(crop_window),
        projection: a.projection.clone(),
        calibration,
        params: ParamList::new(),
    };
    // RIB `Option "searchpath" "string rixplugin"` directories join the search after --plugin-path.
    let search = &search.with_scene_dirs(&scene.plugin_path);
    let projection = ensure(&mut registry, overrides.projection(scene), search).map_err(|e| e.to_string())?;
    let factory = registry.find(&projection).map_err(|e| e.to_string())?;
    overrides.params =
        param_list(&a.params, factory.name(), factory.param_table()).map_err(|e| e.to_string())?;
    overrides.apply(scene).map_err(|e| e.to_string())?;
    scene.projection = projection;
    if let Some(w) = (overrides.calibration.as_ref()).and_then(|c| c.aspect_warning(scene.camera.format)) {
        eprintln!("warning: {w}");
    }
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    Ok((registry, overrides))
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
) -> Result<(), String> {
    let (mut registry, _) = configure(a, search, &mut scene, calibration)?;
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
        sidecars: Sidecars::WithGroundTruth,
        size_source: &source,
    };
    let reporter = Terminal::new(!a.quiet);
    let result = render_frame(&job, &mut registry, &reporter).map_err(|e| e.to_string())?;
    drop(reporter);
    let s = &result.output.stats;
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
    Ok(())
}

/// The summary of one image: size, projection, times, the camera stage's share, the files written.
fn print_summary(scene: &Scene, result: &FrameResult) {
    let s = &result.output.stats;
    let frame = s.render_seconds.max(1e-9);
    let thread_time = (s.camera_stage_seconds + s.sampling_seconds + s.shading_seconds).max(1e-9);
    outln!(
        "rendered {}x{} through {} in {:.2} s (+{:.2} s setup: {} triangles): {} camera samples, {} culled, {} lost to failed project calls, \
         {:.1} Mrays/s traced (camera, bounce and shadow rays); \
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
    let (mut registry, overrides) = configure(a, search, &mut first, calibration)?;
    let projection = first.projection.clone();
    let displays = image_displays(a, &first);
    let opts = render_options(a);
    let size = scene_size_source(a);
    let frames: Vec<u32> = a.frames.as_ref().map_or(vec![1], |f| f.frames().collect());
    let scene = |n: u32| -> Result<Scene, String> {
        let mut s = source.frame(n).map_err(|e| e.to_string())?;
        overrides.apply(&mut s).map_err(|e| e.to_string())?;
        s.projection.clone_from(&projection);
        Ok(s)
    };
    let reporter = Terminal::new(false);
    let several = frames.len() > 1;
    let mut skipped = 0;
    for &n in &frames {
        let displays = without_backward_flow(&frame_displays(&displays, n, several), n > 1);
        if is_complete(&displays) {
            skipped += 1;
            continue;
        }
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
