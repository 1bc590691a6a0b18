//! `EquiangularCubemapFace`: one face of Google's equi-angular cube map (EAC), one face per camera.
//!
//! # Mapping
//!
//! With `u = (2·sx − l − r)/(r − l)` and `v = (2·sy − b − t)/(t − b)`, both in `[−1, 1]` over the
//! screen window (conventions.md), the face coordinates are equi-angular, not equi-distant:
//!
//! ```text
//! a = tan(u·π/4),   b = tan(v·π/4),   D = normalize(F + a·R + b·U)
//! ```
//!
//! so equal steps of `u` are equal angles seen from the cube's centre, and the face's four edges
//! `u = ±1`, `v = ±1` are 45° off its axis `F`. Each face is the picture a camera turned toward it
//! would take, upright and unmirrored (yawed for the side faces, pitched for the top and bottom):
//!
//! | `face` | axis `F` | right `R` (screen +x) | up `U` (screen +y) |
//! |---|---|---|---|
//! | `+Z` | +Z | +X | +Y |
//! | `+X` | +X | −Z | +Y |
//! | `-Z` | −Z | −X | +Y |
//! | `-X` | −X | +Z | +Y |
//! | `+Y` | +Y | +X | −Z |
//! | `-Y` | −Y | +X | +Z |
//!
//! Every basis is a rotation of `+Z`'s (`R × U = F` in components), so neighbouring faces share
//! their edges: the `+Z` face's right edge is the `+X` face's left edge, point for point, and the top
//! edge of each side face meets the `+Y` face. Samples the pixel filter takes just outside the window
//! continue the same formula (onto the neighbouring faces' directions) while `|u|, |v| < 2`, where
//! `a` and `b` stay finite; beyond, the direction is zero (culled).
//!
//! # Footprint
//!
//! With `N = F + a·R + b·U` (`|N|² = 1 + a² + b²`) and `da/du = (π/4)(1 + a²)`, the direction turns by
//! `|∂D/∂u| = (π/4)(1 + a²)·sqrt(1 + b²)/(1 + a² + b²)` per unit of `u`, and by
//! `|∂D/∂v| = (π/4)(1 + b²)·sqrt(1 + a²)/(1 + a² + b²)` per unit of `v`. One pixel is
//! `Δu = 2Δx/(r − l)`, `Δv = 2Δy/(t − b)`, so `αx = Δu·|∂D/∂u|`, `αy = Δv·|∂D/∂v|` and
//! `ray_spread = ½·sqrt(αx·αy)`; `origin_radius = 0`; clipping is spherical: `min_dist = near`,
//! `max_dist = far`.
//!
//! # Inverse
//!
//! A camera-space point `P` with `P·F > 0` is seen at `u = (4/π)·atan((P·R)/(P·F))`,
//! `v = (4/π)·atan((P·U)/(P·F))`, mapped back through the window; a point with `P·F ≤ 0` (behind the
//! face's hemisphere) gives `None`.
//!
//! # Properties
//!
//! DicingHint Spherical (the pixels are equal angles, not equal steps on a plane); FieldOfView 90;
//! DeepMetric RayLength for every face, including `+Z` whose rays never leave +Z: the six faces of one
//! cube must measure depth alike or their depth maps would not meet at the seams.

use std::f32::consts::FRAC_PI_4;
use std::sync::LazyLock;

use obscura_sdk::{DeepMetric, ParamDecl, Point2, ProjectionEnvironment, Vec3};

use crate::panorama::{CentredLane, SphericalClip, SweepWindow};

/// The name scenes use.
pub const NAME: &str = "EquiangularCubemapFace";

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    vec![ParamDecl::string("face", "+Z").choices(&Face::NAMES).doc(
        "the cube face this camera renders: +X, -X, +Y, -Y, +Z or -Z (each upright, as if turned to it)",
    )]
});

/// One face of the cube.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Face {
    /// Looking along +X.
    PosX,
    /// Looking along −X.
    NegX,
    /// Looking up, along +Y.
    PosY,
    /// Looking down, along −Y.
    NegY,
    /// Looking ahead, along +Z.
    #[default]
    PosZ,
    /// Looking back, along −Z.
    NegZ,
}

impl Face {
    /// The spellings of the `face` parameter.
    pub const NAMES: [&'static str; 6] = ["+X", "-X", "+Y", "-Y", "+Z", "-Z"];

    /// Reads a `face` value.
    #[must_use]
    pub fn parse(s: &str) -> Option<Face> {
        Some(match s {
            "+X" => Face::PosX,
            "-X" => Face::NegX,
            "+Y" => Face::PosY,
            "-Y" => Face::NegY,
            "+Z" => Face::PosZ,
            "-Z" => Face::NegZ,
            _ => return None,
        })
    }

    /// The face's axis `F`, right `R` and up `U` (see the module documentation's table).
    #[must_use]
    pub fn basis(self) -> [Vec3; 3] {
        let (x, y, z) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::Z);
        match self {
            Face::PosZ => [z, x, y],
            Face::PosX => [x, -z, y],
            Face::NegZ => [-z, -x, y],
            Face::NegX => [-x, z, y],
            Face::PosY => [y, x, -z],
            Face::NegY => [-y, x, z],
        }
    }
}

/// Creates [`CubemapFace`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct CubemapFaceFactory;

projection_factory!(
    CubemapFaceFactory,
    "one face of Google's equi-angular cube map: D = normalize(F + tan(u pi/4) R + tan(v pi/4) U)",
    |env, p| {
        let face = Face::parse(p.string("face")?).ok_or_else(|| {
            crate::invalid(NAME, "parameter \"face\": expected one of +X, -X, +Y, -Y, +Z, -Z")
        })?;
        env.set_deep_metric(DeepMetric::RayLength);
        Ok(Box::new(CubemapFace::new(env, face)))
    }
);

/// One equi-angular cube-map face (see the module documentation for its mapping).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CubemapFace {
    face: Face,
    basis: [Vec3; 3],
    window: SweepWindow,
    /// `½·sqrt(Δu·Δv)·π/4`.
    spread_scale: f32,
    clip: SphericalClip,
}

impl CubemapFace {
    /// The face `face` for `env`.
    #[must_use]
    pub fn new(env: &ProjectionEnvironment, face: Face) -> Self {
        CubemapFace {
            face,
            basis: face.basis(),
            window: SweepWindow::new(env.screen_window()),
            spread_scale: SweepWindow::half_pixel(env) * FRAC_PI_4,
            clip: SphericalClip::new(env),
        }
    }

    /// The face this camera renders.
    #[must_use]
    pub fn face(&self) -> Face {
        self.face
    }

    /// The ray of screen point `s` as a branch-free lane (culled where `valid` is false), for the
    /// batch loop of [`crate::screen::map_centred_rays`].
    #[inline(always)]
    fn lane(&self, s: Point2) -> CentredLane {
        let (u, v) = self.window.uv_unclamped(s);
        let a = tan_quarter_turn(u);
        let b = tan_quarter_turn(v);
        let (a2, b2) = (a * a, b * b);
        let n2 = 1.0 + a2 + b2;
        let inv = 1.0 / n2.sqrt();
        let [f, r, up] = self.basis;
        let d = (f + r * a + up * b) * inv;
        // αx·αy ∝ (1 + a²)(1 + b²)·sqrt((1 + a²)(1 + b²))/|N|⁴
        let q = (1.0 + a2) * (1.0 + b2);
        CentredLane {
            valid: (u.abs() < 2.0) & (v.abs() < 2.0),
            direction: d,
            ray_spread: self.spread_scale * (q * q.sqrt()).sqrt() / n2,
        }
    }
}

/// `tan(t·π/4)` for `|t| < 2`, to within a few `f32` ulps and several times faster than the library
/// `tan`: the odd polynomial of Cephes' `tanf` on `|x| ≤ π/4`, and `tan x = 1/tan(π/2 − x)` beyond.
#[inline(always)]
fn tan_quarter_turn(t: f32) -> f32 {
    let at = t.abs();
    let far = at > 1.0;
    let x = if far { 2.0 - at } else { at } * FRAC_PI_4;
    let z = x * x;
    let poly = ((((9.385_402e-3 * z + 3.119_922_3e-3) * z + 2.443_013_5e-2) * z + 5.341_128e-2) * z
        + 1.333_88e-1)
        * z
        + 3.333_315_7e-1;
    let tan = x + x * z * poly;
    (if far { 1.0 / tan } else { tan }).copysign(t)
}

spherical_projection!(CubemapFace, |_: &CubemapFace| 90.0, lanes);

impl CubemapFace {
    /// The screen point that sees the camera-space point `(x, y, z)`, finite: the inverse.
    fn screen_of(&self, x: f64, y: f64, z: f64) -> Option<Point2> {
        let dot = |v: Vec3| x * f64::from(v.x) + y * f64::from(v.y) + z * f64::from(v.z);
        let [f, r, up] = self.basis;
        let pf = dot(f);
        if pf.is_nan() || pf <= 0.0 {
            return None;
        }
        let to_screen = std::f64::consts::FRAC_1_PI * 4.0;
        let u = to_screen * (dot(r) / pf).atan();
        let v = to_screen * (dot(up) / pf).atan();
        Some(self.window.screen_point(u, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{self, ContractTest, angle, assert_contract, assert_spherical_ray_length, ray_at};
    use obscura_sdk::{Format, Projection};
    use proptest::prelude::*;

    fn make(face: &str, format: Format) -> Box<dyn Projection> {
        testing::make(&CubemapFaceFactory, &[("string face", face)], format)
    }

    #[test]
    fn every_face_keeps_the_contract() {
        for format in [Format::new(32, 32), Format::new(48, 32)] {
            for face in Face::NAMES {
                let stats = assert_contract(make(face, format).as_ref(), &ContractTest::new(format));
                assert_eq!(stats.valid, stats.samples, "{face}: {stats:?}");
                match face {
                    "+Z" => assert_eq!(stats.backward, 0),
                    "-Z" => assert_eq!(stats.backward, stats.valid),
                    _ => assert!(
                        stats.backward > 0 && stats.backward < stats.valid,
                        "{face}: {stats:?}"
                    ),
                }
            }
        }
    }

    #[test]
    fn the_face_edges_are_at_45_degrees_and_equal_steps_are_equal_angles() {
        let format = Format::new(64, 64);
        for face in Face::NAMES {
            let p = make(face, format);
            let axis = Face::parse(face).unwrap().basis()[0];
            for s in [
                Point2::new(1.0, 0.0),
                Point2::new(-1.0, 0.0),
                Point2::new(0.0, 1.0),
                Point2::new(0.0, -1.0),
            ] {
                let d = ray_at(p.as_ref(), s).direction;
                assert!(
                    (angle(d, axis) - std::f64::consts::FRAC_PI_4).abs() < 1e-6,
                    "{face} {s:?}: {d:?}"
                );
            }
            // Along the horizontal midline, u = 0.25, 0.5, 0.75, 1 are 11.25°, 22.5°, 33.75°, 45° off axis.
            for k in 1..=4 {
                let d = ray_at(p.as_ref(), Point2::new(0.25 * k as f32, 0.0)).direction;
                assert!((angle(d, axis) - f64::from(k) * std::f64::consts::PI / 16.0).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn neighbouring_faces_share_their_edges() {
        let format = Format::new(64, 64);
        let faces: Vec<(&str, Box<dyn Projection>)> =
            Face::NAMES.iter().map(|f| (*f, make(f, format))).collect();
        let edge = |t: f32| {
            [
                Point2::new(1.0, t),
                Point2::new(-1.0, t),
                Point2::new(t, 1.0),
                Point2::new(t, -1.0),
            ]
        };
        // Every edge point of every face is an edge point of exactly one other face.
        for (name, p) in &faces {
            for i in 0..=20 {
                let t = -1.0 + 0.1 * i as f32;
                for s in edge(t) {
                    let d = ray_at(p.as_ref(), s).direction;
                    let mut shared = 0;
                    for (other, q) in &faces {
                        if other == name {
                            continue;
                        }
                        if let Some(back) = q.unproject(d, 0.0)
                            && back.x.abs() <= 1.0 + 1e-5
                            && back.y.abs() <= 1.0 + 1e-5
                        {
                            assert!(
                                (back.x.abs() - 1.0).abs() < 1e-5 || (back.y.abs() - 1.0).abs() < 1e-5,
                                "{name} {s:?} lands inside {other} at {back:?}"
                            );
                            let e = ray_at(q.as_ref(), back).direction;
                            assert!(angle(d, e) < 1e-6, "{name} {s:?} vs {other} {back:?}");
                            shared += 1;
                        }
                    }
                    // Corners belong to three faces, other edge points to two.
                    let corner = t.abs() > 0.999;
                    assert_eq!(shared, if corner { 2 } else { 1 }, "{name} at {s:?}");
                }
            }
        }
        // The +Z face's right edge is the +X face's left edge.
        let (pz, px) = (&faces[4].1, &faces[0].1);
        let d = ray_at(pz.as_ref(), Point2::new(1.0, 0.3)).direction;
        let back = px.unproject(d, 0.0).unwrap();
        assert!(
            (back.x + 1.0).abs() < 1e-6 && (back.y - 0.3).abs() < 1e-6,
            "{back:?}"
        );
    }

    proptest! {
        #[test]
        fn directions_match_the_closed_form(sx in -1.5f32..1.5, sy in -1.0f32..1.0, face in 0usize..6) {
            let name = Face::NAMES[face];
            let p = make(name, Format::new(48, 32));
            let d = ray_at(p.as_ref(), Point2::new(sx, sy)).direction;
            let (u, v) = (f64::from(sx) / 1.5, f64::from(sy));
            let (a, b) = ((u * std::f64::consts::FRAC_PI_4).tan(), (v * std::f64::consts::FRAC_PI_4).tan());
            let [f, r, up] = Face::parse(name).unwrap().basis();
            let n = |k: fn(Vec3) -> f32| f64::from(k(f)) + a * f64::from(k(r)) + b * f64::from(k(up));
            let len = (1.0 + a * a + b * b).sqrt();
            prop_assert!((f64::from(d.x) - n(|v| v.x) / len).abs() < 1e-6);
            prop_assert!((f64::from(d.y) - n(|v| v.y) / len).abs() < 1e-6);
            prop_assert!((f64::from(d.z) - n(|v| v.z) / len).abs() < 1e-6);
        }

        #[test]
        fn unproject_inverts_project(sx in -1.777f32..1.777, sy in -1.0f32..1.0, depth in 0.01f32..1000.0, face in 0usize..6) {
            let format = Format::new(640, 360);
            let p = make(Face::NAMES[face], format);
            let ray = ray_at(p.as_ref(), Point2::new(sx, sy));
            let back = p.unproject(ray.direction * depth, 0.0).unwrap();
            let px = 2.0 / 360.0;
            prop_assert!(((back.x - sx) / px).abs() < 1e-4 && ((back.y - sy) / px).abs() < 1e-4, "{:?}", back);
        }
    }

    #[test]
    fn far_outside_the_window_is_culled_and_behind_the_face_is_not_seen() {
        let p = make("+Z", Format::new(32, 32));
        assert!(ray_at(p.as_ref(), Point2::new(2.0, 0.0)).is_culled());
        assert!(ray_at(p.as_ref(), Point2::new(0.0, -2.5)).is_culled());
        assert!(!ray_at(p.as_ref(), Point2::new(1.9, 1.9)).is_culled());
        assert_eq!(p.unproject(Vec3::new(1.0, 0.0, 0.0), 0.0), None);
        assert_eq!(p.unproject(Vec3::new(0.0, 0.0, -1.0), 0.0), None);
    }

    #[test]
    fn the_fast_tangent_agrees_with_the_library() {
        let mut worst = 0.0f64;
        for i in -19_999..=19_999 {
            let t = i as f32 / 10_000.0;
            let exact = (f64::from(t) * std::f64::consts::FRAC_PI_4).tan();
            worst = worst.max((f64::from(tan_quarter_turn(t)) / exact - 1.0).abs());
        }
        assert!(worst < 3e-7, "relative error {worst}");
        assert_eq!(tan_quarter_turn(1.0), 1.0);
        assert_eq!(tan_quarter_turn(0.0), 0.0);
    }

    #[test]
    fn properties_are_honest() {
        for face in Face::NAMES {
            let p = make(face, Format::new(8, 8));
            assert_spherical_ray_length(p.as_ref(), None, Some(90.0));
        }
        let err = testing::refusal(
            &CubemapFaceFactory,
            &[("string face", "front")],
            Format::new(8, 8),
        );
        assert!(
            err.starts_with("EquiangularCubemapFace: parameter \"face\""),
            "{err}"
        );
    }
}
