//! End to end: `obscura rays` and `obscura plugins` as a user runs them.

use std::path::Path;
use std::process::Command;

use exr::prelude::read_all_flat_layers_from_file;

mod support;

use support::{channel, obscura};

fn pinhole_direction(fov: f64, w: u32, h: u32, x: u32, y: u32) -> [f64; 3] {
    let a = w as f64 / h as f64;
    let (sx, sy) = (
        -a + (x as f64 + 0.5) / w as f64 * 2.0 * a,
        1.0 - (y as f64 + 0.5) / h as f64 * 2.0,
    );
    let d = 1.0 / (fov.to_radians() / 2.0).tan();
    let l = (sx * sx + sy * sy + d * d).sqrt();
    [sx / l, sy / l, d / l]
}

#[test]
fn rays_exr_reads_back_with_the_exr_crate() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rays.exr");
    let run = obscura(&[
        "rays",
        "--format",
        "64x48",
        "--param",
        "float fov=60",
        "--samples",
        "2",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(String::from_utf8_lossy(&run.stdout).contains("64x48 pixels, 3 layers"));
    let image = read_all_flat_layers_from_file(&out).unwrap();
    let layer = &image.layer_data[0];
    assert_eq!((layer.size.0, layer.size.1), (64, 48));
    let names: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    for prefix in ["", "sample1.", "sample2."] {
        for c in [
            "origin.X",
            "origin.Y",
            "origin.Z",
            "direction.X",
            "direction.Y",
            "direction.Z",
            "originRadius",
            "raySpread",
            "tint.R",
            "tint.G",
            "tint.B",
            "valid",
        ] {
            assert!(
                names.contains(&format!("{prefix}{c}")),
                "missing {prefix}{c} in {names:?}"
            );
        }
    }
    assert!(names.contains(&"sample2.time".to_string()) && names.contains(&"sample1.screen.X".to_string()));
    let (dx, dy, dz) = (
        channel(&image, "direction.X"),
        channel(&image, "direction.Y"),
        channel(&image, "direction.Z"),
    );
    for (x, y) in [(0, 0), (63, 0), (31, 24), (10, 47)] {
        let i = (y * 64 + x) as usize;
        let want = pinhole_direction(60.0, 64, 48, x, y);
        let got = [dx[i] as f64, dy[i] as f64, dz[i] as f64];
        for k in 0..3 {
            assert!(
                (got[k] - want[k]).abs() < 1e-6,
                "pixel ({x}, {y}): {got:?} vs {want:?}"
            );
        }
    }
    assert!(channel(&image, "valid").iter().all(|v| *v == 1.0));
    // Sampled rays are unit length and inside their pixel's neighbourhood of the chief ray.
    let (sx, sz) = (
        channel(&image, "sample1.direction.X"),
        channel(&image, "sample1.direction.Z"),
    );
    for i in 0..64 * 48 {
        assert!((sx[i] - dx[i]).abs() < 0.03 && (sz[i] - dz[i]).abs() < 0.03);
    }
    // Nothing but the file is left behind: it was written under a temporary name and renamed.
    let entries: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(entries.len(), 1);
}

#[test]
fn a_crop_writes_the_same_region_of_the_full_image() {
    let dir = tempfile::tempdir().unwrap();
    let (full, crop) = (dir.path().join("full.exr"), dir.path().join("crop.exr"));
    for (path, extra) in [
        (&full, vec![]),
        (&crop, vec!["--crop", "0.25", "0.75", "0.5", "1"]),
    ] {
        let mut args = vec![
            "rays",
            "--format",
            "40x30",
            "--param",
            "fov=70",
            "-o",
            path.to_str().unwrap(),
        ];
        args.extend(extra);
        assert!(obscura(&args).status.success());
    }
    let (f, c) = (
        read_all_flat_layers_from_file(&full).unwrap(),
        read_all_flat_layers_from_file(&crop).unwrap(),
    );
    let cl = &c.layer_data[0];
    assert_eq!(
        (cl.attributes.layer_position.0, cl.attributes.layer_position.1),
        (10, 15)
    );
    assert_eq!((cl.size.0, cl.size.1), (20, 15));
    assert_eq!(
        (
            c.attributes.display_window.size.0,
            c.attributes.display_window.size.1
        ),
        (40, 30)
    );
    for name in ["direction.X", "direction.Y", "raySpread"] {
        let (fv, cv) = (channel(&f, name), channel(&c, name));
        for y in 0..15 {
            for x in 0..20 {
                assert_eq!(cv[y * 20 + x], fv[(y + 15) * 40 + x + 10], "{name} at ({x}, {y})");
            }
        }
    }
}

/// Reads the file with OpenEXR's own (C++) library through its Python binding. CI installs it and sets
/// OBSCURA_REQUIRE_INDEPENDENT_EXR=1, so there a missing reader is a failure, not a skip.
#[test]
fn an_independent_reader_agrees() {
    if !support::python_has("OpenEXR, numpy", "OBSCURA_REQUIRE_INDEPENDENT_EXR") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/read_rays_exr.py");
    for (fov, w, h, crop) in [
        ("45", "96", "54", None),
        ("100", "30", "60", Some(["0.1", "0.6", "0.2", "0.9"])),
    ] {
        let out = dir.path().join(format!("rays-{fov}.exr"));
        let mut args = vec!["rays", "--format", "", "--param", "", "-o", out.to_str().unwrap()];
        let format = format!("{w}x{h}");
        let param = format!("float fov={fov}");
        args[2] = &format;
        args[4] = &param;
        if let Some(c) = &crop {
            args.push("--crop");
            args.extend(c.iter());
        }
        assert!(obscura(&args).status.success());
        let mut check = vec![script.to_str().unwrap(), out.to_str().unwrap(), fov, w, h];
        if let Some(c) = &crop {
            check.extend(c.iter());
        }
        let r = Command::new("python3").args(&check).output().unwrap();
        assert!(
            r.status.success(),
            "independent reader: {}{}",
            String::from_utf8_lossy(&r.stdout),
            String::from_utf8_lossy(&r.stderr)
        );
    }
}

#[test]
fn bad_input_gets_a_clear_error_and_exit_code() {
    for (args, needle) in [
        (
            vec!["rays", "-p", "PxrPerspectve"],
            "did you mean \"PxrPerspective\"",
        ),
        (
            vec!["rays", "--param", "float fov=181"],
            "PxrPerspective: parameter \"fov\" (at --param 'float fov=181') = 181 is out of range",
        ),
        (
            vec!["rays", "--param", "focalDistanse=3"],
            "did you mean \"focalDistance\"",
        ),
        (vec!["rays", "--format", "640by480"], "expected WIDTHxHEIGHT"),
        (
            vec!["rays", "--screen-window", "1", "-1", "-1", "1"],
            "ScreenWindow: expected finite left < right",
        ),
        (vec!["rays", "--aperture-roundness", "2"], "apertureRoundness"),
        (
            vec![
                "rays",
                "--shutter-open-time",
                "0.8",
                "--shutter-close-time",
                "0.2",
            ],
            "shutterOpenTime",
        ),
        (
            vec!["rays", "-o", "/nonexistent-dir/x.exr"],
            "output /nonexistent-dir/x.exr: the directory /nonexistent-dir does not exist",
        ),
        (vec!["plugins", "Nope"], "known projections: CalibratedCamera, "),
    ] {
        let r = obscura(&args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(!r.status.success(), "{args:?} should fail");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn plugins_lists_every_projection_with_its_table() {
    let r = obscura(&["plugins"]);
    assert!(r.status.success());
    let text = String::from_utf8_lossy(&r.stdout);
    for needle in [
        "PxrPerspective\n",
        "PxrOrthographic\n",
        "\"float fovEnd\"",
        "\"float focalDistance\"",
    ] {
        assert!(text.contains(needle), "{needle} missing from:\n{text}");
    }
}
