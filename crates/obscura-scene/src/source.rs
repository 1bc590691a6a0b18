//! A scene file read frame by frame: the one shape every reader gives the renderer.
//!
//! A file holds either **images** (a RIB file's worlds, each with its frame number, or the one image of
//! a glTF or OBJ file) or an **animation** that can be posed at any frame (a glTF file with
//! animations: frame `N` at `(N − 1)/fps` seconds). [`SceneSource`] answers both: the images in file
//! order, the animation's length, and the scene of an image or of a frame. The renderer's sequence
//! loop, its flow across frames and its resume run on this interface alone, so a new format (USD's time
//! codes) is one more implementation.

use std::path::{Path, PathBuf};

use obscura_host::CameraDesc;

use crate::rib::Frame;
use crate::types::Scene;
use crate::{LoadError, gltf_scene};

/// An animation a source can pose at any frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Animation {
    /// Its length in seconds.
    pub seconds: f32,
    /// Frames per second: frame `N` is posed at `(N − 1)/fps` seconds.
    pub fps: f32,
}

/// One image a file holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImageInfo {
    /// Its frame number: `FrameBegin`'s, else its position among the file's images (from 1).
    pub number: u32,
    /// True when the file numbers it (`FrameBegin`); an unnumbered single image is a still, written
    /// as whichever frames are asked for.
    pub numbered: bool,
    /// Where it starts (`file:line` of RIB's `WorldBegin`); empty when the file has one image.
    pub label: String,
}

/// A scene file, frame by frame.
pub trait SceneSource {
    /// The directory the scene's relative paths (textures, archives) are read from.
    fn base_dir(&self) -> &Path;

    /// The images the file holds, in file order (at least one).
    fn images(&self) -> &[ImageInfo];

    /// The scene of image `index` (an index into [`SceneSource::images`]).
    ///
    /// # Errors
    /// A [`LoadError`] naming the file, for a source that reads lazily.
    fn image(&self, index: usize) -> Result<Scene, LoadError>;

    /// `Some` when the file is an animation that [`SceneSource::frame`] poses at any frame.
    fn animation(&self) -> Option<Animation> {
        None
    }

    /// The scene at frame `number`: an animation posed at that frame; otherwise the first image the
    /// file numbers so, or its single still.
    ///
    /// # Errors
    /// A [`LoadError`] naming the file; [`LoadError::NoFrame`] when the file holds no such frame.
    fn frame(&self, number: u32) -> Result<Scene, LoadError> {
        let images = self.images();
        match images.iter().position(|i| i.number == number) {
            Some(index) => self.image(index),
            None if images.len() == 1 && !images[0].numbered => self.image(0),
            None => Err(LoadError::NoFrame(number)),
        }
    }
}

/// Images read at once (RIB, OBJ, a still glTF, the built-in scene).
#[derive(Debug, Clone)]
pub struct Images {
    info: Vec<ImageInfo>,
    scenes: Vec<Scene>,
    base_dir: PathBuf,
}

impl Images {
    /// The images of `frames`, whose relative paths are read from `base_dir`.
    #[must_use]
    pub fn new(frames: Vec<Frame>, base_dir: PathBuf) -> Self {
        let (info, scenes) = frames
            .into_iter()
            .map(|f| {
                let info = ImageInfo {
                    number: f.number,
                    numbered: f.numbered,
                    label: f.world,
                };
                (info, f.scene)
            })
            .unzip();
        Images {
            info,
            scenes,
            base_dir,
        }
    }
}

impl SceneSource for Images {
    fn base_dir(&self) -> &Path {
        &self.base_dir
    }

    fn images(&self) -> &[ImageInfo] {
        &self.info
    }

    fn image(&self, index: usize) -> Result<Scene, LoadError> {
        Ok(self.scenes[index].clone())
    }
}

/// A glTF file with animations, posed per frame ([`gltf_scene::load_gltf_at`]).
#[derive(Debug, Clone)]
pub struct AnimatedGltf {
    path: PathBuf,
    camera: CameraDesc,
    animation: Animation,
    info: [ImageInfo; 1],
    base_dir: PathBuf,
}

impl SceneSource for AnimatedGltf {
    fn base_dir(&self) -> &Path {
        &self.base_dir
    }

    fn images(&self) -> &[ImageInfo] {
        &self.info
    }

    fn image(&self, _: usize) -> Result<Scene, LoadError> {
        self.frame(1)
    }

    fn animation(&self) -> Option<Animation> {
        Some(self.animation)
    }

    fn frame(&self, number: u32) -> Result<Scene, LoadError> {
        let seconds = (number as f32 - 1.0) / self.animation.fps;
        Ok(gltf_scene::load_gltf_at(
            &self.path,
            self.camera.clone(),
            seconds,
            self.animation.fps,
        )?)
    }
}

/// Opens the scene file at `path` frame by frame: a RIB file's images, an OBJ file's one image, a glTF
/// file's one image or, when it has animations, the animation at `fps` frames per second. `camera`
/// gives what a file does not set (the image size of glTF and OBJ).
///
/// # Errors
/// The [`LoadError`] of the file.
pub fn open(path: &Path, camera: CameraDesc, fps: f32) -> Result<Box<dyn SceneSource>, LoadError> {
    let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let frames = crate::load_frames(path, camera.clone())?;
    if let [still] = frames.as_slice()
        && !still.numbered
        && let Some(seconds) = still.scene.animation_seconds
    {
        return Ok(Box::new(AnimatedGltf {
            path: path.to_path_buf(),
            camera,
            animation: Animation { seconds, fps },
            info: [ImageInfo {
                number: 1,
                numbered: false,
                label: String::new(),
            }],
            base_dir,
        }));
    }
    Ok(Box::new(Images::new(frames, base_dir)))
}

#[cfg(test)]
mod tests {
    use obscura_sdk::Format;

    use super::*;

    fn camera() -> CameraDesc {
        CameraDesc::new(Format::new(64, 48))
    }

    /// A RIB file of three worlds numbered by `FrameBegin` 5, 7 and 9, the middle one with another
    /// field of view.
    fn three_frames(dir: &Path) -> PathBuf {
        let frame = |n: u32, fov: u32| {
            format!(
                "FrameBegin {n}\nFormat 64 48 1\nProjection \"perspective\" \"fov\" [{fov}]\nWorldBegin\n\
                 Sphere 1 -1 1 360\nWorldEnd\nFrameEnd\n"
            )
        };
        let path = dir.join("three.rib");
        std::fs::write(&path, [frame(5, 40), frame(7, 55), frame(9, 40)].concat()).unwrap();
        path
    }

    #[test]
    fn a_rib_file_is_its_numbered_images_and_a_frame_is_the_image_of_that_number() {
        let dir = tempfile::tempdir().unwrap();
        let path = three_frames(dir.path());
        let source = open(&path, camera(), 24.0).unwrap();
        let numbers: Vec<(u32, bool)> = source.images().iter().map(|i| (i.number, i.numbered)).collect();
        assert_eq!(numbers, [(5, true), (7, true), (9, true)]);
        assert!(
            source.images()[1].label.ends_with("three.rib:11"),
            "{}",
            source.images()[1].label
        );
        assert_eq!(source.animation(), None);
        assert_eq!(source.base_dir(), dir.path());
        // The same scenes as the reader gives, in file order.
        let frames = crate::load_frames(&path, camera()).unwrap();
        assert_eq!(source.frame(7).unwrap(), frames[1].scene);
        assert_eq!(source.image(2).unwrap(), frames[2].scene);
        assert_ne!(source.frame(7).unwrap(), source.frame(5).unwrap());
        let missing = source.frame(6).unwrap_err();
        assert!(matches!(missing, LoadError::NoFrame(6)), "{missing}");
        assert_eq!(missing.to_string(), "the scene holds no frame 6");
    }

    #[test]
    fn a_still_is_every_frame() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("still.rib");
        std::fs::write(&path, "Format 64 48 1\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n").unwrap();
        let source = open(&path, camera(), 24.0).unwrap();
        assert_eq!(source.images().len(), 1);
        assert!(!source.images()[0].numbered);
        assert_eq!(source.frame(1).unwrap(), source.frame(1234).unwrap());
    }

    #[test]
    fn an_animated_gltf_is_posed_at_each_frame_of_its_fps() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/animated/boxes.gltf");
        let source = open(&path, camera(), 12.0).unwrap();
        let animation = source.animation().expect("boxes.gltf has animations");
        assert_eq!(animation.fps, 12.0);
        assert!(animation.seconds > 0.0);
        // Frame N is the animation at (N − 1)/fps seconds, as the reader poses it.
        let third = gltf_scene::load_gltf_at(&path, camera(), 2.0 / 12.0, 12.0).unwrap();
        assert_eq!(source.frame(3).unwrap(), third);
        assert_eq!(source.image(0).unwrap(), source.frame(1).unwrap());
        assert_ne!(
            source.frame(3).unwrap(),
            source.frame(1).unwrap(),
            "the boxes move"
        );
    }
}
