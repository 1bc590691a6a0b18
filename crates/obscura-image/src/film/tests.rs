//! Tests of [`super`] (film.rs).

use super::*;
use crate::testing::{ALL_FILTERS, rect};
use obscura_scene::{FilterKind, PixelFilter};

fn filter(kind: FilterKind, w: f32) -> Filter {
    Filter::new(&PixelFilter {
        kind,
        width_x: w,
        width_y: w,
    })
    .unwrap()
}

/// A small deterministic generator (SplitMix64) for sample positions.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn hit(c: f32, z: f32) -> SampleValues {
    SampleValues {
        ci: Rgb::new(c, 0.5 * c, 0.25),
        alpha: 1.0,
        z,
        n: Vec3::new(0.0, 0.0, -1.0),
        p: Vec3::new(c, z, 1.0),
        camera_direction: Vec3::Z,
        truth: crate::samples::Truth {
            camera_z: z,
            instance_id: (c * 1000.0) as u32,
            ..crate::samples::Truth::EMPTY
        },
        flow: crate::samples::FlowPixel::NONE,
        ..SampleValues::EMPTY
    }
}

/// `n`×`n` jittered (stratified) samples in every pixel of `r`, values depending on position.
fn samples(r: PixelRect, n: u32, seed: u64) -> Vec<(f32, f32, SampleValues)> {
    let mut rng = Rng(seed);
    let mut out = Vec::new();
    for y in r.y0..r.y1 {
        for x in r.x0..r.x1 {
            for k in 0..n * n {
                let (u, v) = ((k % n) as f32 + rng.next(), (k / n) as f32 + rng.next());
                let (sx, sy) = (x as f32 + u / n as f32, y as f32 + v / n as f32);
                let v = if rng.next() < 0.2 {
                    SampleValues {
                        camera_direction: Vec3::X,
                        ..SampleValues::EMPTY
                    }
                } else {
                    hit(rng.next(), 1.0 + 10.0 * rng.next())
                };
                out.push((sx, sy, v));
            }
        }
    }
    out
}

/// Renders `samples` into a film by splitting the crop into tiles of `tw`×`th`, merged in the
/// order `order` gives.
fn render(
    f: Filter,
    crop: PixelRect,
    samples: &[(f32, f32, SampleValues)],
    tw: u32,
    th: u32,
    reverse: bool,
) -> Film {
    let mut film = Film::new(24, 20, crop, f);
    let mut tiles = Vec::new();
    let mut y = crop.y0;
    while y < crop.y1 {
        let mut x = crop.x0;
        while x < crop.x1 {
            tiles.push(film.tile(rect(x, (x + tw).min(crop.x1), y, (y + th).min(crop.y1))));
            x += tw;
        }
        y += th;
    }
    for (sx, sy, v) in samples {
        let t = tiles
            .iter_mut()
            .find(|t| {
                let r = t.rect();
                (r.x0..r.x1).contains(&(*sx as u32)) && (r.y0..r.y1).contains(&(*sy as u32))
            })
            .unwrap();
        t.add_sample(*sx, *sy, v);
    }
    if reverse {
        tiles.reverse();
    }
    for t in tiles {
        film.merge(t);
    }
    film
}

#[test]
fn a_constant_sample_value_is_reproduced_exactly_with_any_filter_and_tiling() {
    let crop = rect(3, 21, 2, 17);
    let c = SampleValues {
        ci: Rgb::new(0.3, 1.7, 0.012_345),
        alpha: 0.75,
        ..hit(0.0, 2.0)
    };
    for kind in ALL_FILTERS {
        for w in [1.0, 2.0, 3.3, 4.0] {
            let mut pos = samples(crop, 3, 7);
            for s in &mut pos {
                s.2 = c;
            }
            for (tw, th) in [(18, 15), (5, 4), (1, 1)] {
                let film = render(filter(kind, w), crop, &pos, tw, th, tw == 5);
                for y in crop.y0..crop.y1 {
                    for x in crop.x0..crop.x1 {
                        let p = film.pixel(x, y);
                        // Negative lobes can, rarely, leave a pixel with Σw ≤ 0: it resolves to 0.
                        let a = film.pixels[index_in(crop, x as i64, y as i64).unwrap()];
                        let expected = if a.weight > 0.0 {
                            (c.ci, c.alpha)
                        } else {
                            (Rgb::BLACK, 0.0)
                        };
                        assert_eq!((p.ci, p.alpha), expected, "{kind:?} {w} ({x}, {y})");
                    }
                }
                let positive = film.pixels.iter().filter(|a| a.weight > 0.0).count();
                assert!(positive * 10 >= crop.len() * 9, "{kind:?} {w}: {positive}");
            }
        }
    }
}

#[test]
fn any_tile_split_in_any_order_gives_the_single_tile_film() {
    let crop = rect(2, 23, 1, 19);
    let pos = samples(crop, 2, 11);
    for kind in ALL_FILTERS {
        let f = filter(kind, if kind == FilterKind::Box { 1.0 } else { 3.0 });
        let one = render(f, crop, &pos, 100, 100, false);
        for (tw, th, rev) in [(4, 4, false), (7, 3, true), (1, 1, true), (21, 1, false)] {
            let many = render(f, crop, &pos, tw, th, rev);
            for y in crop.y0..crop.y1 {
                for x in crop.x0..crop.x1 {
                    let (a, b) = (one.pixel(x, y), many.pixel(x, y));
                    let close = |p: f32, q: f32| (p - q).abs() <= 1e-6 * p.abs().max(1.0);
                    assert!(
                        close(a.ci.r, b.ci.r)
                            && close(a.ci.g, b.ci.g)
                            && close(a.ci.b, b.ci.b)
                            && close(a.alpha, b.alpha),
                        "{kind:?} {tw}x{th} ({x}, {y}): {a:?} vs {b:?}"
                    );
                    assert_eq!(
                        (a.z, a.n, a.p, a.camera_direction),
                        (b.z, b.n, b.p, b.camera_direction)
                    );
                }
            }
            assert_eq!(one.coverage(), many.coverage());
        }
    }
}

#[test]
fn a_crop_fed_its_margin_samples_equals_the_same_region_of_the_full_film() {
    let (w, h) = (16u32, 12u32);
    let full_rect = rect(0, w, 0, h);
    let all = samples(full_rect, 2, 3);
    for kind in ALL_FILTERS {
        let f = filter(kind, 3.0);
        let full = render(f, full_rect, &all, 5, 4, false);
        let crop = rect(4, 11, 3, 9);
        let mut film = Film::new(w, h, crop, f);
        let mut tiles: Vec<FilmTile> = [rect(4, 7, 3, 9), rect(7, 11, 3, 6), rect(7, 11, 6, 9)]
            .into_iter()
            .map(|r| film.tile(r))
            .collect();
        let margin = f.radius().0.ceil() as u32;
        for (sx, sy, v) in &all {
            let (px, py) = (*sx as u32, *sy as u32);
            let near = px + margin >= crop.x0
                && px < crop.x1 + margin
                && py + margin >= crop.y0
                && py < crop.y1 + margin;
            if !near {
                continue;
            }
            let (cx, cy) = (px.clamp(crop.x0, crop.x1 - 1), py.clamp(crop.y0, crop.y1 - 1));
            let t = tiles
                .iter_mut()
                .find(|t| {
                    (t.rect().x0..t.rect().x1).contains(&cx) && (t.rect().y0..t.rect().y1).contains(&cy)
                })
                .unwrap();
            t.add_sample(*sx, *sy, v);
        }
        for t in tiles {
            film.merge(t);
        }
        for y in crop.y0..crop.y1 {
            for x in crop.x0..crop.x1 {
                let (a, b) = (full.pixel(x, y), film.pixel(x, y));
                assert!(
                    (a.ci.r - b.ci.r).abs() <= 1e-6 && (a.alpha - b.alpha).abs() <= 1e-6,
                    "{kind:?}"
                );
                assert_eq!((a.z, a.n, a.p), (b.z, b.n, b.p));
            }
        }
    }
}

#[test]
fn a_width_one_box_sample_at_a_pixel_centre_touches_only_that_pixel() {
    let crop = rect(0, 8, 0, 6);
    let mut film = Film::new(8, 6, crop, filter(FilterKind::Box, 1.0));
    let mut t = film.tile(crop);
    t.add_sample(3.5, 2.5, &hit(0.8, 3.0));
    film.merge(t);
    for y in 0..6 {
        for x in 0..8 {
            let p = film.pixel(x, y);
            if (x, y) == (3, 2) {
                assert_eq!(p, hit(0.8, 3.0));
            } else {
                assert_eq!(p, SampleValues::EMPTY, "({x}, {y})");
            }
        }
    }
    assert_eq!(film.coverage(), 1.0 / 48.0);
}

#[test]
fn an_impulse_reproduces_the_filter_shape() {
    for kind in ALL_FILTERS {
        let f = filter(kind, 4.0);
        let crop = rect(0, 9, 0, 9);
        let mut film = Film::new(9, 9, crop, f);
        let mut t = film.tile(crop);
        let (sx, sy) = (4.3, 4.8);
        t.add_sample(
            sx,
            sy,
            &SampleValues {
                ci: Rgb::new(2.0, 1.0, 0.5),
                ..hit(0.0, 1.0)
            },
        );
        film.merge(t);
        for y in 0..9u32 {
            for x in 0..9u32 {
                let w = f.eval(x as f32 + 0.5 - sx, y as f32 + 0.5 - sy) as f64;
                let a = &film.pixels[(y * 9 + x) as usize];
                assert_eq!(a.weight, w, "{kind:?} ({x}, {y})");
                assert_eq!((a.ci, a.alpha), ([2.0 * w, w, 0.5 * w], w), "{kind:?} ({x}, {y})");
                // Resolved: the sample's own value wherever its weight is positive.
                let expected = if w > 0.0 { 2.0 } else { 0.0 };
                assert_eq!(film.pixel(x, y).ci.r, expected, "{kind:?} ({x}, {y})");
            }
        }
        // The shape spans the filter's support: (−2, 2] around the sample in both axes.
        let reached = film.pixels.iter().filter(|a| a.weight != 0.0).count();
        assert!(reached >= 9, "{kind:?}: {reached}");
    }
}

#[test]
fn black_tinted_samples_halve_ci_but_keep_alpha() {
    let crop = rect(0, 6, 0, 5);
    for kind in ALL_FILTERS {
        let mut film = Film::new(6, 5, crop, filter(kind, 2.0));
        let mut t = film.tile(crop);
        let white = SampleValues {
            ci: Rgb::new(0.6, 0.6, 0.6),
            ..hit(0.0, 1.0)
        };
        let tinted = SampleValues {
            ci: Rgb::BLACK,
            ..white
        };
        // Both samples at the same positions, so both get the same weights.
        for (sx, sy, _) in samples(crop, 4, 5) {
            t.add_sample(sx, sy, &white);
            t.add_sample(sx, sy, &tinted);
        }
        film.merge(t);
        for y in 0..5 {
            for x in 0..6 {
                let p = film.pixel(x, y);
                assert!(
                    (p.ci.g - 0.3).abs() < 1e-6 && (p.alpha - 1.0).abs() < 1e-6,
                    "{kind:?} {p:?}"
                );
            }
        }
    }
}

#[test]
fn z_n_p_come_from_the_sample_nearest_the_centre_inside_the_pixel() {
    let crop = rect(0, 4, 0, 4);
    let mut film = Film::new(4, 4, crop, filter(FilterKind::Gaussian, 2.0));
    let mut t = film.tile(crop);
    // Pixel (1, 1): centre (1.5, 1.5).
    t.add_sample(1.1, 1.1, &hit(0.1, 5.0));
    t.add_sample(1.45, 1.6, &hit(0.2, 7.0)); // nearest
    t.add_sample(1.9, 1.9, &hit(0.3, 2.0));
    // Nearer to (1, 1)'s centre than anything, but in pixel (2, 1): must not count for (1, 1).
    t.add_sample(2.0, 1.5, &hit(0.4, 1.0));
    // Pixel (3, 3): the miss is nearest, so z = +∞ and N = P = 0.
    t.add_sample(
        3.5,
        3.52,
        &SampleValues {
            camera_direction: Vec3::Y,
            ..SampleValues::EMPTY
        },
    );
    t.add_sample(3.1, 3.1, &hit(0.5, 4.0));
    // Pixel (0, 3): two samples at the same distance: the nearer depth wins, in either order.
    t.add_sample(0.3, 3.5, &hit(0.6, 9.0));
    t.add_sample(0.7, 3.5, &hit(0.7, 8.0));
    film.merge(t);
    let p = film.pixel(1, 1);
    assert_eq!(
        (p.z, p.p, p.n),
        (7.0, Vec3::new(0.2, 7.0, 1.0), Vec3::new(0.0, 0.0, -1.0))
    );
    assert_eq!(film.pixel(2, 1).z, 1.0);
    let miss = film.pixel(3, 3);
    assert_eq!(
        (miss.z, miss.n, miss.p, miss.camera_direction),
        (f32::INFINITY, Vec3::ZERO, Vec3::ZERO, Vec3::Y)
    );
    assert!(
        miss.alpha > 0.0 && miss.alpha < 1.0,
        "the hit still contributes coverage"
    );
    assert_eq!(film.pixel(0, 3).z, 8.0);
    // A pixel reached only by splats has filtered colour but no z.
    let reached = film.pixel(0, 0);
    assert!(reached.alpha > 0.0);
    assert_eq!((reached.z, reached.p), (f32::INFINITY, Vec3::ZERO));
    assert_eq!(film.coverage(), 4.0 / 16.0);
}

#[test]
fn splats_stay_inside_the_crop_and_odd_inputs_do_not_panic() {
    let crop = rect(2, 5, 2, 5);
    let mut film = Film::new(8, 8, crop, filter(FilterKind::Triangle, 4.0));
    assert_eq!(film.size(), (8, 8));
    let mut t = film.tile(rect(0, 100, 0, 100));
    assert_eq!(t.rect(), crop);
    t.add_sample(2.1, 2.1, &hit(1.0, 1.0));
    t.add_sample(f32::NAN, 2.0, &hit(1.0, 1.0));
    t.add_sample(f32::INFINITY, 2.0, &hit(1.0, 1.0));
    t.add_sample(-1e30, 1e30, &hit(1.0, 1.0));
    film.merge(t);
    assert_eq!(film.pixel(1, 1), SampleValues::EMPTY);
    assert_eq!(film.pixel(100, 3), SampleValues::EMPTY);
    assert!(film.pixel(3, 3).alpha > 0.0 && film.pixel(4, 4).alpha == 0.0);
    // Inverted and out-of-format crops are empty, not panics.
    let empty = Film::new(8, 8, rect(6, 3, 9, 12), filter(FilterKind::Box, 1.0));
    assert!(empty.crop().is_empty());
    assert_eq!(empty.coverage(), 0.0);
    let mut t = empty.tile(rect(0, 8, 0, 8));
    t.add_sample(1.5, 1.5, &hit(1.0, 1.0));
    let mut empty = empty;
    empty.merge(t);
    // A huge filter just covers the whole crop.
    let big = Film::new(8, 8, crop, filter(FilterKind::Box, 1e30));
    let mut t = big.tile(rect(3, 4, 3, 4));
    t.add_sample(3.5, 3.5, &hit(1.0, 1.0));
    let mut big = big;
    big.merge(t);
    assert_eq!(big.pixel(2, 2).alpha, 1.0);
    assert_eq!(big.coverage(), 1.0 / 9.0);
}
