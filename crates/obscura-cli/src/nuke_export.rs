//! `obscura export-nuke`: a calibrated camera as a Nuke `LD_3DE4_*` node, so the loop closes in the
//! compositor. A 3DEqualizer lens is written as it is; any other calibration with a pinhole
//! (COLMAP's and OpenCV's `f`/`fx, fy, cx, cy` models) is first fitted with
//! `3DE4 Radial - Standard, Degree 4` ([`obscura_calibration::lens3de::fit_radial_standard`]) and
//! the fit's residual is reported. The node is the library's
//! ([`obscura_calibration::files::nuke::write_node`]); the script adds a `Root` node with the plate's
//! format, so that reading it back gives the same plate.

use std::path::PathBuf;

use clap::Args;
use obscura_calibration::files::nuke::write_node;
use obscura_calibration::lens3de::{Kind, fit_radial_standard};
use obscura_calibration::{CameraModel, model_info};
use obscura_render::job::Calibrated;

use crate::stdout::outln;

/// Grid points per side of the plate a fit is computed on.
const FIT_GRID: usize = 33;

/// Arguments of `obscura export-nuke`.
#[derive(Args, Debug)]
pub struct ExportNukeArgs {
    /// The calibration (a Nuke script with 3DE LD nodes, a 3DE lens export, COLMAP cameras.txt,
    /// OpenCV YAML/JSON, Kalibr camchain.yaml).
    #[arg(long, value_name = "FILE")]
    calibration: PathBuf,
    /// The camera of a file holding several (a Nuke LD node's name, a COLMAP CAMERA_ID, …).
    #[arg(long, value_name = "ID")]
    camera: Option<String>,
    /// The frame of an animated lens (a Nuke script's curves) [default: the script's own].
    #[arg(long, value_name = "N")]
    frame: Option<f64>,
    /// The node's name [default: LD_3DE4_obscura].
    #[arg(long, default_value = "LD_3DE4_obscura")]
    name: String,
    /// The node's direction knob.
    #[arg(long, default_value = "undistort", value_parser = ["undistort", "distort"])]
    direction: String,
    /// The Nuke script to write (atomically).
    #[arg(short, long, default_value = "lens.nk")]
    output: PathBuf,
}

/// Runs `obscura export-nuke`.
///
/// # Errors
/// The calibration's error, a camera without a pinhole to fit, a fit that fails, or the write.
pub fn run(a: &ExportNukeArgs) -> Result<(), String> {
    let c =
        Calibrated::load_frame(&a.calibration, a.camera.as_deref(), a.frame).map_err(|e| e.to_string())?;
    let cal = &c.calibration;
    let (w, h) = (cal.width, cal.height);
    let values: Vec<f64> = cal.params.iter().map(|n| n.value).collect();
    let (kind, params, how) = match Kind::from_name(&cal.model) {
        Some(kind) => (kind, values, format!("{} as it is", kind.name())),
        None => {
            let shift = cal.pixel_convention.shift();
            let info = model_info(&cal.model)
                .ok_or_else(|| format!("{}: unknown model {}", cal.source, cal.model))?;
            let pinhole = if info.params.starts_with("fx, fy, cx, cy") {
                [values[0], values[1], values[2] - shift, values[3] - shift]
            } else if info.params.starts_with("f, cx, cy") {
                [values[0], values[0], values[1] - shift, values[2] - shift]
            } else {
                return Err(format!(
                    "{}: a {} camera has no pinhole (fx, fy, cx, cy) for a 3DE Radial Standard lens to undistort to; export-nuke fits COLMAP's and OpenCV's pinhole-based models",
                    cal.source, cal.model
                ));
            };
            let poly =
                |n: &[obscura_calibration::files::Number]| n.iter().map(|v| v.value).collect::<Vec<_>>();
            let model = CameraModel::new(
                &cal.model,
                &values,
                &poly(&cal.polynomial),
                &poly(&cal.inverse_polynomial),
                f64::from(w),
                f64::from(h),
            )
            .map_err(|e| format!("{}: {e}", cal.source))?;
            let ray = |px: [f64; 2]| model.pixel_to_ray([px[0] + shift, px[1] + shift]).map(|r| r.v);
            let fit = fit_radial_standard(pinhole, f64::from(w), f64::from(h), &ray, FIT_GRID)
                .map_err(|e| format!("{}: fitting 3DE4 Radial - Standard, Degree 4: {e}", cal.source))?;
            let how = format!(
                "3DE4 Radial - Standard, Degree 4 fitted to its {} model: residual {:.4} px rms, {:.4} px max over {} points of a {FIT_GRID}x{FIT_GRID} grid",
                cal.model, fit.rms_px, fit.max_px, fit.points
            );
            (Kind::RadialStandard4, fit.params, how)
        }
    };
    let node = write_node(kind, &params, &a.name, &a.direction)?;
    let script = format!(
        "# written by obscura export-nuke from {}\nRoot {{\n inputs 0\n format \"{w} {h} 0 0 {w} {h} 1 plate\"\n}}\n{node}",
        cal.source
    );
    obscura_image::atomic::write_atomically(&a.output, |out| {
        std::io::Write::write_all(out, script.as_bytes())
    })
    .map_err(|e| e.to_string())?;
    outln!(
        "wrote {}: node {} ({}) for the {w}x{h} plate, {how}",
        a.output.display(),
        a.name,
        kind.nuke_class()
    );
    Ok(())
}
