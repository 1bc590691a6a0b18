//! The RI camera model: Format's defaults, FrameAspectRatio and the default ScreenWindow,
//! Perspective, DepthOfField, CoordinateSystem/CoordSysTransform, and the requests read without
//! effect. Each against the RISpec 3.2 closed form.

use glam::Vec3;
use obscura_sdk::{Format, ParamValue, ScreenWindow};

use super::*;

fn window(text: &str) -> ScreenWindow {
    ok(text).camera.screen_window()
}

#[test]
fn format_values_at_or_below_zero_mean_the_default() {
    // RenderMan writes a pixel aspect of -1 for "the default", which is 1.
    assert_eq!(ok("Format 320 240 -1\n").camera.format, Format::new(320, 240));
    assert_eq!(ok("Format 320 240 0\n").camera.format, Format::new(320, 240));
    // A width or height ≤ 0 keeps the current one (640 × 480 by default).
    assert_eq!(ok("Format 0 100 1\n").camera.format, Format::new(640, 100));
    assert_eq!(ok("Format 300 200 1\nFormat -1 50 2\n").camera.format.width, 300);
}

#[test]
fn the_default_screen_window_follows_the_frame_aspect_ratio() {
    // RISpec 3.2 §4.1.1: a = FrameAspectRatio, else width·pixelaspect/height; (−a, a, −1, 1) for
    // a ≥ 1, else (−1, 1, −1/a, 1/a).
    assert_eq!(
        window("Format 640 480 1\nWorldBegin\n"),
        ScreenWindow::new(-4.0 / 3.0, 4.0 / 3.0, -1.0, 1.0)
    );
    assert_eq!(
        window("Format 300 600 1\nWorldBegin\n"),
        ScreenWindow::new(-1.0, 1.0, -2.0, 2.0)
    );
    assert_eq!(
        window("Format 200 100 0.5\nWorldBegin\n"),
        ScreenWindow::new(-1.0, 1.0, -1.0, 1.0)
    );
    assert_eq!(
        window("FrameAspectRatio 2\nFormat 640 480 1\nWorldBegin\n"),
        ScreenWindow::new(-2.0, 2.0, -1.0, 1.0)
    );
    assert_eq!(
        window("Format 640 480 1\nFrameAspectRatio 0.5\nWorldBegin\n"),
        ScreenWindow::new(-1.0, 1.0, -2.0, 2.0)
    );
    // An explicit ScreenWindow wins, whatever the order.
    assert_eq!(
        window("ScreenWindow -1 1 -1 1\nFrameAspectRatio 2\nWorldBegin\n"),
        ScreenWindow::new(-1.0, 1.0, -1.0, 1.0)
    );
    assert_eq!(
        fail("FrameAspectRatio 0\n"),
        "t.rib:1: FrameAspectRatio expects a positive aspect ratio, got 0"
    );
}

#[test]
fn projection_perspective_and_the_perspective_request_give_the_pinhole_with_that_fov() {
    let s = ok("Projection \"perspective\"\nWorldBegin\n");
    assert_eq!(s.projection, "PxrPerspective");
    // RISpec: the default fov is 90, which is also PxrPerspective's default: no parameter needed.
    assert!(s.projection_params.get("fov").is_none());
    let s = ok("Perspective 35\nWorldBegin\n");
    assert_eq!(s.projection, "PxrPerspective");
    assert_eq!(
        s.projection_params.get("fov").unwrap().value,
        ParamValue::Floats(vec![35.0])
    );
    let s = ok("WorldBegin\nPerspective 35\n");
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
}

#[test]
fn depth_of_field_is_the_perspective_cameras_thin_lens() {
    let s = ok("Projection \"perspective\" \"fov\" 40\nDepthOfField 2.8 0.05 4\nWorldBegin\n");
    let f = |n: &str| s.projection_params.get(n).map(|p| p.value.clone());
    assert_eq!(f("fStop"), Some(ParamValue::Floats(vec![2.8])));
    assert_eq!(f("focalLength"), Some(ParamValue::Floats(vec![0.05])));
    assert_eq!(f("focalDistance"), Some(ParamValue::Floats(vec![4.0])));
    // Order does not matter; the projection's own lens parameters win; no arguments is a pinhole.
    let s = ok("DepthOfField 2.8 0.05 4\nProjection \"perspective\" \"float fStop\" [8]\nWorldBegin\n");
    assert_eq!(
        s.projection_params.get("fStop").unwrap().value,
        ParamValue::Floats(vec![8.0])
    );
    let s = ok("DepthOfField 2.8 0.05 4\nDepthOfField\nProjection \"perspective\"\nWorldBegin\n");
    assert!(s.projection_params.get("fStop").is_none());
    // Another projection keeps its own lens, said so.
    let s = ok("Projection \"PxrFisheye\"\nDepthOfField 2.8 0.05 4\nWorldBegin\n");
    assert!(s.projection_params.get("fStop").is_none());
    assert!(
        s.warnings[0].contains("DepthOfField is the perspective camera's lens"),
        "{:?}",
        s.warnings
    );
    assert_eq!(
        fail("DepthOfField 0 1 1\n"),
        "t.rib:1: DepthOfField expects a positive fstop, focal length and focal distance, got 0 1 1"
    );
}

#[test]
fn coordinate_systems_are_named_transforms() {
    let o = only_object(
        "AttributeBegin\nTranslate 1 2 3\nCoordinateSystem \"lamp\"\nAttributeEnd\n\
         Translate 9 9 9\nCoordSysTransform \"lamp\"\nSphere 1 -1 1 360",
    );
    assert!(close(
        o.transform.samples[0].1.transform_point3(Vec3::ZERO),
        Vec3::new(1.0, 2.0, 3.0)
    ));
    // "camera" in the world is camera → world.
    let o = only_object("Translate 5 0 0\nCoordSysTransform \"camera\"\nSphere 1 -1 1 360")
        .transform
        .samples[0]
        .1;
    assert!(close(o.transform_point3(Vec3::ZERO), Vec3::ZERO));
    let s = ok("Translate 0 0 5\nWorldBegin\nCoordSysTransform \"camera\"\nSphere 1 -1 1 360\n");
    let m = s.objects[0].transform.samples[0].1;
    assert!(close(m.transform_point3(Vec3::ZERO), Vec3::new(0.0, 0.0, -5.0)));
    assert_eq!(
        fail("WorldBegin\nCoordSysTransform \"nope\"\n"),
        "t.rib:2: CoordSysTransform: no coordinate system \"nope\" (named so far: none; predefined: world, camera, object)"
    );
}

#[test]
fn requests_without_an_effect_here_are_named_once() {
    let s = ok(
        "Sides 1\nWorldBegin\nSides 2\nOrientation \"rh\"\nReverseOrientation\nClippingPlane 0 0 1 0 0 -1\n",
    );
    assert_eq!(
        s.warnings,
        [
            "t.rib:1: Sides: one-sided culling is not supported: both sides of every surface render",
            "t.rib:4: Orientation: orientation does not change what renders (surfaces are two-sided and normals face the ray)",
            "t.rib:5: ReverseOrientation: orientation does not change what renders (surfaces are two-sided and normals face the ray)",
            "t.rib:6: ClippingPlane: clipping planes are not supported: geometry beyond it renders",
        ]
    );
}
