//! Dicing: quadrics and Catmull–Clark subdivision surfaces → triangles in object space, once per
//! render at render start, at a rate set by the projection's `DicingHint` and `FieldOfView`
//! (§5.8 of the projection document; §2.4 for the two properties).
//!
//! # The rate: pixels per object-space unit
//!
//! A primitive's object-space bounding sphere (centre `c₀`, radius `ρ₀`) is taken to camera space
//! with `M` = object → camera: `c = M·c₀`, `ρ = σ·ρ₀`, where `σ` is the longest of `M`'s three axis
//! columns (an upper bound on how much `M` stretches a length). One screen unit spans
//! `s = max(W/(r − l), H/(t − b))` pixels (`W × H` the format, `l r b t` the screen window; with
//! square pixels both terms agree). An object-space length `L` then covers `L·k` pixels, with
//!
//! | dicing hint | `k` (pixels per object-space unit) |
//! |---|---|
//! | `Perspective` | `σ·s·d / z`, `d = 1/tan(fov/2)`, `z = max(c.z − ρ, ε·ρ)` |
//! | `Orthographic` | `σ·s` (no divide: a camera-space unit is a screen unit) |
//! | `Spherical` | `σ·(2s/fov) / D`, `D = max(‖c‖ − ρ, ε·ρ)`, fov in radians |
//!
//! `ε` = [`NEAR_FRACTION`]: a primitive that straddles the camera plane, surrounds the camera or lies
//! behind it is measured as if its nearest point were `ε·ρ` away, so it dices finely but finitely.
//! For `Spherical`, the field of view spans the unit circle of screen space, i.e. `2s` pixels:
//! with the default screen window and square pixels `2s = min(W, H)`, the image's shorter side.
//! `k` is clamped to `[0, MAX_PIXELS_PER_UNIT]` (NaN → 0). The field of view is the projection's
//! `FieldOfView` in degrees (90 when it is not a positive finite number), clamped to 179° for
//! `Perspective` and 360° for `Spherical`.
//!
//! # Quadrics: segments per parametric direction
//!
//! With `m` the micropolygon length in pixels (`Attribute "dice" "float micropolygonlength"`), a
//! parametric direction whose longest object-space arc is `A` and which sweeps the fraction `f` of a
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
//!
//! # Catmull–Clark subdivision surfaces
//!
//! The level is the smallest `j ≥ 1` with `L·k / 2^j ≤ m` (`L` the control mesh's longest edge, `k`
//! for the control points' bounding sphere), i.e. `j = clamp(⌈log₂(L·k/m)⌉, 1, 6)`, lowered while
//! the result would exceed [`MAX_QUADS_PER_PRIMITIVE`]. After `j` uniform steps (the first turns an
//! n-gon into n quads) every vertex moves to its limit position:
//!
//! - smooth interior vertex of valence `n`: `(n²·S + 4·Σ eᵢ + Σ fᵢ) / (n·(n + 5))` (`eᵢ` the edge
//!   neighbours, `fᵢ` the opposite corners of the incident quads);
//! - crease or boundary vertex: `(e_a + 4·S + e_b)/6`, the cubic B-spline limit of the crease curve;
//! - corner (three or more sharp edges, or a boundary vertex with one face): fixed.
//!
//! Creases follow DeRose, Kass and Truong (1998): sharpness ≥ 10 is infinitely sharp; a semi-sharp
//! edge uses the sharp rules while its sharpness is ≥ 1, blends smooth and sharp rules by the
//! fractional sharpness on the step where it drops below 1, and its children's sharpness falls by
//! one per step, averaged Chaikin-style with the neighbouring semi-sharp edges
//! (`s' = ¾·s + ¼·mean(s_neighbours) − 1`). An edge still semi-sharp after the last step is
//! approximated at the limit: sharp limit rules when `s ≥ 1`, else smooth and sharp blended by `s`
//! (exact when the level is at least the sharpness). Boundary edges are infinitely sharp: every boundary is
//! treated as interpolated, with or without `"interpolateboundary"` (RenderMan would drop the
//! outer ring of boundary faces without it). Smooth interior vertices get exact limit normals from
//! the tangent masks of Halstead, Kass and DeRose (1993); crease, boundary and corner vertices get
//! the area-weighted average of the adjacent limit triangles' normals. Normals follow the control
//! faces' winding by the right-hand rule. Quads are split along their shorter diagonal.
//!
//! Polygon meshes pass through unchanged (their normals kept) after their indices are checked.

use std::f64::consts::TAU;

use glam::{DVec3, Mat4, Vec3, Vec3A};
use obscura_scene::{Mesh, Shape, SubdivMesh};
use obscura_sdk::{DicingHint, Format, ScreenWindow};
use rayon::prelude::*;

use crate::ray::TriangleMesh;

/// The most segments along one parametric direction of a quadric.
pub const MAX_SEGMENTS: u32 = 4096;

/// The fewest segments along a full 360° sweep (a partial sweep gets this times its fraction of a
/// turn, and at least one).
pub const MIN_SEGMENTS_PER_TURN: u32 = 4;

/// The most quads one primitive dices into (a quadric's `n_u·n_v`, a subdivision surface's faces
/// after the last level): the memory bound for a primitive that surrounds the camera.
pub const MAX_QUADS_PER_PRIMITIVE: u64 = 1 << 22;

/// The deepest Catmull–Clark subdivision level.
pub const MAX_SUBDIVISION_LEVEL: u32 = 6;

/// The nearest a primitive is assumed to be, as a fraction of its camera-space bounding radius
/// (the `ε` of the module documentation).
pub const NEAR_FRACTION: f32 = 0.05;

/// The cap on [`pixels_per_unit`].
pub const MAX_PIXELS_PER_UNIT: f32 = 1e30;

/// Crease sharpness at or above which an edge is infinitely sharp.
pub const INFINITE_SHARPNESS: f32 = 10.0;

/// What dicing needs to know about the camera and the primitive.
#[derive(Debug, Clone, Copy)]
pub struct DicingContext {
    /// The projection's `DicingHint` property.
    pub hint: DicingHint,
    /// The projection's FieldOfView property in degrees (the host uses 90 when a projection answers none).
    pub field_of_view: f32,
    /// The image format.
    pub format: Format,
    /// The screen window.
    pub screen_window: ScreenWindow,
    /// Object space → camera space (glam, column vectors), at shutter open.
    pub object_to_camera: Mat4,
    /// Target edge length in pixels (`Attribute "dice" "float micropolygonlength"`, default 1).
    pub micropolygon_length: f32,
}

impl DicingContext {
    /// A context with `format`'s default screen window, the identity object-to-camera transform and
    /// a micropolygon length of one pixel.
    #[must_use]
    pub fn new(hint: DicingHint, field_of_view: f32, format: Format) -> Self {
        DicingContext {
            hint,
            field_of_view,
            format,
            screen_window: ScreenWindow::default_for(format),
            object_to_camera: Mat4::IDENTITY,
            micropolygon_length: 1.0,
        }
    }
}

/// Why a shape could not be diced. Each names the offending element.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DiceError {
    /// A polygon mesh's triangle names a vertex that does not exist.
    #[error("mesh triangle {triangle} uses vertex {index}, but the mesh has {vertex_count} vertices")]
    MeshIndexOutOfRange {
        /// Which triangle.
        triangle: usize,
        /// The bad index.
        index: u32,
        /// How many vertices there are.
        vertex_count: usize,
    },
    /// A polygon mesh has a different number of normals than positions.
    #[error("mesh has {normals} normals for {positions} positions")]
    MeshNormalCount {
        /// Normals given.
        normals: usize,
        /// Positions given.
        positions: usize,
    },
    /// A mesh vertex or subdivision control point is NaN or infinite.
    #[error("vertex {vertex} has a non-finite position")]
    NonFinitePosition {
        /// Which vertex.
        vertex: usize,
    },
    /// The subdivision mesh's face counts do not add up to its number of face indices.
    #[error("subdivision mesh face counts add up to {expected} indices, but {found} are given")]
    FaceIndexCount {
        /// The sum of the face counts.
        expected: u64,
        /// The number of face indices.
        found: usize,
    },
    /// A subdivision face has fewer than three vertices.
    #[error("subdivision face {face} has {vertices} vertices (at least 3 needed)")]
    FaceTooSmall {
        /// Which face.
        face: usize,
        /// Its vertex count.
        vertices: u32,
    },
    /// A subdivision face names a control point that does not exist.
    #[error("subdivision face {face} uses vertex {index}, but the mesh has {vertex_count} vertices")]
    IndexOutOfRange {
        /// Which face.
        face: usize,
        /// The bad index.
        index: u32,
        /// How many control points there are.
        vertex_count: usize,
    },
    /// A subdivision face uses the same control point twice.
    #[error("subdivision face {face} uses vertex {vertex} more than once")]
    RepeatedVertex {
        /// Which face.
        face: usize,
        /// The repeated vertex.
        vertex: u32,
    },
    /// An edge is shared by more than two faces: the mesh is not a manifold.
    #[error("edge ({a}, {b}) is used by {faces} faces (a manifold edge has at most 2)")]
    NonManifoldEdge {
        /// One end.
        a: u32,
        /// The other end.
        b: u32,
        /// How many faces use it.
        faces: usize,
    },
    /// A crease names a control point that does not exist.
    #[error("crease {crease} uses vertex {index}, but the mesh has {vertex_count} vertices")]
    CreaseIndexOutOfRange {
        /// Which crease (index into `SubdivMesh::creases`).
        crease: usize,
        /// The bad index.
        index: u32,
        /// How many control points there are.
        vertex_count: usize,
    },
    /// A crease joins two control points that no face edge joins.
    #[error("crease {crease} ({a}, {b}) is not an edge of the mesh")]
    CreaseNotAnEdge {
        /// Which crease.
        crease: usize,
        /// One end.
        a: u32,
        /// The other end.
        b: u32,
    },
    /// The control mesh is too large to subdivide even once with 32-bit indices.
    #[error("subdivision mesh too large: one level would make {vertices} vertices")]
    TooLarge {
        /// The vertex count one level would need.
        vertices: u64,
    },
    /// The diced geometry overflowed to infinity (parameters near the limits of `f32`).
    #[error("diced geometry is not finite (parameters too large)")]
    NonFiniteGeometry,
}

/// The shape as triangles in OBJECT space, with smooth per-vertex normals for curved surfaces.
/// Meshes pass through (normals kept).
///
/// Degenerate quadrics (zero sweep or radius, `zmin = zmax`, NaN parameters) give an empty mesh;
/// every vertex and normal of a returned mesh is finite. See the module documentation for the rate.
///
/// # Errors
///
/// A malformed polygon or subdivision mesh (see [`DiceError`]), or geometry that overflows `f32`.
pub fn dice(shape: &Shape, ctx: &DicingContext) -> Result<TriangleMesh, DiceError> {
    let mesh = match shape {
        Shape::Sphere {
            radius,
            z_min,
            z_max,
            theta_max,
        } => sphere(*radius, *z_min, *z_max, *theta_max, ctx),
        Shape::Cylinder {
            radius,
            z_min,
            z_max,
            theta_max,
        } => cylinder(*radius, *z_min, *z_max, *theta_max, ctx),
        Shape::Cone {
            height,
            radius,
            theta_max,
        } => cone(*height, *radius, *theta_max, ctx),
        Shape::Disk {
            height,
            radius,
            theta_max,
        } => disk(*height, *radius, *theta_max, ctx),
        Shape::Torus {
            major_radius,
            minor_radius,
            phi_min,
            phi_max,
            theta_max,
        } => torus(*major_radius, *minor_radius, *phi_min, *phi_max, *theta_max, ctx),
        Shape::Mesh(mesh) => pass_through(mesh)?,
        Shape::Subdiv(mesh) => subdivision(mesh, ctx)?,
    };
    let finite = mesh.positions.iter().all(|p| p.is_finite())
        && mesh
            .normals
            .as_ref()
            .is_none_or(|ns| ns.iter().all(|n| n.is_finite()));
    if finite {
        Ok(mesh)
    } else {
        Err(DiceError::NonFiniteGeometry)
    }
}

/// Pixels per unit of object-space length for a primitive with the given object-space bounding
/// sphere (centre, radius) under ctx: the scale the rate uses (exported for tests and the renderer's
/// statistics).
///
/// The formulas are in the module documentation. Always finite and in `[0, MAX_PIXELS_PER_UNIT]`:
/// a NaN anywhere in the inputs gives 0 (the coarsest dicing); a primitive reaching the camera plane
/// is measured at the [`NEAR_FRACTION`] floor (so a zero-radius one there gets the cap).
#[must_use]
pub fn pixels_per_unit(ctx: &DicingContext, centre: Vec3, radius: f32) -> f32 {
    let m = ctx.object_to_camera;
    let sigma = m
        .x_axis
        .truncate()
        .length()
        .max(m.y_axis.truncate().length())
        .max(m.z_axis.truncate().length());
    let c = m.transform_point3(centre);
    let rho = radius.abs() * sigma;
    let near = (NEAR_FRACTION * rho).max(f32::MIN_POSITIVE);
    let s = pixels_per_screen_unit(ctx);
    let k = match ctx.hint {
        DicingHint::Orthographic => sigma * s,
        DicingHint::Perspective => {
            let d = 1.0 / (0.5 * field_of_view_radians(ctx.field_of_view, 179.0)).tan();
            let z = (c.z - rho).max(near);
            sigma * s * d / z
        }
        DicingHint::Spherical => {
            let pixels_per_radian = 2.0 * s / field_of_view_radians(ctx.field_of_view, 360.0);
            let distance = (c.length() - rho).max(near);
            sigma * pixels_per_radian / distance
        }
    };
    if k.is_nan() {
        0.0
    } else {
        k.clamp(0.0, MAX_PIXELS_PER_UNIT)
    }
}

/// `max(W/(r − l), H/(t − b))`, falling back to the default window when the given one is degenerate.
fn pixels_per_screen_unit(ctx: &DicingContext) -> f32 {
    let w = ctx.format.width.max(1) as f32;
    let h = ctx.format.height.max(1) as f32;
    let usable = |win: &ScreenWindow| {
        let (sw, sh) = (win.width().abs(), win.height().abs());
        sw.is_finite() && sh.is_finite() && sw > 0.0 && sh > 0.0
    };
    let mut window = ctx.screen_window;
    if !usable(&window) {
        let pixel_aspect = ctx.format.pixel_aspect;
        let pixel_aspect = if pixel_aspect.is_finite() && pixel_aspect > 0.0 {
            pixel_aspect
        } else {
            1.0
        };
        let format = Format {
            width: w as u32,
            height: h as u32,
            pixel_aspect,
        };
        window = ScreenWindow::default_for(format);
        if !usable(&window) {
            window = ScreenWindow::new(-1.0, 1.0, -1.0, 1.0);
        }
    }
    (w / window.width().abs()).max(h / window.height().abs())
}

/// The field of view in radians: 90° when not a positive finite number, clamped to `max_degrees`.
fn field_of_view_radians(degrees: f32, max_degrees: f32) -> f32 {
    let degrees = if degrees.is_finite() && degrees > 0.0 {
        degrees
    } else {
        90.0
    };
    degrees.clamp(1e-3, max_degrees).to_radians()
}

/// The rate for one primitive.
struct Rate {
    pixels_per_unit: f64,
    micropolygon_length: f64,
}

impl Rate {
    fn new(ctx: &DicingContext, centre: DVec3, radius: f64) -> Rate {
        let m = ctx.micropolygon_length;
        Rate {
            pixels_per_unit: f64::from(pixels_per_unit(ctx, centre.as_vec3(), radius as f32)),
            micropolygon_length: if m > 0.0 { f64::from(m) } else { 1.0 },
        }
    }

    /// `clamp(⌈arc·k/m⌉, max(1, ⌈4·turn⌉), MAX_SEGMENTS)`.
    fn segments(&self, arc: f64, turn: f64) -> u32 {
        let min = min_segments(turn);
        let want = (arc * self.pixels_per_unit / self.micropolygon_length).ceil();
        if want.is_nan() {
            min
        } else {
            want.clamp(f64::from(min), f64::from(MAX_SEGMENTS)) as u32
        }
    }
}

fn min_segments(turn: f64) -> u32 {
    let min = (f64::from(MIN_SEGMENTS_PER_TURN) * turn).ceil();
    if min.is_nan() {
        1
    } else {
        min.clamp(1.0, f64::from(MIN_SEGMENTS_PER_TURN)) as u32
    }
}

/// Scales `nu` and `nv` down together so that `nu·nv ≤ MAX_QUADS_PER_PRIMITIVE`.
fn fit_budget(nu: u32, nv: u32, min_u: u32, min_v: u32) -> (u32, u32) {
    let quads = u64::from(nu) * u64::from(nv);
    if quads <= MAX_QUADS_PER_PRIMITIVE {
        return (nu, nv);
    }
    let scale = (MAX_QUADS_PER_PRIMITIVE as f64 / quads as f64).sqrt();
    let shrink = |n: u32, min: u32| ((f64::from(n) * scale).floor() as u32).max(min);
    (shrink(nu, min_u), shrink(nv, min_v))
}

/// A sweep in degrees as radians in `[−2π, 2π]`; `None` when zero or not finite.
fn sweep(degrees: f32) -> Option<f64> {
    let d = f64::from(degrees);
    (d.is_finite() && d != 0.0).then(|| d.clamp(-360.0, 360.0).to_radians())
}

/// A (u, v) ∈ [0, 1]² grid of `nu × nv` cells over a surface.
struct Grid {
    nu: u32,
    nv: u32,
    /// u = 1 is u = 0 (a full turn): the seam column is shared.
    wrap_u: bool,
    /// v = 1 is v = 0.
    wrap_v: bool,
    /// Row v = 0 is the single point (position, normal).
    pole0: Option<(DVec3, DVec3)>,
    /// Row v = 1 is the single point (position, normal).
    pole1: Option<(DVec3, DVec3)>,
}

/// Tessellates `surface(u, v) → (position, unit normal)` over `grid`.
fn tessellate<F>(grid: &Grid, surface: F) -> TriangleMesh
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

fn finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

/// `Sphere radius zmin zmax thetamax`.
fn sphere(radius: f32, z_min: f32, z_max: f32, theta_max: f32, ctx: &DicingContext) -> TriangleMesh {
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
fn cylinder(radius: f32, z_min: f32, z_max: f32, theta_max: f32, ctx: &DicingContext) -> TriangleMesh {
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
    let turn_u = theta.abs() / TAU;
    let nu = rate.segments(r * theta.abs(), turn_u);
    let nv = rate.segments(dz.abs(), 0.0);
    let (nu, nv) = fit_budget(nu, nv, min_segments(turn_u), 1);
    let grid = Grid {
        nu,
        nv,
        wrap_u: theta.abs() >= TAU,
        wrap_v: false,
        pole0: None,
        pole1: None,
    };
    tessellate(&grid, |u, v| {
        let t = u * theta;
        let n = DVec3::new(t.cos(), t.sin(), 0.0);
        (DVec3::new(r * n.x, r * n.y, z0 + v * dz), n)
    })
}

/// `Cone height radius thetamax`: base circle at z = 0, apex at (0, 0, height).
fn cone(height: f32, radius: f32, theta_max: f32, ctx: &DicingContext) -> TriangleMesh {
    let (h, r) = (f64::from(height), f64::from(radius).abs());
    let Some(theta) = sweep(theta_max) else {
        return TriangleMesh::default();
    };
    if !finite(&[h, r]) || r == 0.0 {
        return TriangleMesh::default();
    }
    let rate = Rate::new(ctx, DVec3::new(0.0, 0.0, 0.5 * h), r.hypot(0.5 * h));
    let turn_u = theta.abs() / TAU;
    let nu = rate.segments(r * theta.abs(), turn_u);
    let nv = rate.segments(r.hypot(h), 0.0);
    let (nu, nv) = fit_budget(nu, nv, min_segments(turn_u), 1);
    // The outward normal is the gradient of √(x² + y²) − R·(1 − z/h), scaled by |h|.
    let up = if h < 0.0 { -1.0 } else { 1.0 };
    let apex = (DVec3::new(0.0, 0.0, h), DVec3::new(0.0, 0.0, up));
    let grid = Grid {
        nu,
        nv,
        wrap_u: theta.abs() >= TAU,
        wrap_v: false,
        pole0: None,
        pole1: Some(apex),
    };
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
fn disk(height: f32, radius: f32, theta_max: f32, ctx: &DicingContext) -> TriangleMesh {
    let (h, r) = (f64::from(height), f64::from(radius).abs());
    let Some(theta) = sweep(theta_max) else {
        return TriangleMesh::default();
    };
    if !finite(&[h, r]) || r == 0.0 {
        return TriangleMesh::default();
    }
    let rate = Rate::new(ctx, DVec3::new(0.0, 0.0, h), r);
    let turn_u = theta.abs() / TAU;
    let nu = rate.segments(r * theta.abs(), turn_u);
    let nv = rate.segments(r, 0.0);
    let (nu, nv) = fit_budget(nu, nv, min_segments(turn_u), 1);
    let centre = (DVec3::new(0.0, 0.0, h), DVec3::Z);
    let grid = Grid {
        nu,
        nv,
        wrap_u: theta.abs() >= TAU,
        wrap_v: false,
        pole0: None,
        pole1: Some(centre),
    };
    tessellate(&grid, |u, v| {
        let t = u * theta;
        (
            DVec3::new((1.0 - v) * r * t.cos(), (1.0 - v) * r * t.sin(), h),
            DVec3::Z,
        )
    })
}

/// `Torus majorradius minorradius phimin phimax thetamax`.
fn torus(
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

/// A polygon mesh, checked and converted.
fn pass_through(mesh: &Mesh) -> Result<TriangleMesh, DiceError> {
    let n = mesh.positions.len();
    if let Some(vertex) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(DiceError::NonFinitePosition { vertex });
    }
    for (triangle, t) in mesh.triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= n) {
            return Err(DiceError::MeshIndexOutOfRange {
                triangle,
                index,
                vertex_count: n,
            });
        }
    }
    if let Some(normals) = &mesh.normals
        && normals.len() != n
    {
        return Err(DiceError::MeshNormalCount {
            normals: normals.len(),
            positions: n,
        });
    }
    Ok(TriangleMesh {
        positions: mesh.positions.iter().map(|&p| Vec3A::from(p)).collect(),
        normals: mesh
            .normals
            .as_ref()
            .map(|ns| ns.iter().map(|&v| Vec3A::from(v)).collect()),
        triangles: mesh.triangles.clone(),
    })
}

// ---------------------------------------------------------------------------------------------
// Catmull–Clark
// ---------------------------------------------------------------------------------------------

/// A polygon mesh between subdivision steps.
#[derive(Debug, Clone)]
struct Level {
    positions: Vec<DVec3>,
    /// Face `f` is `face_verts[face_start[f]..face_start[f + 1]]`.
    face_start: Vec<usize>,
    face_verts: Vec<u32>,
    /// Sharp interior edges `(lo, hi, sharpness)`, `lo < hi`, sorted; infinite sharpness is `f32::INFINITY`.
    creases: Vec<(u32, u32, f32)>,
}

impl Level {
    fn face_count(&self) -> usize {
        self.face_start.len().saturating_sub(1)
    }

    fn face(&self, f: usize) -> &[u32] {
        &self.face_verts[self.face_start[f]..self.face_start[f + 1]]
    }
}

#[derive(Debug, Clone, Copy)]
struct Edge {
    lo: u32,
    hi: u32,
    faces: [u32; 2],
    face_count: u32,
    /// Boundary edges are infinitely sharp.
    sharpness: f32,
}

impl Edge {
    fn other(&self, v: u32) -> u32 {
        if self.lo == v { self.hi } else { self.lo }
    }

    fn is_boundary(&self) -> bool {
        self.face_count < 2
    }
}

/// Edges (sorted by their ends) and vertex adjacency of a [`Level`].
struct Topology {
    edges: Vec<Edge>,
    /// Parallel to `face_verts`: the edge from each face corner to the next.
    corner_edge: Vec<u32>,
    vertex_edge_start: Vec<usize>,
    vertex_edges: Vec<u32>,
    vertex_face_start: Vec<usize>,
    vertex_faces: Vec<u32>,
}

impl Topology {
    fn build(level: &Level) -> Result<Topology, DiceError> {
        // Bucket the face corners by the lower end of their edge (a counting sort), then sort each
        // small bucket by the upper end: edges come out sorted by (lo, hi) without a global sort.
        let n = level.positions.len();
        let corners = level.face_verts.len();
        let mut corner_face = vec![0u32; corners];
        let mut corner_next = vec![0u32; corners];
        for f in 0..level.face_count() {
            let face = level.face(f);
            for i in 0..face.len() {
                corner_face[level.face_start[f] + i] = f as u32;
                corner_next[level.face_start[f] + i] = face[(i + 1) % face.len()];
            }
        }
        let ends = |c: usize| {
            let (a, b) = (level.face_verts[c], corner_next[c]);
            (a.min(b), a.max(b))
        };
        let mut bucket_start = vec![0usize; n + 1];
        for c in 0..corners {
            bucket_start[ends(c).0 as usize + 1] += 1;
        }
        for v in 0..n {
            bucket_start[v + 1] += bucket_start[v];
        }
        let mut fill = bucket_start.clone();
        let mut entries = vec![(0u32, 0u32); corners];
        for c in 0..corners {
            let (lo, hi) = ends(c);
            entries[fill[lo as usize]] = (hi, c as u32);
            fill[lo as usize] += 1;
        }
        let mut edges: Vec<Edge> = Vec::with_capacity(corners / 2 + n);
        let mut corner_edge = vec![0u32; corners];
        for lo in 0..n {
            let bucket = &mut entries[bucket_start[lo]..bucket_start[lo + 1]];
            bucket.sort_unstable();
            for group in bucket.chunk_by(|x, y| x.0 == y.0) {
                let (lo, hi) = (lo as u32, group[0].0);
                if group.len() > 2 {
                    return Err(DiceError::NonManifoldEdge {
                        a: lo,
                        b: hi,
                        faces: group.len(),
                    });
                }
                let id = edges.len() as u32;
                let mut faces = [u32::MAX; 2];
                for (slot, &(_, c)) in group.iter().enumerate() {
                    faces[slot] = corner_face[c as usize];
                    corner_edge[c as usize] = id;
                }
                let sharpness = if group.len() < 2 {
                    f32::INFINITY
                } else {
                    level
                        .creases
                        .binary_search_by(|c| (c.0, c.1).cmp(&(lo, hi)))
                        .map_or(0.0, |i| level.creases[i].2)
                };
                edges.push(Edge {
                    lo,
                    hi,
                    faces,
                    face_count: group.len() as u32,
                    sharpness,
                });
            }
        }
        let (vertex_edge_start, vertex_edges) = adjacency(
            n,
            edges
                .iter()
                .enumerate()
                .flat_map(|(i, e)| [(e.lo, i as u32), (e.hi, i as u32)]),
        );
        let (vertex_face_start, vertex_faces) = adjacency(
            n,
            (0..level.face_count()).flat_map(|f| level.face(f).iter().map(move |&v| (v, f as u32))),
        );
        Ok(Topology {
            edges,
            corner_edge,
            vertex_edge_start,
            vertex_edges,
            vertex_face_start,
            vertex_faces,
        })
    }

    fn edges_of(&self, v: u32) -> &[u32] {
        &self.vertex_edges[self.vertex_edge_start[v as usize]..self.vertex_edge_start[v as usize + 1]]
    }

    fn faces_of(&self, v: u32) -> &[u32] {
        &self.vertex_faces[self.vertex_face_start[v as usize]..self.vertex_face_start[v as usize + 1]]
    }

    /// A boundary vertex with one face: RenderMan's `interpolateboundary` makes it a corner.
    fn is_boundary_corner(&self, v: u32) -> bool {
        self.faces_of(v).len() == 1
            && self
                .edges_of(v)
                .iter()
                .any(|&e| self.edges[e as usize].is_boundary())
    }

    /// The sharpness the child of edge `e` at end `v` gets: one less per step, averaged Chaikin-style
    /// with the other semi-sharp edges at `v`.
    fn child_sharpness(&self, e: u32, v: u32) -> f32 {
        let s = self.edges[e as usize].sharpness;
        if s <= 0.0 || s.is_infinite() {
            return s.max(0.0);
        }
        let (sum, count) = self
            .edges_of(v)
            .iter()
            .filter(|&&o| o != e)
            .map(|&o| self.edges[o as usize].sharpness)
            .filter(|o| *o > 0.0 && o.is_finite())
            .fold((0.0f32, 0u32), |(sum, count), o| (sum + o, count + 1));
        let base = if count == 0 {
            s
        } else {
            0.75 * s + 0.25 * sum / count as f32
        };
        (base - 1.0).max(0.0)
    }
}

/// A compressed adjacency list from `(vertex, item)` pairs.
fn adjacency(n: usize, pairs: impl Iterator<Item = (u32, u32)> + Clone) -> (Vec<usize>, Vec<u32>) {
    let mut start = vec![0usize; n + 1];
    for (v, _) in pairs.clone() {
        start[v as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut items = vec![0u32; start[n]];
    for (v, item) in pairs {
        items[fill[v as usize]] = item;
        fill[v as usize] += 1;
    }
    (start, items)
}

/// Which vertex rule applies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rule {
    Smooth,
    Crease,
    Corner,
}

fn rule(sharp_edges: usize, corner: bool) -> Rule {
    match sharp_edges {
        _ if corner => Rule::Corner,
        0 | 1 => Rule::Smooth,
        2 => Rule::Crease,
        _ => Rule::Corner,
    }
}

/// The control mesh, checked, as level 0.
fn control_level(mesh: &SubdivMesh) -> Result<Level, DiceError> {
    let n = mesh.positions.len();
    if let Some(vertex) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(DiceError::NonFinitePosition { vertex });
    }
    let expected: u64 = mesh.face_counts.iter().map(|&c| u64::from(c)).sum();
    if expected != mesh.face_indices.len() as u64 {
        return Err(DiceError::FaceIndexCount {
            expected,
            found: mesh.face_indices.len(),
        });
    }
    let mut face_start = Vec::with_capacity(mesh.face_counts.len() + 1);
    face_start.push(0usize);
    let mut sorted = Vec::new();
    for (face, &count) in mesh.face_counts.iter().enumerate() {
        let start = *face_start.last().unwrap_or(&0);
        let verts = &mesh.face_indices[start..start + count as usize];
        if count < 3 {
            return Err(DiceError::FaceTooSmall {
                face,
                vertices: count,
            });
        }
        if let Some(&index) = verts.iter().find(|&&i| i as usize >= n) {
            return Err(DiceError::IndexOutOfRange {
                face,
                index,
                vertex_count: n,
            });
        }
        sorted.clear();
        sorted.extend_from_slice(verts);
        sorted.sort_unstable();
        if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
            return Err(DiceError::RepeatedVertex { face, vertex: w[0] });
        }
        face_start.push(start + count as usize);
    }
    let mut creases = Vec::new();
    for (crease, &(a, b, s)) in mesh.creases.iter().enumerate() {
        if let Some(&index) = [a, b].iter().find(|&&i| i as usize >= n) {
            return Err(DiceError::CreaseIndexOutOfRange {
                crease,
                index,
                vertex_count: n,
            });
        }
        if a == b {
            return Err(DiceError::CreaseNotAnEdge { crease, a, b });
        }
        if s > 0.0 {
            let s = if s >= INFINITE_SHARPNESS { f32::INFINITY } else { s };
            creases.push((a.min(b), a.max(b), s));
        }
    }
    creases.sort_unstable_by(|x, y| (x.0, x.1).cmp(&(y.0, y.1)).then(y.2.total_cmp(&x.2)));
    creases.dedup_by_key(|c| (c.0, c.1));
    Ok(Level {
        positions: mesh.positions.iter().map(|p| p.as_dvec3()).collect(),
        face_start,
        face_verts: mesh.face_indices.clone(),
        creases,
    })
}

/// Dices a subdivision mesh at the level the rate asks for.
fn subdivision(mesh: &SubdivMesh, ctx: &DicingContext) -> Result<TriangleMesh, DiceError> {
    let level = control_level(mesh)?;
    if level.face_count() == 0 {
        return Ok(TriangleMesh::default());
    }
    let topology = Topology::build(&level)?;
    for (crease, &(a, b, _)) in mesh.creases.iter().enumerate() {
        let key = (a.min(b), a.max(b));
        if topology
            .edges
            .binary_search_by(|e| (e.lo, e.hi).cmp(&key))
            .is_err()
        {
            return Err(DiceError::CreaseNotAnEdge { crease, a, b });
        }
    }
    let levels = subdivision_level(&level, &topology, ctx);
    subdivide_to_limit(level, topology, levels)
}

/// `clamp(⌈log₂(L·k/m)⌉, 1, 6)`, lowered to fit [`MAX_QUADS_PER_PRIMITIVE`].
fn subdivision_level(level: &Level, topology: &Topology, ctx: &DicingContext) -> u32 {
    let used = || level.face_verts.iter().map(|&v| level.positions[v as usize]);
    let lo = used().fold(DVec3::splat(f64::INFINITY), DVec3::min);
    let hi = used().fold(DVec3::splat(f64::NEG_INFINITY), DVec3::max);
    let k = f64::from(pixels_per_unit(
        ctx,
        (0.5 * (lo + hi)).as_vec3(),
        (0.5 * (hi - lo).length()) as f32,
    ));
    let longest = topology
        .edges
        .iter()
        .map(|e| level.positions[e.lo as usize].distance(level.positions[e.hi as usize]))
        .fold(0.0, f64::max);
    let m = ctx.micropolygon_length;
    let m = if m > 0.0 { f64::from(m) } else { 1.0 };
    let pixels = longest * k / m;
    let mut levels = if pixels.is_nan() || pixels <= 2.0 {
        1
    } else {
        pixels.log2().ceil().clamp(1.0, f64::from(MAX_SUBDIVISION_LEVEL)) as u32
    };
    let first = level.face_verts.len() as u64;
    while levels > 1 && first.saturating_mul(1 << (2 * (levels - 1))) > MAX_QUADS_PER_PRIMITIVE {
        levels -= 1;
    }
    levels
}

/// `levels` Catmull–Clark steps (at least one), then the limit surface as triangles.
fn subdivide_to_limit(
    mut level: Level,
    mut topology: Topology,
    levels: u32,
) -> Result<TriangleMesh, DiceError> {
    for _ in 0..levels.max(1) {
        level = subdivide(&level, &topology)?;
        topology = Topology::build(&level)?;
    }
    Ok(limit_surface(&level, &topology))
}

/// One Catmull–Clark step with DeRose et al.'s semi-sharp creases.
fn subdivide(level: &Level, topology: &Topology) -> Result<Level, DiceError> {
    let (nv, ne, nf) = (level.positions.len(), topology.edges.len(), level.face_count());
    let vertices = (nv + ne + nf) as u64;
    if vertices > u64::from(u32::MAX) {
        return Err(DiceError::TooLarge { vertices });
    }
    let p = &level.positions;
    let face_points: Vec<DVec3> = (0..nf)
        .into_par_iter()
        .map(|f| {
            let face = level.face(f);
            face.iter().map(|&v| p[v as usize]).sum::<DVec3>() / face.len() as f64
        })
        .collect();
    let edge_points: Vec<DVec3> = topology
        .edges
        .par_iter()
        .map(|e| {
            let mid = 0.5 * (p[e.lo as usize] + p[e.hi as usize]);
            if e.is_boundary() || e.sharpness >= 1.0 {
                return mid;
            }
            let smooth =
                0.5 * mid + 0.25 * (face_points[e.faces[0] as usize] + face_points[e.faces[1] as usize]);
            if e.sharpness > 0.0 {
                smooth.lerp(mid, f64::from(e.sharpness))
            } else {
                smooth
            }
        })
        .collect();
    let vertex_points: Vec<DVec3> = (0..nv as u32)
        .into_par_iter()
        .map(|v| vertex_point(level, topology, &face_points, v))
        .collect();

    let mut face_start = Vec::with_capacity(level.face_verts.len() + 1);
    let mut face_verts = Vec::with_capacity(4 * level.face_verts.len());
    face_start.push(0);
    let (nv, ne) = (nv as u32, ne as u32);
    for f in 0..nf {
        let start = level.face_start[f];
        let n = level.face_start[f + 1] - start;
        for i in 0..n {
            let (c, prev) = (start + i, start + (i + n - 1) % n);
            face_verts.extend_from_slice(&[
                level.face_verts[c],
                nv + topology.corner_edge[c],
                nv + ne + f as u32,
                nv + topology.corner_edge[prev],
            ]);
            face_start.push(face_verts.len());
        }
    }
    let mut creases = Vec::new();
    for (id, e) in topology.edges.iter().enumerate() {
        if e.is_boundary() || e.sharpness <= 0.0 {
            continue;
        }
        for end in [e.lo, e.hi] {
            let s = topology.child_sharpness(id as u32, end);
            if s > 0.0 {
                creases.push((end, nv + id as u32, s));
            }
        }
    }
    creases.sort_unstable_by_key(|x| (x.0, x.1));
    let positions = vertex_points
        .into_iter()
        .chain(edge_points)
        .chain(face_points)
        .collect();
    Ok(Level {
        positions,
        face_start,
        face_verts,
        creases,
    })
}

/// The new position of an old vertex.
fn vertex_point(level: &Level, topology: &Topology, face_points: &[DVec3], v: u32) -> DVec3 {
    let p = &level.positions;
    let s = p[v as usize];
    let faces = topology.faces_of(v);
    if faces.is_empty() {
        return s;
    }
    let edges = topology.edges_of(v);
    let corner = topology.is_boundary_corner(v);
    let sharp = |e: &&u32| topology.edges[**e as usize].sharpness > 0.0;
    let child_sharp = |e: &&u32| topology.child_sharpness(**e, v) > 0.0;
    let parent_rule = rule(edges.iter().filter(sharp).count(), corner);
    let child_rule = rule(edges.iter().filter(child_sharp).count(), corner);
    let apply = |rule: Rule, child: bool| match rule {
        Rule::Smooth => {
            let n = edges.len() as f64;
            let q = faces.iter().map(|&f| face_points[f as usize]).sum::<DVec3>() / faces.len() as f64;
            let r = edges
                .iter()
                .map(|&e| 0.5 * (s + p[topology.edges[e as usize].other(v) as usize]))
                .sum::<DVec3>()
                / n;
            (q + 2.0 * r + (n - 3.0) * s) / n
        }
        Rule::Crease => {
            let ends: DVec3 = edges
                .iter()
                .filter(|e| if child { child_sharp(e) } else { sharp(e) })
                .map(|&e| p[topology.edges[e as usize].other(v) as usize])
                .sum();
            (ends + 6.0 * s) / 8.0
        }
        Rule::Corner => s,
    };
    if parent_rule == child_rule {
        return apply(parent_rule, false);
    }
    // The step on which semi-sharp edges fade: blend by their fractional sharpness.
    let (sum, count) = edges
        .iter()
        .filter(|e| sharp(e) && !child_sharp(e))
        .map(|&e| topology.edges[e as usize].sharpness.min(1.0))
        .fold((0.0f64, 0u32), |(sum, count), w| (sum + f64::from(w), count + 1));
    let w = if count == 0 { 1.0 } else { sum / f64::from(count) };
    apply(child_rule, true).lerp(apply(parent_rule, false), w)
}

/// Moves every vertex of an all-quad level to its limit position, computes limit normals and
/// triangulates.
fn limit_surface(level: &Level, topology: &Topology) -> TriangleMesh {
    let p = &level.positions;
    let n = p.len();
    let limits: Vec<DVec3> = (0..n as u32)
        .into_par_iter()
        .map(|v| limit_position(level, topology, v))
        .collect();

    let mut triangles = Vec::with_capacity(2 * level.face_count());
    let mut averaged = vec![DVec3::ZERO; n];
    for f in 0..level.face_count() {
        let q = level.face(f);
        if q.len() != 4 {
            continue;
        }
        let l = |i: usize| limits[q[i] as usize];
        let pair = if l(0).distance_squared(l(2)) <= l(1).distance_squared(l(3)) {
            [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
        } else {
            [[q[0], q[1], q[3]], [q[1], q[2], q[3]]]
        };
        for t in pair {
            let [a, b, c] = t.map(|i| limits[i as usize]);
            let area_normal = (b - a).cross(c - a);
            for i in t {
                averaged[i as usize] += area_normal;
            }
            triangles.push(t);
        }
    }
    let normals: Vec<DVec3> = (0..n as u32)
        .into_par_iter()
        .map_init(Vec::new, |ring, v| {
            let average = averaged[v as usize].normalize_or_zero();
            match tangent_normal(level, topology, v, ring) {
                Some(exact) if average == DVec3::ZERO || exact.dot(average) >= 0.0 => exact,
                Some(exact) => -exact,
                None if average != DVec3::ZERO => average,
                None => DVec3::Z,
            }
        })
        .collect();

    // Drop control points no face uses, keeping the order (control point i stays vertex i when all
    // control points are used).
    let mut used = vec![false; n];
    triangles.iter().flatten().for_each(|&i| used[i as usize] = true);
    let mut remap = vec![0u32; n];
    let mut positions = Vec::new();
    let mut kept_normals = Vec::new();
    for v in (0..n).filter(|&v| used[v]) {
        remap[v] = positions.len() as u32;
        positions.push(limits[v].as_vec3a());
        kept_normals.push(normals[v].as_vec3a());
    }
    for t in &mut triangles {
        for i in t.iter_mut() {
            *i = remap[*i as usize];
        }
    }
    TriangleMesh {
        positions,
        normals: Some(kept_normals),
        triangles,
    }
}

/// The Catmull–Clark limit position of vertex `v` of an all-quad level.
fn limit_position(level: &Level, topology: &Topology, v: u32) -> DVec3 {
    let p = &level.positions;
    let s = p[v as usize];
    let faces = topology.faces_of(v);
    if faces.is_empty() || topology.is_boundary_corner(v) {
        return s;
    }
    let edges = topology.edges_of(v);
    let on_boundary = edges.iter().any(|&e| topology.edges[e as usize].is_boundary());
    let sharp = || {
        edges
            .iter()
            .map(|&e| &topology.edges[e as usize])
            .filter(|e| e.sharpness > 0.0)
    };
    let sharp_count = sharp().count();
    let smooth = || {
        let n = edges.len() as f64;
        let ring: DVec3 = edges
            .iter()
            .map(|&e| p[topology.edges[e as usize].other(v) as usize])
            .sum();
        let diagonals: DVec3 = faces
            .iter()
            .filter_map(|&f| {
                let q = level.face(f as usize);
                let i = q.iter().position(|&x| x == v)?;
                Some(p[q[(i + 2) % q.len()] as usize])
            })
            .sum();
        (n * n * s + 4.0 * ring + diagonals) / (n * (n + 5.0))
    };
    if sharp_count < 2 {
        return smooth();
    }
    let sharp_limit = if sharp_count == 2 {
        (sharp().map(|e| p[e.other(v) as usize]).sum::<DVec3>() + 4.0 * s) / 6.0
    } else {
        s
    };
    // Semi-sharp edges left after the last step: blend by their mean sharpness.
    let mean = sharp().map(|e| f64::from(e.sharpness)).sum::<f64>() / sharp_count as f64;
    if on_boundary || mean >= 1.0 {
        sharp_limit
    } else {
        smooth().lerp(sharp_limit, mean)
    }
}

/// The exact limit normal of a smooth interior vertex (Halstead, Kass and DeRose 1993), from the
/// tangent masks over its ordered ring of quads; `None` elsewhere or when the ring is not a fan.
fn tangent_normal(
    level: &Level,
    topology: &Topology,
    v: u32,
    ring: &mut Vec<(u32, u32, u32)>,
) -> Option<DVec3> {
    let edges = topology.edges_of(v);
    let faces = topology.faces_of(v);
    let sharp = edges
        .iter()
        .filter(|&&e| topology.edges[e as usize].sharpness > 0.0)
        .count();
    if faces.len() < 3 || faces.len() != edges.len() || sharp >= 2 {
        return None;
    }
    // Each quad (v, a, d, b) in winding order: a the edge neighbour before the face, d the
    // opposite corner, b the edge neighbour after it. Order them so that each b is the next a.
    ring.clear();
    for &f in faces {
        let q = level.face(f as usize);
        let i = q.iter().position(|&x| x == v)?;
        if q.len() != 4 {
            return None;
        }
        ring.push((q[(i + 1) % 4], q[(i + 2) % 4], q[(i + 3) % 4]));
    }
    let n = ring.len();
    for k in 1..n {
        let b = ring[k - 1].2;
        let next = (k..n).find(|&j| ring[j].0 == b)?;
        ring.swap(k, next);
    }
    if ring[n - 1].2 != ring[0].0 {
        return None;
    }
    let p = &level.positions;
    let step = TAU / n as f64;
    let a_n = 1.0 + step.cos() + (0.5 * step).cos() * (2.0 * (9.0 + step.cos())).sqrt();
    let (mut t1, mut t2) = (DVec3::ZERO, DVec3::ZERO);
    let (mut sin, mut cos) = (0.0f64, 1.0f64);
    for (j, &(e, f, _)) in ring.iter().enumerate() {
        let (next_sin, next_cos) = (step * (j + 1) as f64).sin_cos();
        let (e, f) = (p[e as usize], p[f as usize]);
        t1 += a_n * cos * e + (cos + next_cos) * f;
        t2 += a_n * sin * e + (sin + next_sin) * f;
        (sin, cos) = (next_sin, next_cos);
    }
    let normal = t1.cross(t2).normalize_or_zero();
    (normal != DVec3::ZERO && normal.is_finite()).then_some(normal)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    use proptest::prelude::*;

    fn context(hint: DicingHint, fov: f32, distance: f32) -> DicingContext {
        let mut ctx = DicingContext::new(hint, fov, Format::new(640, 480));
        ctx.object_to_camera = Mat4::from_translation(Vec3::new(0.0, 0.0, distance));
        ctx
    }

    fn unit_sphere() -> Shape {
        Shape::Sphere {
            radius: 1.0,
            z_min: -1.0,
            z_max: 1.0,
            theta_max: 360.0,
        }
    }

    fn count(shape: &Shape, ctx: &DicingContext) -> f64 {
        dice(shape, ctx).unwrap().len() as f64
    }

    /// Every undirected edge with the number of triangles that use it.
    fn edge_uses(mesh: &TriangleMesh) -> HashMap<(u32, u32), u32> {
        let mut uses = HashMap::new();
        for t in &mesh.triangles {
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        uses
    }

    /// Asserts every edge is shared by exactly two triangles; returns V − E + F.
    fn assert_watertight(mesh: &TriangleMesh) -> i64 {
        let uses = edge_uses(mesh);
        for (edge, n) in &uses {
            assert_eq!(*n, 2, "edge {edge:?} used by {n} triangles");
        }
        let mut used = vec![false; mesh.positions.len()];
        mesh.triangles
            .iter()
            .flatten()
            .for_each(|&i| used[i as usize] = true);
        assert!(used.iter().all(|&u| u), "unreferenced vertices");
        mesh.positions.len() as i64 - uses.len() as i64 + mesh.triangles.len() as i64
    }

    fn area(mesh: &TriangleMesh) -> f64 {
        mesh.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| mesh.positions[i as usize].as_dvec3());
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    fn within(value: f64, expected: f64, relative: f64) -> bool {
        (value - expected).abs() <= relative * expected.abs()
    }

    // ---- rates ---------------------------------------------------------------------------

    #[test]
    fn perspective_count_quarters_when_distance_doubles() {
        let near = count(&unit_sphere(), &context(DicingHint::Perspective, 90.0, 10.0));
        let far = count(&unit_sphere(), &context(DicingHint::Perspective, 90.0, 20.0));
        assert!(within(near / far, 4.0, 0.2), "{near} / {far}");
    }

    #[test]
    fn orthographic_count_ignores_distance() {
        let near = count(&unit_sphere(), &context(DicingHint::Orthographic, 90.0, 10.0));
        let far = count(&unit_sphere(), &context(DicingHint::Orthographic, 90.0, 20.0));
        assert_eq!(near, far);
        // 640×480, default window (−4/3, 4/3): 240 pixels per unit → ⌈2π·240⌉ segments around.
        let ppu = pixels_per_unit(&context(DicingHint::Orthographic, 90.0, 10.0), Vec3::ZERO, 1.0);
        assert!((ppu - 240.0).abs() < 1e-3, "{ppu}");
    }

    #[test]
    fn spherical_count_follows_angular_size() {
        let near = count(&unit_sphere(), &context(DicingHint::Spherical, 90.0, 10.0));
        let far = count(&unit_sphere(), &context(DicingHint::Spherical, 90.0, 20.0));
        assert!(within(near / far, 4.0, 0.2), "{near} / {far}");
    }

    #[test]
    fn spherical_rate_is_the_shorter_side_over_the_field_of_view() {
        for (w, h) in [(640, 480), (480, 640), (1000, 250)] {
            for fov in [90.0f32, 170.0, 360.0] {
                let mut ctx = context(DicingHint::Spherical, fov, 10.0);
                ctx.format = Format::new(w, h);
                ctx.screen_window = ScreenWindow::default_for(ctx.format);
                let expected = w.min(h) as f32 / fov.to_radians() / (10.0 - 1.0);
                let got = pixels_per_unit(&ctx, Vec3::ZERO, 1.0);
                assert!(
                    (got / expected - 1.0).abs() < 1e-5,
                    "{w}×{h} fov {fov}: {got} vs {expected}"
                );
            }
        }
    }

    #[test]
    fn perspective_rate_matches_the_pinhole_formula() {
        // d = 1/tan(fov/2), nearest depth 10 − 2 (radius 1 scaled by 2), 240 pixels per screen unit.
        let mut ctx = context(DicingHint::Perspective, 40.0, 10.0);
        ctx.object_to_camera *= Mat4::from_scale(Vec3::new(1.0, 2.0, 0.5));
        let expected = 2.0 * 240.0 / (20.0f32.to_radians().tan() * 8.0);
        let got = pixels_per_unit(&ctx, Vec3::ZERO, 1.0);
        assert!((got / expected - 1.0).abs() < 1e-5, "{got} vs {expected}");
    }

    #[test]
    fn narrow_field_of_view_dices_finer() {
        let narrow = count(&unit_sphere(), &context(DicingHint::Perspective, 20.0, 20.0));
        let wide = count(&unit_sphere(), &context(DicingHint::Perspective, 90.0, 20.0));
        // d grows from 1 to 5.67: about 32 times the triangles.
        assert!(narrow > 20.0 * wide, "{narrow} vs {wide}");
    }

    #[test]
    fn doubling_micropolygon_length_quarters_the_count() {
        let mut ctx = context(DicingHint::Perspective, 90.0, 10.0);
        let fine = count(&unit_sphere(), &ctx);
        ctx.micropolygon_length = 2.0;
        let coarse = count(&unit_sphere(), &ctx);
        assert!(within(fine / coarse, 4.0, 0.2), "{fine} / {coarse}");
    }

    #[test]
    fn diced_edges_are_about_one_micropolygon_long() {
        for mpl in [1.0f32, 3.0] {
            let mut ctx = context(DicingHint::Perspective, 90.0, 10.0);
            ctx.micropolygon_length = mpl;
            let mesh = dice(&unit_sphere(), &ctx).unwrap();
            let ppu = pixels_per_unit(&ctx, Vec3::ZERO, 1.0);
            // The same measure the rate uses, and a real pinhole projection to raster.
            let raster = |p: Vec3A| {
                let c = ctx.object_to_camera.transform_point3(Vec3::from(p));
                glam::Vec2::new(c.x, c.y) / c.z * 240.0
            };
            let (mut by_rate, mut projected) = (0.0f32, 0.0f32);
            for (a, b) in edge_uses(&mesh)
                .keys()
                .map(|&(a, b)| (mesh.positions[a as usize], mesh.positions[b as usize]))
            {
                by_rate = by_rate.max(a.distance(b) * ppu);
                projected = projected.max(raster(a).distance(raster(b)));
            }
            assert!(
                by_rate <= 1.5 * mpl && by_rate >= 0.25 * mpl,
                "mpl {mpl}: {by_rate}"
            );
            assert!(
                projected <= 1.5 * mpl && projected >= 0.25 * mpl,
                "mpl {mpl}: {projected}"
            );
        }
    }

    #[test]
    fn subdivision_level_follows_the_rate() {
        let near = count(
            &Shape::Subdiv(cube()),
            &context(DicingHint::Perspective, 90.0, 40.0),
        );
        let far = count(
            &Shape::Subdiv(cube()),
            &context(DicingHint::Perspective, 90.0, 80.0),
        );
        assert_eq!(near / far, 4.0);
        let ctx = context(DicingHint::Perspective, 90.0, 40.0);
        let level = control_level(&cube()).unwrap();
        let topology = Topology::build(&level).unwrap();
        let levels = subdivision_level(&level, &topology, &ctx);
        let ppu = pixels_per_unit(&ctx, Vec3::ZERO, 3.0f32.sqrt());
        let edge_pixels = 2.0 * ppu / (1u32 << levels) as f32;
        assert!(
            edge_pixels <= 1.0 && edge_pixels > 0.5,
            "level {levels}: {edge_pixels} px"
        );
    }

    // ---- quadrics ------------------------------------------------------------------------

    /// A shape, its implicit surface distance, and whether a point lies within its limits.
    struct Case {
        shape: Shape,
        on_surface: fn(Vec3) -> f32,
        outward: fn(Vec3) -> Vec3,
        in_limits: fn(Vec3) -> bool,
        area: f64,
    }

    /// `lo ≤ x ≤ hi` up to rounding.
    fn between(x: f32, lo: f32, hi: f32) -> bool {
        (lo - 1e-5 * lo.abs().max(1.0)..=hi + 1e-5 * hi.abs().max(1.0)).contains(&x)
    }

    fn theta_of(p: Vec3) -> f32 {
        p.y.atan2(p.x).to_degrees().rem_euclid(360.0)
    }

    fn near_theta(p: Vec3, lo: f32, hi: f32) -> bool {
        let t = theta_of(p);
        let r = p.truncate().length();
        // θ = 0 may read as 360° and θ = 360° as 0°; the axis has no θ.
        let wraps = t > 360.0 - 1e-3 || (t < 1e-3 && hi >= 360.0);
        r < 1e-4 || (lo - 1e-3..=hi + 1e-3).contains(&t) || wraps
    }

    fn cases() -> Vec<Case> {
        use std::f64::consts::PI;
        vec![
            Case {
                shape: Shape::Sphere {
                    radius: 2.0,
                    z_min: -0.5,
                    z_max: 1.5,
                    theta_max: 270.0,
                },
                on_surface: |p| p.length() - 2.0,
                outward: |p| p,
                in_limits: |p| between(p.z, -0.5, 1.5) && near_theta(p, 0.0, 270.0),
                area: 2.0 * PI * 2.0 * 2.0 * 0.75,
            },
            Case {
                // Reversed z limits and a negative sweep: θ ∈ [−120°, 0].
                shape: Shape::Sphere {
                    radius: 1.0,
                    z_min: 0.8,
                    z_max: -1.0,
                    theta_max: -120.0,
                },
                on_surface: |p| p.length() - 1.0,
                outward: |p| p,
                in_limits: |p| p.z <= 0.8 + 1e-5 && near_theta(p, 240.0, 360.0),
                area: 2.0 * PI * 1.8 / 3.0,
            },
            Case {
                shape: Shape::Cylinder {
                    radius: 1.5,
                    z_min: -1.0,
                    z_max: 2.0,
                    theta_max: 270.0,
                },
                on_surface: |p| p.truncate().length() - 1.5,
                outward: |p| p.truncate().extend(0.0),
                in_limits: |p| between(p.z, -1.0, 2.0) && near_theta(p, 0.0, 270.0),
                area: 1.5 * 1.5 * PI * 3.0,
            },
            Case {
                shape: Shape::Cone {
                    height: 2.0,
                    radius: 1.0,
                    theta_max: 270.0,
                },
                // Radius at height z is 1 − z/2.
                on_surface: |p| p.truncate().length() - (1.0 - p.z / 2.0),
                outward: |p| p.truncate().extend(0.0) + Vec3::Z * 0.5,
                in_limits: |p| between(p.z, 0.0, 2.0) && near_theta(p, 0.0, 270.0),
                area: PI * 5.0f64.sqrt() * 0.75,
            },
            Case {
                shape: Shape::Cone {
                    height: -1.5,
                    radius: 2.0,
                    theta_max: 360.0,
                },
                on_surface: |p| p.truncate().length() - 2.0 * (1.0 - p.z / -1.5),
                outward: |p| p.truncate().extend(0.0) - Vec3::Z,
                in_limits: |p| between(p.z, -1.5, 0.0),
                area: PI * 2.0 * 6.25f64.sqrt(),
            },
            Case {
                shape: Shape::Disk {
                    height: 0.5,
                    radius: 2.0,
                    theta_max: 270.0,
                },
                on_surface: |p| p.z - 0.5,
                outward: |_| Vec3::Z,
                in_limits: |p| p.truncate().length() <= 2.0 + 1e-5 && near_theta(p, 0.0, 270.0),
                area: PI * 4.0 * 0.75,
            },
            Case {
                shape: Shape::Torus {
                    major_radius: 2.0,
                    minor_radius: 0.5,
                    phi_min: -45.0,
                    phi_max: 180.0,
                    theta_max: 270.0,
                },
                on_surface: |p| (Vec3::new(p.truncate().length() - 2.0, 0.0, p.z)).length() - 0.5,
                outward: |p| p - p.truncate().normalize().extend(0.0) * 2.0,
                in_limits: |p| {
                    let phi = p.z.atan2(p.truncate().length() - 2.0).to_degrees();
                    // atan2 may report φ = 180° as −180°.
                    (between(phi, -45.0, 180.0) || phi <= -180.0 + 1e-3) && near_theta(p, 0.0, 270.0)
                },
                // ρ·θ·(R·Δφ + ρ·(sin φmax − sin φmin)).
                area: 0.5 * 1.5 * PI * (2.0 * 1.25 * PI + 0.5 * (0.0 + 0.5f64.sqrt())),
            },
        ]
    }

    #[test]
    fn quadric_vertices_lie_on_their_surfaces_with_outward_unit_normals() {
        let ctx = context(DicingHint::Perspective, 90.0, 10.0);
        for case in cases() {
            let mesh = dice(&case.shape, &ctx).unwrap();
            assert!(!mesh.is_empty(), "{:?}", case.shape);
            let normals = mesh.normals.as_ref().unwrap();
            assert_eq!(normals.len(), mesh.positions.len());
            for (p, n) in mesh.positions.iter().zip(normals) {
                let p = Vec3::from(*p);
                let scale = p.length().max(1.0);
                assert!(
                    (case.on_surface)(p).abs() <= 1e-5 * scale,
                    "{:?}: {p} off the surface",
                    case.shape
                );
                assert!((case.in_limits)(p), "{:?}: {p} outside the limits", case.shape);
                assert!(
                    (n.length() - 1.0).abs() < 1e-5,
                    "{:?}: |n| = {}",
                    case.shape,
                    n.length()
                );
                let out = (case.outward)(p);
                if out.length() > 1e-3 {
                    assert!(
                        Vec3::from(*n).dot(out) > 0.0,
                        "{:?}: normal {n} not outward at {p}",
                        case.shape
                    );
                }
            }
            // Winding agrees with the normals.
            for t in &mesh.triangles {
                let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
                let face = (b - a).cross(c - a);
                let n = normals[t[0] as usize] + normals[t[1] as usize] + normals[t[2] as usize];
                assert!(
                    face.dot(n) >= 0.0,
                    "{:?}: triangle {t:?} winds against its normals",
                    case.shape
                );
            }
        }
    }

    #[test]
    fn partial_sweeps_have_the_analytic_area() {
        let ctx = context(DicingHint::Perspective, 90.0, 10.0);
        for case in cases() {
            let got = area(&dice(&case.shape, &ctx).unwrap());
            assert!(
                within(got, case.area, 0.01),
                "{:?}: area {got} vs {}",
                case.shape,
                case.area
            );
        }
        // A full torus and the sphere zone 2πR·(zmax − zmin)·θ/360.
        let torus = Shape::Torus {
            major_radius: 3.0,
            minor_radius: 1.0,
            phi_min: 0.0,
            phi_max: 360.0,
            theta_max: 360.0,
        };
        let got = area(&dice(&torus, &ctx).unwrap());
        assert!(
            within(got, 4.0 * std::f64::consts::PI.powi(2) * 3.0, 0.01),
            "torus area {got}"
        );
    }

    #[test]
    fn closed_sphere_and_torus_are_watertight() {
        for distance in [10.0, 200.0, 5000.0] {
            let ctx = context(DicingHint::Perspective, 90.0, distance);
            let sphere = dice(&unit_sphere(), &ctx).unwrap();
            assert_eq!(assert_watertight(&sphere), 2, "sphere at {distance}");
            let torus = Shape::Torus {
                major_radius: 1.0,
                minor_radius: 0.25,
                phi_min: 30.0,
                phi_max: 390.0,
                theta_max: -360.0,
            };
            let torus = dice(&torus, &ctx).unwrap();
            assert_eq!(assert_watertight(&torus), 0, "torus at {distance}");
        }
        // The coarsest full sphere: four segments around, two along: an octahedron.
        let far = dice(&unit_sphere(), &context(DicingHint::Perspective, 90.0, 1e9)).unwrap();
        assert_eq!((far.positions.len(), far.len()), (6, 8));
    }

    #[test]
    fn degenerate_quadrics_are_empty() {
        let ctx = context(DicingHint::Perspective, 90.0, 10.0);
        let shapes = [
            Shape::Sphere {
                radius: 0.0,
                z_min: -1.0,
                z_max: 1.0,
                theta_max: 360.0,
            },
            Shape::Sphere {
                radius: 1.0,
                z_min: 0.3,
                z_max: 0.3,
                theta_max: 360.0,
            },
            Shape::Sphere {
                radius: 1.0,
                z_min: 2.0,
                z_max: 3.0,
                theta_max: 360.0,
            },
            Shape::Sphere {
                radius: 1.0,
                z_min: -1.0,
                z_max: 1.0,
                theta_max: 0.0,
            },
            Shape::Sphere {
                radius: f32::NAN,
                z_min: -1.0,
                z_max: 1.0,
                theta_max: 360.0,
            },
            Shape::Cylinder {
                radius: 1.0,
                z_min: 1.0,
                z_max: 1.0,
                theta_max: 360.0,
            },
            Shape::Cone {
                height: 1.0,
                radius: 0.0,
                theta_max: 360.0,
            },
            Shape::Disk {
                height: 1.0,
                radius: 1.0,
                theta_max: f32::NAN,
            },
            Shape::Torus {
                major_radius: 1.0,
                minor_radius: 0.5,
                phi_min: 10.0,
                phi_max: 10.0,
                theta_max: 360.0,
            },
        ];
        for shape in shapes {
            assert!(dice(&shape, &ctx).unwrap().is_empty(), "{shape:?}");
        }
    }

    #[test]
    fn awkward_cameras_give_finite_bounded_meshes() {
        let mut contexts = Vec::new();
        for (hint, z) in [
            (DicingHint::Perspective, 0.0),  // camera at the centre
            (DicingHint::Perspective, 0.5),  // straddling
            (DicingHint::Perspective, -5.0), // behind
            (DicingHint::Perspective, 1e30), // very far
            (DicingHint::Spherical, 0.0),
            (DicingHint::Orthographic, -5.0),
        ] {
            let mut ctx = context(hint, 90.0, z);
            ctx.format = Format::new(8, 6);
            ctx.screen_window = ScreenWindow::default_for(ctx.format);
            contexts.push(ctx);
        }
        let mut broken = context(DicingHint::Perspective, f32::NAN, 10.0);
        broken.object_to_camera = Mat4::from_cols_array(&[f32::NAN; 16]);
        broken.format = Format::new(0, 0);
        broken.micropolygon_length = -1.0;
        contexts.push(broken);
        for ctx in contexts {
            let ppu = pixels_per_unit(&ctx, Vec3::ZERO, 1.0);
            assert!(ppu.is_finite() && ppu >= 0.0, "{ppu}");
            for shape in cases()
                .into_iter()
                .map(|c| c.shape)
                .chain([unit_sphere(), Shape::Subdiv(cube())])
            {
                let mesh = dice(&shape, &ctx).unwrap();
                assert!(mesh.positions.iter().all(|p| p.is_finite()));
                assert!(mesh.normals.iter().flatten().all(|n| n.is_finite()));
                assert!(mesh.len() as u64 <= 2 * MAX_QUADS_PER_PRIMITIVE);
            }
        }
        // A zero radius at the camera: the cap, not infinity.
        let ctx = context(DicingHint::Perspective, 90.0, 0.0);
        assert_eq!(pixels_per_unit(&ctx, Vec3::ZERO, 0.0), MAX_PIXELS_PER_UNIT);
    }

    fn quadric() -> impl Strategy<Value = Shape> {
        let length = prop_oneof![Just(0.0f32), -3.0f32..3.0, Just(1e20f32)];
        let angle = prop_oneof![Just(0.0f32), Just(360.0f32), -720.0f32..720.0];
        (
            0..5u8,
            length.clone(),
            length.clone(),
            length,
            angle.clone(),
            angle.clone(),
            angle,
        )
            .prop_map(|(kind, a, b, c, d, e, f)| match kind {
                0 => Shape::Sphere {
                    radius: a,
                    z_min: b,
                    z_max: c,
                    theta_max: d,
                },
                1 => Shape::Cylinder {
                    radius: a,
                    z_min: b,
                    z_max: c,
                    theta_max: d,
                },
                2 => Shape::Cone {
                    height: a,
                    radius: b,
                    theta_max: d,
                },
                3 => Shape::Disk {
                    height: a,
                    radius: b,
                    theta_max: d,
                },
                _ => Shape::Torus {
                    major_radius: a,
                    minor_radius: b,
                    phi_min: e,
                    phi_max: f,
                    theta_max: d,
                },
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(96))]

        #[test]
        fn dicing_never_panics_and_stays_finite(
            shape in quadric(),
            t in (-30.0f32..30.0, -30.0f32..30.0, prop_oneof![-30.0f32..30.0, Just(1e25f32)]),
            hint in prop_oneof![
                Just(DicingHint::Perspective), Just(DicingHint::Orthographic), Just(DicingHint::Spherical)
            ],
            // Narrow fields of view behind the camera dice at the caps: too slow for a property test.
            fov in prop_oneof![Just(f32::NAN), Just(-10.0f32), 45.0f32..400.0],
            mpl in 1.0f32..8.0,
        ) {
            let mut ctx = DicingContext::new(hint, fov, Format::new(6, 4));
            ctx.object_to_camera = Mat4::from_translation(Vec3::new(t.0, t.1, t.2));
            ctx.micropolygon_length = mpl;
            match dice(&shape, &ctx) {
                Ok(mesh) => {
                    prop_assert!(mesh.positions.iter().all(|p| p.is_finite()));
                    let normals = mesh.normals.clone().unwrap_or_default();
                    prop_assert!(normals.iter().all(|n| n.is_finite() && (n.length() - 1.0).abs() < 1e-4));
                    prop_assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < mesh.positions.len()));
                    prop_assert!(mesh.len() as u64 <= 2 * MAX_QUADS_PER_PRIMITIVE);
                }
                Err(e) => prop_assert_eq!(e, DiceError::NonFiniteGeometry),
            }
        }

        #[test]
        fn random_subdivision_meshes_never_panic(
            positions in prop::collection::vec((-2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0), 0..8),
            face_counts in prop::collection::vec(0u32..6, 0..5),
            face_indices in prop::collection::vec(0u32..9, 0..24),
            creases in prop::collection::vec((0u32..9, 0u32..9, -1.0f32..12.0), 0..4),
        ) {
            let mesh = SubdivMesh {
                positions: positions.into_iter().map(|(x, y, z)| Vec3::new(x, y, z)).collect(),
                face_counts,
                face_indices,
                creases,
                interpolate_boundary: true,
            };
            let ctx = context(DicingHint::Perspective, 90.0, 30.0);
            if let Ok(out) = dice(&Shape::Subdiv(mesh), &ctx) {
                prop_assert!(out.positions.iter().all(|p| p.is_finite()));
                prop_assert!(out.normals.iter().flatten().all(|n| n.is_finite()));
            }
        }
    }

    // ---- Catmull–Clark -------------------------------------------------------------------

    /// The cube [−1, 1]³, faces wound counter-clockwise seen from outside.
    fn cube() -> SubdivMesh {
        let positions = (0..8)
            .map(|i| {
                Vec3::new(
                    if i & 1 == 0 { -1.0 } else { 1.0 },
                    if i & 2 == 0 { -1.0 } else { 1.0 },
                    if i & 4 == 0 { -1.0 } else { 1.0 },
                )
            })
            .collect();
        let faces: [[u32; 4]; 6] = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        SubdivMesh {
            positions,
            face_counts: vec![4; 6],
            face_indices: faces.concat(),
            creases: Vec::new(),
            interpolate_boundary: true,
        }
    }

    /// An `n × n` grid of unit quads in z = 0, with a function to displace it.
    fn grid(n: u32, height: impl Fn(f32, f32) -> f32) -> SubdivMesh {
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f32 - n as f32 / 2.0, j as f32 - n as f32 / 2.0);
                positions.push(Vec3::new(x, y, height(x, y)));
            }
        }
        let at = |i: u32, j: u32| j * (n + 1) + i;
        let mut face_indices = Vec::new();
        for j in 0..n {
            for i in 0..n {
                face_indices.extend([at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        SubdivMesh {
            positions,
            face_counts: vec![4; (n * n) as usize],
            face_indices,
            creases: Vec::new(),
            interpolate_boundary: true,
        }
    }

    fn at_level(mesh: &SubdivMesh, levels: u32) -> TriangleMesh {
        let level = control_level(mesh).unwrap();
        let topology = Topology::build(&level).unwrap();
        subdivide_to_limit(level, topology, levels).unwrap()
    }

    /// Subdivides without moving to the limit.
    fn refine(mesh: &SubdivMesh, levels: u32) -> Level {
        let mut level = control_level(mesh).unwrap();
        for _ in 0..levels {
            let topology = Topology::build(&level).unwrap();
            level = subdivide(&level, &topology).unwrap();
        }
        level
    }

    /// The fold of [`folded`] with a bump, so that its boundary and crease curves are not straight.
    fn bumpy_fold(sharpness: f32) -> SubdivMesh {
        let mut mesh = folded(sharpness);
        for p in &mut mesh.positions {
            p.z += 0.3 * (1.3 * p.x).sin() * (0.7 * p.y + 0.4).cos();
        }
        mesh
    }

    #[test]
    fn limit_positions_match_deep_refinement() {
        // Control point i is vertex i at every level, so refining 7 times (error ~4⁻⁷) approximates
        // its limit independently of the limit masks. A semi-sharp crease of sharpness 2 is only
        // exact from level 2 on (see the module documentation).
        let meshes = [
            ("cube", cube(), vec![1, 2, 4]),
            ("pyramid", pyramid(), vec![1, 2, 4]),
            ("sharp fold", bumpy_fold(10.0), vec![1, 3]),
            ("semi-sharp fold", bumpy_fold(2.0), vec![2, 3]),
        ];
        for (name, mesh, levels) in meshes {
            let deep = refine(&mesh, 7);
            for levels in levels {
                let limit = at_level(&mesh, levels);
                for (v, expected) in deep.positions.iter().take(mesh.positions.len()).enumerate() {
                    let got = limit.positions[v].as_dvec3();
                    assert!(
                        got.distance(*expected) < 1e-3,
                        "{name}, level {levels}, vertex {v}: {got} vs {expected}"
                    );
                }
            }
        }
        // Symmetry: each cube corner's limit is (±c, ±c, ±c), with c well inside the cube.
        let c = at_level(&cube(), 1).positions[7];
        assert!(
            (c.x - c.y).abs() < 1e-6 && (c.y - c.z).abs() < 1e-6 && c.x > 0.3 && c.x < 0.9,
            "{c}"
        );
    }

    #[test]
    fn cube_limit_surface_is_inside_the_cube_with_outward_normals_and_closed() {
        let mesh = at_level(&cube(), 3);
        assert_eq!(mesh.len(), 6 * 4usize.pow(3) * 2);
        assert_eq!(assert_watertight(&mesh), 2);
        let normals = mesh.normals.as_ref().unwrap();
        for (p, n) in mesh.positions.iter().zip(normals) {
            assert!(p.abs().max_element() < 1.0, "{p}");
            // Convex, centred at the origin: outward means along the position.
            assert!(n.dot(*p) > 0.0 && (n.length() - 1.0).abs() < 1e-5, "{p}: {n}");
        }
        // Limit normals of smooth vertices agree with the limit surface's facets.
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            let face = (b - a).cross(c - a).normalize();
            for &i in t {
                assert!(face.dot(normals[i as usize]) > 0.9, "{t:?}");
            }
        }
    }

    #[test]
    fn flat_grid_stays_flat() {
        let mesh = at_level(&grid(4, |_, _| 0.0), 3);
        for (p, n) in mesh.positions.iter().zip(mesh.normals.as_ref().unwrap()) {
            assert!(p.z.abs() < 1e-6, "{p}");
            assert!((n.z - 1.0).abs() < 1e-6, "{n}");
            assert!(p.x.abs() <= 2.0 + 1e-6 && p.y.abs() <= 2.0 + 1e-6, "{p}");
        }
        // Interpolated boundary: the grid's corners stay put, its edges stay on the square.
        assert!(
            mesh.positions
                .iter()
                .any(|p| (*p - Vec3A::new(2.0, 2.0, 0.0)).length() < 1e-6)
        );
    }

    /// A grid folded along y = 0 (z = |y|), with the fold's edges creased at `sharpness`.
    fn folded(sharpness: f32) -> SubdivMesh {
        let mut mesh = grid(4, |_, y| y.abs());
        let row = |i: u32| 2 * 5 + i;
        mesh.creases = (0..4).map(|i| (row(i), row(i + 1), sharpness)).collect();
        mesh
    }

    /// The largest z among limit vertices on the fold line y = 0.
    fn fold_height(mesh: &TriangleMesh) -> f32 {
        mesh.positions
            .iter()
            .filter(|p| p.y.abs() < 1e-6)
            .map(|p| p.z)
            .fold(0.0, f32::max)
    }

    #[test]
    fn infinitely_sharp_crease_stays_straight() {
        let sharp = at_level(&folded(10.0), 3);
        let on_line: Vec<_> = sharp.positions.iter().filter(|p| p.y.abs() < 1e-6).collect();
        assert_eq!(on_line.len(), 4 * 8 + 1);
        assert!(
            on_line
                .iter()
                .all(|p| p.z.abs() < 1e-6 && p.x.abs() <= 2.0 + 1e-6),
            "{on_line:?}"
        );
        // Without the crease the fold rounds off upward.
        assert!(fold_height(&at_level(&folded(0.0), 3)) > 0.1);
    }

    #[test]
    fn fractional_sharpness_blends_linearly() {
        // For s ≤ 1 every rule of the first step is linear in s and all children are smooth, so
        // the limit surface is linear in s too.
        let [smooth, half, sharp] = [0.0, 0.5, 1.0].map(|s| at_level(&bumpy_fold(s), 3));
        for ((a, m), b) in smooth.positions.iter().zip(&half.positions).zip(&sharp.positions) {
            assert!(m.distance(0.5 * (*a + *b)) < 1e-5, "{m} vs {a} and {b}");
        }
        assert!(
            smooth
                .positions
                .iter()
                .zip(&sharp.positions)
                .any(|(a, b)| a.distance(*b) > 0.05)
        );
    }

    #[test]
    fn crease_sharpness_decays_chaikin_style() {
        let mut mesh = grid(4, |_, _| 0.0);
        mesh.creases = vec![(10, 11, 1.0), (11, 12, 3.0), (12, 13, 3.0), (13, 14, 1.0)];
        let level = control_level(&mesh).unwrap();
        let topology = Topology::build(&level).unwrap();
        let edge = |a: u32, b: u32| {
            topology
                .edges
                .binary_search_by(|e| (e.lo, e.hi).cmp(&(a, b)))
                .unwrap() as u32
        };
        // Where the 3 meets the 1: ¾·3 + ¼·1 − 1 and ¾·1 + ¼·3 − 1.
        assert_eq!(topology.child_sharpness(edge(11, 12), 11), 1.5);
        assert_eq!(topology.child_sharpness(edge(10, 11), 11), 0.5);
        // Between two 3s: 3 − 1. Where the crease meets only the (infinitely sharp) boundary: s − 1.
        assert_eq!(topology.child_sharpness(edge(11, 12), 12), 2.0);
        assert_eq!(topology.child_sharpness(edge(10, 11), 10), 0.0);
        // Boundary edges stay infinitely sharp, smooth edges smooth.
        assert_eq!(topology.child_sharpness(edge(0, 1), 0), f32::INFINITY);
        assert_eq!(topology.child_sharpness(edge(6, 7), 6), 0.0);
        // And the children carry it.
        let child = subdivide(&level, &topology).unwrap();
        let ne = level.positions.len() as u32;
        assert!(
            child.creases.contains(&(11, ne + edge(11, 12), 1.5)),
            "{:?}",
            child.creases
        );
    }

    #[test]
    fn semi_sharp_crease_lies_between_smooth_and_sharp() {
        let heights: Vec<f32> = [0.0, 0.5, 1.0, 2.0, 10.0]
            .iter()
            .map(|&s| fold_height(&at_level(&folded(s), 4)))
            .collect();
        for w in heights.windows(2) {
            assert!(
                w[0] > w[1],
                "fold heights not decreasing with sharpness: {heights:?}"
            );
        }
        assert!(heights[4].abs() < 1e-6);
    }

    /// A pentagonal pyramid: one pentagon and five triangles, apex (valence 5) at vertex 5.
    fn pyramid() -> SubdivMesh {
        let mut positions: Vec<Vec3> = (0..5)
            .map(|i| {
                let a = TAU as f32 * i as f32 / 5.0;
                Vec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        positions.push(Vec3::new(0.2, -0.1, 1.5));
        let mut face_indices = vec![4, 3, 2, 1, 0];
        for i in 0..5 {
            face_indices.extend([i, (i + 1) % 5, 5]);
        }
        SubdivMesh {
            positions,
            face_counts: [5].into_iter().chain([3; 5]).collect(),
            face_indices,
            creases: Vec::new(),
            interpolate_boundary: false,
        }
    }

    #[test]
    fn ngons_and_triangles_become_quads_and_stay_closed() {
        let out = at_level(&pyramid(), 2);
        assert_eq!(out.len(), (5 + 5 * 3) * 4 * 2);
        assert_eq!(assert_watertight(&out), 2);
    }

    #[test]
    fn limit_normals_match_the_tangent_plane_of_deep_refinement() {
        // Asymmetric control meshes: a skewed cube (valence 3) and the pyramid (valences 3 and 5).
        let mut skewed = cube();
        for (i, p) in skewed.positions.iter_mut().enumerate() {
            *p += 0.3
                * Vec3::new(
                    (i as f32 * 1.7).sin(),
                    (i as f32 * 2.3).cos(),
                    (i as f32 * 0.9).sin(),
                );
        }
        for (mesh, vertices) in [(skewed, 0..8u32), (pyramid(), 0..6u32)] {
            // Level 1, where the rings are least regular and a wrong mask shows most.
            let coarse = at_level(&mesh, 1);
            let fine = at_level(&mesh, 7);
            for v in vertices {
                // The facets around v at level 7 lie nearly in the limit tangent plane.
                let around: Vec3A = fine
                    .triangles
                    .iter()
                    .filter(|t| t.contains(&v))
                    .map(|t| {
                        let [a, b, c] = t.map(|i| fine.positions[i as usize]);
                        (b - a).cross(c - a).normalize()
                    })
                    .sum();
                let exact = coarse.normals.as_ref().unwrap()[v as usize];
                let cosine = exact.dot(around.normalize());
                assert!(
                    cosine > 0.99995,
                    "vertex {v}: {exact} vs {} (cos {cosine})",
                    around.normalize()
                );
            }
        }
    }

    #[test]
    fn out_of_range_index_names_the_face() {
        let mut mesh = cube();
        mesh.face_indices[6] = 8;
        let err = dice(
            &Shape::Subdiv(mesh),
            &context(DicingHint::Perspective, 90.0, 10.0),
        )
        .unwrap_err();
        assert_eq!(
            err,
            DiceError::IndexOutOfRange {
                face: 1,
                index: 8,
                vertex_count: 8
            }
        );
        assert!(err.to_string().contains("face 1"));
    }

    #[test]
    fn malformed_subdivision_meshes_are_refused() {
        let ctx = context(DicingHint::Perspective, 90.0, 10.0);
        // Three triangles on the edge (0, 1).
        let fan = SubdivMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::NEG_Y],
            face_counts: vec![3, 3, 3],
            face_indices: vec![0, 1, 2, 1, 0, 3, 0, 1, 4],
            ..SubdivMesh::default()
        };
        assert_eq!(
            dice(&Shape::Subdiv(fan), &ctx),
            Err(DiceError::NonManifoldEdge { a: 0, b: 1, faces: 3 })
        );
        let mut repeated = cube();
        repeated.face_indices[2] = 0;
        assert_eq!(
            dice(&Shape::Subdiv(repeated), &ctx),
            Err(DiceError::RepeatedVertex { face: 0, vertex: 0 })
        );
        let mut short = cube();
        short.face_counts[5] = 3;
        assert!(matches!(
            dice(&Shape::Subdiv(short), &ctx),
            Err(DiceError::FaceIndexCount { .. })
        ));
        let mut crease = cube();
        crease.creases = vec![(0, 7, 2.0)];
        assert_eq!(
            dice(&Shape::Subdiv(crease), &ctx),
            Err(DiceError::CreaseNotAnEdge {
                crease: 0,
                a: 0,
                b: 7
            })
        );
        let mut nan = cube();
        nan.positions[3].x = f32::NAN;
        assert_eq!(
            dice(&Shape::Subdiv(nan), &ctx),
            Err(DiceError::NonFinitePosition { vertex: 3 })
        );
        assert!(
            dice(&Shape::Subdiv(SubdivMesh::default()), &ctx)
                .unwrap()
                .is_empty()
        );
    }

    #[test]
    fn meshes_pass_through_with_their_normals() {
        let mesh = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: Some(vec![Vec3::Z; 3]),
            triangles: vec![[0, 1, 2]],
        };
        let ctx = context(DicingHint::Perspective, 90.0, 10.0);
        let out = dice(&Shape::Mesh(mesh.clone()), &ctx).unwrap();
        assert_eq!(out.triangles, mesh.triangles);
        assert_eq!(out.positions[1], Vec3A::X);
        assert_eq!(out.normals, Some(vec![Vec3A::Z; 3]));
        let bad = Mesh {
            triangles: vec![[0, 1, 2], [2, 1, 3]],
            ..mesh
        };
        assert_eq!(
            dice(&Shape::Mesh(bad), &ctx),
            Err(DiceError::MeshIndexOutOfRange {
                triangle: 1,
                index: 3,
                vertex_count: 3
            })
        );
    }
}
