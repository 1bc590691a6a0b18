//! The projection contract's rules, written once: what a host accepts back from `project`, the
//! clipping distances on each ray, and what each property's answer may be.
//!
//! Every place that enforces or checks the contract calls this module: the host's camera stage
//! (`obscura rays`, `obscura render`), the checker (`obscura check`, the `obscura-check` crate) and the
//! built-in projections' tests. So one bad ray is classed the same way everywhere. The host's half of
//! the contract — calling `project` and classing a lost batch, asking the properties and filling in
//! their defaults, pre-filling the default rays — is `obscura_host::contract`: a plugin never calls it.
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
//! through the C ABI, returns `OBSCURA_ERROR` ([`Violation::Failed`]); the host's `call_project` tells
//! the two apart.
//!
//! # What `project` finds in the batch
//!
//! Before `project`, a host pre-fills every ray with its own camera ray (built from the projection's
//! properties, with the defaults for what it leaves unanswered) and every tint with white, so a
//! projection may be a *modifier* that only rewrites time or tint (RenderMan's PxrRollingShutter).
//!
//! # Clipping distances
//!
//! `min_dist` and `max_dist` put the environment's clipping range on each ray, by the projection's deep
//! metric ([`clipping_distances`]): for [`DeepMetric::CameraZ`] they are where the ray meets the
//! clipping *planes* `z = near` and `z = far`; for [`DeepMetric::RayLength`] they are `near` and `far`
//! themselves (clipping *spheres*: distances along the ray). The default rays follow the same rule.
//!
//! # Property answers
//!
//! A property's answer is used only when it has the property's type ([`expected_type`]) and, for a
//! float, lies in its domain ([`value_in_domain`], [`value_domain`]).

use crate::geometry::{Rgb, Vec3};
use crate::property::{DeepMetric, ProjectionProperty};
use crate::ray::RayGeometry;

/// A unit direction may be off by this much in length (f32 normalisation is good to ~10⁻⁷).
pub const UNIT_TOLERANCE: f32 = 1e-3;

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

    /// Whether this is a per-ray rule, one [`check_ray`] applies to each ray; the two others,
    /// [`Violation::Panicked`] and [`Violation::Failed`], lose a whole batch.
    #[must_use]
    pub fn is_per_ray(self) -> bool {
        !matches!(self, Violation::Panicked | Violation::Failed)
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
// Property answers.

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

#[cfg(test)]
mod tests {
    use super::*;

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
    fn every_rule_but_the_two_batch_losses_is_per_ray_and_after_them() {
        let losses: Vec<_> = Violation::ALL.into_iter().filter(|v| !v.is_per_ray()).collect();
        assert_eq!(losses, [Violation::Panicked, Violation::Failed]);
        assert!(Violation::ALL[2..].iter().all(|v| v.is_per_ray()));
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
}
