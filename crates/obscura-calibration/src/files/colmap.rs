//! COLMAP's `cameras.txt`: one camera a line, `CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]`, blank lines
//! and `#` comments skipped (COLMAP's own header is three comment lines).
//!
//! The model is named as COLMAP names it (`OPENCV`, `SIMPLE_RADIAL`, …; COLMAP's text reader takes
//! names only, not the numeric ids of its binary format) and the parameters are kept in COLMAP's
//! order. Pixel coordinates follow COLMAP's convention: the image corner is (0, 0) and the top-left
//! pixel centre (0.5, 0.5).

use super::{Calibration, CalibrationFileError, FileFormat, Number, Src, choose_camera};

/// COLMAP's camera models (`src/colmap/sensor/models.h`, ids 0–17 in this order) and their parameters.
pub const MODELS: [(&str, &[&str]); 18] = [
    ("SIMPLE_PINHOLE", &["f", "cx", "cy"]),
    ("PINHOLE", &["fx", "fy", "cx", "cy"]),
    ("SIMPLE_RADIAL", &["f", "cx", "cy", "k"]),
    ("RADIAL", &["f", "cx", "cy", "k1", "k2"]),
    ("OPENCV", &["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"]),
    (
        "OPENCV_FISHEYE",
        &["fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"],
    ),
    (
        "FULL_OPENCV",
        &[
            "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6",
        ],
    ),
    ("FOV", &["fx", "fy", "cx", "cy", "omega"]),
    ("SIMPLE_RADIAL_FISHEYE", &["f", "cx", "cy", "k"]),
    ("RADIAL_FISHEYE", &["f", "cx", "cy", "k1", "k2"]),
    (
        "THIN_PRISM_FISHEYE",
        &[
            "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "sx1", "sy1",
        ],
    ),
    (
        "RAD_TAN_THIN_PRISM_FISHEYE",
        &[
            "fx", "fy", "cx", "cy", "k0", "k1", "k2", "k3", "k4", "k5", "p0", "p1", "s0", "s1", "s2", "s3",
        ],
    ),
    ("SIMPLE_DIVISION", &["f", "cx", "cy", "k"]),
    ("DIVISION", &["fx", "fy", "cx", "cy", "k"]),
    ("SIMPLE_FISHEYE", &["f", "cx", "cy"]),
    ("FISHEYE", &["fx", "fy", "cx", "cy"]),
    ("EUCM", &["fx", "fy", "cx", "cy", "alpha", "beta"]),
    ("EQUIRECTANGULAR", &["w", "h"]),
];

/// The parameter names of COLMAP model `name`, if it is one.
#[must_use]
pub fn model_params(name: &str) -> Option<&'static [&'static str]> {
    MODELS.iter().find(|(n, _)| *n == name).map(|(_, p)| *p)
}

struct Line<'a> {
    number: usize,
    tokens: Vec<&'a str>,
}

/// Reads a `cameras.txt` and picks `camera` (a `CAMERA_ID`; the first camera when `None`).
///
/// Every line is checked, not only the chosen one, so a file that loads is wholly well formed.
///
/// # Errors
/// The line and field at fault: too few columns, an unknown model (with the list), a size that is not a
/// positive integer, a parameter count that does not match the model (with its parameter names), a
/// number that is not one, a camera id given twice, or no camera `camera`.
pub(crate) fn read(
    src: &Src<'_>,
    text: &str,
    camera: Option<&str>,
) -> Result<Calibration, CalibrationFileError> {
    let lines: Vec<Line<'_>> = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim().trim_start_matches('\u{feff}')))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
        .map(|(number, l)| Line {
            number,
            tokens: l.split_whitespace().collect(),
        })
        .collect();
    let mut cameras: Vec<Calibration> = Vec::with_capacity(lines.len());
    let mut id_lines: Vec<(String, usize)> = Vec::with_capacity(lines.len());
    for line in &lines {
        let cal = read_line(src, line)?;
        let id = cal.camera.clone().unwrap_or_default();
        let numeric = id.parse::<u64>().ok();
        if let Some((_, first)) = id_lines
            .iter()
            .find(|(other, _)| *other == id || (numeric.is_some() && other.parse::<u64>().ok() == numeric))
        {
            return Err(src.err(
                line.number,
                format!("CAMERA_ID {id} is given twice (first on line {first})"),
            ));
        }
        id_lines.push((id, line.number));
        cameras.push(cal);
    }
    let ids: Vec<String> = id_lines.into_iter().map(|(id, _)| id).collect();
    let (index, by_default) = choose_camera(src, "COLMAP cameras.txt", &ids, camera)?;
    let mut cal = cameras.swap_remove(index);
    cal.cameras = ids;
    cal.first_by_default = by_default;
    Ok(cal)
}

fn read_line(src: &Src<'_>, line: &Line<'_>) -> Result<Calibration, CalibrationFileError> {
    let n = line.number;
    let t = &line.tokens;
    if t.len() < 4 {
        return Err(src.err(
            n,
            format!(
                "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[], got {} column{}",
                t.len(),
                if t.len() == 1 { "" } else { "s" }
            ),
        ));
    }
    let id = t[0];
    if id.parse::<u32>().is_err() {
        return Err(src.err(
            n,
            format!("CAMERA_ID: expected a non-negative integer, got \"{id}\""),
        ));
    }
    let model = t[1];
    let Some(names) = model_params(model) else {
        let known: Vec<&str> = MODELS.iter().map(|(m, _)| *m).collect();
        let hint = obscura_sdk::did_you_mean(model, known.iter().copied())
            .map(|s| format!(" (did you mean {s}?)"))
            .unwrap_or_default();
        return Err(src.err(
            n,
            format!(
                "MODEL: unknown COLMAP camera model \"{model}\"{hint}; expected one of {}",
                known.join(", ")
            ),
        ));
    };
    let width = src.size(t[2], n, "WIDTH")?;
    let height = src.size(t[3], n, "HEIGHT")?;
    let values = &t[4..];
    if values.len() != names.len() {
        return Err(src.err(
            n,
            format!(
                "PARAMS: {model} takes {} parameters ({}), got {}",
                names.len(),
                names.join(", "),
                values.len()
            ),
        ));
    }
    let params = values
        .iter()
        .zip(names.iter())
        .map(|(v, name)| src.number(v, n, &format!("PARAMS {name}")))
        .collect::<Result<Vec<Number>, _>>()?;
    Ok(Calibration {
        camera: Some(id.to_string()),
        ..src.calibration(FileFormat::Colmap, n, model, [width, height], params)
    })
}
