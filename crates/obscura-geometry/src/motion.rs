//! Motion over the shutter: a transform sampled at shutter-normalised times, ready to evaluate at a
//! ray's time. The scene accelerator uses it for moving instances, the render loop for the camera.
//!
//! # Interpolation
//!
//! Between two samples the transform is decomposed into scale, rotation and translation; scale and
//! translation are interpolated linearly and rotation by shortest-path slerp. Outside the sampled
//! range the nearest sample holds (a NaN time takes the first sample). A single sample is used
//! exactly as given, with its inverse computed once.

use glam::{Affine3A, Mat4, Quat, Vec3A};
use obscura_sdk::{Matrix4, MotionSample};

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
    pub fn world_to_object(&self, time: f32) -> Affine3A {
        match self {
            Self::Static { to_object, .. } => *to_object,
            Self::Moving { .. } => self.object_to_world(time).inverse(),
        }
    }
}

/// A glam (column-vector) matrix from an SDK (row-vector) one.
#[must_use]
pub fn glam_from_sdk(m: &Matrix4) -> Mat4 {
    Mat4::from_cols_array_2d(&m.0)
}

/// Maps scene times to shutter-normalised time: `(t − open)/(close − open)`, not clamped, so motion
/// keys outside the shutter keep their place (a shutter shorter than the motion blurs less). For an
/// instantaneous shutter, `t − open`: rays at time 0 then see the transform at the shutter time.
#[must_use]
pub fn normalise_time(t: f32, shutter: (f32, f32)) -> f32 {
    let span = shutter.1 - shutter.0;
    if span > 0.0 {
        (t - shutter.0) / span
    } else {
        t - shutter.0
    }
}

/// An object's motion over the shutter, from its transform samples in scene time.
#[must_use]
pub fn object_motion(samples: &[(f32, Mat4)], shutter: (f32, f32)) -> Vec<(f32, Affine3A)> {
    (samples.iter())
        .map(|(t, m)| (normalise_time(*t, shutter), Affine3A::from_mat4(*m)))
        .collect()
}

/// Camera-to-world over the shutter (shutter-normalised time), from world-to-camera motion samples
/// (the camera stage's, or another frame's).
///
/// # Errors
/// A message naming the shutter time and the rows when a sample's transform is singular or not
/// finite (the renderer reports it as a camera error).
pub fn camera_motion(world_to_camera: &[MotionSample], shutter: (f32, f32)) -> Result<Motion, String> {
    let mut camera_to_world = Vec::new();
    for s in world_to_camera {
        let world_to_camera = glam_from_sdk(&s.world_to_camera);
        let det = world_to_camera.determinant();
        let inverse = world_to_camera.inverse();
        if !world_to_camera.is_finite() || det == 0.0 || !det.is_finite() || !inverse.is_finite() {
            let rows: Vec<String> = (0..4)
                .map(|r| {
                    let row = world_to_camera.row(r);
                    format!("{} {} {} {}", row.x, row.y, row.z, row.w)
                })
                .collect();
            return Err(format!(
                "the camera transform (world to camera) at shutter time {} cannot be inverted: determinant {det}, \
                 rows [{}]; a Scale with a zero factor or a degenerate Transform/ConcatTransform before WorldBegin \
                 collapses the camera",
                s.time,
                rows.join(" | ")
            ));
        }
        camera_to_world.push((normalise_time(s.time, shutter), Affine3A::from_mat4(inverse)));
    }
    Ok(Motion::new(&camera_to_world))
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

    #[test]
    fn motion_keys_outside_the_shutter_keep_their_place() {
        // Regression: keys were clamped into [0, 1], so a shutter half as long as the motion blurred
        // the whole move.
        assert_eq!(normalise_time(1.0, (0.0, 0.5)), 2.0);
        assert_eq!(normalise_time(-1.0, (0.0, 1.0)), -1.0);
        assert_eq!(normalise_time(0.25, (0.0, 0.5)), 0.5);
        // An instantaneous shutter at 0.3 sees the transform at scene time 0.3.
        assert!((normalise_time(0.5, (0.3, 0.3)) - 0.2).abs() < 1e-6);
    }
}
