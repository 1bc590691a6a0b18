//! Flat image files: OpenEXR (through the `exr` crate), 8-bit sRGB PNG previews, and the TIFF of
//! RenderMan's classic drivers ([`write_tiff`]).
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
use obscura_scene::{Aov, AovKind};

use crate::film::{Film, SampleValues};

mod tiff_file;
pub use tiff_file::write_tiff;

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
    /// The sensor's raw file could not be encoded (too large for TIFF).
    #[error("cannot write {path}: {reason}")]
    Raw {
        /// The target file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
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
    let mut bytes = Vec::new();
    let encoded = image
        .write()
        .to_buffered(std::io::Cursor::new(&mut bytes))
        .map_err(|e| match e {
            exr::error::Error::Io(e) => e,
            other => std::io::Error::other(other),
        });
    write_atomically(path, |out| {
        encoded?;
        sort_header_attributes(&mut bytes);
        std::io::Write::write_all(out, &bytes)
    })
}

/// Puts the header attributes of a single-part OpenEXR file in `bytes` in name order, in place.
///
/// The `exr` crate writes a layer's custom attributes in the order of a `HashMap`, which differs
/// from run to run; sorted, the same image is the same bytes every time. The header keeps its length,
/// so the offset table after it stays right. Multi-part files and anything that does not parse as
/// a header are left alone.
pub fn sort_header_attributes(bytes: &mut [u8]) {
    const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
    const MULTIPART: u8 = 0x10;
    if bytes.len() < 8 || bytes[..4] != MAGIC || bytes[5] & MULTIPART != 0 {
        return;
    }
    let mut spans: Vec<(Vec<u8>, std::ops::Range<usize>)> = Vec::new();
    let mut at = 8;
    loop {
        let Some(name_end) = bytes[at..].iter().position(|&b| b == 0).map(|i| at + i) else {
            return;
        };
        if name_end == at {
            break;
        }
        let Some(type_end) = bytes[name_end + 1..]
            .iter()
            .position(|&b| b == 0)
            .map(|i| name_end + 1 + i)
        else {
            return;
        };
        let Some(size) = bytes.get(type_end + 1..type_end + 5) else {
            return;
        };
        let size = i32::from_le_bytes([size[0], size[1], size[2], size[3]]);
        let Ok(size) = usize::try_from(size) else {
            return;
        };
        let end = type_end + 5 + size;
        if end > bytes.len() {
            return;
        }
        spans.push((bytes[at..name_end].to_vec(), at..end));
        at = end;
    }
    let Some(first) = spans.first().map(|s| s.1.start) else {
        return;
    };
    let mut sorted: Vec<u8> = Vec::with_capacity(at - first);
    let mut order: Vec<&(Vec<u8>, std::ops::Range<usize>)> = spans.iter().collect();
    order.sort_by(|a, b| a.0.cmp(&b.0));
    for (_, range) in order {
        sorted.extend_from_slice(&bytes[range.clone()]);
    }
    bytes[first..at].copy_from_slice(&sorted);
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

/// The integer value of an ID AOV in a resolved pixel; `None` for the other AOVs.
#[must_use]
pub fn id_component(v: &SampleValues, aov: Aov) -> Option<u32> {
    match aov {
        Aov::ObjectId => Some(v.truth.object_id),
        Aov::InstanceId => Some(v.truth.instance_id),
        Aov::MaterialId => Some(v.truth.material_id),
        _ => None,
    }
}

/// Component `k` of `aov` in a resolved pixel (`k` below its number of channels): what each AOV of the
/// table ([`obscura_scene::AOVS`]) takes from the film. An ID is its integer as `f32`.
#[must_use]
pub fn component(v: &SampleValues, aov: Aov, k: usize) -> f32 {
    match aov {
        Aov::Ci => [v.ci.r, v.ci.g, v.ci.b][k],
        Aov::Alpha => v.alpha,
        Aov::Z => v.z,
        Aov::N => v.n[k],
        Aov::P => v.p[k],
        Aov::CameraDirection => v.camera_direction[k],
        Aov::Albedo => [v.albedo.r, v.albedo.g, v.albedo.b][k],
        Aov::Uv => v.uv[k],
        Aov::CameraZ => v.truth.camera_z,
        Aov::Distance => v.truth.distance,
        Aov::PCamera => v.truth.p_camera[k],
        Aov::NCamera => v.truth.n_camera[k],
        Aov::ObjectId | Aov::InstanceId | Aov::MaterialId => id_component(v, aov).unwrap_or(0) as f32,
        Aov::FlowForward => v.flow.forward[k],
        Aov::FlowBackward => v.flow.backward[k],
        Aov::FlowValid => [v.flow.forward_valid, v.flow.backward_valid][k],
        Aov::Raw => v.sensor.raw,
        Aov::Electrons => v.sensor.electrons,
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
/// `P.Z`; CameraDirection → `cameraDirection.X`, `.Y`, `.Z`; Albedo → `albedo.R`, `.G`, `.B`; Uv →
/// `uv.X`, `uv.Y`; the ground truth as `cameraZ`,
/// `distance`, `Pcamera.{X,Y,Z}`, `Ncamera.{X,Y,Z}`, `flowForward.{X,Y}`, `flowBackward.{X,Y}`,
/// `flowValid.{forward,backward}` and the IDs `objectId`, `instanceId`, `materialId` as 32-bit
/// unsigned integers (whatever `half` says); the sensor's `raw` (DN) and `electrons` as 32-bit floats
/// (whatever `half` says: half floats hold integers exactly only up to 2048). ZIP compression (16 scanlines per
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
        for (k, name) in aov.channels().iter().enumerate() {
            let values = pixels.iter().map(|v| component(v, aov, k));
            let samples = if aov.spec().kind == AovKind::Id {
                FlatSamples::U32(pixels.iter().filter_map(|v| id_component(v, aov)).collect())
            } else if half && !aov.is_sensor() {
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
    Ok(write_png_rgb(path, crop.width(), crop.height(), &data)?)
}

/// Writes 8-bit RGB pixels (`width × height × 3` bytes, row by row) as the PNG [`write_png`]
/// writes — same chunks, same encoder settings —, atomically.
///
/// # Errors
/// An [`AtomicWriteError`] naming `path`.
///
/// # Panics
/// When `data` does not hold `width × height × 3` bytes (a bug of the caller).
pub fn write_png_rgb(path: &Path, width: u32, height: u32, data: &[u8]) -> Result<(), AtomicWriteError> {
    assert_eq!(
        data.len(),
        width as usize * height as usize * 3,
        "RGB bytes of the whole image"
    );
    let png_err = |e| match e {
        png::EncodingError::IoError(e) => e,
        other => std::io::Error::other(other),
    };
    write_atomically(path, |out| {
        let mut encoder = png::Encoder::new(out, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header().map_err(png_err)?;
        writer.write_image_data(data).map_err(png_err)?;
        writer.finish().map_err(png_err)
    })
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
pub(crate) mod tests;
