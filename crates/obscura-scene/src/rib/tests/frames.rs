//! Frames and worlds: FrameBegin/FrameEnd, several worlds per file, options that persist or not, and
//! lights declared before WorldBegin.

use std::path::Path;

use glam::{Mat4, Vec3};
use obscura_sdk::Format;

use super::*;
use crate::rib::{Frame, parse_bytes_frames, parse_file_frames};
use crate::types::Light;

fn frames(text: &str) -> Vec<Frame> {
    parse_bytes_frames(text.as_bytes(), "t.rib", Path::new(HERE)).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn each_frame_renders_with_the_options_outside_frames_and_its_own() {
    let f = frames(
        "Format 64 48 1\nDisplay \"all.exr\" \"openexr\" \"rgba\"\n\
         FrameBegin 7\n  Format 32 24 1\n  Display \"seven.tif\" \"file\" \"rgb\"\n  WorldBegin\n  Sphere 1 -1 1 360\n  WorldEnd\nFrameEnd\n\
         FrameBegin 8\n  WorldBegin\n  Cone 1 1 360\n  Disk 0 1 360\n  WorldEnd\nFrameEnd\n",
    );
    assert_eq!(f.len(), 2);
    assert_eq!(
        (f[0].number, f[0].numbered, f[0].world.as_str()),
        (7, true, "t.rib:6")
    );
    assert_eq!(f[0].scene.camera.format, Format::new(32, 24));
    assert_eq!(f[0].scene.displays[0].path, Path::new(HERE).join("seven.tif"));
    assert_eq!(f[0].scene.objects.len(), 1);
    // Frame 8 has the options from outside the frames, not frame 7's, and only its own world.
    assert_eq!(f[1].number, 8);
    assert_eq!(f[1].scene.camera.format, Format::new(64, 48));
    assert_eq!(f[1].scene.displays[0].path, Path::new(HERE).join("all.exr"));
    assert_eq!(f[1].scene.objects.len(), 2);
}

#[test]
fn worlds_outside_frames_carry_options_and_camera_into_the_next() {
    let f = frames(
        "Format 40 30 1\nTranslate 0 0 5\n\
         WorldBegin\nSphere 1 -1 1 360\nWorldEnd\n\
         Display \"second.exr\" \"openexr\" \"z\"\n\
         WorldBegin\nCone 1 1 360\nWorldEnd\n",
    );
    assert_eq!(f.len(), 2);
    assert_eq!((f[0].number, f[1].number, f[1].numbered), (1, 2, false));
    assert_eq!(f[1].scene.camera.format, Format::new(40, 30));
    assert_eq!(
        f[1].scene.camera.world_to_camera,
        f[0].scene.camera.world_to_camera
    );
    assert!(f[0].scene.displays.is_empty());
    assert_eq!(f[1].scene.displays.len(), 1);
    assert_eq!(
        f[1].scene.objects.len(),
        1,
        "the first world's sphere was freed at its WorldEnd"
    );
}

#[test]
fn a_shadow_pass_and_a_beauty_pass_in_one_frame_are_two_images_of_that_frame() {
    let f = frames(
        "FrameBegin 3\n\
         Display \"shadow.z\" \"zfile\" \"z\"\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n\
         Display \"beauty.tif\" \"file\" \"rgba\"\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n\
         FrameEnd\n",
    );
    assert_eq!(f.iter().map(|f| f.number).collect::<Vec<_>>(), [3, 3]);
    assert_eq!(f[0].scene.displays[0].path, Path::new(HERE).join("shadow.z"));
    assert_eq!(f[1].scene.displays[0].path, Path::new(HERE).join("beauty.tif"));
    // parse_str gives the last image: the beauty pass.
    let s = ok(
        "Display \"shadow.z\" \"zfile\" \"z\"\nWorldBegin\nWorldEnd\nDisplay \"b.tif\" \"file\" \"rgb\"\nWorldBegin\nWorldEnd\n",
    );
    assert_eq!(s.displays[0].path, Path::new(HERE).join("b.tif"));
}

#[test]
fn warnings_go_with_the_image_they_were_read_for() {
    let f = frames("Bogus1\nWorldBegin\nBogus2\nWorldEnd\nWorldBegin\nBogus3\nWorldEnd\n");
    assert_eq!(
        f[0].scene.warnings,
        [
            "t.rib:1: unknown request Bogus1, skipped",
            "t.rib:3: unknown request Bogus2, skipped"
        ]
    );
    assert_eq!(f[1].scene.warnings, ["t.rib:6: unknown request Bogus3, skipped"]);
}

#[test]
fn frame_errors_are_located() {
    assert_eq!(
        fail("FrameEnd\n"),
        "t.rib:1: FrameEnd without a matching FrameBegin"
    );
    assert_eq!(
        fail("FrameBegin 1\nFrameBegin 2\n"),
        "t.rib:2: FrameBegin inside the frame 1 begun at t.rib:1: frames do not nest"
    );
    assert_eq!(
        fail("FrameBegin -1\n"),
        "t.rib:1: FrameBegin expects a frame number (an integer ≥ 0), got -1"
    );
    assert_eq!(
        fail("WorldBegin\nFrameBegin 2\n"),
        "t.rib:2: FrameBegin inside the world begun at t.rib:1: WorldEnd is missing"
    );
    // A FrameEnd closing a world: read, with a warning.
    let f = frames("FrameBegin 1\nWorldBegin\nSphere 1 -1 1 360\nFrameEnd\n");
    assert_eq!(f.len(), 1);
    assert_eq!(
        f[0].scene.warnings,
        ["t.rib:4: FrameEnd inside a world: WorldEnd is missing, the world ends here"]
    );
}

#[test]
fn a_light_before_world_begin_is_fixed_to_the_camera() {
    // The light stands at camera-space (1, 2, 0); the camera is moved back 5 (world → camera is
    // translate(0, 0, 5) after a 90° turn about y).
    let s = ok("Projection \"perspective\" \"fov\" 40\n\
         Translate 1 2 0\nLightSource \"PxrSphereLight\" 1\nIdentity\n\
         Translate 0 0 5\nRotate 90 0 1 0\nWorldBegin\nWorldEnd\n");
    let Light::Sphere { transform, .. } = &s.lights[0] else {
        panic!("{:?}", s.lights)
    };
    let world_to_camera =
        Mat4::from_translation(Vec3::new(0.0, 0.0, 5.0)) * Mat4::from_axis_angle(Vec3::Y, 90f32.to_radians());
    let expected = world_to_camera
        .inverse()
        .transform_point3(Vec3::new(1.0, 2.0, 0.0));
    let got = transform.transform_point3(Vec3::ZERO);
    assert!(close(got, expected), "{got} vs {expected}");
}

#[test]
fn a_file_of_frames_is_read_with_its_frame_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("anim.rib");
    let mut text = String::from("Format 16 12 1\n");
    for n in [10, 11, 12] {
        text += &format!(
            "FrameBegin {n}\nTranslate 0 0 {n}\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\nFrameEnd\n"
        );
    }
    std::fs::write(&p, text).unwrap();
    let f = parse_file_frames(&p).unwrap();
    assert_eq!(f.iter().map(|f| f.number).collect::<Vec<_>>(), [10, 11, 12]);
    // Each frame's camera is its own: the transform was inside the frame.
    assert_camera_point(&f[2].scene, 0, Vec3::ZERO, Vec3::new(0.0, 0.0, 12.0));
}

/// The material of object `k` of frame `f`, checked to be in that frame's scene.
fn material_of(f: &Frame, k: usize) -> crate::types::Material {
    let index = f.scene.objects[k].material as usize;
    assert!(
        index < f.scene.materials.len(),
        "object {k} of frame {} names material {index} of {}",
        f.number,
        f.scene.materials.len()
    );
    f.scene.materials[index]
}

#[test]
fn frame_end_restores_the_classic_attributes() {
    // RISpec §4: FrameBegin/FrameEnd save and restore the attributes; frame 2 must not inherit
    // frame 1's Color and Surface.
    let f = frames(
        "FrameBegin 1\n  Color [1 0 0]\n  Surface \"matte\"\n  WorldBegin\n  Sphere 1 -1 1 360\n  WorldEnd\nFrameEnd\n\
         FrameBegin 2\n  WorldBegin\n  Sphere 1 -1 1 360\n  WorldEnd\nFrameEnd\n",
    );
    assert_eq!(
        material_of(&f[0], 0),
        crate::types::Material::Diffuse {
            color: obscura_sdk::Rgb::new(1.0, 0.0, 0.0)
        }
    );
    assert_eq!(f[1].scene.objects[0].material, 0);
    assert_eq!(material_of(&f[1], 0), crate::types::Material::default());
}

#[test]
fn world_end_restores_the_attributes_of_world_begin() {
    // A colour set before the first world carries into the next (outside any frame); one set inside
    // the world ends with it, as do the world's Surface and Basis.
    let f = frames(
        "Color [1 0 0]\nWorldBegin\n  Sphere 1 -1 1 360\n  Color [0 1 0]\n  Surface \"constant\"\n  Basis \"b-spline\" 1 \"b-spline\" 1\n  Sphere 1 -1 1 360\nWorldEnd\n\
         WorldBegin\n  Sphere 1 -1 1 360\n  Patch \"bicubic\" \"P\" [0 0 0 1 0 0 2 0 0 3 0 0 0 1 0 1 1 0 2 1 0 3 1 0 0 2 0 1 2 0 2 2 0 3 2 0 0 3 0 1 3 0 2 3 0 3 3 0]\nWorldEnd\n",
    );
    let red = obscura_sdk::Rgb::new(1.0, 0.0, 0.0);
    assert_eq!(
        material_of(&f[0], 1),
        crate::types::Material::Constant {
            color: obscura_sdk::Rgb::new(0.0, 1.0, 0.0)
        }
    );
    assert_eq!(
        material_of(&f[1], 0),
        crate::types::Material::Diffuse { color: red }
    );
    // Bézier (the default basis) again: the patch's corner is its first control point.
    let crate::types::Shape::Patches(p) = &f[1].scene.objects[1].shape else {
        panic!("a patch");
    };
    assert_eq!(p[0].points[0], Vec3::ZERO);
}

#[test]
fn world_end_restores_sides_and_orientation() {
    // Sides and the orientation are attributes: one-sided and inside-out in the first world, the
    // second world's sphere is two-sided again (RISpec §4: WorldEnd restores the attributes).
    let f = frames(
        "WorldBegin\n  Sides 1\n  ReverseOrientation\n  Sphere 1 -1 1 360\nWorldEnd\n\
         WorldBegin\n  Sphere 1 -1 1 360\nWorldEnd\n",
    );
    assert_eq!(f[0].scene.objects[0].sides, crate::Sides::new(true, true));
    assert_eq!(f[1].scene.objects[0].sides, crate::Sides::Both);
}

#[test]
fn materials_of_one_world_are_not_reused_by_the_next() {
    // The reader interns classic materials; the next world's scene starts without the first world's,
    // so an interned index must not outlive its world (it once named the wrong material, or none).
    let f = frames(
        "WorldBegin\n  Color [0 1 0]\n  Surface \"plastic\"\n  Sphere 1 -1 1 360\nWorldEnd\n\
         WorldBegin\n  Color [0 0 1]\n  Surface \"matte\"\n  Sphere 1 -1 1 360\n  Color [0 1 0]\n  Surface \"plastic\"\n  Sphere 1 -1 1 360\nWorldEnd\n",
    );
    let plastic = material_of(&f[0], 0);
    assert!(matches!(plastic, crate::types::Material::Surface { .. }));
    assert_eq!(material_of(&f[1], 1), plastic);
    assert_eq!(
        material_of(&f[1], 0),
        crate::types::Material::Diffuse {
            color: obscura_sdk::Rgb::new(0.0, 0.0, 1.0)
        }
    );
}

#[test]
fn objects_defined_in_a_world_are_freed_at_its_end() {
    // RISpec §4: WorldEnd frees the world's retained objects; one defined before the worlds stays.
    let text = "ObjectBegin \"kept\"\n  Sphere 1 -1 1 360\nObjectEnd\n\
                WorldBegin\n  ObjectBegin \"inner\"\n  Sphere 1 -1 1 360\n  ObjectEnd\n  ObjectInstance \"inner\"\nWorldEnd\n\
                WorldBegin\n  ObjectInstance \"kept\"\n  ObjectInstance \"inner\"\nWorldEnd\n";
    let e = parse_bytes_frames(text.as_bytes(), "t.rib", Path::new(HERE)).unwrap_err();
    assert_eq!(e.line, 12, "{e}");
    assert!(e.message.contains("\"inner\""), "{e}");
}

#[test]
fn a_transform_block_may_enclose_the_camera_and_the_world() {
    // As MTOR and Houdini wrote them: the camera's motion and the world inside one transform block.
    let f = frames(
        "FrameBegin 1\nTransformBegin\nTranslate 0 0 5\nWorldBegin\nTransformBegin\nSphere 1 -1 1 360\nTransformEnd\nWorldEnd\nTransformEnd\nFrameEnd\n",
    );
    assert_eq!(f.len(), 1);
    assert_eq!(f[0].scene.objects.len(), 1);
    let at = |text: &str| {
        parse_bytes_frames(text.as_bytes(), "t.rib", Path::new(HERE))
            .unwrap_err()
            .to_string()
    };
    // Attribute blocks still may not, and the world may not close a block begun before it.
    assert!(
        at("AttributeBegin\nWorldBegin\nWorldEnd\nAttributeEnd\n")
            .starts_with("t.rib:2: WorldBegin inside AttributeBegin (at t.rib:1)")
    );
    assert_eq!(
        at("TransformBegin\nWorldBegin\nTransformEnd\nWorldEnd\n"),
        "t.rib:3: TransformEnd inside the world would close the TransformBegin at t.rib:1, begun before WorldBegin"
    );
    assert!(
        at("TransformBegin\nWorldBegin\nTransformBegin\nWorldEnd\n")
            .starts_with("t.rib:4: WorldEnd: TransformBegin at t.rib:3")
    );
}
