//! One `obscura render` job from start to files: load, override, prepare, render, write.
//!
//! Kept in the library (not the binary) so that tests and other front ends run exactly what the
//! command runs.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use obscura_scene::{Aov, Display, DisplayDriver, Scene};

use crate::deep::{DeepCompression, write_deep_exr};
use crate::output::{OutputError, write_exr, write_png};
use crate::render::RenderOutput;

/// The built-in scene, rendered when no scene file is given.
pub const DEFAULT_SCENE: &str = include_str!("../scenes/default.rib");

/// The displays to write: the scene's own, or `output` (an EXR with beauty, alpha, z, N, P and
/// cameraDirection) when given; with neither, `render.exr`. A PNG preview is added beside the first
/// EXR when no display is a PNG already.
#[must_use]
pub fn displays(scene: &Scene, output: Option<&Path>) -> Vec<Display> {
    let mut list = match output {
        Some(path) => vec![Display {
            path: path.to_path_buf(),
            driver: if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
                DisplayDriver::Png
            } else {
                DisplayDriver::OpenExr
            },
            aovs: vec![Aov::Ci, Aov::Alpha, Aov::Z, Aov::N, Aov::P, Aov::CameraDirection],
            half: false,
        }],
        None if scene.displays.is_empty() => vec![Display {
            path: PathBuf::from("render.exr"),
            driver: DisplayDriver::OpenExr,
            aovs: vec![Aov::Ci, Aov::Alpha, Aov::Z],
            half: false,
        }],
        None => scene.displays.clone(),
    };
    if !list.iter().any(|d| d.driver == DisplayDriver::Png)
        && let Some(exr) = list.iter().find(|d| d.driver != DisplayDriver::Png)
    {
        {
            let preview = Display {
                path: exr.path.with_extension("png"),
                driver: DisplayDriver::Png,
                aovs: vec![Aov::Ci, Aov::Alpha],
                half: false,
            };
            list.push(preview);
        }
    }
    list
}

/// True when any display is deep.
#[must_use]
pub fn wants_deep(displays: &[Display]) -> bool {
    displays.iter().any(|d| d.driver == DisplayDriver::DeepExr)
}

/// Writes every display, each atomically. Returns the paths written.
///
/// # Errors
/// The first file that could not be written, named.
pub fn write_displays(
    displays: &[Display],
    out: &RenderOutput,
    pixel_aspect: f32,
    attributes: &[(&str, String)],
) -> Result<Vec<PathBuf>, OutputError> {
    let mut written = Vec::new();
    for d in displays {
        match d.driver {
            DisplayDriver::OpenExr => {
                write_exr(&d.path, &out.film, &d.aovs, d.half, pixel_aspect, attributes)?
            }
            DisplayDriver::Png => write_png(&d.path, &out.film)?,
            DisplayDriver::DeepExr => match &out.deep {
                Some(deep) => write_deep_exr(&d.path, deep, DeepCompression::Zips)?,
                None => continue,
            },
        }
        written.push(d.path.clone());
    }
    Ok(written)
}

/// A flag set by the first Ctrl-C: the render stops after the tiles in flight and writes what it has.
pub static CANCEL: AtomicBool = AtomicBool::new(false);
