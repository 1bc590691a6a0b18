//! The lifecycle through the C ABI, as docs/plugin-abi.md promises it: loading (or listing) a plugin
//! runs nothing but its entry point; `init` runs with the library's path just before the first
//! projection is created; `synchronize(RenderBegin)` once, then each `create_projection`;
//! `synchronize(RenderEnd)` once at `Registry::end_render` or when the registry is dropped; every
//! projection destroyed once; `finalize` after the last.
//!
//! The C plugin `tests/plugins/recorder.c` writes down each call it receives; the tests read the
//! record through its extra export `recorder_calls` on the same library.

use std::ffi::{CStr, c_char};
use std::path::{Path, PathBuf};

use obscura_host::Registry;
use obscura_plugins::builtin_registry;
use obscura_plugins::listing;
use obscura_plugins::loader::{PluginSearch, load_all, load_file};
use obscura_sdk::{Format, ParamList, ProjectionEnvironment};

#[path = "support/plugin_build.rs"]
mod plugin_build;

use plugin_build::compile_c;

/// The recorder plugin, as `Recorder.so` in a directory of its own (so each test has its own
/// library, and its own record).
fn recorder() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/plugins/recorder.c");
    let p = compile_c(&src, &[], dir.path(), "Recorder", true);
    (dir, p)
}

/// The calls the recorder at `path` has received so far, one per entry.
fn calls(path: &Path) -> Vec<String> {
    type CallsFn = unsafe extern "C" fn() -> *const c_char;
    // SAFETY: the host has already loaded this library (and never unloads it), so opening it again
    // returns the same handle and runs no initialiser; `recorder_calls` has exactly this type and
    // returns a NUL-terminated string in the library's static storage.
    unsafe {
        let lib = libloading::Library::new(path.canonicalize().unwrap()).unwrap();
        let f = lib.get::<CallsFn>(b"recorder_calls\0").unwrap();
        CStr::from_ptr(f())
            .to_str()
            .unwrap()
            .lines()
            .map(str::to_string)
            .collect()
    }
}

fn env() -> ProjectionEnvironment {
    ProjectionEnvironment::for_format(Format::new(8, 8))
}

#[test]
fn loading_and_listing_a_plugin_runs_nothing_but_its_entry_point() {
    let (dir, p) = recorder();
    let mut reg = builtin_registry();
    // What `obscura plugins` does: load everything on the path, then list it.
    let (loaded, failed) = load_all(&mut reg, &PluginSearch::new(vec![dir.path().into()]));
    assert_eq!((loaded, failed), (vec!["Recorder".to_string()], Vec::new()));
    let text = listing::list(&reg, None).unwrap();
    assert!(text.contains("Recorder\n"), "{text}");
    drop(reg);
    assert_eq!(calls(&p), ["entry"]);
}

/// Two projections created, `end_render`, both dropped, the registry dropped: the calls `p` must
/// have received, in order.
fn two_creates_end_render_and_drop(mut reg: Registry, p: &Path) -> Vec<String> {
    let mut env = env();
    let a = reg.create("Recorder", &mut env, &ParamList::new()).unwrap();
    let b = reg.create("Recorder", &mut env, &ParamList::new()).unwrap();
    reg.end_render();
    drop((a, b));
    drop(reg);
    let path = p.canonicalize().unwrap();
    vec![
        "entry".to_string(),
        format!("init {}", path.display()),
        "synchronize RenderBegin params".into(),
        "create".into(),
        "create".into(),
        "synchronize RenderEnd null".into(),
        "destroy".into(),
        "destroy".into(),
        "finalize".into(),
    ]
}

#[test]
fn two_creates_end_render_and_drop_make_the_documented_sequence() {
    let (_d, p) = recorder();
    let mut reg = Registry::new();
    load_file(&mut reg, &p).unwrap();
    let expected = two_creates_end_render_and_drop(reg, &p);
    assert_eq!(calls(&p), expected);
}

/// The same sequence reaches a plugin run in a worker process (`--isolate-plugins`): read from the
/// file the recorder writes beside itself once `init` names its path.
#[cfg(target_os = "linux")]
#[test]
fn the_lifecycle_reaches_an_isolated_plugin_in_the_documented_order() {
    use obscura_plugins::isolate::{Isolation, WorkerCommand};
    let (dir, p) = recorder();
    let worker = WorkerCommand {
        program: env!("CARGO_BIN_EXE_obscura-plugin-worker").into(),
        args: Vec::new(),
    };
    let search = PluginSearch::new(vec![dir.path().into()])
        .with_isolation(Some(Isolation::all(worker, std::time::Duration::from_secs(10))));
    let mut reg = Registry::new();
    obscura_plugins::loader::ensure(&mut reg, "Recorder", &search).unwrap();
    let expected = two_creates_end_render_and_drop(reg, &p);
    let log = PathBuf::from(format!("{}.calls", p.canonicalize().unwrap().display()));
    let record: Vec<String> = std::fs::read_to_string(log)
        .unwrap_or_default()
        .lines()
        .map(str::to_string)
        .collect();
    assert_eq!(record, expected);
}

/// `finalize` comes after every projection is destroyed, even one that outlives its registry; and a
/// registry dropped without `end_render` sends `RenderEnd` itself.
#[test]
fn a_projection_outliving_its_registry_delays_finalize() {
    let (_d, p) = recorder();
    let mut reg = Registry::new();
    load_file(&mut reg, &p).unwrap();
    let proj = reg.create("Recorder", &mut env(), &ParamList::new()).unwrap();
    drop(reg);
    assert_eq!(
        calls(&p)[2..],
        [
            "synchronize RenderBegin params",
            "create",
            "synchronize RenderEnd null"
        ]
    );
    drop(proj);
    assert_eq!(calls(&p)[5..], ["destroy", "finalize"]);
}
