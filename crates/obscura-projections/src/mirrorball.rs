//! `MirrorBall`: the picture of a perfectly reflecting sphere, oriented as Cycles' mirror-ball panorama
//! (the default) or as a light-probe photograph.
//!
//! # Mapping
//!
//! The ball fills the unit circle `sx² + sy² < 1` of screen space (with the default screen window it
//! touches the shorter image edges) and is seen orthographically, by a viewer looking down `V = −σ·Z`.
//! Under screen point `s = (sx, sy)`, `r = |s|`, the ball's surface facing that viewer has the normal
//! `N = (sx, sy, σ·c)` with `c = sqrt(1 − r²)`, and the ray's direction is `V` reflected in it:
//!
//! ```text
//! D = reflect(−σ·Z, N) = −σ·Z − 2((−σ·Z)·N)·N
//!   = (2c·sx,  2c·sy,  σ·(2c² − 1)) = (2c·sx,  2c·sy,  σ·(1 − 2r²))
//! ```
//!
//! with `σ` set by the `orientation` parameter:
//!
//! - `"camera"` (default), `σ = +1`: Cycles' `mirrorball_to_direction` (sphere point
//!   `(2u − 1, −c, 2v − 1)`, `I = (0, −1, 0)`, `D = 2(N·I)·N − I`) turned into this camera space by
//!   Blender's mirror-ball camera matrix (its panorama `(x, y, z)` is our `(x, z, −y)`). The viewer
//!   looks back at the ball down −Z, so the centre of the ball shows **+Z**, our camera's view
//!   direction; the angle from +Z is `γ = 2·asin(r)`, and the rim `r → 1` is −Z, straight behind the
//!   camera. Near the centre this is a pinhole of focal length ½: `D ≈ (2·sx, 2·sy, 1)`.
//! - `"lightprobe"`, `σ = −1`: the ball as the camera that photographed a light probe saw it, looking
//!   down +Z at it. The centre reflects **−Z**, back toward that camera; the angle from −Z is
//!   `γ = 2·asin(r)`, and the rim is +Z, straight behind the ball. Its directions are the default's
//!   mirrored in depth (`z → −z`) at every pixel.
//!
//! Either way screen +x shows camera +X and screen +y camera +Y. The rim itself, where the whole circle
//! would collapse onto the single direction `−σ·Z`, is left out: samples with `r ≥ 1` get the zero
//! direction (culled).
//!
//! # Footprint
//!
//! The map is radial about `σ·Z` with `A = dγ/dr = 2/c` (radial) and `B = sin γ/r = 2c` (tangential),
//! the same for both orientations, so for a pixel of `Δx × Δy` screen units
//!
//! ```text
//! αx = Δx·sqrt(A²·sx² + B²·sy²)/r,   αy = Δy·sqrt(A²·sy² + B²·sx²)/r,   ray_spread = ½·sqrt(αx·αy)
//! ```
//!
//! (`αx = 2Δx`, `αy = 2Δy` at the centre; [`crate::panorama`]'s radial maps). `A` is infinite at the
//! rim; within a hundredth of a pixel of it `c` is held at its value there. `origin_radius = 0`;
//! clipping is spherical: `min_dist = near`, `max_dist = far`.
//!
//! # Inverse
//!
//! A camera-space point with unit direction `(x, y, z)`, `σ·z > −1`, is seen at
//! `s = (x, y)/sqrt(2·(1 + σ·z))` (so `r² = (1 − σ·z)/2 < 1`); the rim direction `−σ·Z` and the origin
//! give `None`.
//!
//! # Properties
//!
//! Both orientations: DicingHint Spherical; DeepMetric RayLength (the ball sees every direction);
//! FieldOfView 360 (twice the 180° from the centre's direction to the rim's).

use std::sync::LazyLock;

use obscura_sdk::{ParamDecl, Point2, ProjectionEnvironment};

use crate::panorama::{CentredLane, SphericalClip, boxed_spherical, radial_lane, rim_cos_floor};
use crate::screen;

/// The name scenes use.
pub const NAME: &str = "MirrorBall";

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    vec![
        ParamDecl::string("orientation", Orientation::NAMES[0])
            .choices(&Orientation::NAMES)
            .doc(
                "camera (Cycles): the ball's centre looks down +Z, the view direction, its rim -Z; \
                 lightprobe: the centre looks back at -Z (toward the camera that photographed the ball), the rim +Z",
            ),
    ]
});

/// Which way the ball's picture faces: the sign `σ` of the module documentation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Orientation {
    /// Cycles' mirror-ball panorama: the centre looks down +Z, the rim −Z (`σ = +1`).
    #[default]
    Camera,
    /// A light-probe photograph: the centre looks back at −Z, the rim +Z (`σ = −1`).
    LightProbe,
}

impl Orientation {
    /// The spellings of the `orientation` parameter, the default first.
    pub const NAMES: [&'static str; 2] = ["camera", "lightprobe"];

    /// Reads an `orientation` value.
    #[must_use]
    pub fn parse(s: &str) -> Option<Orientation> {
        match s {
            "camera" => Some(Orientation::Camera),
            "lightprobe" => Some(Orientation::LightProbe),
            _ => None,
        }
    }

    /// `σ`: the z of the direction the ball's centre shows, `+1` or `−1`.
    #[must_use]
    pub fn sign(self) -> f32 {
        match self {
            Orientation::Camera => 1.0,
            Orientation::LightProbe => -1.0,
        }
    }
}

/// Creates [`MirrorBall`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct MirrorBallFactory;

projection_factory!(
    MirrorBallFactory,
    "mirror ball in the unit circle: D = (2c sx, 2c sy, sigma (1 - 2r^2)), c = sqrt(1 - r^2); orientation \
     camera (Cycles, sigma = +1: centre +Z, rim -Z) or lightprobe (sigma = -1: centre -Z, rim +Z)",
    |env, p| {
        let orientation = Orientation::parse(p.string("orientation")?).ok_or_else(|| {
            crate::invalid(NAME, "parameter \"orientation\": expected camera or lightprobe")
        })?;
        let ball = MirrorBall::new(env, orientation);
        boxed_spherical(NAME, env, Some(ball))
    }
);

/// A mirror-ball camera (see the module documentation for its mapping).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MirrorBall {
    orientation: Orientation,
    /// `σ`.
    sign: f32,
    half_pixel: f32,
    /// The least `c` used for the radial derivative: its value a hundredth of a pixel inside the rim.
    c_floor: f32,
    clip: SphericalClip,
}

impl MirrorBall {
    /// A mirror ball for `env` in `orientation`.
    #[must_use]
    pub fn new(env: &ProjectionEnvironment, orientation: Orientation) -> Self {
        MirrorBall {
            orientation,
            sign: orientation.sign(),
            half_pixel: screen::half_pixel(env),
            c_floor: rim_cos_floor(screen::rim_step(env)),
            clip: SphericalClip::new(env),
        }
    }

    /// The orientation this ball was made with.
    #[must_use]
    pub fn orientation(&self) -> Orientation {
        self.orientation
    }

    /// The ray of screen point `s` as a branch-free lane (culled where `valid` is false), for the
    /// batch loop of [`crate::screen::map_centred_rays`].
    #[inline(always)]
    fn lane(&self, s: Point2) -> CentredLane {
        let r2 = s.x * s.x + s.y * s.y;
        let c = (1.0 - r2).sqrt();
        let along_centre = self.sign * (1.0 - 2.0 * r2);
        let lane = radial_lane(
            self.half_pixel,
            s,
            r2,
            (2.0 * c, along_centre, 2.0 / c.max(self.c_floor)),
        );
        CentredLane {
            valid: r2 < 1.0,
            ..lane
        }
    }
}

spherical_projection!(MirrorBall, |_: &MirrorBall| 360.0, lanes);

impl MirrorBall {
    /// The screen point that sees the camera-space point `(x, y, z)`, finite: the inverse.
    fn screen_of(&self, x: f64, y: f64, z: f64) -> Option<Point2> {
        // The component along the centre's direction σ·Z.
        let zc = f64::from(self.sign) * z;
        let rho2 = x * x + y * y;
        if rho2 == 0.0 && zc <= 0.0 {
            return None;
        }
        let len = (rho2 + z * z).sqrt();
        // 1 + σ·z of the unit direction, without cancellation when it is near the rim's −σ·Z.
        let one_plus_zc = if zc < 0.0 {
            rho2 / (len * (len - zc))
        } else {
            1.0 + zc / len
        };
        let k = 1.0 / (len * (2.0 * one_plus_zc).sqrt());
        Some(Point2::new((x * k) as f32, (y * k) as f32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{self, ContractTest, assert_contract, assert_spherical_ray_length, ray_at};
    use obscura_sdk::{Format, Projection, ProjectionProperty, Vec3};
    use proptest::prelude::*;

    const BOTH: [Orientation; 2] = [Orientation::Camera, Orientation::LightProbe];

    fn make(format: Format) -> Box<dyn Projection> {
        testing::make(&MirrorBallFactory, &[], format)
    }

    fn make_oriented(
        orientation: Orientation,
        format: Format,
    ) -> (Box<dyn Projection>, ProjectionEnvironment) {
        let name = match orientation {
            Orientation::Camera => "camera",
            Orientation::LightProbe => "lightprobe",
        };
        testing::make_env(&MirrorBallFactory, &[("string orientation", name)], format)
    }

    fn orientation_of(lightprobe: bool) -> Orientation {
        if lightprobe {
            Orientation::LightProbe
        } else {
            Orientation::Camera
        }
    }

    #[test]
    fn keeps_the_contract() {
        for orientation in BOTH {
            for format in [Format::new(48, 32), Format::new(27, 40), Format::new(33, 33)] {
                let (p, _) = make_oriented(orientation, format);
                let stats = assert_contract(p.as_ref(), &ContractTest::new(format));
                assert!(
                    stats.backward > 0 && stats.valid < stats.samples && stats.roundtrips > 300,
                    "{orientation:?}: {stats:?}"
                );
            }
        }
    }

    proptest! {
        #[test]
        fn directions_are_the_reflection_of_the_view_in_the_ball(
            sx in -1.0f32..1.0, sy in -1.0f32..1.0, lightprobe in any::<bool>(),
        ) {
            let r2 = f64::from(sx).powi(2) + f64::from(sy).powi(2);
            prop_assume!(r2 < 0.999_999);
            let orientation = orientation_of(lightprobe);
            let sigma = f64::from(orientation.sign());
            let (p, _) = make_oriented(orientation, Format::new(64, 64));
            let d = ray_at(p.as_ref(), Point2::new(sx, sy)).direction;
            // Independently: reflect V = −σ·Z in N = (sx, sy, σ·sqrt(1 − r²)).
            let n = [f64::from(sx), f64::from(sy), sigma * (1.0 - r2).sqrt()];
            let v = [0.0, 0.0, -sigma];
            let v_dot_n = v[2] * n[2];
            let expected = [
                v[0] - 2.0 * v_dot_n * n[0],
                v[1] - 2.0 * v_dot_n * n[1],
                v[2] - 2.0 * v_dot_n * n[2],
            ];
            // Near the rim the direction turns 2/c times faster than the screen point moves, so one
            // rounding of r² in f32 moves it by about 1e-7/c.
            let tol = 1e-6 / (1.0 - r2).sqrt();
            for (got, want) in [d.x, d.y, d.z].iter().zip(expected) {
                prop_assert!((f64::from(*got) - want).abs() < tol, "{:?} vs {:?}", d, expected);
            }
            // The angle from the centre's direction σ·Z is 2·asin(r).
            let gamma = f64::from(d.x).hypot(f64::from(d.y)).atan2(sigma * f64::from(d.z));
            prop_assert!((gamma - 2.0 * r2.sqrt().asin()).abs() < 1e-5);
        }

        #[test]
        fn unproject_inverts_project(
            sx in -1.0f32..1.0, sy in -1.0f32..1.0, depth in 0.01f32..1000.0, lightprobe in any::<bool>(),
        ) {
            let r2 = f64::from(sx).powi(2) + f64::from(sy).powi(2);
            prop_assume!(r2 < 0.998);
            let format = Format::new(640, 360);
            let (p, _) = make_oriented(orientation_of(lightprobe), format);
            let ray = ray_at(p.as_ref(), Point2::new(sx, sy));
            let back = p.unproject(ray.direction * depth, 0.0).unwrap();
            let px = 2.0 / 360.0;
            prop_assert!(((back.x - sx) / px).abs() < 1e-4 && ((back.y - sy) / px).abs() < 1e-4, "{:?}", back);
        }

        #[test]
        fn the_light_probe_is_the_default_mirrored_in_depth(sx in -1.2f32..1.2, sy in -1.2f32..1.2) {
            let format = Format::new(50, 50);
            let (camera, _) = make_oriented(Orientation::Camera, format);
            let (probe, _) = make_oriented(Orientation::LightProbe, format);
            let s = Point2::new(sx, sy);
            let (a, b) = (ray_at(camera.as_ref(), s), ray_at(probe.as_ref(), s));
            prop_assert_eq!(a.direction, Vec3::new(b.direction.x, b.direction.y, -b.direction.z));
            prop_assert_eq!(
                (a.origin, a.origin_radius, a.ray_spread, a.min_dist, a.max_dist),
                (b.origin, b.origin_radius, b.ray_spread, b.min_dist, b.max_dist)
            );
            let p = Vec3::new(sx, sy, 0.7 * sx - 0.4);
            prop_assert_eq!(camera.unproject(p, 0.0), probe.unproject(Vec3::new(p.x, p.y, -p.z), 0.0));
        }
    }

    /// Cycles' `mirrorball_to_direction(u, v)` (kernel/camera/projection.h), written out in f64, then
    /// Blender's mirror-ball camera matrix (`blender_camera_matrix`: panorama `(x, y, z)` is the Blender
    /// camera's `(x, z, y)`) and Blender's camera axes (looking down −Z) into ours (looking down +Z):
    /// panorama `(x, y, z)` → `(x, z, −y)`.
    fn cycles_mirror_ball(u: f64, v: f64) -> Option<[f64; 3]> {
        let (nx, nz) = (2.0 * u - 1.0, 2.0 * v - 1.0);
        if nx * nx + nz * nz > 1.0 {
            return None;
        }
        let n = [nx, -(1.0 - nx * nx - nz * nz).max(0.0).sqrt(), nz];
        let i = [0.0, -1.0, 0.0];
        let n_dot_i = n[0] * i[0] + n[1] * i[1] + n[2] * i[2];
        let pano = [
            2.0 * n_dot_i * n[0] - i[0],
            2.0 * n_dot_i * n[1] - i[1],
            2.0 * n_dot_i * n[2] - i[2],
        ];
        Some([pano[0], pano[2], -pano[1]])
    }

    #[test]
    fn the_default_matches_cycles_mirror_ball() {
        // A square image with the default window: screen [−1, 1]² is Cycles' raster [0, 1]², bottom-up.
        let p = make(Format::new(64, 64));
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let s3 = 0.75f64.sqrt();
        for (s, pinned) in [
            (Point2::ZERO, [0.0, 0.0, 1.0]),
            (Point2::new(0.5, 0.0), [s3, 0.0, 0.5]),
            (Point2::new(0.0, -0.5), [0.0, -s3, 0.5]),
            (Point2::new(h as f32, 0.0), [1.0, 0.0, 0.0]),
            (Point2::new(0.6, 0.0), [1.2 * 0.8, 0.0, 1.0 - 2.0 * 0.36]),
            (
                Point2::new(-0.3, 0.8),
                [-0.6 * 0.27f64.sqrt(), 1.6 * 0.27f64.sqrt(), 1.0 - 2.0 * 0.73],
            ),
            (
                Point2::new(0.0, 0.999),
                [
                    0.0,
                    2.0 * 0.999 * (1.0 - 0.998_001f64).sqrt(),
                    1.0 - 2.0 * 0.998_001,
                ],
            ),
        ] {
            let (u, v) = (0.5 * (f64::from(s.x) + 1.0), 0.5 * (f64::from(s.y) + 1.0));
            let cycles = cycles_mirror_ball(u, v).unwrap();
            let d = ray_at(p.as_ref(), s).direction;
            for k in 0..3 {
                assert!(
                    (cycles[k] - pinned[k]).abs() < 1e-6,
                    "{s:?}: Cycles {cycles:?} vs {pinned:?}"
                );
                let got = [d.x, d.y, d.z][k];
                assert!(
                    (f64::from(got) - cycles[k]).abs() < 2e-5,
                    "{s:?}: {d:?} vs Cycles {cycles:?}"
                );
            }
        }
        // The rim, which Cycles keeps, collapses onto −Z, straight behind the camera; we cull it.
        let rim = cycles_mirror_ball(1.0, 0.5).unwrap();
        assert!((rim[2] + 1.0).abs() < 1e-12, "{rim:?}");
        assert_eq!(
            ray_at(p.as_ref(), Point2::new(1.0, 0.0)),
            obscura_sdk::RayGeometry::CULLED
        );
        // And the light probe is not Cycles' orientation: off the centre's axis its z has the other sign.
        let (probe, _) = make_oriented(Orientation::LightProbe, Format::new(64, 64));
        let d = ray_at(probe.as_ref(), Point2::new(0.5, 0.0)).direction;
        assert!((f64::from(d.z) + 0.5).abs() < 1e-6, "{d:?}");
    }

    /// The centre's direction, the rim, the side and the culled outside of one orientation.
    fn check_centre_rim_and_side(orientation: Orientation) {
        let sigma = orientation.sign();
        let (p, _) = make_oriented(orientation, Format::new(64, 64));
        assert_eq!(
            ray_at(p.as_ref(), Point2::ZERO).direction,
            Vec3::new(0.0, 0.0, sigma)
        );
        let near_rim = ray_at(p.as_ref(), Point2::new(0.0, 0.999_99)).direction;
        assert!(
            -sigma * near_rim.z > 0.999 && near_rim.y > 0.0,
            "{orientation:?}: {near_rim:?}"
        );
        // r = sin 45°: the normal is at 45°, the reflection at 90°, straight to the right.
        let side = ray_at(p.as_ref(), Point2::new(std::f32::consts::FRAC_1_SQRT_2, 0.0)).direction;
        assert!((side.x - 1.0).abs() < 1e-6 && side.z.abs() < 1e-6, "{side:?}");
        // Inside that circle the rays lean toward the centre's side, outside it toward the rim's.
        assert!(sigma * ray_at(p.as_ref(), Point2::new(0.3, -0.4)).direction.z > 0.0);
        assert!(sigma * ray_at(p.as_ref(), Point2::new(-0.6, 0.6)).direction.z < 0.0);
        for s in [
            Point2::new(0.0, 1.0),
            Point2::new(1.0, 0.0),
            Point2::new(0.8, 0.7),
            Point2::new(-1.5, 1.0),
        ] {
            assert_eq!(ray_at(p.as_ref(), s), obscura_sdk::RayGeometry::CULLED, "{s:?}");
        }
        assert_eq!(p.unproject(Vec3::new(0.0, 0.0, -5.0 * sigma), 0.0), None);
        assert_eq!(p.unproject(Vec3::ZERO, 0.0), None);
        assert_eq!(
            p.unproject(Vec3::new(0.0, 0.0, 2.0 * sigma), 0.0),
            Some(Point2::ZERO)
        );
        // Straight to the side is on the circle r = sin 45°, either way.
        let back = p.unproject(Vec3::new(3.0, 0.0, 0.0), 0.0).unwrap();
        assert!(
            (back.x - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-6 && back.y == 0.0,
            "{back:?}"
        );
    }

    #[test]
    fn the_centre_looks_back_at_the_camera_and_the_rim_behind_the_ball() {
        check_centre_rim_and_side(Orientation::LightProbe);
    }

    #[test]
    fn by_default_the_centre_looks_ahead_and_the_rim_behind_the_camera() {
        assert_eq!(
            MirrorBall::new(
                &ProjectionEnvironment::for_format(Format::new(8, 8)),
                Orientation::default()
            )
            .orientation(),
            Orientation::Camera
        );
        check_centre_rim_and_side(Orientation::Camera);
        let d = ray_at(make(Format::new(64, 64)).as_ref(), Point2::ZERO).direction;
        assert_eq!(d, Vec3::Z);
    }

    #[test]
    fn properties_are_honest() {
        for orientation in BOTH {
            let (p, env) = make_oriented(orientation, Format::new(8, 8));
            assert_spherical_ray_length(p.as_ref(), Some(&env), Some(360.0));
            assert_eq!(p.property(ProjectionProperty::FStop), None);
        }
        assert_spherical_ray_length(make(Format::new(8, 8)).as_ref(), None, Some(360.0));
        let err = testing::refusal(&MirrorBallFactory, &[("float fov", "90")], Format::new(8, 8));
        assert!(err.starts_with("MirrorBall: unknown parameter \"fov\""), "{err}");
        let err = testing::refusal(
            &MirrorBallFactory,
            &[("string orientation", "sideways")],
            Format::new(8, 8),
        );
        assert!(
            err.starts_with("MirrorBall:") && err.contains("orientation"),
            "{err}"
        );
    }
}
