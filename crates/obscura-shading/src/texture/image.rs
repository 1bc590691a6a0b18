//! Decoding an image file into linear RGBA: PNG, JPEG, OpenEXR, Radiance HDR and TIFF through the
//! `image` crate, the format told by the bytes. 8- and 16-bit values are decoded with the sRGB
//! transfer function or read as linear, as the texture's [`ColorSpace`] says; float formats are linear
//! whatever it says (OpenEXR and Radiance HDR store scene-linear values). Alpha is always linear.

use std::sync::OnceLock;

use image::DynamicImage;
use obscura_scene::texture::{ColorSpace, ImageSource};

use super::Texels;

/// A decoded image: `width × height` linear RGBA texels, row by row from the top.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearImage {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Texels, row-major from the top-left.
    pub texels: Vec<[f32; 4]>,
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1): encoded value in `[0, 1]` → linear.
#[must_use]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The 256 linear values of the 8-bit sRGB codes.
fn srgb8_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
}

/// Reads and decodes `source` into the storage its texture keeps: 8-bit images as their codes
/// (sRGB-encoded when `color_space` is sRGB), deeper ones as linear floats.
///
/// # Errors
/// A message saying why (the file cannot be read, the format is not one we read, the data is
/// corrupt), without the image's name: the caller names it.
pub(crate) fn decode(source: &ImageSource, color_space: ColorSpace) -> Result<(u32, u32, Texels), String> {
    let bytes: std::borrow::Cow<'_, [u8]> = match source {
        ImageSource::File(path) => std::fs::read(path).map_err(|e| e.to_string())?.into(),
        ImageSource::Embedded { bytes, .. } => (&bytes[..]).into(),
    };
    let image = image::load_from_memory(&bytes).map_err(|e| e.to_string())?;
    let (w, h) = (image.width(), image.height());
    let texels = match image {
        DynamicImage::ImageLuma8(_)
        | DynamicImage::ImageLumaA8(_)
        | DynamicImage::ImageRgb8(_)
        | DynamicImage::ImageRgba8(_) => {
            let codes = image.into_rgba8().pixels().map(|p| p.0).collect();
            match color_space {
                ColorSpace::Srgb => Texels::Srgb8(codes),
                ColorSpace::Linear => Texels::Unorm8(codes),
            }
        }
        other => Texels::Float(
            to_linear(other, color_space)
                .texels
                .into_iter()
                .map(glam::Vec4::from)
                .collect(),
        ),
    };
    Ok((w, h, texels))
}

/// Converts any decoded image to linear RGBA (grey replicated to RGB; missing alpha is 1).
#[must_use]
pub fn to_linear(image: DynamicImage, color_space: ColorSpace) -> LinearImage {
    let (width, height) = (image.width(), image.height());
    let srgb = color_space == ColorSpace::Srgb;
    let texels = match image {
        DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_) => image
            .into_rgba32f()
            .pixels()
            .map(|p| p.0.map(|c| if c.is_finite() { c } else { 0.0 }))
            .collect(),
        DynamicImage::ImageLuma8(_)
        | DynamicImage::ImageLumaA8(_)
        | DynamicImage::ImageRgb8(_)
        | DynamicImage::ImageRgba8(_) => {
            let table = srgb8_table();
            image
                .into_rgba8()
                .pixels()
                .map(|p| {
                    let [r, g, b, a] = p.0;
                    let c = |v: u8| {
                        if srgb {
                            table[v as usize]
                        } else {
                            f32::from(v) / 255.0
                        }
                    };
                    [c(r), c(g), c(b), f32::from(a) / 255.0]
                })
                .collect()
        }
        other => other
            .into_rgba16()
            .pixels()
            .map(|p| {
                let [r, g, b, a] = p.0.map(|v| f32::from(v) / 65535.0);
                let c = |v: f32| if srgb { srgb_to_linear(v) } else { v };
                [c(r), c(g), c(b), a]
            })
            .collect(),
    };
    LinearImage {
        width,
        height,
        texels,
    }
}
