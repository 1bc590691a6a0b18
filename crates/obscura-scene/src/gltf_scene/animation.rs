//! glTF animations: node translation, rotation and scale channels, sampled at any time per the glTF
//! 2.0 specification (§3.11, Appendix C).
//!
//! Every animation of the file plays at once from time 0 (seconds). A channel replaces one property of
//! its node's rest transform (`translation`, `rotation` or `scale`); the others keep their rest value.
//! Between keys `t_k ≤ t < t_{k+1}`, with `s = (t − t_k)/Δ`, `Δ = t_{k+1} − t_k`:
//!
//! - `STEP`: `v_k`;
//! - `LINEAR`: `(1 − s)·v_k + s·v_{k+1}`; rotations by spherical linear interpolation (shortest arc);
//! - `CUBICSPLINE`: the Hermite spline `(2s³ − 3s² + 1)·v_k + Δ(s³ − 2s² + s)·b_k + (−2s³ + 3s²)·v_{k+1} +
//!   Δ(s³ − s²)·a_{k+1}`, with `b_k` key k's out-tangent and `a_{k+1}` key k+1's in-tangent; a rotation
//!   is normalised afterwards.
//!
//! Before the first key the first value holds, after the last the last. Morph-target weights are not
//! supported (a warning names the channel), nor is skinning.

use glam::{Mat4, Quat, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::animation::{Interpolation, Property, util::ReadOutputs};

use super::{GltfError, Loader};
use crate::convert::{flip_z, to_row_vector};
use crate::types::{MotionTransform, Scene};
use obscura_sdk::MotionSample;

/// Gives the objects (each placed by node `object_nodes[i]` of the poses) and the camera (placed by
/// node `camera`) one motion sample per `(shutter time, seconds)` of `times`, from `poses` (each node's
/// world matrix at each time). With one time, nothing changes.
pub(super) fn add_motion(
    scene: &mut Scene,
    times: &[(f32, f32)],
    poses: &[Vec<(gltf::Node<'_>, Mat4)>],
    object_nodes: &[usize],
    camera: Option<usize>,
) {
    if times.len() < 2 {
        return;
    }
    for (object, &node) in scene.objects.iter_mut().zip(object_nodes) {
        let samples: Vec<(f32, Mat4)> = (times.iter().zip(poses))
            .map(|((t, _), pose)| (*t, pose[node].1))
            .collect();
        if samples.windows(2).any(|w| w[0].1 != w[1].1) {
            object.transform = MotionTransform { samples };
        }
    }
    if let Some(node) = camera {
        scene.camera.world_to_camera = (times.iter().zip(poses))
            .map(|((t, _), pose)| MotionSample {
                time: *t,
                world_to_camera: to_row_vector(flip_z() * pose[node].1.inverse()),
            })
            .collect();
    }
}

/// Which property a channel drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Target {
    Translation,
    Rotation,
    Scale,
}

/// One sampled property of one node.
#[derive(Debug, Clone)]
struct Channel {
    node: usize,
    target: Target,
    interpolation: Interpolation,
    /// Key times, seconds, increasing.
    times: Vec<f32>,
    /// Values (x, y, z[, w]); for `CUBICSPLINE` three per key: in-tangent, value, out-tangent.
    values: Vec<Vec4>,
}

impl Channel {
    /// The value at `t` (see the module documentation).
    fn sample(&self, t: f32) -> Vec4 {
        let n = self.times.len();
        let cubic = self.interpolation == Interpolation::CubicSpline;
        let value = |k: usize| {
            if cubic {
                self.values[3 * k + 1]
            } else {
                self.values[k]
            }
        };
        if t.is_nan() || t <= self.times[0] {
            return value(0);
        }
        if t >= self.times[n - 1] {
            return value(n - 1);
        }
        let k = self.times.partition_point(|&x| x <= t) - 1;
        let dt = self.times[k + 1] - self.times[k];
        let s = (t - self.times[k]) / dt;
        match self.interpolation {
            Interpolation::Step => value(k),
            Interpolation::Linear if self.target == Target::Rotation => {
                let (a, b) = (Quat::from_vec4(value(k)), Quat::from_vec4(value(k + 1)));
                Vec4::from(a.normalize().slerp(b.normalize(), s))
            }
            Interpolation::Linear => value(k).lerp(value(k + 1), s),
            Interpolation::CubicSpline => {
                let (s2, s3) = (s * s, s * s * s);
                let v = value(k) * (2.0 * s3 - 3.0 * s2 + 1.0)
                    + self.values[3 * k + 2] * (dt * (s3 - 2.0 * s2 + s))
                    + value(k + 1) * (-2.0 * s3 + 3.0 * s2)
                    + self.values[3 * (k + 1)] * (dt * (s3 - s2));
                if self.target == Target::Rotation {
                    v.normalize()
                } else {
                    v
                }
            }
        }
    }
}

/// The file's animations, ready to pose any node at any time.
#[derive(Debug, Clone, Default)]
pub struct Animation {
    channels: Vec<Channel>,
}

impl Animation {
    /// True when no channel moves anything.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.channels.is_empty()
    }

    /// The last key time over every channel, seconds (0 without channels).
    #[must_use]
    pub fn duration(&self) -> f32 {
        (self.channels.iter())
            .filter_map(|c| c.times.last().copied())
            .fold(0.0, f32::max)
    }

    /// `node`'s local matrix at time `t` (seconds): its rest translation, rotation and scale with the
    /// animated ones replaced.
    #[must_use]
    pub fn local(&self, node: &gltf::Node<'_>, t: f32) -> Mat4 {
        let (tr, rot, sc) = node.transform().decomposed();
        let (mut tr, mut rot, mut sc) = (Vec3::from(tr), Quat::from_array(rot), Vec3::from(sc));
        let mut animated = false;
        for c in self.channels.iter().filter(|c| c.node == node.index()) {
            animated = true;
            let v = c.sample(t);
            match c.target {
                Target::Translation => tr = v.truncate(),
                Target::Rotation => rot = Quat::from_vec4(v).normalize(),
                Target::Scale => sc = v.truncate(),
            }
        }
        if animated {
            Mat4::from_scale_rotation_translation(sc, rot, tr)
        } else {
            // Unanimated nodes keep their matrix exactly as written (it may not decompose exactly).
            Mat4::from_cols_array_2d(&node.transform().matrix())
        }
    }
}

impl Loader<'_> {
    /// Reads every animation channel of `document` that drives a node's translation, rotation or scale.
    ///
    /// # Errors
    /// [`GltfError::Invalid`] naming the animation and channel when an accessor has the wrong type or
    /// lies outside its buffer, key times are not increasing, or outputs do not match the inputs.
    pub(super) fn read_animation(&mut self, document: &gltf::Document) -> Result<Animation, GltfError> {
        let mut out = Animation::default();
        for anim in document.animations() {
            for channel in anim.channels() {
                let here = format!("animation {} channel {}", anim.index(), channel.index());
                let bad = |what: String| GltfError::Invalid {
                    path: self.path.to_path_buf(),
                    what: format!("{here}: {what}"),
                };
                let target = match channel.target().property() {
                    Property::Translation => Target::Translation,
                    Property::Rotation => Target::Rotation,
                    Property::Scale => Target::Scale,
                    Property::MorphTargetWeights => {
                        self.warn(format!("{here}: morph target weights are not supported; ignored"));
                        continue;
                    }
                };
                let sampler = channel.sampler();
                self.check_accessor(&sampler.input(), Dimensions::Scalar, &[DataType::F32])
                    .map_err(|e| bad(format!("input {e}")))?;
                let (dims, types): (Dimensions, &[DataType]) = match target {
                    Target::Rotation => (
                        Dimensions::Vec4,
                        &[
                            DataType::F32,
                            DataType::I8,
                            DataType::U8,
                            DataType::I16,
                            DataType::U16,
                        ],
                    ),
                    _ => (Dimensions::Vec3, &[DataType::F32]),
                };
                self.check_accessor(&sampler.output(), dims, types)
                    .map_err(|e| bad(format!("output {e}")))?;
                let buffers = self.buffers;
                let reader = channel.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
                let times: Vec<f32> = reader
                    .read_inputs()
                    .ok_or_else(|| bad("key times cannot be read".into()))?
                    .collect();
                if times.iter().any(|t| !t.is_finite()) {
                    return Err(bad("a key time is not finite".into()));
                }
                if let Some(w) = times.windows(2).find(|w| w[0] >= w[1]) {
                    return Err(bad(format!(
                        "key times must increase strictly, got {} then {}",
                        w[0], w[1]
                    )));
                }
                let values: Vec<Vec4> = match reader.read_outputs() {
                    Some(ReadOutputs::Translations(v)) | Some(ReadOutputs::Scales(v)) => {
                        v.map(|a| Vec3::from(a).extend(0.0)).collect()
                    }
                    Some(ReadOutputs::Rotations(r)) => r.into_f32().map(Vec4::from).collect(),
                    _ => return Err(bad("output values cannot be read".into())),
                };
                let interpolation = sampler.interpolation();
                let per_key = if interpolation == Interpolation::CubicSpline {
                    3
                } else {
                    1
                };
                if values.len() != per_key * times.len() {
                    return Err(bad(format!(
                        "{} output values for {} key times; expected {}",
                        values.len(),
                        times.len(),
                        per_key * times.len()
                    )));
                }
                out.channels.push(Channel {
                    node: channel.target().node().index(),
                    target,
                    interpolation,
                    times,
                    values,
                });
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(target: Target, interpolation: Interpolation, times: &[f32], values: &[Vec4]) -> Channel {
        Channel {
            node: 0,
            target,
            interpolation,
            times: times.to_vec(),
            values: values.to_vec(),
        }
    }

    #[test]
    fn step_and_linear_follow_the_keys_and_hold_outside_them() {
        let v = [Vec4::new(0.0, 0.0, 0.0, 0.0), Vec4::new(2.0, 4.0, -2.0, 0.0)];
        let lin = channel(Target::Translation, Interpolation::Linear, &[1.0, 2.0], &v);
        assert_eq!(lin.sample(1.25), Vec4::new(0.5, 1.0, -0.5, 0.0));
        assert_eq!(lin.sample(0.0), v[0]);
        assert_eq!(lin.sample(3.0), v[1]);
        let step = channel(Target::Translation, Interpolation::Step, &[1.0, 2.0], &v);
        assert_eq!(step.sample(1.99), v[0]);
        assert_eq!(step.sample(2.0), v[1]);
    }

    #[test]
    fn linear_rotation_is_slerp_at_constant_angular_speed() {
        let a = Quat::IDENTITY;
        let b = Quat::from_rotation_y(1.2);
        let c = channel(
            Target::Rotation,
            Interpolation::Linear,
            &[0.0, 1.0],
            &[Vec4::from(a), Vec4::from(b)],
        );
        let q = Quat::from_vec4(c.sample(0.25));
        assert!(q.abs_diff_eq(Quat::from_rotation_y(0.3), 1e-6), "{q}");
    }

    #[test]
    fn cubic_spline_is_the_hermite_curve_with_tangents_scaled_by_the_key_interval() {
        // p(t) = t³ on [0, 2]: values 0 and 8, derivatives 0 and 12.
        let z = Vec4::ZERO;
        let values = [
            z,
            z,
            z, // key 0: in-tangent, value, out-tangent (p'(0) = 0)
            Vec4::new(12.0, 0.0, 0.0, 0.0),
            Vec4::new(8.0, 0.0, 0.0, 0.0),
            z, // key 1: in-tangent p'(2) = 12
        ];
        let c = channel(
            Target::Translation,
            Interpolation::CubicSpline,
            &[0.0, 2.0],
            &values,
        );
        for t in [0.0f32, 0.3, 1.0, 1.7, 2.0] {
            assert!((c.sample(t).x - t * t * t).abs() < 1e-5, "{t}: {}", c.sample(t).x);
        }
    }

    /// The example animation (`scripts/animated_gltf.py`) posed half-way, with a shutter of half a frame.
    #[test]
    fn the_example_animation_poses_nodes_and_camera_with_shutter_motion() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/animated/boxes.gltf");
        let mut camera = obscura_host::CameraDesc::new(obscura_sdk::Format::new(64, 48));
        camera.shutter = (0.0, 0.5);
        let scene = super::super::load_gltf_at(&path, camera, 0.5, 24.0).unwrap();
        assert_eq!(scene.animation_seconds, Some(1.0));
        let hero = &scene.objects[0];
        assert_eq!(hero.identity.instance, "hero");
        assert_eq!(hero.identity.object, "box");
        let [(t0, open), (t1, close)] = hero.transform.samples[..] else {
            panic!("{:?}", hero.transform.samples)
        };
        assert_eq!((t0, t1), (0.0, 0.5));
        let want = |s: f32| {
            Mat4::from_translation(Vec3::new(-1.5 + 3.0 * s, 0.0, 0.0))
                * Mat4::from_rotation_y(std::f32::consts::FRAC_PI_2 * s)
        };
        assert!(open.abs_diff_eq(want(0.5), 1e-5), "{open}");
        assert!(close.abs_diff_eq(want(0.5 + 0.5 / 24.0), 1e-5), "{close}");
        // STEP holds the second key from t = 0.5; CUBICSPLINE with zero tangents is 1 + 0.5·(3s² − 2s³).
        let side = scene.objects[1].transform.samples[0].1;
        let (scale, _, tr) = side.to_scale_rotation_translation();
        assert!(tr.abs_diff_eq(Vec3::new(0.0, 0.6, -1.0), 1e-6), "{tr}");
        assert!((scale.x - 1.25).abs() < 1e-6, "{scale}");
        // The camera moves too: world-to-camera maps its own position to the origin at both times.
        assert_eq!(scene.camera.world_to_camera.len(), 2);
        for (sample, s) in scene
            .camera
            .world_to_camera
            .iter()
            .zip([0.5f32, 0.5 + 0.5 / 24.0])
        {
            let m = Mat4::from_cols_array_2d(&sample.world_to_camera.0);
            let eye = Vec3::new(0.5 * s, 0.5, 6.0);
            assert!(m.transform_point3(eye).length() < 1e-5);
        }
        // The ground does not move: one sample.
        assert_eq!(scene.objects[2].transform.samples.len(), 1);
    }

    /// A sampler whose output holds fewer values than its input has key times is an error naming the
    /// file, the animation and the channel (the example's hero translation, cut to one value).
    #[test]
    fn a_channel_with_too_few_values_is_an_error_naming_it() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/animated/boxes.gltf");
        let text = std::fs::read_to_string(path).unwrap();
        // Accessor 6 is the hero's translation output (2 values): declare 1.
        let marker = "\"count\": 2,\n   \"type\": \"VEC3\"";
        let at = text.find(marker).unwrap();
        let cut = format!(
            "{}\"count\": 1,\n   \"type\": \"VEC3\"{}",
            &text[..at],
            &text[at + marker.len()..]
        );
        let dir = tempfile::tempdir().unwrap();
        let bad = dir.path().join("bad.gltf");
        std::fs::write(&bad, cut).unwrap();
        let e = super::super::load_gltf(
            &bad,
            obscura_host::CameraDesc::new(obscura_sdk::Format::new(8, 8)),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("bad.gltf")
                && e.contains("animation 0 channel 0: 1 output values for 2 key times; expected 2"),
            "{e}"
        );
    }
}
