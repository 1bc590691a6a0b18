//! Building the test and example plugins: shared by `obscura-plugins/tests/abi.rs` and
//! `obscura-cli/tests/plugins.rs` (included with `#[path]`, so both use one copy).

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The workspace root.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `<name>.so` (`.dylib`, `.dll`): the file the host searches for.
pub fn lib_name(name: &str) -> String {
    format!("{name}.{}", std::env::consts::DLL_EXTENSION)
}

/// The C compiler: `$CC`, else `cc`.
pub fn c_compiler() -> String {
    std::env::var("CC").unwrap_or_else(|_| "cc".into())
}

/// Compiles `src` into `<dir>/<name>.so` with the given defines (strict: warnings are errors); panics
/// with the compiler's output when it fails (the tests need a C compiler: CI has gcc).
pub fn compile_c(src: &Path, defines: &[&str], dir: &Path, name: &str, strict: bool) -> PathBuf {
    let out = dir.join(lib_name(name));
    let mut cmd = Command::new(c_compiler());
    cmd.args(["-std=c11", "-O1", "-fPIC", "-shared"])
        .arg("-I")
        .arg(workspace().join("include"));
    if strict {
        cmd.args(["-Wall", "-Wextra", "-Werror", "-pedantic"]);
    } else {
        cmd.arg("-w");
    }
    if cfg!(target_os = "macos") {
        cmd.arg("-undefined").arg("dynamic_lookup");
    }
    for d in defines {
        cmd.arg(format!("-D{d}"));
    }
    cmd.arg("-o").arg(&out).arg(src).arg("-lm");
    let output = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot run the C compiler `{}` (set CC): {e}", c_compiler()));
    assert!(
        output.status.success(),
        "compiling {} {defines:?} failed:\n{}",
        src.display(),
        String::from_utf8_lossy(&output.stderr)
    );
    out
}

/// The C fisheye example compiled into `<dir>/CFisheye.so`.
pub fn compile_c_fisheye(dir: &Path) -> PathBuf {
    let src = workspace().join("examples/plugins/c-fisheye/fisheye.c");
    compile_c(&src, &[], dir, "CFisheye", true)
}

/// Builds the Rust plugins (the tiny-planet example and the panicking test plugin) once per test
/// binary, into a target directory of their own (so the outer cargo's lock is not needed), and
/// returns that directory's `debug`.
pub fn rust_plugins() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let target = Path::new(env!("CARGO_TARGET_TMPDIR"))
            .parent()
            .unwrap()
            .join("plugin-tests");
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let out = Command::new(cargo)
            .current_dir(workspace())
            .args([
                "build",
                "--quiet",
                "--lib",
                "-p",
                "obscura-test-panicking-plugin",
                "-p",
                "obscura-example-tiny-planet",
                "--target-dir",
            ])
            .arg(&target)
            .output()
            .expect("cannot run cargo");
        assert!(
            out.status.success(),
            "building the Rust test plugins failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        target.join("debug")
    })
}

/// The Rust cdylib of `crate_name` copied into `dir` as `<name>.so`.
pub fn copy_rust_plugin(crate_name: &str, dir: &Path, name: &str) -> PathBuf {
    let built = rust_plugins().join(format!(
        "{}{crate_name}.{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_EXTENSION
    ));
    let p = dir.join(lib_name(name));
    std::fs::copy(&built, &p).unwrap_or_else(|e| panic!("{}: {e}", built.display()));
    p
}
