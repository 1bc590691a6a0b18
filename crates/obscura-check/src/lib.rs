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
//! /// Parallel rays down +Z from the screen point: an orthographic camera.
//! struct Flat(f32);
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
//!                 origin_radius: self.0,
//!                 direction: Vec3::Z,
//!                 ray_spread: 0.0,
//!                 min_dist: 0.0,
//!                 max_dist: f32::INFINITY,
//!             };
//!         }
//!     }
//! }
//!
//! let opts = CheckOptions::default();
//! let env = opts.environment();
//! let report = check_projection(&Flat(0.01), &env, &opts);
//! assert!(report.is_clean(), "{report}");
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

use std::fmt::{self, Write as _};
use std::panic::{AssertUnwindSafe, catch_unwind};

use obscura_sdk::contract::{
    self, DefaultRays, Loss, Properties, PropertyProblem, Violation, call_project, clipping_distances,
    panic_message,
};
use obscura_sdk::{
    DeepMetric, DicingHint, Format, ParamList, PluginError, Point2, Projection, ProjectionContext,
    ProjectionEnvironment, ProjectionFactory, ProjectionProperty, PropertyValue, RayGeometry, Registry, Rgb,
    ScreenWindow, Vec3,
};

/// How thoroughly, and against which camera, to check a projection.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckOptions {
    /// Image size and pixel aspect of the environment [`check_factory`] creates the projection with
    /// (default 96 × 72, square pixels).
    pub format: Format,
    /// The screen window; `None` for the default of the format.
    pub screen_window: Option<ScreenWindow>,
    /// Shutter open and close, scene time (default (0, 1)).
    pub shutter: (f32, f32),
    /// Clipping near and far (default (0.1, ∞), RenderMan's).
    pub clipping: (f32, f32),
    /// Random lens and time samples per pixel, besides the chief sample (default 4).
    pub samples_per_pixel: u32,
    /// Seed of the random samples (default 0).
    pub seed: u64,
    /// Threads for the concurrency check (default 4; at least 1 is used).
    pub threads: usize,
    /// Samples per `project` call (default 256; at least 1 is used).
    pub batch_size: usize,
    /// Pixels of margin sampled outside the window on every side (default 1).
    pub margin: u32,
    /// `|‖D‖ − 1|` allowed for a unit direction (default 10⁻³, the host's).
    pub unit_tolerance: f32,
    /// Relative error allowed in `ray_spread` (default 0.25).
    pub spread_tolerance: f64,
    /// A neighbour angle this many times the local median is a discontinuity (default 20).
    pub discontinuity_ratio: f64,
    /// A pixel whose neighbour angles on the two sides of one axis differ by more than this factor is
    /// too curved for the spread check and skipped (default 1.25).
    pub curvature_ratio: f64,
    /// Relative error allowed in the FieldOfView property (default 0.02) …
    pub fov_tolerance: f64,
    /// … or this many degrees, whichever is larger (default 0.5).
    pub fov_tolerance_degrees: f64,
    /// Distance between chief-ray origins that still counts as one origin, relative to
    /// `max(1, |origin|)` (default 10⁻⁴).
    pub origin_tolerance: f64,
    /// Angle in radians between chief-ray directions that still counts as parallel (default 10⁻⁴).
    pub direction_tolerance: f64,
    /// Error in pixels allowed in `unproject(project(s))` (default 10⁻³).
    pub unproject_tolerance: f64,
    /// Relative error allowed in a ray's clipping distances (default 10⁻³).
    pub clipping_tolerance: f64,
}

impl Default for CheckOptions {
    fn default() -> Self {
        CheckOptions {
            format: Format::new(96, 72),
            screen_window: None,
            shutter: (0.0, 1.0),
            clipping: (0.1, f32::INFINITY),
            samples_per_pixel: 4,
            seed: 0,
            threads: 4,
            batch_size: 256,
            margin: 1,
            unit_tolerance: contract::UNIT_TOLERANCE,
            spread_tolerance: 0.25,
            discontinuity_ratio: 20.0,
            curvature_ratio: 1.25,
            fov_tolerance: 0.02,
            fov_tolerance_degrees: 0.5,
            origin_tolerance: 1e-4,
            direction_tolerance: 1e-4,
            unproject_tolerance: 1e-3,
            clipping_tolerance: 1e-3,
        }
    }
}

impl CheckOptions {
    /// The environment these options describe: format, screen window (the format's default when
    /// `None`), shutter, clipping, an identity camera.
    #[must_use]
    pub fn environment(&self) -> ProjectionEnvironment {
        let format = Format {
            width: self.format.width.max(1),
            height: self.format.height.max(1),
            pixel_aspect: self.format.pixel_aspect,
        };
        ProjectionEnvironment::new(
            format,
            self.screen_window
                .unwrap_or_else(|| ScreenWindow::default_for(format)),
            self.shutter,
            self.clipping,
            Vec::new(),
        )
    }
}

/// One kind of contract check. The report holds one [`CheckResult`] per kind, in [`CheckKind::ALL`]
/// order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CheckKind {
    /// `project`, `property` or `unproject` panicked.
    Panic,
    /// `project` reported an error (a C plugin's `OBSCURA_ERROR`).
    Error,
    /// A direction component is NaN or infinite.
    DirectionFinite,
    /// A direction is neither unit length nor exactly zero.
    DirectionUnit,
    /// An origin component is NaN or infinite.
    OriginFinite,
    /// An output time is outside `[0, 1)`.
    TimeRange,
    /// `origin_radius` or `ray_spread` is negative or not finite.
    RadiusSpread,
    /// Not `0 ≤ min_dist ≤ max_dist`.
    Distances,
    /// A tint channel is not finite.
    TintFinite,
    /// `min_dist`/`max_dist` do not put the environment's clipping range on the ray.
    Clipping,
    /// `ray_spread` is more than the tolerance off half the measured neighbour angle.
    RaySpread,
    /// The FieldOfView property disagrees with the measured angular extent.
    FieldOfView,
    /// DeepMetric CameraZ while some rays point to −Z.
    DeepMetric,
    /// The rays do not fit the dicing hint (Perspective: one origin; Orthographic: one direction).
    DicingHint,
    /// `unproject` does not invert `project`.
    Unproject,
    /// The same inputs gave different outputs.
    Determinism,
    /// The same batches gave different outputs on several threads at once.
    Threads,
    /// A property answered with a value of the wrong type.
    PropertyType,
}

impl CheckKind {
    /// Every check, in report order.
    pub const ALL: [CheckKind; 18] = [
        CheckKind::Panic,
        CheckKind::Error,
        CheckKind::DirectionFinite,
        CheckKind::DirectionUnit,
        CheckKind::OriginFinite,
        CheckKind::TimeRange,
        CheckKind::RadiusSpread,
        CheckKind::Distances,
        CheckKind::TintFinite,
        CheckKind::Clipping,
        CheckKind::RaySpread,
        CheckKind::FieldOfView,
        CheckKind::DeepMetric,
        CheckKind::DicingHint,
        CheckKind::Unproject,
        CheckKind::Determinism,
        CheckKind::Threads,
        CheckKind::PropertyType,
    ];

    /// The machine-readable name used in the JSON output, e.g. `ray_spread`.
    #[must_use]
    pub fn id(self) -> &'static str {
        match self {
            CheckKind::Panic => "panic",
            CheckKind::Error => "error",
            CheckKind::DirectionFinite => "direction_finite",
            CheckKind::DirectionUnit => "direction_unit",
            CheckKind::OriginFinite => "origin_finite",
            CheckKind::TimeRange => "time_range",
            CheckKind::RadiusSpread => "radius_spread",
            CheckKind::Distances => "distances",
            CheckKind::TintFinite => "tint_finite",
            CheckKind::Clipping => "clipping",
            CheckKind::RaySpread => "ray_spread",
            CheckKind::FieldOfView => "field_of_view",
            CheckKind::DeepMetric => "deep_metric",
            CheckKind::DicingHint => "dicing_hint",
            CheckKind::Unproject => "unproject",
            CheckKind::Determinism => "determinism",
            CheckKind::Threads => "threads",
            CheckKind::PropertyType => "property_type",
        }
    }

    /// What the check promises, for people.
    #[must_use]
    pub fn title(self) -> &'static str {
        match self {
            CheckKind::Panic => "no panics in project, property or unproject",
            CheckKind::Error => "no errors returned by project",
            CheckKind::DirectionFinite => "finite directions",
            CheckKind::DirectionUnit => "unit (or exactly zero) directions",
            CheckKind::OriginFinite => "finite origins",
            CheckKind::TimeRange => "times in [0, 1)",
            CheckKind::RadiusSpread => "origin_radius and ray_spread finite and >= 0",
            CheckKind::Distances => "0 <= min_dist <= max_dist",
            CheckKind::TintFinite => "finite tints",
            CheckKind::Clipping => {
                "min_dist/max_dist at the clipping planes (CameraZ) or spheres (RayLength)"
            }
            CheckKind::RaySpread => "ray_spread is half the angle between neighbouring pixels",
            CheckKind::FieldOfView => "FieldOfView matches the measured extent",
            CheckKind::DeepMetric => "DeepMetric CameraZ only with rays toward +Z",
            CheckKind::DicingHint => "rays fit the DicingHint",
            CheckKind::Unproject => "unproject inverts project",
            CheckKind::Determinism => "same inputs, same outputs",
            CheckKind::Threads => "same outputs on several threads at once",
            CheckKind::PropertyType => "property values of the right type and range",
        }
    }

    /// What [`CheckResult::examined`] counts for this check.
    #[must_use]
    pub fn unit(self) -> &'static str {
        match self {
            CheckKind::Panic | CheckKind::Error => "calls",
            CheckKind::RaySpread => "pixels",
            CheckKind::FieldOfView | CheckKind::PropertyType => "properties",
            CheckKind::Unproject => "points",
            CheckKind::DicingHint => "chief rays",
            _ => "rays",
        }
    }

    fn index(self) -> usize {
        self as usize
    }

    /// The check that reports a contract [`Violation`].
    #[must_use]
    pub fn of(v: Violation) -> CheckKind {
        match v {
            Violation::Panicked => CheckKind::Panic,
            Violation::Failed => CheckKind::Error,
            Violation::NonFiniteDirection => CheckKind::DirectionFinite,
            Violation::NonUnitDirection => CheckKind::DirectionUnit,
            Violation::NonFiniteOrigin => CheckKind::OriginFinite,
            Violation::TimeOutOfRange => CheckKind::TimeRange,
            Violation::BadOriginRadius | Violation::BadRaySpread => CheckKind::RadiusSpread,
            Violation::BadDistances => CheckKind::Distances,
            Violation::NonFiniteTint => CheckKind::TintFinite,
        }
    }
}

/// The inputs of one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Screen position.
    pub screen: Point2,
    /// Canonical lens sample in `[0, 1)²` (`(0.5, 0.5)` is the lens centre).
    pub lens: Point2,
    /// The time handed to `project`.
    pub time: f32,
}

/// The worst failure of one check.
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    /// The sample at fault, when the failure belongs to one.
    pub sample: Option<Sample>,
    /// Which value is wrong (`|direction|`, `ray_spread`, `k_FieldOfView`, …).
    pub what: String,
    /// What the contract expects.
    pub expected: String,
    /// What the projection gave.
    pub got: String,
    /// How bad it is, in the check's own measure (the larger, the worse; ∞ for NaN and panics).
    pub severity: f64,
}

/// The outcome of one check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Examined something and found no failure.
    Ok,
    /// At least one failure.
    Failed,
    /// Nothing to examine (not offered, not applicable, or everything culled); see the notes.
    NotChecked,
}

/// One check's counts, worst case and notes.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckResult {
    /// Which check.
    pub kind: CheckKind,
    /// How many items were examined (rays, pixels, calls, …: see [`CheckKind::unit`]).
    pub examined: u64,
    /// How many of them failed.
    pub failures: u64,
    /// Items left out on purpose (a culled neighbour, a discontinuity, …), explained in `notes`.
    pub skipped: u64,
    /// The worst failure.
    pub worst: Option<Case>,
    /// What was not checked and why, and other remarks.
    pub notes: Vec<String>,
}

impl CheckResult {
    fn new(kind: CheckKind) -> Self {
        CheckResult {
            kind,
            examined: 0,
            failures: 0,
            skipped: 0,
            worst: None,
            notes: Vec::new(),
        }
    }

    /// Ok, Failed, or NotChecked.
    #[must_use]
    pub fn status(&self) -> Status {
        if self.failures > 0 {
            Status::Failed
        } else if self.examined == 0 {
            Status::NotChecked
        } else {
            Status::Ok
        }
    }

    /// Counts one failure; `make` builds the case only when it is the worst so far.
    fn fail(&mut self, severity: f64, make: impl FnOnce() -> Case) {
        self.failures += 1;
        let severity = if severity.is_nan() {
            f64::INFINITY
        } else {
            severity
        };
        if self.worst.as_ref().is_none_or(|w| severity > w.severity) {
            self.worst = Some(Case { severity, ..make() });
        }
    }
}

/// Everything `obscura check` found: one [`CheckResult`] per [`CheckKind`], plus what was checked.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckReport {
    /// The projection's name (empty when checked without one).
    pub projection: String,
    /// The format sampled.
    pub format: Format,
    /// The screen window sampled.
    pub screen_window: ScreenWindow,
    /// Pixels of margin sampled outside the window.
    pub margin: u32,
    /// Random samples per pixel.
    pub samples_per_pixel: u32,
    /// Seed of the random samples.
    pub seed: u64,
    /// Threads of the concurrency check.
    pub threads: usize,
    /// Samples in one run over the window.
    pub samples: u64,
    /// Of those, valid rays the projection culled (zero direction) in the first run.
    pub culled: u64,
    /// The answer to every property (`None`: not answered, or the query panicked).
    pub properties: Vec<(ProjectionProperty, Option<PropertyValue>)>,
    /// The dicing hint in force (the answer when of the right type, else Perspective, as a host reads it).
    pub dicing_hint: DicingHint,
    /// The deep metric in force (the answer when of the right type, else the environment's).
    pub deep_metric: DeepMetric,
    /// One result per check, in [`CheckKind::ALL`] order.
    pub checks: Vec<CheckResult>,
}

impl CheckReport {
    fn empty(projection: &str, env: &ProjectionEnvironment, opts: &CheckOptions) -> Self {
        CheckReport {
            projection: projection.to_string(),
            format: env.format(),
            screen_window: env.screen_window(),
            margin: opts.margin,
            samples_per_pixel: opts.samples_per_pixel,
            seed: opts.seed,
            threads: opts.threads.max(1),
            samples: 0,
            culled: 0,
            properties: Vec::new(),
            dicing_hint: DicingHint::Perspective,
            deep_metric: env.deep_metric(),
            checks: CheckKind::ALL.iter().map(|&k| CheckResult::new(k)).collect(),
        }
    }

    /// True when no check failed.
    #[must_use]
    pub fn is_clean(&self) -> bool {
        self.checks.iter().all(|c| c.failures == 0)
    }

    /// The result of one check.
    #[must_use]
    pub fn get(&self, kind: CheckKind) -> &CheckResult {
        &self.checks[kind.index()]
    }

    fn at(&mut self, kind: CheckKind) -> &mut CheckResult {
        &mut self.checks[kind.index()]
    }

    /// The Panic and Error results, where a lost `project` batch is recorded.
    fn lost(&mut self) -> &mut [CheckResult; 2] {
        (&mut self.checks[CheckKind::Panic.index()..=CheckKind::Error.index()])
            .try_into()
            .expect("Panic and Error are the first two checks")
    }

    /// The checks that failed, in report order.
    #[must_use]
    pub fn failed(&self) -> Vec<CheckKind> {
        self.checks
            .iter()
            .filter(|c| c.failures > 0)
            .map(|c| c.kind)
            .collect()
    }

    /// The same content as the [`Display`](fmt::Display) form, as one JSON object:
    ///
    /// `{"projection", "clean", "format": {"width", "height", "pixel_aspect"}, "screen_window": [l, r,
    /// b, t], "margin", "samples_per_pixel", "seed", "threads", "samples", "culled", "properties":
    /// {"k_DicingHint": "Perspective" | number | null, …}, "dicing_hint", "deep_metric", "checks": [{"check",
    /// "title", "status": "ok" | "failed" | "not_checked", "unit", "examined", "failures", "skipped",
    /// "notes": [..], "worst": null | {"screen": [x, y] | null, "lens", "time", "what", "expected",
    /// "got", "severity"}}]}`. Non-finite numbers are written as `null`.
    #[must_use]
    pub fn to_json(&self) -> String {
        let mut j = String::with_capacity(4096);
        j.push('{');
        j.push_str("\"projection\":");
        json_str(&mut j, &self.projection);
        let _ = write!(j, ",\"clean\":{}", self.is_clean());
        let _ = write!(
            j,
            ",\"format\":{{\"width\":{},\"height\":{},\"pixel_aspect\":{}}}",
            self.format.width,
            self.format.height,
            json_num(f64::from(self.format.pixel_aspect))
        );
        let w = self.screen_window;
        let _ = write!(
            j,
            ",\"screen_window\":[{},{},{},{}]",
            json_f32(w.left),
            json_f32(w.right),
            json_f32(w.bottom),
            json_f32(w.top)
        );
        let _ = write!(
            j,
            ",\"margin\":{},\"samples_per_pixel\":{},\"seed\":{},\"threads\":{},\"samples\":{},\"culled\":{}",
            self.margin, self.samples_per_pixel, self.seed, self.threads, self.samples, self.culled
        );
        j.push_str(",\"properties\":{");
        for (i, (p, v)) in self.properties.iter().enumerate() {
            if i > 0 {
                j.push(',');
            }
            json_str(&mut j, p.renderman_name());
            j.push(':');
            match v {
                None => j.push_str("null"),
                Some(PropertyValue::Float(x)) => j.push_str(&json_f32(*x)),
                Some(other) => json_str(&mut j, &value_text(*other)),
            }
        }
        j.push('}');
        j.push_str(",\"dicing_hint\":");
        json_str(&mut j, &format!("{:?}", self.dicing_hint));
        j.push_str(",\"deep_metric\":");
        json_str(&mut j, &format!("{:?}", self.deep_metric));
        j.push_str(",\"checks\":[");
        for (i, c) in self.checks.iter().enumerate() {
            if i > 0 {
                j.push(',');
            }
            j.push_str("{\"check\":");
            json_str(&mut j, c.kind.id());
            j.push_str(",\"title\":");
            json_str(&mut j, c.kind.title());
            let status = match c.status() {
                Status::Ok => "ok",
                Status::Failed => "failed",
                Status::NotChecked => "not_checked",
            };
            let _ = write!(j, ",\"status\":\"{status}\",\"unit\":");
            json_str(&mut j, c.kind.unit());
            let _ = write!(
                j,
                ",\"examined\":{},\"failures\":{},\"skipped\":{},\"notes\":[",
                c.examined, c.failures, c.skipped
            );
            for (k, n) in c.notes.iter().enumerate() {
                if k > 0 {
                    j.push(',');
                }
                json_str(&mut j, n);
            }
            j.push_str("],\"worst\":");
            match &c.worst {
                None => j.push_str("null"),
                Some(w) => {
                    j.push('{');
                    match w.sample {
                        None => j.push_str("\"screen\":null,\"lens\":null,\"time\":null"),
                        Some(s) => {
                            let _ = write!(
                                j,
                                "\"screen\":[{},{}],\"lens\":[{},{}],\"time\":{}",
                                json_f32(s.screen.x),
                                json_f32(s.screen.y),
                                json_f32(s.lens.x),
                                json_f32(s.lens.y),
                                json_f32(s.time)
                            );
                        }
                    }
                    j.push_str(",\"what\":");
                    json_str(&mut j, &w.what);
                    j.push_str(",\"expected\":");
                    json_str(&mut j, &w.expected);
                    j.push_str(",\"got\":");
                    json_str(&mut j, &w.got);
                    let _ = write!(j, ",\"severity\":{}}}", json_num(w.severity));
                }
            }
            j.push('}');
        }
        j.push_str("]}");
        j
    }
}

impl fmt::Display for CheckReport {
    /// One header line, one line of properties, one line per check (`ok`, `FAILED n of m … worst: …`,
    /// `not checked`), and a verdict.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let w = self.screen_window;
        let name = if self.projection.is_empty() {
            "projection"
        } else {
            &self.projection
        };
        writeln!(
            f,
            "obscura check {name}: {}x{} pixels (pixel aspect {}), screen window [{}, {}] x [{}, {}] and a \
             {}-pixel margin, {} random lens/time samples per pixel (seed {}), {} threads: {} samples, {} culled",
            self.format.width,
            self.format.height,
            self.format.pixel_aspect,
            w.left,
            w.right,
            w.bottom,
            w.top,
            self.margin,
            self.samples_per_pixel,
            self.seed,
            self.threads,
            self.samples,
            self.culled
        )?;
        let props: Vec<String> = self
            .properties
            .iter()
            .map(|(p, v)| {
                format!(
                    "{} {}",
                    p.renderman_name(),
                    v.map_or_else(|| "-".to_string(), value_text)
                )
            })
            .collect();
        writeln!(f, "properties: {}", props.join(", "))?;
        for c in &self.checks {
            let (label, counts) = match c.status() {
                Status::Ok => ("ok", count(c.examined, c.kind.unit())),
                Status::Failed => (
                    "FAILED",
                    format!("{} of {}", c.failures, count(c.examined, c.kind.unit())),
                ),
                Status::NotChecked => ("not checked", String::new()),
            };
            write!(f, "{label:<12} {}", c.kind.title())?;
            if !counts.is_empty() {
                write!(f, ": {counts}")?;
            }
            if !c.notes.is_empty() {
                write!(
                    f,
                    "{}{}",
                    if counts.is_empty() { ": " } else { "; " },
                    c.notes.join("; ")
                )?;
            }
            if let Some(case) = &c.worst {
                write!(f, "; worst")?;
                if let Some(s) = case.sample {
                    write!(
                        f,
                        " at screen ({}, {}), lens ({}, {}), time {}",
                        s.screen.x, s.screen.y, s.lens.x, s.lens.y, s.time
                    )?;
                }
                write!(f, ": {}: expected {}, got {}", case.what, case.expected, case.got)?;
            }
            writeln!(f)?;
        }
        let failed = self.failed();
        if failed.is_empty() {
            write!(f, "clean: no check failed")
        } else {
            let names: Vec<&str> = failed.iter().map(|k| k.id()).collect();
            write!(
                f,
                "FAILED: {} of {} checks ({})",
                failed.len(),
                self.checks.len(),
                names.join(", ")
            )
        }
    }
}

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

// ---------------------------------------------------------------------------------------------------
// Sampling and running batches.

/// SplitMix64 (Steele, Lea, Flood 2014): tiny, fast, and the same on every platform.
#[derive(Debug, Clone)]
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`: the top 24 bits, exactly representable.
    fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / 16_777_216.0)
    }
}

/// Shirley and Chiu's concentric map of `[0, 1)²` onto the unit disk (the host's circular aperture).
fn concentric_disk(u: Point2) -> Point2 {
    let (a, b) = (2.0 * u.x - 1.0, 2.0 * u.y - 1.0);
    if a == 0.0 && b == 0.0 {
        return Point2::ZERO;
    }
    let quarter = std::f32::consts::FRAC_PI_4;
    let (r, phi) = if a.abs() > b.abs() {
        (a, quarter * (b / a))
    } else {
        (b, 2.0 * quarter - quarter * (a / b))
    };
    Point2::new(r * phi.cos(), r * phi.sin())
}

#[derive(Debug, Clone, Copy)]
struct Input {
    screen: Point2,
    lens: Point2,
    aperture: Point2,
    time: f32,
}

impl Input {
    fn chief(screen: Point2, time: f32) -> Self {
        Input {
            screen,
            lens: Point2::new(0.5, 0.5),
            aperture: Point2::ZERO,
            time,
        }
    }

    fn sample(&self) -> Sample {
        Sample {
            screen: self.screen,
            lens: self.lens,
            time: self.time,
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Output {
    ray: RayGeometry,
    time: f32,
    tint: Rgb,
}

const FIELDS: [&str; 14] = [
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

impl Output {
    fn values(&self) -> [f32; 14] {
        let r = &self.ray;
        [
            r.origin.x,
            r.origin.y,
            r.origin.z,
            r.origin_radius,
            r.direction.x,
            r.direction.y,
            r.direction.z,
            r.ray_spread,
            r.min_dist,
            r.max_dist,
            self.time,
            self.tint.r,
            self.tint.g,
            self.tint.b,
        ]
    }

    /// `None` when bit-identical, else (first differing field, largest difference).
    fn differs(&self, other: &Output) -> Option<(usize, f64)> {
        let (a, b) = (self.values(), other.values());
        let mut first = None;
        let mut worst = 0.0f64;
        for i in 0..a.len() {
            if a[i].to_bits() != b[i].to_bits() {
                first.get_or_insert(i);
                let d = (f64::from(a[i]) - f64::from(b[i])).abs();
                worst = worst.max(if d.is_nan() { f64::INFINITY } else { d });
            }
        }
        first.map(|f| (f, worst))
    }

    /// The first per-ray contract breach, if any: the host's own rule.
    fn breach(&self, unit_tolerance: f32) -> Option<contract::Breach> {
        contract::check_ray_with(&self.ray, self.time, self.tint, unit_tolerance)
    }
}

/// One run over all batches: the outputs (`None` for samples of a lost batch) and the losses as
/// (first sample of the batch, why).
struct Run {
    outputs: Vec<Option<Output>>,
    losses: Vec<(usize, Loss)>,
    calls: u64,
}

struct Runner<'a> {
    projection: &'a dyn Projection,
    prefill: DefaultRays,
    batch_size: usize,
}

impl Runner<'_> {
    /// Projects one batch; `Err` when `project` panicked or reported an error.
    fn project(&self, inputs: &[Input]) -> Result<Vec<Output>, Loss> {
        let screen: Vec<Point2> = inputs.iter().map(|i| i.screen).collect();
        let lens: Vec<Point2> = inputs.iter().map(|i| i.lens).collect();
        let aperture: Vec<Point2> = inputs.iter().map(|i| i.aperture).collect();
        let mut time: Vec<f32> = inputs.iter().map(|i| i.time).collect();
        let mut rays: Vec<RayGeometry> = inputs
            .iter()
            .map(|i| self.prefill.ray(i.screen, i.aperture))
            .collect();
        let mut tint = vec![Rgb::WHITE; inputs.len()];
        let mut ctx = ProjectionContext::new(&screen, &lens, &aperture, &mut time, &mut rays, &mut tint)
            .expect("the batch's arrays are made alike just above");
        call_project(self.projection, &mut ctx)?;
        Ok(rays
            .into_iter()
            .zip(time)
            .zip(tint)
            .map(|((ray, time), tint)| Output { ray, time, tint })
            .collect())
    }

    /// Every batch of `inputs` once, starting with batch `start` and wrapping around.
    fn run_all(&self, inputs: &[Input], start: usize) -> Run {
        let n_batches = inputs.len().div_ceil(self.batch_size);
        let mut run = Run {
            outputs: vec![None; inputs.len()],
            losses: Vec::new(),
            calls: 0,
        };
        for k in 0..n_batches {
            let b = (start + k) % n_batches;
            let lo = b * self.batch_size;
            let hi = (lo + self.batch_size).min(inputs.len());
            run.calls += 1;
            match self.project(&inputs[lo..hi]) {
                Ok(out) => {
                    for (slot, o) in run.outputs[lo..hi].iter_mut().zip(out) {
                        *slot = Some(o);
                    }
                }
                Err(loss) => run.losses.push((lo, loss)),
            }
        }
        run
    }

    /// Lens-centre rays through `points` at time `t`: the valid, non-culled directions. A lost batch is
    /// recorded in `lost` (the report's Panic and Error results).
    fn directions(
        &self,
        points: &[Point2],
        t: f32,
        lost: &mut [CheckResult; 2],
        unit: f32,
    ) -> Vec<Option<Vec3>> {
        let inputs: Vec<Input> = points.iter().map(|&s| Input::chief(s, t)).collect();
        let mut out = vec![None; points.len()];
        for (chunk, slots) in inputs
            .chunks(self.batch_size)
            .zip(out.chunks_mut(self.batch_size))
        {
            lost[0].examined += 1;
            lost[1].examined += 1;
            match self.project(chunk) {
                Ok(rays) => {
                    for (slot, o) in slots.iter_mut().zip(rays) {
                        if o.breach(unit).is_none() && !o.ray.is_culled() {
                            *slot = Some(o.ray.direction);
                        }
                    }
                }
                Err(loss) => record_loss(lost, Some(chunk[0].sample()), &loss),
            }
        }
        out
    }
}

/// Records a lost `project` batch under Panic (`lost[0]`) or Error (`lost[1]`).
fn record_loss(lost: &mut [CheckResult; 2], sample: Option<Sample>, loss: &Loss) {
    match loss {
        Loss::Panicked(msg) => record_panic(&mut lost[0], sample, "project", msg),
        Loss::Failed(msg) => lost[1].fail(f64::INFINITY, || Case {
            sample,
            what: "project".into(),
            expected: "no error".into(),
            got: format!("returned an error: {msg}"),
            severity: 0.0,
        }),
    }
}

fn record_panic(panic: &mut CheckResult, sample: Option<Sample>, call: &str, msg: &str) {
    panic.fail(f64::INFINITY, || Case {
        sample,
        what: call.to_string(),
        expected: "no panic".into(),
        got: format!("panicked: {msg}"),
        severity: 0.0,
    });
}

// ---------------------------------------------------------------------------------------------------
// The checks.

/// The per-ray checks, one per rule of [`contract::check_ray`] (radius and spread share one).
const PER_RAY: [CheckKind; 7] = [
    CheckKind::DirectionFinite,
    CheckKind::DirectionUnit,
    CheckKind::OriginFinite,
    CheckKind::TimeRange,
    CheckKind::RadiusSpread,
    CheckKind::Distances,
    CheckKind::TintFinite,
];

struct Checker<'a> {
    p: &'a dyn Projection,
    env: &'a ProjectionEnvironment,
    opts: &'a CheckOptions,
    format: Format,
    window: ScreenWindow,
    /// Pixel size in screen units.
    pixel: (f64, f64),
    report: CheckReport,
    /// `(αx, αy)`, the measured per-pixel angles at each window pixel (row by row), from the spread check.
    alphas: Vec<Option<(f64, f64)>>,
}

/// The chief-ray grid: `gw × gh` pixel centres, the window's pixels plus `margin` on every side.
struct Grid {
    gw: usize,
    gh: usize,
    margin: usize,
    w: usize,
    h: usize,
}

impl Grid {
    fn in_window(&self, gx: usize, gy: usize) -> bool {
        (self.margin..self.margin + self.w).contains(&gx) && (self.margin..self.margin + self.h).contains(&gy)
    }
}

impl<'a> Checker<'a> {
    fn new(p: &'a dyn Projection, env: &'a ProjectionEnvironment, opts: &'a CheckOptions) -> Self {
        let f = env.format();
        let format = Format {
            width: f.width.max(1),
            height: f.height.max(1),
            pixel_aspect: f.pixel_aspect,
        };
        let window = env.screen_window();
        Checker {
            p,
            env,
            opts,
            format,
            window,
            pixel: (
                f64::from(window.width()) / f64::from(format.width),
                f64::from(window.height()) / f64::from(format.height),
            ),
            report: CheckReport::empty("", env, opts),
            alphas: Vec::new(),
        }
    }

    fn run(mut self) -> CheckReport {
        let prefill = self.properties();
        let runner = Runner {
            projection: self.p,
            prefill,
            batch_size: self.opts.batch_size.max(1),
        };
        let m = self.opts.margin as usize;
        let grid = Grid {
            gw: self.format.width as usize + 2 * m,
            gh: self.format.height as usize + 2 * m,
            margin: m,
            w: self.format.width as usize,
            h: self.format.height as usize,
        };
        let (inputs, lens_centre) = self.samples(&grid);
        self.report.samples = inputs.len() as u64;

        let first = runner.run_all(&inputs, 0);
        let second = runner.run_all(&inputs, 0);
        let n_batches = inputs.len().div_ceil(runner.batch_size);
        let threads = self.opts.threads.max(1);
        let concurrent: Vec<Run> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..threads)
                .map(|t| {
                    let (runner, inputs) = (&runner, &inputs);
                    s.spawn(move || runner.run_all(inputs, t * n_batches / threads))
                })
                .collect();
            handles.into_iter().filter_map(|h| h.join().ok()).collect()
        });
        for run in std::iter::once(&first)
            .chain(std::iter::once(&second))
            .chain(&concurrent)
        {
            let lost = self.report.lost();
            lost[0].examined += run.calls;
            lost[1].examined += run.calls;
            for (i, loss) in &run.losses {
                record_loss(lost, Some(inputs[*i].sample()), loss);
            }
        }

        let valid = self.per_ray(&inputs, &first);
        self.repeatability(&inputs, &first, &second, &concurrent);
        self.clipping(&inputs, &first, &valid);
        self.deep_metric(&inputs, &first, &valid);
        self.dicing_hint(&inputs, &grid, &first, &valid);
        self.ray_spread(&grid, &first, &valid);
        self.field_of_view(&runner);
        self.unproject(&inputs, &lens_centre, &first, &valid);
        self.report
    }

    /// Asks every property (as the host does: [`Properties::read`]), records panics and answers of the
    /// wrong type or domain, and returns the host's default rays.
    fn properties(&mut self) -> DefaultRays {
        let (props, answers) = Properties::read(self.p, self.env);
        for (prop, answer) in answers {
            self.report.at(CheckKind::Panic).examined += 1;
            let problem = match answer {
                Ok(a) => {
                    self.report.properties.push((prop, a));
                    self.report.at(CheckKind::PropertyType).examined += 1;
                    continue;
                }
                Err(problem) => problem,
            };
            let got = problem.got();
            match &problem {
                PropertyProblem::Panicked(msg) => {
                    self.report.properties.push((prop, None));
                    record_panic(
                        self.report.at(CheckKind::Panic),
                        None,
                        &format!("property({})", prop.renderman_name()),
                        msg,
                    );
                    continue;
                }
                // A value sent through the ABI that is no property value at all: the wrong type.
                PropertyProblem::Undecodable(_) => self.report.properties.push((prop, None)),
                PropertyProblem::WrongType(v) => self.report.properties.push((prop, Some(*v))),
                PropertyProblem::OutOfDomain(x) => {
                    self.report
                        .properties
                        .push((prop, Some(PropertyValue::Float(*x))));
                }
            }
            let types = self.report.at(CheckKind::PropertyType);
            types.examined += 1;
            types.fail(1.0, || Case {
                sample: None,
                what: prop.renderman_name().into(),
                expected: problem.expected(prop),
                got,
                severity: 0.0,
            });
        }
        self.report.dicing_hint = props.dicing_hint;
        self.report.deep_metric = props.deep_metric;
        DefaultRays::new(&props, self.env)
    }

    /// The chief grid (index `gy·gw + gx`) followed by the random samples, and the indices of the
    /// lens-centre samples inside the window.
    fn samples(&self, g: &Grid) -> (Vec<Input>, Vec<usize>) {
        let spp = self.opts.samples_per_pixel as usize;
        let mut inputs = Vec::with_capacity(g.gw * g.gh * (1 + spp));
        let mut lens_centre = Vec::new();
        let raster = |gx: usize, gy: usize, jx: f32, jy: f32| {
            self.window.raster_to_screen(
                self.format,
                gx as f64 - g.margin as f64 + f64::from(jx),
                gy as f64 - g.margin as f64 + f64::from(jy),
            )
        };
        for gy in 0..g.gh {
            for gx in 0..g.gw {
                if g.in_window(gx, gy) {
                    lens_centre.push(inputs.len());
                }
                inputs.push(Input::chief(raster(gx, gy, 0.5, 0.5), 0.0));
            }
        }
        let mut rng = SplitMix64(self.opts.seed);
        for gy in 0..g.gh {
            for gx in 0..g.gw {
                for k in 0..spp {
                    let (jx, jy) = (rng.next_f32(), rng.next_f32());
                    let screen = raster(gx, gy, jx, jy);
                    let time = rng.next_f32();
                    if k == 0 {
                        if g.in_window(gx, gy) {
                            lens_centre.push(inputs.len());
                        }
                        inputs.push(Input::chief(screen, time));
                    } else {
                        let lens = Point2::new(rng.next_f32(), rng.next_f32());
                        inputs.push(Input {
                            screen,
                            lens,
                            aperture: concentric_disk(lens),
                            time,
                        });
                    }
                }
            }
        }
        (inputs, lens_centre)
    }

    /// The per-ray checks on the first run; returns which samples are valid and not culled.
    fn per_ray(&mut self, inputs: &[Input], run: &Run) -> Vec<bool> {
        let unit = self.opts.unit_tolerance;
        let mut valid = vec![false; inputs.len()];
        for (i, o) in run.outputs.iter().enumerate() {
            let Some(o) = o else { continue };
            for k in PER_RAY {
                self.report.at(k).examined += 1;
            }
            match o.breach(unit) {
                Some(b) => {
                    let sample = inputs[i].sample();
                    self.report
                        .at(CheckKind::of(b.violation))
                        .fail(b.severity, || Case {
                            sample: Some(sample),
                            what: b.what.into(),
                            expected: b.expected,
                            got: b.got,
                            severity: b.severity,
                        });
                }
                None if o.ray.is_culled() => self.report.culled += 1,
                None => valid[i] = true,
            }
        }
        valid
    }

    /// Determinism (first vs second sequential run) and thread safety (each concurrent run vs the first).
    fn repeatability(&mut self, inputs: &[Input], first: &Run, second: &Run, concurrent: &[Run]) {
        let mut stable = vec![false; inputs.len()];
        let det = self.report.at(CheckKind::Determinism);
        for (i, (a, b)) in first.outputs.iter().zip(&second.outputs).enumerate() {
            let (Some(a), Some(b)) = (a, b) else { continue };
            det.examined += 1;
            match a.differs(b) {
                None => stable[i] = true,
                Some((field, severity)) => det.fail(severity, || Case {
                    sample: Some(inputs[i].sample()),
                    what: format!("{} on the second run", FIELDS[field]),
                    expected: format!("{} (the first run)", a.values()[field]),
                    got: format!("{}", b.values()[field]),
                    severity,
                }),
            }
        }
        let unstable = det.failures;
        let thr = self.report.at(CheckKind::Threads);
        if unstable > 0 {
            thr.notes.push(format!(
                "{unstable} samples left out: they already differ between two sequential runs"
            ));
        }
        for (t, run) in concurrent.iter().enumerate() {
            for (i, (a, b)) in first.outputs.iter().zip(&run.outputs).enumerate() {
                let (Some(a), Some(b)) = (a, b) else { continue };
                if !stable[i] {
                    continue;
                }
                thr.examined += 1;
                if let Some((field, severity)) = a.differs(b) {
                    thr.fail(severity, || Case {
                        sample: Some(inputs[i].sample()),
                        what: format!("{} on thread {t} of {}", FIELDS[field], concurrent.len()),
                        expected: format!("{} (the sequential run)", a.values()[field]),
                        got: format!("{}", b.values()[field]),
                        severity,
                    });
                }
            }
        }
    }

    /// Every valid ray's `min_dist`/`max_dist` against the environment's clipping planes (CameraZ) or
    /// spheres (RayLength): [`clipping_distances`], the host's own rule for its default rays.
    fn clipping(&mut self, inputs: &[Input], run: &Run, valid: &[bool]) {
        let metric = self.report.deep_metric;
        let (near, far) = (self.env.clipping_near(), self.env.clipping_far());
        let tolerance = self.opts.clipping_tolerance;
        let surface = match metric {
            DeepMetric::CameraZ => "plane",
            DeepMetric::RayLength => "sphere",
        };
        let r = self.report.at(CheckKind::Clipping);
        let mut backward = 0u64;
        for (i, o) in run.outputs.iter().enumerate() {
            let Some(o) = o.filter(|_| valid[i]) else {
                continue;
            };
            let Some(want) = clipping_distances(o.ray.origin, o.ray.direction, metric, near, far) else {
                backward += 1;
                continue;
            };
            r.examined += 1;
            let worst = [
                ("min_dist", o.ray.min_dist, want.0, "near"),
                ("max_dist", o.ray.max_dist, want.1, "far"),
            ]
            .into_iter()
            .map(|(what, got, want, which)| (relative_error(got, want), what, got, want, which))
            .max_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((error, what, got, want, which)) = worst.filter(|w| w.0 > tolerance) {
                r.fail(error, || Case {
                    sample: Some(inputs[i].sample()),
                    what: format!("{what} with {metric:?}"),
                    expected: format!("{want} (the {which} clipping {surface})"),
                    got: format!("{got}"),
                    severity: error,
                });
            }
        }
        if backward > 0 {
            r.skipped += backward;
            r.notes.push(format!(
                "{} toward -Z with CameraZ left to the deep_metric check",
                count(backward, "rays")
            ));
        }
    }

    fn deep_metric(&mut self, inputs: &[Input], run: &Run, valid: &[bool]) {
        let answered = self
            .report
            .properties
            .iter()
            .any(|(p, v)| *p == ProjectionProperty::DeepMetric && v.is_some_and(|v| p.accepts(v)));
        let source = if answered {
            "the DeepMetric property"
        } else {
            "the environment's deep metric (DeepMetric not answered)"
        };
        let metric = self.report.deep_metric;
        let r = self.report.at(CheckKind::DeepMetric);
        if metric == DeepMetric::RayLength {
            r.notes
                .push(format!("RayLength ({source}): rays may point anywhere"));
            return;
        }
        for (i, o) in run.outputs.iter().enumerate() {
            let Some(o) = o.filter(|_| valid[i]) else {
                continue;
            };
            r.examined += 1;
            let dz = o.ray.direction.z;
            if dz < 0.0 {
                r.fail(-f64::from(dz), || Case {
                    sample: Some(inputs[i].sample()),
                    what: format!("direction.z with CameraZ from {source}"),
                    expected: "direction.z >= 0 (or report DeepMetric RayLength)".into(),
                    got: format!("{dz} (direction {})", v3(o.ray.direction)),
                    severity: 0.0,
                });
            }
        }
    }

    fn dicing_hint(&mut self, inputs: &[Input], g: &Grid, run: &Run, valid: &[bool]) {
        let hint = self.report.dicing_hint;
        let r = &mut self.report.checks[CheckKind::DicingHint.index()];
        if hint == DicingHint::Spherical {
            r.notes
                .push("Spherical: neither one origin nor parallel rays required".into());
            return;
        }
        let chief: Vec<(usize, RayGeometry)> = (0..g.gw * g.gh)
            .filter(|&i| valid[i])
            .filter_map(|i| run.outputs[i].map(|o| (i, o.ray)))
            .collect();
        let (cx, cy) = (
            0.5 * (self.window.left + self.window.right),
            0.5 * (self.window.bottom + self.window.top),
        );
        let Some(&(ref_i, reference)) = chief.iter().min_by(|a, b| {
            let d = |s: Point2| (s.x - cx).powi(2) + (s.y - cy).powi(2);
            d(inputs[a.0].screen).total_cmp(&d(inputs[b.0].screen))
        }) else {
            r.notes.push("no valid chief ray".into());
            return;
        };
        let at = inputs[ref_i].screen;
        for (i, ray) in &chief {
            r.examined += 1;
            if hint == DicingHint::Perspective {
                let d = dist(ray.origin, reference.origin);
                let tol = self.opts.origin_tolerance * norm(reference.origin).max(1.0);
                if d > tol {
                    r.fail(d, || Case {
                        sample: Some(inputs[*i].sample()),
                        what: "origin of the lens-centre ray (DicingHint Perspective)".into(),
                        expected: format!(
                            "{} ± {tol}, the origin of the ray at screen ({}, {}): one centre of projection",
                            v3(reference.origin),
                            at.x,
                            at.y
                        ),
                        got: v3(ray.origin),
                        severity: 0.0,
                    });
                }
            } else {
                let a = angle(ray.direction, reference.direction);
                if a > self.opts.direction_tolerance {
                    r.fail(a, || Case {
                        sample: Some(inputs[*i].sample()),
                        what: "direction of the lens-centre ray (DicingHint Orthographic)".into(),
                        expected: format!(
                            "{}, the direction at screen ({}, {}), within {} rad: parallel rays",
                            v3(reference.direction),
                            at.x,
                            at.y,
                            self.opts.direction_tolerance
                        ),
                        got: format!("{} ({a:.3e} rad off)", v3(ray.direction)),
                        severity: 0.0,
                    });
                }
            }
        }
    }

    fn ray_spread(&mut self, g: &Grid, run: &Run, valid: &[bool]) {
        let idx = |gx: usize, gy: usize| gy * g.gw + gx;
        let dir = |gx: usize, gy: usize| {
            let i = idx(gx, gy);
            run.outputs[i].filter(|_| valid[i]).map(|o| o.ray.direction)
        };
        let pair = |a: Option<Vec3>, b: Option<Vec3>| match (a, b) {
            (Some(a), Some(b)) => Some(angle(a, b)),
            _ => None,
        };
        // h[gy][gx]: between (gx, gy) and (gx + 1, gy); v[gy][gx]: between (gx, gy) and (gx, gy + 1).
        let h: Vec<Vec<Option<f64>>> = (0..g.gh)
            .map(|gy| {
                (0..g.gw.saturating_sub(1))
                    .map(|gx| pair(dir(gx, gy), dir(gx + 1, gy)))
                    .collect()
            })
            .collect();
        let v: Vec<Vec<Option<f64>>> = (0..g.gh.saturating_sub(1))
            .map(|gy| (0..g.gw).map(|gx| pair(dir(gx, gy), dir(gx, gy + 1))).collect())
            .collect();
        let ratio = self.opts.discontinuity_ratio;
        let mut discontinuities = 0u64;
        let mut usable = |pairs: &Vec<Vec<Option<f64>>>| -> Vec<Vec<Option<f64>>> {
            let rows = pairs.len();
            (0..rows)
                .map(|y| {
                    let cols = pairs[y].len();
                    (0..cols)
                        .map(|x| {
                            let a = pairs[y][x]?;
                            let mut near: Vec<f64> = (y.saturating_sub(2)..(y + 3).min(rows))
                                .flat_map(|yy| {
                                    (x.saturating_sub(2)..(x + 3).min(cols))
                                        .filter_map(move |xx| pairs[yy][xx])
                                })
                                .collect();
                            near.sort_by(f64::total_cmp);
                            let n = near.len();
                            let median = if n % 2 == 1 {
                                near[n / 2]
                            } else {
                                0.5 * (near[n / 2 - 1] + near[n / 2])
                            };
                            if a > ratio * median {
                                discontinuities += 1;
                                None
                            } else {
                                Some(a)
                            }
                        })
                        .collect()
                })
                .collect()
        };
        let h = usable(&h);
        let v = usable(&v);
        // The per-pixel angle on one axis: the mean of the pairs on either side, when both are usable
        // and agree within the curvature ratio (else the finite difference says little about the
        // derivative at the pixel: a singular rim, a fold).
        let curvature = self.opts.curvature_ratio;
        let (mut missing, mut curved) = (0u64, 0u64);
        let mut axis = |a: [Option<f64>; 2]| -> Option<f64> {
            let [Some(p), Some(q)] = a else {
                missing += 1;
                return None;
            };
            if p.max(q) > curvature * p.min(q) {
                curved += 1;
                return None;
            }
            Some(0.5 * (p + q))
        };
        let tol = self.opts.spread_tolerance;
        self.alphas = vec![None; g.w * g.h];
        let r = &mut self.report.checks[CheckKind::RaySpread.index()];
        for gy in 0..g.gh {
            for gx in 0..g.gw {
                if !g.in_window(gx, gy) || !valid[idx(gx, gy)] {
                    continue;
                }
                let Some(o) = run.outputs[idx(gx, gy)] else {
                    continue;
                };
                let ax = axis([
                    gx.checked_sub(1).and_then(|x| h[gy][x]),
                    h[gy].get(gx).copied().flatten(),
                ]);
                let ay = axis([
                    gy.checked_sub(1).and_then(|y| v[y][gx]),
                    v.get(gy).and_then(|row| row[gx]),
                ]);
                let (Some(ax), Some(ay)) = (ax, ay) else {
                    r.skipped += 1;
                    continue;
                };
                r.examined += 1;
                self.alphas[(gy - g.margin) * g.w + (gx - g.margin)] = Some((ax, ay));
                let expected = 0.5 * (ax * ay).sqrt();
                let got = f64::from(o.ray.ray_spread);
                let err = (got - expected).abs();
                if err > tol * expected + 1e-7 {
                    let severity = if expected > 0.0 {
                        err / expected
                    } else {
                        f64::INFINITY
                    };
                    r.fail(severity, || Case {
                        sample: Some(Sample {
                            screen: o_screen(&self.window, self.format, g, gx, gy),
                            lens: Point2::new(0.5, 0.5),
                            time: 0.0,
                        }),
                        what: "ray_spread of the chief ray".into(),
                        expected: format!(
                            "{expected:.6e} ± {:.0} % (half of sqrt(ax·ay), the measured angles between \
                             neighbouring pixel centres' rays ax = {ax:.6e}, ay = {ay:.6e} rad)",
                            tol * 100.0
                        ),
                        got: format!(
                            "{got:.6e} ({:+.1} %)",
                            if expected > 0.0 {
                                (got / expected - 1.0) * 100.0
                            } else {
                                f64::INFINITY
                            }
                        ),
                        severity: 0.0,
                    });
                }
            }
        }
        if r.skipped > 0 {
            r.notes.push(format!(
                "{} pixels skipped: {missing} pixel axes lack a usable neighbour on one side (culled, invalid, \
                 or across a discontinuity), {curved} change angle by more than {curvature}x from one side to \
                 the other (too curved to measure)",
                r.skipped
            ));
        }
        if discontinuities > 0 {
            r.notes.push(format!(
                "{discontinuities} neighbour pairs left out as discontinuities (angle > {ratio}x the local median)"
            ));
        }
    }

    fn field_of_view(&mut self, runner: &Runner<'_>) {
        let hint = self.report.dicing_hint;
        let answer = self
            .report
            .properties
            .iter()
            .find(|(p, _)| *p == ProjectionProperty::FieldOfView)
            .and_then(|(_, v)| *v);
        let fov = match answer {
            None => {
                self.report
                    .at(CheckKind::FieldOfView)
                    .notes
                    .push("FieldOfView not answered".into());
                return;
            }
            Some(PropertyValue::Float(f)) => f,
            Some(_) => {
                self.report
                    .at(CheckKind::FieldOfView)
                    .notes
                    .push("answered with the wrong type (see property_type)".into());
                return;
            }
        };
        if hint == DicingHint::Orthographic {
            self.report.at(CheckKind::FieldOfView).notes.push(format!(
                "answered {fov} with DicingHint Orthographic, which has no field of view: not checked"
            ));
            return;
        }
        self.report.at(CheckKind::FieldOfView).examined = 1;
        if !(fov.is_finite() && fov > 0.0) {
            self.report
                .at(CheckKind::FieldOfView)
                .fail(f64::INFINITY, || Case {
                    sample: None,
                    what: "k_FieldOfView".into(),
                    expected: "a positive, finite angle in degrees".into(),
                    got: format!("{fov}"),
                    severity: 0.0,
                });
            return;
        }
        const TIMES: [f32; 5] = [0.0, 0.25, 0.5, 0.75, 1.0 - 1.0 / 16_777_216.0];
        let unit = self.opts.unit_tolerance;
        let w = self.window;
        let (cx, cy) = (0.5 * (w.left + w.right), 0.5 * (w.bottom + w.top));
        // (name, degrees at each time)
        let mut measures: Vec<(&str, Vec<Option<f64>>)> = Vec::new();
        if hint == DicingHint::Spherical {
            let (nx, ny) = (
                2 * self.format.width as usize + 1,
                2 * self.format.height as usize + 1,
            );
            let mut points = vec![Point2::new(cx, cy)];
            for y in 0..ny {
                for x in 0..nx {
                    points.push(w.raster_to_screen(self.format, x as f64 * 0.5, y as f64 * 0.5));
                }
            }
            let names = [
                "2x the widest angle from the central ray over the window",
                "2x the widest angle from the central ray along the horizontal midline",
                "2x the widest angle from the central ray along the vertical midline",
            ];
            let mut per_time = [Vec::new(), Vec::new(), Vec::new()];
            for t in TIMES {
                let d = runner.directions(&points, t, self.report.lost(), unit);
                let mut widest = [None::<f64>; 3];
                if let Some(centre) = d[0] {
                    for y in 0..ny {
                        for x in 0..nx {
                            let Some(dir) = d[1 + y * nx + x] else { continue };
                            let a = angle(centre, dir).to_degrees() * 2.0;
                            let on = [true, y == ny / 2, x == nx / 2];
                            for k in 0..3 {
                                if on[k] {
                                    widest[k] = Some(widest[k].map_or(a, |b: f64| b.max(a)));
                                }
                            }
                        }
                    }
                    let radial = self.radial_widest(runner, t, centre);
                    for k in 0..3 {
                        if let Some(a) = radial[k] {
                            widest[k] = Some(widest[k].map_or(a, |b: f64| b.max(a)));
                        }
                    }
                }
                for k in 0..3 {
                    per_time[k].push(widest[k]);
                }
            }
            for (name, values) in names.into_iter().zip(per_time) {
                measures.push((name, values));
            }
            // The host dices a Spherical camera at 2s/fov pixels per radian (s pixels per screen unit):
            // a FieldOfView chosen for the finest (or the central) angular resolution is honest too.
            let (ww, hh) = (self.format.width as usize, self.format.height as usize);
            let s = (f64::from(self.format.width) / f64::from(w.width()).abs())
                .max(f64::from(self.format.height) / f64::from(w.height()).abs());
            let finest = self
                .alphas
                .iter()
                .flatten()
                .map(|(ax, ay)| ax.min(*ay))
                .fold(f64::INFINITY, f64::min);
            if finest.is_finite() {
                measures.push((
                    "2s x the finest per-pixel angle in the window (s pixels per screen unit)",
                    vec![Some((2.0 * s * finest).to_degrees())],
                ));
            }
            let rows = [(hh - 1) / 2, hh / 2];
            let cols = [(ww - 1) / 2, ww / 2];
            let finest_on = |pixels: &mut dyn Iterator<Item = usize>| {
                pixels
                    .filter_map(|i| self.alphas.get(i).copied().flatten())
                    .map(|(ax, ay)| ax.min(ay))
                    .fold(f64::INFINITY, f64::min)
            };
            let horizon = finest_on(&mut rows.into_iter().flat_map(|y| (0..ww).map(move |x| y * ww + x)));
            let meridian = finest_on(&mut cols.into_iter().flat_map(|x| (0..hh).map(move |y| y * ww + x)));
            for (name, a) in [
                (
                    "2s x the finest per-pixel angle along the horizontal midline",
                    horizon,
                ),
                (
                    "2s x the finest per-pixel angle along the vertical midline",
                    meridian,
                ),
            ] {
                if a.is_finite() {
                    measures.push((name, vec![Some((2.0 * s * a).to_degrees())]));
                }
            }
            let centre: Vec<(f64, f64)> = rows
                .into_iter()
                .flat_map(|y| cols.into_iter().map(move |x| y * ww + x))
                .filter_map(|i| self.alphas.get(i).copied().flatten())
                .collect();
            if !centre.is_empty() {
                let n = centre.len() as f64;
                let ax = centre.iter().map(|a| a.0).sum::<f64>() / n;
                let ay = centre.iter().map(|a| a.1).sum::<f64>() / n;
                measures.push((
                    "2s x the per-pixel angle at the window's centre (the finer axis)",
                    vec![Some((2.0 * s * ax.min(ay)).to_degrees())],
                ));
            }
        } else {
            let pairs: [(&str, Point2, Point2); 5] = [
                (
                    "across the [-1, 1] square in x",
                    Point2::new(-1.0, 0.0),
                    Point2::new(1.0, 0.0),
                ),
                (
                    "across the [-1, 1] square in y",
                    Point2::new(0.0, -1.0),
                    Point2::new(0.0, 1.0),
                ),
                (
                    "across the window's width",
                    Point2::new(w.left, cy),
                    Point2::new(w.right, cy),
                ),
                (
                    "across the window's height",
                    Point2::new(cx, w.bottom),
                    Point2::new(cx, w.top),
                ),
                (
                    "across the window's diagonal",
                    Point2::new(w.left, w.bottom),
                    Point2::new(w.right, w.top),
                ),
            ];
            let points: Vec<Point2> = pairs.iter().flat_map(|(_, a, b)| [*a, *b]).collect();
            let mut per_time: Vec<Vec<Option<f64>>> = vec![Vec::new(); pairs.len()];
            for t in TIMES {
                let d = runner.directions(&points, t, self.report.lost(), unit);
                for (k, values) in per_time.iter_mut().enumerate() {
                    values.push(match (d[2 * k], d[2 * k + 1]) {
                        (Some(a), Some(b)) => Some(angle(a, b).to_degrees()),
                        _ => None,
                    });
                }
            }
            for ((name, _, _), values) in pairs.into_iter().zip(per_time) {
                measures.push((name, values));
            }
        }
        let fov64 = f64::from(fov);
        let tol = (self.opts.fov_tolerance * fov64).max(self.opts.fov_tolerance_degrees);
        let mut best = f64::INFINITY;
        let mut described = Vec::new();
        for (name, values) in &measures {
            let got: Vec<f64> = values.iter().flatten().copied().collect();
            if got.is_empty() {
                continue;
            }
            let lo = got.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = got.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let d = if (lo..=hi).contains(&fov64) {
                0.0
            } else {
                (fov64 - lo).abs().min((fov64 - hi).abs())
            };
            best = best.min(d);
            described.push(if hi - lo < 1e-3 {
                format!("{lo:.3}° {name}")
            } else {
                format!("{lo:.3}°..{hi:.3}° {name} over the shutter")
            });
        }
        let r = self.report.at(CheckKind::FieldOfView);
        if described.is_empty() {
            r.examined = 0;
            r.skipped = 1;
            r.notes
                .push("could not measure: the rays needed were culled or invalid".into());
            return;
        }
        if best > tol {
            r.fail(best, || Case {
                sample: None,
                what: format!("k_FieldOfView with DicingHint {hint:?}"),
                expected: format!("within {tol:.3}° of one of: {}", described.join("; ")),
                got: format!("{fov}°"),
                severity: 0.0,
            });
        }
    }

    /// Twice the widest angle (degrees) from `centre`, the ray at the window's centre, along 256 radial
    /// lines from the centre to the window's edge: 64 steps each, then 24 bisections of the step where
    /// the rays stop being valid, so a field of view reached only at a singular rim (a mirror ball's) is
    /// measured to within a hair. Over all lines, the horizontal ones, and the vertical ones.
    fn radial_widest(&mut self, runner: &Runner<'_>, t: f32, centre: Vec3) -> [Option<f64>; 3] {
        const AZIMUTHS: usize = 256;
        const STEPS: usize = 64;
        const ROUNDS: usize = 24;
        let unit = self.opts.unit_tolerance;
        let w = self.window;
        let (cx, cy) = (
            0.5 * (f64::from(w.left) + f64::from(w.right)),
            0.5 * (f64::from(w.bottom) + f64::from(w.top)),
        );
        let (hw, hh) = (
            0.5 * f64::from(w.width()).abs(),
            0.5 * f64::from(w.height()).abs(),
        );
        let ends: Vec<(f64, f64)> = (0..AZIMUTHS)
            .map(|k| {
                let (sin, cos) = (std::f64::consts::TAU * k as f64 / AZIMUTHS as f64).sin_cos();
                let reach_x = if cos.abs() > 1e-12 {
                    hw / cos.abs()
                } else {
                    f64::INFINITY
                };
                let reach_y = if sin.abs() > 1e-12 {
                    hh / sin.abs()
                } else {
                    f64::INFINITY
                };
                let reach = reach_x.min(reach_y);
                (cos * reach, sin * reach)
            })
            .collect();
        let at = |k: usize, f: f64| Point2::new((cx + ends[k].0 * f) as f32, (cy + ends[k].1 * f) as f32);
        let points: Vec<Point2> = (0..AZIMUTHS)
            .flat_map(|k| (0..=STEPS).map(move |j| (k, j)))
            .map(|(k, j)| at(k, j as f64 / STEPS as f64))
            .collect();
        let d = runner.directions(&points, t, self.report.lost(), unit);
        let mut widest = [None::<f64>; AZIMUTHS];
        let widen = |slot: &mut Option<f64>, dir: Vec3| {
            let a = angle(centre, dir);
            *slot = Some(slot.map_or(a, |b| b.max(a)));
        };
        // (last valid, first invalid) fractions of the line, where a line stops being valid.
        let mut bracket: Vec<Option<(f64, f64)>> = vec![None; AZIMUTHS];
        for k in 0..AZIMUTHS {
            for j in 0..=STEPS {
                match d[k * (STEPS + 1) + j] {
                    Some(dir) => widen(&mut widest[k], dir),
                    None => {
                        if j > 0 {
                            bracket[k] = Some(((j - 1) as f64 / STEPS as f64, j as f64 / STEPS as f64));
                        }
                        break;
                    }
                }
            }
        }
        for _ in 0..ROUNDS {
            let active: Vec<(usize, f64, f64)> = bracket
                .iter()
                .enumerate()
                .filter_map(|(k, b)| b.map(|(lo, hi)| (k, lo, hi)))
                .collect();
            if active.is_empty() {
                break;
            }
            let mids: Vec<Point2> = active.iter().map(|&(k, lo, hi)| at(k, 0.5 * (lo + hi))).collect();
            let d = runner.directions(&mids, t, self.report.lost(), unit);
            for (&(k, lo, hi), dir) in active.iter().zip(d) {
                let mid = 0.5 * (lo + hi);
                bracket[k] = match dir {
                    Some(dir) => {
                        widen(&mut widest[k], dir);
                        Some((mid, hi))
                    }
                    None => Some((lo, mid)),
                };
            }
        }
        let max_of = |ks: &mut dyn Iterator<Item = usize>| {
            ks.filter_map(|k| widest[k])
                .fold(None, |m: Option<f64>, a| Some(m.map_or(a, |b| b.max(a))))
                .map(|a| 2.0 * a.to_degrees())
        };
        [
            max_of(&mut (0..AZIMUTHS)),
            max_of(&mut [0, AZIMUTHS / 2].into_iter()),
            max_of(&mut [AZIMUTHS / 4, 3 * AZIMUTHS / 4].into_iter()),
        ]
    }

    fn unproject(&mut self, inputs: &[Input], lens_centre: &[usize], run: &Run, valid: &[bool]) {
        let (px, py) = self.pixel;
        let tol = self.opts.unproject_tolerance;
        let mut answered = 0u64;
        let mut nones: Vec<(Sample, f32)> = Vec::new();
        for &i in lens_centre {
            let Some(o) = run.outputs[i].filter(|_| valid[i]) else {
                continue;
            };
            let s = inputs[i].screen;
            let base = if o.ray.min_dist.is_finite() && o.ray.min_dist > 0.5 {
                2.0 * o.ray.min_dist
            } else {
                1.0
            };
            for depth in [base, 10.0 * base] {
                let point = o.ray.origin + o.ray.direction * depth;
                self.report.at(CheckKind::Panic).examined += 1;
                let back = match catch_unwind(AssertUnwindSafe(|| self.p.unproject(point, o.time))) {
                    Ok(b) => b,
                    Err(payload) => {
                        let msg = panic_message(payload.as_ref());
                        record_panic(
                            self.report.at(CheckKind::Panic),
                            Some(inputs[i].sample()),
                            "unproject",
                            &msg,
                        );
                        continue;
                    }
                };
                let Some(u) = back else {
                    nones.push((inputs[i].sample(), depth));
                    continue;
                };
                answered += 1;
                let r = self.report.at(CheckKind::Unproject);
                r.examined += 1;
                let err = (f64::from(u.x) - f64::from(s.x)).hypot(f64::from(u.y) - f64::from(s.y));
                let err_px =
                    ((f64::from(u.x) - f64::from(s.x)) / px).hypot((f64::from(u.y) - f64::from(s.y)) / py);
                if err_px.is_nan() || err_px > tol {
                    r.fail(err_px, || Case {
                        sample: Some(inputs[i].sample()),
                        what: format!(
                            "unproject(O + D·{depth}) = unproject({}) at time {}",
                            v3(point),
                            o.time
                        ),
                        expected: format!("the screen sample ({}, {}) within {tol} pixel", s.x, s.y),
                        got: format!(
                            "({}, {}): {err_px:.4e} pixels ({err:.3e} screen units) off",
                            u.x, u.y
                        ),
                        severity: 0.0,
                    });
                }
            }
        }
        let r = self.report.at(CheckKind::Unproject);
        if answered == 0 {
            r.notes.push(if nones.is_empty() {
                "no valid lens-centre ray to unproject".into()
            } else {
                "not offered (unproject answered None everywhere)".into()
            });
            return;
        }
        for (sample, depth) in nones {
            r.examined += 1;
            r.fail(f64::INFINITY, || Case {
                sample: Some(sample),
                what: format!("unproject(O + D·{depth}) of the sample's own ray"),
                expected: format!("the screen sample ({}, {})", sample.screen.x, sample.screen.y),
                got: "None".into(),
                severity: 0.0,
            });
        }
        r.notes.push(
            "points at t and 10t along each valid lens-centre ray in the window (t = 1, or 2·min_dist when min_dist > 0.5)"
                .into(),
        );
    }
}

fn o_screen(window: &ScreenWindow, format: Format, g: &Grid, gx: usize, gy: usize) -> Point2 {
    window.raster_to_screen(
        format,
        gx as f64 - g.margin as f64 + 0.5,
        gy as f64 - g.margin as f64 + 0.5,
    )
}

/// `n units`, singular when `n` is 1 ("1 property", "1 chief ray").
fn count(n: u64, unit: &str) -> String {
    if n != 1 {
        format!("{n} {unit}")
    } else if let Some(stem) = unit.strip_suffix("ies") {
        format!("1 {stem}y")
    } else {
        format!("1 {}", unit.strip_suffix('s').unwrap_or(unit))
    }
}

/// `|got − want| / max(|want|, 10⁻³)`; 0 when equal (both infinite included), ∞ when only one is
/// infinite or either is NaN.
fn relative_error(got: f32, want: f32) -> f64 {
    if got == want {
        return 0.0;
    }
    let (g, w) = (f64::from(got), f64::from(want));
    let e = (g - w).abs() / w.abs().max(1e-3);
    if e.is_finite() { e } else { f64::INFINITY }
}

fn value_text(v: PropertyValue) -> String {
    match v {
        PropertyValue::DicingHint(h) => format!("{h:?}"),
        PropertyValue::DeepMetric(m) => format!("{m:?}"),
        PropertyValue::Float(x) => format!("{x}"),
    }
}

fn v3(v: Vec3) -> String {
    format!("({}, {}, {})", v.x, v.y, v.z)
}

fn norm(v: Vec3) -> f64 {
    let (x, y, z) = (f64::from(v.x), f64::from(v.y), f64::from(v.z));
    (x * x + y * y + z * z).sqrt()
}

fn dist(a: Vec3, b: Vec3) -> f64 {
    let (x, y, z) = (
        f64::from(a.x) - f64::from(b.x),
        f64::from(a.y) - f64::from(b.y),
        f64::from(a.z) - f64::from(b.z),
    );
    (x * x + y * y + z * z).sqrt()
}

/// The angle between two directions in radians, accurate for tiny and near-π angles:
/// `atan2(|a × b|, a · b)` in f64 (independent of the vectors' lengths).
fn angle(a: Vec3, b: Vec3) -> f64 {
    let (ax, ay, az) = (f64::from(a.x), f64::from(a.y), f64::from(a.z));
    let (bx, by, bz) = (f64::from(b.x), f64::from(b.y), f64::from(b.z));
    let (cx, cy, cz) = (ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx);
    (cx * cx + cy * cy + cz * cz)
        .sqrt()
        .atan2(ax * bx + ay * by + az * bz)
}

fn json_str(out: &mut String, s: &str) {
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
}

/// A JSON number (Rust's `Display` never uses an exponent, so the text is valid JSON), or `null`.
fn json_num(x: f64) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        "null".into()
    }
}

fn json_f32(x: f32) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        "null".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::contract::value_in_domain;
    use obscura_sdk::optics::PerspectiveRays;
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
                (ProjectionProperty::DicingHint, _) => {
                    Some(PropertyValue::DicingHint(DicingHint::Perspective))
                }
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
                let ax =
                    self.pixel.0 * (self.k * self.k * ux * ux + tangential * tangential * uy * uy).sqrt();
                let ay =
                    self.pixel.1 * (self.k * self.k * uy * uy + tangential * tangential * ux * ux).sqrt();
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

    #[test]
    fn splitmix_matches_the_reference_and_stays_in_the_unit_interval() {
        // The reference implementation's first outputs for seed 0.
        let mut g = SplitMix64(0);
        assert_eq!(g.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(g.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        let mut g = SplitMix64(7);
        for _ in 0..10_000 {
            let x = g.next_f32();
            assert!((0.0..1.0).contains(&x));
        }
    }

    #[test]
    fn the_concentric_map_fills_the_disk_and_keeps_the_centre() {
        assert_eq!(concentric_disk(Point2::new(0.5, 0.5)), Point2::ZERO);
        let mut g = SplitMix64(1);
        for _ in 0..10_000 {
            let p = concentric_disk(Point2::new(g.next_f32(), g.next_f32()));
            assert!(p.x.hypot(p.y) <= 1.0 + 1e-6);
        }
        // The square's edge midpoint lands on the circle.
        let e = concentric_disk(Point2::new(1.0, 0.5));
        assert!((e.x - 1.0).abs() < 1e-6 && e.y.abs() < 1e-6);
    }
}
