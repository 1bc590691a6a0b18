//! `Basis`, `Patch`, `PatchMesh` and `Geometry "teapot"`: every patch becomes a bicubic Bézier patch.
//!
//! A cubic basis `M` (with the RenderMan Interface's convention `P(t) = [t³ t² t 1]·M·G`) is
//! converted exactly: with `B` the Bézier matrix, the Bézier control points are `C·G` with
//! `C = B⁻¹·M`, in `u` and in `v`. A bilinear patch is degree-elevated exactly (its Bézier points lie
//! at thirds). `PatchMesh` cuts its `nu × nv` points into patches as the spec says: bicubic
//! `(n − 4)/step + 1` patches per direction when nonperiodic, `n/step` when periodic (indices wrap);
//! bilinear `n − 1` or `n`. `"Pz"` gives a height field over `(u, v) ∈ [0, 1]²` of the whole mesh;
//! `"Pw"` points are divided by `w` (exact for `w = 1`; a rational patch is approximated, with a
//! warning).
//!
//! Texture coordinates are the RI's `varying` ones: one `(s, t)` per patch corner (`"st"`, or `"s"`
//! and `"t"`), `(nu_p + 1) × (nv_p + 1)` of them on a nonperiodic mesh of `nu_p × nv_p` patches (one
//! fewer per periodic direction), interpolated bilinearly over each patch; without them `s = u`,
//! `t = v` over the whole mesh, `(u, v)` running over `[0, 1]²` as the spec says.

use glam::{Vec2, Vec3};

use super::geometry::with_primitive_variables;
use super::lex::Value;
use super::request::{Req, get_floats};
use super::teapot::TEAPOT;
use super::{Reader, RibError};
use crate::classic::BezierPatch;
use crate::types::Shape;

/// A cubic basis matrix, row-major, and its step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct CubicBasis {
    /// `M`, row-major (`P(t) = [t³ t² t 1]·M·G`).
    pub(super) matrix: [[f64; 4]; 4],
    /// How many control points one patch advances by.
    pub(super) step: usize,
}

/// `Basis`: the bases in `u` and `v` (attribute state).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Basis {
    /// The `u` basis.
    pub(super) u: CubicBasis,
    /// The `v` basis (also the basis of cubic `Curves`).
    pub(super) v: CubicBasis,
}

/// The Bézier matrix.
const BEZIER: [[f64; 4]; 4] = [
    [-1.0, 3.0, -3.0, 1.0],
    [3.0, -6.0, 3.0, 0.0],
    [-3.0, 3.0, 0.0, 0.0],
    [1.0, 0.0, 0.0, 0.0],
];

/// `B⁻¹`: rows are the Bézier control points' coordinates in the power basis (`B⁻¹·B = I`).
const BEZIER_INVERSE: [[f64; 4]; 4] = [
    [0.0, 0.0, 0.0, 1.0],
    [0.0, 0.0, 1.0 / 3.0, 1.0],
    [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0],
    [1.0, 1.0, 1.0, 1.0],
];

impl Default for Basis {
    fn default() -> Self {
        let bezier = CubicBasis {
            matrix: BEZIER,
            step: 3,
        };
        Basis { u: bezier, v: bezier }
    }
}

/// The named bases of the RenderMan Interface with their default steps.
fn named_basis(name: &str) -> Option<CubicBasis> {
    let sixth = 1.0 / 6.0;
    let (m, step): ([[f64; 4]; 4], usize) = match name {
        "bezier" => (BEZIER, 3),
        "b-spline" | "bspline" => (
            [
                [-sixth, 0.5, -0.5, sixth],
                [0.5, -1.0, 0.5, 0.0],
                [-0.5, 0.0, 0.5, 0.0],
                [sixth, 4.0 * sixth, sixth, 0.0],
            ],
            1,
        ),
        "catmull-rom" | "catmullrom" => (
            [
                [-0.5, 1.5, -1.5, 0.5],
                [1.0, -2.5, 2.0, -0.5],
                [-0.5, 0.0, 0.5, 0.0],
                [0.0, 1.0, 0.0, 0.0],
            ],
            1,
        ),
        "hermite" => (
            [
                [2.0, 1.0, -2.0, 1.0],
                [-3.0, -2.0, 3.0, -1.0],
                [0.0, 1.0, 0.0, 0.0],
                [1.0, 0.0, 0.0, 0.0],
            ],
            2,
        ),
        "power" => (
            [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 0.0, 0.0, 1.0],
            ],
            4,
        ),
        _ => return None,
    };
    Some(CubicBasis { matrix: m, step })
}

impl CubicBasis {
    /// `C = B⁻¹·M`: Bézier control point `i` is `Σₖ C[i][k]·G[k]`.
    pub(super) fn to_bezier(self) -> [[f64; 4]; 4] {
        let mut c = [[0.0; 4]; 4];
        for (i, row) in c.iter_mut().enumerate() {
            for (k, out) in row.iter_mut().enumerate() {
                *out = (0..4).map(|j| BEZIER_INVERSE[i][j] * self.matrix[j][k]).sum();
            }
        }
        c
    }
}

/// The four Bézier control points of the cubic whose geometry vector is `g` in the basis whose
/// conversion matrix is `c` ([`CubicBasis::to_bezier`]).
pub(super) fn bezier_points(c: &[[f64; 4]; 4], g: [Vec3; 4]) -> [Vec3; 4] {
    std::array::from_fn(|i| {
        let p = (0..4).fold(glam::DVec3::ZERO, |acc, k| acc + c[i][k] * g[k].as_dvec3());
        p.as_vec3()
    })
}

/// A bicubic patch from its 16 points (`u` fastest) in the bases `cu`, `cv` (conversion matrices).
fn bicubic(cu: &[[f64; 4]; 4], cv: &[[f64; 4]; 4], g: &[Vec3; 16]) -> BezierPatch {
    // Convert the rows (u) first, then the columns (v).
    let mut rows = [Vec3::ZERO; 16];
    for j in 0..4 {
        let b = bezier_points(cu, [g[4 * j], g[4 * j + 1], g[4 * j + 2], g[4 * j + 3]]);
        rows[4 * j..4 * j + 4].copy_from_slice(&b);
    }
    let mut points = [Vec3::ZERO; 16];
    for i in 0..4 {
        let b = bezier_points(cv, [rows[i], rows[4 + i], rows[8 + i], rows[12 + i]]);
        for (j, p) in b.into_iter().enumerate() {
            points[4 * j + i] = p;
        }
    }
    BezierPatch::new(points)
}

/// A bilinear patch (`(0,0) (1,0) (0,1) (1,1)`) as an exact bicubic Bézier patch.
fn bilinear(p: [Vec3; 4]) -> BezierPatch {
    let points = std::array::from_fn(|k| {
        let (u, v) = ((k % 4) as f32 / 3.0, (k / 4) as f32 / 3.0);
        (p[0] * (1.0 - u) + p[1] * u) * (1.0 - v) + (p[2] * (1.0 - u) + p[3] * u) * v
    });
    BezierPatch::new(points)
}

/// Patches along one direction of a mesh of `n` points: their first point indices.
fn patch_starts(n: usize, periodic: bool, cubic: bool, step: usize) -> Option<Vec<usize>> {
    let step = step.max(1);
    let count = match (cubic, periodic) {
        (false, false) => n.checked_sub(1)?,
        (false, true) => n,
        (true, false) => (n.checked_sub(4)? / step) + 1,
        (true, true) => n / step,
    };
    let s = if cubic { step } else { 1 };
    (count > 0).then(|| (0..count).map(|k| k * s).collect())
}

impl Reader {
    /// `Basis ubasis ustep vbasis vstep`: each basis a name or 16 numbers.
    pub(super) fn basis(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let read = |v: &Value, step: &Value| -> Result<CubicBasis, RibError> {
            let mut b = match v {
                Value::Str(name) => named_basis(name).ok_or_else(|| {
                    r.err(format!(
                        "Basis: unknown basis \"{name}\"; expected bezier, b-spline, catmull-rom, hermite, power or 16 numbers"
                    ))
                })?,
                Value::Nums(n) if n.len() == 16 => CubicBasis {
                    matrix: std::array::from_fn(|i| std::array::from_fn(|j| n[4 * i + j].value)),
                    step: 3,
                },
                _ => return Err(r.err("Basis: a basis is a name or 16 numbers")),
            };
            b.step = match step {
                Value::Num(s) if s.value >= 1.0 && s.value.fract() == 0.0 => s.value as usize,
                _ => return Err(r.err("Basis: a step is a positive integer")),
            };
            Ok(b)
        };
        let [u, ustep, v, vstep] = r.args else {
            return Err(
                r.err("Basis expects ubasis ustep vbasis vstep, e.g. Basis \"bezier\" 3 \"bezier\" 3")
            );
        };
        self.classic.basis = Basis {
            u: read(u, ustep)?,
            v: read(v, vstep)?,
        };
        Ok(())
    }

    /// The control points of a patch request: `"P"`, `"Pw"` (divided by w) or `"Pz"` (a height
    /// field on the `cols × rows` grid over `[0, 1]²`); and its varying texture coordinates
    /// (`"st"`, or `"s"` and `"t"`), unchecked, when given.
    fn patch_points(
        &mut self,
        r: &Req<'_>,
        rest: &[Value],
        cols: usize,
        rows: usize,
    ) -> Result<(Vec<Vec3>, Option<Vec<Vec2>>), RibError> {
        let table = with_primitive_variables(&["vertex point P", "vertex hpoint Pw", "vertex float Pz"]);
        let list = self.params(r, rest, &table, false)?;
        let st = match (
            get_floats(&list, "st"),
            get_floats(&list, "s"),
            get_floats(&list, "t"),
        ) {
            (Some(st), _, _) => Some(
                st.chunks(2)
                    .map(|c| Vec2::new(c[0], c.get(1).copied().unwrap_or(f32::NAN)))
                    .collect(),
            ),
            (None, Some(s), Some(t)) if s.len() == t.len() => {
                Some(s.iter().zip(t).map(|(&s, &t)| Vec2::new(s, t)).collect())
            }
            (None, Some(s), Some(t)) => {
                return Err(r.err(format!(
                    "{}: \"s\" has {} values and \"t\" {}; they pair up, one (s, t) per patch corner",
                    r.name,
                    s.len(),
                    t.len()
                )));
            }
            _ => None,
        };
        self.primitive_color(r, &list);
        let need = cols * rows;
        let points: Vec<Vec3> = if let Some(p) = get_floats(&list, "P") {
            p.chunks_exact(3).map(Vec3::from_slice).collect()
        } else if let Some(p) = get_floats(&list, "Pw") {
            if p.chunks_exact(4).any(|q| q[3] != 1.0) {
                self.warn_once(
                    r,
                    "rational patch",
                    format!("{}: rational (\"Pw\" with w ≠ 1) patches are drawn through their points divided by w", r.name),
                );
            }
            p.chunks_exact(4)
                .map(|q| Vec3::new(q[0], q[1], q[2]) / q[3])
                .collect()
        } else if let Some(z) = get_floats(&list, "Pz") {
            let den = |n: usize| (n.max(2) - 1) as f32;
            z.iter()
                .enumerate()
                .map(|(k, &z)| Vec3::new((k % cols) as f32 / den(cols), (k / cols) as f32 / den(rows), z))
                .collect()
        } else {
            return Err(r.err(format!(
                "{}: the positions \"P\" (or \"Pw\", \"Pz\") are missing",
                r.name
            )));
        };
        if points.len() != need {
            return Err(r.err(format!(
                "{}: {} control points given, {need} expected ({cols} × {rows})",
                r.name,
                points.len()
            )));
        }
        Ok((points, st))
    }

    /// `Patch "bilinear"|"bicubic" "P" [...]`.
    pub(super) fn patch(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(kind), rest @ ..] = r.args else {
            return Err(r.err("Patch expects \"bilinear\" or \"bicubic\" then \"P\" [...]"));
        };
        let (mut patch, st) = match kind.as_str() {
            "bilinear" => {
                let (p, st) = self.patch_points(r, rest, 2, 2)?;
                (bilinear([p[0], p[1], p[2], p[3]]), st)
            }
            "bicubic" => {
                let (p, st) = self.patch_points(r, rest, 4, 4)?;
                let g: [Vec3; 16] = std::array::from_fn(|k| p[k]);
                let patch = bicubic(
                    &self.classic.basis.u.to_bezier(),
                    &self.classic.basis.v.to_bezier(),
                    &g,
                );
                (patch, st)
            }
            other => {
                return Err(r.err(format!(
                    "Patch: type \"{other}\" is not one of \"bilinear\", \"bicubic\""
                )));
            }
        };
        if let Some(st) = st {
            patch.st = corner_st(r, &st, (1, false), (1, false))?[0];
        }
        self.add_object(r, Shape::Patches(vec![patch]));
        Ok(())
    }

    /// `PatchMesh type nu uwrap nv vwrap "P" [...]`.
    pub(super) fn patch_mesh(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [
            Value::Str(kind),
            nu,
            Value::Str(uwrap),
            nv,
            Value::Str(vwrap),
            rest @ ..,
        ] = r.args
        else {
            return Err(r.err(
                "PatchMesh expects type nu uwrap nv vwrap then \"P\" [...], e.g. PatchMesh \"bicubic\" 7 \"nonperiodic\" 4 \"nonperiodic\" \"P\" [...]",
            ));
        };
        let count = |v: &Value, what: &str| match v {
            Value::Num(n) if n.value >= 1.0 && n.value.fract() == 0.0 && n.value < 1e8 => {
                Ok(n.value as usize)
            }
            _ => Err(r.err(format!("PatchMesh: {what} must be a positive integer"))),
        };
        let (nu, nv) = (count(nu, "nu")?, count(nv, "nv")?);
        // `wrap`/`nowrap` are the RenderMan Interface's older names (RI_WRAP, RI_NOWRAP in ri.h).
        let wrap = |w: &str| match w {
            "periodic" | "wrap" => Ok(true),
            "nonperiodic" | "nowrap" => Ok(false),
            other => Err(r.err(format!(
                "PatchMesh: wrap \"{other}\" is not \"periodic\" or \"nonperiodic\""
            ))),
        };
        let (uper, vper) = (wrap(uwrap)?, wrap(vwrap)?);
        let cubic = match kind.as_str() {
            "bicubic" => true,
            "bilinear" => false,
            other => {
                return Err(r.err(format!(
                    "PatchMesh: type \"{other}\" is not one of \"bilinear\", \"bicubic\""
                )));
            }
        };
        let (points, st) = self.patch_points(r, rest, nu, nv)?;
        let (Some(us), Some(vs)) = (
            patch_starts(nu, uper, cubic, self.classic.basis.u.step),
            patch_starts(nv, vper, cubic, self.classic.basis.v.step),
        ) else {
            return Err(r.err(format!(
                "PatchMesh: {nu} × {nv} points make no {kind} patch (a nonperiodic bicubic direction needs at least 4)"
            )));
        };
        let mut patches = mesh_patches(&points, nu, nv, &us, &vs, cubic.then_some(self.classic.basis));
        let st = match st {
            Some(st) => corner_st(r, &st, (us.len(), uper), (vs.len(), vper))?,
            None => grid_st(us.len(), vs.len()),
        };
        for (p, st) in patches.iter_mut().zip(st) {
            p.st = st;
        }
        self.add_object(r, Shape::Patches(patches));
        Ok(())
    }

    /// `Geometry "teapot"` (other names are warned about and left out).
    pub(super) fn geometry(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(name), ..] = r.args else {
            return Err(r.err("Geometry expects a name (a string), e.g. Geometry \"teapot\""));
        };
        if name != "teapot" {
            self.warn(
                r,
                format!("Geometry \"{name}\" is not known (known: teapot), left out"),
            );
            return Ok(());
        }
        let mut patches = Vec::new();
        let bezier = Basis::default();
        for (nu, nv, points) in TEAPOT {
            let p: Vec<Vec3> = points.iter().map(|q| Vec3::from_array(*q)).collect();
            let us = patch_starts(nu, false, true, 3).unwrap_or_default();
            let vs = patch_starts(nv, false, true, 3).unwrap_or_default();
            let mut mesh = mesh_patches(&p, nu, nv, &us, &vs, Some(bezier));
            for (patch, st) in mesh.iter_mut().zip(grid_st(us.len(), vs.len())) {
                patch.st = st;
            }
            patches.extend(mesh);
        }
        self.add_object(r, Shape::Patches(patches));
        Ok(())
    }
}

/// The default texture coordinates of a mesh of `nu × nv` patches (`u` fastest): `s = u`, `t = v`
/// with `(u, v)` over `[0, 1]²` of the whole mesh.
fn grid_st(nu: usize, nv: usize) -> Vec<[Vec2; 4]> {
    let at = |i: usize, j: usize| Vec2::new(i as f32 / nu as f32, j as f32 / nv as f32);
    (0..nv)
        .flat_map(|j| (0..nu).map(move |i| [at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]))
        .collect()
}

/// Each patch's corner texture coordinates, `u` fastest, from the varying `st` of a mesh of
/// `nu × nv` patches: one value per corner of the patch grid, `u` fastest, a periodic direction's last
/// patch ending on its first corner.
fn corner_st(
    r: &Req<'_>,
    st: &[Vec2],
    (nu, uper): (usize, bool),
    (nv, vper): (usize, bool),
) -> Result<Vec<[Vec2; 4]>, RibError> {
    let (cols, rows) = (nu + usize::from(!uper), nv + usize::from(!vper));
    if st.len() != cols * rows || st.iter().any(|v| !v.is_finite()) {
        return Err(r.err(format!(
            "{}: texture coordinates (\"st\", or \"s\" and \"t\") are varying: {} finite (s, t) pairs expected, one per patch corner ({cols} × {rows}), got {}",
            r.name,
            cols * rows,
            st.len()
        )));
    }
    let at = |i: usize, j: usize| st[(j % rows) * cols + i % cols];
    Ok((0..nv)
        .flat_map(|j| (0..nu).map(move |i| [at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]))
        .collect())
}

/// The patches of a `cols × rows` mesh (`u` fastest) starting at `us × vs`; bicubic in `basis`, or
/// bilinear when `None`. Indices wrap (periodic meshes).
fn mesh_patches(
    points: &[Vec3],
    cols: usize,
    rows: usize,
    us: &[usize],
    vs: &[usize],
    basis: Option<Basis>,
) -> Vec<BezierPatch> {
    let at = |i: usize, j: usize| points[(j % rows) * cols + (i % cols)];
    let conv = basis.map(|b| (b.u.to_bezier(), b.v.to_bezier()));
    let mut out = Vec::with_capacity(us.len() * vs.len());
    for &j in vs {
        for &i in us {
            out.push(match &conv {
                Some((cu, cv)) => {
                    let g: [Vec3; 16] = std::array::from_fn(|k| at(i + k % 4, j + k / 4));
                    bicubic(cu, cv, &g)
                }
                None => bilinear([at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]),
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `[t³ t² t 1]·M·G`, the spec's definition, for one coordinate.
    fn eval_basis(m: &[[f64; 4]; 4], g: [f64; 4], t: f64) -> f64 {
        let tt = [t * t * t, t * t, t, 1.0];
        (0..4)
            .map(|k| (0..4).map(|i| tt[i] * m[i][k]).sum::<f64>() * g[k])
            .sum()
    }

    /// The cubic Bernstein form.
    fn eval_bezier(b: [f64; 4], t: f64) -> f64 {
        let s = 1.0 - t;
        s * s * s * b[0] + 3.0 * s * s * t * b[1] + 3.0 * s * t * t * b[2] + t * t * t * b[3]
    }

    #[test]
    fn every_named_basis_converts_exactly_to_bezier() {
        let g = [0.3, -1.2, 2.5, 0.7];
        for name in ["bezier", "b-spline", "catmull-rom", "hermite", "power"] {
            let basis = named_basis(name).unwrap();
            let c = basis.to_bezier();
            let b: [f64; 4] = std::array::from_fn(|i| (0..4).map(|k| c[i][k] * g[k]).sum());
            for t in [0.0, 0.2, 0.5, 0.9, 1.0] {
                let (want, got) = (eval_basis(&basis.matrix, g, t), eval_bezier(b, t));
                assert!((want - got).abs() < 1e-12, "{name} at {t}: {want} vs {got}");
            }
        }
    }

    #[test]
    fn bezier_inverse_is_the_inverse() {
        for (i, row) in BEZIER_INVERSE.iter().enumerate() {
            for k in 0..4 {
                let x: f64 = row.iter().zip(&BEZIER).map(|(a, b)| a * b[k]).sum();
                assert!((x - f64::from(u8::from(i == k))).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn patch_counts_follow_the_spec() {
        assert_eq!(patch_starts(7, false, true, 3), Some(vec![0, 3]));
        assert_eq!(patch_starts(7, false, true, 1), Some(vec![0, 1, 2, 3]));
        assert_eq!(patch_starts(6, true, true, 1).map(|v| v.len()), Some(6));
        assert_eq!(patch_starts(4, false, false, 3), Some(vec![0, 1, 2]));
        assert_eq!(patch_starts(4, true, false, 3).map(|v| v.len()), Some(4));
        assert_eq!(patch_starts(3, false, true, 3), None);
    }

    #[test]
    fn a_bilinear_patch_is_elevated_exactly() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 2.0)];
        let b = bilinear(p);
        assert_eq!(b.points[0], p[0]);
        assert_eq!(b.points[3], p[1]);
        assert_eq!(b.points[12], p[2]);
        assert_eq!(b.points[15], p[3]);
        assert!(b.points[5].distance(Vec3::new(1.0 / 3.0, 1.0 / 3.0, 2.0 / 9.0)) < 1e-6);
    }
}
