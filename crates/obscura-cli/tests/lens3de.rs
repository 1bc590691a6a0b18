//! End to end: a 3DEqualizer lens handed over as a Nuke script (`examples/lens3de`), through
//! `obscura rays` and `obscura render` as a user runs them.

use std::path::PathBuf;

use exr::prelude::read_all_flat_layers_from_file;

mod support;

use support::{channel, obscura};

fn example(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/lens3de")
        .join(name)
        .display()
        .to_string()
}

/// Every pixel's ray is the pinhole ray of 3DE's undistorted point, written out here from the
/// white paper's Radial Standard Degree 4 formula with the example's knobs.
#[test]
fn rays_through_a_nuke_lens_node_are_3des_undistorted_pinhole_rays() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rays.exr");
    let (w, h) = (48usize, 27usize);
    let run = obscura(&[
        "rays",
        "--calibration",
        &example("plate_lens.nk"),
        "--format",
        "48x27",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", support::text(&run.stderr));
    let image = read_all_flat_layers_from_file(&out).unwrap();
    let (fl, wfb, hfb, lx, ly) = (3.5, 2.4, 1.35, 0.03, -0.02);
    let (c2, u2, v2, c4) = (0.09, 0.004, -0.003, 0.015);
    let r_fb = 0.5 * f64::hypot(wfb, hfb);
    let mut worst = 0.0f64;
    for j in 0..h {
        for i in 0..w {
            // Pixel centre → 3DE unit coordinates (y up) → diagonally normalised.
            let (u, v) = ((i as f64 + 0.5) / w as f64, 1.0 - (j as f64 + 0.5) / h as f64);
            let (x, y) = (((u - 0.5) * wfb - lx) / r_fb, ((v - 0.5) * hfb - ly) / r_fb);
            let r2 = x * x + y * y;
            let radial = 1.0 + c2 * r2 + c4 * r2 * r2;
            let xu = x * radial + (r2 + 2.0 * x * x) * u2 + 2.0 * x * y * v2;
            let yu = y * radial + (r2 + 2.0 * y * y) * v2 + 2.0 * x * y * u2;
            let want = [xu * r_fb, yu * r_fb, fl];
            let n = (want[0] * want[0] + want[1] * want[1] + want[2] * want[2]).sqrt();
            let k = j * w + i;
            let got = [
                f64::from(channel(&image, "direction.X")[k]),
                f64::from(channel(&image, "direction.Y")[k]),
                f64::from(channel(&image, "direction.Z")[k]),
            ];
            for c in 0..3 {
                worst = worst.max((got[c] - want[c] / n).abs());
            }
        }
    }
    assert!(worst < 1e-6, "rays differ from 3DE's formula by {worst}");
}

/// An animated lens renders each frame through the lens of that frame (a zoom: 3.5 → 5 cm).
#[test]
fn an_animated_lens_renders_each_frame_through_its_own_lens() {
    let dir = tempfile::tempdir().unwrap();
    let pattern = dir.path().join("zoom.####.exr");
    let run = obscura(&[
        "render",
        "--calibration",
        &example("zoom.nk"),
        "--frames",
        "1,11",
        "--format",
        "32x18",
        "--spp",
        "1",
        "-o",
        pattern.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", support::text(&run.stderr));
    let text = support::text(&run.stdout);
    assert!(
        text.contains("frame 1: ") && text.contains("frame 11: "),
        "{text}"
    );
    let a = std::fs::read(dir.path().join("zoom.0001.exr")).unwrap();
    let b = std::fs::read(dir.path().join("zoom.0011.exr")).unwrap();
    assert_ne!(a, b, "frames 1 and 11 rendered the same image");
}

/// `obscura export-nuke` writes a 3DE lens as a Nuke node that the Nuke reader reads back with the
/// same model, plate and parameters.
#[test]
fn an_exported_nuke_node_reads_back_with_equal_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("node.nk");
    let run = obscura(&[
        "export-nuke",
        "--calibration",
        &example("plate_lens.nk"),
        "--name",
        "LD_back",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", support::text(&run.stderr));
    let load = |p: &str, node: Option<&str>| {
        obscura_calibration::files::load(std::path::Path::new(p), node).unwrap()
    };
    let a = load(&example("plate_lens.nk"), None);
    let b = load(out.to_str().unwrap(), Some("LD_back"));
    assert_eq!((&a.model, a.width, a.height), (&b.model, b.width, b.height));
    assert_eq!(a.params.len(), b.params.len());
    for (x, y) in a.params.iter().zip(&b.params) {
        assert!(
            (x.value - y.value).abs() <= 1e-7 * x.value.abs().max(1.0),
            "{x:?} vs {y:?}"
        );
    }
}

/// A calibration that is not a 3DE lens is fitted with Radial Standard Degree 4: a pinhole gives
/// zero distortion and no residual; an OpenCV camera gives the residual the command reports, which
/// the node read back reproduces against the camera's own rays.
#[test]
fn export_nuke_fits_radial_standard_to_other_models_and_reports_the_residual() {
    use obscura_calibration::lens3de::{Kind, Lens};
    let dir = tempfile::tempdir().unwrap();
    let cams = dir.path().join("cameras.txt");
    std::fs::write(
        &cams,
        "1 PINHOLE 640 480 500 480 330.5 236.25\n\
         2 OPENCV 752 480 458.654 457.296 367.215 248.375 -0.2834 0.07396 0.00019359 1.76e-05\n",
    )
    .unwrap();
    let export = |camera: &str| -> (String, obscura_calibration::files::Calibration) {
        let out = dir.path().join(format!("cam{camera}.nk"));
        let run = obscura(&[
            "export-nuke",
            "--calibration",
            cams.to_str().unwrap(),
            "--camera",
            camera,
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(run.status.success(), "{}", support::text(&run.stderr));
        let node = obscura_calibration::files::load(&out, None).unwrap();
        (support::text(&run.stdout), node)
    };
    let residual = |text: &str, what: &str| -> f64 {
        let at = text.find(what).unwrap_or_else(|| panic!("{text}"));
        let tail = &text[..at];
        tail.rsplit(' ').find(|w| !w.is_empty()).unwrap().parse().unwrap()
    };
    let lens_of = |c: &obscura_calibration::files::Calibration| {
        let v: Vec<f64> = c.params.iter().map(|n| n.value).collect();
        (
            Lens::new(Kind::RadialStandard4, &v, f64::from(c.width), f64::from(c.height)).unwrap(),
            v,
        )
    };

    let (text, node) = export("1");
    assert!(text.contains("fitted to its PINHOLE model"), "{text}");
    assert!(residual(&text, " px max") < 1e-6, "{text}");
    let (lens, values) = lens_of(&node);
    assert!(values[10..].iter().all(|c| c.abs() < 1e-9), "{values:?}");
    // Its pinhole is the camera's (to the 7 decimals of the knobs).
    let [fx, fy, cx, cy] = lens.pinhole();
    for (got, want) in [fx, fy, cx, cy].iter().zip([500.0, 480.0, 330.5, 236.25]) {
        assert!((got - want).abs() < 1e-3, "{got} vs {want}");
    }

    // OpenCV: the reported max residual is the read-back node's distance from the camera's own
    // undistorted positions (the closed-form OpenCV distortion, inverted here by fixed point).
    let (text, node) = export("2");
    let max = residual(&text, " px max");
    assert!(max > 0.01 && max < 100.0, "{text}");
    let (lens, _) = lens_of(&node);
    let (fx, fy, cx, cy) = (458.654, 457.296, 367.215, 248.375); // COLMAP: centres at i + ½
    let (k1, k2, p1, p2) = (-0.2834, 0.07396, 0.00019359, 1.76e-05);
    let mut worst = 0.0f64;
    for j in 0..=32 {
        for i in 0..=32 {
            let px = [752.0 * f64::from(i) / 32.0, 480.0 * f64::from(j) / 32.0];
            let (xd, yd) = ((px[0] - cx) / fx, (px[1] - cy) / fy);
            let (mut x, mut y) = (xd, yd);
            for _ in 0..200 {
                let r2 = x * x + y * y;
                let radial = 1.0 + k1 * r2 + k2 * r2 * r2;
                let dx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
                let dy = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
                (x, y) = ((xd - dx) / radial, (yd - dy) / radial);
            }
            let q = [fx * x + cx, fy * y + cy];
            let u = lens.undistort(px).unwrap();
            worst = worst.max((u[0] - q[0]).hypot(u[1] - q[1]));
        }
    }
    assert!(
        (worst - max).abs() < 2e-3 * max.max(1.0),
        "recomputed {worst} vs reported {max}"
    );
}
