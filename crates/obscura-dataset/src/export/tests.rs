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
