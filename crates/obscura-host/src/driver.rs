//! The camera stage: samples in, validated camera rays out.
//!
//! For each batch the stage
//!
//! 1. warps the canonical lens samples into aperture samples ([`crate::aperture`]) and the canonical
//!    time samples through the shutter-opening curve ([`crate::shutter`]);
//! 2. pre-fills every ray with the renderer's **default camera ray** ([`DefaultRays`]) and every tint
//!    with white, so a projection may be a *modifier* that only rewrites time or tint (RenderMan's
//!    PxrRollingShutter);
//! 3. calls `project` ([`call_project`]: a panic or a reported error loses the batch, counted);
//! 4. validates every ray by the contract's rules ([`check_ray`]). A ray that breaks the contract is
//!    culled (its direction set to zero) and counted by kind, with the first offending sample kept for
//!    the message; rays the projection culled itself are counted apart. Nothing invalid reaches the
//!    tracer and nothing is dropped silently.
//!
//! The rules are [`obscura_sdk::contract`]'s, the properties' defaults and the default rays
//! [`crate::contract`]'s: the same that `obscura check` applies.

pub use obscura_sdk::contract::Violation;
use obscura_sdk::contract::check_ray;
use obscura_sdk::{
    ParamList, PluginError, Point2, Projection, ProjectionContext, ProjectionEnvironment, ProjectionProperty,
    PropertyValue, RayGeometry, Rgb, Vec3,
};

pub use crate::contract::Properties;
use crate::contract::{DefaultRays, call_project};
use crate::registry::Registry;

use crate::aperture::ApertureWarp;
use crate::camera::{CameraDesc, CameraError};
use crate::shutter::ShutterWarp;

/// Why a camera stage could not be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HostError {
    /// The camera description is inconsistent.
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// The projection could not be created.
    #[error(transparent)]
    Plugin(#[from] PluginError),
}

/// The names of [`output_values`]' numbers, in order, for messages.
pub const OUTPUT_FIELDS: [&str; 14] = [
    "origin.x",
    "origin.y",
    "origin.z",
    "origin_radius",
    "direction.x",
    "direction.y",
    "direction.z",
    "ray_spread",
    "min_dist",
    "max_dist",
    "time",
    "tint.r",
    "tint.g",
    "tint.b",
];

/// Every number `project` leaves for one sample — its ray, output time and tint — in
/// [`OUTPUT_FIELDS`] order: what two runs of a deterministic projection agree on bit for bit.
#[must_use]
pub fn output_values(ray: &RayGeometry, time: f32, tint: Rgb) -> [f32; 14] {
    [
        ray.origin.x,
        ray.origin.y,
        ray.origin.z,
        ray.origin_radius,
        ray.direction.x,
        ray.direction.y,
        ray.direction.z,
        ray.ray_spread,
        ray.min_dist,
        ray.max_dist,
        time,
        tint.r,
        tint.g,
        tint.b,
    ]
}

/// One batch of samples and the rays made from them. The host fills `screen`, `lens` and `time`
/// (canonical); [`CameraStage::run`] fills the rest.
#[derive(Debug, Clone, Default)]
pub struct Batch {
    /// Screen positions.
    pub screen: Vec<Point2>,
    /// Canonical lens samples, `[0, 1)²`.
    pub lens: Vec<Point2>,
    /// Aperture samples, `[−1, 1]²` (filled by the stage).
    pub aperture: Vec<Point2>,
    /// Time: canonical on input, shutter-warped and possibly rewritten by the projection on output.
    pub time: Vec<f32>,
    /// Camera rays (filled by the stage).
    pub rays: Vec<RayGeometry>,
    /// Beauty tint (filled by the stage).
    pub tint: Vec<Rgb>,
}

impl Batch {
    /// An empty batch with room for `n` samples.
    #[must_use]
    pub fn with_capacity(n: usize) -> Self {
        Batch {
            screen: Vec::with_capacity(n),
            lens: Vec::with_capacity(n),
            aperture: Vec::with_capacity(n),
            time: Vec::with_capacity(n),
            rays: Vec::with_capacity(n),
            tint: Vec::with_capacity(n),
        }
    }

    /// Empties the batch, keeping its memory.
    pub fn clear(&mut self) {
        self.screen.clear();
        self.lens.clear();
        self.aperture.clear();
        self.time.clear();
        self.rays.clear();
        self.tint.clear();
    }

    /// Adds one sample.
    pub fn push(&mut self, screen: Point2, lens: Point2, time: f32) {
        self.screen.push(screen);
        self.lens.push(lens);
        self.time.push(time);
    }

    /// Samples in the batch.
    #[must_use]
    pub fn len(&self) -> usize {
        self.screen.len()
    }

    /// True when the batch is empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.screen.is_empty()
    }
}

/// The first offending sample of one violation kind.
#[derive(Debug, Clone, PartialEq)]
pub struct Example {
    /// The screen position of the sample.
    pub screen: Point2,
    /// What was wrong with it.
    pub detail: String,
}

/// Counts of what one or more batches produced; merge reports from several batches or threads.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContractReport {
    /// Samples handed to `project`.
    pub samples: u64,
    /// Samples the projection culled itself (zero direction): legitimate, contributing nothing.
    pub culled: u64,
    counts: [u64; Violation::ALL.len()],
    examples: [Option<Example>; Violation::ALL.len()],
}

impl ContractReport {
    /// How many samples broke the contract in this way (and were culled by the host).
    #[must_use]
    pub fn count(&self, v: Violation) -> u64 {
        self.counts[v.index()]
    }

    /// The first offending sample of this kind.
    #[must_use]
    pub fn example(&self, v: Violation) -> Option<&Example> {
        self.examples[v.index()].as_ref()
    }

    /// Samples that broke the contract in any way.
    #[must_use]
    pub fn violations(&self) -> u64 {
        self.counts.iter().sum()
    }

    /// Samples of batches whose `project` failed — a panic, an error it returned, or (for an isolated
    /// plugin) its worker's crash or hang: lost whole, neither rendered nor counted as culled.
    #[must_use]
    pub fn lost(&self) -> u64 {
        self.count(Violation::Panicked) + self.count(Violation::Failed)
    }

    /// Samples whose ray broke a per-ray rule (and were culled by the host): [`Self::violations`]
    /// without the [lost](Self::lost) ones.
    #[must_use]
    pub fn breaches(&self) -> u64 {
        self.violations() - self.lost()
    }

    /// True when no sample broke the contract.
    #[must_use]
    pub fn is_clean(&self) -> bool {
        self.violations() == 0
    }

    fn record(&mut self, v: Violation, screen: Point2, detail: impl FnOnce() -> String) {
        let i = v.index();
        self.counts[i] += 1;
        if self.examples[i].is_none() {
            self.examples[i] = Some(Example {
                screen,
                detail: detail(),
            });
        }
    }

    /// Adds another report's counts (keeping this one's first examples).
    pub fn merge(&mut self, other: &ContractReport) {
        self.samples += other.samples;
        self.culled += other.culled;
        for i in 0..self.counts.len() {
            self.counts[i] += other.counts[i];
            if self.examples[i].is_none() {
                self.examples[i].clone_from(&other.examples[i]);
            }
        }
    }

    /// A warning naming the projection, or `None` when it kept the contract.
    #[must_use]
    pub fn warning(&self, projection: &str) -> Option<String> {
        if self.is_clean() {
            return None;
        }
        let mut msg = format!(
            "warning: projection {projection} broke the projection contract on {} of {} samples; \
             those samples were culled (they contribute nothing):",
            self.violations(),
            self.samples
        );
        for v in Violation::ALL {
            let n = self.count(v);
            if n > 0 {
                msg.push_str(&format!("\n  {n} {}", v.describe()));
                if let Some(e) = self.example(v) {
                    msg.push_str(&format!(
                        " (first at screen ({}, {}): {})",
                        e.screen.x, e.screen.y, e.detail
                    ));
                }
            }
        }
        Some(msg)
    }
}

/// One projection, ready to turn batches of samples into validated rays. Shareable across threads:
/// [`CameraStage::run`] takes `&self`.
pub struct CameraStage {
    name: String,
    projection: Box<dyn Projection>,
    env: ProjectionEnvironment,
    camera: CameraDesc,
    properties: Properties,
    defaults: DefaultRays,
    aperture: ApertureWarp,
    shutter: ShutterWarp,
    setup_warnings: Vec<String>,
}

impl std::fmt::Debug for CameraStage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CameraStage")
            .field("projection", &self.name)
            .field("properties", &self.properties)
            .finish_non_exhaustive()
    }
}

impl CameraStage {
    /// Validates `camera`, creates the projection `name` from `registry` with `params`, and reads its
    /// properties.
    ///
    /// # Errors
    /// A [`HostError`] naming the camera request or the projection and parameter at fault.
    pub fn new(
        registry: &mut Registry,
        name: &str,
        params: &ParamList,
        camera: &CameraDesc,
    ) -> Result<Self, HostError> {
        camera.validate()?;
        let mut env = camera.environment();
        let projection = registry.create(name, &mut env, params)?;
        Self::with_projection(name, projection, env, camera)
    }

    /// A stage for a scene's projection `name` that may filter an earlier one, `base` (RenderMan's
    /// projection modifiers: a built-in projection declared before a plugin projection is applied
    /// first, and the plugin edits its rays). When `base` names a built-in (registered with an empty
    /// path) and `name` a loaded plugin, both are created, in that order, from the same environment, and
    /// each batch runs the built-in's `project` and then the plugin's on the same rays; the built-in
    /// answers every property (field of view, dicing, depth metric, …), since the rays' geometry is
    /// its own, and the chain offers no inverse (the plugin may have moved the rays). Otherwise the
    /// last projection wins: `base` is ignored and this is [`CameraStage::new`].
    ///
    /// # Errors
    /// As [`CameraStage::new`], for either projection.
    pub fn chained(
        registry: &mut Registry,
        base: Option<&(String, ParamList)>,
        name: &str,
        params: &ParamList,
        camera: &CameraDesc,
    ) -> Result<Self, HostError> {
        let plugin = registry.path(name).is_some_and(|p| !p.is_empty());
        let Some((first, first_params)) = base.filter(|(b, _)| plugin && registry.path(b) == Some("")) else {
            return Self::new(registry, name, params, camera);
        };
        camera.validate()?;
        let mut env = camera.environment();
        let first = registry.create(first, &mut env, first_params)?;
        let then = registry.create(name, &mut env, params)?;
        Self::with_projection(name, Box::new(Chain { first, then }), env, camera)
    }

    /// A stage around an already-created projection (tests, tools).
    ///
    /// # Errors
    /// A [`HostError`] when the camera description is inconsistent.
    pub fn with_projection(
        name: &str,
        projection: Box<dyn Projection>,
        env: ProjectionEnvironment,
        camera: &CameraDesc,
    ) -> Result<Self, HostError> {
        camera.validate()?;
        let (properties, answers) = Properties::read(projection.as_ref(), &env);
        let setup_warnings = answers
            .iter()
            .filter_map(|(p, a)| a.as_ref().err().map(|e| e.warning(name, *p)))
            .collect();
        let defaults = DefaultRays::new(&properties, &env);
        Ok(CameraStage {
            name: name.to_string(),
            projection,
            env,
            camera: camera.clone(),
            properties,
            defaults,
            aperture: ApertureWarp::new(&camera.aperture).map_err(CameraError::from)?,
            shutter: ShutterWarp::new(&camera.shutter_opening).map_err(CameraError::from)?,
            setup_warnings,
        })
    }

    /// The projection's name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The projection itself (for `unproject`).
    #[must_use]
    pub fn projection(&self) -> &dyn Projection {
        self.projection.as_ref()
    }

    /// The environment the projection was created with.
    #[must_use]
    pub fn environment(&self) -> &ProjectionEnvironment {
        &self.env
    }

    /// The camera description.
    #[must_use]
    pub fn camera(&self) -> &CameraDesc {
        &self.camera
    }

    /// The properties read at setup.
    #[must_use]
    pub fn properties(&self) -> &Properties {
        &self.properties
    }

    /// Warnings from setup (a property answered with the wrong type, …).
    #[must_use]
    pub fn setup_warnings(&self) -> &[String] {
        &self.setup_warnings
    }

    /// Warps the batch's canonical lens and time samples, then runs [`CameraStage::run_prepared`].
    pub fn run(&self, batch: &mut Batch) -> ContractReport {
        let n = batch.len();
        batch.aperture.resize(n, Point2::ZERO);
        self.aperture.warp_batch(&batch.lens, &mut batch.aperture);
        batch.time.truncate(n);
        self.shutter.warp_batch(&mut batch.time);
        self.run_prepared(batch)
    }

    /// Pre-fills the default rays and white tints, calls `project`, validates. `aperture` and `time`
    /// must already be set (a chief-ray map sets the aperture to the lens centre itself).
    pub fn run_prepared(&self, batch: &mut Batch) -> ContractReport {
        let n = batch.len();
        batch.aperture.resize(n, Point2::ZERO);
        batch.time.resize(n, 0.0);
        batch.rays.clear();
        batch.rays.extend(
            batch
                .screen
                .iter()
                .zip(&batch.aperture)
                .map(|(s, a)| self.defaults.ray(*s, *a)),
        );
        batch.tint.clear();
        batch.tint.resize(n, Rgb::WHITE);

        let mut report = ContractReport {
            samples: n as u64,
            ..ContractReport::default()
        };
        let mut ctx = ProjectionContext::new(
            &batch.screen,
            &batch.lens,
            &batch.aperture,
            &mut batch.time,
            &mut batch.rays,
            &mut batch.tint,
        )
        .expect("the batch's arrays were sized alike just above");
        if let Err(loss) = call_project(self.projection.as_ref(), &mut ctx) {
            let why = loss.detail();
            for (r, s) in batch.rays.iter_mut().zip(&batch.screen) {
                r.direction = Vec3::ZERO;
                report.record(loss.violation(), *s, || why.clone());
            }
            return report;
        }
        validate(batch, &mut report);
        report
    }
}

/// A built-in projection and the plugin that filters its rays ([`CameraStage::chained`]).
struct Chain {
    first: Box<dyn Projection>,
    then: Box<dyn Projection>,
}

impl Projection for Chain {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        self.first.property(property)
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        self.first.project(ctx);
        self.then.project(ctx);
    }
}

fn validate(batch: &mut Batch, report: &mut ContractReport) {
    for i in 0..batch.rays.len() {
        let r = &mut batch.rays[i];
        match check_ray(r, batch.time[i], batch.tint[i]) {
            Some(breach) => {
                r.direction = Vec3::ZERO;
                report.record(breach.violation, batch.screen[i], || breach.detail());
            }
            None if r.direction == Vec3::ZERO => report.culled += 1,
            None => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::optics::{PerspectiveRays, screen_distance};
    use obscura_sdk::{DeepMetric, DicingHint, Format, ProjectionProperty, PropertyValue};

    /// The two built-ins the stage's own tests drive.
    fn builtin_registry() -> Registry {
        let mut reg = Registry::new();
        reg.register(Box::new(obscura_projections::PerspectiveFactory), "")
            .unwrap();
        reg.register(Box::new(obscura_projections::OrthographicFactory), "")
            .unwrap();
        reg
    }

    fn camera() -> CameraDesc {
        let mut c = CameraDesc::new(Format::new(64, 48));
        c.shutter = (0.0, 1.0);
        c
    }

    fn grid_batch(cam: &CameraDesc) -> Batch {
        let mut b = Batch::with_capacity(64 * 48);
        for y in 0..48 {
            for x in 0..64 {
                let s = cam.raster_to_screen(x as f64 + 0.5, y as f64 + 0.5);
                b.push(s, Point2::new(0.3, 0.7), (x as f32 + 0.5) / 64.0);
            }
        }
        b
    }

    /// A modifier in RenderMan's PxrRollingShutter sense: it reports a perspective camera and rewrites
    /// only the time (top rows first), leaving the host's pre-filled rays alone.
    struct TimeOnly;
    impl Projection for TimeOnly {
        fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
            match p {
                ProjectionProperty::FieldOfView => Some(PropertyValue::Float(60.0)),
                _ => None,
            }
        }
        fn project(&self, ctx: &mut ProjectionContext<'_>) {
            let c = ctx.parts_mut();
            for (t, s) in c.time.iter_mut().zip(c.screen) {
                *t = (0.5 - 0.5 * s.y).clamp(0.0, 0.999);
            }
        }
    }

    #[test]
    fn a_modifier_that_only_rewrites_time_gets_the_default_rays() {
        let cam = camera();
        let stage =
            CameraStage::with_projection("TimeOnly", Box::new(TimeOnly), cam.environment(), &cam).unwrap();
        let mut batch = grid_batch(&cam);
        let report = stage.run(&mut batch);
        assert!(report.is_clean(), "{:?}", report.warning("TimeOnly"));
        let reference = PerspectiveRays::new(cam.environment().pixel_size(), cam.clipping, 0.0, 1.0);
        let d = screen_distance(60.0);
        for i in 0..batch.len() {
            assert_eq!(batch.rays[i], reference.pinhole(batch.screen[i], d));
            assert_eq!(batch.tint[i], Rgb::WHITE);
            assert_eq!(batch.time[i], (0.5 - 0.5 * batch.screen[i].y).clamp(0.0, 0.999));
        }
    }

    /// Reports a thin lens and rewrites nothing: the defaults must focus at its focal distance.
    struct LensOnly;
    impl Projection for LensOnly {
        fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
            match p {
                ProjectionProperty::FieldOfView => Some(PropertyValue::Float(40.0)),
                ProjectionProperty::FStop => Some(PropertyValue::Float(2.0)),
                ProjectionProperty::FocalLength => Some(PropertyValue::Float(0.1)),
                ProjectionProperty::FocalDistance => Some(PropertyValue::Float(6.0)),
                _ => None,
            }
        }
        fn project(&self, _ctx: &mut ProjectionContext<'_>) {}
    }

    #[test]
    fn default_rays_use_the_reported_thin_lens() {
        let cam = camera();
        let stage =
            CameraStage::with_projection("LensOnly", Box::new(LensOnly), cam.environment(), &cam).unwrap();
        let mut batch = Batch::default();
        let s = Point2::new(0.2, -0.1);
        for i in 0..16 {
            batch.push(
                s,
                Point2::new((i as f32 + 0.5) / 16.0, ((i * 7 % 16) as f32 + 0.5) / 16.0),
                0.0,
            );
        }
        assert!(stage.run(&mut batch).is_clean());
        let d = screen_distance(40.0);
        let focus = Vec3::new(s.x * 6.0 / d, s.y * 6.0 / d, 6.0);
        let mut origins_differ = false;
        for r in &batch.rays {
            let hit = r.origin + r.direction * ((6.0 - r.origin.z) / r.direction.z);
            assert!((hit - focus).length() < 1e-4);
            origins_differ |= r.origin.length() > 0.001;
            assert!(r.origin.length() <= 0.025 + 1e-6, "lens radius is 0.1/(2*2)");
        }
        assert!(origins_differ);
    }

    struct Broken;
    impl Projection for Broken {
        fn property(&self, _: ProjectionProperty) -> Option<PropertyValue> {
            None
        }
        fn project(&self, ctx: &mut ProjectionContext<'_>) {
            let c = ctx.parts_mut();
            c.rays[0].direction = Vec3::new(f32::NAN, 0.0, 1.0);
            c.rays[1].direction = Vec3::new(0.0, 0.0, 2.0);
            c.time[2] = 1.0;
            c.rays[3].ray_spread = -1.0;
            c.rays[4].direction = Vec3::ZERO;
            c.rays[5].min_dist = 10.0;
            c.rays[5].max_dist = 1.0;
            c.tint[6].g = f32::INFINITY;
            c.rays[7].origin.x = f32::INFINITY;
        }
    }

    #[test]
    fn contract_breaches_are_culled_and_counted_by_kind() {
        let cam = camera();
        let stage =
            CameraStage::with_projection("Broken", Box::new(Broken), cam.environment(), &cam).unwrap();
        let mut batch = grid_batch(&cam);
        let r = stage.run(&mut batch);
        for v in [
            Violation::NonFiniteDirection,
            Violation::NonUnitDirection,
            Violation::TimeOutOfRange,
            Violation::BadRaySpread,
            Violation::BadDistances,
            Violation::NonFiniteTint,
            Violation::NonFiniteOrigin,
        ] {
            assert_eq!(r.count(v), 1, "{v:?}");
        }
        assert_eq!(r.violations(), 7);
        assert_eq!(
            r.culled, 1,
            "the projection's own zero direction is a cull, not a breach"
        );
        for i in [0, 1, 2, 3, 5, 6, 7] {
            assert_eq!(batch.rays[i].direction, Vec3::ZERO, "sample {i} must be culled");
        }
        assert_ne!(batch.rays[8].direction, Vec3::ZERO);
        let w = r.warning("Broken").unwrap();
        assert!(
            w.contains("projection Broken broke the projection contract on 7 of 3072 samples"),
            "{w}"
        );
        assert!(w.contains("1 times outside [0, 1) (first at screen"), "{w}");
        assert!(w.contains("|direction| = 2"), "{w}");
    }

    struct Panics;
    impl Projection for Panics {
        fn property(&self, _: ProjectionProperty) -> Option<PropertyValue> {
            None
        }
        fn project(&self, _ctx: &mut ProjectionContext<'_>) {
            panic!("lens table missing");
        }
    }

    #[test]
    fn a_panicking_projection_loses_its_batch_not_the_render() {
        let cam = camera();
        let stage =
            CameraStage::with_projection("Panics", Box::new(Panics), cam.environment(), &cam).unwrap();
        let mut batch = grid_batch(&cam);
        let r = stage.run(&mut batch);
        assert_eq!(r.count(Violation::Panicked), 3072);
        assert!(batch.rays.iter().all(RayGeometry::is_culled));
        assert!(
            r.warning("Panics")
                .unwrap()
                .contains("panicked: lens table missing")
        );
    }

    struct WrongTypes;
    impl Projection for WrongTypes {
        fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
            match p {
                ProjectionProperty::FieldOfView => Some(PropertyValue::DicingHint(DicingHint::Spherical)),
                ProjectionProperty::DicingHint => Some(PropertyValue::Float(1.0)),
                _ => None,
            }
        }
        fn project(&self, _ctx: &mut ProjectionContext<'_>) {}
    }

    #[test]
    fn mistyped_properties_are_ignored_with_a_warning() {
        let cam = camera();
        let stage = CameraStage::with_projection("WrongTypes", Box::new(WrongTypes), cam.environment(), &cam)
            .unwrap();
        assert_eq!(stage.setup_warnings().len(), 2);
        assert!(
            stage.setup_warnings()[0].contains("k_DicingHint"),
            "{:?}",
            stage.setup_warnings()
        );
        assert_eq!(stage.properties().field_of_view, None);
        assert_eq!(stage.properties().dicing_hint, DicingHint::Perspective);
    }

    #[test]
    fn builtins_keep_the_contract_with_warped_samples() {
        let mut reg = builtin_registry();
        let mut cam = camera();
        cam.aperture.n_sides = 6;
        for (name, params) in [
            (
                "PxrPerspective",
                vec![
                    ("float fStop", "2"),
                    ("float focalLength", "0.1"),
                    ("float fovEnd", "50"),
                ],
            ),
            (
                "PxrOrthographic",
                vec![("float fStop", "2"), ("float focalLength", "0.1")],
            ),
        ] {
            let mut list = ParamList::new();
            for (d, v) in params {
                list.push_text(d, &[v], None).unwrap();
            }
            let stage = CameraStage::new(&mut reg, name, &list, &cam).unwrap();
            let mut batch = grid_batch(&cam);
            let r = stage.run(&mut batch);
            assert!(r.is_clean(), "{:?}", r.warning(name));
            assert_eq!(r.culled, 0);
            assert_eq!(stage.properties().deep_metric, DeepMetric::CameraZ);
        }
    }

    #[test]
    fn reports_merge() {
        let mut a = ContractReport {
            samples: 10,
            culled: 1,
            ..Default::default()
        };
        a.record(Violation::TimeOutOfRange, Point2::ZERO, || "time 1".into());
        let mut b = ContractReport {
            samples: 5,
            ..Default::default()
        };
        b.record(Violation::TimeOutOfRange, Point2::new(1.0, 1.0), || {
            "time 2".into()
        });
        b.record(Violation::BadRaySpread, Point2::ZERO, || "spread".into());
        a.merge(&b);
        assert_eq!((a.samples, a.culled, a.violations()), (15, 1, 3));
        assert_eq!(a.example(Violation::TimeOutOfRange).unwrap().detail, "time 1");
        assert_eq!(a.example(Violation::BadRaySpread).unwrap().detail, "spread");
    }

    /// Regression (issue 16): samples of failed batches are counted as lost, apart from per-ray breaches.
    #[test]
    fn lost_batches_and_per_ray_breaches_are_told_apart() {
        let mut r = ContractReport::default();
        for _ in 0..4 {
            r.record(Violation::Panicked, Point2::ZERO, String::new);
        }
        for _ in 0..2 {
            r.record(Violation::Failed, Point2::ZERO, String::new);
        }
        r.record(Violation::NonFiniteTint, Point2::ZERO, String::new);
        assert_eq!((r.lost(), r.breaches(), r.violations()), (6, 1, 7));
    }
}
