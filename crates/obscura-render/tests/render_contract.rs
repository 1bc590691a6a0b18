//! The renderer honours the projection contract: tint before the filter and on the beauty only, culled
//! samples contribute nothing, z in the projection's deep metric, crops, motion over the shutter, and
//! the dicing hint.

mod common;

use std::path::Path;
use std::sync::atomic::AtomicBool;

use common::{full_sphere, test_object, white_dome};
use glam::{Mat4, Vec3};
use obscura_host::{CameraDesc, Registry};
use obscura_plugins::builtin_registry;
use obscura_render::render::{Prepared, RenderOptions, prepare};
use obscura_scene::{Material, Mesh, MotionTransform, Scene, Shape};
use obscura_sdk::{
    DeepMetric, DicingHint, Format, ParamDecl, ParamList, PluginError, Projection, ProjectionContext,
    ProjectionEnvironment, ProjectionFactory, ProjectionProperty, PropertyValue, Rgb, Vec3 as SdkVec3,
};

/// Wraps PxrPerspective (fov 60) and changes one thing, to test the host's side of the contract.
#[derive(Clone, Copy)]
enum Twist {
    /// Tint the samples whose lens.x < ½ to black.
    TintHalf,
    /// Cull every sample left of the screen's centre line.
    CullLeft,
    /// Report DeepMetric RayLength.
    RayLength,
    /// Report DicingHint Orthographic while projecting perspective rays.
    WrongHint,
}

struct Twisted {
    inner: Box<dyn Projection>,
    twist: Twist,
}

impl Projection for Twisted {
    fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
        match (self.twist, p) {
            (Twist::RayLength, ProjectionProperty::DeepMetric) => {
                Some(PropertyValue::DeepMetric(DeepMetric::RayLength))
            }
            (Twist::WrongHint, ProjectionProperty::DicingHint) => {
                Some(PropertyValue::DicingHint(DicingHint::Orthographic))
            }
            _ => self.inner.property(p),
        }
    }
    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        self.inner.project(ctx);
        let c = ctx.parts_mut();
        for i in 0..c.rays.len() {
            match self.twist {
                Twist::TintHalf if c.lens[i].x < 0.5 => c.tint[i] = Rgb::BLACK,
                Twist::CullLeft if c.screen[i].x < 0.0 => c.rays[i].direction = SdkVec3::ZERO,
                _ => {}
            }
        }
    }
}

struct TwistFactory(&'static str, Twist);

impl ProjectionFactory for TwistFactory {
    fn name(&self) -> &str {
        self.0
    }
    fn summary(&self) -> &str {
        "test projection"
    }
    fn param_table(&self) -> &[ParamDecl] {
        &[]
    }
    fn create_projection(
        &self,
        env: &mut ProjectionEnvironment,
        _: &ParamList,
    ) -> Result<Box<dyn Projection>, PluginError> {
        let mut params = ParamList::new();
        params.push_text("float fov", &["60"], None).expect("valid");
        let inner = obscura_projections::PerspectiveFactory.create_projection(env, &params)?;
        Ok(Box::new(Twisted { inner, twist: self.1 }))
    }
}

fn registry() -> Registry {
    let mut r = builtin_registry();
    for (name, t) in [
        ("TintHalf", Twist::TintHalf),
        ("CullLeft", Twist::CullLeft),
        ("RayLength", Twist::RayLength),
        ("WrongHint", Twist::WrongHint),
    ] {
        r.register(Box::new(TwistFactory(name, t)), "").expect("unique");
    }
    r
}

/// A wall of constant emission filling the view at camera z = 5, and a dome.
fn wall_scene(projection: &str, format: Format) -> Scene {
    let mut cam = CameraDesc::new(format);
    cam.shutter = (0.0, 1.0);
    let mut scene = Scene::new(cam);
    scene.projection = projection.to_string();
    if projection == "PxrPerspective" {
        scene
            .projection_params
            .push_text("float fov", &["60"], None)
            .expect("valid");
    }
    scene.materials.push(Material::Constant {
        color: Rgb::new(0.8, 0.6, 0.4),
    });
    scene.objects.push(test_object(
        Shape::Mesh(Mesh {
            positions: vec![
                Vec3::new(-50.0, -50.0, 5.0),
                Vec3::new(50.0, -50.0, 5.0),
                Vec3::new(50.0, 50.0, 5.0),
                Vec3::new(-50.0, 50.0, 5.0),
            ],
            normals: None,
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            ..Mesh::default()
        }),
        MotionTransform::fixed(Mat4::IDENTITY),
        1,
    ));
    scene.samples_per_pixel = 16;
    scene
}

fn prepared(scene: &Scene) -> Prepared {
    prepare(scene, &mut registry(), Path::new("."), &RenderOptions::default()).expect("prepares")
}

fn render(scene: &Scene) -> obscura_render::render::RenderOutput {
    prepared(scene).render(&RenderOptions::default(), &|_, _| {}, &AtomicBool::new(false))
}

#[test]
fn tint_halves_the_beauty_before_the_filter_and_nothing_else() {
    let format = Format::new(24, 16);
    let plain = render(&wall_scene("PxrPerspective", format));
    let tinted = render(&wall_scene("TintHalf", format));
    // Which samples of a pixel are tinted is independent of where they land, so a single pixel's
    // filtered ratio scatters around one half; over the image it is one half.
    let (mut sum_plain, mut sum_tinted) = (0.0f64, 0.0f64);
    for y in 0..16 {
        for x in 0..24 {
            let (a, b) = (plain.film.pixel(x, y), tinted.film.pixel(x, y));
            sum_plain += a.ci.r as f64;
            sum_tinted += b.ci.r as f64;
            assert!(b.ci.r < a.ci.r, "({x}, {y}): tinting can only darken");
            // The tint touches the beauty only.
            assert_eq!(b.alpha, a.alpha);
            assert_eq!(b.z, a.z);
            assert_eq!(b.n, a.n);
            assert_eq!(b.p, a.p);
        }
    }
    let ratio = sum_tinted / sum_plain;
    assert!((ratio - 0.5).abs() < 0.03, "image-wide Ci ratio {ratio}");
}

#[test]
fn culled_samples_leave_black_and_alpha_zero() {
    let out = render(&wall_scene("CullLeft", Format::new(24, 16)));
    assert!(out.stats.contract.culled > 0);
    for y in 0..16 {
        for x in 0..10 {
            let p = out.film.pixel(x, y);
            assert_eq!(
                (p.ci.r, p.ci.g, p.ci.b, p.alpha),
                (0.0, 0.0, 0.0, 0.0),
                "({x}, {y})"
            );
        }
        let p = out.film.pixel(20, y);
        assert!(p.alpha > 0.99 && p.ci.r > 0.7);
    }
}

#[test]
fn z_follows_the_deep_metric() {
    let format = Format::new(24, 16);
    let cz = render(&wall_scene("PxrPerspective", format));
    let rl = render(&wall_scene("RayLength", format));
    let cam = CameraDesc::new(format);
    let d = 1.0 / (30.0f32.to_radians()).tan();
    for (x, y) in [(12, 8), (0, 0), (23, 15), (5, 11)] {
        assert!(
            (cz.film.pixel(x, y).z - 5.0).abs() < 1e-3,
            "camera z at ({x}, {y})"
        );
        // Ray length: 5 / cos(angle off axis) for the pixel's own rays (the nearest-to-centre sample).
        let s = cam.raster_to_screen(x as f64 + 0.5, y as f64 + 0.5);
        let len = 5.0 * (s.x * s.x + s.y * s.y + d * d).sqrt() / d;
        assert!(
            (rl.film.pixel(x, y).z - len).abs() < 0.05 * len,
            "ray length at ({x}, {y}): {} vs {len}",
            rl.film.pixel(x, y).z
        );
    }
}

#[test]
fn a_crop_equals_the_same_region_of_the_full_render() {
    let mut scene = wall_scene("PxrPerspective", Format::new(40, 30));
    scene.lights.push(white_dome());
    scene.objects.push(test_object(
        full_sphere(1.0),
        MotionTransform::fixed(Mat4::from_translation(Vec3::new(0.3, 0.0, 3.0))),
        0,
    ));
    let full = render(&scene);
    scene.camera.crop_window = obscura_host::CropWindow {
        x_min: 0.3,
        x_max: 0.8,
        y_min: 0.2,
        y_max: 0.7,
    };
    let crop = render(&scene);
    let r = crop.film.crop();
    assert_eq!((r.x0, r.x1, r.y0, r.y1), (12, 32, 6, 21));
    for y in r.y0..r.y1 {
        for x in r.x0..r.x1 {
            let (a, b) = (full.film.pixel(x, y), crop.film.pixel(x, y));
            assert!(
                (a.ci.r - b.ci.r).abs() < 1e-4 && (a.alpha - b.alpha).abs() < 1e-5,
                "({x}, {y}): {a:?} vs {b:?}"
            );
        }
    }
}

#[test]
fn a_moving_sphere_is_centred_on_its_mid_shutter_position() {
    let mut cam = CameraDesc::new(Format::new(64, 32));
    cam.shutter = (0.0, 1.0);
    let mut scene = Scene::new(cam);
    scene
        .projection_params
        .push_text("float fov", &["60"], None)
        .expect("valid");
    scene.samples_per_pixel = 64;
    scene.materials.push(Material::Constant { color: Rgb::WHITE });
    scene.objects.push(test_object(
        full_sphere(0.5),
        MotionTransform {
            samples: vec![
                (0.0, Mat4::from_translation(Vec3::new(-1.0, 0.0, 5.0))),
                (1.0, Mat4::from_translation(Vec3::new(2.0, 0.0, 5.0))),
            ],
        },
        1,
    ));
    let out = render(&scene);
    let (mut sum, mut wx) = (0.0f64, 0.0f64);
    let mut covered_columns = 0;
    for x in 0..64 {
        let mut col = 0.0f64;
        for y in 0..32 {
            col += out.film.pixel(x, y).alpha as f64;
        }
        sum += col;
        wx += col * (x as f64 + 0.5);
        covered_columns += (col > 0.01) as u32;
    }
    let centroid_raster = wx / sum;
    // World x = 0.5 at z = 5 projects to screen 0.5·d/5, raster (s + a)/(2a)·64 with a = 2.
    let d = 1.0 / (30.0f64.to_radians()).tan();
    let expected = (0.5 * d / 5.0 + 2.0) / 4.0 * 64.0;
    assert!(
        (centroid_raster - expected).abs() < 0.6,
        "centroid {centroid_raster} vs {expected}"
    );
    // The streak is much wider than the sphere itself (5.5 pixels across; the streak about 22).
    assert!(covered_columns > 18, "{covered_columns}");
}

#[test]
fn a_wrong_dicing_hint_changes_the_dicing() {
    let mut scene = wall_scene("PxrPerspective", Format::new(320, 240));
    scene.objects.push(test_object(
        full_sphere(1.0),
        MotionTransform::fixed(Mat4::from_translation(Vec3::new(0.0, 0.0, 30.0))),
        0,
    ));
    let right = prepared(&scene).accel().triangle_count();
    scene.projection = "WrongHint".into();
    scene.projection_params = ParamList::new();
    let wrong = prepared(&scene).accel().triangle_count();
    assert!(
        right > 2 * wrong || wrong > 2 * right,
        "perspective {right} vs orthographic hint {wrong}"
    );
}

#[test]
fn white_furnace_gives_a_uniform_image() {
    let mut cam = CameraDesc::new(Format::new(16, 16));
    cam.shutter = (0.0, 0.0);
    let mut scene = Scene::new(cam);
    scene.samples_per_pixel = 64;
    scene.materials.push(Material::Diffuse { color: Rgb::WHITE });
    scene.lights.push(white_dome());
    scene.objects.push(test_object(
        full_sphere(1.0),
        MotionTransform::fixed(Mat4::from_translation(Vec3::new(0.0, 0.0, 3.0))),
        1,
    ));
    let mut opts = RenderOptions::default();
    opts.path.max_depth = 64;
    opts.path.rr_start = 64;
    let out = prepare(&scene, &mut registry(), Path::new("."), &opts)
        .expect("prepares")
        .render(&opts, &|_, _| {}, &AtomicBool::new(false));
    for y in 0..16 {
        for x in 0..16 {
            let p = out.film.pixel(x, y);
            assert!((p.ci.r - 1.0).abs() < 0.05, "({x}, {y}): {}", p.ci.r);
        }
    }
}
