//! The OBJ reader's tests: files and material libraries written to a temporary folder.

use super::*;
use crate::fixtures::{CUBE, MTL, write};
use obscura_sdk::Format;

fn camera() -> CameraDesc {
    CameraDesc::new(Format::new(640, 480))
}

fn load_cube(mtl: Option<&str>) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    if let Some(mtl) = mtl {
        write(&dir, "cube.mtl", mtl);
    }
    load_obj(&write(&dir, "cube.obj", CUBE), camera()).unwrap()
}

fn meshes(scene: &Scene) -> Vec<&Mesh> {
    scene
        .objects
        .iter()
        .map(|o| match &o.shape {
            Shape::Mesh(m) => m,
            other => panic!("not a mesh: {other:?}"),
        })
        .collect()
}

#[test]
fn obj_cube_has_twelve_triangles_with_normals() {
    let scene = load_cube(Some(MTL));
    let meshes = meshes(&scene);
    assert_eq!(meshes.iter().map(|m| m.triangles.len()).sum::<usize>(), 12);
    for m in &meshes {
        let n = m.normals.as_ref().expect("normals");
        assert_eq!(n.len(), m.positions.len());
        // Each triangle's winding agrees with its normal up to sign, and the normal is axial.
        for t in &m.triangles {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let face = (b - a).cross(c - a);
            assert!(face.length() > 0.0);
            assert!((face.normalize().dot(n[t[0] as usize]).abs() - 1.0).abs() < 1e-6);
        }
    }
    assert!(
        scene
            .objects
            .iter()
            .all(|o| o.transform == MotionTransform::default())
    );
    assert!(scene.objects[0].source.contains("cube.obj"));
}

#[test]
fn obj_mtl_materials_map_to_diffuse_surface_and_constant() {
    let scene = load_cube(Some(MTL));
    assert_eq!(scene.materials.len(), 4);
    assert_eq!(
        scene.materials[1],
        Material::Diffuse {
            color: Rgb::new(0.8, 0.1, 0.1)
        }
    );
    let Material::Surface {
        diffuse,
        specular,
        roughness,
    } = scene.materials[2]
    else {
        panic!("{:?}", scene.materials[2])
    };
    assert_eq!(
        (diffuse, specular),
        (Rgb::new(0.2, 0.2, 0.2), Rgb::new(0.5, 0.5, 0.5))
    );
    // Ns 98 is a Beckmann α of sqrt(2/100); our roughness is sqrt(α).
    assert!(
        (roughness * roughness - 0.02f32.sqrt()).abs() < 1e-6,
        "{roughness}"
    );
    assert_eq!(
        scene.materials[3],
        Material::Constant {
            color: Rgb::new(4.0, 4.0, 3.0)
        }
    );
    // Three faces (six triangles) each.
    let mut by_material = [0; 4];
    for (o, m) in scene.objects.iter().zip(meshes(&scene)) {
        by_material[o.material as usize] += m.triangles.len();
    }
    assert_eq!(by_material, [0, 6, 6, 0]);
    assert!(
        scene.warnings.iter().all(|w| !w.contains("material")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn obj_single_value_colour_is_grey() {
    let scene = load_cube(Some("newmtl red\nKd 0.5\n"));
    assert_eq!(
        scene.materials[1],
        Material::Diffuse {
            color: Rgb::new(0.5, 0.5, 0.5)
        }
    );
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("usemtl \"shiny\"") && w.contains("cube.obj:22:"))
    );
}

#[test]
fn obj_missing_mtl_warns_and_uses_the_default_material() {
    let scene = load_cube(None);
    assert_eq!(scene.materials, vec![Material::default()]);
    assert!(scene.objects.iter().all(|o| o.material == 0));
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("cube.obj:2") && w.contains("cube.mtl")),
        "{:?}",
        scene.warnings
    );
}

fn error_of(obj: &str, mtl: Option<&str>) -> String {
    let dir = tempfile::tempdir().unwrap();
    if let Some(mtl) = mtl {
        write(&dir, "cube.mtl", mtl);
    }
    load_obj(&write(&dir, "bad.obj", obj), camera())
        .unwrap_err()
        .to_string()
}

#[test]
fn obj_malformed_numbers_are_errors_naming_file_and_line() {
    let e = error_of("v 0 0 0\nv 1 0 0\nv 1 x 0\nf 1 2 3\n", None);
    assert!(e.contains("bad.obj:3:") && e.contains("position"), "{e}");
    // The last line without a newline.
    let e = error_of("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 q", None);
    assert!(e.contains("bad.obj:4:") && e.contains("face"), "{e}");
}

#[test]
fn obj_face_indices_out_of_range_are_errors_not_panics() {
    for (face, what) in [
        ("f 1 2 4", "vertex index 4"),
        ("f 0 1 2", "index 0"),
        ("f 1/0/1 2/1/1 3/1/1", "texture coordinate index 0"),
        ("f 1//0 2//1 3//1", "normal index 0"),
        ("f 1//9223372036854775807 2//1 3//1", "out of range"),
        ("f -4 -2 -1", "reaches before"),
        ("f 1//-2 2//1 3//1", "reaches before"),
    ] {
        let obj = format!("v 0 0 0\nv 1 0 0\nvt 0 0\nv 0 1 0\nvn 0 0 1\n{face}\n");
        let e = error_of(&obj, None);
        assert!(e.contains("bad.obj:6:") && e.contains(what), "{face}: {e}");
    }
    // Relative indices inside the range are fine.
    let dir = tempfile::tempdir().unwrap();
    let scene = load_obj(
        &write(&dir, "rel.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"),
        camera(),
    )
    .unwrap();
    assert_eq!(meshes(&scene)[0].triangles.len(), 1);
}

#[test]
fn obj_malformed_mtl_is_an_error_naming_the_mtl_and_line() {
    let e = error_of(CUBE, Some("newmtl red\nKd 0.5 0.5\n"));
    assert!(e.contains("cube.mtl:2:") && e.contains("Kd"), "{e}");
    let e = error_of(CUBE, Some("newmtl red\n\nNs lots\n"));
    assert!(e.contains("cube.mtl:3:"), "{e}");
}

#[test]
fn obj_missing_files_are_errors_and_latin1_is_read_with_a_warning() {
    let e = load_obj(Path::new("/nonexistent/model.obj"), camera()).unwrap_err();
    assert!(matches!(e, ObjError::Read { .. }) && e.to_string().contains("/nonexistent/model.obj"));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("latin1.obj");
    std::fs::write(&path, b"v 0 0 0\nv 1 0 0\nv 0 1 0\no caf\xe9\nf 1 2 3\n").unwrap();
    let scene = load_obj(&path, camera()).unwrap();
    assert!(
        scene.objects[0].source.contains("café"),
        "{}",
        scene.objects[0].source
    );
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("latin1.obj:4:") && w.contains("Latin-1")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn obj_line_at_counts_from_one() {
    let t = b"a\nbb\nc";
    assert_eq!(line_at(t, 0), 1);
    assert_eq!(line_at(t, 2), 1); // just past the first newline: line 1 was consumed
    assert_eq!(line_at(t, 3), 2);
    assert_eq!(line_at(t, 6), 3);
    assert_eq!(line_at(t, 99), 3);
}

#[test]
fn obj_roughness_follows_the_blinn_phong_exponent() {
    assert_eq!(roughness_from_ns(0.0), 1.0);
    assert_eq!(roughness_from_ns(-5.0), 1.0);
    assert!(roughness_from_ns(1000.0) < roughness_from_ns(10.0));
    assert!((roughness_from_ns(6.0).powi(4) - 0.25).abs() < 1e-6);
}

/// Issue 16: an OBJ statement `zz 1 2` was ignored without a word.
#[test]
fn obj_unknown_statements_are_warned_about_once_each_with_their_first_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        &dir,
        "zz.obj",
        "# a comment\nv 0 0 0\nzz 1 2\nv 1 0 0\nv 0 1 0\nzz 3\nvv 1 1 1\ncstype bspline\nf 1 2 3\n",
    );
    let scene = load_obj(&path, camera()).unwrap();
    let file = path.display().to_string();
    let unknown: Vec<&String> = scene
        .warnings
        .iter()
        .filter(|w| w.contains("unknown OBJ statement"))
        .collect();
    assert_eq!(
        unknown,
        [
            &format!("{file}:3: unknown OBJ statement \"zz\" (2 lines), ignored"),
            &format!("{file}:7: unknown OBJ statement \"vv\", ignored"),
        ]
    );
    assert_eq!(meshes(&scene).len(), 1);
}

#[test]
fn obj_texture_maps_and_coordinates_are_read_with_t_flipped() {
    let dir = tempfile::tempdir().unwrap();
    write(
        &dir,
        "quad.mtl",
        "newmtl wood\nKd 1 1 1\nKe 0 0 0\nmap_Kd -s 2 2 1 wood grain.png\nmap_Ke glow.png\nnorm -bm 1 n.png\nmap_d a.png\n",
    );
    let obj =
        "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 0.25\nusemtl wood\nf 1/1 2/2 3/3\n";
    let scene = load_obj(&write(&dir, "quad.obj", obj), camera()).unwrap();
    let Shape::Mesh(m) = &scene.objects[0].shape else {
        panic!("not a mesh")
    };
    assert_eq!(
        m.uvs[0],
        [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.75)]
    );
    let maps = &scene.material_maps[&scene.objects[0].material];
    let kd = maps.base_color.unwrap();
    let crate::texture::ImageSource::File(p) = &scene.textures[kd.texture as usize].source else {
        panic!("not a file")
    };
    assert!(p.ends_with("wood grain.png"), "{}", p.display());
    assert_eq!(
        scene.textures[kd.texture as usize].color_space,
        crate::texture::ColorSpace::Srgb
    );
    // -s 2 2 in OBJ's (s, t) is v' = 2 v − 1 on the flipped coordinates.
    assert_eq!(kd.transform, [2.0, 0.0, 0.0, 0.0, 2.0, -1.0]);
    assert!(maps.emissive.is_some() && maps.emissive_factor == Rgb::WHITE);
    assert!(maps.normal.is_some() && maps.opacity.is_some());
    assert_eq!(maps.alpha, crate::texture::AlphaMode::Blend);
    assert!(maps.diffuse_only);
}

#[test]
fn a_map_kd_without_kd_shows_the_texture_as_it_is() {
    // Game-map exporters (Cube 2's writeobj) write map_Kd alone: the texture is the colour, not
    // 0.18 of it; a material with neither keeps the 0.18 grey.
    let dir = tempfile::tempdir().unwrap();
    write(
        &dir,
        "m.mtl",
        "newmtl tex\nmap_Kd wall.png\nnewmtl bare\nKs 0 0 0\nmap_d a.png\n",
    );
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl tex\nf 1/1 2/2 3/3\nusemtl bare\nf 1/1 3/3 2/2\n";
    let scene = load_obj(&write(&dir, "m.obj", obj), camera()).unwrap();
    let factor = |i: usize| scene.material_maps[&scene.objects[i].material].base_color_factor;
    assert_eq!(factor(0), [1.0; 4]);
    assert_eq!(factor(1), [0.18, 0.18, 0.18, 1.0]);
}
