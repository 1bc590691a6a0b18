//! Baseline TIFF, the file RenderMan's `file`, `tiff`, `zfile` and `shadow` drivers write (through
//! the `tiff` crate, Deflate-compressed).
//!
//! A TIFF holds either the colour or one float AOV:
//! - with `Ci` among the AOVs: 8-bit RGB, or RGBA when alpha is asked for too, quantized as the RI
//!   default `Quantize "rgba" 255 0 255` does (alpha declared as associated, `ExtraSamples` = 1): `code = clamp(round(255·v), 0, 255)` of the linear,
//!   premultiplied value (no transfer curve: classic RenderMan applies `Exposure` gamma instead, and
//!   no dither, so that a render is repeatable bit for bit);
//! - otherwise the first of `z`, alpha, `N`, `P`, `cameraDirection` asked for, as 32-bit float
//!   (grey for `z` and alpha, RGB for the vectors): `z` is the projection's deep metric, `+∞` where no
//!   surface was hit, as RenderMan's `zfile` and `shadow` drivers store depth.

use std::path::Path;

use ::tiff::encoder::{Compression, DeflateLevel, TiffEncoder, colortype};
use ::tiff::tags::ExtraSamples;
use obscura_scene::Aov;

use super::{OutputError, quantize, resolve};
use crate::atomic::write_atomically;
use crate::film::{Film, SampleValues};

/// Writes the film's crop as a TIFF of `aovs` (see the module docs), atomically.
///
/// # Errors
/// [`OutputError::EmptyImage`], [`OutputError::NoChannels`] or [`OutputError::Write`], each naming
/// `path`.
pub fn write_tiff(path: &Path, film: &Film, aovs: &[Aov]) -> Result<(), OutputError> {
    let crop = film.crop();
    if crop.is_empty() {
        return Err(OutputError::EmptyImage {
            path: path.to_path_buf(),
        });
    }
    let (w, h) = (crop.width(), crop.height());
    let pixels = resolve(film);
    let tiff_err = |e: ::tiff::TiffError| match e {
        ::tiff::TiffError::IoError(e) => e,
        other => std::io::Error::other(other),
    };
    let vectors = |f: fn(&SampleValues) -> [f32; 3]| -> Vec<f32> { pixels.iter().flat_map(f).collect() };
    let data = if aovs.contains(&Aov::Ci) {
        let alpha = aovs.contains(&Aov::Alpha);
        let codes: Vec<u8> = pixels
            .iter()
            .flat_map(|v| {
                let rgba = [v.ci.r, v.ci.g, v.ci.b, v.alpha];
                rgba.into_iter().take(if alpha { 4 } else { 3 }).map(quantize)
            })
            .collect();
        Tiff::Eight { codes, alpha }
    } else if aovs.contains(&Aov::Z) {
        Tiff::Grey(pixels.iter().map(|v| v.z).collect())
    } else if aovs.contains(&Aov::Alpha) {
        Tiff::Grey(pixels.iter().map(|v| v.alpha).collect())
    } else if aovs.contains(&Aov::N) {
        Tiff::Rgb(vectors(|v| v.n.to_array()))
    } else if aovs.contains(&Aov::P) {
        Tiff::Rgb(vectors(|v| v.p.to_array()))
    } else if aovs.contains(&Aov::CameraDirection) {
        Tiff::Rgb(vectors(|v| v.camera_direction.to_array()))
    } else {
        return Err(OutputError::NoChannels {
            path: path.to_path_buf(),
        });
    };
    write_atomically(path, |out| {
        let mut enc = TiffEncoder::new(out)
            .map_err(tiff_err)?
            .with_compression(Compression::Deflate(DeflateLevel::Balanced));
        match &data {
            Tiff::Eight { codes, alpha: true } => {
                // RGB plus one extra sample marked as associated (premultiplied) alpha, as TIFF 6.0
                // says an alpha channel is declared.
                let mut image = enc.new_image::<colortype::RGB8>(w, h).map_err(tiff_err)?;
                image
                    .extra_samples(&[ExtraSamples::AssociatedAlpha])
                    .map_err(tiff_err)?;
                image.write_data(codes)
            }
            Tiff::Eight { codes, alpha: false } => enc.write_image::<colortype::RGB8>(w, h, codes),
            Tiff::Grey(v) => enc.write_image::<colortype::Gray32Float>(w, h, v),
            Tiff::Rgb(v) => enc.write_image::<colortype::RGB32Float>(w, h, v),
        }
        .map_err(tiff_err)
    })?;
    Ok(())
}

/// The samples of one TIFF.
enum Tiff {
    /// 8-bit colour codes, RGB or RGBA.
    Eight { codes: Vec<u8>, alpha: bool },
    /// One float per pixel.
    Grey(Vec<f32>),
    /// Three floats per pixel.
    Rgb(Vec<f32>),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::Filter;
    use glam::Vec3;
    use obscura_host::PixelRect;
    use obscura_scene::{FilterKind, PixelFilter};
    use obscura_sdk::Rgb;
    use std::process::Command;

    /// A 5×3 film whose pixel (x, y) holds known values (one sample at each centre, box filter).
    fn film() -> Film {
        let f = Filter::new(&PixelFilter {
            kind: FilterKind::Box,
            width_x: 1.0,
            width_y: 1.0,
        })
        .unwrap();
        let crop = PixelRect {
            x0: 0,
            y0: 0,
            x1: 5,
            y1: 3,
        };
        let mut film = Film::new(5, 3, crop, f);
        let mut t = film.tile(crop);
        for y in 0..3 {
            for x in 0..5 {
                let (fx, fy) = (x as f32, y as f32);
                let v = SampleValues {
                    ci: Rgb::new(0.2 * fx, 0.5 * fy, 1.5),
                    alpha: 0.25 * fx,
                    z: if x == 0 {
                        f32::INFINITY
                    } else {
                        2.0 + fx + 10.0 * fy
                    },
                    n: Vec3::new(fx, -fy, 0.5),
                    ..SampleValues::EMPTY
                };
                t.add_sample(fx + 0.5, fy + 0.5, &v);
            }
        }
        film.merge(t);
        film
    }

    /// OpenCV's reading of `path` (IMREAD_UNCHANGED) as `shape;dtype;values…` with channels in RGB
    /// order; `None` when python3 has no cv2 (an error when OBSCURA_REQUIRE_OPENCV is set).
    fn opencv_read(path: &Path) -> Option<String> {
        let script = "import sys, cv2, numpy as np\n\
            a = cv2.imread(sys.argv[1], cv2.IMREAD_UNCHANGED)\n\
            a = a[..., [2, 1, 0] + ([3] if a.shape[2] == 4 else [])] if a.ndim == 3 else a\n\
            print(';'.join([str(list(a.shape)), str(a.dtype)] + [repr(float(v)) for v in a.ravel()]))";
        let out = Command::new("python3")
            .args(["-c", script])
            .arg(path)
            .output()
            .ok()?;
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(
                err.contains("No module named") && std::env::var_os("OBSCURA_REQUIRE_OPENCV").is_none(),
                "{err}"
            );
            eprintln!("skipping the independent TIFF check: {err}");
            return None;
        }
        // libtiff warns about a file whose tags disagree (an alpha channel not declared, …).
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("Warning"), "libtiff: {err}");
        Some(String::from_utf8(out.stdout).unwrap().trim().to_string())
    }

    #[test]
    fn colour_is_quantized_linearly_and_read_back_by_opencv() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.tif");
        write_tiff(&path, &film(), &[Aov::Ci, Aov::Alpha]).unwrap();
        let Some(got) = opencv_read(&path) else { return };
        let mut expected = vec!["[3, 5, 4]".to_string(), "uint8".to_string()];
        for y in 0..3 {
            for x in 0..5 {
                let (fx, fy) = (x as f32, y as f32);
                // The RI default quantization: round(255·v), clamped.
                for v in [0.2 * fx, 0.5 * fy, 1.5, 0.25 * fx] {
                    expected.push(format!("{:?}", f64::from((255.0 * v).round().clamp(0.0, 255.0))));
                }
            }
        }
        assert_eq!(got, expected.join(";"));
        // Without alpha: three channels.
        write_tiff(&path, &film(), &[Aov::Ci]).unwrap();
        let Some(got) = opencv_read(&path) else { return };
        assert!(got.starts_with("[3, 5, 3];uint8;0.0;0.0;255.0;51.0;"), "{got}");
    }

    #[test]
    fn depth_is_float_with_infinity_where_nothing_was_hit() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("shadow.z");
        write_tiff(&path, &film(), &[Aov::Z]).unwrap();
        let Some(got) = opencv_read(&path) else { return };
        let mut expected = vec!["[3, 5]".to_string(), "float32".to_string()];
        for y in 0..3 {
            for x in 0..5 {
                let z = if x == 0 {
                    f32::INFINITY
                } else {
                    2.0 + x as f32 + 10.0 * y as f32
                };
                expected.push(format!("{:?}", f64::from(z)));
            }
        }
        assert_eq!(got, expected.join(";"));
        // A vector AOV alone is float RGB.
        write_tiff(&path, &film(), &[Aov::N]).unwrap();
        let Some(got) = opencv_read(&path) else { return };
        assert!(
            got.starts_with("[3, 5, 3];float32;0.0;-0.0;0.5;1.0;-0.0;0.5;"),
            "{got}"
        );
    }

    #[test]
    fn no_writable_aov_is_an_error_naming_the_file() {
        let e = write_tiff(Path::new("x.tif"), &film(), &[]).unwrap_err();
        assert_eq!(e.to_string(), "cannot write x.tif: no channels requested");
    }
}
