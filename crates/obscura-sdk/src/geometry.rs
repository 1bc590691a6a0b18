//! Plain `#[repr(C)]` value types shared by projections and hosts.
//!
//! These mirror RenderMan's `RtPoint2`, `RtPoint3`/`RtVector3`, `RtColorRGB` and `RtMatrix4x4`. They are
//! deliberately small and owned by the SDK (not borrowed from a math crate) because they cross the plugin
//! boundary: their layout is part of Obscura's ABI.

use std::ops::{Add, Mul, Neg, Sub};

/// A 2-D point: a screen sample, a lens sample or an aperture sample (`RtPoint2`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Point2 {
    /// Horizontal coordinate.
    pub x: f32,
    /// Vertical coordinate.
    pub y: f32,
}

impl Point2 {
    /// The origin.
    pub const ZERO: Point2 = Point2 { x: 0.0, y: 0.0 };

    /// Makes a point from its coordinates.
    #[inline]
    #[must_use]
    pub const fn new(x: f32, y: f32) -> Self {
        Point2 { x, y }
    }
}

/// A 3-D point or vector in camera space (`RtPoint3`, `RtVector3`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Vec3 {
    /// +X is right in camera space.
    pub x: f32,
    /// +Y is up in camera space.
    pub y: f32,
    /// +Z is the viewing direction in camera space.
    pub z: f32,
}

impl Vec3 {
    /// The zero vector: as a ray direction it means "cull this sample".
    pub const ZERO: Vec3 = Vec3::new(0.0, 0.0, 0.0);
    /// The camera's viewing axis.
    pub const Z: Vec3 = Vec3::new(0.0, 0.0, 1.0);

    /// Makes a vector from its coordinates.
    #[inline]
    #[must_use]
    pub const fn new(x: f32, y: f32, z: f32) -> Self {
        Vec3 { x, y, z }
    }

    /// The dot product.
    #[inline]
    #[must_use]
    pub fn dot(self, o: Vec3) -> f32 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// The cross product.
    #[inline]
    #[must_use]
    pub fn cross(self, o: Vec3) -> Vec3 {
        Vec3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    /// The Euclidean length.
    #[inline]
    #[must_use]
    pub fn length(self) -> f32 {
        self.dot(self).sqrt()
    }

    /// The vector scaled to unit length.
    ///
    /// The zero vector (and any vector whose length is not a positive finite number) comes back as
    /// [`Vec3::ZERO`], which is the cull marker, never NaN.
    #[inline]
    #[must_use]
    pub fn normalize_or_zero(self) -> Vec3 {
        let len = self.length();
        if len > 0.0 && len.is_finite() {
            self * (1.0 / len)
        } else {
            Vec3::ZERO
        }
    }

    /// True when every component is finite.
    #[inline]
    #[must_use]
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
}

impl Add for Vec3 {
    type Output = Vec3;
    #[inline]
    fn add(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for Vec3 {
    type Output = Vec3;
    #[inline]
    fn sub(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Mul<f32> for Vec3 {
    type Output = Vec3;
    #[inline]
    fn mul(self, s: f32) -> Vec3 {
        Vec3::new(self.x * s, self.y * s, self.z * s)
    }
}

impl Neg for Vec3 {
    type Output = Vec3;
    #[inline]
    fn neg(self) -> Vec3 {
        Vec3::new(-self.x, -self.y, -self.z)
    }
}

/// A linear RGB colour (`RtColorRGB`), used for the per-ray tint.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rgb {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
}

impl Rgb {
    /// (1, 1, 1): the tint that leaves the beauty unchanged.
    pub const WHITE: Rgb = Rgb::new(1.0, 1.0, 1.0);
    /// (0, 0, 0).
    pub const BLACK: Rgb = Rgb::new(0.0, 0.0, 0.0);

    /// Makes a colour from its channels.
    #[inline]
    #[must_use]
    pub const fn new(r: f32, g: f32, b: f32) -> Self {
        Rgb { r, g, b }
    }

    /// True when every channel is finite.
    #[inline]
    #[must_use]
    pub fn is_finite(self) -> bool {
        self.r.is_finite() && self.g.is_finite() && self.b.is_finite()
    }
}

impl Default for Rgb {
    fn default() -> Self {
        Rgb::WHITE
    }
}

/// A 4×4 matrix (`RtMatrix4x4`), row-major, acting on row vectors as RenderMan's do: a point `p` maps
/// to `[p 1]·M`, so the translation sits in the last row.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Matrix4(pub [[f32; 4]; 4]);

impl Matrix4 {
    /// The identity.
    pub const IDENTITY: Matrix4 = Matrix4([
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]);

    /// Transforms a point (`[p 1]·M`, divided by w when w is not 1).
    #[must_use]
    pub fn transform_point(&self, p: Vec3) -> Vec3 {
        let m = &self.0;
        let x = p.x * m[0][0] + p.y * m[1][0] + p.z * m[2][0] + m[3][0];
        let y = p.x * m[0][1] + p.y * m[1][1] + p.z * m[2][1] + m[3][1];
        let z = p.x * m[0][2] + p.y * m[1][2] + p.z * m[2][2] + m[3][2];
        let w = p.x * m[0][3] + p.y * m[1][3] + p.z * m[2][3] + m[3][3];
        if w == 1.0 || w == 0.0 {
            Vec3::new(x, y, z)
        } else {
            Vec3::new(x / w, y / w, z / w)
        }
    }

    /// Transforms a direction (`[v 0]·M`): no translation.
    #[must_use]
    pub fn transform_vector(&self, v: Vec3) -> Vec3 {
        let m = &self.0;
        Vec3::new(
            v.x * m[0][0] + v.y * m[1][0] + v.z * m[2][0],
            v.x * m[0][1] + v.y * m[1][1] + v.z * m[2][1],
            v.x * m[0][2] + v.y * m[1][2] + v.z * m[2][2],
        )
    }
}

impl Default for Matrix4 {
    fn default() -> Self {
        Matrix4::IDENTITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalize_of_zero_is_the_cull_marker_not_nan() {
        assert_eq!(Vec3::ZERO.normalize_or_zero(), Vec3::ZERO);
        assert_eq!(Vec3::new(f32::NAN, 0.0, 1.0).normalize_or_zero(), Vec3::ZERO);
        let n = Vec3::new(3.0, 4.0, 12.0).normalize_or_zero();
        assert!((n.length() - 1.0).abs() < 1e-6);
        assert!((n.z - 12.0 / 13.0).abs() < 1e-6);
    }

    #[test]
    fn matrix_uses_row_vectors_with_translation_in_the_last_row() {
        let mut m = Matrix4::IDENTITY;
        m.0[3] = [1.0, 2.0, 3.0, 1.0];
        assert_eq!(
            m.transform_point(Vec3::new(1.0, 1.0, 1.0)),
            Vec3::new(2.0, 3.0, 4.0)
        );
        assert_eq!(
            m.transform_vector(Vec3::new(1.0, 1.0, 1.0)),
            Vec3::new(1.0, 1.0, 1.0)
        );
    }

    #[test]
    fn cross_is_left_handed_camera_consistent() {
        // x × y = z in component form, whatever the handedness of the space it is read in.
        let x = Vec3::new(1.0, 0.0, 0.0);
        let y = Vec3::new(0.0, 1.0, 0.0);
        assert_eq!(x.cross(y), Vec3::Z);
    }
}
