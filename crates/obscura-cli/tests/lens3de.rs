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
