//! Materials: glTF's metallic–roughness model with its textures as [`SurfaceMaps`], and the
//! factor-only fallback as one of our materials.

use glam::Vec3;
use obscura_sdk::Rgb;

use super::Loader;
use super::textures::TextureCache;
use crate::texture::{AlphaMode, ColorSpace, SurfaceMaps, TextureSlot};
use crate::types::Material;

impl Loader<'_> {
    /// Appends every material of the document, in order, after the default one, each with its
    /// [`SurfaceMaps`] (textures, vertex colours, emission, alpha).
    pub(super) fn read_materials(&mut self, document: &gltf::Document) {
        let mut cache = TextureCache::new();
        for material in document.materials() {
            let index = self.scene.materials.len() as u32;
            self.scene.materials.push(convert_material(&material));
            let maps = self.surface_maps(&material, &mut cache);
            self.scene.material_maps.insert(index, maps);
        }
    }

    /// The slot of a `textureInfo` (with its coordinate set and transform), if there is one.
    fn info_slot(
        &mut self,
        cache: &mut TextureCache,
        info: Option<gltf::texture::Info<'_>>,
        color_space: ColorSpace,
        who: &str,
        name: &str,
    ) -> Option<TextureSlot> {
        let info = info?;
        self.texture_slot(
            cache,
            info.texture(),
            info.tex_coord(),
            info.texture_transform(),
            color_space,
            format!("{who} {name}"),
        )
    }

    /// The maps of one material.
    fn surface_maps(&mut self, m: &gltf::Material<'_>, cache: &mut TextureCache) -> SurfaceMaps {
        let pbr = m.pbr_metallic_roughness();
        let who = match (m.index(), m.name()) {
            (Some(i), Some(n)) => format!("{}: material {i} \"{n}\"", self.file),
            (Some(i), None) => format!("{}: material {i}", self.file),
            _ => format!("{}: the default material", self.file),
        };
        let finite = |x: f32, d: f32| if x.is_finite() { x } else { d };
        let unit = |x: f32| finite(x, 0.0).clamp(0.0, 1.0);
        let mut maps = SurfaceMaps {
            base_color_factor: pbr.base_color_factor().map(unit),
            metallic: unit(pbr.metallic_factor()),
            roughness: unit(pbr.roughness_factor()),
            ..SurfaceMaps::default()
        };
        let strength = finite(m.emissive_strength().unwrap_or(1.0), 1.0).max(0.0);
        let [er, eg, eb] = m.emissive_factor().map(|e| finite(e, 0.0).max(0.0) * strength);
        maps.emissive_factor = Rgb::new(er, eg, eb);
        maps.base_color = self.info_slot(
            cache,
            pbr.base_color_texture(),
            ColorSpace::Srgb,
            &who,
            "baseColorTexture",
        );
        maps.metallic_roughness = self.info_slot(
            cache,
            pbr.metallic_roughness_texture(),
            ColorSpace::Linear,
            &who,
            "metallicRoughnessTexture",
        );
        maps.emissive = self.info_slot(
            cache,
            m.emissive_texture(),
            ColorSpace::Srgb,
            &who,
            "emissiveTexture",
        );
        if let Some(n) = m.normal_texture() {
            maps.normal = self
                .texture_slot(
                    cache,
                    n.texture(),
                    n.tex_coord(),
                    None,
                    ColorSpace::Linear,
                    format!("{who} normalTexture"),
                )
                .map(|mut s| {
                    s.scale = finite(n.scale(), 1.0);
                    s
                });
        }
        // occlusionTexture is not read: it bakes the ambient occlusion a path tracer computes, and
        // glTF applies it to ambient light only (Blender's importer leaves it unconnected too).
        maps.alpha = match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask(finite(m.alpha_cutoff().unwrap_or(0.5), 0.5)),
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        };
        maps
    }
}

/// A glTF material's factors as one of our materials: the fallback when its maps cannot be used.
fn convert_material(m: &gltf::Material<'_>) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let unit = |x: f32| if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
    let [r, g, b, _] = pbr.base_color_factor();
    let base = Vec3::new(unit(r), unit(g), unit(b));
    let metallic = unit(pbr.metallic_factor());
    let roughness = unit(pbr.roughness_factor());
    let emissive = Vec3::from(m.emissive_factor()).map(|e| if e.is_finite() { e.max(0.0) } else { 0.0 });
    let rgb = |v: Vec3| Rgb::new(v.x, v.y, v.z);
    if emissive.max_element() > 0.0 {
        Material::Constant { color: rgb(emissive) }
    } else if roughness == 1.0 && metallic == 0.0 {
        Material::Diffuse { color: rgb(base) }
    } else {
        Material::Surface {
            diffuse: rgb(base * (1.0 - metallic)),
            specular: rgb(Vec3::splat(0.04).lerp(base, metallic)),
            roughness,
        }
    }
}
