//! 3DEqualizer lens files users have (the shared corpus of real 3DE exports, LDPK projects, mmSolver
//! files; never committed): every LD node loads and renders, each plate pixel's ray through the
//! projection (f32 parameters, as a render) is the model's undistorted pinhole ray (f64) to 2e-7
//! rad and comes back to its pixel, and animated nodes follow their curves per frame.
//!
//! The corpus is found at `$OBSCURA_LENS3DE_CORPUS` (default `/work/shared/corpora/lens3de/files`);
//! without it the tests skip, unless `OBSCURA_REQUIRE_CORPORA=1`, which makes that a failure.

use std::path::{Path, PathBuf};

use obscura_calibration::files::{FileFormat, load_frame};
use obscura_calibration::{CalibratedCameraFactory, CameraModel};
use obscura_sdk::{
    Format, Point2, ProjectionContext, ProjectionEnvironment, ProjectionFactory, RayGeometry, Rgb,
};

fn corpus() -> Option<PathBuf> {
    let dir = PathBuf::from(
        std::env::var("OBSCURA_LENS3DE_CORPUS")
            .unwrap_or_else(|_| "/work/shared/corpora/lens3de/files".into()),
    );
    if dir.is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var("OBSCURA_REQUIRE_CORPORA").as_deref() != Ok("1"),
        "OBSCURA_REQUIRE_CORPORA=1 but the 3DE lens corpus is not at {}",
        dir.display()
    );
    eprintln!("skipped: no 3DE lens corpus at {}", dir.display());
    None
}

fn nuke_scripts(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for sub in std::fs::read_dir(dir).unwrap() {
        let sub = sub.unwrap().path();
        if sub.is_dir() {
            for f in std::fs::read_dir(&sub).unwrap() {
                let f = f.unwrap().path();
                if f.extension().is_some_and(|e| e == "nk") {
                    out.push(f);
                }
            }
        }
    }
    out.sort();
    out
}

/// The angle between two directions.
fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let n = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let cross = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    n(cross).atan2(dot)
}

#[test]
fn every_ld_node_of_the_corpus_renders_its_models_rays() {
    let Some(dir) = corpus() else { return };
    let mut nodes = 0;
    for path in nuke_scripts(&dir) {
        let first = load_frame(&path, None, None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(first.format, FileFormat::Nuke);
        for name in first.cameras.clone() {
            let c = load_frame(&path, Some(&name), None).unwrap_or_else(|e| panic!("{e}"));
            let params = match c.param_list() {
                Ok(p) => p,
                Err(e) => panic!("{}: {e}", path.display()),
            };
            nodes += 1;
            let (w, h) = (
                c.width.min(256),
                (f64::from(c.width.min(256)) * f64::from(c.height) / f64::from(c.width))
                    .round()
                    .max(1.0) as u32,
            );
            let values: Vec<f64> = c.params.iter().map(|n| f64::from(n.value as f32)).collect();
            let model = CameraModel::new(
                &c.model,
                &values,
                &[],
                &[],
                f64::from(c.width),
                f64::from(c.height),
            )
            .unwrap();
            let mut env = ProjectionEnvironment::for_format(Format::new(w, h));
            let projection = CalibratedCameraFactory
                .create_projection(&mut env, &params)
                .unwrap();
            // Pixel centres of a w × h render of the plate.
            let sw = env.screen_window();
            let mut screen = Vec::new();
            let mut raster = Vec::new();
            for j in 0..h {
                for i in 0..w {
                    let (x, y) = (f64::from(i) + 0.5, f64::from(j) + 0.5);
                    screen.push(Point2::new(
                        sw.left + (x / f64::from(w)) as f32 * (sw.right - sw.left),
                        sw.top - (y / f64::from(h)) as f32 * (sw.top - sw.bottom),
                    ));
                    // The calibration raster position of the f32 screen point the projection gets.
                    let s = screen.last().unwrap();
                    let (l, r, b, t) = (
                        f64::from(sw.left),
                        f64::from(sw.right),
                        f64::from(sw.bottom),
                        f64::from(sw.top),
                    );
                    raster.push([
                        (f64::from(s.x) - l) / (r - l) * f64::from(c.width),
                        (t - f64::from(s.y)) / (t - b) * f64::from(c.height),
                    ]);
                }
            }
            let n = screen.len();
            let (lens, aperture, mut time) = (
                vec![Point2::new(0.5, 0.5); n],
                vec![Point2::new(0.0, 0.0); n],
                vec![0.0f32; n],
            );
            let mut rays = vec![RayGeometry::CULLED; n];
            let mut tint = vec![Rgb::WHITE; n];
            let mut ctx =
                ProjectionContext::new(&screen, &lens, &aperture, &mut time, &mut rays, &mut tint).unwrap();
            projection.project(&mut ctx);
            let (mut valid, mut worst) = (0, 0.0f64);
            for (k, r) in rays.iter().enumerate() {
                let reference = model.pixel_to_ray(raster[k]);
                let d = r.direction;
                match reference {
                    None => assert!(
                        d.x == 0.0 && d.y == 0.0 && d.z == 0.0,
                        "{} {name}: culled pixel has a ray",
                        path.display()
                    ),
                    Some(pr) => {
                        valid += 1;
                        // The projection's y is up, the model's down.
                        let e = angle([f64::from(d.x), -f64::from(d.y), f64::from(d.z)], pr.v);
                        worst = worst.max(e);
                        let back = model.ray_to_pixel(pr.v).unwrap_or_else(|| {
                            panic!("{} {name}: {:?} has no pixel", path.display(), raster[k])
                        });
                        let e_px = (back[0] - raster[k][0]).hypot(back[1] - raster[k][1]);
                        assert!(
                            e_px < 1e-6,
                            "{} {name}: {:?} → {back:?}",
                            path.display(),
                            raster[k]
                        );
                    }
                }
            }
            assert!(
                worst < 2e-7,
                "{} {name}: rays differ from the model's by {worst} rad",
                path.display()
            );
            assert!(valid > 0, "{} {name}: no pixel has a ray", path.display());
        }
    }
    assert!(
        nodes >= 37,
        "only {nodes} LD nodes in the corpus (its 24 Nuke scripts hold 37)"
    );
}

#[test]
fn animated_nodes_follow_their_curves_per_frame() {
    let Some(dir) = corpus() else { return };
    let path = dir.join("ldpk-2.0/test_2_flame_dynld.nk");
    // The sparse-key node and the per-frame node describe the same zoom: focal 4 → 6 cm over frames
    // 1 … 11, Distortion - Degree 2 0.05 → −0.05, φ 45° → −45°.
    for frame in 1..=11 {
        let f = f64::from(frame);
        let sparse = load_frame(&path, Some("LD_3DE4_Radial_Standard_Degree_4_1"), Some(f)).unwrap();
        let run = load_frame(&path, Some("LD_3DE4_test_2_flame_dynld"), Some(f)).unwrap();
        let v = |c: &obscura_calibration::files::Calibration, i: usize| c.params[i].value;
        let t = (f - 1.0) / 10.0;
        assert!(
            (v(&sparse, 0) - (4.0 + 2.0 * t)).abs() < 1e-9,
            "frame {frame}: focal {}",
            v(&sparse, 0)
        );
        assert!((v(&run, 0) - (4.0 + 2.0 * t)).abs() < 1e-9);
        assert!((v(&sparse, 10) - (0.05 - 0.1 * t)).abs() < 1e-9);
        assert!((v(&run, 10) - v(&sparse, 10)).abs() < 1e-9);
        assert!((v(&sparse, 16) - (45.0 - 90.0 * t)).abs() < 1e-9);
    }
    // The rays change per frame as the focal length does.
    let ray = |frame: f64| {
        let c = load_frame(&path, Some("LD_3DE4_test_2_flame_dynld"), Some(frame)).unwrap();
        let p: Vec<f64> = c.params.iter().map(|n| n.value).collect();
        let m = CameraModel::new(&c.model, &p, &[], &[], f64::from(c.width), f64::from(c.height)).unwrap();
        let r = m.pixel_to_ray([100.0, 100.0]).unwrap().v;
        r[0].hypot(r[1]).atan2(r[2])
    };
    assert!(
        ray(1.0) > ray(11.0) + 0.05,
        "a longer focal length sees a narrower angle"
    );
}

#[test]
fn bad_nuke_scripts_get_located_errors() {
    use obscura_calibration::files::parse;
    let node = |body: &str| {
        format!(
            "Root {{\n format \"1920 1080 0 0 1920 1080 1 HD\"\n}}\nLD_3DE4_Radial_Standard_Degree_4 {{\n{body}\n name lens\n}}\n"
        )
    };
    let cases: [(String, usize, &[&str]); 4] = [
        (
            node(" tde4_filmback_width_cm 0"),
            5,
            &["tde4_filmback_width_cm", "> 0"],
        ),
        (
            node(" Distortion_Degree_2 {{curve x1 0.1 x2}}\n"),
            5,
            &["Distortion_Degree_2", "curve"],
        ),
        (
            "LD_3DE4_Radial_Blah {\n name x\n}\n".to_string(),
            1,
            &["unknown lens-distortion node class LD_3DE4_Radial_Blah"],
        ),
        (
            "LD_3DE_Classic_LD_Model {\n Anamorphic_Squeeze 0\n name c\n}\n".to_string(),
            2,
            &["Anamorphic Squeeze must be > 0"],
        ),
    ];
    for (text, line, words) in cases {
        let e = parse(&text, "lens.nk", None)
            .and_then(|c| c.param_list().map(|_| c))
            .expect_err(&text);
        assert_eq!(e.line, Some(line), "{e}");
        for w in words {
            assert!(e.to_string().contains(w), "{e}");
        }
    }
    let e = parse(&node(""), "lens.nk", Some("other")).unwrap_err();
    assert!(
        e.to_string().contains("no camera \"other\"") && e.to_string().contains("lens"),
        "{e}"
    );
}

#[test]
fn a_3de_lens_export_is_the_same_lens_as_its_nuke_export() {
    let Some(dir) = corpus() else { return };
    let text = load_frame(
        &dir.join("mmsolver-testdata/trackboy_slim_3de_lens.txt"),
        None,
        None,
    )
    .unwrap();
    let nuke = load_frame(
        &dir.join("mmsolver-testdata/trackboy_slim_nuke_ldpk.nk"),
        None,
        None,
    )
    .unwrap();
    assert_eq!(text.format, FileFormat::Tde4Lens);
    assert_eq!(text.model, "3DE4 Radial - Standard, Degree 4");
    assert_eq!(text.model, nuke.model);
    // 15 decimals against the Nuke export's 7.
    for (a, b) in text.params.iter().zip(&nuke.params) {
        assert!((a.value - b.value).abs() < 1e-7, "{a:?} vs {b:?}");
    }
    let classic = load_frame(&dir.join("mmsolver-testdata/test_out_v001.txt"), None, None).unwrap();
    assert_eq!(classic.model, "3DE Classic LD Model");
    assert_eq!(classic.params[5].value, 1.5, "pixel aspect");
    assert_eq!(classic.params[11].value, 0.25, "Anamorphic Squeeze");
    assert!(
        classic.notes.iter().any(|n| n.contains("Anamorphic Squeeze")),
        "{:?}",
        classic.notes
    );
    classic.param_list().unwrap();
}

#[test]
fn bad_lens_exports_get_located_errors() {
    use obscura_calibration::files::parse;
    let lens = |model: &str, mode: &str, param: &str| {
        format!("l\n2.4 1.8 3.5 1.333 0 0 1\n{mode}\n{model}\n{param}\n0.01\n0\n<end_of_file>\n")
    };
    for (text, line, word) in [
        (
            lens("3DE4 Radial - Blah", "DISTORTION_STATIC", "Distortion"),
            4,
            "unknown 3DE lens model",
        ),
        (
            lens("3DE Classic LD Model", "DYNAMIC_FOCAL_LENGTH", "Distortion"),
            3,
            "dynamic distortion",
        ),
        (
            lens(
                "3DE Classic LD Model",
                "DISTORTION_STATIC",
                "Distortion - Degree 2",
            ),
            5,
            "is not a parameter",
        ),
        (
            lens("3DE Classic LD Model", "DISTORTION_STATIC", "Anamorphic Squeeze").replace("0.01", "0"),
            6,
            "Anamorphic Squeeze must be > 0",
        ),
        (
            "l\n0 1.8 3.5 1.333 0 0 1\n0\n3DE Classic LD Model\n<end_of_file>\n".to_string(),
            2,
            "tde4_filmback_width_cm must be > 0",
        ),
    ] {
        let e = parse(&text, "lens.txt", None)
            .and_then(|c| c.param_list().map(|_| c))
            .expect_err(&text);
        assert_eq!(e.line, Some(line), "{e}");
        assert!(e.to_string().contains(word), "{e}");
    }
}
