//! `MirrorBall`: the picture of a perfectly reflecting sphere, as in a light-probe photograph.
//!
//! # Mapping
//!
//! The ball fills the unit circle `sx² + sy² < 1` of screen space (with the default screen window it
//! touches the shorter image edges) and is seen orthographically by a viewer looking down **+Z**, as
//! the camera that photographed a light probe saw it. The ball's surface normal under screen point
//! `s = (sx, sy)`, on the hemisphere facing the viewer, and the reflected view direction are
//!
//! ```text
//! N = (sx, sy, −c),   c = sqrt(1 − sx² − sy²)
//! D = reflect(V, N) = V − 2(V·N)·N,   V = (0, 0, 1)
//!   = (2c·sx,  2c·sy,  1 − 2c²)
//! ```
//!
//! So the centre of the ball reflects **−Z**, the direction toward the camera that took the photo;
//! the angle from −Z is `γ = 2·asin(r)` (`r = |s|`), and the rim `r → 1` is the direction straight
//! behind the ball, +Z. Screen +x shows camera +X and screen +y camera +Y (the ball's right side
//! reflects what is to the photographer's right). The rim itself, where the whole circle would
//! collapse onto +Z, is left out: samples with `r ≥ 1` get the zero direction (culled).
//!
//! # Footprint
//!
//! With `A = dγ/dr = 2/c` (radial) and `B = sin γ / r = 2c` (tangential), for a pixel of `Δx × Δy`
//! screen units
//!
//! ```text
//! αx = Δx·sqrt(A²·sx² + B²·sy²)/r,   αy = Δy·sqrt(A²·sy² + B²·sx²)/r,   ray_spread = ½·sqrt(αx·αy)
//! ```
//!
//! (`αx = 2Δx`, `αy = 2Δy` at the centre). `A` is infinite at the rim; within a hundredth of a pixel
//! of it `c` is held at its value there. `origin_radius = 0`; clipping is spherical:
//! `min_dist = near`, `max_dist = far`.
//!
//! # Inverse
//!
//! A camera-space point with unit direction `(x, y, z)`, `z < 1`, is seen at
//! `s = (x, y)/sqrt(2·(1 − z))` (so `r² = (1 + z)/2 < 1`); +Z itself (the rim) and the origin give
//! `None`.
//!
//! # Properties
//!
//! DicingHint Spherical; DeepMetric RayLength (the ball sees every direction); FieldOfView 360.

use obscura_sdk::{
    DeepMetric, ParamDecl, ParamList, Params, PluginError, Point2, Projection, ProjectionContext,
    ProjectionEnvironment, ProjectionFactory, ProjectionProperty, PropertyValue, RayGeometry, Vec3,
};

use crate::simd;
use crate::sphere::{SphericalClip, spherical_property};

/// The name scenes use.
pub const NAME: &str = "MirrorBall";

/// Creates [`MirrorBall`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct MirrorBallFactory;

impl ProjectionFactory for MirrorBallFactory {
    fn name(&self) -> &str {
        NAME
    }

    fn summary(&self) -> &str {
        "light-probe mirror ball in the unit circle: D = reflect(+Z, N); centre looks back at -Z, rim at +Z"
    }

    fn param_table(&self) -> &[ParamDecl] {
        &[]
    }

    fn create_projection(
        &self,
        env: &mut ProjectionEnvironment,
        params: &ParamList,
    ) -> Result<Box<dyn Projection>, PluginError> {
        Params::resolve(NAME, &[], params)?;
        env.set_deep_metric(DeepMetric::RayLength);
        Ok(Box::new(MirrorBall::new(env)))
    }
}

/// A mirror-ball camera (see the module documentation for its mapping).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MirrorBall {
    half_pixel: f32,
    /// The least `c` used for the radial derivative: its value a hundredth of a pixel inside the rim.
    c_floor: f32,
    clip: SphericalClip,
}

impl MirrorBall {
    /// A mirror ball for `env`.
    #[must_use]
    pub fn new(env: &ProjectionEnvironment) -> Self {
        let (dx, dy) = env.pixel_size();
        let eps = 0.01 * f64::from(dx.min(dy));
        MirrorBall {
            half_pixel: 0.5 * (dx * dy).sqrt(),
            c_floor: (eps * (2.0 - eps)).max(0.0).sqrt() as f32,
            clip: SphericalClip::new(env),
        }
    }

    #[inline(always)]
    fn ray(&self, s: Point2) -> RayGeometry {
        let (x2, y2) = (s.x * s.x, s.y * s.y);
        let r2 = x2 + y2;
        if r2.is_nan() || r2 >= 1.0 {
            return RayGeometry::CULLED;
        }
        let c2 = 1.0 - r2;
        let c = c2.sqrt();
        let a = 2.0 / c.max(self.c_floor);
        let b = 2.0 * c;
        let (a2, b2) = (a * a, b * b);
        let (ax2, ay2) = if r2 > 0.0 {
            let inv = 1.0 / r2;
            ((a2 * x2 + b2 * y2) * inv, (a2 * y2 + b2 * x2) * inv)
        } else {
            (a2, a2)
        };
        self.clip.centred_ray(
            Vec3::new(b * s.x, b * s.y, 1.0 - 2.0 * c2),
            self.half_pixel * (ax2 * ay2).sqrt().sqrt(),
        )
    }
}

impl Projection for MirrorBall {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        spherical_property(property, 360.0)
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        simd::map_screen(c.rays, c.screen, |s| self.ray(s));
    }

    fn unproject(&self, point: Vec3, _time: f32) -> Option<Point2> {
        if !point.is_finite() {
            return None;
        }
        let (x, y, z) = (f64::from(point.x), f64::from(point.y), f64::from(point.z));
        let len = (x * x + y * y + z * z).sqrt();
        let rho2 = x * x + y * y;
        if rho2 == 0.0 && z >= 0.0 {
            return None;
        }
        // 1 − z of the unit direction, without cancellation when z is near 1.
        let one_minus_z = if z > 0.0 {
            rho2 / (len * (len + z))
        } else {
            1.0 - z / len
        };
        let k = 1.0 / (len * (2.0 * one_minus_z).sqrt());
        Some(Point2::new((x * k) as f32, (y * k) as f32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{self, ContractTest, assert_contract, assert_spherical_ray_length, ray_at};
    use obscura_sdk::Format;
    use proptest::prelude::*;

    fn make(format: Format) -> Box<dyn Projection> {
        testing::make(&MirrorBallFactory, &[], format)
    }

    #[test]
    fn keeps_the_contract() {
        for format in [Format::new(48, 32), Format::new(27, 40), Format::new(33, 33)] {
            let stats = assert_contract(make(format).as_ref(), &ContractTest::new(format));
            assert!(
                stats.backward > 0 && stats.valid < stats.samples && stats.roundtrips > 300,
                "{stats:?}"
            );
        }
    }

    proptest! {
        #[test]
        fn directions_are_the_reflection_of_the_view_in_the_ball(sx in -1.0f32..1.0, sy in -1.0f32..1.0) {
            let r2 = f64::from(sx).powi(2) + f64::from(sy).powi(2);
            prop_assume!(r2 < 0.999_999);
            let d = ray_at(make(Format::new(64, 64)).as_ref(), Point2::new(sx, sy)).direction;
            // Independently: reflect V = +Z in N = (sx, sy, −sqrt(1 − r²)).
            let n = [f64::from(sx), f64::from(sy), -(1.0 - r2).sqrt()];
            let v_dot_n = n[2];
            let expected = [-2.0 * v_dot_n * n[0], -2.0 * v_dot_n * n[1], 1.0 - 2.0 * v_dot_n * n[2]];
            // Near the rim the direction turns 2/c times faster than the screen point moves, so one
            // rounding of r² in f32 moves it by about 1e-7/c.
            let tol = 1e-6 / (1.0 - r2).sqrt();
            for (got, want) in [d.x, d.y, d.z].iter().zip(expected) {
                prop_assert!((f64::from(*got) - want).abs() < tol, "{:?} vs {:?}", d, expected);
            }
            // The angle from −Z is 2·asin(r).
            let gamma = f64::from(d.x).hypot(f64::from(d.y)).atan2(-f64::from(d.z));
            prop_assert!((gamma - 2.0 * r2.sqrt().asin()).abs() < 1e-5);
        }

        #[test]
        fn unproject_inverts_project(sx in -1.0f32..1.0, sy in -1.0f32..1.0, depth in 0.01f32..1000.0) {
            let r2 = f64::from(sx).powi(2) + f64::from(sy).powi(2);
            prop_assume!(r2 < 0.998);
            let format = Format::new(640, 360);
            let p = make(format);
            let ray = ray_at(p.as_ref(), Point2::new(sx, sy));
            let back = p.unproject(ray.direction * depth, 0.0).unwrap();
            let px = 2.0 / 360.0;
            prop_assert!(((back.x - sx) / px).abs() < 1e-4 && ((back.y - sy) / px).abs() < 1e-4, "{:?}", back);
        }
    }

    #[test]
    fn the_centre_looks_back_at_the_camera_and_the_rim_behind_the_ball() {
        let p = make(Format::new(64, 64));
        assert_eq!(
            ray_at(p.as_ref(), Point2::ZERO).direction,
            Vec3::new(0.0, 0.0, -1.0)
        );
        let near_rim = ray_at(p.as_ref(), Point2::new(0.0, 0.999_99)).direction;
        assert!(near_rim.z > 0.999 && near_rim.y > 0.0, "{near_rim:?}");
        // r = sin 45°: the normal is at 45°, the reflection at 90°, straight to the right.
        let side = ray_at(p.as_ref(), Point2::new(std::f32::consts::FRAC_1_SQRT_2, 0.0)).direction;
        assert!((side.x - 1.0).abs() < 1e-6 && side.z.abs() < 1e-6, "{side:?}");
        for s in [
            Point2::new(0.0, 1.0),
            Point2::new(1.0, 0.0),
            Point2::new(0.8, 0.7),
            Point2::new(-1.5, 1.0),
        ] {
            assert_eq!(ray_at(p.as_ref(), s), RayGeometry::CULLED, "{s:?}");
        }
        assert_eq!(p.unproject(Vec3::new(0.0, 0.0, 5.0), 0.0), None);
        assert_eq!(p.unproject(Vec3::ZERO, 0.0), None);
        assert_eq!(p.unproject(Vec3::new(0.0, 0.0, -2.0), 0.0), Some(Point2::ZERO));
    }

    #[test]
    fn properties_are_honest() {
        let p = make(Format::new(8, 8));
        assert_spherical_ray_length(p.as_ref(), None, Some(360.0));
        let err = testing::try_make(&MirrorBallFactory, &[("float fov", "90")], Format::new(8, 8))
            .err()
            .unwrap()
            .to_string();
        assert!(err.starts_with("MirrorBall: unknown parameter \"fov\""), "{err}");
    }
}
