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
