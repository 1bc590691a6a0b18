//! Shared by the end-to-end tests: running the `obscura` binary, the calibration fixtures, reading
//! its EXR files back, and checking its output with tools we did not write.

// Each test file is its own crate and uses part of this module.
#![allow(dead_code)]

use std::process::{Command, Output};

use exr::prelude::{AttributeValue, FlatImage, FlatSamples, Text};

/// Runs the `obscura` binary with `args` in the current directory.
pub fn obscura(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_obscura"))
        .args(args)
        .output()
        .expect("the obscura binary runs")
}

/// Runs the `obscura` binary with `args` in `dir`.
pub fn obscura_in(args: &[&str], dir: &std::path::Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_obscura"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the obscura binary runs")
}

/// A command's output bytes (stdout or stderr) as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The path of a calibration file of `obscura-calibration`'s test fixtures.
pub fn fixture(name: &str) -> String {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../obscura-calibration/tests/fixtures")
        .join(name)
        .to_str()
        .unwrap()
        .to_string()
}

/// The `f32` samples of channel `name` of the first layer.
///
/// # Panics
/// When there is no such channel or it is not `f32`.
pub fn channel<'a>(image: &'a FlatImage, name: &str) -> &'a [f32] {
    let ch = image.layer_data[0]
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == name);
    match ch.map(|c| &c.sample_data) {
        Some(FlatSamples::F32(v)) => v,
        other => panic!("channel {name}: {other:?}"),
    }
}

/// The string header attribute `key` of the first layer.
pub fn text_attribute(image: &FlatImage, key: &str) -> Option<String> {
    match image.layer_data[0].attributes.other.get(&Text::from(key)) {
        Some(AttributeValue::Text(t)) => Some(t.to_string()),
        _ => None,
    }
}

/// Screen position of pixel centre (x, y) with the default screen window of a w×h image.
pub fn screen(w: u32, h: u32, x: u32, y: u32) -> (f64, f64) {
    let a = f64::from(w) / f64::from(h);
    let (l, r, b, t) = if a >= 1.0 {
        (-a, a, -1.0, 1.0)
    } else {
        (-1.0, 1.0, -1.0 / a, 1.0 / a)
    };
    (
        l + (f64::from(x) + 0.5) / f64::from(w) * (r - l),
        t - (f64::from(y) + 0.5) / f64::from(h) * (t - b),
    )
}

/// Whether `python3` can import `modules` (as in `import OpenEXR, numpy`). When it cannot, the calling
/// test skips, unless the environment variable `require` is set (CI sets it after installing the
/// modules), and then it fails.
pub fn python_has(modules: &str, require: &str) -> bool {
    let ok = Command::new("python3")
        .args(["-c", &format!("import {modules}")])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var_os(require).is_none(),
            "python3 with {modules} is required here ({require} is set) but missing"
        );
        eprintln!("skipping: python3 with {modules} is not installed (CI installs it)");
    }
    ok
}
