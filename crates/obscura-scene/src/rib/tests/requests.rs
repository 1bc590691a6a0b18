//! Unknown requests and parameters, `Declare`, structure, a scene using every request, and random
//! input that must never panic.

use proptest::prelude::*;

use super::geometry::{mesh, tri_area};
use std::path::Path;

use glam::Vec3;
use obscura_sdk::{Format, ParamType, ParamValue};

use super::*;
use crate::types::Shape;

#[test]
fn unknown_request_warns_once_and_reading_continues() {
    let scene = ok("Format 64 48 1\nFrobnicate 1 2 \"x\" [3 4]\n  \"more\" 5\nShutter 0 1\n");
    assert_eq!(
        scene.warnings,
        vec!["t.rib:2: unknown request Frobnicate, skipped".to_string()]
    );
    assert_eq!(scene.camera.format, Format::new(64, 48));
    assert_eq!(scene.camera.shutter, (0.0, 1.0));
}

#[test]
fn unknown_parameter_of_a_known_request_is_warned() {
    let scene = ok("Hider \"raytrace\" \"int maxsamples\" [8] \"float bogus\" [1]");
    assert_eq!(scene.samples_per_pixel, 8);
    assert_eq!(
        scene.warnings,
        vec!["t.rib:1: Hider: unknown parameter \"bogus\", ignored".to_string()]
    );
    assert_eq!(
        fail("Hider \"raytrace\" \"int maxsamples\""),
        "t.rib:1: Hider: parameter \"int maxsamples\" has no value"
    );
    assert_eq!(
        fail("Hider \"raytrace\" 3 4"),
        "t.rib:1: Hider: expected a parameter name (a string), got the number 3"
    );
}

#[test]
fn declare_lets_bare_names_be_used() {
    let scene = ok("Declare \"squeeze\" \"uniform float\"\nProjection \"PxrAnamorphic\" \"squeeze\" [2]");
    let e = scene.projection_params.get("squeeze").unwrap();
    assert_eq!(
        (e.ty, &e.value),
        (ParamType::Float, &ParamValue::Floats(vec![2.0]))
    );
    assert!(scene.warnings.is_empty());
    assert!(
        fail("Declare \"x\" \"flaot\"").starts_with("t.rib:1: Declare: unknown parameter type \"flaot\"")
    );
}

#[test]
fn structural_requests_are_accepted_silently() {
    let scene = ok("version 3.04\nFrameBegin 1\nWorldBegin\nWorldEnd\nFrameEnd\n");
    assert!(scene.warnings.is_empty());
    assert_eq!(
        fail("WorldBegin\nWorldBegin"),
        "t.rib:2: WorldBegin: the world block was already begun at t.rib:1"
    );
}

#[test]
fn a_file_without_world_begin_still_gets_its_camera_transform() {
    let scene = ok("Translate 0 0 2");
    assert_camera_point(&scene, 0, Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0));
}

/// A scene using every request the reader knows (with `props.rib` beside it).
const EVERY_REQUEST: &str = r#"version 3.04
# Obscura's every-request scene
Declare "squeeze" "float"
Option "searchpath" "string archive" ["."]
FrameBegin 1
  Format 320 240 1
  ScreenWindow -1.333 1.333 -1 1
  CropWindow 0 1 0 1
  Shutter 0 0.5
  Clipping 0.1 1e30
  PixelFilter "gaussian" 2 2
  Hider "raytrace" "int maxsamples" [32] "int minsamples" [8] "int incremental" [1]
  Display "beauty.exr" "openexr" "rgba" "string type" "half"
  Display "+aovs.exr" "openexr" "Ci,a,z,N,P,cameraDirection"
  Projection "PxrPerspective" "float fov" [40] "float fStop" [2.8] "float focalDistance" [5] "squeeze" [1]
  Camera "main" "int apertureNSides" [5] "float apertureAngle" [10] "float apertureRoundness" [0.2]
     "float apertureDensity" [0] "float dofaspect" [1] "float shutterOpenTime" [0]
     "float shutterCloseTime" [1] "float[8] shutteropening" [0 0 0 0 1 1 1 1]
  Identity
  MotionBegin [0 0.5]
Translate 0 0 10
Translate 0.1 0 10
  MotionEnd
  Rotate 5 1 0 0
  Scale 1 1 1
  ConcatTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]
  WorldBegin
Light "PxrDomeLight" "dome" "float intensity" [0.5] "string lightColorMap" ["sky.exr"]
LightSource "PxrDistantLight" "sun" "float angleExtent" [1]
AttributeBegin
  Translate 0 4 0
  AreaLightSource "PxrRectLight" "key" "float exposure" [2]
  Light "PxrSphereLight" "fill"
AttributeEnd
AttributeBegin
  Attribute "dice" "float micropolygonlength" [2]
  Bxdf "PxrSurface" "metal" "color specularFaceColor" [0.9 0.9 0.9]
  TransformBegin
    Transform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]
    MotionBegin [0 0.5]
      Translate 0 0 0
      Translate 1 0 0
    MotionEnd
    Sphere 1 -1 1 360
  TransformEnd
  Cone 1 1 360
  Disk 0 1 360
  Torus 1 0.2 0 360 360
AttributeEnd
Bxdf "PxrDiffuse" "floor" "color diffuseColor" [0.5 0.5 0.5]
Polygon "P" [-5 0 -5 5 0 -5 5 0 5 -5 0 5]
PointsPolygons [3] [0 1 2] "P" [0 0 0 1 0 0 0 1 0]
PointsGeneralPolygons [2] [4 3] [0 1 2 3 4 5 6] "P" [0 0 0 4 0 0 4 4 0 0 4 0 1 1 0 2 1 0 1 2 0]
Bxdf "PxrConstant" "glow"
SubdivisionMesh "catmull-clark" [4] [0 1 2 3] ["interpolateboundary"] [0 0] [] [] "P" [0 0 0 1 0 0 1 1 0 0 1 0]
ReadArchive "props.rib"
  WorldEnd
FrameEnd
"#;

#[test]
fn full_example_scene_using_every_request_parses() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("props.rib"),
        "# an archive\nCylinder 0.5 0 1 360\n",
    )
    .unwrap();
    let scene = parse_str(EVERY_REQUEST, "every.rib", dir.path()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.warnings, Vec::<String>::new());
    assert_eq!(scene.camera.format, Format::new(320, 240));
    assert_eq!(scene.camera.world_to_camera.len(), 2);
    assert_eq!(scene.samples_per_pixel, 32);
    assert_eq!(scene.displays.len(), 2);
    assert_eq!(scene.projection_params.entries().len(), 4);
    assert_eq!(scene.camera.aperture.n_sides, 5);
    assert_eq!(scene.lights.len(), 4);
    assert_eq!(scene.materials.len(), 4);
    let kinds: Vec<&str> = scene
        .objects
        .iter()
        .map(|o| match o.shape {
            Shape::Sphere { .. } => "sphere",
            Shape::Cylinder { .. } => "cylinder",
            Shape::Cone { .. } => "cone",
            Shape::Disk { .. } => "disk",
            Shape::Torus { .. } => "torus",
            Shape::Mesh(_) => "mesh",
            Shape::Subdiv(_) => "subdiv",
            _ => "classic",
        })
        .collect();
    assert_eq!(
        kinds,
        [
            "sphere", "cone", "disk", "torus", "mesh", "mesh", "mesh", "subdiv", "cylinder"
        ]
    );
    let sphere = &scene.objects[0];
    assert!(sphere.transform.is_moving());
    assert_eq!((sphere.material, sphere.micropolygon_length), (1, 2.0));
    assert!(!scene.objects[1].transform.is_moving());
    assert_eq!(scene.objects[4].material, 2);
    let holed = mesh(&scene.objects[6]);
    let area: f32 = holed.triangles.iter().map(|&t| tri_area(holed, t)).sum();
    assert!((area - 15.5).abs() < 1e-4, "{area}");
    assert_eq!(
        scene.objects[8].source,
        format!("{}:2", dir.path().join("props.rib").display())
    );
}

proptest! {
    #![proptest_config(no_persistence())]

    #[test]
    fn reader_never_panics_on_printable_text(text in "[ -~\n]{0,300}") {
        let _ = parse_str(&text, "p.rib", Path::new("/nonexistent-obscura-dir"));
    }

    #[test]
    fn reader_never_panics_on_rib_like_text(words in prop::collection::vec(prop::sample::select(vec![
        "WorldBegin", "WorldEnd", "AttributeBegin", "AttributeEnd", "TransformBegin", "TransformEnd",
        "MotionBegin", "MotionEnd", "Translate", "Rotate", "Scale", "Sphere", "Polygon", "PointsPolygons",
        "PointsGeneralPolygons", "SubdivisionMesh", "Display", "Projection", "Camera", "Bxdf", "Light",
        "Format", "\"P\"", "\"N\"", "\"catmull-clark\"", "\"crease\"", "\"float fov\"", "[", "]", "0", "1",
        "-1", "2.5", "3", "1e30", "\"x\"", "\n", "#",
    ]), 0..60)) {
        let _ = parse_str(&words.join(" "), "p.rib", Path::new("/nonexistent-obscura-dir"));
    }
}

#[test]
fn the_rixplugin_searchpath_lists_plugin_directories_from_the_rib_files_folder() {
    let s = ok(
        "Option \"searchpath\" \"string rixplugin\" [\"plugins:/opt/rman/lib/plugins\"]\n\
                Option \"searchpath\" \"rixplugin\" [\"more:&\"]\nWorldBegin\nWorldEnd\n",
    );
    let dirs: Vec<String> = s.plugin_path.iter().map(|p| p.display().to_string()).collect();
    assert_eq!(dirs, ["/base/more", "/base/plugins", "/opt/rman/lib/plugins"]);
}
