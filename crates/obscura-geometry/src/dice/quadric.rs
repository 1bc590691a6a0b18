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
//! That is the uniform grid, lines at `i/n_u` and `j/n_v`. Above [`UNIFORM_GRID_QUADS`] quads the
//! lines are fitted cell by cell instead ([`tessellate_fitted`]; the rule is in the
//! [`dice`](super) module's "Piece by piece"): each column and row of cells as fine as its finest
//! cell needs, where each cell is measured at its own distance and whether it is in view. All seven
//! quadrics (with `classic_quadrics`) go through that one function.
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

use glam::{DVec3, Vec2};
use rayon::prelude::*;

use super::{
    DicingContext, MAX_QUADS_PER_PRIMITIVE, MAX_SEGMENTS, MIN_SEGMENTS_PER_TURN, OFF_SCREEN_PIXELS,
    UNIFORM_GRID_QUADS, coverage_cap, micropolygon_length, piece_pixels_per_unit, pixels_per_unit,
};
use crate::ray::TriangleMesh;

/// The rate for one primitive.
pub(super) struct Rate {
    /// The whole primitive's [`pixels_per_unit`]: also the cap of its pieces in view.
    pixels_per_unit: f64,
    /// The whole primitive's rate had it covered only [`OFF_SCREEN_PIXELS`]: the cap of its pieces
    /// out of view.
    off_screen: f64,
    micropolygon_length: f64,
}

impl Rate {
    pub(super) fn new(ctx: &DicingContext, centre: DVec3, radius: f64) -> Rate {
        let radius = radius as f32;
        let whole = pixels_per_unit(ctx, centre.as_vec3(), radius);
        Rate {
            pixels_per_unit: f64::from(whole),
            off_screen: f64::from(whole.min(coverage_cap(OFF_SCREEN_PIXELS, radius))),
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

/// A (u, v) ∈ [0, 1]² grid of `nu × nv` cells over a surface, evenly spaced unless tessellated on
/// [`Lines`] of its own.
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

/// Where a grid's lines fall: increasing parameter values from 0 to 1 along u and along v.
pub(super) struct Lines {
    u: Vec<f64>,
    v: Vec<f64>,
}

impl Lines {
    /// `i/nu` and `j/nv`.
    fn uniform(nu: u32, nv: u32) -> Lines {
        let even = |n: u32| (0..=n).map(|i| f64::from(i) / f64::from(n)).collect();
        Lines {
            u: even(nu.max(1)),
            v: even(nv.max(1)),
        }
    }

    /// Cell `a` of `counts.len()` equal cells cut into `counts[a]` equal segments, one after the
    /// other: the values that start each segment, then 1.
    fn concatenated(counts: &[u32]) -> Vec<f64> {
        let cells = counts.len() as f64;
        let mut values = Vec::with_capacity(counts.iter().map(|&n| n as usize).sum::<usize>() + 1);
        for (a, &n) in counts.iter().enumerate() {
            values.extend((0..n).map(|s| (a as f64 + f64::from(s) / f64::from(n)) / cells));
        }
        values.push(1.0);
        values
    }
}

/// Cells across u in which a large quadric's rate is measured (at most its uniform `nu`).
const CELLS_U: u32 = 32;

/// Cells along v in which a large quadric's rate is measured (at most its uniform `nv`).
const CELLS_V: u32 = 16;

/// Segments of a cell's side between its surface samples (5 × 5 samples a cell).
const CELL_SAMPLES: u32 = 4;

/// A cell of the fitting grid, measured from its surface samples.
struct Cell {
    /// The samples' bounding sphere, grown by half the longest step between neighbouring samples
    /// to cover the surface between them.
    centre: DVec3,
    radius: f64,
    /// The longest polyline through the samples along u, and along v.
    arc_u: f64,
    arc_v: f64,
}

impl Cell {
    /// Cell `(a, b)` of `samples` (rows along v, each along u, `CELL_SAMPLES` steps a cell).
    fn measure(samples: &[Vec<DVec3>], a: u32, b: u32) -> Cell {
        let n = CELL_SAMPLES as usize;
        let (i0, j0) = (a as usize * n, b as usize * n);
        let at = |i: usize, j: usize| samples[j0 + j][i0 + i];
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        let (mut arc_u, mut arc_v, mut step) = (0.0f64, 0.0f64, 0.0f64);
        for k in 0..=n {
            let (mut along_u, mut along_v) = (0.0, 0.0);
            for i in 0..=n {
                let p = at(i, k);
                (lo, hi) = (lo.min(p), hi.max(p));
                if i < n {
                    let (du, dv) = (p.distance(at(i + 1, k)), at(k, i).distance(at(k, i + 1)));
                    (along_u, along_v) = (along_u + du, along_v + dv);
                    step = step.max(du).max(dv);
                }
            }
            (arc_u, arc_v) = (arc_u.max(along_u), arc_v.max(along_v));
        }
        let centre = 0.5 * (lo + hi);
        let reach = (0..=n)
            .flat_map(|j| (0..=n).map(move |i| (i, j)))
            .map(|(i, j)| centre.distance(at(i, j)))
            .fold(0.0, f64::max);
        Cell {
            centre,
            radius: reach + 0.5 * step,
            arc_u,
            arc_v,
        }
    }
}

/// The lines of a quadric's `grid` fitted cell by cell, or `None` when the uniform grid is to be
/// kept: it holds at most [`UNIFORM_GRID_QUADS`] quads, the fitted grid would not halve it (a
/// primitive mostly in view keeps its uniform grid, and with it the same precision on its limb as
/// at its nearest point), or a cell cannot be measured.
///
/// `[0, 1]²` is cut into `B_u × B_v` cells (`B_u = min(CELLS_U, nu)`, `B_v = min(CELLS_V, nv)`),
/// each measured from 5 × 5 samples of `surface` and diced at its own rate
/// ([`piece_pixels_per_unit`], capped by the whole primitive's rates in `rate`); a column of cells
/// gets the most segments any of its cells wants along u, a row the most along v, so the grid
/// stays one tensor product: no T-junctions, seams and poles as in the uniform grid.
fn fitted_lines<F>(grid: &Grid, rate: &Rate, ctx: &DicingContext, surface: &F) -> Option<Lines>
where
    F: Fn(f64, f64) -> (DVec3, DVec3) + Sync,
{
    let (nu, nv) = (grid.nu.max(1), grid.nv.max(1));
    let uniform = u64::from(nu) * u64::from(nv);
    if uniform <= UNIFORM_GRID_QUADS {
        return None;
    }
    let (cells_u, cells_v) = (CELLS_U.min(nu), CELLS_V.min(nv));
    let (steps_u, steps_v) = (cells_u * CELL_SAMPLES, cells_v * CELL_SAMPLES);
    let samples: Vec<Vec<DVec3>> = (0..=steps_v)
        .into_par_iter()
        .map(|j| {
            let v = f64::from(j) / f64::from(steps_v);
            (0..=steps_u)
                .map(|i| surface(f64::from(i) / f64::from(steps_u), v).0)
                .collect()
        })
        .collect();
    let (on_screen, off_screen) = (rate.pixels_per_unit as f32, rate.off_screen as f32);
    let mut columns = vec![1u32; cells_u as usize];
    let mut rows = vec![1u32; cells_v as usize];
    for b in 0..cells_v {
        for a in 0..cells_u {
            let cell = Cell::measure(&samples, a, b);
            let (centre, radius) = (cell.centre.as_vec3(), cell.radius as f32);
            if !centre.is_finite() || !radius.is_finite() {
                return None;
            }
            let k = f64::from(piece_pixels_per_unit(ctx, centre, radius, on_screen, off_screen));
            let segments = |arc: f64| {
                let want = (arc * k / rate.micropolygon_length).ceil();
                if want.is_nan() {
                    1
                } else {
                    want.clamp(1.0, f64::from(MAX_SEGMENTS)) as u32
                }
            };
            let (column, row) = (&mut columns[a as usize], &mut rows[b as usize]);
            (*column, *row) = (
                (*column).max(segments(cell.arc_u)),
                (*row).max(segments(cell.arc_v)),
            );
        }
    }
    let (columns, rows) = (at_most_max_segments(columns), at_most_max_segments(rows));
    let total = |counts: &[u32]| counts.iter().map(|&n| u64::from(n)).sum::<u64>();
    (2 * total(&columns) * total(&rows) <= uniform).then(|| Lines {
        u: Lines::concatenated(&columns),
        v: Lines::concatenated(&rows),
    })
}

/// `counts` scaled down together (each at least 1) when they add up to more than [`MAX_SEGMENTS`].
fn at_most_max_segments(counts: Vec<u32>) -> Vec<u32> {
    let sum: u64 = counts.iter().map(|&n| u64::from(n)).sum();
    if sum <= u64::from(MAX_SEGMENTS) {
        return counts;
    }
    // Leaving one segment a cell for the rounding up to 1 keeps the sum within the limit.
    let scale = f64::from(MAX_SEGMENTS - counts.len() as u32) / sum as f64;
    counts
        .into_iter()
        .map(|n| ((f64::from(n) * scale).floor() as u32).max(1))
        .collect()
}

/// Tessellates a quadric's `surface` over `grid`, on lines fitted cell by cell when that makes
/// fewer quads (see [`fitted_lines`]).
pub(super) fn tessellate_fitted<F>(grid: &Grid, rate: &Rate, ctx: &DicingContext, surface: F) -> TriangleMesh
where
    F: Fn(f64, f64) -> (DVec3, DVec3) + Sync,
{
    tessellate_fitted_st(grid, rate, ctx, false, surface).0
}

/// As [`tessellate_fitted`]; with `with_st`, also each vertex's `(u, v)`, the RI's default texture
/// coordinates `(s, t)` of a quadric: the seam column and pole rows are then split (the same
/// positions, one vertex per `(u, v)`), so a texture does not smear across them.
pub(super) fn tessellate_fitted_st<F>(
    grid: &Grid,
    rate: &Rate,
    ctx: &DicingContext,
    with_st: bool,
    surface: F,
) -> (TriangleMesh, Option<Vec<Vec2>>)
where
    F: Fn(f64, f64) -> (DVec3, DVec3) + Sync,
{
    let lines = fitted_lines(grid, rate, ctx, &surface).unwrap_or_else(|| Lines::uniform(grid.nu, grid.nv));
    tessellate_lines(grid, &lines, with_st, surface)
}

/// Tessellates `surface(u, v) → (position, unit normal)` over `grid`, evenly spaced.
pub(super) fn tessellate<F>(grid: &Grid, surface: F) -> TriangleMesh
where
    F: Fn(f64, f64) -> (DVec3, DVec3) + Sync,
{
    tessellate_lines(grid, &Lines::uniform(grid.nu, grid.nv), false, surface).0
}

/// Tessellates `surface` over `grid`'s wraps and poles with its lines at `lines` (their counts
/// replace `grid.nu` and `grid.nv`); with `with_st`, the seams and poles split and each vertex's
/// `(u, v)` returned (see [`tessellate_fitted_st`]).
fn tessellate_lines<F>(
    grid: &Grid,
    lines: &Lines,
    with_st: bool,
    surface: F,
) -> (TriangleMesh, Option<Vec<Vec2>>)
where
    F: Fn(f64, f64) -> (DVec3, DVec3) + Sync,
{
    let (nu, nv) = (lines.u.len() as u32 - 1, lines.v.len() as u32 - 1);
    // Split for texture coordinates: the last column and row are their own vertices (copies of the
    // first's positions when the grid wraps), and a pole row has one vertex per column.
    let (wrap_u, wrap_v) = (grid.wrap_u && !with_st, grid.wrap_v && !with_st);
    let rows = if wrap_v { nv } else { nv + 1 };
    let cols = if wrap_u { nu } else { nu + 1 };
    // Rows are j = 0..=nv; with wrap_v row nv is row 0 again (and there are no poles).
    let pole = |j: u32| match j {
        0 => grid.pole0,
        j if j == nv && !grid.wrap_v => grid.pole1,
        _ => None,
    };
    let point = |i: u32, j: u32| {
        // The seam repeats the first column (and row) exactly, so the split mesh stays closed.
        let i = if grid.wrap_u && i == nu { 0 } else { i };
        let j = if grid.wrap_v && j == nv { 0 } else { j };
        surface(lines.u[i as usize], lines.v[j as usize])
    };
    let row_vertices: Vec<Vec<(DVec3, DVec3)>> = (0..rows)
        .into_par_iter()
        .map(|j| match pole(j) {
            Some(p) if !with_st => vec![p],
            Some(p) => vec![p; cols as usize],
            None => (0..cols).map(|i| point(i, j)).collect(),
        })
        .collect();
    let mut row_start = Vec::with_capacity(rows as usize);
    let mut count = 0u32;
    for row in &row_vertices {
        row_start.push(count);
        count += row.len() as u32;
    }
    let index = |i: u32, j: u32| {
        let j = if wrap_v { j % nv } else { j };
        let i = if wrap_u { i % nu } else { i };
        if pole(j).is_some() && !with_st {
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
    let st = with_st.then(|| {
        (0..rows)
            .flat_map(|j| (0..cols).map(move |i| (i, j)))
            .map(|(i, j)| Vec2::new(lines.u[i as usize] as f32, lines.v[j as usize] as f32))
            .collect()
    });
    let mesh = TriangleMesh {
        positions: positions.iter().map(|p| p.as_vec3a()).collect(),
        normals: Some(row_vertices.iter().flatten().map(|v| v.1.as_vec3a()).collect()),
        triangles,
    };
    (mesh, st)
}

pub(super) fn finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

/// A sphere's, cylinder's or paraboloid's radius (|radius|), z range and sweep (radians), checked:
/// `None` when the sweep is empty, a value is not finite or the radius is 0.
pub(super) fn radius_z_sweep(
    radius: f32,
    z_min: f32,
    z_max: f32,
    theta_max: f32,
) -> Option<(f64, f64, f64, f64)> {
    let r = f64::from(radius).abs();
    let (z0, z1) = (f64::from(z_min), f64::from(z_max));
    let theta = sweep(theta_max)?;
    (finite(&[r, z0, z1]) && r != 0.0).then_some((r, z0, z1, theta))
}

/// `Sphere radius zmin zmax thetamax`.
pub(super) fn sphere(
    radius: f32,
    z_min: f32,
    z_max: f32,
    theta_max: f32,
    ctx: &DicingContext,
    with_st: bool,
) -> (TriangleMesh, Option<Vec<Vec2>>) {
    let Some((r, z0, z1, theta)) = radius_z_sweep(radius, z_min, z_max, theta_max) else {
        return Default::default();
    };
    let (z0, z1) = (z0.clamp(-r, r), z1.clamp(-r, r));
    if z0 == z1 {
        return Default::default();
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
    tessellate_fitted_st(&grid, &rate, ctx, with_st, |u, v| {
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
    with_st: bool,
) -> (TriangleMesh, Option<Vec<Vec2>>) {
    let Some((r, z0, z1, theta)) = radius_z_sweep(radius, z_min, z_max, theta_max) else {
        return Default::default();
    };
    if z0 == z1 {
        return Default::default();
    }
    let dz = z1 - z0;
    let rate = Rate::new(ctx, DVec3::new(0.0, 0.0, 0.5 * (z0 + z1)), r.hypot(0.5 * dz));
    let grid = swept_grid(&rate, r, theta, dz.abs(), None);
    tessellate_fitted_st(&grid, &rate, ctx, with_st, |u, v| {
        let t = u * theta;
        let n = DVec3::new(t.cos(), t.sin(), 0.0);
        (DVec3::new(r * n.x, r * n.y, z0 + v * dz), n)
    })
}

/// A cone's or disk's height, radius (|radius|) and sweep (radians), checked: `None` when the sweep
/// is empty, a value is not finite or the radius is 0.
fn height_radius_sweep(height: f32, radius: f32, theta_max: f32) -> Option<(f64, f64, f64)> {
    let (h, r) = (f64::from(height), f64::from(radius).abs());
    let theta = sweep(theta_max)?;
    (finite(&[h, r]) && r != 0.0).then_some((h, r, theta))
}

/// `Cone height radius thetamax`: base circle at z = 0, apex at (0, 0, height).
pub(super) fn cone(
    height: f32,
    radius: f32,
    theta_max: f32,
    ctx: &DicingContext,
    with_st: bool,
) -> (TriangleMesh, Option<Vec<Vec2>>) {
    let Some((h, r, theta)) = height_radius_sweep(height, radius, theta_max) else {
        return Default::default();
    };
    let rate = Rate::new(ctx, DVec3::new(0.0, 0.0, 0.5 * h), r.hypot(0.5 * h));
    // The outward normal is the gradient of √(x² + y²) − R·(1 − z/h), scaled by |h|.
    let up = if h < 0.0 { -1.0 } else { 1.0 };
    let apex = (DVec3::new(0.0, 0.0, h), DVec3::new(0.0, 0.0, up));
    let grid = swept_grid(&rate, r, theta, r.hypot(h), Some(apex));
    tessellate_fitted_st(&grid, &rate, ctx, with_st, |u, v| {
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
pub(super) fn disk(
    height: f32,
    radius: f32,
    theta_max: f32,
    ctx: &DicingContext,
    with_st: bool,
) -> (TriangleMesh, Option<Vec<Vec2>>) {
    let Some((h, r, theta)) = height_radius_sweep(height, radius, theta_max) else {
        return Default::default();
    };
    let rate = Rate::new(ctx, DVec3::new(0.0, 0.0, h), r);
    let centre = (DVec3::new(0.0, 0.0, h), DVec3::Z);
    let grid = swept_grid(&rate, r, theta, r, Some(centre));
    tessellate_fitted_st(&grid, &rate, ctx, with_st, |u, v| {
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
    with_st: bool,
) -> (TriangleMesh, Option<Vec<Vec2>>) {
    let (big, small) = (f64::from(major), f64::from(minor));
    let Some(theta) = sweep(theta_max) else {
        return Default::default();
    };
    let Some(dphi) = sweep((f64::from(phi_max) - f64::from(phi_min)) as f32) else {
        return Default::default();
    };
    let phi0 = f64::from(phi_min).to_radians();
    if !finite(&[big, small, phi0]) || small == 0.0 {
        return Default::default();
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
    tessellate_fitted_st(&grid, &rate, ctx, with_st, |u, v| {
        let (t, p) = (u * theta, phi0 + v * dphi);
        let ring = big + small * p.cos();
        let position = DVec3::new(ring * t.cos(), ring * t.sin(), small * p.sin());
        let normal = outward * DVec3::new(p.cos() * t.cos(), p.cos() * t.sin(), p.sin());
        (position, normal)
    })
}
