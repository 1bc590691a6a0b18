//! Typed attribute values of a composed stage at a time, each failure located (file, prim,
//! attribute, what was expected).
//!
//! Values are read through `openusd`'s value resolution, with one correction: a `float`/`double`
//! attribute whose time samples are written as integer literals (`{ 0: -15, 1: -14.979 }`, common in
//! DCC exports) comes back from openusd 0.6 as integers that it holds instead of interpolating.
//! Such a value is interpolated here linearly between its bracketing samples, as `usd-core` does.

use openusd::{sdf, usd};

use crate::UsdError;

/// When a value is read: the attribute's default, or a time code (time samples win over the default,
/// interpolated linearly between the bracketing samples).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Time {
    /// The default value (`UsdTimeCode::Default()`).
    Default,
    /// A numeric time code.
    Code(f64),
}

impl Time {
    fn query(self) -> Option<usd::TimeCode> {
        match self {
            Time::Default => None,
            Time::Code(t) => Some(usd::TimeCode::new(t)),
        }
    }
}

/// Reads values of one stage, naming `file` in every error.
pub(crate) struct Values<'a> {
    pub stage: &'a usd::Stage,
    pub file: &'a str,
}

impl Values<'_> {
    /// An error about attribute `name` of prim `prim`.
    pub fn error(&self, prim: &str, name: &str, what: impl Into<String>) -> UsdError {
        UsdError::at(self.file, prim, format!("attribute '{name}': {}", what.into()))
    }

    /// The raw composed value of `prim.name` at `time` (`None` when nothing is authored).
    pub fn raw(&self, prim: &str, name: &str, time: Time) -> Result<Option<sdf::Value>, UsdError> {
        let attr = self.stage.attribute(format!("{prim}.{name}").as_str());
        let value = attr
            .get_at::<sdf::Value>(time.query())
            .map_err(|e| self.error(prim, name, format!("cannot be read: {e:#}")))?;
        let Time::Code(t) = time else {
            return Ok(value);
        };
        // Integer samples of a real-valued attribute: interpolate them (see the module doc).
        match &value {
            Some(sdf::Value::Int(_) | sdf::Value::Int64(_)) => {}
            _ => return Ok(value),
        }
        let declared = attr.type_name().ok().flatten();
        let real = declared.is_some_and(|t| matches!(t.as_str(), "float" | "double" | "half"));
        if !real {
            return Ok(value);
        }
        let Some((lo, hi)) = attr.bracketing_time_samples(t).ok().flatten() else {
            return Ok(value);
        };
        let at = |s: f64| {
            attr.get_at::<sdf::Value>(usd::TimeCode::new(s))
                .ok()
                .flatten()
                .as_ref()
                .and_then(scalar)
        };
        match (at(lo), at(hi)) {
            (Some(a), Some(b)) if hi > lo => Ok(Some(sdf::Value::Double(a + (b - a) * (t - lo) / (hi - lo)))),
            (Some(a), _) => Ok(Some(sdf::Value::Double(a))),
            _ => Ok(value),
        }
    }

    /// A real number, or `fallback` when nothing is authored; any other type is an error.
    pub fn real(&self, prim: &str, name: &str, time: Time, fallback: f64) -> Result<f64, UsdError> {
        Ok(self.real_opt(prim, name, time)?.unwrap_or(fallback))
    }

    /// A real number when authored; any other type is an error.
    pub fn real_opt(&self, prim: &str, name: &str, time: Time) -> Result<Option<f64>, UsdError> {
        match self.raw(prim, name, time)? {
            None => Ok(None),
            Some(v) => scalar(&v)
                .map(Some)
                .ok_or_else(|| self.error(prim, name, format!("expected a number, found {}", describe(&v)))),
        }
    }

    /// A tuple of `n` real numbers when authored (`float2`, `double3`, …).
    pub fn reals_opt(
        &self,
        prim: &str,
        name: &str,
        time: Time,
        n: usize,
    ) -> Result<Option<Vec<f64>>, UsdError> {
        match self.raw(prim, name, time)? {
            None => Ok(None),
            Some(v) => match tuple(&v) {
                Some(t) if t.len() == n => Ok(Some(t)),
                _ => Err(self.error(
                    prim,
                    name,
                    format!("expected {n} numbers, found {}", describe(&v)),
                )),
            },
        }
    }

    /// A token or string when authored.
    pub fn token_opt(&self, prim: &str, name: &str, time: Time) -> Result<Option<String>, UsdError> {
        match self.raw(prim, name, time)? {
            None => Ok(None),
            Some(v) => text(&v)
                .map(Some)
                .ok_or_else(|| self.error(prim, name, format!("expected a token, found {}", describe(&v)))),
        }
    }

    /// An array of real-number tuples (`float3[]`, `float4[]`, `point3f[]`, …), each of `n`.
    pub fn tuples_opt(
        &self,
        prim: &str,
        name: &str,
        time: Time,
        n: usize,
    ) -> Result<Option<Vec<Vec<f64>>>, UsdError> {
        match self.raw(prim, name, time)? {
            None => Ok(None),
            Some(v) => match tuples(&v) {
                Some(t) if t.iter().all(|x| x.len() == n) => Ok(Some(t)),
                _ => Err(self.error(
                    prim,
                    name,
                    format!("expected an array of {n}-tuples, found {}", describe(&v)),
                )),
            },
        }
    }

    /// An array of integers.
    pub fn ints_opt(&self, prim: &str, name: &str, time: Time) -> Result<Option<Vec<i64>>, UsdError> {
        match self.raw(prim, name, time)? {
            None => Ok(None),
            Some(sdf::Value::IntVec(v)) => Ok(Some(v.into_iter().map(i64::from).collect())),
            Some(sdf::Value::Int64Vec(v)) => Ok(Some(v)),
            Some(sdf::Value::UintVec(v)) => Ok(Some(v.into_iter().map(i64::from).collect())),
            Some(v) => Err(self.error(prim, name, format!("expected an int[], found {}", describe(&v)))),
        }
    }

    /// Whether `prim.name` has metadata `key` authored.
    pub fn states_metadata(&self, prim: &str, name: &str, key: &str) -> bool {
        self.stage
            .attribute(format!("{prim}.{name}").as_str())
            .get_metadata::<sdf::Value>(key)
            .ok()
            .flatten()
            .is_some()
    }

    /// A primvar's `interpolation` metadata (`constant` unless authored).
    pub fn interpolation(&self, prim: &str, name: &str) -> String {
        self.stage
            .attribute(format!("{prim}.{name}").as_str())
            .get_metadata::<sdf::Value>("interpolation")
            .ok()
            .flatten()
            .and_then(|v| text(&v))
            .unwrap_or_else(|| "constant".into())
    }

    /// The time codes at which `prim.name` has samples (empty when none).
    pub fn sample_times(&self, prim: &str, name: &str) -> Vec<f64> {
        self.stage
            .attribute(format!("{prim}.{name}").as_str())
            .time_sample_times()
            .unwrap_or_default()
    }

    /// The targets of relationship `prim.name`.
    pub fn targets(&self, prim: &str, name: &str) -> Vec<String> {
        self.stage
            .relationship(format!("{prim}.{name}").as_str())
            .targets()
            .unwrap_or_default()
            .iter()
            .map(|p| p.as_str().to_string())
            .collect()
    }

    /// The connection sources of attribute `prim.name`.
    pub fn connections(&self, prim: &str, name: &str) -> Vec<String> {
        self.stage
            .attribute(format!("{prim}.{name}").as_str())
            .connections()
            .unwrap_or_default()
            .iter()
            .map(|p| p.as_str().to_string())
            .collect()
    }
}

/// A real scalar of any numeric type.
pub(crate) fn scalar(v: &sdf::Value) -> Option<f64> {
    Some(match v {
        sdf::Value::Double(d) => *d,
        sdf::Value::Float(f) => f64::from(*f),
        sdf::Value::Half(h) => f64::from(h.to_f32()),
        sdf::Value::Int(i) => f64::from(*i),
        sdf::Value::Int64(i) => *i as f64,
        sdf::Value::Uint(i) => f64::from(*i),
        sdf::Value::Uchar(i) => f64::from(*i),
        _ => return None,
    })
}

/// A fixed-size tuple of reals (vectors, quaternions as `w x y z`, matrices row by row).
pub(crate) fn tuple(v: &sdf::Value) -> Option<Vec<f64>> {
    let f = |x: &[f32]| x.iter().map(|&v| f64::from(v)).collect::<Vec<_>>();
    Some(match v {
        sdf::Value::Vec2f(a) => f(&<[f32; 2]>::from(*a)),
        sdf::Value::Vec2d(a) => <[f64; 2]>::from(*a).to_vec(),
        sdf::Value::Vec2i(a) => <[i32; 2]>::from(*a).iter().map(|&v| f64::from(v)).collect(),
        sdf::Value::Vec2h(a) => vec![f64::from(a.x.to_f32()), f64::from(a.y.to_f32())],
        sdf::Value::Vec3f(a) => f(&<[f32; 3]>::from(*a)),
        sdf::Value::Vec3d(a) => <[f64; 3]>::from(*a).to_vec(),
        sdf::Value::Vec3i(a) => <[i32; 3]>::from(*a).iter().map(|&v| f64::from(v)).collect(),
        sdf::Value::Vec3h(a) => vec![
            f64::from(a.x.to_f32()),
            f64::from(a.y.to_f32()),
            f64::from(a.z.to_f32()),
        ],
        sdf::Value::Vec4f(a) => f(&<[f32; 4]>::from(*a)),
        sdf::Value::Vec4d(a) => <[f64; 4]>::from(*a).to_vec(),
        sdf::Value::Quatf(q) => vec![f64::from(q.w), f64::from(q.x), f64::from(q.y), f64::from(q.z)],
        sdf::Value::Quatd(q) => <[f64; 4]>::from(*q).to_vec(),
        sdf::Value::Quath(q) => vec![
            f64::from(q.w.to_f32()),
            f64::from(q.x.to_f32()),
            f64::from(q.y.to_f32()),
            f64::from(q.z.to_f32()),
        ],
        sdf::Value::Matrix4d(m) => m.0.to_vec(),
        sdf::Value::FloatVec(a) => f(a),
        sdf::Value::DoubleVec(a) => a.clone(),
        _ => return None,
    })
}

/// An array of tuples.
pub(crate) fn tuples(v: &sdf::Value) -> Option<Vec<Vec<f64>>> {
    let f = |x: &[f32]| x.iter().map(|&v| f64::from(v)).collect::<Vec<_>>();
    Some(match v {
        sdf::Value::Vec2fVec(a) => a.iter().map(|v| f(&<[f32; 2]>::from(*v))).collect(),
        sdf::Value::Vec2dVec(a) => a.iter().map(|v| <[f64; 2]>::from(*v).to_vec()).collect(),
        sdf::Value::Vec3fVec(a) => a.iter().map(|v| f(&<[f32; 3]>::from(*v))).collect(),
        sdf::Value::Vec3dVec(a) => a.iter().map(|v| <[f64; 3]>::from(*v).to_vec()).collect(),
        sdf::Value::Vec4fVec(a) => a.iter().map(|v| f(&<[f32; 4]>::from(*v))).collect(),
        sdf::Value::Vec4dVec(a) => a.iter().map(|v| <[f64; 4]>::from(*v).to_vec()).collect(),
        sdf::Value::QuatfVec(a) => a
            .iter()
            .map(|q| vec![f64::from(q.w), f64::from(q.x), f64::from(q.y), f64::from(q.z)])
            .collect(),
        sdf::Value::QuathVec(a) => a
            .iter()
            .map(|q| {
                vec![
                    f64::from(q.w.to_f32()),
                    f64::from(q.x.to_f32()),
                    f64::from(q.y.to_f32()),
                    f64::from(q.z.to_f32()),
                ]
            })
            .collect(),
        sdf::Value::FloatVec(a) => a.iter().map(|&x| vec![f64::from(x)]).collect(),
        sdf::Value::DoubleVec(a) => a.iter().map(|&x| vec![x]).collect(),
        _ => return None,
    })
}

/// A token, string or asset path as text.
pub(crate) fn text(v: &sdf::Value) -> Option<String> {
    match v {
        sdf::Value::Token(t) => Some(t.as_str().to_string()),
        sdf::Value::String(s) => Some(s.clone()),
        sdf::Value::AssetPath(a) => Some(a.authored_path.clone()),
        _ => None,
    }
}

/// What a value is, for messages (`a string "wide"`, `a float[]`).
pub(crate) fn describe(v: &sdf::Value) -> String {
    match v {
        sdf::Value::String(s) => format!("the string {s:?}"),
        sdf::Value::Token(t) => format!("the token {:?}", t.as_str()),
        sdf::Value::Bool(b) => format!("the bool {b}"),
        other => {
            let name = format!("{other:?}");
            let kind = name.split(['(', ' ', '{']).next().unwrap_or("value").to_string();
            format!("a value of type {kind}")
        }
    }
}
