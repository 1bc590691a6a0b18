//! The dataset driver end to end: the layout contract, resuming, a farm's split frames then
//! finalize, rig poses against independently composed matrices, and the errors bad input gets.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use obscura_dataset::export::ExportFormat;
use obscura_dataset::run::{
    ANNOTATION_NAMES, Annotation, DatasetOptions, Finalize, ParamReader, RenderSettings, Session, Summary,
    export_names, parse_names, run,
};
use obscura_plugins::builtin_registry;
use obscura_plugins::loader::PluginSearch;
use obscura_render::pipeline::{Message, Reporter};
use obscura_sdk::{ParamDecl, ParamList};
use serde_json::Value;

struct Quiet(AtomicBool);

impl Reporter for Quiet {
    fn message(&self, _: Message, _: &str) {}
    fn cancel(&self) -> &AtomicBool {
        &self.0
    }
}

struct NoParams;

impl ParamReader for NoParams {
    fn read(&self, _: &str, _: &[ParamDecl]) -> Result<ParamList, String> {
        Ok(ParamList::new())
    }
    fn describe(&self) -> Vec<String> {
        Vec::new()
    }
}

/// Two frames of a scene whose camera moves: a sphere and a box on a ground plane.
const TWO_FRAMES: &str = r#"
Format 48 32 1
Projection "PxrPerspective" "float fov" [60]
FrameBegin 1
  Translate 0 -0.5 4
  WorldBegin
    AttributeBegin Attribute "identifier" "string name" ["ball"] Translate -0.7 0.5 0 Sphere 0.6 -0.6 0.6 360 AttributeEnd
    AttributeBegin Attribute "identifier" "string name" ["block"] Translate 0.8 0.4 0.5
      Polygon "P" [-0.3 -0.3 -0.3  0.3 -0.3 -0.3  0.3 0.3 -0.3  -0.3 0.3 -0.3]
    AttributeEnd
  WorldEnd
FrameEnd
FrameBegin 2
  Translate 0.2 -0.5 4.2
  WorldBegin
    AttributeBegin Attribute "identifier" "string name" ["ball"] Translate -0.7 0.5 0 Sphere 0.6 -0.6 0.6 360 AttributeEnd
    AttributeBegin Attribute "identifier" "string name" ["block"] Translate 0.8 0.4 0.5
      Polygon "P" [-0.3 -0.3 -0.3  0.3 -0.3 -0.3  0.3 0.3 -0.3  -0.3 0.3 -0.3]
    AttributeEnd
  WorldEnd
FrameEnd
"#;

fn scene(dir: &Path) -> PathBuf {
    let path = dir.join("two.rib");
    std::fs::write(&path, TWO_FRAMES).unwrap();
    path
}

fn options(scene: &Path, output: &Path) -> DatasetOptions {
    DatasetOptions {
        scene: Some(scene.to_path_buf()),
        output: output.to_path_buf(),
        frames: None,
        rig: None,
        exports: Vec::new(),
        annotations: vec![Annotation::Boxes, Annotation::Tracks],
        tracks: 16,
        render: RenderSettings {
            spp: Some(1),
            ..RenderSettings::default()
        },
        finalize: Finalize::Auto,
    }
}

fn go(o: &DatasetOptions) -> Result<Summary, String> {
    let mut registry = builtin_registry();
    let reporter = Quiet(AtomicBool::new(false));
    let search = PluginSearch::from_env(&[]);
    let mut session = Session {
        registry: &mut registry,
        search: &search,
        reporter: &reporter,
        params: &NoParams,
    };
    run(o, &mut session).map_err(|e| e.to_string())
}

/// Every file under `dir`, relative, with its bytes.
fn tree(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().to_string_lossy().replace('\\', "/");
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

fn manifest(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("dataset.json")).unwrap()).unwrap()
}

#[test]
fn the_layout_holds_every_path_and_the_manifest_lists_exactly_them() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("ds");
    let mut o = options(&scene(tmp.path()), &out);
    o.exports = ExportFormat::ALL.to_vec();
    let s = go(&o).unwrap();
    assert!(s.finalized);
    assert_eq!(
        s.rendered,
        vec![("camera".to_string(), 1), ("camera".to_string(), 2)]
    );
    let m = manifest(&out);
    assert_eq!(m["layout"], "obscura-dataset/1");
    assert_eq!(m["complete"], true);
    assert_eq!(m["frames"], serde_json::json!([1, 2]));
    let listed: Vec<String> = m["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap().to_string())
        .collect();
    let mut on_disk: Vec<String> = tree(&out).into_keys().filter(|k| k != "dataset.json").collect();
    on_disk.sort();
    let mut sorted = listed.clone();
    sorted.sort();
    assert_eq!(sorted, on_disk);
    for f in [
        "images/camera/0001.exr",
        "images/camera/0002.png",
        "images/camera/0002.camera.json",
        "annotations/camera/0001.json",
        "annotations/camera/0002.json",
        "tracks/camera.npz",
        "colmap/cameras.txt",
        "colmap/images.txt",
        "colmap/rigs.txt",
        "colmap/frames.txt",
        "transforms.json",
        "gsplat/cameras.json",
    ] {
        assert!(listed.iter().any(|l| l == f), "{f} not in {listed:?}");
    }
    let coco: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("annotations/camera/0001.json")).unwrap())
            .unwrap();
    assert!(coco.to_string().contains("ball"), "{coco}");
}

#[test]
fn a_second_run_renders_nothing_and_a_deleted_frame_is_rendered_again() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("ds");
    let o = options(&scene(tmp.path()), &out);
    go(&o).unwrap();
    let before = tree(&out);
    let again = go(&o).unwrap();
    assert!(again.rendered.is_empty(), "{:?}", again.rendered);
    assert_eq!(again.skipped.len(), 2);
    assert_eq!(tree(&out), before, "a rerun changes no byte");
    std::fs::remove_file(out.join("images/camera/0002.exr")).unwrap();
    let third = go(&o).unwrap();
    assert_eq!(third.rendered, vec![("camera".to_string(), 2)]);
    assert_eq!(
        tree(&out),
        before,
        "the frame rendered again is the same, byte for byte"
    );
    // Another dataset's options in the same directory are refused.
    let mut other = o.clone();
    other.render.seed = 7;
    let e = go(&other).unwrap_err();
    assert!(e.contains("seed = 0") && e.contains("seed = 7"), "{e}");
}

#[test]
fn split_frames_then_finalize_equals_one_run() {
    let tmp = tempfile::tempdir().unwrap();
    let rib = scene(tmp.path());
    let one = tmp.path().join("one");
    go(&options(&rib, &one)).unwrap();
    let split = tmp.path().join("split");
    let mut task = options(&rib, &split);
    for f in ["2", "1"] {
        task.frames = Some(f.parse().unwrap());
        let s = go(&task).unwrap();
        assert!(!s.finalized, "a task of a farm does not finalize");
    }
    assert!(!split.join("tracks/camera.npz").exists());
    // Finalizing before every frame is there is refused, naming what is missing.
    let early = tmp.path().join("early");
    let mut first = options(&rib, &early);
    first.frames = Some("1".parse().unwrap());
    go(&first).unwrap();
    let mut fin = options(&rib, &early);
    fin.finalize = Finalize::Only;
    let e = go(&fin).unwrap_err();
    assert!(e.contains("camera 2") && e.contains("not rendered yet"), "{e}");
    let mut fin = options(&rib, &split);
    fin.finalize = Finalize::Only;
    let s = go(&fin).unwrap();
    assert!(s.finalized && s.rendered.is_empty());
    assert_eq!(tree(&split), tree(&one));
}

/// `a · b` for 4×4 row-major matrices, written out.
fn mul(a: &[[f64; 4]; 4], b: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    let mut m = [[0.0; 4]; 4];
    for r in 0..4 {
        for c in 0..4 {
            m[r][c] = (0..4).map(|k| a[r][k] * b[k][c]).sum();
        }
    }
    m
}

fn world_to_camera(out: &Path, camera: &str) -> [[f64; 4]; 4] {
    let j: Value = serde_json::from_str(
        &std::fs::read_to_string(out.join(format!("images/{camera}/0001.camera.json"))).unwrap(),
    )
    .unwrap();
    let rows = j["world_to_camera"]["open"].as_array().unwrap();
    std::array::from_fn(|r| std::array::from_fn(|c| rows[r][c].as_f64().unwrap()))
}

fn assert_close(a: &[[f64; 4]; 4], b: &[[f64; 4]; 4], what: &str) {
    for r in 0..4 {
        for c in 0..4 {
            assert!(
                (a[r][c] - b[r][c]).abs() < 1e-5,
                "{what}: [{r}][{c}] {} vs {}\n{a:?}\n{b:?}",
                a[r][c],
                b[r][c]
            );
        }
    }
}

/// The world-to-camera of frame 1 rendered without a rig: the rig's base.
fn base_camera(tmp: &Path) -> [[f64; 4]; 4] {
    let out = tmp.join("base");
    let mut o = options(&scene(tmp), &out);
    o.annotations.clear();
    o.frames = Some("1".parse().unwrap());
    go(&o).unwrap();
    world_to_camera(&out, "camera")
}

fn render_rig(tmp: &Path, rig: &Path, name: &str) -> PathBuf {
    let out = tmp.join(name);
    let mut o = options(&scene(tmp), &out);
    o.rig = Some(rig.to_path_buf());
    o.annotations.clear();
    o.frames = Some("1".parse().unwrap());
    go(&o).unwrap();
    out
}

#[test]
fn a_stereo_rig_poses_each_camera_by_its_translation_from_the_base() {
    let tmp = tempfile::tempdir().unwrap();
    let base = base_camera(tmp.path());
    let rig = tmp.path().join("stereo.json");
    std::fs::write(
        &rig,
        r#"{"schema": "obscura-rig/1", "cameras": [
            {"name": "left", "translation": [-0.1, 0, 0]},
            {"name": "right", "translation": [0.1, 0.02, 0], "rotation": {"axis": [0, 1, 0], "degrees": 90}}]}"#,
    )
    .unwrap();
    let out = render_rig(tmp.path(), &rig, "stereo");
    // left: p_left = p_base − t, so world_to_left = T(+0.1, 0, 0) · world_to_base.
    let t = [
        [1.0, 0.0, 0.0, 0.1],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    assert_close(&world_to_camera(&out, "left"), &mul(&t, &base), "left");
    // right: camera_to_base = T(t)·R with R turning +Z to +X about +Y (90°): its inverse is Rᵀ·T(−t).
    let rt = [
        [0.0, 0.0, -1.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let back = [
        [1.0, 0.0, 0.0, -0.1],
        [0.0, 1.0, 0.0, -0.02],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    assert_close(
        &world_to_camera(&out, "right"),
        &mul(&mul(&rt, &back), &base),
        "right",
    );
}

#[test]
fn a_kalibr_camchain_poses_each_camera_by_its_chain_in_opencv_axes() {
    let tmp = tempfile::tempdir().unwrap();
    let base = base_camera(tmp.path());
    // cam1 = cam0 turned 0.1 rad about OpenCV's +Y and moved; cam2 moved down (OpenCV +Y) from cam1.
    let (c, s) = (0.1f64.cos(), 0.1f64.sin());
    let t10 = [
        [c, 0.0, s, -0.11],
        [0.0, 1.0, 0.0, 0.003],
        [-s, 0.0, c, 0.01],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let t21 = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, -0.05],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let m = |t: &[[f64; 4]; 4]| {
        format!(
            "  T_cn_cnm1:\n{}",
            t.iter()
                .map(|r| format!("  - [{}, {}, {}, {}]\n", r[0], r[1], r[2], r[3]))
                .collect::<String>()
        )
    };
    let cam = |i: usize| {
        format!(
            "cam{i}:\n  camera_model: pinhole\n  intrinsics: [40.0, 40.0, 24.0, 16.0]\n  distortion_model: radtan\n  distortion_coeffs: [-0.2, 0.05, 0.001, -0.001]\n  resolution: [48, 32]\n"
        )
    };
    let yaml = format!("{}{}{}{}{}", cam(0), cam(1), m(&t10), cam(2), m(&t21));
    let rig = tmp.path().join("camchain.yaml");
    std::fs::write(&rig, yaml).unwrap();
    let out = render_rig(tmp.path(), &rig, "kalibr");
    let f = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, -1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    // A point in cam0's RenderMan space → OpenCV (F) → camN's OpenCV (chain) → RenderMan (F).
    let w1 = mul(&mul(&mul(&f, &t10), &f), &base);
    let w2 = mul(&mul(&mul(&mul(&f, &t21), &t10), &f), &base);
    assert_close(&world_to_camera(&out, "cam0"), &base, "cam0 is the base");
    assert_close(&world_to_camera(&out, "cam1"), &w1, "cam1");
    assert_close(&world_to_camera(&out, "cam2"), &w2, "cam2");
    let j: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("images/cam1/0001.camera.json")).unwrap())
            .unwrap();
    assert_eq!(j["projection"], "CalibratedCamera");
}

#[test]
fn a_colmap_rig_config_poses_cameras_from_the_reference_sensor() {
    let tmp = tempfile::tempdir().unwrap();
    let base = base_camera(tmp.path());
    // cam_from_rig of camera2: 90° about OpenCV's +Z, then moved; (w, x, y, z) = (cos 45°, 0, 0, sin 45°).
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let rig = tmp.path().join("rig_config.json");
    std::fs::write(
        &rig,
        format!(
            r#"[{{"cameras": [
              {{"image_prefix": "rig1/camera1/", "ref_sensor": true}},
              {{"image_prefix": "rig1/camera2/", "cam_from_rig_rotation": [{h}, 0, 0, {h}], "cam_from_rig_translation": [0.1, 0.2, 0.3]}}]}}]"#
        ),
    )
    .unwrap();
    let out = render_rig(tmp.path(), &rig, "colmap");
    let cam_from_rig = [
        [0.0, -1.0, 0.0, 0.1],
        [1.0, 0.0, 0.0, 0.2],
        [0.0, 0.0, 1.0, 0.3],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let f = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, -1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    assert_close(
        &world_to_camera(&out, "camera1"),
        &base,
        "camera1 is the reference",
    );
    assert_close(
        &world_to_camera(&out, "camera2"),
        &mul(&mul(&mul(&f, &cam_from_rig), &f), &base),
        "camera2",
    );
}

#[test]
fn bad_input_gets_a_located_error() {
    let e = parse_names("--exports", "colmap,nerfstduio", &export_names()).unwrap_err();
    assert!(
        e.contains("'nerfstduio'")
            && e.contains("did you mean 'nerfstudio'")
            && e.contains("colmap, nerfstudio, gsplat"),
        "{e}"
    );
    assert_eq!(
        parse_names("--exports", "gsplat,colmap,gsplat", &export_names()).unwrap(),
        [ExportFormat::Colmap, ExportFormat::Gsplat]
    );
    let e = parse_names("--annotations", "boxes,flow", &ANNOTATION_NAMES).unwrap_err();
    assert!(
        e.contains("'flow'") && e.contains("boxes, tracks, correspondences"),
        "{e}"
    );

    let tmp = tempfile::tempdir().unwrap();
    let rib = scene(tmp.path());
    let bad = |name: &str, text: &str| -> String {
        let rig = tmp.path().join(name);
        std::fs::write(&rig, text).unwrap();
        let mut o = options(&rib, &tmp.path().join("bad"));
        o.rig = Some(rig);
        go(&o).unwrap_err()
    };
    let e = bad(
        "syntax.json",
        "{\n  \"schema\": \"obscura-rig/1\",\n  \"cameras\": [\n    {\"name\": \"a\",}\n  ]\n}",
    );
    assert!(e.contains("syntax.json:4:") && e.contains("not JSON"), "{e}");
    let e = bad(
        "key.json",
        "{\n  \"schema\": \"obscura-rig/1\",\n  \"cameras\": [\n    {\"name\": \"a\"},\n    {\"name\": \"b\", \"translation\": [1, 2]}\n  ]\n}",
    );
    assert!(
        e.contains("key.json:5:") && e.contains("cameras[1].translation: expected a list of 3 numbers"),
        "{e}"
    );
    let e = bad(
        "rot.json",
        "{\"schema\": \"obscura-rig/1\", \"cameras\": [{\"name\": \"a\", \"rotation\": [[1,0,0],[0,1,0],[0,0,2]]}]}",
    );
    assert!(
        e.contains("cameras[0].rotation: the matrix is not a rotation"),
        "{e}"
    );
    let e = bad(
        "dup.json",
        "{\"schema\": \"obscura-rig/1\", \"cameras\": [{\"name\": \"a\"}, {\"name\": \"a\"}]}",
    );
    assert!(e.contains("two cameras are named 'a'"), "{e}");
    let e = bad(
        "param.json",
        "{\"schema\": \"obscura-rig/1\", \"cameras\": [{\"name\": \"a\", \"projection\": \"Fisheye\", \"params\": {\"fvo\": 200}}]}",
    );
    assert!(
        e.contains("Fisheye has no parameter \"fvo\"") && e.contains("did you mean \"fov\""),
        "{e}"
    );
    let e = bad(
        "chain.yaml",
        "cam0:\n  camera_model: pinhole\n  intrinsics: [40, 40, 24, 16]\n  distortion_model: none\n  distortion_coeffs: []\n  resolution: [48, 32]\ncam1:\n  camera_model: pinhole\n  intrinsics: [40, 40, 24, 16]\n  distortion_model: none\n  distortion_coeffs: []\n  resolution: [48, 32]\n",
    );
    assert!(
        e.contains("chain.yaml:8:") && e.contains("cam1.T_cn_cnm1: missing"),
        "{e}"
    );
    let e = bad(
        "rig_config.json",
        "[{\"cameras\": [{\"image_prefix\": \"a/\"}, {\"image_prefix\": \"b/\", \"ref_sensor\": true}]}]",
    );
    assert!(
        e.contains("[0].cameras[0]: cam_from_rig_rotation and cam_from_rig_translation are needed"),
        "{e}"
    );
}

/// A projection without `unproject`: tracks through it are refused before anything renders.
struct NoInverse;

struct Blind;

impl obscura_sdk::Projection for Blind {
    fn property(&self, _: obscura_sdk::ProjectionProperty) -> Option<obscura_sdk::PropertyValue> {
        None
    }
    fn project(&self, _: &mut obscura_sdk::ProjectionContext<'_>) {}
}

impl obscura_sdk::ProjectionFactory for NoInverse {
    fn name(&self) -> &str {
        "NoInverse"
    }
    fn summary(&self) -> &str {
        "a test projection without unproject"
    }
    fn param_table(&self) -> &[ParamDecl] {
        &[]
    }
    fn create_projection(
        &self,
        _: &mut obscura_sdk::ProjectionEnvironment,
        _: &ParamList,
    ) -> Result<Box<dyn obscura_sdk::Projection>, obscura_sdk::PluginError> {
        Ok(Box::new(Blind))
    }
}

#[test]
fn tracks_through_a_projection_without_unproject_are_refused_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("ds");
    let mut o = options(&scene(tmp.path()), &out);
    o.render.projection = Some("NoInverse".into());
    let mut registry = builtin_registry();
    registry.register(Box::new(NoInverse), "").unwrap();
    let reporter = Quiet(AtomicBool::new(false));
    let search = PluginSearch::from_env(&[]);
    let mut session = Session {
        registry: &mut registry,
        search: &search,
        reporter: &reporter,
        params: &NoParams,
    };
    let e = run(&o, &mut session).unwrap_err().to_string();
    assert!(
        e.contains("camera camera: its projection NoInverse has no unproject")
            && e.contains("tracks and correspondences"),
        "{e}"
    );
    assert!(!out.join("images").exists(), "nothing rendered");
}
