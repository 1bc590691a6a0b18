//! The ASCII RIB reader: RenderMan Interface Bytestream → [`Scene`].
//!
//! Reads the subset of RIB a camera user needs: the options that describe the image and the camera
//! (`Format`, `ScreenWindow`, `CropWindow`, `Shutter`, `Clipping`, `PixelFilter`, `Hider`, `PixelSamples`, `Display`,
//! `Projection`, `Camera`), transforms and motion blocks, attribute and transform blocks, the quadrics,
//! polygons (triangulated on load) and Catmull–Clark subdivision meshes, `Bxdf` materials, lights and
//! `ReadArchive`; and classic RenderMan Interface scenes: `Color`, `Opacity`, the standard `Surface`
//! and `LightSource` shaders (mapped to physically based materials and lights), `Basis`, `Patch`,
//! `PatchMesh`, `NuPatch`, `Hyperboloid`, `Paraboloid`, `Curves`, `Points`, `Blobby`,
//! `Geometry "teapot"`, retained objects, `Procedural "DelayedReadArchive"` and `SolidBegin`; and
//! the RI camera model (`camera.rs`): `FrameAspectRatio`, `Perspective`, `DepthOfField`, `Exposure`,
//! `ClippingPlane`, coordinate systems, and the orientation attributes `Sides`, `Orientation`,
//! `ReverseOrientation`.
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
//! (`ReadArchive`, `Display`, `lightColorMap`, textures) resolve against the directory of the file that
//! names them; `ReadArchive` and classic textures look through `Option "searchpath"` first.
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
//! cut by `triangulate.rs`); the classic requests in `classic_shaders.rs`, `patch.rs` (with the
//! teapot's data in `teapot.rs`), `nupatch.rs`, `curves.rs`, `blobby.rs` and `objects.rs`. A new
//! request is one row of `REQUESTS` and one method.

mod binary;
mod blobby;
mod camera;
mod classic_shaders;
mod curves;
mod display;
mod frames;
mod geometry;
mod lex;
mod nupatch;
mod objects;
mod options;
mod patch;
mod pattern;
mod request;
mod searchpath;
mod sensor;
mod shading;
mod teapot;
mod transform;
mod triangulate;

#[cfg(test)]
mod tests;

use std::collections::{HashMap, HashSet};
use std::path::Path;

use obscura_host::CameraDesc;
use obscura_sdk::{Format, parse_declaration};

pub use frames::Frame;

use crate::types::Scene;
use frames::{CameraLight, OpenFrame, Saved};
use lex::{Value, lex};
use request::{Req, normalize_declaration};
use transform::{Block, BlockKind, Ctm, MotionBlock, transform_op};

/// A RIB file could not be read: names the file, the line (or, in binary RIB, the request's index and
/// byte offset) and what was expected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}: {message}", self.location())]
pub struct RibError {
    /// The file: the name given to [`parse_str`], the path given to [`parse_file`], or an archive's path.
    pub file: String,
    /// The line (from 1) of the request at fault; 0 when the file as a whole is at fault.
    pub line: u32,
    /// In binary RIB: the index (from 0) of the request at fault among the file's requests.
    pub request: Option<u32>,
    /// In binary RIB: the byte offset of the request (or of the token) at fault.
    pub byte: Option<u64>,
    /// What was expected and what was found.
    pub message: String,
}

impl RibError {
    /// An error about the file as a whole (`line` 0).
    fn whole_file(file: &str, message: impl Into<String>) -> Self {
        RibError {
            file: file.to_string(),
            line: 0,
            request: None,
            byte: None,
            message: message.into(),
        }
    }

    /// `file:line`, `file: request N at byte B` (binary RIB), or `file` alone.
    fn location(&self) -> String {
        match (self.request, self.byte) {
            (Some(i), Some(b)) => format!("{}: request {i} at byte {b}", self.file),
            (None, Some(b)) => format!("{}: byte {b}", self.file),
            _ if self.line == 0 => self.file.clone(),
            _ => format!("{}:{}", self.file, self.line),
        }
    }
}

/// The bytes of a RIB file, decompressed when they are gzip (by content, whatever the name). A
/// path `archive.zip!member` names a member of a zip file, as RenderMan reads them (RenderMan for
/// Maya writes its geometry caches so).
fn read_rib_bytes(path: &Path) -> Result<Vec<u8>, String> {
    let text = path.to_string_lossy();
    let bytes = match text.find(".zip!") {
        Some(at) => {
            let (zip, member) = (Path::new(&text[..at + 4]), &text[at + 5..]);
            let file = std::fs::File::open(zip)
                .map_err(|e| format!("cannot read the zip file {}: {e}", zip.display()))?;
            let mut archive = zip::ZipArchive::new(file)
                .map_err(|e| format!("{} is not a zip file that can be read: {e}", zip.display()))?;
            let mut entry = archive.by_name(member).map_err(|e| {
                format!(
                    "cannot read \"{member}\" from the zip file {}: {e}",
                    zip.display()
                )
            })?;
            let mut out = Vec::new();
            std::io::Read::read_to_end(&mut entry, &mut out).map_err(|e| {
                format!(
                    "cannot read \"{member}\" from the zip file {}: {e}",
                    zip.display()
                )
            })?;
            out
        }
        None => std::fs::read(path).map_err(|e| format!("cannot read the file: {e}"))?,
    };
    decompress(bytes)
}

/// `bytes`, decompressed when they are gzip (by content).
fn decompress(bytes: Vec<u8>) -> Result<Vec<u8>, String> {
    if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut out = Vec::new();
        std::io::Read::read_to_end(&mut flate2::read::MultiGzDecoder::new(&bytes[..]), &mut out)
            .map_err(|e| format!("the file is gzip-compressed but cannot be decompressed: {e}"))?;
        return Ok(out);
    }
    Ok(bytes)
}

/// Reads a RIB file (ASCII or binary, gzip-compressed or not) as one scene: its last image (a file
/// with shadow or bake passes ends with its beauty pass), with the warnings of every image. Relative
/// paths in it resolve against its directory. [`parse_file_frames`] gives every image.
///
/// # Errors
/// As [`parse_file_frames`].
pub fn parse_file(path: &Path) -> Result<Scene, RibError> {
    Ok(last_image(parse_file_frames(path)?))
}

/// Reads a RIB file (ASCII or binary, gzip-compressed or not) as its images: one per world, in file
/// order, each with the frame it belongs to (see [`Frame`]).
///
/// # Errors
/// A [`RibError`] when the file cannot be read, is empty, holds a malformed or misplaced request, or
/// has no `WorldBegin` (a fragment, such as an archive of options, describes nothing to render).
pub fn parse_file_frames(path: &Path) -> Result<Vec<Frame>, RibError> {
    let name = path.display().to_string();
    let bytes =
        std::fs::read(path).map_err(|e| RibError::whole_file(&name, format!("cannot read the file: {e}")))?;
    let base = path.parent().unwrap_or_else(|| Path::new(""));
    parse_file_bytes_frames(bytes, &name, base)
}

/// Reads the bytes of a RIB file as [`parse_file_frames`] reads the file (the same checks: gzip is
/// decompressed by content, an empty file or one without `WorldBegin` is an error). `name` is used in
/// messages; relative paths resolve against `base_dir`.
///
/// # Errors
/// As [`parse_file_frames`].
pub fn parse_file_bytes_frames(bytes: Vec<u8>, name: &str, base_dir: &Path) -> Result<Vec<Frame>, RibError> {
    let bytes = decompress(bytes).map_err(|m| RibError::whole_file(name, m))?;
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(RibError::whole_file(
            name,
            format!(
                "the file is empty ({} bytes): it holds no requests to render",
                bytes.len()
            ),
        ));
    }
    let mut reader = Reader::new();
    reader.run(&bytes, name, base_dir, 0)?;
    if reader.world.is_none() && reader.images.is_empty() {
        return Err(RibError::whole_file(
            name,
            "no WorldBegin: the file is a fragment (options or an archive for ReadArchive), not a scene; \
             a scene describes its world between WorldBegin and WorldEnd",
        ));
    }
    reader.finish()
}

/// The last image's scene, with the warnings of all.
fn last_image(frames: Vec<Frame>) -> Scene {
    let mut warnings = Vec::new();
    let mut last = None;
    for f in frames {
        warnings.extend(f.scene.warnings.iter().cloned());
        last = Some(f.scene);
    }
    let mut scene = last.unwrap_or_else(|| Scene::new(CameraDesc::new(Format::new(640, 480))));
    scene.warnings = warnings;
    scene
}

/// Reads RIB text as one scene (its last image, as [`parse_file`]). `name` is used in messages;
/// relative paths (ReadArchive, Display, lightColorMap) resolve against `base_dir`. Unlike
/// [`parse_file`], text without `WorldBegin` is read as options and an empty world.
///
/// # Errors
/// A [`RibError`] naming `name` (or an archive) and the line of the first malformed or misplaced request.
pub fn parse_str(text: &str, name: &str, base_dir: &Path) -> Result<Scene, RibError> {
    parse_bytes(text.as_bytes(), name, base_dir)
}

/// Reads RIB bytes: ASCII, binary, or both mixed (not gzip-compressed: [`parse_file`] decompresses).
/// As [`parse_str`] otherwise.
///
/// # Errors
/// A [`RibError`] naming `name` (or an archive) and the line, or for binary RIB the request's index and
/// byte offset, of the first malformed or misplaced request.
pub fn parse_bytes(bytes: &[u8], name: &str, base_dir: &Path) -> Result<Scene, RibError> {
    Ok(last_image(parse_bytes_frames(bytes, name, base_dir)?))
}

/// Reads RIB bytes as their images (see [`parse_file_frames`]); text without `WorldBegin` gives one
/// image of its options.
///
/// # Errors
/// As [`parse_bytes`].
pub fn parse_bytes_frames(bytes: &[u8], name: &str, base_dir: &Path) -> Result<Vec<Frame>, RibError> {
    let mut reader = Reader::new();
    reader.run(bytes, name, base_dir, 0)?;
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
const REQUESTS: [Request; 79] = {
    use Scope::{Anywhere, Options, World};
    [
        known("version", Anywhere, Reader::ignore),
        known("Version", Anywhere, Reader::ignore),
        known("FrameBegin", Anywhere, Reader::frame_begin),
        known("FrameEnd", Anywhere, Reader::frame_end),
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
        known("PixelSamples", Options, Reader::pixel_samples),
        known("Display", Options, Reader::display),
        known("Projection", Options, Reader::projection),
        known("Camera", Options, Reader::camera),
        known("FrameAspectRatio", Options, Reader::frame_aspect_ratio),
        known("Perspective", Anywhere, Reader::perspective),
        known("DepthOfField", Options, Reader::depth_of_field),
        known("Exposure", Options, Reader::exposure),
        known("CoordinateSystem", Anywhere, Reader::coordinate_system),
        known("CoordSysTransform", Anywhere, Reader::coord_sys_transform),
        known("ClippingPlane", Anywhere, Reader::clipping_plane),
        known("Sides", Anywhere, Reader::sides),
        known("Orientation", Anywhere, Reader::orientation),
        known("ReverseOrientation", Anywhere, Reader::reverse_orientation),
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
        known("Light", Anywhere, Reader::any_light),
        known("LightSource", Anywhere, Reader::any_light),
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
        // Classic shading and geometry (classic_shaders.rs, patch.rs, nupatch.rs, curves.rs, objects.rs).
        known("Color", Anywhere, Reader::color),
        known("Opacity", Anywhere, Reader::opacity),
        known("Surface", Anywhere, Reader::surface),
        known("Displacement", Anywhere, Reader::other_shader),
        known("Atmosphere", Anywhere, Reader::other_shader),
        known("Interior", Anywhere, Reader::other_shader),
        known("Exterior", Anywhere, Reader::other_shader),
        known("Imager", Anywhere, Reader::other_shader),
        known("Deformation", Anywhere, Reader::other_shader),
        known("Illuminate", Anywhere, Reader::illuminate),
        known("Basis", Anywhere, Reader::basis),
        known("Hyperboloid", World, Reader::quadric),
        known("Paraboloid", World, Reader::quadric),
        known("Patch", World, Reader::patch),
        known("PatchMesh", World, Reader::patch_mesh),
        known("NuPatch", World, Reader::nu_patch),
        known("TrimCurve", Anywhere, Reader::trim_curve),
        known("Curves", World, Reader::curves),
        known("Points", World, Reader::points),
        known("Geometry", World, Reader::geometry),
        known("ObjectBegin", Anywhere, Reader::object_begin),
        known("ObjectEnd", Anywhere, Reader::object_end),
        known("ObjectInstance", World, Reader::object_instance),
        known("Procedural", World, Reader::procedural),
        known("Procedural2", World, Reader::procedural2),
        known("SolidBegin", World, Reader::solid),
        known("SolidEnd", World, Reader::solid),
        known("Blobby", World, Reader::blobby),
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
    /// The current `Sides` and orientation.
    facing: camera::Facing,
    /// The open attribute and transform blocks, innermost last.
    blocks: Vec<Block>,
    /// The open motion block.
    motion: Option<MotionBlock>,
    /// `file:line` of `WorldBegin` once read.
    world: Option<String>,
    /// How many blocks were open at `WorldBegin` (transform blocks may enclose a world).
    world_blocks: usize,
    /// `Declare`d names → full declarations (`fov` → `float fov`).
    declared: HashMap<String, String>,
    /// Attributes already warned about (each is warned about once).
    warned_attributes: HashSet<String>,
    /// Options already warned about.
    warned_options: HashSet<String>,
    /// `file:line` of each of the scene's displays, in order.
    display_origins: Vec<String>,
    /// The open `FrameBegin`.
    frame: Option<OpenFrame>,
    /// The options as they were at the open world's `WorldBegin`.
    before_world: Option<Saved>,
    /// Lights read before `WorldBegin`, placed when it comes.
    camera_lights: Vec<CameraLight>,
    /// The images of the worlds read so far.
    images: Vec<Frame>,
    /// `FrameAspectRatio`.
    frame_aspect: Option<f32>,
    /// `DepthOfField`.
    depth_of_field: Option<camera::DepthOfField>,
    /// `CoordinateSystem`s: the CTM named, and whether it was named in the world.
    coordinate_systems: HashMap<String, (Ctm, bool)>,
    /// `ArchiveBegin` blocks read so far, by name.
    inline_archives: HashMap<String, Vec<lex::Command>>,
    /// The `ArchiveBegin` block being read.
    recording: Option<InlineArchive>,
    /// Classic shading attributes (`Color`, `Opacity`, `Surface`, `Basis`).
    classic: classic_shaders::ClassicAttributes,
    /// Classic shading state across the file.
    classic_state: classic_shaders::ClassicState,
    /// Retained objects.
    retained: objects::Retained,
    /// `Pattern` handles read so far.
    patterns: pattern::Patterns,
    /// `Option "searchpath"`.
    search: searchpath::SearchPaths,
    /// Whether a `Projection` request has been read (the scene's projection is no longer the default).
    projection_declared: bool,
}

/// An `ArchiveBegin` block being read.
struct InlineArchive {
    name: String,
    /// `ArchiveBegin`s nested inside it, not yet closed.
    nesting: u32,
    commands: Vec<lex::Command>,
    file: String,
    line: u32,
}

impl Reader {
    fn new() -> Self {
        Reader {
            scene: Scene::new(CameraDesc::new(Format::new(640, 480))),
            ctm: Ctm::identity(),
            material: 0,
            micropolygon_length: 1.0,
            identifier: String::new(),
            facing: camera::Facing::default(),
            blocks: Vec::new(),
            motion: None,
            world: None,
            world_blocks: 0,
            declared: HashMap::new(),
            warned_attributes: HashSet::new(),
            warned_options: HashSet::new(),
            display_origins: Vec::new(),
            frame: None,
            before_world: None,
            camera_lights: Vec::new(),
            images: Vec::new(),
            frame_aspect: None,
            depth_of_field: None,
            coordinate_systems: HashMap::new(),
            inline_archives: HashMap::new(),
            recording: None,
            classic: classic_shaders::ClassicAttributes::default(),
            classic_state: classic_shaders::ClassicState::default(),
            retained: objects::Retained::default(),
            patterns: pattern::Patterns::new(),
            search: searchpath::SearchPaths::default(),
            projection_declared: false,
        }
    }

    /// Reads the requests of `text` (from `file`, `depth` archives deep), resolving paths against `base`.
    fn run(&mut self, bytes: &[u8], file: &str, base: &Path, depth: u32) -> Result<(), RibError> {
        let commands = lex(bytes).map_err(|e| RibError {
            file: file.to_string(),
            line: e.line,
            request: None,
            byte: e.byte,
            message: e.message,
        })?;
        self.run_commands(&commands, file, base, depth)
    }

    /// Handles `commands` read from `file`: an `ArchiveBegin "name"` … `ArchiveEnd` block is kept,
    /// not run, until a `ReadArchive "name"` replays it (RISpec 3.3 inline archives).
    fn run_commands(
        &mut self,
        commands: &[lex::Command],
        file: &str,
        base: &Path,
        depth: u32,
    ) -> Result<(), RibError> {
        for c in commands {
            let r = Req {
                file,
                base,
                depth,
                name: &c.name,
                line: c.line,
                binary: c.binary,
                args: &c.args,
            };
            if let Some(rec) = &mut self.recording {
                match c.name.as_str() {
                    "ArchiveEnd" if rec.nesting == 0 => {
                        if let Some(rec) = self.recording.take() {
                            self.inline_archives.insert(rec.name, rec.commands);
                        }
                        continue;
                    }
                    "ArchiveBegin" => rec.nesting += 1,
                    "ArchiveEnd" => rec.nesting -= 1,
                    _ => {}
                }
                rec.commands.push(c.clone());
                continue;
            }
            match c.name.as_str() {
                "ArchiveBegin" => {
                    let Some(Value::Str(name)) = c.args.first() else {
                        return Err(r.err("ArchiveBegin expects an archive name (a string)"));
                    };
                    self.recording = Some(InlineArchive {
                        name: name.clone(),
                        nesting: 0,
                        commands: Vec::new(),
                        file: file.to_string(),
                        line: c.line,
                    });
                }
                "ArchiveEnd" => return Err(r.err("ArchiveEnd without a matching ArchiveBegin")),
                _ => self.request(&r)?,
            }
        }
        Ok(())
    }

    /// The images, once every block is closed: a world still open at the end of the file is closed
    /// there; text without any world gives one image of its options (and an empty world).
    fn finish(mut self) -> Result<Vec<Frame>, RibError> {
        if let Some(a) = &self.recording {
            return Err(RibError {
                line: a.line,
                ..RibError::whole_file(
                    &a.file,
                    format!("ArchiveBegin \"{}\" has no matching ArchiveEnd", a.name),
                )
            });
        }
        if let Some(m) = &self.motion {
            return Err(RibError {
                line: m.line,
                ..RibError::whole_file(&m.file, "MotionBegin has no matching MotionEnd")
            });
        }
        if let Some(b) = self.blocks.last() {
            return Err(RibError {
                line: b.line,
                ..RibError::whole_file(
                    &b.file,
                    format!("{} has no matching {}", b.kind.begin(), b.kind.end()),
                )
            });
        }
        self.close_world();
        if self.images.is_empty() {
            self.store_camera_transform();
            self.images.push(Frame {
                number: 1,
                numbered: false,
                world: String::new(),
                scene: self.scene,
            });
        }
        Ok(self.images)
    }

    /// `LightSource`/`Light`: in the world, a light; before `WorldBegin`, a light fixed to the camera.
    fn any_light(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        if self.world.is_some() {
            self.light(r)
        } else {
            self.camera_light(r)
        }
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
        if let Some(m) = &mut self.motion
            && r.name != "MotionEnd"
        {
            // Deformation blur: the request of the first time stands, the later ones are dropped.
            m.others += 1;
            if m.others > 1 {
                if m.others == 2 {
                    let at = format!("{}:{}", m.file, m.line);
                    self.warn(
                        r,
                        format!(
                            "{} inside MotionBegin (at {at}): deformation motion blur is not supported; \
                             the first time's {} stands, the others are dropped",
                            r.name, r.name
                        ),
                    );
                }
                return Ok(());
            }
        }
        match request.scope {
            Scope::Options if self.world.is_some() => {
                Err(r.err(format!("{} must come before WorldBegin", r.name)))
            }
            Scope::World if self.world.is_none() && self.retained.open.is_none() => {
                Err(r.err(format!("{} must come after WorldBegin", r.name)))
            }
            _ => (request.handle)(self, r),
        }
    }

    /// Requests that need nothing done (`version`, `FrameBegin`, `FrameEnd`).
    fn ignore(&mut self, _r: &Req<'_>) -> Result<(), RibError> {
        Ok(())
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
        if let Some(commands) = self.inline_archives.get(file.as_str()).cloned() {
            return self.run_commands(&commands, r.file, r.base, r.depth + 1);
        }
        let path = self
            .find_file(searchpath::Kind::Archive, r, file)
            .unwrap_or_else(|| r.resolve(file));
        let bytes =
            read_rib_bytes(&path).map_err(|e| r.err(format!("ReadArchive \"{}\": {e}", path.display())))?;
        let name = path.display().to_string();
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        self.run(&bytes, &name, &base, r.depth + 1)
    }
}
