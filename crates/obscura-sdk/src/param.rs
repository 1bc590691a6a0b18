//! Parameters: what a projection declares, what a scene gives, and typed lookup.
//!
//! A projection declares each parameter it takes with a [`ParamDecl`] (RenderMan's `RixSCParamInfo`
//! plus what RenderMan keeps in the `.args` file: default, range, a one-line doc). A scene hands values
//! over in a [`ParamList`], written as RIB writes them (`"float fov" [45]`). [`Params::resolve`] checks
//! the list against the table (unknown names with a did-you-mean, wrong types, wrong array lengths,
//! values out of range) and fills in defaults, so a projection's `create` reads plain typed values.

use std::borrow::Cow;
use std::fmt;

use crate::geometry::{Matrix4, Rgb, Vec3};

/// The type of a parameter (RenderMan's `RixSCType` subset that parameters use).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ParamType {
    /// One `f32`.
    Float,
    /// One `i32`.
    Int,
    /// One string.
    String,
    /// Three floats, linear RGB.
    Color,
    /// Three floats, a position.
    Point,
    /// Three floats, a direction.
    Vector,
    /// Three floats, a surface normal.
    Normal,
    /// Sixteen floats, row-major.
    Matrix,
}

impl ParamType {
    /// Every type, in the order RIB documentation lists them.
    pub const ALL: [ParamType; 8] = [
        ParamType::Float,
        ParamType::Int,
        ParamType::String,
        ParamType::Color,
        ParamType::Point,
        ParamType::Vector,
        ParamType::Normal,
        ParamType::Matrix,
    ];

    /// The RIB spelling: `float`, `int`, `string`, `color`, `point`, `vector`, `normal`, `matrix`.
    #[must_use]
    pub fn rib_name(self) -> &'static str {
        match self {
            ParamType::Float => "float",
            ParamType::Int => "int",
            ParamType::String => "string",
            ParamType::Color => "color",
            ParamType::Point => "point",
            ParamType::Vector => "vector",
            ParamType::Normal => "normal",
            ParamType::Matrix => "matrix",
        }
    }

    /// Parses a RIB type name (`integer` is accepted for `int`).
    #[must_use]
    pub fn from_rib_name(s: &str) -> Option<ParamType> {
        match s {
            "integer" => Some(ParamType::Int),
            _ => ParamType::ALL.into_iter().find(|t| t.rib_name() == s),
        }
    }

    /// How many scalars make one element: 1, 3 for colours and points, 16 for matrices.
    #[must_use]
    pub fn components(self) -> usize {
        match self {
            ParamType::Float | ParamType::Int | ParamType::String => 1,
            ParamType::Color | ParamType::Point | ParamType::Vector | ParamType::Normal => 3,
            ParamType::Matrix => 16,
        }
    }

    fn storage(self) -> Storage {
        match self {
            ParamType::Int => Storage::Int,
            ParamType::String => Storage::String,
            _ => Storage::Float,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Storage {
    Float,
    Int,
    String,
}

impl fmt::Display for ParamType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.rib_name())
    }
}

/// A parameter's values, flattened: a `color[2]` is six floats.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    /// Values of a float, colour, point, vector, normal or matrix parameter.
    Floats(Vec<f32>),
    /// Values of an int parameter.
    Ints(Vec<i32>),
    /// Values of a string parameter.
    Strings(Vec<String>),
}

impl ParamValue {
    /// The number of scalars held.
    #[must_use]
    pub fn len(&self) -> usize {
        match self {
            ParamValue::Floats(v) => v.len(),
            ParamValue::Ints(v) => v.len(),
            ParamValue::Strings(v) => v.len(),
        }
    }

    /// True when no scalar is held.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn storage(&self) -> Storage {
        match self {
            ParamValue::Floats(_) => Storage::Float,
            ParamValue::Ints(_) => Storage::Int,
            ParamValue::Strings(_) => Storage::String,
        }
    }
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("[")?;
        match self {
            ParamValue::Floats(v) => {
                for (i, x) in v.iter().enumerate() {
                    write!(f, "{}{}", if i > 0 { " " } else { "" }, fmt_float(*x))?;
                }
            }
            ParamValue::Ints(v) => {
                for (i, x) in v.iter().enumerate() {
                    write!(f, "{}{x}", if i > 0 { " " } else { "" })?;
                }
            }
            ParamValue::Strings(v) => {
                for (i, x) in v.iter().enumerate() {
                    write!(f, "{}\"{x}\"", if i > 0 { " " } else { "" })?;
                }
            }
        }
        f.write_str("]")
    }
}

fn fmt_float(x: f32) -> String {
    if x.is_infinite() {
        if x > 0.0 { "inf".into() } else { "-inf".into() }
    } else if x != 0.0 && !(1e-4..1e16).contains(&x.abs()) {
        // 1e-38, not 0.00000000000000000000000000000000000001.
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// The numeric range a parameter's values must lie in; each end open or closed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValueRange {
    /// Lower bound (may be `-inf`).
    pub min: f64,
    /// Upper bound (may be `inf`).
    pub max: f64,
    /// True when `min` itself is allowed.
    pub min_inclusive: bool,
    /// True when `max` itself is allowed.
    pub max_inclusive: bool,
}

impl ValueRange {
    /// `[min, max]`.
    #[must_use]
    pub const fn closed(min: f64, max: f64) -> Self {
        ValueRange {
            min,
            max,
            min_inclusive: true,
            max_inclusive: true,
        }
    }
    /// `(min, max)`.
    #[must_use]
    pub const fn open(min: f64, max: f64) -> Self {
        ValueRange {
            min,
            max,
            min_inclusive: false,
            max_inclusive: false,
        }
    }
    /// `[min, ∞]`: non-negative when `min` is 0; infinity itself allowed (an f-stop of ∞).
    #[must_use]
    pub const fn at_least(min: f64) -> Self {
        ValueRange {
            min,
            max: f64::INFINITY,
            min_inclusive: true,
            max_inclusive: true,
        }
    }
    /// `(min, ∞)`: strictly greater than `min`, finite.
    #[must_use]
    pub const fn greater_than(min: f64) -> Self {
        ValueRange {
            min,
            max: f64::INFINITY,
            min_inclusive: false,
            max_inclusive: false,
        }
    }

    /// True when `x` lies in the range (NaN never does).
    #[must_use]
    pub fn contains(&self, x: f64) -> bool {
        let lo = if self.min_inclusive {
            x >= self.min
        } else {
            x > self.min
        };
        let hi = if self.max_inclusive {
            x <= self.max
        } else {
            x < self.max
        };
        lo && hi
    }
}

impl fmt::Display for ValueRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let end = |x: f64| {
            if x.is_infinite() {
                if x > 0.0 {
                    "∞".to_string()
                } else {
                    "−∞".to_string()
                }
            } else {
                format!("{x}")
            }
        };
        write!(
            f,
            "{}{}, {}{}",
            if self.min_inclusive { '[' } else { '(' },
            end(self.min),
            end(self.max),
            if self.max_inclusive { ']' } else { ')' }
        )
    }
}

/// One parameter a projection takes: the row of its parameter table.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamDecl {
    /// The name as a scene spells it (`fStop`, RenderMan's spelling).
    pub name: Cow<'static, str>,
    /// The element type.
    pub ty: ParamType,
    /// `None` for a single value (or a variable-length list, see `variable_len`), `Some(n)` for a
    /// fixed-length array of `n` elements.
    pub array_len: Option<usize>,
    /// True for a list of any length ≥ 1 (`float[] params`): calibration coefficients, polynomials.
    pub variable_len: bool,
    /// The value used when the scene gives none.
    pub default: ParamValue,
    /// Allowed range of every numeric scalar, if limited.
    pub range: Option<ValueRange>,
    /// Allowed strings, if limited.
    pub choices: Vec<Cow<'static, str>>,
    /// One line of documentation for `obscura plugins`.
    pub doc: Cow<'static, str>,
}

impl ParamDecl {
    fn new(name: &'static str, ty: ParamType, default: ParamValue) -> Self {
        ParamDecl {
            name: Cow::Borrowed(name),
            ty,
            array_len: None,
            variable_len: false,
            default,
            range: None,
            choices: Vec::new(),
            doc: Cow::Borrowed(""),
        }
    }

    /// A `float` parameter.
    #[must_use]
    pub fn float(name: &'static str, default: f32) -> Self {
        Self::new(name, ParamType::Float, ParamValue::Floats(vec![default]))
    }
    /// An `int` parameter.
    #[must_use]
    pub fn int(name: &'static str, default: i32) -> Self {
        Self::new(name, ParamType::Int, ParamValue::Ints(vec![default]))
    }
    /// A `string` parameter.
    #[must_use]
    pub fn string(name: &'static str, default: &str) -> Self {
        Self::new(
            name,
            ParamType::String,
            ParamValue::Strings(vec![default.to_string()]),
        )
    }
    /// A `color` parameter.
    #[must_use]
    pub fn color(name: &'static str, default: Rgb) -> Self {
        Self::new(
            name,
            ParamType::Color,
            ParamValue::Floats(vec![default.r, default.g, default.b]),
        )
    }
    /// A `point`, `vector` or `normal` parameter.
    ///
    /// # Panics
    /// When `ty` is not one of those three (a programming error in the plugin's table).
    #[must_use]
    pub fn triple(name: &'static str, ty: ParamType, default: Vec3) -> Self {
        assert!(
            matches!(ty, ParamType::Point | ParamType::Vector | ParamType::Normal),
            "ParamDecl::triple takes point, vector or normal"
        );
        Self::new(
            name,
            ty,
            ParamValue::Floats(vec![default.x, default.y, default.z]),
        )
    }
    /// A `matrix` parameter.
    #[must_use]
    pub fn matrix(name: &'static str, default: Matrix4) -> Self {
        Self::new(name, ParamType::Matrix, ParamValue::Floats(default.0.concat()))
    }
    /// A fixed-length `float[n]` parameter.
    #[must_use]
    pub fn float_array(name: &'static str, default: &[f32]) -> Self {
        let mut d = Self::new(name, ParamType::Float, ParamValue::Floats(default.to_vec()));
        d.array_len = Some(default.len());
        d
    }
    /// A `float[]` parameter: a list of any length ≥ 1 (the default may be empty).
    #[must_use]
    pub fn float_list(name: &'static str, default: &[f32]) -> Self {
        let mut d = Self::new(name, ParamType::Float, ParamValue::Floats(default.to_vec()));
        d.variable_len = true;
        d
    }
    /// A fixed-length `int[n]` parameter.
    #[must_use]
    pub fn int_array(name: &'static str, default: &[i32]) -> Self {
        let mut d = Self::new(name, ParamType::Int, ParamValue::Ints(default.to_vec()));
        d.array_len = Some(default.len());
        d
    }
    /// Limits every numeric value to `range`.
    #[must_use]
    pub fn range(mut self, range: ValueRange) -> Self {
        self.range = Some(range);
        self
    }
    /// Limits a string parameter to these values.
    #[must_use]
    pub fn choices(mut self, choices: &[&'static str]) -> Self {
        self.choices = choices.iter().map(|c| Cow::Borrowed(*c)).collect();
        self
    }
    /// Sets the one-line documentation.
    #[must_use]
    pub fn doc(mut self, doc: &'static str) -> Self {
        self.doc = Cow::Borrowed(doc);
        self
    }

    /// The RIB declaration: `float fov`, `float[5] polynomial`.
    #[must_use]
    pub fn rib_declaration(&self) -> String {
        if self.variable_len {
            return format!("{}[] {}", self.ty, self.name);
        }
        match self.array_len {
            None => format!("{} {}", self.ty, self.name),
            Some(n) => format!("{}[{n}] {}", self.ty, self.name),
        }
    }

    /// The number of scalars a value of this parameter holds.
    #[must_use]
    pub fn scalar_count(&self) -> usize {
        if self.variable_len {
            return self.default.len();
        }
        self.array_len.unwrap_or(1) * self.ty.components()
    }
}

/// One parameter as a scene gave it.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamEntry {
    /// The name.
    pub name: String,
    /// The declared type.
    pub ty: ParamType,
    /// The declared array length (`float[5] x`), if one was written.
    pub array_len: Option<usize>,
    /// The values, flattened.
    pub value: ParamValue,
    /// Where it came from (`scene.rib:12`, `--param`), for error messages.
    pub origin: Option<String>,
}

/// The parameters a scene gives one projection (`RixParameterList`): typed, in the order given.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParamList {
    entries: Vec<ParamEntry>,
}

/// A parameter's declaration string could not be read (`"flaot fov"`, `"float[x] a"`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DeclarationError {
    /// The string is not `type name` or `type[n] name`.
    #[error(
        "cannot read parameter declaration \"{0}\": expected \"type name\" or \"type[n] name\", e.g. \"float fov\""
    )]
    Malformed(String),
    /// The type is not one of the eight.
    #[error(
        "unknown parameter type \"{ty}\" in \"{decl}\": expected one of float, int, string, color, point, vector, normal, matrix"
    )]
    UnknownType {
        /// The declaration string.
        decl: String,
        /// The unrecognised type.
        ty: String,
    },
    /// The values do not fill the declared type and length.
    #[error("\"{decl}\" needs {expected} value(s), got {got}")]
    Count {
        /// The declaration string.
        decl: String,
        /// Scalars the declaration implies.
        expected: usize,
        /// Scalars given.
        got: usize,
    },
    /// The values are of another kind than the type (strings for a float, …).
    #[error("\"{decl}\" takes {expected} values, got {got}")]
    Kind {
        /// The declaration string.
        decl: String,
        /// What the type needs.
        expected: &'static str,
        /// What was given.
        got: &'static str,
    },
    /// A value could not be parsed.
    #[error("\"{decl}\": cannot read \"{value}\" as {ty}")]
    Value {
        /// The declaration string.
        decl: String,
        /// The offending text.
        value: String,
        /// The type it should have been.
        ty: ParamType,
    },
}

fn kind_name(s: Storage) -> &'static str {
    match s {
        Storage::Float => "number",
        Storage::Int => "integer",
        Storage::String => "string",
    }
}

/// Splits a RIB declaration (`float fov`, `float[5] k`, `uniform float fov`) into type, length, name.
///
/// # Errors
/// A [`DeclarationError`] naming the declaration when it cannot be read.
pub fn parse_declaration(decl: &str) -> Result<(ParamType, Option<usize>, String), DeclarationError> {
    let words: Vec<&str> = decl
        .split_whitespace()
        .filter(|w| !matches!(*w, "uniform" | "constant"))
        .collect();
    let [ty_word, name] = words[..] else {
        return Err(DeclarationError::Malformed(decl.to_string()));
    };
    let (ty_name, len) = match ty_word.split_once('[') {
        None => (ty_word, None),
        // `float[] k`: the length is taken from the values.
        Some((t, "]")) => (t, None),
        Some((t, rest)) => {
            let n = rest
                .strip_suffix(']')
                .and_then(|n| n.trim().parse::<usize>().ok())
                .filter(|&n| n > 0)
                .ok_or_else(|| DeclarationError::Malformed(decl.to_string()))?;
            (t, Some(n))
        }
    };
    let ty = ParamType::from_rib_name(ty_name).ok_or_else(|| DeclarationError::UnknownType {
        decl: decl.to_string(),
        ty: ty_name.to_string(),
    })?;
    Ok((ty, len, name.to_string()))
}

impl ParamList {
    /// An empty list.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one parameter as RIB writes it: a declaration (`"float fov"`) and its values.
    ///
    /// Ints are accepted where floats are declared (RIB writes `[45]` for `45.0`); the count of values
    /// must fill the declaration (`float[5]` needs five, `color` three).
    ///
    /// # Errors
    /// A [`DeclarationError`] naming the declaration.
    pub fn push(
        &mut self,
        decl: &str,
        value: ParamValue,
        origin: Option<String>,
    ) -> Result<&mut Self, DeclarationError> {
        let (ty, array_len, name) = parse_declaration(decl)?;
        let value = match (ty.storage(), value) {
            (Storage::Float, ParamValue::Ints(v)) => {
                ParamValue::Floats(v.into_iter().map(|i| i as f32).collect())
            }
            (_, v) => v,
        };
        if value.storage() != ty.storage() {
            return Err(DeclarationError::Kind {
                decl: decl.to_string(),
                expected: kind_name(ty.storage()),
                got: kind_name(value.storage()),
            });
        }
        let comps = ty.components();
        let expected = array_len.map(|n| n * comps);
        let got = value.len();
        let ok = match expected {
            Some(e) => got == e,
            None => got > 0 && got % comps == 0,
        };
        if !ok {
            return Err(DeclarationError::Count {
                decl: decl.to_string(),
                expected: expected.unwrap_or(comps),
                got,
            });
        }
        // An undeclared length is taken from the values: "float k" [1 2 3] is a float[3].
        let array_len = array_len.or(if got == comps { None } else { Some(got / comps) });
        self.entries.push(ParamEntry {
            name,
            ty,
            array_len,
            value,
            origin,
        });
        Ok(self)
    }

    /// Adds one parameter from text values (the CLI's `--param "float fov=60"`, a RIB token list).
    ///
    /// # Errors
    /// A [`DeclarationError`] naming the declaration and the value that could not be read.
    pub fn push_text(
        &mut self,
        decl: &str,
        values: &[&str],
        origin: Option<String>,
    ) -> Result<&mut Self, DeclarationError> {
        let (ty, _, _) = parse_declaration(decl)?;
        let bad = |v: &str| DeclarationError::Value {
            decl: decl.to_string(),
            value: v.to_string(),
            ty,
        };
        let value = match ty.storage() {
            Storage::String => ParamValue::Strings(values.iter().map(|s| s.to_string()).collect()),
            Storage::Int => ParamValue::Ints(
                values
                    .iter()
                    .map(|v| v.parse::<i32>().map_err(|_| bad(v)))
                    .collect::<Result<_, _>>()?,
            ),
            Storage::Float => ParamValue::Floats(
                values
                    .iter()
                    .map(|v| parse_float(v).ok_or_else(|| bad(v)))
                    .collect::<Result<_, _>>()?,
            ),
        };
        self.push(decl, value, origin)
    }

    /// Removes every entry named `name` (so that a later value, e.g. from the command line, replaces
    /// the scene's instead of being reported as given twice). Returns how many were removed.
    pub fn remove(&mut self, name: &str) -> usize {
        let before = self.entries.len();
        self.entries.retain(|e| e.name != name);
        before - self.entries.len()
    }

    /// The entries in the order given.
    #[must_use]
    pub fn entries(&self) -> &[ParamEntry] {
        &self.entries
    }

    /// The entry named `name` (the last one, if given twice).
    #[must_use]
    pub fn get(&self, name: &str) -> Option<&ParamEntry> {
        self.entries.iter().rev().find(|e| e.name == name)
    }

    /// True when nothing was given.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// Reads a float as RIB and the CLI write it; `inf`/`infinity` allowed (an f-stop of ∞).
#[must_use]
fn parse_float(s: &str) -> Option<f32> {
    let t = s.trim();
    match t.to_ascii_lowercase().as_str() {
        "inf" | "+inf" | "infinity" | "+infinity" => Some(f32::INFINITY),
        "-inf" | "-infinity" => Some(f32::NEG_INFINITY),
        _ => t.parse::<f32>().ok().filter(|x| x.is_finite()),
    }
}

/// A parameter the scene gave does not fit the plugin's table, or a plugin asked for one it lacks.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    /// The name is not in the table.
    #[error("{plugin}: unknown parameter \"{name}\"{at}{hint}; {plugin} takes: {known}",
        at = at(origin), hint = suggestion.as_ref().map(|s| format!(" (did you mean \"{s}\"?)")).unwrap_or_default())]
    Unknown {
        /// The projection.
        plugin: String,
        /// The name given.
        name: String,
        /// The closest declared name, if one is close.
        suggestion: Option<String>,
        /// Every declared name, comma-separated.
        known: String,
        /// Where it was given.
        origin: Option<String>,
    },
    /// The declared type differs from the table's.
    #[error("{plugin}: parameter \"{name}\"{at} is declared {expected} by {plugin}, but was given as {got}",
        at = at(origin))]
    WrongType {
        /// The projection.
        plugin: String,
        /// The parameter.
        name: String,
        /// The table's declaration, e.g. `float fov`.
        expected: String,
        /// The scene's declaration.
        got: String,
        /// Where it was given.
        origin: Option<String>,
    },
    /// The array length differs from the table's.
    #[error("{plugin}: parameter \"{name}\"{at} takes {expected} element(s) ({decl}), got {got}", at = at(origin))]
    WrongLength {
        /// The projection.
        plugin: String,
        /// The parameter.
        name: String,
        /// The table's declaration.
        decl: String,
        /// Elements expected.
        expected: usize,
        /// Elements given.
        got: usize,
        /// Where it was given.
        origin: Option<String>,
    },
    /// A value is outside the allowed range or set.
    #[error("{plugin}: parameter \"{name}\"{at} = {value} is out of range: expected {expected}", at = at(origin))]
    OutOfRange {
        /// The projection.
        plugin: String,
        /// The parameter.
        name: String,
        /// The offending value.
        value: String,
        /// What was expected (`a value in (0, 180)`, `one of "left", "right"`).
        expected: String,
        /// Where it was given.
        origin: Option<String>,
    },
    /// The same name was given twice.
    #[error("{plugin}: parameter \"{name}\" given twice ({first} and {second})")]
    Duplicate {
        /// The projection.
        plugin: String,
        /// The parameter.
        name: String,
        /// Where it was first given.
        first: String,
        /// Where it was given again.
        second: String,
    },
    /// The plugin itself asked for a parameter its table lacks, or as another type: a plugin bug.
    #[error(
        "{plugin}: internal error: parameter \"{name}\" looked up as {asked}, but the table declares {declared}"
    )]
    Lookup {
        /// The projection.
        plugin: String,
        /// The parameter.
        name: String,
        /// What the plugin asked for.
        asked: String,
        /// What the table says (`nothing` when absent).
        declared: String,
    },
}

fn at(origin: &Option<String>) -> String {
    origin.as_ref().map(|o| format!(" (at {o})")).unwrap_or_default()
}

/// The closest of `candidates` to `name`, when close enough to be a likely typo.
#[must_use]
pub fn did_you_mean<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<String> {
    let lower = name.to_ascii_lowercase();
    let limit = (lower.chars().count() / 3).max(1);
    candidates
        .into_iter()
        .map(|c| (strsim::osa_distance(&lower, &c.to_ascii_lowercase()), c))
        .filter(|(dist, _)| *dist <= limit)
        .min_by_key(|(dist, _)| *dist)
        .map(|(_, c)| c.to_string())
}

/// A projection's parameters, checked against its table, with defaults filled in.
#[derive(Debug, Clone, PartialEq)]
pub struct Params {
    plugin: String,
    decls: Vec<ParamDecl>,
    values: Vec<ParamValue>,
    given: Vec<bool>,
}

impl Params {
    /// Checks `list` against `table` for the projection `plugin` and fills in defaults.
    ///
    /// # Errors
    /// The first problem found, as a [`ParamError`] naming the plugin, the parameter, where it was given
    /// and what was expected.
    pub fn resolve(plugin: &str, table: &[ParamDecl], list: &ParamList) -> Result<Params, ParamError> {
        let mut values: Vec<ParamValue> = table.iter().map(|d| d.default.clone()).collect();
        let mut given_at: Vec<Option<String>> = vec![None; table.len()];
        for entry in list.entries() {
            let origin_text = entry
                .origin
                .clone()
                .unwrap_or_else(|| "the parameter list".into());
            let Some(idx) = table.iter().position(|d| d.name == entry.name) else {
                return Err(ParamError::Unknown {
                    plugin: plugin.to_string(),
                    name: entry.name.clone(),
                    suggestion: did_you_mean(&entry.name, table.iter().map(|d| d.name.as_ref())),
                    known: if table.is_empty() {
                        "no parameters".into()
                    } else {
                        table
                            .iter()
                            .map(|d| d.name.as_ref())
                            .collect::<Vec<_>>()
                            .join(", ")
                    },
                    origin: entry.origin.clone(),
                });
            };
            let decl = &table[idx];
            if let Some(first) = &given_at[idx] {
                return Err(ParamError::Duplicate {
                    plugin: plugin.to_string(),
                    name: entry.name.clone(),
                    first: first.clone(),
                    second: origin_text,
                });
            }
            if entry.ty != decl.ty {
                return Err(ParamError::WrongType {
                    plugin: plugin.to_string(),
                    name: entry.name.clone(),
                    expected: decl.rib_declaration(),
                    got: match entry.array_len {
                        None => format!("{} {}", entry.ty, entry.name),
                        Some(n) => format!("{}[{n}] {}", entry.ty, entry.name),
                    },
                    origin: entry.origin.clone(),
                });
            }
            let got_elems = entry.value.len() / decl.ty.components();
            if decl.variable_len {
                if entry.value.is_empty() || entry.value.len() % decl.ty.components() != 0 {
                    return Err(ParamError::WrongLength {
                        plugin: plugin.to_string(),
                        name: entry.name.clone(),
                        decl: decl.rib_declaration(),
                        expected: 1,
                        got: got_elems,
                        origin: entry.origin.clone(),
                    });
                }
            } else if entry.value.len() != decl.scalar_count() {
                return Err(ParamError::WrongLength {
                    plugin: plugin.to_string(),
                    name: entry.name.clone(),
                    decl: decl.rib_declaration(),
                    expected: decl.array_len.unwrap_or(1),
                    got: got_elems,
                    origin: entry.origin.clone(),
                });
            }
            check_value(plugin, decl, &entry.value, entry.origin.clone())?;
            values[idx] = entry.value.clone();
            given_at[idx] = Some(origin_text);
        }
        Ok(Params {
            plugin: plugin.to_string(),
            decls: table.to_vec(),
            values,
            given: given_at.iter().map(Option::is_some).collect(),
        })
    }

    /// The projection these parameters belong to.
    #[must_use]
    pub fn plugin(&self) -> &str {
        &self.plugin
    }

    /// True when the scene gave `name` (false when it is the default).
    #[must_use]
    pub fn is_given(&self, name: &str) -> bool {
        self.decls
            .iter()
            .position(|d| d.name == name)
            .is_some_and(|i| self.given[i])
    }

    fn lookup(
        &self,
        name: &str,
        ty: &[ParamType],
        len: Option<usize>,
        asked: &str,
    ) -> Result<&ParamValue, ParamError> {
        match self.decls.iter().position(|d| d.name == name) {
            Some(i)
                if ty.contains(&self.decls[i].ty)
                    && !self.decls[i].variable_len
                    && (len.is_none() || self.decls[i].array_len == len) =>
            {
                Ok(&self.values[i])
            }
            found => Err(ParamError::Lookup {
                plugin: self.plugin.clone(),
                name: name.to_string(),
                asked: asked.to_string(),
                declared: found
                    .map(|i| self.decls[i].rib_declaration())
                    .unwrap_or_else(|| "nothing".into()),
            }),
        }
    }

    fn floats_of(
        &self,
        name: &str,
        ty: &[ParamType],
        len: Option<usize>,
        asked: &str,
    ) -> Result<&[f32], ParamError> {
        match self.lookup(name, ty, len, asked)? {
            ParamValue::Floats(v) => Ok(v),
            _ => unreachable!("float-typed declarations hold floats: resolve checked it"),
        }
    }

    /// A `float` parameter.
    ///
    /// # Errors
    /// [`ParamError::Lookup`] when the table has no `float name` (a plugin bug).
    pub fn float(&self, name: &str) -> Result<f32, ParamError> {
        Ok(self.floats_of(name, &[ParamType::Float], None, "float")?[0])
    }

    /// An `int` parameter.
    ///
    /// # Errors
    /// [`ParamError::Lookup`] when the table has no `int name`.
    pub fn int(&self, name: &str) -> Result<i32, ParamError> {
        match self.lookup(name, &[ParamType::Int], None, "int")? {
            ParamValue::Ints(v) => Ok(v[0]),
            _ => unreachable!("int declarations hold ints"),
        }
    }

    /// A `string` parameter.
    ///
    /// # Errors
    /// [`ParamError::Lookup`] when the table has no `string name`.
    pub fn string(&self, name: &str) -> Result<&str, ParamError> {
        match self.lookup(name, &[ParamType::String], None, "string")? {
            ParamValue::Strings(v) => Ok(&v[0]),
            _ => unreachable!("string declarations hold strings"),
        }
    }

    /// A `color` parameter.
    ///
    /// # Errors
    /// [`ParamError::Lookup`] when the table has no `color name`.
    pub fn color(&self, name: &str) -> Result<Rgb, ParamError> {
        let v = self.floats_of(name, &[ParamType::Color], None, "color")?;
        Ok(Rgb::new(v[0], v[1], v[2]))
    }

    /// A `point`, `vector` or `normal` parameter.
    ///
    /// # Errors
    /// [`ParamError::Lookup`] when the table has no such parameter.
    pub fn triple(&self, name: &str) -> Result<Vec3, ParamError> {
        let v = self.floats_of(
            name,
            &[ParamType::Point, ParamType::Vector, ParamType::Normal],
            None,
            "point",
        )?;
        Ok(Vec3::new(v[0], v[1], v[2]))
    }

    /// A `matrix` parameter.
    ///
    /// # Errors
    /// [`ParamError::Lookup`] when the table has no `matrix name`.
    pub fn matrix(&self, name: &str) -> Result<Matrix4, ParamError> {
        let v = self.floats_of(name, &[ParamType::Matrix], None, "matrix")?;
        let mut m = [[0.0; 4]; 4];
        for (i, row) in m.iter_mut().enumerate() {
            row.copy_from_slice(&v[i * 4..i * 4 + 4]);
        }
        Ok(Matrix4(m))
    }

    /// A `float[]` (variable-length) parameter's values: the scene's list, or the default.
    ///
    /// # Errors
    /// [`ParamError::Lookup`] when the table has no `float[] name`.
    pub fn float_list(&self, name: &str) -> Result<&[f32], ParamError> {
        match self.decls.iter().position(|d| d.name == name) {
            Some(i) if self.decls[i].variable_len && self.decls[i].ty == ParamType::Float => {
                match &self.values[i] {
                    ParamValue::Floats(v) => Ok(v),
                    _ => unreachable!("float declarations hold floats"),
                }
            }
            found => Err(ParamError::Lookup {
                plugin: self.plugin.clone(),
                name: name.to_string(),
                asked: "float[]".into(),
                declared: found
                    .map(|i| self.decls[i].rib_declaration())
                    .unwrap_or_else(|| "nothing".into()),
            }),
        }
    }

    /// A `float[n]` parameter's values.
    ///
    /// # Errors
    /// [`ParamError::Lookup`] when the table has no `float[n] name`.
    pub fn floats(&self, name: &str, n: usize) -> Result<&[f32], ParamError> {
        self.floats_of(name, &[ParamType::Float], Some(n), &format!("float[{n}]"))
    }
}

fn check_value(
    plugin: &str,
    decl: &ParamDecl,
    value: &ParamValue,
    origin: Option<String>,
) -> Result<(), ParamError> {
    let out = |v: String, expected: String| ParamError::OutOfRange {
        plugin: plugin.to_string(),
        name: decl.name.to_string(),
        value: v,
        expected,
        origin: origin.clone(),
    };
    match value {
        ParamValue::Floats(v) => {
            for &x in v {
                if x.is_nan() {
                    return Err(out("NaN".into(), "a number".into()));
                }
                if let Some(r) = decl.range
                    && !r.contains(x as f64)
                {
                    return Err(out(fmt_float(x), format!("a value in {r}")));
                }
                if decl.range.is_none() && x.is_infinite() {
                    return Err(out(fmt_float(x), "a finite number".into()));
                }
            }
        }
        ParamValue::Ints(v) => {
            if let Some(r) = decl.range {
                for &x in v {
                    if !r.contains(x as f64) {
                        return Err(out(x.to_string(), format!("a value in {r}")));
                    }
                }
            }
        }
        ParamValue::Strings(v) => {
            if !decl.choices.is_empty() {
                for s in v {
                    if !decl.choices.iter().any(|c| c == s) {
                        let list = decl
                            .choices
                            .iter()
                            .map(|c| format!("\"{c}\""))
                            .collect::<Vec<_>>()
                            .join(", ");
                        let hint = did_you_mean(s, decl.choices.iter().map(|c| c.as_ref()))
                            .map(|h| format!(" (did you mean \"{h}\"?)"))
                            .unwrap_or_default();
                        return Err(out(format!("\"{s}\""), format!("one of {list}{hint}")));
                    }
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> Vec<ParamDecl> {
        vec![
            ParamDecl::float("fov", 90.0)
                .range(ValueRange::open(0.0, 180.0))
                .doc("field of view"),
            ParamDecl::float("fStop", f32::INFINITY).range(ValueRange::at_least(0.0)),
            ParamDecl::int("samples", 4).range(ValueRange::closed(1.0, 64.0)),
            ParamDecl::string("eye", "left").choices(&["left", "right"]),
            ParamDecl::color("transverse", Rgb::WHITE),
            ParamDecl::triple("focus1", ParamType::Point, Vec3::ZERO),
            ParamDecl::matrix("xform", Matrix4::IDENTITY),
            ParamDecl::float_array("polynomial", &[0.0, 1.0, 0.0, 0.0, 0.0]),
        ]
    }

    fn list(decl: &str, vals: &[&str]) -> ParamList {
        let mut l = ParamList::new();
        l.push_text(decl, vals, Some("test:1".into())).unwrap();
        l
    }

    #[test]
    fn defaults_fill_what_the_scene_leaves_out() {
        let p = Params::resolve("P", &table(), &ParamList::new()).unwrap();
        assert_eq!(p.float("fov").unwrap(), 90.0);
        assert_eq!(p.float("fStop").unwrap(), f32::INFINITY);
        assert_eq!(p.int("samples").unwrap(), 4);
        assert_eq!(p.string("eye").unwrap(), "left");
        assert_eq!(p.color("transverse").unwrap(), Rgb::WHITE);
        assert_eq!(p.triple("focus1").unwrap(), Vec3::ZERO);
        assert_eq!(p.matrix("xform").unwrap(), Matrix4::IDENTITY);
        assert_eq!(p.floats("polynomial", 5).unwrap(), &[0.0, 1.0, 0.0, 0.0, 0.0]);
        assert!(!p.is_given("fov"));
    }

    #[test]
    fn given_values_are_read_back_typed() {
        let mut l = list("float fov", &["45"]);
        l.push_text("float[5] polynomial", &["1", "2", "3", "4", "5"], None)
            .unwrap();
        l.push_text("color transverse", &["1", "0.5", "0.25"], None)
            .unwrap();
        l.push_text("string eye", &["right"], None).unwrap();
        let p = Params::resolve("P", &table(), &l).unwrap();
        assert_eq!(p.float("fov").unwrap(), 45.0);
        assert!(p.is_given("fov"));
        assert_eq!(p.floats("polynomial", 5).unwrap(), &[1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(p.color("transverse").unwrap(), Rgb::new(1.0, 0.5, 0.25));
        assert_eq!(p.string("eye").unwrap(), "right");
    }

    #[test]
    fn unknown_name_names_plugin_and_suggests_the_close_one() {
        let err = Params::resolve("PxrPerspective", &table(), &list("float fvo", &["45"])).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.starts_with("PxrPerspective: unknown parameter \"fvo\""),
            "{msg}"
        );
        assert!(msg.contains("did you mean \"fov\""), "{msg}");
        assert!(msg.contains("test:1"), "{msg}");
        assert!(msg.contains("fov, fStop, samples"), "{msg}");
    }

    #[test]
    fn wrong_type_says_what_the_table_declares() {
        let err = Params::resolve("P", &table(), &list("int fov", &["45"])).unwrap_err();
        assert!(matches!(err, ParamError::WrongType { .. }));
        assert!(err.to_string().contains("declared float fov"), "{err}");
    }

    #[test]
    fn wrong_array_length_is_refused() {
        let err = Params::resolve("P", &table(), &list("float[3] polynomial", &["1", "2", "3"])).unwrap_err();
        assert!(
            matches!(
                err,
                ParamError::WrongLength {
                    expected: 5,
                    got: 3,
                    ..
                }
            ),
            "{err}"
        );
        let err = Params::resolve("P", &table(), &list("float fov", &["1", "2"])).unwrap_err();
        assert!(
            matches!(
                err,
                ParamError::WrongLength {
                    expected: 1,
                    got: 2,
                    ..
                }
            ),
            "{err}"
        );
    }

    #[test]
    fn variable_length_lists_take_any_nonempty_length() {
        let table = vec![ParamDecl::float_list("params", &[]).doc("coefficients")];
        assert_eq!(table[0].rib_declaration(), "float[] params");
        for n in [1usize, 4, 14] {
            let vals: Vec<String> = (0..n).map(|i| i.to_string()).collect();
            let vals: Vec<&str> = vals.iter().map(String::as_str).collect();
            for decl in ["float params", "float[] params"] {
                let p = Params::resolve("P", &table, &list(decl, &vals)).unwrap();
                assert_eq!(p.float_list("params").unwrap().len(), n);
            }
        }
        let p = Params::resolve("P", &table, &ParamList::new()).unwrap();
        assert!(p.float_list("params").unwrap().is_empty());
        assert!(p.floats("params", 0).is_err() && p.float("params").is_err());
        let fixed = vec![ParamDecl::float_array("k", &[0.0; 2]).doc("k")];
        let p = Params::resolve("P", &fixed, &ParamList::new()).unwrap();
        assert!(p.float_list("k").is_err(), "a fixed array is not a list");
    }

    #[test]
    fn out_of_range_names_the_range() {
        let err = Params::resolve("P", &table(), &list("float fov", &["180"])).unwrap_err();
        assert!(err.to_string().contains("expected a value in (0, 180)"), "{err}");
        let err = Params::resolve("P", &table(), &list("int samples", &["0"])).unwrap_err();
        assert!(err.to_string().contains("[1, 64]"), "{err}");
        let err = Params::resolve("P", &table(), &list("string eye", &["lefft"])).unwrap_err();
        assert!(err.to_string().contains("did you mean \"left\""), "{err}");
        // Infinity is allowed only where the range reaches it.
        assert!(Params::resolve("P", &table(), &list("float fStop", &["inf"])).is_ok());
        assert!(Params::resolve("P", &table(), &list("float fov", &["inf"])).is_err());
    }

    #[test]
    fn duplicates_are_refused_with_both_places() {
        let mut l = list("float fov", &["45"]);
        l.push_text("float fov", &["50"], Some("test:2".into())).unwrap();
        let err = Params::resolve("P", &table(), &l).unwrap_err();
        assert!(err.to_string().contains("test:1 and test:2"), "{err}");
    }

    #[test]
    fn declarations_parse_or_explain() {
        assert_eq!(
            parse_declaration("float fov").unwrap(),
            (ParamType::Float, None, "fov".into())
        );
        assert_eq!(
            parse_declaration("uniform float[5] k").unwrap(),
            (ParamType::Float, Some(5), "k".into())
        );
        assert!(matches!(
            parse_declaration("flaot fov"),
            Err(DeclarationError::UnknownType { .. })
        ));
        assert!(matches!(
            parse_declaration("float[x] k"),
            Err(DeclarationError::Malformed(_))
        ));
        assert!(matches!(
            parse_declaration("fov"),
            Err(DeclarationError::Malformed(_))
        ));
        let mut l = ParamList::new();
        assert!(matches!(
            l.push_text("color c", &["1", "2"], None),
            Err(DeclarationError::Count { .. })
        ));
        assert!(matches!(
            l.push_text("float f", &["x"], None),
            Err(DeclarationError::Value { .. })
        ));
        assert!(matches!(
            l.push("float f", ParamValue::Strings(vec!["a".into()]), None),
            Err(DeclarationError::Kind { .. })
        ));
        // RIB writes integers for floats.
        l.push("float f", ParamValue::Ints(vec![3]), None).unwrap();
        assert_eq!(l.get("f").unwrap().value, ParamValue::Floats(vec![3.0]));
    }

    #[test]
    fn remove_lets_a_later_value_replace_an_earlier_one() {
        let mut l = list("float fov", &["45"]);
        assert_eq!(l.remove("fov"), 1);
        l.push_text("float fov", &["50"], None).unwrap();
        assert_eq!(
            Params::resolve("P", &table(), &l).unwrap().float("fov").unwrap(),
            50.0
        );
        assert_eq!(l.remove("nothing"), 0);
    }

    #[test]
    fn a_plugin_asking_for_an_undeclared_parameter_gets_a_lookup_error() {
        let p = Params::resolve("P", &table(), &ParamList::new()).unwrap();
        assert!(matches!(p.float("nope"), Err(ParamError::Lookup { .. })));
        assert!(matches!(p.int("fov"), Err(ParamError::Lookup { .. })));
        assert!(matches!(
            p.floats("polynomial", 4),
            Err(ParamError::Lookup { .. })
        ));
    }
}
