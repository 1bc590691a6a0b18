//! `KHR_lights_punctual`: read from the raw JSON, then placed by their nodes as distant and sphere
//! lights.

use std::f32::consts::PI;

use glam::{Mat4, Quat, Vec3};
use gltf::json::Value;
use obscura_sdk::Rgb;

use super::Loader;
use crate::convert::flip_z;
use crate::types::Light;

/// `PxrDistantLight`'s default `angleExtent` (the sun's apparent diameter), degrees.
const SUN_ANGLE_EXTENT_DEG: f32 = 0.53;

/// A point or spot light becomes a sphere this fraction of the scene's bounding-box diagonal across.
const SPHERE_LIGHT_FRACTION: f32 = 0.01;

/// `KHR_lights_punctual`, read from the raw JSON.
pub(super) struct PunctualLights {
    /// The document's lights, in order (`Err` holds why one cannot be used).
    lights: Vec<Result<Punctual, String>>,
    /// For each node, the light it carries, if any.
    node_light: Vec<Option<u64>>,
}

/// The light types of `KHR_lights_punctual`.
#[derive(Debug, Clone, Copy, PartialEq)]
enum PunctualKind {
    Directional,
    Point,
    Spot,
}

/// One usable light of the extension.
#[derive(Debug, Clone, Copy)]
struct Punctual {
    kind: PunctualKind,
    color: Rgb,
    intensity: f32,
}

impl PunctualLights {
    /// The lights and which node carries which; `None` when the file names no punctual light or
    /// its JSON cannot be read again.
    pub(super) fn parse(json: &[u8]) -> Option<PunctualLights> {
        // Most files have no lights: skip the second JSON parse for them.
        if !json.windows(19).any(|w| w == b"KHR_lights_punctual") {
            return None;
        }
        let root: Value = gltf::json::deserialize::from_slice(json).ok()?;
        let lights = root
            .get("extensions")
            .and_then(|e| e.get("KHR_lights_punctual"))
            .and_then(|k| k.get("lights"))
            .and_then(Value::as_array)
            .map(|ls| ls.iter().map(Punctual::parse).collect())
            .unwrap_or_default();
        let node_light = root
            .get("nodes")
            .and_then(Value::as_array)
            .map(|nodes| {
                nodes
                    .iter()
                    .map(|n| {
                        n.get("extensions")
                            .and_then(|e| e.get("KHR_lights_punctual"))
                            .and_then(|k| k.get("light"))
                            .and_then(Value::as_u64)
                    })
                    .collect()
            })
            .unwrap_or_default();
        Some(PunctualLights { lights, node_light })
    }
}

impl Punctual {
    /// One light of the extension's `lights` array.
    fn parse(v: &Value) -> Result<Punctual, String> {
        let kind = match v.get("type").and_then(Value::as_str) {
            Some("directional") => PunctualKind::Directional,
            Some("point") => PunctualKind::Point,
            Some("spot") => PunctualKind::Spot,
            Some(other) => return Err(format!("unknown type \"{other}\"")),
            None => return Err("no type".into()),
        };
        let number = |x: &Value| {
            x.as_f64()
                .map(|f| f as f32)
                .filter(|f| f.is_finite() && *f >= 0.0)
        };
        let color = match v.get("color") {
            None => Rgb::WHITE,
            Some(c) => match c
                .as_array()
                .map(|a| a.iter().map(number).collect::<Option<Vec<f32>>>())
            {
                Some(Some(rgb)) if rgb.len() == 3 => Rgb::new(rgb[0], rgb[1], rgb[2]),
                _ => return Err("color is not three non-negative numbers".into()),
            },
        };
        let intensity = match v.get("intensity") {
            None => 1.0,
            Some(i) => number(i).ok_or("intensity is not a non-negative number")?,
        };
        Ok(Punctual {
            kind,
            color,
            intensity,
        })
    }
}

impl Loader<'_> {
    /// Maps the `KHR_lights_punctual` lights of placed nodes.
    pub(super) fn read_lights(
        &mut self,
        placed: &[(gltf::Node<'_>, Mat4)],
        punctual: Option<PunctualLights>,
        document: &gltf::Document,
    ) {
        let Some(punctual) = punctual else {
            if document.extensions_used().any(|e| e.starts_with("KHR_lights")) {
                self.warn("light extension present but no lights could be read; lights skipped".into());
            }
            return;
        };
        let diameter = self
            .bounds
            .map(|(lo, hi)| SPHERE_LIGHT_FRACTION * (hi - lo).length())
            .filter(|d| d.is_finite() && *d > 0.0)
            .unwrap_or(SPHERE_LIGHT_FRACTION);
        let mut spot_warned = false;
        for (node, world) in placed {
            let Some(index) = punctual.node_light.get(node.index()).copied().flatten() else {
                continue;
            };
            let light = usize::try_from(index).ok().and_then(|i| punctual.lights.get(i));
            let p = match light {
                Some(Ok(p)) => *p,
                Some(Err(why)) => {
                    self.warn(format!("node {}: light {index}: {why}; skipped", node.index()));
                    continue;
                }
                None => {
                    self.warn(format!(
                        "node {}: light {index} does not exist; skipped",
                        node.index()
                    ));
                    continue;
                }
            };
            let light = match p.kind {
                PunctualKind::Directional => Light::Distant {
                    color: p.color,
                    intensity: p.intensity,
                    exposure: 0.0,
                    angle_extent: SUN_ANGLE_EXTENT_DEG,
                    enable_shadows: true,
                    transform: *world * flip_z(),
                },
                PunctualKind::Point | PunctualKind::Spot => {
                    if p.kind == PunctualKind::Spot && !spot_warned {
                        spot_warned = true;
                        self.warn(format!(
                            "node {}: spot light cones are not supported; emitted as a sphere light in all directions",
                            node.index()
                        ));
                    }
                    let radius = 0.5 * diameter;
                    Light::Sphere {
                        color: p.color,
                        intensity: p.intensity / (PI * radius * radius),
                        exposure: 0.0,
                        transform: Mat4::from_scale_rotation_translation(
                            Vec3::splat(diameter),
                            Quat::IDENTITY,
                            world.transform_point3(Vec3::ZERO),
                        ),
                    }
                }
            };
            self.scene.lights.push(light);
        }
    }
}
