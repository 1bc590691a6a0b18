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
mod tests {
    use super::*;
    use crate::distribution::test_samples::Rng;
    use proptest::prelude::*;

    fn random_points(n: usize, seed: u64) -> Vec<Point2> {
        let mut rng = Rng(seed);
        (0..n)
            .map(|_| Point2::new(rng.next_f32(), rng.next_f32()))
            .collect()
    }

    /// Cell-centred stratified samples on a `k × k` grid.
    fn grid_points(k: usize) -> Vec<Point2> {
        let mut v = Vec::with_capacity(k * k);
        for i in 0..k {
            for j in 0..k {
                v.push(Point2::new(
                    (i as f32 + 0.5) / k as f32,
                    (j as f32 + 0.5) / k as f32,
                ));
            }
        }
        v
    }

    fn desc(n_sides: i32, angle_deg: f32, roundness: f32, density: f32) -> ApertureDesc {
        ApertureDesc {
            n_sides,
            angle_deg,
            roundness,
            density,
            dof_aspect: 1.0,
        }
    }

    fn warp_all(w: &ApertureWarp, u: &[Point2]) -> Vec<Point2> {
        let mut out = vec![Point2::ZERO; u.len()];
        w.warp_batch(u, &mut out);
        out
    }

    /// Vertices of the regular N-gon of circumradius 1 rotated by `angle_deg`, counter-clockwise.
    fn polygon_vertices(n: i32, angle_deg: f64) -> Vec<(f64, f64)> {
        (0..n)
            .map(|k| {
                let a = angle_deg.to_radians() + 2.0 * PI * f64::from(k) / f64::from(n);
                (a.cos(), a.sin())
            })
            .collect()
    }

    /// Signed distance-like margin of `p` inside a counter-clockwise convex polygon: the minimum over
    /// edges of the cross product `(v₁ − v₀) × (p − v₀)` divided by the edge length (≥ 0 inside).
    fn inside_margin(verts: &[(f64, f64)], p: Point2) -> f64 {
        let (px, py) = (f64::from(p.x), f64::from(p.y));
        let mut m = f64::INFINITY;
        for i in 0..verts.len() {
            let (x0, y0) = verts[i];
            let (x1, y1) = verts[(i + 1) % verts.len()];
            let (ex, ey) = (x1 - x0, y1 - y0);
            let cross = ex * (py - y0) - ey * (px - x0);
            m = m.min(cross / ex.hypot(ey));
        }
        m
    }

    fn radius(p: Point2) -> f64 {
        f64::from(p.x).hypot(f64::from(p.y))
    }

    fn angle_of(p: Point2) -> f64 {
        f64::from(p.y).atan2(f64::from(p.x)).rem_euclid(TAU)
    }

    /// The chi-square statistic of observed counts against expected counts.
    fn chi_square(observed: &[usize], expected: &[f64]) -> f64 {
        observed
            .iter()
            .zip(expected)
            .map(|(&o, &e)| (o as f64 - e).powi(2) / e)
            .sum()
    }

    /// The upper `p = 0.001` critical value of chi-square with `k` degrees of freedom
    /// (Wilson–Hilferty approximation, z = 3.09).
    fn chi_square_critical_001(k: usize) -> f64 {
        let k = k as f64;
        let c = 2.0 / (9.0 * k);
        k * (1.0 - c + 3.09 * c.sqrt()).powi(3)
    }

    #[test]
    fn default_desc_is_renderman_default() {
        let d = ApertureDesc::default();
        assert_eq!(
            d,
            ApertureDesc {
                n_sides: 0,
                angle_deg: 0.0,
                roundness: 1.0,
                density: 0.0,
                dof_aspect: 1.0
            }
        );
        let w = ApertureWarp::new(&d).expect("default is valid");
        assert!(w.is_disk());
    }

    #[test]
    fn is_disk_for_few_sides_or_full_roundness() {
        for n in [-4, 0, 1, 2] {
            assert!(
                ApertureWarp::new(&desc(n, 10.0, 0.0, 0.0))
                    .expect("valid")
                    .is_disk(),
                "n = {n}"
            );
        }
        assert!(
            ApertureWarp::new(&desc(6, 0.0, 1.0, 0.0))
                .expect("valid")
                .is_disk()
        );
        assert!(
            !ApertureWarp::new(&desc(6, 0.0, 0.999, 0.0))
                .expect("valid")
                .is_disk()
        );
        assert!(
            !ApertureWarp::new(&desc(3, 0.0, -1.0, 0.0))
                .expect("valid")
                .is_disk()
        );
    }

    #[test]
    fn polygon_samples_stay_inside_rotated_ngon() {
        let mut u = grid_points(150);
        u.extend(random_points(20_000, 7));
        for n in [3, 5, 6, 8] {
            for angle in [0.0f32, 17.5, 36.0, -100.0] {
                let w = ApertureWarp::new(&desc(n, angle, 0.0, 0.0)).expect("valid");
                let verts = polygon_vertices(n, f64::from(angle));
                let out = warp_all(&w, &u);
                let worst = out
                    .iter()
                    .map(|&p| inside_margin(&verts, p))
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    worst > -1e-6,
                    "N = {n}, angle = {angle}: a sample is {worst} outside"
                );
                // The samples also fill the polygon: some land within 0.03 of every vertex.
                for &(vx, vy) in &verts {
                    let nearest = out
                        .iter()
                        .map(|p| (f64::from(p.x) - vx).hypot(f64::from(p.y) - vy))
                        .fold(f64::INFINITY, f64::min);
                    assert!(
                        nearest < 0.03,
                        "N = {n}, angle = {angle}: vertex ({vx}, {vy}) unreached"
                    );
                }
            }
        }
    }

    #[test]
    fn polygon_density_is_uniform_in_area() {
        // Chi-square over the square cells of a 12 × 12 grid that lie wholly inside the hexagon, plus
        // one bin for everything else; expected counts from the cell area over the polygon's area.
        let n = 6;
        let verts = polygon_vertices(n, 10.0);
        let poly_area = 0.5 * f64::from(n) * (2.0 * PI / f64::from(n)).sin();
        let w = ApertureWarp::new(&desc(n, 10.0, 0.0, 0.0)).expect("valid");
        let samples = 200_000;
        let out = warp_all(&w, &random_points(samples, 11));
        let g = 12;
        let cell = 2.0 / g as f64;
        let mut index = vec![None; g * g];
        let mut expected = Vec::new();
        for iy in 0..g {
            for ix in 0..g {
                let (x0, y0) = (-1.0 + ix as f64 * cell, -1.0 + iy as f64 * cell);
                let corners = [(x0, y0), (x0 + cell, y0), (x0, y0 + cell), (x0 + cell, y0 + cell)];
                if corners
                    .iter()
                    .all(|&(x, y)| inside_margin(&verts, Point2::new(x as f32, y as f32)) > 1e-6)
                {
                    index[iy * g + ix] = Some(expected.len());
                    expected.push(samples as f64 * cell * cell / poly_area);
                }
            }
        }
        let rest = samples as f64 - expected.iter().sum::<f64>();
        let rest_bin = expected.len();
        expected.push(rest);
        let mut observed = vec![0usize; expected.len()];
        for p in &out {
            let ix = (((f64::from(p.x) + 1.0) / cell).floor() as usize).min(g - 1);
            let iy = (((f64::from(p.y) + 1.0) / cell).floor() as usize).min(g - 1);
            observed[index[iy * g + ix].unwrap_or(rest_bin)] += 1;
        }
        assert!(expected.len() > 40, "too few interior cells: {}", expected.len());
        let chi2 = chi_square(&observed, &expected);
        let critical = chi_square_critical_001(expected.len() - 1);
        assert!(chi2 < critical, "chi2 = {chi2} >= {critical}");
    }

    #[test]
    fn rotation_by_36_degrees_moves_a_vertex_to_36_degrees() {
        let w0 = ApertureWarp::new(&desc(5, 0.0, 0.0, 0.0)).expect("valid");
        let w36 = ApertureWarp::new(&desc(5, 36.0, 0.0, 0.0)).expect("valid");
        let deg = |d: f64| (d.to_radians()) as f32;
        let cos36 = 36f64.to_radians().cos();
        assert!((w0.boundary_radius(0.0) - 1.0).abs() < 1e-6);
        assert!((f64::from(w0.boundary_radius(deg(36.0))) - cos36).abs() < 1e-6);
        assert!((w36.boundary_radius(deg(36.0)) - 1.0).abs() < 1e-6);
        assert!((f64::from(w36.boundary_radius(0.0)) - cos36).abs() < 1e-6);
        // The samples agree: near 36° they reach radius ≈ 1, near 0° only the edge midpoint cos 36°.
        // (Random, not a grid: the angle depends on u.x alone, so a grid has few distinct angles.)
        let out = warp_all(&w36, &random_points(200_000, 36));
        let max_r_near = |target_deg: f64| {
            out.iter()
                .filter(|p| {
                    let diff = (angle_of(**p) - target_deg.to_radians() + PI).rem_euclid(TAU) - PI;
                    diff.abs() < 0.5f64.to_radians()
                })
                .map(|&p| radius(p))
                .fold(0.0, f64::max)
        };
        assert!(max_r_near(36.0) > 0.98, "{}", max_r_near(36.0));
        assert!(max_r_near(108.0) > 0.98, "{}", max_r_near(108.0));
        let r0 = max_r_near(0.0);
        assert!(r0 < cos36 + 0.01 && r0 > cos36 - 0.03, "{r0} vs {cos36}");
    }

    #[test]
    fn roundness_one_gives_the_unit_disk() {
        for n in [0, 5, 6] {
            let w = ApertureWarp::new(&desc(n, 20.0, 1.0, 0.0)).expect("valid");
            for k in 0..360 {
                assert_eq!(w.boundary_radius((k as f32).to_radians()), 1.0);
            }
            let out = warp_all(&w, &grid_points(300));
            let mut max_in_sector = [0.0f64; 36];
            for &p in &out {
                let r = radius(p);
                assert!(r <= 1.0 + 1e-6, "radius {r}");
                let s = ((angle_of(p) / TAU * 36.0) as usize).min(35);
                max_in_sector[s] = max_in_sector[s].max(r);
            }
            for (s, &m) in max_in_sector.iter().enumerate() {
                assert!(m > 0.99, "N = {n}: sector {s} reaches only {m}");
            }
        }
    }

    #[test]
    fn roundness_between_zero_and_one_interpolates_edge_and_circle() {
        let n = 6;
        let w = ApertureWarp::new(&desc(n, 0.0, 0.25, 0.0)).expect("valid");
        let mid = (PI / f64::from(n)).cos();
        let expected = mid + 0.25 * (1.0 - mid);
        assert!((f64::from(w.boundary_radius((PI / 6.0) as f32)) - expected).abs() < 1e-6);
        assert!((w.boundary_radius(0.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn negative_roundness_bows_the_sides_inward() {
        for n in 3..=8 {
            let half = PI / f64::from(n);
            for (rho, power) in [(-1.0f32, 3), (-0.5, 2)] {
                let w = ApertureWarp::new(&desc(n, 15.0, rho, 0.0)).expect("valid");
                let offset = 15f64.to_radians();
                let at_mid = f64::from(w.boundary_radius((offset + half) as f32));
                assert!(
                    (at_mid - half.cos().powi(power)).abs() < 1e-5,
                    "N = {n}, rho = {rho}: {at_mid}"
                );
                let at_vertex = f64::from(w.boundary_radius((offset + 2.0 * half) as f32));
                assert!(
                    (at_vertex - 1.0).abs() < 1e-5,
                    "N = {n}: vertex radius {at_vertex}"
                );
            }
            // Star samples stay within the star: at the edge midpoint directions nothing passes cos³.
            let w = ApertureWarp::new(&desc(n, 0.0, -1.0, 0.0)).expect("valid");
            for p in warp_all(&w, &grid_points(120)) {
                let theta = angle_of(p).rem_euclid(2.0 * half);
                let edge = half.cos() / (theta - half).cos();
                assert!(
                    radius(p) <= edge.powi(3) + 1e-5,
                    "N = {n}: {p:?} outside the star"
                );
            }
        }
    }

    #[test]
    fn uniform_disk_passes_chi_square_over_rings_and_sectors() {
        let w = ApertureWarp::new(&ApertureDesc::default()).expect("valid");
        let samples = 200_000;
        let (rings, sectors) = (10, 8);
        let mut observed = vec![0usize; rings * sectors];
        for p in warp_all(&w, &random_points(samples, 3)) {
            // Equal-area rings: r² in [k/10, (k+1)/10).
            let ring = ((radius(p).powi(2) * rings as f64) as usize).min(rings - 1);
            let sector = ((angle_of(p) / TAU * sectors as f64) as usize).min(sectors - 1);
            observed[ring * sectors + sector] += 1;
        }
        let expected = vec![samples as f64 / (rings * sectors) as f64; rings * sectors];
        let chi2 = chi_square(&observed, &expected);
        let critical = chi_square_critical_001(rings * sectors - 1);
        assert!(chi2 < critical, "chi2 = {chi2} >= {critical}");
    }

    #[test]
    fn chi_square_detects_a_non_uniform_disk() {
        // Power check of the statistic above: bright-rim samples must fail the uniform hypothesis.
        let w = ApertureWarp::new(&desc(0, 0.0, 1.0, 0.3)).expect("valid");
        let samples = 200_000;
        let mut observed = vec![0usize; 10];
        for p in warp_all(&w, &random_points(samples, 3)) {
            observed[((radius(p).powi(2) * 10.0) as usize).min(9)] += 1;
        }
        let chi2 = chi_square(&observed, &[samples as f64 / 10.0; 10]);
        assert!(chi2 > chi_square_critical_001(9), "chi2 = {chi2}");
    }

    #[test]
    fn density_ramp_matches_its_ring_probabilities() {
        // For the disk r² = q, so ring k of r² ∈ [k/10, (k+1)/10) has probability F(q₁) − F(q₀) with
        // F(q) = q + d·(q² − q).
        for d in [-1.0f32, -0.4, 0.7, 1.0] {
            let w = ApertureWarp::new(&desc(0, 0.0, 1.0, d)).expect("valid");
            let samples = 100_000;
            let mut observed = vec![0usize; 10];
            for p in warp_all(&w, &random_points(samples, 5)) {
                observed[((radius(p).powi(2) * 10.0) as usize).min(9)] += 1;
            }
            let cdf = |q: f64| q + f64::from(d) * (q * q - q);
            let expected: Vec<f64> = (0..10)
                .map(|k| samples as f64 * (cdf((k + 1) as f64 / 10.0) - cdf(k as f64 / 10.0)))
                .collect();
            let chi2 = chi_square(&observed, &expected);
            assert!(chi2 < chi_square_critical_001(9), "d = {d}: chi2 = {chi2}");
        }
    }

    #[test]
    fn density_sets_the_mean_squared_radius() {
        // E[r²] = 1/2 + d/6 on the disk: 2/3 for a bright rim, 1/3 for a bright centre.
        for (d, expected) in [
            (1.0f32, 2.0 / 3.0),
            (-1.0, 1.0 / 3.0),
            (0.0, 0.5),
            (0.5, 0.5 + 0.5 / 6.0),
            (1e-13, 0.5),
        ] {
            let w = ApertureWarp::new(&desc(0, 0.0, 1.0, d)).expect("valid");
            let out = warp_all(&w, &grid_points(400));
            let mean = out.iter().map(|&p| radius(p).powi(2)).sum::<f64>() / out.len() as f64;
            assert!(
                (mean - expected).abs() < 1e-3,
                "d = {d}: mean r² = {mean}, expected {expected}"
            );
        }
        // On a polygon the same holds for the radius relative to the boundary.
        let w = ApertureWarp::new(&desc(5, 12.0, 0.0, 1.0)).expect("valid");
        let out = warp_all(&w, &grid_points(400));
        let mean = out
            .iter()
            .map(|&p| (radius(p) / f64::from(w.boundary_radius(angle_of(p) as f32))).powi(2))
            .sum::<f64>()
            / out.len() as f64;
        assert!((mean - 2.0 / 3.0).abs() < 2e-3, "polygon mean (r/R)² = {mean}");
    }

    #[test]
    fn dof_aspect_squeezes_the_short_axis() {
        let u = grid_points(300);
        let extent = |aspect: f32| {
            let w = ApertureWarp::new(&ApertureDesc {
                dof_aspect: aspect,
                ..ApertureDesc::default()
            })
            .expect("valid");
            let out = warp_all(&w, &u);
            let mx = out.iter().map(|p| p.x.abs()).fold(0.0f32, f32::max);
            let my = out.iter().map(|p| p.y.abs()).fold(0.0f32, f32::max);
            (mx, my)
        };
        let (mx, my) = extent(2.0);
        assert!(mx > 0.99 && mx <= 1.0, "max |x| = {mx}");
        assert!(my > 0.49 && my <= 0.5 + 1e-6, "max |y| = {my}");
        let (mx, my) = extent(0.5);
        assert!(mx > 0.49 && mx <= 0.5 + 1e-6, "max |x| = {mx}");
        assert!(my > 0.99 && my <= 1.0, "max |y| = {my}");
    }

    #[test]
    fn warp_is_monotone_in_each_coordinate() {
        // Stratification is preserved: the angle grows with u.x and the radius with u.y.
        for d in [
            desc(0, 0.0, 1.0, 0.0),
            desc(5, 30.0, 0.0, 0.5),
            desc(7, 0.0, -0.8, -1.0),
        ] {
            let w = ApertureWarp::new(&d).expect("valid");
            let steps = 2000;
            let start = angle_of(w.warp(Point2::new(0.0, 0.9)));
            let mut last = 0.0;
            for i in 1..steps {
                let p = w.warp(Point2::new(i as f32 / steps as f32, 0.9));
                let turned = (angle_of(p) - start).rem_euclid(TAU);
                assert!(
                    turned >= last - 1e-6,
                    "{d:?}: angle went back at u.x = {i}/{steps}"
                );
                last = turned;
            }
            let mut last_r = -1.0;
            for i in 0..steps {
                let r = radius(w.warp(Point2::new(0.3, i as f32 / steps as f32)));
                assert!(r >= last_r - 1e-7, "{d:?}: radius went back at u.y = {i}/{steps}");
                last_r = r;
            }
        }
    }

    #[test]
    fn warp_batch_matches_warp_and_tolerates_length_mismatch() {
        let w = ApertureWarp::new(&desc(6, 5.0, 0.3, -0.2)).expect("valid");
        let u = random_points(100, 9);
        let mut out = vec![Point2::new(9.0, 9.0); 60];
        w.warp_batch(&u, &mut out);
        for (o, &x) in out.iter().zip(&u) {
            assert_eq!(*o, w.warp(x));
        }
        let mut long = vec![Point2::new(9.0, 9.0); 120];
        w.warp_batch(&u, &mut long);
        assert_eq!(long[99], w.warp(u[99]));
        assert_eq!(long[100], Point2::new(9.0, 9.0));
    }

    #[test]
    fn extreme_inputs_stay_finite_and_inside_the_square() {
        let inputs = [
            0.0f32,
            -0.0,
            1.0 - f32::EPSILON / 2.0,
            1.0,
            -3.0,
            7.0,
            f32::NAN,
            f32::INFINITY,
            f32::MIN,
        ];
        for d in [
            ApertureDesc::default(),
            desc(i32::MAX, 1e20, 0.0, 1.0),
            desc(i32::MIN, -1e20, -1.0, -1.0),
            desc(3, 0.0, -1.0, 1.0),
            ApertureDesc {
                dof_aspect: 1e-30,
                ..desc(4, 45.0, 0.0, 0.0)
            },
            ApertureDesc {
                dof_aspect: 3e38,
                ..desc(4, 45.0, 0.0, 0.0)
            },
        ] {
            let w = ApertureWarp::new(&d).expect("valid");
            for &x in &inputs {
                for &y in &inputs {
                    let p = w.warp(Point2::new(x, y));
                    assert!(p.x.is_finite() && p.y.is_finite() && p.x.abs() <= 1.0 && p.y.abs() <= 1.0);
                }
            }
        }
    }

    #[test]
    fn invalid_descs_name_the_parameter() {
        let cases: [(ApertureDesc, &str, &str); 11] = [
            (desc(5, f32::NAN, 0.0, 0.0), "apertureAngle", "finite"),
            (desc(5, f32::INFINITY, 0.0, 0.0), "apertureAngle", "finite"),
            (desc(5, 0.0, 1.5, 0.0), "apertureRoundness", "[-1, 1]"),
            (desc(5, 0.0, -1.01, 0.0), "apertureRoundness", "[-1, 1]"),
            (desc(5, 0.0, f32::NAN, 0.0), "apertureRoundness", "[-1, 1]"),
            (desc(5, 0.0, 0.0, 2.0), "apertureDensity", "[-1, 1]"),
            (desc(5, 0.0, 0.0, f32::NAN), "apertureDensity", "[-1, 1]"),
            (
                ApertureDesc {
                    dof_aspect: 0.0,
                    ..ApertureDesc::default()
                },
                "dofaspect",
                "> 0",
            ),
            (
                ApertureDesc {
                    dof_aspect: -2.0,
                    ..ApertureDesc::default()
                },
                "dofaspect",
                "> 0",
            ),
            (
                ApertureDesc {
                    dof_aspect: f32::INFINITY,
                    ..ApertureDesc::default()
                },
                "dofaspect",
                "finite",
            ),
            (
                ApertureDesc {
                    dof_aspect: f32::NAN,
                    ..ApertureDesc::default()
                },
                "dofaspect",
                "> 0",
            ),
        ];
        for (d, name, range) in cases {
            match ApertureWarp::new(&d) {
                Ok(_) => panic!("{d:?} accepted"),
                Err(e) => {
                    let msg = e.to_string();
                    assert!(msg.contains(name) && msg.contains(range), "{d:?}: {msg}");
                }
            }
        }
        assert!(matches!(
            ApertureWarp::new(&desc(5, 0.0, 1.5, 0.0)),
            Err(ApertureError::Roundness { .. })
        ));
        assert!(matches!(
            ApertureWarp::new(&desc(5, 0.0, 0.0, -1.5)),
            Err(ApertureError::Density { .. })
        ));
    }

    #[test]
    fn warp_is_send_sync_clone() {
        fn check<T: Send + Sync + Clone>() {}
        check::<ApertureWarp>();
        let w = ApertureWarp::new(&desc(6, 0.0, 0.0, 0.0)).expect("valid");
        let c = w.clone();
        let u = Point2::new(0.3, 0.7);
        assert_eq!(w.warp(u), c.warp(u));
    }

    fn valid_desc() -> impl Strategy<Value = ApertureDesc> {
        (
            -3i32..=40,
            -720.0f32..720.0,
            -1.0f32..=1.0,
            -1.0f32..=1.0,
            0.01f32..100.0,
        )
            .prop_map(
                |(n_sides, angle_deg, roundness, density, dof_aspect)| ApertureDesc {
                    n_sides,
                    angle_deg,
                    roundness,
                    density,
                    dof_aspect,
                },
            )
    }

    proptest! {
        #[test]
        fn warp_output_is_finite_and_in_the_square(d in valid_desc(), x in 0.0f32..1.0, y in 0.0f32..1.0) {
            let w = ApertureWarp::new(&d).expect("valid by construction");
            let p = w.warp(Point2::new(x, y));
            prop_assert!(p.x.is_finite() && p.y.is_finite());
            prop_assert!((-1.0..=1.0).contains(&p.x) && (-1.0..=1.0).contains(&p.y), "{:?}", p);
            // And inside the shape (before the aspect squeeze).
            let (sx, sy) = if d.dof_aspect >= 1.0 {
                (f64::from(p.x), f64::from(p.y) * f64::from(d.dof_aspect))
            } else {
                (f64::from(p.x) / f64::from(d.dof_aspect), f64::from(p.y))
            };
            let r = sx.hypot(sy);
            let phi = sy.atan2(sx) as f32;
            prop_assert!(r <= f64::from(w.boundary_radius(phi)) + 1e-4, "r = {} outside", r);
        }
    }
}
