//! The RI camera requests of a RIB scene, traced through the host: the rays equal the closed forms
//! of RISpec 3.2 and conventions.md.

use std::path::Path;

use obscura_host::CameraStage;
use obscura_image::raymap::trace_ray_map;
use obscura_plugins::builtin_registry;
use obscura_scene::rib::parse_str;

/// The camera of the RIB text `rib` (read as `name`), through the built-in plugins.
fn camera_stage(rib: &str, name: &str) -> CameraStage {
    let scene = parse_str(rib, name, Path::new(".")).unwrap();
    CameraStage::new(
        &mut builtin_registry(),
        &scene.projection,
        &scene.projection_params,
        &scene.camera,
    )
    .unwrap()
}

/// `DepthOfField fstop focallength focaldistance` is the thin lens: every sampled ray leaves the lens
/// disc of radius `focallength/(2·fstop)` at z = 0 and passes through the point where the pinhole
/// ray of its screen position meets z = focaldistance.
#[test]
fn a_depth_of_field_scene_traces_the_thin_lens() {
    let (f_stop, focal_length, focal_distance) = (2.0f32, 0.5f32, 4.0f32);
    let text = format!(
        "Format 12 9 1\nProjection \"perspective\" \"fov\" [50]\nDepthOfField {f_stop} {focal_length} {focal_distance}\nWorldBegin\nWorldEnd\n"
    );
    let stage = camera_stage(&text, "dof.rib");
    let (map, _) = trace_ray_map(&stage, 8, 3).unwrap();
    let lens_radius = focal_length / (2.0 * f_stop);
    let t = 25f32.to_radians().tan();
    let mut widest = 0.0f32;
    for layer in &map.layers[1..] {
        for (ray, s) in layer.rays.iter().zip(&layer.screen) {
            let (o, d) = (ray.origin, ray.direction);
            assert!(o.z.abs() < 1e-6, "the lens is at z = 0: {o:?}");
            let r = o.x.hypot(o.y);
            assert!(
                r <= lens_radius * (1.0 + 1e-5),
                "{r} outside the lens radius {lens_radius}"
            );
            widest = widest.max(r);
            // The pinhole ray of screen (sx, sy) is (sx·t, sy·t, 1): at z = fd it is fd·(sx·t, sy·t).
            let focus = (focal_distance * s.x * t, focal_distance * s.y * t);
            let k = focal_distance / d.z;
            let hit = (o.x + k * d.x, o.y + k * d.y);
            assert!(
                (hit.0 - focus.0).abs() < 1e-4 && (hit.1 - focus.1).abs() < 1e-4,
                "through {hit:?}, the thin lens focuses at {focus:?}"
            );
        }
    }
    assert!(
        widest > 0.7 * lens_radius,
        "the lens is sampled: widest {widest} of {lens_radius}"
    );
}

/// RISpec 3.2: without ScreenWindow the window follows FrameAspectRatio (here 2, so (−2, 2, −1, 1)),
/// and `fov` spans the screen's [−1, 1]: the chief ray of the frame's top-right corner has direction
/// (2·tan(fov/2), tan(fov/2), 1). On the 4:3 raster the frame is its top 40 × 20 pixels: only those
/// are traced, and the window spans them.
#[test]
fn frame_aspect_ratio_sets_the_screen_window_the_rays_follow() {
    let text =
        "Format 40 30 1\nFrameAspectRatio 2\nProjection \"perspective\" \"fov\" [60]\nWorldBegin\nWorldEnd\n";
    let stage = camera_stage(text, "fa.rib");
    let (map, _) = trace_ray_map(&stage, 0, 0).unwrap();
    let chief = &map.layers[0];
    let t = 30f32.to_radians().tan();
    assert_eq!(chief.rays.len(), 40 * 20, "the frame's pixels only");
    // Pixel (x, y)'s centre: screen x = −2 + 4·(x + ½)/40, y = 1 − 2·(y + ½)/20.
    for (x, y) in [(39usize, 0usize), (0, 19), (20, 10)] {
        let (sx, sy) = (
            -2.0 + 4.0 * (x as f32 + 0.5) / 40.0,
            1.0 - 2.0 * (y as f32 + 0.5) / 20.0,
        );
        let d = chief.rays[y * 40 + x].direction;
        assert!(
            (d.x / d.z - sx * t).abs() < 1e-5 && (d.y / d.z - sy * t).abs() < 1e-5,
            "pixel ({x}, {y}): {d:?}"
        );
    }
}
