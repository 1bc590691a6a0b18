//! `Display "name" "driver" "mode"`: where the image goes, as a file whatever the driver.
//!
//! RenderMan scenes name drivers of their renderer and their time; each is written as a file:
//!
//! | driver | written as |
//! |---|---|
//! | `openexr`, `exr`, `png`, `deepexr`, `tiff` | that format, at the name given |
//! | `file` | by the name's extension (`.exr`, `.png`, `.tif`); otherwise TIFF at the name given, as RenderMan's `file` driver writes |
//! | `zfile`, `shadow` | the depth alone (`z`), as a float TIFF at the name given (OpenEXR for `.exr`) |
//! | `framebuffer`, `it`, `x11`, `windows`, `mplay` | there is no window: OpenEXR at the name with `.exr` (beside the scene when the name's folders do not exist), with a note |
//! | any other | TIFF at the name with `.tif` (the name as given when it ends in `.exr`, `.png` or `.tif`), with a warning |
//!
//! The mode is `rgb`, `rgba`, `rgbz`, `rgbaz`, `a`, `z`, `az`, or a comma-separated list of AOV names
//! (`Ci`, `a`, `z`, `N`, `P`, `cameraDirection` and the ground-truth AOVs `cameraZ`, `distance`,
//! `Pcamera`, `Ncamera`, `objectId`, `instanceId`, `materialId`, `flowForward`, `flowBackward`,
//! `flowValid`, and `albedo`, `uv`; a leading type such as `color Ci` is allowed). An AOV
//! the renderer does not produce is left out with a warning; a display left with none is skipped.
//!
//! A name starting with `+` adds a display; without it the display replaces the ones before. Two
//! displays naming one file is an error naming both requests.

use std::path::{Path, PathBuf};

use super::lex::Value;
use super::request::{Req, get_string};
use super::{Reader, RibError};
use crate::aov::{AOVS, Aov};
use crate::types::{Display, DisplayDriver};

/// RenderMan's mode words and depth aliases a `Display` mode may use beside the names of the AOV
/// table ([`AOVS`]).
const RIB_CHANNELS: [(&str, &[Aov]); 7] = [
    ("rgb", &[Aov::Ci]),
    ("rgba", &[Aov::Ci, Aov::Alpha]),
    ("rgbz", &[Aov::Ci, Aov::Z]),
    ("rgbaz", &[Aov::Ci, Aov::Alpha, Aov::Z]),
    ("az", &[Aov::Alpha, Aov::Z]),
    ("Z", &[Aov::Z]),
    ("depth", &[Aov::Z]),
];

/// Drivers that show the image in a window.
const INTERACTIVE: [&str; 6] = ["framebuffer", "it", "x11", "windows", "mplay", "iv"];

/// What a driver and name become: the driver written, the path, the AOVs forced (depth drivers), and a
/// note for the scene's warnings.
struct Target {
    driver: DisplayDriver,
    path: PathBuf,
    depth_only: bool,
    note: Option<String>,
}

/// The driver a file extension names, if any.
fn by_extension(path: &Path) -> Option<DisplayDriver> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "exr" => Some(DisplayDriver::OpenExr),
        "png" => Some(DisplayDriver::Png),
        "tif" | "tiff" => Some(DisplayDriver::Tiff),
        "dng" => Some(DisplayDriver::Dng),
        _ => None,
    }
}

/// Where a `Display` with `driver` and the resolved `path` writes (see the module docs); `base` is
/// the scene's directory.
fn target(driver: &str, path: PathBuf, base: &Path) -> Target {
    let plain = |driver| Target {
        driver,
        path: path.clone(),
        depth_only: false,
        note: None,
    };
    match driver {
        "openexr" | "exr" => plain(DisplayDriver::OpenExr),
        "png" => plain(DisplayDriver::Png),
        "deepexr" => plain(DisplayDriver::DeepExr),
        "dng" => plain(DisplayDriver::Dng),
        "tiff" | "tif" => plain(DisplayDriver::Tiff),
        "file" => plain(by_extension(&path).unwrap_or(DisplayDriver::Tiff)),
        "zfile" | "shadow" => Target {
            depth_only: true,
            ..plain(match by_extension(&path) {
                Some(DisplayDriver::OpenExr) => DisplayDriver::OpenExr,
                _ => DisplayDriver::Tiff,
            })
        },
        d if INTERACTIVE.contains(&d) => {
            let exr = with_extension(&path, "exr");
            // A window's name is a title, often with its exporter's folders (RenderMan for Maya
            // writes `renderman/scene/images/scene`): when those do not exist, beside the scene.
            let exr = match (exr.parent(), exr.file_name()) {
                (Some(dir), Some(name)) if !dir.as_os_str().is_empty() && !dir.is_dir() => base.join(name),
                _ => exr,
            };
            Target {
                note: Some(format!(
                    "Display driver \"{d}\" shows a window, which a batch render has not: written to {} instead",
                    exr.display()
                )),
                ..Target {
                    path: exr,
                    ..plain(DisplayDriver::OpenExr)
                }
            }
        }
        other => match by_extension(&path) {
            Some(known) => Target {
                note: Some(format!(
                    "Display driver \"{other}\" is not known: written by its extension to {}",
                    path.display()
                )),
                ..plain(known)
            },
            None => {
                let tif = with_extension(&path, "tif");
                Target {
                    note: Some(format!(
                        "Display driver \"{other}\" is not known: written as TIFF to {}",
                        tif.display()
                    )),
                    ..Target {
                        path: tif,
                        ..plain(DisplayDriver::Tiff)
                    }
                }
            }
        },
    }
}

/// `path` with its extension replaced by (or, without one, extended with) `ext`.
fn with_extension(path: &Path, ext: &str) -> PathBuf {
    let mut p = path.to_path_buf();
    p.set_extension(ext);
    p
}

impl Reader {
    /// `Display "name" "driver" "mode"`: replaces the displays, or adds one when the name starts with
    /// `+` (see the module docs).
    pub(super) fn display(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name), Value::Str(driver), Value::Str(mode), rest @ ..] = r.args else {
            return Err(r.err("Display expects \"name\" \"driver\" \"mode\" (3 strings) then parameters"));
        };
        let (append, file) = match name.strip_prefix('+') {
            Some(f) => (true, f),
            None => (false, name.as_str()),
        };
        if file.is_empty() {
            return Err(r.err("Display expects a file name, got \"\""));
        }
        let target = target(driver, r.resolve(file), r.base);
        let aovs = if target.depth_only {
            vec![Aov::Z]
        } else {
            self.display_aovs(r, name, mode)
        };
        let params = self.params(
            r,
            rest,
            &[
                "string type",
                "int[2] origin",
                "string compression",
                "int[4] quantize",
                "float dither",
            ],
            false,
        )?;
        let half = match get_string(&params, "type") {
            None | Some("float") => false,
            Some("half") => true,
            Some(other) => {
                return Err(r.err(format!(
                    "Display: \"string type\" must be \"half\" or \"float\", got \"{other}\""
                )));
            }
        };
        if !append {
            self.scene.displays.clear();
            self.display_origins.clear();
        }
        if let Some(note) = target.note {
            self.warn(r, note);
        }
        if aovs.is_empty() {
            self.warn(
                r,
                format!("Display \"{name}\": no AOV of mode \"{mode}\" is produced here, so the display is skipped"),
            );
            return Ok(());
        }
        if let Some(i) = self.scene.displays.iter().position(|d| d.path == target.path) {
            return Err(r.err(format!(
                "Display \"{name}\" writes {}, which the display at {} writes already: two displays naming one file would overwrite each other",
                target.path.display(),
                self.display_origins[i]
            )));
        }
        self.scene.displays.push(Display {
            path: target.path,
            driver: target.driver,
            aovs,
            half,
        });
        self.display_origins.push(r.at());
        Ok(())
    }

    /// The AOVs of a display mode, in order; names not produced here are warned about and left out.
    fn display_aovs(&mut self, r: &Req<'_>, name: &str, mode: &str) -> Vec<Aov> {
        let mut aovs: Vec<Aov> = Vec::new();
        for channel in mode.split(',').map(str::trim).filter(|c| !c.is_empty()) {
            // "color Ci", "varying float s": the AOV's name is the last word.
            let bare = channel.split_whitespace().last().unwrap_or(channel);
            let table = Aov::from_name(bare).map(|a| std::slice::from_ref(&a.spec().aov));
            match RIB_CHANNELS
                .iter()
                .find(|(n, _)| *n == bare)
                .map(|(_, list)| *list)
                .or(table)
            {
                Some(list) => {
                    for aov in list {
                        if !aovs.contains(aov) {
                            aovs.push(*aov);
                        }
                    }
                }
                None => {
                    let known: Vec<&str> = (RIB_CHANNELS.iter().map(|(n, _)| *n))
                        .chain(AOVS.iter().map(|s| s.name))
                        .collect();
                    self.warn(
                        r,
                        format!(
                            "Display \"{name}\": AOV \"{bare}\" is not produced by this renderer, left out (known: {})",
                            known.join(", ")
                        ),
                    );
                }
            }
        }
        aovs
    }
}
