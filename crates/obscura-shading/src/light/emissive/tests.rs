use std::f64::consts::PI;

use glam::{Affine3A, Vec3A};
use obscura_scene::Material;
use obscura_sdk::Rgb;

use super::*;
use crate::integrator::{PathOptions, ShadingScene, trace_path};
use obscura_geometry::bvh::{Instance, SceneAccel};
use obscura_geometry::ray::{Ray, Tracer};
use obscura_geometry::rng::Rng;

/// Radiance `L` of the emitter; albedo `ρ` of the plane; the emitter's half-side `a` and height `h`.
const L: f32 = 2.0;
const RHO: f32 = 0.5;
const A: f32 = 1.0;
const H: f32 = 1.0;

/// The view factor from a point to a parallel `x × y` rectangle with one corner straight above it at
/// height 1 (x, y in units of the height): `F = (1/2π)·[X/√(1+X²)·atan(Y/√(1+X²)) + (X↔Y)]`.
fn corner_view_factor(x: f64, y: f64) -> f64 {
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * PI)
}

fn quad(corners: [Vec3A; 4]) -> TriangleMesh {
    TriangleMesh {
        positions: corners.to_vec(),
        normals: None,
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// A large diffuse floor at y = 0 (instance 0) under an emissive square at y = `H` (instance 1),
/// as `trace_path` sees them; `sample_emitters` false leaves the emitter to BSDF rays alone.
fn scene(sample_emitters: bool) -> (ShadingScene, SceneAccel) {
    let floor = quad([
        Vec3A::new(-50.0, 0.0, -50.0),
        Vec3A::new(50.0, 0.0, -50.0),
        Vec3A::new(50.0, 0.0, 50.0),
        Vec3A::new(-50.0, 0.0, 50.0),
    ]);
    let lamp = quad([
        Vec3A::new(-A, H, -A),
        Vec3A::new(A, H, -A),
        Vec3A::new(A, H, A),
        Vec3A::new(-A, H, A),
    ]);
    let materials = vec![
        Material::Diffuse {
            color: Rgb::new(RHO, RHO, RHO),
        },
        Material::Constant {
            color: Rgb::new(L, L, L),
        },
    ];
    let fixed = vec![(0.0, Affine3A::IDENTITY)];
    let texturing = Texturing::default();
    let emissive = if sample_emitters {
        let candidates: Vec<EmitterCandidate<'_>> = [&floor, &lamp]
            .iter()
            .enumerate()
            .map(|(i, mesh)| EmitterCandidate {
                mesh,
                transform: &fixed,
                material: materials[i],
                material_index: i as u32,
            })
            .collect();
        EmissiveTriangles::new(&candidates, &texturing)
    } else {
        EmissiveTriangles::default()
    };
    let instances = (0..2)
        .map(|mesh| Instance {
            mesh,
            transform: fixed.clone(),
        })
        .collect();
    let accel = SceneAccel::build(vec![floor, lamp], instances);
    let shading = ShadingScene {
        materials,
        instance_material: vec![0, 1],
        texturing,
        emissive,
        ..ShadingScene::default()
    };
    (shading, accel)
}

/// Mean red radiance and its standard error over `n` paths of one-bounce direct light.
fn estimate(scene: &ShadingScene, tracer: &dyn Tracer, ray: &Ray, n: usize) -> (f64, f64) {
    let opts = PathOptions {
        max_depth: 1,
        rr_start: 8,
    };
    let mut rng = Rng::new(5, 11);
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let x = f64::from(trace_path(scene, tracer, ray, &mut rng, &opts).radiance.x);
        s += x;
        s2 += x * x;
    }
    let m = s / n as f64;
    (m, ((s2 / n as f64 - m * m).max(0.0) / n as f64).sqrt())
}

#[test]
fn an_emissive_quad_lights_a_diffuse_plane_to_the_closed_form_irradiance() {
    // The camera ray reaches the floor right under the lamp's centre from the side, below the lamp.
    let origin = Vec3A::new(0.0, 0.5, -5.0);
    let ray = Ray {
        origin,
        direction: (-origin).normalize(),
        t_min: 0.0,
        t_max: f32::INFINITY,
        time: 0.0,
    };
    // Irradiance at the centre: four corner rectangles of a × a at height h, `E = π·L·4F`; the
    // floor reflects `ρ/π · E`.
    let f = 4.0 * corner_view_factor(f64::from(A / H), f64::from(A / H));
    let expected = f64::from(RHO) * f64::from(L) * f;

    let (with, accel) = scene(true);
    assert_eq!(
        with.emissive.len(),
        2,
        "the lamp's two triangles, not the floor's"
    );
    let (m, se) = estimate(&with, &accel, &ray, 20_000);
    // Stated error: within 1 % of the closed form (and 4 standard errors of the estimate).
    assert!(
        (m - expected).abs() < 0.01 * expected + 4.0 * se,
        "emitter sampling: {m} ± {se}, closed form {expected}"
    );
    assert!(se < 0.0025 * expected * 4.0, "{se}");

    // BSDF rays alone reach the same answer, noisier: light sampling cuts the standard error by more
    // than 40 % (0.0016 against 0.0035 here).
    let (without, accel) = scene(false);
    let (m_b, se_b) = estimate(&without, &accel, &ray, 20_000);
    assert!(
        (m_b - expected).abs() < 0.01 * expected + 4.0 * se_b,
        "BSDF sampling only: {m_b} ± {se_b}, closed form {expected}"
    );
    assert!(se < 0.6 * se_b, "emitter sampling {se} against BSDF only {se_b}");
}

#[test]
fn moving_emitters_and_non_emitters_are_not_sampled() {
    let lamp = quad([
        Vec3A::new(-1.0, 1.0, -1.0),
        Vec3A::new(1.0, 1.0, -1.0),
        Vec3A::new(1.0, 1.0, 1.0),
        Vec3A::new(-1.0, 1.0, 1.0),
    ]);
    let lit = Material::Constant {
        color: Rgb::new(1.0, 0.0, 0.0),
    };
    let moving = vec![
        (0.0, Affine3A::IDENTITY),
        (1.0, Affine3A::from_translation(glam::Vec3::X)),
    ];
    let fixed = vec![(0.0, Affine3A::IDENTITY)];
    let candidates = [
        EmitterCandidate {
            mesh: &lamp,
            transform: &moving,
            material: lit,
            material_index: 1,
        },
        EmitterCandidate {
            mesh: &lamp,
            transform: &fixed,
            material: Material::default(),
            material_index: 0,
        },
    ];
    let e = EmissiveTriangles::new(&candidates, &Texturing::default());
    assert!(e.is_empty());
    assert_eq!(e.pdf(0, 0, 1.0, Vec3A::Y, Vec3A::Y), None);
}
