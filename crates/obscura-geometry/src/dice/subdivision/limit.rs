//! The Catmull–Clark limit surface of an all-quad level: limit positions, limit normals (exact tangent
//! masks at smooth interior vertices) and the triangulation along each quad's shorter diagonal.

use std::f64::consts::TAU;

use glam::DVec3;
use rayon::prelude::*;

use super::Level;
use super::topology::Topology;
use crate::ray::TriangleMesh;

/// triangulates.
pub(super) fn limit_surface(level: &Level, topology: &Topology) -> TriangleMesh {
    let p = &level.positions;
    let n = p.len();
    let limits: Vec<DVec3> = (0..n as u32)
        .into_par_iter()
        .map(|v| limit_position(level, topology, v))
        .collect();

    let mut triangles = Vec::with_capacity(2 * level.face_count());
    let mut averaged = vec![DVec3::ZERO; n];
    for f in 0..level.face_count() {
        let q = level.face(f);
        if q.len() != 4 {
            continue;
        }
        let l = |i: usize| limits[q[i] as usize];
        let pair = if l(0).distance_squared(l(2)) <= l(1).distance_squared(l(3)) {
            [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
        } else {
            [[q[0], q[1], q[3]], [q[1], q[2], q[3]]]
        };
        for t in pair {
            let [a, b, c] = t.map(|i| limits[i as usize]);
            let area_normal = (b - a).cross(c - a);
            for i in t {
                averaged[i as usize] += area_normal;
            }
            triangles.push(t);
        }
    }
    let normals: Vec<DVec3> = (0..n as u32)
        .into_par_iter()
        .map_init(Vec::new, |ring, v| {
            let average = averaged[v as usize].normalize_or_zero();
            match tangent_normal(level, topology, v, ring) {
                Some(exact) if average == DVec3::ZERO || exact.dot(average) >= 0.0 => exact,
                Some(exact) => -exact,
                None if average != DVec3::ZERO => average,
                None => DVec3::Z,
            }
        })
        .collect();

    // Drop control points no face uses, keeping the order (control point i stays vertex i when all
    // control points are used).
    let mut used = vec![false; n];
    triangles.iter().flatten().for_each(|&i| used[i as usize] = true);
    let mut remap = vec![0u32; n];
    let mut positions = Vec::new();
    let mut kept_normals = Vec::new();
    for v in (0..n).filter(|&v| used[v]) {
        remap[v] = positions.len() as u32;
        positions.push(limits[v].as_vec3a());
        kept_normals.push(normals[v].as_vec3a());
    }
    for t in &mut triangles {
        for i in t.iter_mut() {
            *i = remap[*i as usize];
        }
    }
    TriangleMesh {
        positions,
        normals: Some(kept_normals),
        triangles,
    }
}

/// The Catmull–Clark limit position of vertex `v` of an all-quad level.
fn limit_position(level: &Level, topology: &Topology, v: u32) -> DVec3 {
    let p = &level.positions;
    let s = p[v as usize];
    let faces = topology.faces_of(v);
    if faces.is_empty() || topology.is_boundary_corner(v) {
        return s;
    }
    let edges = topology.edges_of(v);
    let on_boundary = edges.iter().any(|&e| topology.edges[e as usize].is_boundary());
    let sharp = || {
        edges
            .iter()
            .map(|&e| &topology.edges[e as usize])
            .filter(|e| e.sharpness > 0.0)
    };
    let sharp_count = sharp().count();
    let smooth = || {
        let n = edges.len() as f64;
        let ring: DVec3 = edges
            .iter()
            .map(|&e| p[topology.edges[e as usize].other(v) as usize])
            .sum();
        let diagonals: DVec3 = faces
            .iter()
            .filter_map(|&f| {
                let q = level.face(f as usize);
                let i = q.iter().position(|&x| x == v)?;
                Some(p[q[(i + 2) % q.len()] as usize])
            })
            .sum();
        (n * n * s + 4.0 * ring + diagonals) / (n * (n + 5.0))
    };
    if sharp_count < 2 {
        return smooth();
    }
    let sharp_limit = if sharp_count == 2 {
        (sharp().map(|e| p[e.other(v) as usize]).sum::<DVec3>() + 4.0 * s) / 6.0
    } else {
        s
    };
    // Semi-sharp edges left after the last step: blend by their mean sharpness.
    let mean = sharp().map(|e| f64::from(e.sharpness)).sum::<f64>() / sharp_count as f64;
    if on_boundary || mean >= 1.0 {
        sharp_limit
    } else {
        smooth().lerp(sharp_limit, mean)
    }
}

/// The exact limit normal of a smooth interior vertex (Halstead, Kass and DeRose 1993), from the
/// tangent masks over its ordered ring of quads; `None` elsewhere or when the ring is not a fan.
fn tangent_normal(
    level: &Level,
    topology: &Topology,
    v: u32,
    ring: &mut Vec<(u32, u32, u32)>,
) -> Option<DVec3> {
    let edges = topology.edges_of(v);
    let faces = topology.faces_of(v);
    let sharp = edges
        .iter()
        .filter(|&&e| topology.edges[e as usize].sharpness > 0.0)
        .count();
    if faces.len() < 3 || faces.len() != edges.len() || sharp >= 2 {
        return None;
    }
    // Each quad (v, a, d, b) in winding order: a the edge neighbour before the face, d the
    // opposite corner, b the edge neighbour after it. Order them so that each b is the next a.
    ring.clear();
    for &f in faces {
        let q = level.face(f as usize);
        let i = q.iter().position(|&x| x == v)?;
        if q.len() != 4 {
            return None;
        }
        ring.push((q[(i + 1) % 4], q[(i + 2) % 4], q[(i + 3) % 4]));
    }
    let n = ring.len();
    for k in 1..n {
        let b = ring[k - 1].2;
        let next = (k..n).find(|&j| ring[j].0 == b)?;
        ring.swap(k, next);
    }
    if ring[n - 1].2 != ring[0].0 {
        return None;
    }
    let p = &level.positions;
    let step = TAU / n as f64;
    let a_n = 1.0 + step.cos() + (0.5 * step).cos() * (2.0 * (9.0 + step.cos())).sqrt();
    let (mut t1, mut t2) = (DVec3::ZERO, DVec3::ZERO);
    let (mut sin, mut cos) = (0.0f64, 1.0f64);
    for (j, &(e, f, _)) in ring.iter().enumerate() {
        let (next_sin, next_cos) = (step * (j + 1) as f64).sin_cos();
        let (e, f) = (p[e as usize], p[f as usize]);
        t1 += a_n * cos * e + (cos + next_cos) * f;
        t2 += a_n * sin * e + (sin + next_sin) * f;
        (sin, cos) = (next_sin, next_cos);
    }
    let normal = t1.cross(t2).normalize_or_zero();
    (normal != DVec3::ZERO && normal.is_finite()).then_some(normal)
}
