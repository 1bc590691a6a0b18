//! What a render farm needs around `obscura render`: one tile of a frame (`--tile I/N`,
//! `--tiles CxR --tile-index I`), and `obscura merge`, the collect step that checks a shot's frames
//! are complete and stitches tiles back into the images a one-process render writes.

use std::path::{Path, PathBuf};

use clap::Args;
use obscura_host::{CropWindow, PixelRect};
use obscura_image::tiles::{MergeError, TileGrid, merge_exr, merge_png, tile_files};
use obscura_render::frame::relative_to_sidecar;
use obscura_render::metadata::{sidecar_path, with_data_window};
use obscura_render::sequence::{FrameSpec, frame_path};
use obscura_scene::{Display, Scene};

use crate::stdout::outln;

/// Reads `--tile I/N`: tile `I` (from 0) of `N` horizontal bands (a `1×N` grid).
pub fn parse_tile(text: &str) -> Result<(u32, TileGrid), String> {
    let bad = || format!("'{text}' is not a tile; expected I/N, tile I (from 0) of N bands, e.g. 0/4");
    let (i, n) = text.split_once('/').ok_or_else(bad)?;
    let i: u32 = i.trim().parse().map_err(|_| bad())?;
    let grid = TileGrid::parse(&format!("1x{}", n.trim())).map_err(|_| bad())?;
    grid.check_index(i)?;
    Ok((i, grid))
}

/// Reads `--tiles CxR`.
pub fn parse_grid(text: &str) -> Result<TileGrid, String> {
    TileGrid::parse(text)
}

/// One tile of every frame a render writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tile {
    /// Its index in the grid, from 0.
    pub index: u32,
    /// The grid.
    pub grid: TileGrid,
}

impl Tile {
    /// The tile the command line asks for, if any: `--tile I/N`, or `--tiles CxR` with
    /// `--tile-index I`.
    pub fn of_args(
        tile: Option<(u32, TileGrid)>,
        tiles: Option<TileGrid>,
        index: Option<u32>,
    ) -> Result<Option<Tile>, String> {
        match (tile, tiles, index) {
            (Some((index, grid)), _, _) => Ok(Some(Tile { index, grid })),
            (None, Some(grid), Some(index)) => {
                grid.check_index(index)
                    .map_err(|e| format!("--tile-index: {e}"))?;
                Ok(Some(Tile { index, grid }))
            }
            (None, Some(_), None) => Err("--tiles needs --tile-index I: which tile this task renders".into()),
            (None, None, Some(_)) => Err("--tile-index needs --tiles CxR".into()),
            (None, None, None) => Ok(None),
        }
    }

    /// Restricts `scene` to this tile of the pixels it renders (its crop window, or the whole
    /// format): the crop window becomes the tile's rectangle, exactly.
    ///
    /// # Errors
    /// When the rectangle cannot be stated as a crop window of this format (a format wider than
    /// single precision resolves), naming both.
    pub fn apply(&self, scene: &mut Scene) -> Result<PixelRect, String> {
        let region = scene.camera.pixels();
        let rect = self.grid.rect(region, self.index);
        if rect.is_empty() {
            return Err(format!(
                "tile {} of {} is empty: the image's {}×{} pixels are fewer than the grid's tiles",
                self.index,
                self.grid,
                region.width(),
                region.height()
            ));
        }
        let format = scene.camera.format;
        let (w, h) = (format.width as f32, format.height as f32);
        let crop = CropWindow {
            x_min: rect.x0 as f32 / w,
            x_max: rect.x1 as f32 / w,
            y_min: rect.y0 as f32 / h,
            y_max: rect.y1 as f32 / h,
        };
        if crop.pixels(format) != rect {
            return Err(format!(
                "tile {} of {}: pixels {rect:?} of a {}×{} image cannot be stated as a crop window",
                self.index, self.grid, format.width, format.height
            ));
        }
        scene.camera.crop_window = crop;
        Ok(rect)
    }

    /// The displays of this tile: each file named by [`TileGrid::tile_path`].
    pub fn displays(&self, displays: &[Display]) -> Vec<Display> {
        (displays.iter())
            .map(|d| Display {
                path: self.grid.tile_path(&d.path, self.index),
                ..d.clone()
            })
            .collect()
    }
}

/// `obscura merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The images of the shot as `obscura render -o` named them (out/beauty.####.exr); a run of #
    /// (or %04d) is the frame number. An EXR's PNG preview and its camera and ID sidecars are
    /// merged with it.
    #[arg(required = true, value_name = "IMAGE")]
    images: Vec<PathBuf>,
    /// The frames to collect (as `obscura render --frames` reads them). Without it, IMAGE is one
    /// frame's file.
    #[arg(long, value_name = "SPEC")]
    frames: Option<FrameSpec>,
    /// The tile grid the frames were rendered in, COLSxROWS (`--tile I/N` is 1xN). Without it, only
    /// checks that every frame is complete.
    #[arg(long, value_name = "CxR", value_parser = parse_grid)]
    tiles: Option<TileGrid>,
    /// Print nothing for frames that are fine.
    #[arg(short, long)]
    quiet: bool,
}

/// The problems of one frame, for the final list.
struct Problem {
    frame: Option<i32>,
    text: String,
}

/// `obscura merge`: every frame checked (and its tiles merged), all problems listed, exit 1 if any.
pub fn merge(a: &MergeArgs) -> Result<(), String> {
    let frames: Vec<Option<i32>> = match &a.frames {
        Some(f) => f.frames().map(Some).collect(),
        None => vec![None],
    };
    let several = frames.len() > 1;
    let mut problems: Vec<Problem> = Vec::new();
    let mut done = 0usize;
    for &frame in &frames {
        let mut frame_problems = Vec::new();
        for image in &a.images {
            let path = match frame {
                Some(n) => match u32::try_from(n) {
                    Ok(n) => frame_path(image, n, several),
                    Err(_) => {
                        frame_problems.push(format!("frame {n}: output names are numbered from 0"));
                        continue;
                    }
                },
                None => image.clone(),
            };
            let result = match a.tiles {
                Some(grid) => merge_one(&path, grid),
                None => check_complete(&path),
            };
            match result {
                Ok(written) => {
                    if !a.quiet {
                        for p in written {
                            outln!("{}", p.display());
                        }
                    }
                }
                Err(e) => frame_problems.push(e),
            }
        }
        if frame_problems.is_empty() {
            done += 1;
        }
        problems.extend(frame_problems.into_iter().map(|text| Problem { frame, text }));
    }
    if problems.is_empty() {
        if !a.quiet {
            outln!("{done} frame(s) complete");
        }
        return Ok(());
    }
    let missing: Vec<String> = {
        let mut v: Vec<i32> = problems.iter().filter_map(|p| p.frame).collect();
        v.dedup();
        v.iter().map(ToString::to_string).collect()
    };
    for p in &problems {
        eprintln!("error: {}", p.text);
    }
    Err(format!(
        "{} of {} frame(s) incomplete{}",
        frames.len() - done,
        frames.len(),
        if missing.is_empty() {
            String::new()
        } else {
            format!(": {}", missing.join(","))
        }
    ))
}

/// True when the camera JSON at `path` says `"complete": true`; otherwise why not.
fn sidecar_complete(path: &Path) -> Result<(), String> {
    let v = read_camera(path)?;
    match v.get("complete") {
        Some(serde_json::Value::Bool(true)) => Ok(()),
        _ => Err(format!(
            "{}: incomplete (\"complete\" is not true: its render was interrupted or failed)",
            path.display()
        )),
    }
}

/// Without tiles: the image exists and, when it has a camera JSON, that says it is complete.
fn check_complete(image: &Path) -> Result<Vec<PathBuf>, String> {
    if !image.is_file() {
        return Err(format!("{}: missing", image.display()));
    }
    let camera = sidecar_path(image, "camera.json");
    if camera.exists() {
        sidecar_complete(&camera)?;
    }
    Ok(Vec::new())
}

/// The tiles of one image merged: the image (EXR or PNG), the PNG preview beside an EXR when its
/// tiles exist, the ID sidecar, then the camera JSON (last, `"complete": true`). Every tile's camera
/// JSON, where they exist, must say complete. Returns the files written.
fn merge_one(image: &Path, grid: TileGrid) -> Result<Vec<PathBuf>, String> {
    let err = |e: MergeError| e.to_string();
    let tiles = tile_files(image, grid).map_err(err)?;
    let cameras: Vec<PathBuf> = tiles.iter().map(|t| sidecar_path(t, "camera.json")).collect();
    let with_camera = cameras.iter().filter(|c| c.exists()).count();
    if with_camera > 0 {
        for c in &cameras {
            if !c.exists() {
                return Err(format!("{}: missing (the other tiles have theirs)", c.display()));
            }
            sidecar_complete(c)?;
        }
    }
    let mut written = Vec::new();
    let is_png = |p: &Path| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if is_png(image) {
        merge_png(&tiles, grid, image).map_err(err)?;
    } else {
        merge_exr(&tiles, grid, image, &|name, value, rect| {
            (name == "obscura:camera")
                .then(|| with_data_window(value, rect))
                .flatten()
        })
        .map_err(err)?;
    }
    written.push(image.to_path_buf());
    let preview = image.with_extension("png");
    if !is_png(image) && grid.tile_path(&preview, 0).is_file() {
        let pngs = tile_files(&preview, grid).map_err(err)?;
        merge_png(&pngs, grid, &preview).map_err(err)?;
        written.push(preview);
    }
    let ids: Vec<PathBuf> = tiles.iter().map(|t| sidecar_path(t, "ids.json")).collect();
    if ids[0].is_file() {
        let first = std::fs::read(&ids[0]).map_err(|e| format!("{}: {e}", ids[0].display()))?;
        for p in &ids[1..] {
            let other = std::fs::read(p).map_err(|e| format!("{}: {e}", p.display()))?;
            if other != first {
                return Err(format!(
                    "{}: does not belong with {}: another ID table (another scene)",
                    p.display(),
                    ids[0].display()
                ));
            }
        }
        let path = sidecar_path(image, "ids.json");
        obscura_image::atomic::write_atomically(&path, |out| std::io::Write::write_all(out, &first))
            .map_err(|e| e.to_string())?;
        written.push(path);
    }
    if with_camera > 0 {
        written.push(merge_camera(&cameras, image, grid)?);
    }
    Ok(written)
}

/// Reads a camera JSON.
fn read_camera(path: &Path) -> Result<serde_json::Value, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: not a camera JSON: {e}", path.display()))
}

/// The merged image's camera JSON: tile 0's with the data window of the whole (the union of the
/// tiles') and the untiled image names.
fn merge_camera(cameras: &[PathBuf], image: &Path, grid: TileGrid) -> Result<PathBuf, String> {
    let mut v = read_camera(&cameras[0])?;
    let mut window: Option<[u64; 4]> = None;
    for c in cameras {
        let tile = read_camera(c)?;
        let w: Option<Vec<u64>> = (tile.pointer("/image/data_window").and_then(|w| w.as_array()))
            .map(|a| a.iter().filter_map(serde_json::Value::as_u64).collect());
        let Some([x0, y0, x1, y1]) = w.as_deref().and_then(|w| <[u64; 4]>::try_from(w).ok()) else {
            return Err(format!("{}: no image.data_window", c.display()));
        };
        window = Some(match window {
            None => [x0, y0, x1, y1],
            Some(u) => [u[0].min(x0), u[1].min(y0), u[2].max(x1), u[3].max(y1)],
        });
    }
    if let (Some(u), Some(w)) = (window, v.pointer_mut("/image/data_window")) {
        *w = serde_json::json!(u);
    }
    let out = sidecar_path(image, "camera.json");
    let dir = cameras[0].parent().unwrap_or(Path::new("."));
    let tag = format!(".tile0-{}x{}", grid.cols, grid.rows);
    if let Some(list) = v.get_mut("images").and_then(|i| i.as_array_mut()) {
        for item in list.iter_mut() {
            if let Some(name) = item.as_str() {
                let untiled = dir.join(name.replacen(&tag, "", 1));
                *item = serde_json::Value::String(relative_to_sidecar(&untiled, &out));
            }
        }
    }
    obscura_render::metadata::write_json(&out, &v).map_err(|e| e.to_string())?;
    Ok(out)
}
