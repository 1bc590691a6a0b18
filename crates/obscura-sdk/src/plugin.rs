//! The two traits a projection implements (`RixProjectionFactory`, `RixProjection`).

use crate::context::ProjectionContext;
use crate::environment::ProjectionEnvironment;
use crate::geometry::{Point2, Vec3};
use crate::param::{ParamDecl, ParamError, ParamList};
use crate::property::{ProjectionProperty, PropertyValue};
use crate::soa::SoaContext;

/// What the host tells a factory through [`ProjectionFactory::synchronize`] (`RixSCSyncMsg`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(C)]
pub enum SyncMessage {
    /// A render is about to start (`k_RixSCRenderBegin`).
    RenderBegin = 0,
    /// A render has ended (`k_RixSCRenderEnd`).
    RenderEnd = 1,
    /// A projection's parameters were edited in an interactive session (`k_RixSCInstanceEdit`).
    InstanceEdit = 2,
}

/// Why a factory could not initialise or create a projection.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PluginError {
    /// A parameter did not fit the table (boxed: errors stay small on the success path).
    #[error(transparent)]
    Param(Box<ParamError>),
    /// The parameters fit the table but describe no valid camera (three collinear focus points, …).
    #[error("{plugin}: {message}")]
    Invalid {
        /// The projection.
        plugin: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// `init` failed.
    #[error("{plugin}: initialisation failed: {message}")]
    Init {
        /// The projection.
        plugin: String,
        /// Why.
        message: String,
    },
    /// No projection of that name is registered.
    #[error("unknown projection \"{name}\"{hint}; known projections: {known}",
        hint = suggestion.as_ref().map(|s| format!(" (did you mean \"{s}\"?)")).unwrap_or_default(),
        known = known.join(", "))]
    Unknown {
        /// The name asked for.
        name: String,
        /// The closest registered name.
        suggestion: Option<String>,
        /// Every registered name.
        known: Vec<String>,
    },
}

impl From<ParamError> for PluginError {
    fn from(e: ParamError) -> Self {
        PluginError::Param(Box::new(e))
    }
}

/// A camera model, created once per camera per render (`RixProjection`).
///
/// `project` is called from many threads at once on disjoint batches, so it takes `&self` and the
/// type must be `Send + Sync`: keep per-render constants in the struct, nothing mutable.
///
/// A projection answers the host's [`property`](Projection::property) questions at render start (the
/// answers are invariant for the frame), turns each batch of samples into rays in
/// [`project`](Projection::project), and may offer the exact inverse in
/// [`unproject`](Projection::unproject).
pub trait Projection: Send + Sync {
    /// Answers a property query: `Some(value)` is RenderMan's `k_RixSCUniform`, `None` is
    /// `k_RixSCInvalidDetail` ("not supported"). The value's variant must match the property
    /// ([`ProjectionProperty::accepts`]); hosts reject a mismatch with a warning.
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue>;

    /// Turns one batch of samples into camera rays (`RixProjection::Project`).
    ///
    /// The rays arrive pre-filled with the host's default camera ray and the tints with white, so a
    /// *modifier* may rewrite only `time` or `tint`. Every direction written must be unit length, or
    /// exactly zero to cull the sample; every time must stay in `[0, 1)`.
    fn project(&self, ctx: &mut ProjectionContext<'_>);

    /// Turns one batch of samples into rays written field by field ([`SoaContext`]): the
    /// structure-of-arrays form a consumer such as numpy wants, with no per-ray record built and
    /// copied. Returns `true` when this projection wrote **every field of every ray** (the rays arrive
    /// unfilled, unlike `project`'s) and `false` when it does not offer this path — the default —
    /// and then the host runs [`project`](Projection::project) and scatters its records.
    ///
    /// The rays written must be the ones `project` writes for the same samples, bit for bit (tests
    /// hold the built-ins to this); times and tints follow `project`'s rules. A consumer that reads
    /// only some fields says so ([`SoaContext::fields`]); a projection may then skip the others'
    /// arrays, or write them all as when every field is asked for. A projection that edits
    /// the host's pre-filled rays (a modifier) must keep the default.
    fn project_soa(&self, ctx: &mut SoaContext<'_>) -> bool {
        let _ = ctx;
        false
    }

    /// The exact inverse of `project` for the ray through a camera-space point: the screen position
    /// whose (lens-centre) ray passes through `point` at shutter-normalised `time`, or `None` when the
    /// point is outside the field of view. The default is `None` everywhere: no inverse offered.
    fn unproject(&self, point: Vec3, time: f32) -> Option<Point2> {
        let _ = (point, time);
        None
    }
}

/// The plugin object that creates projections (`RixProjectionFactory`, a `RixShadingPlugin`).
///
/// Lifecycle, as in RenderMan: [`init`](ProjectionFactory::init) once per session before the first
/// projection is created, [`synchronize`](ProjectionFactory::synchronize) with render begin/end and edits,
/// [`create_projection`](ProjectionFactory::create_projection) per camera, and
/// [`finalize`](ProjectionFactory::finalize) once at the end.
///
/// There is no `create_instance_data`: RenderMan's document says projections have no lightweight
/// instances and any instance data would never be handed back to the factory, so Obscura does not
/// offer the hook at all rather than offer one that silently does nothing. Everything a projection
/// needs per camera goes into the object `create_projection` returns.
pub trait ProjectionFactory: Send + Sync {
    /// The name scenes use (`PxrPerspective`).
    fn name(&self) -> &str;

    /// One line saying what the projection is, for `obscura plugins`.
    fn summary(&self) -> &str;

    /// Further lines `obscura plugins` prints after the parameter table, for what one line per
    /// parameter cannot say (e.g. which values a list parameter holds for each choice of another).
    /// None by default.
    fn listing_notes(&self) -> Vec<String> {
        Vec::new()
    }

    /// The parameter table (`GetParamTable`): every parameter the projection takes.
    fn param_table(&self) -> &[ParamDecl];

    /// Called once per session before the first `create_projection` (`Init`). `plugin_path` is the
    /// file the plugin was loaded from, or empty for a built-in.
    ///
    /// # Errors
    /// [`PluginError::Init`] when the plugin cannot work in this session.
    fn init(&mut self, plugin_path: &str) -> Result<(), PluginError> {
        let _ = plugin_path;
        Ok(())
    }

    /// Called once at the end of the session (`Finalize`).
    fn finalize(&mut self) {}

    /// Renderer signals (`Synchronize`); doing nothing is legal.
    fn synchronize(&mut self, message: SyncMessage, params: Option<&ParamList>) {
        let _ = (message, params);
    }

    /// Creates the projection for one camera (`CreateProjection`). `env` is read-only but for its deep
    /// metric, which the projection may set.
    ///
    /// # Errors
    /// A [`PluginError`] naming the projection and the parameter when the parameters are wrong.
    fn create_projection(
        &self,
        env: &mut ProjectionEnvironment,
        params: &ParamList,
    ) -> Result<Box<dyn Projection>, PluginError>;
}
