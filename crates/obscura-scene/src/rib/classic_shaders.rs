//! The RenderMan Interface's standard shaders, mapped to the renderer's physically based materials
//! and lights: `Color`, `Opacity`, `Surface` (`constant`, `matte`, `metal`, `shinymetal`, `plastic`,
//! `paintedplastic`) and `LightSource` (`ambientlight`, `distantlight`, `pointlight`, `spotlight`).
//!
//! # Lights
//!
//! A classic light of `intensity` `I` and `lightcolor` `C` lights a `matte` surface (`Kd·Cs`) to
//! `Kd·Cs·C·I·cos θ` (its `diffuse()`); a Lambertian surface of albedo `ρ` under a physical light of
//! irradiance `E` has radiance `ρ·E·cos θ / π`. So `distantlight`, `pointlight` and `spotlight`
//! become physical lights of strength `π·I·C` (irradiance `π·I·C/d²` for the point and spot lights,
//! the spec's `1/(L·L)` falloff) with `Kd·Cs` as the albedo, and the classic brightness is kept
//! exactly. `from` and `to` are taken in the light's "shader" space, the CTM at the request:
//!
//! | light | physical light |
//! |---|---|
//! | `ambientlight` | [`Light::Ambient`]: uniform radiance `I·C` reaching every surface unshadowed, not seen by any ray; a classic surface reflects `Ka·Cs·Σ I·C` (the `Ka·ambient()` term), any other its diffuse albedo times `Σ I·C` |
//! | `distantlight` | [`Light::Distant`] travelling along `to − from`, `angleExtent` 0 |
//! | `pointlight` | [`Light::Point`] at `from` |
//! | `spotlight` | [`Light::Spot`] at `from` along `to − from`: `coneangle`, `conedeltaangle` (radians, as in RIB), `beamdistribution`; the spec's attenuation `cosᵇ α · smoothstep(cos(cone), cos(cone − delta), cos α) / d²` |
//!
//! The spec's `distantlight`, `pointlight` and `spotlight` cast no shadows (their shaders call no
//! `shadow()`; a classic renderer shadows only through shadow-map lights), so their lights have
//! `enable_shadows` off — a scene inside a star-field sphere stays lit — unless BMRT's
//! `Attribute "light" "shadows" "on"` stands when they are declared.
//!
//! # Surfaces
//!
//! The classic `specular()` lobe is Blinn's `(N·H)ⁿ` with `n = 8/roughness` (Aqsis, BMRT and PRMan;
//! the spec's example writes `1/roughness`). It becomes a GGX lobe of `α = √(2/(n + 2))` (the
//! Blinn–Beckmann equivalence; `roughness_ggx = √α`) whose reflectance at normal incidence `F0` is
//! the classic lobe's own directional albedo at normal incidence under the lights above,
//! `F0 = Ks·specularcolor·a(n)`, `a(n) = 8/(n + 2)·(1 − 2^−(n+2)/2)`, so a highlight carries the
//! energy the classic shader gives it (about 0.1·Ks at the default roughness 0.1).
//!
//! | surface | material |
//! |---|---|
//! | `constant` | `PxrConstant` emitting `Cs` (seen without any light) |
//! | `matte` (`Kd` 1) | `PxrDiffuse`, albedo `Kd·Cs` |
//! | `plastic`, `paintedplastic` (`Kd` .5, `Ks` .5, `roughness` .1, `specularcolor` 1) | `PxrSurface`: diffuse `Kd·Cs`, `F0 = Ks·specularcolor·a(n)` |
//! | `metal`, `shinymetal` (`Ks` 1, `roughness` .1) | `PxrSurface`: no diffuse, `F0 = Ks·Cs·a(n)` |
//! | any other | `PxrDiffuse` with albedo `Cs`, and a warning naming the shader |
//!
//! Albedos are clamped to `[0, 1]`. `Kr` and `texturename` of `shinymetal` (a reflection map) are
//! left out. A `Color` with neither a `Surface` nor a `Bxdf` shades as `matte`.
//!
//! # Local illumination
//!
//! The standard shaders compute `Cs·(Ka·ambient() + Kd·diffuse(N)) + specularcolor·Ks·specular(N, V,
//! roughness)` (without the terms a shader lacks): the light that reaches them straight from their
//! lights, plus an ambient term standing in for everything else. So a surface of theirs shades that
//! way here too ([`LocalShading`], `Scene::local_shading`): its lights are sampled as for any
//! surface (shadowed as each light says), the ambient term `Ka·Cs·Σ I·C` is added without a shadow
//! ray (`paintedplastic`: `Ka·Cs·texture`), and the path ends there, so no light arrives by way of
//! other surfaces. The look is the classic one (a planet inside a matte star-field sphere is lit by
//! its sun, not fogged by light bouncing around the inside of the sphere), and a classic scene costs
//! one camera ray and one shadow ray per light sample.
//! `Opacity` and a primitive's `Os` below 1 make the material blended: a ray passes through with
//! probability `1 − o`, `o` the mean of the channels (a coloured opacity is warned about), so what is
//! behind shows through in the RI's proportion `o·C + (1 − o)·B`; the surface keeps its look
//! (untextured surface maps of the same colours, `constant` as emission over black).
//!
//! # `paintedplastic`'s texture
//!
//! `texturename` multiplies the diffuse colour: the spec's shader replaces `Cs` by
//! `Cs·texture(texturename, s, t)` in the diffuse term and leaves the highlight alone, so the
//! material becomes [`SurfaceMaps`] with `Kd·Cs` as the base colour factor, the texture as the base
//! colour and the plastic's `F0` as its specular colour. The file is looked up as RenderMan does: an
//! absolute name as it is, a relative one in each directory of `Option "searchpath" "texture"`
//! (relative directories from the RIB file's), then beside the RIB file. Any format the renderer
//! reads is read by its content: TIFF, PNG, OpenEXR, JPEG, Radiance HDR, and RenderMan's `.tex`/`.tx`
//! when they are TIFF inside (a `.tex` in Pixar's own format fails to decode, and the renderer's
//! warning names the `Surface` line and the file). Values are read as they are stored (linear, as a
//! classic `texture()` call reads them), and the texture repeats. `(s, t)` follows the RI: `s`
//! across the image, `t = 0` on its top row; the primitives' coordinates reach the renderer as
//! `(s, 1 − t)` (the convention of every reader's texture coordinates), so the slot flips `t` back.
//! A file that is not there is a warning naming the `Surface` line and the file, and the surface
//! renders as plastic.

use std::collections::{HashMap, HashSet};
use std::f32::consts::PI;
use std::path::PathBuf;

use glam::{Mat4, Vec3};
use obscura_sdk::{ParamList, Rgb};

use super::lex::Value;
use super::patch::Basis;
use super::request::{Req, get_color, get_float, get_floats, get_string};
use super::searchpath::Kind;
use super::{Reader, RibError};
use crate::texture::{AlphaMode, ColorSpace, ImageSource, SurfaceMaps, TextureDesc, TextureSlot, Wrap};
use crate::types::{AmbientReflectance, Light, LocalShading, Material, PointEmitter};

/// The classic shading attributes (saved and restored by attribute blocks).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct ClassicAttributes {
    /// `Color`, when given.
    pub(super) color: Option<Rgb>,
    /// `Opacity`.
    pub(super) opacity: Rgb,
    /// The current `Surface`, when one was given after the last `Bxdf`.
    pub(super) surface: Option<ClassicSurface>,
    /// `Basis`.
    pub(super) basis: Basis,
    /// `Attribute "light" "shadows" "on"` (BMRT's): classic lights declared under it cast shadows.
    pub(super) light_shadows: bool,
}

impl Default for ClassicAttributes {
    fn default() -> Self {
        ClassicAttributes {
            color: None,
            opacity: Rgb::WHITE,
            surface: None,
            basis: Basis::default(),
            light_shadows: false,
        }
    }
}

/// What the reader remembers across the file about classic shading.
#[derive(Debug, Default)]
pub(super) struct ClassicState {
    /// The warning that classic shaders were mapped was given.
    pub(super) mapped_warned: bool,
    /// Messages given once per scene (keyed by a short name).
    pub(super) warned: HashSet<String>,
    /// Materials already in the scene, by their debug text (and texture), for reuse.
    pub(super) materials: HashMap<String, u32>,
    /// `paintedplastic` textures already in the scene, by path.
    pub(super) textures: HashMap<PathBuf, u32>,
    /// The colour the next primitive's own `"Cs"` gives it (consumed by that primitive).
    pub(super) primitive_color: Option<Rgb>,
    /// The opacity the next primitive's own `"Os"` gives it (consumed by that primitive).
    pub(super) primitive_opacity: Option<Rgb>,
    /// The next primitive (a polygon mesh) carries its `"Cs"` per vertex, as vertex colours
    /// (consumed by that primitive).
    pub(super) vertex_colors: bool,
}

/// A classic surface shader's parameters, as the material mapping needs them.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum ClassicSurface {
    /// `constant`.
    Constant,
    /// `matte`.
    Matte {
        /// `Ka`.
        ka: f32,
        /// `Kd`.
        kd: f32,
    },
    /// `plastic` and `paintedplastic`.
    Plastic {
        /// `paintedplastic`'s `texturename`, when the file was found: its index in the scene's
        /// textures.
        texture: Option<u32>,
        /// `Ka`.
        ka: f32,
        /// `Kd`.
        kd: f32,
        /// `Ks`.
        ks: f32,
        /// `roughness`.
        roughness: f32,
        /// `specularcolor`.
        specular_color: Rgb,
    },
    /// `metal` and `shinymetal`.
    Metal {
        /// `Ka`.
        ka: f32,
        /// `Ks`.
        ks: f32,
        /// `roughness`.
        roughness: f32,
    },
    /// Any other shader: a diffuse surface of colour `Cs` (its `Ka`, when it has one, kept).
    Other {
        /// `Ka`.
        ka: f32,
    },
}

/// The Blinn exponent of the classic `specular()` at `roughness`: `8/roughness` (roughness floored
/// at 10⁻³).
#[must_use]
pub(crate) fn classic_exponent(roughness: f32) -> f32 {
    8.0 / roughness.max(1e-3)
}

/// The GGX roughness (`√α`) equivalent to a Blinn exponent `n`: `α = √(2/(n + 2))`.
#[must_use]
pub(crate) fn ggx_roughness(exponent: f32) -> f32 {
    (2.0 / (exponent.max(0.0) + 2.0)).sqrt().sqrt()
}

/// The directional albedo at normal incidence of the classic lobe `Ks·(N·H)ⁿ` per unit `Ks`, lit by
/// lights of strength `π·I` (see the module documentation): `8/(n + 2)·(1 − 2^−(n+2)/2)`.
#[must_use]
pub(crate) fn classic_specular_albedo(exponent: f32) -> f32 {
    let m = exponent.max(0.0) + 2.0;
    8.0 / m * (1.0 - (-0.5 * m).exp2())
}

/// `c` scaled by `k`, each channel clamped to `[0, 1]` (NaN → 0).
fn scaled(c: Rgb, k: f32) -> Rgb {
    let f = |x: f32| {
        let y = x * k;
        if y.is_nan() { 0.0 } else { y.clamp(0.0, 1.0) }
    };
    Rgb::new(f(c.r), f(c.g), f(c.b))
}

/// How much of a surface of opacity `os` is there: the mean of its channels in `[0, 1]` (NaN → 1,
/// opaque). The renderer passes a ray through with probability `1 − coverage`, so a surface of
/// opacity `o` in front of a background `B` shows `o·C + (1 − o)·B` on average: the RI's `Oi`
/// compositing, with a grey opacity.
fn coverage(os: Rgb) -> f32 {
    let mean = (os.r + os.g + os.b) / 3.0;
    if mean.is_nan() { 1.0 } else { mean.clamp(0.0, 1.0) }
}

/// `material` as surface maps without textures (the form transparency takes): the same diffuse
/// colour, specular colour and roughness, or, for `constant`, its colour as emission over a black
/// surface (which, reflecting nothing, ends the path as `constant` does).
fn untextured(material: Material) -> SurfaceMaps {
    let base = |c: Rgb| [c.r, c.g, c.b, 1.0];
    let maps = SurfaceMaps {
        metallic: 0.0,
        vertex_colors: false,
        ..SurfaceMaps::default()
    };
    match material {
        Material::Diffuse { color } => SurfaceMaps {
            base_color_factor: base(color),
            diffuse_only: true,
            ..maps
        },
        Material::Constant { color } => SurfaceMaps {
            base_color_factor: base(Rgb::BLACK),
            diffuse_only: true,
            emissive_factor: color,
            ..maps
        },
        Material::Surface {
            diffuse,
            specular,
            roughness,
        } => SurfaceMaps {
            base_color_factor: base(diffuse),
            roughness,
            specular: Some(specular),
            ..maps
        },
    }
}

/// `paintedplastic`: the plastic's diffuse colour `Kd·Cs` times texture `texture` at `(s, t)`, its
/// highlight unchanged.
fn painted(texture: u32, diffuse: Rgb, specular: Rgb, roughness: f32) -> SurfaceMaps {
    let mut slot = TextureSlot::new(texture);
    // The primitives' coordinates are (s, 1 − t); the RI's texture() reads (s, t).
    slot.transform = [1.0, 0.0, 0.0, 0.0, -1.0, 1.0];
    SurfaceMaps {
        base_color_factor: [diffuse.r, diffuse.g, diffuse.b, 1.0],
        base_color: Some(slot),
        metallic: 0.0,
        roughness,
        specular: Some(specular),
        vertex_colors: false,
        ..SurfaceMaps::default()
    }
}

impl ClassicSurface {
    /// How the surface shades with colour `cs` beyond its material: by local illumination, with the
    /// ambient term `Ka·Cs` (`paintedplastic`'s `Ka·Cs·texture` through the diffuse albedo); `None`
    /// for `constant`, which only emits.
    pub(super) fn local(&self, cs: Rgb) -> Option<LocalShading> {
        let fixed = |ka: f32| {
            let c = |x: f32| {
                let y = ka * x;
                if y.is_finite() { y.max(0.0) } else { 0.0 }
            };
            AmbientReflectance::Color(Rgb::new(c(cs.r), c(cs.g), c(cs.b)))
        };
        let ambient = match *self {
            ClassicSurface::Constant => return None,
            ClassicSurface::Plastic {
                texture: Some(_),
                ka,
                kd,
                ..
            } if kd > 0.0 && (ka / kd).is_finite() => AmbientReflectance::DiffuseScaled((ka / kd).max(0.0)),
            ClassicSurface::Matte { ka, .. }
            | ClassicSurface::Plastic { ka, .. }
            | ClassicSurface::Metal { ka, .. }
            | ClassicSurface::Other { ka } => fixed(ka),
        };
        Some(LocalShading { ambient })
    }

    /// `Kd`, for the surfaces that have a diffuse term.
    fn kd(&self) -> Option<f32> {
        match *self {
            ClassicSurface::Matte { kd, .. } | ClassicSurface::Plastic { kd, .. } => Some(kd),
            ClassicSurface::Other { .. } => Some(1.0),
            ClassicSurface::Constant | ClassicSurface::Metal { .. } => None,
        }
    }

    /// `paintedplastic`'s texture, when it has one.
    fn texture(&self) -> Option<u32> {
        match self {
            ClassicSurface::Plastic { texture, .. } => *texture,
            _ => None,
        }
    }

    /// The physically based material for this surface with colour `cs`.
    pub(super) fn material(&self, cs: Rgb) -> Material {
        match *self {
            ClassicSurface::Constant => Material::Constant {
                color: scaled(cs, 1.0),
            },
            ClassicSurface::Matte { kd, .. } => Material::Diffuse {
                color: scaled(cs, kd),
            },
            ClassicSurface::Other { .. } => Material::Diffuse {
                color: scaled(cs, 1.0),
            },
            ClassicSurface::Plastic {
                kd,
                ks,
                roughness,
                specular_color,
                ..
            } => {
                let n = classic_exponent(roughness);
                Material::Surface {
                    diffuse: scaled(cs, kd),
                    specular: scaled(specular_color, ks * classic_specular_albedo(n)),
                    roughness: ggx_roughness(n),
                }
            }
            ClassicSurface::Metal { ks, roughness, .. } => {
                let n = classic_exponent(roughness);
                Material::Surface {
                    diffuse: Rgb::BLACK,
                    specular: scaled(cs, ks * classic_specular_albedo(n)),
                    roughness: ggx_roughness(n),
                }
            }
        }
    }
}

/// The parameters the classic surfaces and lights know, for names written bare.
const SURFACE_PARAMETERS: [&str; 8] = [
    "float Ka",
    "float Kd",
    "float Ks",
    "float Kr",
    "float roughness",
    "color specularcolor",
    "string texturename",
    "string mapname",
];

/// The parameters of the classic lights, for names written bare.
const LIGHT_PARAMETERS: [&str; 7] = [
    "float intensity",
    "color lightcolor",
    "point from",
    "point to",
    "float coneangle",
    "float conedeltaangle",
    "float beamdistribution",
];

/// The classic light shaders.
pub(super) const CLASSIC_LIGHTS: [&str; 4] = ["ambientlight", "distantlight", "pointlight", "spotlight"];

impl Reader {
    /// Gives, once per scene, the warning that classic shaders were mapped.
    fn classic_mapped(&mut self, r: &Req<'_>) {
        if !self.classic_state.mapped_warned {
            self.classic_state.mapped_warned = true;
            self.warn(
                r,
                "classic RenderMan shaders (Surface, LightSource) are mapped to the renderer's physically based materials and lights; the look is close to, not the same as, the shaders' own"
                    .into(),
            );
        }
    }

    /// Warns once per scene under `key`.
    pub(super) fn warn_once(&mut self, r: &Req<'_>, key: &str, message: String) {
        if self.classic_state.warned.insert(key.to_string()) {
            self.warn(r, message);
        }
    }

    /// `Color [r g b]` (or three numbers).
    pub(super) fn color(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [red, green, blue] = r.only_numbers::<3>("a colour: 3 numbers, e.g. Color [1 0.5 0]")?;
        self.classic.color = Some(Rgb::new(red, green, blue));
        Ok(())
    }

    /// `Opacity [r g b]`: the surfaces that follow are seen through (see [`coverage`]).
    pub(super) fn opacity(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [red, green, blue] = r.only_numbers::<3>("an opacity: 3 numbers, e.g. Opacity [1 1 1]")?;
        self.classic.opacity = Rgb::new(red, green, blue);
        self.warn_coloured_opacity(r, self.classic.opacity);
        Ok(())
    }

    /// `"Cs"` one per vertex of a polygon mesh of `vertices` points, when it varies: the mesh's vertex
    /// colours (linear RGBA, alpha 1), and the next primitive's material is made to use them. `None`
    /// (the colour then averaged by [`Reader::primitive_color`]) for any other count or one colour.
    pub(super) fn vertex_colors(&mut self, list: &ParamList, vertices: usize) -> Option<Vec<[f32; 4]>> {
        // `constant` and `metal` take Cs into their emission and highlight, which vertex colours
        // (multiplying the diffuse colour) cannot reach: they average it.
        if matches!(
            self.classic.surface,
            Some(ClassicSurface::Constant | ClassicSurface::Metal { .. })
        ) {
            return None;
        }
        let cs = get_floats(list, "Cs").filter(|c| c.len() == 3 * vertices && vertices > 0)?;
        if cs.chunks_exact(3).all(|c| c == &cs[..3]) {
            return None;
        }
        self.classic_state.vertex_colors = true;
        Some(cs.chunks_exact(3).map(|c| [c[0], c[1], c[2], 1.0]).collect())
    }

    /// Warns, once per scene, that an opacity whose channels differ is drawn grey.
    fn warn_coloured_opacity(&mut self, r: &Req<'_>, opacity: Rgb) {
        if opacity.r != opacity.g || opacity.g != opacity.b {
            self.warn_once(
                r,
                "coloured opacity",
                format!(
                    "{}: a coloured opacity is drawn as the mean of its channels ({:.3}): the renderer's transparency is grey",
                    r.name,
                    coverage(opacity)
                ),
            );
        }
    }

    /// `Surface "name" params`: a classic surface shader becomes the current material.
    pub(super) fn surface(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name), rest @ ..] = r.args else {
            return Err(r.err("Surface expects a shader name (a string) then parameters"));
        };
        let list = self.params(r, rest, &SURFACE_PARAMETERS, true)?;
        let f = |key: &str, default: f32| get_float(&list, key).unwrap_or(default);
        let surface = match name.as_str() {
            "constant" => ClassicSurface::Constant,
            "matte" => ClassicSurface::Matte {
                ka: f("Ka", 1.0),
                kd: f("Kd", 1.0),
            },
            "plastic" | "paintedplastic" => ClassicSurface::Plastic {
                texture: None,
                ka: f("Ka", 1.0),
                kd: f("Kd", 0.5),
                ks: f("Ks", 0.5),
                roughness: f("roughness", 0.1),
                specular_color: get_color(&list, "specularcolor").unwrap_or(Rgb::WHITE),
            },
            "metal" | "shinymetal" => ClassicSurface::Metal {
                ka: f("Ka", 1.0),
                ks: f("Ks", 1.0),
                roughness: f("roughness", 0.1),
            },
            other => {
                self.warn(
                    r,
                    format!(
                        "Surface \"{other}\" is not a standard shader (constant, matte, metal, shinymetal, plastic, paintedplastic); drawn as matte in its Color"
                    ),
                );
                ClassicSurface::Other { ka: f("Ka", 1.0) }
            }
        };
        let mut surface = surface;
        if let ClassicSurface::Plastic { texture, .. } = &mut surface
            && name == "paintedplastic"
            && let Some(t) = get_string(&list, "texturename").filter(|t| !t.is_empty())
        {
            *texture = self.painted_texture(r, t);
        }
        if !matches!(surface, ClassicSurface::Other { .. }) {
            self.classic_mapped(r);
        }
        self.classic.surface = Some(surface);
        Ok(())
    }

    /// `paintedplastic`'s texture `name`: its index in the scene's textures, added when new; `None`,
    /// with a warning naming the file and where it was looked for, when no such file exists.
    fn painted_texture(&mut self, r: &Req<'_>, name: &str) -> Option<u32> {
        let Some(path) = self.find_file(Kind::Texture, r, name) else {
            let places = self.search_description(Kind::Texture, r);
            self.warn(
                r,
                format!(
                    "Surface \"paintedplastic\": texture \"{name}\" not found ({places}); drawn as plastic"
                ),
            );
            return None;
        };
        if let Some(&k) = self.classic_state.textures.get(&path) {
            return Some(k);
        }
        let k = self.scene.textures.len() as u32;
        self.scene.textures.push(TextureDesc {
            source: ImageSource::File(path.clone()),
            color_space: ColorSpace::Linear,
            wrap: (Wrap::Repeat, Wrap::Repeat),
            nearest: false,
            used_by: format!("{}: Surface \"paintedplastic\" \"texturename\"", r.at()),
        });
        self.classic_state.textures.insert(path, k);
        Some(k)
    }

    /// `Attribute "light" "shadows" "on"|"off"`: whether the classic lights declared from here on
    /// (in this attribute block) cast shadows.
    pub(super) fn light_attribute(&mut self, r: &Req<'_>, rest: &[Value]) -> Result<(), RibError> {
        let list = self.params(r, rest, &["string shadows"], false)?;
        match get_string(&list, "shadows") {
            Some("on") => self.classic.light_shadows = true,
            Some("off") => self.classic.light_shadows = false,
            Some(other) => {
                return Err(r.err(format!(
                    "Attribute \"light\" \"shadows\": expected \"on\" or \"off\", got \"{other}\""
                )));
            }
            None => {}
        }
        Ok(())
    }

    /// `Displacement`, `Atmosphere`, `Interior`, `Exterior`, `Imager`, `Deformation`: warned about by
    /// the shader's name and left out.
    pub(super) fn other_shader(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let shader = match r.args.first() {
            Some(Value::Str(s)) => s.as_str(),
            _ => "",
        };
        let key = format!("{} {shader}", r.name);
        self.warn_once(
            r,
            &key,
            format!("{} shader \"{shader}\" is not supported, left out", r.name),
        );
        Ok(())
    }

    /// `Illuminate`: every light lights every surface here, so switching lights is warned about.
    pub(super) fn illuminate(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        self.warn_once(
            r,
            "illuminate",
            "Illuminate is not supported: every light lights every surface".into(),
        );
        Ok(())
    }

    /// Records a primitive's own `"Cs"` and `"Os"` for the next object: one value, or several averaged
    /// with a warning (the renderer shades one colour and one opacity per primitive), unless
    /// [`Reader::vertex_colors`] took `"Cs"` as vertex colours.
    pub(super) fn primitive_color(&mut self, r: &Req<'_>, list: &ParamList) {
        if let Some(cs) = get_floats(list, "Cs").filter(|c| c.len() >= 3 && !self.classic_state.vertex_colors)
        {
            let n = (cs.len() / 3) as f32;
            let sum = cs
                .chunks_exact(3)
                .fold([0.0f32; 3], |a, c| [a[0] + c[0], a[1] + c[1], a[2] + c[2]]);
            let first = &cs[..3];
            if cs.chunks_exact(3).any(|c| c != first) {
                self.warn_once(
                    r,
                    "varying Cs",
                    format!("{}: \"Cs\" varies over the primitive; drawn in its average colour (one colour per primitive)", r.name),
                );
            }
            self.classic_state.primitive_color = Some(Rgb::new(sum[0] / n, sum[1] / n, sum[2] / n));
        }
        if let Some(os) = get_floats(list, "Os").filter(|o| o.len() >= 3) {
            let n = (os.len() / 3) as f32;
            let sum = os
                .chunks_exact(3)
                .fold([0.0f32; 3], |a, c| [a[0] + c[0], a[1] + c[1], a[2] + c[2]]);
            if os.chunks_exact(3).any(|c| c != &os[..3]) {
                self.warn_once(
                    r,
                    "varying Os",
                    format!("{}: \"Os\" varies over the primitive; drawn with its average opacity (one opacity per primitive)", r.name),
                );
            }
            let os = Rgb::new(sum[0] / n, sum[1] / n, sum[2] / n);
            self.warn_coloured_opacity(r, os);
            self.classic_state.primitive_opacity = Some(os);
        }
    }

    /// The material of the next primitive: the classic surface in the current colour when one is
    /// set, else the current `Bxdf` (or, with a `Color` and neither, a diffuse surface of that colour).
    pub(super) fn current_material(&mut self) -> u32 {
        let own = self.classic_state.primitive_color.take();
        let vertex = std::mem::take(&mut self.classic_state.vertex_colors);
        // Vertex colours replace the colour: the material is white, and they multiply it.
        let color = if vertex {
            Some(Rgb::WHITE)
        } else {
            own.or(self.classic.color)
        };
        let cs = color.unwrap_or(Rgb::WHITE);
        let opacity = self.classic_state.primitive_opacity.take();
        let alpha = coverage(opacity.unwrap_or(self.classic.opacity));
        // A `Color`, an `Opacity` or a `"Cs"` without any `Surface` (nor `Bxdf`) shades as `matte`.
        let matte = ClassicSurface::Matte { ka: 1.0, kd: 1.0 };
        let surface = match &self.classic.surface {
            Some(s) => s,
            None if self.material == 0 && (color.is_some() || alpha < 1.0) => &matte,
            None => return self.material,
        };
        let (material, texture) = (surface.material(cs), surface.texture());
        let local = surface.local(cs).map(|mut l| {
            // Ka·Cs with Cs per vertex: Ka/Kd times the diffuse albedo, vertex colour included.
            if let (true, Some(kd)) = (vertex, surface.kd())
                && kd > 0.0
                && let AmbientReflectance::Color(c) = l.ambient
            {
                l.ambient = AmbientReflectance::DiffuseScaled((c.r / kd).max(0.0));
            }
            l
        });
        self.intern_material(material, texture, local, alpha, vertex)
    }

    /// The index of `material` (painted with `texture`, shading by `local` illumination, when given,
    /// and seen through where `alpha` < 1) in the scene, adding it when new.
    fn intern_material(
        &mut self,
        material: Material,
        texture: Option<u32>,
        local: Option<LocalShading>,
        alpha: f32,
        vertex_colors: bool,
    ) -> u32 {
        let key = format!("{material:?} {texture:?} {local:?} {alpha:?} {vertex_colors}");
        if let Some(&k) = self.classic_state.materials.get(&key) {
            return k;
        }
        let k = self.scene.materials.len() as u32;
        self.scene.materials.push(material);
        let maps = match (texture, material) {
            (
                Some(t),
                Material::Surface {
                    diffuse,
                    specular,
                    roughness,
                },
            ) => Some(painted(t, diffuse, specular, roughness)),
            _ if alpha < 1.0 || vertex_colors => Some(untextured(material)),
            _ => None,
        };
        if let Some(mut maps) = maps {
            maps.vertex_colors = vertex_colors;
            if alpha < 1.0 {
                maps.base_color_factor[3] = alpha;
                maps.alpha = AlphaMode::Blend;
            }
            self.scene.material_maps.insert(k, maps);
        }
        if let Some(local) = local {
            self.scene.local_shading.insert(k, local);
        }
        self.classic_state.materials.insert(key, k);
        k
    }

    /// A classic `LightSource` (`kind` one of [`CLASSIC_LIGHTS`]).
    pub(super) fn classic_light(&mut self, r: &Req<'_>, kind: &str, rest: &[Value]) -> Result<(), RibError> {
        let list = self.params(r, rest, &LIGHT_PARAMETERS, true)?;
        self.classic_mapped(r);
        let intensity = get_float(&list, "intensity").unwrap_or(1.0);
        let color = get_color(&list, "lightcolor").unwrap_or(Rgb::WHITE);
        let m = self.ctm.first();
        let point = |list: &ParamList, key: &str, default: Vec3| match get_floats(list, key) {
            Some([x, y, z, ..]) => Vec3::new(*x, *y, *z),
            _ => default,
        };
        let from = point(&list, "from", Vec3::ZERO);
        let to = point(&list, "to", Vec3::Z);
        let world_from = m.transform_point3(from);
        let axis = (m.transform_point3(to) - world_from).normalize_or_zero();
        let enable_shadows = self.classic.light_shadows;
        let emitter = PointEmitter {
            color,
            intensity: PI * intensity,
            position: world_from,
            enable_shadows,
        };
        let light = match kind {
            "ambientlight" => Light::Ambient { color, intensity },
            "distantlight" | "spotlight" if axis == Vec3::ZERO => {
                // The spec's shader normalises a zero vector: its light goes nowhere.
                self.warn(
                    r,
                    format!(
                        "LightSource \"{kind}\": \"from\" and \"to\" are the same point, so the light has no direction; left out"
                    ),
                );
                return Ok(());
            }
            "distantlight" => Light::Distant {
                color,
                intensity: PI * intensity,
                exposure: 0.0,
                angle_extent: 0.0,
                enable_shadows,
                transform: rotation_to_z(axis),
            },
            "pointlight" => Light::Point(emitter),
            _ => Light::Spot {
                emitter,
                direction: axis,
                cone_angle: get_float(&list, "coneangle").unwrap_or(30f32.to_radians()),
                cone_delta: get_float(&list, "conedeltaangle").unwrap_or(5f32.to_radians()),
                beam_distribution: get_float(&list, "beamdistribution").unwrap_or(2.0),
            },
        };
        self.scene.lights.push(light);
        Ok(())
    }
}

/// A rotation taking +Z to the unit vector `axis` (a right-handed frame around it).
fn rotation_to_z(axis: Vec3) -> Mat4 {
    let (x, y) = axis.any_orthonormal_pair();
    Mat4::from_cols(x.extend(0.0), y.extend(0.0), axis.extend(0.0), glam::Vec4::W)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The classic lobe's albedo at normal incidence, integrated numerically over the hemisphere of
    /// incoming directions: `1/π ∫ (N·H)ⁿ dω` (the `cos θᵢ` of the physical estimator cancels the one
    /// the classic shader does not have).
    fn numeric_albedo(n: f32) -> f64 {
        let n = f64::from(n);
        let steps = 20_000;
        let mut sum = 0.0;
        for k in 0..steps {
            let theta = (f64::from(k) + 0.5) / f64::from(steps) * std::f64::consts::FRAC_PI_2;
            let half = 0.5 * theta; // wo = N, so the half vector is at θ/2
            sum += half.cos().powf(n) * theta.sin() * 2.0 * std::f64::consts::PI;
        }
        sum * std::f64::consts::FRAC_PI_2 / f64::from(steps) / std::f64::consts::PI
    }

    #[test]
    fn the_classic_specular_albedo_matches_its_integral() {
        for n in [1.0f32, 8.0, 80.0, 800.0] {
            let closed = f64::from(classic_specular_albedo(n));
            let numeric = numeric_albedo(n);
            assert!(
                (closed - numeric).abs() < 1e-3 * numeric.max(1e-3),
                "n {n}: {closed} vs {numeric}"
            );
        }
        // Not vacuous: the spec's 1/r exponent would give another figure.
        assert!((classic_specular_albedo(10.0) - classic_specular_albedo(80.0)).abs() > 0.3);
    }

    #[test]
    fn plastic_keeps_kd_ks_roughness_and_specularcolor() {
        let s = ClassicSurface::Plastic {
            texture: None,
            ka: 1.0,
            kd: 0.5,
            ks: 0.5,
            roughness: 0.1,
            specular_color: Rgb::new(1.0, 0.5, 0.0),
        };
        let Material::Surface {
            diffuse,
            specular,
            roughness,
        } = s.material(Rgb::new(1.0, 0.2, 0.4))
        else {
            panic!("plastic is a PxrSurface");
        };
        assert_eq!(diffuse, Rgb::new(0.5, 0.1, 0.2));
        let a = 0.5 * classic_specular_albedo(80.0);
        assert!((specular.r - a).abs() < 1e-6 && (specular.g - 0.5 * a).abs() < 1e-6 && specular.b == 0.0);
        // α = √(2/82), roughness = √α.
        assert!((roughness - (2.0f32 / 82.0).sqrt().sqrt()).abs() < 1e-6);
    }

    #[test]
    fn constant_and_matte_and_metal() {
        let red = Rgb::new(1.0, 0.0, 0.0);
        assert_eq!(
            ClassicSurface::Constant.material(red),
            Material::Constant { color: red }
        );
        assert_eq!(
            ClassicSurface::Matte { ka: 1.0, kd: 0.8 }.material(red),
            Material::Diffuse {
                color: Rgb::new(0.8, 0.0, 0.0)
            }
        );
        let Material::Surface {
            diffuse, specular, ..
        } = (ClassicSurface::Metal {
            ka: 1.0,
            ks: 1.0,
            roughness: 0.1,
        })
        .material(red)
        else {
            panic!("metal is a PxrSurface");
        };
        assert_eq!(diffuse, Rgb::BLACK);
        assert!(specular.r > 0.0 && specular.g == 0.0);
    }

    #[test]
    fn rotation_to_z_sends_z_to_the_axis() {
        let axis = Vec3::new(1.0, -2.0, 0.5).normalize();
        let m = rotation_to_z(axis);
        assert!(m.transform_vector3(Vec3::Z).distance(axis) < 1e-6);
        assert!((m.determinant() - 1.0).abs() < 1e-5);
    }
}
