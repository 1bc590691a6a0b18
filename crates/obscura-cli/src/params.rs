//! Reading projection parameters from command-line arguments.
//!
//! Three spellings are accepted, so a user can paste from RIB or type quickly:
//!
//! | form | example |
//! |---|---|
//! | typed assignment | `float fov=60`, `float[5] polynomial=0 1 0 0 0`, `color transverse=1,1.01,1.02` |
//! | RIB | `"float fov" [60]`, `"string eye" ["left"]` |
//! | untyped assignment (type from the projection's table) | `fov=60`, `eye=left` |

use obscura_render::job::merge_params;
use obscura_sdk::{DeclarationError, ParamDecl, ParamList, did_you_mean};

/// A `--param` argument could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamArgError {
    /// The argument has none of the accepted forms.
    #[error(
        "--param '{arg}': expected \"type name=value\", \"name=value\" or RIB's '\"type name\" [values]', e.g. --param 'float fov=60'"
    )]
    Form {
        /// The argument.
        arg: String,
    },
    /// A RIB-form argument whose quotes or brackets do not close, or that has text after its array.
    #[error("--param '{arg}': {what}")]
    Unbalanced {
        /// The argument.
        arg: String,
        /// What does not close.
        what: &'static str,
    },
    /// An untyped name the projection does not declare.
    #[error("--param '{arg}': {plugin} has no parameter \"{name}\"{hint}; give its type (e.g. 'float {name}=...') or see `obscura plugins {plugin}`",
        hint = suggestion.as_ref().map(|s| format!(" (did you mean \"{s}\"?)")).unwrap_or_default())]
    Unknown {
        /// The argument.
        arg: String,
        /// The projection.
        plugin: String,
        /// The name given.
        name: String,
        /// The closest declared name.
        suggestion: Option<String>,
    },
    /// The declaration or values could not be read.
    #[error("--param '{arg}': {source}")]
    Declaration {
        /// The argument.
        arg: String,
        /// What was wrong.
        source: DeclarationError,
    },
}

/// Adds one `--param` argument to `list`, reading untyped names against `table` of projection `plugin`.
///
/// # Errors
/// A [`ParamArgError`] quoting the argument.
pub fn push_param_arg(
    list: &mut ParamList,
    arg: &str,
    plugin: &str,
    table: &[ParamDecl],
) -> Result<(), ParamArgError> {
    let form = || ParamArgError::Form { arg: arg.to_string() };
    let origin = Some(format!("--param '{arg}'"));
    let (decl, values): (String, Vec<String>) = if arg.trim_start().starts_with('"') {
        parse_rib(arg).map_err(|what| match what {
            Some(what) => ParamArgError::Unbalanced {
                arg: arg.to_string(),
                what,
            },
            None => form(),
        })?
    } else {
        let (lhs, rhs) = arg.split_once('=').ok_or_else(form)?;
        let lhs = lhs.trim();
        let values: Vec<String> = if lhs
            .split_whitespace()
            .next()
            .is_some_and(|t| t.starts_with("string"))
        {
            vec![rhs.to_string()]
        } else {
            rhs.split([',', ' '])
                .filter(|v| !v.is_empty())
                .map(str::to_string)
                .collect()
        };
        if lhs.contains(char::is_whitespace) {
            (lhs.to_string(), values)
        } else {
            let Some(d) = table.iter().find(|d| d.name == lhs) else {
                return Err(ParamArgError::Unknown {
                    arg: arg.to_string(),
                    plugin: plugin.to_string(),
                    name: lhs.to_string(),
                    suggestion: did_you_mean(lhs, table.iter().map(|d| d.name.as_ref())),
                });
            };
            let values = if d.ty == obscura_sdk::ParamType::String {
                vec![rhs.to_string()]
            } else {
                values
            };
            (d.rib_declaration(), values)
        }
    };
    if values.is_empty() {
        return Err(form());
    }
    let refs: Vec<&str> = values.iter().map(String::as_str).collect();
    list.push_text(&decl, &refs, origin)
        .map_err(|source| ParamArgError::Declaration {
            arg: arg.to_string(),
            source,
        })?;
    Ok(())
}

/// Reads every `--param` argument in `args`, in order, into one list (see [`push_param_arg`]).
///
/// # Errors
/// The first argument that cannot be read, quoted.
pub fn param_list(args: &[String], plugin: &str, table: &[ParamDecl]) -> Result<ParamList, ParamArgError> {
    let mut list = ParamList::new();
    for arg in args {
        push_param_arg(&mut list, arg, plugin, table)?;
    }
    Ok(list)
}

/// Adds the `--param` arguments `args` to `list` (a calibration's parameters), each replacing the
/// entries of the same name ([`merge_params`]).
///
/// # Errors
/// The first argument that cannot be read, quoted.
pub fn merge_param_args(
    list: &mut ParamList,
    args: &[String],
    plugin: &str,
    table: &[ParamDecl],
) -> Result<(), String> {
    let extra = param_list(args, plugin, table).map_err(|e| e.to_string())?;
    merge_params(list, &extra).map_err(|e| e.to_string())
}

/// `"type name" [v v v]` or `"type name" v` → (declaration, values). Strings may be quoted.
///
/// # Errors
/// `Some(what)` for a quote or bracket that does not close (or closes twice, or is followed by more
/// values); `None` for no declaration at all.
fn parse_rib(arg: &str) -> Result<(String, Vec<String>), Option<&'static str>> {
    let mut tokens = Vec::new();
    let mut chars = arg.chars().peekable();
    // 0: before the array, 1: inside it, 2: after it.
    let mut array = 0;
    while let Some(&c) = chars.peek() {
        match c {
            '"' => {
                chars.next();
                let mut s = String::new();
                loop {
                    match chars.next() {
                        Some('"') => break,
                        Some(ch) => s.push(ch),
                        None => return Err(Some("unterminated string: a '\"' does not close")),
                    }
                }
                if array == 2 {
                    return Err(Some("unexpected value after the closing ']'"));
                }
                tokens.push(s);
            }
            '[' => {
                chars.next();
                if array != 0 || tokens.is_empty() {
                    return Err(Some(
                        "unexpected '[': expected one array of values after the declaration",
                    ));
                }
                array = 1;
            }
            ']' => {
                chars.next();
                if array != 1 {
                    return Err(Some("unexpected ']' without an opening '['"));
                }
                array = 2;
            }
            c if c.is_whitespace() || c == ',' => {
                chars.next();
            }
            _ => {
                let mut s = String::new();
                while let Some(&ch) = chars.peek() {
                    if ch.is_whitespace() || matches!(ch, '[' | ']' | '"' | ',') {
                        break;
                    }
                    s.push(ch);
                    chars.next();
                }
                if array == 2 {
                    return Err(Some("unexpected value after the closing ']'"));
                }
                tokens.push(s);
            }
        }
    }
    if array == 1 {
        return Err(Some("unterminated array: a '[' does not close (expected ']')"));
    }
    let mut it = tokens.into_iter();
    let decl = it.next().ok_or(None)?;
    Ok((decl, it.collect()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::{ParamValue, ValueRange};

    fn table() -> Vec<ParamDecl> {
        vec![
            ParamDecl::float("fov", 90.0).range(ValueRange::open(0.0, 180.0)),
            ParamDecl::string("eye", "left"),
            ParamDecl::float_array("polynomial", &[0.0; 5]),
        ]
    }

    fn one(arg: &str) -> Result<ParamList, ParamArgError> {
        let mut l = ParamList::new();
        push_param_arg(&mut l, arg, "P", &table())?;
        Ok(l)
    }

    #[test]
    fn all_three_forms_read_the_same() {
        for arg in ["float fov=60", "\"float fov\" [60]", "fov=60", "\"float fov\" 60"] {
            let l = one(arg).unwrap();
            let e = l.get("fov").unwrap();
            assert_eq!(e.value, ParamValue::Floats(vec![60.0]), "{arg}");
            assert_eq!(e.origin.as_deref(), Some(format!("--param '{arg}'").as_str()));
        }
        for arg in [
            "float[5] polynomial=0 1 2 3 4",
            "polynomial=0,1,2,3,4",
            "\"float[5] polynomial\" [0 1 2 3 4]",
        ] {
            let l = one(arg).unwrap();
            assert_eq!(
                l.get("polynomial").unwrap().value,
                ParamValue::Floats(vec![0.0, 1.0, 2.0, 3.0, 4.0])
            );
        }
        for arg in ["string eye=right", "eye=right", "\"string eye\" [\"right\"]"] {
            let l = one(arg).unwrap();
            assert_eq!(
                l.get("eye").unwrap().value,
                ParamValue::Strings(vec!["right".into()]),
                "{arg}"
            );
        }
    }

    #[test]
    fn unreadable_arguments_are_quoted_back() {
        let e = one("fov 60").unwrap_err().to_string();
        assert!(e.starts_with("--param 'fov 60': expected"), "{e}");
        let e = one("fvo=60").unwrap_err().to_string();
        assert!(e.contains("did you mean \"fov\""), "{e}");
        let e = one("float fov=abc").unwrap_err().to_string();
        assert!(e.contains("cannot read \"abc\" as float"), "{e}");
        let e = one("flaot fov=1").unwrap_err().to_string();
        assert!(e.contains("unknown parameter type \"flaot\""), "{e}");
        assert!(one("\"float fov [60]").is_err());
    }

    /// Issue 16: `--param '"float fov" [60'` was accepted.
    #[test]
    fn unbalanced_rib_arguments_say_what_does_not_close() {
        for (arg, what) in [
            (
                "\"float fov\" [60",
                "unterminated array: a '[' does not close (expected ']')",
            ),
            ("\"float fov\" 60]", "unexpected ']' without an opening '['"),
            ("\"float fov\" [60]]", "unexpected ']' without an opening '['"),
            (
                "\"float fov\" [[60]]",
                "unexpected '[': expected one array of values after the declaration",
            ),
            ("\"float fov\" [60] 70", "unexpected value after the closing ']'"),
            (
                "\"string eye\" [\"left]",
                "unterminated string: a '\"' does not close",
            ),
            ("\"float fov", "unterminated string: a '\"' does not close"),
        ] {
            assert_eq!(
                one(arg).unwrap_err().to_string(),
                format!("--param '{arg}': {what}")
            );
        }
        assert!(one("\"float fov\" [ 60 ]").is_ok());
    }
}
