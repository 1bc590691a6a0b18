//! Classic RenderMan scenes end to end: a `constant` surface shows its colour with no light, and a
//! `matte` surface under a classic `distantlight` has the shader's own brightness `Kd·Cs·I·cos θ`.

mod common;

use common::render_rib;

use std::path::Path;
use std::sync::atomic::AtomicBool;

use obscura_plugins::builtin_registry;
use obscura_render::render::{RenderOptions, prepare};
use obscura_scene::rib::parse_str;

/// The mean beauty of the central 4×4 pixels of `rib` rendered at 16×16.
fn centre(rib: &str) -> [f64; 3] {
    let film = render_rib(rib);
    let mut sum = [0.0f64; 3];
    for y in 6..10 {
        for x in 6..10 {
            let p = film.pixel(x, y);
            sum[0] += f64::from(p.ci.r) / 16.0;
            sum[1] += f64::from(p.ci.g) / 16.0;
            sum[2] += f64::from(p.ci.b) / 16.0;
        }
    }
    sum
}

const CAMERA: &str = "Format 16 16 1\nHider \"raytrace\" \"int maxsamples\" [16]\nProjection \"PxrPerspective\" \"float fov\" [30]\n";

#[test]
fn a_constant_surface_shows_its_colour_without_any_light() {
    let c = centre(&format!(
        "{CAMERA}WorldBegin\nColor [1 0.5 0.25]\nSurface \"constant\"\nTranslate 0 0 5\nSphere 2 -2 2 360\nWorldEnd\n"
    ));
    for (got, want) in c.iter().zip([1.0, 0.5, 0.25]) {
        assert!((got - want).abs() < 1e-3, "{c:?}");
    }
}

#[test]
fn a_matte_surface_under_a_distant_light_has_the_classic_brightness() {
    // A square facing the camera (normal −z) lit head-on, and at 60°: Kd·Cs·I·cos θ.
    for (to, cos) in [("0 0 1", 1.0), ("0 0.8660254 0.5", 0.5)] {
        let c = centre(&format!(
            "{CAMERA}WorldBegin\nLightSource \"distantlight\" 1 \"intensity\" [0.8] \"from\" [0 0 0] \"to\" [{to}]\nColor [1 0.5 1]\nSurface \"matte\" \"Kd\" [0.5]\nPolygon \"P\" [-5 -5 5  5 -5 5  5 5 5  -5 5 5]\nWorldEnd\n"
        ));
        let want = 0.5 * 0.8 * cos;
        assert!((c[0] - want).abs() < 0.01 * want, "cos {cos}: {c:?} vs {want}");
        assert!((c[1] - 0.5 * want).abs() < 0.01 * want, "{c:?}");
    }
}

/// The texels of the painted texture, 8-bit codes, row by row from the top.
const TEXELS: [[[u8; 3]; 4]; 2] = [
    [[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]],
    [[10, 20, 30], [128, 128, 128], [200, 100, 50], [0, 0, 0]],
];

/// Renders `rib` (read as `dir/t.rib`) at 16×8 with point lookups (the nearest texel, unfiltered):
/// the albedo of every pixel, and the renderer's texture warnings.
fn painted_albedo(dir: &Path, rib: &str) -> (Vec<[f32; 3]>, Vec<String>) {
    use obscura_shading::material::textured::TextureLookup;
    let scene = parse_str(rib, &dir.join("t.rib").display().to_string(), dir).expect("reads");
    let opts = RenderOptions {
        samples_per_pixel: Some(4),
        texture_lookup: TextureLookup::Point,
        ..RenderOptions::default()
    };
    let prepared = prepare(&scene, &mut builtin_registry(), dir, &opts).expect("prepares");
    let warnings = prepared.texture_warnings().to_vec();
    let out = prepared.render(&opts, &|_, _| {}, &AtomicBool::new(false));
    let albedo = (0..8)
        .flat_map(|y| (0..16).map(move |x| (x, y)))
        .map(|(x, y)| {
            let a = out.film.pixel(x, y).albedo;
            [a.r, a.g, a.b]
        })
        .collect();
    (albedo, warnings)
}

/// An orthographic camera over x ∈ [−2, 2], y ∈ [−1, 1] looking at a bilinear patch that fills it:
/// its (u, v) = (0, 0) corner at the top left, u to the right, v down.
fn painted_patch(surface: &str) -> String {
    format!(
        "Format 16 8 1\nPixelFilter \"box\" 1 1\nProjection \"orthographic\"\nScreenWindow -2 2 -1 1\n\
         WorldBegin\nLightSource \"ambientlight\" 1\n{surface}\n\
         Patch \"bilinear\" \"P\" [-2 1 5  2 1 5  -2 -1 5  2 -1 5]\nWorldEnd\n"
    )
}

#[test]
fn paintedplastic_paints_the_patch_with_its_texels_in_the_ris_orientation() {
    // RISpec §4.2 and §7.1: a patch's default texture coordinates are s = u, t = v, and t = 0 is the
    // texture's first (top) row; texture() reads the values as stored. The file is a TIFF named
    // `.tex`, as RenderMan's txmake writes them.
    let dir = tempfile::tempdir().unwrap();
    let img = image::RgbImage::from_fn(4, 2, |x, y| image::Rgb(TEXELS[y as usize][x as usize]));
    img.save_with_format(dir.path().join("texels.tex"), image::ImageFormat::Tiff)
        .unwrap();
    let (albedo, warnings) = painted_albedo(
        dir.path(),
        &painted_patch("Surface \"paintedplastic\" \"Kd\" [1] \"texturename\" \"texels.tex\""),
    );
    assert!(warnings.is_empty(), "{warnings:?}");
    for y in 0..8 {
        for x in 0..16 {
            let (col, row) = (x / 4, y / 4);
            let want = TEXELS[row][col].map(|c| f32::from(c) / 255.0);
            let got = albedo[y * 16 + x];
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < 1e-5,
                    "pixel ({x}, {y}) channel {c}: {} instead of texel ({col}, {row}) = {}",
                    got[c],
                    want[c]
                );
            }
        }
    }
}

#[test]
fn a_tex_file_that_is_not_an_image_is_a_located_warning_and_plastic() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("pixar.tex"),
        b"not a TIFF: Pixar's own texture format",
    )
    .unwrap();
    let (albedo, warnings) = painted_albedo(
        dir.path(),
        &painted_patch(
            "Color [0.5 0.25 1]\nSurface \"paintedplastic\" \"Kd\" [1] \"texturename\" \"pixar.tex\"",
        ),
    );
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("t.rib:8: Surface \"paintedplastic\"") && warnings[0].contains("pixar.tex"),
        "{warnings:?}"
    );
    // The factor alone: Kd·Cs.
    for a in albedo {
        assert!((a[0] - 0.5).abs() < 1e-6 && (a[1] - 0.25).abs() < 1e-6 && (a[2] - 1.0).abs() < 1e-6);
    }
}

#[test]
fn classic_lights_cast_no_shadows_unless_bmrts_attribute_asks() {
    // The spec's distantlight has no shadow() call: a scene closed by a star-field sphere (as the
    // RenderMan Companion's planets are) is still lit. BMRT's Attribute "light" "shadows" "on" gives
    // the light shadows, and then the sphere blocks it.
    let scene = |attribute: &str| {
        format!(
            "{CAMERA}WorldBegin\n{attribute}LightSource \"distantlight\" 1 \"intensity\" [0.8] \"from\" [0 0 0] \"to\" [0 0 1]\n\
             Surface \"matte\" \"Kd\" [0.5]\nSphere 50 -50 50 360\nPolygon \"P\" [-5 -5 5  5 -5 5  5 5 5  -5 5 5]\nWorldEnd\n"
        )
    };
    // Kd·I·cos θ = 0.4 direct, plus what the lit inside of the sphere reflects onto the square.
    let lit = centre(&scene(""));
    assert!(lit[0] > 0.4 && lit[0] < 0.6, "{lit:?}");
    let shadowed = centre(&scene("Attribute \"light\" \"shadows\" \"on\"\n"));
    assert!(shadowed[0] < 1e-6, "{shadowed:?}");
}

#[test]
fn a_surface_of_opacity_below_one_shows_what_is_behind_it_in_proportion() {
    // A red constant square of opacity 0.3 in front of a blue constant one: 0.3·red + 0.7·blue, the
    // RI's compositing of `Oi`. Without transparency the centre is pure red.
    let c = centre(
        "Format 16 16 1\nHider \"raytrace\" \"int maxsamples\" [256]\nProjection \"PxrPerspective\" \"float fov\" [30]\n\
         WorldBegin\nSurface \"constant\"\n\
         AttributeBegin\nColor [1 0 0]\nOpacity [0.3 0.3 0.3]\nPolygon \"P\" [-5 -5 5  5 -5 5  5 5 5  -5 5 5]\nAttributeEnd\n\
         Color [0 0 1]\nPolygon \"P\" [-50 -50 20  50 -50 20  50 50 20  -50 50 20]\nWorldEnd\n",
    );
    assert!((c[0] - 0.3).abs() < 0.03, "{c:?}");
    assert!(c[1].abs() < 1e-6, "{c:?}");
    assert!((c[2] - 0.7).abs() < 0.03, "{c:?}");
}

#[test]
fn a_classic_surface_inside_a_closed_sphere_is_lit_by_its_ambient_term() {
    // The camera inside a matte sphere (Ka 0.5) with only an ambientlight of 0.4: the RI's
    // Ka·Cs·ambient() = 0.5·(1, 0.5, 1)·0.4, exactly and without noise. An occluded ambient dome
    // would leave it black.
    let c = centre(&format!(
        "{CAMERA}WorldBegin\nLightSource \"ambientlight\" 1 \"intensity\" [0.4]\nColor [1 0.5 1]\n\
         Surface \"matte\" \"Ka\" [0.5]\nSphere 10 -10 10 360\nWorldEnd\n"
    ));
    for (got, want) in c.iter().zip([0.2, 0.1, 0.2]) {
        assert!((got - want).abs() < 1e-5, "{c:?}");
    }
}

#[test]
fn cs_per_vertex_shades_a_polygon_across_its_vertices() {
    // A matte square lit head-on (Kd·Cs·I·cos θ = Cs), red on its left edge and blue on its right:
    // the middle of the image is half of each. Averaged (as before) every pixel would be that half;
    // off centre, the colour follows the vertices.
    let rib = |x0: f32, x1: f32| {
        format!(
            "{CAMERA}WorldBegin\nLightSource \"distantlight\" 1 \"from\" [0 0 0] \"to\" [0 0 1]\nSurface \"matte\"\n\
             Polygon \"P\" [{x0} -5 5  {x1} -5 5  {x1} 5 5  {x0} 5 5] \"Cs\" [1 0 0  0 0 1  0 0 1  1 0 0]\nWorldEnd\n"
        )
    };
    let c = centre(&rib(-5.0, 5.0));
    assert!(
        (c[0] - 0.5).abs() < 0.02 && c[1].abs() < 1e-6 && (c[2] - 0.5).abs() < 0.02,
        "{c:?}"
    );
    // A square spanning x from −0.5 to 9.5: the centre pixels (x ≈ ±0.17 at z = 5, the view spanning
    // about ±1.34) lie within a tenth of its width of the red edge, so they are nearly red.
    let c = centre(&rib(-0.5, 9.5));
    assert!(c[0] > 0.9 && c[2] < 0.1, "near the red edge: {c:?}");
}

#[test]
fn what_camera_rays_do_not_see_and_what_casts_no_shadow() {
    // A white matte square lit head-on by a shadowing point light (BMRT's light shadows on), behind
    // a blue constant square: hidden from the camera, the blue one leaves the white showing but
    // still shadows it; hidden and shadowless, the white is lit as if it were not there.
    let rib = |visibility: &str| {
        format!(
            "{CAMERA}WorldBegin\nAttribute \"light\" \"shadows\" \"on\"\n\
             LightSource \"pointlight\" 1 \"from\" [0 0 0] \"intensity\" [25]\n\
             Surface \"matte\"\nPolygon \"P\" [-5 -5 5  5 -5 5  5 5 5  -5 5 5]\n\
             AttributeBegin\n{visibility}\nColor [0 0 1]\nSurface \"constant\"\n\
             Polygon \"P\" [-2 -2 3  2 -2 3  2 2 3  -2 2 3]\nAttributeEnd\nWorldEnd\n"
        )
    };
    let seen = centre(&rib(""));
    assert!(
        seen[2] > 0.99 && seen[0] < 1e-6,
        "the blue square in front: {seen:?}"
    );
    let hidden = centre(&rib("Attribute \"visibility\" \"int camera\" [0]"));
    assert!(
        hidden[0] < 1e-6 && hidden[2] < 1e-6,
        "the white square in its shadow: {hidden:?}"
    );
    // Lit: Kd·Cs·I/d² = 25/25 = 1 head-on at the centre (cos θ ≈ 1 over the centre pixels).
    let shadowless = centre(&rib(
        "Attribute \"visibility\" \"int camera\" [0] \"int transmission\" [0]",
    ));
    assert!(
        (shadowless[0] - 1.0).abs() < 0.02 && (shadowless[2] - 1.0).abs() < 0.02,
        "{shadowless:?}"
    );
}

#[test]
fn paintedplastic_paints_a_quadric_by_its_u_and_v() {
    // A Disk of radius 4 at z = 5 under the orthographic view of `painted_patch`: the RI's default
    // (s, t) on a quadric is its (u, v): s = θ/360° around +z from +x toward +y, t = 1 − ρ/4 from the
    // rim in. Every pixel whose exact (s, t) is clear of a texel's edge shows that texel.
    let dir = tempfile::tempdir().unwrap();
    let img = image::RgbImage::from_fn(4, 2, |x, y| image::Rgb(TEXELS[y as usize][x as usize]));
    img.save_with_format(dir.path().join("texels.tex"), image::ImageFormat::Tiff)
        .unwrap();
    let rib = "Format 16 8 1\nPixelFilter \"box\" 1 1\nProjection \"orthographic\"\nScreenWindow -2 2 -1 1\n\
               WorldBegin\nLightSource \"ambientlight\" 1\n\
               Surface \"paintedplastic\" \"Kd\" [1] \"texturename\" \"texels.tex\"\nTranslate 0 0 5\n\
               Disk 0 4 360\nWorldEnd\n";
    let (albedo, warnings) = painted_albedo(dir.path(), rib);
    assert!(warnings.is_empty(), "{warnings:?}");
    let mut checked = 0;
    for y in 0..8 {
        for x in 0..16 {
            let (wx, wy) = (-2.0 + 0.25 * (x as f32 + 0.5), 1.0 - 0.25 * (y as f32 + 0.5));
            let s = wy.atan2(wx).rem_euclid(std::f32::consts::TAU) / std::f32::consts::TAU;
            let t = 1.0 - wx.hypot(wy) / 4.0;
            let clear = |v: f32| (v.fract() - 0.5).abs() < 0.4;
            if !(clear(4.0 * s) && clear(2.0 * t)) {
                continue;
            }
            let want = TEXELS[(2.0 * t) as usize][(4.0 * s) as usize].map(|c| f32::from(c) / 255.0);
            let got = albedo[y * 16 + x];
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < 1e-5,
                    "pixel ({x}, {y}) at s {s}, t {t}: {got:?} instead of {want:?}"
                );
            }
            checked += 1;
        }
    }
    assert!(checked >= 60, "{checked} pixels checked");
}
