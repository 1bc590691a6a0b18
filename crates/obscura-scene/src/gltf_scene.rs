//! glTF 2.0 reader: `.gltf` (JSON, with `data:` or external buffers) and `.glb` (binary).
//!
//! The loader fills geometry, materials, lights and the camera *transform*; format, windows, shutter
//! and clipping come from the caller's [`CameraDesc`], and the CLI may override the projection.
//!
//! What is read:
//!
//! - the default scene (or the first one) and every node under its roots, each node's world matrix
//!   being the product of its ancestors' local matrices;
//! - every `TRIANGLES` primitive of every mesh node, as one [`Object`] with [`Shape::Mesh`]: positions,
//!   normals when present, indices (or the implicit `0, 1, 2, …`); other modes are skipped with a
//!   warning;
//! - materials, from `pbrMetallicRoughness` factors (textures are ignored, with one warning);
//! - the first camera met in a depth-first walk of the scene: its node's world matrix gives the
//!   world-to-camera transform, its projection `PxrPerspective` with `"float fov"` or
//!   `PxrOrthographic` with a screen window;
//! - `KHR_lights_punctual` lights (see [`load_gltf`]).
//!
//! Spaces: glTF is right-handed, +Y up, and a camera looks down its −Z with +X right. Obscura's camera
//! space looks down +Z with +Y up and +X right, so
//! `world_to_camera = S · inverse(camera node world)` with `S = diag(1, 1, −1, 1)`: the flip turns
//! glTF's viewing direction into ours and leaves right right and up up.
//!
//! The file's bytes are checked before they reach code that assumes them valid (GLB header lengths,
//! accessor types, strides and extents, percent-encoded buffer URIs, the node hierarchy), so a
//! malformed file gives a [`GltfError`] naming it, never a panic.

use std::f32::consts::PI;
use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::json::Value;
use obscura_host::CameraDesc;
use obscura_sdk::{Matrix4, MotionSample, ParamValue, Rgb, ScreenWindow};

use crate::types::{Light, Material, Mesh, MotionTransform, Object, Scene, Shape};

/// The vertical field of view, in degrees, used to frame a scene that has no camera of its own.
pub(crate) const FRAMING_FOV_DEG: f32 = 45.0;

/// How far outside the tightest fit [`frame_bounds`] places the camera (10 % of the half-extent), so
/// that the geometry does not touch the image edges.
const FRAMING_MARGIN: f32 = 1.1;

/// `PxrDistantLight`'s default `angleExtent` (the sun's apparent diameter), degrees.
const SUN_ANGLE_EXTENT_DEG: f32 = 0.53;

/// A point or spot light becomes a sphere this fraction of the scene's bounding-box diagonal across.
const SPHERE_LIGHT_FRACTION: f32 = 0.01;

/// A glTF file could not be loaded. Every message starts with the file's path.
#[derive(Debug, thiserror::Error)]
pub enum GltfError {
    /// The file could not be read.
    #[error("cannot read glTF file {}: {source}", .path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The binary container (`.glb`) is malformed.
    #[error("{}: not a valid binary glTF (.glb) file: {what}", .path.display())]
    Binary {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// The JSON is malformed, or the document fails glTF validation (dangling indices, bad enums).
    #[error("{}: not a valid glTF 2.0 file: {source}", .path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// The glTF crate's diagnosis.
        source: gltf::Error,
    },
    /// A buffer could not be loaded: missing external file, bad `data:` URI, too short.
    #[error("{}: buffer {buffer}: {what}", .path.display())]
    Buffer {
        /// The file.
        path: PathBuf,
        /// The buffer's index in the document.
        buffer: usize,
        /// What is wrong.
        what: String,
    },
    /// A mesh primitive's data is inconsistent: an accessor of the wrong type or past the end of its
    /// buffer, or an index out of range.
    #[error("{}: mesh {mesh} primitive {primitive}: {what}", .path.display())]
    Primitive {
        /// The file.
        path: PathBuf,
        /// The mesh's index.
        mesh: usize,
        /// The primitive's index within the mesh.
        primitive: usize,
        /// What is wrong.
        what: String,
    },
    /// The document is inconsistent in a way glTF validation does not catch.
    #[error("{}: {what}", .path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// The node hierarchy is not a set of trees (a cycle, or a node with two parents).
    #[error("{}: node {node}: {what}", .path.display())]
    Node {
        /// The file.
        path: PathBuf,
        /// The node's index.
        node: usize,
        /// What is wrong.
        what: String,
    },
}

/// Loads a `.gltf` or `.glb` file into a [`Scene`] for `camera`.
///
/// `camera` supplies format, windows, shutter, clipping and aperture; its `world_to_camera` is
/// replaced by one motion sample at shutter open: the file's first camera (see the module
/// documentation), or, when the file has none, [`frame_bounds`] of the scene's world bounds with a
/// 45° field of view. The projection is `PxrPerspective` with `"float fov"` (degrees, across the
/// smaller image side, derived from the glTF `yfov` and the format's frame aspect `a`:
/// `fov = yfov` when `a ≥ 1`, else `2·atan(tan(yfov/2)·a)`), or `PxrOrthographic` with the screen
/// window `(−ymag·a, ymag·a, −ymag, ymag)`.
///
/// Materials: glTF material `i` is [`Scene::materials`]`[i + 1]`; a primitive without one uses the
/// default material 0. A non-zero `emissiveFactor` gives [`Material::Constant`]; roughness 1 and
/// metallic 0 give [`Material::Diffuse`] of the base colour; anything else [`Material::Surface`] with
/// `diffuse = base·(1 − metallic)`, `specular = lerp(0.04, base, metallic)` and glTF's roughness
/// (both are perceptual, α = roughness²).
///
/// Lights (`KHR_lights_punctual`, read from the document's JSON because the `gltf` crate exposes the
/// extension only behind a feature): `directional` → [`Light::Distant`] with the light node's world
/// matrix times `S` (glTF's light shines down its −Z, ours along +Z) and the illuminance as
/// intensity; `point` and `spot` → [`Light::Sphere`] at the node's world position, 1 % of the scene's
/// diagonal across, with the radiance that makes its radiant intensity equal the glTF intensity
/// (candela read as W/sr); a spot light's cone is dropped with a warning. A scene with no light gets
/// a white dome of intensity 1 and a warning, since it would otherwise render black.
///
/// # Errors
/// A [`GltfError`] naming the file: unreadable, malformed JSON or GLB, missing or short buffers,
/// accessors of the wrong type or outside their buffers, indices out of range, node cycles.
pub fn load_gltf(path: &Path, camera: CameraDesc) -> Result<Scene, GltfError> {
    let bytes = std::fs::read(path).map_err(|source| GltfError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    check_glb_header(path, &bytes)?;
    let parse = |source| GltfError::Parse {
        path: path.to_path_buf(),
        source,
    };
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(&bytes).map_err(parse)?;
    let root = document.into_json();
    check_before_validation(path, &root)?;
    let document = gltf::Document::from_json(root).map_err(parse)?;
    let base = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let buffers = load_buffers(path, &document, base, blob)?;
    let punctual = json_chunk(&bytes).and_then(PunctualLights::parse);

    let mut loader = Loader {
        path,
        file: path.display().to_string(),
        buffers: &buffers,
        scene: Scene::new(camera),
        bounds: None,
    };
    let placed = loader.walk(&document)?;
    loader.read_materials(&document);
    for (node, world) in &placed {
        if let Some(mesh) = node.mesh() {
            loader.read_mesh(node, &mesh, *world)?;
        }
    }
    let first_camera = placed
        .iter()
        .find_map(|(node, world)| node.camera().map(|c| (node, c, *world)));
    let mut camera_set = false;
    if let Some((node, cam, world)) = first_camera {
        camera_set = loader.apply_camera(node.index(), &cam, world);
    }
    if !camera_set {
        frame_scene(&mut loader.scene, loader.bounds, &loader.file);
    }
    loader.read_lights(&placed, punctual, &document);
    add_default_dome_if_unlit(&mut loader.scene, &loader.file);
    Ok(loader.scene)
}

/// A world-to-camera transform (RenderMan camera space: +Z forward, +Y up, +X right) that frames the
/// box `min`..`max` (world points) from its +Z side, looking toward −Z in world with +Y up (glTF's
/// default viewing direction), for a field of view of `fov_deg` degrees.
///
/// The camera sits on the box's centre line at `z = max.z + 1.1·max(hx, hy)/tan(fov/2)` (`h` the
/// half-extents), the closest distance at which every corner satisfies `|x/z| ≤ tan(fov/2)` and
/// `|y/z| ≤ tan(fov/2)` in camera space, plus a 10 % margin; so the whole box is in view across both
/// image sides whenever the field of view spans the smaller side. A box flat in x and y (a line
/// along z, a point) is treated as at least a quarter of its depth wide, or 1 unit for a point.
/// Non-finite or inverted bounds frame the box `[−1, 1]³`; a field of view outside (0°, 180°) is
/// taken as 45°.
///
/// Returns a `glam` matrix acting on column vectors (`p_camera = M · p_world`).
#[must_use]
pub fn frame_bounds(min: Vec3, max: Vec3, fov_deg: f32) -> Mat4 {
    let (min, max) = if min.is_finite() && max.is_finite() && min.cmple(max).all() {
        (min, max)
    } else {
        (Vec3::splat(-1.0), Vec3::splat(1.0))
    };
    let fov = if fov_deg.is_finite() && fov_deg > 0.0 && fov_deg < 180.0 {
        fov_deg
    } else {
        FRAMING_FOV_DEG
    };
    let tan_half = (0.5 * fov.to_radians()).tan();
    let centre = 0.5 * (min + max);
    let half = 0.5 * (max - min);
    let floor = if half.max_element() > 0.0 {
        0.25 * half.max_element()
    } else {
        1.0
    };
    let across = half.x.max(half.y).max(floor);
    let distance = half.z + FRAMING_MARGIN * across / tan_half;
    let eye = centre + Vec3::new(0.0, 0.0, distance);
    flip_z() * Mat4::from_translation(-eye)
}

/// `S = diag(1, 1, −1, 1)`: glTF's camera and light frames (looking down −Z) to Obscura's (+Z).
fn flip_z() -> Mat4 {
    Mat4::from_scale(Vec3::new(1.0, 1.0, -1.0))
}

/// The row-vector [`Matrix4`] of a column-vector `glam` matrix: the transpose, which is exactly glam's
/// column-major storage read row by row (`[p 1]·Mᵀ = (M·[p 1]ᵀ)ᵀ`).
pub(crate) fn to_row_vector(m: Mat4) -> Matrix4 {
    Matrix4(m.to_cols_array_2d())
}

/// Replaces the camera's world-to-camera motion with one sample of `world_to_camera` (column-vector
/// glam) at shutter open.
pub(crate) fn set_world_to_camera(scene: &mut Scene, world_to_camera: Mat4) {
    scene.camera.world_to_camera = vec![MotionSample {
        time: scene.camera.shutter.0,
        world_to_camera: to_row_vector(world_to_camera),
    }];
}

/// Sets `"float fov"` (degrees) in the projection parameters, replacing an earlier one.
pub(crate) fn set_fov(scene: &mut Scene, fov_deg: f32, origin: String) {
    if let Err(e) = scene
        .projection_params
        .push("float fov", ParamValue::Floats(vec![fov_deg]), Some(origin))
    {
        scene.warnings.push(e.to_string());
    }
}

/// Frames the scene's world bounds (or `[−1, 1]³` when it has no geometry) with a 45° perspective.
pub(crate) fn frame_scene(scene: &mut Scene, bounds: Option<(Vec3, Vec3)>, file: &str) {
    let (min, max) = bounds.unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    set_world_to_camera(scene, frame_bounds(min, max, FRAMING_FOV_DEG));
    scene.projection = "PxrPerspective".into();
    set_fov(
        scene,
        FRAMING_FOV_DEG,
        format!("{file}: framing (no camera in the file)"),
    );
}

/// Adds a white dome light when the scene has no light at all, with a warning saying so.
pub(crate) fn add_default_dome_if_unlit(scene: &mut Scene, file: &str) {
    if scene.lights.is_empty() {
        scene.lights.push(Light::Dome {
            color: Rgb::WHITE,
            intensity: 1.0,
            exposure: 0.0,
            map: None,
            transform: Mat4::IDENTITY,
        });
        scene.warnings.push(format!(
            "{file}: the file has no light; added a white dome light (intensity 1) so the render is not black"
        ));
    }
}

/// Grows `bounds` to hold `p` (non-finite points are left out).
pub(crate) fn grow_bounds(bounds: &mut Option<(Vec3, Vec3)>, p: Vec3) {
    if !p.is_finite() {
        return;
    }
    *bounds = Some(match *bounds {
        Some((lo, hi)) => (lo.min(p), hi.max(p)),
        None => (p, p),
    });
}

/// The field of view across the smaller image side, degrees, for a vertical field of view `yfov`
/// (radians) and a frame aspect (width / height).
fn fov_across_smaller_side(yfov: f32, aspect: f32) -> f32 {
    if aspect >= 1.0 {
        yfov.to_degrees()
    } else {
        (2.0 * ((0.5 * yfov).tan() * aspect).atan()).to_degrees()
    }
}

/// Checks what the `gltf` crate assumes without checking: its validation indexes the accessor a
/// `POSITION` attribute names, and `Camera::projection` unwraps the object its `type` names.
fn check_before_validation(path: &Path, root: &gltf::json::Root) -> Result<(), GltfError> {
    use gltf::json::camera::Type;
    use gltf::json::validation::Checked;
    for (i, camera) in root.cameras.iter().enumerate() {
        let missing = match camera.type_ {
            Checked::Valid(Type::Perspective) => camera.perspective.is_none().then_some("perspective"),
            Checked::Valid(Type::Orthographic) => camera.orthographic.is_none().then_some("orthographic"),
            Checked::Invalid => None,
        };
        if let Some(kind) = missing {
            return Err(GltfError::Invalid {
                path: path.to_path_buf(),
                what: format!("camera {i} has type \"{kind}\" but no \"{kind}\" object"),
            });
        }
    }
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for (semantic, accessor) in &prim.attributes {
                if accessor.value() >= root.accessors.len() {
                    let name = match semantic {
                        Checked::Valid(s) => s.to_string(),
                        Checked::Invalid => "an attribute".into(),
                    };
                    return Err(GltfError::Primitive {
                        path: path.to_path_buf(),
                        mesh: m,
                        primitive: p,
                        what: format!(
                            "{name} refers to accessor {}, but the file has {}",
                            accessor.value(),
                            root.accessors.len()
                        ),
                    });
                }
            }
        }
    }
    Ok(())
}

/// Rejects GLB headers whose declared length would underflow the `gltf` crate's arithmetic.
fn check_glb_header(path: &Path, bytes: &[u8]) -> Result<(), GltfError> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let bad = |what: String| GltfError::Binary {
        path: path.to_path_buf(),
        what,
    };
    let length =
        read_u32(bytes, 8).ok_or_else(|| bad(format!("header is {} bytes, expected 12", bytes.len())))?;
    if length < 12 {
        return Err(bad(format!(
            "declared length {length} is shorter than the 12-byte header"
        )));
    }
    Ok(())
}

fn read_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let b: [u8; 4] = bytes.get(at..at.checked_add(4)?)?.try_into().ok()?;
    Some(u32::from_le_bytes(b))
}

/// The JSON text of a `.gltf`, or the JSON chunk of a `.glb`.
fn json_chunk(bytes: &[u8]) -> Option<&[u8]> {
    if !bytes.starts_with(b"glTF") {
        return Some(bytes);
    }
    let length = usize::try_from(read_u32(bytes, 12)?).ok()?;
    bytes.get(20..20usize.checked_add(length)?)
}

/// Loads every buffer: the GLB's BIN chunk, a base64 `data:` URI, or a file beside the document.
fn load_buffers(
    path: &Path,
    document: &gltf::Document,
    base: &Path,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, GltfError> {
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let bad = |what: String| GltfError::Buffer {
            path: path.to_path_buf(),
            buffer: buffer.index(),
            what,
        };
        let mut data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .take()
                .ok_or_else(|| bad("refers to the GLB binary chunk, which is missing".into()))?,
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                gltf::buffer::Data::from_source(buffer.source(), None)
                    .map_err(|e| bad(format!("cannot decode its data: URI: {e}")))?
                    .0
            }
            gltf::buffer::Source::Uri(uri) => {
                let file = external_path(base, uri)
                    .ok_or_else(|| bad(format!("unsupported or malformed URI \"{uri}\"")))?;
                std::fs::read(&file).map_err(|e| bad(format!("cannot read {}: {e}", file.display())))?
            }
        };
        if data.len() < buffer.length() {
            return Err(bad(format!(
                "declares {} bytes but only {} were found",
                buffer.length(),
                data.len()
            )));
        }
        data.truncate(buffer.length());
        out.push(data);
    }
    Ok(out)
}

/// The file a non-`data:` buffer URI names: `file:` URIs as they are, relative references from the
/// document's folder; percent-escapes are decoded. `None` for other schemes and undecodable escapes.
fn external_path(base: &Path, uri: &str) -> Option<PathBuf> {
    if let Some(rest) = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")) {
        return Some(PathBuf::from(percent_decode(rest)?));
    }
    if uri.contains(':') {
        return None;
    }
    Some(base.join(percent_decode(uri)?))
}

/// Decodes `%XX` escapes; a `%` not followed by two hex digits stays as it is. `None` when the result
/// is not UTF-8.
fn percent_decode(s: &str) -> Option<String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |k: usize| bytes.get(k).and_then(|&b| (b as char).to_digit(16));
        match (bytes[i], hex(i + 1), hex(i + 2)) {
            (b'%', Some(hi), Some(lo)) => {
                out.push((hi * 16 + lo) as u8);
                i += 3;
            }
            (b, _, _) => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}

/// `KHR_lights_punctual`, read from the raw JSON.
struct PunctualLights {
    /// The document's lights, in order (`Err` holds why one cannot be used).
    lights: Vec<Result<Punctual, String>>,
    /// For each node, the light it carries, if any.
    node_light: Vec<Option<u64>>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum PunctualKind {
    Directional,
    Point,
    Spot,
}

#[derive(Debug, Clone, Copy)]
struct Punctual {
    kind: PunctualKind,
    color: Rgb,
    intensity: f32,
}

impl PunctualLights {
    fn parse(json: &[u8]) -> Option<PunctualLights> {
        // Most files have no lights: skip the second JSON parse for them.
        if !json.windows(19).any(|w| w == b"KHR_lights_punctual") {
            return None;
        }
        let root: Value = gltf::json::deserialize::from_slice(json).ok()?;
        let lights = root
            .get("extensions")
            .and_then(|e| e.get("KHR_lights_punctual"))
            .and_then(|k| k.get("lights"))
            .and_then(Value::as_array)
            .map(|ls| ls.iter().map(Punctual::parse).collect())
            .unwrap_or_default();
        let node_light = root
            .get("nodes")
            .and_then(Value::as_array)
            .map(|nodes| {
                nodes
                    .iter()
                    .map(|n| {
                        n.get("extensions")
                            .and_then(|e| e.get("KHR_lights_punctual"))
                            .and_then(|k| k.get("light"))
                            .and_then(Value::as_u64)
                    })
                    .collect()
            })
            .unwrap_or_default();
        Some(PunctualLights { lights, node_light })
    }
}

impl Punctual {
    fn parse(v: &Value) -> Result<Punctual, String> {
        let kind = match v.get("type").and_then(Value::as_str) {
            Some("directional") => PunctualKind::Directional,
            Some("point") => PunctualKind::Point,
            Some("spot") => PunctualKind::Spot,
            Some(other) => return Err(format!("unknown type \"{other}\"")),
            None => return Err("no type".into()),
        };
        let number = |x: &Value| {
            x.as_f64()
                .map(|f| f as f32)
                .filter(|f| f.is_finite() && *f >= 0.0)
        };
        let color = match v.get("color") {
            None => Rgb::WHITE,
            Some(c) => match c
                .as_array()
                .map(|a| a.iter().map(number).collect::<Option<Vec<f32>>>())
            {
                Some(Some(rgb)) if rgb.len() == 3 => Rgb::new(rgb[0], rgb[1], rgb[2]),
                _ => return Err("color is not three non-negative numbers".into()),
            },
        };
        let intensity = match v.get("intensity") {
            None => 1.0,
            Some(i) => number(i).ok_or("intensity is not a non-negative number")?,
        };
        Ok(Punctual {
            kind,
            color,
            intensity,
        })
    }
}

/// What loading one file accumulates.
struct Loader<'a> {
    path: &'a Path,
    file: String,
    buffers: &'a [Vec<u8>],
    scene: Scene,
    /// World-space bounds of every vertex read so far.
    bounds: Option<(Vec3, Vec3)>,
}

impl Loader<'_> {
    fn warn(&mut self, what: String) {
        self.scene.warnings.push(format!("{}: {what}", self.file));
    }

    /// Every node under the scene's roots with its world matrix, depth first, parents before children.
    fn walk<'d>(&mut self, document: &'d gltf::Document) -> Result<Vec<(gltf::Node<'d>, Mat4)>, GltfError> {
        let roots: Vec<gltf::Node<'d>> = match document.default_scene().or_else(|| document.scenes().next()) {
            Some(scene) => scene.nodes().collect(),
            None => {
                let mut has_parent = vec![false; document.nodes().len()];
                for node in document.nodes() {
                    for child in node.children() {
                        has_parent[child.index()] = true;
                    }
                }
                if document.nodes().len() > 0 {
                    self.warn("the file has no scene; using every node without a parent as a root".into());
                }
                document.nodes().filter(|n| !has_parent[n.index()]).collect()
            }
        };
        let mut visited = vec![false; document.nodes().len()];
        let mut stack: Vec<(gltf::Node<'d>, Mat4)> =
            roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY)).collect();
        let mut placed = Vec::new();
        while let Some((node, parent)) = stack.pop() {
            if visited[node.index()] {
                return Err(GltfError::Node {
                    path: self.path.to_path_buf(),
                    node: node.index(),
                    what: "reached twice: glTF nodes must form trees (a cycle, or a node with two parents)"
                        .into(),
                });
            }
            visited[node.index()] = true;
            let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
            let children: Vec<gltf::Node<'d>> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world)));
            placed.push((node, world));
        }
        Ok(placed)
    }

    /// Appends every material of the document, in order, after the default one.
    fn read_materials(&mut self, document: &gltf::Document) {
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

    /// One object per triangle primitive of `mesh`, placed by `world`.
    fn read_mesh(
        &mut self,
        node: &gltf::Node<'_>,
        mesh: &gltf::Mesh<'_>,
        world: Mat4,
    ) -> Result<(), GltfError> {
        for prim in mesh.primitives() {
            let Some(shape) = self.read_primitive(mesh.index(), &prim)? else {
                continue;
            };
            for &p in &shape.positions {
                grow_bounds(&mut self.bounds, world.transform_point3(p));
            }
            let name = node.name().map(|n| format!(" \"{n}\"")).unwrap_or_default();
            let material = prim.material().index().map_or(0, |i| i + 1);
            self.scene.objects.push(Object {
                shape: Shape::Mesh(shape),
                transform: MotionTransform::fixed(world),
                material: u32::try_from(material).unwrap_or(0),
                micropolygon_length: 1.0,
                source: format!(
                    "{}: node {}{name} mesh {} primitive {}",
                    self.file,
                    node.index(),
                    mesh.index(),
                    prim.index()
                ),
            });
        }
        Ok(())
    }

    /// The triangles of one primitive; `None` (with a warning) when it is not made of triangles.
    fn read_primitive(&mut self, mesh: usize, prim: &gltf::Primitive<'_>) -> Result<Option<Mesh>, GltfError> {
        let here = format!("mesh {mesh} primitive {}", prim.index());
        if prim.mode() != gltf::mesh::Mode::Triangles {
            self.warn(format!(
                "{here}: mode {:?} is not TRIANGLES; skipped",
                prim.mode()
            ));
            return Ok(None);
        }
        let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
            self.warn(format!("{here}: no POSITION attribute; skipped"));
            return Ok(None);
        };
        let bad = |what: String| GltfError::Primitive {
            path: self.path.to_path_buf(),
            mesh,
            primitive: prim.index(),
            what,
        };
        let float = [DataType::F32];
        self.check_accessor(&pos_acc, Dimensions::Vec3, &float)
            .map_err(|e| bad(format!("POSITION {e}")))?;
        let normal_acc = prim.get(&gltf::Semantic::Normals);
        if let Some(acc) = &normal_acc {
            self.check_accessor(acc, Dimensions::Vec3, &float)
                .map_err(|e| bad(format!("NORMAL {e}")))?;
        }
        if let Some(acc) = prim.indices() {
            self.check_accessor(
                &acc,
                Dimensions::Scalar,
                &[DataType::U8, DataType::U16, DataType::U32],
            )
            .map_err(|e| bad(format!("indices {e}")))?;
        }

        let buffers = self.buffers;
        let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let positions: Vec<Vec3> = reader
            .read_positions()
            .ok_or_else(|| bad("POSITION data cannot be read".into()))?
            .map(Vec3::from)
            .collect();
        let n = positions.len();
        let mut normals = None;
        if normal_acc.is_some() {
            let ns: Vec<Vec3> = reader
                .read_normals()
                .ok_or_else(|| bad("NORMAL data cannot be read".into()))?
                .map(Vec3::from)
                .collect();
            if ns.len() == n {
                normals = Some(ns);
            } else {
                self.warn(format!(
                    "{here}: {} normals for {n} positions; normals ignored",
                    ns.len()
                ));
            }
        }
        let indices: Vec<u32> = match reader.read_indices() {
            Some(ix) => ix.into_u32().collect(),
            None if prim.indices().is_some() => return Err(bad("index data cannot be read".into())),
            None => (0..u32::try_from(n).map_err(|_| bad(format!("{n} vertices is too many")))?).collect(),
        };
        if let Some(&index) = indices.iter().find(|&&i| i as usize >= n) {
            return Err(bad(format!(
                "index {index} is out of range: the primitive has {n} vertices"
            )));
        }
        if !indices.len().is_multiple_of(3) {
            self.warn(format!(
                "{here}: {} indices is not a multiple of 3; the last {} ignored",
                indices.len(),
                indices.len() % 3
            ));
        }
        let triangles = indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        Ok(Some(Mesh {
            positions,
            normals,
            triangles,
        }))
    }

    /// Checks what the `gltf` crate's readers assume (and assert) about an accessor: its type, a
    /// stride no smaller than an element, and that every element lies inside its view and buffer.
    fn check_accessor(
        &self,
        acc: &gltf::Accessor<'_>,
        dims: Dimensions,
        types: &[DataType],
    ) -> Result<(), String> {
        let which = format!("accessor {}", acc.index());
        if acc.dimensions() != dims || !types.contains(&acc.data_type()) {
            return Err(format!(
                "{which} is {:?} of {:?}; expected {dims:?} of {}",
                acc.dimensions(),
                acc.data_type(),
                types
                    .iter()
                    .map(|t| format!("{t:?}"))
                    .collect::<Vec<_>>()
                    .join(" or ")
            ));
        }
        if acc.sparse().is_some() {
            return Err(format!("{which} is sparse, which this reader does not support"));
        }
        let count = acc.count();
        if count == 0 {
            return Err(format!("{which} has no elements"));
        }
        let view = acc.view().ok_or_else(|| format!("{which} has no buffer view"))?;
        let elem = acc.size();
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(format!(
                "{which}: buffer view {} has stride {stride}, smaller than one {elem}-byte element",
                view.index()
            ));
        }
        let end = stride
            .checked_mul(count - 1)
            .and_then(|s| s.checked_add(elem))
            .and_then(|s| s.checked_add(acc.offset()));
        if end.is_none_or(|e| e > view.length()) {
            return Err(format!(
                "{which}: {count} elements from byte {} run past the end of buffer view {} ({} bytes)",
                acc.offset(),
                view.index(),
                view.length()
            ));
        }
        let buffer_len = self.buffers.get(view.buffer().index()).map_or(0, Vec::len);
        if view
            .offset()
            .checked_add(view.length())
            .is_none_or(|e| e > buffer_len)
        {
            return Err(format!(
                "{which}: buffer view {} runs past the end of buffer {} ({buffer_len} bytes)",
                view.index(),
                view.buffer().index()
            ));
        }
        Ok(())
    }

    /// Sets the camera transform and projection from a glTF camera; false (with a warning) when its
    /// node's matrix cannot be inverted.
    fn apply_camera(&mut self, node: usize, cam: &gltf::Camera<'_>, world: Mat4) -> bool {
        let det = world.determinant();
        if !world.is_finite() || !det.is_finite() || det.abs() < 1e-12 {
            self.warn(format!(
                "camera node {node} has a singular transform; framing the scene instead"
            ));
            return false;
        }
        set_world_to_camera(&mut self.scene, flip_z() * world.inverse());
        let aspect = self.scene.camera.format.frame_aspect();
        let aspect = if aspect.is_finite() && aspect > 0.0 {
            aspect
        } else {
            1.0
        };
        let origin = format!("{}: camera {}", self.file, cam.index());
        match cam.projection() {
            gltf::camera::Projection::Perspective(p) => {
                self.scene.projection = "PxrPerspective".into();
                let mut yfov = p.yfov();
                if !(yfov.is_finite() && yfov > 0.0 && yfov < PI) {
                    self.warn(format!(
                        "camera {}: yfov {yfov} is not in (0, π); using {FRAMING_FOV_DEG}°",
                        cam.index()
                    ));
                    yfov = FRAMING_FOV_DEG.to_radians();
                }
                set_fov(&mut self.scene, fov_across_smaller_side(yfov, aspect), origin);
            }
            gltf::camera::Projection::Orthographic(o) => {
                self.scene.projection = "PxrOrthographic".into();
                let ymag = o.ymag().abs();
                if ymag.is_finite() && ymag > 0.0 {
                    self.scene.camera.screen_window =
                        Some(ScreenWindow::new(-ymag * aspect, ymag * aspect, -ymag, ymag));
                } else {
                    self.warn(format!(
                        "camera {}: ymag {} is not positive; keeping the default screen window",
                        cam.index(),
                        o.ymag()
                    ));
                }
            }
        }
        true
    }

    /// Maps the `KHR_lights_punctual` lights of placed nodes.
    fn read_lights(
        &mut self,
        placed: &[(gltf::Node<'_>, Mat4)],
        punctual: Option<PunctualLights>,
        document: &gltf::Document,
    ) {
        let Some(punctual) = punctual else {
            if document.extensions_used().any(|e| e.starts_with("KHR_lights")) {
                self.warn("light extension present but no lights could be read; lights skipped".into());
            }
            return;
        };
        let diameter = self
            .bounds
            .map(|(lo, hi)| SPHERE_LIGHT_FRACTION * (hi - lo).length())
            .filter(|d| d.is_finite() && *d > 0.0)
            .unwrap_or(SPHERE_LIGHT_FRACTION);
        let mut spot_warned = false;
        for (node, world) in placed {
            let Some(index) = punctual.node_light.get(node.index()).copied().flatten() else {
                continue;
            };
            let light = usize::try_from(index).ok().and_then(|i| punctual.lights.get(i));
            let p = match light {
                Some(Ok(p)) => *p,
                Some(Err(why)) => {
                    self.warn(format!("node {}: light {index}: {why}; skipped", node.index()));
                    continue;
                }
                None => {
                    self.warn(format!(
                        "node {}: light {index} does not exist; skipped",
                        node.index()
                    ));
                    continue;
                }
            };
            let light = match p.kind {
                PunctualKind::Directional => Light::Distant {
                    color: p.color,
                    intensity: p.intensity,
                    exposure: 0.0,
                    angle_extent: SUN_ANGLE_EXTENT_DEG,
                    transform: *world * flip_z(),
                },
                PunctualKind::Point | PunctualKind::Spot => {
                    if p.kind == PunctualKind::Spot && !spot_warned {
                        spot_warned = true;
                        self.warn(format!(
                            "node {}: spot light cones are not supported; emitted as a sphere light in all directions",
                            node.index()
                        ));
                    }
                    let radius = 0.5 * diameter;
                    Light::Sphere {
                        color: p.color,
                        intensity: p.intensity / (PI * radius * radius),
                        exposure: 0.0,
                        transform: Mat4::from_scale_rotation_translation(
                            Vec3::splat(diameter),
                            Quat::IDENTITY,
                            world.transform_point3(Vec3::ZERO),
                        ),
                    }
                }
            };
            self.scene.lights.push(light);
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

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::Format;
    use proptest::prelude::*;

    fn base64(bytes: &[u8]) -> String {
        const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut out = String::new();
        for chunk in bytes.chunks(3) {
            let b = [
                chunk[0],
                chunk.get(1).copied().unwrap_or(0),
                chunk.get(2).copied().unwrap_or(0),
            ];
            let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
            for i in 0..4 {
                if i <= chunk.len() {
                    out.push(ALPHABET[((n >> (18 - 6 * i)) & 63) as usize] as char);
                } else {
                    out.push('=');
                }
            }
        }
        out
    }

    #[test]
    fn gltf_test_helper_base64_matches_rfc_4648() {
        assert_eq!(base64(b"f"), "Zg==");
        assert_eq!(base64(b"fo"), "Zm8=");
        assert_eq!(base64(b"foo"), "Zm9v");
        assert_eq!(base64(b"foobar"), "Zm9vYmFy");
    }

    const POSITIONS: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

    /// 36 bytes of positions, 36 of normals (+Z), 6 of u16 indices and 2 of padding: 80 bytes.
    fn buffer(indices: [u16; 3]) -> Vec<u8> {
        let mut b = Vec::new();
        for p in POSITIONS {
            for c in p {
                b.extend_from_slice(&c.to_le_bytes());
            }
        }
        for _ in 0..3 {
            for c in [0.0f32, 0.0, 1.0] {
                b.extend_from_slice(&c.to_le_bytes());
            }
        }
        for i in indices {
            b.extend_from_slice(&i.to_le_bytes());
        }
        b.extend_from_slice(&[0, 0]);
        b
    }

    /// A glTF document: one triangle mesh, three materials, nodes and cameras as given.
    struct Fixture {
        nodes: String,
        scene_nodes: String,
        cameras: String,
        mode: u32,
        /// `"uri": "…",` or empty for a GLB's BIN chunk.
        buffer_uri: String,
        extensions: String,
        index_type: u32,
    }

    impl Fixture {
        fn new(indices: [u16; 3]) -> Self {
            let (s, c) = (std::f32::consts::FRAC_1_SQRT_2, std::f32::consts::FRAC_1_SQRT_2);
            Fixture {
                nodes: format!(
                    r#"{{"name":"tri","mesh":0,"translation":[1,2,3],"rotation":[0,{s},0,{c}]}},
                       {{"name":"cam","camera":0,"translation":[0,0,5]}}"#
                ),
                scene_nodes: "[0, 1]".into(),
                cameras: r#"{"type":"perspective","perspective":{"yfov":0.8,"znear":0.1}}"#.into(),
                mode: 4,
                buffer_uri: format!(
                    r#""uri":"data:application/octet-stream;base64,{}","#,
                    base64(&buffer(indices))
                ),
                extensions: String::new(),
                index_type: 5123,
            }
        }

        fn json(&self) -> String {
            format!(
                r#"{{
  "asset": {{"version": "2.0"}},
  {ext}
  "scene": 0,
  "scenes": [{{"nodes": {scene_nodes}}}],
  "nodes": [{nodes}],
  "cameras": [{cameras}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1}}, "indices": 2, "material": 0, "mode": {mode}}}]}}],
  "materials": [
    {{"pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.4, 0.2, 1.0], "metallicFactor": 0.5, "roughnessFactor": 0.3}}}},
    {{"pbrMetallicRoughness": {{"baseColorFactor": [0.1, 0.2, 0.3, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}}},
    {{"emissiveFactor": [2.0, 1.0, 0.5]}}
  ],
  "buffers": [{{{uri} "byteLength": 80}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 72, "byteStride": 12, "target": 34962}},
    {{"buffer": 0, "byteOffset": 72, "byteLength": 6, "target": 34963}}
  ],
  "accessors": [
    {{"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}},
    {{"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3"}},
    {{"bufferView": 1, "byteOffset": 0, "componentType": {itype}, "count": 3, "type": "SCALAR"}}
  ]
}}"#,
                ext = self.extensions,
                scene_nodes = self.scene_nodes,
                nodes = self.nodes,
                cameras = self.cameras,
                mode = self.mode,
                uri = self.buffer_uri,
                itype = self.index_type,
            )
        }

        fn write(&self, dir: &tempfile::TempDir, name: &str) -> PathBuf {
            let path = dir.path().join(name);
            std::fs::write(&path, self.json()).unwrap();
            path
        }
    }

    fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
        let mut json = json.as_bytes().to_vec();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let mut bin = bin.to_vec();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = Vec::new();
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        out
    }

    fn camera_desc(w: u32, h: u32) -> CameraDesc {
        let mut c = CameraDesc::new(Format::new(w, h));
        c.shutter = (0.25, 0.75);
        c
    }

    fn load(fixture: &Fixture, w: u32, h: u32) -> Scene {
        let dir = tempfile::tempdir().unwrap();
        load_gltf(&fixture.write(&dir, "scene.gltf"), camera_desc(w, h)).unwrap()
    }

    fn fov_param(scene: &Scene) -> f32 {
        match &scene.projection_params.get("fov").expect("a fov parameter").value {
            ParamValue::Floats(v) => v[0],
            other => panic!("fov is {other:?}"),
        }
    }

    fn to_camera(scene: &Scene, p: Vec3) -> Vec3 {
        let m = scene.camera.world_to_camera[0].world_to_camera;
        let q = m.transform_point(obscura_sdk::Vec3::new(p.x, p.y, p.z));
        Vec3::new(q.x, q.y, q.z)
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).abs().max_element() < 1e-5
    }

    #[test]
    fn gltf_triangle_under_a_rotated_translated_node() {
        let scene = load(&Fixture::new([0, 1, 2]), 640, 480);
        assert_eq!(scene.objects.len(), 1);
        let obj = &scene.objects[0];
        let Shape::Mesh(mesh) = &obj.shape else {
            panic!("not a mesh: {:?}", obj.shape)
        };
        assert_eq!(mesh.positions, POSITIONS.map(Vec3::from).to_vec());
        assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
        assert_eq!(mesh.normals, Some(vec![Vec3::Z; 3]));
        // 90° about +Y takes +X to −Z; then the translation (1, 2, 3).
        let m = obj.transform.samples[0].1;
        assert!(close(m.transform_point3(Vec3::X), Vec3::new(1.0, 2.0, 2.0)));
        assert!(close(m.transform_point3(Vec3::Y), Vec3::new(1.0, 3.0, 3.0)));
        assert!(!obj.transform.is_moving());
        assert!(obj.source.contains("scene.gltf") && obj.source.contains("\"tri\""));
    }

    #[test]
    fn gltf_camera_node_maps_world_to_renderman_camera_space() {
        let scene = load(&Fixture::new([0, 1, 2]), 640, 480);
        assert_eq!(scene.camera.world_to_camera.len(), 1);
        assert_eq!(scene.camera.world_to_camera[0].time, 0.25);
        // The camera at (0, 0, 5) looks down world −Z: the origin is 5 units in front of it.
        assert!(close(to_camera(&scene, Vec3::ZERO), Vec3::new(0.0, 0.0, 5.0)));
        let right = to_camera(&scene, Vec3::X);
        assert!(right.x > 0.0 && close(right, Vec3::new(1.0, 0.0, 5.0)));
        let up = to_camera(&scene, Vec3::Y);
        assert!(up.y > 0.0 && close(up, Vec3::new(0.0, 1.0, 5.0)));
    }

    #[test]
    fn gltf_turned_camera_keeps_right_on_the_right() {
        // At (5, 0, 0), turned +90° about Y: it looks down world −X, toward the origin, and its
        // right (+X) is world −Z.
        let mut f = Fixture::new([0, 1, 2]);
        let s = std::f32::consts::FRAC_1_SQRT_2;
        f.nodes = format!(r#"{{"mesh":0}}, {{"camera":0,"translation":[5,0,0],"rotation":[0,{s},0,{s}]}}"#);
        let scene = load(&f, 640, 480);
        assert!(close(to_camera(&scene, Vec3::ZERO), Vec3::new(0.0, 0.0, 5.0)));
        assert!(close(
            to_camera(&scene, Vec3::new(0.0, 0.0, -1.0)),
            Vec3::new(1.0, 0.0, 5.0)
        ));
        assert!(close(to_camera(&scene, Vec3::Y), Vec3::new(0.0, 1.0, 5.0)));
    }

    #[test]
    fn gltf_camera_under_a_parent_node_uses_its_world_matrix() {
        let mut f = Fixture::new([0, 1, 2]);
        f.nodes = r#"{"mesh":0}, {"translation":[0,0,3],"children":[2]}, {"camera":0,"translation":[0,0,2]}"#
            .into();
        let scene = load(&f, 640, 480);
        assert!(close(to_camera(&scene, Vec3::ZERO), Vec3::new(0.0, 0.0, 5.0)));
    }

    #[test]
    fn gltf_perspective_fov_spans_the_smaller_side() {
        let yfov = 0.8f32;
        let landscape = load(&Fixture::new([0, 1, 2]), 640, 480);
        assert_eq!(landscape.projection, "PxrPerspective");
        assert!((fov_param(&landscape) - yfov.to_degrees()).abs() < 1e-4);

        let portrait = load(&Fixture::new([0, 1, 2]), 480, 640);
        let fov = fov_param(&portrait).to_radians();
        assert!(fov < yfov);
        // Across the width the screen plane at d = 1/tan(fov/2) spans [−1, 1]; the height spans
        // [−1/a, 1/a], which must subtend the file's yfov.
        let a = 480.0f32 / 640.0;
        let d = 1.0 / (0.5 * fov).tan();
        assert!(((1.0 / a / d).atan() - 0.5 * yfov).abs() < 1e-5);
    }

    #[test]
    fn gltf_orthographic_camera_sets_a_window_with_the_frame_aspect() {
        let mut f = Fixture::new([0, 1, 2]);
        f.cameras =
            r#"{"type":"orthographic","orthographic":{"xmag":3,"ymag":1.5,"znear":0.1,"zfar":100}}"#.into();
        let scene = load(&f, 640, 480);
        assert_eq!(scene.projection, "PxrOrthographic");
        assert_eq!(
            scene.camera.screen_window,
            Some(ScreenWindow::new(-2.0, 2.0, -1.5, 1.5))
        );
    }

    #[test]
    fn gltf_materials_map_metallic_roughness() {
        let scene = load(&Fixture::new([0, 1, 2]), 640, 480);
        assert_eq!(scene.materials.len(), 4);
        assert_eq!(scene.materials[0], Material::default());
        assert_eq!(scene.objects[0].material, 1);
        let Material::Surface {
            diffuse,
            specular,
            roughness,
        } = scene.materials[1]
        else {
            panic!("expected a surface: {:?}", scene.materials[1])
        };
        let near = |a: Rgb, b: [f32; 3]| {
            (a.r - b[0]).abs() < 1e-6 && (a.g - b[1]).abs() < 1e-6 && (a.b - b[2]).abs() < 1e-6
        };
        assert!(near(diffuse, [0.4, 0.2, 0.1]), "{diffuse:?}");
        assert!(near(specular, [0.42, 0.22, 0.12]), "{specular:?}");
        assert_eq!(roughness, 0.3);
        assert_eq!(
            scene.materials[2],
            Material::Diffuse {
                color: Rgb::new(0.1, 0.2, 0.3)
            }
        );
        assert_eq!(
            scene.materials[3],
            Material::Constant {
                color: Rgb::new(2.0, 1.0, 0.5)
            }
        );
    }

    #[test]
    fn gltf_without_lights_gets_a_dome_and_a_warning() {
        let scene = load(&Fixture::new([0, 1, 2]), 640, 480);
        assert_eq!(
            scene.lights,
            vec![Light::Dome {
                color: Rgb::WHITE,
                intensity: 1.0,
                exposure: 0.0,
                map: None,
                transform: Mat4::IDENTITY
            }]
        );
        assert!(
            scene
                .warnings
                .iter()
                .any(|w| w.contains("no light") && w.contains("scene.gltf"))
        );
    }

    #[test]
    fn gltf_punctual_lights_become_distant_and_sphere_lights() {
        let mut f = Fixture::new([0, 1, 2]);
        f.extensions = r#""extensionsUsed": ["KHR_lights_punctual"],
          "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "directional", "color": [1, 0.5, 0.25], "intensity": 3},
            {"type": "point", "intensity": 10}
          ]}},"#
            .into();
        f.nodes = r#"{"mesh":0},
            {"extensions":{"KHR_lights_punctual":{"light":0}}},
            {"translation":[1,2,3],"extensions":{"KHR_lights_punctual":{"light":1}}}"#
            .into();
        f.scene_nodes = "[0, 1, 2]".into();
        let scene = load(&f, 640, 480);
        assert_eq!(scene.lights.len(), 2, "{:?}", scene.warnings);
        let Light::Distant {
            color,
            intensity,
            transform,
            ..
        } = &scene.lights[0]
        else {
            panic!("{:?}", scene.lights[0])
        };
        assert_eq!((*color, *intensity), (Rgb::new(1.0, 0.5, 0.25), 3.0));
        // glTF's directional light shines down its node's −Z; ours along the light's +Z.
        assert!(close(transform.transform_vector3(Vec3::Z), Vec3::NEG_Z));
        let Light::Sphere {
            intensity, transform, ..
        } = &scene.lights[1]
        else {
            panic!("{:?}", scene.lights[1])
        };
        assert!(close(
            transform.transform_point3(Vec3::ZERO),
            Vec3::new(1.0, 2.0, 3.0)
        ));
        // Small: 1 % of the triangle's world diagonal (√2) across; radiant intensity preserved.
        let diameter = transform.transform_vector3(Vec3::X).length();
        assert!((diameter - 0.01 * 2f32.sqrt()).abs() < 1e-6);
        let r = 0.5 * diameter;
        assert!((intensity * PI * r * r - 10.0).abs() < 1e-3);
        assert!(!scene.warnings.iter().any(|w| w.contains("no light")));
    }

    #[test]
    fn gltf_without_camera_frames_the_bounds() {
        let mut f = Fixture::new([0, 1, 2]);
        f.nodes = r#"{"mesh":0,"translation":[10,0,0]}"#.into();
        f.scene_nodes = "[0]".into();
        let scene = load(&f, 640, 480);
        assert_eq!(scene.projection, "PxrPerspective");
        assert_eq!(fov_param(&scene), 45.0);
        let t = (22.5f32).to_radians().tan();
        for p in POSITIONS {
            let c = to_camera(&scene, Vec3::from(p) + Vec3::new(10.0, 0.0, 0.0));
            assert!(
                c.z > 0.0 && (c.x / c.z).abs() <= t && (c.y / c.z).abs() <= t,
                "{c}"
            );
        }
    }

    #[test]
    fn gltf_binary_container_loads_the_same_scene() {
        let mut f = Fixture::new([0, 1, 2]);
        f.buffer_uri = String::new();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.glb");
        std::fs::write(&path, glb(&f.json(), &buffer([0, 1, 2]))).unwrap();
        let scene = load_gltf(&path, camera_desc(640, 480)).unwrap();
        let text = load(&Fixture::new([0, 1, 2]), 640, 480);
        assert_eq!(scene.objects.len(), 1);
        assert_eq!(scene.objects[0].shape, text.objects[0].shape);
        assert_eq!(scene.camera.world_to_camera, text.camera.world_to_camera);
    }

    #[test]
    fn gltf_external_buffer_beside_the_file() {
        let mut f = Fixture::new([0, 1, 2]);
        f.buffer_uri = r#""uri":"tri%20angle.bin","#.into();
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("tri angle.bin"), buffer([0, 1, 2])).unwrap();
        let scene = load_gltf(&f.write(&dir, "scene.gltf"), camera_desc(64, 64)).unwrap();
        assert_eq!(scene.objects.len(), 1);
    }

    #[test]
    fn gltf_non_triangle_primitives_are_skipped_with_a_warning() {
        let mut f = Fixture::new([0, 1, 2]);
        f.mode = 1;
        let scene = load(&f, 640, 480);
        assert!(scene.objects.is_empty());
        assert!(scene.warnings.iter().any(|w| w.contains("not TRIANGLES")));
    }

    fn error_of(contents: &[u8], name: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(name);
        std::fs::write(&path, contents).unwrap();
        load_gltf(&path, camera_desc(64, 64)).unwrap_err().to_string()
    }

    #[test]
    fn gltf_missing_file_is_an_error_naming_it() {
        let e = load_gltf(Path::new("/nonexistent/nowhere.gltf"), camera_desc(64, 64)).unwrap_err();
        assert!(matches!(e, GltfError::Read { .. }));
        assert!(e.to_string().contains("/nonexistent/nowhere.gltf"), "{e}");
    }

    #[test]
    fn gltf_malformed_json_is_an_error_naming_the_file() {
        let json = Fixture::new([0, 1, 2]).json();
        let e = error_of(&json.as_bytes()[..json.len() / 2], "broken.gltf");
        assert!(e.contains("broken.gltf") && e.contains("not a valid glTF"), "{e}");
    }

    #[test]
    fn gltf_malformed_binary_is_an_error_not_a_panic() {
        // A declared total length shorter than the header itself.
        let mut bytes = glb(&Fixture::new([0, 1, 2]).json(), &[]);
        bytes[8..12].copy_from_slice(&4u32.to_le_bytes());
        let e = error_of(&bytes, "short.glb");
        assert!(e.contains("short.glb") && e.contains("length"), "{e}");
        // A JSON chunk claiming more bytes than the file holds.
        let mut bytes = glb(&Fixture::new([0, 1, 2]).json(), &[]);
        bytes[12..16].copy_from_slice(&100_000u32.to_le_bytes());
        assert!(error_of(&bytes, "chunk.glb").contains("chunk.glb"));
        assert!(error_of(b"glTF", "tiny.glb").contains("tiny.glb"));
    }

    #[test]
    fn gltf_missing_buffer_is_an_error_naming_both_files() {
        let mut f = Fixture::new([0, 1, 2]);
        f.buffer_uri = r#""uri":"missing.bin","#.into();
        let e = error_of(f.json().as_bytes(), "scene.gltf");
        assert!(e.contains("scene.gltf") && e.contains("missing.bin"), "{e}");
        // A GLB whose buffer wants the BIN chunk it does not have.
        let mut f = Fixture::new([0, 1, 2]);
        f.buffer_uri = String::new();
        let e = error_of(f.json().as_bytes(), "nobin.gltf");
        assert!(e.contains("nobin.gltf") && e.contains("buffer 0"), "{e}");
        // Undecodable percent escapes are refused, not unwrapped.
        let mut f = Fixture::new([0, 1, 2]);
        f.buffer_uri = r#""uri":"bad%FF.bin","#.into();
        assert!(error_of(f.json().as_bytes(), "esc.gltf").contains("esc.gltf"));
    }

    #[test]
    fn gltf_index_out_of_range_is_an_error() {
        let e = error_of(Fixture::new([0, 1, 7]).json().as_bytes(), "oob.gltf");
        assert!(
            e.contains("oob.gltf") && e.contains("index 7") && e.contains("mesh 0 primitive 0"),
            "{e}"
        );
    }

    #[test]
    fn gltf_bad_accessors_are_errors_not_panics() {
        // Float indices would hit the reader's `unreachable!`.
        let mut f = Fixture::new([0, 1, 2]);
        f.index_type = 5126;
        let e = error_of(f.json().as_bytes(), "floatidx.gltf");
        assert!(e.contains("floatidx.gltf") && e.contains("indices"), "{e}");
        // An accessor running past its buffer view.
        let json = Fixture::new([0, 1, 2]).json().replace(
            r#""count": 3, "type": "VEC3", "min""#,
            r#""count": 30, "type": "VEC3", "min""#,
        );
        let e = error_of(json.as_bytes(), "long.gltf");
        assert!(e.contains("long.gltf") && e.contains("past the end"), "{e}");
        // An accessor with no elements (the reader computes count − 1).
        let json = Fixture::new([0, 1, 2]).json().replace(
            r#""count": 3, "type": "SCALAR""#,
            r#""count": 0, "type": "SCALAR""#,
        );
        assert!(error_of(json.as_bytes(), "empty.gltf").contains("no elements"));
    }

    #[test]
    fn gltf_inconsistencies_validation_misses_are_errors_not_panics() {
        // The gltf crate's validation indexes a POSITION accessor unchecked.
        let json = Fixture::new([0, 1, 2])
            .json()
            .replace(r#""POSITION": 0"#, r#""POSITION": 9"#);
        let e = error_of(json.as_bytes(), "pos.gltf");
        assert!(
            e.contains("pos.gltf") && e.contains("POSITION refers to accessor 9"),
            "{e}"
        );
        // Camera::projection unwraps the object the type names.
        let mut f = Fixture::new([0, 1, 2]);
        f.cameras =
            r#"{"type":"perspective","orthographic":{"xmag":1,"ymag":1,"znear":0.1,"zfar":9}}"#.into();
        let e = error_of(f.json().as_bytes(), "cam.gltf");
        assert!(e.contains("cam.gltf") && e.contains("camera 0"), "{e}");
    }

    #[test]
    fn gltf_node_cycle_is_an_error() {
        let mut f = Fixture::new([0, 1, 2]);
        f.nodes = r#"{"mesh":0,"children":[1]}, {"children":[0]}"#.into();
        f.scene_nodes = "[0]".into();
        let e = error_of(f.json().as_bytes(), "cycle.gltf");
        assert!(e.contains("cycle.gltf") && e.contains("node 0"), "{e}");
    }

    #[test]
    fn gltf_row_vector_matrix_agrees_with_glam() {
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 0.5, 3.0),
            Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0),
            Vec3::new(-4.0, 5.0, 6.0),
        );
        let r = to_row_vector(m);
        // The translation sits in the last row, as RenderMan writes it.
        assert_eq!(&r.0[3][..3], &[-4.0, 5.0, 6.0]);
        let p = Vec3::new(0.7, -1.3, 2.9);
        let q = r.transform_point(obscura_sdk::Vec3::new(p.x, p.y, p.z));
        assert!(close(Vec3::new(q.x, q.y, q.z), m.transform_point3(p)));
        let v = r.transform_vector(obscura_sdk::Vec3::new(p.x, p.y, p.z));
        assert!(close(Vec3::new(v.x, v.y, v.z), m.transform_vector3(p)));
    }

    #[test]
    fn gltf_frame_bounds_looks_down_world_minus_z() {
        let m = frame_bounds(Vec3::splat(-1.0), Vec3::splat(1.0), 45.0);
        let forward = m.inverse().transform_vector3(Vec3::Z);
        assert!(close(forward, Vec3::NEG_Z));
        // Right is world +X, up world +Y.
        assert!(close(m.transform_vector3(Vec3::X), Vec3::X));
        assert!(close(m.transform_vector3(Vec3::Y), Vec3::Y));
        // Degenerate input still gives a finite camera in front of the box.
        for (lo, hi) in [
            (Vec3::ZERO, Vec3::ZERO),
            (Vec3::splat(f32::NAN), Vec3::ONE),
            (Vec3::ONE, Vec3::ZERO),
            (Vec3::new(0.0, 0.0, -5.0), Vec3::new(0.0, 0.0, 5.0)),
        ] {
            let m = frame_bounds(lo, hi, f32::NAN);
            assert!(m.is_finite());
            if lo.is_finite() && lo.cmple(hi).all() {
                assert!(m.transform_point3(hi).z > 0.0);
            }
        }
    }

    proptest! {
        #[test]
        fn gltf_corrupted_files_never_panic(
            edits in prop::collection::vec(
                (any::<prop::sample::Index>(), prop_oneof![prop::sample::select(b"0123456789-.e ,]}".to_vec()), any::<u8>()]),
                1..6,
            ),
            binary in any::<bool>(),
        ) {
            let mut bytes = if binary {
                let mut f = Fixture::new([0, 1, 2]);
                f.buffer_uri = String::new();
                glb(&f.json(), &buffer([0, 1, 2]))
            } else {
                Fixture::new([0, 1, 2]).json().into_bytes()
            };
            for (at, b) in edits {
                let i = at.index(bytes.len());
                bytes[i] = b;
            }
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("fuzz.gltf");
            std::fs::write(&path, &bytes).unwrap();
            // Any outcome but a panic.
            let _ = load_gltf(&path, camera_desc(64, 64));
        }

        #[test]
        fn gltf_frame_bounds_keeps_every_corner_in_view(
            lo in prop::array::uniform3(-100.0f32..100.0),
            size in prop::array::uniform3(0.0f32..50.0),
            fov in 5.0f32..150.0,
        ) {
            let (min, max) = (Vec3::from(lo), Vec3::from(lo) + Vec3::from(size));
            let m = frame_bounds(min, max, fov);
            let t = (0.5 * fov.to_radians()).tan() * (1.0 + 1e-4);
            let mut widest = 0.0f32;
            for i in 0..8 {
                let corner = Vec3::new(
                    if i & 1 == 0 { min.x } else { max.x },
                    if i & 2 == 0 { min.y } else { max.y },
                    if i & 4 == 0 { min.z } else { max.z },
                );
                let c = m.transform_point3(corner);
                prop_assert!(c.z > 0.0);
                prop_assert!((c.x / c.z).abs() <= t && (c.y / c.z).abs() <= t, "corner {corner} at {c}");
                widest = widest.max((c.x / c.z).abs()).max((c.y / c.z).abs());
            }
            // Framed, not lost in the distance (when the box is not flat in x and y).
            if size[0].max(size[1]) > 0.25 * size[2] && size[0].max(size[1]) > 1e-3 {
                prop_assert!(widest > 0.8 * t);
            }
        }

        #[test]
        fn gltf_row_vector_matrix_agrees_with_glam_everywhere(
            t in prop::array::uniform3(-10.0f32..10.0),
            e in prop::array::uniform3(-3.0f32..3.0),
            p in prop::array::uniform3(-10.0f32..10.0),
        ) {
            let m = Mat4::from_rotation_translation(Quat::from_euler(glam::EulerRot::ZYX, e[0], e[1], e[2]), Vec3::from(t));
            let q = to_row_vector(m).transform_point(obscura_sdk::Vec3::new(p[0], p[1], p[2]));
            let g = m.transform_point3(Vec3::from(p));
            prop_assert!((Vec3::new(q.x, q.y, q.z) - g).abs().max_element() < 1e-4);
        }
    }
}
