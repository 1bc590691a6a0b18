//! The batched methods of `Camera`: `project`, `rays`, `pixel_to_ray`, `ray_to_pixel` and
//! `world_to_pixel`. Each reads its inputs where they lie, releases the GIL and runs on the module's
//! thread pool, writing new numpy arrays.
//!
//! Precision: `project` and `rays` are the projection's own f32 rays (the contract's type), returned
//! as float64 when float64 came in. `pixel_to_ray` and `ray_to_pixel` of a calibrated camera run its
//! model in f64 from the parameters as given; of any other camera they go through the projection's
//! chief ray and its `unproject` (f32).

use glam::Affine3A;
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use obscura_calibration::PixelConvention;
use obscura_geometry::motion::Motion;
use obscura_geometry::motion::glam_from_sdk;
use obscura_host::driver::{Batch, OUTPUT_FIELDS, output_values};
use obscura_host::{CameraStage, SoaScratch};
use obscura_image::raymap::trace_ray_map;
use obscura_sdk::{Point2, RayGeometry, RaysSoa, Rgb, SoaContext, Vec3};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use rayon::prelude::*;

use crate::arrays::{Matrix, Real, Vector, View, matrix, uninit, vector, zeros};
use crate::camera::Camera;
use crate::pool::pool;

/// A per-point answer: values (N×k) and `valid` (N).
type Answer<'py, T> = (Bound<'py, PyArrayDyn<T>>, Bound<'py, PyArray1<bool>>);

/// Samples per batch handed to the camera stage (the renderer's batch size).
const CHUNK: usize = 4096;

/// The number of `f32` fields of one sample in `project`'s outputs ([`OUTPUT_FIELDS`] order: the ray's
/// ten, time, tint's three).
const FIELDS: usize = OUTPUT_FIELDS.len();

/// One chunk of every output: the fields in [`OUTPUT_FIELDS`] order, each its own contiguous slice of
/// the same rows, and the valid flags.
struct Chunk<'a, T> {
    start: usize,
    fields: [&'a mut [T]; FIELDS],
    valid: &'a mut [bool],
}

impl<T: Real> Chunk<'_, T> {
    fn len(&self) -> usize {
        self.valid.len()
    }

    /// Writes array-of-structs rays (the ray map's) into the fields.
    fn write_aos(&mut self, rays: &[RayGeometry], tint: &[Rgb], time: &[f32]) {
        for (i, ((r, t), time)) in rays.iter().zip(tint).zip(time).enumerate() {
            for (field, v) in self.fields.iter_mut().zip(output_values(r, *time, *t)) {
                field[i] = T::from_f32(v);
            }
        }
    }

    /// `valid`: the direction is not zero (the stage culls every ray that broke the contract).
    fn set_valid(&mut self) {
        let zero = T::from_f32(0.0);
        let [_, _, _, _, dx, dy, dz, ..] = &self.fields;
        for (i, v) in self.valid.iter_mut().enumerate() {
            *v = dx[i] != zero || dy[i] != zero || dz[i] != zero;
        }
    }
}

/// What one worker thread keeps between chunks.
#[derive(Default)]
struct Worker {
    screen: Vec<Point2>,
    lens: Vec<Point2>,
    aperture: Vec<Point2>,
    scratch: SoaScratch,
    /// `FIELDS × CHUNK` floats for a float64 output: the stage writes f32 here first.
    narrow: Vec<f32>,
}

/// The output arrays of `project`/`rays`, with leading dimensions `lead`. Each field is stored
/// component by component: a 3-vector as a `(3, *lead)` array handed back as its `(*lead, 3)`
/// transposed view, so every component (all `origin.x`, …) is contiguous and the camera stage writes
/// it directly.
struct RayArrays<'py, T: Real> {
    origin: Bound<'py, PyArrayDyn<T>>,
    direction: Bound<'py, PyArrayDyn<T>>,
    origin_radius: Bound<'py, PyArrayDyn<T>>,
    ray_spread: Bound<'py, PyArrayDyn<T>>,
    min_dist: Bound<'py, PyArrayDyn<T>>,
    max_dist: Bound<'py, PyArrayDyn<T>>,
    tint: Bound<'py, PyArrayDyn<T>>,
    time: Bound<'py, PyArrayDyn<T>>,
    valid: Bound<'py, PyArrayDyn<bool>>,
    lead: Vec<usize>,
}

impl<'py, T: Real> RayArrays<'py, T> {
    /// Every float array uninitialised (each element is written by `fill`), `valid` zeroed.
    fn new(py: Python<'py>, lead: &[usize]) -> Self {
        let by3: Vec<usize> = [3].into_iter().chain(lead.iter().copied()).collect();
        RayArrays {
            origin: uninit(py, &by3),
            direction: uninit(py, &by3),
            origin_radius: uninit(py, lead),
            ray_spread: uninit(py, lead),
            min_dist: uninit(py, lead),
            max_dist: uninit(py, lead),
            tint: uninit(py, &by3),
            time: uninit(py, lead),
            valid: zeros(py, lead),
            lead: lead.to_vec(),
        }
    }

    /// The arrays of `out`, a dict as an earlier `project` of `n` samples in `T` returned (or any with
    /// those keys whose arrays have its shapes, dtypes and layout): every 3-vector's `.T` a C-contiguous
    /// 3×N array, the others C-contiguous of N, all writeable. A `ValueError` names the first key at
    /// fault and what it expected.
    fn from_out(py: Python<'py>, out: &Bound<'py, PyDict>, n: usize) -> PyResult<Self> {
        let dtype = numpy::dtype::<T>(py).str()?.to_string();
        let get = |key: &str, by3: bool| -> PyResult<Bound<'py, PyAny>> {
            let a = out
                .get_item(key)?
                .ok_or_else(|| PyValueError::new_err(format!("out: no {key:?} array")))?;
            Ok(if by3 { a.getattr("T")? } else { a })
        };
        let wrong = |key: &str, want: &str| {
            PyValueError::new_err(format!(
                "out[{key:?}]: expected {want} (the arrays an earlier project() of {n} samples returned)"
            ))
        };
        let float = |key: &str, by3: bool| -> PyResult<Bound<'py, PyArrayDyn<T>>> {
            let want = if by3 {
                format!("a writeable {dtype} array of shape ({n}, 3) whose .T is C-contiguous")
            } else {
                format!("a writeable C-contiguous {dtype} array of shape ({n},)")
            };
            let a = get(key, by3)?
                .cast_into::<PyArrayDyn<T>>()
                .map_err(|_| wrong(key, &want))?;
            let shape: &[usize] = if by3 { &[3, n] } else { &[n] };
            if a.shape() != shape || !a.is_c_contiguous() || a.try_readwrite().is_err() {
                return Err(wrong(key, &want));
            }
            Ok(a)
        };
        let valid = get("valid", false)?
            .cast_into::<PyArrayDyn<bool>>()
            .ok()
            .filter(|a| a.shape() == [n] && a.is_c_contiguous() && a.try_readwrite().is_ok())
            .ok_or_else(|| {
                wrong(
                    "valid",
                    &format!("a writeable C-contiguous bool array of shape ({n},)"),
                )
            })?;
        Ok(RayArrays {
            origin: float("origin", true)?,
            direction: float("direction", true)?,
            origin_radius: float("origin_radius", false)?,
            ray_spread: float("ray_spread", false)?,
            min_dist: float("min_dist", false)?,
            max_dist: float("max_dist", false)?,
            tint: float("tint", true)?,
            time: float("time", false)?,
            valid,
            lead: vec![n],
        })
    }

    /// Runs `fill` over chunks of `CHUNK` samples of all outputs (disjoint slices of the arrays), in
    /// parallel, without the GIL. `fill` must write every field of its chunk.
    fn fill(
        &self,
        py: Python<'py>,
        n: usize,
        fill: impl Fn(&mut Worker, &mut Chunk<'_, T>) + Send + Sync,
    ) -> PyResult<()> {
        let busy = |_| PyValueError::new_err("out: an array is given twice, or is not writeable");
        let mut origin = self.origin.try_readwrite().map_err(busy)?;
        let mut direction = self.direction.try_readwrite().map_err(busy)?;
        let mut origin_radius = self.origin_radius.try_readwrite().map_err(busy)?;
        let mut ray_spread = self.ray_spread.try_readwrite().map_err(busy)?;
        let mut min_dist = self.min_dist.try_readwrite().map_err(busy)?;
        let mut max_dist = self.max_dist.try_readwrite().map_err(busy)?;
        let mut tint = self.tint.try_readwrite().map_err(busy)?;
        let mut time = self.time.try_readwrite().map_err(busy)?;
        let mut valid = self.valid.try_readwrite().map_err(busy)?;
        let err = not_contiguous;
        let [ox, oy, oz] = thirds(origin.as_slice_mut().map_err(err)?, n)?;
        let [dx, dy, dz] = thirds(direction.as_slice_mut().map_err(err)?, n)?;
        let [tr, tg, tb] = thirds(tint.as_slice_mut().map_err(err)?, n)?;
        let whole: [&mut [T]; FIELDS] = [
            ox,
            oy,
            oz,
            origin_radius.as_slice_mut().map_err(err)?,
            dx,
            dy,
            dz,
            ray_spread.as_slice_mut().map_err(err)?,
            min_dist.as_slice_mut().map_err(err)?,
            max_dist.as_slice_mut().map_err(err)?,
            time.as_slice_mut().map_err(err)?,
            tr,
            tg,
            tb,
        ];
        let valid = valid.as_slice_mut().map_err(err)?;
        if whole.iter().any(|f| f.len() != n) || valid.len() != n {
            return Err(PyRuntimeError::new_err("output arrays of unequal length"));
        }
        let mut parts = whole.map(|f| f.chunks_mut(CHUNK));
        let chunks: Vec<Chunk<'_, T>> = valid
            .chunks_mut(CHUNK)
            .enumerate()
            .map(|(k, valid)| Chunk {
                start: k * CHUNK,
                fields: std::array::from_fn(|f| parts[f].next().expect("every field has n rows")),
                valid,
            })
            .collect();
        let pool = pool()?;
        py.detach(|| {
            pool.install(|| {
                chunks
                    .into_par_iter()
                    .for_each_init(Worker::default, |w, mut c| fill(w, &mut c));
            });
        });
        Ok(())
    }

    fn into_dict(self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        // The (3, *lead) arrays seen as (*lead, 3): axes 1..=L, then 0.
        let axes: Vec<usize> = (1..=self.lead.len()).chain([0]).collect();
        let axes = PyTuple::new(py, axes)?;
        let d = PyDict::new(py);
        d.set_item("origin", self.origin.call_method1("transpose", (&axes,))?)?;
        d.set_item("direction", self.direction.call_method1("transpose", (&axes,))?)?;
        d.set_item("origin_radius", self.origin_radius)?;
        d.set_item("ray_spread", self.ray_spread)?;
        d.set_item("min_dist", self.min_dist)?;
        d.set_item("max_dist", self.max_dist)?;
        d.set_item("tint", self.tint.call_method1("transpose", (&axes,))?)?;
        d.set_item("time", self.time)?;
        d.set_item("valid", self.valid)?;
        Ok(d)
    }
}

/// `s`, of `3·n` values, as its three thirds.
fn thirds<T>(s: &mut [T], n: usize) -> PyResult<[&mut [T]; 3]> {
    if s.len() != 3 * n {
        return Err(PyRuntimeError::new_err("output arrays of unequal length"));
    }
    let (a, bc) = s.split_at_mut(n);
    let (b, c) = bc.split_at_mut(n);
    Ok([a, b, c])
}

/// Runs the camera stage on the worker's samples (`w.screen`, `w.lens`; `fields[10]`, the time,
/// holds the canonical times) into `fields`, every one of which it writes. `chief`: the aperture
/// centre and no warps, as `run_prepared` with a zero aperture.
fn run_stage(stage: &CameraStage, w: &mut Worker, fields: [&mut [f32]; FIELDS], chief: bool) {
    let [
        ox,
        oy,
        oz,
        radius,
        dx,
        dy,
        dz,
        spread,
        near,
        far,
        time,
        tr,
        tg,
        tb,
    ] = fields;
    let rays = RaysSoa::new([ox, oy, oz], radius, [dx, dy, dz], spread, near, far)
        .expect("the chunk's fields have one length");
    if chief {
        w.aperture.clear();
        w.aperture.resize(w.screen.len(), Point2::ZERO);
        let mut ctx = SoaContext::new(&w.screen, &w.lens, &w.aperture, time, rays, [tr, tg, tb])
            .expect("the chunk's inputs have its length");
        stage.run_soa_prepared(&mut ctx, &mut w.scratch);
    } else {
        stage
            .run_soa(&w.screen, &w.lens, time, rays, [tr, tg, tb], &mut w.scratch)
            .expect("the chunk's inputs have its length");
    }
}

/// Allocates an answer of N rows (`cols` values and a valid flag each) and fills it chunk by chunk
/// on the pool without the GIL: `fill(first_row, values, valid)`, `valid` pre-set to false.
fn answer<'py, T: Real>(
    py: Python<'py>,
    n: usize,
    cols: usize,
    fill: impl Fn(usize, &mut [T], &mut [bool]) + Send + Sync,
) -> PyResult<Answer<'py, T>> {
    let values = zeros::<T>(py, &[n, cols]);
    let valid = PyArray1::<bool>::zeros(py, n, false);
    {
        let mut a = values.readwrite();
        let mut b = valid.readwrite();
        let a = a.as_slice_mut().map_err(not_contiguous)?;
        let b = b.as_slice_mut().map_err(not_contiguous)?;
        let pool = pool()?;
        py.detach(|| {
            pool.install(|| {
                a.par_chunks_mut(cols * CHUNK)
                    .zip(b.par_chunks_mut(CHUNK))
                    .enumerate()
                    .for_each(|(k, (a, b))| fill(k * CHUNK, a, b));
            });
        });
    }
    Ok((values, valid))
}

fn not_contiguous(_: numpy::AsSliceError) -> PyErr {
    PyRuntimeError::new_err("a new output array is not contiguous")
}

/// `"obscura"` (+Y up) or `"opencv"` (+Y down): the sign applied to Y.
fn y_sign(camera_space: &str) -> PyResult<f64> {
    match camera_space {
        "obscura" => Ok(1.0),
        "opencv" => Ok(-1.0),
        other => Err(PyValueError::new_err(format!(
            "camera_space={other:?}: expected \"obscura\" (+Y up, the default) or \"opencv\" (+Y down)"
        ))),
    }
}

impl Camera {
    /// The pixel convention asked for, else the camera's own.
    fn convention(&self, name: Option<&str>) -> PyResult<PixelConvention> {
        match name {
            None => Ok(self
                .exact
                .as_ref()
                .map_or(PixelConvention::Colmap, |e| e.convention)),
            Some("colmap") => Ok(PixelConvention::Colmap),
            Some("opencv") => Ok(PixelConvention::OpenCv),
            Some("matlab") => Ok(PixelConvention::Matlab),
            Some(other) => Err(PyValueError::new_err(format!(
                "pixel_convention={other:?}: expected \"colmap\" (top-left pixel centre at (0.5, 0.5)), \
                 \"opencv\" (at (0, 0)) or \"matlab\" (at (1, 1))"
            ))),
        }
    }

    fn project_typed<'py, T: Real>(
        &self,
        py: Python<'py>,
        screen: View<'_>,
        lens: Option<&Matrix<'_>>,
        time: Option<&Vector<'_>>,
        into: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let n = screen.rows();
        let out = match into {
            Some(d) => RayArrays::<T>::from_out(py, d, n)?,
            None => RayArrays::<T>::new(py, &[n]),
        };
        let lens = lens.map(Matrix::view);
        let time = time.map(Vector::view);
        let chief = lens.is_none() && time.is_none();
        let stage = &self.stage;
        out.fill(py, n, |w, c| {
            let m = c.len();
            let range = c.start..c.start + m;
            screen.points(range.clone(), &mut w.screen);
            match &lens {
                Some(l) => l.points(range.clone(), &mut w.lens),
                None => {
                    w.lens.clear();
                    w.lens.resize(m, Point2::new(0.5, 0.5));
                }
            }
            let set_time = |t: &mut [f32]| match &time {
                Some(v) => v.write(range.clone(), t),
                None => t.fill(0.0),
            };
            // float32 out: the stage writes the numpy arrays themselves; float64: a chunk of f32 first.
            let direct: Option<Vec<&mut [f32]>> = c.fields.iter_mut().map(|f| T::as_f32(f)).collect();
            match direct.and_then(|d| <[&mut [f32]; FIELDS]>::try_from(d).ok()) {
                Some(fields) => {
                    set_time(fields[10]);
                    run_stage(stage, w, fields, chief);
                }
                None => {
                    let mut narrow = std::mem::take(&mut w.narrow);
                    narrow.resize(FIELDS * m, 0.0);
                    let mut parts = narrow.chunks_exact_mut(m.max(1));
                    let fields: [&mut [f32]; FIELDS] =
                        std::array::from_fn(|_| parts.next().expect("FIELDS chunks of m"));
                    set_time(fields[10]);
                    run_stage(stage, w, fields, chief);
                    for (to, from) in c.fields.iter_mut().zip(narrow.chunks_exact(m.max(1))) {
                        for (t, f) in to.iter_mut().zip(from) {
                            *t = T::from_f32(*f);
                        }
                    }
                    w.narrow = narrow;
                }
            }
            c.set_valid();
        })?;
        match into {
            Some(d) => Ok(d.clone()),
            None => out.into_dict(py),
        }
    }
}

#[pymethods]
impl Camera {
    /// Rays of N screen samples, through the projection and the host's contract (what the renderer
    /// does with every camera sample).
    ///
    /// `screen`: N×2 screen-space positions (the screen window's coordinates, y up). `lens`: N×2
    /// canonical lens samples in [0, 1)², warped by the camera's aperture options (default: the lens
    /// centre); `time`: N canonical shutter samples in [0, 1), warped by the shutter opening (default
    /// 0). With neither, the chief rays (aperture centre, time 0) as `rays()` computes them.
    ///
    /// Returns a dict: `origin`, `direction` (N×3), `origin_radius`, `ray_spread`, `min_dist`,
    /// `max_dist` (N), `tint` (N×3), `time` (N, after the projection) and `valid` (N bool). Invalid
    /// (culled) rays have a zero direction. Values are the projection's f32 rays, in the input's
    /// float type. A NaN or infinite input raises ValueError naming the argument and row.
    ///
    /// Memory: every component is contiguous — the N×3 arrays are transposed views of 3×N arrays
    /// (`out["direction"].T` is C-contiguous: all x, then all y, then all z), which the camera stage
    /// writes directly; `numpy.ascontiguousarray` gives a row-major copy.
    ///
    /// `out`: a dict an earlier `project` of as many samples in the same float type returned; its
    /// arrays are written in place and the dict returned (no new memory: the loop of a caller that
    /// projects batch after batch). An array of another shape, dtype or layout raises ValueError
    /// naming it.
    #[pyo3(signature = (screen, lens = None, time = None, out = None))]
    fn project<'py>(
        &self,
        py: Python<'py>,
        screen: &Bound<'py, PyAny>,
        lens: Option<&Bound<'py, PyAny>>,
        time: Option<&Bound<'py, PyAny>>,
        out: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let screen = matrix(py, "screen", screen, 2, false)?;
        let n = screen.view().rows();
        let lens = lens.map(|l| matrix(py, "lens", l, 2, false)).transpose()?;
        if let Some(l) = &lens
            && l.view().rows() != n
        {
            return Err(PyValueError::new_err(format!(
                "lens: expected {n} rows (one per screen sample), got {}",
                l.view().rows()
            )));
        }
        let time = time.map(|t| vector(py, "time", t, n)).transpose()?;
        if screen.is_f64() {
            self.project_typed::<f64>(py, screen.view(), lens.as_ref(), time.as_ref(), out)
        } else {
            self.project_typed::<f32>(py, screen.view(), lens.as_ref(), time.as_ref(), out)
        }
    }

    /// Every pixel centre's chief ray (aperture centre, time 0) over the crop window: the same dict
    /// as `project` with H×W leading dimensions, float32, bit-identical to `obscura rays`. The H×W×3
    /// arrays are, as `project`'s, views of 3×H×W arrays (each component contiguous).
    fn rays<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let pool = pool()?;
        let stage = &self.stage;
        let (map, _) = py
            .detach(|| pool.install(|| trace_ray_map(stage, 0, 0)))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let (w, h) = (map.pixels.width() as usize, map.pixels.height() as usize);
        let out = RayArrays::<f32>::new(py, &[h, w]);
        let layer = &map.layers[0];
        out.fill(py, w * h, |_, c| {
            let range = c.start..c.start + c.len();
            c.write_aos(
                &layer.rays[range.clone()],
                &layer.tint[range.clone()],
                &layer.time[range],
            );
            c.set_valid();
        })?;
        out.into_dict(py)
    }

    /// Unit ray directions of N raster positions (N×2, x right, y down): `(directions N×3, valid N)`.
    ///
    /// `pixel_convention`: `"colmap"` (the top-left pixel's centre at (0.5, 0.5)), `"opencv"` (at
    /// (0, 0)) or `"matlab"` (at (1, 1)); default the calibration's own, `"colmap"` (Obscura's raster)
    /// for other cameras. `camera_space`: `"obscura"` (+Y up) or `"opencv"` (+Y down). A calibrated
    /// camera runs its model in f64 (exact to 1e-9 in normalised coordinates); other cameras give their
    /// chief ray's direction (f32). Invalid pixels have a zero direction. NaN raises ValueError.
    #[pyo3(signature = (px, pixel_convention = None, camera_space = "obscura"))]
    fn pixel_to_ray<'py>(
        &self,
        py: Python<'py>,
        px: &Bound<'py, PyAny>,
        pixel_convention: Option<&str>,
        camera_space: &str,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyArray1<bool>>)> {
        let conv = self.convention(pixel_convention)?;
        let sy = y_sign(camera_space)?;
        let px = matrix(py, "px", px, 2, false)?;
        if px.is_f64() {
            let (d, v) = self.pixel_to_ray_typed::<f64>(py, px.view(), conv, sy)?;
            Ok((d.into_any(), v))
        } else {
            let (d, v) = self.pixel_to_ray_typed::<f32>(py, px.view(), conv, sy)?;
            Ok((d.into_any(), v))
        }
    }

    /// Raster positions (N×2) where N camera-space points (N×3) are seen: `(pixels N×2, valid N)`.
    ///
    /// `pixel_convention` and `camera_space` as in `pixel_to_ray`. A calibrated camera runs its model
    /// in f64; other cameras invert their projection (`unproject`, f32). Points the camera does not
    /// see give `valid = False` and NaN pixels. NaN input raises ValueError.
    #[pyo3(signature = (points, pixel_convention = None, camera_space = "obscura"))]
    fn ray_to_pixel<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        pixel_convention: Option<&str>,
        camera_space: &str,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyArray1<bool>>)> {
        let conv = self.convention(pixel_convention)?;
        let sy = y_sign(camera_space)?;
        let pts = matrix(py, "points", points, 3, false)?;
        let n = pts.view().rows();
        let view = pts.view();
        let get = move |i: usize| [view.get(i, 0), sy * view.get(i, 1), view.get(i, 2)];
        if pts.is_f64() {
            let (p, v) = self.ray_to_pixel_typed::<f64>(py, n, get, conv)?;
            Ok((p.into_any(), v))
        } else {
            let (p, v) = self.ray_to_pixel_typed::<f32>(py, n, get, conv)?;
            Ok((p.into_any(), v))
        }
    }

    /// Raster positions (N×2) of N world-space points (N×3) through the camera's world-to-camera
    /// transform at scene time `time` (motion samples interpolated as the renderer does):
    /// `(pixels N×2, valid N)`. `pixel_convention` as in `ray_to_pixel`.
    #[pyo3(signature = (points_world, time = 0.0, pixel_convention = None))]
    fn world_to_pixel<'py>(
        &self,
        py: Python<'py>,
        points_world: &Bound<'py, PyAny>,
        time: f32,
        pixel_convention: Option<&str>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyArray1<bool>>)> {
        let conv = self.convention(pixel_convention)?;
        let pts = matrix(py, "points_world", points_world, 3, false)?;
        let n = pts.view().rows();
        let m = self.world_to_camera_at(time)?;
        let view = pts.view();
        let get = move |i: usize| {
            let p = [view.get(i, 0), view.get(i, 1), view.get(i, 2)];
            std::array::from_fn(|c| p[0] * m[0][c] + p[1] * m[1][c] + p[2] * m[2][c] + m[3][c])
        };
        if pts.is_f64() {
            let (p, v) = self.ray_to_pixel_typed::<f64>(py, n, get, conv)?;
            Ok((p.into_any(), v))
        } else {
            let (p, v) = self.ray_to_pixel_typed::<f32>(py, n, get, conv)?;
            Ok((p.into_any(), v))
        }
    }

    /// World-to-camera at scene time `time` as a 4×4 matrix (RenderMan's row-vector convention:
    /// `[p 1]·M`).
    #[pyo3(signature = (time = 0.0))]
    fn world_to_camera(&self, time: f32) -> PyResult<[[f64; 4]; 4]> {
        self.world_to_camera_at(time)
    }
}

impl Camera {
    /// World-to-camera at scene time `time`, row-vector convention, in f64: the matrix itself for a
    /// static camera, else the renderer's interpolation (scale and translation linear, rotation
    /// slerped) of camera-to-world.
    fn world_to_camera_at(&self, time: f32) -> PyResult<[[f64; 4]; 4]> {
        let samples = self.stage.environment().world_to_camera();
        if let [one] = samples {
            return Ok(one.world_to_camera.0.map(|r| r.map(f64::from)));
        }
        let keys: Vec<(f32, Affine3A)> = samples
            .iter()
            .map(|s| {
                (
                    s.time,
                    Affine3A::from_mat4(glam_from_sdk(&s.world_to_camera).inverse()),
                )
            })
            .collect();
        if keys
            .iter()
            .any(|(_, m)| !m.is_finite() || m.matrix3.determinant() == 0.0)
        {
            return Err(PyValueError::new_err(
                "world_to_camera: a motion sample is singular or not finite",
            ));
        }
        let w2c = glam::Mat4::from(Motion::new(&keys).object_to_world(time).inverse());
        // glam is column-vector: its columns are the row-vector matrix's rows.
        Ok(w2c.to_cols_array_2d().map(|r| r.map(f64::from)))
    }

    fn pixel_to_ray_typed<'py, T: Real>(
        &self,
        py: Python<'py>,
        px: View<'_>,
        conv: PixelConvention,
        sy: f64,
    ) -> PyResult<Answer<'py, T>> {
        let format = self.stage.camera().format;
        let (fw, fh) = (f64::from(format.width), f64::from(format.height));
        match &self.exact {
            Some(e) => {
                let (scale_x, scale_y) = (e.resolution.0 / fw, e.resolution.1 / fh);
                let (out_shift, cal_shift) = (conv.shift(), e.convention.shift());
                answer(py, px.rows(), 3, |start, d, v| {
                    for i in 0..v.len() {
                        let raster = [px.get(start + i, 0) - out_shift, px.get(start + i, 1) - out_shift];
                        let model_px = [raster[0] * scale_x + cal_shift, raster[1] * scale_y + cal_shift];
                        let Some(r) = e.model.pixel_to_ray(model_px) else {
                            continue;
                        };
                        let len = (r.v[0] * r.v[0] + r.v[1] * r.v[1] + r.v[2] * r.v[2]).sqrt();
                        // The model's camera space is OpenCV's (+Y down).
                        let u = [r.v[0] / len, -r.v[1] / len * sy, r.v[2] / len];
                        if u.iter().all(|x| x.is_finite()) {
                            for c in 0..3 {
                                d[3 * i + c] = T::from_f64(u[c]);
                            }
                            v[i] = true;
                        }
                    }
                })
            }
            None => {
                let cam = self.stage.camera();
                let shift = conv.shift();
                answer(py, px.rows(), 3, |start, d, v| {
                    let mut b = Batch::with_capacity(v.len());
                    for i in 0..v.len() {
                        let s =
                            cam.raster_to_screen(px.get(start + i, 0) - shift, px.get(start + i, 1) - shift);
                        b.push(s, Point2::new(0.5, 0.5), 0.0);
                        b.aperture.push(Point2::ZERO);
                    }
                    self.stage.run_prepared(&mut b);
                    for (i, r) in b.rays.iter().enumerate() {
                        d[3 * i] = T::from_f32(r.direction.x);
                        d[3 * i + 1] = T::from_f64(f64::from(r.direction.y) * sy);
                        d[3 * i + 2] = T::from_f32(r.direction.z);
                        v[i] = r.direction != Vec3::ZERO;
                    }
                })
            }
        }
    }

    fn ray_to_pixel_typed<'py, T: Real>(
        &self,
        py: Python<'py>,
        n: usize,
        point: impl Fn(usize) -> [f64; 3] + Send + Sync,
        conv: PixelConvention,
    ) -> PyResult<Answer<'py, T>> {
        let format = self.stage.camera().format;
        let window = self.stage.camera().screen_window();
        let (fw, fh) = (f64::from(format.width), f64::from(format.height));
        let out_shift = conv.shift();
        let exact = self.exact.as_ref();
        let projection = self.stage.projection();
        answer(py, n, 2, |start, p, v| {
            for i in 0..v.len() {
                let q = point(start + i);
                let raster = match exact {
                    Some(e) => e.model.ray_to_pixel([q[0], -q[1], q[2]]).map(|m| {
                        let s = e.convention.shift();
                        [(m[0] - s) * fw / e.resolution.0, (m[1] - s) * fh / e.resolution.1]
                    }),
                    None => projection
                        .unproject(Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32), 0.0)
                        .filter(|s| s.x.is_finite() && s.y.is_finite())
                        .map(|s| {
                            let (x, y) = window.screen_to_raster(format, s);
                            [x, y]
                        }),
                };
                let (x, y) = match raster {
                    Some(r) => {
                        v[i] = true;
                        (r[0] + out_shift, r[1] + out_shift)
                    }
                    None => (f64::NAN, f64::NAN),
                };
                p[2 * i] = T::from_f64(x);
                p[2 * i + 1] = T::from_f64(y);
            }
        })
    }
}
