//! The options: format, windows, shutter, clipping, filter, hider, displays, projection and camera.

use std::path::{Path, PathBuf};

use obscura_host::CropWindow;
use obscura_sdk::{Format, ParamType, ParamValue, ScreenWindow};

use super::*;
use crate::aov::Aov;
use crate::rib::options::FILTERS;
use crate::types::{Display, DisplayDriver, FilterKind, PixelFilter};

#[test]
fn default_scene_is_640_by_480() {
    let scene = ok("");
    assert_eq!(scene.camera.format, Format::new(640, 480));
    assert_eq!(scene.projection, "PxrPerspective");
    assert!(scene.warnings.is_empty());
}

#[test]
fn format_sets_size_and_pixel_aspect_and_a_later_one_wins() {
    let scene = ok("Format 10 10 1\nFormat 1920 1080 1.5\n");
    assert_eq!(
        scene.camera.format,
        Format {
            width: 1920,
            height: 1080,
            pixel_aspect: 1.5
        }
    );
}

#[test]
fn format_with_wrong_arg_count_names_request_and_line() {
    assert_eq!(
        fail("\nFormat 64 64"),
        "t.rib:2: Format expects width height pixelaspect (3 numbers), got 2"
    );
    assert_eq!(
        fail("Format 64.5 64 1"),
        "t.rib:1: Format expects a positive integer width and height (or ≤ 0 for the current one), got 64.5 64"
    );
}

#[test]
fn format_after_world_begin_is_an_error() {
    assert_eq!(
        fail("WorldBegin\nFormat 64 64 1\n"),
        "t.rib:2: Format must come before WorldBegin"
    );
    assert_eq!(
        fail("WorldBegin\n\nProjection \"PxrPerspective\"\n"),
        "t.rib:3: Projection must come before WorldBegin"
    );
    assert_eq!(
        fail("Sphere 1 -1 1 360"),
        "t.rib:1: Sphere must come after WorldBegin"
    );
}

#[test]
fn screen_window_is_stored() {
    let scene = ok("ScreenWindow -2 2 -1 1");
    assert_eq!(
        scene.camera.screen_window,
        Some(ScreenWindow::new(-2.0, 2.0, -1.0, 1.0))
    );
    assert_eq!(
        fail("ScreenWindow 1 -1 -1 1"),
        "t.rib:1: ScreenWindow expects left < right and bottom < top, got 1 -1 -1 1"
    );
}

#[test]
fn crop_window_is_stored() {
    let scene = ok("CropWindow 0.25 0.75 0 0.5");
    assert_eq!(
        scene.camera.crop_window,
        CropWindow {
            x_min: 0.25,
            x_max: 0.75,
            y_min: 0.0,
            y_max: 0.5
        }
    );
    assert!(fail("CropWindow 0 1.5 0 1").starts_with("t.rib:1: CropWindow expects 0 <= xmin"));
}

#[test]
fn shutter_is_stored() {
    assert_eq!(ok("Shutter 0 0.5").camera.shutter, (0.0, 0.5));
    assert_eq!(
        fail("Shutter 1 0"),
        "t.rib:1: Shutter expects open <= close, got 1 0"
    );
}

#[test]
fn clipping_far_of_1e30_is_infinite() {
    assert_eq!(ok("Clipping 0.01 1e30").camera.clipping, (0.01, f32::INFINITY));
    assert_eq!(ok("Clipping 1 100").camera.clipping, (1.0, 100.0));
    assert_eq!(
        fail("Clipping 0 10"),
        "t.rib:1: Clipping expects 0 < near < far, got 0 10"
    );
}

#[test]
fn pixel_filter_sets_kind_and_widths() {
    for (name, kind) in FILTERS {
        let scene = ok(&format!("PixelFilter \"{name}\" 3 4"));
        assert_eq!(
            scene.filter,
            PixelFilter {
                kind,
                width_x: 3.0,
                width_y: 4.0
            }
        );
    }
    assert_eq!(ok("").filter, PixelFilter::default());
}

#[test]
fn an_unknown_pixel_filter_is_the_nearest_one_with_a_warning_listing_the_six() {
    let s = ok("\nPixelFilter \"sinc\" 3 3");
    assert_eq!((s.filter.kind, s.filter.width_x), (FilterKind::CatmullRom, 3.0));
    assert_eq!(
        s.warnings,
        [
            "t.rib:2: PixelFilter \"sinc\" is not available: catmull-rom of the same width is used (available: \
          box, triangle, gaussian, catmull-rom, mitchell, blackman-harris)"
        ]
    );
    assert_eq!(ok("PixelFilter \"bessel\" 2 2").filter.kind, FilterKind::Gaussian);
    assert_eq!(
        fail("PixelFilter \"box\" 2"),
        "t.rib:1: PixelFilter expects a filter name then xwidth ywidth (2 numbers), got 1"
    );
}

#[test]
fn hider_maxsamples_sets_samples_per_pixel() {
    let scene =
        ok("Hider \"raytrace\" \"int maxsamples\" [16] \"int minsamples\" [4] \"int incremental\" [1]");
    assert_eq!(scene.samples_per_pixel, 16);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    // A bare name the reader knows the type of.
    assert_eq!(ok("Hider \"raytrace\" \"maxsamples\" 8").samples_per_pixel, 8);
    let scene = ok("Hider \"hidden\" \"int maxsamples\" [16]");
    assert_eq!(scene.samples_per_pixel, 64);
    assert_eq!(
        scene.warnings,
        vec!["t.rib:1: Hider \"hidden\" is not supported (only \"raytrace\"), ignored".to_string()]
    );
    assert_eq!(
        fail("Hider \"raytrace\" \"int maxsamples\" [0]"),
        "t.rib:1: Hider: maxsamples must be at least 1, got 0"
    );
}

#[test]
fn pixel_samples_sets_samples_per_pixel_as_their_product() {
    assert_eq!(ok("PixelSamples 3 2").samples_per_pixel, 6);
    // Fractional counts round up, as a stratified sampler needs whole strata.
    assert_eq!(ok("PixelSamples 1.5 4").samples_per_pixel, 8);
    // The last word wins, whichever request says it.
    assert_eq!(
        ok("PixelSamples 4 4\nHider \"raytrace\" \"int maxsamples\" [9]").samples_per_pixel,
        9
    );
    assert_eq!(
        ok("Hider \"raytrace\" \"int maxsamples\" [9]\nPixelSamples 2 2").samples_per_pixel,
        4
    );
    assert!(ok("PixelSamples 2 2").warnings.is_empty());
    assert_eq!(
        fail("PixelSamples 0 2"),
        "t.rib:1: PixelSamples expects sample counts from 1 to 65536, got 0 2"
    );
    assert_eq!(
        fail("PixelSamples 1000 1000"),
        "t.rib:1: PixelSamples 1000 1000 asks for 1000000 samples per pixel; at most 65536 are allowed"
    );
    assert!(fail("PixelSamples 2").starts_with("t.rib:1: PixelSamples expects xsamples ysamples"));
}

#[test]
fn display_adds_or_replaces_and_reads_channels_and_type() {
    let scene = ok("Display \"out/beauty.exr\" \"openexr\" \"rgba\"\n\
         Display \"+aovs.exr\" \"exr\" \"rgba,z,N,P,cameraDirection\" \"string type\" \"half\"\n\
         Display \"+/abs/x.png\" \"png\" \"rgb\"\n\
         Display \"+d.exr\" \"deepexr\" \"Ci,a,z\" \"string type\" \"float\"\n\
         Display \"+e.exr\" \"openexr\" \"rgbz\"\n\
         Display \"+f.exr\" \"openexr\" \"rgbaz\"\n");
    let d = &scene.displays;
    assert_eq!(d.len(), 6);
    assert_eq!(
        d[0],
        Display {
            path: PathBuf::from("/base/out/beauty.exr"),
            driver: DisplayDriver::OpenExr,
            aovs: vec![Aov::Ci, Aov::Alpha],
            half: false
        }
    );
    assert_eq!(
        d[1],
        Display {
            path: PathBuf::from("/base/aovs.exr"),
            driver: DisplayDriver::OpenExr,
            aovs: vec![Aov::Ci, Aov::Alpha, Aov::Z, Aov::N, Aov::P, Aov::CameraDirection],
            half: true
        }
    );
    assert_eq!(
        (d[2].path.as_path(), d[2].driver),
        (Path::new("/abs/x.png"), DisplayDriver::Png)
    );
    assert_eq!(d[2].aovs, vec![Aov::Ci]);
    assert_eq!(
        (d[3].driver, d[3].aovs.as_slice(), d[3].half),
        (DisplayDriver::DeepExr, &[Aov::Ci, Aov::Alpha, Aov::Z][..], false)
    );
    assert_eq!(d[4].aovs, vec![Aov::Ci, Aov::Z]);
    assert_eq!(d[5].aovs, vec![Aov::Ci, Aov::Alpha, Aov::Z]);
    // Without "+", a display replaces the list.
    let scene = ok("Display \"a.exr\" \"openexr\" \"rgb\"\nDisplay \"b.png\" \"png\" \"rgb\"\n");
    assert_eq!(scene.displays.len(), 1);
    assert_eq!(scene.displays[0].path, PathBuf::from("/base/b.png"));
}

#[test]
fn display_leaves_out_an_unknown_aov_with_a_warning_naming_it() {
    let scene = ok("\nDisplay \"a.exr\" \"openexr\" \"rgba,Cs\"");
    assert_eq!(scene.displays[0].aovs, vec![Aov::Ci, Aov::Alpha]);
    assert_eq!(
        scene.warnings,
        [
            "t.rib:2: Display \"a.exr\": AOV \"Cs\" is not produced by this renderer, left out (known: rgb, \
          rgba, rgbz, rgbaz, az, Z, depth, Ci, a, z, N, P, cameraDirection, cameraZ, distance, Pcamera, Ncamera, \
          objectId, instanceId, materialId, flowForward, flowBackward, flowValid, albedo, uv, raw, electrons)"
        ]
    );
    // A display left with no AOV is skipped, said so.
    let scene = ok("Display \"a.exr\" \"openexr\" \"color Oi\"");
    assert!(scene.displays.is_empty());
    assert!(
        scene.warnings[1]
            .ends_with("no AOV of mode \"color Oi\" is produced here, so the display is skipped")
    );
    // A typed AOV name is read by its name.
    assert_eq!(
        ok("Display \"n.exr\" \"openexr\" \"normal N\"").displays[0].aovs,
        vec![Aov::N]
    );
    assert_eq!(
        fail("Display \"a.exr\" \"openexr\" \"rgba\" \"string type\" \"double\""),
        "t.rib:1: Display: \"string type\" must be \"half\" or \"float\", got \"double\""
    );
}

#[test]
fn every_display_driver_is_written_as_a_file() {
    let scene = ok("Display \"a.tif\" \"tiff\" \"rgba\"\n\
         Display \"+b.pic\" \"file\" \"rgb\"\n\
         Display \"+c.exr\" \"file\" \"rgba\"\n\
         Display \"+d.png\" \"file\" \"rgb\"\n\
         Display \"+shadow.z\" \"zfile\" \"z\"\n\
         Display \"+map.shd\" \"shadow\" \"rgb\"\n\
         Display \"+depth.exr\" \"zfile\" \"z\"\n\
         Display \"+fb\" \"framebuffer\" \"rgb\"\n\
         Display \"+view.tif\" \"it\" \"rgba\"\n\
         Display \"+pic.xpm\" \"xpm\" \"rgb\"\n\
         Display \"+pic2.png\" \"sgi\" \"rgb\"\n");
    let got: Vec<(String, DisplayDriver, Vec<Aov>)> = scene
        .displays
        .iter()
        .map(|d| (d.path.display().to_string(), d.driver, d.aovs.clone()))
        .collect();
    let (rgb, rgba, z) = (vec![Aov::Ci], vec![Aov::Ci, Aov::Alpha], vec![Aov::Z]);
    let want = [
        ("/base/a.tif", DisplayDriver::Tiff, &rgba),
        ("/base/b.pic", DisplayDriver::Tiff, &rgb),
        ("/base/c.exr", DisplayDriver::OpenExr, &rgba),
        ("/base/d.png", DisplayDriver::Png, &rgb),
        ("/base/shadow.z", DisplayDriver::Tiff, &z),
        ("/base/map.shd", DisplayDriver::Tiff, &z),
        ("/base/depth.exr", DisplayDriver::OpenExr, &z),
        ("/base/fb.exr", DisplayDriver::OpenExr, &rgb),
        ("/base/view.exr", DisplayDriver::OpenExr, &rgba),
        ("/base/pic.tif", DisplayDriver::Tiff, &rgb),
        ("/base/pic2.png", DisplayDriver::Png, &rgb),
    ];
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(want) {
        assert_eq!((g.0.as_str(), g.1, &g.2), w);
    }
    assert_eq!(
        scene.warnings,
        [
            "t.rib:8: Display driver \"framebuffer\" shows a window, which a batch render has not: written to /base/fb.exr instead",
            "t.rib:9: Display driver \"it\" shows a window, which a batch render has not: written to /base/view.exr instead",
            "t.rib:10: Display driver \"xpm\" is not known: written as TIFF to /base/pic.tif",
            "t.rib:11: Display driver \"sgi\" is not known: written by its extension to /base/pic2.png",
        ]
    );
}

#[test]
fn two_displays_naming_one_file_is_an_error_naming_both() {
    assert_eq!(
        fail("Display \"a.tif\" \"file\" \"rgba\"\nDisplay \"+a.tif\" \"tiff\" \"z\"\n"),
        "t.rib:2: Display \"+a.tif\" writes /base/a.tif, which the display at t.rib:1 writes already: two \
         displays naming one file would overwrite each other"
    );
    // Interactive drivers become files too, so they can collide.
    assert!(
        fail("Display \"fb\" \"framebuffer\" \"rgb\"\nDisplay \"+fb.exr\" \"openexr\" \"z\"\n")
            .contains("which the display at t.rib:1 writes already")
    );
    // A display without "+" replaces the list: no collision.
    assert_eq!(
        ok("Display \"a.tif\" \"file\" \"rgba\"\nDisplay \"a.tif\" \"file\" \"rgb\"\n")
            .displays
            .len(),
        1
    );
}

#[test]
fn projection_keeps_its_parameters_with_their_origin() {
    let scene = ok("Projection \"PxrPerspective\" \"float fov\" [10]\n\
         Projection \"PxrFisheye\" \"float fov\" [180] \"string mapping\" \"equisolid\" \"float[2] k\" [1 2]\n");
    assert_eq!(scene.projection, "PxrFisheye");
    let p = &scene.projection_params;
    assert_eq!(p.entries().len(), 3);
    let fov = p.get("fov").unwrap();
    assert_eq!(
        (fov.ty, &fov.value),
        (ParamType::Float, &ParamValue::Floats(vec![180.0]))
    );
    assert_eq!(fov.origin.as_deref(), Some("t.rib:2"));
    assert_eq!(
        p.get("mapping").unwrap().value,
        ParamValue::Strings(vec!["equisolid".into()])
    );
    assert_eq!(p.get("k").unwrap().array_len, Some(2));
    assert_eq!(
        fail("Projection \"PxrFisheye\" \"flaot fov\" [1]"),
        "t.rib:1: Projection: unknown parameter type \"flaot\" in \"flaot fov\": expected one of float, \
         int, string, color, point, vector, normal, matrix"
    );
}

#[test]
fn legacy_projection_names_map_to_plugins() {
    let scene = ok("Projection \"perspective\" \"fov\" [30]");
    assert_eq!(scene.projection, "PxrPerspective");
    let fov = scene.projection_params.get("fov").unwrap();
    assert_eq!(
        (fov.ty, &fov.value),
        (ParamType::Float, &ParamValue::Floats(vec![30.0]))
    );
    let scene = ok("Projection \"orthographic\"");
    assert_eq!(scene.projection, "PxrOrthographic");
    assert!(scene.projection_params.is_empty());
    let scene = ok("Projection \"PxrFoo\" \"bar\" [1]");
    assert_eq!(
        scene.warnings,
        vec!["t.rib:1: Projection: unknown parameter \"bar\", ignored".to_string()]
    );
}

#[test]
fn camera_options_fill_aperture_and_shutter_opening() {
    let scene = ok(
        "Camera \"main\" \"int apertureNSides\" [6] \"float apertureAngle\" [15] \
         \"float apertureRoundness\" [0.5] \"float apertureDensity\" [-0.25] \"float dofaspect\" [2] \
         \"float shutterOpenTime\" [0.1] \"float shutterCloseTime\" [0.9] \
         \"float[8] shutteropening\" [0.1 0.2 0.3 0.4 0.5 0.6 0.7 0.8]",
    );
    let a = scene.camera.aperture;
    assert_eq!(
        (a.n_sides, a.angle_deg, a.roundness, a.density, a.dof_aspect),
        (6, 15.0, 0.5, -0.25, 2.0)
    );
    let s = scene.camera.shutter_opening;
    assert_eq!((s.open_time, s.close_time), (0.1, 0.9));
    assert_eq!(s.opening, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8]);
    // RenderMan ≤ 21's two-value shutteropening.
    let s = ok("Camera \"world\" \"float[2] shutteropening\" [0.25 0.75]")
        .camera
        .shutter_opening;
    assert_eq!((s.open_time, s.close_time), (0.25, 0.75));
    assert_eq!(
        fail("Camera \"main\" \"float apertureNSides\" [6]"),
        "t.rib:1: Camera: parameter \"float apertureNSides\" has the wrong type; expected \"int apertureNSides\""
    );
    assert_eq!(
        fail("Camera \"main\" \"shutteropening\" [1 2 3]"),
        "t.rib:1: Camera: \"float[8] shutteropening\" needs 8 value(s), got 3"
    );
}

#[test]
fn a_window_named_with_folders_that_do_not_exist_is_written_beside_the_scene() {
    // RenderMan for Maya names its `it` window `renderman/<scene>/images/<scene>`.
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("there")).unwrap();
    let text = "Display \"renderman/osl1/images/osl1\" \"it\" \"rgba\"\nDisplay \"+there/fb\" \"framebuffer\" \"rgb\"\n\
                WorldBegin\nWorldEnd\n";
    let scene = super::super::parse_str(text, "t.rib", dir.path()).unwrap_or_else(|e| panic!("{e}"));
    let paths: Vec<_> = scene.displays.iter().map(|d| d.path.clone()).collect();
    assert_eq!(
        paths,
        [
            dir.path().join("osl1.exr"),
            dir.path().join("there").join("fb.exr")
        ]
    );
    assert!(
        scene.warnings[0].ends_with(&format!(
            "written to {} instead",
            dir.path().join("osl1.exr").display()
        )),
        "{:?}",
        scene.warnings
    );
}
