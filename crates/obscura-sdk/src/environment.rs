//! What the host tells a projection about the render (`RixProjectionEnvironment`).

use crate::geometry::{Matrix4, Point2};
use crate::property::DeepMetric;

/// Image size and pixel shape (RIB `Format W H pa`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Format {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Pixel aspect ratio: the width of one pixel over its height.
    pub pixel_aspect: f32,
}

impl Format {
    /// A format with square pixels.
    #[must_use]
    pub const fn new(width: u32, height: u32) -> Self {
        Format {
            width,
            height,
            pixel_aspect: 1.0,
        }
    }

    /// Frame aspect ratio `a = W·pa / H`.
    #[must_use]
    pub fn frame_aspect(&self) -> f32 {
        self.width as f32 * self.pixel_aspect / self.height as f32
    }
}

/// The screen window (RIB `ScreenWindow l r b t`): the region of screen space the image spans.
/// Screen space has x to the right and y **up**.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenWindow {
    /// Screen x at the image's left edge.
    pub left: f32,
    /// Screen x at the image's right edge.
    pub right: f32,
    /// Screen y at the image's bottom edge.
    pub bottom: f32,
    /// Screen y at the image's top edge.
    pub top: f32,
}

impl ScreenWindow {
    /// Makes a window from RIB's order `l r b t`.
    #[must_use]
    pub const fn new(left: f32, right: f32, bottom: f32, top: f32) -> Self {
        ScreenWindow {
            left,
            right,
            bottom,
            top,
        }
    }

    /// RenderMan's default window for a format: with frame aspect `a = W·pa/H`, `(−a, a, −1, 1)` when
    /// `a ≥ 1`, else `(−1, 1, −1/a, 1/a)`. The square `[−1, 1]²` spans the smaller image dimension.
    #[must_use]
    pub fn default_for(format: Format) -> Self {
        let a = format.frame_aspect();
        if a >= 1.0 {
            ScreenWindow::new(-a, a, -1.0, 1.0)
        } else {
            ScreenWindow::new(-1.0, 1.0, -1.0 / a, 1.0 / a)
        }
    }

    /// `r − l`.
    #[must_use]
    pub fn width(&self) -> f32 {
        self.right - self.left
    }

    /// `t − b`.
    #[must_use]
    pub fn height(&self) -> f32 {
        self.top - self.bottom
    }

    /// Maps a raster position (pixels, y down, (0, 0) the top-left corner) to screen space:
    /// `sx = l + (x/W)·(r − l)`, `sy = t − (y/H)·(t − b)`.
    #[must_use]
    pub fn raster_to_screen(&self, format: Format, x: f64, y: f64) -> Point2 {
        let sx = self.left as f64 + (x / format.width as f64) * self.width() as f64;
        let sy = self.top as f64 - (y / format.height as f64) * self.height() as f64;
        Point2::new(sx as f32, sy as f32)
    }

    /// The inverse of [`ScreenWindow::raster_to_screen`].
    #[must_use]
    pub fn screen_to_raster(&self, format: Format, p: Point2) -> (f64, f64) {
        let x = (p.x as f64 - self.left as f64) / self.width() as f64 * format.width as f64;
        let y = (self.top as f64 - p.y as f64) / self.height() as f64 * format.height as f64;
        (x, y)
    }

    /// The size of one pixel in screen units, `((r − l)/W, (t − b)/H)`.
    #[must_use]
    pub fn pixel_size(&self, format: Format) -> (f32, f32) {
        (
            self.width() / format.width as f32,
            self.height() / format.height as f32,
        )
    }
}

/// One motion sample of the world-to-camera transform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionSample {
    /// The sample's time, in the scene's shutter units.
    pub time: f32,
    /// World-to-camera at that time (row-vector convention, see [`Matrix4`]).
    pub world_to_camera: Matrix4,
}

/// Everything the host knows about the render that a projection may need (`RixProjectionEnvironment`).
///
/// Read-only except for one field, the deep metric, exactly as the RenderMan document says: a projection
/// may set it in [`crate::ProjectionFactory::create_projection`] to tell the host how to measure depth.
/// (RenderMan 23 moved the same information to the `DeepMetric` property; Obscura honours both, and the
/// property wins when a projection answers it.)
#[derive(Debug, Clone, PartialEq)]
pub struct ProjectionEnvironment {
    format: Format,
    screen_window: ScreenWindow,
    shutter_open: f32,
    shutter_close: f32,
    clipping_near: f32,
    clipping_far: f32,
    world_to_camera: Vec<MotionSample>,
    deep_metric: DeepMetric,
}

impl ProjectionEnvironment {
    /// Makes an environment: the host's job. `world_to_camera` is sorted by time; an empty list means
    /// the identity.
    #[must_use]
    pub fn new(
        format: Format,
        screen_window: ScreenWindow,
        shutter: (f32, f32),
        clipping: (f32, f32),
        mut world_to_camera: Vec<MotionSample>,
    ) -> Self {
        if world_to_camera.is_empty() {
            world_to_camera.push(MotionSample {
                time: shutter.0,
                world_to_camera: Matrix4::IDENTITY,
            });
        }
        world_to_camera.sort_by(|a, b| a.time.total_cmp(&b.time));
        ProjectionEnvironment {
            format,
            screen_window,
            shutter_open: shutter.0,
            shutter_close: shutter.1,
            clipping_near: clipping.0,
            clipping_far: clipping.1,
            world_to_camera,
            deep_metric: DeepMetric::CameraZ,
        }
    }

    /// An environment with the default screen window, an instantaneous shutter at 0, RenderMan's
    /// default clipping (0.1, ∞) and an identity camera: handy in tests and tools.
    #[must_use]
    pub fn for_format(format: Format) -> Self {
        Self::new(
            format,
            ScreenWindow::default_for(format),
            (0.0, 0.0),
            (0.1, f32::INFINITY),
            Vec::new(),
        )
    }

    /// Image size and pixel aspect.
    #[must_use]
    pub fn format(&self) -> Format {
        self.format
    }
    /// Image width in pixels.
    #[must_use]
    pub fn width(&self) -> u32 {
        self.format.width
    }
    /// Image height in pixels.
    #[must_use]
    pub fn height(&self) -> u32 {
        self.format.height
    }
    /// Pixel aspect ratio (width / height of one pixel).
    #[must_use]
    pub fn pixel_aspect_ratio(&self) -> f32 {
        self.format.pixel_aspect
    }
    /// The screen window.
    #[must_use]
    pub fn screen_window(&self) -> ScreenWindow {
        self.screen_window
    }
    /// Shutter opening time (scene units).
    #[must_use]
    pub fn shutter_open(&self) -> f32 {
        self.shutter_open
    }
    /// Shutter closing time (scene units).
    #[must_use]
    pub fn shutter_close(&self) -> f32 {
        self.shutter_close
    }
    /// Near clipping distance (camera-space z of the near plane).
    #[must_use]
    pub fn clipping_near(&self) -> f32 {
        self.clipping_near
    }
    /// Far clipping distance (camera-space z of the far plane).
    #[must_use]
    pub fn clipping_far(&self) -> f32 {
        self.clipping_far
    }
    /// The world-to-camera motion samples, sorted by time; at least one.
    #[must_use]
    pub fn world_to_camera(&self) -> &[MotionSample] {
        &self.world_to_camera
    }
    /// The deep metric the projection asked for (default [`DeepMetric::CameraZ`]).
    #[must_use]
    pub fn deep_metric(&self) -> DeepMetric {
        self.deep_metric
    }
    /// The one writable field: how the host measures depth for this projection's rays.
    pub fn set_deep_metric(&mut self, metric: DeepMetric) {
        self.deep_metric = metric;
    }
    /// The size of one pixel in screen units, `((r − l)/W, (t − b)/H)`.
    #[must_use]
    pub fn pixel_size(&self) -> (f32, f32) {
        self.screen_window.pixel_size(self.format)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_window_spans_the_smaller_dimension() {
        let w = ScreenWindow::default_for(Format::new(1920, 1080));
        assert!((w.right - 1.777_777_8).abs() < 1e-6);
        assert_eq!((w.bottom, w.top), (-1.0, 1.0));
        let tall = ScreenWindow::default_for(Format::new(1080, 1920));
        assert_eq!((tall.left, tall.right), (-1.0, 1.0));
        assert!((tall.top - 1.777_777_8).abs() < 1e-6);
        // Pixel aspect widens the frame: 100×100 pixels of aspect 2 make a 2:1 frame.
        let pa = ScreenWindow::default_for(Format {
            width: 100,
            height: 100,
            pixel_aspect: 2.0,
        });
        assert_eq!((pa.left, pa.right), (-2.0, 2.0));
    }

    #[test]
    fn raster_corners_map_to_window_corners_and_back() {
        let f = Format::new(640, 480);
        let w = ScreenWindow::default_for(f);
        assert_eq!(w.raster_to_screen(f, 0.0, 0.0), Point2::new(w.left, w.top));
        assert_eq!(
            w.raster_to_screen(f, 640.0, 480.0),
            Point2::new(w.right, w.bottom)
        );
        let (x, y) = w.screen_to_raster(f, w.raster_to_screen(f, 123.25, 77.5));
        assert!((x - 123.25).abs() < 1e-4 && (y - 77.5).abs() < 1e-4);
    }

    #[test]
    fn only_the_deep_metric_is_writable() {
        let mut env = ProjectionEnvironment::for_format(Format::new(4, 4));
        assert_eq!(env.deep_metric(), DeepMetric::CameraZ);
        env.set_deep_metric(DeepMetric::RayLength);
        assert_eq!(env.deep_metric(), DeepMetric::RayLength);
        assert_eq!(env.world_to_camera().len(), 1);
    }
}
