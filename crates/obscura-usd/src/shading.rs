//! UsdPreviewSurface materials with their textures, and the primvars they read.
//!
//! A prim's bound material (`material:binding`, inherited down the namespace) whose
//! `outputs:surface` connects to a `UsdPreviewSurface` gives the glTF-like [`SurfaceMaps`] the
//! renderer already shades glTF with:
//!
//! | UsdPreviewSurface input | SurfaceMaps |
//! |---|---|
//! | `diffuseColor` (value, or `UsdUVTexture.outputs:rgb`) | base colour factor / texture (sRGB unless `sourceColorSpace = raw`) |
//! | `metallic`, `roughness` (value, or a texture's `r`/`g`/`b`) | metallic, roughness factors; a texture as the metallic–roughness map |
//! | `normal` (`UsdUVTexture.outputs:rgb`) | tangent-space normal map |
//! | `emissiveColor` | emissive factor / texture |
//! | `opacity` | alpha blend factor |
//!
//! A `UsdUVTexture`'s `inputs:file` is read from disk, or from inside a `.usdz` package
//! (`pkg.usdz[tex.png]`); `wrapS`/`wrapT` (`repeat`, `clamp`, `mirror`; `useMetadata` and `black`
//! read as repeat) set the wrap; its `st` comes from a `UsdPrimvarReader_float2` (`varname`, itself
//! possibly connected to a material input) through an optional `UsdTransform2d`
//! (`st' = R(rotation)·(scale ⊙ st) + translation`). USD's `t` points up; Obscura's texture
//! coordinates are glTF's (t down), so `t' = 1 − t` on the mesh and the transform is conjugated.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use obscura_scene::texture::{
    AlphaMode, ColorSpace, ImageSource, SurfaceMaps, TextureDesc, TextureSlot, Wrap,
};
use obscura_scene::{Material, Scene};
use obscura_sdk::Rgb;

use crate::UsdError;
use crate::values::{Time, Values};

/// The shader prim feeding `prim.input` (the prim part of its first connection).
fn source(values: &Values<'_>, prim: &str, input: &str) -> Option<(String, String)> {
    let c = values.connections(prim, input).into_iter().next()?;
    let (p, output) = c.split_once('.').unwrap_or((c.as_str(), ""));
    Some((p.to_string(), output.to_string()))
}

fn shader_id(values: &Values<'_>, prim: &str) -> Option<String> {
    values.token_opt(prim, "info:id", Time::Default).ok().flatten()
}

/// The value of `prim.input`, following a connection to a material's interface input.
fn input_value(values: &Values<'_>, prim: &str, input: &str, time: Time) -> Option<openusd::sdf::Value> {
    if let Some((p, out)) = source(values, prim, input)
        && out.starts_with("inputs:")
    {
        return values.raw(&p, &out, time).ok().flatten();
    }
    values.raw(prim, input, time).ok().flatten()
}

/// What a texture needs from the mesh: the primvar holding its coordinates.
pub struct Bound {
    /// The material's index in [`Scene::materials`].
    pub material: u32,
    /// The `st` primvar the textures read (`None`: untextured).
    pub uv_primvar: Option<String>,
}

/// The PreviewSurface bound to `path` as a scene material (added to `scene`), or `None`.
pub(crate) fn bound_material(
    values: &Values<'_>,
    stage_dir: &Path,
    path: &str,
    time: Time,
    scene: &mut Scene,
    cache: &mut Vec<(String, Bound)>,
) -> Result<Option<Bound>, UsdError> {
    let mut bound = None;
    let mut p = path.to_string();
    while p.len() > 1 && bound.is_none() {
        bound = values.targets(&p, "material:binding").into_iter().next();
        p = match p.rfind('/') {
            Some(0) | None => break,
            Some(i) => p[..i].to_string(),
        };
    }
    let Some(material_path) = bound else {
        return Ok(None);
    };
    if let Some((_, b)) = cache.iter().find(|(m, _)| *m == material_path) {
        return Ok(Some(Bound {
            material: b.material,
            uv_primvar: b.uv_primvar.clone(),
        }));
    }
    let Some((surface, _)) = source(values, &material_path, "outputs:surface") else {
        return Ok(None);
    };
    if shader_id(values, &surface).as_deref() != Some("UsdPreviewSurface") {
        return Ok(None);
    }
    let rgb = |v: &[f64]| Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32);
    let color = |input: &str, fallback: [f32; 3]| -> Rgb {
        input_value(values, &surface, input, time)
            .and_then(|v| crate::values::tuple(&v))
            .filter(|t| t.len() == 3)
            .map_or(Rgb::new(fallback[0], fallback[1], fallback[2]), |t| rgb(&t))
    };
    let number = |input: &str, fallback: f64| -> f64 {
        input_value(values, &surface, input, time)
            .and_then(|v| crate::values::scalar(&v))
            .unwrap_or(fallback)
    };
    let diffuse = color("inputs:diffuseColor", [0.18, 0.18, 0.18]);
    let emissive = color("inputs:emissiveColor", [0.0, 0.0, 0.0]);
    let metallic = number("inputs:metallic", 0.0) as f32;
    let roughness = number("inputs:roughness", 0.5) as f32;
    let opacity = number("inputs:opacity", 1.0) as f32;
    let mut uv_primvar = None;
    let mut texture =
        |input: &str, space: ColorSpace, scene: &mut Scene| -> Result<Option<TextureSlot>, UsdError> {
            let Some((tex, _)) = source(values, &surface, input) else {
                return Ok(None);
            };
            if shader_id(values, &tex).as_deref() != Some("UsdUVTexture") {
                return Ok(None);
            }
            let Some(file) = input_value(values, &tex, "inputs:file", time) else {
                return Ok(None);
            };
            let openusd::sdf::Value::AssetPath(asset) = file else {
                return Err(values.error(&tex, "inputs:file", "expected an asset path"));
            };
            let image = image_source(stage_dir, &asset, values.file, &tex)?;
            let wrap = |name: &str| match input_value(values, &tex, name, time)
                .and_then(|v| crate::values::text(&v))
                .as_deref()
            {
                Some("clamp") => Wrap::Clamp,
                Some("mirror") => Wrap::Mirror,
                _ => Wrap::Repeat,
            };
            let raw = input_value(values, &tex, "inputs:sourceColorSpace", time)
                .and_then(|v| crate::values::text(&v))
                .is_some_and(|s| s == "raw");
            scene.textures.push(TextureDesc {
                source: image,
                color_space: if raw { ColorSpace::Linear } else { space },
                wrap: (wrap("inputs:wrapS"), wrap("inputs:wrapT")),
                nearest: false,
                used_by: format!("{}: <{tex}>", values.file),
            });
            // st: a primvar reader, perhaps through a UsdTransform2d.
            let mut transform = TextureSlot::IDENTITY;
            let mut st = source(values, &tex, "inputs:st");
            if let Some((t2d, _)) = st.clone()
                && shader_id(values, &t2d).as_deref() == Some("UsdTransform2d")
            {
                let s = input_value(values, &t2d, "inputs:scale", time)
                    .and_then(|v| crate::values::tuple(&v))
                    .unwrap_or(vec![1.0, 1.0]);
                let r = input_value(values, &t2d, "inputs:rotation", time)
                    .and_then(|v| crate::values::scalar(&v))
                    .unwrap_or(0.0)
                    .to_radians();
                let tr = input_value(values, &t2d, "inputs:translation", time)
                    .and_then(|v| crate::values::tuple(&v))
                    .unwrap_or(vec![0.0, 0.0]);
                // USD: st' = R·(S·st) + T with t up. With t_g = 1 − t on both sides:
                // s' = a·s + b·t + c, t' = d·s + e·t + f  →  in glTF coordinates
                // s' = a·s − b·t_g + (c + b), t_g' = −d·s + e·t_g + (1 − f − e).
                let (cr, sr) = (r.cos(), r.sin());
                let (a, b, c) = (cr * s[0], -sr * s[1], tr[0]);
                let (d, e, f) = (sr * s[0], cr * s[1], tr[1]);
                transform = [a, -b, c + b, -d, e, 1.0 - f - e].map(|x| x as f32);
                st = source(values, &t2d, "inputs:in");
            }
            if let Some((reader, _)) = st {
                let name = input_value(values, &reader, "inputs:varname", time)
                    .and_then(|v| crate::values::text(&v))
                    .unwrap_or_else(|| "st".into());
                uv_primvar = Some(name);
            } else {
                uv_primvar.get_or_insert_with(|| "st".into());
            }
            Ok(Some(TextureSlot {
                texture: (scene.textures.len() - 1) as u32,
                uv_set: 0,
                transform,
                scale: 1.0,
            }))
        };
    let base_color = texture("inputs:diffuseColor", ColorSpace::Srgb, scene)?;
    let normal = texture("inputs:normal", ColorSpace::Linear, scene)?;
    let emissive_map = texture("inputs:emissiveColor", ColorSpace::Srgb, scene)?;
    let metallic_roughness = match texture("inputs:roughness", ColorSpace::Linear, scene)? {
        Some(slot) => Some(slot),
        None => texture("inputs:metallic", ColorSpace::Linear, scene)?,
    };
    let d = 1.0 - metallic;
    scene.materials.push(Material::Surface {
        diffuse: Rgb::new(diffuse.r * d, diffuse.g * d, diffuse.b * d),
        specular: Rgb::new(
            0.04 * d + diffuse.r * metallic,
            0.04 * d + diffuse.g * metallic,
            0.04 * d + diffuse.b * metallic,
        ),
        roughness,
    });
    let index = (scene.materials.len() - 1) as u32;
    let textured =
        base_color.is_some() || normal.is_some() || emissive_map.is_some() || metallic_roughness.is_some();
    if textured || opacity < 1.0 || emissive != Rgb::new(0.0, 0.0, 0.0) {
        let factor = if base_color.is_some() {
            [1.0, 1.0, 1.0, opacity]
        } else {
            [diffuse.r, diffuse.g, diffuse.b, opacity]
        };
        scene.material_maps.insert(
            index,
            SurfaceMaps {
                base_color_factor: factor,
                base_color,
                metallic: if metallic_roughness.is_some() {
                    1.0
                } else {
                    metallic
                },
                roughness: if metallic_roughness.is_some() {
                    1.0
                } else {
                    roughness
                },
                metallic_roughness,
                normal,
                emissive_factor: if emissive_map.is_some() {
                    Rgb::new(1.0, 1.0, 1.0)
                } else {
                    emissive
                },
                emissive: emissive_map,
                alpha: if opacity < 1.0 {
                    AlphaMode::Blend
                } else {
                    AlphaMode::Opaque
                },
                vertex_colors: false,
                diffuse_only: false,
                specular: None,
                specular_map: None,
                opacity: None,
            },
        );
    }
    let b = Bound {
        material: index,
        uv_primvar: if textured { uv_primvar } else { None },
    };
    cache.push((
        material_path,
        Bound {
            material: b.material,
            uv_primvar: b.uv_primvar.clone(),
        },
    ));
    Ok(Some(b))
}

/// Where a texture's bytes are: a file, or an entry of a `.usdz` package (read out of it).
pub(crate) fn image_source(
    stage_dir: &Path,
    asset: &openusd::sdf::AssetPath,
    file: &str,
    prim: &str,
) -> Result<ImageSource, UsdError> {
    let path = asset
        .resolved_path()
        .filter(|p| !p.is_empty())
        .map(str::to_string)
        .unwrap_or_else(|| stage_dir.join(&asset.authored_path).display().to_string());
    if let Some(open) = path.rfind(".usdz[")
        && path.ends_with(']')
    {
        let package = &path[..open + 5];
        let entry = &path[open + 6..path.len() - 1];
        let bytes = read_package_entry(Path::new(package), entry)
            .map_err(|e| UsdError::at(file, prim, format!("inputs:file @{}@: {e}", asset.authored_path)))?;
        return Ok(ImageSource::Embedded {
            name: path.clone(),
            bytes: Arc::from(bytes),
        });
    }
    Ok(ImageSource::File(PathBuf::from(path)))
}

fn read_package_entry(package: &Path, entry: &str) -> Result<Vec<u8>, String> {
    use std::io::Read;
    let f = std::fs::File::open(package).map_err(|e| format!("{}: {e}", package.display()))?;
    let mut zip =
        zip::ZipArchive::new(f).map_err(|e| format!("{}: not a usdz package: {e}", package.display()))?;
    let mut member = zip
        .by_name(entry)
        .map_err(|e| format!("{}: no entry {entry:?}: {e}", package.display()))?;
    let mut bytes = Vec::new();
    member
        .read_to_end(&mut bytes)
        .map_err(|e| format!("{}[{entry}]: {e}", package.display()))?;
    Ok(bytes)
}
