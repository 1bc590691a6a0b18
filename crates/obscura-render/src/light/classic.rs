//! Point and spot lights (the classic `pointlight` and `spotlight`): delta lights at a point.
//!
//! A point light of strength `S` gives the irradiance `S / d²` on a surface facing it at distance
//! `d` (the RenderMan Interface's `1/(L·L)` falloff). A spot light multiplies that by the spec's
//! `spotlight` attenuation
//!
//! `cosᵇ α · smoothstep(cos θ_c, cos(θ_c − δ), cos α)`, `cos α = (−ωᵢ)·A`,
//!
//! with `A` the beam's axis, `θ_c` the cone angle, `δ` the cone delta angle, `b` the beam
//! distribution and `smoothstep(e₀, e₁, x) = 3t² − 2t³`, `t = clamp((x − e₀)/(e₁ − e₀), 0, 1)`
//! (0 outside the cone, where `cos α < cos θ_c`). Being deltas, they are reached by light sampling
//! only and are not seen by camera or BSDF rays.

use glam::Vec3A;

/// A point light, with the spot's cone when it has one.
#[derive(Debug, Clone)]
pub(super) struct PointLight {
    /// `S`.
    pub(super) strength: Vec3A,
    /// World-space position.
    pub(super) position: Vec3A,
    /// The spot's beam, if any.
    pub(super) spot: Option<SpotBeam>,
}

/// A spot light's beam.
#[derive(Debug, Clone, Copy)]
pub(super) struct SpotBeam {
    /// Unit axis `A`.
    pub(super) axis: Vec3A,
    /// `cos θ_c`.
    pub(super) cos_outer: f32,
    /// `cos(θ_c − δ)`.
    pub(super) cos_inner: f32,
    /// `b`.
    pub(super) beam_distribution: f32,
}

/// `smoothstep(e0, e1, x)` as the RenderMan Shading Language defines it.
pub(super) fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    if x < e0 {
        0.0
    } else if x >= e1 {
        1.0
    } else {
        let t = (x - e0) / (e1 - e0);
        t * t * (3.0 - 2.0 * t)
    }
}

impl SpotBeam {
    /// The beam for a cone angle, delta and distribution (radians).
    pub(super) fn new(axis: Vec3A, cone_angle: f32, cone_delta: f32, beam_distribution: f32) -> Option<SpotBeam> {
        let axis = axis.try_normalize()?;
        let ok = |x: f32| x.is_finite();
        if !(ok(cone_angle) && ok(cone_delta) && ok(beam_distribution)) {
            return None;
        }
        Some(SpotBeam {
            axis,
            cos_outer: cone_angle.cos(),
            cos_inner: (cone_angle - cone_delta).cos(),
            beam_distribution,
        })
    }

    /// The attenuation for light leaving toward `dir` (unit, from the light).
    pub(super) fn attenuation(&self, dir: Vec3A) -> f32 {
        let c = dir.dot(self.axis);
        if c < self.cos_outer || c <= 0.0 {
            return 0.0;
        }
        c.powf(self.beam_distribution) * smoothstep(self.cos_outer, self.cos_inner, c)
    }
}

impl PointLight {
    /// `(ωᵢ, d, radiance)` for the shading point `p`: the unit direction to the light, its
    /// distance and `S·attenuation / d²`; `None` at the light's own position.
    pub(super) fn illuminate(&self, p: Vec3A) -> Option<(Vec3A, f32, Vec3A)> {
        let v = self.position - p;
        let d2 = v.length_squared();
        if !(d2 > 0.0 && d2.is_finite()) {
            return None;
        }
        let d = d2.sqrt();
        let wi = v / d;
        let atten = self.spot.map_or(1.0, |s| s.attenuation(-wi));
        (atten > 0.0).then(|| (wi, d, self.strength * (atten / d2)))
    }
}
