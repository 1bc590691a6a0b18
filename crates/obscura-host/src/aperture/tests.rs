//! Tests of [`super`] (aperture.rs).

use super::*;
use crate::distribution::test_samples::Rng;
use proptest::prelude::*;

fn random_points(n: usize, seed: u64) -> Vec<Point2> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| Point2::new(rng.next_f32(), rng.next_f32()))
        .collect()
}

/// Cell-centred stratified samples on a `k × k` grid.
fn grid_points(k: usize) -> Vec<Point2> {
    let mut v = Vec::with_capacity(k * k);
    for i in 0..k {
        for j in 0..k {
            v.push(Point2::new(
                (i as f32 + 0.5) / k as f32,
                (j as f32 + 0.5) / k as f32,
            ));
        }
    }
    v
}

fn desc(n_sides: i32, angle_deg: f32, roundness: f32, density: f32) -> ApertureDesc {
    ApertureDesc {
        n_sides,
        angle_deg,
        roundness,
        density,
        dof_aspect: 1.0,
    }
}

fn warp_all(w: &ApertureWarp, u: &[Point2]) -> Vec<Point2> {
    let mut out = vec![Point2::ZERO; u.len()];
    w.warp_batch(u, &mut out);
    out
}

/// Vertices of the regular N-gon of circumradius 1 rotated by `angle_deg`, counter-clockwise.
fn polygon_vertices(n: i32, angle_deg: f64) -> Vec<(f64, f64)> {
    (0..n)
        .map(|k| {
            let a = angle_deg.to_radians() + 2.0 * PI * f64::from(k) / f64::from(n);
            (a.cos(), a.sin())
        })
        .collect()
}

/// Signed distance-like margin of `p` inside a counter-clockwise convex polygon: the minimum over
/// edges of the cross product `(v₁ − v₀) × (p − v₀)` divided by the edge length (≥ 0 inside).
fn inside_margin(verts: &[(f64, f64)], p: Point2) -> f64 {
    let (px, py) = (f64::from(p.x), f64::from(p.y));
    let mut m = f64::INFINITY;
    for i in 0..verts.len() {
        let (x0, y0) = verts[i];
        let (x1, y1) = verts[(i + 1) % verts.len()];
        let (ex, ey) = (x1 - x0, y1 - y0);
        let cross = ex * (py - y0) - ey * (px - x0);
        m = m.min(cross / ex.hypot(ey));
    }
    m
}

fn radius(p: Point2) -> f64 {
    f64::from(p.x).hypot(f64::from(p.y))
}

fn angle_of(p: Point2) -> f64 {
    f64::from(p.y).atan2(f64::from(p.x)).rem_euclid(TAU)
}

/// The chi-square statistic of observed counts against expected counts.
fn chi_square(observed: &[usize], expected: &[f64]) -> f64 {
    observed
        .iter()
        .zip(expected)
        .map(|(&o, &e)| (o as f64 - e).powi(2) / e)
        .sum()
}

/// The upper `p = 0.001` critical value of chi-square with `k` degrees of freedom
/// (Wilson–Hilferty approximation, z = 3.09).
fn chi_square_critical_001(k: usize) -> f64 {
    let k = k as f64;
    let c = 2.0 / (9.0 * k);
    k * (1.0 - c + 3.09 * c.sqrt()).powi(3)
}

#[test]
fn default_desc_is_renderman_default() {
    let d = ApertureDesc::default();
    assert_eq!(
        d,
        ApertureDesc {
            n_sides: 0,
            angle_deg: 0.0,
            roundness: 1.0,
            density: 0.0,
            dof_aspect: 1.0
        }
    );
    let w = ApertureWarp::new(&d).expect("default is valid");
    assert!(w.is_disk());
}

#[test]
fn is_disk_for_few_sides_or_full_roundness() {
    for n in [-4, 0, 1, 2] {
        assert!(
            ApertureWarp::new(&desc(n, 10.0, 0.0, 0.0))
                .expect("valid")
                .is_disk(),
            "n = {n}"
        );
    }
    assert!(
        ApertureWarp::new(&desc(6, 0.0, 1.0, 0.0))
            .expect("valid")
            .is_disk()
    );
    assert!(
        !ApertureWarp::new(&desc(6, 0.0, 0.999, 0.0))
            .expect("valid")
            .is_disk()
    );
    assert!(
        !ApertureWarp::new(&desc(3, 0.0, -1.0, 0.0))
            .expect("valid")
            .is_disk()
    );
}

#[test]
fn polygon_samples_stay_inside_rotated_ngon() {
    let mut u = grid_points(150);
    u.extend(random_points(20_000, 7));
    for n in [3, 5, 6, 8] {
        for angle in [0.0f32, 17.5, 36.0, -100.0] {
            let w = ApertureWarp::new(&desc(n, angle, 0.0, 0.0)).expect("valid");
            let verts = polygon_vertices(n, f64::from(angle));
            let out = warp_all(&w, &u);
            let worst = out
                .iter()
                .map(|&p| inside_margin(&verts, p))
                .fold(f64::INFINITY, f64::min);
            assert!(
                worst > -1e-6,
                "N = {n}, angle = {angle}: a sample is {worst} outside"
            );
            // The samples also fill the polygon: some land within 0.03 of every vertex.
            for &(vx, vy) in &verts {
                let nearest = out
                    .iter()
                    .map(|p| (f64::from(p.x) - vx).hypot(f64::from(p.y) - vy))
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    nearest < 0.03,
                    "N = {n}, angle = {angle}: vertex ({vx}, {vy}) unreached"
                );
            }
        }
    }
}

#[test]
fn polygon_density_is_uniform_in_area() {
    // Chi-square over the square cells of a 12 × 12 grid that lie wholly inside the hexagon, plus
    // one bin for everything else; expected counts from the cell area over the polygon's area.
    let n = 6;
    let verts = polygon_vertices(n, 10.0);
    let poly_area = 0.5 * f64::from(n) * (2.0 * PI / f64::from(n)).sin();
    let w = ApertureWarp::new(&desc(n, 10.0, 0.0, 0.0)).expect("valid");
    let samples = 200_000;
    let out = warp_all(&w, &random_points(samples, 11));
    let g = 12;
    let cell = 2.0 / g as f64;
    let mut index = vec![None; g * g];
    let mut expected = Vec::new();
    for iy in 0..g {
        for ix in 0..g {
            let (x0, y0) = (-1.0 + ix as f64 * cell, -1.0 + iy as f64 * cell);
            let corners = [(x0, y0), (x0 + cell, y0), (x0, y0 + cell), (x0 + cell, y0 + cell)];
            if corners
                .iter()
                .all(|&(x, y)| inside_margin(&verts, Point2::new(x as f32, y as f32)) > 1e-6)
            {
                index[iy * g + ix] = Some(expected.len());
                expected.push(samples as f64 * cell * cell / poly_area);
            }
        }
    }
    let rest = samples as f64 - expected.iter().sum::<f64>();
    let rest_bin = expected.len();
    expected.push(rest);
    let mut observed = vec![0usize; expected.len()];
    for p in &out {
        let ix = (((f64::from(p.x) + 1.0) / cell).floor() as usize).min(g - 1);
        let iy = (((f64::from(p.y) + 1.0) / cell).floor() as usize).min(g - 1);
        observed[index[iy * g + ix].unwrap_or(rest_bin)] += 1;
    }
    assert!(expected.len() > 40, "too few interior cells: {}", expected.len());
    let chi2 = chi_square(&observed, &expected);
    let critical = chi_square_critical_001(expected.len() - 1);
    assert!(chi2 < critical, "chi2 = {chi2} >= {critical}");
}

#[test]
fn rotation_by_36_degrees_moves_a_vertex_to_36_degrees() {
    let w0 = ApertureWarp::new(&desc(5, 0.0, 0.0, 0.0)).expect("valid");
    let w36 = ApertureWarp::new(&desc(5, 36.0, 0.0, 0.0)).expect("valid");
    let deg = |d: f64| (d.to_radians()) as f32;
    let cos36 = 36f64.to_radians().cos();
    assert!((w0.boundary_radius(0.0) - 1.0).abs() < 1e-6);
    assert!((f64::from(w0.boundary_radius(deg(36.0))) - cos36).abs() < 1e-6);
    assert!((w36.boundary_radius(deg(36.0)) - 1.0).abs() < 1e-6);
    assert!((f64::from(w36.boundary_radius(0.0)) - cos36).abs() < 1e-6);
    // The samples agree: near 36° they reach radius ≈ 1, near 0° only the edge midpoint cos 36°.
    // (Random, not a grid: the angle depends on u.x alone, so a grid has few distinct angles.)
    let out = warp_all(&w36, &random_points(200_000, 36));
    let max_r_near = |target_deg: f64| {
        out.iter()
            .filter(|p| {
                let diff = (angle_of(**p) - target_deg.to_radians() + PI).rem_euclid(TAU) - PI;
                diff.abs() < 0.5f64.to_radians()
            })
            .map(|&p| radius(p))
            .fold(0.0, f64::max)
    };
    assert!(max_r_near(36.0) > 0.98, "{}", max_r_near(36.0));
    assert!(max_r_near(108.0) > 0.98, "{}", max_r_near(108.0));
    let r0 = max_r_near(0.0);
    assert!(r0 < cos36 + 0.01 && r0 > cos36 - 0.03, "{r0} vs {cos36}");
}

#[test]
fn roundness_one_gives_the_unit_disk() {
    for n in [0, 5, 6] {
        let w = ApertureWarp::new(&desc(n, 20.0, 1.0, 0.0)).expect("valid");
        for k in 0..360 {
            assert_eq!(w.boundary_radius((k as f32).to_radians()), 1.0);
        }
        let out = warp_all(&w, &grid_points(300));
        let mut max_in_sector = [0.0f64; 36];
        for &p in &out {
            let r = radius(p);
            assert!(r <= 1.0 + 1e-6, "radius {r}");
            let s = ((angle_of(p) / TAU * 36.0) as usize).min(35);
            max_in_sector[s] = max_in_sector[s].max(r);
        }
        for (s, &m) in max_in_sector.iter().enumerate() {
            assert!(m > 0.99, "N = {n}: sector {s} reaches only {m}");
        }
    }
}

#[test]
fn roundness_between_zero_and_one_interpolates_edge_and_circle() {
    let n = 6;
    let w = ApertureWarp::new(&desc(n, 0.0, 0.25, 0.0)).expect("valid");
    let mid = (PI / f64::from(n)).cos();
    let expected = mid + 0.25 * (1.0 - mid);
    assert!((f64::from(w.boundary_radius((PI / 6.0) as f32)) - expected).abs() < 1e-6);
    assert!((w.boundary_radius(0.0) - 1.0).abs() < 1e-6);
}

#[test]
fn negative_roundness_bows_the_sides_inward() {
    for n in 3..=8 {
        let half = PI / f64::from(n);
        for (rho, power) in [(-1.0f32, 3), (-0.5, 2)] {
            let w = ApertureWarp::new(&desc(n, 15.0, rho, 0.0)).expect("valid");
            let offset = 15f64.to_radians();
            let at_mid = f64::from(w.boundary_radius((offset + half) as f32));
            assert!(
                (at_mid - half.cos().powi(power)).abs() < 1e-5,
                "N = {n}, rho = {rho}: {at_mid}"
            );
            let at_vertex = f64::from(w.boundary_radius((offset + 2.0 * half) as f32));
            assert!(
                (at_vertex - 1.0).abs() < 1e-5,
                "N = {n}: vertex radius {at_vertex}"
            );
        }
        // Star samples stay within the star: at the edge midpoint directions nothing passes cos³.
        let w = ApertureWarp::new(&desc(n, 0.0, -1.0, 0.0)).expect("valid");
        for p in warp_all(&w, &grid_points(120)) {
            let theta = angle_of(p).rem_euclid(2.0 * half);
            let edge = half.cos() / (theta - half).cos();
            assert!(
                radius(p) <= edge.powi(3) + 1e-5,
                "N = {n}: {p:?} outside the star"
            );
        }
    }
}

#[test]
fn uniform_disk_passes_chi_square_over_rings_and_sectors() {
    let w = ApertureWarp::new(&ApertureDesc::default()).expect("valid");
    let samples = 200_000;
    let (rings, sectors) = (10, 8);
    let mut observed = vec![0usize; rings * sectors];
    for p in warp_all(&w, &random_points(samples, 3)) {
        // Equal-area rings: r² in [k/10, (k+1)/10).
        let ring = ((radius(p).powi(2) * rings as f64) as usize).min(rings - 1);
        let sector = ((angle_of(p) / TAU * sectors as f64) as usize).min(sectors - 1);
        observed[ring * sectors + sector] += 1;
    }
    let expected = vec![samples as f64 / (rings * sectors) as f64; rings * sectors];
    let chi2 = chi_square(&observed, &expected);
    let critical = chi_square_critical_001(rings * sectors - 1);
    assert!(chi2 < critical, "chi2 = {chi2} >= {critical}");
}

#[test]
fn chi_square_detects_a_non_uniform_disk() {
    // Power check of the statistic above: bright-rim samples must fail the uniform hypothesis.
    let w = ApertureWarp::new(&desc(0, 0.0, 1.0, 0.3)).expect("valid");
    let samples = 200_000;
    let mut observed = vec![0usize; 10];
    for p in warp_all(&w, &random_points(samples, 3)) {
        observed[((radius(p).powi(2) * 10.0) as usize).min(9)] += 1;
    }
    let chi2 = chi_square(&observed, &[samples as f64 / 10.0; 10]);
    assert!(chi2 > chi_square_critical_001(9), "chi2 = {chi2}");
}

#[test]
fn density_ramp_matches_its_ring_probabilities() {
    // For the disk r² = q, so ring k of r² ∈ [k/10, (k+1)/10) has probability F(q₁) − F(q₀) with
    // F(q) = q + d·(q² − q).
    for d in [-1.0f32, -0.4, 0.7, 1.0] {
        let w = ApertureWarp::new(&desc(0, 0.0, 1.0, d)).expect("valid");
        let samples = 100_000;
        let mut observed = vec![0usize; 10];
        for p in warp_all(&w, &random_points(samples, 5)) {
            observed[((radius(p).powi(2) * 10.0) as usize).min(9)] += 1;
        }
        let cdf = |q: f64| q + f64::from(d) * (q * q - q);
        let expected: Vec<f64> = (0..10)
            .map(|k| samples as f64 * (cdf((k + 1) as f64 / 10.0) - cdf(k as f64 / 10.0)))
            .collect();
        let chi2 = chi_square(&observed, &expected);
        assert!(chi2 < chi_square_critical_001(9), "d = {d}: chi2 = {chi2}");
    }
}

#[test]
fn density_sets_the_mean_squared_radius() {
    // E[r²] = 1/2 + d/6 on the disk: 2/3 for a bright rim, 1/3 for a bright centre.
    for (d, expected) in [
        (1.0f32, 2.0 / 3.0),
        (-1.0, 1.0 / 3.0),
        (0.0, 0.5),
        (0.5, 0.5 + 0.5 / 6.0),
        (1e-13, 0.5),
    ] {
        let w = ApertureWarp::new(&desc(0, 0.0, 1.0, d)).expect("valid");
        let out = warp_all(&w, &grid_points(400));
        let mean = out.iter().map(|&p| radius(p).powi(2)).sum::<f64>() / out.len() as f64;
        assert!(
            (mean - expected).abs() < 1e-3,
            "d = {d}: mean r² = {mean}, expected {expected}"
        );
    }
    // On a polygon the same holds for the radius relative to the boundary.
    let w = ApertureWarp::new(&desc(5, 12.0, 0.0, 1.0)).expect("valid");
    let out = warp_all(&w, &grid_points(400));
    let mean = out
        .iter()
        .map(|&p| (radius(p) / f64::from(w.boundary_radius(angle_of(p) as f32))).powi(2))
        .sum::<f64>()
        / out.len() as f64;
    assert!((mean - 2.0 / 3.0).abs() < 2e-3, "polygon mean (r/R)² = {mean}");
}

#[test]
fn dof_aspect_squeezes_the_short_axis() {
    let u = grid_points(300);
    let extent = |aspect: f32| {
        let w = ApertureWarp::new(&ApertureDesc {
            dof_aspect: aspect,
            ..ApertureDesc::default()
        })
        .expect("valid");
        let out = warp_all(&w, &u);
        let mx = out.iter().map(|p| p.x.abs()).fold(0.0f32, f32::max);
        let my = out.iter().map(|p| p.y.abs()).fold(0.0f32, f32::max);
        (mx, my)
    };
    let (mx, my) = extent(2.0);
    assert!(mx > 0.99 && mx <= 1.0, "max |x| = {mx}");
    assert!(my > 0.49 && my <= 0.5 + 1e-6, "max |y| = {my}");
    let (mx, my) = extent(0.5);
    assert!(mx > 0.49 && mx <= 0.5 + 1e-6, "max |x| = {mx}");
    assert!(my > 0.99 && my <= 1.0, "max |y| = {my}");
}

#[test]
fn warp_is_monotone_in_each_coordinate() {
    // Stratification is preserved: the angle grows with u.x and the radius with u.y.
    for d in [
        desc(0, 0.0, 1.0, 0.0),
        desc(5, 30.0, 0.0, 0.5),
        desc(7, 0.0, -0.8, -1.0),
    ] {
        let w = ApertureWarp::new(&d).expect("valid");
        let steps = 2000;
        let start = angle_of(w.warp(Point2::new(0.0, 0.9)));
        let mut last = 0.0;
        for i in 1..steps {
            let p = w.warp(Point2::new(i as f32 / steps as f32, 0.9));
            let turned = (angle_of(p) - start).rem_euclid(TAU);
            assert!(
                turned >= last - 1e-6,
                "{d:?}: angle went back at u.x = {i}/{steps}"
            );
            last = turned;
        }
        let mut last_r = -1.0;
        for i in 0..steps {
            let r = radius(w.warp(Point2::new(0.3, i as f32 / steps as f32)));
            assert!(r >= last_r - 1e-7, "{d:?}: radius went back at u.y = {i}/{steps}");
            last_r = r;
        }
    }
}

#[test]
fn warp_batch_matches_warp_and_tolerates_length_mismatch() {
    let w = ApertureWarp::new(&desc(6, 5.0, 0.3, -0.2)).expect("valid");
    let u = random_points(100, 9);
    let mut out = vec![Point2::new(9.0, 9.0); 60];
    w.warp_batch(&u, &mut out);
    for (o, &x) in out.iter().zip(&u) {
        assert_eq!(*o, w.warp(x));
    }
    let mut long = vec![Point2::new(9.0, 9.0); 120];
    w.warp_batch(&u, &mut long);
    assert_eq!(long[99], w.warp(u[99]));
    assert_eq!(long[100], Point2::new(9.0, 9.0));
}

#[test]
fn extreme_inputs_stay_finite_and_inside_the_square() {
    let inputs = [
        0.0f32,
        -0.0,
        1.0 - f32::EPSILON / 2.0,
        1.0,
        -3.0,
        7.0,
        f32::NAN,
        f32::INFINITY,
        f32::MIN,
    ];
    for d in [
        ApertureDesc::default(),
        desc(i32::MAX, 1e20, 0.0, 1.0),
        desc(i32::MIN, -1e20, -1.0, -1.0),
        desc(3, 0.0, -1.0, 1.0),
        ApertureDesc {
            dof_aspect: 1e-30,
            ..desc(4, 45.0, 0.0, 0.0)
        },
        ApertureDesc {
            dof_aspect: 3e38,
            ..desc(4, 45.0, 0.0, 0.0)
        },
    ] {
        let w = ApertureWarp::new(&d).expect("valid");
        for &x in &inputs {
            for &y in &inputs {
                let p = w.warp(Point2::new(x, y));
                assert!(p.x.is_finite() && p.y.is_finite() && p.x.abs() <= 1.0 && p.y.abs() <= 1.0);
            }
        }
    }
}

#[test]
fn invalid_descs_name_the_parameter() {
    let cases: [(ApertureDesc, &str, &str); 11] = [
        (desc(5, f32::NAN, 0.0, 0.0), "apertureAngle", "finite"),
        (desc(5, f32::INFINITY, 0.0, 0.0), "apertureAngle", "finite"),
        (desc(5, 0.0, 1.5, 0.0), "apertureRoundness", "[-1, 1]"),
        (desc(5, 0.0, -1.01, 0.0), "apertureRoundness", "[-1, 1]"),
        (desc(5, 0.0, f32::NAN, 0.0), "apertureRoundness", "[-1, 1]"),
        (desc(5, 0.0, 0.0, 2.0), "apertureDensity", "[-1, 1]"),
        (desc(5, 0.0, 0.0, f32::NAN), "apertureDensity", "[-1, 1]"),
        (
            ApertureDesc {
                dof_aspect: 0.0,
                ..ApertureDesc::default()
            },
            "dofaspect",
            "> 0",
        ),
        (
            ApertureDesc {
                dof_aspect: -2.0,
                ..ApertureDesc::default()
            },
            "dofaspect",
            "> 0",
        ),
        (
            ApertureDesc {
                dof_aspect: f32::INFINITY,
                ..ApertureDesc::default()
            },
            "dofaspect",
            "finite",
        ),
        (
            ApertureDesc {
                dof_aspect: f32::NAN,
                ..ApertureDesc::default()
            },
            "dofaspect",
            "> 0",
        ),
    ];
    for (d, name, range) in cases {
        match ApertureWarp::new(&d) {
            Ok(_) => panic!("{d:?} accepted"),
            Err(e) => {
                let msg = e.to_string();
                assert!(msg.contains(name) && msg.contains(range), "{d:?}: {msg}");
            }
        }
    }
    assert!(matches!(
        ApertureWarp::new(&desc(5, 0.0, 1.5, 0.0)),
        Err(ApertureError::Roundness { .. })
    ));
    assert!(matches!(
        ApertureWarp::new(&desc(5, 0.0, 0.0, -1.5)),
        Err(ApertureError::Density { .. })
    ));
}

#[test]
fn warp_is_send_sync_clone() {
    fn check<T: Send + Sync + Clone>() {}
    check::<ApertureWarp>();
    let w = ApertureWarp::new(&desc(6, 0.0, 0.0, 0.0)).expect("valid");
    let c = w.clone();
    let u = Point2::new(0.3, 0.7);
    assert_eq!(w.warp(u), c.warp(u));
}

fn valid_desc() -> impl Strategy<Value = ApertureDesc> {
    (
        -3i32..=40,
        -720.0f32..720.0,
        -1.0f32..=1.0,
        -1.0f32..=1.0,
        0.01f32..100.0,
    )
        .prop_map(
            |(n_sides, angle_deg, roundness, density, dof_aspect)| ApertureDesc {
                n_sides,
                angle_deg,
                roundness,
                density,
                dof_aspect,
            },
        )
}

proptest! {
    #[test]
    fn warp_output_is_finite_and_in_the_square(d in valid_desc(), x in 0.0f32..1.0, y in 0.0f32..1.0) {
        let w = ApertureWarp::new(&d).expect("valid by construction");
        let p = w.warp(Point2::new(x, y));
        prop_assert!(p.x.is_finite() && p.y.is_finite());
        prop_assert!((-1.0..=1.0).contains(&p.x) && (-1.0..=1.0).contains(&p.y), "{:?}", p);
        // And inside the shape (before the aspect squeeze).
        let (sx, sy) = if d.dof_aspect >= 1.0 {
            (f64::from(p.x), f64::from(p.y) * f64::from(d.dof_aspect))
        } else {
            (f64::from(p.x) / f64::from(d.dof_aspect), f64::from(p.y))
        };
        let r = sx.hypot(sy);
        let phi = sy.atan2(sx) as f32;
        prop_assert!(r <= f64::from(w.boundary_radius(phi)) + 1e-4, "r = {} outside", r);
    }
}
