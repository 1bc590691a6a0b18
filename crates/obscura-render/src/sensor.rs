//! The sensor stage: after the film resolves, the scene's sensor ([`Scene::sensor`]) exposes its
//! beauty, reads the raw mosaic with noise, and its ISP makes the processed beauty every display then
//! writes (`obscura_sensor` has the formulas). Without a sensor nothing here runs and every output is
//! the film's, bit for bit.
//!
//! What a frame's sensor gives: the film's Ci replaced by the ISP's linear sRGB, the `raw` and
//! `electrons` planes ([`obscura_image::film::Film::set_sensor`]), the DNG of a `dng` display
//! ([`dng_bytes`]), and the `sensor` record of the camera JSON ([`record`]).
//!
//! The f-number is the description's `f_number`, else the projection's `FStop` property, else
//! [`obscura_sensor::config::DEFAULT_F_NUMBER`]. With `cos4`, each pixel's chief ray (through the
//! pixel centre, the lens centre, at shutter open) gives `cos θ = d_z` of its camera-space direction.

use std::time::Instant;

use obscura_host::Batch;
use obscura_host::contract::Properties;
use obscura_image::film::SensorPlanes;
use obscura_scene::Scene;
use obscura_sdk::{Point2, Rgb};
use obscura_sensor::dng::{DngError, DngInfo};
use obscura_sensor::isp::{Processed, as_shot_neutral, process};
use obscura_sensor::{Sensor, SensorConfig, SensorFrame, color};
use rayon::prelude::*;
use serde_json::{Value, json};

use crate::render::{Prepared, RenderOutput};

/// A frame's sensor stage: the sensor, what it read, what its ISP made, and its cost.
#[derive(Debug, Clone)]
pub struct SensorOutput {
    /// The sensor with its f-number resolved.
    pub sensor: Sensor,
    /// The raw mosaic, the expected electrons and the noise-free DN.
    pub frame: SensorFrame,
    /// The ISP's result of the noisy mosaic.
    pub processed: Processed,
    /// Seconds the stage took (exposure, noise and ISP; not the files).
    pub seconds: f64,
}

/// The sensor of `config` with the projection's f-stop from `props`.
#[must_use]
pub fn sensor_for(config: &SensorConfig, props: &Properties) -> Sensor {
    Sensor::new(config.clone(), props.f_stop.map(f64::from))
}

/// The chief ray's `cos θ` of each crop pixel (row by row), through the prepared camera stage.
fn chief_cosines(prepared: &Prepared) -> Vec<f32> {
    let cam = prepared.stage().camera();
    let crop = cam.pixels();
    (crop.y0..crop.y1)
        .into_par_iter()
        .flat_map_iter(|y| {
            let mut batch = Batch::with_capacity(crop.width() as usize);
            for x in crop.x0..crop.x1 {
                batch.push(
                    cam.raster_to_screen(f64::from(x) + 0.5, f64::from(y) + 0.5),
                    Point2::new(0.5, 0.5),
                    0.0,
                );
                batch.aperture.push(Point2::ZERO);
            }
            prepared.stage().run_prepared(&mut batch);
            batch.rays.into_iter().map(|r| r.direction.z.max(0.0))
        })
        .collect()
}

/// Runs the scene's sensor on the rendered film when it has one: `frame` keys the noise (the frame
/// number; 0 for a still). The film then reports the processed beauty and the sensor planes.
pub fn expose(scene: &Scene, prepared: &Prepared, out: &mut RenderOutput, frame: u64) {
    let Some(config) = &scene.sensor else {
        return;
    };
    let start = Instant::now();
    let sensor = sensor_for(config, prepared.stage().properties());
    let film = &out.film;
    let crop = film.crop();
    let rgb: Vec<[f32; 3]> = (crop.y0..crop.y1)
        .into_par_iter()
        .flat_map_iter(|y| {
            (crop.x0..crop.x1).map(move |x| {
                let c = film.pixel(x, y).ci;
                [c.r, c.g, c.b]
            })
        })
        .collect();
    let cosines = config.cos4.then(|| chief_cosines(prepared));
    let (width, _) = film.size();
    let read = sensor.capture(
        &rgb,
        crop.width(),
        crop.height(),
        (crop.x0, crop.y0),
        width,
        frame,
        cosines.as_deref(),
    );
    let processed = process(sensor.config(), sensor.response(), &read);
    out.film.set_sensor(SensorPlanes {
        ci: processed
            .linear
            .iter()
            .map(|p| Rgb::new(p[0], p[1], p[2]))
            .collect(),
        raw: read.raw.iter().map(|&c| f32::from(c)).collect(),
        electrons: read.electrons.clone(),
    });
    out.sensor = Some(SensorOutput {
        sensor,
        frame: read,
        processed,
        seconds: start.elapsed().as_secs_f64(),
    });
}

/// What a DNG of `sensor`'s frame `frame` holds beside the codes.
#[must_use]
pub fn dng_info(sensor: &Sensor, frame: &SensorFrame) -> DngInfo {
    let c = sensor.config();
    let cfa = c.cfa.at_origin(frame.origin.0, frame.origin.1);
    let linearization = c.companding.as_ref().map(|curve| {
        (0..=c.max_code() as u32)
            .map(|code| curve.expand(f64::from(code)).round().min(65_535.0) as u16)
            .collect()
    });
    DngInfo {
        cfa,
        black_level: c.black_level_dn as u32,
        white_level: c.linear_max_code() as u32,
        color_matrix: cfa.and_then(|_| color::dng_color_matrix(sensor.response())),
        as_shot_neutral: as_shot_neutral(sensor.response()),
        linearization,
        make: "Obscura".into(),
        model: "Obscura simulated sensor".into(),
    }
}

/// The DNG file of a frame's sensor stage.
///
/// # Errors
/// A [`DngError`] (an image too large for TIFF).
pub fn dng_bytes(s: &SensorOutput) -> Result<Vec<u8>, DngError> {
    obscura_sensor::dng::encode(
        &s.frame.raw,
        s.frame.width,
        s.frame.height,
        &dng_info(&s.sensor, &s.frame),
    )
}

/// The camera JSON's `sensor` record: the description with every key, and what follows from it for
/// this camera (the f-number used and its source, the system gain, photons and electrons per radiance
/// unit, the rolling shutter in the projection's terms).
#[must_use]
pub fn record(config: &SensorConfig, props: &Properties, lines: (u32, u32)) -> Value {
    let sensor = sensor_for(config, props);
    let (f, source) = sensor.f_number();
    let mut j = json!({
        "description": config.to_json(),
        "f_number": f,
        "f_number_source": source.name(),
        "system_gain_dn_per_e": config.system_gain_dn_per_e(),
        "photons_per_radiance": sensor.photons_per_radiance(),
        "dark_electrons": sensor.dark_electrons(),
        "white_level_dn": config.linear_max_code(),
        "as_shot_neutral": as_shot_neutral(sensor.response()),
        "response": sensor.response(),
    });
    if let Some(rs) = config.rolling_shutter {
        let n = match rs.order {
            obscura_sensor::config::ScanOrder::TopToBottom
            | obscura_sensor::config::ScanOrder::BottomToTop => lines.1,
            _ => lines.0,
        };
        j["rolling_shutter"] = json!({
            "order": rs.order.name(),
            "lines": n,
            "line_time_s": rs.line_time_s,
            "line_exposure_s": rs.line_exposure_s,
            "readout_s": rs.span_s(n),
            "sweep": rs.order.sweep(),
            "duration": rs.duration(n),
        });
    }
    j
}

/// The projections whose time samples take a rolling shutter (`sweep`, `duration`).
const ROLLING: [&str; 2] = ["PxrCamera", "PxrRollingShutter"];

/// The scene a sensor with a rolling shutter renders: its readout mapped onto the projection's time
/// samples. `PxrCamera` and `PxrRollingShutter` get `sweep` (the scan order) and `duration` (`line
/// exposure / readout`, [`obscura_sensor::config::RollingShutter::duration`]); `PxrPerspective` becomes
/// `PxrRollingShutter` over the same perspective camera (its `fov` and depth of field kept). The scene's
/// shutter interval stands for the readout: line `k` (of `n` in the scan direction) opens at
/// `(k + ½)·line_time` seconds and stays open `line_exposure` seconds. `None` without a rolling
/// shutter.
///
/// # Errors
/// A message naming the projection when it cannot take a rolling shutter.
pub fn rolling_shutter_scene(scene: &Scene) -> Result<Option<Scene>, String> {
    let Some(rs) = scene.sensor.as_ref().and_then(|s| s.rolling_shutter) else {
        return Ok(None);
    };
    let crop = scene.camera.format;
    let lines = match rs.order {
        obscura_sensor::config::ScanOrder::TopToBottom | obscura_sensor::config::ScanOrder::BottomToTop => {
            crop.height
        }
        _ => crop.width,
    };
    let mut s = scene.clone();
    if s.projection == "PxrPerspective" {
        s.projection = "PxrRollingShutter".into();
    } else if !ROLLING.contains(&s.projection.as_str()) {
        return Err(format!(
            "the sensor's rolling_shutter needs a projection with time samples by line (PxrPerspective, {}), not {}",
            ROLLING.join(", "),
            scene.projection
        ));
    }
    let origin = Some("the sensor's rolling_shutter".to_string());
    let p = &mut s.projection_params;
    p.remove("sweep");
    p.remove("duration");
    let error = |e: obscura_sdk::DeclarationError| e.to_string();
    p.push(
        "string sweep",
        obscura_sdk::ParamValue::Strings(vec![rs.order.sweep().to_string()]),
        origin.clone(),
    )
    .map_err(error)?;
    p.push(
        "float duration",
        obscura_sdk::ParamValue::Floats(vec![rs.duration(lines) as f32]),
        origin,
    )
    .map_err(error)?;
    Ok(Some(s))
}
