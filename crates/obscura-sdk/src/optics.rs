//! Perspective and thin-lens ray math shared by `PxrPerspective` and the host's default camera rays.
//!
//! Screen plane at distance `d = 1/tan(fov/2)`; the pinhole ray through screen point `(sx, sy)` is
//! `D = normalize(sx, sy, d)`. A thin lens of radius `R` focused at distance `f` sends every ray of that
//! screen point through `F = (sx, sy, d)·f/d` from `O = (R·ax, R·ay, 0)`, `(ax, ay)` the aperture sample.
//!
//! The footprint cone is half a pixel in radius. For a pixel of `Δx × Δy` screen units, moving one
//! pixel in x turns the pinhole direction by `αx = Δx·sqrt(sy² + d²)/L²` (`L² = sx² + sy² + d²`), and in
//! y by `αy = Δy·sqrt(sx² + d²)/L²`; `ray_spread = ½·sqrt(αx·αy)`. Through a thin lens the cone is the
//! one that has the pinhole's radius at the focus point `F`: `ray_spread = spread_pinhole·|F|/|F − O|`.
//!
//! Clipping planes are planes of constant camera z: a ray leaving `z = 0` with direction `D` meets them
//! at `min_dist = near/D.z` and `max_dist = far/D.z`.

use crate::geometry::{Point2, Vec3};
use crate::ray::RayGeometry;

/// `d = 1/tan(fov/2)`, the screen-plane distance for a field of view in degrees.
///
/// Computed in `f64` and rounded once: `f32::tan` at run time is libm's `tanf`, but an optimised build
/// folds a constant argument through the double-precision `tan`, and the two differ in the last bit
/// for some angles (60° among them), so the same camera would get another `d`, and other rays, in a
/// release build than in a debug one.
#[inline]
#[must_use]
pub fn screen_distance(fov_degrees: f32) -> f32 {
    (1.0 / (0.5 * f64::from(fov_degrees).to_radians()).tan()) as f32
}

/// The field of view in degrees whose screen plane lies at `d`: the inverse of [`screen_distance`]
/// (in `f64` too, for the same reason).
#[inline]
#[must_use]
pub fn fov_from_distance(d: f32) -> f32 {
    (2.0 * (1.0 / f64::from(d)).atan().to_degrees()) as f32
}

/// The constants of one perspective camera, ready to make rays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerspectiveRays {
    /// Half the geometric mean of the pixel's sides in screen units: `½·sqrt(Δx·Δy)`.
    pub half_pixel: f32,
    /// Lens radius in scene units; 0 for a pinhole.
    pub lens_radius: f32,
    /// Distance of the plane of focus (used when `lens_radius > 0`).
    pub focal_distance: f32,
    /// Near clipping plane z.
    pub near: f32,
    /// Far clipping plane z.
    pub far: f32,
}

impl PerspectiveRays {
    /// Constants for a pixel of `Δx × Δy` screen units, clipping `(near, far)`, and a lens.
    #[must_use]
    pub fn new(pixel_size: (f32, f32), clipping: (f32, f32), lens_radius: f32, focal_distance: f32) -> Self {
        PerspectiveRays {
            half_pixel: 0.5 * (pixel_size.0 * pixel_size.1).sqrt(),
            lens_radius,
            focal_distance,
            near: clipping.0,
            far: clipping.1,
        }
    }

    /// The lens radius `½·focalLength/fStop`, or 0 (a pinhole) unless the f-stop is finite and positive
    /// and the focal length positive.
    #[must_use]
    pub fn lens_radius_for(f_stop: f32, focal_length: f32) -> f32 {
        if f_stop.is_finite() && f_stop > 0.0 && focal_length > 0.0 {
            0.5 * focal_length / f_stop
        } else {
            0.0
        }
    }

    /// The pinhole ray through screen point `s` with the screen plane at `d`.
    ///
    /// `L = sqrt(sx² + sy² + d²)`, `D = (sx, sy, d)/L`, and `ray_spread = (half_pixel·d)·W^¼/L²` with
    /// `W = ((sx² + d²)/d²)·((sy² + d²)/d²)`: the module doc's `½·sqrt(αx·αy)` rearranged so that the
    /// only square root and division are those of `1/L`, and so that [`quarter_root`] does not wait for
    /// them (`W` needs the squares only; `1/d²` is the camera's constant). `W = (1 + tan²θx)(1 + tan²θy)`
    /// is at least 1 and is held to [`PINHOLE_W_MAX`] = 2¹²⁰, which only a ray about 10⁻⁹ radians from
    /// 90° off axis reaches. `min_dist =
    /// (near/d)·L`, `max_dist = (far/d)·L` (`near/D.z` with `D.z = d/L`). One `sqrt`, one `div` and
    /// [`quarter_root`]: the SIMD kernels of `PxrPerspective` compute exactly this, operation for
    /// operation, so their rays are bit-identical.
    #[inline(always)]
    #[must_use]
    pub fn pinhole(&self, s: Point2, d: f32) -> RayGeometry {
        let (sx2, sy2, d2) = (s.x * s.x, s.y * s.y, d * d);
        let l = (sx2 + sy2 + d2).sqrt();
        let inv_l = 1.0 / l;
        let w = footprint_w(sx2, sy2, d2);
        RayGeometry {
            origin: Vec3::ZERO,
            origin_radius: 0.0,
            direction: Vec3::new(s.x * inv_l, s.y * inv_l, d * inv_l),
            ray_spread: quarter_root(w) * ((self.half_pixel * d) * (inv_l * inv_l)),
            min_dist: (self.near / d) * l,
            max_dist: (self.far / d) * l,
        }
    }

    /// Pinhole rays for a whole batch with the screen plane at `d`, one [`PerspectiveRays::pinhole`] per
    /// sample (the portable path; `PxrPerspective` adds an AVX-512 kernel with bit-identical results).
    pub fn pinhole_batch(&self, screen: &[Point2], d: f32, out: &mut [RayGeometry]) {
        for (o, s) in out.iter_mut().zip(screen) {
            *o = self.pinhole(*s, d);
        }
    }

    /// The thin-lens ray through screen point `s` from aperture sample `a ∈ [−1, 1]²`.
    ///
    /// With `f` the focal distance and `k = f/d`: `O = (R·ax, R·ay, 0)`, the focus point
    /// `F = k·(sx, sy, d)`, `T = F − O = (k·sx − O.x, k·sy − O.y, f)`, `D = T/|T|`; the pinhole's
    /// footprint scaled by `|F|/|T|`, which with `|F| = k·L` is `ray_spread = (half_pixel·k·d)·W^¼/(L·|T|)`
    /// (`L` and `W` as for [`PerspectiveRays::pinhole`]); `min_dist = (near/f)·|T|`, `max_dist =
    /// (far/f)·|T|` (`near/D.z` with `D.z = f/|T|`). Two `sqrt`s and one `div`: `g = 1/(L·|T|)`, then
    /// `1/|T| = L·g` (the divider is the thin-lens kernel's bottleneck; this costs `D` at most one
    /// rounding more than `1/|T|` would).
    #[inline(always)]
    #[must_use]
    pub fn thin_lens(&self, s: Point2, a: Point2, d: f32) -> RayGeometry {
        let f = self.focal_distance;
        let k = f / d;
        let (sx2, sy2, d2) = (s.x * s.x, s.y * s.y, d * d);
        let l = (sx2 + sy2 + d2).sqrt();
        let w = footprint_w(sx2, sy2, d2);
        let (ox, oy) = (self.lens_radius * a.x, self.lens_radius * a.y);
        let (tx, ty) = (s.x * k - ox, s.y * k - oy);
        let len = (tx * tx + ty * ty + f * f).sqrt();
        let inv_l_len = 1.0 / (l * len);
        let inv_len = l * inv_l_len;
        RayGeometry {
            origin: Vec3::new(ox, oy, 0.0),
            origin_radius: 0.0,
            direction: Vec3::new(tx * inv_len, ty * inv_len, f * inv_len),
            ray_spread: quarter_root(w) * ((self.half_pixel * k * d) * inv_l_len),
            min_dist: (self.near / f) * len,
            max_dist: (self.far / f) * len,
        }
    }

    /// The ray for screen point `s`: thin lens when the lens radius is positive, else the pinhole.
    #[inline(always)]
    #[must_use]
    pub fn ray(&self, s: Point2, a: Point2, d: f32) -> RayGeometry {
        if self.lens_radius > 0.0 {
            self.thin_lens(s, a, d)
        } else {
            self.pinhole(s, d)
        }
    }
}

/// The seed of [`quarter_root`]'s Newton iteration: `w^(−¼)` read off the bits of `w`
/// (`bits(r) ≈ 1.25·bits(1.0) − bits(w)/4`, the constant tuned for the smallest worst-case error).
pub const QUARTER_ROOT_SEED: u32 = 0x4F58_4000;

/// `W = min(((sx² + d²)·(1/d²))·((sy² + d²)·(1/d²)), 2¹²⁰)` from the squares `sx²`, `sy²`, `d²`:
/// the argument of the footprint's fourth root in [`PerspectiveRays::pinhole`] and `thin_lens`.
#[inline(always)]
fn footprint_w(sx2: f32, sy2: f32, d2: f32) -> f32 {
    let inv_d2 = 1.0 / d2;
    (((sx2 + d2) * inv_d2) * ((sy2 + d2) * inv_d2)).min(PINHOLE_W_MAX)
}

/// The largest `W` [`PerspectiveRays::pinhole`] takes the fourth root of: `2¹²⁰`, where
/// [`quarter_root`] is still exact to a millionth (`W` passes it only when `tan θx·tan θy > 2⁶⁰`).
pub const PINHOLE_W_MAX: f32 = f32::from_bits(0x7B80_0000);

/// `w^¼` for `w ∈ [0, 2¹²⁰]`, to 1e-6 relative (8.5·2⁻²⁴ worst over `[2⁻¹⁰⁰, 2¹²⁰]`, measured),
/// with multiplications, fused multiply-adds and one integer shift only.
///
/// Three Newton steps `r ← (5/4)·r − ((w/4)·r²)·(r²·r)` on `r ≈ w^(−¼)` from a bit-pattern seed,
/// then `w^¼ = (w·r)·(r·r)`; the last product and the subtraction of each step are one fused
/// multiply-add ([`f32::mul_add`]: `c − a·b` rounded once), so that each step is three dependent
/// operations (the kernels are bound by this chain's latency), and the products are grouped so that
/// `w = 0` gives 0, not `0·∞`. No `sqrt` or division: the divider is the other bottleneck of the
/// perspective kernels. Every operation here is correctly rounded, so every SIMD tier (`vfnmadd` in
/// AVX2 and AVX-512) and every platform reproduces it bit for bit. Where the CPU has no FMA unit (x86
/// before AVX2) `mul_add` is a call into libm's `fmaf` and the portable tier runs two to four times
/// slower (BENCHMARKS.md); ARM and every x86 with AVX2 fuse in hardware.
#[inline(always)]
#[must_use]
pub fn quarter_root(w: f32) -> f32 {
    let quarter_w = 0.25 * w;
    let mut r = f32::from_bits(QUARTER_ROOT_SEED.wrapping_sub(w.to_bits() >> 2));
    for _ in 0..3 {
        let r2 = r * r;
        r = (-(quarter_w * r2)).mul_add(r2 * r, 1.25 * r);
    }
    (w * r) * (r * r)
}

/// The constants of one orthographic camera, ready to make rays.
///
/// The ray of screen point `(sx, sy)` starts at `(sx, sy, 0)` and runs down +Z; its footprint is a
/// cylinder of half a pixel in radius (`origin_radius = ½·sqrt(Δx·Δy)`, `ray_spread = 0`). With a thin
/// lens of radius `R` focused at `f`, the lens is centred on the pixel's own origin: the ray leaves
/// `O = (sx + R·ax, sy + R·ay, 0)` toward `F = (sx, sy, f)`. (pbrt-v3 centred the lens on the camera axis
/// instead, which tilts the focal cone off-axis: its issue 315.)
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrthographicRays {
    /// `½·sqrt(Δx·Δy)`, half a pixel in screen units.
    pub half_pixel: f32,
    /// Lens radius; 0 for no depth of field.
    pub lens_radius: f32,
    /// Distance of the plane of focus.
    pub focal_distance: f32,
    /// Near clipping plane z.
    pub near: f32,
    /// Far clipping plane z.
    pub far: f32,
}

impl OrthographicRays {
    /// Constants for a pixel of `Δx × Δy` screen units, clipping `(near, far)`, and a lens.
    #[must_use]
    pub fn new(pixel_size: (f32, f32), clipping: (f32, f32), lens_radius: f32, focal_distance: f32) -> Self {
        OrthographicRays {
            half_pixel: 0.5 * (pixel_size.0 * pixel_size.1).sqrt(),
            lens_radius,
            focal_distance,
            near: clipping.0,
            far: clipping.1,
        }
    }

    /// The ray for screen point `s` and aperture sample `a ∈ [−1, 1]²`.
    #[inline(always)]
    #[must_use]
    pub fn ray(&self, s: Point2, a: Point2) -> RayGeometry {
        if self.lens_radius > 0.0 {
            let origin = Vec3::new(s.x + self.lens_radius * a.x, s.y + self.lens_radius * a.y, 0.0);
            let focus = Vec3::new(s.x, s.y, self.focal_distance);
            let dir = (focus - origin).normalize_or_zero();
            RayGeometry {
                origin,
                origin_radius: self.half_pixel,
                direction: dir,
                ray_spread: 0.0,
                min_dist: self.near / dir.z,
                max_dist: self.far / dir.z,
            }
        } else {
            RayGeometry {
                origin: Vec3::new(s.x, s.y, 0.0),
                origin_radius: self.half_pixel,
                direction: Vec3::Z,
                ray_spread: 0.0,
                min_dist: self.near,
                max_dist: self.far,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn screen_distance_matches_the_conventions_page() {
        // The same bits whether the argument is folded at compile time or known only at run time.
        for fov in [60.0f32, 40.0, 37.0, 90.0, 120.0] {
            assert_eq!(
                screen_distance(fov),
                screen_distance(std::hint::black_box(fov)),
                "{fov}"
            );
        }
        assert_eq!(screen_distance(60.0), (1.0 / 30f64.to_radians().tan()) as f32);
        assert!((screen_distance(90.0) - 1.0).abs() < 1e-6);
        assert!((screen_distance(20.0) - 5.6713).abs() < 1e-4);
        assert!((fov_from_distance(screen_distance(37.0)) - 37.0).abs() < 1e-4);
    }

    #[test]
    fn thin_lens_rays_meet_at_the_focus_point() {
        let p = PerspectiveRays::new((0.01, 0.01), (0.1, f32::INFINITY), 0.5, 7.0);
        let s = Point2::new(0.3, -0.4);
        let d = 1.5;
        let focus = Vec3::new(s.x * 7.0 / d, s.y * 7.0 / d, 7.0);
        for a in [
            Point2::new(1.0, 0.0),
            Point2::new(-0.3, 0.9),
            Point2::new(0.0, 0.0),
        ] {
            let r = p.thin_lens(s, a, d);
            let t = (focus.z - r.origin.z) / r.direction.z;
            let hit = r.origin + r.direction * t;
            assert!((hit - focus).length() < 1e-5, "{hit:?}");
        }
    }

    #[test]
    fn quarter_root_is_the_fourth_root_to_a_millionth() {
        assert_eq!(quarter_root(0.0), 0.0);
        assert_eq!(quarter_root(1.0).to_bits(), 1.0f32.to_bits());
        assert_eq!(quarter_root(16.0), 2.0);
        assert_eq!(PINHOLE_W_MAX, 2.0f32.powi(120));
        // Every octave from 2⁻¹⁰⁰ to 2¹²⁰ (the pinhole's `W` reaches the top) at 4096 points each.
        let mut worst = 0.0f64;
        for e in -100..120 {
            for i in 0..4096 {
                let w = (2.0f64.powi(e) * (1.0 - i as f64 / 8192.0)) as f32;
                let exact = f64::from(w).powf(0.25);
                worst = worst.max((f64::from(quarter_root(w)) / exact - 1.0).abs());
            }
        }
        assert!(worst < 1e-6, "worst relative error {worst:e}");
    }

    /// Far off axis the pinhole's `W` grows as `tan⁴θ`: the footprint still matches the f64 formula up
    /// to `tan θ = 10⁹` and stays finite and positive beyond, where `W` is held to 2¹²⁰.
    #[test]
    fn pinhole_footprint_stays_finite_far_off_axis() {
        let p = PerspectiveRays::new((0.002, 0.002), (0.1, 1e4), 0.0, 1.0);
        for e in 0..=18 {
            let t = 10f32.powi(e);
            for s in [Point2::new(t, t), Point2::new(t, 0.5), Point2::new(-0.5, t)] {
                let r = p.pinhole(s, 1.0);
                assert!(
                    r.ray_spread.is_finite() && r.ray_spread > 0.0,
                    "{s:?}: {}",
                    r.ray_spread
                );
                let (x, y) = (f64::from(s.x), f64::from(s.y));
                let l2 = x * x + y * y + 1.0;
                let exact = f64::from(p.half_pixel) * ((x * x + 1.0) * (y * y + 1.0)).powf(0.25) / l2;
                if e <= 9 {
                    let err = (f64::from(r.ray_spread) / exact - 1.0).abs();
                    assert!(err < 1e-5, "{s:?}: {} vs {exact:e}", r.ray_spread);
                }
            }
        }
    }

    /// The rearranged footprint and clipping distances against the module's formulas in f64:
    /// `½·sqrt(αx·αy)`, `near/D.z`, and through a lens the pinhole's spread times `|F|/|F − O|`.
    #[test]
    fn perspective_rays_match_the_textbook_formulas() {
        let p = PerspectiveRays::new((0.004, 0.003), (0.1, 1000.0), 0.05, 3.0);
        for i in 0..2000 {
            let s = Point2::new(
                (i as f32 * 0.618).fract() * 3.0 - 1.5,
                (i as f32 * 0.377).fract() * 2.0 - 1.0,
            );
            let a = Point2::new(
                (i as f32 * 0.1234).fract() * 2.0 - 1.0,
                (i as f32 * 0.771).fract() * 2.0 - 1.0,
            );
            let d = 0.2 + (i % 7) as f32;
            let (x, y, dd) = (f64::from(s.x), f64::from(s.y), f64::from(d));
            let l2 = x * x + y * y + dd * dd;
            let ax = 0.004 * (y * y + dd * dd).sqrt() / l2;
            let ay = 0.003 * (x * x + dd * dd).sqrt() / l2;
            let spread = 0.5 * (ax * ay).sqrt();
            let close = |got: f32, want: f64| (f64::from(got) / want - 1.0).abs() < 2e-6;
            let pin = p.pinhole(s, d);
            assert!(close(pin.ray_spread, spread), "{} vs {spread}", pin.ray_spread);
            assert!(
                close(pin.min_dist, 0.1 * l2.sqrt() / dd) && close(pin.max_dist, 1000.0 * l2.sqrt() / dd)
            );
            let k = 3.0 / dd;
            let (ox, oy) = (0.05 * f64::from(a.x), 0.05 * f64::from(a.y));
            let t = [k * x - ox, k * y - oy, 3.0];
            let tl = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
            let lens = p.thin_lens(s, a, d);
            assert!(close(lens.ray_spread, spread * k * l2.sqrt() / tl), "{i}");
            assert!(
                close(lens.direction.x, t[0] / tl) || (lens.direction.x - (t[0] / tl) as f32).abs() < 1e-7
            );
            assert!(close(lens.direction.z, 3.0 / tl));
            assert!(close(lens.min_dist, 0.1 * tl / 3.0) && close(lens.max_dist, 1000.0 * tl / 3.0));
        }
    }
}
