//! End to end: projection plugins loaded from shared libraries by `obscura render`, `obscura rays`
//! and `obscura plugins`, found through `--plugin-path` and `OBSCURA_PLUGIN_PATH`.
//!
//! The Rust example (`TinyPlanet`, crates/obscura-example-tiny-planet) and the deliberately panicking
//! Rust plugin are built once with cargo into `target/plugin-tests`; the C example
//! (`CFisheye`, examples/plugins/c-fisheye/fisheye.c) is compiled with the system C compiler (`$CC`,
//! else `cc`).

use std::path::Path;
use std::process::{Command, Output};

use exr::prelude::read_all_flat_layers_from_file;

#[path = "../../obscura-plugins/tests/support/plugin_build.rs"]
mod plugin_build;

use plugin_build::{compile_c_fisheye, copy_rust_plugin, lib_name};

mod support;

use support::screen;

/// A directory holding `TinyPlanet.so`, `Panicking.so` and `CFisheye.so`.
fn plugin_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    copy_rust_plugin("obscura_example_tiny_planet", dir.path(), "TinyPlanet");
    copy_rust_plugin("obscura_test_panicking_plugin", dir.path(), "Panicking");
    compile_c_fisheye(dir.path());
    dir
}

fn obscura(args: &[&str], dir: &Path, plugin_path_env: Option<&Path>) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_obscura"));
    cmd.args(args).current_dir(dir).env_remove("OBSCURA_PLUGIN_PATH");
    if let Some(p) = plugin_path_env {
        cmd.env("OBSCURA_PLUGIN_PATH", p);
    }
    cmd.output().expect("the obscura binary runs")
}

fn channel(image: &exr::prelude::FlatImage, name: &str) -> Vec<f32> {
    image.layer_data[0]
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == name)
        .map(|c| c.sample_data.values_as_f32().collect())
        .unwrap_or_else(|| panic!("no channel {name}"))
}

/// Reads the chief-ray directions of `obscura rays`.
fn directions(path: &Path) -> Vec<[f32; 3]> {
    let image = read_all_flat_layers_from_file(path).unwrap();
    let (x, y, z) = (
        channel(&image, "direction.X"),
        channel(&image, "direction.Y"),
        channel(&image, "direction.Z"),
    );
    (0..x.len()).map(|i| [x[i], y[i], z[i]]).collect()
}

#[test]
fn both_example_plugins_render_through_obscura_render() {
    let plugins = plugin_dir();
    let work = tempfile::tempdir().unwrap();
    let pp = plugins.path().to_str().unwrap();
    for (name, format) in [("TinyPlanet", "32x18"), ("CFisheye", "24x24")] {
        let out = format!("{name}.exr");
        let r = obscura(
            &[
                "render",
                "--plugin-path",
                pp,
                "-p",
                name,
                "--format",
                format,
                "--spp",
                "2",
                "--threads",
                "2",
                "-o",
                &out,
            ],
            work.path(),
            None,
        );
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.success(), "{name}: {stderr}");
        assert!(
            !stderr.contains("broke the projection contract"),
            "{name}: {stderr}"
        );
        let stdout = String::from_utf8_lossy(&r.stdout);
        assert!(stdout.contains(&format!("through {name}")), "{stdout}");
        let image = read_all_flat_layers_from_file(work.path().join(&out)).unwrap();
        let (red, green) = (channel(&image, "R"), channel(&image, "G"));
        assert!(red.iter().chain(&green).all(|v| v.is_finite()));
        assert!(red.iter().any(|v| *v > 0.0), "{name} rendered black");
        if name == "CFisheye" {
            // The corners lie outside the image circle: every sample culled, the pixel black.
            for i in [0, 23, 24 * 23, 24 * 24 - 1] {
                assert_eq!((red[i], channel(&image, "A")[i]), (0.0, 0.0), "corner {i}");
            }
            assert!(red[12 * 24 + 12] > 0.0);
        } else {
            assert!(
                stdout.contains(" 0 culled"),
                "the stereographic sphere has no edge: {stdout}"
            );
        }
    }
}

#[test]
fn tiny_planet_rays_match_the_stereographic_formula() {
    let plugins = plugin_dir();
    let work = tempfile::tempdir().unwrap();
    let r = obscura(
        &[
            "rays",
            "-p",
            "TinyPlanet",
            "--format",
            "40x30",
            "--param",
            "fov=200",
            "-o",
            "planet.exr",
        ],
        work.path(),
        Some(plugins.path()),
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let d = directions(&work.path().join("planet.exr"));
    let k = (200f64.to_radians() / 4.0).tan();
    for y in 0..30 {
        for x in 0..40 {
            let (sx, sy) = screen(40, 30, x, y);
            let theta = 2.0 * (sx.hypot(sy) * k).atan();
            let psi = sy.atan2(sx);
            // Straight down at the centre; screen x is camera +X, screen y camera +Z.
            let want = [theta.sin() * psi.cos(), -theta.cos(), theta.sin() * psi.sin()];
            let got = d[(y * 40 + x) as usize];
            for c in 0..3 {
                assert!(
                    (f64::from(got[c]) - want[c]).abs() < 1e-5,
                    "({x}, {y}): {got:?} vs {want:?}"
                );
            }
        }
    }
}

#[test]
fn the_c_fisheye_gives_the_builtin_fisheyes_rays() {
    let plugins = plugin_dir();
    let work = tempfile::tempdir().unwrap();
    let pp = plugins.path().to_str().unwrap();
    let common = ["--format", "33x33", "--param", "fov=190"];
    let r = obscura(
        &[
            &["rays", "--plugin-path", pp, "-p", "CFisheye", "-o", "c.exr"][..],
            &common[..],
        ]
        .concat(),
        work.path(),
        None,
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let r = obscura(
        &[
            &[
                "rays",
                "-p",
                "Fisheye",
                "--param",
                "mapping=equidistant",
                "-o",
                "builtin.exr",
            ][..],
            &common[..],
        ]
        .concat(),
        work.path(),
        None,
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let (c, b) = (
        directions(&work.path().join("c.exr")),
        directions(&work.path().join("builtin.exr")),
    );
    let mut inside = 0;
    for y in 0..33 {
        for x in 0..33 {
            let i = (y * 33 + x) as usize;
            let (sx, sy) = screen(33, 33, x, y);
            let r = sx.hypot(sy);
            if r > 1.0 {
                assert_eq!(c[i], [0.0; 3], "({x}, {y}) is outside the circle");
                assert_eq!(b[i], [0.0; 3]);
                continue;
            }
            inside += 1;
            let phi = r * 95f64.to_radians();
            let psi = sy.atan2(sx);
            let want = [phi.sin() * psi.cos(), phi.sin() * psi.sin(), phi.cos()];
            for k in 0..3 {
                assert!(
                    (f64::from(c[i][k]) - want[k]).abs() < 2e-6,
                    "({x}, {y}): {:?} vs {want:?}",
                    c[i]
                );
                assert!(
                    (c[i][k] - b[i][k]).abs() < 2e-6,
                    "({x}, {y}): {:?} vs built-in {:?}",
                    c[i],
                    b[i]
                );
            }
        }
    }
    assert!(inside > 800);
}

#[test]
fn a_scene_naming_a_plugin_finds_it_on_the_plugin_path() {
    let plugins = plugin_dir();
    let work = tempfile::tempdir().unwrap();
    std::fs::write(
        work.path().join("fish.rib"),
        "Format 16 16 1\nHider \"raytrace\" \"int maxsamples\" [1]\nDisplay \"fish.exr\" \"openexr\" \"rgba\"\n\
         Projection \"CFisheye\" \"float fov\" [180]\nTranslate 0 0 3\nWorldBegin\n\
         Light \"PxrDomeLight\" \"dome\" \"float intensity\" [1]\n\
         Polygon \"P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0]\nWorldEnd\n",
    )
    .unwrap();
    let r = obscura(
        &["render", "fish.rib", "--quiet"],
        work.path(),
        Some(plugins.path()),
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(work.path().join("fish.exr").exists());
    // Without the plugin path the scene's projection is unknown, and the error says where it looked.
    let r = obscura(&["render", "fish.rib", "--quiet"], work.path(), None);
    assert!(!r.status.success());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(err.contains("unknown projection \"CFisheye\""), "{err}");
    assert!(
        err.contains("set OBSCURA_PLUGIN_PATH or pass --plugin-path"),
        "{err}"
    );
}

#[test]
fn a_panicking_plugin_loses_batches_and_the_render_goes_on() {
    let plugins = plugin_dir();
    let work = tempfile::tempdir().unwrap();
    let r = obscura(
        &[
            "render",
            "-p",
            "Panicking",
            "--param",
            "panicAbove=0.9",
            "--format",
            "32x18",
            "--spp",
            "1",
            "-o",
            "p.exr",
        ],
        work.path(),
        Some(plugins.path()),
    );
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{err}");
    assert!(
        err.contains("warning: projection Panicking broke the projection contract on"),
        "{err}"
    );
    assert!(err.contains("samples lost to a panic in project"), "{err}");
    assert!(err.contains("panicked: deliberate panic at screen x"), "{err}");
    assert!(work.path().join("p.exr").exists());
}

#[test]
fn a_panicking_inverse_loses_pixels_of_an_stmap_and_the_map_is_written() {
    // Panicking's unproject panics right of screen x = panicAbove (0.45): those pixels of the map stay empty
    // (alpha 0), the warning counts them and quotes the panic, and the file is still written.
    let plugins = plugin_dir();
    let work = tempfile::tempdir().unwrap();
    let r = obscura(
        &[
            "stmap",
            "--from",
            "Panicking",
            "--from-param",
            "panicAbove=0.45",
            "--to",
            "PxrPerspective",
            "--format",
            "32x18",
            "-o",
            "m.exr",
        ],
        work.path(),
        Some(plugins.path()),
    );
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{err}");
    let line = err
        .lines()
        .find(|l| l.starts_with("warning: Panicking: unproject failed at "))
        .unwrap_or_else(|| panic!("no unproject warning in {err}"));
    // PxrPerspective's default 90° pinhole on a 16:9 frame spans screen x in [-16/9, 16/9]: column i
    // sits at x = (i + ½ − 16)/9, right of 0.45 from i = 20 (x = 0.5; i = 19 is at 0.39): 12 columns
    // of 18 rows.
    assert!(line.contains("at 216 pixels"), "{line}");
    // unproject has no error sink: the status says what happened, the plugin's panic hook said why.
    assert!(line.contains("status 3 (OBSCURA_PANIC"), "{line}");
    assert!(err.contains("deliberate panic in unproject at screen x"), "{err}");
    assert!(work.path().join("m.exr").exists());
}

#[test]
fn plugins_lists_every_library_on_the_plugin_path_and_warns_about_broken_ones() {
    let plugins = plugin_dir();
    let work = tempfile::tempdir().unwrap();
    // Not a library at all: a warning naming it, and the others are still listed.
    let bad = work.path().join(lib_name("NotALibrary"));
    std::fs::write(&bad, "not an ELF file").unwrap();
    // A plugin under another file name could only be used by path: refused, with the name to give it.
    let renamed = work.path().join(lib_name("planet_v2"));
    std::fs::copy(plugins.path().join(lib_name("TinyPlanet")), &renamed).unwrap();
    let dirs = format!("{}:{}", plugins.path().display(), work.path().display());
    let builtins = obscura_plugins::builtin_registry().names();
    let r = obscura(&["plugins", "--names"], work.path(), Some(Path::new(&dirs)));
    assert!(r.status.success());
    let names: Vec<String> = String::from_utf8_lossy(&r.stdout)
        .lines()
        .map(str::to_string)
        .collect();
    let mut want = builtins.clone();
    want.extend(["CFisheye", "Panicking", "TinyPlanet"].map(String::from));
    want.sort();
    assert_eq!(names, want);
    let err = String::from_utf8_lossy(&r.stderr);
    let warnings: Vec<&str> = err.lines().collect();
    assert_eq!(warnings.len(), 2, "{err}");
    assert!(
        warnings[0].starts_with(&format!("warning: {}: ", bad.display())),
        "{err}"
    );
    assert!(
        warnings[1].starts_with(&format!("warning: {}: ", renamed.display()))
            && warnings[1].contains("this library is projection \"TinyPlanet\", not \"planet_v2\""),
        "{err}"
    );
    // The full listing: every table, each plugin with the file it came from, built-ins without.
    let r = obscura(&["plugins"], work.path(), Some(Path::new(&dirs)));
    let out = String::from_utf8_lossy(&r.stdout);
    for name in ["CFisheye", "Panicking", "TinyPlanet"] {
        let file = plugins.path().join(lib_name(name));
        assert!(
            out.contains(&format!("    plugin: {}\n", file.display())),
            "{name}: {out}"
        );
    }
    assert_eq!(out.matches("    plugin: ").count(), 3, "{out}");
    assert!(
        out.contains("PxrPerspective\n") && out.contains("\"float fov\""),
        "{out}"
    );
}

#[test]
fn plugins_lists_a_loaded_plugins_table_and_refuses_unknown_names_clearly() {
    let plugins = plugin_dir();
    let work = tempfile::tempdir().unwrap();
    let pp = plugins.path().to_str().unwrap();
    let r = obscura(&["plugins", "--plugin-path", pp, "TinyPlanet"], work.path(), None);
    let out = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(
        out.contains("TinyPlanet") && out.contains("fov") && out.contains("axis"),
        "{out}"
    );
    // A path works as well as a name.
    let path = plugins.path().join(lib_name("CFisheye"));
    let r = obscura(&["plugins", path.to_str().unwrap()], work.path(), None);
    assert!(String::from_utf8_lossy(&r.stdout).contains("CFisheye"));
    let r = obscura(&["plugins", "--plugin-path", pp, "TinyPlant"], work.path(), None);
    assert!(!r.status.success());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.contains("no TinyPlant.") && err.contains(&format!("looked in {pp}")),
        "{err}"
    );
}
