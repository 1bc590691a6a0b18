//! End to end: a uniform white dome rendered through `LensSystem` shows the lens's relative
//! illumination — the image falls off toward the corners exactly as the real-ray integral of the
//! projection says, with no rings, and the centre stays at the dome's radiance.

mod common;

use std::path::Path;
use std::sync::atomic::AtomicBool;

use common::white_dome;
use obscura_host::CameraDesc;
use obscura_plugins::builtin_registry;
use obscura_projections::lens_system::prescription::Prescription;
use obscura_projections::lens_system::{LensSystem, Settings};
use obscura_render::render::{RenderOptions, prepare};
use obscura_scene::Scene;
use obscura_sdk::{Format, ProjectionEnvironment, ScreenWindow};

#[test]
fn a_white_dome_through_the_double_gauss_shows_its_relative_illumination() {
    let format = Format::new(48, 32);
    let mut cam = CameraDesc::new(format);
    cam.shutter = (0.0, 0.0);
    let mut scene = Scene::new(cam);
    scene.projection = "LensSystem".into();
    scene
        .projection_params
        .push_text("int dispersion", &["0"], None)
        .unwrap();
    scene.samples_per_pixel = 256;
    scene.lights.push(white_dome());
    let opts = RenderOptions::default();
    let out = prepare(&scene, &mut builtin_registry(), Path::new("."), &opts)
        .expect("prepares")
        .render(&opts, &|_, _| {}, &AtomicBool::new(false));

    // The projection's own deterministic integral at each pixel centre's film radius.
    let env = ProjectionEnvironment::for_format(format);
    let settings = Settings {
        dispersion: false,
        ..Settings::default()
    };
    let lens = LensSystem::new(&Prescription::load("dgauss.50mm").unwrap(), settings, &env).unwrap();
    let window = ScreenWindow::default_for(format);
    // Rings of pixels by film radius: the rendered mean against the integral's mean.
    let bins = 6;
    let r_max = 17.6;
    let mut rendered = vec![(0.0f64, 0usize); bins];
    let mut expected = vec![0.0f64; bins];
    for y in 0..format.height {
        for x in 0..format.width {
            let s = window.raster_to_screen(format, f64::from(x) + 0.5, f64::from(y) + 0.5);
            let r = f64::from(s.x).hypot(f64::from(s.y)) * lens.mm_per_screen_unit();
            let b = ((r / r_max) * bins as f64) as usize;
            let p = out.film.pixel(x, y);
            rendered[b].0 += f64::from(p.ci.g);
            rendered[b].1 += 1;
            expected[b] += lens.relative_illumination(r, 48);
        }
    }
    let mut previous = f64::INFINITY;
    for b in 0..bins {
        let (sum, n) = rendered[b];
        let (got, want) = (sum / n as f64, expected[b] / n as f64);
        assert!(
            (got - want).abs() < 0.03,
            "ring {b}: rendered {got}, integral {want}"
        );
        // Falls off monotonically: no bright or dark rings.
        assert!(got < previous + 0.02, "ring {b}: {got} after {previous}");
        previous = got;
    }
    // The corner is well below the centre: the double Gauss vignettes wide open.
    assert!(previous < 0.6, "{previous}");
}
