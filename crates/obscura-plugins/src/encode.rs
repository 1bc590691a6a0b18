//! The host encoding what it sends a plugin: the resolved parameter list ([`OwnedParamList`]) and the
//! environment ([`OwnedEnvironment`]) in C form, each owning what its pointers point to, and the
//! error sink that copies a plugin's message ([`collect_message`]).

use std::ffi::{c_char, c_void};

use obscura_sdk::abi::c_data::Keep;
use obscura_sdk::abi::{
    AbiError, ErrorSink, RawEnvironment, RawMotionSample, RawParam, RawParamList, array_len_to_raw,
    deep_metric_from_raw, param_type_to_raw,
};
use obscura_sdk::{DeepMetric, ParamDecl, ParamList, ProjectionEnvironment};

/// The sink's callback: appends the plugin's bytes, decoded lossily, to the `String` lent as `host`.
///
/// # Safety
/// `host` is null or the `String` [`collect_message`] lent for this call; `message` is null or points
/// to `len` readable bytes.
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

/// Runs `f` with an [`ErrorSink`] that copies whatever the plugin reports, and returns
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

/// A resolved parameter list in C form: one entry per table row, in table order, the
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
    /// Builds the list. `list` should already have passed [`obscura_sdk::Params::resolve`] against
    /// `table` (names, types, lengths and ranges are not checked again here).
    ///
    /// # Errors
    /// [`AbiError::NulByte`] when a string holds a NUL byte.
    pub fn new(table: &[ParamDecl], list: &ParamList) -> Result<Self, AbiError> {
        let mut keep = Keep::default();
        let mut params = Vec::with_capacity(table.len());
        for d in table {
            let given = list.get(&d.name);
            let value = given.map_or(&d.default, |e| &e.value);
            let what = format!("parameter \"{}\"", d.name);
            let v = keep.value(value, &what)?;
            let origin = match given.and_then(|e| e.origin.as_deref()) {
                Some(o) => keep.cstr(o, &what)?,
                None => std::ptr::null(),
            };
            params.push(RawParam {
                name: keep.cstr(&d.name, "parameter name")?,
                origin,
                floats: v.floats,
                ints: v.ints,
                strings: v.strings,
                count: v.count,
                ty: param_type_to_raw(d.ty),
                array_len: array_len_to_raw(d),
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

/// An environment in C form, owning its motion samples.
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
    /// [`AbiError::DeepMetricWritten`] when the plugin wrote an unknown value.
    pub fn deep_metric(&self) -> Result<DeepMetric, AbiError> {
        deep_metric_from_raw(self.raw.deep_metric).ok_or(AbiError::DeepMetricWritten {
            value: self.raw.deep_metric,
        })
    }
}
