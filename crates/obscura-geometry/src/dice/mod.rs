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
//! # Bounded by what the primitive covers on screen
//!
//! The nearest-point rate alone explodes for geometry behind, around or very near the camera (a
//! sphere of radius 0.2 just behind the lens would be measured at `ε·ρ`, a sky sphere around the
//! camera likewise: millions of triangles each). As RenderMan dices off-screen geometry coarsely, the
//! rate is also capped by the primitive's on-screen coverage `P`, in pixels, of its bounding sphere:
//!
//! | dicing hint | `P` |
//! |---|---|
//! | `Perspective` | 0 when the sphere is wholly behind the camera (`c.z + ρ ≤ 0`) or wholly outside one of the frustum's four side planes (`x·d = r·z`, `x·d = l·z`, `y·d = t·z`, `y·d = b·z`, through the eye); the whole image when it reaches the camera plane (`c.z − ρ ≤ ε·ρ`); otherwise its screen square — centre `d·(c.x, c.y)/c.z`, half-side `d·ρ/(c.z − ρ)` — clipped to the screen window, in pixels |
//! | `Orthographic` | 0 when wholly behind; otherwise the square `(c.x, c.y) ± ρ` clipped to the screen window |
//! | `Spherical` | the whole image when the sphere holds the camera; otherwise the disc of angular radius `asin(ρ/‖c‖)`, at most the whole image |
//!
//! and the rate becomes `k' = min(k, √(F·max(P, P₀)/(2π²)) / ρ₀)` (`ρ₀` the object-space radius,
//! `F` = [`COVERAGE_FACTOR`], `P₀` = [`OFF_SCREEN_PIXELS`]): a sphere of radius `ρ₀`, whose (u, v) grid
//! spans the arcs `2πρ₀ × πρ₀`, then holds at most `F·max(P, P₀)` micropolygons of one pixel —
//! several per pixel it covers, and about a thousand for a primitive off screen (which shadows and
//! reflections still see). The micropolygon
//! length is at least [`MIN_MICROPOLYGON_LENGTH`] pixels, so `micropolygonlength 1e-30` dices as
//! `1/16` pixel would. What is left unbounded (a polygon mesh passes through as given) is held by the
//! scene's triangle budget ([`TriangleBudget`]).
//!
//! # Piece by piece: quadrics on a fitted grid
//!
//! One rate for a whole primitive that holds the camera spreads the image's `F·P` micropolygons over
//! all of it, behind the camera as densely as in view (nebula.rib's star-field sphere: 613,088
//! triangles at 160×120, most of them out of view). A quadric whose uniform grid holds more than
//! [`UNIFORM_GRID_QUADS`] quads is therefore measured cell by cell:
//!
//! 1. `[0, 1]²` is cut into `B_u × B_v` equal cells, `B_u = min(32, n_u)`, `B_v = min(16, n_v)`
//!    (`n_u × n_v` the uniform grid).
//! 2. Each cell is sampled at 5 × 5 points of the surface: its bounding sphere (`c_i`, `ρ_i`) is
//!    the samples' box centre and farthest sample, grown by half the longest step between
//!    neighbouring samples; its arcs `A_u`, `A_v` are the longest sampled polylines along u and v.
//! 3. Its rate is `k_i = min(k(c_i, ρ_i), cap_i)`, `k` the uncapped rate of the first table, and
//!    `cap_i` the whole primitive's `k'` when `P(c_i, ρ_i) > 0` (the cell reaches the image: behind
//!    the camera too for a 360° `Spherical` projection), else the whole primitive's off-screen rate
//!    `min(k, √(F·P₀/(2π²))/ρ₀)`. No cell is diced finer than the whole primitive would be.
//! 4. Column `a` gets `max_b ⌈A_u·k_i/m⌉` segments (at least 1), row `b` gets `max_a ⌈A_v·k_i/m⌉`;
//!    the u lines are each column's even subdivision one after the other, the v lines likewise. A
//!    direction over [`MAX_SEGMENTS`] is scaled down.
//! 5. The fitted grid replaces the uniform one when it holds at most half its quads. A primitive
//!    mostly in view keeps its uniform grid, so its limb stays as fine as its nearest point.
//!
//! The grid is still one tensor product of u and v lines, so neighbouring cells share every vertex
//! (no cracks), and seams, poles and winding are the uniform grid's.
//!
//! # Files
//!
//! | module | holds |
//! |---|---|
//! | `quadric` | spheres, cylinders, cones, disks and tori: segment counts and the (u, v) grid, uniform or fitted cell by cell |
//! | `subdivision` | Catmull–Clark with semi-sharp creases: levels, topology, the limit surface |
//! | `polygon` | polygon meshes, checked and passed through |
//! | `classic_quadrics` | hyperboloids and paraboloids, on `quadric`'s grid |
//! | `patch` | bicubic Bézier patches (`Patch`, `PatchMesh`, the teapot) |
//! | `nurbs` | NURBS patches (`NuPatch`) |
//! | `curves` | curves as ribbons and points as discs, facing the camera |
//! | `blobby` | implicit surfaces of blobs, by marching tetrahedra |

mod blobby;
mod classic_quadrics;
mod curves;
mod nurbs;
mod patch;
mod polygon;
mod quadric;
mod subdivision;
#[cfg(test)]
mod tests;

use glam::{Mat4, Vec2, Vec3};
use obscura_scene::Shape;
use obscura_sdk::{DicingHint, Format, ScreenWindow};

use self::blobby::blobby;
use self::classic_quadrics::{hyperboloid, paraboloid};
use self::curves::{curves, points};
use self::nurbs::nu_patch;
use self::patch::{patches, patches_with_st};
use self::polygon::pass_through;
use self::quadric::{cone, cylinder, disk, sphere, torus};
use self::subdivision::subdivision;
use crate::ray::TriangleMesh;

/// The most segments along one parametric direction of a quadric.
pub const MAX_SEGMENTS: u32 = 4096;

/// The fewest segments along a full 360° sweep (a partial sweep gets this times its fraction of a
/// turn, and at least one).
pub const MIN_SEGMENTS_PER_TURN: u32 = 4;

/// The most quads one primitive dices into (a quadric's `n_u·n_v`, a subdivision surface's faces
/// after the last level): the memory bound for a primitive that surrounds the camera.
pub const MAX_QUADS_PER_PRIMITIVE: u64 = 1 << 22;

/// A quadric whose uniform grid holds more quads than this is diced on a grid fitted cell by cell
/// (see the module documentation); smaller ones keep the uniform grid.
pub const UNIFORM_GRID_QUADS: u64 = 4096;

/// The deepest Catmull–Clark subdivision level.
pub const MAX_SUBDIVISION_LEVEL: u32 = 6;

/// The nearest a primitive is assumed to be, as a fraction of its camera-space bounding radius
/// (the `ε` of the module documentation).
pub const NEAR_FRACTION: f32 = 0.05;

/// The cap on [`pixels_per_unit`].
pub const MAX_PIXELS_PER_UNIT: f32 = 1e30;

/// The micropolygons per covered pixel the bounding sphere's area may hold (the `F` of the module
/// documentation): with the sphere's back half and the square around its disc, a primitive in view
/// keeps its nearest-point rate.
pub const COVERAGE_FACTOR: f32 = 16.0;

/// The pixels an off-screen primitive is measured as covering (the `P₀` of the module documentation):
/// `F·P₀` = 1024 micropolygons, a 32 × 32 grid.
pub const OFF_SCREEN_PIXELS: f32 = 64.0;

/// The shortest micropolygon length, in pixels: finer `micropolygonlength` values dice as this.
pub const MIN_MICROPOLYGON_LENGTH: f32 = 0.0625;

/// The most triangles a scene dices into by default ([`TriangleBudget`]): 0.6 to 3.5 GiB with the
/// BVH, depending on the geometry ([`TRIANGLE_BYTES`]).
pub const DEFAULT_SCENE_TRIANGLES: u64 = 8_000_000;

/// The address space a render takes per diced triangle at its peak (while the accelerator is built),
/// the most measured: 442 bytes for ten bilinear patches (5.9 M triangles, a 2.55 GiB peak of
/// `VmPeak` against 0.22 GiB for a one-triangle scene; 303 bytes of it resident), 71 bytes for one
/// sphere of 8.4 M triangles. [`TriangleBudget::within_memory`] divides the memory a job may use by it.
pub const TRIANGLE_BYTES: u64 = 450;

/// The address space of a render before any triangle: the one-triangle scene's peak above, rounded
/// up (threads' stacks and allocator arenas, mostly reserved rather than resident).
pub const RENDER_BASE_BYTES: u64 = 256 << 20;

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
    /// The scene's triangle budget ([`TriangleBudget`]) cannot hold this primitive.
    #[error(
        "this primitive dices into {triangles} triangles, which the scene cannot hold: {used} are diced \
         already and the budget is {limit}, {bound}, or raise this primitive's Attribute \"dice\" \
         \"micropolygonlength\""
    )]
    SceneBudget {
        /// The primitive's triangles.
        triangles: u64,
        /// The scene's triangles before it.
        used: u64,
        /// The budget.
        limit: u64,
        /// What set the budget.
        bound: BudgetBound,
    },
    /// The diced geometry overflowed to infinity (parameters near the limits of `f32`).
    #[error("diced geometry is not finite (parameters too large)")]
    NonFiniteGeometry,
}

/// What set a [`TriangleBudget`]'s limit; its `Display` says what to raise.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BudgetBound {
    /// The renderer's option (`--max-triangles`).
    Option,
    /// The memory the job may use: `memory` (human-readable) according to `source`, at
    /// [`TRIANGLE_BYTES`] a triangle after [`RENDER_BASE_BYTES`].
    Memory {
        /// The memory, e.g. `2.0 GiB`.
        memory: String,
        /// Where that figure comes from (`OBSCURA_MEMORY_LIMIT=2G`, the address-space limit, …).
        source: String,
    },
}

impl std::fmt::Display for BudgetBound {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BudgetBound::Option => f.write_str("set by --max-triangles: raise it if the memory is there"),
            BudgetBound::Memory { memory, source } => write!(
                f,
                "what {memory} of memory holds at {TRIANGLE_BYTES} bytes a triangle ({source}): give \
                 the job more memory"
            ),
        }
    }
}

/// The triangles a whole scene may dice into, shared by the threads dicing its primitives: each
/// diced primitive takes its count, and the first to go over the limit is refused
/// ([`DiceError::SceneBudget`]), so that a scene too large for memory stops with a message naming
/// that primitive instead of being killed.
#[derive(Debug)]
pub struct TriangleBudget {
    limit: u64,
    bound: BudgetBound,
    used: std::sync::atomic::AtomicU64,
}

impl TriangleBudget {
    /// A budget of `limit` triangles, set by the renderer's option.
    #[must_use]
    pub fn new(limit: u64) -> Self {
        TriangleBudget {
            limit,
            bound: BudgetBound::Option,
            used: std::sync::atomic::AtomicU64::new(0),
        }
    }

    /// A budget of `max_triangles`, or fewer when `memory` (bytes the job may use, and where that
    /// figure comes from) holds fewer: `(memory − RENDER_BASE_BYTES) / TRIANGLE_BYTES`. A scene too
    /// large for the memory then stops with a message naming the primitive, where the allocator
    /// would have aborted the process.
    #[must_use]
    pub fn within_memory(max_triangles: u64, memory: Option<(u64, &str)>) -> Self {
        let mut budget = TriangleBudget::new(max_triangles);
        if let Some((bytes, source)) = memory {
            let held = bytes.saturating_sub(RENDER_BASE_BYTES) / TRIANGLE_BYTES;
            if held < max_triangles {
                budget.limit = held;
                budget.bound = BudgetBound::Memory {
                    memory: format!("{:.1} GiB", bytes as f64 / f64::from(1u32 << 30)),
                    source: source.to_string(),
                };
            }
        }
        budget
    }

    /// The most triangles the scene may hold.
    #[must_use]
    pub fn limit(&self) -> u64 {
        self.limit
    }

    /// Takes `triangles` from the budget.
    ///
    /// # Errors
    /// [`DiceError::SceneBudget`] when the scene would then hold more than the limit (nothing is
    /// taken).
    pub fn take(&self, triangles: u64) -> Result<(), DiceError> {
        use std::sync::atomic::Ordering;
        self.used
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |used| {
                used.checked_add(triangles).filter(|&t| t <= self.limit)
            })
            .map(|_| ())
            .map_err(|used| DiceError::SceneBudget {
                triangles,
                used,
                limit: self.limit,
                bound: self.bound.clone(),
            })
    }

    /// The triangles taken so far.
    #[must_use]
    pub fn used(&self) -> u64 {
        self.used.load(std::sync::atomic::Ordering::SeqCst)
    }

    /// True once the scene is at its limit: no further primitive can be diced.
    #[must_use]
    pub fn exhausted(&self) -> bool {
        self.used() >= self.limit
    }
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
    diced(shape, ctx, false).map(|(mesh, _)| mesh)
}

/// The shape as triangles and, with `with_st` and for the primitives that carry them, each vertex's
/// texture coordinates `(s, t)` (see [`dice_with_st`]).
fn diced(
    shape: &Shape,
    ctx: &DicingContext,
    with_st: bool,
) -> Result<(TriangleMesh, Option<Vec<Vec2>>), DiceError> {
    let plain = |mesh: TriangleMesh| (mesh, None);
    let (mesh, st) = match shape {
        Shape::Sphere {
            radius,
            z_min,
            z_max,
            theta_max,
        } => sphere(*radius, *z_min, *z_max, *theta_max, ctx, with_st),
        Shape::Cylinder {
            radius,
            z_min,
            z_max,
            theta_max,
        } => cylinder(*radius, *z_min, *z_max, *theta_max, ctx, with_st),
        Shape::Cone {
            height,
            radius,
            theta_max,
        } => cone(*height, *radius, *theta_max, ctx, with_st),
        Shape::Disk {
            height,
            radius,
            theta_max,
        } => disk(*height, *radius, *theta_max, ctx, with_st),
        Shape::Torus {
            major_radius,
            minor_radius,
            phi_min,
            phi_max,
            theta_max,
        } => torus(
            *major_radius,
            *minor_radius,
            *phi_min,
            *phi_max,
            *theta_max,
            ctx,
            with_st,
        ),
        Shape::Hyperboloid {
            point1,
            point2,
            theta_max,
        } => hyperboloid(*point1, *point2, *theta_max, ctx, with_st),
        Shape::Paraboloid {
            radius,
            z_min,
            z_max,
            theta_max,
        } => paraboloid(*radius, *z_min, *z_max, *theta_max, ctx, with_st),
        Shape::Patches(list) if with_st => {
            let (mesh, st) = patches_with_st(list, ctx);
            (mesh, Some(st))
        }
        Shape::Patches(list) => plain(patches(list, ctx)),
        Shape::NuPatch(patch) => plain(nu_patch(patch, ctx)),
        Shape::Curves(c) => plain(curves(c, ctx)),
        Shape::Points(p) => plain(points(p, ctx)),
        Shape::Blobby(b) => plain(blobby(b, ctx)),
        Shape::Mesh(mesh) => plain(pass_through(mesh)?),
        Shape::Subdiv(mesh) => plain(subdivision(mesh, ctx)?),
    };
    Ok((finite(mesh)?, st))
}

/// `mesh`, when every vertex and normal is finite.
fn finite(mesh: TriangleMesh) -> Result<TriangleMesh, DiceError> {
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

/// As [`dice`], with each vertex's texture coordinates `(s, t)` in the RenderMan Interface's
/// convention (`t = 0` a texture's top row) for the primitives that carry them: patches (`Patch`,
/// `PatchMesh`, the teapot; see [`obscura_scene::BezierPatch::st`]) and the seven quadrics, whose
/// default `(s, t)` is their `(u, v)` (`u` around the z axis from θ = 0, `v` along the RI's second
/// parameter: z or φ from its minimum, a cone's or disk's from the rim, a hyperboloid's from its first
/// point); a quadric's seam column and pole rows are then split, the positions unchanged. `None` for
/// the others (a polygon mesh's `"st"` travels with the scene mesh itself).
///
/// # Errors
///
/// As [`dice`].
pub fn dice_with_st(
    shape: &Shape,
    ctx: &DicingContext,
) -> Result<(TriangleMesh, Option<Vec<Vec2>>), DiceError> {
    diced(shape, ctx, true)
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
    let (c, rho, sigma) = camera_sphere(ctx, centre, radius);
    let k = nearest_point_rate(ctx, c, rho, sigma);
    let covered = screen_coverage(ctx, c, rho).max(OFF_SCREEN_PIXELS);
    clamp_rate(k.min(coverage_cap(covered, radius)))
}

/// Pixels per unit for one piece of a larger primitive (a cell of a quadric's grid), whose
/// object-space bounding sphere is (centre, radius): the piece's own nearest-point rate, at most
/// `on_screen_cap` (the whole primitive's [`pixels_per_unit`]) when the piece's sphere reaches the
/// image and at most `off_screen_cap` (the whole primitive's rate had it covered only
/// [`OFF_SCREEN_PIXELS`]) when it does not. See the module documentation. Always finite and in
/// `[0, MAX_PIXELS_PER_UNIT]`.
#[must_use]
pub(super) fn piece_pixels_per_unit(
    ctx: &DicingContext,
    centre: Vec3,
    radius: f32,
    on_screen_cap: f32,
    off_screen_cap: f32,
) -> f32 {
    let (c, rho, sigma) = camera_sphere(ctx, centre, radius);
    let k = nearest_point_rate(ctx, c, rho, sigma);
    let cap = if screen_coverage(ctx, c, rho) > 0.0 {
        on_screen_cap
    } else {
        off_screen_cap
    };
    clamp_rate(k.min(cap))
}

/// The rate at which a primitive whose object-space bounding radius is `radius` holds
/// `F·pixels` micropolygons of one pixel over the `2πρ₀ × πρ₀` arcs of a sphere's grid:
/// `√(F·pixels/(2π²))/ρ₀` (NaN when `radius` is 0 or NaN; `f32::min` then keeps the other rate).
#[must_use]
pub(super) fn coverage_cap(pixels: f32, radius: f32) -> f32 {
    let grid_area = 2.0 * std::f32::consts::PI * std::f32::consts::PI;
    (COVERAGE_FACTOR * pixels / grid_area).sqrt() / radius.abs()
}

/// The uncapped rate of the module documentation's first table for a camera-space sphere (centre
/// `c`, radius `rho`) from an object space stretched at most `sigma` times.
fn nearest_point_rate(ctx: &DicingContext, c: Vec3, rho: f32, sigma: f32) -> f32 {
    let near = (NEAR_FRACTION * rho).max(f32::MIN_POSITIVE);
    let s = pixels_per_screen_unit(ctx);
    match ctx.hint {
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
    }
}

/// A rate clamped to `[0, MAX_PIXELS_PER_UNIT]`, NaN read as 0.
fn clamp_rate(k: f32) -> f32 {
    if k.is_nan() {
        0.0
    } else {
        k.clamp(0.0, MAX_PIXELS_PER_UNIT)
    }
}

/// An object-space bounding sphere in camera space: its centre `M·c₀`, its radius `σ·ρ₀`, and `σ`
/// (the longest of `M`'s axis columns, `M` = object → camera).
fn camera_sphere(ctx: &DicingContext, centre: Vec3, radius: f32) -> (Vec3, f32, f32) {
    let m = ctx.object_to_camera;
    let sigma = m
        .x_axis
        .truncate()
        .length()
        .max(m.y_axis.truncate().length())
        .max(m.z_axis.truncate().length());
    (m.transform_point3(centre), radius.abs() * sigma, sigma)
}

/// The most quads a primitive with this object-space bounding sphere (centre, radius) should dice
/// into: `F·max(P, P₀)/m²` for the pixels `P` it covers (see the module documentation), at most
/// [`MAX_QUADS_PER_PRIMITIVE`]. Dicers whose count does not follow from one rate (a subdivision
/// mesh's faces times `4^level`) lower their rate until they fit it.
#[must_use]
pub fn quad_budget(ctx: &DicingContext, centre: Vec3, radius: f32) -> u64 {
    let (c, rho, _) = camera_sphere(ctx, centre, radius);
    let covered = screen_coverage(ctx, c, rho).max(OFF_SCREEN_PIXELS);
    let quads = f64::from(COVERAGE_FACTOR * covered) / micropolygon_length(ctx).powi(2);
    if quads.is_nan() {
        MAX_QUADS_PER_PRIMITIVE
    } else {
        (quads.ceil() as u64).min(MAX_QUADS_PER_PRIMITIVE)
    }
}

/// The pixels of the image a camera-space bounding sphere (centre `c`, radius `rho`) covers, as the
/// module documentation's table says: 0 for a sphere out of view, the whole image at most.
#[must_use]
pub fn screen_coverage(ctx: &DicingContext, c: Vec3, rho: f32) -> f32 {
    let (w, h) = (ctx.format.width.max(1) as f32, ctx.format.height.max(1) as f32);
    let image = w * h;
    let s = pixels_per_screen_unit(ctx);
    let window = ctx.screen_window;
    // The pixels of the square centre ± half (screen units) inside the screen window.
    let square = |x: f32, y: f32, half: f32| {
        let ox = ((x + half).min(window.right) - (x - half).max(window.left)).max(0.0);
        let oy = ((y + half).min(window.top) - (y - half).max(window.bottom)).max(0.0);
        let (sx, sy) = (w / window.width().abs(), h / window.height().abs());
        let (sx, sy) = if sx.is_finite() && sy.is_finite() {
            (sx, sy)
        } else {
            (s, s)
        };
        (ox * oy * sx * sy).min(image)
    };
    let pixels = match ctx.hint {
        DicingHint::Perspective => {
            let d = 1.0 / (0.5 * field_of_view_radians(ctx.field_of_view, 179.0)).tan();
            // The frustum's side planes pass through the eye: x·d = r·z etc. A sphere wholly outside
            // one of them is off screen, however near the camera it is.
            let outside = |n: Vec3| n.dot(c) > rho * n.length();
            if c.z + rho <= 0.0
                || outside(Vec3::new(d, 0.0, -window.right))
                || outside(Vec3::new(-d, 0.0, window.left))
                || outside(Vec3::new(0.0, d, -window.top))
                || outside(Vec3::new(0.0, -d, window.bottom))
            {
                0.0
            } else if c.z - rho <= NEAR_FRACTION * rho {
                image
            } else {
                square(d * c.x / c.z, d * c.y / c.z, d * rho / (c.z - rho))
            }
        }
        DicingHint::Orthographic => {
            if c.z + rho <= 0.0 {
                0.0
            } else {
                square(c.x, c.y, rho)
            }
        }
        DicingHint::Spherical => {
            let distance = c.length();
            if distance <= rho {
                image
            } else {
                let pixels_per_radian = 2.0 * s / field_of_view_radians(ctx.field_of_view, 360.0);
                let alpha = (rho / distance).asin();
                (std::f32::consts::PI * (alpha * pixels_per_radian).powi(2)).min(image)
            }
        }
    };
    if pixels.is_nan() { image } else { pixels }
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

/// The micropolygon length in pixels: `ctx`'s when positive (at least [`MIN_MICROPOLYGON_LENGTH`]),
/// else one pixel.
fn micropolygon_length(ctx: &DicingContext) -> f64 {
    let m = ctx.micropolygon_length;
    if m > 0.0 {
        f64::from(m.max(MIN_MICROPOLYGON_LENGTH))
    } else {
        1.0
    }
}

/// Refuses the first position that is NaN or infinite (of a polygon mesh or a control mesh).
fn check_finite(positions: &[Vec3]) -> Result<(), DiceError> {
    match positions.iter().position(|p| !p.is_finite()) {
        Some(vertex) => Err(DiceError::NonFinitePosition { vertex }),
        None => Ok(()),
    }
}
