//! RenderMan projection plugins as they are written (issue 24): the six test plugins of
//! `examples/rman-plugins/`, each written against RenderMan 19–21, 22 and 23–27's interface, built by
//! `obscura build-plugin` with the system C++ compiler, pass `obscura check`, and their rays equal the
//! camera's closed form to 1e-6 rad; broken plugins cost a located error, never a crash; a source of
//! another generation is explained as such.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

use obscura_host::{Batch, CameraDesc, CameraStage};
use obscura_plugins::builtin_registry;
use obscura_plugins::loader::{PluginSearch, ensure};
use obscura_sdk::{Format, ParamList, ParamValue, Point2, RayGeometry, Vec3};

const GENERATIONS: [&str; 3] = ["rman21", "rman22", "rman27"];
const PLUGINS: [&str; 6] = [
    "ThinLens",
    "CullingFisheye",
    "OdsStereo",
    "TimeTint",
    "FourView",
    "OptionsLogger",
];

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn obscura(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_obscura"))
        .args(args)
        .current_dir(dir)
        .env_remove("OBSCURA_PLUGIN_PATH")
        .output()
        .expect("the obscura binary runs")
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// The build directory and each build's (generation, plugin, output).
type Built = (PathBuf, Vec<(String, String, String)>);

/// Every test plugin built once per test binary with `obscura build-plugin` (two at a time), into
/// `<tmp>/rman-plugins/<generation>/<Name>.so`; each build's output kept for the tests.
fn built() -> &'static Built {
    static BUILT: OnceLock<Built> = OnceLock::new();
    BUILT.get_or_init(|| {
        let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rman-plugins");
        let jobs: Vec<(&str, &str)> = GENERATIONS
            .iter()
            .flat_map(|g| PLUGINS.iter().map(move |p| (*g, *p)))
            .collect();
        let results = std::sync::Mutex::new(Vec::new());
        let next = std::sync::atomic::AtomicUsize::new(0);
        std::thread::scope(|s| {
            for _ in 0..2 {
                s.spawn(|| {
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                        let Some(&(g, p)) = jobs.get(i) else { break };
                        let dir = root.join(g);
                        std::fs::create_dir_all(&dir).unwrap();
                        let src = workspace().join(format!("examples/rman-plugins/{g}/{p}.cpp"));
                        // RenderMan 23-27 as the command builds by default (-O2); the older generations
                        // at -O0 (passed after `--`, it overrides), which halves the tests' compile time.
                        let mut args = vec!["build-plugin", src.to_str().unwrap()];
                        if g != "rman27" {
                            args.extend(["--", "-O0"]);
                        }
                        let out = obscura(&args, &dir);
                        assert!(out.status.success(), "building {g}/{p} failed:\n{}", text(&out));
                        results
                            .lock()
                            .unwrap()
                            .push((g.to_string(), p.to_string(), text(&out)));
                    }
                });
            }
        });
        (root, results.into_inner().unwrap())
    })
}

fn dir_of(generation: &str) -> PathBuf {
    built().0.join(generation)
}

#[test]
fn build_plugin_finds_each_generation_prints_the_compiler_line_and_names_the_projection() {
    for (g, p, out) in &built().1 {
        let version = &g[4..];
        assert!(out.contains(&format!("RenderMan {version}")), "{g}/{p}: {out}");
        assert!(out.contains("-shared -fPIC -std=c++17 -O2"), "{g}/{p}: {out}");
        assert!(
            out.contains(&format!("-DOBSCURA_RMAN_VERSION={version}")),
            "{g}/{p}: {out}"
        );
        assert!(
            out.contains(&format!("wrote {p}.so (Projection \"{p}\")")),
            "{g}/{p}: {out}"
        );
        assert!(dir_of(g).join(format!("{p}.so")).is_file());
    }
}

#[test]
fn every_test_plugin_of_every_generation_passes_obscura_check() {
    for g in GENERATIONS {
        for p in PLUGINS {
            let dir = dir_of(g);
            let out = obscura(&["--plugin-path", ".", "check", p], &dir);
            assert!(out.status.success(), "obscura check {g}/{p}:\n{}", text(&out));
            assert!(
                text(&out).contains("clean: no check failed"),
                "{g}/{p}: {}",
                text(&out)
            );
        }
    }
}

#[test]
fn the_options_logger_logs_through_rix_messages_what_rix_render_state_answered() {
    for g in GENERATIONS {
        let out = obscura(
            &[
                "--plugin-path",
                ".",
                "check",
                "OptionsLogger",
                "--format",
                "80x40",
            ],
            &dir_of(g),
        );
        let t = text(&out);
        assert!(
            t.contains(
                "OptionsLogger: info: OptionsLogger: 80x40 pixels, screen window [-2 2 -1 1], scale 1"
            ),
            "{g}: {t}"
        );
        assert!(
            t.contains("OptionsLogger: info: OptionsLogger: render ended"),
            "{g}: {t}"
        );
    }
}

#[test]
fn a_plugin_renders_and_runs_isolated() {
    let dir = dir_of("rman27");
    let out = obscura(
        &[
            "--plugin-path",
            ".",
            "--isolate-plugins",
            "render",
            "-p",
            "CullingFisheye",
            "--format",
            "32x24",
            "--spp",
            "1",
            "-o",
            "fish.exr",
        ],
        &dir,
    );
    assert!(out.status.success(), "{}", text(&out));
    assert!(dir.join("fish.exr").is_file());
}

/// The batch: screen points across (and a little past) the window, lens samples spread over [0, 1)².
fn batch(cam: &CameraDesc) -> Batch {
    let sw = cam.screen_window();
    let mut b = Batch::with_capacity(4096);
    let n = 64;
    for j in 0..n {
        for i in 0..n {
            let u = (i as f32 + 0.5) / n as f32 * 1.04 - 0.02;
            let v = (j as f32 + 0.5) / n as f32 * 1.04 - 0.02;
            let s = Point2::new(
                sw.left + u * (sw.right - sw.left),
                sw.bottom + v * (sw.top - sw.bottom),
            );
            let k = (j * n + i) as f32;
            let lens = Point2::new((k * 0.618_034).fract(), (k * 0.754_877_7).fract());
            b.push(s, lens, (k * 0.137).fract());
        }
    }
    b
}

fn params(list: &[(&str, ParamValue)]) -> ParamList {
    let mut p = ParamList::new();
    for (decl, v) in list {
        p.push(decl, v.clone(), None).unwrap();
    }
    p
}

/// The rays of plugin `name` of `generation` on [`batch`].
fn run(generation: &str, name: &str, list: &[(&str, ParamValue)], cam: &CameraDesc) -> Batch {
    let mut reg = builtin_registry();
    let search = PluginSearch::new(vec![dir_of(generation)]);
    ensure(&mut reg, name, &search).unwrap_or_else(|e| panic!("{generation}/{name}: {e}"));
    let stage = CameraStage::new(&mut reg, name, &params(list), cam)
        .unwrap_or_else(|e| panic!("{generation}/{name}: {e}"));
    let mut b = batch(cam);
    let report = stage.run(&mut b);
    assert_eq!(report.lost(), 0, "{generation}/{name}");
    b
}

fn v3(x: f64, y: f64, z: f64) -> [f64; 3] {
    [x, y, z]
}

fn norm(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// The angle between `got` and the unit `want`, radians.
fn angle(got: Vec3, want: [f64; 3]) -> f64 {
    let g = [f64::from(got.x), f64::from(got.y), f64::from(got.z)];
    let c = [
        g[1] * want[2] - g[2] * want[1],
        g[2] * want[0] - g[0] * want[2],
        g[0] * want[1] - g[1] * want[0],
    ];
    let cross = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    let dot = g[0] * want[0] + g[1] * want[1] + g[2] * want[2];
    cross.atan2(dot)
}

fn assert_ray(what: &str, i: usize, r: &RayGeometry, dir: [f64; 3], origin: [f64; 3]) {
    let a = angle(r.direction, dir);
    assert!(
        a < 1e-6,
        "{what} sample {i}: direction {:?} is {a:e} rad from {dir:?}",
        r.direction
    );
    let o = [
        f64::from(r.origin.x),
        f64::from(r.origin.y),
        f64::from(r.origin.z),
    ];
    for k in 0..3 {
        assert!(
            (o[k] - origin[k]).abs() < 1e-6,
            "{what} sample {i}: origin {o:?}, expected {origin:?}"
        );
    }
}

fn f(v: f32) -> ParamValue {
    ParamValue::Floats(vec![v])
}

#[test]
fn thin_lens_rays_equal_the_closed_form_in_every_generation() {
    let cam = CameraDesc::new(Format::new(64, 48));
    let list = [
        ("float fov", f(50.0)),
        ("float fStop", f(2.8)),
        ("float focalLength", f(0.5)),
        ("float focalDistance", f(4.0)),
    ];
    for g in GENERATIONS {
        let b = run(g, "ThinLens", &list, &cam);
        let d = 1.0 / (25f64.to_radians()).tan();
        let radius = 0.5 * 0.5 / 2.8;
        let mut lens_moved = 0;
        for (i, r) in b.rays.iter().enumerate() {
            let (sx, sy) = (f64::from(b.screen[i].x), f64::from(b.screen[i].y));
            // Generation 19-21 has no properties, so the host's aperture is the same; the plugin
            // scales it by its own lens radius.
            let (ax, ay) = (f64::from(b.aperture[i].x), f64::from(b.aperture[i].y));
            let o = v3(radius * ax, radius * ay, 0.0);
            let focus = v3(sx * 4.0 / d, sy * 4.0 / d, 4.0);
            let dir = norm([focus[0] - o[0], focus[1] - o[1], focus[2] - o[2]]);
            assert_ray(&format!("{g}/ThinLens"), i, r, dir, o);
            lens_moved += usize::from(o[0].abs() > 1e-3);
        }
        assert!(lens_moved > b.len() / 2, "the aperture samples moved the origins");
    }
}

#[test]
fn culling_fisheye_rays_equal_the_closed_form_and_cull_outside_the_circle() {
    let cam = CameraDesc::new(Format::new(64, 48));
    for g in GENERATIONS {
        let b = run(g, "CullingFisheye", &[("float fov", f(190.0))], &cam);
        let (mut culled, mut kept) = (0, 0);
        for (i, r) in b.rays.iter().enumerate() {
            let (sx, sy) = (f64::from(b.screen[i].x), f64::from(b.screen[i].y));
            let rr = (sx * sx + sy * sy).sqrt();
            if rr > 1.0 + 1e-6 {
                assert_eq!(
                    r.direction,
                    Vec3::ZERO,
                    "{g} sample {i} at r = {rr} must be culled"
                );
                culled += 1;
                continue;
            }
            if rr > 1.0 - 1e-6 {
                continue;
            }
            let theta = rr * 95f64.to_radians();
            let k = if rr > 0.0 { theta.sin() / rr } else { 0.0 };
            assert_ray(
                &format!("{g}/CullingFisheye"),
                i,
                r,
                norm(v3(sx * k, sy * k, theta.cos())),
                [0.0; 3],
            );
            kept += 1;
        }
        assert!(culled > 500 && kept > 1000, "{g}: {culled} culled, {kept} kept");
    }
}

#[test]
fn omnidirectional_stereo_rays_equal_the_closed_form_for_each_eye() {
    let cam = CameraDesc::new(Format::new(64, 32));
    let sw = cam.screen_window();
    for g in GENERATIONS {
        for (eye, side) in [("left", -1.0), ("right", 1.0), ("center", 0.0)] {
            let list = [
                ("string eye", ParamValue::Strings(vec![eye.into()])),
                ("float interpupillaryDistance", f(0.1)),
            ];
            let b = run(g, "OdsStereo", &list, &cam);
            for (i, r) in b.rays.iter().enumerate() {
                let (sx, sy) = (f64::from(b.screen[i].x), f64::from(b.screen[i].y));
                let (l, rt, bo, t) = (
                    f64::from(sw.left),
                    f64::from(sw.right),
                    f64::from(sw.bottom),
                    f64::from(sw.top),
                );
                let u = (2.0 * sx - l - rt) / (rt - l);
                let v = ((2.0 * sy - bo - t) / (t - bo)).clamp(-1.0, 1.0);
                let (lon, lat) = (u * std::f64::consts::PI, v * std::f64::consts::FRAC_PI_2);
                let dir = v3(lat.cos() * lon.sin(), lat.sin(), lat.cos() * lon.cos());
                let k = side * 0.05;
                assert_ray(
                    &format!("{g}/OdsStereo {eye}"),
                    i,
                    r,
                    dir,
                    v3(k * lon.cos(), 0.0, -k * lon.sin()),
                );
            }
        }
    }
}

#[test]
fn the_time_and_tint_modifier_edits_only_time_and_tint_of_the_host_camera() {
    let cam = CameraDesc::new(Format::new(64, 48));
    // The host's own camera for a projection that answers nothing: a 90° pinhole.
    let mut reg = builtin_registry();
    let reference = CameraStage::new(
        &mut reg,
        "PxrPerspective",
        &params(&[("float fov", f(90.0))]),
        &cam,
    )
    .unwrap();
    let mut want = batch(&cam);
    reference.run(&mut want);
    for g in GENERATIONS {
        let list = [
            ("int strobes", ParamValue::Ints(vec![3])),
            ("color tint", ParamValue::Floats(vec![1.0, 0.5, 0.25])),
        ];
        let b = run(g, "TimeTint", &list, &cam);
        for (i, r) in b.rays.iter().enumerate() {
            let w = &want.rays[i];
            assert_ray(
                &format!("{g}/TimeTint"),
                i,
                r,
                [
                    f64::from(w.direction.x),
                    f64::from(w.direction.y),
                    f64::from(w.direction.z),
                ],
                [0.0; 3],
            );
            let t = (want.time[i] * 3.0).floor() / 3.0;
            assert_eq!(b.time[i], t, "{g} sample {i}: time");
            assert_eq!(
                (b.tint[i].r, b.tint[i].g, b.tint[i].b),
                (1.0, 0.5, 0.25),
                "{g} sample {i}: tint"
            );
        }
    }
}

#[test]
fn four_view_rays_follow_each_quadrants_matrix() {
    let cam = CameraDesc::new(Format::new(64, 48));
    let sw = cam.screen_window();
    // view1: turned 90° about +Y (camera +Z to +X) and moved to (1, 2, 3); view2: moved to (0, 0, -5).
    let view1 = vec![
        0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 1.0,
    ];
    let view2 = vec![
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -5.0, 1.0,
    ];
    let list = [
        ("float fov", f(60.0)),
        ("matrix view1", ParamValue::Floats(view1.clone())),
        ("matrix view2", ParamValue::Floats(view2.clone())),
    ];
    for g in GENERATIONS {
        let b = run(g, "FourView", &list, &cam);
        let d = 1.0 / 30f64.to_radians().tan();
        for (i, r) in b.rays.iter().enumerate() {
            let (sx, sy) = (f64::from(b.screen[i].x), f64::from(b.screen[i].y));
            let (l, rt, bo, t) = (
                f64::from(sw.left),
                f64::from(sw.right),
                f64::from(sw.bottom),
                f64::from(sw.top),
            );
            let u = (2.0 * sx - l - rt) / (rt - l);
            let v = (2.0 * sy - bo - t) / (t - bo);
            let q = usize::from(u >= 0.0) + 2 * usize::from(v < 0.0);
            let lu = 2.0 * u - if u >= 0.0 { 1.0 } else { -1.0 };
            let lv = 2.0 * v - if v >= 0.0 { 1.0 } else { -1.0 };
            let local = norm(v3(lu, lv, d));
            let m: Vec<f64> = match q {
                1 => view1.iter().map(|&x| f64::from(x)).collect(),
                2 => view2.iter().map(|&x| f64::from(x)).collect(),
                _ => vec![
                    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
                ],
            };
            // Row vectors: [v 0]·M, [0 0 0 1]·M.
            let dir = norm(v3(
                local[0] * m[0] + local[1] * m[4] + local[2] * m[8],
                local[0] * m[1] + local[1] * m[5] + local[2] * m[9],
                local[0] * m[2] + local[1] * m[6] + local[2] * m[10],
            ));
            assert_ray(&format!("{g}/FourView q{q}"), i, r, dir, v3(m[12], m[13], m[14]));
        }
    }
}

#[test]
fn the_options_loggers_orthographic_rays_use_the_options_it_read() {
    let cam = CameraDesc::new(Format::new(80, 40));
    for g in GENERATIONS {
        let b = run(g, "OptionsLogger", &[("float scale", f(2.0))], &cam);
        // DeviceResolution 80x40, Ri:ScreenWindow [-2 2 -1 1]: a pixel is 0.05 x 0.05 screen units.
        let radius = 0.5 * (0.05f64 * 0.05).sqrt() * 2.0;
        for (i, r) in b.rays.iter().enumerate() {
            let (sx, sy) = (f64::from(b.screen[i].x), f64::from(b.screen[i].y));
            assert_ray(
                &format!("{g}/OptionsLogger"),
                i,
                r,
                [0.0, 0.0, 1.0],
                v3(2.0 * sx, 2.0 * sy, 0.0),
            );
            assert!(
                (f64::from(r.origin_radius) - radius).abs() < 1e-7,
                "{g}: origin_radius {}",
                r.origin_radius
            );
        }
    }
}

/// `Broken.cpp` built with the mistake `define` into a directory of its own; `obscura check Broken`'s
/// output.
fn broken(define: &str) -> String {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("rman-broken")
        .join(define);
    std::fs::create_dir_all(&dir).unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/rman/Broken.cpp");
    let out = obscura(
        &[
            "build-plugin",
            src.to_str().unwrap(),
            &format!("-D{define}"),
            "--",
            "-O0",
        ],
        &dir,
    );
    assert!(out.status.success(), "{define}: {}", text(&out));
    let out = obscura(&["--plugin-path", ".", "check", "Broken"], &dir);
    assert!(
        !out.status.success(),
        "{define}: a broken plugin passed: {}",
        text(&out)
    );
    text(&out)
}

#[test]
fn a_broken_plugin_costs_a_located_error_never_a_crash() {
    let cases = [
        (
            "THROW_IN_FACTORY_CONSTRUCTOR",
            "Broken.so: the factory's constructor (RIX_PROJECTIONFACTORYCREATE) threw std::runtime_error: no licence for this camera",
        ),
        (
            "THROW_IN_PROJECTION_CONSTRUCTOR",
            "error: Broken: CreateProjection threw std::runtime_error: the lens table is missing",
        ),
        (
            "NULL_PROPERTY",
            "error: Broken: GetProperty(k_FieldOfView) answered k_RixSCUniform but left *result NULL",
        ),
        ("NULL_TABLE", "Broken.so: GetParamTable() returned NULL"),
        (
            "NULL_FACTORY",
            "Broken.so: RIX_PROJECTIONFACTORYCREATE returned NULL (the plugin made no factory)",
        ),
        (
            "NULL_PROJECTION",
            "error: Broken: CreateProjection returned NULL (the factory made no projection)",
        ),
        (
            "THROW_IN_PROJECT",
            "panicked: Project threw std::out_of_range: sample outside the distortion grid",
        ),
    ];
    for (define, want) in cases {
        let t = broken(define);
        assert!(t.contains(want), "{define}: expected {want:?} in:\n{t}");
        assert!(
            !t.contains("panicked at") && !t.contains("Segmentation"),
            "{define}: {t}"
        );
    }
}

#[test]
fn a_source_of_another_generation_is_explained_naming_the_generation_it_is_written_for() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rman-mismatch");
    std::fs::create_dir_all(&dir).unwrap();
    let cases = [
        (
            "rman22/ThinLens.cpp",
            "27",
            "This source is written for RenderMan 22 (ThinLens.cpp:",
        ),
        (
            "rman27/FourView.cpp",
            "22",
            "This source is written for RenderMan 23-27 (FourView.cpp:",
        ),
        (
            "rman21/CullingFisheye.cpp",
            "25",
            "This source is written for RenderMan 19-21 (CullingFisheye.cpp:",
        ),
        (
            "rman27/TimeTint.cpp",
            "21",
            "RIX_PROJECTIONFACTORYCREATE is the entry of RenderMan 22-27 projection plugins",
        ),
    ];
    for (src, version, want) in cases {
        let src = workspace().join("examples/rman-plugins").join(src);
        let out = obscura(
            &[
                "build-plugin",
                src.to_str().unwrap(),
                "--rman-version",
                version,
                "-o",
                "x.so",
                "--",
                "-O0",
            ],
            &dir,
        );
        let t = text(&out);
        assert!(!out.status.success(), "{t}");
        assert!(t.contains(want), "expected {want:?} in:\n{t}");
        assert!(
            t.contains(&format!("-DOBSCURA_RMAN_VERSION={version}")),
            "the compiler line is printed: {t}"
        );
    }
}

#[test]
fn the_sdk_installs_with_a_cmake_package_and_a_pkg_config_file_that_build_a_plugin() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rman-sdk");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let out = obscura(&["build-plugin", "--install-sdk", "sdk"], &dir);
    assert!(out.status.success(), "{}", text(&out));
    for f in [
        "include/rix/RixProjection.h",
        "include/rix/obscura_rman_glue.cpp",
        "include/obscura/projection.h",
        "lib/cmake/ObscuraRMan/ObscuraRManConfig.cmake",
        "lib/pkgconfig/obscura-rman.pc",
    ] {
        assert!(dir.join("sdk").join(f).is_file(), "{f}");
    }
    // The pkg-config file's flags, with its glue, build a plugin the host loads (pkg-config itself
    // reads it when installed; the flags are read here the way it would).
    let pc = std::fs::read_to_string(dir.join("sdk/lib/pkgconfig/obscura-rman.pc")).unwrap();
    let prefix = pc
        .lines()
        .find_map(|l| l.strip_prefix("prefix="))
        .unwrap()
        .to_string();
    let inc = format!("{prefix}/include");
    let src = workspace().join("examples/rman-plugins/rman27/CullingFisheye.cpp");
    let status = Command::new(std::env::var("CXX").unwrap_or_else(|_| "c++".into()))
        .args([
            "-shared",
            "-fPIC",
            "-std=c++17",
            "-O0",
            "-DOBSCURA_RMAN_VERSION=27",
        ])
        .arg(format!("-I{inc}/rix"))
        .arg(format!("-I{inc}"))
        .arg("-o")
        .arg(dir.join("CullingFisheye.so"))
        .arg(&src)
        .arg(format!("{inc}/rix/obscura_rman_glue.cpp"))
        .status()
        .unwrap();
    assert!(status.success());
    let out = obscura(&["--plugin-path", ".", "check", "CullingFisheye"], &dir);
    assert!(out.status.success(), "{}", text(&out));
}

#[test]
fn a_rib_finds_its_plugin_through_the_rixplugin_searchpath_and_names_it_by_file_stem() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rman-searchpath");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("plugins")).unwrap();
    // Renamed: the projection answers to its file's stem.
    std::fs::copy(
        dir_of("rman27").join("CullingFisheye.so"),
        dir.join("plugins/StudioFisheye.so"),
    )
    .unwrap();
    std::fs::write(
        dir.join("scene.rib"),
        "Option \"searchpath\" \"string rixplugin\" [\"plugins:&\"]\nFormat 32 24 1\n\
         Projection \"StudioFisheye\" \"float fov\" [180]\nWorldBegin\nTranslate 0 0 5\nSphere 1 -1 1 360\nWorldEnd\n",
    )
    .unwrap();
    let out = obscura(&["render", "scene.rib", "--spp", "1", "-o", "out.exr"], &dir);
    assert!(out.status.success(), "{}", text(&out));
    assert!(dir.join("out.exr").is_file());
    // Without the searchpath the name is unknown, and the message says where it looked.
    std::fs::write(
        dir.join("bare.rib"),
        "Format 32 24 1\nProjection \"StudioFisheye\"\nWorldBegin\nWorldEnd\n",
    )
    .unwrap();
    let out = obscura(&["render", "bare.rib", "--spp", "1", "-o", "bare.exr"], &dir);
    assert!(!out.status.success());
    assert!(text(&out).contains("StudioFisheye"), "{}", text(&out));
}

#[test]
fn args_files_describe_the_plugin_give_defaults_and_warn_on_disagreement_or_malformed_xml() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rman-args");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("Args")).unwrap();
    std::fs::copy(dir_of("rman27").join("OdsStereo.so"), dir.join("OdsStereo.so")).unwrap();
    std::fs::write(
        dir.join("Args/OdsStereo.args"),
        r#"<args format="1.0">
  <shaderType><tag value="projection"/></shaderType>
  <param name="eye" label="Eye" type="string" default="right" widget="popup">
    <hintdict name="options"><string name="left" value="left"/><string name="right" value="right"/></hintdict>
    <help>Which eye the camera renders.</help>
  </param>
  <param name="interpupillaryDistance" label="IPD" type="float" default="0.2" min="0" max="1"/>
  <param name="convergence" type="float" default="5"/>
</args>
"#,
    )
    .unwrap();
    let out = obscura(&["--plugin-path", ".", "plugins", "OdsStereo"], &dir);
    let t = text(&out);
    assert!(out.status.success(), "{t}");
    assert!(
        t.contains("string eye: default right, label \"Eye\", options left|right, widget popup"),
        "{t}"
    );
    assert!(t.contains("Which eye the camera renders."), "{t}");
    assert!(
        t.contains("float interpupillaryDistance: default 0.2, label \"IPD\", range [0, 1]"),
        "{t}"
    );
    assert!(
        t.contains("Args/OdsStereo.args:8: parameter \"convergence\" is not in OdsStereo's parameter table"),
        "the disagreement names both: {t}"
    );
    // The defaults reach the plugin where the scene gives none: the right eye, 0.2 apart.
    let cam = CameraDesc::new(Format::new(64, 32));
    let mut reg = builtin_registry();
    ensure(&mut reg, "OdsStereo", &PluginSearch::new(vec![dir.clone()])).unwrap();
    let stage = CameraStage::new(&mut reg, "OdsStereo", &ParamList::new(), &cam).unwrap();
    let mut b = batch(&cam);
    stage.run(&mut b);
    let sw = cam.screen_window();
    for (i, r) in b.rays.iter().enumerate().step_by(97) {
        let u = (2.0 * f64::from(b.screen[i].x) - f64::from(sw.left) - f64::from(sw.right))
            / f64::from(sw.right - sw.left);
        let lon = u * std::f64::consts::PI;
        let want = [0.1 * lon.cos(), 0.0, -0.1 * lon.sin()];
        for k in 0..3 {
            let got = [r.origin.x, r.origin.y, r.origin.z][k];
            assert!(
                (f64::from(got) - want[k]).abs() < 1e-6,
                "sample {i}: origin {:?}, expected {want:?}",
                r.origin
            );
        }
    }
    // A malformed file is a warning naming it; the plugin still loads from its table.
    std::fs::write(
        dir.join("Args/OdsStereo.args"),
        "<args>\n<param name=\"eye\" type=\"string\">\n</args>\n",
    )
    .unwrap();
    let out = obscura(&["--plugin-path", ".", "check", "OdsStereo"], &dir);
    let t = text(&out);
    assert!(out.status.success(), "{t}");
    assert!(t.contains("Args/OdsStereo.args:3: malformed XML"), "{t}");
    assert!(t.contains("OdsStereo loads from its own parameter table"), "{t}");
}

/// The closed form of `PxrPerspective` with field of view `fov_deg`: the unit direction through screen
/// point `s`, `normalize(s.x, s.y, 1/tan(fov/2))`.
fn perspective(s: Point2, fov_deg: f64) -> [f64; 3] {
    let d = 1.0 / (0.5 * fov_deg.to_radians()).tan();
    norm(v3(f64::from(s.x), f64::from(s.y), d))
}

#[test]
fn a_modifier_declared_after_a_builtin_edits_the_builtins_rays_read_from_a_rib() {
    // RenderMan's projection modifiers: the built-in declared first fills the rays, the plugin then
    // rewrites only time and tint; the built-in answers the properties.
    let rib = "Format 64 48 1\nProjection \"PxrPerspective\" \"float fov\" [40]\n\
               Projection \"TimeTint\" \"int strobes\" [3] \"color tint\" [1 0.5 0.25]\n\
               WorldBegin\nWorldEnd\n";
    let scene = obscura_scene::rib::parse_str(rib, "chain.rib", Path::new(".")).unwrap();
    assert_eq!(scene.projection, "TimeTint");
    let (base, base_params) = scene.projection_base.clone().expect("the built-in is kept");
    assert_eq!(base, "PxrPerspective");
    assert!(base_params.get("fov").is_some());
    let cam = &scene.camera;
    for g in GENERATIONS {
        let mut reg = builtin_registry();
        ensure(&mut reg, "TimeTint", &PluginSearch::new(vec![dir_of(g)])).unwrap();
        let stage = CameraStage::chained(
            &mut reg,
            scene.projection_base.as_ref(),
            &scene.projection,
            &scene.projection_params,
            cam,
        )
        .unwrap_or_else(|e| panic!("{g}: {e}"));
        assert_eq!(stage.properties().field_of_view, Some(40.0), "{g}");
        let mut b = batch(cam);
        let canonical = b.time.clone();
        let report = stage.run(&mut b);
        assert_eq!(report.lost(), 0, "{g}");
        assert_eq!(report.violations(), 0, "{g}");
        for (i, r) in b.rays.iter().enumerate() {
            assert_ray(
                &format!("{g}/PxrPerspective+TimeTint"),
                i,
                r,
                perspective(b.screen[i], 40.0),
                [0.0; 3],
            );
            // The default shutter opening leaves canonical time as it is; the plugin strobes it.
            let t = (canonical[i] * 3.0).floor() / 3.0;
            assert_eq!(b.time[i], t, "{g} sample {i}: time");
            assert_eq!(
                (b.tint[i].r, b.tint[i].g, b.tint[i].b),
                (1.0, 0.5, 0.25),
                "{g} sample {i}: tint"
            );
        }
    }
    // Two built-ins, or a plugin first: the last projection wins, as before.
    let rib = "Projection \"PxrPerspective\" \"float fov\" [40]\nProjection \"PxrOrthographic\"\n\
               WorldBegin\nWorldEnd\n";
    let scene = obscura_scene::rib::parse_str(rib, "two.rib", Path::new(".")).unwrap();
    let stage = CameraStage::chained(
        &mut builtin_registry(),
        scene.projection_base.as_ref(),
        &scene.projection,
        &scene.projection_params,
        &scene.camera,
    )
    .unwrap();
    let mut b = batch(&scene.camera);
    stage.run(&mut b);
    assert!(b.rays.iter().all(|r| r.direction == Vec3::new(0.0, 0.0, 1.0)));
    // `obscura render` takes the same path: the plugin found through the RIB's searchpath, chained.
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rman-chain");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let plugins = dir_of("rman27");
    std::fs::write(
        dir.join("chain.rib"),
        format!(
            "Option \"searchpath\" \"string rixplugin\" [\"{}\"]\nFormat 32 24 1\n\
             Projection \"PxrPerspective\" \"float fov\" [40]\nProjection \"TimeTint\" \"int strobes\" [2]\n\
             WorldBegin\nTranslate 0 0 5\nSphere 1 -1 1 360\nWorldEnd\n",
            plugins.display()
        ),
    )
    .unwrap();
    let out = obscura(&["render", "chain.rib", "--spp", "1", "-o", "chain.exr"], &dir);
    assert!(out.status.success(), "{}", text(&out));
    assert!(!text(&out).contains("contract"), "{}", text(&out));
    assert!(dir.join("chain.exr").is_file());
    // A single projection keeps no base.
    let scene = obscura_scene::rib::parse_str(
        "Projection \"TimeTint\"\nWorldBegin\nWorldEnd\n",
        "one.rib",
        Path::new("."),
    )
    .unwrap();
    assert!(scene.projection_base.is_none());
}
