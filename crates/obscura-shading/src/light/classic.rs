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
use obscura_scene::PointEmitter;

/// A point light, with the spot's cone when it has one.
#[derive(Debug, Clone)]
pub(super) struct PointLight {
    /// `S`.
    pub(super) strength: Vec3A,
    /// World-space position.
    pub(super) position: Vec3A,
    /// The spot's beam, if any.
    pub(super) spot: Option<SpotBeam>,
    /// `enable_shadows`: surfaces between a point and the light block it.
    pub(super) shadows: bool,
}

impl PointLight {
    /// The light of `emitter` (its strength `S = color · intensity`), with the spot's beam when it
    /// has one; `None` at a non-finite position.
    pub(super) fn new(emitter: &PointEmitter, spot: Option<SpotBeam>) -> Option<PointLight> {
        if !emitter.position.is_finite() {
            return None;
        }
        Some(PointLight {
            strength: super::strength(emitter.color, emitter.intensity, 0.0),
            position: Vec3A::from(emitter.position),
            spot,
            shadows: emitter.enable_shadows,
        })
    }
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
    pub(super) fn new(
        axis: Vec3A,
        cone_angle: f32,
        cone_delta: f32,
        beam_distribution: f32,
    ) -> Option<SpotBeam> {
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

#[cfg(test)]
mod tests {
    use std::path::Path;

    use glam::Vec3;
    use obscura_scene::{Light, PointEmitter};
    use obscura_sdk::Rgb;

    use super::*;
    use crate::light::Lights;

    fn emitter(intensity: f32) -> PointEmitter {
        PointEmitter {
            color: Rgb::new(1.0, 0.5, 0.25),
            intensity,
            position: Vec3::new(0.0, 0.0, 2.0),
            enable_shadows: true,
        }
    }

    #[test]
    fn a_point_light_falls_off_as_one_over_d_squared() {
        let lights = Lights::new(&[Light::Point(emitter(8.0))], Path::new(".")).unwrap();
        let s = lights.sample(Vec3A::ZERO, Vec3A::Z, (0.3, 0.7), 0.5).unwrap();
        assert!((s.wi - Vec3A::Z).length() < 1e-6 && (s.dist - 2.0).abs() < 1e-6);
        assert!(
            (s.radiance - Vec3A::new(2.0, 1.0, 0.5)).length() < 1e-6,
            "{}",
            s.radiance
        );
        assert!(!s.mis && s.pdf == 1.0);
        // The light is not seen by rays.
        assert_eq!(lights.background(Vec3A::Z), Vec3A::ZERO);
    }

    /// The spec's `spotlight`, written out independently: `cosᵇ α / d² · smoothstep(...)`.
    fn rsl_spotlight(cos: f64, cone: f64, delta: f64, beam: f64, d2: f64) -> f64 {
        let (e0, e1) = (cone.cos(), (cone - delta).cos());
        let t = ((cos - e0) / (e1 - e0)).clamp(0.0, 1.0);
        if cos < e0 {
            0.0
        } else {
            cos.powf(beam) / d2 * t * t * (3.0 - 2.0 * t)
        }
    }

    #[test]
    fn a_spot_light_follows_the_spec_shader_across_its_cone() {
        let (cone, delta, beam) = (30f32.to_radians(), 5f32.to_radians(), 2.0);
        let spot = Light::Spot {
            emitter: PointEmitter {
                color: Rgb::WHITE,
                intensity: 1.0,
                position: Vec3::ZERO,
                enable_shadows: true,
            },
            direction: Vec3::Z,
            cone_angle: cone,
            cone_delta: delta,
            beam_distribution: beam,
        };
        let lights = Lights::new(&[spot], Path::new(".")).unwrap();
        let mut inside_edge = 0;
        for k in 0..=80 {
            let angle = (f64::from(k) * 0.5).to_radians(); // 0° … 40°
            let p = Vec3A::new(angle.sin() as f32, 0.0, angle.cos() as f32) * 3.0;
            let got = lights
                .sample(p, Vec3A::ZERO, (0.5, 0.5), 0.5)
                .map_or(0.0, |s| f64::from(s.radiance.x));
            let want = rsl_spotlight(angle.cos(), f64::from(cone), f64::from(delta), 2.0, 9.0);
            assert!(
                (got - want).abs() < 1e-4 * want + 1e-8,
                "{angle}: {got} vs {want}"
            );
            if want > 0.0 && want < rsl_spotlight(angle.cos(), f64::from(cone), 0.0, 2.0, 9.0) {
                inside_edge += 1;
            }
        }
        // The soft edge was crossed (not vacuous): some angles are between 0 and the hard-edged value.
        assert!(inside_edge >= 5);
        assert_eq!(smoothstep(0.0, 1.0, 0.5), 0.5);
    }

    #[test]
    fn ambient_lights_sum_into_the_unshadowed_ambient_term_and_are_not_seen() {
        let lights = Lights::new(
            &[
                Light::Ambient {
                    color: Rgb::WHITE,
                    intensity: 0.5,
                },
                Light::Ambient {
                    color: Rgb::new(1.0, 0.0, 0.5),
                    intensity: 0.2,
                },
            ],
            Path::new("."),
        )
        .unwrap();
        // Σ I·C, and nothing a ray can see or a light sample can pick.
        assert!((lights.ambient() - Vec3A::new(0.7, 0.5, 0.6)).length() < 1e-6);
        assert_eq!(lights.background(Vec3A::X), Vec3A::ZERO);
        assert_eq!(lights.escaped(Vec3A::X), (Vec3A::ZERO, 0.0));
        assert!(lights.is_empty());
        assert!(lights.sample(Vec3A::ZERO, Vec3A::Y, (0.5, 0.5), 0.5).is_none());
    }
}
