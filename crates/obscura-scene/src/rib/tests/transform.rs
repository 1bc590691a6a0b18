//! Transforms, attribute and transform blocks, and motion blocks.

use glam::{Mat4, Vec3};

use super::*;
use crate::types::{MotionTransform, Shape};

#[test]
fn translate_before_world_begin_puts_the_world_origin_at_plus_z() {
    let scene = ok("Shutter 0.25 1\nTranslate 0 0 5\nWorldBegin\n");
    let w2c = &scene.camera.world_to_camera;
    assert_eq!(w2c.len(), 1);
    assert_eq!(w2c[0].time, 0.25);
    // Row-vector convention: the translation sits in the last row.
    assert_eq!(w2c[0].world_to_camera.0[3], [0.0, 0.0, 5.0, 1.0]);
    assert_camera_point(&scene, 0, Vec3::ZERO, Vec3::new(0.0, 0.0, 5.0));
}

#[test]
fn rotate_90_about_y_sends_world_x_to_camera_minus_z() {
    // Rotation by +90° about +Y in the column-vector formula: x' = x cosθ + z sinθ, z' = −x sinθ + z cosθ,
    // so (1, 0, 0) → (0, 0, −1), behind the camera.
    let scene = ok("Rotate 90 0 1 0\nWorldBegin\n");
    assert_camera_point(&scene, 0, Vec3::X, Vec3::new(0.0, 0.0, -1.0));
}

#[test]
fn camera_requests_apply_last_written_first() {
    // Translate is written last, so it acts first: (0,0,0) → (0,0,5) → rotated 90° about Y → (5,0,0).
    let scene = ok("Rotate 90 0 1 0\nTranslate 0 0 5\nWorldBegin\n");
    assert_camera_point(&scene, 0, Vec3::ZERO, Vec3::new(5.0, 0.0, 0.0));
}

#[test]
fn translate_then_scale_in_the_world_scales_first() {
    let o = only_object("Translate 1 0 0\nScale 2 2 2\nSphere 1 -1 1 360");
    let m = o.transform.samples[0].1;
    assert!(close(m.transform_point3(Vec3::X), Vec3::new(3.0, 0.0, 0.0)));
    assert_eq!(o.source, "t.rib:4");
}

#[test]
fn rotate_about_z_turns_x_toward_y() {
    let o = only_object("Rotate 30 0 0 2\nSphere 1 -1 1 360");
    let (s, c) = 30f32.to_radians().sin_cos();
    assert!(close(
        o.transform.samples[0].1.transform_point3(Vec3::X),
        Vec3::new(c, s, 0.0)
    ));
    assert_eq!(
        fail("WorldBegin\nRotate 30 0 0 0"),
        "t.rib:2: Rotate expects a non-zero axis"
    );
    assert_eq!(
        fail("Translate 1 2"),
        "t.rib:1: Translate expects x y z (3 numbers), got 2"
    );
}

#[test]
fn concat_transform_reads_rib_row_major_matrices() {
    let o =
        only_object("Scale 2 2 2\nConcatTransform [1 0 0 0  0 1 0 0  0 0 1 0  1 2 3 1]\nSphere 1 -1 1 360");
    // The matrix (a translation by (1,2,3) in RIB's row-vector layout) acts before the scale.
    assert!(close(
        o.transform.samples[0].1.transform_point3(Vec3::ZERO),
        Vec3::new(2.0, 4.0, 6.0)
    ));
}

#[test]
fn transform_and_identity_replace_the_current_transform() {
    let o = only_object("Translate 5 0 0\nTransform [2 0 0 0 0 2 0 0 0 0 2 0 0 0 0 1]\nSphere 1 -1 1 360");
    assert_eq!(o.transform.samples[0].1, Mat4::from_scale(Vec3::splat(2.0)));
    let o = only_object("Translate 5 0 0\nIdentity\nSphere 1 -1 1 360");
    assert_eq!(o.transform, MotionTransform::fixed(Mat4::IDENTITY));
}

// --- blocks --------------------------------------------------------------------------------------

#[test]
fn attribute_block_restores_material_transform_and_dicing() {
    let scene = ok("WorldBegin\n\
         Bxdf \"PxrDiffuse\" \"red\" \"color diffuseColor\" [1 0 0]\n\
         Translate 1 0 0\n\
         AttributeBegin\n\
           Bxdf \"PxrConstant\" \"glow\" \"color emitColor\" [2 2 2]\n\
           Attribute \"dice\" \"float micropolygonlength\" [0.5]\n\
           Translate 0 1 0\n\
           Sphere 1 -1 1 360\n\
         AttributeEnd\n\
         Sphere 1 -1 1 360\n");
    let (inner, outer) = (&scene.objects[0], &scene.objects[1]);
    assert_eq!((inner.material, inner.micropolygon_length), (2, 0.5));
    assert_eq!(
        inner.transform.samples[0].1,
        Mat4::from_translation(Vec3::new(1.0, 1.0, 0.0))
    );
    assert_eq!((outer.material, outer.micropolygon_length), (1, 1.0));
    assert_eq!(outer.transform.samples[0].1, Mat4::from_translation(Vec3::X));
}

#[test]
fn transform_block_restores_only_the_transform() {
    let scene = ok(
        "WorldBegin\nTransformBegin\nTranslate 0 1 0\nBxdf \"PxrDiffuse\" \"d\"\nTransformEnd\n\
         Sphere 1 -1 1 360\n",
    );
    assert_eq!(scene.objects[0].transform, MotionTransform::fixed(Mat4::IDENTITY));
    assert_eq!(scene.objects[0].material, 1);
}

#[test]
fn unbalanced_blocks_name_the_unmatched_request() {
    assert_eq!(
        fail("WorldBegin\nAttributeBegin\nAttributeEnd\nAttributeEnd\n"),
        "t.rib:4: AttributeEnd without a matching AttributeBegin"
    );
    assert_eq!(
        fail("WorldBegin\nAttributeBegin\nSphere 1 -1 1 360\n"),
        "t.rib:2: AttributeBegin has no matching AttributeEnd"
    );
    assert_eq!(
        fail("WorldBegin\nAttributeBegin\nTransformEnd\n"),
        "t.rib:3: TransformEnd does not match AttributeBegin at t.rib:2"
    );
    assert_eq!(
        fail("WorldBegin\nTransformBegin\nWorldEnd\n"),
        "t.rib:3: WorldEnd: TransformBegin at t.rib:2 has no matching TransformEnd"
    );
}

// --- motion --------------------------------------------------------------------------------------

#[test]
fn camera_motion_block_gives_one_sample_per_time() {
    let scene =
        ok("Shutter 0 1\nMotionBegin [0 1]\nTranslate 0 0 5\nTranslate 1 0 5\nMotionEnd\nWorldBegin\n");
    let w2c = &scene.camera.world_to_camera;
    assert_eq!(w2c.iter().map(|s| s.time).collect::<Vec<_>>(), vec![0.0, 1.0]);
    assert_camera_point(&scene, 0, Vec3::ZERO, Vec3::new(0.0, 0.0, 5.0));
    assert_camera_point(&scene, 1, Vec3::ZERO, Vec3::new(1.0, 0.0, 5.0));
}

#[test]
fn object_motion_then_static_transforms_apply_to_every_sample() {
    let o = only_object(
        "MotionBegin [0 0.5]\nTranslate 0 0 0\nTranslate 2 0 0\nMotionEnd\nScale 2 2 2\nSphere 1 -1 1 360",
    );
    let s = &o.transform.samples;
    assert_eq!(s.iter().map(|s| s.0).collect::<Vec<_>>(), vec![0.0, 0.5]);
    assert!(close(s[0].1.transform_point3(Vec3::X), Vec3::new(2.0, 0.0, 0.0)));
    assert!(close(s[1].1.transform_point3(Vec3::X), Vec3::new(4.0, 0.0, 0.0)));
    assert!(o.transform.is_moving());
}

#[test]
fn motion_block_with_several_groups_composes_them_per_time() {
    let o = only_object(
        "MotionBegin [0 1]\nTranslate 0 0 0\nTranslate 1 0 0\nRotate 0 0 0 1\nRotate 90 0 0 1\nMotionEnd\n\
         Sphere 1 -1 1 360",
    );
    let s = &o.transform.samples;
    assert!(close(s[0].1.transform_point3(Vec3::X), Vec3::X));
    assert!(close(s[1].1.transform_point3(Vec3::X), Vec3::new(1.0, 1.0, 0.0)));
}

#[test]
fn attribute_end_restores_a_static_transform_after_motion() {
    let scene = ok(
        "WorldBegin\nAttributeBegin\nMotionBegin [0 1]\nTranslate 0 0 0\nTranslate 1 0 0\n\
         MotionEnd\nAttributeEnd\nSphere 1 -1 1 360\n",
    );
    assert!(!scene.objects[0].transform.is_moving());
    assert_eq!(scene.objects[0].transform.samples.len(), 1);
}

#[test]
fn deforming_geometry_takes_its_first_time_with_a_warning() {
    let s =
        ok("WorldBegin\nMotionBegin [0 1]\nSphere 1 -1 1 360\nSphere 2 -2 2 360\nMotionEnd\nCone 1 1 360\n");
    assert_eq!(s.objects.len(), 2);
    assert!(matches!(s.objects[0].shape, Shape::Sphere { radius, .. } if radius == 1.0));
    assert_eq!(
        s.warnings,
        [
            "t.rib:4: Sphere inside MotionBegin (at t.rib:2): deformation motion blur is not supported; the first \
          time's Sphere stands, the others are dropped"
        ]
    );
}

#[test]
fn malformed_motion_blocks_are_errors() {
    assert_eq!(
        fail("WorldBegin\nMotionBegin [0 1]\nTranslate 1 0 0\nMotionEnd\n"),
        "t.rib:4: MotionEnd: MotionBegin at t.rib:2 gives 2 times but the block holds 1 transform \
         requests; expected 2 (one per time, or a multiple of 2 for several groups)"
    );
    assert_eq!(
        fail("WorldBegin\nMotionBegin [0 1]\nSphere 1 -1 1 360\n"),
        "t.rib:2: MotionBegin has no matching MotionEnd"
    );
    assert_eq!(
        fail("MotionBegin [0 1]\nTranslate 1 0 0\n"),
        "t.rib:1: MotionBegin has no matching MotionEnd"
    );
    assert_eq!(
        fail("MotionEnd"),
        "t.rib:1: MotionEnd without a matching MotionBegin"
    );
    assert_eq!(
        fail("MotionBegin [1 0]"),
        "t.rib:1: MotionBegin expects increasing times, got [1.0, 0.0]"
    );
}
