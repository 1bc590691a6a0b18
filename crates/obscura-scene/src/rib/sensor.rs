//! `Option "sensor"`: the image sensor after the lens, with the keys of a sensor description
//! (`obscura_sensor::config::KEYS`) as typed parameters.
//!
//! ```text
//! Option "sensor" "string description" ["sensor.json"] "float iso" [800] "string cfa" ["RGGB"]
//!        "float[9] camera_response" [...] "string isp.demosaic" ["bilinear"]
//!        "string rolling_shutter.order" ["top_to_bottom"] "float rolling_shutter.line_time_s" [1e-5]
//!        "float rolling_shutter.line_exposure_s" [0.004]
//! ```
//!
//! `description` reads a JSON description (relative to the scene's directory) first; every other
//! parameter sets its key over it (a later `Option "sensor"` over an earlier one). One value is a
//! number or a string; nine floats are a 3×3 matrix (`camera_response`, `isp.ccm`); three floats are
//! `isp.white_balance` gains; `companding` is flat `linear stored` pairs; `cos4` is an int, 0 or 1.

use obscura_sdk::ParamValue;
use obscura_sensor::SensorConfig;
use serde_json::{Value as Json, json};

use super::lex::Value;
use super::request::Req;
use super::{Reader, RibError};

/// A parameter's values as the JSON value of its key.
fn to_json(key: &str, value: &ParamValue) -> Json {
    let number = |x: f64| {
        if x.fract() == 0.0 && x.abs() < 9.0e15 {
            json!(x as i64)
        } else {
            json!(x)
        }
    };
    match value {
        ParamValue::Floats(v) if v.len() == 9 => {
            json!([0, 1, 2].map(|r| [0, 1, 2].map(|c| f64::from(v[3 * r + c]))))
        }
        ParamValue::Floats(v) if key == "companding" => {
            json!(
                v.chunks(2)
                    .map(|p| p.iter().map(|&x| f64::from(x)).collect::<Vec<_>>())
                    .collect::<Vec<_>>()
            )
        }
        ParamValue::Floats(v) if v.len() == 1 && key == "cos4" => json!(v[0] != 0.0),
        ParamValue::Ints(v) if v.len() == 1 && key == "cos4" => json!(v[0] != 0),
        ParamValue::Floats(v) if v.len() == 1 => number(f64::from(v[0])),
        ParamValue::Floats(v) => json!(v.iter().map(|&x| f64::from(x)).collect::<Vec<_>>()),
        ParamValue::Ints(v) if v.len() == 1 => json!(v[0]),
        ParamValue::Ints(v) => json!(v),
        ParamValue::Strings(v) if v.len() == 1 => json!(v[0]),
        ParamValue::Strings(v) => json!(v),
    }
}

impl Reader {
    /// `Option "sensor" …` (see the module documentation).
    pub(super) fn sensor(&mut self, r: &Req<'_>, rest: &[Value]) -> Result<(), RibError> {
        let list = self.params(r, rest, &[], true)?;
        let mut config = self.scene.sensor.clone().unwrap_or_default();
        let mut entries = Vec::new();
        for e in list.entries() {
            if e.name == "description" {
                let ParamValue::Strings(v) = &e.value else {
                    return Err(r.err("Option \"sensor\": \"description\" must be a string (a JSON file)"));
                };
                let path = r.resolve(v.first().map_or("", String::as_str));
                let text = std::fs::read_to_string(&path).map_err(|err| {
                    r.err(format!(
                        "Option \"sensor\": cannot read {}: {err}",
                        path.display()
                    ))
                })?;
                config = SensorConfig::from_json(&text, &path.display().to_string())
                    .map_err(|err| r.err(format!("Option \"sensor\": {err}")))?;
            } else {
                entries.push((e.name.clone(), to_json(&e.name, &e.value)));
            }
        }
        config
            .set_all(&entries)
            .map_err(|err| r.err(format!("Option \"sensor\": {err}")))?;
        self.scene.sensor = Some(config);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use obscura_sensor::Cfa;
    use obscura_sensor::config::ScanOrder;

    use crate::DisplayDriver;
    use crate::rib::parse_str;

    #[test]
    fn option_sensor_sets_keys_over_a_description() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("s.json"), r#"{"iso": 400, "bit_depth": 14}"#).unwrap();
        let rib = "Option \"sensor\" \"string description\" [\"s.json\"] \"float iso\" [800] \
                   \"string cfa\" [\"BGGR\"] \"int black_level_dn\" [256] \
                   \"float[9] camera_response\" [0.5 0.1 0 0.1 0.6 0.1 0 0.1 0.4] \
                   \"string rolling_shutter.order\" [\"right_to_left\"] \
                   \"float rolling_shutter.line_time_s\" [0.00002] \"float rolling_shutter.line_exposure_s\" [0.001]\n\
                   Display \"raw.dng\" \"dng\" \"rgb\"\nWorldBegin\nWorldEnd\n";
        let scene = parse_str(rib, "t.rib", dir.path()).unwrap();
        let s = scene.sensor.expect("a sensor");
        assert_eq!(
            (s.iso, s.bit_depth, s.black_level_dn, s.cfa),
            (800.0, 14, 256.0, Cfa::Bggr)
        );
        assert_eq!(s.rolling_shutter.unwrap().order, ScanOrder::RightToLeft);
        assert_eq!(s.response_matrix()[1][1], f64::from(0.6f32));
        assert_eq!(scene.displays[0].driver, DisplayDriver::Dng);
    }

    #[test]
    fn option_sensor_errors_name_the_line_and_key() {
        let e = parse_str(
            "\nOption \"sensor\" \"float iso\" [-3]\n",
            "t.rib",
            Path::new("."),
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.rib:2: Option \"sensor\": \"iso\": expected a number > 0, got -3"
        );
        let e = parse_str(
            "Option \"sensor\" \"string description\" [\"missing.json\"]\n",
            "t.rib",
            Path::new("/nowhere"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("cannot read /nowhere/missing.json"), "{e}");
    }
}
