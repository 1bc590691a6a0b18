//! Transforms: a prim's `xformOpOrder` composed into its local transform, and the world transform
//! through its ancestors (`!resetXformStack!` cuts the chain), at a time.
//!
//! USD writes matrices for row vectors (`p' = p·M`); here every matrix is a `glam::DMat4` for column
//! vectors (`p' = M·p`), i.e. the transpose. The ops of `xformOpOrder = [a, b, c]` give the local
//! matrix `A·B·C` (in column form): `c` applies to a point first, as in USD.
//!
//! | op | column-vector matrix |
//! |---|---|
//! | `translate` (x, y, z), `translateX/Y/Z` | `T(x, y, z)` |
//! | `scale`, `scaleX/Y/Z` | `S(x, y, z)` |
//! | `rotateX/Y/Z` θ (degrees) | the right-handed rotation about the axis |
//! | `rotateABC` (a, b, c degrees about axes A, B, C) | `R_C(c)·R_B(b)·R_A(a)`: A applies first |
//! | `orient` quaternion (w, x, y, z) | the rotation of the normalised quaternion |
//! | `transform` (row-major, row vectors) | its transpose |
//! | `!invert!` prefix | the inverse |

use glam::{DMat4, DQuat, DVec3};

use crate::UsdError;
use crate::values::{Time, Values};

/// The local transform of `prim` at `time` from its `xformOpOrder`, and whether it resets the
/// transform stack.
pub(crate) fn local(values: &Values<'_>, prim: &str, time: Time) -> Result<(DMat4, bool), UsdError> {
    let order = op_order(values, prim)?;
    let mut m = DMat4::IDENTITY;
    let mut reset = false;
    for (i, op) in order.iter().enumerate() {
        if op == "!resetXformStack!" {
            if i != 0 {
                return Err(UsdError::at(
                    values.file,
                    prim,
                    format!(
                        "xformOpOrder: !resetXformStack! is only allowed first, found at position {}",
                        i + 1
                    ),
                ));
            }
            reset = true;
            continue;
        }
        m *= op_matrix(values, prim, op, time)?;
    }
    Ok((m, reset))
}

/// The ops listed by `xformOpOrder` (empty when unauthored).
pub(crate) fn op_order(values: &Values<'_>, prim: &str) -> Result<Vec<String>, UsdError> {
    use openusd::sdf::Value;
    Ok(match values.raw(prim, "xformOpOrder", Time::Default)? {
        None => Vec::new(),
        Some(Value::TokenVec(v)) => v.iter().map(|t| t.as_str().to_string()).collect(),
        Some(Value::StringVec(v)) => v,
        Some(Value::TokenListOp(op)) => op.flatten().iter().map(|t| t.as_str().to_string()).collect(),
        Some(v) => {
            return Err(values.error(
                prim,
                "xformOpOrder",
                format!("expected a token[], found {}", crate::values::describe(&v)),
            ));
        }
    })
}

/// The world transform of `prim` at `time`: its local transform after its ancestors', unless one on
/// the way resets the stack.
pub(crate) fn world(values: &Values<'_>, prim: &str, time: Time) -> Result<DMat4, UsdError> {
    let mut m = DMat4::IDENTITY;
    let mut path = prim.to_string();
    loop {
        if path == "/" || path.is_empty() {
            break;
        }
        let (l, reset) = local(values, &path, time)?;
        m = l * m;
        if reset {
            break;
        }
        path = match path.rfind('/') {
            Some(0) | None => break,
            Some(i) => path[..i].to_string(),
        };
    }
    Ok(m)
}

/// The time codes at which anything in `prim`'s transform chain is sampled.
pub(crate) fn sample_times(values: &Values<'_>, prim: &str) -> Vec<f64> {
    let mut times = Vec::new();
    let mut path = prim.to_string();
    while path.len() > 1 {
        for op in op_order(values, &path).unwrap_or_default() {
            let name = op.strip_prefix("!invert!").unwrap_or(&op);
            times.extend(values.sample_times(&path, name));
        }
        path = match path.rfind('/') {
            Some(0) | None => break,
            Some(i) => path[..i].to_string(),
        };
    }
    times.sort_by(f64::total_cmp);
    times.dedup();
    times
}

fn op_matrix(values: &Values<'_>, prim: &str, op: &str, time: Time) -> Result<DMat4, UsdError> {
    let (inverted, name) = match op.strip_prefix("!invert!") {
        Some(rest) => (true, rest),
        None => (false, op),
    };
    let kind = name.strip_prefix("xformOp:").unwrap_or(name);
    let kind = kind.split(':').next().unwrap_or(kind);
    let Some(raw) = values.raw(prim, name, time)? else {
        // usd-core skips an op listed in xformOpOrder without its attribute (with a coding error).
        return Ok(DMat4::IDENTITY);
    };
    let bad = |expected: &str| {
        values.error(
            prim,
            name,
            format!("expected {expected}, found {}", crate::values::describe(&raw)),
        )
    };
    let num = || crate::values::scalar(&raw).ok_or_else(|| bad("a number"));
    let vec3 = || {
        crate::values::tuple(&raw)
            .filter(|t| t.len() == 3)
            .map(|t| DVec3::new(t[0], t[1], t[2]))
            .ok_or_else(|| bad("a 3-vector"))
    };
    let axis = |c: char, deg: f64| match c {
        'X' => DMat4::from_rotation_x(deg.to_radians()),
        'Y' => DMat4::from_rotation_y(deg.to_radians()),
        _ => DMat4::from_rotation_z(deg.to_radians()),
    };
    let m = match kind {
        "translate" => DMat4::from_translation(vec3()?),
        "translateX" => DMat4::from_translation(DVec3::new(num()?, 0.0, 0.0)),
        "translateY" => DMat4::from_translation(DVec3::new(0.0, num()?, 0.0)),
        "translateZ" => DMat4::from_translation(DVec3::new(0.0, 0.0, num()?)),
        "scale" => DMat4::from_scale(vec3()?),
        "scaleX" => DMat4::from_scale(DVec3::new(num()?, 1.0, 1.0)),
        "scaleY" => DMat4::from_scale(DVec3::new(1.0, num()?, 1.0)),
        "scaleZ" => DMat4::from_scale(DVec3::new(1.0, 1.0, num()?)),
        "rotateX" => axis('X', num()?),
        "rotateY" => axis('Y', num()?),
        "rotateZ" => axis('Z', num()?),
        "rotateXYZ" | "rotateXZY" | "rotateYXZ" | "rotateYZX" | "rotateZXY" | "rotateZYX" => {
            let v = vec3()?;
            let angle = |c: char| match c {
                'X' => v.x,
                'Y' => v.y,
                _ => v.z,
            };
            let mut m = DMat4::IDENTITY;
            for c in kind["rotate".len()..].chars() {
                m = axis(c, angle(c)) * m;
            }
            m
        }
        "orient" => {
            let q = crate::values::tuple(&raw)
                .filter(|t| t.len() == 4)
                .ok_or_else(|| bad("a quaternion"))?;
            let q = DQuat::from_xyzw(q[1], q[2], q[3], q[0]);
            if q.length() == 0.0 {
                return Err(bad("a non-zero quaternion"));
            }
            DMat4::from_quat(q.normalize())
        }
        "transform" => {
            let m = crate::values::tuple(&raw)
                .filter(|t| t.len() == 16)
                .ok_or_else(|| bad("a matrix4d"))?;
            let mut a = [0.0; 16];
            a.copy_from_slice(&m);
            DMat4::from_cols_array(&a)
        }
        other => {
            return Err(values.error(prim, name, format!("unknown xformOp type '{other}'")));
        }
    };
    if inverted {
        if m.determinant().abs() < 1e-300 {
            return Err(values.error(prim, name, "!invert! of a singular matrix"));
        }
        Ok(m.inverse())
    } else {
        Ok(m)
    }
}

/// The USD (row-vector, row-major) spelling of a column-vector matrix: 16 numbers row by row.
#[must_use]
pub fn to_usd_rows(m: DMat4) -> [f64; 16] {
    m.to_cols_array()
}
