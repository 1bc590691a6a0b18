//! What camera rays see: the facing the triangle test reports (its determinant's sign against an
//! independent `D·n`), one-sided instances (mirrored ones keep their side), and clipping planes that
//! pass a hit on to the next one. Other rays see everything.

use glam::{Affine3A, Vec3, Vec3A};
use obscura_scene::Sides;

use super::{SplitMix, still};
use crate::bvh::SceneAccel;
use crate::bvh::triangle::TriRay;
use crate::ray::{Ray, Tracer, TriangleMesh};

#[test]
fn the_determinants_sign_is_the_side_the_ray_meets() {
    let mut rng = SplitMix(11);
    let (mut front, mut back) = (0, 0);
    for _ in 0..4000 {
        let tri = [rng.vec(1.0), rng.vec(1.0), rng.vec(1.0)];
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        // Aimed at a point inside the triangle, so that most rays hit it.
        let (u, v) = (rng.next_f32(), rng.next_f32());
        let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
        let origin = rng.vec(3.0);
        let direction = tri[0] + (tri[1] - tri[0]) * u + (tri[2] - tri[0]) * v - origin;
        // Keep rays that are clearly not grazing, so that f64 and f32 agree on the side.
        if n.length() < 0.05 || direction.normalize().dot(n.normalize()).abs() < 1e-2 {
            continue;
        }
        let Some((_, _, _, det)) = TriRay::new(origin, direction).intersect_det(&tri, 0.0, f32::INFINITY)
        else {
            continue;
        };
        let d_dot_n = f64::from(direction.x) * f64::from(n.x)
            + f64::from(direction.y) * f64::from(n.y)
            + f64::from(direction.z) * f64::from(n.z);
        assert_eq!(det > 0.0, d_dot_n < 0.0, "det {det}, D·n {d_dot_n}");
        if det > 0.0 {
            front += 1;
        } else {
            back += 1;
        }
    }
    assert!(
        front > 1000 && back > 1000,
        "both sides met: {front} front, {back} back"
    );
}

/// One triangle at z = 2 whose `(v₁ − v₀)×(v₂ − v₀)` is −z: its front faces a camera at the origin.
fn facing_the_origin() -> TriangleMesh {
    TriangleMesh {
        positions: vec![
            Vec3A::new(-1.0, -1.0, 2.0),
            Vec3A::new(-1.0, 1.0, 2.0),
            Vec3A::new(1.0, -1.0, 2.0),
        ],
        normals: None,
        triangles: vec![[0, 1, 2]],
    }
}

fn accel(transform: Affine3A, sides: Sides, planes: &[(Vec3A, Vec3A)]) -> SceneAccel {
    SceneAccel::build(vec![facing_the_origin()], vec![still(0, transform)])
        .with_camera_visibility(vec![sides], planes)
}

#[test]
fn one_sided_instances_show_camera_rays_one_side_and_mirrors_keep_it() {
    let towards = Ray::new(Vec3A::ZERO, Vec3A::new(-0.2, -0.2, 1.0));
    let away = Ray::new(Vec3A::new(-0.2, -0.2, 4.0), Vec3A::new(0.0, 0.0, -1.0));
    let id = Affine3A::IDENTITY;
    for (sides, sees_front, sees_back) in [
        (Sides::Both, true, true),
        (Sides::Front, true, false),
        (Sides::Back, false, true),
    ] {
        let a = accel(id, sides, &[]);
        assert_eq!(
            a.intersect_camera(&towards).is_some(),
            sees_front,
            "{sides:?} front"
        );
        assert_eq!(a.intersect_camera(&away).is_some(), sees_back, "{sides:?} back");
        // Secondary and shadow rays see both sides.
        assert!(a.intersect(&towards).is_some() && a.intersect(&away).is_some());
        assert!(a.occluded(&towards) && a.occluded(&away));
    }
    // Mirrored in x: the triangle's front (as a side of its plane) still faces the origin, though its
    // vertices now wind the other way on screen.
    let mirror = Affine3A::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    let a = accel(mirror, Sides::Front, &[]);
    let towards_mirrored = Ray::new(Vec3A::ZERO, Vec3A::new(0.2, -0.2, 1.0));
    let away_mirrored = Ray::new(Vec3A::new(0.2, -0.2, 4.0), Vec3A::new(0.0, 0.0, -1.0));
    assert!(a.intersect_camera(&towards_mirrored).is_some());
    assert!(a.intersect_camera(&away_mirrored).is_none());
}

#[test]
fn clipping_planes_pass_camera_rays_on_to_the_next_hit() {
    // Two triangles: the one at z = 2 and a copy at z = 3 (a second instance).
    let behind = Affine3A::from_translation(Vec3::new(0.0, 0.0, 1.0));
    let build = |planes: &[(Vec3A, Vec3A)]| {
        SceneAccel::build(
            vec![facing_the_origin()],
            vec![still(0, Affine3A::IDENTITY), still(0, behind)],
        )
        .with_camera_visibility(vec![], planes)
    };
    let r = Ray::new(Vec3A::ZERO, Vec3A::new(-0.2, -0.2, 1.0));
    let t = |a: &SceneAccel| a.intersect_camera(&r).map(|h| h.position.z);
    assert_eq!(t(&build(&[])), Some(2.0));
    // Clip z < 2.5 (the normal −z points to the clipped side): the ray goes on to z = 3.
    let near = (Vec3A::new(0.0, 0.0, 2.5), Vec3A::new(0.0, 0.0, -1.0));
    assert_eq!(t(&build(&[near])), Some(3.0));
    // Planes accumulate: also clip z > 2.8, and nothing is left.
    let far = (Vec3A::new(0.0, 0.0, 2.8), Vec3A::new(0.0, 0.0, 1.0));
    assert_eq!(t(&build(&[near, far])), None);
    // Other rays are not clipped; an unusable plane is ignored.
    assert_eq!(build(&[near, far]).intersect(&r).map(|h| h.position.z), Some(2.0));
    let zero = (Vec3A::ZERO, Vec3A::ZERO);
    assert_eq!(t(&build(&[zero])), Some(2.0));
}

#[test]
fn hidden_and_shadowless_instances_are_passed_by_camera_and_shadow_rays_only() {
    // Two copies of the triangle along the ray: instance 0 at z = 2, instance 1 at z = 3. Each
    // combination of (camera, shadows) for the near one: camera rays and shadow rays go on to the far
    // one past what they do not see; every other ray stops at the near one.
    let near = Affine3A::IDENTITY;
    let far = Affine3A::from_translation(Vec3::new(0.0, 0.0, 1.0));
    let r = Ray::new(Vec3A::ZERO, Vec3A::new(-0.2, -0.2, 1.0));
    for (camera, shadows) in [(true, true), (false, true), (true, false), (false, false)] {
        let accel = SceneAccel::build(vec![facing_the_origin()], vec![still(0, near), still(0, far)])
            .with_ray_visibility(&[camera, true], &[shadows, true]);
        let instance = |h: Option<crate::ray::Hit>| h.map(|h| h.instance);
        let first = |seen: bool| Some(if seen { 0 } else { 1 });
        assert_eq!(instance(accel.intersect(&r)), Some(0), "{camera} {shadows}");
        assert_eq!(
            instance(accel.intersect_camera(&r)),
            first(camera),
            "{camera} {shadows}"
        );
        assert_eq!(
            instance(accel.intersect_shadow(&r)),
            first(shadows),
            "{camera} {shadows}"
        );
        // A shadow ray that ends between the two is blocked only by a near one that casts shadows.
        let short = crate::ray::Ray { t_max: 2.5, ..r };
        assert_eq!(accel.occluded(&short), shadows, "{camera} {shadows}");
        assert!(accel.occluded(&r));
        // One-sidedness and clipping keep working with hidden instances (the same filtered pass).
        let one_sided = accel.with_camera_visibility(vec![Sides::Back, Sides::Both], &[]);
        assert_eq!(
            instance(one_sided.intersect_camera(&r)),
            Some(1),
            "{camera} {shadows}"
        );
    }
}
