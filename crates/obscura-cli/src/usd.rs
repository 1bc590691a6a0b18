//! `obscura usd-cameras`: a USD stage's cameras as JSON.

use std::path::PathBuf;

use clap::Args;

use crate::outln;

/// `obscura usd-cameras` arguments.
#[derive(Args, Debug)]
pub struct UsdCamerasArgs {
    /// The stage (.usd, .usda, .usdc, .usdz).
    stage: PathBuf,
    /// A time code to read at (repeatable; default: the stage's start, middle and end, or 0).
    #[arg(long = "time", value_name = "T")]
    times: Vec<f64>,
}

/// Prints the stage's cameras.
pub fn run(a: &UsdCamerasArgs) -> Result<(), String> {
    let stage = obscura_usd::Stage::open(&a.stage).map_err(|e| e.to_string())?;
    let times = (!a.times.is_empty()).then_some(a.times.as_slice());
    let json = obscura_usd::inspect::cameras_json(&stage, times).map_err(|e| e.to_string())?;
    outln!(
        "{}",
        serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?
    );
    Ok(())
}
