//! End to end: rendering through a lens given as an ST-map (`--projection StMapCamera`), as a user
//! runs it: `obscura stmap` writes the redistort map of the README's 3DE lens
//! (`examples/lens3de/plate_lens.nk`), `obscura rays` traces through that map and through the lens.

use std::path::{Path, PathBuf};

use exr::prelude::read_all_flat_layers_from_file;
use obscura_calibration::lens3de::{Kind, Lens};

mod support;

use support::{channel, obscura, text};

fn lens_file() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/lens3de/plate_lens.nk")
}

fn directions(path: &Path) -> Vec<[f64; 3]> {
    let image = read_all_flat_layers_from_file(path).unwrap();
    let (x, y, z) = (
        channel(&image, "direction.X"),
        channel(&image, "direction.Y"),
        channel(&image, "direction.Z"),
    );
    (0..x.len())
        .map(|k| [f64::from(x[k]), f64::from(y[k]), f64::from(z[k])])
        .collect()
}

fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let n = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let c = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    n(c).atan2(a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
}

/// Every pixel's ray through the lens's redistort ST-map equals its ray through the lens itself
/// (`--calibration`), within the bound of the library test
/// (`a_camera_through_the_redistort_map_of_a_3de_lens_has_the_lens_rays`): bilinear
/// interpolation of the map errs by at most ⅛ of the undistortion's second differences per axis
/// (taken as ⅜ of their sum, plus 1e-4 px of f32 map storage), over the pinhole's focal length in
/// pixels, plus 1e-6 rad for the f32 directions of the ray maps.
#[test]
fn rays_through_the_redistort_map_of_a_3de_lens_are_the_lens_rays() {
    let (w, h) = (96u32, 54u32);
    let calibration = obscura_calibration::files::load(&lens_file(), None).unwrap();
    let kind = Kind::from_name(&calibration.model).unwrap();
    let values: Vec<f64> = calibration.params.iter().map(|n| n.value).collect();
    let lens = Lens::new(kind, &values, f64::from(w), f64::from(h)).unwrap();
    let pinhole = lens.pinhole();
    let pinhole_text = pinhole.map(|v| format!("{v}")).join(" ");

    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("redistort.exr");
    let format = format!("{w}x{h}");
    let lens_arg = lens_file().display().to_string();
    let run = obscura(&[
        "stmap",
        "--from",
        "CalibratedCamera",
        "--from-param",
        "model=PINHOLE",
        "--from-param",
        &format!("params={pinhole_text}"),
        "--from-param",
        &format!("resolution={w} {h}"),
        "--to-calibration",
        &lens_arg,
        "--format",
        &format,
        "--from-format",
        &format,
        "-o",
        map.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", text(&run.stderr));

    let through_map = dir.path().join("stmap_rays.exr");
    let run = obscura(&[
        "rays",
        "--projection",
        "StMapCamera",
        "--param",
        &format!("map={}", map.display()),
        "--param",
        &format!("pinhole={pinhole_text}"),
        "--format",
        &format,
        "-o",
        through_map.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    assert!(
        text(&run.stdout).contains("of StMapCamera"),
        "{}",
        text(&run.stdout)
    );
    let through_lens = dir.path().join("lens_rays.exr");
    let run = obscura(&[
        "rays",
        "--calibration",
        &lens_arg,
        "--format",
        &format,
        "-o",
        through_lens.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", text(&run.stderr));

    // The library test's bound, from this lens's undistortion at this raster.
    let mut q2 = [0.0f64; 2];
    for j in 1..h - 1 {
        for i in 1..w - 1 {
            let u = |dx: f64, dy: f64| lens.undistort([f64::from(i) + dx, f64::from(j) + dy]).unwrap();
            let (c, xp, xm, yp, ym) = (u(0.0, 0.0), u(1.0, 0.0), u(-1.0, 0.0), u(0.0, 1.0), u(0.0, -1.0));
            for k in 0..2 {
                q2[0] = q2[0].max((xp[k] - 2.0 * c[k] + xm[k]).abs());
                q2[1] = q2[1].max((yp[k] - 2.0 * c[k] + ym[k]).abs());
            }
        }
    }
    let bound = (1e-4 + 0.375 * (q2[0] + q2[1])) / pinhole[0].min(pinhole[1]) + 1e-6;

    let (got, want) = (directions(&through_map), directions(&through_lens));
    assert_eq!(got.len(), (w * h) as usize);
    assert_eq!(want.len(), got.len());
    let worst = got
        .iter()
        .zip(&want)
        .map(|(g, r)| angle(*g, *r))
        .fold(0.0, f64::max);
    eprintln!(
        "StMapCamera (pinhole {pinhole_text}) vs the 3DE lens through obscura rays: worst {worst:.3e} rad (bound {bound:.3e})"
    );
    assert!(worst < bound, "{worst} rad > {bound}");
    // Not a vacuous match: the lens bends rays by far more than the bound.
    let pinhole_only = (0..h).flat_map(|j| (0..w).map(move |i| (i, j))).map(|(i, j)| {
        [
            (f64::from(i) + 0.5 - pinhole[2]) / pinhole[0],
            -(f64::from(j) + 0.5 - pinhole[3]) / pinhole[1],
            1.0,
        ]
    });
    let bend = pinhole_only
        .zip(&want)
        .map(|(p, r)| angle(p, *r))
        .fold(0.0, f64::max);
    assert!(bend > 100.0 * bound, "the lens bends rays by {bend} rad only");
}

/// A missing map is an error naming the file, from `rays`, `check` and `render` alike; a missing
/// `map` parameter says it is required.
#[test]
fn a_missing_map_is_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no_such_map.exr");
    let out = dir.path().join("rays.exr");
    let map = format!("map={}", missing.display());
    for args in [
        vec![
            "rays",
            "--projection",
            "StMapCamera",
            "--param",
            &map,
            "--param",
            "pinhole=100 100 48 27",
            "--format",
            "96x54",
            "-o",
            out.to_str().unwrap(),
        ],
        vec![
            "check",
            "StMapCamera",
            "--param",
            &map,
            "--param",
            "pinhole=100 100 48 27",
        ],
    ] {
        let run = obscura(&args);
        assert!(!run.status.success(), "{args:?} succeeded");
        let err = text(&run.stderr);
        assert!(err.contains("no_such_map.exr"), "{args:?}: {err}");
        assert!(err.contains("StMapCamera"), "{args:?}: {err}");
    }
    assert!(!out.exists());
    let run = obscura(&["rays", "--projection", "StMapCamera", "-o", out.to_str().unwrap()]);
    assert!(!run.status.success());
    let err = text(&run.stderr);
    assert!(err.contains("map is required"), "{err}");
}
