//! The camera stage: samples in, validated camera rays out.
//!
//! For each batch the stage
//!
//! 1. warps the canonical lens samples into aperture samples ([`crate::aperture`]) and the canonical
//!    time samples through the shutter-opening curve ([`crate::shutter`]);
//! 2. pre-fills every ray with the renderer's **default camera ray** — orthographic when the projection's
//!    DicingHint is Orthographic, else a pinhole at the projection's FieldOfView (90° when it reports
//!    none), through a thin lens when it reports FStop, FocalLength and FocalDistance (the document: the
//!    renderer uses them "as part of the computation for the initial ray directions supplied to the
//!    projection plugin") — and every tint with white, so a projection may be a *modifier* that only
//!    rewrites time or tint (RenderMan's PxrRollingShutter);
//! 3. calls `project`, catching a panic;
//! 4. validates every ray: origin finite; direction finite and unit length (within 10⁻³) or exactly
//!    zero; time in `[0, 1)`; radius and spread finite and ≥ 0; `0 ≤ min_dist ≤ max_dist`; tint finite.
//!    A ray that breaks the contract is culled (its direction set to zero) and counted by kind, with
//!    the first offending sample kept for the message; rays the projection culled itself are counted
//!    apart. Nothing invalid reaches the tracer and nothing is dropped silently.

use std::panic::{AssertUnwindSafe, catch_unwind};

use obscura_sdk::abi::{UndecodableProperty, panic_message};
use obscura_sdk::optics::{OrthographicRays, PerspectiveRays, screen_distance};
use obscura_sdk::{
    DeepMetric, DicingHint, ParamList, PluginError, Point2, Projection, ProjectionContext,
    ProjectionEnvironment, ProjectionProperty, PropertyValue, RayGeometry, Registry, Rgb, Vec3,
};

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

/// The properties a projection answered at render start, with the host's defaults filled in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Properties {
    /// How to dice geometry (default Perspective).
    pub dicing_hint: DicingHint,
    /// How to measure depth: the property when answered, else the environment's deep metric.
    pub deep_metric: DeepMetric,
    /// Field of view in degrees, if answered.
    pub field_of_view: Option<f32>,
    /// f-stop, if answered.
    pub f_stop: Option<f32>,
    /// Focal length, if answered.
    pub focal_length: Option<f32>,
    /// Focal distance, if answered.
    pub focal_distance: Option<f32>,
}

/// A way a ray can break the projection contract.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Violation {
    /// `project` panicked: the whole batch is culled.
    Panicked,
    /// An origin component is NaN or infinite.
    NonFiniteOrigin,
    /// A direction component is NaN or infinite.
    NonFiniteDirection,
    /// The direction is neither unit length nor exactly zero.
    NonUnitDirection,
    /// The time is outside `[0, 1)`.
    TimeOutOfRange,
    /// `origin_radius` is negative or not finite.
    BadOriginRadius,
    /// `ray_spread` is negative or not finite.
    BadRaySpread,
    /// Not `0 ≤ min_dist ≤ max_dist` (or NaN).
    BadDistances,
    /// A tint channel is NaN or infinite.
    NonFiniteTint,
}

impl Violation {
    /// Every violation, in report order.
    pub const ALL: [Violation; 9] = [
        Violation::Panicked,
        Violation::NonFiniteOrigin,
        Violation::NonFiniteDirection,
        Violation::NonUnitDirection,
        Violation::TimeOutOfRange,
        Violation::BadOriginRadius,
        Violation::BadRaySpread,
        Violation::BadDistances,
        Violation::NonFiniteTint,
    ];

    /// What the contract expects, for messages.
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            Violation::Panicked => "samples lost to a panic in project",
            Violation::NonFiniteOrigin => "non-finite origins",
            Violation::NonFiniteDirection => "non-finite directions",
            Violation::NonUnitDirection => "directions neither unit length nor zero",
            Violation::TimeOutOfRange => "times outside [0, 1)",
            Violation::BadOriginRadius => "negative or non-finite origin radii",
            Violation::BadRaySpread => "negative or non-finite ray spreads",
            Violation::BadDistances => "min/max distances not 0 <= min <= max",
            Violation::NonFiniteTint => "non-finite tints",
        }
    }

    fn index(self) -> usize {
        Violation::ALL.iter().position(|v| *v == self).unwrap_or(0)
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
    counts: [u64; 9],
    examples: [Option<Example>; 9],
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

/// The host's own camera ray, used to pre-fill every batch.
#[derive(Debug, Clone, Copy, PartialEq)]
enum DefaultRays {
    Perspective { rays: PerspectiveRays, d: f32 },
    Orthographic(OrthographicRays),
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

/// A unit direction may be off by this much in length (f32 normalisation is good to ~1e-7).
const UNIT_TOLERANCE: f32 = 1e-3;

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
        let mut setup_warnings = Vec::new();
        let properties = read_properties(name, projection.as_ref(), &env, &mut setup_warnings);
        let defaults = default_rays(&properties, &env);
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
                .map(|(s, a)| match &self.defaults {
                    DefaultRays::Perspective { rays, d } => rays.ray(*s, *a, *d),
                    DefaultRays::Orthographic(rays) => rays.ray(*s, *a),
                }),
        );
        batch.tint.clear();
        batch.tint.resize(n, Rgb::WHITE);

        let mut report = ContractReport {
            samples: n as u64,
            ..ContractReport::default()
        };
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            let mut ctx = ProjectionContext::new(
                &batch.screen,
                &batch.lens,
                &batch.aperture,
                &mut batch.time,
                &mut batch.rays,
                &mut batch.tint,
            )
            .expect("the batch's arrays were sized alike just above");
            self.projection.project(&mut ctx);
        }));
        if let Err(payload) = outcome {
            let why = panic_message(payload.as_ref());
            for (r, s) in batch.rays.iter_mut().zip(&batch.screen) {
                r.direction = Vec3::ZERO;
                report.record(Violation::Panicked, *s, || format!("panicked: {why}"));
            }
            return report;
        }
        validate(batch, &mut report);
        report
    }
}

fn validate(batch: &mut Batch, report: &mut ContractReport) {
    for i in 0..batch.rays.len() {
        let s = batch.screen[i];
        let r = batch.rays[i];
        let t = batch.time[i];
        let mut bad = None;
        let len = r.direction.length();
        if !r.origin.is_finite() {
            bad = Some((Violation::NonFiniteOrigin, format!("origin {:?}", r.origin)));
        } else if !r.direction.is_finite() {
            bad = Some((
                Violation::NonFiniteDirection,
                format!("direction {:?}", r.direction),
            ));
        } else if r.direction != Vec3::ZERO && (len - 1.0).abs() > UNIT_TOLERANCE {
            bad = Some((Violation::NonUnitDirection, format!("|direction| = {len}")));
        } else if !(0.0..1.0).contains(&t) {
            bad = Some((Violation::TimeOutOfRange, format!("time {t}")));
        } else if !(r.origin_radius >= 0.0 && r.origin_radius.is_finite()) {
            bad = Some((
                Violation::BadOriginRadius,
                format!("origin_radius {}", r.origin_radius),
            ));
        } else if !(r.ray_spread >= 0.0 && r.ray_spread.is_finite()) {
            bad = Some((Violation::BadRaySpread, format!("ray_spread {}", r.ray_spread)));
        } else if !(r.min_dist >= 0.0 && r.min_dist <= r.max_dist) {
            bad = Some((
                Violation::BadDistances,
                format!("min_dist {} max_dist {}", r.min_dist, r.max_dist),
            ));
        } else if !batch.tint[i].is_finite() {
            bad = Some((Violation::NonFiniteTint, format!("tint {:?}", batch.tint[i])));
        }
        match bad {
            Some((v, detail)) => {
                batch.rays[i].direction = Vec3::ZERO;
                report.record(v, s, || detail);
            }
            None if r.direction == Vec3::ZERO => report.culled += 1,
            None => {}
        }
    }
}

fn read_properties(
    name: &str,
    p: &dyn Projection,
    env: &ProjectionEnvironment,
    warnings: &mut Vec<String>,
) -> Properties {
    let mut ask = |prop: ProjectionProperty| -> Option<PropertyValue> {
        // A panic here (a built-in's bug, or a plugin's failed call raised by its adapter) leaves the
        // property unanswered with a warning; the render goes on.
        let v = match catch_unwind(AssertUnwindSafe(|| p.property(prop))) {
            Ok(v) => v?,
            Err(payload) => {
                warnings.push(match payload.downcast_ref::<UndecodableProperty>() {
                    Some(bad) => format!(
                        "warning: projection {name} answered {} with {}; ignored",
                        bad.property, bad.reason
                    ),
                    None => format!(
                        "warning: projection {name} failed to answer {}: {}; treated as unanswered",
                        prop.renderman_name(),
                        panic_message(payload.as_ref())
                    ),
                });
                return None;
            }
        };
        if prop.accepts(v) {
            Some(v)
        } else {
            warnings.push(format!(
                "warning: projection {name} answered {} with {v:?}, which is not that property's type; ignored",
                prop.renderman_name()
            ));
            None
        }
    };
    let float = |v: Option<PropertyValue>| match v {
        Some(PropertyValue::Float(x)) if x.is_finite() => Some(x),
        _ => None,
    };
    let dicing_hint = match ask(ProjectionProperty::DicingHint) {
        Some(PropertyValue::DicingHint(h)) => h,
        _ => DicingHint::Perspective,
    };
    let deep_metric = match ask(ProjectionProperty::DeepMetric) {
        Some(PropertyValue::DeepMetric(m)) => m,
        _ => env.deep_metric(),
    };
    Properties {
        dicing_hint,
        deep_metric,
        field_of_view: float(ask(ProjectionProperty::FieldOfView)),
        f_stop: float(ask(ProjectionProperty::FStop)),
        focal_length: float(ask(ProjectionProperty::FocalLength)),
        focal_distance: float(ask(ProjectionProperty::FocalDistance)),
    }
}

fn default_rays(props: &Properties, env: &ProjectionEnvironment) -> DefaultRays {
    let (lens_radius, focal_distance) = match (props.f_stop, props.focal_length, props.focal_distance) {
        (Some(f), Some(fl), Some(fd)) if fd > 0.0 => (PerspectiveRays::lens_radius_for(f, fl), fd),
        _ => (0.0, 1.0),
    };
    let clipping = (env.clipping_near(), env.clipping_far());
    if props.dicing_hint == DicingHint::Orthographic {
        return DefaultRays::Orthographic(OrthographicRays::new(
            env.pixel_size(),
            clipping,
            lens_radius,
            focal_distance,
        ));
    }
    // A pinhole cannot show 180° or more; wider projections write their own rays anyway.
    let fov = props
        .field_of_view
        .filter(|f| *f > 0.0)
        .unwrap_or(90.0)
        .min(179.0);
    DefaultRays::Perspective {
        rays: PerspectiveRays::new(env.pixel_size(), clipping, lens_radius, focal_distance),
        d: screen_distance(fov),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_projections::builtin_registry;
    use obscura_sdk::Format;

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
}
