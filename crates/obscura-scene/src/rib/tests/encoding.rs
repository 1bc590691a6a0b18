//! Files as they come: binary RIB, gzip, Latin-1 bytes, empty files and fragments, and the messages
//! for values that are not what a request expects.

use std::io::Write;
use std::path::Path;

use super::*;
use crate::rib::lex::{Command, Value, lex};
use crate::rib::{parse_bytes, parse_file};

/// A scene using numbers (integers, fractions, arrays), strings and string arrays.
const ASCII: &str = r#"Format 64 48 1
Projection "perspective" "fov" [40]
Display "out.exr" "openexr" "rgba"
Translate 0 -0.5 4.25
WorldBegin
  Light "PxrDomeLight" "dome" "color lightColor" [0.5 0.25 1]
  AttributeBegin
    Bxdf "PxrDiffuse" "d" "color diffuseColor" [0.8 0.1 0.1]
    Sphere 1 -1 1 360
    Polygon "P" [-5 0 -5 5 0 -5 5 0 5 -5 0 5]
  AttributeEnd
WorldEnd
"#;

/// A binary RIB writer of our own, from the encoding table of RISpec 3.2 appendix C.2: every request
/// is defined once (0xCC) and then used by its code (0xA6); integers that fit two bytes are 0x81,
/// other numbers float32 (0xA4); number arrays 0xC8; strings 0x90 + length (short) or 0xA0 (long);
/// string arrays are ASCII `[ … ]` around binary strings (the spec allows mixing).
fn encode(commands: &[Command]) -> Vec<u8> {
    fn string(out: &mut Vec<u8>, s: &str) {
        let b = s.as_bytes();
        if b.len() < 16 {
            out.push(0x90 + b.len() as u8);
        } else {
            out.push(0xA0);
            out.push(u8::try_from(b.len()).expect("short enough for the test"));
        }
        out.extend_from_slice(b);
    }
    fn number(out: &mut Vec<u8>, v: f64, int: Option<i32>) {
        match int.and_then(|i| i16::try_from(i).ok()) {
            Some(i) => {
                out.push(0x81);
                out.extend_from_slice(&i.to_be_bytes());
            }
            None => {
                out.push(0xA4);
                out.extend_from_slice(&(v as f32).to_be_bytes());
            }
        }
    }
    let mut out = Vec::new();
    let mut codes: Vec<String> = Vec::new();
    for c in commands {
        let code = match codes.iter().position(|n| *n == c.name) {
            Some(i) => i,
            None => {
                codes.push(c.name.clone());
                out.extend([0xCC, (codes.len() - 1) as u8]);
                string(&mut out, &c.name);
                codes.len() - 1
            }
        };
        out.extend([0xA6, code as u8]);
        for a in &c.args {
            match a {
                Value::Num(n) => number(&mut out, n.value, n.int),
                Value::Str(s) => string(&mut out, s),
                Value::Nums(ns) => {
                    out.push(0xC8);
                    out.push(ns.len() as u8);
                    for n in ns {
                        out.extend_from_slice(&(n.value as f32).to_be_bytes());
                    }
                }
                Value::Strs(ss) => {
                    out.push(b'[');
                    for s in ss {
                        string(&mut out, s);
                    }
                    out.push(b']');
                }
            }
        }
    }
    out
}

/// A request's name, its numbers and its strings.
type Request = (String, Vec<Vec<f64>>, Vec<Vec<String>>);

/// The requests as names and values, where each was read left aside; integers as floats (a binary
/// float array carries no integers).
fn requests(commands: &[Command]) -> Vec<Request> {
    commands
        .iter()
        .map(|c| {
            let nums = c
                .args
                .iter()
                .filter_map(|a| match a {
                    Value::Num(n) => Some(vec![n.value]),
                    Value::Nums(ns) => Some(ns.iter().map(|n| f64::from(n.value as f32)).collect()),
                    _ => None,
                })
                .map(|v| v.into_iter().map(|x| f64::from(x as f32)).collect())
                .collect();
            let strs = c
                .args
                .iter()
                .filter_map(|a| match a {
                    Value::Str(s) => Some(vec![s.clone()]),
                    Value::Strs(ss) => Some(ss.clone()),
                    _ => None,
                })
                .collect();
            (c.name.clone(), nums, strs)
        })
        .collect()
}

#[test]
fn binary_rib_reads_back_as_the_same_requests_and_scene_as_its_ascii_form() {
    let ascii = lex(ASCII).unwrap();
    let binary = encode(&ascii);
    assert!(
        binary.iter().filter(|&&b| b >= 0x80).count() > 40,
        "the encoding is binary"
    );
    let decoded = lex(&binary).unwrap();
    assert_eq!(requests(&decoded), requests(&ascii));
    assert_eq!(decoded[4].binary.map(|b| b.index), Some(4), "{:?}", decoded[4]);
    let a = parse_str(ASCII, "a.rib", Path::new(HERE)).unwrap();
    let b = parse_bytes(&binary, "b.rib", Path::new(HERE)).unwrap();
    assert_eq!(a.camera.world_to_camera, b.camera.world_to_camera);
    assert_eq!(a.camera.format, b.camera.format);
    assert_eq!(a.displays, b.displays);
    assert_eq!(a.objects.len(), b.objects.len());
    assert_eq!(a.lights.len(), b.lights.len());
}

#[test]
fn binary_numbers_decode_as_the_spec_examples_say() {
    // RISpec 3.2 Fig. C.1: 0.1 = 89 19 99, 10000 = 81 27 10, -0.3 = 89 B3 34, 512 = 81 02 00.
    let bytes = [
        0xCC, 7, 0x93, b'F', b'o', b'o', 0xA6, 7, 0x89, 0x19, 0x99, 0x81, 0x27, 0x10, 0x89, 0xB3, 0x34, 0x81,
        0x02, 0x00, 0xA5, 0x40, 0x09, 0x21, 0xFB, 0x54, 0x44, 0x2D, 0x18, 0xCD, 0x05, 0x92, b'h', b'i', 0xCF,
        0x05,
    ];
    let c = lex(bytes).unwrap();
    let Value::Num(n) = &c[0].args[0] else { panic!() };
    assert!((n.value - 6553.0 / 65536.0).abs() < 1e-12 && n.int.is_none());
    let Value::Num(n) = &c[0].args[1] else { panic!() };
    assert_eq!((n.value, n.int), (10000.0, Some(10000)));
    let Value::Num(n) = &c[0].args[2] else { panic!() };
    assert!((n.value + 0.3).abs() < 1e-4);
    let Value::Num(n) = &c[0].args[3] else { panic!() };
    assert_eq!(n.int, Some(512));
    let Value::Num(n) = &c[0].args[4] else { panic!() };
    assert_eq!(n.value, std::f64::consts::PI);
    assert_eq!(c[0].args[5], Value::Str("hi".into()));
}

#[test]
fn binary_errors_name_the_request_index_or_the_byte_offset() {
    let mut bytes = encode(&lex("WorldBegin\nSphere 1 -1 1 360\nFormat 1 1 1\n").unwrap());
    let e = parse_bytes(&bytes, "b.rib", Path::new(HERE)).unwrap_err();
    assert_eq!(e.request, Some(2));
    let offset = e.byte.unwrap();
    assert_eq!(bytes[offset as usize], 0xA6, "the offset is the request token's");
    assert_eq!(
        e.to_string(),
        format!("b.rib: request 2 at byte {offset}: Format must come before WorldBegin")
    );
    bytes.extend([0xA6, 99]);
    let e = parse_bytes(&bytes, "b.rib", Path::new(HERE)).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!(
            "b.rib: byte {}: request code 99 is used before it is defined (by 0xCC)",
            bytes.len() - 2
        )
    );
    let e = parse_bytes(
        &[0xCC, 1, 0x92, b'F', b'o', 0xA6, 1, 0xC8, 3, 0, 0],
        "b.rib",
        Path::new(HERE),
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "b.rib: byte 7: the stream ends inside a binary token (12 more bytes expected at byte 9)"
    );
    let nan = [0xCC, 1, 0x92, b'F', b'o', 0xA6, 1, 0xA4, 0x7F, 0xC0, 0, 0];
    let e = parse_bytes(&nan, "b.rib", Path::new(HERE)).unwrap_err();
    assert_eq!(
        e.to_string(),
        "b.rib: byte 7: a NaN float: numbers must be finite"
    );
}

#[test]
fn latin1_bytes_in_comments_and_strings_are_read_as_latin1() {
    // "# Szene für …" and a texture named "café.tex" in Latin-1 (0xFC, 0xE9): not UTF-8.
    let mut bytes =
        b"# Szene f\xFCr den Test\nDisplay \"caf\xE9.exr\" \"openexr\" \"rgba\"\nWorldBegin\nWorldEnd\n"
            .to_vec();
    let scene = parse_bytes(&bytes, "t.rib", Path::new(HERE)).unwrap();
    assert_eq!(scene.displays[0].path, Path::new(HERE).join("café.exr"));
    // UTF-8 stays UTF-8.
    bytes = "Display \"café.exr\" \"openexr\" \"rgba\"\nWorldBegin\nWorldEnd\n"
        .as_bytes()
        .to_vec();
    let scene = parse_bytes(&bytes, "t.rib", Path::new(HERE)).unwrap();
    assert_eq!(scene.displays[0].path, Path::new(HERE).join("café.exr"));
}

#[test]
fn a_latin1_or_gzip_file_reads_instead_of_failing_as_not_utf8() {
    let dir = tempfile::tempdir().unwrap();
    let latin1 = dir.path().join("latin1.rib");
    std::fs::write(&latin1, b"# \xE9t\xE9\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n").unwrap();
    assert_eq!(parse_file(&latin1).unwrap().objects.len(), 1);
    // gzip is recognised by content, whatever the extension; archives too.
    let gz = dir.path().join("scene.rib");
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(b"WorldBegin\nReadArchive \"part.ribz\"\nWorldEnd\n")
        .unwrap();
    std::fs::write(&gz, enc.finish().unwrap()).unwrap();
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(b"Sphere 1 -1 1 360\nCone 1 1 360\n").unwrap();
    std::fs::write(dir.path().join("part.ribz"), enc.finish().unwrap()).unwrap();
    assert_eq!(parse_file(&gz).unwrap().objects.len(), 2);
    // A broken gzip stream is named as such.
    std::fs::write(&gz, [0x1f, 0x8b, 8, 0, 1, 2]).unwrap();
    let e = parse_file(&gz).unwrap_err().to_string();
    assert!(e.contains("gzip-compressed but cannot be decompressed"), "{e}");
    assert!(!e.contains(":0:"), "{e}");
}

#[test]
fn an_empty_file_or_a_fragment_without_world_begin_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.rib");
    std::fs::write(&empty, b"").unwrap();
    assert_eq!(
        parse_file(&empty).unwrap_err().to_string(),
        format!(
            "{}: the file is empty (0 bytes): it holds no requests to render",
            empty.display()
        )
    );
    let fragment = dir.path().join("opts.rib");
    std::fs::write(
        &fragment,
        b"Format 64 48 1\nProjection \"perspective\" \"fov\" 40\n",
    )
    .unwrap();
    let e = parse_file(&fragment).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!(
            "{}: no WorldBegin: the file is a fragment",
            fragment.display()
        )),
        "{e}"
    );
}

#[test]
fn a_nan_in_an_array_is_named_not_an_unterminated_array() {
    assert_eq!(
        fail("WorldBegin\nLight \"PxrDomeLight\" \"d\"\n \"color lightColor\" [nan 1 1]\n"),
        "t.rib:3: a NaN value (\"nan\"): numbers must be finite"
    );
    assert_eq!(
        fail("WorldBegin\nSphere 1 -1 -inf 360\n"),
        "t.rib:2: an infinite value (\"-inf\"): numbers must be finite"
    );
}

#[test]
fn a_string_where_a_number_is_expected_is_named() {
    assert_eq!(
        fail("Format \"64\" 48 1\n"),
        "t.rib:1: Format expects width height pixelaspect (3 numbers); argument 1 is the string \"64\", where a number is expected"
    );
    assert_eq!(
        fail("WorldBegin\nTranslate 1 \"2\" 3\n").split(": ").nth(1),
        Some(
            "Translate expects x y z (3 numbers); argument 2 is the string \"2\", where a number is expected"
        )
    );
}

#[test]
fn a_files_bytes_read_as_the_file_does() {
    use crate::rib::parse_file_bytes_frames;
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(ASCII.as_bytes()).unwrap();
    let gz = enc.finish().unwrap();
    let frames = parse_file_bytes_frames(gz, "g.rib", Path::new(HERE)).unwrap();
    assert_eq!(frames.last().unwrap().scene.objects.len(), 2);
    let binary = encode(&lex(ASCII).unwrap());
    let frames = parse_file_bytes_frames(binary, "b.rib", Path::new(HERE)).unwrap();
    assert_eq!(frames.last().unwrap().scene.objects.len(), 2);
    // The file checks, which parse_bytes leaves out.
    assert_eq!(
        parse_file_bytes_frames(b" \n".to_vec(), "e.rib", Path::new(HERE))
            .unwrap_err()
            .to_string(),
        "e.rib: the file is empty (2 bytes): it holds no requests to render"
    );
    let e = parse_file_bytes_frames(b"Format 8 6 1\n".to_vec(), "f.rib", Path::new(HERE)).unwrap_err();
    assert!(e.to_string().starts_with("f.rib: no WorldBegin"), "{e}");
}
