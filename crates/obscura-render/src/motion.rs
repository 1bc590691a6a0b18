//! Motion over the shutter: a transform sampled at shutter-normalised times, ready to evaluate at a
//! ray's time. The scene accelerator uses it for moving instances, the render loop for the camera.
//!
//! # Interpolation
//!
//! Between two samples the transform is decomposed into scale, rotation and translation; scale and
//! translation are interpolated linearly and rotation by shortest-path slerp. Outside the sampled
//! range the nearest sample holds (a NaN time takes the first sample). A single sample is used
//! exactly as given, with its inverse computed once.

use glam::{Affine3A, Quat, Vec3A};

/// One decomposed motion sample.
#[derive(Debug, Clone, Copy)]
pub struct Key {
    pub(crate) time: f32,
    pub(crate) scale: Vec3A,
    pub(crate) rotation: Quat,
    pub(crate) translation: Vec3A,
}

impl Key {
    fn new(time: f32, m: &Affine3A) -> Self {
        let (scale, rotation, translation) = m.to_scale_rotation_translation();
        Self {
            time,
            scale: scale.into(),
            rotation,
            translation: translation.into(),
        }
    }
}

/// SRT interpolation between two keys, `f` in `[0, 1]`.
#[inline]
pub(crate) fn interpolate(a: &Key, b: &Key, f: f32) -> Affine3A {
    Affine3A::from_scale_rotation_translation(
        a.scale.lerp(b.scale, f).into(),
        a.rotation.slerp(b.rotation, f),
        a.translation.lerp(b.translation, f).into(),
    )
}

/// A transform over the shutter, ready to evaluate at any time: one matrix, or decomposed keys
/// interpolated by scale/rotation/translation (used for instances by the scene accelerator and for
/// the camera by the render loop).
#[derive(Debug, Clone)]
pub enum Motion {
    /// Does not move.
    Static {
        /// The transform.
        to_world: Affine3A,
        /// Its inverse.
        to_object: Affine3A,
    },
    /// Moves: keys sorted by time.
    Moving {
        /// The decomposed samples.
        keys: Vec<Key>,
    },
}

impl Motion {
    /// From `(time, transform)` samples (sorted here; non-finite times dropped; none = identity).
    #[must_use]
    pub fn new(samples: &[(f32, Affine3A)]) -> Self {
        let mut samples: Vec<(f32, Affine3A)> = samples.iter().copied().filter(|s| s.0.is_finite()).collect();
        samples.sort_by(|a, b| a.0.total_cmp(&b.0));
        match samples.as_slice() {
            [] => Self::Static {
                to_world: Affine3A::IDENTITY,
                to_object: Affine3A::IDENTITY,
            },
            [(_, m)] => Self::Static {
                to_world: *m,
                to_object: m.inverse(),
            },
            many => Self::Moving {
                keys: many.iter().map(|(t, m)| Key::new(*t, m)).collect(),
            },
        }
    }

    /// The transform at `time` (clamped to the sampled range).
    #[must_use]
    pub fn object_to_world(&self, time: f32) -> Affine3A {
        match self {
            Self::Static { to_world, .. } => *to_world,
            Self::Moving { keys } => {
                let (first, last) = (&keys[0], &keys[keys.len() - 1]);
                // NaN times take the first sample, like times before the shutter opens.
                if time.is_nan() || time <= first.time {
                    return interpolate(first, first, 0.0);
                }
                if time >= last.time {
                    return interpolate(last, last, 0.0);
                }
                // first.time < time < last.time, so 1 <= i < keys.len().
                let i = keys.partition_point(|k| k.time <= time);
                let (a, b) = (&keys[i - 1], &keys[i]);
                interpolate(a, b, (time - a.time) / (b.time - a.time))
            }
        }
    }

    /// The inverse transform at `time` (computed once for a static transform).
    #[inline]
    pub(crate) fn world_to_object(&self, time: f32) -> Affine3A {
        match self {
            Self::Static { to_object, .. } => *to_object,
            Self::Moving { .. } => self.object_to_world(time).inverse(),
        }
    }
}

/// The interpolation against an independent model; that model, `rotating_transform`, is
/// shared with the scene accelerator's tests.
#[cfg(test)]
pub(crate) mod tests {
    use core::f32::consts::FRAC_PI_2;

    use super::*;
    use crate::rng::Rng;

    /// The independent motion model for the rotating tests: `Ry(90°·time)` then a translation.
    pub(crate) fn rotating_transform(time: f32) -> Affine3A {
        let s = time.clamp(0.0, 1.0);
        Affine3A::from_translation(glam::Vec3::new(0.5 * s, 0.0, -s))
            * Affine3A::from_rotation_y(FRAC_PI_2 * s)
    }

    /// Two samples of [`rotating_transform`] interpolate to it at any time, clamped outside `[0, 1]`.
    #[test]
    fn instance_transform_at_follows_slerp_and_lerp() {
        let motion = Motion::new(&[(0.0, rotating_transform(0.0)), (1.0, rotating_transform(1.0))]);
        let mut rng = Rng::new(11, 0);
        for _ in 0..100 {
            let time = rng.next_f32() * 1.4 - 0.2;
            let got = motion.object_to_world(time);
            assert!(
                got.abs_diff_eq(rotating_transform(time), 1e-5),
                "time {time}: {got:?}"
            );
        }
    }
}
