//! `obscura render` with a sensor: the DNG read by LibRaw (rawpy, PyPI) has the configured pattern,
//! levels and the EXR's raw values; LibRaw's demosaic of it matches Obscura's ISP (see
//! `rawpy_dng.py` for the tolerances); bad sensor input is refused with the key named. CI installs
//! rawpy and sets OBSCURA_REQUIRE_RAWPY=1.

mod support;

use support::{obscura_in, text};

const CHECKER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/rawpy_dng.py");

#[test]
fn dng_reads_in_libraw_and_matches_the_isp() {
    if !support::python_has("rawpy, numpy, OpenEXR", "OBSCURA_REQUIRE_RAWPY") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("GRBG", 64, 12, "bilinear"),
        ("BGGR", 256, 14, "malvar"),
        ("RGGB", 0, 12, "bilinear"),
        ("GBRG", 128, 14, "malvar"),
    ];
    for (cfa, black, bits, demosaic) in cases {
        let (exr, dng) = (format!("{cfa}.exr"), format!("{cfa}.dng"));
        let params = [
            format!("cfa={cfa}"),
            format!("black_level_dn={black}"),
            format!("bit_depth={bits}"),
            format!("isp.demosaic={demosaic}"),
            "isp.tone=linear".to_string(),
            "camera_response=canon_eos_5d_mark_ii".to_string(),
        ];
        let mut args = vec![
            "render", "--format", "96x64", "--spp", "4", "-q", "-o", &exr, "--raw", &dng,
        ];
        for p in &params {
            args.extend(["--sensor-param", p]);
        }
        let run = obscura_in(&args, dir.path());
        assert!(run.status.success(), "{cfa}: {}", text(&run.stderr));
        let white = ((1u32 << bits) - 1).to_string();
        let check = std::process::Command::new("python3")
            .args([CHECKER, &dng, &exr, cfa, &black.to_string(), &white, demosaic])
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert!(
            check.status.success(),
            "{cfa}: {}{}",
            text(&check.stdout),
            text(&check.stderr)
        );
        eprint!("{cfa}: {}", text(&check.stdout));
    }
}

#[test]
fn sensor_errors_name_the_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.json"), "{\"iso\": 100, \"cfa\": \"RGBW\"}").unwrap();
    let run = obscura_in(
        &["render", "--format", "8x8", "--sensor", "s.json", "-o", "x.exr"],
        dir.path(),
    );
    assert!(!run.status.success());
    let err = text(&run.stderr);
    assert!(
        err.contains("s.json: \"cfa\": expected none, RGGB, BGGR, GRBG or GBRG, got \"RGBW\""),
        "{err}"
    );
    let run = obscura_in(
        &[
            "render",
            "--format",
            "8x8",
            "--sensor-param",
            "isso=3",
            "-o",
            "x.exr",
        ],
        dir.path(),
    );
    assert!(
        text(&run.stderr).contains("unknown sensor key \"isso\""),
        "{}",
        text(&run.stderr)
    );
    let run = obscura_in(
        &["render", "--format", "8x8", "--raw", "x.dng", "-o", "x.exr"],
        dir.path(),
    );
    assert!(
        text(&run.stderr).contains("needs a sensor"),
        "{}",
        text(&run.stderr)
    );
    assert!(!dir.path().join("x.exr").exists(), "nothing is written");
}
