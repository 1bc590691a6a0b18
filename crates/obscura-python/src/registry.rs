//! The process's projection registry: every built-in, and each plugin loaded by path or found along
//! the plugin path (`add_plugin_path`, then `OBSCURA_PLUGIN_PATH`), exactly as the CLI finds them.

use std::path::PathBuf;
use std::sync::{LazyLock, Mutex, MutexGuard};

use obscura_calibration::MODELS;
use obscura_host::Registry;
use obscura_plugins::builtin_registry;
use obscura_plugins::loader::{PluginSearch, ensure, load_all, load_file};
use obscura_sdk::{ParamDecl, ParamValue};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

static REGISTRY: LazyLock<Mutex<Registry>> = LazyLock::new(|| Mutex::new(builtin_registry()));
static EXTRA_PATHS: LazyLock<Mutex<Vec<PathBuf>>> = LazyLock::new(|| Mutex::new(Vec::new()));

/// The registry, locked.
pub fn registry() -> PyResult<MutexGuard<'static, Registry>> {
    REGISTRY
        .lock()
        .map_err(|_| PyRuntimeError::new_err("obscura's projection registry lock was poisoned"))
}

/// The plugin search path: `add_plugin_path` directories, then `OBSCURA_PLUGIN_PATH`.
pub fn search() -> PluginSearch {
    let extra = EXTRA_PATHS.lock().map(|p| p.clone()).unwrap_or_default();
    PluginSearch::from_env(&extra)
}

/// Resolves a projection name or plugin path to a registered name, loading a plugin when needed.
pub fn resolve(registry: &mut Registry, name_or_path: &str) -> PyResult<String> {
    ensure(registry, name_or_path, &search()).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Loads the projection plugin library at `path` (a `.so` built against Obscura's C ABI, in C or
/// Rust) and returns the projection's name. Loading the same file again returns its name.
#[pyfunction]
pub fn load_plugin(path: PathBuf) -> PyResult<String> {
    let mut reg = registry()?;
    let canonical = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
    if let Some(name) = reg.names().into_iter().find(|n| {
        reg.path(n)
            .is_some_and(|p| std::path::Path::new(p) == canonical || std::path::Path::new(p) == path)
    }) {
        return Ok(name);
    }
    load_file(&mut reg, &path).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Adds a directory searched for `<Name>.so` when a camera names a projection that is not loaded
/// (searched before `OBSCURA_PLUGIN_PATH`).
#[pyfunction]
pub fn add_plugin_path(directory: PathBuf) -> PyResult<()> {
    EXTRA_PATHS
        .lock()
        .map_err(|_| PyRuntimeError::new_err("obscura's plugin path lock was poisoned"))?
        .push(directory);
    Ok(())
}

/// Every projection: the built-ins, loaded plugins and every plugin library on the plugin path, each
/// as a dict with `name`, `summary`, `path` (the plugin file, `None` for a built-in) and `params`, its
/// parameter table (`name`, `type` as RIB declares it, `default`, `range` (lo, hi) or None,
/// `choices`, `doc`).
#[pyfunction]
pub fn projections(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let mut reg = registry()?;
    // A library on the path that does not load is skipped here, as `obscura plugins` warns and goes on.
    let _ = load_all(&mut reg, &search());
    let out = PyList::empty(py);
    for name in reg.names() {
        let Some(f) = reg.get(&name) else { continue };
        let d = PyDict::new(py);
        d.set_item("name", &name)?;
        d.set_item("summary", f.summary())?;
        d.set_item("path", reg.path(&name).filter(|p| !p.is_empty()))?;
        let params = PyList::empty(py);
        for p in f.param_table() {
            params.append(param_row(py, p)?)?;
        }
        d.set_item("params", params)?;
        out.append(d)?;
    }
    Ok(out)
}

fn param_row<'py>(py: Python<'py>, p: &ParamDecl) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("name", p.name.as_ref())?;
    d.set_item(
        "type",
        p.rib_declaration().trim_end_matches(&format!(" {}", p.name)),
    )?;
    let default = match &p.default {
        ParamValue::Floats(v) if v.len() == 1 && p.array_len.is_none() && !p.variable_len => {
            v[0].into_pyobject(py)?.into_any()
        }
        ParamValue::Ints(v) if v.len() == 1 && p.array_len.is_none() && !p.variable_len => {
            v[0].into_pyobject(py)?.into_any()
        }
        ParamValue::Strings(v) if v.len() == 1 => v[0].clone().into_pyobject(py)?.into_any(),
        ParamValue::Floats(v) => PyList::new(py, v)?.into_any(),
        ParamValue::Ints(v) => PyList::new(py, v)?.into_any(),
        ParamValue::Strings(v) => PyList::new(py, v)?.into_any(),
    };
    d.set_item("default", default)?;
    d.set_item("range", p.range.map(|r| (r.min, r.max)))?;
    d.set_item(
        "choices",
        p.choices.iter().map(|c| c.as_ref()).collect::<Vec<_>>(),
    )?;
    d.set_item("doc", p.doc.as_ref())?;
    Ok(d)
}

/// The calibrated camera models `Camera("CalibratedCamera", model=...)` takes, each as a dict with
/// `name`, `params` (the parameter names in the source library's order), `counts` (accepted lengths
/// of `params`) and `pixel_convention` (the model's own).
#[pyfunction]
pub fn calibration_models(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let out = PyList::empty(py);
    for m in MODELS.iter() {
        let d = PyDict::new(py);
        d.set_item("name", m.name)?;
        d.set_item("params", m.params)?;
        d.set_item("counts", m.counts.to_vec())?;
        d.set_item("pixel_convention", m.convention.name())?;
        out.append(d)?;
    }
    Ok(out)
}
