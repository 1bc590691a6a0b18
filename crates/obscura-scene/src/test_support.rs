//! Helpers the readers' tests share.

use glam::Vec3;

use crate::types::Scene;

/// The world point `p` in camera space at the camera's motion sample `sample`, through the SDK's
/// row-vector matrix as the renderer applies it.
pub(crate) fn camera_point(scene: &Scene, sample: usize, p: Vec3) -> Vec3 {
    let m = scene.camera.world_to_camera[sample].world_to_camera;
    let q = m.transform_point(obscura_sdk::Vec3::new(p.x, p.y, p.z));
    Vec3::new(q.x, q.y, q.z)
}
