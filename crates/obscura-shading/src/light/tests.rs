//! Tests of [`super`] (light.rs).

use super::*;
use crate::integrator::power_heuristic;
use crate::material::cosine_hemisphere;
use glam::{Quat, Vec3};
use obscura_geometry::rng::Rng;
use obscura_sdk::Rgb;

fn prepare(lights: Vec<Light>) -> Lights {
    Lights::new(&lights, Path::new(".")).expect("lights")
}

fn white() -> Rgb {
    Rgb::new(1.0, 1.0, 1.0)
}

#[derive(Clone, Copy, PartialEq, Debug)]
enum Strategy {
    Light,
    Bsdf,
    Mis,
}

/// The irradiance `∫ L cos θ dω` at `p` (normal `n`, unoccluded) estimated with `n_paths`
/// samples of light sampling, cosine-weighted (Lambert) BSDF sampling, or both combined by the
/// power heuristic — the same combination the path tracer uses.
fn irradiance(lights: &Lights, p: Vec3A, n: Vec3A, n_paths: usize, strategy: Strategy) -> f64 {
    let mut rng = Rng::new(17, 5);
    let frame = Frame::new(n);
    let mut sum = 0.0f64;
    for _ in 0..n_paths {
        if strategy != Strategy::Bsdf
            && let Some(ls) = lights.sample(p, n, rng.next_2d(), rng.next_f32())
        {
            let cos = n.dot(ls.wi).max(0.0);
            let w = if strategy == Strategy::Mis && ls.mis {
                power_heuristic(ls.pdf, cos / PI)
            } else {
                1.0
            };
            sum += f64::from(ls.radiance.x * cos * w / ls.pdf);
        }
        if strategy != Strategy::Light {
            let wi = frame.to_world(cosine_hemisphere(rng.next_2d()));
            let pdf_b = n.dot(wi) / PI;
            if pdf_b <= 0.0 {
                continue;
            }
            let ray = Ray {
                origin: p,
                direction: wi,
                t_min: 0.0,
                t_max: f32::INFINITY,
                time: 0.0,
            };
            let (l, pdf_l) = match lights.intersect_area(&ray, f32::INFINITY) {
                Some(hit) => (hit.radiance, hit.pdf),
                None => lights.escaped(wi),
            };
            let w = if strategy == Strategy::Mis {
                power_heuristic(pdf_b, pdf_l)
            } else {
                1.0
            };
            sum += f64::from(l.x * PI * w);
        }
    }
    sum / n_paths as f64
}

fn assert_close(what: &str, got: f64, want: f64, rel: f64) {
    assert!(
        (got - want).abs() <= rel * want.abs().max(1e-3),
        "{what}: {got} vs {want}"
    );
}

/// Lambert's formula for the irradiance from a uniform polygon of radiance `le` (vertices in
/// order, fully above the horizon of `n` at `p`): `E = (le/2) |Σ γ_i n·(R_i × R_{i+1})/|…||`.
fn polygon_irradiance(le: f64, p: Vec3A, n: Vec3A, vertices: &[Vec3A]) -> f64 {
    let to64 = |v: Vec3A| glam::DVec3::new(v.x.into(), v.y.into(), v.z.into());
    let (p, n) = (to64(p), to64(n));
    let r: Vec<glam::DVec3> = vertices.iter().map(|&v| (to64(v) - p).normalize()).collect();
    let mut s = 0.0;
    for i in 0..r.len() {
        let (a, b) = (r[i], r[(i + 1) % r.len()]);
        let gamma = a.dot(b).clamp(-1.0, 1.0).acos();
        s += gamma * n.dot(a.cross(b).normalize());
    }
    0.5 * le * s.abs()
}

#[test]
fn rect_light_irradiance_matches_the_polygon_formula() {
    // A 2 × 1 rect, tilted, 1.5 above a receiver facing +Y, emitting downward (+Z → −Y).
    let rotation = Quat::from_rotation_z(0.3) * Quat::from_rotation_x(std::f32::consts::FRAC_PI_2);
    let transform =
        Mat4::from_scale_rotation_translation(Vec3::new(2.0, 1.0, 1.0), rotation, Vec3::new(0.3, 1.5, 0.2));
    let le = 3.0;
    let lights = prepare(vec![Light::Rect {
        color: white(),
        intensity: le,
        exposure: 0.0,
        transform,
    }]);
    let corners: Vec<Vec3A> = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
        .iter()
        .map(|&(x, y)| Vec3A::from(transform.transform_point3(Vec3::new(x, y, 0.0))))
        .collect();
    for (p, n) in [
        (Vec3A::ZERO, Vec3A::Y),
        (Vec3A::new(0.5, 0.0, -0.4), Vec3A::new(0.2, 1.0, 0.1).normalize()),
    ] {
        let exact = polygon_irradiance(f64::from(le), p, n, &corners);
        for s in [Strategy::Light, Strategy::Bsdf, Strategy::Mis] {
            let e = irradiance(&lights, p, n, 200_000, s);
            assert_close(&format!("rect {s:?} at {p}"), e, exact, 0.02);
        }
    }
    // One-sided: the same rect turned to face up sends nothing down.
    let flipped = Mat4::from_rotation_translation(
        Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        Vec3::new(0.0, 1.5, 0.0),
    );
    let lights = prepare(vec![Light::Rect {
        color: white(),
        intensity: le,
        exposure: 0.0,
        transform: flipped,
    }]);
    for s in [Strategy::Light, Strategy::Bsdf, Strategy::Mis] {
        assert_eq!(
            irradiance(&lights, Vec3A::ZERO, Vec3A::Y, 10_000, s),
            0.0,
            "{s:?}"
        );
    }
}

#[test]
fn sphere_light_irradiance_is_pi_le_sin2_cos() {
    let (center, scale, le) = (Vec3::new(0.8, 2.0, 0.3), 1.4f32, 2.0f32);
    let transform = Mat4::from_scale_rotation_translation(Vec3::splat(scale), Quat::IDENTITY, center);
    let lights = prepare(vec![Light::Sphere {
        color: white(),
        intensity: 1.0,
        exposure: 1.0,
        transform,
    }]);
    for n in [Vec3A::Y, Vec3A::new(0.3, 1.0, -0.2).normalize()] {
        let to_c = Vec3A::from(center);
        let d = to_c.length();
        let r = 0.5 * scale;
        let exact = f64::from(PI * le * (r / d).powi(2) * n.dot(to_c / d));
        for s in [Strategy::Light, Strategy::Bsdf, Strategy::Mis] {
            let e = irradiance(&lights, Vec3A::ZERO, n, 200_000, s);
            assert_close(&format!("sphere {s:?} n {n}"), e, exact, 0.02);
        }
    }
}

#[test]
fn distant_light_irradiance_is_intensity_cos() {
    // Travels along the light's +Z, here turned to travel down and sideways.
    let rotation = Quat::from_rotation_x(1.9) * Quat::from_rotation_y(0.2);
    let travel = Vec3A::from(rotation * Vec3::Z);
    let transform = Mat4::from_quat(rotation);
    let n = Vec3A::Y;
    let cos = n.dot(-travel);
    assert!(cos > 0.5);
    for (extent, strategies) in [
        (0.53f32, &[Strategy::Light, Strategy::Mis][..]),
        (0.0, &[Strategy::Light, Strategy::Mis][..]),
        (30.0, &[Strategy::Light, Strategy::Bsdf, Strategy::Mis][..]),
    ] {
        let lights = prepare(vec![Light::Distant {
            color: white(),
            intensity: 3.0,
            exposure: 0.0,
            angle_extent: extent,
            enable_shadows: true,
            transform,
        }]);
        // The mean of cos over a cone of half-angle θc around the axis: cos θ (1 + cos θc)/2.
        let cos_c = (extent.to_radians() * 0.5).cos();
        let exact = f64::from(3.0 * cos * (1.0 + cos_c) / 2.0);
        for &s in strategies {
            let e = irradiance(&lights, Vec3A::ZERO, n, 100_000, s);
            assert_close(&format!("distant {extent}° {s:?}"), e, exact, 0.01);
        }
    }
    // Identity: light travels toward +Z, so a surface facing −Z is lit and one facing +Z not.
    let lights = prepare(vec![Light::Distant {
        color: white(),
        intensity: 1.0,
        exposure: 0.0,
        angle_extent: 0.53,
        enable_shadows: true,
        transform: Mat4::IDENTITY,
    }]);
    assert_close(
        "facing -Z",
        irradiance(&lights, Vec3A::ZERO, -Vec3A::Z, 1000, Strategy::Light),
        1.0,
        1e-3,
    );
    assert_eq!(
        irradiance(&lights, Vec3A::ZERO, Vec3A::Z, 1000, Strategy::Light),
        0.0
    );
}

/// Writes a lat-long EXR whose texel (x, y) is `f(x, y)`.
fn write_map(dir: &Path, name: &str, w: usize, h: usize, f: impl Fn(usize, usize) -> f32 + Sync) -> PathBuf {
    let path = dir.join(name);
    exr::prelude::write_rgb_file(&path, w, h, |x, y| {
        let v = f(x, y);
        (v, v, v)
    })
    .expect("write map");
    path
}

fn dome(map: Option<PathBuf>, transform: Mat4) -> Light {
    Light::Dome {
        color: white(),
        intensity: 1.0,
        exposure: 0.0,
        map,
        transform,
    }
}

/// `∫ L cos⁺ dω` over the map by quadrature (8 × 8 points per texel).
fn dome_irradiance_quadrature(lights: &Lights, n: Vec3A, w: usize, h: usize) -> f64 {
    let sub = 8;
    let mut sum = 0.0f64;
    for y in 0..h * sub {
        let v = (y as f64 + 0.5) / (h * sub) as f64;
        let theta = std::f64::consts::PI * v;
        let d_omega = (2.0 * std::f64::consts::PI / (w * sub) as f64)
            * (std::f64::consts::PI / (h * sub) as f64)
            * theta.sin();
        for x in 0..w * sub {
            let u = (x as f64 + 0.5) / (w * sub) as f64;
            let phi = 2.0 * std::f64::consts::PI * (u - 0.5);
            let d = Vec3A::new(
                (theta.sin() * phi.sin()) as f32,
                theta.cos() as f32,
                (theta.sin() * phi.cos()) as f32,
            );
            let cos = f64::from(n.dot(d).max(0.0));
            sum += f64::from(lights.escaped(d).0.x) * cos * d_omega;
        }
    }
    sum
}

#[test]
fn dome_map_importance_sampling_agrees_with_cosine_sampling() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (64, 32);
    // A bright band above the horizon plus a dim floor.
    let path = write_map(dir.path(), "band.exr", w, h, |x, y| {
        if (6..10).contains(&y) && x < 40 { 20.0 } else { 0.1 }
    });
    let lights = prepare(vec![dome(Some(path), Mat4::from_rotation_y(0.4))]);
    for n in [
        Vec3A::Y,
        Vec3A::new(1.0, 1.0, 0.3).normalize(),
        Vec3A::new(0.0, -0.2, 1.0).normalize(),
    ] {
        let exact = dome_irradiance_quadrature(&lights, n, w, h);
        let light = irradiance(&lights, Vec3A::ZERO, n, 200_000, Strategy::Light);
        let bsdf = irradiance(&lights, Vec3A::ZERO, n, 200_000, Strategy::Bsdf);
        let mis = irradiance(&lights, Vec3A::ZERO, n, 200_000, Strategy::Mis);
        assert_close(&format!("dome light sampling, n {n}"), light, exact, 0.02);
        assert_close(&format!("dome cosine sampling, n {n}"), bsdf, exact, 0.03);
        assert_close(&format!("dome MIS, n {n}"), mis, exact, 0.02);
    }
}

#[test]
fn dome_map_orientation() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (64, 32);
    // Bright only at the centre of the image (u ≈ ½, v ≈ ½): documented as +Z.
    let centre = write_map(dir.path(), "centre.exr", w, h, |x, y| {
        if (31..33).contains(&x) && (15..17).contains(&y) {
            100.0
        } else {
            0.0
        }
    });
    // Bright only at u ≈ ¾, v ≈ ½: documented as +X.
    let east = write_map(dir.path(), "east.exr", w, h, |x, y| {
        if (47..49).contains(&x) && (15..17).contains(&y) {
            100.0
        } else {
            0.0
        }
    });
    // Bright only in the top rows: +Y.
    let top = write_map(
        dir.path(),
        "top.exr",
        w,
        h,
        |_, y| if y < 2 { 100.0 } else { 0.0 },
    );
    let lit = |path: &PathBuf, transform: Mat4, n: Vec3A| {
        let lights = prepare(vec![dome(Some(path.clone()), transform)]);
        irradiance(&lights, Vec3A::ZERO, n, 4000, Strategy::Light)
    };
    let id = Mat4::IDENTITY;
    assert!(lit(&centre, id, Vec3A::Z) > 0.5);
    assert_eq!(lit(&centre, id, -Vec3A::Z), 0.0);
    assert!(lit(&centre, id, Vec3A::Z) > 20.0 * lit(&centre, id, Vec3A::X));
    assert!(lit(&east, id, Vec3A::X) > 0.5);
    assert_eq!(lit(&east, id, -Vec3A::X), 0.0);
    assert!(lit(&top, id, Vec3A::Y) > 0.5);
    assert_eq!(lit(&top, id, -Vec3A::Y), 0.0);
    // The light's transform turns the map: rotating 90° about +Y carries light-space +Z to +X.
    let turned = Mat4::from_rotation_y(std::f32::consts::FRAC_PI_2);
    assert!(lit(&centre, turned, Vec3A::X) > 0.5);
    assert_eq!(lit(&centre, turned, -Vec3A::X), 0.0);
    assert!(lit(&centre, turned, Vec3A::X) > 20.0 * lit(&centre, turned, Vec3A::Z));
    // The lookup itself, without sampling.
    let lights = prepare(vec![dome(Some(centre), id)]);
    assert_eq!(lights.escaped(Vec3A::Z).0, Vec3A::splat(100.0));
    assert_eq!(lights.background(Vec3A::new(0.01, 0.0, 1.0)), Vec3A::splat(100.0));
    assert_eq!(lights.escaped(-Vec3A::Z).0, Vec3A::ZERO);
}

#[test]
fn unreadable_map_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = PathBuf::from("no-such-sky.exr");
    let err = Lights::new(&[dome(Some(missing), Mat4::IDENTITY)], dir.path()).unwrap_err();
    assert!(err.to_string().contains("no-such-sky.exr"), "{err}");
    let garbage = dir.path().join("garbage.exr");
    std::fs::write(&garbage, b"not an exr").unwrap();
    let err = Lights::new(&[dome(Some(garbage), Mat4::IDENTITY)], dir.path()).unwrap_err();
    assert!(err.to_string().contains("garbage.exr"), "{err}");
}

/// What `sample` reports for a direction is what `intersect_area` and `escaped` report for a BSDF
/// ray in that direction: the condition for MIS weights that sum to 1.
#[test]
fn sample_and_lookup_pdfs_agree() {
    let dir = tempfile::tempdir().unwrap();
    let map = write_map(dir.path(), "ramp.exr", 32, 16, |x, y| 0.1 + (x * y) as f32);
    let lights = prepare(vec![
        Light::Rect {
            color: white(),
            intensity: 1.0,
            exposure: 0.0,
            transform: Mat4::from_rotation_translation(
                Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
                Vec3::new(0.0, 2.0, 0.0),
            ),
        },
        Light::Sphere {
            color: white(),
            intensity: 1.0,
            exposure: 0.0,
            transform: Mat4::from_translation(Vec3::new(3.0, 1.0, 0.0)),
        },
        dome(Some(map), Mat4::from_rotation_z(0.3)),
        Light::Distant {
            color: white(),
            intensity: 1.0,
            exposure: 0.0,
            angle_extent: 40.0,
            enable_shadows: true,
            transform: Mat4::from_rotation_x(2.0),
        },
    ]);
    let mut rng = Rng::new(1, 9);
    let p = Vec3A::new(0.1, 0.0, 0.2);
    let mut checked = 0;
    for _ in 0..4000 {
        let Some(ls) = lights.sample(p, Vec3A::ZERO, rng.next_2d(), rng.next_f32()) else {
            continue;
        };
        let ray = Ray {
            origin: p,
            direction: ls.wi,
            t_min: 0.0,
            t_max: f32::INFINITY,
            time: 0.0,
        };
        let (l, pdf) = match lights.intersect_area(&ray, f32::INFINITY) {
            Some(hit) => {
                assert!(
                    (hit.t - ls.dist).abs() < 1e-3 * ls.dist,
                    "{} vs {}",
                    hit.t,
                    ls.dist
                );
                (hit.radiance, hit.pdf)
            }
            None => {
                assert!(ls.dist.is_infinite());
                lights.escaped(ls.wi)
            }
        };
        assert!((pdf - ls.pdf).abs() <= 1e-3 * ls.pdf, "{pdf} vs {}", ls.pdf);
        assert!((l - ls.radiance).abs().max_element() <= 1e-4 * l.max_element().max(1.0));
        checked += 1;
    }
    assert!(checked > 2000);
}

#[test]
fn lights_that_cannot_emit_are_dropped() {
    let lights = prepare(vec![
        Light::Rect {
            color: white(),
            intensity: 0.0,
            exposure: 0.0,
            transform: Mat4::IDENTITY,
        },
        Light::Sphere {
            color: white(),
            intensity: 1.0,
            exposure: 0.0,
            transform: Mat4::ZERO,
        },
        Light::Distant {
            color: Rgb::new(f32::NAN, -1.0, 0.0),
            intensity: 1.0,
            exposure: 0.0,
            angle_extent: 0.53,
            enable_shadows: true,
            transform: Mat4::IDENTITY,
        },
    ]);
    assert!(lights.is_empty());
    assert!(lights.sample(Vec3A::ZERO, Vec3A::Y, (0.5, 0.5), 0.5).is_none());
    assert_eq!(lights.escaped(Vec3A::Y), (Vec3A::ZERO, 0.0));
}
