//! What a stage's cameras are, as JSON (`obscura usd-cameras`): each camera's attributes (authored or
//! fallback), world transform and lens model at the Default time and at chosen time codes — the
//! values the tests compare with `usd-core`.

use serde_json::{Value, json};

use crate::values::Time;
use crate::{Stage, UsdError};

/// The JSON description of every camera of `stage` at Default and at each of `times`
/// (`None`: `startTimeCode`, `endTimeCode` and their midpoint when the stage has a range, else 0).
///
/// # Errors
/// A located [`UsdError`] of the first camera that cannot be read.
pub fn cameras_json(stage: &Stage, times: Option<&[f64]>) -> Result<Value, UsdError> {
    let times: Vec<f64> = match (times, stage.time_range) {
        (Some(t), _) => t.to_vec(),
        (None, Some((a, b))) => vec![a, (a + b) / 2.0, b],
        (None, None) => vec![0.0],
    };
    let mut cameras = Vec::new();
    for path in stage.cameras()? {
        let mut samples = Vec::new();
        for time in std::iter::once(Time::Default).chain(times.iter().map(|&t| Time::Code(t))) {
            let cam = stage.camera(&path, time)?;
            let mut attributes = serde_json::Map::new();
            for ((name, _), v) in crate::camera::SCALAR_ATTRIBUTES.iter().zip(cam.scalars()) {
                attributes.insert((*name).into(), json!(v));
            }
            attributes.insert("exposure:responsivity".into(), json!(cam.exposure_responsivity));
            attributes.insert("projection".into(), json!(cam.projection));
            attributes.insert("stereoRole".into(), json!(cam.stereo_role));
            attributes.insert(
                "clippingRange".into(),
                json!([cam.clipping_range.0, cam.clipping_range.1]),
            );
            attributes.insert("clippingPlanes".into(), json!(cam.clipping_planes));
            let lens = stage.lens(&path, time)?.map(|l| {
                json!({"schema": l.schema, "model": l.model, "params": l.params,
                       "polynomial": l.polynomial, "resolution": l.resolution})
            });
            samples.push(json!({
                "time": match time { Time::Default => json!("default"), Time::Code(t) => json!(t) },
                "attributes": attributes,
                "worldTransform": crate::xform::to_usd_rows(cam.camera_to_world).to_vec(),
                "lens": lens,
            }));
        }
        cameras.push(json!({"path": path, "samples": samples}));
    }
    Ok(json!({
        "file": stage.file,
        "upAxis": stage.up_axis,
        "metersPerUnit": stage.meters_per_unit,
        "timeCodesPerSecond": stage.time_codes_per_second,
        "timeRange": stage.time_range.map(|(a, b)| vec![a, b]),
        "renderSettings": stage.render_settings(),
        "warnings": stage.composition_warnings(),
        "cameras": cameras,
    }))
}
