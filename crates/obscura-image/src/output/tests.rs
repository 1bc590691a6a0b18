//! Tests of [`super`] (output.rs).

use super::*;
use crate::filter::Filter;
use crate::testing::rect;
use exr::prelude::{ReadChannels, ReadLayers, read};
use glam::Vec3;
use obscura_host::PixelRect;
use obscura_scene::{FilterKind, PixelFilter};
use obscura_sdk::Rgb;

pub(crate) fn pixel_value(x: u32, y: u32) -> SampleValues {
    let (fx, fy) = (x as f32, y as f32);
    SampleValues {
        ci: Rgb::new(0.1 * fx, 0.05 * fy, 0.333_333),
        alpha: if x.is_multiple_of(3) { 0.0 } else { 1.0 },
        z: if x.is_multiple_of(3) {
            f32::INFINITY
        } else {
            1.0 + fx + 100.0 * fy
        },
        n: Vec3::new(fx, -fy, 0.5),
        p: Vec3::new(10.0 * fx, 1.0 / (1.0 + fy), -3.0),
        camera_direction: Vec3::new(0.1, 0.2, 0.974_679_4),
        albedo: Rgb::new(0.01 * fx, 0.5, 0.02 * fy),
        uv: glam::Vec2::new(0.25 * fx, -fy),
        truth: crate::samples::Truth {
            camera_z: 2.0 + fx,
            distance: 3.0 + fy,
            p_camera: Vec3::new(fx, fy, 7.0),
            n_camera: Vec3::new(0.0, 1.0, 0.0),
            object_id: x,
            instance_id: 100 + y,
            material_id: 4_000_000_000,
        },
        flow: crate::samples::FlowPixel::NONE,
        sensor: crate::film::SensorPixel::default(),
    }
}

#[test]
fn ground_truth_channels_are_named_and_ids_are_exact_integers() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("truth.exr");
    let crop = rect(0, 5, 0, 3);
    let mut f = film(5, 3, crop);
    let flow = (0..15)
        .map(|i| crate::samples::FlowPixel {
            forward: [i as f32, -0.5],
            backward: [0.25, i as f32],
            forward_valid: 1.0,
            backward_valid: (i % 2) as f32,
        })
        .collect();
    f.set_flow(flow);
    let ground_truth: Vec<Aov> = Aov::all_extra().filter(|a| a.is_ground_truth()).collect();
    write_exr(&path, &f, &ground_truth, true, 1.0, &[]).unwrap();
    let image = read_back(&path);
    let layer = &image.layer_data;
    let mut names: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "Ncamera.X",
            "Ncamera.Y",
            "Ncamera.Z",
            "Pcamera.X",
            "Pcamera.Y",
            "Pcamera.Z",
            "cameraZ",
            "distance",
            "flowBackward.X",
            "flowBackward.Y",
            "flowForward.X",
            "flowForward.Y",
            "flowValid.backward",
            "flowValid.forward",
            "instanceId",
            "materialId",
            "objectId",
        ]
    );
    // IDs stay 32-bit integers even in a half file: 4e9 survives exactly.
    match channel(layer, "materialId") {
        FlatSamples::U32(v) => assert!(v.iter().all(|&m| m == 4_000_000_000)),
        other => panic!("{other:?}"),
    }
    match channel(layer, "instanceId") {
        FlatSamples::U32(v) => assert_eq!(v[7], 101),
        other => panic!("{other:?}"),
    }
    match channel(layer, "flowForward.X") {
        FlatSamples::F16(v) => assert_eq!(v[7].to_f32(), 7.0),
        other => panic!("{other:?}"),
    }
    match channel(layer, "flowValid.backward") {
        FlatSamples::F16(v) => assert_eq!((v[0].to_f32(), v[1].to_f32()), (0.0, 1.0)),
        other => panic!("{other:?}"),
    }
    // The reference OpenEXR library reads the IDs as 32-bit unsigned integers, exactly.
    let Some(out) = run_independent_reader("film_exr_read.py", &path) else {
        return;
    };
    let line = |name: &str| {
        out.lines()
            .find(|l| l.starts_with(&format!("{name} ")))
            .unwrap_or_else(|| panic!("no {name} in {out}"))
            .to_string()
    };
    assert!(
        line("materialId").starts_with("materialId uint32 4000000000.0 "),
        "{}",
        line("materialId")
    );
    let instance: Vec<String> = line("instanceId")
        .split(' ')
        .skip(2)
        .map(str::to_string)
        .collect();
    assert_eq!(instance[7], "101.0");
    assert!(line("flowForward.X").starts_with("flowForward.X float16 0.0 1.0 2.0 "));
}

/// A film whose every crop pixel holds exactly `pixel_value` (one sample at each centre, width-1
/// box filter).
pub(crate) fn film(w: u32, h: u32, crop: PixelRect) -> Film {
    let f = Filter::new(&PixelFilter {
        kind: FilterKind::Box,
        width_x: 1.0,
        width_y: 1.0,
    })
    .unwrap();
    let mut film = Film::new(w, h, crop, f);
    let mut t = film.tile(crop);
    for y in crop.y0..crop.y1 {
        for x in crop.x0..crop.x1 {
            t.add_sample(x as f32 + 0.5, y as f32 + 0.5, &pixel_value(x, y));
        }
    }
    film.merge(t);
    film
}

fn channel<'a>(layer: &'a exr::prelude::Layer<AnyChannels<FlatSamples>>, name: &str) -> &'a FlatSamples {
    &layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == name)
        .unwrap()
        .sample_data
}

fn read_back(path: &Path) -> Image<Layer<AnyChannels<FlatSamples>>> {
    read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap()
}

#[test]
fn output_exr_float_channels_values_and_windows() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("beauty.exr");
    let crop = rect(3, 10, 2, 6);
    let f = film(12, 8, crop);
    let aovs = [
        Aov::Ci,
        Aov::Alpha,
        Aov::Z,
        Aov::N,
        Aov::P,
        Aov::CameraDirection,
        Aov::Z,
        Aov::Albedo,
        Aov::Uv,
    ];
    let attrs = [
        ("projection", "PxrPerspective".to_string()),
        ("note", "ünïcode ok".to_string()),
    ];
    write_exr(&path, &f, &aovs, false, 1.5, &attrs).unwrap();
    assert!(crate::atomic::temporaries(&path).is_empty());

    let image = read_back(&path);
    assert_eq!(
        image.attributes.display_window,
        IntegerBounds::new((0, 0), (12, 8))
    );
    assert_eq!(image.attributes.pixel_aspect, 1.5);
    let layer = &image.layer_data;
    assert_eq!(layer.size, Vec2(7, 4));
    assert_eq!(layer.attributes.layer_position, Vec2(3, 2));
    let names: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    assert_eq!(
        names,
        [
            "A",
            "B",
            "G",
            "N.X",
            "N.Y",
            "N.Z",
            "P.X",
            "P.Y",
            "P.Z",
            "R",
            "Z",
            "albedo.B",
            "albedo.G",
            "albedo.R",
            "cameraDirection.X",
            "cameraDirection.Y",
            "cameraDirection.Z",
            "uv.X",
            "uv.Y"
        ]
    );
    assert_eq!(
        layer.attributes.other.get(&Text::from("projection")),
        Some(&AttributeValue::Text(Text::from("PxrPerspective")))
    );
    for (name, aov, k) in [
        ("R", Aov::Ci, 0),
        ("G", Aov::Ci, 1),
        ("B", Aov::Ci, 2),
        ("A", Aov::Alpha, 0),
        ("Z", Aov::Z, 0),
        ("N.Y", Aov::N, 1),
        ("P.Y", Aov::P, 1),
        ("cameraDirection.Z", Aov::CameraDirection, 2),
        ("albedo.R", Aov::Albedo, 0),
        ("albedo.B", Aov::Albedo, 2),
        ("uv.X", Aov::Uv, 0),
        ("uv.Y", Aov::Uv, 1),
    ] {
        let FlatSamples::F32(values) = channel(layer, name) else {
            panic!("{name} is not float");
        };
        for (i, got) in values.iter().enumerate() {
            let (x, y) = (3 + i as u32 % 7, 2 + i as u32 / 7);
            let want = pixel_value(x, y);
            assert_eq!(
                got.to_bits(),
                component(&want, aov, k).to_bits(),
                "{name} ({x}, {y})"
            );
        }
    }
}

#[test]
fn output_exr_half_rounds_like_half() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("half.exr");
    let crop = rect(0, 5, 0, 3);
    let f = film(5, 3, crop);
    write_exr(&path, &f, &[Aov::Ci, Aov::Z], true, 1.0, &[]).unwrap();
    let image = read_back(&path);
    let layer = &image.layer_data;
    assert_eq!(layer.channel_data.list.len(), 4);
    let FlatSamples::F16(b) = channel(layer, "B") else {
        panic!("B is not half")
    };
    // 0.333333 is not a half: it rounds to 0.33325195 (0x3555).
    assert_eq!(b[0].to_bits(), 0x3555);
    assert_eq!(b[0].to_f32(), 0.333_251_95);
    let FlatSamples::F16(z) = channel(layer, "Z") else {
        panic!("Z is not half")
    };
    assert!(z[0].to_f32().is_infinite());
    assert_eq!(z[1].to_f32(), 2.0);
    assert_eq!(z[1 + 5].to_f32(), 102.0);
}

#[test]
fn output_exr_reads_back_with_python_openexr() {
    let dir = tempfile::tempdir().unwrap();
    let crop = rect(3, 10, 2, 6);
    let f = film(12, 8, crop);
    for half in [false, true] {
        let path = dir.path().join(format!("flat-{half}.exr"));
        let attrs = [("projection", "PxrFisheye".to_string())];
        write_exr(
            &path,
            &f,
            &[Aov::Ci, Aov::Alpha, Aov::Z, Aov::P],
            half,
            1.25,
            &attrs,
        )
        .unwrap();
        let Some(out) = run_independent_reader("film_exr_read.py", &path) else {
            return;
        };
        let mut lines = out.lines();
        assert_eq!(lines.next().unwrap(), "dataWindow 3 2 9 5 displayWindow 0 0 11 7");
        assert_eq!(
            lines.next().unwrap(),
            "pixelAspectRatio 1.25 compression ZIP_COMPRESSION"
        );
        assert_eq!(lines.next().unwrap(), "projection PxrFisheye");
        let mut seen = Vec::new();
        for line in lines {
            let mut t = line.split_whitespace();
            let (name, kind) = (t.next().unwrap(), t.next().unwrap());
            assert_eq!(kind, if half { "float16" } else { "float32" }, "{name}");
            let (aov, k) = match name {
                "R" | "G" | "B" => (Aov::Ci, ["R", "G", "B"].iter().position(|c| *c == name).unwrap()),
                "A" => (Aov::Alpha, 0),
                "Z" => (Aov::Z, 0),
                _ => (
                    Aov::P,
                    ["P.X", "P.Y", "P.Z"].iter().position(|c| *c == name).unwrap(),
                ),
            };
            let values: Vec<f32> = t.map(|v| v.parse::<f64>().unwrap() as f32).collect();
            assert_eq!(values.len(), crop.len());
            for (i, got) in values.iter().enumerate() {
                let (x, y) = (3 + i as u32 % 7, 2 + i as u32 / 7);
                let want = component(&pixel_value(x, y), aov, k);
                let want = if half { f16::from_f32(want).to_f32() } else { want };
                assert_eq!(got.to_bits(), want.to_bits(), "{name} ({x}, {y}) half={half}");
            }
            seen.push(name.to_string());
        }
        assert_eq!(seen, ["A", "B", "G", "P.X", "P.Y", "P.Z", "R", "Z"]);
    }
}

#[test]
fn output_exr_refuses_what_it_cannot_write_and_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.exr");
    let f = film(4, 4, rect(0, 4, 0, 4));
    let err = write_exr(&path, &f, &[], false, 1.0, &[]).unwrap_err();
    assert!(matches!(err, OutputError::NoChannels { .. }) && err.to_string().contains("x.exr"));
    for name in ["", "dataWindow", "a\0b"] {
        let err = write_exr(&path, &f, &[Aov::Ci], false, 1.0, &[(name, "v".into())]).unwrap_err();
        assert!(matches!(err, OutputError::Attribute { .. }), "{err}");
    }
    let empty = Film::new(4, 4, rect(2, 2, 0, 4), *f.filter());
    assert!(matches!(
        write_exr(&path, &empty, &[Aov::Ci], false, 1.0, &[]),
        Err(OutputError::EmptyImage { .. })
    ));
    assert!(matches!(
        write_png(&path, &empty),
        Err(OutputError::EmptyImage { .. })
    ));
    assert!(!path.exists());
}

#[test]
fn output_writes_into_a_missing_directory_fail_naming_the_path_and_leave_no_temporary() {
    let dir = tempfile::tempdir().unwrap();
    let f = film(4, 4, rect(0, 4, 0, 4));
    for name in ["a.exr", "a.png"] {
        let path = dir.path().join("missing").join(name);
        let err = if name.ends_with("exr") {
            write_exr(&path, &f, &[Aov::Ci], false, 1.0, &[]).unwrap_err()
        } else {
            write_png(&path, &f).unwrap_err()
        };
        assert!(err.to_string().contains(&path.display().to_string()), "{err}");
        assert!(crate::atomic::temporaries(&path).is_empty());
        assert!(!path.exists());
    }
}

#[test]
fn output_srgb_curve() {
    assert_eq!(srgb_encode(0.0), 0.0);
    assert_eq!(srgb_encode(1.0), 1.0);
    assert_eq!(srgb_encode(-3.0), 0.0);
    assert_eq!(srgb_encode(7.0), 1.0);
    assert_eq!(srgb_encode(f32::NAN), 0.0);
    assert!((srgb_encode(0.002) - 0.02584).abs() < 1e-6);
    // Continuous at the knee (to the precision of the published constants).
    let k = 0.003_130_8f32;
    assert!((srgb_encode(k) - srgb_encode(k + 1e-7)).abs() < 1e-5);
    assert!((srgb_encode(0.5) - 0.735_356_6).abs() < 1e-6);
    assert_eq!(quantize(srgb_encode(0.5)), 188);
    assert_eq!(quantize(srgb_encode(0.18)), 118);
}

#[test]
fn output_png_reads_back_with_the_png_decoder() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("preview.png");
    let crop = rect(1, 6, 2, 5);
    let f = Filter::new(&PixelFilter::default()).unwrap();
    let mut film = Film::new(8, 6, crop, f);
    let mut t = film.tile(crop);
    for y in crop.y0..crop.y1 {
        for x in crop.x0..crop.x1 {
            let ci = if (x, y) == (2, 3) {
                Rgb::new(0.5, 2.0, -1.0)
            } else {
                Rgb::new(0.5, 0.5, 0.5)
            };
            t.add_sample(
                x as f32 + 0.5,
                y as f32 + 0.5,
                &SampleValues {
                    ci,
                    alpha: 1.0,
                    ..SampleValues::EMPTY
                },
            );
        }
    }
    film.merge(t);
    write_png(&path, &film).unwrap();
    assert!(crate::atomic::temporaries(&path).is_empty());

    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (5, 3));
    assert_eq!(
        (info.color_type, info.bit_depth),
        (png::ColorType::Rgb, png::BitDepth::Eight)
    );
    let px = |x: u32, y: u32| {
        let i = ((y - crop.y0) * 5 + (x - crop.x0)) as usize * 3;
        [buf[i], buf[i + 1], buf[i + 2]]
    };
    // A corner pixel far from (2, 3) sees only 0.5 grey samples: 0.5 linear → 188.
    assert_eq!(px(5, 4), [188, 188, 188]);
    // The gaussian mixes (2, 3)'s out-of-range colour in; film values are clamped, never wrapped.
    let v = film.pixel(2, 3);
    assert_eq!(
        px(2, 3),
        [188, quantize(srgb_encode(v.ci.g)), quantize(srgb_encode(v.ci.b)),]
    );
    assert!(px(2, 3)[1] > 188 && px(2, 3)[2] < 188);
}

/// Issue 16: `rays` and `stmap` EXRs differed run to run, the `exr` crate writing custom header
/// attributes in a `HashMap`'s order. Files written in separate processes (separate hash seeds) are
/// simulated by writing the same attributes in every insertion order: the bytes must not change.
#[test]
fn output_exr_bytes_do_not_depend_on_the_attribute_order() {
    let dir = tempfile::tempdir().unwrap();
    let f = film(6, 4, rect(0, 6, 0, 4));
    let attributes = [
        ("obscura:projection", "PxrPerspective".to_string()),
        ("obscura:parameters", "fov=40".to_string()),
        ("obscura:calibration", "cameras.txt".to_string()),
        ("obscura:partial", "no".to_string()),
    ];
    let orders = [[0, 1, 2, 3], [3, 2, 1, 0], [1, 3, 0, 2], [2, 0, 3, 1]];
    let mut files = Vec::new();
    for (k, order) in orders.iter().enumerate() {
        let list: Vec<(&str, String)> = order.iter().map(|&i| attributes[i].clone()).collect();
        // Many writes, so that HashMap orders differ between them at least once.
        for n in 0..4 {
            let path = dir.path().join(format!("a{k}-{n}.exr"));
            write_exr(&path, &f, &[Aov::Ci, Aov::Z], false, 1.0, &list).unwrap();
            files.push(std::fs::read(&path).unwrap());
        }
    }
    assert!(files.iter().all(|b| b == &files[0]));
    // Still a valid file with every attribute.
    let image = read_back(&dir.path().join("a0-0.exr"));
    assert_eq!(image.layer_data.attributes.other.len(), 4);
    // Sorting is idempotent, and leaves anything that is not a single-part header alone.
    let mut again = files[0].clone();
    sort_header_attributes(&mut again);
    assert_eq!(again, files[0]);
    let mut junk = b"not an exr at all".to_vec();
    sort_header_attributes(&mut junk);
    assert_eq!(junk, b"not an exr at all");
}
