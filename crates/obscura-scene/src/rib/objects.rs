//! Retained objects (`ObjectBegin`/`ObjectEnd`/`ObjectInstance`), procedurals (`Procedural
//! "DelayedReadArchive"`; `RunProgram` and `DynamicLoad` stop with a located message) and solids
//! (`SolidBegin`/`SolidEnd`: the primitives are drawn, with a warning that CSG is not applied).
//!
//! An object's geometry is recorded relative to the CTM at `ObjectBegin` (reset to the identity
//! there, restored at `ObjectEnd`); each `ObjectInstance` adds it under the current CTM with the
//! attributes current at the instance (the spec's rule), so one definition can be drawn in several
//! colours.

use std::collections::HashMap;

use glam::Mat4;

use super::lex::Value;
use super::request::{Req, get_string};
use super::transform::Ctm;
use super::{Reader, RibError};
use crate::types::{MotionTransform, Object};

/// The retained objects and the one being defined.
#[derive(Debug, Default)]
pub(super) struct Retained {
    /// Objects by handle.
    pub(super) objects: HashMap<String, Vec<Object>>,
    /// The definition open since `ObjectBegin`.
    pub(super) open: Option<Definition>,
}

/// An open `ObjectBegin`.
#[derive(Debug)]
pub(super) struct Definition {
    handle: String,
    saved_ctm: Ctm,
    pub(super) objects: Vec<Object>,
    at: String,
}

/// A handle: a number or a string, as text.
fn handle(r: &Req<'_>) -> Result<String, RibError> {
    match r.args.first() {
        Some(Value::Num(n)) => Ok(n.value.to_string()),
        Some(Value::Str(s)) => Ok(s.clone()),
        _ => Err(r.err(format!(
            "{} expects an object handle (a number or a string)",
            r.name
        ))),
    }
}

/// `outer · inner` at each motion sample (the inner object's own motion kept when the outer CTM
/// does not move).
fn compose(outer: &MotionTransform, inner: &MotionTransform) -> MotionTransform {
    let first = |m: &MotionTransform| m.samples.first().map_or(Mat4::IDENTITY, |s| s.1);
    if outer.samples.len() <= 1 {
        let o = first(outer);
        MotionTransform {
            samples: inner.samples.iter().map(|&(t, m)| (t, o * m)).collect(),
        }
    } else {
        let i = first(inner);
        MotionTransform {
            samples: outer.samples.iter().map(|&(t, m)| (t, m * i)).collect(),
        }
    }
}

impl Reader {
    /// `ObjectBegin handle`.
    pub(super) fn object_begin(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let handle = handle(r)?;
        if let Some(d) = &self.retained.open {
            return Err(r.err(format!(
                "ObjectBegin inside the ObjectBegin at {}: objects do not nest",
                d.at
            )));
        }
        let saved_ctm = std::mem::replace(&mut self.ctm, Ctm::identity());
        self.retained.open = Some(Definition {
            handle,
            saved_ctm,
            objects: Vec::new(),
            at: r.at(),
        });
        Ok(())
    }

    /// `ObjectEnd`.
    pub(super) fn object_end(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let Some(d) = self.retained.open.take() else {
            return Err(r.err("ObjectEnd without a matching ObjectBegin"));
        };
        self.ctm = d.saved_ctm;
        self.retained.objects.insert(d.handle, d.objects);
        Ok(())
    }

    /// `ObjectInstance handle`.
    pub(super) fn object_instance(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let handle = handle(r)?;
        let Some(objects) = self.retained.objects.get(&handle) else {
            return Err(r.err(format!(
                "ObjectInstance: no object \"{handle}\" was defined (ObjectBegin)"
            )));
        };
        let objects = objects.clone();
        let ctm = self.ctm.to_motion();
        let material = self.current_material();
        for mut o in objects {
            o.transform = compose(&ctm, &o.transform);
            o.material = material;
            // Sides and orientation are attributes: an instance takes those current where it is placed.
            o.sides = self.current_sides();
            o.identity.instance.clone_from(&self.identifier);
            o.source = format!("{} (object \"{handle}\" of {})", r.at(), o.source);
            self.scene.objects.push(o);
        }
        Ok(())
    }

    /// `Procedural "DelayedReadArchive" [file] [bound]` reads the archive in place; other kinds stop.
    pub(super) fn procedural(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(kind), args, ..] = r.args else {
            return Err(r.err("Procedural expects a kind, [arguments] and [bound]"));
        };
        match (kind.as_str(), args) {
            ("DelayedReadArchive", Value::Strs(files)) if !files.is_empty() => {
                let file = [Value::Str(files[0].clone())];
                let inner = Req { args: &file, ..*r };
                self.read_archive(&inner)
            }
            ("DelayedReadArchive", _) => Err(r.err("Procedural \"DelayedReadArchive\" expects [\"file\"]")),
            ("RunProgram" | "DynamicLoad", _) => Err(r.err(format!(
                "Procedural \"{kind}\" is not supported (it runs a program or loads a library); expand it to RIB first"
            ))),
            (other, _) => Err(r.err(format!(
                "Procedural \"{other}\" is not known (known: DelayedReadArchive)"
            ))),
        }
    }

    /// `Procedural2 "DelayedReadArchive2" "SimpleBound" "string filename" [file] "float[6] bound" […]`
    /// (RenderMan 21) reads the archive in place, as `DelayedReadArchive`; other kinds stop.
    pub(super) fn procedural2(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(kind), Value::Str(_bound_kind), rest @ ..] = r.args else {
            return Err(r.err("Procedural2 expects a kind and a bound kind (2 strings) then parameters"));
        };
        if kind != "DelayedReadArchive2" {
            return Err(r.err(format!(
                "Procedural2 \"{kind}\" is not supported (known: DelayedReadArchive2); expand it to RIB first"
            )));
        }
        let list = self.params(r, rest, &["string filename", "float[6] bound"], false)?;
        let Some(file) = get_string(&list, "filename").filter(|f| !f.is_empty()) else {
            return Err(r.err("Procedural2 \"DelayedReadArchive2\" expects \"string filename\" [\"file\"]"));
        };
        let file = [Value::Str(file.to_string())];
        self.read_archive(&Req { args: &file, ..*r })
    }

    /// `SolidBegin`/`SolidEnd`: the primitives inside are drawn as they are, with one warning.
    pub(super) fn solid(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        if r.name == "SolidBegin" {
            self.warn_once(
                r,
                "solid",
                "SolidBegin: constructive solid geometry is not applied; the solids' surfaces are drawn as they are".into(),
            );
        }
        Ok(())
    }
}
