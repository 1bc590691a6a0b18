//! The host's half of the projection contract: asking a projection's properties and filling in the
//! host's defaults ([`ask_property`], [`Properties`]), the default rays a host pre-fills
//! ([`DefaultRays`]), and calling `project` with a lost batch classed ([`call_project`], [`Loss`]).
//!
//! The rules themselves — the per-ray rules and tolerances, the clipping distances, the property
//! domains — are the SDK's [`obscura_sdk::contract`], which a plugin author's tests use too; this
//! module is what only a host needs: the camera stage ([`crate::driver`]), the checker
//! (`obscura-check`) and the plugin adapters (`obscura-plugins`, which raise [`ProjectFailed`] and
//! [`UndecodableProperty`]).
//!
//! # What `project` finds in the batch
//!
//! Before `project`, a host pre-fills every ray with [`DefaultRays`] (the renderer's own camera ray,
//! built from the projection's [`Properties`]) and every tint with white, so a projection may be a
//! *modifier* that only rewrites time or tint (RenderMan's PxrRollingShutter).
//!
//! # Lost batches
//!
//! A whole batch is lost when `project` panics ([`Violation::Panicked`]) or, for a plugin loaded
//! through the C ABI, returns `OBSCURA_ERROR` ([`Violation::Failed`]); see [`call_project`].

use std::any::Any;
use std::panic::{AssertUnwindSafe, catch_unwind};

use obscura_sdk::contract::{Violation, expected_type, value_domain, value_in_domain};
use obscura_sdk::optics::{OrthographicRays, PerspectiveRays, screen_distance};
use obscura_sdk::{
    DeepMetric, DicingHint, Point2, Projection, ProjectionContext, ProjectionEnvironment, ProjectionProperty,
    PropertyValue, RayGeometry, SoaContext,
};

/// The widest field of view, in degrees, of the host's pinhole default ray (a pinhole cannot show 180°;
/// wider projections write their own rays).
pub const MAX_DEFAULT_FOV: f32 = 179.0;

/// The field of view, in degrees, of the default ray of a projection that reports none.
pub const DEFAULT_FOV: f32 = 90.0;

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
/// projection plugin"). Clipping distances follow
/// [`clipping_distances`](obscura_sdk::contract::clipping_distances) for the deep metric.
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

    /// [`DefaultRays::ray`] of every `screen[i]` through `aperture[i]` into `rays[i]` (the three of
    /// one length), the same bits: the kind of ray and the lens chosen once for the batch, so each
    /// case is a plain loop the vectoriser can widen (callers run it inside `obscura_sdk::simd::run`).
    #[inline(always)]
    pub fn fill(&self, screen: &[Point2], aperture: &[Point2], rays: &mut [RayGeometry]) {
        match self {
            DefaultRays::Perspective { rays: p, d, spheres } => {
                let (d, spheres) = (*d, *spheres);
                let clip = move |mut r: RayGeometry| {
                    if spheres {
                        (r.min_dist, r.max_dist) = (p.near, p.far);
                    }
                    r
                };
                if p.lens_radius > 0.0 {
                    for ((r, s), a) in rays.iter_mut().zip(screen).zip(aperture) {
                        *r = clip(p.thin_lens(*s, *a, d));
                    }
                } else {
                    for (r, s) in rays.iter_mut().zip(screen) {
                        *r = clip(p.pinhole(*s, d));
                    }
                }
            }
            DefaultRays::Orthographic { .. } => {
                for ((r, s), a) in rays.iter_mut().zip(screen).zip(aperture) {
                    *r = self.ray(*s, *a);
                }
            }
        }
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
    catch_loss(|| p.project(ctx))
}

/// Calls `project_soa`, catching a panic as [`call_project`] does: `Ok(true)` when the projection
/// wrote the batch, `Ok(false)` when it does not offer the structure-of-arrays path.
///
/// # Errors
/// The [`Loss`] of the batch.
pub fn call_project_soa(p: &dyn Projection, ctx: &mut SoaContext<'_>) -> Result<bool, Loss> {
    catch_loss(|| p.project_soa(ctx))
}

fn catch_loss<R>(call: impl FnOnce() -> R) -> Result<R, Loss> {
    catch_unwind(AssertUnwindSafe(call)).map_err(|payload| match payload.downcast_ref::<ProjectFailed>() {
        Some(f) => Loss::Failed(f.0.clone()),
        None => Loss::Panicked(panic_message(payload.as_ref())),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::contract::clipping_distances;
    use obscura_sdk::{Format, Rgb, ScreenWindow};

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
            ScreenWindow::default_for(Format::new(8, 8)),
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

    #[test]
    fn fill_gives_the_bits_of_ray_at_every_simd_tier() {
        let env = ProjectionEnvironment::new(
            Format::new(64, 48),
            ScreenWindow::default_for(Format::new(64, 48)),
            (0.0, 1.0),
            (0.5, 20.0),
            Vec::new(),
        );
        let screen: Vec<Point2> = (0..203)
            .map(|i| Point2::new((i % 17) as f32 / 8.0 - 1.0, (i % 13) as f32 / 6.0 - 1.0))
            .collect();
        let aperture: Vec<Point2> = (0..203)
            .map(|i| Point2::new((i % 7) as f32 / 3.5 - 1.0, (i % 5) as f32 / 2.5 - 1.0))
            .collect();
        for (hint, metric, lens) in [
            (DicingHint::Perspective, DeepMetric::CameraZ, false),
            (DicingHint::Perspective, DeepMetric::CameraZ, true),
            (DicingHint::Perspective, DeepMetric::RayLength, true),
            (DicingHint::Orthographic, DeepMetric::CameraZ, true),
            (DicingHint::Orthographic, DeepMetric::RayLength, false),
        ] {
            let props = Properties {
                dicing_hint: hint,
                deep_metric: metric,
                field_of_view: Some(50.0),
                f_stop: lens.then_some(2.0),
                focal_length: lens.then_some(0.1),
                focal_distance: lens.then_some(4.0),
            };
            let defaults = DefaultRays::new(&props, &env);
            for level in obscura_sdk::simd::Level::ALL {
                let mut rays = vec![RayGeometry::CULLED; screen.len()];
                obscura_sdk::simd::run_at(level, || defaults.fill(&screen, &aperture, &mut rays));
                for (i, r) in rays.iter().enumerate() {
                    let want = defaults.ray(screen[i], aperture[i]);
                    assert_eq!(
                        r.to_bits(),
                        want.to_bits(),
                        "{hint:?} {metric:?} lens {lens} {level:?} ray {i}"
                    );
                }
            }
        }
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
        let (mut t, mut r, mut c) = ([0.0; 2], [RayGeometry::default(); 2], [Rgb::WHITE; 2]);
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
