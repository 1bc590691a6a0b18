//! `obscura.stmap`, `obscura.check` and `obscura.render`: the CLI's jobs on `Camera`s, returning
//! numpy arrays and dicts (and, for `render`, the same files as the CLI on request).

use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

use numpy::PyArrayMethods;
use obscura_check::{CheckOptions, check_registered};
use obscura_image::film::Film;
use obscura_image::output::{component, id_component};
use obscura_image::stmap::compute_stmap;
use obscura_render::frame::{Neighbours, add_aovs, without_backward_flow};
use obscura_render::job::{self, load_scene};
use obscura_render::pipeline::{FrameJob, FrameWrite, Message, Reporter, Sidecars, render_frame};
use obscura_render::render::RenderOptions;
use obscura_scene::{AOVS, Aov, AovGroup, AovKind};
use obscura_sdk::Format;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::zeros;
use crate::camera::Camera;
use crate::pool::pool;
use crate::registry::registry;

/// The ST-map (Nuke's STMap convention) that turns images made through camera `a` into the image
/// camera `b` would make, over b's format: a dict with `s`, `t` (a's position normalised from its
/// bottom-left corner), `alpha` (1 where a's image holds the direction), each H×W float32 in b's
/// raster order (row 0 at the top), and `mapped`, `culled_by_b`, `unseen_by_a` counts.
/// `distance` only matters for cameras whose rays do not share one origin.
#[pyfunction]
#[pyo3(signature = (a, b, distance = 1.0e4))]
pub fn stmap<'py>(py: Python<'py>, a: &Camera, b: &Camera, distance: f32) -> PyResult<Bound<'py, PyDict>> {
    let pool = pool()?;
    let map = py
        .detach(|| pool.install(|| compute_stmap(&a.stage, &b.stage, distance)))
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let (w, h) = (map.format.width as usize, map.format.height as usize);
    let d = PyDict::new(py);
    for (name, values) in [("s", &map.s), ("t", &map.t), ("alpha", &map.alpha)] {
        let arr = zeros::<f32>(py, &[h, w]);
        arr.readwrite()
            .as_slice_mut()
            .map_err(|_| PyRuntimeError::new_err("output not contiguous"))?
            .copy_from_slice(values);
        d.set_item(name, arr)?;
    }
    d.set_item("mapped", map.stats.mapped)?;
    d.set_item("culled_by_b", map.stats.culled_by_b)?;
    d.set_item("unseen_by_a", map.stats.unseen_by_a)?;
    d.set_item("outside_a", map.stats.outside_a)?;
    Ok(d)
}

/// Checks the camera's projection against the contract, as `obscura check --json` does, and returns
/// the report as a dict (`clean` is True when every check passed). `format` is the image sampled
/// (default 96×72, or 96 wide in a calibration's aspect); `samples_per_pixel` and `seed` as the CLI's.
#[pyfunction]
#[pyo3(signature = (camera, format = None, samples_per_pixel = 4, seed = 0))]
pub fn check<'py>(
    py: Python<'py>,
    camera: &Camera,
    format: Option<(u32, u32)>,
    samples_per_pixel: u32,
    seed: u64,
) -> PyResult<Bound<'py, PyAny>> {
    let desc = camera.stage.camera();
    let (width, height) = match (format, &camera.exact) {
        (Some((w, h)), _) if w > 0 && h > 0 => (w, h),
        (Some((w, h)), _) => {
            return Err(PyValueError::new_err(format!(
                "format=({w}, {h}): expected (width, height) with positive integers"
            )));
        }
        (None, Some(e)) => (
            96,
            ((96.0 * e.resolution.1 / e.resolution.0).round() as u32).max(1),
        ),
        (None, None) => (96, 72),
    };
    let opts = CheckOptions {
        format: Format {
            width,
            height,
            pixel_aspect: desc.format.pixel_aspect,
        },
        screen_window: desc.screen_window,
        clipping: desc.clipping,
        samples_per_pixel,
        seed,
        ..CheckOptions::default()
    };
    let name = camera.stage.name().to_string();
    let mut reg = registry()?;
    let reg_ref: &mut obscura_host::Registry = &mut reg;
    let report = py
        .detach(|| check_registered(reg_ref, &name, &camera.params, &opts))
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let dict = py.import("json")?.call_method1("loads", (report.to_json(),))?;
    dict.set_item("clean", report.is_clean())?;
    Ok(dict)
}

/// The AOVs `render` returns without `aovs`: RenderMan's own and the textures' (rows of the AOV
/// table, under their array names); the sensor's planes only with a sensor.
fn default_aovs() -> Vec<Aov> {
    (AOVS.iter())
        .filter(|s| s.group != AovGroup::GroundTruth && s.group != AovGroup::Sensor)
        .map(|s| s.aov)
        .collect()
}

/// The AOV of an array name (`beauty`, `alpha`, `cameraZ`: the AOV table's Python names).
fn aov_named(name: &str) -> PyResult<Aov> {
    (AOVS.iter())
        .find(|s| s.array == name)
        .map(|s| s.aov)
        .ok_or_else(|| {
            let names: Vec<&str> = AOVS.iter().map(|s| s.array).collect();
            // RenderMan's display name of an AOV whose array is named otherwise (`Ci` → `beauty`).
            let hint = (AOVS.iter())
                .find(|s| s.name == name)
                .map(|s| format!(" (RenderMan's {name:?} is {:?} here)", s.array))
                .unwrap_or_default();
            PyValueError::new_err(format!(
                "aovs: unknown AOV {name:?}{hint}; expected some of {}",
                names.join(", ")
            ))
        })
}

/// Python's reporter: progress counters and the cancel flag the calling thread polls, and the
/// messages, returned in `stats["warnings"]`.
#[derive(Default)]
pub(crate) struct Polled {
    done: AtomicUsize,
    total: AtomicUsize,
    cancel: AtomicBool,
    pub(crate) messages: Mutex<Vec<String>>,
}

impl Reporter for Polled {
    fn message(&self, kind: Message, text: &str) {
        if let Ok(mut m) = self.messages.lock() {
            m.push(kind.line(text));
        }
    }
    fn progress(&self, done: usize, total: usize) {
        self.done.store(done, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
    }
    fn cancel(&self) -> &AtomicBool {
        &self.cancel
    }
}

/// Renders a scene (RIB, glTF, OBJ; None for the built-in one) through the same frame pipeline as
/// `obscura render` and returns its AOVs as numpy arrays over the crop window: by default `beauty`
/// (H×W×3, linear, premultiplied), `alpha`, `z` (the projection's deep metric, inf where nothing was
/// hit), `N`, `P` (world space), `cameraDirection` (H×W×3), `albedo` (H×W×3: the footprint-filtered
/// base colour at the first hit, linear), `uv` (H×W×2: the first texture coordinate set as stored in
/// the file), and `stats`. `aovs` selects AOVs by these names, ground truth included
/// (`cameraZ`, `Pcamera`, `objectId` as uint32, `flowForward` (runs the flow pass), …).
/// `camera` replaces the scene's camera (its projection, parameters, format and options;
/// the scene's camera transform is kept unless the camera has its own `world_to_camera`).
/// `output` writes the files `obscura render -o output` writes (an EXR, its PNG preview, and the ID and
/// camera sidecars when a ground-truth AOV is asked for), with `aovs` added as `--aov` adds them;
/// `write=True` without `output` writes the scene's own displays (else `render.exr`), as
/// `obscura render` does; `stats["written"]` lists the files. `progress(done_tiles, total_tiles)` is
/// called from the calling thread about ten times a second; Ctrl-C (KeyboardInterrupt) stops the
/// render and raises.
/// `sensor` puts an image sensor after the lens: a dict of the sensor keys (those of
/// `obscura render --sensor FILE.json`, docs/sensor.md) or the path of such a JSON file. Then `beauty`
/// is the ISP's processed (noisy) image, `clean` the same ISP on the noise-free exposure (the training
/// pair), `film` the renderer's noiseless linear image, `raw` the mosaic in DN and `electrons` the
/// expected photoelectrons; EXR outputs gain the `raw` and `electrons` channels. `raw_output` writes the
/// mosaic as a DNG file.
#[pyfunction]
#[pyo3(signature = (scene = None, camera = None, spp = None, aovs = None, seed = 0, max_depth = 6, progress = None, output = None, write = false, sensor = None, raw_output = None))]
#[allow(clippy::too_many_arguments)]
pub fn render<'py>(
    py: Python<'py>,
    scene: Option<PathBuf>,
    camera: Option<&Camera>,
    spp: Option<u32>,
    aovs: Option<Vec<String>>,
    seed: u32,
    max_depth: u32,
    progress: Option<Bound<'py, PyAny>>,
    output: Option<PathBuf>,
    write: bool,
    sensor: Option<Bound<'py, PyAny>>,
    raw_output: Option<PathBuf>,
) -> PyResult<Bound<'py, PyDict>> {
    let sensor_config = sensor.map(|s| sensor_config(py, &s)).transpose()?;
    let mut wanted: Vec<Aov> = match &aovs {
        None => default_aovs(),
        Some(list) => list.iter().map(|a| aov_named(a)).collect::<PyResult<_>>()?,
    };
    if sensor_config.is_some() && aovs.is_none() {
        wanted.extend([Aov::Raw, Aov::Electrons]);
    }
    if spp == Some(0) {
        return Err(PyValueError::new_err(
            "spp=0: expected at least 1 sample per pixel",
        ));
    }
    let format = camera.map_or(job::DEFAULT_FORMAT, |c| {
        let f = c.stage.camera().format;
        (f.width, f.height)
    });
    let (mut sc, base_dir) = load_scene(scene.as_deref(), Format::new(format.0, format.1))
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    if let Some(c) = camera {
        let mut desc = c.stage.camera().clone();
        if desc.world_to_camera.is_empty() {
            desc.world_to_camera = sc.camera.world_to_camera.clone();
        }
        sc.camera = desc;
        sc.projection = c.stage.name().to_string();
        sc.projection_params = c.params.clone();
    }
    if sensor_config.is_some() {
        sc.sensor = sensor_config;
    }
    let mut displays = if write || output.is_some() {
        let mut d = job::displays(&sc, output.as_deref());
        if aovs.is_some() {
            add_aovs(&mut d, &wanted);
        }
        if sc.sensor.is_some() {
            job::sensor_displays(&mut d, None);
        }
        without_backward_flow(&d, false)
    } else {
        Vec::new()
    };
    if let Some(path) = &raw_output {
        job::sensor_displays(&mut displays, Some(path));
    }
    let opts = RenderOptions {
        samples_per_pixel: spp,
        seed,
        path: obscura_shading::integrator::PathOptions {
            max_depth,
            ..Default::default()
        },
        ..RenderOptions::default()
    };
    let writes = [FrameWrite {
        number: None,
        displays: &displays,
    }];
    let size_source = match &scene {
        Some(path) => format!("{}: Format", path.display()),
        None => "the built-in scene's Format".to_string(),
    };
    let frame = FrameJob {
        scene: &sc,
        base_dir: &base_dir,
        writes: if displays.is_empty() { &[] } else { &writes },
        also: &wanted,
        neighbours: Neighbours::default(),
        options: &opts,
        header_frame: None,
        sidecars: Sidecars::WithGroundTruth,
        size_source: &size_source,
    };
    let reporter = Polled::default();
    let pool = pool()?;
    let mut reg = registry()?;
    let reg_ref: &mut obscura_host::Registry = &mut reg;
    let mut failure: Option<PyErr> = None;
    let result = std::thread::scope(|s| {
        let worker = s.spawn(|| pool.install(|| render_frame(&frame, reg_ref, &reporter)));
        while !worker.is_finished() {
            py.detach(|| std::thread::sleep(Duration::from_millis(100)));
            if failure.is_none() {
                let step = py.check_signals().and_then(|()| match &progress {
                    Some(cb) => cb
                        .call1((
                            reporter.done.load(Ordering::Relaxed),
                            reporter.total.load(Ordering::Relaxed),
                        ))
                        .map(|_| ()),
                    None => Ok(()),
                });
                if let Err(e) = step {
                    reporter.cancel.store(true, Ordering::SeqCst);
                    failure = Some(e);
                }
            }
        }
        worker.join()
    });
    let result = result
        .map_err(|_| PyRuntimeError::new_err("the render panicked"))?
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    if let Some(e) = failure {
        return Err(e);
    }
    let out = &result.output;
    if let Some(cb) = &progress {
        cb.call1((out.stats.tiles.0, out.stats.tiles.1))?;
    }
    let d = aov_arrays(py, &out.film, &wanted)?;
    if let Some(s) = &out.sensor {
        let crop = out.film.crop();
        let dims = [crop.height() as usize, crop.width() as usize, 3];
        let clean = obscura_sensor::isp::process_clean(s.sensor.config(), s.sensor.response(), &s.frame);
        d.set_item("clean", rgb_array(py, &dims, clean.linear.iter().copied())?)?;
        let film = (crop.y0..crop.y1).flat_map(|y| (crop.x0..crop.x1).map(move |x| (x, y)));
        let film: Vec<[f32; 3]> = film
            .map(|(x, y)| {
                let c = out.film.resolved_ci(x, y);
                [c.r, c.g, c.b]
            })
            .collect();
        d.set_item("film", rgb_array(py, &dims, film.into_iter())?)?;
    }
    let st = PyDict::new(py);
    st.set_item("render_seconds", out.stats.render_seconds)?;
    st.set_item("setup_seconds", out.stats.setup_seconds)?;
    st.set_item("flow_seconds", out.stats.flow_seconds)?;
    st.set_item("triangles", out.stats.triangles)?;
    st.set_item("camera_samples", out.stats.contract.samples)?;
    st.set_item("culled", out.stats.contract.culled)?;
    st.set_item("contract_violations", out.stats.contract.violations())?;
    st.set_item("rays_traced", out.stats.rays_traced)?;
    st.set_item("cancelled", out.stats.cancelled)?;
    let written: Vec<String> = result.written.iter().map(|p| p.display().to_string()).collect();
    st.set_item("written", written)?;
    st.set_item(
        "warnings",
        reporter.messages.lock().map(|m| m.clone()).unwrap_or_default(),
    )?;
    d.set_item("stats", st)?;
    Ok(d)
}

/// A sensor description from Python: a dict of sensor keys, or the path of a JSON file.
fn sensor_config(py: Python<'_>, value: &Bound<'_, PyAny>) -> PyResult<obscura_sensor::SensorConfig> {
    if let Ok(path) = value.extract::<PathBuf>()
        && !value.is_instance_of::<PyDict>()
    {
        let text = std::fs::read_to_string(&path)
            .map_err(|e| PyValueError::new_err(format!("sensor: cannot read {}: {e}", path.display())))?;
        return obscura_sensor::SensorConfig::from_json(&text, &path.display().to_string())
            .map_err(|e| PyValueError::new_err(e.to_string()));
    }
    let text: String = py.import("json")?.call_method1("dumps", (value,))?.extract()?;
    obscura_sensor::SensorConfig::from_json(&text, "sensor").map_err(|e| PyValueError::new_err(e.to_string()))
}

/// An H×W×3 float32 array of `values`.
fn rgb_array<'py>(
    py: Python<'py>,
    dims: &[usize; 3],
    values: impl Iterator<Item = [f32; 3]>,
) -> PyResult<Bound<'py, numpy::PyArrayDyn<f32>>> {
    let arr = zeros::<f32>(py, dims);
    let mut rw = arr.readwrite();
    let s = rw
        .as_slice_mut()
        .map_err(|_| PyRuntimeError::new_err("output not contiguous"))?;
    for (o, v) in s.chunks_exact_mut(3).zip(values) {
        o.copy_from_slice(&v);
    }
    drop(rw);
    Ok(arr)
}

/// The film's `aovs` over the crop window as numpy arrays (H×W for one channel, H×W×C otherwise),
/// keyed by their array names; IDs as uint32, the rest float32.
fn aov_arrays<'py>(py: Python<'py>, film: &Film, aovs: &[Aov]) -> PyResult<Bound<'py, PyDict>> {
    let crop = film.crop();
    let (w, h) = (crop.width() as usize, crop.height() as usize);
    let pixels: Vec<_> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| film.pixel(crop.x0 + x as u32, crop.y0 + y as u32))
        .collect();
    let d = PyDict::new(py);
    for &aov in aovs {
        let comps = aov.channels().len();
        let dims: &[usize] = if comps == 1 { &[h, w] } else { &[h, w, comps] };
        let not_contiguous = || PyRuntimeError::new_err("output not contiguous");
        if aov.spec().kind == AovKind::Id {
            let arr = zeros::<u32>(py, dims);
            let mut rw = arr.readwrite();
            let s = rw.as_slice_mut().map_err(|_| not_contiguous())?;
            for (o, v) in s.iter_mut().zip(&pixels) {
                *o = id_component(v, aov).unwrap_or(0);
            }
            drop(rw);
            d.set_item(aov.spec().array, arr)?;
        } else {
            let arr = zeros::<f32>(py, dims);
            let mut rw = arr.readwrite();
            let s = rw.as_slice_mut().map_err(|_| not_contiguous())?;
            for (o, v) in s.chunks_exact_mut(comps).zip(&pixels) {
                for (k, c) in o.iter_mut().enumerate() {
                    *c = component(v, aov, k);
                }
            }
            drop(rw);
            d.set_item(aov.spec().array, arr)?;
        }
    }
    Ok(d)
}
