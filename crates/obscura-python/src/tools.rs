//! `obscura.stmap`, `obscura.check` and `obscura.render`: the CLI's jobs on `Camera`s, returning
//! numpy arrays and dicts instead of files.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

use numpy::PyArrayMethods;
use obscura_check::{CheckOptions, check_registered};
use obscura_render::job::{self, load_scene};
use obscura_render::render::{RenderOptions, prepare};
use obscura_render::stmap::compute_stmap;
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

/// The AOVs `render` returns: name and components.
const AOVS: [(&str, usize); 8] = [
    ("beauty", 3),
    ("alpha", 1),
    ("z", 1),
    ("N", 3),
    ("P", 3),
    ("cameraDirection", 3),
    ("albedo", 3),
    ("uv", 2),
];

/// Renders a scene (RIB, glTF, OBJ; None for the built-in one) and returns its AOVs as numpy arrays
/// over the crop window: `beauty` (H×W×3, linear, premultiplied), `alpha`, `z` (the projection's
/// deep metric, inf where nothing was hit), `N`, `P` (world space), `cameraDirection` (H×W×3),
/// `albedo` (H×W×3: the footprint-filtered base colour at the first hit, linear), `uv` (H×W×2: the
/// first texture coordinate set as stored in the file), and `stats`.
/// `camera` replaces the scene's camera (its projection, parameters, format and options;
/// the scene's camera transform is kept unless the camera has its own `world_to_camera`). `aovs`
/// selects AOVs (default all). `progress(done_tiles, total_tiles)` is called from the calling
/// thread about ten times a second; Ctrl-C (KeyboardInterrupt) stops the render and raises.
#[pyfunction]
#[pyo3(signature = (scene = None, camera = None, spp = None, aovs = None, seed = 0, max_depth = 6, progress = None))]
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
) -> PyResult<Bound<'py, PyDict>> {
    let wanted: Vec<(&str, usize)> = match &aovs {
        None => AOVS.to_vec(),
        Some(list) => list
            .iter()
            .map(|a| {
                AOVS.iter().find(|(n, _)| n == a).copied().ok_or_else(|| {
                    PyValueError::new_err(format!(
                        "aovs: unknown AOV {a:?}; expected some of {}",
                        AOVS.map(|(n, _)| n).join(", ")
                    ))
                })
            })
            .collect::<PyResult<_>>()?,
    };
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
    let opts = RenderOptions {
        samples_per_pixel: spp,
        seed,
        path: obscura_render::integrator::PathOptions {
            max_depth,
            ..Default::default()
        },
        ..RenderOptions::default()
    };
    let prepared = {
        let mut reg = registry()?;
        let reg_ref: &mut obscura_host::Registry = &mut reg;
        py.detach(|| prepare(&sc, reg_ref, &base_dir, &opts))
            .map_err(|e| PyValueError::new_err(e.to_string()))?
    };
    let pool = pool()?;
    let cancel = AtomicBool::new(false);
    let (done, total) = (AtomicUsize::new(0), AtomicUsize::new(0));
    let mut failure: Option<PyErr> = None;
    let out = std::thread::scope(|s| {
        let worker = s.spawn(|| {
            pool.install(|| {
                prepared.render(
                    &opts,
                    &|d, t| {
                        done.store(d, Ordering::Relaxed);
                        total.store(t, Ordering::Relaxed);
                    },
                    &cancel,
                )
            })
        });
        while !worker.is_finished() {
            py.detach(|| std::thread::sleep(Duration::from_millis(100)));
            if failure.is_none() {
                let step = py.check_signals().and_then(|()| match &progress {
                    Some(cb) => cb
                        .call1((done.load(Ordering::Relaxed), total.load(Ordering::Relaxed)))
                        .map(|_| ()),
                    None => Ok(()),
                });
                if let Err(e) = step {
                    cancel.store(true, Ordering::SeqCst);
                    failure = Some(e);
                }
            }
        }
        worker.join()
    });
    let out = out.map_err(|_| PyRuntimeError::new_err("the render panicked"))?;
    if let Some(e) = failure {
        return Err(e);
    }
    if let Some(cb) = &progress {
        cb.call1((out.stats.tiles.0, out.stats.tiles.1))?;
    }
    let crop = out.film.crop();
    let (w, h) = (crop.width() as usize, crop.height() as usize);
    let d = PyDict::new(py);
    for (name, comps) in wanted {
        let arr = if comps == 1 {
            zeros::<f32>(py, &[h, w])
        } else {
            zeros::<f32>(py, &[h, w, comps])
        };
        {
            let mut rw = arr.readwrite();
            let s = rw
                .as_slice_mut()
                .map_err(|_| PyRuntimeError::new_err("output not contiguous"))?;
            for y in 0..h {
                for x in 0..w {
                    let v = out.film.pixel(crop.x0 + x as u32, crop.y0 + y as u32);
                    let i = (y * w + x) * comps;
                    let v3 = |v: glam::Vec3| [v.x, v.y, v.z];
                    match name {
                        "beauty" => s[i..i + 3].copy_from_slice(&[v.ci.r, v.ci.g, v.ci.b]),
                        "alpha" => s[i] = v.alpha,
                        "z" => s[i] = v.z,
                        "N" => s[i..i + 3].copy_from_slice(&v3(v.n)),
                        "P" => s[i..i + 3].copy_from_slice(&v3(v.p)),
                        "albedo" => s[i..i + 3].copy_from_slice(&[v.albedo.r, v.albedo.g, v.albedo.b]),
                        "uv" => s[i..i + 2].copy_from_slice(&[v.uv.x, v.uv.y]),
                        _ => s[i..i + 3].copy_from_slice(&v3(v.camera_direction)),
                    }
                }
            }
        }
        d.set_item(name, arr)?;
    }
    let st = PyDict::new(py);
    st.set_item("render_seconds", out.stats.render_seconds)?;
    st.set_item("setup_seconds", out.stats.setup_seconds)?;
    st.set_item("triangles", out.stats.triangles)?;
    st.set_item("camera_samples", out.stats.contract.samples)?;
    st.set_item("culled", out.stats.contract.culled)?;
    st.set_item("contract_violations", out.stats.contract.violations())?;
    st.set_item("rays_traced", out.stats.rays_traced)?;
    st.set_item("cancelled", out.stats.cancelled)?;
    d.set_item("stats", st)?;
    Ok(d)
}
