//! Readers of the arguments several subcommands share: `--format`, `--crop` and `--calibration`.
//!
//! Each subcommand's options name these, so that one spelling is accepted (and one message given)
//! everywhere.

use std::path::Path;

use obscura_host::CropWindow;
use obscura_render::job::Calibrated;

/// The most pixels `obscura check` samples (4096 × 4096): every pixel is checked one by one.
const MAX_CHECKED_PIXELS: u64 = 16_777_216;

/// Reads `--format WIDTHxHEIGHT` (`x` or `X`, spaces allowed around the numbers), both positive.
///
/// # Errors
/// A message quoting `s` and showing the form.
pub fn parse_format(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("'{s}': expected WIDTHxHEIGHT with positive integers, e.g. 640x480");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h) = (
        w.trim().parse::<u32>().map_err(|_| bad())?,
        h.trim().parse::<u32>().map_err(|_| bad())?,
    );
    if w == 0 || h == 0 {
        return Err(bad());
    }
    Ok((w, h))
}

/// [`parse_format`] for `obscura check`, which also refuses more than 16,777,216 pixels.
///
/// # Errors
/// As [`parse_format`], and a message quoting `s` and the limit when it holds more pixels.
pub fn parse_checked_format(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = parse_format(s)?;
    if u64::from(w) * u64::from(h) > MAX_CHECKED_PIXELS {
        return Err(format!(
            "'{s}': expected WIDTHxHEIGHT of at most {MAX_CHECKED_PIXELS} pixels, e.g. 4096x4096"
        ));
    }
    Ok((w, h))
}

/// Reads `--plugin-timeout SECONDS`: a positive number of seconds, at most a day.
///
/// # Errors
/// A message quoting `s` and giving the range.
pub fn parse_timeout(s: &str) -> Result<std::time::Duration, String> {
    match s.trim().parse::<f64>() {
        Ok(t) if t > 0.0 && t <= 86_400.0 => Ok(std::time::Duration::from_secs_f64(t)),
        _ => Err(format!(
            "'{s}': expected a number of seconds in (0, 86400], e.g. 10 or 0.5"
        )),
    }
}

/// The crop window of `--crop XMIN XMAX YMIN YMAX` (clap has checked there are four).
pub fn crop_window(v: &[f32]) -> CropWindow {
    CropWindow {
        x_min: v[0],
        x_max: v[1],
        y_min: v[2],
        y_max: v[3],
    }
}

/// Reads `--calibration FILE [--camera ID]`; says on stderr which camera was taken when the file
/// holds several and none was named, unless `quiet`.
///
/// # Errors
/// The calibration file's error, naming the file.
pub fn load_calibration(path: &Path, camera: Option<&str>, quiet: bool) -> Result<Calibrated, String> {
    let c = Calibrated::load(path, camera).map_err(|e| e.to_string())?;
    if !quiet && let Some(note) = c.calibration.selection_note() {
        eprintln!("note: {note}");
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_format_spelling_is_read_and_bad_ones_refused() {
        assert_eq!(parse_format("640x480"), Ok((640, 480)));
        assert_eq!(parse_format(" 8 X 6 "), Ok((8, 6)));
        assert_eq!(parse_format("100000x100000"), Ok((100_000, 100_000)));
        for bad in ["640", "0x5", "5x0", "ax5", "640by480", "-1x5", ""] {
            let e = parse_format(bad).unwrap_err();
            assert!(
                e.contains("WIDTHxHEIGHT") && e.contains(&format!("'{bad}'")),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn the_checked_format_is_the_same_with_a_pixel_limit() {
        assert_eq!(parse_checked_format("4096x4096"), Ok((4096, 4096)));
        assert_eq!(parse_checked_format("96x72"), parse_format("96x72"));
        assert_eq!(parse_checked_format("0x5"), parse_format("0x5"));
        let e = parse_checked_format("4097x4096").unwrap_err();
        assert!(e.contains("at most 16777216 pixels"), "{e}");
    }

    #[test]
    fn a_plugin_timeout_is_positive_seconds() {
        assert_eq!(parse_timeout("0.5"), Ok(std::time::Duration::from_millis(500)));
        assert_eq!(parse_timeout("10"), Ok(std::time::Duration::from_secs(10)));
        for bad in ["0", "-1", "nan", "inf", "1e9", "ten", ""] {
            let e = parse_timeout(bad).unwrap_err();
            assert!(
                e.contains(&format!("'{bad}': expected a number of seconds")),
                "{e}"
            );
        }
    }

    #[test]
    fn crop_arguments_are_in_xmin_xmax_ymin_ymax_order() {
        assert_eq!(
            crop_window(&[0.1, 0.2, 0.3, 0.4]),
            CropWindow {
                x_min: 0.1,
                x_max: 0.2,
                y_min: 0.3,
                y_max: 0.4
            }
        );
    }
}
