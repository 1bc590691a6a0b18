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
//!
//! [`panorama`] holds what the panoramic projections share (window coordinates, azimuth sweeps, radial
//! maps, spherical clipping and property answers).
//!
//! [`register_builtins`] adds them all to a [`Registry`]; [`builtin_registry`] makes one holding them.

pub mod cubemap;
pub mod cylinder;
pub mod dof;
pub mod fisheye;
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

use obscura_sdk::Registry;

pub use cubemap::{CubemapFace, CubemapFaceFactory, Face as CubemapFaceName};
pub use cylinder::{CylinderCamera, CylinderCameraFactory};
pub use fisheye::{Fisheye, FisheyeFactory, Mapping as FisheyeMapping};
pub use mirrorball::{MirrorBall, MirrorBallFactory};
pub use octahedral::{Octahedral, OctahedralFactory};
pub use omnistereo::{Eye, OdsSettings, OmnidirectionalStereo, OmnidirectionalStereoFactory};
pub use orthographic::{Orthographic, OrthographicFactory};
pub use panini::{Panini, PaniniFactory};
pub use perspective::{Perspective, PerspectiveFactory};
pub use pxrcamera::{PxrCamera, PxrCameraFactory};
pub use rolling_shutter::{RollingShutter, RollingShutterFactory, RollingShutterModifier, Sweep};
pub use sphere::{SphereCamera, SphereCameraFactory};

/// Adds every built-in projection to `registry`.
///
/// # Panics
/// When `registry` already holds a projection of a built-in's name (register built-ins first).
pub fn register_builtins(registry: &mut Registry) {
    obscura_calibration::register(registry);
    registry
        .register(Box::new(FisheyeFactory), "")
        .expect("built-in names are unique");
    registry
        .register(Box::new(MirrorBallFactory), "")
        .expect("built-in names are unique");
    registry
        .register(Box::new(CubemapFaceFactory), "")
        .expect("built-in names are unique");
    registry
        .register(Box::new(OctahedralFactory), "")
        .expect("built-in names are unique");
    registry
        .register(Box::new(PerspectiveFactory), "")
        .expect("built-in names are unique");
    registry
        .register(Box::new(OrthographicFactory), "")
        .expect("built-in names are unique");
    registry
        .register(Box::new(PxrCameraFactory), "")
        .expect("built-in names are unique");
    registry
        .register(Box::new(RollingShutterFactory), "")
        .expect("built-in names are unique");
    registry
        .register(Box::new(SphereCameraFactory), "")
        .expect("built-in names are unique");
    registry
        .register(Box::new(CylinderCameraFactory), "")
        .expect("built-in names are unique");
    registry
        .register(Box::new(PaniniFactory), "")
        .expect("built-in names are unique");
    registry
        .register(Box::new(OmnidirectionalStereoFactory), "")
        .expect("built-in names are unique");
}

/// A registry holding every built-in projection.
#[must_use]
pub fn builtin_registry() -> Registry {
    let mut r = Registry::new();
    register_builtins(&mut r);
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::{Format, ParamList, ProjectionEnvironment};

    #[test]
    fn unknown_projection_lists_the_known_ones() {
        let mut reg = builtin_registry();
        let mut env = ProjectionEnvironment::for_format(Format::new(4, 4));
        let err = reg
            .create("PxrPerspectve", &mut env, &ParamList::new())
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("did you mean \"PxrPerspective\""), "{err}");
        let known = format!("known projections: {}", reg.names().join(", "));
        assert!(err.contains(&known), "{err}");
        assert!(reg.names().len() > 2, "{err}");
        assert!(reg.create("PxrOrthographic", &mut env, &ParamList::new()).is_ok());
    }

    #[test]
    fn every_builtin_table_has_documented_unique_parameters() {
        let reg = builtin_registry();
        for name in reg.names() {
            let f = reg.get(&name).unwrap();
            assert!(!f.summary().is_empty(), "{name}");
            let mut seen = std::collections::HashSet::new();
            for d in f.param_table() {
                assert!(!d.doc.is_empty(), "{name}.{} has no doc", d.name);
                assert!(seen.insert(d.name.clone()), "{name}.{} declared twice", d.name);
                assert_eq!(
                    d.default.len(),
                    d.scalar_count(),
                    "{name}.{} default has the wrong size",
                    d.name
                );
            }
        }
    }
}
