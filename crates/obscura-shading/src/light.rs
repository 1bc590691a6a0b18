//! The four RenderMan lights: `PxrDomeLight`, `PxrDistantLight`, `PxrRectLight`, `PxrSphereLight`,
//! and the classic RenderMan Interface's point, spot and ambient lights.
//!
//! Every light's strength is `S = color · intensity · 2^exposure` (negative or non-finite channels
//! count as 0); its `transform` is light-to-world, taken at shutter open (lights do not move).
//!
//! | light | emission | sampling (solid-angle pdf `p`) |
//! |---|---|---|
//! | dome | radiance `S · map(ω)` from every direction `ω` (`map ≡ 1` without `lightColorMap`) | map: 2-D piecewise-constant in `(u, v)` ∝ `mean(rgb) · sin θ`, `p = p_uv / (2π² sin θ)`; no map: uniform sphere, `p = 1/(4π)` |
//! | distant | radiance `S / Ω` inside a cone of half-angle `θ_c = angleExtent/2` around the direction *to* the light, `Ω = 2π(1 − cos θ_c)`; so `∫_cone L dω = S` and the irradiance at normal incidence is `S` | uniform in the cone, `p = 1/Ω`; `angleExtent = 0`: a delta |
//! | rect | radiance `S` from the light's `+Z` side of the 1×1 square `[−½, ½]²` of the light's XY plane (one-sided; RenderMan's `normalize` off: `S` is radiance whatever the size) | uniform in area, `p = d² / (cos θ_l · A)` |
//! | sphere | radiance `S` outward from the sphere of diameter 1 at the light's origin (radius `½ · ∛|det M|`) | uniform in the cone the sphere subtends, `p = 1 / (2π(1 − cos θ_max))`, `sin θ_max = r/d` |
//! | point, spot (classic `pointlight`, `spotlight`; `light/classic.rs`) | irradiance `S / d²` facing the light, times the spot's `cosᵇ α · smoothstep(cos θ_c, cos(θ_c − δ), cos α)` | a delta: `p` = the selection probability, not seen by rays |
//! | ambient (classic `ambientlight`) | not an emitter: uniform radiance `S` that reaches every surface unshadowed, the RI's `ambient()` ([`Lights::ambient`]); the integrator adds it analytically | none |
//!
//! **Dome orientation.** With an identity transform `+Y` is up, and the centre of the lat-long map
//! (`u = v = ½`) is seen looking down `+Z`. A light-space direction `d` reads the map at
//!
//! `u = ½ + atan2(d.x, d.z) / (2π)`, `v = acos(d.y) / π`,
//!
//! with `(u, v) = (0, 0)` the top-left corner of the image (`v` grows down the rows): the top row is
//! `+Y`, the bottom row `−Y`, `u = ¾` is `+X` and `u = ¼` is `−X`; the seam (`u = 0` and `1`) is
//! `−Z`. Inversely, `θ = π v`, `φ = 2π(u − ½)`, `d = (sin θ sin φ, cos θ, sin θ cos φ)`. This is
//! OpenEXR's latitude-longitude layout (centre = `+Z`, top = `+Y`) mirrored left–right, because
//! OpenEXR's spec is written for a right-handed space and RenderMan's is left-handed: a camera with
//! an identity transform looking down `+Z` (`+X` to its right) sees the middle of the map upright and
//! unmirrored. Texels are looked up without filtering (nearest), so the sampling density is exactly
//! proportional to what is seen. Only the rotation of a dome's or distant light's transform is used
//! (its columns orthonormalised; RenderMan lets these lights rotate only).
//!
//! **Distant direction.** The light travels along its light-to-world transform's `+Z` axis: with an
//! identity transform, light moves toward `+Z`, so it falls on surfaces whose normal faces `−Z`, and
//! the direction *to* the light is `−Z`.
//!
//! **Selection and MIS.** [`Lights::sample`] picks one light uniformly among those that can emit (a
//! light with `S = 0` or a degenerate transform is dropped at [`Lights::new`]). Infinite lights that
//! a BSDF ray can find ([`Lights::escaped`]: domes, and distant lights whose `angleExtent` is at
//! least [`DISTANT_MIS_MIN_DEGREES`]) are sampled as one mixture: a sample from any of them reports
//! the radiance of all of them along its direction and the mixture's pdf
//! `Σ_j P(select j) p_j(ω)`, exactly what [`Lights::escaped`] reports for a BSDF ray, so the power
//! heuristic weights of the two strategies sum to 1. Narrower distant lights are reached by light
//! sampling only (`mis = false`). Area lights are found by BSDF rays through
//! [`Lights::intersect_area`]; they are opaque (a light sample blocked by another area light is
//! dropped), but the scene's geometry does not know them, so they cast no shadows of their own on
//! it beyond that.

use std::f32::consts::{PI, TAU};
use std::path::{Path, PathBuf};

use glam::{Mat3A, Mat4, Vec3A};
use obscura_host::distribution::Distribution1D;
use obscura_scene::Light;
use obscura_sdk::Rgb;

mod classic;

use self::classic::{PointLight, SpotBeam};
use crate::material::{Frame, color, sanitize};
use obscura_geometry::ray::Ray;

pub mod emissive;

/// Distant lights at least this wide (`angleExtent`, degrees) are also found by BSDF rays and
/// weighted by MIS; narrower ones (the 0.53° default sun) are reached by light sampling only.
pub const DISTANT_MIS_MIN_DEGREES: f32 = 2.0;

/// Cones narrower than this solid angle (sr) are treated as a delta direction.
const MIN_CONE_SOLID_ANGLE: f32 = 1e-12;

/// Why the lights could not be prepared.
#[derive(Debug, thiserror::Error)]
pub enum ShadeError {
    /// A dome's `lightColorMap` could not be read as an RGB(A) EXR.
    #[error("PxrDomeLight lightColorMap {}: {source}", path.display())]
    MapRead {
        /// The file, as resolved against the scene's directory.
        path: PathBuf,
        /// What the EXR reader said.
        #[source]
        source: exr::error::Error,
    },
    /// A dome's `lightColorMap` has no pixels.
    #[error("PxrDomeLight lightColorMap {}: the image is empty", path.display())]
    MapEmpty {
        /// The file, as resolved against the scene's directory.
        path: PathBuf,
    },
}

/// One light sample toward a shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shading point toward the light.
    pub wi: Vec3A,
    /// Distance to the sampled point on the light; `f32::INFINITY` for dome and distant lights.
    pub dist: f32,
    /// Radiance arriving along `wi` (for a delta distant light: its irradiance at normal incidence,
    /// `S`). The estimate of the reflected radiance is `f · |n·wi| · radiance / pdf`.
    pub radiance: Vec3A,
    /// Solid-angle density of `wi`, including the probability of selecting the light (for a
    /// delta distant light: that probability alone).
    pub pdf: f32,
    /// True when BSDF sampling can also find this light, so the sample is MIS-weighted; false for
    /// delta-like lights (narrow distant lights).
    pub mis: bool,
    /// True when surfaces between the point and the light block it (a shadow ray is traced); false
    /// for lights with `enable_shadows` off (the classic RenderMan lights).
    pub shadows: bool,
}

/// An area light found along a ray by [`Lights::intersect_area`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AreaHit {
    /// Ray parameter of the hit (in units of the ray's direction length).
    pub t: f32,
    /// Radiance leaving the light toward the ray's origin (0 from a rect's back or a sphere's
    /// inside).
    pub radiance: Vec3A,
    /// The density with which [`Lights::sample`] would have produced this direction from the
    /// ray's origin (solid angle, including light selection); 0 where `radiance` is 0.
    pub pdf: f32,
}

/// A lat-long map and its importance distribution.
#[derive(Debug, Clone)]
struct EnvMap {
    width: usize,
    height: usize,
    texels: Vec<Vec3A>,
    dist: Distribution2D,
}

impl EnvMap {
    fn texel(&self, u: f32, v: f32) -> Vec3A {
        let (x, y) = self.cell(u, v);
        self.texels[y * self.width + x]
    }

    fn cell(&self, u: f32, v: f32) -> (usize, usize) {
        let x = ((u * self.width as f32) as usize).min(self.width - 1);
        let y = ((v * self.height as f32) as usize).min(self.height - 1);
        (x, y)
    }
}

/// A 2-D piecewise-constant density on `[0, 1)²`: a marginal over rows, a conditional per row (each a
/// [`Distribution1D`] in `f32`).
#[derive(Debug, Clone)]
struct Distribution2D {
    rows: Vec<Distribution1D<f32>>,
    marginal: Distribution1D<f32>,
}

impl Distribution2D {
    /// The density proportional to `weight(x, y)` on a `width × height` grid (both at least 1), every
    /// weight a number ≥ 0 (`+∞` allowed: its row, and the marginal, become uniform).
    fn new(width: usize, height: usize, weight: impl Fn(usize, usize) -> f32) -> Self {
        let table = |weights: Vec<f32>| {
            Distribution1D::new(weights).expect("a non-empty grid of weights that are numbers >= 0")
        };
        let rows: Vec<Distribution1D<f32>> = (0..height)
            .map(|y| table((0..width).map(|x| weight(x, y)).collect()))
            .collect();
        let marginal = table(rows.iter().map(Distribution1D::integral).collect());
        Distribution2D { rows, marginal }
    }

    /// `((u, v), density in (u, v))`, both coordinates below `1 − ε`.
    fn sample(&self, u: (f32, f32)) -> ((f32, f32), f32) {
        let below_one = |x: f32| x.min(1.0 - f32::EPSILON);
        let (v, pv, y) = self.marginal.sample_continuous(u.1);
        let (x, pu, _) = self.rows[y].sample_continuous(u.0);
        ((below_one(x), below_one(v)), pu * pv)
    }

    fn pdf(&self, x: usize, y: usize) -> f32 {
        self.marginal.cell_pdf(y) * self.rows[y].cell_pdf(x)
    }
}

#[derive(Debug, Clone)]
struct Dome {
    strength: Vec3A,
    to_world: Mat3A,
    to_light: Mat3A,
    map: Option<EnvMap>,
}

impl Dome {
    /// A dome of strength `s` oriented by `transform`'s rotation, its map (if any) read from
    /// `map` resolved against `base_dir`; `None` when the rotation is degenerate or `s` is 0.
    ///
    /// # Errors
    ///
    /// [`ShadeError`] when the map cannot be read (even for a dome of strength 0).
    fn new(
        s: Vec3A,
        map: Option<&Path>,
        transform: &Mat4,
        base_dir: &Path,
    ) -> Result<Option<Dome>, ShadeError> {
        let Some(to_world) = rotation_of(transform) else {
            return Ok(None);
        };
        let map = match map {
            Some(path) => Some(load_map(&base_dir.join(path))?),
            None => None,
        };
        if s == Vec3A::ZERO {
            return Ok(None);
        }
        Ok(Some(Dome {
            strength: s,
            to_world,
            to_light: to_world.transpose(),
            map,
        }))
    }

    /// `(u, v, sin θ)` of a world direction.
    fn uv(&self, dir: Vec3A) -> (f32, f32, f32) {
        let d = (self.to_light * dir).normalize_or(Vec3A::Y);
        let u = 0.5 + d.x.atan2(d.z) / TAU;
        let cos_t = d.y.clamp(-1.0, 1.0);
        let v = cos_t.acos() / PI;
        (
            u.clamp(0.0, 1.0),
            v.clamp(0.0, 1.0),
            (1.0 - cos_t * cos_t).max(0.0).sqrt(),
        )
    }

    fn radiance(&self, dir: Vec3A) -> Vec3A {
        match &self.map {
            None => self.strength,
            Some(map) => {
                let (u, v, _) = self.uv(dir);
                self.strength * map.texel(u, v)
            }
        }
    }

    /// Solid-angle density of sampling `dir` from this dome (without light selection).
    fn pdf(&self, dir: Vec3A) -> f32 {
        match &self.map {
            None => 1.0 / (4.0 * PI),
            Some(map) => {
                let (u, v, sin_t) = self.uv(dir);
                if sin_t <= 0.0 {
                    return 0.0;
                }
                let (x, y) = map.cell(u, v);
                finite_or_zero(map.dist.pdf(x, y) / (2.0 * PI * PI * sin_t))
            }
        }
    }

    /// A world direction drawn with the density [`Dome::pdf`].
    fn sample(&self, u: (f32, f32)) -> Option<Vec3A> {
        match &self.map {
            None => {
                let z = 1.0 - 2.0 * u.0;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = TAU * u.1;
                Some(Vec3A::new(r * phi.cos(), r * phi.sin(), z))
            }
            Some(map) => {
                let ((mu, mv), p_uv) = map.dist.sample(u);
                let theta = PI * mv;
                let phi = TAU * (mu - 0.5);
                let sin_t = theta.sin();
                if p_uv <= 0.0 || sin_t <= 0.0 {
                    return None;
                }
                let d = Vec3A::new(sin_t * phi.sin(), theta.cos(), sin_t * phi.cos());
                (self.to_world * d).try_normalize()
            }
        }
    }
}

#[derive(Debug, Clone)]
struct Distant {
    strength: Vec3A,
    /// Unit direction toward the light (`−Z` of light space, in world space).
    to_light: Vec3A,
    frame: Frame,
    cos_max: f32,
    /// `1 − cos θ_c`, computed as `2 sin²(θ_c/2)`.
    one_minus_cos: f32,
    solid_angle: f32,
    mis: bool,
    /// `enable_shadows`.
    shadows: bool,
}

impl Distant {
    /// A distant light of strength `s` in the cone `angle_extent` degrees wide (clamped to
    /// [0°, 360°]; 0 when not finite) around `transform`'s `−Z`; `None` for a degenerate rotation.
    fn new(s: Vec3A, angle_extent: f32, shadows: bool, transform: &Mat4) -> Option<Distant> {
        let rot = rotation_of(transform)?;
        let extent = if angle_extent.is_finite() {
            angle_extent.clamp(0.0, 360.0)
        } else {
            0.0
        };
        let half = (extent * 0.5).min(180.0).to_radians();
        let s_half = (half * 0.5).sin();
        let one_minus_cos = 2.0 * s_half * s_half;
        let to_light = -(rot * Vec3A::Z).normalize();
        Some(Distant {
            strength: s,
            to_light,
            frame: Frame::new(to_light),
            cos_max: 1.0 - one_minus_cos,
            one_minus_cos,
            solid_angle: TAU * one_minus_cos,
            mis: extent >= DISTANT_MIS_MIN_DEGREES,
            shadows,
        })
    }

    fn is_delta(&self) -> bool {
        self.solid_angle < MIN_CONE_SOLID_ANGLE
    }

    fn radiance(&self, dir: Vec3A) -> Vec3A {
        if self.is_delta() || dir.dot(self.to_light) < self.cos_max {
            Vec3A::ZERO
        } else {
            self.strength / self.solid_angle
        }
    }

    fn pdf(&self, dir: Vec3A) -> f32 {
        if self.is_delta() || dir.dot(self.to_light) < self.cos_max {
            0.0
        } else {
            1.0 / self.solid_angle
        }
    }
}

#[derive(Debug, Clone)]
struct Rect {
    strength: Vec3A,
    corner: Vec3A,
    ex: Vec3A,
    ey: Vec3A,
    /// Unit normal on the emitting (`+Z` of light space) side.
    normal: Vec3A,
    /// `ex × ey`, and `1 / |ex × ey|²`.
    cross: Vec3A,
    inv_cross2: f32,
    area: f32,
}

impl Rect {
    /// The unit square of `transform`'s XY plane, of strength `s`, facing `+Z` (mirrored by a
    /// mirroring transform); `None` when the transform is not finite or flattens the square.
    fn new(s: Vec3A, transform: &Mat4) -> Option<Rect> {
        if !transform.is_finite() {
            return None;
        }
        let corner = Vec3A::from(transform.transform_point3(glam::Vec3::new(-0.5, -0.5, 0.0)));
        let ex = Vec3A::from(transform.transform_vector3(glam::Vec3::X));
        let ey = Vec3A::from(transform.transform_vector3(glam::Vec3::Y));
        let det = Mat3A::from_mat4(*transform).determinant();
        let cross = ex.cross(ey);
        let area = cross.length();
        if !(area > 0.0 && area.is_finite() && det != 0.0) {
            return None;
        }
        let normal = cross / area * det.signum();
        Some(Rect {
            strength: s,
            corner,
            ex,
            ey,
            normal,
            cross,
            inv_cross2: 1.0 / (area * area),
            area,
        })
    }

    fn intersect(&self, o: Vec3A, d: Vec3A, t_min: f32, t_max: f32) -> Option<f32> {
        let denom = self.normal.dot(d);
        if denom == 0.0 || !denom.is_finite() {
            return None;
        }
        let t = self.normal.dot(self.corner - o) / denom;
        if !(t > t_min && t < t_max) {
            return None;
        }
        let q = o + d * t - self.corner;
        let a = q.cross(self.ey).dot(self.cross) * self.inv_cross2;
        let b = self.ex.cross(q).dot(self.cross) * self.inv_cross2;
        ((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)).then_some(t)
    }

    /// Solid-angle density (without selection) of reaching the rect along unit `wi` at `dist`.
    fn pdf(&self, wi: Vec3A, dist: f32) -> f32 {
        let cos_l = -wi.dot(self.normal);
        if cos_l <= 0.0 {
            0.0
        } else {
            finite_or_zero(dist * dist / (cos_l * self.area))
        }
    }
}

#[derive(Debug, Clone)]
struct SphereLight {
    strength: Vec3A,
    center: Vec3A,
    radius: f32,
}

impl SphereLight {
    /// The sphere of diameter 1 at `transform`'s origin (radius `½ · ∛|det M|`), of strength `s`;
    /// `None` when the transform is not finite or the radius is 0.
    fn new(s: Vec3A, transform: &Mat4) -> Option<SphereLight> {
        if !transform.is_finite() {
            return None;
        }
        let center = Vec3A::from(transform.transform_point3(glam::Vec3::ZERO));
        let radius = 0.5 * Mat3A::from_mat4(*transform).determinant().abs().cbrt();
        if !(radius > 0.0 && radius.is_finite()) {
            return None;
        }
        Some(SphereLight {
            strength: s,
            center,
            radius,
        })
    }

    /// `1 − cos θ_max` of the cone the sphere subtends from `p`, or `None` from inside.
    fn cone(&self, p: Vec3A) -> Option<(f32, f32)> {
        let d2 = (self.center - p).length_squared();
        let r2 = self.radius * self.radius;
        if d2 <= r2 {
            return None;
        }
        let sin2 = r2 / d2;
        let cos_max = (1.0 - sin2).max(0.0).sqrt();
        // 1 − cos θ = sin²θ / (1 + cos θ): no cancellation for small spheres.
        Some((cos_max, sin2 / (1.0 + cos_max)))
    }

    fn pdf(&self, p: Vec3A) -> f32 {
        match self.cone(p) {
            Some((_, omc)) if omc > 0.0 => finite_or_zero(1.0 / (TAU * omc)),
            _ => 0.0,
        }
    }

    fn intersect(&self, o: Vec3A, d: Vec3A, t_min: f32, t_max: f32) -> Option<f32> {
        let a = d.length_squared();
        if a <= 0.0 {
            return None;
        }
        let oc = o - self.center;
        let b = oc.dot(d);
        // The discriminant from the closest approach (Haines et al., Ray Tracing Gems ch. 7).
        let l = oc - d * (b / a);
        let disc = a * (self.radius * self.radius - l.length_squared());
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let c = oc.length_squared() - self.radius * self.radius;
        let q = -b - b.signum() * disc.sqrt();
        let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
        let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
        [t0, t1].into_iter().find(|&t| t > t_min && t < t_max)
    }
}

#[derive(Debug, Clone)]
enum Emitter {
    Dome(Dome),
    Distant(Distant),
    Rect(Rect),
    Sphere(SphereLight),
    /// A point or spot light (a delta).
    Point(PointLight),
}

impl Emitter {
    /// `S`, the light's strength.
    fn strength(&self) -> Vec3A {
        match self {
            Emitter::Dome(d) => d.strength,
            Emitter::Distant(d) => d.strength,
            Emitter::Rect(r) => r.strength,
            Emitter::Sphere(s) => s.strength,
            Emitter::Point(p) => p.strength,
        }
    }

    /// False for a light whose `enable_shadows` is off: nothing blocks it.
    fn casts_shadows(&self) -> bool {
        match self {
            Emitter::Distant(d) => d.shadows,
            Emitter::Point(p) => p.shadows,
            Emitter::Dome(_) | Emitter::Rect(_) | Emitter::Sphere(_) => true,
        }
    }

    /// The ray parameter of the nearest hit with `t_min < t < t_max` along `o + t·d` for an area
    /// light (rect or sphere); `None` for infinite lights.
    fn intersect_area(&self, o: Vec3A, d: Vec3A, t_min: f32, t_max: f32) -> Option<f32> {
        match self {
            Emitter::Rect(r) => r.intersect(o, d, t_min, t_max),
            Emitter::Sphere(s) => s.intersect(o, d, t_min, t_max),
            Emitter::Dome(_) | Emitter::Distant(_) | Emitter::Point(_) => None,
        }
    }
}

/// All lights of a scene, in world space, ready for sampling.
#[derive(Debug, Clone, Default)]
pub struct Lights {
    emitters: Vec<Emitter>,
    /// The classic ambient lights' summed strength.
    ambient: Vec3A,
}

impl Lights {
    /// Prepares `lights`; a dome's relative `lightColorMap` is resolved against `base_dir` and read
    /// as a lat-long EXR (channels R, G, B, optional A; the largest level of a mip-mapped file).
    /// Lights that cannot emit (strength 0, a singular or non-finite transform) are dropped.
    ///
    /// # Errors
    ///
    /// [`ShadeError`] naming the map file when it cannot be read or is empty.
    pub fn new(lights: &[Light], base_dir: &Path) -> Result<Self, ShadeError> {
        let mut emitters = Vec::new();
        let mut ambient = Vec3A::ZERO;
        for light in lights {
            if let Light::Ambient { color: c, intensity } = light {
                ambient += sanitize(color(*c) * *intensity);
            } else if let Some(e) = Self::prepare(light, base_dir)? {
                emitters.push(e);
            }
        }
        Ok(Lights {
            emitters,
            ambient: sanitize(ambient),
        })
    }

    /// The radiance of the classic `ambientlight`s, summed: `Σ I·C`. It reaches every surface from
    /// every direction without shadowing, as the RI's `ambient()` does: a surface whose ambient
    /// reflectance is `ρ_a` (`Ka·Cs` for a classic shader, the diffuse albedo for any other) reflects
    /// `ρ_a·Σ I·C`. Not seen by any ray.
    #[must_use]
    pub fn ambient(&self) -> Vec3A {
        self.ambient
    }

    /// The emitter `light` becomes; `None` for a light that cannot emit (or is not an emitter:
    /// the ambient lights, which `new` sums).
    fn prepare(light: &Light, base_dir: &Path) -> Result<Option<Emitter>, ShadeError> {
        let e = match light {
            Light::Dome {
                color: c,
                intensity,
                exposure,
                map,
                transform,
            } => Dome::new(
                strength(*c, *intensity, *exposure),
                map.as_deref(),
                transform,
                base_dir,
            )?
            .map(Emitter::Dome),
            Light::Ambient { .. } => None,
            Light::Point(p) => PointLight::new(p, None).map(Emitter::Point),
            Light::Spot {
                emitter: p,
                direction,
                cone_angle,
                cone_delta,
                beam_distribution,
            } => SpotBeam::new(
                Vec3A::from(*direction),
                *cone_angle,
                *cone_delta,
                *beam_distribution,
            )
            .and_then(|beam| PointLight::new(p, Some(beam)))
            .map(Emitter::Point),
            Light::Distant {
                color: c,
                intensity,
                exposure,
                angle_extent,
                enable_shadows,
                transform,
            } => Distant::new(
                strength(*c, *intensity, *exposure),
                *angle_extent,
                *enable_shadows,
                transform,
            )
            .map(Emitter::Distant),
            Light::Rect {
                color: c,
                intensity,
                exposure,
                transform,
            } => Rect::new(strength(*c, *intensity, *exposure), transform).map(Emitter::Rect),
            Light::Sphere {
                color: c,
                intensity,
                exposure,
                transform,
            } => SphereLight::new(strength(*c, *intensity, *exposure), transform).map(Emitter::Sphere),
        };
        Ok(e.filter(|e| e.strength() != Vec3A::ZERO))
    }

    /// Number of lights that can emit.
    #[must_use]
    pub fn len(&self) -> usize {
        self.emitters.len()
    }

    /// True when no light can emit.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.emitters.is_empty()
    }

    /// The probability of selecting any one light: `1 / len` (uniform selection).
    fn select_pdf(&self) -> f32 {
        if self.emitters.is_empty() {
            0.0
        } else {
            1.0 / self.emitters.len() as f32
        }
    }

    /// Samples one light for the shading point `p` with surface normal `n`: `u_light` selects the
    /// light (uniformly), `u` the point or direction on it; all in `[0, 1)`. Samples below the
    /// tangent plane of `n` are dropped early (pass `Vec3A::ZERO` to keep them). `None` when there
    /// is nothing to sample, the sample cannot contribute, or another area light blocks it. The
    /// caller traces the shadow ray (to `dist`, or unbounded for infinite lights).
    #[must_use]
    pub fn sample(&self, p: Vec3A, n: Vec3A, u: (f32, f32), u_light: f32) -> Option<LightSample> {
        let count = self.emitters.len();
        if count == 0 {
            return None;
        }
        let index = ((u_light.clamp(0.0, 1.0) * count as f32) as usize).min(count - 1);
        let select = self.select_pdf();
        let sample = match &self.emitters[index] {
            Emitter::Dome(d) => {
                let wi = d.sample(u)?;
                self.infinite_sample(wi)?
            }
            Emitter::Distant(d) => {
                if d.is_delta() {
                    LightSample {
                        wi: d.to_light,
                        dist: f32::INFINITY,
                        radiance: d.strength,
                        pdf: select,
                        mis: false,
                        shadows: true,
                    }
                } else {
                    let (local, _, _) = sample_cone(u, d.one_minus_cos);
                    let wi = d.frame.to_world(local).normalize_or(d.to_light);
                    if d.mis {
                        self.infinite_sample(wi)?
                    } else {
                        LightSample {
                            wi,
                            dist: f32::INFINITY,
                            radiance: d.strength / d.solid_angle,
                            pdf: select / d.solid_angle,
                            mis: false,
                            shadows: true,
                        }
                    }
                }
            }
            Emitter::Rect(r) => {
                let q = r.corner + r.ex * u.0 + r.ey * u.1;
                let v = q - p;
                let dist = v.length();
                if !(dist > 0.0 && dist.is_finite()) {
                    return None;
                }
                let wi = v / dist;
                let pdf = r.pdf(wi, dist) * select;
                if pdf.is_nan() || pdf <= 0.0 {
                    return None;
                }
                LightSample {
                    wi,
                    dist,
                    radiance: r.strength,
                    pdf,
                    mis: true,
                    shadows: true,
                }
            }
            Emitter::Sphere(s) => {
                let (_, omc) = s.cone(p)?;
                let to_c = s.center - p;
                let dc = to_c.length();
                let frame = Frame::new(to_c / dc);
                let (local, cos_t, sin_t) = sample_cone(u, omc);
                let wi = frame.to_world(local).normalize();
                // Distance to the near side: d cos θ − √(r² − d² sin²θ).
                let h2 = (s.radius * s.radius - dc * dc * sin_t * sin_t).max(0.0);
                let dist = (dc * cos_t - h2.sqrt()).max(0.0);
                let pdf = finite_or_zero(select / (TAU * omc));
                if !(pdf > 0.0 && dist > 0.0) {
                    return None;
                }
                LightSample {
                    wi,
                    dist,
                    radiance: s.strength,
                    pdf,
                    mis: true,
                    shadows: true,
                }
            }
            Emitter::Point(l) => {
                let (wi, dist, radiance) = l.illuminate(p)?;
                LightSample {
                    wi,
                    dist,
                    radiance,
                    pdf: select,
                    mis: false,
                    shadows: true,
                }
            }
        };
        if n != Vec3A::ZERO && sample.wi.dot(n) <= 0.0 {
            return None;
        }
        let sample = LightSample {
            shadows: self.emitters[index].casts_shadows(),
            ..sample
        };
        if sample.shadows && self.blocked_by_area(p, sample.wi, sample.dist, index) {
            return None;
        }
        (sample.pdf > 0.0 && sample.pdf.is_finite() && sample.radiance.is_finite()).then_some(sample)
    }

    /// A sample of the infinite-light mixture along `wi` (see the module doc).
    fn infinite_sample(&self, wi: Vec3A) -> Option<LightSample> {
        let (radiance, pdf) = self.escaped(wi);
        (pdf > 0.0).then_some(LightSample {
            wi,
            dist: f32::INFINITY,
            radiance,
            pdf,
            mis: true,
            shadows: true,
        })
    }

    /// True when an area light other than `except` lies on the segment from `p` along unit `wi`
    /// up to `dist` (slightly short of it).
    fn blocked_by_area(&self, p: Vec3A, wi: Vec3A, dist: f32, except: usize) -> bool {
        let t_max = if dist.is_finite() {
            dist * (1.0 - 1e-4)
        } else {
            f32::INFINITY
        };
        self.emitters
            .iter()
            .enumerate()
            .any(|(i, e)| i != except && e.intersect_area(p, wi, 0.0, t_max).is_some())
    }

    /// Radiance arriving along a ray that leaves the scene in direction `ray_dir` (any length), and
    /// the density with which [`Lights::sample`] produces that direction (solid angle, including
    /// selection): the sum over domes and over distant lights wide enough for MIS
    /// ([`DISTANT_MIS_MIN_DEGREES`]). Weight a BSDF ray's contribution by the power heuristic
    /// against this pdf.
    #[must_use]
    pub fn escaped(&self, ray_dir: Vec3A) -> (Vec3A, f32) {
        let Some(dir) = ray_dir.try_normalize() else {
            return (Vec3A::ZERO, 0.0);
        };
        let select = self.select_pdf();
        let mut radiance = Vec3A::ZERO;
        let mut pdf = 0.0;
        for e in &self.emitters {
            match e {
                Emitter::Dome(d) => {
                    radiance += d.radiance(dir);
                    pdf += select * d.pdf(dir);
                }
                Emitter::Distant(d) if d.mis => {
                    radiance += d.radiance(dir);
                    pdf += select * d.pdf(dir);
                }
                _ => {}
            }
        }
        (sanitize(radiance), finite_or_zero(pdf))
    }

    /// What a camera ray that leaves the scene sees: the domes' radiance along `ray_dir` (distant
    /// lights are not visible to the camera, as in RenderMan).
    #[must_use]
    pub fn background(&self, ray_dir: Vec3A) -> Vec3A {
        let Some(dir) = ray_dir.try_normalize() else {
            return Vec3A::ZERO;
        };
        let l = self
            .emitters
            .iter()
            .map(|e| {
                if let Emitter::Dome(d) = e {
                    d.radiance(dir)
                } else {
                    Vec3A::ZERO
                }
            })
            .fold(Vec3A::ZERO, |a, b| a + b);
        sanitize(l)
    }

    /// The nearest rect or sphere light along `ray` with `ray.t_min < t < t_max` (also bounded by
    /// `ray.t_max`), with the radiance it sends back along the ray and the pdf with which
    /// [`Lights::sample`] at `ray.origin` would have chosen that direction.
    #[must_use]
    pub fn intersect_area(&self, ray: &Ray, t_max: f32) -> Option<AreaHit> {
        let len = ray.direction.length();
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        let t_max = t_max.min(ray.t_max);
        let (o, d) = (ray.origin, ray.direction);
        let mut best: Option<(f32, usize)> = None;
        for (i, e) in self.emitters.iter().enumerate() {
            let limit = best.map_or(t_max, |b| b.0);
            if let Some(t) = e.intersect_area(o, d, ray.t_min, limit) {
                best = Some((t, i));
            }
        }
        let (t, i) = best?;
        let wi = d / len;
        let select = self.select_pdf();
        let emitter = &self.emitters[i];
        let pdf = match emitter {
            Emitter::Rect(r) => r.pdf(wi, t * len),
            Emitter::Sphere(s) => s.pdf(o),
            Emitter::Dome(_) | Emitter::Distant(_) | Emitter::Point(_) => 0.0,
        };
        let (radiance, pdf) = if pdf > 0.0 {
            (emitter.strength(), pdf * select)
        } else {
            (Vec3A::ZERO, 0.0)
        };
        Some(AreaHit {
            t,
            radiance,
            pdf: finite_or_zero(pdf),
        })
    }
}

/// `S = color · intensity · 2^exposure`, with negative or non-finite channels as 0.
fn strength(c: Rgb, intensity: f32, exposure: f32) -> Vec3A {
    sanitize(color(c) * (intensity * exposure.exp2()))
}

/// A direction drawn uniformly in the cone of `1 − cos θ_max = one_minus_cos` around local `+Z`:
/// `cos θ = 1 − u₀·(1 − cos θ_max)`, `φ = 2π·u₁`, with `sin θ` taken from `1 − cos θ` (no cancellation
/// for narrow cones). Returns `(direction, cos θ, sin θ)`.
fn sample_cone(u: (f32, f32), one_minus_cos: f32) -> (Vec3A, f32, f32) {
    let one_minus = u.0 * one_minus_cos;
    let cos_t = 1.0 - one_minus;
    let sin_t = (one_minus * (1.0 + cos_t)).max(0.0).sqrt();
    let phi = TAU * u.1;
    (
        Vec3A::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t),
        cos_t,
        sin_t,
    )
}

fn finite_or_zero(x: f32) -> f32 {
    if x.is_finite() && x > 0.0 { x } else { 0.0 }
}

/// The rotation (possibly with a reflection) of a light-to-world matrix: its first two columns
/// orthonormalised (Gram–Schmidt), the third their cross product with the sign of the determinant.
fn rotation_of(m: &Mat4) -> Option<Mat3A> {
    if !m.is_finite() {
        return None;
    }
    let m3 = Mat3A::from_mat4(*m);
    let det = m3.determinant();
    let x = m3.x_axis.try_normalize()?;
    let y = (m3.y_axis - x * x.dot(m3.y_axis)).try_normalize()?;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let z = x.cross(y) * det.signum();
    Some(Mat3A::from_cols(x, y, z))
}

/// Reads a lat-long EXR and builds its importance distribution (texel mean × sin θ of its row).
fn load_map(path: &Path) -> Result<EnvMap, ShadeError> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| {
            (
                resolution.width(),
                vec![Vec3A::ZERO; resolution.width() * resolution.height()],
            )
        },
        |(width, texels): &mut (usize, Vec<Vec3A>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            if let Some(t) = texels.get_mut(pos.y() * *width + pos.x()) {
                *t = sanitize(Vec3A::new(r, g, b));
            }
        },
    )
    .map_err(|source| ShadeError::MapRead {
        path: path.to_path_buf(),
        source,
    })?;
    let (width, texels) = image.layer_data.channel_data.pixels;
    let height = texels.len().checked_div(width).unwrap_or(0);
    if width == 0 || height == 0 {
        return Err(ShadeError::MapEmpty {
            path: path.to_path_buf(),
        });
    }
    let dist = Distribution2D::new(width, height, |x, y| {
        let sin_t = (PI * (y as f32 + 0.5) / height as f32).sin();
        texels[y * width + x].element_sum() / 3.0 * sin_t
    });
    Ok(EnvMap {
        width,
        height,
        texels,
        dist,
    })
}

#[cfg(test)]
mod tests;
