//! Our own deep-scanline OpenEXR writer (the `exr` crate cannot write deep data).
//!
//! The layout follows the OpenEXR File Layout document (OpenEXR 2.0 and later), single part:
//!
//! 1. magic `20000630` and the version field `2 | 0x800` (the non-image, i.e. deep, bit);
//! 2. the header: attributes `name\0 type\0 size:i32 value`, sorted by name, then a NUL byte.
//!    `channels` (A, B, G, R, Z, ZBack, all FLOAT), `chunkCount`, `compression`, `dataWindow`,
//!    `displayWindow`, `lineOrder` (increasing y), `maxSamplesPerPixel`, `name`,
//!    `pixelAspectRatio` (1), `screenWindowCenter` (0, 0), `screenWindowWidth` (1),
//!    `type` = "deepscanline", `version` = 1;
//! 3. the offset table: one `u64` file offset per chunk;
//! 4. one chunk per scanline: `y:i32`, the packed size of the sample-count table (`u64`), the packed
//!    size of the sample data (`u64`), the unpacked size of the sample data (`u64`), the packed
//!    table — per pixel, the cumulative sample count of the line so far, `i32` — and the packed
//!    sample data: channel by channel in name order, pixel by pixel, sample by sample, `f32`.
//!
//! With ZIPS, the table and the data are each compressed alone: bytes split into even and odd
//! halves, a delta predictor `d = t[i] − t[i−1] + 128`, then zlib; each is stored raw when
//! compressing does not make it smaller (readers tell by comparing the packed and unpacked sizes).

use std::io::Write;
use std::path::Path;

use miniz_oxide::deflate::compress_to_vec_zlib;
use obscura_host::PixelRect;
use rayon::prelude::*;

use crate::atomic::write_atomically;
use crate::output::OutputError;

/// One sample of a deep pixel: a slab from `z` to `z_back` with premultiplied colour and alpha.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeepSample {
    /// Front depth.
    pub z: f32,
    /// Back depth (`z` for a point sample).
    pub z_back: f32,
    /// Red, premultiplied.
    pub r: f32,
    /// Green, premultiplied.
    pub g: f32,
    /// Blue, premultiplied.
    pub b: f32,
    /// Alpha.
    pub a: f32,
}

/// How the chunks are compressed. Both store one scanline per chunk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DeepCompression {
    /// `NO_COMPRESSION`.
    None,
    /// `ZIPS_COMPRESSION`: zlib, one scanline at a time.
    Zips,
}

/// A deep image: format size, data window, and the samples of every pixel of the data window.
#[derive(Debug, Clone, PartialEq)]
pub struct DeepImage {
    /// Format width: the display window is `0..width`.
    pub width: u32,
    /// Format height: the display window is `0..height`.
    pub height: u32,
    /// The pixels stored (usually the crop).
    pub data_window: PixelRect,
    /// Row-major over the data window; each pixel's samples sorted by z (front to back).
    pub pixels: Vec<Vec<DeepSample>>,
}

/// Reads one channel's value from a sample.
type Component = fn(&DeepSample) -> f32;

/// The channels in the order OpenEXR stores them (sorted by name), with their component.
const CHANNELS: [(&str, Component); 6] = [
    ("A", |s| s.a),
    ("B", |s| s.b),
    ("G", |s| s.g),
    ("R", |s| s.r),
    ("Z", |s| s.z),
    ("ZBack", |s| s.z_back),
];

const MAGIC: i32 = 20_000_630;
/// File format version 2 with the non-image (deep data) flag.
const VERSION_FIELD: i32 = 2 | 0x800;
const FLOAT: i32 = 2;
const ZLIB_LEVEL: u8 = 6;

/// Writes `image` as a single-part deep-scanline OpenEXR, atomically
/// ([`crate::atomic::write_atomically`]).
///
/// Samples are written in the order given; OpenEXR expects them sorted by `z`.
///
/// # Errors
/// [`OutputError::InvalidDeepImage`] when the data window is empty, its pixel count differs from
/// `pixels.len()`, a coordinate or a sample count does not fit OpenEXR's `i32`s, or the format is
/// empty; [`OutputError::Write`] when writing fails. All name `path`.
pub fn write_deep_exr(
    path: &Path,
    image: &DeepImage,
    compression: DeepCompression,
) -> Result<(), OutputError> {
    let invalid = |reason: String| OutputError::InvalidDeepImage {
        path: path.to_path_buf(),
        reason,
    };
    let dw = image.data_window;
    let fits = |v: u32| i32::try_from(v).is_ok();
    if dw.x1 <= dw.x0 || dw.y1 <= dw.y0 {
        return Err(invalid(format!("the data window {dw:?} holds no pixel")));
    }
    if image.width == 0 || image.height == 0 {
        return Err(invalid(format!(
            "the format {}x{} is empty",
            image.width, image.height
        )));
    }
    if ![dw.x1, dw.y1, image.width, image.height].into_iter().all(fits) {
        return Err(invalid("coordinates beyond 2^31 cannot be stored".into()));
    }
    if image.pixels.len() != dw.len() {
        return Err(invalid(format!(
            "{} pixel sample lists for a {}x{} data window",
            image.pixels.len(),
            dw.width(),
            dw.height()
        )));
    }
    let width = dw.width() as usize;
    let max_samples = image.pixels.iter().map(Vec::len).max().unwrap_or(0);
    let chunks: Vec<Vec<u8>> = image
        .pixels
        .par_chunks(width)
        .zip(dw.y0..dw.y1)
        .map(|(row, y)| chunk(y as i32, row, compression))
        .collect::<Option<_>>()
        .ok_or_else(|| invalid("a scanline holds more than 2^31 − 1 samples".into()))?;
    let header = header(image, compression, max_samples.min(i32::MAX as usize) as i32);

    write_atomically(path, |out| {
        out.write_all(&header)?;
        let mut offset = (header.len() + 8 * chunks.len()) as u64;
        for c in &chunks {
            out.write_all(&offset.to_le_bytes())?;
            offset += c.len() as u64;
        }
        for c in &chunks {
            out.write_all(c)?;
        }
        Ok(())
    })?;
    Ok(())
}

/// Magic, version field and header.
fn header(image: &DeepImage, compression: DeepCompression, max_samples: i32) -> Vec<u8> {
    let dw = image.data_window;
    let i32s = |v: &[i32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let f32s = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let mut chlist = Vec::new();
    for (name, _) in CHANNELS {
        chlist.extend_from_slice(name.as_bytes());
        chlist.push(0);
        chlist.extend_from_slice(&FLOAT.to_le_bytes());
        chlist.extend_from_slice(&[0, 0, 0, 0]); // pLinear, reserved ×3
        chlist.extend_from_slice(&i32s(&[1, 1])); // x and y sampling
    }
    chlist.push(0);
    let box2i = |r: PixelRect| i32s(&[r.x0 as i32, r.y0 as i32, r.x1 as i32 - 1, r.y1 as i32 - 1]);
    let display = PixelRect {
        x0: 0,
        x1: image.width,
        y0: 0,
        y1: image.height,
    };
    let mut attributes: Vec<(&str, &str, Vec<u8>)> = vec![
        ("channels", "chlist", chlist),
        ("chunkCount", "int", i32s(&[dw.height() as i32])),
        ("compression", "compression", vec![compression_code(compression)]),
        ("dataWindow", "box2i", box2i(dw)),
        ("displayWindow", "box2i", box2i(display)),
        ("lineOrder", "lineOrder", vec![0]),
        ("maxSamplesPerPixel", "int", i32s(&[max_samples])),
        // Required by the layout document when the non-image bit is set.
        ("name", "string", b"deep".to_vec()),
        ("pixelAspectRatio", "float", f32s(&[1.0])),
        ("screenWindowCenter", "v2f", f32s(&[0.0, 0.0])),
        ("screenWindowWidth", "float", f32s(&[1.0])),
        ("type", "string", b"deepscanline".to_vec()),
        ("version", "int", i32s(&[1])),
    ];
    attributes.sort_by(|a, b| a.0.cmp(b.0));
    let mut out = Vec::new();
    out.extend_from_slice(&MAGIC.to_le_bytes());
    out.extend_from_slice(&VERSION_FIELD.to_le_bytes());
    for (name, kind, value) in attributes {
        out.extend_from_slice(name.as_bytes());
        out.push(0);
        out.extend_from_slice(kind.as_bytes());
        out.push(0);
        out.extend_from_slice(&(value.len() as i32).to_le_bytes());
        out.extend_from_slice(&value);
    }
    out.push(0);
    out
}

fn compression_code(c: DeepCompression) -> u8 {
    match c {
        DeepCompression::None => 0,
        DeepCompression::Zips => 2,
    }
}

/// One scanline's chunk; `None` when its sample count overflows an `i32`.
fn chunk(y: i32, row: &[Vec<DeepSample>], compression: DeepCompression) -> Option<Vec<u8>> {
    let mut table = Vec::with_capacity(4 * row.len());
    let mut total: i32 = 0;
    for p in row {
        total = total.checked_add(i32::try_from(p.len()).ok()?)?;
        table.extend_from_slice(&total.to_le_bytes());
    }
    let mut data = Vec::with_capacity(4 * CHANNELS.len() * total as usize);
    for (_, component) in CHANNELS {
        for s in row.iter().flatten() {
            data.extend_from_slice(&component(s).to_le_bytes());
        }
    }
    let unpacked = data.len() as u64;
    let (packed_table, packed_data) = match compression {
        DeepCompression::None => (table, data),
        DeepCompression::Zips => (zips(table), zips(data)),
    };
    let mut out = Vec::with_capacity(28 + packed_table.len() + packed_data.len());
    out.extend_from_slice(&y.to_le_bytes());
    out.extend_from_slice(&(packed_table.len() as u64).to_le_bytes());
    out.extend_from_slice(&(packed_data.len() as u64).to_le_bytes());
    out.extend_from_slice(&unpacked.to_le_bytes());
    out.extend_from_slice(&packed_table);
    out.extend_from_slice(&packed_data);
    Some(out)
}

/// OpenEXR's ZIP(S) packing of `raw`, or `raw` itself when that is not smaller.
fn zips(raw: Vec<u8>) -> Vec<u8> {
    if raw.is_empty() {
        return raw;
    }
    let n = raw.len();
    let half = n.div_ceil(2);
    let mut t = vec![0u8; n];
    for (i, &b) in raw.iter().enumerate() {
        t[if i % 2 == 0 { i / 2 } else { half + i / 2 }] = b;
    }
    let mut previous = t[0];
    for v in &mut t[1..] {
        let current = *v;
        *v = current.wrapping_sub(previous).wrapping_add(128);
        previous = current;
    }
    let packed = compress_to_vec_zlib(&t, ZLIB_LEVEL);
    if packed.len() < n { packed } else { raw }
}

/// True when the file at `path` starts as an OpenEXR whose version field has the non-image (deep)
/// bit; false when it cannot be read or is not one.
#[must_use]
pub fn is_deep_exr(path: &Path) -> bool {
    let mut head = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
        .is_ok()
        && head[..4] == MAGIC.to_le_bytes()
        && i32::from_le_bytes([head[4], head[5], head[6], head[7]]) & 0x800 != 0
}

/// Reads a deep-scanline OpenEXR in the layout [`write_deep_exr`] writes (single part; the channels
/// A, B, G, R, Z, ZBack as FLOAT; no or ZIPS compression; increasing lines), with its compression.
///
/// # Errors
/// A message saying what is wrong (truncated, another layout, a corrupt chunk); the caller names
/// the file.
pub fn read_deep_exr(path: &Path) -> Result<(DeepImage, DeepCompression), String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let mut at = 0usize;
    let take = |at: &mut usize, n: usize| -> Result<&[u8], String> {
        let s = bytes
            .get(*at..*at + n)
            .ok_or_else(|| format!("truncated at byte {} (the file has {})", *at + n, bytes.len()))?;
        *at += n;
        Ok(s)
    };
    let int = |b: &[u8]| i32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    if int(take(&mut at, 4)?) != MAGIC {
        return Err("not an OpenEXR file".into());
    }
    if int(take(&mut at, 4)?) & 0x1800 != 0x800 {
        return Err("not a single-part deep OpenEXR".into());
    }
    let cstr = |at: &mut usize| -> Result<String, String> {
        let end = (bytes[*at..].iter().position(|&b| b == 0))
            .ok_or_else(|| "truncated in the header".to_string())?;
        let s = String::from_utf8_lossy(&bytes[*at..*at + end]).into_owned();
        *at += end + 1;
        Ok(s)
    };
    let mut attrs = std::collections::HashMap::new();
    loop {
        let name = cstr(&mut at)?;
        if name.is_empty() {
            break;
        }
        let _kind = cstr(&mut at)?;
        let size = usize::try_from(int(take(&mut at, 4)?)).map_err(|_| "a negative attribute size")?;
        attrs.insert(name, take(&mut at, size)?.to_vec());
    }
    let get = |name: &str| attrs.get(name).ok_or_else(|| format!("no {name} attribute"));
    let box2i = |name: &str| -> Result<[i32; 4], String> {
        let v = get(name)?;
        if v.len() != 16 {
            return Err(format!("{name}: not a box2i"));
        }
        Ok([int(&v[0..]), int(&v[4..]), int(&v[8..]), int(&v[12..])])
    };
    let mut expected = Vec::new();
    for (name, _) in CHANNELS {
        expected.extend_from_slice(name.as_bytes());
        expected.push(0);
        expected.extend_from_slice(&FLOAT.to_le_bytes());
        expected.extend_from_slice(&[0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0]);
    }
    expected.push(0);
    if *get("channels")? != expected {
        return Err("channels other than A, B, G, R, Z, ZBack (float)".into());
    }
    let compression = match get("compression")?.first() {
        Some(0) => DeepCompression::None,
        Some(2) => DeepCompression::Zips,
        _ => return Err("a compression other than none or ZIPS".into()),
    };
    let [x0, y0, x1, y1] = box2i("dataWindow")?;
    let [dx0, dy0, dx1, dy1] = box2i("displayWindow")?;
    let non_negative = |v: i32| u32::try_from(v).map_err(|_| "negative pixel coordinates".to_string());
    if dx0 != 0 || dy0 != 0 || x1 < x0 || y1 < y0 {
        return Err("a display window not at the origin, or an empty data window".into());
    }
    let data_window = PixelRect {
        x0: non_negative(x0)?,
        x1: non_negative(x1)? + 1,
        y0: non_negative(y0)?,
        y1: non_negative(y1)? + 1,
    };
    let (width, lines) = (data_window.width() as usize, data_window.height() as usize);
    take(&mut at, 8 * lines)?; // the offset table: chunks follow in order
    let mut pixels: Vec<Vec<DeepSample>> = Vec::with_capacity(width * lines);
    for line in 0..lines {
        let y = int(take(&mut at, 4)?);
        if i64::from(y) != i64::from(data_window.y0) + line as i64 {
            return Err(format!("chunk {line} holds line {y}: lines out of order"));
        }
        let u64_at = |at: &mut usize| -> Result<usize, String> {
            let b = take(at, 8)?;
            usize::try_from(u64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
                .map_err(|_| "a size beyond memory".into())
        };
        let (table_size, data_size, unpacked) = (u64_at(&mut at)?, u64_at(&mut at)?, u64_at(&mut at)?);
        let table = unzips(take(&mut at, table_size)?, 4 * width)?;
        let data = unzips(take(&mut at, data_size)?, unpacked)?;
        let counts: Vec<usize> = table.chunks_exact(4).map(|b| int(b).max(0) as usize).collect();
        let total = counts.last().copied().unwrap_or(0);
        if data.len() != 4 * CHANNELS.len() * total {
            return Err(format!(
                "line {y}: {} bytes of samples for {total} samples",
                data.len()
            ));
        }
        let value = |channel: usize, k: usize| {
            let i = 4 * (channel * total + k);
            f32::from_le_bytes([data[i], data[i + 1], data[i + 2], data[i + 3]])
        };
        let mut start = 0;
        for &end in &counts {
            if end < start || end > total {
                return Err(format!("line {y}: the sample-count table decreases"));
            }
            pixels.push(
                (start..end)
                    .map(|k| DeepSample {
                        a: value(0, k),
                        b: value(1, k),
                        g: value(2, k),
                        r: value(3, k),
                        z: value(4, k),
                        z_back: value(5, k),
                    })
                    .collect(),
            );
            start = end;
        }
    }
    Ok((
        DeepImage {
            width: non_negative(dx1)? + 1,
            height: non_negative(dy1)? + 1,
            data_window,
            pixels,
        },
        compression,
    ))
}

/// The inverse of [`zips`]: `packed` as stored, `unpacked` bytes long.
fn unzips(packed: &[u8], unpacked: usize) -> Result<Vec<u8>, String> {
    if packed.len() == unpacked {
        return Ok(packed.to_vec());
    }
    let mut t = miniz_oxide::inflate::decompress_to_vec_zlib(packed)
        .map_err(|e| format!("a corrupt ZIPS chunk: {e:?}"))?;
    if t.len() != unpacked {
        return Err(format!("a ZIPS chunk of {} bytes, expected {unpacked}", t.len()));
    }
    for i in 1..t.len() {
        t[i] = t[i].wrapping_add(t[i - 1]).wrapping_sub(128);
    }
    let half = unpacked.div_ceil(2);
    Ok((0..unpacked)
        .map(|i| t[if i % 2 == 0 { i / 2 } else { half + i / 2 }])
        .collect())
}

#[cfg(test)]
mod tests;
