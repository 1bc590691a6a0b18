//! The built-in scene rendered with its static objects flattened into one world-space hierarchy
//! (the default layout) and with every object an instance (the former layout): the same object and
//! instance IDs in every pixel, and a beauty that differs only by the rounding of world- against
//! object-space triangle tests (bounds measured on this frame, stated in docs/decisions.md). Also
//! the rays the renderer counts by kind, and shadow rays through transparent scenes passing
//! shadowless surfaces.

mod common;

use std::path::Path;
use std::sync::atomic::AtomicBool;

use obscura_geometry::bvh::SceneLayout;
use obscura_plugins::builtin_registry;
use obscura_render::job::DEFAULT_SCENE;
use obscura_render::render::{RenderOptions, RenderOutput, prepare};
use obscura_scene::rib::parse_str;

const WIDTH: u32 = 160;
const HEIGHT: u32 = 90;

/// The built-in scene at 160×90, 4 samples per pixel, in `layout`; also how many of its objects
/// were flattened and how many stayed instances.
fn render(layout: SceneLayout) -> (RenderOutput, (usize, usize), usize) {
    let rib = DEFAULT_SCENE
        .replace("Format 640 360 1", &format!("Format {WIDTH} {HEIGHT} 1"))
        .replace("\"int maxsamples\" [32]", "\"int maxsamples\" [4]");
    assert_ne!(rib, DEFAULT_SCENE, "the built-in scene's format line moved");
    let scene = parse_str(&rib, "<built-in scene>", Path::new(".")).unwrap();
    let opts = RenderOptions {
        scene_layout: Some(layout),
        ..RenderOptions::default()
    };
    let prepared = prepare(&scene, &mut builtin_registry(), Path::new("."), &opts).unwrap();
    let counts = prepared.accel().instance_counts();
    let out = prepared.render(&opts, &|_, _| {}, &AtomicBool::new(false));
    (out, counts, scene.objects.len())
}

#[test]
fn flat_and_instanced_scenes_render_the_same_ids_and_nearly_the_same_beauty() {
    let (flat, flat_counts, objects) = render(SceneLayout::Flat);
    let (instanced, instanced_counts, _) = render(SceneLayout::Instanced);
    // Nothing in the built-in scene moves, is placed twice or is hidden from some rays.
    assert_eq!(flat_counts, (objects, 0));
    assert_eq!(instanced_counts, (0, objects));
    assert_eq!(flat.stats.triangles, instanced.stats.triangles);
    // Every camera sample meets the same surfaces' IDs.
    let (mut covered, mut worst, mut sum, mut n) = (0, 0.0f32, 0.0f64, 0usize);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let (f, i) = (flat.film.pixel(x, y), instanced.film.pixel(x, y));
            assert_eq!(
                (f.truth.object_id, f.truth.instance_id, f.truth.material_id),
                (i.truth.object_id, i.truth.instance_id, i.truth.material_id),
                "pixel ({x}, {y})"
            );
            assert_eq!(f.alpha, i.alpha, "pixel ({x}, {y})");
            covered += usize::from(f.truth.object_id != 0);
            for (a, b) in [(f.ci.r, i.ci.r), (f.ci.g, i.ci.g), (f.ci.b, i.ci.b)] {
                let d = (a - b).abs();
                worst = worst.max(d);
                sum += f64::from(d);
                n += 1;
            }
        }
    }
    assert!(
        covered > (WIDTH * HEIGHT) as usize / 2,
        "{covered} pixels on objects"
    );
    let mean = sum / n as f64;
    // The same random numbers drive both renders, so paths agree until a bounce grazes an edge or a
    // Russian-roulette test lands within rounding of its threshold.
    assert!(mean < 1e-6, "mean |ΔCi| {mean}");
    assert!(worst < 1e-2, "max |ΔCi| {worst}");
    println!(
        "{objects} objects flattened; flat vs instanced, {WIDTH}×{HEIGHT} at 4 spp: mean |ΔCi| {mean:.2e}, max {worst:.2e}"
    );
}

/// The mean beauty of the central 4×4 pixels of a 16×16 film.
fn centre(film: &obscura_image::film::Film) -> [f32; 3] {
    let mut sum = [0.0f32; 3];
    for y in 6..10 {
        for x in 6..10 {
            let p = film.pixel(x, y);
            for (s, v) in sum.iter_mut().zip([p.ci.r, p.ci.g, p.ci.b]) {
                *s += v / 16.0;
            }
        }
    }
    sum
}

/// A shadowless surface (`"int transmission" [0]`) between a light and a lit square lets the light
/// through also when the scene has a transparent surface (which sends shadow rays through the
/// nearest-hit query that passes surfaces, `intersect_shadow`): the renderer's ray-counting tracer
/// used to answer that query as a bounce ray's, which sees every surface.
#[test]
fn shadowless_surfaces_cast_no_shadow_in_scenes_with_transparent_surfaces() {
    let rib = |transparent: &str| {
        format!(
            "Format 16 16 1\nHider \"raytrace\" \"int maxsamples\" [16]\nProjection \"PxrPerspective\" \"float fov\" [30]\n\
             WorldBegin\nAttribute \"light\" \"shadows\" \"on\"\n\
             LightSource \"pointlight\" 1 \"from\" [0 0 0] \"intensity\" [25]\n\
             Surface \"matte\"\nPolygon \"P\" [-5 -5 5  5 -5 5  5 5 5  -5 5 5]\n\
             AttributeBegin\nAttribute \"visibility\" \"int camera\" [0] \"int transmission\" [0]\n\
             Color [0 0 1]\nSurface \"constant\"\nPolygon \"P\" [-2 -2 3  2 -2 3  2 2 3  -2 2 3]\nAttributeEnd\n\
             {transparent}WorldEnd\n"
        )
    };
    // Behind the camera, out of every ray's way: it only makes the scene one with transparency.
    let behind = "AttributeBegin\nOpacity [0.5 0.5 0.5]\nSurface \"constant\"\n\
                  Polygon \"P\" [-1 -1 -5  1 -1 -5  1 1 -5  -1 1 -5]\nAttributeEnd\n";
    for extra in ["", behind] {
        let c = centre(&common::render_rib(&rib(extra)));
        // Lit head-on: Kd·Cs·I/d² = 25/25 = 1 at the centre.
        assert!(c.iter().all(|v| (v - 1.0).abs() < 0.02), "{c:?} with {extra:?}");
    }
}

/// The renderer counts the rays it traces by kind: one camera ray per camera sample, and on a
/// scene lit by a shadowing light, shadow rays; the kinds add up to the total.
#[test]
fn rays_are_counted_by_kind() {
    let (out, _, _) = render(SceneLayout::Flat);
    let rays = out.stats.rays;
    assert_eq!(rays.total(), out.stats.rays_traced);
    assert_eq!(
        rays.camera,
        out.stats.contract.samples - out.stats.contract.culled
    );
    assert!(
        rays.bounce > rays.camera / 4 && rays.shadow > rays.camera,
        "{rays:?}"
    );
}
