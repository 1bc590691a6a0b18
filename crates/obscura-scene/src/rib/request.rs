//! One request being handled ([`Req`]): where it was read, typed access to its arguments, and its
//! parameter list (`"float fov" [40]`) checked against the parameters the request knows.

use std::path::{Path, PathBuf};

use glam::Vec3;
use obscura_sdk::{ParamList, ParamType, ParamValue, Rgb, parse_declaration};

use super::lex::{BinaryAt, Num, Value, describe};
use super::{Reader, RibError};

/// One request being handled: its file, the directory relative paths resolve against, its arguments.
pub(super) struct Req<'a> {
    /// The file the request is in (as messages name it).
    pub(super) file: &'a str,
    /// The directory relative paths resolve against.
    pub(super) base: &'a Path,
    /// How many `ReadArchive`s deep the file is (0 for the file given to the reader).
    pub(super) depth: u32,
    /// The request name.
    pub(super) name: &'a str,
    /// The line (from 1) of the request name.
    pub(super) line: u32,
    /// For a binary-encoded request: its index and byte offset.
    pub(super) binary: Option<BinaryAt>,
    /// The arguments.
    pub(super) args: &'a [Value],
}

impl<'a> Req<'a> {
    /// `file:line` (binary RIB: `file: request N at byte B`), the origin recorded in parameter lists
    /// and objects.
    pub(super) fn at(&self) -> String {
        self.err("").location()
    }

    /// An error at this request.
    pub(super) fn err(&self, message: impl Into<String>) -> RibError {
        RibError {
            file: self.file.to_string(),
            line: self.line,
            request: self.binary.map(|b| b.index),
            byte: self.binary.map(|b| b.byte),
            message: message.into(),
        }
    }

    /// `path` resolved against the directory of the request's file (absolute paths as they are).
    pub(super) fn resolve(&self, path: &str) -> PathBuf {
        let p = Path::new(path);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.base.join(p)
        }
    }

    /// Exactly `N` leading numbers of `args` (written one by one or as one array), and what follows.
    pub(super) fn numbers<const N: usize>(
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
        if got < N
            && let Some(other) = rest
                .first()
                .filter(|v| !matches!(v, Value::Num(_) | Value::Nums(_)))
        {
            return Err(self.err(format!(
                "{} expects {what} ({N} numbers); argument {} is {}, where a number is expected",
                self.name,
                got + 1,
                describe(other)
            )));
        }
        let array: [f32; N] = values
            .into_iter()
            .map(|v| v as f32)
            .collect::<Vec<_>>()
            .try_into()
            .map_err(|_| self.err(format!("{} expects {what} ({N} numbers), got {got}", self.name)))?;
        Ok((array, rest))
    }

    /// Exactly `N` numbers and nothing else.
    pub(super) fn only_numbers<const N: usize>(&self, what: &str) -> Result<[f32; N], RibError> {
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
    pub(super) fn indices(&self, v: &Value, what: &str) -> Result<Vec<i64>, RibError> {
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
    pub(super) fn counts(&self, v: &Value, what: &str) -> Result<Vec<usize>, RibError> {
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
/// An `hpoint` (homogeneous point, `NuPatch`'s `Pw`) is kept as its four floats, an `mpoint` (a
/// blob's coordinate system, `Blobby`'s `Pref`) as its sixteen.
pub(super) fn normalize_declaration(decl: &str) -> String {
    decl.split_whitespace()
        .filter(|w| {
            !matches!(
                *w,
                "uniform" | "constant" | "vertex" | "varying" | "facevarying" | "facevertex"
            )
        })
        .map(|w| match w {
            "hpoint" => "float[4]",
            "mpoint" => "float[16]",
            _ => w,
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// The name a declaration declares: its last word.
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

/// The floats of parameter `name`, when it holds floats.
pub(super) fn get_floats<'l>(list: &'l ParamList, name: &str) -> Option<&'l [f32]> {
    match &list.get(name)?.value {
        ParamValue::Floats(v) => Some(v),
        _ => None,
    }
}

/// The first float of parameter `name`.
pub(super) fn get_float(list: &ParamList, name: &str) -> Option<f32> {
    get_floats(list, name)?.first().copied()
}

/// The first integer of parameter `name`, when it holds integers.
pub(super) fn get_int(list: &ParamList, name: &str) -> Option<i32> {
    match &list.get(name)?.value {
        ParamValue::Ints(v) => v.first().copied(),
        _ => None,
    }
}

/// The first string of parameter `name`.
pub(super) fn get_string<'l>(list: &'l ParamList, name: &str) -> Option<&'l str> {
    match &list.get(name)?.value {
        ParamValue::Strings(v) => v.first().map(String::as_str),
        _ => None,
    }
}

/// The colour of parameter `name` (its first three floats).
pub(super) fn get_color(list: &ParamList, name: &str) -> Option<Rgb> {
    match get_floats(list, name)? {
        [r, g, b, ..] => Some(Rgb::new(*r, *g, *b)),
        _ => None,
    }
}

/// Flat `x y z x y z …` as points (a trailing partial point is dropped).
pub(super) fn to_points(v: &[f32]) -> Vec<Vec3> {
    v.chunks_exact(3).map(Vec3::from_slice).collect()
}

impl Reader {
    /// Reads `rest` as a parameter list. `table` lists the parameters the request uses, as full
    /// declarations (exactly one value of the declared type, or one per point for `vertex` entries); a
    /// name written bare is looked up in `Declare`d names, then in `table`. With `open` any typed
    /// parameter is kept (a projection's list); otherwise the others are warned about and skipped.
    pub(super) fn params(
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
            let Some(decl) = self.declaration(r, written, table) else {
                continue;
            };
            let (ty, _, name) = parse_declaration(&decl).map_err(|e| r.err(format!("{}: {e}", r.name)))?;
            let value = param_value(value);
            match table.iter().find(|d| declared_name(d) == name) {
                Some(known) => {
                    check_against_table(r, written, known, ty, &name, &value)?;
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

    /// The full declaration of a parameter written as `written`: as written when typed, else from the
    /// `Declare`d names, then from `table`; `None` (with a warning) for an unknown bare name.
    fn declaration(&mut self, r: &Req<'_>, written: &str, table: &[&str]) -> Option<String> {
        let decl = normalize_declaration(written);
        if decl.split_whitespace().count() != 1 {
            return Some(decl);
        }
        let found = self.declared.get(&decl).cloned().or_else(|| {
            table
                .iter()
                .find(|d| declared_name(d) == decl)
                .map(|d| normalize_declaration(d))
        });
        if found.is_none() {
            self.warn(r, format!("{}: unknown parameter \"{decl}\", ignored", r.name));
        }
        found
    }
}

/// Checks a parameter the request knows (`known`, its table entry) against its type and value count.
fn check_against_table(
    r: &Req<'_>,
    written: &str,
    known: &str,
    ty: ParamType,
    name: &str,
    value: &ParamValue,
) -> Result<(), RibError> {
    let Ok((known_ty, known_len, _)) = parse_declaration(&normalize_declaration(known)) else {
        return Err(r.err(format!("{}: bad table entry \"{known}\"", r.name)));
    };
    if known_ty != ty {
        return Err(r.err(format!(
            "{}: parameter \"{written}\" has the wrong type; expected \"{known}\"",
            r.name
        )));
    }
    let need = known_len.unwrap_or(1) * known_ty.components();
    // A `vertex` entry has one value per point (any number: `push` checks whole elements).
    // RenderMan ≤ 21 wrote `"float[2] shutteropening" [open close]`.
    let per_vertex = known.split_whitespace().next() == Some("vertex");
    let legacy = name == "shutteropening" && value.len() == 2;
    if value.len() != need && !legacy && !per_vertex {
        return Err(r.err(format!(
            "{}: \"{known}\" needs {need} value(s), got {}",
            r.name,
            value.len()
        )));
    }
    Ok(())
}
