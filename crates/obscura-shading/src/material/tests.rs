//! Tests of [`super`] (material.rs).

use super::*;
use obscura_geometry::rng::Rng;

/// Uniform over the upper hemisphere, `z ≥ z_min`.
fn random_dir_upper(rng: &mut Rng, z_min: f32) -> Vec3A {
    let (u1, u2) = rng.next_2d();
    let z = u1.max(z_min);
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3A::new(r * (TAU * u2).cos(), r * (TAU * u2).sin(), z)
}

fn surface(d: f32, f0: f32, roughness: f32) -> Material {
    Material::Surface {
        diffuse: Rgb::new(d, d, d),
        specular: Rgb::new(f0, f0, f0),
        roughness,
    }
}

/// `∫ D(h) cos θ_h dω = 2π ∫₀¹ D(μ) μ dμ = 1`, by the trapezoid rule on a grid fine near μ = 1.
#[test]
fn ggx_d_is_normalised() {
    for alpha in [0.02f32, 0.05, 0.2, 0.5, 0.8, 1.0] {
        // Substitute μ = 1 − s², dμ = 2s ds, to resolve the peak at μ = 1.
        let n = 200_000;
        let mut sum = 0.0f64;
        for k in 0..n {
            let s = (k as f64 + 0.5) / n as f64;
            let mu = 1.0 - s * s;
            let h = Vec3A::new((1.0 - mu * mu).max(0.0).sqrt() as f32, 0.0, mu as f32);
            sum += f64::from(ggx_d(h, alpha)) * mu * 2.0 * s / n as f64;
        }
        let integral = 2.0 * std::f64::consts::PI * sum;
        assert!((integral - 1.0).abs() < 2e-3, "alpha {alpha}: {integral}");
    }
}

/// Smith's `G1` is what normalises the visible normals: `∫ max(0, wo·h) D(h) dω_h =
/// cos θo (1 + Λ(wo))`, so `∫ G1(wo) max(0, wo·h) D(h) dω_h = cos θo` (Heitz 2014, eq. 3).
#[test]
fn smith_g1_normalises_the_visible_normals() {
    for alpha in [0.3f32, 0.7] {
        for theta_o in [30f32, 70.0] {
            let (s, c) = theta_o.to_radians().sin_cos();
            let wo = Vec3A::new(s, 0.0, c);
            let (ns, np) = (2000, 512);
            let mut sum = 0.0f64;
            for a in 0..ns {
                // μ = 1 − t², dμ = 2t dt resolves the peak at μ = 1.
                let t = (a as f64 + 0.5) / ns as f64;
                let mu = 1.0 - t * t;
                let r = (1.0 - mu * mu).max(0.0).sqrt();
                for b in 0..np {
                    let phi = (b as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                    let h = Vec3A::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, mu as f32);
                    let w = f64::from(wo.dot(h).max(0.0) * ggx_d(h, alpha));
                    sum += w * 2.0 * t / ns as f64 * std::f64::consts::TAU / np as f64;
                }
            }
            let g1 = f64::from(ggx_g1(wo, alpha));
            assert!(
                (g1 * sum - f64::from(c)).abs() < 2e-3,
                "α {alpha} θo {theta_o}: {}",
                g1 * sum
            );
        }
    }
    // The height-correlated form, by hand: α = 0.5, θo = 60°, θi = 45°:
    // Λo = (√1.75 − 1)/2, Λi = (√1.25 − 1)/2, G2 = 1/(1 + Λo + Λi) = 0.819 36
    // (the uncorrelated product G1(wo) G1(wi) would be 0.813 02).
    let wo = Vec3A::new(60f32.to_radians().sin(), 0.0, 0.5);
    let wi = Vec3A::new(0.0, 45f32.to_radians().sin(), 45f32.to_radians().cos());
    let want = 1.0 / (1.0 + (1.75f32.sqrt() - 1.0) / 2.0 + (1.25f32.sqrt() - 1.0) / 2.0);
    assert!((ggx_g2(wo, wi, 0.5) - want).abs() < 1e-5);
    assert!((want - 0.81936).abs() < 1e-4);
}

#[test]
fn sample_pdf_and_weight_match_eval() {
    let mut rng = Rng::new(3, 1);
    let materials = [
        surface(0.8, 0.04, 0.3),
        surface(0.2, 0.9, 0.05),
        surface(0.0, 0.5, 0.7),
        surface(1.0, 0.0, 1.0),
        Material::Diffuse {
            color: Rgb::new(0.7, 0.5, 0.2),
        },
    ];
    for (m, normal) in materials
        .iter()
        .flat_map(|m| [(m, Vec3A::Z), (m, Vec3A::new(0.3, -0.5, 0.8).normalize())])
    {
        let bsdf = Bsdf::new(m, normal);
        let frame = Frame::new(normal);
        let mut checked = 0;
        for _ in 0..2000 {
            let z_min = if normal == Vec3A::Z { 1e-3 } else { 0.05 };
            let wo = frame.to_world(random_dir_upper(&mut rng, z_min));
            let Some(s) = bsdf.sample(wo, rng.next_2d(), rng.next_f32()) else {
                continue;
            };
            assert!(!s.specular);
            let (f, pdf) = bsdf.eval(wo, s.wi);
            // With n = +Z the frame is exact and so must be the match; with a tilted normal the
            // round trip local → world → local rounds `wi`, which a narrow lobe (D ≈ 10⁵ at
            // roughness 0.05) magnifies to a few 10⁻³.
            let tol = if normal == Vec3A::Z { 1e-4 } else { 5e-3 };
            assert!(
                (pdf - s.pdf).abs() <= tol * pdf.max(1.0),
                "{m:?} {normal}: {pdf} vs {}",
                s.pdf
            );
            let w = f * normal.dot(s.wi) / pdf;
            assert!((w - s.weight).abs().max_element() <= tol * w.max_element().max(1.0));
            checked += 1;
        }
        assert!(checked > 1000, "{m:?}: only {checked} samples");
    }
}

#[test]
fn bsdf_is_reciprocal() {
    let mut rng = Rng::new(5, 2);
    let normal = Vec3A::Z;
    for m in [
        surface(0.5, 0.04, 0.2),
        surface(0.9, 0.6, 0.8),
        surface(0.3, 0.2, 0.02),
    ] {
        let bsdf = Bsdf::new(&m, normal);
        for _ in 0..2000 {
            let (a, b) = (random_dir_upper(&mut rng, 1e-3), random_dir_upper(&mut rng, 1e-3));
            let (fab, _) = bsdf.eval(a, b);
            let (fba, _) = bsdf.eval(b, a);
            let tol = 1e-4 * fab.max_element().max(1.0);
            assert!((fab - fba).abs().max_element() <= tol, "{m:?}: {fab} vs {fba}");
        }
    }
}

/// Chi-square goodness of fit of sampled directions against `eval`'s pdf on a (μ, φ) grid.
#[test]
fn sampled_directions_follow_the_pdf() {
    const NT: usize = 10;
    const NP: usize = 16;
    const SUB: usize = 24;
    let normal = Vec3A::Z;
    let wo = Vec3A::new(0.6, 0.0, 0.8);
    for m in [
        surface(0.5, 0.3, 0.5),
        surface(0.2, 0.8, 0.8),
        surface(0.7, 0.04, 0.6),
    ] {
        let bsdf = Bsdf::new(&m, normal);
        let n = 200_000;
        let mut counts = [[0u32; NP]; NT];
        let mut rng = Rng::new(11, 3);
        let mut drawn = 0;
        for _ in 0..n {
            if let Some(s) = bsdf.sample(wo, rng.next_2d(), rng.next_f32()) {
                let it = ((s.wi.z * NT as f32) as usize).min(NT - 1);
                let phi = s.wi.y.atan2(s.wi.x).rem_euclid(TAU);
                let ip = ((phi / TAU * NP as f32) as usize).min(NP - 1);
                counts[it][ip] += 1;
                drawn += 1;
            }
        }
        // A sample below the horizon (returned as None) still counts toward n: expected
        // counts are n × ∫ pdf over the bin.
        let mut chi2 = 0.0f64;
        let mut dof = 0;
        let mut total_expected = 0.0;
        for (it, row) in counts.iter().enumerate() {
            for (ip, &count) in row.iter().enumerate() {
                let mut integral = 0.0f64;
                for a in 0..SUB {
                    for b in 0..SUB {
                        let mu = (it as f64 + (a as f64 + 0.5) / SUB as f64) / NT as f64;
                        let phi =
                            (ip as f64 + (b as f64 + 0.5) / SUB as f64) / NP as f64 * std::f64::consts::TAU;
                        let r = (1.0 - mu * mu).max(0.0).sqrt();
                        let wi = Vec3A::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, mu as f32);
                        integral += f64::from(bsdf.eval(wo, wi).1);
                    }
                }
                let area = std::f64::consts::TAU / (NT * NP) as f64;
                let expected = integral / (SUB * SUB) as f64 * area * n as f64;
                total_expected += expected;
                let observed = f64::from(count);
                if expected > 5.0 {
                    chi2 += (observed - expected).powi(2) / expected;
                    dof += 1;
                }
            }
        }
        assert!(
            (total_expected - drawn as f64).abs() < 0.01 * n as f64,
            "{total_expected} {drawn}"
        );
        // The 0.999 quantile of χ² with k degrees of freedom is below k + 4.5√(2k) here.
        let limit = dof as f64 + 4.5 * (2.0 * dof as f64).sqrt();
        assert!(chi2 < limit, "{m:?}: chi2 {chi2} with {dof} bins (limit {limit})");
    }
}

/// The directional albedo `∫ f μi dωi` estimated by sampling: 1 for a white PxrSurface (any
/// F0, any roughness), never above 1 for any PxrSurface with colours in [0, 1].
#[test]
fn surface_conserves_energy() {
    let mut rng = Rng::new(7, 4);
    let normal = Vec3A::Z;
    for (d, f0, r) in [
        (1.0, 0.0, 0.3),
        (1.0, 0.04, 0.05),
        (1.0, 1.0, 0.5),
        (1.0, 0.5, 1.0),
    ] {
        let bsdf = Bsdf::new(&surface(d, f0, r), normal);
        for mu in [0.05f32, 0.3, 0.7, 1.0] {
            let wo = Vec3A::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let n = 40_000;
            let mut sum = Vec3A::ZERO;
            for _ in 0..n {
                if let Some(s) = bsdf.sample(wo, rng.next_2d(), rng.next_f32()) {
                    sum += s.weight;
                }
            }
            let albedo = sum.x / n as f32;
            assert!(
                (albedo - 1.0).abs() < 0.03,
                "d {d} F0 {f0} r {r} μ {mu}: {albedo}"
            );
        }
    }
    for _ in 0..40 {
        let (d, f0, r) = (rng.next_f32(), rng.next_f32(), rng.next_f32());
        let bsdf = Bsdf::new(&surface(d, f0, r), normal);
        let mu = rng.next_f32().max(0.02);
        let wo = Vec3A::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let n = 10_000;
        let mut sum = 0.0;
        for _ in 0..n {
            if let Some(s) = bsdf.sample(wo, rng.next_2d(), rng.next_f32()) {
                sum += s.weight.x;
            }
        }
        let albedo = sum / n as f32;
        assert!(albedo < 1.03, "d {d} F0 {f0} r {r} μ {mu}: {albedo}");
    }
}

#[test]
fn energy_table_matches_the_mirror_and_a_direct_quadrature() {
    let t = EnergyTable::get();
    // Roughness 0: a mirror reflects F(μ) exactly.
    let (e1, e2) = t.albedo(0.5 + 0.5 / N_MU as f32, 0.0);
    assert!((e1 - 1.0).abs() < 1e-6);
    let mu = 0.5 + 0.5 / N_MU as f32;
    assert!((e2 - (1.0 - mu).powi(5)).abs() < 1e-6);
    // Roughness 0.6, μ = 0.6: brute-force ∫ f_s μi dωi on a fine (θ, φ) grid with F = 1.
    let (alpha, mu) = (0.36f32, 0.6f32);
    let wo = Vec3A::new((1.0 - mu * mu).sqrt(), 0.0, mu);
    let n = 800;
    let mut sum = 0.0f64;
    for a in 0..n {
        for b in 0..n {
            let mu_i = (a as f32 + 0.5) / n as f32;
            let phi = (b as f32 + 0.5) / n as f32 * TAU;
            let r = (1.0 - mu_i * mu_i).sqrt();
            let wi = Vec3A::new(r * phi.cos(), r * phi.sin(), mu_i);
            let h = (wo + wi).normalize();
            let f = ggx_d(h, alpha) * ggx_g2(wo, wi, alpha) / (4.0 * wo.z * wi.z);
            sum += f64::from(f * mu_i) * (std::f64::consts::TAU / (n * n) as f64);
        }
    }
    let exact = lobe_albedo(mu, alpha).0;
    assert!((sum as f32 - exact).abs() < 5e-3, "{sum} vs {exact}");
}

#[test]
fn mirror_is_a_delta_and_constant_does_not_reflect() {
    let bsdf = Bsdf::new(&surface(0.0, 0.5, 0.0), Vec3A::Z);
    let wo = Vec3A::new(0.6, 0.0, 0.8);
    let s = bsdf.sample(wo, (0.3, 0.7), 0.1).expect("mirror sample");
    assert!(s.specular);
    assert!((s.wi - Vec3A::new(-0.6, 0.0, 0.8)).length() < 1e-6);
    assert_eq!(bsdf.eval(wo, s.wi).0, Vec3A::ZERO);
    let c = Bsdf::new(
        &Material::Constant {
            color: Rgb::new(1.0, 2.0, 3.0),
        },
        Vec3A::Z,
    );
    assert_eq!(c.emission(), Vec3A::new(1.0, 2.0, 3.0));
    assert!(!c.reflects());
    assert!(c.sample(wo, (0.5, 0.5), 0.5).is_none());
    assert_eq!(c.eval(wo, Vec3A::Z), (Vec3A::ZERO, 0.0));
}

#[test]
fn lambert_weight_is_the_albedo_and_below_horizon_is_black() {
    let m = Material::Diffuse {
        color: Rgb::new(0.5, 0.25, 1.0),
    };
    let bsdf = Bsdf::new(&m, Vec3A::Y);
    let s = bsdf.sample(Vec3A::new(0.0, 1.0, 0.0), (0.3, 0.8), 0.0).unwrap();
    assert_eq!(s.weight, Vec3A::new(0.5, 0.25, 1.0));
    assert!(s.wi.y > 0.0);
    assert_eq!(bsdf.eval(Vec3A::Y, -Vec3A::Y), (Vec3A::ZERO, 0.0));
    assert!(bsdf.sample(-Vec3A::Y, (0.3, 0.8), 0.0).is_none());
}
