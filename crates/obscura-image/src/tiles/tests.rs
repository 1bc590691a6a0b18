//! Tests of [`super`] (tiles.rs).

use super::*;
use crate::output::tests::film;
use crate::output::{write_exr, write_png};
use crate::testing::rect;
use obscura_scene::Aov;
use proptest::prelude::*;

const AOVS: [Aov; 5] = [Aov::Ci, Aov::Alpha, Aov::Z, Aov::ObjectId, Aov::N];

/// Keeps the header as it is: the films here record no data window in their text attributes.
fn keep(_: &str, _: &str, _: PixelRect) -> Option<String> {
    None
}

/// Writes the full image and the tiles of `grid` of a `w×h` film; returns (full EXR, tile EXRs).
fn render(dir: &Path, w: u32, h: u32, grid: TileGrid, half: bool) -> (PathBuf, Vec<PathBuf>) {
    let whole = rect(0, w, 0, h);
    let full = dir.join("full.exr");
    let attrs = [("obscura:projection", "PxrPerspective".to_string())];
    write_exr(&full, &film(w, h, whole), &AOVS, half, 1.0, &attrs).unwrap();
    write_png(&full.with_extension("png"), &film(w, h, whole)).unwrap();
    let out = dir.join("merged.exr");
    let mut tiles = Vec::new();
    for i in 0..grid.count() {
        let r = grid.rect(whole, i);
        let path = grid.tile_path(&out, i);
        write_exr(&path, &film(w, h, r), &AOVS, half, 1.0, &attrs).unwrap();
        write_png(&path.with_extension("png"), &film(w, h, r)).unwrap();
        tiles.push(path);
    }
    (full, tiles)
}

#[test]
fn a_grid_covers_the_region_exactly_and_names_its_files() {
    let g = TileGrid::parse("3x2").unwrap();
    let region = rect(10, 27, 5, 10);
    let mut covered = vec![0; 17 * 5];
    for i in 0..g.count() {
        let r = g.rect(region, i);
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                covered[((y - 5) * 17 + x - 10) as usize] += 1;
            }
        }
    }
    assert!(covered.iter().all(|&n| n == 1));
    assert_eq!(g.rect(region, 4), rect(15, 21, 7, 10));
    assert_eq!(
        g.tile_path(Path::new("out/beauty.0001.exr"), 4),
        Path::new("out/beauty.0001.tile4-3x2.exr")
    );
    assert_eq!(g.tile_path(Path::new("render"), 0), Path::new("render.tile0-3x2"));
    for bad in ["2", "0x2", "ax2", "2x", "100x100"] {
        assert!(TileGrid::parse(bad).unwrap_err().contains(bad), "{bad}");
    }
    assert!(g.check_index(6).unwrap_err().contains("0 to 5"));
}

#[test]
fn merged_tiles_are_the_bytes_of_the_full_image() {
    for (grid, half) in [("2x2", false), ("3x1", true), ("1x4", false)] {
        let dir = tempfile::tempdir().unwrap();
        let grid = TileGrid::parse(grid).unwrap();
        let (full, tiles) = render(dir.path(), 13, 9, grid, half);
        let out = dir.path().join("merged.exr");
        assert_eq!(tile_files(&out, grid).unwrap(), tiles);
        merge_exr(&tiles, grid, &out, &keep).unwrap();
        assert_eq!(
            std::fs::read(&out).unwrap(),
            std::fs::read(&full).unwrap(),
            "{grid}"
        );
        let pngs: Vec<PathBuf> = tiles.iter().map(|t| t.with_extension("png")).collect();
        merge_png(&pngs, grid, &out.with_extension("png")).unwrap();
        assert_eq!(
            std::fs::read(out.with_extension("png")).unwrap(),
            std::fs::read(full.with_extension("png")).unwrap()
        );
    }
}

#[test]
fn tiles_that_do_not_belong_together_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let grid = TileGrid::parse("2x2").unwrap();
    let (_, tiles) = render(dir.path(), 8, 6, grid, false);
    let out = dir.path().join("merged.exr");
    let attrs = [("obscura:projection", "PxrPerspective".to_string())];
    let err = |tiles: &[PathBuf]| merge_exr(tiles, grid, &out, &keep).unwrap_err().to_string();

    // Another setting (a header attribute), another size, other channels.
    let odd = dir.path().join("odd.exr");
    let r = grid.rect(rect(0, 8, 0, 6), 1);
    write_exr(
        &odd,
        &film(8, 6, r),
        &AOVS,
        false,
        1.0,
        &[("obscura:projection", "FishEye".into())],
    )
    .unwrap();
    let mut set = tiles.clone();
    set[1] = odd.clone();
    let e = err(&set);
    assert!(
        e.starts_with(&odd.display().to_string()) && e.contains("\"obscura:projection\" differs"),
        "{e}"
    );
    write_exr(&odd, &film(9, 6, r), &AOVS, false, 1.0, &attrs).unwrap();
    let e = err(&set);
    assert!(
        e.contains("odd.exr") && e.contains("its frame is 9×6 pixels"),
        "{e}"
    );
    write_exr(&odd, &film(8, 6, r), &AOVS[..2], false, 1.0, &attrs).unwrap();
    assert!(err(&set).contains("channels"), "{}", err(&set));

    // Two tiles covering one region: tile 1's file holds tile 0's pixels.
    write_exr(
        &odd,
        &film(8, 6, grid.rect(rect(0, 8, 0, 6), 0)),
        &AOVS,
        false,
        1.0,
        &attrs,
    )
    .unwrap();
    let e = err(&set);
    assert!(
        e.contains("odd.exr: holds pixels [0, 4) × [0, 3), but tile 1 of 2x2 is [4, 8) × [0, 3)"),
        "{e}"
    );
    assert!(e.contains("overlaps tile 0"), "{e}");

    // A truncated file.
    let bytes = std::fs::read(&tiles[2]).unwrap();
    std::fs::write(&odd, &bytes[..bytes.len() - 40]).unwrap();
    let mut set = tiles.clone();
    set[2] = odd.clone();
    assert!(
        err(&set).starts_with(&format!("{}: cannot read this tile", odd.display())),
        "{}",
        err(&set)
    );

    // An interrupted tile.
    write_exr(
        &odd,
        &film(8, 6, grid.rect(rect(0, 8, 0, 6), 2)),
        &AOVS,
        false,
        1.0,
        &[
            ("obscura:projection", "PxrPerspective".into()),
            (PARTIAL_ATTRIBUTE, "1 of 4 tiles".into()),
        ],
    )
    .unwrap();
    assert!(err(&set).contains("incomplete"), "{}", err(&set));

    // A missing tile: named with its index; nothing was written at any point.
    std::fs::remove_file(&tiles[3]).unwrap();
    let e = tile_files(&out, grid).unwrap_err().to_string();
    assert!(
        e.contains("tile 3 (") && e.contains("merged.tile3-2x2.exr"),
        "{e}"
    );
    assert!(!out.exists());
}

#[test]
fn a_good_image_is_not_replaced_when_a_merge_fails() {
    let dir = tempfile::tempdir().unwrap();
    let grid = TileGrid::parse("2x1").unwrap();
    let (_, tiles) = render(dir.path(), 6, 4, grid, false);
    let out = dir.path().join("merged.exr");
    merge_exr(&tiles, grid, &out, &keep).unwrap();
    let good = std::fs::read(&out).unwrap();
    let bytes = std::fs::read(&tiles[1]).unwrap();
    std::fs::write(&tiles[1], &bytes[..bytes.len() / 2]).unwrap();
    assert!(merge_exr(&tiles, grid, &out, &keep).is_err());
    assert_eq!(std::fs::read(&out).unwrap(), good);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn every_grid_partitions_every_region(
        x0 in 0u32..50, y0 in 0u32..50, w in 0u32..60, h in 0u32..60, cols in 1u32..9, rows in 1u32..9,
    ) {
        let g = TileGrid { cols, rows };
        let region = rect(x0, x0 + w, y0, y0 + h);
        let mut area = 0;
        for i in 0..g.count() {
            let r = g.rect(region, i);
            prop_assert!(r.x0 >= region.x0 && r.x1 <= region.x1 && r.y0 >= region.y0 && r.y1 <= region.y1);
            prop_assert!(r.width() <= w / cols + 1 && r.height() <= h / rows + 1);
            area += r.len();
            for j in 0..i {
                let o = g.rect(region, j);
                let disjoint = r.x1 <= o.x0 || o.x1 <= r.x0 || r.y1 <= o.y0 || o.y1 <= r.y0;
                prop_assert!(disjoint || r.is_empty() || o.is_empty());
            }
        }
        prop_assert_eq!(area, region.len());
    }
}

/// A deep image of `w×h` over `window`: pixel (x, y) holds `(x + y) % 3` samples.
fn deep(w: u32, h: u32, window: PixelRect) -> crate::deep::DeepImage {
    let pixels = (window.y0..window.y1)
        .flat_map(|y| (window.x0..window.x1).map(move |x| (x, y)))
        .map(|(x, y)| {
            (0..(x + y) % 3)
                .map(|k| crate::deep::DeepSample {
                    z: (x * 10 + y + k) as f32,
                    z_back: (x * 10 + y + k) as f32 + 0.5,
                    r: 0.1 * x as f32,
                    g: 0.2 * y as f32,
                    b: 0.3,
                    a: 0.5,
                })
                .collect()
        })
        .collect();
    crate::deep::DeepImage {
        width: w,
        height: h,
        data_window: window,
        pixels,
    }
}

#[test]
fn deep_tiles_merge_to_the_bytes_of_the_full_deep_image() {
    use crate::deep::{DeepCompression, read_deep_exr, write_deep_exr};
    for compression in [DeepCompression::Zips, DeepCompression::None] {
        let dir = tempfile::tempdir().unwrap();
        let grid = TileGrid::parse("2x2").unwrap();
        let whole = rect(0, 11, 0, 7);
        let full = dir.path().join("full.exr");
        write_deep_exr(&full, &deep(11, 7, whole), compression).unwrap();
        let (back, c) = read_deep_exr(&full).unwrap();
        assert_eq!((back, c), (deep(11, 7, whole), compression));
        let out = dir.path().join("deep.exr");
        let tiles: Vec<PathBuf> = (0..4)
            .map(|i| {
                let p = grid.tile_path(&out, i);
                write_deep_exr(&p, &deep(11, 7, grid.rect(whole, i)), compression).unwrap();
                p
            })
            .collect();
        merge_exr(&tiles, grid, &out, &keep).unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&full).unwrap());
        // A truncated deep tile is named.
        let bytes = std::fs::read(&tiles[3]).unwrap();
        std::fs::write(&tiles[3], &bytes[..bytes.len() - 5]).unwrap();
        let e = merge_exr(&tiles, grid, &out, &keep).unwrap_err().to_string();
        assert!(
            e.contains("deep.tile3-2x2.exr: cannot read this tile: truncated"),
            "{e}"
        );
    }
}
