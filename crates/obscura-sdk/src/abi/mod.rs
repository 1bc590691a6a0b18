//! The C ABI of projection plugins, as a Rust plugin compiles it in: the `#[repr(C)]` mirror of
//! `include/obscura/projection.h`, the readers of the C data both sides exchange, and
//! [`export_projection!`](crate::export_projection), which turns a Rust [`ProjectionFactory`] into a
//! `cdylib` with the C entry point.
//!
//! A plugin library exports one symbol, [`ENTRY_SYMBOL`], of type [`EntryFn`]: it returns a pointer to
//! a [`ProjectionDescriptor`] (name, summary, parameter table, and the function pointers of the factory
//! and its projections). The host checks [`ProjectionDescriptor::abi_version`] and
//! [`ProjectionDescriptor::struct_size`] before any other call; see `docs/plugin-abi.md` for the
//! versioning and ownership rules.
//!
//! Nothing Rust-specific crosses the boundary: no `String`, `Vec`, `Box<dyn …>` or Rust enum. Enums
//! cross as `i32` and are checked on arrival ([`param_type_from_raw`], [`deep_metric_from_raw`], …), so
//! an unknown value is an [`AbiError`], never undefined behaviour. Messages travel through an
//! [`ErrorSink`]: the plugin hands the bytes to a host callback that copies them, so no allocation
//! changes hands.
//!
//! | file | what | used by |
//! |---|---|---|
//! | `raw.rs` | constants, `Raw*` structs, function-pointer types, the descriptor, enum numbers | both sides |
//! | [`c_data`] | reading C strings, arrays and values; [`c_data::Keep`], the owner of C views | both sides |
//! | `export.rs` | [`OwnedParamTable`], [`param_list_from_raw`], [`environment_from_raw`], [`report`], the trampolines | a Rust plugin |
//! | `error.rs` | [`AbiError`] | both sides |
//!
//! The host's side (reading a plugin's table and property values, building the parameter lists and
//! environments it sends, collecting messages) is not here: a plugin never needs it. It lives in
//! `obscura-plugins` (`decode`, `encode` and `loader`).
//!
//! | C (`projection.h`) | Rust |
//! |---|---|
//! | `ObscuraPoint2`, `ObscuraVec3`, `ObscuraRgb`, `ObscuraMatrix4`, `ObscuraRayGeometry` | [`Point2`](crate::Point2), [`Vec3`](crate::Vec3), [`Rgb`](crate::Rgb), [`Matrix4`](crate::Matrix4), [`RayGeometry`](crate::RayGeometry) (already `#[repr(C)]`) |
//! | `ObscuraErrorSink` | [`ErrorSink`] |
//! | `ObscuraParamDecl` | [`RawParamDecl`] |
//! | `ObscuraParam`, `ObscuraParamList` | [`RawParam`], [`RawParamList`] |
//! | `ObscuraMotionSample`, `ObscuraEnvironment` | [`RawMotionSample`], [`RawEnvironment`] |
//! | `ObscuraProjectionContext` | [`RawContext`] |
//! | `ObscuraPropertyValue` | [`RawPropertyValue`] |
//! | `ObscuraProjectionDescriptor` | [`ProjectionDescriptor`] |
//!
//! [`ProjectionFactory`]: crate::ProjectionFactory

pub mod c_data;
mod error;
mod export;
mod raw;

pub use error::AbiError;
#[doc(hidden)]
pub use export::{Exported, export_entry};
pub use export::{OwnedParamTable, environment_from_raw, param_list_from_raw, report};
pub use raw::*;
