//! `Panicking`: a deliberately broken Rust projection plugin for the host's ABI tests.
//!
//! It is a modifier (RenderMan's sense): it reports a 90° field of view and leaves the host's default
//! pinhole rays alone, except that `project` panics whenever its batch holds a screen sample with
//! `sx > panicAbove`. The host must report the panic, cull and count that batch's samples, and keep
//! rendering the other batches. Its `unproject` (the 90° pinhole's inverse, `(x/z, y/z)`) panics in
//! the same region, so `obscura stmap --from Panicking` must count the pixels and go on.

#![forbid(unsafe_code)]

use std::sync::LazyLock;

use obscura_sdk::{
    ParamDecl, ParamList, Params, PluginError, Point2, Projection, ProjectionContext, ProjectionEnvironment,
    ProjectionFactory, ProjectionProperty, PropertyValue, Vec3,
};

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    vec![
        ParamDecl::float("panicAbove", 0.5)
            .doc("project (on a batch) and unproject panic at a screen x above this"),
    ]
});

/// Creates [`Panicking`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct PanickingFactory;

impl ProjectionFactory for PanickingFactory {
    fn name(&self) -> &str {
        "Panicking"
    }

    fn summary(&self) -> &str {
        "test plugin: panics in project on batches right of panicAbove"
    }

    fn param_table(&self) -> &[ParamDecl] {
        &TABLE
    }

    fn create_projection(
        &self,
        _env: &mut ProjectionEnvironment,
        params: &ParamList,
    ) -> Result<Box<dyn Projection>, PluginError> {
        let p = Params::resolve("Panicking", &TABLE, params)?;
        Ok(Box::new(Panicking {
            above: p.float("panicAbove")?,
        }))
    }
}

/// Panics on batches reaching right of `above`.
#[derive(Debug, Clone, Copy)]
pub struct Panicking {
    above: f32,
}

impl Projection for Panicking {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        (property == ProjectionProperty::FieldOfView).then_some(PropertyValue::Float(90.0))
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        if let Some(s) = ctx.screen().iter().find(|s| s.x > self.above) {
            panic!("deliberate panic at screen x {}", s.x);
        }
    }

    fn unproject(&self, point: Vec3, _time: f32) -> Option<Point2> {
        if point.z <= 0.0 {
            return None;
        }
        let s = Point2::new(point.x / point.z, point.y / point.z);
        assert!(
            s.x <= self.above,
            "deliberate panic in unproject at screen x {}",
            s.x
        );
        Some(s)
    }
}

obscura_sdk::export_projection!(PanickingFactory);
