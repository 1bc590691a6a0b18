//! Tests of the fisheye lenses: closed forms, inverses, rims and the contract.

use super::*;
use crate::testing::{
    self, ContractTest, assert_contract, assert_spherical_ray_length, project_points, ray_at,
};
use obscura_sdk::{Format, ParamList, ProjectionFactory, ScreenWindow};
use proptest::prelude::*;

fn make(params: &[(&str, &[&str])], format: Format) -> Result<Box<dyn Projection>, PluginError> {
    testing::try_create(&FisheyeFactory, &testing::param_list(params), format).0
}

fn lens(mapping: &str, fov: &str, format: Format) -> Box<dyn Projection> {
    make(&[("string mapping", &[mapping]), ("float fov", &[fov])], format).unwrap()
}

fn angle_from_z(d: Vec3) -> f64 {
    let (x, y, z) = (f64::from(d.x), f64::from(d.y), f64::from(d.z));
    x.hypot(y).atan2(z)
}

/// Blender's default lens polynomial (a fit to its 50 mm rectilinear camera on a 36 mm sensor).
const BLENDER_DEFAULT: [&str; 5] = [
    "-1.1735143712967577e-05",
    "-0.019988736953434998",
    "-3.3525322965709175e-06",
    "3.099275275886036e-06",
    "-2.6064646454854524e-08",
];

#[test]
fn every_mapping_keeps_the_contract() {
    for format in [Format::new(48, 32), Format::new(27, 40)] {
        let configs: Vec<(&str, &str)> = vec![
            ("equidistant", "90"),
            ("equidistant", "180"),
            ("equidistant", "220"),
            ("equidistant", "360"),
            ("stereographic", "180"),
            ("stereographic", "300"),
            ("orthographic", "120"),
            ("orthographic", "180"),
            ("equisolid", "180"),
            ("equisolid", "360"),
            ("polynomial", "180"),
            ("polynomial", "360"),
        ];
        for (mapping, fov) in configs {
            let p = lens(mapping, fov, format);
            let stats = assert_contract(p.as_ref(), &ContractTest::new(format));
            assert!(
                stats.valid > 0
                    && (stats.valid < stats.samples || mapping == "polynomial")
                    && stats.roundtrips > 300
                    && stats.spread_checked > 300,
                "{mapping} {fov}: {stats:?}"
            );
            if fov.parse::<f32>().unwrap() > 180.0 && mapping != "equisolid" && mapping != "polynomial" {
                assert!(
                    stats.backward > 0,
                    "{mapping} {fov} never looks behind: {stats:?}"
                );
            }
        }
        // A short equisolid lens whose image circle covers the whole sphere, and a real polynomial.
        let short = make(
            &[
                ("string mapping", &["equisolid"]),
                ("float fov", &["360"]),
                ("float focalLengthMm", &["6"]),
            ],
            format,
        )
        .unwrap();
        let stats = assert_contract(short.as_ref(), &ContractTest::new(format));
        assert!(stats.backward > 0, "{stats:?}");
        // Blender's lens with k0 = 0: with k0 ≠ 0 the centre is a singular point (the circle
        // θ = −k0 collapses onto it), where no finite footprint is right.
        let mut k = BLENDER_DEFAULT;
        k[0] = "0";
        let blender = make(
            &[("string mapping", &["polynomial"]), ("float[5] polynomial", &k)],
            format,
        )
        .unwrap();
        assert_contract(blender.as_ref(), &ContractTest::new(format));
    }
}

#[test]
fn outside_the_image_circle_the_direction_is_exactly_zero() {
    let format = Format::new(48, 32);
    for mapping in ["equidistant", "stereographic", "orthographic"] {
        let p = lens(mapping, "180", format);
        for s in [
            Point2::new(1.5, 1.0),
            Point2::new(-1.5, -1.0),
            Point2::new(1.000_001, 0.0),
            Point2::new(0.0, -1.01),
            Point2::new(0.8, 0.61),
        ] {
            assert_eq!(
                ray_at(p.as_ref(), s),
                obscura_sdk::RayGeometry::CULLED,
                "{mapping} at {s:?}"
            );
        }
        // The rim itself is seen, at 90°.
        let rim = ray_at(p.as_ref(), Point2::new(0.0, 1.0));
        assert!(
            (angle_from_z(rim.direction) - std::f64::consts::FRAC_PI_2).abs() < 1e-6,
            "{rim:?}"
        );
    }
    // A 360° rim collapses to −Z and is left out; just inside it is seen.
    let p = lens("equidistant", "360", format);
    assert!(ray_at(p.as_ref(), Point2::new(1.0, 0.0)).is_culled());
    let inside = ray_at(p.as_ref(), Point2::new(0.999, 0.0));
    assert!(
        inside.direction.z < -0.99 && inside.direction.x > 0.0,
        "{inside:?}"
    );
    // Equisolid: the default 10.5 mm lens at 180° has its circle at 2f·sin(45°) = 14.849 mm.
    let p = lens("equisolid", "180", format);
    let mm = 36.0 / 3.0; // mm per screen unit: the 36 mm sensor spans the window's 3 units
    let rim = 2.0 * 10.5 * std::f32::consts::FRAC_PI_4.sin() / mm;
    assert!(!ray_at(p.as_ref(), Point2::new(rim * 0.9999, 0.0)).is_culled());
    assert!(ray_at(p.as_ref(), Point2::new(rim * 1.0001, 0.0)).is_culled());
}

#[test]
fn nothing_is_nan_anywhere_in_or_around_the_window() {
    let format = Format::new(64, 48);
    let w = ScreenWindow::default_for(format);
    let grid: Vec<Point2> = (0..=200)
        .flat_map(|j| (0..=200).map(move |i| (i, j)))
        .map(|(i, j)| {
            Point2::new(
                w.left - 0.2 + (w.width() + 0.4) * i as f32 / 200.0,
                w.bottom - 0.2 + (w.height() + 0.4) * j as f32 / 200.0,
            )
        })
        .chain([
            Point2::ZERO,
            Point2::new(1.0, 0.0),
            Point2::new(0.0, -1.0),
            Point2::new(f32::NAN, 0.0),
        ])
        .collect();
    let n = grid.len();
    for (mapping, fov) in [
        ("equidistant", "360"),
        ("equidistant", "220"),
        ("stereographic", "359.9"),
        ("orthographic", "180"),
        ("equisolid", "360"),
        ("polynomial", "360"),
    ] {
        let p = lens(mapping, fov, format);
        let rays = project_points(p.as_ref(), &grid, &vec![Point2::ZERO; n], &vec![0.0; n]);
        for (s, r) in grid.iter().zip(&rays) {
            assert!(
                r.direction.is_finite() && r.ray_spread.is_finite() && r.ray_spread >= 0.0,
                "{mapping} {fov} at {s:?}: {r:?}"
            );
            assert!(
                r.is_culled() || (r.direction.length() - 1.0).abs() < 1e-6,
                "{mapping} at {s:?}: {r:?}"
            );
        }
    }
}

proptest! {
    #[test]
    fn equidistant_angle_is_exactly_r_times_half_the_fov(
        sx in -1.0f32..1.0, sy in -1.0f32..1.0, fov in 10.0f32..360.0,
    ) {
        let r = f64::from(sx).hypot(f64::from(sy));
        prop_assume!(r <= 0.999);
        let p = lens("equidistant", &fov.to_string(), Format::new(64, 64));
        let d = ray_at(p.as_ref(), Point2::new(sx, sy)).direction;
        let expected = r * f64::from(fov).to_radians() / 2.0;
        prop_assert!((angle_from_z(d) - expected).abs() < 2e-6, "{} vs {}", angle_from_z(d), expected);
        // The azimuth is the screen point's own.
        if r > 1e-3 && expected < 3.1 {
            let phi = f64::from(d.y).atan2(f64::from(d.x));
            prop_assert!((phi - f64::from(sy).atan2(f64::from(sx))).abs() < 1e-4);
        }
    }

    #[test]
    fn stereographic_and_orthographic_follow_their_laws(
        sx in -1.0f32..1.0, sy in -1.0f32..1.0, fov in 10.0f32..180.0,
    ) {
        let r = f64::from(sx).hypot(f64::from(sy));
        prop_assume!(r <= 1.0);
        let half = f64::from(fov).to_radians() / 2.0;
        let stereo = lens("stereographic", &fov.to_string(), Format::new(64, 64));
        let d = ray_at(stereo.as_ref(), Point2::new(sx, sy)).direction;
        prop_assert!((angle_from_z(d) - 2.0 * (r * (half / 2.0).tan()).atan()).abs() < 2e-6);
        let ortho = lens("orthographic", &fov.to_string(), Format::new(64, 64));
        let d = ray_at(ortho.as_ref(), Point2::new(sx, sy)).direction;
        let sin = f64::from(d.x).hypot(f64::from(d.y));
        prop_assert!((sin - r * half.sin()).abs() < 2e-6 && d.z >= 0.0);
    }

    #[test]
    fn equisolid_places_the_angle_where_2f_sin_half_theta_is_the_sensor_radius(
        sx in -1.5f32..1.5, sy in -1.0f32..1.0, f in 6.0f32..30.0,
    ) {
        // 48×32: the 36 mm sensor spans the window's width of 3 units, 12 mm each.
        let p = make(&[("string mapping", &["equisolid"]), ("float fov", &["360"]),
            ("float focalLengthMm", &[&f.to_string()])], Format::new(48, 32)).unwrap();
        let ray = ray_at(p.as_ref(), Point2::new(sx, sy));
        let r_mm = 12.0 * f64::from(sx).hypot(f64::from(sy));
        if r_mm >= 2.0 * f64::from(f) * 0.999_999 {
            prop_assert!(ray.is_culled());
        } else {
            let theta = angle_from_z(ray.direction);
            prop_assert!((2.0 * f64::from(f) * (theta / 2.0).sin() - r_mm).abs() < 2e-5 * f64::from(f),
                "θ {} r_mm {}", theta, r_mm);
        }
    }

    #[test]
    fn unproject_inverts_project_over_the_valid_field(
        sx in -1.0f32..1.0, sy in -1.0f32..1.0, depth in 0.01f32..1000.0,
        which in 0usize..7,
    ) {
        let (mapping, fov) = [
            ("equidistant", "180"), ("equidistant", "360"), ("stereographic", "330"),
            ("orthographic", "180"), ("equisolid", "360"), ("polynomial", "200"), ("equidistant", "30"),
        ][which];
        let format = Format::new(640, 360);
        let p = lens(mapping, fov, format);
        let ray = ray_at(p.as_ref(), Point2::new(sx, sy));
        prop_assume!(!ray.is_culled() && f64::from(sx).hypot(f64::from(sy)) < 0.999);
        let back = p.unproject(ray.direction * depth, 0.5).unwrap();
        let px = 2.0 / 360.0;
        prop_assert!(((back.x - sx) / px).abs() < 1e-4 && ((back.y - sy) / px).abs() < 1e-4,
            "{} {}: {:?} for ({}, {})", mapping, fov, back, sx, sy);
    }
}

#[test]
fn unproject_refuses_what_the_lens_cannot_see() {
    let format = Format::new(64, 64);
    let p = lens("equidistant", "180", format);
    assert_eq!(p.unproject(Vec3::new(0.0, 1.0, -0.1), 0.0), None);
    assert_eq!(p.unproject(Vec3::new(0.0, 0.0, -1.0), 0.0), None);
    assert_eq!(p.unproject(Vec3::ZERO, 0.0), None);
    assert_eq!(p.unproject(Vec3::new(0.0, 0.0, 2.0), 0.0), Some(Point2::ZERO));
    let side = p.unproject(Vec3::new(3.0, 0.0, 0.0), 0.0).unwrap();
    assert!((side.x - 1.0).abs() < 1e-6 && side.y == 0.0);
    let ortho = lens("orthographic", "120", format);
    assert_eq!(ortho.unproject(Vec3::new(1.0, 0.0, 0.1), 0.0), None);
    // 360°: everything but −Z itself.
    let all = lens("equidistant", "360", format);
    assert!(all.unproject(Vec3::new(0.01, 0.0, -1.0), 0.0).is_some());
    assert_eq!(all.unproject(Vec3::new(0.0, 0.0, -1.0), 0.0), None);
}

#[test]
fn a_polynomial_with_k1_minus_one_over_f_is_an_equidistant_lens() {
    // 64×64: the 36 mm sensor spans the window's 2 units, 18 mm each; f = 12 mm puts
    // θ = 18/12 rad at the unit circle, an equidistant lens of fov 2·1.5 rad.
    let format = Format::new(64, 64);
    let f = 12.0f64;
    let poly = make(
        &[
            ("string mapping", &["polynomial"]),
            ("float fov", &["360"]),
            (
                "float[5] polynomial",
                &["0", &(-1.0 / f).to_string(), "0", "0", "0"],
            ),
        ],
        format,
    )
    .unwrap();
    let fov = (2.0 * 18.0 / f).to_degrees();
    let equi = lens("equidistant", &fov.to_string(), format);
    for i in 0..200 {
        let a = i as f32 * 0.731;
        let r = (i as f32 / 200.0).sqrt() * 0.999;
        let s = Point2::new(r * a.cos(), r * a.sin());
        let (rp, re) = (ray_at(poly.as_ref(), s), ray_at(equi.as_ref(), s));
        assert!(
            (rp.direction - re.direction).length() < 2e-6,
            "{s:?}: {rp:?} vs {re:?}"
        );
        assert!((rp.ray_spread / re.ray_spread - 1.0).abs() < 1e-4, "{s:?}");
    }
    // Cycles' sign: the same coefficients with the opposite sign describe no lens.
    let err = make(
        &[
            ("string mapping", &["polynomial"]),
            (
                "float[5] polynomial",
                &["0", &(1.0 / f).to_string(), "0", "0", "0"],
            ),
        ],
        format,
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        err.starts_with("Fisheye: parameter \"polynomial\"") && err.contains("k1 < 0"),
        "{err}"
    );
}

#[test]
fn the_polynomial_stops_where_it_turns_back() {
    // θ = 0.1 r − 0.001 r³ peaks at r = sqrt(100/3) = 5.7735 mm (θ = 0.3849 rad < fov/2).
    let p = Fisheye::new(
        &ProjectionEnvironment::for_format(Format::new(64, 64)),
        &Lens {
            mapping: Mapping::Polynomial,
            fov: 180.0,
            focal_length_mm: 10.5,
            sensor_width_mm: 36.0,
            polynomial: [0.0, -0.1, 0.0, 0.001, 0.0],
        },
    )
    .unwrap();
    let r_mono = (100.0f64 / 3.0).sqrt() / 18.0;
    // (to the f32 rounding of the coefficients)
    assert!((p.r_hi / r_mono - 1.0).abs() < 1e-7, "{} vs {r_mono}", p.r_hi);
    assert!(!ray_at(&p, Point2::new(r_mono as f32 * 0.999, 0.0)).is_culled());
    assert!(ray_at(&p, Point2::new(r_mono as f32 * 1.001, 0.0)).is_culled());
    // A positive k0 leaves a small blind disk at the centre, up to θ = 0.
    let hole = Fisheye::new(
        &ProjectionEnvironment::for_format(Format::new(64, 64)),
        &Lens {
            polynomial: [0.01, -0.1, 0.0, 0.0, 0.0],
            ..Lens {
                mapping: Mapping::Polynomial,
                fov: 180.0,
                focal_length_mm: 10.5,
                sensor_width_mm: 36.0,
                polynomial: [0.0; 5],
            }
        },
    )
    .unwrap();
    assert!((hole.r_lo * 180.0 - 1.0).abs() < 1e-7, "{}", hole.r_lo);
    assert!(ray_at(&hole, Point2::ZERO).is_culled());
}

#[test]
fn blenders_default_lens_with_its_off_axis_centre_is_finite_and_invertible() {
    // k0 = −1.17e-5: the centre looks 1.17e-5 rad off axis; directions closer to +Z are unseen.
    let format = Format::new(96, 64);
    let p = make(
        &[
            ("string mapping", &["polynomial"]),
            ("float[5] polynomial", &BLENDER_DEFAULT),
        ],
        format,
    )
    .unwrap();
    let centre = ray_at(p.as_ref(), Point2::ZERO);
    assert!(
        (angle_from_z(centre.direction) - 1.173_514_3e-5).abs() < 1e-9,
        "{centre:?}"
    );
    assert!(centre.ray_spread.is_finite() && centre.ray_spread > 0.0);
    assert_eq!(p.unproject(Vec3::Z, 0.0), None);
    for i in 1..400 {
        let a = i as f32 * 0.618;
        let r = 1.5 * i as f32 / 400.0;
        let s = Point2::new(r * a.cos(), r * a.sin());
        let ray = ray_at(p.as_ref(), s);
        assert!((ray.direction.length() - 1.0).abs() < 1e-6 && ray.ray_spread.is_finite());
        let back = p.unproject(ray.direction * 3.0, 0.0).unwrap();
        let px = 3.0 / 96.0;
        assert!(
            (back.x - s.x).abs() < 1e-4 * px && (back.y - s.y).abs() < 1e-4 * px,
            "{s:?} -> {back:?}"
        );
    }
}

#[test]
fn newton_converges_within_eight_steps() {
    let format = Format::new(1920, 1080);
    let p = make(
        &[
            ("string mapping", &["polynomial"]),
            ("float[5] polynomial", &BLENDER_DEFAULT),
        ],
        format,
    )
    .unwrap();
    let env = ProjectionEnvironment::for_format(format);
    let k: Vec<f32> = BLENDER_DEFAULT.iter().map(|s| s.parse().unwrap()).collect();
    let fish = Fisheye::new(
        &env,
        &Lens {
            mapping: Mapping::Polynomial,
            fov: 180.0,
            focal_length_mm: 10.5,
            sensor_width_mm: 36.0,
            polynomial: [k[0], k[1], k[2], k[3], k[4]],
        },
    )
    .unwrap();
    // Over the image: out to the window's corner, sqrt(1.778² + 1) screen units.
    let (lo, hi) = (fish.theta_of(fish.r_lo), fish.theta_of(2.04));
    assert!(fish.r_hi > 2.04);
    for i in 0..=1000 {
        let theta = lo + (hi - lo) * f64::from(i) / 1000.0;
        let (r, steps) = fish.solve_polynomial(theta);
        assert!((fish.theta_of(r) - theta).abs() < 1e-12, "θ {theta}");
        assert!(steps <= 8, "θ {theta}: {steps} steps");
    }
    assert!(p.unproject(Vec3::new(0.1, 0.2, 1.0), 0.0).is_some());
}

#[test]
fn impossible_lenses_are_refused_by_name() {
    let format = Format::new(8, 8);
    for (params, needle) in [
        (
            vec![
                ("string mapping", &["stereographic"][..]),
                ("float fov", &["360"][..]),
            ],
            "\"fov\" = 360 is out of range for mapping \"stereographic\"",
        ),
        (
            vec![
                ("string mapping", &["orthographic"][..]),
                ("float fov", &["200"][..]),
            ],
            "expected a value in (0, 180]",
        ),
        (vec![("float fov", &["400"][..])], "\"fov\" = 400 is out of range"),
        (vec![("string mapping", &["fisheye"][..])], "\"mapping\""),
        (
            vec![
                ("string mapping", &["polynomial"][..]),
                ("float[5] polynomial", &["0", "0", "0", "0", "0"][..]),
            ],
            "k1..k4 are all zero",
        ),
        (
            vec![
                ("string mapping", &["polynomial"][..]),
                ("float[5] polynomial", &["-2", "-0.1", "0", "0", "0"][..]),
            ],
            "beyond fov/2",
        ),
    ] {
        let err = make(&params, format).err().unwrap().to_string();
        assert!(err.starts_with("Fisheye: "), "{err}");
        assert!(err.contains(needle), "{err}");
    }
}

#[test]
fn properties_are_honest() {
    let p = lens("equidistant", "220", Format::new(48, 32));
    assert_spherical_ray_length(p.as_ref(), None, Some(220.0));
    assert_eq!(p.property(ProjectionProperty::FStop), None);
    // Equisolid on a 3:2 window: the shorter side is 24 mm, 12 mm each way: 2·2·asin(12/21).
    let e = lens("equisolid", "180", Format::new(48, 32));
    let expected = (4.0 * (12.0f64 / 21.0).asin()).to_degrees() as f32;
    let Some(PropertyValue::Float(got)) = e.property(ProjectionProperty::FieldOfView) else {
        panic!("no field of view")
    };
    assert!((got - expected).abs() < 1e-3, "{got} vs {expected}");
    let mut env = ProjectionEnvironment::for_format(Format::new(8, 8));
    FisheyeFactory
        .create_projection(&mut env, &ParamList::new())
        .unwrap();
    assert_eq!(env.deep_metric(), DeepMetric::RayLength);
}

/// The equidistant law takes θ's sine and cosine from the branch-free polynomial
/// ([`crate::panorama::sin_cos`]) so its batch loop vectorises. Over a dense grid of the image circle,
/// every ray is within 2·10⁻⁷ rad of the same ray computed with the library's `f32::sin_cos` (the
/// scalar formula it replaced), and no farther from the exact ray (`θ = h·r`, the sine and cosine in
/// f64 from the same f32 screen point) than that one plus 10⁻⁷ rad. Measured on this grid (601²,
/// printed with `--nocapture`): 1.43e-7, 1.41e-7, 1.50e-7 rad from the library formula at 360°, 180°,
/// 90°; from the exact ray 4.35e-7, 1.75e-7, 1.36e-7 against the library's 3.87e-7, 1.62e-7, 1.10e-7
/// (both dominated by θ = h·r rounded in f32).
#[test]
fn equidistant_rays_are_within_2e_7_rad_of_the_scalar_formula() {
    let format = Format::new(601, 601);
    let w = ScreenWindow::default_for(format);
    let f64s = |v: Vec3| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
    for fov in ["360", "180", "90"] {
        let p = lens("equidistant", fov, format);
        let h = 0.5 * f64::from(fov.parse::<f32>().unwrap()).to_radians() as f32;
        let screen: Vec<Point2> = (0..601 * 601)
            .map(|i| w.raster_to_screen(format, (i % 601) as f64 + 0.37, (i / 601) as f64 + 0.61))
            .collect();
        let n = screen.len();
        let rays = project_points(p.as_ref(), &screen, &vec![Point2::ZERO; n], &vec![0.0; n]);
        let (mut to_libm, mut to_exact, mut libm_to_exact, mut checked) = (0.0f64, 0.0f64, 0.0f64, 0);
        for (s, r) in screen.iter().zip(&rays) {
            if r.is_culled() {
                continue;
            }
            let (sx, sy) = (f64::from(s.x), f64::from(s.y));
            let rr = sx.hypot(sy);
            let theta = f64::from(h) * rr;
            let b = if rr > 0.0 { theta.sin() / rr } else { f64::from(h) };
            let exact = [b * sx, b * sy, theta.cos()];
            // The scalar formula this replaced: the library's f32 sine and cosine.
            let rf = (s.x * s.x + s.y * s.y).sqrt();
            let (sin, cos) = (h * rf).sin_cos();
            let bf = if rf > 0.0 { sin.max(0.0) / rf } else { h };
            let libm = Vec3::new(bf * s.x, bf * s.y, cos);
            to_libm = to_libm.max(testing::angle(r.direction, libm));
            to_exact = to_exact.max(crate::panorama::angle_between(f64s(r.direction), exact));
            libm_to_exact = libm_to_exact.max(crate::panorama::angle_between(f64s(libm), exact));
            checked += 1;
        }
        assert!(checked > n / 2, "{fov}: {checked} valid");
        eprintln!(
            "equidistant {fov}°: {to_libm:.2e} rad from the f32 library formula; from the exact ray {to_exact:.2e} (library: {libm_to_exact:.2e})"
        );
        assert!(
            to_libm < 2e-7,
            "equidistant {fov}°: {to_libm} rad off the scalar formula"
        );
        assert!(
            to_exact < libm_to_exact + 1e-7,
            "equidistant {fov}°: {to_exact} vs {libm_to_exact}"
        );
    }
}
