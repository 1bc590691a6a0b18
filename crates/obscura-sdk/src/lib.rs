//! # obscura-sdk
//!
//! The SDK a camera-projection author depends on: Obscura's Rust form of RenderMan's `RixProjection`
//! plugin interface ("Writing Projections").
//!
//! | RenderMan | Obscura |
//! |---|---|
//! | `RixProjectionFactory` | [`ProjectionFactory`] |
//! | `RixProjection` | [`Projection`] |
//! | `RixProjectionEnvironment` | [`ProjectionEnvironment`] |
//! | `RixProjectionContext` | [`ProjectionContext`] |
//! | `RtRayGeometry` | [`RayGeometry`] |
//! | `RtPoint2`, `RtVector3`, `RtColorRGB`, `RtMatrix4x4` | [`Point2`], [`Vec3`], [`Rgb`], [`Matrix4`] |
//! | `ProjectionProperty`, `DicingHint`, `DeepMetric` | [`ProjectionProperty`], [`DicingHint`], [`DeepMetric`] |
//! | `k_RixSCUniform` / `k_RixSCInvalidDetail` | `Some(PropertyValue)` / `None` |
//! | `RixSCParamInfo` (+ the `.args` file) | [`ParamDecl`] |
//! | `RixParameterList` | [`ParamList`], checked into [`Params`] |
//! | `RixSCSyncMsg` | [`SyncMessage`] |
//!
//! Camera space is RenderMan's: the camera at the origin looking down +Z, +Y up, +X right. Screen space
//! is the screen window's (y up); see [`ScreenWindow`].
//!
//! Beyond the interface: [`contract`] is the contract's rules, written once — the per-ray rules and
//! tolerances, the clipping distances and the property domains, exactly what the host enforces (the
//! checker `obscura check` runs is the `obscura-check` crate: add it as a dev-dependency to test your
//! projection) — and [`abi`] with [`export_projection!`] turns a factory into a shared library the
//! host loads through the C ABI of `include/obscura/projection.h`. Only the plugin's side is here:
//! the host's side — the registry of projections, calling `project`, reading properties with their
//! defaults, the default rays — is in `obscura-host`, and loading plugins in `obscura-plugins`.
//!
//! A minimal projection:
//!
//! ```
//! use obscura_sdk::*;
//!
//! /// Rays straight down +Z from the screen point: an orthographic camera without depth of field.
//! struct Flat;
//! impl Projection for Flat {
//!     fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
//!         match p {
//!             ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(DicingHint::Orthographic)),
//!             ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(DeepMetric::CameraZ)),
//!             _ => None,
//!         }
//!     }
//!     fn project(&self, ctx: &mut ProjectionContext<'_>) {
//!         let c = ctx.parts_mut();
//!         for (ray, s) in c.rays.iter_mut().zip(c.screen) {
//!             ray.origin = Vec3::new(s.x, s.y, 0.0);
//!             ray.direction = Vec3::Z;
//!         }
//!     }
//! }
//! ```

pub mod abi;
mod context;
pub mod contract;
mod environment;
mod geometry;
pub mod optics;
mod param;
mod plugin;
mod property;
mod ray;
pub mod simd;
mod soa;

pub use context::{ContextLengthError, ContextParts, ProjectionContext};
pub use environment::{Format, MotionSample, ProjectionEnvironment, ScreenWindow};
pub use geometry::{Matrix4, Point2, Rgb, Vec3};
pub use param::{
    DeclarationError, ParamDecl, ParamEntry, ParamError, ParamList, ParamType, ParamValue, Params,
    ValueRange, did_you_mean, parse_declaration,
};
pub use plugin::{PluginError, Projection, ProjectionFactory, SyncMessage};
pub use property::{DeepMetric, DicingHint, ProjectionProperty, PropertyValue};
pub use ray::RayGeometry;
pub use soa::{RaysSoa, SOA_UNWRITTEN, SoaContext, SoaFields, SoaLengthError, check_project_soa};
