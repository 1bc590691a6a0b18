//! The AOV table: every output a display can ask for, declared once.
//!
//! Each [`Aov`] has one row of [`AOVS`]: the name `Display` channel lists, `--aov` and Python use, the
//! EXR channels it writes, whether it is filtered like the beauty or is one sample's value (the IDs),
//! which pass computes it, and where `--aov all` and Python's `render` take it. The film's resolved
//! pixel holds every value; `obscura_image::output` reads a row to name and type the channels, the
//! CLI to parse `--aov`, the renderer to know whether the flow pass runs, Python to name its arrays.
//! Adding an AOV is one row here, one variant, and its value in the film.

/// One AOV a display writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Aov {
    /// Beauty, RGB (`rgb`, `Ci`).
    Ci,
    /// Coverage (`a`).
    Alpha,
    /// Depth in the projection's deep metric (`z`).
    Z,
    /// Shading normal, world space (`N`).
    N,
    /// Hit position, world space (`P`).
    P,
    /// The camera ray's direction, world space (`cameraDirection`).
    CameraDirection,
    /// Camera-space z of the hit, whatever the projection's deep metric (`cameraZ`).
    CameraZ,
    /// Distance from the camera ray's origin to the hit, along the ray (`distance`).
    Distance,
    /// Hit position, camera space at the ray's time (`Pcamera`).
    PCamera,
    /// Shading normal, camera space at the ray's time (`Ncamera`).
    NCamera,
    /// The hit object's ID, an integer (`objectId`; 0 = nothing hit).
    ObjectId,
    /// The hit instance's ID, an integer (`instanceId`; 0 = nothing hit).
    InstanceId,
    /// The hit material's ID, an integer (`materialId`; 0 = nothing hit).
    MaterialId,
    /// Raster displacement toward shutter close or the next frame (`flowForward`), pixels.
    FlowForward,
    /// Raster displacement toward the previous frame (`flowBackward`), pixels.
    FlowBackward,
    /// Where each flow is defined (`flowValid`: `.forward`, `.backward`, 1 or 0).
    FlowValid,
    /// The textured base colour at the first hit, linear RGB (`albedo`).
    Albedo,
    /// The first texture coordinate set at the first hit, as stored in the file (`uv`).
    Uv,
    /// The sensor's raw mosaic in DN, an integer stored as a float (`raw`; needs a sensor).
    Raw,
    /// The sensor's noise-free expected photoelectrons of each pixel's channel (`electrons`; needs a
    /// sensor).
    Electrons,
}

/// How an AOV's pixels are made and stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AovKind {
    /// Filtered over the pixel like the beauty; `f32` (or `f16` on request) channels.
    Filtered,
    /// One sample's value: that of the sample nearest the pixel centre, the same sample as `Z`.
    Nearest,
    /// An integer of the nearest sample, never filtered: `UINT` channels whatever the precision asked.
    Id,
    /// Computed once per pixel after the samples (the flow, through the pixel's centre; the sensor,
    /// from the resolved beauty).
    Centre,
}

/// Which pass computes an AOV.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AovSource {
    /// The path tracer (beauty, alpha).
    Shading,
    /// The camera sample's first hit (depth, position, normal, direction, ground truth, IDs).
    FirstHit,
    /// The textures at the first hit.
    Texture,
    /// The flow pass after the samples, through the projection's `unproject`.
    Flow,
    /// The sensor after the film resolves (`obscura_sensor`).
    Sensor,
}

/// Where an AOV belongs among the outputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AovGroup {
    /// RenderMan's own outputs: a display names them.
    RenderMan,
    /// Ground truth for vision: `--aov all` adds them first.
    GroundTruth,
    /// What the textures give: `--aov all` adds them after the ground truth.
    Texture,
    /// The sensor's planes: written when a sensor is configured, never by `--aov all`.
    Sensor,
}

/// One row of the AOV table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AovSpec {
    /// The AOV.
    pub aov: Aov,
    /// The name a `Display` channel list, `--aov` and Python use.
    pub name: &'static str,
    /// The key of its array in Python's `render` result (RenderMan's `Ci` is `beauty` there).
    pub array: &'static str,
    /// Its EXR channels, in RenderMan's and Nuke's spelling.
    pub channels: &'static [&'static str],
    /// Filtered, nearest sample or integer ID.
    pub kind: AovKind,
    /// The pass that computes it.
    pub source: AovSource,
    /// Where it belongs.
    pub group: AovGroup,
}

/// A row of [`AOVS`].
const fn row(
    aov: Aov,
    name: &'static str,
    array: &'static str,
    channels: &'static [&'static str],
    kind: AovKind,
    source: AovSource,
    group: AovGroup,
) -> AovSpec {
    AovSpec {
        aov,
        name,
        array,
        channels,
        kind,
        source,
        group,
    }
}

use AovGroup::{GroundTruth, RenderMan, Texture};
use AovKind::{Centre, Filtered, Id, Nearest};

/// Every AOV, in the order of [`Aov`]'s variants (each row at its variant's index). `--aov all`
/// takes the ground-truth rows, then the texture rows, in this order.
pub const AOVS: [AovSpec; 20] = [
    row(
        Aov::Ci,
        "Ci",
        "beauty",
        &["R", "G", "B"],
        Filtered,
        AovSource::Shading,
        RenderMan,
    ),
    row(
        Aov::Alpha,
        "a",
        "alpha",
        &["A"],
        Filtered,
        AovSource::Shading,
        RenderMan,
    ),
    row(Aov::Z, "z", "z", &["Z"], Nearest, AovSource::FirstHit, RenderMan),
    row(
        Aov::N,
        "N",
        "N",
        &["N.X", "N.Y", "N.Z"],
        Nearest,
        AovSource::FirstHit,
        RenderMan,
    ),
    row(
        Aov::P,
        "P",
        "P",
        &["P.X", "P.Y", "P.Z"],
        Nearest,
        AovSource::FirstHit,
        RenderMan,
    ),
    row(
        Aov::CameraDirection,
        "cameraDirection",
        "cameraDirection",
        &["cameraDirection.X", "cameraDirection.Y", "cameraDirection.Z"],
        Nearest,
        AovSource::FirstHit,
        RenderMan,
    ),
    row(
        Aov::CameraZ,
        "cameraZ",
        "cameraZ",
        &["cameraZ"],
        Nearest,
        AovSource::FirstHit,
        GroundTruth,
    ),
    row(
        Aov::Distance,
        "distance",
        "distance",
        &["distance"],
        Nearest,
        AovSource::FirstHit,
        GroundTruth,
    ),
    row(
        Aov::PCamera,
        "Pcamera",
        "Pcamera",
        &["Pcamera.X", "Pcamera.Y", "Pcamera.Z"],
        Nearest,
        AovSource::FirstHit,
        GroundTruth,
    ),
    row(
        Aov::NCamera,
        "Ncamera",
        "Ncamera",
        &["Ncamera.X", "Ncamera.Y", "Ncamera.Z"],
        Nearest,
        AovSource::FirstHit,
        GroundTruth,
    ),
    row(
        Aov::ObjectId,
        "objectId",
        "objectId",
        &["objectId"],
        Id,
        AovSource::FirstHit,
        GroundTruth,
    ),
    row(
        Aov::InstanceId,
        "instanceId",
        "instanceId",
        &["instanceId"],
        Id,
        AovSource::FirstHit,
        GroundTruth,
    ),
    row(
        Aov::MaterialId,
        "materialId",
        "materialId",
        &["materialId"],
        Id,
        AovSource::FirstHit,
        GroundTruth,
    ),
    row(
        Aov::FlowForward,
        "flowForward",
        "flowForward",
        &["flowForward.X", "flowForward.Y"],
        Centre,
        AovSource::Flow,
        GroundTruth,
    ),
    row(
        Aov::FlowBackward,
        "flowBackward",
        "flowBackward",
        &["flowBackward.X", "flowBackward.Y"],
        Centre,
        AovSource::Flow,
        GroundTruth,
    ),
    row(
        Aov::FlowValid,
        "flowValid",
        "flowValid",
        &["flowValid.forward", "flowValid.backward"],
        Centre,
        AovSource::Flow,
        GroundTruth,
    ),
    row(
        Aov::Albedo,
        "albedo",
        "albedo",
        &["albedo.R", "albedo.G", "albedo.B"],
        Nearest,
        AovSource::Texture,
        Texture,
    ),
    row(
        Aov::Uv,
        "uv",
        "uv",
        &["uv.X", "uv.Y"],
        Nearest,
        AovSource::Texture,
        Texture,
    ),
    row(
        Aov::Raw,
        "raw",
        "raw",
        &["raw"],
        Centre,
        AovSource::Sensor,
        AovGroup::Sensor,
    ),
    row(
        Aov::Electrons,
        "electrons",
        "electrons",
        &["electrons"],
        Centre,
        AovSource::Sensor,
        AovGroup::Sensor,
    ),
];

impl Aov {
    /// This AOV's row of [`AOVS`].
    #[must_use]
    pub fn spec(self) -> &'static AovSpec {
        &AOVS[self as usize]
    }

    /// The name a `Display` channel list, `--aov` and Python use for this AOV.
    #[must_use]
    pub fn name(self) -> &'static str {
        self.spec().name
    }

    /// Its EXR channel names.
    #[must_use]
    pub fn channels(self) -> &'static [&'static str] {
        self.spec().channels
    }

    /// The AOV a name means (a name of [`AOVS`]), `None` for anything else.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Aov> {
        AOVS.iter().find(|s| s.name == name).map(|s| s.aov)
    }

    /// True for the flow AOVs, which need the flow pass.
    #[must_use]
    pub fn is_flow(self) -> bool {
        self.spec().source == AovSource::Flow
    }

    /// True for the sensor's planes (`raw`, `electrons`).
    #[must_use]
    pub fn is_sensor(self) -> bool {
        self.spec().source == AovSource::Sensor
    }

    /// True for the ground-truth AOVs (a display holding one gets the frame's ID and camera sidecars).
    #[must_use]
    pub fn is_ground_truth(self) -> bool {
        self.spec().group == AovGroup::GroundTruth
    }

    /// What `--aov all` adds: the ground-truth AOVs, then the texture AOVs, in table order.
    pub fn all_extra() -> impl Iterator<Item = Aov> {
        let in_group = |g: AovGroup| AOVS.iter().filter(move |s| s.group == g).map(|s| s.aov);
        in_group(GroundTruth).chain(in_group(Texture))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_row_stands_at_its_variant_and_names_are_unique() {
        for (i, s) in AOVS.iter().enumerate() {
            assert_eq!(s.aov as usize, i, "{}", s.name);
            assert_eq!(Aov::from_name(s.name), Some(s.aov));
            assert!(!s.channels.is_empty());
        }
        let mut names: Vec<&str> = AOVS.iter().map(|s| s.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), AOVS.len());
    }

    #[test]
    fn all_extra_is_the_ground_truth_then_the_textures() {
        let all: Vec<Aov> = Aov::all_extra().collect();
        assert_eq!(all.len(), 12);
        assert_eq!(all[0], Aov::CameraZ);
        assert_eq!(&all[10..], &[Aov::Albedo, Aov::Uv]);
        assert!(all[..10].iter().all(|a| a.is_ground_truth()));
        assert_eq!(
            AOVS.iter().filter(|s| s.kind == AovKind::Id).count(),
            3,
            "the three IDs are the only integer channels"
        );
    }
}
