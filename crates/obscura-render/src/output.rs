//! Flat image files: OpenEXR (through the `exr` crate) and 8-bit sRGB PNG previews.
//!
//! Both are written with [`crate::atomic::write_atomically`], so a reader never sees half a file
//! and a failed write leaves nothing behind.

use std::path::{Path, PathBuf};

use crate::atomic::{AtomicWriteError, write_atomically};
use exr::image::Blocks;
use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Compression, Encoding, FlatSamples, Image, IntegerBounds, Layer,
    LayerAttributes, LineOrder, Text, Vec2, WritableImage, f16,
};
use obscura_scene::Aov;

use crate::film::{Film, SampleValues};

/// An image file could not be written. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// Creating, writing, syncing or renaming the file failed.
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
    /// The crop window (data window) holds no pixel: image files cannot be empty.
    #[error("cannot write {path}: the image has no pixels (empty crop window)")]
    EmptyImage {
        /// The target file.
        path: PathBuf,
    },
    /// No AOV was requested for an EXR.
    #[error("cannot write {path}: no channels requested")]
    NoChannels {
        /// The target file.
        path: PathBuf,
    },
    /// A header attribute cannot be stored under that name.
    #[error("cannot write {path}: header attribute \"{name}\": {reason}")]
    Attribute {
        /// The target file.
        path: PathBuf,
        /// The attribute's name.
        name: String,
        /// Why.
        reason: &'static str,
    },
    /// A deep image is inconsistent (see [`crate::deep::write_deep_exr`]).
    #[error("cannot write {path}: {reason}")]
    InvalidDeepImage {
        /// The target file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// One OpenEXR layer of channels (`f32` or `f16`), as the writers here build them.
pub type FloatExrImage = Image<Layer<AnyChannels<FlatSamples>>>;

/// Stores `attributes` as header strings of `layer` (the projection's name and parameters, for the
/// record).
pub fn add_text_attributes(layer: &mut LayerAttributes, attributes: &[(&str, String)]) {
    for (k, v) in attributes {
        layer
            .other
            .insert(Text::from(*k), AttributeValue::Text(Text::from(v.as_str())));
    }
}

/// Writes `image` to `path` with [`write_atomically`].
///
/// # Errors
/// An [`AtomicWriteError`] naming `path`; the `exr` crate's own errors become its message.
pub fn write_exr_image(image: FloatExrImage, path: &Path) -> Result<(), AtomicWriteError> {
    write_atomically(path, |out| {
        image.write().to_buffered(out).map_err(|e| match e {
            exr::error::Error::Io(e) => e,
            other => std::io::Error::other(other),
        })
    })
}

/// Attribute names the writer sets itself (or that OpenEXR reserves); callers may not override them.
const RESERVED: [&str; 16] = [
    "channels",
    "chunkCount",
    "compression",
    "dataWindow",
    "displayWindow",
    "lineOrder",
    "maxSamplesPerPixel",
    "name",
    "pixelAspectRatio",
    "screenWindowCenter",
    "screenWindowWidth",
    "tiles",
    "type",
    "version",
    "view",
    "multiView",
];

/// The EXR channel names of an AOV, in RenderMan's and Nuke's spelling.
fn channel_names(aov: Aov) -> &'static [&'static str] {
    match aov {
        Aov::Ci => &["R", "G", "B"],
        Aov::Alpha => &["A"],
        Aov::Z => &["Z"],
        Aov::N => &["N.X", "N.Y", "N.Z"],
        Aov::P => &["P.X", "P.Y", "P.Z"],
        Aov::CameraDirection => &["cameraDirection.X", "cameraDirection.Y", "cameraDirection.Z"],
    }
}

/// Component `k` of `aov` in a resolved pixel.
fn component(v: &SampleValues, aov: Aov, k: usize) -> f32 {
    match aov {
        Aov::Ci => [v.ci.r, v.ci.g, v.ci.b][k],
        Aov::Alpha => v.alpha,
        Aov::Z => v.z,
        Aov::N => v.n[k],
        Aov::P => v.p[k],
        Aov::CameraDirection => v.camera_direction[k],
    }
}

/// The crop's resolved pixels, row by row.
fn resolve(film: &Film) -> Vec<SampleValues> {
    let c = film.crop();
    (c.y0..c.y1)
        .flat_map(|y| (c.x0..c.x1).map(move |x| film.pixel(x, y)))
        .collect()
}

/// Writes the film's crop as an OpenEXR with the requested AOVs, atomically.
///
/// Channels: Ci → `R`, `G`, `B`; Alpha → `A`; Z → `Z`; N → `N.X`, `N.Y`, `N.Z`; P → `P.X`, `P.Y`,
/// `P.Z`; CameraDirection → `cameraDirection.X`, `.Y`, `.Z`. ZIP compression (16 scanlines per
/// block); data window = the crop, display window = the full format; `pixelAspectRatio` =
/// `pixel_aspect`. An AOV named twice is written once; OpenEXR itself stores channels sorted by name. `half`
/// applies to every channel (Z and P included: ask for float when depth precision matters). A pixel
/// no sample reached has Z = +∞ (+∞ in half too). `attributes` are stored as header strings (UTF-8
/// bytes); names must be non-empty, at most 255 bytes, free of NUL and not one of OpenEXR's own.
///
/// # Errors
/// [`OutputError::EmptyImage`], [`OutputError::NoChannels`], [`OutputError::Attribute`] or
/// [`OutputError::Write`], each naming `path`.
pub fn write_exr(
    path: &Path,
    film: &Film,
    aovs: &[Aov],
    half: bool,
    pixel_aspect: f32,
    attributes: &[(&str, String)],
) -> Result<(), OutputError> {
    let crop = film.crop();
    if crop.is_empty() {
        return Err(OutputError::EmptyImage {
            path: path.to_path_buf(),
        });
    }
    let mut unique: Vec<Aov> = Vec::new();
    for &aov in aovs {
        if !unique.contains(&aov) {
            unique.push(aov);
        }
    }
    if unique.is_empty() {
        return Err(OutputError::NoChannels {
            path: path.to_path_buf(),
        });
    }
    let mut other = Vec::new();
    for (name, value) in attributes {
        let reason = if name.is_empty() {
            Some("the name is empty")
        } else if name.len() > 255 {
            Some("the name is longer than 255 bytes")
        } else if name.contains('\0') {
            Some("the name contains a NUL byte")
        } else if RESERVED.contains(name) {
            Some("OpenEXR reserves this name")
        } else {
            None
        };
        if let Some(reason) = reason {
            return Err(OutputError::Attribute {
                path: path.to_path_buf(),
                name: (*name).to_string(),
                reason,
            });
        }
        other.push((
            Text::from_slice_unchecked(name.as_bytes()),
            AttributeValue::Text(Text::from_slice_unchecked(value.as_bytes())),
        ));
    }

    let pixels = resolve(film);
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
    for aov in unique {
        for (k, name) in channel_names(aov).iter().enumerate() {
            let values = pixels.iter().map(|v| component(v, aov, k));
            let samples = if half {
                FlatSamples::F16(values.map(f16::from_f32).collect())
            } else {
                FlatSamples::F32(values.collect())
            };
            channels.push(AnyChannel::new(*name, samples));
        }
    }
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let size = (crop.width() as usize, crop.height() as usize);
    let mut layer = Layer::new(
        size,
        LayerAttributes::default(),
        encoding,
        AnyChannels::sort(channels.into()),
    );
    // u32 pixel coordinates beyond i32 cannot be stored; the exr crate reports the overflow.
    layer.attributes.layer_position = Vec2(
        i32::try_from(crop.x0).unwrap_or(i32::MAX),
        i32::try_from(crop.y0).unwrap_or(i32::MAX),
    );
    layer.attributes.other.extend(other);
    let mut image = Image::from_layer(layer);
    let (w, h) = film.size();
    image.attributes.display_window = IntegerBounds::new((0, 0), (w as usize, h as usize));
    image.attributes.pixel_aspect = pixel_aspect;

    Ok(write_exr_image(image, path)?)
}

/// The sRGB transfer function (IEC 61966-2-1) of `linear`, clamped to [0, 1] first (NaN → 0):
/// `12.92·v` up to 0.0031308, `1.055·v^(1/2.4) − 0.055` above.
#[must_use]
pub fn srgb_encode(linear: f32) -> f32 {
    // f64 inside so that 1 encodes to exactly 1.
    let v = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0) as f64
    };
    let e = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    e as f32
}

/// An 8-bit code for a value in [0, 1] (rounded to nearest).
fn quantize(v: f32) -> u8 {
    // The saturating cast sends NaN to 0.
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Writes the film's crop as an opaque 8-bit RGB PNG preview, atomically.
///
/// Ci is clamped to [0, 1] and encoded with the exact piecewise sRGB curve ([`srgb_encode`]);
/// values are rounded to the nearest 8-bit code. The preview shows the beauty exactly as rendered —
/// including a dome seen behind the geometry, which has alpha 0 — so it carries no alpha channel
/// (viewers would otherwise show the sky as transparent); alpha is in the EXR. The file carries an
/// `sRGB` chunk.
///
/// # Errors
/// [`OutputError::EmptyImage`] or [`OutputError::Write`], each naming `path`.
pub fn write_png(path: &Path, film: &Film) -> Result<(), OutputError> {
    let crop = film.crop();
    if crop.is_empty() {
        return Err(OutputError::EmptyImage {
            path: path.to_path_buf(),
        });
    }
    let mut data = Vec::with_capacity(crop.len() * 3);
    for v in resolve(film) {
        data.extend_from_slice(&[
            quantize(srgb_encode(v.ci.r)),
            quantize(srgb_encode(v.ci.g)),
            quantize(srgb_encode(v.ci.b)),
        ]);
    }
    let png_err = |e| match e {
        png::EncodingError::IoError(e) => e,
        other => std::io::Error::other(other),
    };
    write_atomically(path, |out| {
        let mut encoder = png::Encoder::new(out, crop.width(), crop.height());
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header().map_err(png_err)?;
        writer.write_image_data(&data).map_err(png_err)?;
        writer.finish().map_err(png_err)
    })?;
    Ok(())
}

/// Runs the Python script `tests/<script>` on `path` with the reference OpenEXR library (PyPI
/// `OpenEXR`) and returns its standard output; `None` (after saying so) when `python3` cannot import
/// `OpenEXR` and numpy, unless `OBSCURA_REQUIRE_INDEPENDENT_EXR` is set, which makes that a failure.
#[cfg(test)]
pub(crate) fn run_independent_reader(script: &str, path: &Path) -> Option<String> {
    use std::process::Command;
    let available = Command::new("python3")
        .args(["-c", "import OpenEXR, numpy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !available {
        assert!(
            std::env::var_os("OBSCURA_REQUIRE_INDEPENDENT_EXR").is_none(),
            "OBSCURA_REQUIRE_INDEPENDENT_EXR is set but python3 cannot import OpenEXR and numpy"
        );
        eprintln!("skipping the independent check: python3 cannot import OpenEXR and numpy");
        return None;
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests").join(script);
    let out = Command::new("python3").arg(&script).arg(path).output().unwrap();
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(stdout)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::Filter;
    use exr::prelude::{ReadChannels, ReadLayers, read};
    use glam::Vec3;
    use obscura_host::PixelRect;
    use obscura_scene::{FilterKind, PixelFilter};
    use obscura_sdk::Rgb;

    fn pixel_value(x: u32, y: u32) -> SampleValues {
        let (fx, fy) = (x as f32, y as f32);
        SampleValues {
            ci: Rgb::new(0.1 * fx, 0.05 * fy, 0.333_333),
            alpha: if x.is_multiple_of(3) { 0.0 } else { 1.0 },
            z: if x.is_multiple_of(3) {
                f32::INFINITY
            } else {
                1.0 + fx + 100.0 * fy
            },
            n: Vec3::new(fx, -fy, 0.5),
            p: Vec3::new(10.0 * fx, 1.0 / (1.0 + fy), -3.0),
            camera_direction: Vec3::new(0.1, 0.2, 0.974_679_4),
        }
    }

    /// A film whose every crop pixel holds exactly `pixel_value` (one sample at each centre, width-1
    /// box filter).
    fn film(w: u32, h: u32, crop: PixelRect) -> Film {
        let f = Filter::new(&PixelFilter {
            kind: FilterKind::Box,
            width_x: 1.0,
            width_y: 1.0,
        })
        .unwrap();
        let mut film = Film::new(w, h, crop, f);
        let mut t = film.tile(crop);
        for y in crop.y0..crop.y1 {
            for x in crop.x0..crop.x1 {
                t.add_sample(x as f32 + 0.5, y as f32 + 0.5, &pixel_value(x, y));
            }
        }
        film.merge(t);
        film
    }

    fn channel<'a>(layer: &'a exr::prelude::Layer<AnyChannels<FlatSamples>>, name: &str) -> &'a FlatSamples {
        &layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .unwrap()
            .sample_data
    }

    fn read_back(path: &Path) -> Image<Layer<AnyChannels<FlatSamples>>> {
        read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_file(path)
            .unwrap()
    }

    #[test]
    fn output_exr_float_channels_values_and_windows() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("beauty.exr");
        let crop = PixelRect {
            x0: 3,
            x1: 10,
            y0: 2,
            y1: 6,
        };
        let f = film(12, 8, crop);
        let aovs = [
            Aov::Ci,
            Aov::Alpha,
            Aov::Z,
            Aov::N,
            Aov::P,
            Aov::CameraDirection,
            Aov::Z,
        ];
        let attrs = [
            ("projection", "PxrPerspective".to_string()),
            ("note", "ünïcode ok".to_string()),
        ];
        write_exr(&path, &f, &aovs, false, 1.5, &attrs).unwrap();
        assert!(crate::atomic::temporaries(&path).is_empty());

        let image = read_back(&path);
        assert_eq!(
            image.attributes.display_window,
            IntegerBounds::new((0, 0), (12, 8))
        );
        assert_eq!(image.attributes.pixel_aspect, 1.5);
        let layer = &image.layer_data;
        assert_eq!(layer.size, Vec2(7, 4));
        assert_eq!(layer.attributes.layer_position, Vec2(3, 2));
        let names: Vec<String> = layer
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        assert_eq!(
            names,
            [
                "A",
                "B",
                "G",
                "N.X",
                "N.Y",
                "N.Z",
                "P.X",
                "P.Y",
                "P.Z",
                "R",
                "Z",
                "cameraDirection.X",
                "cameraDirection.Y",
                "cameraDirection.Z"
            ]
        );
        assert_eq!(
            layer.attributes.other.get(&Text::from("projection")),
            Some(&AttributeValue::Text(Text::from("PxrPerspective")))
        );
        for (name, aov, k) in [
            ("R", Aov::Ci, 0),
            ("G", Aov::Ci, 1),
            ("B", Aov::Ci, 2),
            ("A", Aov::Alpha, 0),
            ("Z", Aov::Z, 0),
            ("N.Y", Aov::N, 1),
            ("P.Y", Aov::P, 1),
            ("cameraDirection.Z", Aov::CameraDirection, 2),
        ] {
            let FlatSamples::F32(values) = channel(layer, name) else {
                panic!("{name} is not float");
            };
            for (i, got) in values.iter().enumerate() {
                let (x, y) = (3 + i as u32 % 7, 2 + i as u32 / 7);
                let want = pixel_value(x, y);
                assert_eq!(
                    got.to_bits(),
                    component(&want, aov, k).to_bits(),
                    "{name} ({x}, {y})"
                );
            }
        }
    }

    #[test]
    fn output_exr_half_rounds_like_half() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("half.exr");
        let crop = PixelRect {
            x0: 0,
            x1: 5,
            y0: 0,
            y1: 3,
        };
        let f = film(5, 3, crop);
        write_exr(&path, &f, &[Aov::Ci, Aov::Z], true, 1.0, &[]).unwrap();
        let image = read_back(&path);
        let layer = &image.layer_data;
        assert_eq!(layer.channel_data.list.len(), 4);
        let FlatSamples::F16(b) = channel(layer, "B") else {
            panic!("B is not half")
        };
        // 0.333333 is not a half: it rounds to 0.33325195 (0x3555).
        assert_eq!(b[0].to_bits(), 0x3555);
        assert_eq!(b[0].to_f32(), 0.333_251_95);
        let FlatSamples::F16(z) = channel(layer, "Z") else {
            panic!("Z is not half")
        };
        assert!(z[0].to_f32().is_infinite());
        assert_eq!(z[1].to_f32(), 2.0);
        assert_eq!(z[1 + 5].to_f32(), 102.0);
    }

    #[test]
    fn output_exr_reads_back_with_python_openexr() {
        let dir = tempfile::tempdir().unwrap();
        let crop = PixelRect {
            x0: 3,
            x1: 10,
            y0: 2,
            y1: 6,
        };
        let f = film(12, 8, crop);
        for half in [false, true] {
            let path = dir.path().join(format!("flat-{half}.exr"));
            let attrs = [("projection", "PxrFisheye".to_string())];
            write_exr(
                &path,
                &f,
                &[Aov::Ci, Aov::Alpha, Aov::Z, Aov::P],
                half,
                1.25,
                &attrs,
            )
            .unwrap();
            let Some(out) = run_independent_reader("film_exr_read.py", &path) else {
                return;
            };
            let mut lines = out.lines();
            assert_eq!(lines.next().unwrap(), "dataWindow 3 2 9 5 displayWindow 0 0 11 7");
            assert_eq!(
                lines.next().unwrap(),
                "pixelAspectRatio 1.25 compression ZIP_COMPRESSION"
            );
            assert_eq!(lines.next().unwrap(), "projection PxrFisheye");
            let mut seen = Vec::new();
            for line in lines {
                let mut t = line.split_whitespace();
                let (name, kind) = (t.next().unwrap(), t.next().unwrap());
                assert_eq!(kind, if half { "float16" } else { "float32" }, "{name}");
                let (aov, k) = match name {
                    "R" | "G" | "B" => (Aov::Ci, ["R", "G", "B"].iter().position(|c| *c == name).unwrap()),
                    "A" => (Aov::Alpha, 0),
                    "Z" => (Aov::Z, 0),
                    _ => (
                        Aov::P,
                        ["P.X", "P.Y", "P.Z"].iter().position(|c| *c == name).unwrap(),
                    ),
                };
                let values: Vec<f32> = t.map(|v| v.parse::<f64>().unwrap() as f32).collect();
                assert_eq!(values.len(), crop.len());
                for (i, got) in values.iter().enumerate() {
                    let (x, y) = (3 + i as u32 % 7, 2 + i as u32 / 7);
                    let want = component(&pixel_value(x, y), aov, k);
                    let want = if half { f16::from_f32(want).to_f32() } else { want };
                    assert_eq!(got.to_bits(), want.to_bits(), "{name} ({x}, {y}) half={half}");
                }
                seen.push(name.to_string());
            }
            assert_eq!(seen, ["A", "B", "G", "P.X", "P.Y", "P.Z", "R", "Z"]);
        }
    }

    #[test]
    fn output_exr_refuses_what_it_cannot_write_and_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.exr");
        let f = film(
            4,
            4,
            PixelRect {
                x0: 0,
                x1: 4,
                y0: 0,
                y1: 4,
            },
        );
        let err = write_exr(&path, &f, &[], false, 1.0, &[]).unwrap_err();
        assert!(matches!(err, OutputError::NoChannels { .. }) && err.to_string().contains("x.exr"));
        for name in ["", "dataWindow", "a\0b"] {
            let err = write_exr(&path, &f, &[Aov::Ci], false, 1.0, &[(name, "v".into())]).unwrap_err();
            assert!(matches!(err, OutputError::Attribute { .. }), "{err}");
        }
        let empty = Film::new(
            4,
            4,
            PixelRect {
                x0: 2,
                x1: 2,
                y0: 0,
                y1: 4,
            },
            *f.filter(),
        );
        assert!(matches!(
            write_exr(&path, &empty, &[Aov::Ci], false, 1.0, &[]),
            Err(OutputError::EmptyImage { .. })
        ));
        assert!(matches!(
            write_png(&path, &empty),
            Err(OutputError::EmptyImage { .. })
        ));
        assert!(!path.exists());
    }

    #[test]
    fn output_writes_into_a_missing_directory_fail_naming_the_path_and_leave_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let f = film(
            4,
            4,
            PixelRect {
                x0: 0,
                x1: 4,
                y0: 0,
                y1: 4,
            },
        );
        for name in ["a.exr", "a.png"] {
            let path = dir.path().join("missing").join(name);
            let err = if name.ends_with("exr") {
                write_exr(&path, &f, &[Aov::Ci], false, 1.0, &[]).unwrap_err()
            } else {
                write_png(&path, &f).unwrap_err()
            };
            assert!(err.to_string().contains(&path.display().to_string()), "{err}");
            assert!(crate::atomic::temporaries(&path).is_empty());
            assert!(!path.exists());
        }
    }

    #[test]
    fn output_srgb_curve() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert_eq!(srgb_encode(1.0), 1.0);
        assert_eq!(srgb_encode(-3.0), 0.0);
        assert_eq!(srgb_encode(7.0), 1.0);
        assert_eq!(srgb_encode(f32::NAN), 0.0);
        assert!((srgb_encode(0.002) - 0.02584).abs() < 1e-6);
        // Continuous at the knee (to the precision of the published constants).
        let k = 0.003_130_8f32;
        assert!((srgb_encode(k) - srgb_encode(k + 1e-7)).abs() < 1e-5);
        assert!((srgb_encode(0.5) - 0.735_356_6).abs() < 1e-6);
        assert_eq!(quantize(srgb_encode(0.5)), 188);
        assert_eq!(quantize(srgb_encode(0.18)), 118);
    }

    #[test]
    fn output_png_reads_back_with_the_png_decoder() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("preview.png");
        let crop = PixelRect {
            x0: 1,
            x1: 6,
            y0: 2,
            y1: 5,
        };
        let f = Filter::new(&PixelFilter::default()).unwrap();
        let mut film = Film::new(8, 6, crop, f);
        let mut t = film.tile(crop);
        for y in crop.y0..crop.y1 {
            for x in crop.x0..crop.x1 {
                let ci = if (x, y) == (2, 3) {
                    Rgb::new(0.5, 2.0, -1.0)
                } else {
                    Rgb::new(0.5, 0.5, 0.5)
                };
                t.add_sample(
                    x as f32 + 0.5,
                    y as f32 + 0.5,
                    &SampleValues {
                        ci,
                        alpha: 1.0,
                        ..SampleValues::EMPTY
                    },
                );
            }
        }
        film.merge(t);
        write_png(&path, &film).unwrap();
        assert!(crate::atomic::temporaries(&path).is_empty());

        let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (5, 3));
        assert_eq!(
            (info.color_type, info.bit_depth),
            (png::ColorType::Rgb, png::BitDepth::Eight)
        );
        let px = |x: u32, y: u32| {
            let i = ((y - crop.y0) * 5 + (x - crop.x0)) as usize * 3;
            [buf[i], buf[i + 1], buf[i + 2]]
        };
        // A corner pixel far from (2, 3) sees only 0.5 grey samples: 0.5 linear → 188.
        assert_eq!(px(5, 4), [188, 188, 188]);
        // The gaussian mixes (2, 3)'s out-of-range colour in; film values are clamped, never wrapped.
        let v = film.pixel(2, 3);
        assert_eq!(
            px(2, 3),
            [188, quantize(srgb_encode(v.ci.g)), quantize(srgb_encode(v.ci.b)),]
        );
        assert!(px(2, 3)[1] > 188 && px(2, 3)[2] < 188);
    }
}
