//! The file's bytes: the GLB header and JSON chunk, the buffers (GLB chunk, `data:` URI or a file beside
//! the document) and what the `gltf` crate assumes without checking.

use std::path::{Path, PathBuf};

use super::GltfError;

/// Checks what the `gltf` crate assumes without checking: its validation indexes the accessor a
/// `POSITION` attribute names, and `Camera::projection` unwraps the object its `type` names.
/// glTF 2.0's `asset.version` rule: a major version other than 2 is another format (glTF 1.0's JSON
/// differs throughout), and `minVersion` above 2.0 asks for features this reader does not have.
fn check_version(path: &Path, asset: &gltf::json::Asset) -> Result<(), GltfError> {
    let invalid = |what: String| GltfError::Invalid {
        path: path.to_path_buf(),
        what,
    };
    let major = |v: &str| v.split('.').next().and_then(|m| m.trim().parse::<u32>().ok());
    match major(&asset.version) {
        Some(2) => {}
        Some(_) => {
            return Err(invalid(format!(
                "asset.version is \"{}\": expected a glTF 2.x file (glTF 1.0 and others are not read; convert with a glTF 2.0 exporter)",
                asset.version
            )));
        }
        None => {
            return Err(invalid(format!(
                "asset.version is \"{}\": expected \"2.0\"",
                asset.version
            )));
        }
    }
    if let Some(min) = &asset.min_version {
        let minor = min.split('.').nth(1).and_then(|m| m.trim().parse::<u32>().ok());
        if major(min) != Some(2) || minor != Some(0) {
            return Err(invalid(format!(
                "asset.minVersion is \"{min}\": this reader reads glTF 2.0"
            )));
        }
    }
    Ok(())
}

pub(super) fn check_before_validation(path: &Path, root: &gltf::json::Root) -> Result<(), GltfError> {
    use gltf::json::camera::Type;
    use gltf::json::validation::Checked;
    check_version(path, &root.asset)?;
    for (i, camera) in root.cameras.iter().enumerate() {
        let missing = match camera.type_ {
            Checked::Valid(Type::Perspective) => camera.perspective.is_none().then_some("perspective"),
            Checked::Valid(Type::Orthographic) => camera.orthographic.is_none().then_some("orthographic"),
            Checked::Invalid => None,
        };
        if let Some(kind) = missing {
            return Err(GltfError::Invalid {
                path: path.to_path_buf(),
                what: format!("camera {i} has type \"{kind}\" but no \"{kind}\" object"),
            });
        }
    }
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for (semantic, accessor) in &prim.attributes {
                if accessor.value() >= root.accessors.len() {
                    let name = match semantic {
                        Checked::Valid(s) => s.to_string(),
                        Checked::Invalid => "an attribute".into(),
                    };
                    return Err(GltfError::Primitive {
                        path: path.to_path_buf(),
                        mesh: m,
                        primitive: p,
                        what: format!(
                            "{name} refers to accessor {}, but the file has {}",
                            accessor.value(),
                            root.accessors.len()
                        ),
                    });
                }
            }
        }
    }
    Ok(())
}

/// Extensions a file may require that this reader honours; the `gltf` crate validates only those its
/// enabled features know, so the others are taken off the required list once checked here.
const SUPPORTED_REQUIRED: [&str; 3] = [
    "KHR_texture_transform",
    "KHR_materials_emissive_strength",
    "KHR_lights_punctual",
];

/// What an unsupported required extension is, for the error message.
fn extension_meaning(name: &str) -> &'static str {
    match name {
        "KHR_draco_mesh_compression" => "Draco-compressed geometry",
        "EXT_meshopt_compression" | "KHR_meshopt_compression" => "meshoptimizer-compressed buffers",
        "KHR_mesh_quantization" => "quantized vertex attributes",
        "KHR_materials_pbrSpecularGlossiness" => "specular–glossiness materials",
        "KHR_texture_basisu" => "Basis Universal (KTX2) textures",
        "EXT_texture_webp" => "WebP textures",
        "EXT_texture_avif" => "AVIF textures",
        _ => "an extension",
    }
}

/// Refuses a file that requires an extension this reader does not honour, naming it (a file
/// requiring Draco otherwise fails deep inside validation with "Missing data"), and removes the
/// honoured ones from the required list so validation accepts them.
pub(super) fn check_required_extensions(path: &Path, root: &mut gltf::json::Root) -> Result<(), GltfError> {
    if let Some(name) = root
        .extensions_required
        .iter()
        .find(|e| !SUPPORTED_REQUIRED.contains(&e.as_str()))
    {
        return Err(GltfError::Invalid {
            path: path.to_path_buf(),
            what: format!(
                "the file requires extension {name} ({}), which Obscura does not read; export or convert it without it (for example with Blender's glTF exporter, compression off)",
                extension_meaning(name)
            ),
        });
    }
    root.extensions_required.clear();
    Ok(())
}

/// Rejects GLB headers whose declared length would underflow the `gltf` crate's arithmetic.
pub(super) fn check_glb_header(path: &Path, bytes: &[u8]) -> Result<(), GltfError> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let bad = |what: String| GltfError::Binary {
        path: path.to_path_buf(),
        what,
    };
    let length =
        read_u32(bytes, 8).ok_or_else(|| bad(format!("header is {} bytes, expected 12", bytes.len())))?;
    if length < 12 {
        return Err(bad(format!(
            "declared length {length} is shorter than the 12-byte header"
        )));
    }
    Ok(())
}

/// The little-endian `u32` at byte `at`, when the bytes reach that far.
fn read_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let b: [u8; 4] = bytes.get(at..at.checked_add(4)?)?.try_into().ok()?;
    Some(u32::from_le_bytes(b))
}

/// The JSON text of a `.gltf`, or the JSON chunk of a `.glb`.
pub(super) fn json_chunk(bytes: &[u8]) -> Option<&[u8]> {
    if !bytes.starts_with(b"glTF") {
        return Some(bytes);
    }
    let length = usize::try_from(read_u32(bytes, 12)?).ok()?;
    bytes.get(20..20usize.checked_add(length)?)
}

/// Loads every buffer: the GLB's BIN chunk, a base64 `data:` URI, or a file beside the document.
pub(super) fn load_buffers(
    path: &Path,
    document: &gltf::Document,
    base: &Path,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, GltfError> {
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let bad = |what: String| GltfError::Buffer {
            path: path.to_path_buf(),
            buffer: buffer.index(),
            what,
        };
        let mut data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .take()
                .ok_or_else(|| bad("refers to the GLB binary chunk, which is missing".into()))?,
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                gltf::buffer::Data::from_source(buffer.source(), None)
                    .map_err(|e| bad(format!("cannot decode its data: URI: {e}")))?
                    .0
            }
            gltf::buffer::Source::Uri(uri) => {
                let file = external_path(base, uri)
                    .ok_or_else(|| bad(format!("unsupported or malformed URI \"{uri}\"")))?;
                std::fs::read(&file).map_err(|e| bad(format!("cannot read {}: {e}", file.display())))?
            }
        };
        if data.len() < buffer.length() {
            return Err(bad(format!(
                "declares {} bytes but only {} were found",
                buffer.length(),
                data.len()
            )));
        }
        data.truncate(buffer.length());
        out.push(data);
    }
    Ok(out)
}

/// The file a non-`data:` buffer URI names: `file:` URIs as they are, relative references from the
/// document's folder; percent-escapes are decoded. `None` for other schemes and undecodable escapes.
pub(super) fn external_path(base: &Path, uri: &str) -> Option<PathBuf> {
    if let Some(rest) = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")) {
        return Some(PathBuf::from(percent_decode(rest)?));
    }
    if uri.contains(':') {
        return None;
    }
    Some(base.join(percent_decode(uri)?))
}

/// Decodes `%XX` escapes; a `%` not followed by two hex digits stays as it is. `None` when the result
/// is not UTF-8.
fn percent_decode(s: &str) -> Option<String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |k: usize| bytes.get(k).and_then(|&b| (b as char).to_digit(16));
        match (bytes[i], hex(i + 1), hex(i + 2)) {
            (b'%', Some(hi), Some(lo)) => {
                out.push((hi * 16 + lo) as u8);
                i += 3;
            }
            (b, _, _) => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}
