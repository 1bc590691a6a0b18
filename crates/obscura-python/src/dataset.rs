//! `render_dataset`: the dataset driver ([`obscura_dataset::run::run`]) from Python, with the options
//! of `obscura dataset` as keyword arguments.

use std::path::PathBuf;

use obscura_dataset::export::ExportFormat;
use obscura_dataset::run::{
    ANNOTATION_NAMES, Annotation, DEFAULT_TRACKS, DatasetOptions, Finalize, ParamReader, RenderSettings,
    Session, export_names, parse_names,
};
use obscura_render::sequence::FrameSpec;
use obscura_sdk::{ParamDecl, ParamList};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::registry::{registry, search};
use crate::tools::Polled;

/// `params=` read against the base camera's projection table, as `Camera(...)` reads keywords.
struct PyParams<'a, 'py>(Option<&'a Bound<'py, PyDict>>);

impl ParamReader for PyParams<'_, '_> {
    fn read(&self, projection: &str, table: &[ParamDecl]) -> Result<ParamList, String> {
        crate::params::read_params(projection, table, self.0)
            .map(|(list, _)| list)
            .map_err(|e| e.to_string())
    }

    fn describe(&self) -> Vec<String> {
        let Some(d) = self.0 else { return Vec::new() };
        d.iter()
            .map(|(k, v)| {
                let value = v.repr().map(|r| r.to_string()).unwrap_or_default();
                format!("{k}={value}")
            })
            .collect()
    }
}

/// Names given as a list of strings or one comma-separated string.
fn names<T: Copy + PartialEq>(
    option: &str,
    given: Option<&Bound<'_, PyAny>>,
    table: &[(&str, T)],
) -> PyResult<Vec<T>> {
    let Some(v) = given else { return Ok(Vec::new()) };
    let text = match v.extract::<String>() {
        Ok(s) => s,
        Err(_) => v.extract::<Vec<String>>()?.join(","),
    };
    parse_names(option, &text, table).map_err(PyValueError::new_err)
}

/// Renders a dataset through the same driver as `obscura dataset` (layout: docs/datasets.md):
/// `images/<camera>/<frame>.exr` (beauty and ground truth) and `.png` for every camera of `rig` (or
/// one camera named `camera`), `exports` (`"colmap"`, `"nerfstudio"`, `"gsplat"`), `annotations`
/// (`"boxes"`, `"tracks"`, `"correspondences"`, with `tracks` points per object) and `dataset.json`.
/// `frames` selects frames as `--frames` does ("1-24", "1-3,5"); a run with `frames` renders them
/// without assembling the files that span frames, `finalize=True` assembles them from the frames on
/// disk. The render options are `obscura dataset`'s: `projection` and `params` (a dict of the
/// projection's parameters, as `Camera(...)` takes them) or `calibration` (+ `camera`), `format`
/// (width, height), `spp`, `seed`, `max_depth`, `fps`. A complete frame is skipped, so a rerun
/// resumes. Returns a dict: `rendered` and `skipped` ((camera, frame) pairs), `render_seconds`,
/// `annotation_seconds`, `finalized`, `warnings`. Raises ValueError for bad input, naming the
/// option, file and line.
#[pyfunction]
#[pyo3(signature = (scene, output, frames = None, rig = None, exports = None, annotations = None, tracks = DEFAULT_TRACKS, finalize = false, projection = None, params = None, calibration = None, camera = None, format = None, spp = None, seed = 0, max_depth = 6, fps = 24.0))]
#[allow(clippy::too_many_arguments)]
pub fn render_dataset<'py>(
    py: Python<'py>,
    scene: Option<PathBuf>,
    output: PathBuf,
    frames: Option<&str>,
    rig: Option<PathBuf>,
    exports: Option<Bound<'py, PyAny>>,
    annotations: Option<Bound<'py, PyAny>>,
    tracks: u32,
    finalize: bool,
    projection: Option<String>,
    params: Option<Bound<'py, PyDict>>,
    calibration: Option<PathBuf>,
    camera: Option<String>,
    format: Option<(u32, u32)>,
    spp: Option<u32>,
    seed: u32,
    max_depth: u32,
    fps: f32,
) -> PyResult<Bound<'py, PyDict>> {
    if tracks == 0 {
        return Err(PyValueError::new_err(
            "tracks=0: expected at least 1 point per object",
        ));
    }
    if spp == Some(0) {
        return Err(PyValueError::new_err(
            "spp=0: expected at least 1 sample per pixel",
        ));
    }
    if format.is_some_and(|(w, h)| w == 0 || h == 0) {
        return Err(PyValueError::new_err(
            "format: expected (width, height), both positive",
        ));
    }
    let frames = frames
        .map(FrameSpec::parse)
        .transpose()
        .map_err(|e| PyValueError::new_err(format!("frames: {e}")))?;
    let exports: Vec<ExportFormat> = names("exports", exports.as_ref(), &export_names())?;
    let annotations: Vec<Annotation> = names("annotations", annotations.as_ref(), &ANNOTATION_NAMES)?;
    let options = DatasetOptions {
        scene,
        output,
        frames,
        rig,
        exports,
        annotations,
        tracks,
        render: RenderSettings {
            format,
            projection,
            calibration,
            camera,
            spp,
            seed,
            max_depth,
            fps,
        },
        finalize: if finalize { Finalize::Only } else { Finalize::Auto },
    };
    let reporter = Polled::default();
    let reader = PyParams(params.as_ref());
    let search = search();
    let mut reg = registry()?;
    let mut session = Session {
        registry: &mut reg,
        search: &search,
        reporter: &reporter,
        params: &reader,
    };
    // The parameter reader needs the GIL (it reads the dict), so the driver runs on this thread, its
    // renders on rayon's global pool.
    let summary = obscura_dataset::run::run(&options, &mut session)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let d = PyDict::new(py);
    d.set_item("rendered", summary.rendered)?;
    d.set_item("skipped", summary.skipped)?;
    d.set_item("render_seconds", summary.render_seconds)?;
    d.set_item("annotation_seconds", summary.annotation_seconds)?;
    d.set_item("finalized", summary.finalized)?;
    let mut warnings = reporter.messages.lock().map(|m| m.clone()).unwrap_or_default();
    warnings.extend(summary.warnings);
    d.set_item("warnings", warnings)?;
    Ok(d)
}
