//! Materials whose parameters come from textures: what a surface is at one hit.
//!
//! [`Texturing`] holds the loaded textures, the per-material [`SurfaceMaps`] and the per-instance
//! vertex attributes (texture coordinates, colours). [`Texturing::surface`] turns a hit into a
//! [`SurfacePoint`]: the material to build the BSDF from, the shading normal (normal-mapped), the
//! emitted radiance, the base colour for the `albedo` AOV, the first texture coordinates for the `uv`
//! AOV, and the opacity. Every lookup is filtered by the ray cone's footprint
//! ([`crate::texture::footprint`]), or by none at all when [`TextureLookup::Point`] asks so (the tests'
//! aliased reference).
//!
//! The metallic–roughness model is glTF's, mapped onto PxrSurface as the factor-only glTF reader
//! does: `diffuse = base·(1 − m)`, `specular = lerp(0.04, base, m)`, roughness `r` (see
//! [`SurfaceMaps`]).

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use glam::{Vec2, Vec3, Vec3A, Vec4};
use obscura_scene::Material;
use obscura_scene::texture::{AlphaMode, ImageSource, SurfaceMaps, TextureDesc, TextureSlot};
use obscura_sdk::Rgb;

use crate::texture::footprint::{UvMap, cone_footprint};
use crate::texture::{Footprint, Texture, image};
use obscura_geometry::ray::Hit;

/// How texture lookups are filtered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TextureLookup {
    /// By the ray cone's footprint (EWA over the mip pyramid): the renderer's behaviour.
    #[default]
    Footprint,
    /// The nearest level-0 texel, unfiltered: aliases; for comparisons.
    Point,
    /// Each texture's mean (its last mip level), everywhere: the same colours on average without
    /// the cost of filtering; for measuring that cost.
    Mean,
}

/// Per-vertex attributes of one mesh for texturing, with its triangles.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SurfaceAttributes {
    /// Triangles (the same as the diced mesh's).
    pub triangles: Vec<[u32; 3]>,
    /// Texture coordinate sets, one coordinate per vertex.
    pub uvs: Vec<Vec<Vec2>>,
    /// Linear RGBA vertex colours.
    pub colors: Option<Vec<Vec4>>,
}

impl SurfaceAttributes {
    /// The attributes of a scene mesh, or `None` when it has neither coordinates nor colours.
    #[must_use]
    pub fn of_mesh(mesh: &obscura_scene::Mesh) -> Option<Self> {
        let n = mesh.positions.len();
        let uvs: Vec<Vec<Vec2>> = mesh.uvs.iter().filter(|s| s.len() == n).cloned().collect();
        let colors = mesh
            .colors
            .as_ref()
            .filter(|c| c.len() == n)
            .map(|c| c.iter().map(|&v| Vec4::from(v)).collect());
        (!uvs.is_empty() || colors.is_some()).then(|| SurfaceAttributes {
            triangles: mesh.triangles.clone(),
            uvs,
            colors,
        })
    }

    /// The attributes of a diced primitive from its vertices' RenderMan texture coordinates
    /// `(s, t)` ([`obscura_geometry::dice::dice_with_st`]): one coordinate set `(s, 1 − t)`, the convention of
    /// every reader's texture coordinates (a RIB polygon's `"st"` is read the same way). `None`
    /// unless there is one coordinate per vertex.
    #[must_use]
    pub fn of_diced(mesh: &obscura_geometry::ray::TriangleMesh, st: &[Vec2]) -> Option<Self> {
        (st.len() == mesh.positions.len()).then(|| SurfaceAttributes {
            triangles: mesh.triangles.clone(),
            uvs: vec![st.iter().map(|p| Vec2::new(p.x, 1.0 - p.y)).collect()],
            colors: None,
        })
    }

    /// Texture coordinates of set `set` at barycentrics `(b1, b2)` of triangle `tri` with the three
    /// vertex values.
    fn uv(&self, set: usize, tri: [u32; 3], b: (f32, f32)) -> Option<(Vec2, [Vec2; 3])> {
        let uvs = self.uvs.get(set).or_else(|| self.uvs.first())?;
        let v = tri.map(|i| uvs[i as usize]);
        Some((v[0] * (1.0 - b.0 - b.1) + v[1] * b.0 + v[2] * b.1, v))
    }
}

/// What a surface is at one hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// The material to build the BSDF from.
    pub material: Material,
    /// Shading normal (world space; normal-mapped where the material says so).
    pub normal: Vec3A,
    /// Radiance emitted by the surface in addition to the BSDF's own.
    pub emission: Vec3A,
    /// The base colour (linear), for the `albedo` AOV.
    pub albedo: Vec3A,
    /// The first texture coordinate set, for the `uv` AOV.
    pub uv: Vec2,
    /// Probability that the surface is there (1 opaque; alpha MASK gives 0 or 1, BLEND the alpha).
    pub opacity: f32,
}

/// The base colour of an untextured material: its diffuse or emitted colour.
#[must_use]
pub fn material_albedo(m: &Material) -> Vec3A {
    match *m {
        Material::Diffuse { color } | Material::Constant { color } => super::color(color),
        Material::Surface { diffuse, .. } => super::color(diffuse),
    }
}

/// Textures, surface maps and vertex attributes of a prepared scene.
#[derive(Debug, Clone, Default)]
pub struct Texturing {
    textures: Vec<Option<Arc<Texture>>>,
    maps: BTreeMap<u32, SurfaceMaps>,
    /// Per instance, its mesh's attributes (shared between instances of one mesh).
    attributes: Vec<Option<Arc<SurfaceAttributes>>>,
    /// How lookups are filtered.
    pub lookup: TextureLookup,
}

/// A texture of the scene could not be used (the render goes on with the factor alone).
#[derive(Debug, Clone, PartialEq)]
pub struct TextureWarning(pub String);

impl Texturing {
    /// Loads every texture of `descs` (in parallel) and keeps `maps` and the per-instance
    /// `attributes`. A texture that cannot be read or decoded becomes a warning naming its user and
    /// file, and its slots read as 1 (the factor alone). Relative paths are taken from `base_dir`.
    #[must_use]
    pub fn new(
        descs: &[TextureDesc],
        maps: BTreeMap<u32, SurfaceMaps>,
        attributes: Vec<Option<Arc<SurfaceAttributes>>>,
        base_dir: &Path,
    ) -> (Texturing, Vec<TextureWarning>) {
        use rayon::prelude::*;
        let loaded: Vec<Result<Texture, String>> = descs
            .par_iter()
            .map(|d| {
                let source = match &d.source {
                    ImageSource::File(p) if p.is_relative() => ImageSource::File(base_dir.join(p)),
                    s => s.clone(),
                };
                image::decode(&source, d.color_space)
                    .map(|(w, h, texels)| Texture::from_texels(w, h, texels, d.wrap, d.nearest))
                    .map_err(|e| {
                        format!(
                            "{}: cannot use texture {}: {e}; the factor alone is used",
                            d.used_by,
                            source.describe()
                        )
                    })
            })
            .collect();
        let mut warnings = Vec::new();
        let textures = loaded
            .into_iter()
            .map(|r| match r {
                Ok(t) => Some(Arc::new(t)),
                Err(w) => {
                    warnings.push(TextureWarning(w));
                    None
                }
            })
            .collect();
        (
            Texturing {
                textures,
                maps,
                attributes,
                lookup: TextureLookup::Footprint,
            },
            warnings,
        )
    }

    /// Bytes held by every loaded texture's pyramid.
    #[must_use]
    pub fn memory_bytes(&self) -> usize {
        self.textures.iter().flatten().map(|t| t.memory_bytes()).sum()
    }

    /// True when some material may let rays through (alpha MASK or BLEND).
    #[must_use]
    pub fn has_cutouts(&self) -> bool {
        self.maps.values().any(|m| m.alpha != AlphaMode::Opaque)
    }

    /// True when material `index` takes its parameters from maps (its own entry is the fallback).
    #[must_use]
    pub fn has_maps(&self, index: u32) -> bool {
        self.maps.contains_key(&index)
    }

    /// True when material `index` has maps with a non-zero emissive factor and no alpha cut-out or
    /// blending: an emitter light sampling may aim at.
    #[must_use]
    pub fn opaque_emitter(&self, index: u32) -> bool {
        self.maps.get(&index).is_some_and(|m| {
            let e = m.emissive_factor;
            m.alpha == AlphaMode::Opaque && e.r.max(e.g).max(e.b) > 0.0
        })
    }

    /// Slot `slot` looked up at `hit`'s texture coordinates without a footprint (level 0, bilinear or
    /// a sampler's NEAREST): what a light sample or a cut-out test reads, both at points a camera
    /// never saw through a cone.
    fn point_texel(&self, hit: &Hit, slot: Option<TextureSlot>) -> Option<Vec4> {
        let slot = slot?;
        let texture = self.textures.get(slot.texture as usize)?.as_ref()?;
        let attrs = self.attributes.get(hit.instance as usize)?.as_ref()?;
        let tri = *attrs.triangles.get(hit.primitive as usize)?;
        let (uv, _) = attrs.uv(slot.uv_set as usize, tri, hit.uv)?;
        let c = Footprint::point(uv).transformed(&slot.transform).center;
        Some(match self.lookup {
            TextureLookup::Footprint => texture.filter(&Footprint::point(c)),
            TextureLookup::Point => texture.nearest(c),
            TextureLookup::Mean => texture.texel(usize::MAX, 0, 0),
        })
    }

    /// The linear RGBA vertex colour at `hit`, when material maps `maps` use vertex colours.
    fn vertex_color(&self, hit: &Hit, maps: &SurfaceMaps) -> Option<Vec4> {
        if !maps.vertex_colors {
            return None;
        }
        let attrs = self.attributes.get(hit.instance as usize)?.as_ref()?;
        let t = attrs.triangles.get(hit.primitive as usize)?;
        let c = attrs.colors.as_ref()?;
        let (b1, b2) = hit.uv;
        Some(c[t[0] as usize] * (1.0 - b1 - b2) + c[t[1] as usize] * b1 + c[t[2] as usize] * b2)
    }

    /// The radiance a surface emits at `hit`, for a point sampled on an emitter (light sampling): the
    /// emissive factor times the emissive map, or an untextured `PxrConstant`'s colour — what
    /// [`Texturing::surface`] and the BSDF give a ray without a footprint. A light sample is taken at
    /// every path vertex, so it reads the emissive map alone, not the base colour,
    /// metallic–roughness and normal maps a full surface needs.
    #[must_use]
    pub fn emission(&self, hit: &Hit, material: Material, index: Option<u32>) -> Vec3A {
        let Some(maps) = index.and_then(|i| self.maps.get(&i)) else {
            return match material {
                Material::Constant { color } => super::color(color),
                _ => Vec3A::ZERO,
            };
        };
        let emission = super::color(maps.emissive_factor);
        if emission == Vec3A::ZERO {
            return emission;
        }
        match self.point_texel(hit, maps.emissive) {
            Some(t) => emission * Vec3A::new(t.x, t.y, t.z),
            None => emission,
        }
    }

    /// True when material `index` emits nothing anywhere on triangle `primitive` of instance
    /// `instance`: it has an emissive map, and the map is black over the triangle's texture
    /// coordinates ([`Texture::is_black_over`] of their box after the slot's transform). Light
    /// sampling leaves such triangles out (a helmet's emissive map is black but for its lamps).
    #[must_use]
    pub fn emission_is_black(&self, index: u32, instance: u32, primitive: u32) -> bool {
        let black = || -> Option<bool> {
            let slot = self.maps.get(&index)?.emissive?;
            let texture = self.textures.get(slot.texture as usize)?.as_ref()?;
            let attrs = self.attributes.get(instance as usize)?.as_ref()?;
            let tri = *attrs.triangles.get(primitive as usize)?;
            let (_, corners) = attrs.uv(slot.uv_set as usize, tri, (0.0, 0.0))?;
            let corners = corners.map(|c| Footprint::point(c).transformed(&slot.transform).center);
            let lo = corners[0].min(corners[1]).min(corners[2]);
            let hi = corners[0].max(corners[1]).max(corners[2]);
            Some(texture.is_black_over(lo, hi))
        };
        black().unwrap_or(false)
    }

    /// The probability that the surface is there at `hit` (material index `index`): 1 for opaque
    /// materials without reading anything, else the base colour's alpha (factor, map, vertex colour)
    /// times the opacity map, through the material's alpha mode — [`SurfacePoint::opacity`] for a
    /// ray without a footprint. Every hit of a scene with cut-outs is tested, shadow rays' too.
    #[must_use]
    pub fn opacity(&self, hit: &Hit, index: Option<u32>) -> f32 {
        let Some(maps) = index.and_then(|i| self.maps.get(&i)) else {
            return 1.0;
        };
        if maps.alpha == AlphaMode::Opaque {
            return 1.0;
        }
        let mut alpha = maps.base_color_factor[3];
        if let Some(t) = self.point_texel(hit, maps.base_color) {
            alpha *= t.w;
        }
        if let Some(c) = self.vertex_color(hit, maps) {
            alpha *= c.w;
        }
        if let Some(t) = self.point_texel(hit, maps.opacity) {
            alpha *= t.x;
        }
        alpha_coverage(maps.alpha, alpha)
    }

    /// The surface at `hit` for a material `material` (index `index`), seen along unit `direction`
    /// with shading normal `n_s` (facing the viewer) by a cone of radius `cone_radius` (world units)
    /// at the hit. `primary` is true for the camera ray's hit: its lookups are filtered over the
    /// footprint's ellipse (EWA); later hits, whose cones have widened, over a circle of the same
    /// area on the nearest mip level ([`Texture::bilinear_at`]), as renderers do for indirect rays.
    #[must_use]
    #[allow(clippy::too_many_arguments)]
    pub fn surface(
        &self,
        hit: &Hit,
        material: Material,
        index: Option<u32>,
        direction: Vec3A,
        n_s: Vec3A,
        cone_radius: f32,
        primary: bool,
    ) -> SurfacePoint {
        let attrs = self
            .attributes
            .get(hit.instance as usize)
            .and_then(Option::as_ref);
        let tri = attrs.and_then(|a| a.triangles.get(hit.primitive as usize).copied());
        let uv0 = attrs
            .zip(tri)
            .and_then(|(a, t)| a.uv(0, t, hit.uv))
            .map_or(Vec2::ZERO, |(uv, _)| uv);
        let maps = index.and_then(|i| self.maps.get(&i));
        let Some(maps) = maps else {
            return SurfacePoint {
                material,
                normal: n_s,
                emission: Vec3A::ZERO,
                albedo: material_albedo(&material),
                uv: uv0,
                opacity: 1.0,
            };
        };
        // The footprint on a coordinate set, before any slot's transform.
        let footprint_on = |set: u32| -> Option<Footprint> {
            let (a, t) = (attrs?, tri?);
            let (uv, corners) = a.uv(set as usize, t, hit.uv)?;
            Some(
                match (self.lookup, UvMap::new(hit.edges[0], hit.edges[1], corners)) {
                    (TextureLookup::Footprint, Some(map)) => {
                        cone_footprint(uv, cone_radius, direction, hit.geometric_normal, &map)
                    }
                    _ => Footprint::point(uv),
                },
            )
        };
        // Most materials read every map through set 0: its footprint is computed once.
        let set0 = footprint_on(0);
        let lookup = |slot: Option<TextureSlot>| -> Option<Vec4> {
            let slot = slot?;
            let texture = self.textures.get(slot.texture as usize)?.as_ref()?;
            let footprint = if slot.uv_set == 0 {
                set0?
            } else {
                footprint_on(slot.uv_set)?
            };
            let footprint = footprint.transformed(&slot.transform);
            Some(match self.lookup {
                TextureLookup::Footprint if primary => texture.filter(&footprint),
                TextureLookup::Footprint => {
                    let r = (footprint.a.length() * footprint.b.length()).sqrt();
                    texture.bilinear_at(footprint.center, r)
                }
                TextureLookup::Point => texture.nearest(footprint.center),
                TextureLookup::Mean => texture.texel(usize::MAX, 0, 0),
            })
        };
        let mut base = Vec4::from(maps.base_color_factor);
        if let Some(t) = lookup(maps.base_color) {
            base *= t;
        }
        if let Some(c) = self.vertex_color(hit, maps) {
            base *= c;
        }
        let (mut metallic, mut roughness) = (maps.metallic, maps.roughness);
        if let Some(t) = lookup(maps.metallic_roughness) {
            metallic *= t.z;
            roughness *= t.y;
        }
        let unit = |x: f32| if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
        let (metallic, roughness) = (unit(metallic), unit(roughness));
        let rgb = Vec3::new(base.x, base.y, base.z);
        let diffuse = rgb * (1.0 - metallic);
        let to_rgb = |v: Vec3| Rgb::new(v.x, v.y, v.z);
        let specular = match maps.specular {
            Some(ks) => {
                let mut ks = Vec3::new(ks.r, ks.g, ks.b);
                if let Some(t) = lookup(maps.specular_map) {
                    ks *= Vec3::new(t.x, t.y, t.z);
                }
                ks
            }
            None => Vec3::splat(0.04).lerp(rgb, metallic),
        };
        let material = if maps.diffuse_only {
            Material::Diffuse {
                color: to_rgb(diffuse),
            }
        } else {
            Material::Surface {
                diffuse: to_rgb(diffuse),
                specular: to_rgb(specular),
                roughness,
            }
        };
        let mut emission = super::color(maps.emissive_factor);
        if emission != Vec3A::ZERO
            && let Some(t) = lookup(maps.emissive)
        {
            emission *= Vec3A::new(t.x, t.y, t.z);
        }
        let normal = match (maps.normal, attrs, tri) {
            (Some(slot), Some(a), Some(t)) => lookup(Some(slot))
                .and_then(|texel| {
                    let (_, corners) = a.uv(slot.uv_set as usize, t, hit.uv)?;
                    let map = UvMap::new(hit.edges[0], hit.edges[1], corners)?;
                    normal_mapped(n_s, map, texel, slot.scale)
                })
                .filter(|n| n.dot(-direction) > 0.0)
                .unwrap_or(n_s),
            _ => n_s,
        };
        if let Some(t) = lookup(maps.opacity) {
            base.w *= t.x;
        }
        SurfacePoint {
            material,
            normal,
            emission,
            albedo: Vec3A::from(rgb).max(Vec3A::ZERO),
            uv: uv0,
            opacity: alpha_coverage(maps.alpha, base.w),
        }
    }
}

/// The probability that a surface of alpha `alpha` is there under `mode`: 1 when opaque, 0 or 1
/// against a MASK's cutoff, the alpha itself (in `[0, 1]`) when blended.
fn alpha_coverage(mode: AlphaMode, alpha: f32) -> f32 {
    match mode {
        AlphaMode::Opaque => 1.0,
        AlphaMode::Mask(cutoff) => {
            if alpha >= cutoff {
                1.0
            } else {
                0.0
            }
        }
        AlphaMode::Blend if alpha.is_finite() => alpha.clamp(0.0, 1.0),
        AlphaMode::Blend => 0.0,
    }
}

/// The shading normal `n` perturbed by a tangent-space normal-map texel (`[0, 1]` → `[−1, 1]`, x and
/// y scaled by `scale`): tangent `T` along `∂p/∂u`, bitangent `B` toward **decreasing** `v` (up in
/// the image, since glTF's `v` runs down the image and a normal map's +Y is up), both made
/// orthogonal to `n`.
fn normal_mapped(n: Vec3A, map: UvMap, texel: Vec4, scale: f32) -> Option<Vec3A> {
    let (dpdu, dpdv) = map.dp_duv()?;
    let t = (dpdu - n * n.dot(dpdu)).try_normalize()?;
    let mut b = n.cross(t);
    if b.dot(dpdv) > 0.0 {
        b = -b;
    }
    let x = (2.0 * texel.x - 1.0) * scale;
    let y = (2.0 * texel.y - 1.0) * scale;
    let z = 2.0 * texel.z - 1.0;
    (t * x + b * y + n * z).try_normalize()
}
