//! Calibration files in: COLMAP `cameras.txt`, OpenCV calibration YAML/JSON, Kalibr `camchain.yaml`
//! and OCamCalib `calib_results.txt`, each read into a [`Calibration`]: the model's name, its
//! parameters in the source library's order, the calibration image size and pixel convention, ready
//! as the `CalibratedCamera` projection's [`ParamList`].
//!
//! | file | how it is recognised | model | `pixelConvention` |
//! |---|---|---|---|
//! | COLMAP `cameras.txt` | text lines `CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]` | the line's model, verbatim | `colmap` (top-left pixel centre at (0.5, 0.5)) |
//! | OpenCV YAML / JSON | a mapping with `camera_matrix` | `OPENCV_PINHOLE` (0, 4, 5, 8, 12 or 14 coefficients); `OPENCV_FISHEYE` when `fisheye_model` is set | `opencv` (pixel centres at integers) |
//! | Kalibr `camchain.yaml` | a mapping of cameras with `camera_model` | see [`kalibr`] | `opencv` |
//! | OCamCalib `calib_results.txt` | text lines of numbers | `OCAMCALIB` | `opencv` |
//! | 3DEqualizer lens export text | the fourth line names a 3DE model, `<end_of_file>` follows | that model, see [`tde4`] | `colmap` |
//! | Nuke script (`.nk`) with 3DE lens nodes | a node `LD_3DE4_…`, `LD_3DE_Classic_LD_Model` or `tde4_ldp_…` | the node's 3DE model, see [`nuke`] | `colmap` (3DE's unit coordinates are corner-based) |
//!
//! Values keep the file's text: each number reaches the projection as written (it is held there as
//! `f32`). Every error names the file, the line and the field, and what was expected.

use std::fmt;
use std::path::Path;

use obscura_sdk::ParamList;

use tree::{Node, Value};

pub mod colmap;
pub mod kalibr;
pub mod nuke;
pub mod ocamcalib;
pub mod opencv;
pub mod tde4;
mod tree;

/// The projection a [`Calibration`]'s parameters are for.
pub const PROJECTION: &str = crate::NAME;

/// A calibration file could not be read: the file, the line (when one is to blame) and what was
/// expected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct CalibrationFileError {
    /// The file as named by the caller.
    pub file: String,
    /// The 1-based line, when one line is to blame.
    pub line: Option<usize>,
    /// What is wrong and what was expected, naming the field.
    pub message: String,
}

/// The kinds of calibration file read here.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FileFormat {
    /// COLMAP's `cameras.txt`.
    Colmap,
    /// OpenCV's calibration output (FileStorage YAML or JSON), also ROS `camera_info` YAML.
    OpenCv,
    /// Kalibr's `camchain.yaml` (or a single-camera `camera.yaml` of the same layout).
    Kalibr,
    /// OCamCalib's `calib_results.txt`.
    OCamCalib,
    /// A Nuke script with 3DEqualizer's lens-distortion nodes (`LD_3DE4_*`, see [`nuke`]).
    Nuke,
    /// 3DEqualizer's lens export text (see [`tde4`]).
    Tde4Lens,
}

impl fmt::Display for FileFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FileFormat::Colmap => "COLMAP cameras.txt",
            FileFormat::OpenCv => "OpenCV calibration",
            FileFormat::Kalibr => "Kalibr camchain",
            FileFormat::OCamCalib => "OCamCalib calib_results",
            FileFormat::Nuke => "Nuke script with 3DE lens nodes",
            FileFormat::Tde4Lens => "3DEqualizer lens export",
        })
    }
}

pub use crate::models::PixelConvention;

/// One number as the file wrote it.
#[derive(Debug, Clone, PartialEq)]
pub struct Number {
    /// The text, as written.
    pub text: String,
    /// Its value.
    pub value: f64,
    /// 1-based line.
    pub line: usize,
}

/// One camera read from a calibration file.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// The file as named by the caller.
    pub file: String,
    /// Which kind of file it was.
    pub format: FileFormat,
    /// The camera's id in the file (COLMAP's `CAMERA_ID`, Kalibr's `cam0`); `None` for files that
    /// hold one camera only (OpenCV, OCamCalib).
    pub camera: Option<String>,
    /// Every camera id in the file, in file order (empty for single-camera files).
    pub cameras: Vec<String>,
    /// True when the file holds several cameras and none was asked for, so the first was taken.
    pub first_by_default: bool,
    /// Calibration image width in pixels.
    pub width: u32,
    /// Calibration image height in pixels.
    pub height: u32,
    /// The model, as `CalibratedCamera`'s `model` names it (COLMAP names verbatim, `OPENCV_PINHOLE`,
    /// `OPENCV_OMNIDIR`, `DOUBLE_SPHERE`, `OCAMCALIB`, …).
    pub model: String,
    /// The scalar parameters in the source library's order (`params`).
    pub params: Vec<Number>,
    /// OCamCalib's `pol` coefficients a0..aN (`polynomial`); empty for other models.
    pub polynomial: Vec<Number>,
    /// OCamCalib's `invpol` coefficients (`inversePolynomial`); empty for other models.
    pub inverse_polynomial: Vec<Number>,
    /// Where pixel centres lie in the file's coordinates.
    pub pixel_convention: PixelConvention,
    /// `file:line` of the camera's entry.
    pub source: String,
    /// What was ignored or assumed while reading (extrinsics, a converted parameter order), one
    /// sentence each.
    pub notes: Vec<String>,
    /// True when some parameter follows a curve over frames (a Nuke script's animated knob): the
    /// values are those of the frame asked for, and other frames differ.
    pub animated: bool,
}

impl Calibration {
    /// The parameters for the [`PROJECTION`]: `string model`, `float[] params`, `float[] polynomial`
    /// and `float[] inversePolynomial` (OCamCalib only), `int[2] resolution` (width height),
    /// `string pixelConvention`; each entry's origin is the `file:line` it came from.
    ///
    /// # Errors
    /// A [`CalibrationFileError`] when a number does not fit an `f32` (read as ±∞ there).
    pub fn param_list(&self) -> Result<ParamList, CalibrationFileError> {
        let mut list = ParamList::new();
        let at = |line: usize| Some(format!("{}:{line}", self.file));
        let entry_line = self.params.first().map_or(1, |n| n.line);
        let err = |line: usize, e: obscura_sdk::DeclarationError| CalibrationFileError {
            file: self.file.clone(),
            line: Some(line),
            message: e.to_string(),
        };
        list.push_text("string model", &[self.model.as_str()], Some(self.source.clone()))
            .map_err(|e| err(entry_line, e))?;
        for (decl, numbers) in [
            ("float[] params", &self.params),
            ("float[] polynomial", &self.polynomial),
            ("float[] inversePolynomial", &self.inverse_polynomial),
        ] {
            if numbers.is_empty() {
                continue;
            }
            let texts: Vec<&str> = numbers.iter().map(|n| n.text.as_str()).collect();
            list.push_text(decl, &texts, at(numbers[0].line))
                .map_err(|e| err(numbers[0].line, e))?;
        }
        let size = [
            i32::try_from(self.width).unwrap_or(i32::MAX),
            i32::try_from(self.height).unwrap_or(i32::MAX),
        ];
        list.push(
            "int[2] resolution",
            obscura_sdk::ParamValue::Ints(size.to_vec()),
            Some(self.source.clone()),
        )
        .map_err(|e| err(entry_line, e))?;
        list.push_text(
            "string pixelConvention",
            &[self.pixel_convention.name()],
            Some(self.source.clone()),
        )
        .map_err(|e| err(entry_line, e))?;
        // The values themselves (a focal length ≤ 0, ξ out of range, …) are checked here, where the
        // line they came from is known, exactly as the projection will check them (f32 as stored).
        let values =
            |numbers: &[Number]| -> Vec<f64> { numbers.iter().map(|n| f64::from(n.value as f32)).collect() };
        crate::models::CameraModel::new(
            &self.model,
            &values(&self.params),
            &values(&self.polynomial),
            &values(&self.inverse_polynomial),
            f64::from(self.width),
            f64::from(self.height),
        )
        .map_err(|message| {
            // A complaint about the direct polynomial is about its line (OCamCalib's `pol` line),
            // not the camera's first parameter.
            // A complaint naming one parameter (`… Squeeze-X must be > 0`) is about its line.
            let named = crate::models::model_info(&self.model).and_then(|info| {
                info.params
                    .split(", ")
                    .position(|name| message.contains(&format!(": {name} must")))
                    .and_then(|i| self.params.get(i))
                    .map(|n| n.line)
            });
            let line = match self.polynomial.first() {
                Some(first) if message.contains("pol's") => first.line,
                _ => named.unwrap_or(entry_line),
            };
            CalibrationFileError {
                file: self.file.clone(),
                line: Some(line),
                message,
            }
        })?;
        Ok(list)
    }

    /// One line for a user: `camera 2 (OPENCV 640x480) of cameras.txt (COLMAP cameras.txt)`.
    #[must_use]
    pub fn summary(&self) -> String {
        let which = self
            .camera
            .as_ref()
            .map(|c| format!("camera {c} "))
            .unwrap_or_default();
        format!(
            "{which}({} {}x{}) of {} ({})",
            self.model, self.width, self.height, self.file, self.format
        )
    }

    /// When several cameras were in the file and none was asked for: which one was taken and how to
    /// choose another.
    #[must_use]
    pub fn selection_note(&self) -> Option<String> {
        let camera = self.camera.as_ref()?;
        self.first_by_default.then(|| {
            format!(
                "{} holds {} cameras ({}); using the first, {camera} (choose with --camera)",
                self.file,
                self.cameras.len(),
                self.cameras.join(", ")
            )
        })
    }
}

/// The file being read, for errors.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Src<'a> {
    pub file: &'a str,
}

impl Src<'_> {
    /// An error at `line`.
    pub fn err(&self, line: usize, message: impl Into<String>) -> CalibrationFileError {
        CalibrationFileError {
            file: self.file.to_string(),
            line: Some(line),
            message: message.into(),
        }
    }

    /// An error about the whole file.
    pub fn whole(&self, message: impl Into<String>) -> CalibrationFileError {
        CalibrationFileError {
            file: self.file.to_string(),
            line: None,
            message: message.into(),
        }
    }

    /// Reads `text` as a finite number that fits an `f32`; `what` names the field.
    pub fn number(&self, text: &str, line: usize, what: &str) -> Result<Number, CalibrationFileError> {
        let t = text.trim();
        let value = t
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.err(line, format!("{what}: expected a finite number, got \"{t}\"")))?;
        if value.abs() > f64::from(f32::MAX) {
            return Err(self.err(line, format!("{what}: {t} is beyond the range of a 32-bit float")));
        }
        Ok(Number {
            text: t.to_string(),
            value,
            line,
        })
    }

    /// Reads a list's `items` as numbers; `what` names the list (items are `what[i]`).
    pub fn numbers(&self, items: &[Node], what: &str) -> Result<Vec<Number>, CalibrationFileError> {
        items
            .iter()
            .enumerate()
            .map(|(i, n)| match &n.value {
                Value::Scalar { text, quoted: false } => self.number(text, n.line, &format!("{what}[{i}]")),
                _ => Err(self.err(
                    n.line,
                    format!("{what}[{i}]: expected a number, got {}", n.describe()),
                )),
            })
            .collect()
    }

    /// The camera read from this file, its entry at `line`: a single camera of `format`'s own pixel
    /// convention, without polynomials or notes; readers of files that differ set those fields.
    pub fn calibration(
        &self,
        format: FileFormat,
        line: usize,
        model: &str,
        [width, height]: [u32; 2],
        params: Vec<Number>,
    ) -> Calibration {
        Calibration {
            file: self.file.to_string(),
            format,
            camera: None,
            cameras: Vec::new(),
            first_by_default: false,
            width,
            height,
            model: model.to_string(),
            params,
            polynomial: Vec::new(),
            inverse_polynomial: Vec::new(),
            pixel_convention: match format {
                FileFormat::Colmap | FileFormat::Nuke | FileFormat::Tde4Lens => PixelConvention::Colmap,
                FileFormat::OpenCv | FileFormat::Kalibr | FileFormat::OCamCalib => PixelConvention::OpenCv,
            },
            source: format!("{}:{line}", self.file),
            notes: Vec::new(),
            animated: false,
        }
    }

    /// Reads `text` as an image size in pixels (a positive integer); `what` names the field.
    pub fn size(&self, text: &str, line: usize, what: &str) -> Result<u32, CalibrationFileError> {
        let t = text.trim();
        // OpenCV and Kalibr write integers; accept `640.` or `640.0` too, but nothing fractional.
        let v = t.parse::<u32>().ok().or_else(|| {
            t.parse::<f64>()
                .ok()
                .filter(|v| v.fract() == 0.0 && *v >= 0.0 && *v <= f64::from(u32::MAX))
                .map(|v| v as u32)
        });
        match v {
            Some(v) if v > 0 && v <= i32::MAX as u32 => Ok(v),
            _ => Err(self.err(
                line,
                format!("{what}: expected a positive whole number of pixels, got \"{t}\""),
            )),
        }
    }
}

/// Picks `wanted` among `ids` (file order), or the first when none is wanted.
///
/// Returns the index and whether it was taken by default. Ids compare as text, or as integers when
/// both are (COLMAP's `--camera 01` is camera 1).
pub(crate) fn choose_camera(
    src: &Src<'_>,
    kind: &str,
    ids: &[String],
    wanted: Option<&str>,
) -> Result<(usize, bool), CalibrationFileError> {
    if ids.is_empty() {
        return Err(src.whole(format!("no camera found in this {kind}")));
    }
    let Some(w) = wanted else {
        return Ok((0, ids.len() > 1));
    };
    let same = |id: &str| {
        id == w || matches!((id.parse::<u64>(), w.trim().parse::<u64>()), (Ok(a), Ok(b)) if a == b)
    };
    ids.iter()
        .position(|id| same(id))
        .map(|i| (i, false))
        .ok_or_else(|| {
            src.whole(format!(
                "no camera \"{w}\" in this {kind}; its cameras are: {}",
                ids.join(", ")
            ))
        })
}

/// Reads the calibration file at `path`, choosing `camera` (an id or name) in files holding several.
/// The kind of file is recognised from its extension and content.
///
/// # Errors
/// A [`CalibrationFileError`] naming the file (and the line and field where one is to blame): the file
/// cannot be read, is of no known kind, is malformed, or holds no camera `camera` (the error lists the
/// ids it holds).
pub fn load(path: &Path, camera: Option<&str>) -> Result<Calibration, CalibrationFileError> {
    load_frame(path, camera, None)
}

/// [`load`] with animated parameters (a Nuke script's curves) evaluated at `frame` (`None`: the
/// file's own current frame).
///
/// # Errors
/// As [`load`].
pub fn load_frame(
    path: &Path,
    camera: Option<&str>,
    frame: Option<f64>,
) -> Result<Calibration, CalibrationFileError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| CalibrationFileError {
        file: name.clone(),
        line: None,
        message: format!("cannot read the calibration file: {e}"),
    })?;
    parse_frame(&text, &name, camera, frame)
}

/// Reads calibration `text` from the file named `file` (the name's extension and the content tell the
/// kind), choosing `camera` as [`load`] does.
///
/// # Errors
/// As [`load`].
pub fn parse(text: &str, file: &str, camera: Option<&str>) -> Result<Calibration, CalibrationFileError> {
    parse_frame(text, file, camera, None)
}

/// [`parse`] with animated parameters evaluated at `frame`, as [`load_frame`].
///
/// # Errors
/// As [`load`].
pub fn parse_frame(
    text: &str,
    file: &str,
    camera: Option<&str>,
    frame: Option<f64>,
) -> Result<Calibration, CalibrationFileError> {
    let src = Src { file };
    if nuke::looks_like(text) || file.to_ascii_lowercase().ends_with(".nk") {
        return nuke::read(&src, text, camera, frame);
    }
    if tde4::looks_like(text) {
        return tde4::read(&src, text, camera);
    }
    let ext = Path::new(file)
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let structured = matches!(ext.as_str(), "yaml" | "yml" | "json")
        || first_data_line(text).is_some_and(|(_, l)| {
            l.starts_with('{') || l.starts_with('%') || l.starts_with("---") || l.contains(':')
        });
    if structured {
        let root = tree::parse(&src, text)?;
        if root.get_ignore_case("camera_matrix").is_some() {
            return opencv::read(&src, &root, camera);
        }
        if kalibr::looks_like(&root) {
            return kalibr::read(&src, &root, camera);
        }
        return Err(src.whole(
            "not a calibration file of a known kind: expected OpenCV's camera_matrix, \
             distortion_coefficients, image_width, image_height, or Kalibr's cam0: { camera_model, \
             intrinsics, distortion_model, distortion_coeffs, resolution }",
        ));
    }
    parse_as(
        if looks_like_ocamcalib(text) {
            FileFormat::OCamCalib
        } else {
            FileFormat::Colmap
        },
        text,
        file,
        camera,
    )
}

/// Reads `text` as a file of the given kind, without guessing.
///
/// # Errors
/// As [`load`].
pub fn parse_as(
    format: FileFormat,
    text: &str,
    file: &str,
    camera: Option<&str>,
) -> Result<Calibration, CalibrationFileError> {
    let src = Src { file };
    match format {
        FileFormat::Colmap => colmap::read(&src, text, camera),
        FileFormat::OCamCalib => ocamcalib::read(&src, text, camera),
        FileFormat::OpenCv => opencv::read(&src, &tree::parse(&src, text)?, camera),
        FileFormat::Kalibr => kalibr::read(&src, &tree::parse(&src, text)?, camera),
        FileFormat::Nuke => nuke::read(&src, text, camera, None),
        FileFormat::Tde4Lens => tde4::read(&src, text, camera),
    }
}

/// The first line that is neither blank nor a `#` comment, with its 1-based number, trimmed.
fn first_data_line(text: &str) -> Option<(usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim().trim_start_matches('\u{feff}')))
        .find(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

/// OCamCalib's file: its comments speak of polynomial coefficients, or its first data line is all
/// numbers (COLMAP's names a model in the second column).
fn looks_like_ocamcalib(text: &str) -> bool {
    let commented = text.lines().any(|l| {
        let l = l.trim_start();
        l.starts_with('#') && l.to_ascii_lowercase().contains("polynomial coefficients")
    });
    commented
        || first_data_line(text).is_some_and(|(_, l)| l.split_whitespace().all(|t| t.parse::<f64>().is_ok()))
}

/// Rejects `--camera` for a file that holds one camera.
pub(crate) fn single_camera(
    src: &Src<'_>,
    kind: &str,
    camera: Option<&str>,
) -> Result<(), CalibrationFileError> {
    match camera {
        None => Ok(()),
        Some(c) => Err(src.whole(format!(
            "--camera {c}: an {kind} file holds a single camera; --camera chooses among the cameras \
             of a COLMAP cameras.txt or a Kalibr camchain.yaml"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_keep_their_text_and_refuse_what_f32_cannot_hold() {
        let src = Src { file: "f.yaml" };
        let n = src.number("5.3591573396163199e+02", 4, "fx").unwrap();
        assert_eq!(n.text, "5.3591573396163199e+02");
        assert_eq!(n.value, 535.915_733_961_632);
        assert_eq!(src.number("1.", 1, "k").unwrap().value, 1.0);
        let e = src.number("1e300", 7, "k1").unwrap_err();
        assert_eq!((e.line, e.file.as_str()), (Some(7), "f.yaml"));
        assert!(e.message.contains("k1"), "{e}");
        assert!(src.number("nan", 1, "k").is_err());
        assert!(src.number(".Inf", 1, "k").is_err());
        assert!(src.number("abc", 1, "k").is_err());
    }

    #[test]
    fn sizes_are_positive_whole_numbers() {
        let src = Src { file: "f" };
        assert_eq!(src.size("640", 1, "w").unwrap(), 640);
        assert_eq!(src.size("640.", 1, "w").unwrap(), 640);
        for bad in ["0", "-3", "640.5", "x", "4294967296"] {
            assert!(src.size(bad, 1, "w").is_err(), "{bad}");
        }
    }

    #[test]
    fn cameras_are_chosen_by_id_text_or_number() {
        let src = Src { file: "f" };
        let ids = ["1".to_string(), "7".to_string()];
        assert_eq!(choose_camera(&src, "k", &ids, None).unwrap(), (0, true));
        assert_eq!(choose_camera(&src, "k", &ids, Some("07")).unwrap(), (1, false));
        let e = choose_camera(&src, "k", &ids, Some("3")).unwrap_err();
        assert!(e.message.contains("its cameras are: 1, 7"), "{e}");
        assert_eq!(choose_camera(&src, "k", &ids[..1], None).unwrap(), (0, false));
    }
}
