//! Tests of dicing: the rate (this file), its on-screen bound, quadrics, quadrics on grids fitted
//! cell by cell and Catmull–Clark surfaces (one file each), and the helpers they share
//! (watertightness, area, edge lengths).

mod bounds;
mod fitted;
mod quadric;
mod st;
mod subdivision;

use std::collections::HashMap;

use glam::{Mat4, Vec3, Vec3A};
use obscura_scene::{Mesh, Shape, SubdivMesh};
use obscura_sdk::{DicingHint, Format, ScreenWindow};

use super::blobby::cube_corner;
use super::subdivision::{Topology, control_level, subdivision_level};
use super::*;
use crate::testing::CUBE_QUADS;

fn context(hint: DicingHint, fov: f32, distance: f32) -> DicingContext {
    let mut ctx = DicingContext::new(hint, fov, Format::new(640, 480));
    ctx.object_to_camera = Mat4::from_translation(Vec3::new(0.0, 0.0, distance));
    ctx
}

fn unit_sphere() -> Shape {
    Shape::Sphere {
        radius: 1.0,
        z_min: -1.0,
        z_max: 1.0,
        theta_max: 360.0,
    }
}

fn count(shape: &Shape, ctx: &DicingContext) -> f64 {
    dice(shape, ctx).unwrap().len() as f64
}

/// Every undirected edge with the number of triangles that use it.
fn edge_uses(mesh: &TriangleMesh) -> HashMap<(u32, u32), u32> {
    let mut uses = HashMap::new();
    for t in &mesh.triangles {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    uses
}

/// Asserts every edge is shared by exactly two triangles; returns V − E + F.
fn assert_watertight(mesh: &TriangleMesh) -> i64 {
    let uses = edge_uses(mesh);
    for (edge, n) in &uses {
        assert_eq!(*n, 2, "edge {edge:?} used by {n} triangles");
    }
    let mut used = vec![false; mesh.positions.len()];
    mesh.triangles
        .iter()
        .flatten()
        .for_each(|&i| used[i as usize] = true);
    assert!(used.iter().all(|&u| u), "unreferenced vertices");
    mesh.positions.len() as i64 - uses.len() as i64 + mesh.triangles.len() as i64
}

fn area(mesh: &TriangleMesh) -> f64 {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize].as_dvec3());
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

fn within(value: f64, expected: f64, relative: f64) -> bool {
    (value - expected).abs() <= relative * expected.abs()
}

// ---- rates ---------------------------------------------------------------------------

/// The cube [−1, 1]³, faces wound counter-clockwise seen from outside.
fn cube() -> SubdivMesh {
    let positions = (0..8).map(cube_corner).collect();
    SubdivMesh {
        positions,
        face_counts: vec![4; 6],
        face_indices: CUBE_QUADS.concat(),
        creases: Vec::new(),
        interpolate_boundary: true,
    }
}

#[test]
fn perspective_count_quarters_when_distance_doubles() {
    let near = count(&unit_sphere(), &context(DicingHint::Perspective, 90.0, 10.0));
    let far = count(&unit_sphere(), &context(DicingHint::Perspective, 90.0, 20.0));
    assert!(within(near / far, 4.0, 0.2), "{near} / {far}");
}

#[test]
fn orthographic_count_ignores_distance() {
    let near = count(&unit_sphere(), &context(DicingHint::Orthographic, 90.0, 10.0));
    let far = count(&unit_sphere(), &context(DicingHint::Orthographic, 90.0, 20.0));
    assert_eq!(near, far);
    // 640×480, default window (−4/3, 4/3): 240 pixels per unit → ⌈2π·240⌉ segments around.
    let ppu = pixels_per_unit(&context(DicingHint::Orthographic, 90.0, 10.0), Vec3::ZERO, 1.0);
    assert!((ppu - 240.0).abs() < 1e-3, "{ppu}");
}

#[test]
fn spherical_count_follows_angular_size() {
    let near = count(&unit_sphere(), &context(DicingHint::Spherical, 90.0, 10.0));
    let far = count(&unit_sphere(), &context(DicingHint::Spherical, 90.0, 20.0));
    assert!(within(near / far, 4.0, 0.2), "{near} / {far}");
}

#[test]
fn spherical_rate_is_the_shorter_side_over_the_field_of_view() {
    for (w, h) in [(640, 480), (480, 640), (1000, 250)] {
        for fov in [90.0f32, 170.0, 360.0] {
            let mut ctx = context(DicingHint::Spherical, fov, 10.0);
            ctx.format = Format::new(w, h);
            ctx.screen_window = ScreenWindow::default_for(ctx.format);
            let expected = w.min(h) as f32 / fov.to_radians() / (10.0 - 1.0);
            let got = pixels_per_unit(&ctx, Vec3::ZERO, 1.0);
            assert!(
                (got / expected - 1.0).abs() < 1e-5,
                "{w}×{h} fov {fov}: {got} vs {expected}"
            );
        }
    }
}

#[test]
fn perspective_rate_matches_the_pinhole_formula() {
    // d = 1/tan(fov/2), nearest depth 10 − 2 (radius 1 scaled by 2), 240 pixels per screen unit.
    let mut ctx = context(DicingHint::Perspective, 40.0, 10.0);
    ctx.object_to_camera *= Mat4::from_scale(Vec3::new(1.0, 2.0, 0.5));
    let expected = 2.0 * 240.0 / (20.0f32.to_radians().tan() * 8.0);
    let got = pixels_per_unit(&ctx, Vec3::ZERO, 1.0);
    assert!((got / expected - 1.0).abs() < 1e-5, "{got} vs {expected}");
}

#[test]
fn narrow_field_of_view_dices_finer() {
    let narrow = count(&unit_sphere(), &context(DicingHint::Perspective, 20.0, 20.0));
    let wide = count(&unit_sphere(), &context(DicingHint::Perspective, 90.0, 20.0));
    // d grows from 1 to 5.67: about 32 times the triangles.
    assert!(narrow > 20.0 * wide, "{narrow} vs {wide}");
}

#[test]
fn doubling_micropolygon_length_quarters_the_count() {
    let mut ctx = context(DicingHint::Perspective, 90.0, 10.0);
    let fine = count(&unit_sphere(), &ctx);
    ctx.micropolygon_length = 2.0;
    let coarse = count(&unit_sphere(), &ctx);
    assert!(within(fine / coarse, 4.0, 0.2), "{fine} / {coarse}");
}

#[test]
fn diced_edges_are_about_one_micropolygon_long() {
    for mpl in [1.0f32, 3.0] {
        let mut ctx = context(DicingHint::Perspective, 90.0, 10.0);
        ctx.micropolygon_length = mpl;
        let mesh = dice(&unit_sphere(), &ctx).unwrap();
        let ppu = pixels_per_unit(&ctx, Vec3::ZERO, 1.0);
        // The same measure the rate uses, and a real pinhole projection to raster.
        let raster = |p: Vec3A| {
            let c = ctx.object_to_camera.transform_point3(Vec3::from(p));
            glam::Vec2::new(c.x, c.y) / c.z * 240.0
        };
        let (mut by_rate, mut projected) = (0.0f32, 0.0f32);
        for (a, b) in edge_uses(&mesh)
            .keys()
            .map(|&(a, b)| (mesh.positions[a as usize], mesh.positions[b as usize]))
        {
            by_rate = by_rate.max(a.distance(b) * ppu);
            projected = projected.max(raster(a).distance(raster(b)));
        }
        assert!(
            by_rate <= 1.5 * mpl && by_rate >= 0.25 * mpl,
            "mpl {mpl}: {by_rate}"
        );
        assert!(
            projected <= 1.5 * mpl && projected >= 0.25 * mpl,
            "mpl {mpl}: {projected}"
        );
    }
}

#[test]
fn subdivision_level_follows_the_rate() {
    let near = count(
        &Shape::Subdiv(cube()),
        &context(DicingHint::Perspective, 90.0, 40.0),
    );
    let far = count(
        &Shape::Subdiv(cube()),
        &context(DicingHint::Perspective, 90.0, 80.0),
    );
    assert_eq!(near / far, 4.0);
    let ctx = context(DicingHint::Perspective, 90.0, 40.0);
    let level = control_level(&cube()).unwrap();
    let topology = Topology::build(&level).unwrap();
    let levels = subdivision_level(&level, &topology, &ctx);
    let ppu = pixels_per_unit(&ctx, Vec3::ZERO, 3.0f32.sqrt());
    let edge_pixels = 2.0 * ppu / (1u32 << levels) as f32;
    assert!(
        edge_pixels <= 1.0 && edge_pixels > 0.5,
        "level {levels}: {edge_pixels} px"
    );
}

#[test]
fn meshes_pass_through_with_their_normals() {
    let mesh = Mesh {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        normals: Some(vec![Vec3::Z; 3]),
        triangles: vec![[0, 1, 2]],
        ..Mesh::default()
    };
    let ctx = context(DicingHint::Perspective, 90.0, 10.0);
    let out = dice(&Shape::Mesh(mesh.clone()), &ctx).unwrap();
    assert_eq!(out.triangles, mesh.triangles);
    assert_eq!(out.positions[1], Vec3A::X);
    assert_eq!(out.normals, Some(vec![Vec3A::Z; 3]));
    let bad = Mesh {
        triangles: vec![[0, 1, 2], [2, 1, 3]],
        ..mesh
    };
    assert_eq!(
        dice(&Shape::Mesh(bad), &ctx),
        Err(DiceError::MeshIndexOutOfRange {
            triangle: 1,
            index: 3,
            vertex_count: 3
        })
    );
}
