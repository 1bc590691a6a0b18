//! The glTF reader's tests: files written to a temporary folder (JSON with `data:` buffers, GLB,
//! external buffers), checked against independent formulas; corrupted files must give errors.

use std::f32::consts::PI;

use glam::{Mat4, Quat};
use obscura_sdk::{Format, ParamValue, Rgb, ScreenWindow};
use proptest::prelude::*;

use super::*;
use crate::convert::to_row_vector;
use crate::fixtures::{Fixture, POSITIONS, buffer};
use crate::test_support::camera_point;
use crate::types::{Light, Material, Shape};

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = json.as_bytes().to_vec();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

fn camera_desc(w: u32, h: u32) -> CameraDesc {
    let mut c = CameraDesc::new(Format::new(w, h));
    c.shutter = (0.25, 0.75);
    c
}

fn load(fixture: &Fixture, w: u32, h: u32) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    load_gltf(&fixture.write(&dir, "scene.gltf"), camera_desc(w, h)).unwrap()
}

fn fov_param(scene: &Scene) -> f32 {
    match &scene.projection_params.get("fov").expect("a fov parameter").value {
        ParamValue::Floats(v) => v[0],
        other => panic!("fov is {other:?}"),
    }
}

fn to_camera(scene: &Scene, p: Vec3) -> Vec3 {
    camera_point(scene, 0, p)
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-5
}

#[test]
fn gltf_triangle_under_a_rotated_translated_node() {
    let scene = load(&Fixture::new([0, 1, 2]), 640, 480);
    assert_eq!(scene.objects.len(), 1);
    let obj = &scene.objects[0];
    let Shape::Mesh(mesh) = &obj.shape else {
        panic!("not a mesh: {:?}", obj.shape)
    };
    assert_eq!(mesh.positions, POSITIONS.map(Vec3::from).to_vec());
    assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
    assert_eq!(mesh.normals, Some(vec![Vec3::Z; 3]));
    // 90° about +Y takes +X to −Z; then the translation (1, 2, 3).
    let m = obj.transform.samples[0].1;
    assert!(close(m.transform_point3(Vec3::X), Vec3::new(1.0, 2.0, 2.0)));
    assert!(close(m.transform_point3(Vec3::Y), Vec3::new(1.0, 3.0, 3.0)));
    assert!(!obj.transform.is_moving());
    assert!(obj.source.contains("scene.gltf") && obj.source.contains("\"tri\""));
}

#[test]
fn gltf_camera_node_maps_world_to_renderman_camera_space() {
    let scene = load(&Fixture::new([0, 1, 2]), 640, 480);
    assert_eq!(scene.camera.world_to_camera.len(), 1);
    assert_eq!(scene.camera.world_to_camera[0].time, 0.25);
    // The camera at (0, 0, 5) looks down world −Z: the origin is 5 units in front of it.
    assert!(close(to_camera(&scene, Vec3::ZERO), Vec3::new(0.0, 0.0, 5.0)));
    let right = to_camera(&scene, Vec3::X);
    assert!(right.x > 0.0 && close(right, Vec3::new(1.0, 0.0, 5.0)));
    let up = to_camera(&scene, Vec3::Y);
    assert!(up.y > 0.0 && close(up, Vec3::new(0.0, 1.0, 5.0)));
}

#[test]
fn gltf_turned_camera_keeps_right_on_the_right() {
    // At (5, 0, 0), turned +90° about Y: it looks down world −X, toward the origin, and its
    // right (+X) is world −Z.
    let mut f = Fixture::new([0, 1, 2]);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    f.nodes = format!(r#"{{"mesh":0}}, {{"camera":0,"translation":[5,0,0],"rotation":[0,{s},0,{s}]}}"#);
    let scene = load(&f, 640, 480);
    assert!(close(to_camera(&scene, Vec3::ZERO), Vec3::new(0.0, 0.0, 5.0)));
    assert!(close(
        to_camera(&scene, Vec3::new(0.0, 0.0, -1.0)),
        Vec3::new(1.0, 0.0, 5.0)
    ));
    assert!(close(to_camera(&scene, Vec3::Y), Vec3::new(0.0, 1.0, 5.0)));
}

#[test]
fn gltf_camera_under_a_parent_node_uses_its_world_matrix() {
    let mut f = Fixture::new([0, 1, 2]);
    f.nodes =
        r#"{"mesh":0}, {"translation":[0,0,3],"children":[2]}, {"camera":0,"translation":[0,0,2]}"#.into();
    let scene = load(&f, 640, 480);
    assert!(close(to_camera(&scene, Vec3::ZERO), Vec3::new(0.0, 0.0, 5.0)));
}

#[test]
fn gltf_perspective_fov_spans_the_smaller_side() {
    let yfov = 0.8f32;
    let landscape = load(&Fixture::new([0, 1, 2]), 640, 480);
    assert_eq!(landscape.projection, "PxrPerspective");
    assert!((fov_param(&landscape) - yfov.to_degrees()).abs() < 1e-4);

    let portrait = load(&Fixture::new([0, 1, 2]), 480, 640);
    let fov = fov_param(&portrait).to_radians();
    assert!(fov < yfov);
    // Across the width the screen plane at d = 1/tan(fov/2) spans [−1, 1]; the height spans
    // [−1/a, 1/a], which must subtend the file's yfov.
    let a = 480.0f32 / 640.0;
    let d = 1.0 / (0.5 * fov).tan();
    assert!(((1.0 / a / d).atan() - 0.5 * yfov).abs() < 1e-5);
}

#[test]
fn gltf_orthographic_camera_sets_a_window_with_the_frame_aspect() {
    let mut f = Fixture::new([0, 1, 2]);
    f.cameras =
        r#"{"type":"orthographic","orthographic":{"xmag":3,"ymag":1.5,"znear":0.1,"zfar":100}}"#.into();
    let scene = load(&f, 640, 480);
    assert_eq!(scene.projection, "PxrOrthographic");
    assert_eq!(
        scene.camera.screen_window,
        Some(ScreenWindow::new(-2.0, 2.0, -1.5, 1.5))
    );
}

#[test]
fn gltf_materials_map_metallic_roughness() {
    let scene = load(&Fixture::new([0, 1, 2]), 640, 480);
    assert_eq!(scene.materials.len(), 4);
    assert_eq!(scene.materials[0], Material::default());
    assert_eq!(scene.objects[0].material, 1);
    let Material::Surface {
        diffuse,
        specular,
        roughness,
    } = scene.materials[1]
    else {
        panic!("expected a surface: {:?}", scene.materials[1])
    };
    let near = |a: Rgb, b: [f32; 3]| {
        (a.r - b[0]).abs() < 1e-6 && (a.g - b[1]).abs() < 1e-6 && (a.b - b[2]).abs() < 1e-6
    };
    assert!(near(diffuse, [0.4, 0.2, 0.1]), "{diffuse:?}");
    assert!(near(specular, [0.42, 0.22, 0.12]), "{specular:?}");
    assert_eq!(roughness, 0.3);
    assert_eq!(
        scene.materials[2],
        Material::Diffuse {
            color: Rgb::new(0.1, 0.2, 0.3)
        }
    );
    assert_eq!(
        scene.materials[3],
        Material::Constant {
            color: Rgb::new(2.0, 1.0, 0.5)
        }
    );
}

#[test]
fn gltf_punctual_lights_become_distant_and_sphere_lights() {
    let mut f = Fixture::new([0, 1, 2]);
    f.extensions = r#""extensionsUsed": ["KHR_lights_punctual"],
      "extensions": {"KHR_lights_punctual": {"lights": [
        {"type": "directional", "color": [1, 0.5, 0.25], "intensity": 3},
        {"type": "point", "intensity": 10}
      ]}},"#
        .into();
    f.nodes = r#"{"mesh":0},
        {"extensions":{"KHR_lights_punctual":{"light":0}}},
        {"translation":[1,2,3],"extensions":{"KHR_lights_punctual":{"light":1}}}"#
        .into();
    f.scene_nodes = "[0, 1, 2]".into();
    let scene = load(&f, 640, 480);
    assert_eq!(scene.lights.len(), 2, "{:?}", scene.warnings);
    let Light::Distant {
        color,
        intensity,
        transform,
        ..
    } = &scene.lights[0]
    else {
        panic!("{:?}", scene.lights[0])
    };
    assert_eq!((*color, *intensity), (Rgb::new(1.0, 0.5, 0.25), 3.0));
    // glTF's directional light shines down its node's −Z; ours along the light's +Z.
    assert!(close(transform.transform_vector3(Vec3::Z), Vec3::NEG_Z));
    let Light::Sphere {
        intensity, transform, ..
    } = &scene.lights[1]
    else {
        panic!("{:?}", scene.lights[1])
    };
    assert!(close(
        transform.transform_point3(Vec3::ZERO),
        Vec3::new(1.0, 2.0, 3.0)
    ));
    // Small: 1 % of the triangle's world diagonal (√2) across; radiant intensity preserved.
    let diameter = transform.transform_vector3(Vec3::X).length();
    assert!((diameter - 0.01 * 2f32.sqrt()).abs() < 1e-6);
    let r = 0.5 * diameter;
    assert!((intensity * PI * r * r - 10.0).abs() < 1e-3);
    assert!(!scene.warnings.iter().any(|w| w.contains("no light")));
}

#[test]
fn gltf_binary_container_loads_the_same_scene() {
    let mut f = Fixture::new([0, 1, 2]);
    f.buffer_uri = String::new();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.glb");
    std::fs::write(&path, glb(&f.json(), &buffer([0, 1, 2]))).unwrap();
    let scene = load_gltf(&path, camera_desc(640, 480)).unwrap();
    let text = load(&Fixture::new([0, 1, 2]), 640, 480);
    assert_eq!(scene.objects.len(), 1);
    assert_eq!(scene.objects[0].shape, text.objects[0].shape);
    assert_eq!(scene.camera.world_to_camera, text.camera.world_to_camera);
}

#[test]
fn gltf_external_buffer_beside_the_file() {
    let mut f = Fixture::new([0, 1, 2]);
    f.buffer_uri = r#""uri":"tri%20angle.bin","#.into();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tri angle.bin"), buffer([0, 1, 2])).unwrap();
    let scene = load_gltf(&f.write(&dir, "scene.gltf"), camera_desc(64, 64)).unwrap();
    assert_eq!(scene.objects.len(), 1);
}

#[test]
fn gltf_non_triangle_primitives_are_skipped_with_a_warning() {
    let mut f = Fixture::new([0, 1, 2]);
    f.mode = 1;
    let scene = load(&f, 640, 480);
    assert!(scene.objects.is_empty());
    assert!(scene.warnings.iter().any(|w| w.contains("points or lines")));
}

#[test]
fn gltf_triangle_strips_and_fans_are_read() {
    for mode in [5, 6] {
        let mut f = Fixture::new([0, 1, 2]);
        f.mode = mode;
        let scene = load(&f, 640, 480);
        let Shape::Mesh(m) = &scene.objects[0].shape else {
            panic!("not a mesh")
        };
        assert_eq!(m.triangles.len(), 1, "mode {mode}");
    }
}

#[test]
fn gltf_a_required_extension_we_do_not_read_is_named() {
    let mut f = Fixture::new([0, 1, 2]);
    f.extensions = r#""extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"],"#.into();
    let dir = tempfile::tempdir().unwrap();
    let e = load_gltf(&f.write(&dir, "scene.gltf"), camera_desc(64, 64))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("KHR_draco_mesh_compression") && e.contains("Draco"),
        "{e}"
    );
    // A required extension we honour is accepted.
    f.extensions =
        r#""extensionsUsed": ["KHR_texture_transform"], "extensionsRequired": ["KHR_texture_transform"],"#
            .into();
    assert!(load_gltf(&f.write(&dir, "scene.gltf"), camera_desc(64, 64)).is_ok());
}

fn error_of(contents: &[u8], name: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, contents).unwrap();
    load_gltf(&path, camera_desc(64, 64)).unwrap_err().to_string()
}

#[test]
fn gltf_missing_file_is_an_error_naming_it() {
    let e = load_gltf(Path::new("/nonexistent/nowhere.gltf"), camera_desc(64, 64)).unwrap_err();
    assert!(matches!(e, GltfError::Read { .. }));
    assert!(e.to_string().contains("/nonexistent/nowhere.gltf"), "{e}");
}

#[test]
fn gltf_malformed_json_is_an_error_naming_the_file() {
    let json = Fixture::new([0, 1, 2]).json();
    let e = error_of(&json.as_bytes()[..json.len() / 2], "broken.gltf");
    assert!(e.contains("broken.gltf") && e.contains("not a valid glTF"), "{e}");
}

#[test]
fn gltf_malformed_binary_is_an_error_not_a_panic() {
    // A declared total length shorter than the header itself.
    let mut bytes = glb(&Fixture::new([0, 1, 2]).json(), &[]);
    bytes[8..12].copy_from_slice(&4u32.to_le_bytes());
    let e = error_of(&bytes, "short.glb");
    assert!(e.contains("short.glb") && e.contains("length"), "{e}");
    // A JSON chunk claiming more bytes than the file holds.
    let mut bytes = glb(&Fixture::new([0, 1, 2]).json(), &[]);
    bytes[12..16].copy_from_slice(&100_000u32.to_le_bytes());
    assert!(error_of(&bytes, "chunk.glb").contains("chunk.glb"));
    assert!(error_of(b"glTF", "tiny.glb").contains("tiny.glb"));
}

#[test]
fn gltf_missing_buffer_is_an_error_naming_both_files() {
    let mut f = Fixture::new([0, 1, 2]);
    f.buffer_uri = r#""uri":"missing.bin","#.into();
    let e = error_of(f.json().as_bytes(), "scene.gltf");
    assert!(e.contains("scene.gltf") && e.contains("missing.bin"), "{e}");
    // A GLB whose buffer wants the BIN chunk it does not have.
    let mut f = Fixture::new([0, 1, 2]);
    f.buffer_uri = String::new();
    let e = error_of(f.json().as_bytes(), "nobin.gltf");
    assert!(e.contains("nobin.gltf") && e.contains("buffer 0"), "{e}");
    // Undecodable percent escapes are refused, not unwrapped.
    let mut f = Fixture::new([0, 1, 2]);
    f.buffer_uri = r#""uri":"bad%FF.bin","#.into();
    assert!(error_of(f.json().as_bytes(), "esc.gltf").contains("esc.gltf"));
}

#[test]
fn gltf_index_out_of_range_is_an_error() {
    let e = error_of(Fixture::new([0, 1, 7]).json().as_bytes(), "oob.gltf");
    assert!(
        e.contains("oob.gltf") && e.contains("index 7") && e.contains("mesh 0 primitive 0"),
        "{e}"
    );
}

#[test]
fn gltf_bad_accessors_are_errors_not_panics() {
    // Float indices would hit the reader's `unreachable!`.
    let mut f = Fixture::new([0, 1, 2]);
    f.index_type = 5126;
    let e = error_of(f.json().as_bytes(), "floatidx.gltf");
    assert!(e.contains("floatidx.gltf") && e.contains("indices"), "{e}");
    // An accessor running past its buffer view.
    let json = Fixture::new([0, 1, 2]).json().replace(
        r#""count": 3, "type": "VEC3", "min""#,
        r#""count": 30, "type": "VEC3", "min""#,
    );
    let e = error_of(json.as_bytes(), "long.gltf");
    assert!(e.contains("long.gltf") && e.contains("past the end"), "{e}");
    // An accessor with no elements (the reader computes count − 1).
    let json = Fixture::new([0, 1, 2]).json().replace(
        r#""count": 3, "type": "SCALAR""#,
        r#""count": 0, "type": "SCALAR""#,
    );
    assert!(error_of(json.as_bytes(), "empty.gltf").contains("no elements"));
}

#[test]
fn gltf_inconsistencies_validation_misses_are_errors_not_panics() {
    // The gltf crate's validation indexes a POSITION accessor unchecked.
    let json = Fixture::new([0, 1, 2])
        .json()
        .replace(r#""POSITION": 0"#, r#""POSITION": 9"#);
    let e = error_of(json.as_bytes(), "pos.gltf");
    assert!(
        e.contains("pos.gltf") && e.contains("POSITION refers to accessor 9"),
        "{e}"
    );
    // Camera::projection unwraps the object the type names.
    let mut f = Fixture::new([0, 1, 2]);
    f.cameras = r#"{"type":"perspective","orthographic":{"xmag":1,"ymag":1,"znear":0.1,"zfar":9}}"#.into();
    let e = error_of(f.json().as_bytes(), "cam.gltf");
    assert!(e.contains("cam.gltf") && e.contains("camera 0"), "{e}");
}

#[test]
fn gltf_node_cycle_is_an_error() {
    let mut f = Fixture::new([0, 1, 2]);
    f.nodes = r#"{"mesh":0,"children":[1]}, {"children":[0]}"#.into();
    f.scene_nodes = "[0]".into();
    let e = error_of(f.json().as_bytes(), "cycle.gltf");
    assert!(e.contains("cycle.gltf") && e.contains("node 0"), "{e}");
}

#[test]
fn gltf_row_vector_matrix_agrees_with_glam() {
    let m = Mat4::from_scale_rotation_translation(
        Vec3::new(2.0, 0.5, 3.0),
        Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0),
        Vec3::new(-4.0, 5.0, 6.0),
    );
    let r = to_row_vector(m);
    // The translation sits in the last row, as RenderMan writes it.
    assert_eq!(&r.0[3][..3], &[-4.0, 5.0, 6.0]);
    let p = Vec3::new(0.7, -1.3, 2.9);
    let q = r.transform_point(obscura_sdk::Vec3::new(p.x, p.y, p.z));
    assert!(close(Vec3::new(q.x, q.y, q.z), m.transform_point3(p)));
    let v = r.transform_vector(obscura_sdk::Vec3::new(p.x, p.y, p.z));
    assert!(close(Vec3::new(v.x, v.y, v.z), m.transform_vector3(p)));
}

proptest! {
    #[test]
    fn gltf_corrupted_files_never_panic(
        edits in prop::collection::vec(
            (any::<prop::sample::Index>(), prop_oneof![prop::sample::select(b"0123456789-.e ,]}".to_vec()), any::<u8>()]),
            1..6,
        ),
        binary in any::<bool>(),
    ) {
        let mut bytes = if binary {
            let mut f = Fixture::new([0, 1, 2]);
            f.buffer_uri = String::new();
            glb(&f.json(), &buffer([0, 1, 2]))
        } else {
            Fixture::new([0, 1, 2]).json().into_bytes()
        };
        for (at, b) in edits {
            let i = at.index(bytes.len());
            bytes[i] = b;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fuzz.gltf");
        std::fs::write(&path, &bytes).unwrap();
        // Any outcome but a panic.
        let _ = load_gltf(&path, camera_desc(64, 64));
    }

    #[test]
    fn gltf_row_vector_matrix_agrees_with_glam_everywhere(
        t in prop::array::uniform3(-10.0f32..10.0),
        e in prop::array::uniform3(-3.0f32..3.0),
        p in prop::array::uniform3(-10.0f32..10.0),
    ) {
        let m = Mat4::from_rotation_translation(Quat::from_euler(glam::EulerRot::ZYX, e[0], e[1], e[2]), Vec3::from(t));
        let q = to_row_vector(m).transform_point(obscura_sdk::Vec3::new(p[0], p[1], p[2]));
        let g = m.transform_point3(Vec3::from(p));
        prop_assert!((Vec3::new(q.x, q.y, q.z) - g).abs().max_element() < 1e-4);
    }
}

/// Issue 16: a glTF whose asset version was "1.0" was read as if it were 2.0.
#[test]
fn gltf_of_another_version_is_an_error_naming_the_version() {
    let with = |asset: &str| {
        Fixture::new([0, 1, 2])
            .json()
            .replace(r#""asset": {"version": "2.0"}"#, asset)
    };
    for (asset, want) in [
        (
            r#""asset": {"version": "1.0"}"#,
            "asset.version is \"1.0\": expected a glTF 2.x file",
        ),
        (
            r#""asset": {"version": "3.0"}"#,
            "asset.version is \"3.0\": expected a glTF 2.x file",
        ),
        (
            r#""asset": {"version": "two"}"#,
            "asset.version is \"two\": expected \"2.0\"",
        ),
        (
            r#""asset": {"version": "2.0", "minVersion": "2.1"}"#,
            "asset.minVersion is \"2.1\": this reader reads glTF 2.0",
        ),
    ] {
        let json = with(asset);
        assert!(json.contains(asset));
        let e = error_of(json.as_bytes(), "v.gltf");
        assert!(e.contains(want) && e.contains("v.gltf"), "{asset}: {e}");
    }
    let json = with(r#""asset": {"version": "2.0", "minVersion": "2.0"}"#);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ok.gltf");
    std::fs::write(&path, json).unwrap();
    assert!(load_gltf(&path, camera_desc(8, 8)).is_ok());
}
