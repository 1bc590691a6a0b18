//! `obscura_sdk::contract` over the built-in projections: every one keeps the contract with its default
//! parameters (the test walks the registry, so a new projection is covered as soon as it is registered),
//! and the perspective and orthographic cameras keep it in their depth-of-field, zoom and non-default
//! window variants.

use obscura_check::{CheckKind, CheckOptions, Status, check_registered};
use obscura_plugins::builtin_registry;
use obscura_sdk::{Format, ParamList, ScreenWindow};

fn params(list: &[(&str, &str)]) -> ParamList {
    let mut p = ParamList::new();
    for (decl, value) in list {
        p.push_text(decl, &[value], None).unwrap();
    }
    p
}

/// Small enough to keep the whole registry quick in a debug build, large enough for the spread check.
fn options() -> CheckOptions {
    CheckOptions {
        format: Format::new(48, 36),
        samples_per_pixel: 2,
        threads: 3,
        ..CheckOptions::default()
    }
}

#[test]
fn every_builtin_keeps_the_contract_with_default_parameters() {
    let mut registry = builtin_registry();
    let names = registry.names();
    assert!(names.len() >= 2, "{names:?}");
    let mut dirty = Vec::new();
    for name in &names {
        let report = check_registered(&mut registry, name, &ParamList::new(), &options())
            .unwrap_or_else(|e| panic!("{name} refused its own defaults: {e}"));
        // Every per-ray and repeatability check must have looked at something.
        for kind in [
            CheckKind::DirectionUnit,
            CheckKind::Determinism,
            CheckKind::Threads,
            CheckKind::PropertyType,
        ] {
            assert_ne!(report.get(kind).status(), Status::NotChecked, "{report}");
        }
        if !report.is_clean() {
            dirty.push(report.to_string());
        }
    }
    assert!(dirty.is_empty(), "\n{}", dirty.join("\n\n"));
}

#[test]
fn perspective_pinhole_thin_lens_and_zoom_are_clean() {
    let mut registry = builtin_registry();
    let cases: [&[(&str, &str)]; 5] = [
        &[],
        &[("float fov", "30")],
        &[("float fov", "150")],
        &[
            ("float fStop", "2.8"),
            ("float focalLength", "0.5"),
            ("float focalDistance", "4"),
        ],
        &[("float fov", "60"), ("float fovEnd", "30")],
    ];
    for case in cases {
        let report = check_registered(&mut registry, "PxrPerspective", &params(case), &options()).unwrap();
        assert!(report.is_clean(), "{case:?}\n{report}");
        for kind in [
            CheckKind::RaySpread,
            CheckKind::FieldOfView,
            CheckKind::DeepMetric,
            CheckKind::DicingHint,
            CheckKind::Unproject,
        ] {
            assert_eq!(report.get(kind).status(), Status::Ok, "{case:?}\n{report}");
        }
    }
}

/// Regression: PxrCamera reported its undistorted `fov` as FieldOfView, up to 20° off the rays'
/// extent with strong distortion or a lens shift.
#[test]
fn pxrcamera_distortion_shift_and_lens_keep_the_contract() {
    let mut registry = builtin_registry();
    let cases: [&[(&str, &str)]; 6] = [
        &[("float radial1", "-0.3")],
        &[("float radial1", "0.3")],
        &[
            ("float radial1", "-0.1"),
            ("float squeeze", "2"),
            ("float assymY", "0.05"),
        ],
        &[("float shiftX", "0.3")],
        &[
            ("float shiftY", "-0.5"),
            ("float fov", "60"),
            ("float fovEnd", "40"),
        ],
        &[
            ("float focalLength", "0.05"),
            ("float fStop", "2"),
            ("float tilt", "10"),
            ("float radial1", "-0.05"),
            ("float natural", "1"),
        ],
    ];
    for case in cases {
        let report = check_registered(&mut registry, "PxrCamera", &params(case), &options()).unwrap();
        assert!(report.is_clean(), "{case:?}\n{report}");
        assert_eq!(
            report.get(CheckKind::FieldOfView).status(),
            Status::Ok,
            "{case:?}\n{report}"
        );
    }
}

/// Regression: PxrRollingShutter took fov up to 180 while the host's default rays stop at 179°, so
/// its `unproject` inverted a camera the rays did not come from (20 pixels off at 179.5).
#[test]
fn the_rolling_shutter_base_stops_where_the_hosts_pinhole_does() {
    let mut registry = builtin_registry();
    let p = params(&[
        ("float fov", "179"),
        ("string sweep", "left"),
        ("float duration", "0.5"),
    ]);
    let report = check_registered(&mut registry, "PxrRollingShutter", &p, &options()).unwrap();
    assert!(report.is_clean(), "{report}");
    let err = check_registered(
        &mut registry,
        "PxrRollingShutter",
        &params(&[("float fov", "179.5")]),
        &options(),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("\"fov\"") && err.contains("179"), "{err}");
}

#[test]
fn a_zoom_passes_with_the_narrower_field_of_view_either_way_round() {
    let mut registry = builtin_registry();
    for (fov, end) in [("60", "30"), ("30", "60")] {
        let p = params(&[("float fov", fov), ("float fovEnd", end)]);
        let report = check_registered(&mut registry, "PxrPerspective", &p, &options()).unwrap();
        assert!(report.is_clean(), "{report}");
        assert_eq!(
            report.properties[2].1,
            Some(obscura_sdk::PropertyValue::Float(30.0)),
            "{report}"
        );
    }
}

#[test]
fn orthographic_with_and_without_a_lens_is_clean() {
    let mut registry = builtin_registry();
    for case in [
        &[][..],
        &[
            ("float fStop", "2"),
            ("float focalLength", "1"),
            ("float focalDistance", "3"),
        ][..],
    ] {
        let report = check_registered(&mut registry, "PxrOrthographic", &params(case), &options()).unwrap();
        assert!(report.is_clean(), "{case:?}\n{report}");
        assert_eq!(report.get(CheckKind::FieldOfView).status(), Status::NotChecked);
        for kind in [CheckKind::RaySpread, CheckKind::DicingHint, CheckKind::Unproject] {
            assert_eq!(report.get(kind).status(), Status::Ok, "{case:?}\n{report}");
        }
    }
}

#[test]
fn an_off_centre_window_and_wide_pixels_stay_clean() {
    let mut registry = builtin_registry();
    let opts = CheckOptions {
        format: Format {
            width: 40,
            height: 30,
            pixel_aspect: 1.5,
        },
        screen_window: Some(ScreenWindow::new(-0.5, 1.5, -0.75, 0.5)),
        ..options()
    };
    for name in ["PxrPerspective", "PxrOrthographic"] {
        let report = check_registered(&mut registry, name, &ParamList::new(), &opts).unwrap();
        assert!(report.is_clean(), "{report}");
    }
}

#[test]
fn a_parameter_out_of_range_is_an_error_not_a_report() {
    let mut registry = builtin_registry();
    let err = check_registered(
        &mut registry,
        "PxrPerspective",
        &params(&[("float fov", "200")]),
        &options(),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("fov") && err.contains("out of range"), "{err}");
}
