//! What a render farm needs around `obscura render`: one tile of a frame (`--tile I/N`,
//! `--tiles CxR --tile-index I`), and `obscura merge`, the collect step that checks a shot's frames
//! are complete and stitches tiles back into the images a one-process render writes.

use std::path::{Path, PathBuf};

use clap::Args;
use obscura_host::{CropWindow, PixelRect};
use obscura_image::tiles::{MergeError, TileGrid, merge_exr, merge_png, tile_files};
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
/// tiles') and the untiled image names, edited as text so that every other byte stays.
fn merge_camera(cameras: &[PathBuf], image: &Path, grid: TileGrid) -> Result<PathBuf, String> {
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
    let first = &cameras[0];
    let text = std::fs::read_to_string(first).map_err(|e| format!("{}: {e}", first.display()))?;
    let u = window.unwrap_or_default();
    let as_u32 =
        |v: u64| u32::try_from(v).map_err(|_| format!("{}: a data window beyond 2^32", first.display()));
    let rect = PixelRect {
        x0: as_u32(u[0])?,
        y0: as_u32(u[1])?,
        x1: as_u32(u[2])?,
        y1: as_u32(u[3])?,
    };
    let text =
        with_data_window(&text, rect).ok_or_else(|| format!("{}: no image.data_window", first.display()))?;
    // The image names: relative to the sidecar, which sits beside the tile's first image as the
    // merged one sits beside the merged image, so only the tile tag goes.
    let tag = format!(".tile0-{}x{}", grid.cols, grid.rows);
    let text = match text.find("\"images\"") {
        Some(at) => {
            let end = at + text[at..].find(']').unwrap_or(text.len() - at);
            format!(
                "{}{}{}",
                &text[..at],
                text[at..end].replace(&tag, ""),
                &text[end..]
            )
        }
        None => text,
    };
    let out = sidecar_path(image, "camera.json");
    obscura_image::atomic::write_atomically(&out, |o| std::io::Write::write_all(o, text.as_bytes()))
        .map_err(|e| e.to_string())?;
    Ok(out)
}

/// The shipped job files: the Slurm array task, the Slurm collect job, the OpenJD template.
const RENDER_SBATCH: &str = include_str!("../../../scripts/farm/render.sbatch");
const COLLECT_SBATCH: &str = include_str!("../../../scripts/farm/collect.sbatch");
const OPENJD_TEMPLATE: &str = include_str!("../../../scripts/farm/job.yaml");

/// The farm engine `obscura submit` writes for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Engine {
    /// A Slurm job array over chunks × tiles (`sbatch`), then a collect job `--dependency=afterany`.
    Slurm,
    /// The Open Job Description template, run with `openjd run` (or given to a farm that runs OpenJD).
    Openjd,
}

/// `obscura submit`.
#[derive(Args, Debug)]
pub struct SubmitArgs {
    /// The engine: slurm or openjd.
    #[arg(long, value_enum)]
    engine: Engine,
    /// The scene (RIB, glTF, OBJ).
    scene: PathBuf,
    /// The images, with a run of # for the frame number (out/beauty.####.exr).
    #[arg(short, long)]
    output: PathBuf,
    /// The frames of the shot, as `obscura render --frames` reads them.
    #[arg(long, value_name = "SPEC")]
    frames: FrameSpec,
    /// Frames per task: the scene is read once per task, so larger chunks amortise its load.
    #[arg(long, value_name = "N", default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..))]
    chunk: u32,
    /// Split each frame in COLSxROWS tiles, one task each; the collect step merges them.
    #[arg(long, value_name = "CxR", value_parser = parse_grid)]
    tiles: Option<TileGrid>,
    /// Where the job files go (default: obscura-job beside the images).
    #[arg(long, value_name = "DIR")]
    job_dir: Option<PathBuf>,
    /// The obscura the tasks run (default: this one).
    #[arg(long, value_name = "PATH")]
    obscura: Option<PathBuf>,
    /// An argument for both sbatch calls (--partition=render, --time=2:00:00). Repeatable.
    #[arg(long = "sbatch-arg", value_name = "ARG", allow_hyphen_values = true)]
    sbatch_args: Vec<String>,
    /// The openjd command (default: openjd on PATH).
    #[arg(long, value_name = "PATH", default_value = "openjd")]
    openjd: PathBuf,
    /// Only write the job files and print the commands that would submit them.
    #[arg(long)]
    dry_run: bool,
    /// More `obscura render` arguments for every task, after `--` (-- --format 1920x1080 --spp 64).
    #[arg(last = true, value_name = "RENDER_ARGS")]
    render_args: Vec<String>,
}

/// `path` made absolute (tasks run in other directories), as text.
fn absolute(path: &Path) -> Result<String, String> {
    let p = std::path::absolute(path).map_err(|e| format!("{}: {e}", path.display()))?;
    p.to_str()
        .map(str::to_string)
        .ok_or_else(|| format!("{}: not valid UTF-8, which job files cannot carry", p.display()))
}

/// Writes `text` to `dir/name` atomically (mode 0755 for scripts is set by the caller's `sbatch`/
/// `bash` invocation, which does not need it).
fn write_file(dir: &Path, name: &str, text: &str) -> Result<PathBuf, String> {
    let path = dir.join(name);
    obscura_image::atomic::write_atomically(&path, |out| std::io::Write::write_all(out, text.as_bytes()))
        .map_err(|e| e.to_string())?;
    Ok(path)
}

/// Runs `cmd`, returning its standard output, or an error naming the command and its stderr.
fn run_capture(cmd: &mut std::process::Command) -> Result<String, String> {
    let shown = format!("{cmd:?}");
    let out = cmd.output().map_err(|e| format!("{shown}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "{shown} failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// `obscura submit`: the job directory written, then submitted (unless `--dry-run`).
pub fn submit(a: &SubmitArgs) -> Result<(), String> {
    let output = absolute(&a.output)?;
    let scene = absolute(&a.scene)?;
    if !a.scene.is_file() {
        return Err(format!("{scene}: no such scene file"));
    }
    let out_dir = Path::new(&output)
        .parent()
        .unwrap_or(Path::new("/"))
        .to_path_buf();
    let job = match &a.job_dir {
        Some(d) => PathBuf::from(absolute(d)?),
        None => out_dir.join("obscura-job"),
    };
    for dir in [&out_dir, &job, &job.join("logs")] {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let obscura = match &a.obscura {
        Some(p) => p.display().to_string(),
        None => std::env::current_exe()
            .map_err(|e| format!("the path of this obscura: {e}"))?
            .display()
            .to_string(),
    };
    let grid = a.tiles.unwrap_or(TileGrid { cols: 1, rows: 1 });
    let chunks = a.frames.chunks(a.chunk);
    let tasks = chunks.len() as u64 * u64::from(grid.count());
    let quote = |s: &str| format!("'{}'", s.replace('\'', "'\\''"));
    write_file(
        &job,
        "job.env",
        &format!(
            "OBSCURA={}\nTILES={grid}\nTILE_COUNT={}\nCHUNKS={}\n",
            quote(&obscura),
            grid.count(),
            chunks.len()
        ),
    )?;
    let lines = |v: &[String]| v.iter().map(|s| format!("{s}\n")).collect::<String>();
    write_file(
        &job,
        "chunks.txt",
        &lines(&chunks.iter().map(ToString::to_string).collect::<Vec<_>>()),
    )?;
    let mut render_args = vec![scene.clone(), "-o".into(), output.clone()];
    render_args.extend(a.render_args.iter().cloned());
    if render_args.iter().any(|s| s.contains('\n')) {
        return Err("render arguments cannot hold a line break".into());
    }
    write_file(&job, "render.args", &lines(&render_args))?;
    let mut collect_args = vec![output.clone(), "--frames".into(), a.frames.to_string()];
    if a.tiles.is_some() {
        collect_args.extend(["--tiles".into(), grid.to_string()]);
    }
    write_file(&job, "collect.args", &lines(&collect_args))?;
    let render_script = write_file(&job, "render.sbatch", RENDER_SBATCH)?;
    let collect_script = write_file(&job, "collect.sbatch", COLLECT_SBATCH)?;
    let template = write_file(&job, "job.yaml", OPENJD_TEMPLATE)?;
    outln!(
        "job files in {} ({tasks} render tasks: {} chunk(s) × {} tile(s))",
        job.display(),
        chunks.len(),
        grid.count()
    );

    match a.engine {
        Engine::Slurm => {
            let export = format!("--export=ALL,OBSCURA_JOB_DIR={}", job.display());
            let logs = job.join("logs");
            let mut render = std::process::Command::new("sbatch");
            render
                .arg("--parsable")
                .arg(format!("--array=0-{}", tasks - 1))
                .arg(format!("--output={}/render_%A_%a.log", logs.display()))
                .arg(&export)
                .args(&a.sbatch_args)
                .arg(&render_script);
            let collect_base = |dependency: &str| {
                let mut c = std::process::Command::new("sbatch");
                c.arg("--parsable")
                    .arg(format!("--dependency=afterany:{dependency}"))
                    .arg(format!("--output={}/collect_%j.log", logs.display()))
                    .arg(&export)
                    .args(&a.sbatch_args)
                    .arg(&collect_script);
                c
            };
            if a.dry_run {
                outln!("would run: {render:?}");
                outln!("then: {:?}", collect_base("<render job>"));
                return Ok(());
            }
            let id = run_capture(&mut render)?;
            let id = id.split(';').next().unwrap_or_default().to_string();
            outln!("render job {id}: array 0-{}", tasks - 1);
            let collect = run_capture(&mut collect_base(&id))?;
            outln!(
                "collect job {} (after any end of {id})",
                collect.split(';').next().unwrap_or_default()
            );
        }
        Engine::Openjd => {
            let mut params = vec![
                format!("Obscura={obscura}"),
                format!("Scene={scene}"),
                format!("Output={output}"),
                format!("Frames={}", a.frames),
                format!("FramesPerTask={}", a.chunk),
                format!("Tiles={grid}"),
                format!("TileIndices=0-{}", grid.count() - 1),
            ];
            if !a.render_args.is_empty() {
                params.push(format!("RenderArgs={}", a.render_args.join(" ")));
            }
            let mut run = std::process::Command::new(&a.openjd);
            run.arg("run")
                .arg(&template)
                .args(["--step", "Collect", "--run-dependencies"]);
            for p in &params {
                run.arg("-p").arg(p);
            }
            if a.dry_run {
                outln!("would run: {run:?}");
                return Ok(());
            }
            let status = run.status().map_err(|e| format!("{}: {e}", a.openjd.display()))?;
            if !status.success() {
                return Err(format!("openjd run failed ({status})"));
            }
        }
    }
    Ok(())
}
