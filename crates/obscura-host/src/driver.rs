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
//! [`CameraStage::run_soa`] runs the same steps into structure-of-arrays outputs ([`RaysSoa`], the
//! layout numpy wants): a projection that offers [`Projection::project_soa`] writes the arrays itself,
//! with no default ray pre-filled (it writes every field); any other goes through `project` on
//! sub-batches of [`SOA_FALLBACK_CHUNK`] samples that stay in the first-level cache, each pre-filled,
//! validated and scattered into the arrays. Validation is the same rules with the same report either
//! way ([`ContractReport`]: counts, the first offending sample of each kind, culls).
//!
//! Validation runs a branch-free test of every rule over blocks of rays at the widest SIMD tier
//! ([`obscura_sdk::simd`]) and hands only the rays it flags (breaches and the projection's own culls)
//! to [`check_ray`], which classes them: a clean batch costs a few instructions a ray.
//!
//! The rules are [`obscura_sdk::contract`]'s, the properties' defaults and the default rays
//! [`crate::contract`]'s: the same that `obscura check` applies.

pub use obscura_sdk::contract::Violation;
use obscura_sdk::contract::{UNIT_TOLERANCE, check_ray};
use obscura_sdk::{
    ParamList, PluginError, Point2, Projection, ProjectionContext, ProjectionEnvironment, ProjectionProperty,
    PropertyValue, RayGeometry, RaysSoa, Rgb, SoaContext, SoaLengthError, Vec3, simd,
};

pub use crate::contract::Properties;
use crate::contract::{DefaultRays, Loss, call_project, call_project_soa};
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
        batch.rays.resize(n, RayGeometry::CULLED);
        self.prefill(&batch.screen, &batch.aperture, &mut batch.rays);
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
        validate_batch(batch, &mut report);
        report
    }
}

/// Samples per sub-batch when [`CameraStage::run_soa`] falls back to `project`: 256 samples' inputs,
/// rays and tints (about 20 KiB) stay in the first-level cache between the pre-fill, `project`, the
/// validation and the scatter into the arrays.
pub const SOA_FALLBACK_CHUNK: usize = 256;

/// The memory [`CameraStage::run_soa`] reuses from batch to batch: the warped aperture samples and the
/// fallback's array-of-structs sub-batch. Keep one per thread.
#[derive(Debug, Default)]
pub struct SoaScratch {
    aperture: Vec<Point2>,
    batch: Batch,
}

impl CameraStage {
    /// The default rays of `screen` through `aperture` into `rays` (all three of one length), at the
    /// widest SIMD tier: the pre-fill `project` finds.
    fn prefill(&self, screen: &[Point2], aperture: &[Point2], rays: &mut [RayGeometry]) {
        let defaults = &self.defaults;
        simd::run(
            #[inline(always)]
            || defaults.fill(screen, aperture, rays),
        );
    }

    /// [`CameraStage::run`] into structure-of-arrays outputs: warps the canonical lens samples (into
    /// `scratch`) and, in place, the canonical times, then runs [`CameraStage::run_soa_prepared`].
    /// `time` comes back as the projection's output times, `rays` and `tint` written for every
    /// sample.
    ///
    /// # Errors
    /// A [`SoaLengthError`] naming the first array whose length is not `screen`'s (nothing is run).
    pub fn run_soa(
        &self,
        screen: &[Point2],
        lens: &[Point2],
        time: &mut [f32],
        rays: RaysSoa<'_>,
        tint: [&mut [f32]; 3],
        scratch: &mut SoaScratch,
    ) -> Result<ContractReport, SoaLengthError> {
        let n = screen.len();
        let SoaScratch { aperture, batch } = scratch;
        aperture.clear();
        aperture.resize(n, Point2::ZERO);
        if lens.len() == n && time.len() == n {
            self.aperture.warp_batch(lens, aperture);
            self.shutter.warp_batch(time);
        }
        let mut ctx = SoaContext::new(screen, lens, aperture, time, rays, tint)?;
        Ok(self.soa(&mut ctx, batch))
    }

    /// [`CameraStage::run_prepared`] into structure-of-arrays outputs: `ctx.aperture` and `ctx.time`
    /// are already warped; the rays' contents on entry do not matter. Fills the tints with white, then
    /// calls [`Projection::project_soa`]; when the projection does not offer it, runs the pre-filled
    /// `project` path on sub-batches of [`SOA_FALLBACK_CHUNK`] samples and scatters their rays, tints
    /// and times into `ctx`. Either way every ray is validated by the contract's rules with the same
    /// report as `run_prepared` (the fallback's sub-batches are reported in order, so the first example
    /// of each kind is the batch's first); a panic or error in `project_soa` loses the batch (every ray
    /// the default ray, culled; tints white), in the fallback a sub-batch.
    pub fn run_soa_prepared(&self, ctx: &mut SoaContext<'_>, scratch: &mut SoaScratch) -> ContractReport {
        self.soa(ctx, &mut scratch.batch)
    }

    fn soa(&self, ctx: &mut SoaContext<'_>, batch: &mut Batch) -> ContractReport {
        let n = ctx.num_rays();
        for t in &mut ctx.tint {
            t.fill(1.0);
        }
        match call_project_soa(self.projection.as_ref(), ctx) {
            Ok(true) => {
                let mut report = ContractReport {
                    samples: n as u64,
                    ..ContractReport::default()
                };
                validate_soa(ctx, &mut report);
                report
            }
            Ok(false) => self.soa_fallback(ctx, batch),
            Err(loss) => self.soa_lost(ctx, &loss),
        }
    }

    /// The fallback of [`CameraStage::run_soa_prepared`]: `run_prepared` sub-batch by sub-batch.
    fn soa_fallback(&self, ctx: &mut SoaContext<'_>, batch: &mut Batch) -> ContractReport {
        let n = ctx.num_rays();
        let mut report = ContractReport::default();
        for start in (0..n).step_by(SOA_FALLBACK_CHUNK) {
            let end = (start + SOA_FALLBACK_CHUNK).min(n);
            batch.clear();
            batch.screen.extend_from_slice(&ctx.screen[start..end]);
            batch.lens.extend_from_slice(&ctx.lens[start..end]);
            batch.aperture.extend_from_slice(&ctx.aperture[start..end]);
            batch.time.extend_from_slice(&ctx.time[start..end]);
            report.merge(&self.run_prepared(batch));
            ctx.rays.scatter(start, &batch.rays);
            ctx.time[start..end].copy_from_slice(&batch.time);
            let [r, g, b] = &mut ctx.tint;
            for (i, t) in (start..end).zip(&batch.tint) {
                r[i] = t.r;
                g[i] = t.g;
                b[i] = t.b;
            }
        }
        report
    }

    /// A batch whose `project_soa` failed: every ray the default ray, culled, every tint white, every
    /// sample counted as lost (as [`CameraStage::run_prepared`] counts them).
    fn soa_lost(&self, ctx: &mut SoaContext<'_>, loss: &Loss) -> ContractReport {
        let n = ctx.num_rays();
        let mut report = ContractReport {
            samples: n as u64,
            ..ContractReport::default()
        };
        let why = loss.detail();
        for i in 0..n {
            let mut r = self.defaults.ray(ctx.screen[i], ctx.aperture[i]);
            r.direction = Vec3::ZERO;
            ctx.rays.set(i, &r);
            report.record(loss.violation(), ctx.screen[i], || why.clone());
        }
        for t in &mut ctx.tint {
            t.fill(1.0);
        }
        report
    }
}

/// True when a ray keeps every per-ray rule of the contract **and** is not culled: exactly when
/// [`check_ray`] finds nothing and the direction is not zero (the same arithmetic: `|D|` is
/// `sqrt(x·x + y·y + z·z)` summed left to right, and `|D| ≈ 1` excludes zero). Branch-free (`&` on
/// booleans), so a loop of it vectorises; [`check_ray`] classes the rays it refuses.
#[inline(always)]
// `&` and plain comparisons, not `contains` and `&&`: no branch, so the loop vectorises.
#[allow(clippy::too_many_arguments, clippy::manual_range_contains)]
fn keeps_contract(
    origin: [f32; 3],
    origin_radius: f32,
    d: [f32; 3],
    ray_spread: f32,
    min_dist: f32,
    max_dist: f32,
    time: f32,
    tint: [f32; 3],
) -> bool {
    let finite = |x: f32| x.abs() < f32::INFINITY;
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    finite(d[0])
        & finite(d[1])
        & finite(d[2])
        & ((len - 1.0).abs() <= UNIT_TOLERANCE)
        & finite(origin[0])
        & finite(origin[1])
        & finite(origin[2])
        & (time >= 0.0)
        & (time < 1.0)
        & (origin_radius >= 0.0)
        & finite(origin_radius)
        & (ray_spread >= 0.0)
        & finite(ray_spread)
        & (min_dist >= 0.0)
        & (min_dist <= max_dist)
        & finite(tint[0])
        & finite(tint[1])
        & finite(tint[2])
}

/// Rays per block of the validation's vectorised pass.
const VALIDATE_BLOCK: usize = 64;

/// Classes one ray [`keeps_contract`] refused: a breach is culled and recorded, a cull counted.
fn class_ray(ray: &mut RayGeometry, time: f32, tint: Rgb, screen: Point2, report: &mut ContractReport) {
    match check_ray(ray, time, tint) {
        Some(breach) => {
            ray.direction = Vec3::ZERO;
            report.record(breach.violation, screen, || breach.detail());
        }
        None if ray.direction == Vec3::ZERO => report.culled += 1,
        None => {}
    }
}

/// The validation of [`CameraStage::run_soa_prepared`]'s native path, on the arrays.
fn validate_soa(ctx: &mut SoaContext<'_>, report: &mut ContractReport) {
    let n = ctx.num_rays();
    for start in (0..n).step_by(VALIDATE_BLOCK) {
        let end = (start + VALIDATE_BLOCK).min(n);
        let refused = {
            let r = &ctx.rays;
            let b = start..end;
            let (ox, oy, oz) = (
                &r.origin[0][b.clone()],
                &r.origin[1][b.clone()],
                &r.origin[2][b.clone()],
            );
            let (dx, dy, dz) = (
                &r.direction[0][b.clone()],
                &r.direction[1][b.clone()],
                &r.direction[2][b.clone()],
            );
            let (radius, spread) = (&r.origin_radius[b.clone()], &r.ray_spread[b.clone()]);
            let (near, far, time) = (
                &r.min_dist[b.clone()],
                &r.max_dist[b.clone()],
                &ctx.time[b.clone()],
            );
            let (tr, tg, tb) = (&ctx.tint[0][b.clone()], &ctx.tint[1][b.clone()], &ctx.tint[2][b]);
            let m = end - start;
            simd::run(
                #[inline(always)]
                || {
                    let mut refused = 0u32;
                    for k in 0..m {
                        refused += u32::from(!keeps_contract(
                            [ox[k], oy[k], oz[k]],
                            radius[k],
                            [dx[k], dy[k], dz[k]],
                            spread[k],
                            near[k],
                            far[k],
                            time[k],
                            [tr[k], tg[k], tb[k]],
                        ));
                    }
                    refused
                },
            )
        };
        if refused == 0 {
            continue;
        }
        for i in start..end {
            let mut ray = ctx.rays.get(i);
            let tint = Rgb::new(ctx.tint[0][i], ctx.tint[1][i], ctx.tint[2][i]);
            let before = ray.direction;
            class_ray(&mut ray, ctx.time[i], tint, ctx.screen[i], report);
            if ray.direction != before {
                for k in 0..3 {
                    ctx.rays.direction[k][i] = 0.0;
                }
            }
        }
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

/// Validates every ray of `batch` (after `project`) by the contract's per-ray rules, as the stage does:
/// a ray that breaks one is culled (direction set to zero) and counted in `report` by kind with the
/// first offending sample kept; rays the projection culled itself are counted in `report.culled`.
/// A ray that keeps every rule costs one branch-free test ([`check_ray`] runs only on the others).
pub fn validate_batch(batch: &mut Batch, report: &mut ContractReport) {
    for i in 0..batch.rays.len() {
        let (r, time, tint) = (&mut batch.rays[i], batch.time[i], batch.tint[i]);
        let o = r.origin;
        let d = r.direction;
        if !keeps_contract(
            [o.x, o.y, o.z],
            r.origin_radius,
            [d.x, d.y, d.z],
            r.ray_spread,
            r.min_dist,
            r.max_dist,
            time,
            [tint.r, tint.g, tint.b],
        ) {
            class_ray(r, time, tint, batch.screen[i], report);
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

    /// Runs `batch` through `run_soa` (into fresh arrays) and returns what it wrote as a batch of
    /// records, with the report.
    fn through_soa(stage: &CameraStage, batch: &Batch) -> (Batch, ContractReport) {
        let n = batch.len();
        let mut fields = vec![f32::NAN; 10 * n];
        let mut tint = vec![f32::NAN; 3 * n];
        let mut time = batch.time.clone();
        let report = {
            let rays = RaysSoa::from_fields(&mut fields).unwrap();
            let (r, gb) = tint.split_at_mut(n);
            let (g, b) = gb.split_at_mut(n);
            stage
                .run_soa(
                    &batch.screen,
                    &batch.lens,
                    &mut time,
                    rays,
                    [r, g, b],
                    &mut SoaScratch::default(),
                )
                .unwrap()
        };
        let soa = RaysSoa::from_fields(&mut fields).unwrap();
        let out = Batch {
            screen: batch.screen.clone(),
            lens: batch.lens.clone(),
            aperture: Vec::new(),
            rays: (0..n).map(|i| soa.get(i)).collect(),
            tint: (0..n)
                .map(|i| Rgb::new(tint[i], tint[n + i], tint[2 * n + i]))
                .collect(),
            time,
        };
        (out, report)
    }

    /// Runs `batch` through both paths and asserts the same rays, tints, times (bit for bit) and the
    /// same report; returns the report.
    fn both_paths_agree(stage: &CameraStage, batch: &Batch) -> ContractReport {
        let mut aos = batch.clone();
        let aos_report = stage.run(&mut aos);
        let (soa, soa_report) = through_soa(stage, batch);
        for i in 0..batch.len() {
            let (a, b) = (&aos, &soa);
            assert_eq!(
                output_values(&a.rays[i], a.time[i], a.tint[i]).map(f32::to_bits),
                output_values(&b.rays[i], b.time[i], b.tint[i]).map(f32::to_bits),
                "sample {i} of {}",
                stage.name()
            );
        }
        assert_eq!(aos_report, soa_report, "{}", stage.name());
        aos_report
    }

    /// A pinhole that writes every field itself, through `project` and through `project_soa` (the
    /// same per-sample function), and breaks the contract on the samples whose canonical lens `x`
    /// asks for it (`kind = round(16·x)`): so each sample's fate is its own, whatever the batch.
    struct Pinhole {
        rays: PerspectiveRays,
        d: f32,
        native: bool,
    }

    impl Pinhole {
        fn new(cam: &CameraDesc, native: bool) -> Self {
            Pinhole {
                rays: PerspectiveRays::new(cam.environment().pixel_size(), cam.clipping, 0.0, 1.0),
                d: screen_distance(60.0),
                native,
            }
        }

        fn sample(&self, s: Point2, lens: Point2, time: &mut f32, tint: &mut Rgb) -> RayGeometry {
            let mut r = self.rays.pinhole(s, self.d);
            match (lens.x * 16.0).round() as u32 {
                1 => r.direction = Vec3::new(f32::NAN, 0.0, 1.0),
                2 => r.direction = Vec3::new(0.0, 0.0, 2.0),
                3 => *time = 1.0,
                4 => r.direction = Vec3::ZERO,
                5 => r.ray_spread = -1.0,
                6 => (r.min_dist, r.max_dist) = (10.0, 1.0),
                7 => tint.g = f32::INFINITY,
                8 => r.origin.x = f32::INFINITY,
                9 => r.origin_radius = f32::NAN,
                10 => *tint = Rgb::new(0.5, 0.25, 2.0),
                _ => {}
            }
            r
        }
    }

    impl Projection for Pinhole {
        fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
            (p == ProjectionProperty::FieldOfView).then_some(PropertyValue::Float(60.0))
        }
        fn project(&self, ctx: &mut ProjectionContext<'_>) {
            let c = ctx.parts_mut();
            for i in 0..c.screen.len() {
                c.rays[i] = self.sample(c.screen[i], c.lens[i], &mut c.time[i], &mut c.tint[i]);
            }
        }
        fn project_soa(&self, ctx: &mut SoaContext<'_>) -> bool {
            if !self.native {
                return false;
            }
            for i in 0..ctx.num_rays() {
                let mut tint = Rgb::new(ctx.tint[0][i], ctx.tint[1][i], ctx.tint[2][i]);
                let r = self.sample(ctx.screen[i], ctx.lens[i], &mut ctx.time[i], &mut tint);
                ctx.rays.set(i, &r);
                (ctx.tint[0][i], ctx.tint[1][i], ctx.tint[2][i]) = (tint.r, tint.g, tint.b);
            }
            true
        }
    }

    /// 3000 samples (not a multiple of the fallback's sub-batch) with breaches of every per-ray kind
    /// spread over the batch, several of each.
    fn breaking_batch(cam: &CameraDesc) -> Batch {
        let mut b = grid_batch(cam);
        b.screen.truncate(3000);
        b.lens.truncate(3000);
        b.time.truncate(3000);
        for (i, l) in b.lens.iter_mut().enumerate() {
            let kind = if i % 97 == 13 { 1 + (i / 97) % 10 } else { 0 };
            *l = Point2::new(kind as f32 / 16.0, 0.5);
        }
        b
    }

    #[test]
    fn the_soa_path_gives_the_aos_rays_and_report_natively_and_through_the_fallback() {
        let cam = camera();
        for native in [true, false] {
            let stage = CameraStage::with_projection(
                "Pinhole",
                Box::new(Pinhole::new(&cam, native)),
                cam.environment(),
                &cam,
            )
            .unwrap();
            // A clean batch, then one that breaks every rule here and there.
            let mut clean = grid_batch(&cam);
            clean.lens.fill(Point2::new(0.0, 0.5));
            let clean = both_paths_agree(&stage, &clean);
            assert!(clean.is_clean() && clean.culled == 0);
            let r = both_paths_agree(&stage, &breaking_batch(&cam));
            // i % 97 == 13 for i < 3000: 31 samples, kinds 1..=10 in turn (kind 1 gets a fourth); kind 4
            // is a cull, kind 10 a finite tint.
            for (v, n) in [
                (Violation::NonFiniteDirection, 4),
                (Violation::NonUnitDirection, 3),
                (Violation::TimeOutOfRange, 3),
                (Violation::BadRaySpread, 3),
                (Violation::BadDistances, 3),
                (Violation::NonFiniteTint, 3),
                (Violation::NonFiniteOrigin, 3),
                (Violation::BadOriginRadius, 3),
            ] {
                assert_eq!(r.count(v), n, "{v:?}, native {native}");
            }
            assert_eq!(r.culled, 3, "the projection's own culls");
            assert_eq!(
                r.example(Violation::NonFiniteDirection).unwrap().screen,
                grid_batch(&cam).screen[13]
            );
            assert!(r.warning("Pinhole").unwrap().contains("25 of 3000 samples"));
        }
    }

    #[test]
    fn the_soa_path_reports_a_modifier_and_a_broken_projection_as_the_aos_path() {
        let cam = camera();
        let stage =
            CameraStage::with_projection("TimeOnly", Box::new(TimeOnly), cam.environment(), &cam).unwrap();
        assert!(both_paths_agree(&stage, &grid_batch(&cam)).is_clean());
        let stage =
            CameraStage::with_projection("LensOnly", Box::new(LensOnly), cam.environment(), &cam).unwrap();
        assert!(both_paths_agree(&stage, &grid_batch(&cam)).is_clean());
        // Panics on every call: every sample lost, the first one the example, either way.
        let stage =
            CameraStage::with_projection("Panics", Box::new(Panics), cam.environment(), &cam).unwrap();
        let r = both_paths_agree(&stage, &grid_batch(&cam));
        assert_eq!(r.count(Violation::Panicked), 3072);
    }

    /// A native path that panics loses its batch as `project`'s panic does.
    struct PanicsNatively;
    impl Projection for PanicsNatively {
        fn property(&self, _: ProjectionProperty) -> Option<PropertyValue> {
            None
        }
        fn project(&self, _ctx: &mut ProjectionContext<'_>) {
            panic!("lens table missing");
        }
        fn project_soa(&self, _ctx: &mut SoaContext<'_>) -> bool {
            panic!("lens table missing");
        }
    }

    #[test]
    fn a_native_path_that_panics_loses_the_batch_as_project_does() {
        let cam = camera();
        let stage = CameraStage::with_projection(
            "PanicsNatively",
            Box::new(PanicsNatively),
            cam.environment(),
            &cam,
        )
        .unwrap();
        let r = both_paths_agree(&stage, &grid_batch(&cam));
        assert_eq!(r.count(Violation::Panicked), 3072);
        assert!(
            r.warning("PanicsNatively")
                .unwrap()
                .contains("panicked: lens table missing")
        );
    }

    #[test]
    fn run_soa_names_an_array_of_the_wrong_length() {
        let cam = camera();
        let stage =
            CameraStage::with_projection("TimeOnly", Box::new(TimeOnly), cam.environment(), &cam).unwrap();
        let mut fields = vec![0.0; 40];
        let (mut r, mut g, mut b) = (vec![0.0; 4], vec![0.0; 4], vec![0.0; 4]);
        let screen = [Point2::ZERO; 4];
        let err = stage
            .run_soa(
                &screen,
                &[Point2::ZERO; 3],
                &mut [0.0; 4],
                RaysSoa::from_fields(&mut fields).unwrap(),
                [&mut r, &mut g, &mut b],
                &mut SoaScratch::default(),
            )
            .unwrap_err();
        assert_eq!((err.field, err.len, err.expected), ("lens", 3, 4));
    }

    fn special() -> impl proptest::strategy::Strategy<Value = f32> {
        use proptest::prelude::*;
        prop_oneof![
            Just(0.0f32),
            Just(-0.0),
            Just(1.0),
            Just(-1.0),
            Just(f32::NAN),
            Just(f32::INFINITY),
            Just(f32::NEG_INFINITY),
            Just(1.0 + UNIT_TOLERANCE),
            Just(1.0 - UNIT_TOLERANCE),
            Just(0.999_999_9),
            Just(f32::MAX),
            -2.0f32..2.0,
        ]
    }

    proptest::proptest! {
        /// The vectorised pre-test is exactly "check_ray finds nothing and the ray is not culled".
        #[test]
        fn keeps_contract_is_check_ray_without_culls(
            v in proptest::collection::vec(special(), 14),
            unit in proptest::bool::ANY,
        ) {
            let mut d = Vec3::new(v[4], v[5], v[6]);
            if unit {
                d = d.normalize_or_zero();
            }
            let ray = RayGeometry {
                origin: Vec3::new(v[0], v[1], v[2]),
                origin_radius: v[3],
                direction: d,
                ray_spread: v[7],
                min_dist: v[8],
                max_dist: v[9],
            };
            let tint = Rgb::new(v[11], v[12], v[13]);
            let fast = keeps_contract(
                [v[0], v[1], v[2]], v[3], [d.x, d.y, d.z], v[7], v[8], v[9], v[10], [v[11], v[12], v[13]],
            );
            let slow = check_ray(&ray, v[10], tint).is_none() && d != Vec3::ZERO;
            proptest::prop_assert_eq!(fast, slow, "{:?} time {} tint {:?}", ray, v[10], tint);
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
