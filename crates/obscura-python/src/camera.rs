//! `obscura.Camera`: a projection (built-in, plugin or calibration) with the camera options of RIB
//! (`Format`, `ScreenWindow`, `CropWindow`, `Clipping`, `Shutter`, the aperture and shutter-opening
//! options, the world-to-camera transform with motion), ready to turn numpy arrays into rays.

use std::collections::HashMap;
use std::path::PathBuf;

use obscura_calibration::{CameraModel, PixelConvention, model_info};
use obscura_host::aperture::ApertureDesc;
use obscura_host::shutter::ShutterDesc;
use obscura_host::{CameraDesc, CameraStage, CropWindow};
use obscura_render::job::{CALIBRATED, Calibrated, merge_params};
use obscura_sdk::{
    DeepMetric, DicingHint, Format, Matrix4, MotionSample, ParamDecl, ParamList, ParamValue, ScreenWindow,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyType};

use crate::params::{Raw, read_params};
use crate::registry::{registry, resolve};

/// The f64 model of a calibrated camera, for `pixel_to_ray`/`ray_to_pixel` to 1e-6 px: built from the
/// parameters as given (Python floats, a file's text), not from the projection's f32 copies.
pub struct Exact {
    /// The model.
    pub model: CameraModel,
    /// The convention of its pixel coordinates.
    pub convention: PixelConvention,
    /// The calibration image's size.
    pub resolution: (f64, f64),
}

/// A camera: a projection with its parameters and the camera options.
///
/// `Camera(projection, format=(w, h), **params)` makes one from a projection's name (a built-in, a
/// plugin along the plugin path, or a plugin file's path) with its parameters as keyword arguments,
/// named, typed and range-checked exactly as `obscura --param` does. Keyword-only camera options:
/// `format`, `pixel_aspect`, `screen_window` (l, r, b, t), `crop` (xmin, xmax, ymin, ymax, NDC),
/// `clipping` (near, far), `shutter` (open, close), `aperture_sides`, `aperture_angle`,
/// `aperture_roundness`, `aperture_density`, `dof_aspect`, `shutter_open_time`, `shutter_close_time`,
/// `shutter_opening` (8 values), `world_to_camera` (a 4×4 matrix in RenderMan's row-vector
/// convention, or a list of (time, matrix) motion samples).
#[pyclass(frozen, module = "obscura")]
pub struct Camera {
    pub(crate) stage: CameraStage,
    pub(crate) params: ParamList,
    pub(crate) exact: Option<Exact>,
    pub(crate) calibration: Option<String>,
}

/// Camera options, as keyword arguments.
#[derive(Default)]
struct Options {
    format: Option<(u32, u32)>,
    pixel_aspect: Option<f32>,
    screen_window: Option<(f32, f32, f32, f32)>,
    crop: Option<(f32, f32, f32, f32)>,
    clipping: Option<(f32, f32)>,
    shutter: Option<(f32, f32)>,
    aperture_sides: Option<i32>,
    aperture_angle: Option<f32>,
    aperture_roundness: Option<f32>,
    aperture_density: Option<f32>,
    dof_aspect: Option<f32>,
    shutter_open_time: Option<f32>,
    shutter_close_time: Option<f32>,
    shutter_opening: Option<[f32; 8]>,
    world_to_camera: Option<Vec<MotionSample>>,
}

fn option<'py, T: for<'a> FromPyObject<'a, 'py>>(
    kwargs: &Bound<'py, PyDict>,
    name: &str,
    expected: &str,
) -> PyResult<Option<T>> {
    match kwargs.get_item(name)? {
        None => Ok(None),
        Some(v) if v.is_none() => {
            kwargs.del_item(name)?;
            Ok(None)
        }
        Some(v) => {
            let r = v.extract::<T>().map_err(|_| {
                let ty = v.get_type().name().map(|n| n.to_string()).unwrap_or_default();
                PyTypeError::new_err(format!(
                    "{name}: expected {expected}, got {ty} {}",
                    v.repr().map(|r| r.to_string()).unwrap_or_default()
                ))
            })?;
            kwargs.del_item(name)?;
            Ok(Some(r))
        }
    }
}

/// A camera option of `N` numbers, given as any sequence (tuple, list, array).
fn tuple<'py, T, const N: usize>(
    kwargs: &Bound<'py, PyDict>,
    name: &str,
    expected: &str,
) -> PyResult<Option<[T; N]>>
where
    T: for<'a> FromPyObject<'a, 'py> + Copy,
{
    let v: Option<Vec<T>> = option(kwargs, name, expected)?;
    v.map(|v| {
        <[T; N]>::try_from(v.as_slice()).map_err(|_| {
            PyValueError::new_err(format!("{name}: expected {expected}, got {} values", v.len()))
        })
    })
    .transpose()
}

impl Options {
    /// Removes the camera options from `kwargs` and reads them.
    fn take(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Options> {
        let Some(k) = kwargs else {
            return Ok(Options::default());
        };
        let format = tuple::<i64, 2>(k, "format", "(width, height) in pixels")?;
        let format = format
            .map(|[w, h]| match (u32::try_from(w), u32::try_from(h)) {
                (Ok(w), Ok(h)) if w > 0 && h > 0 => Ok((w, h)),
                _ => Err(PyValueError::new_err(format!(
                    "format=({w}, {h}): expected (width, height) with positive integers, e.g. (640, 480)"
                ))),
            })
            .transpose()?;
        let motion = match k.get_item("world_to_camera")? {
            None => None,
            Some(v) if v.is_none() => None,
            Some(v) => Some(read_motion(&v)?),
        };
        if motion.is_some() {
            k.del_item("world_to_camera")?;
        }
        let opening: Option<Vec<f32>> = option(k, "shutter_opening", "eight floats c1 c2 d1 d2 e1 e2 f1 f2")?;
        let shutter_opening = opening
            .map(|v| {
                <[f32; 8]>::try_from(v.as_slice()).map_err(|_| {
                    PyValueError::new_err(format!(
                        "shutter_opening: expected eight values c1 c2 d1 d2 e1 e2 f1 f2, got {}",
                        v.len()
                    ))
                })
            })
            .transpose()?;
        Ok(Options {
            format,
            pixel_aspect: option(k, "pixel_aspect", "a float")?,
            screen_window: tuple::<f32, 4>(k, "screen_window", "(left, right, bottom, top)")?
                .map(|[l, r, b, t]| (l, r, b, t)),
            crop: tuple::<f32, 4>(k, "crop", "(xmin, xmax, ymin, ymax) in NDC")?
                .map(|[a, b, c, d]| (a, b, c, d)),
            clipping: tuple::<f32, 2>(k, "clipping", "(near, far)")?.map(|[n, f]| (n, f)),
            shutter: tuple::<f32, 2>(k, "shutter", "(open, close)")?.map(|[o, c]| (o, c)),
            aperture_sides: option(k, "aperture_sides", "an int")?,
            aperture_angle: option(k, "aperture_angle", "a float (degrees)")?,
            aperture_roundness: option(k, "aperture_roundness", "a float in [-1, 1]")?,
            aperture_density: option(k, "aperture_density", "a float in [-1, 1]")?,
            dof_aspect: option(k, "dof_aspect", "a float > 0")?,
            shutter_open_time: option(k, "shutter_open_time", "a float in [0, 1]")?,
            shutter_close_time: option(k, "shutter_close_time", "a float in [0, 1]")?,
            shutter_opening,
            world_to_camera: motion,
        })
    }

    /// The camera description, with `default_format` when no `format` was given.
    fn describe(&self, default_format: (u32, u32)) -> CameraDesc {
        let (width, height) = self.format.unwrap_or(default_format);
        let mut cam = CameraDesc::new(Format {
            width,
            height,
            pixel_aspect: self.pixel_aspect.unwrap_or(1.0),
        });
        cam.screen_window = self
            .screen_window
            .map(|(l, r, b, t)| ScreenWindow::new(l, r, b, t));
        if let Some((x_min, x_max, y_min, y_max)) = self.crop {
            cam.crop_window = CropWindow {
                x_min,
                x_max,
                y_min,
                y_max,
            };
        }
        if let Some(s) = self.shutter {
            cam.shutter = s;
        }
        if let Some(c) = self.clipping {
            cam.clipping = c;
        }
        let ad = ApertureDesc::default();
        cam.aperture = ApertureDesc {
            n_sides: self.aperture_sides.unwrap_or(ad.n_sides),
            angle_deg: self.aperture_angle.unwrap_or(ad.angle_deg),
            roundness: self.aperture_roundness.unwrap_or(ad.roundness),
            density: self.aperture_density.unwrap_or(ad.density),
            dof_aspect: self.dof_aspect.unwrap_or(ad.dof_aspect),
        };
        let sd = ShutterDesc::default();
        cam.shutter_opening = ShutterDesc {
            open_time: self.shutter_open_time.unwrap_or(sd.open_time),
            close_time: self.shutter_close_time.unwrap_or(sd.close_time),
            opening: self.shutter_opening.unwrap_or(sd.opening),
        };
        if let Some(m) = &self.world_to_camera {
            cam.world_to_camera = m.clone();
        }
        cam
    }
}

/// A 4×4 matrix (nested or flat 16 values), row-major, RenderMan's row-vector convention.
fn read_matrix(v: &Bound<'_, PyAny>) -> PyResult<Matrix4> {
    let flat: Vec<f32> = match v.extract::<Vec<Vec<f32>>>() {
        Ok(rows) if rows.len() == 4 && rows.iter().all(|r| r.len() == 4) => rows.concat(),
        _ => v.extract::<Vec<f32>>().map_err(|_| {
            PyTypeError::new_err("world_to_camera: expected a 4×4 matrix (nested sequences or 16 floats)")
        })?,
    };
    if flat.len() != 16 || flat.iter().any(|x| !x.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "world_to_camera: expected 16 finite values of a 4×4 matrix, got {}",
            flat.len()
        )));
    }
    Ok(Matrix4(std::array::from_fn(|r| {
        std::array::from_fn(|c| flat[4 * r + c])
    })))
}

/// `world_to_camera`: one matrix (time 0), or a list of (time, matrix) motion samples.
fn read_motion(v: &Bound<'_, PyAny>) -> PyResult<Vec<MotionSample>> {
    if let Ok(m) = read_matrix(v) {
        return Ok(vec![MotionSample {
            time: 0.0,
            world_to_camera: m,
        }]);
    }
    let items: Vec<Bound<'_, PyAny>> = v.extract().map_err(|_| {
        PyTypeError::new_err("world_to_camera: expected a 4×4 matrix or a list of (time, 4×4 matrix) samples")
    })?;
    items
        .iter()
        .map(|item| {
            let (t, m): (f32, Bound<'_, PyAny>) = item.extract().map_err(|_| {
                PyTypeError::new_err("world_to_camera: each motion sample must be (time, 4×4 matrix)")
            })?;
            Ok(MotionSample {
                time: t,
                world_to_camera: read_matrix(&m)?,
            })
        })
        .collect()
}

fn table_default(table: &[ParamDecl], name: &str) -> Option<Raw> {
    let d = table.iter().find(|d| d.name == name)?;
    Some(match &d.default {
        ParamValue::Floats(v) => Raw::Numbers(v.iter().map(|&x| f64::from(x)).collect()),
        ParamValue::Ints(v) => Raw::Numbers(v.iter().map(|&x| f64::from(x)).collect()),
        ParamValue::Strings(v) => Raw::Strings(v.clone()),
    })
}

/// The f64 model of a `CalibratedCamera` from its parameters as given (`raw`), else the table's
/// defaults.
fn exact_model(table: &[ParamDecl], raw: &HashMap<String, Raw>) -> PyResult<Exact> {
    let get = |name: &str| raw.get(name).cloned().or_else(|| table_default(table, name));
    let numbers = |name: &str| match get(name) {
        Some(Raw::Numbers(v)) => v,
        _ => Vec::new(),
    };
    let string = |name: &str| match get(name) {
        Some(Raw::Strings(v)) => v.into_iter().next().unwrap_or_default(),
        _ => String::new(),
    };
    let model = string("model");
    let res = numbers("resolution");
    let (w, h) = match res.as_slice() {
        [w, h] => (*w, *h),
        _ => {
            return Err(PyValueError::new_err(
                "CalibratedCamera: resolution must be (width, height)",
            ));
        }
    };
    let m = CameraModel::new(
        &model,
        &numbers("params"),
        &numbers("polynomial"),
        &numbers("inversePolynomial"),
        w,
        h,
    )
    .map_err(|e| PyValueError::new_err(format!("CalibratedCamera: {e}")))?;
    let convention = match string("pixelConvention").as_str() {
        "colmap" => PixelConvention::Colmap,
        "opencv" => PixelConvention::OpenCv,
        "matlab" => PixelConvention::Matlab,
        _ => model_info(&model).map_or(PixelConvention::Colmap, |i| i.convention),
    };
    Ok(Exact {
        model: m,
        convention,
        resolution: (w, h),
    })
}

impl Camera {
    /// Builds the stage for `projection` with `base` parameters (a calibration's), the keyword
    /// arguments' parameters over them, and the options.
    fn build(
        projection: &str,
        base: Option<(&Calibrated, HashMap<String, Raw>)>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Camera> {
        let options = Options::take(kwargs)?;
        let mut reg = registry()?;
        let name = resolve(&mut reg, projection)?;
        let factory = reg
            .find(&name)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let table = factory.param_table().to_vec();
        let (extra, given) = read_params(&name, &table, kwargs)?;
        let (mut params, mut raw) = match &base {
            Some((c, raw)) => (c.params.clone(), raw.clone()),
            None => (ParamList::new(), HashMap::new()),
        };
        merge_params(&mut params, &extra).map_err(|e| PyValueError::new_err(e.to_string()))?;
        raw.extend(given);
        let exact = (name == CALIBRATED)
            .then(|| exact_model(&table, &raw))
            .transpose()?;
        let default_format = match &exact {
            Some(e) => (e.resolution.0 as u32, e.resolution.1 as u32),
            None => (640, 480),
        };
        let desc = options.describe(default_format);
        let stage = CameraStage::new(&mut reg, &name, &params, &desc)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Camera {
            stage,
            params,
            exact,
            calibration: base.map(|(c, _)| c.calibration.summary()),
        })
    }
}

fn hint_name(h: DicingHint) -> &'static str {
    match h {
        DicingHint::Orthographic => "orthographic",
        DicingHint::Perspective => "perspective",
        DicingHint::Spherical => "spherical",
    }
}

#[pymethods]
impl Camera {
    #[new]
    #[pyo3(signature = (projection = "PxrPerspective", **kwargs))]
    fn new(projection: &str, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let kwargs = kwargs.map(|k| k.copy()).transpose()?;
        Camera::build(projection, None, kwargs.as_ref())
    }

    /// A camera from a calibration file the CLI reads (COLMAP `cameras.txt`, OpenCV YAML/JSON,
    /// Kalibr `camchain.yaml`, OCamCalib `calib_results.txt`, a Nuke script with 3DEqualizer's
    /// `LD_3DE*` nodes, a 3DE lens export): `camera` picks one of several (a COLMAP CAMERA_ID,
    /// Kalibr's `cam0`, an LD node's name; default the first); `frame` evaluates a Nuke script's
    /// animated knobs at that frame (default: the script's current frame). The format defaults to
    /// the calibration's size; keyword arguments are camera options or `CalibratedCamera`
    /// parameters replacing the file's.
    #[classmethod]
    #[pyo3(signature = (path, camera = None, frame = None, **kwargs))]
    fn from_calibration(
        _cls: &Bound<'_, PyType>,
        path: PathBuf,
        camera: Option<&Bound<'_, PyAny>>,
        frame: Option<f64>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let camera = camera.map(|c| c.str().map(|s| s.to_string())).transpose()?;
        let c = Calibrated::load_frame(&path, camera.as_deref(), frame)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let cal = &c.calibration;
        let nums =
            |v: &[obscura_calibration::files::Number]| Raw::Numbers(v.iter().map(|n| n.value).collect());
        let mut raw = HashMap::new();
        raw.insert("model".to_string(), Raw::Strings(vec![cal.model.clone()]));
        raw.insert("params".to_string(), nums(&cal.params));
        raw.insert("polynomial".to_string(), nums(&cal.polynomial));
        raw.insert("inversePolynomial".to_string(), nums(&cal.inverse_polynomial));
        raw.insert(
            "resolution".to_string(),
            Raw::Numbers(vec![f64::from(cal.width), f64::from(cal.height)]),
        );
        raw.insert(
            "pixelConvention".to_string(),
            Raw::Strings(vec![cal.pixel_convention.name().to_string()]),
        );
        let kwargs = kwargs.map(|k| k.copy()).transpose()?;
        Camera::build(CALIBRATED, Some((&c, raw)), kwargs.as_ref())
    }

    /// The projection's name.
    #[getter]
    fn projection(&self) -> &str {
        self.stage.name()
    }

    /// (width, height) in pixels.
    #[getter]
    fn format(&self) -> (u32, u32) {
        let f = self.stage.camera().format;
        (f.width, f.height)
    }

    /// (left, right, bottom, top) of the screen window in force.
    #[getter]
    fn screen_window(&self) -> (f32, f32, f32, f32) {
        let w = self.stage.camera().screen_window();
        (w.left, w.right, w.bottom, w.top)
    }

    /// The pixels `rays()` covers (the crop): (x0, x1, y0, y1), end exclusive.
    #[getter]
    fn pixels(&self) -> (u32, u32, u32, u32) {
        let p = self.stage.camera().pixels();
        (p.x0, p.x1, p.y0, p.y1)
    }

    /// The field of view in degrees (the `FieldOfView` property), or None when not answered.
    #[getter]
    fn fov(&self) -> Option<f32> {
        self.stage.properties().field_of_view
    }

    /// `"perspective"`, `"orthographic"` or `"spherical"` (the `DicingHint` property).
    #[getter]
    fn dicing_hint(&self) -> &'static str {
        hint_name(self.stage.properties().dicing_hint)
    }

    /// `"CameraZ"` or `"RayLength"` (the `DeepMetric` property): how depth is measured.
    #[getter]
    fn deep_metric(&self) -> &'static str {
        match self.stage.properties().deep_metric {
            DeepMetric::CameraZ => "CameraZ",
            DeepMetric::RayLength => "RayLength",
        }
    }

    /// The f-stop (`FStop` property), or None.
    #[getter]
    fn fstop(&self) -> Option<f32> {
        self.stage.properties().f_stop
    }

    /// The focal length (`FocalLength` property), or None.
    #[getter]
    fn focal_length(&self) -> Option<f32> {
        self.stage.properties().focal_length
    }

    /// The focal distance (`FocalDistance` property), or None.
    #[getter]
    fn focal_distance(&self) -> Option<f32> {
        self.stage.properties().focal_distance
    }

    /// (near, far) clipping.
    #[getter]
    fn clipping(&self) -> (f32, f32) {
        self.stage.camera().clipping
    }

    /// (open, close) shutter times.
    #[getter]
    fn shutter(&self) -> (f32, f32) {
        self.stage.camera().shutter
    }

    /// The calibrated model's name (`"OPENCV"`, …), or None for other projections.
    #[getter]
    fn model(&self) -> Option<&'static str> {
        self.exact.as_ref().map(|e| e.model.info().name)
    }

    /// The pixel convention `pixel_to_ray`/`ray_to_pixel` use by default: the calibration's own
    /// (`"colmap"` or `"opencv"`), `"colmap"` (Obscura's raster) for other cameras.
    #[getter]
    fn pixel_convention(&self) -> &'static str {
        self.exact
            .as_ref()
            .map_or(PixelConvention::Colmap, |e| e.convention)
            .name()
    }

    /// Where the camera came from: the calibration file and line, or None.
    #[getter]
    fn calibration(&self) -> Option<String> {
        self.calibration.clone()
    }

    /// The projection's parameters as given, as a dict of name → value.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for e in self.params.entries() {
            match &e.value {
                ParamValue::Floats(v) if v.len() == 1 => d.set_item(&e.name, v[0])?,
                ParamValue::Ints(v) if v.len() == 1 => d.set_item(&e.name, v[0])?,
                ParamValue::Strings(v) if v.len() == 1 => d.set_item(&e.name, &v[0])?,
                ParamValue::Floats(v) => d.set_item(&e.name, v.clone())?,
                ParamValue::Ints(v) => d.set_item(&e.name, v.clone())?,
                ParamValue::Strings(v) => d.set_item(&e.name, v.clone())?,
            }
        }
        Ok(d)
    }

    /// Warnings from setting the camera up (a property answered with the wrong type, …).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.stage.setup_warnings().to_vec()
    }

    fn __repr__(&self) -> String {
        let (w, h) = self.format();
        match &self.exact {
            Some(e) => format!(
                "Camera(CalibratedCamera {}, format=({w}, {h}))",
                e.model.info().name
            ),
            None => format!("Camera({:?}, format=({w}, {h}))", self.stage.name()),
        }
    }
}
