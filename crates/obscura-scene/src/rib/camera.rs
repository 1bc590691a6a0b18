//! The RenderMan Interface's own camera requests beyond `Projection` and `Format`'s core:
//! `FrameAspectRatio`, `Perspective`, `DepthOfField`, `Exposure`, `CoordinateSystem` and
//! `CoordSysTransform`, and the requests whose effect the renderer does not have (`ClippingPlane`,
//! `Sides`, `Orientation`, `ReverseOrientation`), which are read and named in a warning.
//!
//! As RISpec 3.2 §4.1.1 says (and Aqsis does, deriving them at `WorldBegin` so that call order does
//! not matter): without `ScreenWindow`, the window follows the frame aspect ratio `a` —
//! `(−a, a, −1, 1)` when `a ≥ 1`, else `(−1, 1, −1/a, 1/a)` — where `a` is `FrameAspectRatio` when
//! given, else `width·pixelaspect/height`.
//!
//! `DepthOfField fstop focallength focaldistance` is the thin lens of the RI (lens radius
//! `focallength/(2·fstop)`, in focus at `focaldistance` along the view direction): it becomes the
//! `fStop`, `focalLength` and `focalDistance` parameters of the perspective projection, which the
//! host's thin lens reads (the projection's own parameters win when both are given). Without
//! arguments, or with an infinite f-stop, it is a pinhole.

use glam::Mat4;

use super::lex::Value;
use super::request::Req;
use super::transform::Ctm;
use super::{Reader, RibError};
use obscura_sdk::{ParamValue, ScreenWindow};

/// `DepthOfField` as read: f-stop, focal length, focal distance.
pub(super) type DepthOfField = [f32; 3];

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
        if (gain, gamma) != (1.0, 1.0) {
            self.warn(
                r,
                format!("Exposure {gain} {gamma} is not applied: images are written as rendered (linear)"),
            );
        }
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

    /// Requests read but without an effect here: named once each in a warning.
    pub(super) fn without_effect(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let why = match r.name {
            "ClippingPlane" => "clipping planes are not supported: geometry beyond it renders",
            "Sides" => "one-sided culling is not supported: both sides of every surface render",
            "Orientation" | "ReverseOrientation" => {
                "orientation does not change what renders (surfaces are two-sided and normals face the ray)"
            }
            _ => "not supported",
        };
        if self.warned_options.insert(r.name.to_string()) {
            self.warn(r, format!("{}: {why}", r.name));
        }
        Ok(())
    }

    /// At `WorldBegin`: the screen window from `FrameAspectRatio` when none is given, and
    /// `DepthOfField` as the perspective projection's lens.
    pub(super) fn settle_camera(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        if self.scene.camera.screen_window.is_none()
            && let Some(a) = self.frame_aspect
        {
            self.scene.camera.screen_window = Some(if a >= 1.0 {
                ScreenWindow::new(-a, a, -1.0, 1.0)
            } else {
                ScreenWindow::new(-1.0, 1.0, -1.0 / a, 1.0 / a)
            });
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
