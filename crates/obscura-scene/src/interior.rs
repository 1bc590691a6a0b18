//! Telling an interior (a room, an atrium, a church: geometry closed around the viewer) from an
//! object, and where a camera stands inside it.
//!
//! **The test.** From a point `p`, rays go out along 64 directions spread evenly over the sphere (a
//! Fibonacci lattice). A ray's first hit is *front-facing* when the triangle's normal points back
//! at `p`: the file's vertex normals where it gives them (they survive a mirrored or flipped
//! winding), else the winding normal `(p₁ − p₀) × (p₂ − p₀)` (glTF's and OBJ's counter-clockwise
//! front faces). `p` is **inside** the geometry when at least half the directions meet a front
//! face: walls, floor and
//! ceiling all face into a room, while from the centre of a closed object (a helmet, a duck) every
//! ray meets the back of its shell, and from outside most rays meet nothing. An atrium open to the
//! sky stays inside (its floor and walls are more than half the sphere).
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
//! room (none escape) needs a light of its own inside ([`crate::framing`] adds one).
//!
//! The rays are tested against the triangles in runs of 64 consecutive ones, a run skipped when the
//! ray misses its bounds: a few hundred rays, once per file read without a camera.

use glam::{Mat4, Vec3};

use crate::types::{Object, Shape};

/// Directions per probe.
const DIRECTIONS: usize = 64;

/// Triangles per bounded run ([`Triangles`]).
const CHUNK: usize = 64;

/// Share of directions that must meet a front face for a point to be inside.
const INSIDE: f32 = 0.5;

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
    /// default key's ([`crate::framing::DEFAULT_KEY_DIRECTION`]) when nothing blocks it, else the
    /// first of it turned 25, 50, 75 and 100 % of the way toward straight down that gets through;
    /// `None` when none does.
    pub key: Option<Vec3>,
}

/// One world-space triangle and the direction its front faces.
type Facing = ([Vec3; 3], Vec3);

/// World-space triangles of a scene in runs of up to [`CHUNK`] consecutive triangles of one object,
/// each run with its bounds.
struct Triangles {
    groups: Vec<(Vec3, Vec3, Vec<Facing>)>,
}

/// The first hit along a ray: distance and whether the triangle faces the ray's origin.
#[derive(Debug, Clone, Copy)]
struct Hit {
    t: f32,
    front: bool,
}

impl Triangles {
    /// The meshes of `objects`, each posed by its first transform sample.
    fn new(objects: &[Object]) -> Self {
        let groups = objects
            .iter()
            .filter_map(|o| {
                let Shape::Mesh(mesh) = &o.shape else {
                    return None;
                };
                let m = o.transform.samples.first().map_or(Mat4::IDENTITY, |s| s.1);
                let p: Vec<Vec3> = mesh.positions.iter().map(|&v| m.transform_point3(v)).collect();
                let normal_matrix = m.inverse().transpose();
                let normals = mesh.normals.as_ref().filter(|n| n.len() == p.len());
                let tris: Vec<Facing> = (mesh.triangles.iter())
                    .filter_map(|t| {
                        let v = [
                            p.get(t[0] as usize)?,
                            p.get(t[1] as usize)?,
                            p.get(t[2] as usize)?,
                        ];
                        let tri = [*v[0], *v[1], *v[2]];
                        // The file's normals when it has them (they survive a flipped winding),
                        // else the counter-clockwise winding.
                        let front = match normals {
                            Some(n) => normal_matrix
                                .transform_vector3(n[t[0] as usize] + n[t[1] as usize] + n[t[2] as usize]),
                            None => (tri[1] - tri[0]).cross(tri[2] - tri[0]),
                        };
                        (tri.iter().all(|x| x.is_finite()) && front.is_finite()).then_some((tri, front))
                    })
                    .collect();
                Some(tris)
            })
            .flat_map(|tris| {
                // Runs of consecutive triangles (files keep neighbours together), each with its
                // bounds, so a ray skips most of a large mesh.
                tris.chunks(CHUNK)
                    .map(|c| {
                        let points = || c.iter().flat_map(|(tri, _)| tri);
                        let lo = points().fold(Vec3::INFINITY, |a, &b| a.min(b));
                        let hi = points().fold(Vec3::NEG_INFINITY, |a, &b| a.max(b));
                        (lo, hi, c.to_vec())
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        Triangles { groups }
    }

    /// The nearest hit from `o` along unit `d` (Möller–Trumbore), if any.
    fn first_hit(&self, o: Vec3, d: Vec3) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let inv = d.recip();
        for (lo, hi, tris) in &self.groups {
            // Slab test against the group's bounds.
            let (t0, t1) = ((*lo - o) * inv, (*hi - o) * inv);
            let near = t0.min(t1).max_element().max(0.0);
            let far = t0.max(t1).min_element();
            if near > far || best.is_some_and(|b| near > b.t) {
                continue;
            }
            for ([p0, p1, p2], facing) in tris {
                let (e1, e2) = (*p1 - *p0, *p2 - *p0);
                let q = d.cross(e2);
                let det = e1.dot(q);
                if det.abs() < 1e-12 {
                    continue;
                }
                let s = o - *p0;
                let u = s.dot(q) / det;
                if !(0.0..=1.0).contains(&u) {
                    continue;
                }
                let r = s.cross(e1);
                let v = d.dot(r) / det;
                if v < 0.0 || u + v > 1.0 {
                    continue;
                }
                let t = e2.dot(r) / det;
                if t > 1e-6 && best.is_none_or(|b| t < b.t) {
                    best = Some(Hit {
                        t,
                        front: facing.dot(d) < 0.0,
                    });
                }
            }
        }
        best
    }

    /// Share of the probe directions from `p` whose first hit is a front face.
    fn front_share(&self, p: Vec3) -> f32 {
        let front = directions()
            .filter(|&d| self.first_hit(p, d).is_some_and(|h| h.front))
            .count();
        front as f32 / DIRECTIONS as f32
    }
}

/// [`DIRECTIONS`] unit vectors spread evenly over the sphere (a Fibonacci lattice, `y` from +1 down
/// to −1).
fn directions() -> impl Iterator<Item = Vec3> {
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
    let default_key = crate::framing::DEFAULT_KEY_DIRECTION.normalize();
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::{Identity, Mesh, MotionTransform};

    /// An axis-aligned box `min..max` as one object, faces wound to face inward (`inward`) or out,
    /// without its top face when `open_top`.
    fn room(min: Vec3, max: Vec3, inward: bool, open_top: bool) -> Object {
        let c = |i: usize| {
            Vec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            )
        };
        // Each face's corners counter-clockwise seen from outside.
        let mut faces = vec![
            [0, 4, 6, 2], // −X
            [1, 3, 7, 5], // +X
            [0, 1, 5, 4], // −Y (floor)
            [0, 2, 3, 1], // −Z
            [4, 5, 7, 6], // +Z
        ];
        if !open_top {
            faces.push([2, 6, 7, 3]); // +Y (ceiling)
        }
        let positions: Vec<Vec3> = (0..8).map(c).collect();
        let mut triangles = Vec::new();
        for f in faces {
            for t in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
                let t = t.map(|i| i as u32);
                triangles.push(if inward { [t[0], t[2], t[1]] } else { t });
            }
        }
        Object {
            shape: Shape::Mesh(Mesh {
                positions,
                triangles,
                ..Mesh::default()
            }),
            transform: MotionTransform::fixed(Mat4::IDENTITY),
            material: 0,
            micropolygon_length: 1.0,
            source: "test".into(),
            identity: Identity::default(),
            sides: Default::default(),
            visibility: Default::default(),
        }
    }

    #[test]
    fn a_room_is_an_interior_and_a_closed_object_is_not() {
        let (min, max) = (Vec3::new(-6.0, 0.0, -2.0), Vec3::new(6.0, 3.0, 2.0));
        let hall = probe(&[room(min, max, true, false)], min, max).expect("a room faces inward");
        // Centre on the plan, 40 % up; the long side is X; the end eye 10 % of the length from −X.
        assert!(
            (hall.centre_eye - Vec3::new(0.0, 1.2, 0.0)).length() < 1e-5,
            "{hall:?}"
        );
        assert_eq!(hall.along, Vec3::X);
        assert!(
            (hall.end_eye - Vec3::new(-4.8, 1.2, 0.0)).length() < 1e-4,
            "{hall:?}"
        );
        assert_eq!(hall.open_above, 0.0, "a closed room lets no sky in");
        assert_eq!(hall.key, None);
        // The same box wound outward is a closed object: from its centre every ray meets a back face.
        assert_eq!(probe(&[room(min, max, false, false)], min, max), None);
    }

    #[test]
    fn the_files_normals_decide_over_a_flipped_winding() {
        let (min, max) = (Vec3::new(-3.0, 0.0, -2.0), Vec3::new(3.0, 3.0, 2.0));
        // Wound outward, as an object, but every vertex normal points in at the centre: a room.
        let mut hall = room(min, max, false, false);
        let Shape::Mesh(mesh) = &mut hall.shape else {
            unreachable!()
        };
        let centre = 0.5 * (min + max);
        mesh.normals = Some(mesh.positions.iter().map(|&p| (centre - p).normalize()).collect());
        assert!(probe(&[hall.clone()], min, max).is_some());
        // The same normals pointing out: an object again.
        let Shape::Mesh(mesh) = &mut hall.shape else {
            unreachable!()
        };
        mesh.normals = mesh.normals.take().map(|n| n.into_iter().map(|v| -v).collect());
        assert_eq!(probe(&[hall], min, max), None);
    }

    #[test]
    fn an_atrium_open_to_the_sky_is_an_interior_open_above() {
        let (min, max) = (Vec3::new(-4.0, 0.0, -5.0), Vec3::new(4.0, 8.0, 5.0));
        let atrium = probe(&[room(min, max, true, true)], min, max).expect("open above, still inside");
        assert_eq!(atrium.along, Vec3::Z);
        // From 3.2 units up, the 8 × 10 opening 4.8 units above subtends
        // Ω = 4 asin(ab / √((a² + 4d²)(b² + 4d²))) = 1.92 sr: 31 % of the upper hemisphere.
        assert!(atrium.open_above > 0.2 && atrium.open_above < 0.42, "{atrium:?}");
        // The key light reaches the eye through the opening.
        let key = atrium.key.expect("the opening lets a key light in");
        let travel_up = -key;
        let reach = |t: f32| atrium.centre_eye + travel_up * t;
        let exit = (8.0 - atrium.centre_eye.y) / travel_up.y;
        assert!(reach(exit).x.abs() < 4.0 && reach(exit).z.abs() < 5.0, "{key}");
    }

    #[test]
    fn an_end_eye_inside_a_pillar_moves_toward_the_centre() {
        let (min, max) = (Vec3::new(-10.0, 0.0, -2.0), Vec3::new(10.0, 4.0, 2.0));
        // A solid pillar (outward faces) around the first end-eye candidate, x = −8.
        let pillar = room(
            Vec3::new(-8.5, 0.0, -0.5),
            Vec3::new(-7.5, 4.0, 0.5),
            false,
            false,
        );
        let hall = probe(&[room(min, max, true, false), pillar], min, max).unwrap();
        assert!(
            (hall.end_eye - Vec3::new(-7.0, 1.6, 0.0)).length() < 1e-4,
            "{hall:?}"
        );
    }
}
