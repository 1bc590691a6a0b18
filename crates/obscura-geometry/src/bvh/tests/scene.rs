//! [`SceneAccel`] against brute force over world-space triangles: static and moving instances,
//! conservative motion bounds, and the normals of the world-space hit.

use glam::{Affine3A, Quat, Vec3A};
use proptest::prelude::*;

use super::*;
use crate::bvh::tree::Aabb;
use crate::bvh::{Instance, SceneAccel};
use crate::motion::tests::rotating_transform;
use crate::ray::{Hit, Tracer};
use crate::testing::CUBE_QUADS;

#[test]
fn empty_inputs_build_and_miss() {
    let empty = MeshBvh::build(TriangleMesh::default());
    assert_eq!(empty.triangle_count(), 0);
    assert_eq!(empty.bounds(), (Vec3A::INFINITY, Vec3A::NEG_INFINITY));
    let r = Ray::new(Vec3A::ZERO, Vec3A::Z);
    assert_eq!(empty.intersect(&r), None);
    assert!(!empty.occluded(&r));

    let scene = SceneAccel::build(vec![], vec![]);
    assert_eq!(scene.triangle_count(), 0);
    assert_eq!(scene.bounds(), (Vec3A::INFINITY, Vec3A::NEG_INFINITY));
    assert!(scene.intersect(&r).is_none() && !scene.occluded(&r));

    // A bad mesh index is never hit but keeps its slot; an empty sample list is the identity.
    let tri = soup(
        &[[
            Vec3A::new(-1.0, -1.0, 1.0),
            Vec3A::new(1.0, -1.0, 1.0),
            Vec3A::new(0.0, 1.0, 1.0),
        ]],
        1.0,
    );
    let scene = SceneAccel::build(
        vec![tri],
        vec![
            Instance {
                mesh: 7,
                transform: vec![],
            },
            Instance {
                mesh: 0,
                transform: vec![],
            },
        ],
    );
    assert_eq!(scene.triangle_count(), 1);
    assert_eq!(scene.instance_transform_at(1, 0.3), Affine3A::IDENTITY);
    assert_eq!(scene.intersect(&r).map(|h| (h.instance, h.t)), Some((1, 1.0)));
}

/// Brute force over world-space triangles: `(t, instance, primitive, u, v)`.
fn brute_scene(
    meshes: &[TriangleMesh],
    instances: &[Instance],
    accel: &SceneAccel,
    ray: &Ray,
) -> Option<(f32, u32, u32, f32, f32)> {
    let tri_ray = TriRay::new(ray.origin, ray.direction);
    let mut best: Option<(f32, u32, u32, f32, f32)> = None;
    for (k, inst) in instances.iter().enumerate() {
        let Some(mesh) = meshes.get(inst.mesh as usize) else {
            continue;
        };
        let m = accel.instance_transform_at(k as u32, ray.time);
        for (i, &tri) in mesh.triangles.iter().enumerate() {
            let Some(v) = triangle_vertices(mesh, tri) else {
                continue;
            };
            if let Some((t, u, w)) =
                tri_ray.intersect(&v.map(|p| m.transform_point3a(p)), ray.t_min, ray.t_max)
                && best.is_none_or(|b| t < b.0)
            {
                best = Some((t, k as u32, i as u32, u, w));
            }
        }
    }
    best
}

/// The world-space triangle `primitive` of `instance` at `time`.
fn world_triangle(accel: &SceneAccel, instance: u32, primitive: u32, time: f32) -> [Vec3A; 3] {
    let mesh = accel.meshes[accel.placements[instance as usize].mesh.unwrap()].mesh();
    let m = accel.instance_transform_at(instance, time);
    mesh.triangles[primitive as usize].map(|i| m.transform_point3a(mesh.positions[i as usize]))
}

/// True when the point at `t` on `ray` lies on the plane of `tri` (to 1e-4 of the coordinates'
/// size). Unlike `t` itself this is well conditioned for grazing rays.
fn on_plane(tri: &[Vec3A; 3], ray: &Ray, t: f32) -> bool {
    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
    let p = ray.at(t);
    n.dot(p - tri[0]).abs() <= 1e-4 * (1.0 + p.length() + tri[0].length())
}

/// Compares the accelerator with brute force over world triangles. Object- and world-space
/// tests round differently, so where rounding can flip the answer the check accepts either: a
/// hit within 1e-3 of a triangle edge (in barycentrics), or two hits at the same depth (the `t`
/// values agree, or one hit point lies on the other's plane). Returns how many hits differed.
fn check_scene_ray(
    meshes: &[TriangleMesh],
    instances: &[Instance],
    accel: &SceneAccel,
    ray: &Ray,
) -> Result<usize, TestCaseError> {
    let expected = brute_scene(meshes, instances, accel, ray);
    let near_edge = |u: f32, v: f32| u.min(v).min(1.0 - u - v) < 1e-3;
    let mut borderline = 0;
    for scalar in KERNELS {
        let got = accel
            .closest_dispatch(ray, scalar)
            .map(|h| accel.make_hit(ray, h));
        match (got, expected) {
            (None, None) => {}
            (Some(g), Some(e)) => {
                let e_tri = world_triangle(accel, e.1, e.2, ray.time);
                let same_depth = (g.t - e.0).abs() <= 1e-4 * (1.0 + e.0.abs()) || on_plane(&e_tri, ray, g.t);
                if (g.instance, g.primitive) == (e.1, e.2) {
                    prop_assert!(same_depth, "t {} vs {} for {:?}", g.t, e.0, ray);
                } else {
                    prop_assert!(
                        same_depth || near_edge(g.uv.0, g.uv.1) || near_edge(e.3, e.4),
                        "hit {:?} vs brute force {:?} for {:?}",
                        g,
                        e,
                        ray
                    );
                    borderline += 1;
                }
                check_hit_frame(&g, ray, accel)?;
            }
            (Some(g), None) => {
                prop_assert!(
                    near_edge(g.uv.0, g.uv.1),
                    "hit {:?}, brute force misses, for {:?}",
                    g,
                    ray
                );
                borderline += 1;
            }
            (None, Some(e)) => {
                prop_assert!(
                    near_edge(e.3, e.4),
                    "miss, brute force hits {:?}, for {:?}",
                    e,
                    ray
                );
                borderline += 1;
            }
        }
        let any = accel.any_dispatch(ray, scalar);
        if any != expected.is_some() {
            prop_assert!(
                expected.is_none_or(|e| near_edge(e.3, e.4)),
                "occluded {} for {:?}",
                any,
                ray
            );
        }
    }
    Ok(borderline)
}

/// Normals unit and facing the ray; the geometric normal is perpendicular to the world triangle;
/// the position lies on the ray.
fn check_hit_frame(hit: &Hit, ray: &Ray, accel: &SceneAccel) -> Result<(), TestCaseError> {
    let ng = hit.geometric_normal;
    prop_assert!((ng.length() - 1.0).abs() < 1e-5, "|n| = {}", ng.length());
    prop_assert!((hit.shading_normal.length() - 1.0).abs() < 1e-5);
    prop_assert!(
        ng.dot(ray.direction) < 0.0,
        "normal {:?} does not face {:?}",
        ng,
        ray.direction
    );
    prop_assert!(hit.shading_normal.dot(ng) >= 0.0);
    let p = world_triangle(accel, hit.instance, hit.primitive, ray.time);
    for e in [p[1] - p[0], p[2] - p[0]] {
        prop_assert!(
            ng.dot(e).abs() <= 1e-3 * e.length(),
            "normal not perpendicular to the triangle"
        );
    }
    let at = ray.at(hit.t);
    prop_assert!((hit.position - at).length() <= 1e-4 * (1.0 + at.length() + hit.t * ray.direction.length()));
    Ok(())
}

fn affine() -> impl Strategy<Value = Affine3A> {
    (
        vec3(1.0),
        -3.0f32..3.0,
        (0.3f32..3.0, 0.3f32..3.0, 0.3f32..3.0),
        vec3(3.0),
        any::<bool>(),
        -0.5f32..0.5,
    )
        .prop_map(|(axis, angle, (sx, sy, sz), t, shear, k)| {
            let rotation = Quat::from_axis_angle(axis.normalize_or(Vec3A::Y).into(), angle);
            let mut m =
                Affine3A::from_scale_rotation_translation(glam::Vec3::new(sx, sy, sz), rotation, t.into());
            if shear {
                m.matrix3.y_axis += m.matrix3.x_axis * k;
            }
            m
        })
}

proptest! {
    #![proptest_config(config(128))]
    #[test]
    fn proptest_static_instances_match_brute_force(
        mesh_a in prop::collection::vec(solid_triangle(), 1..=40),
        mesh_b in prop::collection::vec(solid_triangle(), 1..=40),
        placements in prop::collection::vec((0u32..3, affine()), 1..=6),
        rays in prop::collection::vec(ray_spec(), 24),
    ) {
        let meshes = vec![soup(&mesh_a, 1.0), soup(&mesh_b, 1.0)];
        // Mesh index 2 does not exist: such instances must be ignored.
        let instances: Vec<Instance> =
            placements.iter().map(|(mesh, m)| still(*mesh, *m)).collect();
        let accel = SceneAccel::build(meshes.clone(), instances.clone());
        let targets: Vec<[Vec3A; 3]> = instances
            .iter()
            .filter_map(|inst| meshes.get(inst.mesh as usize).map(|mesh| (mesh, inst.transform[0].1)))
            .flat_map(|(mesh, m)| mesh.triangles.iter().map(move |t| t.map(|i| m.transform_point3a(mesh.positions[i as usize]))))
            .collect();
        let mut borderline = 0;
        for spec in &rays {
            borderline += check_scene_ray(&meshes, &instances, &accel, &make_ray(spec, &targets, 2.0, true))?;
        }
        prop_assert!(borderline <= 4, "{} borderline disagreements in {} rays", borderline, rays.len());
    }
}

/// A box-shaped mesh (12 triangles) spanning `lo..hi`.
pub(super) fn cuboid(lo: Vec3A, hi: Vec3A) -> TriangleMesh {
    let b = Aabb { lo, hi };
    TriangleMesh {
        positions: b.corners().to_vec(),
        normals: None,
        triangles: CUBE_QUADS
            .iter()
            .flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]])
            .collect(),
    }
}

#[test]
fn translated_triangle_is_hit_only_mid_shutter() {
    // A thin triangle around x = 0 moving to x = 2: the ray at x = 1 sees it only near time 0.5.
    let half = 0.05;
    let tri = TriangleMesh {
        positions: vec![
            Vec3A::new(-half, -1.0, 0.0),
            Vec3A::new(half, -1.0, 0.0),
            Vec3A::new(0.0, 1.0, 0.0),
        ],
        normals: None,
        triangles: vec![[0, 1, 2]],
    };
    let instance = Instance {
        mesh: 0,
        transform: vec![
            (0.0, Affine3A::IDENTITY),
            (1.0, Affine3A::from_translation(glam::Vec3::new(2.0, 0.0, 0.0))),
        ],
    };
    let accel = SceneAccel::build(vec![tri.clone()], vec![instance.clone()]);
    let at = |time: f32| Ray {
        time,
        ..Ray::new(Vec3A::new(1.0, -0.9, 5.0), Vec3A::NEG_Z)
    };
    let hit = accel.intersect(&at(0.5)).expect("hit at mid-shutter");
    assert!((hit.t - 5.0).abs() < 1e-5);
    for k in 0..=1000 {
        let time = k as f32 / 1000.0;
        // At y = -0.9 the triangle spans x ∈ 2·time ± 0.0475.
        let expect = (2.0 * time - 1.0).abs() < 0.0475;
        let clear = ((2.0 * time - 1.0).abs() - 0.0475).abs() > 1e-3;
        if clear {
            assert_eq!(accel.intersect(&at(time)).is_some(), expect, "time {time}");
            assert_eq!(accel.occluded(&at(time)), expect, "time {time}");
        }
    }
    for time in [0.48, 0.49, 0.5, 0.51, 0.52, 0.0, 1.0, 0.3] {
        check_scene_ray(
            std::slice::from_ref(&tri),
            std::slice::from_ref(&instance),
            &accel,
            &at(time),
        )
        .unwrap();
    }
    // Clamped outside the samples.
    assert_eq!(accel.instance_transform_at(0, -1.0), Affine3A::IDENTITY);
    assert!(
        accel
            .instance_transform_at(0, 7.0)
            .translation
            .abs_diff_eq(Vec3A::new(2.0, 0.0, 0.0), 1e-6)
    );
}

fn rotating_scene() -> (Vec<TriangleMesh>, Vec<Instance>) {
    // Long in x and off the rotation axis, so mid-rotation corners leave both end boxes.
    let mesh = cuboid(Vec3A::new(1.0, -0.2, -0.3), Vec3A::new(3.0, 0.4, 0.1));
    let instance = Instance {
        mesh: 0,
        transform: vec![(0.0, rotating_transform(0.0)), (1.0, rotating_transform(1.0))],
    };
    (vec![mesh], vec![instance])
}

#[test]
fn rotating_instance_matches_brute_force_at_random_times() {
    let (meshes, instances) = rotating_scene();
    let accel = SceneAccel::build(meshes.clone(), instances.clone());
    let mut rng = SplitMix(5);
    let (mut hits, mut borderline) = (0, 0);
    for _ in 0..400 {
        let time = rng.next_f32();
        // Aim at a point of the independently transformed box, so most rays hit.
        let m = rotating_transform(time);
        let target = m.transform_point3a(Vec3A::new(
            1.0 + 2.0 * rng.next_f32(),
            -0.2 + 0.6 * rng.next_f32(),
            -0.1,
        ));
        let origin = rng.vec(6.0);
        let r = Ray {
            time,
            ..Ray::new(origin, target - origin)
        };
        borderline += check_scene_ray(&meshes, &instances, &accel, &r).unwrap();
        hits += usize::from(accel.intersect(&r).is_some());
    }
    assert!(hits > 300, "{hits} hits");
    assert!(borderline < 8, "{borderline} borderline cases");
}

#[test]
fn motion_bounds_enclose_the_instance_at_random_times() {
    let (meshes, mut instances) = rotating_scene();
    // A second instance with three samples, scaling and a half turn about a tilted axis.
    let spin = |a: f32| Quat::from_axis_angle(glam::Vec3::new(1.0, 1.0, 0.0).normalize(), a);
    instances.push(Instance {
        mesh: 0,
        transform: vec![
            (
                0.0,
                Affine3A::from_scale_rotation_translation(glam::Vec3::ONE, spin(0.0), glam::Vec3::ZERO),
            ),
            (
                0.4,
                Affine3A::from_scale_rotation_translation(
                    glam::Vec3::new(2.0, 1.0, 0.5),
                    spin(1.5),
                    glam::Vec3::X,
                ),
            ),
            (
                1.0,
                Affine3A::from_scale_rotation_translation(glam::Vec3::splat(0.7), spin(3.0), glam::Vec3::Y),
            ),
        ],
    });
    for instances in [&instances[..1], &instances[1..]] {
        let accel = SceneAccel::build(meshes.clone(), instances.to_vec());
        let (lo, hi) = accel.bounds();
        let mut rng = SplitMix(99);
        for _ in 0..100 {
            let time = rng.next_f32();
            let m = accel.instance_transform_at(0, time);
            for &p in &meshes[0].positions {
                let w = m.transform_point3a(p);
                assert!(
                    w.cmpge(lo).all() && w.cmple(hi).all(),
                    "time {time}: {w:?} outside {lo:?}..{hi:?}"
                );
            }
        }
        // Conservative but not loose: compare with the box swept at 2001 times.
        let mut swept = Aabb::EMPTY;
        for k in 0..=2000 {
            let m = accel.instance_transform_at(0, k as f32 / 2000.0);
            for &p in &meshes[0].positions {
                swept.grow_point(m.transform_point3a(p));
            }
        }
        let ratio = Aabb { lo, hi }.half_area() / swept.half_area();
        assert!(ratio < 1.25, "bounds {ratio}× the swept box's area");
    }
}

// -----------------------------------------------------------------------------------------------
// Normals

/// A flat quad in z = 0 over x, y ∈ [-1, 1] whose vertex normals lean ±0.5 in x.
fn tilted_quad() -> (TriangleMesh, impl Fn(f32) -> Vec3A) {
    let left = Vec3A::new(-0.5, 0.0, 1.0).normalize();
    let right = Vec3A::new(0.5, 0.0, 1.0).normalize();
    let mesh = TriangleMesh {
        positions: vec![
            Vec3A::new(-1.0, -1.0, 0.0),
            Vec3A::new(1.0, -1.0, 0.0),
            Vec3A::new(1.0, 1.0, 0.0),
            Vec3A::new(-1.0, 1.0, 0.0),
        ],
        normals: Some(vec![left, right, right, left]),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    };
    // Barycentric interpolation is linear in x here.
    let expected = move |x: f32| (left * (1.0 - x) / 2.0 + right * (1.0 + x) / 2.0).normalize();
    (mesh, expected)
}

#[test]
fn shading_normals_interpolate_vertex_normals() {
    let (mesh, expected) = tilted_quad();
    let scale = Affine3A::from_scale(glam::Vec3::new(2.0, 1.0, 1.0));
    let accel = SceneAccel::build(
        vec![mesh],
        vec![
            still(0, Affine3A::IDENTITY),
            still(0, Affine3A::from_translation(glam::Vec3::Z * -10.0) * scale),
        ],
    );
    for x in [-0.9f32, -0.3, 0.0, 0.5, 0.8] {
        // From above: normals point up (+z).
        let hit = accel
            .intersect(&Ray::new(Vec3A::new(x, 0.3, 3.0), Vec3A::new(0.0, 0.0, -2.0)))
            .unwrap();
        assert_eq!(hit.instance, 0);
        assert!(hit.geometric_normal.abs_diff_eq(Vec3A::Z, 1e-6));
        assert!(
            hit.shading_normal.abs_diff_eq(expected(x), 1e-5),
            "x {x}: {:?}",
            hit.shading_normal
        );
        // From below: both flip.
        let hit = accel
            .intersect(&Ray::new(Vec3A::new(x, 0.3, -3.0), Vec3A::Z))
            .unwrap();
        assert_eq!(hit.instance, 0);
        assert!(hit.geometric_normal.abs_diff_eq(Vec3A::NEG_Z, 1e-6));
        assert!(hit.shading_normal.abs_diff_eq(-expected(x), 1e-5));
        // The scaled copy: world x = 2·object x, and normals go through the inverse transpose
        // diag(1/2, 1, 1).
        let hit = accel
            .intersect(&Ray::new(Vec3A::new(2.0 * x, 0.3, -5.0), Vec3A::NEG_Z))
            .unwrap();
        assert_eq!(hit.instance, 1);
        let n = expected(x);
        let want = Vec3A::new(n.x * 0.5, n.y, n.z).normalize();
        assert!(
            hit.shading_normal.abs_diff_eq(want, 1e-5),
            "x {x}: {:?} vs {want:?}",
            hit.shading_normal
        );
        assert!(
            (hit.t - 5.0).abs() < 1e-5 && hit.position.abs_diff_eq(Vec3A::new(2.0 * x, 0.3, -10.0), 1e-5)
        );
    }
}

#[test]
fn geometric_normals_are_unit_and_face_the_ray() {
    let (meshes, instances) = rotating_scene();
    let accel = SceneAccel::build(meshes, instances);
    let mut rng = SplitMix(8);
    let mut hits = 0;
    for _ in 0..500 {
        let time = rng.next_f32();
        let r = Ray {
            time,
            ..Ray::new(rng.vec(5.0), rng.vec(1.0))
        };
        // Also from inside the box, where the ray meets back faces.
        let inside = Ray {
            time,
            ..Ray::new(
                rotating_transform(time).transform_point3a(Vec3A::new(2.0, 0.1, -0.1)),
                rng.vec(1.0),
            )
        };
        for r in [r, inside] {
            if let Some(hit) = accel.intersect(&r) {
                check_hit_frame(&hit, &r, &accel).unwrap();
                assert_eq!(
                    hit.shading_normal, hit.geometric_normal,
                    "no vertex normals: shading = geometric"
                );
                hits += 1;
            }
        }
    }
    assert!(hits > 500, "{hits} hits");
}
