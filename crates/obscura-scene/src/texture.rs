//! Textures in the scene description: which image, how it wraps and filters, and how a material's
//! parameters read it ([`SurfaceMaps`]). Readers fill these; the renderer loads the images and filters
//! them by each camera ray's footprint.

use std::path::PathBuf;
use std::sync::Arc;

use obscura_sdk::Rgb;

/// Where an image's bytes are.
#[derive(Debug, Clone, PartialEq)]
pub enum ImageSource {
    /// A file (PNG, JPEG, OpenEXR, Radiance HDR or TIFF, told by its content).
    File(PathBuf),
    /// Bytes embedded in the scene file (a `.glb` buffer view or a `data:` URI).
    Embedded {
        /// How messages name it (`scene.glb: image 3`).
        name: String,
        /// The encoded image.
        bytes: Arc<[u8]>,
    },
}

impl ImageSource {
    /// How messages name the image: the file's path or the embedded image's name.
    #[must_use]
    pub fn describe(&self) -> String {
        match self {
            ImageSource::File(p) => p.display().to_string(),
            ImageSource::Embedded { name, .. } => name.clone(),
        }
    }
}

/// How an image's 8- and 16-bit values map to linear light.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColorSpace {
    /// The sRGB transfer function (IEC 61966-2-1): colour maps in glTF, `map_Kd` in MTL.
    Srgb,
    /// Values are linear already: data maps (normal, metallic–roughness, opacity).
    Linear,
}

/// What a texture coordinate outside `[0, 1]` reads (glTF's sampler wrap modes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    /// The image tiles (`REPEAT`, the glTF default, `periodic` in RenderMan).
    Repeat,
    /// The edge texel extends (`CLAMP_TO_EDGE`, `clamp`).
    Clamp,
    /// Every other tile is mirrored (`MIRRORED_REPEAT`, `mirror`).
    Mirror,
}

/// One texture: an image and how it is sampled.
#[derive(Debug, Clone, PartialEq)]
pub struct TextureDesc {
    /// The image.
    pub source: ImageSource,
    /// How 8/16-bit values decode; float formats (EXR, HDR) are linear whatever this says.
    pub color_space: ColorSpace,
    /// Wrap along s (u) and t (v).
    pub wrap: (Wrap, Wrap),
    /// True for a sampler whose magnification filter is `NEAREST`: texels are not interpolated.
    pub nearest: bool,
    /// Who uses it, for messages (`scene.gltf: material 2 "Helmet" baseColorTexture`).
    pub used_by: String,
}

/// A material parameter read from a texture: which one, which texture coordinate set, and the affine
/// map applied to the coordinates first (`KHR_texture_transform`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureSlot {
    /// Index into [`crate::Scene::textures`].
    pub texture: u32,
    /// Which texture coordinate set of the mesh (`TEXCOORD_n`).
    pub uv_set: u32,
    /// `[a, b, c, d, e, f]`: `s' = a·s + b·t + c`, `t' = d·s + e·t + f` (identity `[1, 0, 0, 0, 1, 0]`).
    pub transform: [f32; 6],
    /// `normalTexture.scale`; 1 elsewhere.
    pub scale: f32,
}

impl TextureSlot {
    /// The identity coordinate transform.
    pub const IDENTITY: [f32; 6] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

    /// Texture `texture` read with coordinate set 0, untransformed, scale 1.
    #[must_use]
    pub fn new(texture: u32) -> Self {
        TextureSlot {
            texture,
            uv_set: 0,
            transform: Self::IDENTITY,
            scale: 1.0,
        }
    }
}

/// How a surface's alpha is used (glTF `alphaMode`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AlphaMode {
    /// Alpha is ignored.
    Opaque,
    /// Coverage: the surface is there where alpha ≥ the cutoff, absent elsewhere.
    Mask(f32),
    /// Transparency: a ray passes through with probability `1 − alpha`.
    Blend,
}

/// A metallic–roughness surface whose parameters may come from textures (glTF 2.0's model, which MTL
/// and `PxrTexture` map onto). Colours are linear; a texture's value multiplies its factor.
///
/// At a hit: `base = base_color_factor · texture · vertex colour`; metallic `m` and roughness `r` are
/// the factors times the blue and green channels of `metallic_roughness`; the BSDF is PxrSurface with
/// `diffuse = base·(1 − m)`, `specular = lerp(0.04, base, m)` and roughness `r`; the emitted radiance is
/// `emissive_factor · texture`; `normal` perturbs the shading normal in the tangent frame of the
/// texture coordinates. MTL
/// materials give a specular colour (`Ks` times `map_Ks`) that replaces the F0 above, and an
/// opacity map (`map_d`) that multiplies alpha.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceMaps {
    /// Linear RGBA factor of the base colour.
    pub base_color_factor: [f32; 4],
    /// Base colour (sRGB RGBA texture).
    pub base_color: Option<TextureSlot>,
    /// Metallic factor.
    pub metallic: f32,
    /// Roughness factor (perceptual; α = roughness²).
    pub roughness: f32,
    /// Metallic in blue, roughness in green.
    pub metallic_roughness: Option<TextureSlot>,
    /// Tangent-space normal map (`scale` scales x and y).
    pub normal: Option<TextureSlot>,
    /// Emitted radiance factor (times `KHR_materials_emissive_strength`).
    pub emissive_factor: Rgb,
    /// Emission texture (sRGB).
    pub emissive: Option<TextureSlot>,
    /// Alpha use.
    pub alpha: AlphaMode,
    /// True when the mesh's vertex colours (`COLOR_0`) multiply the base colour.
    pub vertex_colors: bool,
    /// True when the surface is a pure Lambertian (no specular lobe): MTL without `Ks`.
    pub diffuse_only: bool,
    /// A specular colour used as F0 instead of `lerp(0.04, base, metallic)` (MTL's `Ks`).
    pub specular: Option<Rgb>,
    /// A texture multiplying [`SurfaceMaps::specular`] (MTL's `map_Ks`, sRGB).
    pub specular_map: Option<TextureSlot>,
    /// A texture whose red channel multiplies the alpha (MTL's `map_d`).
    pub opacity: Option<TextureSlot>,
}

impl Default for SurfaceMaps {
    fn default() -> Self {
        SurfaceMaps {
            base_color_factor: [1.0; 4],
            base_color: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness: None,
            normal: None,
            emissive_factor: Rgb::BLACK,
            emissive: None,
            alpha: AlphaMode::Opaque,
            vertex_colors: true,
            diffuse_only: false,
            specular: None,
            specular_map: None,
            opacity: None,
        }
    }
}

impl SurfaceMaps {
    /// Every texture slot in use, with its glTF name.
    pub fn slots(&self) -> impl Iterator<Item = (&'static str, TextureSlot)> + '_ {
        [
            ("baseColorTexture", self.base_color),
            ("metallicRoughnessTexture", self.metallic_roughness),
            ("normalTexture", self.normal),
            ("emissiveTexture", self.emissive),
            ("map_Ks", self.specular_map),
            ("map_d", self.opacity),
        ]
        .into_iter()
        .filter_map(|(n, s)| s.map(|s| (n, s)))
    }
}
