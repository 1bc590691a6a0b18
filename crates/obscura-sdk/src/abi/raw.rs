//! The `#[repr(C)]` mirror of `include/obscura/projection.h`: its constants, structs, function-pointer
//! types and descriptor, and the numbering of the SDK's enums as the `int32_t`s that cross.
//!
//! Nothing here reads through a pointer: this is the layout both sides agree on, checked against the
//! header by `the_header_and_the_rust_types_cannot_drift_apart` (obscura-plugins' `tests/abi.rs`).

use std::ffi::{c_char, c_void};

use crate::geometry::{Matrix4, Point2, Rgb, Vec3};
use crate::param::{ParamDecl, ParamType};
use crate::plugin::SyncMessage;
use crate::property::{DeepMetric, ProjectionProperty, PropertyValue};
use crate::ray::RayGeometry;

/// The layout generation (`OBSCURA_PROJECTION_ABI_VERSION`). A host refuses any other.
pub const ABI_VERSION: u32 = 1;

/// The symbol every plugin library exports (`OBSCURA_PROJECTION_ENTRY_SYMBOL`).
pub const ENTRY_SYMBOL: &str = "obscura_projection_entry";

/// A status code returned across the boundary (`ObscuraStatus`).
pub type Status = i32;
/// Success (`OBSCURA_OK`).
pub const OK: Status = 0;
/// A property not supported, or a point outside the view for `unproject` (`OBSCURA_UNSUPPORTED`).
pub const UNSUPPORTED: Status = 1;
/// Failure; the message went to the error sink (`OBSCURA_ERROR`).
pub const ERROR: Status = 2;
/// A panic or exception caught at the boundary; the message went to the error sink (`OBSCURA_PANIC`).
pub const PANIC: Status = 3;

/// `array_len` of a single value (`OBSCURA_ARRAY_SINGLE`).
pub const ARRAY_SINGLE: i32 = 0;
/// `array_len` of a variable-length `float[]` list (`OBSCURA_ARRAY_VARIABLE`).
pub const ARRAY_VARIABLE: i32 = -1;

/// `range_flags` bit: the range applies (`OBSCURA_RANGE_LIMITED`).
pub const RANGE_LIMITED: u32 = 1;
/// `range_flags` bit: `range_min` itself is allowed (`OBSCURA_RANGE_MIN_INCLUSIVE`).
pub const RANGE_MIN_INCLUSIVE: u32 = 2;
/// `range_flags` bit: `range_max` itself is allowed (`OBSCURA_RANGE_MAX_INCLUSIVE`).
pub const RANGE_MAX_INCLUSIVE: u32 = 4;

/// [`RawPropertyValue::kind`] of a dicing hint (`OBSCURA_VALUE_DICING_HINT`).
pub const VALUE_DICING_HINT: i32 = 0;
/// [`RawPropertyValue::kind`] of a deep metric (`OBSCURA_VALUE_DEEP_METRIC`).
pub const VALUE_DEEP_METRIC: i32 = 1;
/// [`RawPropertyValue::kind`] of a float (`OBSCURA_VALUE_FLOAT`).
pub const VALUE_FLOAT: i32 = 2;

/// The host's message callback (`ObscuraErrorSink`): `report(host, bytes, len)` copies `len` bytes of
/// UTF-8 into the host's storage. Valid only during the call it is handed to.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct ErrorSink {
    /// The host's storage, opaque to the plugin.
    pub host: *mut c_void,
    /// Appends a message to the host's storage.
    pub report: Option<unsafe extern "C" fn(host: *mut c_void, message: *const c_char, len: usize)>,
}

/// One row of a parameter table (`ObscuraParamDecl`). See the header for each field.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct RawParamDecl {
    /// The name, NUL-terminated UTF-8; required.
    pub name: *const c_char,
    /// One line of documentation, or NULL.
    pub doc: *const c_char,
    /// The default of a float-stored parameter (float, color, point, vector, normal, matrix).
    pub default_floats: *const f32,
    /// The default of an int parameter.
    pub default_ints: *const i32,
    /// The default of a string parameter.
    pub default_strings: *const *const c_char,
    /// Scalars in the default.
    pub default_count: usize,
    /// Allowed strings, or NULL.
    pub choices: *const *const c_char,
    /// Number of allowed strings.
    pub num_choices: usize,
    /// Lower bound, when `range_flags` has [`RANGE_LIMITED`].
    pub range_min: f64,
    /// Upper bound, when `range_flags` has [`RANGE_LIMITED`].
    pub range_max: f64,
    /// The type, as [`param_type_to_raw`] numbers it.
    pub ty: i32,
    /// [`ARRAY_SINGLE`], a fixed length `n > 0`, or [`ARRAY_VARIABLE`].
    pub array_len: i32,
    /// [`RANGE_LIMITED`] | [`RANGE_MIN_INCLUSIVE`] | [`RANGE_MAX_INCLUSIVE`].
    pub range_flags: u32,
}

/// One resolved parameter (`ObscuraParam`): one per table row, in table order, defaults filled in.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct RawParam {
    /// The name.
    pub name: *const c_char,
    /// Where the scene gave it, or NULL.
    pub origin: *const c_char,
    /// Values of a float-stored parameter.
    pub floats: *const f32,
    /// Values of an int parameter.
    pub ints: *const i32,
    /// Values of a string parameter.
    pub strings: *const *const c_char,
    /// Scalars held.
    pub count: usize,
    /// The type.
    pub ty: i32,
    /// As declared in the table.
    pub array_len: i32,
    /// 1 when the scene gave the value, 0 for the default.
    pub given: i32,
}

/// A resolved parameter list (`ObscuraParamList`).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct RawParamList {
    /// `size_of::<RawParamList>()` as the host filled it.
    pub struct_size: u32,
    /// Entries in `params`.
    pub num_params: u32,
    /// The entries.
    pub params: *const RawParam,
}

/// One world-to-camera motion sample (`ObscuraMotionSample`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawMotionSample {
    /// Time, scene shutter units.
    pub time: f32,
    /// World-to-camera at that time.
    pub world_to_camera: Matrix4,
}

/// The environment (`ObscuraEnvironment`); read-only but for `deep_metric`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct RawEnvironment {
    /// `size_of::<RawEnvironment>()` as the host filled it.
    pub struct_size: u32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Width over height of one pixel.
    pub pixel_aspect: f32,
    /// Screen window left.
    pub screen_left: f32,
    /// Screen window right.
    pub screen_right: f32,
    /// Screen window bottom.
    pub screen_bottom: f32,
    /// Screen window top.
    pub screen_top: f32,
    /// Shutter open, scene units.
    pub shutter_open: f32,
    /// Shutter close, scene units.
    pub shutter_close: f32,
    /// Near clipping distance.
    pub clipping_near: f32,
    /// Far clipping distance.
    pub clipping_far: f32,
    /// In/out: the deep metric, as [`DeepMetric`] numbers it.
    pub deep_metric: i32,
    /// Entries in `world_to_camera` (at least one).
    pub num_motion_samples: u32,
    /// The motion samples, sorted by time.
    pub world_to_camera: *const RawMotionSample,
}

/// One batch (`ObscuraProjectionContext`): `num_rays` elements in every array.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct RawContext {
    /// `size_of::<RawContext>()` as the host filled it.
    pub struct_size: u32,
    /// Elements in every array.
    pub num_rays: u32,
    /// Screen samples (in).
    pub screen: *const Point2,
    /// Canonical lens samples (in).
    pub lens: *const Point2,
    /// Aperture samples (in).
    pub aperture: *const Point2,
    /// Times (in/out).
    pub time: *mut f32,
    /// Rays (out, pre-filled).
    pub rays: *mut RayGeometry,
    /// Tints (in/out, pre-filled with white).
    pub tint: *mut Rgb,
}

/// A property's answer (`ObscuraPropertyValue`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawPropertyValue {
    /// [`VALUE_DICING_HINT`], [`VALUE_DEEP_METRIC`] or [`VALUE_FLOAT`].
    pub kind: i32,
    /// The enum's number for the first two kinds.
    pub enum_value: i32,
    /// The value for [`VALUE_FLOAT`].
    pub float_value: f32,
}

/// `init`: sets `*factory` to the plugin's (non-null) factory state.
pub type InitFn = unsafe extern "C" fn(
    descriptor: *const ProjectionDescriptor,
    plugin_path: *const c_char,
    factory: *mut *mut c_void,
    error: *const ErrorSink,
) -> Status;
/// `finalize`: releases the factory state.
pub type FinalizeFn = unsafe extern "C" fn(factory: *mut c_void);
/// `synchronize`: a renderer signal; `params` may be null.
pub type SynchronizeFn =
    unsafe extern "C" fn(factory: *mut c_void, message: i32, params: *const RawParamList);
/// `create_projection`: sets `*projection` (non-null) on [`OK`].
pub type CreateFn = unsafe extern "C" fn(
    factory: *mut c_void,
    env: *mut RawEnvironment,
    params: *const RawParamList,
    projection: *mut *mut c_void,
    error: *const ErrorSink,
) -> Status;
/// `destroy_projection`.
pub type DestroyFn = unsafe extern "C" fn(factory: *mut c_void, projection: *mut c_void);
/// `property`: [`OK`] with `*value` filled, or [`UNSUPPORTED`].
pub type PropertyFn =
    unsafe extern "C" fn(projection: *const c_void, property: i32, value: *mut RawPropertyValue) -> Status;
/// `project`: one batch.
pub type ProjectFn = unsafe extern "C" fn(
    projection: *const c_void,
    ctx: *const RawContext,
    error: *const ErrorSink,
) -> Status;
/// `unproject`: [`OK`] with `*screen` filled, or [`UNSUPPORTED`].
pub type UnprojectFn =
    unsafe extern "C" fn(projection: *const c_void, point: Vec3, time: f32, screen: *mut Point2) -> Status;
/// The entry point's type.
pub type EntryFn = unsafe extern "C" fn(host_abi_version: u32) -> *const ProjectionDescriptor;

/// What a plugin library's entry point returns (`ObscuraProjectionDescriptor`).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct ProjectionDescriptor {
    /// [`ABI_VERSION`] as the plugin was built.
    pub abi_version: u32,
    /// `size_of::<ProjectionDescriptor>()` as the plugin was built.
    pub struct_size: u32,
    /// The name scenes use; required.
    pub name: *const c_char,
    /// One line, or NULL.
    pub summary: *const c_char,
    /// The parameter table.
    pub params: *const RawParamDecl,
    /// Rows in `params`.
    pub num_params: usize,
    /// Required.
    pub init: Option<InitFn>,
    /// Optional.
    pub finalize: Option<FinalizeFn>,
    /// Optional.
    pub synchronize: Option<SynchronizeFn>,
    /// Required.
    pub create_projection: Option<CreateFn>,
    /// Required.
    pub destroy_projection: Option<DestroyFn>,
    /// Required.
    pub property: Option<PropertyFn>,
    /// Required.
    pub project: Option<ProjectFn>,
    /// Optional: no inverse when null.
    pub unproject: Option<UnprojectFn>,
}

// ------------------------------------------------------------------------------------------------
// Enumerations.

/// A parameter type's number in the ABI (`OBSCURA_PARAM_*`): the order of [`ParamType::ALL`].
#[must_use]
pub fn param_type_to_raw(t: ParamType) -> i32 {
    match t {
        ParamType::Float => 0,
        ParamType::Int => 1,
        ParamType::String => 2,
        ParamType::Color => 3,
        ParamType::Point => 4,
        ParamType::Vector => 5,
        ParamType::Normal => 6,
        ParamType::Matrix => 7,
    }
}

/// The parameter type numbered `v`, if any.
#[must_use]
pub fn param_type_from_raw(v: i32) -> Option<ParamType> {
    ParamType::ALL.into_iter().find(|t| param_type_to_raw(*t) == v)
}

/// The property numbered `v` (`OBSCURA_PROPERTY_*`), if any.
#[must_use]
pub fn property_from_raw(v: i32) -> Option<ProjectionProperty> {
    ProjectionProperty::ALL.into_iter().find(|p| *p as i32 == v)
}

/// The sync message numbered `v` (`OBSCURA_SYNC_*`), if any.
#[must_use]
pub fn sync_message_from_raw(v: i32) -> Option<SyncMessage> {
    [
        SyncMessage::RenderBegin,
        SyncMessage::RenderEnd,
        SyncMessage::InstanceEdit,
    ]
    .into_iter()
    .find(|m| *m as i32 == v)
}

/// The deep metric numbered `v` (`OBSCURA_DEEP_*`), if any.
#[must_use]
pub fn deep_metric_from_raw(v: i32) -> Option<DeepMetric> {
    [DeepMetric::CameraZ, DeepMetric::RayLength]
        .into_iter()
        .find(|m| *m as i32 == v)
}

/// A property answer in ABI form.
#[must_use]
pub fn value_to_raw(v: PropertyValue) -> RawPropertyValue {
    match v {
        PropertyValue::DicingHint(h) => RawPropertyValue {
            kind: VALUE_DICING_HINT,
            enum_value: h as i32,
            float_value: 0.0,
        },
        PropertyValue::DeepMetric(m) => RawPropertyValue {
            kind: VALUE_DEEP_METRIC,
            enum_value: m as i32,
            float_value: 0.0,
        },
        PropertyValue::Float(x) => RawPropertyValue {
            kind: VALUE_FLOAT,
            enum_value: 0,
            float_value: x,
        },
    }
}

/// A parameter's `array_len` in the ABI: [`ARRAY_VARIABLE`] for a `float[]` list, the length of a
/// fixed array, else [`ARRAY_SINGLE`].
#[must_use]
pub fn array_len_to_raw(d: &ParamDecl) -> i32 {
    if d.variable_len {
        ARRAY_VARIABLE
    } else {
        // A table's lengths are far below i32::MAX (a host refuses more than 2¹⁶ scalars).
        d.array_len.map_or(ARRAY_SINGLE, |n| n as i32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    #[test]
    fn layouts_have_the_sizes_the_header_promises_on_64_bit() {
        if size_of::<usize>() != 8 {
            return;
        }
        assert_eq!(size_of::<RawParamDecl>(), 96);
        assert_eq!(size_of::<RawParam>(), 64);
        assert_eq!(size_of::<RawParamList>(), 16);
        assert_eq!(size_of::<RawMotionSample>(), 68);
        assert_eq!(size_of::<RawEnvironment>(), 64);
        assert_eq!(size_of::<RawContext>(), 56);
        assert_eq!(size_of::<RawPropertyValue>(), 12);
        assert_eq!(size_of::<ProjectionDescriptor>(), 104);
        assert_eq!(offset_of!(ProjectionDescriptor, init), 40);
        assert_eq!(size_of::<Option<ProjectFn>>(), size_of::<usize>());
    }
}
