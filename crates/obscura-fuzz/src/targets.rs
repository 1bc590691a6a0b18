//! The fuzz targets: each reads one input as its parser would see it from a user, and goes on as far
//! as the command would before rendering (a RIB's camera is built, a calibration's projection
//! created, `--param` arguments checked against a projection's table).

use std::ffi::CString;
use std::os::raw::c_char;
use std::path::Path;

use obscura_calibration::files::{FileFormat, parse_as};
use obscura_host::{CameraDesc, CameraStage};
use obscura_plugins::builtin_registry;
use obscura_plugins::decode::{decl_from_raw, value_from_raw};
use obscura_sdk::abi::{RawParamDecl, RawPropertyValue};
use obscura_sdk::{Format, ParamList};

use crate::params;

/// What a target reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Target {
    /// ASCII RIB, through the reader and the camera stage.
    Rib,
    /// A RIB file's bytes as the CLI reads them: ASCII, binary (RISpec encoded requests), gzip or
    /// Latin-1, through the reader's file checks and the camera stage.
    RibBytes,
    /// glTF 2.0 JSON (`.gltf`) or binary (`.glb`), by the first byte.
    Gltf,
    /// Wavefront OBJ.
    Obj,
    /// COLMAP `cameras.txt`.
    Colmap,
    /// OpenCV FileStorage YAML/JSON.
    Opencv,
    /// Kalibr `camchain.yaml`.
    Kalibr,
    /// OCamCalib `calib_results.txt`.
    Ocamcalib,
    /// `--param` arguments, one a line after a first line choosing the projection.
    Param,
    /// The plugin ABI's parameter-table rows and property answers, built from the bytes.
    Abi,
}

/// Every target, in the order the runner reports them.
pub const TARGETS: [Target; 10] = [
    Target::Rib,
    Target::RibBytes,
    Target::Gltf,
    Target::Obj,
    Target::Colmap,
    Target::Opencv,
    Target::Kalibr,
    Target::Ocamcalib,
    Target::Param,
    Target::Abi,
];

impl Target {
    /// The name on the command line and of the corpus directory.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Target::Rib => "rib",
            Target::RibBytes => "rib-bytes",
            Target::Gltf => "gltf",
            Target::Obj => "obj",
            Target::Colmap => "colmap",
            Target::Opencv => "opencv",
            Target::Kalibr => "kalibr",
            Target::Ocamcalib => "ocamcalib",
            Target::Param => "param",
            Target::Abi => "abi",
        }
    }

    /// The target of a name.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Target> {
        TARGETS.into_iter().find(|t| t.name() == name)
    }

    /// True when the target reads binary inputs, which the mutator edits with binary tokens too.
    #[must_use]
    pub fn binary(self) -> bool {
        matches!(self, Target::RibBytes)
    }

    /// Tokens the mutator inserts.
    #[must_use]
    pub fn dictionary(self) -> &'static [&'static str] {
        match self {
            Target::Rib | Target::RibBytes => &[
                "WorldBegin",
                "WorldEnd",
                "AttributeBegin",
                "AttributeEnd",
                "TransformBegin",
                "TransformEnd",
                "Format",
                "ScreenWindow",
                "CropWindow",
                "Clipping",
                "Shutter",
                "Projection",
                "Display",
                "Hider",
                "PixelFilter",
                "Translate",
                "Rotate",
                "Scale",
                "ConcatTransform",
                "Transform",
                "Identity",
                "MotionBegin",
                "MotionEnd",
                "Sphere",
                "Cylinder",
                "Cone",
                "Disk",
                "Torus",
                "Paraboloid",
                "Hyperboloid",
                "Polygon",
                "PointsPolygons",
                "PointsGeneralPolygons",
                "SubdivisionMesh",
                "Patch",
                "NuPatch",
                "Light",
                "Bxdf",
                "Attribute",
                "Option",
                "Camera",
                "ReadArchive",
                "ObjectBegin",
                "ObjectEnd",
                "ObjectInstance",
                "\"P\"",
                "\"N\"",
                "\"float fov\"",
                "\"color lightColor\"",
                "\"float intensity\"",
                "\"PxrPerspective\"",
                "\"PxrCamera\"",
                "\"Fisheye\"",
                "\"PxrDomeLight\"",
                "\"PxrRectLight\"",
                "\"catmull-clark\"",
                "[",
                "]",
                "\"",
                "#",
                "\n",
                "version 3.04",
            ],
            Target::Gltf => &[
                "{",
                "}",
                "[",
                "]",
                ",",
                ":",
                "\"nodes\"",
                "\"meshes\"",
                "\"accessors\"",
                "\"bufferViews\"",
                "\"buffers\"",
                "\"byteLength\"",
                "\"byteOffset\"",
                "\"byteStride\"",
                "\"count\"",
                "\"children\"",
                "\"matrix\"",
                "\"translation\"",
                "\"rotation\"",
                "\"scale\"",
                "\"camera\"",
                "\"cameras\"",
                "\"perspective\"",
                "\"orthographic\"",
                "\"yfov\"",
                "\"znear\"",
                "\"zfar\"",
                "\"indices\"",
                "\"POSITION\"",
                "\"NORMAL\"",
                "\"componentType\"",
                "5126",
                "5123",
                "5125",
                "\"VEC3\"",
                "\"SCALAR\"",
                "\"extensions\"",
                "\"KHR_lights_punctual\"",
                "\"materials\"",
                "\"version\"",
                "\"2.0\"",
                "\"mode\"",
                "null",
                "true",
                "-1",
            ],
            Target::Obj => &[
                "v", "vt", "vn", "f", "l", "o", "g", "s", "usemtl", "mtllib", "#", "/", "//", "-1", "\n",
                "\\",
            ],
            Target::Colmap => &[
                "SIMPLE_PINHOLE",
                "PINHOLE",
                "SIMPLE_RADIAL",
                "RADIAL",
                "OPENCV",
                "OPENCV_FISHEYE",
                "FULL_OPENCV",
                "FOV",
                "SIMPLE_RADIAL_FISHEYE",
                "RADIAL_FISHEYE",
                "THIN_PRISM_FISHEYE",
                "RAD_TAN_THIN_PRISM_FISHEYE",
                "SIMPLE_DIVISION",
                "DIVISION",
                "SIMPLE_FISHEYE",
                "FISHEYE",
                "#",
                "\n",
            ],
            Target::Opencv | Target::Kalibr => &[
                "%YAML:1.0",
                "---",
                "!!opencv-matrix",
                "rows:",
                "cols:",
                "dt:",
                "d",
                "data:",
                "[",
                "]",
                "{",
                "}",
                ",",
                ":",
                "camera_matrix:",
                "distortion_coefficients:",
                "image_width:",
                "image_height:",
                "fisheye_model:",
                "cam0:",
                "cam1:",
                "camera_model:",
                "pinhole",
                "omni",
                "ds",
                "eucm",
                "intrinsics:",
                "distortion_model:",
                "radtan",
                "equidistant",
                "fov",
                "distortion_coeffs:",
                "resolution:",
                "- ",
                "\n",
                "  ",
                "&a",
                "*a",
                "<<:",
            ],
            Target::Ocamcalib => &["#", "\n", " ", "-", "e-05", "e+02"],
            Target::Param => &[
                "float",
                "int",
                "string",
                "color",
                "point",
                "vector",
                "normal",
                "matrix",
                "float[3]",
                "fov",
                "fStop",
                "focalLength",
                "focalDistance",
                "mapping",
                "=",
                "\"",
                "[",
                "]",
                ",",
                "\n",
            ],
            Target::Abi => &[],
        }
    }

    /// Reads `input`. `Ok` when it was accepted, `Err` with the message when refused; a panic
    /// propagates (the runner catches it). `scratch` is a directory for targets that read files.
    ///
    /// # Errors
    /// The parser's message for an input it refuses.
    pub fn run(self, input: &[u8], scratch: &Path) -> Result<(), String> {
        match self {
            Target::Rib => rib(input),
            Target::RibBytes => rib_bytes(input),
            Target::Gltf => {
                let name = if input.starts_with(b"glTF") {
                    "fuzz.glb"
                } else {
                    "fuzz.gltf"
                };
                scene_file(input, &scratch.join(name))
            }
            Target::Obj => scene_file(input, &scratch.join("fuzz.obj")),
            Target::Colmap => calibration(FileFormat::Colmap, input),
            Target::Opencv => calibration(FileFormat::OpenCv, input),
            Target::Kalibr => calibration(FileFormat::Kalibr, input),
            Target::Ocamcalib => calibration(FileFormat::OCamCalib, input),
            Target::Param => param(input),
            Target::Abi => abi(input),
        }
    }
}

/// The most pixels for which a fuzzed scene's camera stage is built (its allocations scale with it).
const MAX_STAGE_PIXELS: u64 = 1 << 16;

fn text(input: &[u8]) -> Result<&str, String> {
    std::str::from_utf8(input).map_err(|e| e.to_string())
}

fn rib(input: &[u8]) -> Result<(), String> {
    let text = text(input)?;
    let scene = obscura_scene::rib::parse_str(text, "fuzz.rib", Path::new("/nonexistent-obscura-fuzz"))
        .map_err(|e| e.to_string())?;
    stage(&scene.projection, &scene.projection_params, &scene.camera)
}

fn rib_bytes(input: &[u8]) -> Result<(), String> {
    let frames = obscura_scene::rib::parse_file_bytes_frames(
        input.to_vec(),
        "fuzz.rib",
        Path::new("/nonexistent-obscura-fuzz"),
    )
    .map_err(|e| e.to_string())?;
    let Some(last) = frames.last() else {
        return Err("no image".into());
    };
    let scene = &last.scene;
    stage(&scene.projection, &scene.projection_params, &scene.camera)
}

/// Builds the camera stage a render would, for small images.
fn stage(projection: &str, params: &ParamList, camera: &CameraDesc) -> Result<(), String> {
    let f = camera.format;
    if u64::from(f.width) * u64::from(f.height) > MAX_STAGE_PIXELS {
        return Ok(());
    }
    let mut registry = builtin_registry();
    CameraStage::new(&mut registry, projection, params, camera)
        .map(drop)
        .map_err(|e| e.to_string())
}

fn scene_file(input: &[u8], path: &Path) -> Result<(), String> {
    std::fs::write(path, input).map_err(|e| format!("scratch file: {e}"))?;
    let scene = obscura_render::staging::load(path, CameraDesc::new(Format::new(64, 48)))
        .map_err(|e| e.to_string())?;
    stage(&scene.projection, &scene.projection_params, &scene.camera)
}

fn calibration(format: FileFormat, input: &[u8]) -> Result<(), String> {
    let text = text(input)?;
    let c = parse_as(format, text, "fuzz.calib", None).map_err(|e| e.to_string())?;
    let params = c.param_list().map_err(|e| e.to_string())?;
    let camera = CameraDesc::new(Format::new(c.width.clamp(1, 64), c.height.clamp(1, 64)));
    stage(obscura_calibration::files::PROJECTION, &params, &camera)
}

fn param(input: &[u8]) -> Result<(), String> {
    let text = text(input)?;
    let mut lines = text.lines();
    let registry = builtin_registry();
    let names = registry.names();
    // The first line names the projection, or (mutated) picks one by its bytes.
    let first = lines.next().unwrap_or_default();
    let name = match names.iter().find(|n| *n == first.trim()) {
        Some(n) => n,
        None => &names[first.bytes().map(usize::from).sum::<usize>() % names.len()],
    };
    let factory = registry.find(name).map_err(|e| e.to_string())?;
    let args: Vec<String> = lines.map(str::to_string).collect();
    let list = params::param_list(&args, factory.name(), factory.param_table()).map_err(|e| e.to_string())?;
    stage(name, &list, &CameraDesc::new(Format::new(16, 12)))
}

/// Reads a little-endian value of `N` bytes at `*at`, zero past the end.
fn take<const N: usize>(input: &[u8], at: &mut usize) -> [u8; N] {
    let mut out = [0u8; N];
    for (k, b) in out.iter_mut().enumerate() {
        *b = input.get(*at + k).copied().unwrap_or(0);
    }
    *at += N;
    out
}

/// `p`, or null when the low bit of `flag` is set.
fn pick<T>(flag: u8, p: *const T) -> *const T {
    if flag & 1 == 1 { std::ptr::null() } else { p }
}

/// A C string of the next `len` bytes (cut at the first NUL).
fn c_string(input: &[u8], at: &mut usize, len: usize) -> CString {
    let end = (*at + len).min(input.len());
    let bytes: Vec<u8> = input
        .get(*at..end)
        .unwrap_or_default()
        .iter()
        .copied()
        .take_while(|&b| b != 0)
        .collect();
    *at = end;
    CString::new(bytes).unwrap_or_default()
}

/// One table row and one property answer, every field from the bytes. Every pointer is made valid
/// for the counts the row gives (a plugin that lied about them is outside what a host can check);
/// what the decoder must survive is any combination of values.
fn abi(input: &[u8]) -> Result<(), String> {
    let mut at = 0;
    let value = RawPropertyValue {
        kind: i32::from_le_bytes(take(input, &mut at)) % 4,
        enum_value: i32::from_le_bytes(take(input, &mut at)),
        float_value: f32::from_le_bytes(take(input, &mut at)),
    };
    let value_result = value_from_raw(value).map(drop).map_err(|e| e.to_string());
    let [name_len, doc_len, count, choices] = take::<4>(input, &mut at).map(usize::from);
    let ty = i32::from(i8::from_le_bytes(take(input, &mut at)));
    let array_len = i32::from(i8::from_le_bytes(take(input, &mut at)));
    let range_flags = u32::from(take::<1>(input, &mut at)[0]);
    let range_min = f64::from_le_bytes(take(input, &mut at));
    let range_max = f64::from_le_bytes(take(input, &mut at));
    let name = c_string(input, &mut at, name_len % 24);
    let doc = c_string(input, &mut at, doc_len % 24);
    let count = count % 20;
    let floats: Vec<f32> = (0..count)
        .map(|_| f32::from_le_bytes(take(input, &mut at)))
        .collect();
    let ints: Vec<i32> = (0..count)
        .map(|_| i32::from_le_bytes(take(input, &mut at)))
        .collect();
    let strings: Vec<CString> = (0..count).map(|_| c_string(input, &mut at, 6)).collect();
    let string_ptrs: Vec<*const c_char> = strings.iter().map(|s| s.as_ptr()).collect();
    let choice_strings: Vec<CString> = (0..choices % 6).map(|_| c_string(input, &mut at, 6)).collect();
    let choice_ptrs: Vec<*const c_char> = choice_strings.iter().map(|s| s.as_ptr()).collect();
    let nulls = take::<1>(input, &mut at)[0];
    let decl = RawParamDecl {
        name: pick(nulls, name.as_ptr()),
        doc: pick(nulls >> 1, doc.as_ptr()),
        default_floats: pick(nulls >> 2, floats.as_ptr()),
        default_ints: pick(nulls >> 3, ints.as_ptr()),
        default_strings: pick(nulls >> 4, string_ptrs.as_ptr()),
        default_count: count,
        choices: pick(nulls >> 5, choice_ptrs.as_ptr()),
        num_choices: choice_ptrs.len(),
        range_min,
        range_max,
        ty,
        array_len,
        range_flags,
    };
    // SAFETY: every non-null pointer in `decl` points into a live vector (or CString) of this frame
    // holding at least the count the row gives (`default_count` floats, ints and NUL-terminated
    // strings; `num_choices` strings), and the strings are NUL-terminated CStrings.
    let decl_result = unsafe { decl_from_raw(&decl) };
    value_result?;
    decl_result.map(drop).map_err(|e| e.to_string())
}
