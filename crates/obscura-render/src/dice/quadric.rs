//! Quadrics → triangles: segment counts from the rate, and the (u, v) grid evaluated on the analytic
//! surface.
//!
//! With `k` the rate in pixels per object-space unit (see the [`dice`](super) module) and `m` the
//! micropolygon length in pixels (`Attribute "dice" "float micropolygonlength"`), a parametric
//! direction whose longest object-space arc is `A` and which sweeps the fraction `f` of a
//! full turn gets
//!
//! `n = clamp(⌈A·k / m⌉, max(1, ⌈4·f⌉), 4096)` segments,
//!
//! and when `n_u·n_v` exceeds [`MAX_QUADS_PER_PRIMITIVE`] both are scaled down by the same factor.
//! The arcs (angles in radians, `Δθ` = thetamax clamped to one turn, every length and angle taken
//! as its absolute value):
//!
//! | quadric | around z (`u`) | the other direction (`v`) |
//! |---|---|---|
//! | sphere `R`, cut to `φ ∈ [asin(zmin/R), asin(zmax/R)]` | `R·max(cos φ)·Δθ` | meridian `R·Δφ` |
//! | cylinder | `R·Δθ` | `zmax − zmin` |
//! | cone height `h`, radius `R` | `R·Δθ` (base circle) | slant `√(h² + R²)` |
//! | disk | `R·Δθ` | `R` |
//! | torus `R₁`, `R₂`, `Δφ = phimax − phimin` | `(R₁ + R₂)·Δθ` | `R₂·Δφ` |
//!
//! Vertices lie on the analytic surface (RenderMan Interface 3.2 parametrisation, evaluated in `f64`),
//! normals are the analytic outward normals (the disk's is +z), full turns share their seam vertices
//! and poles (sphere ends, cone apex, disk centre) are a single vertex, so a closed sphere or torus
//! is watertight. Triangles wind so that `(p₁ − p₀)×(p₂ − p₀)` points along the normal. Negative
//! sweeps and reversed limits sweep the other way, as the RenderMan Interface says; a zero sweep, a
//! zero radius, `zmin = zmax` or a non-finite parameter gives an empty mesh.

use std::f64::consts::TAU;

use glam::DVec3;
use rayon::prelude::*;

use super::{
    DicingContext, MAX_QUADS_PER_PRIMITIVE, MAX_SEGMENTS, MIN_SEGMENTS_PER_TURN, micropolygon_length,
    pixels_per_unit,
};
use crate::ray::TriangleMesh;

/// The rate for one primitive.
pub(super) struct Rate {
    pixels_per_unit: f64,
    micropolygon_length: f64,
}

impl Rate {
    pub(super) fn new(ctx: &DicingContext, centre: DVec3, radius: f64) -> Rate {
        Rate {
            pixels_per_unit: f64::from(pixels_per_unit(ctx, centre.as_vec3(), radius as f32)),
            micropolygon_length: micropolygon_length(ctx),
        }
    }

    /// `clamp(⌈arc·k/m⌉, max(1, ⌈4·turn⌉), MAX_SEGMENTS)`.
    pub(super) fn segments(&self, arc: f64, turn: f64) -> u32 {
        let min = min_segments(turn);
        let want = (arc * self.pixels_per_unit / self.micropolygon_length).ceil();
        if want.is_nan() {
            min
        } else {
            want.clamp(f64::from(min), f64::from(MAX_SEGMENTS)) as u32
        }
    }
}

pub(super) fn min_segments(turn: f64) -> u32 {
    let min = (f64::from(MIN_SEGMENTS_PER_TURN) * turn).ceil();
    if min.is_nan() {
        1
    } else {
        min.clamp(1.0, f64::from(MIN_SEGMENTS_PER_TURN)) as u32
    }
}

/// Scales `nu` and `nv` down together so that `nu·nv ≤ MAX_QUADS_PER_PRIMITIVE`.
pub(super) fn fit_budget(nu: u32, nv: u32, min_u: u32, min_v: u32) -> (u32, u32) {
    let quads = u64::from(nu) * u64::from(nv);
    if quads <= MAX_QUADS_PER_PRIMITIVE {
        return (nu, nv);
    }
    let scale = (MAX_QUADS_PER_PRIMITIVE as f64 / quads as f64).sqrt();
    let shrink = |n: u32, min: u32| ((f64::from(n) * scale).floor() as u32).max(min);
    (shrink(nu, min_u), shrink(nv, min_v))
}

/// A sweep in degrees as radians in `[−2π, 2π]`; `None` when zero or not finite.
pub(super) fn sweep(degrees: f32) -> Option<f64> {
    let d = f64::from(degrees);
    (d.is_finite() && d != 0.0).then(|| d.clamp(-360.0, 360.0).to_radians())
}

/// A (u, v) ∈ [0, 1]² grid of `nu × nv` cells over a surface.
pub(super) struct Grid {
    pub(super) nu: u32,
    pub(super) nv: u32,
    /// u = 1 is u = 0 (a full turn): the seam column is shared.
    pub(super) wrap_u: bool,
    /// v = 1 is v = 0.
    pub(super) wrap_v: bool,
    /// Row v = 0 is the single point (position, normal).
    pub(super) pole0: Option<(DVec3, DVec3)>,
    /// Row v = 1 is the single point (position, normal).
    pub(super) pole1: Option<(DVec3, DVec3)>,
}

/// The grid of a surface swept `theta` around z from a circle of radius `r`, whose other direction
/// is a straight line of `length` (cylinder, cone, disk) ending in `pole1` when given.
fn swept_grid(rate: &Rate, r: f64, theta: f64, length: f64, pole1: Option<(DVec3, DVec3)>) -> Grid {
    let turn_u = theta.abs() / TAU;
    let nu = rate.segments(r * theta.abs(), turn_u);
    let nv = rate.segments(length, 0.0);
    let (nu, nv) = fit_budget(nu, nv, min_segments(turn_u), 1);
    Grid {
        nu,
        nv,
        wrap_u: theta.abs() >= TAU,
        wrap_v: false,
        pole0: None,
        pole1,
    }
}

/// Tessellates `surface(u, v) → (position, unit normal)` over `grid`.
pub(super) fn tessellate<F>(grid: &Grid, surface: F) -> TriangleMesh
where
    F: Fn(f64, f64) -> (DVec3, DVec3) + Sync,
{
    let (nu, nv) = (grid.nu.max(1), grid.nv.max(1));
    let rows = if grid.wrap_v { nv } else { nv + 1 };
    let cols = if grid.wrap_u { nu } else { nu + 1 };
    // Rows are j = 0..=nv; with wrap_v row nv is row 0 again (and there are no poles).
    let pole = |j: u32| match j {
        0 => grid.pole0,
        j if j == nv && !grid.wrap_v => grid.pole1,
        _ => None,
    };
    let row_vertices: Vec<Vec<(DVec3, DVec3)>> = (0..rows)
        .into_par_iter()
        .map(|j| match pole(j) {
            Some(p) => vec![p],
            None => {
                let v = f64::from(j) / f64::from(nv);
                (0..cols)
                    .map(|i| surface(f64::from(i) / f64::from(nu), v))
                    .collect()
            }
        })
        .collect();
    let mut row_start = Vec::with_capacity(rows as usize);
    let mut count = 0u32;
    for row in &row_vertices {
        row_start.push(count);
        count += row.len() as u32;
    }
    let index = |i: u32, j: u32| {
        let j = if grid.wrap_v { j % nv } else { j };
        let i = if grid.wrap_u { i % nu } else { i };
        if pole(j).is_some() {
            row_start[j as usize]
        } else {
            row_start[j as usize] + i
        }
    };
    let positions: Vec<DVec3> = row_vertices.iter().flatten().map(|v| v.0).collect();

    // Wind so that (b − a)×(c − a) agrees with the normal, judged once at the patch's centre.
    let h = 1e-4;
    let du = surface(0.5 + h, 0.5).0 - surface(0.5 - h, 0.5).0;
    let dv = surface(0.5, 0.5 + h).0 - surface(0.5, 0.5 - h).0;
    let flip = du.cross(dv).dot(surface(0.5, 0.5).1) < 0.0;

    let mut triangles = Vec::with_capacity(2 * nu as usize * nv as usize);
    let mut push = |t: [u32; 3]| triangles.push(if flip { [t[0], t[2], t[1]] } else { t });
    for j in 0..nv {
        let (pole_a, pole_b) = (pole(j).is_some(), pole(j + 1).is_some());
        for i in 0..nu {
            let (a, b, c, d) = (index(i, j), index(i + 1, j), index(i + 1, j + 1), index(i, j + 1));
            match (pole_a, pole_b) {
                (true, true) => {}
                (true, false) => push([a, c, d]),
                (false, true) => push([a, b, c]),
                (false, false) => {
                    let p = |k: u32| positions[k as usize];
                    if p(a).distance_squared(p(c)) <= p(b).distance_squared(p(d)) {
                        push([a, b, c]);
                        push([a, c, d]);
                    } else {
                        push([a, b, d]);
                        push([b, c, d]);
                    }
                }
            }
        }
    }
    TriangleMesh {
        positions: positions.iter().map(|p| p.as_vec3a()).collect(),
        normals: Some(row_vertices.iter().flatten().map(|v| v.1.as_vec3a()).collect()),
        triangles,
    }
}

pub(super) fn finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

/// `Sphere radius zmin zmax thetamax`.
pub(super) fn sphere(
    radius: f32,
    z_min: f32,
    z_max: f32,
    theta_max: f32,
    ctx: &DicingContext,
) -> TriangleMesh {
    let r = f64::from(radius).abs();
    let (z0, z1) = (f64::from(z_min), f64::from(z_max));
    let Some(theta) = sweep(theta_max) else {
        return TriangleMesh::default();
    };
    if !finite(&[r, z0, z1]) || r == 0.0 {
        return TriangleMesh::default();
    }
    let (z0, z1) = (z0.clamp(-r, r), z1.clamp(-r, r));
    if z0 == z1 {
        return TriangleMesh::default();
    }
    let (phi0, phi1) = ((z0 / r).clamp(-1.0, 1.0).asin(), (z1 / r).clamp(-1.0, 1.0).asin());
    let dphi = phi1 - phi0;
    let rate = Rate::new(ctx, DVec3::ZERO, r);
    let widest = if phi0 * phi1 <= 0.0 {
        1.0
    } else {
        phi0.cos().max(phi1.cos())
    };
    let (turn_u, turn_v) = (theta.abs() / TAU, dphi.abs() / TAU);
    let nu = rate.segments(r * widest * theta.abs(), turn_u);
    let nv = rate.segments(r * dphi.abs(), turn_v);
    let pole = |z: f64| (z.abs() == r).then(|| (DVec3::new(0.0, 0.0, z), DVec3::new(0.0, 0.0, z.signum())));
    let (pole0, pole1) = (pole(z0), pole(z1));
    let min_v = if pole0.is_some() && pole1.is_some() {
        2
    } else {
        min_segments(turn_v)
    };
    let (nu, nv) = fit_budget(nu, nv.max(min_v), min_segments(turn_u), min_v);
    let grid = Grid {
        nu,
        nv,
        wrap_u: theta.abs() >= TAU,
        wrap_v: false,
        pole0,
        pole1,
    };
    tessellate(&grid, |u, v| {
        let (t, p) = (u * theta, phi0 + v * dphi);
        let n = DVec3::new(p.cos() * t.cos(), p.cos() * t.sin(), p.sin());
        (n * r, n)
    })
}

/// `Cylinder radius zmin zmax thetamax`, open.
pub(super) fn cylinder(
    radius: f32,
    z_min: f32,
    z_max: f32,
    theta_max: f32,
    ctx: &DicingContext,
) -> TriangleMesh {
    let r = f64::from(radius).abs();
    let (z0, z1) = (f64::from(z_min), f64::from(z_max));
    let Some(theta) = sweep(theta_max) else {
        return TriangleMesh::default();
    };
    if !finite(&[r, z0, z1]) || r == 0.0 || z0 == z1 {
        return TriangleMesh::default();
    }
    let dz = z1 - z0;
    let rate = Rate::new(ctx, DVec3::new(0.0, 0.0, 0.5 * (z0 + z1)), r.hypot(0.5 * dz));
    let grid = swept_grid(&rate, r, theta, dz.abs(), None);
    tessellate(&grid, |u, v| {
        let t = u * theta;
        let n = DVec3::new(t.cos(), t.sin(), 0.0);
        (DVec3::new(r * n.x, r * n.y, z0 + v * dz), n)
    })
}

/// `Cone height radius thetamax`: base circle at z = 0, apex at (0, 0, height).
pub(super) fn cone(height: f32, radius: f32, theta_max: f32, ctx: &DicingContext) -> TriangleMesh {
    let (h, r) = (f64::from(height), f64::from(radius).abs());
    let Some(theta) = sweep(theta_max) else {
        return TriangleMesh::default();
    };
    if !finite(&[h, r]) || r == 0.0 {
        return TriangleMesh::default();
    }
    let rate = Rate::new(ctx, DVec3::new(0.0, 0.0, 0.5 * h), r.hypot(0.5 * h));
    // The outward normal is the gradient of √(x² + y²) − R·(1 − z/h), scaled by |h|.
    let up = if h < 0.0 { -1.0 } else { 1.0 };
    let apex = (DVec3::new(0.0, 0.0, h), DVec3::new(0.0, 0.0, up));
    let grid = swept_grid(&rate, r, theta, r.hypot(h), Some(apex));
    tessellate(&grid, |u, v| {
        let t = u * theta;
        let (c, s) = (t.cos(), t.sin());
        let p = DVec3::new((1.0 - v) * r * c, (1.0 - v) * r * s, v * h);
        let n = if h == 0.0 {
            DVec3::Z
        } else {
            DVec3::new(h.abs() * c, h.abs() * s, r * up).normalize()
        };
        (p, n)
    })
}

/// `Disk height radius thetamax`: at z = height, normal +z.
pub(super) fn disk(height: f32, radius: f32, theta_max: f32, ctx: &DicingContext) -> TriangleMesh {
    let (h, r) = (f64::from(height), f64::from(radius).abs());
    let Some(theta) = sweep(theta_max) else {
        return TriangleMesh::default();
    };
    if !finite(&[h, r]) || r == 0.0 {
        return TriangleMesh::default();
    }
    let rate = Rate::new(ctx, DVec3::new(0.0, 0.0, h), r);
    let centre = (DVec3::new(0.0, 0.0, h), DVec3::Z);
    let grid = swept_grid(&rate, r, theta, r, Some(centre));
    tessellate(&grid, |u, v| {
        let t = u * theta;
        (
            DVec3::new((1.0 - v) * r * t.cos(), (1.0 - v) * r * t.sin(), h),
            DVec3::Z,
        )
    })
}

/// `Torus majorradius minorradius phimin phimax thetamax`.
pub(super) fn torus(
    major: f32,
    minor: f32,
    phi_min: f32,
    phi_max: f32,
    theta_max: f32,
    ctx: &DicingContext,
) -> TriangleMesh {
    let (big, small) = (f64::from(major), f64::from(minor));
    let Some(theta) = sweep(theta_max) else {
        return TriangleMesh::default();
    };
    let Some(dphi) = sweep((f64::from(phi_max) - f64::from(phi_min)) as f32) else {
        return TriangleMesh::default();
    };
    let phi0 = f64::from(phi_min).to_radians();
    if !finite(&[big, small, phi0]) || small == 0.0 {
        return TriangleMesh::default();
    }
    let rate = Rate::new(ctx, DVec3::ZERO, big.abs() + small.abs());
    let (turn_u, turn_v) = (theta.abs() / TAU, dphi.abs() / TAU);
    let nu = rate.segments((big.abs() + small.abs()) * theta.abs(), turn_u);
    let nv = rate.segments(small.abs() * dphi.abs(), turn_v);
    let (nu, nv) = fit_budget(nu, nv, min_segments(turn_u), min_segments(turn_v));
    let grid = Grid {
        nu,
        nv,
        wrap_u: theta.abs() >= TAU,
        wrap_v: dphi.abs() >= TAU,
        pole0: None,
        pole1: None,
    };
    let outward = small.signum();
    tessellate(&grid, |u, v| {
        let (t, p) = (u * theta, phi0 + v * dphi);
        let ring = big + small * p.cos();
        let position = DVec3::new(ring * t.cos(), ring * t.sin(), small * p.sin());
        let normal = outward * DVec3::new(p.cos() * t.cos(), p.cos() * t.sin(), p.sin());
        (position, normal)
    })
}
