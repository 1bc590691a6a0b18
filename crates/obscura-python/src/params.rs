//! Projection parameters from Python keyword arguments, read against the projection's table exactly
//! as the CLI reads `--param name=value`: the same names, types, ranges and messages.
//!
//! | declared type | Python value |
//! |---|---|
//! | `float`, `float[n]`, `float[]` | a number, or a sequence / array of numbers |
//! | `int`, `int[n]` | an int, or a sequence of ints |
//! | `string` | a str |
//! | `color`, `point`, `vector`, `normal` | three numbers |
//! | `matrix` | sixteen numbers, flat or 4×4 (row-major, RenderMan's row-vector convention) |

use std::collections::HashMap;

use obscura_sdk::{ParamDecl, ParamList, ParamType, ParamValue, did_you_mean};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyString};

/// A parameter value as Python gave it, before the projection's f32 storage: the calibrated camera's
/// f64 path reads these.
#[derive(Debug, Clone, PartialEq)]
pub enum Raw {
    /// Numbers, in f64 as given.
    Numbers(Vec<f64>),
    /// Strings.
    Strings(Vec<String>),
}

/// Reads `kwargs` against `table` of projection `plugin` into a [`ParamList`] (each entry's origin
/// is `name=value`), and the values as given.
pub fn read_params(
    plugin: &str,
    table: &[ParamDecl],
    kwargs: Option<&Bound<'_, PyDict>>,
) -> PyResult<(ParamList, HashMap<String, Raw>)> {
    let mut list = ParamList::new();
    let mut raw = HashMap::new();
    let Some(kwargs) = kwargs else {
        return Ok((list, raw));
    };
    for (k, v) in kwargs.iter() {
        let name: String = k.extract()?;
        let Some(decl) = table.iter().find(|d| d.name == name) else {
            let hint = did_you_mean(&name, table.iter().map(|d| d.name.as_ref()))
                .map(|s| format!(" (did you mean \"{s}\"?)"))
                .unwrap_or_default();
            return Err(PyValueError::new_err(format!(
                "{plugin} has no parameter \"{name}\"{hint}; its parameters: {} (see obscura.projections())",
                table
                    .iter()
                    .map(|d| d.name.as_ref())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        };
        let repr = v.repr().map(|r| r.to_string()).unwrap_or_default();
        let value = read_value(plugin, decl, &v)?;
        let stored = match &value {
            Raw::Strings(s) => ParamValue::Strings(s.clone()),
            Raw::Numbers(x) if decl.ty == ParamType::Int => ParamValue::Ints(
                x.iter()
                    .map(|&f| {
                        i32::try_from(f as i64).map_err(|_| {
                            PyValueError::new_err(format!(
                                "{plugin}: {name}={repr}: {f} does not fit a 32-bit int"
                            ))
                        })
                    })
                    .collect::<PyResult<_>>()?,
            ),
            Raw::Numbers(x) => ParamValue::Floats(x.iter().map(|&f| f as f32).collect()),
        };
        list.push(&decl.rib_declaration(), stored, Some(format!("{name}={repr}")))
            .map_err(|e| PyValueError::new_err(format!("{plugin}: {name}={repr}: {e}")))?;
        raw.insert(name, value);
    }
    Ok((list, raw))
}

fn type_error(plugin: &str, decl: &ParamDecl, expected: &str, v: &Bound<'_, PyAny>) -> PyErr {
    let ty = v.get_type().name().map(|n| n.to_string()).unwrap_or_default();
    PyTypeError::new_err(format!(
        "{plugin}: parameter \"{}\" ({}) expects {expected}, got {ty}",
        decl.name,
        decl.rib_declaration()
    ))
}

fn read_value(plugin: &str, decl: &ParamDecl, v: &Bound<'_, PyAny>) -> PyResult<Raw> {
    if decl.ty == ParamType::String {
        if let Ok(s) = v.cast::<PyString>() {
            return Ok(Raw::Strings(vec![s.to_string()]));
        }
        if !v.is_instance_of::<PyString>()
            && let Ok(list) = v.extract::<Vec<String>>()
        {
            return Ok(Raw::Strings(list));
        }
        return Err(type_error(plugin, decl, "a str", v));
    }
    let int = decl.ty == ParamType::Int;
    let what = if int {
        "an int or a sequence of ints"
    } else {
        "a number or a sequence of numbers"
    };
    let mut out = Vec::new();
    flatten(plugin, decl, v, int, &mut out, 0).map_err(|_| type_error(plugin, decl, what, v))?;
    Ok(Raw::Numbers(out))
}

/// Appends the numbers of `v` (a number or nested sequences of them) to `out`.
fn flatten(
    plugin: &str,
    decl: &ParamDecl,
    v: &Bound<'_, PyAny>,
    int: bool,
    out: &mut Vec<f64>,
    depth: usize,
) -> PyResult<()> {
    let bad = || PyTypeError::new_err(format!("{plugin}: {}", decl.name));
    if v.is_instance_of::<PyString>() || v.is_instance_of::<PyBool>() || depth > 2 {
        return Err(bad());
    }
    if int {
        if let Ok(i) = v.extract::<i64>() {
            out.push(i as f64);
            return Ok(());
        }
    } else if let Ok(x) = v.extract::<f64>() {
        out.push(x);
        return Ok(());
    }
    let iter = v.try_iter().map_err(|_| bad())?;
    for item in iter {
        flatten(plugin, decl, &item?, int, out, depth + 1)?;
    }
    Ok(())
}
