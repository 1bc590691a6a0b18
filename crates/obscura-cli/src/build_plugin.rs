//! `obscura build-plugin`: a RenderMan projection plugin's C++ sources, as they are written, compiled
//! into an Obscura plugin with the embedded RenderMan-compatible headers (like Houdini's `hcustom`).

use std::ffi::OsString;
use std::path::PathBuf;

use clap::Args;
use obscura_plugins::rman::{self, BuildError, BuildRequest};

use crate::stdout::outln;

/// The arguments of `obscura build-plugin`.
#[derive(Args, Debug)]
pub struct BuildPluginArgs {
    /// The plugin's C++ sources, unchanged (RenderMan 19-21, 22 or 23-27).
    #[arg(required_unless_present = "install_sdk", value_name = "SRC.cpp")]
    sources: Vec<PathBuf>,
    /// The library to write. Default: <stem of the first source>.so here; the stem is the projection's
    /// name (Projection "MyFisheye" loads MyFisheye.so).
    #[arg(short, long, value_name = "OUT.so")]
    output: Option<PathBuf>,
    /// An include directory (the plugin's own headers). Repeatable.
    #[arg(short = 'I', value_name = "DIR")]
    include: Vec<PathBuf>,
    /// A preprocessor definition, NAME or NAME=VALUE. Repeatable.
    #[arg(short = 'D', value_name = "NAME[=V]")]
    define: Vec<String>,
    /// A library directory. Repeatable.
    #[arg(short = 'L', value_name = "DIR")]
    lib_dir: Vec<PathBuf>,
    /// A library to link. Repeatable.
    #[arg(short = 'l', value_name = "LIB")]
    lib: Vec<String>,
    /// The RenderMan release the source is written for, 19 to 27. Default: found from the source's
    /// signatures (19-21: RIX_PROJECTIONCREATE; 22: CreateProjection with the environment; 23-27: the
    /// rest).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(19..=27))]
    rman_version: Option<u32>,
    /// Write the headers, the glue, a CMake package (lib/cmake/ObscuraRMan) and a pkg-config file
    /// (lib/pkgconfig/obscura-rman.pc) under DIR for a studio build system, and build nothing else.
    #[arg(long, value_name = "DIR")]
    install_sdk: Option<PathBuf>,
    /// Extra compiler arguments, after `--`.
    #[arg(last = true, value_name = "ARGS")]
    extra: Vec<OsString>,
}

/// Runs `obscura build-plugin`.
pub fn run(a: &BuildPluginArgs) -> Result<(), BuildError> {
    if let Some(dir) = &a.install_sdk {
        let include = rman::install_sdk(dir)?;
        outln!("wrote the RenderMan-compatible SDK under {}", dir.display());
        outln!(
            "  headers: {} (and {})",
            include.join("rix").display(),
            include.display()
        );
        outln!("  glue:    {}", include.join(rman::GLUE).display());
        outln!(
            "  cmake:   {}",
            dir.join("lib/cmake/ObscuraRMan/ObscuraRManConfig.cmake")
                .display()
        );
        outln!(
            "  pkg-config: {}",
            dir.join("lib/pkgconfig/obscura-rman.pc").display()
        );
        if a.sources.is_empty() {
            return Ok(());
        }
    }
    let req = BuildRequest {
        sources: a.sources.clone(),
        output: a.output.clone(),
        include_dirs: a.include.clone(),
        defines: a.define.clone(),
        lib_dirs: a.lib_dir.clone(),
        libs: a.lib.clone(),
        rman_version: a.rman_version,
        extra: a.extra.clone(),
    };
    match rman::build(&req) {
        Ok(r) => {
            match (&r.detected, a.rman_version) {
                (Some(d), None) => outln!("RenderMan {} ({}): {}", r.rman_version, d.generation, d.evidence),
                (None, None) => outln!(
                    "RenderMan {}: no generation-specific signature found, the newest interface assumed",
                    r.rman_version
                ),
                (_, Some(v)) => outln!("RenderMan {v} (--rman-version)"),
            }
            outln!("{}", r.command_line);
            if !r.warnings.is_empty() {
                eprint!("{}", r.warnings);
            }
            let name = r
                .output
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            outln!("wrote {} (Projection \"{name}\")", r.output.display());
            Ok(())
        }
        Err(BuildError::Compile {
            command_line,
            stderr,
            explanation,
        }) => {
            outln!("{command_line}");
            Err(BuildError::Compile {
                command_line,
                stderr,
                explanation,
            })
        }
        Err(e) => Err(e),
    }
}
