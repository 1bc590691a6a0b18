//! The catalogue of bad inputs (issue 16): every family a user can get wrong — sizes and limits,
//! output paths, scene files (RIB, glTF, OBJ), calibration files, `--param`, command-line options,
//! plugins, ST-maps — each with the fragment of the message it must get. Each case runs the real
//! binary in a fresh directory and must end with that message (an error: exit status 1; a warning:
//! exit status 0), within 30 s, without a panic or a signal.

mod support;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use support::text;

/// What a case must end with.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Want {
    /// Exit status 1 and the fragment on stderr.
    Error,
    /// Exit status 0 and the fragment on stderr.
    Warning,
    /// A command line clap refuses: exit status 2 and the fragment on stderr.
    Usage,
}

type Env = Option<(&'static str, &'static str)>;

/// An error.
const E: (Env, Want) = (None, Want::Error);
/// A warning; the command goes on.
const W: (Env, Want) = (None, Want::Warning);
/// A command line refused before it runs.
const U: (Env, Want) = (None, Want::Usage);
/// An error under a 1 GiB memory limit (the machine's own memory does not matter).
const M: (Env, Want) = (Some(("OBSCURA_MEMORY_LIMIT", "1G")), Want::Error);

type Case = (
    &'static str,
    &'static [&'static str],
    &'static [(&'static str, &'static str)],
    (Env, Want),
    &'static str,
);

/// A sphere diced into 4.3 M triangles (an eighth of a pixel each at 160×120).
const FINE_SPHERE: &str = "Format 160 120 1\nProjection \"perspective\" \"fov\" [40]\nWorldBegin\nTranslate 0 0 5\n\
Attribute \"dice\" \"float micropolygonlength\" [0.125]\nSphere 1 -1 1 360\nWorldEnd\n";

/// A triangle 10^300 units away: its translation does not fit an f32.
const GLTF_FAR: &str = r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0,1]}],
"nodes":[{"mesh":0,"translation":[1e300,0,0]},{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
"bufferViews":[{"buffer":0,"byteLength":36}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}]}"#;

/// A primitive whose POSITION names accessor 5 of 1.
const GLTF_BAD_ACCESSOR: &str = r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":5}}]}],
"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
"bufferViews":[{"buffer":0,"byteLength":36}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}]}"#;

/// A buffer in a file that is not there.
const GLTF_MISSING_BUFFER: &str = r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
"buffers":[{"byteLength":36,"uri":"missing.bin"}],
"bufferViews":[{"buffer":0,"byteLength":36}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}]}"#;

/// OCamCalib's calib_results.txt with pol's a0 = 0 (line 3).
const OCAM_BAD_A0: &str = "#polynomial coefficients for the DIRECT mapping function\n\n\
5 0.000000e+00 0.000000e+00 1.600000e-03 1.200000e-07 2.500000e-09 \n\n\
#polynomial coefficients for the inverse mapping function\n\n\
13 324.287521 228.918471 39.736762 33.573213 18.473399 8.572804 5.223985 3.145349 1.636333 0.974980 0.505832 0.150800 0.018392 \n\n\
#center\n\n240.300000 320.700000\n\n#affine parameters\n\n1.000165 0.000115 -0.000106\n\n#image size\n\n480 640\n";

/// OCamCalib's calib_results.txt whose pol length (6) disagrees with its line (5 coefficients).
const OCAM_BAD_LENGTH: &str = "#polynomial coefficients for the DIRECT mapping function\n\n\
6 -2.000000e+02 0.000000e+00 1.600000e-03 1.200000e-07 2.500000e-09 \n\n\
#polynomial coefficients for the inverse mapping function\n\n\
13 324.287521 228.918471 39.736762 33.573213 18.473399 8.572804 5.223985 3.145349 1.636333 0.974980 0.505832 0.150800 0.018392 \n\n\
#center\n\n240.300000 320.700000\n\n#affine parameters\n\n1.000165 0.000115 -0.000106\n\n#image size\n\n480 640\n";

/// An OpenCV calibration with a skewed camera matrix.
const OPENCV_SKEW: &str = "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 500., 3., 320., 0., 500., 240., 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n";

/// The catalogue: name, arguments, files to create (path, contents), expectation, message fragment.
const CATALOGUE: &[Case] = &[
    // ----- limits (issue 16, point 1) -----
    (
        "render --format 100000x100000",
        &["render", "--format", "100000x100000"],
        &[],
        E,
        "--format: an image of 100000x100000 pixels is too large: expected each side in 1..=65536",
    ),
    (
        "rays --format 4000000000x1",
        &["rays", "--format", "4000000000x1"],
        &[],
        E,
        "--format: an image of 4000000000x1 pixels is too large",
    ),
    (
        "RIB Format 100000 100000",
        &["render", "s.rib"],
        &[("s.rib", "Format 100000 100000 1\nWorldBegin\nWorldEnd\n")],
        E,
        "s.rib: Format: an image of 100000x100000 pixels is too large",
    ),
    (
        "calibration image size 100000x100000",
        &["rays", "--calibration", "c.txt"],
        &[("c.txt", "1 PINHOLE 100000 100000 500 500 50000 50000\n")],
        E,
        "c.txt: the calibration's image size: an image of 100000x100000 pixels is too large",
    ),
    (
        "render 20000x20000 over the memory limit",
        &["render", "--format", "20000x20000", "-o", "big.exr"],
        &[],
        M,
        "a 20000x20000 render with 14 channels needs about 155.0 GiB of memory, more than the 1.0 GiB available (OBSCURA_MEMORY_LIMIT=1G)",
    ),
    (
        "a scene that dices into more triangles than the memory limit holds",
        &["render", "s.rib"],
        &[("s.rib", FINE_SPHERE)],
        M,
        "s.rib:6: this primitive dices into 4289040 triangles, which the scene cannot hold: 0 are diced \
         already and the budget is 1789569, what 1.0 GiB of memory holds at 450 bytes a triangle \
         (OBSCURA_MEMORY_LIMIT=1G)",
    ),
    (
        "rays with sample layers over the memory limit",
        &["rays", "--format", "8000x8000", "--samples", "16"],
        &[],
        M,
        "a 8000x8000 ray map with 16 sample layer(s) needs about",
    ),
    (
        "stmap over the memory limit",
        &[
            "stmap",
            "--from",
            "PxrPerspective",
            "--to",
            "PxrPerspective",
            "--format",
            "60000x16000",
        ],
        &[],
        M,
        "a 60000x16000 ST-map needs about",
    ),
    (
        "a deep render over the memory limit",
        &["render", "d.rib"],
        &[(
            "d.rib",
            "Format 8000 8000 1\nHider \"raytrace\" \"int maxsamples\" [64]\nDisplay \"d.exr\" \"deepexr\" \"rgba\"\nWorldBegin\nWorldEnd\n",
        )],
        M,
        "and 64 deep samples per pixel needs about",
    ),
    (
        "--threads 100000",
        &["render", "--threads", "100000"],
        &[],
        E,
        "--threads 100000: expected 1..=1024 worker threads",
    ),
    (
        "--threads 0",
        &["render", "--threads", "0"],
        &[],
        E,
        "--threads 0: expected 1..=1024 worker threads",
    ),
    (
        "--spp 0",
        &["render", "--spp", "0"],
        &[],
        U,
        "invalid value '0' for '--spp <SPP>'",
    ),
    (
        "Hider maxsamples beyond the sampler",
        &["render", "h.rib"],
        &[(
            "h.rib",
            "Format 8 6 1\nHider \"raytrace\" \"int maxsamples\" [100000]\nWorldBegin\nWorldEnd\n",
        )],
        E,
        "the scene's Hider \"int maxsamples\": 100000 samples per pixel: expected 1..=65536",
    ),
    (
        "-o x.txt",
        &["render", "-o", "x.txt"],
        &[],
        E,
        "output x.txt: unknown extension \".txt\": expected .exr",
    ),
    (
        "-o x",
        &["render", "-o", "x"],
        &[],
        E,
        "output x: the file name has no extension: expected .exr",
    ),
    (
        "-o x.jpg",
        &["render", "-o", "x.jpg"],
        &[],
        E,
        "unknown extension \".jpg\": expected .exr",
    ),
    (
        // `render -o x.tif` writes TIFF (RenderMan's file driver); the rays are EXR only.
        "rays -o x.tif",
        &["rays", "-o", "x.tif", "--format", "4x4"],
        &[],
        E,
        "output x.tif: unknown extension \".tif\": expected .exr",
    ),
    (
        "-o in a missing directory",
        &["render", "-o", "missing/x.exr"],
        &[],
        E,
        "output missing/x.exr: the directory missing does not exist",
    ),
    (
        "-o a directory",
        &["render", "-o", "dir.exr"],
        &[("dir.exr/keep", "")],
        E,
        "output dir.exr: is a directory",
    ),
    (
        "-o under a file",
        &["render", "-o", "f/x.exr"],
        &[("f", "")],
        E,
        "output f/x.exr: f is not a directory",
    ),
    (
        "RIB Display with an unknown extension",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nDisplay \"out.txt\" \"openexr\" \"rgba\"\nWorldBegin\nWorldEnd\n",
        )],
        E,
        "output out.txt: unknown extension \".txt\": expected .exr",
    ),
    (
        "RIB Display in a missing directory",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nDisplay \"nowhere/out.exr\" \"openexr\" \"rgba\"\nWorldBegin\nWorldEnd\n",
        )],
        E,
        "output nowhere/out.exr: the directory nowhere does not exist",
    ),
    (
        "rays -o x.png",
        &["rays", "-o", "x.png"],
        &[],
        E,
        "output x.png: unknown extension \".png\": expected .exr",
    ),
    (
        "stmap -o x.txt",
        &[
            "stmap",
            "--from",
            "PxrPerspective",
            "--to",
            "PxrPerspective",
            "-o",
            "x.txt",
        ],
        &[],
        E,
        "output x.txt: unknown extension \".txt\"",
    ),
    (
        "OBSCURA_MEMORY_LIMIT not a size",
        &["rays", "--format", "8x6"],
        &[],
        (Some(("OBSCURA_MEMORY_LIMIT", "lots")), Want::Error),
        "OBSCURA_MEMORY_LIMIT=lots: expected a number of bytes with an optional K, M, G or T suffix",
    ),
    // ----- nothing silent (point 3) -----
    (
        "negative light intensity",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nWorldBegin\nLight \"PxrDomeLight\" \"d\" \"float intensity\" [-5]\nWorldEnd\n",
        )],
        E,
        "s.rib:3: Light \"PxrDomeLight\": \"float intensity\" [-5]: expected a finite value >= 0",
    ),
    (
        "negative light colour",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nWorldBegin\nLight \"PxrRectLight\" \"r\" \"color lightColor\" [-5 1 1]\nWorldEnd\n",
        )],
        E,
        "s.rib:3: Light \"PxrRectLight\": \"color lightColor\" [-5 1 1]: expected finite components >= 0",
    ),
    (
        "light exposure out of range",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nWorldBegin\nLight \"PxrSphereLight\" \"s\" \"float exposure\" [1e9]\nWorldEnd\n",
        )],
        E,
        "\"float exposure\" [1000000000]: expected stops in [-64, 64]",
    ),
    (
        "-q keeps scene warnings",
        &["render", "s.rib", "-q", "--spp", "1"],
        &[(
            "s.rib",
            "Format 8 6 1\nDisplay \"q.exr\" \"openexr\" \"rgba\"\nWorldBegin\nFrobnicate 1 2\nWorldEnd\n",
        )],
        W,
        "warning: s.rib:4: unknown request Frobnicate, skipped",
    ),
    (
        "glTF translation 1e300",
        &["render", "t.gltf", "--format", "8x6", "--spp", "1"],
        &[("t.gltf", GLTF_FAR)],
        E,
        "t.gltf: node 0 mesh 0 primitive 0: the object-to-world transform at time 0 is not finite",
    ),
    (
        "glTF asset version 1.0",
        &["render", "v.gltf"],
        &[("v.gltf", "{\"asset\":{\"version\":\"1.0\"}}")],
        E,
        "asset.version is \"1.0\": expected a glTF 2.x file",
    ),
    (
        "glTF asset version 3.0",
        &["render", "v.gltf"],
        &[("v.gltf", "{\"asset\":{\"version\":\"3.0\"}}")],
        E,
        "asset.version is \"3.0\": expected a glTF 2.x file",
    ),
    (
        "glTF minVersion 2.1",
        &["render", "v.gltf"],
        &[(
            "v.gltf",
            "{\"asset\":{\"version\":\"2.0\",\"minVersion\":\"2.1\"}}",
        )],
        E,
        "asset.minVersion is \"2.1\": this reader reads glTF 2.0",
    ),
    (
        "OBJ statement zz 1 2",
        &["render", "z.obj", "--format", "8x6", "--spp", "1", "-o", "z.exr"],
        &[("z.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nzz 1 2\nf 1 2 3\n")],
        W,
        "warning: z.obj:4: unknown OBJ statement \"zz\", ignored",
    ),
    (
        "unterminated --param array",
        &["rays", "--param", "\"float fov\" [60"],
        &[],
        E,
        "--param '\"float fov\" [60': unterminated array: a '[' does not close (expected ']')",
    ),
    (
        "--param closing bracket without opening",
        &["rays", "--param", "\"float fov\" 60]"],
        &[],
        E,
        "unexpected ']' without an opening '['",
    ),
    (
        "--param value after the array",
        &["rays", "--param", "\"float fov\" [60] 70"],
        &[],
        E,
        "unexpected value after the closing ']'",
    ),
    (
        "--param unterminated string",
        &[
            "rays",
            "-p",
            "OmnidirectionalStereo",
            "--param",
            "\"string eye\" [\"left]",
        ],
        &[],
        E,
        "unterminated string: a '\"' does not close",
    ),
    (
        "PxrPerspective fov=1e-38",
        &["rays", "--param", "fov=1e-38"],
        &[],
        E,
        "parameter \"fov\" (at --param 'fov=1e-38') = 1e-38 is out of range: expected a value in [0.001, 180)",
    ),
    (
        "PxrPerspective fovEnd=1e-38",
        &["rays", "--param", "fovEnd=1e-38"],
        &[],
        E,
        "PxrPerspective: parameter \"fovEnd\" = 1e-38: expected 0 (no zoom) or a field of view of at least 0.001 degrees",
    ),
    (
        "PxrCamera fov=1e-38",
        &["rays", "-p", "PxrCamera", "--param", "fov=1e-38"],
        &[],
        E,
        "expected a value in [0.001, 180)",
    ),
    (
        "RIB Projection fov 1e-38",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nProjection \"PxrPerspective\" \"float fov\" [1e-38]\nWorldBegin\nWorldEnd\n",
        )],
        E,
        "expected a value in [0.001, 180)",
    ),
    (
        "ScreenWindow -2 1e32 -2 2",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nScreenWindow -2 1e32 -2 2\nWorldBegin\nWorldEnd\n",
        )],
        E,
        "ScreenWindow: expected finite left < right and bottom < top within [-1e6, 1e6], got -2.0 1e32 -2.0 2.0",
    ),
    (
        "rays --screen-window 1e32",
        &["rays", "--screen-window", "-1", "1e32", "-1", "1"],
        &[],
        E,
        "ScreenWindow: expected finite left < right and bottom < top within [-1e6, 1e6]",
    ),
    (
        "--plugin-path /nonexistent",
        &["--plugin-path", "/nonexistent-obscura", "plugins", "--names"],
        &[],
        W,
        "warning: --plugin-path /nonexistent-obscura: no such directory",
    ),
    (
        "--plugin-path a file",
        &["--plugin-path", "f", "plugins", "--names"],
        &[("f", "")],
        W,
        "warning: --plugin-path f: not a directory",
    ),
    (
        "OBSCURA_PLUGIN_PATH entry missing",
        &["plugins", "--names"],
        &[],
        (
            Some(("OBSCURA_PLUGIN_PATH", "/nonexistent-obscura-env")),
            Want::Warning,
        ),
        "warning: OBSCURA_PLUGIN_PATH entry /nonexistent-obscura-env: no such directory",
    ),
    // ----- messages (point 4) -----
    (
        "Scale 0 0 0 before WorldBegin",
        &["render", "s.rib"],
        &[("s.rib", "Format 8 6 1\nScale 0 0 0\nWorldBegin\nWorldEnd\n")],
        E,
        "the camera transform (world to camera) at shutter time 0 cannot be inverted: determinant 0, rows [0 0 0 0 | 0 0 0 0 | 0 0 0 0 | 0 0 0 1]; a Scale with a zero factor",
    ),
    (
        "Format 64 48 1e-45",
        &["render", "s.rib"],
        &[("s.rib", "Format 64 48 1e-45\nWorldBegin\nWorldEnd\n")],
        E,
        "Format: expected a positive width and height and a pixel aspect ratio in [1e-6, 1e6], got 64x48 with pixel aspect 1e-45",
    ),
    (
        "Format 64 48 1e-30 before rendering",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 64 48 1e-30\nDisplay \"f.exr\" \"openexr\" \"rgba\"\nWorldBegin\nWorldEnd\n",
        )],
        E,
        "got 64x48 with pixel aspect 1e-30",
    ),
    (
        "a frame aspect beyond the default window",
        &["rays", "--format", "1x65536", "--pixel-aspect", "0.000001"],
        &[],
        E,
        "Format 1x65536 with pixel aspect 1e-6: the frame aspect",
    ),
    (
        "rays --pixel-aspect 1e7",
        &["rays", "--pixel-aspect", "1e7"],
        &[],
        E,
        "a pixel aspect ratio in [1e-6, 1e6], got 640x480 with pixel aspect 10000000.0",
    ),
    (
        "OCamCalib a0 on its own line",
        &["rays", "--calibration", "r.txt"],
        &[("r.txt", OCAM_BAD_A0)],
        E,
        "r.txt:3: model OCAMCALIB: pol's a0 must be < 0",
    ),
    (
        "a bad output directory before rendering",
        &["render", "-o", "missing/x.exr", "--spp", "65536"],
        &[],
        E,
        "output missing/x.exr: the directory missing does not exist",
    ),
    // ----- RIB -----
    (
        "RIB unknown projection",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nProjection \"Nope\"\nWorldBegin\nWorldEnd\n",
        )],
        E,
        "s.rib:2: unknown projection \"Nope\"",
    ),
    (
        "RIB unknown projection parameter",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nProjection \"PxrPerspective\" \"float fvo\" [40]\nWorldBegin\nWorldEnd\n",
        )],
        E,
        "fvo",
    ),
    (
        "RIB unterminated string",
        &["render", "s.rib"],
        &[("s.rib", "Format 8 6 1\nDisplay \"x.exr\n")],
        E,
        "s.rib:",
    ),
    (
        "RIB Sphere without arguments",
        &["render", "s.rib"],
        &[("s.rib", "WorldBegin\nSphere\nWorldEnd\n")],
        E,
        "s.rib:2: Sphere",
    ),
    (
        "RIB polygon with a short P",
        &["render", "s.rib"],
        &[("s.rib", "WorldBegin\nPolygon \"P\" [0 0 0 1 0]\nWorldEnd\n")],
        E,
        "s.rib:2: Polygon",
    ),
    (
        "RIB PointsPolygons index out of range",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "WorldBegin\nPointsPolygons [3] [0 1 7] \"P\" [0 0 0 1 0 0 0 1 0]\nWorldEnd\n",
        )],
        E,
        "s.rib:2: PointsPolygons",
    ),
    (
        "RIB unknown request",
        &["render", "s.rib", "--spp", "1"],
        &[(
            "s.rib",
            "Format 8 6 1\nDisplay \"u.exr\" \"openexr\" \"rgba\"\nWorldBegin\nFrobnicate\nWorldEnd\n",
        )],
        W,
        "s.rib:4: unknown request Frobnicate, skipped",
    ),
    (
        "RIB ReadArchive of a missing file",
        &["render", "s.rib"],
        &[("s.rib", "WorldBegin\nReadArchive \"missing.rib\"\nWorldEnd\n")],
        E,
        "missing.rib",
    ),
    (
        "RIB a NaN in an array",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nWorldBegin\nLight \"PxrDomeLight\" \"d\" \"color lightColor\" [nan 1 1]\nWorldEnd\n",
        )],
        E,
        "s.rib:3: a NaN value (\"nan\"): numbers must be finite",
    ),
    (
        "RIB a string where a number is expected",
        &["render", "s.rib"],
        &[("s.rib", "Format \"64\" 48 1\nWorldBegin\nWorldEnd\n")],
        E,
        "s.rib:1: Format expects width height pixelaspect (3 numbers); argument 1 is the string \"64\", where a number is expected",
    ),
    (
        "RIB two Displays writing one file",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nDisplay \"a.exr\" \"openexr\" \"rgba\"\nDisplay \"+a.exr\" \"openexr\" \"z\"\nWorldBegin\nWorldEnd\n",
        )],
        E,
        "s.rib:3: Display \"+a.exr\" writes ",
    ),
    (
        "RIB two Displays writing one file: the first named",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nDisplay \"b.exr\" \"openexr\" \"rgba\"\nDisplay \"+b.exr\" \"openexr\" \"z\"\nWorldBegin\nWorldEnd\n",
        )],
        E,
        "which the display at s.rib:2 writes already: two displays naming one file would overwrite each other",
    ),
    (
        "RIB a 0-byte file",
        &["render", "s.rib"],
        &[("s.rib", "")],
        E,
        "s.rib: the file is empty (0 bytes): it holds no requests to render",
    ),
    (
        "RIB a fragment without WorldBegin",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nProjection \"PxrPerspective\" \"float fov\" [40]\n",
        )],
        E,
        "s.rib: no WorldBegin: the file is a fragment",
    ),
    (
        "RIB AttributeEnd without AttributeBegin",
        &["render", "s.rib"],
        &[("s.rib", "WorldBegin\nAttributeEnd\nWorldEnd\n")],
        E,
        "s.rib:2: AttributeEnd",
    ),
    (
        "RIB a number that is not one",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nProjection \"PxrPerspective\" \"float fov\" [abc]\nWorldBegin\nWorldEnd\n",
        )],
        E,
        "s.rib:2",
    ),
    (
        "RIB CropWindow selecting nothing",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "Format 8 6 1\nCropWindow 0.5 0.5 0 1\nWorldBegin\nWorldEnd\n",
        )],
        E,
        "CropWindow",
    ),
    (
        "RIB Clipping 0 10",
        &["render", "s.rib"],
        &[("s.rib", "Format 8 6 1\nClipping 0 10\nWorldBegin\nWorldEnd\n")],
        E,
        "Clipping",
    ),
    (
        "RIB Shutter backwards",
        &["render", "s.rib"],
        &[("s.rib", "Format 8 6 1\nShutter 1 0\nWorldBegin\nWorldEnd\n")],
        E,
        "Shutter",
    ),
    (
        "RIB micropolygonlength 0",
        &["render", "s.rib"],
        &[(
            "s.rib",
            "WorldBegin\nAttribute \"dice\" \"float micropolygonlength\" [0]\nWorldEnd\n",
        )],
        E,
        "s.rib:2: Attribute \"dice\": micropolygonlength must be greater than 0, got 0",
    ),
    (
        "a missing scene file",
        &["render", "missing.rib"],
        &[],
        E,
        "missing.rib",
    ),
    // ----- glTF -----
    (
        "glTF malformed JSON",
        &["render", "b.gltf"],
        &[("b.gltf", "{\"asset\": {\"version\": ")],
        E,
        "b.gltf",
    ),
    (
        "glTF accessor out of range",
        &["render", "a.gltf"],
        &[("a.gltf", GLTF_BAD_ACCESSOR)],
        E,
        "refers to accessor 5, but the file has 1",
    ),
    (
        "GLB truncated",
        &["render", "t.glb"],
        &[("t.glb", "glTF\u{2}\u{0}\u{0}\u{0}")],
        E,
        "t.glb",
    ),
    (
        "glTF buffer file missing",
        &["render", "m.gltf"],
        &[("m.gltf", GLTF_MISSING_BUFFER)],
        E,
        "missing.bin",
    ),
    // ----- OBJ -----
    (
        "OBJ face index 0",
        &["render", "o.obj"],
        &[("o.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")],
        E,
        "o.obj:4: vertex index 0 in \"0\" (OBJ indices start at 1)",
    ),
    (
        "OBJ face index out of range",
        &["render", "o.obj"],
        &[("o.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")],
        E,
        "o.obj:4: vertex index 9 in \"9\" is out of range: the file declares 3",
    ),
    (
        "OBJ relative index before the first",
        &["render", "o.obj"],
        &[("o.obj", "v 0 0 0\nf -1 -2 -3\n")],
        E,
        "o.obj:2: relative vertex index -2",
    ),
    (
        "OBJ a number that is not one",
        &["render", "o.obj"],
        &[("o.obj", "v 0 x 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")],
        E,
        "o.obj",
    ),
    (
        "OBJ vertex 1e300",
        &["render", "o.obj"],
        &[("o.obj", "v 1e300 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")],
        E,
        "vertex 0 has a non-finite position",
    ),
    // ----- calibration files -----
    (
        "COLMAP unknown model",
        &["rays", "--calibration", "c.txt"],
        &[("c.txt", "1 NOPE 640 480 500 320 240\n")],
        E,
        "c.txt:1",
    ),
    (
        "COLMAP wrong parameter count",
        &["rays", "--calibration", "c.txt"],
        &[("c.txt", "1 PINHOLE 640 480 500 500 320\n")],
        E,
        "c.txt:1",
    ),
    (
        "COLMAP camera not in the file",
        &["rays", "--calibration", "c.txt", "--camera", "9"],
        &[("c.txt", "1 PINHOLE 640 480 500 500 320 240\n")],
        E,
        "c.txt",
    ),
    (
        "COLMAP focal length 0",
        &["rays", "--calibration", "c.txt"],
        &[("c.txt", "1 PINHOLE 640 480 0 500 320 240\n")],
        E,
        "c.txt:1",
    ),
    (
        "OpenCV YAML without camera_matrix",
        &["rays", "--calibration", "o.yml"],
        &[("o.yml", "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n")],
        E,
        "not a calibration file of a known kind",
    ),
    (
        "OpenCV skew",
        &["rays", "--calibration", "o.yml"],
        &[("o.yml", OPENCV_SKEW)],
        E,
        "o.yml",
    ),
    (
        "Kalibr unknown camera model",
        &["rays", "--calibration", "k.yaml"],
        &[(
            "k.yaml",
            "cam0:\n  camera_model: nope\n  intrinsics: [500, 500, 320, 240]\n  distortion_model: radtan\n  distortion_coeffs: [0, 0, 0, 0]\n  resolution: [640, 480]\n",
        )],
        E,
        "k.yaml",
    ),
    (
        "OCamCalib wrong polynomial length",
        &["rays", "--calibration", "r.txt"],
        &[("r.txt", OCAM_BAD_LENGTH)],
        E,
        "r.txt:3: pol: the length says 6 coefficients but its line holds 5",
    ),
    (
        "a calibration file that cannot be read",
        &["rays", "--calibration", "missing.yml"],
        &[],
        E,
        "missing.yml",
    ),
    (
        "--camera without --calibration",
        &["rays", "--camera", "1"],
        &[],
        U,
        "--calibration",
    ),
    // ----- command line -----
    (
        "--format without x",
        &["rays", "--format", "640"],
        &[],
        U,
        "'640': expected WIDTHxHEIGHT with positive integers",
    ),
    (
        "--format 0x5",
        &["rays", "--format", "0x5"],
        &[],
        U,
        "'0x5': expected WIDTHxHEIGHT",
    ),
    (
        "--crop selecting nothing",
        &["rays", "--crop", "0.5", "0.5", "0", "1"],
        &[],
        E,
        "CropWindow",
    ),
    (
        "unknown projection",
        &["rays", "-p", "Nope"],
        &[],
        E,
        "unknown projection \"Nope\"",
    ),
    (
        "--param misspelt",
        &["rays", "--param", "fvo=60"],
        &[],
        E,
        "PxrPerspective has no parameter \"fvo\" (did you mean \"fov\"?)",
    ),
    (
        "--param not a number",
        &["rays", "--param", "float fov=abc"],
        &[],
        E,
        "cannot read \"abc\" as float",
    ),
    (
        "--param out of range",
        &["rays", "--param", "float fov=200"],
        &[],
        E,
        "= 200 is out of range: expected a value in [0.001, 180)",
    ),
    (
        "--param without a value",
        &["rays", "--param", "fov 60"],
        &[],
        E,
        "--param 'fov 60': expected",
    ),
    (
        "rays --samples beyond the sampler",
        &["rays", "--samples", "100000"],
        &[],
        E,
        "--samples 100000",
    ),
    (
        "check --format too large",
        &["check", "PxrPerspective", "--format", "5000x5000"],
        &[],
        U,
        "at most 16777216 pixels",
    ),
    ("plugins of an unknown name", &["plugins", "Nope"], &[], E, "Nope"),
    (
        "a plugin file that is not a library",
        &["plugins", "./Fake.so"],
        &[("Fake.so", "not an ELF file")],
        E,
        "Fake.so",
    ),
    (
        "stmap --from an unknown projection",
        &["stmap", "--from", "Nope", "--to", "PxrPerspective"],
        &[],
        E,
        "--from Nope",
    ),
    (
        "stmap --from-format 0x1",
        &[
            "stmap",
            "--from",
            "PxrPerspective",
            "--to",
            "PxrPerspective",
            "--from-format",
            "0x1",
        ],
        &[],
        U,
        "'0x1': expected WIDTHxHEIGHT",
    ),
];

/// Runs one case in a fresh directory; returns what went wrong, if anything.
fn run(case: &Case) -> Option<String> {
    let (name, args, files, (env, want), fragment) = *case;
    let dir = tempfile::tempdir().unwrap();
    for (path, contents) in files {
        let path = dir.path().join(path);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        if !path.ends_with("keep") {
            std::fs::write(&path, contents).unwrap();
        }
    }
    let mut command = Command::new(env!("CARGO_BIN_EXE_obscura"));
    command
        .args(args)
        .current_dir(dir.path())
        .env_remove("OBSCURA_PLUGIN_PATH")
        .env_remove("OBSCURA_MEMORY_LIMIT");
    if let Some((k, v)) = env {
        command.env(k, v);
    }
    let start = Instant::now();
    let out = command.output().unwrap();
    let elapsed = start.elapsed();
    let stderr = text(&out.stderr);
    let code = out.status.code();
    let expected_code = match want {
        Want::Error => 1,
        Want::Warning => 0,
        Want::Usage => 2,
    };
    let mut problems = Vec::new();
    if code != Some(expected_code) {
        problems.push(format!("exit status {code:?}, expected {expected_code}"));
    }
    if !stderr.contains(fragment) {
        problems.push(format!("message without \"{fragment}\""));
    }
    if stderr.contains("panicked") || stderr.contains("RUST_BACKTRACE") {
        problems.push("a panic".into());
    }
    if elapsed > Duration::from_secs(30) {
        problems.push(format!("took {elapsed:?}"));
    }
    // Files a refused job must not leave behind (a half-written output, a temporary).
    if want != Want::Warning {
        let leftovers: Vec<String> = walk(dir.path())
            .into_iter()
            .filter(|p| !files.iter().any(|(f, _)| dir.path().join(f) == *p))
            .filter(|p| !p.is_dir())
            .map(|p| p.display().to_string())
            .collect();
        if !leftovers.is_empty() {
            problems.push(format!("left files behind: {leftovers:?}"));
        }
    }
    (!problems.is_empty())
        .then(|| format!("{name}: {}\n  stderr: {}", problems.join("; "), stderr.trim_end()))
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().filter_map(Result::ok) {
        let p = e.path();
        if p.is_dir() {
            out.extend(walk(&p));
        }
        out.push(p);
    }
    out
}

#[test]
fn every_bad_input_of_the_catalogue_gets_its_message() {
    assert!(CATALOGUE.len() >= 80, "{} cases", CATALOGUE.len());
    let mut names: Vec<&str> = CATALOGUE.iter().map(|c| c.0).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), CATALOGUE.len(), "case names are unique");
    // Two workers: the cases are independent processes.
    let (a, b) = CATALOGUE.split_at(CATALOGUE.len() / 2);
    let failures: Vec<String> = std::thread::scope(|s| {
        let ha = s.spawn(|| a.iter().filter_map(run).collect::<Vec<_>>());
        let hb = s.spawn(|| b.iter().filter_map(run).collect::<Vec<_>>());
        let mut f = ha.join().unwrap();
        f.extend(hb.join().unwrap());
        f
    });
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        CATALOGUE.len(),
        failures.join("\n")
    );
}

/// The process's address-space limit (`ulimit -v`, what Grid Engine's `h_vmem` sets) bounds the
/// scene's triangles as `OBSCURA_MEMORY_LIMIT` does: under util-linux's `prlimit --as` a scene too
/// large for it stops with a message naming the primitive and the limit, where the allocator used to
/// abort the process (aqsis's `tenpatch.rib` under the corpus script's 2 GiB).
#[test]
fn an_address_space_limit_bounds_the_triangles_with_a_located_error() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.rib"), FINE_SPHERE).unwrap();
    let out = Command::new("prlimit")
        .arg(format!("--as={}", 1u64 << 30))
        .arg(env!("CARGO_BIN_EXE_obscura"))
        .args(["render", "s.rib", "-o", "s.exr"])
        .current_dir(dir.path())
        .env_remove("OBSCURA_MEMORY_LIMIT")
        .output()
        .expect("prlimit (util-linux) runs");
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains(
            "s.rib:6: this primitive dices into 4289040 triangles, which the scene cannot hold: 0 are \
             diced already and the budget is 1789569, what 1.0 GiB of memory holds at 450 bytes a \
             triangle (the process's address-space limit, ulimit -v)"
        ),
        "{stderr}"
    );
    assert!(!dir.path().join("s.exr").exists());
}

/// RIB files as they come (issue 16): a Latin-1 byte, gzip (by content, whatever the name) and binary
/// RIB render instead of failing with "stream did not contain valid UTF-8".
#[test]
fn latin1_gzip_and_binary_ribs_render() {
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    let scene = |out: &str| {
        format!(
            "Format 8 6 1\nDisplay \"{out}\" \"openexr\" \"rgba\"\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n"
        )
    };
    std::fs::write(
        dir.path().join("latin1.rib"),
        b"# Szene f\xFCr den Test\nFormat 8 6 1\nDisplay \"caf\xE9.exr\" \"openexr\" \"rgba\"\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n",
    )
    .unwrap();
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(scene("gz.exr").as_bytes()).unwrap();
    std::fs::write(dir.path().join("gz.rib"), gz.finish().unwrap()).unwrap();
    // Binary (RISpec 3.2 C.2): define request 0 "Format" (0xCC 0 0x96 …), use it (0xA6 0) with three
    // two-byte integers (0x81), then Display with short strings (0x90 + length), then the world.
    let mut bin = vec![0xCC, 0, 0x96];
    bin.extend(b"Format");
    bin.extend([0xA6, 0, 0x81, 0, 8, 0x81, 0, 6, 0x81, 0, 1, 0xCC, 1, 0x97]);
    bin.extend(b"Display");
    bin.extend([0xA6, 1, 0x97]);
    bin.extend(b"bin.exr");
    bin.extend([0x97]);
    bin.extend(b"openexr");
    bin.extend([0x94]);
    bin.extend(b"rgba");
    bin.extend(b"\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n");
    std::fs::write(dir.path().join("bin.rib"), bin).unwrap();
    for (file, output) in [
        ("latin1.rib", "café.exr"),
        ("gz.rib", "gz.exr"),
        ("bin.rib", "bin.exr"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_obscura"))
            .args(["render", file, "--spp", "1"])
            .current_dir(dir.path())
            .env_remove("OBSCURA_PLUGIN_PATH")
            .output()
            .unwrap();
        let stderr = text(&out.stderr);
        assert!(out.status.success(), "{file}: {:?}\n{stderr}", out.status);
        assert!(!stderr.contains("valid UTF-8"), "{file}: {stderr}");
        assert!(dir.path().join(output).is_file(), "{file}: no {output}\n{stderr}");
    }
}
