//! One frame from a scene to its files, the same for every front end: `obscura render` (a still, a
//! RIB file's frames, an animated scene's sequence) and Python's `render` run [`render_frame`].
//!
//! The steps, in order:
//!
//! 1. **check** every display list against the limits ([`crate::job::check_render`]) before any work;
//! 2. **prepare** the scene through its projection ([`crate::render::prepare`]): camera stage, dicing,
//!    BVH, textures, lights;
//! 3. tell the setup's **warnings** (projection setup, textures, the automatic camera and lights);
//! 4. **render** the tiles, reporting progress and stopping when the reporter cancels;
//! 5. the **flow** pass when a display (or the caller) asks for a flow AOV ([`crate::frame::run_flow`]);
//!    Then the **sensor**, when the scene has one ([`crate::sensor::expose`]): exposure, noise, raw
//!    mosaic and ISP, whose processed beauty every display then writes;
//! 6. the EXR **header attributes**: the projection, a partial render's missing tiles, the camera and
//!    ID JSON;
//! 7. every **display**, atomically ([`crate::job::write_displays`]), once per frame number the image
//!    is written as;
//! 8. the **sidecars** (ID table, camera JSON marking the frame complete) when a display holds ground
//!    truth or the sequence must resume;
//! 9. the projection's **contract** warning, if its rays broke the contract.
//!
//! What a front end shows of it goes through a [`Reporter`]: the terminal's progress bar, plain lines,
//! Python's callback, a farm's progress format. The summary a front end prints is its own, from the
//! [`FrameResult`].

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use obscura_host::Registry;
use obscura_image::output::OutputError;
use obscura_scene::{Aov, Display, Scene};

use crate::frame::{Neighbours, header_attributes, run_flow, write_sidecars};
use crate::job::{check_render, wants_deep, write_displays};
use crate::limits::LimitError;
use crate::render::{RenderError, RenderOptions, RenderOutput, prepare};

/// What a message of the pipeline is about, so that a front end can tell each kind once or in its
/// own way.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Message {
    /// The projection's setup warnings (its parameters, its properties), already prefixed.
    Setup,
    /// A texture that could not be read or was replaced: the text has no `warning: ` prefix.
    Texture,
    /// What the renderer chose for the scene (automatic camera, default lights): no `info: ` prefix.
    Info,
    /// The flow pass's warnings (a projection without `unproject`), already prefixed.
    Flow,
    /// The contract report: the projection's rays broke the contract, already prefixed.
    Contract,
}

impl Message {
    /// The line a terminal shows for `text` of this kind.
    #[must_use]
    pub fn line(self, text: &str) -> String {
        match self {
            Message::Texture => format!("warning: {text}"),
            Message::Info => format!("info: {text}"),
            Message::Setup | Message::Flow | Message::Contract => text.to_string(),
        }
    }
}

/// Where a frame's messages and progress go, and whether it should stop.
pub trait Reporter: Sync {
    /// A message of the pipeline.
    fn message(&self, kind: Message, text: &str);
    /// `done` of `total` tiles are rendered; called from the render's threads.
    fn progress(&self, done: usize, total: usize) {
        let _ = (done, total);
    }
    /// Set to stop the render after the tiles in flight; what is rendered is still written, marked
    /// partial.
    fn cancel(&self) -> &AtomicBool;
    /// The scene is prepared and the tiles start: from here a cancelled frame still writes what it
    /// has (a command's signal handler switches from ending the process to setting the cancel flag).
    fn rendering(&self) {}
    /// The render's tiles are all done (or cancelled): a progress bar may clear itself.
    fn rendered(&self) {}
}

/// When a frame writes its sidecars (the ID table beside each EXR with an ID AOV, and the camera JSON,
/// which also records the sensor).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sidecars {
    /// When a display of the frame holds a ground-truth AOV, or the scene has a sensor.
    WithGroundTruth,
    /// Always: a sequence that resumes knows a complete frame by its camera JSON.
    Always,
}

/// One image written as one frame: the frame number its sidecars carry and its displays.
#[derive(Debug, Clone, Copy)]
pub struct FrameWrite<'a> {
    /// The number the camera JSON carries (`None` for a still rendered without `--frames`).
    pub number: Option<u32>,
    /// The files, each with its AOVs.
    pub displays: &'a [Display],
}

/// Everything one frame needs.
#[derive(Debug, Clone, Copy)]
pub struct FrameJob<'a> {
    /// The scene, with every override applied and its projection loaded into the registry.
    pub scene: &'a Scene,
    /// Where the scene's relative paths (textures) are read from.
    pub base_dir: &'a Path,
    /// The frames the image is written as: a still selected as several frames renders once and is
    /// written as each. The first one's displays decide the flow pass, deep samples and sidecars.
    pub writes: &'a [FrameWrite<'a>],
    /// AOVs the caller wants in the film beyond the displays' (Python's arrays): a flow AOV here runs
    /// the flow pass.
    pub also: &'a [Aov],
    /// The scenes of the neighbouring frames, for flow across frames.
    pub neighbours: Neighbours<'a>,
    /// Samples, seed, path depth, tiles, triangle budget (`deep` is set from the displays).
    pub options: &'a RenderOptions,
    /// The frame number in the EXR header's camera JSON.
    pub header_frame: Option<u32>,
    /// When the sidecars are written.
    pub sidecars: Sidecars,
    /// What set the image size, for the limit messages (`--format`, the scene's `Format`, …).
    pub size_source: &'a str,
}

/// A frame rendered and written.
#[derive(Debug)]
pub struct FrameResult {
    /// The film (every AOV, resolved on demand), deep samples and the render's counts and times.
    pub output: RenderOutput,
    /// Every file written, in order: the displays of each write, then its sidecars.
    pub written: Vec<PathBuf>,
    /// The prepared scene the frame was rendered from (camera stage, geometry, IDs): what annotations
    /// computed after the render trace against.
    pub prepared: crate::render::Prepared,
}

/// Why a frame was not rendered or not written. Each variant's text names the file, object or
/// limit to blame.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    /// A limit checked before any work (image size, samples, memory, an output's name).
    #[error(transparent)]
    Limit(#[from] LimitError),
    /// The scene could not be prepared, or a neighbour's camera for the flow.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// An image could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A sidecar could not be written.
    #[error("{0}")]
    Sidecar(String),
    /// The sensor cannot be used with this scene (a rolling shutter through a projection without
    /// time samples by line).
    #[error("{0}")]
    Sensor(String),
}

/// Renders one frame of `job` through the projection in `registry` and writes it (see the module
/// documentation for the steps).
///
/// # Errors
/// A [`FrameError`]; files already written stay (each is complete: every write is atomic).
pub fn render_frame(
    job: &FrameJob<'_>,
    registry: &mut Registry,
    reporter: &dyn Reporter,
) -> Result<FrameResult, FrameError> {
    let rolling = crate::sensor::rolling_shutter_scene(job.scene).map_err(FrameError::Sensor)?;
    let scene = rolling.as_ref().unwrap_or(job.scene);
    let first: &[Display] = job.writes.first().map_or(&[], |w| w.displays);
    for w in job.writes {
        check_render(scene, w.displays, job.options.samples_per_pixel, job.size_source)?;
    }
    let options = RenderOptions {
        deep: wants_deep(first),
        ..job.options.clone()
    };
    let prepared = prepare(scene, registry, job.base_dir, &options)?;
    for w in prepared.stage().setup_warnings() {
        reporter.message(Message::Setup, w);
    }
    for w in prepared.texture_warnings() {
        reporter.message(Message::Texture, w);
    }
    if !prepared.info().is_empty() {
        reporter.message(Message::Info, prepared.info());
    }
    reporter.rendering();
    let mut out = prepared.render(
        &options,
        &|done, total| reporter.progress(done, total),
        reporter.cancel(),
    );
    reporter.rendered();
    let flow_aovs = first.iter().flat_map(|d| d.aovs.iter()).chain(job.also);
    if flow_aovs.clone().any(|a| a.is_flow()) {
        for w in run_flow(scene, &prepared, &mut out, job.neighbours)? {
            reporter.message(Message::Flow, &w);
        }
    }
    crate::sensor::expose(scene, &prepared, &mut out, job.header_frame.map_or(0, u64::from));
    let mut attributes = vec![("obscura:projection", scene.projection.clone())];
    if let Some(note) = out.stats.partial_note() {
        attributes.push(("obscura:partial", note));
    }
    attributes.extend(header_attributes(scene, &prepared, job.header_frame)?);
    let sidecars = match job.sidecars {
        Sidecars::Always => true,
        Sidecars::WithGroundTruth => {
            scene.sensor.is_some() || first.iter().any(|d| d.aovs.iter().any(|a| a.is_ground_truth()))
        }
    };
    let mut written = Vec::new();
    for w in job.writes {
        written.extend(write_displays(
            w.displays,
            &out,
            scene.camera.format.pixel_aspect,
            &attributes,
        )?);
        if sidecars {
            written.extend(
                write_sidecars(scene, &prepared, w.displays, w.number, out.stats.cancelled)
                    .map_err(FrameError::Sidecar)?,
            );
        }
    }
    if let Some(w) = out.stats.contract.warning(&scene.projection) {
        reporter.message(Message::Contract, &w);
    }
    Ok(FrameResult {
        output: out,
        written,
        prepared,
    })
}
