//! The image sensor after the lens: Obscura's film is a noiseless linear HDR image; this crate turns it
//! into what a camera delivers.
//!
//! - [`config`]: the sensor description (JSON, `--sensor-param`, RIB `Option "sensor"`, Python), one
//!   table of keys ([`config::KEYS`]);
//! - [`capture`]: physical exposure (radiance → photoelectrons through the camera equation), photon
//!   shot noise, dark current, full well, read noise, gain, black level, ADC and companding;
//! - [`cfa`]: the Bayer patterns;
//! - [`isp`]: linearisation, demosaic (bilinear, Malvar–He–Cutler), white balance, colour correction,
//!   tone curve;
//! - [`dng`]: the raw mosaic as a DNG file;
//! - [`color`], [`noise`], [`rng`]: the matrices, the two random laws, the counter-based random stream;
//! - [`emva`]: the EMVA 1288 photon-transfer analysis the test suite characterises the model with.
//!
//! The formulas are in each module's documentation and in `docs/sensor.md`.

pub mod capture;
pub mod cfa;
pub mod color;
pub mod config;
pub mod dng;
pub mod emva;
pub mod isp;
pub mod noise;
pub mod rng;

pub use capture::{FNumberSource, Sensor, SensorFrame};
pub use cfa::Cfa;
pub use config::{ConfigError, SensorConfig};
