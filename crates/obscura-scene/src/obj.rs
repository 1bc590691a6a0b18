//! Wavefront OBJ reader (through `tobj`), with the `.mtl` material libraries it names.
//!
//! Every object (or each run of faces under one `usemtl`) becomes one [`Object`] with [`Shape::Mesh`]
//! (polygons fan-triangulated, one index per vertex) and the identity transform. Points and lines are
//! dropped. There is no camera or light in OBJ: the camera frames the geometry with
//! [`crate::gltf_scene::frame_bounds`] and a 45° `PxrPerspective`, and a white dome lights the scene.
//!
//! `tobj` reports no line numbers and trusts some of its input, so the text is checked first (face
//! indices against the vertices the file declares, colour statements of the material library) and fed
//! to `tobj` through a reader that knows which line it is on: every error names the file and, where
//! there is one, the line, and no input panics.

use std::cell::{Cell, RefCell};
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

use glam::Vec3;
use obscura_host::CameraDesc;
use obscura_sdk::Rgb;

use crate::framing::{add_default_dome_if_unlit, frame_scene, grow_bounds};
use crate::types::{Material, Mesh, MotionTransform, Object, Scene, Shape};

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
/// `camera` supplies format, windows, shutter and clipping; its `world_to_camera` is replaced by
/// [`crate::gltf_scene::frame_bounds`] of the geometry's bounds with a 45° field of view, and the
/// projection set to `PxrPerspective` with `"float fov" [45]` (the CLI may override both).
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
    let text = utf8(path, &bytes)?;
    let usemtl = check_faces(path, text)?;
    let file = path.display().to_string();
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
    // A broken library is reported before what it may have caused.
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

    let mut scene = Scene::new(camera);
    for library in &libraries {
        if let LibraryState::Unreadable { what } = &library.state {
            scene.warnings.push(format!(
                "{file}:{}: cannot read material library {}: {what}; its materials fall back to the default",
                library.line,
                library.path.display()
            ));
        }
    }
    let materials = materials.unwrap_or_default();
    let mut textured = None;
    for m in &materials {
        if textured.is_none() && uses_texture(m) {
            textured = Some(m.name.clone());
        }
        scene.materials.push(convert_material(m));
    }
    if let Some(name) = textured {
        scene.warnings.push(format!(
            "{file}: texture maps are ignored (material \"{name}\" is the first to use one); only the colours are read"
        ));
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

    let mut bounds = None;
    for model in models {
        let m = model.mesh;
        let positions: Vec<Vec3> = m
            .positions
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect();
        if m.indices.len() < 3 {
            continue;
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
                scene.warnings.push(format!(
                    "{file}: object \"{}\": only some vertices have normals; normals ignored",
                    model.name
                ));
            }
            None
        };
        for &p in &positions {
            grow_bounds(&mut bounds, p);
        }
        let material = match m.material_id {
            Some(i) if i < materials.len() => u32::try_from(i + 1).unwrap_or(0),
            _ => 0,
        };
        scene.objects.push(Object {
            shape: Shape::Mesh(Mesh {
                positions,
                normals,
                triangles: m.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
            }),
            transform: MotionTransform::default(),
            material,
            micropolygon_length: 1.0,
            source: format!("{file}: object \"{}\"", model.name),
        });
    }
    if scene.objects.is_empty() {
        scene
            .warnings
            .push(format!("{file}: no faces; the scene has no geometry"));
    }
    frame_scene(&mut scene, bounds, &file);
    add_default_dome_if_unlit(&mut scene, &file);
    Ok(scene)
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

fn utf8<'a>(path: &Path, bytes: &'a [u8]) -> Result<&'a str, ObjError> {
    std::str::from_utf8(bytes).map_err(|e| ObjError::Parse {
        path: path.to_path_buf(),
        line: line_at(bytes, e.valid_up_to() + 1),
        what: "not UTF-8 text".into(),
    })
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
        let text = match std::str::from_utf8(&bytes) {
            Ok(t) => t,
            Err(e) => {
                let line = line_at(&bytes, e.valid_up_to() + 1);
                let what = "not UTF-8 text".to_owned();
                return failed(LibraryState::Malformed { line, what }, tobj::LoadError::ReadError);
            }
        };
        let text = match normalise_mtl(text) {
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

fn uses_texture(m: &tobj::Material) -> bool {
    m.diffuse_texture.is_some()
        || m.ambient_texture.is_some()
        || m.specular_texture.is_some()
        || m.normal_texture.is_some()
        || m.shininess_texture.is_some()
        || m.dissolve_texture.is_some()
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
mod tests {
    use super::*;
    use obscura_sdk::{Format, ParamValue};

    use crate::types::Light;

    const CUBE: &str = "\
# a unit cube, two materials
mtllib cube.mtl
o cube
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
vn 0 0 -1
vn 0 0 1
vn 0 -1 0
vn 0 1 0
vn -1 0 0
vn 1 0 0
usemtl red
f 1//1 4//1 3//1 2//1
f 5//2 6//2 7//2 8//2
f 1//3 2//3 6//3 5//3
usemtl shiny
f 4//4 8//4 7//4 3//4
f 1//5 5//5 8//5 4//5
f 2//6 3//6 7//6 6//6
";

    const MTL: &str = "\
newmtl red
Kd 0.8 0.1 0.1

newmtl shiny
Kd 0.2 0.2 0.2
Ks 0.5 0.5 0.5
Ns 98

newmtl lamp
Ke 4 4 3
";

    fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    fn camera() -> CameraDesc {
        CameraDesc::new(Format::new(640, 480))
    }

    fn load_cube(mtl: Option<&str>) -> Scene {
        let dir = tempfile::tempdir().unwrap();
        if let Some(mtl) = mtl {
            write(&dir, "cube.mtl", mtl);
        }
        load_obj(&write(&dir, "cube.obj", CUBE), camera()).unwrap()
    }

    fn meshes(scene: &Scene) -> Vec<&Mesh> {
        scene
            .objects
            .iter()
            .map(|o| match &o.shape {
                Shape::Mesh(m) => m,
                other => panic!("not a mesh: {other:?}"),
            })
            .collect()
    }

    #[test]
    fn obj_cube_has_twelve_triangles_with_normals() {
        let scene = load_cube(Some(MTL));
        let meshes = meshes(&scene);
        assert_eq!(meshes.iter().map(|m| m.triangles.len()).sum::<usize>(), 12);
        for m in &meshes {
            let n = m.normals.as_ref().expect("normals");
            assert_eq!(n.len(), m.positions.len());
            // Each triangle's winding agrees with its normal up to sign, and the normal is axial.
            for t in &m.triangles {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                let face = (b - a).cross(c - a);
                assert!(face.length() > 0.0);
                assert!((face.normalize().dot(n[t[0] as usize]).abs() - 1.0).abs() < 1e-6);
            }
        }
        assert!(
            scene
                .objects
                .iter()
                .all(|o| o.transform == MotionTransform::default())
        );
        assert!(scene.objects[0].source.contains("cube.obj"));
    }

    #[test]
    fn obj_mtl_materials_map_to_diffuse_surface_and_constant() {
        let scene = load_cube(Some(MTL));
        assert_eq!(scene.materials.len(), 4);
        assert_eq!(
            scene.materials[1],
            Material::Diffuse {
                color: Rgb::new(0.8, 0.1, 0.1)
            }
        );
        let Material::Surface {
            diffuse,
            specular,
            roughness,
        } = scene.materials[2]
        else {
            panic!("{:?}", scene.materials[2])
        };
        assert_eq!(
            (diffuse, specular),
            (Rgb::new(0.2, 0.2, 0.2), Rgb::new(0.5, 0.5, 0.5))
        );
        // Ns 98 is a Beckmann α of sqrt(2/100); our roughness is sqrt(α).
        assert!(
            (roughness * roughness - 0.02f32.sqrt()).abs() < 1e-6,
            "{roughness}"
        );
        assert_eq!(
            scene.materials[3],
            Material::Constant {
                color: Rgb::new(4.0, 4.0, 3.0)
            }
        );
        // Three faces (six triangles) each.
        let mut by_material = [0; 4];
        for (o, m) in scene.objects.iter().zip(meshes(&scene)) {
            by_material[o.material as usize] += m.triangles.len();
        }
        assert_eq!(by_material, [0, 6, 6, 0]);
        assert!(
            scene.warnings.iter().all(|w| !w.contains("material")),
            "{:?}",
            scene.warnings
        );
    }

    #[test]
    fn obj_single_value_colour_is_grey() {
        let scene = load_cube(Some("newmtl red\nKd 0.5\n"));
        assert_eq!(
            scene.materials[1],
            Material::Diffuse {
                color: Rgb::new(0.5, 0.5, 0.5)
            }
        );
        assert!(
            scene
                .warnings
                .iter()
                .any(|w| w.contains("usemtl \"shiny\"") && w.contains("cube.obj:22:"))
        );
    }

    #[test]
    fn obj_missing_mtl_warns_and_uses_the_default_material() {
        let scene = load_cube(None);
        assert_eq!(scene.materials, vec![Material::default()]);
        assert!(scene.objects.iter().all(|o| o.material == 0));
        assert!(
            scene
                .warnings
                .iter()
                .any(|w| w.contains("cube.obj:2") && w.contains("cube.mtl")),
            "{:?}",
            scene.warnings
        );
    }

    #[test]
    fn obj_camera_frames_every_corner_of_the_bounds() {
        let scene = load_cube(Some(MTL));
        assert_eq!(scene.projection, "PxrPerspective");
        let fov = match &scene.projection_params.get("fov").unwrap().value {
            ParamValue::Floats(v) => v[0],
            other => panic!("{other:?}"),
        };
        assert_eq!(fov, 45.0);
        let m = scene.camera.world_to_camera[0].world_to_camera;
        let t = (0.5 * fov.to_radians()).tan() * (1.0 + 1e-4);
        for i in 0..8 {
            let corner = obscura_sdk::Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32);
            let c = m.transform_point(corner);
            assert!(
                c.z > 0.0 && (c.x / c.z).abs() <= t && (c.y / c.z).abs() <= t,
                "{corner:?} → {c:?}"
            );
        }
    }

    #[test]
    fn obj_gets_a_default_dome_light() {
        let scene = load_cube(Some(MTL));
        assert!(matches!(
            scene.lights.as_slice(),
            [Light::Dome {
                intensity: 1.0,
                map: None,
                ..
            }]
        ));
        assert!(scene.warnings.iter().any(|w| w.contains("dome")));
    }

    fn error_of(obj: &str, mtl: Option<&str>) -> String {
        let dir = tempfile::tempdir().unwrap();
        if let Some(mtl) = mtl {
            write(&dir, "cube.mtl", mtl);
        }
        load_obj(&write(&dir, "bad.obj", obj), camera())
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn obj_malformed_numbers_are_errors_naming_file_and_line() {
        let e = error_of("v 0 0 0\nv 1 0 0\nv 1 x 0\nf 1 2 3\n", None);
        assert!(e.contains("bad.obj:3:") && e.contains("position"), "{e}");
        // The last line without a newline.
        let e = error_of("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 q", None);
        assert!(e.contains("bad.obj:4:") && e.contains("face"), "{e}");
    }

    #[test]
    fn obj_face_indices_out_of_range_are_errors_not_panics() {
        for (face, what) in [
            ("f 1 2 4", "vertex index 4"),
            ("f 0 1 2", "index 0"),
            ("f 1/0/1 2/1/1 3/1/1", "texture coordinate index 0"),
            ("f 1//0 2//1 3//1", "normal index 0"),
            ("f 1//9223372036854775807 2//1 3//1", "out of range"),
            ("f -4 -2 -1", "reaches before"),
            ("f 1//-2 2//1 3//1", "reaches before"),
        ] {
            let obj = format!("v 0 0 0\nv 1 0 0\nvt 0 0\nv 0 1 0\nvn 0 0 1\n{face}\n");
            let e = error_of(&obj, None);
            assert!(e.contains("bad.obj:6:") && e.contains(what), "{face}: {e}");
        }
        // Relative indices inside the range are fine.
        let dir = tempfile::tempdir().unwrap();
        let scene = load_obj(
            &write(&dir, "rel.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"),
            camera(),
        )
        .unwrap();
        assert_eq!(meshes(&scene)[0].triangles.len(), 1);
    }

    #[test]
    fn obj_malformed_mtl_is_an_error_naming_the_mtl_and_line() {
        let e = error_of(CUBE, Some("newmtl red\nKd 0.5 0.5\n"));
        assert!(e.contains("cube.mtl:2:") && e.contains("Kd"), "{e}");
        let e = error_of(CUBE, Some("newmtl red\n\nNs lots\n"));
        assert!(e.contains("cube.mtl:3:"), "{e}");
    }

    #[test]
    fn obj_missing_and_non_utf8_files_are_errors() {
        let e = load_obj(Path::new("/nonexistent/model.obj"), camera()).unwrap_err();
        assert!(matches!(e, ObjError::Read { .. }) && e.to_string().contains("/nonexistent/model.obj"));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("latin1.obj");
        std::fs::write(&path, b"v 0 0 0\no caf\xe9\n").unwrap();
        let e = load_obj(&path, camera()).unwrap_err().to_string();
        assert!(e.contains("latin1.obj:2:") && e.contains("UTF-8"), "{e}");
    }

    #[test]
    fn obj_line_at_counts_from_one() {
        let t = b"a\nbb\nc";
        assert_eq!(line_at(t, 0), 1);
        assert_eq!(line_at(t, 2), 1); // just past the first newline: line 1 was consumed
        assert_eq!(line_at(t, 3), 2);
        assert_eq!(line_at(t, 6), 3);
        assert_eq!(line_at(t, 99), 3);
    }

    #[test]
    fn obj_roughness_follows_the_blinn_phong_exponent() {
        assert_eq!(roughness_from_ns(0.0), 1.0);
        assert_eq!(roughness_from_ns(-5.0), 1.0);
        assert!(roughness_from_ns(1000.0) < roughness_from_ns(10.0));
        assert!((roughness_from_ns(6.0).powi(4) - 0.25).abs() < 1e-6);
    }

    const OBJ_WORDS: &[&str] = &[
        "v 0 0 0",
        "v 1 2 3 4",
        "v 1 2 3 0",
        "v 1 2",
        "v 1 2 3 0.5 0.5",
        "vt 0 0",
        "vn 0 0 1",
        "f 1 2 3",
        "f -1 -2 -3",
        "f 1/1/1 2/2/2 3/3/3",
        "f 1//1 2//1 3//1 4//1",
        "f 2 3",
        "f 1",
        "l 1 2",
        "p 1",
        "o",
        "o thing",
        "g grp",
        "usemtl a",
        "usemtl",
        "mtllib m.mtl",
        "f 99999999999999999999 1 2",
        "f 1/-5 2 3",
        "f a b c",
        "#",
        "",
        "s 1",
        "f 1/2/3/4 1 1",
        "f 1/1 2/1 3/1 4/1 5/1",
        "  o  ",
        "f",
    ];
    const MTL_WORDS: &[&str] = &[
        "newmtl a",
        "newmtl",
        "Kd 1",
        "Kd 1 2",
        "Kd 1 2 3",
        "Ks 1 1 1",
        "Ns 10",
        "Ns",
        "Ke 1 1 1",
        "map_Kd",
        "map_Kd t.png",
        "illum",
        "d 0.5",
        "Kd",
        "Tf 1 1 1",
        "Ka nan 1 1",
        "Kd spectral x.rfl",
    ];

    proptest::proptest! {
        #[test]
        fn obj_random_statements_never_panic(
            obj in proptest::collection::vec(proptest::sample::select(OBJ_WORDS), 0..24),
            mtl in proptest::collection::vec(proptest::sample::select(MTL_WORDS), 0..8),
        ) {
            let dir = tempfile::tempdir().unwrap();
            write(&dir, "m.mtl", &mtl.join("\n"));
            let path = write(&dir, "fuzz.obj", &obj.join("\n"));
            // Any outcome but a panic; a scene always gets a camera and a light.
            if let Ok(scene) = load_obj(&path, camera()) {
                proptest::prop_assert_eq!(scene.camera.world_to_camera.len(), 1);
                proptest::prop_assert!(!scene.lights.is_empty());
            }
        }
    }
}
