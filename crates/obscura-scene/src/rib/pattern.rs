//! `Pattern "PxrTexture"` and `Pattern "PxrNormalMap"`, and Bxdf parameters connected to them by
//! `reference`:
//!
//! ```text
//! Pattern "PxrTexture" "wood" "string filename" ["wood.png"] "int linearize" [1]
//! Pattern "PxrNormalMap" "bumps" "string filename" ["bumps.png"] "float bumpScale" [0.5]
//! Bxdf "PxrSurface" "s" "reference color diffuseColor" ["wood:resultRGB"]
//!     "reference normal bumpNormal" ["bumps:resultN"]
//! ```
//!
//! A connected material becomes [`SurfaceMaps`]: `diffuseColor` (PxrDiffuse, PxrSurface) reads the
//! texture's `resultRGB` as the base colour (times `diffuseGain`), `bumpNormal` (PxrSurface) reads a
//! PxrNormalMap's `resultN` as a tangent-space normal map. PxrTexture's `linearize 1` decodes 8- and
//! 16-bit images from sRGB (RenderMan's default 0 reads them as they are); `invertT` (default 1)
//! reads `t` as RenderMan does, with the image's first row at `t = 0` after the reader's flip of
//! `st`; `invertT 0` mirrors it. `filter 0` (nearest) reads texels unblended; every other filter is
//! the renderer's own footprint filtering. Textures repeat. A reference to an unknown handle, to an output the pattern does not
//! have, or from a parameter that cannot take it is an error naming the line.

use std::collections::HashMap;

use glam::Vec2;
use obscura_sdk::{ParamList, Rgb};

use super::lex::Value;
use super::request::{Req, get_float, get_floats, get_int, get_string};
use super::{Reader, RibError};
use crate::texture::{ColorSpace, ImageSource, SurfaceMaps, TextureDesc, TextureSlot, Wrap};
use crate::types::Material;

/// A pattern node a Bxdf may reference.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Pattern {
    /// `PxrTexture`: a colour image, output `resultRGB`.
    Texture {
        /// The texture slot (its texture already in the scene).
        slot: TextureSlot,
    },
    /// `PxrNormalMap`: a tangent-space normal image, output `resultN`.
    NormalMap {
        /// The texture slot, `scale` = `bumpScale`.
        slot: TextureSlot,
    },
}

/// The handles of the patterns read so far.
pub(super) type Patterns = HashMap<String, Pattern>;

/// One `reference` parameter of a Bxdf: `(parameter name, pattern handle, output name)`.
pub(super) struct Reference {
    name: String,
    handle: String,
    output: String,
}

impl Reader {
    /// `Pattern "PxrTexture"|"PxrNormalMap" "handle" params`; other patterns warn and are ignored.
    pub(super) fn pattern(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(kind), Value::Str(handle), rest @ ..] = r.args else {
            return Err(r.err("Pattern expects a pattern name and a handle (2 strings) then parameters"));
        };
        let normal = match kind.as_str() {
            "PxrTexture" => false,
            "PxrNormalMap" => true,
            other => {
                self.warn(
                    r,
                    format!(
                        "Pattern: \"{other}\" is not supported (known: PxrTexture, PxrNormalMap), ignored"
                    ),
                );
                return Ok(());
            }
        };
        let table = [
            "string filename",
            "int linearize",
            "int invertT",
            "int filter",
            "float bumpScale",
        ];
        let list = self.params(r, rest, &table, false)?;
        let Some(filename) = get_string(&list, "filename").filter(|f| !f.is_empty()) else {
            return Err(r.err(format!("Pattern \"{kind}\" \"{handle}\": no \"string filename\"")));
        };
        let srgb = !normal && get_int(&list, "linearize").unwrap_or(0) == 1;
        let texture = self.scene.textures.len() as u32;
        self.scene.textures.push(TextureDesc {
            source: ImageSource::File(r.base.join(filename)),
            color_space: if srgb {
                ColorSpace::Srgb
            } else {
                ColorSpace::Linear
            },
            wrap: (Wrap::Repeat, Wrap::Repeat),
            nearest: get_int(&list, "filter") == Some(0),
            used_by: format!("{}: Pattern \"{kind}\" \"{handle}\"", r.at()),
        });
        let mut slot = TextureSlot::new(texture);
        if get_int(&list, "invertT").unwrap_or(1) == 0 {
            slot.transform = [1.0, 0.0, 0.0, 0.0, -1.0, 1.0];
        }
        let pattern = if normal {
            slot.scale = get_float(&list, "bumpScale").unwrap_or(1.0);
            Pattern::NormalMap { slot }
        } else {
            Pattern::Texture { slot }
        };
        self.patterns.insert(handle.clone(), pattern);
        Ok(())
    }

    /// Splits a Bxdf's parameters into the ordinary ones and its `reference` connections, each checked
    /// against the patterns read so far.
    pub(super) fn references(
        &mut self,
        r: &Req<'_>,
        rest: &[Value],
    ) -> Result<(Vec<Value>, Vec<Reference>), RibError> {
        let mut plain = Vec::new();
        let mut refs = Vec::new();
        let mut pairs = rest.chunks(2);
        for pair in &mut pairs {
            let declaration = match pair.first() {
                Some(Value::Str(s)) => s.split_whitespace().collect::<Vec<_>>(),
                _ => Vec::new(),
            };
            if declaration.first() != Some(&"reference") {
                plain.extend(pair.iter().cloned());
                continue;
            }
            let [_, _ty, name] = declaration[..] else {
                return Err(r.err(format!(
                    "{}: a reference is declared \"reference TYPE NAME\", got \"{}\"",
                    r.name,
                    declaration.join(" ")
                )));
            };
            let target = match pair.get(1) {
                Some(Value::Str(s)) => s.clone(),
                Some(Value::Strs(v)) if v.len() == 1 => v[0].clone(),
                _ => {
                    return Err(r.err(format!(
                        "{}: reference \"{name}\" expects one string \"handle:output\"",
                        r.name
                    )));
                }
            };
            let Some((handle, output)) = target.split_once(':') else {
                return Err(r.err(format!(
                    "{}: reference \"{name}\": \"{target}\" is not \"handle:output\"",
                    r.name
                )));
            };
            if !self.patterns.contains_key(handle) {
                return Err(r.err(format!(
                    "{}: reference \"{name}\": no Pattern with handle \"{handle}\" before this line",
                    r.name
                )));
            }
            refs.push(Reference {
                name: name.to_string(),
                handle: handle.to_string(),
                output: output.to_string(),
            });
        }
        Ok((plain, refs))
    }

    /// Gives the material just added (`self.material`) the maps its references connect; nothing
    /// without references. `gain` is PxrSurface's `diffuseGain` (1 for PxrDiffuse).
    pub(super) fn connect(&mut self, r: &Req<'_>, refs: &[Reference], gain: f32) -> Result<(), RibError> {
        if refs.is_empty() {
            return Ok(());
        }
        let material = self.scene.materials[self.material as usize];
        let mut maps = match material {
            Material::Diffuse { color } => SurfaceMaps {
                base_color_factor: [color.r, color.g, color.b, 1.0],
                metallic: 0.0,
                roughness: 1.0,
                diffuse_only: true,
                ..SurfaceMaps::default()
            },
            Material::Surface {
                diffuse,
                specular,
                roughness,
            } => SurfaceMaps {
                base_color_factor: [diffuse.r, diffuse.g, diffuse.b, 1.0],
                metallic: 0.0,
                roughness,
                diffuse_only: specular == Rgb::BLACK,
                specular: Some(specular),
                ..SurfaceMaps::default()
            },
            _ => {
                return Err(r.err(format!(
                    "{}: references are read on PxrDiffuse and PxrSurface only",
                    r.name
                )));
            }
        };
        for reference in refs {
            let pattern = &self.patterns[&reference.handle];
            match (reference.name.as_str(), reference.output.as_str(), pattern) {
                ("diffuseColor", "resultRGB", Pattern::Texture { slot }) => {
                    // The texture replaces the colour; `diffuseGain` still multiplies it.
                    maps.base_color_factor = [gain, gain, gain, 1.0];
                    maps.base_color = Some(*slot);
                }
                ("bumpNormal", "resultN", Pattern::NormalMap { slot })
                    if matches!(material, Material::Surface { .. }) =>
                {
                    maps.normal = Some(*slot);
                }
                (name, output, _) => {
                    let outputs = match pattern {
                        Pattern::Texture { .. } => "PxrTexture gives resultRGB to diffuseColor",
                        Pattern::NormalMap { .. } => "PxrNormalMap gives resultN to PxrSurface's bumpNormal",
                    };
                    return Err(r.err(format!(
                        "{}: reference \"{name}\" [\"{}:{output}\"] cannot be connected ({outputs})",
                        r.name, reference.handle
                    )));
                }
            }
        }
        self.scene.material_maps.insert(self.material, maps);
        Ok(())
    }
}

/// A polygon mesh's `"st"` (one `(s, t)` per point) as the mesh's first texture coordinate set, `t`
/// flipped to glTF's convention (`t' = 1 − t`, origin at the image's top-left) like every reader's;
/// empty without `st`.
pub(super) fn texture_coordinates(
    r: &Req<'_>,
    list: &ParamList,
    points: usize,
) -> Result<Vec<Vec<Vec2>>, RibError> {
    let Some(st) = get_floats(list, "st") else {
        return Ok(Vec::new());
    };
    if st.len() != 2 * points {
        return Err(r.err(format!(
            "{}: \"st\" has {} values; expected 2 per point ({})",
            r.name,
            st.len(),
            2 * points
        )));
    }
    Ok(vec![
        st.chunks_exact(2).map(|p| Vec2::new(p[0], 1.0 - p[1])).collect(),
    ])
}
