use glam::{Vec2, Vec3A, Vec4};
use obscura_scene::texture::Wrap;

use super::footprint::{UvMap, cone_footprint};
use super::image::{LinearImage, srgb_to_linear};
use super::*;

fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 4]) -> LinearImage {
    LinearImage {
        width: w,
        height: h,
        texels: (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| f(x, y))
            .collect(),
    }
}

fn checker(n: u32) -> LinearImage {
    image(n, n, |x, y| {
        let v = ((x + y) % 2) as f32;
        [v, v, v, 1.0]
    })
}

#[test]
fn every_level_keeps_the_mean_of_the_image() {
    // 7×5: odd sizes exercise the area-split box filter.
    let img = image(7, 5, |x, y| [x as f32, y as f32, (x * y) as f32, 1.0]);
    let mean: Vec4 = img.texels.iter().map(|&t| Vec4::from(t)).sum::<Vec4>() / 35.0;
    let tex = Texture::new(img, (Wrap::Repeat, Wrap::Repeat), false);
    assert_eq!(tex.level_count(), 3);
    assert_eq!(tex.level_size(1), (3, 2));
    for l in 0..tex.level_count() {
        let (w, h) = tex.level_size(l);
        let m: Vec4 = (0..h as i64)
            .flat_map(|y| (0..w as i64).map(move |x| (x, y)))
            .map(|(x, y)| tex.texel(l, x, y))
            .sum::<Vec4>()
            / (w * h) as f32;
        assert!((m - mean).abs().max_element() < 1e-4, "level {l}: {m} vs {mean}");
    }
}

#[test]
fn mip_levels_average_in_linear_space() {
    // A black/white checker of sRGB codes 0 and 255 averages to linear 0.5 (sRGB code ≈ 188), not to
    // code 128 (linear 0.216) as averaging the encoded values would.
    let tex = Texture::new(checker(4), (Wrap::Repeat, Wrap::Repeat), false);
    let top = tex.texel(tex.level_count() - 1, 0, 0);
    assert!((top.x - 0.5).abs() < 1e-6);
    assert!((srgb_to_linear(188.0 / 255.0) - 0.5).abs() < 3e-3);
}

#[test]
fn wrap_modes_repeat_clamp_and_mirror() {
    let img = image(4, 1, |x, _| [x as f32, 0.0, 0.0, 1.0]);
    let r = Texture::new(img.clone(), (Wrap::Repeat, Wrap::Clamp), false);
    let c = Texture::new(img.clone(), (Wrap::Clamp, Wrap::Clamp), false);
    let m = Texture::new(img, (Wrap::Mirror, Wrap::Clamp), false);
    let xs = [-5, -1, 0, 3, 4, 5, 8];
    let get = |t: &Texture| xs.map(|x| t.texel(0, x, 0).x);
    assert_eq!(get(&r), [3.0, 3.0, 0.0, 3.0, 0.0, 1.0, 0.0]);
    assert_eq!(get(&c), [0.0, 0.0, 0.0, 3.0, 3.0, 3.0, 3.0]);
    assert_eq!(get(&m), [3.0, 0.0, 0.0, 3.0, 3.0, 2.0, 0.0]);
}

#[test]
fn a_tiny_footprint_interpolates_and_nearest_does_not() {
    let img = image(2, 1, |x, _| [x as f32, 0.0, 0.0, 1.0]);
    let smooth = Texture::new(img.clone(), (Wrap::Clamp, Wrap::Clamp), false);
    let nearest = Texture::new(img, (Wrap::Clamp, Wrap::Clamp), true);
    let fp = Footprint {
        center: Vec2::new(0.6, 0.5),
        a: Vec2::new(1e-4, 0.0),
        b: Vec2::new(0.0, 1e-4),
    };
    // Texel centres at u = 0.25 and 0.75: u = 0.6 is 70 % of the way.
    let s = smooth.filter(&fp).x;
    assert!((s - 0.7).abs() < 0.02, "{s}");
    assert_eq!(nearest.filter(&fp).x, 1.0);
}

#[test]
fn a_footprint_covering_the_checker_sees_its_mean() {
    let tex = Texture::new(checker(64), (Wrap::Repeat, Wrap::Repeat), false);
    for (a, b) in [
        (Vec2::new(0.1, 0.0), Vec2::new(0.0, 0.1)),
        (Vec2::new(0.3, 0.3), Vec2::new(-0.02, 0.02)),
        (Vec2::new(0.0, 0.9), Vec2::new(0.001, 0.0)),
    ] {
        let v = tex.filter(&Footprint {
            center: Vec2::new(0.37, 0.61),
            a,
            b,
        });
        assert!((v.x - 0.5).abs() < 0.03, "{a} {b}: {v}");
    }
}

#[test]
fn the_footprint_of_a_head_on_cone_is_its_circle_in_texture_units() {
    // A 2×2 world-unit square carrying uv [0, 1]²: a cone of radius 0.1 head-on covers radius 0.05.
    let map = UvMap::new(
        Vec3A::new(2.0, 0.0, 0.0),
        Vec3A::new(0.0, 2.0, 0.0),
        [Vec2::ZERO, Vec2::X, Vec2::Y],
    )
    .unwrap();
    let fp = cone_footprint(Vec2::splat(0.5), 0.1, -Vec3A::Z, Vec3A::Z, &map);
    assert!((fp.a.length() - 0.05).abs() < 1e-6 && (fp.b.length() - 0.05).abs() < 1e-6);
    assert!(fp.a.dot(fp.b).abs() < 1e-9);
    // At 60° from the normal the axis along the ray doubles.
    let d = Vec3A::new(3f32.sqrt() / 2.0, 0.0, -0.5);
    let fp = cone_footprint(Vec2::splat(0.5), 0.1, d, Vec3A::Z, &map);
    let (lo, hi) = (fp.a.length().min(fp.b.length()), fp.a.length().max(fp.b.length()));
    assert!((lo - 0.05).abs() < 1e-6 && (hi - 0.1).abs() < 1e-5, "{lo} {hi}");
    let (dpdu, dpdv) = map.dp_duv().unwrap();
    assert!((dpdu - Vec3A::new(2.0, 0.0, 0.0)).length() < 1e-6);
    assert!((dpdv - Vec3A::new(0.0, 2.0, 0.0)).length() < 1e-6);
}

#[test]
fn a_texture_transform_moves_the_centre_and_scales_the_axes() {
    let fp = Footprint {
        center: Vec2::new(0.5, 0.25),
        a: Vec2::new(0.1, 0.0),
        b: Vec2::new(0.0, 0.2),
    };
    let t = fp.transformed(&[2.0, 0.0, 0.1, 0.0, 3.0, -0.5]);
    assert_eq!(t.center, Vec2::new(1.1, 0.25));
    assert_eq!(t.a, Vec2::new(0.2, 0.0));
    assert!((t.b - Vec2::new(0.0, 0.6)).length() < 1e-6);
}

#[test]
fn a_box_is_black_only_where_no_lookup_can_reach_a_lit_texel() {
    // 256² black with one lit texel at (200, 40); texel centres at (i + ½)/256.
    let img = image(256, 256, |x, y| {
        let v = if (x, y) == (200, 40) { 1.0 } else { 0.0 };
        [v, v, v, 1.0]
    });
    let tex = Texture::new(img, (Wrap::Repeat, Wrap::Repeat), false);
    let at = |x: f32, y: f32| Vec2::new(x, y) / 256.0;
    // Far from it, on level 0 and on coarse levels (a box of 100 texels is judged on level 4).
    assert!(tex.is_black_over(at(10.0, 10.0), at(20.0, 20.0)));
    assert!(tex.is_black_over(at(10.0, 100.0), at(110.0, 200.0)));
    // Containing it, or within the one texel a bilinear lookup reaches beyond the box.
    assert!(!tex.is_black_over(at(190.0, 30.0), at(210.0, 50.0)));
    assert!(!tex.is_black_over(at(201.2, 40.2), at(202.0, 40.8)));
    // A lit texel is found on a coarse level too: its average is not 0.
    assert!(!tex.is_black_over(at(100.0, 0.0), at(230.0, 120.0)));
    // Repeat wrapping: a box left of 0 reads the right edge.
    let edge = image(
        16,
        16,
        |x, _| if x == 15 { [1.0; 4] } else { [0.0, 0.0, 0.0, 1.0] },
    );
    let tex = Texture::new(edge, (Wrap::Repeat, Wrap::Repeat), false);
    assert!(!tex.is_black_over(Vec2::new(-0.02, 0.4), Vec2::new(0.01, 0.5)));
    assert!(tex.is_black_over(Vec2::new(0.3, 0.4), Vec2::new(0.5, 0.5)));
    // Not finite: never black.
    assert!(!tex.is_black_over(Vec2::splat(f32::NAN), Vec2::ONE));
}
