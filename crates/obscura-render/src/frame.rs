//! One frame's ground truth around a render: the flow pass (when a display asks for flow), the files
//! beside the images (camera JSON, ID sidecar), and how a sequence knows a frame is already complete.
//!
//! # Complete frames (resuming a sequence)
//!
//! Every image is written atomically, but an interrupted render still writes what it has. So a frame
//! is **complete** when each of its display files exists and its camera JSON (`<first image>.camera.json`,
//! written last, after every image) exists and says `"complete": true`. A restarted sequence skips
//! complete frames and renders the others from scratch.

use std::path::{Path, PathBuf};

use obscura_scene::{Aov, AovKind, Display, DisplayDriver, Scene};

use crate::flow::{FlowTarget, SHUTTER_CLOSE};
use crate::metadata::{camera_json, sidecar_path, write_json};
use crate::render::{Prepared, RenderError, RenderOutput};
use obscura_image::output::OutputError;

/// The scenes of the frames around this one, for flow across frames.
#[derive(Debug, Clone, Copy, Default)]
pub struct Neighbours<'a> {
    /// The previous frame's scene (`flowBackward` goes to its shutter open).
    pub previous: Option<&'a Scene>,
    /// The next frame's scene (`flowForward` goes to its shutter open); without one, `flowForward`
    /// goes to this frame's shutter close.
    pub next: Option<&'a Scene>,
}

/// Adds `aovs` to every EXR display (once each); PNG and deep displays are left alone.
pub fn add_aovs(displays: &mut [Display], aovs: &[Aov]) {
    for d in displays.iter_mut().filter(|d| d.driver == DisplayDriver::OpenExr) {
        for &a in aovs {
            if !d.aovs.contains(&a) {
                d.aovs.push(a);
            }
        }
    }
}

/// `displays` without `flowBackward` when there is no previous frame (the issue: it is written only
/// when a previous frame exists); `flowValid.backward` stays, all 0.
#[must_use]
pub fn without_backward_flow(displays: &[Display], has_previous: bool) -> Vec<Display> {
    let mut out = displays.to_vec();
    if !has_previous {
        for d in &mut out {
            d.aovs.retain(|a| *a != Aov::FlowBackward);
        }
    }
    out
}

/// Runs the flow pass into `out`'s film: forward to the next frame's shutter open (or this frame's
/// close), backward to the previous frame's open when there is one. Returns the pass's warnings (a
/// projection without `unproject`).
///
/// # Errors
/// [`RenderError::Camera`] when a neighbour's camera transform is singular.
pub fn run_flow(
    scene: &Scene,
    prepared: &Prepared,
    out: &mut RenderOutput,
    neighbours: Neighbours<'_>,
) -> Result<Vec<String>, RenderError> {
    let forward = match neighbours.next {
        Some(next) => FlowTarget::new(next, 0.0)?,
        None => FlowTarget::new(scene, SHUTTER_CLOSE)?,
    };
    let backward = neighbours.previous.map(|p| FlowTarget::new(p, 0.0)).transpose()?;
    let flow = prepared.flow(Some(&forward), backward.as_ref());
    out.stats.flow_seconds = flow.seconds;
    out.film.set_flow(flow.pixels);
    Ok(flow.warnings)
}

/// The header attributes every EXR of the frame carries: `obscura:camera` (the camera JSON) and
/// `obscura:ids` (the ID table), both compact JSON.
///
/// # Errors
/// [`RenderError::Camera`] when a camera transform is singular.
pub fn header_attributes(
    scene: &Scene,
    prepared: &Prepared,
    frame: Option<u32>,
) -> Result<Vec<(&'static str, String)>, RenderError> {
    let camera = camera_json(scene, prepared, frame.map(i64::from))?;
    Ok(vec![
        ("obscura:camera", camera.to_string()),
        ("obscura:ids", prepared.ids().to_json().to_string()),
    ])
}

/// Writes the sidecars of a frame whose displays are written: `<image>.ids.json` beside each EXR with
/// an ID AOV, then `<first image>.camera.json` with `"complete": !cancelled` (last, so that a complete
/// frame is one whose camera JSON says so). Returns the paths written.
///
/// # Errors
/// The first file that could not be written, or a singular camera transform, as a message naming it.
pub fn write_sidecars(
    scene: &Scene,
    prepared: &Prepared,
    displays: &[Display],
    frame: Option<u32>,
    cancelled: bool,
) -> Result<Vec<PathBuf>, String> {
    let mut written = Vec::new();
    let ids = prepared.ids().to_json();
    for d in displays.iter().filter(|d| d.driver == DisplayDriver::OpenExr) {
        let has_ids = (d.aovs.iter()).any(|a| a.spec().kind == AovKind::Id);
        if has_ids {
            let path = sidecar_path(&d.path, "ids.json");
            write_json(&path, &ids).map_err(|e| OutputError::from(e).to_string())?;
            written.push(path);
        }
    }
    if let Some(first) = displays.first() {
        let mut camera = camera_json(scene, prepared, frame.map(i64::from)).map_err(|e| e.to_string())?;
        camera["complete"] = serde_json::Value::Bool(!cancelled);
        let path = camera_path(displays).unwrap_or_else(|| sidecar_path(&first.path, "camera.json"));
        camera["images"] = serde_json::json!(
            displays
                .iter()
                .map(|d| relative_to_sidecar(&d.path, &path))
                .collect::<Vec<_>>()
        );
        write_json(&path, &camera).map_err(|e| OutputError::from(e).to_string())?;
        written.push(path);
    }
    Ok(written)
}

/// `image` named from the directory of `sidecar` (`beauty.0001.exr`, `../png/beauty.0001.png`), with
/// `/` between components whatever the platform, so that a sidecar moved or path-mapped with its
/// images (a farm's output directory mounted elsewhere) still names them. Falls back to the absolute
/// path when the two share no root (another drive), and to the path as given when the working
/// directory cannot be read.
#[must_use]
pub fn relative_to_sidecar(image: &Path, sidecar: &Path) -> String {
    use std::path::Component;
    let (Ok(image), Ok(sidecar)) = (std::path::absolute(image), std::path::absolute(sidecar)) else {
        return image.display().to_string();
    };
    // Lexically normal: `.` dropped, `..` applied.
    fn normal(p: &Path) -> Vec<Component<'_>> {
        let mut out: Vec<Component<'_>> = Vec::new();
        for c in p.components() {
            match c {
                Component::CurDir => {}
                Component::ParentDir if matches!(out.last(), Some(Component::Normal(_))) => {
                    out.pop();
                }
                other => out.push(other),
            }
        }
        out
    }
    let to = normal(&image);
    let from = normal(sidecar.parent().unwrap_or(Path::new("/")));
    if to.first() != from.first() {
        return image.display().to_string();
    }
    let common = to.iter().zip(&from).take_while(|(a, b)| a == b).count();
    let mut parts: Vec<String> = vec!["..".to_string(); from.len() - common];
    parts.extend(
        to[common..]
            .iter()
            .map(|c| c.as_os_str().to_string_lossy().into_owned()),
    );
    parts.join("/")
}

/// The camera JSON of a frame's displays: beside the first one.
fn camera_path(displays: &[Display]) -> Option<PathBuf> {
    displays.first().map(|d| sidecar_path(&d.path, "camera.json"))
}

/// True when the frame whose displays are `displays` is complete (see the module documentation).
#[must_use]
pub fn is_complete(displays: &[Display]) -> bool {
    let Some(camera) = camera_path(displays) else {
        return false;
    };
    let marked = std::fs::read_to_string(&camera)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .is_some_and(|j| j["complete"] == serde_json::Value::Bool(true));
    marked && displays.iter().all(|d| Path::new(&d.path).is_file())
}
