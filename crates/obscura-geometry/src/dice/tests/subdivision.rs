//! Catmull–Clark: limit positions and normals against deep refinement, creases (sharp, semi-sharp,
//! fractional, Chaikin decay), n-gons, and malformed control meshes.

use std::f64::consts::TAU;

use glam::{Vec3, Vec3A};
use obscura_scene::{Shape, SubdivMesh};
use obscura_sdk::DicingHint;
use proptest::prelude::*;

use super::*;
use crate::dice::subdivision::{Level, Topology, control_level, subdivide, subdivide_to_limit};
use crate::dice::{DiceError, dice};
use crate::ray::TriangleMesh;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

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
