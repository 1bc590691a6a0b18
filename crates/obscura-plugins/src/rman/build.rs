//! `obscura build-plugin`: the embedded SDK written out, the system C++ compiler run on the plugin's
//! sources and the glue.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

use super::detect::{Detected, Generation, detect};
use super::{GLUE, SDK_FILES};

/// What to build.
#[derive(Debug, Clone, Default)]
pub struct BuildRequest {
    /// The plugin's C++ sources (at least one).
    pub sources: Vec<PathBuf>,
    /// The library to write; default `<stem of the first source>.so` in the current directory.
    pub output: Option<PathBuf>,
    /// `-I` directories.
    pub include_dirs: Vec<PathBuf>,
    /// `-D` definitions, `NAME` or `NAME=VALUE`.
    pub defines: Vec<String>,
    /// `-L` directories.
    pub lib_dirs: Vec<PathBuf>,
    /// `-l` libraries.
    pub libs: Vec<String>,
    /// The RenderMan release the sources are written for (19–27); `None` finds it from the sources.
    pub rman_version: Option<u32>,
    /// Arguments passed to the compiler as they are, after everything else.
    pub extra: Vec<OsString>,
}

/// What a successful build did.
#[derive(Debug, Clone)]
pub struct BuildResult {
    /// The library written.
    pub output: PathBuf,
    /// The release the sources were compiled as.
    pub rman_version: u32,
    /// What the detection found (`None` when `--rman-version` was given and nothing was found).
    pub detected: Option<Detected>,
    /// The compiler's command line as it ran, shell-quoted (the SDK's temporary directory included).
    pub command_line: String,
    /// The compiler's warnings.
    pub warnings: String,
}

/// Why a build failed.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// Nothing to compile.
    #[error(
        "build-plugin: no source file given (usage: obscura build-plugin SRC.cpp [SRC2.cpp …] [-o OUT.so])"
    )]
    NoSources,
    /// A source file is missing.
    #[error("{path}: cannot read the source: {source}")]
    Source {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// `--rman-version` outside 19–27.
    #[error(
        "--rman-version {0}: RenderMan releases 19 to 27 have projection plugins (19-21, 22 and 23-27 are the three generations)"
    )]
    BadVersion(u32),
    /// No C++ compiler could be run.
    #[error("no C++ compiler found: tried {tried}; install one (g++ or clang++) or set CXX")]
    NoCompiler {
        /// The commands tried.
        tried: String,
    },
    /// Writing the SDK or the output failed.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The compiler failed.
    #[error("compiling failed:\n{stderr}{explanation}")]
    Compile {
        /// The command line.
        command_line: String,
        /// The compiler's messages.
        stderr: String,
        /// Obscura's explanation (a generation mismatch, an interface Obscura does not offer), if any.
        explanation: String,
    },
}

/// The C++ compiler: `$CXX`, else the first of `c++`, `g++`, `clang++` that runs.
///
/// # Errors
/// [`BuildError::NoCompiler`] when none runs.
pub fn compiler() -> Result<OsString, BuildError> {
    if let Some(cxx) = std::env::var_os("CXX").filter(|c| !c.is_empty()) {
        return Ok(cxx);
    }
    for c in ["c++", "g++", "clang++"] {
        if Command::new(c)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
        {
            return Ok(c.into());
        }
    }
    Err(BuildError::NoCompiler {
        tried: "$CXX (unset), c++, g++, clang++".into(),
    })
}

/// Writes the SDK (headers, glue, C ABI header) under `dir/include`, plus a CMake package
/// (`dir/lib/cmake/ObscuraRMan/ObscuraRManConfig.cmake`) and a pkg-config file
/// (`dir/lib/pkgconfig/obscura-rman.pc`) for studio build systems. Returns the include directory.
///
/// # Errors
/// [`BuildError::Io`] when a file cannot be written.
pub fn install_sdk(dir: &Path) -> Result<PathBuf, BuildError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| BuildError::Io { path, source }
    };
    let include = dir.join("include");
    for (rel, text) in SDK_FILES {
        let p = include.join(rel);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).map_err(io(parent))?;
        }
        std::fs::write(&p, text).map_err(io(&p))?;
    }
    let cmake_dir = dir.join("lib/cmake/ObscuraRMan");
    std::fs::create_dir_all(&cmake_dir).map_err(io(&cmake_dir))?;
    let cmake = cmake_dir.join("ObscuraRManConfig.cmake");
    std::fs::write(&cmake, CMAKE_CONFIG).map_err(io(&cmake))?;
    let pc_dir = dir.join("lib/pkgconfig");
    std::fs::create_dir_all(&pc_dir).map_err(io(&pc_dir))?;
    let pc = pc_dir.join("obscura-rman.pc");
    let prefix = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
    std::fs::write(&pc, PKG_CONFIG.replace("@PREFIX@", &prefix.to_string_lossy())).map_err(io(&pc))?;
    Ok(include)
}

/// The CMake package: `find_package(ObscuraRMan)` then `obscura_add_rman_projection(NAME VERSION src…)`.
const CMAKE_CONFIG: &str = r#"# ObscuraRManConfig.cmake — written by `obscura build-plugin --install-sdk`.
# find_package(ObscuraRMan REQUIRED)
# obscura_add_rman_projection(MyFisheye 25 MyFisheye.cpp)   # a MODULE library MyFisheye.so
get_filename_component(_obscura_rman_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
set(ObscuraRMan_INCLUDE_DIRS "${_obscura_rman_prefix}/include/rix" "${_obscura_rman_prefix}/include")
set(ObscuraRMan_GLUE "${_obscura_rman_prefix}/include/rix/obscura_rman_glue.cpp")
function(obscura_add_rman_projection name rman_version)
  add_library(${name} MODULE ${ARGN} "${ObscuraRMan_GLUE}")
  set_target_properties(${name} PROPERTIES PREFIX "" CXX_STANDARD 17 CXX_STANDARD_REQUIRED ON
                        POSITION_INDEPENDENT_CODE ON)
  target_include_directories(${name} PRIVATE ${ObscuraRMan_INCLUDE_DIRS})
  target_compile_definitions(${name} PRIVATE OBSCURA_RMAN_VERSION=${rman_version})
endfunction()
"#;

/// The pkg-config file: the flags; the glue's path is the variable `glue`.
const PKG_CONFIG: &str = "prefix=@PREFIX@
includedir=${prefix}/include
glue=${includedir}/rix/obscura_rman_glue.cpp

Name: obscura-rman
Description: Obscura's RenderMan-compatible projection plugin headers (compile ${glue} with your sources and -DOBSCURA_RMAN_VERSION=N)
Version: 0.1.0
Cflags: -I${includedir}/rix -I${includedir} -std=c++17 -fPIC
Libs: -shared
";

/// The compiler invocation for `req` with the SDK under `sdk_include`, as the program and its arguments.
#[must_use]
pub fn sdk_command(
    cxx: &OsString,
    req: &BuildRequest,
    version: u32,
    sdk_include: &Path,
    output: &Path,
) -> Vec<OsString> {
    let mut a: Vec<OsString> = vec![cxx.clone()];
    for s in ["-shared", "-fPIC", "-std=c++17", "-O2"] {
        a.push(s.into());
    }
    a.push(format!("-DOBSCURA_RMAN_VERSION={version}").into());
    let mut inc = OsString::from("-I");
    inc.push(sdk_include.join("rix"));
    a.push(inc);
    let mut inc = OsString::from("-I");
    inc.push(sdk_include);
    a.push(inc);
    for d in &req.include_dirs {
        let mut s = OsString::from("-I");
        s.push(d);
        a.push(s);
    }
    for d in &req.defines {
        a.push(format!("-D{d}").into());
    }
    a.push("-o".into());
    a.push(output.into());
    for s in &req.sources {
        a.push(s.into());
    }
    a.push(sdk_include.join(GLUE).into());
    for d in &req.lib_dirs {
        let mut s = OsString::from("-L");
        s.push(d);
        a.push(s);
    }
    for l in &req.libs {
        a.push(format!("-l{l}").into());
    }
    if cfg!(target_os = "macos") {
        a.push("-undefined".into());
        a.push("dynamic_lookup".into());
    }
    a.extend(req.extra.iter().cloned());
    a
}

/// Builds the plugin: detects the generation (unless given), writes the SDK to a temporary directory,
/// runs the compiler, and on failure explains generation mismatches.
///
/// # Errors
/// See [`BuildError`].
pub fn build(req: &BuildRequest) -> Result<BuildResult, BuildError> {
    let first = req.sources.first().ok_or(BuildError::NoSources)?;
    for s in &req.sources {
        std::fs::metadata(s).map_err(|source| BuildError::Source {
            path: s.clone(),
            source,
        })?;
    }
    let paths: Vec<&Path> = req.sources.iter().map(PathBuf::as_path).collect();
    let detected = detect(&paths);
    let version = match req.rman_version {
        Some(v) => {
            Generation::of_version(v).ok_or(BuildError::BadVersion(v))?;
            v
        }
        None => detected.as_ref().map_or(Generation::G3.default_version(), |d| {
            d.generation.default_version()
        }),
    };
    let output = req.output.clone().unwrap_or_else(|| {
        let stem = first
            .file_stem()
            .map_or_else(|| "plugin".into(), |s| s.to_string_lossy().into_owned());
        PathBuf::from(format!("{stem}.{}", std::env::consts::DLL_EXTENSION))
    });
    let cxx = compiler()?;
    let tmp = tempfile::Builder::new()
        .prefix("obscura-rman-sdk-")
        .tempdir()
        .map_err(|source| BuildError::Io {
            path: std::env::temp_dir(),
            source,
        })?;
    let include = install_sdk(tmp.path())?;
    let argv = sdk_command(&cxx, req, version, &include, &output);
    let command_line = shell_line(&argv);
    let out = Command::new(&argv[0])
        .args(&argv[1..])
        .output()
        .map_err(|source| BuildError::Io {
            path: PathBuf::from(&argv[0]),
            source,
        })?;
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    if !out.status.success() {
        let explanation = super::explain(&stderr, version, detected.as_ref());
        return Err(BuildError::Compile {
            command_line,
            stderr,
            explanation: explanation.map(|e| format!("\n{e}")).unwrap_or_default(),
        });
    }
    Ok(BuildResult {
        output,
        rman_version: version,
        detected,
        command_line,
        warnings: stderr,
    })
}

/// `argv` as one shell line, each argument quoted where it needs it.
fn shell_line(argv: &[OsString]) -> String {
    argv.iter()
        .map(|a| {
            let s = a.to_string_lossy();
            if !s.is_empty()
                && s.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_./=+,:@%".contains(c))
            {
                s.into_owned()
            } else {
                format!("'{}'", s.replace('\'', r"'\''"))
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}
