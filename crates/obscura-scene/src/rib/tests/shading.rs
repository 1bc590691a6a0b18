//! Materials, lights and attributes.

use std::path::PathBuf;

use glam::{Mat4, Vec3};
use obscura_sdk::Rgb;

use super::*;
use crate::types::{Light, Material};

#[test]
fn bxdfs_become_materials() {
    let scene = ok("WorldBegin\n\
         Bxdf \"PxrDiffuse\" \"a\" \"color diffuseColor\" [0.1 0.2 0.3]\n\
         Bxdf \"PxrDiffuse\" \"b\"\n\
         Bxdf \"PxrConstant\" \"c\"\n\
         Bxdf \"PxrConstant\" \"d\" \"color emitColor\" [4 5 6]\n\
         Bxdf \"PxrSurface\" \"e\" \"color diffuseColor\" [0.5 0.5 1] \"float diffuseGain\" [0.5] \
              \"color specularFaceColor\" [0.04 0.04 0.04] \"float specularRoughness\" [0.3]\n\
         Bxdf \"PxrSurface\" \"f\"\n");
    let m = &scene.materials;
    assert_eq!(m.len(), 7);
    assert_eq!(
        m[1],
        Material::Diffuse {
            color: Rgb::new(0.1, 0.2, 0.3)
        }
    );
    assert_eq!(
        m[2],
        Material::Diffuse {
            color: Rgb::new(0.18, 0.18, 0.18)
        }
    );
    assert_eq!(m[3], Material::Constant { color: Rgb::WHITE });
    assert_eq!(
        m[4],
        Material::Constant {
            color: Rgb::new(4.0, 5.0, 6.0)
        }
    );
    assert_eq!(
        m[5],
        Material::Surface {
            diffuse: Rgb::new(0.25, 0.25, 0.5),
            specular: Rgb::new(0.04, 0.04, 0.04),
            roughness: 0.3
        }
    );
    assert_eq!(
        m[6],
        Material::Surface {
            diffuse: Rgb::new(0.18, 0.18, 0.18),
            specular: Rgb::BLACK,
            roughness: 0.2
        }
    );
}

#[test]
fn unknown_bxdf_warns_and_falls_back_to_the_default_material() {
    let scene = ok("WorldBegin\nBxdf \"PxrDiffuse\" \"a\"\nBxdf \"PxrDisney\" \"b\"\nSphere 1 -1 1 360\n");
    assert_eq!(scene.objects[0].material, 0);
    assert_eq!(scene.warnings.len(), 1);
    assert!(scene.warnings[0].starts_with("t.rib:3: Bxdf: unknown Bxdf \"PxrDisney\""));
}

#[test]
fn lights_are_read_with_defaults_and_transforms() {
    let scene = ok("WorldBegin\n\
         Light \"PxrDomeLight\" \"dome\" \"color lightColor\" [1 0.5 0.25] \"float intensity\" [2] \
               \"float exposure\" [1] \"string lightColorMap\" [\"sky.exr\"]\n\
         Light \"PxrDistantLight\" \"sun\" \"float angleExtent\" [2]\n\
         Translate 0 3 0\n\
         Light \"PxrRectLight\" \"rect\"\n\
         LightSource \"PxrSphereLight\" 1 \"intensity\" 5\n\
         AreaLightSource \"PxrDistantLight\" \"old\"\n\
         Light \"PxrSpotLight\" \"spot\"\n");
    let l = &scene.lights;
    assert_eq!(l.len(), 5);
    assert_eq!(
        l[0],
        Light::Dome {
            color: Rgb::new(1.0, 0.5, 0.25),
            intensity: 2.0,
            exposure: 1.0,
            map: Some(PathBuf::from("/base/sky.exr")),
            transform: Mat4::IDENTITY
        }
    );
    assert_eq!(
        l[1],
        Light::Distant {
            color: Rgb::WHITE,
            intensity: 1.0,
            exposure: 0.0,
            angle_extent: 2.0,
            enable_shadows: true,
            transform: Mat4::IDENTITY
        }
    );
    let up = Mat4::from_translation(Vec3::new(0.0, 3.0, 0.0));
    assert_eq!(
        l[2],
        Light::Rect {
            color: Rgb::WHITE,
            intensity: 1.0,
            exposure: 0.0,
            transform: up
        }
    );
    assert_eq!(
        l[3],
        Light::Sphere {
            color: Rgb::WHITE,
            intensity: 5.0,
            exposure: 0.0,
            transform: up
        }
    );
    assert!(matches!(
        l[4],
        Light::Distant {
            angle_extent: 0.53,
            enable_shadows: true,
            ..
        }
    ));
    assert_eq!(scene.warnings.len(), 1);
    assert!(scene.warnings[0].starts_with("t.rib:8: Light: unknown light \"PxrSpotLight\""));
}

#[test]
fn dice_attribute_sets_micropolygon_length_and_others_warn_once() {
    let scene = ok("WorldBegin\nAttribute \"trace\" \"int maxdiffusedepth\" [1]\n\
         Attribute \"trace\" \"int maxdiffusedepth\" [2]\n\
         Attribute \"dice\" \"micropolygonlength\" [3]\nSphere 1 -1 1 360\n");
    assert_eq!(scene.objects[0].micropolygon_length, 3.0);
    assert_eq!(
        scene.warnings,
        vec!["t.rib:2: Attribute \"trace\" is not supported, ignored".to_string()]
    );
    assert_eq!(
        fail("WorldBegin\nAttribute \"dice\" \"float micropolygonlength\" [0]"),
        "t.rib:2: Attribute \"dice\": micropolygonlength must be greater than 0, got 0"
    );
}

#[test]
fn identifier_names_the_objects_of_its_attribute_block() {
    let scene = ok(
        "WorldBegin\nAttributeBegin\nAttribute \"identifier\" \"string name\" \"hero\"\n\
         Sphere 1 -1 1 360\nAttributeBegin\nAttribute \"identifier\" \"name\" \"hat\"\nDisk 0 1 360\n\
         AttributeEnd\nCone 1 1 360\nAttributeEnd\nTorus 1 0.2 0 360 360\n",
    );
    let names: Vec<&str> = scene.objects.iter().map(|o| o.identity.object.as_str()).collect();
    assert_eq!(names, ["hero", "hat", "hero", ""]);
    assert_eq!(scene.objects[1].identity.instance, "hat");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
}

/// Issue 16: a light of intensity −5 or colour −5 rendered without a word.
#[test]
fn negative_or_non_finite_lights_are_errors_naming_the_line_and_parameter() {
    assert_eq!(
        fail("WorldBegin\nLight \"PxrDomeLight\" \"d\" \"float intensity\" [-5]"),
        "t.rib:2: Light \"PxrDomeLight\": \"float intensity\" [-5]: expected a finite value >= 0 (lights do not subtract light)"
    );
    assert_eq!(
        fail("WorldBegin\n\nLight \"PxrRectLight\" \"r\" \"color lightColor\" [-5 1 1]"),
        "t.rib:3: Light \"PxrRectLight\": \"color lightColor\" [-5 1 1]: expected finite components >= 0 (lights do not subtract light)"
    );
    let e = fail("WorldBegin\nLight \"PxrSphereLight\" \"s\" \"float exposure\" [1e9]");
    assert!(
        e.starts_with("t.rib:2: Light \"PxrSphereLight\": \"float exposure\" [1000000000]: expected stops"),
        "{e}"
    );
    // Zero is a light switched off, not a mistake.
    let scene = ok(
        "WorldBegin\nLight \"PxrDistantLight\" \"k\" \"float intensity\" [0] \"color lightColor\" [0 0 0]",
    );
    assert_eq!(scene.lights.len(), 1);
}
