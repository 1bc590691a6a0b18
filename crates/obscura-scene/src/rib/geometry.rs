//! Geometry: the quadrics, polygons (triangulated by [`triangulate`]) and Catmull–Clark subdivision
//! meshes with their tags.

use std::collections::HashSet;

use glam::Vec3;
use obscura_sdk::ParamList;

use super::lex::{Value, describe};
use super::request::{Req, get_floats, to_points};
use super::triangulate::triangulate;
use super::{Reader, RibError};
use crate::types::{Identity, Mesh, Object, Shape, SubdivMesh};

impl Reader {
    /// Adds an object of `shape` with the current transform, material and dicing (to the object
    /// being defined, inside `ObjectBegin`).
    pub(super) fn add_object(&mut self, r: &Req<'_>, shape: Shape) {
        let material = self.current_material();
        let has_st = match &shape {
            Shape::Patches(_)
            | Shape::Sphere { .. }
            | Shape::Cylinder { .. }
            | Shape::Cone { .. }
            | Shape::Disk { .. }
            | Shape::Torus { .. }
            | Shape::Hyperboloid { .. }
            | Shape::Paraboloid { .. } => true,
            Shape::Mesh(m) => !m.uvs.is_empty(),
            _ => false,
        };
        if !has_st && self.scene.material_maps.contains_key(&material) {
            self.warn_once(
                r,
                &format!("no st {}", r.name),
                format!(
                    "{}: the surface's texture needs texture coordinates, which the renderer has for patches, quadrics and polygons with \"st\" only; drawn in the surface's colour alone",
                    r.name
                ),
            );
        }
        let object = Object {
            shape,
            transform: self.ctm.to_motion(),
            material,
            micropolygon_length: self.micropolygon_length,
            source: r.at(),
            sides: self.current_sides(),
            visibility: self.facing.visibility,
            identity: Identity {
                object: self.identifier.clone(),
                instance: self.identifier.clone(),
            },
        };
        match &mut self.retained.open {
            Some(d) => d.objects.push(object),
            None => self.scene.objects.push(object),
        }
    }

    /// `Sphere`, `Cylinder`, `Cone`, `Disk`, `Torus`, `Hyperboloid` and `Paraboloid`.
    pub(super) fn quadric(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let (shape, rest) = match r.name {
            "Sphere" => {
                let ([radius, z_min, z_max, theta_max], rest) =
                    r.numbers::<4>(r.args, "radius zmin zmax thetamax")?;
                (
                    Shape::Sphere {
                        radius,
                        z_min,
                        z_max,
                        theta_max,
                    },
                    rest,
                )
            }
            "Cylinder" => {
                let ([radius, z_min, z_max, theta_max], rest) =
                    r.numbers::<4>(r.args, "radius zmin zmax thetamax")?;
                (
                    Shape::Cylinder {
                        radius,
                        z_min,
                        z_max,
                        theta_max,
                    },
                    rest,
                )
            }
            "Cone" => {
                let ([height, radius, theta_max], rest) = r.numbers::<3>(r.args, "height radius thetamax")?;
                (
                    Shape::Cone {
                        height,
                        radius,
                        theta_max,
                    },
                    rest,
                )
            }
            "Disk" => {
                let ([height, radius, theta_max], rest) = r.numbers::<3>(r.args, "height radius thetamax")?;
                (
                    Shape::Disk {
                        height,
                        radius,
                        theta_max,
                    },
                    rest,
                )
            }
            "Hyperboloid" => {
                let ([x1, y1, z1, x2, y2, z2, theta_max], rest) =
                    r.numbers::<7>(r.args, "x1 y1 z1 x2 y2 z2 thetamax")?;
                (
                    Shape::Hyperboloid {
                        point1: Vec3::new(x1, y1, z1),
                        point2: Vec3::new(x2, y2, z2),
                        theta_max,
                    },
                    rest,
                )
            }
            "Paraboloid" => {
                let ([radius, z_min, z_max, theta_max], rest) =
                    r.numbers::<4>(r.args, "rmax zmin zmax thetamax")?;
                (
                    Shape::Paraboloid {
                        radius,
                        z_min,
                        z_max,
                        theta_max,
                    },
                    rest,
                )
            }
            _ => {
                let ([major_radius, minor_radius, phi_min, phi_max, theta_max], rest) =
                    r.numbers::<5>(r.args, "rmajor rminor phimin phimax thetamax")?;
                (
                    Shape::Torus {
                        major_radius,
                        minor_radius,
                        phi_min,
                        phi_max,
                        theta_max,
                    },
                    rest,
                )
            }
        };
        let list = self.params(r, rest, &PRIMITIVE_VARIABLES, false)?;
        self.primitive_color(r, &list);
        self.add_object(r, shape);
        Ok(())
    }

    /// `"P"` (required) from a parameter list, and `"N"` when it is per vertex.
    pub(super) fn points_and_normals(
        &mut self,
        r: &Req<'_>,
        list: &ParamList,
    ) -> Result<(Vec<Vec3>, Option<Vec<Vec3>>), RibError> {
        let positions = get_floats(list, "P")
            .map(to_points)
            .ok_or_else(|| r.err(format!("{}: the positions \"P\" are missing", r.name)))?;
        let normals = match get_floats(list, "N").map(to_points) {
            Some(n) if n.len() == positions.len() => Some(n),
            Some(n) => {
                self.warn(
                    r,
                    format!(
                        "{}: \"N\" has {} normals for {} points (not per vertex), ignored",
                        r.name,
                        n.len(),
                        positions.len()
                    ),
                );
                None
            }
            None => None,
        };
        Ok((positions, normals))
    }

    /// `Polygon`, `PointsPolygons` and `PointsGeneralPolygons`, triangulated into one mesh; degenerate
    /// faces are warned about and skipped.
    pub(super) fn polygons(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        // Each face: its loops (outline first, then holes) of vertex indices as written.
        let (faces, rest): (Option<Vec<FaceLoops>>, &[Value]) = match r.name {
            "Polygon" => (None, r.args),
            "PointsPolygons" => {
                let [nverts, verts, rest @ ..] = r.args else {
                    return Err(r.err("PointsPolygons expects [nverts] [verts] then \"P\" [...]"));
                };
                let nverts = r.counts(nverts, "[nverts]")?;
                let verts = r.indices(verts, "[verts]")?;
                let loops = split_by_counts(r, &verts, &nverts, "[nverts]", "[verts]")?;
                (Some(loops.into_iter().map(|l| vec![l]).collect()), rest)
            }
            _ => {
                let [nloops, nverts, verts, rest @ ..] = r.args else {
                    return Err(
                        r.err("PointsGeneralPolygons expects [nloops] [nverts] [verts] then \"P\" [...]")
                    );
                };
                let nloops = r.counts(nloops, "[nloops]")?;
                let nverts = r.counts(nverts, "[nverts]")?;
                let verts = r.indices(verts, "[verts]")?;
                let loops = split_by_counts(r, &verts, &nverts, "[nverts]", "[verts]")?;
                let faces = split_by_counts(r, &loops, &nloops, "[nloops]", "[nverts]")?;
                (Some(faces), rest)
            }
        };
        let list = self.params(
            r,
            rest,
            &with_primitive_variables(&["vertex point P", "vertex float[2] uv"]),
            false,
        )?;
        let (positions, normals) = self.points_and_normals(r, &list)?;
        let colors = self.vertex_colors(&list, positions.len());
        self.primitive_color(r, &list);
        let uvs = super::pattern::texture_coordinates(r, &list, positions.len())?;
        let faces = match faces {
            Some(f) => f,
            None => vec![vec![(0..positions.len() as i64).collect()]],
        };
        let mut triangles = Vec::new();
        for (k, face) in faces.iter().enumerate() {
            let loops = face
                .iter()
                .map(|l| check_indices(r, l, positions.len()))
                .collect::<Result<Vec<_>, _>>()?;
            match triangulate(&positions, &loops) {
                Some(t) => triangles.extend(t),
                None => self.warn(
                    r,
                    format!(
                        "{}: face {k} is degenerate (fewer than 3 distinct vertices or no area), skipped",
                        r.name
                    ),
                ),
            }
        }
        if triangles.is_empty() {
            // Nothing drawn: its colours must not pass to the next primitive.
            let state = &mut self.classic_state;
            (
                state.vertex_colors,
                state.primitive_color,
                state.primitive_opacity,
            ) = (false, None, None);
        } else {
            self.add_object(
                r,
                Shape::Mesh(Mesh {
                    positions,
                    normals,
                    triangles,
                    uvs,
                    colors,
                }),
            );
        }
        Ok(())
    }

    /// `SubdivisionMesh "catmull-clark"` with its optional tags.
    pub(super) fn subdivision_mesh(&mut self, r: &Req<'_>) -> Result<(), RibError> {
        let [Value::Str(scheme), nverts, verts, rest @ ..] = r.args else {
            return Err(r.err(
                "SubdivisionMesh expects \"scheme\" [nverts] [verts] ([tags] [nargs] [intargs] [floatargs]) then \"P\" [...]",
            ));
        };
        if scheme != "catmull-clark" {
            return Err(r.err(format!(
                "SubdivisionMesh: scheme \"{scheme}\" is not supported; expected \"catmull-clark\""
            )));
        }
        let face_counts = r.counts(nverts, "[nverts]")?;
        let verts = r.indices(verts, "[verts]")?;
        split_by_counts(r, &verts, &face_counts, "[nverts]", "[verts]")?;
        if let Some((k, n)) = face_counts.iter().enumerate().find(|(_, n)| **n < 3) {
            return Err(r.err(format!(
                "SubdivisionMesh: face {k} has {n} vertices; a face needs at least 3"
            )));
        }
        // The tag arrays, present when an array (not a parameter name) follows [verts].
        let (tags, rest): (Option<[&Value; 4]>, &[Value]) = match rest {
            [
                tags @ (Value::Strs(_) | Value::Nums(_)),
                nargs,
                intargs,
                floatargs,
                rest @ ..,
            ] => {
                let rest = match rest {
                    [Value::Strs(_) | Value::Nums(_), more @ ..] => more, // [stringargs]
                    _ => rest,
                };
                (Some([tags, nargs, intargs, floatargs]), rest)
            }
            [Value::Strs(_) | Value::Nums(_), ..] => {
                return Err(r.err("SubdivisionMesh expects [tags] [nargs] [intargs] [floatargs] together"));
            }
            _ => (None, rest),
        };
        let list = self.params(
            r,
            rest,
            &with_primitive_variables(&["vertex point P", "vertex float[2] uv"]),
            false,
        )?;
        self.primitive_color(r, &list);
        let (positions, _) = self.points_and_normals(r, &list)?;
        let face_indices = check_indices(r, &verts, positions.len())?;
        let face_counts: Vec<u32> = face_counts.iter().map(|&n| n as u32).collect();
        let mut mesh = SubdivMesh {
            positions,
            face_counts,
            face_indices,
            ..SubdivMesh::default()
        };
        if let Some(tags) = tags {
            self.subdivision_tags(r, tags, &mut mesh)?;
        }
        self.add_object(r, Shape::Subdiv(mesh));
        Ok(())
    }

    /// Applies the tags (`[tags] [nargs] [intargs] [floatargs]`) to `mesh`: creases and
    /// `interpolateboundary`; other tags are warned about once each.
    fn subdivision_tags(
        &mut self,
        r: &Req<'_>,
        arrays: [&Value; 4],
        mesh: &mut SubdivMesh,
    ) -> Result<(), RibError> {
        let [tags, nargs, intargs, floatargs] = arrays;
        let tags: &[String] = match tags {
            Value::Strs(t) => t,
            _ => &[],
        };
        let nargs = r.counts(nargs, "[nargs]")?;
        let ints = r.indices(intargs, "[intargs]")?;
        let floats: Vec<f32> = match floatargs {
            Value::Nums(v) => v.iter().map(|n| n.value as f32).collect(),
            other => {
                return Err(r.err(format!(
                    "SubdivisionMesh: [floatargs] must be an array of numbers, got {}",
                    describe(other)
                )));
            }
        };
        let per_tag = counts_per_tag(r, nargs.len(), tags.len())?;
        let (mut io, mut fo) = (0usize, 0usize);
        let mut warned = HashSet::new();
        for (k, tag) in tags.iter().enumerate() {
            let (ni, nf) = (nargs[k * per_tag], nargs[k * per_tag + 1]);
            let (Some(ti), Some(tf)) = (
                ints.get(io..io.saturating_add(ni)),
                floats.get(fo..fo.saturating_add(nf)),
            ) else {
                return Err(r.err(format!(
                    "SubdivisionMesh: [nargs] asks for more arguments than [intargs] ({}) and [floatargs] ({}) hold",
                    ints.len(),
                    floats.len()
                )));
            };
            io += ni;
            fo += nf;
            match tag.as_str() {
                "crease" => add_crease(r, ti, tf, mesh)?,
                "interpolateboundary" => mesh.interpolate_boundary = ti.first().is_none_or(|&v| v != 0),
                other => {
                    if warned.insert(other.to_string()) {
                        self.warn(
                            r,
                            format!("SubdivisionMesh: tag \"{other}\" is not supported, ignored"),
                        );
                    }
                }
            }
        }
        if io != ints.len() || fo != floats.len() {
            return Err(r.err(format!(
                "SubdivisionMesh: [nargs] accounts for {io} integer and {fo} float arguments, but [intargs] has {} and [floatargs] {}",
                ints.len(),
                floats.len()
            )));
        }
        Ok(())
    }
}

/// How many `[nargs]` entries each tag has: two (ints, floats), or three when string arguments follow.
fn counts_per_tag(r: &Req<'_>, nargs: usize, tags: usize) -> Result<usize, RibError> {
    if nargs == 2 * tags {
        Ok(2)
    } else if nargs == 3 * tags {
        Ok(3)
    } else {
        Err(r.err(format!(
            "SubdivisionMesh: [nargs] has {nargs} values for {tags} tags; expected 2 per tag"
        )))
    }
}

/// A `crease` tag: a chain of vertices (`ints`) and one sharpness, or one per edge (`floats`).
fn add_crease(r: &Req<'_>, ints: &[i64], floats: &[f32], mesh: &mut SubdivMesh) -> Result<(), RibError> {
    let chain = check_indices(r, ints, mesh.positions.len())?;
    let edges = chain.len().saturating_sub(1);
    if chain.len() < 2 || !(floats.len() == 1 || floats.len() == edges) {
        return Err(r.err(format!(
            "SubdivisionMesh: a \"crease\" needs at least 2 vertices and 1 sharpness (or one per edge), got {} and {}",
            chain.len(),
            floats.len()
        )));
    }
    for (e, pair) in chain.windows(2).enumerate() {
        let s = if floats.len() == 1 { floats[0] } else { floats[e] };
        mesh.creases.push((pair[0], pair[1], s));
    }
    Ok(())
}

/// The primitive variables any primitive may carry: its colour is used (see `primitive_color`), the
/// others are accepted.
const PRIMITIVE_VARIABLES: [&str; 6] = [
    "vertex normal N",
    "vertex color Cs",
    "vertex color Os",
    "vertex float s",
    "vertex float t",
    "vertex float[2] st",
];

/// A request's parameter table: its own entries, then [`PRIMITIVE_VARIABLES`].
pub(super) fn with_primitive_variables<'a>(own: &[&'a str]) -> Vec<&'a str> {
    own.iter().copied().chain(PRIMITIVE_VARIABLES).collect()
}

/// One polygon's loops (outline, then holes) of vertex indices as written.
type FaceLoops = Vec<Vec<i64>>;

/// Cuts `items` into consecutive runs of `counts[k]` items; the counts must add up to `items.len()`.
fn split_by_counts<T: Clone>(
    r: &Req<'_>,
    items: &[T],
    counts: &[usize],
    counts_name: &str,
    items_name: &str,
) -> Result<Vec<Vec<T>>, RibError> {
    let total = counts.iter().fold(0usize, |a, &n| a.saturating_add(n));
    if total != items.len() {
        return Err(r.err(format!(
            "{}: {counts_name} adds up to {total} but {items_name} has {} entries",
            r.name,
            items.len()
        )));
    }
    let mut out = Vec::with_capacity(counts.len());
    let mut at = 0;
    for &n in counts {
        out.push(items[at..at + n].to_vec());
        at += n;
    }
    Ok(out)
}

/// The indices as `u32`, each checked against the number of points.
fn check_indices(r: &Req<'_>, indices: &[i64], points: usize) -> Result<Vec<u32>, RibError> {
    indices
        .iter()
        .map(|&i| {
            usize::try_from(i)
                .ok()
                .filter(|&u| u < points)
                .map(|u| u as u32)
                .ok_or_else(|| {
                    r.err(format!(
                        "{}: vertex index {i} is out of range (\"P\" has {points} points)",
                        r.name
                    ))
                })
        })
        .collect()
}
