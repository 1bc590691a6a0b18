//! Tests of the hierarchies against brute force, and the helpers they share: brute-force closest and
//! any hit, proptest strategies for triangles and rays, and a deterministic generator.

mod flatten;
mod mesh;
mod quality;
mod scene;
mod triangle;
mod visibility;
mod wide;

use glam::{Affine3A, Vec3A};
use proptest::prelude::*;

use super::triangle::{TriRay, triangle_vertices};
use super::{Instance, MeshBvh};
use crate::ray::{Ray, TriangleMesh};

/// Instance of mesh `mesh` that stays at `transform`.
fn still(mesh: u32, transform: Affine3A) -> Instance {
    Instance {
        mesh,
        transform: vec![(0.0, transform)],
    }
}

/// `(t, triangle, u, v)`.
type MeshHit = (f32, u32, f32, f32);

/// Both traversal kernels (`true` = scalar only); without AVX2 both runs use the scalar one.
const KERNELS: [bool; 2] = [false, true];

fn brute_closest(mesh: &TriangleMesh, ray: &Ray) -> Option<MeshHit> {
    let tri_ray = TriRay::new(ray.origin, ray.direction);
    let mut best: Option<MeshHit> = None;
    for (i, &tri) in mesh.triangles.iter().enumerate() {
        let Some(v) = triangle_vertices(mesh, tri) else {
            continue;
        };
        if let Some((t, u, w)) = tri_ray.intersect(&v, ray.t_min, ray.t_max)
            && best.is_none_or(|b| t < b.0)
        {
            best = Some((t, i as u32, u, w));
        }
    }
    best
}

fn brute_any(mesh: &TriangleMesh, ray: &Ray) -> bool {
    let tri_ray = TriRay::new(ray.origin, ray.direction);
    mesh.triangles
        .iter()
        .filter_map(|&tri| triangle_vertices(mesh, tri))
        .any(|v| tri_ray.intersect(&v, ray.t_min, ray.t_max).is_some())
}

/// Checks a BVH against brute force on one ray, with both kernels.
fn check_mesh_ray(bvh: &MeshBvh, ray: &Ray, scale: f32) -> Result<(), TestCaseError> {
    let expected = brute_closest(bvh.mesh(), ray);
    let any = brute_any(bvh.mesh(), ray);
    for scalar in KERNELS {
        let got = bvh.intersect_with(ray, scalar);
        match (got, expected) {
            (None, None) => {}
            (Some(g), Some(e)) => {
                prop_assert!(
                    g.2 >= 0.0 && g.3 >= 0.0 && g.2 + g.3 <= 1.0 + 1e-6,
                    "barycentrics {:?}",
                    g
                );
                prop_assert_eq!(g.1, e.1, "triangle (scalar kernel: {}) for {:?}", scalar, ray);
                prop_assert!((g.0 - e.0).abs() <= 1e-4 * scale, "t {} vs {}", g.0, e.0);
                prop_assert!((g.2 - e.2).abs() <= 1e-4 && (g.3 - e.3).abs() <= 1e-4);
            }
            _ => prop_assert!(
                false,
                "BVH {:?} vs brute force {:?} (scalar kernel: {}) for {:?}",
                got,
                expected,
                scalar,
                ray
            ),
        }
        prop_assert_eq!(
            bvh.occluded_with(ray, scalar),
            any,
            "occluded (scalar kernel: {}) for {:?}",
            scalar,
            ray
        );
    }
    Ok(())
}

fn vec3(r: f32) -> impl Strategy<Value = Vec3A> {
    (-r..r, -r..r, -r..r).prop_map(|(x, y, z)| Vec3A::new(x, y, z))
}

/// Ordinary, sliver, exactly degenerate, collinear and axis-aligned (flat box) triangles.
fn triangle() -> impl Strategy<Value = [Vec3A; 3]> {
    (
        vec3(1.0),
        vec3(1.0),
        vec3(1.0),
        0u8..8,
        0.0f32..1.0,
        -1e-5f32..1e-5,
    )
        .prop_map(|(a, b, c, kind, s, eps)| {
            let snap = |v: Vec3A| Vec3A::new(v.x, v.y, (a.z * 4.0).round() / 4.0);
            match kind {
                0 => [a, b, a + (b - a) * s + c * eps],
                1 => [a, a, c],
                2 => [a, b, a + (b - a) * s],
                3 => [snap(a), snap(b), snap(c)],
                _ => [a, b, c],
            }
        })
}

/// Well-shaped triangles only (area at least 1% of the longest edge squared): for the world-vs-object
/// comparisons, where a sliver's plane (and so `t`) is too ill-conditioned to compare across spaces.
fn solid_triangle() -> impl Strategy<Value = [Vec3A; 3]> {
    (vec3(1.0), vec3(1.0), vec3(1.0))
        .prop_map(|(a, b, c)| [a, b, c])
        .prop_filter("sliver", |[a, b, c]| {
            let longest = (b - a)
                .length_squared()
                .max((c - b).length_squared())
                .max((a - c).length_squared());
            (b - a).cross(c - a).length() * 0.5 >= 0.01 * longest
        })
}

fn soup(triangles: &[[Vec3A; 3]], scale: f32) -> TriangleMesh {
    TriangleMesh {
        positions: triangles.iter().flatten().map(|&p| p * scale).collect(),
        normals: None,
        triangles: (0..triangles.len() as u32)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect(),
    }
}

#[derive(Debug, Clone)]
struct RaySpec {
    origin: Vec3A,
    snap_origin: bool,
    aim: Option<(prop::sample::Index, f32, f32)>,
    direction: Vec3A,
    zero_axis: u8,
    t_min: f32,
    t_max: Option<f32>,
}

fn ray_spec() -> impl Strategy<Value = RaySpec> {
    (
        vec3(2.0),
        any::<bool>(),
        prop::option::weighted(0.7, (any::<prop::sample::Index>(), 0.0f32..1.0, 0.0f32..1.0)),
        vec3(1.0),
        0u8..6,
        prop_oneof![Just(0.0f32), 0.0f32..1.0],
        prop::option::of(0.1f32..5.0),
    )
        .prop_map(
            |(origin, snap_origin, aim, direction, zero_axis, t_min, t_max)| RaySpec {
                origin,
                snap_origin,
                aim,
                direction,
                zero_axis,
                t_min,
                t_max,
            },
        )
}

/// A world ray from `spec`, aimed (when asked) at a point of one of `targets` (world-space
/// triangles); `interior` keeps that point at least 5% (in barycentrics) away from the edges.
fn make_ray(spec: &RaySpec, targets: &[[Vec3A; 3]], scale: f32, interior: bool) -> Ray {
    let mut origin = spec.origin * scale;
    if spec.snap_origin {
        origin = (spec.origin * 4.0).round() / 4.0 * scale;
    }
    let mut direction = match (&spec.aim, targets.is_empty()) {
        (Some((index, s, t)), false) => {
            let [a, b, c] = targets[index.index(targets.len())];
            let (s, t) = if s + t > 1.0 { (1.0 - s, 1.0 - t) } else { (*s, *t) };
            let (s, t) = if interior {
                (0.05 + 0.85 * s, 0.05 + 0.85 * t)
            } else {
                (s, t)
            };
            a + (b - a) * s + (c - a) * t - origin
        }
        _ => spec.direction,
    };
    if spec.zero_axis < 3 {
        direction[spec.zero_axis as usize] = 0.0;
    }
    Ray {
        origin,
        direction,
        t_min: spec.t_min * scale,
        t_max: spec.t_max.map_or(f32::INFINITY, |t| t * scale),
        time: 0.0,
    }
}

/// No regression files in the source tree; failures print their minimal input instead.
fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// SplitMix64 for the deterministic large tests.
struct SplitMix(u64);

impl SplitMix {
    fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }

    fn vec(&mut self, r: f32) -> Vec3A {
        Vec3A::new(self.next_f32(), self.next_f32(), self.next_f32()) * (2.0 * r) - Vec3A::splat(r)
    }
}
