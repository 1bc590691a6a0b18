//! End to end: `obscura stmap` as a user runs it, and `obscura plugins --names`.

use std::process::{Command, Output};

use exr::prelude::{AttributeValue, FlatImage, FlatSamples, Text, read_all_flat_layers_from_file};

mod support;

fn obscura(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_obscura"))
        .args(args)
        .output()
        .expect("the obscura binary runs")
}

fn channel<'a>(image: &'a FlatImage, name: &str) -> &'a [f32] {
    let ch = image.layer_data[0]
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == name);
    match ch.map(|c| &c.sample_data) {
        Some(FlatSamples::F32(v)) => v,
        other => panic!("channel {name}: {other:?}"),
    }
}

fn text_attribute(image: &FlatImage, key: &str) -> Option<String> {
    match image.layer_data[0].attributes.other.get(&Text::from(key)) {
        Some(AttributeValue::Text(t)) => Some(t.to_string()),
        _ => None,
    }
}

/// Screen position of pixel centre (i, j) with the default window of a w×h image.
fn screen(w: u32, h: u32, i: u32, j: u32) -> (f64, f64) {
    let a = w as f64 / h as f64;
    let (l, r, b, t) = if a >= 1.0 {
        (-a, a, -1.0, 1.0)
    } else {
        (-1.0, 1.0, -1.0 / a, 1.0 / a)
    };
    (
        l + (i as f64 + 0.5) / w as f64 * (r - l),
        t - (j as f64 + 0.5) / h as f64 * (t - b),
    )
}

#[test]
fn stmap_exr_holds_the_closed_form_perspective_map() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("map.exr");
    let run = obscura(&[
        "stmap",
        "--from",
        "PxrPerspective",
        "--from-param",
        "float fov=60",
        "--to",
        "PxrPerspective",
        "--to-param",
        "fov=90",
        "--format",
        "48x32",
        "--from-format",
        "96x54",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(stdout.contains("48x32 from 96x54"), "{stdout}");
    let image = read_all_flat_layers_from_file(&out).unwrap();
    let layer = &image.layer_data[0];
    assert_eq!((layer.size.0, layer.size.1), (48, 32));
    let (s, t, b, a) = (
        channel(&image, "R"),
        channel(&image, "G"),
        channel(&image, "B"),
        channel(&image, "A"),
    );
    assert_eq!(
        text_attribute(&image, "obscura:stmapFrom").as_deref(),
        Some("PxrPerspective")
    );
    assert_eq!(
        text_attribute(&image, "obscura:stmapFromFormat").as_deref(),
        Some("96x54")
    );
    // A's screen point is B's times tan 45° / tan 30°; A's window is ±16/9 × ±1.
    let k = 1.0 / 30f64.to_radians().tan();
    let aa = 96.0 / 54.0;
    let (mut inside, mut outside) = (0, 0);
    for j in 0..32 {
        for i in 0..48 {
            let n = (j * 48 + i) as usize;
            let (sx, sy) = screen(48, 32, i, j);
            let (es, et) = ((sx * k + aa) / (2.0 * aa), (sy * k + 1.0) / 2.0);
            assert!((s[n] as f64 - es).abs() < 1e-5, "s at {i},{j}: {} vs {es}", s[n]);
            assert!((t[n] as f64 - et).abs() < 1e-5, "t at {i},{j}: {} vs {et}", t[n]);
            assert_eq!(b[n], 0.0);
            let holds = (0.0..=1.0).contains(&es) && (0.0..=1.0).contains(&et);
            assert_eq!(a[n], if holds { 1.0 } else { 0.0 }, "alpha at {i},{j}");
            if holds {
                inside += 1;
            } else {
                outside += 1;
            }
        }
    }
    assert!(inside > 0 && outside > 0);
}

#[test]
fn the_same_projection_at_another_resolution_maps_pixel_centres_to_themselves() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("identity.exr");
    let run = obscura(&[
        "stmap",
        "--from",
        "PxrPerspective",
        "--to",
        "PxrPerspective",
        "--format",
        "40x30",
        "--from-format",
        "160x120",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let image = read_all_flat_layers_from_file(&out).unwrap();
    let (s, t, a) = (channel(&image, "R"), channel(&image, "G"), channel(&image, "A"));
    for j in 0..30u32 {
        for i in 0..40u32 {
            let n = (j * 40 + i) as usize;
            let (es, et) = ((i as f64 + 0.5) / 40.0, 1.0 - (j as f64 + 0.5) / 30.0);
            assert!(
                (s[n] as f64 - es).abs() < 1e-5 && (t[n] as f64 - et).abs() < 1e-5,
                "{i},{j}"
            );
            assert_eq!(a[n], 1.0);
        }
    }
}

#[test]
fn bad_requests_are_clear_errors_and_leave_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("never.exr");
    let o = out.to_str().unwrap();
    for (args, needle) in [
        (
            vec![
                "stmap",
                "--from",
                "PxrPerspectve",
                "--to",
                "PxrPerspective",
                "-o",
                o,
            ],
            "--from PxrPerspectve: unknown projection \"PxrPerspectve\" (did you mean \"PxrPerspective\"?)",
        ),
        (
            vec!["stmap", "--from", "PxrPerspective", "--to", "Nope", "-o", o],
            "--to Nope: unknown projection",
        ),
        (
            vec![
                "stmap",
                "--from",
                "PxrPerspective",
                "--from-param",
                "fvo=60",
                "--to",
                "PxrPerspective",
                "-o",
                o,
            ],
            "did you mean \"fov\"",
        ),
        (
            vec![
                "stmap",
                "--from",
                "PxrPerspective",
                "--to",
                "PxrPerspective",
                "--to-param",
                "fov=500",
                "-o",
                o,
            ],
            "--to PxrPerspective: PxrPerspective: parameter \"fov\"",
        ),
        (
            vec![
                "stmap",
                "--from",
                "PxrPerspective",
                "--to",
                "PxrPerspective",
                "--distance",
                "-1",
                "-o",
                o,
            ],
            "--distance -1: expected a positive finite distance",
        ),
        (
            vec![
                "stmap",
                "--from",
                "PxrPerspective",
                "--to",
                "PxrPerspective",
                "--format",
                "0x10",
                "-o",
                o,
            ],
            "expected WIDTHxHEIGHT",
        ),
    ] {
        let run = obscura(&args);
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{args:?} succeeded");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!out.exists());
    }
    let run = obscura(&[
        "stmap",
        "--from",
        "PxrPerspective",
        "--to",
        "PxrPerspective",
        "--format",
        "8x8",
        "-o",
        "/nonexistent-dir/map.exr",
    ]);
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("cannot write /nonexistent-dir/map.exr"));
}

#[test]
fn plugins_names_lists_every_registered_projection_one_per_line() {
    let run = obscura(&["plugins", "--names"]);
    assert!(run.status.success());
    let listed: Vec<String> = String::from_utf8_lossy(&run.stdout)
        .lines()
        .map(str::to_string)
        .collect();
    assert_eq!(listed, obscura_projections::builtin_registry().names());
}

/// Reads an identity map with OpenEXR's own library through its Python binding (CI installs it and
/// sets OBSCURA_REQUIRE_INDEPENDENT_EXR=1, so there a missing reader is a failure, not a skip).
#[test]
fn an_independent_reader_sees_nukes_convention() {
    if !support::python_has("OpenEXR, numpy", "OBSCURA_REQUIRE_INDEPENDENT_EXR") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("identity.exr");
    let run = obscura(&[
        "stmap",
        "--from",
        "PxrOrthographic",
        "--to",
        "PxrOrthographic",
        "--format",
        "24x12",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    // Nuke: s = (i + ½)/W from the left, t = (row-from-the-bottom + ½)/H; the file's first row is the top.
    let script = r#"
import sys, numpy as np, OpenEXR
ch = OpenEXR.File(sys.argv[1], separate_channels=True).parts[0].channels
s, t, a = ch["R"].pixels, ch["G"].pixels, ch["A"].pixels
h, w = s.shape
i, j = np.meshgrid(np.arange(w), np.arange(h))
ok = (np.abs(s - (i + 0.5) / w).max() < 1e-6 and np.abs(t - (h - j - 0.5) / h).max() < 1e-6
      and (a == 1).all() and (ch["B"].pixels == 0).all() and (w, h) == (24, 12))
print("ok" if ok else f"mismatch: s {s[0, :3]} t {t[:3, 0]}")
sys.exit(0 if ok else 1)
"#;
    let r = Command::new("python3")
        .args(["-c", script, out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        r.status.success(),
        "independent reader: {}{}",
        String::from_utf8_lossy(&r.stdout),
        String::from_utf8_lossy(&r.stderr)
    );
}
