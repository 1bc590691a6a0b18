//! The ASCII RIB reader: RenderMan Interface Bytestream → [`Scene`].
//!
//! Reads the subset of RIB a camera user needs: the options that describe the image and the camera
//! (`Format`, `ScreenWindow`, `CropWindow`, `Shutter`, `Clipping`, `PixelFilter`, `Hider`, `Display`,
//! `Projection`, `Camera`), transforms and motion blocks, attribute and transform blocks, the quadrics,
//! polygons (triangulated on load) and Catmull–Clark subdivision meshes, `Bxdf` materials, lights and
//! `ReadArchive`.
//!
//! # Transforms
//!
//! As the RenderMan Interface says, each transform request applies to points *before* the current
//! transform (CTM): in glam's column-vector form the CTM becomes `CTM · T`, so the request written last
//! acts on the object first (`Translate 1 0 0` then `Scale 2 2 2` sends (1, 0, 0) to (3, 0, 0)).
//! `Rotate θ x y z` is `Mat4::from_axis_angle(normalize(x, y, z), θ°)`: `Rotate 90 0 0 1` sends +X to +Y.
//! A RIB matrix (`ConcatTransform`, `Transform`), sixteen numbers row-major for row vectors, is
//! `Mat4::from_cols_array` of the same sixteen numbers. `Transform` and `Identity` replace the CTM.
//!
//! Before `WorldBegin` the CTM is world-to-camera; `WorldBegin` stores it in
//! [`CameraDesc::world_to_camera`](obscura_host::CameraDesc) as the SDK's row-vector
//! [`Matrix4`] (its rows are glam's columns) and resets the CTM to the identity, which then maps object
//! to world space.
//!
//! # Motion
//!
//! `MotionBegin [t0 … tn-1]` … `MotionEnd` holds transform requests, `n` per group: the k-th request
//! of each group is the transform at time `tk`. Before `WorldBegin` this moves the camera; in the world
//! it makes the CTM a motion transform, which later static transforms modify at every time, and which
//! objects take as their [`Object::transform`]. A block whose times differ from those of an enclosing
//! motion transform resamples it (matrix entries interpolated linearly) at the block's times.
//!
//! # Messages
//!
//! Errors ([`RibError`]) stop the reading and name the file, the line of the request and what was
//! expected. Unknown requests, unknown parameters and unsupported attributes, hiders, lights, Bxdfs and
//! subdivision tags are skipped with a warning `file:line: …` in [`Scene::warnings`]. Relative paths
//! (`ReadArchive`, `Display`, `lightColorMap`) resolve against the directory of the file that names them.
//!
//! [`Matrix4`]: obscura_sdk::Matrix4
//! [`Object::transform`]: crate::types::Object::transform
//!
//! # Layout
//!
//! `lex.rs` turns text into requests (a name, its line, its arguments); the `REQUESTS` table in this
//! file says where each known request may stand and which method of the reader handles it;
//! `request.rs` gives those methods typed access to the arguments and parameter lists. The handlers
//! are grouped by what they describe: `options.rs` (the image and the camera), `transform.rs` (the
//! CTM, motion and blocks), `shading.rs` (dicing, materials, lights) and `geometry.rs` (with polygons
//! cut by `triangulate.rs`). A new request is one row of `REQUESTS` and one method.

mod geometry;
mod lex;
mod options;
mod pattern;
mod request;
mod shading;
mod transform;
mod triangulate;

#[cfg(test)]
mod tests;

use std::collections::{HashMap, HashSet};
use std::path::Path;

use obscura_host::CameraDesc;
use obscura_sdk::{Format, parse_declaration};

use crate::types::Scene;
use lex::{Value, lex};
use request::{Req, normalize_declaration};
use transform::{Block, BlockKind, Ctm, MotionBlock, transform_op};

/// A RIB file could not be read: names the file, the line and what was expected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}:{line}: {message}")]
pub struct RibError {
    /// The file: the name given to [`parse_str`], the path given to [`parse_file`], or an archive's path.
    pub file: String,
    /// The line (from 1) of the request at fault; 0 when the file itself could not be read.
    pub line: u32,
    /// What was expected and what was found.
    pub message: String,
}

/// Reads a RIB file; relative paths in it resolve against its directory.
///
/// # Errors
/// A [`RibError`] when the file cannot be read or holds a malformed or misplaced request.
pub fn parse_file(path: &Path) -> Result<Scene, RibError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| RibError {
        file: name.clone(),
        line: 0,
        message: format!("cannot read the file: {e}"),
    })?;
    let base = path.parent().unwrap_or_else(|| Path::new(""));
    parse_str(&text, &name, base)
}

/// Reads RIB text. `name` is used in messages; relative paths (ReadArchive, Display, lightColorMap)
/// resolve against `base_dir`.
///
/// # Errors
/// A [`RibError`] naming `name` (or an archive) and the line of the first malformed or misplaced request.
pub fn parse_str(text: &str, name: &str, base_dir: &Path) -> Result<Scene, RibError> {
    let mut reader = Reader::new();
    reader.run(text, name, base_dir, 0)?;
    reader.finish()
}

/// Archives may nest this deep; deeper is taken for a cycle.
const MAX_ARCHIVE_DEPTH: u32 = 32;

/// Where a request may stand in a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scope {
    /// Anywhere.
    Anywhere,
    /// Only before `WorldBegin`: the options.
    Options,
    /// Only after `WorldBegin`: geometry, lights and `WorldEnd`.
    World,
}

/// The reader's method for one request.
type Handler = fn(&mut Reader, &Req<'_>) -> Result<(), RibError>;

/// A request the reader knows: its name, where it may stand, and its handler.
struct Request {
    name: &'static str,
    scope: Scope,
    handle: Handler,
}

/// A row of [`REQUESTS`].
const fn known(name: &'static str, scope: Scope, handle: Handler) -> Request {
    Request { name, scope, handle }
}

/// Every request the reader knows besides the transform requests (`Identity`, `Translate`, `Rotate`,
/// `Scale`, `ConcatTransform`, `Transform`), which [`transform_op`] reads first because a motion block
/// collects them instead of applying them. Any other request is skipped with a warning.
const REQUESTS: [Request; 40] = {
    use Scope::{Anywhere, Options, World};
    [
        known("version", Anywhere, Reader::ignore),
        known("Version", Anywhere, Reader::ignore),
        known("FrameBegin", Anywhere, Reader::ignore),
        known("FrameEnd", Anywhere, Reader::ignore),
        known("WorldBegin", Anywhere, Reader::world_begin),
        known("WorldEnd", World, Reader::world_end),
        known("Declare", Anywhere, Reader::declare),
        known("Option", Anywhere, Reader::option),
        known("Format", Options, Reader::format),
        known("ScreenWindow", Options, Reader::screen_window),
        known("CropWindow", Options, Reader::crop_window),
        known("Shutter", Options, Reader::shutter),
        known("Clipping", Options, Reader::clipping),
        known("PixelFilter", Options, Reader::pixel_filter),
        known("Hider", Options, Reader::hider),
        known("Display", Options, Reader::display),
        known("Projection", Options, Reader::projection),
        known("Camera", Options, Reader::camera),
        known("MotionBegin", Anywhere, Reader::motion_begin),
        known("MotionEnd", Anywhere, Reader::motion_end),
        known("AttributeBegin", Anywhere, |rd, r| {
            rd.begin_block(r, BlockKind::Attribute)
        }),
        known("AttributeEnd", Anywhere, |rd, r| {
            rd.end_block(r, BlockKind::Attribute)
        }),
        known("TransformBegin", Anywhere, |rd, r| {
            rd.begin_block(r, BlockKind::Transform)
        }),
        known("TransformEnd", Anywhere, |rd, r| {
            rd.end_block(r, BlockKind::Transform)
        }),
        known("Attribute", Anywhere, Reader::attribute),
        known("Bxdf", Anywhere, Reader::bxdf),
        known("Pattern", Anywhere, Reader::pattern),
        known("Light", World, Reader::light),
        known("LightSource", World, Reader::light),
        known("AreaLightSource", World, Reader::light),
        known("ReadArchive", Anywhere, Reader::read_archive),
        known("Sphere", World, Reader::quadric),
        known("Cylinder", World, Reader::quadric),
        known("Cone", World, Reader::quadric),
        known("Disk", World, Reader::quadric),
        known("Torus", World, Reader::quadric),
        known("Polygon", World, Reader::polygons),
        known("PointsPolygons", World, Reader::polygons),
        known("PointsGeneralPolygons", World, Reader::polygons),
        known("SubdivisionMesh", World, Reader::subdivision_mesh),
    ]
};

/// The reading state: the scene so far and the graphics state RIB requests change.
struct Reader {
    /// The scene so far.
    scene: Scene,
    /// The current transform.
    ctm: Ctm,
    /// The current material: an index into the scene's materials.
    material: u32,
    /// The current `Attribute "dice" "micropolygonlength"`.
    micropolygon_length: f32,
    /// The current `Attribute "identifier" "name"` (empty before one).
    identifier: String,
    /// The open attribute and transform blocks, innermost last.
    blocks: Vec<Block>,
    /// The open motion block.
    motion: Option<MotionBlock>,
    /// `file:line` of `WorldBegin` once read.
    world: Option<String>,
    /// `Declare`d names → full declarations (`fov` → `float fov`).
    declared: HashMap<String, String>,
    /// Attributes already warned about (each is warned about once).
    warned_attributes: HashSet<String>,
    /// Options already warned about.
    warned_options: HashSet<String>,
    /// `Pattern` handles read so far.
    patterns: pattern::Patterns,
}

impl Reader {
    fn new() -> Self {
        Reader {
            scene: Scene::new(CameraDesc::new(Format::new(640, 480))),
            ctm: Ctm::identity(),
            material: 0,
            micropolygon_length: 1.0,
            identifier: String::new(),
            blocks: Vec::new(),
            motion: None,
            world: None,
            declared: HashMap::new(),
            warned_attributes: HashSet::new(),
            warned_options: HashSet::new(),
            patterns: pattern::Patterns::new(),
        }
    }

    /// Reads the requests of `text` (from `file`, `depth` archives deep), resolving paths against `base`.
    fn run(&mut self, text: &str, file: &str, base: &Path, depth: u32) -> Result<(), RibError> {
        let commands = lex(text).map_err(|e| RibError {
            file: file.to_string(),
            line: e.line,
            message: e.message,
        })?;
        for c in &commands {
            let r = Req {
                file,
                base,
                depth,
                name: &c.name,
                line: c.line,
                args: &c.args,
            };
            self.request(&r)?;
        }
        Ok(())
    }

    /// The scene, once every block is closed.
    fn finish(mut self) -> Result<Scene, RibError> {
        if let Some(m) = &self.motion {
            return Err(RibError {
                file: m.file.clone(),
                line: m.line,
                message: "MotionBegin has no matching MotionEnd".into(),
            });
        }
        if let Some(b) = self.blocks.last() {
            return Err(RibError {
                file: b.file.clone(),
                line: b.line,
                message: format!("{} has no matching {}", b.kind.begin(), b.kind.end()),
            });
        }
        if self.world.is_none() {
            self.store_camera_transform();
        }
        Ok(self.scene)
    }

    /// Records a warning at the request.
    fn warn(&mut self, r: &Req<'_>, message: String) {
        self.scene.warnings.push(format!("{}: {message}", r.at()));
    }

    /// Handles one request: a transform request changes the CTM (or joins the open motion block); a
    /// known one is checked against its [`Scope`] and handed to its handler; an unknown one is warned
    /// about.
    fn request(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        if let Some(op) = transform_op(r)? {
            match &mut self.motion {
                Some(m) => m.ops.push(op),
                None => self.ctm.apply(&op),
            }
            return Ok(());
        }
        let Some(request) = REQUESTS.iter().find(|q| q.name == r.name) else {
            self.warn(r, format!("unknown request {}, skipped", r.name));
            return Ok(());
        };
        if let Some(m) = &self.motion
            && r.name != "MotionEnd"
        {
            return Err(r.err(format!(
                "{} inside MotionBegin (at {}:{}): only transform requests may move",
                r.name, m.file, m.line
            )));
        }
        match request.scope {
            Scope::Options if self.world.is_some() => {
                Err(r.err(format!("{} must come before WorldBegin", r.name)))
            }
            Scope::World if self.world.is_none() => {
                Err(r.err(format!("{} must come after WorldBegin", r.name)))
            }
            _ => (request.handle)(self, r),
        }
    }

    /// Requests that need nothing done (`version`, `FrameBegin`, `FrameEnd`).
    fn ignore(&mut self, _r: &Req<'_>) -> Result<(), RibError> {
        Ok(())
    }

    /// `WorldBegin`: the CTM so far becomes the camera transform, and the world starts at the identity.
    fn world_begin(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        if let Some(at) = &self.world {
            return Err(r.err(format!("WorldBegin: the world block was already begun at {at}")));
        }
        if let Some(b) = self.blocks.last() {
            return Err(r.err(format!(
                "WorldBegin inside {} (at {}:{}): close it first",
                b.kind.begin(),
                b.file,
                b.line
            )));
        }
        self.store_camera_transform();
        self.ctm = Ctm::identity();
        self.world = Some(r.at());
        Ok(())
    }

    /// `WorldEnd`: every attribute and transform block must be closed.
    fn world_end(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        match self.blocks.last() {
            Some(b) => Err(r.err(format!(
                "WorldEnd: {} at {}:{} has no matching {}",
                b.kind.begin(),
                b.file,
                b.line,
                b.kind.end()
            ))),
            None => Ok(()),
        }
    }

    /// `Declare "name" "type"`: lets later parameter lists write `name` bare.
    fn declare(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name), Value::Str(decl)] = r.args else {
            return Err(
                r.err("Declare expects a name and a type (2 strings), e.g. Declare \"fov\" \"float\"")
            );
        };
        let full = normalize_declaration(&format!("{decl} {name}"));
        parse_declaration(&full).map_err(|e| r.err(format!("Declare: {e}")))?;
        self.declared.insert(name.clone(), full);
        Ok(())
    }

    /// `ReadArchive "file"`: reads the file in place, with the same state, relative to its own folder.
    fn read_archive(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(file)] = r.args else {
            return Err(r.err("ReadArchive expects a file name (one string)"));
        };
        if r.depth >= MAX_ARCHIVE_DEPTH {
            return Err(r.err(format!(
                "ReadArchive \"{file}\": archives nested more than {MAX_ARCHIVE_DEPTH} deep (does an archive read itself?)"
            )));
        }
        let path = r.resolve(file);
        let text = std::fs::read_to_string(&path)
            .map_err(|e| r.err(format!("ReadArchive: cannot read \"{}\": {e}", path.display())))?;
        let name = path.display().to_string();
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        self.run(&text, &name, &base, r.depth + 1)
    }
}
