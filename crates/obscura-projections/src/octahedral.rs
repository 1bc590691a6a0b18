//! `Octahedral`: the whole sphere of directions on one square, equal-area (pbrt-v4's
//! `EqualAreaSquareToSphere`, Clarberg's octahedral mapping).
//!
//! # Mapping
//!
//! With `u = (2·sx − l − r)/(r − l)` and `v = (2·sy − b − t)/(t − b)`, both in `[−1, 1]` over the
//! screen window (conventions.md), and `p = |u|`, `q = |v|`:
//!
//! ```text
//! d = 1 − p − q                       (signed distance from the diamond p + q = 1: the equator)
//! r = 1 − |d|                         (0 at the poles, 1 on the equator)
//! φ = (π/4)·((q − p)/r + 1)           (azimuth within the quadrant, 0..π/2)
//! z = sign(d)·(1 − r²)
//! D = (sign(u)·cos φ·r·sqrt(2 − r²),  sign(v)·sin φ·r·sqrt(2 − r²),  z)
//! ```
//!
//! The centre of the window looks down **+Z**, the four corners all look down −Z, the diamond
//! `|u| + |v| = 1` is the horizon `z = 0`, screen +x leans toward camera +X and screen +y toward +Y
//! (pbrt's own axes; pbrt's SphericalCamera then swaps y and z for its world, which we do not). Every
//! unit of `u·v` area covers π steradians: the map is equal-area, so uniform samples of the window are
//! uniform directions. The square's edges are glued to themselves mirrored (`(±1, v)` and `(±1, −v)`
//! are one direction, likewise `(u, ±1)`), so samples the pixel filter takes outside the window wrap
//! back in as pbrt's `WrapEqualAreaSquare` does — `u > 1 → (2 − u, −v)`, `u < −1 → (−2 − u, −v)`, then
//! the same for `v` — and stay continuous; beyond one wrap (`|u|` or `|v| > 3`) the direction is zero.
//!
//! # Footprint
//!
//! In one quadrant of the upper hemisphere (`d ≥ 0`: `r = p + q`, `φ = (π/2)·q/r`) the polar angle
//! turns by `dθ = 2·dr/sqrt(2 − r²)` and the azimuth by `sin θ·dφ` with `sin θ = r·sqrt(2 − r²)`, so
//!
//! ```text
//! |∂D/∂u|² = 4/(2 − r²) + (π²/4)·(2 − r²)·(mu/r)²
//! |∂D/∂v|² = 4/(2 − r²) + (π²/4)·(2 − r²)·(mv/r)²
//! ```
//!
//! with `(mu, mv) = (q, p)` above the horizon and `(1 − q, 1 − p)` below it (there `r = 2 − p − q`,
//! `φ = (π/2)·(1 − p)/r`); `mu/r` is bounded by 1 and taken as 0 at the poles, where it is 0 along
//! the axes. (The two factors' product, `|∂D/∂u × ∂D/∂v| = π`, is the equal-area property.) One
//! pixel is `Δu = 2Δx/(r − l)`, `Δv = 2Δy/(t − b)`; `αx = Δu·|∂D/∂u|`, `αy = Δv·|∂D/∂v|`,
//! `ray_spread = ½·sqrt(αx·αy)`. The map folds along the axes and the horizon diamond (the direction
//! has a kink there, not a jump); on a fold the footprint is the one-sided derivative of the side the
//! point belongs to (`d ≥ 0` is above). `origin_radius = 0`; clipping is spherical: `min_dist = near`,
//! `max_dist = far`.
//!
//! # Inverse
//!
//! pbrt's `EqualAreaSphereToSquare`: for the unit direction `(x, y, z)`, `r = sqrt(1 − |z|)`,
//! `φ = atan2(|y|, |x|)`, `q' = (2/π)·φ·r`, `p' = r − q'`; below the horizon (`z < 0`)
//! `(p', q') → (1 − q', 1 − p')`; then `u = sign(x)·p'`, `v = sign(y)·q'` (signs of zero kept, so
//! the glued edges come back where they were), mapped back through the window. Every direction has a
//! screen point in the window; only the origin and non-finite points give `None`.
//!
//! # Properties
//!
//! DicingHint Spherical; DeepMetric RayLength (half the rays look behind); FieldOfView 360.

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};

use obscura_sdk::{DeepMetric, ParamDecl, Point2, ProjectionEnvironment, Vec3};

use crate::panorama::{CentredLane, SphericalClip, SweepWindow, sin_cos};

/// The name scenes use.
pub const NAME: &str = "Octahedral";

/// None: the map is fixed, the screen window alone places it.
static TABLE: [ParamDecl; 0] = [];

/// Creates [`Octahedral`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct OctahedralFactory;

projection_factory!(
    OctahedralFactory,
    "pbrt-v4's equal-area octahedral sphere over the whole window: centre +Z, corners -Z, horizon the diamond",
    |env, _p| {
        env.set_deep_metric(DeepMetric::RayLength);
        Ok(Box::new(Octahedral::new(env)))
    }
);

/// An equal-area octahedral camera (see the module documentation for its mapping).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Octahedral {
    window: SweepWindow,
    /// `½·sqrt(Δu·Δv)`.
    half_pixel_uv: f32,
    clip: SphericalClip,
}

/// `π²/4`.
const PI2_4: f32 = FRAC_PI_2 * FRAC_PI_2;

impl Octahedral {
    /// An octahedral camera for `env`.
    #[must_use]
    pub fn new(env: &ProjectionEnvironment) -> Self {
        Octahedral {
            window: SweepWindow::new(env.screen_window()),
            half_pixel_uv: SweepWindow::half_pixel(env),
            clip: SphericalClip::new(env),
        }
    }

    /// The direction of window coordinates `(u, v) ∈ [−1, 1]²` and the squared turn rates
    /// `|∂D/∂u|²`, `|∂D/∂v|²`.
    #[inline(always)]
    fn square_to_sphere(u: f32, v: f32) -> (Vec3, f32, f32) {
        let (p, q) = (u.abs(), v.abs());
        let d = 1.0 - (p + q);
        let r = 1.0 - d.abs();
        let r2 = r * r;
        let (mu, mv) = if d >= 0.0 { (q, p) } else { (1.0 - q, 1.0 - p) };
        let (phi, ku, kv) = if r > 0.0 {
            let inv = 1.0 / r;
            (((q - p) * inv + 1.0) * FRAC_PI_4, mu * inv, mv * inv)
        } else {
            (FRAC_PI_4, 0.0, 0.0)
        };
        let (sin, cos) = sin_cos(phi);
        let w = 2.0 - r2;
        let rho = r * w.sqrt();
        let z = (1.0 - r2).copysign(d);
        let dir = Vec3::new(cos.copysign(u) * rho, sin.copysign(v) * rho, z);
        let radial = 4.0 / w;
        let tangential = PI2_4 * w;
        (dir, radial + tangential * ku * ku, radial + tangential * kv * kv)
    }

    /// The ray of screen point `s` as a branch-free lane (culled where `valid` is false), for the
    /// batch loop of [`crate::screen::map_centred_rays`].
    #[inline(always)]
    fn lane(&self, s: Point2) -> CentredLane {
        let (mut u, mut v) = self.window.uv_unclamped(s);
        if u > 1.0 {
            (u, v) = (2.0 - u, -v);
        } else if u < -1.0 {
            (u, v) = (-2.0 - u, -v);
        }
        if v > 1.0 {
            (u, v) = (-u, 2.0 - v);
        } else if v < -1.0 {
            (u, v) = (-u, -2.0 - v);
        }
        let (dir, gu2, gv2) = Self::square_to_sphere(u, v);
        CentredLane {
            valid: (u.abs() <= 1.0) & (v.abs() <= 1.0),
            direction: dir,
            ray_spread: self.half_pixel_uv * (gu2 * gv2).sqrt().sqrt(),
        }
    }
}

spherical_projection!(Octahedral, |_: &Octahedral| 360.0, lanes);

impl Octahedral {
    /// The screen point that sees the camera-space point `(x, y, z)`, finite: the inverse.
    fn screen_of(&self, x: f64, y: f64, z: f64) -> Option<Point2> {
        let len = (x * x + y * y + z * z).sqrt();
        if len == 0.0 {
            return None;
        }
        let (ax, ay, az) = (x.abs() / len, y.abs() / len, z.abs() / len);
        // sqrt(1 − |z|) without cancellation near the poles: 1 − |z| = (x² + y²)/(1 + |z|).
        let r = ((ax * ax + ay * ay) / (1.0 + az)).sqrt();
        let phi = ay.atan2(ax);
        let mut q = std::f64::consts::FRAC_2_PI * phi * r;
        let mut p = r - q;
        if z < 0.0 {
            (p, q) = (1.0 - q, 1.0 - p);
        }
        let (u, v) = (p.copysign(x), q.copysign(y));
        Some(self.window.screen_point(u, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{
        self, ContractTest, angle, assert_contract, assert_spherical_ray_length, project_points, ray_at,
    };
    use obscura_sdk::{Format, Projection, ScreenWindow};
    use proptest::prelude::*;

    fn make(format: Format) -> Box<dyn Projection> {
        testing::make(&OctahedralFactory, &[], format)
    }

    fn dir(p: &dyn Projection, s: Point2) -> Vec3 {
        ray_at(p, s).direction
    }

    /// The contract, but for two checks that cannot hold on this map's seams, each made below
    /// instead: the map folds along the axes and the horizon diamond, where the checker's central
    /// differences straddle the fold and measure a chord shorter than the path
    /// ([`footprint_matches_one_sided_differences`]); and the window's edges are glued in pairs
    /// (`(±1, v)` and `(±1, −v)` are one direction, the four corners are −Z), so a screen point on an
    /// edge cannot be told from its mirror ([`unproject_inverts_project`] inside the window,
    /// [`edges_come_back_to_the_same_direction`] on it).
    #[test]
    fn keeps_the_contract() {
        for format in [Format::new(48, 32), Format::new(33, 33), Format::new(27, 40)] {
            // The footprint on the fold lines themselves is the limit from one side, which the
            // checker's axis-aligned chords cannot see: it is checked by
            // `footprint_matches_one_sided_differences`; everything else, round trips included, here.
            let mut t = ContractTest::new(format);
            t.spread_rel_tol = f64::MAX;
            let stats = assert_contract(make(format).as_ref(), &t);
            assert_eq!(stats.valid, stats.samples);
            assert!(stats.backward > stats.valid / 3, "{stats:?}");
            assert!(stats.roundtrips > stats.valid / 2, "{stats:?}");
        }
    }

    #[test]
    fn edges_come_back_to_the_same_direction() {
        let format = Format::new(48, 32);
        let p = make(format);
        let w = ScreenWindow::default_for(format);
        for i in 0..=64 {
            let f = f64::from(i) / 64.0;
            for (x, y) in [
                (f * 48.0, 0.0),
                (f * 48.0, 32.0),
                (0.0, f * 32.0),
                (48.0, f * 32.0),
            ] {
                let s = w.raster_to_screen(format, x, y);
                let d = dir(p.as_ref(), s);
                let back = p.unproject(d * 10.0, 0.0).unwrap();
                let (bx, by) = w.screen_to_raster(format, back);
                assert!(
                    (-1e-4..=48.0001).contains(&bx) && (-1e-4..=32.0001).contains(&by),
                    "{back:?}"
                );
                let again = dir(p.as_ref(), back);
                assert!(angle(d, again) < 1e-6, "{s:?} -> {back:?}: {d:?} vs {again:?}");
                // On an edge the mirror image is the only other answer.
                let same = ((back.x - s.x).abs() < 1e-5 && (back.y - s.y).abs() < 1e-5)
                    || ((back.x - s.x).abs() < 1e-5 && (back.y + s.y).abs() < 1e-5)
                    || ((back.x + s.x).abs() < 1e-5 && (back.y - s.y).abs() < 1e-5)
                    || ((back.x + s.x).abs() < 1e-5 && (back.y + s.y).abs() < 1e-5);
                assert!(same, "{s:?} -> {back:?}");
            }
        }
    }

    #[test]
    fn footprint_matches_one_sided_differences() {
        let format = Format::new(64, 48);
        let p = make(format);
        let w = ScreenWindow::default_for(format);
        let (px, py) = w.pixel_size(format);
        let h = 0.01f32;
        let mut checked = 0;
        for j in 0..=96 {
            for i in 0..=128 {
                let s = w.raster_to_screen(format, f64::from(i) * 0.5 + 0.013, f64::from(j) * 0.5 + 0.007);
                let ray = project_points(p.as_ref(), &[s], &[Point2::ZERO], &[0.0])[0];
                let d0 = ray.direction;
                // Within 0.05 of a pole (in u, v) the direction turns too fast for differences over a
                // hundredth of a pixel to resolve; the poles are checked on their own below.
                let (pu, pv) = ((s.x / w.right).abs(), (s.y / w.top).abs());
                if pu + pv < 0.05 || 2.0 - pu - pv < 0.05 || pu > 1.0 || pv > 1.0 {
                    continue;
                }
                // Per pixel, along each axis: the one-sided difference toward a neighbour in the same
                // cell of the fold pattern (quadrant, above or below the horizon) as the point.
                let cell = |s: Point2| {
                    let (u, v) = (s.x / w.right, s.y / w.top);
                    (
                        u >= 0.0,
                        v >= 0.0,
                        u.abs() + v.abs() <= 1.0,
                        u.abs() <= 1.0 && v.abs() <= 1.0,
                    )
                };
                let rate = |dx: f32, dy: f32| {
                    let (fwd, bwd) = (Point2::new(s.x + dx, s.y + dy), Point2::new(s.x - dx, s.y - dy));
                    let n = [fwd, bwd].into_iter().find(|n| cell(*n) == cell(s))?;
                    Some(angle(d0, dir(p.as_ref(), n)) / f64::from(h))
                };
                // (Where two folds meet closer than a hundredth of a pixel, no neighbour shares the cell.)
                let (Some(ax), Some(ay)) = (rate(h * px, 0.0), rate(0.0, h * py)) else {
                    continue;
                };
                let expected = 0.5 * (ax * ay).sqrt();
                let got = f64::from(ray.ray_spread);
                assert!(
                    (got / expected - 1.0).abs() < 0.02,
                    "at {s:?}: {got} vs {expected}"
                );
                checked += 1;
            }
        }
        assert!(checked > 12000, "{checked}");
        // At the poles the derivative along either axis is sqrt(2) per unit of u or v: the two
        // neighbours a step e away are 2·sqrt(2)·e apart in angle, mirror images of each other.
        for s in [
            Point2::ZERO,
            Point2::new(w.right, w.top),
            Point2::new(w.left, w.bottom),
        ] {
            let ray = project_points(p.as_ref(), &[s], &[Point2::ZERO], &[0.0])[0];
            let (du, dv) = (2.0 * px / (w.right - w.left), 2.0 * py / (w.top - w.bottom));
            let expected = 0.5 * (f64::from(du) * f64::from(dv)).sqrt() * std::f64::consts::SQRT_2;
            assert!(
                (f64::from(ray.ray_spread) / expected - 1.0).abs() < 1e-5,
                "pole {s:?}: {ray:?}"
            );
        }
    }

    #[test]
    fn the_map_is_equal_area() {
        // Uniform points of the window (a rank-1 lattice) must be uniform on the sphere.
        let format = Format::new(64, 64);
        let p = make(format);
        let n = 1 << 18;
        let g = 0.754_877_666_246_692_7f64; // 1/plastic number
        let screen: Vec<Point2> = (0..n)
            .map(|i| {
                let (a, b) = ((i as f64 * g).fract(), (i as f64 * g * g).fract());
                Point2::new((2.0 * a - 1.0) as f32, (2.0 * b - 1.0) as f32)
            })
            .collect();
        let rays = project_points(p.as_ref(), &screen, &vec![Point2::ZERO; n], &vec![0.0; n]);
        let frac =
            |pred: &dyn Fn(Vec3) -> bool| rays.iter().filter(|r| pred(r.direction)).count() as f64 / n as f64;
        // z is uniform on the sphere: each band of z of width 0.5 holds a quarter.
        for k in 0..4 {
            let lo = -1.0 + 0.5 * k as f32;
            let f = frac(&|d| d.z >= lo && d.z < lo + 0.5);
            assert!((f - 0.25).abs() < 2e-3, "band {lo}: {f}");
        }
        // A cap of 40° around an axis that is none of the map's: (1 − cos 40°)/2 of the sphere.
        let axis = Vec3::new(0.3, -0.5, 0.81).normalize_or_zero();
        let cos40 = 40f32.to_radians().cos();
        let f = frac(&|d| d.dot(axis) > cos40);
        let expected = (1.0 - f64::from(cos40)) / 2.0;
        assert!((f - expected).abs() < 2e-3, "cap {f} vs {expected}");
        // And locally: |∂D/∂u × ∂D/∂v| = π everywhere off the folds.
        for i in 0..500 {
            let (u, v) = (
                ((i as f64 * g).fract() * 2.0 - 1.0) as f32,
                ((i as f64 * g * g).fract() * 2.0 - 1.0) as f32,
            );
            let e = 1e-3f32;
            let near_fold = |x: f32| x.abs() < 2.0 * e;
            if near_fold(u)
                || near_fold(v)
                || near_fold(u.abs() + v.abs() - 1.0)
                || near_fold(u.abs().max(v.abs()) - 1.0)
            {
                continue;
            }
            let d = |a: f32, b: f32| Octahedral::square_to_sphere(a, b).0;
            let du = d(u + e, v) - d(u - e, v);
            let dv = d(u, v + e) - d(u, v - e);
            let area = f64::from(du.cross(dv).length()) / (4.0 * f64::from(e) * f64::from(e));
            assert!(
                (area / std::f64::consts::PI - 1.0).abs() < 5e-3,
                "at ({u}, {v}): {area}"
            );
        }
    }

    #[test]
    fn the_centre_looks_ahead_the_corners_behind_and_the_diamond_at_the_horizon() {
        let format = Format::new(32, 32);
        let p = make(format);
        assert_eq!(dir(p.as_ref(), Point2::ZERO), Vec3::Z);
        for (cx, cy) in [(1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)] {
            let d = dir(p.as_ref(), Point2::new(cx, cy));
            assert!(d.z == -1.0 && d.x.abs() < 1e-7 && d.y.abs() < 1e-7, "{d:?}");
        }
        for (s, want) in [
            (Point2::new(1.0, 0.0), Vec3::new(1.0, 0.0, 0.0)),
            (Point2::new(0.0, 1.0), Vec3::new(0.0, 1.0, 0.0)),
            (Point2::new(-1.0, 0.0), Vec3::new(-1.0, 0.0, 0.0)),
            (Point2::new(0.0, -1.0), Vec3::new(0.0, -1.0, 0.0)),
            (
                Point2::new(0.5, 0.5),
                Vec3::new(
                    std::f32::consts::FRAC_1_SQRT_2,
                    std::f32::consts::FRAC_1_SQRT_2,
                    0.0,
                ),
            ),
        ] {
            let d = dir(p.as_ref(), s);
            assert!((d - want).length() < 1e-6, "{s:?}: {d:?}");
        }
        // The glued edges: (1, v) and (1, −v) are one direction; the margin wraps continuously.
        let (a, b) = (
            dir(p.as_ref(), Point2::new(1.0, 0.3)),
            dir(p.as_ref(), Point2::new(1.0, -0.3)),
        );
        assert!((a - b).length() < 1e-6);
        let (inside, outside) = (
            dir(p.as_ref(), Point2::new(0.99, 0.3)),
            dir(p.as_ref(), Point2::new(1.01, -0.3)),
        );
        assert!((inside - outside).length() < 1e-6, "{inside:?} vs {outside:?}");
        assert!(project_points(p.as_ref(), &[Point2::new(3.5, 0.0)], &[Point2::ZERO], &[0.0])[0].is_culled());
    }

    proptest! {
        #[test]
        fn directions_match_pbrts_equal_area_formulas(u in -1.0f64..1.0, v in -1.0f64..1.0) {
            // pbrt-v4's EqualAreaSquareToSphere on ((u + 1)/2, (v + 1)/2), written out in f64.
            let (up, vp) = (u.abs(), v.abs());
            let sd = 1.0 - (up + vp);
            let r = 1.0 - sd.abs();
            let phi = if r == 0.0 { 1.0 } else { (vp - up) / r + 1.0 } * std::f64::consts::FRAC_PI_4;
            let z = (1.0 - r * r).copysign(sd);
            let k = r * (2.0 - r * r).sqrt();
            let want = [phi.cos().copysign(u) * k, phi.sin().copysign(v) * k, z];
            let d = Octahedral::square_to_sphere(u as f32, v as f32).0;
            for (got, w) in [d.x, d.y, d.z].iter().zip(want) {
                prop_assert!((f64::from(*got) - w).abs() < 2e-6, "{:?} vs {:?}", d, want);
            }
        }

        #[test]
        fn unproject_inverts_project(sx in -1.777f32..1.777, sy in -1.0f32..1.0, depth in 0.01f32..1000.0) {
            let format = Format::new(640, 360);
            let p = make(format);
            let d = dir(p.as_ref(), Point2::new(sx, sy));
            let back = p.unproject(d * depth, 0.0).unwrap();
            let px = 2.0 / 360.0;
            prop_assert!(((back.x - sx) / px).abs() < 1e-4 && ((back.y - sy) / px).abs() < 1e-4, "{:?}", back);
        }
    }

    #[test]
    fn properties_are_honest() {
        let p = make(Format::new(8, 8));
        assert_spherical_ray_length(p.as_ref(), None, Some(360.0));
        assert_eq!(p.unproject(Vec3::ZERO, 0.0), None);
    }
}
