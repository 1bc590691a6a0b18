//! Libraries refused before the system loader sees them (`loader::validate`): every case here crashed
//! the process in `dlopen` or at the entry call before (issue 16), and is now an error naming the file
//! and the reason, while the good libraries beside it still load.

#![cfg(target_os = "linux")]

use std::path::{Path, PathBuf};

use obscura_host::Registry;
use obscura_plugins::loader::{PluginLoadError, PluginSearch, load_all, load_file};

#[path = "support/plugin_build.rs"]
mod plugin_build;

use plugin_build::{compile_c, compile_c_fisheye};

fn hostile(define: &str, dir: &Path, name: &str) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/plugins/hostile.c");
    compile_c(&src, &[define], dir, name, true)
}

fn refused(path: &Path) -> String {
    let e = load_file(&mut Registry::new(), path).expect_err("must be refused");
    assert!(
        matches!(
            e,
            PluginLoadError::Refused { .. } | PluginLoadError::MissingSymbol { .. }
        ),
        "{e:?}"
    );
    let text = e.to_string();
    assert!(text.starts_with(&path.display().to_string()), "{text}");
    text
}

/// A good library cut at every kind of place (inside the ELF header, the program headers, a
/// segment, the section headers at the end): each is refused, none reaches `dlopen` (which died of
/// SIGBUS on such a file).
#[test]
fn a_truncated_library_is_refused_wherever_it_was_cut() {
    let dir = tempfile::tempdir().unwrap();
    let good = compile_c_fisheye(dir.path());
    let bytes = std::fs::read(&good).unwrap();
    let n = bytes.len();
    for (i, len) in [0, 3, 40, 63, 64, 100, 1000, n / 3, n / 2, n - 200, n - 1]
        .into_iter()
        .enumerate()
    {
        let p = dir.path().join(format!("Cut{i}.so"));
        std::fs::write(&p, &bytes[..len]).unwrap();
        let e = refused(&p);
        let expect = match len {
            0 => "the file is empty (0 bytes)".to_string(),
            3 => "it starts with the bytes 7f 45 4c where".into(),
            40 | 63 => format!("it is truncated: {len} bytes, shorter than an ELF header (64 bytes)"),
            _ => format!("but the file has {len} bytes (was it cut short while copying?)"),
        };
        assert!(e.contains(&expect), "{len} of {n} bytes: {e}");
    }
}

#[test]
fn a_text_file_named_like_a_library_is_named_a_text_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("Notes.so");
    std::fs::write(&p, "# my camera\nfov = 90\n").unwrap();
    assert!(
        refused(&p)
            .ends_with("not loaded: it is a text file (it starts \"# my camera\"), not a shared library")
    );
}

#[test]
fn an_entry_symbol_that_is_data_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = hostile("DATA_ENTRY", dir.path(), "Data");
    assert!(
        refused(&p).ends_with(
            "its entry point `obscura_projection_entry` is a data object (STT_OBJECT), not a function"
        ),
        "{}",
        refused(&p)
    );
}

#[test]
fn an_entry_symbol_typed_a_function_but_pointing_at_garbage_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = hostile("RODATA_ENTRY", dir.path(), "Rodata");
    assert!(
        refused(&p).ends_with(
            "its entry point `obscura_projection_entry` lies in section .rodata, which is not executable: it is not a function"
        ),
        "{}",
        refused(&p)
    );
    let p = hostile("ABS_ENTRY", dir.path(), "Absolute");
    assert!(
        refused(&p).ends_with(
            "its entry point `obscura_projection_entry` is an absolute address (0xdeadbeef), not code in the library"
        ),
        "{}",
        refused(&p)
    );
}

/// A copy of a good library with some header bytes changed.
fn patched(good: &Path, dir: &Path, name: &str, patch: &[(usize, u8)]) -> PathBuf {
    let mut bytes = std::fs::read(good).unwrap();
    for &(at, v) in patch {
        bytes[at] = v;
    }
    let p = dir.join(format!("{name}.so"));
    std::fs::write(&p, bytes).unwrap();
    p
}

#[cfg(all(target_arch = "x86_64", target_endian = "little"))]
#[test]
fn a_library_of_another_architecture_class_byte_order_or_type_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let good = compile_c_fisheye(dir.path());
    // e_machine (bytes 18-19) = 183, AArch64.
    let arm = patched(&good, dir.path(), "Arm", &[(18, 183), (19, 0)]);
    assert!(refused(&arm).ends_with("it was built for AArch64 (ARM 64-bit), and this host is x86-64"));
    let c32 = patched(&good, dir.path(), "C32", &[(4, 1)]);
    assert!(refused(&c32).ends_with("it is a 32-bit library, and this host is 64-bit"));
    let be = patched(&good, dir.path(), "Be", &[(5, 2)]);
    assert!(refused(&be).ends_with("its byte order is big-endian, and this host is little-endian"));
    // e_type (bytes 16-17) = ET_EXEC.
    let exe = patched(&good, dir.path(), "Exe", &[(16, 2)]);
    assert!(refused(&exe).ends_with("it is an executable, not a shared library"));
    let mut macho = vec![0xcf, 0xfa, 0xed, 0xfe, 7, 0, 0, 1];
    macho.resize(4096, 0);
    let p = dir.path().join("Mac.so");
    std::fs::write(&p, macho).unwrap();
    assert!(refused(&p).ends_with("it is a Mach-O file (macOS), and this host loads ELF shared libraries"));
    let mut pe = b"MZ\x90\x00".to_vec();
    pe.resize(4096, 0);
    let p = dir.path().join("Win.so");
    std::fs::write(&p, pe).unwrap();
    assert!(refused(&p).ends_with(
        "it is a PE file (a Windows DLL or executable), and this host loads ELF shared libraries"
    ));
}

/// What `obscura plugins` does: one directory with a good plugin among broken ones lists the good one
/// and names each broken file with its reason (before, the first broken file killed the listing).
#[test]
fn listing_a_directory_of_broken_libraries_keeps_the_good_one() {
    let dir = tempfile::tempdir().unwrap();
    let good = compile_c_fisheye(dir.path());
    let bytes = std::fs::read(&good).unwrap();
    std::fs::write(dir.path().join("ACut.so"), &bytes[..bytes.len() / 2]).unwrap();
    std::fs::write(dir.path().join("BText.so"), "text\n").unwrap();
    hostile("DATA_ENTRY", dir.path(), "CData");
    let mut reg = Registry::new();
    let (loaded, failed) = load_all(&mut reg, &PluginSearch::new(vec![dir.path().into()]));
    assert_eq!(loaded, ["CFisheye"]);
    let text: Vec<String> = failed.iter().map(ToString::to_string).collect();
    assert_eq!(text.len(), 3, "{text:?}");
    assert!(
        text[0].contains("ACut.so: not loaded: it is truncated"),
        "{}",
        text[0]
    );
    assert!(
        text[1].contains("BText.so: not loaded: it is a text file"),
        "{}",
        text[1]
    );
    assert!(
        text[2].contains("CData.so: not loaded: its entry point"),
        "{}",
        text[2]
    );
}
