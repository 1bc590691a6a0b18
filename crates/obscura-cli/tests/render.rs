//! End to end: `obscura render` as a user runs it.

use std::process::{Command, Output};

fn obscura(args: &[&str], dir: &std::path::Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_obscura"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the obscura binary runs")
}

/// A scene using every RIB request the renderer supports.
const EVERY_REQUEST: &str = r#"##RenderMan RIB
version 3.04
Format 48 32 1
ScreenWindow -1.5 1.5 -1 1
CropWindow 0 1 0 1
Shutter 0 1
Clipping 0.01 1e30
PixelFilter "mitchell" 4 4
Hider "raytrace" "int maxsamples" [4]
Display "every.exr" "openexr" "rgba,z,N,P,cameraDirection" "string type" "half"
Display "+every_deep.exr" "deepexr" "rgbaz"
Display "+every.png" "png" "rgba"
Projection "PxrPerspective" "float fov" [60] "float fStop" [4] "float focalLength" [0.1] "float focalDistance" [6]
Camera "main" "int apertureNSides" [6] "float apertureAngle" [10] "float apertureRoundness" [0.5] "float apertureDensity" [0.2] "float dofaspect" [1.2] "float shutterOpenTime" [0.1] "float shutterCloseTime" [0.9] "float[8] shutteropening" [0 0 0 0 1 1 1 1]
MotionBegin [0 1]
  Translate 0 -1 6
  Translate 0.1 -1 6
MotionEnd
Identity
Translate 0 -1 6
Rotate 5 1 0 0
Scale 1 1 1
ConcatTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]
WorldBegin
  Light "PxrDomeLight" "dome" "color lightColor" [0.5 0.6 0.8] "float intensity" [1] "float exposure" [0] "string lightColorMap" ["sky.exr"]
  Light "PxrDistantLight" "sun" "float intensity" [2] "float angleExtent" [2]
  AttributeBegin
    Translate 0 4 0
    Rotate 90 1 0 0
    Light "PxrRectLight" "key" "float intensity" [3]
  AttributeEnd
  AttributeBegin
    Translate 2 3 1
    Light "PxrSphereLight" "bulb" "float intensity" [5]
  AttributeEnd
  Attribute "dice" "float micropolygonlength" [2]
  Bxdf "PxrDiffuse" "floor" "color diffuseColor" [0.5 0.5 0.5]
  Polygon "P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5]
  PointsPolygons [3 3] [0 1 2 0 2 3] "P" [-5 0 5  5 0 5  5 3 5  -5 3 5]
  PointsGeneralPolygons [2] [4 3] [0 1 2 3 4 5 6] "P" [-4 0 4.9  -2 0 4.9  -2 2 4.9  -4 2 4.9  -3.5 0.5 4.9  -2.5 0.5 4.9  -3 1.5 4.9]
  AttributeBegin
    Bxdf "PxrSurface" "red" "color diffuseColor" [0.8 0.1 0.1] "float diffuseGain" [1] "color specularFaceColor" [0.04 0.04 0.04] "float specularRoughness" [0.3]
    TransformBegin
      MotionBegin [0 1]
        Translate -1.5 1 0
        Translate -1.2 1 0
      MotionEnd
      Sphere 0.8 -0.8 0.8 360
    TransformEnd
    Translate 1.5 0.5 0
    Cylinder 0.4 -0.5 0.5 300
    Cone 1 0.5 360
    Disk 0.6 0.3 360
    Torus 0.5 0.15 0 360 360
  AttributeEnd
  AttributeBegin
    Bxdf "PxrConstant" "glow" "color emitColor" [2 2 2]
    Translate 0 2 1
    SubdivisionMesh "catmull-clark" [4 4 4 4 4 4] [0 1 3 2 2 3 5 4 4 5 7 6 6 7 1 0 1 7 5 3 6 0 2 4] ["interpolateboundary" "crease"] [0 0 2 1] [0 1] [10] "P" [-0.3 -0.3 0.3  0.3 -0.3 0.3  -0.3 0.3 0.3  0.3 0.3 0.3  -0.3 0.3 -0.3  0.3 0.3 -0.3  -0.3 -0.3 -0.3  0.3 -0.3 -0.3]
  AttributeEnd
  AttributeBegin
    Transform [1 0 0 0 0 1 0 0 0 0 1 0 2.5 0.3 -1 1]
    ReadArchive "archive.rib"
  AttributeEnd
WorldEnd
"#;

#[test]
fn a_rib_scene_using_every_request_renders_to_exr_png_and_deep_exr() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("every.rib"), EVERY_REQUEST).unwrap();
    std::fs::write(dir.path().join("archive.rib"), "Sphere 0.3 -0.3 0.3 360\n").unwrap();
    // A small lat-long sky for the dome: bright at the top, dark below.
    exr::prelude::write_rgb_file(dir.path().join("sky.exr"), 16, 8, |_x, y| {
        let v = if y < 4 { 2.0f32 } else { 0.2 };
        (v, v, v)
    })
    .unwrap();
    let r = obscura(&["render", "every.rib"], dir.path());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{err}");
    assert!(!err.contains("unknown request"), "{err}");
    for f in ["every.exr", "every_deep.exr", "every.png"] {
        assert!(
            dir.path().join(f).exists(),
            "{f} missing; stdout: {}",
            String::from_utf8_lossy(&r.stdout)
        );
    }
    let image = exr::prelude::read_all_flat_layers_from_file(dir.path().join("every.exr")).unwrap();
    let names: Vec<String> = image.layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    for c in ["R", "G", "B", "A", "Z", "N.X", "P.Y", "cameraDirection.Z"] {
        assert!(names.contains(&c.to_string()), "{c} missing from {names:?}");
    }
    // The deep file, read by OpenEXR's own library (required in CI).
    let required = std::env::var_os("OBSCURA_REQUIRE_INDEPENDENT_EXR").is_some();
    let script = "import OpenEXR, sys\n\
        p = OpenEXR.File(sys.argv[1]).parts[0]\n\
        z = p.channels['Z'].pixels\n\
        n = sum(len(v) for row in z for v in row if v is not None)\n\
        assert n > 0, 'no deep samples'\n\
        print(n)\n";
    let py = Command::new("python3")
        .args(["-c", script, dir.path().join("every_deep.exr").to_str().unwrap()])
        .output();
    match py {
        Ok(o) if o.status.success() => {}
        Ok(o) if required || !String::from_utf8_lossy(&o.stderr).contains("No module named") => {
            panic!(
                "deep EXR read-back failed: {}",
                String::from_utf8_lossy(&o.stderr)
            )
        }
        _ => assert!(!required, "python3 with OpenEXR is required here"),
    }
}

#[test]
fn the_default_scene_renders_with_overrides_and_bad_input_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let r = obscura(
        &[
            "render",
            "--format",
            "64x36",
            "--spp",
            "2",
            "-p",
            "PxrOrthographic",
            "--param",
            "fStop=0",
            "-o",
            "o.exr",
        ],
        dir.path(),
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(String::from_utf8_lossy(&r.stdout).contains("through PxrOrthographic"));
    assert!(dir.path().join("o.exr").exists() && dir.path().join("o.png").exists());
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "only the two outputs, no temporaries: {names:?}");

    std::fs::write(
        dir.path().join("bad.rib"),
        "Format 64 36 1\nWorldBegin\nSphere 1 2\nWorldEnd\n",
    )
    .unwrap();
    let r = obscura(&["render", "bad.rib"], dir.path());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success());
    assert!(err.contains("bad.rib:3: Sphere"), "{err}");
    let r = obscura(&["render", "--param", "fov=500", "--format", "8x8"], dir.path());
    assert!(String::from_utf8_lossy(&r.stderr).contains("\"fov\""));
    // Regression: a singular camera transform rendered a silent black image.
    std::fs::write(
        dir.path().join("flat.rib"),
        "Format 8 8 1\nScale 0 0 0\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n",
    )
    .unwrap();
    let r = obscura(&["render", "flat.rib"], dir.path());
    assert!(!r.status.success());
    assert!(
        String::from_utf8_lossy(&r.stderr).contains("camera transform"),
        "{}",
        String::from_utf8_lossy(&r.stderr)
    );
    let r = obscura(&["render", "--spp", "0"], dir.path());
    assert!(!r.status.success());
    let r = obscura(&["render", "scene.xyz"], dir.path());
    assert!(String::from_utf8_lossy(&r.stderr).contains("unknown scene format"));
}

#[test]
fn an_obj_scene_renders_with_the_projection_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = String::new();
    for (x, y, z) in [
        (0, 0, 0),
        (1, 0, 0),
        (1, 1, 0),
        (0, 1, 0),
        (0, 0, 1),
        (1, 0, 1),
        (1, 1, 1),
        (0, 1, 1),
    ] {
        obj.push_str(&format!("v {x} {y} {z}\n"));
    }
    // Counter-clockwise seen from outside (OBJ's front faces): a closed object. Wound the other way
    // its faces would face in, and a file without a camera whose faces face in around its centre is
    // framed from inside, as a room.
    obj.push_str("f 4 3 2 1\nf 6 7 8 5\nf 2 6 5 1\nf 3 7 6 2\nf 4 8 7 3\nf 8 4 1 5\n");
    std::fs::write(dir.path().join("cube.obj"), obj).unwrap();
    let r = obscura(
        &[
            "render",
            "cube.obj",
            "--format",
            "32x24",
            "--spp",
            "4",
            "-p",
            "PxrPerspective",
            "--param",
            "fov=50",
            "-o",
            "cube.exr",
        ],
        dir.path(),
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let image = exr::prelude::read_all_flat_layers_from_file(dir.path().join("cube.exr")).unwrap();
    let alpha = image.layer_data[0]
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == "A")
        .map(|c| match &c.sample_data {
            exr::prelude::FlatSamples::F32(v) => v.clone(),
            _ => Vec::new(),
        })
        .unwrap();
    // The framed cube covers the centre and not the corners.
    assert!(alpha[12 * 32 + 16] > 0.99, "centre alpha {}", alpha[12 * 32 + 16]);
    assert!(alpha[0] < 0.01);
}

/// Issue 29: a render is byte-identical whichever SIMD tier generated its camera rays. The same frame
/// (pinhole, thin lens, then two panoramas with structure-of-arrays lane loops: an equidistant 360°
/// fisheye, which culls outside its circle, and the spherical panorama) at `OBSCURA_SIMD=portable`,
/// `avx2` and `avx512`; the image files compared byte for byte. Tiers the CPU lacks fall back to the widest it has (and say so on stderr), so the
/// comparison never passes by skipping on a machine that has them.
#[test]
fn renders_are_byte_identical_at_every_simd_tier() {
    let dir = tempfile::tempdir().unwrap();
    for (name, projection) in [
        ("pinhole", r#"Projection "PxrPerspective" "float fov" [50]"#),
        (
            "thin_lens",
            r#"Projection "PxrPerspective" "float fov" [50] "float fStop" [2] "float focalLength" [0.1] "float focalDistance" [5]"#,
        ),
        ("fisheye", r#"Projection "Fisheye" "float fov" [360]"#),
        ("sphere", r#"Projection "PxrSphereCamera""#),
    ] {
        let rib = format!(
            r#"##RenderMan RIB
version 3.04
Format 64 48 1
Hider "raytrace" "int maxsamples" [4]
Display "{name}.exr" "openexr" "rgba,z"
{projection}
Translate 0 -0.5 5
WorldBegin
  Light "PxrDistantLight" "sun" "float intensity" [2]
  Bxdf "PxrDiffuse" "grey" "color diffuseColor" [0.5 0.5 0.5]
  Polygon "P" [-5 0 -5  5 0 -5  5 0 5  -5 0 5]
  Translate 0.3 0.8 0.5
  Sphere 0.8 -0.8 0.8 360
WorldEnd
"#
        );
        std::fs::write(dir.path().join(format!("{name}.rib")), rib).unwrap();
        let mut images = Vec::new();
        for tier in ["portable", "avx2", "avx512"] {
            let out = Command::new(env!("CARGO_BIN_EXE_obscura"))
                .args(["render", &format!("{name}.rib")])
                .env("OBSCURA_SIMD", tier)
                .current_dir(dir.path())
                .output()
                .expect("the obscura binary runs");
            assert!(
                out.status.success(),
                "{tier}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            images.push((
                tier,
                std::fs::read(dir.path().join(format!("{name}.exr"))).unwrap(),
            ));
        }
        for (tier, bytes) in &images[1..] {
            assert!(
                *bytes == images[0].1,
                "{name}: the {tier} render differs from the portable one"
            );
        }
    }
}
