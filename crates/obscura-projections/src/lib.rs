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
//! [`screen`] holds what every projection does with the screen samples (the batch loop, the pixel
//! footprint); [`panorama`] holds what the panoramic projections share (window coordinates, azimuth
//! sweeps, radial maps, spherical clipping and property answers).

/// Implements `ProjectionFactory` for `$factory`, the unit struct of a projection module, from the
/// module's `NAME` and `TABLE`: every factory answers its name and table the same way and resolves the
/// scene's parameters against the table before `$create` (a closure of the environment and the
/// resolved parameters) makes the projection.
macro_rules! projection_factory {
    ($factory:ident, $summary:expr, $create:expr $(,)?) => {
        impl obscura_sdk::ProjectionFactory for $factory {
            fn name(&self) -> &str {
                NAME
            }

            fn summary(&self) -> &str {
                $summary
            }

            fn param_table(&self) -> &[obscura_sdk::ParamDecl] {
                &TABLE
            }

            fn create_projection(
                &self,
                env: &mut obscura_sdk::ProjectionEnvironment,
                params: &obscura_sdk::ParamList,
            ) -> Result<Box<dyn obscura_sdk::Projection>, obscura_sdk::PluginError> {
                let create: fn(
                    &mut obscura_sdk::ProjectionEnvironment,
                    &obscura_sdk::Params,
                )
                    -> Result<Box<dyn obscura_sdk::Projection>, obscura_sdk::PluginError> = $create;
                create(env, &obscura_sdk::Params::resolve(NAME, &TABLE, params)?)
            }
        }
    };
}

/// Implements `Projection` for `$camera`, a panoramic camera whose rays leave its centre: DicingHint
/// Spherical, DeepMetric RayLength and the FieldOfView `$fov` reads off the camera
/// (`crate::panorama::spherical_property`); the inverse by its `screen_of(&self, x, y, z) ->
/// Option<Point2>` once the point's components are finite. Each ray from its screen sample by the
/// camera's `ray(&self, Point2) -> RayGeometry`, or — with `lanes` after the field of view — by its
/// branch-free `lane(&self, Point2) -> panorama::CentredLane` and its `clip` field, in the
/// structure-of-arrays loop of `crate::screen::map_centred_rays`, and then also `project_soa` (the
/// same rays straight into the caller's arrays, `crate::screen::map_centred_rays_soa`).
macro_rules! spherical_projection {
    ($camera:ty, $fov:expr $(,)?) => {
        spherical_projection!(@impl $camera, $fov, ray);
    };
    ($camera:ty, $fov:expr, lanes $(,)?) => {
        spherical_projection!(@impl $camera, $fov, lane);
    };
    (@project $this:ident, $ctx:ident, ray) => {
        crate::screen::map_rays($ctx, |s| $this.ray(s))
    };
    (@project $this:ident, $ctx:ident, lane) => {
        crate::screen::map_centred_rays(
            $ctx,
            $this.clip,
            #[inline(always)]
            |s| $this.lane(s),
        )
    };
    (@soa ray) => {};
    (@soa lane) => {
        fn project_soa(&self, ctx: &mut obscura_sdk::SoaContext<'_>) -> bool {
            crate::screen::map_centred_rays_soa(
                ctx,
                self.clip,
                #[inline(always)]
                |s| self.lane(s),
            )
        }
    };
    (@impl $camera:ty, $fov:expr, $how:ident) => {
        impl obscura_sdk::Projection for $camera {
            fn property(
                &self,
                property: obscura_sdk::ProjectionProperty,
            ) -> Option<obscura_sdk::PropertyValue> {
                let fov: fn(&$camera) -> f32 = $fov;
                crate::panorama::spherical_property(property, fov(self))
            }

            fn project(&self, ctx: &mut obscura_sdk::ProjectionContext<'_>) {
                spherical_projection!(@project self, ctx, $how);
            }

            spherical_projection!(@soa $how);

            fn unproject(&self, point: obscura_sdk::Vec3, _time: f32) -> Option<obscura_sdk::Point2> {
                let (x, y, z) = crate::panorama::finite_f64(point)?;
                self.screen_of(x, y, z)
            }
        }
    };
}

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
pub mod screen;
pub mod simd;
pub mod sphere;
#[cfg(test)]
mod testing;

use obscura_sdk::{PluginError, ProjectionFactory};

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

/// The error of `plugin` for parameters it cannot use.
pub(crate) fn invalid(plugin: &str, message: impl Into<String>) -> PluginError {
    PluginError::Invalid {
        plugin: plugin.to_string(),
        message: message.into(),
    }
}

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
