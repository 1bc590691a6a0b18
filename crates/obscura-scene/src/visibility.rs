//! What the camera sees of a surface beyond its geometry: the RenderMan Interface's `Sides`,
//! `Orientation`/`ReverseOrientation` ([`Sides`]), `ClippingPlane` ([`ClipPlane`]) and `Exposure`
//! ([`Exposure`]).
//!
//! # Front and back (RISpec 3.2 §4.2.14, §5)
//!
//! Every primitive has a *natural* normal in its object space: the cross product of its parametric
//! derivatives `∂P/∂u × ∂P/∂v` (for the quadrics, with a positive `thetamax`, it points outward), for
//! a polygon `(P₁ − P₀) × (P₂ − P₀)` taken component by component (under the default left-handed
//! orientation, a polygon whose vertices run clockwise as the camera sees them faces the camera).
//! When the current orientation differs from the handedness of the current coordinate system
//! (`Orientation "inside"`, a `ReverseOrientation`, an `Orientation "rh"` in a left-handed space),
//! the primitive is turned inside out and its normal flipped. A transform with a negative
//! determinant flips both the coordinate system's handedness and the current orientation, so it
//! changes neither: a mirrored object keeps its outside (its vertices now run counter-clockwise on
//! screen, which a right-handed orientation reads as front-facing).
//!
//! The renderer's triangles are wound so that `(v₁ − v₀) × (v₂ − v₀)` is the natural normal
//! (polygons and subdivision meshes keep the file's vertex order, patches and NURBS follow
//! `∂P/∂u × ∂P/∂v`), except that every quadric is wound outward, so a quadric with a negative
//! `thetamax` keeps its outside as its front; an object's [`Sides`] then says which side of each
//! triangle the camera may see.

use glam::Vec3;

/// Which rays see a surface at all: RenderMan's `Attribute "visibility"` (`"int camera"`,
/// `"int transmission"` or the older `"string transmission"`) and BMRT's
/// `Attribute "render" "casts_shadows"`. Every other ray (reflections, bounces) sees everything.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Visibility {
    /// Camera rays see it (`"int camera" [0]`: seen only in reflections and by its shadow).
    pub camera: bool,
    /// It blocks shadow rays (`"int transmission" [0]`, `"string transmission" "transparent"`,
    /// `"casts_shadows" "none"`: it casts no shadow).
    pub shadows: bool,
}

impl Default for Visibility {
    fn default() -> Self {
        Visibility {
            camera: true,
            shadows: true,
        }
    }
}

/// Which sides of a surface camera rays see (`Sides`, with the orientation the surface had).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Sides {
    /// `Sides 2` (the default): both.
    #[default]
    Both,
    /// `Sides 1`: only the side the natural normal points to (the outside).
    Front,
    /// `Sides 1` on a surface turned inside out: only the side opposite the natural normal.
    Back,
}

impl Sides {
    /// `Sides 1` (`one_sided`) or `Sides 2`, for a surface turned inside out or not.
    #[must_use]
    pub fn new(one_sided: bool, inside_out: bool) -> Self {
        match (one_sided, inside_out) {
            (false, _) => Sides::Both,
            (true, false) => Sides::Front,
            (true, true) => Sides::Back,
        }
    }
}

/// The space a [`ClipPlane`] was given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClipSpace {
    /// Camera space: the plane moves with the camera (a `ClippingPlane` before `WorldBegin`).
    Camera,
    /// World space (a `ClippingPlane` inside the world).
    World,
}

/// `ClippingPlane x y z nx ny nz`: geometry on the side the normal points to is not seen by camera
/// rays (RISpec 3.2 §4.1.1: "all geometry on the positive side of the plane … is clipped").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClipPlane {
    /// A point on the plane, in `space`.
    pub point: Vec3,
    /// The normal, in `space` (not necessarily unit); the clipped half-space is `(p − point)·normal > 0`.
    pub normal: Vec3,
    /// The space of `point` and `normal`.
    pub space: ClipSpace,
}

/// `Exposure gain gamma`: each colour component `c` is written as `(c·gain)^(1/gamma)` (RISpec 3.2
/// §4.1.2), after the pixel filter and before quantization.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exposure {
    /// Gain, ≥ 0.
    pub gain: f32,
    /// Gamma, > 0.
    pub gamma: f32,
}

impl Default for Exposure {
    fn default() -> Self {
        Exposure {
            gain: 1.0,
            gamma: 1.0,
        }
    }
}

impl Exposure {
    /// True for `Exposure 1 1`, which changes nothing.
    #[must_use]
    pub fn is_identity(&self) -> bool {
        self.gain == 1.0 && self.gamma == 1.0
    }

    /// `(c·gain)^(1/gamma)`; a negative `c·gain` (a filter's negative lobe) keeps its sign,
    /// `−(|c|·gain)^(1/gamma)`, so the curve stays odd and monotonic.
    #[must_use]
    pub fn apply(&self, c: f32) -> f32 {
        if self.is_identity() {
            return c;
        }
        let v = f64::from(c) * f64::from(self.gain);
        let out = if self.gamma == 1.0 {
            v
        } else {
            v.signum() * v.abs().powf(1.0 / f64::from(self.gamma))
        };
        out as f32
    }
}
