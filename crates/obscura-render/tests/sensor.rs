//! The sensor stage through the real frame pipeline ([`render_frame`]): an emissive wall filling the
//! frame rendered at 12 exposure times and in the dark, characterised by the EMVA 1288 photon-transfer
//! method; a sensor's files (EXR planes, DNG, camera JSON); and the outputs without a sensor.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use obscura_plugins::builtin_registry;
use obscura_render::frame::Neighbours;
use obscura_render::pipeline::{
    FrameError, FrameJob, FrameResult, FrameWrite, Message, Reporter, Sidecars, render_frame,
};
use obscura_render::render::RenderOptions;
use obscura_scene::rib::parse_str;
use obscura_scene::{Aov, Display, DisplayDriver, Scene};
use obscura_sensor::emva::{Level, linear_fit, pair_statistics, photon_transfer};
use obscura_sensor::{Cfa, SensorConfig};

struct Quiet(AtomicBool);

impl Reporter for Quiet {
    fn message(&self, _: Message, _: &str) {}
    fn cancel(&self) -> &AtomicBool {
        &self.0
    }
}

const SIZE: u32 = 128;

/// A wall of `PxrConstant` radiance `level` filling a 128×128 frame, one sample per pixel (a light
/// of intensity 0 keeps the renderer from adding its default ones).
fn wall(level: f32) -> Scene {
    let rib = format!(
        "Format {SIZE} {SIZE} 1\nHider \"raytrace\" \"int maxsamples\" [1]\n\
         Projection \"PxrPerspective\" \"float fov\" [30]\nWorldBegin\n\
         Light \"PxrDistantLight\" \"key\" \"float intensity\" [0]\n\
         Bxdf \"PxrConstant\" \"wall\" \"color emitColor\" [{level} {level} {level}]\n\
         Translate 0 0 5\nPolygon \"P\" [-10 10 0  10 10 0  10 -10 0  -10 -10 0]\nWorldEnd\n"
    );
    parse_str(&rib, "wall.rib", Path::new(".")).expect("reads")
}

fn render(scene: &Scene, writes: &[FrameWrite<'_>]) -> FrameResult {
    try_render(scene, writes).expect("renders")
}

fn try_render(scene: &Scene, writes: &[FrameWrite<'_>]) -> Result<FrameResult, FrameError> {
    let job = FrameJob {
        scene,
        base_dir: Path::new("."),
        writes,
        also: &[],
        neighbours: Neighbours {
            previous: None,
            next: None,
        },
        options: &RenderOptions::default(),
        header_frame: None,
        sidecars: Sidecars::WithGroundTruth,
        size_source: "test",
    };
    render_frame(&job, &mut builtin_registry(), &Quiet(AtomicBool::new(false)))
}

/// The raw codes of `scene` read by `config` with `seed`, through the pipeline, as EMVA's pair of
/// frames: the left and the right half of the frame (the model has no fixed-pattern noise, and every
/// pixel's noise is independent, so two halves are two frames of 64×128 pixels; one render instead of
/// two keeps the test short).
fn pair(scene: &Scene, config: &SensorConfig, seed: u64) -> (f64, f64) {
    let codes = raw(scene, config, seed);
    let half = (SIZE / 2) as usize;
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for row in codes.chunks(SIZE as usize) {
        a.extend_from_slice(&row[..half]);
        b.extend_from_slice(&row[half..]);
    }
    pair_statistics(&a, &b)
}

/// The raw codes of `scene` read by `config` with `seed`, through the pipeline.
fn raw(scene: &Scene, config: &SensorConfig, seed: u64) -> Vec<f64> {
    let mut scene = scene.clone();
    scene.sensor = Some(SensorConfig {
        seed,
        ..config.clone()
    });
    let out = render(&scene, &[]).output;
    let sensor = out.sensor.expect("the sensor ran");
    sensor.frame.raw.iter().map(|&c| f64::from(c)).collect()
}

fn sensor_config() -> SensorConfig {
    SensorConfig {
        iso: 200.0,
        gain_e_per_dn: 2.0,
        read_noise_e: 4.0,
        dark_current_e_per_s: 200.0,
        full_well_e: 8_000.0,
        black_level_dn: 128.0,
        bit_depth: 14,
        f_number: Some(4.0),
        cfa: Cfa::Rggb,
        ..SensorConfig::default()
    }
}

/// EMVA 1288 through the renderer: 12 exposure times from 1 % to 150 % of the full well, a flat field
/// and a dark frame at each; system gain within 2 %, read noise and dark current within
/// 5 %, saturation at the full well.
#[test]
fn emva1288_through_the_frame_pipeline() {
    let light = wall(0.25);
    let dark = wall(0.0);
    let base = sensor_config();
    let k_true = base.system_gain_dn_per_e();
    let electrons_per_second = {
        let out = {
            let mut s = light.clone();
            s.sensor = Some(SensorConfig {
                exposure_time_s: 1.0,
                ..base.clone()
            });
            render(&s, &[]).output
        };
        let e = f64::from(out.sensor.expect("sensor").frame.electrons[0]);
        // The film is the wall's radiance exactly, in every pixel.
        let c = out.film.crop();
        assert_eq!(c.len(), (SIZE * SIZE) as usize);
        e
    };
    let mut levels = Vec::new();
    let mut dark_points = Vec::new();
    let fractions = [0.01, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.85, 1.1, 1.5];
    for (i, f) in fractions.iter().enumerate() {
        let t = f * base.full_well_e / electrons_per_second;
        let config = SensorConfig {
            exposure_time_s: t,
            ..base.clone()
        };
        let s = 1000 + 2 * i as u64;
        let (mean, variance) = pair(&light, &config, s);
        let (dark_mean, dark_variance) = pair(&dark, &config, s + 1);
        levels.push(Level {
            mean,
            variance,
            dark_mean,
            dark_variance,
        });
        dark_points.push((t, dark_mean));
    }
    let ptc = photon_transfer(&levels);
    assert!(
        (ptc.gain_dn_per_e / k_true - 1.0).abs() < 0.02,
        "K {} vs {k_true}",
        ptc.gain_dn_per_e
    );
    let (slope, _) = linear_fit(&dark_points);
    let dark_current = slope / ptc.gain_dn_per_e;
    assert!(
        (dark_current / base.dark_current_e_per_s - 1.0).abs() < 0.05,
        "dark current {dark_current}"
    );
    // The shortest exposure's dark noise, less its dark electrons' own shot noise.
    let dark_e = (levels[0].dark_mean - base.black_level_dn) / ptc.gain_dn_per_e;
    let read_noise = (ptc.read_noise_e.powi(2) - dark_e).sqrt();
    assert!(
        (read_noise / base.read_noise_e - 1.0).abs() < 0.05,
        "read noise {read_noise}"
    );
    // Saturation: the last level's mean, less its dark electrons (which fill the same well).
    let last = levels.last().expect("levels");
    let sat_dark_e = (dark_points.last().expect("dark").1 - base.black_level_dn) / ptc.gain_dn_per_e;
    let sat = (last.mean - base.black_level_dn) / ptc.gain_dn_per_e;
    assert!(
        (sat / base.full_well_e - 1.0).abs() < 0.02,
        "saturation {sat} e (dark {sat_dark_e})"
    );
    assert!(last.variance < 0.25 * levels[ptc.saturation_level].variance);
    eprintln!(
        "pipeline EMVA: K {:.5} (true {k_true}), read noise {read_noise:.3} e, dark current {dark_current:.2} e/s, saturation {sat:.0} e",
        ptc.gain_dn_per_e
    );
}

/// A sensor's files: the EXR's `raw` channel holds the DNG's codes and the processed beauty; the
/// camera JSON records the sensor.
#[test]
fn sensor_files_agree() {
    let dir = tempfile::tempdir().unwrap();
    let mut scene = wall(0.2);
    scene.camera.format.width = 16;
    scene.camera.format.height = 12;
    scene.sensor = Some(sensor_config());
    let exr = dir.path().join("s.exr");
    let dng = dir.path().join("s.dng");
    let mut displays = vec![Display {
        path: exr.clone(),
        driver: DisplayDriver::OpenExr,
        aovs: vec![Aov::Ci],
        half: true,
    }];
    obscura_render::job::sensor_displays(&mut displays, Some(&dng));
    let result = render(
        &scene,
        &[FrameWrite {
            number: None,
            displays: &displays,
        }],
    );
    let sensor = result.output.sensor.as_ref().expect("sensor");
    let image = exr::prelude::read_all_flat_layers_from_file(&exr).expect("reads");
    let layer = &image.layer_data[0];
    let channel = |name: &str| {
        let c = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .unwrap_or_else(|| panic!("channel {name}"));
        c.sample_data.values_as_f32().collect::<Vec<f32>>()
    };
    let raw = channel("raw");
    let codes: Vec<f32> = sensor.frame.raw.iter().map(|&c| f32::from(c)).collect();
    assert_eq!(raw, codes, "raw stays exact although the EXR is half");
    assert_eq!(channel("electrons"), sensor.frame.electrons);
    let dng_bytes = std::fs::read(&dng).unwrap();
    let strip = &dng_bytes[dng_bytes.len() - codes.len() * 2..];
    let dng_codes: Vec<f32> = strip
        .chunks(2)
        .map(|c| f32::from(u16::from_le_bytes([c[0], c[1]])))
        .collect();
    assert_eq!(dng_codes, codes);
    let camera: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("s.camera.json")).unwrap()).unwrap();
    assert_eq!(camera["sensor"]["description"]["cfa"], "RGGB");
    assert_eq!(camera["sensor"]["f_number"], 4.0);
    assert_eq!(camera["sensor"]["system_gain_dn_per_e"], 1.0);
}

/// Without a sensor the film is written as it is: no sensor planes, the beauty the film's, no sensor
/// record; the raw display is refused before any work.
#[test]
fn without_a_sensor_nothing_changes() {
    let dir = tempfile::tempdir().unwrap();
    let mut scene = wall(0.3);
    scene.camera.format.width = 8;
    scene.camera.format.height = 8;
    let exr = dir.path().join("n.exr");
    let displays = vec![Display {
        path: exr.clone(),
        driver: DisplayDriver::OpenExr,
        aovs: vec![Aov::Ci, Aov::Alpha, Aov::ObjectId],
        half: false,
    }];
    let result = render(
        &scene,
        &[FrameWrite {
            number: None,
            displays: &displays,
        }],
    );
    assert!(result.output.sensor.is_none());
    let v = result.output.film.pixel(3, 3);
    assert_eq!((v.ci.r, v.sensor.raw, v.sensor.electrons), (0.3, 0.0, 0.0));
    let camera: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("n.camera.json")).unwrap()).unwrap();
    assert!(camera.get("sensor").is_none());
    let bad = vec![Display {
        path: dir.path().join("x.dng"),
        driver: DisplayDriver::Dng,
        aovs: vec![Aov::Raw],
        half: false,
    }];
    let e = try_render(
        &scene,
        &[FrameWrite {
            number: None,
            displays: &bad,
        }],
    )
    .unwrap_err();
    assert!(e.to_string().contains("needs a sensor"), "{e}");
}

/// A rolling shutter in sensor terms reaches the projection's time samples: `PxrPerspective` renders
/// as `PxrRollingShutter` with the sweep of the scan order and `duration = line_exposure/readout`, and
/// the camera JSON says so; a projection without time samples by line is refused, named.
#[test]
fn rolling_shutter_maps_onto_the_projection() {
    let dir = tempfile::tempdir().unwrap();
    let mut scene = wall(0.2);
    scene.camera.format.width = 16;
    scene.camera.format.height = 10;
    let mut config = sensor_config();
    config
        .set_all(&[
            ("rolling_shutter.order".into(), serde_json::json!("bottom_to_top")),
            ("rolling_shutter.line_time_s".into(), serde_json::json!(0.001)),
            ("rolling_shutter.line_exposure_s".into(), serde_json::json!(0.002)),
        ])
        .unwrap();
    scene.sensor = Some(config);
    let displays = vec![Display {
        path: dir.path().join("r.exr"),
        driver: DisplayDriver::OpenExr,
        aovs: vec![Aov::Ci],
        half: false,
    }];
    let writes = [FrameWrite {
        number: None,
        displays: &displays,
    }];
    render(&scene, &writes);
    let camera: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("r.camera.json")).unwrap()).unwrap();
    assert_eq!(camera["projection"], "PxrRollingShutter");
    assert_eq!(camera["parameters"]["sweep"], serde_json::json!(["up"]));
    // 10 lines of 1 ms and a 2 ms exposure: a 12 ms readout, each line open 2/12 of it.
    let duration = camera["parameters"]["duration"][0].as_f64().unwrap();
    assert!((duration - 2.0 / 12.0).abs() < 1e-6, "{duration}");
    assert_eq!(camera["sensor"]["rolling_shutter"]["readout_s"], 0.012);
    scene.projection = "PxrOrthographic".into();
    let e = obscura_render::sensor::rolling_shutter_scene(&scene).unwrap_err();
    assert!(e.contains("not PxrOrthographic"), "{e}");
}
