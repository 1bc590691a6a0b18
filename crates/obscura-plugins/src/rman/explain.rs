//! Compiler errors that come from a generation mismatch, or from an interface Obscura does not offer,
//! explained in one paragraph.

use super::detect::{Detected, Generation};

/// RenderMan identifiers a projection might use that Obscura's headers do not offer, with what to do.
const NOT_OFFERED: &[(&str, &str)] = &[
    (
        "TransformOrigins",
        "RixProjectionContext::TransformOrigins is not offered (deprecated by RenderMan): use the environment's worldToCameraMatrix samples",
    ),
    (
        "TransformDirections",
        "RixProjectionContext::TransformDirections is not offered (deprecated by RenderMan): use the environment's worldToCameraMatrix samples",
    ),
    (
        "k_RixThreadUtils",
        "RixThreadUtils is not offered: use std::mutex / std::thread",
    ),
    (
        "RixThreadUtils",
        "RixThreadUtils is not offered: use std::mutex / std::thread",
    ),
    (
        "k_RixStorage",
        "RixStorage is not offered: keep per-camera data in the projection object",
    ),
    (
        "RixStorage",
        "RixStorage is not offered: keep per-camera data in the projection object",
    ),
    ("k_RixLPE", "RixLPE is not offered to projections"),
    (
        "k_RixStats",
        "RixStats is not offered: report through RixMessages",
    ),
    ("k_RixGlobalData", "RixGlobalData is not offered"),
    ("k_RixTimer", "RixTimer is not offered"),
    ("k_RixTexture", "RixTexture is not offered to projections"),
    (
        "SynchronizeInstanceData",
        "SynchronizeInstanceData is not offered: projections have no instance data",
    ),
];

/// One paragraph explaining `stderr` (a failed compile as `version`), or `None` when nothing in it is
/// a known mismatch.
#[must_use]
pub fn explain(stderr: &str, version: u32, detected: Option<&Detected>) -> Option<String> {
    let selected = Generation::of_version(version)?;
    let mut out = Vec::new();
    if let Some(d) = detected
        && d.generation != selected
    {
        out.push(format!(
            "This source is written for {} ({}), but it was compiled as RenderMan {version}{}: the \
             interface changed between these releases. Build without --rman-version to let obscura \
             choose, or pass --rman-version {}.",
            d.generation.releases(),
            d.evidence,
            if selected == Generation::G2 {
                String::new()
            } else {
                format!(" ({})", selected.releases())
            },
            d.generation.default_version()
        ));
    } else {
        let mismatch = stderr.contains("does not override")
            || stderr.contains("overriding final function")
            || stderr.contains("RIX_PROJECTION")
            || stderr.contains("abstract type")
            || stderr.contains("has no member named 'deepMetric'")
            || stderr.contains("has no member named \u{2018}deepMetric\u{2019}")
            || stderr.contains("k_DeepMetric");
        if mismatch {
            out.push(format!(
                "These errors are what a source of another generation gives: it was compiled as RenderMan \
                 {version} ({}), where {}. If the plugin is written for another release, pass \
                 --rman-version (21 for RenderMan 19-21, 22, or 23-27); a source mixing generations \
                 must be made one.",
                selected.releases(),
                shape(selected)
            ));
        }
    }
    for (name, what) in NOT_OFFERED {
        if stderr.contains(&format!("'{name}'")) || stderr.contains(&format!("\u{2018}{name}\u{2019}")) {
            let line = format!("{what} (see docs/renderman-plugins.md, \"What is not offered\").");
            if !out.contains(&line) {
                out.push(line);
            }
        }
    }
    (!out.is_empty()).then(|| out.join("\n"))
}

/// The shape of a generation's interface, in one clause.
fn shape(g: Generation) -> &'static str {
    match g {
        Generation::G1 => {
            "the plugin is one RixProjection with Init(RixContext&, char const*) and RenderBegin(RixContext&, \
             RixProjectionEnvironment&, RixParameterList const*), entered by RIX_PROJECTIONCREATE"
        }
        Generation::G2 => {
            "RixProjectionFactory::CreateProjection takes (RixContext&, RixProjectionEnvironment&, RtUString \
             const, RixParameterList const*) and the projection has no RenderBegin"
        }
        Generation::G3 => {
            "CreateProjection takes (RixContext&, RtUString const, RixParameterList const*), the projection \
             has RenderBegin(RixContext&, RixProjectionEnvironment const&, RixParameterList const*) and \
             CreateInstanceData is final"
        }
    }
}
