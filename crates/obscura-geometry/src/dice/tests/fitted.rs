//! Quadrics on grids fitted cell by cell: nebula's sky sphere, watertightness and the surface over
//! random cameras, all seven quadrics through the one fitting, each dicing hint.

use std::f64::consts::{PI, TAU};

use glam::{DVec3, Mat4, Quat, Vec2, Vec3, Vec4};
use obscura_scene::Shape;
use obscura_sdk::{DicingHint, Format};
use proptest::prelude::*;

use super::*;
use crate::dice::quadric::{Grid, tessellate};

/// The segments the uniform rule of `quadric`'s documentation gives an arc at `k` pixels per unit:
/// `clamp(⌈arc·k/m⌉, min, MAX_SEGMENTS)` with m = 1.
fn uniform_segments(arc: f64, k: f32, min: u32) -> u64 {
    ((arc * f64::from(k)).ceil() as u64).clamp(u64::from(min), u64::from(MAX_SEGMENTS))
}

/// The triangles of a full sphere of radius `r` on the uniform grid: `2·nu·(nv − 1)` (the two
/// pole rows are fans).
fn uniform_sphere_triangles(ctx: &DicingContext, r: f32) -> u64 {
    let k = pixels_per_unit(ctx, Vec3::ZERO, r);
    let nu = uniform_segments(TAU * f64::from(r), k, 4);
    let nv = uniform_segments(PI * f64::from(r), k, 2);
    2 * nu * (nv - 1)
}

/// nebula.rib's star field (`Sphere 65 -65 65 360`) seen from 2 units off its centre through
/// `Projection "perspective" "fov" [40]` at 160×120, looking at its +z pole or (as the file's
/// `Rotate 180 0 1 0` does) at its −z pole.
fn nebula(look_at_minus_z: bool) -> DicingContext {
    let mut ctx = DicingContext::new(DicingHint::Perspective, 40.0, Format::new(160, 120));
    ctx.object_to_camera = Mat4::from_translation(Vec3::new(0.0, 0.0, 2.0));
    if look_at_minus_z {
        ctx.object_to_camera *= Mat4::from_rotation_y(std::f32::consts::PI);
    }
    ctx
}

fn sky_sphere() -> Shape {
    Shape::Sphere {
        radius: 65.0,
        z_min: -65.0,
        z_max: 65.0,
        theta_max: 360.0,
    }
}

/// The triangles of a full sphere of radius `r` on the uniform grid of `nu × nv` cells, built
/// here from the sphere's own formula.
fn uniform_sphere(r: f64, nu: u32, nv: u32) -> TriangleMesh {
    let pole = |z: f64| Some((DVec3::new(0.0, 0.0, z * r), DVec3::new(0.0, 0.0, z)));
    let grid = Grid {
        nu,
        nv,
        wrap_u: true,
        wrap_v: false,
        pole0: pole(-1.0),
        pole1: pole(1.0),
    };
    tessellate(&grid, |u, v| {
        let (theta, phi) = (u * TAU, (v - 0.5) * PI);
        let n = DVec3::new(phi.cos() * theta.cos(), phi.cos() * theta.sin(), phi.sin());
        (n * r, n)
    })
}

/// The longest edge, in pixels, of the triangles whose three vertices a pinhole camera of `ctx`
/// (perspective, default screen window) sees, and how many such triangles there are.
fn longest_edge_in_view(mesh: &TriangleMesh, ctx: &DicingContext) -> (f32, usize) {
    let d = 1.0 / (0.5 * ctx.field_of_view.to_radians()).tan();
    let (w, h) = (ctx.format.width as f32, ctx.format.height as f32);
    let half = Vec2::new(w / h, 1.0);
    let pixels_per_screen_unit = h / 2.0;
    let raster = |p: Vec3A| {
        let c = ctx.object_to_camera.transform_point3(Vec3::from(p));
        let screen = Vec2::new(c.x, c.y) * d / c.z;
        (c.z > 0.0 && screen.abs().cmple(half).all()).then_some(screen * pixels_per_screen_unit)
    };
    let (mut longest, mut seen) = (0.0f32, 0);
    for t in &mesh.triangles {
        if let [Some(a), Some(b), Some(c)] = t.map(|i| raster(mesh.positions[i as usize])) {
            seen += 1;
            longest = longest.max(a.distance(b)).max(b.distance(c)).max(c.distance(a));
        }
    }
    (longest, seen)
}

#[test]
fn nebulas_sky_sphere_dices_its_view_as_before_and_the_rest_coarsely() {
    for look_at_minus_z in [false, true] {
        let ctx = nebula(look_at_minus_z);
        let mesh = dice(&sky_sphere(), &ctx).unwrap();
        // The camera is inside: the uniform grid takes the whole image's 16·19200 micropolygons
        // over the whole sphere (613,088 triangles; 0.28 s of setup a frame in the release build).
        let uniform = uniform_sphere_triangles(&ctx, 65.0);
        assert_eq!(uniform, 613_088);
        let n = mesh.len() as u64;
        assert!(4 * n <= uniform, "{n} triangles vs {uniform} on the uniform grid");
        // In view, as fine as the uniform grid: its longest edge on screen is 1.90 pixels (the
        // coverage cap spreads 16 micropolygons per pixel over the whole sphere, and the view looks
        // at it from 2 units off its centre, nearer than its radius); the fitted grid's cells in
        // view have the same rate, but only as many segments around as their own circle needs
        // where the uniform grid takes the equator's everywhere.
        let k = pixels_per_unit(&ctx, Vec3::ZERO, 65.0);
        let nu = (TAU * 65.0 * f64::from(k)).ceil() as u32;
        let nv = (PI * 65.0 * f64::from(k)).ceil() as u32;
        let (uniform_edge, _) = longest_edge_in_view(&uniform_sphere(65.0, nu, nv), &ctx);
        let (edge, seen) = longest_edge_in_view(&mesh, &ctx);
        assert!(seen > 10_000, "{seen} triangles in view");
        assert!((1.85..1.95).contains(&uniform_edge), "{uniform_edge}");
        assert!(
            edge <= 1.15 * uniform_edge,
            "{edge} px on screen vs {uniform_edge} on the uniform grid"
        );
    }
}

/// Asserts every vertex of `mesh` is within `1e-4·scale` of the surface `distance` measures.
fn assert_on_surface(mesh: &TriangleMesh, distance: impl Fn(DVec3) -> f64, scale: f64) {
    for p in &mesh.positions {
        let d = distance(p.as_dvec3());
        assert!(d.abs() < 1e-4 * scale, "{p} is {d} off the surface");
    }
}

#[test]
fn a_fitted_sphere_is_closed_and_on_its_surface() {
    let ctx = nebula(true);
    let mesh = dice(&sky_sphere(), &ctx).unwrap();
    assert_eq!(assert_watertight(&mesh), 2);
    assert_on_surface(&mesh, |p| p.length() - 65.0, 65.0);
    // Fitted, not uniform: the rings of vertices lie at unequal steps of latitude, fine in view
    // (around the −z pole) and coarse elsewhere.
    let mut rings: Vec<f64> = mesh
        .positions
        .iter()
        .map(|p| (f64::from(p.z) / 65.0).clamp(-1.0, 1.0).asin())
        .collect();
    rings.sort_by(f64::total_cmp);
    rings.dedup_by(|a, b| (*a - *b).abs() < 1e-5);
    let steps: Vec<f64> = rings.windows(2).map(|w| w[1] - w[0]).collect();
    let (fine, coarse) = (
        steps.iter().copied().fold(f64::INFINITY, f64::min),
        steps.iter().copied().fold(0.0, f64::max),
    );
    assert!(coarse > 5.0 * fine, "latitude steps from {fine} to {coarse}");
    assert!(rings.len() < 200, "{} rings", rings.len());
}

/// A 64×48 camera at `eye` (object space) looking along object +x with object +z up.
fn looking_along_x(hint: DicingHint, fov: f32, eye: Vec3) -> DicingContext {
    let mut ctx = DicingContext::new(hint, fov, Format::new(64, 48));
    // Object x → camera z (the view), object y → camera −x, object z → camera y.
    let to_camera = Mat4::from_cols(
        Vec4::new(0.0, 0.0, 1.0, 0.0),
        Vec4::new(-1.0, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 1.0, 0.0, 0.0),
        Vec4::W,
    );
    ctx.object_to_camera = to_camera * Mat4::from_translation(-eye);
    ctx
}

/// The seven quadrics, each about ten units across, with the triangles its uniform grid would
/// hold at `ctx` (the arcs of `quadric`'s tables) and its distance from the analytic surface.
struct Large {
    shape: Shape,
    uniform: fn(&DicingContext) -> u64,
    distance: fn(DVec3) -> f64,
}

fn large_quadrics() -> Vec<Large> {
    // (arcs around and along, the rate's sphere, the fewest segments along, pole fans).
    fn count(
        ctx: &DicingContext,
        around: f64,
        along: f64,
        centre: Vec3,
        radius: f32,
        min_v: u32,
        fans: u64,
    ) -> u64 {
        let k = pixels_per_unit(ctx, centre, radius);
        let (nu, nv) = (uniform_segments(around, k, 4), uniform_segments(along, k, min_v));
        2 * nu * nv - fans * nu
    }
    // The cone and the paraboloid: 10 across, 10 high, one pole fan.
    fn pointed(ctx: &DicingContext, min_v: u32) -> u64 {
        let centre = Vec3::new(0.0, 0.0, 5.0);
        count(ctx, TAU * 10.0, 200f64.sqrt(), centre, 125f32.sqrt(), min_v, 1)
    }
    vec![
        Large {
            shape: Shape::Sphere {
                radius: 10.0,
                z_min: -10.0,
                z_max: 10.0,
                theta_max: 360.0,
            },
            uniform: |c| count(c, TAU * 10.0, PI * 10.0, Vec3::ZERO, 10.0, 2, 2),
            distance: |p| p.length() - 10.0,
        },
        Large {
            shape: Shape::Cylinder {
                radius: 10.0,
                z_min: -10.0,
                z_max: 10.0,
                theta_max: 360.0,
            },
            uniform: |c| count(c, TAU * 10.0, 20.0, Vec3::ZERO, 200f32.sqrt(), 1, 0),
            distance: |p| p.truncate().length() - 10.0,
        },
        Large {
            shape: Shape::Cone {
                height: 10.0,
                radius: 10.0,
                theta_max: 360.0,
            },
            uniform: |c| pointed(c, 1),
            distance: |p| p.truncate().length() - (10.0 - p.z),
        },
        Large {
            shape: Shape::Disk {
                height: -1.0,
                radius: 10.0,
                theta_max: 360.0,
            },
            uniform: |c| count(c, TAU * 10.0, 10.0, Vec3::new(0.0, 0.0, -1.0), 10.0, 1, 1),
            distance: |p| p.z + 1.0,
        },
        Large {
            shape: Shape::Torus {
                major_radius: 7.0,
                minor_radius: 3.0,
                phi_min: 0.0,
                phi_max: 360.0,
                theta_max: 360.0,
            },
            uniform: |c| count(c, TAU * 10.0, TAU * 3.0, Vec3::ZERO, 10.0, 4, 0),
            distance: |p| torus_distance(p, 7.0, 3.0),
        },
        Large {
            shape: Shape::Hyperboloid {
                point1: Vec3::new(10.0, 0.0, -10.0),
                point2: Vec3::new(0.0, 10.0, 10.0),
                theta_max: 360.0,
            },
            uniform: |c| count(c, TAU * 10.0, 600f64.sqrt(), Vec3::ZERO, 200f32.sqrt(), 1, 0),
            // The ruled line at height z, turned about z: its distance from the axis.
            distance: |p| {
                let v = (p.z + 10.0) / 20.0;
                let q = DVec3::new(10.0, 0.0, -10.0).lerp(DVec3::new(0.0, 10.0, 10.0), v);
                p.truncate().length() - q.truncate().length()
            },
        },
        Large {
            shape: Shape::Paraboloid {
                radius: 10.0,
                z_min: 0.0,
                z_max: 10.0,
                theta_max: 360.0,
            },
            uniform: |c| pointed(c, 2),
            distance: |p| p.truncate().length() - 10.0 * (p.z / 10.0).max(0.0).sqrt(),
        },
    ]
}

#[test]
fn all_seven_quadrics_are_fitted_under_each_dicing_hint() {
    for hint in [
        DicingHint::Perspective,
        DicingHint::Orthographic,
        DicingHint::Spherical,
    ] {
        let fov = if hint == DicingHint::Spherical {
            360.0
        } else {
            60.0
        };
        // Inside each quadric (or just above the disk), half of it behind the camera.
        let ctx = looking_along_x(hint, fov, Vec3::new(0.0, 0.0, 1.0));
        for q in large_quadrics() {
            let mesh = dice(&q.shape, &ctx).unwrap();
            let (n, uniform) = (mesh.len() as u64, (q.uniform)(&ctx));
            assert!(
                2 * n <= uniform,
                "{hint:?} {:?}: {n} triangles vs {uniform} uniform",
                q.shape
            );
            assert_on_surface(&mesh, q.distance, 10.0);
        }
    }
}

#[test]
fn small_and_distant_quadrics_keep_the_uniform_grid() {
    // The test's uniform formula is the dicer's: far away every quadric holds at most
    // UNIFORM_GRID_QUADS quads and dices to exactly that count.
    for distance in [60.0, 400.0] {
        let ctx = looking_along_x(DicingHint::Perspective, 60.0, Vec3::new(-distance, 0.0, 0.0));
        for q in large_quadrics() {
            let uniform = (q.uniform)(&ctx);
            assert!(uniform <= 2 * UNIFORM_GRID_QUADS, "{:?}: {uniform}", q.shape);
            assert_eq!(
                dice(&q.shape, &ctx).unwrap().len() as u64,
                uniform,
                "{:?}",
                q.shape
            );
        }
    }
}

#[test]
fn a_spherical_camera_dices_what_is_behind_it_at_its_own_angular_rate() {
    // 360° across 64×48: 48/2π pixels per radian everywhere, behind the camera too. Cells behind
    // measured as off screen would be diced at the off-screen cap, edges of many pixels.
    let per_radian = 48.0 / std::f32::consts::TAU;
    for eye in [Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0)] {
        let ctx = looking_along_x(DicingHint::Spherical, 360.0, eye);
        for q in large_quadrics().into_iter().filter(|q| {
            matches!(
                q.shape,
                Shape::Sphere { .. } | Shape::Cylinder { .. } | Shape::Torus { .. }
            )
        }) {
            let mesh = dice(&q.shape, &ctx).unwrap();
            let longest = mesh
                .triangles
                .iter()
                .flat_map(|t| {
                    let [a, b, c] = t.map(|i| (Vec3::from(mesh.positions[i as usize]) - eye).normalize());
                    [a.angle_between(b), b.angle_between(c), c.angle_between(a)]
                })
                .fold(0.0f32, f32::max);
            assert!(
                longest * per_radian <= 1.5,
                "{eye} {:?}: {} px",
                q.shape,
                longest * per_radian
            );
            assert!(4 * mesh.len() as u64 <= (q.uniform)(&ctx), "{:?}", q.shape);
        }
    }
}

/// The distance of `p` from a torus of radii `big`, `small` about z.
fn torus_distance(p: DVec3, big: f64, small: f64) -> f64 {
    DVec3::new(p.truncate().length() - big, 0.0, p.z).length() - small
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn fitted_spheres_and_tori_are_closed_on_their_surfaces_and_never_finer(
        torus in any::<bool>(),
        eye in (-2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0),
        axis in (-1.0f32..1.0, -1.0f32..1.0, 0.1f32..1.0),
        angle in 0.0f32..std::f32::consts::TAU,
        hint in prop_oneof![
            Just(DicingHint::Perspective), Just(DicingHint::Orthographic), Just(DicingHint::Spherical)
        ],
        fov in 30.0f32..120.0,
    ) {
        let mut ctx = DicingContext::new(hint, fov, Format::new(64, 48));
        let turn = Quat::from_axis_angle(Vec3::new(axis.0, axis.1, axis.2).normalize(), angle);
        ctx.object_to_camera = Mat4::from_quat(turn) * Mat4::from_translation(-Vec3::new(eye.0, eye.1, eye.2));
        let (shape, uniform, euler) = if torus {
            let shape = Shape::Torus {
                major_radius: 1.0, minor_radius: 0.35, phi_min: 0.0, phi_max: 360.0, theta_max: 360.0,
            };
            let k = pixels_per_unit(&ctx, Vec3::ZERO, 1.35);
            let nu = uniform_segments(TAU * 1.35, k, 4);
            let nv = uniform_segments(TAU * 0.35, k, 4);
            (shape, 2 * nu * nv, 0)
        } else {
            (unit_sphere(), uniform_sphere_triangles(&ctx, 1.0), 2)
        };
        let mesh = dice(&shape, &ctx).unwrap();
        prop_assert!(mesh.len() as u64 <= uniform, "{} vs {}", mesh.len(), uniform);
        prop_assert_eq!(assert_watertight(&mesh), euler);
        if torus {
            assert_on_surface(&mesh, |p| torus_distance(p, 1.0, 0.35), 1.0);
        } else {
            assert_on_surface(&mesh, |p| p.length() - 1.0, 1.0);
        }
    }
}

#[test]
fn a_sphere_in_view_keeps_its_uniform_grid_unless_fitting_halves_it() {
    // ground_truth.rs's fisheye sphere: fitted cell by cell its limb, 1.4 times farther than its
    // nearest point, would be diced coarser (39,400 triangles instead of 60,024) and its depth
    // along grazing rays less exact; a third fewer triangles is not worth that.
    let mut ctx = DicingContext::new(DicingHint::Spherical, 180.0, Format::new(96, 72));
    ctx.object_to_camera = Mat4::from_translation(Vec3::new(0.3, -0.2, 4.0));
    ctx.micropolygon_length = 0.25;
    let sphere = Shape::Sphere {
        radius: 1.2,
        z_min: -1.2,
        z_max: 1.2,
        theta_max: 360.0,
    };
    let k = pixels_per_unit(&ctx, Vec3::ZERO, 1.2);
    let nu = uniform_segments(TAU * 1.2 * 4.0, k, 4);
    let nv = uniform_segments(PI * 1.2 * 4.0, k, 2);
    assert_eq!(dice(&sphere, &ctx).unwrap().len() as u64, 2 * nu * (nv - 1));
    assert!(
        nu * nv > 4 * UNIFORM_GRID_QUADS,
        "{nu} × {nv}: large enough to be fitted"
    );
}
