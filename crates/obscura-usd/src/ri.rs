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
