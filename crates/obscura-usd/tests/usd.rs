//! The USD reader end to end: the rays of a stage's camera against the formula the file's numbers
//! define (the pinhole of its gate and focal length; each lens-distortion model's documented
//! mapping), RenderMan's projection wiring, and bad input as located errors. (Attribute values and
//! transforms against usd-core: `crates/obscura-python/tests/test_usd.py`.)

use std::path::{Path, PathBuf};

use obscura_host::{Batch, CameraDesc, CameraStage};
use obscura_plugins::builtin_registry;
use obscura_scene::Scene;
use obscura_scene::source::SceneSource;
use obscura_sdk::{Format, ParamValue, Point2};
use obscura_usd::{Options, Stage, Time, open};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The scene of frame `frame` of `file` through `camera`, rendered at `w × h`.
fn scene(file: &Path, camera: Option<&str>, w: u32, h: u32, frame: u32) -> Scene {
    let options = Options {
        camera: camera.map(str::to_string),
        ..Options::default()
    };
    let source = open(file, CameraDesc::new(Format::new(w, h)), &options).unwrap();
    source.frame(frame).unwrap()
}

/// The camera-space ray directions (Obscura's: +Z forward, +Y up) at raster positions `at`.
fn rays(scene: &Scene, at: &[(f64, f64)]) -> Vec<[f64; 3]> {
    let stage = CameraStage::new(
        &mut builtin_registry(),
        &scene.projection,
        &scene.projection_params,
        &scene.camera,
    )
    .unwrap();
    let mut batch = Batch::with_capacity(at.len());
    for &(x, y) in at {
        batch.push(scene.camera.raster_to_screen(x, y), Point2::new(0.5, 0.5), 0.0);
    }
    let report = stage.run(&mut batch);
    assert!(report.is_clean(), "{report:?}");
    batch
        .rays
        .iter()
        .map(|r| {
            [
                f64::from(r.direction.x),
                f64::from(r.direction.y),
                f64::from(r.direction.z),
            ]
        })
        .collect()
}

/// The projection parameters without depth of field (`fov` alone).
fn pinhole_only(s: &Scene) -> obscura_sdk::ParamList {
    let mut list = obscura_sdk::ParamList::new();
    let fov = s.projection_params.get("fov").unwrap();
    list.push("float fov", fov.value.clone(), None).unwrap();
    list
}

/// The angle between two directions, radians (accurate at small angles).
fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let cross = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let c = (cross[0].powi(2) + cross[1].powi(2) + cross[2].powi(2)).sqrt();
    let d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    c.atan2(d)
}

fn grid(w: f64, h: f64, n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for i in 0..n {
        for j in 0..n {
            out.push(((i as f64 + 0.5) / n as f64 * w, (j as f64 + 0.5) / n as f64 * h));
        }
    }
    out
}

const RAY_TOLERANCE: f64 = 2e-7;

#[test]
fn a_plain_camera_is_the_pinhole_of_its_gate_and_focal_length() {
    // cameras.usda /World/Shot: 36 x 24 gate, offsets (1.5, −0.75), focal length 35 → 85 over time
    // codes 1…5 (60 at 3); the RenderSettings crop the gate to the image (cropAperture): at 2:1 the
    // gate is 36 x 18.
    let (w, h) = (120.0, 60.0);
    let mut s = scene(&data("cameras.usda"), None, 120, 60, 3);
    assert_eq!(s.projection, "PxrPerspective");
    // The chief rays: without the lens (its depth of field is checked below).
    s.projection_params = pinhole_only(&s);
    let at = grid(w, h, 9);
    let (gw, gh, ox, oy, f) = (36.0, 18.0, 1.5, -0.75, 60.0);
    let mut worst: f64 = 0.0;
    for (&(x, y), d) in at.iter().zip(rays(&s, &at)) {
        let film = [(x / w - 0.5) * gw + ox, (0.5 - y / h) * gh + oy, f];
        worst = worst.max(angle(d, film));
    }
    assert!(worst <= RAY_TOLERANCE, "worst {worst:e} rad");
    // The unauthored camera: the schema's 20.955 x 15.2908 gate and focal length 50, cropped to a
    // 4:3 image by the stage's RenderSettings (cropAperture).
    let s = scene(&data("cameras.usda"), Some("Plain"), 80, 60, 1);
    let at = grid(80.0, 60.0, 7);
    let (ga, gb) = (20.955_f64, 15.2908_f64);
    let (gw, gh) = if 80.0 / 60.0 > ga / gb {
        (ga, ga * 60.0 / 80.0)
    } else {
        (gb * 80.0 / 60.0, gb)
    };
    let mut worst: f64 = 0.0;
    for (&(x, y), d) in at.iter().zip(rays(&s, &at)) {
        worst = worst.max(angle(d, [(x / 80.0 - 0.5) * gw, (0.5 - y / 60.0) * gh, 50.0]));
    }
    assert!(worst <= RAY_TOLERANCE, "worst {worst:e} rad");
}

#[test]
fn depth_of_field_shutter_clipping_and_exposure_come_from_the_camera() {
    let s = scene(&data("cameras.usda"), None, 60, 40, 3);
    let float = |n: &str| match s.projection_params.get(n).map(|e| &e.value) {
        Some(ParamValue::Floats(v)) => v[0],
        other => panic!("{n}: {other:?}"),
    };
    assert_eq!(float("fStop"), 2.8);
    assert!((float("focalLength") - 6.0).abs() < 1e-6, "60 tenths of a unit");
    assert_eq!(float("focalDistance"), 12.0);
    assert_eq!(s.camera.shutter, (-0.25, 0.25));
    assert_eq!(s.camera.clipping, (0.1, 500.0));
    assert_eq!(s.exposure.gain, 2.0);
    // The camera moves (translate and rotateX are sampled): samples at both shutter ends, distinct.
    assert!(s.camera.world_to_camera.len() >= 2);
    assert_ne!(s.camera.world_to_camera[0], s.camera.world_to_camera[1]);
    // The clipping plane (0, 0, 1, 50) cuts z_usd < −50: 50 units in front of the camera (USD looks down −Z).
    assert_eq!(s.clip_planes.len(), 1);
    let p = &s.clip_planes[0];
    let ahead = |z: f32| (glam::Vec3::new(0.0, 0.0, z) - p.point).dot(p.normal) > 0.0;
    assert!(ahead(60.0) && !ahead(40.0));
}

#[test]
fn an_orthographic_camera_is_its_gate_in_scene_units() {
    let s = scene(&data("cameras.usda"), Some("/World/Ortho"), 100, 50, 1);
    assert_eq!(s.projection, "PxrOrthographic");
    let w = s.camera.screen_window();
    // 200 x 100 tenths of a unit: 20 x 10 units.
    assert_eq!((w.left, w.right, w.bottom, w.top), (-10.0, 10.0, -5.0, 5.0));
}

/// (x, y) on the normalised plane of OpenCV's camera (+Y down) to a pixel by the OpenCV rational
/// model with thin prism, as OpenCV documents it.
fn opencv_pinhole(k: &[f64; 16], x: f64, y: f64) -> (f64, f64) {
    let [fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4] = *k;
    let r2 = x * x + y * y;
    let radial = (1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2)
        / (1.0 + k4 * r2 + k5 * r2 * r2 + k6 * r2 * r2 * r2);
    let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + s1 * r2 + s2 * r2 * r2;
    let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + s3 * r2 + s4 * r2 * r2;
    (fx * xd + cx, fy * yd + cy)
}

/// OpenCV's fisheye (Kannala–Brandt) model.
fn opencv_fisheye(k: &[f64; 8], x: f64, y: f64) -> (f64, f64) {
    let [fx, fy, cx, cy, k1, k2, k3, k4] = *k;
    let r = (x * x + y * y).sqrt();
    let t = r.atan();
    let t2 = t * t;
    let td = t * (1.0 + k1 * t2 + k2 * t2 * t2 + k3 * t2 * t2 * t2 + k4 * t2 * t2 * t2 * t2);
    (fx * td * x / r + cx, fy * td * y / r + cy)
}

/// Checks the rays of distorted camera `camera` of lenses.usda: for each direction `(x, y, 1)` of
/// OpenCV's frame in `dirs`, the ray at the pixel `model` maps it to (plus ½: OpenCV's pixel centres
/// to raster positions) points along it.
fn check_forward(
    camera: &str,
    size: (u32, u32),
    dirs: &[(f64, f64)],
    model: impl Fn(f64, f64) -> (f64, f64),
) {
    let s = scene(&data("lenses.usda"), Some(camera), size.0, size.1, 1);
    assert_eq!(s.projection, "CalibratedCamera");
    let at: Vec<(f64, f64)> = dirs
        .iter()
        .map(|&(x, y)| model(x, y))
        .map(|(u, v)| (u + 0.5, v + 0.5))
        .collect();
    let mut worst: f64 = 0.0;
    for (&(x, y), d) in dirs.iter().zip(rays(&s, &at)) {
        worst = worst.max(angle([d[0], -d[1], d[2]], [x, y, 1.0]));
    }
    assert!(worst <= RAY_TOLERANCE, "{camera}: worst {worst:e} rad");
}

fn directions(extent: f64) -> Vec<(f64, f64)> {
    let n = 7;
    let mut out = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let x = (i as f64 / (n - 1) as f64 * 2.0 - 1.0) * extent;
            let y = (j as f64 / (n - 1) as f64 * 2.0 - 1.0) * extent * 0.6;
            if x != 0.0 || y != 0.0 {
                out.push((x, y));
            }
        }
    }
    out
}

#[test]
fn omni_opencv_pinhole_rays_follow_opencvs_formula() {
    let k = [
        900.0, 905.0, 645.5, 355.25, -0.12, 0.03, 0.0005, -0.0003, -0.002, 0.01, 0.0, 0.0, 0.0002, 0.0, 0.0,
        -0.0001,
    ];
    let k = k.map(|v: f64| f64::from(v as f32));
    check_forward("Pinhole", (1280, 720), &directions(0.6), |x, y| {
        opencv_pinhole(&k, x, y)
    });
}

#[test]
fn omni_opencv_fisheye_rays_follow_opencvs_formula() {
    let k = [320.0, 321.0, 511.5, 512.5, 0.05, -0.01, 0.002, -0.0003].map(|v: f64| f64::from(v as f32));
    check_forward("Fisheye", (1024, 1024), &directions(2.5), |x, y| {
        opencv_fisheye(&k, x, y)
    });
}

/// f-theta: the ray of pixel (u, v) is at angle θ = k0 + k1·ρ + … + k4·ρ⁴ from the axis, ρ the
/// pixel's distance from the optical centre (NVIDIA's backward polynomial).
fn check_ftheta(camera: &str, size: (u32, u32), centre: (f64, f64), k: [f64; 5]) {
    let max_angle = 100_f64.to_radians(); // maxFov 200° in both cameras
    let s = scene(&data("lenses.usda"), Some(camera), size.0, size.1, 1);
    assert_eq!(s.projection, "CalibratedCamera");
    let (cx, cy) = (f64::from(centre.0 as f32), f64::from(centre.1 as f32));
    let k = k.map(|v| f64::from(v as f32));
    let pixels: Vec<(f64, f64)> = grid(f64::from(size.0) - 1.0, f64::from(size.1) - 1.0, 9)
        .into_iter()
        .filter(|&(u, v)| (u - cx).hypot(v - cy) > 1.0)
        .collect();
    let at: Vec<(f64, f64)> = pixels.iter().map(|&(u, v)| (u + 0.5, v + 0.5)).collect();
    let mut worst: f64 = 0.0;
    for (&(u, v), d) in pixels.iter().zip(rays(&s, &at)) {
        let rho = (u - cx).hypot(v - cy);
        let theta = k[0] + k[1] * rho + k[2] * rho.powi(2) + k[3] * rho.powi(3) + k[4] * rho.powi(4);
        if theta > max_angle {
            // Beyond maxFov/2: no ray.
            assert_eq!(d, [0.0; 3], "{camera}: a ray at θ = {theta} > maxFov/2");
            continue;
        }
        let want = [
            theta.sin() * (u - cx) / rho,
            theta.sin() * (v - cy) / rho,
            theta.cos(),
        ];
        worst = worst.max(angle([d[0], -d[1], d[2]], want));
    }
    assert!(worst <= RAY_TOLERANCE, "{camera}: worst {worst:e} rad");
}

#[test]
fn omni_ftheta_rays_follow_nvidias_polynomial() {
    check_ftheta(
        "Ftheta",
        (1936, 1216),
        (970.9424, 600.3748),
        [0.0, 0.00245, 1e-8, -2e-11, 0.0],
    );
}

#[test]
fn isaac_sims_legacy_fisheye_polynomial_is_the_same_ftheta() {
    check_ftheta(
        "IsaacLegacy",
        (1920, 1080),
        (960.0, 540.0),
        [0.0, 0.0024, 0.0, 0.0, 0.0],
    );
}

#[test]
fn renderman_projections_are_wired_as_hdprman_reads_them() {
    let file = data("ri_projection.usda");
    let pano = scene(&file, Some("Pano"), 64, 32, 1);
    assert_eq!(pano.projection, "PxrCylinderCamera");
    // An error about the projection (an unknown name, a bad parameter) names the prim it came from.
    let origin = pano.projection_origin.as_deref().unwrap_or_default();
    assert!(
        origin.ends_with("ri_projection.usda: </World/Pano/Projection>"),
        "{origin}"
    );
    let hsweep = pano.projection_params.get("hsweep").map(|e| e.value.clone());
    assert_eq!(hsweep, Some(ParamValue::Floats(vec![270.0])));
    let legacy = scene(&file, Some("Legacy"), 64, 32, 1);
    assert_eq!(legacy.projection, "PxrSphereCamera");
    // The RenderSettings' camera with its ri:projection:name and parameters.
    let plain = scene(&file, None, 64, 32, 1);
    assert_eq!(plain.projection, "PxrPanini");
    let origin = plain.projection_origin.as_deref().unwrap_or_default();
    assert!(
        origin.ends_with("ri_projection.usda: </Render/Settings>"),
        "{origin}"
    );
    let c = plain
        .projection_params
        .get("compression")
        .map(|e| e.value.clone());
    assert_eq!(c, Some(ParamValue::Floats(vec![0.5])));
    // Each renders through the built-in table.
    for s in [&pano, &legacy, &plain] {
        assert_eq!(rays(s, &[(10.0, 10.0)]).len(), 1);
    }
}

#[test]
fn time_codes_are_the_frames_and_the_stage_is_turned_to_y_up() {
    let source = open(
        &data("cameras.usda"),
        CameraDesc::new(Format::new(32, 32)),
        &Options::default(),
    )
    .unwrap();
    let numbers: Vec<u32> = source.images().iter().map(|i| i.number).collect();
    assert_eq!(numbers, [1, 2, 3, 4, 5]);
    assert!(source.frame(6).is_err());
    let stage = Stage::open(&data("cameras.usda")).unwrap();
    assert_eq!((stage.up_axis.as_str(), stage.meters_per_unit), ("Z", 1.0));
    // Integer time samples on a float attribute interpolate (rotateX −15 at 1, −14 at 3).
    let at2 = stage
        .camera("/World/Shot", Time::Code(2.0))
        .unwrap()
        .camera_to_world;
    let at1 = stage
        .camera("/World/Shot", Time::Code(1.0))
        .unwrap()
        .camera_to_world;
    let at3 = stage
        .camera("/World/Shot", Time::Code(3.0))
        .unwrap()
        .camera_to_world;
    assert_ne!(at2, at1);
    assert_ne!(at2, at3);
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn error_of(path: &Path, camera: Option<&str>) -> String {
    let options = Options {
        camera: camera.map(str::to_string),
        ..Options::default()
    };
    match open(path, CameraDesc::new(Format::new(16, 16)), &options) {
        Err(e) => e.to_string(),
        Ok(source) => match source.frame(1) {
            Err(e) => e.to_string(),
            Ok(s) => s.warnings.join("\n"),
        },
    }
}

/// `kannalaBrandtK3`, `radTanThinPrism` and `lut`: NVIDIA publishes their attribute names but no
/// formula turning `k0…`, the nominal size and the optical centre into rays, so a stage using
/// one is refused, naming the prim and the schema, whether the model token or only the applied
/// schema says which model it is; never rendered through a guessed mapping.
#[test]
fn omni_models_without_a_documented_projection_are_refused_naming_the_schema() {
    let dir = tempfile::tempdir().unwrap();
    for (model, api) in [
        ("kannalaBrandtK3", "OmniLensDistortionKannalaBrandtK3API"),
        ("radTanThinPrism", "OmniLensDistortionRadTanThinPrismAPI"),
        ("lut", "OmniLensDistortionLutAPI"),
    ] {
        let attrs = format!(
            "    float omni:lensdistortion:{model}:nominalWidth = 1936\n    \
             float omni:lensdistortion:{model}:nominalHeight = 1216\n    \
             float2 omni:lensdistortion:{model}:opticalCenter = (968, 608)\n"
        );
        for with_token in [true, false] {
            let token = if with_token {
                format!("    token omni:lensdistortion:model = \"{model}\"\n")
            } else {
                String::new()
            };
            let p = write(
                dir.path(),
                &format!("{model}-{with_token}.usda"),
                &format!(
                    "#usda 1.0\ndef Camera \"Cam\" (\n    prepend apiSchemas = [\"{api}\"]\n)\n{{\n{token}{attrs}}}\n"
                ),
            );
            let e = error_of(&p, None);
            assert!(
                e.contains("</Cam>") && e.contains(api) && e.contains("is not supported"),
                "{model} (token {with_token}): {e}"
            );
        }
    }
}

#[test]
fn bad_input_is_a_located_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A non-numeric aperture.
    let p = write(
        d,
        "aperture.usda",
        "#usda 1.0\ndef Camera \"Cam\"\n{\n    string horizontalAperture = \"wide\"\n}\n",
    );
    let e = error_of(&p, None);
    assert!(
        e.contains("aperture.usda")
            && e.contains("</Cam>")
            && e.contains("horizontalAperture")
            && e.contains("expected a number"),
        "{e}"
    );
    // A lens-distortion schema without its focal length.
    let p = write(
        d,
        "lens.usda",
        "#usda 1.0\ndef Camera \"Cam\" (\n    prepend apiSchemas = [\"OmniLensDistortionOpenCvPinholeAPI\"]\n)\n{\n    \
         int2 omni:lensdistortion:opencvPinhole:imageSize = (640, 480)\n    float omni:lensdistortion:opencvPinhole:fy = 500\n    \
         float omni:lensdistortion:opencvPinhole:cx = 320\n    float omni:lensdistortion:opencvPinhole:cy = 240\n}\n",
    );
    let e = error_of(&p, None);
    assert!(
        e.contains("</Cam>")
            && e.contains("omni:lensdistortion:opencvPinhole:fx")
            && e.contains("not authored"),
        "{e}"
    );
    // An unknown --camera names the stage's cameras.
    let e = error_of(&data("cameras.usda"), Some("/World/Nope"));
    assert!(
        e.contains("--camera /World/Nope") && e.contains("/World/Shot"),
        "{e}"
    );
    // A missing reference: a warning naming the layer and the asset.
    let p = write(
        d,
        "missing.usda",
        "#usda 1.0\ndef Xform \"A\" (\n    references = @./nowhere.usda@\n)\n{\n}\n",
    );
    let e = error_of(&p, None);
    assert!(e.contains("missing.usda") && e.contains("nowhere.usda"), "{e}");
    // A cyclic sublayer.
    write(d, "b.usda", "#usda 1.0\n(\n    subLayers = [@./a.usda@]\n)\n");
    let p = write(
        d,
        "a.usda",
        "#usda 1.0\n(\n    subLayers = [@./b.usda@]\n)\ndef Camera \"Cam\"\n{\n}\n",
    );
    let e = error_of(&p, None);
    assert!(
        e.contains("a.usda") && (e.contains("cycl") || e.contains("Cycl") || e.contains("recurs")),
        "{e}"
    );
    // A file that is not USD at all.
    let p = write(d, "junk.usda", "#usda 1.0\ndef Camera \"Cam\" {{{\n");
    let e = error_of(&p, None);
    assert!(
        e.contains("junk.usda") && e.contains("cannot open the stage"),
        "{e}"
    );
}

#[test]
fn a_stage_without_camera_or_light_is_staged_like_gltf() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "box.usda",
        "#usda 1.0\ndef Mesh \"Tri\"\n{\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)]\n    \
         int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 3, 2]\n    uniform token subdivisionScheme = \"none\"\n}\n",
    );
    let s = scene(&p, None, 32, 32, 1);
    assert_eq!(
        s.auto_camera,
        Some((glam::Vec3::ZERO, glam::Vec3::new(1.0, 1.0, 0.0)))
    );
    assert!(s.auto_light);
    match &s.objects[0].shape {
        obscura_scene::Shape::Mesh(m) => assert_eq!(m.triangles, [[0, 1, 3], [0, 3, 2]]),
        other => panic!("{other:?}"),
    }
    assert_eq!(s.objects[0].identity.object, "/Tri");
}

#[test]
fn a_point_instancer_places_its_prototypes_and_hides_invisible_ids() {
    let s = scene(&data("instancer.usda"), None, 32, 32, 1);
    // Four instances, id 3 invisible; the prototypes themselves are not rendered.
    assert_eq!(s.objects.len(), 3);
    let names: Vec<&str> = s.objects.iter().map(|o| o.identity.instance.as_str()).collect();
    assert_eq!(names, ["/World/Crowd[0]", "/World/Crowd[1]", "/World/Crowd[2]"]);
    // Instance 2: the box (its own translate (0, 0.5, 0)) scaled by 2 at (6, 0, 0) under the
    // instancer's parent at (0, 1, 0): T(0,1,0)·T(6,0,0)·S(2)·T(0,0.5,0).
    let m = s.objects[2].transform.samples[0].1;
    let origin = m.transform_point3(glam::Vec3::ZERO);
    assert!(
        (origin - glam::Vec3::new(6.0, 2.0, 0.0)).length() < 1e-6,
        "{origin}"
    );
    assert!((m.transform_vector3(glam::Vec3::X).length() - 2.0).abs() < 1e-6);
    // Instance 1: the ball turned 90° about Z at (3, 0, 0).
    let m = s.objects[1].transform.samples[0].1;
    assert!((m.transform_vector3(glam::Vec3::X) - glam::Vec3::Y).length() < 1e-3);
    assert!(matches!(s.objects[1].shape, obscura_scene::Shape::Sphere { radius, .. } if radius == 0.5));
}

/// hdPrman's camera attributes (`hdPrman/camera.cpp`, `cameraContext.cpp`): `ri:shutterOpenTime`,
/// `ri:shutterCloseTime`, `ri:shutteropening` and the `ri:aperture*` shape go to the host's shutter
/// opening and aperture; Hydra's `lensDistortion:k1/k2/anaSq/asym` make the camera PxrCamera with
/// `fov = 2·atan(W/2f)` over the window normalised by half the gate width, so the rays are
/// PxrCamera's division model on the gate: `s = film/(W/2)`, `q = (sx/anaSq)² + sy²`,
/// `u = (sx/(1 + (k1 + asymX)q + k2q²), sy/(1 + (k1 + asymY)q + k2q²))`, direction `(u·W/2, f)`.
#[test]
fn hdprman_camera_attributes_and_lens_distortion_are_read_as_hdprman_reads_them() {
    let file = data("ri_camera.usda");
    let (w, h) = (120.0, 80.0);
    let s = scene(&file, Some("Warped"), 120, 80, 1);
    assert_eq!(s.projection, "PxrCamera");
    let o = &s.camera.shutter_opening;
    assert_eq!((o.open_time, o.close_time), (0.2, 0.7));
    assert_eq!(o.opening, [0.1, 0.2, 0.3, 0.4, 0.6, 0.7, 0.8, 0.9]);
    let a = &s.camera.aperture;
    assert_eq!(
        (a.n_sides, a.angle_deg, a.roundness, a.density),
        (6, 15.0, 0.25, -0.5)
    );
    assert_eq!(
        s.camera.shutter,
        (-0.25, 0.25),
        "USD's shutter:open/close stay the interval"
    );
    let (k1, k2, sq, ax, ay) = (-0.12, 0.03, 1.33, 0.02, -0.01);
    let (gw, gh, ox, oy, f) = (36.0, 24.0, 2.0, -1.0, 35.0);
    let at = grid(w, h, 9);
    let mut worst: f64 = 0.0;
    for (&(x, y), d) in at.iter().zip(rays(&s, &at)) {
        let film = [(x / w - 0.5) * gw + ox, (0.5 - y / h) * gh + oy];
        let (sx, sy) = (film[0] / (gw / 2.0), film[1] / (gw / 2.0));
        let q = (sx / sq).powi(2) + sy * sy;
        let ux = sx / (1.0 + (k1 + ax) * q + k2 * q * q);
        let uy = sy / (1.0 + (k1 + ay) * q + k2 * q * q);
        worst = worst.max(angle(d, [ux * gw / 2.0, uy * gw / 2.0, f]));
    }
    assert!(worst <= RAY_TOLERANCE, "worst {worst:e} rad");
    // A distortion centre or scale PxrCamera cannot express is warned about, naming prim and
    // attribute; the rest still applies.
    let c = scene(&file, Some("Centred"), 16, 16, 1);
    assert_eq!(c.projection, "PxrCamera");
    let warnings = c.warnings.join("\n");
    assert!(
        warnings.contains("<Centred>.lensDistortion:center")
            || warnings.contains("</World/Centred>.lensDistortion:center"),
        "{warnings}"
    );
    assert!(warnings.contains("lensDistortion:scale = 1.1"), "{warnings}");
    // hdPrman applies it to perspective cameras only: an orthographic one says it is not applied.
    let ortho = scene(&file, Some("Ortho"), 16, 16, 1);
    assert_eq!(ortho.projection, "PxrOrthographic");
    assert!(
        ortho
            .warnings
            .join("\n")
            .contains("lensDistortion:* is not applied"),
        "{:?}",
        ortho.warnings
    );
    // Bad values are located errors naming the camera and the attribute.
    for (camera, what) in [
        ("BadBlades", "ri:apertureNSides"),
        ("BadRoundness", "apertureRoundness"),
        ("BadOpening", "ri:shutteropening"),
        ("BadK1", "lensDistortion:k1"),
    ] {
        let e = error_of(&file, Some(camera));
        assert!(
            e.contains(camera) && e.contains(what) && e.contains("ri_camera.usda"),
            "{camera}: {e}"
        );
    }
}

/// The mesh of the one object a stage of `text` renders through `camera`-less staging.
fn objects_of(text: &str) -> (Scene, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "stage.usda", text);
    let options = Options {
        camera: None,
        ..Options::default()
    };
    let source = open(&p, CameraDesc::new(Format::new(16, 16)), &options).unwrap();
    (source.frame(0).unwrap(), dir)
}

/// `Capsule`: a cylinder of `height` between two hemispheres of `radius` (UsdGeomCapsule), so it is
/// `height + 2·radius` long along its axis and `radius` round; `Capsule_1` with equal radii the
/// same; with different radii it is left out with a warning naming the prim.
#[test]
fn a_capsule_is_its_cylinder_between_two_hemispheres() {
    let (s, _dir) = objects_of(
        "#usda 1.0\n(\n    upAxis = \"Y\"\n)\n\
         def Capsule \"A\" { double radius = 0.5\n double height = 2\n uniform token axis = \"Y\" }\n\
         def Capsule_1 \"B\" { double radiusTop = 0.25\n double radiusBottom = 0.25\n double height = 1\n uniform token axis = \"X\" }\n\
         def Capsule_1 \"C\" { double radiusTop = 0.25\n double radiusBottom = 0.5 }\n",
    );
    assert_eq!(s.objects.len(), 2, "{:?}", s.warnings);
    let check = |i: usize, axis: usize, r: f32, h: f32| {
        let obscura_scene::Shape::Mesh(m) = &s.objects[i].shape else {
            panic!("not a mesh")
        };
        let (mut lo, mut hi, mut round) = (f32::MAX, f32::MIN, 0.0f32);
        for p in &m.positions {
            let p = p.to_array();
            lo = lo.min(p[axis]);
            hi = hi.max(p[axis]);
            let radial = (0..3)
                .filter(|&k| k != axis)
                .map(|k| p[k] * p[k])
                .sum::<f32>()
                .sqrt();
            round = round.max(radial);
            // Every point lies on the capsule: distance r from the axis segment of length h.
            let along = p[axis].clamp(-h / 2.0, h / 2.0);
            let d = ((p[axis] - along).powi(2) + radial * radial).sqrt();
            assert!((d - r).abs() < 1e-5, "point {p:?} is {d} from the segment");
        }
        assert!(
            (lo + h / 2.0 + r).abs() < 1e-6 && (hi - h / 2.0 - r).abs() < 1e-6,
            "{lo} {hi}"
        );
        assert!((round - r).abs() < 1e-6);
    };
    check(0, 1, 0.5, 2.0);
    check(1, 0, 0.25, 1.0);
    let w = s.warnings.join("\n");
    assert!(w.contains("<C>") || w.contains("</C>"), "{w}");
}

/// A DomeLight's lat-long texture reads as USD specifies (OpenEXR's layout: longitude +π at the
/// left edge, 0 toward +Z, +π/2 toward +X; the top row +Y), and a `DomeLight_1` on a Z-up stage
/// with `poleAxis = "scene"` has its pole on +Z and longitude 0 toward −Y.
#[test]
fn a_dome_texture_is_openexrs_lat_long_as_usd_specifies() {
    let dir = tempfile::tempdir().unwrap();
    // Texel (column c, row r) = (c + 1, r + 1, 1).
    exr::prelude::write_rgba_file(dir.path().join("sky.exr"), 4, 2, |x, y| {
        ((x + 1) as f32, (y + 1) as f32, 1.0_f32, 1.0_f32)
    })
    .unwrap();
    let radiance = |stage: &str, dirs: &[([f32; 3], [f32; 2])]| {
        let p = write(dir.path(), "dome.usda", stage);
        let source = open(
            &p,
            CameraDesc::new(Format::new(8, 8)),
            &Options {
                camera: None,
                ..Options::default()
            },
        )
        .unwrap();
        let s = source.frame(0).unwrap();
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
        let lights = obscura_shading::light::Lights::new(&s.lights, dir.path()).unwrap();
        for &(d, want) in dirs {
            let (l, _) = lights.escaped(glam::Vec3A::from_array(d));
            assert_eq!([l.x, l.y], want, "direction {d:?}");
        }
    };
    // Longitude atan2(x, z): 45° → column 1, −45° → 2, 135° → 0, −135° → 3; y > 0 the top row.
    radiance(
        "#usda 1.0\n(\n    upAxis = \"Y\"\n)\ndef DomeLight \"Sky\" { asset inputs:texture:file = @sky.exr@ }\n",
        &[
            ([1.0, 0.3, 1.0], [2.0, 1.0]),
            ([-1.0, 0.3, 1.0], [3.0, 1.0]),
            ([1.0, -0.3, -1.0], [1.0, 2.0]),
            ([-1.0, -0.3, -1.0], [4.0, 2.0]),
        ],
    );
    // Z up, poleAxis "scene": USD (1, −1, 0.3) is longitude 45° above the horizon; Obscura's world
    // is the stage turned by R_x(−90°): (x, y, z) ↦ (x, z, −y).
    radiance(
        "#usda 1.0\n(\n    upAxis = \"Z\"\n)\ndef DomeLight_1 \"Sky\" { asset inputs:texture:file = @sky.exr@ }\n",
        &[([1.0, 0.3, 1.0], [2.0, 1.0]), ([-1.0, -0.3, -1.0], [4.0, 2.0])],
    );
    // A layout or a file PxrDomeLight cannot read: a warning naming the prim and the attribute,
    // and the dome lights with its colour.
    for (attrs, why) in [
        (
            "asset inputs:texture:file = @sky.exr@\n token inputs:texture:format = \"angular\"",
            "angular",
        ),
        ("asset inputs:texture:file = @sky.hdr@", "OpenEXR"),
        ("asset inputs:texture:file = @missing.exr@", "does not exist"),
    ] {
        let p = write(
            dir.path(),
            "dome.usda",
            &format!("#usda 1.0\ndef DomeLight \"Sky\" {{\n {attrs}\n}}\n"),
        );
        let source = open(&p, CameraDesc::new(Format::new(8, 8)), &Options::default()).unwrap();
        let s = source.frame(0).unwrap();
        let w = s.warnings.join("\n");
        assert!(w.contains("Sky>.inputs:texture:file") && w.contains(why), "{w}");
        let obscura_scene::Light::Dome { map, .. } = &s.lights[0] else {
            panic!()
        };
        assert!(map.is_none());
    }
}

/// `GeomSubset`s of the `materialBind` family bind materials per face: the faces of a subset render
/// with its material, the others with the mesh's; a subset of another family changes nothing; a
/// subdivision mesh with subsets renders as its polygons; a face index outside the mesh is a located
/// error naming the subset.
#[test]
fn geom_subsets_bind_materials_per_face() {
    let material = |name: &str, c: &str| {
        format!(
            "def Material \"{name}\" {{\n token outputs:surface.connect = </Looks/{name}/S.outputs:surface>\n\
             def Shader \"S\" {{\n uniform token info:id = \"UsdPreviewSurface\"\n color3f inputs:diffuseColor = {c}\n\
             float inputs:metallic = 0\n token outputs:surface\n }}\n}}\n"
        )
    };
    let stage = |indices: &str| {
        format!(
            "#usda 1.0\n(\n    upAxis = \"Y\"\n)\ndef Scope \"Looks\" {{\n{}{}}}\n\
             def Mesh \"Strip\" (\n prepend apiSchemas = [\"MaterialBindingAPI\"]\n) {{\n\
             point3f[] points = [(0,0,0), (1,0,0), (2,0,0), (3,0,0), (0,1,0), (1,1,0), (2,1,0), (3,1,0)]\n\
             int[] faceVertexCounts = [4, 4, 4]\n int[] faceVertexIndices = [0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6]\n\
             rel material:binding = </Looks/Green>\n\
             def GeomSubset \"Red\" (\n prepend apiSchemas = [\"MaterialBindingAPI\"]\n) {{\n\
             uniform token elementType = \"face\"\n uniform token familyName = \"materialBind\"\n\
             int[] indices = [{indices}]\n rel material:binding = </Looks/Red>\n }}\n\
             def GeomSubset \"Other\" {{\n uniform token elementType = \"face\"\n uniform token familyName = \"parts\"\n\
             int[] indices = [0]\n }}\n}}\n",
            material("Green", "(0, 1, 0)"),
            material("Red", "(1, 0, 0)")
        )
    };
    let (s, _dir) = objects_of(&stage("2, 0"));
    assert_eq!(s.objects.len(), 2, "{:?}", s.warnings);
    let mut seen = Vec::new();
    for o in &s.objects {
        let obscura_scene::Shape::Mesh(m) = &o.shape else {
            panic!("a mesh with subsets renders as its polygons")
        };
        let obscura_scene::Material::Surface { diffuse, .. } = &s.materials[o.material as usize] else {
            panic!("{:?}", s.materials[o.material as usize])
        };
        // Which faces: each quad is two triangles whose centroid x is its face's x + ½.
        let mut faces: Vec<u32> = m
            .triangles
            .iter()
            .map(|t| (t.iter().map(|&i| m.positions[i as usize].x).sum::<f32>() / 3.0).floor() as u32)
            .collect();
        faces.dedup();
        seen.push(((diffuse.r > 0.5, diffuse.g > 0.5), faces));
    }
    seen.sort();
    assert_eq!(
        seen,
        vec![((false, true), vec![1]), ((true, false), vec![0, 2])],
        "green on face 1, red on faces 0 and 2"
    );
    let e = objects_error(&stage("1, 7"));
    assert!(
        e.contains("/Strip/Red") && e.contains("indices") && e.contains("face 7"),
        "{e}"
    );
}

fn objects_error(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "stage.usda", text);
    error_of(&p, None)
}

/// Normals by face corner (`faceVarying`), by face (`uniform`) and by point: each corner of the
/// rendered mesh carries its own point and the normal the file gives that corner (indexed
/// `primvars:normals` win over `normals`); a left-handed mesh keeps each corner's pair while its
/// faces turn round.
#[test]
fn face_varying_and_uniform_normals_follow_their_corners() {
    let points = "[(0,0,0), (1,0,0), (2,0,0), (0,1,0), (1,1,0), (2,1,0)]";
    let topology = "int[] faceVertexCounts = [4, 4]\n int[] faceVertexIndices = [0, 1, 4, 3, 1, 2, 5, 4]\n";
    let mesh_of = |normals: &str, left: bool| {
        let orientation = if left {
            "uniform token orientation = \"leftHanded\"\n"
        } else {
            ""
        };
        let (s, _dir) = objects_of(&format!(
            "#usda 1.0\n(\n    upAxis = \"Y\"\n)\ndef Mesh \"M\" {{\n uniform token subdivisionScheme = \"none\"\n {orientation}\
             point3f[] points = {points}\n {topology} {normals}\n}}\n"
        ));
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
        let obscura_scene::Shape::Mesh(m) = &s.objects[0].shape else {
            panic!()
        };
        m.clone()
    };
    let pts = [
        [0., 0., 0.],
        [1., 0., 0.],
        [2., 0., 0.],
        [0., 1., 0.],
        [1., 1., 0.],
        [2., 1., 0.],
    ];
    let fvi = [0usize, 1, 4, 3, 1, 2, 5, 4];
    // Corner k's normal: (k, 1, 2)/|…|, distinct for every corner.
    let corner_normal = |k: usize| glam::Vec3::new(k as f32, 1.0, 2.0).normalize();
    let list = (0..8)
        .map(|k| {
            let n = corner_normal(k);
            format!("({}, {}, {})", n.x, n.y, n.z)
        })
        .collect::<Vec<_>>()
        .join(", ");
    for left in [false, true] {
        let m = mesh_of(
            &format!("normal3f[] normals = [{list}] (\n interpolation = \"faceVarying\"\n )"),
            left,
        );
        let n = m.normals.as_ref().expect("normals");
        assert_eq!(m.positions.len(), 8);
        for face in 0..2 {
            for j in 0..4 {
                // Output corner j of the face is file corner j (or 3 − j when left-handed).
                let k = face * 4 + if left { 3 - j } else { j };
                let i = face * 4 + j;
                assert_eq!(
                    m.positions[i].to_array(),
                    pts[fvi[k]].map(|v: f64| v as f32),
                    "corner {i}"
                );
                assert!(
                    (n[i] - corner_normal(k)).length() < 1e-6,
                    "corner {i}: {:?}",
                    n[i]
                );
            }
        }
    }
    // Uniform, through an indexed primvar that wins over `normals`.
    let m = mesh_of(
        "normal3f[] primvars:normals = [(0, 0, 1), (1, 0, 0)] (\n interpolation = \"uniform\"\n )\n \
         int[] primvars:normals:indices = [1, 0]\n normal3f[] normals = [(0,1,0), (0,1,0), (0,1,0), (0,1,0), (0,1,0), (0,1,0)]",
        false,
    );
    let n = m.normals.unwrap();
    assert!(
        n[..4].iter().all(|v| *v == glam::Vec3::X) && n[4..].iter().all(|v| *v == glam::Vec3::Z),
        "{n:?}"
    );
    // Per point (no interpolation stated: `normals` is vertex-interpolated).
    let m = mesh_of(
        "normal3f[] normals = [(0,0,1), (0,0,1), (0,0,1), (0,1,0), (0,1,0), (0,1,0)]",
        false,
    );
    assert_eq!(m.positions.len(), 6);
    assert_eq!(m.normals.unwrap()[4], glam::Vec3::Y);
}

/// Without a size from the caller (`product_resolution`), the RenderSettings' first product's
/// `resolution` and `pixelAspectRatio` are the image's (a product's value over the settings'), and
/// the gate is fitted to that image; with the caller's size they are not read. A bad resolution is a
/// located error.
#[test]
fn the_render_products_resolution_is_the_image_size_when_none_is_given() {
    let stage = |resolution: &str| {
        format!(
            "#usda 1.0\n(\n    renderSettingsPrimPath = \"/Render/Settings\"\n)\n\
             def Camera \"Cam\" {{\n float horizontalAperture = 36\n float verticalAperture = 24\n}}\n\
             def Scope \"Render\" {{\n def RenderSettings \"Settings\" {{\n rel camera = </Cam>\n\
             rel products = </Render/Product>\n uniform int2 resolution = (64, 64)\n\
             uniform float pixelAspectRatio = 2\n }}\n\
             def RenderProduct \"Product\" {{\n uniform int2 resolution = {resolution}\n }}\n}}\n"
        )
    };
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "product.usda", &stage("(320, 90)"));
    let with = |product_resolution: bool| {
        let options = Options {
            camera: None,
            product_resolution,
        };
        open(&p, CameraDesc::new(Format::new(16, 16)), &options)
            .unwrap()
            .frame(0)
            .unwrap()
    };
    let s = with(true);
    let f = s.camera.format;
    assert_eq!((f.width, f.height, f.pixel_aspect), (320, 90, 2.0));
    // The 36 × 24 gate expanded to the image's aspect 320·2/90 (wider): 24 high, 24·640/90 wide,
    // over focal length 50.
    let w = s.camera.screen_window();
    let half_w = 24.0 * 640.0 / 90.0 / 2.0 / 50.0;
    assert!(
        (w.right - half_w).abs() < 1e-6 && (w.top - 0.24).abs() < 1e-6,
        "{w:?}"
    );
    let s = with(false);
    assert_eq!((s.camera.format.width, s.camera.format.height), (16, 16));
    let bad = write(dir.path(), "bad.usda", &stage("(320, 0)"));
    let options = Options {
        camera: None,
        product_resolution: true,
    };
    let e = open(&bad, CameraDesc::new(Format::new(16, 16)), &options)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("/Render/Product") && e.contains("resolution") && e.contains("bad.usda"),
        "{e}"
    );
}

/// `--export-usd` of a PxrCamera with distortion writes Hydra's `lensDistortion:*`, which read back
/// give the same rays; a window hdPrman's normalisation cannot express is refused, not dropped.
#[test]
fn an_exported_pxrcamera_distortion_reads_back_as_the_same_rays() {
    let file = data("ri_camera.usda");
    // 20 × 16 is narrower than the 20.955 × 15.2908 gate: the gate keeps its width.
    let s = scene(&file, Some("Centred"), 20, 16, 1);
    let text = obscura_usd::export::camera_usda(
        &[obscura_usd::export::Frame {
            time_code: 1.0,
            scene: &s,
        }],
        24.0,
    )
    .unwrap();
    assert!(text.contains("float lensDistortion:k1 = 0.05"), "{text}");
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "back.usda", &text);
    let back = scene(&p, None, 20, 16, 1);
    assert_eq!(back.projection, "PxrCamera");
    let at = grid(20.0, 16.0, 5);
    let worst = rays(&s, &at)
        .into_iter()
        .zip(rays(&back, &at))
        .map(|(a, b)| angle(a, b))
        .fold(0.0, f64::max);
    assert!(worst <= RAY_TOLERANCE, "worst {worst:e} rad");
    // The offset gate of /World/Warped is not centred on the distortion's axis of symmetry.
    let w = scene(&file, Some("Warped"), 24, 16, 1);
    let e = obscura_usd::export::camera_usda(
        &[obscura_usd::export::Frame {
            time_code: 1.0,
            scene: &w,
        }],
        24.0,
    )
    .unwrap_err();
    assert!(e.contains("lensDistortion"), "{e}");
}
