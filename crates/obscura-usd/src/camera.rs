//! `UsdGeomCamera`: every attribute with its schema fallback, and the camera Obscura renders with.
//!
//! # Attributes (UsdGeomCamera, OpenUSD 24–26)
//!
//! | attribute | fallback | unit |
//! |---|---|---|
//! | `projection` | `perspective` | `perspective` or `orthographic` |
//! | `horizontalAperture`, `verticalAperture` | 20.955, 15.2908 | tenths of a scene unit |
//! | `horizontalApertureOffset`, `verticalApertureOffset` | 0, 0 | tenths of a scene unit |
//! | `focalLength` | 50 | tenths of a scene unit |
//! | `clippingRange` | (1, 1000000) | scene units |
//! | `clippingPlanes` | `[]` | `(a, b, c, d)`: camera-space points with `a·x + b·y + c·z + d < 0` are cut |
//! | `fStop` | 0 (no depth of field) | |
//! | `focusDistance` | 0 | scene units |
//! | `shutter:open`, `shutter:close` | 0, 0 | time codes relative to the frame |
//! | `stereoRole` | `mono` | `mono`, `left`, `right` |
//! | `exposure`, `exposure:iso`, `exposure:time`, `exposure:fStop`, `exposure:responsivity` | 0, 100, 1, 1, 1 | stops, ISO, seconds, f-number, scale |
//!
//! # The rendered camera
//!
//! USD's camera looks down −Z with +Y up; Obscura's (RenderMan's) looks down +Z, so
//! `world_to_camera = diag(1, 1, −1, 1) · (camera_to_world)⁻¹`. The film gate becomes the screen window:
//! for a perspective camera, with the apertures `W × H`, offsets `(ox, oy)` and focal length `f` (all
//! in tenths of a scene unit, so only their ratios matter),
//!
//! ```text
//! screen window = [(−W/2 + ox)/f, (W/2 + ox)/f] × [(−H/2 + oy)/f, (H/2 + oy)/f]   through PxrPerspective fov = 90°
//! ```
//!
//! so the ray of screen point `(sx, sy)` is `normalize(sx, sy, 1)`: exactly the pinhole the gate and
//! focal length define. An orthographic camera's window is the same gate in scene units (`/10`) through
//! `PxrOrthographic`. Depth of field: `fStop > 0` and `focusDistance > 0` give PxrPerspective's
//! `fStop`, `focalLength = f/10` (scene units) and `focalDistance`. The exposure scale
//! `2^exposure · (time · iso/100 · responsivity)/fStop²` is the image's gain.
//!
//! With Hydra's `lensDistortion:*` authored (see [`crate::ri::RiCamera`]) a perspective camera renders
//! through `PxrCamera` as hdPrman sets it up: `fov = 2·atan(W/2f)` and the screen window above times
//! `f/(W/2)`, so the same rays before distortion, with the distortion's `x = ±1` at the gate's sides.
//!
//! # Fitting the gate to the image (`aspectRatioConformPolicy`)
//!
//! The image's aspect `A = width·pixelAspect/height` and the gate's `a = W/H` are reconciled as
//! UsdRender specifies: `expandAperture` (the fallback) grows the gate's short side, `cropAperture`
//! shrinks its long side, `adjustApertureWidth` sets `W = H·A`, `adjustApertureHeight` sets `H = W/A`,
//! `adjustPixelAspectRatio` keeps the gate and sets the pixel aspect to `a·height/width`.

use glam::{DMat4, DVec3};

use crate::UsdError;
use crate::values::{Time, Values};
use crate::xform;

/// A `UsdGeomCamera` read at one time: each attribute's value, authored or its fallback.
#[derive(Debug, Clone, PartialEq)]
pub struct UsdCamera {
    /// The prim's path.
    pub path: String,
    /// `projection`: `perspective` or `orthographic`.
    pub projection: String,
    /// `horizontalAperture`, tenths of a scene unit.
    pub horizontal_aperture: f64,
    /// `verticalAperture`, tenths of a scene unit.
    pub vertical_aperture: f64,
    /// `horizontalApertureOffset`, tenths of a scene unit.
    pub horizontal_aperture_offset: f64,
    /// `verticalApertureOffset`, tenths of a scene unit.
    pub vertical_aperture_offset: f64,
    /// `focalLength`, tenths of a scene unit.
    pub focal_length: f64,
    /// `clippingRange` (near, far), scene units.
    pub clipping_range: (f64, f64),
    /// `clippingPlanes`: `(a, b, c, d)` each, camera space.
    pub clipping_planes: Vec<[f64; 4]>,
    /// `fStop` (0: no depth of field).
    pub f_stop: f64,
    /// `focusDistance`, scene units.
    pub focus_distance: f64,
    /// `shutter:open`, time codes relative to the frame.
    pub shutter_open: f64,
    /// `shutter:close`, time codes relative to the frame.
    pub shutter_close: f64,
    /// `stereoRole`: `mono`, `left` or `right`.
    pub stereo_role: String,
    /// `exposure`, stops.
    pub exposure: f64,
    /// `exposure:iso`.
    pub exposure_iso: f64,
    /// `exposure:time`, seconds.
    pub exposure_time: f64,
    /// `exposure:fStop`.
    pub exposure_f_stop: f64,
    /// `exposure:responsivity`.
    pub exposure_responsivity: f64,
    /// Camera-to-world (column vectors), in the stage's own axes and units.
    pub camera_to_world: DMat4,
}

/// The scalar attributes with their fallbacks, in the order [`UsdCamera::scalars`] lists them.
pub const SCALAR_ATTRIBUTES: [(&str, f64); 13] = [
    ("horizontalAperture", 20.955),
    ("verticalAperture", 15.2908),
    ("horizontalApertureOffset", 0.0),
    ("verticalApertureOffset", 0.0),
    ("focalLength", 50.0),
    ("fStop", 0.0),
    ("focusDistance", 0.0),
    ("shutter:open", 0.0),
    ("shutter:close", 0.0),
    ("exposure", 0.0),
    ("exposure:iso", 100.0),
    ("exposure:time", 1.0),
    ("exposure:fStop", 1.0),
];

impl UsdCamera {
    /// Reads camera `path` at `time`.
    pub(crate) fn read(values: &Values<'_>, path: &str, time: Time) -> Result<Self, UsdError> {
        let mut s = [0.0; 13];
        for (slot, (name, fallback)) in s.iter_mut().zip(SCALAR_ATTRIBUTES) {
            *slot = values.real(path, name, time, fallback)?;
        }
        let projection = values
            .token_opt(path, "projection", time)?
            .unwrap_or_else(|| "perspective".into());
        if projection != "perspective" && projection != "orthographic" {
            return Err(values.error(
                path,
                "projection",
                format!("expected perspective or orthographic, found {projection:?}"),
            ));
        }
        let clipping_range = match values.reals_opt(path, "clippingRange", time, 2)? {
            Some(r) => (r[0], r[1]),
            None => (1.0, 1_000_000.0),
        };
        let clipping_planes = values
            .tuples_opt(path, "clippingPlanes", time, 4)?
            .unwrap_or_default()
            .into_iter()
            .map(|p| [p[0], p[1], p[2], p[3]])
            .collect();
        let stereo_role = values
            .token_opt(path, "stereoRole", time)?
            .unwrap_or_else(|| "mono".into());
        let camera = UsdCamera {
            path: path.to_string(),
            projection,
            horizontal_aperture: s[0],
            vertical_aperture: s[1],
            horizontal_aperture_offset: s[2],
            vertical_aperture_offset: s[3],
            focal_length: s[4],
            clipping_range,
            clipping_planes,
            f_stop: s[5],
            focus_distance: s[6],
            shutter_open: s[7],
            shutter_close: s[8],
            stereo_role,
            exposure: s[9],
            exposure_iso: s[10],
            exposure_time: s[11],
            exposure_f_stop: s[12],
            exposure_responsivity: values.real(path, "exposure:responsivity", time, 1.0)?,
            camera_to_world: xform::world(values, path, time)?,
        };
        camera.check(values)?;
        Ok(camera)
    }

    /// The scalar attributes in [`SCALAR_ATTRIBUTES`]' order.
    #[must_use]
    pub fn scalars(&self) -> [f64; 13] {
        [
            self.horizontal_aperture,
            self.vertical_aperture,
            self.horizontal_aperture_offset,
            self.vertical_aperture_offset,
            self.focal_length,
            self.f_stop,
            self.focus_distance,
            self.shutter_open,
            self.shutter_close,
            self.exposure,
            self.exposure_iso,
            self.exposure_time,
            self.exposure_f_stop,
        ]
    }

    fn check(&self, values: &Values<'_>) -> Result<(), UsdError> {
        let positive = [
            ("horizontalAperture", self.horizontal_aperture),
            ("verticalAperture", self.vertical_aperture),
            ("focalLength", self.focal_length),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(values.error(&self.path, name, format!("expected a positive number, found {v}")));
            }
        }
        let (near, far) = self.clipping_range;
        if !(near > 0.0 && far > near) {
            return Err(values.error(
                &self.path,
                "clippingRange",
                format!("expected 0 < near < far, found ({near}, {far})"),
            ));
        }
        if self.shutter_close < self.shutter_open {
            return Err(values.error(
                &self.path,
                "shutter:close",
                format!(
                    "expected shutter:close ≥ shutter:open ({}), found {}",
                    self.shutter_open, self.shutter_close
                ),
            ));
        }
        Ok(())
    }

    /// The linear exposure scale: `2^exposure · (time · iso/100 · responsivity)/fStop²`.
    #[must_use]
    pub fn exposure_scale(&self) -> f64 {
        self.exposure.exp2() * self.exposure_time * self.exposure_iso / 100.0 * self.exposure_responsivity
            / (self.exposure_f_stop * self.exposure_f_stop)
    }

    /// The gate `(W, H, ox, oy)` fitted to an image of aspect `image_aspect` by `policy`, and the
    /// pixel aspect the image then needs (1 unless `adjustPixelAspectRatio`).
    ///
    /// # Errors
    /// An unknown policy, naming it.
    pub fn fitted_gate(&self, image_aspect: f64, policy: &str) -> Result<([f64; 4], f64), String> {
        let (w, h) = (self.horizontal_aperture, self.vertical_aperture);
        let gate = w / h;
        let (w, h, pixel_aspect) = match policy {
            "expandAperture" if image_aspect > gate => (h * image_aspect, h, 1.0),
            "expandAperture" => (w, w / image_aspect, 1.0),
            "cropAperture" if image_aspect > gate => (w, w / image_aspect, 1.0),
            "cropAperture" => (h * image_aspect, h, 1.0),
            "adjustApertureWidth" => (h * image_aspect, h, 1.0),
            "adjustApertureHeight" => (w, w / image_aspect, 1.0),
            "adjustPixelAspectRatio" => (w, h, gate / image_aspect),
            other => {
                return Err(format!(
                    "unknown aspectRatioConformPolicy {other:?}; expected expandAperture, cropAperture, \
                     adjustApertureWidth, adjustApertureHeight or adjustPixelAspectRatio"
                ));
            }
        };
        Ok((
            [
                w,
                h,
                self.horizontal_aperture_offset,
                self.vertical_aperture_offset,
            ],
            pixel_aspect,
        ))
    }

    /// The screen window `[left, right, bottom, top]` of a fitted gate: for a perspective camera in
    /// units of the focal length (the tangents of the edge angles), for an orthographic one in scene
    /// units.
    #[must_use]
    pub fn screen_window(&self, gate: [f64; 4]) -> [f64; 4] {
        let [w, h, ox, oy] = gate;
        let scale = if self.projection == "orthographic" {
            0.1
        } else {
            1.0 / self.focal_length
        };
        [
            (-w / 2.0 + ox) * scale,
            (w / 2.0 + ox) * scale,
            (-h / 2.0 + oy) * scale,
            (h / 2.0 + oy) * scale,
        ]
    }

    /// The clipping planes in Obscura's camera space (+Z forward), each as (point, normal) with the
    /// clipped side `(p − point)·normal > 0`; planes with a zero normal are left out.
    #[must_use]
    pub fn obscura_clip_planes(&self) -> Vec<(DVec3, DVec3)> {
        self.clipping_planes
            .iter()
            .filter_map(|&[a, b, c, d]| {
                // Cut: a·x + b·y + c·z_usd + d < 0 with z_usd = −z.
                let n = DVec3::new(-a, -b, c);
                let len2 = n.length_squared();
                (len2 > 0.0).then(|| (n * (d / len2), n))
            })
            .collect()
    }
}

/// `diag(1, 1, −1, 1)`: USD's camera frame (looking down −Z) to Obscura's (+Z).
#[must_use]
pub fn flip_z() -> DMat4 {
    DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0))
}
