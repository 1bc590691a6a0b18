//! Scene files read and staged as the renderer reads them ([`load`](super::super::load)): OBJ and
//! glTF files without a camera or a light, a RIB file without a light.

use std::path::Path;

use glam::Vec3;
use obscura_host::CameraDesc;
use obscura_scene::fixtures::{CUBE, Fixture, MTL, POSITIONS, write};
use obscura_scene::{Light, Scene};
use obscura_sdk::{Format, ParamValue};
use proptest::prelude::*;

use super::super::*;
use super::assert_verdicts_agree;

/// A scene as the renderer reads and stages it: the scene (its camera placed), the interior it
/// is, and the lights it renders with, as [`Staged::new`] finds them.
fn staged(path: &Path, camera: CameraDesc) -> (Scene, Option<Interior>, Vec<Light>) {
    let scene = load(path, camera).unwrap();
    let interior = probe_scene(&scene);
    let lights = lights(&scene, interior.as_ref()).into_owned();
    (scene, interior, lights)
}

// ---- OBJ ----

fn camera() -> CameraDesc {
    CameraDesc::new(Format::new(640, 480))
}

/// The cube of [`CUBE`] with `mtl` beside it, staged.
fn load_cube(mtl: Option<&str>) -> (Scene, Option<Interior>, Vec<Light>) {
    let dir = tempfile::tempdir().unwrap();
    if let Some(mtl) = mtl {
        write(&dir, "cube.mtl", mtl);
    }
    staged(&write(&dir, "cube.obj", CUBE), camera())
}

#[test]
fn obj_camera_frames_every_corner_of_the_bounds() {
    let (scene, ..) = load_cube(Some(MTL));
    assert_eq!(scene.projection, "PxrPerspective");
    let fov = match &scene.projection_params.get("fov").unwrap().value {
        ParamValue::Floats(v) => v[0],
        other => panic!("{other:?}"),
    };
    assert_eq!(fov, 45.0);
    let m = scene.camera.world_to_camera[0].world_to_camera;
    let t = (0.5 * fov.to_radians()).tan() * (1.0 + 1e-4);
    for i in 0..8 {
        let corner = obscura_sdk::Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32);
        let c = m.transform_point(corner);
        assert!(
            c.z > 0.0 && (c.x / c.z).abs() <= t && (c.y / c.z).abs() <= t,
            "{corner:?} → {c:?}"
        );
    }
}

#[test]
fn obj_gets_the_default_sky_and_key_light() {
    let (scene, _, lights) = load_cube(Some(MTL));
    assert!(matches!(
        lights.as_slice(),
        [
            Light::Dome {
                intensity: 1.0,
                map: None,
                ..
            },
            Light::Distant { .. }
        ]
    ));
    assert!(scene.auto_light && scene.auto_camera.is_some());
}

#[test]
fn a_closed_room_without_lights_gets_a_lamp_inside() {
    // The cube of CUBE stretched to a 4 × 2.5 × 3 room, each face wound the other way and its
    // normals turned: it faces in.
    let room: String = CUBE
        .lines()
        .map(|l| match l.split_whitespace().collect::<Vec<_>>().as_slice() {
            ["v", x, y, z] => format!(
                "v {} {} {}",
                4.0 * x.parse::<f32>().unwrap(),
                2.5 * y.parse::<f32>().unwrap(),
                3.0 * z.parse::<f32>().unwrap()
            ),
            ["f", a, b, c, d] => format!("f {d} {c} {b} {a}"),
            ["vn", x, y, z] => {
                let n = |c: &str| -c.parse::<f32>().unwrap();
                format!("vn {} {} {}", n(x), n(y), n(z))
            }
            _ => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n");
    let dir = tempfile::tempdir().unwrap();
    write(&dir, "cube.mtl", MTL);
    let (scene, interior, lights) = staged(&write(&dir, "room.obj", &room), camera());
    let inside = interior.expect("a room facing in is an interior");
    assert_eq!(inside.open_above, 0.0);
    let [
        Light::Dome { .. },
        Light::Distant { .. },
        Light::Sphere {
            transform, intensity, ..
        },
    ] = lights.as_slice()
    else {
        panic!("{:?}", lights);
    };
    // Under the ceiling (80 % of 2.5) over the centre eye, 4 % of the 3-unit side in radius.
    let at = transform.transform_point3(glam::Vec3::ZERO);
    assert!((at - glam::Vec3::new(2.0, 2.0, 1.5)).length() < 1e-5, "{at}");
    let diameter = transform.transform_vector3(glam::Vec3::X).length();
    assert!((diameter - 0.24).abs() < 1e-5 && *intensity > 100.0, "{diameter}");
    // The cube wound outward (CUBE itself) is an object: no interior, no lamp
    // (obj_gets_the_default_sky_and_key_light).
    assert!(load_cube(Some(MTL)).1.is_none());
    // The BVH and the former intersector agree on both.
    let (min, max) = scene.auto_camera.unwrap();
    assert_verdicts_agree(&scene.objects, min, max);
    let (cube, ..) = load_cube(Some(MTL));
    let (min, max) = cube.auto_camera.unwrap();
    assert_verdicts_agree(&cube.objects, min, max);
}

const OBJ_WORDS: &[&str] = &[
    "v 0 0 0",
    "v 1 2 3 4",
    "v 1 2 3 0",
    "v 1 2",
    "v 1 2 3 0.5 0.5",
    "vt 0 0",
    "vn 0 0 1",
    "f 1 2 3",
    "f -1 -2 -3",
    "f 1/1/1 2/2/2 3/3/3",
    "f 1//1 2//1 3//1 4//1",
    "f 2 3",
    "f 1",
    "l 1 2",
    "p 1",
    "o",
    "o thing",
    "g grp",
    "usemtl a",
    "usemtl",
    "mtllib m.mtl",
    "f 99999999999999999999 1 2",
    "f 1/-5 2 3",
    "f a b c",
    "#",
    "",
    "s 1",
    "f 1/2/3/4 1 1",
    "f 1/1 2/1 3/1 4/1 5/1",
    "  o  ",
    "f",
];
const MTL_WORDS: &[&str] = &[
    "newmtl a",
    "newmtl",
    "Kd 1",
    "Kd 1 2",
    "Kd 1 2 3",
    "Ks 1 1 1",
    "Ns 10",
    "Ns",
    "Ke 1 1 1",
    "map_Kd",
    "map_Kd t.png",
    "illum",
    "d 0.5",
    "Kd",
    "Tf 1 1 1",
    "Ka nan 1 1",
    "Kd spectral x.rfl",
];

proptest! {
    #[test]
    fn obj_random_statements_never_panic(
        obj in proptest::collection::vec(proptest::sample::select(OBJ_WORDS), 0..24),
        mtl in proptest::collection::vec(proptest::sample::select(MTL_WORDS), 0..8),
    ) {
        let dir = tempfile::tempdir().unwrap();
        write(&dir, "m.mtl", &mtl.join("\n"));
        let path = write(&dir, "fuzz.obj", &obj.join("\n"));
        // Any outcome but a panic; a scene always gets a camera and a light.
        if let Ok(scene) = load(&path, camera()) {
            let interior = probe_scene(&scene);
            proptest::prop_assert_eq!(scene.camera.world_to_camera.len(), 1);
            proptest::prop_assert!(!lights(&scene, interior.as_ref()).is_empty());
        }
    }
}

// ---- glTF ----

fn camera_desc(w: u32, h: u32) -> CameraDesc {
    let mut c = CameraDesc::new(Format::new(w, h));
    c.shutter = (0.25, 0.75);
    c
}

fn load_fixture(fixture: &Fixture, w: u32, h: u32) -> (Scene, Option<Interior>, Vec<Light>) {
    let dir = tempfile::tempdir().unwrap();
    staged(&fixture.write(&dir, "scene.gltf"), camera_desc(w, h))
}

fn fov_param(scene: &Scene) -> f32 {
    match &scene.projection_params.get("fov").expect("a fov parameter").value {
        ParamValue::Floats(v) => v[0],
        other => panic!("fov is {other:?}"),
    }
}

/// The world point `p` in camera space at shutter open, through the SDK's row-vector matrix as the
/// renderer applies it.
fn to_camera(scene: &Scene, p: Vec3) -> Vec3 {
    let m = scene.camera.world_to_camera[0].world_to_camera;
    let q = m.transform_point(obscura_sdk::Vec3::new(p.x, p.y, p.z));
    Vec3::new(q.x, q.y, q.z)
}

#[test]
fn gltf_without_lights_gets_a_sky_that_is_not_white_and_a_key_light() {
    let (scene, _, lights) = load_fixture(&Fixture::new([0, 1, 2]), 640, 480);
    let [
        Light::Dome { color, map: None, .. },
        Light::Distant { transform, .. },
    ] = lights.as_slice()
    else {
        panic!("{:?}", lights)
    };
    assert!(
        color.r < 0.9 && color.b > color.r,
        "a backdrop unlike a white asset: {color:?}"
    );
    // The key light comes from above: it travels downward.
    assert!(transform.transform_vector3(Vec3::Z).y < -0.5);
    assert!(scene.auto_light);
    assert!(!scene.warnings.iter().any(|w| w.contains("no light")));
}

#[test]
fn gltf_without_camera_frames_the_bounds() {
    let mut f = Fixture::new([0, 1, 2]);
    f.nodes = r#"{"mesh":0,"translation":[10,0,0]}"#.into();
    f.scene_nodes = "[0]".into();
    let (scene, interior, _) = load_fixture(&f, 640, 480);
    assert_eq!(scene.projection, "PxrPerspective");
    assert_eq!(fov_param(&scene), 45.0);
    let t = (22.5f32).to_radians().tan();
    for p in POSITIONS {
        let c = to_camera(&scene, Vec3::from(p) + Vec3::new(10.0, 0.0, 0.0));
        assert!(
            c.z > 0.0 && (c.x / c.z).abs() <= t && (c.y / c.z).abs() <= t,
            "{c}"
        );
    }
    // A lone triangle is no interior, by the BVH as by the former intersector.
    assert_eq!(interior, None);
    let (min, max) = scene.auto_camera.unwrap();
    assert_verdicts_agree(&scene.objects, min, max);
}

// ---- RIB ----

#[test]
fn a_rib_scene_without_lights_gets_the_default_light_when_loaded() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dark.rib");
    std::fs::write(
        &path,
        "WorldBegin\nSurface \"matte\"\nSphere 1 -1 1 360\nWorldEnd\n",
    )
    .unwrap();
    let (scene, _, lights) = staged(
        &path,
        obscura_host::CameraDesc::new(obscura_sdk::Format::new(8, 8)),
    );
    assert!(
        matches!(
            lights[..],
            [
                Light::Dome { .. },
                Light::Distant {
                    enable_shadows: false,
                    ..
                }
            ]
        ),
        "the key light of a classic scene casts no shadows, as classic lights: {:?}",
        lights
    );
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("no light") && w.contains("any LightSource in the file replaces them")),
        "{:?}",
        scene.warnings
    );
    // A scene with a light of its own keeps it alone.
    std::fs::write(
        &path,
        "WorldBegin\nLightSource \"pointlight\" 1\nSphere 1 -1 1 360\nWorldEnd\n",
    )
    .unwrap();
    let (_, _, lights) = staged(
        &path,
        obscura_host::CameraDesc::new(obscura_sdk::Format::new(8, 8)),
    );
    assert!(matches!(lights[..], [Light::Point(_)]));
}
