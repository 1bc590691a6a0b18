//! Shared by the end-to-end tests that check Obscura's output with tools we did not write.

use std::process::Command;

/// Whether `python3` can import `modules` (as in `import OpenEXR, numpy`). When it cannot, the calling
/// test skips, unless the environment variable `require` is set (CI sets it after installing the
/// modules), and then it fails.
pub fn python_has(modules: &str, require: &str) -> bool {
    let ok = Command::new("python3")
        .args(["-c", &format!("import {modules}")])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var_os(require).is_none(),
            "python3 with {modules} is required here ({require} is set) but missing"
        );
        eprintln!("skipping: python3 with {modules} is not installed (CI installs it)");
    }
    ok
}
