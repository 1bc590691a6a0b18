//! The ray a projection writes (`RtRayGeometry`).

use crate::geometry::Vec3;

/// One camera ray, in camera space (RenderMan's `RtRayGeometry`, the fields a projection owns).
///
/// `#[repr(C)]`, 40 bytes, field order as in RenderMan: it is written in place into the host's
/// batch and is part of the plugin ABI.
///
/// | field | meaning |
/// |---|---|
/// | `origin` | where the ray starts (the pinhole is the origin) |
/// | `origin_radius` | radius of the ray's footprint cone at the origin (0 for a pinhole) |
/// | `direction` | unit length, or exactly [`Vec3::ZERO`] to cull the sample |
/// | `ray_spread` | growth of the footprint radius per unit distance (1 = 45°) |
/// | `min_dist`, `max_dist` | hits nearer than `min_dist` or farther than `max_dist` are ignored |
///
/// The footprint cone is the one pixel's footprint makes: its **radius is half a pixel** (the cone is
/// one pixel across), so at distance `t` along the ray the radius is `origin_radius + ray_spread·t`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayGeometry {
    /// Ray origin in camera space.
    pub origin: Vec3,
    /// Footprint radius at the origin.
    pub origin_radius: f32,
    /// Unit direction in camera space, or zero to cull.
    pub direction: Vec3,
    /// Footprint radius growth per unit distance.
    pub ray_spread: f32,
    /// Nearest accepted hit distance along the ray.
    pub min_dist: f32,
    /// Farthest accepted hit distance along the ray.
    pub max_dist: f32,
}

impl RayGeometry {
    /// A culled ray: zero direction, everything else zero, `max_dist` infinite.
    pub const CULLED: RayGeometry = RayGeometry {
        origin: Vec3::ZERO,
        origin_radius: 0.0,
        direction: Vec3::ZERO,
        ray_spread: 0.0,
        min_dist: 0.0,
        max_dist: f32::INFINITY,
    };

    /// True when the direction is exactly zero: the host culls this sample.
    #[inline]
    #[must_use]
    pub fn is_culled(&self) -> bool {
        self.direction == Vec3::ZERO
    }

    /// The bit patterns of the ten fields in memory order: what "bit-identical rays" compares (`==` on
    /// the floats would equate 0 and −0 and never NaN with itself).
    #[must_use]
    pub fn to_bits(&self) -> [u32; 10] {
        [
            self.origin.x,
            self.origin.y,
            self.origin.z,
            self.origin_radius,
            self.direction.x,
            self.direction.y,
            self.direction.z,
            self.ray_spread,
            self.min_dist,
            self.max_dist,
        ]
        .map(f32::to_bits)
    }
}

impl Default for RayGeometry {
    fn default() -> Self {
        RayGeometry::CULLED
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_is_renderman_order_and_forty_bytes() {
        assert_eq!(std::mem::size_of::<RayGeometry>(), 40);
        assert_eq!(std::mem::offset_of!(RayGeometry, origin), 0);
        assert_eq!(std::mem::offset_of!(RayGeometry, origin_radius), 12);
        assert_eq!(std::mem::offset_of!(RayGeometry, direction), 16);
        assert_eq!(std::mem::offset_of!(RayGeometry, ray_spread), 28);
        assert_eq!(std::mem::offset_of!(RayGeometry, min_dist), 32);
        assert_eq!(std::mem::offset_of!(RayGeometry, max_dist), 36);
    }
}
