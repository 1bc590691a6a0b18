//! # obscura-python
//!
//! Obscura from Python: the native module `obscura._obscura` behind the `obscura` package (pyo3, one
//! abi3 wheel for CPython ≥ 3.9, built with maturin). Every camera the CLI can make — a built-in
//! projection, a plugin, a calibration file, a calibrated model given by its parameters — becomes an
//! `obscura.Camera` whose batched methods take and return numpy arrays.
//!
//! | file | what |
//! |---|---|
//! | `camera.rs` | `Camera`: parameters from keyword arguments, the camera options, properties |
//! | `params.rs` | Python values → a projection's [`obscura_sdk::ParamList`], with the CLI's messages |
//! | `arrays.rs` | reading numpy inputs (dtype, shape, order, NaN) and allocating outputs |
//! | `rays.rs` | `project`, `rays`, `pixel_to_ray`, `ray_to_pixel`, `world_to_pixel` |
//! | `registry.rs` | the process's projection registry, plugins, `projections()` |
//! | `tools.rs` | `stmap`, `check`, `render` |
//! | `dataset.rs` | `render_dataset`: the dataset driver of `obscura dataset` |
//! | `farm.rs` | `parse_frames`, `frame_chunks`: the CLI's frame-list parser |
//! | `pool.rs` | the worker threads (`set_num_threads`) |
//!
//! The work of every batched call runs with the GIL released, on the module's thread pool.

use pyo3::prelude::*;

mod arrays;
mod camera;
mod dataset;
mod farm;
mod params;
mod pool;
mod rays;
mod registry;
mod tools;

/// The native module: everything `obscura/__init__.py` re-exports.
#[pymodule]
fn _obscura(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<camera::Camera>()?;
    m.add_function(wrap_pyfunction!(pool::set_num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(pool::get_num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(registry::projections, m)?)?;
    m.add_function(wrap_pyfunction!(registry::load_plugin, m)?)?;
    m.add_function(wrap_pyfunction!(registry::add_plugin_path, m)?)?;
    m.add_function(wrap_pyfunction!(registry::calibration_models, m)?)?;
    m.add_function(wrap_pyfunction!(tools::stmap, m)?)?;
    m.add_function(wrap_pyfunction!(tools::check, m)?)?;
    m.add_function(wrap_pyfunction!(tools::render, m)?)?;
    m.add_function(wrap_pyfunction!(dataset::render_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(farm::parse_frames, m)?)?;
    m.add_function(wrap_pyfunction!(farm::frame_chunks, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
