//! The projection contract, written once: what a host hands `project`, what it accepts back, and how
//! it reads a projection's properties.
//!
//! Every place that enforces or checks the contract calls this module: the host's camera stage
//! (`obscura rays`, `obscura render`), the checker (`obscura check`, the `obscura-check` crate) and the
//! built-in projections' tests. So one bad ray is classed the same way everywhere.
//!
//! # The per-ray rules
//!
//! After `project`, every ray is checked by [`check_ray`], in this order; a ray that breaks several
//! rules counts once, under the first:
//!
//! | [`Violation`] | the ray breaks the contract when |
//! |---|---|
//! | [`NonFiniteDirection`](Violation::NonFiniteDirection) | a direction component is NaN or infinite |
//! | [`NonUnitDirection`](Violation::NonUnitDirection) | the direction is not exactly zero and `|‖D‖ − 1| >` [`UNIT_TOLERANCE`] |
//! | [`NonFiniteOrigin`](Violation::NonFiniteOrigin) | an origin component is NaN or infinite |
//! | [`TimeOutOfRange`](Violation::TimeOutOfRange) | the output time is outside `[0, 1)` (NaN included) |
//! | [`BadOriginRadius`](Violation::BadOriginRadius) | `origin_radius` is negative or not finite |
//! | [`BadRaySpread`](Violation::BadRaySpread) | `ray_spread` is negative or not finite |
//! | [`BadDistances`](Violation::BadDistances) | not `0 ≤ min_dist ≤ max_dist` (NaN included) |
//! | [`NonFiniteTint`](Violation::NonFiniteTint) | a tint channel is NaN or infinite |
//!
//! A zero direction is a legitimate cull (a pixel outside a fisheye's circle). A host culls a ray that
//! breaks a rule (sets its direction to zero) and counts it; nothing invalid reaches a tracer.
//!
//! A whole batch is lost when `project` panics ([`Violation::Panicked`]) or, for a plugin loaded
//! through the C ABI, returns `OBSCURA_ERROR` ([`Violation::Failed`]); see [`call_project`].
//!
//! # What `project` finds in the batch
//!
//! Before `project`, a host pre-fills every ray with [`DefaultRays`] (the renderer's own camera ray,
//! built from the projection's [`Properties`]) and every tint with white, so a projection may be a
//! *modifier* that only rewrites time or tint (RenderMan's PxrRollingShutter).
//!
//! # Clipping distances
//!
//! `min_dist` and `max_dist` put the environment's clipping range on each ray, by the projection's deep
//! metric ([`clipping_distances`]): for [`DeepMetric::CameraZ`] they are where the ray meets the
//! clipping *planes* `z = near` and `z = far`; for [`DeepMetric::RayLength`] they are `near` and `far`
//! themselves (clipping *spheres*: distances along the ray). The default rays follow the same rule.

use std::any::Any;
use std::panic::{AssertUnwindSafe, catch_unwind};

use crate::context::ProjectionContext;
use crate::environment::ProjectionEnvironment;
use crate::geometry::{Point2, Rgb, Vec3};
use crate::optics::{OrthographicRays, PerspectiveRays, screen_distance};
use crate::plugin::Projection;
use crate::property::{DeepMetric, DicingHint, ProjectionProperty, PropertyValue};
use crate::ray::RayGeometry;

/// A unit direction may be off by this much in length (f32 normalisation is good to ~10⁻⁷).
pub const UNIT_TOLERANCE: f32 = 1e-3;

/// The widest field of view, in degrees, of the host's pinhole default ray (a pinhole cannot show 180°;
/// wider projections write their own rays).
pub const MAX_DEFAULT_FOV: f32 = 179.0;

/// The field of view, in degrees, of the default ray of a projection that reports none.
pub const DEFAULT_FOV: f32 = 90.0;

/// A way a sample can break the projection contract. [`Violation::ALL`] is the report order; the
/// per-ray ones are checked in that order too.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Violation {
    /// `project` panicked: the whole batch is lost.
    Panicked,
    /// `project` reported an error (a C plugin's `OBSCURA_ERROR`): the whole batch is lost.
    Failed,
    /// A direction component is NaN or infinite.
    NonFiniteDirection,
    /// The direction is neither unit length nor exactly zero.
    NonUnitDirection,
    /// An origin component is NaN or infinite.
    NonFiniteOrigin,
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
    /// Every violation, in report order: the two batch losses, then the per-ray rules in the order
    /// [`check_ray`] applies them.
    pub const ALL: [Violation; 10] = [
        Violation::Panicked,
        Violation::Failed,
        Violation::NonFiniteDirection,
        Violation::NonUnitDirection,
        Violation::NonFiniteOrigin,
        Violation::TimeOutOfRange,
        Violation::BadOriginRadius,
        Violation::BadRaySpread,
        Violation::BadDistances,
        Violation::NonFiniteTint,
    ];

    /// What broke, as a plural noun phrase for counts ("3 non-finite directions").
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            Violation::Panicked => "samples lost to a panic in project",
            Violation::Failed => {
                "samples lost to a failed project call (an error it returned, or its isolated worker's crash or hang)"
            }
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

    /// The position in [`Violation::ALL`].
    #[must_use]
    pub fn index(self) -> usize {
        self as usize
    }
}

/// One ray's breach of the contract: which rule, and the values for a message.
#[derive(Debug, Clone, PartialEq)]
pub struct Breach {
    /// The rule broken.
    pub violation: Violation,
    /// The field(s) at fault (`"|direction|"`, `"min_dist, max_dist"`).
    pub what: &'static str,
    /// What the contract expects there.
    pub expected: String,
    /// What the ray holds.
    pub got: String,
    /// How far off, for ranking the worst case (infinite for non-finite values).
    pub severity: f64,
}

impl Breach {
    /// `what = got`, the short form a host's warning shows.
    #[must_use]
    pub fn detail(&self) -> String {
        format!("{} = {}", self.what, self.got)
    }
}

fn v3(v: Vec3) -> String {
    format!("({}, {}, {})", v.x, v.y, v.z)
}

/// The first per-ray rule the sample breaks at the contract's [`UNIT_TOLERANCE`], if any.
#[must_use]
pub fn check_ray(ray: &RayGeometry, time: f32, tint: Rgb) -> Option<Breach> {
    check_ray_with(ray, time, tint, UNIT_TOLERANCE)
}

/// [`check_ray`] with another unit-length tolerance (the checker's option).
#[must_use]
pub fn check_ray_with(ray: &RayGeometry, time: f32, tint: Rgb, unit_tolerance: f32) -> Option<Breach> {
    let breach = |violation, what, expected: &str, got: String, severity| {
        Some(Breach {
            violation,
            what,
            expected: expected.to_string(),
            got,
            severity,
        })
    };
    let d = ray.direction;
    if !d.is_finite() {
        return breach(
            Violation::NonFiniteDirection,
            "direction",
            "finite components",
            v3(d),
            f64::INFINITY,
        );
    }
    let len = d.length();
    if d != Vec3::ZERO && (len - 1.0).abs() > unit_tolerance {
        return breach(
            Violation::NonUnitDirection,
            "|direction|",
            &format!("1 ± {unit_tolerance} (or exactly zero to cull)"),
            format!("{len} (direction {})", v3(d)),
            f64::from((len - 1.0).abs()),
        );
    }
    if !ray.origin.is_finite() {
        return breach(
            Violation::NonFiniteOrigin,
            "origin",
            "finite components",
            v3(ray.origin),
            f64::INFINITY,
        );
    }
    if !(0.0..1.0).contains(&time) {
        let t = f64::from(time);
        let severity = if t < 0.0 { -t } else { t - 1.0 + f64::EPSILON };
        return breach(
            Violation::TimeOutOfRange,
            "time",
            "a time in [0, 1)",
            format!("{time}"),
            if severity.is_nan() {
                f64::INFINITY
            } else {
                severity
            },
        );
    }
    for (violation, what, v) in [
        (Violation::BadOriginRadius, "origin_radius", ray.origin_radius),
        (Violation::BadRaySpread, "ray_spread", ray.ray_spread),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            let severity = if v.is_finite() {
                -f64::from(v)
            } else {
                f64::INFINITY
            };
            return breach(violation, what, "a finite value >= 0", format!("{v}"), severity);
        }
    }
    if !(ray.min_dist >= 0.0 && ray.min_dist <= ray.max_dist) {
        let severity = if ray.min_dist < 0.0 {
            -f64::from(ray.min_dist)
        } else {
            f64::from(ray.min_dist) - f64::from(ray.max_dist)
        };
        return breach(
            Violation::BadDistances,
            "min_dist, max_dist",
            "0 <= min_dist <= max_dist",
            format!("{}, {}", ray.min_dist, ray.max_dist),
            if severity.is_nan() {
                f64::INFINITY
            } else {
                severity
            },
        );
    }
    if !tint.is_finite() {
        return breach(
            Violation::NonFiniteTint,
            "tint",
            "finite channels",
            format!("({}, {}, {})", tint.r, tint.g, tint.b),
            f64::INFINITY,
        );
    }
    None
}

// ------------------------------------------------------------------------------------------------
// Clipping.

/// The clipping distances `(min_dist, max_dist)` the contract expects on a ray with `origin` and unit
/// `direction`, for a projection of deep metric `metric` in an environment clipping at `near`, `far`.
///
/// CameraZ: where the ray meets the planes `z = near` and `z = far`, `(near − O.z)/D.z` and
/// `(far − O.z)/D.z`, each at least 0; `None` when `D.z ≤ 0` (the ray never meets them; the deep-metric
/// rule already forbids such a ray). RayLength: `(near, far)`.
#[must_use]
pub fn clipping_distances(
    origin: Vec3,
    direction: Vec3,
    metric: DeepMetric,
    near: f32,
    far: f32,
) -> Option<(f32, f32)> {
    match metric {
        DeepMetric::RayLength => Some((near, far)),
        DeepMetric::CameraZ if direction.z > 0.0 => Some((
            ((near - origin.z) / direction.z).max(0.0),
            ((far - origin.z) / direction.z).max(0.0),
        )),
        DeepMetric::CameraZ => None,
    }
}

// ------------------------------------------------------------------------------------------------
// Properties.

/// The properties a projection answered, with the host's defaults filled in.
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

/// Why an answer to `property` was not used.
#[derive(Debug, Clone, PartialEq)]
pub enum PropertyProblem {
    /// `property` panicked (for a plugin: its call failed).
    Panicked(String),
    /// A plugin sent a value through the ABI that is no property value (an unknown kind or enum).
    Undecodable(String),
    /// A value of another property's type.
    WrongType(PropertyValue),
    /// A float outside the property's domain (a NaN, zero or negative FStop, FocalLength or
    /// FocalDistance, an infinite focal length).
    OutOfDomain(f32),
}

impl PropertyProblem {
    /// What the property should have been answered with.
    #[must_use]
    pub fn expected(&self, p: ProjectionProperty) -> String {
        match self {
            PropertyProblem::Panicked(_) => "no panic".into(),
            PropertyProblem::OutOfDomain(_) => value_domain(p).into(),
            _ => format!("{} or None", expected_type(p)),
        }
    }

    /// What was answered (or what happened).
    #[must_use]
    pub fn got(&self) -> String {
        match self {
            PropertyProblem::Panicked(msg) => format!("panicked: {msg}"),
            PropertyProblem::Undecodable(reason) => reason.clone(),
            PropertyProblem::WrongType(v) => format!("{v:?}"),
            PropertyProblem::OutOfDomain(x) => format!("{x}"),
        }
    }

    /// The host's warning for projection `name`.
    #[must_use]
    pub fn warning(&self, name: &str, p: ProjectionProperty) -> String {
        let prop = p.renderman_name();
        match self {
            PropertyProblem::Panicked(msg) => {
                format!("warning: projection {name} failed to answer {prop}: {msg}; treated as unanswered")
            }
            PropertyProblem::Undecodable(reason) => {
                format!("warning: projection {name} answered {prop} with {reason}; ignored")
            }
            PropertyProblem::WrongType(v) => format!(
                "warning: projection {name} answered {prop} with {v:?}, which is not that property's type; ignored"
            ),
            PropertyProblem::OutOfDomain(x) => format!(
                "warning: projection {name} answered {prop} with {x}, expected {}; ignored",
                value_domain(p)
            ),
        }
    }
}

/// The type a property's answer must have, for messages.
#[must_use]
pub fn expected_type(p: ProjectionProperty) -> &'static str {
    match p {
        ProjectionProperty::DicingHint => "PropertyValue::DicingHint",
        ProjectionProperty::DeepMetric => "PropertyValue::DeepMetric",
        _ => "PropertyValue::Float",
    }
}

/// Whether a float property's value means anything: the depth-of-field triple is positive (an f-stop
/// or focal distance of ∞ is a pinhole or focus at infinity), a focal length finite too. FieldOfView's
/// value is checked against the rays by the checker.
#[must_use]
pub fn value_in_domain(p: ProjectionProperty, x: f32) -> bool {
    match p {
        ProjectionProperty::FStop | ProjectionProperty::FocalDistance => x > 0.0,
        ProjectionProperty::FocalLength => x > 0.0 && x.is_finite(),
        _ => true,
    }
}

/// The domain of the float property `p`, for messages.
#[must_use]
pub fn value_domain(p: ProjectionProperty) -> &'static str {
    match p {
        ProjectionProperty::FocalLength => "a positive, finite length",
        _ => "a positive value (∞ allowed), not NaN",
    }
}

/// The panic payload with which a host adapter reports a property value that does not decode (an
/// unknown value kind or enum value sent through the ABI).
///
/// The adapter raises it with [`std::panic::resume_unwind`] instead of answering `None`, so nothing
/// is lost: [`ask_property`] turns it into [`PropertyProblem::Undecodable`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UndecodableProperty {
    /// The property asked, by RenderMan's name (`k_FieldOfView`).
    pub property: &'static str,
    /// What was wrong with the value (`unknown property value kind 7 (expected 0, 1 or 2)`).
    pub reason: String,
}

impl std::fmt::Display for UndecodableProperty {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} answered with {}", self.property, self.reason)
    }
}

/// The panic payload with which a host adapter reports that a plugin's `project` returned an error
/// (`OBSCURA_ERROR`) rather than panicking; [`call_project`] turns it into [`Loss::Failed`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ProjectFailed(pub String);

/// The text of a panic payload (a `&str`, a `String`, an [`UndecodableProperty`] or a
/// [`ProjectFailed`]).
#[must_use]
pub fn panic_message(payload: &(dyn Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .or_else(|| {
            payload
                .downcast_ref::<UndecodableProperty>()
                .map(ToString::to_string)
        })
        .or_else(|| payload.downcast_ref::<ProjectFailed>().map(|f| f.0.clone()))
        .unwrap_or_else(|| "a panic with a non-string payload".into())
}

/// Asks one property, catching a panic, and checks the answer's type and domain.
///
/// # Errors
/// The [`PropertyProblem`] that keeps the answer from being used.
pub fn ask_property(
    p: &dyn Projection,
    prop: ProjectionProperty,
) -> Result<Option<PropertyValue>, PropertyProblem> {
    let answer = catch_unwind(AssertUnwindSafe(|| p.property(prop))).map_err(|payload| {
        match payload.downcast_ref::<UndecodableProperty>() {
            Some(bad) => PropertyProblem::Undecodable(bad.reason.clone()),
            None => PropertyProblem::Panicked(panic_message(payload.as_ref())),
        }
    })?;
    match answer {
        Some(v) if !prop.accepts(v) => Err(PropertyProblem::WrongType(v)),
        Some(PropertyValue::Float(x)) if !value_in_domain(prop, x) => Err(PropertyProblem::OutOfDomain(x)),
        a => Ok(a),
    }
}

/// Every property's answer, in [`ProjectionProperty::ALL`] order, as [`ask_property`] gives it.
pub type Answers = Vec<(ProjectionProperty, Result<Option<PropertyValue>, PropertyProblem>)>;

impl Properties {
    /// Asks every property once and fills in the host's defaults for what is unanswered or unusable.
    /// The answers come back too, for warnings and checks.
    #[must_use]
    pub fn read(p: &dyn Projection, env: &ProjectionEnvironment) -> (Properties, Answers) {
        let answers: Answers = ProjectionProperty::ALL
            .iter()
            .map(|&prop| (prop, ask_property(p, prop)))
            .collect();
        (Properties::from_answers(&answers, env), answers)
    }

    /// The properties given `answers` (as from [`Properties::read`]).
    #[must_use]
    pub fn from_answers(answers: &Answers, env: &ProjectionEnvironment) -> Properties {
        let get = |p: ProjectionProperty| {
            answers
                .iter()
                .find(|(q, _)| *q == p)
                .and_then(|(_, a)| a.clone().ok().flatten())
        };
        let float = |p| match get(p) {
            Some(PropertyValue::Float(x)) if x.is_finite() => Some(x),
            _ => None,
        };
        Properties {
            dicing_hint: match get(ProjectionProperty::DicingHint) {
                Some(PropertyValue::DicingHint(h)) => h,
                _ => DicingHint::Perspective,
            },
            deep_metric: match get(ProjectionProperty::DeepMetric) {
                Some(PropertyValue::DeepMetric(m)) => m,
                _ => env.deep_metric(),
            },
            field_of_view: float(ProjectionProperty::FieldOfView),
            f_stop: float(ProjectionProperty::FStop),
            focal_length: float(ProjectionProperty::FocalLength),
            focal_distance: float(ProjectionProperty::FocalDistance),
        }
    }
}

// ------------------------------------------------------------------------------------------------
// Default rays.

/// The host's own camera ray, pre-filled into every batch before `project`.
///
/// Orthographic when the DicingHint is Orthographic, else a pinhole at the FieldOfView
/// ([`DEFAULT_FOV`] when unanswered, at most [`MAX_DEFAULT_FOV`]); through a thin lens of radius
/// `½·FocalLength/FStop` focused at FocalDistance when all three are answered (the document: the
/// renderer uses them "as part of the computation for the initial ray directions supplied to the
/// projection plugin"). Clipping distances follow [`clipping_distances`] for the deep metric.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DefaultRays {
    /// A pinhole or thin lens with the screen plane at `d`; `spheres` when the deep metric is RayLength.
    Perspective {
        /// The camera's constants.
        rays: PerspectiveRays,
        /// The screen-plane distance `1/tan(fov/2)`.
        d: f32,
        /// Clipping spheres (`min_dist = near`, `max_dist = far`) instead of planes.
        spheres: bool,
    },
    /// Parallel rays; `spheres` as above.
    Orthographic {
        /// The camera's constants.
        rays: OrthographicRays,
        /// Clipping spheres instead of planes.
        spheres: bool,
    },
}

impl DefaultRays {
    /// The default rays of a projection with `props` in `env`.
    #[must_use]
    pub fn new(props: &Properties, env: &ProjectionEnvironment) -> Self {
        let (lens_radius, focal_distance) = match (props.f_stop, props.focal_length, props.focal_distance) {
            (Some(f), Some(fl), Some(fd)) if fd > 0.0 => (PerspectiveRays::lens_radius_for(f, fl), fd),
            _ => (0.0, 1.0),
        };
        let clipping = (env.clipping_near(), env.clipping_far());
        let spheres = props.deep_metric == DeepMetric::RayLength;
        if props.dicing_hint == DicingHint::Orthographic {
            return DefaultRays::Orthographic {
                rays: OrthographicRays::new(env.pixel_size(), clipping, lens_radius, focal_distance),
                spheres,
            };
        }
        let fov = props
            .field_of_view
            .filter(|f| *f > 0.0)
            .unwrap_or(DEFAULT_FOV)
            .min(MAX_DEFAULT_FOV);
        DefaultRays::Perspective {
            rays: PerspectiveRays::new(env.pixel_size(), clipping, lens_radius, focal_distance),
            d: screen_distance(fov),
            spheres,
        }
    }

    /// The default ray of screen point `s` through aperture sample `a ∈ [−1, 1]²`.
    #[inline]
    #[must_use]
    pub fn ray(&self, s: Point2, a: Point2) -> RayGeometry {
        let (mut ray, spheres, near, far) = match self {
            DefaultRays::Perspective { rays, d, spheres } => {
                (rays.ray(s, a, *d), *spheres, rays.near, rays.far)
            }
            DefaultRays::Orthographic { rays, spheres } => (rays.ray(s, a), *spheres, rays.near, rays.far),
        };
        if spheres {
            ray.min_dist = near;
            ray.max_dist = far;
        }
        ray
    }
}

// ------------------------------------------------------------------------------------------------
// Calling project.

/// Why a whole batch was lost.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Loss {
    /// `project` panicked, with this message.
    Panicked(String),
    /// `project` reported an error (a plugin's `OBSCURA_ERROR`), with this message.
    Failed(String),
}

impl Loss {
    /// The violation every sample of the batch counts as.
    #[must_use]
    pub fn violation(&self) -> Violation {
        match self {
            Loss::Panicked(_) => Violation::Panicked,
            Loss::Failed(_) => Violation::Failed,
        }
    }

    /// The message, prefixed by what happened (`panicked: …`, `returned an error: …`).
    #[must_use]
    pub fn detail(&self) -> String {
        match self {
            Loss::Panicked(m) => format!("panicked: {m}"),
            Loss::Failed(m) => format!("returned an error: {m}"),
        }
    }
}

/// Calls `project`, catching a panic; a [`ProjectFailed`] payload is an error, anything else a panic.
///
/// # Errors
/// The [`Loss`] of the batch.
pub fn call_project(p: &dyn Projection, ctx: &mut ProjectionContext<'_>) -> Result<(), Loss> {
    catch_unwind(AssertUnwindSafe(|| p.project(ctx))).map_err(|payload| {
        match payload.downcast_ref::<ProjectFailed>() {
            Some(f) => Loss::Failed(f.0.clone()),
            None => Loss::Panicked(panic_message(payload.as_ref())),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::environment::Format;

    fn good() -> RayGeometry {
        RayGeometry {
            origin: Vec3::ZERO,
            origin_radius: 0.0,
            direction: Vec3::Z,
            ray_spread: 0.001,
            min_dist: 0.1,
            max_dist: f32::INFINITY,
        }
    }

    #[test]
    fn a_good_ray_and_a_culled_one_pass() {
        assert_eq!(check_ray(&good(), 0.0, Rgb::WHITE), None);
        let culled = RayGeometry {
            direction: Vec3::ZERO,
            ..good()
        };
        assert_eq!(check_ray(&culled, 0.999, Rgb::WHITE), None);
    }

    #[test]
    fn the_first_rule_in_table_order_wins() {
        let both = RayGeometry {
            origin: Vec3::new(f32::NAN, 0.0, 0.0),
            direction: Vec3::new(f32::NAN, 0.0, 1.0),
            ..good()
        };
        let b = check_ray(&both, 2.0, Rgb::WHITE).unwrap();
        assert_eq!(b.violation, Violation::NonFiniteDirection);
        let origin_and_time = RayGeometry {
            origin: Vec3::new(f32::INFINITY, 0.0, 0.0),
            ..good()
        };
        let b = check_ray(&origin_and_time, 2.0, Rgb::WHITE).unwrap();
        assert_eq!(b.violation, Violation::NonFiniteOrigin);
    }

    #[test]
    fn the_unit_tolerance_is_one_thousandth() {
        let r = |len: f32| RayGeometry {
            direction: Vec3::new(0.0, 0.0, len),
            ..good()
        };
        assert_eq!(check_ray(&r(1.0009), 0.0, Rgb::WHITE), None);
        assert_eq!(
            check_ray(&r(1.0011), 0.0, Rgb::WHITE).map(|b| b.violation),
            Some(Violation::NonUnitDirection)
        );
        assert!(
            check_ray(&r(2.0), 0.0, Rgb::WHITE)
                .unwrap()
                .detail()
                .starts_with("|direction| = 2")
        );
    }

    #[test]
    fn nan_time_and_distances_are_breaches_with_finite_severity_ranking() {
        let b = check_ray(&good(), f32::NAN, Rgb::WHITE).unwrap();
        assert_eq!(b.violation, Violation::TimeOutOfRange);
        let nan_min = RayGeometry {
            min_dist: f32::NAN,
            ..good()
        };
        let b = check_ray(&nan_min, 0.0, Rgb::WHITE).unwrap();
        assert_eq!(b.violation, Violation::BadDistances);
        assert!(b.severity.is_infinite());
    }

    #[test]
    fn violation_index_is_its_place_in_all() {
        for (i, v) in Violation::ALL.iter().enumerate() {
            assert_eq!(v.index(), i);
        }
    }

    #[test]
    fn clipping_is_planes_for_camera_z_and_spheres_for_ray_length() {
        let d = Vec3::new(0.6, 0.0, 0.8);
        let o = Vec3::new(0.0, 0.0, 0.05);
        let (near, far) = clipping_distances(o, d, DeepMetric::CameraZ, 0.1, 10.0).unwrap();
        assert!((o.z + d.z * near - 0.1).abs() < 1e-6);
        assert!((o.z + d.z * far - 10.0).abs() < 1e-5);
        assert_eq!(
            clipping_distances(o, d, DeepMetric::RayLength, 0.1, 10.0),
            Some((0.1, 10.0))
        );
        assert_eq!(clipping_distances(o, -d, DeepMetric::CameraZ, 0.1, 10.0), None);
    }

    struct Answers6;
    impl Projection for Answers6 {
        fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
            match p {
                ProjectionProperty::DicingHint => Some(PropertyValue::Float(1.0)),
                ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(DeepMetric::RayLength)),
                ProjectionProperty::FieldOfView => panic!("no table"),
                ProjectionProperty::FStop => Some(PropertyValue::Float(f32::NAN)),
                ProjectionProperty::FocalLength => Some(PropertyValue::Float(0.05)),
                ProjectionProperty::FocalDistance => {
                    std::panic::resume_unwind(Box::new(UndecodableProperty {
                        property: "k_FocalDistance",
                        reason: "kind 7".into(),
                    }))
                }
            }
        }
        fn project(&self, _ctx: &mut ProjectionContext<'_>) {}
    }

    #[test]
    fn properties_keep_what_is_usable_and_say_why_the_rest_is_not() {
        let env = ProjectionEnvironment::for_format(Format::new(8, 8));
        let (props, answers) = Properties::read(&Answers6, &env);
        assert_eq!(props.dicing_hint, DicingHint::Perspective);
        assert_eq!(props.deep_metric, DeepMetric::RayLength);
        assert_eq!((props.field_of_view, props.f_stop), (None, None));
        assert_eq!(props.focal_length, Some(0.05));
        let problems: Vec<_> = answers
            .iter()
            .filter_map(|(p, a)| a.clone().err().map(|e| (*p, e)))
            .collect();
        assert!(matches!(
            problems[0],
            (ProjectionProperty::DicingHint, PropertyProblem::WrongType(_))
        ));
        assert!(
            matches!(&problems[1], (ProjectionProperty::FieldOfView, PropertyProblem::Panicked(m)) if m == "no table")
        );
        assert!(matches!(
            problems[2],
            (ProjectionProperty::FStop, PropertyProblem::OutOfDomain(_))
        ));
        assert!(
            matches!(&problems[3], (ProjectionProperty::FocalDistance, PropertyProblem::Undecodable(r)) if r == "kind 7")
        );
        assert_eq!(problems.len(), 4);
    }

    #[test]
    fn default_rays_of_a_ray_length_camera_clip_at_spheres() {
        let env = ProjectionEnvironment::new(
            Format::new(8, 8),
            crate::environment::ScreenWindow::default_for(Format::new(8, 8)),
            (0.0, 1.0),
            (0.5, 20.0),
            Vec::new(),
        );
        let mut props = Properties {
            dicing_hint: DicingHint::Spherical,
            deep_metric: DeepMetric::RayLength,
            field_of_view: Some(360.0),
            f_stop: None,
            focal_length: None,
            focal_distance: None,
        };
        let s = Point2::new(0.7, -0.4);
        let r = DefaultRays::new(&props, &env).ray(s, Point2::ZERO);
        assert_eq!((r.min_dist, r.max_dist), (0.5, 20.0));
        props.deep_metric = DeepMetric::CameraZ;
        let r = DefaultRays::new(&props, &env).ray(s, Point2::ZERO);
        let (near, far) = clipping_distances(r.origin, r.direction, DeepMetric::CameraZ, 0.5, 20.0).unwrap();
        assert!((r.min_dist - near).abs() <= 1e-6 * near && (r.max_dist - far).abs() <= 1e-5 * far);
    }

    struct Fails;
    impl Projection for Fails {
        fn property(&self, _: ProjectionProperty) -> Option<PropertyValue> {
            None
        }
        fn project(&self, ctx: &mut ProjectionContext<'_>) {
            if ctx.num_rays() > 1 {
                std::panic::resume_unwind(Box::new(ProjectFailed("lens file unreadable".into())));
            }
            panic!("one ray only");
        }
    }

    #[test]
    fn a_reported_error_is_not_a_panic() {
        let s = [Point2::ZERO; 2];
        let (mut t, mut r, mut c) = ([0.0; 2], [good(); 2], [Rgb::WHITE; 2]);
        let mut ctx = ProjectionContext::new(&s, &s, &s, &mut t, &mut r, &mut c).unwrap();
        let loss = call_project(&Fails, &mut ctx).unwrap_err();
        assert_eq!(loss, Loss::Failed("lens file unreadable".into()));
        assert_eq!(loss.violation(), Violation::Failed);
        let mut ctx =
            ProjectionContext::new(&s[..1], &s[..1], &s[..1], &mut t[..1], &mut r[..1], &mut c[..1]).unwrap();
        assert_eq!(
            call_project(&Fails, &mut ctx).unwrap_err().detail(),
            "panicked: one ray only"
        );
    }
}
