//! The limits every job is checked against before any work: image size, memory, threads, samples,
//! output files.
//!
//! A job that cannot finish should fail in seconds with a message, not after an hour of rendering or
//! in the allocator. The checks live here, in the library, so the command line and any other front
//! end refuse the same jobs with the same words:
//!
//! - **image size**: each side at most [`MAX_IMAGE_SIDE`] pixels and at most [`MAX_IMAGE_PIXELS`] in
//!   all ([`check_image_size`]), whatever set it (`--format`, RIB `Format`, a calibration file);
//! - **memory**: an estimate of the bytes the job allocates ([`render_bytes`], [`ray_map_bytes`],
//!   [`stmap_bytes`]) against the memory available ([`memory_limit`]: `OBSCURA_MEMORY_LIMIT`, else the
//!   smallest of the cgroup's limit, `MemAvailable` of `/proc/meminfo` and the process's address-space
//!   limit), and the scene's triangles against what that memory holds
//!   ([`obscura_geometry::dice::TriangleBudget::within_memory`]);
//! - **threads**: 1 to [`MAX_THREADS`]; an absurd count is an error, not clamped;
//! - **samples per pixel**: 1 to [`obscura_host::sampler::MAX_SAMPLES`];
//! - **output files** ([`check_output`]): a known extension for the driver, an existing directory we
//!   may create files in, and not a directory itself.

use std::path::Path;

use obscura_host::sampler::MAX_SAMPLES;

use obscura_image::atomic;

/// The longest image side, in pixels (OpenEXR stores coordinates as `i32`; 64 Ki is beyond any
/// production plate).
pub const MAX_IMAGE_SIDE: u32 = 65_536;

/// The most pixels of one image (2³⁰, about a gigapixel).
pub const MAX_IMAGE_PIXELS: u64 = 1 << 30;

/// The most worker threads a job may ask for.
pub const MAX_THREADS: usize = 1024;

/// The environment variable that sets the memory a job may use, in bytes with an optional `K`, `M`,
/// `G` or `T` suffix (powers of 1024): `OBSCURA_MEMORY_LIMIT=8G`.
pub const MEMORY_LIMIT_VAR: &str = "OBSCURA_MEMORY_LIMIT";

/// Bytes per pixel of the film (its accumulator).
const FILM_BYTES: u64 = obscura_image::film::Film::BYTES_PER_PIXEL as u64;
/// Bytes per pixel of one resolved pixel at writing (every AOV).
const RESOLVED_BYTES: u64 = std::mem::size_of::<obscura_image::film::SampleValues>() as u64;
/// Bytes per pixel of one deep sample (Z, ZBack, colour, alpha), times the samples per pixel.
const DEEP_SAMPLE_BYTES: u64 = 32;
/// Bytes per pixel of one ray-map layer (screen, ray, tint, time) and its 17 EXR channels, twice
/// (the channels and their compressed copy).
const RAY_LAYER_BYTES: u64 = 64 + 2 * 17 * 4;
/// Bytes per pixel of an ST-map (s, t, alpha) and its four EXR channels, twice.
const STMAP_BYTES: u64 = 12 + 2 * 4 * 4;

/// A job refused before it started. Each message names what set the value and the limit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LimitError {
    /// An image side of zero or over [`MAX_IMAGE_SIDE`], or over [`MAX_IMAGE_PIXELS`] in all.
    #[error(
        "{source_name}: an image of {width}x{height} pixels is too large: expected each side in 1..={MAX_IMAGE_SIDE} \
         and at most {MAX_IMAGE_PIXELS} pixels in all"
    )]
    ImageSize {
        /// What set the size: `--format`, `scene.rib:3: Format`, a calibration file.
        source_name: String,
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// The job's memory estimate exceeds the memory available.
    #[error(
        "{what} needs about {} of memory, more than the {} available ({limit_source}); \
         render a smaller --format or a --crop, or raise {MEMORY_LIMIT_VAR}",
        human(*need), human(*limit)
    )]
    Memory {
        /// The job: `a 20000x20000 render with 6 AOVs`.
        what: String,
        /// The estimate, in bytes.
        need: u64,
        /// The limit, in bytes.
        limit: u64,
        /// Where the limit comes from.
        limit_source: String,
    },
    /// `--threads 0` or more than [`MAX_THREADS`].
    #[error("--threads {0}: expected 1..={MAX_THREADS} worker threads")]
    Threads(usize),
    /// Samples per pixel of zero or over the sampler's maximum.
    #[error("{source_name}: {spp} samples per pixel: expected 1..={MAX_SAMPLES}")]
    Samples {
        /// What set the count: `--spp`, the scene's `Hider "int maxsamples"`.
        source_name: String,
        /// The count.
        spp: u32,
    },
    /// An output file that cannot be written: its extension, its directory, or a directory in its place.
    #[error("output {path}: {reason}")]
    Output {
        /// The file.
        path: String,
        /// Why it cannot be written.
        reason: String,
    },
    /// An object whose transform is not finite (it would vanish from the render).
    #[error(
        "{object}: the object-to-world transform at time {time} is not finite (a Translate, Scale or matrix \
         beyond f32's range of ±3.4e38); the object would vanish from the render"
    )]
    Transform {
        /// Where the object was declared (`scene.rib:42`, a glTF node).
        object: String,
        /// The motion sample's time.
        time: f32,
    },
    /// `OBSCURA_MEMORY_LIMIT` does not read as a size.
    #[error(
        "{MEMORY_LIMIT_VAR}={0}: expected a number of bytes with an optional K, M, G or T suffix, e.g. 8G"
    )]
    MemoryVariable(String),
}

/// `bytes` in KiB, MiB, GiB or TiB with one decimal.
#[must_use]
pub fn human(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["bytes", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{v:.1} {}", UNITS[unit])
    }
}

/// Checks an image size set by `source_name` against [`MAX_IMAGE_SIDE`] and [`MAX_IMAGE_PIXELS`].
///
/// # Errors
/// [`LimitError::ImageSize`] naming `source_name`.
pub fn check_image_size(width: u32, height: u32, source_name: &str) -> Result<(), LimitError> {
    let ok = (1..=MAX_IMAGE_SIDE).contains(&width)
        && (1..=MAX_IMAGE_SIDE).contains(&height)
        && u64::from(width) * u64::from(height) <= MAX_IMAGE_PIXELS;
    if ok {
        Ok(())
    } else {
        Err(LimitError::ImageSize {
            source_name: source_name.to_string(),
            width,
            height,
        })
    }
}

/// Checks a worker-thread count: 1 to [`MAX_THREADS`].
///
/// # Errors
/// [`LimitError::Threads`].
pub fn check_threads(threads: usize) -> Result<(), LimitError> {
    if (1..=MAX_THREADS).contains(&threads) {
        Ok(())
    } else {
        Err(LimitError::Threads(threads))
    }
}

/// Checks a samples-per-pixel count set by `source_name`: 1 to the sampler's maximum.
///
/// # Errors
/// [`LimitError::Samples`].
pub fn check_samples(spp: u32, source_name: &str) -> Result<(), LimitError> {
    if (1..=MAX_SAMPLES).contains(&spp) {
        Ok(())
    } else {
        Err(LimitError::Samples {
            source_name: source_name.to_string(),
            spp,
        })
    }
}

/// The bytes a render of `pixels` (the crop's) allocates: the film, the resolved pixels and the
/// `channels` f32 channels of the largest output twice (channels and compressed copy), and with
/// `deep_samples` per pixel the deep samples.
#[must_use]
pub fn render_bytes(pixels: u64, channels: u64, deep_samples: Option<u32>) -> u64 {
    let per_pixel = FILM_BYTES + RESOLVED_BYTES + 2 * 4 * channels;
    let deep = deep_samples.map_or(0, |s| u64::from(s) * DEEP_SAMPLE_BYTES);
    pixels.saturating_mul(per_pixel.saturating_add(deep))
}

/// The bytes `obscura rays` allocates for `pixels` and `samples` sample layers.
#[must_use]
pub fn ray_map_bytes(pixels: u64, samples: u32) -> u64 {
    pixels.saturating_mul(RAY_LAYER_BYTES.saturating_mul(1 + u64::from(samples)))
}

/// The bytes `obscura stmap` allocates for a map of `pixels`.
#[must_use]
pub fn stmap_bytes(pixels: u64) -> u64 {
    pixels.saturating_mul(STMAP_BYTES)
}

/// The memory a job may use, in bytes, and where that figure comes from: `OBSCURA_MEMORY_LIMIT` when
/// set; else the smallest of the cgroup's `memory.max`, `/proc/meminfo`'s `MemAvailable` and the
/// process's address-space limit (`ulimit -v`, `prlimit --as`, a farm's virtual-memory limit such as
/// Grid Engine's `h_vmem`); `None` where none can be read (then only the image-size limits apply).
///
/// # Errors
/// [`LimitError::MemoryVariable`] when the variable is set but not a size.
pub fn memory_limit() -> Result<Option<(u64, String)>, LimitError> {
    if let Some(v) = std::env::var_os(MEMORY_LIMIT_VAR) {
        let text = v.to_string_lossy().into_owned();
        let bytes = parse_size(&text).ok_or(LimitError::MemoryVariable(text.clone()))?;
        return Ok(Some((bytes, format!("{MEMORY_LIMIT_VAR}={text}"))));
    }
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| mem_available(&t))
        .map(|b| (b, "MemAvailable in /proc/meminfo".to_string()));
    let cgroup = std::fs::read_to_string("/sys/fs/cgroup/memory.max")
        .ok()
        .and_then(|t| t.trim().parse::<u64>().ok())
        .map(|b| (b, "the cgroup's memory.max".to_string()));
    let address_space = std::fs::read_to_string("/proc/self/limits")
        .ok()
        .and_then(|t| address_space_limit(&t))
        .map(|b| (b, "the process's address-space limit, ulimit -v".to_string()));
    Ok([available, cgroup, address_space]
        .into_iter()
        .flatten()
        .min_by_key(|(bytes, _)| *bytes))
}

/// The soft "Max address space" of a `/proc/<pid>/limits` text, in bytes (`None` when unlimited).
fn address_space_limit(limits: &str) -> Option<u64> {
    let line = limits.lines().find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..]
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// `MemAvailable` of a `/proc/meminfo` text, in bytes.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// Reads `123`, `512M`, `8G`, `1.5T` (powers of 1024; a trailing `B`/`iB` is allowed).
#[must_use]
pub fn parse_size(text: &str) -> Option<u64> {
    let t = text.trim();
    let t = t.strip_suffix("iB").or_else(|| t.strip_suffix('B')).unwrap_or(t);
    let (number, scale) = match t.char_indices().last()? {
        (i, 'K' | 'k') => (&t[..i], 1u64 << 10),
        (i, 'M' | 'm') => (&t[..i], 1 << 20),
        (i, 'G' | 'g') => (&t[..i], 1 << 30),
        (i, 'T' | 't') => (&t[..i], 1 << 40),
        _ => (t, 1),
    };
    let v: f64 = number.trim().parse().ok()?;
    (v.is_finite() && v >= 0.0 && v * (scale as f64) < u64::MAX as f64).then_some((v * scale as f64) as u64)
}

/// Checks `need` bytes for the job described by `what` against [`memory_limit`].
///
/// # Errors
/// [`LimitError::Memory`] with the estimate and the limit, or [`LimitError::MemoryVariable`].
pub fn check_memory(need: u64, what: &str) -> Result<(), LimitError> {
    match memory_limit()? {
        Some((limit, limit_source)) if need > limit => Err(LimitError::Memory {
            what: what.to_string(),
            need,
            limit,
            limit_source,
        }),
        _ => Ok(()),
    }
}

/// The output kinds and the extensions each may be written under.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    /// OpenEXR (flat or deep): `.exr`.
    Exr,
    /// 8-bit PNG: `.png`.
    Png,
    /// Baseline TIFF: `.tif`, `.tiff`.
    Tiff,
    /// The sensor's raw mosaic: `.dng`.
    Dng,
}

impl OutputKind {
    /// The extensions (lower case, without the dot) this kind is written under.
    #[must_use]
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            OutputKind::Exr => &["exr"],
            OutputKind::Png => &["png"],
            OutputKind::Tiff => &["tif", "tiff"],
            OutputKind::Dng => &["dng"],
        }
    }

    /// The kind an output path's extension names, if any.
    #[must_use]
    pub fn of_path(path: &Path) -> Option<OutputKind> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        [
            OutputKind::Exr,
            OutputKind::Png,
            OutputKind::Tiff,
            OutputKind::Dng,
        ]
        .into_iter()
        .find(|k| k.extensions().contains(&ext.as_str()))
    }
}

/// Checks that `path` can be written as `kind` before any work: its extension is `kind`'s, it is not
/// a directory, and its directory exists and takes new files (a temporary file is created there and
/// removed, exactly as the final write will).
///
/// # Errors
/// [`LimitError::Output`] naming the path and what is wrong.
pub fn check_output(path: &Path, kind: OutputKind) -> Result<(), LimitError> {
    let fail = |reason: String| LimitError::Output {
        path: path.display().to_string(),
        reason,
    };
    let known = || {
        kind.extensions()
            .iter()
            .map(|e| format!(".{e}"))
            .collect::<Vec<_>>()
            .join(" or ")
    };
    match path.extension().and_then(|e| e.to_str()) {
        None => {
            return Err(fail(format!(
                "the file name has no extension: expected {}",
                known()
            )));
        }
        Some(e) if !kind.extensions().contains(&e.to_ascii_lowercase().as_str()) => {
            return Err(fail(format!("unknown extension \".{e}\": expected {}", known())));
        }
        Some(_) => {}
    }
    check_output_location(path)
}

/// Checks that `path` can be created: it is not a directory, and its directory exists and takes new
/// files (a temporary file is created there and removed, exactly as the final write will). For
/// outputs whose name the scene chose freely (RenderMan's `file` driver writes TIFF under any name).
///
/// # Errors
/// [`LimitError::Output`] naming the path and what is wrong.
pub fn check_output_location(path: &Path) -> Result<(), LimitError> {
    let fail = |reason: String| LimitError::Output {
        path: path.display().to_string(),
        reason,
    };
    if path.is_dir() {
        return Err(fail("is a directory".into()));
    }
    let directory = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !directory.is_dir() {
        let reason = if directory.exists() {
            format!("{} is not a directory", directory.display())
        } else {
            format!("the directory {} does not exist", directory.display())
        };
        return Err(fail(reason));
    }
    atomic::check_writable(path)
        .map_err(|e| fail(format!("cannot create files in {}: {e}", directory.display())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_sizes_are_checked_against_both_limits() {
        assert_eq!(check_image_size(640, 480, "--format"), Ok(()));
        assert_eq!(check_image_size(MAX_IMAGE_SIDE, 16384, "--format"), Ok(()));
        for (w, h) in [
            (0, 5),
            (5, 0),
            (MAX_IMAGE_SIDE + 1, 1),
            (4_000_000_000, 1),
            (65536, 65536),
        ] {
            let e = check_image_size(w, h, "x.rib:1: Format").unwrap_err().to_string();
            assert!(
                e.starts_with(&format!(
                    "x.rib:1: Format: an image of {w}x{h} pixels is too large"
                )),
                "{e}"
            );
        }
    }

    #[test]
    fn threads_and_samples_outside_their_range_are_errors_not_clamped() {
        assert_eq!(check_threads(1), Ok(()));
        assert_eq!(check_threads(MAX_THREADS), Ok(()));
        assert_eq!(check_threads(0), Err(LimitError::Threads(0)));
        assert_eq!(
            check_threads(100_000).unwrap_err().to_string(),
            "--threads 100000: expected 1..=1024 worker threads"
        );
        assert!(check_samples(1, "--spp").is_ok());
        assert!(check_samples(MAX_SAMPLES + 1, "--spp").is_err());
        assert!(
            check_samples(0, "Hider")
                .unwrap_err()
                .to_string()
                .starts_with("Hider: 0 samples")
        );
    }

    #[test]
    fn sizes_read_with_binary_suffixes() {
        assert_eq!(parse_size("123"), Some(123));
        assert_eq!(parse_size("2K"), Some(2048));
        assert_eq!(parse_size("1.5G"), Some(3 << 29));
        assert_eq!(parse_size("8GiB"), Some(8 << 30));
        assert_eq!(parse_size("1T"), Some(1 << 40));
        for bad in ["", "G", "-1", "abc", "1Q", "nan", "1e30T"] {
            assert_eq!(parse_size(bad), None, "{bad}");
        }
        assert_eq!(human(512), "512 bytes");
        assert_eq!(human(3 << 29), "1.5 GiB");
    }

    #[test]
    fn mem_available_is_read_in_kib() {
        let t = "MemTotal:       24000000 kB\nMemFree: 1 kB\nMemAvailable:   2048 kB\n";
        assert_eq!(mem_available(t), Some(2 << 20));
        assert_eq!(mem_available("MemTotal: 1 kB"), None);
    }

    #[test]
    fn the_address_space_limit_is_the_soft_one_of_proc_limits() {
        let limited = "Limit                     Soft Limit           Hard Limit           Units     \n\
                       Max stack size            8388608              unlimited            bytes     \n\
                       Max address space         2147483648           4294967296           bytes     \n";
        assert_eq!(address_space_limit(limited), Some(2 << 30));
        let unlimited = "Max address space         unlimited            unlimited            bytes     \n";
        assert_eq!(address_space_limit(unlimited), None);
        assert_eq!(
            address_space_limit("Max stack size 8388608 unlimited bytes"),
            None
        );
        // This process's own file reads, whatever its limit.
        let own = std::fs::read_to_string("/proc/self/limits").unwrap();
        assert!(own.contains("Max address space"));
    }

    #[test]
    fn the_estimates_grow_with_pixels_channels_deep_samples_and_layers() {
        // The film's accumulator is what the allocator refused in issue 16 (880000000000 bytes for
        // 10^10 pixels): at least 88 bytes a pixel.
        const { assert!(FILM_BYTES >= 88) };
        assert_eq!(render_bytes(1, 0, None), FILM_BYTES + RESOLVED_BYTES);
        assert!(render_bytes(1, 14, None) > render_bytes(1, 4, None));
        assert!(render_bytes(1, 4, Some(64)) > render_bytes(1, 4, None) + 63 * 32);
        assert_eq!(render_bytes(u64::MAX, 14, Some(65536)), u64::MAX);
        assert_eq!(ray_map_bytes(10, 3), 4 * ray_map_bytes(10, 0));
        // 20000x20000 with every AOV: tens of GiB, more than this machine class has.
        assert!(render_bytes(400_000_000, 14, None) > 64 << 30);
        assert!(stmap_bytes(100) > 0);
    }

    #[test]
    fn outputs_need_a_known_extension_and_a_writable_directory() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(check_output(&dir.path().join("a.exr"), OutputKind::Exr), Ok(()));
        assert_eq!(check_output(&dir.path().join("a.EXR"), OutputKind::Exr), Ok(()));
        assert_eq!(check_output(&dir.path().join("a.png"), OutputKind::Png), Ok(()));
        // The probe leaves nothing behind.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let msg = |p: &Path, k| check_output(p, k).unwrap_err().to_string();
        let e = msg(&dir.path().join("x.txt"), OutputKind::Exr);
        assert!(e.ends_with("unknown extension \".txt\": expected .exr"), "{e}");
        let e = msg(&dir.path().join("x"), OutputKind::Exr);
        assert!(
            e.ends_with("the file name has no extension: expected .exr"),
            "{e}"
        );
        let e = msg(&dir.path().join("x.tif"), OutputKind::Exr);
        assert!(e.ends_with("unknown extension \".tif\": expected .exr"), "{e}");
        assert_eq!(check_output(&dir.path().join("a.tiff"), OutputKind::Tiff), Ok(()));
        let e = msg(&dir.path().join("missing/x.exr"), OutputKind::Exr);
        assert!(e.contains("does not exist"), "{e}");
        std::fs::create_dir(dir.path().join("d.exr")).unwrap();
        let e = msg(&dir.path().join("d.exr"), OutputKind::Exr);
        assert!(e.ends_with("is a directory"), "{e}");
        std::fs::write(dir.path().join("f"), b"").unwrap();
        let e = msg(&dir.path().join("f/x.exr"), OutputKind::Exr);
        assert!(e.contains("is not a directory"), "{e}");
        assert_eq!(OutputKind::of_path(Path::new("a.PNG")), Some(OutputKind::Png));
        assert_eq!(OutputKind::of_path(Path::new("a.tif")), Some(OutputKind::Tiff));
        assert_eq!(OutputKind::of_path(Path::new("a.txt")), None);
    }
}
