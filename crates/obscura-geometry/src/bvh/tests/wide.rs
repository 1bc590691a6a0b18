//! The wide layout against the binary one (same hits, bit for bit, with both kernel tiers) and
//! against brute force, and the collapse's structure.

use glam::Vec3A;
use proptest::prelude::*;

use super::*;
use crate::bvh::BvhLayout;
use crate::bvh::wide::{LANES, LEAF, WIDTH};

/// Both layouts over `mesh`.
fn both(mesh: &TriangleMesh) -> (MeshBvh, MeshBvh) {
    (
        MeshBvh::build_with_layout(mesh.clone(), BvhLayout::Wide),
        MeshBvh::build_with_layout(mesh.clone(), BvhLayout::Binary),
    )
}

/// The wide tree's answers equal the binary tree's exactly (`t`, triangle, `u`, `v` bits; any hit),
/// with each kernel tier.
fn same_bits(wide: &MeshBvh, binary: &MeshBvh, ray: &Ray) -> Result<(), TestCaseError> {
    let bits = |h: Option<MeshHit>| h.map(|(t, i, u, v)| (t.to_bits(), i, u.to_bits(), v.to_bits()));
    for scalar in KERNELS {
        prop_assert_eq!(
            bits(wide.intersect_with(ray, scalar)),
            bits(binary.intersect_with(ray, scalar)),
            "scalar kernel: {} ray {:?}",
            scalar,
            ray
        );
        prop_assert_eq!(wide.occluded_with(ray, scalar), binary.occluded_with(ray, scalar));
    }
    Ok(())
}

proptest! {
    #![proptest_config(config(256))]

    /// Random soups of up to 200 triangles (enough for several wide levels): the wide tree
    /// answers as brute force does and as the binary tree does, bit for bit.
    #[test]
    fn wide_matches_brute_force_and_binary(
        triangles in prop::collection::vec(triangle(), 1..200),
        specs in prop::collection::vec(ray_spec(), 1..24),
        scale in prop_oneof![Just(1.0f32), Just(1e-3f32), Just(1e4f32)],
    ) {
        let (wide, binary) = both(&soup(&triangles, scale));
        let targets: Vec<[Vec3A; 3]> = triangles.iter().map(|t| t.map(|p| p * scale)).collect();
        for spec in &specs {
            let ray = make_ray(spec, &targets, scale, false);
            check_mesh_ray(&wide, &ray, scale)?;
            same_bits(&wide, &binary, &ray)?;
        }
    }
}

#[test]
fn collapse_keeps_every_leaf_and_box() {
    // Every triangle appears in exactly one wide leaf, every child box contains its subtree, and
    // some nodes are full.
    let mut rng = SplitMix(9);
    let triangles: Vec<[Vec3A; 3]> = (0..5000)
        .map(|_| {
            let c = rng.vec(1.0);
            [c + rng.vec(0.02), c + rng.vec(0.02), c + rng.vec(0.02)]
        })
        .collect();
    let bvh = MeshBvh::build(soup(&triangles, 1.0));
    let nodes = &bvh.wide.nodes;
    let mut seen = vec![0u32; bvh.triangle_count()];
    let mut todo = vec![0usize];
    let mut partial = 0;
    while let Some(n) = todo.pop() {
        let node = &nodes[n];
        let used = (0..WIDTH).filter(|&k| node.meta[k] != LEAF).count();
        partial += usize::from(used < WIDTH);
        for k in 0..WIDTH {
            let (lo, hi) = (
                Vec3A::new(node.lo[0][k], node.lo[1][k], node.lo[2][k]),
                Vec3A::new(node.hi[0][k], node.hi[1][k], node.hi[2][k]),
            );
            if node.meta[k] == 0 {
                let c = &nodes[node.child[k] as usize];
                for j in (0..WIDTH).filter(|&j| c.meta[j] != LEAF) {
                    let (clo, chi) = (
                        Vec3A::new(c.lo[0][j], c.lo[1][j], c.lo[2][j]),
                        Vec3A::new(c.hi[0][j], c.hi[1][j], c.hi[2][j]),
                    );
                    assert!(
                        lo.cmple(clo).all() && chi.cmple(hi).all(),
                        "child box outside parent"
                    );
                }
                todo.push(node.child[k] as usize);
            } else {
                let (block, count) = (
                    &bvh.wide.leaves[node.child[k] as usize],
                    (node.meta[k] & !LEAF) as usize,
                );
                assert!(count <= LANES);
                for lane in 0..count {
                    seen[block.id[lane] as usize] += 1;
                    assert_eq!(block.triangle(lane), triangles[block.id[lane] as usize]);
                    for p in block.triangle(lane) {
                        assert!(
                            lo.cmple(p).all() && p.cmple(hi).all(),
                            "triangle outside its leaf box"
                        );
                    }
                }
            }
        }
    }
    assert!(seen.iter().all(|&s| s == 1), "a triangle in no leaf or in two");
    // Only nodes over a binary node with two leaf children (and the root of a tiny tree) have
    // fewer than four children.
    assert!(
        partial < nodes.len(),
        "{partial} of {} nodes not full",
        nodes.len()
    );
    let binary = MeshBvh::build_with_layout(soup(&triangles, 1.0), BvhLayout::Binary);
    assert!(
        bvh.wide.depth() * 2 <= binary.tree.depth() + 2,
        "collapse should halve the depth"
    );
    assert!(bvh.memory_bytes() < binary.memory_bytes());
}

#[test]
fn wide_layout_on_a_single_leaf_and_an_empty_mesh() {
    // A root that is one leaf becomes a wide node with one used slot; an empty mesh has no nodes.
    let one = soup(&[[Vec3A::ZERO, Vec3A::X, Vec3A::Y]], 1.0);
    let (wide, binary) = both(&one);
    assert_eq!(wide.wide.nodes.len(), 1);
    let r = Ray::new(Vec3A::new(0.2, 0.2, 1.0), Vec3A::NEG_Z);
    assert_eq!(wide.intersect(&r).map(|h| h.1), Some(0));
    same_bits(&wide, &binary, &r).unwrap();
    let empty = MeshBvh::build(TriangleMesh::default());
    assert!(empty.wide.nodes.is_empty());
    assert_eq!(empty.intersect(&r), None);
    assert!(!empty.occluded(&r));
}

#[test]
fn one_leaf_block_decides_zero_edge_functions_as_the_scalar_test_does() {
    // Four triangles in one leaf block, the ray along +z through the origin:
    // 0. an edge function f32 rounds to 0 while its exact value is +2⁻⁴⁶ and the other two are
    //    negative (from `edge_signs_are_exact_when_f32_rounds_them_to_zero`): a miss, decided by
    //    the exact redo;
    // 1. the same triangle moved 2⁻²⁰ across that edge and back to z = 1.5: a hit;
    // 2. an edge on the line x = 0 through the ray (its edge function exactly 0) with the other two
    //    of opposite signs (the ray meets the line outside the edge): a miss, dropped before the
    //    redo;
    // 3. a plain triangle at z = 2: a hit, but farther than 1.
    let e = f32::EPSILON;
    let exact = [
        Vec3A::new(1.0, -1.0, 1.0),
        Vec3A::new(1.0 + e, 1.0, 1.0),
        Vec3A::new(-(1.0 + 2.0 * e), -(1.0 + e), 1.0),
    ];
    let inside = exact.map(|p| p - Vec3A::new(2f32.powi(-20), -(2f32.powi(-20)), -0.5));
    let mixed = [
        Vec3A::new(0.0, 1.0, 0.75),
        Vec3A::new(0.0, 2.0, 0.75),
        Vec3A::new(1.0, 1.5, 0.75),
    ];
    let plain = [
        Vec3A::new(-1.0, -1.0, 2.0),
        Vec3A::new(1.0, -1.0, 2.0),
        Vec3A::new(0.0, 1.0, 2.0),
    ];
    let (wide, binary) = both(&soup(&[exact, inside, mixed, plain], 1.0));
    assert_eq!(
        wide.wide.leaves.len(),
        1,
        "the four triangles share one leaf block"
    );
    let r = Ray::new(Vec3A::ZERO, Vec3A::Z);
    for scalar in KERNELS {
        let hit = wide.intersect_with(&r, scalar).expect("triangle 1 is hit");
        assert_eq!((hit.0, hit.1), (1.5, 1), "scalar kernel only: {scalar}");
        assert!(wide.occluded_with(&r, scalar));
        // Without the nearer two, triangle 3 is what the ray meets.
        let far = Ray { t_min: 1.6, ..r };
        assert_eq!(
            wide.intersect_with(&far, scalar).map(|h| (h.0, h.1)),
            Some((2.0, 3))
        );
        // Short of every hit: nothing, though lanes 0 and 2 need the zero-edge rules.
        let short = Ray { t_max: 1.4, ..r };
        assert_eq!(wide.intersect_with(&short, scalar), None);
        assert!(!wide.occluded_with(&short, scalar));
    }
    for ray in [r, Ray { t_max: 1.4, ..r }, Ray { t_min: 1.6, ..r }] {
        same_bits(&wide, &binary, &ray).unwrap();
    }
}
