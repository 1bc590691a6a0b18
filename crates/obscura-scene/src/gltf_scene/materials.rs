//! Materials: `pbrMetallicRoughness` factors as diffuse, constant or surface materials.

use glam::Vec3;
use obscura_sdk::Rgb;

use super::Loader;
use crate::types::Material;

impl Loader<'_> {
    /// Appends every material of the document, in order, after the default one.
    pub(super) fn read_materials(&mut self, document: &gltf::Document) {
        let mut textured = None;
        for material in document.materials() {
            let (converted, uses_texture) = convert_material(&material);
            if uses_texture && textured.is_none() {
                textured = Some(material.index().unwrap_or(0));
            }
            self.scene.materials.push(converted);
        }
        if let Some(i) = textured {
            self.warn(format!(
                "textures are ignored (material {i} is the first to use one); only the factors are read"
            ));
        }
    }
}

/// A glTF material as one of ours, and whether it uses a texture (which is ignored).
fn convert_material(m: &gltf::Material<'_>) -> (Material, bool) {
    let pbr = m.pbr_metallic_roughness();
    let unit = |x: f32| if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
    let [r, g, b, _] = pbr.base_color_factor();
    let base = Vec3::new(unit(r), unit(g), unit(b));
    let metallic = unit(pbr.metallic_factor());
    let roughness = unit(pbr.roughness_factor());
    let emissive = Vec3::from(m.emissive_factor()).map(|e| if e.is_finite() { e.max(0.0) } else { 0.0 });
    let uses_texture = pbr.base_color_texture().is_some()
        || pbr.metallic_roughness_texture().is_some()
        || m.normal_texture().is_some()
        || m.occlusion_texture().is_some()
        || m.emissive_texture().is_some();
    let rgb = |v: Vec3| Rgb::new(v.x, v.y, v.z);
    let material = if emissive.max_element() > 0.0 {
        Material::Constant { color: rgb(emissive) }
    } else if roughness == 1.0 && metallic == 0.0 {
        Material::Diffuse { color: rgb(base) }
    } else {
        Material::Surface {
            diffuse: rgb(base * (1.0 - metallic)),
            specular: rgb(Vec3::splat(0.04).lerp(base, metallic)),
            roughness,
        }
    };
    (material, uses_texture)
}
