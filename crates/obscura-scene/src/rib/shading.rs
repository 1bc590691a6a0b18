//! Shading state and emitters: `Attribute` (dicing), `Bxdf` materials and lights.

use obscura_sdk::Rgb;

use super::classic_shaders::CLASSIC_LIGHTS;
use super::lex::Value;
use super::request::{Req, get_color, get_float, get_int, get_string};
use super::{Reader, RibError};
use crate::types::{Light, Material};

impl Reader {
    /// `Attribute "dice"` with `micropolygonlength` and `Attribute "identifier"` with `name` (the
    /// object and instance name of the ID AOVs); other attributes are warned about once each.
    pub(super) fn attribute(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name), rest @ ..] = r.args else {
            return Err(r.err("Attribute expects an attribute name (a string) then parameters"));
        };
        if name == "identifier" {
            let list = self.params(r, rest, &["string name"], false)?;
            if let Some(id) = get_string(&list, "name") {
                self.identifier = id.to_string();
            }
            return Ok(());
        }
        if name == "light" {
            return self.light_attribute(r, rest);
        }
        if name == "visibility" || name == "render" {
            return self.visibility_attribute(r, name, rest);
        }
        if name != "dice" {
            if self.warned_attributes.insert(name.clone()) {
                self.warn(r, format!("Attribute \"{name}\" is not supported, ignored"));
            }
            return Ok(());
        }
        let list = self.params(r, rest, &["float micropolygonlength"], false)?;
        if let Some(x) = get_float(&list, "micropolygonlength") {
            if x <= 0.0 {
                return Err(r.err(format!(
                    "Attribute \"dice\": micropolygonlength must be greater than 0, got {x}"
                )));
            }
            self.micropolygon_length = x;
        }
        Ok(())
    }

    /// `Attribute "visibility"` (RenderMan: `"int camera"`, `"int transmission"`, the older
    /// `"string transmission"` `"opaque"`/`"Os"`/`"shader"` or `"transparent"`) and `Attribute "render"`
    /// (BMRT: `"string casts_shadows"` `"none"`, or `"opaque"`/`"Os"`/`"shade"`/`"Oi"`): whether camera
    /// rays see the surfaces that follow and whether they cast shadows. The other visibilities
    /// (`indirect`, `trace`, `diffuse`, `specular`, `photon`) and `render` attributes are warned about
    /// once each and left as they are (seen by every other ray). Names may carry their type or not.
    fn visibility_attribute(&mut self, r: &Req<'_>, attribute: &str, rest: &[Value]) -> Result<(), RibError> {
        let mut pairs = rest.iter();
        while let Some(name) = pairs.next() {
            let Value::Str(written) = name else {
                return Err(r.err(format!(
                    "Attribute \"{attribute}\": expected a parameter name (a string), got a number"
                )));
            };
            let Some(value) = pairs.next() else {
                return Err(r.err(format!(
                    "Attribute \"{attribute}\": parameter \"{written}\" has no value"
                )));
            };
            let key = written.rsplit(' ').next().unwrap_or(written);
            // One value: a number (0 or 1) or a string.
            let (number, text) = match value {
                Value::Num(n) => (Some(n.value), None),
                Value::Nums(v) if v.len() == 1 => (Some(v[0].value), None),
                Value::Str(s) => (None, Some(s.as_str())),
                Value::Strs(v) if v.len() == 1 => (None, Some(v[0].as_str())),
                _ => {
                    return Err(r.err(format!(
                        "Attribute \"{attribute}\" \"{key}\": expected one number or one string"
                    )));
                }
            };
            let visibility = &mut self.facing.visibility;
            match (attribute, key, number, text) {
                ("visibility", "camera", Some(x), _) => visibility.camera = x != 0.0,
                ("visibility", "transmission", Some(x), _) => visibility.shadows = x != 0.0,
                ("visibility", "transmission", _, Some(t)) | ("render", "casts_shadows", _, Some(t)) => {
                    visibility.shadows = match t {
                        "transparent" | "none" => false,
                        "opaque" | "Os" | "Oi" | "shade" | "shader" => true,
                        other => {
                            return Err(r.err(format!(
                                "Attribute \"{attribute}\" \"{key}\": expected \"opaque\", \"Os\", \"shade\" or \"{}\", got \"{other}\"",
                                if attribute == "render" { "none" } else { "transparent" }
                            )));
                        }
                    };
                }
                ("visibility", "camera" | "transmission", ..) | ("render", "casts_shadows", ..) => {
                    return Err(r.err(format!(
                        "Attribute \"{attribute}\" \"{key}\": expected {}",
                        if key == "camera" {
                            "0 or 1"
                        } else {
                            "0, 1 or a string"
                        }
                    )));
                }
                _ => {
                    if self.warned_attributes.insert(format!("{attribute} {key}")) {
                        self.warn(
                            r,
                            format!("Attribute \"{attribute}\" \"{key}\" is not supported (every other ray sees the surface), ignored"),
                        );
                    }
                }
            }
        }
        Ok(())
    }

    /// `Bxdf`: `PxrDiffuse`, `PxrConstant` or `PxrSurface` becomes the current material; others warn and
    /// select the default material.
    pub(super) fn bxdf(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(kind), Value::Str(_handle), rest @ ..] = r.args else {
            return Err(r.err("Bxdf expects a Bxdf name and a handle (2 strings) then parameters"));
        };
        // `reference` parameters connect patterns (rib/pattern.rs).
        let (rest, references) = self.references(r, rest)?;
        let rest = &rest[..];
        let mut gain = 1.0;
        let material = match kind.as_str() {
            "PxrDiffuse" => {
                let list = self.params(r, rest, &["color diffuseColor"], false)?;
                Material::Diffuse {
                    color: get_color(&list, "diffuseColor").unwrap_or(Rgb::new(0.18, 0.18, 0.18)),
                }
            }
            "PxrConstant" => {
                let list = self.params(r, rest, &["color emitColor"], false)?;
                Material::Constant {
                    color: get_color(&list, "emitColor").unwrap_or(Rgb::WHITE),
                }
            }
            "PxrSurface" => {
                let table = [
                    "color diffuseColor",
                    "float diffuseGain",
                    "color specularFaceColor",
                    "float specularRoughness",
                ];
                let list = self.params(r, rest, &table, false)?;
                let color = get_color(&list, "diffuseColor").unwrap_or(Rgb::new(0.18, 0.18, 0.18));
                gain = get_float(&list, "diffuseGain").unwrap_or(1.0);
                Material::Surface {
                    diffuse: Rgb::new(color.r * gain, color.g * gain, color.b * gain),
                    specular: get_color(&list, "specularFaceColor").unwrap_or(Rgb::BLACK),
                    roughness: get_float(&list, "specularRoughness").unwrap_or(0.2),
                }
            }
            other => {
                self.warn(
                    r,
                    format!(
                        "Bxdf: unknown Bxdf \"{other}\" (known: PxrDiffuse, PxrConstant, PxrSurface), using the default material"
                    ),
                );
                self.material = 0;
                return Ok(());
            }
        };
        self.material = self.scene.materials.len() as u32;
        self.scene.materials.push(material);
        self.classic.surface = None;
        self.connect(r, &references, gain)
    }

    /// `Light`, `LightSource` or `AreaLightSource`: the Pxr dome, distant, rect and sphere lights, placed by
    /// the current transform.
    pub(super) fn light(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(kind), Value::Str(_) | Value::Num(_), rest @ ..] = r.args else {
            return Err(r.err(format!(
                "{} expects a light name and a handle, e.g. {} \"PxrDomeLight\" \"dome\"",
                r.name, r.name
            )));
        };
        if CLASSIC_LIGHTS.contains(&kind.as_str()) {
            return self.classic_light(r, kind, rest);
        }
        let mut table = vec!["color lightColor", "float intensity", "float exposure"];
        match kind.as_str() {
            "PxrDomeLight" => table.push("string lightColorMap"),
            "PxrDistantLight" => table.extend(["float angleExtent", "int enableShadows"]),
            "PxrRectLight" | "PxrSphereLight" => {}
            other => {
                self.warn(
                    r,
                    format!(
                        "{}: unknown light \"{other}\" (known: PxrDomeLight, PxrDistantLight, PxrRectLight, PxrSphereLight, ambientlight, distantlight, pointlight, spotlight), skipped",
                        r.name
                    ),
                );
                return Ok(());
            }
        }
        let list = self.params(r, rest, &table, false)?;
        let color = get_color(&list, "lightColor").unwrap_or(Rgb::WHITE);
        let intensity = get_float(&list, "intensity").unwrap_or(1.0);
        let exposure = get_float(&list, "exposure").unwrap_or(0.0);
        if ![color.r, color.g, color.b]
            .iter()
            .all(|c| c.is_finite() && *c >= 0.0)
        {
            return Err(r.err(format!(
                "{} \"{kind}\": \"color lightColor\" [{} {} {}]: expected finite components >= 0 (lights do not subtract light)",
                r.name, color.r, color.g, color.b
            )));
        }
        if !(intensity.is_finite() && intensity >= 0.0) {
            return Err(r.err(format!(
                "{} \"{kind}\": \"float intensity\" [{intensity}]: expected a finite value >= 0 (lights do not subtract light)",
                r.name
            )));
        }
        if !(exposure.is_finite() && exposure.abs() <= 64.0) {
            return Err(r.err(format!(
                "{} \"{kind}\": \"float exposure\" [{exposure}]: expected stops in [-64, 64]",
                r.name
            )));
        }
        let transform = self.ctm.first();
        let light = match kind.as_str() {
            "PxrDomeLight" => Light::Dome {
                color,
                intensity,
                exposure,
                map: get_string(&list, "lightColorMap")
                    .filter(|m| !m.is_empty())
                    .map(|m| r.resolve(m)),
                transform,
            },
            "PxrDistantLight" => Light::Distant {
                color,
                intensity,
                exposure,
                angle_extent: get_float(&list, "angleExtent").unwrap_or(0.53),
                enable_shadows: get_int(&list, "enableShadows").unwrap_or(1) != 0,
                transform,
            },
            "PxrRectLight" => Light::Rect {
                color,
                intensity,
                exposure,
                transform,
            },
            _ => Light::Sphere {
                color,
                intensity,
                exposure,
                transform,
            },
        };
        self.scene.lights.push(light);
        Ok(())
    }
}
