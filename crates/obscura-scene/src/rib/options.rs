//! The options: what the image and the camera are (`Format`, `ScreenWindow`, `CropWindow`, `Shutter`,
//! `Clipping`, `PixelFilter`, `Hider`, `Projection`, `Camera`, `Option`; `Display` is in `display.rs`).
//! They may only come before `WorldBegin`.

use obscura_host::CropWindow;
use obscura_sdk::{Format, ScreenWindow};

use super::lex::Value;
use super::request::{Req, get_float, get_floats, get_int};
use super::{Reader, RibError};
use crate::types::{FilterKind, PixelFilter};

/// `Clipping` far values at least this large mean "no far plane" (RenderMan writes 1e30).
const FAR_IS_INFINITE: f32 = 1e30;

/// The pixel filters, as `PixelFilter` spells them.
pub(super) const FILTERS: [(&str, FilterKind); 6] = [
    ("box", FilterKind::Box),
    ("triangle", FilterKind::Triangle),
    ("gaussian", FilterKind::Gaussian),
    ("catmull-rom", FilterKind::CatmullRom),
    ("mitchell", FilterKind::Mitchell),
    ("blackman-harris", FilterKind::BlackmanHarris),
];

/// Parameters a projection may be given by bare name (`Projection "perspective" "fov" [40]`).
const PROJECTION_BARE_NAMES: [&str; 5] = [
    "float fov",
    "float fovEnd",
    "float fStop",
    "float focalLength",
    "float focalDistance",
];

/// The parameters `Camera` reads.
const CAMERA_PARAMS: [&str; 8] = [
    "int apertureNSides",
    "float apertureAngle",
    "float apertureRoundness",
    "float apertureDensity",
    "float dofaspect",
    "float shutterOpenTime",
    "float shutterCloseTime",
    "float[8] shutteropening",
];

impl Reader {
    /// `ScreenWindow left right bottom top`.
    pub(super) fn screen_window(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [l, rt, b, t] = r.only_numbers::<4>("left right bottom top")?;
        if !(l < rt && b < t) {
            return Err(r.err(format!(
                "ScreenWindow expects left < right and bottom < top, got {l} {rt} {b} {t}"
            )));
        }
        self.scene.camera.screen_window = Some(ScreenWindow::new(l, rt, b, t));
        Ok(())
    }

    /// `CropWindow xmin xmax ymin ymax`, fractions of the image.
    pub(super) fn crop_window(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [x_min, x_max, y_min, y_max] = r.only_numbers::<4>("xmin xmax ymin ymax")?;
        let unit = |v: f32| (0.0..=1.0).contains(&v);
        if !(unit(x_min) && unit(x_max) && unit(y_min) && unit(y_max) && x_min < x_max && y_min < y_max) {
            return Err(r.err(format!(
                "CropWindow expects 0 <= xmin < xmax <= 1 and 0 <= ymin < ymax <= 1, got {x_min} {x_max} {y_min} {y_max}"
            )));
        }
        self.scene.camera.crop_window = CropWindow {
            x_min,
            x_max,
            y_min,
            y_max,
        };
        Ok(())
    }

    /// `Shutter open close`.
    pub(super) fn shutter(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [open, close] = r.only_numbers::<2>("open close")?;
        if open > close {
            return Err(r.err(format!("Shutter expects open <= close, got {open} {close}")));
        }
        self.scene.camera.shutter = (open, close);
        Ok(())
    }

    /// `Clipping near far`; a far of [`FAR_IS_INFINITE`] or more is no far plane.
    pub(super) fn clipping(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [near, far] = r.only_numbers::<2>("near far")?;
        let far = if far >= FAR_IS_INFINITE {
            f32::INFINITY
        } else {
            far
        };
        if !(near > 0.0 && far > near) {
            return Err(r.err(format!("Clipping expects 0 < near < far, got {near} {far}")));
        }
        self.scene.camera.clipping = (near, far);
        Ok(())
    }

    /// `Format width height pixelaspect`. As RISpec 3.2 says, a value ≤ 0 means "the default": a
    /// width or height ≤ 0 keeps the current one, and a pixel aspect ≤ 0 (RenderMan writes −1) is 1.
    pub(super) fn format(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [w, h, pa] = r.only_numbers::<3>("width height pixelaspect")?;
        let current = self.scene.camera.format;
        let size = |v: f32, keep: u32| {
            if v <= 0.0 {
                Some(keep)
            } else {
                (v >= 1.0 && v.fract() == 0.0 && v <= u32::MAX as f32).then_some(v as u32)
            }
        };
        let (Some(width), Some(height)) = (size(w, current.width), size(h, current.height)) else {
            return Err(r.err(format!(
                "Format expects a positive integer width and height (or ≤ 0 for the current one), got {w} {h}"
            )));
        };
        if !pa.is_finite() {
            return Err(r.err(format!("Format expects a finite pixel aspect ratio, got {pa}")));
        }
        self.scene.camera.format = Format {
            width,
            height,
            pixel_aspect: if pa <= 0.0 { 1.0 } else { pa },
        };
        Ok(())
    }

    /// `PixelFilter "name" xwidth ywidth`.
    pub(super) fn pixel_filter(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name), rest @ ..] = r.args else {
            return Err(r.err("PixelFilter expects a filter name then xwidth ywidth"));
        };
        let kind = match FILTERS.iter().find(|(n, _)| n == name) {
            Some(&(_, kind)) => kind,
            None => {
                // Filters of other renderers: the nearest here, by the shape of their kernel.
                let (stand_in, kind) = match name.as_str() {
                    "sinc" | "lanczos" | "separable-catmull-rom" => ("catmull-rom", FilterKind::CatmullRom),
                    _ => ("gaussian", FilterKind::Gaussian),
                };
                let names: Vec<&str> = FILTERS.iter().map(|(n, _)| *n).collect();
                self.warn(
                    r,
                    format!(
                        "PixelFilter \"{name}\" is not available: {stand_in} of the same width is used (available: {})",
                        names.join(", ")
                    ),
                );
                kind
            }
        };
        let ([width_x, width_y], extra) = r.numbers::<2>(rest, "a filter name then xwidth ywidth")?;
        if !extra.is_empty() {
            return Err(r.err("PixelFilter expects a filter name then xwidth ywidth, and nothing after"));
        }
        if !(width_x > 0.0 && width_y > 0.0) {
            return Err(r.err(format!(
                "PixelFilter expects positive widths, got {width_x} {width_y}"
            )));
        }
        self.scene.filter = PixelFilter {
            kind,
            width_x,
            width_y,
        };
        Ok(())
    }

    /// `Hider "raytrace"` with `maxsamples` (the samples per pixel); other hiders are warned about.
    pub(super) fn hider(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name), rest @ ..] = r.args else {
            return Err(r.err("Hider expects a hider name (a string) then parameters"));
        };
        if name != "raytrace" {
            self.warn(
                r,
                format!("Hider \"{name}\" is not supported (only \"raytrace\"), ignored"),
            );
            return Ok(());
        }
        let list = self.params(
            r,
            rest,
            &["int maxsamples", "int minsamples", "int incremental"],
            false,
        )?;
        if let Some(n) = get_int(&list, "maxsamples") {
            let n = u32::try_from(n)
                .ok()
                .filter(|&n| n >= 1)
                .ok_or_else(|| r.err(format!("Hider: maxsamples must be at least 1, got {n}")))?;
            self.scene.samples_per_pixel = n;
        }
        Ok(())
    }

    /// `PixelSamples xsamples ysamples`: the RI's samples per pixel in x and y, read as
    /// `⌈xsamples⌉·⌈ysamples⌉` samples per pixel (the renderer stratifies them itself); a later
    /// `Hider "raytrace" "maxsamples"` or `--spp` replaces it.
    pub(super) fn pixel_samples(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [x, y] = r.only_numbers::<2>("xsamples ysamples")?;
        let count = |v: f32| {
            (v.is_finite() && (1.0..=65_536.0).contains(&v))
                .then(|| v.ceil() as u32)
                .ok_or_else(|| {
                    r.err(format!(
                        "PixelSamples expects sample counts from 1 to 65536, got {x} {y}"
                    ))
                })
        };
        let samples = count(x)?.saturating_mul(count(y)?);
        if samples > obscura_host::sampler::MAX_SAMPLES {
            return Err(r.err(format!(
                "PixelSamples {x} {y} asks for {samples} samples per pixel; at most {} are allowed",
                obscura_host::sampler::MAX_SAMPLES
            )));
        }
        self.scene.samples_per_pixel = samples;
        Ok(())
    }

    /// `Projection "name"` and its parameters, kept as given for the projection plugin (`perspective` and
    /// `orthographic` name `PxrPerspective` and `PxrOrthographic`). A `Projection` that follows another
    /// keeps the earlier one as [`Scene::projection_base`](crate::Scene::projection_base): RenderMan
    /// applies a built-in declared before a plugin first, and the plugin filters its rays.
    pub(super) fn projection(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name), rest @ ..] = r.args else {
            return Err(r.err("Projection expects a projection name (a string) then parameters"));
        };
        let plugin = match name.as_str() {
            "perspective" => "PxrPerspective",
            "orthographic" => "PxrOrthographic",
            other => other,
        };
        let list = self.params(r, rest, &PROJECTION_BARE_NAMES, true)?;
        let earlier = std::mem::replace(&mut self.scene.projection, plugin.to_string());
        let earlier_params = std::mem::replace(&mut self.scene.projection_params, list);
        self.scene.projection_base = self.projection_declared.then_some((earlier, earlier_params));
        self.scene.projection_origin = Some(r.at());
        self.projection_declared = true;
        Ok(())
    }

    /// `Camera "name"` with the aperture and shutter-opening parameters.
    pub(super) fn camera(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(_name), rest @ ..] = r.args else {
            return Err(r.err("Camera expects a camera name (a string) then parameters"));
        };
        let list = self.params(r, rest, &CAMERA_PARAMS, false)?;
        let cam = &mut self.scene.camera;
        if let Some(n) = get_int(&list, "apertureNSides") {
            cam.aperture.n_sides = n;
        }
        let floats = [
            ("apertureAngle", &mut cam.aperture.angle_deg),
            ("apertureRoundness", &mut cam.aperture.roundness),
            ("apertureDensity", &mut cam.aperture.density),
            ("dofaspect", &mut cam.aperture.dof_aspect),
            ("shutterOpenTime", &mut cam.shutter_opening.open_time),
            ("shutterCloseTime", &mut cam.shutter_opening.close_time),
        ];
        for (name, field) in floats {
            if let Some(v) = get_float(&list, name) {
                *field = v;
            }
        }
        match get_floats(&list, "shutteropening") {
            Some(&[open, close]) => {
                cam.shutter_opening.open_time = open;
                cam.shutter_opening.close_time = close;
            }
            Some(v) => {
                if let Ok(opening) = <[f32; 8]>::try_from(v) {
                    cam.shutter_opening.opening = opening;
                }
            }
            None => {}
        }
        Ok(())
    }

    /// `Option`: none is supported; each name is warned about once.
    pub(super) fn option(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let Some(Value::Str(name)) = r.args.first() else {
            return Err(r.err("Option expects an option name (a string) then parameters"));
        };
        if name == "searchpath" {
            return self.search_path(r, &r.args[1..]);
        }
        if name == "sensor" {
            return self.sensor(r, &r.args[1..]);
        }
        if self.warned_options.insert(name.clone()) {
            self.warn(r, format!("Option \"{name}\" is not supported, ignored"));
        }
        Ok(())
    }
}
