//! 3DEqualizer's lens-distortion models (the "Standard Models for Lens Distortion in 3DE4" and
//! the Classic model), as a calibrated camera: a plate pixel's ray through the lens, and back.
//!
//! # Coordinates (3DE's)
//!
//! For a plate of `W × H` pixels, raster `(x, y)` (y down, corner-based) is the unit coordinate
//! `u = x/W`, `v = 1 − y/H` (y up, (0, 0) the lower-left corner). The field-of-view knobs remap it,
//! `u' = (u − xa)/(xb − xa)`, `v' = (v − ya)/(yb − ya)`. With the **virtual** film back
//! `w_fb × h_fb` cm (physical width × pixel aspect), the lens-centre offset `(x_lco, y_lco)` cm and
//! the half diagonal `r_fb = ½·√(w_fb² + h_fb²)`, the diagonally normalised point is
//!
//! ```text
//! p = ( ((u' − ½)·w_fb − x_lco)/r_fb , ((v' − ½)·h_fb − y_lco)/r_fb )
//! ```
//!
//! Each model is the closed-form map `g: p ↦ p'` from the distorted (photographed) point to the
//! undistorted (pinhole) one, 3DE's `undistort`. The ray of the plate pixel is the pinhole ray of
//! `p'` with the focal length `fl` cm, centred on the lens centre: `V = (r_fb·p'ₓ, r_fb·p'ᵧ, fl)`
//! (y up; the calibrated camera hands out `(r_fb·p'ₓ, −r_fb·p'ᵧ, fl)`, OpenCV's y down).
//!
//! # The models (`p = (x, y)`, `r² = x² + y²`)
//!
//! - `3DE Classic LD Model` (δ, s, κx, κy, q): `x' = x·(1 + (δx² + (δ + κx)y² + q·r⁴)/s)`,
//!   `y' = y·(1 + (δ + κy)x² + δy² + q·r⁴)`.
//! - `3DE4 Radial - Standard, Degree 4`: `x̃ = x·(1 + c2·r² + c4·r⁴) + (r² + 2x²)(u2 + u4·r²) +
//!   2xy(v2 + v4·r²)`, `ỹ = y·(1 + c2·r² + c4·r⁴) + (r² + 2y²)(v2 + v4·r²) + 2xy(u2 + u4·r²)`,
//!   then the area-preserving cylindric stretch by `k = √(1 + b)` along direction φ and `1/k`
//!   across it: `p' = [[c²k + s²/k, (k − 1/k)cs], [(k − 1/k)cs, c²/k + s²k]]·p̃`.
//! - the anamorphic polynomial of degree N: `x' = x·(1 + Σ Cx_{i,d}·r^d·cos(iφ))`,
//!   `y' = y·(1 + Σ Cy_{i,d}·r^d·cos(iφ))`, φ the point's own angle, d = 2, 4 (, 6), i = 0, 2, …, d
//!   (evaluated in its Cartesian form).
//! - `3DE4 Anamorphic - Standard, Degree 4/6`: `p' = R(ψ)·diag(sx·pa, sy)·g_N(R(−ψ)·diag(1/pa, 1)·p)`
//!   with the lens rotation ψ (degrees) and the pixel aspect `pa`; `… - Rescaled` the same with
//!   `pa·ρ` for `pa` (ρ = `Rescale`); `3DE4 Anamorphic, Degree 6` is `g_6` alone.
//! - `3DE4 Radial - Fisheye, Degree 8`: with `f = fl/r_fb` and `r = |p|`, the equisolid plate
//!   `θ = 2·asin(r/2f)` is made rectilinear, `ρ = f·tan θ`, and
//!   `p' = (p/r)·ρ·(1 + c2ρ² + c4ρ⁴ + c6ρ⁶ + c8ρ⁸)`; only θ < 90° and ρ ≤ 50 (LDPK's clip) have a
//!   ray.
//!
//! # Both directions, and the fold
//!
//! Pixel → ray evaluates `g` (closed form) and its Jacobian (forward-mode derivatives of the very
//! same code). Ray → pixel solves `g(p) = p'` by damped Newton with the analytic Jacobian, falling
//! back to continuation from the lens centre, to the last bits. A model folds where `det ∂g/∂p`
//! reaches 0; the **primary region** is the set of points reached from the lens centre along a
//! straight segment on which `det ∂g/∂p > 0` (tabulated per direction when the model is built, and
//! checked point by point). Outside it a pixel has no ray (culled), and a ray whose solution would
//! lie outside it has no pixel: neither LDPK's diverged value nor the mirrored branch is ever
//! returned.

use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::solve::{Mat2, Mat32, det2, inv2};

/// The built-in knobs every 3DE model reads, in the order of `params`: focal length, virtual film
/// back, lens-centre offset (cm), pixel aspect, then the field-of-view knobs (unit coordinates).
pub const BUILTINS: [(&str, f64); 10] = [
    ("tde4_focal_length_cm", 1.0),
    ("tde4_filmback_width_cm", 0.8),
    ("tde4_filmback_height_cm", 0.6),
    ("tde4_lens_center_offset_x_cm", 0.0),
    ("tde4_lens_center_offset_y_cm", 0.0),
    ("tde4_pixel_aspect", 1.0),
    ("field_of_view_xa_unit", 0.0),
    ("field_of_view_xb_unit", 1.0),
    ("field_of_view_ya_unit", 0.0),
    ("field_of_view_yb_unit", 1.0),
];

/// One of 3DE's models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    /// `3DE Classic LD Model`.
    Classic,
    /// `3DE4 Radial - Standard, Degree 4`.
    RadialStandard4,
    /// `3DE4 Anamorphic - Standard, Degree 4`.
    AnamorphicStandard4,
    /// `3DE4 Anamorphic - Standard, Degree 6`.
    AnamorphicStandard6,
    /// `3DE4 Anamorphic - Rescaled, Degree 4`.
    AnamorphicRescaled4,
    /// `3DE4 Anamorphic - Rescaled, Degree 6`.
    AnamorphicRescaled6,
    /// `3DE4 Anamorphic, Degree 6` (the older model, no extenders).
    Anamorphic6,
    /// `3DE4 Radial - Fisheye, Degree 8`.
    RadialFisheye8,
}

const ANAMORPHIC_4: [&str; 10] = [
    "Cx02 - Degree 2",
    "Cy02 - Degree 2",
    "Cx22 - Degree 2",
    "Cy22 - Degree 2",
    "Cx04 - Degree 4",
    "Cy04 - Degree 4",
    "Cx24 - Degree 4",
    "Cy24 - Degree 4",
    "Cx44 - Degree 4",
    "Cy44 - Degree 4",
];

const ANAMORPHIC_6: [&str; 8] = [
    "Cx06 - Degree 6",
    "Cy06 - Degree 6",
    "Cx26 - Degree 6",
    "Cy26 - Degree 6",
    "Cx46 - Degree 6",
    "Cy46 - Degree 6",
    "Cx66 - Degree 6",
    "Cy66 - Degree 6",
];

/// Every model, in the order of [`Kind`].
pub const KINDS: [Kind; 8] = [
    Kind::Classic,
    Kind::RadialStandard4,
    Kind::AnamorphicStandard4,
    Kind::AnamorphicStandard6,
    Kind::AnamorphicRescaled4,
    Kind::AnamorphicRescaled6,
    Kind::Anamorphic6,
    Kind::RadialFisheye8,
];

impl Kind {
    /// The model's name, exactly as 3DE writes it (the `model` parameter).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Kind::Classic => "3DE Classic LD Model",
            Kind::RadialStandard4 => "3DE4 Radial - Standard, Degree 4",
            Kind::AnamorphicStandard4 => "3DE4 Anamorphic - Standard, Degree 4",
            Kind::AnamorphicStandard6 => "3DE4 Anamorphic - Standard, Degree 6",
            Kind::AnamorphicRescaled4 => "3DE4 Anamorphic - Rescaled, Degree 4",
            Kind::AnamorphicRescaled6 => "3DE4 Anamorphic - Rescaled, Degree 6",
            Kind::Anamorphic6 => "3DE4 Anamorphic, Degree 6",
            Kind::RadialFisheye8 => "3DE4 Radial - Fisheye, Degree 8",
        }
    }

    /// The class of LDPK's Nuke node for the model.
    #[must_use]
    pub fn nuke_class(self) -> &'static str {
        match self {
            Kind::Classic => "LD_3DE_Classic_LD_Model",
            Kind::RadialStandard4 => "LD_3DE4_Radial_Standard_Degree_4",
            Kind::AnamorphicStandard4 => "LD_3DE4_Anamorphic_Standard_Degree_4",
            Kind::AnamorphicStandard6 => "LD_3DE4_Anamorphic_Standard_Degree_6",
            Kind::AnamorphicRescaled4 => "LD_3DE4_Anamorphic_Rescaled_Degree_4",
            Kind::AnamorphicRescaled6 => "LD_3DE4_Anamorphic_Rescaled_Degree_6",
            Kind::Anamorphic6 => "LD_3DE4_Anamorphic_Degree_6",
            Kind::RadialFisheye8 => "LD_3DE4_Radial_Fisheye_Degree_8",
        }
    }

    /// The model by its 3DE name.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Kind> {
        KINDS.into_iter().find(|k| k.name() == name)
    }

    /// The model's own parameters (after [`BUILTINS`]) with their defaults, named as 3DE names them.
    #[must_use]
    pub fn params(self) -> Vec<(&'static str, f64)> {
        let zero = |names: &[&'static str]| names.iter().map(|&n| (n, 0.0)).collect::<Vec<_>>();
        let extenders = |rescaled: bool| {
            let mut v = vec![("Lens Rotation", 0.0), ("Squeeze-X", 1.0), ("Squeeze-Y", 1.0)];
            if rescaled {
                v.push(("Rescale", 1.0));
            }
            v
        };
        match self {
            Kind::Classic => vec![
                ("Distortion", 0.0),
                ("Anamorphic Squeeze", 1.0),
                ("Curvature X", 0.0),
                ("Curvature Y", 0.0),
                ("Quartic Distortion", 0.0),
            ],
            Kind::RadialStandard4 => zero(&[
                "Distortion - Degree 2",
                "U - Degree 2",
                "V - Degree 2",
                "Quartic Distortion - Degree 4",
                "U - Degree 4",
                "V - Degree 4",
                "Phi - Cylindric Direction",
                "B - Cylindric Bending",
            ]),
            Kind::AnamorphicStandard4 | Kind::AnamorphicRescaled4 => {
                let mut v = zero(&ANAMORPHIC_4);
                v.extend(extenders(self == Kind::AnamorphicRescaled4));
                v
            }
            Kind::AnamorphicStandard6 | Kind::AnamorphicRescaled6 | Kind::Anamorphic6 => {
                let mut v = zero(&ANAMORPHIC_4);
                v.extend(zero(&ANAMORPHIC_6));
                if self != Kind::Anamorphic6 {
                    v.extend(extenders(self == Kind::AnamorphicRescaled6));
                }
                v
            }
            Kind::RadialFisheye8 => zero(&[
                "Distortion - Degree 2",
                "Quartic Distortion - Degree 4",
                "Degree 6",
                "Degree 8",
            ]),
        }
    }

    /// Every parameter of `params` in order: [`BUILTINS`], then [`Kind::params`].
    #[must_use]
    pub fn all_params(self) -> Vec<(&'static str, f64)> {
        let mut v = BUILTINS.to_vec();
        v.extend(self.params());
        v
    }
}

/// The Nuke knob of a 3DE parameter name: every maximal run of characters other than ASCII letters
/// and digits becomes one `_` (LDPK 2's rule); a leading digit gets a `_` in front.
#[must_use]
pub fn knob_name(name: &str) -> String {
    let mut out = String::new();
    let mut gap = false;
    for ch in name.chars() {
        if ch.is_ascii_alphanumeric() {
            if gap && !out.is_empty() {
                out.push('_');
            }
            gap = false;
            out.push(ch);
        } else {
            gap = true;
        }
    }
    if gap {
        out.push('_');
    }
    if out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, '_');
    }
    out
}

/// The knob of the legacy (LDPK 1, Weta-era) nodes: one `_` per character other than a letter or
/// digit (`Distortion - Degree 2` → `Distortion___Degree_2`).
#[must_use]
pub fn legacy_knob_name(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// A number with its derivatives by the two coordinates of a point (forward-mode differentiation),
/// so each model is written once and gives its Jacobian exactly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct D2 {
    v: f64,
    d: [f64; 2],
}

/// What a model's formulas need of a number: `f64` for values alone, [`D2`] with derivatives.
pub(crate) trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    fn c(x: f64) -> Self;
    fn val(self) -> f64;
    fn sqrt(self) -> Self;
    fn asin(self) -> Self;
    fn tan(self) -> Self;
}

impl Real for f64 {
    fn c(x: f64) -> Self {
        x
    }
    fn val(self) -> f64 {
        self
    }
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    fn asin(self) -> Self {
        f64::asin(self)
    }
    fn tan(self) -> Self {
        f64::tan(self)
    }
}

impl D2 {
    fn chain(self, v: f64, dv: f64) -> D2 {
        D2 {
            v,
            d: [self.d[0] * dv, self.d[1] * dv],
        }
    }
}

impl Add for D2 {
    type Output = D2;
    fn add(self, o: D2) -> D2 {
        D2 {
            v: self.v + o.v,
            d: [self.d[0] + o.d[0], self.d[1] + o.d[1]],
        }
    }
}
impl Sub for D2 {
    type Output = D2;
    fn sub(self, o: D2) -> D2 {
        D2 {
            v: self.v - o.v,
            d: [self.d[0] - o.d[0], self.d[1] - o.d[1]],
        }
    }
}
impl Mul for D2 {
    type Output = D2;
    fn mul(self, o: D2) -> D2 {
        D2 {
            v: self.v * o.v,
            d: [
                self.d[0] * o.v + self.v * o.d[0],
                self.d[1] * o.v + self.v * o.d[1],
            ],
        }
    }
}
impl Div for D2 {
    type Output = D2;
    fn div(self, o: D2) -> D2 {
        let q = self.v / o.v;
        D2 {
            v: q,
            d: [(self.d[0] - q * o.d[0]) / o.v, (self.d[1] - q * o.d[1]) / o.v],
        }
    }
}
impl Neg for D2 {
    type Output = D2;
    fn neg(self) -> D2 {
        D2 {
            v: -self.v,
            d: [-self.d[0], -self.d[1]],
        }
    }
}
impl Real for D2 {
    fn c(x: f64) -> Self {
        D2 { v: x, d: [0.0; 2] }
    }
    fn val(self) -> f64 {
        self.v
    }
    fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        self.chain(s, 0.5 / s)
    }
    fn asin(self) -> Self {
        self.chain(self.v.asin(), 1.0 / (1.0 - self.v * self.v).sqrt())
    }
    fn tan(self) -> Self {
        let t = self.v.tan();
        self.chain(t, 1.0 + t * t)
    }
}

/// The model function `g` of one model with its parameters, in diagonally normalised coordinates.
#[derive(Debug, Clone, PartialEq)]
enum Map {
    Classic {
        delta: f64,
        squeeze: f64,
        cx: f64,
        cy: f64,
        quartic: f64,
    },
    Radial {
        c2: f64,
        u2: f64,
        v2: f64,
        c4: f64,
        u4: f64,
        v4: f64,
        /// The cylindric stretch matrix.
        cyl: Mat2,
    },
    Anamorphic {
        /// Cx02, Cx22, Cx04, Cx24, Cx44, Cx06, Cx26, Cx46, Cx66 as the Cartesian coefficients of
        /// x's multiplier (see [`cartesian`]).
        mx: [f64; 9],
        /// The same for y.
        my: [f64; 9],
        /// `pa` (times ρ for Rescaled) dividing x before the polynomial; 1 for the old model.
        pa: f64,
        /// cos ψ, sin ψ of the lens rotation.
        rot: [f64; 2],
        /// `sx·pa`, `sy` after the polynomial.
        scale: [f64; 2],
    },
    Fisheye {
        /// `fl/r_fb`.
        f: f64,
        c: [f64; 4],
    },
}

/// The Cartesian coefficients of `1 + Σ C_{i,d}·r^d·cos(iφ)` from `[C02, C22, C04, C24, C44, C06,
/// C26, C46, C66]`: the multipliers of x², y², x⁴, x²y², y⁴, x⁶, x⁴y², x²y⁴, y⁶.
fn cartesian(c: [f64; 9]) -> [f64; 9] {
    let [c02, c22, c04, c24, c44, c06, c26, c46, c66] = c;
    [
        c02 + c22,
        c02 - c22,
        c04 + c24 + c44,
        2.0 * c04 - 6.0 * c44,
        c04 - c24 + c44,
        c06 + c26 + c46 + c66,
        3.0 * c06 + c26 - 5.0 * c46 - 15.0 * c66,
        3.0 * c06 - c26 - 5.0 * c46 + 15.0 * c66,
        c06 - c26 + c46 - c66,
    ]
}

#[inline(always)]
fn multiplier<T: Real>(k: &[f64; 9], x2: T, y2: T) -> T {
    let c = T::c;
    let quad = c(k[0]) * x2 + c(k[1]) * y2;
    let quart = (c(k[2]) * x2 + c(k[3]) * y2) * x2 + c(k[4]) * y2 * y2;
    let sext = ((c(k[5]) * x2 + c(k[6]) * y2) * x2 + c(k[7]) * y2 * y2) * x2 + c(k[8]) * y2 * y2 * y2;
    c(1.0) + quad + quart + sext
}

impl Map {
    /// `g(p)`, or `None` outside the model's domain (the fisheye's θ ≥ 90°).
    #[inline]
    fn eval<T: Real>(&self, p: [T; 2]) -> Option<[T; 2]> {
        let c = T::c;
        let [x, y] = p;
        match *self {
            Map::Classic {
                delta,
                squeeze,
                cx,
                cy,
                quartic,
            } => {
                let (x2, y2) = (x * x, y * y);
                let r4 = (x2 + y2) * (x2 + y2);
                let qx = (c(delta) * x2 + c(delta + cx) * y2 + c(quartic) * r4) / c(squeeze);
                let qy = c(delta + cy) * x2 + c(delta) * y2 + c(quartic) * r4;
                Some([x * (c(1.0) + qx), y * (c(1.0) + qy)])
            }
            Map::Radial {
                c2,
                u2,
                v2,
                c4,
                u4,
                v4,
                cyl,
            } => {
                let r2 = x * x + y * y;
                let radial = c(1.0) + c(c2) * r2 + c(c4) * r2 * r2;
                let (u, v) = (c(u2) + c(u4) * r2, c(v2) + c(v4) * r2);
                let xy2 = c(2.0) * x * y;
                let xt = x * radial + (r2 + c(2.0) * x * x) * u + xy2 * v;
                let yt = y * radial + (r2 + c(2.0) * y * y) * v + xy2 * u;
                Some([
                    c(cyl[0][0]) * xt + c(cyl[0][1]) * yt,
                    c(cyl[1][0]) * xt + c(cyl[1][1]) * yt,
                ])
            }
            Map::Anamorphic {
                ref mx,
                ref my,
                pa,
                rot: [cs, sn],
                scale,
            } => {
                let xs = x / c(pa);
                // R(−ψ)
                let (xl, yl) = (c(cs) * xs + c(sn) * y, c(cs) * y - c(sn) * xs);
                let (x2, y2) = (xl * xl, yl * yl);
                let xa = xl * multiplier(mx, x2, y2) * c(scale[0]);
                let ya = yl * multiplier(my, x2, y2) * c(scale[1]);
                // R(+ψ)
                Some([c(cs) * xa - c(sn) * ya, c(sn) * xa + c(cs) * ya])
            }
            Map::Fisheye { f, c: k } => {
                let r2 = x * x + y * y;
                // θ < 90° ⇔ r < √2·f.
                if r2.val() >= 2.0 * f * f || r2.val().is_nan() {
                    return None;
                }
                // ρ/r, smooth at the centre (its series 1 + 3r²/8f² + O(r⁴) below 1e-4 f).
                let ratio = if r2.val() < 1e-8 * f * f {
                    c(1.0) + c(3.0 / (8.0 * f * f)) * r2
                } else {
                    let r = r2.sqrt();
                    let theta = c(2.0) * (r / c(2.0 * f)).asin();
                    c(f) * theta.tan() / r
                };
                let rho2 = ratio * ratio * r2;
                // LDPK clips the rectilinear radius at 50 dn: beyond it (θ within a hair of 90°)
                // the polynomial has no meaning, so there is no ray.
                if rho2.val() > FISHEYE_MAX_RHO * FISHEYE_MAX_RHO || rho2.val().is_nan() {
                    return None;
                }
                let poly = c(1.0) + rho2 * (c(k[0]) + rho2 * (c(k[1]) + rho2 * (c(k[2]) + rho2 * c(k[3]))));
                let s = ratio * poly;
                Some([x * s, y * s])
            }
        }
    }

    /// `g(p)` with `∂g/∂p`.
    #[inline]
    fn eval_jacobian(&self, p: [f64; 2]) -> Option<([f64; 2], Mat2)> {
        let q = self.eval([
            D2 {
                v: p[0],
                d: [1.0, 0.0],
            },
            D2 {
                v: p[1],
                d: [0.0, 1.0],
            },
        ])?;
        let out = [q[0].v, q[1].v];
        (out[0].is_finite() && out[1].is_finite()).then_some((out, [q[0].d, q[1].d]))
    }
}

/// The largest rectilinear radius (dn) of the fisheye's domain, LDPK's clip.
const FISHEYE_MAX_RHO: f64 = 50.0;

/// How far (relative radius) inside the fold a pixel must lie to have a ray.
const FOLD_MARGIN: f64 = 1e-4;

/// Directions of the fold table.
const FOLD_DIRECTIONS: usize = 128;
/// Radial steps of the fold search per direction, up to the table's radius.
const FOLD_STEPS: usize = 64;

/// A 3DE lens on a plate: the model, the film back, and the plate's size.
#[derive(Debug, Clone, PartialEq)]
pub struct Lens {
    kind: Kind,
    map: Map,
    /// `fl`, cm.
    focal: f64,
    /// Half diagonal of the film back, cm.
    r_fb: f64,
    /// Pixel → dn: `p = (a[0]·x + b[0], a[1]·y + b[1])`.
    a: [f64; 2],
    b: [f64; 2],
    /// The first radius where the primary region ends, per direction (angle `2πi/N`).
    fold: Vec<f64>,
}

impl Lens {
    /// A lens of `kind` from `params` in the order of [`Kind::all_params`], on a plate of
    /// `width × height` pixels.
    ///
    /// # Errors
    /// A message naming the parameter (as 3DE names it) and what was expected: a film back, focal
    /// length, pixel aspect, squeeze or rescale ≤ 0, an empty field of view, a bending ≤ −1.
    pub fn new(kind: Kind, params: &[f64], width: f64, height: f64) -> Result<Lens, String> {
        let names = kind.all_params();
        if params.len() != names.len() {
            return Err(format!(
                "model {}: takes {} params ({}), got {}",
                kind.name(),
                names.len(),
                names.iter().map(|n| n.0).collect::<Vec<_>>().join(", "),
                params.len()
            ));
        }
        let get = |name: &str| -> f64 {
            let i = names
                .iter()
                .position(|n| n.0 == name)
                .expect("a parameter of the model");
            params[i]
        };
        let positive = |name: &str| -> Result<f64, String> {
            let v = get(name);
            if v > 0.0 {
                Ok(v)
            } else {
                Err(format!("model {}: {name} must be > 0, got {v}", kind.name()))
            }
        };
        let focal = positive("tde4_focal_length_cm")?;
        let (w_fb, h_fb) = (
            positive("tde4_filmback_width_cm")?,
            positive("tde4_filmback_height_cm")?,
        );
        let pa = positive("tde4_pixel_aspect")?;
        let (xa, xb, ya, yb) = (
            get("field_of_view_xa_unit"),
            get("field_of_view_xb_unit"),
            get("field_of_view_ya_unit"),
            get("field_of_view_yb_unit"),
        );
        if xb <= xa || yb <= ya {
            return Err(format!(
                "model {}: the field of view must not be empty: field_of_view_xa_unit {xa} < field_of_view_xb_unit {xb} and field_of_view_ya_unit {ya} < field_of_view_yb_unit {yb} expected",
                kind.name()
            ));
        }
        let r_fb = 0.5 * w_fb.hypot(h_fb);
        let (lx, ly) = (
            get("tde4_lens_center_offset_x_cm"),
            get("tde4_lens_center_offset_y_cm"),
        );
        // u' = (x/W − xa)/(xb − xa); p.x = ((u' − ½)·w_fb − x_lco)/r_fb. Likewise y with v = 1 − y/H.
        let a = [
            w_fb / (width * (xb - xa) * r_fb),
            -h_fb / (height * (yb - ya) * r_fb),
        ];
        let b = [
            ((-xa / (xb - xa) - 0.5) * w_fb - lx) / r_fb,
            (((1.0 - ya) / (yb - ya) - 0.5) * h_fb - ly) / r_fb,
        ];
        let base = BUILTINS.len();
        let m = &params[base..];
        let anamorphic = |rotation: bool| -> Result<Map, String> {
            let c6 = |i: usize| m.get(10 + i).copied().unwrap_or(0.0);
            let deg6 = kind != Kind::AnamorphicStandard4 && kind != Kind::AnamorphicRescaled4;
            let coefs = |o: usize| {
                let six = if deg6 {
                    [c6(o), c6(2 + o), c6(4 + o), c6(6 + o)]
                } else {
                    [0.0; 4]
                };
                cartesian([
                    m[o],
                    m[2 + o],
                    m[4 + o],
                    m[6 + o],
                    m[8 + o],
                    six[0],
                    six[1],
                    six[2],
                    six[3],
                ])
            };
            let (mut pa_in, mut rot, mut scale) = (1.0, [1.0, 0.0], [1.0, 1.0]);
            if rotation {
                let rescale = if matches!(kind, Kind::AnamorphicRescaled4 | Kind::AnamorphicRescaled6) {
                    positive("Rescale")?
                } else {
                    1.0
                };
                let psi = get("Lens Rotation").to_radians();
                pa_in = pa * rescale;
                rot = [psi.cos(), psi.sin()];
                scale = [positive("Squeeze-X")? * pa_in, positive("Squeeze-Y")?];
            }
            Ok(Map::Anamorphic {
                mx: coefs(0),
                my: coefs(1),
                pa: pa_in,
                rot,
                scale,
            })
        };
        let map = match kind {
            Kind::Classic => Map::Classic {
                delta: m[0],
                squeeze: positive("Anamorphic Squeeze")?,
                cx: m[2],
                cy: m[3],
                quartic: m[4],
            },
            Kind::RadialStandard4 => {
                let bend = get("B - Cylindric Bending");
                if bend <= -1.0 {
                    return Err(format!(
                        "model {}: B - Cylindric Bending must be > -1 (the stretch is sqrt(1 + B)), got {bend}",
                        kind.name()
                    ));
                }
                let k = (1.0 + bend).sqrt();
                let phi = get("Phi - Cylindric Direction").to_radians();
                let (c, s) = (phi.cos(), phi.sin());
                let off = (k - 1.0 / k) * c * s;
                Map::Radial {
                    c2: m[0],
                    u2: m[1],
                    v2: m[2],
                    c4: m[3],
                    u4: m[4],
                    v4: m[5],
                    cyl: [[c * c * k + s * s / k, off], [off, c * c / k + s * s * k]],
                }
            }
            Kind::Anamorphic6 => anamorphic(false)?,
            Kind::AnamorphicStandard4
            | Kind::AnamorphicStandard6
            | Kind::AnamorphicRescaled4
            | Kind::AnamorphicRescaled6 => anamorphic(true)?,
            Kind::RadialFisheye8 => Map::Fisheye {
                f: focal / r_fb,
                c: [m[0], m[1], m[2], m[3]],
            },
        };
        let mut lens = Lens {
            kind,
            map,
            focal,
            r_fb,
            a,
            b,
            fold: Vec::new(),
        };
        // The table reaches well past the plate: 3 × the farthest corner's dn radius.
        let corners = [[0.0, 0.0], [width, 0.0], [0.0, height], [width, height]];
        let reach = corners
            .iter()
            .map(|&c| {
                let p = lens.dn(c);
                p[0].hypot(p[1])
            })
            .fold(0.0, f64::max);
        lens.fold = lens.fold_table(3.0 * reach.max(1.0));
        Ok(lens)
    }

    /// The model.
    #[must_use]
    pub fn kind(&self) -> Kind {
        self.kind
    }

    /// The diagonally normalised point of raster position `px`.
    #[inline]
    fn dn(&self, px: [f64; 2]) -> [f64; 2] {
        [self.a[0] * px[0] + self.b[0], self.a[1] * px[1] + self.b[1]]
    }

    /// The raster position of a diagonally normalised point.
    #[inline]
    fn raster(&self, p: [f64; 2]) -> [f64; 2] {
        [(p[0] - self.b[0]) / self.a[0], (p[1] - self.b[1]) / self.a[1]]
    }

    /// For each direction, the first radius where `det ∂g/∂p ≤ 0` or `g` is undefined (scanned,
    /// then bisected), or `reach`.
    fn fold_table(&self, reach: f64) -> Vec<f64> {
        let good = |p: [f64; 2]| self.map.eval_jacobian(p).is_some_and(|(_, j)| det2(&j) > 0.0);
        (0..FOLD_DIRECTIONS)
            .map(|i| {
                let phi = std::f64::consts::TAU * i as f64 / FOLD_DIRECTIONS as f64;
                let dir = [phi.cos(), phi.sin()];
                let at = |r: f64| [dir[0] * r, dir[1] * r];
                let step = reach / FOLD_STEPS as f64;
                match (1..=FOLD_STEPS).find(|&k| !good(at(step * k as f64))) {
                    None => reach,
                    Some(k) => {
                        crate::solve::bisect(step * (k - 1) as f64, step * k as f64, 60, |r| good(at(r)))
                    }
                }
            })
            .collect()
    }

    /// The fold radius in the direction of `p` (linear between the table's directions).
    fn fold_radius(&self, p: [f64; 2]) -> f64 {
        let n = FOLD_DIRECTIONS as f64;
        let t = p[1].atan2(p[0]).rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU * n;
        let i = (t.floor() as usize).min(FOLD_DIRECTIONS - 1);
        let f = t - i as f64;
        let (r0, r1) = (self.fold[i], self.fold[(i + 1) % FOLD_DIRECTIONS]);
        r0 + f * (r1 - r0)
    }

    /// `g(p)` and its Jacobian when `p` is in the primary region shrunk by the relative `margin`.
    #[inline]
    fn primary_within(&self, p: [f64; 2], margin: f64) -> Option<([f64; 2], Mat2)> {
        if p[0].hypot(p[1]) >= self.fold_radius(p) * (1.0 - margin) {
            return None;
        }
        let (q, j) = self.map.eval_jacobian(p)?;
        (det2(&j) > 0.0).then_some((q, j))
    }

    /// `g(p)` and its Jacobian when `p` is in the primary region.
    #[inline]
    fn primary(&self, p: [f64; 2]) -> Option<([f64; 2], Mat2)> {
        self.primary_within(p, 0.0)
    }

    /// 3DE's `undistort` of a raster position: the undistorted raster position on the same plate
    /// (same film back and field of view), or `None` outside the primary region.
    #[must_use]
    pub fn undistort(&self, px: [f64; 2]) -> Option<[f64; 2]> {
        self.primary(self.dn(px)).map(|(q, _)| self.raster(q))
    }

    /// 3DE's `distort` of a raster position (the exact inverse of [`Lens::undistort`]), or `None`
    /// when the point has no preimage in the primary region (beyond the fold).
    #[must_use]
    pub fn distort(&self, px: [f64; 2]) -> Option<[f64; 2]> {
        self.solve(self.dn(px)).map(|p| self.raster(p))
    }

    /// The ray (OpenCV camera space, y down, not unit) of raster position `px` with its derivative
    /// by `px`, or `None` outside the primary region.
    #[inline]
    pub(crate) fn ray(&self, px: [f64; 2]) -> Option<([f64; 3], Mat32)> {
        // A pixel within 1e-4 (relative) of the fold has no ray: there the inverse is so
        // ill-conditioned that the ray's own rounding (f32 in a render) could carry it past the
        // fold's image, and the pixel would have a ray without a pixel.
        let (q, j) = self.primary_within(self.dn(px), FOLD_MARGIN)?;
        let (sx, sy) = (self.r_fb * self.a[0], -self.r_fb * self.a[1]);
        Some((
            [self.r_fb * q[0], -self.r_fb * q[1], self.focal],
            [
                [j[0][0] * sx, j[0][1] * -sy],
                [-j[1][0] * sx, j[1][1] * sy],
                [0.0, 0.0],
            ],
        ))
    }

    /// The raster position whose ray is `d` (OpenCV camera space, any length), or `None`.
    pub(crate) fn pixel(&self, d: [f64; 3]) -> Option<[f64; 2]> {
        if d[2] <= 0.0 || d[2].is_nan() {
            return None;
        }
        let k = self.focal / (d[2] * self.r_fb);
        let q = [d[0] * k, -d[1] * k];
        let p = self.solve(q)?;
        let px = self.raster(p);
        (px[0].is_finite() && px[1].is_finite()).then_some(px)
    }

    /// The point `p` of the primary region with `g(p) = q`, by damped Newton from `q` and, failing
    /// that, by continuation from the lens centre (`g(0) = 0`) along `t·q`.
    fn solve(&self, q: [f64; 2]) -> Option<[f64; 2]> {
        if !(q[0].is_finite() && q[1].is_finite()) {
            return None;
        }
        if let Some(p) = self.newton(q, q) {
            return Some(p);
        }
        const STEPS: usize = 16;
        let mut p = [0.0, 0.0];
        for k in 1..=STEPS {
            let t = k as f64 / STEPS as f64;
            p = self.newton([q[0] * t, q[1] * t], p)?;
        }
        Some(p)
    }

    /// Damped Newton for `g(p) = q` from `start`, staying in the primary region; `None` when it
    /// does not converge there.
    fn newton(&self, q: [f64; 2], start: [f64; 2]) -> Option<[f64; 2]> {
        let tol = 1e-15 * (1.0 + q[0].abs() + q[1].abs());
        let mut p = start;
        let (mut g, mut j) = self.primary(p)?;
        let residual = |g: [f64; 2]| (g[0] - q[0]).hypot(g[1] - q[1]);
        let mut res = residual(g);
        for _ in 0..crate::solve::MAX_ITERATIONS {
            if res <= tol {
                return Some(p);
            }
            let ji = inv2(&j)?;
            let e = [q[0] - g[0], q[1] - g[1]];
            let step = [
                ji[0][0] * e[0] + ji[0][1] * e[1],
                ji[1][0] * e[0] + ji[1][1] * e[1],
            ];
            let mut scale = 1.0;
            let mut moved = false;
            for _ in 0..40 {
                let next = [p[0] + scale * step[0], p[1] + scale * step[1]];
                if let Some((gn, jn)) = self.primary(next) {
                    let rn = residual(gn);
                    if rn < res || rn <= tol {
                        (p, g, j, res) = (next, gn, jn, rn);
                        moved = true;
                        break;
                    }
                }
                scale *= 0.5;
            }
            if !moved {
                // No decrease: converged to the last bits, or stuck at the fold.
                return (res <= 1e-12 * (1.0 + q[0].abs() + q[1].abs())).then_some(p);
            }
        }
        (res <= 1e-12 * (1.0 + q[0].abs() + q[1].abs())).then_some(p)
    }

    /// The pinhole 3DE's model undistorts to, as COLMAP's `PINHOLE` `[fx, fy, cx, cy]` on this
    /// plate's raster (pixel centres at `i + ½`): the undistorted raster position `q` has the ray
    /// `((q_x − c_x)/f_x, (q_y − c_y)/f_y, 1)`, with `f_x = fl/(r_fb·a_x)`, `f_y = fl/(r_fb·|a_y|)`
    /// (`a` the raster → diagonally normalised scale, `r_fb` the half diagonal of the film back)
    /// and `c` the raster position of the lens centre (`dn = 0`). It is the camera of the plate's
    /// undistorted image (Nuke's `LD_3DE4_*` node in undistort mode), which an overscanned render
    /// extends.
    #[must_use]
    pub fn pinhole(&self) -> [f64; 4] {
        [
            self.focal / (self.r_fb * self.a[0]),
            -self.focal / (self.r_fb * self.a[1]),
            -self.b[0] / self.a[0],
            -self.b[1] / self.a[1],
        ]
    }

    /// The bounding box (x0, y0, x1, y1), raster, y down, of the undistorted image of the plate's
    /// `width × height` frame: the extremes of [`Lens::undistort`] along the four edges, sampled
    /// densely (the frame's edge points beyond the fold are left out).
    #[must_use]
    pub fn undistorted_box(&self, width: f64, height: f64) -> Option<[f64; 4]> {
        const SAMPLES: usize = 2048;
        let mut bx = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
        for i in 0..=SAMPLES {
            let f = i as f64 / SAMPLES as f64;
            for px in [
                [f * width, 0.0],
                [f * width, height],
                [0.0, f * height],
                [width, f * height],
            ] {
                if let Some(q) = self.undistort(px) {
                    bx = [bx[0].min(q[0]), bx[1].min(q[1]), bx[2].max(q[0]), bx[3].max(q[1])];
                }
            }
        }
        bx.iter().all(|v| v.is_finite()).then_some(bx)
    }
}

/// A 3DE lens fitted to another camera ([`fit_radial_standard`]): its parameters and how far it
/// stays from the camera.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The parameters of [`Kind::RadialStandard4`] in [`Kind::all_params`] order.
    pub params: Vec<f64>,
    /// The root mean square distance, in pixels of the plate, between the fitted lens's
    /// undistorted position and the camera's, over the grid points both map.
    pub rms_px: f64,
    /// The largest such distance.
    pub max_px: f64,
    /// The grid points used.
    pub points: usize,
}

/// The plate width, in cm, of the virtual film back a fitted lens is given (3DE's model is in unit
/// coordinates: any back with the right aspect and focal length is the same lens).
const FIT_BACK_WIDTH_CM: f64 = 3.6;

/// Fits `3DE4 Radial - Standard, Degree 4` to a camera on a `width × height` plate: `ray(px)` is
/// the camera's ray (OpenCV camera space, y down, any length) through raster position `px`, or
/// `None`, and `pinhole = [fx, fy, cx, cy]` (raster, COLMAP's pixel centres) the pinhole it
/// undistorts to. The lens's built-ins reproduce that pinhole exactly (film back
/// `3.6 × 3.6·(H/W)·(fx/fy)` cm, focal `fx·3.6/W` cm, the lens-centre offset of `(cx, cy)` from
/// the plate's centre, no field-of-view crop, pixel aspect 1); its distortion `c2, u2, v2, c4, u4,
/// v4` (no cylindric bending) minimises `Σ |undistort(px) − q(px)|²` over a `grid × grid` lattice
/// of the plate's edges and inside, `q(px) = (fx·d_x/d_z + cx, fy·d_y/d_z + cy)` the camera's
/// undistorted position. The model's undistort is linear in those six coefficients, so the least
/// squares problem is linear and solved exactly (normal equations, 6 × 6).
///
/// # Errors
/// A message when the pinhole is not positive and finite, fewer than 6 grid points have a ray in
/// front of the camera, or the points do not determine the coefficients.
pub fn fit_radial_standard(
    pinhole: [f64; 4],
    width: f64,
    height: f64,
    ray: &dyn Fn([f64; 2]) -> Option<[f64; 3]>,
    grid: usize,
) -> Result<Fit, String> {
    let [fx, fy, cx, cy] = pinhole;
    if !(fx > 0.0 && fy > 0.0 && cx.is_finite() && cy.is_finite() && fx.is_finite() && fy.is_finite()) {
        return Err(format!(
            "the pinhole {pinhole:?} (fx, fy, cx, cy) must have positive finite focal lengths"
        ));
    }
    let kind = Kind::RadialStandard4;
    let k = FIT_BACK_WIDTH_CM / width;
    let (w_fb, h_fb) = (FIT_BACK_WIDTH_CM, height * k * fx / fy);
    let builtins = [
        ("tde4_focal_length_cm", fx * k),
        ("tde4_filmback_width_cm", w_fb),
        ("tde4_filmback_height_cm", h_fb),
        ("tde4_lens_center_offset_x_cm", (cx - 0.5 * width) * k),
        (
            "tde4_lens_center_offset_y_cm",
            (0.5 * height - cy) * h_fb / height,
        ),
    ];
    let coefficients: Vec<&str> = kind.params().iter().take(6).map(|p| p.0).collect();
    let with = |c: &[f64]| -> Vec<f64> {
        kind.all_params()
            .iter()
            .map(|(n, d)| {
                builtins
                    .iter()
                    .find(|b| b.0 == *n)
                    .map(|b| b.1)
                    .or_else(|| coefficients.iter().position(|m| m == n).map(|i| c[i]))
                    .unwrap_or(*d)
            })
            .collect()
    };
    let lens_of = |c: &[f64]| Lens::new(kind, &with(c), width, height);
    let identity = lens_of(&[0.0; 6])?;
    // Each coefficient's column: the undistort with that coefficient alone, less the identity.
    let units: Vec<Lens> = (0..6)
        .map(|i| {
            let mut c = [0.0; 6];
            c[i] = 1e-3;
            lens_of(&c)
        })
        .collect::<Result<_, _>>()?;
    let n = grid.max(2);
    let mut rows: Vec<([[f64; 6]; 2], [f64; 2])> = Vec::new();
    let mut targets: Vec<([f64; 2], [f64; 2])> = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let px = [
                width * i as f64 / (n - 1) as f64,
                height * j as f64 / (n - 1) as f64,
            ];
            let Some(d) = ray(px).filter(|d| d[2] > 0.0 && d.iter().all(|v| v.is_finite())) else {
                continue;
            };
            let q = [fx * d[0] / d[2] + cx, fy * d[1] / d[2] + cy];
            let (Some(base), Some(cols)) = (
                identity.undistort(px),
                units.iter().map(|u| u.undistort(px)).collect::<Option<Vec<_>>>(),
            ) else {
                continue;
            };
            let mut a = [[0.0; 6]; 2];
            for (c, col) in cols.iter().enumerate() {
                a[0][c] = (col[0] - base[0]) / 1e-3;
                a[1][c] = (col[1] - base[1]) / 1e-3;
            }
            rows.push((a, [q[0] - base[0], q[1] - base[1]]));
            targets.push((px, q));
        }
    }
    if rows.len() < 6 {
        return Err(format!(
            "only {} of the {n}x{n} grid points have a ray in front of the camera: too few to fit 6 coefficients",
            rows.len()
        ));
    }
    let mut m = [[0.0; 7]; 6];
    for (a, b) in &rows {
        for r in 0..2 {
            for i in 0..6 {
                for j in 0..6 {
                    m[i][j] += a[r][i] * a[r][j];
                }
                m[i][6] += a[r][i] * b[r];
            }
        }
    }
    let c = solve_6(m).ok_or("the grid points do not determine the 6 coefficients (a singular system)")?;
    let params = with(&c);
    let fitted = Lens::new(kind, &params, width, height)?;
    // The residual of the lens as built (not of the linear system): its own undistort.
    let (mut sum, mut max) = (0.0, 0.0f64);
    for (px, q) in &targets {
        let u = fitted.undistort(*px).ok_or_else(|| {
            format!("the fitted lens folds before the plate's point {px:?}: the camera is beyond what the model can fit")
        })?;
        let d = (u[0] - q[0]).hypot(u[1] - q[1]);
        sum += d * d;
        max = max.max(d);
    }
    Ok(Fit {
        params,
        rms_px: (sum / targets.len() as f64).sqrt(),
        max_px: max,
        points: targets.len(),
    })
}

/// Solves the augmented 6 × 7 system by Gaussian elimination with partial pivoting.
fn solve_6(mut m: [[f64; 7]; 6]) -> Option<[f64; 6]> {
    let scale = m
        .iter()
        .flat_map(|r| r[..6].iter())
        .fold(0.0f64, |a, v| a.max(v.abs()));
    for col in 0..6 {
        let pivot = (col..6).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))?;
        if m[pivot][col].abs() <= 1e-13 * scale {
            return None;
        }
        m.swap(col, pivot);
        let row = m[col];
        for (r, other) in m.iter_mut().enumerate() {
            if r != col {
                let f = other[col] / row[col];
                for (o, p) in other.iter_mut().zip(row).skip(col) {
                    *o -= f * p;
                }
            }
        }
    }
    let mut x = [0.0; 6];
    for (i, xi) in x.iter_mut().enumerate() {
        *xi = m[i][6] / m[i][i];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// `params` for `kind`: the built-ins and the model's defaults, with `set` applied by name.
    fn params(kind: Kind, set: &[(&str, f64)]) -> Vec<f64> {
        kind.all_params()
            .iter()
            .map(|(n, d)| set.iter().find(|s| s.0 == *n).map_or(*d, |s| s.1))
            .collect()
    }

    fn lens(kind: Kind, set: &[(&str, f64)], w: f64, h: f64) -> Lens {
        Lens::new(kind, &params(kind, set), w, h).unwrap()
    }

    /// A unit coordinate (y up) of 3DE, as the lens's raster position on a `w × h` plate.
    fn unit_to_raster(u: [f64; 2], w: f64, h: f64) -> [f64; 2] {
        [u[0] * w, (1.0 - u[1]) * h]
    }

    fn raster_to_unit(p: [f64; 2], w: f64, h: f64) -> [f64; 2] {
        [p[0] / w, 1.0 - p[1] / h]
    }

    /// Fitting Radial Standard Degree 4 to a Radial Standard lens's own rays gives that lens back
    /// (its coefficients, and a residual at rounding level); a lens with a cylindric bending the
    /// fit leaves out is approximated with a residual of the size the bending makes.
    #[test]
    fn fitting_a_radial_standard_lens_recovers_it() {
        let (w, h) = (1920.0, 1080.0);
        let set = [
            ("tde4_focal_length_cm", 3.0),
            ("tde4_filmback_width_cm", 3.6),
            ("tde4_filmback_height_cm", 2.025),
            ("tde4_lens_center_offset_x_cm", 0.04),
            ("tde4_lens_center_offset_y_cm", -0.02),
            ("Distortion - Degree 2", 0.08),
            ("U - Degree 2", 0.006),
            ("V - Degree 2", -0.004),
            ("Quartic Distortion - Degree 4", 0.02),
            ("U - Degree 4", -0.003),
            ("V - Degree 4", 0.002),
        ];
        let truth = lens(Kind::RadialStandard4, &set, w, h);
        let ray = |px: [f64; 2]| truth.ray(px).map(|(v, _)| v);
        let fit = fit_radial_standard(truth.pinhole(), w, h, &ray, 17).unwrap();
        assert_eq!(fit.points, 17 * 17);
        assert!(fit.max_px < 1e-7, "{fit:?}");
        let want = params(Kind::RadialStandard4, &set);
        let names = Kind::RadialStandard4.all_params();
        for (i, (name, _)) in names.iter().enumerate().skip(BUILTINS.len()) {
            assert!(
                (fit.params[i] - want[i]).abs() < 1e-9,
                "{name}: {} vs {}",
                fit.params[i],
                want[i]
            );
        }
        // The refitted lens has the same rays (its own built-ins differ: another film back).
        let back = Lens::new(Kind::RadialStandard4, &fit.params, w, h).unwrap();
        for px in [[0.0, 0.0], [960.0, 540.0], [1900.0, 30.0]] {
            let (a, b) = (truth.ray(px).unwrap().0, back.ray(px).unwrap().0);
            assert!(
                ((a[0] / a[2]) - (b[0] / b[2])).abs() < 1e-10
                    && ((a[1] / a[2]) - (b[1] / b[2])).abs() < 1e-10
            );
        }
        // A bending the fit cannot express leaves a residual, reported, not hidden.
        let bent = lens(
            Kind::RadialStandard4,
            &[&set[..], &[("B - Cylindric Bending", 0.05)]].concat(),
            w,
            h,
        );
        let ray = |px: [f64; 2]| bent.ray(px).map(|(v, _)| v);
        let fit = fit_radial_standard(bent.pinhole(), w, h, &ray, 17).unwrap();
        assert!(fit.max_px > 0.5 && fit.rms_px <= fit.max_px, "{fit:?}");
        // No ray at all: a clear refusal.
        let e = fit_radial_standard(truth.pinhole(), w, h, &|_| None, 5).unwrap_err();
        assert!(e.contains("only 0 of the 5x5 grid points"), "{e}");
    }

    /// LDPK 2.0's supplement (§2.1.4): Radial Standard Degree 4 with c2 = c4 = 0.1 at the corners.
    #[test]
    fn radial_standard_corners_are_the_supplements() {
        let l = lens(
            Kind::RadialStandard4,
            &[
                ("Distortion - Degree 2", 0.1),
                ("Quartic Distortion - Degree 4", 0.1),
            ],
            1000.0,
            800.0,
        );
        let (w, h) = (1000.0, 800.0);
        for (u, undist, dist) in [
            ([0.0, 0.0], [-0.1, -0.1], [0.0603, 0.0603]),
            ([1.0, 0.0], [1.1, -0.1], [0.9397, 0.0603]),
            ([0.0, 1.0], [-0.1, 1.1], [0.0603, 0.9397]),
            ([1.0, 1.0], [1.1, 1.1], [0.9397, 0.9397]),
        ] {
            let q = raster_to_unit(l.undistort(unit_to_raster(u, w, h)).unwrap(), w, h);
            let d = raster_to_unit(l.distort(unit_to_raster(u, w, h)).unwrap(), w, h);
            for k in 0..2 {
                assert!((q[k] - undist[k]).abs() < 1e-12, "undistort {u:?}: {q:?}");
                assert!((d[k] - dist[k]).abs() < 5e-5, "distort {u:?}: {d:?}");
            }
        }
    }

    /// The supplement's §2.1.5: Jacobians (unit coordinates, row-major) and twist vectors (mixed
    /// second derivatives) of Radial Standard Degree 4 on a 2 × 1 cm back with c2 = 0.1.
    #[test]
    fn radial_standard_jacobians_and_twists_are_the_supplements() {
        let (w, h) = (2000.0, 1000.0);
        let l = lens(
            Kind::RadialStandard4,
            &[
                ("tde4_filmback_width_cm", 2.0),
                ("tde4_filmback_height_cm", 1.0),
                ("Distortion - Degree 2", 0.1),
            ],
            w,
            h,
        );
        // The unit-coordinate Jacobian of undistort from the dn one: diag(1/w_fb, 1/h_fb)·J·diag(w_fb, h_fb).
        let jac_unit = |u: [f64; 2]| {
            let p = l.dn(unit_to_raster(u, w, h));
            let (_, j) = l.map.eval_jacobian(p).unwrap();
            [j[0][0], j[0][1] * 0.5, j[1][0] * 2.0, j[1][1]]
        };
        for (u, want) in [
            ([0.5, 0.5], [1.0, 0.0, 0.0, 1.0]),
            ([0.0, 0.0], [1.26, 0.04, 0.16, 1.14]),
            ([1.0, 0.0], [1.26, -0.04, -0.16, 1.14]),
            ([0.0, 1.0], [1.26, -0.04, -0.16, 1.14]),
            ([1.0, 1.0], [1.26, 0.04, 0.16, 1.14]),
        ] {
            let j = jac_unit(u);
            for k in 0..4 {
                assert!((j[k] - want[k]).abs() < 1e-12, "J at {u:?}: {j:?}");
            }
        }
        for (u, want) in [
            ([0.5, 0.5], [0.0, 0.0]),
            ([0.0, 0.0], [-0.08, -0.32]),
            ([1.0, 0.0], [-0.08, 0.32]),
            ([0.0, 1.0], [0.08, -0.32]),
            ([1.0, 1.0], [0.08, 0.32]),
        ] {
            // ∂²g/∂u∂v by central differences of the exact ∂g/∂u.
            let e = 1e-5;
            let a = jac_unit([u[0], u[1] + e]);
            let b = jac_unit([u[0], u[1] - e]);
            let twist = [(a[0] - b[0]) / (2.0 * e), (a[2] - b[2]) / (2.0 * e)];
            for k in 0..2 {
                assert!((twist[k] - want[k]).abs() < 1e-6, "twist at {u:?}: {twist:?}");
            }
        }
    }

    /// The supplement's §2.2.2 bounding boxes (Nuke pixels, y up, `floor − 2`, `ceil + 2`): Nuke's
    /// node defaults (0.8 × 0.6 cm back) with `Distortion - Degree 2` 0.5 on 2000 × 1500.
    #[test]
    fn nuke_bounding_boxes_are_the_supplements() {
        let (w, h) = (2000.0, 1500.0);
        let l = lens(Kind::RadialStandard4, &[("Distortion - Degree 2", 0.5)], w, h);
        let nuke_box = |f: &dyn Fn([f64; 2]) -> Option<[f64; 2]>, b: [f64; 4]| {
            let mut bx = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
            let n = 1000;
            for i in 0..=n {
                let t = i as f64 / n as f64;
                let (x, y) = (b[0] + t * (b[2] - b[0]), b[1] + t * (b[3] - b[1]));
                for p in [[x, b[1]], [x, b[3]], [b[0], y], [b[2], y]] {
                    // Nuke (y up) → raster (y down) and back.
                    let q = f([p[0], h - p[1]]).unwrap();
                    let q = [q[0], h - q[1]];
                    bx = [bx[0].min(q[0]), bx[1].min(q[1]), bx[2].max(q[0]), bx[3].max(q[1])];
                }
            }
            bx
        };
        // Nuke pads `floor(min) − 2`, `ceil(max) + 2`; an extreme that lies on a whole pixel (the
        // corners here) may round either way in the last bit, so the figure must be reproduced by
        // the box moved by at most 1e-6 px.
        let padded = |bx: [f64; 4], want: [f64; 4]| {
            for k in 0..4 {
                let ok = [-1e-6, 0.0, 1e-6].iter().any(|e| {
                    let v = bx[k] + e;
                    want[k] == if k < 2 { v.floor() - 2.0 } else { v.ceil() + 2.0 }
                });
                assert!(ok, "edge {k}: {bx:?} does not pad to {want:?}");
            }
        };
        let format = [0.0, 0.0, w, h];
        let input = [-200.0, 200.0, 2200.0, 1300.0];
        padded(nuke_box(&|p| l.distort(p), format), [175.0, 89.0, 1825.0, 1411.0]);
        padded(
            nuke_box(&|p| l.undistort(p), format),
            [-503.0, -377.0, 2502.0, 1877.0],
        );
        padded(nuke_box(&|p| l.distort(p), input), [61.0, 239.0, 1939.0, 1261.0]);
        padded(
            nuke_box(&|p| l.undistort(p), input),
            [-872.0, -109.0, 2872.0, 1609.0],
        );
        // The lens's own undistorted box of the frame (raster, y down) is the same figure.
        let b = l.undistorted_box(w, h).unwrap();
        padded([b[0], h - b[3], b[2], h - b[1]], [-503.0, -377.0, 2502.0, 1877.0]);
    }

    /// The lens's pinhole gives each plate pixel the ray of its undistorted position, for every
    /// model (anamorphic with rotation and an off-centre lens included).
    #[test]
    fn the_pinhole_is_the_ray_of_the_undistorted_position() {
        let (w, h) = (1920.0, 1080.0);
        for (kind, set) in [
            (
                Kind::RadialStandard4,
                vec![
                    ("Distortion - Degree 2", -0.12),
                    ("Quartic Distortion - Degree 4", 0.03),
                    ("tde4_lens_center_offset_x_cm", 0.05),
                    ("tde4_lens_center_offset_y_cm", -0.03),
                ],
            ),
            (
                Kind::AnamorphicStandard4,
                vec![
                    ("Cx02 - Degree 2", 0.05),
                    ("Lens Rotation", 3.0),
                    ("Squeeze-X", 0.9),
                    ("tde4_pixel_aspect", 2.0),
                    ("tde4_lens_center_offset_x_cm", -0.04),
                ],
            ),
        ] {
            let l = lens(kind, &set, w, h);
            let [fx, fy, cx, cy] = l.pinhole();
            for px in [[10.5, 20.5], [960.0, 540.0], [1800.25, 1000.75], [300.0, 900.0]] {
                let q = l.undistort(px).unwrap();
                let (ray, _) = l.ray(px).unwrap();
                let want = [(q[0] - cx) / fx, (q[1] - cy) / fy];
                let got = [ray[0] / ray[2], ray[1] / ray[2]];
                for k in 0..2 {
                    assert!(
                        (got[k] - want[k]).abs() < 1e-12,
                        "{kind:?} {px:?}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }

    /// The anamorphic polynomial in its polar form `1 + Σ C_{i,d}·r^d·cos(iφ)`, written
    /// independently of the Cartesian form the model evaluates.
    fn polar(c: &[f64], x: f64, y: f64) -> f64 {
        let (r, phi) = (x.hypot(y), y.atan2(x));
        let terms = [
            (0, 2),
            (2, 2),
            (0, 4),
            (2, 4),
            (4, 4),
            (0, 6),
            (2, 6),
            (4, 6),
            (6, 6),
        ];
        1.0 + terms
            .iter()
            .zip(c)
            .map(|(&(i, d), &k)| k * r.powi(d) * (f64::from(i) * phi).cos())
            .sum::<f64>()
    }

    #[test]
    fn anamorphic_standard_is_its_formula_in_3des_order() {
        let (w, h) = (1828.0, 1556.0);
        let names: Vec<&str> = ANAMORPHIC_4.iter().chain(ANAMORPHIC_6.iter()).copied().collect();
        let values = [
            0.05, -0.03, 0.02, 0.01, -0.01, 0.015, 0.004, -0.006, 0.003, 0.002, 0.001, -0.002, 0.0005,
            0.0007, -0.0004, 0.0003, 0.0002, -0.0001,
        ];
        let mut set: Vec<(&str, f64)> = names.iter().copied().zip(values).collect();
        let (pa, psi, sx, sy, rho) = (2.0, 1.5f64, 1.02, 0.97, 1.3);
        set.extend([
            ("tde4_filmback_width_cm", 2.1936 * 2.0),
            ("tde4_filmback_height_cm", 1.8672),
            ("tde4_pixel_aspect", pa),
            ("tde4_lens_center_offset_x_cm", 0.03),
            ("tde4_lens_center_offset_y_cm", -0.02),
            ("Lens Rotation", psi),
            ("Squeeze-X", sx),
            ("Squeeze-Y", sy),
            ("Rescale", rho),
        ]);
        let cx: Vec<f64> = (0..9).map(|i| values[2 * i]).collect();
        let cy: Vec<f64> = (0..9).map(|i| values[2 * i + 1]).collect();
        let reference = |p: [f64; 2], pa: f64| {
            let (c, s) = (psi.to_radians().cos(), psi.to_radians().sin());
            let x = p[0] / pa;
            let (xl, yl) = (c * x + s * p[1], -s * x + c * p[1]);
            let (xa, ya) = (xl * polar(&cx, xl, yl) * sx * pa, yl * polar(&cy, xl, yl) * sy);
            [c * xa - s * ya, s * xa + c * ya]
        };
        for (kind, pa_eff) in [
            (Kind::AnamorphicStandard6, pa),
            (Kind::AnamorphicRescaled6, pa * rho),
        ] {
            let l = lens(kind, &set, w, h);
            for p in [[0.3, -0.2], [-0.5, 0.41], [0.05, 0.7], [0.8, 0.55]] {
                let got = l.map.eval(p).unwrap();
                let want = reference(p, pa_eff);
                for k in 0..2 {
                    assert!(
                        (got[k] - want[k]).abs() < 1e-14,
                        "{kind:?} {p:?}: {got:?} vs {want:?}"
                    );
                }
            }
        }
        // The older model is Standard Degree 6 with pa 1, no rotation, no squeeze.
        let old = lens(Kind::Anamorphic6, &set, w, h);
        let mut plain = set.clone();
        plain.extend([
            ("tde4_pixel_aspect", 1.0),
            ("Lens Rotation", 0.0),
            ("Squeeze-X", 1.0),
            ("Squeeze-Y", 1.0),
        ]);
        plain.retain(|s| {
            !matches!(
                s.0,
                "tde4_pixel_aspect" | "Lens Rotation" | "Squeeze-X" | "Squeeze-Y"
            )
        });
        let standard = lens(Kind::AnamorphicStandard6, &plain, w, h);
        for p in [[0.3, -0.2], [-0.5, 0.41]] {
            assert_eq!(old.map.eval(p), standard.map.eval(p));
        }
    }

    #[test]
    fn classic_without_squeeze_or_curvature_is_radial_standard() {
        let (w, h) = (2048.0, 1152.0);
        let classic = lens(
            Kind::Classic,
            &[("Distortion", 0.07), ("Quartic Distortion", -0.02)],
            w,
            h,
        );
        let radial = lens(
            Kind::RadialStandard4,
            &[
                ("Distortion - Degree 2", 0.07),
                ("Quartic Distortion - Degree 4", -0.02),
            ],
            w,
            h,
        );
        for p in [[10.0, 20.0], [1000.0, 500.0], [2040.0, 1150.0]] {
            assert_eq!(classic.undistort(p), radial.undistort(p));
        }
        // Squeeze divides only x's terms; curvature X multiplies y² in x, curvature Y x² in y.
        let c = lens(
            Kind::Classic,
            &[
                ("Distortion", 0.1),
                ("Anamorphic Squeeze", 2.0),
                ("Curvature X", 0.05),
                ("Curvature Y", -0.04),
                ("Quartic Distortion", 0.02),
            ],
            w,
            h,
        );
        let (x, y) = (0.4, -0.3);
        let r4 = (x * x + y * y) * (x * x + y * y);
        let want = [
            x * (1.0 + (0.1 * x * x + 0.15 * y * y + 0.02 * r4) / 2.0),
            y * (1.0 + 0.06 * x * x + 0.1 * y * y + 0.02 * r4),
        ];
        assert_eq!(c.map.eval([x, y]).unwrap(), want);
    }

    #[test]
    fn the_cylindric_stretch_preserves_area_and_is_symmetric_under_a_quarter_turn() {
        let (w, h) = (1920.0, 1080.0);
        let a = lens(
            Kind::RadialStandard4,
            &[
                ("Phi - Cylindric Direction", 30.0),
                ("B - Cylindric Bending", 0.08),
            ],
            w,
            h,
        );
        let Map::Radial { cyl, .. } = a.map else { panic!() };
        assert!((det2(&cyl) - 1.0).abs() < 1e-15);
        // φ + 90° with k → 1/k (1 + b' = 1/(1 + b)) is the same stretch.
        let b = lens(
            Kind::RadialStandard4,
            &[
                ("Phi - Cylindric Direction", 120.0),
                ("B - Cylindric Bending", 1.0 / 1.08 - 1.0),
            ],
            w,
            h,
        );
        let Map::Radial { cyl: cyl2, .. } = b.map else {
            panic!()
        };
        for i in 0..2 {
            for j in 0..2 {
                assert!((cyl[i][j] - cyl2[i][j]).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn the_fisheye_is_equisolid_to_rectilinear() {
        let (w, h) = (2048.0, 2048.0);
        let l = lens(
            Kind::RadialFisheye8,
            &[
                ("tde4_focal_length_cm", 0.8),
                ("tde4_filmback_width_cm", 2.4),
                ("tde4_filmback_height_cm", 2.4),
            ],
            w,
            h,
        );
        // Without coefficients a plate point at equisolid radius 2f·sin(θ/2) has the pinhole ray at θ.
        let r_fb = 0.5 * 2.4f64.hypot(2.4);
        for theta in [0.1f64, 0.5, 0.9, 1.2] {
            let r_cm = 2.0 * 0.8 * (theta / 2.0).sin();
            let px = [w / 2.0 + r_cm / 2.4 * w, h / 2.0];
            let (v, _) = l.ray(px).unwrap();
            let got = v[0].hypot(v[1]).atan2(v[2]);
            assert!((got - theta).abs() < 1e-12, "θ {theta}: {got}");
            let _ = r_fb;
        }
        // θ ≥ 90° has no ray: the plate's corner radius 1.697 cm > √2·0.8.
        assert!(l.ray([0.0, 0.0]).is_none());
    }

    /// Lenses the round trips run over: strong barrel, strong pincushion (folding inside the
    /// frame), 2× anamorphic with rotation, an off-centre lens centre, a fisheye.
    fn hard_lenses() -> Vec<(Lens, f64, f64)> {
        let (w, h) = (2048.0, 1152.0);
        let ana = [
            ("tde4_filmback_width_cm", 2.2 * 2.0),
            ("tde4_filmback_height_cm", 1.86),
            ("tde4_pixel_aspect", 2.0),
            ("Cx02 - Degree 2", -0.12),
            ("Cy02 - Degree 2", -0.09),
            ("Cx22 - Degree 2", 0.03),
            ("Cy22 - Degree 2", 0.02),
            ("Cx04 - Degree 4", 0.02),
            ("Cy04 - Degree 4", 0.015),
            ("Cx24 - Degree 4", 0.01),
            ("Cy44 - Degree 4", -0.005),
            ("Lens Rotation", 2.0),
            ("Squeeze-X", 1.05),
            ("Squeeze-Y", 0.95),
            ("Rescale", 1.0),
        ];
        let (aw, ah) = (1828.0, 1556.0);
        vec![
            (
                lens(
                    Kind::RadialStandard4,
                    &[
                        ("Distortion - Degree 2", 0.3),
                        ("Quartic Distortion - Degree 4", 0.1),
                        ("U - Degree 2", 0.02),
                        ("V - Degree 4", -0.01),
                    ],
                    w,
                    h,
                ),
                w,
                h,
            ),
            (
                lens(
                    Kind::RadialStandard4,
                    &[
                        ("Distortion - Degree 2", -0.35),
                        ("Phi - Cylindric Direction", 20.0),
                        ("B - Cylindric Bending", 0.05),
                    ],
                    w,
                    h,
                ),
                w,
                h,
            ),
            (
                lens(
                    Kind::Classic,
                    &[
                        ("Distortion", -0.3),
                        ("Anamorphic Squeeze", 0.5),
                        ("Curvature X", 0.1),
                        ("Quartic Distortion", -0.05),
                    ],
                    w,
                    h,
                ),
                w,
                h,
            ),
            (lens(Kind::AnamorphicStandard4, &ana, aw, ah), aw, ah),
            (lens(Kind::AnamorphicRescaled4, &ana, aw, ah), aw, ah),
            (lens(Kind::AnamorphicStandard6, &ana, aw, ah), aw, ah),
            (lens(Kind::Anamorphic6, &ana, aw, ah), aw, ah),
            (
                lens(
                    Kind::RadialStandard4,
                    &[
                        ("tde4_lens_center_offset_x_cm", 0.25),
                        ("tde4_lens_center_offset_y_cm", -0.15),
                        ("Distortion - Degree 2", 0.2),
                        ("field_of_view_xa_unit", 0.05),
                        ("field_of_view_xb_unit", 0.95),
                    ],
                    w,
                    h,
                ),
                w,
                h,
            ),
            (
                lens(
                    Kind::RadialFisheye8,
                    &[
                        ("tde4_focal_length_cm", 1.2),
                        ("tde4_filmback_width_cm", 2.4),
                        ("tde4_filmback_height_cm", 1.35),
                        ("Distortion - Degree 2", 0.05),
                        ("Quartic Distortion - Degree 4", -0.01),
                    ],
                    w,
                    h,
                ),
                w,
                h,
            ),
        ]
    }

    #[test]
    fn undistort_then_distort_is_the_identity_inside_the_fold_and_culled_beyond() {
        for (l, w, h) in hard_lenses() {
            let (mut inside, mut culled) = (0, 0);
            let n = 64;
            for i in 0..=n {
                for j in 0..=n {
                    let px = [w * i as f64 / n as f64, h * j as f64 / n as f64];
                    match l.ray(px) {
                        Some((v, _)) => {
                            inside += 1;
                            let back = l.pixel(v).unwrap_or_else(|| {
                                panic!("{:?}: {px:?} has a ray {v:?} without a pixel", l.kind)
                            });
                            let e = (back[0] - px[0]).hypot(back[1] - px[1]);
                            assert!(e < 1e-6, "{:?}: {px:?} → {back:?} ({e} px)", l.kind);
                        }
                        None => {
                            culled += 1;
                            // Beyond the fold: det J ≤ 0 somewhere on the way from the lens centre.
                            let p = l.dn(px);
                            let on_the_way = (1..=1000).any(|k| {
                                let t = k as f64 / 1000.0 * (1.0 + FOLD_MARGIN);
                                l.map
                                    .eval_jacobian([p[0] * t, p[1] * t])
                                    .is_none_or(|(_, j)| det2(&j) <= 0.0)
                            });
                            assert!(
                                on_the_way,
                                "{:?}: {px:?} culled inside the primary region",
                                l.kind
                            );
                        }
                    }
                }
            }
            assert!(inside > 0, "{:?}", l.kind);
            let _ = culled;
        }
    }

    #[test]
    fn a_pincushion_folds_inside_the_frame_and_never_answers_with_the_mirrored_branch() {
        let (w, h) = (2048.0, 1152.0);
        // g(r) = r(1 − 0.6 r²) has its maximum at r = 1/√1.8 = 0.745 < 1 (the corner).
        let l = lens(Kind::RadialStandard4, &[("Distortion - Degree 2", -0.6)], w, h);
        assert!(
            l.ray([0.0, 0.0]).is_none() && l.ray([w, h]).is_none(),
            "corners are beyond the fold"
        );
        assert!(l.ray([w / 2.0, h / 2.0]).is_some());
        let r_fold = 1.0 / 1.8f64.sqrt();
        let g_max = r_fold * (1.0 - 0.6 * r_fold * r_fold);
        // Along the diagonal: an undistorted radius below g_max has exactly one primary preimage
        // (below r_fold); above it none. The mirrored branch (r > r_fold) is never returned.
        let diag = [w / 2.0 / 1.0, h / 2.0];
        let dir = {
            let p = l.dn([0.0, 0.0]);
            let n = p[0].hypot(p[1]);
            [p[0] / n, p[1] / n]
        };
        for k in 1..200 {
            let q = g_max * 1.3 * k as f64 / 200.0;
            let got = l.solve([dir[0] * q, dir[1] * q]);
            if q < g_max * (1.0 - 1e-9) {
                let p = got.unwrap_or_else(|| panic!("q {q}: no preimage below the fold's image"));
                assert!(p[0].hypot(p[1]) < r_fold, "q {q}: mirrored branch {p:?}");
            } else if q > g_max * (1.0 + 1e-9) {
                assert!(got.is_none(), "q {q}: beyond the fold's image, got {got:?}");
            }
        }
        let _ = diag;
    }

    #[test]
    fn ray_jacobians_match_finite_differences() {
        for (l, w, h) in hard_lenses() {
            for px in [[0.3 * w, 0.4 * h], [0.7 * w, 0.2 * h], [0.5 * w, 0.9 * h]] {
                let Some((_, j)) = l.ray(px) else { continue };
                let e = 1e-3;
                for k in 0..2 {
                    let (mut a, mut b) = (px, px);
                    a[k] += e;
                    b[k] -= e;
                    let (fa, _) = l.ray(a).unwrap();
                    let (fb, _) = l.ray(b).unwrap();
                    for i in 0..3 {
                        let fd = (fa[i] - fb[i]) / (2.0 * e);
                        assert!(
                            (fd - j[i][k]).abs() < 1e-7 * (1.0 + fd.abs()),
                            "{:?} ∂V{i}/∂px{k}: {fd} vs {}",
                            l.kind,
                            j[i][k]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn bad_parameters_are_named() {
        let (w, h) = (100.0, 100.0);
        for (kind, name, value) in [
            (Kind::Classic, "Anamorphic Squeeze", 0.0),
            (Kind::Classic, "tde4_filmback_width_cm", 0.0),
            (Kind::RadialStandard4, "tde4_filmback_height_cm", -1.0),
            (Kind::RadialStandard4, "tde4_focal_length_cm", 0.0),
            (Kind::AnamorphicStandard4, "Squeeze-X", 0.0),
            (Kind::AnamorphicStandard4, "Squeeze-Y", 0.0),
            (Kind::AnamorphicRescaled4, "Rescale", 0.0),
            (Kind::AnamorphicStandard6, "tde4_pixel_aspect", 0.0),
            (Kind::RadialStandard4, "B - Cylindric Bending", -1.0),
        ] {
            let e = Lens::new(kind, &params(kind, &[(name, value)]), w, h).unwrap_err();
            assert!(e.contains(name), "{e}");
        }
        let e = Lens::new(
            Kind::Classic,
            &params(Kind::Classic, &[("field_of_view_xb_unit", 0.0)]),
            w,
            h,
        )
        .unwrap_err();
        assert!(e.contains("field_of_view_xb_unit"), "{e}");
    }

    #[test]
    fn knob_names_follow_ldpk() {
        assert_eq!(knob_name("Distortion - Degree 2"), "Distortion_Degree_2");
        assert_eq!(knob_name("Squeeze-X"), "Squeeze_X");
        assert_eq!(knob_name("Phi - Cylindric Direction"), "Phi_Cylindric_Direction");
        assert_eq!(knob_name("Anamorphic Squeeze"), "Anamorphic_Squeeze");
        assert_eq!(legacy_knob_name("Distortion - Degree 2"), "Distortion___Degree_2");
    }

    #[test]
    fn the_model_tables_params_are_the_kinds() {
        for kind in KINDS {
            let info = crate::model_info(kind.name()).unwrap();
            let names: Vec<&str> = kind.all_params().iter().map(|p| p.0).collect();
            assert_eq!(info.params, names.join(", "), "{kind:?}");
            assert_eq!(info.counts, &[names.len()]);
        }
    }

    proptest! {
        #[test]
        fn round_trips_hold_over_random_anamorphic_lenses(
            c02 in -0.2f64..0.2, c22 in -0.05f64..0.05, c04 in -0.05f64..0.05,
            psi in -10.0f64..10.0, sq in 0.9f64..1.1, lx in -0.2f64..0.2, u in 0.0f64..1.0, v in 0.0f64..1.0,
        ) {
            let (w, h) = (1828.0, 1556.0);
            let l = lens(Kind::AnamorphicStandard4, &[
                ("tde4_filmback_width_cm", 4.3872), ("tde4_filmback_height_cm", 1.8672), ("tde4_pixel_aspect", 2.0),
                ("tde4_lens_center_offset_x_cm", lx), ("Cx02 - Degree 2", c02), ("Cy02 - Degree 2", -c02 * 0.8),
                ("Cx22 - Degree 2", c22), ("Cy04 - Degree 4", c04), ("Lens Rotation", psi), ("Squeeze-X", sq),
            ], w, h);
            let px = [u * w, v * h];
            if let Some((ray, _)) = l.ray(px) {
                let back = l.pixel(ray);
                prop_assert!(back.is_some(), "{:?} has no pixel", px);
                let back = back.unwrap();
                prop_assert!((back[0] - px[0]).hypot(back[1] - px[1]) < 1e-6, "{:?} → {:?}", px, back);
            }
        }
    }
}
