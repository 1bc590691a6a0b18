//! End to end: `obscura check` on plugin libraries, as a plugin author runs it before shipping.
//!
//! The example plugins (the C fisheye `CFisheye` and the Rust `TinyPlanet`) and the correct build of
//! `ContractPinhole` (tests/plugins/contract_broken.c, a pinhole camera in C) must pass, by path and by
//! name along `--plugin-path`. Then `ContractPinhole` is compiled once per deliberate breach of the
//! contract, one `-D DEFECT_*` switch for each [`CheckKind`], and each build must fail `obscura check`
//! with exactly its own check failed (the checker promises that a fault is reported once, by its own
//! check). Two breaches the host's adapter raises at the ABI boundary (a property value of an unknown
//! kind, a property call that fails) must fail `property_type` and `panic` respectively, and a render
//! through the latter goes on with a warning.
//!
//! The JSON report is read with a small extractor over its fixed layout (`{"check":"<id>","title":..,
//! "status":..,..,"failures":n,..}`): a raw `{"check":"` cannot occur inside a JSON string, where every
//! `"` is escaped, so splitting on it finds exactly the checks.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use obscura_check::CheckKind;

#[path = "../../obscura-plugins/tests/support/plugin_build.rs"]
mod plugin_build;

use plugin_build::{compile_c, compile_c_fisheye, copy_rust_plugin, workspace};

/// A small, quick check: 32 × 24 pixels plus the margin, one random sample per pixel, two threads.
const QUICK: [&str; 6] = ["--format", "32x24", "--samples", "1", "--threads", "2"];

/// The C source of `ContractPinhole`.
fn source() -> PathBuf {
    workspace().join("crates/obscura-cli/tests/plugins/contract_broken.c")
}

/// `ContractPinhole` compiled with `defect` (none: the correct camera) into `<dir>/<name>.so`, with
/// warnings as errors so every variant is clean C.
fn pinhole(dir: &Path, name: &str, defect: Option<&str>) -> PathBuf {
    let defines: Vec<&str> = defect.into_iter().collect();
    compile_c(&source(), &defines, dir, name, true)
}

fn obscura(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_obscura"))
        .args(args)
        .env_remove("OBSCURA_PLUGIN_PATH")
        .output()
        .expect("the obscura binary runs")
}

/// `obscura check <what> --json` with the quick options and `extra`.
fn check_json(what: &str, extra: &[&str]) -> Output {
    obscura(&[&["check", what, "--json"][..], &QUICK[..], extra].concat())
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// One check's entry in the JSON report.
#[derive(Debug)]
struct Entry {
    id: String,
    status: String,
    examined: u64,
    failures: u64,
    /// The entry's JSON text, from its `"title"` to the next entry (notes and worst case included).
    json: String,
}

impl Entry {
    /// The raw JSON value after `"key":` in this entry (a number, `null`, or a string with its quotes).
    fn raw(&self, key: &str) -> Option<&str> {
        let start = self.json.find(&format!("\"{key}\":"))? + key.len() + 3;
        let rest = &self.json[start..];
        let end = if let Some(body) = rest.strip_prefix('"') {
            // A string: up to the first quote not escaped.
            let mut esc = false;
            let close = body.char_indices().find(|&(_, c)| {
                let is_end = !esc && c == '"';
                esc = !esc && c == '\\';
                is_end
            })?;
            close.0 + 2
        } else {
            rest.find([',', '}', ']'])?
        };
        Some(&rest[..end])
    }

    fn number(&self, key: &str) -> Option<f64> {
        self.raw(key)?.parse().ok()
    }

    /// The worst case's screen position.
    fn worst_screen(&self) -> Option<(f64, f64)> {
        let start = self.json.find("\"screen\":[")? + 10;
        let rest = &self.json[start..];
        let (x, y) = rest[..rest.find(']')?].split_once(',')?;
        Some((x.parse().ok()?, y.parse().ok()?))
    }
}

/// The `checks` of a JSON report, in order.
fn entries(json: &str) -> Vec<Entry> {
    let at = json
        .find("\"checks\":[")
        .unwrap_or_else(|| panic!("no checks in {json}"));
    json[at..]
        .split("{\"check\":\"")
        .skip(1)
        .map(|piece| {
            let (id, rest) = piece.split_once('"').expect("a check id");
            let mut e = Entry {
                id: id.to_string(),
                status: String::new(),
                examined: 0,
                failures: 0,
                json: rest.to_string(),
            };
            e.status = e
                .raw("status")
                .unwrap_or_else(|| panic!("no status in {piece}"))
                .trim_matches('"')
                .to_string();
            e.examined = e.number("examined").expect("examined") as u64;
            e.failures = e.number("failures").expect("failures") as u64;
            e
        })
        .collect()
}

/// The entries, checked to be one per [`CheckKind`] in report order.
fn report(json: &str) -> Vec<Entry> {
    let e = entries(json);
    let ids: Vec<&str> = e.iter().map(|e| e.id.as_str()).collect();
    let want: Vec<&str> = CheckKind::ALL.iter().map(|k| k.id()).collect();
    assert_eq!(ids, want, "{json}");
    e
}

fn get(entries: &[Entry], kind: CheckKind) -> &Entry {
    entries.iter().find(|e| e.id == kind.id()).unwrap()
}

/// Asserts a clean pass: exit code 0, `"clean":true`, no check failed.
fn assert_passes(run: &Output, what: &str) -> Vec<Entry> {
    let (out, err) = (text(&run.stdout), text(&run.stderr));
    assert_eq!(run.status.code(), Some(0), "{what}: {err}\n{out}");
    assert!(out.contains("\"clean\":true"), "{what}: {out}");
    let e = report(&out);
    for c in &e {
        assert_ne!(c.status, "failed", "{what}: {}: {out}", c.id);
    }
    assert!(err.is_empty(), "{what}: {err}");
    e
}

#[test]
fn the_example_plugins_and_the_correct_pinhole_pass_by_path_and_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let plugins = [
        ("CFisheye", compile_c_fisheye(dir.path())),
        (
            "TinyPlanet",
            copy_rust_plugin("obscura_example_tiny_planet", dir.path(), "TinyPlanet"),
        ),
        ("ContractPinhole", pinhole(dir.path(), "ContractPinhole", None)),
    ];
    let pp = dir.path().to_str().unwrap();
    for (name, path) in &plugins {
        let by_path = check_json(path.to_str().unwrap(), &[]);
        let e = assert_passes(&by_path, name);
        assert!(
            text(&by_path.stdout).starts_with(&format!("{{\"projection\":\"{name}\",")),
            "{name}"
        );
        let by_name = check_json(name, &["--plugin-path", pp]);
        assert_passes(&by_name, name);
        // The same plugin, the same samples: the same report.
        assert_eq!(text(&by_path.stdout), text(&by_name.stdout), "{name}");
        if *name == "ContractPinhole" {
            // Every check had something to examine: the camera answers every property it is checked
            // against and offers unproject.
            for c in &e {
                assert_eq!(c.status, "ok", "{}: {}", c.id, text(&by_path.stdout));
            }
        }
    }
    // The plain-text form ends with the verdict; parameters reach the plugin.
    let run = obscura(
        &[
            &[
                "check",
                "ContractPinhole",
                "--plugin-path",
                pp,
                "--param",
                "fov=60",
            ][..],
            &QUICK[..],
        ]
        .concat(),
    );
    let out = text(&run.stdout);
    assert_eq!(run.status.code(), Some(0), "{out}{}", text(&run.stderr));
    assert!(out.contains("k_FieldOfView 60,"), "{out}");
    assert!(out.trim_end().ends_with("clean: no check failed"), "{out}");
}

/// One deliberate breach: the `-D` switch, the check that must catch it, and what the worst case must
/// say (a substring of its JSON).
struct Defect {
    define: &'static str,
    kind: CheckKind,
    worst: &'static str,
}

/// One breach per check, in [`CheckKind::ALL`] order.
const DEFECTS: [Defect; 18] = [
    Defect {
        define: "DEFECT_PROJECT_PANIC",
        kind: CheckKind::Panic,
        worst: "\"what\":\"project\",\"expected\":\"no panic\",\"got\":\"panicked: \
                ContractPinhole: deliberate exception in the top-right corner\"",
    },
    Defect {
        define: "DEFECT_PROJECT_ERROR",
        kind: CheckKind::Error,
        worst: "\"what\":\"project\",\"expected\":\"no error\",\"got\":\"returned an error: \
                ContractPinhole: deliberate failure in the top-right corner\"",
    },
    Defect {
        define: "DEFECT_NAN_DIRECTION",
        kind: CheckKind::DirectionFinite,
        worst: "\"got\":\"(NaN, ",
    },
    Defect {
        define: "DEFECT_LONG_DIRECTION",
        kind: CheckKind::DirectionUnit,
        worst: "\"what\":\"|direction|\"",
    },
    Defect {
        define: "DEFECT_INFINITE_ORIGIN",
        kind: CheckKind::OriginFinite,
        worst: "\"got\":\"(0, 0, inf)\"",
    },
    Defect {
        define: "DEFECT_TIME_ONE",
        kind: CheckKind::TimeRange,
        worst: "\"what\":\"time\",\"expected\":\"a time in [0, 1)\",\"got\":\"1\"",
    },
    Defect {
        define: "DEFECT_NEGATIVE_SPREAD",
        kind: CheckKind::RadiusSpread,
        worst: "\"what\":\"ray_spread\",\"expected\":\"a finite value >= 0\",\"got\":\"-",
    },
    Defect {
        define: "DEFECT_CLIP_INVERTED",
        kind: CheckKind::Distances,
        worst: "\"what\":\"min_dist, max_dist\"",
    },
    Defect {
        define: "DEFECT_NAN_TINT",
        kind: CheckKind::TintFinite,
        worst: "\"got\":\"(1, NaN, 1)\"",
    },
    Defect {
        define: "DEFECT_CLIP_SPHERES",
        kind: CheckKind::Clipping,
        worst: "\"what\":\"min_dist with CameraZ\",\"expected\":\"",
    },
    Defect {
        define: "DEFECT_DOUBLE_SPREAD",
        kind: CheckKind::RaySpread,
        worst: "\"what\":\"ray_spread of the chief ray\"",
    },
    Defect {
        define: "DEFECT_WRONG_FOV",
        kind: CheckKind::FieldOfView,
        worst: "\"got\":\"95°\"",
    },
    Defect {
        define: "DEFECT_BACKWARD",
        kind: CheckKind::DeepMetric,
        worst: "\"what\":\"direction.z with CameraZ from the DeepMetric property\"",
    },
    Defect {
        define: "DEFECT_MOVING_ORIGINS",
        kind: CheckKind::DicingHint,
        worst: "\"what\":\"origin of the lens-centre ray (DicingHint Perspective)\"",
    },
    Defect {
        define: "DEFECT_WRONG_UNPROJECT",
        kind: CheckKind::Unproject,
        worst: "\"what\":\"unproject(O + D·",
    },
    Defect {
        define: "DEFECT_COUNTER",
        kind: CheckKind::Determinism,
        worst: "\"what\":\"ray_spread on the second run\"",
    },
    Defect {
        define: "DEFECT_THREAD_DEPENDENT",
        kind: CheckKind::Threads,
        worst: "\"what\":\"ray_spread on thread ",
    },
    Defect {
        define: "DEFECT_PROPERTY_TYPE",
        kind: CheckKind::PropertyType,
        worst: "\"what\":\"k_FieldOfView\",\"expected\":\"PropertyValue::Float or None\",\
                \"got\":\"DicingHint(Perspective)\"",
    },
];

/// What a defect's failure must show beyond its worst case's text, measured against the defect's
/// own size: `Err` says what is wrong.
fn measure(d: &Defect, c: &Entry, all: &[Entry]) -> Result<(), String> {
    let sev = c.number("severity");
    let near = |want: f64, tol: f64| match sev {
        Some(s) if (s - want).abs() <= tol => Ok(()),
        _ => Err(format!("severity {sev:?}, expected {want} ± {tol}")),
    };
    match d.kind {
        // |D| = 1.01 exactly (up to f32 rounding).
        CheckKind::DirectionUnit => near(0.01, 1e-4),
        // Every pixel's spread is twice half the neighbour angle: +100 %.
        CheckKind::RaySpread if c.failures != c.examined => {
            Err(format!("{} of {} pixels failed", c.failures, c.examined))
        }
        CheckKind::RaySpread => near(1.0, 0.01),
        // min_dist = near where near/D.z is due: off by 1 − D.z, D.z = 1/sqrt(x² + y² + 1) at 90°.
        CheckKind::Clipping => {
            let (x, y) = c.worst_screen().ok_or("no worst screen position")?;
            near(1.0 - 1.0 / (x * x + y * y + 1.0).sqrt(), 1e-5)
        }
        // The answer is fov + 5 for a measured 90°.
        CheckKind::FieldOfView => near(5.0, 0.01),
        // Every ray looks down −Z.
        CheckKind::DeepMetric if c.failures != c.examined => {
            Err(format!("{} of {} rays failed", c.failures, c.examined))
        }
        // x scaled by 1.01: an error of 0.01·|x| screen units, in pixels of 1/12 screen unit.
        CheckKind::Unproject => {
            let (x, _) = c.worst_screen().ok_or("no worst screen position")?;
            near(0.12 * x.abs(), 1e-3)
        }
        // Every run differs from the one before, so the thread check has no stable sample to compare
        // and says so instead of failing.
        CheckKind::Determinism => {
            let t = get(all, CheckKind::Threads);
            if t.status == "not_checked" && t.json.contains("already differ between two sequential runs") {
                Ok(())
            } else {
                Err(format!("threads entry: {} {}", t.status, t.json))
            }
        }
        _ => Ok(()),
    }
}

/// What is wrong with the run of one broken build (empty when it failed exactly as it should).
fn verdict(d: &Defect, run: &Output, out: &str, err: &str) -> Vec<String> {
    let id = d.kind.id();
    // 1: the plugin ran and broke the contract (2 would mean the check could not run at all).
    if run.status.code() != Some(1) {
        return vec![format!("exit code {:?}, expected 1", run.status.code())];
    }
    let mut why = Vec::new();
    // The command's own summary names exactly the one check.
    let summary = format!("broke the projection contract: 1 check failed ({id})");
    if !err.contains(&summary) {
        why.push(format!("stderr lacks {summary:?}"));
    }
    if !out.contains("\"clean\":false") {
        why.push("not \"clean\":false".into());
    }
    let e = report(out);
    for c in &e {
        let expect_failed = c.id == id;
        if (c.status == "failed") != expect_failed || (c.failures > 0) != expect_failed {
            why.push(format!("{} is {} with {} failures", c.id, c.status, c.failures));
        }
    }
    let c = get(&e, d.kind);
    if !c.json.contains(d.worst) {
        why.push(format!("the worst case lacks {:?}", d.worst));
    }
    if let Err(w) = measure(d, c, &e) {
        why.push(w);
    }
    why
}

#[test]
fn every_broken_pinhole_fails_its_own_check_and_no_other() {
    assert_eq!(
        DEFECTS.iter().map(|d| d.kind).collect::<Vec<_>>(),
        CheckKind::ALL,
        "one deliberately broken plugin per check"
    );
    let dir = tempfile::tempdir().unwrap();
    let mut problems = Vec::new();
    for d in &DEFECTS {
        let lib = pinhole(dir.path(), d.define, Some(d.define));
        let run = check_json(lib.to_str().unwrap(), &[]);
        let (out, err) = (text(&run.stdout), text(&run.stderr));
        let why = verdict(d, &run, &out, &err);
        if !why.is_empty() {
            problems.push(format!(
                "{} ({}): {}\n{out}\n{err}",
                d.define,
                d.kind.id(),
                why.join("; ")
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n\n"));
}

#[test]
fn a_property_value_of_an_unknown_kind_fails_the_property_type_check() {
    // A C plugin can send any int32 as the value kind or enum value. The host's adapter raises what
    // does not decode instead of passing it off as unanswered, and the checker counts a wrong type.
    let dir = tempfile::tempdir().unwrap();
    let lib = pinhole(dir.path(), "UnknownKind", Some("DEFECT_UNKNOWN_VALUE_KIND"));
    let run = check_json(lib.to_str().unwrap(), &[]);
    let (out, err) = (text(&run.stdout), text(&run.stderr));
    assert!(!run.status.success(), "{out}\n{err}");
    assert!(out.contains("\"clean\":false"), "{out}");
    let e = report(&out);
    let types = get(&e, CheckKind::PropertyType);
    assert_eq!(types.status, "failed", "{out}");
    // k_FieldOfView with value kind 7 and k_DicingHint with enum value 9.
    assert_eq!(types.failures, 2, "{out}");
    // The worst case (equal severities: the last asked) is the dicing hint.
    assert!(
        types.json.contains(
            "\"what\":\"k_DicingHint\",\"expected\":\"PropertyValue::DicingHint or None\",\
             \"got\":\"unknown dicing hint 9 (expected 0, 1 or 2)\""
        ),
        "{out}"
    );
    assert_eq!(get(&e, CheckKind::Panic).failures, 0, "{out}");
    assert!(
        out.contains("\"k_DicingHint\":null") && out.contains("\"k_FieldOfView\":null"),
        "{out}"
    );
    assert!(err.contains("(property_type)"), "{err}");
}

#[test]
fn a_failing_property_call_fails_the_panic_check() {
    // OBSCURA_PANIC (what export_projection! returns for a panic in a Rust plugin's property) or
    // OBSCURA_ERROR from `property` is a failure, not "unanswered": the checker reports it.
    let dir = tempfile::tempdir().unwrap();
    let lib = pinhole(dir.path(), "PropertyFails", Some("DEFECT_PROPERTY_FAILS"));
    let run = check_json(lib.to_str().unwrap(), &[]);
    let (out, err) = (text(&run.stdout), text(&run.stderr));
    assert!(!run.status.success(), "{out}\n{err}");
    let e = report(&out);
    let panic = get(&e, CheckKind::Panic);
    assert_eq!(panic.status, "failed", "{out}");
    assert!(
        panic.json.contains(
            "\"what\":\"property(k_FieldOfView)\",\"expected\":\"no panic\",\"got\":\"panicked: \
             the plugin returned status 3 (OBSCURA_PANIC"
        ),
        "{out}"
    );
    assert!(out.contains("\"k_FieldOfView\":null"), "{out}");
    assert!(err.contains("1 check failed (panic)"), "{err}");
}

#[test]
fn a_render_goes_on_without_a_property_whose_call_fails() {
    // What the renderer does with the same plugins: a warning naming the plugin and the property, the
    // property unanswered, every pixel rendered.
    let dir = tempfile::tempdir().unwrap();
    for (defect, warning) in [
        (
            "DEFECT_PROPERTY_FAILS",
            "warning: projection ContractPinhole failed to answer k_FieldOfView: the plugin returned \
             status 3 (OBSCURA_PANIC",
        ),
        (
            "DEFECT_UNKNOWN_VALUE_KIND",
            "warning: projection ContractPinhole answered k_FieldOfView with unknown property value \
             kind 7 (expected 0, 1 or 2); ignored",
        ),
    ] {
        let err = render_with(dir.path(), defect);
        assert!(err.contains(warning), "{defect}: {err}");
    }
}

/// Renders a small frame through the pinhole built with `defect`; returns stderr (the render must
/// succeed and write its file).
fn render_with(dir: &Path, defect: &str) -> String {
    let lib = pinhole(dir, defect, Some(defect));
    let out = dir.join(format!("{defect}.exr"));
    let run = obscura(&[
        "render",
        "-p",
        lib.to_str().unwrap(),
        "--format",
        "16x12",
        "--spp",
        "1",
        "--threads",
        "2",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    let err = text(&run.stderr);
    assert!(run.status.success(), "{defect}: {err}");
    assert!(out.exists(), "{defect}");
    err
}
