//! Mesh primitives: each `TRIANGLES` primitive becomes an object, its accessors checked before the
//! `gltf` crate's readers (which assert) see them.

use glam::{Mat4, Vec2, Vec3};
use gltf::accessor::{DataType, Dimensions};

use super::{GltfError, Loader};
use crate::convert::grow_bounds;
use crate::types::{Identity, Mesh, MotionTransform, Object, Shape};

impl Loader<'_> {
    /// One object per triangle primitive of `mesh`, placed by `world`.
    pub(super) fn read_mesh(
        &mut self,
        node: &gltf::Node<'_>,
        mesh: &gltf::Mesh<'_>,
        world: Mat4,
    ) -> Result<(), GltfError> {
        for prim in mesh.primitives() {
            let Some(shape) = self.read_primitive(mesh.index(), &prim)? else {
                continue;
            };
            for &p in &shape.positions {
                grow_bounds(&mut self.bounds, world.transform_point3(p));
            }
            let name = node.name().map(|n| format!(" \"{n}\"")).unwrap_or_default();
            let material = prim.material().index().map_or(0, |i| i + 1);
            self.scene.objects.push(Object {
                shape: Shape::Mesh(shape),
                transform: MotionTransform::fixed(world),
                material: u32::try_from(material).unwrap_or(0),
                micropolygon_length: 1.0,
                source: format!(
                    "{}: node {}{name} mesh {} primitive {}",
                    self.file,
                    node.index(),
                    mesh.index(),
                    prim.index()
                ),
                sides: Default::default(),
                visibility: Default::default(),
                identity: Identity {
                    object: mesh.name().unwrap_or_default().to_string(),
                    instance: node.name().unwrap_or_default().to_string(),
                },
            });
        }
        Ok(())
    }

    /// The triangles of one primitive; `None` (with a warning) when it is not made of triangles.
    pub(super) fn read_primitive(
        &mut self,
        mesh: usize,
        prim: &gltf::Primitive<'_>,
    ) -> Result<Option<Mesh>, GltfError> {
        let here = format!("mesh {mesh} primitive {}", prim.index());
        let mode = prim.mode();
        if !matches!(
            mode,
            gltf::mesh::Mode::Triangles | gltf::mesh::Mode::TriangleStrip | gltf::mesh::Mode::TriangleFan
        ) {
            self.warn(format!(
                "{here}: mode {mode:?} (points or lines) has no surface to render; skipped"
            ));
            return Ok(None);
        }
        let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
            self.warn(format!("{here}: no POSITION attribute; skipped"));
            return Ok(None);
        };
        let bad = |what: String| GltfError::Primitive {
            path: self.path.to_path_buf(),
            mesh,
            primitive: prim.index(),
            what,
        };
        self.check_attributes(prim, pos_acc).map_err(bad)?;
        let normal_acc = prim.get(&gltf::Semantic::Normals);
        let buffers = self.buffers;
        let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let positions: Vec<Vec3> = reader
            .read_positions()
            .ok_or_else(|| bad("POSITION data cannot be read".into()))?
            .map(Vec3::from)
            .collect();
        let n = positions.len();
        let mut normals = None;
        if normal_acc.is_some() {
            let ns: Vec<Vec3> = reader
                .read_normals()
                .ok_or_else(|| bad("NORMAL data cannot be read".into()))?
                .map(Vec3::from)
                .collect();
            if ns.len() == n {
                normals = Some(ns);
            } else {
                self.warn(format!(
                    "{here}: {} normals for {n} positions; normals ignored",
                    ns.len()
                ));
            }
        }
        let indices: Vec<u32> = match reader.read_indices() {
            Some(ix) => ix.into_u32().collect(),
            None if prim.indices().is_some() => return Err(bad("index data cannot be read".into())),
            None => (0..u32::try_from(n).map_err(|_| bad(format!("{n} vertices is too many")))?).collect(),
        };
        if let Some(&index) = indices.iter().find(|&&i| i as usize >= n) {
            return Err(bad(format!(
                "index {index} is out of range: the primitive has {n} vertices"
            )));
        }
        let triangles = match mode {
            gltf::mesh::Mode::TriangleStrip => strip_triangles(&indices),
            gltf::mesh::Mode::TriangleFan => fan_triangles(&indices),
            _ => {
                if !indices.len().is_multiple_of(3) {
                    self.warn(format!(
                        "{here}: {} indices is not a multiple of 3; the last {} ignored",
                        indices.len(),
                        indices.len() % 3
                    ));
                }
                indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()
            }
        };
        let mut uvs = Vec::new();
        for set in 0.. {
            if prim.get(&gltf::Semantic::TexCoords(set)).is_none() {
                break;
            }
            let uv: Vec<Vec2> = reader
                .read_tex_coords(set)
                .ok_or_else(|| bad(format!("TEXCOORD_{set} data cannot be read")))?
                .into_f32()
                .map(Vec2::from)
                .collect();
            if uv.len() != n {
                self.warn(format!(
                    "{here}: {} TEXCOORD_{set} values for {n} positions; ignored with the sets after it",
                    uv.len()
                ));
                break;
            }
            uvs.push(uv);
        }
        let mut colors = None;
        if prim.get(&gltf::Semantic::Colors(0)).is_some() {
            let c: Vec<[f32; 4]> = reader
                .read_colors(0)
                .ok_or_else(|| bad("COLOR_0 data cannot be read".into()))?
                .into_rgba_f32()
                .collect();
            if c.len() == n {
                colors = Some(c);
            } else {
                self.warn(format!(
                    "{here}: {} COLOR_0 values for {n} positions; vertex colours ignored",
                    c.len()
                ));
            }
        }
        Ok(Some(Mesh {
            positions,
            normals,
            triangles,
            uvs,
            colors,
        }))
    }

    /// Checks the accessors of a primitive's positions, normals and indices (see [`Self::check_accessor`]);
    /// the error names the attribute.
    fn check_attributes(
        &self,
        prim: &gltf::Primitive<'_>,
        positions: gltf::Accessor<'_>,
    ) -> Result<(), String> {
        let float = [DataType::F32];
        self.check_accessor(&positions, Dimensions::Vec3, &float)
            .map_err(|e| format!("POSITION {e}"))?;
        if let Some(acc) = &prim.get(&gltf::Semantic::Normals) {
            self.check_accessor(acc, Dimensions::Vec3, &float)
                .map_err(|e| format!("NORMAL {e}"))?;
        }
        let normalized = [DataType::F32, DataType::U8, DataType::U16];
        for set in 0.. {
            let Some(acc) = prim.get(&gltf::Semantic::TexCoords(set)) else {
                break;
            };
            self.check_accessor(&acc, Dimensions::Vec2, &normalized)
                .map_err(|e| format!("TEXCOORD_{set} {e}"))?;
        }
        if let Some(acc) = &prim.get(&gltf::Semantic::Colors(0)) {
            self.check_accessor(acc, Dimensions::Vec4, &normalized)
                .or_else(|_| self.check_accessor(acc, Dimensions::Vec3, &normalized))
                .map_err(|e| format!("COLOR_0 {e} (or Vec4)"))?;
        }
        if let Some(acc) = prim.indices() {
            self.check_accessor(
                &acc,
                Dimensions::Scalar,
                &[DataType::U8, DataType::U16, DataType::U32],
            )
            .map_err(|e| format!("indices {e}"))?;
        }
        Ok(())
    }

    /// Checks what the `gltf` crate's readers assume (and assert) about an accessor: its type, a
    /// stride no smaller than an element, and that every element lies inside its view and buffer.
    pub(super) fn check_accessor(
        &self,
        acc: &gltf::Accessor<'_>,
        dims: Dimensions,
        types: &[DataType],
    ) -> Result<(), String> {
        let which = format!("accessor {}", acc.index());
        if acc.dimensions() != dims || !types.contains(&acc.data_type()) {
            return Err(format!(
                "{which} is {:?} of {:?}; expected {dims:?} of {}",
                acc.dimensions(),
                acc.data_type(),
                types
                    .iter()
                    .map(|t| format!("{t:?}"))
                    .collect::<Vec<_>>()
                    .join(" or ")
            ));
        }
        if acc.sparse().is_some() {
            return Err(format!("{which} is sparse, which this reader does not support"));
        }
        let count = acc.count();
        if count == 0 {
            return Err(format!("{which} has no elements"));
        }
        let view = acc.view().ok_or_else(|| format!("{which} has no buffer view"))?;
        let elem = acc.size();
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(format!(
                "{which}: buffer view {} has stride {stride}, smaller than one {elem}-byte element",
                view.index()
            ));
        }
        let end = stride
            .checked_mul(count - 1)
            .and_then(|s| s.checked_add(elem))
            .and_then(|s| s.checked_add(acc.offset()));
        if end.is_none_or(|e| e > view.length()) {
            return Err(format!(
                "{which}: {count} elements from byte {} run past the end of buffer view {} ({} bytes)",
                acc.offset(),
                view.index(),
                view.length()
            ));
        }
        let buffer_len = self.buffers.get(view.buffer().index()).map_or(0, Vec::len);
        if view
            .offset()
            .checked_add(view.length())
            .is_none_or(|e| e > buffer_len)
        {
            return Err(format!(
                "{which}: buffer view {} runs past the end of buffer {} ({buffer_len} bytes)",
                view.index(),
                view.buffer().index()
            ));
        }
        Ok(())
    }
}

/// The triangles of a `TRIANGLE_STRIP` (glTF 2.0 §3.7.2.1): triangle `i` is
/// `(v_i, v_{i+1+i%2}, v_{i+2−i%2})`, which keeps every triangle's winding that of the first.
fn strip_triangles(v: &[u32]) -> Vec<[u32; 3]> {
    (0..v.len().saturating_sub(2))
        .map(|i| [v[i], v[i + 1 + i % 2], v[i + 2 - i % 2]])
        .collect()
}

/// The triangles of a `TRIANGLE_FAN`: triangle `i` is `(v_{i+1}, v_{i+2}, v_0)`.
fn fan_triangles(v: &[u32]) -> Vec<[u32; 3]> {
    (0..v.len().saturating_sub(2))
        .map(|i| [v[i + 1], v[i + 2], v[0]])
        .collect()
}

#[cfg(test)]
mod strip_tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_the_winding_of_the_first_triangle() {
        assert_eq!(
            strip_triangles(&[0, 1, 2, 3, 4]),
            [[0, 1, 2], [1, 3, 2], [2, 3, 4]]
        );
        assert_eq!(fan_triangles(&[0, 1, 2, 3]), [[1, 2, 0], [2, 3, 0]]);
        assert!(strip_triangles(&[0, 1]).is_empty());
        assert!(fan_triangles(&[]).is_empty());
    }
}
