//! Scenes and renders several of the renderer's integration tests share.

// Every test binary compiles this module and uses only some of it.
#![allow(dead_code)]

use std::path::Path;
use std::sync::atomic::AtomicBool;

use glam::Mat4;
use obscura_image::film::Film;
use obscura_plugins::builtin_registry;
use obscura_render::render::{RenderOptions, prepare};
use obscura_scene::rib::parse_str;
use obscura_scene::{Identity, Light, MotionTransform, Object, Shape};
use obscura_sdk::Rgb;

/// A uniform white dome of radiance 1.
pub fn white_dome() -> Light {
    Light::Dome {
        color: Rgb::WHITE,
        intensity: 1.0,
        exposure: 0.0,
        map: None,
        transform: Mat4::IDENTITY,
    }
}

/// `shape` under `transform` with material `material`, diced at micropolygon length 1, seen from
/// both sides by every ray, with no name.
pub fn test_object(shape: Shape, transform: MotionTransform, material: u32) -> Object {
    Object {
        shape,
        transform,
        material,
        micropolygon_length: 1.0,
        source: "test".into(),
        sides: Default::default(),
        visibility: Default::default(),
        identity: Identity::default(),
    }
}

/// The film of the RIB text `rib` rendered with the default options through the built-in plugins.
pub fn render_rib(rib: &str) -> Film {
    let scene = parse_str(rib, "t.rib", Path::new(".")).expect("reads");
    let prepared = prepare(
        &scene,
        &mut builtin_registry(),
        Path::new("."),
        &RenderOptions::default(),
    )
    .expect("prepares");
    prepared
        .render(&RenderOptions::default(), &|_, _| {}, &AtomicBool::new(false))
        .film
}

/// The whole sphere of radius `radius` about the origin.
pub fn full_sphere(radius: f32) -> Shape {
    Shape::Sphere {
        radius,
        z_min: -radius,
        z_max: radius,
        theta_max: 360.0,
    }
}
