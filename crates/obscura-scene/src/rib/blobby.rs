//! `Blobby nleaf [code] [floats] [strings]`: the program read into [`BlobOp`]s, checked (every
//! index in range, every operand an earlier instruction). Repellers (`1003`) and dynamic blob
//! operators (`1004`+, `8000`+) stop with a message naming the opcode.

use glam::{Mat4, Vec3};

use super::geometry::with_primitive_variables;
use super::lex::Value;
use super::request::Req;
use super::{Reader, RibError};
use crate::classic::{BlobOp, Blobby};
use crate::types::Shape;

impl Reader {
    /// `Blobby`.
    pub(super) fn blobby(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Num(_), code, floats, rest @ ..] = r.args else {
            return Err(r.err("Blobby expects nleaf [code] [floats] [strings] then parameters"));
        };
        let code = r.indices(code, "[code]")?;
        let floats: Vec<f32> = match floats {
            Value::Nums(v) => v.iter().map(|n| n.value as f32).collect(),
            _ => return Err(r.err("Blobby: [floats] must be an array of numbers")),
        };
        let rest = match rest {
            [Value::Strs(_) | Value::Nums(_), more @ ..] => more,
            _ => rest,
        };
        let list = self.params(r, rest, &with_primitive_variables(&[]), false)?;
        self.primitive_color(r, &list);
        let ops = program(r, &code, &floats)?;
        self.add_object(r, Shape::Blobby(Blobby { ops }));
        Ok(())
    }
}

/// Decodes the program.
fn program(r: &Req<'_>, code: &[i64], floats: &[f32]) -> Result<Vec<BlobOp>, RibError> {
    let mut ops = Vec::new();
    let mut pc = 0usize;
    let word = |pc: usize| {
        code.get(pc)
            .copied()
            .ok_or_else(|| r.err(format!("Blobby: [code] ends inside an instruction at word {pc}")))
    };
    let float_run = |at: i64, n: usize| {
        usize::try_from(at)
            .ok()
            .and_then(|a| floats.get(a..a.checked_add(n)?))
            .ok_or_else(|| {
                r.err(format!(
                    "Blobby: float index {at} (+{n}) is outside [floats] ({} values)",
                    floats.len()
                ))
            })
    };
    let operand = |v: i64, count: usize| {
        u32::try_from(v)
            .ok()
            .filter(|&k| (k as usize) < count)
            .ok_or_else(|| r.err(format!("Blobby: operand {v} is not an earlier instruction")))
    };
    while pc < code.len() {
        let op = word(pc)?;
        pc += 1;
        let n = ops.len();
        let decoded = match op {
            1000 => BlobOp::Constant(float_run(word(pc)?, 1)?[0]),
            1001 => BlobOp::Ellipsoid(Mat4::from_cols_slice(float_run(word(pc)?, 16)?)),
            1002 => {
                let f = float_run(word(pc)?, 23)?;
                BlobOp::Segment {
                    start: Vec3::from_slice(&f[0..3]),
                    end: Vec3::from_slice(&f[3..6]),
                    radius: f[6],
                    matrix: Mat4::from_cols_slice(&f[7..23]),
                }
            }
            0..=3 => {
                let count = usize::try_from(word(pc)?).unwrap_or(usize::MAX);
                if count > code.len() {
                    return Err(r.err(format!("Blobby: an operation claims {count} operands")));
                }
                let operands = (0..count)
                    .map(|k| operand(word(pc + 1 + k)?, n))
                    .collect::<Result<Vec<_>, _>>()?;
                pc += count;
                BlobOp::Combine {
                    kind: op as u8,
                    operands,
                }
            }
            4 | 5 => {
                let (a, b) = (operand(word(pc)?, n)?, operand(word(pc + 1)?, n)?);
                pc += 1;
                BlobOp::Binary { kind: op as u8, a, b }
            }
            6 | 7 => BlobOp::Unary {
                kind: op as u8,
                a: operand(word(pc)?, n)?,
            },
            other => {
                return Err(r.err(format!(
                    "Blobby: opcode {other} is not supported (supported: 1000 constant, 1001 ellipsoid, 1002 segment, 0–7 operations)"
                )));
            }
        };
        // Every instruction above has one word after its opcode (index, count or operand).
        pc += 1;
        ops.push(decoded);
    }
    Ok(ops)
}
