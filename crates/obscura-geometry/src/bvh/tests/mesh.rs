//! [`MeshBvh`] against brute force: random soups, watertight heightfields, a large parallel build,
//! ties, skipped triangles, odd rays and adversarial depth.

use glam::{Affine3A, Vec3A};
use proptest::prelude::*;

use super::*;
use crate::bvh::build::PARALLEL_BUILD_MIN;
use crate::bvh::traverse::STACK_SIZE;
use crate::bvh::{BvhLayout, Instance, SceneAccel};
use crate::ray::Tracer;

proptest! {
    #![proptest_config(config(256))]
    #[test]
    fn proptest_mesh_bvh_matches_brute_force(
        triangles in prop::collection::vec(triangle(), 1..=200),
        scale in prop::sample::select(vec![1e-3f32, 1.0, 1e3]),
        rays in prop::collection::vec(ray_spec(), 24),
    ) {
        let mesh = soup(&triangles, scale);
        let targets: Vec<[Vec3A; 3]> = triangles.iter().map(|t| t.map(|p| p * scale)).collect();
        let bvh = MeshBvh::build(mesh);
        for spec in &rays {
            check_mesh_ray(&bvh, &make_ray(spec, &targets, scale, false), scale)?;
        }
    }
}

/// An indexed heightfield: shared vertices, so rays through shared edges test watertightness too.
fn heightfield(n: u32, seed: u64) -> TriangleMesh {
    let mut rng = SplitMix(seed);
    let mut mesh = TriangleMesh::default();
    for j in 0..=n {
        for i in 0..=n {
            mesh.positions.push(Vec3A::new(
                i as f32 / n as f32,
                0.2 * rng.next_f32(),
                j as f32 / n as f32,
            ));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let v = |a: u32, b: u32| b * (n + 1) + a;
            mesh.triangles.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
            mesh.triangles.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    mesh
}

#[test]
fn heightfield_rays_through_grid_lines_match_brute_force_and_never_leak() {
    let n = 16;
    let bvh = MeshBvh::build(heightfield(n, 7));
    for j in 0..=n {
        for i in 0..=n {
            // Straight down through every grid vertex and along grid lines: exactly on shared
            // vertices and edges, where a non-watertight test can miss both neighbours.
            for (dx, dz) in [(0.0, 0.0), (0.5, 0.0), (0.0, 0.5), (0.5, 0.5)] {
                let (x, z) = ((i as f32 + dx) / n as f32, (j as f32 + dz) / n as f32);
                if x > 1.0 || z > 1.0 {
                    continue;
                }
                let r = Ray::new(Vec3A::new(x, 1.0, z), Vec3A::NEG_Y);
                check_mesh_ray(&bvh, &r, 1.0).unwrap();
                assert!(
                    bvh.intersect(&r).is_some(),
                    "leaked through the surface at ({x}, {z})"
                );
            }
        }
    }
}

#[test]
fn large_mesh_matches_brute_force() {
    // Debug builds are ~50× slower: keep the test under a few seconds there.
    let (tris, rays) = if cfg!(debug_assertions) {
        (20_000, 100)
    } else {
        (50_000, 1000)
    };
    let mut rng = SplitMix(42);
    let mut triangles = Vec::with_capacity(tris);
    for _ in 0..tris {
        let c = rng.vec(1.0);
        triangles.push([c + rng.vec(0.03), c + rng.vec(0.03), c + rng.vec(0.03)]);
    }
    let mesh = soup(&triangles, 1.0);
    let bvh = MeshBvh::build(mesh);
    assert!(
        bvh.triangle_count() >= PARALLEL_BUILD_MIN,
        "exercise the parallel build"
    );
    assert!(bvh.wide.depth() < STACK_SIZE);
    let mut hits = 0;
    for k in 0..rays {
        let origin = rng.vec(1.5);
        let direction = if k % 2 == 0 {
            let [a, b, c] = triangles[(rng.next_f32() * tris as f32) as usize % tris];
            (a + b + c) / 3.0 - origin
        } else {
            rng.vec(1.0)
        };
        let r = Ray::new(origin, direction);
        check_mesh_ray(&bvh, &r, 1.0).unwrap();
        hits += usize::from(bvh.intersect(&r).is_some());
    }
    assert!(hits > rays / 2, "most rays should hit ({hits} of {rays})");
}

#[test]
fn rays_through_vertices_and_edges_match_brute_force() {
    // Vertices are box corners and edges lie on box faces, where rounding in the slab test and in
    // the triangle test disagree most: the far-distance padding must keep these boxes.
    let mut rng = SplitMix(17);
    let triangles: Vec<[Vec3A; 3]> = (0..300)
        .map(|_| {
            let c = rng.vec(1.0);
            [c + rng.vec(0.2), c + rng.vec(0.2), c + rng.vec(0.2)]
        })
        .collect();
    let bvh = MeshBvh::build(soup(&triangles, 1.0));
    for [a, b, c] in &triangles {
        for target in [*a, *b, *c, (*a + *b) * 0.5, (*b + *c) * 0.5, (*c + *a) * 0.5] {
            let origin = rng.vec(3.0);
            check_mesh_ray(&bvh, &Ray::new(origin, target - origin), 1.0).unwrap();
        }
    }
}

#[test]
fn duplicate_triangles_report_the_lower_index() {
    let t = [
        Vec3A::new(-1.0, -1.0, 0.0),
        Vec3A::new(1.0, -1.0, 0.0),
        Vec3A::new(0.0, 1.0, 0.0),
    ];
    let mut triangles = vec![[Vec3A::splat(5.0), Vec3A::splat(6.0), Vec3A::new(5.0, 6.0, 7.0)]; 40];
    triangles[17] = t;
    triangles[31] = t;
    triangles[9] = t.map(|p| p + Vec3A::Z);
    let bvh = MeshBvh::build(soup(&triangles, 1.0));
    for scalar in KERNELS {
        assert_eq!(
            bvh.intersect_with(&Ray::new(Vec3A::new(0.1, 0.0, -3.0), Vec3A::Z), scalar)
                .map(|h| h.1),
            Some(17)
        );
        assert_eq!(
            bvh.intersect_with(&Ray::new(Vec3A::new(0.1, 0.0, 3.0), Vec3A::NEG_Z), scalar)
                .map(|h| h.1),
            Some(9)
        );
    }
}

#[test]
fn skipped_triangles_are_never_hit() {
    let mesh = TriangleMesh {
        positions: vec![
            Vec3A::new(-1.0, -1.0, 0.0),
            Vec3A::new(1.0, -1.0, 0.0),
            Vec3A::new(0.0, 1.0, 0.0),
            Vec3A::new(f32::NAN, 0.0, 0.0),
            Vec3A::new(f32::INFINITY, 0.0, 0.0),
            Vec3A::new(2.0, 2.0, 0.0),
        ],
        normals: None,
        triangles: vec![
            [0, 0, 2],  // repeated vertex
            [0, 1, 99], // index out of range
            [0, 1, 3],  // NaN vertex
            [0, 1, 4],  // infinite vertex
            [0, 5, 5],  // repeated vertex
            [0, 2, 5],  // valid, but out of the way of the ray below
        ],
    };
    let bvh = MeshBvh::build(mesh);
    assert_eq!(bvh.triangle_count(), 1);
    assert_eq!(bvh.mesh().len(), 6, "the mesh is kept as given");
    let r = Ray::new(Vec3A::new(0.0, -0.5, 1.0), Vec3A::NEG_Z);
    for scalar in KERNELS {
        assert_eq!(bvh.intersect_with(&r, scalar), None);
        assert!(!bvh.occluded_with(&r, scalar));
    }
    // The one valid triangle is still found.
    assert_eq!(
        bvh.intersect(&Ray::new(Vec3A::new(0.5, 0.9, 1.0), Vec3A::NEG_Z))
            .map(|h| h.1),
        Some(5)
    );
}

#[test]
fn odd_rays_miss_without_panicking() {
    let mesh = soup(
        &[[
            Vec3A::new(-1.0, -1.0, 0.0),
            Vec3A::new(1.0, -1.0, 0.0),
            Vec3A::new(0.0, 1.0, 0.0),
        ]; 9],
        1.0,
    );
    let bvh = MeshBvh::build(mesh.clone());
    let moving = Instance {
        mesh: 0,
        transform: vec![
            (0.0, Affine3A::IDENTITY),
            (1.0, Affine3A::from_translation(glam::Vec3::X)),
        ],
    };
    let accel = SceneAccel::build(vec![mesh], vec![moving]);
    let nan = f32::NAN;
    let rays = [
        Ray::new(Vec3A::new(0.0, 0.0, 1.0), Vec3A::new(nan, 0.0, -1.0)),
        Ray::new(Vec3A::new(nan, 0.0, 1.0), Vec3A::NEG_Z),
        Ray::new(Vec3A::new(0.0, 0.0, 1.0), Vec3A::ZERO),
        Ray::new(Vec3A::new(0.0, 0.0, 1.0), Vec3A::splat(nan)),
        Ray {
            t_min: nan,
            ..Ray::new(Vec3A::new(0.0, 0.0, 1.0), Vec3A::NEG_Z)
        },
        Ray {
            t_max: nan,
            ..Ray::new(Vec3A::new(0.0, 0.0, 1.0), Vec3A::NEG_Z)
        },
        Ray {
            t_min: 5.0,
            t_max: 1.0,
            ..Ray::new(Vec3A::new(0.0, 0.0, 1.0), Vec3A::NEG_Z)
        },
        Ray {
            time: nan,
            t_max: nan,
            ..Ray::new(Vec3A::new(0.0, 0.0, 1.0), Vec3A::NEG_Z)
        },
        Ray::new(Vec3A::splat(f32::INFINITY), Vec3A::NEG_Z),
    ];
    for r in &rays {
        for scalar in KERNELS {
            assert_eq!(bvh.intersect_with(r, scalar), None, "{r:?}");
            assert!(!bvh.occluded_with(r, scalar), "{r:?}");
            assert!(accel.closest_dispatch(r, scalar).is_none(), "{r:?}");
            assert!(!accel.any_dispatch(r, scalar), "{r:?}");
        }
    }
    // A NaN time alone is the first sample.
    let r = Ray {
        time: nan,
        ..Ray::new(Vec3A::new(0.0, 0.0, 1.0), Vec3A::NEG_Z)
    };
    assert_eq!(accel.intersect(&r).map(|h| h.t), Some(1.0));
}

#[test]
fn tree_depth_stays_bounded_on_adversarial_input() {
    // 240 nested, coplanar right triangles of sizes 2^-120 .. 2^119 sharing the corner at the
    // origin: the SAH peels the largest off a few at a time and, left alone, builds a tree ~57
    // deep. From depth SAH_DEPTH_LIMIT = 40 on, median splits must take over.
    let triangles: Vec<[Vec3A; 3]> = (-120..120)
        .map(|i| {
            let x = 2f32.powi(i);
            [Vec3A::ZERO, Vec3A::new(x, 0.0, 0.0), Vec3A::new(0.0, x, 0.0)]
        })
        .collect();
    let binary = MeshBvh::build_with_layout(soup(&triangles, 1.0), BvhLayout::Binary);
    let depth = binary.tree.depth();
    assert!((41..=48).contains(&depth), "depth {depth}");
    let bvh = MeshBvh::build(soup(&triangles, 1.0));
    let wide_depth = bvh.wide.depth();
    assert!(
        wide_depth <= depth,
        "wide depth {wide_depth} > binary depth {depth}"
    );
    for (k, i) in (-120..120).enumerate() {
        // All triangles containing the point lie at the same t; the smallest has the lowest index.
        let p = 0.3 * 2f32.powi(i);
        let r = Ray::new(Vec3A::new(p, p, 1.0), Vec3A::NEG_Z);
        check_mesh_ray(&bvh, &r, 1.0).unwrap();
        // Beyond 2^±60 the edge functions (products of two coordinates) leave the f32 range.
        if (-60..60).contains(&i) {
            assert_eq!(bvh.intersect(&r).map(|h| h.1), Some(k as u32), "size 2^{i}");
        }
    }
}

#[test]
fn sphere_3e38_builds_a_real_tree() {
    // `Sphere 3e38`: the boxes span ±3·10³⁸, so `hi − lo` and every area overflow f32. The builder
    // once saw all splits cost ∞ (and a zero bin scale put every centroid in bin 0), found none and
    // made the root one leaf of every triangle: each ray tested them all.
    let radius = 3e38f32;
    let (nu, nv) = (48u32, 24u32);
    let mut mesh = TriangleMesh::default();
    for j in 0..=nv {
        let phi = std::f32::consts::PI * (j as f32 / nv as f32 - 0.5);
        for i in 0..nu {
            let theta = std::f32::consts::TAU * i as f32 / nu as f32;
            mesh.positions
                .push(Vec3A::new(theta.cos() * phi.cos(), theta.sin() * phi.cos(), phi.sin()) * radius);
        }
    }
    for j in 0..nv {
        for i in 0..nu {
            let v = |a: u32, b: u32| b * nu + a % nu;
            mesh.triangles.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
            mesh.triangles.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    let wide = MeshBvh::build(mesh.clone());
    let bvh = MeshBvh::build_with_layout(mesh, BvhLayout::Binary);
    assert!(bvh.triangle_count() > 2000);
    let largest = bvh.tree.largest_leaf();
    assert!(largest <= 4, "a leaf of {largest} triangles");
    let depth = bvh.tree.depth();
    assert!((9..=24).contains(&depth), "depth {depth}");
    // And the tree answers as brute force does, from the centre outward. (At this size the
    // triangle test's edge functions, products of two coordinates, leave f32: both may miss.)
    let mut rng = SplitMix(3);
    for _ in 0..64 {
        let d = Vec3A::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5);
        check_mesh_ray(&bvh, &Ray::new(Vec3A::ZERO, d.normalize()), radius).unwrap();
        check_mesh_ray(&wide, &Ray::new(Vec3A::ZERO, d.normalize()), radius).unwrap();
    }
}
