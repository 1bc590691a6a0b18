//! # obscura-check
//!
//! The projection contract checker: what `obscura check` runs, as a library a plugin author adds as a
//! dev-dependency and calls from their own tests. The per-ray rules, the property defaults and the
//! host's default rays are [`obscura_sdk::contract`]'s, exactly what the host's camera stage applies;
//! this crate adds the checks that need many rays at once (spread, field of view, clipping, dicing
//! hint, deep metric, unproject, determinism, threads).
//!
//! ```
//! use obscura_check::{CheckOptions, check_projection};
//! use obscura_sdk::*;
//!
//! /// Parallel rays down +Z from the screen point: an orthographic camera, clipped at the
//! /// environment's near and far planes.
//! struct Flat {
//!     origin_radius: f32,
//!     clipping: (f32, f32),
//! }
//! impl Projection for Flat {
//!     fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
//!         match p {
//!             ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(DicingHint::Orthographic)),
//!             _ => None,
//!         }
//!     }
//!     fn project(&self, ctx: &mut ProjectionContext<'_>) {
//!         let c = ctx.parts_mut();
//!         for (ray, s) in c.rays.iter_mut().zip(c.screen) {
//!             *ray = RayGeometry {
//!                 origin: Vec3::new(s.x, s.y, 0.0),
//!                 origin_radius: self.origin_radius,
//!                 direction: Vec3::Z,
//!                 ray_spread: 0.0,
//!                 min_dist: self.clipping.0,
//!                 max_dist: self.clipping.1,
//!             };
//!         }
//!     }
//! }
//!
//! let opts = CheckOptions::default();
//! let env = opts.environment();
//! let flat = Flat {
//!     origin_radius: 0.01,
//!     clipping: (env.clipping_near(), env.clipping_far()),
//! };
//! let report = check_projection(&flat, &env, &opts);
//! assert!(report.is_clean(), "{report}");
//! ```
//!
//! # Using the checker in your plugin's tests
//!
//! Add `obscura-check` to your plugin crate's `[dev-dependencies]` and check your factory from an
//! ordinary `#[test]`. [`check_factory`] creates the projection with the parameters you give, in the
//! environment of the [`CheckOptions`], exactly as a host would; [`check_registered`] goes through a
//! [`Registry`] instead, so your factory's `init` runs first, as in a render.
//! Check each parameter set you ship (the defaults, depth of field, the extremes of each range), and
//! put the report in the assertion message: its text names the check that failed, the sample, what
//! the contract expected and what came back. A smaller format and fewer samples keep the test quick in
//! a debug build. A known limitation can be pinned instead of hidden, with
//! `assert_eq!(report.failed(), [CheckKind::FieldOfView])`.
//!
//! ```
//! use obscura_check::{CheckKind, CheckOptions, Status, check_factory};
//! use obscura_sdk::optics::PerspectiveRays;
//! use obscura_sdk::*;
//!
//! /// A 90° pinhole: the screen plane at distance 1.
//! struct Pinhole(PerspectiveRays);
//! # impl Projection for Pinhole {
//! #     fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
//! #         match p {
//! #             ProjectionProperty::FieldOfView => Some(PropertyValue::Float(90.0)),
//! #             _ => None,
//! #         }
//! #     }
//! #     fn project(&self, ctx: &mut ProjectionContext<'_>) {
//! #         let c = ctx.parts_mut();
//! #         for (ray, s) in c.rays.iter_mut().zip(c.screen) {
//! #             *ray = self.0.pinhole(*s, 1.0);
//! #         }
//! #     }
//! #     fn unproject(&self, p: Vec3, _time: f32) -> Option<Point2> {
//! #         (p.z > 0.0).then(|| Point2::new(p.x / p.z, p.y / p.z))
//! #     }
//! # }
//!
//! struct PinholeFactory;
//! impl ProjectionFactory for PinholeFactory {
//!     fn name(&self) -> &str {
//!         "MyPinhole"
//!     }
//!     fn summary(&self) -> &str {
//!         "a 90° pinhole"
//!     }
//!     fn param_table(&self) -> &[ParamDecl] {
//!         &[]
//!     }
//!     fn create_projection(
//!         &self,
//!         env: &mut ProjectionEnvironment,
//!         _params: &ParamList,
//!     ) -> Result<Box<dyn Projection>, PluginError> {
//!         let clipping = (env.clipping_near(), env.clipping_far());
//!         Ok(Box::new(Pinhole(PerspectiveRays::new(env.pixel_size(), clipping, 0.0, 1.0))))
//!     }
//! }
//!
//! // In your crate, a `#[test]` in `tests/contract.rs`:
//! fn my_pinhole_keeps_the_projection_contract() {
//!     let opts = CheckOptions {
//!         format: Format::new(48, 36),
//!         samples_per_pixel: 2,
//!         ..CheckOptions::default()
//!     };
//!     let report = check_factory(&PinholeFactory, &ParamList::new(), &opts).expect("defaults accepted");
//!     assert!(report.is_clean(), "{report}");
//!     // Clean is not enough when a check had nothing to look at: make sure the inverse was tested.
//!     assert_eq!(report.get(CheckKind::Unproject).status(), Status::Ok, "{report}");
//! }
//! # my_pinhole_keeps_the_projection_contract();
//! ```
//!
//! # What is checked, and exactly how
//!
//! The checker builds one set of samples over the screen window of the environment: the lens-centre,
//! time-0 *chief* sample at every pixel centre of the format plus a ring of [`CheckOptions::margin`]
//! pixels just outside the window, and [`CheckOptions::samples_per_pixel`] random samples in each of
//! those pixels (screen position uniform in the pixel, lens uniform in `[0, 1)²` warped to the unit
//! disk for `aperture`, time uniform in `[0, 1)`; the first random sample of each pixel keeps the lens
//! centre, so `unproject` is also tested at other times). The random numbers come from a SplitMix64
//! generator seeded with [`CheckOptions::seed`]: a report is reproducible. Every batch (of
//! [`CheckOptions::batch_size`] samples) arrives pre-filled as from a host: the default rays of the
//! answered properties (a host's rule, see `docs/decisions.md`) and white tints.
//!
//! | check | fails when |
//! |---|---|
//! | [`CheckKind::Panic`] | `project`, `property` or `unproject` panics (caught; the batch counts as lost) |
//! | [`CheckKind::Error`] | `project` reports an error (a C plugin's `OBSCURA_ERROR`; the batch counts as lost) |
//! | [`CheckKind::DirectionFinite`] | a direction component is NaN or infinite |
//! | [`CheckKind::DirectionUnit`] | a finite direction is not exactly zero and `|‖D‖ − 1| > 10⁻³` ([`obscura_sdk::contract::UNIT_TOLERANCE`]) |
//! | [`CheckKind::OriginFinite`] | an origin component is NaN or infinite |
//! | [`CheckKind::TimeRange`] | an output time is outside `[0, 1)` |
//! | [`CheckKind::RadiusSpread`] | `origin_radius` or `ray_spread` is negative or not finite |
//! | [`CheckKind::Distances`] | not `0 ≤ min_dist ≤ max_dist` (NaN included) |
//! | [`CheckKind::TintFinite`] | a tint channel is not finite |
//! | [`CheckKind::Clipping`] | `min_dist`/`max_dist` are not where the ray meets the environment's clipping planes (DeepMetric CameraZ) or spheres (RayLength), within a relative `10⁻³` ([`obscura_sdk::contract::clipping_distances`]) |
//! | [`CheckKind::RaySpread`] | a chief ray's `ray_spread` is more than 25 % off `½·sqrt(αx·αy)`, with `αx`, `αy` the measured angles between the chief rays of neighbouring pixel centres (central differences) |
//! | [`CheckKind::FieldOfView`] | the FieldOfView property disagrees with the measured angular extent by more than `max(2 %, 0.5°)` |
//! | [`CheckKind::DeepMetric`] | the deep metric is CameraZ (the property, else the environment's) while a ray has `D.z < 0` |
//! | [`CheckKind::DicingHint`] | DicingHint Perspective while the chief rays do not share an origin; Orthographic while their directions differ |
//! | [`CheckKind::Unproject`] | `unproject(O + D·t)` of a lens-centre ray misses its screen sample by more than 10⁻³ pixel, or is `None` |
//! | [`CheckKind::Determinism`] | the same batches, run twice in order, give outputs that differ in any bit |
//! | [`CheckKind::Threads`] | the same batches, run on several threads at once, give outputs that differ in any bit from the sequential run |
//! | [`CheckKind::PropertyType`] | a property is answered with a value of another property's type, or an FStop, FocalLength or FocalDistance that is NaN, zero or negative (or an infinite focal length) |
//!
//! A ray that breaks several per-ray rules counts once, under the first in the table's order (a NaN
//! direction is not also a non-unit one): [`obscura_sdk::contract::check_ray`], the host's own rule.
//! Only rays that pass every per-ray check (and are not culled) enter the geometric checks (clipping,
//! spread, field of view, deep metric, dicing hint, unproject), so one fault is reported once, by its
//! own check; the clipping check leaves out CameraZ rays toward −Z, which the deep-metric check
//! reports.
//!
//! **Ray spread.** The footprint cone is one pixel across (`docs/decisions.md`), so `ray_spread` should
//! be *half* the per-pixel angle. `αx` at a pixel is the mean angle between its chief ray and those of
//! its left and right neighbours (`αy`: above and below). A neighbour pair is left out when either ray
//! is culled or invalid, or when the pair's angle exceeds [`CheckOptions::discontinuity_ratio`] (20)
//! times the median angle of the same axis's pairs within two pixels: the pair straddles a
//! discontinuity (a seam). A pixel is skipped, and the report says how many and why, when on either
//! axis one of its two pairs is left out (a culled neighbour beyond a fisheye's circle, a seam) or the
//! two pairs' angles differ by more than [`CheckOptions::curvature_ratio`] (1.25): there the angle
//! changes too fast from pixel to pixel (a mirror ball's singular rim, an octahedral fold) for a
//! finite difference to say what the spread at the pixel should be.
//!
//! **Field of view.** Measured on lens-centre rays at times 0, ¼, ½, ¾ and just under 1, so a zoom
//! passes with any value its field of view takes during the shutter. With DicingHint Perspective (or no
//! hint, which a host reads as Perspective) five extents are measured: the angle between the rays at
//! screen `(−1, 0)` and `(1, 0)` (how `PxrPerspective` defines fov: across the `[−1, 1]` square, the
//! smaller image side with the default window), between `(0, −1)` and `(0, 1)`, between the midpoints
//! of the window's left and right edges, of its bottom and top edges, and between its bottom-left and
//! top-right corners. With DicingHint Spherical three: twice the largest angle from the ray at the
//! window's centre to any ray of a half-pixel grid over the window (edges included), over its
//! horizontal midline, and over its vertical midline; and, because a host dices a Spherical camera at
//! `2s/fov` pixels per radian (`s` pixels per screen unit, `docs/decisions.md`), four angular rates
//! written as a field of view, `2s·α` with `α` the per-pixel angle measured by the spread check (the
//! finer of `αx`, `αy`): the finest in the window, the finest along the horizontal midline, the finest
//! along the vertical midline, and at the window's centre (these four at time 0 only). A projection may
//! thus report its extent or the rate it wants to be diced at. The property passes when it is within
//! `max(2 %, 0.5°)` of any measure at any of those times, or between a measure's smallest and largest
//! value over the shutter. An Orthographic camera has no field of view: an answer is noted, not checked.
//!
//! **Unproject.** For every valid lens-centre ray inside the window (the chief rays and the first
//! random sample of each pixel), the points `O + D·t` at `t = 1` and `t = 10` (or `2·min_dist` and
//! `20·min_dist` when `min_dist > ½`) are unprojected at the ray's output time, and the distance to the
//! screen sample is measured in pixels. A projection whose `unproject` answers `None` everywhere does
//! not offer the inverse: that is reported as "not offered", not as a failure.
//!
//! **Threads.** [`CheckOptions::threads`] threads (spawned with `std::thread::scope`) each run every
//! batch, starting at different batches, while the others do the same. Samples whose two sequential
//! runs already differ are left out (the determinism check reports them).
//!
//! Panics are caught with `catch_unwind`; the default panic hook still prints each one to stderr (the
//! `obscura check` command silences it while checking).

#![forbid(unsafe_code)]

mod checks;
mod json;
mod options;
mod report;
mod run;
#[cfg(test)]
mod tests;

use std::panic::{AssertUnwindSafe, catch_unwind};

use obscura_host::Registry;
use obscura_host::contract::panic_message;
use obscura_sdk::{ParamList, PluginError, Projection, ProjectionEnvironment, ProjectionFactory};

pub use options::CheckOptions;
pub use report::{Case, CheckKind, CheckReport, CheckResult, Sample, Status};

use checks::Checker;

/// Creates a projection with `factory` in the environment of `opts` and checks it.
///
/// The factory's `init` is not called (it needs `&mut`); use [`check_registered`] to go through a
/// registry's lifecycle. A panic in `create_projection` is caught and reported as a
/// [`CheckKind::Panic`] failure, with every other check not run.
///
/// # Errors
/// The factory's own [`PluginError`] when it refuses the parameters.
pub fn check_factory(
    factory: &dyn ProjectionFactory,
    params: &ParamList,
    opts: &CheckOptions,
) -> Result<CheckReport, PluginError> {
    let mut env = opts.environment();
    let created = catch_unwind(AssertUnwindSafe(|| factory.create_projection(&mut env, params)));
    finish_creation(factory.name(), created, &env, opts)
}

/// Creates the projection `name` from `registry` (initialising its factory on first use, as a render
/// does) in the environment of `opts`, and checks it. A panic in `init` or `create_projection` is
/// caught and reported as a [`CheckKind::Panic`] failure.
///
/// # Errors
/// An unknown name, or the factory's refusal of the parameters or of `init`.
pub fn check_registered(
    registry: &mut Registry,
    name: &str,
    params: &ParamList,
    opts: &CheckOptions,
) -> Result<CheckReport, PluginError> {
    let mut env = opts.environment();
    let created = catch_unwind(AssertUnwindSafe(|| registry.create(name, &mut env, params)));
    finish_creation(name, created, &env, opts)
}

type Created = std::thread::Result<Result<Box<dyn Projection>, PluginError>>;

fn finish_creation(
    name: &str,
    created: Created,
    env: &ProjectionEnvironment,
    opts: &CheckOptions,
) -> Result<CheckReport, PluginError> {
    match created {
        Ok(Ok(p)) => {
            let mut report = check_projection(p.as_ref(), env, opts);
            report.projection = name.to_string();
            Ok(report)
        }
        Ok(Err(e)) => Err(e),
        Err(payload) => {
            let msg = panic_message(payload.as_ref());
            let mut report = CheckReport::empty(name, env, opts);
            for c in &mut report.checks {
                c.notes.push("not run: creating the projection panicked".into());
            }
            let panic = report.at(CheckKind::Panic);
            panic.notes.clear();
            panic.examined = 1;
            panic.fail(f64::INFINITY, || Case {
                sample: None,
                what: "create_projection".into(),
                expected: "a projection or an error".into(),
                got: format!("panicked: {msg}"),
                severity: 0.0,
            });
            Ok(report)
        }
    }
}

/// Checks an already-created projection against `env` (the environment it was created with; its format
/// and screen window are sampled) with the sampling and tolerances of `opts`.
#[must_use]
pub fn check_projection(
    projection: &dyn Projection,
    env: &ProjectionEnvironment,
    opts: &CheckOptions,
) -> CheckReport {
    Checker::new(projection, env, opts).run()
}
