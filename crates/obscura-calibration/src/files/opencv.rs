//! OpenCV's calibration output as its samples write it through `cv::FileStorage`, in YAML
//! (`%YAML:1.0`, matrices as `!!opencv-matrix` mappings of `rows`, `cols`, `dt`, `data`) or JSON (the
//! same mappings with `"type_id": "opencv-matrix"`):
//!
//! ```text
//! image_width: 640
//! image_height: 480
//! camera_matrix: !!opencv-matrix { rows: 3, cols: 3, dt: d, data: [ fx, 0., cx, 0., fy, cy, 0., 0., 1. ] }
//! distortion_coefficients: !!opencv-matrix { rows: 5, cols: 1, dt: d, data: [ k1, k2, p1, p2, k3 ] }
//! ```
//!
//! Read as `OPENCV_PINHOLE` with parameters `fx fy cx cy` followed by the distortion coefficients in
//! OpenCV's order (4, 5, 8, 12 or 14 of them: k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [τx τy]]]]), or
//! `PINHOLE` when there are none. OpenCV's calibration tutorial writes `fisheye_model: 1` for a
//! `cv::fisheye` calibration: its four coefficients are Kannala–Brandt's k1..k4, read as
//! `OPENCV_FISHEYE`. The same layout without tags, as ROS `camera_info` files write it (with
//! `distortion_model: plumb_bob`, `rational_polynomial` or `equidistant`), reads too. Keys are matched
//! ignoring case (OpenCV's older tutorial wrote `Camera_Matrix`). Pixel centres are at integer
//! coordinates (`pixelConvention` `opencv`).

use super::tree::{Node, Value};
use super::{Calibration, CalibrationFileError, FileFormat, Number, Src, single_camera};

/// A matrix as written: its shape and values in row-major order.
struct Matrix {
    rows: usize,
    cols: usize,
    data: Vec<Number>,
}

fn field<'a>(src: &Src<'_>, root: &'a Node, key: &str, what: &str) -> Result<&'a Node, CalibrationFileError> {
    root.get_ignore_case(key)
        .ok_or_else(|| src.err(root.line, format!("{key}: missing; expected {what}")))
}

fn count(src: &Src<'_>, node: &Node, what: &str) -> Result<usize, CalibrationFileError> {
    node.text()
        .and_then(|t| t.trim().parse::<usize>().ok())
        .ok_or_else(|| {
            src.err(
                node.line,
                format!("{what}: expected a non-negative integer, got {}", node.describe()),
            )
        })
}

/// Reads an OpenCV matrix: an `opencv-matrix` mapping, or a plain list (a column), or a list of rows.
fn matrix(src: &Src<'_>, node: &Node, name: &str) -> Result<Matrix, CalibrationFileError> {
    match &node.value {
        Value::Map(_) => {
            let get = |k: &str| {
                node.get(k).ok_or_else(|| {
                    src.err(
                        node.line,
                        format!("{name}: the matrix has no \"{k}\"; expected rows, cols, dt and data"),
                    )
                })
            };
            let rows = count(src, get("rows")?, &format!("{name}.rows"))?;
            let cols = count(src, get("cols")?, &format!("{name}.cols"))?;
            if let Some(dt) = node.get("dt") {
                let t = dt.text().unwrap_or_default().trim();
                let channels = t.trim_end_matches(|c: char| c.is_ascii_alphabetic());
                let kind = &t[channels.len()..];
                let ok = matches!(kind, "u" | "c" | "w" | "s" | "i" | "f" | "d" | "h")
                    && (channels.is_empty() || channels == "1");
                if !ok {
                    return Err(src.err(
                        dt.line,
                        format!(
                            "{name}.dt: expected a single-channel element type such as d or f, got {}",
                            dt.describe()
                        ),
                    ));
                }
            }
            let data_node = get("data")?;
            let items = data_node.items().ok_or_else(|| {
                src.err(
                    data_node.line,
                    format!(
                        "{name}.data: expected a list of numbers, got {}",
                        data_node.describe()
                    ),
                )
            })?;
            let data = src.numbers(items, &format!("{name}.data"))?;
            if data.len() != rows * cols {
                return Err(src.err(
                    data_node.line,
                    format!(
                        "{name}.data: a {rows}x{cols} matrix needs {} values, got {}",
                        rows * cols,
                        data.len()
                    ),
                ));
            }
            Ok(Matrix { rows, cols, data })
        }
        Value::Seq(items) if items.iter().all(|i| i.items().is_some()) && !items.is_empty() => {
            let cols = items[0].items().map_or(0, <[Node]>::len);
            let mut data = Vec::with_capacity(items.len() * cols);
            for (r, row) in items.iter().enumerate() {
                let row_items = row.items().unwrap_or_default();
                if row_items.len() != cols {
                    return Err(src.err(
                        row.line,
                        format!(
                            "{name}[{r}]: rows of a matrix must be equally long: {cols} values, got {}",
                            row_items.len()
                        ),
                    ));
                }
                data.extend(src.numbers(row_items, &format!("{name}[{r}]"))?);
            }
            Ok(Matrix {
                rows: items.len(),
                cols,
                data,
            })
        }
        Value::Seq(items) => Ok(Matrix {
            rows: items.len(),
            cols: 1,
            data: src.numbers(items, name)?,
        }),
        Value::Scalar { .. } => Err(src.err(
            node.line,
            format!(
                "{name}: expected a matrix (an opencv-matrix with rows, cols, dt, data), got {}",
                node.describe()
            ),
        )),
    }
}

/// Reads and checks `camera_matrix`: 3×3, `[fx 0 cx; 0 fy cy; 0 0 1]` with positive focal lengths.
fn camera_matrix<'a>(src: &Src<'_>, root: &'a Node) -> Result<(&'a Node, Matrix), CalibrationFileError> {
    let k_node = field(src, root, "camera_matrix", "the 3x3 camera matrix")?;
    let k = matrix(src, k_node, "camera_matrix")?;
    if (k.rows, k.cols) != (3, 3) {
        return Err(src.err(
            k_node.line,
            format!("camera_matrix: expected 3x3, got {}x{}", k.rows, k.cols),
        ));
    }
    let kv = |i: usize| k.data[i].value;
    for (i, want, what) in [
        (1, 0.0, "the skew K[0][1]"),
        (3, 0.0, "K[1][0]"),
        (6, 0.0, "K[2][0]"),
        (7, 0.0, "K[2][1]"),
        (8, 1.0, "K[2][2]"),
    ] {
        if kv(i) != want {
            let extra = if i == 1 {
                "; the OpenCV models here have no skew parameter"
            } else {
                ""
            };
            return Err(src.err(
                k.data[i].line,
                format!(
                    "camera_matrix: {what} is {}, expected {want}{extra} (a camera matrix is [fx 0 cx; 0 fy cy; 0 0 1])",
                    k.data[i].text
                ),
            ));
        }
    }
    for (i, name) in [(0, "fx = K[0][0]"), (4, "fy = K[1][1]")] {
        if kv(i) <= 0.0 {
            return Err(src.err(
                k.data[i].line,
                format!(
                    "camera_matrix: {name} is {}, expected a positive focal length in pixels",
                    k.data[i].text
                ),
            ));
        }
    }
    Ok((k_node, k))
}

/// Whether the file is a `cv::fisheye` calibration: its `fisheye_model` flag, else ROS's
/// `distortion_model`.
fn is_fisheye(src: &Src<'_>, root: &Node) -> Result<bool, CalibrationFileError> {
    match (
        root.get_ignore_case("fisheye_model"),
        root.get_ignore_case("distortion_model"),
    ) {
        (Some(f), _) => match f.text().unwrap_or_default().trim() {
            "0" | "false" | "False" => Ok(false),
            "1" | "true" | "True" => Ok(true),
            _ => Err(src.err(
                f.line,
                format!("fisheye_model: expected 0 or 1, got {}", f.describe()),
            )),
        },
        (None, Some(m)) => match m.text().unwrap_or_default().trim() {
            "plumb_bob" | "rational_polynomial" | "" => Ok(false),
            "equidistant" | "fisheye" => Ok(true),
            other => Err(src.err(
                m.line,
                format!(
                    "distortion_model: \"{other}\" is not read here; expected plumb_bob, rational_polynomial or equidistant"
                ),
            )),
        },
        (None, None) => Ok(false),
    }
}

/// Reads an OpenCV (or ROS `camera_info`) calibration from its parsed tree.
///
/// # Errors
/// The line and field at fault: a missing or malformed `image_width`, `image_height`,
/// `camera_matrix` (3×3, zero skew, last row 0 0 1, positive focal lengths) or
/// `distortion_coefficients` (a row or column of 0, 4, 5, 8, 12 or 14; 4 for a fisheye), or
/// `--camera` given for this single-camera file.
pub(crate) fn read(
    src: &Src<'_>,
    root: &Node,
    camera: Option<&str>,
) -> Result<Calibration, CalibrationFileError> {
    single_camera(src, "OpenCV calibration", camera)?;
    if root.entries().is_none() {
        return Err(src.err(
            root.line,
            format!(
                "expected a mapping of calibration fields, got {}",
                root.describe()
            ),
        ));
    }
    let w = field(src, root, "image_width", "the calibration image width in pixels")?;
    let h = field(
        src,
        root,
        "image_height",
        "the calibration image height in pixels",
    )?;
    let width = src.size(w.text().unwrap_or_default(), w.line, "image_width")?;
    let height = src.size(h.text().unwrap_or_default(), h.line, "image_height")?;

    let (k_node, k) = camera_matrix(src, root)?;

    let d_node = field(
        src,
        root,
        "distortion_coefficients",
        "the distortion coefficients",
    )?;
    let d = matrix(src, d_node, "distortion_coefficients")?;
    if d.rows != 1 && d.cols != 1 && !d.data.is_empty() {
        return Err(src.err(
            d_node.line,
            format!(
                "distortion_coefficients: expected one row or one column, got {}x{}",
                d.rows, d.cols
            ),
        ));
    }

    let mut notes = Vec::new();
    let fisheye = is_fisheye(src, root)?;
    let n = d.data.len();
    let model = if fisheye {
        if n != 4 {
            return Err(src.err(
                d_node.line,
                format!(
                    "distortion_coefficients: an OpenCV fisheye (Kannala-Brandt) calibration has 4 coefficients k1 k2 k3 k4, got {n}"
                ),
            ));
        }
        notes.push("cv::fisheye calibration: read as OPENCV_FISHEYE (Kannala-Brandt k1..k4)".to_string());
        "OPENCV_FISHEYE"
    } else {
        match n {
            0 => "PINHOLE",
            4 | 5 | 8 | 12 | 14 => "OPENCV_PINHOLE",
            _ => {
                return Err(src.err(
                    d_node.line,
                    format!(
                        "distortion_coefficients: OpenCV's pinhole model takes 4, 5, 8, 12 or 14 coefficients \
                         (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [taux tauy]]]]), got {n}"
                    ),
                ));
            }
        }
    };
    let mut params = vec![
        k.data[0].clone(),
        k.data[4].clone(),
        k.data[2].clone(),
        k.data[5].clone(),
    ];
    params.extend(d.data);
    Ok(Calibration {
        notes,
        ..src.calibration(FileFormat::OpenCv, k_node.line, model, [width, height], params)
    })
}
