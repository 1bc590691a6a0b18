//! `cargo bench -p obscura-dataset --bench annotations`: the cost of a frame's annotations against the
//! frame's render, through a pinhole and a 200° equidistant fisheye at 320×240 (four spheres and a
//! cube, 1000 tracks in all, 16 samples per pixel):
//!
//! - `render`: `Prepared::render` of the frame (the same-run reference);
//! - `boxes`: `frame_boxes` (visible boxes from the film, whole-object boxes through the camera, 3D boxes);
//! - `tracks`: `track_frame` of 1000 points (positions and occlusion).
//!
//! The target (issue 28): boxes + tracks ≤ 10 % of the render.

use std::path::Path;
use std::sync::OnceLock;
use std::sync::atomic::AtomicBool;

use divan::Bencher;
use glam::{Mat4, Vec3};
use obscura_dataset::annotate::boxes::frame_boxes;
use obscura_dataset::annotate::tracks::{TrackPoints, track_frame};
use obscura_host::CameraDesc;
use obscura_image::film::Film;
use obscura_plugins::builtin_registry;
use obscura_render::render::{Prepared, RenderOptions, prepare};
use obscura_scene::{Identity, Light, Mesh, MotionTransform, Object, Scene, Shape};
use obscura_sdk::{Format, Rgb};

const CAMERAS: [&str; 2] = ["pinhole", "fisheye"];

fn object(shape: Shape, at: Vec3, name: &str) -> Object {
    Object {
        shape,
        transform: MotionTransform::fixed(Mat4::from_translation(at)),
        material: 0,
        micropolygon_length: 1.0,
        source: name.into(),
        sides: Default::default(),
        visibility: Default::default(),
        identity: Identity {
            object: name.into(),
            instance: name.into(),
        },
    }
}

fn scene(camera: &str) -> Scene {
    let mut s = Scene::new(CameraDesc::new(Format::new(320, 240)));
    let params: &[(&str, &str)] = if camera == "pinhole" {
        s.projection = "PxrPerspective".into();
        &[("float fov", "60")]
    } else {
        s.projection = "Fisheye".into();
        &[("string mapping", "equidistant"), ("float fov", "200")]
    };
    for (decl, v) in params {
        s.projection_params.push_text(decl, &[v], None).unwrap();
    }
    let sphere = |r: f32| Shape::Sphere {
        radius: r,
        z_min: -r,
        z_max: r,
        theta_max: 360.0,
    };
    s.objects
        .push(object(sphere(1.0), Vec3::new(-0.8, 0.2, 5.0), "a"));
    s.objects
        .push(object(sphere(1.3), Vec3::new(1.2, -0.3, 7.0), "b"));
    s.objects
        .push(object(sphere(0.5), Vec3::new(-3.0, 0.0, 1.0), "c"));
    s.objects
        .push(object(sphere(0.8), Vec3::new(0.5, -1.5, 4.0), "d"));
    s.objects.push(object(
        Shape::Mesh(Mesh::cube(1.2)),
        Vec3::new(0.2, 1.3, 6.0),
        "box",
    ));
    s.lights.push(Light::Dome {
        color: Rgb::WHITE,
        intensity: 1.0,
        exposure: 0.0,
        map: None,
        transform: Mat4::IDENTITY,
    });
    s.samples_per_pixel = 16;
    s
}

struct Frame {
    scene: Scene,
    prepared: Prepared,
    film: Film,
    tracks: TrackPoints,
}

fn frame(camera: &str) -> &'static Frame {
    static FRAMES: [OnceLock<Frame>; 2] = [OnceLock::new(), OnceLock::new()];
    let i = CAMERAS.iter().position(|c| *c == camera).unwrap();
    FRAMES[i].get_or_init(|| {
        let scene = scene(camera);
        let prepared = prepare(
            &scene,
            &mut builtin_registry(),
            Path::new("."),
            &RenderOptions::default(),
        )
        .unwrap();
        let film = prepared
            .render(&RenderOptions::default(), &|_, _| {}, &AtomicBool::new(false))
            .film;
        let tracks = TrackPoints::sample(&prepared, 200, 1);
        assert_eq!(tracks.len(), 1000);
        Frame {
            scene,
            prepared,
            film,
            tracks,
        }
    })
}

#[divan::bench(args = CAMERAS, sample_count = 5)]
fn render(bencher: Bencher, camera: &str) {
    let f = frame(camera);
    bencher.bench(|| {
        f.prepared
            .render(&RenderOptions::default(), &|_, _| {}, &AtomicBool::new(false))
    });
}

#[divan::bench(args = CAMERAS, sample_count = 10)]
fn boxes(bencher: Bencher, camera: &str) {
    let f = frame(camera);
    bencher.bench(|| frame_boxes(&f.prepared, &f.scene, &f.film, 0.0).unwrap());
}

#[divan::bench(args = CAMERAS, sample_count = 10)]
fn tracks(bencher: Bencher, camera: &str) {
    let f = frame(camera);
    bencher.bench(|| track_frame(&f.prepared, &f.scene, &f.tracks, 0.0).unwrap());
}

fn main() {
    divan::main();
}
