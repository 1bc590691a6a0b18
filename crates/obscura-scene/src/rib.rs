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

use std::collections::{HashMap, HashSet};
use std::iter::Peekable;
use std::path::{Path, PathBuf};
use std::str::Chars;

use glam::{Mat4, Vec2, Vec3};
use obscura_host::{CameraDesc, CropWindow};
use obscura_sdk::{
    Format, Matrix4, MotionSample, ParamList, ParamValue, Rgb, ScreenWindow, parse_declaration,
};

use crate::types::{
    Aov, Display, DisplayDriver, FilterKind, Light, Material, Mesh, MotionTransform, Object, PixelFilter,
    Scene, Shape, SubdivMesh,
};

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

/// `Clipping` far values at least this large mean "no far plane" (RenderMan writes 1e30).
const FAR_IS_INFINITE: f32 = 1e30;

// ---------------------------------------------------------------------------------------------------
// Tokenizer
// ---------------------------------------------------------------------------------------------------

/// A number as written: its value, and the integer it is when written without `.` or an exponent.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Num {
    value: f64,
    int: Option<i32>,
}

/// One argument of a request.
#[derive(Debug, Clone, PartialEq)]
enum Value {
    Num(Num),
    Str(String),
    /// `[ … ]` of numbers (an empty array is one of these).
    Nums(Vec<Num>),
    /// `[ … ]` of strings.
    Strs(Vec<String>),
}

/// A request name and the arguments up to the next request name.
#[derive(Debug, Clone, PartialEq)]
struct Command {
    name: String,
    line: u32,
    args: Vec<Value>,
}

#[derive(Debug, Clone, PartialEq)]
struct LexError {
    line: u32,
    message: String,
}

impl LexError {
    fn new(line: u32, message: impl Into<String>) -> Self {
        LexError {
            line,
            message: message.into(),
        }
    }
}

/// Splits RIB text into requests. Strings may span lines; an array must close before the next request.
fn lex(text: &str) -> Result<Vec<Command>, LexError> {
    let mut commands: Vec<Command> = Vec::new();
    let mut chars = text.chars().peekable();
    let mut line: u32 = 1;
    // The array being read: the line of its '[' and its items.
    let mut array: Option<(u32, Vec<Value>)> = None;
    while let Some(c) = chars.next() {
        let start = line;
        let item = match c {
            '\n' => {
                line = line.saturating_add(1);
                continue;
            }
            '#' => {
                while chars.next_if(|&n| n != '\n').is_some() {}
                continue;
            }
            c if c.is_whitespace() => continue,
            '"' => match read_string(&mut chars, &mut line) {
                Some(s) => Value::Str(s),
                None => {
                    return Err(LexError::new(
                        start,
                        "unterminated string: the closing '\"' is missing",
                    ));
                }
            },
            '[' => {
                if let Some((open, _)) = &array {
                    return Err(LexError::new(*open, "unterminated array: '[' inside an array"));
                }
                array = Some((line, Vec::new()));
                continue;
            }
            ']' => {
                let Some((open, items)) = array.take() else {
                    return Err(LexError::new(line, "']' without a matching '['"));
                };
                let value = array_value(items)
                    .ok_or_else(|| LexError::new(open, "an array mixes numbers and strings"))?;
                append_arg(&mut commands, value, open)?;
                continue;
            }
            c if c.is_ascii_digit() || matches!(c, '+' | '-' | '.') => {
                Value::Num(read_number(c, &mut chars, line)?)
            }
            c if c.is_alphabetic() || c == '_' => {
                if let Some((open, _)) = &array {
                    return Err(LexError::new(
                        *open,
                        "unterminated array: no ']' before the next request",
                    ));
                }
                let mut name = String::from(c);
                while let Some(n) = chars.next_if(|&n| n.is_alphanumeric() || n == '_') {
                    name.push(n);
                }
                commands.push(Command {
                    name,
                    line,
                    args: Vec::new(),
                });
                continue;
            }
            other => {
                return Err(LexError::new(
                    line,
                    format!("unexpected character '{}'", other.escape_default()),
                ));
            }
        };
        match &mut array {
            Some((_, items)) => items.push(item),
            None => append_arg(&mut commands, item, start)?,
        }
    }
    if let Some((open, _)) = array {
        return Err(LexError::new(
            open,
            "unterminated array: the closing ']' is missing",
        ));
    }
    Ok(commands)
}

fn append_arg(commands: &mut [Command], value: Value, line: u32) -> Result<(), LexError> {
    match commands.last_mut() {
        Some(c) => {
            c.args.push(value);
            Ok(())
        }
        None => Err(LexError::new(
            line,
            format!("expected a request name, got {}", describe(&value)),
        )),
    }
}

/// The body of a string after its opening quote; `None` when the text ends first.
fn read_string(chars: &mut Peekable<Chars<'_>>, line: &mut u32) -> Option<String> {
    let mut s = String::new();
    loop {
        match chars.next()? {
            '"' => return Some(s),
            '\\' => match chars.next()? {
                'n' => s.push('\n'),
                't' => s.push('\t'),
                'r' => s.push('\r'),
                '\n' => *line = line.saturating_add(1), // a continued line
                e @ ('\\' | '"') => s.push(e),
                other => {
                    s.push('\\');
                    s.push(other);
                }
            },
            '\n' => {
                *line = line.saturating_add(1);
                s.push('\n');
            }
            c => s.push(c),
        }
    }
}

fn read_number(first: char, chars: &mut Peekable<Chars<'_>>, line: u32) -> Result<Num, LexError> {
    let mut s = String::from(first);
    while let Some(c) = chars.next_if(|&c| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E')) {
        s.push(c);
        if matches!(c, 'e' | 'E')
            && let Some(sign) = chars.next_if(|&n| matches!(n, '+' | '-'))
        {
            s.push(sign);
        }
    }
    let value = s
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && v.abs() <= f64::from(f32::MAX))
        .ok_or_else(|| LexError::new(line, format!("cannot read the number \"{s}\"")))?;
    let int = if s.contains(['.', 'e', 'E']) {
        None
    } else {
        s.parse::<i32>().ok()
    };
    Ok(Num { value, int })
}

/// The array of these items, or `None` when it mixes numbers and strings.
fn array_value(items: Vec<Value>) -> Option<Value> {
    if items.iter().all(|v| matches!(v, Value::Num(_))) {
        Some(Value::Nums(
            items
                .into_iter()
                .filter_map(|v| if let Value::Num(n) = v { Some(n) } else { None })
                .collect(),
        ))
    } else if items.iter().all(|v| matches!(v, Value::Str(_))) {
        Some(Value::Strs(
            items
                .into_iter()
                .filter_map(|v| if let Value::Str(s) = v { Some(s) } else { None })
                .collect(),
        ))
    } else {
        None
    }
}

/// An argument as a message shows it.
fn describe(v: &Value) -> String {
    match v {
        Value::Num(n) => format!("the number {}", n.value),
        Value::Str(s) => format!("the string \"{s}\""),
        Value::Nums(n) => format!("an array of {} numbers", n.len()),
        Value::Strs(s) => format!("an array of {} strings", s.len()),
    }
}

// ---------------------------------------------------------------------------------------------------
// Requests: where they were read and their arguments
// ---------------------------------------------------------------------------------------------------

/// One request being handled: its file, the directory relative paths resolve against, its arguments.
struct Req<'a> {
    file: &'a str,
    base: &'a Path,
    depth: u32,
    name: &'a str,
    line: u32,
    args: &'a [Value],
}

impl<'a> Req<'a> {
    /// `file:line`, the origin recorded in parameter lists and objects.
    fn at(&self) -> String {
        format!("{}:{}", self.file, self.line)
    }

    fn err(&self, message: impl Into<String>) -> RibError {
        RibError {
            file: self.file.to_string(),
            line: self.line,
            message: message.into(),
        }
    }

    fn resolve(&self, path: &str) -> PathBuf {
        let p = Path::new(path);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.base.join(p)
        }
    }

    /// Exactly `N` leading numbers of `args` (written one by one or as one array), and what follows.
    fn numbers<const N: usize>(
        &self,
        args: &'a [Value],
        what: &str,
    ) -> Result<([f32; N], &'a [Value]), RibError> {
        let (values, rest): (Vec<f64>, &[Value]) = match args.first() {
            Some(Value::Nums(v)) => (v.iter().map(|n| n.value).collect(), &args[1..]),
            _ => {
                let k = args.iter().take_while(|a| matches!(a, Value::Num(_))).count();
                let v = args[..k]
                    .iter()
                    .filter_map(|a| {
                        if let Value::Num(n) = a {
                            Some(n.value)
                        } else {
                            None
                        }
                    })
                    .collect();
                (v, &args[k..])
            }
        };
        let got = values.len();
        let array: [f32; N] = values
            .into_iter()
            .map(|v| v as f32)
            .collect::<Vec<_>>()
            .try_into()
            .map_err(|_| self.err(format!("{} expects {what} ({N} numbers), got {got}", self.name)))?;
        Ok((array, rest))
    }

    /// Exactly `N` numbers and nothing else.
    fn only_numbers<const N: usize>(&self, what: &str) -> Result<[f32; N], RibError> {
        let (v, rest) = self.numbers::<N>(self.args, what)?;
        match rest.first() {
            None => Ok(v),
            Some(extra) => Err(self.err(format!(
                "{} expects {what} ({N} numbers), then nothing; got {} after them",
                self.name,
                describe(extra)
            ))),
        }
    }

    /// An array of non-negative integers (`[nverts]`, `[verts]`).
    fn indices(&self, v: &Value, what: &str) -> Result<Vec<i64>, RibError> {
        let bad = || {
            self.err(format!(
                "{}: {what} must be an array of integers, got {}",
                self.name,
                describe(v)
            ))
        };
        match v {
            Value::Nums(ns) => ns.iter().map(|n| n.int.map(i64::from).ok_or_else(bad)).collect(),
            Value::Num(Num { int: Some(i), .. }) => Ok(vec![i64::from(*i)]),
            _ => Err(bad()),
        }
    }

    /// An array of counts (non-negative integers).
    fn counts(&self, v: &Value, what: &str) -> Result<Vec<usize>, RibError> {
        self.indices(v, what)?
            .into_iter()
            .map(|n| {
                usize::try_from(n)
                    .map_err(|_| self.err(format!("{}: {what} must not be negative, got {n}", self.name)))
            })
            .collect()
    }
}

/// Drops RIB's storage classes (`vertex point P` is `point P`): Obscura keeps every value as given.
fn normalize_declaration(decl: &str) -> String {
    decl.split_whitespace()
        .filter(|w| {
            !matches!(
                *w,
                "uniform" | "constant" | "vertex" | "varying" | "facevarying" | "facevertex"
            )
        })
        .collect::<Vec<_>>()
        .join(" ")
}

fn declared_name(decl: &str) -> &str {
    decl.split_whitespace().last().unwrap_or(decl)
}

/// The values of a parameter: integers when every number was written as one (a float parameter takes
/// them too), else floats; strings as strings.
fn param_value(v: &Value) -> ParamValue {
    match v {
        Value::Num(Num { int: Some(i), .. }) => ParamValue::Ints(vec![*i]),
        Value::Num(n) => ParamValue::Floats(vec![n.value as f32]),
        Value::Nums(ns) => match ns.iter().map(|n| n.int).collect::<Option<Vec<i32>>>() {
            Some(ints) if !ints.is_empty() => ParamValue::Ints(ints),
            _ => ParamValue::Floats(ns.iter().map(|n| n.value as f32).collect()),
        },
        Value::Str(s) => ParamValue::Strings(vec![s.clone()]),
        Value::Strs(s) => ParamValue::Strings(s.clone()),
    }
}

fn get_floats<'l>(list: &'l ParamList, name: &str) -> Option<&'l [f32]> {
    match &list.get(name)?.value {
        ParamValue::Floats(v) => Some(v),
        _ => None,
    }
}

fn get_float(list: &ParamList, name: &str) -> Option<f32> {
    get_floats(list, name)?.first().copied()
}

fn get_int(list: &ParamList, name: &str) -> Option<i32> {
    match &list.get(name)?.value {
        ParamValue::Ints(v) => v.first().copied(),
        _ => None,
    }
}

fn get_string<'l>(list: &'l ParamList, name: &str) -> Option<&'l str> {
    match &list.get(name)?.value {
        ParamValue::Strings(v) => v.first().map(String::as_str),
        _ => None,
    }
}

fn get_color(list: &ParamList, name: &str) -> Option<Rgb> {
    match get_floats(list, name)? {
        [r, g, b, ..] => Some(Rgb::new(*r, *g, *b)),
        _ => None,
    }
}

fn to_points(v: &[f32]) -> Vec<Vec3> {
    v.chunks_exact(3).map(Vec3::from_slice).collect()
}

// ---------------------------------------------------------------------------------------------------
// Reader state
// ---------------------------------------------------------------------------------------------------

/// The current transform: one sample when static (its time is then meaningless), else motion samples
/// sorted by time.
#[derive(Debug, Clone, PartialEq)]
struct Ctm(Vec<(f32, Mat4)>);

impl Ctm {
    fn identity() -> Self {
        Ctm(vec![(0.0, Mat4::IDENTITY)])
    }

    fn apply(&mut self, op: &Op) {
        match op {
            Op::Concat(m) => {
                for s in &mut self.0 {
                    s.1 *= *m;
                }
            }
            Op::Replace(m) => *self = Ctm(vec![(0.0, *m)]),
        }
    }

    fn first(&self) -> Mat4 {
        self.0.first().map_or(Mat4::IDENTITY, |s| s.1)
    }

    /// The transform at time `t`: matrix entries interpolated between samples, held beyond the ends.
    fn at(&self, t: f32) -> Mat4 {
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

    fn to_motion(&self) -> MotionTransform {
        MotionTransform {
            samples: self.0.clone(),
        }
    }
}

/// What a transform request does to the CTM.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Op {
    /// `CTM = CTM · M` (Translate, Rotate, Scale, ConcatTransform).
    Concat(Mat4),
    /// `CTM = M` (Transform, Identity).
    Replace(Mat4),
}

/// glam's column-vector matrix `M` (`p' = M·p`) as the SDK's row-vector [`Matrix4`] (`p' = [p 1]·R`):
/// `R = Mᵀ`, whose rows are `M`'s columns — exactly what `to_cols_array_2d` lists.
fn to_row_vector(m: Mat4) -> Matrix4 {
    Matrix4(m.to_cols_array_2d())
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum BlockKind {
    Attribute,
    Transform,
}

impl BlockKind {
    fn begin(self) -> &'static str {
        match self {
            BlockKind::Attribute => "AttributeBegin",
            BlockKind::Transform => "TransformBegin",
        }
    }
    fn end(self) -> &'static str {
        match self {
            BlockKind::Attribute => "AttributeEnd",
            BlockKind::Transform => "TransformEnd",
        }
    }
}

/// An open `AttributeBegin`/`TransformBegin`: what to restore, and where it was opened.
struct Block {
    kind: BlockKind,
    ctm: Ctm,
    material: u32,
    micropolygon_length: f32,
    file: String,
    line: u32,
}

/// An open `MotionBegin`.
struct MotionBlock {
    times: Vec<f32>,
    ops: Vec<Op>,
    file: String,
    line: u32,
}

/// Requests that set options: only before `WorldBegin`.
const OPTIONS: [&str; 10] = [
    "Format",
    "ScreenWindow",
    "CropWindow",
    "Shutter",
    "Clipping",
    "PixelFilter",
    "Hider",
    "Display",
    "Projection",
    "Camera",
];

/// Requests that make geometry or lights: only after `WorldBegin`.
const WORLD_ONLY: [&str; 13] = [
    "Sphere",
    "Cylinder",
    "Cone",
    "Disk",
    "Torus",
    "Polygon",
    "PointsPolygons",
    "PointsGeneralPolygons",
    "SubdivisionMesh",
    "Light",
    "LightSource",
    "AreaLightSource",
    "WorldEnd",
];

/// Every request the reader knows (the others are skipped with a warning).
const KNOWN: [&str; 45] = [
    "version",
    "Version",
    "FrameBegin",
    "FrameEnd",
    "WorldBegin",
    "WorldEnd",
    "Declare",
    "Option",
    "Format",
    "ScreenWindow",
    "CropWindow",
    "Shutter",
    "Clipping",
    "PixelFilter",
    "Hider",
    "Display",
    "Projection",
    "Camera",
    "Identity",
    "Translate",
    "Rotate",
    "Scale",
    "ConcatTransform",
    "Transform",
    "MotionBegin",
    "MotionEnd",
    "AttributeBegin",
    "AttributeEnd",
    "TransformBegin",
    "TransformEnd",
    "Attribute",
    "Bxdf",
    "Light",
    "LightSource",
    "AreaLightSource",
    "ReadArchive",
    "Sphere",
    "Cylinder",
    "Cone",
    "Disk",
    "Torus",
    "Polygon",
    "PointsPolygons",
    "PointsGeneralPolygons",
    "SubdivisionMesh",
];

/// The pixel filters, as `PixelFilter` spells them.
const FILTERS: [(&str, FilterKind); 6] = [
    ("box", FilterKind::Box),
    ("triangle", FilterKind::Triangle),
    ("gaussian", FilterKind::Gaussian),
    ("catmull-rom", FilterKind::CatmullRom),
    ("mitchell", FilterKind::Mitchell),
    ("blackman-harris", FilterKind::BlackmanHarris),
];

/// The names a `Display` channel list may use.
const CHANNELS: [(&str, &[Aov]); 10] = [
    ("rgb", &[Aov::Ci]),
    ("rgba", &[Aov::Ci, Aov::Alpha]),
    ("rgbz", &[Aov::Ci, Aov::Z]),
    ("rgbaz", &[Aov::Ci, Aov::Alpha, Aov::Z]),
    ("Ci", &[Aov::Ci]),
    ("a", &[Aov::Alpha]),
    ("z", &[Aov::Z]),
    ("N", &[Aov::N]),
    ("P", &[Aov::P]),
    ("cameraDirection", &[Aov::CameraDirection]),
];

/// Parameters a projection may be given by bare name (`Projection "perspective" "fov" [40]`).
const PROJECTION_BARE_NAMES: [&str; 5] = [
    "float fov",
    "float fovEnd",
    "float fStop",
    "float focalLength",
    "float focalDistance",
];

const CAMERA_PARAMS: [&str; 8] = [
    "int apertureNSides",
    "float apertureAngle",
    "float apertureRoundness",
    "float apertureDensity",
    "float dofaspect",
    "float shutterOpenTime",
    "float shutterCloseTime",
    "float[8] shutteropening",
];

struct Reader {
    scene: Scene,
    ctm: Ctm,
    material: u32,
    micropolygon_length: f32,
    blocks: Vec<Block>,
    motion: Option<MotionBlock>,
    /// `file:line` of `WorldBegin` once read.
    world: Option<String>,
    /// `Declare`d names → full declarations (`fov` → `float fov`).
    declared: HashMap<String, String>,
    warned_attributes: HashSet<String>,
    warned_options: HashSet<String>,
}

impl Reader {
    fn new() -> Self {
        Reader {
            scene: Scene::new(CameraDesc::new(Format::new(640, 480))),
            ctm: Ctm::identity(),
            material: 0,
            micropolygon_length: 1.0,
            blocks: Vec::new(),
            motion: None,
            world: None,
            declared: HashMap::new(),
            warned_attributes: HashSet::new(),
            warned_options: HashSet::new(),
        }
    }

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

    fn warn(&mut self, r: &Req<'_>, message: String) {
        self.scene.warnings.push(format!("{}: {message}", r.at()));
    }

    fn store_camera_transform(&mut self) {
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

    fn request(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        if let Some(op) = transform_op(r)? {
            match &mut self.motion {
                Some(m) => m.ops.push(op),
                None => self.ctm.apply(&op),
            }
            return Ok(());
        }
        let known = KNOWN.contains(&r.name);
        if let Some(m) = &self.motion
            && r.name != "MotionEnd"
            && known
        {
            return Err(r.err(format!(
                "{} inside MotionBegin (at {}:{}): only transform requests may move",
                r.name, m.file, m.line
            )));
        }
        if OPTIONS.contains(&r.name) && self.world.is_some() {
            return Err(r.err(format!("{} must come before WorldBegin", r.name)));
        }
        if WORLD_ONLY.contains(&r.name) && self.world.is_none() {
            return Err(r.err(format!("{} must come after WorldBegin", r.name)));
        }
        match r.name {
            "version" | "Version" | "FrameBegin" | "FrameEnd" => Ok(()),
            "WorldBegin" => self.world_begin(r),
            "WorldEnd" => self.world_end(r),
            "Declare" => self.declare(r),
            "Option" => self.option(r),
            "Format" => self.format(r),
            "ScreenWindow" => {
                let [l, rt, b, t] = r.only_numbers::<4>("left right bottom top")?;
                if !(l < rt && b < t) {
                    return Err(r.err(format!(
                        "ScreenWindow expects left < right and bottom < top, got {l} {rt} {b} {t}"
                    )));
                }
                self.scene.camera.screen_window = Some(ScreenWindow::new(l, rt, b, t));
                Ok(())
            }
            "CropWindow" => {
                let [x_min, x_max, y_min, y_max] = r.only_numbers::<4>("xmin xmax ymin ymax")?;
                let unit = |v: f32| (0.0..=1.0).contains(&v);
                if !(unit(x_min)
                    && unit(x_max)
                    && unit(y_min)
                    && unit(y_max)
                    && x_min < x_max
                    && y_min < y_max)
                {
                    return Err(r.err(format!(
                        "CropWindow expects 0 <= xmin < xmax <= 1 and 0 <= ymin < ymax <= 1, got {x_min} {x_max} {y_min} {y_max}"
                    )));
                }
                self.scene.camera.crop_window = CropWindow {
                    x_min,
                    x_max,
                    y_min,
                    y_max,
                };
                Ok(())
            }
            "Shutter" => {
                let [open, close] = r.only_numbers::<2>("open close")?;
                if open > close {
                    return Err(r.err(format!("Shutter expects open <= close, got {open} {close}")));
                }
                self.scene.camera.shutter = (open, close);
                Ok(())
            }
            "Clipping" => {
                let [near, far] = r.only_numbers::<2>("near far")?;
                let far = if far >= FAR_IS_INFINITE {
                    f32::INFINITY
                } else {
                    far
                };
                if !(near > 0.0 && far > near) {
                    return Err(r.err(format!("Clipping expects 0 < near < far, got {near} {far}")));
                }
                self.scene.camera.clipping = (near, far);
                Ok(())
            }
            "PixelFilter" => self.pixel_filter(r),
            "Hider" => self.hider(r),
            "Display" => self.display(r),
            "Projection" => self.projection(r),
            "Camera" => self.camera(r),
            "MotionBegin" => self.motion_begin(r),
            "MotionEnd" => self.motion_end(r),
            "AttributeBegin" => self.begin_block(r, BlockKind::Attribute),
            "TransformBegin" => self.begin_block(r, BlockKind::Transform),
            "AttributeEnd" => self.end_block(r, BlockKind::Attribute),
            "TransformEnd" => self.end_block(r, BlockKind::Transform),
            "Attribute" => self.attribute(r),
            "Bxdf" => self.bxdf(r),
            "Light" | "LightSource" | "AreaLightSource" => self.light(r),
            "ReadArchive" => self.read_archive(r),
            "Sphere" | "Cylinder" | "Cone" | "Disk" | "Torus" => self.quadric(r),
            "Polygon" | "PointsPolygons" | "PointsGeneralPolygons" => self.polygons(r),
            "SubdivisionMesh" => self.subdivision_mesh(r),
            _ => {
                self.warn(r, format!("unknown request {}, skipped", r.name));
                Ok(())
            }
        }
    }

    // --- structure -----------------------------------------------------------------------------------

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

    fn option(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let Some(Value::Str(name)) = r.args.first() else {
            return Err(r.err("Option expects an option name (a string) then parameters"));
        };
        if self.warned_options.insert(name.clone()) {
            self.warn(r, format!("Option \"{name}\" is not supported, ignored"));
        }
        Ok(())
    }

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

    fn begin_block(&mut self, r: &Req<'_>, kind: BlockKind) -> Result<(), RibError> {
        self.blocks.push(Block {
            kind,
            ctm: self.ctm.clone(),
            material: self.material,
            micropolygon_length: self.micropolygon_length,
            file: r.file.to_string(),
            line: r.line,
        });
        Ok(())
    }

    fn end_block(&mut self, r: &Req<'_>, kind: BlockKind) -> Result<(), RibError> {
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
        }
        Ok(())
    }

    // --- motion --------------------------------------------------------------------------------------

    fn motion_begin(&mut self, r: &Req<'_>) -> Result<(), RibError> {
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
            file: r.file.to_string(),
            line: r.line,
        });
        Ok(())
    }

    fn motion_end(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let Some(m) = self.motion.take() else {
            return Err(r.err("MotionEnd without a matching MotionBegin"));
        };
        let (n, k) = (m.times.len(), m.ops.len());
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

    // --- parameter lists -----------------------------------------------------------------------------

    /// Reads `rest` as a parameter list. `table` lists the parameters the request uses, as full
    /// declarations (exactly one value of the declared type, or one per point for `vertex` entries); a name written bare is looked up in `Declare`d names, then in `table`. With `open`
    /// any typed parameter is kept (a projection's list); otherwise the others are warned about and
    /// skipped.
    fn params(
        &mut self,
        r: &Req<'_>,
        rest: &[Value],
        table: &[&str],
        open: bool,
    ) -> Result<ParamList, RibError> {
        let mut list = ParamList::new();
        let mut pairs = rest.iter();
        while let Some(name_value) = pairs.next() {
            let Value::Str(written) = name_value else {
                return Err(r.err(format!(
                    "{}: expected a parameter name (a string), got {}",
                    r.name,
                    describe(name_value)
                )));
            };
            let Some(value) = pairs.next() else {
                return Err(r.err(format!("{}: parameter \"{written}\" has no value", r.name)));
            };
            let mut decl = normalize_declaration(written);
            if decl.split_whitespace().count() == 1 {
                let found = self.declared.get(&decl).cloned().or_else(|| {
                    table
                        .iter()
                        .find(|d| declared_name(d) == decl)
                        .map(|d| normalize_declaration(d))
                });
                match found {
                    Some(d) => decl = d,
                    None => {
                        self.warn(r, format!("{}: unknown parameter \"{decl}\", ignored", r.name));
                        continue;
                    }
                }
            }
            let (ty, _, name) = parse_declaration(&decl).map_err(|e| r.err(format!("{}: {e}", r.name)))?;
            let value = param_value(value);
            match table.iter().find(|d| declared_name(d) == name) {
                Some(known) => {
                    let Ok((known_ty, known_len, _)) = parse_declaration(&normalize_declaration(known))
                    else {
                        return Err(r.err(format!("{}: bad table entry \"{known}\"", r.name)));
                    };
                    if known_ty != ty {
                        return Err(r.err(format!(
                            "{}: parameter \"{written}\" has the wrong type; expected \"{known}\"",
                            r.name
                        )));
                    }
                    let need = known_len.unwrap_or(1) * known_ty.components();
                    // A `vertex` entry has one value per point (any number: `push` checks whole
                    // elements). RenderMan ≤ 21 wrote `"float[2] shutteropening" [open close]`.
                    let per_vertex = known.split_whitespace().next() == Some("vertex");
                    let legacy = name == "shutteropening" && value.len() == 2;
                    if value.len() != need && !legacy && !per_vertex {
                        return Err(r.err(format!(
                            "{}: \"{known}\" needs {need} value(s), got {}",
                            r.name,
                            value.len()
                        )));
                    }
                    list.push(&format!("{ty} {name}"), value, Some(r.at()))
                }
                None if open => list.push(&decl, value, Some(r.at())),
                None => {
                    self.warn(r, format!("{}: unknown parameter \"{name}\", ignored", r.name));
                    continue;
                }
            }
            .map_err(|e| r.err(format!("{}: {e}", r.name)))?;
        }
        Ok(list)
    }

    // --- options -------------------------------------------------------------------------------------

    fn format(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [w, h, pa] = r.only_numbers::<3>("width height pixelaspect")?;
        let size = |v: f32| (v >= 1.0 && v.fract() == 0.0 && v <= u32::MAX as f32).then_some(v as u32);
        let (Some(width), Some(height)) = (size(w), size(h)) else {
            return Err(r.err(format!(
                "Format expects a positive integer width and height, got {w} {h}"
            )));
        };
        if pa <= 0.0 {
            return Err(r.err(format!("Format expects a positive pixel aspect ratio, got {pa}")));
        }
        self.scene.camera.format = Format {
            width,
            height,
            pixel_aspect: pa,
        };
        Ok(())
    }

    fn pixel_filter(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name), rest @ ..] = r.args else {
            return Err(r.err("PixelFilter expects a filter name then xwidth ywidth"));
        };
        let Some(&(_, kind)) = FILTERS.iter().find(|(n, _)| n == name) else {
            let names: Vec<&str> = FILTERS.iter().map(|(n, _)| *n).collect();
            return Err(r.err(format!(
                "PixelFilter: unknown filter \"{name}\"; expected one of {}",
                names.join(", ")
            )));
        };
        let ([width_x, width_y], extra) = r.numbers::<2>(rest, "a filter name then xwidth ywidth")?;
        if !extra.is_empty() {
            return Err(r.err("PixelFilter expects a filter name then xwidth ywidth, and nothing after"));
        }
        if !(width_x > 0.0 && width_y > 0.0) {
            return Err(r.err(format!(
                "PixelFilter expects positive widths, got {width_x} {width_y}"
            )));
        }
        self.scene.filter = PixelFilter {
            kind,
            width_x,
            width_y,
        };
        Ok(())
    }

    fn hider(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name), rest @ ..] = r.args else {
            return Err(r.err("Hider expects a hider name (a string) then parameters"));
        };
        if name != "raytrace" {
            self.warn(
                r,
                format!("Hider \"{name}\" is not supported (only \"raytrace\"), ignored"),
            );
            return Ok(());
        }
        let list = self.params(
            r,
            rest,
            &["int maxsamples", "int minsamples", "int incremental"],
            false,
        )?;
        if let Some(n) = get_int(&list, "maxsamples") {
            let n = u32::try_from(n)
                .ok()
                .filter(|&n| n >= 1)
                .ok_or_else(|| r.err(format!("Hider: maxsamples must be at least 1, got {n}")))?;
            self.scene.samples_per_pixel = n;
        }
        Ok(())
    }

    fn display(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [
            Value::Str(file),
            Value::Str(driver),
            Value::Str(channels),
            rest @ ..,
        ] = r.args
        else {
            return Err(r.err("Display expects \"file\" \"driver\" \"channels\" (3 strings) then parameters"));
        };
        let (append, file) = match file.strip_prefix('+') {
            Some(f) => (true, f),
            None => (false, file.as_str()),
        };
        if file.is_empty() {
            return Err(r.err("Display expects a file name, got \"\""));
        }
        let driver = match driver.as_str() {
            "openexr" | "exr" => DisplayDriver::OpenExr,
            "png" => DisplayDriver::Png,
            "deepexr" => DisplayDriver::DeepExr,
            other => {
                return Err(r.err(format!(
                    "Display: unknown driver \"{other}\"; expected one of openexr, exr, png, deepexr"
                )));
            }
        };
        let mut aovs: Vec<Aov> = Vec::new();
        for channel in channels.split(',').map(str::trim) {
            let Some((_, list)) = CHANNELS.iter().find(|(n, _)| *n == channel) else {
                let known: Vec<&str> = CHANNELS.iter().map(|(n, _)| *n).collect();
                return Err(r.err(format!(
                    "Display: unknown channel \"{channel}\"; known channels: {}",
                    known.join(", ")
                )));
            };
            for aov in list.iter() {
                if !aovs.contains(aov) {
                    aovs.push(*aov);
                }
            }
        }
        let params = self.params(r, rest, &["string type"], false)?;
        let half = match get_string(&params, "type") {
            None | Some("float") => false,
            Some("half") => true,
            Some(other) => {
                return Err(r.err(format!(
                    "Display: \"string type\" must be \"half\" or \"float\", got \"{other}\""
                )));
            }
        };
        let display = Display {
            path: r.resolve(file),
            driver,
            aovs,
            half,
        };
        if !append {
            self.scene.displays.clear();
        }
        self.scene.displays.push(display);
        Ok(())
    }

    fn projection(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name), rest @ ..] = r.args else {
            return Err(r.err("Projection expects a projection name (a string) then parameters"));
        };
        let plugin = match name.as_str() {
            "perspective" => "PxrPerspective",
            "orthographic" => "PxrOrthographic",
            other => other,
        };
        let list = self.params(r, rest, &PROJECTION_BARE_NAMES, true)?;
        self.scene.projection = plugin.to_string();
        self.scene.projection_params = list;
        Ok(())
    }

    fn camera(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(_name), rest @ ..] = r.args else {
            return Err(r.err("Camera expects a camera name (a string) then parameters"));
        };
        let list = self.params(r, rest, &CAMERA_PARAMS, false)?;
        let cam = &mut self.scene.camera;
        if let Some(n) = get_int(&list, "apertureNSides") {
            cam.aperture.n_sides = n;
        }
        let floats = [
            ("apertureAngle", &mut cam.aperture.angle_deg),
            ("apertureRoundness", &mut cam.aperture.roundness),
            ("apertureDensity", &mut cam.aperture.density),
            ("dofaspect", &mut cam.aperture.dof_aspect),
            ("shutterOpenTime", &mut cam.shutter_opening.open_time),
            ("shutterCloseTime", &mut cam.shutter_opening.close_time),
        ];
        for (name, field) in floats {
            if let Some(v) = get_float(&list, name) {
                *field = v;
            }
        }
        match get_floats(&list, "shutteropening") {
            Some(&[open, close]) => {
                cam.shutter_opening.open_time = open;
                cam.shutter_opening.close_time = close;
            }
            Some(v) => {
                if let Ok(opening) = <[f32; 8]>::try_from(v) {
                    cam.shutter_opening.opening = opening;
                }
            }
            None => {}
        }
        Ok(())
    }

    // --- attributes ----------------------------------------------------------------------------------

    fn attribute(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name), rest @ ..] = r.args else {
            return Err(r.err("Attribute expects an attribute name (a string) then parameters"));
        };
        if name != "dice" {
            if self.warned_attributes.insert(name.clone()) {
                self.warn(r, format!("Attribute \"{name}\" is not supported, ignored"));
            }
            return Ok(());
        }
        let list = self.params(r, rest, &["float micropolygonlength"], false)?;
        if let Some(x) = get_float(&list, "micropolygonlength") {
            if x <= 0.0 {
                return Err(r.err(format!(
                    "Attribute \"dice\": micropolygonlength must be greater than 0, got {x}"
                )));
            }
            self.micropolygon_length = x;
        }
        Ok(())
    }

    fn bxdf(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(kind), Value::Str(_handle), rest @ ..] = r.args else {
            return Err(r.err("Bxdf expects a Bxdf name and a handle (2 strings) then parameters"));
        };
        let material = match kind.as_str() {
            "PxrDiffuse" => {
                let list = self.params(r, rest, &["color diffuseColor"], false)?;
                Material::Diffuse {
                    color: get_color(&list, "diffuseColor").unwrap_or(Rgb::new(0.18, 0.18, 0.18)),
                }
            }
            "PxrConstant" => {
                let list = self.params(r, rest, &["color emitColor"], false)?;
                Material::Constant {
                    color: get_color(&list, "emitColor").unwrap_or(Rgb::WHITE),
                }
            }
            "PxrSurface" => {
                let table = [
                    "color diffuseColor",
                    "float diffuseGain",
                    "color specularFaceColor",
                    "float specularRoughness",
                ];
                let list = self.params(r, rest, &table, false)?;
                let color = get_color(&list, "diffuseColor").unwrap_or(Rgb::new(0.18, 0.18, 0.18));
                let gain = get_float(&list, "diffuseGain").unwrap_or(1.0);
                Material::Surface {
                    diffuse: Rgb::new(color.r * gain, color.g * gain, color.b * gain),
                    specular: get_color(&list, "specularFaceColor").unwrap_or(Rgb::BLACK),
                    roughness: get_float(&list, "specularRoughness").unwrap_or(0.2),
                }
            }
            other => {
                self.warn(
                    r,
                    format!(
                        "Bxdf: unknown Bxdf \"{other}\" (known: PxrDiffuse, PxrConstant, PxrSurface), using the default material"
                    ),
                );
                self.material = 0;
                return Ok(());
            }
        };
        self.material = self.scene.materials.len() as u32;
        self.scene.materials.push(material);
        Ok(())
    }

    fn light(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(kind), Value::Str(_) | Value::Num(_), rest @ ..] = r.args else {
            return Err(r.err(format!(
                "{} expects a light name and a handle, e.g. {} \"PxrDomeLight\" \"dome\"",
                r.name, r.name
            )));
        };
        let mut table = vec!["color lightColor", "float intensity", "float exposure"];
        match kind.as_str() {
            "PxrDomeLight" => table.push("string lightColorMap"),
            "PxrDistantLight" => table.push("float angleExtent"),
            "PxrRectLight" | "PxrSphereLight" => {}
            other => {
                self.warn(
                    r,
                    format!(
                        "{}: unknown light \"{other}\" (known: PxrDomeLight, PxrDistantLight, PxrRectLight, PxrSphereLight), skipped",
                        r.name
                    ),
                );
                return Ok(());
            }
        }
        let list = self.params(r, rest, &table, false)?;
        let color = get_color(&list, "lightColor").unwrap_or(Rgb::WHITE);
        let intensity = get_float(&list, "intensity").unwrap_or(1.0);
        let exposure = get_float(&list, "exposure").unwrap_or(0.0);
        let transform = self.ctm.first();
        let light = match kind.as_str() {
            "PxrDomeLight" => Light::Dome {
                color,
                intensity,
                exposure,
                map: get_string(&list, "lightColorMap")
                    .filter(|m| !m.is_empty())
                    .map(|m| r.resolve(m)),
                transform,
            },
            "PxrDistantLight" => Light::Distant {
                color,
                intensity,
                exposure,
                angle_extent: get_float(&list, "angleExtent").unwrap_or(0.53),
                transform,
            },
            "PxrRectLight" => Light::Rect {
                color,
                intensity,
                exposure,
                transform,
            },
            _ => Light::Sphere {
                color,
                intensity,
                exposure,
                transform,
            },
        };
        self.scene.lights.push(light);
        Ok(())
    }

    // --- geometry ------------------------------------------------------------------------------------

    fn add_object(&mut self, r: &Req<'_>, shape: Shape) {
        self.scene.objects.push(Object {
            shape,
            transform: self.ctm.to_motion(),
            material: self.material,
            micropolygon_length: self.micropolygon_length,
            source: r.at(),
        });
    }

    fn quadric(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let (shape, rest) = match r.name {
            "Sphere" => {
                let ([radius, z_min, z_max, theta_max], rest) =
                    r.numbers::<4>(r.args, "radius zmin zmax thetamax")?;
                (
                    Shape::Sphere {
                        radius,
                        z_min,
                        z_max,
                        theta_max,
                    },
                    rest,
                )
            }
            "Cylinder" => {
                let ([radius, z_min, z_max, theta_max], rest) =
                    r.numbers::<4>(r.args, "radius zmin zmax thetamax")?;
                (
                    Shape::Cylinder {
                        radius,
                        z_min,
                        z_max,
                        theta_max,
                    },
                    rest,
                )
            }
            "Cone" => {
                let ([height, radius, theta_max], rest) = r.numbers::<3>(r.args, "height radius thetamax")?;
                (
                    Shape::Cone {
                        height,
                        radius,
                        theta_max,
                    },
                    rest,
                )
            }
            "Disk" => {
                let ([height, radius, theta_max], rest) = r.numbers::<3>(r.args, "height radius thetamax")?;
                (
                    Shape::Disk {
                        height,
                        radius,
                        theta_max,
                    },
                    rest,
                )
            }
            _ => {
                let ([major_radius, minor_radius, phi_min, phi_max, theta_max], rest) =
                    r.numbers::<5>(r.args, "rmajor rminor phimin phimax thetamax")?;
                (
                    Shape::Torus {
                        major_radius,
                        minor_radius,
                        phi_min,
                        phi_max,
                        theta_max,
                    },
                    rest,
                )
            }
        };
        self.params(r, rest, &[], false)?;
        self.add_object(r, shape);
        Ok(())
    }

    /// `"P"` (required) from a parameter list, and `"N"` when it is per vertex.
    fn points_and_normals(
        &mut self,
        r: &Req<'_>,
        list: &ParamList,
    ) -> Result<(Vec<Vec3>, Option<Vec<Vec3>>), RibError> {
        let positions = get_floats(list, "P")
            .map(to_points)
            .ok_or_else(|| r.err(format!("{}: the positions \"P\" are missing", r.name)))?;
        let normals = match get_floats(list, "N").map(to_points) {
            Some(n) if n.len() == positions.len() => Some(n),
            Some(n) => {
                self.warn(
                    r,
                    format!(
                        "{}: \"N\" has {} normals for {} points (not per vertex), ignored",
                        r.name,
                        n.len(),
                        positions.len()
                    ),
                );
                None
            }
            None => None,
        };
        Ok((positions, normals))
    }

    fn polygons(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        // Each face: its loops (outline first, then holes) of vertex indices as written.
        let (faces, rest): (Option<Vec<FaceLoops>>, &[Value]) = match r.name {
            "Polygon" => (None, r.args),
            "PointsPolygons" => {
                let [nverts, verts, rest @ ..] = r.args else {
                    return Err(r.err("PointsPolygons expects [nverts] [verts] then \"P\" [...]"));
                };
                let nverts = r.counts(nverts, "[nverts]")?;
                let verts = r.indices(verts, "[verts]")?;
                let loops = split_by_counts(r, &verts, &nverts, "[nverts]", "[verts]")?;
                (Some(loops.into_iter().map(|l| vec![l]).collect()), rest)
            }
            _ => {
                let [nloops, nverts, verts, rest @ ..] = r.args else {
                    return Err(
                        r.err("PointsGeneralPolygons expects [nloops] [nverts] [verts] then \"P\" [...]")
                    );
                };
                let nloops = r.counts(nloops, "[nloops]")?;
                let nverts = r.counts(nverts, "[nverts]")?;
                let verts = r.indices(verts, "[verts]")?;
                let loops = split_by_counts(r, &verts, &nverts, "[nverts]", "[verts]")?;
                let faces = split_by_counts(r, &loops, &nloops, "[nloops]", "[nverts]")?;
                (Some(faces), rest)
            }
        };
        let list = self.params(r, rest, &["vertex point P", "vertex normal N"], false)?;
        let (positions, normals) = self.points_and_normals(r, &list)?;
        let faces = match faces {
            Some(f) => f,
            None => vec![vec![(0..positions.len() as i64).collect()]],
        };
        let mut triangles = Vec::new();
        for (k, face) in faces.iter().enumerate() {
            let loops = face
                .iter()
                .map(|l| check_indices(r, l, positions.len()))
                .collect::<Result<Vec<_>, _>>()?;
            match triangulate(&positions, &loops) {
                Some(t) => triangles.extend(t),
                None => self.warn(
                    r,
                    format!(
                        "{}: face {k} is degenerate (fewer than 3 distinct vertices or no area), skipped",
                        r.name
                    ),
                ),
            }
        }
        if !triangles.is_empty() {
            self.add_object(
                r,
                Shape::Mesh(Mesh {
                    positions,
                    normals,
                    triangles,
                }),
            );
        }
        Ok(())
    }

    fn subdivision_mesh(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(scheme), nverts, verts, rest @ ..] = r.args else {
            return Err(r.err(
                "SubdivisionMesh expects \"scheme\" [nverts] [verts] ([tags] [nargs] [intargs] [floatargs]) then \"P\" [...]",
            ));
        };
        if scheme != "catmull-clark" {
            return Err(r.err(format!(
                "SubdivisionMesh: scheme \"{scheme}\" is not supported; expected \"catmull-clark\""
            )));
        }
        let face_counts = r.counts(nverts, "[nverts]")?;
        let verts = r.indices(verts, "[verts]")?;
        split_by_counts(r, &verts, &face_counts, "[nverts]", "[verts]")?;
        if let Some((k, n)) = face_counts.iter().enumerate().find(|(_, n)| **n < 3) {
            return Err(r.err(format!(
                "SubdivisionMesh: face {k} has {n} vertices; a face needs at least 3"
            )));
        }
        // The tag arrays, present when an array (not a parameter name) follows [verts].
        let (tags, rest): (Option<[&Value; 4]>, &[Value]) = match rest {
            [
                tags @ (Value::Strs(_) | Value::Nums(_)),
                nargs,
                intargs,
                floatargs,
                rest @ ..,
            ] => {
                let rest = match rest {
                    [Value::Strs(_) | Value::Nums(_), more @ ..] => more, // [stringargs]
                    _ => rest,
                };
                (Some([tags, nargs, intargs, floatargs]), rest)
            }
            [Value::Strs(_) | Value::Nums(_), ..] => {
                return Err(r.err("SubdivisionMesh expects [tags] [nargs] [intargs] [floatargs] together"));
            }
            _ => (None, rest),
        };
        let list = self.params(r, rest, &["vertex point P"], false)?;
        let (positions, _) = self.points_and_normals(r, &list)?;
        let face_indices = check_indices(r, &verts, positions.len())?;
        let face_counts: Vec<u32> = face_counts.iter().map(|&n| n as u32).collect();
        let mut mesh = SubdivMesh {
            positions,
            face_counts,
            face_indices,
            ..SubdivMesh::default()
        };
        if let Some(tags) = tags {
            self.subdivision_tags(r, tags, &mut mesh)?;
        }
        self.add_object(r, Shape::Subdiv(mesh));
        Ok(())
    }

    fn subdivision_tags(
        &mut self,
        r: &Req<'_>,
        arrays: [&Value; 4],
        mesh: &mut SubdivMesh,
    ) -> Result<(), RibError> {
        let [tags, nargs, intargs, floatargs] = arrays;
        let tags: &[String] = match tags {
            Value::Strs(t) => t,
            _ => &[],
        };
        let nargs = r.counts(nargs, "[nargs]")?;
        let ints = r.indices(intargs, "[intargs]")?;
        let floats: Vec<f32> = match floatargs {
            Value::Nums(v) => v.iter().map(|n| n.value as f32).collect(),
            other => {
                return Err(r.err(format!(
                    "SubdivisionMesh: [floatargs] must be an array of numbers, got {}",
                    describe(other)
                )));
            }
        };
        // Two counts per tag (ints, floats), or three when string arguments follow.
        let per_tag = if nargs.len() == 2 * tags.len() {
            2
        } else if nargs.len() == 3 * tags.len() {
            3
        } else {
            return Err(r.err(format!(
                "SubdivisionMesh: [nargs] has {} values for {} tags; expected 2 per tag",
                nargs.len(),
                tags.len()
            )));
        };
        let (mut io, mut fo) = (0usize, 0usize);
        let mut warned = HashSet::new();
        for (k, tag) in tags.iter().enumerate() {
            let (ni, nf) = (nargs[k * per_tag], nargs[k * per_tag + 1]);
            let (Some(ti), Some(tf)) = (
                ints.get(io..io.saturating_add(ni)),
                floats.get(fo..fo.saturating_add(nf)),
            ) else {
                return Err(r.err(format!(
                    "SubdivisionMesh: [nargs] asks for more arguments than [intargs] ({}) and [floatargs] ({}) hold",
                    ints.len(),
                    floats.len()
                )));
            };
            io += ni;
            fo += nf;
            match tag.as_str() {
                "crease" => {
                    let chain = check_indices(r, ti, mesh.positions.len())?;
                    let edges = chain.len().saturating_sub(1);
                    if chain.len() < 2 || !(tf.len() == 1 || tf.len() == edges) {
                        return Err(r.err(format!(
                            "SubdivisionMesh: a \"crease\" needs at least 2 vertices and 1 sharpness (or one per edge), got {} and {}",
                            chain.len(),
                            tf.len()
                        )));
                    }
                    for (e, pair) in chain.windows(2).enumerate() {
                        let s = if tf.len() == 1 { tf[0] } else { tf[e] };
                        mesh.creases.push((pair[0], pair[1], s));
                    }
                }
                "interpolateboundary" => mesh.interpolate_boundary = ti.first().is_none_or(|&v| v != 0),
                other => {
                    if warned.insert(other.to_string()) {
                        self.warn(
                            r,
                            format!("SubdivisionMesh: tag \"{other}\" is not supported, ignored"),
                        );
                    }
                }
            }
        }
        if io != ints.len() || fo != floats.len() {
            return Err(r.err(format!(
                "SubdivisionMesh: [nargs] accounts for {io} integer and {fo} float arguments, but [intargs] has {} and [floatargs] {}",
                ints.len(),
                floats.len()
            )));
        }
        Ok(())
    }
}

/// The transform a request applies, or `None` when it is not a transform request.
fn transform_op(r: &Req<'_>) -> Result<Option<Op>, RibError> {
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

/// One polygon's loops (outline, then holes) of vertex indices as written.
type FaceLoops = Vec<Vec<i64>>;

/// Cuts `items` into consecutive runs of `counts[k]` items; the counts must add up to `items.len()`.
fn split_by_counts<T: Clone>(
    r: &Req<'_>,
    items: &[T],
    counts: &[usize],
    counts_name: &str,
    items_name: &str,
) -> Result<Vec<Vec<T>>, RibError> {
    let total = counts.iter().fold(0usize, |a, &n| a.saturating_add(n));
    if total != items.len() {
        return Err(r.err(format!(
            "{}: {counts_name} adds up to {total} but {items_name} has {} entries",
            r.name,
            items.len()
        )));
    }
    let mut out = Vec::with_capacity(counts.len());
    let mut at = 0;
    for &n in counts {
        out.push(items[at..at + n].to_vec());
        at += n;
    }
    Ok(out)
}

/// The indices as `u32`, each checked against the number of points.
fn check_indices(r: &Req<'_>, indices: &[i64], points: usize) -> Result<Vec<u32>, RibError> {
    indices
        .iter()
        .map(|&i| {
            usize::try_from(i)
                .ok()
                .filter(|&u| u < points)
                .map(|u| u as u32)
                .ok_or_else(|| {
                    r.err(format!(
                        "{}: vertex index {i} is out of range (\"P\" has {points} points)",
                        r.name
                    ))
                })
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------------
// Triangulation
// ---------------------------------------------------------------------------------------------------

/// A polygon vertex projected to the polygon's plane: its index into the positions and its 2-D point.
#[derive(Debug, Clone, Copy, PartialEq)]
struct RingVertex {
    index: u32,
    p: Vec2,
}

fn cross2(a: Vec2, b: Vec2) -> f32 {
    a.x * b.y - a.y * b.x
}

/// Twice the signed area (positive counter-clockwise).
fn signed_area2(ring: &[RingVertex]) -> f32 {
    let n = ring.len();
    (0..n).map(|i| cross2(ring[i].p, ring[(i + 1) % n].p)).sum()
}

/// The turn at vertex `i` of a ring: positive when convex in a counter-clockwise ring.
fn turn(ring: &[RingVertex], i: usize) -> f32 {
    let n = ring.len();
    let (a, b, c) = (ring[(i + n - 1) % n].p, ring[i].p, ring[(i + 1) % n].p);
    cross2(b - a, c - b)
}

/// Triangulates one polygon: `loops[0]` the outline, the others holes, as indices into `positions`.
/// Triangles keep the outline's winding. `None` when the polygon is degenerate (fewer than 3 distinct
/// vertices, or no area).
///
/// The polygon is projected onto the axis plane of the largest component of its Newell normal. A convex
/// polygon without holes is fanned; otherwise each hole (in order of decreasing rightmost x) is joined to
/// the outline by a bridge from its rightmost vertex to the nearest visible outline vertex, and the
/// resulting simple ring is ear-clipped.
fn triangulate(positions: &[Vec3], loops: &[Vec<u32>]) -> Option<Vec<[u32; 3]>> {
    let point = |i: u32| positions.get(i as usize).copied();
    let mut cleaned = Vec::with_capacity(loops.len());
    for l in loops {
        let mut out: Vec<u32> = Vec::with_capacity(l.len());
        for &i in l {
            let p = point(i)?;
            if out.last().and_then(|&j| point(j)) != Some(p) {
                out.push(i);
            }
        }
        while out.len() > 1 && point(out[0]) == out.last().and_then(|&j| point(j)) {
            out.pop();
        }
        cleaned.push(out);
    }
    let outline = cleaned.first().filter(|o| o.len() >= 3)?;
    let pts: Vec<Vec3> = outline.iter().filter_map(|&i| point(i)).collect();
    let mut normal = Vec3::ZERO;
    for (k, a) in pts.iter().enumerate() {
        let b = pts[(k + 1) % pts.len()];
        normal += Vec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    let (lo, hi) = pts
        .iter()
        .fold((pts[0], pts[0]), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let extent = (hi - lo).max_element();
    if !(normal.is_finite() && normal.length() > 1e-7 * extent * extent) {
        return None;
    }
    let a = normal.abs();
    let project = |p: Vec3| {
        if a.x >= a.y && a.x >= a.z {
            Vec2::new(p.y, p.z)
        } else if a.y >= a.z {
            Vec2::new(p.z, p.x)
        } else {
            Vec2::new(p.x, p.y)
        }
    };
    let ring_of = |l: &[u32]| -> Vec<RingVertex> {
        l.iter()
            .filter_map(|&i| {
                Some(RingVertex {
                    index: i,
                    p: project(point(i)?),
                })
            })
            .collect()
    };
    let mut ring = ring_of(outline);
    // Mirror the plane, not the order, so that the outline runs counter-clockwise and the triangles keep
    // the winding the file gave.
    let mirror = signed_area2(&ring) < 0.0;
    let flip = |r: &mut Vec<RingVertex>| {
        if mirror {
            for v in r.iter_mut() {
                v.p.x = -v.p.x;
            }
        }
    };
    flip(&mut ring);
    if signed_area2(&ring).is_nan() || signed_area2(&ring) <= 0.0 {
        return None;
    }
    let mut holes: Vec<Vec<RingVertex>> = Vec::new();
    for l in cleaned.iter().skip(1).filter(|l| l.len() >= 3) {
        let mut h = ring_of(l);
        flip(&mut h);
        let area = signed_area2(&h);
        if area == 0.0 {
            continue;
        }
        if area > 0.0 {
            h.reverse(); // holes run clockwise
        }
        holes.push(h);
    }
    if holes.is_empty() && (0..ring.len()).all(|i| turn(&ring, i) >= 0.0) {
        let r0 = ring[0].index;
        return Some(
            ring.windows(2)
                .skip(1)
                .map(|w| [r0, w[0].index, w[1].index])
                .collect(),
        );
    }
    let max_x = |h: &[RingVertex]| h.iter().map(|v| v.p.x).fold(f32::NEG_INFINITY, f32::max);
    holes.sort_by(|a, b| max_x(b).total_cmp(&max_x(a)));
    for h in &holes {
        ring = bridge(ring, h);
    }
    Some(ear_clip(&ring))
}

/// True when the segments `p1–p2` and `q1–q2` cross at a point interior to both.
fn segments_cross(p1: Vec2, p2: Vec2, q1: Vec2, q2: Vec2) -> bool {
    let d1 = cross2(q2 - q1, p1 - q1);
    let d2 = cross2(q2 - q1, p2 - q1);
    let d3 = cross2(p2 - p1, q1 - p1);
    let d4 = cross2(p2 - p1, q2 - p1);
    d1 * d2 < 0.0 && d3 * d4 < 0.0
}

/// True when the direction from ring vertex `k` towards `m` points into the polygon's interior at `k`.
fn in_wedge(ring: &[RingVertex], k: usize, m: Vec2) -> bool {
    let n = ring.len();
    let v = ring[k].p;
    let (prev, next) = (ring[(k + n - 1) % n].p - v, ring[(k + 1) % n].p - v);
    let d = m - v;
    if cross2(next, prev) >= 0.0 {
        cross2(next, d) > 0.0 && cross2(d, prev) > 0.0
    } else {
        !(cross2(prev, d) >= 0.0 && cross2(d, next) >= 0.0)
    }
}

/// Joins a clockwise hole to a counter-clockwise ring: from the hole's rightmost vertex to the nearest
/// ring vertex it sees (preferring those to its right, where no unjoined hole can be in the way).
fn bridge(ring: Vec<RingVertex>, hole: &[RingVertex]) -> Vec<RingVertex> {
    let Some(mi) = (0..hole.len()).max_by(|&a, &b| hole[a].p.x.total_cmp(&hole[b].p.x)) else {
        return ring;
    };
    let m = hole[mi].p;
    let n = ring.len();
    let mut candidates: Vec<usize> = (0..n).collect();
    candidates.sort_by(|&a, &b| {
        let key = |i: usize| (ring[i].p.x < m.x, ring[i].p.distance_squared(m));
        let (ka, kb) = (key(a), key(b));
        ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
    });
    let visible = |k: usize| {
        let v = ring[k].p;
        (0..n).all(|j| {
            let (a, b) = (ring[j].p, ring[(j + 1) % n].p);
            a == v || b == v || a == m || b == m || !segments_cross(m, v, a, b)
        })
    };
    let pick = candidates
        .iter()
        .copied()
        .find(|&k| visible(k) && in_wedge(&ring, k, m))
        .or_else(|| candidates.iter().copied().find(|&k| visible(k)))
        .or_else(|| candidates.first().copied());
    let Some(k) = pick else {
        return ring;
    };
    let mut out = Vec::with_capacity(n + hole.len() + 2);
    out.extend_from_slice(&ring[..=k]);
    out.extend_from_slice(&hole[mi..]);
    out.extend_from_slice(&hole[..=mi]);
    out.extend_from_slice(&ring[k..]);
    out
}

/// True when `p` lies inside or on the counter-clockwise triangle `a b c`.
fn in_triangle(p: Vec2, a: Vec2, b: Vec2, c: Vec2) -> bool {
    cross2(b - a, p - a) >= 0.0 && cross2(c - b, p - b) >= 0.0 && cross2(a - c, p - c) >= 0.0
}

/// Ear clipping of a counter-clockwise ring (which may touch itself along hole bridges).
fn ear_clip(ring: &[RingVertex]) -> Vec<[u32; 3]> {
    let mut live = ring.to_vec();
    let mut tris = Vec::with_capacity(ring.len().saturating_sub(2));
    let mut i = 0usize;
    let mut misses = 0usize;
    while live.len() > 3 {
        let n = live.len();
        i %= n;
        let (a, b, c) = (live[(i + n - 1) % n], live[i], live[(i + 1) % n]);
        let is_ear = turn(&live, i) > 0.0
            && live
                .iter()
                .all(|v| v.p == a.p || v.p == b.p || v.p == c.p || !in_triangle(v.p, a.p, b.p, c.p));
        if is_ear {
            tris.push([a.index, b.index, c.index]);
            live.remove(i);
            misses = 0;
            // Step back: the previous vertex has a new neighbour and may have become an ear.
            i = (i + live.len() - 1) % live.len();
            continue;
        }
        i += 1;
        misses += 1;
        if misses >= n {
            // No clean ear in a whole pass: straight vertices or rounding. Remove the flattest
            // non-reflex vertex (a straight one adds no area).
            let k = (0..n)
                .map(|k| (k, turn(&live, k)))
                .filter(|(_, t)| *t >= 0.0)
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .map_or(i % n, |(k, _)| k);
            if turn(&live, k) > 0.0 {
                tris.push([
                    live[(k + n - 1) % n].index,
                    live[k].index,
                    live[(k + 1) % n].index,
                ]);
            }
            live.remove(k);
            misses = 0;
            i = k;
        }
    }
    if live.len() == 3 && turn(&live, 1) > 0.0 {
        tris.push([live[0].index, live[1].index, live[2].index]);
    }
    tris
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::{ParamType, Vec3 as SdkVec3};
    use proptest::prelude::*;

    const HERE: &str = "/base";

    fn parse(text: &str) -> Result<Scene, RibError> {
        parse_str(text, "t.rib", Path::new(HERE))
    }

    fn ok(text: &str) -> Scene {
        parse(text).unwrap_or_else(|e| panic!("{e}"))
    }

    fn fail(text: &str) -> String {
        match parse(text) {
            Ok(_) => panic!("expected an error for:\n{text}"),
            Err(e) => e.to_string(),
        }
    }

    /// The one object a world block holding `body` makes.
    fn only_object(body: &str) -> Object {
        let scene = ok(&format!("WorldBegin\n{body}\nWorldEnd\n"));
        assert_eq!(scene.objects.len(), 1, "{:?}", scene.objects);
        scene.objects[0].clone()
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-5
    }

    fn camera_point(scene: &Scene, sample: usize, p: Vec3) -> Vec3 {
        let m = scene.camera.world_to_camera[sample].world_to_camera;
        let q = m.transform_point(SdkVec3::new(p.x, p.y, p.z));
        Vec3::new(q.x, q.y, q.z)
    }

    fn num(value: f64, int: Option<i32>) -> Num {
        Num { value, int }
    }

    // --- tokenizer -----------------------------------------------------------------------------------

    #[test]
    fn lexer_reads_comments_strings_escapes_numbers_and_arrays() {
        let text = "# heading\nFoo \"a\\\"b\\\\c\\nd\" -1.5e2 .5 +3 42 [1 2.0] [\"x\" \"y\"] [] # tail\nBar";
        let cmds = lex(text).unwrap();
        assert_eq!(cmds.len(), 2);
        assert_eq!((cmds[0].name.as_str(), cmds[0].line), ("Foo", 2));
        assert_eq!(
            cmds[0].args,
            vec![
                Value::Str("a\"b\\c\nd".into()),
                Value::Num(num(-150.0, None)),
                Value::Num(num(0.5, None)),
                Value::Num(num(3.0, Some(3))),
                Value::Num(num(42.0, Some(42))),
                Value::Nums(vec![num(1.0, Some(1)), num(2.0, None)]),
                Value::Strs(vec!["x".into(), "y".into()]),
                Value::Nums(vec![]),
            ]
        );
        assert_eq!(
            (cmds[1].name.as_str(), cmds[1].line, cmds[1].args.len()),
            ("Bar", 3, 0)
        );
    }

    #[test]
    fn lexer_counts_lines_inside_strings_and_arrays() {
        let cmds = lex("A \"x\ny\" [1\n2]\nB").unwrap();
        assert_eq!(cmds[0].line, 1);
        assert_eq!(cmds[1].line, 4);
    }

    #[test]
    fn unterminated_string_names_the_line_it_started() {
        let msg = fail("Format 64 64 1\nDisplay \"a.exr\n\n\nWorldBegin\n");
        assert_eq!(msg, "t.rib:2: unterminated string: the closing '\"' is missing");
    }

    #[test]
    fn unterminated_array_names_the_line_it_started() {
        let msg = fail("WorldBegin\nPolygon \"P\" [0 0 0\n1 0 0\nSphere 1 -1 1 360\n");
        assert_eq!(msg, "t.rib:2: unterminated array: no ']' before the next request");
        let msg = fail("WorldBegin\n\nPolygon \"P\" [0 0 0\n1 0 0\n");
        assert_eq!(msg, "t.rib:3: unterminated array: the closing ']' is missing");
    }

    #[test]
    fn malformed_numbers_and_stray_values_are_errors_with_lines() {
        assert_eq!(
            fail("\nTranslate 1e 0 0"),
            "t.rib:2: cannot read the number \"1e\""
        );
        assert_eq!(
            fail("3 Format 1 1 1"),
            "t.rib:1: expected a request name, got the number 3"
        );
        assert_eq!(fail("Foo ]"), "t.rib:1: ']' without a matching '['");
        assert_eq!(
            fail("Foo [1 \"a\"]"),
            "t.rib:1: an array mixes numbers and strings"
        );
    }

    // --- options -------------------------------------------------------------------------------------

    #[test]
    fn default_scene_is_640_by_480() {
        let scene = ok("");
        assert_eq!(scene.camera.format, Format::new(640, 480));
        assert_eq!(scene.projection, "PxrPerspective");
        assert!(scene.warnings.is_empty());
    }

    #[test]
    fn format_sets_size_and_pixel_aspect_and_a_later_one_wins() {
        let scene = ok("Format 10 10 1\nFormat 1920 1080 1.5\n");
        assert_eq!(
            scene.camera.format,
            Format {
                width: 1920,
                height: 1080,
                pixel_aspect: 1.5
            }
        );
    }

    #[test]
    fn format_with_wrong_arg_count_names_request_and_line() {
        assert_eq!(
            fail("\nFormat 64 64"),
            "t.rib:2: Format expects width height pixelaspect (3 numbers), got 2"
        );
        assert_eq!(
            fail("Format 64.5 64 1"),
            "t.rib:1: Format expects a positive integer width and height, got 64.5 64"
        );
    }

    #[test]
    fn format_after_world_begin_is_an_error() {
        assert_eq!(
            fail("WorldBegin\nFormat 64 64 1\n"),
            "t.rib:2: Format must come before WorldBegin"
        );
        assert_eq!(
            fail("WorldBegin\n\nProjection \"PxrPerspective\"\n"),
            "t.rib:3: Projection must come before WorldBegin"
        );
        assert_eq!(
            fail("Sphere 1 -1 1 360"),
            "t.rib:1: Sphere must come after WorldBegin"
        );
    }

    #[test]
    fn screen_window_is_stored() {
        let scene = ok("ScreenWindow -2 2 -1 1");
        assert_eq!(
            scene.camera.screen_window,
            Some(ScreenWindow::new(-2.0, 2.0, -1.0, 1.0))
        );
        assert_eq!(
            fail("ScreenWindow 1 -1 -1 1"),
            "t.rib:1: ScreenWindow expects left < right and bottom < top, got 1 -1 -1 1"
        );
    }

    #[test]
    fn crop_window_is_stored() {
        let scene = ok("CropWindow 0.25 0.75 0 0.5");
        assert_eq!(
            scene.camera.crop_window,
            CropWindow {
                x_min: 0.25,
                x_max: 0.75,
                y_min: 0.0,
                y_max: 0.5
            }
        );
        assert!(fail("CropWindow 0 1.5 0 1").starts_with("t.rib:1: CropWindow expects 0 <= xmin"));
    }

    #[test]
    fn shutter_is_stored() {
        assert_eq!(ok("Shutter 0 0.5").camera.shutter, (0.0, 0.5));
        assert_eq!(
            fail("Shutter 1 0"),
            "t.rib:1: Shutter expects open <= close, got 1 0"
        );
    }

    #[test]
    fn clipping_far_of_1e30_is_infinite() {
        assert_eq!(ok("Clipping 0.01 1e30").camera.clipping, (0.01, f32::INFINITY));
        assert_eq!(ok("Clipping 1 100").camera.clipping, (1.0, 100.0));
        assert_eq!(
            fail("Clipping 0 10"),
            "t.rib:1: Clipping expects 0 < near < far, got 0 10"
        );
    }

    #[test]
    fn pixel_filter_sets_kind_and_widths() {
        for (name, kind) in FILTERS {
            let scene = ok(&format!("PixelFilter \"{name}\" 3 4"));
            assert_eq!(
                scene.filter,
                PixelFilter {
                    kind,
                    width_x: 3.0,
                    width_y: 4.0
                }
            );
        }
        assert_eq!(ok("").filter, PixelFilter::default());
    }

    #[test]
    fn unknown_pixel_filter_lists_the_six() {
        assert_eq!(
            fail("\nPixelFilter \"sinc\" 2 2"),
            "t.rib:2: PixelFilter: unknown filter \"sinc\"; expected one of box, triangle, gaussian, \
             catmull-rom, mitchell, blackman-harris"
        );
        assert_eq!(
            fail("PixelFilter \"box\" 2"),
            "t.rib:1: PixelFilter expects a filter name then xwidth ywidth (2 numbers), got 1"
        );
    }

    #[test]
    fn hider_maxsamples_sets_samples_per_pixel() {
        let scene =
            ok("Hider \"raytrace\" \"int maxsamples\" [16] \"int minsamples\" [4] \"int incremental\" [1]");
        assert_eq!(scene.samples_per_pixel, 16);
        assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
        // A bare name the reader knows the type of.
        assert_eq!(ok("Hider \"raytrace\" \"maxsamples\" 8").samples_per_pixel, 8);
        let scene = ok("Hider \"hidden\" \"int maxsamples\" [16]");
        assert_eq!(scene.samples_per_pixel, 64);
        assert_eq!(
            scene.warnings,
            vec!["t.rib:1: Hider \"hidden\" is not supported (only \"raytrace\"), ignored".to_string()]
        );
        assert_eq!(
            fail("Hider \"raytrace\" \"int maxsamples\" [0]"),
            "t.rib:1: Hider: maxsamples must be at least 1, got 0"
        );
    }

    #[test]
    fn display_adds_or_replaces_and_reads_channels_and_type() {
        let scene = ok("Display \"out/beauty.exr\" \"openexr\" \"rgba\"\n\
             Display \"+aovs.exr\" \"exr\" \"rgba,z,N,P,cameraDirection\" \"string type\" \"half\"\n\
             Display \"+/abs/x.png\" \"png\" \"rgb\"\n\
             Display \"+d.exr\" \"deepexr\" \"Ci,a,z\" \"string type\" \"float\"\n\
             Display \"+e.exr\" \"openexr\" \"rgbz\"\n\
             Display \"+f.exr\" \"openexr\" \"rgbaz\"\n");
        let d = &scene.displays;
        assert_eq!(d.len(), 6);
        assert_eq!(
            d[0],
            Display {
                path: PathBuf::from("/base/out/beauty.exr"),
                driver: DisplayDriver::OpenExr,
                aovs: vec![Aov::Ci, Aov::Alpha],
                half: false
            }
        );
        assert_eq!(
            d[1],
            Display {
                path: PathBuf::from("/base/aovs.exr"),
                driver: DisplayDriver::OpenExr,
                aovs: vec![Aov::Ci, Aov::Alpha, Aov::Z, Aov::N, Aov::P, Aov::CameraDirection],
                half: true
            }
        );
        assert_eq!(
            (d[2].path.as_path(), d[2].driver),
            (Path::new("/abs/x.png"), DisplayDriver::Png)
        );
        assert_eq!(d[2].aovs, vec![Aov::Ci]);
        assert_eq!(
            (d[3].driver, d[3].aovs.as_slice(), d[3].half),
            (DisplayDriver::DeepExr, &[Aov::Ci, Aov::Alpha, Aov::Z][..], false)
        );
        assert_eq!(d[4].aovs, vec![Aov::Ci, Aov::Z]);
        assert_eq!(d[5].aovs, vec![Aov::Ci, Aov::Alpha, Aov::Z]);
        // Without "+", a display replaces the list.
        let scene = ok("Display \"a.exr\" \"openexr\" \"rgb\"\nDisplay \"b.png\" \"png\" \"rgb\"\n");
        assert_eq!(scene.displays.len(), 1);
        assert_eq!(scene.displays[0].path, PathBuf::from("/base/b.png"));
    }

    #[test]
    fn display_with_unknown_channel_names_it_and_the_known_ones() {
        assert_eq!(
            fail("\nDisplay \"a.exr\" \"openexr\" \"rgba,Cs\""),
            "t.rib:2: Display: unknown channel \"Cs\"; known channels: rgb, rgba, rgbz, rgbaz, Ci, a, z, N, \
             P, cameraDirection"
        );
        assert_eq!(
            fail("Display \"a.tif\" \"tiff\" \"rgba\""),
            "t.rib:1: Display: unknown driver \"tiff\"; expected one of openexr, exr, png, deepexr"
        );
        assert_eq!(
            fail("Display \"a.exr\" \"openexr\" \"rgba\" \"string type\" \"double\""),
            "t.rib:1: Display: \"string type\" must be \"half\" or \"float\", got \"double\""
        );
    }

    #[test]
    fn projection_keeps_its_parameters_with_their_origin() {
        let scene = ok("Projection \"PxrPerspective\" \"float fov\" [10]\n\
             Projection \"PxrFisheye\" \"float fov\" [180] \"string mapping\" \"equisolid\" \"float[2] k\" [1 2]\n");
        assert_eq!(scene.projection, "PxrFisheye");
        let p = &scene.projection_params;
        assert_eq!(p.entries().len(), 3);
        let fov = p.get("fov").unwrap();
        assert_eq!(
            (fov.ty, &fov.value),
            (ParamType::Float, &ParamValue::Floats(vec![180.0]))
        );
        assert_eq!(fov.origin.as_deref(), Some("t.rib:2"));
        assert_eq!(
            p.get("mapping").unwrap().value,
            ParamValue::Strings(vec!["equisolid".into()])
        );
        assert_eq!(p.get("k").unwrap().array_len, Some(2));
        assert_eq!(
            fail("Projection \"PxrFisheye\" \"flaot fov\" [1]"),
            "t.rib:1: Projection: unknown parameter type \"flaot\" in \"flaot fov\": expected one of float, \
             int, string, color, point, vector, normal, matrix"
        );
    }

    #[test]
    fn legacy_projection_names_map_to_plugins() {
        let scene = ok("Projection \"perspective\" \"fov\" [30]");
        assert_eq!(scene.projection, "PxrPerspective");
        let fov = scene.projection_params.get("fov").unwrap();
        assert_eq!(
            (fov.ty, &fov.value),
            (ParamType::Float, &ParamValue::Floats(vec![30.0]))
        );
        let scene = ok("Projection \"orthographic\"");
        assert_eq!(scene.projection, "PxrOrthographic");
        assert!(scene.projection_params.is_empty());
        let scene = ok("Projection \"PxrFoo\" \"bar\" [1]");
        assert_eq!(
            scene.warnings,
            vec!["t.rib:1: Projection: unknown parameter \"bar\", ignored".to_string()]
        );
    }

    #[test]
    fn camera_options_fill_aperture_and_shutter_opening() {
        let scene = ok(
            "Camera \"main\" \"int apertureNSides\" [6] \"float apertureAngle\" [15] \
             \"float apertureRoundness\" [0.5] \"float apertureDensity\" [-0.25] \"float dofaspect\" [2] \
             \"float shutterOpenTime\" [0.1] \"float shutterCloseTime\" [0.9] \
             \"float[8] shutteropening\" [0.1 0.2 0.3 0.4 0.5 0.6 0.7 0.8]",
        );
        let a = scene.camera.aperture;
        assert_eq!(
            (a.n_sides, a.angle_deg, a.roundness, a.density, a.dof_aspect),
            (6, 15.0, 0.5, -0.25, 2.0)
        );
        let s = scene.camera.shutter_opening;
        assert_eq!((s.open_time, s.close_time), (0.1, 0.9));
        assert_eq!(s.opening, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8]);
        // RenderMan ≤ 21's two-value shutteropening.
        let s = ok("Camera \"world\" \"float[2] shutteropening\" [0.25 0.75]")
            .camera
            .shutter_opening;
        assert_eq!((s.open_time, s.close_time), (0.25, 0.75));
        assert_eq!(
            fail("Camera \"main\" \"float apertureNSides\" [6]"),
            "t.rib:1: Camera: parameter \"float apertureNSides\" has the wrong type; expected \"int apertureNSides\""
        );
        assert_eq!(
            fail("Camera \"main\" \"shutteropening\" [1 2 3]"),
            "t.rib:1: Camera: \"float[8] shutteropening\" needs 8 value(s), got 3"
        );
    }

    // --- transforms ----------------------------------------------------------------------------------

    #[test]
    fn translate_before_world_begin_puts_the_world_origin_at_plus_z() {
        let scene = ok("Shutter 0.25 1\nTranslate 0 0 5\nWorldBegin\n");
        let w2c = &scene.camera.world_to_camera;
        assert_eq!(w2c.len(), 1);
        assert_eq!(w2c[0].time, 0.25);
        // Row-vector convention: the translation sits in the last row.
        assert_eq!(w2c[0].world_to_camera.0[3], [0.0, 0.0, 5.0, 1.0]);
        assert!(close(
            camera_point(&scene, 0, Vec3::ZERO),
            Vec3::new(0.0, 0.0, 5.0)
        ));
    }

    #[test]
    fn rotate_90_about_y_sends_world_x_to_camera_minus_z() {
        // Rotation by +90° about +Y in the column-vector formula: x' = x cosθ + z sinθ, z' = −x sinθ + z cosθ,
        // so (1, 0, 0) → (0, 0, −1), behind the camera.
        let scene = ok("Rotate 90 0 1 0\nWorldBegin\n");
        assert!(close(camera_point(&scene, 0, Vec3::X), Vec3::new(0.0, 0.0, -1.0)));
    }

    #[test]
    fn camera_requests_apply_last_written_first() {
        // Translate is written last, so it acts first: (0,0,0) → (0,0,5) → rotated 90° about Y → (5,0,0).
        let scene = ok("Rotate 90 0 1 0\nTranslate 0 0 5\nWorldBegin\n");
        assert!(close(
            camera_point(&scene, 0, Vec3::ZERO),
            Vec3::new(5.0, 0.0, 0.0)
        ));
    }

    #[test]
    fn translate_then_scale_in_the_world_scales_first() {
        let o = only_object("Translate 1 0 0\nScale 2 2 2\nSphere 1 -1 1 360");
        let m = o.transform.samples[0].1;
        assert!(close(m.transform_point3(Vec3::X), Vec3::new(3.0, 0.0, 0.0)));
        assert_eq!(o.source, "t.rib:4");
    }

    #[test]
    fn rotate_about_z_turns_x_toward_y() {
        let o = only_object("Rotate 30 0 0 2\nSphere 1 -1 1 360");
        let (s, c) = 30f32.to_radians().sin_cos();
        assert!(close(
            o.transform.samples[0].1.transform_point3(Vec3::X),
            Vec3::new(c, s, 0.0)
        ));
        assert_eq!(
            fail("WorldBegin\nRotate 30 0 0 0"),
            "t.rib:2: Rotate expects a non-zero axis"
        );
        assert_eq!(
            fail("Translate 1 2"),
            "t.rib:1: Translate expects x y z (3 numbers), got 2"
        );
    }

    #[test]
    fn concat_transform_reads_rib_row_major_matrices() {
        let o = only_object(
            "Scale 2 2 2\nConcatTransform [1 0 0 0  0 1 0 0  0 0 1 0  1 2 3 1]\nSphere 1 -1 1 360",
        );
        // The matrix (a translation by (1,2,3) in RIB's row-vector layout) acts before the scale.
        assert!(close(
            o.transform.samples[0].1.transform_point3(Vec3::ZERO),
            Vec3::new(2.0, 4.0, 6.0)
        ));
    }

    #[test]
    fn transform_and_identity_replace_the_current_transform() {
        let o =
            only_object("Translate 5 0 0\nTransform [2 0 0 0 0 2 0 0 0 0 2 0 0 0 0 1]\nSphere 1 -1 1 360");
        assert_eq!(o.transform.samples[0].1, Mat4::from_scale(Vec3::splat(2.0)));
        let o = only_object("Translate 5 0 0\nIdentity\nSphere 1 -1 1 360");
        assert_eq!(o.transform, MotionTransform::fixed(Mat4::IDENTITY));
    }

    // --- blocks --------------------------------------------------------------------------------------

    #[test]
    fn attribute_block_restores_material_transform_and_dicing() {
        let scene = ok("WorldBegin\n\
             Bxdf \"PxrDiffuse\" \"red\" \"color diffuseColor\" [1 0 0]\n\
             Translate 1 0 0\n\
             AttributeBegin\n\
               Bxdf \"PxrConstant\" \"glow\" \"color emitColor\" [2 2 2]\n\
               Attribute \"dice\" \"float micropolygonlength\" [0.5]\n\
               Translate 0 1 0\n\
               Sphere 1 -1 1 360\n\
             AttributeEnd\n\
             Sphere 1 -1 1 360\n");
        let (inner, outer) = (&scene.objects[0], &scene.objects[1]);
        assert_eq!((inner.material, inner.micropolygon_length), (2, 0.5));
        assert_eq!(
            inner.transform.samples[0].1,
            Mat4::from_translation(Vec3::new(1.0, 1.0, 0.0))
        );
        assert_eq!((outer.material, outer.micropolygon_length), (1, 1.0));
        assert_eq!(outer.transform.samples[0].1, Mat4::from_translation(Vec3::X));
    }

    #[test]
    fn transform_block_restores_only_the_transform() {
        let scene = ok(
            "WorldBegin\nTransformBegin\nTranslate 0 1 0\nBxdf \"PxrDiffuse\" \"d\"\nTransformEnd\n\
             Sphere 1 -1 1 360\n",
        );
        assert_eq!(scene.objects[0].transform, MotionTransform::fixed(Mat4::IDENTITY));
        assert_eq!(scene.objects[0].material, 1);
    }

    #[test]
    fn unbalanced_blocks_name_the_unmatched_request() {
        assert_eq!(
            fail("WorldBegin\nAttributeBegin\nAttributeEnd\nAttributeEnd\n"),
            "t.rib:4: AttributeEnd without a matching AttributeBegin"
        );
        assert_eq!(
            fail("WorldBegin\nAttributeBegin\nSphere 1 -1 1 360\n"),
            "t.rib:2: AttributeBegin has no matching AttributeEnd"
        );
        assert_eq!(
            fail("WorldBegin\nAttributeBegin\nTransformEnd\n"),
            "t.rib:3: TransformEnd does not match AttributeBegin at t.rib:2"
        );
        assert_eq!(
            fail("WorldBegin\nTransformBegin\nWorldEnd\n"),
            "t.rib:3: WorldEnd: TransformBegin at t.rib:2 has no matching TransformEnd"
        );
    }

    // --- motion --------------------------------------------------------------------------------------

    #[test]
    fn camera_motion_block_gives_one_sample_per_time() {
        let scene =
            ok("Shutter 0 1\nMotionBegin [0 1]\nTranslate 0 0 5\nTranslate 1 0 5\nMotionEnd\nWorldBegin\n");
        let w2c = &scene.camera.world_to_camera;
        assert_eq!(w2c.iter().map(|s| s.time).collect::<Vec<_>>(), vec![0.0, 1.0]);
        assert!(close(
            camera_point(&scene, 0, Vec3::ZERO),
            Vec3::new(0.0, 0.0, 5.0)
        ));
        assert!(close(
            camera_point(&scene, 1, Vec3::ZERO),
            Vec3::new(1.0, 0.0, 5.0)
        ));
    }

    #[test]
    fn object_motion_then_static_transforms_apply_to_every_sample() {
        let o = only_object(
            "MotionBegin [0 0.5]\nTranslate 0 0 0\nTranslate 2 0 0\nMotionEnd\nScale 2 2 2\nSphere 1 -1 1 360",
        );
        let s = &o.transform.samples;
        assert_eq!(s.iter().map(|s| s.0).collect::<Vec<_>>(), vec![0.0, 0.5]);
        assert!(close(s[0].1.transform_point3(Vec3::X), Vec3::new(2.0, 0.0, 0.0)));
        assert!(close(s[1].1.transform_point3(Vec3::X), Vec3::new(4.0, 0.0, 0.0)));
        assert!(o.transform.is_moving());
    }

    #[test]
    fn motion_block_with_several_groups_composes_them_per_time() {
        let o = only_object(
            "MotionBegin [0 1]\nTranslate 0 0 0\nTranslate 1 0 0\nRotate 0 0 0 1\nRotate 90 0 0 1\nMotionEnd\n\
             Sphere 1 -1 1 360",
        );
        let s = &o.transform.samples;
        assert!(close(s[0].1.transform_point3(Vec3::X), Vec3::X));
        assert!(close(s[1].1.transform_point3(Vec3::X), Vec3::new(1.0, 1.0, 0.0)));
    }

    #[test]
    fn attribute_end_restores_a_static_transform_after_motion() {
        let scene = ok(
            "WorldBegin\nAttributeBegin\nMotionBegin [0 1]\nTranslate 0 0 0\nTranslate 1 0 0\n\
             MotionEnd\nAttributeEnd\nSphere 1 -1 1 360\n",
        );
        assert!(!scene.objects[0].transform.is_moving());
        assert_eq!(scene.objects[0].transform.samples.len(), 1);
    }

    #[test]
    fn malformed_motion_blocks_are_errors() {
        assert_eq!(
            fail("WorldBegin\nMotionBegin [0 1]\nTranslate 1 0 0\nMotionEnd\n"),
            "t.rib:4: MotionEnd: MotionBegin at t.rib:2 gives 2 times but the block holds 1 transform \
             requests; expected 2 (one per time, or a multiple of 2 for several groups)"
        );
        assert_eq!(
            fail("WorldBegin\nMotionBegin [0 1]\nSphere 1 -1 1 360\n"),
            "t.rib:3: Sphere inside MotionBegin (at t.rib:2): only transform requests may move"
        );
        assert_eq!(
            fail("MotionBegin [0 1]\nTranslate 1 0 0\n"),
            "t.rib:1: MotionBegin has no matching MotionEnd"
        );
        assert_eq!(
            fail("MotionEnd"),
            "t.rib:1: MotionEnd without a matching MotionBegin"
        );
        assert_eq!(
            fail("MotionBegin [1 0]"),
            "t.rib:1: MotionBegin expects increasing times, got [1.0, 0.0]"
        );
    }

    // --- archives ------------------------------------------------------------------------------------

    #[test]
    fn read_archive_reads_in_place_with_the_same_state() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let main = dir.path().join("main.rib");
        std::fs::write(
            &main,
            "WorldBegin\nBxdf \"PxrDiffuse\" \"d\"\nTranslate 1 0 0\nReadArchive \"sub/part.rib\"\nSphere 1 -1 1 360\n",
        )
        .unwrap();
        std::fs::write(
            dir.path().join("sub/part.rib"),
            "Cone 1 1 360\nReadArchive \"leaf.rib\"\n",
        )
        .unwrap();
        std::fs::write(
            dir.path().join("sub/leaf.rib"),
            "Translate 0 1 0\nDisk 0 1 360\nBogus 1\n",
        )
        .unwrap();
        let scene = parse_file(&main).unwrap();
        let part = dir.path().join("sub/part.rib").display().to_string();
        let leaf = dir.path().join("sub/leaf.rib").display().to_string();
        let o = &scene.objects;
        assert_eq!(o.len(), 3);
        assert_eq!(o[0].source, format!("{part}:1"));
        assert_eq!(
            (o[0].material, o[0].transform.samples[0].1),
            (1, Mat4::from_translation(Vec3::X))
        );
        assert_eq!(o[1].source, format!("{leaf}:2"));
        // The archive's Translate stays in force after it: the state is shared.
        assert_eq!(
            o[2].transform.samples[0].1,
            Mat4::from_translation(Vec3::new(1.0, 1.0, 0.0))
        );
        assert_eq!(
            scene.warnings,
            vec![format!("{leaf}:3: unknown request Bogus, skipped")]
        );
    }

    #[test]
    fn missing_archive_names_the_including_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let main = dir.path().join("main.rib");
        std::fs::write(&main, "WorldBegin\nReadArchive \"nope.rib\"\n").unwrap();
        let e = parse_file(&main).unwrap_err();
        assert_eq!(
            (e.file.as_str(), e.line),
            (main.display().to_string().as_str(), 2)
        );
        let missing = dir.path().join("nope.rib").display().to_string();
        assert!(
            e.message
                .starts_with(&format!("ReadArchive: cannot read \"{missing}\": ")),
            "{e}"
        );
    }

    #[test]
    fn recursive_archives_stop_at_32_levels() {
        let dir = tempfile::tempdir().unwrap();
        let me = dir.path().join("self.rib");
        std::fs::write(&me, "ReadArchive \"self.rib\"\n").unwrap();
        let e = parse_file(&me).unwrap_err();
        assert_eq!((e.file.as_str(), e.line), (me.display().to_string().as_str(), 1));
        assert_eq!(
            e.message,
            "ReadArchive \"self.rib\": archives nested more than 32 deep (does an archive read itself?)"
        );
    }

    #[test]
    fn parse_file_names_the_file_in_messages() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.rib");
        std::fs::write(&path, "\n\nFormat 1 2\n").unwrap();
        let e = parse_file(&path).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "{}:3: Format expects width height pixelaspect (3 numbers), got 2",
                path.display()
            )
        );
        let e = parse_file(&dir.path().join("absent.rib")).unwrap_err();
        assert_eq!(e.line, 0);
    }

    // --- shapes --------------------------------------------------------------------------------------

    #[test]
    fn sphere_is_read() {
        let o = only_object("Sphere 2 -1 1.5 270");
        assert_eq!(
            o.shape,
            Shape::Sphere {
                radius: 2.0,
                z_min: -1.0,
                z_max: 1.5,
                theta_max: 270.0
            }
        );
        assert_eq!((o.material, o.micropolygon_length), (0, 1.0));
    }

    #[test]
    fn sphere_with_wrong_arg_count_names_the_line() {
        assert_eq!(
            fail("WorldBegin\nSphere 1 -1 1"),
            "t.rib:2: Sphere expects radius zmin zmax thetamax (4 numbers), got 3"
        );
    }

    #[test]
    fn cylinder_is_read() {
        let o = only_object("Cylinder 0.5 0 2 360");
        assert_eq!(
            o.shape,
            Shape::Cylinder {
                radius: 0.5,
                z_min: 0.0,
                z_max: 2.0,
                theta_max: 360.0
            }
        );
    }

    #[test]
    fn cone_is_read() {
        assert_eq!(
            only_object("Cone 2 0.5 180").shape,
            Shape::Cone {
                height: 2.0,
                radius: 0.5,
                theta_max: 180.0
            }
        );
    }

    #[test]
    fn disk_is_read() {
        assert_eq!(
            only_object("Disk 0.25 3 360").shape,
            Shape::Disk {
                height: 0.25,
                radius: 3.0,
                theta_max: 360.0
            }
        );
    }

    #[test]
    fn torus_is_read_and_extra_parameters_are_ignored_with_a_warning() {
        let scene = ok("WorldBegin\nTorus 1 0.25 0 360 180 \"constant float foo\" [1]\n");
        assert_eq!(
            scene.objects[0].shape,
            Shape::Torus {
                major_radius: 1.0,
                minor_radius: 0.25,
                phi_min: 0.0,
                phi_max: 360.0,
                theta_max: 180.0
            }
        );
        assert_eq!(
            scene.warnings,
            vec!["t.rib:2: Torus: unknown parameter \"foo\", ignored".to_string()]
        );
    }

    fn mesh(o: &Object) -> &Mesh {
        match &o.shape {
            Shape::Mesh(m) => m,
            other => panic!("expected a mesh, got {other:?}"),
        }
    }

    fn tri_area(m: &Mesh, t: [u32; 3]) -> f32 {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        (b - a).cross(c - a).length() / 2.0
    }

    /// Shoelace formula, written independently of the reader.
    fn shoelace(poly: &[(f32, f32)]) -> f32 {
        let n = poly.len();
        (0..n)
            .map(|i| {
                let (x0, y0) = poly[i];
                let (x1, y1) = poly[(i + 1) % n];
                x0 * y1 - x1 * y0
            })
            .sum::<f32>()
            / 2.0
    }

    /// Even–odd crossing test, written independently of the reader.
    fn inside(poly: &[(f32, f32)], (x, y): (f32, f32)) -> bool {
        let mut c = false;
        let n = poly.len();
        for i in 0..n {
            let (xi, yi) = poly[i];
            let (xj, yj) = poly[(i + n - 1) % n];
            if (yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi {
                c = !c;
            }
        }
        c
    }

    /// A tilted plane: 2-D (x, y) ↦ origin + x·u + y·v, u and v orthonormal (areas are kept).
    fn plane_point((x, y): (f32, f32)) -> Vec3 {
        Vec3::new(1.0, 2.0, 3.0) + x * Vec3::new(0.6, 0.0, 0.8) + y * Vec3::Y
    }

    fn plane_coords(p: Vec3) -> (f32, f32) {
        let d = p - Vec3::new(1.0, 2.0, 3.0);
        (d.dot(Vec3::new(0.6, 0.0, 0.8)), d.y)
    }

    fn rib_points(points: &[(f32, f32)]) -> String {
        points
            .iter()
            .map(|&p| {
                let q = plane_point(p);
                format!("{} {} {}", q.x, q.y, q.z)
            })
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// Area sum, every triangle's centroid inside the outline and outside every hole, consistent winding.
    fn check_triangulation(m: &Mesh, outline: &[(f32, f32)], holes: &[&[(f32, f32)]]) {
        let expected = shoelace(outline).abs() - holes.iter().map(|h| shoelace(h).abs()).sum::<f32>();
        let total: f32 = m.triangles.iter().map(|&t| tri_area(m, t)).sum();
        assert!(
            (total - expected).abs() < 1e-3,
            "area {total}, expected {expected}"
        );
        let plane_normal = Vec3::new(0.6, 0.0, 0.8).cross(Vec3::Y) * shoelace(outline).signum();
        for &t in &m.triangles {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let centroid = plane_coords((a + b + c) / 3.0);
            assert!(inside(outline, centroid), "triangle {t:?} leaves the outline");
            for h in holes {
                assert!(!inside(h, centroid), "triangle {t:?} covers a hole");
            }
            assert!(
                (b - a).cross(c - a).dot(plane_normal) > 0.0,
                "triangle {t:?} is flipped"
            );
        }
    }

    #[test]
    fn concave_polygon_is_ear_clipped_to_its_area() {
        // A comb, counter-clockwise, then a star, clockwise, both on a tilted plane.
        let comb = [
            (0.0, 0.0),
            (4.0, 0.0),
            (4.0, 1.0),
            (1.0, 1.0),
            (1.0, 2.0),
            (4.0, 2.0),
            (4.0, 3.0),
            (0.0, 3.0),
        ];
        let o = only_object(&format!("Polygon \"P\" [{}]", rib_points(&comb)));
        assert_eq!(mesh(&o).triangles.len(), comb.len() - 2);
        check_triangulation(mesh(&o), &comb, &[]);
        let star: Vec<(f32, f32)> = (0..10)
            .rev()
            .map(|k| {
                let r = if k % 2 == 0 { 2.0 } else { 0.7 };
                let a = k as f32 * std::f32::consts::PI / 5.0;
                (r * a.cos(), r * a.sin())
            })
            .collect();
        let o = only_object(&format!("Polygon \"P\" [{}]", rib_points(&star)));
        check_triangulation(mesh(&o), &star, &[]);
    }

    #[test]
    fn polygon_with_holes_is_bridged_and_clipped_to_its_area() {
        let outline = [(0.0, 0.0), (10.0, 0.0), (10.0, 4.0), (0.0, 4.0)];
        let square = [(1.0, 1.0), (3.0, 1.0), (3.0, 3.0), (1.0, 3.0)]; // counter-clockwise, like the outline
        let slot = [(8.0, 1.0), (6.0, 1.0), (6.0, 2.0), (8.0, 2.0)]; // clockwise
        let points: Vec<(f32, f32)> = outline.iter().chain(&square).chain(&slot).copied().collect();
        let o = only_object(&format!(
            "PointsGeneralPolygons [3] [4 4 4] [0 1 2 3 4 5 6 7 8 9 10 11] \"P\" [{}]",
            rib_points(&points)
        ));
        check_triangulation(mesh(&o), &outline, &[&square, &slot]);
        // A concave outline with one hole.
        let u = [
            (0.0, 0.0),
            (6.0, 0.0),
            (6.0, 5.0),
            (4.0, 5.0),
            (4.0, 2.0),
            (2.0, 2.0),
            (2.0, 5.0),
            (0.0, 5.0),
        ];
        let hole = [(0.5, 0.5), (0.5, 1.5), (5.5, 1.5), (5.5, 0.5)];
        let points: Vec<(f32, f32)> = u.iter().chain(&hole).copied().collect();
        let o = only_object(&format!(
            "PointsGeneralPolygons [2] [8 4] [0 1 2 3 4 5 6 7 8 9 10 11] \"P\" [{}]",
            rib_points(&points)
        ));
        check_triangulation(mesh(&o), &u, &[&hole]);
    }

    #[test]
    fn points_polygons_keep_points_and_per_vertex_normals() {
        let o = only_object(
            "PointsPolygons [4 3] [0 1 4 3 1 2 4] \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 1 0] \
             \"N\" [0 0 1 0 0 1 0 0 1 0 0 1 0 0 1]",
        );
        let m = mesh(&o);
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.normals.as_ref().map(Vec::len), Some(5));
        assert_eq!(m.triangles, vec![[0, 1, 4], [0, 4, 3], [1, 2, 4]]);
    }

    #[test]
    fn vertex_index_out_of_range_names_the_line_and_index() {
        assert_eq!(
            fail("WorldBegin\nPointsPolygons [3] [0 1 5] \"P\" [0 0 0 1 0 0 0 1 0]\n"),
            "t.rib:2: PointsPolygons: vertex index 5 is out of range (\"P\" has 3 points)"
        );
        assert_eq!(
            fail("WorldBegin\nPointsPolygons [4] [0 1 2] \"P\" [0 0 0 1 0 0 0 1 0]\n"),
            "t.rib:2: PointsPolygons: [nverts] adds up to 4 but [verts] has 3 entries"
        );
    }

    #[test]
    fn degenerate_polygons_are_warned_and_skipped() {
        let scene = ok("WorldBegin\nPolygon \"P\" [0 0 0 1 0 0 2 0 0]\n");
        assert!(scene.objects.is_empty());
        assert_eq!(
            scene.warnings,
            vec![
                "t.rib:2: Polygon: face 0 is degenerate (fewer than 3 distinct vertices or no area), skipped"
                    .to_string()
            ]
        );
        let scene = ok("WorldBegin\nPointsPolygons [3 3] [0 0 1 0 1 2] \"P\" [0 0 0 1 0 0 0 1 0]\n");
        assert_eq!(mesh(&scene.objects[0]).triangles, vec![[0, 1, 2]]);
        assert_eq!(scene.warnings.len(), 1);
        assert!(scene.warnings[0].contains("face 0 is degenerate"));
    }

    #[test]
    fn subdivision_mesh_reads_crease_and_boundary_tags() {
        let scene = ok(
            "WorldBegin\nSubdivisionMesh \"catmull-clark\" [4 4] [0 1 4 3 1 2 5 4] \
             [\"crease\" \"interpolateboundary\" \"corner\"] [3 1 0 0 1 1] [0 1 2 0] [2.5 10] \
             \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 1 0 2 1 0]\n",
        );
        let Shape::Subdiv(s) = &scene.objects[0].shape else {
            panic!("not a subdivision mesh")
        };
        assert_eq!(s.positions.len(), 6);
        assert_eq!(s.face_counts, vec![4, 4]);
        assert_eq!(s.face_indices, vec![0, 1, 4, 3, 1, 2, 5, 4]);
        assert_eq!(s.creases, vec![(0, 1, 2.5), (1, 2, 2.5)]);
        assert!(s.interpolate_boundary);
        assert_eq!(
            scene.warnings,
            vec!["t.rib:2: SubdivisionMesh: tag \"corner\" is not supported, ignored".to_string()]
        );
        // Without tags.
        let o = only_object("SubdivisionMesh \"catmull-clark\" [3] [0 1 2] \"P\" [0 0 0 1 0 0 0 1 0]");
        let Shape::Subdiv(s) = &o.shape else {
            panic!("not a subdivision mesh")
        };
        assert!(s.creases.is_empty() && !s.interpolate_boundary);
    }

    #[test]
    fn subdivision_mesh_errors_name_scheme_and_indices() {
        assert_eq!(
            fail("WorldBegin\nSubdivisionMesh \"loop\" [3] [0 1 2] \"P\" [0 0 0 1 0 0 0 1 0]"),
            "t.rib:2: SubdivisionMesh: scheme \"loop\" is not supported; expected \"catmull-clark\""
        );
        assert_eq!(
            fail(
                "WorldBegin\nSubdivisionMesh \"catmull-clark\" [3] [0 1 2] [\"crease\"] [2 1] [0 7] [1] \
                  \"P\" [0 0 0 1 0 0 0 1 0]"
            ),
            "t.rib:2: SubdivisionMesh: vertex index 7 is out of range (\"P\" has 3 points)"
        );
    }

    // --- materials, lights, attributes ---------------------------------------------------------------

    #[test]
    fn bxdfs_become_materials() {
        let scene = ok("WorldBegin\n\
             Bxdf \"PxrDiffuse\" \"a\" \"color diffuseColor\" [0.1 0.2 0.3]\n\
             Bxdf \"PxrDiffuse\" \"b\"\n\
             Bxdf \"PxrConstant\" \"c\"\n\
             Bxdf \"PxrConstant\" \"d\" \"color emitColor\" [4 5 6]\n\
             Bxdf \"PxrSurface\" \"e\" \"color diffuseColor\" [0.5 0.5 1] \"float diffuseGain\" [0.5] \
                  \"color specularFaceColor\" [0.04 0.04 0.04] \"float specularRoughness\" [0.3]\n\
             Bxdf \"PxrSurface\" \"f\"\n");
        let m = &scene.materials;
        assert_eq!(m.len(), 7);
        assert_eq!(
            m[1],
            Material::Diffuse {
                color: Rgb::new(0.1, 0.2, 0.3)
            }
        );
        assert_eq!(
            m[2],
            Material::Diffuse {
                color: Rgb::new(0.18, 0.18, 0.18)
            }
        );
        assert_eq!(m[3], Material::Constant { color: Rgb::WHITE });
        assert_eq!(
            m[4],
            Material::Constant {
                color: Rgb::new(4.0, 5.0, 6.0)
            }
        );
        assert_eq!(
            m[5],
            Material::Surface {
                diffuse: Rgb::new(0.25, 0.25, 0.5),
                specular: Rgb::new(0.04, 0.04, 0.04),
                roughness: 0.3
            }
        );
        assert_eq!(
            m[6],
            Material::Surface {
                diffuse: Rgb::new(0.18, 0.18, 0.18),
                specular: Rgb::BLACK,
                roughness: 0.2
            }
        );
    }

    #[test]
    fn unknown_bxdf_warns_and_falls_back_to_the_default_material() {
        let scene =
            ok("WorldBegin\nBxdf \"PxrDiffuse\" \"a\"\nBxdf \"PxrDisney\" \"b\"\nSphere 1 -1 1 360\n");
        assert_eq!(scene.objects[0].material, 0);
        assert_eq!(scene.warnings.len(), 1);
        assert!(scene.warnings[0].starts_with("t.rib:3: Bxdf: unknown Bxdf \"PxrDisney\""));
    }

    #[test]
    fn lights_are_read_with_defaults_and_transforms() {
        let scene = ok("WorldBegin\n\
             Light \"PxrDomeLight\" \"dome\" \"color lightColor\" [1 0.5 0.25] \"float intensity\" [2] \
                   \"float exposure\" [1] \"string lightColorMap\" [\"sky.exr\"]\n\
             Light \"PxrDistantLight\" \"sun\" \"float angleExtent\" [2]\n\
             Translate 0 3 0\n\
             Light \"PxrRectLight\" \"rect\"\n\
             LightSource \"PxrSphereLight\" 1 \"intensity\" 5\n\
             AreaLightSource \"PxrDistantLight\" \"old\"\n\
             Light \"PxrSpotLight\" \"spot\"\n");
        let l = &scene.lights;
        assert_eq!(l.len(), 5);
        assert_eq!(
            l[0],
            Light::Dome {
                color: Rgb::new(1.0, 0.5, 0.25),
                intensity: 2.0,
                exposure: 1.0,
                map: Some(PathBuf::from("/base/sky.exr")),
                transform: Mat4::IDENTITY
            }
        );
        assert_eq!(
            l[1],
            Light::Distant {
                color: Rgb::WHITE,
                intensity: 1.0,
                exposure: 0.0,
                angle_extent: 2.0,
                transform: Mat4::IDENTITY
            }
        );
        let up = Mat4::from_translation(Vec3::new(0.0, 3.0, 0.0));
        assert_eq!(
            l[2],
            Light::Rect {
                color: Rgb::WHITE,
                intensity: 1.0,
                exposure: 0.0,
                transform: up
            }
        );
        assert_eq!(
            l[3],
            Light::Sphere {
                color: Rgb::WHITE,
                intensity: 5.0,
                exposure: 0.0,
                transform: up
            }
        );
        assert!(matches!(
            l[4],
            Light::Distant {
                angle_extent: 0.53,
                ..
            }
        ));
        assert_eq!(scene.warnings.len(), 1);
        assert!(scene.warnings[0].starts_with("t.rib:8: Light: unknown light \"PxrSpotLight\""));
    }

    #[test]
    fn dice_attribute_sets_micropolygon_length_and_others_warn_once() {
        let scene = ok("WorldBegin\nAttribute \"identifier\" \"string name\" \"a\"\n\
             Attribute \"identifier\" \"string name\" \"b\"\n\
             Attribute \"dice\" \"micropolygonlength\" [3]\nSphere 1 -1 1 360\n");
        assert_eq!(scene.objects[0].micropolygon_length, 3.0);
        assert_eq!(
            scene.warnings,
            vec!["t.rib:2: Attribute \"identifier\" is not supported, ignored".to_string()]
        );
        assert_eq!(
            fail("WorldBegin\nAttribute \"dice\" \"float micropolygonlength\" [0]"),
            "t.rib:2: Attribute \"dice\": micropolygonlength must be greater than 0, got 0"
        );
    }

    // --- unknowns and structure ----------------------------------------------------------------------

    #[test]
    fn unknown_request_warns_once_and_reading_continues() {
        let scene = ok("Format 64 48 1\nFrobnicate 1 2 \"x\" [3 4]\n  \"more\" 5\nShutter 0 1\n");
        assert_eq!(
            scene.warnings,
            vec!["t.rib:2: unknown request Frobnicate, skipped".to_string()]
        );
        assert_eq!(scene.camera.format, Format::new(64, 48));
        assert_eq!(scene.camera.shutter, (0.0, 1.0));
    }

    #[test]
    fn unknown_parameter_of_a_known_request_is_warned() {
        let scene = ok("Hider \"raytrace\" \"int maxsamples\" [8] \"float bogus\" [1]");
        assert_eq!(scene.samples_per_pixel, 8);
        assert_eq!(
            scene.warnings,
            vec!["t.rib:1: Hider: unknown parameter \"bogus\", ignored".to_string()]
        );
        assert_eq!(
            fail("Hider \"raytrace\" \"int maxsamples\""),
            "t.rib:1: Hider: parameter \"int maxsamples\" has no value"
        );
        assert_eq!(
            fail("Hider \"raytrace\" 3 4"),
            "t.rib:1: Hider: expected a parameter name (a string), got the number 3"
        );
    }

    #[test]
    fn declare_lets_bare_names_be_used() {
        let scene = ok("Declare \"squeeze\" \"uniform float\"\nProjection \"PxrAnamorphic\" \"squeeze\" [2]");
        let e = scene.projection_params.get("squeeze").unwrap();
        assert_eq!(
            (e.ty, &e.value),
            (ParamType::Float, &ParamValue::Floats(vec![2.0]))
        );
        assert!(scene.warnings.is_empty());
        assert!(
            fail("Declare \"x\" \"flaot\"").starts_with("t.rib:1: Declare: unknown parameter type \"flaot\"")
        );
    }

    #[test]
    fn structural_requests_are_accepted_silently() {
        let scene = ok("version 3.04\nFrameBegin 1\nWorldBegin\nWorldEnd\nFrameEnd\n");
        assert!(scene.warnings.is_empty());
        assert_eq!(
            fail("WorldBegin\nWorldBegin"),
            "t.rib:2: WorldBegin: the world block was already begun at t.rib:1"
        );
    }

    #[test]
    fn a_file_without_world_begin_still_gets_its_camera_transform() {
        let scene = ok("Translate 0 0 2");
        assert!(close(
            camera_point(&scene, 0, Vec3::ZERO),
            Vec3::new(0.0, 0.0, 2.0)
        ));
    }

    #[test]
    fn full_example_scene_using_every_request_parses() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("props.rib"),
            "# an archive\nCylinder 0.5 0 1 360\n",
        )
        .unwrap();
        let text = r#"version 3.04
# Obscura's every-request scene
Declare "squeeze" "float"
Option "searchpath" "string archive" ["."]
FrameBegin 1
  Format 320 240 1
  ScreenWindow -1.333 1.333 -1 1
  CropWindow 0 1 0 1
  Shutter 0 0.5
  Clipping 0.1 1e30
  PixelFilter "gaussian" 2 2
  Hider "raytrace" "int maxsamples" [32] "int minsamples" [8] "int incremental" [1]
  Display "beauty.exr" "openexr" "rgba" "string type" "half"
  Display "+aovs.exr" "openexr" "Ci,a,z,N,P,cameraDirection"
  Projection "PxrPerspective" "float fov" [40] "float fStop" [2.8] "float focalDistance" [5] "squeeze" [1]
  Camera "main" "int apertureNSides" [5] "float apertureAngle" [10] "float apertureRoundness" [0.2]
         "float apertureDensity" [0] "float dofaspect" [1] "float shutterOpenTime" [0]
         "float shutterCloseTime" [1] "float[8] shutteropening" [0 0 0 0 1 1 1 1]
  Identity
  MotionBegin [0 0.5]
    Translate 0 0 10
    Translate 0.1 0 10
  MotionEnd
  Rotate 5 1 0 0
  Scale 1 1 1
  ConcatTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]
  WorldBegin
    Light "PxrDomeLight" "dome" "float intensity" [0.5] "string lightColorMap" ["sky.exr"]
    LightSource "PxrDistantLight" "sun" "float angleExtent" [1]
    AttributeBegin
      Translate 0 4 0
      AreaLightSource "PxrRectLight" "key" "float exposure" [2]
      Light "PxrSphereLight" "fill"
    AttributeEnd
    AttributeBegin
      Attribute "dice" "float micropolygonlength" [2]
      Bxdf "PxrSurface" "metal" "color specularFaceColor" [0.9 0.9 0.9]
      TransformBegin
        Transform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]
        MotionBegin [0 0.5]
          Translate 0 0 0
          Translate 1 0 0
        MotionEnd
        Sphere 1 -1 1 360
      TransformEnd
      Cone 1 1 360
      Disk 0 1 360
      Torus 1 0.2 0 360 360
    AttributeEnd
    Bxdf "PxrDiffuse" "floor" "color diffuseColor" [0.5 0.5 0.5]
    Polygon "P" [-5 0 -5 5 0 -5 5 0 5 -5 0 5]
    PointsPolygons [3] [0 1 2] "P" [0 0 0 1 0 0 0 1 0]
    PointsGeneralPolygons [2] [4 3] [0 1 2 3 4 5 6] "P" [0 0 0 4 0 0 4 4 0 0 4 0 1 1 0 2 1 0 1 2 0]
    Bxdf "PxrConstant" "glow"
    SubdivisionMesh "catmull-clark" [4] [0 1 2 3] ["interpolateboundary"] [0 0] [] [] "P" [0 0 0 1 0 0 1 1 0 0 1 0]
    ReadArchive "props.rib"
  WorldEnd
FrameEnd
"#;
        let scene = parse_str(text, "every.rib", dir.path()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            scene.warnings,
            vec!["every.rib:4: Option \"searchpath\" is not supported, ignored".to_string()]
        );
        assert_eq!(scene.camera.format, Format::new(320, 240));
        assert_eq!(scene.camera.world_to_camera.len(), 2);
        assert_eq!(scene.samples_per_pixel, 32);
        assert_eq!(scene.displays.len(), 2);
        assert_eq!(scene.projection_params.entries().len(), 4);
        assert_eq!(scene.camera.aperture.n_sides, 5);
        assert_eq!(scene.lights.len(), 4);
        assert_eq!(scene.materials.len(), 4);
        let kinds: Vec<&str> = scene
            .objects
            .iter()
            .map(|o| match o.shape {
                Shape::Sphere { .. } => "sphere",
                Shape::Cylinder { .. } => "cylinder",
                Shape::Cone { .. } => "cone",
                Shape::Disk { .. } => "disk",
                Shape::Torus { .. } => "torus",
                Shape::Mesh(_) => "mesh",
                Shape::Subdiv(_) => "subdiv",
            })
            .collect();
        assert_eq!(
            kinds,
            [
                "sphere", "cone", "disk", "torus", "mesh", "mesh", "mesh", "subdiv", "cylinder"
            ]
        );
        let sphere = &scene.objects[0];
        assert!(sphere.transform.is_moving());
        assert_eq!((sphere.material, sphere.micropolygon_length), (1, 2.0));
        assert!(!scene.objects[1].transform.is_moving());
        assert_eq!(scene.objects[4].material, 2);
        let holed = mesh(&scene.objects[6]);
        let area: f32 = holed.triangles.iter().map(|&t| tri_area(holed, t)).sum();
        assert!((area - 15.5).abs() < 1e-4, "{area}");
        assert_eq!(
            scene.objects[8].source,
            format!("{}:2", dir.path().join("props.rib").display())
        );
    }

    /// A polygon star-shaped about the origin: simple whatever the radii, concave for most.
    fn star_polygon(radii: &[f32], scale: f32) -> Vec<(f32, f32)> {
        let n = radii.len() as f32;
        radii
            .iter()
            .enumerate()
            .map(|(k, r)| {
                let a = k as f32 * std::f32::consts::TAU / n;
                (scale * r * a.cos(), scale * r * a.sin())
            })
            .collect()
    }

    proptest! {
        // No regression files: this module's tests write nothing outside the temporary directory.
        #![proptest_config(ProptestConfig { failure_persistence: None, ..ProptestConfig::default() })]

        #[test]
        fn star_shaped_polygons_triangulate_to_their_area(
            radii in prop::collection::vec(0.3f32..2.0, 3..40),
            hole in prop::collection::vec(0.5f32..1.0, 3..12),
            with_hole: bool,
        ) {
            let outline = star_polygon(&radii, 1.0);
            // With at least 6 vertices at radius >= 0.3 the outline holds the disk of radius
            // 0.3·cos(30°) = 0.26, and the hole stays within radius 0.2.
            let with_hole = with_hole && radii.len() >= 6;
            let hole = star_polygon(&hole, 0.2);
            let text = if with_hole {
                let all: Vec<(f32, f32)> = outline.iter().chain(&hole).copied().collect();
                let verts: Vec<String> = (0..all.len()).map(|i| i.to_string()).collect();
                format!(
                    "PointsGeneralPolygons [2] [{} {}] [{}] \"P\" [{}]",
                    outline.len(),
                    hole.len(),
                    verts.join(" "),
                    rib_points(&all)
                )
            } else {
                format!("Polygon \"P\" [{}]", rib_points(&outline))
            };
            let o = only_object(&text);
            let holes: Vec<&[(f32, f32)]> = if with_hole { vec![&hole] } else { vec![] };
            check_triangulation(mesh(&o), &outline, &holes);
        }

        #[test]
        fn lexer_never_panics(text in ".*") {
            let _ = lex(&text);
        }

        #[test]
        fn reader_never_panics_on_printable_text(text in "[ -~\n]{0,300}") {
            let _ = parse_str(&text, "p.rib", Path::new("/nonexistent-obscura-dir"));
        }

        #[test]
        fn reader_never_panics_on_rib_like_text(words in prop::collection::vec(prop::sample::select(vec![
            "WorldBegin", "WorldEnd", "AttributeBegin", "AttributeEnd", "TransformBegin", "TransformEnd",
            "MotionBegin", "MotionEnd", "Translate", "Rotate", "Scale", "Sphere", "Polygon", "PointsPolygons",
            "PointsGeneralPolygons", "SubdivisionMesh", "Display", "Projection", "Camera", "Bxdf", "Light",
            "Format", "\"P\"", "\"N\"", "\"catmull-clark\"", "\"crease\"", "\"float fov\"", "[", "]", "0", "1",
            "-1", "2.5", "3", "1e30", "\"x\"", "\n", "#",
        ]), 0..60)) {
            let _ = parse_str(&words.join(" "), "p.rib", Path::new("/nonexistent-obscura-dir"));
        }
    }
}
