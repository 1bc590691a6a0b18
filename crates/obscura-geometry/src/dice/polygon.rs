//! Polygon meshes: checked (finite positions, indices in range, one normal per position) and passed
//! through unchanged, normals kept.

use glam::Vec3A;
use obscura_scene::Mesh;

use super::{DiceError, check_finite};
use crate::ray::TriangleMesh;

/// A polygon mesh, checked and converted.
pub(super) fn pass_through(mesh: &Mesh) -> Result<TriangleMesh, DiceError> {
    let n = mesh.positions.len();
    check_finite(&mesh.positions)?;
    for (triangle, t) in mesh.triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= n) {
            return Err(DiceError::MeshIndexOutOfRange {
                triangle,
                index,
                vertex_count: n,
            });
        }
    }
    if let Some(normals) = &mesh.normals
        && normals.len() != n
    {
        return Err(DiceError::MeshNormalCount {
            normals: normals.len(),
            positions: n,
        });
    }
    Ok(TriangleMesh {
        positions: mesh.positions.iter().map(|&p| Vec3A::from(p)).collect(),
        normals: mesh
            .normals
            .as_ref()
            .map(|ns| ns.iter().map(|&v| Vec3A::from(v)).collect()),
        triangles: mesh.triangles.clone(),
    })
}
