//! The RI's default texture coordinates of the seven quadrics: every vertex's `(s, t)` is its
//! `(u, v)`, checked against the RI's parametric formulas written out here independently; splitting the
//! seams and poles for them changes no position and no triangle count, and no triangle spans the seam.

use std::collections::BTreeSet;

use glam::{Mat4, Vec2, Vec3};
use obscura_scene::Shape;
use obscura_sdk::{DicingHint, Format};

use super::*;

/// A quadric and its surface `P(u, v)` by the RenderMan Interface's definition.
struct Case {
    shape: Shape,
    surface: fn(f64, f64) -> [f64; 3],
}

fn cases() -> Vec<Case> {
    use std::f64::consts::PI;
    vec![
        Case {
            shape: Shape::Sphere {
                radius: 2.0,
                z_min: -1.0,
                z_max: 2.0,
                theta_max: 360.0,
            },
            surface: |u, v| {
                let (p0, p1) = ((-0.5f64).asin(), PI / 2.0);
                let (t, p) = (u * 2.0 * PI, p0 + v * (p1 - p0));
                [2.0 * t.cos() * p.cos(), 2.0 * t.sin() * p.cos(), 2.0 * p.sin()]
            },
        },
        Case {
            shape: Shape::Cylinder {
                radius: 1.5,
                z_min: -1.0,
                z_max: 2.0,
                theta_max: 270.0,
            },
            surface: |u, v| {
                let t = u * 1.5 * PI;
                [1.5 * t.cos(), 1.5 * t.sin(), -1.0 + 3.0 * v]
            },
        },
        Case {
            shape: Shape::Cone {
                height: 2.0,
                radius: 1.0,
                theta_max: 360.0,
            },
            surface: |u, v| {
                let t = u * 2.0 * PI;
                [(1.0 - v) * t.cos(), (1.0 - v) * t.sin(), 2.0 * v]
            },
        },
        Case {
            shape: Shape::Disk {
                height: 0.5,
                radius: 2.0,
                theta_max: 360.0,
            },
            surface: |u, v| {
                let t = u * 2.0 * PI;
                [2.0 * (1.0 - v) * t.cos(), 2.0 * (1.0 - v) * t.sin(), 0.5]
            },
        },
        Case {
            shape: Shape::Torus {
                major_radius: 2.0,
                minor_radius: 0.5,
                phi_min: 0.0,
                phi_max: 360.0,
                theta_max: 360.0,
            },
            surface: |u, v| {
                let (t, p) = (u * 2.0 * PI, v * 2.0 * PI);
                let ring = 2.0 + 0.5 * p.cos();
                [ring * t.cos(), ring * t.sin(), 0.5 * p.sin()]
            },
        },
        Case {
            shape: Shape::Hyperboloid {
                point1: Vec3::new(1.0, 0.0, -1.0),
                point2: Vec3::new(0.0, 1.0, 1.0),
                theta_max: 360.0,
            },
            surface: |u, v| {
                let t = u * 2.0 * PI;
                let (x, y, z) = (1.0 - v, v, -1.0 + 2.0 * v);
                [x * t.cos() - y * t.sin(), x * t.sin() + y * t.cos(), z]
            },
        },
        Case {
            shape: Shape::Paraboloid {
                radius: 2.0,
                z_min: 0.0,
                z_max: 3.0,
                theta_max: 360.0,
            },
            surface: |u, v| {
                let t = u * 2.0 * PI;
                let z = 3.0 * v;
                let r = 2.0 * (z / 3.0).sqrt();
                [r * t.cos(), r * t.sin(), z]
            },
        },
    ]
}

/// Positions as exact bit patterns, for comparing sets.
fn position_set(mesh: &TriangleMesh) -> BTreeSet<[u32; 3]> {
    mesh.positions
        .iter()
        .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
        .collect()
}

#[test]
fn quadrics_carry_their_u_and_v_as_texture_coordinates() {
    // Far away (the uniform grid) and close in front (fitted cell by cell; the camera inside).
    for distance in [40.0f32, 0.0] {
        let mut ctx = DicingContext::new(DicingHint::Perspective, 60.0, Format::new(320, 240));
        ctx.object_to_camera = Mat4::from_translation(Vec3::new(0.0, 0.0, distance));
        for case in cases() {
            let plain = dice(&case.shape, &ctx).unwrap();
            let (mesh, st) = dice_with_st(&case.shape, &ctx).unwrap();
            let st = st.expect("a quadric has texture coordinates");
            assert_eq!(st.len(), mesh.positions.len(), "{:?}", case.shape);
            assert_eq!(mesh.triangles.len(), plain.triangles.len(), "{:?}", case.shape);
            assert_eq!(position_set(&mesh), position_set(&plain), "{:?}", case.shape);
            // A full turn's seam (all but the 270° cylinder) is split.
            let full_turn = !matches!(case.shape, Shape::Cylinder { .. });
            assert_eq!(
                mesh.positions.len() > plain.positions.len(),
                full_turn,
                "{:?}: the seam",
                case.shape
            );
            for (p, uv) in mesh.positions.iter().zip(&st) {
                let want = (case.surface)(f64::from(uv.x), f64::from(uv.y));
                let err = (0..3)
                    .map(|k| (f64::from(p[k]) - want[k]).abs())
                    .fold(0.0, f64::max);
                assert!(err < 1e-4, "{:?} at {uv}: {p} vs {want:?}", case.shape);
            }
            for t in &mesh.triangles {
                let uv = t.map(|k| st[k as usize]);
                let span = |f: fn(&Vec2) -> f32| {
                    let vals = uv.iter().map(f);
                    vals.clone().fold(f32::MIN, f32::max) - vals.fold(f32::MAX, f32::min)
                };
                assert!(
                    span(|v| v.x) < 0.5 && span(|v| v.y) < 0.5,
                    "{:?}: a triangle spans {uv:?}",
                    case.shape
                );
            }
        }
    }
}
