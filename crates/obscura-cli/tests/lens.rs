//! End to end: `obscura lens` prints a prescription's figures, as text and as JSON other tools read,
//! draws it, and `obscura check LensSystem` is clean.

mod support;

use support::{obscura, text};

fn json(args: &[&str]) -> serde_json::Value {
    let run = obscura(args);
    assert_eq!(run.status.code(), Some(0), "{}", text(&run.stderr));
    serde_json::from_str(&text(&run.stdout)).unwrap()
}

#[test]
fn lens_json_holds_the_paraxial_figures_under_their_keys() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/lenses/dgauss.50mm.dat");
    let v = json(&["lens", file, "--json"]);
    let f = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} in {v}"));
    // The figure: the double Gauss's paraxial EFL is 50.36 mm.
    assert!((f("efl_mm") - 50.36).abs() < 0.01, "{v}");
    assert!(f("bfl_mm") > 30.0 && f("bfl_mm") < 40.0, "{v}");
    assert!(f("f_number") > 1.9 && f("f_number") < 2.2, "{v}");
    // 35 mm diagonal at 50 mm: 2·atan(17.5/50) ≈ 38.6° paraxially, a little more with its distortion.
    assert!((f("fov_deg") - 38.6).abs() < 1.0, "{v}");
    for key in ["entrance_pupil_mm", "exit_pupil_mm"] {
        assert!(
            v[key]["position"].is_f64() && v[key]["diameter"].as_f64().unwrap() > 0.0,
            "{v}"
        );
    }
    assert!(v["ffl_mm"].is_f64());
    let tele = json(&["lens", "telephoto.250mm.dat", "--json"]);
    assert!((tele["efl_mm"].as_f64().unwrap() - 250.0).abs() < 2.5, "{tele}");
}

#[test]
fn the_shipped_patent_asphere_has_its_sources_figures() {
    // US 2007/0236805 A1, Example 4: f = 99.80 mm, back focus 40.123 mm, angle of view 17.81° over a
    // 31.14 mm image diagonal (the traced chief ray's, with the lens's own −0.3 % distortion).
    let v = json(&["lens", "masterprime.100mm", "--json", "--film-diagonal", "31.14"]);
    let f = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} in {v}"));
    assert!((f("efl_mm") - 99.80).abs() < 0.01, "{v}");
    assert!((f("bfl_mm") - 40.123).abs() < 0.005, "{v}");
    assert!((f("fov_deg") - 17.81).abs() < 0.05, "{v}");
    assert!((f("f_number") - 1.24).abs() < 0.025, "{v}");
}

#[test]
fn the_shipped_patent_fisheye_has_its_sources_figures() {
    // US 4,256,373 scaled ×16: f = 1.0 → 16 mm, F/2.8, a 180° field whose image circle is about the
    // 24 × 36 mm frame's diagonal, so across that diagonal the traced field is a little under 180°.
    let v = json(&["lens", "fisheye.16mm", "--json", "--film-diagonal", "43.27"]);
    let f = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} in {v}"));
    assert!((f("efl_mm") - 16.0).abs() < 0.005 * 16.0, "{v}");
    assert!((f("f_number") - 2.8).abs() < 0.01 * 2.8, "{v}");
    assert!(f("fov_deg") > 0.97 * 180.0 && f("fov_deg") < 180.0, "{v}");
    // On the 44 mm circle of its full field it sees 180°.
    let v = json(&["lens", "fisheye.16mm", "--json", "--film-diagonal", "43.9"]);
    assert!(
        (v["fov_deg"].as_f64().unwrap() - 180.0).abs() < 0.01 * 180.0,
        "{v}"
    );
}

#[test]
fn lens_draws_svg_and_png_and_refuses_other_extensions() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["d.svg", "d.png"] {
        let path = dir.path().join(name);
        let run = obscura(&["lens", "fisheye.10mm", "--diagram", path.to_str().unwrap()]);
        assert_eq!(run.status.code(), Some(0), "{}", text(&run.stderr));
        let bytes = std::fs::read(&path).unwrap();
        assert!(bytes.len() > 1000);
        if name.ends_with(".svg") {
            assert!(text(&bytes).contains("<polyline"));
        } else {
            assert_eq!(&bytes[1..4], b"PNG");
        }
    }
    let run = obscura(&["lens", "dgauss.50mm", "--diagram", "x.gif"]);
    assert_ne!(run.status.code(), Some(0));
    assert!(
        text(&run.stderr).contains(".svg or .png"),
        "{}",
        text(&run.stderr)
    );
    let run = obscura(&["lens", "no-such-lens.dat"]);
    assert!(
        text(&run.stderr).contains("no-such-lens.dat"),
        "{}",
        text(&run.stderr)
    );
}

#[test]
fn check_lens_system_is_clean() {
    for lens in ["dgauss.50mm", "fisheye.10mm", "fisheye.16mm", "masterprime.100mm"] {
        let param = format!("lens={lens}");
        let run = obscura(&["check", "LensSystem", "--param", &param, "--format", "48x32"]);
        let out = text(&run.stdout);
        assert_eq!(run.status.code(), Some(0), "{out}\n{}", text(&run.stderr));
        assert!(out.trim_end().ends_with("clean: no check failed"), "{out}");
    }
}
