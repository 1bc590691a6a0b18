//! Tiles of a frame rendered apart and stitched back: which pixels tile `i` of a `C×R` grid holds,
//! what its files are called, and [`merge_exr`] / [`merge_png`], which put the tiles' files back
//! together into the bytes a one-process render writes (flat EXR with every channel, deep EXR, PNG).
//!
//! This is the one place that reasons about data windows of a split frame: a tile's data window is
//! its rectangle of the region being split (the full render's data window), and the merged file's
//! data window is the union of the tiles'. An overscanned render ([`Overscan`]) is the other case:
//! its data window reaches past the display window (the plate) on every side, from a negative origin.
//!
//! ## The grid
//!
//! Column `c` of `C` over a region `[x0, x1)` is `[x0 + ⌊w·c/C⌋, x0 + ⌊w·(c+1)/C⌋)` with `w = x1 − x0`;
//! rows likewise. Tile `i` (from 0) is column `i mod C`, row `⌊i / C⌋` (row 0 at the top). The
//! tiles cover the region exactly, without overlap, and their sizes differ by at most one pixel.
//!
//! ## File names
//!
//! Tile `i` of `C×R` of the file `name.ext` is `name.tile{i}-{C}x{R}.ext` (`beauty.0001.exr` →
//! `beauty.0001.tile3-2x2.exr`); its sidecars follow from that name as any image's do.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, FlatSamples, Image, IntegerBounds, Layer, ReadChannels,
    ReadLayers, Text, Vec2, read,
};
use obscura_host::PixelRect;

use crate::deep::{DeepImage, read_deep_exr, write_deep_exr};
use crate::output::{FloatExrImage, write_exr_image, write_png_rgb};

/// The header attribute that marks an interrupted render's EXR (written by the frame pipeline).
pub const PARTIAL_ATTRIBUTE: &str = "obscura:partial";

/// A grid of `cols × rows` tiles over a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TileGrid {
    /// Columns, at least 1.
    pub cols: u32,
    /// Rows, at least 1.
    pub rows: u32,
}

/// The most tiles a grid may have.
pub const MAX_TILES: u32 = 4096;

impl TileGrid {
    /// Reads `CxR` (`2x2`, `4x1`).
    ///
    /// # Errors
    /// A message quoting `text` when it is not two positive integers joined by `x`, or names more
    /// than [`MAX_TILES`] tiles.
    pub fn parse(text: &str) -> Result<Self, String> {
        let bad = || format!("'{text}' is not a tile grid; expected COLSxROWS, e.g. 2x2 or 4x1");
        let (c, r) = text.split_once(['x', 'X']).ok_or_else(bad)?;
        let (cols, rows) = (
            c.trim().parse::<u32>().map_err(|_| bad())?,
            r.trim().parse::<u32>().map_err(|_| bad())?,
        );
        if cols == 0 || rows == 0 {
            return Err(format!(
                "'{text}': a tile grid has at least one column and one row"
            ));
        }
        if u64::from(cols) * u64::from(rows) > u64::from(MAX_TILES) {
            return Err(format!("'{text}': at most {MAX_TILES} tiles"));
        }
        Ok(TileGrid { cols, rows })
    }

    /// How many tiles.
    #[must_use]
    pub fn count(&self) -> u32 {
        self.cols * self.rows
    }

    /// Checks that `index` is a tile of this grid.
    ///
    /// # Errors
    /// A message naming the index and the grid.
    pub fn check_index(&self, index: u32) -> Result<(), String> {
        if index >= self.count() {
            return Err(format!(
                "tile index {index} is not a tile of {self} (0 to {})",
                self.count() - 1
            ));
        }
        Ok(())
    }

    /// The pixels tile `index` holds of `region` (see the module docs).
    #[must_use]
    pub fn rect(&self, region: PixelRect, index: u32) -> PixelRect {
        let (c, r) = (index % self.cols, index / self.cols);
        let cut = |lo: u32, hi: u32, k: u32, n: u32| {
            let w = u64::from(hi - lo);
            // At most `w`, so within u32.
            lo + (w * u64::from(k) / u64::from(n)) as u32
        };
        PixelRect {
            x0: cut(region.x0, region.x1, c, self.cols),
            x1: cut(region.x0, region.x1, c + 1, self.cols),
            y0: cut(region.y0, region.y1, r, self.rows),
            y1: cut(region.y0, region.y1, r + 1, self.rows),
        }
    }

    /// The file tile `index` writes for the output `path` (see the module docs).
    #[must_use]
    pub fn tile_path(&self, path: &Path, index: u32) -> PathBuf {
        let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
            return path.to_path_buf();
        };
        let tag = format!("tile{index}-{}x{}", self.cols, self.rows);
        let named = match name.rsplit_once('.') {
            Some((stem, ext)) if !stem.is_empty() => format!("{stem}.{tag}.{ext}"),
            _ => format!("{name}.{tag}"),
        };
        path.with_file_name(named)
    }
}

impl fmt::Display for TileGrid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.cols, self.rows)
    }
}

/// Why a set of tiles could not be merged. Every variant names the file at fault.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// Tiles of the grid have no file.
    #[error("missing tile(s) of {grid}: {}", list(.paths))]
    Missing {
        /// The grid.
        grid: TileGrid,
        /// The files that do not exist, with their tile index.
        paths: Vec<(u32, PathBuf)>,
    },
    /// A tile cannot be read (truncated, not an image of that kind).
    #[error("{path}: cannot read this tile: {reason}")]
    Unreadable {
        /// The file.
        path: PathBuf,
        /// The reader's message.
        reason: String,
    },
    /// A tile's render was interrupted.
    #[error(
        "{path}: the tile is incomplete (its render was interrupted: {PARTIAL_ATTRIBUTE}); render it again"
    )]
    Incomplete {
        /// The file.
        path: PathBuf,
    },
    /// A tile does not belong with the first one.
    #[error("{path}: does not belong with {first}: {what}")]
    OddOneOut {
        /// The file that differs.
        path: PathBuf,
        /// The first tile, the reference.
        first: PathBuf,
        /// What differs.
        what: String,
    },
    /// A tile holds other pixels than its place in the grid.
    #[error("{path}: holds pixels {got}, but tile {index} of {grid} is {want}{overlap}")]
    WrongRegion {
        /// The file.
        path: PathBuf,
        /// Its index.
        index: u32,
        /// The grid.
        grid: TileGrid,
        /// Its pixels.
        got: String,
        /// The pixels it should hold.
        want: String,
        /// The other tiles covering some of the same pixels, if any.
        overlap: String,
    },
    /// The merged image could not be written.
    #[error(transparent)]
    Write(#[from] crate::atomic::AtomicWriteError),
}

fn list(paths: &[(u32, PathBuf)]) -> String {
    (paths.iter())
        .map(|(i, p)| format!("tile {i} ({})", p.display()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The tiles' files of `output` for `grid`, in index order; every missing one named at once.
///
/// # Errors
/// [`MergeError::Missing`] listing each tile without a file.
pub fn tile_files(output: &Path, grid: TileGrid) -> Result<Vec<PathBuf>, MergeError> {
    let all: Vec<(u32, PathBuf)> = (0..grid.count())
        .map(|i| (i, grid.tile_path(output, i)))
        .collect();
    let missing: Vec<(u32, PathBuf)> = all.iter().filter(|(_, p)| !p.is_file()).cloned().collect();
    if !missing.is_empty() {
        return Err(MergeError::Missing { grid, paths: missing });
    }
    Ok(all.into_iter().map(|(_, p)| p).collect())
}

/// A rectangle for messages: `[x0, x1) × [y0, y1)`.
fn show(b: IntegerBounds) -> String {
    let end = b.end();
    format!("[{}, {}) × [{}, {})", b.position.0, end.0, b.position.1, end.1)
}

/// The union of rectangles as a pixel rectangle of non-negative coordinates, if it is one.
fn union(bounds: &[IntegerBounds]) -> Option<PixelRect> {
    let x0 = bounds.iter().map(|b| b.position.0).min()?;
    let y0 = bounds.iter().map(|b| b.position.1).min()?;
    let x1 = bounds.iter().map(|b| b.end().0).max()?;
    let y1 = bounds.iter().map(|b| b.end().1).max()?;
    Some(PixelRect {
        x0: u32::try_from(x0).ok()?,
        x1: u32::try_from(x1).ok()?,
        y0: u32::try_from(y0).ok()?,
        y1: u32::try_from(y1).ok()?,
    })
}

fn bounds_of(r: PixelRect) -> IntegerBounds {
    IntegerBounds::new(
        (r.x0 as i32, r.y0 as i32),
        (r.width() as usize, r.height() as usize),
    )
}

fn overlaps(a: IntegerBounds, b: IntegerBounds) -> bool {
    let (ae, be) = (a.end(), b.end());
    a.position.0 < be.0 && b.position.0 < ae.0 && a.position.1 < be.1 && b.position.1 < ae.1
}

/// Checks that the tiles' rectangles are the grid's over their union; returns the union.
fn check_regions(
    paths: &[PathBuf],
    bounds: &[IntegerBounds],
    grid: TileGrid,
) -> Result<PixelRect, MergeError> {
    let region = union(bounds).ok_or_else(|| MergeError::Unreadable {
        path: paths[0].clone(),
        reason: "the tiles' data windows reach negative pixel coordinates".into(),
    })?;
    for (i, (path, &b)) in paths.iter().zip(bounds).enumerate() {
        let want = bounds_of(grid.rect(region, i as u32));
        if b != want {
            let others: Vec<String> = (paths.iter().zip(bounds).enumerate())
                .filter(|&(j, (_, &o))| j != i && overlaps(o, b))
                .map(|(j, (p, _))| format!("tile {j} ({})", p.display()))
                .collect();
            return Err(MergeError::WrongRegion {
                path: path.clone(),
                index: i as u32,
                grid,
                got: show(b),
                want: show(want),
                overlap: if others.is_empty() {
                    String::new()
                } else {
                    format!("; it overlaps {}", others.join(", "))
                },
            });
        }
    }
    Ok(region)
}

/// Reads one tile EXR (every channel of its first layer, every attribute).
fn read_tile(path: &Path) -> Result<FloatExrImage, MergeError> {
    read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .pedantic()
        .from_file(path)
        .map_err(|e| MergeError::Unreadable {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })
}

/// The text attributes of a layer, by name (for comparing and rewriting).
fn texts(image: &FloatExrImage) -> BTreeMap<String, String> {
    (image.layer_data.attributes.other.iter())
        .filter_map(|(k, v)| match v {
            AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect()
}

/// Stitches the tile EXRs `tiles` (tile `i` of `grid` at index `i`) into `output`, written
/// atomically, byte-identical to the EXR a one-process render of the whole region writes.
///
/// Every tile is read and checked before anything is written: none may be interrupted
/// ([`PARTIAL_ATTRIBUTE`]); all must share display window, pixel aspect, compression, channels
/// (names and types) and every header attribute after `rewrite` — which receives each text
/// attribute's name and value and the merged data window, and returns the value the merged file
/// carries (a header that records the data window is rewritten there; `None` keeps it) —; and
/// each must hold exactly its rectangle of the grid over their union.
///
/// # Errors
/// A [`MergeError`] naming the tile at fault; nothing is written then.
pub fn merge_exr(
    tiles: &[PathBuf],
    grid: TileGrid,
    output: &Path,
    rewrite: &dyn Fn(&str, &str, PixelRect) -> Option<String>,
) -> Result<(), MergeError> {
    assert_eq!(tiles.len(), grid.count() as usize, "one file per tile");
    if crate::deep::is_deep_exr(&tiles[0]) {
        return merge_deep(tiles, grid, output);
    }
    let images: Vec<FloatExrImage> = tiles.iter().map(|p| read_tile(p)).collect::<Result<_, _>>()?;
    for (path, image) in tiles.iter().zip(&images) {
        if image
            .layer_data
            .attributes
            .other
            .contains_key(&Text::from(PARTIAL_ATTRIBUTE))
        {
            return Err(MergeError::Incomplete { path: path.clone() });
        }
    }
    let bounds: Vec<IntegerBounds> = (images.iter())
        .map(|im| IntegerBounds::new(im.layer_data.attributes.layer_position, im.layer_data.size))
        .collect();
    // Settings before regions: a tile of another size is named as such, not as a wrong region.
    let first = &images[0];
    let channels = |im: &FloatExrImage| -> Vec<String> {
        (im.layer_data.channel_data.list.iter())
            .map(|c| {
                let kind = match c.sample_data {
                    FlatSamples::F16(_) => "half",
                    FlatSamples::F32(_) => "float",
                    FlatSamples::U32(_) => "uint",
                };
                format!("{} ({kind})", c.name)
            })
            .collect()
    };
    for (path, image) in tiles.iter().zip(&images).skip(1) {
        let odd = |what: String| MergeError::OddOneOut {
            path: path.clone(),
            first: tiles[0].clone(),
            what,
        };
        let (a, b) = (&first.attributes, &image.attributes);
        if a.display_window != b.display_window {
            return Err(odd(format!(
                "its frame is {}×{} pixels, the first tile's {}×{}",
                b.display_window.size.0,
                b.display_window.size.1,
                a.display_window.size.0,
                a.display_window.size.1
            )));
        }
        if a.pixel_aspect != b.pixel_aspect {
            return Err(odd(format!(
                "pixel aspect {} instead of {}",
                b.pixel_aspect, a.pixel_aspect
            )));
        }
        if first.layer_data.encoding != image.layer_data.encoding {
            return Err(odd("another compression or block layout".into()));
        }
        if channels(first) != channels(image) {
            return Err(odd(format!(
                "channels {} instead of {}",
                channels(image).join(", "),
                channels(first).join(", ")
            )));
        }
    }
    let region = check_regions(tiles, &bounds, grid)?;
    let rewritten = |im: &FloatExrImage| -> BTreeMap<String, String> {
        (texts(im).into_iter())
            .map(|(k, v)| {
                let v = rewrite(&k, &v, region).unwrap_or(v);
                (k, v)
            })
            .collect()
    };
    let reference = rewritten(first);
    for (path, image) in tiles.iter().zip(&images).skip(1) {
        let theirs = rewritten(image);
        let differs = (reference.keys().chain(theirs.keys()))
            .find(|k| reference.get(*k) != theirs.get(*k))
            .cloned();
        let non_text = |im: &FloatExrImage| {
            (im.layer_data.attributes.other.iter())
                .filter(|(_, v)| !matches!(v, AttributeValue::Text(_)))
                .map(|(k, v)| format!("{k}={v:?}"))
                .collect::<std::collections::BTreeSet<_>>()
        };
        let differs =
            differs.or_else(|| (non_text(first) != non_text(image)).then(|| "a non-text attribute".into()));
        if let Some(name) = differs {
            return Err(MergeError::OddOneOut {
                path: path.clone(),
                first: tiles[0].clone(),
                what: format!("header attribute \"{name}\" differs (another scene, frame or setting)"),
            });
        }
    }

    // The merged planes: each channel's samples, row by row over the region.
    let (w, h) = (region.width() as usize, region.height() as usize);
    let mut planes: Vec<FlatSamples> = (first.layer_data.channel_data.list.iter())
        .map(|c| match &c.sample_data {
            FlatSamples::F16(_) => FlatSamples::F16(vec![exr::prelude::f16::ZERO; w * h]),
            FlatSamples::F32(_) => FlatSamples::F32(vec![0.0; w * h]),
            FlatSamples::U32(_) => FlatSamples::U32(vec![0; w * h]),
        })
        .collect();
    for (image, b) in images.iter().zip(&bounds) {
        let (tw, th) = (b.size.0, b.size.1);
        let ox = (b.position.0 as i64 - i64::from(region.x0)) as usize;
        let oy = (b.position.1 as i64 - i64::from(region.y0)) as usize;
        for (plane, channel) in planes.iter_mut().zip(&image.layer_data.channel_data.list) {
            for row in 0..th {
                let (src, dst) = (
                    row * tw..(row + 1) * tw,
                    (oy + row) * w + ox..(oy + row) * w + ox + tw,
                );
                match (&mut *plane, &channel.sample_data) {
                    (FlatSamples::F16(d), FlatSamples::F16(s)) => d[dst].copy_from_slice(&s[src]),
                    (FlatSamples::F32(d), FlatSamples::F32(s)) => d[dst].copy_from_slice(&s[src]),
                    (FlatSamples::U32(d), FlatSamples::U32(s)) => d[dst].copy_from_slice(&s[src]),
                    // The channel types were checked equal above.
                    _ => unreachable!("channel types differ between tiles"),
                }
            }
        }
    }
    let channels: Vec<AnyChannel<FlatSamples>> = (first.layer_data.channel_data.list.iter())
        .zip(planes)
        .map(|(c, samples)| AnyChannel {
            sample_data: samples,
            ..c.clone()
        })
        .collect();
    let mut attributes = first.layer_data.attributes.clone();
    attributes.layer_position = Vec2(region.x0 as i32, region.y0 as i32);
    for (k, v) in reference {
        attributes.other.insert(
            Text::from(k.as_str()),
            AttributeValue::Text(Text::from(v.as_str())),
        );
    }
    let layer = Layer {
        channel_data: AnyChannels {
            list: channels.into(),
        },
        attributes,
        size: Vec2(w, h),
        encoding: first.layer_data.encoding,
    };
    let image = Image {
        attributes: first.attributes.clone(),
        layer_data: layer,
    };
    Ok(write_exr_image(image, output)?)
}

/// The deep case of [`merge_exr`]: the tiles' samples put together and written by
/// [`write_deep_exr`] as the one-process render writes them.
fn merge_deep(tiles: &[PathBuf], grid: TileGrid, output: &Path) -> Result<(), MergeError> {
    let mut images = Vec::with_capacity(tiles.len());
    for path in tiles {
        let (image, compression) = read_deep_exr(path).map_err(|reason| MergeError::Unreadable {
            path: path.clone(),
            reason,
        })?;
        images.push((image, compression));
    }
    let (size, compression) = ((images[0].0.width, images[0].0.height), images[0].1);
    for (path, (image, c)) in tiles.iter().zip(&images).skip(1) {
        let what = if (image.width, image.height) != size {
            format!(
                "its frame is {}×{} pixels, the first tile's {}×{}",
                image.width, image.height, size.0, size.1
            )
        } else if *c != compression {
            "another compression".into()
        } else {
            continue;
        };
        return Err(MergeError::OddOneOut {
            path: path.clone(),
            first: tiles[0].clone(),
            what,
        });
    }
    let bounds: Vec<IntegerBounds> = images.iter().map(|(im, _)| bounds_of(im.data_window)).collect();
    let region = check_regions(tiles, &bounds, grid)?;
    let w = region.width() as usize;
    let mut pixels = vec![Vec::new(); region.len()];
    for (image, _) in images {
        let r = image.data_window;
        for (k, samples) in image.pixels.into_iter().enumerate() {
            let (x, y) = (
                r.x0 as usize + k % r.width() as usize,
                r.y0 as usize + k / r.width() as usize,
            );
            pixels[(y - region.y0 as usize) * w + x - region.x0 as usize] = samples;
        }
    }
    let merged = DeepImage {
        width: size.0,
        height: size.1,
        data_window: region,
        pixels,
    };
    write_deep_exr(output, &merged, compression).map_err(|e| match e {
        crate::output::OutputError::Write(e) => MergeError::Write(e),
        other => MergeError::Unreadable {
            path: output.to_path_buf(),
            reason: other.to_string(),
        },
    })
}

/// One decoded PNG tile: size and RGB bytes.
fn read_png_tile(path: &Path) -> Result<(u32, u32, Vec<u8>), MergeError> {
    let bad = |reason: String| MergeError::Unreadable {
        path: path.to_path_buf(),
        reason,
    };
    let file = std::fs::File::open(path).map_err(|e| bad(e.to_string()))?;
    let mut reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .map_err(|e| bad(e.to_string()))?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| bad("the image is too large".into()))?;
    let mut data = vec![0; size];
    let info = reader.next_frame(&mut data).map_err(|e| bad(e.to_string()))?;
    if info.color_type != png::ColorType::Rgb || info.bit_depth != png::BitDepth::Eight {
        return Err(bad(format!(
            "{:?} {:?}: not an 8-bit RGB preview as obscura render writes",
            info.color_type, info.bit_depth
        )));
    }
    data.truncate(info.buffer_size());
    Ok((info.width, info.height, data))
}

/// Stitches the PNG previews `tiles` (tile `i` of `grid` at index `i`) into `output`, written
/// atomically, byte-identical to the preview a one-process render writes. The frame's size is the
/// sum of the first row's widths by the sum of the first column's heights; every tile must have
/// the size of its rectangle of the grid over that frame.
///
/// # Errors
/// A [`MergeError`] naming the tile at fault; nothing is written then.
pub fn merge_png(tiles: &[PathBuf], grid: TileGrid, output: &Path) -> Result<(), MergeError> {
    assert_eq!(tiles.len(), grid.count() as usize, "one file per tile");
    let images: Vec<(u32, u32, Vec<u8>)> =
        tiles.iter().map(|p| read_png_tile(p)).collect::<Result<_, _>>()?;
    let width: u32 = (0..grid.cols).map(|c| images[c as usize].0).sum();
    let height: u32 = (0..grid.rows).map(|r| images[(r * grid.cols) as usize].1).sum();
    let frame = PixelRect {
        x0: 0,
        x1: width,
        y0: 0,
        y1: height,
    };
    let mut data = vec![0u8; width as usize * height as usize * 3];
    for (i, ((tw, th, pixels), path)) in images.iter().zip(tiles).enumerate() {
        let r = grid.rect(frame, i as u32);
        if (r.width(), r.height()) != (*tw, *th) {
            return Err(MergeError::OddOneOut {
                path: path.clone(),
                first: tiles[0].clone(),
                what: format!(
                    "it is {tw}×{th} pixels, but tile {i} of {grid} over a {width}×{height} frame is {}×{}",
                    r.width(),
                    r.height()
                ),
            });
        }
        let row = *tw as usize * 3;
        for y in 0..*th as usize {
            let at = ((r.y0 as usize + y) * width as usize + r.x0 as usize) * 3;
            data[at..at + row].copy_from_slice(&pixels[y * row..(y + 1) * row]);
        }
    }
    Ok(write_png_rgb(output, width, height, &data)?)
}

/// Pixels of filter support Nuke adds on each side of a distortion node's bounding box (and
/// [`Overscan::covering`] with it).
pub const FILTER_PAD: u32 = 2;

/// The margins, in whole pixels, by which a render for a `width × height` plate reaches past the
/// plate on each side (overscan), so that redistorting it onto the plate leaves no uncovered pixel.
///
/// The overscanned render is `(width + left + right) × (height + top + bottom)` pixels of the same
/// pinhole, extended: its pixel `(i, j)` is the plate's raster position `(i − left, j − top)`. Its
/// OpenEXR keeps the plate as the display window `[0, width) × [0, height)` and stores the data
/// window `[−left, width + right) × [−top, height + bottom)`, so a compositor places it on the plate
/// without a reformat.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Overscan {
    /// Pixels left of the plate (x < 0).
    pub left: u32,
    /// Pixels above the plate (y < 0, raster y down).
    pub top: u32,
    /// Pixels right of the plate (x ≥ width).
    pub right: u32,
    /// Pixels below the plate (y ≥ height).
    pub bottom: u32,
}

impl Overscan {
    /// The same margin on all four sides.
    #[must_use]
    pub fn uniform(pixels: u32) -> Self {
        Self {
            left: pixels,
            top: pixels,
            right: pixels,
            bottom: pixels,
        }
    }

    /// The margins of the data window Nuke's `LD_3DE4_*` node gives the undistorted plate: the box
    /// `[x0, y0, x1, y1]` (raster, y down; a lens's undistorted box of the plate, e.g.
    /// `obscura_calibration::lens3de::Lens::undistorted_box`) widened to whole pixels and then by
    /// [`FILTER_PAD`] pixels of filter support per side, `[⌊x0⌋ − 2, ⌈x1⌉ + 2) × [⌊y0⌋ − 2, ⌈y1⌉ + 2)`,
    /// around a `width × height` plate: `left = 2 − ⌊x0⌋`, `top = 2 − ⌊y0⌋`,
    /// `right = ⌈x1⌉ + 2 − width`, `bottom = ⌈y1⌉ + 2 − height`, each at least 0 (a box inside the
    /// plate needs no margin there). The padding is what lets a bilinear or wider filter resample
    /// the box's edge from rendered pixels only. An extreme that lies exactly on a whole pixel (a
    /// corner of a symmetric lens) may land a pixel either way, as in Nuke, from the last bits of
    /// the box; either way every pixel of the box stays covered.
    ///
    /// # Errors
    /// A message when a bound is not finite or a margin exceeds `i32::MAX / 2` pixels.
    pub fn covering(bounds: [f64; 4], width: u32, height: u32) -> Result<Self, String> {
        let pad = f64::from(FILTER_PAD);
        let margin = |beyond: f64| -> Result<u32, String> {
            if !beyond.is_finite() {
                return Err(format!("the box {bounds:?} is not finite"));
            }
            let m = beyond.max(0.0);
            if m > f64::from(i32::MAX / 2) {
                return Err(format!("the box {bounds:?} needs a margin of {m} pixels"));
            }
            Ok(m as u32)
        };
        Ok(Self {
            left: margin(pad - bounds[0].floor())?,
            top: margin(pad - bounds[1].floor())?,
            right: margin(bounds[2].ceil() + pad - f64::from(width))?,
            bottom: margin(bounds[3].ceil() + pad - f64::from(height))?,
        })
    }

    /// Reads `PIXELS` (all sides) or `LEFT,TOP,RIGHT,BOTTOM`.
    ///
    /// # Errors
    /// A message quoting `text` when it is neither.
    pub fn parse(text: &str) -> Result<Self, String> {
        let bad = || {
            format!(
                "'{text}' is not an overscan; expected PIXELS or LEFT,TOP,RIGHT,BOTTOM (whole pixels ≥ 0)"
            )
        };
        let v: Vec<u32> = (text.split(','))
            .map(|p| p.trim().parse::<u32>().map_err(|_| bad()))
            .collect::<Result<_, _>>()?;
        let o = match v[..] {
            [p] => Self::uniform(p),
            [left, top, right, bottom] => Self {
                left,
                top,
                right,
                bottom,
            },
            _ => return Err(bad()),
        };
        if [o.left, o.top, o.right, o.bottom]
            .iter()
            .any(|&m| m > i32::MAX as u32 / 2)
        {
            return Err(bad());
        }
        Ok(o)
    }

    /// The overscanned render's size for a `width × height` plate.
    #[must_use]
    pub fn render_size(&self, width: u32, height: u32) -> (u32, u32) {
        (width + self.left + self.right, height + self.top + self.bottom)
    }

    /// The data window of the overscanned render, in the plate's pixel coordinates:
    /// `[−left, width + right) × [−top, height + bottom)`.
    #[must_use]
    pub fn data_window(&self, width: u32, height: u32) -> IntegerBounds {
        let (w, h) = self.render_size(width, height);
        IntegerBounds::new(
            (-(self.left as i32), -(self.top as i32)),
            (w as usize, h as usize),
        )
    }

    /// The screen window of the overscanned pinhole, given the plate's `[left, right, bottom, top]`
    /// (RenderMan's `ScreenWindow`, y up; for a `w × h` plate by default `[−w/h, w/h, −1, 1]` when
    /// `w ≥ h`): each side pushed out in proportion, `left − (right − left)·self.left / width`, … so
    /// that the plate's pixels keep their rays and the margins continue the same pinhole.
    #[must_use]
    pub fn screen_window(&self, plate: [f64; 4], width: u32, height: u32) -> [f64; 4] {
        let (sx, sy) = (
            (plate[1] - plate[0]) / f64::from(width),
            (plate[3] - plate[2]) / f64::from(height),
        );
        [
            plate[0] - sx * f64::from(self.left),
            plate[1] + sx * f64::from(self.right),
            plate[2] - sy * f64::from(self.bottom),
            plate[3] + sy * f64::from(self.top),
        ]
    }
}

impl fmt::Display for Overscan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{},{},{}", self.left, self.top, self.right, self.bottom)
    }
}

/// Why an overscanned render could not be placed on its plate.
#[derive(Debug, thiserror::Error)]
pub enum OverscanError {
    /// The file is not a readable flat OpenEXR.
    #[error("{path}: cannot read this render: {reason}")]
    Unreadable {
        /// The file.
        path: PathBuf,
        /// The reader's message.
        reason: String,
    },
    /// The render is not the overscanned size.
    #[error(
        "{path}: holds {got}, but a {width}x{height} plate overscanned by {overscan} (left,top,right,bottom) is {want}"
    )]
    WrongSize {
        /// The file.
        path: PathBuf,
        /// Its data window.
        got: String,
        /// The data window the overscan asks for, at the origin.
        want: String,
        /// The plate's width.
        width: u32,
        /// The plate's height.
        height: u32,
        /// The overscan.
        overscan: Overscan,
    },
    /// The placed image could not be written.
    #[error(transparent)]
    Write(#[from] crate::atomic::AtomicWriteError),
}

/// Places an overscanned render on its plate: the flat EXR at `path`, rendered as an ordinary
/// `render_size` frame (data window `[0, w') × [0, h')`), is rewritten atomically with the display
/// window `[0, width) × [0, height)` and the data window [`Overscan::data_window`]. Pixels,
/// channels and attributes are kept.
///
/// # Errors
/// [`OverscanError::Unreadable`], [`OverscanError::WrongSize`] when the file's data window is not
/// the overscanned frame at the origin, or [`OverscanError::Write`].
pub fn place_overscan(path: &Path, overscan: Overscan, width: u32, height: u32) -> Result<(), OverscanError> {
    place_overscan_with(path, overscan, width, height, &|_, _| None)
}

/// [`place_overscan`] with the text attributes rewritten: `rewrite` receives each text attribute's
/// name and value and returns the value the placed file carries (`None` keeps it), so a header
/// that records the image's size (`obscura:camera`) follows the placement.
///
/// # Errors
/// As [`place_overscan`].
pub fn place_overscan_with(
    path: &Path,
    overscan: Overscan,
    width: u32,
    height: u32,
    rewrite: &dyn Fn(&str, &str) -> Option<String>,
) -> Result<(), OverscanError> {
    let mut image = read_tile(path).map_err(|e| match e {
        MergeError::Unreadable { path, reason } => OverscanError::Unreadable { path, reason },
        other => OverscanError::Unreadable {
            path: path.to_path_buf(),
            reason: other.to_string(),
        },
    })?;
    let got = IntegerBounds::new(image.layer_data.attributes.layer_position, image.layer_data.size);
    let (w, h) = overscan.render_size(width, height);
    let want = IntegerBounds::new((0, 0), (w as usize, h as usize));
    if got != want {
        return Err(OverscanError::WrongSize {
            path: path.to_path_buf(),
            got: show(got),
            want: show(want),
            width,
            height,
            overscan,
        });
    }
    image.layer_data.attributes.layer_position = overscan.data_window(width, height).position;
    image.attributes.display_window = IntegerBounds::new((0, 0), (width as usize, height as usize));
    for (name, value) in &mut image.layer_data.attributes.other {
        if let AttributeValue::Text(text) = value
            && let Some(new) = rewrite(&name.to_string(), &text.to_string())
        {
            *value = AttributeValue::Text(Text::from(new.as_str()));
        }
    }
    Ok(write_exr_image(image, path)?)
}

/// The plate of an overscanned PNG: the PNG at `path`, rendered as the overscanned frame, is
/// rewritten atomically holding only the display window (`width × height` pixels from
/// `(left, top)`). A PNG has no data window, so its preview shows what Nuke's viewer shows: the
/// plate.
///
/// # Errors
/// [`OverscanError::Unreadable`], [`OverscanError::WrongSize`] when the PNG is not the
/// overscanned size, or [`OverscanError::Write`].
pub fn crop_png_to_plate(
    path: &Path,
    overscan: Overscan,
    width: u32,
    height: u32,
) -> Result<(), OverscanError> {
    let (w, h, data) = read_png_tile(path).map_err(|e| OverscanError::Unreadable {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    let want = overscan.render_size(width, height);
    if (w, h) != want {
        return Err(OverscanError::WrongSize {
            path: path.to_path_buf(),
            got: format!("{w}x{h} pixels"),
            want: format!("{}x{} pixels", want.0, want.1),
            width,
            height,
            overscan,
        });
    }
    let mut plate = Vec::with_capacity(width as usize * height as usize * 3);
    for y in overscan.top..overscan.top + height {
        let row = (y as usize * w as usize + overscan.left as usize) * 3;
        plate.extend_from_slice(&data[row..row + width as usize * 3]);
    }
    Ok(write_png_rgb(path, width, height, &plate)?)
}

#[cfg(test)]
mod tests;
