//! The current transform (CTM) and what changes it: the transform requests, `MotionBegin`/`MotionEnd`
//! blocks, and the `AttributeBegin`/`TransformBegin` blocks that save and restore it.

use glam::{Mat4, Vec3};
use obscura_sdk::MotionSample;

use super::lex::Value;
use super::request::Req;
use super::{Reader, RibError};
use crate::convert::to_row_vector;
use crate::types::MotionTransform;

/// The current transform: one sample when static (its time is then meaningless), else motion samples
/// sorted by time.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Ctm(pub(super) Vec<(f32, Mat4)>);

impl Ctm {
    /// The identity, static.
    pub(super) fn identity() -> Self {
        Ctm(vec![(0.0, Mat4::IDENTITY)])
    }

    /// Applies a transform request at every sample.
    pub(super) fn apply(&mut self, op: &Op) {
        match op {
            Op::Concat(m) => {
                for s in &mut self.0 {
                    s.1 *= *m;
                }
            }
            Op::Replace(m) => *self = Ctm(vec![(0.0, *m)]),
        }
    }

    /// The first sample (the transform itself when static).
    pub(super) fn first(&self) -> Mat4 {
        self.0.first().map_or(Mat4::IDENTITY, |s| s.1)
    }

    /// The transform at time `t`: matrix entries interpolated between samples, held beyond the ends.
    pub(super) fn at(&self, t: f32) -> Mat4 {
        let s = &self.0;
        match s.as_slice() {
            [] => Mat4::IDENTITY,
            [(_, m)] => *m,
            [(t0, m0), ..] if t <= *t0 => *m0,
            _ => {
                for w in s.windows(2) {
                    let ((t0, m0), (t1, m1)) = (w[0], w[1]);
                    if t <= t1 {
                        let f = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
                        return m0 * (1.0 - f) + m1 * f;
                    }
                }
                s.last().map_or(Mat4::IDENTITY, |l| l.1)
            }
        }
    }

    /// The samples as an object's transform.
    pub(super) fn to_motion(&self) -> MotionTransform {
        MotionTransform {
            samples: self.0.clone(),
        }
    }
}

/// What a transform request does to the CTM.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Op {
    /// `CTM = CTM · M` (Translate, Rotate, Scale, ConcatTransform).
    Concat(Mat4),
    /// `CTM = M` (Transform, Identity).
    Replace(Mat4),
}

/// Which kind of block an `…Begin` opened.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum BlockKind {
    /// `AttributeBegin`: restores the transform, the material, the dicing, the sides and orientation.
    Attribute,
    /// `TransformBegin`: restores the transform only.
    Transform,
}

impl BlockKind {
    /// The request that opens this kind of block.
    pub(super) fn begin(self) -> &'static str {
        match self {
            BlockKind::Attribute => "AttributeBegin",
            BlockKind::Transform => "TransformBegin",
        }
    }
    /// The request that closes it.
    pub(super) fn end(self) -> &'static str {
        match self {
            BlockKind::Attribute => "AttributeEnd",
            BlockKind::Transform => "TransformEnd",
        }
    }
}

/// An open `AttributeBegin`/`TransformBegin`: what to restore, and where it was opened.
pub(super) struct Block {
    pub(super) kind: BlockKind,
    pub(super) ctm: Ctm,
    pub(super) material: u32,
    pub(super) micropolygon_length: f32,
    pub(super) classic: super::classic_shaders::ClassicAttributes,
    pub(super) identifier: String,
    pub(super) facing: super::camera::Facing,
    pub(super) file: String,
    pub(super) line: u32,
}

/// An open `MotionBegin`.
pub(super) struct MotionBlock {
    pub(super) times: Vec<f32>,
    pub(super) ops: Vec<Op>,
    /// Requests other than transforms read in the block (deformation blur: only the first stands).
    pub(super) others: u32,
    pub(super) file: String,
    pub(super) line: u32,
}

/// The transform a request applies, or `None` when it is not a transform request.
pub(super) fn transform_op(r: &Req<'_>) -> Result<Option<Op>, RibError> {
    let op = match r.name {
        "Identity" => {
            r.only_numbers::<0>("no arguments")?;
            Op::Replace(Mat4::IDENTITY)
        }
        "Translate" => Op::Concat(Mat4::from_translation(Vec3::from(r.only_numbers::<3>("x y z")?))),
        "Scale" => Op::Concat(Mat4::from_scale(Vec3::from(r.only_numbers::<3>("x y z")?))),
        "Rotate" => {
            let [angle, x, y, z] = r.only_numbers::<4>("angle x y z")?;
            let axis = Vec3::new(x, y, z);
            if !(axis.length_squared() > 0.0 && axis.is_finite()) {
                return Err(r.err("Rotate expects a non-zero axis"));
            }
            Op::Concat(Mat4::from_axis_angle(axis.normalize(), angle.to_radians()))
        }
        "ConcatTransform" => Op::Concat(Mat4::from_cols_array(&r.only_numbers::<16>("a 4x4 matrix")?)),
        "Transform" => Op::Replace(Mat4::from_cols_array(&r.only_numbers::<16>("a 4x4 matrix")?)),
        _ => return Ok(None),
    };
    Ok(Some(op))
}

impl Reader {
    /// Stores the CTM (world-to-camera before `WorldBegin`) as the camera's motion samples; a static
    /// one is placed at shutter open.
    pub(super) fn store_camera_transform(&mut self) {
        let open = self.scene.camera.shutter.0;
        let samples = &self.ctm.0;
        self.scene.camera.world_to_camera = samples
            .iter()
            .map(|&(t, m)| MotionSample {
                time: if samples.len() == 1 { open } else { t },
                world_to_camera: to_row_vector(m),
            })
            .collect();
    }

    /// `AttributeBegin`/`TransformBegin`: saves what the matching end restores.
    pub(super) fn begin_block(&mut self, r: &Req<'_>, kind: BlockKind) -> Result<(), RibError> {
        self.blocks.push(Block {
            kind,
            ctm: self.ctm.clone(),
            material: self.material,
            micropolygon_length: self.micropolygon_length,
            classic: self.classic.clone(),
            identifier: self.identifier.clone(),
            facing: self.facing,
            file: r.file.to_string(),
            line: r.line,
        });
        Ok(())
    }

    /// `AttributeEnd`/`TransformEnd`: restores what the matching begin saved.
    pub(super) fn end_block(&mut self, r: &Req<'_>, kind: BlockKind) -> Result<(), RibError> {
        if self.world.is_some()
            && self.blocks.len() <= self.world_blocks
            && let Some(b) = self.blocks.last()
        {
            return Err(r.err(format!(
                "{} inside the world would close the {} at {}:{}, begun before WorldBegin",
                kind.end(),
                b.kind.begin(),
                b.file,
                b.line
            )));
        }
        let Some(b) = self.blocks.pop() else {
            return Err(r.err(format!("{} without a matching {}", kind.end(), kind.begin())));
        };
        if b.kind != kind {
            return Err(r.err(format!(
                "{} does not match {} at {}:{}",
                kind.end(),
                b.kind.begin(),
                b.file,
                b.line
            )));
        }
        self.ctm = b.ctm;
        if kind == BlockKind::Attribute {
            self.material = b.material;
            self.micropolygon_length = b.micropolygon_length;
            self.classic = b.classic;
            self.identifier = b.identifier;
            self.facing = b.facing;
        }
        Ok(())
    }

    /// `MotionBegin [times]`: the following transform requests are collected, not applied.
    pub(super) fn motion_begin(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let times: Vec<f32> = match r.args {
            [Value::Nums(t)] if !t.is_empty() => t.iter().map(|n| n.value as f32).collect(),
            args if !args.is_empty() && args.iter().all(|a| matches!(a, Value::Num(_))) => args
                .iter()
                .filter_map(|a| {
                    if let Value::Num(n) = a {
                        Some(n.value as f32)
                    } else {
                        None
                    }
                })
                .collect(),
            _ => return Err(r.err("MotionBegin expects an array of times, e.g. MotionBegin [0 1]")),
        };
        if times.windows(2).any(|w| w[0] >= w[1]) {
            return Err(r.err(format!("MotionBegin expects increasing times, got {times:?}")));
        }
        self.motion = Some(MotionBlock {
            times,
            ops: Vec::new(),
            others: 0,
            file: r.file.to_string(),
            line: r.line,
        });
        Ok(())
    }

    /// `MotionEnd`: the collected requests give the CTM one sample per time.
    pub(super) fn motion_end(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let Some(m) = self.motion.take() else {
            return Err(r.err("MotionEnd without a matching MotionBegin"));
        };
        let (n, k) = (m.times.len(), m.ops.len());
        if k == 0 {
            // A block of deforming geometry (its first time was read) or of requests skipped with a
            // warning: nothing moves.
            return Ok(());
        }
        if k == 0 || k % n != 0 {
            return Err(r.err(format!(
                "MotionEnd: MotionBegin at {}:{} gives {n} times but the block holds {k} transform requests; expected {n} (one per time, or a multiple of {n} for several groups)",
                m.file, m.line
            )));
        }
        let samples = m
            .times
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let mut at_t = Ctm(vec![(t, self.ctm.at(t))]);
                for op in m.ops.iter().skip(i).step_by(n) {
                    at_t.apply(op);
                }
                (t, at_t.first())
            })
            .collect();
        self.ctm = Ctm(samples);
        Ok(())
    }
}
