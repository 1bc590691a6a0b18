//! `obscura check`: the projection contract checker a plugin author runs before shipping.
//!
//! Argument handling and printing only; the checks are `obscura_sdk::contract`.

use crate::args::{load_calibration, parse_checked_format};
use crate::params::merge_param_args;
use crate::stdout::outln;
use clap::Args;
use obscura_check::{CheckOptions, check_registered};
use obscura_plugins::cli_registry;
use obscura_plugins::loader::{PluginSearch, ensure};
use obscura_render::job::CALIBRATED;
use obscura_sdk::{Format, ParamList, ScreenWindow};

/// `obscura check <name or path> [--param ...] [--json]`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    /// The projection: a registered name (PxrPerspective), a plugin name found along the plugin path,
    /// or the path of a plugin library.
    #[arg(required_unless_present = "calibration", conflicts_with = "calibration")]
    pub projection: Option<String>,
    /// Check the camera of a calibration file (COLMAP cameras.txt, OpenCV YAML/JSON, Kalibr
    /// camchain.yaml, OCamCalib calib_results.txt, a Nuke script with 3DE LD nodes, a 3DE lens export) as CalibratedCamera; --param adds to or replaces
    /// its parameters.
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<std::path::PathBuf>,
    /// The camera of a calibration file holding several (a COLMAP CAMERA_ID, Kalibr's cam0, a Nuke LD node's name, …).
    #[arg(long, value_name = "ID", requires = "calibration")]
    pub camera: Option<String>,
    /// A projection parameter: 'float fov=60', 'fov=60' or RIB's '"float fov" [60]'. Repeatable.
    #[arg(long = "param", value_name = "PARAM")]
    pub params: Vec<String>,
    /// Print the report as JSON (same content) instead of text.
    #[arg(long)]
    pub json: bool,
    /// Image size sampled, WIDTHxHEIGHT: every pixel centre plus a margin around the window
    /// [default: 96x72; with --calibration, 96 wide in the calibration image's aspect].
    #[arg(long, value_parser = parse_checked_format)]
    pub format: Option<(u32, u32)>,
    /// Pixel aspect ratio (pixel width / height).
    #[arg(long, default_value_t = 1.0)]
    pub pixel_aspect: f32,
    /// ScreenWindow left right bottom top (default: from the frame aspect).
    #[arg(long, num_args = 4, value_names = ["L", "R", "B", "T"], allow_negative_numbers = true)]
    pub screen_window: Option<Vec<f32>>,
    /// Clipping near far.
    #[arg(long, num_args = 2, value_names = ["NEAR", "FAR"])]
    pub clipping: Option<Vec<f32>>,
    /// Random lens and time samples per pixel, besides the pixel centre's chief ray.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(0..=1024))]
    pub samples: u32,
    /// Seed of the random samples.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Threads running the same batches at once for the thread-safety check.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u64).range(1..=256))]
    pub threads: u64,
    /// Samples per project call.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u64).range(1..=1_048_576))]
    pub batch: u64,
}

/// The options the arguments describe, checked; `calibrated` is the calibration image's size, if any.
fn options(a: &CheckArgs, calibrated: Option<(u32, u32)>) -> Result<CheckOptions, String> {
    if !(a.pixel_aspect.is_finite() && a.pixel_aspect > 0.0) {
        return Err(format!(
            "--pixel-aspect {}: expected a positive number",
            a.pixel_aspect
        ));
    }
    let screen_window = match a.screen_window.as_deref() {
        None => None,
        Some(&[l, r, b, t]) => {
            if !([l, r, b, t].iter().all(|v| v.is_finite()) && l < r && b < t) {
                return Err(format!(
                    "--screen-window {l} {r} {b} {t}: expected finite L < R and B < T"
                ));
            }
            Some(ScreenWindow::new(l, r, b, t))
        }
        Some(other) => return Err(format!("--screen-window: expected 4 numbers, got {other:?}")),
    };
    let (width, height) = a.format.unwrap_or(match calibrated {
        Some((w, h)) => (96, ((96.0 * f64::from(h) / f64::from(w)).round() as u32).max(1)),
        None => (96, 72),
    });
    let mut opts = CheckOptions {
        format: Format {
            width,
            height,
            pixel_aspect: a.pixel_aspect,
        },
        screen_window,
        samples_per_pixel: a.samples,
        seed: a.seed,
        threads: a.threads as usize,
        batch_size: a.batch as usize,
        ..CheckOptions::default()
    };
    if let Some(c) = a.clipping.as_deref() {
        let (near, far) = (c[0], c[1]);
        if !(near >= 0.0 && near.is_finite() && far > near) {
            return Err(format!(
                "--clipping {near} {far}: expected 0 <= NEAR < FAR (FAR may be inf)"
            ));
        }
        opts.clipping = (near, far);
    }
    Ok(opts)
}

/// What `obscura check` ended with, for its exit code.
pub enum Outcome {
    /// Every check passed (exit 0).
    Clean,
    /// The report was printed and some check failed (exit 1); the message names them.
    Broken(String),
    /// The check could not run: the projection could not be found, loaded or created, or an option
    /// was refused (exit 2; with --json the message is also printed as `{"error": …}` on stdout).
    CouldNotRun(String),
}

/// Runs `obscura check` and says how it ended (see [`Outcome`]).
pub fn run(a: &CheckArgs, search: &PluginSearch) -> Outcome {
    match run_report(a, search) {
        Ok(None) => Outcome::Clean,
        Ok(Some(failed)) => Outcome::Broken(failed),
        Err(e) => {
            if a.json {
                outln!("{{\"error\": {}}}", json_string(&e));
            }
            Outcome::CouldNotRun(e)
        }
    }
}

/// `s` as a JSON string literal.
fn json_string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// Prints the report; `Ok(Some(message))` when a check failed, `Err` when the check could not run.
fn run_report(a: &CheckArgs, search: &PluginSearch) -> Result<Option<String>, String> {
    let mut registry = cli_registry();
    let (name, mut params, calibrated) = match (&a.calibration, &a.projection) {
        (Some(path), _) => {
            let c = load_calibration(path, a.camera.as_deref(), a.json)?;
            let size = c.size();
            (CALIBRATED.to_string(), c.params, Some(size))
        }
        // A registered name is used as is; a path, or a name found as <Name>.so along
        // --plugin-path and OBSCURA_PLUGIN_PATH, is loaded into the registry first.
        (None, Some(projection)) => (
            ensure(&mut registry, projection, search).map_err(|e| e.to_string())?,
            ParamList::new(),
            None,
        ),
        (None, None) => return Err("expected a projection or --calibration FILE".into()),
    };
    let opts = options(a, calibrated)?;
    let factory = registry.find(&name).map_err(|e| e.to_string())?;
    merge_param_args(&mut params, &a.params, factory.name(), factory.param_table())?;
    // Panics are caught and reported by the checker; the default hook would print each one as well.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let report = check_registered(&mut registry, &name, &params, &opts);
    std::panic::set_hook(hook);
    let report = report.map_err(|e| e.to_string())?;
    if a.json {
        outln!("{}", report.to_json());
    } else {
        outln!("{report}");
    }
    let failed = report.failed();
    if failed.is_empty() {
        Ok(None)
    } else {
        let names: Vec<&str> = failed.iter().map(|k| k.id()).collect();
        Ok(Some(format!(
            "projection {name} broke the projection contract: {} check{} failed ({})",
            failed.len(),
            if failed.len() == 1 { "" } else { "s" },
            names.join(", ")
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_messages_become_json_strings() {
        assert_eq!(json_string("a \"b\"\\c\nd"), "\"a \\\"b\\\"\\\\c\\u000ad\"");
    }

    #[test]
    fn formats_are_read_and_bad_ones_refused() {
        assert_eq!(parse_checked_format("96x72"), Ok((96, 72)));
        assert_eq!(parse_checked_format(" 8 X 6 "), Ok((8, 6)));
        for bad in ["96", "0x5", "ax5", "100000x100000"] {
            assert!(
                parse_checked_format(bad).unwrap_err().contains("WIDTHxHEIGHT"),
                "{bad}"
            );
        }
    }
}
