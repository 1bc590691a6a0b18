//! Wavefront OBJ reader (through `tobj`), with the `.mtl` material libraries it names.
//!
//! Every object (or each run of faces under one `usemtl`) becomes one [`Object`] with [`Shape::Mesh`]
//! (polygons fan-triangulated, one index per vertex) and the identity transform. Points and lines are
//! dropped. There is no camera or light in OBJ: the scene records its bounds and that it is unlit
//! ([`Scene::auto_camera`], [`Scene::auto_light`]), and the renderer's staging frames and lights it.
//!
//! `tobj` reports no line numbers and trusts some of its input, so the text is checked first (face
//! indices against the vertices the file declares, colour statements of the material library) and fed
//! to `tobj` through a reader that knows which line it is on: every error names the file and, where
//! there is one, the line, and no input panics.

use std::cell::{Cell, RefCell};
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use obscura_host::CameraDesc;
use obscura_sdk::Rgb;

use crate::convert::grow_bounds;
use crate::types::{Identity, Material, Mesh, MotionTransform, Object, Scene, Shape};

mod maps;

/// An OBJ file (or a material library it names) could not be loaded. Every message starts with the
/// file's path, and with the line when one is known.
#[derive(Debug, thiserror::Error)]
pub enum ObjError {
    /// The file could not be read.
    #[error("cannot read OBJ file {}: {source}", .path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A statement is malformed: a number that does not parse, a face index out of range, a material
    /// colour with the wrong number of values. `path` is the `.obj` or the `.mtl`.
    #[error("{}:{line}: {what}", .path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// The line, counted from 1.
        line: usize,
        /// What is wrong.
        what: String,
    },
    /// The file is inconsistent in a way no single line shows.
    #[error("{}: {what}", .path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
}

/// Loads a Wavefront OBJ file into a [`Scene`] for `camera`.
///
/// `camera` supplies format, windows, shutter and clipping. OBJ has no camera and no light: the
/// geometry's bounds go to [`Scene::auto_camera`] and [`Scene::auto_light`] is set, for the renderer's
/// staging to frame (a 45° `PxrPerspective` the CLI may override) and light the scene.
///
/// Materials from the `mtllib` files, appended after the default material 0 in the order read:
/// non-zero `Ke` gives [`Material::Constant`]; non-zero `Ks` gives [`Material::Surface`] with `Kd` as
/// the diffuse colour, `Ks` as F0 and the roughness of the Blinn–Phong exponent `Ns`: Walter et al.'s
/// Beckmann width `α = sqrt(2/(Ns + 2))`, and since our roughness is perceptual (α = roughness²),
/// `roughness = (2/(Ns + 2))^¼`; otherwise [`Material::Diffuse`] of `Kd` (0.18 grey when absent). A
/// `Kd r` with one value means grey `r r r`, as the MTL specification says. Texture maps are ignored
/// with one warning. A material library that cannot be read, or a `usemtl` naming no known material,
/// gives a warning and the default material.
///
/// # Errors
/// An [`ObjError`] naming the file (and the line): unreadable, not UTF-8, a statement `tobj` cannot
/// parse, a face index of 0 or outside the vertices, normals or texture coordinates declared, a
/// malformed material library.
pub fn load_obj(path: &Path, camera: CameraDesc) -> Result<Scene, ObjError> {
    let bytes = std::fs::read(path).map_err(|source| ObjError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let (text, latin1_line) = text_of(&bytes);
    let text = &*text;
    let usemtl = check_faces(path, text)?;
    let file = path.display().to_string();
    let Parsed {
        models,
        materials,
        libraries,
    } = parse(path, text)?;

    let mut scene = Scene::new(camera);
    if let Some(line) = latin1_line {
        scene.warnings.push(format!(
            "{file}:{line}: not UTF-8 text; the file is read as Latin-1 (ISO 8859-1)"
        ));
    }
    scene.warnings.extend(unknown_statements(&file, text));
    read_materials(&mut scene, &file, &libraries, &materials, usemtl);
    let mut bounds = None;
    for model in models {
        if let Some(object) = model_object(path, &file, model, materials.len(), &mut scene.warnings)? {
            if let Shape::Mesh(mesh) = &object.shape {
                for &p in &mesh.positions {
                    grow_bounds(&mut bounds, p);
                }
            }
            scene.objects.push(object);
        }
    }
    if scene.objects.is_empty() {
        scene
            .warnings
            .push(format!("{file}: no faces; the scene has no geometry"));
    }
    scene.auto_camera = Some(bounds.unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0))));
    scene.auto_light = scene.lights.is_empty();
    Ok(scene)
}

/// Runs `tobj` over the checked text through a [`LineReader`], loading material libraries beside the
/// file. A malformed library is reported before what it may have caused.
fn parse(path: &Path, text: &str) -> Result<Parsed, ObjError> {
    let base = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let pos = Cell::new(0);
    let mut reader = LineReader {
        data: text.as_bytes(),
        pos: &pos,
    };
    let libraries: RefCell<Vec<Library>> = RefCell::new(Vec::new());
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let loaded = tobj::load_obj_buf(&mut reader, &options, |name| {
        let library = Library::load(base.join(name), line_at(text.as_bytes(), pos.get()));
        let result = library.result.clone();
        libraries.borrow_mut().push(library);
        result
    });
    let libraries = libraries.into_inner();
    for library in &libraries {
        if let LibraryState::Malformed { line, what } = &library.state {
            return Err(ObjError::Parse {
                path: library.path.clone(),
                line: *line,
                what: what.clone(),
            });
        }
    }
    let (models, materials) = loaded.map_err(|e| ObjError::Parse {
        path: path.to_path_buf(),
        line: line_at(text.as_bytes(), pos.get()),
        what: e.to_string(),
    })?;
    Ok(Parsed {
        models,
        materials: materials.unwrap_or_default(),
        libraries,
    })
}

/// What `tobj` read from a file.
struct Parsed {
    /// The objects (or runs of faces under one `usemtl`).
    models: Vec<tobj::Model>,
    /// The materials of every library that loaded.
    materials: Vec<tobj::Material>,
    /// Every material library the file named, loaded or not.
    libraries: Vec<Library>,
}

/// Appends the materials after the default one, warning about unreadable libraries, textures and
/// `usemtl` names (at their lines) that no library defines.
fn read_materials(
    scene: &mut Scene,
    file: &str,
    libraries: &[Library],
    materials: &[tobj::Material],
    usemtl: Vec<(usize, String)>,
) {
    for library in libraries {
        if let Some(line) = library.latin1 {
            scene.warnings.push(format!(
                "{}:{line}: not UTF-8 text; the material library is read as Latin-1 (ISO 8859-1)",
                library.path.display()
            ));
        }
        if let LibraryState::Unreadable { what } = &library.state {
            scene.warnings.push(format!(
                "{file}:{}: cannot read material library {}: {what}; its materials fall back to the default",
                library.line,
                library.path.display()
            ));
        }
    }
    let base = match Path::new(file).parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    for m in materials {
        let index = scene.materials.len() as u32;
        scene.materials.push(convert_material(m));
        let roughness = roughness_from_ns(m.shininess.unwrap_or(0.0));
        if let Some(maps) = maps::material_maps(scene, file, &base, m, roughness) {
            scene.material_maps.insert(index, maps);
        }
    }
    if libraries.iter().all(|l| matches!(l.state, LibraryState::Loaded)) {
        for (line, name) in usemtl {
            if !materials.iter().any(|m| m.name == name) {
                scene.warnings.push(format!(
                    "{file}:{line}: usemtl \"{name}\": no such material; the default is used"
                ));
            }
        }
    }
}

/// One `tobj` model as an object with the identity transform; `None` when it has no triangle.
fn model_object(
    path: &Path,
    file: &str,
    model: tobj::Model,
    materials: usize,
    warnings: &mut Vec<String>,
) -> Result<Option<Object>, ObjError> {
    let m = model.mesh;
    let positions: Vec<Vec3> = m
        .positions
        .chunks_exact(3)
        .map(|p| Vec3::new(p[0], p[1], p[2]))
        .collect();
    if m.indices.len() < 3 {
        return Ok(None);
    }
    if let Some(&i) = m.indices.iter().find(|&&i| i as usize >= positions.len()) {
        return Err(ObjError::Invalid {
            path: path.to_path_buf(),
            what: format!(
                "object \"{}\": vertex index {i} out of range ({} vertices)",
                model.name,
                positions.len()
            ),
        });
    }
    let normals = if m.normals.len() == m.positions.len() {
        Some(
            m.normals
                .chunks_exact(3)
                .map(|n| Vec3::new(n[0], n[1], n[2]))
                .collect(),
        )
    } else {
        if !m.normals.is_empty() {
            warnings.push(format!(
                "{file}: object \"{}\": only some vertices have normals; normals ignored",
                model.name
            ));
        }
        None
    };
    let n = positions.len();
    let uvs = if m.texcoords.len() == 2 * n {
        vec![
            m.texcoords
                .chunks_exact(2)
                .map(|t| Vec2::new(t[0], 1.0 - t[1]))
                .collect(),
        ]
    } else {
        Vec::new()
    };
    let colors = (m.vertex_color.len() == 3 * n).then(|| {
        m.vertex_color
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2], 1.0])
            .collect()
    });
    let material = match m.material_id {
        Some(i) if i < materials => u32::try_from(i + 1).unwrap_or(0),
        _ => 0,
    };
    Ok(Some(Object {
        shape: Shape::Mesh(Mesh {
            positions,
            normals,
            triangles: m.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
            uvs,
            colors,
        }),
        transform: MotionTransform::default(),
        material,
        micropolygon_length: 1.0,
        source: format!("{file}: object \"{}\"", model.name),
        sides: Default::default(),
        visibility: Default::default(),
        identity: Identity {
            object: model.name.clone(),
            instance: model.name.clone(),
        },
    }))
}

/// The line (from 1) holding byte `pos`, or the line just ended when `pos` follows its newline: where
/// a line-by-line parser that has consumed `data[..pos]` stopped.
fn line_at(data: &[u8], pos: usize) -> usize {
    let pos = pos.min(data.len());
    let newlines = data[..pos].iter().filter(|&&b| b == b'\n').count();
    if pos > 0 && data[pos - 1] == b'\n' {
        newlines
    } else {
        newlines + 1
    }
}

/// The text of an OBJ or MTL file: UTF-8 when it is, else Latin-1 (every byte one character, as
/// older exporters wrote names), with the first line that is not UTF-8.
fn text_of(bytes: &[u8]) -> (std::borrow::Cow<'_, str>, Option<usize>) {
    match std::str::from_utf8(bytes) {
        Ok(t) => (t.into(), None),
        Err(e) => (
            bytes.iter().map(|&b| char::from(b)).collect::<String>().into(),
            Some(line_at(bytes, e.valid_up_to() + 1)),
        ),
    }
}

/// A `BufRead` over text that publishes how far it has been read, so the line `tobj` failed on (or
/// asked for a material library on) can be named.
struct LineReader<'a> {
    data: &'a [u8],
    pos: &'a Cell<usize>,
}

impl Read for LineReader<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let rest = self.fill_buf()?;
        let n = rest.len().min(buf.len());
        buf[..n].copy_from_slice(&rest[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl BufRead for LineReader<'_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        Ok(self.data.get(self.pos.get()..).unwrap_or_default())
    }

    fn consume(&mut self, amt: usize) {
        self.pos.set((self.pos.get() + amt).min(self.data.len()));
    }
}

/// Checks every face and line index before `tobj` sees it (it would overflow on a texture or normal
/// index of 0, or on one far out of range): an index must not be 0, a negative (relative) one must not
/// reach before the first element declared so far, a positive one must not exceed those the file
/// declares. Returns the `usemtl` statements `(line, name)`.
/// Every statement keyword of the OBJ and its free-form-geometry extensions (Wavefront's appendix B1).
const OBJ_STATEMENTS: [&str; 42] = [
    "v",
    "vt",
    "vn",
    "vp",
    "f",
    "fo",
    "l",
    "p",
    "o",
    "g",
    "s",
    "mg",
    "usemtl",
    "mtllib",
    "usemap",
    "maplib",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "bevel",
    "c_interp",
    "d_interp",
    "lod",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "call",
    "csh",
    "res",
    "bsp",
];

/// One warning per statement keyword OBJ does not have (`zz 1 2`), naming its first line and how
/// often it occurs; such lines are ignored, as tobj ignores them.
fn unknown_statements(file: &str, text: &str) -> Vec<String> {
    let mut seen: Vec<(String, usize, usize)> = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let Some(word) = line.split_whitespace().next() else {
            continue;
        };
        if word.starts_with('#') || OBJ_STATEMENTS.contains(&word) {
            continue;
        }
        match seen.iter_mut().find(|(w, _, _)| w == word) {
            Some(entry) => entry.2 += 1,
            None => seen.push((word.to_string(), n + 1, 1)),
        }
    }
    seen.into_iter()
        .map(|(word, line, count)| {
            let more = if count > 1 {
                format!(" ({count} lines)")
            } else {
                String::new()
            };
            let shown: String = word.chars().take(40).collect();
            format!("{file}:{line}: unknown OBJ statement \"{shown}\"{more}, ignored")
        })
        .collect()
}

fn check_faces(path: &Path, text: &str) -> Result<Vec<(usize, String)>, ObjError> {
    const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let keyword = |line: &str| line.split_whitespace().next().map(str::to_owned);
    let mut total = [0usize; 3];
    for line in text.lines() {
        match keyword(line).as_deref() {
            Some("v") => total[0] += 1,
            Some("vt") => total[1] += 1,
            Some("vn") => total[2] += 1,
            _ => {}
        }
    }
    let mut so_far = [0usize; 3];
    let mut usemtl = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let bad = |what: String| ObjError::Parse {
            path: path.to_path_buf(),
            line: n + 1,
            what,
        };
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => so_far[0] += 1,
            Some("vt") => so_far[1] += 1,
            Some("vn") => so_far[2] += 1,
            Some("usemtl") => {
                let name = line.split_once(' ').unwrap_or_default().1.trim();
                if !name.is_empty() {
                    usemtl.push((n + 1, name.to_owned()));
                }
            }
            Some("f") | Some("l") => {
                for corner in words {
                    for (k, part) in corner.split('/').enumerate().take(3) {
                        // Unparsable parts are left to tobj, which reports them.
                        let Ok(x) = part.parse::<isize>() else { continue };
                        if x == 0 {
                            return Err(bad(format!(
                                "{} index 0 in \"{corner}\" (OBJ indices start at 1)",
                                KINDS[k]
                            )));
                        }
                        if x < 0 && x.unsigned_abs() > so_far[k] {
                            return Err(bad(format!(
                                "relative {} index {x} in \"{corner}\" reaches before the first one ({} declared so far)",
                                KINDS[k], so_far[k]
                            )));
                        }
                        if x > 0 && x.unsigned_abs() > total[k] {
                            return Err(bad(format!(
                                "{} index {x} in \"{corner}\" is out of range: the file declares {}",
                                KINDS[k], total[k]
                            )));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(usemtl)
}

/// What became of one `mtllib`.
struct Library {
    /// The library's path.
    path: PathBuf,
    /// The OBJ line that named it.
    line: usize,
    state: LibraryState,
    /// What is handed back to `tobj`.
    result: tobj::MTLLoadResult,
    /// The first line that is not UTF-8, when the library was read as Latin-1.
    latin1: Option<usize>,
}

enum LibraryState {
    Loaded,
    Unreadable { what: String },
    Malformed { line: usize, what: String },
}

impl Library {
    fn load(path: PathBuf, line: usize) -> Library {
        let failed = |state, error| Library {
            path: path.clone(),
            line,
            state,
            result: Err(error),
            latin1: None,
        };
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) => {
                return failed(
                    LibraryState::Unreadable { what: e.to_string() },
                    tobj::LoadError::OpenFileFailed,
                );
            }
        };
        let (text, latin1) = text_of(&bytes);
        let text = match normalise_mtl(&text) {
            Ok(t) => t,
            Err((line, what)) => {
                return failed(
                    LibraryState::Malformed { line, what },
                    tobj::LoadError::MaterialParseError,
                );
            }
        };
        let pos = Cell::new(0);
        let mut reader = LineReader {
            data: text.as_bytes(),
            pos: &pos,
        };
        match tobj::load_mtl_buf(&mut reader) {
            Ok(ok) => Library {
                path,
                line,
                state: LibraryState::Loaded,
                result: Ok(ok),
                latin1,
            },
            Err(e) => {
                let state = LibraryState::Malformed {
                    line: line_at(text.as_bytes(), pos.get()),
                    what: e.to_string(),
                };
                failed(state, e)
            }
        }
    }
}

/// Rewrites a material library line for line so `tobj` can take it: `Ka`/`Kd`/`Ks`/`Ke` with one value
/// becomes that grey (`tobj` would panic on fewer than three); two values, or none, are an error
/// `(line, what)`.
fn normalise_mtl(text: &str) -> Result<String, (usize, String)> {
    let mut out = String::with_capacity(text.len() + 64);
    for (n, line) in text.lines().enumerate() {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            [key @ ("Ka" | "Kd" | "Ks" | "Ke"), grey] => {
                out.push_str(&format!("{key} {grey} {grey} {grey}"));
            }
            [key @ ("Ka" | "Kd" | "Ks" | "Ke")] | [key @ ("Ka" | "Kd" | "Ks" | "Ke"), _, _] => {
                return Err((
                    n + 1,
                    format!(
                        "{key} needs three numbers (r g b), or one for a grey; got {}",
                        words.len() - 1
                    ),
                ));
            }
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    Ok(out)
}

/// One MTL material as ours (see [`load_obj`]).
fn convert_material(m: &tobj::Material) -> Material {
    let colour = |c: [f32; 3]| Vec3::from(c).map(|x| if x.is_finite() { x.max(0.0) } else { 0.0 });
    let rgb = |v: Vec3| Rgb::new(v.x, v.y, v.z);
    let emissive = m.emissive.map(colour).unwrap_or(Vec3::ZERO);
    let specular = m.specular.map(colour).unwrap_or(Vec3::ZERO);
    let diffuse = m.diffuse.map(colour).unwrap_or(Vec3::splat(0.18));
    if emissive.max_element() > 0.0 {
        Material::Constant { color: rgb(emissive) }
    } else if specular.max_element() > 0.0 {
        Material::Surface {
            diffuse: rgb(diffuse),
            specular: rgb(specular),
            roughness: roughness_from_ns(m.shininess.unwrap_or(0.0)),
        }
    } else {
        Material::Diffuse { color: rgb(diffuse) }
    }
}

/// Perceptual GGX roughness for a Blinn–Phong exponent: `α = sqrt(2/(Ns + 2))` (Walter et al. 2007),
/// `roughness = sqrt(α)`. `Ns` below 0 (or not finite) is taken as 0, giving roughness 1.
fn roughness_from_ns(ns: f32) -> f32 {
    let ns = if ns.is_finite() { ns.max(0.0) } else { 0.0 };
    (2.0 / (ns + 2.0)).sqrt().sqrt()
}

#[cfg(test)]
mod tests;
