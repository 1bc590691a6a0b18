//! Telling an interior (a room, an atrium, a church: geometry closed around the viewer) from an
//! object, and where a camera stands inside it.
//!
//! **The test.** From a point `p`, rays go out along 64 directions spread evenly over the sphere (a
//! Fibonacci lattice). A ray's first hit is *front-facing* when the triangle's normal points back
//! at `p`: the file's vertex normals where it gives them (they survive a mirrored or flipped
//! winding), else the winding normal `(p₁ − p₀) × (p₂ − p₀)` (glTF's and OBJ's counter-clockwise
//! front faces). `p` is **inside** the geometry when at least half the directions meet a front
//! face: walls, floor and ceiling all face into a room, while from the centre of a closed object (a
//! helmet, a duck) every ray meets the back of its shell, and from outside most rays meet nothing.
//! An atrium open to the sky stays inside (its floor and walls are more than half the sphere).
//!
//! **Where the camera stands** ([`Interior`]): on the bounds' centre line, 40 % of the way up from
//! the floor (a viewer's height in a tall space, clear of the floor in a low one), looking along the
//! longer horizontal side of the bounds; a camera that sees one way (perspective, a fisheye) stands
//! toward one end of that side, 10 % of its length from the end, so the space recedes in front of it.
//! A candidate that is not itself inside (it is in a wall or a column) moves toward the centre in
//! steps of 5 % of the length, and falls back to the centre.
//!
//! **The sky.** [`Interior::open_above`] is the share of the upper hemisphere's directions from the
//! centre eye that meet nothing: an atrium's opening lets the default sky and key light in; a closed
//! room (none escape) needs a light of its own inside ([`default_lights`](super::default_lights)
//! adds one).
//!
//! **The rays** go through the renderer's intersector, [`SceneAccel`]: every triangle of the
//! scene's meshes, posed by its object's first transform sample, in world space (the vertices
//! transformed exactly as the probe always has), one mesh under one identity instance; a hit's
//! primitive index finds the triangle's facing. The accelerator's watertight test differs from a
//! Möller–Trumbore test only for rays through a triangle's edge or vertex, or nearly parallel to
//! its plane; a tie between two triangles at the same distance can go either way. The verdicts are
//! the old intersector's on every scene the tests use (`staging/tests/mod.rs` compares them ray by ray).

use glam::{Affine3A, Mat4, Vec3, Vec3A};
use obscura_geometry::bvh::{Instance, SceneAccel};
use obscura_geometry::ray::{Ray, Tracer, TriangleMesh};
use obscura_scene::{Object, Shape};

use super::DEFAULT_KEY_DIRECTION;

/// Directions per probe.
pub(super) const DIRECTIONS: usize = 64;

/// Share of directions that must meet a front face for a point to be inside.
const INSIDE: f32 = 0.5;

/// The nearest distance a hit counts at: the probe's points are never on a surface.
pub(super) const T_MIN: f32 = 1e-6;

/// Where a camera stands inside an interior and what it looks along (world space).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interior {
    /// Where a camera that sees all around (a panorama) stands: the centre on the plan, 40 % up.
    pub centre_eye: Vec3,
    /// Where a camera that sees one way (perspective, fisheye) stands: toward one end of the long
    /// side, looking along [`Interior::along`].
    pub end_eye: Vec3,
    /// Unit horizontal direction of the long side, from `end_eye` toward the far end.
    pub along: Vec3,
    /// Share of the upper hemisphere's directions from `centre_eye` that meet no geometry (0: a
    /// closed room; an atrium open to the sky is well above 0).
    pub open_above: f32,
    /// The direction a key light travels so that it reaches `centre_eye` through an opening: the
    /// default key's ([`DEFAULT_KEY_DIRECTION`](super::DEFAULT_KEY_DIRECTION)) when nothing blocks
    /// it, else the first of it turned 25, 50, 75 and 100 % of the way toward straight down that
    /// gets through; `None` when none does.
    pub key: Option<Vec3>,
}

/// One world-space triangle and the direction its front faces.
pub(super) type Facing = ([Vec3; 3], Vec3);

/// The world-space triangles of the meshes of `objects`, each posed by its first transform sample,
/// with the direction each faces: the file's normals when it has them (they survive a flipped
/// winding), else the counter-clockwise winding. Triangles with an index out of range or a
/// non-finite vertex or facing are left out.
pub(super) fn facing_triangles(objects: &[Object]) -> Vec<Facing> {
    let mut out = Vec::new();
    for o in objects {
        let Shape::Mesh(mesh) = &o.shape else {
            continue;
        };
        let m = o.transform.samples.first().map_or(Mat4::IDENTITY, |s| s.1);
        let p: Vec<Vec3> = mesh.positions.iter().map(|&v| m.transform_point3(v)).collect();
        let normal_matrix = m.inverse().transpose();
        let normals = mesh.normals.as_ref().filter(|n| n.len() == p.len());
        out.extend(mesh.triangles.iter().filter_map(|t| {
            let v = [
                p.get(t[0] as usize)?,
                p.get(t[1] as usize)?,
                p.get(t[2] as usize)?,
            ];
            let tri = [*v[0], *v[1], *v[2]];
            let front = match normals {
                Some(n) => {
                    normal_matrix.transform_vector3(n[t[0] as usize] + n[t[1] as usize] + n[t[2] as usize])
                }
                None => (tri[1] - tri[0]).cross(tri[2] - tri[0]),
            };
            (tri.iter().all(|x| x.is_finite()) && front.is_finite()).then_some((tri, front))
        }));
    }
    out
}

/// The scene's triangles in the renderer's accelerator, with the direction each faces.
pub(super) struct Triangles {
    accel: SceneAccel,
    /// By primitive index of the accelerator's one mesh.
    facing: Vec<Vec3>,
}

impl Triangles {
    /// The meshes of `objects` (see [`facing_triangles`]) as one world-space mesh of separate
    /// triangles, so that primitive `i` is the `i`-th triangle and its vertices are exactly the
    /// transformed ones.
    pub(super) fn new(objects: &[Object]) -> Self {
        let tris = facing_triangles(objects);
        let mut mesh = TriangleMesh {
            positions: Vec::with_capacity(3 * tris.len()),
            normals: None,
            triangles: Vec::with_capacity(tris.len()),
        };
        let mut facing = Vec::with_capacity(tris.len());
        for (tri, front) in tris {
            let first = mesh.positions.len() as u32;
            mesh.positions.extend(tri.map(Vec3A::from));
            mesh.triangles.push([first, first + 1, first + 2]);
            facing.push(front);
        }
        let instance = Instance {
            mesh: 0,
            transform: vec![(0.0, Affine3A::IDENTITY)],
        };
        Triangles {
            accel: SceneAccel::build(vec![mesh], vec![instance]),
            facing,
        }
    }

    /// The nearest hit from `o` along unit `d`, if any: whether the triangle faces `o`.
    pub(super) fn first_hit(&self, o: Vec3, d: Vec3) -> Option<bool> {
        let ray = Ray {
            origin: o.into(),
            direction: d.into(),
            t_min: T_MIN,
            t_max: f32::INFINITY,
            time: 0.0,
        };
        let hit = self.accel.intersect(&ray)?;
        Some(self.facing[hit.primitive as usize].dot(d) < 0.0)
    }

    /// Share of the probe directions from `p` whose first hit is a front face.
    fn front_share(&self, p: Vec3) -> f32 {
        let front = directions()
            .filter(|&d| self.first_hit(p, d) == Some(true))
            .count();
        front as f32 / DIRECTIONS as f32
    }
}

/// [`DIRECTIONS`] unit vectors spread evenly over the sphere (a Fibonacci lattice, `y` from +1 down
/// to −1).
pub(super) fn directions() -> impl Iterator<Item = Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..DIRECTIONS).map(move |i| {
        let y = 1.0 - (i as f32 + 0.5) * 2.0 / DIRECTIONS as f32;
        let r = (1.0 - y * y).max(0.0).sqrt();
        let phi = golden * i as f32;
        Vec3::new(r * phi.cos(), y, r * phi.sin())
    })
}

/// The interior view of `objects` within the bounds `min..max` (glTF's +Y up), or `None` when the
/// bounds' centre is not inside the geometry (see the module documentation).
#[must_use]
pub fn probe(objects: &[Object], min: Vec3, max: Vec3) -> Option<Interior> {
    if !(min.is_finite() && max.is_finite() && min.cmple(max).all()) {
        return None;
    }
    let tris = Triangles::new(objects);
    let centre = 0.5 * (min + max);
    if tris.front_share(centre) < INSIDE {
        return None;
    }
    let ext = max - min;
    let inside = |p: Vec3| tris.front_share(p) >= INSIDE;
    let mut centre_eye = Vec3::new(centre.x, min.y + 0.4 * ext.y, centre.z);
    if !inside(centre_eye) {
        centre_eye = centre;
    }
    let (along, length) = if ext.x >= ext.z {
        (Vec3::X, ext.x)
    } else {
        (Vec3::Z, ext.z)
    };
    // From 10 % of the length off the −along end toward the centre, in steps of 5 %.
    let end_eye = (0..8)
        .map(|k| centre_eye - along * length * (0.4 - 0.05 * k as f32))
        .find(|&p| inside(p))
        .unwrap_or(centre_eye);
    let up: Vec<Vec3> = directions().filter(|d| d.y > 0.0).collect();
    let open = up
        .iter()
        .filter(|&&d| tris.first_hit(centre_eye, d).is_none())
        .count();
    let default_key = DEFAULT_KEY_DIRECTION.normalize();
    let key = (0..5)
        .map(|k| default_key.lerp(Vec3::NEG_Y, 0.25 * k as f32).normalize())
        .find(|&travel| tris.first_hit(centre_eye, -travel).is_none());
    Some(Interior {
        centre_eye,
        end_eye,
        along,
        open_above: open as f32 / up.len().max(1) as f32,
        key,
    })
}
