//! 3DEqualizer's lens export text ("Export Lens" / "Import Lens"):
//!
//! ```text
//! <lens name>
//! <fb width cm> <fb height cm> <focal length cm> <film aspect> <lco x cm> <lco y cm> <pixel aspect>
//! <dynamic distortion mode: DISTORTION_STATIC, or 0 in 3DE4 R1 files>
//! <model name>
//! <parameter name>            (per parameter:)
//! <value>
//! <number of curve keys n>
//! <n lines: x y tangent1 x y tangent2 x y MODE>
//! <end_of_file>
//! [<begin_2dlut_samples> … per parameter: name, n, n lines "focal focus value" … <end_2dlut_samples>]
//! ```
//!
//! Static distortion (the exports' usual mode) is read: each parameter's value. The curve keys and
//! 2-D table samples describe 3DE's *dynamic* distortion (a parameter as a function of focal
//! length or focus distance); a file whose mode is dynamic is refused with a located error rather
//! than rendered with one of its values, and a static file's curves or samples are noted as
//! unused. The file names no plate size: the plate is 2048 pixels wide in the film back's aspect.

use super::{Calibration, CalibrationFileError, FileFormat, Number, PixelConvention, Src, single_camera};
use crate::lens3de::Kind;

/// True when `text` looks like a 3DE lens export (its fourth line names a 3DE model, and it ends
/// its parameters with `<end_of_file>`).
#[must_use]
pub fn looks_like(text: &str) -> bool {
    text.lines().nth(3).is_some_and(|l| l.trim().starts_with("3DE")) && text.contains("<end_of_file>")
}

/// Reads a 3DE lens export.
///
/// # Errors
/// A [`CalibrationFileError`] at the line to blame: a short header, a number that is not one, an
/// unknown model or parameter name, a dynamic distortion mode, `--camera` given.
pub(crate) fn read(
    src: &Src<'_>,
    text: &str,
    camera: Option<&str>,
) -> Result<Calibration, CalibrationFileError> {
    single_camera(src, "3DE lens export", camera)?;
    let lines: Vec<(usize, &str)> = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())).collect();
    let at = |i: usize| -> Result<(usize, &str), CalibrationFileError> {
        lines
            .get(i)
            .copied()
            .ok_or_else(|| src.whole(format!("the lens export ends at line {} (expected the header's 4 lines, then the parameters and <end_of_file>)", lines.len())))
    };
    let (camera_line, camera_text) = at(1)?;
    let fields: Vec<&str> = camera_text.split_whitespace().collect();
    if fields.len() != 7 {
        return Err(src.err(
            camera_line,
            format!(
                "expected 7 numbers (film back width, height, focal length (cm), film aspect, lens-centre offset x, y (cm), pixel aspect), got {}",
                fields.len()
            ),
        ));
    }
    let names = [
        "filmback width",
        "filmback height",
        "focal length",
        "film aspect",
        "lens center offset x",
        "lens center offset y",
        "pixel aspect",
    ];
    let header: Vec<Number> = fields
        .iter()
        .zip(names)
        .map(|(t, n)| src.number(t, camera_line, n))
        .collect::<Result<_, _>>()?;
    let (mode_line, mode) = at(2)?;
    if !matches!(mode, "DISTORTION_STATIC" | "0") {
        return Err(src.err(
            mode_line,
            format!(
                "dynamic distortion ({mode}) is not read: its parameters are curves over focal length or focus distance; export the lens with static distortion, or export Nuke distortion nodes (3DE bakes the curves per frame there)"
            ),
        ));
    }
    let (model_line, model) = at(3)?;
    let kind = Kind::from_name(model).ok_or_else(|| {
        src.err(
            model_line,
            format!(
                "unknown 3DE lens model \"{model}\": expected one of {}",
                crate::lens3de::KINDS
                    .iter()
                    .map(|k| k.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )
    })?;
    let all = kind.all_params();
    let mut params: Vec<Number> = all
        .iter()
        .map(|&(_, d)| Number {
            text: format!("{d}"),
            value: d,
            line: model_line,
        })
        .collect();
    // Film back, focal length, offset, pixel aspect from the camera line.
    for (slot, field) in [(0, 2), (1, 0), (2, 1), (3, 4), (4, 5), (5, 6)] {
        params[slot] = header[field].clone();
    }
    let mut notes = Vec::new();
    let mut i = 4;
    let mut ended = false;
    while i < lines.len() {
        let (line, name) = lines[i];
        if name == "<end_of_file>" {
            ended = true;
            i += 1;
            break;
        }
        if name.is_empty() {
            i += 1;
            continue;
        }
        let slot = all.iter().position(|p| p.0 == name).ok_or_else(|| {
            src.err(
                line,
                format!(
                    "\"{name}\" is not a parameter of {}: expected {}",
                    kind.name(),
                    kind.params().iter().map(|p| p.0).collect::<Vec<_>>().join(", ")
                ),
            )
        })?;
        let (vline, vtext) = at(i + 1)?;
        params[slot] = src.number(vtext, vline, name)?;
        let (kline, ktext) = at(i + 2)?;
        let keys: usize = ktext.parse().map_err(|_| {
            src.err(
                kline,
                format!("{name}: expected the number of curve keys, got \"{ktext}\""),
            )
        })?;
        if keys > 0 {
            notes.push(format!(
                "{name}: its {keys} curve key(s) (dynamic distortion) are not used: the mode is static"
            ));
        }
        i += 3 + keys;
    }
    if !ended {
        return Err(src.whole("no <end_of_file> after the parameters"));
    }
    if lines[i.min(lines.len())..]
        .iter()
        .any(|(_, l)| *l == "<begin_2dlut_samples>")
    {
        notes.push("the 2-D table of dynamic distortion samples is not used: the mode is static".to_string());
    }
    let (w, h, note) = super::nuke::plate_of_back(&params, "a lens export names no plate size");
    notes.push(note);
    let mut c = src.calibration(FileFormat::Tde4Lens, model_line, kind.name(), [w, h], params);
    c.pixel_convention = PixelConvention::Colmap;
    c.notes = notes;
    Ok(c)
}
