//! Small scene files for tests, written to a temporary folder: an OBJ cube with its material
//! library, and a glTF document of one triangle with cameras and nodes as a test sets them. The
//! readers' tests and the renderer's staging tests read the same files (the renderer through the
//! `fixtures` feature).

use std::path::PathBuf;

/// A unit cube in two materials (`red` and `shiny`, from `cube.mtl`), with normals.
pub const CUBE: &str = "\
# a unit cube, two materials
mtllib cube.mtl
o cube
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
vn 0 0 -1
vn 0 0 1
vn 0 -1 0
vn 0 1 0
vn -1 0 0
vn 1 0 0
usemtl red
f 1//1 4//1 3//1 2//1
f 5//2 6//2 7//2 8//2
f 1//3 2//3 6//3 5//3
usemtl shiny
f 4//4 8//4 7//4 3//4
f 1//5 5//5 8//5 4//5
f 2//6 3//6 7//6 6//6
";

/// The cube's material library, with an unused emissive `lamp`.
pub const MTL: &str = "\
newmtl red
Kd 0.8 0.1 0.1

newmtl shiny
Kd 0.2 0.2 0.2
Ks 0.5 0.5 0.5
Ns 98

newmtl lamp
Ke 4 4 3
";

/// Writes `text` to `dir/name` and returns the path.
pub fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// RFC 4648 base64 (with padding), for `data:` URIs.
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ALPHABET[((n >> (18 - 6 * i)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// The triangle's vertices.
pub const POSITIONS: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// 36 bytes of positions, 36 of normals (+Z), 6 of u16 indices and 2 of padding: 80 bytes.
pub fn buffer(indices: [u16; 3]) -> Vec<u8> {
    let mut b = Vec::new();
    for p in POSITIONS {
        for c in p {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    for _ in 0..3 {
        for c in [0.0f32, 0.0, 1.0] {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in indices {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b.extend_from_slice(&[0, 0]);
    b
}

/// A glTF document: one triangle mesh, three materials, nodes and cameras as given.
pub struct Fixture {
    /// The `nodes` array's entries.
    pub nodes: String,
    /// The scene's node list, `[0, 1]`.
    pub scene_nodes: String,
    /// The `cameras` array's entries.
    pub cameras: String,
    /// The primitive's mode (4: triangles).
    pub mode: u32,
    /// `"uri": "…",` or empty for a GLB's BIN chunk.
    pub buffer_uri: String,
    /// `"extensionsUsed": …,` and the like, or empty.
    pub extensions: String,
    /// The index accessor's component type (5123: u16).
    pub index_type: u32,
}

impl Fixture {
    /// The triangle with `indices`, its node rotated and moved, a perspective camera at z = 5.
    pub fn new(indices: [u16; 3]) -> Self {
        let (s, c) = (std::f32::consts::FRAC_1_SQRT_2, std::f32::consts::FRAC_1_SQRT_2);
        Fixture {
            nodes: format!(
                r#"{{"name":"tri","mesh":0,"translation":[1,2,3],"rotation":[0,{s},0,{c}]}},
                   {{"name":"cam","camera":0,"translation":[0,0,5]}}"#
            ),
            scene_nodes: "[0, 1]".into(),
            cameras: r#"{"type":"perspective","perspective":{"yfov":0.8,"znear":0.1}}"#.into(),
            mode: 4,
            buffer_uri: format!(
                r#""uri":"data:application/octet-stream;base64,{}","#,
                base64(&buffer(indices))
            ),
            extensions: String::new(),
            index_type: 5123,
        }
    }

    /// The document's JSON text.
    pub fn json(&self) -> String {
        format!(
            r#"{{
  "asset": {{"version": "2.0"}},
  {ext}
  "scene": 0,
  "scenes": [{{"nodes": {scene_nodes}}}],
  "nodes": [{nodes}],
  "cameras": [{cameras}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1}}, "indices": 2, "material": 0, "mode": {mode}}}]}}],
  "materials": [
{{"pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.4, 0.2, 1.0], "metallicFactor": 0.5, "roughnessFactor": 0.3}}}},
{{"pbrMetallicRoughness": {{"baseColorFactor": [0.1, 0.2, 0.3, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}}},
{{"emissiveFactor": [2.0, 1.0, 0.5]}}
  ],
  "buffers": [{{{uri} "byteLength": 80}}],
  "bufferViews": [
{{"buffer": 0, "byteOffset": 0, "byteLength": 72, "byteStride": 12, "target": 34962}},
{{"buffer": 0, "byteOffset": 72, "byteLength": 6, "target": 34963}}
  ],
  "accessors": [
{{"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}},
{{"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3"}},
{{"bufferView": 1, "byteOffset": 0, "componentType": {itype}, "count": 3, "type": "SCALAR"}}
  ]
}}"#,
            ext = self.extensions,
            scene_nodes = self.scene_nodes,
            nodes = self.nodes,
            cameras = self.cameras,
            mode = self.mode,
            uri = self.buffer_uri,
            itype = self.index_type,
        )
    }

    /// Writes the document to `dir/name` and returns the path.
    pub fn write(&self, dir: &tempfile::TempDir, name: &str) -> PathBuf {
        let path = dir.path().join(name);
        std::fs::write(&path, self.json()).unwrap();
        path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gltf_test_helper_base64_matches_rfc_4648() {
        assert_eq!(base64(b"f"), "Zg==");
        assert_eq!(base64(b"fo"), "Zm8=");
        assert_eq!(base64(b"foo"), "Zm9v");
        assert_eq!(base64(b"foobar"), "Zm9vYmFy");
    }
}
