//! How a pyramid level keeps its texels: 8-bit sources stay 8-bit (4 bytes a texel), sRGB-encoded
//! when they are colour, as GPUs keep `SRGB8_ALPHA8` textures; mip levels are averaged in linear
//! space and encoded again. Anything deeper (16-bit, float) is kept as linear `f32`.

use std::sync::OnceLock;

use glam::Vec4;

use super::image::srgb_to_linear;

/// Texels of one level.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Texels {
    /// sRGB-encoded RGB, linear alpha.
    Srgb8(Vec<[u8; 4]>),
    /// Linear 8-bit values (`code / 255`).
    Unorm8(Vec<[u8; 4]>),
    /// Linear floats.
    Float(Vec<Vec4>),
}

/// The 256 linear values of the 8-bit sRGB codes.
fn srgb_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
}

/// The sRGB code of a linear value (IEC 61966-2-1's encoding, rounded).
fn linear_to_srgb8(c: f32) -> u8 {
    let c = if c.is_finite() { c.clamp(0.0, 1.0) } else { 0.0 };
    let e = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0 + 0.5) as u8
}

fn unorm8(c: f32) -> u8 {
    let c = if c.is_finite() { c.clamp(0.0, 1.0) } else { 0.0 };
    (c * 255.0 + 0.5) as u8
}

impl Texels {
    /// The number of texels.
    pub(crate) fn len(&self) -> usize {
        match self {
            Texels::Srgb8(t) | Texels::Unorm8(t) => t.len(),
            Texels::Float(t) => t.len(),
        }
    }

    /// Bytes held.
    pub(crate) fn bytes(&self) -> usize {
        match self {
            Texels::Srgb8(t) | Texels::Unorm8(t) => 4 * t.len(),
            Texels::Float(t) => 16 * t.len(),
        }
    }

    /// Texel `i`, linear.
    #[inline]
    pub(crate) fn get(&self, i: usize) -> Vec4 {
        match self {
            Texels::Srgb8(t) => {
                let s = srgb_table();
                let [r, g, b, a] = t[i];
                Vec4::new(s[r as usize], s[g as usize], s[b as usize], f32::from(a) / 255.0)
            }
            Texels::Unorm8(t) => Vec4::from(t[i].map(f32::from)) / 255.0,
            Texels::Float(t) => t[i],
        }
    }

    /// Every texel, linear.
    pub(crate) fn decode(&self) -> Vec<Vec4> {
        (0..self.len()).map(|i| self.get(i)).collect()
    }

    /// `linear` stored the way `self` stores its texels.
    pub(crate) fn encode_like(&self, linear: Vec<Vec4>) -> Texels {
        match self {
            Texels::Srgb8(_) => Texels::Srgb8(
                linear
                    .iter()
                    .map(|v| {
                        [
                            linear_to_srgb8(v.x),
                            linear_to_srgb8(v.y),
                            linear_to_srgb8(v.z),
                            unorm8(v.w),
                        ]
                    })
                    .collect(),
            ),
            Texels::Unorm8(_) => Texels::Unorm8(linear.iter().map(|v| v.to_array().map(unorm8)).collect()),
            Texels::Float(_) => Texels::Float(linear),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_srgb_code_survives_decoding_and_encoding() {
        for code in 0..=255u8 {
            assert_eq!(linear_to_srgb8(srgb_table()[code as usize]), code);
        }
    }
}
