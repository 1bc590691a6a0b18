//! `Curves` (linear and cubic, periodic or not, in the current `v` basis) as ribbons, and `Points` as
//! discs facing the camera.
//!
//! Each curve is cut into segments as the spec says (linear: `n − 1`, periodic `n`; cubic:
//! `(n − 4)/vstep + 1`, periodic `n/vstep`), every segment converted exactly to cubic Bézier form.
//! `"width"` is varying (one value per segment end: `Σ (segments + 1)`, periodic `Σ segments`),
//! `"constantwidth"` constant, default 1; `"N"` (varying) turns the ribbon to face it, otherwise it
//! faces the camera.

use glam::Vec3;

use super::geometry::with_primitive_variables;
use super::lex::Value;
use super::patch::bezier_points;
use super::request::{Req, get_float, get_floats, to_points};
use super::{Reader, RibError};
use crate::classic::{CurveSegment, Curves, Points};
use crate::types::Shape;

/// The parameters `Curves` and `Points` read besides the primitive variables.
const TABLE: [&str; 3] = ["vertex point P", "vertex float width", "float constantwidth"];

impl Reader {
    /// `Curves "linear"|"cubic" [nvertices] "nonperiodic"|"periodic" "P" [...]`.
    pub(super) fn curves(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(kind), counts, Value::Str(wrap), rest @ ..] = r.args else {
            return Err(r.err(
                "Curves expects \"linear\"|\"cubic\" [nvertices] \"nonperiodic\"|\"periodic\" then \"P\" [...]",
            ));
        };
        let cubic = match kind.as_str() {
            "linear" => false,
            "cubic" => true,
            other => return Err(r.err(format!("Curves: type \"{other}\" is not \"linear\" or \"cubic\""))),
        };
        let periodic = match wrap.as_str() {
            "periodic" => true,
            "nonperiodic" => false,
            other => {
                return Err(r.err(format!(
                    "Curves: wrap \"{other}\" is not \"periodic\" or \"nonperiodic\""
                )));
            }
        };
        let counts = r.counts(counts, "[nvertices]")?;
        let list = self.params(r, rest, &with_primitive_variables(&TABLE), false)?;
        self.primitive_color(r, &list);
        let points = get_floats(&list, "P")
            .map(to_points)
            .ok_or_else(|| r.err("Curves: the positions \"P\" are missing"))?;
        let total = counts.iter().fold(0usize, |a, &n| a.saturating_add(n));
        if total != points.len() {
            return Err(r.err(format!(
                "Curves: [nvertices] adds up to {total} but \"P\" has {} points",
                points.len()
            )));
        }
        let step = if cubic {
            self.classic.basis.v.step.max(1)
        } else {
            1
        };
        // Segments per curve and the start of each curve's points.
        let mut segs = Vec::with_capacity(counts.len());
        for (k, &n) in counts.iter().enumerate() {
            let s = match (cubic, periodic) {
                (false, false) => n.checked_sub(1),
                (false, true) => Some(n),
                (true, false) => n.checked_sub(4).map(|m| m / step + 1),
                (true, true) => Some(n / step),
            };
            match s {
                Some(s) if s > 0 => segs.push(s),
                _ => {
                    return Err(r.err(format!(
                        "Curves: curve {k} has {n} vertices, too few for one {kind} segment"
                    )));
                }
            }
        }
        let varying: usize = segs.iter().map(|&s| if periodic { s } else { s + 1 }).sum();
        let widths = match get_floats(&list, "width") {
            Some(w) if w.len() == varying => Some(w.to_vec()),
            Some(w) => {
                return Err(r.err(format!(
                    "Curves: \"width\" has {} values; {varying} expected (one per segment end)",
                    w.len()
                )));
            }
            None => None,
        };
        let constant = get_float(&list, "constantwidth").unwrap_or(1.0);
        let normals = match get_floats(&list, "N").map(to_points) {
            Some(n) if n.len() == varying => Some(n),
            Some(n) => {
                return Err(r.err(format!(
                    "Curves: \"N\" has {} normals; {varying} expected (one per segment end)",
                    n.len()
                )));
            }
            None => None,
        };
        let conv = self.classic.basis.v.to_bezier();
        let mut out = Vec::new();
        let (mut first_point, mut first_varying) = (0usize, 0usize);
        for (&n, &s) in counts.iter().zip(&segs) {
            let ends = if periodic { s } else { s + 1 };
            for k in 0..s {
                let p = |i: usize| points[first_point + (i % n)];
                let control = if cubic {
                    let i = k * step;
                    bezier_points(&conv, [p(i), p(i + 1), p(i + 2), p(i + 3)])
                } else {
                    let (a, b) = (p(k), p(k + 1));
                    [a, a + (b - a) / 3.0, a + (b - a) * (2.0 / 3.0), b]
                };
                let end = |j: usize| first_varying + (j % ends);
                out.push(CurveSegment {
                    points: control,
                    widths: match &widths {
                        Some(w) => [w[end(k)], w[end(k + 1)]],
                        None => [constant; 2],
                    },
                    normals: normals.as_ref().map(|nn| [nn[end(k)], nn[end(k + 1)]]),
                });
            }
            first_point += n;
            first_varying += ends;
        }
        self.add_object(r, Shape::Curves(Curves { segments: out }));
        Ok(())
    }

    /// `Points "P" [...]` with `"width"` or `"constantwidth"`.
    pub(super) fn points(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        // Particle exporters write a frame without particles as `Points "P" []`: nothing to draw.
        let empty = |v: &Value| matches!(v, Value::Nums(n) if n.is_empty());
        if let [Value::Str(p), v, ..] = r.args
            && p.split_whitespace().last() == Some("P")
            && empty(v)
        {
            self.warn(r, "Points: \"P\" is empty; nothing to draw".into());
            return Ok(());
        }
        let list = self.params(r, r.args, &with_primitive_variables(&TABLE), false)?;
        self.primitive_color(r, &list);
        let positions: Vec<Vec3> = get_floats(&list, "P")
            .map(to_points)
            .ok_or_else(|| r.err("Points: the positions \"P\" are missing"))?;
        let widths = match get_floats(&list, "width") {
            Some(w) if w.len() == positions.len() => w.to_vec(),
            Some(w) => {
                return Err(r.err(format!(
                    "Points: \"width\" has {} values for {} points",
                    w.len(),
                    positions.len()
                )));
            }
            None => vec![get_float(&list, "constantwidth").unwrap_or(1.0); positions.len()],
        };
        self.add_object(r, Shape::Points(Points { positions, widths }));
        Ok(())
    }
}
