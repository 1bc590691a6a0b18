//! `PxrOrthographic`: parallel rays, with optional thin-lens depth of field.
//!
//! Mapping, for screen sample `(sx, sy)` and aperture sample `(ax, ay) ∈ [−1, 1]²`:
//!
//! - without depth of field: `O = (sx, sy, 0)`, `D = (0, 0, 1)`;
//! - with a thin lens (finite positive `fStop`, positive `focalLength`, `R = ½·focalLength/fStop`): the
//!   lens is centred on the pixel's own origin, `O = (sx + R·ax, sy + R·ay, 0)`,
//!   `D = normalize((sx, sy, focalDistance) − O)`, so every ray of one screen point meets the plane
//!   `z = focalDistance` at `(sx, sy)` (pbrt-v3 centred the lens on the axis instead: its issue 315);
//! - footprint: `origin_radius = ½·sqrt(Δx·Δy)` (half a pixel, screen units are camera units here),
//!   `ray_spread = 0`;
//! - clipping: `min_dist = near/D.z`, `max_dist = far/D.z`.
//!
//! The view size is the screen window: a window `[−2, 2]²` sees a 4 × 4 region of camera space.
//!
//! Inverse: a camera-space point `P` with `P.z > 0` is seen at `(P.x, P.y)`.
//!
//! Properties: DicingHint Orthographic; DeepMetric CameraZ; no FieldOfView (an orthographic camera has
//! none); FStop, FocalLength, FocalDistance when depth of field is on.

use std::sync::LazyLock;

use obscura_sdk::optics::OrthographicRays;
use obscura_sdk::{
    DeepMetric, DicingHint, ParamDecl, Point2, Projection, ProjectionContext, ProjectionEnvironment,
    ProjectionProperty, PropertyValue, Vec3,
};

use crate::dof::{self, DepthOfField};
use crate::screen;

/// The name scenes use.
pub const NAME: &str = "PxrOrthographic";

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| dof::params().to_vec());

/// Creates [`Orthographic`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct OrthographicFactory;

projection_factory!(
    OrthographicFactory,
    "parallel rays O = (sx, sy, 0), D = +Z; thin-lens depth of field centred on each pixel",
    |env, p| {
        env.set_deep_metric(DeepMetric::CameraZ);
        Ok(Box::new(Orthographic::new(env, DepthOfField::from_params(p)?)))
    }
);

/// An orthographic camera (see the module documentation for its mapping).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orthographic {
    rays: OrthographicRays,
    dof: DepthOfField,
}

impl Orthographic {
    /// An orthographic camera for `env`, with a thin lens when `dof` is on.
    #[must_use]
    pub fn new(env: &ProjectionEnvironment, dof: DepthOfField) -> Self {
        Orthographic {
            rays: OrthographicRays::new(
                env.pixel_size(),
                (env.clipping_near(), env.clipping_far()),
                dof.lens_radius(),
                dof.focal_distance,
            ),
            dof,
        }
    }
}

impl Projection for Orthographic {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        match property {
            ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(DicingHint::Orthographic)),
            ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(DeepMetric::CameraZ)),
            other => self.dof.property(other),
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let rays = &self.rays;
        screen::map_rays_with_aperture(ctx, |s, a| rays.ray(s, a));
    }

    fn unproject(&self, point: Vec3, _time: f32) -> Option<Point2> {
        (point.z > 0.0 && point.is_finite()).then(|| Point2::new(point.x, point.y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{assert_camera_z, project_points};
    use obscura_sdk::{Format, ParamList, ProjectionFactory, ScreenWindow};
    use proptest::prelude::*;

    fn make(params: &[(&str, &str)]) -> Box<dyn Projection> {
        let mut list = ParamList::new();
        for (decl, val) in params {
            list.push_text(decl, &[val], None).unwrap();
        }
        let mut env = ProjectionEnvironment::new(
            Format::new(200, 100),
            ScreenWindow::new(-4.0, 4.0, -2.0, 2.0),
            (0.0, 1.0),
            (0.1, f32::INFINITY),
            Vec::new(),
        );
        OrthographicFactory.create_projection(&mut env, &list).unwrap()
    }

    proptest! {
        #[test]
        fn rays_are_parallel_and_start_on_the_screen_point(sx in -4.0f32..4.0, sy in -2.0f32..2.0) {
            let p = make(&[]);
            let r = project_points(p.as_ref(), &[Point2::new(sx, sy)], &[Point2::new(0.3, 0.3)], &[0.0])[0];
            prop_assert_eq!(r.origin, Vec3::new(sx, sy, 0.0));
            prop_assert_eq!(r.direction, Vec3::Z);
            prop_assert_eq!(r.ray_spread, 0.0);
            // Half a pixel: the window is 8 units over 200 pixels and 4 over 100, so 0.04 units a pixel.
            prop_assert!((r.origin_radius - 0.02).abs() < 1e-7);
            prop_assert_eq!(p.unproject(r.origin + r.direction * 3.0, 0.0), Some(Point2::new(sx, sy)));
        }

        #[test]
        fn the_lens_is_centred_on_each_pixel_not_on_the_axis(
            sx in -4.0f32..4.0, sy in -2.0f32..2.0, ax in -1.0f32..1.0, ay in -1.0f32..1.0,
        ) {
            let p = make(&[("float fStop", "2"), ("float focalLength", "1"), ("float focalDistance", "5")]);
            let r = project_points(p.as_ref(), &[Point2::new(sx, sy)], &[Point2::new(ax, ay)], &[0.0])[0];
            // Radius 0.25 around the pixel's own origin.
            prop_assert!((r.origin.x - (sx + 0.25 * ax)).abs() < 1e-5 && (r.origin.y - (sy + 0.25 * ay)).abs() < 1e-5);
            // Every ray of a screen point meets the focal plane at that screen point.
            let t = 5.0 / r.direction.z;
            let hit = r.origin + r.direction * t;
            prop_assert!((hit.x - sx).abs() < 1e-4 && (hit.y - sy).abs() < 1e-4, "{:?}", hit);
            prop_assert!((r.direction.length() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn properties_are_honest() {
        let p = make(&[]);
        assert_camera_z(p.as_ref(), DicingHint::Orthographic, None);
        assert_eq!(p.property(ProjectionProperty::FieldOfView), None);
        assert_eq!(p.property(ProjectionProperty::FStop), None);
        let lens = make(&[("float fStop", "2"), ("float focalLength", "1")]);
        assert_eq!(
            lens.property(ProjectionProperty::FStop),
            Some(PropertyValue::Float(2.0))
        );
    }
}
