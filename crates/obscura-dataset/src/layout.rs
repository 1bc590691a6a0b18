//! The dataset layout: where every file of a dataset is, by camera and frame. The layout is a
//! contract with the tools that read a dataset, versioned by [`LAYOUT_VERSION`] (written into
//! `dataset.json`); a change that moves or renames a file bumps it.
//!
//! ```text
//! DIR/dataset.json                                   the manifest (layout version, cameras, frames, options, files, warnings)
//! DIR/images/<camera>/<frame>.exr                    beauty + ground truth (see IMAGE_AOVS)
//! DIR/images/<camera>/<frame>.png                    8-bit preview of the beauty
//! DIR/images/<camera>/<frame>.camera.json            the frame's camera (obscura-camera/1), "complete": true once written
//! DIR/images/<camera>/<frame>.ids.json               the object/instance/material ID table
//! DIR/colmap/cameras.txt, images.txt (rigs.txt, frames.txt)
//! DIR/transforms.json                                nerfstudio, one camera
//! DIR/nerfstudio/<camera>/transforms.json            nerfstudio, one per camera of a rig
//! DIR/gsplat/cameras.json
//! DIR/annotations/<camera>/<frame>.json              COCO-style boxes
//! DIR/tracks/<camera>.npz                            point tracks over every frame
//! DIR/correspondences/<camA>__<camB>/<frame>.npz     cross-camera correspondences
//! ```
//!
//! `<frame>` is the frame number zero-padded to four digits (`0012`), as `obscura render` numbers a
//! sequence; `<camera>` is the rig camera's name (`camera` without a rig).

use std::path::{Path, PathBuf};

use obscura_scene::Aov;

/// The layout's version, written as `dataset.json`'s `"layout"`.
pub const LAYOUT_VERSION: &str = "obscura-dataset/1";

/// The name of the one camera of a dataset rendered without a rig.
pub const DEFAULT_CAMERA: &str = "camera";

/// The AOVs every frame's EXR holds beside the beauty: what the annotations are computed from
/// (depth along the ray and along +Z, world and camera-space positions, normals, object and instance
/// IDs).
pub const IMAGE_AOVS: [Aov; 11] = [
    Aov::Ci,
    Aov::Alpha,
    Aov::Z,
    Aov::N,
    Aov::P,
    Aov::CameraDirection,
    Aov::CameraZ,
    Aov::Distance,
    Aov::PCamera,
    Aov::ObjectId,
    Aov::InstanceId,
];

/// The paths of one dataset directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    root: PathBuf,
}

/// A frame number as it appears in file names: four digits at least.
#[must_use]
pub fn frame_name(frame: u32) -> String {
    format!("{frame:04}")
}

impl Layout {
    /// The layout of the dataset at `root`.
    #[must_use]
    pub fn new(root: impl Into<PathBuf>) -> Self {
        Layout { root: root.into() }
    }

    /// The dataset's directory.
    #[must_use]
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// `DIR/dataset.json`.
    #[must_use]
    pub fn manifest(&self) -> PathBuf {
        self.root.join("dataset.json")
    }

    /// `images/<camera>`, relative to the root.
    #[must_use]
    pub fn images_dir(camera: &str) -> PathBuf {
        Path::new("images").join(camera)
    }

    /// `images/<camera>/<frame>.exr`, relative to the root.
    #[must_use]
    pub fn exr(camera: &str, frame: u32) -> PathBuf {
        Self::images_dir(camera).join(format!("{}.exr", frame_name(frame)))
    }

    /// `images/<camera>/<frame>.png`, relative to the root.
    #[must_use]
    pub fn png(camera: &str, frame: u32) -> PathBuf {
        Self::images_dir(camera).join(format!("{}.png", frame_name(frame)))
    }

    /// `images/<camera>/<frame>.camera.json`, relative to the root: the sidecar the frame pipeline
    /// writes last, `"complete": true` once every file of the frame is written.
    #[must_use]
    pub fn camera_json(camera: &str, frame: u32) -> PathBuf {
        Self::images_dir(camera).join(format!("{}.camera.json", frame_name(frame)))
    }

    /// `images/<camera>/<frame>.ids.json`, relative to the root.
    #[must_use]
    pub fn ids_json(camera: &str, frame: u32) -> PathBuf {
        Self::images_dir(camera).join(format!("{}.ids.json", frame_name(frame)))
    }

    /// `annotations/<camera>/<frame>.json`, relative to the root.
    #[must_use]
    pub fn annotations(camera: &str, frame: u32) -> PathBuf {
        Path::new("annotations")
            .join(camera)
            .join(format!("{}.json", frame_name(frame)))
    }

    /// `tracks/<camera>.npz`, relative to the root.
    #[must_use]
    pub fn tracks(camera: &str) -> PathBuf {
        Path::new("tracks").join(format!("{camera}.npz"))
    }

    /// `correspondences/<a>__<b>/<frame>.npz`, relative to the root.
    #[must_use]
    pub fn correspondences(a: &str, b: &str, frame: u32) -> PathBuf {
        Path::new("correspondences")
            .join(format!("{a}__{b}"))
            .join(format!("{}.npz", frame_name(frame)))
    }

    /// `path` (relative to the root) under the root.
    #[must_use]
    pub fn at(&self, path: &Path) -> PathBuf {
        self.root.join(path)
    }
}

/// Checks that `name` can name a camera's directory: not empty, at most 64 characters of ASCII
/// letters, digits, `-`, `_` and `.`, not starting with `.`, and without `__` (which separates the
/// two cameras of a correspondence directory).
///
/// # Errors
/// A message quoting the name and saying what is allowed.
pub fn check_camera_name(name: &str) -> Result<(), String> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && !name.starts_with('.')
        && !name.contains("__")
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'-' | b'_' | b'.'));
    if ok {
        Ok(())
    } else {
        Err(format!(
            "camera name '{name}': expected 1 to 64 ASCII letters, digits, '-', '_' or '.', not starting with '.' and without '__' (it names a directory)"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_follow_the_contract() {
        assert_eq!(Layout::exr("left", 12), Path::new("images/left/0012.exr"));
        assert_eq!(Layout::png("left", 12345), Path::new("images/left/12345.png"));
        assert_eq!(
            Layout::camera_json("camera", 1),
            Path::new("images/camera/0001.camera.json")
        );
        assert_eq!(Layout::annotations("c", 3), Path::new("annotations/c/0003.json"));
        assert_eq!(Layout::tracks("c"), Path::new("tracks/c.npz"));
        assert_eq!(
            Layout::correspondences("left", "right", 7),
            Path::new("correspondences/left__right/0007.npz")
        );
        assert_eq!(Layout::new("/d").manifest(), Path::new("/d/dataset.json"));
    }

    #[test]
    fn camera_names_must_be_directory_names() {
        for good in ["camera", "cam0", "ring-3", "left.rgb"] {
            assert!(check_camera_name(good).is_ok(), "{good}");
        }
        for bad in ["", ".hidden", "a/b", "a__b", "ç", "a b"] {
            let e = check_camera_name(bad).unwrap_err();
            assert!(e.contains(&format!("'{bad}'")), "{e}");
        }
    }
}
