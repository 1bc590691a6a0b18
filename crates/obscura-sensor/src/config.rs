//! The sensor description: one table of keys read from JSON (`--sensor FILE.json`), from
//! `--sensor-param KEY=VALUE` on the command line, from RIB's `Option "sensor"` and from Python's
//! keyword arguments, all through [`SensorConfig::set`].
//!
//! Every key, its type, default and meaning is in [`KEYS`]; an unknown key, a value of the wrong type
//! or out of its range is an error naming the key, what was expected and what was given.

use serde_json::Value;

use crate::cfa::Cfa;
use crate::color::{self, Mat3};

/// Why a sensor description was refused. The text names the source, the key and what was expected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{source_name}: {message}")]
pub struct ConfigError {
    /// The file (or `--sensor-param`, `Option "sensor"`, …) the description came from.
    pub source_name: String,
    /// What is wrong.
    pub message: String,
}

/// How a rolling shutter reads the sensor, in sensor terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RollingShutter {
    /// The direction lines are read in.
    pub order: ScanOrder,
    /// Seconds between the starts of two consecutive lines' exposures.
    pub line_time_s: f64,
    /// Seconds each line is exposed for.
    pub line_exposure_s: f64,
}

/// The order a rolling shutter reads lines (rows or columns) in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScanOrder {
    /// Top row first.
    TopToBottom,
    /// Bottom row first.
    BottomToTop,
    /// Left column first.
    LeftToRight,
    /// Right column first.
    RightToLeft,
}

impl ScanOrder {
    /// The spellings the description uses.
    pub const NAMES: [&'static str; 4] = ["top_to_bottom", "bottom_to_top", "left_to_right", "right_to_left"];

    /// Reads one of [`ScanOrder::NAMES`].
    #[must_use]
    pub fn parse(s: &str) -> Option<ScanOrder> {
        match s {
            "top_to_bottom" => Some(ScanOrder::TopToBottom),
            "bottom_to_top" => Some(ScanOrder::BottomToTop),
            "left_to_right" => Some(ScanOrder::LeftToRight),
            "right_to_left" => Some(ScanOrder::RightToLeft),
            _ => None,
        }
    }

    /// The name in [`ScanOrder::NAMES`].
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ScanOrder::TopToBottom => "top_to_bottom",
            ScanOrder::BottomToTop => "bottom_to_top",
            ScanOrder::LeftToRight => "left_to_right",
            ScanOrder::RightToLeft => "right_to_left",
        }
    }

    /// PxrCamera's / PxrRollingShutter's `sweep` for this order.
    #[must_use]
    pub fn sweep(self) -> &'static str {
        match self {
            ScanOrder::TopToBottom => "down",
            ScanOrder::BottomToTop => "up",
            ScanOrder::LeftToRight => "right",
            ScanOrder::RightToLeft => "left",
        }
    }
}

impl RollingShutter {
    /// The whole readout in seconds for `lines` lines: `lines·line_time + line_exposure` (the first line
    /// opens at 0, the last closes then).
    #[must_use]
    pub fn span_s(&self, lines: u32) -> f64 {
        f64::from(lines) * self.line_time_s + self.line_exposure_s
    }

    /// The projection's `duration` (the fraction of the shutter interval a line is exposed for):
    /// `line_exposure / span`. With the projection's mapping `τ' = p·(1 − duration) + τ·duration` and a
    /// line centre at `p = (k + ½)/lines`, line `k` opens at `(k + ½)·line_time` seconds.
    #[must_use]
    pub fn duration(&self, lines: u32) -> f64 {
        self.line_exposure_s / self.span_s(lines)
    }
}

/// Which demosaic the ISP runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Demosaic {
    /// Bilinear interpolation of each colour plane.
    Bilinear,
    /// Malvar–He–Cutler (2004): bilinear corrected by the Laplacian of the pixel's own channel.
    MalvarHeCutler,
}

/// The ISP's output curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Tone {
    /// The sRGB transfer function (IEC 61966-2-1).
    Srgb,
    /// `v^(1/γ)`.
    Gamma(f64),
    /// No curve.
    Linear,
}

/// White balance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WhiteBalance {
    /// The camera's neutral for the scene's white `(1, 1, 1)` (the DNG's AsShotNeutral).
    AsShot,
    /// Grey world: each channel's mean made equal to green's.
    GreyWorld,
    /// Given multipliers for R, G, B.
    Gains([f64; 3]),
    /// None.
    Off,
}

/// What the ISP does with the raw mosaic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IspConfig {
    /// The demosaic.
    pub demosaic: Demosaic,
    /// White balance.
    pub white_balance: WhiteBalance,
    /// The colour-correction matrix from white-balanced camera RGB to linear sRGB; `None` derives it
    /// from the camera response.
    pub ccm: Option<Mat3>,
    /// A linear gain before the tone curve (exposure compensation).
    pub gain: f64,
    /// The output curve.
    pub tone: Tone,
    /// Bits per channel of the processed image: 8 or 16.
    pub output_bits: u32,
}

impl Default for IspConfig {
    fn default() -> Self {
        IspConfig {
            demosaic: Demosaic::MalvarHeCutler,
            white_balance: WhiteBalance::AsShot,
            ccm: None,
            gain: 1.0,
            tone: Tone::Srgb,
            output_bits: 8,
        }
    }
}

/// A piecewise-linear companding curve: linear DN → stored DN through `knees` (pairs, both strictly
/// increasing, starting at (0, 0)).
#[derive(Debug, Clone, PartialEq)]
pub struct Companding {
    /// `(linear, stored)` points.
    pub knees: Vec<(f64, f64)>,
}

impl Companding {
    /// The stored code of a linear code (clamped to the last knee's input).
    #[must_use]
    pub fn compress(&self, linear: f64) -> f64 {
        interpolate(&self.knees, linear, false)
    }

    /// The linear code of a stored code (the exact inverse on the curve).
    #[must_use]
    pub fn expand(&self, stored: f64) -> f64 {
        interpolate(&self.knees, stored, true)
    }

    /// The largest linear code.
    #[must_use]
    pub fn linear_max(&self) -> f64 {
        self.knees.last().map_or(0.0, |k| k.0)
    }

    /// The largest stored code.
    #[must_use]
    pub fn stored_max(&self) -> f64 {
        self.knees.last().map_or(0.0, |k| k.1)
    }
}

fn interpolate(knees: &[(f64, f64)], v: f64, inverse: bool) -> f64 {
    let pick = |k: &(f64, f64)| if inverse { (k.1, k.0) } else { (k.0, k.1) };
    let last = knees.last().map(pick).unwrap_or((0.0, 0.0));
    if v >= last.0 {
        return last.1;
    }
    for w in knees.windows(2) {
        let (a, b) = (pick(&w[0]), pick(&w[1]));
        if v <= b.0 {
            return a.1 + (v - a.0) * (b.1 - a.1) / (b.0 - a.0);
        }
    }
    last.1
}

/// How the pixel's channels respond to linear RGB radiance.
#[derive(Debug, Clone, PartialEq)]
pub enum Response {
    /// One quantum efficiency for the three channels (each channel sees its own colour of the
    /// radiance): `M = QE·I`.
    QuantumEfficiency(f64),
    /// A 3×3 matrix: row `c` gives channel `c`'s electrons per photon for linear-sRGB R, G, B.
    Matrix(Mat3),
    /// A published camera (its XYZ→camera matrix, DNG's ColorMatrix under D65), scaled so that the
    /// strongest channel's response to white is `quantum_efficiency`.
    Camera {
        /// The preset's name.
        name: String,
        /// The peak quantum efficiency.
        quantum_efficiency: f64,
    },
}

/// A complete sensor description (see [`KEYS`] for every key).
#[derive(Debug, Clone, PartialEq)]
pub struct SensorConfig {
    /// Pixel pitch, micrometres (square pixels, 100 % fill factor).
    pub pixel_pitch_um: f64,
    /// ISO: the analogue gain is `iso / base_iso`.
    pub iso: f64,
    /// The ISO at which `gain_e_per_dn` holds.
    pub base_iso: f64,
    /// Exposure (integration) time, seconds.
    pub exposure_time_s: f64,
    /// The f-number; `None` takes the projection's `FStop` (or [`DEFAULT_F_NUMBER`] without one).
    pub f_number: Option<f64>,
    /// W·sr⁻¹·m⁻² per scene radiance unit (USD's `exposure:responsivity`): physical radiance is
    /// `responsivity · L`.
    pub responsivity: f64,
    /// The channels' response.
    pub response: Response,
    /// Electrons per DN at `base_iso` (the inverse of the system gain K).
    pub gain_e_per_dn: f64,
    /// Read noise, electrons RMS.
    pub read_noise_e: f64,
    /// Dark current, electrons per second.
    pub dark_current_e_per_s: f64,
    /// Full-well capacity, electrons.
    pub full_well_e: f64,
    /// Black level (offset), DN.
    pub black_level_dn: f64,
    /// Bits of the ADC.
    pub bit_depth: u32,
    /// The colour filter array.
    pub cfa: Cfa,
    /// Seed of the noise.
    pub seed: u64,
    /// Multiply the exposure by `cos⁴θ` of the pixel's chief ray (natural vignetting).
    pub cos4: bool,
    /// An optional companding curve after the ADC.
    pub companding: Option<Companding>,
    /// An optional rolling shutter.
    pub rolling_shutter: Option<RollingShutter>,
    /// The ISP.
    pub isp: IspConfig,
}

/// The f-number used when neither the description nor the projection gives one.
pub const DEFAULT_F_NUMBER: f64 = 4.0;

impl Default for SensorConfig {
    fn default() -> Self {
        SensorConfig {
            pixel_pitch_um: 3.45,
            iso: 100.0,
            base_iso: 100.0,
            exposure_time_s: 0.005,
            f_number: None,
            responsivity: 1.0,
            response: Response::QuantumEfficiency(0.6),
            gain_e_per_dn: 2.5,
            read_noise_e: 2.5,
            dark_current_e_per_s: 5.0,
            full_well_e: 10_000.0,
            black_level_dn: 64.0,
            bit_depth: 12,
            cfa: Cfa::Rggb,
            seed: 0,
            cos4: false,
            companding: None,
            rolling_shutter: None,
            isp: IspConfig::default(),
        }
    }
}

/// One key of the description: its name, type and meaning (the documentation and the CLI's help read
/// this table).
#[derive(Debug, Clone, Copy)]
pub struct KeyDoc {
    /// The key.
    pub name: &'static str,
    /// Its JSON type.
    pub kind: &'static str,
    /// Its default.
    pub default: &'static str,
    /// What it means.
    pub doc: &'static str,
}

const fn key(name: &'static str, kind: &'static str, default: &'static str, doc: &'static str) -> KeyDoc {
    KeyDoc {
        name,
        kind,
        default,
        doc,
    }
}

/// Every key of a sensor description.
pub const KEYS: [KeyDoc; 20] = [
    key(
        "pixel_pitch_um",
        "number > 0",
        "3.45",
        "pixel pitch in micrometres",
    ),
    key("iso", "number > 0", "100", "ISO; analogue gain iso/base_iso"),
    key(
        "base_iso",
        "number > 0",
        "100",
        "the ISO at which gain_e_per_dn holds",
    ),
    key(
        "exposure_time_s",
        "number > 0",
        "0.005",
        "integration time in seconds",
    ),
    key(
        "f_number",
        "number > 0",
        "the projection's fStop, else 4",
        "the aperture's f-number",
    ),
    key(
        "responsivity",
        "number > 0",
        "1",
        "W/(sr·m²) per scene radiance unit",
    ),
    key(
        "quantum_efficiency",
        "number in (0, 1]",
        "0.6",
        "electrons per photon, every channel",
    ),
    key(
        "camera_response",
        "3×3 array or preset name",
        "none",
        "channel electrons per photon for linear-sRGB R, G, B (rows R, G, B); a preset name (\"canon_eos_5d_mark_ii\") takes a published colour matrix scaled to quantum_efficiency",
    ),
    key(
        "gain_e_per_dn",
        "number > 0",
        "2.5",
        "electrons per DN at base_iso",
    ),
    key("read_noise_e", "number ≥ 0", "2.5", "read noise, electrons RMS"),
    key(
        "dark_current_e_per_s",
        "number ≥ 0",
        "5",
        "dark current, electrons per second",
    ),
    key(
        "full_well_e",
        "number > 0",
        "10000",
        "full-well capacity, electrons",
    ),
    key("black_level_dn", "integer ≥ 0", "64", "black level, DN"),
    key("bit_depth", "integer 8..16", "12", "ADC bits"),
    key(
        "cfa",
        "string",
        "RGGB",
        "none (monochrome), RGGB, BGGR, GRBG or GBRG",
    ),
    key("seed", "integer ≥ 0", "0", "noise seed"),
    key(
        "cos4",
        "boolean",
        "false",
        "natural vignetting cos⁴θ of the chief ray",
    ),
    key(
        "companding",
        "array of [linear, stored] pairs",
        "none",
        "piecewise-linear companding after the ADC, from [0, 0], both strictly increasing",
    ),
    key(
        "rolling_shutter",
        "object",
        "none",
        "{order: top_to_bottom|bottom_to_top|left_to_right|right_to_left, line_time_s, line_exposure_s}",
    ),
    key(
        "isp",
        "object",
        "{}",
        "{demosaic: bilinear|malvar, white_balance: as_shot|grey_world|none|[r,g,b], ccm: 3×3 or \"camera\", gain, tone: srgb|linear|number (gamma), output_bits: 8|16}",
    ),
];

impl SensorConfig {
    /// Reads a JSON object of [`KEYS`] over the defaults; `source_name` names it in errors.
    ///
    /// # Errors
    /// A [`ConfigError`] for text that is not JSON, not an object, an unknown key or a bad value.
    pub fn from_json(text: &str, source_name: &str) -> Result<SensorConfig, ConfigError> {
        let err = |message: String| ConfigError {
            source_name: source_name.to_string(),
            message,
        };
        let value: Value = serde_json::from_str(text).map_err(|e| {
            err(format!(
                "not JSON: {e} (line {}, column {})",
                e.line(),
                e.column()
            ))
        })?;
        let Value::Object(map) = value else {
            return Err(err("expected a JSON object of sensor keys".into()));
        };
        let mut config = SensorConfig::default();
        for (k, v) in &map {
            config.set(k, v).map_err(err)?;
        }
        config.validate().map_err(err)?;
        Ok(config)
    }

    /// Sets one key (a key of [`KEYS`]) from a JSON value.
    ///
    /// # Errors
    /// A message naming the key and what was expected.
    pub fn set(&mut self, key: &str, v: &Value) -> Result<(), String> {
        let positive = |v: &Value| -> Result<f64, String> {
            match v.as_f64() {
                Some(x) if x > 0.0 && x.is_finite() => Ok(x),
                _ => Err(format!("\"{key}\": expected a number > 0, got {v}")),
            }
        };
        let non_negative = |v: &Value| -> Result<f64, String> {
            match v.as_f64() {
                Some(x) if x >= 0.0 && x.is_finite() => Ok(x),
                _ => Err(format!("\"{key}\": expected a number ≥ 0, got {v}")),
            }
        };
        match key {
            "f_number" if v.is_null() => self.f_number = None,
            "companding" if v.is_null() => self.companding = None,
            "rolling_shutter" if v.is_null() => self.rolling_shutter = None,
            "pixel_pitch_um" => self.pixel_pitch_um = positive(v)?,
            "iso" => self.iso = positive(v)?,
            "base_iso" => self.base_iso = positive(v)?,
            "exposure_time_s" => self.exposure_time_s = positive(v)?,
            "f_number" => self.f_number = Some(positive(v)?),
            "responsivity" => self.responsivity = positive(v)?,
            "quantum_efficiency" => {
                let qe = positive(v)?;
                if qe > 1.0 {
                    return Err(format!("\"{key}\": expected a number in (0, 1], got {v}"));
                }
                self.response = match &self.response {
                    Response::Camera { name, .. } => Response::Camera {
                        name: name.clone(),
                        quantum_efficiency: qe,
                    },
                    _ => Response::QuantumEfficiency(qe),
                };
            }
            "camera_response" => {
                self.response = if let Some(name) = v.as_str() {
                    if color::camera_preset(name).is_none() {
                        return Err(format!(
                            "\"{key}\": unknown camera \"{name}\" (known: {})",
                            color::CAMERA_PRESETS
                                .iter()
                                .map(|p| p.0)
                                .collect::<Vec<_>>()
                                .join(", ")
                        ));
                    }
                    let qe = match self.response {
                        Response::QuantumEfficiency(q) => q,
                        Response::Camera {
                            quantum_efficiency, ..
                        } => quantum_efficiency,
                        Response::Matrix(_) => 0.6,
                    };
                    Response::Camera {
                        name: name.to_string(),
                        quantum_efficiency: qe,
                    }
                } else {
                    Response::Matrix(matrix(key, v)?)
                }
            }
            "gain_e_per_dn" => self.gain_e_per_dn = positive(v)?,
            "read_noise_e" => self.read_noise_e = non_negative(v)?,
            "dark_current_e_per_s" => self.dark_current_e_per_s = non_negative(v)?,
            "full_well_e" => self.full_well_e = positive(v)?,
            "black_level_dn" => {
                let b = non_negative(v)?;
                if b.fract() != 0.0 {
                    return Err(format!("\"{key}\": expected an integer ≥ 0, got {v}"));
                }
                self.black_level_dn = b;
            }
            "bit_depth" => match v.as_u64() {
                Some(b @ 8..=16) => self.bit_depth = b as u32,
                _ => return Err(format!("\"{key}\": expected an integer from 8 to 16, got {v}")),
            },
            "cfa" => {
                let s = v
                    .as_str()
                    .ok_or_else(|| format!("\"{key}\": expected a string, got {v}"))?;
                self.cfa = Cfa::parse(s).ok_or_else(|| {
                    format!("\"{key}\": expected none, RGGB, BGGR, GRBG or GBRG, got \"{s}\"")
                })?;
            }
            "seed" => {
                self.seed = v
                    .as_u64()
                    .ok_or_else(|| format!("\"{key}\": expected an integer ≥ 0, got {v}"))?;
            }
            "cos4" => {
                self.cos4 = v
                    .as_bool()
                    .ok_or_else(|| format!("\"{key}\": expected true or false, got {v}"))?;
            }
            "companding" => self.companding = Some(companding(v)?),
            "rolling_shutter" => self.rolling_shutter = Some(rolling_shutter(v)?),
            "isp" => {
                let Value::Object(map) = v else {
                    return Err(format!("\"isp\": expected an object, got {v}"));
                };
                for (k, v) in map {
                    set_isp(&mut self.isp, k, v)?;
                }
            }
            _ => {
                if let Some(isp_key) = key.strip_prefix("isp.") {
                    return set_isp(&mut self.isp, isp_key, v);
                }
                return Err(format!(
                    "unknown sensor key \"{key}\" (known: {})",
                    KEYS.iter().map(|k| k.name).collect::<Vec<_>>().join(", ")
                ));
            }
        }
        Ok(())
    }

    /// Sets several keys at once, where a dotted key (`isp.demosaic`, `rolling_shutter.line_time_s`)
    /// names a member of an object key: the members of one object are gathered and set together (a
    /// rolling shutter needs its line time and exposure in the same call). Then [`Self::validate`].
    ///
    /// # Errors
    /// The first key's message, as [`Self::set`].
    pub fn set_all(&mut self, entries: &[(String, Value)]) -> Result<(), String> {
        let mut nested: Vec<(String, Value)> = Vec::new();
        for (k, v) in entries {
            match k.split_once('.') {
                Some((outer, inner)) => {
                    let slot = match nested.iter().position(|(n, _)| n == outer) {
                        Some(i) => i,
                        None => {
                            nested.push((outer.to_string(), Value::Object(serde_json::Map::new())));
                            nested.len() - 1
                        }
                    };
                    if let Value::Object(map) = &mut nested[slot].1 {
                        map.insert(inner.to_string(), v.clone());
                    } else {
                        return Err(format!("\"{outer}\" is given both whole and as \"{k}\""));
                    }
                }
                None => nested.push((k.clone(), v.clone())),
            }
        }
        for (k, v) in &nested {
            self.set(k, v)?;
        }
        self.validate()
    }

    /// Checks what single keys cannot: the black level and companding against the bit depth.
    ///
    /// # Errors
    /// A message naming the keys in conflict.
    pub fn validate(&self) -> Result<(), String> {
        let max = self.max_code();
        if self.black_level_dn >= max {
            return Err(format!(
                "\"black_level_dn\" {} must be below the largest code {max} of \"bit_depth\" {}",
                self.black_level_dn, self.bit_depth
            ));
        }
        if let Some(c) = &self.companding
            && c.stored_max() > max
        {
            return Err(format!(
                "\"companding\": its largest stored code {} exceeds {max}, the largest code of \"bit_depth\" {}",
                c.stored_max(),
                self.bit_depth
            ));
        }
        Ok(())
    }

    /// The largest code the ADC (or the companding curve) writes, `2^bit_depth − 1`.
    #[must_use]
    pub fn max_code(&self) -> f64 {
        f64::from((1u32 << self.bit_depth) - 1)
    }

    /// The largest linear code before companding (the curve's last input, else [`Self::max_code`]).
    #[must_use]
    pub fn linear_max_code(&self) -> f64 {
        self.companding
            .as_ref()
            .map_or(self.max_code(), Companding::linear_max)
    }

    /// The system gain K in DN per electron: `(iso / base_iso) / gain_e_per_dn`.
    #[must_use]
    pub fn system_gain_dn_per_e(&self) -> f64 {
        (self.iso / self.base_iso) / self.gain_e_per_dn
    }

    /// The response matrix `M` (channel electrons per photon for linear-sRGB R, G, B).
    #[must_use]
    pub fn response_matrix(&self) -> Mat3 {
        match &self.response {
            Response::QuantumEfficiency(qe) => color::scale(color::IDENTITY, *qe),
            Response::Matrix(m) => *m,
            Response::Camera {
                name,
                quantum_efficiency,
            } => {
                let m =
                    color::camera_preset(name).map_or(color::IDENTITY, color::srgb_response_of_color_matrix);
                color::scale(m, *quantum_efficiency)
            }
        }
    }

    /// The description as JSON with every key (what `<image>.camera.json` records).
    #[must_use]
    pub fn to_json(&self) -> Value {
        let response = match &self.response {
            Response::QuantumEfficiency(q) => serde_json::json!({"quantum_efficiency": q}),
            Response::Matrix(m) => serde_json::json!({"camera_response": m}),
            Response::Camera {
                name,
                quantum_efficiency,
            } => serde_json::json!({"camera_response": name, "quantum_efficiency": quantum_efficiency}),
        };
        let mut j = serde_json::json!({
            "pixel_pitch_um": self.pixel_pitch_um,
            "iso": self.iso,
            "base_iso": self.base_iso,
            "exposure_time_s": self.exposure_time_s,
            "f_number": self.f_number,
            "responsivity": self.responsivity,
            "gain_e_per_dn": self.gain_e_per_dn,
            "read_noise_e": self.read_noise_e,
            "dark_current_e_per_s": self.dark_current_e_per_s,
            "full_well_e": self.full_well_e,
            "black_level_dn": self.black_level_dn,
            "bit_depth": self.bit_depth,
            "cfa": self.cfa.name(),
            "seed": self.seed,
            "cos4": self.cos4,
            "companding": self.companding.as_ref().map(|c| c.knees.iter().map(|k| [k.0, k.1]).collect::<Vec<_>>()),
            "rolling_shutter": self.rolling_shutter.map(|r| serde_json::json!({
                "order": r.order.name(),
                "line_time_s": r.line_time_s,
                "line_exposure_s": r.line_exposure_s,
            })),
            "isp": {
                "demosaic": match self.isp.demosaic {
                    Demosaic::Bilinear => "bilinear",
                    Demosaic::MalvarHeCutler => "malvar",
                },
                "white_balance": match self.isp.white_balance {
                    WhiteBalance::AsShot => serde_json::json!("as_shot"),
                    WhiteBalance::GreyWorld => serde_json::json!("grey_world"),
                    WhiteBalance::Off => serde_json::json!("none"),
                    WhiteBalance::Gains(g) => serde_json::json!(g),
                },
                "ccm": self.isp.ccm.map_or(serde_json::json!("camera"), |m| serde_json::json!(m)),
                "gain": self.isp.gain,
                "tone": match self.isp.tone {
                    Tone::Srgb => serde_json::json!("srgb"),
                    Tone::Linear => serde_json::json!("linear"),
                    Tone::Gamma(g) => serde_json::json!(g),
                },
                "output_bits": self.isp.output_bits,
            },
        });
        if let (Value::Object(a), Value::Object(b)) = (&mut j, response) {
            a.extend(b);
        }
        j
    }
}

fn matrix(key: &str, v: &Value) -> Result<Mat3, String> {
    let bad = || format!("\"{key}\": expected a 3×3 array of numbers [[..],[..],[..]], got {v}");
    let rows = v.as_array().filter(|r| r.len() == 3).ok_or_else(bad)?;
    let mut m = [[0.0; 3]; 3];
    for (i, row) in rows.iter().enumerate() {
        let row = row.as_array().filter(|r| r.len() == 3).ok_or_else(bad)?;
        for (j, x) in row.iter().enumerate() {
            m[i][j] = x.as_f64().filter(|x| x.is_finite()).ok_or_else(bad)?;
        }
    }
    Ok(m)
}

fn companding(v: &Value) -> Result<Companding, String> {
    let bad = |why: &str| format!("\"companding\": {why}, got {v}");
    let points = v
        .as_array()
        .ok_or_else(|| bad("expected an array of [linear, stored] pairs"))?;
    let mut knees = Vec::new();
    for p in points {
        let pair = p
            .as_array()
            .filter(|p| p.len() == 2)
            .and_then(|p| Some((p[0].as_f64()?, p[1].as_f64()?)))
            .ok_or_else(|| bad("expected an array of [linear, stored] pairs"))?;
        knees.push(pair);
    }
    if knees.len() < 2 || knees[0] != (0.0, 0.0) {
        return Err(bad("expected at least two pairs, the first [0, 0]"));
    }
    if knees.windows(2).any(|w| w[1].0 <= w[0].0 || w[1].1 <= w[0].1) {
        return Err(bad("expected both columns strictly increasing"));
    }
    Ok(Companding { knees })
}

fn rolling_shutter(v: &Value) -> Result<RollingShutter, String> {
    let Value::Object(map) = v else {
        return Err(format!("\"rolling_shutter\": expected an object, got {v}"));
    };
    let mut order = ScanOrder::TopToBottom;
    let (mut line_time_s, mut line_exposure_s) = (None, None);
    for (k, x) in map {
        let num = || match x.as_f64() {
            Some(n) if n > 0.0 && n.is_finite() => Ok(n),
            _ => Err(format!("\"rolling_shutter.{k}\": expected a number > 0, got {x}")),
        };
        match k.as_str() {
            "order" => {
                order = x.as_str().and_then(ScanOrder::parse).ok_or_else(|| {
                    format!(
                        "\"rolling_shutter.order\": expected one of {}, got {x}",
                        ScanOrder::NAMES.join(", ")
                    )
                })?;
            }
            "line_time_s" => line_time_s = Some(num()?),
            "line_exposure_s" => line_exposure_s = Some(num()?),
            _ => {
                return Err(format!(
                    "unknown key \"rolling_shutter.{k}\" (known: order, line_time_s, line_exposure_s)"
                ));
            }
        }
    }
    match (line_time_s, line_exposure_s) {
        (Some(line_time_s), Some(line_exposure_s)) => Ok(RollingShutter {
            order,
            line_time_s,
            line_exposure_s,
        }),
        _ => Err("\"rolling_shutter\": expected both line_time_s and line_exposure_s".into()),
    }
}

fn set_isp(isp: &mut IspConfig, k: &str, v: &Value) -> Result<(), String> {
    match k {
        "demosaic" => {
            isp.demosaic = match v.as_str() {
                Some("bilinear") => Demosaic::Bilinear,
                Some("malvar") => Demosaic::MalvarHeCutler,
                _ => {
                    return Err(format!(
                        "\"isp.demosaic\": expected \"bilinear\" or \"malvar\", got {v}"
                    ));
                }
            }
        }
        "white_balance" => {
            isp.white_balance = match v {
                Value::String(s) if s == "as_shot" => WhiteBalance::AsShot,
                Value::String(s) if s == "grey_world" => WhiteBalance::GreyWorld,
                Value::String(s) if s == "none" => WhiteBalance::Off,
                Value::Array(a) if a.len() == 3 && a.iter().all(|x| x.as_f64().is_some_and(|x| x > 0.0)) => {
                    WhiteBalance::Gains([0, 1, 2].map(|i| a[i].as_f64().unwrap_or(1.0)))
                }
                _ => {
                    return Err(format!(
                        "\"isp.white_balance\": expected \"as_shot\", \"grey_world\", \"none\" or three gains > 0, got {v}"
                    ));
                }
            }
        }
        "ccm" => {
            isp.ccm = match v {
                Value::String(s) if s == "camera" => None,
                _ => Some(matrix("isp.ccm", v)?),
            }
        }
        "gain" => {
            isp.gain = v
                .as_f64()
                .filter(|g| *g > 0.0 && g.is_finite())
                .ok_or_else(|| format!("\"isp.gain\": expected a number > 0, got {v}"))?;
        }
        "tone" => {
            isp.tone = match v {
                Value::String(s) if s == "srgb" => Tone::Srgb,
                Value::String(s) if s == "linear" => Tone::Linear,
                Value::Number(n) if n.as_f64().is_some_and(|g| g > 0.0) => {
                    Tone::Gamma(n.as_f64().unwrap_or(1.0))
                }
                _ => {
                    return Err(format!(
                        "\"isp.tone\": expected \"srgb\", \"linear\" or a gamma > 0, got {v}"
                    ));
                }
            }
        }
        "output_bits" => match v.as_u64() {
            Some(b @ (8 | 16)) => isp.output_bits = b as u32,
            _ => return Err(format!("\"isp.output_bits\": expected 8 or 16, got {v}")),
        },
        _ => {
            return Err(format!(
                "unknown key \"isp.{k}\" (known: demosaic, white_balance, ccm, gain, tone, output_bits)"
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_every_key() {
        let text = r#"{"pixel_pitch_um": 5, "iso": 400, "exposure_time_s": 0.02, "f_number": 2,
            "quantum_efficiency": 0.5, "gain_e_per_dn": 2, "read_noise_e": 3, "dark_current_e_per_s": 10,
            "full_well_e": 20000, "black_level_dn": 256, "bit_depth": 14, "cfa": "GRBG", "seed": 9,
            "rolling_shutter": {"order": "left_to_right", "line_time_s": 1e-5, "line_exposure_s": 0.002},
            "isp": {"demosaic": "bilinear", "tone": 2.2, "output_bits": 16}}"#;
        let c = SensorConfig::from_json(text, "s.json").unwrap();
        assert_eq!(c.cfa, Cfa::Grbg);
        assert_eq!(c.bit_depth, 14);
        assert!((c.system_gain_dn_per_e() - 2.0).abs() < 1e-12);
        assert_eq!(c.rolling_shutter.unwrap().order, ScanOrder::LeftToRight);
        assert_eq!(c.isp.tone, Tone::Gamma(2.2));
        // The record reads back to the same description.
        let again = SensorConfig::from_json(&c.to_json().to_string(), "record").unwrap();
        assert_eq!(again, c);
    }

    #[test]
    fn errors_name_the_key_and_the_expectation() {
        let e = SensorConfig::from_json(r#"{"iso": -1}"#, "cam.json").unwrap_err();
        assert_eq!(e.to_string(), "cam.json: \"iso\": expected a number > 0, got -1");
        let e = SensorConfig::from_json(r#"{"isso": 100}"#, "cam.json").unwrap_err();
        assert!(e.to_string().contains("unknown sensor key \"isso\""), "{e}");
        let e =
            SensorConfig::from_json(r#"{"black_level_dn": 300, "bit_depth": 8}"#, "cam.json").unwrap_err();
        assert!(e.to_string().contains("black_level_dn"), "{e}");
        let e = SensorConfig::from_json("{\"iso\": 1,\n", "cam.json").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
        let e = SensorConfig::from_json(r#"{"cfa": "RGBG"}"#, "x").unwrap_err();
        assert!(e.to_string().contains("RGGB, BGGR, GRBG or GBRG"), "{e}");
    }

    #[test]
    fn dotted_keys_gather_into_objects() {
        let mut c = SensorConfig::default();
        let entries = [
            ("iso".to_string(), serde_json::json!(800)),
            (
                "rolling_shutter.order".to_string(),
                serde_json::json!("bottom_to_top"),
            ),
            ("rolling_shutter.line_time_s".to_string(), serde_json::json!(2e-5)),
            (
                "rolling_shutter.line_exposure_s".to_string(),
                serde_json::json!(1e-3),
            ),
            ("isp.demosaic".to_string(), serde_json::json!("bilinear")),
        ];
        c.set_all(&entries).unwrap();
        assert_eq!(c.iso, 800.0);
        assert_eq!(c.rolling_shutter.unwrap().order, ScanOrder::BottomToTop);
        assert_eq!(c.isp.demosaic, Demosaic::Bilinear);
        let e = c.set_all(&[("rolling_shutter.line_time_s".to_string(), serde_json::json!(1e-5))]);
        assert!(e.unwrap_err().contains("line_exposure_s"));
    }

    #[test]
    fn companding_inverts_exactly_on_its_knees() {
        let c = companding(&serde_json::json!([[0, 0], [1024, 1024], [16383, 4095]])).unwrap();
        for x in [0.0, 10.0, 1024.0, 5000.0, 16383.0] {
            assert!((c.expand(c.compress(x)) - x).abs() < 1e-9, "{x}");
        }
        assert!(companding(&serde_json::json!([[0, 0], [10, 5], [5, 10]])).is_err());
    }

    #[test]
    fn rolling_shutter_duration_maps_line_starts() {
        let r = RollingShutter {
            order: ScanOrder::TopToBottom,
            line_time_s: 1e-5,
            line_exposure_s: 1e-3,
        };
        let lines = 1000;
        let span = r.span_s(lines);
        let d = r.duration(lines);
        // Line k's exposure opens at p·(1 − d)·span with p = (k + ½)/lines.
        for k in [0u32, 10, 999] {
            let p = (f64::from(k) + 0.5) / f64::from(lines);
            let open = p * (1.0 - d) * span;
            assert!((open - (f64::from(k) + 0.5) * r.line_time_s).abs() < 1e-12);
        }
        assert!((d * span - r.line_exposure_s).abs() < 1e-15);
    }
}
