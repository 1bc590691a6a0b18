//! # obscura-projections
//!
//! Obscura's built-in projections, one per file, each with its parameter table, its mapping stated as
//! formulas in its module documentation, its `project`, its exact inverse and its tests.
//!
//! | name | file | dicing hint | deep metric |
//! |---|---|---|---|
//! | `PxrPerspective` | [`perspective`] | Perspective | CameraZ |
//! | `PxrOrthographic` | [`orthographic`] | Orthographic | CameraZ |
//! | `PxrCamera` | [`pxrcamera`] | Perspective | CameraZ |
//! | `PxrRollingShutter` | [`rolling_shutter`] | of its base camera | CameraZ |
//! | `PxrSphereCamera` | [`sphere`] | Spherical | RayLength |
//! | `PxrCylinderCamera` | [`cylinder`] | Spherical | RayLength |
//! | `PxrPanini` | [`panini`] | Spherical (Perspective at compression 0) | RayLength (CameraZ at 0) |
//! | `OmnidirectionalStereo` | [`omnistereo`] | Spherical | RayLength |
//! | `Fisheye` | [`fisheye`] | Spherical | RayLength |
//! | `MirrorBall` | [`mirrorball`] | Spherical | RayLength |
//! | `EquiangularCubemapFace` | [`cubemap`] | Spherical | RayLength |
//! | `Octahedral` | [`octahedral`] | Spherical | RayLength |
//! | `LensSystem` | [`lens_system`] | Spherical | CameraZ (RayLength past 60°) |
//!
//! The table of every built-in projection (these and the calibrated cameras of `obscura-calibration`)
//! is assembled above both crates, in `obscura-plugins`.
//!
//! [`panorama`] holds what the panoramic projections share (window coordinates, azimuth sweeps, radial
//! maps, spherical clipping and property answers).

pub mod cubemap;
pub mod cylinder;
pub mod dof;
pub mod fisheye;
pub mod lens_system;
pub mod mirrorball;
pub mod octahedral;
pub mod omnistereo;
pub mod orthographic;
pub mod panini;
pub mod panorama;
pub mod perspective;
pub mod pxrcamera;
pub mod rolling_shutter;
pub mod simd;
pub mod sphere;
#[cfg(test)]
mod testing;

use obscura_sdk::ProjectionFactory;

pub use cubemap::{CubemapFace, CubemapFaceFactory, Face as CubemapFaceName};
pub use cylinder::{CylinderCamera, CylinderCameraFactory};
pub use fisheye::{Fisheye, FisheyeFactory, Mapping as FisheyeMapping};
pub use lens_system::{LensSystem, LensSystemFactory};
pub use mirrorball::{MirrorBall, MirrorBallFactory};
pub use octahedral::{Octahedral, OctahedralFactory};
pub use omnistereo::{Eye, OdsSettings, OmnidirectionalStereo, OmnidirectionalStereoFactory};
pub use orthographic::{Orthographic, OrthographicFactory};
pub use panini::{Panini, PaniniFactory};
pub use perspective::{Perspective, PerspectiveFactory};
pub use pxrcamera::{PxrCamera, PxrCameraFactory};
pub use rolling_shutter::{RollingShutter, RollingShutterFactory, RollingShutterModifier, Sweep};
pub use sphere::{SphereCamera, SphereCameraFactory};

/// A factory of every projection in this crate, for a host's table of built-ins (assembled, with the
/// calibrated cameras, by `obscura_plugins::builtin_registry`).
#[must_use]
pub fn factories() -> Vec<Box<dyn ProjectionFactory>> {
    vec![
        Box::new(FisheyeFactory),
        Box::new(MirrorBallFactory),
        Box::new(CubemapFaceFactory),
        Box::new(OctahedralFactory),
        Box::new(PerspectiveFactory),
        Box::new(OrthographicFactory),
        Box::new(PxrCameraFactory),
        Box::new(RollingShutterFactory),
        Box::new(SphereCameraFactory),
        Box::new(CylinderCameraFactory),
        Box::new(PaniniFactory),
        Box::new(OmnidirectionalStereoFactory),
        Box::new(LensSystemFactory),
    ]
}
