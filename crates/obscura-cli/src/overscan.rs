//! `obscura render --overscan PIXELS|LEFT,TOP,RIGHT,BOTTOM|auto`: the CG for a plate, rendered
//! larger than the plate so that redistorting it leaves no uncovered edge, and written so that a
//! compositor lines it up with the plate without a reformat.
//!
//! The sizes, the screen window and the placement in the EXR are [`obscura_image::tiles::Overscan`]'s
//! and [`obscura_image::tiles::place_overscan_with`]'s; the camera JSON's edit is
//! [`obscura_render::metadata::with_overscan`]. What is here is the command's own:
//!
//! - **Which camera.** With `--calibration` holding a 3DEqualizer lens, the render is the lens's
//!   undistorted pinhole ([`obscura_calibration::lens3de::Lens::pinhole`], the camera of Nuke's
//!   `LD_3DE4_*` node in undistort mode, lens-centre offset included) as `CalibratedCamera`'s
//!   `PINHOLE` on the overscanned frame; `auto` takes the margins of Nuke's bounding box of the
//!   undistorted plate ([`Overscan::covering`] of [`obscura_calibration::lens3de::Lens::undistorted_box`]).
//!   Without a calibration, the scene's projection renders with its screen window pushed out at
//!   the same pixel pitch ([`Overscan::screen_window`]); only a given margin is possible there.
//! - **Which files.** Every flat EXR is placed (display window = the plate, data window = the
//!   overscanned box from a negative origin; its `obscura:camera` header follows), the PNG preview
//!   is cropped to the plate (a PNG has no data window: it shows what Nuke's viewer shows) and the
//!   camera JSON states the plate, the data window and the margins. Deep EXR, TIFF and DNG outputs,
//!   a sensor, a crop window and tiles are refused with the reason: their files or frames have no
//!   place for a data window past the plate.

use std::path::{Path, PathBuf};

use obscura_calibration::files::{Calibration, Number};
use obscura_calibration::lens3de::{Kind, Lens};
use obscura_host::CropWindow;
use obscura_image::tiles::{Overscan, crop_png_to_plate, place_overscan_with};
use obscura_render::job::Calibrated;
use obscura_render::metadata::with_overscan;
use obscura_scene::{Display, DisplayDriver, Scene};
use obscura_sdk::{Format, ParamList, ScreenWindow};

/// `--overscan` as given.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OverscanArg {
    /// `auto`: the margins of the lens's undistorted box, as Nuke's `LD_3DE4_*` node computes it.
    Auto,
    /// `PIXELS` or `LEFT,TOP,RIGHT,BOTTOM`.
    Given(Overscan),
}

/// Reads `--overscan`: `auto`, `PIXELS` or `LEFT,TOP,RIGHT,BOTTOM`.
pub fn parse_overscan(text: &str) -> Result<OverscanArg, String> {
    if text.trim() == "auto" {
        return Ok(OverscanArg::Auto);
    }
    Overscan::parse(text)
        .map(OverscanArg::Given)
        .map_err(|e| format!("{e}, or auto (the lens's undistorted box)"))
}

/// An overscanned render resolved for one frame: the margins, the plate, and what changes in the
/// scene.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The margins.
    pub overscan: Overscan,
    /// The plate's size (the display window).
    pub plate: (u32, u32),
    /// The overscanned frame's screen window (no calibration) or the lens's pinhole parameters.
    camera: PlanCamera,
}

/// What renders the overscanned frame.
#[derive(Debug, Clone)]
enum PlanCamera {
    /// The scene's projection with this screen window.
    Window(ScreenWindow),
    /// `CalibratedCamera` with these parameters (the lens's undistorted pinhole).
    Pinhole(ParamList),
}

impl Plan {
    /// The plan for `scene` as configured (the plate is its format; its projection and, with a
    /// calibration, the calibrated camera's parameters are set).
    ///
    /// # Errors
    /// A message saying what `--overscan` cannot do with this render: `auto` without a 3DE lens, a
    /// calibration that is not a 3DE lens, a crop window, a display of a kind that has no data
    /// window, a sensor, a lens without an undistorted box.
    pub fn new(
        arg: OverscanArg,
        scene: &Scene,
        calibration: Option<&Calibrated>,
        displays: &[Display],
    ) -> Result<Plan, String> {
        let cam = &scene.camera;
        if cam.crop_window != CropWindow::default() {
            return Err(
                "--overscan renders the whole overscanned frame: the scene's CropWindow (or --crop) cannot be combined with it"
                    .into(),
            );
        }
        if scene.sensor.is_some() {
            return Err("--overscan: a sensor simulates the plate's own pixels; render the overscanned CG without --sensor / Option \"sensor\"".into());
        }
        if let Some(d) = displays.iter().find(|d| {
            matches!(
                d.driver,
                DisplayDriver::DeepExr | DisplayDriver::Tiff | DisplayDriver::Dng
            )
        }) {
            return Err(format!(
                "--overscan: {} is a {:?} display, which has no data window to place past the plate; write OpenEXR (and a PNG preview)",
                d.path.display(),
                d.driver
            ));
        }
        let plate = (cam.format.width, cam.format.height);
        let (w, h) = plate;
        match calibration {
            Some(c) => {
                let cal = &c.calibration;
                let lens = lens_of(cal, plate, "--overscan with --calibration")?;
                let overscan = match arg {
                    OverscanArg::Given(o) => o,
                    OverscanArg::Auto => {
                        let b = lens.undistorted_box(f64::from(w), f64::from(h)).ok_or_else(|| {
                            format!(
                                "--overscan auto: the lens of {} undistorts no edge point of the {w}x{h} plate (all beyond its fold)",
                                cal.source
                            )
                        })?;
                        Overscan::covering(b, w, h).map_err(|e| format!("--overscan auto: {e}"))?
                    }
                };
                let pinhole = pinhole_calibration(cal, &lens, overscan, plate);
                let params = pinhole.param_list().map_err(|e| e.to_string())?;
                Ok(Plan {
                    overscan,
                    plate,
                    camera: PlanCamera::Pinhole(params),
                })
            }
            None => {
                let OverscanArg::Given(overscan) = arg else {
                    return Err("--overscan auto sizes the margins from a lens: give --calibration with a 3DEqualizer lens (a Nuke LD_3DE4_* script or a 3DE lens export), or PIXELS".into());
                };
                let win = cam.screen_window();
                let pushed =
                    overscan.screen_window([win.left, win.right, win.bottom, win.top].map(f64::from), w, h);
                let pushed = pushed.map(|v| v as f32);
                Ok(Plan {
                    overscan,
                    plate,
                    camera: PlanCamera::Window(ScreenWindow::new(pushed[0], pushed[1], pushed[2], pushed[3])),
                })
            }
        }
    }

    /// Sets `scene` up to render the overscanned frame: the render size, and the pushed-out screen
    /// window or the lens's pinhole.
    pub fn apply(&self, scene: &mut Scene) {
        let (rw, rh) = self.overscan.render_size(self.plate.0, self.plate.1);
        let aspect = scene.camera.format.pixel_aspect;
        scene.camera.format = Format::new(rw, rh);
        scene.camera.format.pixel_aspect = aspect;
        match &self.camera {
            PlanCamera::Window(win) => scene.camera.screen_window = Some(*win),
            PlanCamera::Pinhole(params) => {
                scene.projection = obscura_render::job::CALIBRATED.to_string();
                scene.projection_params = params.clone();
            }
        }
    }

    /// One line saying what is rendered.
    #[must_use]
    pub fn describe(&self) -> String {
        let (w, h) = self.plate;
        let (rw, rh) = self.overscan.render_size(w, h);
        let dw = self.overscan.data_window(w, h);
        format!(
            "overscan {} (left,top,right,bottom): a {rw}x{rh} render, data window [{}, {}) x [{}, {}) over the {w}x{h} plate{}",
            self.overscan,
            dw.position.0,
            dw.position.0 + rw as i32,
            dw.position.1,
            dw.position.1 + rh as i32,
            match self.camera {
                PlanCamera::Window(_) => "",
                PlanCamera::Pinhole(_) => ", through the lens's undistorted pinhole",
            }
        )
    }

    /// Places the files of a rendered frame on the plate: EXRs placed, the PNG cropped, the camera
    /// JSON rewritten (last, so that "complete" still means every file is final).
    ///
    /// # Errors
    /// The file that could not be placed, and why.
    pub fn place(&self, written: &[PathBuf]) -> Result<(), String> {
        let (w, h) = self.plate;
        let o = self.overscan;
        let ext = |p: &Path| {
            p.extension()
                .and_then(|e| e.to_str())
                .map(str::to_ascii_lowercase)
        };
        let (json, images): (Vec<&PathBuf>, Vec<&PathBuf>) = written
            .iter()
            .partition(|p| p.to_string_lossy().ends_with(".camera.json"));
        for path in images {
            match ext(path).as_deref() {
                Some("exr") => place_overscan_with(path, o, w, h, &|name, value| {
                    (name == "obscura:camera")
                        .then(|| with_overscan(value, o, w, h))
                        .flatten()
                })
                .map_err(|e| e.to_string())?,
                Some("png") => crop_png_to_plate(path, o, w, h).map_err(|e| e.to_string())?,
                _ => {}
            }
        }
        for path in json {
            let text =
                std::fs::read_to_string(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
            let placed = with_overscan(&text, o, w, h)
                .ok_or_else(|| format!("{}: not the camera JSON of the overscanned frame", path.display()))?;
            obscura_image::atomic::write_atomically(path, |out| {
                std::io::Write::write_all(out, placed.as_bytes())
            })
            .map_err(|e| e.to_string())?;
        }
        Ok(())
    }
}

/// The 3DEqualizer lens of `cal` on a `plate`-sized plate, as the render evaluates it (values as
/// stored, in `f32`); `what` names the option that needs it.
fn lens_of(cal: &Calibration, plate: (u32, u32), what: &str) -> Result<Lens, String> {
    let kind = Kind::from_name(&cal.model).ok_or_else(|| {
        format!(
            "{what} needs a 3DEqualizer lens (the undistorted pinhole is its model's); {} holds a {} camera",
            cal.file, cal.model
        )
    })?;
    let values: Vec<f64> = cal.params.iter().map(|n| f64::from(n.value as f32)).collect();
    Lens::new(kind, &values, f64::from(plate.0), f64::from(plate.1))
        .map_err(|e| format!("{}: {e}", cal.source))
}

/// The undistorted pinhole of the 3DEqualizer lens in `c` on the calibration's plate (what Nuke's
/// `LD_3DE4_*` node undistorts the plate to): `CalibratedCamera`'s `PINHOLE` of
/// [`Lens::pinhole`], for `obscura stmap --from-undistorted` / `--to-undistorted`.
///
/// # Errors
/// A message when `c` is not a 3DE lens (`what` names the option) or its values are refused.
pub fn undistorted(c: &Calibrated, what: &str) -> Result<Calibrated, String> {
    let plate = c.size();
    let lens = lens_of(&c.calibration, plate, what)?;
    let calibration = pinhole_calibration(&c.calibration, &lens, Overscan::default(), plate);
    let params = calibration.param_list().map_err(|e| e.to_string())?;
    Ok(Calibrated { calibration, params })
}

/// The lens's undistorted pinhole on the overscanned frame, as a calibration of COLMAP's `PINHOLE`
/// (`fx, fy, cx + left, cy + top`), each number attributed to the lens's entry in `cal`.
fn pinhole_calibration(cal: &Calibration, lens: &Lens, o: Overscan, plate: (u32, u32)) -> Calibration {
    let [fx, fy, cx, cy] = lens.pinhole();
    let line = cal.params.first().map_or(1, |n| n.line);
    let number = |value: f64| Number {
        text: format!("{value}"),
        value,
        line,
    };
    let (rw, rh) = o.render_size(plate.0, plate.1);
    let mut c = cal.clone();
    c.model = "PINHOLE".into();
    c.params = vec![
        number(fx),
        number(fy),
        number(cx + f64::from(o.left)),
        number(cy + f64::from(o.top)),
    ];
    c.polynomial.clear();
    c.inverse_polynomial.clear();
    c.width = rw;
    c.height = rh;
    c.pixel_convention = obscura_calibration::PixelConvention::Colmap;
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overscan_arguments_are_read_and_bad_ones_refused() {
        assert_eq!(parse_overscan("auto"), Ok(OverscanArg::Auto));
        assert_eq!(
            parse_overscan("16"),
            Ok(OverscanArg::Given(Overscan::uniform(16)))
        );
        assert_eq!(
            parse_overscan("1,2,3,4"),
            Ok(OverscanArg::Given(Overscan {
                left: 1,
                top: 2,
                right: 3,
                bottom: 4
            }))
        );
        for bad in ["-3", "1,2", "big", ""] {
            let e = parse_overscan(bad).unwrap_err();
            assert!(
                e.contains(&format!("'{bad}'")) && e.ends_with("or auto (the lens's undistorted box)"),
                "{e}"
            );
        }
    }
}
