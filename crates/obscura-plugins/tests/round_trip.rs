//! Round trips through C that need both sides of the ABI: what the SDK builds for a plugin (its
//! table, its exported entry points) read back by the host's decoder, and what the host builds
//! (parameter lists, environments, error sinks) read back by the SDK's plugin-side readers. No shared
//! library: the entry points are called as a host would, in this process.

use std::ffi::c_void;

use obscura_plugins::decode::{decl_from_raw, value_from_raw};
use obscura_plugins::encode::{OwnedEnvironment, OwnedParamList, collect_message};
use obscura_sdk::abi::c_data::read_str;
use obscura_sdk::abi::{
    ABI_VERSION, ARRAY_VARIABLE, AbiError, ERROR, OK, OwnedParamTable, PANIC, ProjectionDescriptor,
    RawContext, RawParamDecl, RawPropertyValue, Status, UNSUPPORTED, environment_from_raw,
    param_list_from_raw, report,
};
use obscura_sdk::{
    DeepMetric, Format, Matrix4, MotionSample, ParamDecl, ParamList, Params, PluginError, Point2, Projection,
    ProjectionContext, ProjectionEnvironment, ProjectionFactory, ProjectionProperty, PropertyValue,
    RayGeometry, Rgb, ScreenWindow, ValueRange, Vec3,
};

fn table() -> Vec<ParamDecl> {
    vec![
        ParamDecl::float("fov", 90.0)
            .range(ValueRange::open(0.0, 360.0))
            .doc("field of view"),
        ParamDecl::string("mode", "a").choices(&["a", "b"]).doc("mode"),
        ParamDecl::int_array("steps", &[1, 2]),
        ParamDecl::float_list("k", &[]),
        ParamDecl::matrix("m", Matrix4::IDENTITY),
    ]
}

#[test]
fn a_table_survives_the_trip_through_c() {
    let t = table();
    let raw = OwnedParamTable::new(&t).unwrap();
    let back: Vec<ParamDecl> = raw.rows().iter().map(|d| decode(d).unwrap()).collect();
    assert_eq!(back, t);
}

/// Decodes a row whose pointers all point into an [`OwnedParamTable`] alive for the call.
fn decode(row: &RawParamDecl) -> Result<ParamDecl, AbiError> {
    // SAFETY: every row passed here is a copy of a live owned table's row with only counts, flags or
    // bounds changed, or a pointer set to NULL; the counts are checked before any read.
    unsafe { decl_from_raw(row) }
}

#[test]
fn inconsistent_rows_are_refused_with_the_parameter_named() {
    let t = table();
    let raw = OwnedParamTable::new(&t).unwrap();
    let mut row = raw.rows()[0];
    row.default_count = 2;
    let e = decode(&row).unwrap_err().to_string();
    assert!(
        e.contains("parameter \"fov\"") && e.contains("default_count 2 but a float default has 1 scalar(s)"),
        "{e}"
    );
    let mut row = raw.rows()[0];
    row.range_max = 10.0;
    assert!(
        decode(&row)
            .unwrap_err()
            .to_string()
            .contains("outside its own range")
    );
    let mut row = raw.rows()[2];
    row.default_ints = std::ptr::null();
    assert!(decode(&row).unwrap_err().to_string().contains("NULL"));
    let mut row = raw.rows()[2];
    row.array_len = ARRAY_VARIABLE;
    assert!(decode(&row).unwrap_err().to_string().contains("only float[]"));
    let mut row = raw.rows()[1];
    row.name = std::ptr::null();
    let e = decode(&row).unwrap_err();
    assert_eq!(e.to_string(), "name is NULL");
    assert_eq!(e, AbiError::NullPointer { what: "name".into() });
}

#[test]
fn a_parameter_list_resolves_in_table_order_and_reads_back_as_given() {
    let t = table();
    let mut list = ParamList::new();
    list.push_text("string mode", &["b"], Some("scene.rib:3".into()))
        .unwrap();
    list.push_text("float k", &["0.5", "0.25", "0.125"], None)
        .unwrap();
    Params::resolve("P", &t, &list).unwrap();
    let owned = OwnedParamList::new(&t, &list).unwrap();
    let e = owned.entries();
    assert_eq!(e.len(), t.len());
    assert_eq!((e[0].given, e[1].given, e[3].given), (0, 1, 1));
    // SAFETY: the list owns one float for the defaulted `fov`.
    assert_eq!(unsafe { *e[0].floats }, 90.0, "the default is filled in");
    assert_eq!(e[3].count, 3);
    assert_eq!(e[3].array_len, ARRAY_VARIABLE);
    // SAFETY: the list and everything it points to live in `owned`.
    let back = unsafe { param_list_from_raw(owned.raw()) }.unwrap();
    assert_eq!(back.entries().len(), 2);
    assert_eq!(back.get("mode").unwrap().origin.as_deref(), Some("scene.rib:3"));
    let p = Params::resolve("P", &t, &back).unwrap();
    assert_eq!(p.string("mode").unwrap(), "b");
    assert_eq!(p.float_list("k").unwrap(), &[0.5, 0.25, 0.125]);
    assert!(!p.is_given("fov"));
}

#[test]
fn the_environment_survives_the_trip_through_c() {
    let mut m = Matrix4::IDENTITY;
    m.0[3] = [1.0, 2.0, 3.0, 1.0];
    let mut env = ProjectionEnvironment::new(
        Format {
            width: 320,
            height: 200,
            pixel_aspect: 1.25,
        },
        ScreenWindow::new(-2.0, 2.0, -1.0, 1.0),
        (0.25, 0.75),
        (0.5, 100.0),
        vec![
            MotionSample {
                time: 0.25,
                world_to_camera: Matrix4::IDENTITY,
            },
            MotionSample {
                time: 0.75,
                world_to_camera: m,
            },
        ],
    );
    env.set_deep_metric(DeepMetric::RayLength);
    let mut owned = OwnedEnvironment::new(&env);
    // SAFETY: the environment and its motion samples live in `owned`.
    let back = unsafe { environment_from_raw(owned.raw_mut()) }.unwrap();
    assert_eq!(back, env);
    owned.raw_mut().deep_metric = 9;
    assert!(owned.deep_metric().unwrap_err().to_string().contains("9"));
    owned.raw_mut().struct_size = 8;
    assert!(
        // SAFETY: as above; the short size is refused before anything else is read.
        unsafe { environment_from_raw(owned.raw_mut()) }
            .unwrap_err()
            .to_string()
            .contains("smaller")
    );
}

#[test]
fn messages_cross_as_copies() {
    // SAFETY: the sink `collect_message` lends is valid for the closure.
    let ((), msg) = collect_message(|sink| unsafe {
        report(sink, "bad fov: ");
        report(sink, "expected (0, 360)");
    });
    assert_eq!(msg, "bad fov: expected (0, 360)");
    // SAFETY: a null sink is allowed: the message is dropped.
    unsafe { report(std::ptr::null(), "dropped") };
}

// The exported entry points, called as a host would, without a shared library.

struct Doubler;
struct DoublerFactory;
impl Projection for Doubler {
    fn property(&self, p: ProjectionProperty) -> Option<PropertyValue> {
        (p == ProjectionProperty::FieldOfView).then_some(PropertyValue::Float(60.0))
    }
    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        if c.screen.first().is_some_and(|s| s.x > 100.0) {
            panic!("screen x {} is absurd", c.screen[0].x);
        }
        for (t, s) in c.time.iter_mut().zip(c.screen) {
            *t = s.x * 2.0;
        }
    }
}
impl ProjectionFactory for DoublerFactory {
    fn name(&self) -> &str {
        "Doubler"
    }
    fn summary(&self) -> &str {
        "doubles"
    }
    fn param_table(&self) -> &[ParamDecl] {
        &[]
    }
    fn create_projection(
        &self,
        env: &mut ProjectionEnvironment,
        params: &ParamList,
    ) -> Result<Box<dyn Projection>, PluginError> {
        Params::resolve("Doubler", &[], params)?;
        env.set_deep_metric(DeepMetric::RayLength);
        Ok(Box::new(Doubler))
    }
}

mod exported {
    obscura_sdk::export_projection!(super::DoublerFactory);
}

/// Calls the exported `project` on `ctx`, returning its status and message.
fn project(d: &ProjectionDescriptor, proj: *mut c_void, ctx: *const RawContext) -> (Status, String) {
    // SAFETY: `proj` is a live projection of this descriptor's `create_projection`; `ctx` is null
    // (refused) or points to a context whose arrays hold `num_rays` elements for the call.
    collect_message(|e| unsafe { d.project.unwrap()(proj, ctx, e) })
}

/// `project` through the ABI: results come back, a panic is a status and a message, and null or
/// short contexts are refused.
fn project_keeps_the_contract(d: &ProjectionDescriptor, proj: *mut c_void) {
    let screen = [Point2::new(0.25, 0.0), Point2::new(0.125, 0.0)];
    let mut time = [0.0f32; 2];
    let mut rays = [RayGeometry::CULLED; 2];
    let mut tint = [Rgb::WHITE; 2];
    let ctx = RawContext {
        struct_size: size_of::<RawContext>() as u32,
        num_rays: 2,
        screen: screen.as_ptr(),
        lens: screen.as_ptr(),
        aperture: screen.as_ptr(),
        time: time.as_mut_ptr(),
        rays: rays.as_mut_ptr(),
        tint: tint.as_mut_ptr(),
    };
    assert_eq!(project(d, proj, &ctx).0, OK);
    assert_eq!(time, [0.5, 0.25]);

    let absurd = [Point2::new(1000.0, 0.0); 2];
    let ctx_panics = RawContext {
        screen: absurd.as_ptr(),
        ..ctx
    };
    let (s, m) = project(d, proj, &ctx_panics);
    assert_eq!(s, PANIC);
    assert!(m.contains("panicked in project: screen x 1000 is absurd"), "{m}");

    let (s, m) = project(d, proj, std::ptr::null());
    assert_eq!(s, ERROR);
    assert!(m.contains("context pointer is NULL"), "{m}");
    let null_rays = RawContext {
        rays: std::ptr::null_mut(),
        ..ctx
    };
    let (s, m) = project(d, proj, &null_rays);
    assert_eq!(s, ERROR);
    assert!(m.contains("rays is NULL"), "{m}");
    let small = RawContext {
        struct_size: 8,
        ..ctx
    };
    // SAFETY: as in `project`, with no sink (the message is dropped).
    let s = unsafe { d.project.unwrap()(proj, &small, std::ptr::null()) };
    assert_eq!(s, ERROR);
}

#[test]
fn exported_entry_points_keep_the_contract() {
    // SAFETY: the generated entry point returns a descriptor that lives for the process.
    let d = unsafe { &*exported::obscura_projection_entry(ABI_VERSION) };
    assert_eq!(
        (d.abi_version, d.struct_size as usize),
        (ABI_VERSION, size_of::<ProjectionDescriptor>())
    );
    // SAFETY: the descriptor's name is a NUL-terminated string it keeps.
    assert_eq!(unsafe { read_str(d.name, "name") }.unwrap(), "Doubler");
    let mut factory = std::ptr::null_mut();
    // SAFETY: the descriptor `init` belongs to, a NUL-terminated path, a valid out-pointer and sink.
    let (s, _) = collect_message(|e| unsafe { d.init.unwrap()(d, c"".as_ptr(), &mut factory, e) });
    assert_eq!(s, OK);
    assert!(!factory.is_null());

    let env = ProjectionEnvironment::for_format(Format::new(4, 4));
    let mut raw_env = OwnedEnvironment::new(&env);
    let params = OwnedParamList::new(&[], &ParamList::new()).unwrap();
    let mut proj = std::ptr::null_mut();
    // SAFETY: the factory `init` made; the environment and list live for the call.
    let (s, m) = collect_message(|e| unsafe {
        d.create_projection.unwrap()(factory, raw_env.raw_mut(), params.raw(), &mut proj, e)
    });
    assert_eq!(s, OK, "{m}");
    assert_eq!(
        raw_env.deep_metric(),
        Ok(DeepMetric::RayLength),
        "the writable field comes back"
    );

    let mut v = RawPropertyValue {
        kind: -1,
        enum_value: 0,
        float_value: 0.0,
    };
    let property = |p: i32, v: &mut RawPropertyValue| {
        // SAFETY: a live projection and an out-pointer valid for the call.
        unsafe { d.property.unwrap()(proj, p, v) }
    };
    assert_eq!(property(2, &mut v), OK);
    assert_eq!(value_from_raw(v), Ok(PropertyValue::Float(60.0)));
    assert_eq!(property(0, &mut v), UNSUPPORTED);
    assert_eq!(property(99, &mut v), UNSUPPORTED);

    project_keeps_the_contract(d, proj);

    let mut out = Point2::ZERO;
    assert_eq!(
        // SAFETY: a live projection and an out-pointer valid for the call.
        unsafe { d.unproject.unwrap()(proj, Vec3::Z, 0.0, &mut out) },
        UNSUPPORTED,
        "the trait's default: no inverse"
    );
    // SAFETY: made by this factory's `create_projection`, destroyed once.
    unsafe { d.destroy_projection.unwrap()(factory, proj) };

    let mut given = ParamList::new();
    given.push_text("float fov", &["3"], Some("here".into())).unwrap();
    let table = [ParamDecl::float("fov", 1.0)];
    let params = OwnedParamList::new(&table, &given).unwrap();
    // SAFETY: as for the first create.
    let (s, m) = collect_message(|e| unsafe {
        d.create_projection.unwrap()(factory, raw_env.raw_mut(), params.raw(), &mut proj, e)
    });
    assert_eq!(s, ERROR);
    assert!(m.contains("unknown parameter \"fov\""), "{m}");
    // SAFETY: the factory `init` made, every projection destroyed.
    unsafe { d.finalize.unwrap()(factory) };
}
