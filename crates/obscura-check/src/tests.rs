//! The checker's own tests: a 90° pinhole with one deliberate flaw per check must fail that check
//! and no other; a correct pinhole and a correct wide fisheye must pass every check that applies.

use crate::json::{json_f32, json_num, json_str};
use crate::*;
use obscura_sdk::contract::value_in_domain;
use obscura_sdk::optics::PerspectiveRays;
use obscura_sdk::{
    DeepMetric, DicingHint, Format, ParamList, PluginError, Point2, Projection, ProjectionContext,
    ProjectionEnvironment, ProjectionFactory, ProjectionProperty, PropertyValue, RayGeometry, Vec3,
};
use std::sync::atomic::{AtomicU64, Ordering};
use std::thread::ThreadId;

/// One deliberate breach of the contract each (or none).
#[derive(Debug)]
enum Flaw {
    None,
    NanDirection,
    NonUnit,
    TimeOne,
    NegativeSpread,
    DoubleSpread,
    WrongFov,
    Backward,
    MovingOrigins,
    OrthographicHint,
    WrongUnproject,
    Counter(AtomicU64),
    ThreadDependent(ThreadId),
    WrongPropertyType,
    NanFStop,
    PanicInProject,
    PanicInUnproject,
    PanicInProperty,
}

/// A 90° pinhole (screen plane at d = 1), correct unless `flaw` says otherwise.
struct Pinhole {
    rays: PerspectiveRays,
    flaw: Flaw,
}

impl Pinhole {
    fn new(env: &ProjectionEnvironment, flaw: Flaw) -> Self {
        Pinhole {
            rays: PerspectiveRays::new(
                env.pixel_size(),
                (env.clipping_near(), env.clipping_far()),
                0.0,
                1.0,
            ),
            flaw,
        }
    }
}

impl Projection for Pinhole {
    fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
        match (p, &self.flaw) {
            (ProjectionProperty::DicingHint, Flaw::OrthographicHint) => {
                Some(PropertyValue::DicingHint(DicingHint::Orthographic))
            }
            (ProjectionProperty::DicingHint, _) => Some(PropertyValue::DicingHint(DicingHint::Perspective)),
            (ProjectionProperty::DeepMetric, _) => Some(PropertyValue::DeepMetric(DeepMetric::CameraZ)),
            (ProjectionProperty::FieldOfView, Flaw::WrongFov) => Some(PropertyValue::Float(95.0)),
            (ProjectionProperty::FieldOfView, Flaw::WrongPropertyType) => {
                Some(PropertyValue::DicingHint(DicingHint::Perspective))
            }
            (ProjectionProperty::FieldOfView, Flaw::PanicInProperty) => {
                panic!("deliberate property panic")
            }
            (ProjectionProperty::FieldOfView, _) => Some(PropertyValue::Float(90.0)),
            (ProjectionProperty::FStop, Flaw::NanFStop) => Some(PropertyValue::Float(f32::NAN)),
            _ => None,
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        if matches!(self.flaw, Flaw::PanicInProject)
            && c.screen.iter().any(|s| s.x > 1.2 && (0.9..0.99).contains(&s.y))
        {
            panic!("deliberate project panic");
        }
        for i in 0..c.rays.len() {
            let s = c.screen[i];
            let mut r = self.rays.pinhole(s, 1.0);
            match &self.flaw {
                Flaw::NanDirection if s.x > 1.1 => r.direction.x = f32::NAN,
                Flaw::NonUnit if s.y > 0.5 => r.direction = r.direction * 1.01,
                Flaw::TimeOne if s.x < -1.1 => c.time[i] = 1.0,
                Flaw::NegativeSpread if s.y < -0.5 => r.ray_spread = -r.ray_spread,
                Flaw::DoubleSpread => r.ray_spread *= 2.0,
                Flaw::Backward => r.direction = -r.direction,
                Flaw::MovingOrigins => r.origin = Vec3::new(0.1 * s.x, 0.1 * s.y, 0.0),
                Flaw::Counter(n) => {
                    r.ray_spread *= 1.0 + 1e-9 * n.fetch_add(1, Ordering::Relaxed) as f32;
                }
                Flaw::ThreadDependent(creator) if std::thread::current().id() != *creator => {
                    r.ray_spread *= 1.001;
                }
                _ => {}
            }
            c.rays[i] = r;
        }
    }

    fn unproject(&self, p: Vec3, _time: f32) -> Option<Point2> {
        match self.flaw {
            Flaw::Backward => (p.z < 0.0).then(|| Point2::new(p.x / p.z, p.y / p.z)),
            Flaw::MovingOrigins => (p.z > 0.0).then(|| Point2::new(p.x / (0.1 + p.z), p.y / (0.1 + p.z))),
            Flaw::WrongUnproject => (p.z > 0.0).then(|| Point2::new(1.01 * p.x / p.z, p.y / p.z)),
            Flaw::PanicInUnproject if p.x > 1.0 => panic!("deliberate unproject panic"),
            _ => (p.z > 0.0).then(|| Point2::new(p.x / p.z, p.y / p.z)),
        }
    }
}

fn check(flaw: Flaw) -> CheckReport {
    let opts = CheckOptions::default();
    let env = opts.environment();
    check_projection(&Pinhole::new(&env, flaw), &env, &opts)
}

fn assert_only(report: &CheckReport, kind: CheckKind) {
    assert_eq!(report.failed(), vec![kind], "{report}");
    let r = report.get(kind);
    assert!(r.failures > 0 && r.worst.is_some(), "{report}");
    assert!(!report.is_clean());
}

#[test]
fn a_correct_pinhole_is_clean_and_every_check_ran() {
    let report = check(Flaw::None);
    assert!(report.is_clean(), "{report}");
    for c in &report.checks {
        assert_eq!(c.status(), Status::Ok, "{} did not run: {report}", c.kind.id());
    }
    assert_eq!(report.samples, 98 * 74 * 5);
    assert_eq!(report.culled, 0);
    let text = report.to_string();
    assert!(
        text.contains("ok           finite directions: 36260 rays"),
        "{text}"
    );
    assert!(text.ends_with("clean: no check failed"), "{text}");
}

#[test]
fn the_spread_and_fov_measures_are_much_sharper_than_their_tolerances() {
    let opts = CheckOptions {
        spread_tolerance: 0.01,
        fov_tolerance: 1e-4,
        fov_tolerance_degrees: 1e-3,
        unproject_tolerance: 1e-4,
        ..CheckOptions::default()
    };
    let env = opts.environment();
    let report = check_projection(&Pinhole::new(&env, Flaw::None), &env, &opts);
    assert!(report.is_clean(), "{report}");
}

#[test]
fn odd_batches_no_margin_and_other_formats_stay_clean() {
    for (format, batch, margin, spp) in [
        (Format::new(17, 31), 7, 0, 1),
        (Format::new(40, 40), 1, 2, 2),
        (
            Format {
                width: 30,
                height: 20,
                pixel_aspect: 2.0,
            },
            4096,
            1,
            3,
        ),
    ] {
        let opts = CheckOptions {
            format,
            batch_size: batch,
            margin,
            samples_per_pixel: spp,
            threads: 2,
            ..CheckOptions::default()
        };
        let env = opts.environment();
        let report = check_projection(&Pinhole::new(&env, Flaw::None), &env, &opts);
        assert!(report.is_clean(), "{report}");
        assert_eq!(report.get(CheckKind::RaySpread).status(), Status::Ok, "{report}");
    }
}

#[test]
fn nan_direction_is_caught_by_direction_finite() {
    let r = check(Flaw::NanDirection);
    assert_only(&r, CheckKind::DirectionFinite);
    assert!(
        r.get(CheckKind::DirectionFinite)
            .worst
            .as_ref()
            .unwrap()
            .got
            .contains("NaN")
    );
}

#[test]
fn a_long_direction_is_caught_by_direction_unit() {
    let r = check(Flaw::NonUnit);
    assert_only(&r, CheckKind::DirectionUnit);
    let w = r.get(CheckKind::DirectionUnit).worst.clone().unwrap();
    assert!((w.severity - 0.01).abs() < 1e-4, "{w:?}");
    assert!(w.sample.unwrap().screen.y > 0.5);
}

#[test]
fn time_one_is_caught_by_time_range() {
    let r = check(Flaw::TimeOne);
    assert_only(&r, CheckKind::TimeRange);
    assert_eq!(r.get(CheckKind::TimeRange).worst.as_ref().unwrap().got, "1");
}

#[test]
fn a_negative_spread_is_caught_by_radius_spread() {
    let r = check(Flaw::NegativeSpread);
    assert_only(&r, CheckKind::RadiusSpread);
}

#[test]
fn a_spread_twice_too_big_is_caught_by_ray_spread() {
    let r = check(Flaw::DoubleSpread);
    assert_only(&r, CheckKind::RaySpread);
    let c = r.get(CheckKind::RaySpread);
    // Every pixel is off by +100 %: the spread is compared with half the angle, not the whole.
    assert_eq!(c.failures, c.examined);
    let w = c.worst.as_ref().unwrap();
    assert!((w.severity - 1.0).abs() < 0.01, "{w:?}");
}

#[test]
fn a_wrong_field_of_view_is_caught() {
    let r = check(Flaw::WrongFov);
    assert_only(&r, CheckKind::FieldOfView);
    let w = r.get(CheckKind::FieldOfView).worst.clone().unwrap();
    assert!((w.severity - 5.0).abs() < 0.01, "{w:?}");
    assert!(
        w.expected.contains("90.000° across the [-1, 1] square in x"),
        "{w:?}"
    );
}

#[test]
fn camera_z_with_backward_rays_is_caught_by_deep_metric() {
    let r = check(Flaw::Backward);
    assert_only(&r, CheckKind::DeepMetric);
    let c = r.get(CheckKind::DeepMetric);
    assert_eq!(c.failures, c.examined);
}

#[test]
fn a_perspective_hint_with_moving_origins_is_caught_by_dicing_hint() {
    let r = check(Flaw::MovingOrigins);
    assert_only(&r, CheckKind::DicingHint);
}

#[test]
fn an_orthographic_hint_on_converging_rays_is_caught_by_dicing_hint() {
    let r = check(Flaw::OrthographicHint);
    assert_only(&r, CheckKind::DicingHint);
    assert!(
        r.get(CheckKind::FieldOfView).notes[0].contains("Orthographic"),
        "{r}"
    );
}

#[test]
fn a_wrong_unproject_is_caught() {
    let r = check(Flaw::WrongUnproject);
    assert_only(&r, CheckKind::Unproject);
}

#[test]
fn no_unproject_is_not_offered_not_failed() {
    struct NoInverse(Pinhole);
    impl Projection for NoInverse {
        fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
            self.0.property(p)
        }
        fn project(&self, ctx: &mut ProjectionContext<'_>) {
            self.0.project(ctx);
        }
    }
    let opts = CheckOptions::default();
    let env = opts.environment();
    let r = check_projection(&NoInverse(Pinhole::new(&env, Flaw::None)), &env, &opts);
    assert!(r.is_clean(), "{r}");
    let u = r.get(CheckKind::Unproject);
    assert_eq!(u.status(), Status::NotChecked);
    assert!(u.notes[0].starts_with("not offered"), "{r}");
    assert!(
        r.to_string()
            .contains("not checked  unproject inverts project: not offered"),
        "{r}"
    );
}

#[test]
fn a_counter_in_project_is_caught_by_determinism_only() {
    let r = check(Flaw::Counter(AtomicU64::new(0)));
    assert_only(&r, CheckKind::Determinism);
    let t = r.get(CheckKind::Threads);
    assert_eq!(t.status(), Status::NotChecked, "{r}");
    assert!(t.notes[0].contains("already differ"), "{r}");
}

#[test]
fn output_that_depends_on_the_thread_is_caught_by_threads() {
    let r = check(Flaw::ThreadDependent(std::thread::current().id()));
    assert_only(&r, CheckKind::Threads);
    assert!(
        r.get(CheckKind::Threads)
            .worst
            .as_ref()
            .unwrap()
            .what
            .starts_with("ray_spread on thread")
    );
}

#[test]
fn a_property_of_the_wrong_type_is_caught() {
    let r = check(Flaw::WrongPropertyType);
    assert_only(&r, CheckKind::PropertyType);
    let w = r.get(CheckKind::PropertyType).worst.clone().unwrap();
    assert_eq!(w.what, "k_FieldOfView");
    assert!(w.expected.starts_with("PropertyValue::Float"), "{w:?}");
}

/// Regression: a NaN (or negative) f-stop passed, only its type was checked.
#[test]
fn a_nan_fstop_is_caught() {
    let r = check(Flaw::NanFStop);
    assert_only(&r, CheckKind::PropertyType);
    let w = r.get(CheckKind::PropertyType).worst.clone().unwrap();
    assert_eq!(w.what, "k_FStop");
    assert_eq!(w.got, "NaN");
    for (p, x, ok) in [
        (ProjectionProperty::FStop, f32::INFINITY, true),
        (ProjectionProperty::FStop, 0.0, false),
        (ProjectionProperty::FocalDistance, f32::INFINITY, true),
        (ProjectionProperty::FocalDistance, -1.0, false),
        (ProjectionProperty::FocalLength, f32::INFINITY, false),
        (ProjectionProperty::FocalLength, 0.05, true),
    ] {
        assert_eq!(value_in_domain(p, x), ok, "{p:?} {x}");
    }
}

#[test]
fn panics_are_caught_and_reported_as_panics() {
    for (flaw, call) in [
        (Flaw::PanicInProject, "project"),
        (Flaw::PanicInUnproject, "unproject"),
        (Flaw::PanicInProperty, "property(k_FieldOfView)"),
    ] {
        let r = check(flaw);
        assert_only(&r, CheckKind::Panic);
        let w = r.get(CheckKind::Panic).worst.clone().unwrap();
        assert_eq!(w.what, call);
        assert!(w.got.contains("deliberate"), "{w:?}");
    }
}

/// An equidistant fisheye: θ = k·|s| with k = fov/2, culled outside the unit circle.
struct Fisheye {
    k: f64,
    fov: f32,
    pixel: (f64, f64),
    clipping: (f32, f32),
}

impl Fisheye {
    fn new(env: &ProjectionEnvironment, fov: f32) -> Self {
        let (dx, dy) = env.pixel_size();
        Fisheye {
            k: f64::from(fov).to_radians() / 2.0,
            fov,
            pixel: (f64::from(dx), f64::from(dy)),
            clipping: (env.clipping_near(), env.clipping_far()),
        }
    }
}

impl Projection for Fisheye {
    fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
        match p {
            ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(DicingHint::Spherical)),
            ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(DeepMetric::RayLength)),
            ProjectionProperty::FieldOfView => Some(PropertyValue::Float(self.fov)),
            _ => None,
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        for (ray, s) in c.rays.iter_mut().zip(c.screen) {
            let (x, y) = (f64::from(s.x), f64::from(s.y));
            let r = x.hypot(y);
            if r > 1.0 {
                *ray = RayGeometry::CULLED;
                continue;
            }
            let theta = self.k * r;
            let (ux, uy, tangential) = if r > 0.0 {
                (x / r, y / r, theta.sin() / r)
            } else {
                (0.0, 0.0, self.k)
            };
            // Turn per unit screen distance: k radially, sin θ / r tangentially.
            let ax = self.pixel.0 * (self.k * self.k * ux * ux + tangential * tangential * uy * uy).sqrt();
            let ay = self.pixel.1 * (self.k * self.k * uy * uy + tangential * tangential * ux * ux).sqrt();
            *ray = RayGeometry {
                origin: Vec3::ZERO,
                origin_radius: 0.0,
                direction: Vec3::new(
                    (theta.sin() * ux) as f32,
                    (theta.sin() * uy) as f32,
                    theta.cos() as f32,
                ),
                ray_spread: (0.5 * (ax * ay).sqrt()) as f32,
                min_dist: self.clipping.0,
                max_dist: self.clipping.1,
            };
        }
    }

    fn unproject(&self, p: Vec3, _time: f32) -> Option<Point2> {
        let (x, y, z) = (f64::from(p.x), f64::from(p.y), f64::from(p.z));
        let rho = x.hypot(y);
        let r = rho.atan2(z) / self.k;
        if r > 1.0 {
            return None;
        }
        if rho == 0.0 {
            return Some(Point2::ZERO);
        }
        Some(Point2::new((r * x / rho) as f32, (r * y / rho) as f32))
    }
}

#[test]
fn a_correct_wide_fisheye_is_clean_and_a_wrong_fov_is_caught() {
    let opts = CheckOptions::default();
    let env = opts.environment();
    let r = check_projection(&Fisheye::new(&env, 200.0), &env, &opts);
    assert!(r.is_clean(), "{r}");
    assert!(r.culled > 0);
    for k in [CheckKind::RaySpread, CheckKind::FieldOfView, CheckKind::Unproject] {
        assert_eq!(r.get(k).status(), Status::Ok, "{r}");
    }
    assert_eq!(r.get(CheckKind::DeepMetric).status(), Status::NotChecked);
    // Wrong by 20°: the property says 180 while the lens sees 200.
    struct Lying(Fisheye);
    impl Projection for Lying {
        fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
            match p {
                ProjectionProperty::FieldOfView => Some(PropertyValue::Float(180.0)),
                p => self.0.property(p),
            }
        }
        fn project(&self, ctx: &mut ProjectionContext<'_>) {
            self.0.project(ctx);
        }
        fn unproject(&self, p: Vec3, t: f32) -> Option<Point2> {
            self.0.unproject(p, t)
        }
    }
    let r = check_projection(&Lying(Fisheye::new(&env, 200.0)), &env, &opts);
    assert_only(&r, CheckKind::FieldOfView);
}

#[test]
fn a_seam_is_left_out_of_the_spread_check_and_said_so() {
    // The right half of the image tilted up by 40°: a jump of 25 neighbour angles at sx = 0.
    struct Split(Pinhole);
    impl Projection for Split {
        fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
            match p {
                ProjectionProperty::FieldOfView => None,
                p => self.0.property(p),
            }
        }
        fn project(&self, ctx: &mut ProjectionContext<'_>) {
            self.0.project(ctx);
            let c = ctx.parts_mut();
            let (sin, cos) = 40f32.to_radians().sin_cos();
            for (r, s) in c.rays.iter_mut().zip(c.screen) {
                if s.x > 0.0 {
                    let d = r.direction;
                    r.direction = Vec3::new(d.x, cos * d.y + sin * d.z, -sin * d.y + cos * d.z);
                    r.min_dist = 0.1 / r.direction.z;
                }
            }
        }
    }
    let opts = CheckOptions::default();
    let env = opts.environment();
    let r = check_projection(&Split(Pinhole::new(&env, Flaw::None)), &env, &opts);
    assert_eq!(r.get(CheckKind::RaySpread).status(), Status::Ok, "{r}");
    assert!(
        r.get(CheckKind::RaySpread)
            .notes
            .iter()
            .any(|n| n.contains("74 neighbour pairs left out as discontinuities")),
        "{r}"
    );
}

#[test]
fn a_factory_that_panics_or_refuses_is_reported() {
    struct Bad(bool);
    impl ProjectionFactory for Bad {
        fn name(&self) -> &str {
            "Bad"
        }
        fn summary(&self) -> &str {
            "always fails"
        }
        fn param_table(&self) -> &[obscura_sdk::ParamDecl] {
            &[]
        }
        fn create_projection(
            &self,
            _env: &mut ProjectionEnvironment,
            _params: &ParamList,
        ) -> Result<Box<dyn Projection>, PluginError> {
            if self.0 {
                panic!("deliberate create panic");
            }
            Err(PluginError::Invalid {
                plugin: "Bad".into(),
                message: "no".into(),
            })
        }
    }
    let opts = CheckOptions::default();
    let r = check_factory(&Bad(true), &ParamList::new(), &opts).unwrap();
    assert_only(&r, CheckKind::Panic);
    assert_eq!(r.projection, "Bad");
    assert!(r.get(CheckKind::Unproject).notes[0].starts_with("not run"));
    assert!(check_factory(&Bad(false), &ParamList::new(), &opts).is_err());
}

#[test]
fn json_has_every_check_and_escapes_strings() {
    let r = check(Flaw::NanDirection);
    let j = r.to_json();
    assert!(j.starts_with("{\"projection\":\"\",\"clean\":false,"), "{j}");
    for k in CheckKind::ALL {
        assert!(j.contains(&format!("{{\"check\":\"{}\"", k.id())), "{j}");
    }
    assert!(j.contains("\"status\":\"failed\""));
    // The NaN in the worst case is text inside a string, never a bare NaN number.
    assert!(!j.contains(":NaN") && !j.contains(",NaN"), "{j}");
    let mut s = String::new();
    json_str(&mut s, "a\"b\\c\nd\u{1}é");
    assert_eq!(s, "\"a\\\"b\\\\c\\nd\\u0001é\"");
    assert_eq!(json_num(f64::NAN), "null");
    assert_eq!(json_f32(1e-7), "0.0000001");
    // Brackets and braces balance outside strings.
    let (mut depth, mut in_str, mut esc) = (0i32, false, false);
    for c in j.chars() {
        match (in_str, esc, c) {
            (true, true, _) => esc = false,
            (true, false, '\\') => esc = true,
            (true, false, '"') => in_str = false,
            (false, _, '"') => in_str = true,
            (false, _, '{' | '[') => depth += 1,
            (false, _, '}' | ']') => depth -= 1,
            _ => {}
        }
        assert!(depth >= 0);
    }
    assert_eq!(depth, 0);
}
