//! Tests of [`super`] (stmap.rs).

use super::*;
use obscura_plugins::builtin_registry;
use obscura_sdk::{
    DeepMetric, DicingHint, Projection, ProjectionContext, ProjectionProperty, PropertyValue, ScreenWindow,
};

fn params(list: &[(&str, &str)]) -> ParamList {
    let mut l = ParamList::new();
    for (d, v) in list {
        l.push_text(d, &[v], None).unwrap();
    }
    l
}

fn builtin(name: &str, p: &[(&str, &str)], f: Format) -> CameraStage {
    CameraStage::new(&mut builtin_registry(), name, &params(p), &CameraDesc::new(f)).unwrap()
}

/// An equidistant fisheye written here, independent of the library's: screen radius 1 ↔ `fov/2`
/// from the axis, culled outside the unit circle. With `fov` above 180° it sees behind the camera.
struct TestFisheye {
    half_fov: f32,
    inverse: bool,
}

impl Projection for TestFisheye {
    fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
        match p {
            ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(DicingHint::Spherical)),
            ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(DeepMetric::RayLength)),
            _ => None,
        }
    }
    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let parts = ctx.parts_mut();
        for (s, r) in parts.screen.iter().zip(parts.rays.iter_mut()) {
            let rho = (s.x * s.x + s.y * s.y).sqrt();
            if rho > 1.0 {
                *r = RayGeometry::CULLED;
                continue;
            }
            let theta = rho * self.half_fov;
            let (c, sn) = if rho > 0.0 {
                (s.x / rho, s.y / rho)
            } else {
                (1.0, 0.0)
            };
            r.origin = Vec3::ZERO;
            r.origin_radius = 0.0;
            r.direction = Vec3::new(theta.sin() * c, theta.sin() * sn, theta.cos());
            r.ray_spread = 0.01;
        }
    }
    fn unproject(&self, p: Vec3, _time: f32) -> Option<Point2> {
        if !self.inverse {
            return None;
        }
        let len = p.length();
        let theta = (p.z / len).clamp(-1.0, 1.0).acos();
        let rho = theta / self.half_fov;
        let q = (p.x * p.x + p.y * p.y).sqrt();
        if rho > 1.0 || len == 0.0 {
            return None;
        }
        Some(if q > 0.0 {
            Point2::new(rho * p.x / q, rho * p.y / q)
        } else {
            Point2::ZERO
        })
    }
}

fn fisheye(fov_deg: f32, inverse: bool, f: Format) -> CameraStage {
    let cam = CameraDesc::new(f);
    CameraStage::with_projection(
        "TestFisheye",
        Box::new(TestFisheye {
            half_fov: fov_deg.to_radians() / 2.0,
            inverse,
        }),
        cam.environment(),
        &cam,
    )
    .unwrap()
}

fn screen_of(f: Format, x: f64, y: f64) -> (f64, f64) {
    let w = ScreenWindow::default_for(f);
    let p = w.raster_to_screen(f, x, y);
    (p.x as f64, p.y as f64)
}

#[test]
fn identity_map_is_every_pixel_centre() {
    for f in [Format::new(64, 36), Format::new(30, 50)] {
        let a = builtin("PxrPerspective", &[("float fov", "50")], f);
        let b = builtin("PxrPerspective", &[("float fov", "50")], f);
        let map = compute_stmap(&a, &b, DEFAULT_DISTANCE).unwrap();
        assert_eq!(map.stats.mapped, map.stats.pixels);
        assert_eq!(map.stats.inconsistent, 0);
        for (k, ((s, t), al)) in map.s.iter().zip(&map.t).zip(&map.alpha).enumerate() {
            let (i, j) = (k as u32 % f.width, k as u32 / f.width);
            let es = (i as f64 + 0.5) / f.width as f64;
            let et = 1.0 - (j as f64 + 0.5) / f.height as f64;
            assert!(
                (*s as f64 - es).abs() * (f.width as f64) < 1e-3,
                "s at {i},{j}: {s} vs {es}"
            );
            assert!(
                (*t as f64 - et).abs() * (f.height as f64) < 1e-3,
                "t at {i},{j}: {t} vs {et}"
            );
            assert_eq!(*al, 1.0);
        }
    }
}

#[test]
fn perspective_to_perspective_is_the_tangent_ratio() {
    // A: fov 60 at 80x60, B: fov 90 at 64x48. A screen point is B's scaled by tan 45° / tan 30°.
    let (fa, fb) = (Format::new(80, 60), Format::new(64, 48));
    let a = builtin("PxrPerspective", &[("float fov", "60")], fa);
    let b = builtin("PxrPerspective", &[("float fov", "90")], fb);
    let map = compute_stmap(&a, &b, DEFAULT_DISTANCE).unwrap();
    let k = 45f64.to_radians().tan() / 30f64.to_radians().tan();
    let aa = fa.width as f64 / fa.height as f64;
    let mut inside = 0;
    for (n, (s, t)) in map.s.iter().zip(&map.t).enumerate() {
        let (i, j) = (n as u32 % fb.width, n as u32 / fb.width);
        let (sx, sy) = screen_of(fb, i as f64 + 0.5, j as f64 + 0.5);
        let (ax, ay) = (sx * k, sy * k);
        let es = (ax + aa) / (2.0 * aa);
        let et = (ay + 1.0) / 2.0;
        assert!((*s as f64 - es).abs() < 2e-6 * k, "s at {i},{j}: {s} vs {es}");
        assert!((*t as f64 - et).abs() < 2e-6 * k, "t at {i},{j}: {t} vs {et}");
        let want = (0.0..=1.0).contains(&es) && (0.0..=1.0).contains(&et);
        assert_eq!(map.alpha[n], if want { 1.0 } else { 0.0 }, "alpha at {i},{j}");
        inside += want as u32;
    }
    assert!(inside > 0 && (inside as u64) < map.stats.pixels);
    assert_eq!(map.stats.outside_a + map.stats.mapped, map.stats.pixels);
}

#[test]
fn culled_and_unseen_pixels_are_transparent_black() {
    // B: a 240° fisheye (corners culled, the rim looks backwards); A: a 100° perspective.
    let f = Format::new(48, 32);
    let a = builtin("PxrPerspective", &[("float fov", "100")], f);
    let b = fisheye(240.0, true, f);
    let map = compute_stmap(&a, &b, DEFAULT_DISTANCE).unwrap();
    let st = &map.stats;
    assert!(
        st.culled_by_b > 0 && st.unseen_by_a > 0 && st.outside_a > 0 && st.mapped > 0,
        "{st:?}"
    );
    assert_eq!(
        st.culled_by_b + st.unseen_by_a + st.outside_a + st.mapped,
        st.pixels
    );
    for n in 0..map.s.len() {
        let (i, j) = (n as u32 % f.width, n as u32 / f.width);
        let (sx, sy) = screen_of(f, i as f64 + 0.5, j as f64 + 0.5);
        let rho = (sx * sx + sy * sy).sqrt();
        let theta = rho * 120f64.to_radians();
        if rho > 1.0 || theta >= std::f64::consts::FRAC_PI_2 {
            assert_eq!((map.s[n], map.t[n], map.alpha[n]), (0.0, 0.0, 0.0), "at {i},{j}");
        } else {
            // Closed form: A's screen position is tan θ·(direction in the image plane)·d_A.
            let d = 1.0 / 50f64.to_radians().tan();
            let (ax, ay) = (theta.tan() * sx / rho * d, theta.tan() * sy / rho * d);
            let a_aspect = 1.5;
            let (es, et) = ((ax + a_aspect) / (2.0 * a_aspect), (ay + 1.0) / 2.0);
            assert!((map.s[n] as f64 - es).abs() < 1e-4 * (1.0 + es.abs()), "{i},{j}");
            assert!((map.t[n] as f64 - et).abs() < 1e-4 * (1.0 + et.abs()), "{i},{j}");
            let inside = (0.0..=1.0).contains(&es) && (0.0..=1.0).contains(&et);
            assert_eq!(map.alpha[n], if inside { 1.0 } else { 0.0 }, "{i},{j}");
        }
    }
}

#[test]
fn orthographic_source_holds_only_what_its_window_covers() {
    // A orthographic (screen = camera x, y); B a 90° pinhole. At distance D a ray (sx, sy, 1)/l
    // reaches A's screen at D·(sx, sy)/l: inside A's window (±1.5, ±1) only near the axis.
    let f = Format::new(48, 32);
    let dist = 3.0f32;
    let a = builtin("PxrOrthographic", &[], f);
    let b = builtin("PxrPerspective", &[("float fov", "90")], f);
    let map = compute_stmap(&a, &b, dist).unwrap();
    assert!(map.stats.mapped > 0 && map.stats.outside_a > 0, "{:?}", map.stats);
    for n in 0..map.s.len() {
        let (i, j) = (n as u32 % f.width, n as u32 / f.width);
        let (sx, sy) = screen_of(f, i as f64 + 0.5, j as f64 + 0.5);
        let l = (sx * sx + sy * sy + 1.0).sqrt();
        let (ax, ay) = (dist as f64 * sx / l, dist as f64 * sy / l);
        let (es, et) = ((ax + 1.5) / 3.0, (ay + 1.0) / 2.0);
        assert!((map.s[n] as f64 - es).abs() < 1e-5 && (map.t[n] as f64 - et).abs() < 1e-5);
        let inside = (0.0..=1.0).contains(&es) && (0.0..=1.0).contains(&et);
        assert_eq!(map.alpha[n], if inside { 1.0 } else { 0.0 }, "{i},{j}");
    }
}

/// Nuke's STMap lookup: bilinear between pixel centres at ((i + ½)/W, 1 − (j + ½)/H).
fn bilinear(img: &[[f64; 3]], f: Format, s: f64, t: f64) -> [f64; 3] {
    let x = s * f.width as f64 - 0.5;
    let y = (1.0 - t) * f.height as f64 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let at = |i: f64, j: f64| {
        let i = i.clamp(0.0, f.width as f64 - 1.0) as usize;
        let j = j.clamp(0.0, f.height as f64 - 1.0) as usize;
        img[j * f.width as usize + i]
    };
    let (a, b, c, d) = (
        at(x0, y0),
        at(x0 + 1.0, y0),
        at(x0, y0 + 1.0),
        at(x0 + 1.0, y0 + 1.0),
    );
    std::array::from_fn(|k| {
        (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy
    })
}

#[test]
fn applying_the_map_to_an_image_of_a_gives_the_rays_of_b() {
    // The "image" of A is its own ray directions; looking it up through the map must give B's
    // directions, up to the bilinear interpolation error (second order in A's pixel angle).
    let cases: Vec<(CameraStage, CameraStage)> = vec![
        (
            fisheye(180.0, true, Format::new(200, 200)),
            builtin("PxrPerspective", &[("float fov", "70")], Format::new(64, 40)),
        ),
        (
            builtin("PxrPerspective", &[("float fov", "100")], Format::new(160, 120)),
            fisheye(150.0, true, Format::new(50, 50)),
        ),
    ];
    for (a, b) in cases {
        let fa = a.camera().format;
        let screen: Vec<Point2> = (0..fa.height)
            .flat_map(|y| (0..fa.width).map(move |x| (x, y)))
            .map(|(x, y)| a.camera().raster_to_screen(x as f64 + 0.5, y as f64 + 0.5))
            .collect();
        let (a_rays, _) = chief_rays(&a, &screen);
        let img: Vec<[f64; 3]> = a_rays
            .iter()
            .map(|r| [r.direction.x as f64, r.direction.y as f64, r.direction.z as f64])
            .collect();
        let fb = b.camera().format;
        let map = compute_stmap(&a, &b, DEFAULT_DISTANCE).unwrap();
        assert_eq!(map.stats.inconsistent, 0);
        let b_screen: Vec<Point2> = (0..fb.height)
            .flat_map(|y| (0..fb.width).map(move |x| (x, y)))
            .map(|(x, y)| b.camera().raster_to_screen(x as f64 + 0.5, y as f64 + 0.5))
            .collect();
        let (b_rays, _) = chief_rays(&b, &b_screen);
        let mut checked = 0;
        for (n, b_ray) in b_rays.iter().enumerate() {
            let (s, t) = (map.s[n] as f64, map.t[n] as f64);
            // Away from A's border (clamped lookups) and from its culled region.
            let (xa, ya) = (s * fa.width as f64, (1.0 - t) * fa.height as f64);
            let margin = 1.5;
            if map.alpha[n] == 0.0
                || xa < margin
                || ya < margin
                || xa > fa.width as f64 - margin
                || ya > fa.height as f64 - margin
            {
                continue;
            }
            let v = bilinear(&img, fa, s, t);
            if v.iter().all(|c| *c == 0.0) {
                continue;
            }
            // atan2(|v × d|, v · d): acos of a dot product near 1 has no precision.
            let d = b_ray.direction;
            let d = [d.x as f64, d.y as f64, d.z as f64];
            let cross = [
                v[1] * d[2] - v[2] * d[1],
                v[2] * d[0] - v[0] * d[2],
                v[0] * d[1] - v[1] * d[0],
            ];
            let sin = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
            let angle = sin.atan2(v[0] * d[0] + v[1] * d[1] + v[2] * d[2]);
            // Looking up between neighbours of a cull boundary mixes in zeros: skip those too.
            let neighbours_live = {
                // The four pixels the lookup blends (margin keeps them inside the image).
                let (i, j) = ((xa - 0.5).floor() as usize, (ya - 0.5).floor() as usize);
                [(0, 0), (1, 0), (0, 1), (1, 1)]
                    .iter()
                    .all(|(di, dj)| img[(j + dj) * fa.width as usize + i + di] != [0.0; 3])
            };
            if !neighbours_live {
                continue;
            }
            assert!(angle < 1e-4, "pixel {n}: looked-up direction off by {angle} rad");
            checked += 1;
        }
        assert!(checked as u64 > map.stats.pixels / 4, "{checked}");
    }
}

#[test]
fn a_projection_without_inverse_is_refused() {
    let f = Format::new(16, 16);
    let a = fisheye(180.0, false, f);
    let b = builtin("PxrPerspective", &[], f);
    let e = compute_stmap(&a, &b, DEFAULT_DISTANCE).unwrap_err().to_string();
    assert!(
        e.contains("TestFisheye offers no inverse") && e.contains("ST-maps need one"),
        "{e}"
    );
    // The other way round works: B needs no inverse.
    assert!(compute_stmap(&b, &a, DEFAULT_DISTANCE).is_ok());
}

#[test]
fn bad_distances_and_names_are_clear_errors() {
    let f = Format::new(8, 8);
    let a = builtin("PxrPerspective", &[], f);
    for d in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let e = compute_stmap(&a, &a, d).unwrap_err().to_string();
        assert!(e.starts_with("--distance"), "{e}");
    }
    let empty = ParamList::new();
    let e = stages(
        &mut builtin_registry(),
        ("PxrPerspectve", &empty, f),
        ("PxrPerspective", &empty, f),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        e.starts_with("--from PxrPerspectve: unknown projection") && e.contains("did you mean"),
        "{e}"
    );
    let bad = params(&[("float fov", "500")]);
    let e = stages(
        &mut builtin_registry(),
        ("PxrPerspective", &empty, f),
        ("PxrPerspective", &bad, f),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.starts_with("--to PxrPerspective:") && e.contains("fov"), "{e}");
}

/// A map from any registered projection to itself is the identity wherever the projection sees
/// (every projection added to the library is checked here without being named).
#[test]
fn every_registered_projection_maps_to_itself() {
    let f = Format::new(40, 24);
    let reg = builtin_registry();
    let mut checked = Vec::new();
    for name in reg.names() {
        let a = builtin(&name, &[], f);
        let b = builtin(&name, &[], f);
        let map = match compute_stmap(&a, &b, DEFAULT_DISTANCE) {
            Ok(m) => m,
            Err(StMapError::NoInverse { .. }) => {
                eprintln!("{name}: no inverse, no identity map to check");
                continue;
            }
            Err(e) => panic!("{name}: {e}"),
        };
        assert!(map.stats.mapped > 0, "{name}: nothing mapped: {:?}", map.stats);
        assert_eq!(
            map.stats.inconsistent,
            0,
            "{name}: {:?}",
            map.stats.consistency_warning(&name)
        );
        for n in 0..map.s.len() {
            assert!(map.s[n].is_finite() && map.t[n].is_finite(), "{name}: NaN at {n}");
            if map.alpha[n] == 1.0 {
                let (i, j) = (n as u32 % f.width, n as u32 / f.width);
                let es = (i as f64 + 0.5) / f.width as f64;
                let et = 1.0 - (j as f64 + 0.5) / f.height as f64;
                assert!(
                    (map.s[n] as f64 - es).abs() * (f.width as f64) < 1e-3
                        && (map.t[n] as f64 - et).abs() * (f.height as f64) < 1e-3,
                    "{name}: pixel {i},{j} maps to ({}, {}), not its own centre ({es}, {et})",
                    map.s[n],
                    map.t[n]
                );
            }
        }
        checked.push(name);
    }
    eprintln!("identity maps checked: {}", checked.join(", "));
    assert!(checked.len() >= 2, "{checked:?}");
}

#[test]
fn written_file_reads_back_and_failures_name_the_path() {
    let f = Format::new(12, 6);
    let a = builtin("PxrPerspective", &[("float fov", "60")], f);
    let b = builtin("PxrPerspective", &[("float fov", "90")], f);
    let map = compute_stmap(&a, &b, DEFAULT_DISTANCE).unwrap();
    let dir = std::env::temp_dir().join(format!("obscura-stmap-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("map.exr");
    write_stmap_exr(&map, &[("obscura:from", "PxrPerspective".into())], &path).unwrap();
    let img = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
    let layer = &img.layer_data[0];
    assert_eq!((layer.size.0, layer.size.1), (12, 6));
    for (name, want) in [("R", &map.s), ("G", &map.t), ("A", &map.alpha)] {
        let ch = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .unwrap();
        match &ch.sample_data {
            FlatSamples::F32(v) => assert_eq!(v, want, "{name}"),
            other => panic!("{name}: {other:?}"),
        }
    }
    assert!(crate::atomic::temporaries(&path).is_empty());
    std::fs::remove_dir_all(&dir).unwrap();
    let bad = Path::new("/nonexistent-dir/map.exr");
    let e = write_stmap_exr(&map, &[], bad).unwrap_err().to_string();
    assert!(e.contains("/nonexistent-dir/map.exr"), "{e}");
}

/// The ST-map camera ([`obscura_calibration::stmap::StMapLens`]) built from the redistort map of a
/// 3DE lens (A = the lens's undistorted pinhole, B = the lens, on the plate) and read back from the
/// EXR: its rays equal the 3DE model's, and its inverse is exact.
///
/// The bound, from the lens itself: the map holds `(s, t)` in f32 (half an ulp of 1 is 6e-8, 2e-5
/// px on this 320-pixel plate), computed through `unproject`'s f32 screen position (≤ 1.2e-7 of the
/// screen window, 4e-5 px): together under 1e-4 px. Between samples, bilinear interpolation of the
/// undistorted position `q` errs by at most `(h²/8)·(max|∂²q/∂x²| + max|∂²q/∂y²|)` with h = 1 px,
/// and linear extrapolation in the frame's half-pixel border by `3/8` of the same: the bound is
/// `e = 1e-4 + (3/8)·(max|q_xx| + max|q_yy|)` px of the undistorted image, the second derivatives
/// measured on the 3DE model's own `undistort` by central differences over the plate. A ray's
/// direction is then right to `e/min(f_x, f_y)` rad, and the plate position the map's inverse gives
/// for the model's ray to `e·max‖J⁻¹‖` px (`J = ∂q/∂(x, y)`, measured likewise).
#[test]
fn a_camera_through_the_redistort_map_of_a_3de_lens_has_the_lens_rays() {
    use obscura_calibration::lens3de::{Kind, Lens};
    use obscura_calibration::models::CameraModel;
    use obscura_calibration::stmap::{StMapLens, read_stmap_exr};

    let (w, h) = (320u32, 180u32);
    let plate = Format::new(w, h);
    let kind = Kind::RadialStandard4;
    let set = [
        ("tde4_focal_length_cm", 2.5),
        ("tde4_filmback_width_cm", 3.6),
        ("tde4_filmback_height_cm", 2.025),
        ("tde4_lens_center_offset_x_cm", 0.03),
        ("tde4_lens_center_offset_y_cm", -0.02),
        ("Distortion - Degree 2", -0.12),
        ("U - Degree 2", 0.01),
        ("V - Degree 2", -0.008),
        ("Quartic Distortion - Degree 4", 0.03),
    ];
    let values: Vec<f64> = kind
        .all_params()
        .iter()
        .map(|(name, default)| {
            let v = set.iter().find(|(n, _)| n == name).map_or(*default, |(_, v)| *v);
            f64::from(v as f32)
        })
        .collect();
    let text: Vec<String> = values.iter().map(|v| format!("{v}")).collect();
    let lens = Lens::new(kind, &values, f64::from(w), f64::from(h)).unwrap();
    let pinhole = lens.pinhole().map(|v| f64::from(v as f32));
    let pinhole_text: Vec<String> = pinhole.iter().map(|v| format!("{v}")).collect();
    let res = format!("{w} {h}");
    let stage = |model: &str, p: &[String]| {
        let mut l = ParamList::new();
        l.push_text("string model", &[model], None).unwrap();
        let p: Vec<&str> = p.iter().map(String::as_str).collect();
        l.push_text("float[] params", &p, None).unwrap();
        l.push_text("int[2] resolution", &res.split(' ').collect::<Vec<_>>(), None)
            .unwrap();
        CameraStage::new(
            &mut builtin_registry(),
            "CalibratedCamera",
            &l,
            &CameraDesc::new(plate),
        )
        .unwrap()
    };
    let from = stage("PINHOLE", &pinhole_text);
    let to = stage(kind.name(), &text);
    let map = compute_stmap(&from, &to, DEFAULT_DISTANCE).unwrap();
    assert_eq!(
        map.stats.culled_by_b + map.stats.unseen_by_a,
        0,
        "{:?}",
        map.stats
    );

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("redistort.exr");
    write_stmap_exr(&map, &[], &path).unwrap();
    let read = read_stmap_exr(&path).unwrap();
    assert_eq!((read.width, read.height), (w as usize, h as usize));
    let camera = StMapLens::new(
        read.width,
        read.height,
        &read.s,
        &read.t,
        [f64::from(w), f64::from(h)],
        pinhole,
    )
    .unwrap();
    let model = CameraModel::new(kind.name(), &values, &[], &[], f64::from(w), f64::from(h)).unwrap();

    let angle = |a: [f64; 3], b: [f64; 3]| {
        let n = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let c = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        n(c).atan2(a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
    };
    let (mut q2, mut jinv) = ([0.0f64; 2], 0.0f64);
    for j in (1..h - 1).step_by(3) {
        for i in (1..w - 1).step_by(3) {
            let u = |dx: f64, dy: f64| lens.undistort([f64::from(i) + dx, f64::from(j) + dy]).unwrap();
            let (c, xp, xm, yp, ym) = (u(0.0, 0.0), u(1.0, 0.0), u(-1.0, 0.0), u(0.0, 1.0), u(0.0, -1.0));
            for k in 0..2 {
                q2[0] = q2[0].max((xp[k] - 2.0 * c[k] + xm[k]).abs());
                q2[1] = q2[1].max((yp[k] - 2.0 * c[k] + ym[k]).abs());
            }
            let jm = [
                [(xp[0] - xm[0]) / 2.0, (yp[0] - ym[0]) / 2.0],
                [(xp[1] - xm[1]) / 2.0, (yp[1] - ym[1]) / 2.0],
            ];
            let det = jm[0][0] * jm[1][1] - jm[0][1] * jm[1][0];
            let frob = jm.iter().flatten().map(|v| v * v).sum::<f64>().sqrt();
            jinv = jinv.max(frob / det.abs());
        }
    }
    let bound_px = 1e-4 + 0.375 * (q2[0] + q2[1]);
    let bound_rad = bound_px / pinhole[0].min(pinhole[1]);
    let bound_cross = bound_px * jinv;
    let (mut worst_rad, mut worst_trip, mut worst_cross) = (0.0f64, 0.0f64, 0.0f64);
    // Pixel centres on a grid, and positions between them (a fixed LCG), edges included.
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut rand = move || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut points: Vec<[f64; 2]> = Vec::new();
    for j in (0..h).step_by(7) {
        for i in (0..w).step_by(9) {
            points.push([f64::from(i) + 0.5, f64::from(j) + 0.5]);
        }
    }
    points.extend((0..2000).map(|_| [rand() * f64::from(w), rand() * f64::from(h)]));
    points.extend([
        [0.0, 0.0],
        [f64::from(w), f64::from(h)],
        [0.2, f64::from(h) - 0.1],
    ]);
    for p in points {
        let got = camera.pixel_to_ray(p).unwrap();
        let want = model.pixel_to_ray(p).unwrap().v;
        worst_rad = worst_rad.max(angle(got, want));
        let back = camera.ray_to_pixel(got).unwrap();
        worst_trip = worst_trip.max((back[0] - p[0]).hypot(back[1] - p[1]));
        let cross = camera.ray_to_pixel(want).unwrap();
        worst_cross = worst_cross.max((cross[0] - p[0]).hypot(cross[1] - p[1]));
    }
    eprintln!(
        "ST-map camera vs 3DE model: worst ray angle {worst_rad:.3e} rad (bound {bound_rad:.3e}), \
         round trip {worst_trip:.3e} px, model ray -> map pixel {worst_cross:.3e} px (bound {bound_cross:.3e})"
    );
    assert!(worst_rad < bound_rad, "{worst_rad} rad > {bound_rad}");
    assert!(worst_trip < 1e-3, "round trip {worst_trip} px");
    assert!(
        worst_cross < bound_cross,
        "model ray through the map's inverse: {worst_cross} px > {bound_cross}"
    );

    // The same map as the StMapCamera projection: its rays through the renderer's stage equal the 3DE
    // lens's CalibratedCamera rays at every pixel centre (f32 directions: the bound plus 1e-6 rad),
    // and the shared contract checker passes it.
    let mut l = ParamList::new();
    let map_path = path.display().to_string();
    l.push_text("string map", &[map_path.as_str()], None).unwrap();
    let p: Vec<&str> = pinhole_text.iter().map(String::as_str).collect();
    l.push_text("float[4] pinhole", &p, None).unwrap();
    let mut registry = Registry::new();
    registry
        .register(Box::new(obscura_calibration::stmap::StMapCameraFactory), "")
        .unwrap();
    let camera_stage = CameraStage::new(&mut registry, "StMapCamera", &l, &CameraDesc::new(plate)).unwrap();
    let screen: Vec<Point2> = (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| {
            let (x, y) = screen_of(plate, f64::from(i) + 0.5, f64::from(j) + 0.5);
            Point2::new(x as f32, y as f32)
        })
        .collect();
    let (got, got_report) = chief_rays(&camera_stage, &screen);
    let (want, _) = chief_rays(&to, &screen);
    assert!(got_report.is_clean(), "{got_report:?}");
    let mut worst_stage = 0.0f64;
    for (g, r) in got.iter().zip(&want) {
        let v = |d: Vec3| [f64::from(d.x), f64::from(d.y), f64::from(d.z)];
        worst_stage = worst_stage.max(angle(v(g.direction), v(r.direction)));
    }
    eprintln!(
        "StMapCamera stage vs the 3DE CalibratedCamera stage: worst {worst_stage:.3e} rad over {} pixels",
        got.len()
    );
    assert!(worst_stage < bound_rad + 1e-6, "{worst_stage} rad");
    let opts = obscura_check::CheckOptions {
        format: plate,
        samples_per_pixel: 1,
        ..obscura_check::CheckOptions::default()
    };
    let report =
        obscura_check::check_factory(&obscura_calibration::stmap::StMapCameraFactory, &l, &opts).unwrap();
    assert!(report.is_clean(), "{:?}\n{}", report.failed(), report.to_json());
}

#[test]
fn st_map_files_without_st_channels_are_refused_naming_the_file() {
    use obscura_calibration::stmap::read_stmap_exr;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rgb.exr");
    let layer = Layer::new(
        (4, 3),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(vec![AnyChannel::new("Y", FlatSamples::F32(vec![0.5; 12]))].into()),
    );
    crate::output::write_exr_image(Image::from_layer(layer), &path).unwrap();
    let e = read_stmap_exr(&path).unwrap_err().to_string();
    assert!(
        e.contains("rgb.exr") && e.contains("no channel R") && e.contains("channels present: Y"),
        "{e}"
    );
    let text = dir.path().join("notes.exr");
    std::fs::write(&text, "not an image").unwrap();
    let e = read_stmap_exr(&text).unwrap_err().to_string();
    assert!(
        e.contains("notes.exr: cannot read it as an OpenEXR ST-map"),
        "{e}"
    );
}
