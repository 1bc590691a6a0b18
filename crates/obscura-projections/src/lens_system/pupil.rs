//! Ray aiming: which direction from a film point reaches a given point of the aperture stop.
//!
//! For film radii `r_j = j·Δr` (the film point on +x; other azimuths by rotation, the lens being
//! rotationally symmetric) and a `G × G` grid of stop points `q = (u, v)·R_stop`, `u, v ∈ [−1, 1]`,
//! [`PupilTable::build`] solves by Newton (finite-difference Jacobian, from the neighbouring radius's
//! solution or the paraxial exit pupil) for the film-side slope `t = (tx, ty)` (direction
//! `∝ (tx, ty, 1)`) whose ray, traced from the film through the rear group, crosses the stop plane at
//! `q`. At render time an aperture sample `a` is mapped to a slope by bilinear interpolation in `(u, v)`
//! and linear interpolation in `r`; the map's Jacobian `|∂t/∂a|` is that interpolant's exact derivative.
//!
//! Radiometry: the irradiance at a film point is `E = ∫ L·cos θ dω = ∫ L·(1 + |t|²)⁻² dtx dty`, so with
//! `a` uniform over the aperture the estimate of `E/L` is `(1 + |t|²)⁻²·|∂t/∂a|·V`, `V` = 1 when the ray
//! passes every clear aperture. Because the estimator carries the Jacobian of the very map used, it is
//! unbiased whatever the interpolation error: errors only move samples, never weight them wrongly, and
//! there are no bounds to miss light (the rings of a bounding-box pupil).

use super::surface::Ray;
use super::system::Lens;

/// Stop grid nodes per side.
pub const GRID: usize = 9;

/// The aiming table of one placed lens (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct PupilTable {
    /// Film radius step, mm.
    pub dr: f64,
    /// Number of radii.
    pub radii: usize,
    /// The stop radius the grid spans, mm.
    pub stop_radius: f64,
    /// Slopes `[radius][v][u]`, film point on +x.
    slopes: Vec<[f64; 2]>,
    /// Whether each radius has a usable row.
    valid: Vec<bool>,
}

/// A slope from the aiming table and the Jacobian determinant `|∂t/∂a|`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aimed {
    /// Film-side slope in the rotated frame.
    pub t: [f64; 2],
    /// `|det ∂t/∂a|`.
    pub jacobian: f64,
}

/// The film-side ray from film point `(r, 0, 0)` with slope `t`.
#[inline]
#[must_use]
pub fn film_ray(r: f64, t: [f64; 2]) -> Ray {
    let inv = 1.0 / (t[0] * t[0] + t[1] * t[1] + 1.0).sqrt();
    Ray {
        o: [r, 0.0, 0.0],
        d: [t[0] * inv, t[1] * inv, inv],
    }
}

/// Where the ray from film point `(r, 0)` with slope `t` crosses the stop plane (rear group only, no
/// clipping), or `None`.
fn at_stop(lens: &Lens, r: f64, t: [f64; 2]) -> Option<[f64; 2]> {
    let n = lens.surfaces.len();
    let ray = lens
        .trace_range(
            film_ray(r, t),
            lens.stop,
            n - 1,
            (&lens.n_before, &lens.n_after),
            false,
        )
        .ok()?;
    Some([ray.o[0], ray.o[1]])
}

/// The slope from film point `(r, 0)` whose ray reaches stop point `q` (mm), by Newton from `guess`.
#[must_use]
pub fn aim(lens: &Lens, r: f64, q: [f64; 2], guess: [f64; 2]) -> Option<[f64; 2]> {
    let mut t = guess;
    let mut h = at_stop(lens, r, t)?;
    for _ in 0..40 {
        let f = [h[0] - q[0], h[1] - q[1]];
        if f[0].abs().max(f[1].abs()) < 1e-10 {
            return Some(t);
        }
        let eps = 1e-7;
        let hx = at_stop(lens, r, [t[0] + eps, t[1]])?;
        let hy = at_stop(lens, r, [t[0], t[1] + eps])?;
        let j = [
            [(hx[0] - h[0]) / eps, (hy[0] - h[0]) / eps],
            [(hx[1] - h[1]) / eps, (hy[1] - h[1]) / eps],
        ];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let step = [
            (j[1][1] * f[0] - j[0][1] * f[1]) / det,
            (j[0][0] * f[1] - j[1][0] * f[0]) / det,
        ];
        // Halve the step until the ray still reaches the stop and the residual does not grow.
        let mut k = 1.0;
        loop {
            let next = [t[0] - k * step[0], t[1] - k * step[1]];
            if let Some(hn) = at_stop(lens, r, next) {
                let fn_ = (hn[0] - q[0]).hypot(hn[1] - q[1]);
                if fn_ <= f[0].hypot(f[1]) || k < 1e-3 {
                    t = next;
                    h = hn;
                    break;
                }
            }
            k *= 0.5;
            if k < 1e-6 {
                return None;
            }
        }
    }
    let f = (h[0] - q[0]).hypot(h[1] - q[1]);
    (f < 1e-8).then_some(t)
}

impl PupilTable {
    /// Aims every node for `radii` film radii up to `r_max` mm at a stop of radius `stop_radius`.
    #[must_use]
    #[allow(clippy::needless_range_loop)] // rows, slopes and validity share the radius index
    pub fn build(lens: &Lens, stop_radius: f64, r_max: f64, radii: usize) -> PupilTable {
        let dr = r_max / (radii - 1) as f64;
        let n = lens.surfaces.len();
        // Paraxial exit pupil: the stop imaged by the rear group, for the first guesses.
        let m = lens.matrix(lens.stop, n - 1, super::glass::LAMBDA_D, 0.0);
        let (xp_z, xp_mag) = (lens.back() + m[0][1] / m[1][1], 1.0 / m[1][1]);
        let mut slopes = vec![[f64::NAN; 2]; radii * GRID * GRID];
        let mut valid = vec![false; radii];
        let node = |i: usize| -1.0 + 2.0 * i as f64 / (GRID - 1) as f64;
        for j in 0..radii {
            let r = j as f64 * dr;
            let mut good = Vec::new();
            for iv in 0..GRID {
                for iu in 0..GRID {
                    let q = [node(iu) * stop_radius, node(iv) * stop_radius];
                    let k = (j * GRID + iv) * GRID + iu;
                    let paraxial = [(q[0] * xp_mag - r) / xp_z, q[1] * xp_mag / xp_z];
                    let prev = if j > 0 {
                        slopes[k - GRID * GRID]
                    } else {
                        [f64::NAN; 2]
                    };
                    let t = if prev[0].is_finite() {
                        aim(lens, r, q, prev)
                    } else {
                        None
                    }
                    .or_else(|| aim(lens, r, q, paraxial));
                    if let Some(t) = t {
                        slopes[k] = t;
                        good.push((node(iu), node(iv), t));
                    }
                }
            }
            // Nodes no ray reaches (beyond a rear element's edge): the affine fit of the others, so the
            // map stays smooth; those samples are then blocked by the traced apertures.
            if good.len() >= 3 && good.len() < GRID * GRID {
                let fit = affine_fit(&good);
                for iv in 0..GRID {
                    for iu in 0..GRID {
                        let k = (j * GRID + iv) * GRID + iu;
                        if !slopes[k][0].is_finite() {
                            let (u, v) = (node(iu), node(iv));
                            slopes[k] = [
                                fit[0][0] + fit[0][1] * u + fit[0][2] * v,
                                fit[1][0] + fit[1][1] * u + fit[1][2] * v,
                            ];
                        }
                    }
                }
            }
            valid[j] = good.len() >= 3;
        }
        PupilTable {
            dr,
            radii,
            stop_radius,
            slopes,
            valid,
        }
    }

    /// The largest film radius the table covers, mm.
    #[must_use]
    pub fn r_max(&self) -> f64 {
        self.dr * (self.radii - 1) as f64
    }

    /// The slope for aperture sample `a` (stop point `a·R_stop`, in the frame with the film point at
    /// `(r, 0)`), with `|∂t/∂a|`; `None` beyond the table or where no row is usable.
    #[inline]
    #[must_use]
    pub fn lookup(&self, r: f64, a: [f64; 2]) -> Option<Aimed> {
        let x = r / self.dr;
        if x.is_nan() || x > (self.radii - 1) as f64 {
            return None;
        }
        let j = (x as usize).min(self.radii - 2);
        let w = x - j as f64;
        if !self.valid[j] || !self.valid[j + 1] {
            return None;
        }
        let half = 0.5 * (GRID - 1) as f64;
        let (gu, gv) = ((a[0] + 1.0) * half, (a[1] + 1.0) * half);
        let iu = (gu.max(0.0) as usize).min(GRID - 2);
        let iv = (gv.max(0.0) as usize).min(GRID - 2);
        let (fu, fv) = (gu - iu as f64, gv - iv as f64);
        let mut t = [0.0; 2];
        let mut du = [0.0; 2];
        let mut dv = [0.0; 2];
        for (row, wr) in [(j, 1.0 - w), (j + 1, w)] {
            let base = (row * GRID + iv) * GRID + iu;
            let (p00, p10, p01, p11) = (
                self.slopes[base],
                self.slopes[base + 1],
                self.slopes[base + GRID],
                self.slopes[base + GRID + 1],
            );
            for c in 0..2 {
                t[c] += wr
                    * ((1.0 - fu) * (1.0 - fv) * p00[c]
                        + fu * (1.0 - fv) * p10[c]
                        + (1.0 - fu) * fv * p01[c]
                        + fu * fv * p11[c]);
                du[c] += wr * half * ((1.0 - fv) * (p10[c] - p00[c]) + fv * (p11[c] - p01[c]));
                dv[c] += wr * half * ((1.0 - fu) * (p01[c] - p00[c]) + fu * (p11[c] - p10[c]));
            }
        }
        Some(Aimed {
            t,
            jacobian: (du[0] * dv[1] - dv[0] * du[1]).abs(),
        })
    }
}

/// Least-squares `t ≈ c0 + c1·u + c2·v` for each slope component.
fn affine_fit(points: &[(f64, f64, [f64; 2])]) -> [[f64; 3]; 2] {
    let mut ata = [[0.0f64; 3]; 3];
    let mut atb = [[0.0f64; 3]; 2];
    for &(u, v, t) in points {
        let row = [1.0, u, v];
        for a in 0..3 {
            for b in 0..3 {
                ata[a][b] += row[a] * row[b];
            }
            for c in 0..2 {
                atb[c][a] += row[a] * t[c];
            }
        }
    }
    let mut out = [[0.0; 3]; 2];
    for c in 0..2 {
        out[c] = solve3(ata, atb[c]).unwrap_or([atb[c][0] / ata[0][0], 0.0, 0.0]);
    }
    out
}

fn solve3(m: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(m);
    if d.abs() < 1e-12 {
        return None;
    }
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let mut mk = m;
        for r in 0..3 {
            mk[r][k] = b[r];
        }
        *o = det(mk) / d;
    }
    Some(out)
}
