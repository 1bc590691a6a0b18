//! A textured quad seen head-on through an orthographic glTF camera: its `albedo` AOV equals the
//! texture's texels, decoded from sRGB with the IEC 61966-2-1 formula written here, in glTF's
//! orientation (texture coordinate (0, 0) is the image's top-left corner), and moved by
//! `KHR_texture_transform` exactly as the extension's matrix says. The files are written by the test:
//! a 4×2 PNG and a glTF with an external buffer.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use obscura_host::CameraDesc;
use obscura_plugins::builtin_registry;
use obscura_render::render::{RenderOptions, prepare};
use obscura_sdk::Format;
use obscura_shading::integrator::PathOptions;

/// The texels, sRGB codes, row by row from the top.
const TEXELS: [[[u8; 3]; 4]; 2] = [
    [[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]],
    [[10, 20, 30], [128, 128, 128], [200, 100, 50], [0, 0, 0]],
];

fn srgb(code: u8) -> f32 {
    let c = f32::from(code) / 255.0;
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Writes the PNG and a glTF quad (x ∈ [−2, 2], y ∈ [−1, 1], facing +Z, (0, 0) at the top-left
/// corner) seen by an orthographic camera at z = 5 with `ymag` 1, its base colour texture read
/// through `texture_info` (the JSON of the `baseColorTexture` object).
fn write_scene(dir: &Path, texture_info: &str) -> std::path::PathBuf {
    let img = image::RgbImage::from_fn(4, 2, |x, y| image::Rgb(TEXELS[y as usize][x as usize]));
    img.save(dir.join("texels.png")).unwrap();
    let positions: [[f32; 3]; 4] = [
        [-2.0, 1.0, 0.0],
        [2.0, 1.0, 0.0],
        [2.0, -1.0, 0.0],
        [-2.0, -1.0, 0.0],
    ];
    let uvs: [[f32; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let indices: [u16; 6] = [0, 3, 2, 0, 2, 1];
    let mut bin = Vec::new();
    positions
        .iter()
        .flatten()
        .for_each(|v| bin.extend_from_slice(&v.to_le_bytes()));
    uvs.iter()
        .flatten()
        .for_each(|v| bin.extend_from_slice(&v.to_le_bytes()));
    indices
        .iter()
        .for_each(|v| bin.extend_from_slice(&v.to_le_bytes()));
    std::fs::write(dir.join("quad.bin"), &bin).unwrap();
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_texture_transform"],
  "scene": 0,
  "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0}}, {{"camera": 0, "translation": [0, 0, 5]}}],
  "cameras": [{{"type": "orthographic", "orthographic": {{"xmag": 2, "ymag": 1, "znear": 0.1, "zfar": 100}}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "indices": 2, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {texture_info}}}}}],
  "textures": [{{"source": 0, "sampler": 0}}],
  "samplers": [{{"magFilter": 9728, "wrapS": 10497, "wrapT": 10497}}],
  "images": [{{"uri": "texels.png"}}],
  "buffers": [{{"uri": "quad.bin", "byteLength": {len}}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 32}},
    {{"buffer": 0, "byteOffset": 80, "byteLength": 12}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-2, -1, 0], "max": [2, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"}},
    {{"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}}
  ]
}}"#,
        len = bin.len()
    );
    let path = dir.join("quad.gltf");
    std::fs::write(&path, json).unwrap();
    path
}

/// The albedo of every pixel of a 16×8 render (4 pixels per texel across, 4 down).
fn render_albedo(path: &Path) -> Vec<[f32; 3]> {
    let scene = obscura_render::staging::load(path, CameraDesc::new(Format::new(16, 8))).expect("loads");
    assert!(scene.auto_camera.is_none(), "the file's camera is used");
    let opts = RenderOptions {
        samples_per_pixel: Some(4),
        path: PathOptions {
            max_depth: 0,
            ..PathOptions::default()
        },
        ..RenderOptions::default()
    };
    let prepared = prepare(&scene, &mut builtin_registry(), Path::new("."), &opts).expect("prepares");
    assert!(
        prepared.texture_warnings().is_empty(),
        "{:?}",
        prepared.texture_warnings()
    );
    let out = prepared.render(&opts, &|_, _| {}, &AtomicBool::new(false));
    (0..8)
        .flat_map(|y| (0..16).map(move |x| (x, y)))
        .map(|(x, y)| {
            let a = out.film.pixel(x, y).albedo;
            [a.r, a.g, a.b]
        })
        .collect()
}

/// Checks every pixel against the texel under `(s, t) → transform(s, t)`, where `(s, t)` are the
/// quad's texture coordinates at the pixel centre.
fn check(albedo: &[[f32; 3]], transform: impl Fn(f32, f32) -> (f32, f32), what: &str) {
    for y in 0..8 {
        for x in 0..16 {
            let (s, t) = ((x as f32 + 0.5) / 16.0, (y as f32 + 0.5) / 8.0);
            let (s, t) = transform(s, t);
            let col = ((s * 4.0).floor() as i64).rem_euclid(4) as usize;
            let row = ((t * 2.0).floor() as i64).rem_euclid(2) as usize;
            let want = TEXELS[row][col].map(srgb);
            let got = albedo[y * 16 + x];
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < 1e-5,
                    "{what}: pixel ({x}, {y}) channel {c}: {} instead of texel ({col}, {row}) = {}",
                    got[c],
                    want[c]
                );
            }
        }
    }
}

#[test]
fn a_head_on_quad_shows_its_texels_decoded_from_srgb_in_gltf_orientation() {
    let dir = tempfile::tempdir().unwrap();
    let albedo = render_albedo(&write_scene(dir.path(), r#"{"index": 0}"#));
    check(&albedo, |s, t| (s, t), "untransformed");
}

#[test]
fn khr_texture_transform_offsets_scales_and_rotates_as_the_extension_says() {
    let dir = tempfile::tempdir().unwrap();
    // Offset and scale: s' = 0.5 s + 0.5 (the right half of the image), t' = t.
    let info =
        r#"{"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0], "scale": [0.5, 1]}}}"#;
    check(
        &render_albedo(&write_scene(dir.path(), info)),
        |s, t| (0.5 * s + 0.5, t),
        "offset+scale",
    );
    // Rotation by 90°: the extension's matrix has columns (cos r, sin r) and (−sin r, cos r), so
    // s' = −t + 1 (with the offset) and t' = s.
    let info =
        r#"{"index": 0, "extensions": {"KHR_texture_transform": {"offset": [1, 0], "rotation": 1.5707964}}}"#;
    check(
        &render_albedo(&write_scene(dir.path(), info)),
        |s, t| (1.0 - t, s),
        "rotation",
    );
}

#[test]
fn a_rib_pxr_texture_referenced_by_a_bxdf_shows_its_texels_the_same_way() {
    let dir = tempfile::tempdir().unwrap();
    let img = image::RgbImage::from_fn(4, 2, |x, y| image::Rgb(TEXELS[y as usize][x as usize]));
    img.save(dir.path().join("texels.png")).unwrap();
    // RenderMan's camera looks down +Z with +Y up: the quad's top-left corner (−2, 1) has
    // st = (0, 1), which PxrTexture (invertT 1) reads at the image's top-left texel; filter 0 is
    // nearest, like the glTF sampler above.
    let rib = dir.path().join("quad.rib");
    std::fs::write(
        &rib,
        "Format 16 8 1\n\
         Projection \"orthographic\"\n\
         ScreenWindow -2 2 -1 1\n\
         WorldBegin\n\
         Pattern \"PxrTexture\" \"t\" \"string filename\" [\"texels.png\"] \"int linearize\" [1] \"int filter\" [0]\n\
         Bxdf \"PxrDiffuse\" \"d\" \"reference color diffuseColor\" [\"t:resultRGB\"]\n\
         Polygon \"P\" [-2 1 5  2 1 5  2 -1 5  -2 -1 5] \"st\" [0 1  1 1  1 0  0 0]\n\
         WorldEnd\n",
    )
    .unwrap();
    check(&render_albedo(&rib), |s, t| (s, t), "RIB PxrTexture");
}
