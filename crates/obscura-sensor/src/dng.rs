//! The raw mosaic as a DNG file (Adobe DNG 1.4 over baseline TIFF 6.0), written by hand: one
//! little-endian IFD, the image as one uncompressed strip of 16-bit samples.
//!
//! Tags (in the ascending order TIFF requires): NewSubfileType 0, ImageWidth, ImageLength,
//! BitsPerSample 16, Compression 1, PhotometricInterpretation (32803 CFA, or 34892 LinearRaw for a
//! monochrome sensor), Make, Model, StripOffsets, Orientation 1, SamplesPerPixel 1, RowsPerStrip,
//! StripByteCounts, PlanarConfiguration 1, Software; for a CFA CFARepeatPatternDim `2 2` and CFAPattern
//! (0 = R, 1 = G, 2 = B, row by row); DNGVersion 1.4, DNGBackwardVersion 1.1, UniqueCameraModel,
//! CFAPlaneColor `0 1 2` and CFALayout 1 (CFA only), LinearizationTable when the codes are companded,
//! BlackLevelRepeatDim `1 1`, BlackLevel, WhiteLevel, and for colour ColorMatrix1 (XYZ → camera,
//! SRATIONAL ×10⁴), AsShotNeutral (RATIONAL ×10⁶) and CalibrationIlluminant1 21 (D65).

use crate::color::Mat3;

/// What a DNG holds beside the codes.
#[derive(Debug, Clone, PartialEq)]
pub struct DngInfo {
    /// The 2×2 CFA cell at the image's top-left pixel (`None`: monochrome).
    pub cfa: Option<[[u8; 2]; 2]>,
    /// BlackLevel, DN (linear, after the linearisation table).
    pub black_level: u32,
    /// WhiteLevel, DN (linear).
    pub white_level: u32,
    /// ColorMatrix1 (XYZ → camera under D65); `None` for a monochrome sensor.
    pub color_matrix: Option<Mat3>,
    /// AsShotNeutral (camera coordinates of white).
    pub as_shot_neutral: [f64; 3],
    /// LinearizationTable: the linear code of every stored code, when companded.
    pub linearization: Option<Vec<u16>>,
    /// Make and Model.
    pub make: String,
    /// Model, also UniqueCameraModel.
    pub model: String,
}

enum Value {
    Short(Vec<u16>),
    Long(Vec<u32>),
    Byte(Vec<u8>),
    Ascii(String),
    Rational(Vec<(u32, u32)>),
    SRational(Vec<(i32, i32)>),
}

impl Value {
    fn type_and_count(&self) -> (u16, u32) {
        match self {
            Value::Byte(v) => (1, v.len() as u32),
            Value::Ascii(s) => (2, s.len() as u32 + 1),
            Value::Short(v) => (3, v.len() as u32),
            Value::Long(v) => (4, v.len() as u32),
            Value::Rational(v) => (5, v.len() as u32),
            Value::SRational(v) => (10, v.len() as u32),
        }
    }

    fn bytes(&self) -> Vec<u8> {
        let mut b = Vec::new();
        match self {
            Value::Byte(v) => b.extend_from_slice(v),
            Value::Ascii(s) => {
                b.extend_from_slice(s.as_bytes());
                b.push(0);
            }
            Value::Short(v) => v.iter().for_each(|x| b.extend_from_slice(&x.to_le_bytes())),
            Value::Long(v) => v.iter().for_each(|x| b.extend_from_slice(&x.to_le_bytes())),
            Value::Rational(v) => v.iter().for_each(|(n, d)| {
                b.extend_from_slice(&n.to_le_bytes());
                b.extend_from_slice(&d.to_le_bytes());
            }),
            Value::SRational(v) => v.iter().for_each(|(n, d)| {
                b.extend_from_slice(&n.to_le_bytes());
                b.extend_from_slice(&d.to_le_bytes());
            }),
        }
        b
    }
}

/// Why a DNG was not encoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DngError {
    /// The codes do not fill `width × height`.
    #[error("the raw image holds {got} codes, expected {width}×{height}")]
    Size {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// Codes given.
        got: usize,
    },
    /// The file would pass TIFF's 4 GiB offsets.
    #[error("the raw image is too large for a TIFF file (4 GiB)")]
    TooLarge,
}

/// Encodes `codes` (`width × height`, row by row) as a DNG file's bytes.
///
/// # Errors
/// [`DngError`] when the codes do not fill the image or the file passes 4 GiB.
pub fn encode(codes: &[u16], width: u32, height: u32, info: &DngInfo) -> Result<Vec<u8>, DngError> {
    if codes.len() != width as usize * height as usize || width == 0 || height == 0 {
        return Err(DngError::Size {
            width,
            height,
            got: codes.len(),
        });
    }
    let strip_bytes = codes.len() as u64 * 2;
    if strip_bytes > u64::from(u32::MAX) / 2 {
        return Err(DngError::TooLarge);
    }
    let rational = |v: f64| ((v * 1e6).round().max(0.0) as u32, 1_000_000u32);
    let srational = |v: f64| ((v * 1e4).round() as i32, 10_000i32);
    let mut tags: Vec<(u16, Value)> = vec![
        (254, Value::Long(vec![0])),
        (256, Value::Long(vec![width])),
        (257, Value::Long(vec![height])),
        (258, Value::Short(vec![16])),
        (259, Value::Short(vec![1])),
        (
            262,
            Value::Short(vec![if info.cfa.is_some() { 32803 } else { 34892 }]),
        ),
        (271, Value::Ascii(info.make.clone())),
        (272, Value::Ascii(info.model.clone())),
        (273, Value::Long(vec![0])), // StripOffsets, patched below
        (274, Value::Short(vec![1])),
        (277, Value::Short(vec![1])),
        (278, Value::Long(vec![height])),
        (279, Value::Long(vec![strip_bytes as u32])),
        (284, Value::Short(vec![1])),
        (
            305,
            Value::Ascii(format!("Obscura {}", env!("CARGO_PKG_VERSION"))),
        ),
    ];
    if let Some(cell) = info.cfa {
        tags.push((33421, Value::Short(vec![2, 2])));
        tags.push((33422, Value::Byte(cell.iter().flatten().copied().collect())));
    }
    tags.push((50706, Value::Byte(vec![1, 4, 0, 0])));
    tags.push((50707, Value::Byte(vec![1, 1, 0, 0])));
    tags.push((50708, Value::Ascii(info.model.clone())));
    if info.cfa.is_some() {
        tags.push((50710, Value::Byte(vec![0, 1, 2])));
        tags.push((50711, Value::Short(vec![1])));
    }
    if let Some(table) = &info.linearization {
        tags.push((50712, Value::Short(table.clone())));
    }
    tags.push((50713, Value::Short(vec![1, 1])));
    tags.push((50714, Value::Long(vec![info.black_level])));
    tags.push((50717, Value::Long(vec![info.white_level])));
    if let Some(m) = &info.color_matrix {
        tags.push((
            50721,
            Value::SRational(m.iter().flatten().map(|&v| srational(v)).collect()),
        ));
        tags.push((
            50728,
            Value::Rational(info.as_shot_neutral.iter().map(|&v| rational(v)).collect()),
        ));
        tags.push((50778, Value::Short(vec![21])));
    }
    debug_assert!(tags.windows(2).all(|w| w[0].0 < w[1].0), "TIFF tags ascend");

    // Layout: header (8), IFD (2 + 12·n + 4), out-of-line values, then the strip (2-byte aligned).
    let ifd_size = 2 + 12 * tags.len() + 4;
    let mut extra: Vec<u8> = Vec::new();
    let extra_start = 8 + ifd_size;
    let mut entries: Vec<[u8; 12]> = Vec::new();
    let mut strip_entry = 0;
    for (k, (tag, value)) in tags.iter().enumerate() {
        let (ty, count) = value.type_and_count();
        let bytes = value.bytes();
        let mut e = [0u8; 12];
        e[0..2].copy_from_slice(&tag.to_le_bytes());
        e[2..4].copy_from_slice(&ty.to_le_bytes());
        e[4..8].copy_from_slice(&count.to_le_bytes());
        if bytes.len() <= 4 {
            e[8..8 + bytes.len()].copy_from_slice(&bytes);
        } else {
            if extra.len() % 2 == 1 {
                extra.push(0);
            }
            let offset = (extra_start + extra.len()) as u32;
            e[8..12].copy_from_slice(&offset.to_le_bytes());
            extra.extend_from_slice(&bytes);
        }
        if *tag == 273 {
            strip_entry = k;
        }
        entries.push(e);
    }
    if extra.len() % 2 == 1 {
        extra.push(0);
    }
    let strip_offset = (extra_start + extra.len()) as u64;
    if strip_offset + strip_bytes > u64::from(u32::MAX) {
        return Err(DngError::TooLarge);
    }
    entries[strip_entry][8..12].copy_from_slice(&(strip_offset as u32).to_le_bytes());

    let mut out = Vec::with_capacity(strip_offset as usize + strip_bytes as usize);
    out.extend_from_slice(b"II");
    out.extend_from_slice(&42u16.to_le_bytes());
    out.extend_from_slice(&8u32.to_le_bytes());
    out.extend_from_slice(&(tags.len() as u16).to_le_bytes());
    for e in &entries {
        out.extend_from_slice(e);
    }
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&extra);
    for c in codes {
        out.extend_from_slice(&c.to_le_bytes());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info() -> DngInfo {
        DngInfo {
            cfa: Some([[0, 1], [1, 2]]),
            black_level: 64,
            white_level: 4095,
            color_matrix: Some(crate::color::camera_preset("canon_eos_5d_mark_ii").unwrap()),
            as_shot_neutral: [0.5, 1.0, 0.7],
            linearization: None,
            make: "Obscura".into(),
            model: "Obscura test sensor".into(),
        }
    }

    /// Walks the IFD as TIFF 6.0 describes it (the standard raw reader, LibRaw, reads the file in
    /// `test.sh`): tags ascend, the strip holds the codes and ends the file.
    #[test]
    fn ifd_walk_finds_codes_and_tags() {
        let (w, h) = (6u32, 4u32);
        let codes: Vec<u16> = (0..w * h).map(|i| (i * 97 % 4096) as u16).collect();
        let b = encode(&codes, w, h, &info()).unwrap();
        let u16_at = |o: usize| u16::from_le_bytes([b[o], b[o + 1]]);
        let u32_at = |o: usize| u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
        assert_eq!(&b[..4], b"II*\0");
        let ifd = u32_at(4) as usize;
        let n = u16_at(ifd) as usize;
        let tags: Vec<(u16, u16, u32, usize)> = (0..n)
            .map(|k| {
                let e = ifd + 2 + 12 * k;
                (u16_at(e), u16_at(e + 2), u32_at(e + 4), e + 8)
            })
            .collect();
        assert!(tags.windows(2).all(|t| t[0].0 < t[1].0));
        let find = |tag| tags.iter().find(|t| t.0 == tag).copied().unwrap();
        assert_eq!(u32_at(find(50714).3), 64);
        assert_eq!(u32_at(find(50717).3), 4095);
        assert_eq!(u16_at(find(262).3), 32803);
        assert_eq!(&b[find(33422).3..find(33422).3 + 4], &[0, 1, 1, 2]);
        let at = u32_at(find(273).3) as usize;
        assert_eq!(u32_at(find(279).3) as usize, codes.len() * 2);
        let strip: Vec<u16> = (0..codes.len()).map(|i| u16_at(at + 2 * i)).collect();
        assert_eq!(strip, codes);
        assert_eq!(at + codes.len() * 2, b.len());
        // ColorMatrix1 is nine SRATIONALs ×10⁴ out of line.
        let cm = find(50721);
        assert_eq!((cm.1, cm.2), (10, 9));
        let off = u32_at(cm.3) as usize;
        assert_eq!(u32_at(off) as i32, 4716);
        assert_eq!(u32_at(off + 4), 10_000);
    }

    #[test]
    fn wrong_size_is_refused() {
        assert_eq!(
            encode(&[0; 5], 2, 3, &info()).unwrap_err().to_string(),
            "the raw image holds 5 codes, expected 2×3"
        );
    }
}
