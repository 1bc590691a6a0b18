//! The gallery (`docs/gallery.png`, made by `scripts/gallery.py`) shows every registered projection:
//! its manifest `docs/gallery.txt` must name each one, so a projection added without regenerating the
//! gallery fails here.

use std::path::Path;

/// The projection names of the manifest's tiles: the first word of every line that is neither blank
/// nor a `#` comment.
fn tiles(manifest: &str) -> Vec<&str> {
    manifest
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .filter_map(|l| l.split_whitespace().next())
        .collect()
}

#[test]
fn manifest_tiles_are_the_first_word_of_each_line() {
    let m = "# comment\n\nPxrPerspective  fov=60  320x180\n  Fisheye mapping=equidistant\n";
    assert_eq!(tiles(m), ["PxrPerspective", "Fisheye"]);
}

#[test]
fn every_registered_projection_has_a_gallery_tile() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/gallery.txt");
    let manifest = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; regenerate the gallery with `python3 scripts/gallery.py`",
            path.display()
        )
    });
    let shown = tiles(&manifest);
    let missing: Vec<String> = obscura_plugins::builtin_registry()
        .names()
        .into_iter()
        .filter(|n| !shown.contains(&n.as_str()))
        .collect();
    assert!(
        missing.is_empty(),
        "docs/gallery.png has no tile of {}; regenerate it with `python3 scripts/gallery.py`",
        missing.join(", ")
    );
}
