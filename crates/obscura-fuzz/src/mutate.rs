//! The mutations: byte-level edits, the target's dictionary of tokens, numbers at the edges of
//! `f32`/`u32`, and splices of two inputs.

/// A small, fast, seedable generator (xorshift64*): runs are reproducible from their seed.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// A generator seeded with `seed` (0 is replaced, xorshift needs a non-zero state).
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15 | 1)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// A number in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next_u64() % n as u64) as usize
        }
    }
}

/// Numbers that break parsers and the arithmetic behind them.
pub const INTERESTING_NUMBERS: [&str; 24] = [
    "0",
    "-0",
    "1",
    "-1",
    "0.5",
    "1e38",
    "3.5e38",
    "-3.5e38",
    "1e-45",
    "1e-38",
    "1e300",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "65536",
    "65537",
    "4294967295",
    "4294967296",
    "2147483648",
    "-2147483649",
    "1e-300",
    "99999999999999999999",
    "0x10",
];

/// Applies one to four random mutations to `input`; `dictionary` holds the target's tokens and
/// `other` an input to splice from. The result is at most `max_len` bytes.
pub fn mutate(rng: &mut Rng, input: &[u8], other: &[u8], dictionary: &[&str], max_len: usize) -> Vec<u8> {
    mutate_as(rng, input, other, dictionary, false, max_len)
}

/// As [`mutate`]; when `binary`, a third of the mutations insert a binary RIB token (RISpec 3.2
/// appendix C.2: numbers, strings, float arrays, request and string definitions and uses, well-formed
/// or with a count that lies) or overwrite a float with one at the edges of `f32`.
pub fn mutate_as(
    rng: &mut Rng,
    input: &[u8],
    other: &[u8],
    dictionary: &[&str],
    binary: bool,
    max_len: usize,
) -> Vec<u8> {
    let mut out = input.to_vec();
    for _ in 0..1 + rng.below(4) {
        if binary && rng.below(3) == 0 {
            if rng.below(4) == 0 {
                replace_float(rng, &mut out);
            } else {
                // Mostly before a request (0xA6), so the stream around the token stays whole.
                let requests: Vec<usize> = (0..out.len()).filter(|&i| out[i] == 0xA6).collect();
                let at = if requests.is_empty() || rng.below(4) == 0 {
                    rng.below(out.len() + 1)
                } else {
                    requests[rng.below(requests.len())]
                };
                let token = binary_token(rng, dictionary);
                out.splice(at..at, token);
            }
            continue;
        }
        match rng.below(10) {
            0 if !out.is_empty() => {
                let i = rng.below(out.len());
                out[i] ^= 1 << rng.below(8);
            }
            1 if !out.is_empty() => {
                let i = rng.below(out.len());
                out[i] = rng.next_u64() as u8;
            }
            2 => {
                let i = rng.below(out.len() + 1);
                let n = 1 + rng.below(4);
                let bytes: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
                out.splice(i..i, bytes);
            }
            3 if !out.is_empty() => {
                let i = rng.below(out.len());
                let n = 1 + rng.below((out.len() - i).min(64));
                out.drain(i..i + n);
            }
            4 if !out.is_empty() => {
                let i = rng.below(out.len());
                let n = 1 + rng.below((out.len() - i).min(256));
                let piece = out[i..i + n].to_vec();
                let at = rng.below(out.len() + 1);
                out.splice(at..at, piece);
            }
            5 if !dictionary.is_empty() => {
                let token = dictionary[rng.below(dictionary.len())];
                let at = token_boundary(rng, &out);
                let mut piece = token.as_bytes().to_vec();
                piece.push(b' ');
                out.splice(at..at, piece);
            }
            6 => replace_number(rng, &mut out),
            7 if !other.is_empty() => {
                let i = rng.below(other.len());
                let n = 1 + rng.below((other.len() - i).min(512));
                let at = token_boundary(rng, &out);
                out.splice(at..at, other[i..i + n].iter().copied());
            }
            8 if !out.is_empty() => {
                let n = rng.below(out.len());
                out.truncate(n);
            }
            _ => {
                // A whole line repeated: deep nesting, duplicate definitions.
                let lines: Vec<usize> = out
                    .iter()
                    .enumerate()
                    .filter(|(_, b)| **b == b'\n')
                    .map(|(i, _)| i + 1)
                    .collect();
                if lines.len() >= 2 {
                    let k = rng.below(lines.len() - 1);
                    let piece = out[lines[k]..lines[k + 1]].to_vec();
                    for _ in 0..1 + rng.below(8) {
                        out.splice(lines[k]..lines[k], piece.iter().copied());
                    }
                }
            }
        }
    }
    out.truncate(max_len);
    out
}

/// Floats that break binary readers and the arithmetic behind them (big-endian `f32` bits).
const INTERESTING_FLOATS: [u32; 12] = [
    0x0000_0000, // 0
    0x8000_0000, // -0
    0x3F80_0000, // 1
    0xBF80_0000, // -1
    0x7F7F_FFFF, // the largest f32
    0xFF7F_FFFF, // its negative
    0x0000_0001, // the smallest subnormal
    0x0080_0000, // the smallest normal
    0x7F80_0000, // inf
    0xFF80_0000, // -inf
    0x7FC0_0000, // NaN
    0x4B80_0000, // 2^24
];

/// One binary RIB token, mostly well-formed: the reader should get past it to the requests.
fn binary_token(rng: &mut Rng, dictionary: &[&str]) -> Vec<u8> {
    let random = |rng: &mut Rng, n: usize| -> Vec<u8> { (0..n).map(|_| rng.next_u64() as u8).collect() };
    let string = |rng: &mut Rng, s: &[u8]| -> Vec<u8> {
        let mut out = if s.len() < 16 && rng.below(4) != 0 {
            vec![0x90 + s.len() as u8]
        } else {
            vec![0xA0, s.len().min(255) as u8]
        };
        out.extend_from_slice(&s[..s.len().min(255)]);
        out
    };
    let word = |rng: &mut Rng| -> Vec<u8> {
        if dictionary.is_empty() {
            b"Sphere".to_vec()
        } else {
            dictionary[rng.below(dictionary.len())]
                .trim_matches('"')
                .as_bytes()
                .to_vec()
        }
    };
    let code = |rng: &mut Rng| {
        if rng.below(8) == 0 {
            rng.next_u64() as u8
        } else {
            rng.below(4) as u8
        }
    };
    match rng.below(10) {
        // An integer or fixed-point number of 1-4 bytes.
        0 => {
            let b = 0x80 + rng.below(16) as u8;
            let mut out = vec![b];
            out.extend(random(rng, usize::from(b & 3) + 1));
            out
        }
        1 | 2 => {
            let mut out = vec![if rng.below(8) == 0 { 0xA5 } else { 0xA4 }];
            let bits = INTERESTING_FLOATS[rng.below(INTERESTING_FLOATS.len())];
            if out[0] == 0xA5 {
                out.extend(f64::from(f32::from_bits(bits)).to_be_bytes());
            } else {
                out.extend(bits.to_be_bytes());
            }
            out
        }
        3 => {
            let w = word(rng);
            string(rng, &w)
        }
        // A float array; now and then its count lies.
        4 => {
            let n = rng.below(17);
            let count = if rng.below(6) == 0 { rng.below(256) } else { n };
            let mut out = vec![0xC8, count as u8];
            for _ in 0..n {
                let bits = if rng.below(4) == 0 {
                    INTERESTING_FLOATS[rng.below(INTERESTING_FLOATS.len())]
                } else {
                    (rng.below(2000) as f32 / 100.0 - 10.0).to_bits()
                };
                out.extend(bits.to_be_bytes());
            }
            out
        }
        // A request defined, and used.
        5 => {
            let c = code(rng);
            let mut out = vec![0xCC, c];
            let w = word(rng);
            out.extend(string(rng, &w));
            out.extend([0xA6, c]);
            out
        }
        6 => vec![0xA6, code(rng)],
        // A string id defined, or used.
        7 => {
            let mut out = vec![0xCD, code(rng)];
            let w = word(rng);
            out.extend(string(rng, &w));
            out
        }
        8 => vec![0xCF, code(rng)],
        // Any byte from 0x80 up: the reserved ones too.
        _ => {
            let mut out = vec![0x80 | rng.next_u64() as u8];
            let n = rng.below(5);
            out.extend(random(rng, n));
            out
        }
    }
}

/// Overwrites the four bytes after a float token (0xA4) with one of [`INTERESTING_FLOATS`].
fn replace_float(rng: &mut Rng, out: &mut [u8]) {
    let starts: Vec<usize> = (0..out.len().saturating_sub(4))
        .filter(|&i| out[i] == 0xA4)
        .collect();
    if starts.is_empty() {
        return;
    }
    let s = starts[rng.below(starts.len())] + 1;
    let bits = INTERESTING_FLOATS[rng.below(INTERESTING_FLOATS.len())];
    out[s..s + 4].copy_from_slice(&bits.to_be_bytes());
}

/// A position just after whitespace or a bracket (or a random one), so inserted tokens stay tokens.
fn token_boundary(rng: &mut Rng, bytes: &[u8]) -> usize {
    let at = rng.below(bytes.len() + 1);
    (at..bytes.len())
        .find(|&i| matches!(bytes[i], b' ' | b'\n' | b'[' | b',' | b'{'))
        .map_or(at, |i| i + 1)
}

/// Replaces a run of digits (a number) with one of [`INTERESTING_NUMBERS`].
fn replace_number(rng: &mut Rng, out: &mut Vec<u8>) {
    let starts: Vec<usize> = (0..out.len())
        .filter(|&i| out[i].is_ascii_digit() && (i == 0 || !out[i - 1].is_ascii_alphanumeric()))
        .collect();
    if starts.is_empty() {
        return;
    }
    let s = starts[rng.below(starts.len())];
    let e = (s..out.len())
        .find(|&i| !(out[i].is_ascii_digit() || matches!(out[i], b'.' | b'e' | b'E' | b'-' | b'+')))
        .unwrap_or(out.len());
    let n = INTERESTING_NUMBERS[rng.below(INTERESTING_NUMBERS.len())];
    out.splice(s..e, n.bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_are_reproducible_and_bounded() {
        let seed = b"Format 64 48 1\nWorldBegin\nSphere 1 -1 1 360\n".to_vec();
        let run = |s| {
            let mut rng = Rng::new(s);
            (0..200)
                .map(|_| mutate(&mut rng, &seed, b"Translate 1 2 3\n", &["Scale"], 100))
                .collect::<Vec<_>>()
        };
        assert_eq!(run(7), run(7));
        assert_ne!(run(7), run(8));
        assert!(run(7).iter().all(|m| m.len() <= 100));
        assert!(run(7).iter().any(|m| m != &seed));
        let mut rng = Rng::new(1);
        assert!((0..1000).all(|_| rng.below(3) < 3));
        assert_eq!(rng.below(0), 0);
    }

    #[test]
    fn binary_mutations_insert_encoded_tokens_and_edge_floats() {
        // Format 8 6 1 in binary RIB, with a float32 pixel aspect.
        let seed = [
            0xCC, 0, 0x96, b'F', b'o', b'r', b'm', b'a', b't', 0xA6, 0, 0x81, 0, 8, 0x81, 0, 6, 0xA4, 0x3F,
            0x80, 0, 0,
        ];
        let mut rng = Rng::new(5);
        let out: Vec<Vec<u8>> = (0..500)
            .map(|_| mutate_as(&mut rng, &seed, &seed, &["Sphere"], true, 64))
            .collect();
        assert!(out.iter().all(|m| m.len() <= 64));
        // Request definitions with a dictionary name, and edge floats written over the aspect.
        assert!(out.iter().any(|m| {
            m.windows(8)
                .any(|w| w == [0xCC, w[1], 0x96, b'S', b'p', b'h', b'e', b'r'])
        }));
        assert!(out.iter().any(|m| {
            m.windows(5)
                .any(|w| w[0] == 0xA4 && w[1..] == 0x7FC0_0000u32.to_be_bytes())
        }));
    }

    #[test]
    fn numbers_are_replaced_whole() {
        let mut rng = Rng::new(3);
        let mut v = b"Format 640 480".to_vec();
        replace_number(&mut rng, &mut v);
        let text = String::from_utf8(v).unwrap();
        assert!(text.starts_with("Format "), "{text}");
        assert!(INTERESTING_NUMBERS.iter().any(|n| text.contains(n)), "{text}");
    }
}
