//! The tokenizer: RIB bytes → [`Command`]s (a request name, where it was read, its arguments).
//!
//! ASCII RIB and the binary encoding of the RenderMan Interface (RISpec 3.2 appendix C.2) are read by
//! the same loop, byte by byte, as the spec asks (the two may be mixed and there is no header): a byte
//! below 0x80 is ASCII text (comments, strings with their escapes, numbers remembering whether each
//! was written as an integer, `[ … ]` arrays, request names); a byte from 0x80 up outside a string or
//! comment starts a binary token ([`binary`](super::binary) decodes it). Strings and comments are
//! bytes: UTF-8 when they are valid UTF-8, else read as Latin-1, which is what older exporters wrote.
//! Nothing here knows what a request means.

use super::binary::{self, Binary, Definitions};

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

/// Where a binary-encoded request was read: its index among the file's requests (from 0) and the
/// byte offset of its code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct BinaryAt {
    /// The request's index in the file (from 0).
    pub(super) index: u32,
    /// The byte offset of the request token.
    pub(super) byte: u64,
}

/// A request name and the arguments up to the next request name.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Command {
    /// The request name as written.
    pub(super) name: String,
    /// The line (from 1) of the name (lines are counted in the ASCII parts).
    pub(super) line: u32,
    /// For a binary-encoded request: its index and byte offset.
    pub(super) binary: Option<BinaryAt>,
    /// The arguments, in order.
    pub(super) args: Vec<Value>,
}

/// Bytes that are not RIB: the line (or byte offset, in binary RIB) where the fault starts and what
/// is wrong.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct LexError {
    /// The line (from 1) of the fault; for an unterminated string or array, where it began.
    pub(super) line: u32,
    /// The byte offset, for faults in binary tokens.
    pub(super) byte: Option<u64>,
    /// What is wrong.
    pub(super) message: String,
}

impl LexError {
    fn new(line: u32, message: impl Into<String>) -> Self {
        LexError {
            line,
            byte: None,
            message: message.into(),
        }
    }
}

/// Bare words that are numbers a scene must not hold: read as numbers so the message can say so.
const NOT_FINITE: [&str; 4] = ["nan", "inf", "infinity", "-nan"];

/// Splits RIB (ASCII, binary, or both) into requests. Strings may span lines; an array must close
/// before the next request.
pub(super) fn lex(bytes: impl AsRef<[u8]>) -> Result<Vec<Command>, LexError> {
    Lexer {
        bytes: bytes.as_ref(),
        pos: 0,
        line: 1,
        commands: Vec::new(),
        array: None,
        defs: Definitions::default(),
    }
    .run()
}

/// The tokenizer's state.
struct Lexer<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: u32,
    commands: Vec<Command>,
    /// The array being read: the line of its '[' and its items.
    array: Option<(u32, Vec<Value>)>,
    /// Binary RIB's defined request codes and strings.
    defs: Definitions,
}

impl Lexer<'_> {
    fn run(mut self) -> Result<Vec<Command>, LexError> {
        while let Some(&c) = self.bytes.get(self.pos) {
            let start = self.line;
            let at = self.pos;
            self.pos += 1;
            let item = match c {
                b'\n' => {
                    self.line = self.line.saturating_add(1);
                    continue;
                }
                b'#' => {
                    while self.bytes.get(self.pos).is_some_and(|&b| b != b'\n') {
                        self.pos += 1;
                    }
                    continue;
                }
                c if c.is_ascii_whitespace() || c == 0 => continue,
                b'"' => Value::Str(self.read_string(start)?),
                b'[' => {
                    if let Some((open, _)) = &self.array {
                        return Err(LexError::new(*open, "unterminated array: '[' inside an array"));
                    }
                    self.array = Some((self.line, Vec::new()));
                    continue;
                }
                b']' => {
                    self.close_array()?;
                    continue;
                }
                c if c.is_ascii_digit() || matches!(c, b'+' | b'-' | b'.') => {
                    Value::Num(self.read_number(at)?)
                }
                c if c.is_ascii_alphabetic() || c == b'_' => {
                    let name = self.read_name(at);
                    if NOT_FINITE.contains(&name.to_ascii_lowercase().as_str()) {
                        return Err(LexError::new(
                            self.line,
                            format!(
                                "{} value (\"{name}\"): numbers must be finite",
                                not_finite_kind(&name)
                            ),
                        ));
                    }
                    self.request(name, None)?;
                    continue;
                }
                0x80.. => match binary::token(self.bytes, at, &mut self.defs).map_err(|message| LexError {
                    line: self.line,
                    byte: Some(at as u64),
                    message,
                })? {
                    (Binary::Value(v), next) => {
                        self.pos = next;
                        v
                    }
                    (Binary::Request(name), next) => {
                        self.pos = next;
                        let index = u32::try_from(self.commands.len()).unwrap_or(u32::MAX);
                        self.request(
                            name,
                            Some(BinaryAt {
                                index,
                                byte: at as u64,
                            }),
                        )?;
                        continue;
                    }
                    (Binary::Definition, next) => {
                        self.pos = next;
                        continue;
                    }
                },
                other => {
                    return Err(LexError::new(
                        self.line,
                        format!("unexpected character '{}'", char::from(other).escape_default()),
                    ));
                }
            };
            match &mut self.array {
                Some((_, items)) => items.push(item),
                None => append_arg(&mut self.commands, item, start)?,
            }
        }
        if let Some((open, _)) = self.array {
            return Err(LexError::new(
                open,
                "unterminated array: the closing ']' is missing",
            ));
        }
        Ok(self.commands)
    }

    /// Starts request `name`; an open array is an error.
    fn request(&mut self, name: String, binary: Option<BinaryAt>) -> Result<(), LexError> {
        if let Some((open, _)) = &self.array {
            return Err(LexError::new(
                *open,
                format!("unterminated array: no ']' before the next request ({name})"),
            ));
        }
        self.commands.push(Command {
            name,
            line: self.line,
            binary,
            args: Vec::new(),
        });
        Ok(())
    }

    /// Ends the array at a `]`, as an argument of the last request.
    fn close_array(&mut self) -> Result<(), LexError> {
        let Some((open, items)) = self.array.take() else {
            return Err(LexError::new(self.line, "']' without a matching '['"));
        };
        let value =
            array_value(items).ok_or_else(|| LexError::new(open, "an array mixes numbers and strings"))?;
        append_arg(&mut self.commands, value, open)
    }

    /// A bare word starting at `start`: letters, digits and `_`.
    fn read_name(&mut self, start: usize) -> String {
        while self
            .bytes
            .get(self.pos)
            .is_some_and(|&b| b.is_ascii_alphanumeric() || b == b'_')
        {
            self.pos += 1;
        }
        String::from_utf8_lossy(&self.bytes[start..self.pos]).into_owned()
    }

    /// The body of a string after its opening quote (the quote was on line `start`).
    fn read_string(&mut self, start: u32) -> Result<String, LexError> {
        let unterminated = || LexError::new(start, "unterminated string: the closing '\"' is missing");
        let mut s = Vec::new();
        loop {
            let &c = self.bytes.get(self.pos).ok_or_else(unterminated)?;
            self.pos += 1;
            match c {
                b'"' => return Ok(decode_text(&s)),
                b'\\' => {
                    let &e = self.bytes.get(self.pos).ok_or_else(unterminated)?;
                    self.pos += 1;
                    match e {
                        b'n' => s.push(b'\n'),
                        b't' => s.push(b'\t'),
                        b'r' => s.push(b'\r'),
                        b'b' => s.push(0x08),
                        b'f' => s.push(0x0c),
                        b'\n' => self.line = self.line.saturating_add(1), // a continued line
                        b'0'..=b'7' => {
                            let mut v = u32::from(e - b'0');
                            for _ in 0..2 {
                                match self.bytes.get(self.pos) {
                                    Some(&d @ b'0'..=b'7') => {
                                        v = v * 8 + u32::from(d - b'0');
                                        self.pos += 1;
                                    }
                                    _ => break,
                                }
                            }
                            s.push((v & 0xff) as u8);
                        }
                        b'\\' | b'"' => s.push(e),
                        other => s.extend([b'\\', other]),
                    }
                }
                b'\n' => {
                    self.line = self.line.saturating_add(1);
                    s.push(b'\n');
                }
                c => s.push(c),
            }
        }
    }

    /// A number starting at `start`; an error when it does not parse or overflows `f32`.
    fn read_number(&mut self, start: usize) -> Result<Num, LexError> {
        while let Some(&c) = self.bytes.get(self.pos) {
            if c.is_ascii_digit() || c == b'.' {
                self.pos += 1;
            } else if matches!(c, b'e' | b'E') {
                self.pos += 1;
                if self
                    .bytes
                    .get(self.pos)
                    .is_some_and(|&n| matches!(n, b'+' | b'-'))
                {
                    self.pos += 1;
                }
            } else {
                break;
            }
        }
        let s = String::from_utf8_lossy(&self.bytes[start..self.pos]).into_owned();
        // `-inf`, `+nan`: a sign then a word.
        if matches!(s.as_str(), "-" | "+") && self.bytes.get(self.pos).is_some_and(u8::is_ascii_alphabetic) {
            let word = self.read_name(self.pos);
            if NOT_FINITE.contains(&word.to_ascii_lowercase().as_str()) {
                return Err(LexError::new(
                    self.line,
                    format!(
                        "{} value (\"{s}{word}\"): numbers must be finite",
                        not_finite_kind(&word)
                    ),
                ));
            }
            return Err(LexError::new(
                self.line,
                format!("cannot read the number \"{s}{word}\""),
            ));
        }
        let value = s
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && v.abs() <= f64::from(f32::MAX))
            .ok_or_else(|| LexError::new(self.line, format!("cannot read the number \"{s}\"")))?;
        let int = if s.contains(['.', 'e', 'E']) {
            None
        } else {
            s.parse::<i32>().ok()
        };
        Ok(Num { value, int })
    }
}

/// "a NaN" or "an infinite", for a bare word of [`NOT_FINITE`].
fn not_finite_kind(word: &str) -> &'static str {
    if word.to_ascii_lowercase().contains("nan") {
        "a NaN"
    } else {
        "an infinite"
    }
}

/// Text bytes as a string: UTF-8 when valid, else Latin-1 (each byte is the code point of its value).
pub(super) fn decode_text(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(s) => s.to_string(),
        Err(_) => bytes.iter().map(|&b| char::from(b)).collect(),
    }
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

/// The array of these items, or `None` when it mixes numbers and strings.
pub(super) fn array_value(items: Vec<Value>) -> Option<Value> {
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
