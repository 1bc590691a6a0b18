//! End to end: `obscura render --frames` and the files each frame writes.

use std::path::Path;
use std::process::{Command, Output};

fn obscura(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_obscura"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the obscura binary runs")
}

fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

const SMALL: [&str; 5] = ["render", "--format", "8x6", "--spp", "1"];

#[test]
fn several_frames_write_one_file_each_by_frame_number() {
    let dir = tempfile::tempdir().unwrap();
    let out = obscura(
        &[&SMALL[..], &["-q", "--frames", "2-3", "-o", "out.exr"]].concat(),
        dir.path(),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(
        files(dir.path()),
        ["out.0002.exr", "out.0002.png", "out.0003.exr", "out.0003.png"]
    );
}

#[test]
fn frame_is_an_alias_and_a_hash_run_is_replaced_even_for_one_frame() {
    let dir = tempfile::tempdir().unwrap();
    let out = obscura(
        &[&SMALL[..], &["-q", "--frame", "7", "-o", "shot.###.png"]].concat(),
        dir.path(),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(files(dir.path()), ["shot.007.png"]);
    // One frame and no pattern: the name as given.
    let out = obscura(
        &[&SMALL[..], &["-q", "--frames", "7", "-o", "one.png"]].concat(),
        dir.path(),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(dir.path().join("one.png").exists());
}

#[test]
fn a_bad_frame_selection_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = obscura(&[&SMALL[..], &["--frames", "9-2"]].concat(), dir.path());
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("'9-2': the range 9-2 ends before it starts") && err.contains("--frames"),
        "{err}"
    );
    assert!(files(dir.path()).is_empty());
}
