//! Staging's tests: the automatic camera and the interior probe on scenes built here (this file),
//! and scene files read and staged as the renderer reads them (`files.rs`). The probe's verdicts
//! are compared ray by ray with its former intersector's (`reference.rs`).

mod files;

use glam::{Mat4, Vec3};
use obscura_scene::{Identity, Mesh, MotionTransform, Object, Shape};
use proptest::prelude::*;

use super::interior::{DIRECTIONS, Triangles, directions};
use super::reference;
use super::*;

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-5
}

/// The bounding box's corners in camera space.
fn corners(m: Mat4, min: Vec3, max: Vec3) -> Vec<Vec3> {
    (0..8)
        .map(|i| {
            let p = Vec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            );
            m.transform_point3(p)
        })
        .collect()
}

#[test]
fn a_flat_asset_lying_down_is_seen_from_above_and_whole() {
    // A rug: 4 × 0.05 × 2. Looking down −Y, the rug's front (+Z) at the bottom of the image.
    let (min, max) = (Vec3::new(-2.0, 0.0, -1.0), Vec3::new(2.0, 0.05, 1.0));
    let cam = auto_camera(min, max, AutoView::Perspective { fov: 45.0 }, 1.5, None);
    let forward = cam.world_to_camera.inverse().transform_vector3(Vec3::Z);
    assert!((forward - Vec3::NEG_Y).length() < 1e-5, "{forward}");
    let front = cam.world_to_camera.transform_point3(Vec3::new(0.0, 0.0, 1.0));
    assert!(front.y < 0.0, "the front edge is low in the picture: {front}");
    let t = (22.5f32).to_radians().tan();
    for c in corners(cam.world_to_camera, min, max) {
        assert!(c.z > 0.0 && (c.x / c.z).abs() < t && (c.y / c.z).abs() < t, "{c}");
    }
    assert!(cam.description.contains("top"));
}

#[test]
fn an_interior_gets_a_camera_inside_looking_along_its_length() {
    let (min, max) = (Vec3::new(-6.0, 0.0, -2.0), Vec3::new(6.0, 3.0, 2.0));
    let inside = Interior {
        centre_eye: Vec3::new(0.0, 1.2, 0.0),
        end_eye: Vec3::new(-4.8, 1.2, 0.0),
        along: Vec3::X,
        open_above: 0.0,
        key: None,
    };
    let eye_and_forward = |view| {
        let cam = auto_camera(min, max, view, 1.5, Some(&inside));
        let to_world = cam.world_to_camera.inverse();
        (
            to_world.transform_point3(Vec3::ZERO),
            to_world.transform_vector3(Vec3::Z),
            to_world.transform_vector3(Vec3::Y),
            cam.description,
        )
    };
    // Perspective and fisheye stand at the end eye, a full panorama at the centre; all look
    // along +X with +Y up.
    for (view, eye) in [
        (AutoView::Perspective { fov: 40.0 }, inside.end_eye),
        (AutoView::Wide { fov: 180.0 }, inside.end_eye),
        (AutoView::Wide { fov: 360.0 }, inside.centre_eye),
    ] {
        let (at, forward, up, what) = eye_and_forward(view);
        assert!((at - eye).length() < 1e-5, "{view:?}: {at}");
        assert!((forward - Vec3::X).length() < 1e-5 && (up - Vec3::Y).length() < 1e-5);
        assert!(what.contains("inside an interior"), "{what}");
    }
    // An orthographic view still frames the bounds from outside.
    let ortho = auto_camera(min, max, AutoView::Orthographic, 1.5, Some(&inside));
    for c in corners(ortho.world_to_camera, min, max) {
        assert!(c.z > 0.0, "{c}");
    }
}

#[test]
fn a_wide_view_stands_closer_and_an_orthographic_one_fits_its_window() {
    let (min, max) = (Vec3::splat(-1.0), Vec3::splat(1.0));
    let dist = |v| {
        let m: Mat4 = auto_camera(min, max, v, 1.0, None).world_to_camera;
        m.inverse().transform_point3(Vec3::ZERO).length()
    };
    let persp = dist(AutoView::Perspective { fov: 45.0 });
    let fisheye = dist(AutoView::Wide { fov: 180.0 });
    assert!(fisheye < 0.6 * persp, "{fisheye} vs {persp}");
    // The cube's corners fit 140° of a fisheye: the nearest corner offsets give
    // d = max(max(|x|, |y|)/tan 70° − z) over the corners.
    assert!(fisheye > 1.0 && fisheye < 2.0, "{fisheye}");
    let wide = auto_camera(min, max, AutoView::Wide { fov: 180.0 }, 1.0, None);
    let t = 70f32.to_radians().tan();
    let worst = corners(wide.world_to_camera, min, max)
        .iter()
        .map(|c| (c.x / c.z).abs().max((c.y / c.z).abs()))
        .fold(0.0f32, f32::max);
    assert!(worst <= t * (1.0 + 1e-5) && worst > 0.99 * t, "{worst} vs {t}");
    let ortho = auto_camera(min, max, AutoView::Orthographic, 2.0, None);
    let w = ortho.screen_window.unwrap();
    assert!((w.top - 3f32.sqrt()).abs() < 1e-5 && (w.right - 2.0 * 3f32.sqrt()).abs() < 1e-5);
    for c in corners(ortho.world_to_camera, min, max) {
        assert!(c.z > 0.0 && c.x.abs() <= w.right && c.y.abs() <= w.top, "{c}");
    }
}

#[test]
fn gltf_frame_bounds_looks_down_world_minus_z() {
    let m = frame_bounds(Vec3::splat(-1.0), Vec3::splat(1.0), 45.0);
    let forward = m.inverse().transform_vector3(Vec3::Z);
    assert!(close(forward, Vec3::NEG_Z));
    // Right is world +X, up world +Y.
    assert!(close(m.transform_vector3(Vec3::X), Vec3::X));
    assert!(close(m.transform_vector3(Vec3::Y), Vec3::Y));
    // Degenerate input still gives a finite camera in front of the box.
    for (lo, hi) in [
        (Vec3::ZERO, Vec3::ZERO),
        (Vec3::splat(f32::NAN), Vec3::ONE),
        (Vec3::ONE, Vec3::ZERO),
        (Vec3::new(0.0, 0.0, -5.0), Vec3::new(0.0, 0.0, 5.0)),
    ] {
        let m = frame_bounds(lo, hi, f32::NAN);
        assert!(m.is_finite());
        if lo.is_finite() && lo.cmple(hi).all() {
            assert!(m.transform_point3(hi).z > 0.0);
        }
    }
}

proptest! {
    #[test]
    fn gltf_frame_bounds_keeps_every_corner_in_view(
        lo in prop::array::uniform3(-100.0f32..100.0),
        size in prop::array::uniform3(0.0f32..50.0),
        fov in 5.0f32..150.0,
    ) {
        let (min, max) = (Vec3::from(lo), Vec3::from(lo) + Vec3::from(size));
        let m = frame_bounds(min, max, fov);
        let t = (0.5 * fov.to_radians()).tan() * (1.0 + 1e-4);
        let mut widest = 0.0f32;
        for i in 0..8 {
            let corner = Vec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            );
            let c = m.transform_point3(corner);
            prop_assert!(c.z > 0.0);
            prop_assert!((c.x / c.z).abs() <= t && (c.y / c.z).abs() <= t, "corner {corner} at {c}");
            widest = widest.max((c.x / c.z).abs()).max((c.y / c.z).abs());
        }
        // Framed, not lost in the distance (when the box is not flat in x and y).
        if size[0].max(size[1]) > 0.25 * size[2] && size[0].max(size[1]) > 1e-3 {
            prop_assert!(widest > 0.8 * t);
        }
    }
}

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

/// Every ray [`probe`] can cast in `objects` within `min..max`: from the bounds' centre, both
/// candidate centre eyes and the end-eye candidates of each, along the 64 probe directions and
/// toward each key direction tried.
fn probe_rays(min: Vec3, max: Vec3) -> Vec<(Vec3, Vec3)> {
    let centre = 0.5 * (min + max);
    let ext = max - min;
    let eyes = [Vec3::new(centre.x, min.y + 0.4 * ext.y, centre.z), centre];
    let (along, length) = if ext.x >= ext.z {
        (Vec3::X, ext.x)
    } else {
        (Vec3::Z, ext.z)
    };
    let mut points = vec![centre];
    for eye in eyes {
        points.push(eye);
        points.extend((0..8).map(|k| eye - along * length * (0.4 - 0.05 * k as f32)));
    }
    let default_key = DEFAULT_KEY_DIRECTION.normalize();
    let keys = (0..5).map(|k| -default_key.lerp(Vec3::NEG_Y, 0.25 * k as f32).normalize());
    let dirs: Vec<Vec3> = directions().chain(keys).collect();
    points
        .iter()
        .flat_map(|&p| dirs.iter().map(move |&d| (p, d)))
        .collect()
}

/// Asserts that the BVH the probe casts through and the former intersector give the same verdict
/// (no hit, a front face, a back face) for every ray the probe can cast in `objects`; returns how
/// many rays met a front face, a back face and nothing.
pub(super) fn assert_verdicts_agree(objects: &[Object], min: Vec3, max: Vec3) -> [usize; 3] {
    let (bvh, old) = (Triangles::new(objects), reference::Triangles::new(objects));
    let mut counts = [0; 3];
    for (p, d) in probe_rays(min, max) {
        let verdict = bvh.first_hit(p, d);
        assert_eq!(verdict, old.first_hit(p, d), "from {p} along {d}");
        counts[match verdict {
            Some(true) => 0,
            Some(false) => 1,
            None => 2,
        }] += 1;
    }
    counts
}

/// The scenes of the probe's tests above, with their bounds.
fn probe_scenes() -> Vec<(Vec<Object>, Vec3, Vec3)> {
    let hall = (Vec3::new(-6.0, 0.0, -2.0), Vec3::new(6.0, 3.0, 2.0));
    let small = (Vec3::new(-3.0, 0.0, -2.0), Vec3::new(3.0, 3.0, 2.0));
    let atrium = (Vec3::new(-4.0, 0.0, -5.0), Vec3::new(4.0, 8.0, 5.0));
    let long = (Vec3::new(-10.0, 0.0, -2.0), Vec3::new(10.0, 4.0, 2.0));
    let with_normals = |inward: bool| {
        let mut o = room(small.0, small.1, false, false);
        let Shape::Mesh(mesh) = &mut o.shape else {
            unreachable!()
        };
        let centre = 0.5 * (small.0 + small.1);
        let sign = if inward { 1.0 } else { -1.0 };
        mesh.normals = Some(
            mesh.positions
                .iter()
                .map(|&p| sign * (centre - p).normalize())
                .collect(),
        );
        o
    };
    let pillar = room(
        Vec3::new(-8.5, 0.0, -0.5),
        Vec3::new(-7.5, 4.0, 0.5),
        false,
        false,
    );
    vec![
        (vec![room(hall.0, hall.1, true, false)], hall.0, hall.1),
        (vec![room(hall.0, hall.1, false, false)], hall.0, hall.1),
        (vec![with_normals(true)], small.0, small.1),
        (vec![with_normals(false)], small.0, small.1),
        (vec![room(atrium.0, atrium.1, true, true)], atrium.0, atrium.1),
        (vec![room(long.0, long.1, true, false), pillar], long.0, long.1),
    ]
}

#[test]
fn the_probe_through_the_bvh_agrees_with_its_former_intersector_ray_by_ray() {
    let mut all = [0; 3];
    for (objects, min, max) in probe_scenes() {
        let counts = assert_verdicts_agree(&objects, min, max);
        (0..3).for_each(|i| all[i] += counts[i]);
    }
    // Fronts, backs and misses all occur: the comparison is not vacuous.
    assert!(all.iter().all(|&n| n > 50), "{all:?}");
    assert_eq!(all.iter().sum::<usize>(), 6 * 19 * (DIRECTIONS + 5));
}
