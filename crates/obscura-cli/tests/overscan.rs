//! End to end: `obscura render --overscan` as a compositor uses it. A plate's 3DEqualizer lens
//! (a strong barrel with decentring and an off-centre lens centre); the CG rendered through the lens;
//! the undistorted pinhole rendered overscanned (`--overscan auto`); Obscura's redistort ST-map
//! (`obscura stmap --from-undistorted`, Nuke's convention) applied to it as Nuke's STMap node does
//! (bilinear, `s, t` over the plate's display window, the data window reaching past it).

use std::path::Path;

use exr::prelude::{FlatImage, read_all_flat_layers_from_file};
use obscura_calibration::lens3de::{Kind, Lens};
use obscura_image::tiles::Overscan;

mod support;

use support::{channel, obscura, text};

/// The plate.
const W: u32 = 32;
const H: u32 = 18;

/// Samples per pixel: 256 = 16 × 16, so the owen-scrambled Sobol points put one sample in every
/// 1/16 × 1/16 square of the pixel, and the sample nearest the centre (whose direction the
/// `cameraDirection` AOV keeps) lies within √2/16 px of it.
const SPP: u32 = 256;

/// A strong 3DE lens on a 32 × 18 plate: barrel c2 = 0.2 and quartic 0.05 with decentring, the
/// lens centre off by (0.05, −0.03) cm.
const LENS: &str = r#"Root {
 format "32 18 0 0 32 18 1 plate"
}
LD_3DE4_Radial_Standard_Degree_4 {
 direction undistort
 tde4_focal_length_cm 2.0
 tde4_filmback_width_cm 2.4
 tde4_filmback_height_cm 1.35
 tde4_lens_center_offset_x_cm 0.05
 tde4_lens_center_offset_y_cm -0.03
 Distortion_Degree_2 0.2
 U_Degree_2 0.01
 V_Degree_2 -0.008
 Quartic_Distortion_Degree_4 0.05
 name LD_strong
}
"#;

fn run(args: &[&str]) {
    let out = obscura(args);
    assert!(out.status.success(), "{args:?}: {}", text(&out.stderr));
}

/// `cameraDirection` of every pixel, unit length.
fn directions(image: &FlatImage) -> Vec<[f64; 3]> {
    let (x, y, z) = (
        channel(image, "cameraDirection.X"),
        channel(image, "cameraDirection.Y"),
        channel(image, "cameraDirection.Z"),
    );
    (0..x.len())
        .map(|i| {
            let v = [f64::from(x[i]), f64::from(y[i]), f64::from(z[i])];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            assert!(n > 0.5, "pixel {i} has no camera direction: {v:?}");
            v.map(|c| c / n)
        })
        .collect()
}

fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2])
        .sqrt()
        .atan2(dot)
}

/// The Done-when loop of issue 26: the overscanned pinhole render, redistorted with Obscura's
/// ST-map, equals the render through the lens to within the resampling error, with every plate
/// pixel resampled from rendered pixels only (no black edge); the data window is the model's
/// undistorted box as Nuke pads it.
#[test]
fn an_overscanned_pinhole_redistorted_by_obscuras_stmap_is_the_render_through_the_lens() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    std::fs::write(p("lens.nk"), LENS).unwrap();
    // No geometry: cameraDirection is every sample's ray, hit or miss (sky and key light added).
    std::fs::write(p("empty.rib"), "WorldBegin\nWorldEnd\n").unwrap();
    let spp = SPP.to_string();
    let common = ["--calibration", &p("lens.nk"), "--spp", &spp, "--quiet"];
    run(&[&["render", &p("empty.rib")][..], &common, &["-o", &p("lens.exr")]].concat());
    run(&[
        &["render", &p("empty.rib")][..],
        &common,
        &["--overscan", "auto", "-o", &p("over.exr")],
    ]
    .concat());
    run(&[
        "stmap",
        "--from-calibration",
        &p("lens.nk"),
        "--from-undistorted",
        "--to-calibration",
        &p("lens.nk"),
        "-o",
        &p("redistort.exr"),
    ]);

    // The data window is the model's undistorted box of the plate, padded as Nuke pads it.
    let over = read_all_flat_layers_from_file(p("over.exr")).unwrap();
    let cal = obscura_calibration::files::load(Path::new(&p("lens.nk")), None).unwrap();
    let values: Vec<f64> = cal.params.iter().map(|n| f64::from(n.value as f32)).collect();
    let lens = Lens::new(Kind::RadialStandard4, &values, f64::from(W), f64::from(H)).unwrap();
    let bx = lens.undistorted_box(f64::from(W), f64::from(H)).unwrap();
    let want = Overscan::covering(bx, W, H).unwrap().data_window(W, H);
    let layer = &over.layer_data[0];
    let (x0, y0) = (
        layer.attributes.layer_position.0,
        layer.attributes.layer_position.1,
    );
    let (dw, dh) = (layer.size.0 as i32, layer.size.1 as i32);
    assert_eq!(
        (x0, y0, dw, dh),
        (
            want.position.0,
            want.position.1,
            want.size.0 as i32,
            want.size.1 as i32
        )
    );
    assert_eq!(
        over.attributes.display_window,
        exr::prelude::IntegerBounds::new((0, 0), (W as usize, H as usize)),
        "the display window is the plate"
    );
    // The box, checked against the lens's own undistort of the plate's corners and edge
    // midpoints: they lie inside it, and it is no more than the 2 px pad + 1 px of rounding wider.
    let edge_points = [
        [0.0, 0.0],
        [f64::from(W), 0.0],
        [0.0, f64::from(H)],
        [f64::from(W), f64::from(H)],
        [f64::from(W) / 2.0, 0.0],
        [0.0, f64::from(H) / 2.0],
    ];
    for q in edge_points.iter().map(|&e| lens.undistort(e).unwrap()) {
        assert!(
            f64::from(x0) + 2.0 <= q[0] && q[0] <= f64::from(x0 + dw) - 2.0,
            "{q:?}"
        );
        assert!(
            f64::from(y0) + 2.0 <= q[1] && q[1] <= f64::from(y0 + dh) - 2.0,
            "{q:?}"
        );
    }
    assert!(
        f64::from(x0) > bx[0] - 3.0 && f64::from(x0 + dw) < bx[2] + 3.0,
        "{bx:?}"
    );
    assert!(
        f64::from(y0) > bx[1] - 3.0 && f64::from(y0 + dh) < bx[3] + 3.0,
        "{bx:?}"
    );
    assert!(x0 < -3 && y0 < -3, "a strong barrel needs overscan: {x0}, {y0}");

    let through = read_all_flat_layers_from_file(p("lens.exr")).unwrap();
    let map = read_all_flat_layers_from_file(p("redistort.exr")).unwrap();
    let (s, t) = (channel(&map, "R"), channel(&map, "G"));
    let (want_dirs, over_dirs) = (directions(&through), directions(&over));
    // Nuke's STMap: the source position (s·W, (1 − t)·H) on the plate, bilinear between pixel
    // centres; the source's pixels are the data window's.
    let source = |n: usize| {
        [
            f64::from(s[n]) * f64::from(W),
            (1.0 - f64::from(t[n])) * f64::from(H),
        ]
    };
    let (mut worst, mut uncovered_without_overscan) = (0.0f64, 0);
    // The resampling error's bound. Each render's direction is its sample nearest the pixel
    // centre, within d = √2/16 px; the lens render's offset reaches the pinhole through the
    // undistort's Jacobian (largest stretch `stretch`, measured on the map), the pinhole's is
    // direct; bilinear interpolation of the smooth direction field adds h²/8·|f''| < 0.01 px. At
    // the pinhole's angular pitch ≤ 1/fx rad per px.
    let [fx, fy, _, _] = lens.pinhole();
    let mut stretch = 0.0f64;
    for j in 0..H as usize {
        for i in 0..W as usize - 1 {
            let n = j * W as usize + i;
            let (a, b) = (source(n), source(n + 1));
            stretch = stretch.max((b[0] - a[0]).hypot(b[1] - a[1]));
        }
    }
    let d = std::f64::consts::SQRT_2 / 16.0;
    let bound = (d * (1.0 + stretch) + 0.01) / fx.min(fy);
    for j in 0..H as usize {
        for i in 0..W as usize {
            let n = j * W as usize + i;
            let [x, y] = source(n);
            // The taps of the bilinear filter, as indices of the overscanned render's pixels.
            let (fxp, fyp) = (x - 0.5 - f64::from(x0), y - 0.5 - f64::from(y0));
            let (i0, j0) = (fxp.floor() as i32, fyp.floor() as i32);
            assert!(
                i0 >= 0 && j0 >= 0 && i0 + 1 < dw && j0 + 1 < dh,
                "plate pixel ({i}, {j}) reads ({x}, {y}) outside the data window: a black edge"
            );
            if x < 0.5 || y < 0.5 || x > f64::from(W) - 0.5 || y > f64::from(H) - 0.5 {
                uncovered_without_overscan += 1;
            }
            let (ax, ay) = (fxp - f64::from(i0), fyp - f64::from(j0));
            let at = |di: i32, dj: i32| over_dirs[((j0 + dj) * dw + i0 + di) as usize];
            let mut v = [0.0; 3];
            for (di, dj, wgt) in [
                (0, 0, (1.0 - ax) * (1.0 - ay)),
                (1, 0, ax * (1.0 - ay)),
                (0, 1, (1.0 - ax) * ay),
                (1, 1, ax * ay),
            ] {
                let a = at(di, dj);
                for k in 0..3 {
                    v[k] += wgt * a[k];
                }
            }
            worst = worst.max(angle(v, want_dirs[n]));
        }
    }
    eprintln!(
        "redistorted overscan vs through the lens: worst {worst:.3e} rad, bound {bound:.3e} rad ({:.3} px of the pinhole); stretch {stretch:.3}",
        worst * fx
    );
    assert!(worst <= bound, "worst {worst} rad > bound {bound} rad");
    // Half a pixel's shift would show: the bound is well under it.
    assert!(bound * fx < 0.45, "{bound}");
    // Without the overscan the plate's border would read outside the rendered frame.
    assert!(
        uncovered_without_overscan >= 2 * (W + H) as usize - 4,
        "{uncovered_without_overscan}"
    );
}

/// Without a lens, `--overscan PIXELS` renders the scene's own camera past the plate at the same
/// pixel pitch: the plate's pixels keep their rays, the PNG preview is the plate, the camera JSON
/// states the plate, the data window and the margins.
#[test]
fn a_given_overscan_extends_the_scenes_camera_at_the_same_pitch() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    std::fs::write(p("empty.rib"), "WorldBegin\nWorldEnd\n").unwrap();
    let common = [
        "render",
        &p("empty.rib"),
        "-p",
        "PxrPerspective",
        "--param",
        "fov=50",
        "--format",
        "16x9",
        "--spp",
        "256",
        "--quiet",
    ];
    run(&[&common[..], &["-o", &p("plate.exr")]].concat());
    run(&[
        &common[..],
        &["--overscan", "3,2,5,4", "--camera-json", "-o", &p("over.exr")],
    ]
    .concat());
    let over = read_all_flat_layers_from_file(p("over.exr")).unwrap();
    let plate = read_all_flat_layers_from_file(p("plate.exr")).unwrap();
    let layer = &over.layer_data[0];
    assert_eq!(layer.attributes.layer_position.0, -3);
    assert_eq!(layer.attributes.layer_position.1, -2);
    assert_eq!((layer.size.0, layer.size.1), (24, 15));
    assert_eq!(over.attributes.display_window.size.0, 16);
    assert_eq!(over.attributes.display_window.size.1, 9);
    let (a, b) = (directions(&plate), directions(&over));
    // fov 50° over the 9 px height (the shorter side): the pitch is at most tan(25°)/4.5 rad.
    let pitch = 25f64.to_radians().tan() / 4.5;
    let bound = 2.0 * std::f64::consts::SQRT_2 / 16.0 * pitch;
    let mut worst = 0.0f64;
    for j in 0..9 {
        for i in 0..16 {
            worst = worst.max(angle(a[j * 16 + i], b[(j + 2) * 24 + i + 3]));
        }
    }
    assert!(worst <= bound, "{worst} > {bound}");
    // The margin's pixels continue the pinhole: the overscan's first column (plate x = −2.5) is
    // the pinhole ray there, at its angle from the plate's first column (x = 0.5).
    let ray = |x: f64, y: f64| {
        let k = 25f64.to_radians().tan();
        let (sx, sy) = (-16.0 / 9.0 + x / 16.0 * 32.0 / 9.0, 1.0 - y / 9.0 * 2.0);
        let v = [sx * k, sy * k, 1.0];
        let n = (v[0] * v[0] + v[1] * v[1] + 1.0).sqrt();
        v.map(|c| c / n)
    };
    let want = angle(ray(-2.5, 0.5), ray(0.5, 0.5));
    assert!((angle(b[2 * 24], b[2 * 24 + 3]) - want).abs() <= bound, "{want}");
    let png = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(p("over.png")).unwrap(),
    ))
    .read_info()
    .unwrap();
    assert_eq!(
        (png.info().width, png.info().height),
        (16, 9),
        "the preview is the plate"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p("over.camera.json")).unwrap()).unwrap();
    assert_eq!(json["image"]["width"], 16);
    assert_eq!(json["image"]["data_window"], serde_json::json!([-3, -2, 21, 13]));
    assert_eq!(json["image"]["overscan"], serde_json::json!([3, 2, 5, 4]));
    assert_eq!(json["complete"], true);
}

/// What `--overscan` cannot do is said, naming the option.
#[test]
fn overscan_refusals_name_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    std::fs::write(p("empty.rib"), "WorldBegin\nWorldEnd\n").unwrap();
    let fails = |args: &[&str], want: &str| {
        let out = obscura(args);
        assert!(!out.status.success(), "{args:?}");
        let err = text(&out.stderr);
        assert!(err.contains(want), "{args:?}: {err}");
    };
    let render = ["render", &p("empty.rib"), "--format", "8x6", "--spp", "1", "-o"];
    fails(
        &[&render[..], &[&p("a.exr"), "--overscan", "auto"]].concat(),
        "--overscan auto sizes the margins from a lens",
    );
    fails(
        &[
            &render[..],
            &[
                &p("a.exr"),
                "--overscan",
                "4",
                "--calibration",
                &support::fixture("opencv_calibration.yml"),
            ],
        ]
        .concat(),
        "--overscan with --calibration needs a 3DEqualizer lens",
    );
    fails(
        &[&render[..], &[&p("a.exr"), "--overscan", "4", "--tile", "0/2"]].concat(),
        "cannot be used with",
    );
    fails(
        &[&render[..], &[&p("a.tif"), "--overscan", "4"]].concat(),
        "has no data window",
    );
    fails(
        &[&render[..], &[&p("a.exr"), "--overscan", "4,4"]].concat(),
        "'4,4' is not an overscan",
    );
}
