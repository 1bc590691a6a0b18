//! Tests of [`super`] (integrator.rs).

use super::*;
use glam::{Mat4, Quat, Vec3};
use obscura_geometry::rng::Rng;
use obscura_scene::Light;
use obscura_sdk::Rgb;
use proptest::prelude::{Just, ProptestConfig, Strategy, any, prop, prop_assert, prop_oneof, proptest};
use std::f32::consts::PI;
use std::path::Path;

/// Exact spheres: `(centre, radius)`, instance `i` is sphere `i`.
struct Spheres(Vec<(Vec3A, f32)>);

impl Spheres {
    fn hit(&self, i: usize, ray: &Ray) -> Option<f32> {
        let (c, r) = self.0[i];
        let a = ray.direction.length_squared();
        let oc = ray.origin - c;
        let b = oc.dot(ray.direction);
        let l = oc - ray.direction * (b / a);
        let disc = a * (r * r - l.length_squared());
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let q = -b - b.signum() * disc.sqrt();
        let (t0, t1) = (q / a, (oc.length_squared() - r * r) / q);
        let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
        [t0, t1].into_iter().find(|&t| t > ray.t_min && t < ray.t_max)
    }
}

impl Tracer for Spheres {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let (t, i) = (0..self.0.len())
            .filter_map(|i| self.hit(i, ray).map(|t| (t, i)))
            .min_by(|a, b| a.0.total_cmp(&b.0))?;
        let position = ray.at(t);
        let mut n = (position - self.0[i].0).normalize();
        if n.dot(ray.direction) > 0.0 {
            n = -n;
        }
        Some(Hit {
            t,
            position,
            geometric_normal: n,
            shading_normal: n,
            uv: (0.0, 0.0),
            instance: i as u32,
            primitive: 0,
            edges: [Vec3A::ZERO; 2],
        })
    }

    fn occluded(&self, ray: &Ray) -> bool {
        (0..self.0.len()).any(|i| self.hit(i, ray).is_some())
    }
}

fn uniform_dome(radiance: f32) -> Lights {
    let dome = Light::Dome {
        color: Rgb::new(1.0, 1.0, 1.0),
        intensity: radiance,
        exposure: 0.0,
        map: None,
        transform: Mat4::IDENTITY,
    };
    Lights::new(&[dome], Path::new(".")).unwrap()
}

fn scene(material: Material, lights: Lights) -> ShadingScene {
    ShadingScene {
        materials: vec![material],
        instance_material: vec![0],
        lights,
        texturing: Default::default(),
        emissive: Default::default(),
        local_shading: Vec::new(),
    }
}

/// Camera rays from (0, 0, −5) toward a grid on the z = 0 plane: some hit the unit sphere at the
/// origin (at every angle of incidence), some miss it.
fn camera_rays() -> Vec<Ray> {
    let mut rays = Vec::new();
    for (x, y) in [
        (0.0, 0.0),
        (0.5, 0.1),
        (0.8, -0.3),
        (0.0, 0.97),
        (-0.6, 0.6),
        (1.5, 0.0),
        (0.0, -2.0),
    ] {
        let o = Vec3A::new(0.0, 0.0, -5.0);
        let d = (Vec3A::new(x, y, 0.0) - o).normalize();
        rays.push(Ray {
            origin: o,
            direction: d,
            t_min: 0.0,
            t_max: f32::INFINITY,
            time: 0.25,
        });
    }
    rays
}

/// Direct lighting only: one scattering event.
const DIRECT: PathOptions = PathOptions {
    max_depth: 1,
    rr_start: 3,
};

/// [`scene`] with a grey PxrDiffuse of albedo `albedo` lit by `light` alone.
fn lit_diffuse(albedo: f32, light: Light) -> ShadingScene {
    scene(
        Material::Diffuse {
            color: Rgb::new(albedo, albedo, albedo),
        },
        Lights::new(&[light], Path::new(".")).unwrap(),
    )
}

/// Mean radiance (red channel) and its standard error over `n` paths.
fn mean(scene: &ShadingScene, tracer: &dyn Tracer, ray: &Ray, n: usize, opts: &PathOptions) -> (f64, f64) {
    let mut rng = Rng::new(99, 7);
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let r = trace_path(scene, tracer, ray, &mut rng, opts);
        let x = f64::from(r.radiance.x);
        s += x;
        s2 += x * x;
    }
    let m = s / n as f64;
    (m, ((s2 / n as f64 - m * m).max(0.0) / n as f64).sqrt())
}

const DEEP: PathOptions = PathOptions {
    max_depth: 64,
    rr_start: 3,
};

#[test]
fn white_furnace_diffuse() {
    let tracer = Spheres(vec![(Vec3A::ZERO, 1.0)]);
    for (albedo, expected_hit) in [(1.0f32, 1.0f64), (0.5, 0.5)] {
        let s = scene(
            Material::Diffuse {
                color: Rgb::new(albedo, albedo, albedo),
            },
            uniform_dome(1.0),
        );
        for ray in camera_rays() {
            let hit = tracer.intersect(&ray).is_some();
            let (m, se) = mean(&s, &tracer, &ray, 16_384, &DEEP);
            let want = if hit { expected_hit } else { 1.0 };
            assert!(
                (m - want).abs() < 0.01 * want && (m - want).abs() < 5.0 * se + 1e-6,
                "albedo {albedo} ray {:?}: {m} ± {se}",
                ray.direction
            );
            let r = trace_path(&s, &tracer, &ray, &mut Rng::new(1, 1), &DEEP);
            assert_eq!(r.alpha, if hit { 1.0 } else { 0.0 });
            assert_eq!(r.first_hit.is_some(), hit);
        }
    }
}

#[test]
fn white_furnace_pxr_surface() {
    let tracer = Spheres(vec![(Vec3A::ZERO, 1.0)]);
    // A white PxrSurface conserves energy exactly (the coupled diffuse lobe takes what the
    // specular lobe does not reflect): 1 whatever F0 and roughness.
    for (f0, roughness) in [(0.0f32, 0.3f32), (0.0, 0.8), (0.04, 0.1), (0.5, 0.5), (1.0, 0.2)] {
        let m = Material::Surface {
            diffuse: Rgb::new(1.0, 1.0, 1.0),
            specular: Rgb::new(f0, f0, f0),
            roughness,
        };
        let s = scene(m, uniform_dome(1.0));
        for ray in camera_rays() {
            let (m, se) = mean(&s, &tracer, &ray, 8192, &DEEP);
            assert!(
                (m - 1.0).abs() < 0.02 && (m - 1.0).abs() < 5.0 * se + 0.005,
                "F0 {f0} roughness {roughness} ray {:?}: {m} ± {se}",
                ray.direction
            );
        }
    }
    // Any PxrSurface with colours in [0, 1] reflects at most what arrives.
    let mut rng = Rng::new(4, 4);
    for _ in 0..12 {
        let (d, f0, r) = (rng.next_f32(), rng.next_f32(), rng.next_f32());
        let m = Material::Surface {
            diffuse: Rgb::new(d, d, d),
            specular: Rgb::new(f0, f0, f0),
            roughness: r,
        };
        let s = scene(m, uniform_dome(1.0));
        for ray in camera_rays() {
            let (m, se) = mean(&s, &tracer, &ray, 1024, &DEEP);
            assert!(m < 1.0 + 5.0 * se + 0.005, "d {d} F0 {f0} r {r}: {m} ± {se}");
        }
    }
}

#[test]
fn distant_light_direct_lighting_is_albedo_over_pi_times_irradiance() {
    let tracer = Spheres(vec![(Vec3A::ZERO, 1.0)]);
    // Identity: the light travels toward +Z, lighting the side that faces the camera at −Z.
    let light = Light::Distant {
        color: Rgb::new(1.0, 1.0, 1.0),
        intensity: 2.0,
        exposure: 1.0,
        angle_extent: 0.0,
        enable_shadows: true,
        transform: Mat4::IDENTITY,
    };
    let s = lit_diffuse(0.8, light);
    for ray in camera_rays() {
        let r = trace_path(&s, &tracer, &ray, &mut Rng::new(3, 3), &DIRECT);
        let want = match tracer.intersect(&ray) {
            Some(h) => 0.8 / PI * 4.0 * h.geometric_normal.dot(-Vec3A::Z).max(0.0),
            None => 0.0,
        };
        assert!((r.radiance.x - want).abs() < 1e-4, "{} vs {want}", r.radiance.x);
    }
}

#[test]
fn sphere_light_direct_lighting_matches_the_closed_form() {
    // A diffuse unit sphere lit by a sphere light; the camera sees points on which the light
    // is fully above the horizon. Light sampling and BSDF sampling are both used (MIS).
    let tracer = Spheres(vec![(Vec3A::ZERO, 1.0)]);
    let centre = Vec3::new(0.0, 0.0, -4.0);
    let light = Light::Sphere {
        color: Rgb::new(1.0, 1.0, 1.0),
        intensity: 5.0,
        exposure: 0.0,
        transform: Mat4::from_scale_rotation_translation(Vec3::splat(1.5), Quat::IDENTITY, centre),
    };
    let s = lit_diffuse(0.5, light);
    let o = Vec3A::new(0.0, 3.0, -3.0);
    for target in [
        Vec3A::new(0.0, 0.3, -0.95),
        Vec3A::new(0.2, 0.0, -1.0),
        Vec3A::new(-0.3, 0.2, -0.9),
    ] {
        let ray = Ray::new(o, (target - o).normalize());
        let h = tracer.intersect(&ray).unwrap();
        let to_c = Vec3A::from(centre) - h.position;
        let (d, r) = (to_c.length(), 0.75f32);
        let sin2 = (r / d).powi(2);
        let cos = h.geometric_normal.dot(to_c / d);
        assert!(cos > sin2.sqrt() + 0.05, "light must be above the horizon");
        let want = f64::from(0.5 / PI * PI * 5.0 * sin2 * cos);
        let (m, se) = mean(&s, &tracer, &ray, 20_000, &DIRECT);
        assert!(
            (m - want).abs() < 0.02 * want && (m - want).abs() < 5.0 * se + 1e-4,
            "{m} ± {se} vs {want}"
        );
    }
    // A camera ray that sees the light itself: its radiance, alpha 1, no geometry hit.
    let ray = Ray::new(Vec3A::new(0.0, 0.0, -9.0), Vec3A::Z);
    let r = trace_path(&s, &tracer, &ray, &mut Rng::new(1, 1), &DIRECT);
    assert_eq!((r.radiance, r.alpha, r.first_hit), (Vec3A::splat(5.0), 1.0, None));
}

#[test]
fn constant_material_is_unlit_emission() {
    let tracer = Spheres(vec![(Vec3A::ZERO, 1.0), (Vec3A::new(0.0, 0.0, 3.0), 1.0)]);
    let s = ShadingScene {
        materials: vec![
            Material::Constant {
                color: Rgb::new(0.25, 0.5, 2.0),
            },
            Material::Diffuse {
                color: Rgb::new(1.0, 1.0, 1.0),
            },
        ],
        instance_material: vec![0, 1],
        lights: uniform_dome(1.0),
        texturing: Default::default(),
        emissive: Default::default(),
        local_shading: Vec::new(),
    };
    let ray = Ray::new(Vec3A::new(0.0, 0.0, -5.0), Vec3A::Z);
    let r = trace_path(&s, &tracer, &ray, &mut Rng::new(5, 5), &DEEP);
    assert_eq!(r.radiance, Vec3A::new(0.25, 0.5, 2.0));
    assert_eq!(r.alpha, 1.0);
}

#[test]
fn max_depth_zero_sees_only_emission() {
    let tracer = Spheres(vec![(Vec3A::ZERO, 1.0)]);
    let s = scene(
        Material::Diffuse {
            color: Rgb::new(1.0, 1.0, 1.0),
        },
        uniform_dome(1.0),
    );
    let opts = PathOptions {
        max_depth: 0,
        rr_start: 0,
    };
    let ray = Ray::new(Vec3A::new(0.0, 0.0, -5.0), Vec3A::Z);
    assert_eq!(
        trace_path(&s, &tracer, &ray, &mut Rng::new(5, 5), &opts).radiance,
        Vec3A::ZERO
    );
}

#[test]
fn power_heuristic_edges() {
    assert_eq!(power_heuristic(1.0, 0.0), 1.0);
    assert_eq!(power_heuristic(0.0, 1.0), 0.0);
    assert_eq!(power_heuristic(f32::NAN, 1.0), 0.0);
    assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
    assert_eq!(power_heuristic(1e-30, 1e30), 0.0);
    assert!((power_heuristic(1.0, 2.0) - 0.2).abs() < 1e-7);
    assert!((power_heuristic(3.0, 7.0) + power_heuristic(7.0, 3.0) - 1.0).abs() < 1e-6);
}

fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -2.0f32..4.0,
        1 => Just(0.0f32),
        1 => Just(1e30f32),
        1 => Just(-1e30f32),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(1e-30f32),
    ]
}

fn any_rgb() -> impl Strategy<Value = Rgb> {
    (any_f32(), any_f32(), any_f32()).prop_map(|(r, g, b)| Rgb::new(r, g, b))
}

fn any_material() -> impl Strategy<Value = Material> {
    prop_oneof![
        any_rgb().prop_map(|color| Material::Diffuse { color }),
        any_rgb().prop_map(|color| Material::Constant { color }),
        (any_rgb(), any_rgb(), any_f32()).prop_map(|(diffuse, specular, roughness)| Material::Surface {
            diffuse,
            specular,
            roughness
        }),
    ]
}

fn any_transform() -> impl Strategy<Value = Mat4> {
    prop_oneof![
        4 => (-3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0, 0.01f32..3.0).prop_map(
            |(ax, ay, az, tx, ty, s)| Mat4::from_scale_rotation_translation(
                Vec3::splat(s),
                Quat::from_euler(glam::EulerRot::XYZ, ax, ay, az),
                Vec3::new(tx, ty, tz_of(ax)),
            )
        ),
        1 => Just(Mat4::ZERO),
        1 => Just(Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0))),
        1 => Just(Mat4::from_scale(Vec3::new(1e-20, 1e20, 1.0))),
    ]
}

fn tz_of(a: f32) -> f32 {
    a * 0.7
}

fn any_light() -> impl Strategy<Value = Light> {
    prop_oneof![
        (any_rgb(), any_f32(), any_f32(), any_transform()).prop_map(
            |(color, intensity, exposure, transform)| {
                Light::Dome {
                    color,
                    intensity,
                    exposure,
                    map: None,
                    transform,
                }
            }
        ),
        (any_rgb(), any_f32(), any_f32(), any_f32(), any_transform()).prop_map(
            |(color, intensity, exposure, angle_extent, transform)| Light::Distant {
                color,
                intensity,
                exposure,
                angle_extent: angle_extent * 20.0,
                enable_shadows: true,
                transform,
            }
        ),
        (any_rgb(), any_f32(), any_f32(), any_transform()).prop_map(
            |(color, intensity, exposure, transform)| Light::Rect {
                color,
                intensity,
                exposure,
                transform
            }
        ),
        (any_rgb(), any_f32(), any_f32(), any_transform()).prop_map(
            |(color, intensity, exposure, transform)| {
                Light::Sphere {
                    color,
                    intensity,
                    exposure,
                    transform,
                }
            }
        ),
    ]
}

fn any_vec() -> impl Strategy<Value = Vec3A> {
    (-4.0f32..4.0, -4.0f32..4.0, -4.0f32..4.0).prop_map(|(x, y, z)| Vec3A::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn radiance_is_finite_and_non_negative(
        spheres in prop::collection::vec((any_vec(), 0.05f32..2.0, any_material()), 1..4),
        lights in prop::collection::vec(any_light(), 0..4),
        origin in any_vec(),
        direction in any_vec(),
        seed in any::<u64>(),
    ) {
        let tracer = Spheres(spheres.iter().map(|s| (s.0, s.1)).collect());
        let scene = ShadingScene {
            materials: spheres.iter().map(|s| s.2).collect(),
            instance_material: (0..spheres.len() as u32).collect(),
            lights: Lights::new(&lights, Path::new(".")).unwrap(),
            texturing: Default::default(),
            emissive: Default::default(),
            local_shading: Vec::new(),
        };
        let direction = direction.try_normalize().unwrap_or(Vec3A::Z);
        let ray = Ray { origin, direction, t_min: 0.0, t_max: f32::INFINITY, time: 0.5 };
        let mut rng = Rng::new(seed, 3);
        for _ in 0..8 {
            let r = trace_path(&scene, &tracer, &ray, &mut rng, &PathOptions::default());
            prop_assert!(r.radiance.is_finite(), "{:?}", r.radiance);
            prop_assert!(r.radiance.min_element() >= 0.0, "{:?}", r.radiance);
            prop_assert!(r.alpha == 0.0 || r.alpha == 1.0);
        }
    }
}

/// A classic shader's local shading with the ambient reflectance `Ka·Cs` = `ka`.
fn classic(ka: Rgb) -> Option<LocalShading> {
    Some(LocalShading {
        ambient: AmbientReflectance::Color(ka),
    })
}

#[test]
fn a_classic_surface_inside_a_closed_sphere_shows_exactly_its_ambient_term() {
    // The camera inside a closed sphere: nothing escapes, so only the unshadowed ambient term can
    // light it. A classic surface shows `Ka·Cs·Σ I·C` on every path, with no noise; before, the
    // ambient light was a dome the sphere hid, and the surface was black (or lit by its own bounces).
    let tracer = Spheres(vec![(Vec3A::ZERO, 10.0)]);
    let ambient = [
        Light::Ambient {
            color: Rgb::WHITE,
            intensity: 0.3,
        },
        Light::Ambient {
            color: Rgb::new(1.0, 0.0, 0.0),
            intensity: 0.1,
        },
    ];
    let mut s = scene(
        Material::Diffuse {
            color: Rgb::new(0.9, 0.9, 0.9),
        },
        Lights::new(&ambient, Path::new(".")).unwrap(),
    );
    s.local_shading = vec![classic(Rgb::new(0.5, 0.25, 1.0))];
    let want = Vec3A::new(0.4 * 0.5, 0.3 * 0.25, 0.3);
    let mut rng = Rng::new(5, 5);
    for k in 0..64 {
        let a = k as f32 * 0.7;
        let direction = Vec3A::new(a.cos(), (0.3 * a).sin(), a.sin()).normalize();
        let ray = Ray::new(Vec3A::new(0.5, -1.0, 2.0), direction);
        let r = trace_path(&s, &tracer, &ray, &mut rng, &DEEP);
        assert!(
            (r.radiance - want).abs().max_element() < 1e-6,
            "{} vs {want}",
            r.radiance
        );
        assert_eq!(r.alpha, 1.0);
    }
}

#[test]
fn a_path_traced_surface_adds_the_ambient_term_at_every_bounce() {
    // The same closed sphere with a PxrDiffuse of albedo ρ: each vertex reflects ρ·A and passes ρ
    // on, so the expected radiance is A·(ρ + ρ² + …) = A·ρ/(1 − ρ) (Russian roulette is unbiased).
    let tracer = Spheres(vec![(Vec3A::ZERO, 10.0)]);
    let rho = 0.5f64;
    let s = scene(
        Material::Diffuse {
            color: Rgb::new(0.5, 0.5, 0.5),
        },
        Lights::new(
            &[Light::Ambient {
                color: Rgb::WHITE,
                intensity: 0.4,
            }],
            Path::new("."),
        )
        .unwrap(),
    );
    let ray = Ray::new(Vec3A::ZERO, Vec3A::Z);
    let (m, se) = mean(&s, &tracer, &ray, 16_384, &DEEP);
    let want = 0.4 * rho / (1.0 - rho);
    assert!((m - want).abs() < 5.0 * se + 1e-3, "{m} ± {se} vs {want}");
}

#[test]
fn a_classic_surface_takes_its_lights_directly_and_nothing_by_way_of_other_surfaces() {
    // A unit sphere (classic matte, Kd·Cs = 0.8) inside a white enclosure of radius 10, lit by a point
    // light. Its radiance is the classic diffuse() term exactly, ρ/π · S·cos θ/d²; the white enclosure
    // lit by the same light would add light by way of its walls if the path went on.
    let tracer = Spheres(vec![(Vec3A::ZERO, 1.0), (Vec3A::ZERO, 10.0)]);
    let light_at = Vec3A::new(0.0, 0.0, -4.0);
    let point = Light::Point(obscura_scene::PointEmitter {
        color: Rgb::WHITE,
        intensity: 3.0,
        position: light_at.into(),
        enable_shadows: true,
    });
    let mut s = ShadingScene {
        materials: vec![
            Material::Diffuse {
                color: Rgb::new(0.8, 0.8, 0.8),
            },
            Material::Diffuse { color: Rgb::WHITE },
        ],
        instance_material: vec![0, 1],
        lights: Lights::new(&[point], Path::new(".")).unwrap(),
        ..ShadingScene::default()
    };
    s.local_shading = vec![classic(Rgb::BLACK), None];
    let mut checked = 0;
    for ray in camera_rays() {
        let Some(h) = tracer.intersect(&ray).filter(|h| h.instance == 0) else {
            continue;
        };
        let to_light = light_at - h.position;
        let d2 = to_light.length_squared();
        let want = 0.8 / PI * 3.0 * h.geometric_normal.dot(to_light.normalize()).max(0.0) / d2;
        let mut rng = Rng::new(7, 7);
        for _ in 0..16 {
            let r = trace_path(&s, &tracer, &ray, &mut rng, &DEEP);
            assert!((r.radiance.x - want).abs() < 1e-5, "{} vs {want}", r.radiance.x);
        }
        // Path traced, the same surface gathers the enclosure's light as well.
        let mut traced = s.clone();
        traced.local_shading.clear();
        let (m, se) = mean(&traced, &tracer, &ray, 4096, &DEEP);
        assert!(
            m > f64::from(want) + 0.01 && m > f64::from(want) + 5.0 * se,
            "{m} ± {se} vs {want}"
        );
        checked += 1;
    }
    assert!(checked >= 4);
}
