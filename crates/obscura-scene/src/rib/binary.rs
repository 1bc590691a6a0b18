//! Binary RIB: the RenderMan Interface's encoded tokens (RISpec 3.2 appendix C.2), one at a time.
//!
//! A byte from 0x80 up outside a string or comment starts a token; [`token`] decodes it at its byte
//! offset and returns what it is and where the next token starts. The encodings (octal as the spec
//! writes them):
//!
//! | first byte | token | followed by |
//! |---|---|---|
//! | 0200 + 4d + w (0x80–0x8F) | integer (d = 0) or fixed point `n / 256^d` | w + 1 bytes, signed big-endian |
//! | 0220 + w (0x90–0x9F) | string of w ≤ 15 bytes | the bytes |
//! | 0240 + l (0xA0–0xA3) | string | an (l + 1)-byte big-endian length, the bytes |
//! | 0244, 0245 (0xA4, 0xA5) | float32, float64 | 4 or 8 bytes IEEE big-endian |
//! | 0246 (0xA6) | a request by its code | the code byte |
//! | 0310 + l (0xC8–0xCB) | float32 array (as `[ … ]`) | an (l + 1)-byte count N, 4N bytes |
//! | 0314 (0xCC) | define a request code | the code byte, a string token (the name) |
//! | 0315 + w (0xCD, 0xCE) | define a string id | a (w + 1)-byte id, a string token |
//! | 0317 + w (0xCF, 0xD0) | a defined string | a (w + 1)-byte id |
//!
//! Every other byte from 0x80 up is reserved; a scene holding one is an error naming its offset.

use std::collections::HashMap;

use super::lex::{Num, Value, decode_text};

/// What a binary token is.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Binary {
    /// A number, string or array argument.
    Value(Value),
    /// A request, by its defined code: its name.
    Request(String),
    /// A request code or string id was defined: nothing to add.
    Definition,
}

/// The request codes and string ids a binary stream has defined so far.
#[derive(Debug, Default)]
pub(super) struct Definitions {
    requests: HashMap<u8, String>,
    strings: HashMap<u64, String>,
}

/// Reads the binary token at `bytes[at]` (a byte ≥ 0x80): what it is and the offset after it.
///
/// # Errors
/// A message saying what is wrong: a reserved byte, a stream that ends inside the token, a request
/// code or string id used before it was defined, a non-finite float.
pub(super) fn token(bytes: &[u8], at: usize, defs: &mut Definitions) -> Result<(Binary, usize), String> {
    let mut r = Cursor { bytes, pos: at + 1 };
    let b = bytes[at];
    let value = match b {
        0x80..=0x8F => {
            let (d, w) = (u32::from((b - 0x80) >> 2), usize::from(b & 3) + 1);
            let raw = r.signed(w)?;
            let int = (d == 0).then(|| i32::try_from(raw).ok()).flatten();
            Value::Num(Num {
                value: raw as f64 / 256f64.powi(d as i32),
                int,
            })
        }
        0x90..=0xA3 => Value::Str(r.string_body(b)?),
        0xA4 => Value::Num(finite(f64::from(f32::from_be_bytes(r.array()?)))?),
        0xA5 => Value::Num(finite(f64::from_be_bytes(r.array()?))?),
        0xA6 => {
            let code = r.byte()?;
            let name = defs
                .requests
                .get(&code)
                .ok_or_else(|| format!("request code {code} is used before it is defined (by 0xCC)"))?;
            return Ok((Binary::Request(name.clone()), r.pos));
        }
        0xC8..=0xCB => {
            let n = r.unsigned(usize::from(b - 0xC8) + 1)?;
            let n = usize::try_from(n).map_err(|_| format!("a float array of {n} values is too long"))?;
            let data = r.take(n.checked_mul(4).ok_or("a float array too long")?)?;
            let nums = data
                .chunks_exact(4)
                .map(|c| finite(f64::from(f32::from_be_bytes([c[0], c[1], c[2], c[3]]))))
                .collect::<Result<Vec<_>, _>>()?;
            Value::Nums(nums)
        }
        0xCC => {
            let code = r.byte()?;
            let name = r.string_token()?;
            if name.is_empty() || !name.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'_') {
                return Err(format!(
                    "request code {code} is defined as \"{name}\", which is not a request name"
                ));
            }
            defs.requests.insert(code, name);
            return Ok((Binary::Definition, r.pos));
        }
        0xCD | 0xCE => {
            let id = r.unsigned(usize::from(b - 0xCD) + 1)?;
            let s = r.string_token()?;
            defs.strings.insert(id, s);
            return Ok((Binary::Definition, r.pos));
        }
        0xCF | 0xD0 => {
            let id = r.unsigned(usize::from(b - 0xCF) + 1)?;
            let s = defs
                .strings
                .get(&id)
                .ok_or_else(|| format!("string id {id} is used before it is defined (by 0xCD or 0xCE)"))?;
            Value::Str(s.clone())
        }
        _ => {
            return Err(format!(
                "byte 0x{b:02X} is not a RIB token (binary RIB reserves it; in ASCII RIB, bytes above 0x7F may only stand in strings and comments)"
            ));
        }
    };
    Ok((Binary::Value(value), r.pos))
}

/// A binary float as a number; NaN and infinities are refused.
fn finite(v: f64) -> Result<Num, String> {
    if v.is_finite() && v.abs() <= f64::from(f32::MAX) {
        Ok(Num { value: v, int: None })
    } else {
        Err(format!(
            "{} float: numbers must be finite",
            if v.is_nan() { "a NaN" } else { "an infinite" }
        ))
    }
}

/// Reads a binary token's operand bytes.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl Cursor<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| {
                format!(
                    "the stream ends inside a binary token ({n} more bytes expected at byte {})",
                    self.pos
                )
            })?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn byte(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let mut a = [0; N];
        a.copy_from_slice(self.take(N)?);
        Ok(a)
    }

    /// An `n`-byte unsigned big-endian integer (n ≤ 8).
    fn unsigned(&mut self, n: usize) -> Result<u64, String> {
        Ok(self.take(n)?.iter().fold(0u64, |v, &b| (v << 8) | u64::from(b)))
    }

    /// An `n`-byte signed big-endian integer (n ≤ 4).
    fn signed(&mut self, n: usize) -> Result<i64, String> {
        let u = self.unsigned(n)?;
        let bits = 8 * n as u32;
        Ok(((u << (64 - bits)) as i64) >> (64 - bits))
    }

    /// The bytes of a string whose token byte `b` (0x90–0xA3) was read.
    fn string_body(&mut self, b: u8) -> Result<String, String> {
        let len = if b < 0xA0 {
            u64::from(b - 0x90)
        } else {
            self.unsigned(usize::from(b - 0xA0) + 1)?
        };
        let len = usize::try_from(len).map_err(|_| format!("a string of {len} bytes is too long"))?;
        Ok(decode_text(self.take(len)?))
    }

    /// A string operand of a definition: a binary string token or an ASCII `"…"` string.
    fn string_token(&mut self) -> Result<String, String> {
        while self.bytes.get(self.pos).is_some_and(u8::is_ascii_whitespace) {
            self.pos += 1;
        }
        match self.byte()? {
            b @ 0x90..=0xA3 => self.string_body(b),
            b'"' => {
                let start = self.pos;
                let len = self.bytes[start..]
                    .iter()
                    .position(|&c| c == b'"')
                    .ok_or("unterminated string in a definition")?;
                self.pos = start + len + 1;
                Ok(decode_text(&self.bytes[start..start + len]))
            }
            other => Err(format!(
                "a definition expects a string token, got byte 0x{other:02X}"
            )),
        }
    }
}
