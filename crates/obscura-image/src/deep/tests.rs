//! Tests of [`super`] (deep.rs).

//! Two independent checks of every file: a parser written here from the layout document, and
//! Python's `OpenEXR` (the reference C++ library) through `tests/deep_read.py`.

use super::*;
use crate::testing::rect;
use miniz_oxide::inflate::decompress_to_vec_zlib;
use proptest::prelude::*;
use std::collections::HashMap;

/// What the test parser makes of a file.
#[derive(Debug)]
struct Parsed {
    attributes: HashMap<String, (String, Vec<u8>)>,
    image: DeepImage,
    /// Per chunk: packed table size, packed data size, unpacked data size.
    chunk_sizes: Vec<(usize, usize, usize)>,
}

struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> &'a [u8] {
        let s = &self.bytes[self.at..self.at + n];
        self.at += n;
        s
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take(8).try_into().unwrap())
    }
    fn cstr(&mut self) -> String {
        let end = self.bytes[self.at..].iter().position(|&b| b == 0).unwrap();
        let s = String::from_utf8(self.take(end).to_vec()).unwrap();
        self.at += 1;
        s
    }
}

fn i32s(b: &[u8]) -> Vec<i32> {
    b.chunks(4)
        .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// Undoes ZIPS: inflate, undo the predictor, interleave the halves.
fn unzips(packed: &[u8], unpacked: usize) -> Vec<u8> {
    if packed.len() == unpacked {
        return packed.to_vec();
    }
    let mut t = decompress_to_vec_zlib(packed).unwrap();
    assert_eq!(t.len(), unpacked);
    for i in 1..t.len() {
        t[i] = t[i - 1].wrapping_add(t[i]).wrapping_sub(128);
    }
    let half = unpacked.div_ceil(2);
    (0..unpacked)
        .map(|i| t[if i % 2 == 0 { i / 2 } else { half + i / 2 }])
        .collect()
}

fn parse(bytes: &[u8]) -> Parsed {
    let mut c = Cursor { bytes, at: 0 };
    assert_eq!(c.take(4), [0x76, 0x2f, 0x31, 0x01]);
    assert_eq!(c.i32(), 0x802);
    let mut attributes = HashMap::new();
    let mut names = Vec::new();
    loop {
        let name = c.cstr();
        if name.is_empty() {
            break;
        }
        let kind = c.cstr();
        let size = c.i32() as usize;
        names.push(name.clone());
        attributes.insert(name, (kind, c.take(size).to_vec()));
    }
    let mut sorted = names.clone();
    sorted.sort();
    assert_eq!(names, sorted, "attributes are sorted");
    let attr = |n: &str, kind: &str| {
        let (k, v) = &attributes[n];
        assert_eq!(k, kind, "{n}");
        v.clone()
    };
    // Channels: A, B, G, R, Z, ZBack, all FLOAT, sampling 1.
    let ch = attr("channels", "chlist");
    let mut cc = Cursor { bytes: &ch, at: 0 };
    for expected in ["A", "B", "G", "R", "Z", "ZBack"] {
        assert_eq!(cc.cstr(), expected);
        assert_eq!(cc.i32(), 2);
        assert_eq!(cc.take(4), [0, 0, 0, 0]);
        assert_eq!((cc.i32(), cc.i32()), (1, 1));
    }
    assert_eq!(cc.take(1), [0]);
    assert_eq!(cc.at, ch.len());
    assert_eq!(attr("type", "string"), b"deepscanline");
    assert_eq!(i32s(&attr("version", "int")), [1]);
    assert_eq!(attr("lineOrder", "lineOrder"), [0]);
    assert_eq!(attr("pixelAspectRatio", "float"), 1.0f32.to_le_bytes());
    assert_eq!(attr("screenWindowWidth", "float"), 1.0f32.to_le_bytes());
    assert_eq!(attr("screenWindowCenter", "v2f"), [0; 8]);
    assert!(!attr("name", "string").is_empty());
    let compression = attr("compression", "compression")[0];
    assert!(compression == 0 || compression == 2);
    let dw = i32s(&attr("dataWindow", "box2i"));
    let disp = i32s(&attr("displayWindow", "box2i"));
    assert_eq!((disp[0], disp[1]), (0, 0));
    let (w, h) = ((dw[2] - dw[0] + 1) as usize, (dw[3] - dw[1] + 1) as usize);
    let chunks = i32s(&attr("chunkCount", "int"))[0] as usize;
    assert_eq!(chunks, h);
    let max_samples = i32s(&attr("maxSamplesPerPixel", "int"))[0] as usize;

    let offsets: Vec<u64> = (0..chunks).map(|_| c.u64()).collect();
    let mut pixels = Vec::new();
    let mut chunk_sizes = Vec::new();
    for (line, &offset) in offsets.iter().enumerate() {
        assert_eq!(offset as usize, c.at, "chunks are contiguous, in order");
        assert_eq!(c.i32(), dw[1] + line as i32);
        let (table_size, data_size, unpacked) = (c.u64() as usize, c.u64() as usize, c.u64() as usize);
        chunk_sizes.push((table_size, data_size, unpacked));
        if compression == 0 {
            assert_eq!((table_size, data_size), (4 * w, unpacked));
        }
        let table = i32s(&unzips(c.take(table_size), 4 * w));
        let data = unzips(c.take(data_size), unpacked);
        let total = *table.last().unwrap() as usize;
        assert_eq!(unpacked, total * 6 * 4);
        let values: Vec<f32> = data
            .chunks(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        let mut start = 0;
        for &end in &table {
            let end = end as usize;
            assert!(end >= start && end - start <= max_samples);
            let at = |ch: usize, i: usize| values[ch * total + i];
            pixels.push(
                (start..end)
                    .map(|i| DeepSample {
                        a: at(0, i),
                        b: at(1, i),
                        g: at(2, i),
                        r: at(3, i),
                        z: at(4, i),
                        z_back: at(5, i),
                    })
                    .collect(),
            );
            start = end;
        }
    }
    assert_eq!(c.at, bytes.len(), "nothing after the last chunk");
    let image = DeepImage {
        width: (disp[2] + 1) as u32,
        height: (disp[3] + 1) as u32,
        data_window: rect(dw[0] as u32, (dw[2] + 1) as u32, dw[1] as u32, (dw[3] + 1) as u32),
        pixels,
    };
    Parsed {
        attributes,
        image,
        chunk_sizes,
    }
}

/// 0–3 samples per pixel, values depending on the position.
fn sample_image(width: u32, height: u32, dw: PixelRect) -> DeepImage {
    let mut pixels = Vec::new();
    for y in dw.y0..dw.y1 {
        for x in dw.x0..dw.x1 {
            let n = (x + 2 * y) % 4;
            pixels.push(
                (0..n)
                    .map(|i| {
                        let z = 1.0 + x as f32 * 0.5 + y as f32 * 0.25 + i as f32;
                        DeepSample {
                            z,
                            z_back: z + 0.125 * i as f32,
                            r: 0.1 * x as f32,
                            g: 0.01 * y as f32,
                            b: 1.0 / (1.0 + i as f32),
                            a: 0.5 + 0.1 * i as f32,
                        }
                    })
                    .collect(),
            );
        }
    }
    DeepImage {
        width,
        height,
        data_window: dw,
        pixels,
    }
}

/// Two pixels, one sample: too small for zlib to win.
fn tiny_image() -> DeepImage {
    let s = DeepSample {
        z: 2.0,
        z_back: 3.0,
        r: 0.25,
        g: 0.5,
        b: 0.75,
        a: 1.0,
    };
    DeepImage {
        width: 4,
        height: 4,
        data_window: rect(1, 3, 3, 4),
        pixels: vec![vec![s], Vec::new()],
    }
}

fn roundtrip(image: &DeepImage, compression: DeepCompression) -> Parsed {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("deep.exr");
    write_deep_exr(&path, image, compression).unwrap();
    assert!(crate::atomic::temporaries(&path).is_empty());
    parse(&std::fs::read(&path).unwrap())
}

#[test]
fn deep_files_parse_back_exactly_with_both_compressions() {
    let dw = rect(3, 40, 2, 9);
    let image = sample_image(48, 12, dw);
    for compression in [DeepCompression::None, DeepCompression::Zips] {
        let parsed = roundtrip(&image, compression);
        assert_eq!(parsed.image, image, "{compression:?}");
        assert_eq!(
            parsed.attributes["compression"].1,
            [compression_code(compression)]
        );
        assert_eq!(parsed.attributes["maxSamplesPerPixel"].1, 3i32.to_le_bytes());
    }
}

#[test]
fn deep_zips_actually_compresses_and_falls_back_to_raw() {
    // A large smooth image shrinks...
    let dw = rect(0, 300, 0, 4);
    let image = sample_image(300, 4, dw);
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    write_deep_exr(&a, &image, DeepCompression::None).unwrap();
    write_deep_exr(&b, &image, DeepCompression::Zips).unwrap();
    let (na, nb) = (
        std::fs::metadata(&a).unwrap().len(),
        std::fs::metadata(&b).unwrap().len(),
    );
    assert!(nb * 2 < na, "{nb} vs {na}");
    for &(table, data, unpacked) in &parse(&std::fs::read(&b).unwrap()).chunk_sizes {
        assert!(table < 4 * 300 && data < unpacked, "{table} {data} {unpacked}");
    }
    // ...while a two-pixel line does not, and is stored raw.
    let tiny = tiny_image();
    for (table, data, unpacked) in roundtrip(&tiny, DeepCompression::Zips).chunk_sizes {
        assert_eq!((table, data), (8, unpacked));
    }
    assert_eq!(zips(vec![7, 1, 200, 3]), [7, 1, 200, 3]);
    assert!(zips(Vec::new()).is_empty());
    // The packing itself, by hand: reorder [1, 2, 3, 4, 5] → [1, 3, 5, 2, 4], predictor →
    // [1, 130, 130, 125, 130], which zlib then compresses.
    let packed = compress_to_vec_zlib(&[1, 130, 130, 125, 130], ZLIB_LEVEL);
    assert_eq!(unzips(&packed, 5), [1, 2, 3, 4, 5]);
}

#[test]
fn deep_empty_lines_and_empty_images() {
    let dw = rect(0, 3, 0, 2);
    let image = DeepImage {
        width: 3,
        height: 2,
        data_window: dw,
        pixels: vec![Vec::new(); 6],
    };
    for compression in [DeepCompression::None, DeepCompression::Zips] {
        assert_eq!(roundtrip(&image, compression).image, image);
    }
}

#[test]
fn deep_inconsistent_images_are_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.exr");
    let good = sample_image(4, 4, rect(0, 4, 0, 4));
    let mut short = good.clone();
    short.pixels.pop();
    let mut empty = good.clone();
    empty.data_window = rect(2, 2, 0, 4);
    empty.pixels.clear();
    let mut inverted = good.clone();
    inverted.data_window = rect(3, 1, 0, 4);
    let mut no_format = good.clone();
    no_format.width = 0;
    let mut huge = good.clone();
    huge.data_window = rect(u32::MAX - 4, u32::MAX, 0, 4);
    for image in [short, empty, inverted, no_format, huge] {
        let err = write_deep_exr(&path, &image, DeepCompression::Zips).unwrap_err();
        assert!(matches!(err, OutputError::InvalidDeepImage { .. }), "{err}");
        assert!(err.to_string().contains("bad.exr"), "{err}");
    }
    let missing = dir.path().join("no/such/dir/deep.exr");
    let err = write_deep_exr(&missing, &good, DeepCompression::None).unwrap_err();
    assert!(err.to_string().contains(&missing.display().to_string()), "{err}");
    assert!(crate::atomic::temporaries(&missing).is_empty() && !path.exists());
}

/// Sample values per (x, y, channel).
type PythonSamples = HashMap<(u32, u32, String), Vec<f32>>;

/// Runs `tests/deep_read.py` on `path`: per pixel and channel, the sample values OpenEXR reads.
/// `None` when Python's OpenEXR is not installed (and not required).
fn read_with_python(path: &Path) -> Option<(String, PythonSamples)> {
    let stdout = crate::output::run_independent_reader("deep_read.py", path)?;
    let mut lines = stdout.lines();
    let header = lines.next().unwrap().to_string();
    let mut samples = HashMap::new();
    for line in lines {
        let mut t = line.split_whitespace();
        let x: u32 = t.next().unwrap().parse().unwrap();
        let y: u32 = t.next().unwrap().parse().unwrap();
        let ch = t.next().unwrap().to_string();
        let values = t.map(|v| v.parse::<f64>().unwrap() as f32).collect();
        samples.insert((x, y, ch), values);
    }
    Some((header, samples))
}

#[test]
fn deep_files_read_back_with_python_openexr() {
    let dir = tempfile::tempdir().unwrap();
    let small = rect(5, 21, 3, 11);
    let wide = rect(0, 300, 0, 3);
    let mut sparse = sample_image(7, 5, rect(0, 7, 0, 5));
    for (i, p) in sparse.pixels.iter_mut().enumerate() {
        if i / 7 != 2 {
            p.clear(); // only row 2 has samples
        }
    }
    let images = [
        (
            "small",
            sample_image(24, 16, small),
            "deepscanline 5 3 20 10 0 0 23 15 A B G R Z ZBack",
        ),
        (
            "wide",
            sample_image(300, 3, wide),
            "deepscanline 0 0 299 2 0 0 299 2 A B G R Z ZBack",
        ),
        ("sparse", sparse, "deepscanline 0 0 6 4 0 0 6 4 A B G R Z ZBack"),
        (
            "tiny",
            tiny_image(),
            "deepscanline 1 3 2 3 0 0 3 3 A B G R Z ZBack",
        ),
    ];
    for (label, image, expected_header) in &images {
        for compression in [DeepCompression::None, DeepCompression::Zips] {
            let path = dir.path().join(format!("{label}-{compression:?}.exr"));
            write_deep_exr(&path, image, compression).unwrap();
            let Some((header, samples)) = read_with_python(&path) else {
                return;
            };
            assert_eq!(&header, expected_header);
            let dw = image.data_window;
            let mut i = 0;
            for y in dw.y0..dw.y1 {
                for x in dw.x0..dw.x1 {
                    let pixel = &image.pixels[i];
                    i += 1;
                    for (name, component) in CHANNELS {
                        let expected: Vec<f32> = pixel.iter().map(component).collect();
                        let got = &samples[&(x, y, name.to_string())];
                        assert_eq!(got, &expected, "{label} {compression:?} ({x}, {y}) {name}");
                    }
                }
            }
            assert_eq!(samples.len(), dw.len() * 6);
        }
    }
}

fn arb_image() -> impl Strategy<Value = DeepImage> {
    (0u32..4, 1u32..6, 0u32..3, 1u32..5).prop_flat_map(|(x0, w, y0, h)| {
        let sample =
            (any::<f32>(), -1e6f32..1e6, any::<[f32; 4]>()).prop_map(|(z, dz, [r, g, b, a])| DeepSample {
                z,
                z_back: z + dz,
                r,
                g,
                b,
                a,
            });
        proptest::collection::vec(proptest::collection::vec(sample, 0..5), (w * h) as usize).prop_map(
            move |pixels| DeepImage {
                width: x0 + w + 1,
                height: y0 + h,
                data_window: PixelRect {
                    x0,
                    x1: x0 + w,
                    y0,
                    y1: y0 + h,
                },
                pixels,
            },
        )
    })
}

/// Bit patterns, so that NaNs compare too.
fn bits(image: &DeepImage) -> Vec<Vec<[u32; 6]>> {
    image
        .pixels
        .iter()
        .map(|p| {
            p.iter()
                .map(|s| [s.z, s.z_back, s.r, s.g, s.b, s.a].map(f32::to_bits))
                .collect()
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn deep_random_images_roundtrip(image in arb_image(), zip in any::<bool>()) {
        let compression = if zip { DeepCompression::Zips } else { DeepCompression::None };
        let parsed = roundtrip(&image, compression).image;
        prop_assert_eq!(
            (parsed.width, parsed.height, parsed.data_window),
            (image.width, image.height, image.data_window)
        );
        prop_assert_eq!(bits(&parsed), bits(&image));
    }
}
