//! `PxrRollingShutter`: a projection *modifier* that rewrites only each ray's time (rolling shutter).
//!
//! RenderMan 21 shipped `PxrRollingShutter` as a modifier of the default perspective or orthographic
//! camera that changes the time samples and nothing else; PxrCamera later took over the same two
//! controls, `sweep` and `duration`, whose documented meanings we follow: the sensor is read line by
//! line in the `sweep` direction, and `duration` is the fraction of the shutter interval each line is
//! exposed for — 1 is a global shutter (every line sees the whole interval), 0 an ideal rolling shutter
//! (each line an instant).
//!
//! # Mapping
//!
//! For a screen sample `s = (sx, sy)` in the window `(l, r, b, t)` and the host's time `τ ∈ [0, 1)`:
//!
//! - the sample's position along the sweep, `p ∈ [0, 1]`:
//!   `"down"`: `p = (t − sy)/(t − b)` (0 on the top edge, 1 on the bottom), `"up"`: `p = (sy − b)/(t − b)`,
//!   `"right"`: `p = (sx − l)/(r − l)`, `"left"`: `p = (r − sx)/(r − l)`; samples the pixel filter takes
//!   from outside the window are clamped to the nearer edge;
//! - the new time `τ' = p·(1 − duration) + τ·duration`, clamped below 1 (the largest `f32` under 1) so it
//!   stays in `[0, 1)`: each line's exposure is the interval `[p·(1 − duration), p·(1 − duration) +
//!   duration]`, all inside the shutter.
//!
//! Nothing else changes: origins, directions, footprints, clipping and tints are the host's default
//! camera rays, which arrive pre-filled (the host builds them from this projection's properties).
//!
//! # The underlying camera
//!
//! A modifier has no geometry of its own, but the host makes its default rays from the properties the
//! projection reports (DicingHint, FieldOfView, and FStop/FocalLength/FocalDistance for a thin lens). So
//! `PxrRollingShutter` takes the base camera's parameters and reports them: `base` ("perspective", the
//! default, or "orthographic"), `fov` (perspective, across the screen window's `[−1, 1]` square as for
//! `PxrPerspective`) and the depth-of-field triple. Its [`Projection::unproject`] is the base camera's
//! exact inverse (`(x·d/z, y·d/z)` with `d = 1/tan(fov/2)`, or `(x, y)`; `None` for `z ≤ 0`).
//!
//! Defaults are RenderMan's documented ones (PxrCamera: `sweep` "down", `duration` 1), so with no
//! parameters the modifier is a global shutter and leaves every time as it was.
//!
//! [`RollingShutter`] is the time rewrite alone, for any projection that offers rolling shutter
//! (PxrCamera's `sweep`/`duration`): [`RollingShutter::params`] declares the two parameters,
//! [`RollingShutter::from_params`] reads them and [`RollingShutter::apply`] rewrites a batch.

use std::sync::LazyLock;

use obscura_sdk::optics::screen_distance;
use obscura_sdk::{
    DeepMetric, DicingHint, ParamDecl, Params, PluginError, Point2, Projection, ProjectionContext,
    ProjectionProperty, PropertyValue, ScreenWindow, ValueRange, Vec3,
};

use crate::dof::{self, DepthOfField};

/// The name scenes use.
pub const NAME: &str = "PxrRollingShutter";

/// The largest `f32` below 1: times are clamped to it so they stay in `[0, 1)`.
pub const LAST_TIME: f32 = 1.0 - f32::EPSILON / 2.0;

/// The direction the sensor is read in (`sweep`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Sweep {
    /// Top line first (RenderMan's default).
    #[default]
    Down,
    /// Bottom line first.
    Up,
    /// Left column first.
    Right,
    /// Right column first.
    Left,
}

impl Sweep {
    /// The four spellings, as the parameter's choices.
    pub const NAMES: [&'static str; 4] = ["down", "up", "left", "right"];

    /// Reads `"down"`, `"up"`, `"left"` or `"right"`.
    #[must_use]
    pub fn parse(s: &str) -> Option<Sweep> {
        match s {
            "down" => Some(Sweep::Down),
            "up" => Some(Sweep::Up),
            "left" => Some(Sweep::Left),
            "right" => Some(Sweep::Right),
            _ => None,
        }
    }
}

/// The rolling-shutter time rewrite `τ' = p·(1 − duration) + τ·duration` (see the module
/// documentation), with the sweep position `p = clamp(a·sx + c·sy + e, 0, 1)` precomputed as an affine
/// function of the screen position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RollingShutter {
    sweep: Sweep,
    duration: f32,
    a: f32,
    c: f32,
    e: f32,
}

impl RollingShutter {
    /// The parameter declarations `sweep` and `duration`, to append to a projection's table.
    #[must_use]
    pub fn params() -> [ParamDecl; 2] {
        [
            ParamDecl::string("sweep", "down")
                .choices(&Sweep::NAMES)
                .doc("rolling-shutter read-out direction: down (top line first), up, left, right"),
            ParamDecl::float("duration", 1.0)
                .range(ValueRange::closed(0.0, 1.0))
                .doc("exposure of each line as a fraction of the shutter: 1 = global shutter, 0 = ideal rolling shutter"),
        ]
    }

    /// Reads the parameters declared by [`RollingShutter::params`] for the screen window `window`.
    ///
    /// # Errors
    /// A parameter lookup error when the table lacks them, or [`PluginError::Invalid`] when the window
    /// has no area.
    pub fn from_params(p: &Params, window: ScreenWindow) -> Result<Self, PluginError> {
        let name = p.string("sweep")?;
        let sweep = Sweep::parse(name).ok_or_else(|| {
            crate::invalid(
                p.plugin(),
                format!("\"sweep\" = \"{name}\": expected one of down, up, left, right"),
            )
        })?;
        Self::new(sweep, p.float("duration")?, window).ok_or_else(|| {
            crate::invalid(
                p.plugin(),
                format!(
                    "rolling shutter needs a screen window with area and a duration in [0, 1]; got window \
                 ({}, {}, {}, {}) and duration {}",
                    window.left,
                    window.right,
                    window.bottom,
                    window.top,
                    p.float("duration").unwrap_or(f32::NAN)
                ),
            )
        })
    }

    /// The rewrite for `sweep` and `duration ∈ [0, 1]` over `window`; `None` when the duration is out of
    /// range or the window has no width or height.
    #[must_use]
    pub fn new(sweep: Sweep, duration: f32, window: ScreenWindow) -> Option<Self> {
        let (w, h) = (window.width(), window.height());
        let usable = w.is_finite() && h.is_finite() && w != 0.0 && h != 0.0;
        if !(0.0..=1.0).contains(&duration) || !usable {
            return None;
        }
        let (a, c, e) = match sweep {
            Sweep::Down => (0.0, -1.0 / h, window.top / h),
            Sweep::Up => (0.0, 1.0 / h, -window.bottom / h),
            Sweep::Right => (1.0 / w, 0.0, -window.left / w),
            Sweep::Left => (-1.0 / w, 0.0, window.right / w),
        };
        Some(RollingShutter {
            sweep,
            duration,
            a,
            c,
            e,
        })
    }

    /// The read-out direction.
    #[must_use]
    pub fn sweep(&self) -> Sweep {
        self.sweep
    }

    /// The exposure of each line as a fraction of the shutter.
    #[must_use]
    pub fn duration(&self) -> f32 {
        self.duration
    }

    /// True when every line sees the whole shutter (`duration` 1): times are left alone.
    #[must_use]
    pub fn is_global(&self) -> bool {
        self.duration >= 1.0
    }

    /// The position `p ∈ [0, 1]` of screen point `s` along the sweep.
    #[inline]
    #[must_use]
    pub fn sweep_position(&self, s: Point2) -> f32 {
        (self.a * s.x + self.c * s.y + self.e).clamp(0.0, 1.0)
    }

    /// The rewritten time of a sample at screen point `s` with host time `t ∈ [0, 1)`; in `[0, 1)`.
    #[inline]
    #[must_use]
    pub fn time(&self, s: Point2, t: f32) -> f32 {
        let p = self.sweep_position(s);
        (p * (1.0 - self.duration) + t * self.duration).clamp(0.0, LAST_TIME)
    }

    /// Rewrites a batch of times in place (`time[i]` belongs to `screen[i]`); a global shutter leaves
    /// them untouched.
    pub fn apply(&self, screen: &[Point2], time: &mut [f32]) {
        if self.is_global() {
            return;
        }
        for (t, s) in time.iter_mut().zip(screen) {
            *t = self.time(*s, *t);
        }
    }
}

/// The camera under the modifier, whose rays the host pre-fills.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Base {
    /// Pinhole or thin-lens perspective with the screen plane at `d`.
    Perspective { fov: f32, d: f32 },
    /// Parallel rays.
    Orthographic,
}

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    let mut table = RollingShutter::params().to_vec();
    table.push(
        ParamDecl::string("base", "perspective")
            .choices(&["perspective", "orthographic"])
            .doc("the default camera the host makes the rays with; only their time is rewritten"),
    );
    table.push(
        // The host's default pinhole stops at 179° (a pinhole cannot show 180°): a wider base would
        // describe rays the host does not make, and `unproject` would invert the wrong camera.
        ParamDecl::float("fov", 90.0)
            .range(ValueRange {
                min: 0.0,
                max: 179.0,
                min_inclusive: false,
                max_inclusive: true,
            })
            .doc("perspective base: field of view in degrees across the screen window's [-1, 1] square (at most 179, the host's default pinhole)"),
    );
    table.extend(dof::params());
    table
});

/// Creates [`RollingShutterModifier`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct RollingShutterFactory;

projection_factory!(
    RollingShutterFactory,
    "modifier: rolling shutter over the host's default camera; time' = p(1 - duration) + time*duration",
    |env, p| {
        let shutter = RollingShutter::from_params(p, env.screen_window())?;
        let base = match p.string("base")? {
            "orthographic" => Base::Orthographic,
            _ => {
                let fov = p.float("fov")?;
                Base::Perspective {
                    fov,
                    d: screen_distance(fov),
                }
            }
        };
        env.set_deep_metric(DeepMetric::CameraZ);
        Ok(Box::new(RollingShutterModifier {
            shutter,
            base,
            dof: DepthOfField::from_params(p)?,
        }))
    }
);

/// `PxrRollingShutter` (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RollingShutterModifier {
    shutter: RollingShutter,
    base: Base,
    dof: DepthOfField,
}

impl RollingShutterModifier {
    /// The time rewrite.
    #[must_use]
    pub fn shutter(&self) -> &RollingShutter {
        &self.shutter
    }
}

impl Projection for RollingShutterModifier {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        match (property, self.base) {
            (ProjectionProperty::DicingHint, Base::Perspective { .. }) => {
                Some(PropertyValue::DicingHint(DicingHint::Perspective))
            }
            (ProjectionProperty::DicingHint, Base::Orthographic) => {
                Some(PropertyValue::DicingHint(DicingHint::Orthographic))
            }
            (ProjectionProperty::DeepMetric, _) => Some(PropertyValue::DeepMetric(DeepMetric::CameraZ)),
            (ProjectionProperty::FieldOfView, Base::Perspective { fov, .. }) => {
                Some(PropertyValue::Float(fov))
            }
            (ProjectionProperty::FieldOfView, Base::Orthographic) => None,
            (other, _) => self.dof.property(other),
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        self.shutter.apply(c.screen, c.time);
    }

    fn unproject(&self, point: Vec3, _time: f32) -> Option<Point2> {
        if point.z <= 0.0 || !point.is_finite() {
            return None;
        }
        match self.base {
            Base::Perspective { d, .. } => {
                let k = d / point.z;
                Some(Point2::new(point.x * k, point.y * k))
            }
            Base::Orthographic => Some(Point2::new(point.x, point.y)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::optics::PerspectiveRays;
    use obscura_sdk::{Format, ProjectionEnvironment, RayGeometry, Rgb};
    use proptest::prelude::*;

    fn make(params: &[(&str, &str)], format: Format) -> (Box<dyn Projection>, ProjectionEnvironment) {
        crate::testing::make_env(&RollingShutterFactory, params, format)
    }

    /// Runs `project` on pre-filled rays and returns (rays, times, tints) after it.
    fn run(
        p: &dyn Projection,
        screen: &[Point2],
        time: &[f32],
        fill: RayGeometry,
    ) -> (Vec<RayGeometry>, Vec<f32>, Vec<Rgb>) {
        let n = screen.len();
        let lens = vec![Point2::new(0.5, 0.5); n];
        let aperture = vec![Point2::ZERO; n];
        let mut time = time.to_vec();
        let mut rays = vec![fill; n];
        let mut tint = vec![Rgb::WHITE; n];
        let mut ctx =
            ProjectionContext::new(screen, &lens, &aperture, &mut time, &mut rays, &mut tint).unwrap();
        p.project(&mut ctx);
        (rays, time, tint)
    }

    #[test]
    fn each_sweep_starts_on_its_own_edge() {
        let format = Format::new(40, 20);
        let w = ScreenWindow::default_for(format);
        let (top, bottom) = (Point2::new(0.3, w.top), Point2::new(0.3, w.bottom));
        let (left, right) = (Point2::new(w.left, -0.2), Point2::new(w.right, -0.2));
        // Ideal rolling shutter: the time is the sweep position alone.
        for (sweep, first, last) in [
            ("down", top, bottom),
            ("up", bottom, top),
            ("right", left, right),
            ("left", right, left),
        ] {
            let (p, _) = make(&[("string sweep", sweep), ("float duration", "0")], format);
            let (_, t, _) = run(p.as_ref(), &[first, last], &[0.7, 0.7], RayGeometry::CULLED);
            assert_eq!(t[0], 0.0, "{sweep}: the first line is read at shutter open");
            assert_eq!(
                t[1], LAST_TIME,
                "{sweep}: the last line is read at shutter close, kept below 1"
            );
        }
        // Half the shutter per line: the top line sees [0, ½), the bottom one [½, 1).
        let (p, _) = make(&[("float duration", "0.5")], format);
        let (_, t, _) = run(
            p.as_ref(),
            &[top, top, bottom, bottom],
            &[0.0, 0.99, 0.0, 0.99],
            RayGeometry::CULLED,
        );
        for (got, want) in t.iter().zip([0.0, 0.495, 0.5, 0.995]) {
            assert!((got - want).abs() < 1e-7, "{t:?}");
        }
    }

    proptest! {
        #[test]
        fn time_follows_the_formula_and_stays_in_the_shutter(
            sx in -3.0f32..3.0, sy in -2.0f32..2.0, t in 0.0f32..1.0, duration in 0.0f32..=1.0,
            sweep in 0usize..4,
        ) {
            let format = Format::new(64, 32);
            let w = ScreenWindow::default_for(format);
            let name = Sweep::NAMES[sweep];
            let rs = RollingShutter::new(Sweep::parse(name).unwrap(), duration, w).unwrap();
            let got = rs.time(Point2::new(sx, sy), t);
            prop_assert!((0.0..1.0).contains(&got), "{got}");
            // Independent formula in f64, positions measured from the named edge.
            let (sx, sy) = (sx as f64, sy as f64);
            let (l, r, b, tp) = (w.left as f64, w.right as f64, w.bottom as f64, w.top as f64);
            let p = match name {
                "down" => (tp - sy) / (tp - b),
                "up" => (sy - b) / (tp - b),
                "right" => (sx - l) / (r - l),
                _ => (r - sx) / (r - l),
            }.clamp(0.0, 1.0);
            let expected = (p * (1.0 - duration as f64) + t as f64 * duration as f64).min(LAST_TIME as f64);
            prop_assert!((got as f64 - expected).abs() < 1e-6, "{got} vs {expected}");
        }
    }

    #[test]
    fn only_time_changes() {
        let format = Format::new(32, 32);
        let (p, _) = make(&[("string sweep", "left"), ("float duration", "0.25")], format);
        let fill = RayGeometry {
            origin: Vec3::new(0.1, 0.2, 0.0),
            origin_radius: 0.01,
            direction: Vec3::new(0.0, 0.6, 0.8),
            ray_spread: 0.002,
            min_dist: 0.1,
            max_dist: 100.0,
        };
        let screen: Vec<Point2> = (0..50).map(|i| Point2::new(i as f32 / 25.0 - 1.0, 0.5)).collect();
        let (rays, times, tints) = run(p.as_ref(), &screen, &[0.5; 50], fill);
        assert!(rays.iter().all(|r| *r == fill));
        assert!(tints.iter().all(|c| *c == Rgb::WHITE));
        // "left": the right edge is read first, so times fall from right to left.
        assert!(times.windows(2).all(|w| w[0] >= w[1]), "{times:?}");
        assert!(times[0] > times[49]);
    }

    #[test]
    fn the_default_is_a_global_shutter() {
        let (p, _) = make(&[], Format::new(16, 16));
        let t: Vec<f32> = (0..16).map(|i| i as f32 / 16.0).collect();
        let screen: Vec<Point2> = (0..16).map(|i| Point2::new(0.0, 1.0 - i as f32 / 8.0)).collect();
        let (_, got, _) = run(p.as_ref(), &screen, &t, RayGeometry::CULLED);
        assert_eq!(got, t);
    }

    #[test]
    fn properties_describe_the_base_camera_the_host_fills_in() {
        let (p, env) = make(
            &[
                ("float fov", "40"),
                ("float fStop", "2"),
                ("float focalLength", "0.1"),
            ],
            Format::new(8, 8),
        );
        crate::testing::assert_camera_z(p.as_ref(), DicingHint::Perspective, Some(40.0));
        assert_eq!(env.deep_metric(), DeepMetric::CameraZ);
        assert_eq!(
            p.property(ProjectionProperty::FStop),
            Some(PropertyValue::Float(2.0))
        );
        assert_eq!(
            p.property(ProjectionProperty::FocalDistance),
            Some(PropertyValue::Float(1.0))
        );
        let (o, _) = make(&[("string base", "orthographic")], Format::new(8, 8));
        assert_eq!(
            o.property(ProjectionProperty::DicingHint),
            Some(PropertyValue::DicingHint(DicingHint::Orthographic))
        );
        assert_eq!(o.property(ProjectionProperty::FieldOfView), None);
        assert_eq!(
            o.unproject(Vec3::new(0.3, -0.4, 5.0), 0.0),
            Some(Point2::new(0.3, -0.4))
        );
        assert_eq!(o.unproject(Vec3::new(0.3, -0.4, -5.0), 0.0), None);
    }

    proptest! {
        #[test]
        fn unproject_inverts_the_base_cameras_pinhole_ray(sx in -1.5f32..1.5, sy in -1.0f32..1.0, depth in 0.5f32..50.0) {
            let format = Format::new(48, 32);
            let (p, env) = make(&[("float fov", "65")], format);
            let reference = PerspectiveRays::new(env.pixel_size(), (0.1, f32::INFINITY), 0.0, 1.0);
            let r = reference.pinhole(Point2::new(sx, sy), screen_distance(65.0));
            let back = p.unproject(r.direction * depth, 0.3).unwrap();
            prop_assert!((back.x - sx).abs() < 2e-5 && (back.y - sy).abs() < 2e-5, "{:?}", back);
        }
    }

    #[test]
    fn bad_parameters_name_the_plugin_and_parameter() {
        let cases = [
            ("string sweep", "sideways", "\"sweep\""),
            ("float duration", "1.5", "\"duration\""),
            ("float fov", "180", "\"fov\""),
        ];
        crate::testing::assert_refused(
            &RollingShutterFactory,
            "PxrRollingShutter",
            Format::new(8, 8),
            &cases,
        );
    }
}
