use super::glass::{Glass, LAMBDA_C, LAMBDA_D, LAMBDA_F};
use super::prescription::Prescription;
use super::surface::{ASPHERE_TERMS, Ray, Surface, intersect, intersect_newton, intersect_sphere};
use super::system::Lens;
use super::*;
use crate::testing::{keeps_contract, make, make_env, project_batch, project_points, refusal};
use obscura_sdk::Format;
use proptest::prelude::*;

fn tinted(p: &dyn Projection, s: &[Point2], a: &[Point2], t: &[f32]) -> (Vec<RayGeometry>, Vec<Rgb>) {
    let (rays, _, tints) = project_batch(p, s, a, t);
    (rays, tints)
}

/// A ray from the film centre at `slope` to the axis, in the x–z plane.
fn near_axial(slope: f64) -> Ray {
    let l = (1.0 + slope * slope).sqrt();
    Ray {
        o: [0.0; 3],
        d: [slope / l, 0.0, 1.0 / l],
    }
}

fn lens(name: &str) -> Prescription {
    Prescription::load(name).unwrap()
}

/// An independent paraxial y–u ray trace (not the matrices): a ray parallel to the axis at height 1
/// from the scene; EFL = −1/u′ and BFL = −y′/u′ after the last surface, at `lambda`.
fn y_u_trace(p: &Prescription, lambda: f64) -> (f64, f64) {
    let (mut y, mut u, mut n) = (1.0, 0.0, 1.0);
    let last = p.surfaces.len() - 1;
    for (i, s) in p.surfaces.iter().enumerate() {
        let n2 = s.glass.index(lambda);
        let c = s.curvature();
        // n'u' = nu − y·c·(n' − n)
        u = (n * u - y * c * (n2 - n)) / n2;
        n = n2;
        if i < last {
            y += s.thickness * u;
        }
    }
    (-1.0 / u, -y / u)
}

#[test]
fn paraxial_efl_and_bfl_equal_an_independent_y_u_trace() {
    for name in [
        "dgauss.50mm",
        "dgauss.50mm.dat",
        "telephoto.250mm.dat",
        "wide.100mm.dat",
        "fisheye.10mm",
        "fisheye.16mm",
        "masterprime.100mm",
    ] {
        let p = lens(name);
        let l = Lens::new(&p, 0.0);
        let par = l.paraxial(LAMBDA_D, 10.0);
        let (efl, bfl) = y_u_trace(&p, LAMBDA_D);
        assert!(
            (par.efl - efl).abs() < 1e-9 * efl.abs(),
            "{name}: {} vs {efl}",
            par.efl
        );
        assert!(
            (par.bfl - bfl).abs() < 1e-9 * efl.abs(),
            "{name}: {} vs {bfl}",
            par.bfl
        );
    }
}

#[test]
fn the_double_gauss_and_the_telephoto_have_their_nominal_focal_lengths() {
    let dg = Lens::new(&lens("dgauss.50mm.dat"), 0.0).paraxial(LAMBDA_D, 17.1);
    assert!((dg.efl - 50.36).abs() < 0.01, "{}", dg.efl);
    assert!((dg.efl - 50.0).abs() < 0.5);
    let tele = Lens::new(&lens("telephoto.250mm.dat"), 0.0).paraxial(LAMBDA_D, 40.5);
    assert!((tele.efl - 250.0).abs() < 2.5, "{}", tele.efl);
    // The published glass changes the EFL a little, not the lens.
    let dgj = Lens::new(&lens("dgauss.50mm"), 0.0).paraxial(LAMBDA_D, 17.1);
    assert!((dgj.efl - 50.0).abs() < 0.5, "{}", dgj.efl);
}

#[test]
fn the_patent_asphere_has_the_focal_length_back_focus_and_f_number_its_source_states() {
    // US 2007/0236805 A1, Example 4, as shipped in masterprime.100mm.json: the source states
    // f = 99.80 mm, back focus 40.123 mm and F-number 1.24 (the transcribed stop diameter 41.035 mm
    // gives 1.259: within 2 %). A transcription slip in any radius, spacing or index moves the EFL
    // or the back focus by more than the source's rounding.
    let p = lens("masterprime.100mm");
    assert!(
        p.surfaces.iter().filter(|s| !s.is_spherical()).count() == 1,
        "one even asphere"
    );
    let stop = 2.0 * p.surfaces[p.stop].semi_aperture;
    let par = Lens::new(&p, 0.0).paraxial(LAMBDA_D, stop);
    assert!((par.efl - 99.80).abs() < 0.01, "EFL {}", par.efl);
    assert!((par.bfl - 40.123).abs() < 0.005, "BFL {}", par.bfl);
    assert!((par.f_number - 1.24).abs() < 0.02 * 1.24, "F {}", par.f_number);
    let (efl, bfl) = y_u_trace(&p, LAMBDA_D);
    assert!((efl - 99.80).abs() < 0.01 && (bfl - 40.123).abs() < 0.005);
}

/// The chief ray's angle to the axis (degrees) from film radius `r` of `l`: aimed at the stop's
/// centre from `guess`, traced through every clear aperture; with the slope for the next guess.
fn chief_angle(l: &Lens, r: f64, guess: [f64; 2]) -> Option<(f64, [f64; 2])> {
    let t = super::pupil::aim(l, r, [0.0, 0.0], guess)?;
    let out = l.trace(super::pupil::film_ray(r, t)).ok()?;
    Some((out.d[0].hypot(out.d[1]).atan2(out.d[2]).to_degrees(), t))
}

#[test]
fn the_patent_fisheye_has_the_focal_length_f_number_and_field_its_source_states() {
    // US 4,256,373, as shipped in fisheye.16mm.json (×16): the source states f = 1.0, F/2.8 and a
    // 180° field. The EFL is the transcription's check (a slip in any radius, spacing or index moves
    // it); the stop diameter is set from the stated F-number, so the F-number only checks the pupil
    // arithmetic; the field is the lens's own: a chief ray from 90° off the axis must pass every
    // clear aperture.
    let p = lens("fisheye.16mm");
    assert_eq!(p.surfaces.len(), 17);
    let stop = 2.0 * p.surfaces[p.stop].semi_aperture;
    let mut l = Lens::new(&p, 0.0);
    l.focus(f64::INFINITY).unwrap();
    let par = l.paraxial(LAMBDA_D, stop);
    assert!((par.efl - 16.0).abs() < 0.005 * 16.0, "EFL {}", par.efl);
    assert!((par.f_number - 2.8).abs() < 0.01 * 2.8, "F {}", par.f_number);
    // Walk out from the centre along the film until the chief ray leaves at 90°, then bisect.
    let (mut r0, mut guess) = (0.0, [0.0, 0.0]);
    let mut theta0 = 0.0;
    let step = 0.25;
    let r90 = loop {
        let r1 = r0 + step;
        let (theta1, t) = chief_angle(&l, r1, guess)
            .unwrap_or_else(|| panic!("the chief ray from {r1} mm (beyond {theta0}°) is blocked"));
        if theta1 >= 90.0 {
            let (mut a, mut b, mut g) = (r0, r1, guess);
            for _ in 0..40 {
                let m = 0.5 * (a + b);
                let (th, tm) = chief_angle(&l, m, g).expect("inside the traced range");
                if th < 90.0 {
                    (a, g) = (m, tm);
                } else {
                    b = m;
                }
            }
            break 0.5 * (a + b);
        }
        assert!(theta1 > theta0, "the field angle grows with the film radius");
        (r0, guess, theta0) = (r1, t, theta1);
    };
    // An independent meridional trace of the patent's numbers puts the 90° chief ray at
    // 1.3727·f: 21.96 mm here. The 180° image circle is then the 24 × 36 mm frame's diagonal
    // (43.27 mm) within 1.5 %: a full-frame fisheye.
    assert!((r90 - 1.3727 * par.efl).abs() < 0.002 * r90, "r(90°) = {r90} mm");
    assert!((2.0 * r90 - 43.27).abs() < 0.02 * 43.27);
}

#[test]
fn traced_rays_find_the_paraxial_focus_and_focal_length() {
    // Focused at infinity, a near-axial ray from the film centre leaves the lens parallel to the axis
    // at height EFL·slope (reversed: a parallel ray focuses at the film).
    for name in [
        "dgauss.50mm",
        "telephoto.250mm.dat",
        "wide.100mm.dat",
        "masterprime.100mm",
    ] {
        let p = lens(name);
        let mut l = Lens::new(&p, 0.0);
        l.focus(f64::INFINITY).unwrap();
        let par = l.paraxial(LAMBDA_D, 1.0);
        assert!((l.back() - par.bfl).abs() < 1e-12);
        let slope: f64 = 1e-5;
        let out = l.trace(near_axial(slope)).unwrap();
        assert!(out.d[0].abs() < 1e-9, "{name}: leaves at slope {}", out.d[0]);
        let efl = out.o[0] / slope;
        assert!(
            (efl - par.efl).abs() < 1e-3 * par.efl,
            "{name}: traced {efl} vs {}",
            par.efl
        );
    }
}

#[test]
fn focusing_puts_the_focus_plane_on_the_film() {
    let p = lens("dgauss.50mm");
    for dist in [300.0, 1000.0, 5000.0] {
        let mut l = Lens::new(&p, 0.0);
        l.focus(dist).unwrap();
        // A near-axial ray from the film centre crosses the axis again at the focus plane.
        let slope: f64 = 1e-5;
        let out = l.trace(near_axial(slope)).unwrap();
        let t = -out.o[0] / out.d[0];
        let z = out.o[2] + t * out.d[2];
        assert!((z - dist).abs() < 1e-3 * dist, "{dist}: crosses at {z}");
    }
    // Nearer focus moves the lens out (focus breathing follows from it).
    let mut near = Lens::new(&p, 0.0);
    near.focus(500.0).unwrap();
    let mut far = Lens::new(&p, 0.0);
    far.focus(f64::INFINITY).unwrap();
    assert!(near.back() > far.back());
    assert!(Lens::new(&p, 0.0).focus_back(60.0, LAMBDA_D).is_err());
}

fn asphere() -> Surface {
    Surface {
        radius: 30.0,
        conic: -0.7,
        asphere: [2e-5, -3e-8, 1e-10, 0.0, 0.0, 0.0, 1e-22],
        thickness: 1.0,
        glass: Glass::AIR,
        semi_aperture: 12.0,
        stop: false,
    }
}

#[test]
fn the_asphere_sag_and_normal_match_finite_differences() {
    let s = asphere();
    for h in [0.5, 3.0, 7.0, 11.0] {
        let rho = h * h;
        let (_, ds) = s.sag(rho).unwrap();
        let e = 1e-6;
        let numeric = (s.sag(rho + e).unwrap().0 - s.sag(rho - e).unwrap().0) / (2.0 * e);
        assert!(
            (ds - numeric).abs() < 1e-6 * (1.0 + ds.abs()),
            "h {h}: {ds} vs {numeric}"
        );
        // The normal at the traced point against the gradient of z = zv − s(x² + y²) by differences.
        let ray = Ray {
            o: [h * 0.6, h * 0.8, -20.0],
            d: [0.0, 0.0, 1.0],
        };
        let (p, n) = intersect(&s, 5.0, &ray).unwrap();
        let sz = |x: f64, y: f64| 5.0 - s.sag(x * x + y * y).unwrap().0;
        assert!((p[2] - sz(p[0], p[1])).abs() < 1e-10);
        let gx = -(sz(p[0] + e, p[1]) - sz(p[0] - e, p[1])) / (2.0 * e);
        let gy = -(sz(p[0], p[1] + e) - sz(p[0], p[1] - e)) / (2.0 * e);
        let l = (gx * gx + gy * gy + 1.0).sqrt();
        for (a, b) in n.iter().zip([gx / l, gy / l, 1.0 / l]) {
            assert!((a - b).abs() < 1e-7, "h {h}: {n:?}");
        }
    }
}

proptest! {
    #[test]
    fn a_conic_of_k_zero_by_newton_is_the_sphere(
        radius in prop_oneof![-200.0..-15.0f64, 15.0..200.0f64],
        x in -8.0..8.0f64, y in -8.0..8.0f64, dx in -0.3..0.3f64, dy in -0.3..0.3f64,
    ) {
        let s = Surface { radius, conic: 0.0, asphere: [0.0; ASPHERE_TERMS], thickness: 1.0,
            glass: Glass::AIR, semi_aperture: 10.0, stop: false };
        let l = (dx * dx + dy * dy + 1.0).sqrt();
        let ray = Ray { o: [x, y, -3.0], d: [dx / l, dy / l, 1.0 / l] };
        // Both miss (the cap lies behind the ray's origin) or both hit at the same point.
        let (a, b) = match (intersect_sphere(&s, 0.0, &ray), intersect_newton(&s, 0.0, &ray)) {
            (None, None) => return Ok(()),
            (Some(a), Some(b)) => (a, b),
            (a, b) => return Err(TestCaseError::fail(format!("{a:?} vs {b:?}"))),
        };
        for k in 0..3 {
            prop_assert!((a.0[k] - b.0[k]).abs() < 1e-9, "{:?} vs {:?}", a, b);
            prop_assert!((a.1[k] - b.1[k]).abs() < 1e-9);
        }
    }
}

#[test]
fn a_ray_through_a_flat_window_is_displaced_by_the_textbook_formula() {
    // d = T·sin θ·(1 − cos θ/√(n² − sin² θ)) for a plate of thickness T and index n.
    let text = "# window\n0 2 0 30\n0 6 1.5 30\n0 10 1 30\n";
    let p = Prescription::parse("window.dat", text).unwrap();
    let l = Lens::new(&p, 10.0);
    for theta in [0.1f64, 0.3, 0.6] {
        let ray = Ray {
            o: [0.0, 0.0, 0.0],
            d: [theta.sin(), 0.0, theta.cos()],
        };
        let out = l.trace(ray).unwrap();
        assert!((out.d[0] - theta.sin()).abs() < 1e-12, "leaves parallel");
        // Undisplaced line at the exit plane z: x = z·tan θ.
        let straight = out.o[2] * theta.tan();
        let along = (straight - out.o[0]) * theta.cos();
        let n: f64 = 1.5;
        let expected = 6.0 * theta.sin() * (1.0 - theta.cos() / (n * n - theta.sin().powi(2)).sqrt());
        assert!(
            (along - expected).abs() < 1e-10,
            "θ {theta}: {along} vs {expected}"
        );
    }
}

#[test]
fn dispersion_separates_f_and_c_focal_lengths_by_the_abbe_number() {
    // A thin N-BK7 singlet: f_C − f_F = f_d·(nF − nC)/(nd − 1) = f_d/Vd to first order.
    let text = r#"{"surfaces": [
        {"stop": true, "thickness": 1, "diameter": 10},
        {"radius": 103.36, "thickness": 0.2, "glass": "N-BK7", "diameter": 20},
        {"radius": -103.36, "thickness": 0, "diameter": 20}]}"#;
    let p = Prescription::parse("singlet.json", text).unwrap();
    let l = Lens::new(&p, 0.0);
    let (f_d, f_f, f_c) = (
        l.paraxial(LAMBDA_D, 10.0).efl,
        l.paraxial(LAMBDA_F, 10.0).efl,
        l.paraxial(LAMBDA_C, 10.0).efl,
    );
    let vd = p.surfaces[1].glass.vd();
    let predicted = f_d / vd;
    assert!(
        ((f_c - f_f) - predicted).abs() < 0.01 * predicted,
        "{} vs {predicted}",
        f_c - f_f
    );
    // And the traced rays at F and C focus where the paraxial F and C foci are.
    for (lambda, efl) in [(LAMBDA_F, f_f), (LAMBDA_C, f_c)] {
        let mut lf = Lens::new(&p, 0.0);
        let b = lf.paraxial(lambda, 10.0).bfl;
        lf.place(b);
        let (before, after) = lf.indices(lambda);
        let slope: f64 = 1e-5;
        let out = lf
            .trace_range(near_axial(slope), 0, 2, (&before, &after), true)
            .unwrap();
        assert!(out.d[0].abs() < 1e-9);
        assert!((out.o[0] / slope - efl).abs() < 1e-3 * efl);
    }
    // The double Gauss is colour-corrected: its F–C focal shift is far below a singlet's.
    let dg = Lens::new(&lens("dgauss.50mm"), 0.0);
    let shift = (dg.paraxial(LAMBDA_C, 1.0).efl - dg.paraxial(LAMBDA_F, 1.0).efl).abs();
    assert!(shift < 0.4 * 50.0 / 64.17, "{shift}");
}

#[test]
fn the_hyperbolic_singlet_focuses_every_height_on_the_paraxial_focus() {
    // Conic k = −n²: no spherical aberration at any height (the textbook's reason for the asphere).
    let n: f64 = 1.5168;
    let text = format!(
        r#"{{"surfaces": [
        {{"stop": true, "thickness": 2, "diameter": 20}},
        {{"radius": 0, "thickness": 5, "glass": {{"n": {n}}}, "diameter": 22}},
        {{"radius": {}, "conic": {}, "thickness": 0, "diameter": 22}}]}}"#,
        -(n - 1.0) * 50.0,
        -n * n
    );
    let p = Prescription::parse("hyperbolic.json", &text).unwrap();
    let mut l = Lens::new(&p, 0.0);
    l.focus(f64::INFINITY).unwrap();
    for slope in [0.01, 0.05, 0.1, 0.15] {
        let out = l.trace(near_axial(slope)).unwrap();
        assert!(out.d[0].abs() < 1e-12, "slope {slope}: leaves at {}", out.d[0]);
    }
    // A sphere of the same radius does not: its marginal ray leaves far from parallel.
    let sphere = text.replace(&format!("\"conic\": {}, ", -n * n), "");
    let mut ls = Lens::new(&Prescription::parse("sphere.json", &sphere).unwrap(), 0.0);
    ls.focus(f64::INFINITY).unwrap();
    assert!(ls.trace(near_axial(0.15)).unwrap().d[0].abs() > 1e-3);
    // The shipped asphere is this design in N-BK7.
    let shipped = lens("asphere.50mm");
    assert!((shipped.surfaces[2].conic + n * n).abs() < 1e-4);
}

fn camera(params: &[(&str, &str)]) -> (Box<dyn Projection>, ProjectionEnvironment) {
    make_env(&LensSystemFactory, params, Format::new(96, 64))
}

fn system(settings: Settings, name: &str) -> LensSystem {
    let env = ProjectionEnvironment::for_format(Format::new(96, 64));
    LensSystem::new(&lens(name), settings, &env).unwrap()
}

#[test]
fn relative_illumination_matches_a_brute_force_integral_and_has_no_rings() {
    // Brute force: irradiance at a film point = Σ over a fine grid of film-side slopes of the rays that
    // pass every aperture, weighted (1 + |t|²)⁻² — no aiming table, no pupil.
    let cam = system(
        Settings {
            dispersion: false,
            ..Settings::default()
        },
        "dgauss.50mm",
    );
    let l = cam.lens();
    let brute = |r: f64| {
        let (n, half) = (300, 0.45);
        let step = 2.0 * half / n as f64;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let t = [-half + (i as f64 + 0.5) * step, -half + (j as f64 + 0.5) * step];
                if l.trace(super::pupil::film_ray(r, t)).is_ok() {
                    let t2 = t[0] * t[0] + t[1] * t[1];
                    sum += step * step / ((1.0 + t2) * (1.0 + t2));
                }
            }
        }
        sum
    };
    let e0 = brute(0.0);
    for r in [6.0, 12.0, 17.0] {
        let ours = cam.relative_illumination(r, 96);
        let reference = brute(r) / e0;
        assert!((ours - reference).abs() < 0.01, "r {r}: {ours} vs {reference}");
    }
    assert!((cam.relative_illumination(0.0, 128) - 1.0).abs() < 1e-9);
    // No rings: the relative illumination falls smoothly (second differences small) across radii that
    // straddle the table's rows.
    let ri: Vec<f64> = (0..60)
        .map(|i| cam.relative_illumination(i as f64 * 0.29, 96))
        .collect();
    let worst = ri
        .windows(3)
        .map(|w| (w[0] - 2.0 * w[1] + w[2]).abs())
        .fold(0.0, f64::max);
    assert!(worst < 0.01, "{worst}: {ri:?}");
}

#[test]
fn blocked_samples_keep_a_valid_ray_with_a_zero_tint() {
    let (cam, _) = camera(&[("int dispersion", "0")]);
    // Corner of a 35 mm diagonal at f/2: the double Gauss vignettes (cat's eye).
    let corner = Point2::new(1.5, 1.0);
    let n = 24;
    let (mut screen, mut aperture) = (Vec::new(), Vec::new());
    for i in 0..n {
        for j in 0..n {
            let a = Point2::new(
                -1.0 + 2.0 * (i as f32 + 0.5) / n as f32,
                -1.0 + 2.0 * (j as f32 + 0.5) / n as f32,
            );
            if a.x * a.x + a.y * a.y <= 1.0 {
                screen.push(corner);
                aperture.push(a);
            }
        }
    }
    let times = vec![0.0; screen.len()];
    let (rays, tints) = tinted(cam.as_ref(), &screen, &aperture, &times);
    let blocked = tints.iter().filter(|t| t.r == 0.0).count();
    assert!(
        blocked > 0 && blocked < tints.len(),
        "{blocked} of {}",
        tints.len()
    );
    for (r, t) in rays.iter().zip(&tints) {
        assert!(!r.is_culled());
        assert!((r.direction.length() - 1.0).abs() < 1e-5);
        assert!(t.r >= 0.0 && t.r == t.g && t.g == t.b);
    }
}

#[test]
fn the_lens_centre_sample_is_the_chief_ray_through_the_stop_centre() {
    let cam = system(Settings::default(), "dgauss.50mm");
    let l = cam.lens();
    let n = l.surfaces.len();
    for r in [0.0, 5.0, 11.3, 17.0] {
        let t = super::pupil::aim(l, r, [0.0, 0.0], [-r / 60.0, 0.0]).unwrap();
        let at = l
            .trace_range(
                super::pupil::film_ray(r, t),
                l.stop,
                n - 1,
                (&l.n_before, &l.n_after),
                false,
            )
            .unwrap();
        assert!(at.o[0].abs() < 1e-9 && at.o[1].abs() < 1e-9);
        let chief = cam.chief_ray(r).unwrap();
        let direct = l.trace(super::pupil::film_ray(r, t)).unwrap();
        assert!((chief.d[0] - direct.d[0]).abs() < 1e-12);
    }
}

#[test]
fn unproject_inverts_the_chief_ray() {
    for name in ["dgauss.50mm", "wide.100mm.dat", "fisheye.10mm"] {
        let (cam, env) = camera(&[("string lens", name), ("float focusDistance", "3")]);
        let w = env.screen_window();
        for (u, v) in [(0.0, 0.0), (0.3, 0.2), (-0.7, 0.5), (0.9, -0.8)] {
            let s = Point2::new(u * w.right, v * w.top);
            let ray = project_points(cam.as_ref(), &[s], &[Point2::ZERO], &[0.0])[0];
            if ray.is_culled() {
                continue;
            }
            let p = ray.origin + ray.direction * 7.0;
            let back = cam.unproject(p, 0.0).unwrap();
            assert!(
                (back.x - s.x).abs() < 2e-4 && (back.y - s.y).abs() < 2e-4,
                "{name} {s:?} -> {back:?}"
            );
        }
    }
}

#[test]
fn properties_are_the_lens_figures() {
    let (cam, _) = camera(&[("float focusDistance", "200"), ("float metersPerUnit", "0.01")]);
    let f = |p| match cam.property(p) {
        Some(PropertyValue::Float(x)) => x,
        other => panic!("{other:?}"),
    };
    // EFL ≈ 50 mm = 5 cm = 5 scene units of 1 cm.
    assert!((f(ProjectionProperty::FocalLength) - 5.0).abs() < 0.05);
    assert_eq!(f(ProjectionProperty::FocalDistance), 200.0);
    assert!(f(ProjectionProperty::FStop) > 2.0 && f(ProjectionProperty::FStop) < 4.0);
    let fov = f(ProjectionProperty::FieldOfView);
    // 35 mm diagonal at 3:2 → 9.7 mm half height over ~50 mm: about 22°.
    assert!(fov > 20.0 && fov < 24.0, "{fov}");
    let (fish, _) = camera(&[("string lens", "fisheye.10mm")]);
    assert_eq!(
        fish.property(ProjectionProperty::DeepMetric),
        Some(PropertyValue::DeepMetric(DeepMetric::RayLength))
    );
}

#[test]
fn bad_prescriptions_and_parameters_name_what_is_wrong() {
    let e = Prescription::parse("x.dat", "# c\n29 3 1.6 25\n12 x 1 18\n").unwrap_err();
    assert!(e.contains("x.dat:3") && e.contains("thickness"), "{e}");
    let e = Prescription::parse("x.dat", "29 3 1.6 25\n12 3 1 18\n").unwrap_err();
    assert!(e.contains("no aperture stop"), "{e}");
    let e = Prescription::parse("x.dat", "10 3 1.6 25\n0 3 0 18\n-12 3 1 18\n").unwrap_err();
    assert!(e.contains("x.dat:1") && e.contains("exceeds the radius"), "{e}");
    let e = Prescription::parse(
        "y.json",
        r#"{"surfaces": [{"stop": true, "thickness": 1, "diameter": 5},
        {"radius": 20, "thickness": 2, "diameter": 10, "glass": "UNOBTAINIUM"}]}"#,
    )
    .unwrap_err();
    assert!(
        e.contains("surfaces[1]") && e.contains("UNOBTAINIUM") && e.contains("N-BK7"),
        "{e}"
    );
    let e = refusal(
        &LensSystemFactory,
        &[("string lens", "/no/such.dat")],
        Format::new(8, 8),
    );
    assert!(e.contains("\"lens\"") && e.contains("/no/such.dat"), "{e}");
    let e = refusal(&LensSystemFactory, &[("float fStop", "1.2")], Format::new(8, 8));
    assert!(e.contains("fStop") && e.contains("opens only to f/"), "{e}");
    let e = refusal(
        &LensSystemFactory,
        &[("float focusDistance", "0.03")],
        Format::new(8, 8),
    );
    assert!(e.contains("focusDistance"), "{e}");
}

#[test]
fn dispersion_tints_average_to_white_at_the_centre_and_fringe_at_the_edge() {
    let (cam, _) = camera(&[]);
    let n = 4000;
    let screen = vec![Point2::new(0.0, 0.0); n];
    let aperture: Vec<Point2> = (0..n)
        .map(|i| {
            let (r, phi) = (((i as f32 + 0.5) / n as f32).sqrt(), i as f32 * 2.399_963);
            Point2::new(r * phi.cos(), r * phi.sin())
        })
        .collect();
    let times = vec![0.0; n];
    let (_, tints) = tinted(cam.as_ref(), &screen, &aperture, &times);
    let mean = |c: fn(&Rgb) -> f32| tints.iter().map(c).sum::<f32>() / n as f32;
    for m in [mean(|t| t.r), mean(|t| t.g), mean(|t| t.b)] {
        assert!((m - 1.0).abs() < 0.05, "{m}");
    }
    let (off, _) = camera(&[("int dispersion", "0")]);
    let (_, flat) = tinted(off.as_ref(), &screen, &aperture, &times);
    assert!(flat.iter().all(|t| t.r == t.g && t.g == t.b));
}

#[test]
fn every_shipped_lens_keeps_the_contract() {
    for name in [
        "dgauss.50mm",
        "telephoto.250mm.dat",
        "wide.100mm.dat",
        "asphere.50mm",
        "masterprime.100mm",
    ] {
        keeps_contract(
            &LensSystemFactory,
            &[(
                Format::new(48, 32),
                vec![("string lens", name), ("float focusDistance", "4")],
            )],
        );
    }
    for fisheye in ["fisheye.10mm", "fisheye.16mm"] {
        let p = make(
            &LensSystemFactory,
            &[("string lens", fisheye)],
            Format::new(32, 32),
        );
        assert!(p.property(ProjectionProperty::FieldOfView).is_some());
    }
}

#[test]
fn the_eight_lane_tracer_is_the_scalar_tracer_and_ignores_the_batch_position() {
    let env = ProjectionEnvironment::for_format(Format::new(96, 64));
    let cam = LensSystem::new(
        &lens("dgauss.50mm"),
        Settings {
            focus_distance: 3.0,
            ..Settings::default()
        },
        &env,
    )
    .unwrap();
    assert!(cam.lane_lens.is_some());
    let n = 2003;
    let screen: Vec<Point2> = (0..n)
        .map(|i| {
            Point2::new(
                ((i * 37) % 97) as f32 / 97.0 * 3.0 - 1.5,
                ((i * 53) % 89) as f32 / 89.0 * 2.0 - 1.0,
            )
        })
        .collect();
    let aperture: Vec<Point2> = (0..n)
        .map(|i| {
            let (r, phi) = ((((i * 71) % 101) as f32 / 101.0).sqrt(), i as f32 * 2.399_963);
            Point2::new(r * phi.cos(), r * phi.sin())
        })
        .collect();
    let times = vec![0.0; n];
    let (rays, _, tints) = project_batch(&cam, &screen, &aperture, &times);
    let mut disagree = 0;
    for i in 0..n {
        let lens_sample = Point2::new(0.5 * aperture[i].x + 0.5, 0.5 * aperture[i].y + 0.5);
        let (ray, tint) = cam.sample(screen[i], aperture[i], lens_sample);
        if (tint.r == 0.0) != (tints[i].r == 0.0) {
            disagree += 1; // a ray grazing an aperture's edge, f32 against f64
            continue;
        }
        assert!(
            (ray.direction - rays[i].direction).length() < 2e-5,
            "{i}: {ray:?} vs {:?}",
            rays[i]
        );
        assert!((ray.origin - rays[i].origin).length() < 1e-5);
        assert!(
            (tint.g - tints[i].g).abs() <= 1e-5 * tint.g.abs().max(1.0),
            "{tint:?} vs {:?}",
            tints[i]
        );
    }
    assert!(
        disagree * 200 < n,
        "{disagree} of {n} samples blocked by one tracer only"
    );
    // Shifted by three places in the batch, every ray is the same to the bit.
    let (shifted, _, shifted_tints) = project_batch(&cam, &screen[3..], &aperture[3..], &times[3..]);
    for i in 3..n {
        assert_eq!(shifted[i - 3], rays[i]);
        assert_eq!(shifted_tints[i - 3], tints[i]);
    }
}

#[test]
fn each_aperture_sample_crosses_the_stop_at_its_own_place_so_blades_shape_the_stop() {
    // The host's warped aperture sample a (a polygon for blades) is the stop point a·R_stop: the traced
    // ray crosses the stop plane there, to the aiming table's interpolation error.
    let cam = system(Settings::default(), "dgauss.50mm");
    let l = cam.lens();
    let n = l.surfaces.len();
    let radius = cam.stop_radius();
    let (mut worst, mut checked): (f64, usize) = (0.0, 0);
    for r in [0.0, 4.1, 9.7, 15.2] {
        for k in 0..60 {
            let (rho, phi) = ((f64::from(k) + 0.5) / 60.0, f64::from(k) * 2.399_963);
            let a = [rho.sqrt() * phi.cos(), rho.sqrt() * phi.sin()];
            let ray = cam.film_side_ray(r, a).unwrap();
            // Only the samples the glass lets through make the picture.
            if l.trace(ray).is_err() {
                continue;
            }
            let at = l
                .trace_range(ray, l.stop, n - 1, (&l.n_before, &l.n_after), false)
                .unwrap();
            checked += 1;
            let e = (at.o[0] - a[0] * radius).hypot(at.o[1] - a[1] * radius);
            worst = worst.max(e);
        }
    }
    assert!(checked > 150, "{checked}");
    assert!(
        worst < 0.005 * radius,
        "off by {worst} mm on a stop of radius {radius} mm"
    );
}
