//! The tokenizer: RIB text → [`Command`]s (a request name, its line and its arguments).
//!
//! Comments, strings with their escapes, numbers (remembering whether each was written as an
//! integer), `[ … ]` arrays and line counting live here; nothing here knows what a request means. A
//! binary RIB decoder would sit beside [`lex`] and produce the same [`Command`]s.

use std::iter::Peekable;
use std::str::Chars;

/// A number as written: its value, and the integer it is when written without `.` or an exponent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Num {
    /// The value.
    pub(super) value: f64,
    /// The integer, when written as one that fits `i32`.
    pub(super) int: Option<i32>,
}

/// One argument of a request.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Value {
    /// A single number.
    Num(Num),
    /// A single string.
    Str(String),
    /// `[ … ]` of numbers (an empty array is one of these).
    Nums(Vec<Num>),
    /// `[ … ]` of strings.
    Strs(Vec<String>),
}

/// A request name and the arguments up to the next request name.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Command {
    /// The request name as written.
    pub(super) name: String,
    /// The line (from 1) of the name.
    pub(super) line: u32,
    /// The arguments, in order.
    pub(super) args: Vec<Value>,
}

/// Text that is not RIB: the line where the fault starts and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct LexError {
    /// The line (from 1) of the fault; for an unterminated string or array, where it began.
    pub(super) line: u32,
    /// What is wrong.
    pub(super) message: String,
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
pub(super) fn lex(text: &str) -> Result<Vec<Command>, LexError> {
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
                close_array(array.take(), &mut commands, line)?;
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
                commands.push(Command {
                    name: read_name(c, &mut chars),
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

/// Ends the array `array` (its `[` line and items) at a `]` on `line`, as an argument of the last request.
fn close_array(
    array: Option<(u32, Vec<Value>)>,
    commands: &mut [Command],
    line: u32,
) -> Result<(), LexError> {
    let Some((open, items)) = array else {
        return Err(LexError::new(line, "']' without a matching '['"));
    };
    let value =
        array_value(items).ok_or_else(|| LexError::new(open, "an array mixes numbers and strings"))?;
    append_arg(commands, value, open)
}

/// A request name starting with `first`: letters, digits and `_`.
fn read_name(first: char, chars: &mut Peekable<Chars<'_>>) -> String {
    let mut name = String::from(first);
    while let Some(n) = chars.next_if(|&n| n.is_alphanumeric() || n == '_') {
        name.push(n);
    }
    name
}

/// Adds `value` to the arguments of the request read last; before any request it is an error.
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

/// A number starting with `first`; an error when it does not parse or overflows `f32`.
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
pub(super) fn describe(v: &Value) -> String {
    match v {
        Value::Num(n) => format!("the number {}", n.value),
        Value::Str(s) => format!("the string \"{s}\""),
        Value::Nums(n) => format!("an array of {} numbers", n.len()),
        Value::Strs(s) => format!("an array of {} strings", s.len()),
    }
}
