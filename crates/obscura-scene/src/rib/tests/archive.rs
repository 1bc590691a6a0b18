//! `ReadArchive` and `parse_file`: paths, nesting, and the file named in messages.

use glam::{Mat4, Vec3};

use super::{fail, ok};
use crate::rib::parse_file;
use crate::types::Shape;

#[test]
fn read_archive_reads_in_place_with_the_same_state() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    let main = dir.path().join("main.rib");
    std::fs::write(
        &main,
        "WorldBegin\nBxdf \"PxrDiffuse\" \"d\"\nTranslate 1 0 0\nReadArchive \"sub/part.rib\"\nSphere 1 -1 1 360\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("sub/part.rib"),
        "Cone 1 1 360\nReadArchive \"leaf.rib\"\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("sub/leaf.rib"),
        "Translate 0 1 0\nDisk 0 1 360\nBogus 1\n",
    )
    .unwrap();
    let scene = parse_file(&main).unwrap();
    let part = dir.path().join("sub/part.rib").display().to_string();
    let leaf = dir.path().join("sub/leaf.rib").display().to_string();
    let o = &scene.objects;
    assert_eq!(o.len(), 3);
    assert_eq!(o[0].source, format!("{part}:1"));
    assert_eq!(
        (o[0].material, o[0].transform.samples[0].1),
        (1, Mat4::from_translation(Vec3::X))
    );
    assert_eq!(o[1].source, format!("{leaf}:2"));
    // The archive's Translate stays in force after it: the state is shared.
    assert_eq!(
        o[2].transform.samples[0].1,
        Mat4::from_translation(Vec3::new(1.0, 1.0, 0.0))
    );
    assert_eq!(
        scene.warnings,
        vec![format!("{leaf}:3: unknown request Bogus, skipped")]
    );
}

#[test]
fn missing_archive_names_the_including_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let main = dir.path().join("main.rib");
    std::fs::write(&main, "WorldBegin\nReadArchive \"nope.rib\"\n").unwrap();
    let e = parse_file(&main).unwrap_err();
    assert_eq!(
        (e.file.as_str(), e.line),
        (main.display().to_string().as_str(), 2)
    );
    let missing = dir.path().join("nope.rib").display().to_string();
    assert!(
        e.message
            .starts_with(&format!("ReadArchive \"{missing}\": cannot read the file: ")),
        "{e}"
    );
}

#[test]
fn recursive_archives_stop_at_32_levels() {
    let dir = tempfile::tempdir().unwrap();
    let me = dir.path().join("self.rib");
    std::fs::write(&me, "ReadArchive \"self.rib\"\n").unwrap();
    let e = parse_file(&me).unwrap_err();
    assert_eq!((e.file.as_str(), e.line), (me.display().to_string().as_str(), 1));
    assert_eq!(
        e.message,
        "ReadArchive \"self.rib\": archives nested more than 32 deep (does an archive read itself?)"
    );
}

#[test]
fn parse_file_names_the_file_in_messages() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.rib");
    std::fs::write(&path, "\n\nFormat 1 2\n").unwrap();
    let e = parse_file(&path).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!(
            "{}:3: Format expects width height pixelaspect (3 numbers), got 2",
            path.display()
        )
    );
    let e = parse_file(&dir.path().join("absent.rib")).unwrap_err();
    assert_eq!(e.line, 0);
}

#[test]
fn an_inline_archive_is_kept_until_read_and_then_read_each_time() {
    let s = ok(
        "ArchiveBegin \"wave\"\n  Sphere 1 -1 1 360\n  ArchiveBegin \"inner\"\n  Cone 1 1 360\n  ArchiveEnd\nArchiveEnd\n\
         WorldBegin\nReadArchive \"wave\"\nTranslate 1 0 0\nReadArchive \"wave\"\nReadArchive \"inner\"\nWorldEnd\n",
    );
    let kinds: Vec<bool> = s
        .objects
        .iter()
        .map(|o| matches!(o.shape, Shape::Sphere { .. }))
        .collect();
    assert_eq!(kinds, [true, true, false]);
    assert_eq!(
        fail("ArchiveBegin \"a\"\nSphere 1 -1 1 360\n"),
        "t.rib:1: ArchiveBegin \"a\" has no matching ArchiveEnd"
    );
    assert_eq!(
        fail("\nArchiveEnd\n"),
        "t.rib:2: ArchiveEnd without a matching ArchiveBegin"
    );
}

#[test]
fn archives_inside_zip_files_are_read_by_procedural2_and_read_archive() {
    // RenderMan for Maya writes its geometry caches as `cache.zip!member.rib`.
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    let mut zip = zip::ZipWriter::new(std::fs::File::create(dir.path().join("geo.zip")).unwrap());
    let stored = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    zip.start_file("inner/sphere.rib", stored).unwrap();
    zip.write_all(b"Sphere 1 -1 1 360\n").unwrap();
    zip.finish().unwrap();
    let scene = crate::rib::parse_str(
        "WorldBegin\nProcedural2 \"DelayedReadArchive2\" \"SimpleBound\" \"string filename\" [\"geo.zip!inner/sphere.rib\"] \"float[6] bound\" [-1 1 -1 1 -1 1]\nReadArchive \"geo.zip!inner/sphere.rib\"\nWorldEnd\n",
        "t.rib",
        dir.path(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.objects.len(), 2);
    let e = crate::rib::parse_str(
        "WorldBegin\nReadArchive \"geo.zip!nothing.rib\"\nWorldEnd\n",
        "t.rib",
        dir.path(),
    )
    .unwrap_err();
    assert_eq!(e.line, 2);
    assert!(
        e.message
            .contains("cannot read \"nothing.rib\" from the zip file"),
        "{e}"
    );
}
