//! The messages between a host and its plugin worker, and their byte form.
//!
//! Each message is a little-endian `u32` length, then that many bytes: a tag byte and the fields in
//! order. Floats travel as their bits, so a value arrives exactly as it left. The batch arrays do not
//! travel here: they are in the shared memory (`shm.rs`); a `Project` request only says how many
//! rays.

use std::borrow::Cow;
use std::io::{Read, Write};

use obscura_sdk::{
    DeepMetric, DicingHint, Format, Matrix4, MotionSample, ParamDecl, ParamList, ParamType, ParamValue,
    PluginError, Point2, ProjectionEnvironment, ProjectionProperty, PropertyValue, ScreenWindow, SyncMessage,
    ValueRange, Vec3,
};

/// Largest message accepted (the biggest is a description with its parameter table).
const MAX_MESSAGE: u32 = 64 << 20;

/// A host → worker request.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    /// Open the library at this path and describe it.
    Load(String),
    /// `ProjectionFactory::init` with the plugin path.
    Init(String),
    /// `ProjectionFactory::synchronize`.
    Sync(SyncMessage, Option<ParamList>),
    /// `create_projection`, keeping the projection as this id.
    Create(u64, ProjectionEnvironment, ParamList),
    /// Drop the projection of this id.
    Destroy(u64),
    /// `ProjectionFactory::finalize`.
    Finalize,
    /// `Projection::property`.
    Property(u64, ProjectionProperty),
    /// `Projection::project` on the first `n` rays of the shared memory, which is `len` bytes long.
    Project {
        /// The projection.
        id: u64,
        /// Rays in the batch.
        n: u64,
        /// Length of the shared memory.
        len: u64,
    },
    /// `Projection::unproject`.
    Unproject(u64, Vec3, f32),
}

/// What the library says of itself (its descriptor, as the worker decoded it).
#[derive(Debug, Clone, PartialEq)]
pub struct Description {
    /// The projection's name.
    pub name: String,
    /// Its one-line summary.
    pub summary: String,
    /// Its parameter table.
    pub table: Vec<ParamDecl>,
}

/// A worker → host reply.
#[derive(Debug, Clone, PartialEq)]
pub enum Reply {
    /// Done, nothing to say.
    Done,
    /// The library loaded and described itself.
    Described(Description),
    /// The library could not be loaded (the loader's message).
    LoadFailed(String),
    /// `init` or `create_projection` failed.
    Plugin(PluginError),
    /// A projection was created; the deep metric it left in the environment.
    Created(DeepMetric),
    /// A property's answer.
    Property(Option<PropertyValue>),
    /// An unproject's answer.
    Point(Option<Point2>),
    /// The call unwound: `project` returned `OBSCURA_ERROR` (`failed`) or something else (a status,
    /// a panic caught in the plugin, an undecodable value), with the message.
    Unwound {
        /// True for `OBSCURA_ERROR` from `project` (raised as a `ProjectFailed`).
        failed: bool,
        /// The message.
        message: String,
    },
}

/// Writes one message.
pub fn send(to: &mut impl Write, body: &[u8]) -> std::io::Result<()> {
    let mut framed = Vec::with_capacity(body.len() + 4);
    framed.extend_from_slice(&(body.len() as u32).to_le_bytes());
    framed.extend_from_slice(body);
    to.write_all(&framed)
}

/// Reads one message.
pub fn receive(from: &mut impl Read) -> std::io::Result<Vec<u8>> {
    let mut len = [0u8; 4];
    from.read_exact(&mut len)?;
    let len = u32::from_le_bytes(len);
    if len > MAX_MESSAGE {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("a message of {len} bytes (more than {MAX_MESSAGE})"),
        ));
    }
    let mut body = vec![0; len as usize];
    from.read_exact(&mut body)?;
    Ok(body)
}

/// A message being written.
#[derive(Default)]
struct Out(Vec<u8>);

impl Out {
    fn u8(&mut self, v: u8) -> &mut Self {
        self.0.push(v);
        self
    }
    fn u64(&mut self, v: u64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn f32(&mut self, v: f32) -> &mut Self {
        self.0.extend_from_slice(&v.to_bits().to_le_bytes());
        self
    }
    fn f64(&mut self, v: f64) -> &mut Self {
        self.0.extend_from_slice(&v.to_bits().to_le_bytes());
        self
    }
    fn bool(&mut self, v: bool) -> &mut Self {
        self.u8(u8::from(v))
    }
    fn str(&mut self, s: &str) -> &mut Self {
        self.u64(s.len() as u64);
        self.0.extend_from_slice(s.as_bytes());
        self
    }
    fn opt_str(&mut self, s: Option<&str>) -> &mut Self {
        match s {
            Some(s) => self.u8(1).str(s),
            None => self.u8(0),
        }
    }
    fn opt_len(&mut self, n: Option<usize>) -> &mut Self {
        match n {
            Some(n) => self.u8(1).u64(n as u64),
            None => self.u8(0),
        }
    }
    fn value(&mut self, v: &ParamValue) -> &mut Self {
        match v {
            ParamValue::Floats(f) => {
                self.u8(0).u64(f.len() as u64);
                f.iter().for_each(|&x| {
                    self.f32(x);
                });
            }
            ParamValue::Ints(i) => {
                self.u8(1).u64(i.len() as u64);
                i.iter().for_each(|&x| {
                    self.u64(x as u32 as u64);
                });
            }
            ParamValue::Strings(s) => {
                self.u8(2).u64(s.len() as u64);
                s.iter().for_each(|x| {
                    self.str(x);
                });
            }
        }
        self
    }
    fn ty(&mut self, t: ParamType) -> &mut Self {
        self.str(t.rib_name())
    }
    fn list(&mut self, l: &ParamList) -> &mut Self {
        self.u64(l.entries().len() as u64);
        for e in l.entries() {
            self.str(&e.name)
                .ty(e.ty)
                .opt_len(e.array_len)
                .value(&e.value)
                .opt_str(e.origin.as_deref());
        }
        self
    }
    fn decl(&mut self, d: &ParamDecl) -> &mut Self {
        self.str(&d.name)
            .ty(d.ty)
            .opt_len(d.array_len)
            .bool(d.variable_len)
            .value(&d.default);
        match &d.range {
            Some(r) => self
                .u8(1)
                .f64(r.min)
                .f64(r.max)
                .bool(r.min_inclusive)
                .bool(r.max_inclusive),
            None => self.u8(0),
        };
        self.u64(d.choices.len() as u64);
        d.choices.iter().for_each(|c| {
            self.str(c);
        });
        self.str(&d.doc)
    }
    fn env(&mut self, e: &ProjectionEnvironment) -> &mut Self {
        let f = e.format();
        let w = e.screen_window();
        self.u64(u64::from(f.width))
            .u64(u64::from(f.height))
            .f32(f.pixel_aspect)
            .f32(w.left)
            .f32(w.right)
            .f32(w.bottom)
            .f32(w.top)
            .f32(e.shutter_open())
            .f32(e.shutter_close())
            .f32(e.clipping_near())
            .f32(e.clipping_far())
            .u8(e.deep_metric() as u8)
            .u64(e.world_to_camera().len() as u64);
        for s in e.world_to_camera() {
            self.f32(s.time);
            s.world_to_camera.0.iter().flatten().for_each(|&x| {
                self.f32(x);
            });
        }
        self
    }
    fn property_value(&mut self, v: Option<PropertyValue>) -> &mut Self {
        match v {
            None => self.u8(0),
            Some(PropertyValue::DicingHint(h)) => self.u8(1).u8(h as u8),
            Some(PropertyValue::DeepMetric(m)) => self.u8(2).u8(m as u8),
            Some(PropertyValue::Float(f)) => self.u8(3).f32(f),
        }
    }
}

/// A message being read; every read fails cleanly on a short or malformed message.
struct In<'a>(&'a [u8]);

type Res<T> = Result<T, String>;

impl In<'_> {
    fn end<T>(&self, value: T) -> Res<T> {
        if self.0.is_empty() {
            Ok(value)
        } else {
            Err(format!("{} bytes left over after a message", self.0.len()))
        }
    }
    fn take(&mut self, n: usize) -> Res<&[u8]> {
        if self.0.len() < n {
            return Err("a message ended early".into());
        }
        let (head, rest) = self.0.split_at(n);
        self.0 = rest;
        Ok(head)
    }
    fn u8(&mut self) -> Res<u8> {
        Ok(self.take(1)?[0])
    }
    fn u64(&mut self) -> Res<u64> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes")))
    }
    fn u32(&mut self) -> Res<u32> {
        u32::try_from(self.u64()?).map_err(|_| "a number out of range".to_string())
    }
    fn len(&mut self) -> Res<usize> {
        let n = self.u64()?;
        if n > self.0.len() as u64 {
            return Err("a length longer than its message".into());
        }
        Ok(n as usize)
    }
    fn f32(&mut self) -> Res<f32> {
        Ok(f32::from_bits(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        )))
    }
    fn f64(&mut self) -> Res<f64> {
        Ok(f64::from_bits(self.u64()?))
    }
    fn bool(&mut self) -> Res<bool> {
        Ok(self.u8()? != 0)
    }
    fn str(&mut self) -> Res<String> {
        let n = self.len()?;
        String::from_utf8(self.take(n)?.to_vec()).map_err(|_| "a string that is not UTF-8".into())
    }
    fn opt_str(&mut self) -> Res<Option<String>> {
        Ok(if self.bool()? { Some(self.str()?) } else { None })
    }
    fn opt_len(&mut self) -> Res<Option<usize>> {
        Ok(if self.bool()? {
            Some(self.u64()? as usize)
        } else {
            None
        })
    }
    fn value(&mut self) -> Res<ParamValue> {
        let kind = self.u8()?;
        let n = self.len()?;
        Ok(match kind {
            0 => ParamValue::Floats((0..n).map(|_| self.f32()).collect::<Res<_>>()?),
            1 => ParamValue::Ints(
                (0..n)
                    .map(|_| Ok(self.u64()? as u32 as i32))
                    .collect::<Res<_>>()?,
            ),
            2 => ParamValue::Strings((0..n).map(|_| self.str()).collect::<Res<_>>()?),
            k => return Err(format!("unknown value kind {k}")),
        })
    }
    fn ty(&mut self) -> Res<ParamType> {
        let s = self.str()?;
        ParamType::from_rib_name(&s).ok_or_else(|| format!("unknown parameter type {s}"))
    }
    fn list(&mut self) -> Res<ParamList> {
        let n = self.len()?;
        let mut list = ParamList::new();
        for _ in 0..n {
            let (name, ty, len, value, origin) = (
                self.str()?,
                self.ty()?,
                self.opt_len()?,
                self.value()?,
                self.opt_str()?,
            );
            let decl = match len {
                Some(k) => format!("{}[{k}] {name}", ty.rib_name()),
                None => format!("{} {name}", ty.rib_name()),
            };
            list.push(&decl, value, origin).map_err(|e| e.to_string())?;
        }
        Ok(list)
    }
    fn decl(&mut self) -> Res<ParamDecl> {
        let name = self.str()?;
        let ty = self.ty()?;
        let array_len = self.opt_len()?;
        let variable_len = self.bool()?;
        let default = self.value()?;
        let range = if self.bool()? {
            Some(ValueRange {
                min: self.f64()?,
                max: self.f64()?,
                min_inclusive: self.bool()?,
                max_inclusive: self.bool()?,
            })
        } else {
            None
        };
        let n = self.len()?;
        let choices = (0..n).map(|_| self.str().map(Cow::Owned)).collect::<Res<_>>()?;
        Ok(ParamDecl {
            name: Cow::Owned(name),
            ty,
            array_len,
            variable_len,
            default,
            range,
            choices,
            doc: Cow::Owned(self.str()?),
        })
    }
    fn env(&mut self) -> Res<ProjectionEnvironment> {
        let format = Format {
            width: self.u32()?,
            height: self.u32()?,
            pixel_aspect: self.f32()?,
        };
        let window = ScreenWindow::new(self.f32()?, self.f32()?, self.f32()?, self.f32()?);
        let shutter = (self.f32()?, self.f32()?);
        let clipping = (self.f32()?, self.f32()?);
        let metric = deep_metric(self.u8()?)?;
        let n = self.len()?;
        let mut motion = Vec::with_capacity(n);
        for _ in 0..n {
            let time = self.f32()?;
            let mut m = [[0f32; 4]; 4];
            for x in m.iter_mut().flatten() {
                *x = self.f32()?;
            }
            motion.push(MotionSample {
                time,
                world_to_camera: Matrix4(m),
            });
        }
        let mut env = ProjectionEnvironment::new(format, window, shutter, clipping, motion);
        env.set_deep_metric(metric);
        Ok(env)
    }
    fn property_value(&mut self) -> Res<Option<PropertyValue>> {
        Ok(match self.u8()? {
            0 => None,
            1 => Some(PropertyValue::DicingHint(match self.u8()? {
                0 => DicingHint::Orthographic,
                1 => DicingHint::Perspective,
                2 => DicingHint::Spherical,
                h => return Err(format!("unknown dicing hint {h}")),
            })),
            2 => Some(PropertyValue::DeepMetric(deep_metric(self.u8()?)?)),
            3 => Some(PropertyValue::Float(self.f32()?)),
            k => return Err(format!("unknown property value kind {k}")),
        })
    }
}

fn deep_metric(m: u8) -> Res<DeepMetric> {
    match m {
        0 => Ok(DeepMetric::CameraZ),
        1 => Ok(DeepMetric::RayLength),
        m => Err(format!("unknown deep metric {m}")),
    }
}

fn sync_message(m: u8) -> Res<SyncMessage> {
    match m {
        0 => Ok(SyncMessage::RenderBegin),
        1 => Ok(SyncMessage::RenderEnd),
        2 => Ok(SyncMessage::InstanceEdit),
        m => Err(format!("unknown sync message {m}")),
    }
}

fn property(p: u8) -> Res<ProjectionProperty> {
    ProjectionProperty::ALL
        .get(usize::from(p))
        .copied()
        .ok_or_else(|| format!("unknown property {p}"))
}

impl Request {
    /// The message's bytes.
    #[must_use]
    pub fn encode(&self) -> Vec<u8> {
        let mut o = Out::default();
        match self {
            Request::Load(path) => o.u8(0).str(path),
            Request::Init(path) => o.u8(1).str(path),
            Request::Sync(m, l) => {
                o.u8(2).u8(*m as u8);
                match l {
                    Some(l) => o.u8(1).list(l),
                    None => o.u8(0),
                }
            }
            Request::Create(id, env, list) => o.u8(3).u64(*id).env(env).list(list),
            Request::Destroy(id) => o.u8(4).u64(*id),
            Request::Finalize => o.u8(5),
            Request::Property(id, p) => o.u8(6).u64(*id).u8(*p as u8),
            Request::Project { id, n, len } => o.u8(7).u64(*id).u64(*n).u64(*len),
            Request::Unproject(id, p, t) => o.u8(8).u64(*id).f32(p.x).f32(p.y).f32(p.z).f32(*t),
        };
        o.0
    }

    /// Reads a message.
    ///
    /// # Errors
    /// What is malformed.
    pub fn decode(bytes: &[u8]) -> Result<Self, String> {
        let mut i = In(bytes);
        let r = match i.u8()? {
            0 => Request::Load(i.str()?),
            1 => Request::Init(i.str()?),
            2 => {
                let m = sync_message(i.u8()?)?;
                Request::Sync(m, if i.bool()? { Some(i.list()?) } else { None })
            }
            3 => Request::Create(i.u64()?, i.env()?, i.list()?),
            4 => Request::Destroy(i.u64()?),
            5 => Request::Finalize,
            6 => Request::Property(i.u64()?, property(i.u8()?)?),
            7 => Request::Project {
                id: i.u64()?,
                n: i.u64()?,
                len: i.u64()?,
            },
            8 => Request::Unproject(i.u64()?, Vec3::new(i.f32()?, i.f32()?, i.f32()?), i.f32()?),
            t => return Err(format!("unknown request {t}")),
        };
        i.end(r)
    }
}

impl Reply {
    /// The message's bytes.
    #[must_use]
    pub fn encode(&self) -> Vec<u8> {
        let mut o = Out::default();
        match self {
            Reply::Done => o.u8(0),
            Reply::Described(d) => {
                o.u8(1).str(&d.name).str(&d.summary).u64(d.table.len() as u64);
                d.table.iter().for_each(|row| {
                    o.decl(row);
                });
                &mut o
            }
            Reply::LoadFailed(m) => o.u8(2).str(m),
            Reply::Plugin(e) => match e {
                PluginError::Init { plugin, message } => o.u8(3).u8(0).str(plugin).str(message),
                PluginError::Invalid { plugin, message } => o.u8(3).u8(1).str(plugin).str(message),
                // The host resolves parameters itself before it asks; anything else arrives as text.
                other => o.u8(3).u8(2).str("").str(&other.to_string()),
            },
            Reply::Created(m) => o.u8(4).u8(*m as u8),
            Reply::Property(v) => o.u8(5).property_value(*v),
            Reply::Point(p) => match p {
                Some(p) => o.u8(6).u8(1).f32(p.x).f32(p.y),
                None => o.u8(6).u8(0),
            },
            Reply::Unwound { failed, message } => o.u8(7).bool(*failed).str(message),
        };
        o.0
    }

    /// Reads a message.
    ///
    /// # Errors
    /// What is malformed.
    pub fn decode(bytes: &[u8]) -> Result<Self, String> {
        let mut i = In(bytes);
        let r = match i.u8()? {
            0 => Reply::Done,
            1 => {
                let (name, summary) = (i.str()?, i.str()?);
                let n = i.len()?;
                let table = (0..n).map(|_| i.decl()).collect::<Res<_>>()?;
                Reply::Described(Description { name, summary, table })
            }
            2 => Reply::LoadFailed(i.str()?),
            3 => {
                let kind = i.u8()?;
                let (plugin, message) = (i.str()?, i.str()?);
                Reply::Plugin(match kind {
                    0 => PluginError::Init { plugin, message },
                    _ => PluginError::Invalid { plugin, message },
                })
            }
            4 => Reply::Created(deep_metric(i.u8()?)?),
            5 => Reply::Property(i.property_value()?),
            6 => Reply::Point(if i.bool()? {
                Some(Point2::new(i.f32()?, i.f32()?))
            } else {
                None
            }),
            7 => Reply::Unwound {
                failed: i.bool()?,
                message: i.str()?,
            },
            t => return Err(format!("unknown reply {t}")),
        };
        i.end(r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::Rgb;

    /// Every request and reply survives the trip bit for bit, NaN payloads and signed zeros included.
    #[test]
    fn messages_round_trip_exactly() {
        let mut list = ParamList::new();
        list.push(
            "float fov",
            ParamValue::Floats(vec![f32::from_bits(0x7fc0_1234), -0.0]),
            None,
        )
        .unwrap();
        list.push(
            "int[2] n",
            ParamValue::Ints(vec![-3, i32::MAX]),
            Some("a.rib:3".into()),
        )
        .unwrap();
        list.push("string mode", ParamValue::Strings(vec!["é x".into()]), None)
            .unwrap();
        let mut env = ProjectionEnvironment::new(
            Format {
                width: 7,
                height: 5,
                pixel_aspect: 1.25,
            },
            ScreenWindow::new(-1.0, 2.0, -0.5, 0.5),
            (0.1, 0.9),
            (0.01, f32::INFINITY),
            vec![MotionSample {
                time: 0.3,
                world_to_camera: Matrix4::IDENTITY,
            }],
        );
        env.set_deep_metric(DeepMetric::RayLength);
        let requests = [
            Request::Load("/p/Ü.so".into()),
            Request::Init(String::new()),
            Request::Sync(SyncMessage::RenderBegin, Some(list.clone())),
            Request::Sync(SyncMessage::RenderEnd, None),
            Request::Create(9, env, list),
            Request::Destroy(9),
            Request::Finalize,
            Request::Property(1, ProjectionProperty::FocalDistance),
            Request::Project {
                id: 2,
                n: 4096,
                len: 1 << 20,
            },
            Request::Unproject(3, Vec3::new(0.5, -0.0, 1.0), 0.25),
        ];
        for r in requests {
            let back = Request::decode(&r.encode()).unwrap();
            assert_eq!(format!("{back:?}"), format!("{r:?}"));
        }
        let table = vec![
            ParamDecl::float("fov", 90.0)
                .range(ValueRange {
                    min: 0.0,
                    max: 180.0,
                    min_inclusive: false,
                    max_inclusive: true,
                })
                .doc("the field of view"),
            ParamDecl::string("mode", "a").choices(&["a", "b"]),
            ParamDecl::color("c", Rgb::WHITE),
            ParamDecl::float_list("k", &[1.0, 2.0]),
        ];
        let replies = [
            Reply::Done,
            Reply::Described(Description {
                name: "X".into(),
                summary: "s".into(),
                table,
            }),
            Reply::LoadFailed("no".into()),
            Reply::Plugin(PluginError::Init {
                plugin: "X".into(),
                message: "m".into(),
            }),
            Reply::Created(DeepMetric::RayLength),
            Reply::Property(Some(PropertyValue::Float(-0.0))),
            Reply::Property(Some(PropertyValue::DicingHint(DicingHint::Spherical))),
            Reply::Property(None),
            Reply::Point(Some(Point2::new(0.25, f32::NAN))),
            Reply::Unwound {
                failed: true,
                message: "bad".into(),
            },
        ];
        for r in replies {
            let back = Reply::decode(&r.encode()).unwrap();
            assert_eq!(format!("{back:?}"), format!("{r:?}"));
        }
    }

    #[test]
    fn malformed_messages_are_errors_not_panics() {
        assert_eq!(Reply::decode(&[0]), Ok(Reply::Done));
        assert!(Request::decode(&[0]).is_err());
        for bad in [
            &[][..],
            &[0, 255, 255, 255, 255, 255, 255, 255, 255],
            &[99],
            &[3, 0, 1],
        ] {
            assert!(Request::decode(bad).is_err(), "{bad:?}");
            assert!(Reply::decode(bad).is_err(), "{bad:?}");
        }
    }
}
