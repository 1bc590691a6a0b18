//! The aperture warp: canonical lens samples `u ∈ [0, 1)²` → aperture samples in `[−1, 1]²`.
//!
//! A projection that does depth of field scales the aperture sample by its lens radius, so the shape and
//! brightness profile of the bokeh is decided here, from the camera parameters `apertureNSides` (N),
//! `apertureAngle` (α, degrees), `apertureRoundness` (ρ), `apertureDensity` (d) and `dofaspect` (A).
//! RenderMan describes the parameters but not the warp; this module is Obscura's documented model.
//!
//! # Shape
//!
//! The aperture boundary in polar coordinates is `R(φ)` with unit circumradius.
//!
//! - N < 3: the unit disk, `R(φ) = 1`.
//! - N ≥ 3: a regular N-gon with a vertex at angle α (α = 0 puts a vertex on +X; positive α turns the
//!   shape counter-clockwise). With the angle measured from a vertex, `θ = (φ − α) mod (2π/N)`, the
//!   straight polygon edge lies at `e(φ) = cos(π/N) / cos(θ − π/N)`. Roundness reshapes it:
//!   - ρ ≥ 0: `R = e + ρ·(1 − e)` (ρ = 0 the straight polygon, ρ = 1 the unit circle);
//!   - ρ < 0: `R = e^(1 + 2|ρ|)` (the sides bow inward while the vertices stay at radius 1; ρ = −1 is a
//!     star whose edge midpoints sit at `cos³(π/N)`).
//!
//! # Sampling (uniform in area, stratification preserved)
//!
//! The map is monotone in each coordinate, so stratified lens samples stay stratified:
//!
//! - `u.x → φ`: the inverse CDF of the angular density `p(φ) ∝ R(φ)²` (the area of a thin wedge). For
//!   the disk this is exactly `φ = α + 2π·u.x`. For a polygon, `k = ⌊N·u.x⌋` picks the sector between
//!   vertex k and k + 1 and `w = N·u.x − k` is inverted through a table of the cumulative
//!   `∫₀^θ R² dθ'` over one sector (a [`Distribution1D`] of 2048 cells, Simpson's rule per cell, linear
//!   interpolation within a cell): `φ = α + 2πk/N + θ(w)`.
//! - `u.y → q ∈ [0, 1]`, the fraction of the wedge's area inside radius r, then `r = R(φ)·√q`.
//!
//! # Density
//!
//! `apertureDensity` d reweights the area fraction with the linear ramp `pdf(q) = 1 + d·(2q − 1)` on
//! `[0, 1]`: d = 0 uniform, d = +1 a bright rim (`pdf = 2q`, "bad bokeh"), d = −1 a bright centre
//! (`pdf = 2 − 2q`, "good bokeh"). Its CDF `F(q) = q + d·(q² − q)` is inverted in closed form with the
//! cancellation-free root of the quadratic `d·q² + (1 − d)·q − ξ = 0`:
//!
//! `q = 2ξ / ((1 − d) + √((1 − d)² + 4dξ))`, and `q = ξ` when `|d| < 10⁻¹²`.
//!
//! With a uniform angle this gives `E[(r/R)²] = E[q] = 1/2 + d/6`.
//!
//! # Anamorphic aspect
//!
//! `dofaspect` A > 0 stretches the shape into an ellipse of confusion that stays inside `[−1, 1]²`:
//! A ≥ 1: `y ← y / A` (wider than tall); A < 1: `x ← x·A` (taller than wide).
//!
//! The result is computed in `f64`, rounded to `f32` and clamped to `[−1, 1]²`, so it is always finite
//! and inside the square; inputs outside `[0, 1)` are clamped to `[0, 1]` first (NaN reads as 0).

use obscura_sdk::Point2;
use std::f64::consts::{PI, TAU};
use std::fmt;

use crate::distribution::Distribution1D;

/// Cells of the per-sector angular CDF table.
const SECTOR_CELLS: usize = 2048;

/// Below this |density| the area-fraction warp is the identity `q = ξ`.
const DENSITY_EPSILON: f64 = 1e-12;

/// The camera's aperture description, in RenderMan's parameter terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ApertureDesc {
    /// `apertureNSides`: the number of blades; fewer than 3 means a circular aperture.
    pub n_sides: i32,
    /// `apertureAngle`: counter-clockwise rotation of the polygon in degrees (0 puts a vertex on +X).
    pub angle_deg: f32,
    /// `apertureRoundness` in `[−1, 1]`: 0 straight sides, 1 a circle, below 0 sides bowed inward.
    pub roundness: f32,
    /// `apertureDensity` in `[−1, 1]`: 0 uniform, +1 bright rim, −1 bright centre.
    pub density: f32,
    /// `dofaspect` > 0: the aspect of the ellipse of confusion, > 1 wider horizontally.
    pub dof_aspect: f32,
}

impl Default for ApertureDesc {
    /// RenderMan's defaults: `apertureNSides 0`, `apertureAngle 0`, `apertureRoundness 1`,
    /// `apertureDensity 0`, `dofaspect 1` (a uniformly lit circular aperture).
    fn default() -> Self {
        ApertureDesc {
            n_sides: 0,
            angle_deg: 0.0,
            roundness: 1.0,
            density: 0.0,
            dof_aspect: 1.0,
        }
    }
}

/// An [`ApertureDesc`] that [`ApertureWarp::new`] rejects; the message names the RenderMan parameter.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ApertureError {
    /// `apertureAngle` was NaN or infinite.
    #[error("apertureAngle must be a finite angle in degrees, got {value}")]
    Angle {
        /// The rejected value.
        value: f32,
    },
    /// `apertureRoundness` was outside `[−1, 1]` or NaN.
    #[error("apertureRoundness must be in [-1, 1], got {value}")]
    Roundness {
        /// The rejected value.
        value: f32,
    },
    /// `apertureDensity` was outside `[−1, 1]` or NaN.
    #[error("apertureDensity must be in [-1, 1], got {value}")]
    Density {
        /// The rejected value.
        value: f32,
    },
    /// `dofaspect` was not a finite number greater than 0.
    #[error("dofaspect must be a finite number > 0, got {value}")]
    DofAspect {
        /// The rejected value.
        value: f32,
    },
}

/// A validated aperture description with its sampling table precomputed; maps lens samples to
/// aperture samples (see the [module documentation](self) for the formulas).
///
/// Immutable after [`ApertureWarp::new`], so one warp may be shared by every rendering thread.
#[derive(Clone)]
pub struct ApertureWarp {
    /// Number of polygon sides, or 0 for the disk (including roundness 1).
    sides: u32,
    /// Rotation in radians, in `[0, 2π)`.
    angle: f64,
    /// Roundness ρ in `[−1, 1]`.
    roundness: f64,
    /// Density d in `[−1, 1]`.
    density: f64,
    /// `dofaspect` A > 0.
    aspect: f64,
    /// `2π/N`, the angle of one sector (polygon only).
    sector: f64,
    /// `cos(π/N)`, the inradius of the straight polygon (polygon only).
    cos_half: f64,
    /// The distribution of `∫ R² dθ` over one sector's `SECTOR_CELLS` equal cells of angle; `None` for
    /// the disk.
    sector_table: Option<Distribution1D>,
}

impl fmt::Debug for ApertureWarp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ApertureWarp")
            .field("sides", &self.sides)
            .field("angle", &self.angle)
            .field("roundness", &self.roundness)
            .field("density", &self.density)
            .field("aspect", &self.aspect)
            .finish_non_exhaustive()
    }
}

impl ApertureWarp {
    /// Validates `desc` and precomputes the angular sampling table.
    ///
    /// # Errors
    /// When `apertureAngle` is not finite, `apertureRoundness` or `apertureDensity` is outside
    /// `[−1, 1]` (or NaN), or `dofaspect` is not a finite number > 0. Any `apertureNSides` is accepted.
    pub fn new(desc: &ApertureDesc) -> Result<Self, ApertureError> {
        if !desc.angle_deg.is_finite() {
            return Err(ApertureError::Angle {
                value: desc.angle_deg,
            });
        }
        if !(-1.0..=1.0).contains(&desc.roundness) {
            return Err(ApertureError::Roundness {
                value: desc.roundness,
            });
        }
        if !(-1.0..=1.0).contains(&desc.density) {
            return Err(ApertureError::Density { value: desc.density });
        }
        if !(desc.dof_aspect.is_finite() && desc.dof_aspect > 0.0) {
            return Err(ApertureError::DofAspect {
                value: desc.dof_aspect,
            });
        }
        let disk = desc.n_sides < 3 || desc.roundness == 1.0;
        let sides = if disk { 0 } else { desc.n_sides.unsigned_abs() };
        let mut warp = ApertureWarp {
            sides,
            angle: f64::from(desc.angle_deg).rem_euclid(360.0).to_radians(),
            roundness: f64::from(desc.roundness),
            density: f64::from(desc.density),
            aspect: f64::from(desc.dof_aspect),
            sector: 0.0,
            cos_half: 1.0,
            sector_table: None,
        };
        if !disk {
            let n = f64::from(sides);
            warp.sector = TAU / n;
            warp.cos_half = (PI / n).cos();
            warp.sector_table = Some(warp.build_sector_table());
        }
        Ok(warp)
    }

    /// Whether the aperture is the unit disk: fewer than 3 sides, or roundness exactly 1.
    #[inline]
    #[must_use]
    pub fn is_disk(&self) -> bool {
        self.sides == 0
    }

    /// The radius `R(φ)` of the aperture boundary in direction `phi` (radians, counter-clockwise from
    /// +X), before `dofaspect` is applied. 1 for the disk; NaN when `phi` is not finite.
    #[must_use]
    pub fn boundary_radius(&self, phi: f32) -> f32 {
        if !phi.is_finite() {
            return f32::NAN;
        }
        if self.is_disk() {
            return 1.0;
        }
        let theta = (f64::from(phi) - self.angle).rem_euclid(self.sector);
        self.radius_in_sector(theta) as f32
    }

    /// Warps one lens sample `u ∈ [0, 1)²` to an aperture sample in `[−1, 1]²`.
    #[must_use]
    pub fn warp(&self, u: Point2) -> Point2 {
        let ux = unit_interval(u.x);
        let uy = unit_interval(u.y);
        let (phi, boundary) = if self.is_disk() {
            (self.angle + TAU * ux, 1.0)
        } else {
            let n = f64::from(self.sides);
            let scaled = ux * n;
            let k = scaled.floor().clamp(0.0, n - 1.0);
            let theta = self.sector_angle((scaled - k).clamp(0.0, 1.0));
            (self.angle + k * self.sector + theta, self.radius_in_sector(theta))
        };
        let r = boundary * self.area_fraction(uy).sqrt();
        let (sin, cos) = phi.sin_cos();
        let (mut x, mut y) = (r * cos, r * sin);
        if self.aspect >= 1.0 {
            y /= self.aspect;
        } else {
            x *= self.aspect;
        }
        Point2::new((x as f32).clamp(-1.0, 1.0), (y as f32).clamp(-1.0, 1.0))
    }

    /// Warps `lens[i]` into `out[i]`; when the lengths differ only the common prefix is written.
    pub fn warp_batch(&self, lens: &[Point2], out: &mut [Point2]) {
        for (o, &u) in out.iter_mut().zip(lens) {
            *o = self.warp(u);
        }
    }

    /// `R(θ)` for `θ ∈ [0, 2π/N]` measured from a vertex (polygon only).
    fn radius_in_sector(&self, theta: f64) -> f64 {
        let half = 0.5 * self.sector;
        let edge = (self.cos_half / (theta - half).cos()).clamp(self.cos_half, 1.0);
        if self.roundness >= 0.0 {
            edge + self.roundness * (1.0 - edge)
        } else {
            edge.powf(1.0 - 2.0 * self.roundness)
        }
    }

    /// The distribution of `∫₀^θ R² dθ'` over one sector: each cell's Simpson integral times
    /// `SECTOR_CELLS` as its weight (a power of two, so the table's running sums are the cells'
    /// integrals bit for bit).
    fn build_sector_table(&self) -> Distribution1D {
        let h = self.sector / SECTOR_CELLS as f64;
        let density = |theta: f64| {
            let r = self.radius_in_sector(theta);
            r * r
        };
        let mut weights = Vec::with_capacity(SECTOR_CELLS);
        let mut lo = density(0.0);
        for j in 0..SECTOR_CELLS {
            let t0 = j as f64 * h;
            let mid = density(t0 + 0.5 * h);
            let hi = density(t0 + h);
            weights.push(h / 6.0 * (lo + 4.0 * mid + hi) * SECTOR_CELLS as f64);
            lo = hi;
        }
        // R ≥ cos³(π/3) > 0, so every weight is positive and finite.
        Distribution1D::new(weights).expect("R² > 0 on the whole sector")
    }

    /// The angle `θ ∈ [0, 2π/N]` from the sector's first vertex whose cumulative mass is `w ∈ [0, 1]`
    /// (0 for the disk, which has no sectors).
    fn sector_angle(&self, w: f64) -> f64 {
        self.sector_table
            .as_ref()
            .map_or(0.0, |table| table.sample_continuous(w).0 * self.sector)
    }

    /// The area fraction `q = F⁻¹(ξ)` for the density ramp `pdf(q) = 1 + d·(2q − 1)`.
    fn area_fraction(&self, xi: f64) -> f64 {
        let d = self.density;
        if d.abs() < DENSITY_EPSILON {
            return xi;
        }
        let b = 1.0 - d;
        let denominator = b + (b * b + 4.0 * d * xi).max(0.0).sqrt();
        if denominator > 0.0 {
            (2.0 * xi / denominator).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// A sample coordinate clamped to `[0, 1]`, NaN read as 0.
#[inline]
fn unit_interval(v: f32) -> f64 {
    if v.is_nan() {
        0.0
    } else {
        f64::from(v.clamp(0.0, 1.0))
    }
}

#[cfg(test)]
mod tests;
