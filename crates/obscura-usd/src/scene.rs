//! A stage at one time code as an Obscura [`Scene`]: the camera, meshes and UsdGeom primitives, their
//! PreviewSurface materials and UsdLux lights.
//!
//! - Stage axes: a `Z`-up stage is turned to Obscura's `Y`-up world by `R_x(−90°)` applied to
//!   everything (camera included), so the render is the same and staging's automatic camera sees the
//!   stage upright. `metersPerUnit` scales nothing: camera and geometry share the scene unit.
//! - Motion: with `shutter:open < shutter:close`, every transform is sampled at the shutter's ends and
//!   at each time sample in between (times relative to the frame's time code), the camera's too.
//! - `Mesh`: `points`, `faceVertexCounts`/`Indices` (polygons fanned into triangles; `orientation =
//!   leftHanded` reverses them), normals (`primvars:normals` with its indices, else `normals`) by point,
//!   face corner or face; `subdivisionScheme = catmullClark` (the fallback)
//!   is Obscura's own Catmull–Clark surface, `none` a polygon mesh. `Sphere` (radius), `Cube` (size),
//!   `Cylinder` and `Cone` (radius, height, axis) are quadrics or meshes of the same shape; `Capsule`
//!   (and `Capsule_1` with equal radii) a mesh of the cylinder of `height` between two hemispheres.
//! - Visibility: `invisible` (inherited) and `purpose` `guide`/`proxy` prims are not rendered.
//! - Material: the bound `UsdPreviewSurface`'s constant `diffuseColor`, `roughness` and
//!   `specularColor`/`metallic` as PxrSurface, else `primvars:displayColor` (constant) as PxrDiffuse.
//!   A mesh's `GeomSubset` children of the `materialBind` family (`elementType = face`) bind their
//!   own material to their faces: the mesh becomes one object per material (as polygons, sharing the
//!   points), the faces of no subset keeping the mesh's material (not yet inside PointInstancer
//!   prototypes).
//! - Lights: `DistantLight`, `DomeLight` (and `DomeLight_1`), `SphereLight`, `RectLight` with
//!   `inputs:intensity`, `inputs:exposure`, `inputs:color` (and `inputs:angle`, `inputs:radius`,
//!   `inputs:width/height`). A dome's `inputs:texture:file` (an EXR, `latlong` or `automatic`) is
//!   PxrDomeLight's map in USD's orientation, OpenEXR's lat-long layout: for a light-space direction
//!   `d`, `u = ½ − atan2(d.x, d.z)/2π`, `v = acos(d.y)/π` (Obscura's dome mirrored in x); a
//!   `DomeLight_1` whose `poleAxis` is `Z` (or `scene` on a Z-up stage) is first turned by `R_x(90°)`.
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
                | "Capsule"
                | "Capsule_1"
                | "DistantLight"
                | "DomeLight"
                | "DomeLight_1"
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
        let subsets = if ty == "Mesh" {
            material_subsets(&values, &prims, path, time)?
        } else {
            Vec::new()
        };
        let shape = match ty.as_str() {
            "Mesh" => mesh(
                &values,
                path,
                time,
                bound.as_ref().and_then(|b| b.uv_primvar.as_deref()),
                !subsets.is_empty(),
                &mut scene.warnings,
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
            "Capsule" | "Capsule_1" => {
                capsule(&values, path, ty, time, &mut scene.warnings)?.map(Shape::Mesh)
            }
            light_type => {
                let transform = motion.samples[0].1;
                let light = light(
                    &values,
                    path,
                    light_type,
                    time,
                    transform,
                    stage,
                    &mut scene.warnings,
                )?;
                scene.lights.push(light);
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
        let object = |shape: Shape, material: u32, source: &str| Object {
            shape,
            transform: motion.clone(),
            material,
            micropolygon_length: 1.0,
            source: format!("{}: <{source}>", stage.file),
            identity: Identity {
                object: path.clone(),
                instance: path.clone(),
            },
            sides: Sides::Both,
            visibility: Visibility::default(),
        };
        if let (false, Shape::Mesh(m)) = (subsets.is_empty(), &shape) {
            // Per-face materials: one object per material, each with its faces' triangles.
            let mut parts = Vec::new();
            for (subset, _) in &subsets {
                let b = crate::shading::bound_material(
                    &values,
                    &stage_dir,
                    subset,
                    time,
                    &mut scene,
                    &mut materials,
                )?;
                parts.push(b.map_or(material, |b| b.material));
            }
            for (which, triangles) in split_faces(&values, path, time, &subsets, &m.triangles)? {
                let (material, source) = match which {
                    Some(i) => (parts[i], subsets[i].0.as_str()),
                    None => (material, path.as_str()),
                };
                let part = Mesh {
                    triangles,
                    ..m.clone()
                };
                scene.objects.push(object(Shape::Mesh(part), material, source));
            }
            continue;
        }
        scene.objects.push(object(shape, material, path));
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
                    false,
                    &mut scene.warnings,
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
    let ri_camera = crate::ri::RiCamera::read(stage, &cam.path, Time::Code(t))?;
    ri_camera.apply(stage, &cam.path, &mut scene.camera)?;
    let distortion_unused = |scene: &mut Scene, why: &str| {
        if ri_camera.lens_distortion.is_some() {
            scene.warnings.push(format!(
                "{}: <{}>: lensDistortion:* is not applied: {why} (hdPrman gives it to the perspective PxrCamera only)",
                stage.file, cam.path
            ));
        }
    };
    if let Some(lens) = stage.lens(&cam.path, Time::Code(t))? {
        scene.projection = "CalibratedCamera".into();
        scene.projection_params = lens.param_list(&format!("{}: <{}> {}", stage.file, cam.path, lens.schema));
        scene.camera.screen_window = None;
        distortion_unused(scene, &format!("the camera renders through {}", lens.schema));
        return Ok(());
    }
    if let Some(ri) = crate::ri::projection(stage, &cam.path, Time::Code(t))?
        && ri.name != "PxrPerspective"
    {
        distortion_unused(
            scene,
            &format!("the camera renders through {} from <{}>", ri.name, ri.source),
        );
        scene.projection = ri.name;
        scene.projection_params = ri.params;
        scene.projection_origin = Some(format!("{}: <{}>", stage.file, ri.source));
        return Ok(());
    }
    if cam.projection == "orthographic" {
        distortion_unused(scene, "the camera is orthographic");
        scene.projection = "PxrOrthographic".into();
        return Ok(());
    }
    if let Some(d) = &ri_camera.lens_distortion {
        // hdPrman's PxrCamera: fov = 2·atan(W/2f) over the screen window normalised by half the
        // camera's own horizontal aperture, so the distortion's x is ±1 at the gate's sides.
        scene.projection = "PxrCamera".into();
        let half = cam.horizontal_aperture / 2.0;
        let fov = 2.0 * (half / cam.focal_length).atan().to_degrees();
        push(scene, "float fov", fov as f32, "focalLength");
        let k = cam.focal_length / half;
        scene.camera.screen_window = Some(ScreenWindow::new(
            (l * k) as f32,
            (r * k) as f32,
            (b * k) as f32,
            (top * k) as f32,
        ));
        let (params, warnings) = d.pxrcamera_params(&stage.file, &cam.path);
        for (decl, v, attr) in params {
            push(scene, decl, v, attr);
        }
        scene.warnings.extend(warnings);
    } else {
        scene.projection = "PxrPerspective".into();
        push(scene, "float fov", 90.0, "focalLength");
    }
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

/// The `GeomSubset` children of mesh `path` in the `materialBind` family with `elementType` `face`:
/// each subset's path and its face indices.
fn material_subsets(
    values: &Values<'_>,
    prims: &[(String, String)],
    path: &str,
    time: Time,
) -> Result<Vec<(String, Vec<i64>)>, UsdError> {
    let mut out = Vec::new();
    for (child, ty) in prims {
        let is_child = child
            .strip_prefix(path)
            .and_then(|rest| rest.strip_prefix('/'))
            .is_some_and(|name| !name.contains('/'));
        if ty != "GeomSubset" || !is_child {
            continue;
        }
        let family = values.token_opt(child, "familyName", Time::Default)?;
        let element = values
            .token_opt(child, "elementType", Time::Default)?
            .unwrap_or_else(|| "face".into());
        if family.as_deref() != Some("materialBind") || element != "face" {
            continue;
        }
        let indices = values.ints_opt(child, "indices", time)?.unwrap_or_default();
        out.push((child.clone(), indices));
    }
    Ok(out)
}

/// The triangles of the faces of one subset (its index), or of the faces in none (`None`).
type FaceGroup = (Option<usize>, Vec<[u32; 3]>);

/// The fanned `triangles` of mesh `path` (each face's `c − 2`, in face order, as [`mesh`] makes
/// them) grouped by the subset each face belongs to (`None`: no subset); a face listed by two subsets belongs to the first (UsdGeomSubset's
/// `materialBind` family must not overlap). A face index outside the mesh is a located error.
fn split_faces(
    values: &Values<'_>,
    path: &str,
    time: Time,
    subsets: &[(String, Vec<i64>)],
    triangles: &[[u32; 3]],
) -> Result<Vec<FaceGroup>, UsdError> {
    let counts = values
        .ints_opt(path, "faceVertexCounts", time)?
        .unwrap_or_default();
    let mut owner: Vec<Option<usize>> = vec![None; counts.len()];
    for (i, (subset, faces)) in subsets.iter().enumerate() {
        for &f in faces {
            let slot = usize::try_from(f)
                .ok()
                .and_then(|f| owner.get_mut(f))
                .ok_or_else(|| {
                    values.error(
                        subset,
                        "indices",
                        format!("face {f} is outside the {} faces of <{path}>", counts.len()),
                    )
                })?;
            slot.get_or_insert(i);
        }
    }
    let mut groups: Vec<FaceGroup> = Vec::new();
    let mut next = triangles.iter();
    for (face, &c) in counts.iter().enumerate() {
        let which = owner[face];
        let tris: Vec<[u32; 3]> = next
            .by_ref()
            .take(c.saturating_sub(2) as usize)
            .copied()
            .collect();
        match groups.iter_mut().find(|(w, _)| *w == which) {
            Some((_, g)) => g.extend(tris),
            None => groups.push((which, tris)),
        }
    }
    Ok(groups)
}

fn mesh(
    values: &Values<'_>,
    path: &str,
    time: Time,
    uv: Option<&str>,
    polygons: bool,
    warnings: &mut Vec<String>,
) -> Result<Option<Shape>, UsdError> {
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
        && !polygons
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
    let normals = normals_of(values, path, time, positions.len(), &counts, warnings)?;
    let vertex_normals = |n: &Option<Primvar3>| match n {
        Some(Primvar3::Vertex(n)) => Some(n.clone()),
        _ => None,
    };
    match (uvs, normals) {
        (Some(Primvar::Vertex(uv)), n @ (None | Some(Primvar3::Vertex(_)))) => Ok(Some(Shape::Mesh(Mesh {
            positions,
            normals: vertex_normals(&n),
            triangles,
            uvs: vec![uv],
            colors: None,
        }))),
        (None, n @ (None | Some(Primvar3::Vertex(_)))) => Ok(Some(Shape::Mesh(Mesh {
            positions,
            normals: vertex_normals(&n),
            triangles,
            uvs: Vec::new(),
            colors: None,
        }))),
        (uvs, normals) => {
            // Face-varying coordinates or normals: one vertex per face corner (in the file's
            // corner order, which `face_indices` kept unless left-handed reversed it).
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
            let n = match normals {
                Some(Primvar3::Vertex(n)) => Some(face_indices.iter().map(|&i| n[i as usize]).collect()),
                Some(Primvar3::Corner(n)) => Some(corner_of.iter().map(|&k| n[k]).collect()),
                None => None,
            };
            let uv = match uvs {
                Some(Primvar::Vertex(uv)) => vec![face_indices.iter().map(|&i| uv[i as usize]).collect()],
                Some(Primvar::Corner(uv)) => vec![corner_of.iter().map(|&k| uv[k]).collect()],
                None => Vec::new(),
            };
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
                uvs: uv,
                colors: None,
            })))
        }
    }
}

/// Normals by vertex or by face corner (a `uniform` normal repeated on its face's corners).
enum Primvar3 {
    Vertex(Vec<Vec3>),
    Corner(Vec<Vec3>),
}

/// A polygon mesh's normals: `primvars:normals` (with its `:indices`) when authored, else
/// `normals`, by their interpolation (`vertex`/`varying` per point, `faceVarying` per face corner,
/// `uniform` per face; `constant` is none). A count that fits no interpolation is a located error.
fn normals_of(
    values: &Values<'_>,
    path: &str,
    time: Time,
    points: usize,
    counts: &[i64],
    warnings: &mut Vec<String>,
) -> Result<Option<Primvar3>, UsdError> {
    let (attr, raw) = match values.tuples_opt(path, "primvars:normals", time, 3)? {
        Some(n) => ("primvars:normals", n),
        None => match values.tuples_opt(path, "normals", time, 3)? {
            Some(n) => ("normals", n),
            None => return Ok(None),
        },
    };
    let flat: Vec<Vec3> = raw
        .iter()
        .map(|v| DVec3::new(v[0], v[1], v[2]).as_vec3())
        .collect();
    let data = if attr == "primvars:normals" {
        indexed(values, path, attr, time, flat)?
    } else {
        flat
    };
    let corners = counts.iter().sum::<i64>() as usize;
    // `normals` is vertex-interpolated unless its metadata says otherwise (UsdGeomPointBased);
    // a primvar's fallback is constant.
    let interpolation = match values.interpolation(path, attr).as_str() {
        "constant" if attr == "normals" && !has_interpolation(values, path, attr) => "vertex".to_string(),
        other => other.to_string(),
    };
    let uniform = |data: &[Vec3]| {
        counts
            .iter()
            .zip(data)
            .flat_map(|(&c, &n)| std::iter::repeat_n(n, c as usize))
            .collect()
    };
    Ok(match interpolation.as_str() {
        "constant" if data.len() <= 1 => None,
        "faceVarying" if data.len() == corners => Some(Primvar3::Corner(data)),
        "uniform" if data.len() == counts.len() => Some(Primvar3::Corner(uniform(&data))),
        "vertex" | "varying" if data.len() == points => Some(Primvar3::Vertex(data)),
        other => {
            warnings.push(format!(
                "{}: <{path}>.{attr}: {} normals with interpolation {other:?} fit neither the {points} points, \
                 the {corners} face corners nor the {} faces; the mesh is shaded with its geometric normals",
                values.file,
                data.len(),
                counts.len()
            ));
            None
        }
    })
}

/// A primvar's values `flat` expanded through its `<attr>:indices` when authored; an index outside
/// the values is a located error.
fn indexed<T: Copy>(
    values: &Values<'_>,
    path: &str,
    attr: &str,
    time: Time,
    flat: Vec<T>,
) -> Result<Vec<T>, UsdError> {
    let name = format!("{attr}:indices");
    match values.ints_opt(path, &name, time)? {
        Some(ix) => ix
            .iter()
            .map(|&i| {
                usize::try_from(i)
                    .ok()
                    .and_then(|i| flat.get(i))
                    .copied()
                    .ok_or_else(|| {
                        values.error(
                            path,
                            &name,
                            format!("index {i} outside the {} values", flat.len()),
                        )
                    })
            })
            .collect(),
        None => Ok(flat),
    }
}

/// Whether `prim.name` states its `interpolation`.
fn has_interpolation(values: &Values<'_>, prim: &str, name: &str) -> bool {
    values.states_metadata(prim, name, "interpolation")
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
    let data = indexed(values, path, &attr, time, flat)?;
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
    Ok(Mesh {
        positions: positions.into_iter().map(|p| to_axis(&axis, p)).collect(),
        normals: None,
        triangles,
        uvs: Vec::new(),
        colors: None,
    })
}

/// A point of a primitive built along +Z, turned so that +Z becomes its `axis` (`X`, `Y` or `Z`).
fn to_axis(axis: &str, p: Vec3) -> Vec3 {
    match axis {
        "X" => Vec3::new(p.z, p.x, p.y),
        "Y" => Vec3::new(p.y, p.z, p.x),
        _ => p,
    }
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

fn light(
    values: &Values<'_>,
    path: &str,
    ty: &str,
    time: Time,
    transform: Mat4,
    stage: &Stage,
    warnings: &mut Vec<String>,
) -> Result<Light, UsdError> {
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
        "DomeLight" | "DomeLight_1" => {
            // USD's dome is OpenEXR's lat-long layout in the light's frame (longitude +π at the left
            // edge, 0 toward +Z, π/2 toward +X); Obscura's dome is that layout mirrored in x.
            let mut orient = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
            if ty == "DomeLight_1" {
                let pole = values
                    .token_opt(path, "poleAxis", Time::Default)?
                    .unwrap_or_else(|| "scene".into());
                // poleAxis Z (or "scene" on a Z-up stage): the pole is +Z and longitude 0 looks
                // down −Y, R_x(+90°) applied to the dome alone.
                if pole == "Z" || (pole == "scene" && stage.up_axis == "Z") {
                    orient = Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2) * orient;
                }
            }
            Light::Dome {
                color,
                intensity,
                exposure,
                map: dome_map(values, path, time, stage, warnings)?,
                transform: transform * orient,
            }
        }
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

/// A dome's `inputs:texture:file` as the lat-long EXR PxrDomeLight reads; `None`, with a warning
/// naming the prim and the attribute, for a layout or a file it cannot read (the dome then lights
/// with its colour alone).
fn dome_map(
    values: &Values<'_>,
    path: &str,
    time: Time,
    stage: &Stage,
    warnings: &mut Vec<String>,
) -> Result<Option<std::path::PathBuf>, UsdError> {
    let Some(raw) = values.raw(path, "inputs:texture:file", time)? else {
        return Ok(None);
    };
    let openusd::sdf::Value::AssetPath(asset) = raw else {
        return Err(values.error(path, "inputs:texture:file", "expected an asset path"));
    };
    if asset.authored_path.is_empty() {
        return Ok(None);
    }
    let format = values
        .token_opt(path, "inputs:texture:format", time)?
        .unwrap_or_else(|| "automatic".into());
    let mut skip = |why: String| {
        warnings.push(format!(
            "{}: <{path}>.inputs:texture:file @{}@ is not applied: {why}; the dome lights with its colour alone",
            stage.file, asset.authored_path
        ));
        Ok(None)
    };
    if !matches!(format.as_str(), "automatic" | "latlong") {
        return skip(format!(
            "inputs:texture:format {format:?} (only latlong maps are read)"
        ));
    }
    let stage_dir = std::path::Path::new(&stage.file)
        .parent()
        .unwrap_or(std::path::Path::new(""));
    match crate::shading::image_source(stage_dir, &asset, &stage.file, path)? {
        obscura_scene::texture::ImageSource::File(file) => {
            let exr = file
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
            if !exr {
                return skip("PxrDomeLight reads OpenEXR lat-long maps only".into());
            }
            if !file.is_file() {
                return skip(format!("{} does not exist", file.display()));
            }
            Ok(Some(file))
        }
        _ => skip("a map inside a .usdz package is not read for a dome".into()),
    }
}

/// A `Capsule` (`radius`, `height` of the cylinder between the hemispherical caps, `axis`) or a
/// `Capsule_1` with equal `radiusTop` and `radiusBottom`, as a mesh: 64 segments around, 16 rings on
/// each cap, the whole `height + 2·radius` long. A `Capsule_1` with different radii is left out with
/// a warning naming the prim (its tapered caps are not meshed).
fn capsule(
    values: &Values<'_>,
    path: &str,
    ty: &str,
    time: Time,
    warnings: &mut Vec<String>,
) -> Result<Option<Mesh>, UsdError> {
    let (r, h) = if ty == "Capsule_1" {
        let top = values.real(path, "radiusTop", time, 0.5)?;
        let bottom = values.real(path, "radiusBottom", time, 0.5)?;
        if top != bottom {
            warnings.push(format!(
                "{}: <{path}>: a Capsule_1 with radiusTop {top} and radiusBottom {bottom} is not rendered \
                 (tapered caps are not meshed; equal radii are)",
                values.file
            ));
            return Ok(None);
        }
        (top, values.real(path, "height", time, 1.0)?)
    } else {
        (
            values.real(path, "radius", time, 0.5)?,
            values.real(path, "height", time, 1.0)?,
        )
    };
    if !(r.is_finite() && h.is_finite() && r >= 0.0 && h >= 0.0) {
        return Err(values.error(
            path,
            "radius",
            format!("expected a non-negative radius and height, found {r} and {h}"),
        ));
    }
    let (r, h) = (r as f32, h as f32);
    let axis = values
        .token_opt(path, "axis", Time::Default)?
        .unwrap_or_else(|| "Z".into());
    let (around, rings) = (64u32, 16u32);
    // Rings from the bottom pole to the top pole: the bottom cap's, then the top cap's (the
    // cylinder is the band between the two equators).
    let mut profile = Vec::new();
    for k in 0..=rings {
        let a = -std::f32::consts::FRAC_PI_2 + k as f32 / rings as f32 * std::f32::consts::FRAC_PI_2;
        profile.push((r * a.cos(), -h / 2.0 + r * a.sin()));
    }
    for k in 0..=rings {
        let a = k as f32 / rings as f32 * std::f32::consts::FRAC_PI_2;
        profile.push((r * a.cos(), h / 2.0 + r * a.sin()));
    }
    let mut positions = Vec::new();
    for &(rad, z) in &profile {
        for j in 0..around {
            let a = j as f32 / around as f32 * std::f32::consts::TAU;
            positions.push(Vec3::new(rad * a.cos(), rad * a.sin(), z));
        }
    }
    let mut triangles = Vec::new();
    for i in 0..profile.len() as u32 - 1 {
        for j in 0..around {
            let (a0, a1) = (i * around + j, i * around + (j + 1) % around);
            let (b0, b1) = (a0 + around, a1 + around);
            triangles.push([a0, a1, b1]);
            triangles.push([a0, b1, b0]);
        }
    }
    Ok(Some(Mesh {
        positions: positions.into_iter().map(|p| to_axis(&axis, p)).collect(),
        normals: None,
        triangles,
        uvs: Vec::new(),
        colors: None,
    }))
}
