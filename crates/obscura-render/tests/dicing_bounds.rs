//! Dicing that cannot explode (issue 12, point 6): geometry behind, around or very near the camera,
//! huge radii and absurd micropolygon lengths dice to bounded triangle counts, and a scene over its
//! triangle budget stops with a message naming the primitive.
//!
//! Before the on-screen bound, the first three scenes diced into 8.4 million triangles each (about
//! 1.3 GB) and the twelve spheres into 100 million; the bounds asserted here keep each of these 32×24
//! renders well under 300 MB.

use std::path::Path;

use obscura_plugins::builtin_registry;
use obscura_render::render::{RenderOptions, prepare};
use obscura_scene::rib::parse_str;

/// The triangles `rib` dices into, through the built-in perspective camera at 32×24.
fn triangles(world: &str) -> usize {
    triangles_with(world, &RenderOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn triangles_with(world: &str, opts: &RenderOptions) -> Result<usize, String> {
    let text = format!(
        "Format 32 24 1\nProjection \"perspective\" \"fov\" [60]\nWorldBegin\nLight \"PxrDomeLight\" \"d\"\n{world}\nWorldEnd\n"
    );
    let scene = parse_str(&text, "t.rib", Path::new(".")).unwrap();
    let prepared =
        prepare(&scene, &mut builtin_registry(), Path::new("."), opts).map_err(|e| e.to_string())?;
    Ok(prepared.accel().triangle_count())
}

#[test]
fn a_small_sphere_just_behind_the_camera_is_diced_coarsely() {
    let n = triangles("Translate 0 0 -0.3\nSphere 0.2 -0.2 0.2 360");
    // 16 micropolygons for each of 64 pixels: 1024 quads, plus the segments' rounding up.
    assert!(n <= 2 * 1024 * 11 / 10 + 100, "{n} triangles");
}

#[test]
fn a_sky_sphere_around_the_camera_is_diced_for_the_pixels_it_covers() {
    let n = triangles("Sphere 10 -10 10 360");
    // 32×24 = 768 pixels, 16 micropolygons each at most: 12,288 quads (24,492 triangles) on the
    // uniform grid. Fitted cell by cell, the part out of view is coarse: 11,776 triangles.
    assert!(n <= 16 * 768, "{n} triangles");
    assert!(n >= 500, "still a sphere: {n} triangles");
}

#[test]
fn a_sphere_of_radius_3e38_dices_to_a_bounded_finite_mesh() {
    let n = triangles("Sphere 3e38 -3e38 3e38 360");
    assert!(n <= 16 * 768, "{n} triangles");
}

#[test]
fn twelve_spheres_at_micropolygonlength_1e_minus_30_stay_bounded() {
    let mut world = String::from("Attribute \"dice\" \"float micropolygonlength\" [1e-30]\n");
    for i in 0..12 {
        world += &format!(
            "AttributeBegin\nTranslate {} {} 6\nSphere 0.5 -0.5 0.5 360\nAttributeEnd\n",
            (i % 4) as f32 - 1.5,
            (i / 4) as f32 - 1.0
        );
    }
    let n = triangles(&world);
    // Each sphere covers about 8×8 pixels; at 1/16-pixel micropolygons and the coverage factor the
    // twelve hold a few hundred thousand triangles, not 100 million.
    assert!(n <= 600_000, "{n} triangles");
}

#[test]
fn a_sphere_in_view_keeps_its_nearest_point_rate() {
    // A unit sphere 4 units away at 32×24 (fov 60) is about 14 pixels across: the on-screen bound
    // must not coarsen it (the nearest-point rate gives a few hundred triangles).
    let bounded = triangles("Translate 0 0 4\nSphere 1 -1 1 360");
    assert!((200..=2_000).contains(&bounded), "{bounded} triangles");
}

#[test]
fn a_scene_over_its_triangle_budget_names_the_primitive() {
    let opts = RenderOptions {
        max_triangles: 1_000,
        ..RenderOptions::default()
    };
    let e = triangles_with(
        "Translate 0 0 3\nSphere 1 -1 1 360\nSphere 1.5 -1.5 1.5 360",
        &opts,
    )
    .unwrap_err();
    assert!(e.starts_with("t.rib:"), "{e}");
    assert!(
        e.contains("which the scene cannot hold") && e.contains("the budget is 1000"),
        "{e}"
    );
}

#[test]
fn a_subdivision_surface_around_the_camera_fits_its_quad_budget() {
    // A cube of side 20 around the camera: the whole 32×24 image, so at most 16·768 quads.
    let n = triangles(
        "SubdivisionMesh \"catmull-clark\" [4 4 4 4 4 4] [0 1 3 2 2 3 5 4 4 5 7 6 6 7 1 0 1 7 5 3 6 0 2 4] \
         [\"interpolateboundary\"] [0 0] [] [] \
         \"P\" [-10 -10 10 10 -10 10 -10 10 10 10 10 10 -10 10 -10 10 10 -10 -10 -10 -10 10 -10 -10]",
    );
    assert!(n <= 2 * 16 * 768, "{n} triangles");
    assert!(n >= 1000, "{n} triangles");
}
