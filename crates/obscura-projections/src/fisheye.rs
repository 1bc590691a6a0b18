//! `Fisheye`: circular fisheye lenses with an angular or a physical (sensor) mapping.
//!
//! # Mapping
//!
//! A screen sample `s = (sx, sy)` is at radius `r = |s|` from the lens axis. Its ray leaves the origin
//! at the angle `θ(r)` from +Z, with the azimuth of `s` itself (screen +x → camera +X, screen +y →
//! camera +Y, no mirroring):
//!
//! ```text
//! D = (sin θ · sx/r,  sin θ · sy/r,  cos θ)          (D = (sin θ, 0, cos θ) at r = 0)
//! ```
//!
//! `θ(r)` per `mapping`, with `fov` the full field of view and `θmax = min(fov/2, 180°)`:
//!
//! | mapping | law | valid region |
//! |---|---|---|
//! | `equidistant` | `θ = r·fov/2` | `r ≤ 1`; `fov ≤ 360°` |
//! | `stereographic` | `θ = 2·atan(r·tan(fov/4))` | `r ≤ 1`; `fov < 360°` |
//! | `orthographic` | `sin θ = r·sin(fov/2)` | `r ≤ 1`; `fov ≤ 180°` |
//! | `equisolid` | `r_mm = 2f·sin(θ/2)` | `θ ≤ θmax`, i.e. `r_mm ≤ 2f·sin(θmax/2)`; `fov ≤ 360°` |
//! | `polynomial` | `θ = −(k0 + k1·r_mm + k2·r_mm² + k3·r_mm³ + k4·r_mm⁴)` | `0 ≤ θ ≤ θmax` and `θ` increasing (below) |
//!
//! The angular mappings (equidistant, stereographic, orthographic) map the unit circle `sx² + sy² ≤ 1`
//! of screen space onto `fov` (with the default screen window the circle touches the shorter image
//! edges; conventions.md). The physical mappings place the sensor across the screen window's width:
//! `r_mm = r·sensorWidthMm/(r − l)` millimetres from the sensor centre, `f = focalLengthMm`. The lens
//! maps by its focal length (or polynomial) and `fov` only clips the image circle, as in Cycles; the
//! equisolid's physical limit `θ ≤ 180°` (`r_mm ≤ 2f`) is `fov ≤ 360°`. The polynomial is Cycles'
//! `fisheye_lens_polynomial` with its sign convention (a real lens has `k1 < 0`; `k1 = −1/f` is an
//! equidistant lens of focal length `f` mm). Its valid region is the interval `r_mm ∈ [r_lo, r_hi]`
//! where, walking out from the centre, `θ` is still increasing (`r_hi` is at most the first zero of
//! `dθ/dr`), `θ ≥ 0` (`r_lo` is the zero of `θ` when `k0 > 0`, else 0) and `θ ≤ θmax`. Every other
//! parameter combination describes no visible lens and is an error at `create`.
//!
//! `focalLengthMm` and `sensorWidthMm` matter only to `equisolid` and `polynomial`; `polynomial` only to
//! `polynomial`. Samples outside the valid region get the zero direction (culled), with nothing NaN
//! anywhere: the rim `r = r_hi` itself is inside, except where it collapses to the single direction −Z
//! (`θ(r_hi) = 180°`, a 360° fisheye), where it is left out so every valid sample has one inverse.
//!
//! # Footprint
//!
//! With `A = dθ/dr` (radial) and `B = sin θ / r` (tangential), both per screen unit, moving the screen
//! point by `(dx, dy)` turns the direction by `sqrt(A²·dr² + B²·r²·dφ²)`, so for a pixel of
//! `Δx × Δy` screen units
//!
//! ```text
//! αx = Δx·sqrt(A²·sx² + B²·sy²)/r,   αy = Δy·sqrt(A²·sy² + B²·sx²)/r,   ray_spread = ½·sqrt(αx·αy)
//! ```
//!
//! (`αx = Δx·A`, `αy = Δy·A` at `r = 0`; [`crate::panorama`]'s radial maps). Per mapping: equidistant `A = fov/2`, `B = sin θ/r`;
//! stereographic `A = B = 2t/(r·(1 + t²))`, `t = r·tan(fov/4)` (it is conformal); orthographic
//! `A = sin(fov/2)/cos θ`, `B = sin(fov/2)`; equisolid `A = 2q/cos(θ/2)`, `B = 2q·cos(θ/2)` with
//! `q = (mm per screen unit)/(2f)`; polynomial `A = dθ/dr` from the derivative polynomial. The
//! orthographic and equisolid `A` are infinite where `θ` reaches 90° and 180°; within a hundredth of a
//! pixel of that radius the cosine is held at its value there, so the spread stays finite.
//! `origin_radius = 0`; clipping is spherical: `min_dist = near`, `max_dist = far`.
//!
//! # Inverse
//!
//! A camera-space point at angle `θ = atan2(sqrt(x² + y²), z)` from +Z is seen at
//! `s = r(θ)·(x, y)/sqrt(x² + y²)` with the mapping's inverse law (`r = θ/(fov/2)`,
//! `tan(θ/2)/tan(fov/4)`, `sin θ/sin(fov/2)`, `2f·sin(θ/2)` mm); the polynomial is inverted by Newton's
//! method, bracketed by `[r_lo, r_hi]`. Points outside the valid region give `None` (a millionth of a
//! radian of slack at the rim absorbs `f32` rounding of the rays).
//!
//! # Properties
//!
//! DicingHint Spherical; DeepMetric RayLength for every mapping and fov (the depth of a fisheye is the
//! distance along its rays, as in Cycles, and does not change meaning when `fov` crosses 180°);
//! FieldOfView the angle across the screen window's shorter side through the centre,
//! `2·θ(min(r − l, t − b)/2)` capped at `fov`, which is exactly `fov` for the angular mappings with the
//! default window.

use std::sync::LazyLock;

use obscura_sdk::{
    DeepMetric, ParamDecl, PluginError, Point2, Projection, ProjectionContext, ProjectionEnvironment,
    ProjectionProperty, PropertyValue, SoaContext, ValueRange, Vec3,
};

use crate::panorama::{
    CentredLane, SphericalClip, finite_f64, radial_lane, rim_cos_floor, sin_cos, spherical_property,
};
use crate::screen;

/// The name scenes use.
pub const NAME: &str = "Fisheye";

/// The default `polynomial`: an equidistant lens of the default 10.5 mm focal length (`k1 = −1/10.5`).
pub const DEFAULT_POLYNOMIAL: [f32; 5] = [0.0, -1.0 / 10.5, 0.0, 0.0, 0.0];

/// Slack in radians when deciding whether a direction is inside the field of view.
const ANGLE_SLACK: f64 = 1e-6;

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    vec![
        ParamDecl::string("mapping", "equidistant")
            .choices(&Mapping::NAMES)
            .doc("radial law: equidistant, equisolid, stereographic, orthographic or polynomial"),
        ParamDecl::float("fov", 180.0)
            .range(ValueRange {
                min: 0.0,
                max: 360.0,
                min_inclusive: false,
                max_inclusive: true,
            })
            .doc(
                "field of view in degrees: the unit circle's angle (angular mappings) or the clip of the image \
                 circle (equisolid, polynomial); up to 360 (stereographic < 360, orthographic <= 180)",
            ),
        ParamDecl::float("focalLengthMm", 10.5)
            .range(ValueRange::greater_than(0.0))
            .doc("equisolid focal length f in mm: r_mm = 2 f sin(theta/2)"),
        ParamDecl::float("sensorWidthMm", 36.0)
            .range(ValueRange::greater_than(0.0))
            .doc("sensor width in mm across the screen window's width (equisolid, polynomial)"),
        ParamDecl::float_array("polynomial", &DEFAULT_POLYNOMIAL).doc(
            "k0..k4: theta = -(k0 + k1 r + k2 r^2 + k3 r^3 + k4 r^4), r in sensor mm (Cycles' convention); \
             default an equidistant 10.5 mm lens",
        ),
    ]
});

/// The radial law of a [`Fisheye`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Mapping {
    /// `θ = r·fov/2`.
    #[default]
    Equidistant,
    /// `r_mm = 2f·sin(θ/2)`.
    Equisolid,
    /// `θ = 2·atan(r·tan(fov/4))`.
    Stereographic,
    /// `sin θ = r·sin(fov/2)`.
    Orthographic,
    /// `θ = −(k0 + k1·r_mm + … + k4·r_mm⁴)`.
    Polynomial,
}

impl Mapping {
    /// The spellings of the `mapping` parameter.
    pub const NAMES: [&'static str; 5] = [
        "equidistant",
        "equisolid",
        "stereographic",
        "orthographic",
        "polynomial",
    ];

    /// Reads a `mapping` value.
    #[must_use]
    pub fn parse(s: &str) -> Option<Mapping> {
        match s {
            "equidistant" => Some(Mapping::Equidistant),
            "equisolid" => Some(Mapping::Equisolid),
            "stereographic" => Some(Mapping::Stereographic),
            "orthographic" => Some(Mapping::Orthographic),
            "polynomial" => Some(Mapping::Polynomial),
            _ => None,
        }
    }
}

/// Creates [`Fisheye`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct FisheyeFactory;

projection_factory!(
    FisheyeFactory,
    "circular fisheye: equidistant, equisolid, stereographic, orthographic or Cycles' polynomial lens; \
     fov may exceed 180",
    |env, p| {
        let mapping = Mapping::parse(p.string("mapping")?).ok_or_else(|| invalid("unknown mapping"))?;
        let k = p.floats("polynomial", 5)?;
        let lens = Lens {
            mapping,
            fov: p.float("fov")?,
            focal_length_mm: p.float("focalLengthMm")?,
            sensor_width_mm: p.float("sensorWidthMm")?,
            polynomial: [k[0], k[1], k[2], k[3], k[4]],
        };
        env.set_deep_metric(DeepMetric::RayLength);
        Ok(Box::new(Fisheye::new(env, &lens)?))
    }
);

fn invalid(message: impl Into<String>) -> PluginError {
    crate::invalid(NAME, message)
}

/// The parameters of one fisheye lens, as the table declares them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lens {
    /// The radial law.
    pub mapping: Mapping,
    /// Field of view in degrees.
    pub fov: f32,
    /// Focal length in mm (equisolid).
    pub focal_length_mm: f32,
    /// Sensor width in mm across the screen window's width (equisolid, polynomial).
    pub sensor_width_mm: f32,
    /// `k0..k4` of the polynomial mapping.
    pub polynomial: [f32; 5],
}

/// The per-mapping constants of the radial law, in screen units.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Law {
    /// `θ = h·r`.
    Equidistant { h: f32 },
    /// `θ = 2·atan(k·r)`.
    Stereographic { k: f32 },
    /// `sin θ = m·r`; `cos_floor` keeps `A = m/cos θ` finite at a 180° rim.
    Orthographic { m: f32, cos_floor: f32 },
    /// `sin(θ/2) = q·r`; `cos_floor` keeps `A = 2q/cos(θ/2)` finite at a 360° rim.
    Equisolid { q: f32, cos_floor: f32 },
    /// `θ = Σ p[i]·rⁱ`, `dθ/dr = Σ dp[i]·rⁱ`.
    Polynomial { p: [f32; 5], dp: [f32; 4] },
}

/// A fisheye lens (see the module documentation for its mapping).
#[derive(Debug, Clone, PartialEq)]
pub struct Fisheye {
    law: Law,
    /// The polynomial in screen units, f64, for the inverse.
    p64: [f64; 5],
    fov: f32,
    field_of_view: f32,
    theta_max: f64,
    r_lo: f64,
    r_hi: f64,
    r_lo2: f32,
    /// `r_hi²`, or the float just below it when the rim is left out.
    r_hi2: f32,
    half_pixel: f32,
    clip: SphericalClip,
}

impl Fisheye {
    /// A fisheye for `env` with the lens `lens`.
    ///
    /// # Errors
    /// [`PluginError::Invalid`] when `fov` is beyond the mapping's limit (stereographic 360°,
    /// orthographic 180°) or the polynomial describes no visible lens (not increasing from the centre,
    /// or never inside `[0, fov/2]`).
    pub fn new(env: &ProjectionEnvironment, lens: &Lens) -> Result<Self, PluginError> {
        let fov = lens.fov;
        if !(fov > 0.0 && fov <= 360.0) {
            return Err(invalid(format!(
                "parameter \"fov\" = {fov}: expected a value in (0, 360]"
            )));
        }
        let theta_max = (0.5 * f64::from(fov).to_radians()).min(std::f64::consts::PI);
        let window = env.screen_window();
        let eps = screen::rim_step(env);
        let mm_per_unit = f64::from(lens.sensor_width_mm) / f64::from(window.width());
        let mut p64 = [0.0; 5];
        let (law, r_lo, r_hi) = match lens.mapping {
            Mapping::Equidistant => (Law::Equidistant { h: theta_max as f32 }, 0.0, 1.0),
            Mapping::Stereographic => {
                if fov >= 360.0 {
                    return Err(invalid(format!(
                        "parameter \"fov\" = {fov} is out of range for mapping \"stereographic\": expected a \
                         value in (0, 360) (the stereographic rim is at infinity at 360)"
                    )));
                }
                (
                    Law::Stereographic {
                        k: (0.5 * theta_max).tan() as f32,
                    },
                    0.0,
                    1.0,
                )
            }
            Mapping::Orthographic => {
                if fov > 180.0 {
                    return Err(invalid(format!(
                        "parameter \"fov\" = {fov} is out of range for mapping \"orthographic\": expected a \
                         value in (0, 180] (sin θ = r·sin(fov/2) folds back beyond 90°)"
                    )));
                }
                let m = theta_max.sin();
                (
                    Law::Orthographic {
                        m: m as f32,
                        cos_floor: rim_cos_floor(m * eps),
                    },
                    0.0,
                    1.0,
                )
            }
            Mapping::Equisolid => {
                let q = mm_per_unit / (2.0 * f64::from(lens.focal_length_mm));
                (
                    Law::Equisolid {
                        q: q as f32,
                        cos_floor: rim_cos_floor(q * eps),
                    },
                    0.0,
                    (0.5 * theta_max).sin() / q,
                )
            }
            Mapping::Polynomial => {
                let (lo_mm, hi_mm) = polynomial_region(&lens.polynomial, theta_max)?;
                let mut scale = 1.0;
                for (i, k) in lens.polynomial.iter().enumerate() {
                    p64[i] = -f64::from(*k) * scale;
                    scale *= mm_per_unit;
                }
                let p = p64.map(|c| c as f32);
                let dp = [p64[1], 2.0 * p64[2], 3.0 * p64[3], 4.0 * p64[4]].map(|c| c as f32);
                (
                    Law::Polynomial { p, dp },
                    lo_mm / mm_per_unit,
                    hi_mm / mm_per_unit,
                )
            }
        };
        let mut fisheye = Fisheye {
            law,
            p64,
            fov,
            field_of_view: fov,
            theta_max,
            r_lo,
            r_hi,
            r_lo2: (r_lo * r_lo) as f32,
            r_hi2: (r_hi * r_hi) as f32,
            half_pixel: screen::half_pixel(env),
            clip: SphericalClip::new(env),
        };
        if fisheye.theta_of(r_hi) >= std::f64::consts::PI - 1e-9 {
            fisheye.r_hi2 = fisheye.r_hi2.next_down();
        }
        let half_short = 0.5 * f64::from(window.width().min(window.height()));
        let across = 2.0
            * fisheye
                .theta_of(half_short.clamp(r_lo, r_hi))
                .max(0.0)
                .to_degrees();
        if across > 0.0 && across.is_finite() {
            fisheye.field_of_view = (across as f32).min(fov);
        }
        Ok(fisheye)
    }

    /// The mapping's angle from +Z (radians) at screen radius `r`, in f64.
    #[must_use]
    pub fn theta_of(&self, r: f64) -> f64 {
        match self.law {
            Law::Equidistant { .. } => r * self.theta_max,
            Law::Stereographic { .. } => 2.0 * (r * (0.5 * self.theta_max).tan()).atan(),
            Law::Orthographic { .. } => (r * self.theta_max.sin()).clamp(-1.0, 1.0).asin(),
            Law::Equisolid { q, .. } => 2.0 * (r * f64::from(q)).clamp(-1.0, 1.0).asin(),
            Law::Polynomial { .. } => horner(&self.p64, r),
        }
    }

    /// The screen radius of the angle `theta` from +Z (radians): the inverse of [`Fisheye::theta_of`]
    /// over the valid region, `None` outside it.
    #[must_use]
    pub fn radius_of(&self, theta: f64) -> Option<f64> {
        let (th_lo, th_hi) = (self.theta_of(self.r_lo), self.theta_of(self.r_hi));
        if !(theta >= th_lo - ANGLE_SLACK && theta <= th_hi + ANGLE_SLACK) {
            return None;
        }
        let theta = theta.clamp(th_lo, th_hi);
        let r = match self.law {
            Law::Equidistant { .. } => theta / self.theta_max,
            Law::Stereographic { .. } => (0.5 * theta).tan() / (0.5 * self.theta_max).tan(),
            Law::Orthographic { .. } => theta.sin() / self.theta_max.sin(),
            Law::Equisolid { q, .. } => (0.5 * theta).sin() / f64::from(q),
            Law::Polynomial { .. } => self.solve_polynomial(theta).0,
        };
        Some(r.clamp(self.r_lo, self.r_hi))
    }

    /// Solves `θ(r) = theta` for the polynomial on `[r_lo, r_hi]` (where it increases) by Newton's
    /// method, falling back to bisection whenever a step leaves the bracket. Returns the radius and
    /// the number of steps taken.
    fn solve_polynomial(&self, theta: f64) -> (f64, u32) {
        let p = &self.p64;
        let dp = [p[1], 2.0 * p[2], 3.0 * p[3], 4.0 * p[4]];
        let (mut lo, mut hi) = (self.r_lo, self.r_hi);
        // Seeded with the linear lens through the centre, as Cycles does.
        let mut r = if p[1] > 0.0 {
            ((theta - p[0]) / p[1]).clamp(lo, hi)
        } else {
            0.5 * (lo + hi)
        };
        let tol = 1e-13 * hi.max(1.0);
        for step in 1..=100 {
            let f = horner(p, r) - theta;
            if f == 0.0 {
                return (r, step);
            }
            if f > 0.0 {
                hi = r;
            } else {
                lo = r;
            }
            let d = horner(&dp, r);
            let mut next = if d > 0.0 { r - f / d } else { f64::NAN };
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            if (next - r).abs() <= tol || hi - lo <= tol {
                return (next, step);
            }
            r = next;
        }
        (r, 100)
    }

    /// The lane of a radial law at `s` (`r2 = |s|²`), valid inside the image circle (or ring).
    #[inline(always)]
    fn lane(&self, s: Point2, r2: f32, b: f32, cos_theta: f32, a: f32) -> CentredLane {
        CentredLane {
            valid: (r2 <= self.r_hi2) & (r2 >= self.r_lo2),
            ..radial_lane(self.half_pixel, s, r2, (b, cos_theta, a))
        }
    }

    /// `θ = h·r`; the sine and cosine by [`sin_cos`] (θ ≤ π here, where it is within 1.2e-7 of the
    /// exact values), so the batch loop vectorises.
    #[inline(always)]
    fn equidistant(&self, s: Point2, h: f32) -> CentredLane {
        let r2 = s.x * s.x + s.y * s.y;
        let r = r2.sqrt();
        let theta = h * r;
        let (sin, cos) = sin_cos(theta);
        // sin θ/r, never negative: at a 360° rim θ rounds past π.
        let b = if r > 0.0 { sin.max(0.0) / r } else { h };
        self.lane(s, r2, b, cos, h)
    }

    #[inline(always)]
    fn stereographic(&self, s: Point2, k: f32) -> CentredLane {
        let r2 = s.x * s.x + s.y * s.y;
        let t2 = k * k * r2;
        let inv = 1.0 / (1.0 + t2);
        let b = 2.0 * k * inv;
        self.lane(s, r2, b, (1.0 - t2) * inv, b)
    }

    #[inline(always)]
    fn orthographic(&self, s: Point2, m: f32, cos_floor: f32) -> CentredLane {
        let r2 = s.x * s.x + s.y * s.y;
        let cos = (1.0 - m * m * r2).max(0.0).sqrt();
        self.lane(s, r2, m, cos, m / cos.max(cos_floor))
    }

    #[inline(always)]
    fn equisolid(&self, s: Point2, q: f32, cos_floor: f32) -> CentredLane {
        let r2 = s.x * s.x + s.y * s.y;
        let sin_half2 = q * q * r2;
        let cos_half = (1.0 - sin_half2).max(0.0).sqrt();
        let b = 2.0 * q * cos_half;
        self.lane(s, r2, b, 1.0 - 2.0 * sin_half2, 2.0 * q / cos_half.max(cos_floor))
    }

    /// Cycles' polynomial; the sine and cosine of θ by [`sin_cos`], as for the equidistant law.
    #[inline(always)]
    fn polynomial(&self, s: Point2, p: &[f32; 5], dp: &[f32; 4]) -> CentredLane {
        let r2 = s.x * s.x + s.y * s.y;
        let r = r2.sqrt();
        let theta = p[0] + r * (p[1] + r * (p[2] + r * (p[3] + r * p[4])));
        let a = dp[0] + r * (dp[1] + r * (dp[2] + r * dp[3]));
        let (sin, cos) = sin_cos(theta);
        let off_centre = self.lane(s, r2, sin.max(0.0) / r, cos, a);
        // The centre of a lens with k0 ≠ 0 looks θ(0) off axis; its azimuth is taken as +X.
        let centre = CentredLane {
            direction: Vec3::new(sin, 0.0, cos),
            ..self.lane(s, r2, a, cos, a)
        };
        if r > 0.0 { off_centre } else { centre }
    }
}

/// `$map(ctx, clip, lane)` with the lane of `$fisheye`'s law: `project` and `project_soa` run the
/// same lanes into records or into arrays.
macro_rules! by_law {
    ($fisheye:ident, $map:path, $ctx:ident) => {{
        let (clip, this) = ($fisheye.clip, $fisheye);
        match this.law {
            Law::Equidistant { h } => $map(
                $ctx,
                clip,
                #[inline(always)]
                |s| this.equidistant(s, h),
            ),
            Law::Stereographic { k } => $map(
                $ctx,
                clip,
                #[inline(always)]
                |s| this.stereographic(s, k),
            ),
            Law::Orthographic { m, cos_floor } => $map(
                $ctx,
                clip,
                #[inline(always)]
                |s| this.orthographic(s, m, cos_floor),
            ),
            Law::Equisolid { q, cos_floor } => $map(
                $ctx,
                clip,
                #[inline(always)]
                |s| this.equisolid(s, q, cos_floor),
            ),
            Law::Polynomial { p, dp } => $map(
                $ctx,
                clip,
                #[inline(always)]
                |s| this.polynomial(s, &p, &dp),
            ),
        }
    }};
}

impl Projection for Fisheye {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        spherical_property(property, self.field_of_view)
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        by_law!(self, screen::map_centred_rays, ctx);
    }

    /// The rays of `project` straight into the caller's arrays ([`screen::map_centred_rays_soa`]).
    fn project_soa(&self, ctx: &mut SoaContext<'_>) -> bool {
        by_law!(self, screen::map_centred_rays_soa, ctx)
    }

    fn unproject(&self, point: Vec3, _time: f32) -> Option<Point2> {
        let (x, y, z) = finite_f64(point)?;
        let rho = x.hypot(y);
        if rho == 0.0 && z <= 0.0 {
            // The origin, or straight behind: −Z is the collapsed rim of a 360° lens at best.
            return None;
        }
        let r = self.radius_of(rho.atan2(z))?;
        if rho == 0.0 {
            return Some(Point2::new(r as f32, 0.0));
        }
        let k = r / rho;
        Some(Point2::new((x * k) as f32, (y * k) as f32))
    }
}

fn horner(c: &[f64], r: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * r + ci)
}

/// The valid interval `[r_lo, r_hi]` (mm) of Cycles' polynomial `θ = −(k0 + k1·r + …)`: where `θ`
/// increases from the centre and lies in `[0, theta_max]`.
fn polynomial_region(k: &[f32; 5], theta_max: f64) -> Result<(f64, f64), PluginError> {
    let t: Vec<f64> = k.iter().map(|&c| -f64::from(c)).collect();
    let dt = [t[1], 2.0 * t[2], 3.0 * t[3], 4.0 * t[4]];
    let shown = || format!("[{}, {}, {}, {}, {}]", k[0], k[1], k[2], k[3], k[4]);
    match dt.iter().find(|&&c| c != 0.0) {
        None => {
            return Err(invalid(format!(
                "parameter \"polynomial\" = {}: k1..k4 are all zero, so every ray has the same angle",
                shown()
            )));
        }
        Some(&c) if c < 0.0 => {
            return Err(invalid(format!(
                "parameter \"polynomial\" = {}: θ = −(k0 + k1·r + … + k4·r⁴) must increase from the sensor \
                 centre (expected k1 < 0, or the first non-zero of k1..k4 negative)",
                shown()
            )));
        }
        Some(_) => {}
    }
    // θ increases on [0, r_mono): r_mono is the first sign change of dθ/dr.
    let r_mono = sign_change_roots(&dt, 0.0, cauchy_bound(&dt))
        .first()
        .copied()
        .unwrap_or(f64::INFINITY);
    let theta_at = |r: f64| horner(&t, r);
    if t[0] > theta_max {
        return Err(invalid(format!(
            "parameter \"polynomial\" = {}: the centre is already {:.3}° off axis, beyond fov/2",
            shown(),
            t[0].to_degrees()
        )));
    }
    let upper = |c0: f64| {
        let mut shifted = t.clone();
        shifted[0] = c0;
        if r_mono.is_finite() {
            r_mono
        } else {
            cauchy_bound(&shifted)
        }
    };
    let r_lo = if t[0] >= 0.0 {
        0.0
    } else {
        let reach = r_mono.is_infinite() || theta_at(r_mono) > 0.0;
        let root = reach
            .then(|| sign_change_roots(&t, 0.0, upper(t[0])).first().copied())
            .flatten();
        root.ok_or_else(|| {
            invalid(format!(
                "parameter \"polynomial\" = {}: θ never reaches 0 while it increases, so no ray is in front of \
                 the lens",
                shown()
            ))
        })?
    };
    let r_hi = if r_mono.is_finite() && theta_at(r_mono) <= theta_max {
        r_mono
    } else {
        let mut shifted = t.clone();
        shifted[0] -= theta_max;
        sign_change_roots(&shifted, r_lo, upper(shifted[0]))
            .first()
            .copied()
            .unwrap_or(r_mono)
    };
    if r_hi.is_nan() || r_hi <= r_lo || !r_hi.is_finite() {
        return Err(invalid(format!(
            "parameter \"polynomial\" = {}: no radius of the sensor has 0 ≤ θ ≤ fov/2 while θ increases",
            shown()
        )));
    }
    Ok((r_lo, r_hi))
}

/// An upper bound on the magnitude of every root of the polynomial `c` (Cauchy's bound), plus one.
fn cauchy_bound(c: &[f64]) -> f64 {
    let n = c.iter().rposition(|&x| x != 0.0).unwrap_or(0);
    if n == 0 {
        return 1.0;
    }
    let lead = c[n].abs();
    2.0 + c[..n].iter().map(|x| x.abs() / lead).fold(0.0, f64::max)
}

/// The roots of the polynomial `c` in `(a, b)` at which it changes sign, ascending. Exact up to
/// bisection to the last bit: the interval is split at the derivative's sign changes (found the same
/// way), so each piece is monotone and holds at most one root.
fn sign_change_roots(c: &[f64], a: f64, b: f64) -> Vec<f64> {
    let n = c.iter().rposition(|&x| x != 0.0).unwrap_or(0);
    if n == 0 || a.is_nan() || b <= a {
        return Vec::new();
    }
    let deriv: Vec<f64> = (1..=n).map(|i| i as f64 * c[i]).collect();
    let mut cuts = vec![a];
    cuts.extend(sign_change_roots(&deriv, a, b));
    cuts.push(b);
    let mut roots = Vec::new();
    for w in cuts.windows(2) {
        let (mut lo, mut hi) = (w[0], w[1]);
        let (flo, fhi) = (horner(c, lo), horner(c, hi));
        if !((flo < 0.0 && fhi > 0.0) || (flo > 0.0 && fhi < 0.0)) {
            continue;
        }
        let rising = fhi > 0.0;
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if (horner(c, mid) > 0.0) == rising {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        roots.push(0.5 * (lo + hi));
    }
    roots
}

#[cfg(test)]
mod tests;
