//! Textures: glTF images (buffer views of a `.glb`, `data:` URIs, files beside the document) and
//! samplers as [`TextureDesc`]s, and a material's texture references as [`TextureSlot`]s with their
//! coordinate set and `KHR_texture_transform`.

use std::collections::HashMap;
use std::sync::Arc;

use base64::Engine;

use super::Loader;
use super::container::external_path;
use crate::texture::{ColorSpace, ImageSource, TextureDesc, TextureSlot, Wrap};

/// The scene textures made so far, by (glTF texture index, colour space): a texture read both as
/// colour and as data is two scene textures.
pub(super) type TextureCache = HashMap<(usize, bool), Option<u32>>;

impl Loader<'_> {
    /// The slot for a glTF texture reference, adding its texture to the scene on first use; `None`
    /// (with a warning) when its image cannot be located.
    pub(super) fn texture_slot(
        &mut self,
        cache: &mut TextureCache,
        texture: gltf::Texture<'_>,
        tex_coord: u32,
        transform: Option<gltf::texture::TextureTransform<'_>>,
        color_space: ColorSpace,
        used_by: String,
    ) -> Option<TextureSlot> {
        let key = (texture.index(), color_space == ColorSpace::Srgb);
        let index = match cache.get(&key) {
            Some(i) => *i,
            None => {
                let made = self.texture_desc(&texture, color_space, &used_by).map(|d| {
                    self.scene.textures.push(d);
                    (self.scene.textures.len() - 1) as u32
                });
                cache.insert(key, made);
                made
            }
        }?;
        let mut slot = TextureSlot::new(index);
        slot.uv_set = tex_coord;
        if let Some(t) = transform {
            slot.transform = texture_transform(t.offset(), t.rotation(), t.scale());
            if let Some(set) = t.tex_coord() {
                slot.uv_set = set;
            }
        }
        Some(slot)
    }

    /// The description of one glTF texture, or `None` with a warning when its image cannot be
    /// located.
    fn texture_desc(
        &mut self,
        texture: &gltf::Texture<'_>,
        color_space: ColorSpace,
        used_by: &str,
    ) -> Option<TextureDesc> {
        let image = texture.source();
        let name = format!("{}: image {}", self.file, image.index());
        let source = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let bytes = self
                    .buffers
                    .get(view.buffer().index())
                    .and_then(|b| b.get(view.offset()..view.offset().checked_add(view.length())?));
                match bytes {
                    Some(b) => ImageSource::Embedded {
                        name,
                        bytes: Arc::from(b),
                    },
                    None => {
                        self.warn(format!(
                            "{used_by}: image {} lies outside its buffer; the factor alone is used",
                            image.index()
                        ));
                        return None;
                    }
                }
            }
            gltf::image::Source::Uri { uri, .. } => match decode_data_uri(uri) {
                Some(Ok(bytes)) => ImageSource::Embedded {
                    name,
                    bytes: Arc::from(bytes),
                },
                Some(Err(e)) => {
                    self.warn(format!(
                        "{used_by}: image {}: cannot decode its data: URI ({e}); the factor alone is used",
                        image.index()
                    ));
                    return None;
                }
                None => match external_path(self.base, uri) {
                    Some(p) => ImageSource::File(p),
                    None => {
                        self.warn(format!(
                            "{used_by}: image {}: unsupported URI \"{uri}\"; the factor alone is used",
                            image.index()
                        ));
                        return None;
                    }
                },
            },
        };
        let sampler = texture.sampler();
        let wrap = |w: gltf::texture::WrappingMode| match w {
            gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        };
        Some(TextureDesc {
            source,
            color_space,
            wrap: (wrap(sampler.wrap_s()), wrap(sampler.wrap_t())),
            nearest: sampler.mag_filter() == Some(gltf::texture::MagFilter::Nearest),
            used_by: used_by.to_string(),
        })
    }
}

/// The bytes of a base64 `data:` URI; `None` when `uri` is not a `data:` URI.
fn decode_data_uri(uri: &str) -> Option<Result<Vec<u8>, String>> {
    let rest = uri.strip_prefix("data:")?;
    let Some((header, payload)) = rest.split_once(',') else {
        return Some(Err("no comma before the data".into()));
    };
    if !header.ends_with(";base64") {
        return Some(Err(format!("\"{header}\" is not base64-encoded")));
    }
    Some(
        base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map_err(|e| e.to_string()),
    )
}

/// `KHR_texture_transform` as the affine map `[a, b, c, d, e, f]` of [`TextureSlot::transform`]:
/// the extension's `T · R · S` with `R` its rotation matrix (columns `(cos r, sin r)` and
/// `(−sin r, cos r)`), so `s' = cos r·sx·s − sin r·sy·t + ox` and `t' = sin r·sx·s + cos r·sy·t + oy`.
#[must_use]
pub(crate) fn texture_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> [f32; 6] {
    let (s, c) = rotation.sin_cos();
    [
        c * scale[0],
        -s * scale[1],
        offset[0],
        s * scale[0],
        c * scale[1],
        offset[1],
    ]
}
