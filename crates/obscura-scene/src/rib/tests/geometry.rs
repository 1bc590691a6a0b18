//! Quadrics, polygons (checked against an independent area and inside test) and subdivision meshes.

use proptest::prelude::*;

use glam::Vec3;

use super::*;
use crate::types::{Mesh, Object, Shape};

#[test]
fn sphere_is_read() {
    let o = only_object("Sphere 2 -1 1.5 270");
    assert_eq!(
        o.shape,
        Shape::Sphere {
            radius: 2.0,
            z_min: -1.0,
            z_max: 1.5,
            theta_max: 270.0
        }
    );
    assert_eq!((o.material, o.micropolygon_length), (0, 1.0));
}

#[test]
fn sphere_with_wrong_arg_count_names_the_line() {
    assert_eq!(
        fail("WorldBegin\nSphere 1 -1 1"),
        "t.rib:2: Sphere expects radius zmin zmax thetamax (4 numbers), got 3"
    );
}

#[test]
fn cylinder_is_read() {
    let o = only_object("Cylinder 0.5 0 2 360");
    assert_eq!(
        o.shape,
        Shape::Cylinder {
            radius: 0.5,
            z_min: 0.0,
            z_max: 2.0,
            theta_max: 360.0
        }
    );
}

#[test]
fn cone_is_read() {
    assert_eq!(
        only_object("Cone 2 0.5 180").shape,
        Shape::Cone {
            height: 2.0,
            radius: 0.5,
            theta_max: 180.0
        }
    );
}

#[test]
fn disk_is_read() {
    assert_eq!(
        only_object("Disk 0.25 3 360").shape,
        Shape::Disk {
            height: 0.25,
            radius: 3.0,
            theta_max: 360.0
        }
    );
}

#[test]
fn torus_is_read_and_extra_parameters_are_ignored_with_a_warning() {
    let scene = ok("WorldBegin\nTorus 1 0.25 0 360 180 \"constant float foo\" [1]\n");
    assert_eq!(
        scene.objects[0].shape,
        Shape::Torus {
            major_radius: 1.0,
            minor_radius: 0.25,
            phi_min: 0.0,
            phi_max: 360.0,
            theta_max: 180.0
        }
    );
    assert_eq!(
        scene.warnings,
        vec!["t.rib:2: Torus: unknown parameter \"foo\", ignored".to_string()]
    );
}

pub(super) fn mesh(o: &Object) -> &Mesh {
    match &o.shape {
        Shape::Mesh(m) => m,
        other => panic!("expected a mesh, got {other:?}"),
    }
}

pub(super) fn tri_area(m: &Mesh, t: [u32; 3]) -> f32 {
    let [a, b, c] = t.map(|i| m.positions[i as usize]);
    (b - a).cross(c - a).length() / 2.0
}

/// Shoelace formula, written independently of the reader.
fn shoelace(poly: &[(f32, f32)]) -> f32 {
    let n = poly.len();
    (0..n)
        .map(|i| {
            let (x0, y0) = poly[i];
            let (x1, y1) = poly[(i + 1) % n];
            x0 * y1 - x1 * y0
        })
        .sum::<f32>()
        / 2.0
}

/// Even–odd crossing test, written independently of the reader.
fn inside(poly: &[(f32, f32)], (x, y): (f32, f32)) -> bool {
    let mut c = false;
    let n = poly.len();
    for i in 0..n {
        let (xi, yi) = poly[i];
        let (xj, yj) = poly[(i + n - 1) % n];
        if (yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi {
            c = !c;
        }
    }
    c
}

/// A tilted plane: 2-D (x, y) ↦ origin + x·u + y·v, u and v orthonormal (areas are kept).
fn plane_point((x, y): (f32, f32)) -> Vec3 {
    Vec3::new(1.0, 2.0, 3.0) + x * Vec3::new(0.6, 0.0, 0.8) + y * Vec3::Y
}

fn plane_coords(p: Vec3) -> (f32, f32) {
    let d = p - Vec3::new(1.0, 2.0, 3.0);
    (d.dot(Vec3::new(0.6, 0.0, 0.8)), d.y)
}

fn rib_points(points: &[(f32, f32)]) -> String {
    points
        .iter()
        .map(|&p| {
            let q = plane_point(p);
            format!("{} {} {}", q.x, q.y, q.z)
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Area sum, every triangle's centroid inside the outline and outside every hole, consistent winding.
fn check_triangulation(m: &Mesh, outline: &[(f32, f32)], holes: &[&[(f32, f32)]]) {
    let expected = shoelace(outline).abs() - holes.iter().map(|h| shoelace(h).abs()).sum::<f32>();
    let total: f32 = m.triangles.iter().map(|&t| tri_area(m, t)).sum();
    assert!(
        (total - expected).abs() < 1e-3,
        "area {total}, expected {expected}"
    );
    let plane_normal = Vec3::new(0.6, 0.0, 0.8).cross(Vec3::Y) * shoelace(outline).signum();
    for &t in &m.triangles {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        let centroid = plane_coords((a + b + c) / 3.0);
        assert!(inside(outline, centroid), "triangle {t:?} leaves the outline");
        for h in holes {
            assert!(!inside(h, centroid), "triangle {t:?} covers a hole");
        }
        assert!(
            (b - a).cross(c - a).dot(plane_normal) > 0.0,
            "triangle {t:?} is flipped"
        );
    }
}

#[test]
fn concave_polygon_is_ear_clipped_to_its_area() {
    // A comb, counter-clockwise, then a star, clockwise, both on a tilted plane.
    let comb = [
        (0.0, 0.0),
        (4.0, 0.0),
        (4.0, 1.0),
        (1.0, 1.0),
        (1.0, 2.0),
        (4.0, 2.0),
        (4.0, 3.0),
        (0.0, 3.0),
    ];
    let o = only_object(&format!("Polygon \"P\" [{}]", rib_points(&comb)));
    assert_eq!(mesh(&o).triangles.len(), comb.len() - 2);
    check_triangulation(mesh(&o), &comb, &[]);
    let star: Vec<(f32, f32)> = (0..10)
        .rev()
        .map(|k| {
            let r = if k % 2 == 0 { 2.0 } else { 0.7 };
            let a = k as f32 * std::f32::consts::PI / 5.0;
            (r * a.cos(), r * a.sin())
        })
        .collect();
    let o = only_object(&format!("Polygon \"P\" [{}]", rib_points(&star)));
    check_triangulation(mesh(&o), &star, &[]);
}

#[test]
fn polygon_with_holes_is_bridged_and_clipped_to_its_area() {
    let outline = [(0.0, 0.0), (10.0, 0.0), (10.0, 4.0), (0.0, 4.0)];
    let square = [(1.0, 1.0), (3.0, 1.0), (3.0, 3.0), (1.0, 3.0)]; // counter-clockwise, like the outline
    let slot = [(8.0, 1.0), (6.0, 1.0), (6.0, 2.0), (8.0, 2.0)]; // clockwise
    let points: Vec<(f32, f32)> = outline.iter().chain(&square).chain(&slot).copied().collect();
    let o = only_object(&format!(
        "PointsGeneralPolygons [3] [4 4 4] [0 1 2 3 4 5 6 7 8 9 10 11] \"P\" [{}]",
        rib_points(&points)
    ));
    check_triangulation(mesh(&o), &outline, &[&square, &slot]);
    // A concave outline with one hole.
    let u = [
        (0.0, 0.0),
        (6.0, 0.0),
        (6.0, 5.0),
        (4.0, 5.0),
        (4.0, 2.0),
        (2.0, 2.0),
        (2.0, 5.0),
        (0.0, 5.0),
    ];
    let hole = [(0.5, 0.5), (0.5, 1.5), (5.5, 1.5), (5.5, 0.5)];
    let points: Vec<(f32, f32)> = u.iter().chain(&hole).copied().collect();
    let o = only_object(&format!(
        "PointsGeneralPolygons [2] [8 4] [0 1 2 3 4 5 6 7 8 9 10 11] \"P\" [{}]",
        rib_points(&points)
    ));
    check_triangulation(mesh(&o), &u, &[&hole]);
}

#[test]
fn points_polygons_keep_points_and_per_vertex_normals() {
    let o = only_object(
        "PointsPolygons [4 3] [0 1 4 3 1 2 4] \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 1 0] \
         \"N\" [0 0 1 0 0 1 0 0 1 0 0 1 0 0 1]",
    );
    let m = mesh(&o);
    assert_eq!(m.positions.len(), 5);
    assert_eq!(m.normals.as_ref().map(Vec::len), Some(5));
    assert_eq!(m.triangles, vec![[0, 1, 4], [0, 4, 3], [1, 2, 4]]);
}

#[test]
fn vertex_index_out_of_range_names_the_line_and_index() {
    assert_eq!(
        fail("WorldBegin\nPointsPolygons [3] [0 1 5] \"P\" [0 0 0 1 0 0 0 1 0]\n"),
        "t.rib:2: PointsPolygons: vertex index 5 is out of range (\"P\" has 3 points)"
    );
    assert_eq!(
        fail("WorldBegin\nPointsPolygons [4] [0 1 2] \"P\" [0 0 0 1 0 0 0 1 0]\n"),
        "t.rib:2: PointsPolygons: [nverts] adds up to 4 but [verts] has 3 entries"
    );
}

#[test]
fn degenerate_polygons_are_warned_and_skipped() {
    let scene = ok("WorldBegin\nPolygon \"P\" [0 0 0 1 0 0 2 0 0]\n");
    assert!(scene.objects.is_empty());
    assert_eq!(
        scene.warnings,
        vec![
            "t.rib:2: Polygon: face 0 is degenerate (fewer than 3 distinct vertices or no area), skipped"
                .to_string()
        ]
    );
    let scene = ok("WorldBegin\nPointsPolygons [3 3] [0 0 1 0 1 2] \"P\" [0 0 0 1 0 0 0 1 0]\n");
    assert_eq!(mesh(&scene.objects[0]).triangles, vec![[0, 1, 2]]);
    assert_eq!(scene.warnings.len(), 1);
    assert!(scene.warnings[0].contains("face 0 is degenerate"));
}

#[test]
fn subdivision_mesh_reads_crease_and_boundary_tags() {
    let scene = ok(
        "WorldBegin\nSubdivisionMesh \"catmull-clark\" [4 4] [0 1 4 3 1 2 5 4] \
         [\"crease\" \"interpolateboundary\" \"corner\"] [3 1 0 0 1 1] [0 1 2 0] [2.5 10] \
         \"P\" [0 0 0 1 0 0 2 0 0 0 1 0 1 1 0 2 1 0]\n",
    );
    let Shape::Subdiv(s) = &scene.objects[0].shape else {
        panic!("not a subdivision mesh")
    };
    assert_eq!(s.positions.len(), 6);
    assert_eq!(s.face_counts, vec![4, 4]);
    assert_eq!(s.face_indices, vec![0, 1, 4, 3, 1, 2, 5, 4]);
    assert_eq!(s.creases, vec![(0, 1, 2.5), (1, 2, 2.5)]);
    assert!(s.interpolate_boundary);
    assert_eq!(
        scene.warnings,
        vec!["t.rib:2: SubdivisionMesh: tag \"corner\" is not supported, ignored".to_string()]
    );
    // Without tags.
    let o = only_object("SubdivisionMesh \"catmull-clark\" [3] [0 1 2] \"P\" [0 0 0 1 0 0 0 1 0]");
    let Shape::Subdiv(s) = &o.shape else {
        panic!("not a subdivision mesh")
    };
    assert!(s.creases.is_empty() && !s.interpolate_boundary);
}

#[test]
fn subdivision_mesh_errors_name_scheme_and_indices() {
    assert_eq!(
        fail("WorldBegin\nSubdivisionMesh \"loop\" [3] [0 1 2] \"P\" [0 0 0 1 0 0 0 1 0]"),
        "t.rib:2: SubdivisionMesh: scheme \"loop\" is not supported; expected \"catmull-clark\""
    );
    assert_eq!(
        fail(
            "WorldBegin\nSubdivisionMesh \"catmull-clark\" [3] [0 1 2] [\"crease\"] [2 1] [0 7] [1] \
              \"P\" [0 0 0 1 0 0 0 1 0]"
        ),
        "t.rib:2: SubdivisionMesh: vertex index 7 is out of range (\"P\" has 3 points)"
    );
}

/// A polygon star-shaped about the origin: simple whatever the radii, concave for most.
fn star_polygon(radii: &[f32], scale: f32) -> Vec<(f32, f32)> {
    let n = radii.len() as f32;
    radii
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let a = k as f32 * std::f32::consts::TAU / n;
            (scale * r * a.cos(), scale * r * a.sin())
        })
        .collect()
}

proptest! {
    #![proptest_config(no_persistence())]

    #[test]
    fn star_shaped_polygons_triangulate_to_their_area(
        radii in prop::collection::vec(0.3f32..2.0, 3..40),
        hole in prop::collection::vec(0.5f32..1.0, 3..12),
        with_hole: bool,
    ) {
        let outline = star_polygon(&radii, 1.0);
        // With at least 6 vertices at radius >= 0.3 the outline holds the disk of radius
        // 0.3·cos(30°) = 0.26, and the hole stays within radius 0.2.
        let with_hole = with_hole && radii.len() >= 6;
        let hole = star_polygon(&hole, 0.2);
        let text = if with_hole {
            let all: Vec<(f32, f32)> = outline.iter().chain(&hole).copied().collect();
            let verts: Vec<String> = (0..all.len()).map(|i| i.to_string()).collect();
            format!(
                "PointsGeneralPolygons [2] [{} {}] [{}] \"P\" [{}]",
                outline.len(),
                hole.len(),
                verts.join(" "),
                rib_points(&all)
            )
        } else {
            format!("Polygon \"P\" [{}]", rib_points(&outline))
        };
        let o = only_object(&text);
        let holes: Vec<&[(f32, f32)]> = if with_hole { vec![&hole] } else { vec![] };
        check_triangulation(mesh(&o), &outline, &holes);
    }
}
