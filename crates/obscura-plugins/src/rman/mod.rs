//! RenderMan projection plugins as they are written: Obscura's RenderMan-compatible C++ headers
//! (`include/rix/`), the glue translation unit that turns a compiled `RixProjectionFactory` (or a
//! RenderMan 19–21 `RixProjection`) into an Obscura plugin through the C ABI, and `obscura build-plugin`.
//!
//! The headers and the glue are embedded in the binary ([`SDK_FILES`]), so an installed `obscura` alone
//! builds a plugin: [`build`] writes them to a temporary directory and runs the system C++ compiler.
//! [`detect`] finds the interface generation a source is written for; [`explain`] turns a compiler's
//! generation-mismatch errors into a sentence naming both generations.

pub mod args;
mod build;
mod detect;
mod explain;

pub use build::{BuildError, BuildRequest, BuildResult, build, compiler, install_sdk, sdk_command};
pub use detect::{Detected, Generation, detect, detect_text};
pub use explain::explain;

/// Every file of the C++ SDK, as `(path under the SDK's include directory, contents)`: the
/// RenderMan-compatible headers, the glue, and Obscura's C ABI header they build on.
pub const SDK_FILES: &[(&str, &str)] = &[
    (
        "rix/RixInterfaces.h",
        include_str!("../../../../include/rix/RixInterfaces.h"),
    ),
    (
        "rix/RixShading.h",
        include_str!("../../../../include/rix/RixShading.h"),
    ),
    (
        "rix/RixIntegrator.h",
        include_str!("../../../../include/rix/RixIntegrator.h"),
    ),
    (
        "rix/RixProjection.h",
        include_str!("../../../../include/rix/RixProjection.h"),
    ),
    (
        "rix/RixShadingUtils.h",
        include_str!("../../../../include/rix/RixShadingUtils.h"),
    ),
    (
        "rix/RiTypesHelper.h",
        include_str!("../../../../include/rix/RiTypesHelper.h"),
    ),
    (
        "rix/prmanapi.h",
        include_str!("../../../../include/rix/prmanapi.h"),
    ),
    ("rix/ri.h", include_str!("../../../../include/rix/ri.h")),
    (
        "rix/obscura_rman_glue.cpp",
        include_str!("../../../../include/rix/obscura_rman_glue.cpp"),
    ),
    (
        "obscura/projection.h",
        include_str!("../../../../include/obscura/projection.h"),
    ),
];

/// The glue translation unit's path under the SDK's include directory.
pub const GLUE: &str = "rix/obscura_rman_glue.cpp";
