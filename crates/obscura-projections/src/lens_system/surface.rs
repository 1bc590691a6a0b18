//! One optical interface: its shape (sphere, plane or even asphere), where a ray meets it, and how the
//! ray refracts there.
//!
//! In the lens frame (mm) the axis is `z`, increasing from the film toward the scene, and a surface's
//! vertex is at `z = zv`. With `ρ = x² + y²`, curvature `c = 1/R` (R > 0: centre of curvature on the
//! film side, the optical-design convention for light travelling from the scene to the film), conic
//! constant `k` and even terms `A4…A16`, the surface is
//!
//! `z = zv − s(ρ)`, `s(ρ) = c·ρ/(1 + √(1 − (1 + k)·c²·ρ)) + A4·ρ² + A6·ρ³ + … + A16·ρ⁸`,
//!
//! with `ds/dρ = c/(2√(1 − (1 + k)c²ρ)) + 2A4·ρ + 3A6·ρ² + …`; the (unnormalised) normal is
//! `(2x·s′, 2y·s′, 1)`. A sphere (`k = 0`, no `A` terms) is met in closed form: relative to the vertex
//! the surface is `c·|p|² + 2p_z = 0`, and of the two roots the one that tends to the vertex plane's as
//! `c → 0` is taken (no cancellation for nearly flat surfaces). Conics and aspheres are met by Newton on
//! `g(t) = p_z(t) + s(ρ(t))` from the vertex plane's intersection.

use super::glass::Glass;

/// Number of even-asphere terms: `A4, A6, …, A16`.
pub const ASPHERE_TERMS: usize = 7;

/// One interface of a prescription, in prescription order (scene to film).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Surface {
    /// Radius of curvature, mm (0: flat).
    pub radius: f64,
    /// Conic constant `k` (0: sphere, −1: paraboloid).
    pub conic: f64,
    /// Even asphere terms `A4…A16` (mm^(1−2i)).
    pub asphere: [f64; ASPHERE_TERMS],
    /// Axial distance to the next interface (or, for the last, the design's distance to the film), mm.
    pub thickness: f64,
    /// The medium behind this interface, toward the film.
    pub glass: Glass,
    /// Clear aperture radius (half the diameter), mm.
    pub semi_aperture: f64,
    /// True for the aperture stop (a flat disk in air).
    pub stop: bool,
}

impl Surface {
    /// Curvature `1/R`, 0 for a flat surface.
    #[inline]
    #[must_use]
    pub fn curvature(&self) -> f64 {
        if self.radius == 0.0 {
            0.0
        } else {
            1.0 / self.radius
        }
    }

    /// True for a sphere or plane (met in closed form).
    #[must_use]
    pub fn is_spherical(&self) -> bool {
        self.conic == 0.0 && self.asphere.iter().all(|&a| a == 0.0)
    }

    /// The sag `s(ρ)` and `ds/dρ` at `ρ = h²`; `None` where the conic has no surface.
    #[inline]
    #[must_use]
    pub fn sag(&self, rho: f64) -> Option<(f64, f64)> {
        let c = self.curvature();
        let q2 = 1.0 - (1.0 + self.conic) * c * c * rho;
        if q2 < 0.0 {
            return None;
        }
        let q = q2.sqrt();
        let mut s = c * rho / (1.0 + q);
        let mut ds = if q > 0.0 { c / (2.0 * q) } else { f64::INFINITY };
        let mut pow = rho; // ρ^(i+1) for A_(2i+4)
        let mut dpow = 1.0; // ρ^i
        for (i, &a) in self.asphere.iter().enumerate() {
            if a != 0.0 {
                s += a * pow * rho;
                ds += a * (i as f64 + 2.0) * dpow * rho;
            }
            dpow = pow;
            pow *= rho;
        }
        Some((s, ds))
    }
}

/// A ray in the lens frame, mm; `d` is unit length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub o: [f64; 3],
    /// Unit direction.
    pub d: [f64; 3],
}

#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Where `ray` meets `surface` (vertex at `zv`): the point and the unit normal (pointing to +z), or
/// `None` when it misses (or the point lies outside the conic's domain).
#[inline]
#[must_use]
pub fn intersect(surface: &Surface, zv: f64, ray: &Ray) -> Option<([f64; 3], [f64; 3])> {
    if surface.is_spherical() {
        intersect_sphere(surface, zv, ray)
    } else {
        intersect_newton(surface, zv, ray)
    }
}

/// [`intersect`] for a sphere or plane, in closed form (the conic and asphere terms are ignored).
#[inline]
#[must_use]
pub fn intersect_sphere(surface: &Surface, zv: f64, ray: &Ray) -> Option<([f64; 3], [f64; 3])> {
    let c = surface.curvature();
    let p0 = [ray.o[0], ray.o[1], ray.o[2] - zv];
    let d = ray.d;
    {
        // c·|p|² + 2p_z = 0 along p0 + t·d: c·t² + 2(c·p0·d + d_z)·t + (c|p0|² + 2p0_z) = 0.
        let b = c * dot(p0, d) + d[2];
        let cc = c * dot(p0, p0) + 2.0 * p0[2];
        let disc = b * b - c * cc;
        if disc < 0.0 {
            return None;
        }
        let den = b + disc.sqrt().copysign(b);
        if den == 0.0 {
            return None;
        }
        // The two roots: -cc/den (the one that tends to the vertex plane's) and -den/c. The surface is
        // the cap on the vertex's side of the centre, where 1 + c·p_z > 0.
        let on_cap = |t: f64| t.is_finite() && t > 0.0 && 1.0 + c * (p0[2] + t * d[2]) > 0.0;
        let t1 = -cc / den;
        let t = if on_cap(t1) {
            t1
        } else {
            let t2 = if c == 0.0 { f64::INFINITY } else { -den / c };
            if on_cap(t2) { t2 } else { return None }
        };
        let p = [p0[0] + t * d[0], p0[1] + t * d[1], p0[2] + t * d[2]];
        // c·p + ẑ = c·(p − centre): unit length on the sphere (|p − centre| = |R|), no square root.
        Some(([p[0], p[1], p[2] + zv], [c * p[0], c * p[1], 1.0 + c * p[2]]))
    }
}

/// [`intersect`] by Newton on the sag from the vertex plane's intersection: any conic or asphere.
#[must_use]
pub fn intersect_newton(surface: &Surface, zv: f64, ray: &Ray) -> Option<([f64; 3], [f64; 3])> {
    let p0 = [ray.o[0], ray.o[1], ray.o[2] - zv];
    let d = ray.d;
    if d[2] == 0.0 {
        return None;
    }
    let mut t = -p0[2] / d[2];
    for _ in 0..40 {
        let p = [p0[0] + t * d[0], p0[1] + t * d[1], p0[2] + t * d[2]];
        let rho = p[0] * p[0] + p[1] * p[1];
        let (s, ds) = surface.sag(rho)?;
        let g = p[2] + s;
        let dg = d[2] + ds * 2.0 * (p[0] * d[0] + p[1] * d[1]);
        if dg == 0.0 || !dg.is_finite() {
            return None;
        }
        let step = g / dg;
        t -= step;
        if step.abs() <= 1e-12 * (1.0 + t.abs()) {
            if t <= 0.0 {
                return None;
            }
            let p = [p0[0] + t * d[0], p0[1] + t * d[1], p0[2] + t * d[2]];
            let (_, ds) = surface.sag(p[0] * p[0] + p[1] * p[1])?;
            let n = [2.0 * p[0] * ds, 2.0 * p[1] * ds, 1.0];
            let inv = 1.0 / dot(n, n).sqrt();
            return Some(([p[0], p[1], p[2] + zv], [n[0] * inv, n[1] * inv, n[2] * inv]));
        }
    }
    None
}

/// Snell's law: the unit direction after `d` crosses a surface of unit normal `n` from index `n1` to
/// `n2`, or `None` on total internal reflection.
#[inline]
#[must_use]
pub fn refract(d: [f64; 3], n: [f64; 3], n1: f64, n2: f64) -> Option<[f64; 3]> {
    let mut cos_i = -dot(d, n);
    let mut n = n;
    if cos_i < 0.0 {
        cos_i = -cos_i;
        n = [-n[0], -n[1], -n[2]];
    }
    let eta = n1 / n2;
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    if k < 0.0 {
        return None;
    }
    let f = eta * cos_i - k.sqrt();
    Some([
        eta * d[0] + f * n[0],
        eta * d[1] + f * n[1],
        eta * d[2] + f * n[2],
    ])
}
