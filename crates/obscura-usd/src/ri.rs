//! RenderMan projections on USD cameras, as hdPrman attaches them.
//!
//! 1. Per camera (usdRiPxr `PxrCameraProjectionAPI`): `rel ri:projection = </Cam/Projection>`, or the
//!    older connection `outputs:ri:projection.connect = </Cam/Projection.outputs:result>`. The
//!    projection prim's type (`PxrCylinderCamera`, `PxrSphereCamera`, `PxrPanini`, `PxrCamera`,
//!    `OmnidirectionalStereo`, …; or its `ri:projection:shaderId`) names the projection — a built-in
//!    or a plugin on the plugin path — and its `inputs:ri:<param>` attributes are the parameters.
//! 2. Else, for the render's camera, the RenderSettings' `ri:projection:name` with its
//!    `ri:projection:<Name>:<param>` attributes.
//!
//! `PxrPerspective` (or no projection) keeps the camera's own perspective or orthographic mapping.
//!
//! [`RiCamera`] holds the camera-level attributes hdPrman reads besides the projection: the
//! `ri:*` shutter and aperture attributes and Hydra's `lensDistortion:*`, which hdPrman gives to
//! PxrCamera's distortion.

use obscura_host::CameraDesc;
use obscura_host::aperture::ApertureWarp;
use obscura_host::shutter::ShutterWarp;
use obscura_sdk::{ParamList, ParamValue};
use openusd::sdf;

use crate::values::{Time, Values, scalar, text};
use crate::{Stage, UsdError};

/// A RenderMan projection named by the stage, with its parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct RiProjection {
    /// The projection's name.
    pub name: String,
    /// Its parameters, each with the attribute it came from.
    pub params: ParamList,
    /// Where it was found (the projection prim, or the RenderSettings prim).
    pub source: String,
}

/// The RenderMan projection of camera `camera` at `time`, if the stage gives one.
///
/// # Errors
/// A located [`UsdError`]: a target that is not a prim, a parameter of an unusable type.
pub fn projection(stage: &Stage, camera: &str, time: Time) -> Result<Option<RiProjection>, UsdError> {
    let values = stage.values();
    let target = values
        .targets(camera, "ri:projection")
        .into_iter()
        .next()
        .or_else(|| {
            values
                .connections(camera, "outputs:ri:projection")
                .into_iter()
                .next()
                .map(|c| c.split('.').next().unwrap_or_default().to_string())
        });
    if let Some(prim) = target {
        let ty = stage
            .stage
            .prim(prim.as_str())
            .type_name()
            .ok()
            .flatten()
            .map(|t| t.as_str().to_string())
            .filter(|t| !t.is_empty());
        let shader = values.token_opt(&prim, "ri:projection:shaderId", time)?;
        let Some(name) = shader.or(ty) else {
            return Err(UsdError::at(
                &stage.file,
                camera,
                format!(
                    "ri:projection targets <{prim}>, which has no type or ri:projection:shaderId naming a projection"
                ),
            ));
        };
        let params = params_with_prefix(stage, &values, &prim, "inputs:ri:", time)?;
        return Ok(Some(RiProjection {
            name,
            params,
            source: prim,
        }));
    }
    let Some(settings) = stage.render_settings() else {
        return Ok(None);
    };
    let Some(name) = values.token_opt(&settings, "ri:projection:name", time)? else {
        return Ok(None);
    };
    let params = params_with_prefix(stage, &values, &settings, &format!("ri:projection:{name}:"), time)?;
    Ok(Some(RiProjection {
        name,
        params,
        source: settings,
    }))
}

fn params_with_prefix(
    stage: &Stage,
    values: &Values<'_>,
    prim: &str,
    prefix: &str,
    time: Time,
) -> Result<ParamList, UsdError> {
    let mut list = ParamList::new();
    let names = stage.stage.prim(prim).property_names().unwrap_or_default();
    for property in names {
        let property = property.as_str();
        let Some(param) = property.strip_prefix(prefix) else {
            continue;
        };
        let Some(value) = values.raw(prim, property, time)? else {
            continue;
        };
        let (decl, v) = match &value {
            sdf::Value::Int(i) => (format!("int {param}"), ParamValue::Ints(vec![*i])),
            sdf::Value::Bool(b) => (format!("int {param}"), ParamValue::Ints(vec![i32::from(*b)])),
            v if scalar(v).is_some() => (
                format!("float {param}"),
                ParamValue::Floats(vec![scalar(v).unwrap_or_default() as f32]),
            ),
            v if text(v).is_some() => (
                format!("string {param}"),
                ParamValue::Strings(vec![text(v).unwrap_or_default()]),
            ),
            v => match crate::values::tuple(v) {
                Some(t) => (
                    format!("float[{}] {param}", t.len()),
                    ParamValue::Floats(t.iter().map(|&x| x as f32).collect()),
                ),
                None => {
                    return Err(values.error(
                        prim,
                        property,
                        format!(
                            "expected a number, string or tuple for a projection parameter, found {}",
                            crate::values::describe(v)
                        ),
                    ));
                }
            },
        };
        list.push(&decl, v, Some(format!("{}: <{prim}>.{property}", stage.file)))
            .map_err(|e| values.error(prim, property, e.to_string()))?;
    }
    Ok(list)
}

/// The camera-level RenderMan attributes hdPrman reads (`hdPrman/camera.cpp`) and Hydra's lens
/// distortion (`HdCameraTokens` `lensDistortion:*`), each `None` when not authored.
///
/// | attribute | Obscura |
/// |---|---|
/// | `float ri:shutterOpenTime`, `float ri:shutterCloseTime` | the shutter opening's `shutterOpenTime`, `shutterCloseTime` |
/// | `float[] ri:shutteropening` (8 values `c1 c2 d1 d2 e1 e2 f1 f2`) | `shutteropening` |
/// | `int ri:apertureNSides`, `float ri:apertureAngle`, `ri:apertureRoundness`, `ri:apertureDensity` | the host's aperture shape |
/// | `lensDistortion:k1`, `k2`, `anaSq`, `asym` (float2) | PxrCamera `radial1`, `radial2`, `squeeze`, `assymX`/`assymY` |
/// | `lensDistortion:center` (float2), `lensDistortion:scale` | no PxrCamera counterpart: warned about unless (0, 0) and 1 |
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RiCamera {
    /// `ri:shutterOpenTime`.
    pub shutter_open_time: Option<f64>,
    /// `ri:shutterCloseTime`.
    pub shutter_close_time: Option<f64>,
    /// `ri:shutteropening`.
    pub shutter_opening: Option<[f64; 8]>,
    /// `ri:apertureNSides`.
    pub aperture_n_sides: Option<i32>,
    /// `ri:apertureAngle` (degrees).
    pub aperture_angle: Option<f64>,
    /// `ri:apertureRoundness`.
    pub aperture_roundness: Option<f64>,
    /// `ri:apertureDensity`.
    pub aperture_density: Option<f64>,
    /// Hydra's lens distortion, when any of its attributes is authored.
    pub lens_distortion: Option<LensDistortion>,
}

/// Hydra's `lensDistortion:*` camera attributes with their `HdCamera` fallbacks.
#[derive(Debug, Clone, PartialEq)]
pub struct LensDistortion {
    /// `lensDistortion:k1` (0).
    pub k1: f64,
    /// `lensDistortion:k2` (0).
    pub k2: f64,
    /// `lensDistortion:center` ((0, 0)).
    pub center: [f64; 2],
    /// `lensDistortion:anaSq` (1).
    pub ana_sq: f64,
    /// `lensDistortion:asym` ((0, 0)).
    pub asym: [f64; 2],
    /// `lensDistortion:scale` (1).
    pub scale: f64,
}

impl RiCamera {
    /// Reads the attributes of camera `camera` at `time`.
    ///
    /// # Errors
    /// A located [`UsdError`] naming the attribute: a value of the wrong type or length, a
    /// non-integer `ri:apertureNSides`.
    pub fn read(stage: &Stage, camera: &str, time: Time) -> Result<Self, UsdError> {
        let values = stage.values();
        let real = |name: &str| values.real_opt(camera, name, time);
        let pair = |name: &str| -> Result<Option<[f64; 2]>, UsdError> {
            Ok(values.reals_opt(camera, name, time, 2)?.map(|v| [v[0], v[1]]))
        };
        let shutter_opening = values
            .reals_opt(camera, "ri:shutteropening", time, 8)?
            .map(|v| std::array::from_fn(|i| v[i]));
        let aperture_n_sides = match real("ri:apertureNSides")? {
            None => None,
            Some(n) if n.fract() == 0.0 && n.abs() <= f64::from(i32::MAX) => Some(n as i32),
            Some(n) => {
                return Err(values.error(
                    camera,
                    "ri:apertureNSides",
                    format!("expected a whole number of aperture blades, found {n}"),
                ));
            }
        };
        let k1 = real("lensDistortion:k1")?;
        let k2 = real("lensDistortion:k2")?;
        let center = pair("lensDistortion:center")?;
        let ana_sq = real("lensDistortion:anaSq")?;
        let asym = pair("lensDistortion:asym")?;
        let scale = real("lensDistortion:scale")?;
        let any = k1.is_some()
            || k2.is_some()
            || center.is_some()
            || ana_sq.is_some()
            || asym.is_some()
            || scale.is_some();
        Ok(RiCamera {
            shutter_open_time: real("ri:shutterOpenTime")?,
            shutter_close_time: real("ri:shutterCloseTime")?,
            shutter_opening,
            aperture_n_sides,
            aperture_angle: real("ri:apertureAngle")?,
            aperture_roundness: real("ri:apertureRoundness")?,
            aperture_density: real("ri:apertureDensity")?,
            lens_distortion: any.then(|| LensDistortion {
                k1: k1.unwrap_or(0.0),
                k2: k2.unwrap_or(0.0),
                center: center.unwrap_or([0.0, 0.0]),
                ana_sq: ana_sq.unwrap_or(1.0),
                asym: asym.unwrap_or([0.0, 0.0]),
                scale: scale.unwrap_or(1.0),
            }),
        })
    }

    /// Writes the shutter and aperture attributes into `camera` and checks them.
    ///
    /// # Errors
    /// A located [`UsdError`] naming the camera when a value is out of the host's range (the
    /// message names the RenderMan parameter).
    pub fn apply(&self, stage: &Stage, prim: &str, camera: &mut CameraDesc) -> Result<(), UsdError> {
        let set = |field: &mut f32, v: Option<f64>| {
            if let Some(v) = v {
                *field = v as f32;
            }
        };
        set(&mut camera.shutter_opening.open_time, self.shutter_open_time);
        set(&mut camera.shutter_opening.close_time, self.shutter_close_time);
        if let Some(o) = self.shutter_opening {
            camera.shutter_opening.opening = o.map(|v| v as f32);
        }
        if let Some(n) = self.aperture_n_sides {
            camera.aperture.n_sides = n;
        }
        set(&mut camera.aperture.angle_deg, self.aperture_angle);
        set(&mut camera.aperture.roundness, self.aperture_roundness);
        set(&mut camera.aperture.density, self.aperture_density);
        let located = |e: String| UsdError::at(&stage.file, prim, format!("ri:* camera attributes: {e}"));
        ApertureWarp::new(&camera.aperture).map_err(|e| located(e.to_string()))?;
        ShutterWarp::new(&camera.shutter_opening).map_err(|e| located(e.to_string()))?;
        Ok(())
    }
}

impl LensDistortion {
    /// PxrCamera's distortion parameters, each with the attribute it came from, and a warning for
    /// each authored value PxrCamera cannot express (`center` off the axis, `scale` ≠ 1).
    #[must_use]
    pub fn pxrcamera_params(
        &self,
        file: &str,
        prim: &str,
    ) -> (Vec<(&'static str, f32, &'static str)>, Vec<String>) {
        let params = vec![
            ("float radial1", self.k1 as f32, "lensDistortion:k1"),
            ("float radial2", self.k2 as f32, "lensDistortion:k2"),
            ("float squeeze", self.ana_sq as f32, "lensDistortion:anaSq"),
            ("float assymX", self.asym[0] as f32, "lensDistortion:asym"),
            ("float assymY", self.asym[1] as f32, "lensDistortion:asym"),
        ];
        let mut warnings = Vec::new();
        if self.center != [0.0, 0.0] {
            warnings.push(format!(
                "{file}: <{prim}>.lensDistortion:center = ({}, {}) is not applied: PxrCamera's distortion is \
                 centred on the optical axis (k1, k2, anaSq and asym are)",
                self.center[0], self.center[1]
            ));
        }
        if self.scale != 1.0 {
            warnings.push(format!(
                "{file}: <{prim}>.lensDistortion:scale = {} is not applied: PxrCamera has no distortion scale \
                 (k1, k2, anaSq and asym are)",
                self.scale
            ));
        }
        (params, warnings)
    }
}
