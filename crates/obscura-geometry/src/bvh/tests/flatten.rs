//! The flat scene layout against the instanced one: static objects flattened into one world-space
//! hierarchy give the same hits, instance IDs and triangle indices as the same objects traced as
//! instances (up to the rounding of the triangle test in world rather than object space), keep the
//! tie rule between instances, and leave moving, shared and partly visible instances as instances.

use glam::{Affine3A, Quat, Vec3, Vec3A};
use obscura_scene::Sides;
use proptest::prelude::*;

use super::scene::cuboid;
use super::{SplitMix, config, make_ray, ray_spec, solid_triangle, soup, still};
use crate::bvh::{Instance, RayVisibility, SceneAccel, SceneLayout};
use crate::ray::{Hit, Ray, Tracer, TriangleMesh};

/// Both layouts of one scene.
fn both(meshes: &[TriangleMesh], instances: &[Instance]) -> (SceneAccel, SceneAccel) {
    let build = |layout| {
        SceneAccel::build_with(
            meshes.to_vec(),
            instances.to_vec(),
            RayVisibility::default(),
            layout,
        )
    };
    (build(SceneLayout::Flat), build(SceneLayout::Instanced))
}

/// Within `1e-3` (barycentrics) of the triangle's edges: where object- and world-space tests may
/// disagree on which triangle (or whether anything) is hit.
fn near_edge(h: &Hit) -> bool {
    let (u, v) = h.uv;
    u.min(v).min(1.0 - u - v) < 1e-3
}

/// True when the point at `t` on `ray` lies on the plane of `hit`'s world triangle (to 1e-5 of the
/// coordinates' size): well conditioned where `t` is not (grazing rays).
fn on_plane(accel: &SceneAccel, hit: &Hit, ray: &Ray, t: f32) -> bool {
    let mesh = accel.instance_mesh(hit.instance).unwrap();
    let m = accel.instance_transform_at(hit.instance, ray.time);
    let tri = mesh.triangles[hit.primitive as usize].map(|i| m.transform_point3a(mesh.positions[i as usize]));
    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
    let p = ray.at(t);
    n.dot(p - tri[0]).abs() <= 1e-5 * (1.0 + p.length() + tri[0].length())
}

/// Compares the flat and the instanced layout on `ray`: the same instance and triangle (or both
/// within 1e-3 of an edge) at the same depth (`t` within `1e-5` relative, or each layout's hit
/// point on the other's plane: grazing rays), the same any-hit answer. Returns whether the two
/// differed at all (a borderline case).
fn agree(flat: &SceneAccel, instanced: &SceneAccel, ray: &Ray) -> Result<bool, TestCaseError> {
    let (f, i) = (flat.intersect(ray), instanced.intersect(ray));
    let same_depth =
        |f: &Hit, i: &Hit| (f.t - i.t).abs() <= 1e-5 * (1.0 + i.t.abs()) || on_plane(instanced, i, ray, f.t);
    let borderline = match (f, i) {
        (None, None) => false,
        (Some(f), Some(i)) if (f.instance, f.primitive) == (i.instance, i.primitive) => {
            prop_assert!(
                same_depth(&f, &i),
                "t {} (flat) vs {} (instanced) for {:?}",
                f.t,
                i.t,
                ray
            );
            prop_assert_eq!(f.geometric_normal, i.geometric_normal);
            false
        }
        (Some(f), Some(i)) => {
            let same_depth = same_depth(&f, &i) || on_plane(flat, &f, ray, i.t);
            prop_assert!(
                same_depth || near_edge(&f) || near_edge(&i),
                "flat {:?} vs instanced {:?} for {:?}",
                f,
                i,
                ray
            );
            true
        }
        (Some(h), None) | (None, Some(h)) => {
            prop_assert!(near_edge(&h), "only one layout hits {:?} for {:?}", h, ray);
            true
        }
    };
    let (fo, io) = (flat.occluded(ray), instanced.occluded(ray));
    if fo != io {
        prop_assert!(
            borderline || f.or(i).is_some_and(|h| near_edge(&h)),
            "occluded {fo} vs {io} for {ray:?}"
        );
    }
    Ok(borderline || fo != io)
}

/// A rotation, non-uniform scale and translation (no shear).
fn placement() -> impl Strategy<Value = Affine3A> {
    (
        (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0),
        -3.0f32..3.0,
        (0.3f32..3.0, 0.3f32..3.0, 0.3f32..3.0),
        (-3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0),
    )
        .prop_map(|((ax, ay, az), angle, (sx, sy, sz), (tx, ty, tz))| {
            let axis = Vec3::new(ax, ay, az).try_normalize().unwrap_or(Vec3::Y);
            Affine3A::from_scale_rotation_translation(
                Vec3::new(sx, sy, sz),
                Quat::from_axis_angle(axis, angle),
                Vec3::new(tx, ty, tz),
            )
        })
}

proptest! {
    #![proptest_config(config(96))]
    /// Each mesh placed once, statically, except the last (placed twice) and one moving instance:
    /// the flat layout flattens exactly the single static placements and agrees with the
    /// instanced one on random rays, most of them aimed at the triangles.
    #[test]
    fn flat_and_instanced_layouts_give_the_same_hits(
        meshes in prop::collection::vec(prop::collection::vec(solid_triangle(), 1..=30), 2..=5),
        transforms in prop::collection::vec(placement(), 6),
        moving in any::<bool>(),
        rays in prop::collection::vec(ray_spec(), 32),
    ) {
        let meshes: Vec<TriangleMesh> = meshes.iter().map(|m| soup(m, 1.0)).collect();
        let last = meshes.len() as u32 - 1;
        let mut instances: Vec<Instance> =
            (0..=last).map(|m| still(m, transforms[m as usize])).collect();
        instances.push(still(last, transforms[5]));
        if moving {
            instances[0].transform.push((1.0, transforms[4]));
        }
        let (flat, instanced) = both(&meshes, &instances);
        // Mesh `last` is placed twice and instance 0 may move: neither is flattened.
        let expect_flat = last as usize - usize::from(moving);
        prop_assert_eq!(flat.instance_counts().0, expect_flat);
        prop_assert_eq!(instanced.instance_counts(), (0, instances.len()));
        prop_assert_eq!(flat.triangle_count(), instanced.triangle_count());
        let targets: Vec<[Vec3A; 3]> = (0..instances.len() as u32)
            .flat_map(|k| {
                let mesh = flat.instance_mesh(k).unwrap();
                let m = flat.instance_transform_at(k, 0.0);
                mesh.triangles.iter().map(move |t| t.map(|i| m.transform_point3a(mesh.positions[i as usize])))
            })
            .collect();
        let mut borderline = 0;
        for spec in &rays {
            let ray = make_ray(spec, &targets, 3.0, false);
            borderline += usize::from(agree(&flat, &instanced, &ray)?);
        }
        prop_assert!(borderline <= 3, "{} borderline disagreements in {} rays", borderline, rays.len());
    }
}

/// Every triangle of every object is hit, from outside, through its centroid: the flat layout
/// reports exactly the instance and triangle index the instanced one does (the IDs the truth AOVs
/// and the shading read), for 3 × 12 × 8 rays.
#[test]
fn flattened_hits_keep_their_instance_and_triangle() {
    let meshes = vec![
        cuboid(Vec3A::splat(-0.5), Vec3A::splat(0.5)),
        cuboid(Vec3A::new(-1.0, -0.2, -0.3), Vec3A::new(1.0, 0.2, 0.3)),
        cuboid(Vec3A::splat(0.0), Vec3A::new(0.4, 0.7, 0.2)),
    ];
    let instances = vec![
        still(0, Affine3A::from_translation(Vec3::new(-4.0, 0.0, 0.0))),
        still(
            1,
            Affine3A::from_scale_rotation_translation(
                Vec3::new(1.5, 0.5, 2.0),
                Quat::from_rotation_y(0.7),
                Vec3::new(0.0, 3.0, 0.0),
            ),
        ),
        still(2, Affine3A::from_rotation_x(2.0)),
    ];
    let (flat, instanced) = both(&meshes, &instances);
    assert_eq!(flat.instance_counts(), (3, 0));
    let mut rng = SplitMix(29);
    let mut checked = 0;
    for (k, mesh) in meshes.iter().enumerate() {
        let m = instances[k].transform[0].1;
        let centre = mesh
            .positions
            .iter()
            .map(|&p| m.transform_point3a(p))
            .sum::<Vec3A>()
            / 8.0;
        for (p, tri) in mesh.triangles.iter().enumerate() {
            let w = tri.map(|i| m.transform_point3a(mesh.positions[i as usize]));
            let centroid = (w[0] + w[1] + w[2]) / 3.0;
            let outward = (w[1] - w[0]).cross(w[2] - w[0]).normalize();
            // Aim from outside the box, off the face normal by a random tilt.
            let out = if (centroid - centre).dot(outward) > 0.0 {
                outward
            } else {
                -outward
            };
            for _ in 0..8 {
                let origin = centroid + (out + rng.vec(0.4)) * 0.3;
                let ray = Ray::new(origin, centroid - origin);
                let (f, i) = (flat.intersect(&ray).unwrap(), instanced.intersect(&ray).unwrap());
                assert_eq!((f.instance, f.primitive), (k as u32, p as u32), "{ray:?}");
                assert_eq!((i.instance, i.primitive), (k as u32, p as u32), "{ray:?}");
                assert!((f.t - 1.0).abs() < 1e-5 && (i.t - 1.0).abs() < 1e-5);
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 3 * 12 * 8);
}

/// Placed by the identity, a flattened object's world triangles are its object triangles, bit for
/// bit, and the instanced layout's ray transform is skipped: both layouts give the same hits to the
/// bit.
#[test]
fn identity_placements_flatten_bit_for_bit() {
    let mut rng = SplitMix(7);
    let tris: Vec<[Vec3A; 3]> = (0..200)
        .map(|_| {
            let c = rng.vec(2.0);
            [c + rng.vec(0.3), c + rng.vec(0.3), c + rng.vec(0.3)]
        })
        .collect();
    let meshes = vec![soup(&tris[..120], 1.0), soup(&tris[120..], 1.0)];
    let instances = vec![still(0, Affine3A::IDENTITY), still(1, Affine3A::IDENTITY)];
    let (flat, instanced) = both(&meshes, &instances);
    assert_eq!(flat.instance_counts(), (2, 0));
    let mut hits = 0;
    for _ in 0..4000 {
        // From around the cloud of triangles, through it.
        let origin = rng.vec(4.0);
        let ray = Ray::new(origin, rng.vec(1.5) - origin);
        let (f, i) = (flat.intersect(&ray), instanced.intersect(&ray));
        assert_eq!(f, i, "{ray:?}");
        assert_eq!(flat.occluded(&ray), instanced.occluded(&ray));
        hits += usize::from(f.is_some());
    }
    assert!(hits > 1000, "{hits} hits");
}

/// Two instances with the same triangle in the same place: the lower instance wins, whichever of
/// them is flattened and whichever is traced as an instance.
#[test]
fn ties_between_flat_and_instanced_go_to_the_lower_instance() {
    let tri = soup(
        &[[
            Vec3A::new(-1.0, -1.0, 0.0),
            Vec3A::new(1.0, -1.0, 0.0),
            Vec3A::new(0.0, 1.0, 0.0),
        ]],
        1.0,
    );
    // Mesh 0 placed twice (traced as instances), mesh 1 once (flattened).
    let meshes = vec![tri.clone(), tri];
    let ray = Ray::new(Vec3A::new(0.1, 0.0, 2.0), Vec3A::NEG_Z);
    for (instances, flattened) in [
        (
            vec![
                still(0, Affine3A::IDENTITY),
                still(1, Affine3A::IDENTITY),
                still(0, Affine3A::IDENTITY),
            ],
            1,
        ),
        (
            vec![
                still(1, Affine3A::IDENTITY),
                still(0, Affine3A::IDENTITY),
                still(0, Affine3A::IDENTITY),
            ],
            0,
        ),
    ] {
        let (flat, instanced) = both(&meshes, &instances);
        assert!(flat.placements[flattened].flat);
        for accel in [&flat, &instanced] {
            let hit = accel.intersect(&ray).unwrap();
            assert_eq!((hit.instance, hit.t), (0, 2.0));
        }
        // With instance 0 casting no shadow, shadow rays meet instance 1 first (the lower of 1 and 2).
        let accel = SceneAccel::build_with(
            meshes.clone(),
            instances.clone(),
            RayVisibility {
                shadows: vec![false],
                ..RayVisibility::default()
            },
            SceneLayout::Flat,
        );
        assert_eq!(accel.intersect_shadow(&ray).map(|h| h.instance), Some(1));
        assert_eq!(accel.intersect(&ray).map(|h| h.instance), Some(0));
    }
}

/// Visibility decides what is flattened: an instance some rays do not see stays an instance (given
/// at build time or later, when the flattened hierarchy is rebuilt without it), and what the rays
/// see is the same either way.
#[test]
fn instances_some_rays_do_not_see_stay_instances() {
    let quad = |z: f32| TriangleMesh {
        positions: vec![
            Vec3A::new(-1.0, -1.0, z),
            Vec3A::new(-1.0, 1.0, z),
            Vec3A::new(1.0, -1.0, z),
            Vec3A::new(1.0, 1.0, z),
        ],
        normals: None,
        // Both wound so that (v1 − v0)×(v2 − v0) = −z: the front faces the origin.
        triangles: vec![[0, 1, 2], [2, 1, 3]],
    };
    let meshes = vec![quad(1.0), quad(2.0), quad(3.0)];
    let instances = vec![
        still(0, Affine3A::IDENTITY),
        still(1, Affine3A::IDENTITY),
        still(2, Affine3A::IDENTITY),
    ];
    let visibility = RayVisibility {
        sides: vec![Sides::Back],
        camera: vec![true, false],
        shadows: vec![true, true, false],
        clip_planes: vec![],
    };
    let given = SceneAccel::build_with(
        meshes.clone(),
        instances.clone(),
        visibility.clone(),
        SceneLayout::Flat,
    );
    let later = SceneAccel::build_with(
        meshes.clone(),
        instances.clone(),
        RayVisibility::default(),
        SceneLayout::Flat,
    );
    assert_eq!(later.instance_counts(), (3, 0));
    let later = later
        .with_camera_visibility(visibility.sides.clone(), &[])
        .with_ray_visibility(&visibility.camera, &visibility.shadows);
    let instanced = SceneAccel::build_with(meshes, instances, visibility, SceneLayout::Instanced);
    let toward = Ray::new(Vec3A::new(0.1, 0.2, 0.0), Vec3A::Z);
    for accel in [&given, &later, &instanced] {
        // Nothing is flattened: each instance is one-sided, hidden or casts no shadow.
        assert_eq!(accel.instance_counts().0, 0);
        // Camera rays: the first quad shows its back only, the second is hidden: the third.
        assert_eq!(accel.intersect_camera(&toward).map(|h| h.instance), Some(2));
        // Other rays see the first.
        assert_eq!(accel.intersect(&toward).map(|h| h.instance), Some(0));
        // Shadow rays past the first two see nothing further: the third casts no shadow.
        let past = Ray { t_min: 2.5, ..toward };
        assert!(!accel.occluded(&past));
        assert!(accel.intersect(&past).is_some());
    }
    // Clipping planes alone keep every instance flattened; hits beyond a plane are passed.
    let clipped = SceneAccel::build_with(
        vec![quad(1.0), quad(2.0)],
        vec![still(0, Affine3A::IDENTITY), still(1, Affine3A::IDENTITY)],
        RayVisibility {
            clip_planes: vec![(Vec3A::new(0.0, 0.0, 1.5), Vec3A::NEG_Z)],
            ..RayVisibility::default()
        },
        SceneLayout::Flat,
    );
    assert_eq!(clipped.instance_counts(), (2, 0));
    assert_eq!(clipped.intersect_camera(&toward).map(|h| h.instance), Some(1));
    assert_eq!(clipped.intersect(&toward).map(|h| h.instance), Some(0));
}
