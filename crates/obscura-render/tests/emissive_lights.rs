//! Emissive surfaces read from files become lights the path tracer samples: an OBJ `Ke` quad and a
//! glTF `emissiveFactor` quad each give their two triangles to light sampling; the floor beside them
//! gives none. The files are written by the test.

use std::path::Path;

use obscura_host::CameraDesc;
use obscura_plugins::builtin_registry;
use obscura_render::render::{RenderOptions, prepare};
use obscura_sdk::Format;

fn emissive_triangles(path: &Path) -> usize {
    let scene = obscura_render::staging::load(path, CameraDesc::new(Format::new(8, 8))).expect("loads");
    let opts = RenderOptions::default();
    let prepared = prepare(&scene, &mut builtin_registry(), Path::new("."), &opts).expect("prepares");
    prepared.emissive_triangles()
}

#[test]
fn obj_ke_and_gltf_emissive_quads_are_sampled_lights() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("lamp.mtl"),
        "newmtl lamp\nKd 0 0 0\nKe 4 4 4\nnewmtl floor\nKd 0.5 0.5 0.5\n",
    )
    .unwrap();
    let obj = dir.path().join("room.obj");
    std::fs::write(
        &obj,
        "mtllib lamp.mtl\n\
         v -1 1 -1\nv 1 1 -1\nv 1 1 1\nv -1 1 1\n\
         v -5 0 -5\nv 5 0 -5\nv 5 0 5\nv -5 0 5\n\
         o lamp\nusemtl lamp\nf 1 2 3 4\n\
         o floor\nusemtl floor\nf 5 6 7 8\n",
    )
    .unwrap();
    assert_eq!(emissive_triangles(&obj), 2);

    let gltf = dir.path().join("lamp.gltf");
    // Two triangles of a unit quad: positions (4 × vec3) then indices (6 × u16), base64.
    let mut bytes = Vec::new();
    for p in [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ] {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    let data = base64_encode(&bytes);
    std::fs::write(
        &gltf,
        format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
"nodes": [{{"mesh": 0}}],
"meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
"materials": [{{"emissiveFactor": [1.0, 0.5, 0.25]}}],
"buffers": [{{"byteLength": {len}, "uri": "data:application/octet-stream;base64,{data}"}}],
"bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}],
"accessors": [
 {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
 {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}]}}"#,
            len = bytes.len()
        ),
    )
    .unwrap();
    assert_eq!(emissive_triangles(&gltf), 2);
}

/// Standard base64 with padding (RFC 4648), written here so the test needs no crate.
fn base64_encode(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ABC[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}
