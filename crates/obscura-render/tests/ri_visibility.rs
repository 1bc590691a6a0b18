//! The RI requests that change what the camera sees or writes, rendered end to end from RIB and
//! checked pixel by pixel against closed forms: `Exposure`, `Sides` with `Orientation` and
//! `ReverseOrientation`, and `ClippingPlane`.

mod common;

use common::render_rib;

use obscura_image::film::Film;

/// A `size`² image through a 90° pinhole, 4 samples per pixel, box filter.
fn camera(size: u32) -> String {
    format!(
        "Format {size} {size} 1\nPixelFilter \"box\" 1 1\nHider \"raytrace\" \"int maxsamples\" [4]\nProjection \"perspective\" \"fov\" [90]\n"
    )
}

/// Alpha of every pixel of an `n`² film, row by row.
fn alphas(film: &Film, n: u32) -> Vec<f32> {
    (0..n)
        .flat_map(|y| (0..n).map(move |x| (x, y)))
        .map(|(x, y)| film.pixel(x, y).alpha)
        .collect()
}

#[test]
fn exposure_writes_gain_then_gamma_of_the_filtered_colour() {
    // A constant surface filling the frame: every pixel's Ci is Cs; written, (Cs·gain)^(1/gamma).
    let cs = [0.5f32, 0.25, 0.1];
    let scene = |exposure: &str| {
        format!(
            "{}{exposure}WorldBegin\nColor [{} {} {}]\nSurface \"constant\"\nSphere 10 -10 10 360\nWorldEnd\n",
            camera(6),
            cs[0],
            cs[1],
            cs[2]
        )
    };
    let (gain, gamma) = (2.0f32, 2.2f32);
    let plain = render_rib(&scene(""));
    let exposed = render_rib(&scene(&format!("Exposure {gain} {gamma}\n")));
    for y in 0..6 {
        for x in 0..6 {
            let (p, e) = (plain.pixel(x, y), exposed.pixel(x, y));
            for (k, (c, got)) in [(p.ci.r, e.ci.r), (p.ci.g, e.ci.g), (p.ci.b, e.ci.b)]
                .into_iter()
                .enumerate()
            {
                assert!((c - cs[k]).abs() < 1e-5, "unexposed {c} vs Cs {}", cs[k]);
                let want = (f64::from(cs[k]) * f64::from(gain)).powf(1.0 / f64::from(gamma)) as f32;
                assert!(
                    (got - want).abs() < 1e-5,
                    "pixel ({x}, {y}) channel {k}: {got} vs {want}"
                );
            }
            // Alpha and depth are not colour: untouched.
            assert_eq!((e.alpha, e.z), (p.alpha, p.z));
        }
    }
}

#[test]
fn a_one_sided_sphere_shows_its_outside_and_reverse_orientation_its_inside() {
    let n = 8;
    let outside = |attrs: &str| {
        alphas(
            &render_rib(&format!(
                "{}WorldBegin\n{attrs}Surface \"constant\"\nTranslate 0 0 5\nSphere 2 -2 2 360\nWorldEnd\n",
                camera(n)
            )),
            n,
        )
    };
    let inside = |attrs: &str| {
        alphas(
            &render_rib(&format!(
                "{}WorldBegin\n{attrs}Surface \"constant\"\nSphere 10 -10 10 360\nWorldEnd\n",
                camera(n)
            )),
            n,
        )
    };
    let centre = |a: &[f32]| a[(n / 2 * n + n / 2) as usize];
    // Seen from outside: its front (outside) faces the camera, one-sided or not.
    assert_eq!(centre(&outside("Sides 1\n")), 1.0);
    assert_eq!(centre(&outside("")), 1.0);
    // From inside (the camera within it): only the back is in view.
    assert!(inside("Sides 1\n").iter().all(|a| *a == 0.0));
    assert!(inside("").iter().all(|a| *a == 1.0));
    // ReverseOrientation (or Orientation "inside") makes the inside the front.
    assert!(inside("Sides 1\nReverseOrientation\n").iter().all(|a| *a == 1.0));
    assert!(
        inside("Sides 1\nOrientation \"inside\"\n")
            .iter()
            .all(|a| *a == 1.0)
    );
    // Seen from outside, a reversed one-sided sphere hides its near half and shows the inside of
    // its far half: the depth of the pixel at screen [0, ¼] × [−¼, 0] is the far root of a ray in it,
    // between 7 (the pole, at its corner (0, 0)) and 5.49 (its corner (¼, −¼)); the near half would
    // be nearer than 5.
    let film = render_rib(&format!(
        "{}WorldBegin\nSides 1\nReverseOrientation\nSurface \"constant\"\nTranslate 0 0 5\nSphere 2 -2 2 360\nWorldEnd\n",
        camera(n)
    ));
    let z = film.pixel(n / 2, n / 2).z;
    assert!((5.48..=7.0).contains(&z), "far inside at z {z}");
    // An attribute block restores two-sidedness.
    assert!(
        inside("AttributeBegin\nSides 1\nAttributeEnd\n")
            .iter()
            .all(|a| *a == 1.0)
    );
}

#[test]
fn a_polygons_front_is_its_clockwise_side_and_a_mirror_keeps_it() {
    // RISpec 3.2 §5.1: under the default (left-handed) orientation a polygon whose vertices run
    // clockwise as the camera sees them faces the camera. Up the left edge, along the top, down the
    // right: clockwise on screen (+x right, +y up).
    let clockwise = "Polygon \"P\" [-5 -5 5  -5 5 5  5 5 5  5 -5 5]";
    let counter = "Polygon \"P\" [-5 -5 5  5 -5 5  5 5 5  -5 5 5]";
    let n = 4;
    let seen = |body: &str| {
        let a = alphas(
            &render_rib(&format!(
                "{}WorldBegin\nSides 1\nSurface \"constant\"\n{body}\nWorldEnd\n",
                camera(n)
            )),
            n,
        );
        assert!(a.iter().all(|v| *v == a[0]), "all or nothing: {a:?}");
        a[0] == 1.0
    };
    assert!(seen(clockwise));
    assert!(!seen(counter));
    // `Scale -1 1 1` mirrors the clockwise polygon into a counter-clockwise one on screen, and
    // flips the current orientation to right-handed with the coordinate system: RISpec 3.2 §4.2.14,
    // a right-handed orientation's front is the counter-clockwise side. It still faces the camera.
    assert!(seen(&format!("Scale -1 1 1\n{clockwise}")));
    assert!(!seen(&format!("Scale -1 1 1\n{counter}")));
    // Asking for left-handed in the mirrored space turns it inside out.
    assert!(!seen(&format!("Scale -1 1 1\nOrientation \"lh\"\n{clockwise}")));
    assert!(seen(&format!("Orientation \"rh\"\n{counter}")));
}

/// The far root `t` (= camera z for a direction with z = 1) of the ray `t·(sx, sy, 1)` on the unit
/// sphere centred at (0, 0, 2); `None` when it misses.
fn far_root(sx: f64, sy: f64) -> Option<f64> {
    let dd = sx * sx + sy * sy + 1.0;
    // |t·d − c|² = 1 with c = (0, 0, 2): dd·t² − 4t + 3 = 0.
    let disc = 16.0 - 12.0 * dd;
    (disc >= 0.0).then(|| (4.0 + disc.sqrt()) / (2.0 * dd))
}

#[test]
fn a_sphere_cut_through_its_centre_shows_its_far_inside_through_the_cut() {
    // A unit sphere at z = 2 seen through a 90° pinhole (screen = direction x/z, y/z), cut by the plane
    // through its centre whose normal points at the camera: the near half is clipped. Through the
    // cut's circle (screen radius ½) the camera sees the far half's inside; between ½ and the
    // silhouette (tan 30° = 0.577) both hits lie in the near half, so the background shows.
    let n = 64u32;
    let scene = |attrs: &str, planes: &str| {
        render_rib(&format!(
            "{}WorldBegin\n{attrs}Surface \"constant\"\nTranslate 0 0 2\n{planes}Sphere 1 -1 1 360\nWorldEnd\n",
            camera(n)
        ))
    };
    let cut = "ClippingPlane 0 0 0 0 0 -1\n";
    let clipped = scene("", cut);
    let whole = scene("", "");
    let one_sided = scene("Sides 1\n", cut);
    // The second plane (x > 0 clipped) accumulates with the first.
    let halved = scene("", &format!("{cut}ClippingPlane 0 0 0 1 0 0\n"));
    let screen = |x: f64, y: f64| (-1.0 + 2.0 * x / f64::from(n), 1.0 - 2.0 * y / f64::from(n));
    let (mut inside, mut annulus) = (0, 0);
    for y in 0..n {
        for x in 0..n {
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .map(|(dx, dy)| screen(f64::from(x) + dx, f64::from(y) + dy));
            let radii = corners.map(|(sx, sy)| sx.hypot(sy));
            let (r_lo, r_hi) = (
                radii.iter().copied().fold(f64::MAX, f64::min),
                radii.iter().copied().fold(0.0, f64::max),
            );
            let (c, w, o, h) = (
                clipped.pixel(x, y),
                whole.pixel(x, y),
                one_sided.pixel(x, y),
                halved.pixel(x, y),
            );
            if r_hi < 0.5 - 1e-3 {
                inside += 1;
                assert_eq!(c.alpha, 1.0, "pixel ({x}, {y}) inside the cut");
                // Its depth is the far root somewhere in the pixel.
                let roots = corners.map(|(sx, sy)| far_root(sx, sy).expect("inside the silhouette"));
                let (lo, hi) = (
                    roots.iter().copied().fold(f64::MAX, f64::min),
                    roots.iter().copied().fold(0.0, f64::max),
                );
                let z = f64::from(c.z);
                assert!(
                    z >= lo - 1e-3 && z <= hi + 1e-3,
                    "pixel ({x}, {y}): z {z} outside [{lo}, {hi}]"
                );
                assert!(z > 2.0, "the far half");
                // The unclipped sphere shows its near side there.
                assert!(f64::from(w.z) < 2.0);
                // One-sided: the inside is its back, so nothing shows.
                assert_eq!(o.alpha, 0.0, "pixel ({x}, {y}), Sides 1");
                let xs = corners.map(|p| p.0);
                if xs.iter().all(|sx| *sx > 1e-3) {
                    assert_eq!(h.alpha, 0.0, "pixel ({x}, {y}) right of the second plane");
                } else if xs.iter().all(|sx| *sx < -1e-3) {
                    assert_eq!(h.alpha, 1.0, "pixel ({x}, {y}) left of the second plane");
                }
            } else if r_lo > 0.5 + 1e-3 && r_hi < 0.577 - 1e-3 {
                annulus += 1;
                assert_eq!(
                    c.alpha, 0.0,
                    "pixel ({x}, {y}) between the cut and the silhouette"
                );
                assert_eq!(w.alpha, 1.0, "pixel ({x}, {y}): the whole sphere covers it");
            } else if r_lo > 0.6 {
                assert_eq!(c.alpha + w.alpha, 0.0, "pixel ({x}, {y}) off the sphere");
            }
        }
    }
    assert!(
        inside > 500 && annulus > 20,
        "{inside} pixels inside the cut, {annulus} in the annulus"
    );
}
