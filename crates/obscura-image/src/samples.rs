//! What one camera sample carries to the film beside its colour: the ground truth of its first hit
//! ([`Truth`]) and, per pixel, the optical flow the renderer computes after the samples
//! ([`FlowPixel`]). The renderer fills them; the film and the writers only store them, so they live
//! here, with the film, rather than with the code that computes them.

use glam::Vec3;

/// What one camera sample reports besides the beauty and RenderMan's own AOVs. A miss is
/// [`Truth::EMPTY`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Truth {
    /// Camera-space z of the hit at the ray's time (`cameraZ`); `+∞` for a miss.
    pub camera_z: f32,
    /// Distance from the camera ray's origin to the hit, in camera units (`distance`); `+∞` for a miss.
    pub distance: f32,
    /// The hit in camera space at the ray's time (`Pcamera`); 0 for a miss.
    pub p_camera: Vec3,
    /// The shading normal in camera space at the ray's time (`Ncamera`), unit; 0 for a miss.
    pub n_camera: Vec3,
    /// `objectId` (0: nothing hit).
    pub object_id: u32,
    /// `instanceId` (0: nothing hit).
    pub instance_id: u32,
    /// `materialId` (0: nothing hit).
    pub material_id: u32,
}

impl Truth {
    /// A miss: infinite depths, zero vectors, ID 0.
    pub const EMPTY: Truth = Truth {
        camera_z: f32::INFINITY,
        distance: f32::INFINITY,
        p_camera: Vec3::ZERO,
        n_camera: Vec3::ZERO,
        object_id: 0,
        instance_id: 0,
        material_id: 0,
    };
}

/// One pixel's flow, as the EXR stores it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowPixel {
    /// `flowForward.X`, `.Y`: toward shutter close or the next frame, pixels.
    pub forward: [f32; 2],
    /// `flowBackward.X`, `.Y`: toward the previous frame, pixels.
    pub backward: [f32; 2],
    /// `flowValid.forward`: 1 where `forward` is defined, else 0.
    pub forward_valid: f32,
    /// `flowValid.backward`: 1 where `backward` is defined, else 0.
    pub backward_valid: f32,
}

impl FlowPixel {
    /// No flow: zero vectors, not valid.
    pub const NONE: FlowPixel = FlowPixel {
        forward: [0.0; 2],
        backward: [0.0; 2],
        forward_valid: 0.0,
        backward_valid: 0.0,
    };
}
