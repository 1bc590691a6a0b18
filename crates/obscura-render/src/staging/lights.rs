//! The default lights of a scene whose file has none: a soft sky, a key light, and a lamp under the
//! ceiling of a closed interior.

use std::borrow::Cow;

use glam::{Mat4, Vec3, Vec4};
use obscura_scene::{Light, Scene};
use obscura_sdk::Rgb;

use super::interior::Interior;
use super::{DEFAULT_KEY_DIRECTION, DEFAULT_SKY};

/// Radiance of the lamp a closed interior gets: a sphere of radius `r` = 4 % of the room's
/// narrower side gives irradiance `π·L·(r/d)²`, so `L = 156` gives π (a white wall's radiance 1)
/// at half that side's width, `d = 12.5 r`.
const ROOM_LAMP_RADIANCE: f32 = 156.25;

/// The lights `scene` renders with: its own, after the [`default_lights`] when the file has none
/// ([`Scene::auto_light`]); `interior` is the [`probe`](super::probe) of its bounds.
#[must_use]
pub fn lights<'a>(scene: &'a Scene, interior: Option<&Interior>) -> Cow<'a, [Light]> {
    if !scene.auto_light {
        return Cow::Borrowed(&scene.lights);
    }
    let mut all = default_lights(scene, interior);
    all.extend(scene.lights.iter().cloned());
    Cow::Owned(all)
}

/// The default lights of a scene without any: a soft sky (a uniform dome of [`DEFAULT_SKY`]) and a
/// distant key light along [`DEFAULT_KEY_DIRECTION`] (intensity 2.2, 5° wide), so surfaces show their
/// shape and the backdrop is not the asset's white. Inside an interior the key travels along
/// [`Interior::key`] when one gets through, and a closed one (nothing open above) also gets a lamp
/// under its ceiling, over the centre eye, at 80 % of the height of the bounds
/// ([`Scene::auto_camera`]). In a scene of classic RenderMan shaders ([`Scene::local_shading`] not
/// empty) the key light casts no shadows, as the classic lights it stands in for do: a scene closed
/// by a star-field sphere is still lit.
#[must_use]
pub fn default_lights(scene: &Scene, interior: Option<&Interior>) -> Vec<Light> {
    let mut lights = vec![Light::Dome {
        color: DEFAULT_SKY,
        intensity: 1.0,
        exposure: 0.0,
        map: None,
        transform: Mat4::IDENTITY,
    }];
    let z = interior
        .and_then(|i| i.key)
        .unwrap_or(DEFAULT_KEY_DIRECTION)
        .normalize();
    let x = z.any_orthonormal_vector();
    let y = z.cross(x);
    lights.push(Light::Distant {
        color: Rgb::WHITE,
        intensity: 2.2,
        exposure: 0.0,
        angle_extent: 5.0,
        enable_shadows: scene.local_shading.is_empty(),
        transform: Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), Vec4::W),
    });
    // A closed interior lets neither in: a lamp under its ceiling shows the room.
    if let (Some(i), Some((min, max))) = (interior, scene.auto_camera)
        && i.open_above == 0.0
    {
        let ext = max - min;
        let radius = (0.04 * ext.x.min(ext.z)).max(1e-3);
        let at = Vec3::new(i.centre_eye.x, min.y + 0.8 * ext.y, i.centre_eye.z);
        lights.push(Light::Sphere {
            color: Rgb::WHITE,
            intensity: ROOM_LAMP_RADIANCE,
            exposure: 0.0,
            transform: Mat4::from_translation(at) * Mat4::from_scale(Vec3::splat(2.0 * radius)),
        });
    }
    lights
}

/// The render's info line about the default lights.
#[must_use]
pub fn default_light_note() -> String {
    format!(
        "no light in the scene: a soft sky (dome of colour {:.2} {:.2} {:.2}) and a distant key light from above, front left",
        DEFAULT_SKY.r, DEFAULT_SKY.g, DEFAULT_SKY.b
    )
}
