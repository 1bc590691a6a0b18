//! [`CheckOptions`]: the environment a projection is checked in, how densely it is sampled, and the
//! tolerance of every check.

use obscura_sdk::contract;
use obscura_sdk::{Format, ProjectionEnvironment, ScreenWindow};

/// How thoroughly, and against which camera, to check a projection.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckOptions {
    /// Image size and pixel aspect of the environment [`check_factory`](crate::check_factory) creates
    /// the projection with (default 96 × 72, square pixels).
    pub format: Format,
    /// The screen window; `None` for the default of the format.
    pub screen_window: Option<ScreenWindow>,
    /// Shutter open and close, scene time (default (0, 1)).
    pub shutter: (f32, f32),
    /// Clipping near and far (default (0.1, ∞), RenderMan's).
    pub clipping: (f32, f32),
    /// Random lens and time samples per pixel, besides the chief sample (default 4).
    pub samples_per_pixel: u32,
    /// Seed of the random samples (default 0).
    pub seed: u64,
    /// Threads for the concurrency check (default 4; at least 1 is used).
    pub threads: usize,
    /// Samples per `project` call (default 256; at least 1 is used).
    pub batch_size: usize,
    /// Pixels of margin sampled outside the window on every side (default 1).
    pub margin: u32,
    /// `|‖D‖ − 1|` allowed for a unit direction (default 10⁻³, the host's).
    pub unit_tolerance: f32,
    /// Relative error allowed in `ray_spread` (default 0.25).
    pub spread_tolerance: f64,
    /// A neighbour angle this many times the local median is a discontinuity (default 20).
    pub discontinuity_ratio: f64,
    /// A pixel whose neighbour angles on the two sides of one axis differ by more than this factor is
    /// too curved for the spread check and skipped (default 1.25).
    pub curvature_ratio: f64,
    /// Relative error allowed in the FieldOfView property (default 0.02) …
    pub fov_tolerance: f64,
    /// … or this many degrees, whichever is larger (default 0.5).
    pub fov_tolerance_degrees: f64,
    /// Distance between chief-ray origins that still counts as one origin, relative to
    /// `max(1, |origin|)` (default 10⁻⁴).
    pub origin_tolerance: f64,
    /// Angle in radians between chief-ray directions that still counts as parallel (default 10⁻⁴).
    pub direction_tolerance: f64,
    /// Error in pixels allowed in `unproject(project(s))` (default 10⁻³).
    pub unproject_tolerance: f64,
    /// Relative error allowed in a ray's clipping distances (default 10⁻³).
    pub clipping_tolerance: f64,
}

impl Default for CheckOptions {
    fn default() -> Self {
        CheckOptions {
            format: Format::new(96, 72),
            screen_window: None,
            shutter: (0.0, 1.0),
            clipping: (0.1, f32::INFINITY),
            samples_per_pixel: 4,
            seed: 0,
            threads: 4,
            batch_size: 256,
            margin: 1,
            unit_tolerance: contract::UNIT_TOLERANCE,
            spread_tolerance: 0.25,
            discontinuity_ratio: 20.0,
            curvature_ratio: 1.25,
            fov_tolerance: 0.02,
            fov_tolerance_degrees: 0.5,
            origin_tolerance: 1e-4,
            direction_tolerance: 1e-4,
            unproject_tolerance: 1e-3,
            clipping_tolerance: 1e-3,
        }
    }
}

impl CheckOptions {
    /// The environment these options describe: format, screen window (the format's default when
    /// `None`), shutter, clipping, an identity camera.
    #[must_use]
    pub fn environment(&self) -> ProjectionEnvironment {
        let format = Format {
            width: self.format.width.max(1),
            height: self.format.height.max(1),
            pixel_aspect: self.format.pixel_aspect,
        };
        ProjectionEnvironment::new(
            format,
            self.screen_window
                .unwrap_or_else(|| ScreenWindow::default_for(format)),
            self.shutter,
            self.clipping,
            Vec::new(),
        )
    }
}
