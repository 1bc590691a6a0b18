//! `NuPatch` (rational B-spline surfaces) and `TrimCurve` (warned about: patches are drawn
//! untrimmed).

use super::geometry::with_primitive_variables;
use super::lex::Value;
use super::request::{Req, get_floats};
use super::{Reader, RibError};
use crate::classic::{NuPatch, NurbsAxis};
use crate::types::Shape;

impl Reader {
    /// `NuPatch nu uorder [uknot] umin umax nv vorder [vknot] vmin vmax "Pw"|"P" [...]`.
    pub(super) fn nu_patch(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [
            nu,
            uorder,
            uknot,
            umin,
            umax,
            nv,
            vorder,
            vknot,
            vmin,
            vmax,
            rest @ ..,
        ] = r.args
        else {
            return Err(r.err(
                "NuPatch expects nu uorder [uknot] umin umax nv vorder [vknot] vmin vmax then \"Pw\" [...]",
            ));
        };
        let u = axis(r, "u", [nu, uorder, uknot, umin, umax])?;
        let v = axis(r, "v", [nv, vorder, vknot, vmin, vmax])?;
        let table = with_primitive_variables(&["vertex hpoint Pw", "vertex point P"]);
        let list = self.params(r, rest, &table, false)?;
        self.primitive_color(r, &list);
        let points: Vec<[f32; 4]> = if let Some(p) = get_floats(&list, "Pw") {
            p.chunks_exact(4).map(|q| [q[0], q[1], q[2], q[3]]).collect()
        } else if let Some(p) = get_floats(&list, "P") {
            p.chunks_exact(3).map(|q| [q[0], q[1], q[2], 1.0]).collect()
        } else {
            return Err(r.err("NuPatch: the positions \"Pw\" (or \"P\") are missing"));
        };
        let need = u.count as usize * v.count as usize;
        if points.len() != need {
            return Err(r.err(format!(
                "NuPatch: {} control points given, {need} expected ({} × {})",
                points.len(),
                u.count,
                v.count
            )));
        }
        if let Some(k) = points.iter().position(|p| {
            p[3].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !p.iter().all(|x| x.is_finite())
        }) {
            return Err(r.err(format!(
                "NuPatch: control point {k} has a weight that is not positive or a coordinate that is not finite"
            )));
        }
        self.add_object(r, Shape::NuPatch(NuPatch { u, v, points }));
        Ok(())
    }

    /// `TrimCurve`: trimming is not supported; the patches it would trim are drawn whole.
    pub(super) fn trim_curve(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        self.warn_once(
            r,
            "trim",
            "TrimCurve is not supported: NuPatch surfaces are drawn untrimmed".into(),
        );
        Ok(())
    }
}

/// One direction of a `NuPatch`: `n order [knots] min max`, checked against the spec's rules.
fn axis(r: &Req<'_>, name: &str, args: [&Value; 5]) -> Result<NurbsAxis, RibError> {
    let [n, order, knots, min, max] = args;
    let int = |v: &Value, what: &str| match v {
        Value::Num(x) if x.value >= 1.0 && x.value.fract() == 0.0 && x.value < 1e7 => Ok(x.value as u32),
        _ => Err(r.err(format!("NuPatch: {name}{what} must be a positive integer"))),
    };
    let num = |v: &Value, what: &str| match v {
        Value::Num(x) if x.value.is_finite() => Ok(x.value as f32),
        _ => Err(r.err(format!("NuPatch: {name}{what} must be a number"))),
    };
    let (count, order) = (int(n, "")?, int(order, "order")?);
    if order > count {
        return Err(r.err(format!(
            "NuPatch: {name}order {order} is more than the {count} control points in {name}"
        )));
    }
    let knots: Vec<f32> = match knots {
        Value::Nums(k) => k.iter().map(|x| x.value as f32).collect(),
        _ => return Err(r.err(format!("NuPatch: [{name}knot] must be an array of numbers"))),
    };
    if knots.len() != (count + order) as usize {
        return Err(r.err(format!(
            "NuPatch: [{name}knot] has {} knots; {name} + {name}order = {} expected",
            knots.len(),
            count + order
        )));
    }
    if !knots.iter().all(|k| k.is_finite()) || knots.windows(2).any(|w| w[1] < w[0]) {
        return Err(r.err(format!("NuPatch: [{name}knot] must be finite and non-decreasing")));
    }
    let (lo, hi) = (knots[order as usize - 1], knots[count as usize]);
    let (min, max) = (num(min, "min")?.max(lo), num(max, "max")?.min(hi));
    if min.partial_cmp(&max) != Some(std::cmp::Ordering::Less) {
        return Err(r.err(format!(
            "NuPatch: {name}min..{name}max is empty within the knots' range {lo}..{hi}"
        )));
    }
    Ok(NurbsAxis {
        count,
        order,
        knots,
        min,
        max,
    })
}
