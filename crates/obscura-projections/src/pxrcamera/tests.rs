//! Tests of `PxrCamera`: the pinhole and thin lens, distortion, vignetting, the focal plane, shutter
//! and properties.

use super::*;
use crate::testing::{
    self, ContractTest, assert_camera_z, assert_contract, assert_lens_properties, assert_refused,
};
use obscura_sdk::{Format, ParamList, ProjectionFactory};
use proptest::prelude::*;

fn try_make(params: &[(&str, &str)], format: Format) -> Result<Box<dyn Projection>, PluginError> {
    testing::try_make(&PxrCameraFactory, params, format)
}

fn make(params: &[(&str, &str)], format: Format) -> Box<dyn Projection> {
    try_make(params, format).unwrap()
}

/// Projects one batch; returns the rays, the rewritten times and the tints.
fn run(
    p: &dyn Projection,
    screen: &[Point2],
    aperture: &[Point2],
    time: &[f32],
) -> (Vec<RayGeometry>, Vec<f32>, Vec<Rgb>) {
    testing::project_batch(p, screen, aperture, time)
}

fn one(p: &dyn Projection, s: Point2, a: Point2, t: f32) -> (RayGeometry, f32, Rgb) {
    let (r, t, c) = run(p, &[s], &[a], &[t]);
    (r[0], t[0], c[0])
}

fn f64v(v: Vec3) -> [f64; 3] {
    [v.x as f64, v.y as f64, v.z as f64]
}

fn fmt(x: f32) -> String {
    format!("{x}")
}

/// The plane-of-focus normal from tilt and roll, written out independently of `focal_plane`.
fn plane_normal(tilt: f64, roll: f64) -> [f64; 3] {
    let (t, r) = (tilt.to_radians(), roll.to_radians());
    [t.sin() * r.sin(), t.sin() * r.cos(), t.cos()]
}

/// Where the line of ray `r` meets the plane `n·X = delta`.
fn meet(r: &RayGeometry, n: [f64; 3], delta: f64) -> [f64; 3] {
    let (o, d) = (f64v(r.origin), f64v(r.direction));
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let t = (delta - dot(n, o)) / dot(n, d);
    [o[0] + d[0] * t, o[1] + d[1] * t, o[2] + d[2] * t]
}

fn dist3(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

proptest! {
    #[test]
    fn chief_rays_match_an_independent_f64_formula(
        fov in 20.0f32..150.0, shift in (-0.3f32..0.3, -0.3f32..0.3),
        k1 in -0.2f32..0.2, k2 in -0.05f32..0.05, ax in -0.05f32..0.05, ay in -0.05f32..0.05, sq in 0.7f32..1.5,
        e in (-0.5f32..0.5, -0.5f32..0.5, 0.5f32..4.0), sx in -2.0f32..2.0, sy in -1.2f32..1.2,
    ) {
        let p = make(&[
            ("float fov", &fmt(fov)), ("float shiftX", &fmt(shift.0)), ("float shiftY", &fmt(shift.1)),
            ("float radial1", &fmt(k1)), ("float radial2", &fmt(k2)), ("float assymX", &fmt(ax)),
            ("float assymY", &fmt(ay)), ("float squeeze", &fmt(sq)),
            ("float[3] enhance", &format!("{} {} {}", e.0, e.1, e.2)),
        ], Format::new(64, 48));
        let (r, _, _) = one(p.as_ref(), Point2::new(sx, sy), Point2::ZERO, 0.0);
        let (k1, k2, ax, ay, sq) = (k1 as f64, k2 as f64, ax as f64, ay as f64, sq as f64);
        let x = e.0 as f64 + sx as f64 / e.2 as f64 + shift.0 as f64;
        let y = e.1 as f64 + sy as f64 / e.2 as f64 + shift.1 as f64;
        let q = (x / sq).powi(2) + y * y;
        // Beyond the fold: some radius up to this one has a non-positive denominator or a
        // non-rising radial profile on one of the axes.
        let broken = |q: f64| [k1 + ax, k1 + ay].iter().any(|&c| 1.0 + c * q + k2 * q * q <= 0.0 || 1.0 - c * q - 3.0 * k2 * q * q <= 0.0);
        let folds_before = |q_end: f64| (0..=2000).any(|i| broken(q_end * i as f64 / 2000.0));
        if r.is_culled() {
            prop_assert!(folds_before(q * (1.0 + 1e-4)), "culled at q {} though the map is monotonic there", q);
        } else {
            prop_assert!(!folds_before(q * (1.0 - 1e-4)), "kept a sample beyond the fold, q {}", q);
            let dx = 1.0 + (k1 + ax) * q + k2 * q * q;
            let dy = 1.0 + (k1 + ay) * q + k2 * q * q;
            let d = 1.0 / (fov as f64 / 2.0).to_radians().tan();
            let v = [x / dx, y / dy, d];
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            let got = f64v(r.direction);
            for k in 0..3 {
                prop_assert!((got[k] - v[k] / l).abs() < 2e-5, "{:?} vs {:?}", got, v.map(|c| c / l));
            }
            prop_assert_eq!(r.origin, Vec3::ZERO);
        }
    }

    #[test]
    fn thin_lens_rays_of_one_screen_point_meet_on_the_tilted_focal_plane(
        tilt in -60.0f64..60.0, roll in -180.0f64..180.0, fd in 0.5f64..50.0, f_stop in 1.0f32..16.0,
        sx in -1.4f32..1.4, sy in -1.0f32..1.0, k1 in -0.1f32..0.1,
        apertures in proptest::collection::vec((-1.0f32..1.0, -1.0f32..1.0), 4),
    ) {
        let p = make(&[
            ("float fov", "60"), ("float fStop", &fmt(f_stop)), ("float focalLength", "0.2"),
            ("float focalDistance", &fd.to_string()), ("float tilt", &tilt.to_string()),
            ("float roll", &roll.to_string()), ("float radial1", &fmt(k1)),
        ], Format::new(64, 48));
        let n = plane_normal(tilt, roll);
        let delta = fd * tilt.to_radians().cos();
        let s = Point2::new(sx, sy);
        let (chief, _, _) = one(p.as_ref(), s, Point2::ZERO, 0.0);
        prop_assume!(!chief.is_culled());
        let w = f64v(chief.direction);
        let nw = n[0] * w[0] + n[1] * w[1] + n[2] * w[2];
        prop_assume!(nw.abs() > 0.05);
        // The focus point: the chief ray meets the plane (in front, or behind for a virtual focus).
        let focus = w.map(|c| c * delta / nw);
        let scale = 1.0 + focus.iter().map(|c| c.abs()).fold(0.0, f64::max);
        for (ax, ay) in apertures {
            let (r, _, _) = one(p.as_ref(), s, Point2::new(ax, ay), 0.0);
            let radius = 0.5 * 0.2 / f_stop as f64;
            prop_assert!((r.origin.x as f64 - radius * ax as f64).abs() < 1e-6);
            prop_assert!((r.origin.y as f64 - radius * ay as f64).abs() < 1e-6);
            let hit = meet(&r, n, delta);
            prop_assert!(dist3(hit, focus) < 2e-5 * scale * scale / radius.clamp(0.05, 1.0), "{:?} vs {:?}", hit, focus);
        }
    }

    #[test]
    fn unproject_inverts_project_to_a_ten_thousandth_of_a_pixel(
        k1 in -0.12f32..0.12, k2 in -0.015f32..0.015, ax in -0.04f32..0.04, sq in 0.8f32..1.3,
        shift in (-0.2f32..0.2, -0.2f32..0.2), e in (-0.3f32..0.3, -0.3f32..0.3, 0.5f32..2.0),
        g in 0.9f32..1.1, t in 0.0f32..1.0, depth in 0.5f32..40.0,
        fx in 0.0f64..320.0, fy in 0.0f64..240.0,
    ) {
        let format = Format::new(320, 240);
        let p = make(&[
            ("float fov", "55"), ("float fovEnd", "40"),
            ("float radial1", &fmt(k1)), ("float radial2", &fmt(k2)), ("float assymX", &fmt(ax)),
            ("float squeeze", &fmt(sq)), ("float shiftX", &fmt(shift.0)), ("float shiftY", &fmt(shift.1)),
            ("float[3] enhance", &format!("{} {} {}", e.0, e.1, e.2)),
            ("color transverse", &format!("{g} {g} {g}")),
            ("float fStop", "2"), ("float focalLength", "0.1"), ("float focalDistance", "3"),
        ], format);
        let window = obscura_sdk::ScreenWindow::default_for(format);
        let s = window.raster_to_screen(format, fx, fy);
        let (r, t2, _) = one(p.as_ref(), s, Point2::ZERO, t);
        prop_assume!(!r.is_culled());
        // Close to a fold the radial profile flattens and a few f32 ulps of direction are more
        // than 1e-4 pixel of screen: keep to where the profile still rises at half its rate at
        // the centre (1 − c·q − 3·k2·q² on both axes ≥ 0.5). The f64 inverse itself is exact
        // everywhere (`distortion` tests).
        let x = (e.0 + s.x / e.2 + shift.0) as f64 / g as f64;
        let y = (e.1 + s.y / e.2 + shift.1) as f64 / g as f64;
        let q = (x / sq as f64).powi(2) + y * y;
        let (k1, k2) = (k1 as f64, k2 as f64);
        prop_assume!([k1 + ax as f64, k1].iter().all(|c| 1.0 - c * q - 3.0 * k2 * q * q >= 0.5));
        let back = p.unproject(r.origin + r.direction * depth, t2).expect("a point the camera sees");
        let (bx, by) = window.screen_to_raster(format, back);
        prop_assert!((bx - fx).abs() < 1e-4 && (by - fy).abs() < 1e-4, "({}, {}) vs ({}, {})", bx, by, fx, fy);
    }
}

#[test]
fn focus_points_reproduce_the_plane_of_tilt_roll_and_focal_distance() {
    let (tilt, roll, fd) = (25.0f64, 30.0f64, 6.0f64);
    let n = plane_normal(tilt, roll);
    let delta = fd * tilt.to_radians().cos();
    let on = |x: f64, y: f64| {
        let z = (delta - n[0] * x - n[1] * y) / n[2];
        format!("{x} {y} {z}")
    };
    let lens = [("float fStop", "2.8"), ("float focalLength", "0.1")];
    let mut by_points = lens.to_vec();
    let (p1, p2, p3) = (on(0.5, 0.2), on(-2.0, 1.0), on(1.0, -3.0));
    by_points.extend([
        ("point focus1", p1.as_str()),
        ("point focus2", p2.as_str()),
        ("point focus3", p3.as_str()),
    ]);
    // tilt given too: the points win, as in RenderMan.
    by_points.push(("float tilt", "-10"));
    let mut by_angles = lens.to_vec();
    let (t, r, f) = (tilt.to_string(), roll.to_string(), fd.to_string());
    by_angles.extend([
        ("float tilt", t.as_str()),
        ("float roll", r.as_str()),
        ("float focalDistance", f.as_str()),
    ]);
    let format = Format::new(32, 32);
    let (a, b) = (make(&by_points, format), make(&by_angles, format));
    match a.property(ProjectionProperty::FocalDistance) {
        Some(PropertyValue::Float(got)) => assert!((got as f64 - fd).abs() < 1e-4, "{got}"),
        other => panic!("{other:?}"),
    }
    for i in 0..50 {
        let s = Point2::new((i as f32 * 0.37).sin(), (i as f32 * 0.71).cos());
        let ap = Point2::new((i as f32 * 1.3).cos(), (i as f32 * 0.9).sin() * 0.8);
        let (ra, _, _) = one(a.as_ref(), s, ap, 0.0);
        let (rb, _, _) = one(b.as_ref(), s, ap, 0.0);
        assert!((ra.direction - rb.direction).length() < 1e-5, "{ra:?} vs {rb:?}");
        assert_eq!(ra.origin, rb.origin);
    }
}

#[test]
fn bad_focus_points_are_refused_naming_the_parameters() {
    let format = Format::new(8, 8);
    let err = |params: &[(&str, &str)]| try_make(params, format).err().expect("refused").to_string();
    let collinear = err(&[
        ("point focus1", "0 0 1"),
        ("point focus2", "1 1 2"),
        ("point focus3", "2 2 3"),
    ]);
    assert!(collinear.starts_with("PxrCamera: "), "{collinear}");
    assert!(
        collinear.contains("collinear")
            && collinear.contains("focus1 (0, 0, 1)")
            && collinear.contains("focus3"),
        "{collinear}"
    );
    let through = err(&[
        ("point focus1", "1 0 1"),
        ("point focus2", "-1 0 -1"),
        ("point focus3", "0 1 0"),
    ]);
    assert!(through.contains("passes through the camera"), "{through}");
    let parallel = err(&[
        ("point focus1", "1 0 1"),
        ("point focus2", "1 1 5"),
        ("point focus3", "1 -1 3"),
    ]);
    assert!(parallel.contains("parallel to the view"), "{parallel}");
    let partial = err(&[("point focus1", "0 0 1"), ("point focus3", "1 0 2")]);
    assert!(partial.contains("only focus1 and focus3 were given"), "{partial}");
}

#[test]
fn chromatic_tints_average_to_white_and_each_channel_has_its_own_lens() {
    let format = Format::new(64, 64);
    let transverse = [0.97f64, 1.0, 1.03];
    let axial = [0.3f64, 0.0, -0.2];
    let p = make(
        &[
            ("float fov", "50"),
            ("color transverse", "0.97 1 1.03"),
            ("color axial", "0.3 0 -0.2"),
            ("float fStop", "2"),
            ("float focalLength", "0.2"),
            ("float focalDistance", "4"),
        ],
        format,
    );
    let n = 30_000;
    let screen: Vec<Point2> = (0..n)
        .map(|i| {
            Point2::new(
                ((i as f32 * 0.618_034).fract() * 2.0 - 1.0) * 1.2,
                (i as f32 * 0.754_877_7).fract() * 2.0 - 1.0,
            )
        })
        .collect();
    let aperture: Vec<Point2> = (0..n)
        .map(|i| Point2::new((i as f32 * 0.31).sin(), (i as f32 * 0.47).cos() * 0.7))
        .collect();
    let (rays, _, tints) = run(p.as_ref(), &screen, &aperture, &vec![0.0; n]);
    let mut sum = [0.0f64; 3];
    let d = 1.0 / 25f64.to_radians().tan();
    for ((s, r), c) in screen.iter().zip(&rays).zip(&tints) {
        let rgb = [c.r, c.g, c.b];
        let ch = (0..3).find(|&k| rgb[k] != 0.0).unwrap();
        assert_eq!(rgb.iter().filter(|&&v| v != 0.0).count(), 1);
        assert_eq!(rgb[ch], 3.0);
        for k in 0..3 {
            sum[k] += rgb[k] as f64;
        }
        // The channel's chief ray is magnified by transverse[c], and its lens focuses at
        // focalDistance + axial[c].
        let w = [s.x as f64 / transverse[ch], s.y as f64 / transverse[ch], d];
        let fz = 4.0 + axial[ch];
        let focus = [w[0] * fz / d, w[1] * fz / d, fz];
        let hit = meet(r, [0.0, 0.0, 1.0], fz);
        assert!(dist3(hit, focus) < 1e-4, "channel {ch}: {hit:?} vs {focus:?}");
    }
    for (k, total) in sum.iter().enumerate() {
        let mean = total / n as f64;
        assert!((mean - 1.0).abs() < 0.03, "channel {k} mean tint {mean}");
    }
    // The channel does not depend on the lens or time samples.
    let s = [Point2::new(0.3, 0.2); 2];
    let (_, _, c) = run(
        p.as_ref(),
        &s,
        &[Point2::new(0.5, 0.5), Point2::new(-0.9, 0.1)],
        &[0.1, 0.9],
    );
    assert_eq!(c[0], c[1]);
    // Without aberration nothing is tinted.
    let plain = make(&[("color transverse", "1.02 1.02 1.02")], format);
    let (_, _, c) = run(plain.as_ref(), &screen[..100], &aperture[..100], &[0.0; 100]);
    assert!(c.iter().all(|c| *c == Rgb::WHITE));
}

#[test]
fn natural_vignetting_is_cos4_of_the_chief_ray() {
    let format = Format::new(64, 64);
    let full = make(
        &[
            ("float fov", "100"),
            ("float natural", "1"),
            ("float radial1", "-0.05"),
        ],
        format,
    );
    let half = make(
        &[
            ("float fov", "100"),
            ("float natural", "0.5"),
            ("float radial1", "-0.05"),
        ],
        format,
    );
    for i in 0..200 {
        let s = Point2::new((i as f32 * 0.13).sin() * 1.5, (i as f32 * 0.29).cos());
        let (r, _, c) = one(full.as_ref(), s, Point2::ZERO, 0.0);
        let cos4 = (r.direction.z as f64).powi(4);
        assert!(
            (c.r as f64 - cos4).abs() < 1e-6 && c.r == c.g && c.g == c.b,
            "{c:?} vs {cos4}"
        );
        let (_, _, c) = one(half.as_ref(), s, Point2::ZERO, 0.0);
        assert!((c.g as f64 - (1.0 + cos4) / 2.0).abs() < 1e-6);
    }
}

#[test]
fn optical_vignetting_darkens_toward_the_corners_and_clips_the_aperture() {
    let format = Format::new(64, 48);
    let optical = 0.8f64;
    let p = make(
        &[
            ("float fov", "90"),
            ("float optical", "0.8"),
            ("float fStop", "2"),
            ("float focalLength", "0.2"),
            ("float focalDistance", "5"),
        ],
        format,
    );
    let radius = 0.05f64;
    let mut last = f64::INFINITY;
    for i in 0..=40 {
        let f = i as f32 / 40.0;
        let s = Point2::new(f * 4.0 / 3.0, f);
        let (r, _, c) = one(p.as_ref(), s, Point2::new(0.2, -0.3), 0.0);
        // Independent area fraction of two unit disks at distance δ = optical·tanθ (d = 1).
        let dist = optical * ((s.x as f64).powi(2) + (s.y as f64).powi(2)).sqrt();
        let expected = if dist >= 2.0 {
            0.0
        } else {
            (2.0 * (dist / 2.0).acos() - dist / 2.0 * (4.0 - dist * dist).sqrt()) / std::f64::consts::PI
        };
        assert!(
            (c.r as f64 - expected).abs() < 1e-5,
            "at {s:?}: {} vs {expected}",
            c.r
        );
        assert!(
            c.r as f64 <= last && (i == 0 || (c.r as f64) < last),
            "not darker toward the corner at {s:?}"
        );
        last = c.r as f64;
        // The lens point lies inside the aperture and inside the clipping disk.
        let o = [r.origin.x as f64 / radius, r.origin.y as f64 / radius];
        let b = [-optical * s.x as f64, -optical * s.y as f64];
        assert!(o[0].hypot(o[1]) <= 1.0 + 1e-4, "outside the aperture at {s:?}");
        assert!(
            (o[0] - b[0]).hypot(o[1] - b[1]) <= 1.0 + 1e-4,
            "outside the clipping disk at {s:?}"
        );
    }
    // The bokeh is clipped, not the focus: every lens ray still meets the chief ray's focus point.
    let s = Point2::new(0.9, 0.6);
    let (chief, _, _) = one(
        make(&[("float fov", "90")], format).as_ref(),
        s,
        Point2::ZERO,
        0.0,
    );
    let w = f64v(chief.direction);
    let focus = w.map(|c| c * 5.0 / w[2]);
    for a in [
        Point2::new(0.9, 0.0),
        Point2::new(-0.5, 0.5),
        Point2::new(0.0, -1.0),
    ] {
        let (r, _, _) = one(p.as_ref(), s, a, 0.0);
        assert!(dist3(meet(&r, [0.0, 0.0, 1.0], 5.0), focus) < 1e-4);
    }
}

#[test]
fn rolling_shutter_rewrites_time_by_screen_position() {
    let format = Format::new(40, 20);
    let window = obscura_sdk::ScreenWindow::default_for(format);
    for (sweep, pos) in [
        ("down", (|s: Point2| (1.0 - s.y) / 2.0) as fn(Point2) -> f32),
        ("up", |s: Point2| (s.y + 1.0) / 2.0),
        ("left", |s: Point2| (2.0 - s.x) / 4.0),
        ("right", |s: Point2| (s.x + 2.0) / 4.0),
    ] {
        let p = make(&[("string sweep", sweep), ("float duration", "0.25")], format);
        assert_eq!((window.left, window.right), (-2.0, 2.0));
        for i in 0..50 {
            let s = Point2::new((i as f32 * 0.37).sin() * 2.0, (i as f32 * 0.53).cos());
            let t = (i as f32 * 0.618).fract();
            let (r, t2, _) = one(p.as_ref(), s, Point2::ZERO, t);
            let expected = pos(s) * 0.75 + t * 0.25;
            assert!(
                (t2 - expected).abs() < 1e-6,
                "{sweep} at {s:?}: {t2} vs {expected}"
            );
            assert!(!r.is_culled());
        }
    }
    // An ideal rolling shutter at the last line still keeps time below 1.
    let p = make(&[("float duration", "0")], format);
    let (_, t, _) = one(p.as_ref(), Point2::new(0.0, -1.5), Point2::ZERO, 0.999);
    assert!(t < 1.0 && t > 0.999_99);
    // Global shutter: time untouched.
    let p = make(&[], format);
    assert_eq!(one(p.as_ref(), Point2::new(0.3, 0.9), Point2::ZERO, 0.4).1, 0.4);
}

#[test]
fn enhance_zooms_into_the_unenhanced_image() {
    let format = Format::new(64, 48);
    let base = [
        ("float fov", "70"),
        ("float radial1", "-0.08"),
        ("float shiftX", "0.1"),
    ];
    let mut zoomed = base.to_vec();
    zoomed.push(("float[3] enhance", "0.3 -0.2 4"));
    let (a, b) = (make(&zoomed, format), make(&base, format));
    for i in 0..100 {
        let s = Point2::new((i as f32 * 0.41).sin() * 1.3, (i as f32 * 0.23).cos());
        let (ra, _, _) = one(a.as_ref(), s, Point2::ZERO, 0.0);
        let (rb, _, _) = one(
            b.as_ref(),
            Point2::new(0.3 + s.x / 4.0, -0.2 + s.y / 4.0),
            Point2::ZERO,
            0.0,
        );
        assert!((ra.direction - rb.direction).length() < 1e-6);
        // The footprint is the true one: a pixel covers a quarter of the angle.
        assert!((ra.ray_spread / rb.ray_spread - 0.25).abs() < 1e-5);
    }
    // Dicing is that of the un-enhanced camera.
    assert_eq!(
        a.property(ProjectionProperty::FieldOfView),
        b.property(ProjectionProperty::FieldOfView)
    );
}

#[test]
fn field_of_view_is_the_angle_the_rays_span() {
    let format = Format::new(64, 48);
    let fov = |params: &[(&str, &str)]| match make(params, format).property(ProjectionProperty::FieldOfView) {
        Some(PropertyValue::Float(f)) => f64::from(f),
        other => panic!("{other:?}"),
    };
    let half = (35f64).to_radians().tan();
    // Radial distortion: the square's edge (radius 1) is imaged from ideal radius 1/(1 + k1 + k2).
    for (k1, k2) in [(-0.2, 0.0), (0.15, 0.0), (0.05, -0.02)] {
        let want = 2.0 * (half / (1.0 + k1 + k2)).atan().to_degrees();
        let got = fov(&[
            ("float fov", "70"),
            ("float radial1", &k1.to_string()),
            ("float radial2", &k2.to_string()),
        ]);
        assert!((got - want).abs() < 1e-3, "k1 {k1} k2 {k2}: {got} vs {want}");
    }
    // Shift: the angle between the rays through (−1 + s, 0) and (1 + s, 0) on the plane at 1/half.
    let s = 0.4;
    let want = ((1.0 + s) * half).atan().to_degrees() - ((-1.0 + s) * half).atan().to_degrees();
    let got = fov(&[("float fov", "70"), ("float shiftX", "0.4")]);
    assert!((got - want).abs() < 1e-3, "{got} vs {want}");
    // The x axis alone is distorted: the undistorted y pair is the narrower.
    assert!((fov(&[("float fov", "70"), ("float assymX", "-0.3")]) - 70.0).abs() < 1e-3);
    // Green magnified by 1.1: the square sees 1/1.1 of the ideal plane.
    let want = 2.0 * (half / 1.1).atan().to_degrees();
    let got = fov(&[("float fov", "70"), ("color transverse", "1 1.1 1")]);
    assert!((got - want).abs() < 1e-3, "{got} vs {want}");
    // Without any of those, exactly fov (the narrower end of a zoom).
    assert_eq!(fov(&[("float fov", "70"), ("float fovEnd", "60")]), 60.0);
}

#[test]
fn shift_moves_the_view_without_converging_verticals() {
    let format = Format::new(64, 48);
    let p = make(&[("float shiftY", "0.5")], format);
    let (r, _, _) = one(p.as_ref(), Point2::ZERO, Point2::ZERO, 0.0);
    assert!((r.direction.y / r.direction.z - 0.5).abs() < 1e-6);
    // A vertical screen line stays a vertical plane of directions: x/z constant along it.
    let ratios: Vec<f32> = (0..10)
        .map(|i| {
            let (r, _, _) = one(
                p.as_ref(),
                Point2::new(0.7, -1.0 + 0.2 * i as f32),
                Point2::ZERO,
                0.0,
            );
            r.direction.x / r.direction.z
        })
        .collect();
    assert!(ratios.iter().all(|x| (x - 0.7).abs() < 1e-6), "{ratios:?}");
}

#[test]
fn nothing_is_nan_over_the_window_even_with_extreme_parameters() {
    let format = Format::new(48, 32);
    let window = obscura_sdk::ScreenWindow::default_for(format);
    let configs: &[&[(&str, &str)]] = &[
        &[("float fov", "179.99")],
        &[("float fov", "0.001"), ("float fovEnd", "179.9")],
        &[("float radial1", "100")],
        &[("float radial1", "-100"), ("float radial2", "-50")],
        &[
            ("float radial1", "-0.5"),
            ("float radial2", "0.01"),
            ("float assymX", "3"),
            ("float assymY", "-3"),
        ],
        &[("float radial1", "0.2"), ("float squeeze", "0.001")],
        &[("float radial1", "0.2"), ("float squeeze", "1000")],
        &[("float[3] enhance", "1e6 -1e6 1e-6")],
        &[("float[3] enhance", "0 0 1e30"), ("float radial1", "0.1")],
        &[("float shiftX", "1e30"), ("float shiftY", "-1e30")],
        &[
            ("color transverse", "1e-6 1 1e6"),
            ("color axial", "1e9 0 -0.999"),
            ("float fStop", "1"),
            ("float focalLength", "1"),
        ],
        &[
            ("float fStop", "1e-6"),
            ("float focalLength", "1e6"),
            ("float focalDistance", "1e-6"),
            ("float tilt", "89"),
            ("float roll", "1e6"),
        ],
        &[
            ("float fStop", "0.5"),
            ("float focalLength", "1"),
            ("float focalDistance", "1e30"),
            ("float tilt", "-89"),
            ("float optical", "1e9"),
            ("float natural", "1"),
        ],
        &[
            ("float optical", "1e30"),
            ("float natural", "1"),
            ("float fov", "179"),
        ],
        &[
            ("float duration", "0"),
            ("string sweep", "left"),
            ("float fovEnd", "1"),
        ],
        &[
            ("point focus1", "0 0 0.01"),
            ("point focus2", "1 0 0.01"),
            ("point focus3", "0 1 50"),
            ("float fStop", "1"),
            ("float focalLength", "10"),
        ],
    ];
    let mut screen = Vec::new();
    for j in -2..=34 {
        for i in -2..=50 {
            screen.push(window.raster_to_screen(format, i as f64, j as f64));
        }
    }
    screen.extend([
        Point2::new(1e30, -1e30),
        Point2::new(-3e38, 3e38),
        Point2::new(0.0, 1e-38),
    ]);
    let n = screen.len();
    let aperture: Vec<Point2> = (0..n)
        .map(|i| Point2::new((i as f32 * 0.7).sin(), (i as f32 * 0.3).cos()))
        .collect();
    let times: Vec<f32> = (0..n)
        .map(|i| (i as f32 * 0.618_034).fract().min(0.999_999))
        .collect();
    for params in configs {
        let p = try_make(params, format).unwrap_or_else(|e| panic!("{params:?}: {e}"));
        let (rays, ts, tints) = run(p.as_ref(), &screen, &aperture, &times);
        for ((r, t), c) in rays.iter().zip(&ts).zip(&tints) {
            let at = format!("{params:?}: {r:?} {c:?} {t}");
            assert!(
                r.origin.is_finite() && r.direction.is_finite() && r.ray_spread.is_finite(),
                "{at}"
            );
            assert!(
                r.ray_spread >= 0.0
                    && r.min_dist >= 0.0
                    && r.min_dist.is_finite()
                    && r.min_dist <= r.max_dist,
                "{at}"
            );
            assert!(r.is_culled() || (r.direction.length() - 1.0).abs() < 1e-5, "{at}");
            assert!(c.is_finite() && c.r >= 0.0 && c.g >= 0.0 && c.b >= 0.0, "{at}");
            assert!((0.0..1.0).contains(t), "{at}");
        }
        for s in &screen[..200] {
            if let Some(b) = p.unproject(Vec3::new(s.x, s.y, 1.0), 0.5) {
                assert!(b.x.is_finite() && b.y.is_finite());
            }
        }
    }
}

#[test]
fn the_contract_holds_for_several_configurations() {
    let format = Format::new(48, 32);
    let configs: &[&[(&str, &str)]] = &[
        &[],
        &[
            ("float fov", "40"),
            ("float radial1", "-0.12"),
            ("float radial2", "0.01"),
            ("float shiftX", "0.1"),
            ("float shiftY", "-0.05"),
            ("float squeeze", "1.2"),
            ("float assymX", "0.03"),
        ],
        &[
            ("float fov", "60"),
            ("float fovEnd", "45"),
            ("float radial1", "0.08"),
            ("float assymY", "-0.02"),
            ("float[3] enhance", "0.2 0.1 2"),
        ],
        &[
            ("float fStop", "2.8"),
            ("float focalLength", "0.05"),
            ("float focalDistance", "3"),
            ("float tilt", "20"),
            ("float roll", "30"),
            ("float natural", "1"),
            ("float radial1", "-0.05"),
        ],
        &[
            ("float optical", "0.7"),
            ("float natural", "0.5"),
            ("float duration", "0.3"),
            ("string sweep", "left"),
        ],
    ];
    for params in configs {
        let p = make(params, format);
        let stats = assert_contract(p.as_ref(), &ContractTest::new(format));
        assert!(
            stats.valid == stats.samples && stats.spread_checked > 1500 && stats.roundtrips > 1500,
            "{params:?}: {stats:?}"
        );
    }
    // A pincushion strong enough to fold inside the window culls the samples beyond the fold and keeps
    // the contract on the rest.
    let folded = make(&[("float radial1", "0.4")], format);
    let mut t = ContractTest::new(format);
    t.roundtrip_px = 1e-3;
    let stats = assert_contract(folded.as_ref(), &t);
    assert!(
        stats.valid < stats.samples && stats.valid > stats.samples / 2,
        "{stats:?}"
    );
}

#[test]
fn properties_are_honest() {
    let format = Format::new(8, 8);
    let pin = make(&[("float fov", "50"), ("float fovEnd", "35")], format);
    assert_camera_z(pin.as_ref(), DicingHint::Perspective, Some(35.0));
    // RenderMan's default fStop 16 without a focal length is a pinhole.
    assert_eq!(pin.property(ProjectionProperty::FStop), None);
    let lens = make(
        &[
            ("float focalLength", "0.05"),
            ("float focalDistance", "3"),
            ("float dofMult", "2"),
        ],
        format,
    );
    assert_lens_properties(lens.as_ref(), 8.0, 0.05, 3.0);
    // dofMult multiplies the lens radius: R = 2·0.05/(2·16).
    let (r, _, _) = one(lens.as_ref(), Point2::ZERO, Point2::new(1.0, 0.0), 0.0);
    assert!((r.origin.x - 2.0 * 0.05 / 32.0).abs() < 1e-9);
    let off = make(&[("float focalLength", "0.05"), ("float dofMult", "0")], format);
    assert_eq!(off.property(ProjectionProperty::FStop), None);
    let mut env = ProjectionEnvironment::for_format(format);
    env.set_deep_metric(DeepMetric::RayLength);
    PxrCameraFactory
        .create_projection(&mut env, &ParamList::new())
        .unwrap();
    assert_eq!(env.deep_metric(), DeepMetric::CameraZ);
}

#[test]
fn bad_parameters_name_the_plugin_and_parameter() {
    let cases = [
        (
            "float[3] enhance",
            "0 0 0",
            "\"enhance\" = (0, 0, 0): the third value is the zoom factor",
        ),
        ("float[3] enhance", "0 0 -2", "must be positive"),
        ("color axial", "0 -2 0", "green plane of focus to -1"),
        ("float tilt", "95", "\"tilt\""),
        ("string sweep", "sideways", "\"sweep\""),
        ("float squeeze", "0", "\"squeeze\""),
        ("float radial1", "inf", "\"radial1\""),
        ("float radail1", "0.1", "did you mean \"radial1\""),
    ];
    assert_refused(&PxrCameraFactory, "PxrCamera", Format::new(8, 8), &cases);
}

/// The split-diopter focus distance written out independently: ξ, smoothstep, nested lerps.
fn diopter_focus(xi: f64, main: f64, regions: &[(f64, f64, f64, f64)]) -> f64 {
    let mut z = main;
    for &(side, offset, width, focus) in regions {
        let d = side * (xi - offset);
        let s = if width > 0.0 {
            let x = (0.5 + d / width).clamp(0.0, 1.0);
            3.0 * x * x - 2.0 * x * x * x
        } else if d >= 0.0 {
            1.0
        } else {
            0.0
        };
        z += (focus - z) * s;
    }
    z
}

#[test]
fn split_diopter_focuses_each_region_at_its_distance_and_blends_across_the_band() {
    let format = Format::new(64, 48); // window [−4/3, 4/3] × [−1, 1]: h = 4/3
    let h = 4.0 / 3.0;
    let regions = [(1.0, 0.3, 0.2, 1.5), (-1.0, -0.3, 0.0, 8.0)];
    for (angle, across) in [(0.0f64, [1.0f64, 0.0]), (90.0, [0.0, -1.0]), (30.0, [0.0, 0.0])] {
        let across = if angle == 30.0 {
            [angle.to_radians().cos(), -angle.to_radians().sin()]
        } else {
            across
        };
        let p = make(
            &[
                ("float fov", "60"),
                ("float fStop", "2"),
                ("float focalLength", "0.1"),
                ("float focalDistance", "3"),
                ("int splitDiopter:count", "2"),
                ("float splitDiopter:angle", &format!("{angle}")),
                ("float splitDiopter:offset1", "0.3"),
                ("float splitDiopter:width1", "0.2"),
                ("float splitDiopter:focusDistance1", "1.5"),
                ("float splitDiopter:offset2", "-0.3"),
                ("float splitDiopter:focusDistance2", "8"),
            ],
            format,
        );
        // ξ from −0.89 to 0.91: region 2, the main focus, through the band, region 1.
        for k in 0..=36 {
            let xi = -0.89 + 0.05 * k as f64; // never exactly on the hard edge at −0.3
            let s = Point2::new((xi * h * across[0]) as f32, (xi * h * across[1]) as f32);
            let z = diopter_focus(xi, 3.0, &regions);
            if (0.0..=0.75).contains(&xi) || xi < -0.3 {
                let expected = if xi > 0.4 {
                    1.5
                } else if xi < -0.3 {
                    8.0
                } else if xi < 0.2 {
                    3.0
                } else {
                    z
                };
                assert!((z - expected).abs() < 1e-12, "ξ = {xi}: {z} vs {expected}");
            }
            let (chief, _, _) = one(p.as_ref(), s, Point2::ZERO, 0.0);
            let target = meet(&chief, [0.0, 0.0, 1.0], z);
            for a in [(1.0, 0.0), (-0.7, 0.7), (0.0, -1.0), (0.3, 0.9)] {
                let (r, _, _) = one(p.as_ref(), s, Point2::new(a.0, a.1), 0.0);
                assert!(r.origin.x != 0.0 || r.origin.y != 0.0);
                let got = meet(&r, [0.0, 0.0, 1.0], z);
                assert!(
                    dist3(got, target) < 2e-5 * z,
                    "angle {angle}, ξ = {xi}: aperture {a:?} meets z = {z} at {got:?}, chief at {target:?}"
                );
            }
        }
    }
    // The smoothstep across band 1 at its midpoint is ½: the focus is halfway.
    assert!((diopter_focus(0.3, 3.0, &regions) - 2.25).abs() < 1e-12);
}

#[test]
fn the_contract_holds_with_a_split_diopter() {
    let format = Format::new(48, 32);
    let p = make(
        &[
            ("float fStop", "2.8"),
            ("float focalLength", "0.05"),
            ("float focalDistance", "3"),
            ("float tilt", "10"),
            ("int splitDiopter:count", "2"),
            ("float splitDiopter:angle", "20"),
            ("float splitDiopter:offset1", "0.2"),
            ("float splitDiopter:width1", "0.3"),
            ("float splitDiopter:focusDistance1", "1"),
            ("float splitDiopter:offset2", "-0.4"),
            ("float splitDiopter:width2", "0.1"),
            ("float splitDiopter:focusDistance2", "20"),
        ],
        format,
    );
    let stats = assert_contract(p.as_ref(), &ContractTest::new(format));
    assert!(
        stats.valid == stats.samples && stats.spread_checked > 1500 && stats.roundtrips > 1500,
        "{stats:?}"
    );
}

#[test]
fn bad_split_diopter_parameters_are_refused_by_name() {
    let format = Format::new(48, 32);
    assert_refused(
        &PxrCameraFactory,
        NAME,
        format,
        &[
            ("int splitDiopter:count", "3", "splitDiopter:count"),
            ("float splitDiopter:width1", "-0.1", "splitDiopter:width1"),
            (
                "float splitDiopter:focusDistance2",
                "0",
                "splitDiopter:focusDistance2",
            ),
        ],
    );
    let err = try_make(
        &[
            ("int splitDiopter:count", "1"),
            ("float splitDiopter:focusDistance1", "0.5"),
            ("color axial", "-0.6 0 0"),
        ],
        format,
    )
    .err()
    .expect("refused")
    .to_string();
    for needle in ["PxrCamera", "splitDiopter:focusDistance1", "axial", "red"] {
        assert!(err.contains(needle), "{err}");
    }
}
