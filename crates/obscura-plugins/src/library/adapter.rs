//! The adapter that makes a loaded plugin an ordinary SDK factory: [`PluginFactory`] implements
//! [`ProjectionFactory`] and its projections [`Projection`] by calling through the descriptor's
//! function pointers, so a plugin goes through the same registry, camera stage, validation and
//! culling as a built-in.
//!
//! A status other than OK from the plugin's `project` becomes a panic in [`Projection::project`]
//! (raised with `resume_unwind`, so no second panic message is printed): `OBSCURA_ERROR` as a
//! [`ProjectFailed`], `OBSCURA_PANIC` as the plugin's message. The camera stage already catches that,
//! culls and counts the batch's samples, and the render goes on. The same holds for `property` and
//! `unproject`: a failed call (any status but OK and UNSUPPORTED) is raised, never passed off as
//! "unanswered" or "outside the view", and a property value that does not decode is raised as an
//! [`UndecodableProperty`]. Every caller catches them: the camera stage's property reader warns and
//! goes on without the property, `stmap` counts the pixels, and `obscura check` reports a panic or a
//! property of the wrong type.

use std::ffi::c_void;
use std::panic::resume_unwind;
use std::path::Path;
use std::sync::PoisonError;

use obscura_host::contract::{ProjectFailed, UndecodableProperty};
use obscura_sdk::abi::{self, RawContext, RawPropertyValue};
use obscura_sdk::{
    ParamDecl, ParamList, Params, PluginError, Point2, Projection, ProjectionContext, ProjectionEnvironment,
    ProjectionFactory, ProjectionProperty, PropertyValue, SyncMessage, Vec3,
};

use super::PluginLoadError;
use super::open::{self, Loaded, or_status, status_name};
use crate::decode::value_from_raw;
use crate::encode::{OwnedEnvironment, OwnedParamList, collect_message};

/// A loaded plugin's factory: a [`ProjectionFactory`] calling through the C ABI.
pub struct PluginFactory {
    lib: &'static Loaded,
    initialized: bool,
}

impl std::fmt::Debug for PluginFactory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PluginFactory")
            .field("name", &self.lib.name)
            .field("path", &self.lib.path)
            .finish()
    }
}

impl PluginFactory {
    /// Opens the library at `path` and checks its descriptor. The plugin's `init` is not called here:
    /// the registry calls it, with the library's path, before the first projection is created, so
    /// listing or loading a plugin runs none of its code but the entry point.
    ///
    /// # Errors
    /// A [`PluginLoadError`] naming the file and the reason.
    pub fn open(path: &Path) -> Result<Self, PluginLoadError> {
        Ok(PluginFactory {
            lib: open::open(path)?,
            initialized: false,
        })
    }

    /// The library's file (canonical path).
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.lib.path
    }
}

impl ProjectionFactory for PluginFactory {
    fn name(&self) -> &str {
        &self.lib.name
    }

    fn summary(&self) -> &str {
        &self.lib.summary
    }

    fn param_table(&self) -> &[ParamDecl] {
        &self.lib.table
    }

    fn init(&mut self, plugin_path: &str) -> Result<(), PluginError> {
        if !self.initialized {
            self.lib.acquire(plugin_path)?;
            self.initialized = true;
        }
        Ok(())
    }

    fn finalize(&mut self) {
        if std::mem::take(&mut self.initialized) {
            self.lib.release(None);
        }
    }

    fn synchronize(&mut self, message: SyncMessage, params: Option<&ParamList>) {
        let Some(sync) = self.lib.synchronize else {
            return;
        };
        // A list that does not fit the table reaches the plugin as NULL; create reports the error.
        let list = params
            .filter(|p| Params::resolve(&self.lib.name, &self.lib.table, p).is_ok())
            .and_then(|p| OwnedParamList::new(&self.lib.table, p).ok());
        let s = self.lib.session.lock().unwrap_or_else(PoisonError::into_inner);
        if s.factory.is_null() {
            return;
        }
        let raw = list.as_ref().map_or(std::ptr::null(), |l| l.raw() as *const _);
        // SAFETY: the factory `init` made, a valid (or null) list, serialised by the session lock.
        unsafe { sync(s.factory, message as i32, raw) };
    }

    fn create_projection(
        &self,
        env: &mut ProjectionEnvironment,
        params: &ParamList,
    ) -> Result<Box<dyn Projection>, PluginError> {
        let name = &self.lib.name;
        let invalid = |message: String| PluginError::Invalid {
            plugin: name.clone(),
            message,
        };
        // RenderMan's Args/<Name>.args defaults, where the scene gives no value.
        let merged;
        let params = match &self.lib.args {
            Some(args) => {
                let (list, warnings) = args.with_defaults(&self.lib.table, params);
                for w in warnings {
                    eprintln!("warning: {w}");
                }
                merged = list;
                &merged
            }
            None => params,
        };
        Params::resolve(name, &self.lib.table, params)?;
        let list = OwnedParamList::new(&self.lib.table, params).map_err(|e| invalid(e.to_string()))?;
        let mut raw_env = OwnedEnvironment::new(env);
        let mut s = self.lib.session.lock().unwrap_or_else(PoisonError::into_inner);
        if s.factory.is_null() {
            return Err(self.lib.init_error("create_projection before init"));
        }
        let mut handle = std::ptr::null_mut();
        // SAFETY: the factory `init` made; the environment, list, out-pointer and sink live for the
        // call; factory calls are serialised by the session lock.
        let (status, msg) = collect_message(|e| unsafe {
            (self.lib.create)(s.factory, raw_env.raw_mut(), list.raw(), &mut handle, e)
        });
        let prefix = format!("{name}: ");
        let msg = msg.strip_prefix(&prefix).map(str::to_string).unwrap_or(msg);
        match status {
            abi::OK if handle.is_null() => {
                return Err(invalid(
                    "create_projection returned OK but no projection (NULL)".into(),
                ));
            }
            abi::OK => {}
            _ => return Err(invalid(or_status(msg, status))),
        }
        match raw_env.deep_metric() {
            Ok(m) => env.set_deep_metric(m),
            Err(e) => {
                // SAFETY: just created, destroyed once.
                unsafe { (self.lib.destroy)(s.factory, handle) };
                return Err(invalid(e.to_string()));
            }
        }
        s.users += 1;
        Ok(Box::new(PluginProjection {
            lib: self.lib,
            handle,
        }))
    }
}

impl Drop for PluginFactory {
    fn drop(&mut self) {
        self.finalize();
    }
}

/// A projection made by a loaded plugin.
struct PluginProjection {
    lib: &'static Loaded,
    handle: *mut c_void,
}

// SAFETY: the ABI requires a projection's `property`, `project` and `unproject` to be thread-safe.
unsafe impl Send for PluginProjection {}
// SAFETY: as above.
unsafe impl Sync for PluginProjection {}

impl Projection for PluginProjection {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        let mut v = RawPropertyValue {
            kind: -1,
            enum_value: 0,
            float_value: 0.0,
        };
        // SAFETY: a live projection handle and an out-pointer valid for the call.
        let status = unsafe { (self.lib.property)(self.handle, property as i32, &mut v) };
        match status {
            abi::OK => match value_from_raw(v) {
                Ok(v) => Some(v),
                // Not `None`: the reader catches this and warns, `obscura check` counts a wrong type.
                Err(e) => resume_unwind(Box::new(UndecodableProperty {
                    property: property.renderman_name(),
                    reason: e.to_string(),
                })),
            },
            abi::UNSUPPORTED => None,
            s => resume_unwind(Box::new(format!("the plugin returned status {}", status_name(s)))),
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        let n = c.screen.len();
        let mut start = 0;
        while start < n {
            let end = n.min(start + u32::MAX as usize);
            let raw = RawContext {
                struct_size: size_of::<RawContext>() as u32,
                num_rays: (end - start) as u32,
                screen: c.screen[start..].as_ptr(),
                lens: c.lens[start..].as_ptr(),
                aperture: c.aperture[start..].as_ptr(),
                time: c.time[start..].as_mut_ptr(),
                rays: c.rays[start..].as_mut_ptr(),
                tint: c.tint[start..].as_mut_ptr(),
            };
            // SAFETY: every array holds `num_rays` elements from `start` and is lent for the call.
            let (status, msg) = collect_message(|e| unsafe { (self.lib.project)(self.handle, &raw, e) });
            // The camera stage catches these, culls and counts the batch; `resume_unwind` skips the
            // panic hook, which already spoke in the plugin if it was a Rust panic.
            match status {
                abi::OK => {}
                abi::ERROR => resume_unwind(Box::new(ProjectFailed(or_status(msg, status)))),
                abi::PANIC => resume_unwind(Box::new(
                    msg.strip_prefix("panicked in project: ")
                        .map(str::to_string)
                        .unwrap_or(msg),
                )),
                _ => resume_unwind(Box::new(format!("project failed: {}", or_status(msg, status)))),
            }
            start = end;
        }
    }

    fn unproject(&self, point: Vec3, time: f32) -> Option<Point2> {
        let f = self.lib.unproject?;
        let mut out = Point2::ZERO;
        // SAFETY: a live projection handle and an out-pointer valid for the call.
        let status = unsafe { f(self.handle, point, time, &mut out) };
        match status {
            abi::OK => Some(out),
            abi::UNSUPPORTED => None,
            // A failure is not "outside the view": callers catch this and count it.
            s => resume_unwind(Box::new(format!("the plugin returned status {}", status_name(s)))),
        }
    }
}

impl Drop for PluginProjection {
    fn drop(&mut self) {
        self.lib.release(Some(self.handle));
    }
}
