//! The host and the checker class every breach of the projection contract the same way.
//!
//! Each case is a 90° pinhole that writes one defect (or several) into every ray. It runs through the
//! host's camera stage as `obscura render` and `obscura rays` run it (`CameraStage::with_projection`,
//! a `Batch` per row of pixels, `CameraStage::run`, the reports merged, `ContractReport::warning`) and
//! through the checker (`check_projection`). Both sides must class it alike: the host counts every
//! sample under one violation, the table's; the checker fails exactly one check,
//! `CheckKind::of(violation)`, on every sample. Where a ray breaks several rules, the first in the
//! contract's order must win on both sides. The two batch losses (a panic, a reported error) close
//! the table.

use obscura_check::{CheckKind, CheckOptions, CheckReport, check_projection};
use obscura_host::contract::ProjectFailed;
use obscura_host::sampler::Sampler;
use obscura_host::{Batch, CameraDesc, CameraStage, ContractReport, Violation};
use obscura_sdk::optics::PerspectiveRays;
use obscura_sdk::{
    DeepMetric, DicingHint, Format, Point2, Projection, ProjectionContext, ProjectionEnvironment,
    ProjectionProperty, PropertyValue, RayGeometry, Rgb, Vec3,
};

/// What the projection does to each ray (and its time and tint) after writing a correct pinhole ray.
type Defect = fn(&mut RayGeometry, &mut f32, &mut Rgb);

/// How a case's `project` goes wrong.
#[derive(Clone, Copy)]
enum Fault {
    /// Writes a defect into every ray.
    Rays(Defect),
    /// Panics.
    Panics,
    /// Reports an error, as a plugin adapter does for `OBSCURA_ERROR`.
    Fails,
}

/// One row of the table.
struct Case {
    name: &'static str,
    fault: Fault,
    /// The violation both sides must find on every sample.
    expected: Violation,
}

const fn rays(name: &'static str, defect: Defect, expected: Violation) -> Case {
    Case {
        name,
        fault: Fault::Rays(defect),
        expected,
    }
}

/// Every rule of the contract broken at least twice, then combinations, then the batch losses.
const TABLE: &[Case] = {
    use Violation::*;
    &[
        rays(
            "NaN direction",
            |r, _, _| r.direction.x = f32::NAN,
            NonFiniteDirection,
        ),
        rays(
            "infinite direction",
            |r, _, _| r.direction.y = f32::INFINITY,
            NonFiniteDirection,
        ),
        rays(
            "|D| = 2",
            |r, _, _| r.direction = r.direction * 2.0,
            NonUnitDirection,
        ),
        rays(
            "|D| = 0.5",
            |r, _, _| r.direction = r.direction * 0.5,
            NonUnitDirection,
        ),
        rays("NaN origin", |r, _, _| r.origin.z = f32::NAN, NonFiniteOrigin),
        rays(
            "infinite origin",
            |r, _, _| r.origin.x = f32::NEG_INFINITY,
            NonFiniteOrigin,
        ),
        rays("time 1.0", |_, t, _| *t = 1.0, TimeOutOfRange),
        rays("time -0.1", |_, t, _| *t = -0.1, TimeOutOfRange),
        rays("NaN time", |_, t, _| *t = f32::NAN, TimeOutOfRange),
        rays(
            "negative origin_radius",
            |r, _, _| r.origin_radius = -0.01,
            BadOriginRadius,
        ),
        rays(
            "NaN origin_radius",
            |r, _, _| r.origin_radius = f32::NAN,
            BadOriginRadius,
        ),
        rays(
            "infinite ray_spread",
            |r, _, _| r.ray_spread = f32::INFINITY,
            BadRaySpread,
        ),
        rays(
            "negative ray_spread",
            |r, _, _| r.ray_spread = -r.ray_spread,
            BadRaySpread,
        ),
        rays(
            "min_dist > max_dist",
            |r, _, _| r.max_dist = 0.5 * r.min_dist,
            BadDistances,
        ),
        rays("negative min_dist", |r, _, _| r.min_dist = -0.1, BadDistances),
        rays("NaN max_dist", |r, _, _| r.max_dist = f32::NAN, BadDistances),
        rays("infinite tint", |_, _, c| c.g = f32::INFINITY, NonFiniteTint),
        rays("NaN tint", |_, _, c| c.b = f32::NAN, NonFiniteTint),
        rays(
            "NaN direction + NaN origin",
            |r, _, _| {
                r.direction.z = f32::NAN;
                r.origin.x = f32::NAN;
            },
            NonFiniteDirection,
        ),
        rays(
            "|D| = 2 + time 2",
            |r, t, _| {
                r.direction = r.direction * 2.0;
                *t = 2.0;
            },
            NonUnitDirection,
        ),
        rays(
            "infinite origin + time 2 + NaN tint",
            |r, t, c| {
                r.origin.y = f32::INFINITY;
                *t = 2.0;
                c.r = f32::NAN;
            },
            NonFiniteOrigin,
        ),
        rays(
            "NaN time + negative origin_radius + negative min_dist",
            |r, t, _| {
                *t = f32::NAN;
                r.origin_radius = -1.0;
                r.min_dist = -1.0;
            },
            TimeOutOfRange,
        ),
        rays(
            "negative origin_radius + negative ray_spread",
            |r, _, _| {
                r.origin_radius = -1.0;
                r.ray_spread = -1.0;
            },
            BadOriginRadius,
        ),
        rays(
            "NaN ray_spread + min_dist > max_dist + infinite tint",
            |r, _, c| {
                r.ray_spread = f32::NAN;
                r.max_dist = 0.0;
                c.r = f32::INFINITY;
            },
            BadRaySpread,
        ),
        rays(
            "NaN min_dist + NaN tint",
            |r, _, c| {
                r.min_dist = f32::NAN;
                c.g = f32::NAN;
            },
            BadDistances,
        ),
        Case {
            name: "project panics",
            fault: Fault::Panics,
            expected: Panicked,
        },
        Case {
            name: "project reports an error",
            fault: Fault::Fails,
            expected: Failed,
        },
    ]
};

/// A 90° pinhole (screen plane at 1, the environment's clipping) with a fault.
struct Faulty {
    rays: PerspectiveRays,
    fault: Fault,
}

impl Faulty {
    fn new(env: &ProjectionEnvironment, fault: Fault) -> Self {
        Faulty {
            rays: PerspectiveRays::new(
                env.pixel_size(),
                (env.clipping_near(), env.clipping_far()),
                0.0,
                1.0,
            ),
            fault,
        }
    }
}

impl Projection for Faulty {
    fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
        match p {
            ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(DicingHint::Perspective)),
            ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(DeepMetric::CameraZ)),
            ProjectionProperty::FieldOfView => Some(PropertyValue::Float(90.0)),
            _ => None,
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let defect = match self.fault {
            Fault::Rays(defect) => defect,
            Fault::Panics => panic!("deliberate panic in project"),
            Fault::Fails => std::panic::resume_unwind(Box::new(ProjectFailed("lens file unreadable".into()))),
        };
        let c = ctx.parts_mut();
        for i in 0..c.rays.len() {
            c.rays[i] = self.rays.pinhole(c.screen[i], 1.0);
            defect(&mut c.rays[i], &mut c.time[i], &mut c.tint[i]);
        }
    }

    fn unproject(&self, p: Vec3, _time: f32) -> Option<Point2> {
        (p.z > 0.0).then(|| Point2::new(p.x / p.z, p.y / p.z))
    }
}

const FORMAT: Format = Format {
    width: 16,
    height: 12,
    pixel_aspect: 1.0,
};

/// The case through the host's camera stage, as a render traces it: one batch per row of pixels,
/// four samples per pixel from the host's sampler, the reports merged.
fn host(case: &Case) -> ContractReport {
    let mut camera = CameraDesc::new(FORMAT);
    camera.shutter = (0.0, 1.0);
    let env = camera.environment();
    let projection = Box::new(Faulty::new(&env, case.fault));
    let stage = CameraStage::with_projection(case.name, projection, env, &camera).unwrap();
    let sampler = Sampler::new(1);
    let mut report = ContractReport::default();
    for y in 0..FORMAT.height {
        let mut batch = Batch::with_capacity(4 * FORMAT.width as usize);
        for x in 0..FORMAT.width {
            for k in 0..4 {
                let s = sampler.sample(x, y, k);
                let screen = camera.raster_to_screen(
                    f64::from(x) + f64::from(s.pixel.0),
                    f64::from(y) + f64::from(s.pixel.1),
                );
                batch.push(screen, Point2::new(s.lens.0, s.lens.1), s.time);
            }
        }
        report.merge(&stage.run(&mut batch));
    }
    report
}

/// The case through the checker, in an environment of the same format.
fn checker(case: &Case) -> CheckReport {
    let opts = CheckOptions {
        format: FORMAT,
        samples_per_pixel: 1,
        threads: 2,
        ..CheckOptions::default()
    };
    let env = opts.environment();
    check_projection(&Faulty::new(&env, case.fault), &env, &opts)
}

/// What the host counted, by violation, and its warning.
fn host_said(report: &ContractReport, name: &str) -> String {
    let counts: Vec<String> = Violation::ALL
        .iter()
        .filter(|v| report.count(**v) > 0)
        .map(|v| format!("{v:?}: {}", report.count(*v)))
        .collect();
    format!(
        "{} of {} samples, [{}]; warning:\n{}",
        report.violations(),
        report.samples,
        counts.join(", "),
        report.warning(name).unwrap_or_else(|| "(none)".into())
    )
}

/// Why the two sides disagree with each other or with the table, if they do.
fn disagreement(case: &Case) -> Option<String> {
    let (host, checked) = (host(case), checker(case));
    let v = case.expected;
    let kind = CheckKind::of(v);
    let warning = host.warning(case.name).unwrap_or_default();
    let mut wrong = Vec::new();
    if host.samples == 0 || host.count(v) != host.samples || host.violations() != host.samples {
        wrong.push(format!("the host did not count every sample as {v:?} alone"));
    }
    let line = format!("\n  {} {}", host.samples, v.describe());
    if !warning.contains(&line) || warning.matches("\n  ").count() != 1 {
        wrong.push(format!(
            "the host's warning does not say {line:?} and nothing else"
        ));
    }
    if checked.failed() != [kind] {
        wrong.push(format!("the checker did not fail {kind:?} alone"));
    }
    let failures = checked.get(kind).failures;
    let expected_failures = match v {
        // Every `project` call is lost (the Error check counts exactly the calls; Panic counts the
        // property and unproject calls too).
        Violation::Panicked | Violation::Failed => checked.get(CheckKind::Error).examined,
        _ => checked.samples,
    };
    if failures == 0 || failures != expected_failures {
        wrong.push(format!(
            "the checker's {kind:?} failed {failures} times, not on every one of {expected_failures}"
        ));
    }
    // The same words on both sides: the field at fault (a ray's values differ from sample to sample)
    // or, for a lost batch, the whole message.
    let host_detail = host.example(v).map(|e| e.detail.clone()).unwrap_or_default();
    if let Some(worst) = &checked.get(kind).worst {
        let same = match v {
            Violation::Panicked | Violation::Failed => host_detail == worst.got,
            _ => host_detail.starts_with(&format!("{} = ", worst.what)),
        };
        if !same {
            wrong.push(format!(
                "the host's first example {host_detail:?} does not match the checker's worst case {:?}: {:?}",
                worst.what, worst.got
            ));
        }
    }
    (!wrong.is_empty()).then(|| {
        format!(
            "case {:?} (expected {v:?}, checked as {kind:?}): {}\n-- the host said: {}\n-- the checker said:\n{checked}",
            case.name,
            wrong.join("; "),
            host_said(&host, case.name)
        )
    })
}

#[test]
fn the_table_covers_every_violation() {
    for v in Violation::ALL {
        let n = TABLE.iter().filter(|c| c.expected == v).count();
        assert!(n >= 1, "no case for {v:?}");
    }
    assert!(TABLE.len() >= 12);
}

#[test]
fn host_and_checker_class_every_bad_ray_alike() {
    let wrong: Vec<String> = TABLE
        .iter()
        .filter(|c| matches!(c.fault, Fault::Rays(_)))
        .filter_map(disagreement)
        .collect();
    assert!(wrong.is_empty(), "\n{}", wrong.join("\n\n"));
}

#[test]
fn host_and_checker_class_a_lost_batch_alike() {
    let wrong: Vec<String> = TABLE
        .iter()
        .filter(|c| !matches!(c.fault, Fault::Rays(_)))
        .filter_map(disagreement)
        .collect();
    assert!(wrong.is_empty(), "\n{}", wrong.join("\n\n"));
}

/// The test can fail: a correct pinhole is clean on both sides, so "every sample under one violation"
/// is not met by a projection without a fault.
#[test]
fn a_correct_pinhole_disagrees_with_every_row() {
    let clean = Case {
        name: "no defect",
        fault: Fault::Rays(|_, _, _| {}),
        expected: Violation::NonFiniteDirection,
    };
    let why = disagreement(&clean).expect("a clean projection cannot match a row of the table");
    assert!(why.contains("case \"no defect\""), "{why}");
    assert!(why.contains("the host did not count every sample"), "{why}");
    assert!(
        why.contains("the checker did not fail DirectionFinite alone"),
        "{why}"
    );
}
