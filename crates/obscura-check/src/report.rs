//! What a check finds: [`CheckKind`] (one per promise of the contract), the [`CheckResult`] of each
//! with its worst [`Case`], and the whole [`CheckReport`] with its text form. The JSON form is in
//! `json.rs`.

use std::fmt;

use obscura_sdk::contract::Violation;
use obscura_sdk::{
    DeepMetric, DicingHint, Format, Point2, ProjectionEnvironment, ProjectionProperty, PropertyValue,
    ScreenWindow,
};

use crate::CheckOptions;

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

    /// The position in [`CheckKind::ALL`] (and in [`CheckReport::checks`]).
    pub(crate) fn index(self) -> usize {
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
    /// A result with nothing examined yet.
    pub(crate) fn new(kind: CheckKind) -> Self {
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
    pub(crate) fn fail(&mut self, severity: f64, make: impl FnOnce() -> Case) {
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
    /// A report with every check at nothing examined, for `projection` checked in `env` with `opts`.
    pub(crate) fn empty(projection: &str, env: &ProjectionEnvironment, opts: &CheckOptions) -> Self {
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

    /// The result of one check, to record into.
    pub(crate) fn at(&mut self, kind: CheckKind) -> &mut CheckResult {
        &mut self.checks[kind.index()]
    }

    /// The Panic and Error results, where a lost `project` batch is recorded.
    pub(crate) fn lost(&mut self) -> &mut [CheckResult; 2] {
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
}

impl fmt::Display for CheckReport {
    /// One header line, one line of properties, one line per check (`ok`, `FAILED n of m … worst: …`,
    /// `not checked`), and a verdict.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.write_header(f)?;
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
            write_check(f, c)?;
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

impl CheckReport {
    /// The first line: what was sampled, how, and how many samples came back culled.
    fn write_header(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
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
        )
    }
}

/// One check's line: status, title, counts, notes and the worst case.
fn write_check(f: &mut fmt::Formatter<'_>, c: &CheckResult) -> fmt::Result {
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
    writeln!(f)
}

/// `n units`, singular when `n` is 1 ("1 property", "1 chief ray").
pub(crate) fn count(n: u64, unit: &str) -> String {
    if n != 1 {
        format!("{n} {unit}")
    } else if let Some(stem) = unit.strip_suffix("ies") {
        format!("1 {stem}y")
    } else {
        format!("1 {}", unit.strip_suffix('s').unwrap_or(unit))
    }
}

/// A property value as the report shows it: the enum variant's name, or the number.
pub(crate) fn value_text(v: PropertyValue) -> String {
    match v {
        PropertyValue::DicingHint(h) => format!("{h:?}"),
        PropertyValue::DeepMetric(m) => format!("{m:?}"),
        PropertyValue::Float(x) => format!("{x}"),
    }
}
