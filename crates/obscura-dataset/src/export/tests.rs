use super::*;

#[test]
fn format_names_round_trip_and_unknown_names_list_the_choices() {
    for f in ExportFormat::ALL {
        assert_eq!(f.name().parse::<ExportFormat>().unwrap(), f);
    }
    let e = "colmpa".parse::<ExportFormat>().unwrap_err().to_string();
    assert!(
        e.contains("\"colmpa\"") && e.contains("colmap, nerfstudio, gsplat"),
        "{e}"
    );
}

#[test]
fn poses_compose_and_invert() {
    let m = DMat4::from_rotation_translation(
        DQuat::from_rotation_y(0.7) * DQuat::from_rotation_x(-0.2),
        DVec3::new(1.0, -2.0, 3.0),
    );
    let p = Pose::from_matrix(m).unwrap();
    assert!(p.matrix().abs_diff_eq(m, 1e-12));
    let id = p.compose(&p.inverse());
    assert!(id.matrix().abs_diff_eq(DMat4::IDENTITY, 1e-12));
    assert!(Pose::from_matrix(DMat4::from_scale(DVec3::splat(2.0))).is_none());
    assert!(p.colmap_quaternion()[0] >= 0.0);
}

#[test]
fn bad_camera_json_is_an_error_naming_the_camera_and_frame() {
    let dir = tempfile::tempdir().unwrap();
    let frame = |camera: Value, image: &str| ExportCamera {
        name: "cam".into(),
        frames: vec![ExportFrame {
            frame: 3,
            image: image.into(),
            camera,
        }],
    };
    let e = write_exports(
        dir.path(),
        &[frame(serde_json::json!({}), "a.exr")],
        &[ExportFormat::Gsplat],
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("camera \"cam\", frame 3") && e.contains("world_to_camera.open"),
        "{e}"
    );
    let id = serde_json::json!([
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0]
    ]);
    let camera = serde_json::json!({"world_to_camera": {"open": id, "close": id}});
    let e = write_exports(
        dir.path(),
        &[frame(camera.clone(), "a.exr")],
        &[ExportFormat::Colmap],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("equivalents.colmap") && e.contains("re-render"), "{e}");
    let mut camera = camera;
    camera["equivalents"]["colmap"] =
        serde_json::json!({"model": "PINHOLE", "width": 4, "height": 3, "params": [1.0, 1.0, 2.0, 1.5]});
    let e = write_exports(
        dir.path(),
        &[frame(camera.clone(), "my image.exr")],
        &[ExportFormat::Colmap],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("my image.exr") && e.contains("whitespace"), "{e}");
    let warnings = write_exports(
        dir.path(),
        &[frame(camera, "images/a.exr")],
        &[ExportFormat::Colmap],
    )
    .unwrap();
    let images = std::fs::read_to_string(dir.path().join("colmap/images.txt")).unwrap();
    assert!(images.contains(" 1 images/a.exr\n\n"), "{images}");
    assert!(
        warnings.is_empty() || warnings.iter().all(|w| w.starts_with("exports:")),
        "{warnings:?}"
    );
}
