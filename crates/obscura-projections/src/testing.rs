//! Test helpers: run a projection on hand-made samples.

use obscura_host::contract::{Properties, ask_property};
use obscura_sdk::contract;
use obscura_sdk::simd::{Level, with_level};
use obscura_sdk::{
    DeepMetric, DicingHint, Format, ParamList, PluginError, Point2, Projection, ProjectionContext,
    ProjectionEnvironment, ProjectionFactory, ProjectionProperty, PropertyValue, RayGeometry, RaysSoa, Rgb,
    ScreenWindow, SoaContext, SoaFields, Vec3,
};

use crate::panorama::angle_between;

/// A parameter list from `(declaration, values)` pairs, each value given as its own string.
pub fn param_list(params: &[(&str, &[&str])]) -> ParamList {
    let mut list = ParamList::new();
    for (decl, vals) in params {
        list.push_text(decl, vals, None).unwrap();
    }
    list
}

/// A parameter list from `(declaration, value)` pairs; a value with spaces is split into several, as
/// RIB would give them (`("float[3] enhance", "0 0 2")`).
pub fn split_param_list(params: &[(&str, &str)]) -> ParamList {
    let mut list = ParamList::new();
    for (decl, text) in params {
        let vals: Vec<&str> = text.split_whitespace().collect();
        list.push_text(decl, &vals, None).unwrap();
    }
    list
}

/// What `factory` makes of `list` for `format` (default screen window), and the environment after it.
pub fn try_create(
    factory: &dyn ProjectionFactory,
    list: &ParamList,
    format: Format,
) -> (Result<Box<dyn Projection>, PluginError>, ProjectionEnvironment) {
    let mut env = ProjectionEnvironment::for_format(format);
    let made = factory.create_projection(&mut env, list);
    (made, env)
}

/// The projection `factory` makes from `(declaration, value)` pairs (see [`split_param_list`]) for
/// `format`, or its error.
pub fn try_make(
    factory: &dyn ProjectionFactory,
    params: &[(&str, &str)],
    format: Format,
) -> Result<Box<dyn Projection>, PluginError> {
    try_create(factory, &split_param_list(params), format).0
}

/// The error `factory` gives for `(declaration, value)` pairs (made for `format`), as the host shows it;
/// panics when the factory accepts them.
pub fn refusal(factory: &dyn ProjectionFactory, params: &[(&str, &str)], format: Format) -> String {
    try_make(factory, params, format)
        .err()
        .unwrap_or_else(|| panic!("{params:?} was accepted"))
        .to_string()
}

/// The projection `factory` makes from `(declaration, value)` pairs for `format`, and the environment
/// after it; panics when the factory refuses.
pub fn make_env(
    factory: &dyn ProjectionFactory,
    params: &[(&str, &str)],
    format: Format,
) -> (Box<dyn Projection>, ProjectionEnvironment) {
    let (made, env) = try_create(factory, &split_param_list(params), format);
    (made.unwrap(), env)
}

/// The projection `factory` makes from `(declaration, value)` pairs for `format`; panics when the
/// factory refuses.
pub fn make(factory: &dyn ProjectionFactory, params: &[(&str, &str)], format: Format) -> Box<dyn Projection> {
    make_env(factory, params, format).0
}

/// The ray of one screen sample at the aperture centre and time 0.
pub fn ray_at(p: &dyn Projection, s: Point2) -> RayGeometry {
    project_points(p, &[s], &[Point2::ZERO], &[0.0])[0]
}

/// Checks that the ray through window point `(u·right, v·top)` of `env`'s screen window, taken `depth`
/// along from the origin, unprojects to that screen point within 10⁻⁴ pixel: the round trip of a
/// projection whose rays start at the camera's centre.
pub fn check_centred_roundtrip(
    p: &dyn Projection,
    env: &ProjectionEnvironment,
    u: f32,
    v: f32,
    depth: f32,
) -> Result<(), proptest::test_runner::TestCaseError> {
    let w = env.screen_window();
    let s = Point2::new(u * w.right, v * w.top);
    let r = ray_at(p, s);
    let back = p.unproject(r.direction * depth, 0.0).unwrap();
    let (px, py) = env.pixel_size();
    proptest::prop_assert!(
        ((back.x - s.x) / px).abs() < 1e-4 && ((back.y - s.y) / py).abs() < 1e-4,
        "{s:?} -> {back:?}"
    );
    Ok(())
}

/// [`check_centred_roundtrip`] on the panorama `factory` makes with `(hsweep, vsweep)` degrees for a
/// 300 × 200 image.
pub fn check_sweep_roundtrip(
    factory: &dyn ProjectionFactory,
    (hsweep, vsweep): (f32, f32),
    u: f32,
    v: f32,
    depth: f32,
) -> Result<(), proptest::test_runner::TestCaseError> {
    let (hsweep, vsweep) = (hsweep.to_string(), vsweep.to_string());
    let params = [
        ("float hsweep", hsweep.as_str()),
        ("float vsweep", vsweep.as_str()),
    ];
    let (p, env) = make_env(factory, &params, Format::new(300, 200));
    check_centred_roundtrip(p.as_ref(), &env, u, v, depth)
}

/// Checks that `factory` refuses each `(declaration, value, needle)` (made for `format`) with an error
/// that starts with `"{plugin}: "` and contains `needle`.
pub fn assert_refused(
    factory: &dyn ProjectionFactory,
    plugin: &str,
    format: Format,
    cases: &[(&str, &str, &str)],
) {
    let prefix = format!("{plugin}: ");
    for (decl, val, needle) in cases {
        let err = refusal(factory, &[(decl, val)], format);
        assert!(err.starts_with(&prefix), "{err}");
        assert!(err.contains(needle), "{decl} {val}: {err}");
    }
}

/// Checks the property answers of a camera whose rays may leave +Z: DicingHint Spherical and DeepMetric
/// RayLength; when given, the same metric set in `env` and FieldOfView exactly `fov`.
pub fn assert_spherical_ray_length(
    p: &dyn Projection,
    env: Option<&ProjectionEnvironment>,
    fov: Option<f32>,
) {
    assert_eq!(
        p.property(ProjectionProperty::DicingHint),
        Some(PropertyValue::DicingHint(DicingHint::Spherical))
    );
    assert_eq!(
        p.property(ProjectionProperty::DeepMetric),
        Some(PropertyValue::DeepMetric(DeepMetric::RayLength))
    );
    if let Some(env) = env {
        assert_eq!(env.deep_metric(), DeepMetric::RayLength);
    }
    if let Some(fov) = fov {
        assert_eq!(
            p.property(ProjectionProperty::FieldOfView),
            Some(PropertyValue::Float(fov))
        );
    }
}

/// Checks the property answers of a camera whose depth is camera z (a pinhole, a thin lens, parallel
/// rays): DicingHint `hint` and DeepMetric CameraZ; when given, FieldOfView exactly `fov`.
pub fn assert_camera_z(p: &dyn Projection, hint: DicingHint, fov: Option<f32>) {
    assert_eq!(
        p.property(ProjectionProperty::DicingHint),
        Some(PropertyValue::DicingHint(hint))
    );
    assert_eq!(
        p.property(ProjectionProperty::DeepMetric),
        Some(PropertyValue::DeepMetric(DeepMetric::CameraZ))
    );
    if let Some(fov) = fov {
        assert_eq!(
            p.property(ProjectionProperty::FieldOfView),
            Some(PropertyValue::Float(fov))
        );
    }
}

/// Checks the thin-lens property answers: FStop, FocalLength and FocalDistance exactly these.
pub fn assert_lens_properties(p: &dyn Projection, f_stop: f32, focal_length: f32, focal_distance: f32) {
    for (property, value) in [
        (ProjectionProperty::FStop, f_stop),
        (ProjectionProperty::FocalLength, focal_length),
        (ProjectionProperty::FocalDistance, focal_distance),
    ] {
        assert_eq!(
            p.property(property),
            Some(PropertyValue::Float(value)),
            "{property:?}"
        );
    }
}

/// The contract of a panorama swept by `hsweep` and `vsweep`: at its defaults on a 48 × 24 image, and
/// with each `(hsweep, vsweep)` of `sweeps` on a landscape 40 × 30 and a portrait 30 × 40 image; nothing
/// culled, over 1000 round trips and footprints checked in each.
pub fn assert_sweeps_keep_contract(factory: &dyn ProjectionFactory, sweeps: [(&str, &str); 2]) {
    let [(h1, v1), (h2, v2)] = sweeps;
    let cases = [
        (Format::new(48, 24), vec![]),
        (
            Format::new(40, 30),
            vec![("float hsweep", h1), ("float vsweep", v1)],
        ),
        (
            Format::new(30, 40),
            vec![("float hsweep", h2), ("float vsweep", v2)],
        ),
    ];
    for (_, stats) in keeps_contract(factory, &cases) {
        stats.assert_complete(1000);
    }
}

/// For each `(format, params)`: makes the projection with [`make_env`] and checks it with
/// [`assert_contract`] at the default tolerances; returns the environments and what was seen.
pub fn keeps_contract(
    factory: &dyn ProjectionFactory,
    cases: &[(Format, Vec<(&str, &str)>)],
) -> Vec<(ProjectionEnvironment, ContractStats)> {
    cases
        .iter()
        .map(|(format, params)| {
            let (p, env) = make_env(factory, params, *format);
            (env, assert_contract(p.as_ref(), &ContractTest::new(*format)))
        })
        .collect()
}

/// Projects one batch of hand-made samples and returns the rays.
pub fn project_points(
    p: &dyn Projection,
    screen: &[Point2],
    aperture: &[Point2],
    time: &[f32],
) -> Vec<RayGeometry> {
    project_batch(p, screen, aperture, time).0
}

/// The host's lens samples in `[0, 1)²` behind aperture samples in `[−1, 1]²`.
fn lens_of(aperture: &[Point2]) -> Vec<Point2> {
    aperture
        .iter()
        .map(|a| Point2::new(0.5 * a.x + 0.5, 0.5 * a.y + 0.5))
        .collect()
}

/// Projects one batch of hand-made samples and returns the rays, output times and tints.
pub fn project_batch(
    p: &dyn Projection,
    screen: &[Point2],
    aperture: &[Point2],
    time: &[f32],
) -> (Vec<RayGeometry>, Vec<f32>, Vec<Rgb>) {
    let n = screen.len();
    let lens = lens_of(aperture);
    let mut time = time.to_vec();
    let mut rays = vec![RayGeometry::CULLED; n];
    let mut tint = vec![Rgb::WHITE; n];
    let mut ctx = ProjectionContext::new(screen, &lens, aperture, &mut time, &mut rays, &mut tint).unwrap();
    p.project(&mut ctx);
    (rays, time, tint)
}

/// `project_soa` of one batch into arrays of [`obscura_sdk::SOA_UNWRITTEN`] floats, the ten of them cut from one buffer
/// one float past an aligned start (so no array is 16-byte aligned): `None` when the projection does
/// not offer the path, else the rays read back as records, the output times and the tints. The
/// context asks for `fields` ([`SoaContext::with_fields`]).
pub fn project_soa_batch(
    p: &dyn Projection,
    screen: &[Point2],
    aperture: &[Point2],
    time: &[f32],
    fields: SoaFields,
) -> Option<(Vec<RayGeometry>, Vec<f32>, Vec<Rgb>)> {
    let n = screen.len();
    let lens = lens_of(aperture);
    let mut time = time.to_vec();
    let mut buffer = vec![f32::from_bits(obscura_sdk::SOA_UNWRITTEN); 10 * n + 1];
    let [mut r, mut g, mut b] = [(); 3].map(|()| vec![1.0f32; n]);
    let rays = RaysSoa::from_fields(&mut buffer[1..]).unwrap();
    let mut ctx = SoaContext::new(screen, &lens, aperture, &mut time, rays, [&mut r, &mut g, &mut b])
        .unwrap()
        .with_fields(fields);
    if !p.project_soa(&mut ctx) {
        return None;
    }
    let rays = (0..n).map(|i| ctx.rays.get(i)).collect();
    let tint = (0..n).map(|i| Rgb::new(r[i], g[i], b[i])).collect();
    Some((rays, time, tint))
}

/// Asserts that `p` offers `project_soa` and that it gives what `project` gives — every field of
/// every ray, the times and the tints, bit for bit ([`obscura_sdk::check_project_soa`]) — at every
/// SIMD tier this CPU has, for each batch length 0 to 40 (every tail of the 8- and 16-lane kernels)
/// from two starting samples, and for all of `screen` at once.
pub fn assert_soa_is_project(
    label: &str,
    p: &dyn Projection,
    screen: &[Point2],
    aperture: &[Point2],
    time: &[f32],
) {
    let ranges = (0..=40)
        .flat_map(|n| [0..n, 3..3 + n])
        .chain(std::iter::once(0..screen.len()))
        .filter(|r| r.end <= screen.len());
    for range in ranges {
        let (s, a, t) = (
            &screen[range.clone()],
            &aperture[range.clone()],
            &time[range.clone()],
        );
        for level in Level::ALL.into_iter().filter(|l| l.is_available()) {
            match with_level(level, || obscura_sdk::check_project_soa(p, s, a, t)) {
                Ok(true) => {}
                Ok(false) => panic!("{label}: project_soa is not offered"),
                Err(e) => panic!("{label}: samples {range:?}, tier {level}: {e}"),
            }
        }
    }
}

/// The rays through every pixel centre of `format` with the default screen window, row by row.
pub fn pixel_centre_rays(p: &dyn Projection, format: Format) -> Vec<RayGeometry> {
    let w = ScreenWindow::default_for(format);
    let screen: Vec<Point2> = (0..format.height)
        .flat_map(|y| (0..format.width).map(move |x| (x, y)))
        .map(|(x, y)| w.raster_to_screen(format, x as f64 + 0.5, y as f64 + 0.5))
        .collect();
    let n = screen.len();
    project_points(p, &screen, &vec![Point2::ZERO; n], &vec![0.0; n])
}

/// What [`assert_contract`] checks a projection against, and how strictly.
///
/// The projection must have been created with `ProjectionEnvironment::for_format(format)` (the default
/// screen window of `format`).
#[derive(Debug, Clone)]
pub struct ContractTest {
    /// The image the projection was created for.
    pub format: Format,
    /// Largest `unproject(project(s))` error, in pixels.
    pub roundtrip_px: f64,
    /// Largest relative difference between `ray_spread` and half the finite-difference pixel angle.
    pub spread_rel_tol: f64,
    /// Distance along each ray of the point handed to `unproject`.
    pub depth: f32,
    /// Shutter times the rays are made at.
    pub times: Vec<f32>,
    /// Check `unproject` (false for a projection that offers none).
    pub check_unproject: bool,
}

impl ContractTest {
    /// The tolerances: 1e-4 pixel round trips, spread within 2 % of finite differences.
    pub fn new(format: Format) -> Self {
        ContractTest {
            format,
            roundtrip_px: 1e-4,
            spread_rel_tol: 0.02,
            depth: 10.0,
            times: vec![0.0, 0.5],
            check_unproject: true,
        }
    }
}

/// What [`assert_contract`] saw, for tests that want to assert more.
#[derive(Debug, Clone, Copy, Default)]
pub struct ContractStats {
    /// Samples projected (pixel centres, edges and the margin, at every time).
    pub samples: usize,
    /// Samples with a non-zero direction.
    pub valid: usize,
    /// Samples whose direction has `z < 0`.
    pub backward: usize,
    /// Samples whose footprint was compared with finite differences.
    pub spread_checked: usize,
    /// Samples whose round trip was checked.
    pub roundtrips: usize,
}

impl ContractStats {
    /// Asserts that nothing was culled and that more than `min_checked` round trips and footprints were
    /// checked.
    pub fn assert_complete(&self, min_checked: usize) {
        assert_eq!(self.valid, self.samples, "nothing is culled");
        assert!(
            self.roundtrips > min_checked && self.spread_checked > min_checked,
            "{self:?}"
        );
    }
}

/// Screen points the contract is checked at: every pixel centre, the window's edges and corners, its
/// centre and axes, and a margin two pixels outside (where filters reach).
pub fn contract_points(format: Format) -> Vec<Point2> {
    let w = ScreenWindow::default_for(format);
    let (fw, fh) = (format.width as f64, format.height as f64);
    let mut pts: Vec<Point2> = (0..format.height)
        .flat_map(|y| (0..format.width).map(move |x| (x, y)))
        .map(|(x, y)| w.raster_to_screen(format, x as f64 + 0.5, y as f64 + 0.5))
        .collect();
    let n = 64;
    for i in 0..=n {
        let f = i as f64 / n as f64;
        for (x, y) in [
            (f * fw, 0.0),
            (f * fw, fh),
            (0.0, f * fh),
            (fw, f * fh),
            (f * fw, 0.5 * fh),
            (0.5 * fw, f * fh),
            (f * fw, -2.0),
            (f * fw, fh + 2.0),
            (-2.0, f * fh),
            (fw + 2.0, f * fh),
        ] {
            pts.push(w.raster_to_screen(format, x, y));
        }
    }
    pts.push(Point2::ZERO);
    pts
}

/// Checks the contract on one projection and panics with a description of the first breach:
///
/// - every ray keeps the contract's per-ray rules ([`contract::check_ray`], the host's own), and its
///   clipping distances are the environment's planes or spheres by its deep metric
///   ([`contract::clipping_distances`]);
/// - beyond the contract, the bar for built-ins: directions unit to 10⁻⁵ (the contract allows 10⁻³)
///   and `min_dist` finite;
/// - DeepMetric RayLength whenever a direction has `z < 0`;
/// - DicingHint Perspective ⇒ one shared origin; Orthographic ⇒ one shared direction;
/// - every property answer usable ([`ask_property`]), and every float answer finite and > 0;
/// - `unproject(O + depth·D) = s` within `roundtrip_px` pixels for every valid sample inside the window
///   (or, where a map glues edges, a screen point whose ray is within `roundtrip_px` pixels' angle);
/// - `ray_spread` within `spread_rel_tol` of ½·sqrt(αx·αy), with αx, αy one-sided finite differences of
///   the direction over a hundredth of a pixel — their means, or one side's where a fold makes the
///   sides differ (skipped where a neighbour is culled).
pub fn assert_contract(p: &dyn Projection, t: &ContractTest) -> ContractStats {
    let format = t.format;
    let window = ScreenWindow::default_for(format);
    let (px, py) = window.pixel_size(format);
    let pts = contract_points(format);
    let mut stats = ContractStats::default();
    for prop in ProjectionProperty::ALL {
        match ask_property(p, prop) {
            Ok(Some(PropertyValue::Float(f))) => assert!(f.is_finite() && f > 0.0, "{prop:?} = {f}"),
            Ok(_) => {}
            Err(problem) => panic!("{prop:?}: {problem:?}"),
        }
    }
    let env = ProjectionEnvironment::for_format(format);
    let (near, far) = (env.clipping_near(), env.clipping_far());
    let deep_metric = Properties::read(p, &env).0.deep_metric;
    let hint = p.property(ProjectionProperty::DicingHint);
    let metric = p.property(ProjectionProperty::DeepMetric);
    let inside =
        |s: Point2| s.x >= window.left && s.x <= window.right && s.y >= window.bottom && s.y <= window.top;
    let mut first_origin: Option<Vec3> = None;
    let mut first_dir: Option<Vec3> = None;
    for &time in &t.times {
        let n = pts.len();
        let (rays, times, tints) = project_batch(p, &pts, &vec![Point2::ZERO; n], &vec![time; n]);
        // Neighbours a hundredth of a pixel away, for the finite differences.
        let h = 0.01f32;
        let offsets = [(h * px, 0.0), (-h * px, 0.0), (0.0, h * py), (0.0, -h * py)];
        let nb: Vec<Vec<RayGeometry>> = offsets
            .iter()
            .map(|&(dx, dy)| {
                let moved: Vec<Point2> = pts.iter().map(|s| Point2::new(s.x + dx, s.y + dy)).collect();
                project_points(p, &moved, &vec![Point2::ZERO; n], &vec![time; n])
            })
            .collect();
        for (i, (s, r)) in pts.iter().zip(&rays).enumerate() {
            stats.samples += 1;
            let at = format!("screen ({}, {}) time {time}", s.x, s.y);
            if let Some(b) = contract::check_ray(r, times[i], tints[i]) {
                panic!("{:?} at {at}: {} = {} ({r:?})", b.violation, b.what, b.got);
            }
            assert!(r.min_dist.is_finite(), "infinite min_dist at {at}: {r:?}");
            if r.direction == Vec3::ZERO {
                continue;
            }
            let len = r.direction.length();
            assert!(
                (len - 1.0).abs() <= BUILTIN_UNIT_TOLERANCE,
                "direction not unit ({len}) at {at}: {r:?}"
            );
            if let Some((lo, hi)) =
                contract::clipping_distances(r.origin, r.direction, deep_metric, near, far)
            {
                let off =
                    |got: f32, want: f32| got != want && (got - want).abs() > 1e-4 * want.abs().max(1e-3);
                assert!(
                    !off(r.min_dist, lo) && !off(r.max_dist, hi),
                    "clipping ({}, {}) at {at}, expected ({lo}, {hi}) for {deep_metric:?}: {r:?}",
                    r.min_dist,
                    r.max_dist
                );
            }
            stats.valid += 1;
            if r.direction.z < 0.0 {
                stats.backward += 1;
                assert_eq!(
                    metric,
                    Some(PropertyValue::DeepMetric(DeepMetric::RayLength)),
                    "a ray leaves +Z at {at} ({r:?}) but the deep metric is {metric:?}"
                );
            }
            match hint {
                Some(PropertyValue::DicingHint(DicingHint::Perspective)) => {
                    let o = *first_origin.get_or_insert(r.origin);
                    assert!(
                        (r.origin - o).length() <= 1e-6,
                        "Perspective hint but origins differ at {at}"
                    );
                }
                Some(PropertyValue::DicingHint(DicingHint::Orthographic)) => {
                    let d = *first_dir.get_or_insert(r.direction);
                    assert!(
                        (r.direction - d).length() <= 1e-6,
                        "Orthographic hint but directions differ at {at}"
                    );
                }
                _ => {}
            }
            if t.check_unproject && inside(*s) {
                let point = r.origin + r.direction * t.depth;
                let back = p
                    .unproject(point, time)
                    .unwrap_or_else(|| panic!("unproject gave None for the valid ray at {at}: {r:?}"));
                let ex = ((back.x - s.x) / px).abs() as f64;
                let ey = ((back.y - s.y) / py).abs() as f64;
                if ex > t.roundtrip_px || ey > t.roundtrip_px {
                    // A map that glues edges (octahedral, a pole of a panorama) sees one direction at
                    // two screen points; the inverse may return either, so compare what they see.
                    let again = project_points(p, &[back], &[Point2::ZERO], &[time])[0];
                    let miss = angle(again.direction, r.direction);
                    let pixel_angle = 2.0 * r.ray_spread.max(again.ray_spread) as f64;
                    assert!(
                        again.direction != Vec3::ZERO && miss <= t.roundtrip_px * pixel_angle + 1e-6,
                        "round trip off by ({ex}, {ey}) px at {at}: got ({}, {}), whose ray misses by {miss} rad",
                        back.x,
                        back.y
                    );
                }
                stats.roundtrips += 1;
            }
            let [xp, xm, yp, ym] = [&nb[0][i], &nb[1][i], &nb[2][i], &nb[3][i]];
            if [xp, xm, yp, ym].iter().any(|q| q.direction == Vec3::ZERO) {
                continue;
            }
            // Angle per pixel along x and y from the one-sided chords over h pixel. Where the map folds
            // or glues edges the two sides differ and the footprint is that of one side, so the spread
            // must match one of the side combinations; on smooth ground they all agree.
            let d = r.direction;
            let hh = h as f64;
            let (axp, axm) = (angle(xp.direction, d) / hh, angle(d, xm.direction) / hh);
            let (ayp, aym) = (angle(yp.direction, d) / hh, angle(d, ym.direction) / hh);
            let got = r.ray_spread as f64;
            let candidates = [
                (0.5 * (axp + axm), 0.5 * (ayp + aym)),
                (axp, ayp),
                (axp, aym),
                (axm, ayp),
                (axm, aym),
            ];
            let (ax, ay) = candidates[0];
            let expected = 0.5 * (ax * ay).sqrt();
            let fits = candidates.iter().any(|&(cx, cy)| {
                let e = 0.5 * (cx * cy).sqrt();
                (got - e).abs() <= t.spread_rel_tol * e + 1e-7
            });
            assert!(
                fits,
                "ray_spread {got} but half the measured pixel angle is {expected} (αx {ax}, αy {ay}; one-sided {axp} {axm} {ayp} {aym}) at {at}"
            );
            stats.spread_checked += 1;
        }
    }
    stats
}

/// How close to unit length a built-in's directions are (the contract itself allows
/// [`contract::UNIT_TOLERANCE`]).
pub const BUILTIN_UNIT_TOLERANCE: f32 = 1e-5;

/// The angle between two directions in radians, in `f64` (`atan2(|a × b|, a·b)`, accurate at every
/// size).
pub fn angle(a: Vec3, b: Vec3) -> f64 {
    let f64s = |v: Vec3| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
    angle_between(f64s(a), f64s(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_builtin_perspective_and_orthographic_keep_the_contract() {
        let f = Format::new(48, 32);
        for fov in ["20", "90", "160"] {
            let p = make(&crate::PerspectiveFactory, &[("float fov", fov)], f);
            assert_contract(p.as_ref(), &ContractTest::new(f)).assert_complete(1500);
        }
        let p = make(&crate::OrthographicFactory, &[], f);
        let mut t = ContractTest::new(f);
        t.spread_rel_tol = 0.0;
        assert_contract(p.as_ref(), &t);
    }

    /// The checker must fail a projection that breaks the contract; a spread twice too wide is one.
    struct WideSpread(Box<dyn Projection>);

    impl Projection for WideSpread {
        fn property(&self, p: obscura_sdk::ProjectionProperty) -> Option<obscura_sdk::PropertyValue> {
            self.0.property(p)
        }
        fn project(&self, ctx: &mut ProjectionContext<'_>) {
            self.0.project(ctx);
            for r in ctx.parts_mut().rays.iter_mut() {
                r.ray_spread *= 2.0;
            }
        }
        fn unproject(&self, point: Vec3, time: f32) -> Option<Point2> {
            self.0.unproject(point, time)
        }
    }

    #[test]
    #[should_panic(expected = "ray_spread")]
    fn a_wrong_spread_fails_the_contract() {
        let f = Format::new(16, 16);
        let p = WideSpread(make(&crate::PerspectiveFactory, &[], f));
        assert_contract(&p, &ContractTest::new(f));
    }
}
