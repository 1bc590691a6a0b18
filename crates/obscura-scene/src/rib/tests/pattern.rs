//! `Pattern "PxrTexture"`/`"PxrNormalMap"` connected to Bxdf parameters by `reference`.

use std::path::PathBuf;

use obscura_sdk::Rgb;

use super::*;
use crate::texture::{ColorSpace, ImageSource, TextureSlot};
use crate::types::Material;

#[test]
fn pxr_texture_and_normal_map_connect_to_a_surface_by_reference() {
    let scene = ok("WorldBegin\n\
         Pattern \"PxrTexture\" \"wood\" \"string filename\" [\"tex/wood.png\"] \"int linearize\" [1]\n\
         Pattern \"PxrNormalMap\" \"bumps\" \"string filename\" \"/abs/n.png\" \"float bumpScale\" [0.5]\n\
         Pattern \"PxrTexture\" \"raw\" \"string filename\" [\"raw.exr\"] \"int invertT\" [0] \"int filter\" [0]\n\
         Bxdf \"PxrSurface\" \"s\" \"reference color diffuseColor\" [\"wood:resultRGB\"] \
              \"float diffuseGain\" [0.5] \"color specularFaceColor\" [0.04 0.04 0.04] \
              \"reference normal bumpNormal\" [\"bumps:resultN\"]\n\
         Bxdf \"PxrDiffuse\" \"d\" \"reference color diffuseColor\" [\"raw:resultRGB\"]\n\
         Bxdf \"PxrDiffuse\" \"plain\" \"color diffuseColor\" [0.1 0.2 0.3]\n");
    let t = &scene.textures;
    assert_eq!(t.len(), 3);
    assert_eq!(
        t[0].source,
        ImageSource::File(PathBuf::from("/base/tex/wood.png"))
    );
    assert_eq!(t[0].color_space, ColorSpace::Srgb, "linearize 1: sRGB decoded");
    assert_eq!(t[1].source, ImageSource::File(PathBuf::from("/abs/n.png")));
    assert_eq!(t[1].color_space, ColorSpace::Linear);
    assert_eq!(t[2].color_space, ColorSpace::Linear, "linearize defaults to 0");
    assert!(t[2].nearest && !t[0].nearest, "filter 0 is nearest");
    assert!(
        t[0].used_by
            .starts_with("t.rib:2: Pattern \"PxrTexture\" \"wood\""),
        "{}",
        t[0].used_by
    );

    // Material 1: PxrSurface, its entry the untextured fallback, its maps the connections.
    assert_eq!(scene.material_maps.len(), 2);
    let s = &scene.material_maps[&1];
    assert_eq!(s.base_color, Some(TextureSlot::new(0)));
    assert_eq!(
        s.base_color_factor,
        [0.5, 0.5, 0.5, 1.0],
        "diffuseGain multiplies the texture"
    );
    assert_eq!(s.specular, Some(Rgb::new(0.04, 0.04, 0.04)));
    assert!(!s.diffuse_only);
    let n = s.normal.expect("bumpNormal connected");
    assert_eq!((n.texture, n.scale), (1, 0.5));
    assert!(matches!(scene.materials[1], Material::Surface { .. }));

    // Material 2: PxrDiffuse reading the texture with invertT 0 (t mirrored).
    let d = &scene.material_maps[&2];
    let slot = d.base_color.expect("diffuseColor connected");
    assert_eq!(slot.texture, 2);
    assert_eq!(slot.transform, [1.0, 0.0, 0.0, 0.0, -1.0, 1.0]);
    assert!(d.diffuse_only);
    assert_eq!((d.metallic, d.roughness), (0.0, 1.0));
    // Material 3 has no references: no maps.
    assert!(!scene.material_maps.contains_key(&3));
}

#[test]
fn bad_references_are_errors_naming_the_line() {
    let texture = "Pattern \"PxrTexture\" \"t\" \"string filename\" [\"a.png\"]\n";
    assert_eq!(
        fail("WorldBegin\nBxdf \"PxrDiffuse\" \"d\" \"reference color diffuseColor\" [\"nope:resultRGB\"]\n"),
        "t.rib:2: Bxdf: reference \"diffuseColor\": no Pattern with handle \"nope\" before this line"
    );
    assert_eq!(
        fail(&format!(
            "WorldBegin\n{texture}Bxdf \"PxrDiffuse\" \"d\" \"reference color diffuseColor\" [\"t\"]\n"
        )),
        "t.rib:3: Bxdf: reference \"diffuseColor\": \"t\" is not \"handle:output\""
    );
    assert_eq!(
        fail(&format!(
            "WorldBegin\n{texture}Bxdf \"PxrDiffuse\" \"d\" \"reference color diffuseColor\" [\"t:resultN\"]\n"
        )),
        "t.rib:3: Bxdf: reference \"diffuseColor\" [\"t:resultN\"] cannot be connected (PxrTexture gives \
         resultRGB to diffuseColor)"
    );
    assert_eq!(
        fail(&format!(
            "WorldBegin\n{texture}Bxdf \"PxrConstant\" \"c\" \"reference color emitColor\" [\"t:resultRGB\"]\n"
        )),
        "t.rib:3: Bxdf: references are read on PxrDiffuse and PxrSurface only"
    );
    assert_eq!(
        fail("WorldBegin\nPattern \"PxrTexture\" \"t\" \"int linearize\" [1]\n"),
        "t.rib:2: Pattern \"PxrTexture\" \"t\": no \"string filename\""
    );
    let scene = ok("WorldBegin\nPattern \"PxrChecker\" \"c\"\n");
    assert!(
        scene.warnings[0].contains("Pattern: \"PxrChecker\" is not supported"),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn polygon_st_is_the_first_coordinate_set_with_t_flipped() {
    let o = only_object("Polygon \"P\" [0 0 0 1 0 0 1 1 0] \"st\" [0 0 1 0 1 0.25]");
    let m = match &o.shape {
        crate::types::Shape::Mesh(m) => m,
        other => panic!("{other:?}"),
    };
    assert_eq!(
        m.uvs,
        [vec![
            glam::Vec2::new(0.0, 1.0),
            glam::Vec2::new(1.0, 1.0),
            glam::Vec2::new(1.0, 0.75)
        ]]
    );
    assert_eq!(
        fail("WorldBegin\nPolygon \"P\" [0 0 0 1 0 0 1 1 0] \"st\" [0 0 1 0]\n"),
        "t.rib:2: Polygon: \"st\" has 4 values; expected 2 per point (6)"
    );
}
