//! numpy in and out: inputs are read where they lie (C or Fortran order, any strides, float32 or
//! float64; anything else array-like goes through `numpy.asarray` first), outputs are new arrays
//! owned by Python, of the input's float type.

use numpy::ndarray::{ArrayView1, ArrayView2};
use numpy::{
    Element, PyArray1, PyArray2, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyReadonlyArray1,
    PyReadonlyArray2, PyUntypedArray, PyUntypedArrayMethods, dtype,
};
use obscura_sdk::Point2;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// A float type numpy arrays come in.
pub trait Real: Element + Copy + PartialEq + Send + Sync + 'static {
    /// From f64 (rounded for f32).
    fn from_f64(x: f64) -> Self;
    /// From f32 (exact).
    fn from_f32(x: f32) -> Self;
    /// The slice itself when `Self` is f32 (the camera stage writes it directly), else `None`.
    fn as_f32(values: &mut [Self]) -> Option<&mut [f32]>;
}

impl Real for f32 {
    fn from_f64(x: f64) -> Self {
        x as f32
    }
    fn from_f32(x: f32) -> Self {
        x
    }
    fn as_f32(values: &mut [Self]) -> Option<&mut [f32]> {
        Some(values)
    }
}

impl Real for f64 {
    fn from_f64(x: f64) -> Self {
        x
    }
    fn from_f32(x: f32) -> Self {
        f64::from(x)
    }
    fn as_f32(_: &mut [Self]) -> Option<&mut [f32]> {
        None
    }
}

/// An N×k float array as given: a view of its own memory.
pub enum Matrix<'py> {
    /// float32.
    F32(PyReadonlyArray2<'py, f32>),
    /// float64.
    F64(PyReadonlyArray2<'py, f64>),
}

/// A borrowed view of a [`Matrix`], sendable to worker threads.
#[derive(Clone, Copy)]
pub enum View<'a> {
    /// float32.
    F32(ArrayView2<'a, f32>),
    /// float64.
    F64(ArrayView2<'a, f64>),
}

impl<'py> Matrix<'py> {
    /// The view.
    pub fn view(&self) -> View<'_> {
        match self {
            Matrix::F32(a) => View::F32(a.as_array()),
            Matrix::F64(a) => View::F64(a.as_array()),
        }
    }

    /// True for float64.
    pub fn is_f64(&self) -> bool {
        matches!(self, Matrix::F64(_))
    }
}

impl View<'_> {
    /// Rows.
    pub fn rows(&self) -> usize {
        match self {
            View::F32(a) => a.nrows(),
            View::F64(a) => a.nrows(),
        }
    }

    /// Element (i, j) in f64.
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        match self {
            View::F32(a) => f64::from(a[[i, j]]),
            View::F64(a) => a[[i, j]],
        }
    }

    /// Rows `range` as points (the first two columns, in f32).
    pub fn points(&self, range: std::ops::Range<usize>, out: &mut Vec<Point2>) {
        out.clear();
        match self {
            View::F32(a) => out.extend(range.map(|i| Point2::new(a[[i, 0]], a[[i, 1]]))),
            View::F64(a) => out.extend(range.map(|i| Point2::new(a[[i, 0]] as f32, a[[i, 1]] as f32))),
        }
    }

    /// The first row that holds a NaN or an infinity, with its values. A contiguous array is
    /// scanned first with a branch-free pass that vectorises (this runs on the caller's thread, before
    /// the parallel work, for every sample).
    pub fn first_non_finite(&self) -> Option<(usize, Vec<f64>)> {
        let all_finite = match self {
            View::F32(a) => a
                .as_slice_memory_order()
                .map(|s| s.iter().fold(true, |ok, x| ok & x.is_finite())),
            View::F64(a) => a
                .as_slice_memory_order()
                .map(|s| s.iter().fold(true, |ok, x| ok & x.is_finite())),
        };
        if all_finite == Some(true) {
            return None;
        }
        let cols = match self {
            View::F32(a) => a.ncols(),
            View::F64(a) => a.ncols(),
        };
        (0..self.rows())
            .find(|&i| (0..cols).any(|j| !self.get(i, j).is_finite()))
            .map(|i| (i, (0..cols).map(|j| self.get(i, j)).collect()))
    }
}

/// `obj` as a numpy array: itself, or `numpy.asarray(obj)` (lists, torch CPU tensors, anything with
/// `__array__` or the buffer protocol).
fn as_array<'py>(py: Python<'py>, obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyUntypedArray>> {
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        return Ok(a.clone());
    }
    let a = py.import("numpy")?.call_method1("asarray", (obj,))?;
    a.cast_into::<PyUntypedArray>().map_err(PyErr::from)
}

fn dtype_name(a: &Bound<'_, PyUntypedArray>) -> String {
    a.dtype()
        .str()
        .map(|s| s.to_string())
        .unwrap_or_else(|_| "?".into())
}

/// Reads argument `name` as an N×`cols` float32 or float64 array; `allow_non_finite` lets NaN and
/// infinite entries through (otherwise the first such row is a `ValueError`).
pub fn matrix<'py>(
    py: Python<'py>,
    name: &str,
    obj: &Bound<'py, PyAny>,
    cols: usize,
    allow_non_finite: bool,
) -> PyResult<Matrix<'py>> {
    let a = as_array(py, obj).map_err(|e| {
        PyTypeError::new_err(format!(
            "{name}: expected an N×{cols} float array, could not read it as one: {e}"
        ))
    })?;
    let shape = a.shape().to_vec();
    let m = if a.dtype().is_equiv_to(&dtype::<f64>(py)) {
        check_shape(name, &shape, cols)?;
        Matrix::F64(a.cast::<PyArray2<f64>>()?.readonly())
    } else if a.dtype().is_equiv_to(&dtype::<f32>(py)) {
        check_shape(name, &shape, cols)?;
        Matrix::F32(a.cast::<PyArray2<f32>>()?.readonly())
    } else {
        return Err(PyTypeError::new_err(format!(
            "{name}: expected a float32 or float64 array, got dtype {} (convert with .astype(numpy.float64))",
            dtype_name(&a)
        )));
    };
    if !allow_non_finite && let Some((i, row)) = m.view().first_non_finite() {
        return Err(PyValueError::new_err(format!(
            "{name}: row {i} is not finite: {row:?}; every value must be a finite number"
        )));
    }
    Ok(m)
}

fn check_shape(name: &str, shape: &[usize], cols: usize) -> PyResult<()> {
    if shape.len() != 2 || shape[1] != cols {
        return Err(PyValueError::new_err(format!(
            "{name}: expected an array of shape (N, {cols}), got shape {}",
            shape_text(shape)
        )));
    }
    Ok(())
}

fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        s => format!(
            "({})",
            s.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")
        ),
    }
}

/// A length-N float array as given.
pub enum Vector<'py> {
    /// float32.
    F32(PyReadonlyArray1<'py, f32>),
    /// float64.
    F64(PyReadonlyArray1<'py, f64>),
}

/// A borrowed view of a [`Vector`], sendable to worker threads.
#[derive(Clone, Copy)]
pub enum VectorView<'a> {
    /// float32.
    F32(ArrayView1<'a, f32>),
    /// float64.
    F64(ArrayView1<'a, f64>),
}

impl Vector<'_> {
    /// The view.
    pub fn view(&self) -> VectorView<'_> {
        match self {
            Vector::F32(a) => VectorView::F32(a.as_array()),
            Vector::F64(a) => VectorView::F64(a.as_array()),
        }
    }
}

impl VectorView<'_> {
    /// The values in f32, for rows `range`.
    pub fn values(&self, range: std::ops::Range<usize>, out: &mut Vec<f32>) {
        out.clear();
        match self {
            VectorView::F32(a) => out.extend(range.map(|i| a[i])),
            VectorView::F64(a) => out.extend(range.map(|i| a[i] as f32)),
        }
    }

    /// The values in f32, for rows `range`, into `out` (of the range's length).
    pub fn write(&self, range: std::ops::Range<usize>, out: &mut [f32]) {
        match self {
            VectorView::F32(a) => out.iter_mut().zip(range).for_each(|(o, i)| *o = a[i]),
            VectorView::F64(a) => out.iter_mut().zip(range).for_each(|(o, i)| *o = a[i] as f32),
        }
    }
}

/// Reads argument `name` as a float32 or float64 array of length `n`, finite.
pub fn vector<'py>(py: Python<'py>, name: &str, obj: &Bound<'py, PyAny>, n: usize) -> PyResult<Vector<'py>> {
    let a = as_array(py, obj)
        .map_err(|e| PyTypeError::new_err(format!("{name}: expected a float array of length {n}: {e}")))?;
    let shape = a.shape().to_vec();
    if shape != [n] {
        return Err(PyValueError::new_err(format!(
            "{name}: expected an array of shape ({n},), got shape {}",
            shape_text(&shape)
        )));
    }
    let v = if a.dtype().is_equiv_to(&dtype::<f64>(py)) {
        Vector::F64(a.cast::<PyArray1<f64>>()?.readonly())
    } else if a.dtype().is_equiv_to(&dtype::<f32>(py)) {
        Vector::F32(a.cast::<PyArray1<f32>>()?.readonly())
    } else {
        return Err(PyTypeError::new_err(format!(
            "{name}: expected a float32 or float64 array, got dtype {}",
            dtype_name(&a)
        )));
    };
    let mut all = Vec::new();
    v.view().values(0..n, &mut all);
    if let Some(i) = all.iter().position(|x| !x.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{name}: element {i} is not finite ({}); every value must be a finite number",
            all[i]
        )));
    }
    Ok(v)
}

/// A new zeroed array of shape `dims`, owned by Python.
pub fn zeros<'py, T: Element>(py: Python<'py>, dims: &[usize]) -> Bound<'py, PyArrayDyn<T>> {
    PyArrayDyn::<T>::zeros(py, dims, false)
}

/// A new array of shape `dims`, owned by Python, whose contents are not initialised: for outputs the
/// caller writes every element of before Python sees them (no pass of zeros first).
pub fn uninit<'py, T: Element>(py: Python<'py>, dims: &[usize]) -> Bound<'py, PyArrayDyn<T>> {
    // SAFETY: `T` is a float type (every bit pattern a value), and every caller writes each element
    // before the array is handed to Python.
    unsafe { PyArrayDyn::<T>::new(py, dims, false) }
}
