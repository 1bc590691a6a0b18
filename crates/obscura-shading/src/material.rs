//! BSDFs: what a surface does with the light arriving at one hit.
//!
//! A [`Bsdf`] is built at a hit from the surface's [`Material`] and the shading normal `n`. All
//! directions point *away* from the surface: `wo` toward the viewer (the previous path vertex), `wi`
//! toward the light. Surfaces are opaque and reflect only: every lobe is zero unless both `wo` and
//! `wi` lie in the hemisphere of `n` (`μo = n·wo > 0`, `μi = n·wi > 0`).
//!
//! | material | `f(wo, wi)` (without the cosine) |
//! |---|---|
//! | `PxrDiffuse` | `ρ / π` (Lambert) |
//! | `PxrConstant` | 0; emits `emitColor` ([`Bsdf::emission`]) |
//! | `PxrSurface` | `f_d + f_s` (below) |
//!
//! **GGX specular lobe** (Trowbridge–Reitz; Walter et al. 2007, Heitz 2014), `α = roughness²`,
//! `h = normalize(wo + wi)`, in the local frame where `n = +Z`:
//!
//! - `D(h) = 1 / (π α² ((h.x² + h.y²)/α² + h.z²)²)`, so `∫ D(h) cos θ_h dω_h = 1`;
//! - `Λ(w) = (√(1 + α² tan²θ_w) − 1) / 2`, `G1(w) = 1 / (1 + Λ(w))`, and the height-correlated
//!   masking–shadowing `G2(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi))`;
//! - Schlick's Fresnel `F(c) = F0 + (1 − F0)(1 − c)⁵` with `c = wo·h` and `F0 = specularFaceColor`;
//! - `f_s = D(h) G2 F(wo·h) / (4 μo μi)`.
//!
//! Below `α = 10⁻⁴` (roughness < 0.01) the lobe is a perfect mirror: a delta the sampler returns with
//! `specular = true` and that [`Bsdf::eval`] leaves out.
//!
//! **Coupling of the lobes** (Kelemen & Szirmay-Kalos 2001): the diffuse lobe receives exactly the
//! energy the specular lobe does not reflect. With `E(μ)` the specular lobe's directional albedo
//! `∫ f_s μi dωi` and `E_avg = 2 ∫₀¹ E(μ) μ dμ` its hemispherical average,
//!
//! `f_d = ρ (1 − E(μo)) (1 − E(μi)) / (π (1 − E_avg))`.
//!
//! `f_d` is reciprocal like `f_s`, and for `ρ = 1` the total albedo `∫ (f_d + f_s) μi dωi` is
//! `E(μo) + (1 − E(μo)) = 1` at every `μo`: a white PxrSurface neither gains nor loses energy
//! whatever its `F0` and roughness, and a darker one only loses. Because Schlick's `F` is linear in
//! `F0`, `E = F0·E₁ + (1 − F0)·E₂`, where `E₁` is the albedo with `F = 1` and `E₂` with
//! `F = (1 − c)⁵`; both are tabulated once over `(μ, roughness)` by integrating the GGX lobe
//! numerically (see `EnergyTable`).
//!
//! **Sampling.** Lambert: cosine-weighted, `pdf = μi/π`. GGX: the distribution of visible normals
//! (Heitz 2018), `pdf(wi) = G1(wo) D(h) / (4 μo)`. PxrSurface picks the specular lobe with
//! probability `p_s = a_s / (a_s + a_d)` from the albedo estimates `a_s = mean(E(μo))` and
//! `a_d = mean(ρ (1 − E(μo)))`, and its pdf is the mixture `p_s pdf_s + (1 − p_s) pdf_d`; the
//! sampled weight is the full `f(wo, wi) μi / pdf(wi)` (one-sample MIS over the lobes), so
//! [`Bsdf::sample`] and [`Bsdf::eval`] agree exactly.

use std::f32::consts::{FRAC_1_PI, PI, TAU};
use std::sync::OnceLock;

use glam::Vec3A;
use obscura_scene::Material;
use obscura_sdk::Rgb;

/// Below this `α` the GGX lobe is treated as a perfect mirror (a delta).
const MIRROR_ALPHA: f32 = 1e-4;

/// A colour as a vector, with NaN, infinite and negative channels set to 0.
pub(crate) fn color(c: Rgb) -> Vec3A {
    sanitize(Vec3A::new(c.r, c.g, c.b))
}

/// Every channel that is NaN, infinite or negative becomes 0.
pub(crate) fn sanitize(v: Vec3A) -> Vec3A {
    let f = |x: f32| if x.is_finite() && x > 0.0 { x } else { 0.0 };
    Vec3A::new(f(v.x), f(v.y), f(v.z))
}

/// An orthonormal frame around a unit normal (Duff et al. 2017, "Building an Orthonormal Basis,
/// Revisited"): `t × b = n`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Frame {
    t: Vec3A,
    b: Vec3A,
    n: Vec3A,
}

impl Frame {
    /// The frame whose +Z axis is `n` (unit length).
    pub(crate) fn new(n: Vec3A) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Frame {
            t: Vec3A::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            b: Vec3A::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }

    /// World → local (`n` becomes +Z).
    #[inline]
    pub(crate) fn to_local(self, v: Vec3A) -> Vec3A {
        Vec3A::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    /// Local → world.
    #[inline]
    pub(crate) fn to_world(self, v: Vec3A) -> Vec3A {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// A direction drawn from the cosine-weighted hemisphere around +Z: `pdf = z / π`.
pub(crate) fn cosine_hemisphere(u: (f32, f32)) -> Vec3A {
    let r = u.0.max(0.0).sqrt();
    let phi = TAU * u.1;
    Vec3A::new(r * phi.cos(), r * phi.sin(), (1.0 - u.0).max(0.0).sqrt())
}

/// Schlick's Fresnel: `F0 + (1 − F0)(1 − c)⁵`.
fn schlick(f0: Vec3A, c: f32) -> Vec3A {
    let m = (1.0 - c).clamp(0.0, 1.0);
    let m5 = (m * m) * (m * m) * m;
    f0 + (Vec3A::ONE - f0) * m5
}

/// The GGX normal distribution `D(h)` for a local half vector `h` (unit, +Z = normal).
fn ggx_d(h: Vec3A, alpha: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let x = (h.x * h.x + h.y * h.y) / a2 + h.z * h.z;
    let d = 1.0 / (PI * a2 * x * x);
    if d.is_finite() { d } else { 0.0 }
}

/// Smith's `Λ(w) = (√(1 + α² tan²θ) − 1)/2`, written as `t / (2(√(1 + t) + 1))` with
/// `t = α² tan²θ` to stay exact for small `t`; infinite at and below the horizon.
fn ggx_lambda(w: Vec3A, alpha: f32) -> f32 {
    let z2 = w.z * w.z;
    if w.z <= 0.0 || z2 <= 0.0 {
        return f32::INFINITY;
    }
    let t = alpha * alpha * (w.x * w.x + w.y * w.y) / z2;
    if !t.is_finite() {
        return f32::INFINITY;
    }
    t / (2.0 * ((1.0 + t).sqrt() + 1.0))
}

/// Smith's masking `G1(w) = 1 / (1 + Λ(w))`.
fn ggx_g1(w: Vec3A, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(w, alpha))
}

/// Height-correlated masking–shadowing `G2 = 1 / (1 + Λ(wo) + Λ(wi))`.
fn ggx_g2(wo: Vec3A, wi: Vec3A, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha))
}

/// A visible normal for `wo` (local, `wo.z > 0`), Heitz 2018: stretch `wo` to the hemisphere
/// configuration, sample the projected disk (warped toward the visible half), and unstretch.
/// The half vector has density `G1(wo) max(0, wo·h) D(h) / wo.z`.
fn sample_vndf(wo: Vec3A, alpha: f32, u: (f32, f32)) -> Vec3A {
    let vh = Vec3A::new(alpha * wo.x, alpha * wo.y, wo.z).normalize_or(Vec3A::Z);
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len2 > 0.0 {
        Vec3A::new(-vh.y, vh.x, 0.0) / len2.sqrt()
    } else {
        Vec3A::X
    };
    let t2 = vh.cross(t1);
    let r = u.0.max(0.0).sqrt();
    let phi = TAU * u.1;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * (r * phi.sin());
    let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    Vec3A::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize_or(Vec3A::Z)
}

/// Mirror `wo` about `h`: `2 (wo·h) h − wo`.
#[inline]
fn reflect(wo: Vec3A, h: Vec3A) -> Vec3A {
    2.0 * wo.dot(h) * h - wo
}

/// The density of `wi = reflect(wo, h)` under visible-normal sampling: `G1(wo) D(h) / (4 wo.z)`.
fn vndf_reflection_pdf(wo: Vec3A, h: Vec3A, alpha: f32) -> f32 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    let p = ggx_g1(wo, alpha) * ggx_d(h, alpha) / (4.0 * wo.z);
    if p.is_finite() { p.max(0.0) } else { 0.0 }
}

/// Number of `μ` cells of the energy table (cell centres `(i + ½)/N_MU`).
const N_MU: usize = 32;
/// Number of roughness nodes of the energy table (`j/(N_R − 1)`, roughness, not `α`).
const N_R: usize = 32;
/// Stratified samples per side for each table entry.
const N_SAMPLES: usize = 32;

/// The GGX lobe's directional albedo, tabulated: `e1[j][i]` with `F = 1`, `e2[j][i]` with
/// `F = (1 − c)⁵`, for roughness node `j` and `μ` cell `i`; `avg1[j]`, `avg2[j]` their
/// hemispherical averages `2 ∫ E(μ) μ dμ` (midpoint rule).
struct EnergyTable {
    e1: Vec<[f32; N_MU]>,
    e2: Vec<[f32; N_MU]>,
    avg1: Vec<f32>,
    avg2: Vec<f32>,
}

impl EnergyTable {
    /// The table, computed on first use (about a million GGX samples, a few tens of milliseconds
    /// in an optimised build). Serial on purpose: a rayon job inside the initialiser could steal a
    /// render task that calls `get` again on the same thread, and re-entering a `OnceLock`
    /// initialiser deadlocks.
    fn get() -> &'static EnergyTable {
        static TABLE: OnceLock<EnergyTable> = OnceLock::new();
        TABLE.get_or_init(EnergyTable::compute)
    }

    fn compute() -> EnergyTable {
        let rows: Vec<([f32; N_MU], [f32; N_MU])> = (0..N_R)
            .map(|j| {
                let roughness = j as f32 / (N_R - 1) as f32;
                let alpha = roughness * roughness;
                let mut e1 = [0.0; N_MU];
                let mut e2 = [0.0; N_MU];
                for i in 0..N_MU {
                    let mu = (i as f32 + 0.5) / N_MU as f32;
                    (e1[i], e2[i]) = lobe_albedo(mu, alpha);
                }
                (e1, e2)
            })
            .collect();
        let avg = |e: &[f32; N_MU]| {
            let s: f32 = (0..N_MU).map(|i| e[i] * (i as f32 + 0.5) / N_MU as f32).sum();
            2.0 * s / N_MU as f32
        };
        EnergyTable {
            avg1: rows.iter().map(|r| avg(&r.0)).collect(),
            avg2: rows.iter().map(|r| avg(&r.1)).collect(),
            e1: rows.iter().map(|r| r.0).collect(),
            e2: rows.iter().map(|r| r.1).collect(),
        }
    }

    /// Bilinear lookup of `(E₁, E₂)` at `(μ, roughness)`.
    fn albedo(&self, mu: f32, roughness: f32) -> (f32, f32) {
        let (j0, j1, fj) = Self::roughness_nodes(roughness);
        let y = (mu * N_MU as f32 - 0.5).clamp(0.0, (N_MU - 1) as f32);
        let i0 = (y as usize).min(N_MU - 1);
        let i1 = (i0 + 1).min(N_MU - 1);
        let fi = y - i0 as f32;
        let lerp2 = |t: &Vec<[f32; N_MU]>| {
            let a = t[j0][i0] + (t[j0][i1] - t[j0][i0]) * fi;
            let b = t[j1][i0] + (t[j1][i1] - t[j1][i0]) * fi;
            a + (b - a) * fj
        };
        (lerp2(&self.e1), lerp2(&self.e2))
    }

    /// Linear lookup of `(E₁_avg, E₂_avg)` at `roughness`.
    fn average(&self, roughness: f32) -> (f32, f32) {
        let (j0, j1, f) = Self::roughness_nodes(roughness);
        let lerp = |t: &Vec<f32>| t[j0] + (t[j1] - t[j0]) * f;
        (lerp(&self.avg1), lerp(&self.avg2))
    }

    fn roughness_nodes(roughness: f32) -> (usize, usize, f32) {
        let x = roughness.clamp(0.0, 1.0) * (N_R - 1) as f32;
        let j0 = (x as usize).min(N_R - 1);
        (j0, (j0 + 1).min(N_R - 1), x - j0 as f32)
    }
}

/// `(E₁, E₂)` at one `(μ, α)`: the mean of the VNDF sample weight `G2/G1` (times `(1 − wo·h)⁵`
/// for `E₂`) over a stratified grid; exact for the mirror.
fn lobe_albedo(mu: f32, alpha: f32) -> (f32, f32) {
    let m = 1.0 - mu;
    if alpha < MIRROR_ALPHA {
        return (1.0, (m * m) * (m * m) * m);
    }
    let wo = Vec3A::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let g1 = ggx_g1(wo, alpha);
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for a in 0..N_SAMPLES {
        for b in 0..N_SAMPLES {
            let u = (
                (a as f32 + 0.5) / N_SAMPLES as f32,
                (b as f32 + 0.5) / N_SAMPLES as f32,
            );
            let h = sample_vndf(wo, alpha, u);
            let wi = reflect(wo, h);
            if wi.z <= 0.0 || g1 <= 0.0 {
                continue;
            }
            let w = ggx_g2(wo, wi, alpha) / g1;
            let c = (1.0 - wo.dot(h)).clamp(0.0, 1.0);
            s1 += f64::from(w);
            s2 += f64::from(w * (c * c) * (c * c) * c);
        }
    }
    let n = (N_SAMPLES * N_SAMPLES) as f64;
    ((s1 / n) as f32, (s2 / n) as f32)
}

/// The lobes of one material, in the shading frame.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Lobes {
    Lambert {
        albedo: Vec3A,
    },
    Emitter {
        color: Vec3A,
    },
    Surface {
        diffuse: Vec3A,
        f0: Vec3A,
        roughness: f32,
        alpha: f32,
        /// `ρ / (π (1 − E_avg))` per channel (0 where `E_avg` ≈ 1).
        diffuse_norm: Vec3A,
    },
}

/// A direction drawn by [`Bsdf::sample`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfSample {
    /// The incident direction (world space, unit length, toward the light).
    pub wi: Vec3A,
    /// `f(wo, wi) |n·wi| / pdf`: what the path throughput is multiplied by. For a mirror sample,
    /// `F(μo) / p_s`.
    pub weight: Vec3A,
    /// The solid-angle density of `wi` (the whole mixture, as [`Bsdf::eval`] returns it); for a
    /// mirror sample (`specular`), the probability `p_s` of having chosen the mirror.
    pub pdf: f32,
    /// True when `wi` came from a delta lobe (a perfect mirror): MIS does not apply, and light
    /// found along `wi` is counted with weight 1.
    pub specular: bool,
}

/// A material's scattering at one hit: the lobes in the shading frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bsdf {
    frame: Frame,
    lobes: Lobes,
}

impl Bsdf {
    /// The BSDF of `material` around the shading normal `normal` (world space; normalised here,
    /// and +Z if it is zero or not finite). Colours that are negative or not finite count as 0;
    /// roughness is clamped to `[0, 1]` (NaN → 0).
    #[must_use]
    pub fn new(material: &Material, normal: Vec3A) -> Bsdf {
        let n = normal
            .try_normalize()
            .filter(|n| n.is_finite())
            .unwrap_or(Vec3A::Z);
        let lobes = match *material {
            Material::Diffuse { color: c } => Lobes::Lambert { albedo: color(c) },
            Material::Constant { color: c } => Lobes::Emitter { color: color(c) },
            Material::Surface {
                diffuse,
                specular,
                roughness,
            } => {
                let roughness = if roughness.is_nan() {
                    0.0
                } else {
                    roughness.clamp(0.0, 1.0)
                };
                let diffuse = color(diffuse);
                let f0 = color(specular).min(Vec3A::ONE);
                let (a1, a2) = EnergyTable::get().average(roughness);
                let e_avg = f0 * a1 + (Vec3A::ONE - f0) * a2;
                let room = Vec3A::ONE - e_avg;
                let norm = |d: f32, r: f32| if r > 1e-4 { d / (PI * r) } else { 0.0 };
                Lobes::Surface {
                    diffuse,
                    f0,
                    roughness,
                    alpha: roughness * roughness,
                    diffuse_norm: Vec3A::new(
                        norm(diffuse.x, room.x),
                        norm(diffuse.y, room.y),
                        norm(diffuse.z, room.z),
                    ),
                }
            }
        };
        Bsdf {
            frame: Frame::new(n),
            lobes,
        }
    }

    /// The shading normal the BSDF was built around (unit length).
    #[must_use]
    pub fn normal(&self) -> Vec3A {
        self.frame.n
    }

    /// True when the BSDF reflects anything (false for PxrConstant): only then are lights sampled.
    #[must_use]
    pub fn reflects(&self) -> bool {
        match self.lobes {
            Lobes::Lambert { albedo } => albedo != Vec3A::ZERO,
            Lobes::Emitter { .. } => false,
            Lobes::Surface { .. } => true,
        }
    }

    /// The diffuse lobe's albedo: PxrDiffuse's colour, PxrSurface's diffuse colour, 0 for
    /// PxrConstant. What an unshadowed uniform (ambient) radiance `A` is reflected by: `albedo·A`.
    #[must_use]
    pub fn diffuse_albedo(&self) -> Vec3A {
        match self.lobes {
            Lobes::Lambert { albedo } => albedo,
            Lobes::Surface { diffuse, .. } => diffuse,
            Lobes::Emitter { .. } => Vec3A::ZERO,
        }
    }

    /// The radiance the surface emits toward any direction: `emitColor` for PxrConstant, else 0.
    #[must_use]
    pub fn emission(&self) -> Vec3A {
        match self.lobes {
            Lobes::Emitter { color } => color,
            _ => Vec3A::ZERO,
        }
    }

    /// `(f(wo, wi), pdf(wi))`: the BSDF value **without** the cosine factor (the integrand is
    /// `f · |n·wi| · L`), and the solid-angle density with which [`Bsdf::sample`] draws `wi` given
    /// `wo`. Both are 0 when `wo` or `wi` is below the shading hemisphere; delta lobes (a perfect
    /// mirror) are not included. `wo` and `wi` are world-space unit vectors pointing away from the
    /// surface. `f` is reciprocal: `f(wo, wi) = f(wi, wo)`; the pdf is not.
    #[must_use]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> (Vec3A, f32) {
        let wo = self.frame.to_local(wo);
        let wi = self.frame.to_local(wi);
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Vec3A::ZERO, 0.0);
        }
        let (f, pdf) = match self.lobes {
            Lobes::Lambert { albedo } => (albedo * FRAC_1_PI, wi.z * FRAC_1_PI),
            Lobes::Emitter { .. } => (Vec3A::ZERO, 0.0),
            Lobes::Surface { .. } => self.eval_surface(wo, wi),
        };
        if pdf.is_finite() && f.is_finite() {
            (sanitize(f), pdf.max(0.0))
        } else {
            (Vec3A::ZERO, 0.0)
        }
    }

    /// Draws `wi` for `wo` (world space, unit, away from the surface): `u` chooses the direction
    /// within a lobe, `u_lobe` the lobe; all in `[0, 1)`. `None` when the BSDF does not reflect,
    /// `wo` is below the shading hemisphere, or the sample falls below it (GGX).
    #[must_use]
    pub fn sample(&self, wo: Vec3A, u: (f32, f32), u_lobe: f32) -> Option<BsdfSample> {
        let wo_l = self.frame.to_local(wo);
        if wo_l.z <= 0.0 {
            return None;
        }
        match self.lobes {
            Lobes::Emitter { .. } => None,
            Lobes::Lambert { albedo } => {
                let wi = cosine_hemisphere(u);
                let pdf = wi.z * FRAC_1_PI;
                (pdf > 0.0 && albedo != Vec3A::ZERO).then(|| BsdfSample {
                    wi: self.frame.to_world(wi),
                    weight: albedo,
                    pdf,
                    specular: false,
                })
            }
            Lobes::Surface { f0, alpha, .. } => {
                let p_s = self.specular_probability(wo_l.z);
                let wi = if u_lobe < p_s {
                    if alpha < MIRROR_ALPHA {
                        let wi = Vec3A::new(-wo_l.x, -wo_l.y, wo_l.z);
                        return Some(BsdfSample {
                            wi: self.frame.to_world(wi),
                            weight: sanitize(schlick(f0, wo_l.z) / p_s),
                            pdf: p_s,
                            specular: true,
                        });
                    }
                    reflect(wo_l, sample_vndf(wo_l, alpha, u))
                } else {
                    cosine_hemisphere(u)
                };
                if wi.z <= 0.0 {
                    return None;
                }
                let (f, pdf) = self.eval_surface(wo_l, wi);
                if !(pdf > 0.0 && pdf.is_finite()) {
                    return None;
                }
                Some(BsdfSample {
                    wi: self.frame.to_world(wi),
                    weight: sanitize(f * (wi.z / pdf)),
                    pdf,
                    specular: false,
                })
            }
        }
    }

    /// PxrSurface's probability of sampling the specular lobe for `μo`:
    /// `a_s / (a_s + a_d)` with `a_s = mean(E(μo))`, `a_d = mean(ρ (1 − E(μo)))`.
    fn specular_probability(&self, mu_o: f32) -> f32 {
        let Lobes::Surface {
            diffuse,
            f0,
            roughness,
            ..
        } = self.lobes
        else {
            return 0.0;
        };
        let e = specular_albedo(f0, mu_o, roughness);
        let a_s = e.element_sum() / 3.0;
        let a_d = (diffuse * (Vec3A::ONE - e)).element_sum() / 3.0;
        if a_d <= 0.0 {
            1.0
        } else if a_s <= 0.0 {
            0.0
        } else {
            (a_s / (a_s + a_d)).clamp(0.0, 1.0)
        }
    }

    /// PxrSurface's `(f, pdf)` in the local frame, both directions above the horizon.
    fn eval_surface(&self, wo: Vec3A, wi: Vec3A) -> (Vec3A, f32) {
        let Lobes::Surface {
            f0,
            roughness,
            alpha,
            diffuse_norm,
            ..
        } = self.lobes
        else {
            return (Vec3A::ZERO, 0.0);
        };
        let e_o = specular_albedo(f0, wo.z, roughness);
        let e_i = specular_albedo(f0, wi.z, roughness);
        let f_d = diffuse_norm * (Vec3A::ONE - e_o) * (Vec3A::ONE - e_i);
        let p_s = self.specular_probability(wo.z);
        let pdf_d = wi.z * FRAC_1_PI;
        if alpha < MIRROR_ALPHA {
            return (f_d, (1.0 - p_s) * pdf_d);
        }
        let h = (wo + wi).normalize_or_zero();
        if h == Vec3A::ZERO {
            return (f_d, (1.0 - p_s) * pdf_d);
        }
        let d = ggx_d(h, alpha);
        let g2 = ggx_g2(wo, wi, alpha);
        let f_s = schlick(f0, wo.dot(h)) * (d * g2 / (4.0 * wo.z * wi.z));
        let pdf_s = vndf_reflection_pdf(wo, h, alpha);
        (f_d + f_s, p_s * pdf_s + (1.0 - p_s) * pdf_d)
    }
}

/// The GGX lobe's directional albedo `E(μ) = F0·E₁ + (1 − F0)·E₂` per channel.
fn specular_albedo(f0: Vec3A, mu: f32, roughness: f32) -> Vec3A {
    let (e1, e2) = EnergyTable::get().albedo(mu, roughness);
    (f0 * e1 + (Vec3A::ONE - f0) * e2).clamp(Vec3A::ZERO, Vec3A::ONE)
}

pub mod textured;

#[cfg(test)]
mod tests;
