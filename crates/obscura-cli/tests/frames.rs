//! End to end: `obscura render --frames` and the files each frame writes.

use std::path::Path;

mod support;

use support::obscura_in as obscura;

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
        err.contains("'9-2': the range ends (2) before it starts (9)") && err.contains("--frames"),
        "{err}"
    );
    assert!(files(dir.path()).is_empty());
    let out = obscura(&[&SMALL[..], &["--frames", "0-2000000000"]].concat(), dir.path());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("selects 2000000001 frames of a scene without frames of its own"),
        "{err}"
    );
    assert!(files(dir.path()).is_empty());
}

/// Three frames of a sphere moving away; each names `name_of(n)` as its display.
fn animation(dir: &Path, name_of: impl Fn(u32) -> String) -> String {
    let mut text = String::from("Format 8 6 1\nHider \"raytrace\" \"int maxsamples\" [1]\n");
    for n in [1, 2, 3] {
        text += &format!(
            "FrameBegin {n}\nDisplay \"{}\" \"file\" \"rgba\"\nTranslate 0 0 {}\nWorldBegin\n\
             Light \"PxrDomeLight\" \"d\"\nSphere 1 -1 1 360\nWorldEnd\nFrameEnd\n",
            name_of(n),
            3 + n
        );
    }
    let path = dir.join("anim.rib");
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

#[test]
fn a_rib_animation_renders_its_frames_with_their_own_displays_and_frames_picks() {
    let dir = tempfile::tempdir().unwrap();
    let scene = animation(dir.path(), |n| format!("own{n}.tif"));
    let out = obscura(&["render", "-q", &scene, "--frames", "2-3"], dir.path());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(
        files(dir.path()),
        ["anim.rib", "own2.png", "own2.tif", "own3.png", "own3.tif"]
    );
    let e = obscura(&["render", "-q", &scene, "--frame", "9"], dir.path());
    assert!(!e.status.success());
    assert!(
        String::from_utf8_lossy(&e.stderr)
            .contains("--frames 9 selects none of the frames the scene has (1, 2, 3)"),
        "{}",
        String::from_utf8_lossy(&e.stderr)
    );
}

#[test]
fn frames_naming_one_file_or_an_output_given_with_o_are_numbered_by_frame() {
    let dir = tempfile::tempdir().unwrap();
    let scene = animation(dir.path(), |_| "same.tif".into());
    let out = obscura(&["render", "-q", &scene], dir.path());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(
        files(dir.path()),
        [
            "anim.rib",
            "same.0001.png",
            "same.0001.tif",
            "same.0002.png",
            "same.0002.tif",
            "same.0003.png",
            "same.0003.tif"
        ]
    );
    let sub = dir.path().join("o");
    std::fs::create_dir(&sub).unwrap();
    let out = obscura(
        &["render", "-q", &scene, "-o", "o/out.exr", "--frames", "1,3"],
        dir.path(),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(
        files(&sub),
        ["out.0001.exr", "out.0001.png", "out.0003.exr", "out.0003.png"]
    );
}

#[test]
fn a_shadow_pass_and_a_beauty_pass_both_render() {
    let dir = tempfile::tempdir().unwrap();
    let text = "Format 8 6 1\nHider \"raytrace\" \"int maxsamples\" [1]\nFrameBegin 1\n\
         Display \"shadow.z\" \"zfile\" \"z\"\nTranslate 0 0 4\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n\
         Display \"beauty.tif\" \"tiff\" \"rgba\"\nWorldBegin\nLight \"PxrDomeLight\" \"d\"\nSphere 1 -1 1 360\nWorldEnd\n\
         FrameEnd\n";
    std::fs::write(dir.path().join("passes.rib"), text).unwrap();
    let out = obscura(&["render", "passes.rib"], dir.path());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("frame 1 (") && stdout.matches("rendered 8x6").count() == 2,
        "{stdout}"
    );
    assert_eq!(
        files(dir.path()),
        ["beauty.png", "beauty.tif", "passes.rib", "shadow.z"]
    );
    // With -o, both images of frame 1 write out.exr: numbered by their place in the sequence.
    let out = obscura(&["render", "-q", "passes.rib", "-o", "out.exr"], dir.path());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(dir.path().join("out.0001.exr").exists() && dir.path().join("out.0002.exr").exists());
}
