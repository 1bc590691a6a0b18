//! The last stage of each model: an undistorted 2-D point `m` lifted to a 3-D ray `V` (not unit
//! length) with its derivative `∂V/∂m`, and back ("unlift": ray → `m`, or `None` outside the model's
//! valid set). Every formula is in OpenCV/COLMAP camera space: x right, **y down**, z forward.

// The lane forms test validity as `!(x <= 0.0)` etc.: exactly the negation of the per-pixel
// early-return conditions, so a NaN is treated the same way on both paths (it passes the check and
// is culled by the non-finite ray).
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use crate::solve::{self, InverseTable, Mat32};

/// How an undistorted point becomes a ray.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Lift {
    /// `V = (x, y, 1)`: the pinhole.
    Perspective,
    /// Equidistant fisheye `θ = |m|`: `V = (sin θ·m/θ, cos θ)`, θ up to π.
    Equidistant,
    /// Enhanced unified model (Khomutenko et al.; UCM when β = 1):
    /// `V = (x, y, (1 − βα²q)/(α·sqrt(1 − (2α − 1)βq) + 1 − α))`, `q = |m|²`.
    Unified {
        /// α ∈ [0, 1].
        alpha: f64,
        /// β > 0.
        beta: f64,
    },
    /// Mei's unified omnidirectional model: `λ = (ξ + sqrt(1 + (1 − ξ²)q))/(1 + q)`,
    /// `V = (λx, λy, λ − ξ)`.
    Mei {
        /// ξ ≥ 0.
        xi: f64,
    },
    /// Double sphere (Usenko et al. 2018).
    DoubleSphere {
        /// ξ ∈ [−1, 1].
        xi: f64,
        /// α ∈ [0, 1].
        alpha: f64,
    },
    /// Fitzgibbon's division model: `V = (x, y, 1 + k·q)`.
    Division {
        /// k.
        k: f64,
    },
    /// Devernay–Faugeras FOV model on the distorted plane: `V = (sin(ωr)·m/r, 2·tan(ω/2)·cos(ωr))`,
    /// `ωr < π/2`.
    Fov {
        /// ω (radians).
        omega: f64,
        /// `2·tan(ω/2)`.
        c: f64,
    },
    /// COLMAP's equirectangular model on pixel coordinates: azimuth `2π(u/w − ½)`, elevation
    /// `π(½ − v/h)`, `V = (cos φ sin θ, −sin φ, cos φ cos θ)`.
    Equirect {
        /// Width the azimuth spans.
        w: f64,
        /// Height the elevation spans.
        h: f64,
    },
    /// Scaramuzza's OCamCalib, with `m` the (row/column-swapped) sensor point:
    /// `V = (x, y, −pol(|m|))`.
    OCam {
        /// `pol`, ascending.
        pol: Vec<f64>,
        /// `invpol`, ascending (only seeds the exact inverse); may be empty.
        invpol: Vec<f64>,
        /// Largest sensor radius where the ray angle still increases.
        rho_max: f64,
    },
    /// NVIDIA f-theta: ray angle θ from the pixel distance ρ = |m|, `V = (sin θ·m/ρ, cos θ)`.
    FTheta {
        /// Pixel distance → angle (the reference when given).
        bw: Option<Vec<f64>>,
        /// Angle → pixel distance (the reference when `bw` is absent, else a seed).
        fw: Option<Forward>,
        /// Largest pixel distance in the valid set.
        rho_max: f64,
        /// Largest angle in the valid set.
        theta_max: f64,
    },
    /// A 3DEqualizer lens on its plate: `m` is the plate's raster position, the ray the pinhole
    /// ray of 3DE's undistorted point (see [`crate::lens3de`]).
    Lens3de(Box<crate::lens3de::Lens>),
}

/// A lifted ray and its derivative by the lift's input.
pub(crate) type Lifted = ([f64; 3], Mat32);

/// `dmz/dq` pieces of the unified-type formula `mz = (1 − a·q)/(α·sqrt(1 − b·q) + 1 − α)`, with
/// whether `q` is in its domain (branch-free: the values are computed, meaningless, outside).
#[inline(always)]
fn unified_mz(alpha: f64, a: f64, b: f64, q: f64) -> (bool, (f64, f64)) {
    let rad = 1.0 - b * q;
    let sq = rad.sqrt();
    let den = alpha * sq + 1.0 - alpha;
    let num = 1.0 - a * q;
    let dden = -alpha * b / (2.0 * sq);
    let ok = !(rad <= 0.0) & !(den <= 0.0);
    (ok, (num / den, (-a * den - num * dden) / (den * den)))
}

/// `V = (s·x, s·y, vz)` with `s = s(q)`, `vz = vz(q)`: the derivative by `m` given `ds/dq`, `dvz/dq`.
#[inline(always)]
fn radial_jacobian(m: [f64; 2], s: f64, ds: f64, dvz: f64) -> Mat32 {
    let (x, y) = (m[0], m[1]);
    [
        [s + 2.0 * ds * x * x, 2.0 * ds * x * y],
        [2.0 * ds * x * y, s + 2.0 * ds * y * y],
        [2.0 * dvz * x, 2.0 * dvz * y],
    ]
}

/// `V = (sin θ·m/ρ, cos θ)` for `θ = θ(ρ)` (given as its sine and cosine) with `θ'(ρ)`: value and
/// derivative.
#[inline]
fn angle_lift(m: [f64; 2], rho: f64, sin: f64, cos: f64, dtheta: f64) -> Lifted {
    if rho < 1e-12 {
        return (
            [m[0] * dtheta, m[1] * dtheta, cos],
            [[dtheta, 0.0], [0.0, dtheta], [0.0, 0.0]],
        );
    }
    let (ux, uy) = (m[0] / rho, m[1] / rho);
    let a = sin / rho;
    let b = cos * dtheta - a;
    (
        [sin * ux, sin * uy, cos],
        [
            [a + b * ux * ux, b * ux * uy],
            [b * ux * uy, a + b * uy * uy],
            [-sin * dtheta * ux, -sin * dtheta * uy],
        ],
    )
}

impl Lift {
    /// The radius of the plane the lift is defined on (for the distortion's fold search).
    pub fn plane_limit(&self) -> f64 {
        match self {
            Lift::Equidistant => PI,
            Lift::Mei { xi } if *xi > 1.0 => 1.0 / (xi * xi - 1.0).sqrt(),
            _ => f64::INFINITY,
        }
    }

    /// True when some valid ray has `z ≤ 0` (the deep metric must then be the ray length).
    pub fn may_leave_front(&self, max_radius: f64) -> bool {
        match self {
            Lift::Perspective | Lift::Fov { .. } => false,
            Lift::Equidistant => max_radius > FRAC_PI_2,
            Lift::Unified { alpha, .. } => *alpha > 0.0 && *alpha < 1.0,
            Lift::Mei { xi } => *xi > 0.0,
            Lift::DoubleSphere { xi, alpha } => ds_w2(*xi, *alpha) > 0.0,
            Lift::Division { k } => *k < 0.0,
            Lift::Equirect { .. } => true,
            Lift::OCam { pol, rho_max, .. } => solve::poly(pol, *rho_max).0 >= 0.0,
            Lift::FTheta { theta_max, .. } => *theta_max > FRAC_PI_2,
            Lift::Lens3de(_) => false,
        }
    }

    /// The ray of `m` and `∂V/∂m`, or `None` outside the valid set.
    #[inline]
    pub fn lift(&self, m: [f64; 2]) -> Option<Lifted> {
        match self {
            Lift::Perspective => perspective(m),
            Lift::Equidistant => equidistant(m),
            Lift::Unified { alpha, beta } => unified(*alpha, *beta, m),
            Lift::Mei { xi } => mei(*xi, m),
            Lift::DoubleSphere { xi, alpha } => double_sphere(*xi, *alpha, m),
            Lift::Division { k } => division(*k, m),
            Lift::Fov { omega, c } => fov(*omega, *c, m),
            Lift::Equirect { w, h } => equirect(*w, *h, m),
            Lift::OCam { pol, rho_max, .. } => ocam(pol, *rho_max, m),
            Lift::FTheta {
                bw,
                fw,
                rho_max,
                theta_max,
            } => ftheta(bw.as_deref(), fw.as_ref(), *rho_max, *theta_max, m),
            Lift::Lens3de(lens) => lens.ray(m),
        }
    }

    /// The point `m` whose ray is `d` (any length), or `None` when the ray is outside the valid set.
    #[inline]
    pub fn unlift(&self, d: [f64; 3]) -> Option<[f64; 2]> {
        let [x, y, z] = d;
        let rho = x.hypot(y);
        let len = (rho * rho + z * z).sqrt();
        if len.is_nan() || len <= 0.0 || !len.is_finite() {
            return None;
        }
        // (x, y) scaled to length s, the axis when rho is 0 (only for a forward ray).
        let along = |s: f64| {
            if rho > 0.0 {
                Some([x * s / rho, y * s / rho])
            } else if z > 0.0 {
                Some([0.0, 0.0])
            } else {
                None
            }
        };
        match self {
            Lift::Perspective => (z > 0.0).then(|| [x / z, y / z]),
            Lift::Equidistant => along(rho.atan2(z)),
            Lift::Unified { alpha, beta } => {
                let re = (beta * rho * rho + z * z).sqrt();
                let w = if *alpha > 0.5 {
                    (1.0 - alpha) / alpha
                } else {
                    alpha / (1.0 - alpha)
                };
                let den = alpha * re + (1.0 - alpha) * z;
                (z > -w * re && den > 0.0).then(|| [x / den, y / den])
            }
            Lift::Mei { xi } => {
                let zs = z / len;
                let den = zs + xi;
                let ok = den > 0.0 && (*xi <= 1.0 || zs > -1.0 / xi);
                ok.then(|| [x / len / den, y / len / den])
            }
            Lift::DoubleSphere { xi, alpha } => {
                let zz = xi * len + z;
                let d2 = (rho * rho + zz * zz).sqrt();
                let den = alpha * d2 + (1.0 - alpha) * zz;
                (z > -ds_w2(*xi, *alpha) * len && den > 0.0).then(|| [x / den, y / den])
            }
            Lift::Division { k } => {
                let disc = z * z - 4.0 * rho * rho * k;
                if disc < 0.0 {
                    return None;
                }
                let den = z + disc.sqrt();
                (den > 0.0).then(|| [2.0 * x / den, 2.0 * y / den])
            }
            Lift::Fov { omega, c } => {
                if z <= 0.0 {
                    return None;
                }
                along((c * rho).atan2(z) / omega)
            }
            Lift::Equirect { w, h } => {
                let theta = x.atan2(z);
                let phi = (-y).atan2(x.hypot(z));
                Some([(theta / TAU + 0.5) * w, (0.5 - phi / PI) * h])
            }
            Lift::OCam { pol, invpol, rho_max } => {
                let target = rho.atan2(z);
                let angle = |r: f64| {
                    let (p, dp) = solve::poly(pol, r);
                    let (qv, dq) = (-p, -dp);
                    (r.atan2(qv), (qv - r * dq) / (r * r + qv * qv))
                };
                let guess = if invpol.is_empty() {
                    0.0
                } else {
                    solve::poly(invpol, target - FRAC_PI_2).0
                };
                let r = solve::solve_increasing(angle, target, 0.0, *rho_max, guess)?;
                along(r)
            }
            Lift::FTheta {
                bw,
                fw,
                rho_max,
                theta_max,
            } => {
                let theta = rho.atan2(z);
                if theta > *theta_max {
                    return None;
                }
                let r = match (bw, fw) {
                    (Some(bw), fw) => {
                        let guess = match fw {
                            Some(fw) => solve::poly(&fw.coefficients, theta).0,
                            None => theta / solve::poly(bw, 0.0).1.max(1e-300),
                        };
                        solve::solve_increasing(|r| solve::poly(bw, r), theta, 0.0, *rho_max, guess)?
                    }
                    (None, Some(fw)) => solve::poly(&fw.coefficients, theta).0,
                    (None, None) => return None,
                };
                if r > *rho_max {
                    return None;
                }
                along(r)
            }
            Lift::Lens3de(lens) => lens.pixel(d),
        }
    }
}

/// A lifted ray with whether the input is in the lift's valid set, computed without branches (a
/// loop over lanes vectorises); the values are meaningless where invalid.
pub(crate) type LaneLifted = (bool, Lifted);

/// [`Lift::Perspective`].
#[inline(always)]
pub(crate) fn perspective(m: [f64; 2]) -> Option<Lifted> {
    Some(perspective_lane(m).1)
}

/// [`perspective`] per lane.
#[inline(always)]
pub(crate) fn perspective_lane(m: [f64; 2]) -> LaneLifted {
    (true, ([m[0], m[1], 1.0], [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]))
}

/// [`Lift::Equidistant`].
#[inline(always)]
pub(crate) fn equidistant(m: [f64; 2]) -> Option<Lifted> {
    let (ok, l) = equidistant_lane(m);
    ok.then_some(l)
}

/// [`equidistant`] per lane (θ ≤ π where valid, inside [`solve::sin_cos_kernel`]'s range).
#[inline(always)]
pub(crate) fn equidistant_lane(m: [f64; 2]) -> LaneLifted {
    let q = m[0] * m[0] + m[1] * m[1];
    let t = q.sqrt();
    let (sin, cos) = solve::sin_cos_kernel(t);
    // sin t / t and its derivative by q = t², by series near 0.
    let series = (1.0 - q / 6.0 + q * q / 120.0, -1.0 / 6.0 + q / 60.0);
    let exact = (sin / t, (t * cos - sin) / (2.0 * t * q));
    let (s, ds) = if t < 1e-3 { series } else { exact };
    // d cos t / dq = −sin t/(2t) = −s/2.
    (
        !(t > PI),
        ([s * m[0], s * m[1], cos], radial_jacobian(m, s, ds, -0.5 * s)),
    )
}

/// [`Lift::Unified`].
#[inline(always)]
pub(crate) fn unified(alpha: f64, beta: f64, m: [f64; 2]) -> Option<Lifted> {
    let (ok, l) = unified_lane(alpha, beta, m);
    ok.then_some(l)
}

/// [`unified`] per lane.
#[inline(always)]
pub(crate) fn unified_lane(alpha: f64, beta: f64, m: [f64; 2]) -> LaneLifted {
    let q = m[0] * m[0] + m[1] * m[1];
    let (ok, (mz, dmz)) = unified_mz(alpha, alpha * alpha * beta, (2.0 * alpha - 1.0) * beta, q);
    (ok, ([m[0], m[1], mz], radial_jacobian(m, 1.0, 0.0, dmz)))
}

/// [`Lift::Mei`].
#[inline(always)]
pub(crate) fn mei(xi: f64, m: [f64; 2]) -> Option<Lifted> {
    let (ok, l) = mei_lane(xi, m);
    ok.then_some(l)
}

/// [`mei`] per lane.
#[inline(always)]
pub(crate) fn mei_lane(xi: f64, m: [f64; 2]) -> LaneLifted {
    let q = m[0] * m[0] + m[1] * m[1];
    let rad = 1.0 + (1.0 - xi * xi) * q;
    let sq = rad.sqrt();
    let lam = (xi + sq) / (1.0 + q);
    let dlam = ((1.0 - xi * xi) / (2.0 * sq) - lam) / (1.0 + q);
    (
        !(rad <= 0.0),
        (
            [lam * m[0], lam * m[1], lam - xi],
            radial_jacobian(m, lam, dlam, dlam),
        ),
    )
}

/// [`Lift::DoubleSphere`].
#[inline(always)]
pub(crate) fn double_sphere(xi: f64, alpha: f64, m: [f64; 2]) -> Option<Lifted> {
    let (ok, l) = double_sphere_lane(xi, alpha, m);
    ok.then_some(l)
}

/// [`double_sphere`] per lane.
#[inline(always)]
pub(crate) fn double_sphere_lane(xi: f64, alpha: f64, m: [f64; 2]) -> LaneLifted {
    let q = m[0] * m[0] + m[1] * m[1];
    let (ok, (mz, dmz)) = unified_mz(alpha, alpha * alpha, 2.0 * alpha - 1.0, q);
    let srad = mz * mz + (1.0 - xi * xi) * q;
    let s = srad.sqrt();
    let ds = (2.0 * mz * dmz + 1.0 - xi * xi) / (2.0 * s);
    let (p, dp) = (mz * xi + s, dmz * xi + ds);
    let (qq, dqq) = (mz * mz + q, 2.0 * mz * dmz + 1.0);
    let k = p / qq;
    let dk = (dp * qq - p * dqq) / (qq * qq);
    (
        ok & !(srad < 0.0),
        (
            [k * m[0], k * m[1], k * mz - xi],
            radial_jacobian(m, k, dk, dk * mz + k * dmz),
        ),
    )
}

/// [`Lift::Division`].
#[inline(always)]
pub(crate) fn division(k: f64, m: [f64; 2]) -> Option<Lifted> {
    let (ok, l) = division_lane(k, m);
    ok.then_some(l)
}

/// [`division`] per lane.
#[inline(always)]
pub(crate) fn division_lane(k: f64, m: [f64; 2]) -> LaneLifted {
    let q = m[0] * m[0] + m[1] * m[1];
    (
        !(k > 0.0 && k * q >= 1.0),
        ([m[0], m[1], 1.0 + k * q], radial_jacobian(m, 1.0, 0.0, k)),
    )
}

/// [`Lift::Fov`].
#[inline(always)]
pub(crate) fn fov(omega: f64, c: f64, m: [f64; 2]) -> Option<Lifted> {
    let (ok, l) = fov_lane(omega, c, m);
    ok.then_some(l)
}

/// [`fov`] per lane (ωr < π/2 where valid, inside [`solve::sin_cos_kernel`]'s range).
#[inline(always)]
pub(crate) fn fov_lane(omega: f64, c: f64, m: [f64; 2]) -> LaneLifted {
    let q = m[0] * m[0] + m[1] * m[1];
    let r = q.sqrt();
    let phi = omega * r;
    let (sin, cos) = solve::sin_cos_kernel(phi);
    // g(r) = sin(ωr)/r and g'(r)/r, by series near 0.
    let w2 = omega * omega;
    let series = (
        omega * (1.0 - w2 * q / 6.0),
        omega * w2 * (-1.0 / 3.0 + w2 * q / 30.0),
    );
    let exact = (sin / r, (phi * cos - sin) / (r * q));
    let (g, dg_over_r) = if phi < 1e-3 { series } else { exact };
    // V = (g·m, c·cos(ωr)); ∂/∂q: ds = g'/(2r), dvz = −c·ω·sin(ωr)/(2r) = −c·ω·g/2.
    (
        !(phi >= FRAC_PI_2),
        (
            [g * m[0], g * m[1], c * cos],
            radial_jacobian(m, g, 0.5 * dg_over_r, -0.5 * c * omega * g),
        ),
    )
}

/// [`Lift::Equirect`].
#[inline(always)]
pub(crate) fn equirect(w: f64, h: f64, m: [f64; 2]) -> Option<Lifted> {
    let (u, v) = (m[0], m[1]);
    if !(0.0..=h).contains(&v) {
        return None;
    }
    let (theta, phi) = equirect_angles(w, h, u, v);
    Some(equirect_rays(w, h, solve::sin_cos(theta), solve::sin_cos(phi)))
}

/// [`equirect`] per lane, with whether the lane must be redone by [`equirect`]: the azimuth is
/// then beyond [`solve::sin_cos_kernel`]'s range (a pixel some 16000 image widths away).
#[inline(always)]
pub(crate) fn equirect_lane(w: f64, h: f64, m: [f64; 2]) -> (bool, bool, Lifted) {
    let (u, v) = (m[0], m[1]);
    let (theta, phi) = equirect_angles(w, h, u, v);
    let rays = equirect_rays(w, h, solve::sin_cos_kernel(theta), solve::sin_cos_kernel(phi));
    ((v >= 0.0) & (v <= h), !(theta.abs() <= 1e5), rays)
}

/// Azimuth `θ = 2π·u/w − π` and elevation `φ = π/2 − π·v/h` of model pixel `(u, v)` (a product by
/// each constant instead of a division: the batch loop is bound by its divisions).
#[inline(always)]
fn equirect_angles(w: f64, h: f64, u: f64, v: f64) -> (f64, f64) {
    (u * (TAU / w) - PI, FRAC_PI_2 - v * (PI / h))
}

/// The equirectangular ray and its derivative from the azimuth's and elevation's sine and cosine.
#[inline(always)]
fn equirect_rays(w: f64, h: f64, (st, ct): (f64, f64), (sp, cp): (f64, f64)) -> Lifted {
    let (a, b) = (TAU / w, PI / h);
    (
        [cp * st, -sp, cp * ct],
        [
            [a * cp * ct, b * sp * st],
            [0.0, b * cp],
            [-a * cp * st, b * sp * ct],
        ],
    )
}

/// [`Lift::OCam`].
#[inline(always)]
pub(crate) fn ocam(pol: &[f64], rho_max: f64, m: [f64; 2]) -> Option<Lifted> {
    let rho = (m[0] * m[0] + m[1] * m[1]).sqrt();
    if rho > rho_max {
        return None;
    }
    let (p, dp) = solve::poly(pol, rho);
    let g = if rho > 0.0 { -dp / rho } else { 0.0 };
    Some(([m[0], m[1], -p], [[1.0, 0.0], [0.0, 1.0], [g * m[0], g * m[1]]]))
}

/// [`ocam`] per lane, with `pol` padded to `N` coefficients ([`solve::padded`]).
#[inline(always)]
pub(crate) fn ocam_lane<const N: usize>(pol: &[f64; N], rho_max: f64, m: [f64; 2]) -> LaneLifted {
    let rho = (m[0] * m[0] + m[1] * m[1]).sqrt();
    let (p, dp) = solve::poly_fixed(pol, rho);
    let g = if rho > 0.0 { -dp / rho } else { 0.0 };
    (
        !(rho > rho_max),
        ([m[0], m[1], -p], [[1.0, 0.0], [0.0, 1.0], [g * m[0], g * m[1]]]),
    )
}

/// [`Lift::FTheta`].
#[inline(always)]
pub(crate) fn ftheta(
    bw: Option<&[f64]>,
    fw: Option<&Forward>,
    rho_max: f64,
    theta_max: f64,
    m: [f64; 2],
) -> Option<Lifted> {
    let rho = (m[0] * m[0] + m[1] * m[1]).sqrt();
    if rho > rho_max {
        return None;
    }
    match (bw, fw) {
        (Some(bw), _) => {
            let (theta, dtheta) = solve::poly(bw, rho);
            let (sin, cos) = solve::sin_cos(theta);
            Some(angle_lift(m, rho, sin, cos, dtheta))
        }
        (None, Some(fw)) => Some(fw.lift_at(m, rho, fw.invert(rho, theta_max)?)),
        (None, None) => None,
    }
}

/// f-theta's forward polynomial (angle → pixel distance) with a table of its inverse, which seeds
/// the exact Newton solve of the backward direction.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Forward {
    /// The polynomial, ascending.
    pub coefficients: Vec<f64>,
    table: Option<InverseTable>,
}

impl Forward {
    /// Samples in the seed table: the (Hermite) seed is then within ~1e-13 rad of the root.
    const SAMPLES: usize = 512;

    /// The polynomial alone; [`Forward::tabulate`] adds the seed table once its range is known.
    pub fn new(coefficients: Vec<f64>) -> Self {
        Forward {
            coefficients,
            table: None,
        }
    }

    /// Tabulates the inverse over `ρ ∈ [0, ρ(θ_max)]`, with the polynomial increasing on
    /// `[0, θ_max]`.
    pub fn tabulate(&mut self, theta_max: f64) {
        let c = &self.coefficients;
        let rho_max = solve::poly(c, theta_max).0;
        if rho_max > 0.0 && rho_max.is_finite() {
            let f = |t| solve::poly(c, t);
            self.table = Some(InverseTable::new(rho_max, Self::SAMPLES, f, |r, g| {
                solve::solve_increasing(f, r, 0.0, theta_max, g)
            }));
        }
    }

    /// The angle of pixel distance `rho` (within `[0, θ_max]`), to the last bits.
    #[inline]
    pub fn invert(&self, rho: f64, theta_max: f64) -> Option<f64> {
        match self.seed(rho) {
            Some(seed) => Some(self.solve_from(rho, theta_max, seed)),
            None => {
                let f = |t| solve::poly(&self.coefficients, t);
                let guess = rho / f(0.0).1.max(1e-300);
                solve::solve_increasing(f, rho, 0.0, theta_max, guess)
            }
        }
    }

    /// The table's seed for the angle of `rho`, or `None` beyond the table.
    #[inline(always)]
    pub fn seed(&self, rho: f64) -> Option<f64> {
        self.table.as_ref().and_then(|t| t.seed(rho))
    }

    /// The angle of `rho` to the last bits, from a `seed` of [`Forward::seed`].
    #[inline(always)]
    pub fn solve_from(&self, rho: f64, theta_max: f64, seed: f64) -> f64 {
        solve::solve_bracketed(|t| solve::poly(&self.coefficients, t), rho, 0.0, theta_max, seed)
    }

    /// The ray of `m` (at distance `rho`) seen at angle `theta`, with its derivative.
    #[inline(always)]
    pub fn lift_at(&self, m: [f64; 2], rho: f64, theta: f64) -> Lifted {
        let dtheta = 1.0 / solve::poly(&self.coefficients, theta).1;
        let (sin, cos) = solve::sin_cos(theta);
        angle_lift(m, rho, sin, cos, dtheta)
    }
}

/// The double-sphere validity bound `w₂`: a point is valid when `z > −w₂·|X|`.
fn ds_w2(xi: f64, alpha: f64) -> f64 {
    let w1 = if alpha <= 0.5 {
        alpha / (1.0 - alpha)
    } else {
        (1.0 - alpha) / alpha
    };
    (w1 + xi) / (2.0 * w1 * xi + xi * xi + 1.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn lifts() -> Vec<Lift> {
        vec![
            Lift::Perspective,
            Lift::Equidistant,
            Lift::Unified {
                alpha: 0.6,
                beta: 1.1,
            },
            Lift::Unified {
                alpha: 0.3,
                beta: 0.9,
            },
            Lift::Mei { xi: 0.8 },
            Lift::Mei { xi: 1.4 },
            Lift::DoubleSphere {
                xi: -0.2,
                alpha: 0.59,
            },
            Lift::DoubleSphere { xi: 0.4, alpha: 0.3 },
            Lift::Division { k: -0.2 },
            Lift::Division { k: 0.15 },
            Lift::Fov {
                omega: 0.9,
                c: 2.0 * 0.45f64.tan(),
            },
            Lift::OCam {
                pol: vec![-1.0, 0.0, 0.4, -0.02],
                invpol: vec![],
                rho_max: 2.0,
            },
            Lift::FTheta {
                bw: Some(vec![0.0, 1.0, 0.05, -0.01]),
                fw: None,
                rho_max: 2.5,
                theta_max: 3.0,
            },
            Lift::FTheta {
                bw: None,
                fw: Some(Forward::new(vec![0.0, 1.0, -0.04, 0.002])),
                rho_max: 2.5,
                theta_max: 2.5,
            },
        ]
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let mut lifts = lifts();
        lifts.push(Lift::Equirect { w: 6.0, h: 3.0 });
        for l in &lifts {
            for m in [[0.3, -0.2], [-0.5, 0.41], [0.05, 0.7], [1.2, 0.9]] {
                let Some((_, j)) = l.lift(m) else { continue };
                let h = 1e-6;
                for k in 0..2 {
                    let (mut a, mut b) = (m, m);
                    a[k] += h;
                    b[k] -= h;
                    let (Some((fa, _)), Some((fb, _))) = (l.lift(a), l.lift(b)) else {
                        continue;
                    };
                    for i in 0..3 {
                        let fd = (fa[i] - fb[i]) / (2.0 * h);
                        assert!(
                            (fd - j[i][k]).abs() < 1e-6 * (1.0 + fd.abs()),
                            "{l:?} m {m:?} ∂V{i}/∂m{k}: fd {fd} vs {}",
                            j[i][k]
                        );
                    }
                }
            }
        }
    }

    proptest! {
        #[test]
        fn unlift_inverts_lift(x in -1.6f64..1.6, y in -1.6f64..1.6) {
            for l in lifts() {
                let Some((v, _)) = l.lift([x, y]) else { continue };
                let m = l.unlift(v);
                prop_assert!(m.is_some(), "{:?}: valid point ({}, {}) has a ray {:?} that does not unlift", l, x, y, v);
                let m = m.unwrap();
                prop_assert!((m[0] - x).abs() < 1e-9 && (m[1] - y).abs() < 1e-9, "{:?}: ({}, {}) came back as {:?}", l, x, y, m);
            }
        }

        #[test]
        fn lift_inverts_unlift(x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0) {
            let mut lifts = lifts();
            lifts.push(Lift::Equirect { w: 6.0, h: 3.0 });
            for l in lifts {
                let Some(m) = l.unlift([x, y, z]) else { continue };
                let lifted = l.lift(m);
                prop_assert!(lifted.is_some(), "{:?}: ray ({}, {}, {}) unlifted to {:?}, which does not lift", l, x, y, z, m);
                let (v, _) = lifted.unwrap();
                let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                let d = (x * x + y * y + z * z).sqrt();
                for (a, b) in v.iter().zip([x, y, z]) {
                    prop_assert!((a / n - b / d).abs() < 1e-9, "{:?}: ({}, {}, {}) → {:?} → {:?}", l, x, y, z, m, v);
                }
            }
        }
    }

    #[test]
    fn wide_models_see_behind_the_camera() {
        // Equidistant at |m| = 2.5 rad (143° off axis), Mei with ξ > 1, double sphere, equirect.
        assert!(Lift::Equidistant.lift([2.5, 0.0]).unwrap().0[2] < 0.0);
        let mei = Lift::Mei { xi: 1.4 };
        assert!(mei.lift([0.9, 0.0]).unwrap().0[2] < 0.0);
        assert!(
            mei.lift([1.0 / (1.4f64 * 1.4 - 1.0).sqrt() + 1e-6, 0.0])
                .is_none()
        );
        assert!(Lift::Division { k: -0.2 }.lift([3.0, 0.0]).unwrap().0[2] < 0.0);
        assert!(Lift::Equirect { w: 4.0, h: 2.0 }.lift([0.1, 1.0]).unwrap().0[2] < 0.0);
        assert!(Lift::Perspective.unlift([0.0, 0.0, -1.0]).is_none());
    }
}
