//! The plugin side of the ABI, compiled into every Rust plugin: what
//! [`export_projection!`](crate::export_projection) expands to.
//!
//! - [`OwnedParamTable`]: the factory's parameter table in C form, published in the descriptor;
//! - [`param_list_from_raw`] and [`environment_from_raw`]: what the host sends, read back into the
//!   SDK's [`ParamList`] and [`ProjectionEnvironment`];
//! - [`report`]: a message to the host's error sink;
//! - the `rs_*` trampolines: each C entry point calls the factory or projection inside
//!   `catch_unwind`, so a panic reaches the host as `OBSCURA_PANIC` and an `Err` as `OBSCURA_ERROR`,
//!   both with a message, never as an unwind across `extern "C"`.

use std::ffi::{CStr, c_char, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::{OnceLock, PoisonError, RwLock};

use super::AbiError;
use super::c_data::{Keep, check_array, read_slice, read_str, read_value};
use super::raw::{
    ABI_VERSION, ERROR, ErrorSink, OK, PANIC, ProjectionDescriptor, RANGE_LIMITED, RANGE_MAX_INCLUSIVE,
    RANGE_MIN_INCLUSIVE, RawContext, RawEnvironment, RawParam, RawParamDecl, RawParamList, RawPropertyValue,
    Status, UNSUPPORTED, array_len_to_raw, deep_metric_from_raw, param_type_from_raw, param_type_to_raw,
    property_from_raw, sync_message_from_raw, value_to_raw,
};
use crate::context::ProjectionContext;
use crate::environment::{Format, MotionSample, ProjectionEnvironment, ScreenWindow};
use crate::geometry::{Point2, Rgb, Vec3};
use crate::param::{ParamDecl, ParamList};
use crate::plugin::{Projection, ProjectionFactory};
use crate::ray::RayGeometry;

/// Sends `message` to the host's error sink (plugin side).
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

/// Reads a parameter list back into the scene's [`ParamList`] (the entries the scene gave, with
/// their origins). A null pointer is an empty list.
///
/// # Errors
/// An [`AbiError`] when the list is malformed (too small a `struct_size`, null arrays, unknown types).
///
/// # Safety
/// `p` is null or points to a valid [`RawParamList`] whose pointers are valid for its counts.
pub unsafe fn param_list_from_raw(p: *const RawParamList) -> Result<ParamList, AbiError> {
    // SAFETY: the caller's promise.
    let Some(list) = (unsafe { p.as_ref() }) else {
        return Ok(ParamList::new());
    };
    if (list.struct_size as usize) < size_of::<RawParamList>() {
        return Err(AbiError::TooSmall {
            what: "parameter list",
            size: list.struct_size,
            min: size_of::<RawParamList>(),
        });
    }
    // SAFETY: the caller's promise.
    let entries = unsafe { read_slice(list.params, list.num_params as usize, "params")? };
    let mut out = ParamList::new();
    for (i, e) in entries.iter().enumerate().filter(|(_, e)| e.given != 0) {
        // SAFETY: the caller's promise.
        unsafe { push_entry(&mut out, i, e)? };
    }
    Ok(out)
}

/// Appends the given entry `i` of a parameter list to `out`, declared by the shape of its value.
///
/// # Safety
/// As [`param_list_from_raw`], for the entry.
unsafe fn push_entry(out: &mut ParamList, i: usize, e: &RawParam) -> Result<(), AbiError> {
    // SAFETY: the caller's promise.
    let name = unsafe { read_str(e.name, &format!("params[{i}].name"))? };
    let ty = param_type_from_raw(e.ty).ok_or_else(|| {
        AbiError::UnknownEnum {
            what: "type",
            value: e.ty,
            expected: None,
        }
        .in_param(&name)
    })?;
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
        return Err(AbiError::PartialValue {
            count: value.len(),
            ty,
        }
        .in_param(&name));
    }
    let decl = if value.len() == comps {
        format!("{ty} {name}")
    } else {
        format!("{ty}[{}] {name}", value.len() / comps)
    };
    out.push(&decl, value, origin)?;
    Ok(())
}

/// Reads the environment the host hands to `create_projection`.
///
/// # Errors
/// An [`AbiError`] when the pointer is null, the struct too small, the motion samples missing or the
/// deep metric unknown.
///
/// # Safety
/// `e` is null or points to a valid [`RawEnvironment`] whose motion-sample pointer is valid for its
/// count.
pub unsafe fn environment_from_raw(e: *const RawEnvironment) -> Result<ProjectionEnvironment, AbiError> {
    // SAFETY: the caller's promise.
    let Some(e) = (unsafe { e.as_ref() }) else {
        return Err(AbiError::NullPointer {
            what: "environment".into(),
        });
    };
    if (e.struct_size as usize) < size_of::<RawEnvironment>() {
        return Err(AbiError::TooSmall {
            what: "environment",
            size: e.struct_size,
            min: size_of::<RawEnvironment>(),
        });
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
    let metric = deep_metric_from_raw(e.deep_metric).ok_or(AbiError::UnknownEnum {
        what: "deep metric",
        value: e.deep_metric,
        expected: None,
    })?;
    env.set_deep_metric(metric);
    Ok(env)
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
    /// [`AbiError::NulByte`] when a string holds a NUL byte (C cannot carry it).
    pub fn new(table: &[ParamDecl]) -> Result<Self, AbiError> {
        let mut keep = Keep::default();
        let decls = table
            .iter()
            .map(|d| row(&mut keep, d))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(OwnedParamTable { decls, _keep: keep })
    }

    /// The rows.
    #[must_use]
    pub fn rows(&self) -> &[RawParamDecl] {
        &self.decls
    }
}

/// One table row in C form, its strings and default kept in `keep`.
fn row(keep: &mut Keep, d: &ParamDecl) -> Result<RawParamDecl, AbiError> {
    let what = format!("parameter \"{}\"", d.name);
    let default = keep.value(&d.default, &what)?;
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
    Ok(RawParamDecl {
        name: keep.cstr(&d.name, "parameter name")?,
        doc: keep.cstr(&d.doc, &what)?,
        default_floats: default.floats,
        default_ints: default.ints,
        default_strings: default.strings,
        default_count: default.count,
        choices: keep.strs(&choices, &what)?,
        num_choices: choices.len(),
        range_min,
        range_max,
        ty: param_type_to_raw(d.ty),
        array_len: array_len_to_raw(d),
        range_flags,
    })
}

// ------------------------------------------------------------------------------------------------
// What `export_projection!` expands to.

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
    fn new(factory: Box<dyn ProjectionFactory>) -> Result<Self, AbiError> {
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

/// The text of a panic payload: a `&str` or a `String` (what `panic!` raises), else a placeholder.
/// (The host's `obscura_host::contract::panic_message` also reads its adapters' own payloads.)
fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic with a non-string payload".into())
}

/// Runs `f`, turning an error or a panic into a status and a message on `sink`.
///
/// # Safety
/// `sink` is null or valid for this call.
unsafe fn guarded<T>(
    sink: *const ErrorSink,
    what: &str,
    f: impl FnOnce() -> Result<T, AbiError>,
) -> Result<T, Status> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => {
            // SAFETY: forwarded promise.
            unsafe { report(sink, &e.to_string()) };
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

/// `init`: hands back the [`Exported`] as the factory state once the factory's `init` succeeds.
///
/// # Safety
/// `descriptor` is the one this library's entry point returned; `plugin_path` null or NUL-terminated;
/// `factory` null or writable; `error` null or a sink valid for the call.
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
            Ok(f.init(&path)?)
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

/// `finalize`: the factory's own `finalize`, a panic in it swallowed (there is no sink).
///
/// # Safety
/// `factory` is null or the pointer `rs_init` handed out.
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

/// `synchronize`: forwards a known message with the list, read back (NULL or unreadable: none).
///
/// # Safety
/// `factory` is null or the pointer `rs_init` handed out; `params` null or a list valid for the call.
unsafe extern "C" fn rs_synchronize(factory: *mut c_void, message: i32, params: *const RawParamList) {
    // SAFETY: the pointer rs_init handed out, or null.
    let Some(ex) = (unsafe { exported(factory) }) else {
        return;
    };
    let Some(message) = sync_message_from_raw(message) else {
        return;
    };
    let list = if params.is_null() {
        None
    } else {
        // SAFETY: the host's list is valid for this call.
        unsafe { param_list_from_raw(params) }.ok()
    };
    let _ = catch_unwind(AssertUnwindSafe(|| {
        ex.factory
            .write()
            .unwrap_or_else(PoisonError::into_inner)
            .synchronize(message, list.as_ref());
    }));
}

/// `create_projection`: reads the environment and list, creates, writes back the deep metric.
///
/// # Safety
/// `factory` is null or the pointer `rs_init` handed out; `env` null or a valid environment,
/// `params` null or a valid list, `projection` null or writable, `error` null or a valid sink, all
/// for the call.
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
            let p = f.create_projection(&mut rust_env, &list)?;
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

/// `destroy_projection`: drops the projection, a panic in its `Drop` swallowed.
///
/// # Safety
/// `projection` is null or a pointer `rs_create` made, not yet destroyed.
unsafe extern "C" fn rs_destroy(_factory: *mut c_void, projection: *mut c_void) {
    if projection.is_null() {
        return;
    }
    // SAFETY: made by `rs_create`; the host destroys each projection once.
    let b = unsafe { Box::from_raw(projection.cast::<Box<dyn Projection>>()) };
    let _ = catch_unwind(AssertUnwindSafe(move || drop(b)));
}

/// `property`: the projection's answer in ABI form.
///
/// # Safety
/// `p` is null or a live projection `rs_create` made; `value` null or writable.
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

/// `project`: one batch, its arrays checked before they become slices.
///
/// # Safety
/// `p` is null or a live projection `rs_create` made; `ctx` null or a context whose non-null arrays
/// hold `num_rays` elements, the in/out ones lent exclusively, for the call; `error` null or valid.
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
            let c = ctx.as_ref().ok_or_else(|| AbiError::NullPointer {
                what: "project: the context pointer".into(),
            })?;
            if (c.struct_size as usize) < size_of::<RawContext>() {
                return Err(AbiError::TooSmall {
                    what: "project: context",
                    size: c.struct_size,
                    min: size_of::<RawContext>(),
                });
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
            )?;
            p.project(&mut batch);
            Ok(())
        })
    };
    match r {
        Ok(()) => OK,
        Err(s) => s,
    }
}

/// `unproject`: the projection's inverse, if it has one.
///
/// # Safety
/// `p` is null or a live projection `rs_create` made; `screen` null or writable.
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
