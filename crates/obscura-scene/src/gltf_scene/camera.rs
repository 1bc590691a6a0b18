//! The file's camera: the world-to-camera transform and the projection (`PxrPerspective` with a field of
//! view across the smaller side, or `PxrOrthographic` with a screen window).

use std::f32::consts::PI;

use glam::Mat4;
use obscura_sdk::ScreenWindow;

use super::Loader;
use crate::convert::{flip_z, set_fov, set_world_to_camera};

/// The vertical field of view, in degrees, read for a camera whose `yfov` is unusable: the same 45°
/// the renderer frames a file without a camera with.
const FALLBACK_FOV_DEG: f32 = 45.0;

impl Loader<'_> {
    /// Sets the camera transform and projection from a glTF camera; false (with a warning) when its
    /// node's matrix cannot be inverted.
    pub(super) fn apply_camera(&mut self, node: usize, cam: &gltf::Camera<'_>, world: Mat4) -> bool {
        let det = world.determinant();
        if !world.is_finite() || !det.is_finite() || det.abs() < 1e-12 {
            self.warn(format!(
                "camera node {node} has a singular transform; framing the scene instead"
            ));
            return false;
        }
        set_world_to_camera(&mut self.scene, flip_z() * world.inverse());
        let aspect = self.scene.camera.format.frame_aspect();
        let aspect = if aspect.is_finite() && aspect > 0.0 {
            aspect
        } else {
            1.0
        };
        let origin = format!("{}: camera {}", self.file, cam.index());
        match cam.projection() {
            gltf::camera::Projection::Perspective(p) => {
                self.scene.projection = "PxrPerspective".into();
                let mut yfov = p.yfov();
                if !(yfov.is_finite() && yfov > 0.0 && yfov < PI) {
                    self.warn(format!(
                        "camera {}: yfov {yfov} is not in (0, π); using {FALLBACK_FOV_DEG}°",
                        cam.index()
                    ));
                    yfov = FALLBACK_FOV_DEG.to_radians();
                }
                set_fov(&mut self.scene, fov_across_smaller_side(yfov, aspect), origin);
            }
            gltf::camera::Projection::Orthographic(o) => {
                self.scene.projection = "PxrOrthographic".into();
                let ymag = o.ymag().abs();
                if ymag.is_finite() && ymag > 0.0 {
                    self.scene.camera.screen_window =
                        Some(ScreenWindow::new(-ymag * aspect, ymag * aspect, -ymag, ymag));
                } else {
                    self.warn(format!(
                        "camera {}: ymag {} is not positive; keeping the default screen window",
                        cam.index(),
                        o.ymag()
                    ));
                }
            }
        }
        true
    }
}

/// The field of view across the smaller image side, degrees, for a vertical field of view `yfov`
/// (radians) and a frame aspect (width / height).
pub(super) fn fov_across_smaller_side(yfov: f32, aspect: f32) -> f32 {
    if aspect >= 1.0 {
        yfov.to_degrees()
    } else {
        (2.0 * ((0.5 * yfov).tan() * aspect).atan()).to_degrees()
    }
}
