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
#[inline]
#[must_use]
pub fn screen_distance(fov_degrees: f32) -> f32 {
    1.0 / (0.5 * fov_degrees.to_radians()).tan()
}

/// The field of view in degrees whose screen plane lies at `d`: the inverse of [`screen_distance`].
#[inline]
#[must_use]
pub fn fov_from_distance(d: f32) -> f32 {
    2.0 * (1.0 / d).atan().to_degrees()
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
    #[inline(always)]
    #[must_use]
    pub fn pinhole(&self, s: Point2, d: f32) -> RayGeometry {
        let (sx2, sy2, d2) = (s.x * s.x, s.y * s.y, d * d);
        let l2 = sx2 + sy2 + d2;
        let inv_l = 1.0 / l2.sqrt();
        let dz = d * inv_l;
        let spread = self.half_pixel * ((sx2 + d2) * (sy2 + d2)).sqrt().sqrt() / l2;
        RayGeometry {
            origin: Vec3::ZERO,
            origin_radius: 0.0,
            direction: Vec3::new(s.x * inv_l, s.y * inv_l, dz),
            ray_spread: spread,
            min_dist: self.near / dz,
            max_dist: self.far / dz,
        }
    }

    /// Pinhole rays for a whole batch with the screen plane at `d`, one [`PerspectiveRays::pinhole`] per
    /// sample (the portable path; `PxrPerspective` adds an AVX2 kernel with bit-identical results).
    pub fn pinhole_batch(&self, screen: &[Point2], d: f32, out: &mut [RayGeometry]) {
        for (o, s) in out.iter_mut().zip(screen) {
            *o = self.pinhole(*s, d);
        }
    }

    /// The thin-lens ray through screen point `s` from aperture sample `a ∈ [−1, 1]²`.
    #[inline(always)]
    #[must_use]
    pub fn thin_lens(&self, s: Point2, a: Point2, d: f32) -> RayGeometry {
        let pin = self.pinhole(s, d);
        let k = self.focal_distance / d;
        let focus = Vec3::new(s.x * k, s.y * k, self.focal_distance);
        let origin = Vec3::new(self.lens_radius * a.x, self.lens_radius * a.y, 0.0);
        let to_focus = focus - origin;
        let len = to_focus.length();
        let dir = to_focus * (1.0 / len);
        RayGeometry {
            origin,
            origin_radius: 0.0,
            direction: dir,
            ray_spread: pin.ray_spread * focus.length() / len,
            min_dist: self.near / dir.z,
            max_dist: self.far / dir.z,
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
}
