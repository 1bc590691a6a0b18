//! MTL texture statements as [`SurfaceMaps`]: `map_Kd`, `map_Ks`, `map_Ke`, `map_d`, `norm`
//! (tangent-space normal map), with their `-s`, `-o` and `-clamp` options.
//!
//! OBJ texture coordinates have `t` up; the reader stores `1 − t` (glTF's convention, which every
//! lookup uses), so an MTL option `-s su sv` / `-o ou ov` (in OBJ's `(s, t)`) becomes the affine map
//! `s' = su·s + ou`, `v' = sv·v + (1 − sv − ov)` on the stored coordinates.

use std::path::Path;

use obscura_sdk::Rgb;

use crate::texture::{AlphaMode, ColorSpace, ImageSource, SurfaceMaps, TextureDesc, TextureSlot, Wrap};
use crate::types::Scene;

/// A texture statement's options and file.
#[derive(Debug, Clone, PartialEq)]
struct MapStatement {
    file: String,
    scale: [f32; 2],
    offset: [f32; 2],
    clamp: bool,
}

/// Options of MTL texture statements and how many values each takes (at most; `-o`, `-s` and `-t`
/// take one to three numbers).
const OPTIONS: [(&str, usize); 12] = [
    ("-blendu", 1),
    ("-blendv", 1),
    ("-bm", 1),
    ("-boost", 1),
    ("-cc", 1),
    ("-clamp", 1),
    ("-imfchan", 1),
    ("-mm", 2),
    ("-texres", 1),
    ("-type", 1),
    ("-o", 3),
    ("-s", 3),
];

/// Parses `[options] file` (the file name may contain spaces: it is everything after the options).
fn parse_statement(value: &str) -> Option<MapStatement> {
    let mut words = value.split_whitespace().peekable();
    let mut m = MapStatement {
        file: String::new(),
        scale: [1.0, 1.0],
        offset: [0.0, 0.0],
        clamp: false,
    };
    while let Some(&w) = words.peek() {
        let Some(&(name, most)) = OPTIONS.iter().chain(&[("-t", 3)]).find(|(n, _)| *n == w) else {
            break;
        };
        words.next();
        let mut values = Vec::new();
        while values.len() < most {
            match words.peek() {
                Some(v)
                    if (name == "-clamp" || name == "-imfchan" || name == "-type") && values.is_empty() =>
                {
                    values.push(v.to_string());
                    words.next();
                }
                Some(v) if v.parse::<f32>().is_ok() => {
                    values.push(v.to_string());
                    words.next();
                }
                _ => break,
            }
        }
        let num = |i: usize, d: f32| values.get(i).and_then(|v| v.parse().ok()).unwrap_or(d);
        match name {
            "-s" => m.scale = [num(0, 1.0), num(1, 1.0)],
            "-o" => m.offset = [num(0, 0.0), num(1, 0.0)],
            "-clamp" => m.clamp = values.first().is_some_and(|v| v == "on"),
            _ => {}
        }
    }
    m.file = words.collect::<Vec<_>>().join(" ");
    (!m.file.is_empty()).then_some(m)
}

/// The slot for one texture statement, its texture added to `scene`.
fn slot(
    scene: &mut Scene,
    base: &Path,
    value: &str,
    color_space: ColorSpace,
    used_by: String,
) -> Option<TextureSlot> {
    let Some(m) = parse_statement(value) else {
        scene
            .warnings
            .push(format!("{used_by}: no file named in \"{value}\"; ignored"));
        return None;
    };
    let wrap = if m.clamp { Wrap::Clamp } else { Wrap::Repeat };
    scene.textures.push(TextureDesc {
        source: ImageSource::File(base.join(m.file.replace('\\', "/"))),
        color_space,
        wrap: (wrap, wrap),
        nearest: false,
        used_by,
    });
    let mut slot = TextureSlot::new((scene.textures.len() - 1) as u32);
    let ([su, sv], [ou, ov]) = (m.scale, m.offset);
    slot.transform = [su, 0.0, ou, 0.0, sv, 1.0 - sv - ov];
    Some(slot)
}

/// The maps of one MTL material (index `index` in the scene) when it names any texture, else
/// `None`. Factors: `Kd` (the map is multiplied by it, as the MTL specification says; absent, 1
/// when `map_Kd` gives the colour, as Blender's importer reads it, else 0.18 grey), `Ks` as the
/// specular colour,
/// `Ke` as emission (1 when only `map_Ke` is given), `d` as alpha (BLEND below 1 or with `map_d`).
pub(super) fn material_maps(
    scene: &mut Scene,
    file: &str,
    base: &Path,
    m: &tobj::Material,
    roughness: f32,
) -> Option<SurfaceMaps> {
    let who = format!("{file}: material \"{}\"", m.name);
    let unknown = |key: &str| m.unknown_param.get(key).cloned();
    let map_ke = unknown("map_Ke");
    let norm = unknown("norm").or_else(|| unknown("map_norm"));
    let any = m.diffuse_texture.is_some()
        || m.specular_texture.is_some()
        || m.dissolve_texture.is_some()
        || map_ke.is_some()
        || norm.is_some();
    if m.normal_texture.is_some() {
        scene.warnings.push(format!(
            "{who}: bump (height) maps are not supported; use a tangent-space normal map (norm)"
        ));
    }
    if !any {
        return None;
    }
    let colour = |c: [f32; 3]| c.map(|x| if x.is_finite() { x.max(0.0) } else { 0.0 });
    let absent = if m.diffuse_texture.is_some() { 1.0 } else { 0.18 };
    let kd = m.diffuse.map(colour).unwrap_or([absent; 3]);
    let ks = m.specular.map(colour).unwrap_or([0.0; 3]);
    let ke = m.emissive.map(colour);
    let d = m
        .dissolve
        .filter(|d| d.is_finite())
        .unwrap_or(1.0)
        .clamp(0.0, 1.0);
    let mut maps = SurfaceMaps {
        base_color_factor: [kd[0], kd[1], kd[2], d],
        metallic: 0.0,
        roughness,
        diffuse_only: ks == [0.0; 3] && m.specular_texture.is_none(),
        specular: Some(Rgb::new(ks[0], ks[1], ks[2])),
        ..SurfaceMaps::default()
    };
    if let Some(v) = &m.diffuse_texture {
        maps.base_color = slot(scene, base, v, ColorSpace::Srgb, format!("{who} map_Kd"));
    }
    if let Some(v) = &m.specular_texture {
        maps.specular_map = slot(scene, base, v, ColorSpace::Srgb, format!("{who} map_Ks"));
    }
    if let Some(v) = &map_ke {
        maps.emissive = slot(scene, base, v, ColorSpace::Srgb, format!("{who} map_Ke"));
    }
    let e = match (ke, &maps.emissive) {
        (Some(e), _) if e != [0.0; 3] => e,
        (_, Some(_)) => [1.0; 3],
        _ => [0.0; 3],
    };
    maps.emissive_factor = Rgb::new(e[0], e[1], e[2]);
    if let Some(v) = &m.dissolve_texture {
        maps.opacity = slot(scene, base, v, ColorSpace::Linear, format!("{who} map_d"));
    }
    if let Some(v) = &norm {
        maps.normal = slot(scene, base, v, ColorSpace::Linear, format!("{who} norm"));
    }
    if d < 1.0 || maps.opacity.is_some() {
        maps.alpha = AlphaMode::Blend;
    }
    Some(maps)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_statements_keep_spaces_in_file_names_and_read_scale_offset_clamp() {
        let m = parse_statement("-s 2 3 1 -o 0.5 0.25 -clamp on -bm 0.5 my wood.png").unwrap();
        assert_eq!(m.file, "my wood.png");
        assert_eq!((m.scale, m.offset, m.clamp), ([2.0, 3.0], [0.5, 0.25], true));
        assert_eq!(parse_statement("wood.jpg").unwrap().scale, [1.0, 1.0]);
        assert!(parse_statement("-s 2 2").is_none());
    }
}
