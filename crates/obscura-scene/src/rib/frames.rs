//! Frames and worlds: `FrameBegin n`/`FrameEnd`, several `WorldBegin`/`WorldEnd` blocks per file, and
//! lights declared before `WorldBegin`.
//!
//! As RISpec 3.2 §4 says: `FrameBegin` saves the options (and the transform) and `FrameEnd` restores
//! them, so options set outside any frame persist into every frame and options set inside one do not
//! leak into the next. Each `WorldEnd` makes one image ([`Frame`]) from the options as they stood at
//! `WorldBegin` and the world's lights and geometry, which it then frees; without frame blocks the
//! options and camera carry over into the next world. A world not closed by the end of the file is
//! closed there. A file with shadow or bake passes thus gives one image per pass, in file order.
//!
//! Both also save the attributes (RISpec §4: every begin–end pair does), and what the world defines
//! goes with it: `WorldEnd` and `FrameEnd` bring back `Color`, `Opacity`, `Surface`, `Basis`,
//! `Sides` and the orientation, the current `Bxdf` and identifier as they were at the begin, and free
//! the retained objects (`ObjectBegin`), patterns and materials defined since; so a frame or a world
//! never inherits its predecessor's colour or shader, and never refers to a material or texture its
//! scene does not hold.
//!
//! A `LightSource` before `WorldBegin` lives in the space current at the call — camera space after
//! `Projection` — so it moves with the camera: it is kept with that transform and placed in the world
//! at `WorldBegin`, once the camera is known, at `world_to_camera⁻¹ · CTM`.

use std::collections::HashMap;
use std::path::PathBuf;

use super::lex::{BinaryAt, Value};
use super::request::Req;
use super::transform::{BlockKind, Ctm, Op};
use super::{Reader, RibError, classic_shaders, pattern, searchpath};
use crate::types::{Object, Scene};

/// One image of a RIB file: the frame it belongs to and the scene of its world.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// `FrameBegin`'s number; for a world outside any frame block, its position among the file's
    /// images (from 1).
    pub number: u32,
    /// True when the number came from `FrameBegin`.
    pub numbered: bool,
    /// `file:line` of the world's `WorldBegin`.
    pub world: String,
    /// The options in force at `WorldBegin` and the world's contents; its warnings are those read since
    /// the previous image.
    pub scene: Scene,
}

/// What `FrameBegin` and `WorldBegin` save: the options (the scene without its world), the attributes,
/// and the definitions that refer into the scene (materials, textures).
#[derive(Debug, Clone)]
pub(super) struct Saved {
    scene: Scene,
    ctm: Ctm,
    material: u32,
    micropolygon_length: f32,
    display_origins: Vec<String>,
    frame_aspect: Option<f32>,
    depth_of_field: Option<super::camera::DepthOfField>,
    /// `Color`, `Opacity`, `Surface`, `Basis`.
    classic: classic_shaders::ClassicAttributes,
    identifier: String,
    /// `Sides`, `Orientation`, `ReverseOrientation`.
    facing: super::camera::Facing,
    /// Retained objects by handle.
    objects: HashMap<String, Vec<Object>>,
    /// The classic materials interned so far: indices into `scene.materials`.
    interned: HashMap<String, u32>,
    /// `Pattern` handles: they hold indices into `scene.textures`.
    patterns: pattern::Patterns,
    /// `paintedplastic` textures: indices into `scene.textures`.
    painted: HashMap<PathBuf, u32>,
    /// `Option "searchpath"`.
    search: searchpath::SearchPaths,
    projection_declared: bool,
}

/// An open `FrameBegin`: its number, where it is, and the options to restore.
#[derive(Debug, Clone)]
pub(super) struct OpenFrame {
    number: u32,
    at: String,
    saved: Saved,
}

/// A `LightSource` read before `WorldBegin`, kept until the camera is known.
#[derive(Debug, Clone)]
pub(super) struct CameraLight {
    name: String,
    file: String,
    base: PathBuf,
    depth: u32,
    line: u32,
    binary: Option<BinaryAt>,
    args: Vec<Value>,
    ctm: Ctm,
}

impl Reader {
    /// The options and their state, as `FrameBegin` and `WorldBegin` save them.
    fn save(&self) -> Saved {
        Saved {
            scene: Scene {
                warnings: Vec::new(),
                ..self.scene.clone()
            },
            ctm: self.ctm.clone(),
            material: self.material,
            micropolygon_length: self.micropolygon_length,
            display_origins: self.display_origins.clone(),
            frame_aspect: self.frame_aspect,
            depth_of_field: self.depth_of_field,
            classic: self.classic.clone(),
            identifier: self.identifier.clone(),
            facing: self.facing,
            objects: self.retained.objects.clone(),
            interned: self.classic_state.materials.clone(),
            patterns: self.patterns.clone(),
            painted: self.classic_state.textures.clone(),
            search: self.search.clone(),
            projection_declared: self.projection_declared,
        }
    }

    /// Restores `saved`, keeping the warnings not yet handed out.
    fn restore(&mut self, saved: Saved) {
        let warnings = std::mem::take(&mut self.scene.warnings);
        self.scene = Scene {
            warnings,
            ..saved.scene
        };
        self.ctm = saved.ctm;
        self.material = saved.material;
        self.micropolygon_length = saved.micropolygon_length;
        self.display_origins = saved.display_origins;
        self.frame_aspect = saved.frame_aspect;
        self.depth_of_field = saved.depth_of_field;
        self.classic = saved.classic;
        self.identifier = saved.identifier;
        self.facing = saved.facing;
        self.retained.objects = saved.objects;
        self.classic_state.materials = saved.interned;
        self.patterns = saved.patterns;
        self.classic_state.textures = saved.painted;
        self.search = saved.search;
        self.projection_declared = saved.projection_declared;
    }

    /// `FrameBegin n`: saves the options.
    pub(super) fn frame_begin(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        if let Some(f) = &self.frame {
            return Err(r.err(format!(
                "FrameBegin inside the frame {} begun at {}: frames do not nest",
                f.number, f.at
            )));
        }
        if let Some(at) = &self.world {
            return Err(r.err(format!(
                "FrameBegin inside the world begun at {at}: WorldEnd is missing"
            )));
        }
        let number = match r.args {
            [] => self.images.len() as u32 + 1,
            [Value::Num(n)] => n.int.and_then(|i| u32::try_from(i).ok()).ok_or_else(|| {
                r.err(format!(
                    "FrameBegin expects a frame number (an integer ≥ 0), got {}",
                    n.value
                ))
            })?,
            _ => return Err(r.err("FrameBegin expects a frame number (one integer)")),
        };
        self.frame = Some(OpenFrame {
            number,
            at: r.at(),
            saved: self.save(),
        });
        Ok(())
    }

    /// `FrameEnd`: restores the options `FrameBegin` saved. An open world is closed first, with a
    /// warning.
    pub(super) fn frame_end(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        if self.world.is_some() {
            self.warn(
                r,
                "FrameEnd inside a world: WorldEnd is missing, the world ends here".into(),
            );
            self.world_end(r)?;
        }
        let Some(frame) = self.frame.take() else {
            return Err(r.err("FrameEnd without a matching FrameBegin"));
        };
        self.restore(frame.saved);
        Ok(())
    }

    /// `WorldBegin`: the CTM so far becomes the camera transform, the options are saved for the next
    /// world, the lights declared before it are placed, and the world starts at the identity.
    pub(super) fn world_begin(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        if let Some(at) = &self.world {
            return Err(r.err(format!("WorldBegin: the world block was already begun at {at}")));
        }
        // Exporters of the time (MTOR, Houdini) wrap the camera's motion and the world in one
        // TransformBegin/TransformEnd, which RenderMan accepts: only attribute blocks must be closed.
        if let Some(b) = self.blocks.iter().rev().find(|b| b.kind != BlockKind::Transform) {
            return Err(r.err(format!(
                "WorldBegin inside {} (at {}:{}): close it first",
                b.kind.begin(),
                b.file,
                b.line
            )));
        }
        self.world_blocks = self.blocks.len();
        self.before_world = Some(self.save());
        self.settle_camera(r)?;
        self.store_camera_transform();
        let camera_to_world = self.ctm.first().inverse();
        self.world = Some(r.at());
        for light in std::mem::take(&mut self.camera_lights) {
            let req = Req {
                file: &light.file,
                base: &light.base,
                depth: light.depth,
                name: &light.name,
                line: light.line,
                binary: light.binary,
                args: &light.args,
            };
            self.ctm = light.ctm;
            self.ctm.apply(&Op::Replace(camera_to_world * self.ctm.first()));
            self.light(&req)?;
        }
        self.ctm = Ctm::identity();
        Ok(())
    }

    /// `WorldEnd`: every attribute and transform block must be closed; the world becomes an image and
    /// the options return to what they were at `WorldBegin`.
    pub(super) fn world_end(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        if let Some(b) = self.blocks[self.world_blocks.min(self.blocks.len())..].last() {
            return Err(r.err(format!(
                "WorldEnd: {} at {}:{} has no matching {}",
                b.kind.begin(),
                b.file,
                b.line,
                b.kind.end()
            )));
        }
        self.close_world();
        Ok(())
    }

    /// Hands out the open world as an image and restores the options saved at its `WorldBegin`.
    pub(super) fn close_world(&mut self) {
        let Some(world) = self.world.take() else {
            return;
        };
        let (number, numbered) = match &self.frame {
            Some(f) => (f.number, true),
            None => (self.images.len() as u32 + 1, false),
        };
        let scene = Scene {
            warnings: std::mem::take(&mut self.scene.warnings),
            ..self.scene.clone()
        };
        self.images.push(Frame {
            number,
            numbered,
            world,
            scene,
        });
        if let Some(saved) = self.before_world.take() {
            self.restore(saved);
        }
    }

    /// A `LightSource` (or `Light`) before `WorldBegin`: kept with the CTM of the call until the camera
    /// is known.
    pub(super) fn camera_light(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        self.camera_lights.push(CameraLight {
            name: r.name.to_string(),
            file: r.file.to_string(),
            base: r.base.to_path_buf(),
            depth: r.depth,
            line: r.line,
            binary: r.binary,
            args: r.args.to_vec(),
            ctm: self.ctm.clone(),
        });
        Ok(())
    }
}
