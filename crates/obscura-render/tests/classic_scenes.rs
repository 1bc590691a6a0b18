//! Classic RenderMan scenes end to end: a `constant` surface shows its colour with no light, and a
//! `matte` surface under a classic `distantlight` has the shader's own brightness `Kd·Cs·I·cos θ`.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use obscura_plugins::builtin_registry;
use obscura_render::render::{RenderOptions, prepare};
use obscura_scene::rib::parse_str;

/// The mean beauty of the central 4×4 pixels of `rib` rendered at 16×16.
fn centre(rib: &str) -> [f64; 3] {
    let scene = parse_str(rib, "t.rib", Path::new(".")).expect("reads");
    let prepared = prepare(
        &scene,
        &mut builtin_registry(),
        Path::new("."),
        &RenderOptions::default(),
    )
    .expect("prepares");
    let out = prepared.render(&RenderOptions::default(), &|_, _| {}, &AtomicBool::new(false));
    let mut sum = [0.0f64; 3];
    for y in 6..10 {
        for x in 6..10 {
            let p = out.film.pixel(x, y);
            sum[0] += f64::from(p.ci.r) / 16.0;
            sum[1] += f64::from(p.ci.g) / 16.0;
            sum[2] += f64::from(p.ci.b) / 16.0;
        }
    }
    sum
}

const CAMERA: &str = "Format 16 16 1\nHider \"raytrace\" \"int maxsamples\" [16]\nProjection \"PxrPerspective\" \"float fov\" [30]\n";

#[test]
fn a_constant_surface_shows_its_colour_without_any_light() {
    let c = centre(&format!(
        "{CAMERA}WorldBegin\nColor [1 0.5 0.25]\nSurface \"constant\"\nTranslate 0 0 5\nSphere 2 -2 2 360\nWorldEnd\n"
    ));
    for (got, want) in c.iter().zip([1.0, 0.5, 0.25]) {
        assert!((got - want).abs() < 1e-3, "{c:?}");
    }
}

#[test]
fn a_matte_surface_under_a_distant_light_has_the_classic_brightness() {
    // A square facing the camera (normal −z) lit head-on, and at 60°: Kd·Cs·I·cos θ.
    for (to, cos) in [("0 0 1", 1.0), ("0 0.8660254 0.5", 0.5)] {
        let c = centre(&format!(
            "{CAMERA}WorldBegin\nLightSource \"distantlight\" 1 \"intensity\" [0.8] \"from\" [0 0 0] \"to\" [{to}]\nColor [1 0.5 1]\nSurface \"matte\" \"Kd\" [0.5]\nPolygon \"P\" [-5 -5 5  5 -5 5  5 5 5  -5 5 5]\nWorldEnd\n"
        ));
        let want = 0.5 * 0.8 * cos;
        assert!((c[0] - want).abs() < 0.01 * want, "cos {cos}: {c:?} vs {want}");
        assert!((c[1] - 0.5 * want).abs() < 0.01 * want, "{c:?}");
    }
}
