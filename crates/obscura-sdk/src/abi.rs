//! The C ABI of projection plugins: the `#[repr(C)]` mirror of `include/obscura/projection.h`, the
//! conversions between it and the SDK's types, and [`export_projection!`](crate::export_projection),
//! which turns a Rust [`ProjectionFactory`] into a `cdylib` with the C entry point.
//!
//! A plugin library exports one symbol, [`ENTRY_SYMBOL`], of type [`EntryFn`]: it returns a pointer to
//! a [`ProjectionDescriptor`] (name, summary, parameter table, and the function pointers of the factory
//! and its projections). The host checks [`ProjectionDescriptor::abi_version`] and
//! [`ProjectionDescriptor::struct_size`] before any other call; see `docs/plugin-abi.md` for the
//! versioning and ownership rules.
//!
//! Nothing Rust-specific crosses the boundary: no `String`, `Vec`, `Box<dyn …>` or Rust enum. Enums
//! cross as `i32` and are checked on arrival ([`param_type_from_raw`], [`value_from_raw`], …), so an
//! unknown value is an error, never undefined behaviour. Messages travel through an [`ErrorSink`]: the
//! plugin hands the bytes to a host callback that copies them, so no allocation changes hands.
//!
//! | C (`projection.h`) | Rust |
//! |---|---|
//! | `ObscuraPoint2`, `ObscuraVec3`, `ObscuraRgb`, `ObscuraMatrix4`, `ObscuraRayGeometry` | [`Point2`], [`Vec3`], [`Rgb`], [`Matrix4`], [`RayGeometry`] (already `#[repr(C)]`) |
//! | `ObscuraErrorSink` | [`ErrorSink`] |
//! | `ObscuraParamDecl` | [`RawParamDecl`] |
//! | `ObscuraParam`, `ObscuraParamList` | [`RawParam`], [`RawParamList`] |
//! | `ObscuraMotionSample`, `ObscuraEnvironment` | [`RawMotionSample`], [`RawEnvironment`] |
//! | `ObscuraProjectionContext` | [`RawContext`] |
//! | `ObscuraPropertyValue` | [`RawPropertyValue`] |
//! | `ObscuraProjectionDescriptor` | [`ProjectionDescriptor`] |

use std::borrow::Cow;
use std::ffi::{CStr, CString, c_char, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::{OnceLock, PoisonError, RwLock};

use crate::context::ProjectionContext;
use crate::contract::panic_message;
use crate::environment::{Format, MotionSample, ProjectionEnvironment, ScreenWindow};
use crate::geometry::{Matrix4, Point2, Rgb, Vec3};
use crate::param::{ParamDecl, ParamList, ParamType, ParamValue, ValueRange};
use crate::plugin::{Projection, ProjectionFactory, SyncMessage};
use crate::property::{DeepMetric, DicingHint, ProjectionProperty, PropertyValue};
use crate::ray::RayGeometry;

/// The layout generation (`OBSCURA_PROJECTION_ABI_VERSION`). A host refuses any other.
pub const ABI_VERSION: u32 = 1;

/// The symbol every plugin library exports (`OBSCURA_PROJECTION_ENTRY_SYMBOL`).
pub const ENTRY_SYMBOL: &str = "obscura_projection_entry";

/// [`ENTRY_SYMBOL`] with its terminating NUL, as symbol lookups want it.
pub const ENTRY_SYMBOL_NUL: &[u8] = b"obscura_projection_entry\0";

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

/// The size of generation 1's first descriptor layout (64-bit targets: through `unproject`), the
/// smallest `struct_size` the host accepts. Fields appended within the generation lie beyond it; a
/// descriptor built with an older header is read up to its own `struct_size` and the rest is taken
/// as absent (zero: NULL pointers, no function). Pinned: it never changes within a generation.
pub const DESCRIPTOR_V1_SIZE: usize = 13 * size_of::<usize>();

// Every Option<fn> and pointer field is valid all-zero, which is what an absent appended field reads as.
const _: () = assert!(size_of::<ProjectionDescriptor>() >= DESCRIPTOR_V1_SIZE);

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

/// The dicing hint numbered `v` (`OBSCURA_DICING_*`), if any.
#[must_use]
pub fn dicing_hint_from_raw(v: i32) -> Option<DicingHint> {
    [
        DicingHint::Orthographic,
        DicingHint::Perspective,
        DicingHint::Spherical,
    ]
    .into_iter()
    .find(|h| *h as i32 == v)
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

/// Reads a property answer.
///
/// # Errors
/// A message naming the unknown kind or enum value.
pub fn value_from_raw(v: RawPropertyValue) -> Result<PropertyValue, String> {
    match v.kind {
        VALUE_DICING_HINT => dicing_hint_from_raw(v.enum_value)
            .map(PropertyValue::DicingHint)
            .ok_or_else(|| format!("unknown dicing hint {} (expected 0, 1 or 2)", v.enum_value)),
        VALUE_DEEP_METRIC => deep_metric_from_raw(v.enum_value)
            .map(PropertyValue::DeepMetric)
            .ok_or_else(|| format!("unknown deep metric {} (expected 0 or 1)", v.enum_value)),
        VALUE_FLOAT => Ok(PropertyValue::Float(v.float_value)),
        k => Err(format!("unknown property value kind {k} (expected 0, 1 or 2)")),
    }
}

// ------------------------------------------------------------------------------------------------
// Messages.

unsafe extern "C" fn append_to_string(host: *mut c_void, message: *const c_char, len: usize) {
    if host.is_null() || message.is_null() || len == 0 {
        return;
    }
    // SAFETY: `host` is the `String` that `collect_message` lent for this call, and the plugin
    // promises `len` readable bytes at `message`.
    let (s, bytes) = unsafe {
        (
            &mut *host.cast::<String>(),
            std::slice::from_raw_parts(message.cast::<u8>(), len),
        )
    };
    s.push_str(&String::from_utf8_lossy(bytes));
}

/// Host side: runs `f` with an [`ErrorSink`] that copies whatever the plugin reports, and returns
/// `f`'s result with the message (empty when nothing was reported).
pub fn collect_message<R>(f: impl FnOnce(&ErrorSink) -> R) -> (R, String) {
    let mut message = String::new();
    let sink = ErrorSink {
        host: (&raw mut message).cast(),
        report: Some(append_to_string),
    };
    let r = f(&sink);
    (r, message)
}

/// Plugin side: sends `message` to the host's sink.
///
/// # Safety
/// `sink` is null or points to a valid [`ErrorSink`] the host handed to the current call.
pub unsafe fn report(sink: *const ErrorSink, message: &str) {
    // SAFETY: the caller guarantees `sink` is null or valid.
    if let Some(sink) = unsafe { sink.as_ref() }
        && let Some(f) = sink.report
    {
        // SAFETY: the host's callback reads `len` bytes from a live buffer.
        unsafe { f(sink.host, message.as_ptr().cast(), message.len()) };
    }
}

// ------------------------------------------------------------------------------------------------
// Reading C data.

/// Reads a NUL-terminated UTF-8 string.
///
/// # Safety
/// `p` is null or points to a NUL-terminated string.
unsafe fn read_str(p: *const c_char, what: &str) -> Result<String, String> {
    if p.is_null() {
        return Err(format!("{what} is NULL"));
    }
    // SAFETY: non-null and NUL-terminated by the caller's promise.
    unsafe { CStr::from_ptr(p) }
        .to_str()
        .map(str::to_string)
        .map_err(|_| format!("{what} is not UTF-8"))
}

/// A slice from a C array; `n == 0` needs no pointer.
///
/// # Safety
/// When `n > 0`, `p` is null or points to `n` readable, initialised `T`s alive for `'a`.
unsafe fn read_slice<'a, T>(p: *const T, n: usize, what: &str) -> Result<&'a [T], String> {
    check_array(p, n, what)?;
    if n == 0 {
        return Ok(&[]);
    }
    // SAFETY: non-null, aligned, `n` elements by the caller's promise.
    Ok(unsafe { std::slice::from_raw_parts(p, n) })
}

/// The checks a C array passes before it becomes a slice: non-null and aligned when not empty.
fn check_array<T>(p: *const T, n: usize, what: &str) -> Result<(), String> {
    if n > 0 && p.is_null() {
        return Err(format!("{what} is NULL but {n} element(s) were promised"));
    }
    if n > 0 && !p.is_aligned() {
        return Err(format!("{what} is misaligned"));
    }
    Ok(())
}

/// # Safety
/// Pointers as for [`read_slice`], each string NUL-terminated.
unsafe fn read_strs(p: *const *const c_char, n: usize, what: &str) -> Result<Vec<String>, String> {
    // SAFETY: forwarded promise.
    let ptrs = unsafe { read_slice(p, n, what)? };
    ptrs.iter()
        .enumerate()
        // SAFETY: forwarded promise.
        .map(|(i, s)| unsafe { read_str(*s, &format!("{what}[{i}]")) })
        .collect()
}

/// # Safety
/// The pointer of `ty`'s storage points to `count` values.
unsafe fn read_value(
    ty: ParamType,
    floats: *const f32,
    ints: *const i32,
    strings: *const *const c_char,
    count: usize,
    what: &str,
) -> Result<ParamValue, String> {
    // SAFETY: forwarded promise.
    unsafe {
        Ok(match ty {
            ParamType::Int => ParamValue::Ints(read_slice(ints, count, what)?.to_vec()),
            ParamType::String => ParamValue::Strings(read_strs(strings, count, what)?),
            _ => ParamValue::Floats(read_slice(floats, count, what)?.to_vec()),
        })
    }
}

/// Most scalars a `float[]` parameter's default may hold: more is taken for a corrupt count.
pub const MAX_LIST_DEFAULT: usize = 1 << 16;

/// Most choices a string parameter may offer: more is taken for a corrupt count.
pub const MAX_CHOICES: usize = 1024;

/// Reads one row of a plugin's parameter table, checking it: a name, a known type, a consistent
/// array length and default, a well-formed range that holds the default, choices only on strings.
///
/// # Errors
/// A message naming the parameter (or its row) and what is wrong.
///
/// # Safety
/// Every pointer in `d` is null or valid for the counts it gives, strings NUL-terminated.
pub unsafe fn decl_from_raw(d: &RawParamDecl) -> Result<ParamDecl, String> {
    // SAFETY: the caller's promise covers every pointer read below.
    let name = unsafe { read_str(d.name, "name")? };
    if name.is_empty() || name.chars().any(char::is_whitespace) {
        return Err(format!("parameter name \"{name}\" is empty or has spaces"));
    }
    let bad = |why: String| format!("parameter \"{name}\": {why}");
    let ty =
        param_type_from_raw(d.ty).ok_or_else(|| bad(format!("unknown type {} (expected 0..7)", d.ty)))?;
    let (array_len, variable_len) = match d.array_len {
        ARRAY_SINGLE => (None, false),
        ARRAY_VARIABLE if ty == ParamType::Float => (None, true),
        ARRAY_VARIABLE => return Err(bad(format!("only float[] may have variable length, not {ty}[]"))),
        n if n > 0 && n as usize <= MAX_LIST_DEFAULT => (Some(n as usize), false),
        n if n > 0 => {
            return Err(bad(format!("array length {n} (at most {MAX_LIST_DEFAULT})")));
        }
        n => {
            return Err(bad(format!(
                "array length {n} (expected 0, -1 or a positive length)"
            )));
        }
    };
    // The counts are checked before anything is read through them: a C author's slip (a sizeof
    // where a length belongs) must be an error naming the parameter, not a read past the array.
    let comps = ty.components();
    if variable_len {
        if d.default_count > MAX_LIST_DEFAULT || !d.default_count.is_multiple_of(comps) {
            return Err(bad(format!(
                "default_count {} for float[] (expected a multiple of {comps}, at most {MAX_LIST_DEFAULT})",
                d.default_count
            )));
        }
    } else {
        let need = comps * array_len.unwrap_or(1);
        if d.default_count != need {
            return Err(bad(format!(
                "default_count {} but a {ty}{} default has {need} scalar(s)",
                d.default_count,
                array_len.map(|n| format!("[{n}]")).unwrap_or_default()
            )));
        }
    }
    if d.num_choices > MAX_CHOICES {
        return Err(bad(format!(
            "num_choices {} (at most {MAX_CHOICES}; a sizeof where a count belongs?)",
            d.num_choices
        )));
    }
    // SAFETY: see above.
    let default = unsafe {
        read_value(
            ty,
            d.default_floats,
            d.default_ints,
            d.default_strings,
            d.default_count,
            "default",
        )
        .map_err(bad)?
    };
    let doc = if d.doc.is_null() {
        String::new()
    } else {
        // SAFETY: see above.
        unsafe { read_str(d.doc, "doc").map_err(bad)? }
    };
    let choices = if d.num_choices == 0 {
        Vec::new()
    } else if ty != ParamType::String {
        return Err(bad(format!(
            "choices on a {ty} parameter (only strings take choices)"
        )));
    } else {
        // SAFETY: see above.
        unsafe { read_strs(d.choices, d.num_choices, "choices").map_err(bad)? }
    };
    let range = if d.range_flags & RANGE_LIMITED != 0 {
        if d.range_min.is_nan() || d.range_max.is_nan() || d.range_min > d.range_max {
            return Err(bad(format!(
                "range [{}, {}] is empty or NaN",
                d.range_min, d.range_max
            )));
        }
        Some(ValueRange {
            min: d.range_min,
            max: d.range_max,
            min_inclusive: d.range_flags & RANGE_MIN_INCLUSIVE != 0,
            max_inclusive: d.range_flags & RANGE_MAX_INCLUSIVE != 0,
        })
    } else {
        None
    };
    let decl = ParamDecl {
        name: Cow::Owned(name.clone()),
        ty,
        array_len,
        variable_len,
        default,
        range,
        choices: choices.into_iter().map(Cow::Owned).collect(),
        doc: Cow::Owned(doc),
    };
    let count_ok = if variable_len {
        decl.default.len().is_multiple_of(comps)
    } else {
        decl.default.len() == decl.scalar_count()
    };
    if !count_ok {
        return Err(bad(format!(
            "the default has {} scalar(s) but {} needs {}",
            decl.default.len(),
            decl.rib_declaration(),
            decl.scalar_count()
        )));
    }
    if let Some(r) = range {
        let outside = match &decl.default {
            ParamValue::Floats(v) => v.iter().map(|x| f64::from(*x)).find(|x| !r.contains(*x)),
            ParamValue::Ints(v) => v.iter().map(|x| f64::from(*x)).find(|x| !r.contains(*x)),
            ParamValue::Strings(_) => None,
        };
        if let Some(x) = outside {
            return Err(bad(format!("the default {x} is outside its own range {r}")));
        }
    }
    if let ParamValue::Strings(v) = &decl.default
        && !decl.choices.is_empty()
        && let Some(s) = v.iter().find(|s| !decl.choices.iter().any(|c| c == s.as_str()))
    {
        return Err(bad(format!("the default \"{s}\" is not one of its own choices")));
    }
    Ok(decl)
}

/// Plugin side: reads a parameter list back into the scene's [`ParamList`] (the entries the scene
/// gave, with their origins). A null pointer is an empty list.
///
/// # Errors
/// A message when the list is malformed (too small a `struct_size`, null arrays, unknown types).
///
/// # Safety
/// `p` is null or points to a valid [`RawParamList`] whose pointers are valid for its counts.
pub unsafe fn param_list_from_raw(p: *const RawParamList) -> Result<ParamList, String> {
    // SAFETY: the caller's promise.
    let Some(list) = (unsafe { p.as_ref() }) else {
        return Ok(ParamList::new());
    };
    if (list.struct_size as usize) < size_of::<RawParamList>() {
        return Err(format!(
            "parameter list struct_size {} is smaller than {}",
            list.struct_size,
            size_of::<RawParamList>()
        ));
    }
    // SAFETY: the caller's promise.
    let entries = unsafe { read_slice(list.params, list.num_params as usize, "params")? };
    let mut out = ParamList::new();
    for (i, e) in entries.iter().enumerate().filter(|(_, e)| e.given != 0) {
        // SAFETY: the caller's promise.
        let name = unsafe { read_str(e.name, &format!("params[{i}].name"))? };
        let ty = param_type_from_raw(e.ty)
            .ok_or_else(|| format!("parameter \"{name}\": unknown type {}", e.ty))?;
        // SAFETY: the caller's promise.
        let value = unsafe { read_value(ty, e.floats, e.ints, e.strings, e.count, &name)? };
        let origin = if e.origin.is_null() {
            None
        } else {
            // SAFETY: the caller's promise.
            Some(unsafe { read_str(e.origin, "origin")? })
        };
        let comps = ty.components();
        if value.is_empty() || !value.len().is_multiple_of(comps) {
            return Err(format!(
                "parameter \"{name}\": {} scalar(s) do not make whole {ty}s",
                value.len()
            ));
        }
        let decl = if value.len() == comps {
            format!("{ty} {name}")
        } else {
            format!("{ty}[{}] {name}", value.len() / comps)
        };
        out.push(&decl, value, origin).map_err(|e| e.to_string())?;
    }
    Ok(out)
}

/// Plugin side: reads the environment.
///
/// # Errors
/// A message when the struct is too small, the motion samples are missing or the deep metric unknown.
///
/// # Safety
/// `e` points to a valid [`RawEnvironment`] whose motion-sample pointer is valid for its count.
pub unsafe fn environment_from_raw(e: *const RawEnvironment) -> Result<ProjectionEnvironment, String> {
    // SAFETY: the caller's promise.
    let Some(e) = (unsafe { e.as_ref() }) else {
        return Err("environment is NULL".into());
    };
    if (e.struct_size as usize) < size_of::<RawEnvironment>() {
        return Err(format!(
            "environment struct_size {} is smaller than {}",
            e.struct_size,
            size_of::<RawEnvironment>()
        ));
    }
    // SAFETY: the caller's promise.
    let motion = unsafe {
        read_slice(
            e.world_to_camera,
            e.num_motion_samples as usize,
            "world_to_camera",
        )?
    };
    let format = Format {
        width: e.width,
        height: e.height,
        pixel_aspect: e.pixel_aspect,
    };
    let mut env = ProjectionEnvironment::new(
        format,
        ScreenWindow::new(e.screen_left, e.screen_right, e.screen_bottom, e.screen_top),
        (e.shutter_open, e.shutter_close),
        (e.clipping_near, e.clipping_far),
        motion
            .iter()
            .map(|m| MotionSample {
                time: m.time,
                world_to_camera: m.world_to_camera,
            })
            .collect(),
    );
    env.set_deep_metric(
        deep_metric_from_raw(e.deep_metric)
            .ok_or_else(|| format!("unknown deep metric {}", e.deep_metric))?,
    );
    Ok(env)
}

// ------------------------------------------------------------------------------------------------
// Owning C data built from SDK types.

/// Heap storage that C views point into. Moving a `Keep` moves no heap buffer, so the pointers it
/// handed out stay valid for as long as it lives.
#[derive(Default)]
struct Keep {
    strings: Vec<CString>,
    floats: Vec<Vec<f32>>,
    ints: Vec<Vec<i32>>,
    ptrs: Vec<Vec<*const c_char>>,
}

impl Keep {
    fn cstr(&mut self, s: &str, what: &str) -> Result<*const c_char, String> {
        let c = CString::new(s).map_err(|_| format!("{what} \"{s}\" contains a NUL byte"))?;
        let p = c.as_ptr();
        self.strings.push(c);
        Ok(p)
    }

    fn strs<S: AsRef<str>>(&mut self, v: &[S], what: &str) -> Result<*const *const c_char, String> {
        if v.is_empty() {
            return Ok(std::ptr::null());
        }
        let ptrs = v
            .iter()
            .map(|s| self.cstr(s.as_ref(), what))
            .collect::<Result<Vec<_>, _>>()?;
        let p = ptrs.as_ptr();
        self.ptrs.push(ptrs);
        Ok(p)
    }

    /// Pointers and scalar count of `v`, stored by its kind.
    fn value(
        &mut self,
        v: &ParamValue,
        what: &str,
    ) -> Result<(*const f32, *const i32, *const *const c_char, usize), String> {
        let none = (std::ptr::null(), std::ptr::null(), std::ptr::null());
        let (f, i, s) = match v {
            ParamValue::Floats(x) if !x.is_empty() => {
                self.floats.push(x.clone());
                (self.floats.last().map_or(none.0, |b| b.as_ptr()), none.1, none.2)
            }
            ParamValue::Ints(x) if !x.is_empty() => {
                self.ints.push(x.clone());
                (none.0, self.ints.last().map_or(none.1, |b| b.as_ptr()), none.2)
            }
            ParamValue::Strings(x) => (none.0, none.1, self.strs(x, what)?),
            _ => none,
        };
        Ok((f, i, s, v.len()))
    }
}

/// A parameter table in C form, owning what it points to (plugin side: the descriptor's table).
pub struct OwnedParamTable {
    decls: Vec<RawParamDecl>,
    _keep: Keep,
}

impl std::fmt::Debug for OwnedParamTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OwnedParamTable")
            .field("rows", &self.decls.len())
            .finish()
    }
}

impl OwnedParamTable {
    /// Converts a table.
    ///
    /// # Errors
    /// A message when a string holds a NUL byte (C cannot carry it).
    pub fn new(table: &[ParamDecl]) -> Result<Self, String> {
        let mut keep = Keep::default();
        let mut decls = Vec::with_capacity(table.len());
        for d in table {
            let what = format!("parameter \"{}\"", d.name);
            let (default_floats, default_ints, default_strings, default_count) =
                keep.value(&d.default, &what)?;
            let choices: Vec<&str> = d.choices.iter().map(AsRef::as_ref).collect();
            let (range_min, range_max, range_flags) = match d.range {
                Some(r) => (
                    r.min,
                    r.max,
                    RANGE_LIMITED
                        | if r.min_inclusive { RANGE_MIN_INCLUSIVE } else { 0 }
                        | if r.max_inclusive { RANGE_MAX_INCLUSIVE } else { 0 },
                ),
                None => (0.0, 0.0, 0),
            };
            decls.push(RawParamDecl {
                name: keep.cstr(&d.name, "parameter name")?,
                doc: keep.cstr(&d.doc, &what)?,
                default_floats,
                default_ints,
                default_strings,
                default_count,
                choices: keep.strs(&choices, &what)?,
                num_choices: choices.len(),
                range_min,
                range_max,
                ty: param_type_to_raw(d.ty),
                array_len: if d.variable_len {
                    ARRAY_VARIABLE
                } else {
                    d.array_len.map_or(ARRAY_SINGLE, |n| n as i32)
                },
                range_flags,
            });
        }
        Ok(OwnedParamTable { decls, _keep: keep })
    }

    /// The rows.
    #[must_use]
    pub fn rows(&self) -> &[RawParamDecl] {
        &self.decls
    }
}

/// A resolved parameter list in C form (host side): one entry per table row, in table order, the
/// scene's value where given, else the default.
pub struct OwnedParamList {
    list: RawParamList,
    params: Vec<RawParam>,
    _keep: Keep,
}

impl std::fmt::Debug for OwnedParamList {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OwnedParamList")
            .field("entries", &self.params.len())
            .finish()
    }
}

impl OwnedParamList {
    /// Builds the list. `list` should already have passed [`crate::Params::resolve`] against `table`
    /// (names, types, lengths and ranges are not checked again here).
    ///
    /// # Errors
    /// A message when a string holds a NUL byte.
    pub fn new(table: &[ParamDecl], list: &ParamList) -> Result<Self, String> {
        let mut keep = Keep::default();
        let mut params = Vec::with_capacity(table.len());
        for d in table {
            let given = list.get(&d.name);
            let value = given.map_or(&d.default, |e| &e.value);
            let what = format!("parameter \"{}\"", d.name);
            let (floats, ints, strings, count) = keep.value(value, &what)?;
            let origin = match given.and_then(|e| e.origin.as_deref()) {
                Some(o) => keep.cstr(o, &what)?,
                None => std::ptr::null(),
            };
            params.push(RawParam {
                name: keep.cstr(&d.name, "parameter name")?,
                origin,
                floats,
                ints,
                strings,
                count,
                ty: param_type_to_raw(d.ty),
                array_len: if d.variable_len {
                    ARRAY_VARIABLE
                } else {
                    d.array_len.map_or(ARRAY_SINGLE, |n| n as i32)
                },
                given: i32::from(given.is_some()),
            });
        }
        let list = RawParamList {
            struct_size: size_of::<RawParamList>() as u32,
            num_params: params.len() as u32,
            params: params.as_ptr(),
        };
        Ok(OwnedParamList {
            list,
            params,
            _keep: keep,
        })
    }

    /// The list, valid while `self` lives.
    #[must_use]
    pub fn raw(&self) -> &RawParamList {
        &self.list
    }

    /// The entries.
    #[must_use]
    pub fn entries(&self) -> &[RawParam] {
        &self.params
    }
}

/// An environment in C form (host side), owning its motion samples.
#[derive(Debug)]
pub struct OwnedEnvironment {
    raw: RawEnvironment,
    _motion: Vec<RawMotionSample>,
}

impl OwnedEnvironment {
    /// Converts `env`.
    #[must_use]
    pub fn new(env: &ProjectionEnvironment) -> Self {
        let motion: Vec<RawMotionSample> = env
            .world_to_camera()
            .iter()
            .map(|m| RawMotionSample {
                time: m.time,
                world_to_camera: m.world_to_camera,
            })
            .collect();
        let w = env.screen_window();
        let raw = RawEnvironment {
            struct_size: size_of::<RawEnvironment>() as u32,
            width: env.width(),
            height: env.height(),
            pixel_aspect: env.pixel_aspect_ratio(),
            screen_left: w.left,
            screen_right: w.right,
            screen_bottom: w.bottom,
            screen_top: w.top,
            shutter_open: env.shutter_open(),
            shutter_close: env.shutter_close(),
            clipping_near: env.clipping_near(),
            clipping_far: env.clipping_far(),
            deep_metric: env.deep_metric() as i32,
            num_motion_samples: motion.len() as u32,
            world_to_camera: motion.as_ptr(),
        };
        OwnedEnvironment { raw, _motion: motion }
    }

    /// The environment to hand to `create_projection` (the plugin may write `deep_metric`).
    pub fn raw_mut(&mut self) -> &mut RawEnvironment {
        &mut self.raw
    }

    /// The deep metric as it stands (after `create_projection` it is the plugin's choice).
    ///
    /// # Errors
    /// A message when the plugin wrote an unknown value.
    pub fn deep_metric(&self) -> Result<DeepMetric, String> {
        deep_metric_from_raw(self.raw.deep_metric).ok_or_else(|| {
            format!(
                "create_projection set the environment's deep metric to {} (expected 0 = cameraZ or 1 = rayLength)",
                self.raw.deep_metric
            )
        })
    }
}

// ------------------------------------------------------------------------------------------------
// The Rust plugin side: what `export_projection!` expands to.

/// A Rust factory exported through the ABI. The descriptor comes first, so the descriptor pointer the
/// host holds is also a pointer to this struct (`#[repr(C)]`).
#[doc(hidden)]
#[repr(C)]
pub struct Exported {
    descriptor: ProjectionDescriptor,
    factory: RwLock<Box<dyn ProjectionFactory>>,
    _table: OwnedParamTable,
    _keep: Keep,
}

// SAFETY: the raw pointers in `descriptor` point into `_table` and `_keep`, which are never mutated
// after construction; the factory is behind a lock and is `Send + Sync` itself.
unsafe impl Send for Exported {}
// SAFETY: as above.
unsafe impl Sync for Exported {}

impl Exported {
    fn new(factory: Box<dyn ProjectionFactory>) -> Result<Self, String> {
        let table = OwnedParamTable::new(factory.param_table())?;
        let mut keep = Keep::default();
        let descriptor = ProjectionDescriptor {
            abi_version: ABI_VERSION,
            struct_size: size_of::<ProjectionDescriptor>() as u32,
            name: keep.cstr(factory.name(), "name")?,
            summary: keep.cstr(factory.summary(), "summary")?,
            params: if table.rows().is_empty() {
                std::ptr::null()
            } else {
                table.rows().as_ptr()
            },
            num_params: table.rows().len(),
            init: Some(rs_init),
            finalize: Some(rs_finalize),
            synchronize: Some(rs_synchronize),
            create_projection: Some(rs_create),
            destroy_projection: Some(rs_destroy),
            property: Some(rs_property),
            project: Some(rs_project),
            unproject: Some(rs_unproject),
        };
        Ok(Exported {
            descriptor,
            factory: RwLock::new(factory),
            _table: table,
            _keep: keep,
        })
    }
}

/// The body of the entry point [`export_projection!`](crate::export_projection) generates: builds the
/// descriptor once (catching a panicking constructor) and returns it, or null when it cannot be built
/// (the reason goes to stderr, since there is no sink yet).
#[doc(hidden)]
pub fn export_entry(
    _host_abi_version: u32,
    cell: &'static OnceLock<Option<Exported>>,
    make: fn() -> Box<dyn ProjectionFactory>,
) -> *const ProjectionDescriptor {
    let exported = cell.get_or_init(|| match catch_unwind(|| Exported::new(make())) {
        Ok(Ok(e)) => Some(e),
        Ok(Err(why)) => {
            eprintln!("obscura plugin: cannot export the factory: {why}");
            None
        }
        Err(p) => {
            eprintln!(
                "obscura plugin: the factory panicked while being made: {}",
                panic_message(p.as_ref())
            );
            None
        }
    });
    exported
        .as_ref()
        .map_or(std::ptr::null(), |e| &raw const e.descriptor)
}

/// Runs `f`, turning an error or a panic into a status and a message on `sink`.
///
/// # Safety
/// `sink` is null or valid for this call.
unsafe fn guarded<T>(
    sink: *const ErrorSink,
    what: &str,
    f: impl FnOnce() -> Result<T, String>,
) -> Result<T, Status> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(m)) => {
            // SAFETY: forwarded promise.
            unsafe { report(sink, &m) };
            Err(ERROR)
        }
        Err(p) => {
            // SAFETY: forwarded promise.
            unsafe {
                report(
                    sink,
                    &format!("panicked in {what}: {}", panic_message(p.as_ref())),
                )
            };
            Err(PANIC)
        }
    }
}

/// # Safety
/// `factory` is null or the pointer `rs_init` handed out.
unsafe fn exported<'a>(factory: *const c_void) -> Option<&'a Exported> {
    // SAFETY: the pointer was made from an `&'static Exported`.
    unsafe { factory.cast::<Exported>().as_ref() }
}

unsafe extern "C" fn rs_init(
    descriptor: *const ProjectionDescriptor,
    plugin_path: *const c_char,
    factory: *mut *mut c_void,
    error: *const ErrorSink,
) -> Status {
    // SAFETY: the host hands back the descriptor we returned, which is the head of an `Exported`.
    let Some(ex) = (unsafe { exported(descriptor.cast()) }) else {
        // SAFETY: `error` is null or valid.
        unsafe { report(error, "init: the descriptor pointer is NULL") };
        return ERROR;
    };
    if factory.is_null() {
        // SAFETY: as above.
        unsafe { report(error, "init: the factory out-pointer is NULL") };
        return ERROR;
    }
    let path = if plugin_path.is_null() {
        String::new()
    } else {
        // SAFETY: the host passes a NUL-terminated string.
        unsafe { CStr::from_ptr(plugin_path) }
            .to_string_lossy()
            .into_owned()
    };
    // SAFETY: `error` is null or valid.
    let r = unsafe {
        guarded(error, "init", || {
            let mut f = ex.factory.write().unwrap_or_else(PoisonError::into_inner);
            f.init(&path).map_err(|e| e.to_string())
        })
    };
    match r {
        Ok(()) => {
            // SAFETY: checked non-null above.
            unsafe { *factory = (&raw const *ex).cast_mut().cast() };
            OK
        }
        Err(s) => s,
    }
}

unsafe extern "C" fn rs_finalize(factory: *mut c_void) {
    // SAFETY: the pointer rs_init handed out, or null.
    if let Some(ex) = unsafe { exported(factory) } {
        let _ = catch_unwind(AssertUnwindSafe(|| {
            ex.factory
                .write()
                .unwrap_or_else(PoisonError::into_inner)
                .finalize();
        }));
    }
}

unsafe extern "C" fn rs_synchronize(factory: *mut c_void, message: i32, params: *const RawParamList) {
    // SAFETY: the pointer rs_init handed out, or null.
    let Some(ex) = (unsafe { exported(factory) }) else {
        return;
    };
    let Some(message) = sync_message_from_raw(message) else {
        return;
    };
    // SAFETY: the host's list is valid for this call.
    let list = if params.is_null() {
        None
    } else {
        unsafe { param_list_from_raw(params) }.ok()
    };
    let _ = catch_unwind(AssertUnwindSafe(|| {
        ex.factory
            .write()
            .unwrap_or_else(PoisonError::into_inner)
            .synchronize(message, list.as_ref());
    }));
}

unsafe extern "C" fn rs_create(
    factory: *mut c_void,
    env: *mut RawEnvironment,
    params: *const RawParamList,
    projection: *mut *mut c_void,
    error: *const ErrorSink,
) -> Status {
    // SAFETY: the pointer rs_init handed out, or null.
    let Some(ex) = (unsafe { exported(factory) }) else {
        // SAFETY: `error` is null or valid.
        unsafe { report(error, "create_projection: the factory pointer is NULL") };
        return ERROR;
    };
    if projection.is_null() || env.is_null() {
        // SAFETY: as above.
        unsafe {
            report(
                error,
                "create_projection: NULL environment or projection out-pointer",
            )
        };
        return ERROR;
    }
    // SAFETY: the host's environment and list are valid for this call; `error` is null or valid.
    let r = unsafe {
        guarded(error, "create_projection", || {
            let mut rust_env = environment_from_raw(env)?;
            let list = param_list_from_raw(params)?;
            let f = ex.factory.read().unwrap_or_else(PoisonError::into_inner);
            let p = f
                .create_projection(&mut rust_env, &list)
                .map_err(|e| e.to_string())?;
            (*env).deep_metric = rust_env.deep_metric() as i32;
            Ok(p)
        })
    };
    match r {
        Ok(p) => {
            // SAFETY: checked non-null above.
            unsafe { *projection = Box::into_raw(Box::new(p)).cast() };
            OK
        }
        Err(s) => s,
    }
}

/// # Safety
/// `p` is null or a pointer made by `rs_create`, not yet destroyed.
unsafe fn projection<'a>(p: *const c_void) -> Option<&'a dyn Projection> {
    // SAFETY: `rs_create` made it from a `Box<Box<dyn Projection>>`.
    unsafe { p.cast::<Box<dyn Projection>>().as_ref() }.map(AsRef::as_ref)
}

unsafe extern "C" fn rs_destroy(_factory: *mut c_void, projection: *mut c_void) {
    if projection.is_null() {
        return;
    }
    // SAFETY: made by `rs_create`; the host destroys each projection once.
    let b = unsafe { Box::from_raw(projection.cast::<Box<dyn Projection>>()) };
    let _ = catch_unwind(AssertUnwindSafe(move || drop(b)));
}

unsafe extern "C" fn rs_property(p: *const c_void, property: i32, value: *mut RawPropertyValue) -> Status {
    // SAFETY: made by `rs_create`, or null.
    let (Some(p), false) = (unsafe { projection(p) }, value.is_null()) else {
        return ERROR;
    };
    let Some(property) = property_from_raw(property) else {
        return UNSUPPORTED;
    };
    match catch_unwind(AssertUnwindSafe(|| p.property(property))) {
        Ok(Some(v)) => {
            // SAFETY: checked non-null.
            unsafe { *value = value_to_raw(v) };
            OK
        }
        Ok(None) => UNSUPPORTED,
        Err(_) => PANIC,
    }
}

unsafe extern "C" fn rs_project(p: *const c_void, ctx: *const RawContext, error: *const ErrorSink) -> Status {
    // SAFETY: made by `rs_create`, or null.
    let Some(p) = (unsafe { projection(p) }) else {
        // SAFETY: `error` is null or valid.
        unsafe { report(error, "project: the projection pointer is NULL") };
        return ERROR;
    };
    // SAFETY: the host's context is valid for this call; `error` is null or valid.
    let r = unsafe {
        guarded(error, "project", || {
            let c = ctx.as_ref().ok_or("project: the context pointer is NULL")?;
            if (c.struct_size as usize) < size_of::<RawContext>() {
                return Err(format!(
                    "project: context struct_size {} is smaller than {}",
                    c.struct_size,
                    size_of::<RawContext>()
                ));
            }
            let n = c.num_rays as usize;
            check_array(c.time.cast_const(), n, "time")?;
            check_array(c.rays.cast_const(), n, "rays")?;
            check_array(c.tint.cast_const(), n, "tint")?;
            // The host lends the in/out arrays exclusively for this call; `check_array` vouched
            // for null and alignment.
            let (time, rays, tint): (&mut [f32], &mut [RayGeometry], &mut [Rgb]) = if n == 0 {
                (&mut [], &mut [], &mut [])
            } else {
                (
                    std::slice::from_raw_parts_mut(c.time, n),
                    std::slice::from_raw_parts_mut(c.rays, n),
                    std::slice::from_raw_parts_mut(c.tint, n),
                )
            };
            let mut batch = ProjectionContext::new(
                read_slice(c.screen, n, "screen")?,
                read_slice(c.lens, n, "lens")?,
                read_slice(c.aperture, n, "aperture")?,
                time,
                rays,
                tint,
            )
            .map_err(|e| e.to_string())?;
            p.project(&mut batch);
            Ok(())
        })
    };
    match r {
        Ok(()) => OK,
        Err(s) => s,
    }
}

unsafe extern "C" fn rs_unproject(p: *const c_void, point: Vec3, time: f32, screen: *mut Point2) -> Status {
    // SAFETY: made by `rs_create`, or null.
    let (Some(p), false) = (unsafe { projection(p) }, screen.is_null()) else {
        return ERROR;
    };
    match catch_unwind(AssertUnwindSafe(|| p.unproject(point, time))) {
        Ok(Some(s)) => {
            // SAFETY: checked non-null.
            unsafe { *screen = s };
            OK
        }
        Ok(None) => UNSUPPORTED,
        Err(_) => PANIC,
    }
}

/// Exports a [`ProjectionFactory`] from a `cdylib` through the C ABI.
///
/// ```text
/// // Cargo.toml: [lib] crate-type = ["cdylib", "rlib"]
/// obscura_sdk::export_projection!(MyFactory);
/// ```
///
/// The argument is an expression making the factory (a unit struct's name, `MyFactory::default()`),
/// evaluated once, on the host's first call. The macro defines the library's entry point,
/// `obscura_projection_entry`, so it may appear once per library. Every call across the boundary
/// catches panics: a panic in `project` reaches the host as a status and a message (the host culls and
/// counts that batch and the render goes on), one in `create_projection` or `init` as an error.
#[macro_export]
macro_rules! export_projection {
    ($factory:expr) => {
        /// The plugin's entry point, generated by `obscura_sdk::export_projection!`.
        #[unsafe(no_mangle)]
        pub extern "C" fn obscura_projection_entry(
            host_abi_version: u32,
        ) -> *const $crate::abi::ProjectionDescriptor {
            static EXPORTED: ::std::sync::OnceLock<::std::option::Option<$crate::abi::Exported>> =
                ::std::sync::OnceLock::new();
            fn make() -> ::std::boxed::Box<dyn $crate::ProjectionFactory> {
                ::std::boxed::Box::new($factory)
            }
            $crate::abi::export_entry(host_abi_version, &EXPORTED, make)
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Params, PluginError};
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

    #[test]
    fn enum_numbers_round_trip_and_unknown_ones_are_refused() {
        for t in ParamType::ALL {
            assert_eq!(param_type_from_raw(param_type_to_raw(t)), Some(t));
        }
        assert_eq!(param_type_from_raw(8), None);
        for p in ProjectionProperty::ALL {
            assert_eq!(property_from_raw(p as i32), Some(p));
        }
        assert_eq!(property_from_raw(-1), None);
        for v in [
            PropertyValue::DicingHint(DicingHint::Spherical),
            PropertyValue::DeepMetric(DeepMetric::RayLength),
            PropertyValue::Float(37.5),
        ] {
            assert_eq!(value_from_raw(value_to_raw(v)), Ok(v));
        }
        let bad = RawPropertyValue {
            kind: VALUE_DICING_HINT,
            enum_value: 7,
            float_value: 0.0,
        };
        assert!(value_from_raw(bad).unwrap_err().contains("unknown dicing hint 7"));
    }

    fn table() -> Vec<ParamDecl> {
        vec![
            ParamDecl::float("fov", 90.0)
                .range(ValueRange::open(0.0, 360.0))
                .doc("field of view"),
            ParamDecl::string("mode", "a").choices(&["a", "b"]).doc("mode"),
            ParamDecl::int_array("steps", &[1, 2]),
            ParamDecl::float_list("k", &[]),
            ParamDecl::matrix("m", Matrix4::IDENTITY),
        ]
    }

    #[test]
    fn a_table_survives_the_trip_through_c() {
        let t = table();
        let raw = OwnedParamTable::new(&t).unwrap();
        let back: Vec<ParamDecl> = raw
            .rows()
            .iter()
            .map(|d| unsafe { decl_from_raw(d) }.unwrap())
            .collect();
        assert_eq!(back, t);
    }

    #[test]
    fn inconsistent_rows_are_refused_with_the_parameter_named() {
        let t = table();
        let raw = OwnedParamTable::new(&t).unwrap();
        let mut row = raw.rows()[0];
        row.default_count = 2;
        let e = unsafe { decl_from_raw(&row) }.unwrap_err();
        assert!(
            e.contains("parameter \"fov\"")
                && e.contains("default_count 2 but a float default has 1 scalar(s)"),
            "{e}"
        );
        let mut row = raw.rows()[0];
        row.range_max = 10.0;
        assert!(
            unsafe { decl_from_raw(&row) }
                .unwrap_err()
                .contains("outside its own range")
        );
        let mut row = raw.rows()[2];
        row.default_ints = std::ptr::null();
        assert!(unsafe { decl_from_raw(&row) }.unwrap_err().contains("NULL"));
        let mut row = raw.rows()[2];
        row.array_len = ARRAY_VARIABLE;
        assert!(
            unsafe { decl_from_raw(&row) }
                .unwrap_err()
                .contains("only float[]")
        );
        let mut row = raw.rows()[1];
        row.name = std::ptr::null();
        assert_eq!(unsafe { decl_from_raw(&row) }.unwrap_err(), "name is NULL");
    }

    #[test]
    fn a_parameter_list_resolves_in_table_order_and_reads_back_as_given() {
        let t = table();
        let mut list = ParamList::new();
        list.push_text("string mode", &["b"], Some("scene.rib:3".into()))
            .unwrap();
        list.push_text("float k", &["0.5", "0.25", "0.125"], None)
            .unwrap();
        Params::resolve("P", &t, &list).unwrap();
        let owned = OwnedParamList::new(&t, &list).unwrap();
        let e = owned.entries();
        assert_eq!(e.len(), t.len());
        assert_eq!((e[0].given, e[1].given, e[3].given), (0, 1, 1));
        assert_eq!(unsafe { *e[0].floats }, 90.0, "the default is filled in");
        assert_eq!(e[3].count, 3);
        assert_eq!(e[3].array_len, ARRAY_VARIABLE);
        let back = unsafe { param_list_from_raw(owned.raw()) }.unwrap();
        assert_eq!(back.entries().len(), 2);
        assert_eq!(back.get("mode").unwrap().origin.as_deref(), Some("scene.rib:3"));
        let p = Params::resolve("P", &t, &back).unwrap();
        assert_eq!(p.string("mode").unwrap(), "b");
        assert_eq!(p.float_list("k").unwrap(), &[0.5, 0.25, 0.125]);
        assert!(!p.is_given("fov"));
    }

    #[test]
    fn the_environment_survives_the_trip_through_c() {
        let mut m = Matrix4::IDENTITY;
        m.0[3] = [1.0, 2.0, 3.0, 1.0];
        let mut env = ProjectionEnvironment::new(
            Format {
                width: 320,
                height: 200,
                pixel_aspect: 1.25,
            },
            ScreenWindow::new(-2.0, 2.0, -1.0, 1.0),
            (0.25, 0.75),
            (0.5, 100.0),
            vec![
                MotionSample {
                    time: 0.25,
                    world_to_camera: Matrix4::IDENTITY,
                },
                MotionSample {
                    time: 0.75,
                    world_to_camera: m,
                },
            ],
        );
        env.set_deep_metric(DeepMetric::RayLength);
        let mut owned = OwnedEnvironment::new(&env);
        let back = unsafe { environment_from_raw(owned.raw_mut()) }.unwrap();
        assert_eq!(back, env);
        owned.raw_mut().deep_metric = 9;
        assert!(owned.deep_metric().unwrap_err().contains("9"));
        owned.raw_mut().struct_size = 8;
        assert!(
            unsafe { environment_from_raw(owned.raw_mut()) }
                .unwrap_err()
                .contains("smaller")
        );
    }

    #[test]
    fn messages_cross_as_copies() {
        let ((), msg) = collect_message(|sink| unsafe {
            report(sink, "bad fov: ");
            report(sink, "expected (0, 360)");
        });
        assert_eq!(msg, "bad fov: expected (0, 360)");
        unsafe { report(std::ptr::null(), "dropped") };
    }

    // The exported entry points, called as a host would, without a shared library.

    struct Doubler;
    struct DoublerFactory;
    impl Projection for Doubler {
        fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
            (p == ProjectionProperty::FieldOfView).then_some(PropertyValue::Float(60.0))
        }
        fn project(&self, ctx: &mut ProjectionContext<'_>) {
            let c = ctx.parts_mut();
            if c.screen.first().is_some_and(|s| s.x > 100.0) {
                panic!("screen x {} is absurd", c.screen[0].x);
            }
            for (t, s) in c.time.iter_mut().zip(c.screen) {
                *t = s.x * 2.0;
            }
        }
    }
    impl ProjectionFactory for DoublerFactory {
        fn name(&self) -> &str {
            "Doubler"
        }
        fn summary(&self) -> &str {
            "doubles"
        }
        fn param_table(&self) -> &[ParamDecl] {
            &[]
        }
        fn create_projection(
            &self,
            env: &mut ProjectionEnvironment,
            params: &ParamList,
        ) -> Result<Box<dyn Projection>, PluginError> {
            Params::resolve("Doubler", &[], params)?;
            env.set_deep_metric(DeepMetric::RayLength);
            Ok(Box::new(Doubler))
        }
    }

    mod exported {
        crate::export_projection!(super::DoublerFactory);
    }

    #[test]
    fn exported_entry_points_keep_the_contract() {
        let d = unsafe { &*exported::obscura_projection_entry(ABI_VERSION) };
        assert_eq!(
            (d.abi_version, d.struct_size as usize),
            (ABI_VERSION, size_of::<ProjectionDescriptor>())
        );
        assert_eq!(unsafe { read_str(d.name, "name") }.unwrap(), "Doubler");
        let mut factory = std::ptr::null_mut();
        let (s, _) = collect_message(|e| unsafe { d.init.unwrap()(d, c"".as_ptr(), &mut factory, e) });
        assert_eq!(s, OK);
        assert!(!factory.is_null());

        let env = ProjectionEnvironment::for_format(Format::new(4, 4));
        let mut raw_env = OwnedEnvironment::new(&env);
        let params = OwnedParamList::new(&[], &ParamList::new()).unwrap();
        let mut proj = std::ptr::null_mut();
        let (s, m) = collect_message(|e| unsafe {
            d.create_projection.unwrap()(factory, raw_env.raw_mut(), params.raw(), &mut proj, e)
        });
        assert_eq!(s, OK, "{m}");
        assert_eq!(
            raw_env.deep_metric(),
            Ok(DeepMetric::RayLength),
            "the writable field comes back"
        );

        let mut v = RawPropertyValue {
            kind: -1,
            enum_value: 0,
            float_value: 0.0,
        };
        assert_eq!(unsafe { d.property.unwrap()(proj, 2, &mut v) }, OK);
        assert_eq!(value_from_raw(v), Ok(PropertyValue::Float(60.0)));
        assert_eq!(unsafe { d.property.unwrap()(proj, 0, &mut v) }, UNSUPPORTED);
        assert_eq!(unsafe { d.property.unwrap()(proj, 99, &mut v) }, UNSUPPORTED);

        let screen = [Point2::new(0.25, 0.0), Point2::new(0.125, 0.0)];
        let mut time = [0.0f32; 2];
        let mut rays = [RayGeometry::CULLED; 2];
        let mut tint = [Rgb::WHITE; 2];
        let ctx = RawContext {
            struct_size: size_of::<RawContext>() as u32,
            num_rays: 2,
            screen: screen.as_ptr(),
            lens: screen.as_ptr(),
            aperture: screen.as_ptr(),
            time: time.as_mut_ptr(),
            rays: rays.as_mut_ptr(),
            tint: tint.as_mut_ptr(),
        };
        let (s, _) = collect_message(|e| unsafe { d.project.unwrap()(proj, &ctx, e) });
        assert_eq!(s, OK);
        assert_eq!(time, [0.5, 0.25]);

        let absurd = [Point2::new(1000.0, 0.0); 2];
        let ctx_panics = RawContext {
            screen: absurd.as_ptr(),
            ..ctx
        };
        let (s, m) = collect_message(|e| unsafe { d.project.unwrap()(proj, &ctx_panics, e) });
        assert_eq!(s, PANIC);
        assert!(m.contains("panicked in project: screen x 1000 is absurd"), "{m}");

        let (s, m) = collect_message(|e| unsafe { d.project.unwrap()(proj, std::ptr::null(), e) });
        assert_eq!(s, ERROR);
        assert!(m.contains("context pointer is NULL"), "{m}");
        let null_rays = RawContext {
            rays: std::ptr::null_mut(),
            ..ctx
        };
        let (s, m) = collect_message(|e| unsafe { d.project.unwrap()(proj, &null_rays, e) });
        assert_eq!(s, ERROR);
        assert!(m.contains("rays is NULL"), "{m}");
        let small = RawContext {
            struct_size: 8,
            ..ctx
        };
        assert_eq!(
            unsafe { d.project.unwrap()(proj, &small, std::ptr::null()) },
            ERROR
        );

        let mut out = Point2::ZERO;
        assert_eq!(
            unsafe { d.unproject.unwrap()(proj, Vec3::Z, 0.0, &mut out) },
            UNSUPPORTED,
            "the trait's default: no inverse"
        );
        unsafe { d.destroy_projection.unwrap()(factory, proj) };

        let mut given = ParamList::new();
        given.push_text("float fov", &["3"], Some("here".into())).unwrap();
        let table = [ParamDecl::float("fov", 1.0)];
        let params = OwnedParamList::new(&table, &given).unwrap();
        let (s, m) = collect_message(|e| unsafe {
            d.create_projection.unwrap()(factory, raw_env.raw_mut(), params.raw(), &mut proj, e)
        });
        assert_eq!(s, ERROR);
        assert!(m.contains("unknown parameter \"fov\""), "{m}");
        unsafe { d.finalize.unwrap()(factory) };
    }
}
