//! The worker threads every batched call runs on: all cores unless `set_num_threads` says otherwise.

use std::sync::{Arc, LazyLock, RwLock};

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use rayon::{ThreadPool, ThreadPoolBuilder};

static POOL: LazyLock<RwLock<Option<Arc<ThreadPool>>>> = LazyLock::new(|| RwLock::new(None));

/// The pool in force (built on first use with one thread per core).
pub fn pool() -> PyResult<Arc<ThreadPool>> {
    if let Some(p) = POOL.read().ok().and_then(|p| p.clone()) {
        return Ok(p);
    }
    let mut slot = POOL
        .write()
        .map_err(|_| PyRuntimeError::new_err("obscura's thread pool lock was poisoned"))?;
    if let Some(p) = slot.as_ref() {
        return Ok(p.clone());
    }
    let p = Arc::new(build(0)?);
    *slot = Some(p.clone());
    Ok(p)
}

fn build(n: usize) -> PyResult<ThreadPool> {
    ThreadPoolBuilder::new()
        .num_threads(n)
        .thread_name(|i| format!("obscura-{i}"))
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start obscura's worker threads: {e}")))
}

/// Sets how many threads obscura's batched calls use (`0`: one per core, the default).
///
/// Takes effect for the calls that start after it.
#[pyfunction]
pub fn set_num_threads(n: i64) -> PyResult<()> {
    let n = usize::try_from(n)
        .map_err(|_| PyValueError::new_err(format!("set_num_threads: n = {n}: expected an integer >= 0")))?;
    let p = Arc::new(build(n)?);
    *POOL
        .write()
        .map_err(|_| PyRuntimeError::new_err("obscura's thread pool lock was poisoned"))? = Some(p);
    Ok(())
}

/// The number of threads obscura's batched calls use.
#[pyfunction]
pub fn get_num_threads() -> PyResult<usize> {
    Ok(pool()?.current_num_threads())
}
