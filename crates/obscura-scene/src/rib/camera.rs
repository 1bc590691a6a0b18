//! The RenderMan Interface's own camera requests beyond `Projection` and `Format`'s core:
//! `FrameAspectRatio`, `Perspective`, `DepthOfField`, `Exposure`, `ClippingPlane`,
//! `CoordinateSystem` and `CoordSysTransform`; and the orientation attributes `Sides`,
//! `Orientation` and `ReverseOrientation` (see [`crate::visibility`] for what front and back mean).
//!
//! As RISpec 3.2 §4.1.1 says (and Aqsis does, deriving them at `WorldBegin` so that call order does
//! not matter): without `ScreenWindow`, the window follows the frame aspect ratio `a` —
//! `(−a, a, −1, 1)` when `a ≥ 1`, else `(−1, 1, −1/a, 1/a)` — where `a` is `FrameAspectRatio` when
//! given, else `width·pixelaspect/height`.
//!
//! A `FrameAspectRatio` `a` other than the raster's own `A = width·pixelaspect/height` does not resize
//! the raster: "the picture produced is adjusted in size so that it fits into the display area …
//! with the specified frame aspect ratio and … the upper left corner is aligned with the upper left
//! corner of the display" (RISpec 3.2 §4.1.1). The frame is the largest rectangle of aspect `a`
//! inside the raster, from its top-left corner: `W × W·p/a` pixels when `a ≥ A`, else
//! `H·a/p × H` (`W`, `H` the raster, `p` the pixel aspect). The screen window maps onto the frame
//! (so the whole raster sees a window extended right and down in proportion), and only the frame's
//! pixels are rendered: the crop window is cut to it.
//!
//! `DepthOfField fstop focallength focaldistance` is the thin lens of the RI (lens radius
//! `focallength/(2·fstop)`, in focus at `focaldistance` along the view direction): it becomes the
//! `fStop`, `focalLength` and `focalDistance` parameters of the perspective projection, which the
//! host's thin lens reads (the projection's own parameters win when both are given). Without
//! arguments, or with an infinite f-stop, it is a pinhole.

use glam::{Mat4, Vec3};

use super::lex::Value;
use super::request::Req;
use super::transform::Ctm;
use super::{Reader, RibError};
use crate::visibility::{ClipPlane, ClipSpace, Exposure, Sides, Visibility};
use obscura_host::CropWindow;
use obscura_sdk::{ParamValue, ScreenWindow};

/// `DepthOfField` as read: f-stop, focal length, focal distance.
pub(super) type DepthOfField = [f32; 3];

/// The orientation attributes: `Sides 1`, and whether the current orientation differs from the
/// handedness of the current coordinate system (the surface is then turned inside out). A transform
/// flips both or neither, so it leaves `inside_out` as it is.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct Facing {
    /// `Sides 1`.
    pub(super) one_sided: bool,
    /// The current orientation is not the current coordinate system's handedness.
    pub(super) inside_out: bool,
    /// `Attribute "visibility"` and BMRT's `Attribute "render" "casts_shadows"`: which rays see
    /// the surfaces defined now.
    pub(super) visibility: Visibility,
}

/// RenderMan's `RI_INFINITY` as RIB files write it (`1.0e38`); an fstop at or above it is a pinhole.
const RI_INFINITY: f32 = 1.0e38;

impl Reader {
    /// `FrameAspectRatio a`: the aspect the default screen window follows.
    pub(super) fn frame_aspect_ratio(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [a] = r.only_numbers::<1>("an aspect ratio")?;
        if !(a > 0.0 && a.is_finite()) {
            return Err(r.err(format!(
                "FrameAspectRatio expects a positive aspect ratio, got {a}"
            )));
        }
        self.frame_aspect = Some(a);
        Ok(())
    }

    /// `Perspective fov`: RenderMan's perspective transform before `WorldBegin` is the perspective
    /// projection of that full field of view; in the world it cannot be a modeling transform here.
    pub(super) fn perspective(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [fov] = r.only_numbers::<1>("a field of view in degrees")?;
        if !(fov > 0.0 && fov < 180.0) {
            return Err(r.err(format!(
                "Perspective expects a field of view in (0, 180) degrees, got {fov}"
            )));
        }
        if self.world.is_some() {
            self.warn(
                r,
                "Perspective inside the world (a perspective modeling transform) is not supported, ignored"
                    .into(),
            );
            return Ok(());
        }
        self.scene.projection = "PxrPerspective".into();
        self.scene.projection_params = obscura_sdk::ParamList::new();
        self.scene.projection_base = None;
        self.scene.projection_origin = Some(r.at());
        self.projection_declared = true;
        self.scene
            .projection_params
            .push("float fov", ParamValue::Floats(vec![fov]), Some(r.at()))
            .map_err(|e| r.err(format!("Perspective: {e}")))?;
        Ok(())
    }

    /// `DepthOfField [fstop focallength focaldistance]`.
    pub(super) fn depth_of_field(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        if r.args.is_empty() {
            self.depth_of_field = None;
            return Ok(());
        }
        let [f_stop, focal_length, focal_distance] =
            r.only_numbers::<3>("fstop focallength focaldistance")?;
        // RISpec 3.2 §4.1.2: an fstop of RI_INFINITY (1e38 in RIB) is a pinhole camera, whatever the
        // other two say (files write `DepthOfField 1e38 0 0`). So is a focal length of 0 with any
        // positive fstop: the lens's aperture, focallength/fstop, is then 0 (`DepthOfField 1e+37 0 0`).
        if f_stop >= RI_INFINITY || (focal_length == 0.0 && f_stop > 0.0) {
            self.depth_of_field = None;
            return Ok(());
        }
        if !(f_stop > 0.0 && focal_length > 0.0 && focal_distance > 0.0) || focal_length.is_infinite() {
            return Err(r.err(format!(
                "DepthOfField expects a positive fstop, focal length and focal distance, got {f_stop} {focal_length} {focal_distance}"
            )));
        }
        self.depth_of_field = Some([f_stop, focal_length, focal_distance]);
        Ok(())
    }

    /// `Exposure gain gamma`: kept in the scene, applied to the colour as `(c·gain)^(1/gamma)`.
    pub(super) fn exposure(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [gain, gamma] = r.only_numbers::<2>("gain gamma")?;
        if !(gain >= 0.0 && gamma > 0.0 && gain.is_finite() && gamma.is_finite()) {
            return Err(r.err(format!(
                "Exposure expects a gain ≥ 0 and a gamma > 0, got {gain} {gamma}"
            )));
        }
        self.scene.exposure = Exposure { gain, gamma };
        Ok(())
    }

    /// `CoordinateSystem "name"`: names the CTM.
    pub(super) fn coordinate_system(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name)] = r.args else {
            return Err(r.err("CoordinateSystem expects a name (one string)"));
        };
        self.coordinate_systems
            .insert(name.clone(), (self.ctm.clone(), self.world.is_some()));
        Ok(())
    }

    /// `CoordSysTransform "name"`: the CTM becomes a named system: one `CoordinateSystem` named, or
    /// `world`, `camera`, `object` (RISpec 3.2 §4.3.1; `screen`, `NDC` and `raster` are not transforms
    /// geometry can stand in here).
    pub(super) fn coord_sys_transform(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name)] = r.args else {
            return Err(r.err("CoordSysTransform expects a name (one string)"));
        };
        let in_world = self.world.is_some();
        let ctm = match (name.as_str(), self.coordinate_systems.get(name)) {
            (_, Some((ctm, defined_in_world))) if *defined_in_world == in_world => ctm.clone(),
            (_, Some(_)) => {
                return Err(r.err(format!(
                    "CoordSysTransform \"{name}\": the system was named {} WorldBegin and is used {} it",
                    if in_world { "before" } else { "after" },
                    if in_world { "after" } else { "before" }
                )));
            }
            ("world", None) if in_world => Ctm::identity(),
            ("camera", None) if in_world => {
                let w2c = self
                    .scene
                    .camera
                    .world_to_camera
                    .first()
                    .map(|s| s.world_to_camera);
                let m = w2c.map_or(Mat4::IDENTITY, |m| Mat4::from_cols_array_2d(&m.0).inverse());
                Ctm(vec![(0.0, m)])
            }
            ("camera", None) => Ctm::identity(),
            ("object", None) => self.ctm.clone(),
            _ => {
                let mut known: Vec<&str> = self.coordinate_systems.keys().map(String::as_str).collect();
                known.sort_unstable();
                return Err(r.err(format!(
                    "CoordSysTransform: no coordinate system \"{name}\" (named so far: {}; predefined: world, camera, object)",
                    if known.is_empty() { "none".to_string() } else { known.join(", ") }
                )));
            }
        };
        self.ctm = ctm;
        Ok(())
    }

    /// `Sides 1|2`: whether later surfaces show camera rays their back.
    pub(super) fn sides(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [n] = r.only_numbers::<1>("1 or 2")?;
        self.facing.one_sided = match n {
            1.0 => true,
            2.0 => false,
            _ => return Err(r.err(format!("Sides expects 1 or 2, got {n}"))),
        };
        Ok(())
    }

    /// `Orientation "outside"|"inside"|"lh"|"rh"`: `outside` matches the current coordinate system,
    /// `inside` opposes it, `lh` and `rh` are explicit handednesses (camera space is left-handed, so
    /// the current space is right-handed when its transform to camera space mirrors).
    pub(super) fn orientation(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(o)] = r.args else {
            return Err(r.err("Orientation expects one of \"outside\", \"inside\", \"lh\", \"rh\""));
        };
        let space_is_right_handed = self.current_to_camera_determinant() < 0.0;
        self.facing.inside_out = match o.as_str() {
            "outside" => false,
            "inside" => true,
            "lh" => space_is_right_handed,
            "rh" => !space_is_right_handed,
            other => {
                return Err(r.err(format!(
                    "Orientation expects one of \"outside\", \"inside\", \"lh\", \"rh\", got \"{other}\""
                )));
            }
        };
        Ok(())
    }

    /// `ReverseOrientation`: toggles the current orientation.
    pub(super) fn reverse_orientation(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        r.only_numbers::<0>("no arguments")?;
        self.facing.inside_out = !self.facing.inside_out;
        Ok(())
    }

    /// The sides camera rays see of a surface defined now.
    pub(super) fn current_sides(&self) -> Sides {
        Sides::new(self.facing.one_sided, self.facing.inside_out)
    }

    /// The determinant of the transform from the current space to camera space (at shutter open):
    /// the CTM before `WorldBegin`, world-to-camera times the CTM in the world.
    fn current_to_camera_determinant(&self) -> f32 {
        let ctm = self.ctm.first().determinant();
        if self.world.is_none() {
            return ctm;
        }
        let w2c = self.scene.camera.world_to_camera.first();
        w2c.map_or(1.0, |s| {
            Mat4::from_cols_array_2d(&s.world_to_camera.0).determinant()
        }) * ctm
    }

    /// `ClippingPlane x y z nx ny nz`: a point and a normal in the current space; camera rays do not
    /// see what lies on the side the normal points to. Before `WorldBegin` the plane is fixed to the
    /// camera, in the world to the world; planes accumulate.
    pub(super) fn clipping_plane(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [x, y, z, nx, ny, nz] = r.only_numbers::<6>("x y z nx ny nz")?;
        let (point, normal) = (Vec3::new(x, y, z), Vec3::new(nx, ny, nz));
        if !(point.is_finite() && normal.is_finite() && normal != Vec3::ZERO) {
            return Err(r.err(format!(
                "ClippingPlane expects a finite point and a finite, non-zero normal, got {x} {y} {z} {nx} {ny} {nz}"
            )));
        }
        let m = self.ctm.first();
        let point = m.transform_point3(point);
        // A normal is a covector: it goes through the inverse transpose.
        let normal = m.inverse().transpose().transform_vector3(normal);
        if !(point.is_finite() && normal.is_finite() && normal != Vec3::ZERO) {
            return Err(
                r.err("ClippingPlane: the current transform is singular, so the plane cannot be placed")
            );
        }
        let space = if self.world.is_some() {
            ClipSpace::World
        } else {
            ClipSpace::Camera
        };
        self.scene.clip_planes.push(ClipPlane { point, normal, space });
        Ok(())
    }

    /// A frame of aspect `a` (≠ the raster's, or equal) at the raster's top-left corner: `window`
    /// maps onto it, the crop window is cut to it.
    fn place_frame(&mut self, a: f32, window: ScreenWindow) {
        let f = self.scene.camera.format;
        let (w, h, p) = (f64::from(f.width), f64::from(f.height), f64::from(f.pixel_aspect));
        let (a, raster) = (f64::from(a), w * p / h);
        if a == raster {
            self.scene.camera.screen_window = Some(window);
            return;
        }
        // The frame's size in pixels, as fractions of the raster.
        let (fx, fy) = if a >= raster {
            (1.0, w * p / a / h)
        } else {
            (h * a / p / w, 1.0)
        };
        let (l, r, b, t) = (
            f64::from(window.left),
            f64::from(window.right),
            f64::from(window.bottom),
            f64::from(window.top),
        );
        self.scene.camera.screen_window = Some(ScreenWindow::new(
            l as f32,
            (l + (r - l) / fx) as f32,
            (t - (t - b) / fy) as f32,
            t as f32,
        ));
        let c = self.scene.camera.crop_window;
        self.scene.camera.crop_window = CropWindow {
            x_max: c.x_max.min(fx as f32),
            y_max: c.y_max.min(fy as f32),
            ..c
        };
    }

    /// At `WorldBegin`: the screen window from `FrameAspectRatio` when none is given, and
    /// `DepthOfField` as the perspective projection's lens.
    pub(super) fn settle_camera(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let deep = (self.scene.displays.iter()).any(|d| d.driver == crate::types::DisplayDriver::DeepExr);
        if deep && self.scene.exposure.gamma != 1.0 {
            self.warn(
                r,
                format!(
                    "Exposure gamma {}: deep samples take the gain only (a gamma applied before compositing would \
                     not composite to the flat image's colour)",
                    self.scene.exposure.gamma
                ),
            );
        }
        if let Some(a) = self.frame_aspect {
            let window = self.scene.camera.screen_window.unwrap_or(if a >= 1.0 {
                ScreenWindow::new(-a, a, -1.0, 1.0)
            } else {
                ScreenWindow::new(-1.0, 1.0, -1.0 / a, 1.0 / a)
            });
            self.place_frame(a, window);
        }
        if let Some([f_stop, focal_length, focal_distance]) = self.depth_of_field {
            if self.scene.projection != "PxrPerspective" {
                self.warn(
                    r,
                    format!(
                        "DepthOfField is the perspective camera's lens; projection {} takes its own lens parameters, so it is not applied",
                        self.scene.projection
                    ),
                );
                return Ok(());
            }
            let params = &mut self.scene.projection_params;
            for (name, v) in [
                ("fStop", f_stop),
                ("focalLength", focal_length),
                ("focalDistance", focal_distance),
            ] {
                if params.get(name).is_none() {
                    params
                        .push(
                            &format!("float {name}"),
                            ParamValue::Floats(vec![v]),
                            Some(r.at()),
                        )
                        .map_err(|e| r.err(format!("DepthOfField: {e}")))?;
                }
            }
        }
        Ok(())
    }
}
