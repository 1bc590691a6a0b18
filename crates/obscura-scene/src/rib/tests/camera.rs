//! The RI camera model: Format's defaults, FrameAspectRatio and the default ScreenWindow,
//! Perspective, DepthOfField, Exposure, ClippingPlane, CoordinateSystem/CoordSysTransform, and the
//! orientation attributes (Sides, Orientation, ReverseOrientation). Each against the RISpec 3.2
//! closed form.

use glam::{Mat4, Vec3};
use obscura_host::CropWindow;
use obscura_sdk::{Format, ParamValue, ScreenWindow};

use crate::visibility::{ClipPlane, ClipSpace, Exposure, Sides};

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
    // A FrameAspectRatio equal to the raster's changes nothing.
    let s = ok("Format 640 480 1\nFrameAspectRatio 1.3333334\nWorldBegin\n");
    assert_eq!(
        s.camera.screen_window(),
        ScreenWindow::new(-4.0 / 3.0, 4.0 / 3.0, -1.0, 1.0)
    );
    assert_eq!(s.camera.crop_window, CropWindow::default());
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
fn a_projection_after_another_keeps_the_earlier_as_its_base_and_frames_restore_it() {
    // RenderMan applies a built-in declared before a plugin first; the reader keeps the order.
    let s = ok("Projection \"perspective\" \"fov\" 40\nProjection \"Strobe\" \"int n\" 3\nWorldBegin\n");
    assert_eq!(s.projection, "Strobe");
    // Errors about a projection name the request that named it.
    assert_eq!(s.projection_origin.as_deref(), Some("t.rib:2"));
    let (name, params) = s.projection_base.expect("the earlier projection is kept");
    assert_eq!(name, "PxrPerspective");
    assert_eq!(params.get("fov").unwrap().value, ParamValue::Floats(vec![40.0]));
    // `Perspective` declares the built-in too.
    let s = ok("Perspective 35\nProjection \"Strobe\"\nWorldBegin\n");
    assert_eq!(s.projection_base.unwrap().0, "PxrPerspective");
    let s = ok("Format 8 6 1\n\nPerspective 35\nWorldBegin\n");
    assert_eq!(s.projection_origin.as_deref(), Some("t.rib:3"));
    assert_eq!(ok("WorldBegin\n").projection_origin, None);
    // The first projection has no base, and a later `Perspective` replaces the chain.
    assert!(
        ok("Projection \"Strobe\"\nWorldBegin\n")
            .projection_base
            .is_none()
    );
    assert!(
        ok("Projection \"Strobe\"\nPerspective 35\nWorldBegin\n")
            .projection_base
            .is_none()
    );
    // A projection declared inside one frame is not the base of the next frame's.
    let frames = crate::rib::parse_bytes_frames(
        b"FrameBegin 1\nProjection \"perspective\"\nWorldBegin\nWorldEnd\nFrameEnd\n\
          FrameBegin 2\nProjection \"Strobe\"\nWorldBegin\nWorldEnd\nFrameEnd\n",
        "frames.rib",
        std::path::Path::new("."),
    )
    .unwrap();
    assert_eq!(frames[1].scene.projection, "Strobe");
    assert!(frames[1].scene.projection_base.is_none());
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
    // An fstop of RI_INFINITY is a pinhole whatever the other two say (Affine's `DepthOfField 1e38 0 0`),
    // and it replaces an earlier lens.
    let s = ok("DepthOfField 2.8 0.05 4\nDepthOfField 1e38 0 0\nProjection \"perspective\"\nWorldBegin\n");
    assert!(s.projection_params.get("fStop").is_none());
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // A focal length of 0 leaves no aperture (focallength/fstop = 0): a pinhole too (Affine's
    // `DepthOfField 1e+37 0 0`); a negative one is still refused.
    let s = ok("DepthOfField 2.8 0.05 4\nDepthOfField 1e+37 0 0\nProjection \"perspective\"\nWorldBegin\n");
    assert!(s.projection_params.get("fStop").is_none());
    assert_eq!(
        fail("DepthOfField 2.8 -1 1\n"),
        "t.rib:1: DepthOfField expects a positive fstop, focal length and focal distance, got 2.8 -1 1"
    );
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

/// The screen position of raster point `(x, y)`, as the camera maps it.
fn screen_at(s: &crate::types::Scene, x: f64, y: f64) -> (f32, f32) {
    let p = s.camera.raster_to_screen(x, y);
    (p.x, p.y)
}

#[test]
fn a_frame_aspect_ratio_other_than_the_rasters_fits_the_frame_top_left() {
    // RISpec 3.2 §4.1.1: the picture keeps the raster, fits inside it with the frame aspect and is
    // aligned with its upper left corner. 640×480 (aspect 4/3) with a = 2: the frame is 640 × 320
    // pixels, and the default window (−2, 2, −1, 1) spans exactly those.
    let s = ok("FrameAspectRatio 2\nFormat 640 480 1\nWorldBegin\n");
    let close2 = |a: (f32, f32), b: (f32, f32)| (a.0 - b.0).abs() < 1e-5 && (a.1 - b.1).abs() < 1e-5;
    assert!(close2(screen_at(&s, 0.0, 0.0), (-2.0, 1.0)));
    assert!(close2(screen_at(&s, 640.0, 320.0), (2.0, -1.0)));
    // Any pixel centre: sx = −2 + 4·(x/640), sy = 1 − 2·(y/320), the frame's own closed form.
    for (x, y) in [(0.5, 0.5), (100.5, 200.5), (639.5, 319.5)] {
        assert!(close2(
            screen_at(&s, x, y),
            ((-2.0 + 4.0 * x / 640.0) as f32, (1.0 - 2.0 * y / 320.0) as f32)
        ));
    }
    // Only the frame's rows are rendered.
    assert_eq!(s.camera.pixels().y1, 320);
    assert_eq!(s.camera.pixels().x1, 640);
    // a = 0.5 < 4/3: the frame is 240 × 480 (height fills), window (−1, 1, −2, 2) over it.
    let s = ok("Format 640 480 1\nFrameAspectRatio 0.5\nWorldBegin\n");
    assert!(close2(screen_at(&s, 240.0, 480.0), (1.0, -2.0)));
    assert!(close2(screen_at(&s, 0.0, 0.0), (-1.0, 2.0)));
    assert_eq!((s.camera.pixels().x1, s.camera.pixels().y1), (240, 480));
    // Non-square pixels: 200×100 at pixel aspect 2 has aspect 4; a = 1 makes a frame 50 × 100
    // pixels (50·2/100 = 1).
    let s = ok("Format 200 100 2\nFrameAspectRatio 1\nWorldBegin\n");
    assert!(close2(screen_at(&s, 50.0, 100.0), (1.0, -1.0)));
    assert_eq!(s.camera.pixels().x1, 50);
    // An explicit ScreenWindow maps onto the frame too, whatever the order; a crop stays inside it.
    let s = ok(
        "ScreenWindow -1 1 -1 1\nCropWindow 0.5 1 0 1\nFrameAspectRatio 2\nFormat 640 480 1\nWorldBegin\n",
    );
    assert!(close2(screen_at(&s, 640.0, 320.0), (1.0, -1.0)));
    assert_eq!(
        (s.camera.pixels().x0, s.camera.pixels().x1, s.camera.pixels().y1),
        (320, 640, 320)
    );
}

#[test]
fn exposure_is_kept_for_the_outputs() {
    assert_eq!(ok("WorldBegin\n").exposure, Exposure::default());
    let s = ok("Exposure 2 2.2\nWorldBegin\n");
    assert_eq!(
        s.exposure,
        Exposure {
            gain: 2.0,
            gamma: 2.2
        }
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // (c·gain)^(1/gamma), per component.
    assert!((s.exposure.apply(0.3) - 0.6f32.powf(1.0 / 2.2)).abs() < 1e-6);
    assert_eq!(Exposure::default().apply(0.3), 0.3);
    assert_eq!(
        fail("Exposure 1 0\n"),
        "t.rib:1: Exposure expects a gain ≥ 0 and a gamma > 0, got 1 0"
    );
    // A deep display cannot take the gamma: said so.
    let s = ok("Display \"d.exr\" \"deepexr\" \"rgba\"\nExposure 1 2\nWorldBegin\n");
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("deep samples take the gain only")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn sides_and_orientation_are_attributes_that_pick_the_visible_side() {
    let sides = |body: &str| -> Vec<Sides> {
        ok(&format!("WorldBegin\n{body}\nWorldEnd\n"))
            .objects
            .iter()
            .map(|o| o.sides)
            .collect()
    };
    let sphere = "Sphere 1 -1 1 360";
    assert_eq!(sides(sphere), [Sides::Both]);
    // Saved by AttributeBegin/End.
    assert_eq!(
        sides(&format!(
            "AttributeBegin\nSides 1\n{sphere}\nAttributeEnd\n{sphere}"
        )),
        [Sides::Front, Sides::Both]
    );
    // ReverseOrientation toggles; Orientation "inside"/"outside" set against the coordinate system.
    assert_eq!(
        sides(&format!(
            "Sides 1\nReverseOrientation\n{sphere}\nReverseOrientation\n{sphere}\nOrientation \"inside\"\n{sphere}\nOrientation \"outside\"\n{sphere}"
        )),
        [Sides::Back, Sides::Front, Sides::Back, Sides::Front]
    );
    // A mirror flips the coordinate system and the orientation together: nothing turns inside out.
    // "lh" in the mirrored (right-handed) space does; "rh" there does not.
    assert_eq!(
        sides(&format!(
            "Sides 1\nScale -1 1 1\n{sphere}\nOrientation \"lh\"\n{sphere}\nOrientation \"rh\"\n{sphere}"
        )),
        [Sides::Front, Sides::Back, Sides::Front]
    );
    // The camera transform counts: a world mirrored before WorldBegin is right-handed.
    let s = ok(&format!(
        "Scale 1 1 -1\nWorldBegin\nSides 1\nOrientation \"rh\"\n{sphere}\nOrientation \"lh\"\n{sphere}\n"
    ));
    assert_eq!(
        s.objects.iter().map(|o| o.sides).collect::<Vec<_>>(),
        [Sides::Front, Sides::Back]
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // An instance takes the attributes current where it is placed (RISpec 3.2 §5.10).
    assert_eq!(
        sides(&format!(
            "ObjectBegin 1\n{sphere}\nObjectEnd\nObjectInstance 1\nAttributeBegin\nSides 1\nReverseOrientation\nObjectInstance 1\nAttributeEnd"
        )),
        [Sides::Both, Sides::Back]
    );
    assert_eq!(fail("Sides 3\n"), "t.rib:1: Sides expects 1 or 2, got 3");
    assert_eq!(
        fail("Orientation \"up\"\n"),
        "t.rib:1: Orientation expects one of \"outside\", \"inside\", \"lh\", \"rh\", got \"up\""
    );
}

#[test]
fn clipping_planes_are_placed_by_the_current_transform_and_accumulate() {
    // Before WorldBegin: camera space (after the camera's own transform, the current space is the
    // world as the camera sees it, so the point moves with the CTM).
    let s = ok(
        "ClippingPlane 0 0 2 0 0 -1\nTranslate 0 0 5\nWorldBegin\nTranslate 1 0 0\nScale 2 1 1\nClippingPlane 1 0 0 1 1 0\n",
    );
    assert_eq!(s.clip_planes.len(), 2);
    assert_eq!(
        s.clip_planes[0],
        ClipPlane {
            point: Vec3::new(0.0, 0.0, 2.0),
            normal: Vec3::new(0.0, 0.0, -1.0),
            space: ClipSpace::Camera
        }
    );
    // In the world: p' = M·p, n' = M⁻ᵀ·n with M = Translate(1,0,0)·Scale(2,1,1).
    let m = Mat4::from_translation(Vec3::X) * Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0));
    let w = s.clip_planes[1];
    assert_eq!(w.space, ClipSpace::World);
    assert!(close(w.point, m.transform_point3(Vec3::X)));
    assert!(close(w.normal, Vec3::new(0.5, 1.0, 0.0)));
    // The normal stays perpendicular to the transformed plane: a direction in the plane, (1, −1, 0)
    // (⊥ to (1, 1, 0)), maps to one ⊥ to the transformed normal.
    assert!(m.transform_vector3(Vec3::new(1.0, -1.0, 0.0)).dot(w.normal).abs() < 1e-6);
    // A world's planes end with it; the camera's persist into the next world.
    let s = ok(
        "ClippingPlane 0 0 2 0 0 -1\nWorldBegin\nClippingPlane 0 0 0 1 0 0\nWorldEnd\nWorldBegin\nWorldEnd\n",
    );
    assert_eq!(s.clip_planes.len(), 1);
    assert_eq!(
        fail("ClippingPlane 0 0 0 0 0 0\n"),
        "t.rib:1: ClippingPlane expects a finite point and a finite, non-zero normal, got 0 0 0 0 0 0"
    );
}
