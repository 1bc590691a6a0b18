//! Lens prescriptions: the four-column text format and Obscura's JSON format, and the lenses shipped
//! in the repository's `data/lenses/`.
//!
//! **Four columns** (`.dat`, as physically based renderers read them), one row per interface from the
//! front element to the rear: radius of curvature (mm, 0 = flat), thickness to the next interface
//! (mm; the last row's is the design's distance to the film, which focusing replaces), index behind
//! the interface (0 or 1 = air), clear aperture *diameter* (mm). A row with radius 0 **and** index 0
//! is the aperture stop; radius 0 with an index ≥ 1 is a flat glass surface. `#` starts a comment.
//!
//! **JSON** (`.json`): an object with optional `"name"`, `"source"` and `"notes"` strings and a
//! `"surfaces"` array, front to rear; each surface is an object with
//!
//! | key | meaning | default |
//! |---|---|---|
//! | `radius` | radius of curvature, mm (0 = flat) | 0 |
//! | `thickness` | axial distance to the next surface, mm | required |
//! | `diameter` | clear aperture diameter, mm | required |
//! | `glass` | the medium behind the surface: `"air"`, a catalogue name (`"N-BK7"`), `{"n": 1.5}`, `{"nd": 1.67, "vd": 47.1}` or `{"sellmeier": {"b": [B1, B2, B3], "c": [C1, C2, C3]}}` (λ in µm) | air |
//! | `conic` | conic constant k | 0 |
//! | `asphere` | even terms `[A4, A6, …, A16]` (up to seven) | none |
//! | `stop` | `true` for the aperture stop (flat, in air) | false |
//! | `note` | free text | none |
//!
//! Unknown keys are errors (a misspelt `"conic"` must not silently make a sphere).

use std::path::Path;

use serde_json::Value;

use super::glass::{Glass, catalogue};
use super::surface::{ASPHERE_TERMS, Surface};

/// A lens: its interfaces from the front element (scene side) to the rear (film side).
#[derive(Debug, Clone, PartialEq)]
pub struct Prescription {
    /// A name for messages (the file name).
    pub name: String,
    /// Where the design comes from, as the file says.
    pub source: String,
    /// The interfaces, front to rear.
    pub surfaces: Vec<Surface>,
    /// The index of the aperture stop in `surfaces`.
    pub stop: usize,
}

/// The lenses shipped in `data/lenses/`, by name (file name without extension) and text.
pub const SHIPPED: &[(&str, &str)] = &[
    (
        "dgauss.50mm",
        include_str!("../../../../data/lenses/dgauss.50mm.json"),
    ),
    (
        "dgauss.50mm.dat",
        include_str!("../../../../data/lenses/dgauss.50mm.dat"),
    ),
    (
        "fisheye.10mm",
        include_str!("../../../../data/lenses/fisheye.10mm.json"),
    ),
    (
        "fisheye.10mm.dat",
        include_str!("../../../../data/lenses/fisheye.10mm.dat"),
    ),
    (
        "fisheye.16mm",
        include_str!("../../../../data/lenses/fisheye.16mm.json"),
    ),
    (
        "telephoto.250mm.dat",
        include_str!("../../../../data/lenses/telephoto.250mm.dat"),
    ),
    (
        "wide.100mm.dat",
        include_str!("../../../../data/lenses/wide.100mm.dat"),
    ),
    (
        "asphere.50mm",
        include_str!("../../../../data/lenses/asphere.50mm.json"),
    ),
    (
        "masterprime.100mm",
        include_str!("../../../../data/lenses/masterprime.100mm.json"),
    ),
];

impl Prescription {
    /// Reads `lens`: a file (`.json` is JSON, anything else four columns) or, when no such file
    /// exists, a shipped lens by name (`dgauss.50mm`, `dgauss.50mm.dat`, `fisheye.10mm`, …).
    ///
    /// # Errors
    /// A message naming the file, the line or surface, the field and what was expected.
    pub fn load(lens: &str) -> Result<Prescription, String> {
        let path = Path::new(lens);
        if path.exists() {
            let text = std::fs::read_to_string(path).map_err(|e| format!("{lens}: cannot read: {e}"))?;
            return Self::parse(lens, &text);
        }
        let key = lens.strip_suffix(".json").unwrap_or(lens);
        match SHIPPED.iter().find(|(n, _)| *n == key) {
            Some((n, text)) => Self::parse(if n.ends_with(".dat") { n } else { lens }, text),
            None => Err(format!(
                "{lens}: no such file, and no shipped lens of that name (shipped: {})",
                SHIPPED.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
            )),
        }
    }

    /// Parses `text` as JSON when it starts with `{`, else as four columns; `name` is for messages.
    ///
    /// # Errors
    /// As [`Prescription::load`].
    pub fn parse(name: &str, text: &str) -> Result<Prescription, String> {
        if text.trim_start().starts_with('{') {
            parse_json(name, text)
        } else {
            parse_columns(name, text)
        }
    }

    /// The sum of the thicknesses from the front vertex to the rear vertex, mm.
    #[must_use]
    pub fn track(&self) -> f64 {
        let n = self.surfaces.len();
        self.surfaces[..n - 1].iter().map(|s| s.thickness).sum()
    }

    /// True when some medium's index changes with wavelength.
    #[must_use]
    pub fn is_dispersive(&self) -> bool {
        self.surfaces.iter().any(|s| s.glass.is_dispersive())
    }
}

fn parse_columns(name: &str, text: &str) -> Result<Prescription, String> {
    const COLUMNS: [&str; 4] = ["radius", "thickness", "index", "aperture diameter"];
    let mut surfaces = Vec::new();
    let mut source = Vec::new();
    let mut lines = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if let Some(c) = line.strip_prefix('#') {
            // Comments are the design's source, but for the column headings.
            let c = c.trim().trim_matches('"').trim();
            if !c.to_ascii_lowercase().starts_with("radius") {
                source.push(c.to_string());
            }
            continue;
        }
        if line.is_empty() {
            continue;
        }
        let at = format!("{name}:{}", i + 1);
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.len() != 4 {
            return Err(format!(
                "{at}: expected 4 columns (radius, thickness, index, aperture diameter), found {}",
                fields.len()
            ));
        }
        let mut v = [0.0f64; 4];
        for (k, f) in fields.iter().enumerate() {
            v[k] = f.parse::<f64>().ok().filter(|x| x.is_finite()).ok_or_else(|| {
                format!(
                    "{at}: column {} ({}) = \"{f}\": expected a number",
                    k + 1,
                    COLUMNS[k]
                )
            })?;
        }
        let [radius, thickness, index, diameter] = v;
        let stop = radius == 0.0 && index == 0.0;
        if !(index == 0.0 || index >= 1.0) {
            return Err(format!(
                "{at}: column 3 (index) = {index}: expected 0 or 1 (air) or an index above 1"
            ));
        }
        let glass = if index <= 1.0 {
            Glass::AIR
        } else {
            Glass::Constant(index)
        };
        surfaces.push(Surface {
            radius,
            conic: 0.0,
            asphere: [0.0; ASPHERE_TERMS],
            thickness,
            glass,
            semi_aperture: 0.5 * diameter,
            stop,
        });
        lines.push(at);
    }
    finish(name, source.join(" / "), surfaces, &lines)
}

fn parse_json(name: &str, text: &str) -> Result<Prescription, String> {
    let root: Value = serde_json::from_str(text).map_err(|e| format!("{name}: not valid JSON: {e}"))?;
    let obj = root
        .as_object()
        .ok_or_else(|| format!("{name}: expected a JSON object with a \"surfaces\" array"))?;
    for key in obj.keys() {
        if !["name", "source", "surfaces", "notes"].contains(&key.as_str()) {
            return Err(format!(
                "{name}: unknown key \"{key}\" (expected \"name\", \"source\", \"notes\", \"surfaces\")"
            ));
        }
    }
    let source = obj
        .get("source")
        .and_then(Value::as_str)
        .unwrap_or("")
        .to_string();
    let list = obj
        .get("surfaces")
        .and_then(Value::as_array)
        .ok_or_else(|| format!("{name}: expected a \"surfaces\" array"))?;
    let mut surfaces = Vec::new();
    let mut lines = Vec::new();
    for (i, s) in list.iter().enumerate() {
        let at = format!("{name}: surfaces[{i}]");
        let o = s.as_object().ok_or_else(|| format!("{at}: expected an object"))?;
        const KEYS: [&str; 8] = [
            "radius",
            "thickness",
            "diameter",
            "glass",
            "conic",
            "asphere",
            "stop",
            "note",
        ];
        for key in o.keys() {
            if !KEYS.contains(&key.as_str()) {
                return Err(format!(
                    "{at}: unknown key \"{key}\" (expected one of {})",
                    KEYS.join(", ")
                ));
            }
        }
        let num = |key: &str, default: Option<f64>| -> Result<f64, String> {
            match o.get(key) {
                None => default.ok_or_else(|| format!("{at}: \"{key}\" is missing: expected a number (mm)")),
                Some(v) => v
                    .as_f64()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| format!("{at}: \"{key}\" = {v}: expected a number")),
            }
        };
        let stop = match o.get("stop") {
            None => false,
            Some(Value::Bool(b)) => *b,
            Some(v) => return Err(format!("{at}: \"stop\" = {v}: expected true or false")),
        };
        let mut asphere = [0.0; ASPHERE_TERMS];
        if let Some(a) = o.get("asphere") {
            let arr = a.as_array().filter(|a| a.len() <= ASPHERE_TERMS).ok_or_else(|| {
                format!("{at}: \"asphere\" = {a}: expected an array of up to 7 numbers [A4, …, A16]")
            })?;
            for (k, x) in arr.iter().enumerate() {
                asphere[k] = x
                    .as_f64()
                    .ok_or_else(|| format!("{at}: \"asphere\"[{k}] = {x}: expected a number"))?;
            }
        }
        let glass = match o.get("glass") {
            None => Glass::AIR,
            Some(g) => parse_glass(&at, g)?,
        };
        surfaces.push(Surface {
            radius: num("radius", Some(0.0))?,
            conic: num("conic", Some(0.0))?,
            asphere,
            thickness: num("thickness", None)?,
            glass,
            semi_aperture: 0.5 * num("diameter", None)?,
            stop,
        });
        lines.push(at);
    }
    finish(name, source, surfaces, &lines)
}

fn parse_glass(at: &str, g: &Value) -> Result<Glass, String> {
    let expected = "expected \"air\", a catalogue name, {\"n\": …}, {\"nd\": …, \"vd\": …} or {\"sellmeier\": {\"b\": […], \"c\": […]}}";
    match g {
        Value::String(s) if s.eq_ignore_ascii_case("air") => Ok(Glass::AIR),
        Value::String(s) => catalogue(s).map(|c| c.glass()).ok_or_else(|| {
            format!(
                "{at}: \"glass\" = \"{s}\" is not in the built-in catalogue ({})",
                super::glass::CATALOGUE
                    .iter()
                    .map(|c| c.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        }),
        Value::Object(o) => {
            let f = |k: &str| o.get(k).and_then(Value::as_f64).filter(|x| x.is_finite());
            if let Some(n) = f("n") {
                if n < 1.0 {
                    return Err(format!(
                        "{at}: glass \"n\" = {n}: expected an index of at least 1"
                    ));
                }
                Ok(Glass::Constant(n))
            } else if let (Some(nd), Some(vd)) = (f("nd"), f("vd")) {
                if nd <= 1.0 || vd <= 0.0 {
                    return Err(format!(
                        "{at}: glass nd = {nd}, vd = {vd}: expected nd > 1 and vd > 0"
                    ));
                }
                Ok(Glass::from_abbe(nd, vd))
            } else if let Some(s) = o.get("sellmeier").and_then(Value::as_object) {
                let three = |k: &str| -> Option<[f64; 3]> {
                    let a = s.get(k)?.as_array()?;
                    if a.len() != 3 {
                        return None;
                    }
                    Some([a[0].as_f64()?, a[1].as_f64()?, a[2].as_f64()?])
                };
                match (three("b"), three("c")) {
                    (Some(b), Some(c)) => {
                        let glass = Glass::Sellmeier { b, c };
                        let nd = glass.nd();
                        if !(nd.is_finite() && nd >= 1.0) {
                            return Err(format!(
                                "{at}: the Sellmeier coefficients give nd = {nd}: expected ≥ 1"
                            ));
                        }
                        Ok(glass)
                    }
                    _ => Err(format!(
                        "{at}: \"sellmeier\" needs \"b\" and \"c\", three numbers each"
                    )),
                }
            } else {
                Err(format!("{at}: \"glass\" = {g}: {expected}"))
            }
        }
        _ => Err(format!("{at}: \"glass\" = {g}: {expected}")),
    }
}

/// Checks a parsed lens: one stop, positive thicknesses and apertures, apertures inside each sphere.
fn finish(
    name: &str,
    source: String,
    surfaces: Vec<Surface>,
    lines: &[String],
) -> Result<Prescription, String> {
    if surfaces.len() < 2 {
        return Err(format!(
            "{name}: a lens needs at least two surfaces, found {}",
            surfaces.len()
        ));
    }
    let stops: Vec<usize> = (0..surfaces.len()).filter(|&i| surfaces[i].stop).collect();
    let stop = match stops.as_slice() {
        [s] => *s,
        [] => {
            return Err(format!(
                "{name}: no aperture stop (a row with radius 0 and index 0, or \"stop\": true)"
            ));
        }
        _ => {
            return Err(format!(
                "{name}: {} aperture stops ({}): expected exactly one",
                stops.len(),
                stops
                    .iter()
                    .map(|&i| lines[i].clone())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
    };
    let last = surfaces.len() - 1;
    for (i, s) in surfaces.iter().enumerate() {
        let at = &lines[i];
        if s.semi_aperture.is_nan() || s.semi_aperture <= 0.0 {
            return Err(format!(
                "{at}: aperture diameter {}: expected a positive number (mm)",
                2.0 * s.semi_aperture
            ));
        }
        if s.thickness < 0.0 || (i < last && s.thickness == 0.0 && s.glass != Glass::AIR) {
            return Err(format!(
                "{at}: thickness {}: expected a positive distance (mm)",
                s.thickness
            ));
        }
        if s.stop && (s.radius != 0.0 || s.glass.nd() != 1.0) {
            return Err(format!("{at}: the aperture stop must be flat and in air"));
        }
        if s.is_spherical() && s.radius != 0.0 && s.semi_aperture > s.radius.abs() {
            return Err(format!(
                "{at}: aperture radius {} mm exceeds the radius of curvature {} mm: no sphere is that wide",
                s.semi_aperture,
                s.radius.abs()
            ));
        }
        if s.sag(s.semi_aperture * s.semi_aperture).is_none() {
            return Err(format!(
                "{at}: the conic (k = {}) does not reach the aperture radius {} mm",
                s.conic, s.semi_aperture
            ));
        }
    }
    if stop > 0 && surfaces[stop - 1].glass.nd() != 1.0 {
        return Err(format!(
            "{}: the aperture stop must be in air (the medium before it is glass)",
            lines[stop]
        ));
    }
    Ok(Prescription {
        name: name.to_string(),
        source,
        surfaces,
        stop,
    })
}
