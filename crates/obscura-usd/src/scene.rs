//! A stage at one time code as an Obscura [`Scene`]: the camera, meshes and UsdGeom primitives, their
//! PreviewSurface materials and UsdLux lights.
//!
//! - Stage axes: a `Z`-up stage is turned to Obscura's `Y`-up world by `R_x(−90°)` applied to
//!   everything (camera included), so the render is the same and staging's automatic camera sees the
//!   stage upright. `metersPerUnit` scales nothing: camera and geometry share the scene unit.
//! - Motion: with `shutter:open < shutter:close`, every transform is sampled at the shutter's ends and
//!   at each time sample in between (times relative to the frame's time code), the camera's too.
//! - `Mesh`: `points`, `faceVertexCounts`/`Indices` (polygons fanned into triangles; `orientation =
//!   leftHanded` reverses them), vertex `normals`; `subdivisionScheme = catmullClark` (the fallback)
//!   is Obscura's own Catmull–Clark surface, `none` a polygon mesh. `Sphere` (radius), `Cube` (size),
//!   `Cylinder` and `Cone` (radius, height, axis) are quadrics or meshes of the same shape.
//! - Visibility: `invisible` (inherited) and `purpose` `guide`/`proxy` prims are not rendered.
//! - Material: the bound `UsdPreviewSurface`'s constant `diffuseColor`, `roughness` and
//!   `specularColor`/`metallic` as PxrSurface, else `primvars:displayColor` (constant) as PxrDiffuse.
//! - Lights: `DistantLight`, `DomeLight`, `SphereLight`, `RectLight` with `inputs:intensity`,
//!   `inputs:exposure`, `inputs:color` (and `inputs:angle`, `inputs:radius`, `inputs:width/height`).
//! - IDs: each object's name and instance name are its prim path.

use glam::{DMat4, DVec3, Mat4, Vec3};
use obscura_host::CameraDesc;
use obscura_scene::{
    ClipPlane, ClipSpace, Exposure, Identity, Light, Material, Mesh, MotionTransform, Object, Scene, Shape,
    Sides, SubdivMesh, Visibility,
};
use obscura_sdk::{MotionSample, ParamValue, Rgb, ScreenWindow};

use crate::values::{Time, Values};
use crate::{Stage, UsdError, camera::flip_z, xform};

/// The stage at time code `t`, seen through camera `camera` (`None`: the scene records that it needs
/// an automatic camera).
///
/// # Errors
/// A located [`UsdError`].
pub fn build(
    stage: &Stage,
    camera_desc: CameraDesc,
    camera: Option<&str>,
    t: f64,
) -> Result<Scene, UsdError> {
    let values = stage.values();
    let up = if stage.up_axis == "Z" {
        DMat4::from_rotation_x(-std::f64::consts::FRAC_PI_2)
    } else {
        DMat4::IDENTITY
    };
    let mut scene = Scene::new(camera_desc);
    let time = Time::Code(t);
    let mut shutter = (0.0, 0.0);
    if let Some(path) = camera {
        let cam = stage.camera(path, time)?;
        shutter = (cam.shutter_open, cam.shutter_close);
        set_camera(stage, &mut scene, &cam, up, t)?;
    }
    let prims = stage.prims()?;
    let stage_dir = std::path::Path::new(&stage.file)
        .parent()
        .map(std::path::Path::to_path_buf)
        .unwrap_or_default();
    let mut materials = Vec::new();
    let mut bounds: Option<(Vec3, Vec3)> = None;
    // Prototypes of point instancers render only as their instances.
    let instancers: Vec<&String> = prims
        .iter()
        .filter(|(_, ty)| ty == "PointInstancer")
        .map(|(p, _)| p)
        .collect();
    let prototypes: Vec<Vec<String>> = instancers
        .iter()
        .map(|i| values.targets(i, "prototypes"))
        .collect();
    let under = |path: &str, root: &str| path == root || path.starts_with(&format!("{root}/"));
    let in_prototype = |path: &str| prototypes.iter().flatten().any(|r| under(path, r));
    for (path, ty) in &prims {
        if in_prototype(path) {
            continue;
        }
        if !matches!(
            ty.as_str(),
            "Mesh"
                | "Sphere"
                | "Cube"
                | "Cylinder"
                | "Cone"
                | "DistantLight"
                | "DomeLight"
                | "SphereLight"
                | "RectLight"
        ) || !visible(&values, path, time)?
        {
            continue;
        }
        let motion = motion(&values, path, up, t, shutter)?;
        let bound = if ty.ends_with("Light") {
            None
        } else {
            crate::shading::bound_material(&values, &stage_dir, path, time, &mut scene, &mut materials)?
        };
        let shape = match ty.as_str() {
            "Mesh" => mesh(
                &values,
                path,
                time,
                bound.as_ref().and_then(|b| b.uv_primvar.as_deref()),
            )?,
            "Sphere" => {
                let r = values.real(path, "radius", time, 1.0)? as f32;
                Some(Shape::Sphere {
                    radius: r,
                    z_min: -r,
                    z_max: r,
                    theta_max: 360.0,
                })
            }
            "Cube" => Some(Shape::Mesh(Mesh::cube(
                values.real(path, "size", time, 2.0)? as f32
            ))),
            "Cylinder" | "Cone" => Some(Shape::Mesh(round(&values, path, ty, time)?)),
            light_type => {
                scene
                    .lights
                    .push(light(&values, path, light_type, time, motion.samples[0].1)?);
                continue;
            }
        };
        let Some(shape) = shape else { continue };
        for p in shape_points(&shape) {
            grow(&mut bounds, motion.samples[0].1.transform_point3(p));
        }
        let material = match &bound {
            Some(b) => b.material,
            None => display_color(&values, path, time, &mut scene),
        };
        scene.objects.push(Object {
            shape,
            transform: motion,
            material,
            micropolygon_length: 1.0,
            source: format!("{}: <{path}>", stage.file),
            identity: Identity {
                object: path.clone(),
                instance: path.clone(),
            },
            sides: Sides::Both,
            visibility: Visibility::default(),
        });
    }
    let all_prims = if instancers.is_empty() {
        Vec::new()
    } else {
        stage.all_prims()?
    };
    for (instancer, roots) in instancers.iter().zip(&prototypes) {
        if !visible(&values, instancer, time)? {
            continue;
        }
        instance(
            stage,
            &values,
            &stage_dir,
            &all_prims,
            (instancer, roots),
            up,
            time,
            &mut scene,
            &mut materials,
            &mut bounds,
        )?;
    }
    if camera.is_none() {
        scene.auto_camera = Some(bounds.unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0))));
    }
    scene.auto_light = scene.lights.is_empty();
    Ok(scene)
}

/// Points whose box holds `shape`.
fn shape_points(shape: &Shape) -> Vec<Vec3> {
    match shape {
        Shape::Mesh(m) => m.positions.clone(),
        Shape::Subdiv(m) => m.positions.clone(),
        Shape::Sphere { radius, .. } => vec![Vec3::splat(-radius), Vec3::splat(*radius)],
        _ => Vec::new(),
    }
}

/// A `PointInstancer`'s instances: each prototype's geometry placed by
/// `instancer · T(position) · R(orientation) · S(scale) · instancer⁻¹ · geometry` (the prototypes sit
/// under the instancer), skipping `invisibleIds`; IDs name the instancer and the instance index.
#[allow(clippy::too_many_arguments)]
fn instance(
    stage: &Stage,
    values: &Values<'_>,
    stage_dir: &std::path::Path,
    prims: &[(String, String)],
    (instancer, roots): (&str, &[String]),
    up: DMat4,
    time: Time,
    scene: &mut Scene,
    materials: &mut Vec<(String, crate::shading::Bound)>,
    bounds: &mut Option<(Vec3, Vec3)>,
) -> Result<(), UsdError> {
    let indices = values
        .ints_opt(instancer, "protoIndices", time)?
        .unwrap_or_default();
    let positions = values
        .tuples_opt(instancer, "positions", time, 3)?
        .unwrap_or_default();
    let n = indices.len();
    if positions.len() != n {
        return Err(values.error(
            instancer,
            "positions",
            format!("{} positions for {n} protoIndices", positions.len()),
        ));
    }
    let orientations = values.tuples_opt(instancer, "orientations", time, 4)?;
    let scales = values.tuples_opt(instancer, "scales", time, 3)?;
    let ids = values.ints_opt(instancer, "ids", time)?;
    let invisible = values
        .ints_opt(instancer, "invisibleIds", time)?
        .unwrap_or_default();
    let world = xform::world(values, instancer, time)?;
    let inverse = world.inverse();
    // Each prototype's renderable prims with their shapes, built once.
    let mut protos: Vec<Vec<(String, Shape, u32, DMat4)>> = Vec::new();
    for root in roots {
        let mut parts = Vec::new();
        for (path, ty) in prims {
            let inside = path == root || path.starts_with(&format!("{root}/"));
            if !inside || !matches!(ty.as_str(), "Mesh" | "Sphere" | "Cube" | "Cylinder" | "Cone") {
                continue;
            }
            let bound = crate::shading::bound_material(values, stage_dir, path, time, scene, materials)?;
            let shape = match ty.as_str() {
                "Mesh" => mesh(
                    values,
                    path,
                    time,
                    bound.as_ref().and_then(|b| b.uv_primvar.as_deref()),
                )?,
                "Sphere" => {
                    let r = values.real(path, "radius", time, 1.0)? as f32;
                    Some(Shape::Sphere {
                        radius: r,
                        z_min: -r,
                        z_max: r,
                        theta_max: 360.0,
                    })
                }
                "Cube" => Some(Shape::Mesh(Mesh::cube(
                    values.real(path, "size", time, 2.0)? as f32
                ))),
                _ => Some(Shape::Mesh(round(values, path, ty, time)?)),
            };
            let Some(shape) = shape else { continue };
            let material = match &bound {
                Some(b) => b.material,
                None => display_color(values, path, time, scene),
            };
            parts.push((
                path.clone(),
                shape,
                material,
                inverse * xform::world(values, path, time)?,
            ));
        }
        protos.push(parts);
    }
    for i in 0..n {
        let id = ids.as_ref().and_then(|v| v.get(i).copied()).unwrap_or(i as i64);
        if invisible.contains(&id) {
            continue;
        }
        let k = indices[i];
        let Some(parts) = usize::try_from(k).ok().and_then(|k| protos.get(k)) else {
            return Err(values.error(
                instancer,
                "protoIndices",
                format!(
                    "index {k} at instance {i}: the instancer has {} prototypes",
                    protos.len()
                ),
            ));
        };
        let p = &positions[i];
        let mut m = DMat4::from_translation(DVec3::new(p[0], p[1], p[2]));
        if let Some(q) = orientations.as_ref().and_then(|o| o.get(i)) {
            let q = glam::DQuat::from_xyzw(q[1], q[2], q[3], q[0]);
            if q.length() > 0.0 {
                m *= DMat4::from_quat(q.normalize());
            }
        }
        if let Some(s) = scales.as_ref().and_then(|o| o.get(i)) {
            m *= DMat4::from_scale(DVec3::new(s[0], s[1], s[2]));
        }
        for (path, shape, material, local) in parts {
            let to_world = (up * world * m * *local).as_mat4();
            for q in shape_points(shape) {
                grow(bounds, to_world.transform_point3(q));
            }
            scene.objects.push(Object {
                shape: shape.clone(),
                transform: MotionTransform::fixed(to_world),
                material: *material,
                micropolygon_length: 1.0,
                source: format!("{}: <{instancer}> instance {i} of <{path}>", stage.file),
                identity: Identity {
                    object: path.clone(),
                    instance: format!("{instancer}[{i}]"),
                },
                sides: Sides::Both,
                visibility: Visibility::default(),
            });
        }
    }
    Ok(())
}

fn grow(bounds: &mut Option<(Vec3, Vec3)>, p: Vec3) {
    if p.is_finite() {
        *bounds = Some(match *bounds {
            Some((lo, hi)) => (lo.min(p), hi.max(p)),
            None => (p, p),
        });
    }
}

/// The rendered camera of `cam` (see [`crate::camera`]).
fn set_camera(
    stage: &Stage,
    scene: &mut Scene,
    cam: &crate::UsdCamera,
    up: DMat4,
    t: f64,
) -> Result<(), UsdError> {
    let values = stage.values();
    let origin = |a: &str| Some(format!("{}: <{}>.{a}", stage.file, cam.path));
    let format = scene.camera.format;
    let aspect = f64::from(format.width) * f64::from(format.pixel_aspect) / f64::from(format.height);
    let policy = match stage.render_settings() {
        Some(s) => values
            .token_opt(&s, "aspectRatioConformPolicy", Time::Code(t))?
            .unwrap_or_else(|| "expandAperture".into()),
        None => "expandAperture".into(),
    };
    let (gate, pixel_aspect) = cam
        .fitted_gate(aspect, &policy)
        .map_err(|e| UsdError::file(&stage.file, e))?;
    if pixel_aspect != 1.0 {
        scene.camera.format.pixel_aspect = pixel_aspect as f32;
    }
    let [l, r, b, top] = cam.screen_window(gate);
    scene.camera.screen_window = Some(ScreenWindow::new(l as f32, r as f32, b as f32, top as f32));
    scene.camera.clipping = (cam.clipping_range.0 as f32, cam.clipping_range.1 as f32);
    scene.camera.shutter = (cam.shutter_open as f32, cam.shutter_close as f32);
    // The camera's motion over the shutter: the inverse of each sample of its world transform.
    let motion = motion(&values, &cam.path, up, t, (cam.shutter_open, cam.shutter_close))?;
    scene.camera.world_to_camera = motion
        .samples
        .iter()
        .map(|&(time, c2w)| MotionSample {
            time,
            world_to_camera: obscura_sdk::Matrix4((flip_z().as_mat4() * c2w.inverse()).to_cols_array_2d()),
        })
        .collect();
    scene.exposure = Exposure {
        gain: cam.exposure_scale() as f32,
        gamma: 1.0,
    };
    scene.clip_planes = cam
        .obscura_clip_planes()
        .into_iter()
        .map(|(p, n)| ClipPlane {
            point: p.as_vec3(),
            normal: n.as_vec3(),
            space: ClipSpace::Camera,
        })
        .collect();
    let push = |scene: &mut Scene, decl: &str, v: f32, attr: &str| {
        if let Err(e) = scene
            .projection_params
            .push(decl, ParamValue::Floats(vec![v]), origin(attr))
        {
            scene.warnings.push(e.to_string());
        }
    };
    if let Some(lens) = stage.lens(&cam.path, Time::Code(t))? {
        scene.projection = "CalibratedCamera".into();
        scene.projection_params = lens.param_list(&format!("{}: <{}> {}", stage.file, cam.path, lens.schema));
        scene.camera.screen_window = None;
        return Ok(());
    }
    if let Some(ri) = crate::ri::projection(stage, &cam.path, Time::Code(t))?
        && ri.name != "PxrPerspective"
    {
        scene.projection = ri.name;
        scene.projection_params = ri.params;
        return Ok(());
    }
    if cam.projection == "orthographic" {
        scene.projection = "PxrOrthographic".into();
        return Ok(());
    }
    scene.projection = "PxrPerspective".into();
    push(scene, "float fov", 90.0, "focalLength");
    if cam.f_stop > 0.0 && cam.focus_distance > 0.0 {
        push(scene, "float fStop", cam.f_stop as f32, "fStop");
        push(
            scene,
            "float focalLength",
            (cam.focal_length / 10.0) as f32,
            "focalLength",
        );
        push(
            scene,
            "float focalDistance",
            cam.focus_distance as f32,
            "focusDistance",
        );
    }
    Ok(())
}

/// The world transform of `path` over the shutter `(open, close)` around time code `t` (Obscura's
/// axes, column vectors, single precision), with times relative to `t`.
fn motion(
    values: &Values<'_>,
    path: &str,
    up: DMat4,
    t: f64,
    shutter: (f64, f64),
) -> Result<MotionTransform, UsdError> {
    let (open, close) = shutter;
    let mut times = vec![open];
    if close > open {
        times.extend(
            xform::sample_times(values, path)
                .into_iter()
                .map(|s| s - t)
                .filter(|&s| s > open && s < close),
        );
        times.push(close);
    }
    let samples = times
        .into_iter()
        .map(|s| {
            Ok((
                s as f32,
                (up * xform::world(values, path, Time::Code(t + s))?).as_mat4(),
            ))
        })
        .collect::<Result<Vec<_>, UsdError>>()?;
    Ok(MotionTransform { samples })
}

/// False when the prim or an ancestor is `invisible`, or its purpose is `guide` or `proxy`.
fn visible(values: &Values<'_>, path: &str, time: Time) -> Result<bool, UsdError> {
    let mut p = path.to_string();
    while p.len() > 1 {
        if values.token_opt(&p, "visibility", time)?.as_deref() == Some("invisible") {
            return Ok(false);
        }
        if matches!(
            values.token_opt(&p, "purpose", Time::Default)?.as_deref(),
            Some("guide" | "proxy")
        ) {
            return Ok(false);
        }
        p = match p.rfind('/') {
            Some(0) | None => break,
            Some(i) => p[..i].to_string(),
        };
    }
    Ok(true)
}

fn mesh(values: &Values<'_>, path: &str, time: Time, uv: Option<&str>) -> Result<Option<Shape>, UsdError> {
    let Some(points) = values.tuples_opt(path, "points", time, 3)? else {
        return Ok(None);
    };
    let positions: Vec<Vec3> = points
        .iter()
        .map(|p| DVec3::new(p[0], p[1], p[2]).as_vec3())
        .collect();
    let counts = values
        .ints_opt(path, "faceVertexCounts", time)?
        .unwrap_or_default();
    let indices = values
        .ints_opt(path, "faceVertexIndices", time)?
        .unwrap_or_default();
    let total: i64 = counts.iter().sum();
    if counts.iter().any(|&c| c < 0) || total != indices.len() as i64 {
        return Err(values.error(
            path,
            "faceVertexCounts",
            format!(
                "the counts sum to {total} but faceVertexIndices has {} entries",
                indices.len()
            ),
        ));
    }
    if let Some(bad) = indices.iter().find(|&&i| i < 0 || i as usize >= positions.len()) {
        return Err(values.error(
            path,
            "faceVertexIndices",
            format!("index {bad} is outside the {} points", positions.len()),
        ));
    }
    let left = values.token_opt(path, "orientation", Time::Default)?.as_deref() == Some("leftHanded");
    let scheme = values
        .token_opt(path, "subdivisionScheme", Time::Default)?
        .unwrap_or_else(|| "catmullClark".into());
    let mut face_indices: Vec<u32> = Vec::with_capacity(indices.len());
    let mut start = 0usize;
    for &c in &counts {
        let face = &indices[start..start + c as usize];
        if left {
            face_indices.extend(face.iter().rev().map(|&i| i as u32));
        } else {
            face_indices.extend(face.iter().map(|&i| i as u32));
        }
        start += c as usize;
    }
    let uvs = match uv {
        Some(name) => primvar2(
            values,
            path,
            name,
            time,
            positions.len(),
            indices.len(),
            counts.len(),
        )?,
        None => None,
    };
    if uvs.is_none()
        && scheme == "catmullClark"
        && counts.iter().all(|&c| c >= 3)
        && !counts.is_empty()
        && manifold(&counts, &face_indices)
    {
        return Ok(Some(Shape::Subdiv(SubdivMesh {
            positions,
            face_counts: counts.iter().map(|&c| c as u32).collect(),
            face_indices,
            creases: Vec::new(),
            interpolate_boundary: true,
        })));
    }
    let mut triangles = Vec::new();
    let mut start = 0usize;
    for &c in &counts {
        let c = c as usize;
        for k in 1..c.saturating_sub(1) {
            triangles.push([
                face_indices[start],
                face_indices[start + k],
                face_indices[start + k + 1],
            ]);
        }
        start += c;
    }
    let normals = values
        .tuples_opt(path, "normals", time, 3)
        .ok()
        .flatten()
        .filter(|n| n.len() == positions.len())
        .map(|n| n.iter().map(|v| DVec3::new(v[0], v[1], v[2]).as_vec3()).collect());
    match uvs {
        Some(Primvar::Vertex(uv)) => Ok(Some(Shape::Mesh(Mesh {
            positions,
            normals,
            triangles,
            uvs: vec![uv],
            colors: None,
        }))),
        Some(Primvar::Corner(uv)) => {
            // Face-varying coordinates: one vertex per face corner (in the file's corner order,
            // which `face_indices` kept unless left-handed reversed it).
            let mut corner_of = Vec::with_capacity(face_indices.len());
            let mut start = 0usize;
            for &c in &counts {
                let c = c as usize;
                let order: Vec<usize> = if left {
                    (0..c).rev().collect()
                } else {
                    (0..c).collect()
                };
                corner_of.extend(order.into_iter().map(|k| start + k));
                start += c;
            }
            let p: Vec<Vec3> = face_indices.iter().map(|&i| positions[i as usize]).collect();
            let n = normals.map(|n: Vec<Vec3>| face_indices.iter().map(|&i| n[i as usize]).collect());
            let uv = corner_of.iter().map(|&k| uv[k]).collect();
            let mut tris = Vec::new();
            let mut start = 0u32;
            for &c in &counts {
                let c = c as u32;
                for k in 1..c.saturating_sub(1) {
                    tris.push([start, start + k, start + k + 1]);
                }
                start += c;
            }
            Ok(Some(Shape::Mesh(Mesh {
                positions: p,
                normals: n,
                triangles: tris,
                uvs: vec![uv],
                colors: None,
            })))
        }
        None => Ok(Some(Shape::Mesh(Mesh {
            positions,
            normals,
            triangles,
            uvs: Vec::new(),
            colors: None,
        }))),
    }
}

/// True when no edge is shared by more than two faces: Catmull–Clark is defined there; a mesh
/// with a non-manifold edge is rendered as its polygons (hdPrman's subdivision refuses it too).
fn manifold(counts: &[i64], face_indices: &[u32]) -> bool {
    let mut uses = std::collections::HashMap::new();
    let mut start = 0usize;
    for &c in counts {
        let face = &face_indices[start..start + c as usize];
        for k in 0..face.len() {
            let (a, b) = (face[k], face[(k + 1) % face.len()]);
            let n = uses.entry((a.min(b), a.max(b))).or_insert(0u32);
            *n += 1;
            if *n > 2 {
                return false;
            }
        }
        start += c as usize;
    }
    true
}

/// A 2-vector primvar, by vertex or by face corner (glTF's texture convention: `t` flipped).
enum Primvar {
    Vertex(Vec<glam::Vec2>),
    Corner(Vec<glam::Vec2>),
}

/// `primvars:<name>` (with `:indices`) as texture coordinates, by its `interpolation`.
fn primvar2(
    values: &Values<'_>,
    path: &str,
    name: &str,
    time: Time,
    points: usize,
    corners: usize,
    faces: usize,
) -> Result<Option<Primvar>, UsdError> {
    let attr = format!("primvars:{name}");
    let Some(raw) = values.tuples_opt(path, &attr, time, 2)? else {
        return Ok(None);
    };
    let flat: Vec<glam::Vec2> = raw
        .iter()
        .map(|v| glam::Vec2::new(v[0] as f32, 1.0 - v[1] as f32))
        .collect();
    let data = match values.ints_opt(path, &format!("{attr}:indices"), time)? {
        Some(ix) => ix
            .iter()
            .map(|&i| {
                flat.get(i as usize).copied().ok_or_else(|| {
                    values.error(
                        path,
                        &format!("{attr}:indices"),
                        format!("index {i} outside the {} values", flat.len()),
                    )
                })
            })
            .collect::<Result<Vec<_>, _>>()?,
        None => flat,
    };
    let interpolation = values.interpolation(path, &attr);
    Ok(match interpolation.as_str() {
        "faceVarying" if data.len() == corners => Some(Primvar::Corner(data)),
        "vertex" | "varying" if data.len() == points => Some(Primvar::Vertex(data)),
        "uniform" if data.len() == faces => None,
        "constant" => None,
        _ if data.len() == corners => Some(Primvar::Corner(data)),
        _ if data.len() == points => Some(Primvar::Vertex(data)),
        other => {
            return Err(values.error(
                path,
                &attr,
                format!("{} values with interpolation {other:?} fit neither the {points} points nor the {corners} face corners", data.len()),
            ));
        }
    })
}

/// A `Cylinder` or `Cone` (capped) as a mesh of 64 segments, along its `axis`.
fn round(values: &Values<'_>, path: &str, ty: &str, time: Time) -> Result<Mesh, UsdError> {
    let r = values.real(path, "radius", time, 1.0)? as f32;
    let h = values.real(path, "height", time, 2.0)? as f32;
    let axis = values
        .token_opt(path, "axis", Time::Default)?
        .unwrap_or_else(|| "Z".into());
    let n = 64u32;
    let top_r = if ty == "Cone" { 0.0 } else { r };
    let mut positions = Vec::new();
    for k in 0..n {
        let a = k as f32 / n as f32 * std::f32::consts::TAU;
        positions.push(Vec3::new(r * a.cos(), r * a.sin(), -h / 2.0));
        positions.push(Vec3::new(top_r * a.cos(), top_r * a.sin(), h / 2.0));
    }
    positions.push(Vec3::new(0.0, 0.0, -h / 2.0));
    positions.push(Vec3::new(0.0, 0.0, h / 2.0));
    let (cb, ct) = (2 * n, 2 * n + 1);
    let mut triangles = Vec::new();
    for k in 0..n {
        let (a0, a1) = (2 * k, 2 * k + 1);
        let (b0, b1) = (2 * ((k + 1) % n), 2 * ((k + 1) % n) + 1);
        triangles.push([a0, b0, b1]);
        triangles.push([a0, b1, a1]);
        triangles.push([cb, b0, a0]);
        triangles.push([ct, a1, b1]);
    }
    let to_axis = |p: Vec3| match axis.as_str() {
        "X" => Vec3::new(p.z, p.x, p.y),
        "Y" => Vec3::new(p.y, p.z, p.x),
        _ => p,
    };
    Ok(Mesh {
        positions: positions.into_iter().map(to_axis).collect(),
        normals: None,
        triangles,
        uvs: Vec::new(),
        colors: None,
    })
}

/// A constant `primvars:displayColor` as a PxrDiffuse material (0, the default, without one).
fn display_color(values: &Values<'_>, path: &str, time: Time, scene: &mut Scene) -> u32 {
    let Some(c) = values
        .tuples_opt(path, "primvars:displayColor", time, 3)
        .ok()
        .flatten()
        .filter(|c| c.len() == 1)
    else {
        return 0;
    };
    scene.materials.push(Material::Diffuse {
        color: Rgb::new(c[0][0] as f32, c[0][1] as f32, c[0][2] as f32),
    });
    (scene.materials.len() - 1) as u32
}

fn light(values: &Values<'_>, path: &str, ty: &str, time: Time, transform: Mat4) -> Result<Light, UsdError> {
    let intensity = values.real(path, "inputs:intensity", time, 1.0)? as f32;
    let exposure = values.real(path, "inputs:exposure", time, 0.0)? as f32;
    let c = values
        .reals_opt(path, "inputs:color", time, 3)?
        .unwrap_or(vec![1.0, 1.0, 1.0]);
    let color = Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32);
    // UsdLux lights emit along −Z; Obscura's distant and rect lights along +Z.
    let flip = Mat4::from_scale(Vec3::new(1.0, 1.0, -1.0));
    Ok(match ty {
        "DistantLight" => Light::Distant {
            color,
            intensity,
            exposure,
            angle_extent: values.real(path, "inputs:angle", time, 0.53)? as f32,
            enable_shadows: true,
            transform: transform * flip,
        },
        "DomeLight" => Light::Dome {
            color,
            intensity,
            exposure,
            map: None,
            transform,
        },
        "SphereLight" => {
            let r = values.real(path, "inputs:radius", time, 0.5)? as f32;
            Light::Sphere {
                color,
                intensity,
                exposure,
                transform: transform * Mat4::from_scale(Vec3::splat(2.0 * r)),
            }
        }
        _ => {
            let w = values.real(path, "inputs:width", time, 1.0)? as f32;
            let h = values.real(path, "inputs:height", time, 1.0)? as f32;
            Light::Rect {
                color,
                intensity,
                exposure,
                transform: transform * flip * Mat4::from_scale(Vec3::new(w, h, 1.0)),
            }
        }
    })
}
