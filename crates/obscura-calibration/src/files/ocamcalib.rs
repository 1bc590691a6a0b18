//! OCamCalib's `calib_results.txt`, as the toolbox's `export_data` writes it for its C functions
//! (`get_ocam_model`): `#` comment lines, then
//!
//! ```text
//! N a0 a1 … a(N-1)      pol: the direct polynomial (cam2world), preceded by its length
//! M b0 b1 … b(M-1)      invpol: the inverse polynomial (world2cam), preceded by its length
//! xc yc                 the image centre: row, then column
//! c d e                 the affine parameters
//! height width          the image size
//! ```
//!
//! Read as `OCAMCALIB` with `params` `xc yc c d e` exactly as written (xc is OCamCalib's row
//! coordinate), `polynomial` a0..a(N-1) and `inversePolynomial` b0..b(M-1). Each polynomial's length
//! must match the coefficients on its line (as `export_data` writes them), so a wrong length is
//! reported at its own line rather than shifting every later number; the remaining numbers are read
//! in sequence whatever the line breaks, like the C reader. The C functions take the centre in 0-based pixel
//! indices (they feed `cvRemap` directly), so `pixelConvention` is `opencv`; the MATLAB toolbox that
//! calibrated counts pixels from 1, an offset the file format itself carries.

use super::{Calibration, CalibrationFileError, FileFormat, Number, Src, single_camera};

struct Tokens<'a> {
    items: Vec<(&'a str, usize)>,
    next: usize,
    last_line: usize,
}

impl<'a> Tokens<'a> {
    fn take(&mut self, src: &Src<'_>, what: &str) -> Result<(&'a str, usize), CalibrationFileError> {
        let t = self.items.get(self.next).copied().ok_or_else(|| {
            src.err(
                self.last_line,
                format!("the file ends before {what}; expected pol, invpol, \"xc yc\", \"c d e\", \"height width\""),
            )
        })?;
        self.next += 1;
        Ok(t)
    }

    fn number(&mut self, src: &Src<'_>, what: &str) -> Result<Number, CalibrationFileError> {
        let (t, line) = self.take(src, what)?;
        src.number(t, line, what)
    }

    fn polynomial(&mut self, src: &Src<'_>, name: &str) -> Result<Vec<Number>, CalibrationFileError> {
        let (t, line) = self.take(src, &format!("the length of {name}"))?;
        let n = t
            .parse::<usize>()
            .ok()
            .or_else(|| {
                t.parse::<f64>()
                    .ok()
                    .filter(|v| v.fract() == 0.0 && *v >= 0.0)
                    .map(|v| v as usize)
            })
            .filter(|&n| (1..=64).contains(&n))
            .ok_or_else(|| {
                src.err(
                    line,
                    format!("{name}: expected the number of coefficients (1 to 64) first, got \"{t}\""),
                )
            })?;
        // export_data writes a polynomial's length and coefficients on one line: a length that
        // disagrees with its own line is the error to report, not whatever it would shift further on.
        let on_line = self.items.iter().filter(|t| t.1 == line).count() - 1;
        if on_line != n {
            return Err(src.err(
                line,
                format!(
                    "{name}: the length says {n} coefficients but its line holds {on_line}                      (OCamCalib writes the length and the coefficients on one line)"
                ),
            ));
        }
        (0..n)
            .map(|i| self.number(src, &format!("{name} coefficient {i} (of {n})")))
            .collect()
    }
}

/// Reads a `calib_results.txt`.
///
/// # Errors
/// The line and field at fault: a polynomial length that is not a count, a missing or non-numeric
/// value (naming which), a size that is not a positive integer, numbers left over after the image
/// size, or `--camera` given for this single-camera file.
pub(crate) fn read(
    src: &Src<'_>,
    text: &str,
    camera: Option<&str>,
) -> Result<Calibration, CalibrationFileError> {
    single_camera(src, "OCamCalib", camera)?;
    let mut tokens = Tokens {
        items: Vec::new(),
        next: 0,
        last_line: text.lines().count().max(1),
    };
    for (i, line) in text.lines().enumerate() {
        let l = line.trim().trim_start_matches('\u{feff}');
        if l.starts_with('#') {
            continue;
        }
        tokens.items.extend(l.split_whitespace().map(|t| (t, i + 1)));
    }
    let first_line = tokens.items.first().map_or(1, |t| t.1);
    let polynomial = tokens.polynomial(src, "pol")?;
    let inverse_polynomial = tokens.polynomial(src, "invpol")?;
    let mut params = Vec::with_capacity(5);
    for what in [
        "xc (centre row)",
        "yc (centre column)",
        "affine c",
        "affine d",
        "affine e",
    ] {
        params.push(tokens.number(src, what)?);
    }
    let (h, h_line) = tokens.take(src, "the image height")?;
    let height = src.size(h, h_line, "image height")?;
    let (w, w_line) = tokens.take(src, "the image width")?;
    let width = src.size(w, w_line, "image width")?;
    if let Some((t, line)) = tokens.items.get(tokens.next) {
        return Err(src.err(
            *line,
            format!("unexpected \"{t}\" after the image size \"height width\", the last field of calib_results.txt"),
        ));
    }
    let det = params[2].value - params[3].value * params[4].value;
    if det == 0.0 {
        return Err(src.err(
            params[2].line,
            "affine c d e: c - d*e is 0, so the affine map [c d; e 1] has no inverse",
        ));
    }
    Ok(Calibration {
        polynomial,
        inverse_polynomial,
        notes: vec!["OCamCalib's image size is written height width; the resolution is width height".into()],
        ..src.calibration(
            FileFormat::OCamCalib,
            first_line,
            "OCAMCALIB",
            [width, height],
            params,
        )
    })
}
