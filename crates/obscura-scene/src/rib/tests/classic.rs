//! Classic shading and geometry: `Color`, `Surface`, classic lights, patches, curves, points,
//! retained objects and procedurals.

use std::f32::consts::PI;

use glam::Vec3;
use obscura_sdk::Rgb;

use super::{fail, ok};
use crate::types::{AmbientReflectance, Light, LocalShading, Material, Shape};

#[test]
fn surfaces_take_the_current_color_and_attribute_blocks_restore_them() {
    let scene = ok(
        "WorldBegin\nAttributeBegin\nColor [1 0 0]\nSurface \"plastic\" \"Kd\" 0.8\nSphere 1 -1 1 360\nAttributeEnd\nSurface \"matte\"\nSphere 1 -1 1 360\nBxdf \"PxrDiffuse\" \"d\"\nSphere 1 -1 1 360\nWorldEnd\n",
    );
    let m = |k: usize| scene.materials[scene.objects[k].material as usize];
    let Material::Surface { diffuse, .. } = m(0) else {
        panic!("plastic is a PxrSurface: {:?}", m(0));
    };
    assert_eq!(diffuse, Rgb::new(0.8, 0.0, 0.0));
    assert_eq!(m(1), Material::Diffuse { color: Rgb::WHITE });
    assert_eq!(
        m(2),
        Material::Diffuse {
            color: Rgb::new(0.18, 0.18, 0.18)
        }
    );
    let mapped = scene
        .warnings
        .iter()
        .filter(|w| w.contains("classic RenderMan shaders"))
        .count();
    assert_eq!(mapped, 1, "{:?}", scene.warnings);
}

#[test]
fn other_shaders_are_named_in_a_warning() {
    let scene =
        ok("WorldBegin\nSurface \"wood\" \"Kd\" 1\nDisplacement \"bumpy\"\nSphere 1 -1 1 360\nWorldEnd\n");
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.starts_with("t.rib:2:") && w.contains("\"wood\"")),
        "{:?}",
        scene.warnings
    );
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.starts_with("t.rib:3:") && w.contains("\"bumpy\""))
    );
}

#[test]
fn classic_lights_become_physical_lights_in_world_space() {
    let scene = ok(
        "WorldBegin\nLightSource \"ambientlight\" 1 \"intensity\" 0.2\nTranslate 0 1 0\nLightSource \"distantlight\" 2 \"from\" [0 0 0] \"to\" [1 0 0] \"intensity\" 2\nLightSource \"pointlight\" 3 \"from\" [0 0 1] \"lightcolor\" [1 0.5 0]\nLightSource \"spotlight\" 4 \"from\" [0 0 0] \"to\" [0 -1 0] \"coneangle\" 0.5 \"conedeltaangle\" 0.1 \"beamdistribution\" 3\nWorldEnd\n",
    );
    let [ambient, distant, point, spot] = &scene.lights[..] else {
        panic!("{:?}", scene.lights);
    };
    assert_eq!(
        *ambient,
        Light::Ambient {
            color: Rgb::WHITE,
            intensity: 0.2
        }
    );
    let Light::Distant {
        intensity,
        transform,
        angle_extent,
        ..
    } = distant
    else {
        panic!("{distant:?}");
    };
    assert!((intensity - 2.0 * PI).abs() < 1e-5 && *angle_extent == 0.0);
    assert!(transform.transform_vector3(Vec3::Z).distance(Vec3::X) < 1e-6);
    let Light::Point(p) = point else {
        panic!("{point:?}")
    };
    assert_eq!(p.position, Vec3::new(0.0, 1.0, 1.0));
    assert_eq!(p.color, Rgb::new(1.0, 0.5, 0.0));
    assert!((p.intensity - PI).abs() < 1e-6);
    let Light::Spot {
        emitter,
        direction,
        cone_angle,
        cone_delta,
        beam_distribution,
    } = spot
    else {
        panic!("{spot:?}");
    };
    assert_eq!(emitter.position, Vec3::Y);
    assert!(direction.distance(-Vec3::Y) < 1e-6);
    assert_eq!((*cone_angle, *cone_delta, *beam_distribution), (0.5, 0.1, 3.0));
}

#[test]
fn a_constant_surface_is_an_emitter_of_its_color() {
    let scene = ok("WorldBegin\nColor 0 1 0\nSurface \"constant\"\nSphere 1 -1 1 360\nWorldEnd\n");
    assert_eq!(
        scene.materials[scene.objects[0].material as usize],
        Material::Constant {
            color: Rgb::new(0.0, 1.0, 0.0)
        }
    );
}

#[test]
fn patch_meshes_are_cut_as_the_spec_says() {
    let pts: String = (0..28).map(|k| format!("{} {} 0 ", k % 7, k / 7)).collect();
    let scene = ok(&format!(
        "WorldBegin\nPatchMesh \"bicubic\" 7 \"nonperiodic\" 4 \"nonperiodic\" \"P\" [{pts}]\nBasis \"b-spline\" 1 \"b-spline\" 1\nPatchMesh \"bicubic\" 7 \"periodic\" 4 \"nonperiodic\" \"P\" [{pts}]\nPatchMesh \"bilinear\" 7 \"nonperiodic\" 4 \"nonperiodic\" \"P\" [{pts}]\nWorldEnd\n"
    ));
    let count = |k: usize| match &scene.objects[k].shape {
        Shape::Patches(p) => p.len(),
        other => panic!("{other:?}"),
    };
    assert_eq!((count(0), count(1), count(2)), (2, 7, 18));
    // A bezier mesh's patch corners are its control points (0,0) and (3,3).
    let Shape::Patches(p) = &scene.objects[0].shape else {
        unreachable!()
    };
    assert_eq!(p[0].points[0], Vec3::ZERO);
    assert_eq!(p[0].points[15], Vec3::new(3.0, 3.0, 0.0));
    let e = fail(
        "WorldBegin\nPatchMesh \"bicubic\" 3 \"nonperiodic\" 4 \"nonperiodic\" \"P\" [0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0]\n",
    );
    assert!(e.contains("t.rib:2") && e.contains("3 × 4"), "{e}");
}

#[test]
fn the_teapot_is_28_bezier_patches_standing_on_z_zero() {
    let scene = ok("WorldBegin\nGeometry \"teapot\"\nWorldEnd\n");
    let Shape::Patches(p) = &scene.objects[0].shape else {
        panic!()
    };
    assert_eq!(p.len(), 28);
    let zmin = p
        .iter()
        .flat_map(|q| q.points)
        .map(|v| v.z)
        .fold(f32::INFINITY, f32::min);
    assert_eq!(zmin, 0.0);
}

#[test]
fn nupatch_is_read_and_checked() {
    let scene = ok(
        "WorldBegin\nNuPatch 2 2 [0 0 1 1] 0 1 2 2 [0 0 1 1] 0 1 \"Pw\" [0 0 0 1 1 0 0 1 0 1 0 1 1 1 0 1]\nTrimCurve [1] [2] [0 0 1 1] [0] [1] [2] [0 1] [0 1] [1 1]\nWorldEnd\n",
    );
    assert!(matches!(&scene.objects[0].shape, Shape::NuPatch(p) if p.points.len() == 4));
    assert!(scene.warnings.iter().any(|w| w.contains("TrimCurve")));
    let e = fail(
        "WorldBegin\nNuPatch 2 2 [0 0 1] 0 1 2 2 [0 0 1 1] 0 1 \"Pw\" [0 0 0 1 1 0 0 1 0 1 0 1 1 1 0 1]\n",
    );
    assert!(e.contains("t.rib:2") && e.contains("[uknot] has 3 knots"), "{e}");
}

#[test]
fn curves_are_cut_into_segments_with_their_widths() {
    let scene = ok(
        "WorldBegin\nCurves \"linear\" [3 2] \"nonperiodic\" \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 1 0] \"width\" [1 2 3 4 5]\nCurves \"cubic\" [7] \"nonperiodic\" \"P\" [0 0 0 1 0 0 2 0 0 3 0 0 4 0 0 5 0 0 6 0 0] \"constantwidth\" 0.1\nWorldEnd\n",
    );
    let Shape::Curves(c) = &scene.objects[0].shape else {
        panic!()
    };
    let widths: Vec<[f32; 2]> = c.segments.iter().map(|s| s.widths).collect();
    assert_eq!(widths, [[1.0, 2.0], [2.0, 3.0], [4.0, 5.0]]);
    let Shape::Curves(c) = &scene.objects[1].shape else {
        panic!()
    };
    assert_eq!(c.segments.len(), 2);
    assert_eq!(c.segments[1].points[3], Vec3::new(6.0, 0.0, 0.0));
    let e =
        fail("WorldBegin\nCurves \"linear\" [3] \"nonperiodic\" \"P\" [0 0 0 1 0 0 2 0 0] \"width\" [1 2]\n");
    assert!(e.contains("\"width\" has 2 values; 3 expected"), "{e}");
}

#[test]
fn points_and_quadrics() {
    let scene = ok(
        "WorldBegin\nPoints \"P\" [0 0 0 1 1 1] \"constantwidth\" 0.5\nHyperboloid 1 0 -1 0 1 1 360\nParaboloid 1 0 2 360\nWorldEnd\n",
    );
    assert!(matches!(&scene.objects[0].shape, Shape::Points(p) if p.widths == [0.5, 0.5]));
    assert!(matches!(scene.objects[1].shape, Shape::Hyperboloid { .. }));
    assert!(matches!(
        scene.objects[2].shape,
        Shape::Paraboloid { radius: 1.0, .. }
    ));
}

#[test]
fn instances_take_the_current_transform_and_color() {
    let scene = ok(
        "ObjectBegin 1\nTranslate 0 0 1\nSphere 1 -1 1 360\nObjectEnd\nWorldBegin\nTranslate 5 0 0\nColor [0 0 1]\nObjectInstance 1\nObjectInstance 1\nWorldEnd\n",
    );
    assert_eq!(scene.objects.len(), 2);
    let m = scene.objects[0].transform.samples[0].1;
    assert_eq!(m.transform_point3(Vec3::ZERO), Vec3::new(5.0, 0.0, 1.0));
    assert_eq!(
        scene.materials[scene.objects[0].material as usize],
        Material::Diffuse {
            color: Rgb::new(0.0, 0.0, 1.0)
        }
    );
    let e = fail("WorldBegin\nObjectInstance 7\n");
    assert!(e.contains("t.rib:2") && e.contains("no object \"7\""), "{e}");
}

#[test]
fn procedurals_read_archives_or_name_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("part.rib"), "Sphere 1 -1 1 360\n").unwrap();
    let main = dir.path().join("main.rib");
    std::fs::write(
        &main,
        "WorldBegin\nProcedural \"DelayedReadArchive\" [\"part.rib\"] [-1 1 -1 1 -1 1]\nSolidBegin \"union\"\nSphere 1 -1 1 360\nSolidEnd\nWorldEnd\n",
    )
    .unwrap();
    let scene = crate::rib::parse_file(&main).unwrap();
    assert_eq!(scene.objects.len(), 2);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("constructive solid geometry"))
    );
    let e = fail("WorldBegin\nProcedural \"RunProgram\" [\"gen\" \"\"] [0 1 0 1 0 1]\n");
    assert!(e.contains("t.rib:2") && e.contains("RunProgram"), "{e}");
}

#[test]
fn a_varying_cs_is_averaged_with_one_warning() {
    // On a quadric (its four corners' colours); a polygon mesh takes them as vertex colours.
    let scene = ok(
        "WorldBegin\nSurface \"matte\"\nSphere 1 -1 1 360 \"Cs\" [1 0 0 0 1 0 0 0 1 1 1 1]\nSphere 1 -1 1 360 \"Cs\" [1 0 0 0 1 0 0 0 1 1 1 1]\nWorldEnd\n",
    );
    assert_eq!(
        scene.materials[scene.objects[0].material as usize],
        Material::Diffuse {
            color: Rgb::new(0.5, 0.5, 0.5)
        }
    );
    let warned = scene
        .warnings
        .iter()
        .filter(|w| w.contains("\"Cs\" varies"))
        .count();
    assert_eq!(warned, 1, "{:?}", scene.warnings);
}

#[test]
fn blobby_programs_are_decoded_and_checked() {
    let scene = ok(
        "WorldBegin\nBlobby 2 [1001 0 1001 16 0 2 0 1] [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 1 0 0 0 0 1 0 0 0 0 1 0 1 0 0 1] [\"\"]\nWorldEnd\n",
    );
    let Shape::Blobby(b) = &scene.objects[0].shape else {
        panic!()
    };
    assert_eq!(b.ops.len(), 3);
    assert!(
        matches!(&b.ops[2], crate::classic::BlobOp::Combine { kind: 0, operands } if operands == &[0, 1])
    );
    // A declared `mpoint` primitive variable is read (and left out with a warning), not an error.
    let scene = ok(
        "WorldBegin\nBlobby 1 [1001 0] [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1] [\"\"] \"vertex mpoint Pref\" [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]\nWorldEnd\n",
    );
    assert!(
        scene.warnings.iter().any(|w| w.contains("Pref")),
        "{:?}",
        scene.warnings
    );
    let e = fail("WorldBegin\nBlobby 1 [1001 5] [0 0 0] [\"\"]\n");
    assert!(e.contains("t.rib:2") && e.contains("float index 5"), "{e}");
    let e = fail("WorldBegin\nBlobby 1 [1003 0 0] [0 0 0 0] [\"x\"]\n");
    assert!(e.contains("opcode 1003"), "{e}");
}

#[test]
fn paintedplastic_without_its_texture_file_warns_where_and_stays_plastic() {
    let scene = ok(
        "WorldBegin\nSurface \"paintedplastic\" \"texturename\" \"grid.tif\"\nSphere 1 -1 1 360\nWorldEnd\n",
    );
    let warning = scene
        .warnings
        .iter()
        .find(|w| w.contains("grid.tif"))
        .unwrap_or_else(|| panic!("{:?}", scene.warnings));
    assert!(
        warning.starts_with(
            "t.rib:2: Surface \"paintedplastic\": texture \"grid.tif\" not found (looked in /base)"
        ),
        "{warning}"
    );
    assert!(scene.textures.is_empty() && scene.material_maps.is_empty());
    assert!(matches!(
        scene.materials[scene.objects[0].material as usize],
        Material::Surface { .. }
    ));
}

#[test]
fn a_missing_texture_beside_a_rib_named_without_a_folder_says_the_current_directory() {
    // `obscura render t.rib` has an empty base folder; the message once read "(looked in )".
    let scene = crate::rib::parse_str(
        "WorldBegin\nSurface \"paintedplastic\" \"texturename\" \"grid.tif\"\nSphere 1 -1 1 360\nWorldEnd\n",
        "t.rib",
        std::path::Path::new(""),
    )
    .unwrap();
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("not found (looked in .)")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn paintedplastic_finds_its_texture_through_the_searchpath_and_paints_the_diffuse_only() {
    use crate::texture::ImageSource;
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("maps")).unwrap();
    std::fs::write(dir.path().join("maps").join("grid.tif"), b"bytes").unwrap();
    let text = "Option \"searchpath\" \"texture\" [\"elsewhere:maps\"]\nWorldBegin\nColor [1 0.5 0.5]\n\
                Surface \"paintedplastic\" \"Kd\" [0.5] \"texturename\" \"grid.tif\"\nSphere 1 -1 1 360\n\
                Surface \"paintedplastic\" \"Kd\" [0.5] \"texturename\" \"grid.tif\"\nSphere 1 -1 1 360\n\
                Surface \"plastic\" \"Kd\" [0.5]\nSphere 1 -1 1 360\nWorldEnd\n";
    let scene = super::super::parse_str(text, "t.rib", dir.path()).unwrap_or_else(|e| panic!("{e}"));
    // One texture for both surfaces, found in the searchpath's second directory.
    assert_eq!(scene.textures.len(), 1);
    assert_eq!(
        scene.textures[0].source,
        ImageSource::File(dir.path().join("maps").join("grid.tif"))
    );
    assert_eq!(
        scene.textures[0].used_by,
        "t.rib:4: Surface \"paintedplastic\" \"texturename\""
    );
    let (a, b, c) = (
        scene.objects[0].material,
        scene.objects[1].material,
        scene.objects[2].material,
    );
    assert_eq!(a, b);
    assert_ne!(a, c, "the untextured plastic is its own material");
    let maps = &scene.material_maps[&a];
    // Kd·Cs is the base colour factor; the highlight is the plastic's own.
    assert_eq!(maps.base_color_factor, [0.5, 0.25, 0.25, 1.0]);
    assert_eq!(maps.metallic, 0.0);
    let Material::Surface { specular, .. } = scene.materials[c as usize] else {
        panic!("plastic");
    };
    assert_eq!(maps.specular, Some(specular));
    let slot = maps.base_color.expect("the texture paints the base colour");
    assert_eq!(slot.texture, 0);
    // (s, 1 − t) coordinates are read back at (s, t).
    assert_eq!(slot.transform, [1.0, 0.0, 0.0, 0.0, -1.0, 1.0]);
    assert!(!scene.material_maps.contains_key(&c));
    // The ambient term is Ka·Cs·texture: (Ka/Kd) times the textured diffuse albedo.
    assert_eq!(
        scene.local_shading[&a].ambient,
        AmbientReflectance::DiffuseScaled(2.0)
    );
    assert_eq!(
        scene.local_shading[&c].ambient,
        AmbientReflectance::Color(Rgb::new(1.0, 0.5, 0.5))
    );
    // A sphere has texture coordinates (its u and v); a polygon without "st" has none: said once.
    assert!(
        !scene.warnings.iter().any(|w| w.contains("texture coordinates")),
        "{:?}",
        scene.warnings
    );
    let text = "Option \"searchpath\" \"texture\" [\"maps\"]\nWorldBegin\n\
                Surface \"paintedplastic\" \"texturename\" \"grid.tif\"\n\
                Polygon \"P\" [0 0 0 1 0 0 1 1 0]\nPolygon \"P\" [0 0 0 1 0 0 1 1 0]\nWorldEnd\n";
    let scene = super::super::parse_str(text, "t.rib", dir.path()).unwrap_or_else(|e| panic!("{e}"));
    let no_st: Vec<_> = scene
        .warnings
        .iter()
        .filter(|w| w.contains("texture coordinates"))
        .collect();
    assert_eq!(no_st.len(), 1, "{:?}", scene.warnings);
    assert!(no_st[0].starts_with("t.rib:4: Polygon: "), "{no_st:?}");
}

#[test]
fn patch_meshes_carry_their_texture_coordinates() {
    // A 3 × 2 bilinear mesh: 2 × 1 patches; by default s = u, t = v over the whole mesh.
    let scene = ok(
        "WorldBegin\nPatchMesh \"bilinear\" 3 \"nonperiodic\" 2 \"nonperiodic\" \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 1 0 2 1 0]\n\
         PatchMesh \"bilinear\" 3 \"nonperiodic\" 2 \"nonperiodic\" \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 1 0 2 1 0] \"st\" [0 0 2 0 4 0 0 1 2 1 4 1]\n\
         PatchMesh \"bilinear\" 3 \"periodic\" 2 \"nonperiodic\" \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 1 0 2 1 0] \"s\" [0 1 2 0 1 2] \"t\" [0 0 0 1 1 1]\nWorldEnd\n",
    );
    let st = |k: usize| -> Vec<[f32; 8]> {
        let Shape::Patches(p) = &scene.objects[k].shape else {
            panic!("patches");
        };
        p.iter()
            .map(|p| {
                let s = p.st;
                [s[0].x, s[0].y, s[1].x, s[1].y, s[2].x, s[2].y, s[3].x, s[3].y]
            })
            .collect()
    };
    assert_eq!(
        st(0),
        vec![
            [0.0, 0.0, 0.5, 0.0, 0.0, 1.0, 0.5, 1.0],
            [0.5, 0.0, 1.0, 0.0, 0.5, 1.0, 1.0, 1.0]
        ]
    );
    assert_eq!(
        st(1),
        vec![
            [0.0, 0.0, 2.0, 0.0, 0.0, 1.0, 2.0, 1.0],
            [2.0, 0.0, 4.0, 0.0, 2.0, 1.0, 4.0, 1.0]
        ]
    );
    // Periodic in u: three patches, the last closing on the first corner.
    assert_eq!(st(2).len(), 3);
    assert_eq!(st(2)[2], [2.0, 0.0, 0.0, 0.0, 2.0, 1.0, 0.0, 1.0]);
    let e = fail(
        "WorldBegin\nPatch \"bilinear\" \"P\" [0 0 0 1 0 0 0 1 0 1 1 0] \"st\" [0 0 1 0 0 1]\nWorldEnd\n",
    );
    assert!(
        e.starts_with("t.rib:2: ") && e.contains("4 finite (s, t) pairs expected"),
        "{e}"
    );
}

#[test]
fn a_distant_light_without_a_direction_is_left_out_with_a_warning() {
    // `"to" [0 0 0]` with the default `"from"`: the spec's shader would light along a zero vector.
    let scene = ok(
        "WorldBegin\nLightSource \"distantlight\" 1 \"to\" [1 0 0]\nLightSource \"distantlight\" 2 \"to\" [0 0 0]\nSphere 1 -1 1 360\nWorldEnd\n",
    );
    assert_eq!(scene.lights.len(), 1);
    assert!(
        scene.warnings.iter().any(|w| w
            .starts_with("t.rib:3: LightSource \"distantlight\": \"from\" and \"to\" are the same point")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn older_wrap_names_and_empty_points_are_read() {
    // RI_WRAP/RI_NOWRAP spell periodic/nonperiodic in older scenes; a particle frame without
    // particles writes `Points "P" []`.
    let scene = ok(
        "WorldBegin\nPatchMesh \"bilinear\" 3 \"wrap\" 2 \"nowrap\" \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 1 0 2 1 0]\nPoints \"P\" []\nWorldEnd\n",
    );
    let Shape::Patches(p) = &scene.objects[0].shape else {
        panic!("patches");
    };
    assert_eq!(p.len(), 3, "periodic in u: as many patches as points");
    assert_eq!(scene.objects.len(), 1);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w == "t.rib:3: Points: \"P\" is empty; nothing to draw"),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn classic_lights_cast_shadows_only_under_bmrts_light_attribute() {
    let scene = ok(
        "WorldBegin\nLightSource \"pointlight\" 1\nAttributeBegin\nAttribute \"light\" \"shadows\" \"on\"\n\
         LightSource \"spotlight\" 2\nLightSource \"distantlight\" 3\nAttributeEnd\nLightSource \"distantlight\" 4\n\
         Light \"PxrDistantLight\" \"d\"\nLight \"PxrDistantLight\" \"e\" \"int enableShadows\" [0]\nWorldEnd\n",
    );
    let shadows: Vec<bool> = scene
        .lights
        .iter()
        .map(|l| match l {
            Light::Point(p) | Light::Spot { emitter: p, .. } => p.enable_shadows,
            Light::Distant { enable_shadows, .. } => *enable_shadows,
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(shadows, [false, true, true, false, true, false]);
    assert!(
        fail("WorldBegin\nAttribute \"light\" \"shadows\" \"yes\"\nWorldEnd\n")
            .starts_with("t.rib:2: Attribute \"light\" \"shadows\": expected \"on\" or \"off\"")
    );
}

#[test]
fn classic_surfaces_shade_by_local_illumination_with_ka_cs_as_their_ambient() {
    let scene = ok("WorldBegin\nColor [1 0.5 0]\n\
         Surface \"matte\" \"Ka\" 0.3\nSphere 1 -1 1 360\n\
         Surface \"plastic\"\nSphere 1 -1 1 360\n\
         Surface \"metal\" \"Ka\" 2\nSphere 1 -1 1 360\n\
         Surface \"wood\" \"Ka\" 0.5\nSphere 1 -1 1 360\n\
         Surface \"constant\"\nSphere 1 -1 1 360\nWorldEnd\n");
    let local = |k: usize| scene.local_shading.get(&scene.objects[k].material).copied();
    let ambient = |ka: f32| {
        Some(LocalShading {
            ambient: AmbientReflectance::Color(Rgb::new(ka, 0.5 * ka, 0.0)),
        })
    };
    assert_eq!(local(0), ambient(0.3));
    assert_eq!(local(1), ambient(1.0), "Ka defaults to 1");
    assert_eq!(local(2), ambient(2.0));
    assert_eq!(local(3), ambient(0.5), "an unknown shader's Ka is kept");
    assert_eq!(local(4), None, "constant only emits");

    let scene = ok(
        "WorldBegin\nColor [0 1 0]\nSphere 1 -1 1 360\nBxdf \"PxrDiffuse\" \"d\"\nSphere 1 -1 1 360\nWorldEnd\n",
    );
    let local = |k: usize| scene.local_shading.get(&scene.objects[k].material).copied();
    assert_eq!(
        local(0),
        Some(LocalShading {
            ambient: AmbientReflectance::Color(Rgb::new(0.0, 1.0, 0.0))
        }),
        "a Color without a Surface shades as matte"
    );
    assert_eq!(local(1), None, "a Bxdf is path traced");
}

#[test]
fn opacity_below_one_makes_a_blended_material_of_the_same_look() {
    use crate::texture::AlphaMode;
    let scene = ok(
        "WorldBegin\nColor [1 0.5 0]\nOpacity [0.5 0.5 0.5]\nSurface \"matte\"\nSphere 1 -1 1 360\n\
         Surface \"plastic\"\nSphere 1 -1 1 360\nOpacity [1 1 1]\nSphere 1 -1 1 360\n\
         Surface \"constant\"\nSphere 1 -1 1 360 \"Os\" [0.2 0.2 0.2]\n\
         Opacity [0.2 0.4 0.6]\nSphere 1 -1 1 360\nWorldEnd\n",
    );
    let maps = |k: usize| scene.material_maps.get(&scene.objects[k].material);
    let matte = maps(0).expect("a transparent matte has maps");
    assert_eq!(matte.base_color_factor, [1.0, 0.5, 0.0, 0.5]);
    assert_eq!(matte.alpha, AlphaMode::Blend);
    assert!(matte.diffuse_only && !matte.vertex_colors && matte.metallic == 0.0);
    let Material::Surface {
        diffuse,
        specular,
        roughness,
    } = scene.materials[scene.objects[1].material as usize]
    else {
        panic!("plastic");
    };
    let plastic = maps(1).expect("a transparent plastic has maps");
    assert_eq!(plastic.base_color_factor, [diffuse.r, diffuse.g, diffuse.b, 0.5]);
    assert_eq!((plastic.specular, plastic.roughness), (Some(specular), roughness));
    assert!(!plastic.diffuse_only);
    assert!(maps(2).is_none(), "opaque again after Opacity [1 1 1]");
    // A primitive's own Os; constant becomes emission over a black surface.
    let constant = maps(3).expect("a transparent constant has maps");
    assert_eq!(constant.base_color_factor, [0.0, 0.0, 0.0, 0.2]);
    assert_eq!(constant.emissive_factor, Rgb::new(1.0, 0.5, 0.0));
    // A coloured opacity is its mean, said once.
    assert!((maps(4).unwrap().base_color_factor[3] - 0.4).abs() < 1e-6);
    let said: Vec<_> = scene
        .warnings
        .iter()
        .filter(|w| w.contains("coloured opacity"))
        .collect();
    assert_eq!(said.len(), 1, "{:?}", scene.warnings);
    assert!(said[0].starts_with("t.rib:"), "{said:?}");
}

#[test]
fn cs_per_vertex_on_a_polygon_mesh_becomes_vertex_colours() {
    let scene = ok(
        "WorldBegin\nColor [0.2 0.2 0.2]\nSurface \"matte\" \"Ka\" 0.5 \"Kd\" 0.8\n\
         Polygon \"P\" [0 0 0  1 0 0  1 1 0  0 1 0] \"Cs\" [1 0 0  0 1 0  0 0 1  1 1 1]\n\
         Polygon \"P\" [0 0 0  1 0 0  1 1 0] \"Cs\" [0 1 0  0 1 0  0 1 0]\n\
         Polygon \"P\" [0 0 0  1 0 0  1 1 0]\nWorldEnd\n",
    );
    let Shape::Mesh(mesh) = &scene.objects[0].shape else {
        panic!("a mesh")
    };
    assert_eq!(
        mesh.colors.as_deref(),
        Some(
            &[
                [1.0, 0.0, 0.0, 1.0],
                [0.0, 1.0, 0.0, 1.0],
                [0.0, 0.0, 1.0, 1.0],
                [1.0; 4]
            ][..]
        )
    );
    let k = scene.objects[0].material;
    // White, Kd 0.8, multiplied by the vertex colours; the ambient term follows them: Ka/Kd.
    assert_eq!(
        scene.materials[k as usize],
        Material::Diffuse {
            color: Rgb::new(0.8, 0.8, 0.8)
        }
    );
    let maps = &scene.material_maps[&k];
    assert!(maps.vertex_colors && maps.diffuse_only);
    assert_eq!(maps.base_color_factor, [0.8, 0.8, 0.8, 1.0]);
    assert_eq!(
        scene.local_shading[&k].ambient,
        AmbientReflectance::DiffuseScaled(0.5 / 0.8)
    );
    assert!(
        !scene
            .warnings
            .iter()
            .any(|w| w.contains("varies over the primitive")),
        "{:?}",
        scene.warnings
    );
    // One colour given per vertex is that colour; without "Cs" the Color stands.
    let Shape::Mesh(one) = &scene.objects[1].shape else {
        panic!("a mesh")
    };
    assert!(one.colors.is_none());
    assert_eq!(
        scene.materials[scene.objects[1].material as usize],
        Material::Diffuse {
            color: Rgb::new(0.0, 0.8, 0.0)
        }
    );
    assert_eq!(
        scene.materials[scene.objects[2].material as usize],
        Material::Diffuse {
            color: Rgb::new(0.2 * 0.8, 0.2 * 0.8, 0.2 * 0.8)
        }
    );
    assert!(!scene.material_maps.contains_key(&scene.objects[2].material));
}

#[test]
fn visibility_attributes_hide_from_the_camera_and_from_shadow_rays() {
    use crate::Visibility;
    let scene = ok("WorldBegin\n\
         AttributeBegin\nAttribute \"visibility\" \"int camera\" [0]\nSphere 1 -1 1 360\n\
         Attribute \"visibility\" \"string transmission\" [\"transparent\"]\nSphere 1 -1 1 360\n\
         Attribute \"visibility\" \"camera\" 1 \"int transmission\" [1]\nSphere 1 -1 1 360\nAttributeEnd\n\
         AttributeBegin\nAttribute \"render\" \"string casts_shadows\" [\"none\"]\nSphere 1 -1 1 360\n\
         Attribute \"render\" \"casts_shadows\" \"Os\"\nSphere 1 -1 1 360\nAttributeEnd\n\
         Attribute \"visibility\" \"int trace\" [1] \"int indirect\" [0]\nSphere 1 -1 1 360\nWorldEnd\n");
    let v = |k: usize| scene.objects[k].visibility;
    let vis = |camera, shadows| Visibility { camera, shadows };
    assert_eq!(v(0), vis(false, true));
    assert_eq!(v(1), vis(false, false));
    assert_eq!(v(2), vis(true, true));
    assert_eq!(v(3), vis(true, false), "BMRT's casts_shadows none");
    assert_eq!(v(4), vis(true, true));
    // The attribute blocks restored the default; the visibilities the renderer has no rays for are
    // named once each.
    assert_eq!(v(5), Visibility::default());
    for key in ["\"trace\"", "\"indirect\""] {
        assert_eq!(
            scene
                .warnings
                .iter()
                .filter(|w| w.contains(key) && w.contains("not supported"))
                .count(),
            1,
            "{key}: {:?}",
            scene.warnings
        );
    }
    assert_eq!(
        fail("WorldBegin\nAttribute \"render\" \"casts_shadows\" \"sometimes\"\n"),
        "t.rib:2: Attribute \"render\" \"casts_shadows\": expected \"opaque\", \"Os\", \"shade\" or \"none\", got \"sometimes\""
    );
    assert_eq!(
        fail("WorldBegin\nAttribute \"visibility\" \"int camera\" [\"no\"]\n"),
        "t.rib:2: Attribute \"visibility\" \"camera\": expected 0 or 1"
    );
}
