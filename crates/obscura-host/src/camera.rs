//! The camera description a host builds from a scene or the command line, and its raster → screen map.
//!
//! Conventions (normative, `conventions.md`): raster space has (0, 0) at the image's top-left corner,
//! y down, pixel (i, j)'s centre at (i + ½, j + ½); screen space is the screen window's, y up;
//! `sx = l + (x/W)·(r − l)`, `sy = t − (y/H)·(t − b)`. The crop window (NDC, y down) selects which pixels
//! are rendered and never changes the mapping: a crop is the same region of the full image.

use obscura_sdk::{Format, Matrix4, MotionSample, Point2, ProjectionEnvironment, ScreenWindow};

use crate::aperture::{ApertureDesc, ApertureError, ApertureWarp};
use crate::shutter::{ShutterDesc, ShutterError, ShutterWarp};

/// `CropWindow xmin xmax ymin ymax` in NDC: (0, 0) the top-left corner, (1, 1) the bottom-right.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CropWindow {
    /// Left edge, NDC.
    pub x_min: f32,
    /// Right edge, NDC.
    pub x_max: f32,
    /// Top edge, NDC.
    pub y_min: f32,
    /// Bottom edge, NDC.
    pub y_max: f32,
}

impl Default for CropWindow {
    fn default() -> Self {
        CropWindow {
            x_min: 0.0,
            x_max: 1.0,
            y_min: 0.0,
            y_max: 1.0,
        }
    }
}

/// A rectangle of pixels: columns `x0..x1`, rows `y0..y1` (half-open).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelRect {
    /// First column.
    pub x0: u32,
    /// One past the last column.
    pub x1: u32,
    /// First row.
    pub y0: u32,
    /// One past the last row.
    pub y1: u32,
}

impl PixelRect {
    /// Columns in the rectangle.
    #[must_use]
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }
    /// Rows in the rectangle.
    #[must_use]
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }
    /// Pixels in the rectangle.
    #[must_use]
    pub fn len(&self) -> usize {
        self.width() as usize * self.height() as usize
    }
    /// True when it holds no pixel.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl CropWindow {
    /// The pixels the crop selects, as the RenderMan Interface specification and pbrt define it:
    /// columns `ceil(W·x_min) .. ceil(W·x_max)`, rows likewise. A thousandth of a pixel is forgiven
    /// before rounding up, so that `0.1` (stored as 0.100000001) of 640 pixels is 64, not 65.
    #[must_use]
    pub fn pixels(&self, format: Format) -> PixelRect {
        let edge = |n: u32, t: f32| ((n as f64 * t as f64 - 1e-3).ceil().max(0.0) as u32).min(n);
        PixelRect {
            x0: edge(format.width, self.x_min),
            x1: edge(format.width, self.x_max),
            y0: edge(format.height, self.y_min),
            y1: edge(format.height, self.y_max),
        }
    }
}

/// A camera description is inconsistent.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// `Format` is not positive, or its pixel aspect ratio is outside [`PIXEL_ASPECT_RANGE`].
    #[error(
        "Format: expected a positive width and height and a pixel aspect ratio in [1e-6, 1e6], got {width}x{height} with pixel aspect {pixel_aspect:?}"
    )]
    Format {
        /// Width given.
        width: u32,
        /// Height given.
        height: u32,
        /// Pixel aspect given.
        pixel_aspect: f32,
    },
    /// `ScreenWindow` has no area, is not finite or reaches beyond [`SCREEN_WINDOW_LIMIT`].
    #[error(
        "ScreenWindow: expected finite left < right and bottom < top within [-1e6, 1e6], got {0:?} {1:?} {2:?} {3:?}"
    )]
    ScreenWindow(f32, f32, f32, f32),
    /// No `ScreenWindow` was given and the default one of the format's frame aspect is unusable.
    #[error(
        "Format {width}x{height} with pixel aspect {pixel_aspect:?}: the frame aspect {aspect:e} puts the default \
         ScreenWindow at {left:?} {right:?} {bottom:?} {top:?}, beyond [-1e6, 1e6]: expected a frame aspect in [1e-6, 1e6]"
    )]
    FrameAspect {
        /// Width given.
        width: u32,
        /// Height given.
        height: u32,
        /// Pixel aspect given.
        pixel_aspect: f32,
        /// `width · pixel_aspect / height`.
        aspect: f64,
        /// The default window's left edge.
        left: f32,
        /// Its right edge.
        right: f32,
        /// Its bottom edge.
        bottom: f32,
        /// Its top edge.
        top: f32,
    },
    /// `CropWindow` is outside [0, 1] or selects no pixel.
    #[error(
        "CropWindow: expected 0 <= xmin < xmax <= 1 and 0 <= ymin < ymax <= 1 selecting at least one pixel, got {0} {1} {2} {3}"
    )]
    CropWindow(f32, f32, f32, f32),
    /// `Shutter` is backwards or not finite.
    #[error("Shutter: expected finite open <= close, got {0} {1}")]
    Shutter(f32, f32),
    /// `Clipping` is not `0 < near < far`.
    #[error("Clipping: expected 0 < near < far (far may be infinite), got {0} {1}")]
    Clipping(f32, f32),
    /// The aperture description is out of range.
    #[error(transparent)]
    Aperture(#[from] ApertureError),
    /// The shutter-opening description is out of range.
    #[error(transparent)]
    ShutterOpening(#[from] ShutterError),
}

/// The pixel aspect ratios a `Format` may have: OpenEXR's own range (its files refuse others).
pub const PIXEL_ASPECT_RANGE: (f32, f32) = (1e-6, 1e6);

/// The largest magnitude of a `ScreenWindow` edge. Beyond it screen coordinates squared overflow
/// `f32` in the projections' ray math (every ray would be NaN and culled).
pub const SCREEN_WINDOW_LIMIT: f32 = 1e6;

/// Everything about the camera that is not the projection: what RIB's `Format`, `ScreenWindow`,
/// `CropWindow`, `Shutter`, `Clipping`, the camera transform and `Camera` options say.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraDesc {
    /// Image size and pixel aspect.
    pub format: Format,
    /// The screen window; `None` for RenderMan's default from the frame aspect.
    pub screen_window: Option<ScreenWindow>,
    /// Which pixels to render.
    pub crop_window: CropWindow,
    /// Shutter open and close times (scene units).
    pub shutter: (f32, f32),
    /// Near and far clipping planes.
    pub clipping: (f32, f32),
    /// World-to-camera motion samples (empty: identity).
    pub world_to_camera: Vec<MotionSample>,
    /// `apertureNSides`, `apertureAngle`, `apertureRoundness`, `apertureDensity`, `dofaspect`.
    pub aperture: ApertureDesc,
    /// `shutterOpenTime`, `shutterCloseTime`, `shutteropening`.
    pub shutter_opening: ShutterDesc,
}

impl CameraDesc {
    /// RenderMan's defaults for a format: default window, no crop, shutter (0, 0), clipping (0.1, ∞),
    /// identity camera, circular aperture, instantaneous shutter opening.
    #[must_use]
    pub fn new(format: Format) -> Self {
        CameraDesc {
            format,
            screen_window: None,
            crop_window: CropWindow::default(),
            shutter: (0.0, 0.0),
            clipping: (0.1, f32::INFINITY),
            world_to_camera: Vec::new(),
            aperture: ApertureDesc::default(),
            shutter_opening: ShutterDesc::default(),
        }
    }

    /// Checks every field; the errors name the RIB request at fault.
    ///
    /// # Errors
    /// The first inconsistency found.
    pub fn validate(&self) -> Result<(), CameraError> {
        let f = self.format;
        let (pa_min, pa_max) = PIXEL_ASPECT_RANGE;
        if f.width == 0 || f.height == 0 || !(pa_min..=pa_max).contains(&f.pixel_aspect) {
            return Err(CameraError::Format {
                width: f.width,
                height: f.height,
                pixel_aspect: f.pixel_aspect,
            });
        }
        let w = self.screen_window();
        let bounded = [w.left, w.right, w.bottom, w.top]
            .iter()
            .all(|v| v.abs() <= SCREEN_WINDOW_LIMIT);
        if !bounded || w.left >= w.right || w.bottom >= w.top {
            if self.screen_window.is_none() {
                return Err(CameraError::FrameAspect {
                    width: f.width,
                    height: f.height,
                    pixel_aspect: f.pixel_aspect,
                    aspect: f64::from(f.width) * f64::from(f.pixel_aspect) / f64::from(f.height),
                    left: w.left,
                    right: w.right,
                    bottom: w.bottom,
                    top: w.top,
                });
            }
            return Err(CameraError::ScreenWindow(w.left, w.right, w.bottom, w.top));
        }
        let c = self.crop_window;
        let in_unit = [c.x_min, c.x_max, c.y_min, c.y_max]
            .iter()
            .all(|v| (0.0..=1.0).contains(v));
        if !in_unit || c.x_min >= c.x_max || c.y_min >= c.y_max || c.pixels(f).is_empty() {
            return Err(CameraError::CropWindow(c.x_min, c.x_max, c.y_min, c.y_max));
        }
        let (o, cl) = self.shutter;
        if !(o.is_finite() && cl.is_finite() && o <= cl) {
            return Err(CameraError::Shutter(o, cl));
        }
        let (n, fa) = self.clipping;
        if !(n.is_finite() && n > 0.0 && fa > n) {
            return Err(CameraError::Clipping(n, fa));
        }
        ApertureWarp::new(&self.aperture)?;
        ShutterWarp::new(&self.shutter_opening)?;
        Ok(())
    }

    /// The screen window in force: the explicit one or the default for the format.
    #[must_use]
    pub fn screen_window(&self) -> ScreenWindow {
        self.screen_window
            .unwrap_or_else(|| ScreenWindow::default_for(self.format))
    }

    /// The pixels to render.
    #[must_use]
    pub fn pixels(&self) -> PixelRect {
        self.crop_window.pixels(self.format)
    }

    /// Maps a raster position to screen space (see the module documentation).
    #[must_use]
    pub fn raster_to_screen(&self, x: f64, y: f64) -> Point2 {
        self.screen_window().raster_to_screen(self.format, x, y)
    }

    /// The environment handed to the projection.
    #[must_use]
    pub fn environment(&self) -> ProjectionEnvironment {
        let motion = if self.world_to_camera.is_empty() {
            vec![MotionSample {
                time: self.shutter.0,
                world_to_camera: Matrix4::IDENTITY,
            }]
        } else {
            self.world_to_camera.clone()
        };
        ProjectionEnvironment::new(
            self.format,
            self.screen_window(),
            self.shutter,
            self.clipping,
            motion,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hd_default_window_is_16_by_9() {
        let cam = CameraDesc::new(Format::new(1920, 1080));
        let w = cam.screen_window();
        assert!((w.left + 1.7778).abs() < 1e-4 && (w.right - 1.7778).abs() < 1e-4);
        assert_eq!((w.bottom, w.top), (-1.0, 1.0));
        // Pixel (0, 0)'s centre is half a pixel in from the top-left corner of the window.
        let p = cam.raster_to_screen(0.5, 0.5);
        assert!((p.x - (-1.7778 + 1.7778 / 1920.0)).abs() < 1e-4);
        assert!((p.y - (1.0 - 1.0 / 1080.0)).abs() < 1e-6);
    }

    #[test]
    fn crop_selects_pixels_without_moving_the_camera() {
        let mut cam = CameraDesc::new(Format::new(640, 480));
        let full = cam.raster_to_screen(100.5, 200.5);
        cam.crop_window = CropWindow {
            x_min: 0.1,
            x_max: 0.5,
            y_min: 0.25,
            y_max: 1.0,
        };
        assert_eq!(
            cam.pixels(),
            PixelRect {
                x0: 64,
                x1: 320,
                y0: 120,
                y1: 480
            }
        );
        assert_eq!(cam.raster_to_screen(100.5, 200.5), full);
        assert_eq!(
            cam.environment().screen_window(),
            CameraDesc::new(Format::new(640, 480)).screen_window()
        );
        // Adjacent crops tile the image with no pixel twice and none missed.
        let columns = |x_min, x_max| {
            CropWindow {
                x_min,
                x_max,
                y_min: 0.0,
                y_max: 1.0,
            }
            .pixels(cam.format)
        };
        let (left, right) = (columns(0.0, 0.37), columns(0.37, 1.0));
        assert_eq!(left.x1, right.x0);
        assert_eq!(left.width() + right.width(), 640);
    }

    #[test]
    fn inconsistent_descriptions_name_the_request() {
        let mut cam = CameraDesc::new(Format::new(64, 64));
        cam.screen_window = Some(ScreenWindow::new(1.0, -1.0, -1.0, 1.0));
        assert!(
            cam.validate()
                .unwrap_err()
                .to_string()
                .starts_with("ScreenWindow:")
        );
        let mut cam = CameraDesc::new(Format::new(64, 64));
        cam.crop_window = CropWindow {
            x_min: 0.5,
            x_max: 0.5,
            y_min: 0.0,
            y_max: 1.0,
        };
        assert!(cam.validate().unwrap_err().to_string().starts_with("CropWindow:"));
        let mut cam = CameraDesc::new(Format::new(64, 64));
        cam.clipping = (0.0, 10.0);
        assert!(cam.validate().unwrap_err().to_string().starts_with("Clipping:"));
        let cam = CameraDesc::new(Format {
            width: 0,
            height: 4,
            pixel_aspect: 1.0,
        });
        assert!(cam.validate().unwrap_err().to_string().starts_with("Format:"));
        assert!(CameraDesc::new(Format::new(64, 64)).validate().is_ok());
    }

    /// Issue 16: `Format 64 48 1e-45` blamed a ScreenWindow the file did not have, `Format 64 48
    /// 1e-30` failed only when the EXR was written, `ScreenWindow -2 1e32 -2 2` made every ray NaN.
    #[test]
    fn degenerate_formats_and_screen_windows_are_refused_naming_the_request_at_fault() {
        let with_aspect = |pixel_aspect| {
            CameraDesc::new(Format {
                width: 64,
                height: 48,
                pixel_aspect,
            })
            .validate()
            .map_err(|e| e.to_string())
        };
        for pa in [1e-45, 1e-30, 1e-7, 2e6, f32::NAN, f32::INFINITY, -1.0] {
            let e = with_aspect(pa).unwrap_err();
            assert!(
                e.starts_with(
                    "Format: expected a positive width and height and a pixel aspect ratio in [1e-6, 1e6]"
                ),
                "{e}"
            );
        }
        assert_eq!(with_aspect(1e-6), Ok(()));
        assert_eq!(with_aspect(1e5), Ok(()));
        // An extreme frame aspect from an in-range pixel aspect: the Format is blamed, not a window.
        let cam = CameraDesc::new(Format {
            width: 1,
            height: 65536,
            pixel_aspect: 1e-6,
        });
        let e = cam.validate().unwrap_err().to_string();
        assert!(
            e.starts_with("Format 1x65536 with pixel aspect 1e-6: the frame aspect"),
            "{e}"
        );
        assert!(e.contains("expected a frame aspect in [1e-6, 1e6]"), "{e}");
        let mut cam = CameraDesc::new(Format::new(64, 48));
        cam.screen_window = Some(ScreenWindow::new(-2.0, 1e32, -2.0, 2.0));
        let e = cam.validate().unwrap_err().to_string();
        assert!(e.starts_with("ScreenWindow: expected finite left < right and bottom < top within [-1e6, 1e6], got -2.0 1e32 -2.0 2.0"), "{e}");
        cam.screen_window = Some(ScreenWindow::new(-1e6, 1e6, -2.0, 2.0));
        assert_eq!(cam.validate(), Ok(()));
    }
}
