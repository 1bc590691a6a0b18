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

// ---- Overscan ----

use obscura_calibration::lens3de::{Kind, Lens};

/// Nuke's LD node defaults (0.8 × 0.6 cm back) with `Distortion - Degree 2` = 0.5: the
/// supplement's lens (its undistorted plate is larger than the plate on every side).
fn supplement_lens(w: u32, h: u32) -> Lens {
    let params: Vec<f64> = (Kind::RadialStandard4.all_params().iter())
        .map(|(n, d)| if *n == "Distortion - Degree 2" { 0.5 } else { *d })
        .collect();
    Lens::new(Kind::RadialStandard4, &params, f64::from(w), f64::from(h)).unwrap()
}

/// The supplement's §2.2.2 figure: on 2000 × 1500 Nuke's node gives the undistorted plate the box
/// `[−503, 2502) × [−377, 1877)` (y up; symmetric in y, so the same y down).
#[test]
fn overscan_of_a_lens_is_nukes_undistorted_box() {
    let (w, h) = (2000, 1500);
    let b = supplement_lens(w, h)
        .undistorted_box(f64::from(w), f64::from(h))
        .unwrap();
    let o = Overscan::covering(b, w, h).unwrap();
    let want = [503, 377, 502, 377];
    // The extremes lie on whole pixels (the corners); the figure must be reproduced by the box
    // moved by at most 1e-6 px, as the supplement's own check allows.
    for (k, want) in want.into_iter().enumerate() {
        let ok = [-1e-6, 0.0, 1e-6].iter().any(|e| {
            let mut moved = b;
            moved[k] += e;
            let m = Overscan::covering(moved, w, h).unwrap();
            [m.left, m.top, m.right, m.bottom][k] == want
        });
        assert!(ok, "side {k} of {b:?} does not give {want} ({o:?})");
    }
    let o = Overscan {
        left: 503,
        top: 377,
        right: 502,
        bottom: 377,
    };
    assert_eq!(o.render_size(w, h), (3005, 2254));
    assert_eq!(
        o.data_window(w, h),
        IntegerBounds::new((-503, -377), (3005, 2254))
    );
}

#[test]
fn overscan_parses_and_rejects() {
    assert_eq!(Overscan::parse("16").unwrap(), Overscan::uniform(16));
    let o = Overscan::parse("1, 2,3,4").unwrap();
    assert_eq!((o.left, o.top, o.right, o.bottom), (1, 2, 3, 4));
    assert_eq!(Overscan::parse(&o.to_string()).unwrap(), o);
    for bad in ["", "-1", "1,2", "1,2,3,4,5", "x", "2000000000"] {
        let e = Overscan::parse(bad).unwrap_err();
        assert!(
            e.contains(&format!("'{bad}'")) && e.contains("LEFT,TOP,RIGHT,BOTTOM"),
            "{e}"
        );
    }
    assert!(Overscan::covering([f64::NAN, 0.0, 1.0, 1.0], 4, 4).is_err());
    // A box inside the plate still gets the filter's margin only where it reaches the edge.
    assert_eq!(
        Overscan::covering([10.0, 10.0, 20.0, 20.0], 64, 64).unwrap(),
        Overscan::default()
    );
}

/// The overscanned screen window keeps the plate's pixel pitch: the plate's corner pixels keep
/// their screen positions and the margins continue them.
#[test]
fn overscan_screen_window_keeps_the_pixel_pitch() {
    let o = Overscan {
        left: 10,
        top: 4,
        right: 6,
        bottom: 2,
    };
    let (w, h) = (64, 48);
    let plate = [-4.0 / 3.0, 4.0 / 3.0, -1.0, 1.0];
    let sw = o.screen_window(plate, w, h);
    let (rw, rh) = o.render_size(w, h);
    let pitch = |s: [f64; 4], w: u32, h: u32| ((s[1] - s[0]) / f64::from(w), (s[3] - s[2]) / f64::from(h));
    let (a, b) = (pitch(plate, w, h), pitch(sw, rw, rh));
    assert!((a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12);
    // The plate's top-left corner is the overscanned render's pixel (left, top) corner.
    assert!((sw[0] + f64::from(o.left) * b.0 - plate[0]).abs() < 1e-12);
    assert!((sw[3] - f64::from(o.top) * b.1 - plate[3]).abs() < 1e-12);
}

/// The scene both renders see, as a function of the undistorted pinhole's raster position (a
/// textured card facing the camera): a smooth grid of period 12 px, so that bilinear resampling's
/// error has the bound `(Δx² + Δy²)/8 · max|f''| ≤ (1/4)·(1/8)·(2π/12)²·2 ≈ 0.0171` at pixel
/// spacing 1.
fn card(q: [f64; 2]) -> f64 {
    let k = std::f64::consts::TAU / 12.0;
    0.5 + 0.25 * (k * q[0]).sin() * (k * q[1]).sin()
}

/// A flat one-channel EXR of `w × h` at the origin, as a render writes an ordinary frame.
fn write_frame(path: &Path, w: u32, h: u32, value: &dyn Fn(u32, u32) -> f32) {
    let samples: Vec<f32> = (0..h).flat_map(|y| (0..w).map(move |x| value(x, y))).collect();
    let channels = AnyChannels::sort(vec![AnyChannel::new("Y", FlatSamples::F32(samples))].into());
    let layer = Layer::new(
        (w as usize, h as usize),
        exr::prelude::LayerAttributes::default(),
        exr::prelude::Encoding::FAST_LOSSLESS,
        channels,
    );
    write_exr_image(Image::from_layer(layer), path).unwrap();
}

/// An EXR's one channel, its data window and display window.
fn read_frame(path: &Path) -> (Vec<f32>, IntegerBounds, IntegerBounds) {
    let image = read_tile(path).unwrap();
    let data = match &image.layer_data.channel_data.list[0].sample_data {
        FlatSamples::F32(v) => v.clone(),
        other => panic!("not f32: {other:?}"),
    };
    let dw = IntegerBounds::new(image.layer_data.attributes.layer_position, image.layer_data.size);
    (data, dw, image.attributes.display_window)
}

/// Bilinear lookup at display position `p` of an image whose pixels fill `dw` (pixel `(i, j)`
/// centred at `(i + ½, j + ½)`); `None` where the four pixels are not all in the data window
/// (there the image would be black).
fn bilinear(data: &[f32], dw: IntegerBounds, p: [f64; 2]) -> Option<f64> {
    let fx = p[0] - 0.5 - f64::from(dw.position.0);
    let fy = p[1] - 0.5 - f64::from(dw.position.1);
    let (i, j) = (fx.floor(), fy.floor());
    let (w, h) = (dw.size.0 as f64, dw.size.1 as f64);
    if !(i >= 0.0 && j >= 0.0 && i + 1.0 < w && j + 1.0 < h) {
        return None;
    }
    let (tx, ty, i, j) = (fx - i, fy - j, i as usize, j as usize);
    let at = |x: usize, y: usize| f64::from(data[y * dw.size.0 + x]);
    Some(
        (1.0 - ty) * ((1.0 - tx) * at(i, j) + tx * at(i + 1, j))
            + ty * ((1.0 - tx) * at(i, j + 1) + tx * at(i + 1, j + 1)),
    )
}

/// An overscanned pinhole render, placed on its plate and redistorted through the lens's ST-map
/// (Nuke's convention: the plate pixel's `(s, t)` = its undistorted position over the plate, `t`
/// up), equals the render through the lens to within bilinear resampling's bound, with every plate
/// pixel covered; the same render without overscan leaves uncovered (black) pixels at the edge.
#[test]
fn overscanned_render_redistorts_onto_the_plate() {
    let (w, h) = (200, 150);
    let lens = supplement_lens(w, h);
    let b = lens.undistorted_box(f64::from(w), f64::from(h)).unwrap();
    let o = Overscan::covering(b, w, h).unwrap();
    assert!(o.left > 2 && o.top > 2 && o.right > 2 && o.bottom > 2, "{o:?}");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cg.exr");
    let (rw, rh) = o.render_size(w, h);
    // The pinhole's pixel (x, y) of the overscanned frame is the plate's raster (x − left, y − top).
    let (l, t) = (f64::from(o.left), f64::from(o.top));
    write_frame(&path, rw, rh, &|x, y| {
        card([f64::from(x) + 0.5 - l, f64::from(y) + 0.5 - t]) as f32
    });
    place_overscan(&path, o, w, h).unwrap();
    let (data, dw, display) = read_frame(&path);
    assert_eq!(display, IntegerBounds::new((0, 0), (w as usize, h as usize)));
    assert_eq!(dw, o.data_window(w, h));
    // The data window is the undistorted box, padded as Nuke pads it.
    assert_eq!(dw.position.0, b[0].floor() as i32 - 2);
    assert_eq!(dw.position.1, b[1].floor() as i32 - 2);
    assert_eq!(dw.end().0, b[2].ceil() as i32 + 2);
    assert_eq!(dw.end().1, b[3].ceil() as i32 + 2);

    let k = std::f64::consts::TAU / 12.0;
    let bound = 0.25 * 0.125 * k * k * 2.0 + 1e-6;
    let (mut worst, mut uncovered_plain) = (0.0_f64, 0);
    let plain = IntegerBounds::new((0, 0), (w as usize, h as usize));
    let plain_data: Vec<f32> = (0..h)
        .flat_map(|y| (0..w).map(move |x| card([f64::from(x) + 0.5, f64::from(y) + 0.5]) as f32))
        .collect();
    for y in 0..h {
        for x in 0..w {
            let p = [f64::from(x) + 0.5, f64::from(y) + 0.5];
            // The ray of plate pixel p through the lens is the undistorted pinhole's ray at q.
            let q = lens.undistort(p).unwrap();
            let through_lens = card(q);
            // The ST-map's (s, t) and back to display pixels.
            let (s, tt) = (q[0] / f64::from(w), 1.0 - q[1] / f64::from(h));
            let lookup = [s * f64::from(w), (1.0 - tt) * f64::from(h)];
            let Some(v) = bilinear(&data, dw, lookup) else {
                panic!("plate pixel ({x}, {y}) maps to {lookup:?}, outside the data window {dw:?}");
            };
            worst = worst.max((v - through_lens).abs());
            if bilinear(&plain_data, plain, lookup).is_none() {
                uncovered_plain += 1;
            }
        }
    }
    eprintln!("redistorted vs through the lens: worst {worst:.5}, bilinear bound {bound:.5}");
    assert!(worst <= bound, "worst {worst} > bilinear bound {bound}");
    // Without overscan the plate's whole border ring is black.
    assert!(uncovered_plain >= 2 * (w + h) as usize, "{uncovered_plain}");
}

#[test]
fn place_overscan_names_a_frame_of_the_wrong_size() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cg.exr");
    write_frame(&path, 10, 10, &|_, _| 0.0);
    let e = place_overscan(&path, Overscan::uniform(2), 10, 10).unwrap_err();
    let m = e.to_string();
    assert!(
        m.contains("cg.exr") && m.contains("[0, 14) × [0, 14)") && m.contains("10x10"),
        "{m}"
    );
    let missing = dir.path().join("none.exr");
    assert!(matches!(
        place_overscan(&missing, Overscan::uniform(2), 10, 10),
        Err(OverscanError::Unreadable { .. })
    ));
}

proptest! {
    /// The margins are the least whole pixels that keep `FILTER_PAD` pixels beyond every side of
    /// the box: with them the data window reaches 2 px past the box, one pixel less would not.
    #[test]
    fn overscan_covering_is_the_least_padded_cover(
        x0 in -500.0f64..300.0, y0 in -500.0f64..300.0,
        dx in 0.0f64..900.0, dy in 0.0f64..900.0,
        w in 1u32..400, h in 1u32..400,
    ) {
        let b = [x0, y0, x0 + dx, y0 + dy];
        let o = Overscan::covering(b, w, h).unwrap();
        let dw = o.data_window(w, h);
        let (lo, hi) = (dw.position, dw.end());
        let pad = f64::from(FILTER_PAD);
        // Covers, with the pad.
        prop_assert!(f64::from(lo.0) <= b[0] - pad + 1e-9 || o.left == 0);
        prop_assert!(f64::from(lo.1) <= b[1] - pad + 1e-9 || o.top == 0);
        prop_assert!(f64::from(hi.0) >= b[2] + pad - 1e-9 || o.right == 0);
        prop_assert!(f64::from(hi.1) >= b[3] + pad - 1e-9 || o.bottom == 0);
        // Never smaller than the plate, and least: a margin one pixel smaller loses the pad.
        prop_assert!(lo.0 <= 0 && lo.1 <= 0 && hi.0 >= w as i32 && hi.1 >= h as i32);
        if o.left > 0 { prop_assert!(f64::from(lo.0 + 1) > b[0] - pad); }
        if o.top > 0 { prop_assert!(f64::from(lo.1 + 1) > b[1] - pad); }
        if o.right > 0 { prop_assert!(f64::from(hi.0 - 1) < b[2] + pad); }
        if o.bottom > 0 { prop_assert!(f64::from(hi.1 - 1) < b[3] + pad); }
    }
}
