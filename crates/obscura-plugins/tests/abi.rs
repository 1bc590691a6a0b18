//! The plugin ABI's promises, one test each (as the `embree3` crate tests its FFI): versions and
//! sizes checked before any call, null pointers refused, panics and failing batches culled and
//! counted, NaN caught by validation, any batch size, and a header that cannot drift from the Rust
//! types without a test failing.
//!
//! C test plugins are compiled here with the system C compiler (`$CC`, else `cc`); the Rust test
//! plugin is built once with cargo into `target/plugin-tests`.

use std::path::{Path, PathBuf};
use std::process::Command;

use obscura_host::{Batch, CameraDesc, CameraStage, Registry, Violation};
use obscura_plugins::builtin_registry;
use obscura_plugins::loader::{
    PluginLoadError, PluginSearch, ensure, library_file_name, load_all, load_file,
};
use obscura_sdk::abi::{self, ProjectionDescriptor, RawContext, RawEnvironment, RawMotionSample};
use obscura_sdk::abi::{RawParam, RawParamDecl, RawParamList, RawPropertyValue};
use obscura_sdk::{
    DeepMetric, DicingHint, Format, ParamList, ParamType, PluginError, Point2, ProjectionProperty,
    PropertyValue, RayGeometry, SyncMessage, Vec3,
};

#[path = "support/plugin_build.rs"]
mod plugin_build;

use plugin_build::{c_compiler, compile_c, compile_c_fisheye, copy_rust_plugin, workspace};

/// The broken plugin with one defect, in its own directory as `Broken.so`.
fn broken(defect: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/plugins/broken.c");
    let p = compile_c(&src, &[defect], dir.path(), "Broken", false);
    (dir, p)
}

/// The C fisheye example, as `CFisheye.so` in its own directory.
fn c_fisheye() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let p = compile_c_fisheye(dir.path());
    (dir, p)
}

/// A Rust cdylib copied to `<dir>/<name>.so`.
fn rust_plugin(crate_name: &str, name: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let p = copy_rust_plugin(crate_name, dir.path(), name);
    (dir, p)
}

fn load_err(path: &Path) -> PluginLoadError {
    let mut reg = Registry::new();
    load_file(&mut reg, path).expect_err("the plugin must be refused")
}

fn square_camera(n: u32) -> CameraDesc {
    let mut c = CameraDesc::new(Format::new(n, n));
    c.shutter = (0.0, 1.0);
    c
}

/// Pixel-centre samples of the whole image, row by row.
fn grid(cam: &CameraDesc) -> Vec<Point2> {
    let p = cam.pixels();
    let mut v = Vec::new();
    for y in 0..p.height() {
        for x in 0..p.width() {
            v.push(cam.raster_to_screen(f64::from(x) + 0.5, f64::from(y) + 0.5));
        }
    }
    v
}

fn batch_of(screen: &[Point2]) -> Batch {
    let mut b = Batch::with_capacity(screen.len());
    for (i, s) in screen.iter().enumerate() {
        b.push(*s, Point2::new(0.5, 0.5), (i % 97) as f32 / 97.0);
    }
    b
}

// ------------------------------------------------------------------------------------------------
// Versions and sizes.

#[test]
fn a_plugin_built_for_another_abi_version_is_refused() {
    let (_d, p) = broken("BAD_VERSION");
    let e = load_err(&p);
    assert!(
        matches!(
            e,
            PluginLoadError::Version {
                found: 99,
                expected: 1,
                ..
            }
        ),
        "{e:?}"
    );
    let msg = e.to_string();
    assert!(
        msg.starts_with(&p.canonicalize().unwrap().display().to_string()),
        "{msg}"
    );
    assert!(
        msg.contains("ABI version 99, but this host speaks version 1"),
        "{msg}"
    );
}

#[test]
fn a_descriptor_smaller_than_its_layout_is_refused() {
    let (_d, p) = broken("BAD_SIZE");
    let e = load_err(&p);
    let want = std::mem::size_of::<ProjectionDescriptor>();
    assert!(
        matches!(e, PluginLoadError::Size { found, minimum, .. }
            if found as usize == want - 8 && minimum == obscura_plugins::loader::DESCRIPTOR_V1_SIZE),
        "{e:?}"
    );
    assert!(e.to_string().contains("mismatched header"), "{e}");
}

/// The smallest descriptor the host accepts is generation 1's first layout, pinned: appending a field
/// to the descriptor must not raise it (plugins built before the append keep loading).
#[test]
fn the_first_layouts_size_is_pinned() {
    #[cfg(target_pointer_width = "64")]
    assert_eq!(obscura_plugins::loader::DESCRIPTOR_V1_SIZE, 104);
    assert!(std::mem::size_of::<ProjectionDescriptor>() >= obscura_plugins::loader::DESCRIPTOR_V1_SIZE);
}

#[test]
fn a_descriptor_grown_by_a_newer_header_still_loads() {
    let (_d, p) = broken("LARGER_SIZE");
    let mut reg = Registry::new();
    assert_eq!(load_file(&mut reg, &p).unwrap(), "Broken");
}

// ------------------------------------------------------------------------------------------------
// Null pointers and malformed descriptors.

#[test]
fn null_pointers_in_the_descriptor_are_refused_before_any_call() {
    for (defect, expect) in [
        ("NULL_DESCRIPTOR", "returned NULL"),
        ("NULL_NAME", "the name is NULL"),
        ("NULL_PROJECT", "the required function `project` is NULL"),
        ("NULL_PARAMS", "the parameter table is NULL"),
        ("NO_ENTRY", "does not export `obscura_projection_entry`"),
        (
            "BAD_DEFAULT",
            "parameter table row 0: parameter \"scale\": the default 1 is outside its own range",
        ),
        // Regression: the counts were used to read memory before they were checked.
        (
            "SIZEOF_DEFAULT",
            "parameter \"scale\": default_count 4 but a float default has 1 scalar(s)",
        ),
        ("HUGE_CHOICES", "parameter \"scale\": num_choices"),
    ] {
        let (_d, p) = broken(defect);
        let msg = load_err(&p).to_string();
        assert!(msg.contains(expect), "{defect}: {msg}");
        assert!(msg.contains("Broken.so"), "{defect}: the file is named: {msg}");
    }
}

/// Loading runs nothing of a plugin but its entry point (docs/plugin-abi.md, Lifecycle): `init` runs
/// before the first projection is created. So an `init` that reports OK without a factory no longer
/// fails the load (as it did while the loader called `init`) but the first `create`, with the plugin
/// and its file named.
#[test]
fn an_init_that_sets_no_factory_is_refused() {
    let (_d, p) = broken("NULL_FACTORY");
    let mut reg = Registry::new();
    load_file(&mut reg, &p).expect("loading runs no init");
    let mut env = square_camera(8).environment();
    let e = reg
        .create("Broken", &mut env, &ParamList::new())
        .err()
        .expect("the create that needed init fails");
    assert!(matches!(e, PluginError::Init { .. }), "{e:?}");
    let msg = e.to_string();
    assert!(msg.contains("init returned OK but set no factory"), "{msg}");
    assert!(msg.contains("Broken.so"), "the file is named: {msg}");
}

/// `init` runs lazily (docs/plugin-abi.md, Lifecycle), so a plugin whose `init` fails now loads and is
/// listed without error, as `obscura plugins` loads and lists it with `load_all`; the failure
/// surfaces at the first `create`, naming the plugin, the file and the plugin's reason. (While the
/// loader called `init`, the load failed with `plugin Broken failed to initialise`.)
#[test]
fn a_failing_init_names_the_file_and_the_reason() {
    let (dir, p) = broken("FAIL_INIT");
    let mut reg = builtin_registry();
    let (loaded, failed) = load_all(&mut reg, &PluginSearch::new(vec![dir.path().into()]));
    assert_eq!((loaded, failed), (vec!["Broken".to_string()], Vec::new()));
    let listing = obscura_plugins::listing::list(&reg, Some("Broken")).unwrap();
    assert!(listing.starts_with("Broken\n"), "{listing}");
    let mut env = square_camera(8).environment();
    let msg = reg
        .create("Broken", &mut env, &ParamList::new())
        .err()
        .expect("the first create runs the failing init")
        .to_string();
    let file = p.canonicalize().unwrap().display().to_string();
    assert!(
        msg.contains(&format!(
            "Broken: initialisation failed: {file}: license server unreachable"
        )),
        "{msg}"
    );
}

/// Regression: `range_flags` bits the header does not define were ignored, so a row that meant
/// something this host does not know loaded as if it meant something else. Both INCLUSIVE bits
/// without LIMITED are documented as no range, and still load.
#[test]
fn a_range_flag_the_header_does_not_define_is_refused_at_load() {
    let (_d, p) = broken("UNKNOWN_RANGE_BIT");
    let msg = load_err(&p).to_string();
    assert!(
        msg.contains(
            "Broken.so: invalid descriptor: plugin Broken: parameter table row 0: parameter \"scale\": \
             range_flags 0xf has unknown bits 0x8"
        ),
        "{msg}"
    );
    let (_d, p) = broken("INCLUSIVE_WITHOUT_LIMITED");
    let mut reg = Registry::new();
    load_file(&mut reg, &p).unwrap();
    assert_eq!(reg.get("Broken").unwrap().param_table()[0].range, None);
}

#[test]
fn a_create_that_returns_no_projection_is_an_error_not_a_crash() {
    let (_d, p) = broken("NULL_PROJECTION");
    let mut reg = Registry::new();
    load_file(&mut reg, &p).unwrap();
    let cam = square_camera(8);
    let e = CameraStage::new(&mut reg, "Broken", &ParamList::new(), &cam).unwrap_err();
    assert!(
        e.to_string()
            .contains("Broken: create_projection returned OK but no projection (NULL)"),
        "{e}"
    );
}

#[test]
fn a_deep_metric_outside_the_enum_is_an_error() {
    let (_d, p) = broken("BAD_DEEP_METRIC");
    let mut reg = Registry::new();
    load_file(&mut reg, &p).unwrap();
    let e = CameraStage::new(&mut reg, "Broken", &ParamList::new(), &square_camera(8)).unwrap_err();
    assert!(e.to_string().contains("deep metric to 7"), "{e}");
}

// ------------------------------------------------------------------------------------------------
// Failures at run time.

#[test]
fn a_rust_plugin_panicking_in_project_loses_its_batches_not_the_render() {
    let (dir, _p) = rust_plugin("obscura_test_panicking_plugin", "Panicking");
    let mut reg = builtin_registry();
    let search = PluginSearch::new(vec![dir.path().to_path_buf()]);
    assert_eq!(ensure(&mut reg, "Panicking", &search).unwrap(), "Panicking");
    let cam = square_camera(32);
    let stage = CameraStage::new(&mut reg, "Panicking", &ParamList::new(), &cam).unwrap();
    // One batch per image row: each row reaches right of 0.5, so every batch panics when run whole;
    // run the left and right halves apart instead.
    let all = grid(&cam);
    let (mut lost, mut kept, mut panicked) = (0u64, 0u64, 0u64);
    for row in all.chunks(32) {
        for half in row.chunks(16) {
            let mut b = batch_of(half);
            let r = stage.run(&mut b);
            let bad = r.count(Violation::Panicked);
            panicked += bad;
            if bad > 0 {
                assert_eq!(bad, 16, "the whole batch is lost");
                assert!(b.rays.iter().all(RayGeometry::is_culled));
                let w = r.warning("Panicking").unwrap();
                assert!(w.contains("panicked: deliberate panic at screen x"), "{w}");
                lost += 16;
            } else {
                assert!(r.is_clean(), "{:?}", r.warning("Panicking"));
                assert!(b.rays.iter().all(|r| !r.is_culled()));
                kept += 16;
            }
        }
    }
    // Pixel centres right of x = 0.5 are in columns 24..32: the right half of every row panics.
    assert_eq!((lost, kept, panicked), (512, 512, 512));
}

#[test]
fn nan_output_is_caught_by_validation() {
    let (_d, p) = broken("NAN_OUTPUT");
    let mut reg = Registry::new();
    load_file(&mut reg, &p).unwrap();
    let cam = square_camera(16);
    let stage = CameraStage::new(&mut reg, "Broken", &ParamList::new(), &cam).unwrap();
    let mut b = batch_of(&grid(&cam));
    let r = stage.run(&mut b);
    assert_eq!(r.count(Violation::NonFiniteDirection), 128, "the right half");
    assert_eq!(r.violations(), 128);
    for (ray, s) in b.rays.iter().zip(&b.screen) {
        assert!(ray.direction.is_finite());
        assert_eq!(ray.is_culled(), s.x > 0.0);
    }
}

/// `OBSCURA_ERROR` from `project` is counted as an error (`Violation::Failed`), not as a panic
/// (docs/plugin-abi.md, Panics and failing calls): the batch is lost all the same.
#[test]
fn a_project_that_returns_an_error_loses_its_batch_with_the_message() {
    let (_d, p) = broken("PROJECT_ERROR");
    let mut reg = Registry::new();
    load_file(&mut reg, &p).unwrap();
    let cam = square_camera(8);
    let stage = CameraStage::new(&mut reg, "Broken", &ParamList::new(), &cam).unwrap();
    let mut b = batch_of(&grid(&cam));
    let r = stage.run(&mut b);
    assert_eq!(r.count(Violation::Failed), 64);
    assert_eq!(r.count(Violation::Panicked), 0);
    assert!(b.rays.iter().all(RayGeometry::is_culled));
    let w = r.warning("Broken").unwrap();
    assert!(w.contains("returned an error: lens table missing"), "{w}");
}

// ------------------------------------------------------------------------------------------------
// Batches and results.

/// The equidistant fisheye written out in f64: renderman-projection-api.md §3.3.
fn equidistant(s: Point2, fov: f64) -> Option<Vec3> {
    let (sx, sy) = (f64::from(s.x), f64::from(s.y));
    let r = sx.hypot(sy);
    if r > 1.0 {
        return None;
    }
    let phi = r * fov.to_radians() / 2.0;
    let psi = sy.atan2(sx);
    Some(Vec3::new(
        (phi.sin() * psi.cos()) as f32,
        (phi.sin() * psi.sin()) as f32,
        phi.cos() as f32,
    ))
}

#[test]
fn batch_sizes_1_7_and_4096_give_the_builtin_fisheyes_rays() {
    let (dir, _p) = c_fisheye();
    let mut reg = builtin_registry();
    let search = PluginSearch::new(vec![dir.path().to_path_buf()]);
    assert_eq!(ensure(&mut reg, "CFisheye", &search).unwrap(), "CFisheye");
    let cam = square_camera(64);
    let mut params = ParamList::new();
    params.push_text("float fov", &["200"], None).unwrap();
    let plugin = CameraStage::new(&mut reg, "CFisheye", &params, &cam).unwrap();
    assert_eq!(plugin.properties().dicing_hint, DicingHint::Spherical);
    assert_eq!(plugin.properties().deep_metric, DeepMetric::RayLength);
    assert_eq!(plugin.properties().field_of_view, Some(200.0));
    params
        .push_text("string mapping", &["equidistant"], None)
        .unwrap();
    let builtin = CameraStage::new(&mut reg, "Fisheye", &params, &cam).unwrap();

    let all = grid(&cam);
    assert_eq!(all.len(), 4096);
    for size in [1usize, 7, 4096] {
        let mut compared = 0;
        let chunks: Vec<&[Point2]> = all.chunks(size).collect();
        for chunk in chunks.iter().step_by((chunks.len() / 64).max(1)) {
            let (mut a, mut b) = (batch_of(chunk), batch_of(chunk));
            let (ra, rb) = (plugin.run(&mut a), builtin.run(&mut b));
            assert!(ra.is_clean() && rb.is_clean(), "{:?}", ra.warning("CFisheye"));
            assert_eq!(a.rays.len(), chunk.len());
            for i in 0..chunk.len() {
                let (p, q) = (a.rays[i], b.rays[i]);
                let s = a.screen[i];
                match equidistant(s, 200.0) {
                    None => assert!(p.is_culled() && q.is_culled(), "{s:?}"),
                    Some(d) => {
                        assert!(
                            (p.direction - d).length() < 2e-6,
                            "{s:?}: {:?} vs {d:?}",
                            p.direction
                        );
                        assert!((p.direction - q.direction).length() < 2e-6, "{s:?}");
                        assert!(
                            (p.ray_spread / q.ray_spread - 1.0).abs() < 1e-4,
                            "{s:?}: {} vs {}",
                            p.ray_spread,
                            q.ray_spread
                        );
                        assert_eq!(
                            (p.origin, p.min_dist, p.max_dist),
                            (q.origin, q.min_dist, q.max_dist)
                        );
                    }
                }
                assert_eq!(a.time[i], b.time[i]);
                compared += 1;
            }
        }
        assert!(compared >= size.min(4096), "batch size {size}");
    }
}

#[test]
fn unproject_crosses_the_boundary_and_inverts_project() {
    let (_d, p) = c_fisheye();
    let mut reg = Registry::new();
    load_file(&mut reg, &p).unwrap();
    let cam = square_camera(32);
    let stage = CameraStage::new(&mut reg, "CFisheye", &ParamList::new(), &cam).unwrap();
    let mut b = batch_of(&grid(&cam));
    assert!(stage.run(&mut b).is_clean());
    let mut seen = 0;
    for (ray, s) in b.rays.iter().zip(&b.screen) {
        if ray.is_culled() {
            continue;
        }
        let back = stage.projection().unproject(ray.direction * 3.0, 0.0).unwrap();
        assert!(
            (back.x - s.x).abs() < 1e-5 && (back.y - s.y).abs() < 1e-5,
            "{s:?} -> {back:?}"
        );
        seen += 1;
    }
    assert!(seen > 700, "most of the 1024 pixels are inside the circle");
    // Behind the camera is outside a 180° fisheye, and the origin has no direction at all.
    assert_eq!(stage.projection().unproject(Vec3::new(0.1, 0.0, -1.0), 0.0), None);
    assert_eq!(stage.projection().unproject(Vec3::ZERO, 0.0), None);
}

#[test]
fn parameters_are_checked_by_the_host_against_the_plugins_table() {
    let (_d, p) = c_fisheye();
    let mut reg = Registry::new();
    load_file(&mut reg, &p).unwrap();
    let table = reg.get("CFisheye").unwrap().param_table().to_vec();
    assert_eq!(table.len(), 1);
    assert_eq!((table[0].name.as_ref(), table[0].ty), ("fov", ParamType::Float));
    let mut params = ParamList::new();
    params
        .push_text("float fov", &["400"], Some("scene.rib:7".into()))
        .unwrap();
    let e = CameraStage::new(&mut reg, "CFisheye", &params, &square_camera(8)).unwrap_err();
    let e = e.to_string();
    assert!(
        e.contains(
            "CFisheye: parameter \"fov\" (at scene.rib:7) = 400 is out of range: expected a value in (0, 360]"
        ),
        "{e}"
    );
    let mut params = ParamList::new();
    params.push_text("float fvo", &["90"], None).unwrap();
    let e = CameraStage::new(&mut reg, "CFisheye", &params, &square_camera(8)).unwrap_err();
    assert!(e.to_string().contains("did you mean \"fov\""), "{e}");
}

#[test]
fn a_search_that_finds_a_plugin_of_another_name_says_so() {
    let (dir, p) = c_fisheye();
    std::fs::rename(&p, dir.path().join(library_file_name("Fish"))).unwrap();
    let mut reg = Registry::new();
    let e = ensure(&mut reg, "Fish", &PluginSearch::new(vec![dir.path().into()])).unwrap_err();
    assert!(
        e.to_string()
            .contains("this library is projection \"CFisheye\", not \"Fish\""),
        "{e}"
    );
}

#[test]
fn a_path_loads_directly_and_a_second_load_of_the_name_is_a_duplicate() {
    let (_d, p) = c_fisheye();
    let mut reg = Registry::new();
    let name = ensure(&mut reg, p.to_str().unwrap(), &PluginSearch::default()).unwrap();
    assert_eq!(name, "CFisheye");
    assert_eq!(
        ensure(&mut reg, "CFisheye", &PluginSearch::default()).unwrap(),
        "CFisheye"
    );
    assert!(matches!(
        load_file(&mut reg, &p).unwrap_err(),
        PluginLoadError::Duplicate { .. }
    ));
}

// ------------------------------------------------------------------------------------------------
// The header and the Rust types.

/// Every struct, field offset and constant of `projection.h`, with the values the Rust side has.
type Sizes = Vec<(&'static str, usize)>;
/// (C struct, C field, offset, the field's C type spelled from its Rust type).
type Offsets = Vec<(&'static str, &'static str, usize, String)>;
type Constants = Vec<(&'static str, i64)>;

fn header_facts() -> (Sizes, Offsets, Constants) {
    use std::mem::{offset_of, size_of};
    let sizes = vec![
        ("ObscuraPoint2", size_of::<Point2>()),
        ("ObscuraVec3", size_of::<Vec3>()),
        ("ObscuraRgb", size_of::<obscura_sdk::Rgb>()),
        ("ObscuraMatrix4", size_of::<obscura_sdk::Matrix4>()),
        ("ObscuraRayGeometry", size_of::<RayGeometry>()),
        ("ObscuraErrorSink", size_of::<abi::ErrorSink>()),
        ("ObscuraParamDecl", size_of::<RawParamDecl>()),
        ("ObscuraParam", size_of::<RawParam>()),
        ("ObscuraParamList", size_of::<RawParamList>()),
        ("ObscuraMotionSample", size_of::<RawMotionSample>()),
        ("ObscuraEnvironment", size_of::<RawEnvironment>()),
        ("ObscuraProjectionContext", size_of::<RawContext>()),
        ("ObscuraPropertyValue", size_of::<RawPropertyValue>()),
        ("ObscuraProjectionDescriptor", size_of::<ProjectionDescriptor>()),
        ("ObscuraStatus", size_of::<abi::Status>()),
    ];
    macro_rules! fields {
        ($c:literal, $r:ty: $($cf:ident => $rf:ident),* $(,)?) => {
            vec![$(($c, stringify!($cf), offset_of!($r, $rf), c_type_of(|s: &$r| &s.$rf))),*]
        };
    }
    let mut offsets = Vec::new();
    offsets.extend(fields!("ObscuraPoint2", Point2: x => x, y => y));
    offsets.extend(fields!("ObscuraVec3", Vec3: x => x, y => y, z => z));
    offsets.extend(fields!("ObscuraRgb", obscura_sdk::Rgb: r => r, g => g, b => b));
    offsets.push((
        "ObscuraMatrix4",
        "m",
        0,
        c_type_of(|s: &obscura_sdk::Matrix4| &s.0),
    ));
    offsets.extend(fields!("ObscuraRayGeometry", RayGeometry:
        origin => origin, origin_radius => origin_radius, direction => direction,
        ray_spread => ray_spread, min_dist => min_dist, max_dist => max_dist));
    offsets.extend(fields!("ObscuraErrorSink", abi::ErrorSink: host => host, report => report));
    offsets.extend(fields!("ObscuraParamDecl", RawParamDecl:
        name => name, doc => doc, default_floats => default_floats, default_ints => default_ints,
        default_strings => default_strings, default_count => default_count, choices => choices,
        num_choices => num_choices, range_min => range_min, range_max => range_max, type => ty,
        array_len => array_len, range_flags => range_flags));
    offsets.extend(fields!("ObscuraParam", RawParam:
        name => name, origin => origin, floats => floats, ints => ints, strings => strings,
        count => count, type => ty, array_len => array_len, given => given));
    offsets.extend(fields!("ObscuraParamList", RawParamList:
        struct_size => struct_size, num_params => num_params, params => params));
    offsets.extend(fields!("ObscuraMotionSample", RawMotionSample:
        time => time, world_to_camera => world_to_camera));
    offsets.extend(fields!("ObscuraEnvironment", RawEnvironment:
        struct_size => struct_size, width => width, height => height, pixel_aspect => pixel_aspect,
        screen_left => screen_left, screen_right => screen_right, screen_bottom => screen_bottom,
        screen_top => screen_top, shutter_open => shutter_open, shutter_close => shutter_close,
        clipping_near => clipping_near, clipping_far => clipping_far, deep_metric => deep_metric,
        num_motion_samples => num_motion_samples, world_to_camera => world_to_camera));
    offsets.extend(fields!("ObscuraProjectionContext", RawContext:
        struct_size => struct_size, num_rays => num_rays, screen => screen, lens => lens,
        aperture => aperture, time => time, rays => rays, tint => tint));
    offsets.extend(fields!("ObscuraPropertyValue", RawPropertyValue:
        kind => kind, enum_value => enum_value, float_value => float_value));
    offsets.extend(fields!("ObscuraProjectionDescriptor", ProjectionDescriptor:
        abi_version => abi_version, struct_size => struct_size, name => name, summary => summary,
        params => params, num_params => num_params, init => init, finalize => finalize,
        synchronize => synchronize, create_projection => create_projection,
        destroy_projection => destroy_projection, property => property, project => project,
        unproject => unproject));

    let pt = |t: ParamType| i64::from(abi::param_type_to_raw(t));
    let constants = vec![
        ("OBSCURA_PROJECTION_ABI_VERSION", i64::from(abi::ABI_VERSION)),
        ("OBSCURA_OK", i64::from(abi::OK)),
        ("OBSCURA_UNSUPPORTED", i64::from(abi::UNSUPPORTED)),
        ("OBSCURA_ERROR", i64::from(abi::ERROR)),
        ("OBSCURA_PANIC", i64::from(abi::PANIC)),
        ("OBSCURA_PARAM_FLOAT", pt(ParamType::Float)),
        ("OBSCURA_PARAM_INT", pt(ParamType::Int)),
        ("OBSCURA_PARAM_STRING", pt(ParamType::String)),
        ("OBSCURA_PARAM_COLOR", pt(ParamType::Color)),
        ("OBSCURA_PARAM_POINT", pt(ParamType::Point)),
        ("OBSCURA_PARAM_VECTOR", pt(ParamType::Vector)),
        ("OBSCURA_PARAM_NORMAL", pt(ParamType::Normal)),
        ("OBSCURA_PARAM_MATRIX", pt(ParamType::Matrix)),
        ("OBSCURA_ARRAY_SINGLE", i64::from(abi::ARRAY_SINGLE)),
        ("OBSCURA_ARRAY_VARIABLE", i64::from(abi::ARRAY_VARIABLE)),
        ("OBSCURA_RANGE_LIMITED", i64::from(abi::RANGE_LIMITED)),
        ("OBSCURA_RANGE_MIN_INCLUSIVE", i64::from(abi::RANGE_MIN_INCLUSIVE)),
        ("OBSCURA_RANGE_MAX_INCLUSIVE", i64::from(abi::RANGE_MAX_INCLUSIVE)),
        ("OBSCURA_SYNC_RENDER_BEGIN", SyncMessage::RenderBegin as i64),
        ("OBSCURA_SYNC_RENDER_END", SyncMessage::RenderEnd as i64),
        ("OBSCURA_SYNC_INSTANCE_EDIT", SyncMessage::InstanceEdit as i64),
        (
            "OBSCURA_PROPERTY_DICING_HINT",
            ProjectionProperty::DicingHint as i64,
        ),
        (
            "OBSCURA_PROPERTY_DEEP_METRIC",
            ProjectionProperty::DeepMetric as i64,
        ),
        (
            "OBSCURA_PROPERTY_FIELD_OF_VIEW",
            ProjectionProperty::FieldOfView as i64,
        ),
        ("OBSCURA_PROPERTY_FSTOP", ProjectionProperty::FStop as i64),
        (
            "OBSCURA_PROPERTY_FOCAL_LENGTH",
            ProjectionProperty::FocalLength as i64,
        ),
        (
            "OBSCURA_PROPERTY_FOCAL_DISTANCE",
            ProjectionProperty::FocalDistance as i64,
        ),
        ("OBSCURA_DICING_ORTHOGRAPHIC", DicingHint::Orthographic as i64),
        ("OBSCURA_DICING_PERSPECTIVE", DicingHint::Perspective as i64),
        ("OBSCURA_DICING_SPHERICAL", DicingHint::Spherical as i64),
        ("OBSCURA_DEEP_CAMERA_Z", DeepMetric::CameraZ as i64),
        ("OBSCURA_DEEP_RAY_LENGTH", DeepMetric::RayLength as i64),
        ("OBSCURA_VALUE_DICING_HINT", i64::from(abi::VALUE_DICING_HINT)),
        ("OBSCURA_VALUE_DEEP_METRIC", i64::from(abi::VALUE_DEEP_METRIC)),
        ("OBSCURA_VALUE_FLOAT", i64::from(abi::VALUE_FLOAT)),
        (
            "sizeof(OBSCURA_PROJECTION_ENTRY_SYMBOL)",
            obscura_plugins::loader::ENTRY_SYMBOL_NUL.len() as i64,
        ),
    ];
    (sizes, offsets, constants)
}

/// The C spelling (a C++ type-id) of a Rust type that crosses the ABI.
trait CType {
    fn c() -> String;
}

macro_rules! c_types {
    ($($t:ty => $s:literal),* $(,)?) => { $(impl CType for $t { fn c() -> String { $s.into() } })* };
}

c_types!(
    () => "void", f32 => "float", f64 => "double", i32 => "int32_t", u32 => "uint32_t", usize => "size_t",
    std::ffi::c_char => "char", std::ffi::c_void => "void",
    Point2 => "ObscuraPoint2", Vec3 => "ObscuraVec3", obscura_sdk::Rgb => "ObscuraRgb",
    obscura_sdk::Matrix4 => "ObscuraMatrix4", RayGeometry => "ObscuraRayGeometry",
    abi::ErrorSink => "ObscuraErrorSink", RawParamDecl => "ObscuraParamDecl", RawParam => "ObscuraParam",
    RawParamList => "ObscuraParamList", RawMotionSample => "ObscuraMotionSample",
    RawEnvironment => "ObscuraEnvironment", RawContext => "ObscuraProjectionContext",
    RawPropertyValue => "ObscuraPropertyValue", ProjectionDescriptor => "ObscuraProjectionDescriptor",
);

impl<T: CType> CType for *const T {
    fn c() -> String {
        format!("{} const *", T::c())
    }
}

impl<T: CType> CType for *mut T {
    fn c() -> String {
        format!("{} *", T::c())
    }
}

impl<T: CType, const N: usize> CType for [T; N] {
    fn c() -> String {
        // float[4] inside [_; 4] is float[4][4]: the new extent goes before the inner ones.
        let inner = T::c();
        match inner.find('[') {
            Some(i) => format!("{}[{N}]{}", &inner[..i], &inner[i..]),
            None => format!("{inner}[{N}]"),
        }
    }
}

macro_rules! c_fn_types {
    ($($a:ident),+) => {
        impl<R: CType, $($a: CType),+> CType for unsafe extern "C" fn($($a),+) -> R {
            fn c() -> String {
                format!("{} (*)({})", R::c(), [$($a::c()),+].join(", "))
            }
        }
        impl<R: CType, $($a: CType),+> CType for Option<unsafe extern "C" fn($($a),+) -> R> {
            fn c() -> String {
                <unsafe extern "C" fn($($a),+) -> R as CType>::c()
            }
        }
    };
}

c_fn_types!(A);
c_fn_types!(A, B);
c_fn_types!(A, B, C);
c_fn_types!(A, B, C, D);
c_fn_types!(A, B, C, D, E);

/// The C type of the field `get` reads, inferred from its Rust type.
fn c_type_of<S, T: CType>(_get: fn(&S) -> &T) -> String {
    T::c()
}

/// Every struct body in a C header, with its member names in order (comments stripped; a function
/// pointer member is named by its `(*name)`).
fn header_members(header: &str) -> Vec<(String, Vec<String>)> {
    let mut text = String::new();
    let mut rest = header;
    while let Some(i) = rest.find("/*") {
        text.push_str(&rest[..i]);
        rest = rest[i..].find("*/").map_or("", |j| &rest[i + j + 2..]);
    }
    text.push_str(rest);
    let text: String = text
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n");
    let mut out = Vec::new();
    let mut rest = text.as_str();
    while let Some(i) = rest.find("struct ") {
        let after = &rest[i + 7..];
        let name: String = after
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        let tail = after[name.len()..].trim_start();
        rest = after;
        let Some(body) = tail.strip_prefix('{') else {
            continue;
        };
        let end = body.find('}').expect("a closed struct body");
        let declarator = |d: &str| {
            let d = d.split('[').next().unwrap().trim();
            d.rsplit(|c: char| c.is_whitespace() || c == '*')
                .next()
                .unwrap()
                .to_string()
        };
        let members = body[..end]
            .split(';')
            .map(str::trim)
            .filter(|d| !d.is_empty())
            .flat_map(|d| match d.find("(*") {
                Some(p) => vec![d[p + 2..].split(')').next().unwrap().trim().to_string()],
                // `float x, y;` declares two members.
                None => d.split(',').map(declarator).collect(),
            })
            .collect();
        out.push((name, members));
    }
    out
}

/// A C translation unit that includes the header and asserts every fact at compile time.
fn static_asserts(tamper: bool) -> String {
    let (sizes, offsets, constants) = header_facts();
    let mut c = String::from(
        "#include <stddef.h>\n#include \"obscura/projection.h\"\n\
         #ifdef __cplusplus\n#define OBSCURA_SA static_assert\n#else\n#define OBSCURA_SA _Static_assert\n#endif\n",
    );
    for (i, (ty, size)) in sizes.iter().enumerate() {
        let size = if tamper && i == 4 { size + 4 } else { *size };
        c.push_str(&format!("OBSCURA_SA(sizeof({ty}) == {size}, \"sizeof {ty}\");\n"));
    }
    for (ty, field, off, _) in &offsets {
        c.push_str(&format!(
            "OBSCURA_SA(offsetof({ty}, {field}) == {off}, \"offset of {ty}.{field}\");\n"
        ));
    }
    // C++ can name a field's type: each must be exactly the one the Rust field's type spells
    // (function pointers with their whole signature, enumerations as int32_t).
    c.push_str("#ifdef __cplusplus\n#include <type_traits>\n");
    for (ty, field, _, c_type) in &offsets {
        c.push_str(&format!(
            "static_assert(std::is_same<decltype({ty}::{field}), {c_type}>::value, \"type of {ty}.{field}\");\n"
        ));
    }
    c.push_str(&format!(
        "static_assert(std::is_same<ObscuraProjectionEntry, {}>::value, \"ObscuraProjectionEntry\");\n#endif\n",
        <abi::EntryFn as CType>::c()
    ));
    for (name, value) in constants {
        c.push_str(&format!("OBSCURA_SA(({name}) == {value}, \"{name}\");\n"));
    }
    c.push_str("OBSCURA_SA(OBSCURA_ARRAY_VARIABLE < 0, \"signed\");\nint obscura_layout_checked(void) { return 1; }\n");
    c
}

fn compile_object(src: &Path, compiler: &str, args: &[&str]) -> std::process::Output {
    Command::new(compiler)
        .args(args)
        .arg("-I")
        .arg(workspace().join("include"))
        .arg("-c")
        .arg(src)
        .arg("-o")
        .arg(src.with_extension("o"))
        .output()
        .unwrap_or_else(|e| panic!("cannot run `{compiler}`: {e}"))
}

#[test]
fn the_header_and_the_rust_types_cannot_drift_apart() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("layout.c");
    std::fs::write(&good, static_asserts(false)).unwrap();
    let out = compile_object(
        &good,
        &c_compiler(),
        &["-std=c11", "-Wall", "-Wextra", "-Werror", "-pedantic"],
    );
    assert!(
        out.status.success(),
        "projection.h disagrees with the Rust #[repr(C)] types:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The same facts hold for C++ authors, and C++ checks every field's type and every function
    // pointer's signature too (CI installs g++; elsewhere a missing C++ compiler skips this part).
    let cxx = std::env::var("CXX").unwrap_or_else(|_| "c++".into());
    if Command::new(&cxx).arg("--version").output().is_ok() {
        let cpp = dir.path().join("layout.cpp");
        std::fs::write(&cpp, static_asserts(false)).unwrap();
        let out = compile_object(&cpp, &cxx, &["-std=c++11", "-Wall", "-Wextra", "-Werror"]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    } else {
        eprintln!("no C++ compiler ({cxx}): field types not checked");
    }
    // Every struct has exactly the fields the Rust side knows, in order: a field appended into
    // tail padding (same size, same offsets) is caught here.
    let header = std::fs::read_to_string(workspace().join("include/obscura/projection.h")).unwrap();
    let (_, offsets, _) = header_facts();
    let members = header_members(&header);
    let mut structs: Vec<&str> = offsets.iter().map(|o| o.0).collect();
    structs.dedup();
    for name in &structs {
        let want: Vec<&str> = offsets.iter().filter(|o| o.0 == *name).map(|o| o.1).collect();
        let got = members
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, m)| m.iter().map(String::as_str).collect::<Vec<_>>())
            .unwrap_or_else(|| panic!("no struct {name} in projection.h"));
        assert_eq!(got, want, "the fields of {name} in projection.h");
    }
    let header_structs: Vec<&str> = members.iter().map(|(n, _)| n.as_str()).collect();
    for name in &header_structs {
        assert!(
            structs.contains(name),
            "projection.h has struct {name}, the Rust side does not"
        );
    }
    // The parser sees an appended field.
    let grown = header.replace(
        "    float float_value;\n",
        "    float float_value;\n    int32_t flags;\n",
    );
    assert_ne!(grown, header);
    assert_ne!(header_members(&grown), members);
    // And the check itself can fail: one wrong size is a compile error naming the struct.
    let bad = dir.path().join("tampered.c");
    std::fs::write(&bad, static_asserts(true)).unwrap();
    let out = compile_object(&bad, &c_compiler(), &["-std=c11"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("sizeof ObscuraRayGeometry"));
}

#[test]
fn a_loaded_projection_answers_properties_through_the_abi() {
    let (_d, p) = c_fisheye();
    let mut reg = Registry::new();
    load_file(&mut reg, &p).unwrap();
    let mut env = square_camera(16).environment();
    let proj = reg.create("CFisheye", &mut env, &ParamList::new()).unwrap();
    assert_eq!(
        env.deep_metric(),
        DeepMetric::RayLength,
        "the environment's writable field came back"
    );
    assert_eq!(
        proj.property(ProjectionProperty::DicingHint),
        Some(PropertyValue::DicingHint(DicingHint::Spherical))
    );
    assert_eq!(
        proj.property(ProjectionProperty::FieldOfView),
        Some(PropertyValue::Float(180.0))
    );
    assert_eq!(proj.property(ProjectionProperty::FStop), None);
}
