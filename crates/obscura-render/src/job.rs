//! One `obscura render` job from start to files: load, override, prepare, render, write; and the
//! calibration files and `--param` merging that `obscura rays` and `obscura stmap` share with it.
//!
//! Kept in the library (not the binary) so that tests and other front ends run exactly what the
//! command runs: the binary only turns its arguments into an [`Overrides`] (or a [`Calibrated`]
//! camera and a parameter list) and calls these.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use obscura_calibration::files::{Calibration, CalibrationFileError};
use obscura_host::{CameraDesc, CropWindow};
use obscura_scene::rib::Frame;
use obscura_scene::source::{Images, SceneSource};
use obscura_scene::{Aov, Display, DisplayDriver, LoadError, Scene};
use obscura_sdk::{DeclarationError, Format, ParamList};

use crate::limits::{self, LimitError, OutputKind};
use crate::render::RenderOutput;
use obscura_image::deep::{DeepCompression, write_deep_exr};
use obscura_image::output::{OutputError, write_exr, write_png, write_tiff};

/// The built-in scene, rendered when no scene file is given.
pub const DEFAULT_SCENE: &str = include_str!("../scenes/default.rib");

/// The projection that renders through a calibration file (`CalibratedCamera`).
pub const CALIBRATED: &str = obscura_calibration::files::PROJECTION;

/// The image size of a scene file that does not set one (glTF, OBJ) and of the built-in scene when
/// no `--format` is given.
pub const DEFAULT_FORMAT: (u32, u32) = (640, 360);

/// Reads the scene at `path`, or the built-in scene ([`DEFAULT_SCENE`]) without one, and the
/// directory its relative paths (textures, archives) are read from.
///
/// `format` is the image size of a scene whose file does not set one (glTF, OBJ); RIB sets its own.
///
/// # Errors
/// The [`LoadError`] of the file (or of the built-in scene, which would be a bug).
pub fn load_scene(path: Option<&Path>, format: Format) -> Result<(Scene, PathBuf), LoadError> {
    Ok(match path {
        None => (
            obscura_scene::rib::parse_str(DEFAULT_SCENE, "<built-in scene>", Path::new("."))?,
            PathBuf::from("."),
        ),
        Some(path) => (
            crate::staging::load(path, CameraDesc::new(format))?,
            path.parent().map(Path::to_path_buf).unwrap_or_default(),
        ),
    })
}

/// Opens the scene at `path` frame by frame ([`SceneSource`]), or the built-in scene
/// ([`DEFAULT_SCENE`]) without one: a RIB file's images, a glTF animation posed at `fps` frames per
/// second, one image otherwise.
///
/// `format` is the image size of a scene whose file does not set one (glTF, OBJ); RIB sets its own.
///
/// # Errors
/// As [`load_scene`].
pub fn open_scene(path: Option<&Path>, format: Format, fps: f32) -> Result<Box<dyn SceneSource>, LoadError> {
    open_scene_with(path, format, fps, &obscura_usd::Options::default())
}

/// [`open_scene`] with the choices a USD stage takes (`--camera PRIM`); a `.usd`, `.usda`, `.usdc`
/// or `.usdz` file is read by `obscura_usd` (one image per time code), staged like every other format.
///
/// # Errors
/// The [`LoadError`] of the file.
pub fn open_scene_with(
    path: Option<&Path>,
    format: Format,
    fps: f32,
    usd: &obscura_usd::Options,
) -> Result<Box<dyn SceneSource>, LoadError> {
    if let Some(path) = path.filter(|p| obscura_usd::is_usd(p)) {
        let source = obscura_usd::open(path, CameraDesc::new(format), usd)?;
        return Ok(Box::new(crate::staging::Placed::new(Box::new(source), path)));
    }
    match path {
        None => {
            let (scene, dir) = load_scene(None, format)?;
            let still = Frame {
                number: 1,
                numbered: false,
                world: String::new(),
                scene,
            };
            Ok(Box::new(Images::new(vec![still], dir)))
        }
        Some(path) => {
            let source = obscura_scene::source::open(path, CameraDesc::new(format), fps)?;
            Ok(Box::new(crate::staging::Placed::new(source, path)))
        }
    }
}

/// A real camera read from a calibration file (`--calibration FILE [--camera ID]`): the file's
/// description and the parameters of [`CALIBRATED`] that reproduce it.
#[derive(Debug, Clone)]
pub struct Calibrated {
    /// The calibration as read.
    pub calibration: Calibration,
    /// `CalibratedCamera`'s parameters, each with the file and line it came from.
    pub params: ParamList,
}

impl Calibrated {
    /// Reads camera `camera` (or the file's first) of the calibration file at `path`.
    ///
    /// When the file holds several cameras and none was named, [`Calibration::selection_note`] says
    /// which was taken; printing it is the caller's choice.
    ///
    /// # Errors
    /// A [`CalibrationFileError`] naming the file (and the line, when one is to blame).
    pub fn load(path: &Path, camera: Option<&str>) -> Result<Self, CalibrationFileError> {
        Self::load_frame(path, camera, None)
    }

    /// [`Calibrated::load`] with animated parameters (a Nuke script's curves) at `frame` (`None`:
    /// the file's own current frame).
    ///
    /// # Errors
    /// As [`Calibrated::load`].
    pub fn load_frame(
        path: &Path,
        camera: Option<&str>,
        frame: Option<f64>,
    ) -> Result<Self, CalibrationFileError> {
        let calibration = obscura_calibration::files::load_frame(path, camera, frame)?;
        let params = calibration.param_list()?;
        Ok(Calibrated { calibration, params })
    }

    /// The calibration image's size in pixels.
    #[must_use]
    pub fn size(&self) -> (u32, u32) {
        (self.calibration.width, self.calibration.height)
    }

    /// A warning when `format`'s frame aspect differs from the calibration image's by more than
    /// 0.1 %: the calibrated image still fills the frame, so the same camera is resampled with
    /// non-square pixels. The text has no `warning: ` prefix.
    #[must_use]
    pub fn aspect_warning(&self, format: Format) -> Option<String> {
        let c = &self.calibration;
        let frame = f64::from(format.width) * f64::from(format.pixel_aspect) / f64::from(format.height);
        let calibrated = f64::from(c.width) / f64::from(c.height);
        ((frame / calibrated - 1.0).abs() > 1e-3).then(|| {
            format!(
                "the image is {}x{} (frame aspect {frame:.4}) but the calibration is {}x{} ({calibrated:.4}); \
                 the calibrated image fills the frame, so each pixel covers {:.3} x {:.3} calibration pixels",
                format.width,
                format.height,
                c.width,
                c.height,
                f64::from(c.width) / f64::from(format.width),
                f64::from(c.height) / f64::from(format.height)
            )
        })
    }
}

/// Adds the entries of `extra` to `list` in order, each replacing every entry of the same name
/// (command-line parameters over a scene's or a calibration's).
///
/// # Errors
/// A [`DeclarationError`] when an entry cannot be declared again (an entry of a [`ParamList`]
/// always can, so this is a bug).
pub fn merge_params(list: &mut ParamList, extra: &ParamList) -> Result<(), DeclarationError> {
    for e in extra.entries() {
        list.remove(&e.name);
        let decl = match e.array_len {
            None => format!("{} {}", e.ty, e.name),
            Some(n) => format!("{}[{n}] {}", e.ty, e.name),
        };
        list.push(&decl, e.value.clone(), e.origin.clone())?;
    }
    Ok(())
}

/// What `obscura render`'s options change in the scene it loaded, applied in this order by
/// [`Overrides::apply`]: format, crop window, projection, calibration, sensor, parameters.
#[derive(Debug, Clone, Default)]
pub struct Overrides {
    /// `--format`: the image size in pixels (the pixel aspect stays the scene's).
    pub format: Option<(u32, u32)>,
    /// `--crop`: the crop window.
    pub crop: Option<CropWindow>,
    /// `--projection`: another projection, without the scene's parameters (they were the old
    /// projection's).
    pub projection: Option<String>,
    /// `--calibration`: render through this camera with [`CALIBRATED`] and the calibration's
    /// parameters; without `format`, at the calibration image's size (square pixels).
    pub calibration: Option<Calibrated>,
    /// `--param`: parameters added to the projection's, each replacing those of the same name.
    pub params: ParamList,
    /// `--sensor` / `--sensor-param`: the sensor, replacing the scene's `Option "sensor"`.
    pub sensor: Option<obscura_sensor::SensorConfig>,
}

impl Overrides {
    /// The projection the scene renders through once these are applied: the one whose parameter
    /// table `params` should be read against.
    #[must_use]
    pub fn projection<'a>(&'a self, scene: &'a Scene) -> &'a str {
        if self.calibration.is_some() {
            CALIBRATED
        } else {
            self.projection.as_deref().unwrap_or(&scene.projection)
        }
    }

    /// Where the scene file named [`Overrides::projection`]'s projection
    /// ([`Scene::projection_origin`]); `None` when an override chose it.
    #[must_use]
    pub fn projection_origin<'a>(&self, scene: &'a Scene) -> Option<&'a str> {
        if self.calibration.is_some() || self.projection.is_some() {
            None
        } else {
            scene.projection_origin.as_deref()
        }
    }

    /// `error`, about the projection of [`Overrides::projection`], prefixed with where the scene
    /// named it (`s.rib:2: unknown projection "Nope": …`).
    #[must_use]
    pub fn locate_projection_error(&self, scene: &Scene, error: impl std::fmt::Display) -> String {
        match self.projection_origin(scene) {
            Some(at) => format!("{at}: {error}"),
            None => error.to_string(),
        }
    }

    /// Applies every override to `scene` (see the fields for what each does).
    ///
    /// # Errors
    /// A [`DeclarationError`] from [`merge_params`] (a bug).
    pub fn apply(&self, scene: &mut Scene) -> Result<(), DeclarationError> {
        if let Some((w, h)) = self.format {
            scene.camera.format.width = w;
            scene.camera.format.height = h;
        }
        if let Some(crop) = self.crop {
            scene.camera.crop_window = crop;
        }
        if let Some(p) = &self.projection {
            scene.projection = p.clone();
            scene.projection_params = ParamList::new();
            scene.projection_base = None;
        }
        if let Some(c) = &self.calibration {
            scene.projection = CALIBRATED.to_string();
            scene.projection_params = c.params.clone();
            scene.projection_base = None;
            if self.format.is_none() {
                let (w, h) = c.size();
                scene.camera.format = Format::new(w, h);
            }
        }
        if let Some(sensor) = &self.sensor {
            scene.sensor = Some(sensor.clone());
        }
        merge_params(&mut scene.projection_params, &self.params)
    }
}

/// The displays to write: the scene's own, or `output` (an EXR with beauty, alpha, z, N, P and
/// cameraDirection) when given; with neither, `render.exr`. A PNG preview is added beside the first
/// display holding the beauty (`Ci`) when no display is a PNG already and no display writes that name.
#[must_use]
pub fn displays(scene: &Scene, output: Option<&Path>) -> Vec<Display> {
    let mut list = match output {
        Some(path) => vec![Display {
            path: path.to_path_buf(),
            driver: match OutputKind::of_path(path) {
                Some(OutputKind::Png) => DisplayDriver::Png,
                Some(OutputKind::Tiff) => DisplayDriver::Tiff,
                _ => DisplayDriver::OpenExr,
            },
            aovs: vec![Aov::Ci, Aov::Alpha, Aov::Z, Aov::N, Aov::P, Aov::CameraDirection],
            half: false,
        }],
        None if scene.displays.is_empty() => vec![Display {
            path: PathBuf::from("render.exr"),
            driver: DisplayDriver::OpenExr,
            aovs: vec![Aov::Ci, Aov::Alpha, Aov::Z],
            half: false,
        }],
        None => scene.displays.clone(),
    };
    if !list.iter().any(|d| d.driver == DisplayDriver::Png)
        && let Some(beauty) = list.iter().find(|d| d.aovs.contains(&Aov::Ci))
    {
        let path = beauty.path.with_extension("png");
        if !list.iter().any(|d| d.path == path) {
            list.push(Display {
                path,
                driver: DisplayDriver::Png,
                aovs: vec![Aov::Ci, Aov::Alpha],
                half: false,
            });
        }
    }
    list
}

/// What a sensor adds to `displays`: the `raw` and `electrons` channels to every EXR holding the
/// beauty, and a `dng` display writing the raw mosaic to `raw` when given.
pub fn sensor_displays(displays: &mut Vec<Display>, raw: Option<&Path>) {
    for d in displays
        .iter_mut()
        .filter(|d| d.driver == DisplayDriver::OpenExr && d.aovs.contains(&Aov::Ci))
    {
        for a in [Aov::Raw, Aov::Electrons] {
            if !d.aovs.contains(&a) {
                d.aovs.push(a);
            }
        }
    }
    if let Some(path) = raw {
        displays.push(Display {
            path: path.to_path_buf(),
            driver: DisplayDriver::Dng,
            aovs: vec![Aov::Raw],
            half: false,
        });
    }
}

/// True when any display is deep.
#[must_use]
pub fn wants_deep(displays: &[Display]) -> bool {
    displays.iter().any(|d| d.driver == DisplayDriver::DeepExr)
}

/// Writes every display, each atomically. Returns the paths written.
///
/// # Errors
/// The first file that could not be written, named.
pub fn write_displays(
    displays: &[Display],
    out: &RenderOutput,
    pixel_aspect: f32,
    attributes: &[(&str, String)],
) -> Result<Vec<PathBuf>, OutputError> {
    let mut written = Vec::new();
    for d in displays {
        match d.driver {
            DisplayDriver::OpenExr => {
                write_exr(&d.path, &out.film, &d.aovs, d.half, pixel_aspect, attributes)?
            }
            DisplayDriver::Png => write_png(&d.path, &out.film)?,
            DisplayDriver::Tiff => write_tiff(&d.path, &out.film, &d.aovs)?,
            DisplayDriver::DeepExr => match &out.deep {
                Some(deep) => write_deep_exr(&d.path, deep, DeepCompression::Zips)?,
                None => continue,
            },
            DisplayDriver::Dng => match &out.sensor {
                Some(sensor) => {
                    let bytes = crate::sensor::dng_bytes(sensor).map_err(|e| OutputError::Raw {
                        path: d.path.clone(),
                        reason: e.to_string(),
                    })?;
                    obscura_image::atomic::write_atomically(&d.path, |f| {
                        std::io::Write::write_all(f, &bytes)
                    })?;
                }
                None => continue,
            },
        }
        written.push(d.path.clone());
    }
    Ok(written)
}

/// Checks a render job before any work ([`crate::limits`]): the image size (`size_source` names
/// what set it: `--format`, the scene file's `Format`, a calibration file), the samples per pixel
/// (`spp`, else the scene's), every object's transform being finite, the memory the film, the outputs and any deep samples need, and every
/// display's file (extension, directory).
///
/// # Errors
/// The first [`LimitError`] found.
pub fn check_render(
    scene: &Scene,
    displays: &[Display],
    spp: Option<u32>,
    size_source: &str,
) -> Result<(), LimitError> {
    let f = scene.camera.format;
    limits::check_image_size(f.width, f.height, size_source)?;
    for o in &scene.objects {
        if let Some((time, _)) = o.transform.samples.iter().find(|(_, m)| !m.is_finite()) {
            return Err(LimitError::Transform {
                object: o.source.clone(),
                time: *time,
            });
        }
    }
    let samples = match spp {
        Some(n) => {
            limits::check_samples(n, "--spp")?;
            n
        }
        None => {
            limits::check_samples(scene.samples_per_pixel, "the scene's Hider \"int maxsamples\"")?;
            scene.samples_per_pixel
        }
    };
    for d in displays {
        match d.driver {
            DisplayDriver::OpenExr | DisplayDriver::DeepExr => {
                limits::check_output(&d.path, OutputKind::Exr)?
            }
            DisplayDriver::Png => limits::check_output(&d.path, OutputKind::Png)?,
            // RenderMan's `file` driver writes TIFF under whatever name the scene gives.
            DisplayDriver::Tiff => limits::check_output_location(&d.path)?,
            DisplayDriver::Dng => limits::check_output(&d.path, OutputKind::Dng)?,
        }
        let sensor_output = d.driver == DisplayDriver::Dng || d.aovs.iter().any(|a| a.is_sensor());
        if sensor_output && scene.sensor.is_none() {
            return Err(LimitError::Output {
                path: d.path.display().to_string(),
                reason: "the raw mosaic (a dng display, or the raw or electrons AOV) needs a sensor: \
                         --sensor FILE.json, --sensor-param, or the scene's Option \"sensor\""
                    .into(),
            });
        }
    }
    let channels = displays
        .iter()
        .map(|d| d.aovs.iter().map(|&a| a.channels().len() as u64).sum::<u64>())
        .max()
        .unwrap_or(0);
    let pixels = scene.camera.pixels().len() as u64;
    let need = limits::render_bytes(pixels, channels, wants_deep(displays).then_some(samples));
    let crop = scene.camera.pixels();
    let what = format!(
        "a {}x{} render{} with {channels} channels{}",
        f.width,
        f.height,
        if crop.len() as u64 == u64::from(f.width) * u64::from(f.height) {
            String::new()
        } else {
            format!(" (crop {}x{})", crop.width(), crop.height())
        },
        if wants_deep(displays) {
            format!(" and {samples} deep samples per pixel")
        } else {
            String::new()
        }
    );
    limits::check_memory(need, &what)
}

/// A flag set by the first Ctrl-C: the render stops after the tiles in flight and writes what it has.
pub static CANCEL: AtomicBool = AtomicBool::new(false);

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::ParamValue;

    fn fixture(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../obscura-calibration/tests/fixtures")
            .join(name)
    }

    /// A scene through PxrPerspective with two parameters and a 2:1 pixel aspect.
    fn scene() -> Scene {
        let mut camera = CameraDesc::new(Format::new(100, 50));
        camera.format.pixel_aspect = 2.0;
        let mut s = Scene::new(camera);
        s.projection_params.push_text("float fov", &["40"], None).unwrap();
        s.projection_params
            .push_text("float fStop", &["2.8"], None)
            .unwrap();
        s
    }

    fn params(list: &[(&str, &str)]) -> ParamList {
        let mut l = ParamList::new();
        for (decl, value) in list {
            l.push_text(decl, &[value], Some("--param".into())).unwrap();
        }
        l
    }

    fn floats(list: &ParamList, name: &str) -> Option<Vec<f32>> {
        match &list.get(name)?.value {
            ParamValue::Floats(v) => Some(v.clone()),
            other => panic!("{name}: {other:?}"),
        }
    }

    #[test]
    fn no_overrides_change_nothing() {
        let mut s = scene();
        Overrides::default().apply(&mut s).unwrap();
        assert_eq!(s.camera, scene().camera);
        assert_eq!(s.projection, "PxrPerspective");
        assert_eq!(s.projection_params, scene().projection_params);
    }

    /// The test scene with `o` applied.
    fn applied(o: Overrides) -> Scene {
        let mut s = scene();
        o.apply(&mut s).unwrap();
        s
    }

    /// `width`×`height` with the test scene's pixel aspect, 2.
    fn format_keeping_aspect(width: u32, height: u32) -> Format {
        Format {
            width,
            height,
            pixel_aspect: 2.0,
        }
    }

    #[test]
    fn the_format_sets_the_size_and_keeps_the_pixel_aspect() {
        let s = applied(Overrides {
            format: Some((64, 48)),
            ..Overrides::default()
        });
        assert_eq!(s.camera.format, format_keeping_aspect(64, 48));
    }

    #[test]
    fn the_crop_replaces_the_scenes() {
        let mut s = scene();
        let crop = CropWindow {
            x_min: 0.25,
            x_max: 0.5,
            y_min: 0.0,
            y_max: 1.0,
        };
        let o = Overrides {
            crop: Some(crop),
            ..Overrides::default()
        };
        o.apply(&mut s).unwrap();
        assert_eq!(s.camera.crop_window, crop);
    }

    #[test]
    fn another_projection_drops_the_scenes_parameters() {
        let mut s = scene();
        let o = Overrides {
            projection: Some("PxrOrthographic".into()),
            ..Overrides::default()
        };
        assert_eq!(o.projection(&s), "PxrOrthographic");
        o.apply(&mut s).unwrap();
        assert_eq!(s.projection, "PxrOrthographic");
        assert!(s.projection_params.is_empty());
        assert_eq!(Overrides::default().projection(&s), "PxrOrthographic");
    }

    #[test]
    fn params_replace_those_of_the_same_name_and_keep_the_others() {
        let mut s = scene();
        let o = Overrides {
            params: params(&[
                ("float fov", "60"),
                ("float focalLength", "3"),
                ("float fov", "70"),
            ]),
            ..Overrides::default()
        };
        o.apply(&mut s).unwrap();
        let names: Vec<&str> = s
            .projection_params
            .entries()
            .iter()
            .map(|e| e.name.as_str())
            .collect();
        assert_eq!(names, ["fStop", "focalLength", "fov"]);
        assert_eq!(floats(&s.projection_params, "fov"), Some(vec![70.0]));
        assert_eq!(floats(&s.projection_params, "fStop"), Some(vec![2.8]));
        assert_eq!(
            s.projection_params.get("fov").unwrap().origin.as_deref(),
            Some("--param")
        );
    }

    #[test]
    fn merged_arrays_keep_their_declared_length() {
        let mut list = params(&[("float fov", "40")]);
        let mut extra = ParamList::new();
        extra.push_text("float[3] k", &["1", "2", "3"], None).unwrap();
        merge_params(&mut list, &extra).unwrap();
        let k = list.get("k").unwrap();
        assert_eq!(
            (k.array_len, &k.value),
            (Some(3), &ParamValue::Floats(vec![1.0, 2.0, 3.0]))
        );
    }

    #[test]
    fn a_calibration_renders_through_its_camera_at_its_size() {
        let c = Calibrated::load(&fixture("opencv_calibration.yml"), None).unwrap();
        assert_eq!(c.size(), (640, 480));
        assert!(!c.params.is_empty());
        let mut s = scene();
        let o = Overrides {
            calibration: Some(c.clone()),
            params: params(&[("float fov", "10")]),
            ..Overrides::default()
        };
        assert_eq!(o.projection(&s), CALIBRATED);
        o.apply(&mut s).unwrap();
        assert_eq!(s.projection, CALIBRATED);
        // The calibration's parameters replace the scene's; --param adds to them.
        assert_eq!(s.projection_params.get("fStop"), None);
        for e in c.params.entries() {
            assert_eq!(s.projection_params.get(&e.name), Some(e));
        }
        assert_eq!(floats(&s.projection_params, "fov"), Some(vec![10.0]));
        // Without --format the calibration's size, with square pixels.
        assert_eq!(s.camera.format, Format::new(640, 480));

        let s = applied(Overrides {
            format: Some((32, 24)),
            calibration: Some(c),
            ..Overrides::default()
        });
        assert_eq!(s.camera.format, format_keeping_aspect(32, 24));
    }

    #[test]
    fn a_frame_of_another_aspect_than_the_calibration_is_warned_about() {
        let c = Calibrated::load(&fixture("opencv_calibration.yml"), None).unwrap();
        assert_eq!(c.aspect_warning(Format::new(32, 24)), None);
        assert_eq!(c.aspect_warning(Format::new(640, 480)), None);
        let w = c.aspect_warning(Format::new(64, 24)).unwrap();
        assert!(
            w.starts_with("the image is 64x24 (frame aspect 2.6667) but the calibration is 640x480 (1.3333)"),
            "{w}"
        );
        assert!(
            w.ends_with("each pixel covers 10.000 x 20.000 calibration pixels"),
            "{w}"
        );
        // The frame aspect counts the pixel aspect: pixels twice as wide make 32x48 a 4:3 frame.
        let mut f = Format::new(32, 48);
        f.pixel_aspect = 2.0;
        assert_eq!(c.aspect_warning(f), None);
        f.height = 24;
        assert!(c.aspect_warning(f).unwrap().contains("frame aspect 2.6667"));
    }

    #[test]
    fn calibration_errors_name_the_file() {
        let e = Calibrated::load(&fixture("cameras.txt"), Some("9")).unwrap_err();
        assert!(e.to_string().contains("cameras.txt"), "{e}");
        let c = Calibrated::load(&fixture("cameras.txt"), None).unwrap();
        assert!(c.calibration.selection_note().is_some());
    }

    #[test]
    fn without_a_file_the_built_in_scene_is_loaded() {
        let (s, base) = load_scene(None, Format::new(8, 8)).unwrap();
        assert_eq!(base, PathBuf::from("."));
        assert!(!s.objects.is_empty());
        let e = load_scene(Some(Path::new("/nonexistent/scene.obj")), Format::new(8, 8)).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/scene.obj"), "{e}");
    }
}
