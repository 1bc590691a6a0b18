//! `PxrPerspective`: the pinhole and thin-lens perspective camera.
//!
//! Mapping, for screen sample `(sx, sy)`, aperture sample `(ax, ay) ∈ [−1, 1]²` and shutter time `t`:
//!
//! - field of view `φ(t) = fov + (fovEnd − fov)·t` (or `fov` throughout when `fovEnd` is 0), screen
//!   plane at `d(t) = 1/tan(φ(t)/2)`: the square `[−1, 1]²` of screen space spans `φ`, so with the
//!   default screen window `fov` is the angle across the *smaller* image dimension;
//! - pinhole: `O = 0`, `D = normalize(sx, sy, d)`;
//! - thin lens (finite positive `fStop`, positive `focalLength`): lens radius
//!   `R = ½·focalLength/fStop`, `O = (R·ax, R·ay, 0)`, `D = normalize(F − O)` with the focus point
//!   `F = (sx, sy, d)·focalDistance/d`, so every ray of one screen point crosses the plane
//!   `z = focalDistance` at the same point;
//! - footprint: `origin_radius = 0`, `ray_spread = ½·sqrt(αx·αy)` with the per-pixel turn of the
//!   pinhole direction `αx = Δx·sqrt(sy² + d²)/L²`, `αy = Δy·sqrt(sx² + d²)/L²`, `L² = sx² + sy² + d²`
//!   (through a lens scaled by `|F|/|F − O|`, so the cone has the pinhole's radius at the focus point);
//! - clipping: `min_dist = near/D.z`, `max_dist = far/D.z` (the clipping planes are planes of constant z).
//!
//! Inverse: a camera-space point `P` with `P.z > 0` is seen at `(P.x·d/P.z, P.y·d/P.z)`.
//!
//! Properties: DicingHint Perspective; FieldOfView `fov` (the narrower of `fov`, `fovEnd` during a
//! zoom, so dicing is fine enough all through the shutter); DeepMetric CameraZ; FStop, FocalLength and
//! FocalDistance only when depth of field is on.
//!
//! Batches: `project` writes 40-byte `RtRayGeometry` records; `project_soa` writes the same rays, bit
//! for bit, one array per field ([`obscura_sdk::RaysSoa`]). Both run the same kernels at the dispatch
//! tier — AVX-512 (`perspective/avx512.rs`, pinhole and thin lens), AVX2 + FMA (`perspective/avx2.rs`,
//! pinhole) or the portable loop — and differ only in the kernel's sink: records take a transpose of
//! the lanes, arrays take each register as it is (ten stores per sixteen rays, no shuffle). When the
//! consumer asks for some fields only ([`obscura_sdk::SoaFields`]), the AVX-512 and AVX2 sinks store
//! only those, and skip the footprint's fourth root when `ray_spread` is not among them.

use std::sync::LazyLock;

use obscura_sdk::optics::{PerspectiveRays, screen_distance};
use obscura_sdk::{
    DeepMetric, DicingHint, ParamDecl, PluginError, Point2, Projection, ProjectionContext,
    ProjectionEnvironment, ProjectionProperty, PropertyValue, RayGeometry, RaysSoa, SoaContext, SoaFields,
    ValueRange, Vec3,
};

use crate::dof::{self, DepthOfField};
use crate::screen::write_soa;
use crate::simd;

/// The name scenes use.
pub const NAME: &str = "PxrPerspective";

/// The narrowest field of view of the perspective projections, in degrees (10⁻³°: 3.6 arcseconds,
/// beyond any lens). Narrower, the screen plane `1/tan(fov/2)` is so far that its square overflows
/// `f32` and every ray would be NaN.
pub const MIN_FOV: f64 = 1e-3;

/// `fov`'s range, `[MIN_FOV, 180)`, shared by PxrPerspective and PxrCamera.
pub const FOV_RANGE: ValueRange = ValueRange {
    min: MIN_FOV,
    max: 180.0,
    min_inclusive: true,
    max_inclusive: false,
};

/// Checks `fovEnd`: 0 (no zoom) or in [`FOV_RANGE`].
///
/// # Errors
/// [`PluginError::Invalid`] naming `plugin`.
pub fn check_fov_end(plugin: &str, fov_end: f32) -> Result<(), PluginError> {
    if fov_end == 0.0 || f64::from(fov_end) >= MIN_FOV {
        return Ok(());
    }
    Err(crate::invalid(
        plugin,
        format!(
            "parameter \"fovEnd\" = {fov_end:?}: expected 0 (no zoom) or a field of view of at least {MIN_FOV} degrees"
        ),
    ))
}

/// The parameter declarations `fov` and `fovEnd` (zoom blur), shared by PxrPerspective and PxrCamera.
#[must_use]
pub fn zoom_params() -> [ParamDecl; 2] {
    [
        ParamDecl::float("fov", 90.0).range(FOV_RANGE).doc(
            "field of view in degrees across the screen window's [-1, 1] square (the smaller image side)",
        ),
        ParamDecl::float("fovEnd", 0.0)
            .range(ValueRange {
                min: 0.0,
                max: 180.0,
                min_inclusive: true,
                max_inclusive: false,
            })
            .doc("field of view at shutter close, for zoom blur; 0 = same as fov"),
    ]
}

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| [&zoom_params()[..], &dof::params()].concat());

/// Creates [`Perspective`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct PerspectiveFactory;

projection_factory!(
    PerspectiveFactory,
    "pinhole or thin-lens perspective: D = normalize(sx, sy, 1/tan(fov/2)); zoom blur with fovEnd",
    |env, p| {
        env.set_deep_metric(DeepMetric::CameraZ);
        let (fov, fov_end) = (p.float("fov")?, p.float("fovEnd")?);
        check_fov_end(NAME, fov_end)?;
        Ok(Box::new(Perspective::new(
            env,
            fov,
            fov_end,
            DepthOfField::from_params(p)?,
        )))
    }
);

/// The field of view over the shutter, `φ(t) = fov + (fovEnd − fov)·t`, and the screen plane
/// `d(t) = 1/tan(φ(t)/2)` it puts the image at (PxrPerspective's and PxrCamera's zoom).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Zoom {
    /// `fov` at shutter open, degrees.
    pub fov: f32,
    /// `Some(fovEnd)` when the field of view changes during the shutter.
    pub fov_end: Option<f32>,
    /// The screen plane at shutter open, `d(0)`.
    pub d: f32,
}

impl Zoom {
    /// `fov` throughout when `fov_end` is 0 or equal to it, else a zoom from `fov` to `fov_end`.
    #[must_use]
    pub fn new(fov: f32, fov_end: f32) -> Self {
        Zoom {
            fov,
            fov_end: (fov_end > 0.0 && fov_end != fov).then_some(fov_end),
            d: screen_distance(fov),
        }
    }

    /// The screen-plane distance `d(t)` at shutter-normalised time `t`.
    #[inline]
    #[must_use]
    pub fn screen_distance_at(&self, t: f32) -> f32 {
        match self.fov_end {
            None => self.d,
            Some(end) => screen_distance(self.fov + (end - self.fov) * t),
        }
    }

    /// The narrowest field of view of the shutter interval: dicing fine enough all through it.
    #[must_use]
    pub fn narrowest(&self) -> f32 {
        self.fov_end.map_or(self.fov, |e| e.min(self.fov))
    }
}

/// A perspective camera (see the module documentation for its mapping).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Perspective {
    rays: PerspectiveRays,
    zoom: Zoom,
    dof: DepthOfField,
}

impl Perspective {
    /// A perspective camera for `env`; `fov_end` 0 means no zoom.
    #[must_use]
    pub fn new(env: &ProjectionEnvironment, fov: f32, fov_end: f32, dof: DepthOfField) -> Self {
        Perspective {
            rays: PerspectiveRays::new(
                env.pixel_size(),
                (env.clipping_near(), env.clipping_far()),
                dof.lens_radius(),
                dof.focal_distance,
            ),
            zoom: Zoom::new(fov, fov_end),
            dof,
        }
    }

    /// The screen-plane distance at shutter-normalised time `t`.
    #[inline]
    #[must_use]
    pub fn screen_distance_at(&self, t: f32) -> f32 {
        self.zoom.screen_distance_at(t)
    }

    /// True when depth of field is on.
    #[must_use]
    pub fn has_depth_of_field(&self) -> bool {
        self.dof.is_on()
    }
}

impl Projection for Perspective {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        match property {
            ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(DicingHint::Perspective)),
            ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(DeepMetric::CameraZ)),
            ProjectionProperty::FieldOfView => Some(PropertyValue::Float(self.zoom.narrowest())),
            other => self.dof.property(other),
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let rays = self.rays;
        let d = self.zoom.d;
        match (self.zoom.fov_end.is_some(), self.has_depth_of_field()) {
            (false, false) => {
                let c = ctx.parts_mut();
                pinhole_batch(&rays, c.screen, d, c.rays);
            }
            (false, true) => {
                let c = ctx.parts_mut();
                thin_lens_batch(&rays, c.screen, c.aperture, d, c.rays);
            }
            (true, _) => {
                let c = ctx.parts_mut();
                simd::run(|| {
                    for (((r, s), a), t) in c.rays.iter_mut().zip(c.screen).zip(c.aperture).zip(c.time.iter())
                    {
                        *r = rays.ray(*s, *a, self.screen_distance_at(*t));
                    }
                });
            }
        }
    }

    /// The rays of `project`, bit for bit, one array per field: the pinhole and thin-lens kernels
    /// store each register straight into its array at every tier (no transposes); the zoom path
    /// writes its per-ray rays field by field. Always offered.
    fn project_soa(&self, ctx: &mut SoaContext<'_>) -> bool {
        let rays = self.rays;
        let d = self.zoom.d;
        match (self.zoom.fov_end.is_some(), self.has_depth_of_field()) {
            (false, false) => pinhole_soa(&rays, ctx.screen, d, ctx.fields(), &mut ctx.rays),
            (false, true) => thin_lens_soa(&rays, ctx.screen, ctx.aperture, d, ctx.fields(), &mut ctx.rays),
            (true, _) => {
                let (screen, aperture, time, out) = (ctx.screen, ctx.aperture, &*ctx.time, &mut ctx.rays);
                let n = out.len();
                simd::run(
                    #[inline(always)]
                    || {
                        write_soa(out, n, |i| {
                            rays.ray(screen[i], aperture[i], self.screen_distance_at(time[i]))
                        })
                    },
                );
            }
        }
        true
    }

    fn unproject(&self, point: Vec3, time: f32) -> Option<Point2> {
        if point.z <= 0.0 || !point.is_finite() {
            return None;
        }
        let k = self.screen_distance_at(time) / point.z;
        Some(Point2::new(point.x * k, point.y * k))
    }
}

/// Pinhole rays for a batch at the dispatch tier ([`simd::level`]): the AVX-512 or the AVX2 kernel,
/// else the portable loop. Every tier gives bit-identical rays: the kernels are
/// [`PerspectiveRays::pinhole`] operation for operation.
fn pinhole_batch(rays: &PerspectiveRays, screen: &[Point2], d: f32, out: &mut [RayGeometry]) {
    let n = screen.len().min(out.len());
    match simd::level() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `level` only answers Avx512 when the CPU has it; `out` holds `n` rays.
        simd::Level::Avx512 => unsafe {
            avx512::pinhole(rays, &screen[..n], d, &mut avx512::Aos(&mut out[..n]))
        },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `level` only answers Avx2Fma when the CPU has AVX2 and FMA.
        simd::Level::Avx2Fma => unsafe {
            avx2::pinhole(rays, &screen[..n], d, n, &mut avx2::Aos(&mut out[..n]))
        },
        level => simd::run_at(
            level,
            #[inline(always)]
            || rays.pinhole_batch(screen, d, out),
        ),
    }
}

/// Thin-lens rays for a batch at the dispatch tier, as [`pinhole_batch`].
fn thin_lens_batch(
    rays: &PerspectiveRays,
    screen: &[Point2],
    aperture: &[Point2],
    d: f32,
    out: &mut [RayGeometry],
) {
    let n = screen.len().min(aperture.len()).min(out.len());
    match simd::level() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `level` only answers Avx512 when the CPU has it; every slice holds `n` items.
        simd::Level::Avx512 => unsafe {
            avx512::thin_lens(
                rays,
                &screen[..n],
                &aperture[..n],
                d,
                &mut avx512::Aos(&mut out[..n]),
            );
        },
        level => simd::run_at(
            level,
            #[inline(always)]
            move || {
                for ((r, s), a) in out.iter_mut().zip(screen).zip(aperture) {
                    *r = rays.thin_lens(*s, *a, d);
                }
            },
        ),
    }
}

/// [`pinhole_batch`] into arrays: the same kernels, with sinks that store each register into its
/// field's array — those in `fields` only, and without computing the spread unless it is asked for
/// (the portable tier writes every field).
fn pinhole_soa(rays: &PerspectiveRays, screen: &[Point2], d: f32, fields: SoaFields, out: &mut RaysSoa<'_>) {
    let n = screen.len().min(out.len());
    match simd::level() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `level` only answers Avx512 when the CPU has it; `out` holds at least `n` rays.
        simd::Level::Avx512 => unsafe {
            avx512::pinhole(rays, &screen[..n], d, &mut avx512::Soa::new(out, fields))
        },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `level` only answers Avx2Fma when the CPU has AVX2 and FMA; `out` holds `n` rays.
        simd::Level::Avx2Fma => unsafe {
            avx2::pinhole(rays, &screen[..n], d, n, &mut avx2::Soa(out, fields))
        },
        level => simd::run_at(
            level,
            #[inline(always)]
            || write_soa(out, n, |i| rays.pinhole(screen[i], d)),
        ),
    }
}

/// [`thin_lens_batch`] into arrays, as [`pinhole_soa`].
fn thin_lens_soa(
    rays: &PerspectiveRays,
    screen: &[Point2],
    aperture: &[Point2],
    d: f32,
    fields: SoaFields,
    out: &mut RaysSoa<'_>,
) {
    let n = screen.len().min(aperture.len()).min(out.len());
    match simd::level() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `level` only answers Avx512 when the CPU has it; every slice holds `n` items.
        simd::Level::Avx512 => unsafe {
            avx512::thin_lens(
                rays,
                &screen[..n],
                &aperture[..n],
                d,
                &mut avx512::Soa::new(out, fields),
            );
        },
        level => simd::run_at(
            level,
            #[inline(always)]
            || write_soa(out, n, |i| rays.thin_lens(screen[i], aperture[i], d)),
        ),
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
#[cfg(target_arch = "x86_64")]
pub(crate) use avx512::store_centred_records;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{
        self, angle, assert_camera_z, assert_lens_properties, assert_refused, pixel_centre_rays,
        project_points,
    };
    use obscura_sdk::{Format, ParamList, ProjectionFactory};
    use proptest::prelude::*;

    fn make(params: &[(&str, &[&str])], format: Format) -> Box<dyn Projection> {
        testing::try_create(&PerspectiveFactory, &testing::param_list(params), format)
            .0
            .unwrap()
    }

    /// Issue 16: `fov=1e-38` was inside the stated range (0, 180) and made every ray NaN.
    #[test]
    fn fields_of_view_too_narrow_for_f32_are_outside_the_range() {
        let format = Format::new(8, 6);
        assert_refused(
            &PerspectiveFactory,
            NAME,
            format,
            &[
                ("float fov", "1e-38", "out of range"),
                ("float fov", "0.0009", "out of range"),
                (
                    "float fovEnd",
                    "1e-38",
                    "expected 0 (no zoom) or a field of view of at least 0.001 degrees",
                ),
            ],
        );
        let narrowest = make(&[("float fov", &["0.001"]), ("float fovEnd", &["0.001"])], format);
        for r in pixel_centre_rays(narrowest.as_ref(), format) {
            assert!(
                r.direction.is_finite() && r.ray_spread.is_finite() && r.ray_spread > 0.0,
                "{r:?}"
            );
        }
    }

    proptest! {
        #[test]
        fn pinhole_directions_match_the_closed_form(sx in -2.0f32..2.0, sy in -2.0f32..2.0, fov in 1.0f32..179.0) {
            let p = make(&[("float fov", &[&fov.to_string()])], Format::new(64, 64));
            let r = project_points(p.as_ref(), &[Point2::new(sx, sy)], &[Point2::ZERO], &[0.0])[0];
            let d = 1.0 / (fov.to_radians() as f64 / 2.0).tan();
            let l = ((sx as f64).powi(2) + (sy as f64).powi(2) + d * d).sqrt();
            prop_assert!((r.direction.x as f64 - sx as f64 / l).abs() < 1e-6);
            prop_assert!((r.direction.y as f64 - sy as f64 / l).abs() < 1e-6);
            prop_assert!((r.direction.z as f64 - d / l).abs() < 1e-6);
            prop_assert_eq!(r.origin, Vec3::ZERO);
            prop_assert!((r.direction.length() - 1.0).abs() < 1e-6);
        }

        #[test]
        fn thin_lens_rays_of_one_screen_point_share_a_point_of_the_focal_plane(
            sx in -1.5f32..1.5, sy in -1.0f32..1.0,
            ax in -1.0f32..1.0, ay in -1.0f32..1.0,
            f_stop in 0.5f32..22.0, fd in 0.5f32..100.0,
        ) {
            let p = make(&[
                ("float fov", &["40"]), ("float fStop", &[&f_stop.to_string()]),
                ("float focalLength", &["0.05"]), ("float focalDistance", &[&fd.to_string()]),
            ], Format::new(64, 64));
            let s = Point2::new(sx, sy);
            let rays = project_points(p.as_ref(), &[s, s], &[Point2::ZERO, Point2::new(ax, ay)], &[0.0, 0.0]);
            let hit = |r: &obscura_sdk::RayGeometry| {
                let t = (fd - r.origin.z) / r.direction.z;
                r.origin + r.direction * t
            };
            let (a, b) = (hit(&rays[0]), hit(&rays[1]));
            prop_assert!((a - b).length() <= 1e-5 * fd.max(1.0) * (1.0 + sx.abs() + sy.abs()), "{:?} vs {:?}", a, b);
            // The lens-centre ray is the pinhole ray; the other starts on the lens disk.
            let radius = 0.5 * 0.05 / f_stop;
            prop_assert!((rays[1].origin.x - radius * ax).abs() < 1e-6 && (rays[1].origin.y - radius * ay).abs() < 1e-6);
        }

        #[test]
        fn unproject_inverts_project(sx in -2.0f32..2.0, sy in -2.0f32..2.0, t in 0.0f32..1.0, depth in 0.2f32..50.0) {
            let p = make(&[("float fov", &["50"]), ("float fovEnd", &["30"])], Format::new(64, 64));
            let r = project_points(p.as_ref(), &[Point2::new(sx, sy)], &[Point2::ZERO], &[t])[0];
            let back = p.unproject(r.origin + r.direction * depth, t).unwrap();
            prop_assert!((back.x - sx).abs() < 2e-5 && (back.y - sy).abs() < 2e-5, "{:?}", back);
        }
    }

    /// Screen and aperture samples over and beyond the frame, 1037 of them (not a multiple of 16 or 8,
    /// so the masked tails run), with the axis, huge and tiny coordinates among them.
    fn samples() -> (Vec<Point2>, Vec<Point2>) {
        let mut screen: Vec<Point2> = (0..1037)
            .map(|i| {
                Point2::new(
                    (i as f32 * 0.618).fract() * 2.6 - 1.3,
                    (i as f32 * 0.377).fract() * 2.0 - 1.0,
                )
            })
            .collect();
        screen[..6].copy_from_slice(&[
            Point2::ZERO,
            Point2::new(1e-30, -1e-30),
            Point2::new(1e6, 3.0),
            Point2::new(-40.0, 1e-7),
            Point2::new(f32::MIN_POSITIVE, 0.5),
            Point2::new(0.0, -1e4),
        ]);
        let aperture = (0..1037)
            .map(|i| {
                Point2::new(
                    (i as f32 * 0.123).fract() * 2.0 - 1.0,
                    (i as f32 * 0.871).fract() * 2.0 - 1.0,
                )
            })
            .collect();
        (screen, aperture)
    }

    fn bits(rays: &[RayGeometry]) -> Vec<[u32; 10]> {
        rays.iter()
            .map(|r| {
                [
                    r.origin.x,
                    r.origin.y,
                    r.origin.z,
                    r.origin_radius,
                    r.direction.x,
                    r.direction.y,
                    r.direction.z,
                    r.ray_spread,
                    r.min_dist,
                    r.max_dist,
                ]
                .map(f32::to_bits)
            })
            .collect()
    }

    /// Every dispatch tier this CPU has against the portable one, through `project`: pinhole, thin lens
    /// and zoom rays bit for bit, every field (the kernels use exact `div`/`sqrt`, and a fused
    /// multiply-add only where the portable code has `mul_add`). Tiers the CPU lacks are skipped, and
    /// only then.
    #[test]
    fn tiers_give_bit_identical_perspective_rays() {
        let (screen, aperture) = samples();
        let configs: [&[(&str, &[&str])]; 3] = [
            &[("float fov", &["60"])],
            &[
                ("float fov", &["40"]),
                ("float fStop", &["2.8"]),
                ("float focalLength", &["0.05"]),
                ("float focalDistance", &["4"]),
            ],
            &[("float fov", &["60"]), ("float fovEnd", &["30"])],
        ];
        for params in configs {
            let p = make(params, Format::new(640, 480));
            let time: Vec<f32> = (0..screen.len())
                .map(|i| i as f32 / screen.len() as f32)
                .collect();
            let at =
                |level| simd::with_level(level, || project_points(p.as_ref(), &screen, &aperture, &time));
            let portable = at(simd::Level::Portable);
            for level in simd::Level::ALL {
                if !level.is_available() {
                    eprintln!("tier {level} skipped: this CPU lacks it");
                    continue;
                }
                assert_eq!(bits(&at(level)), bits(&portable), "tier {level}, {params:?}");
            }
        }
    }

    /// The three perspective configurations the kernels serve: pinhole, thin lens, zoom.
    type Params = &'static [(&'static str, &'static [&'static str])];
    const CONFIGS: [(&str, Params); 3] = [
        ("pinhole", &[("float fov", &["60"])]),
        (
            "thin lens",
            &[
                ("float fov", &["40"]),
                ("float fStop", &["2.8"]),
                ("float focalLength", &["0.05"]),
                ("float focalDistance", &["4"]),
            ],
        ),
        ("zoom", &[("float fov", &["60"]), ("float fovEnd", &["30"])]),
    ];

    /// `project_soa` writes `project`'s rays bit for bit, every field (the arrays start as NaN
    /// payloads), at every tier, every tail length 0..40 and the whole batch of awkward samples.
    #[test]
    fn tiers_project_soa_is_project_bit_for_bit() {
        let (screen, aperture) = samples();
        let time: Vec<f32> = (0..screen.len())
            .map(|i| i as f32 / screen.len() as f32)
            .collect();
        for (label, params) in CONFIGS {
            let p = make(params, Format::new(640, 480));
            testing::assert_soa_is_project(label, p.as_ref(), &screen, &aperture, &time);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// Random batches of random length (tails of every size), at every tier: `project_soa` is
        /// `project` bit for bit.
        #[test]
        fn tiers_project_soa_is_project_on_random_batches(
            samples in proptest::collection::vec((-3.0f32..3.0, -3.0f32..3.0, -1.0f32..1.0, -1.0f32..1.0, 0.0f32..1.0), 0..70),
            config in 0usize..3,
        ) {
            let (label, params) = CONFIGS[config];
            let p = make(params, Format::new(320, 240));
            let screen: Vec<_> = samples.iter().map(|s| Point2::new(s.0, s.1)).collect();
            let aperture: Vec<_> = samples.iter().map(|s| Point2::new(s.2, s.3)).collect();
            let time: Vec<_> = samples.iter().map(|s| s.4).collect();
            for level in simd::Level::ALL.into_iter().filter(|l| l.is_available()) {
                let want = simd::with_level(level, || project_points(p.as_ref(), &screen, &aperture, &time));
                let got = simd::with_level(level, || testing::project_soa_batch(p.as_ref(), &screen, &aperture, &time, SoaFields::ALL))
                    .expect("offered").0;
                prop_assert_eq!(bits(&got), bits(&want), "{} tier {}", label, level);
            }
        }
    }

    /// A consumer asking for some fields only (Mitsuba's set: direction and `max_dist`; with the
    /// origin; the spread alone; `min_dist` alone) gets those arrays bit for bit at every tier and
    /// every tail length; every other array holds `project`'s value or was not touched, and on the
    /// AVX-512 tier (which skips them) it was not touched at all.
    #[test]
    fn tiers_project_soa_writes_the_selected_fields() {
        let (screen, aperture) = samples();
        let time = vec![0.0; screen.len()];
        let selections = [
            SoaFields::DIRECTION | SoaFields::MAX_DIST,
            SoaFields::ORIGIN | SoaFields::DIRECTION | SoaFields::MAX_DIST,
            SoaFields::RAY_SPREAD,
            SoaFields::MIN_DIST,
        ];
        for (label, params) in &CONFIGS[..2] {
            let p = make(params, Format::new(640, 480));
            for level in simd::Level::ALL.into_iter().filter(|l| l.is_available()) {
                for n in (0..40).chain([screen.len()]) {
                    let (s, a, t) = (&screen[..n], &aperture[..n], &time[..n]);
                    let want = bits(&project_points(p.as_ref(), s, a, t));
                    for fields in selections {
                        let got = simd::with_level(level, || {
                            testing::project_soa_batch(p.as_ref(), s, a, t, fields)
                        })
                        .expect("offered")
                        .0;
                        for (i, (g, w)) in bits(&got).iter().zip(&want).enumerate() {
                            for k in 0..10 {
                                let what =
                                    format!("{label}, tier {level}, n {n}, {fields:?}, ray {i}, field {k}");
                                if fields.has(k) {
                                    assert_eq!(g[k], w[k], "{what}");
                                } else if level == simd::Level::Avx512 {
                                    assert_eq!(g[k], obscura_sdk::SOA_UNWRITTEN, "{what}: written");
                                } else {
                                    assert!(g[k] == w[k] || g[k] == obscura_sdk::SOA_UNWRITTEN, "{what}");
                                }
                            }
                        }
                    }
                }
            }
        }
    }

    /// The kernels at every tier against the per-ray formulas, straight (no host in between), every
    /// batch length 0..40 so each tail length runs.
    #[test]
    fn tiers_match_the_per_ray_formulas_at_every_tail_length() {
        let env = ProjectionEnvironment::for_format(Format::new(640, 480));
        let rays = PerspectiveRays::new(env.pixel_size(), (0.1, 1000.0), 0.03, 2.5);
        let (screen, aperture) = samples();
        for level in simd::Level::ALL.into_iter().filter(|l| l.is_available()) {
            for n in (0..40).chain([1037]) {
                let mut out = vec![RayGeometry::CULLED; n];
                simd::with_level(level, || pinhole_batch(&rays, &screen[..n], 1.3, &mut out));
                let want: Vec<_> = screen[..n].iter().map(|s| rays.pinhole(*s, 1.3)).collect();
                assert_eq!(bits(&out), bits(&want), "pinhole, tier {level}, n {n}");
                simd::with_level(level, || {
                    thin_lens_batch(&rays, &screen[..n], &aperture[..n], 1.3, &mut out)
                });
                let want: Vec<_> = screen[..n]
                    .iter()
                    .zip(&aperture)
                    .map(|(s, a)| rays.thin_lens(*s, *a, 1.3))
                    .collect();
                assert_eq!(bits(&out), bits(&want), "thin lens, tier {level}, n {n}");
            }
        }
    }

    #[test]
    fn twenty_degrees_puts_the_screen_plane_at_5_6713() {
        let p = make(&[("float fov", &["20"])], Format::new(100, 100));
        let r = project_points(p.as_ref(), &[Point2::new(1.0, 0.0)], &[Point2::ZERO], &[0.0])[0];
        assert!((r.direction.z / r.direction.x - 5.6713).abs() < 1e-3);
        // The edge of the [-1, 1] square is half the field of view off axis.
        assert!((r.direction.x.asin().to_degrees() - 10.0).abs() < 1e-4);
    }

    #[test]
    fn ray_spread_is_half_the_angle_between_neighbouring_pixel_rays() {
        let format = Format::new(640, 480);
        for fov in ["30", "90", "150"] {
            let p = make(&[("float fov", &[fov])], format);
            let grid = pixel_centre_rays(p.as_ref(), format);
            let w = format.width as usize;
            let mut worst = 0.0f64;
            for y in (1..format.height as usize - 1).step_by(7) {
                for x in (1..w - 1).step_by(7) {
                    let c = &grid[y * w + x];
                    let ax = 0.5 * angle(grid[y * w + x - 1].direction, grid[y * w + x + 1].direction);
                    let ay = 0.5 * angle(grid[(y - 1) * w + x].direction, grid[(y + 1) * w + x].direction);
                    let expected = 0.5 * (ax * ay).sqrt();
                    worst = worst.max((c.ray_spread as f64 / expected - 1.0).abs());
                }
            }
            assert!(worst < 0.02, "fov {fov}: worst relative error {worst}");
        }
    }

    #[test]
    fn zoom_follows_each_rays_time() {
        let p = make(
            &[("float fov", &["60"]), ("float fovEnd", &["20"])],
            Format::new(64, 64),
        );
        let s = [Point2::new(1.0, 0.0); 3];
        let rays = project_points(p.as_ref(), &s, &[Point2::ZERO; 3], &[0.0, 0.5, 0.999_999]);
        let half_angle = |r: &obscura_sdk::RayGeometry| r.direction.x.atan2(r.direction.z).to_degrees();
        assert!((half_angle(&rays[0]) - 30.0).abs() < 1e-4);
        assert!((half_angle(&rays[1]) - 20.0).abs() < 1e-4);
        assert!((half_angle(&rays[2]) - 10.0).abs() < 1e-3);
        // Dicing uses the narrowest field of view of the shutter interval.
        assert_eq!(
            p.property(ProjectionProperty::FieldOfView),
            Some(PropertyValue::Float(20.0))
        );
    }

    #[test]
    fn properties_are_honest() {
        let pin = make(&[("float fov", &["45"])], Format::new(8, 8));
        assert_camera_z(pin.as_ref(), DicingHint::Perspective, Some(45.0));
        assert_eq!(pin.property(ProjectionProperty::FStop), None);
        let lens = make(
            &[
                ("float fStop", &["2.8"]),
                ("float focalLength", &["0.05"]),
                ("float focalDistance", &["3"]),
            ],
            Format::new(8, 8),
        );
        assert_lens_properties(lens.as_ref(), 2.8, 0.05, 3.0);
        // A finite f-stop without a focal length is still a pinhole.
        let no_fl = make(&[("float fStop", &["2.8"])], Format::new(8, 8));
        assert_eq!(no_fl.property(ProjectionProperty::FStop), None);
    }

    #[test]
    fn clipping_planes_become_distances_along_each_ray() {
        let mut env = ProjectionEnvironment::new(
            Format::new(8, 8),
            obscura_sdk::ScreenWindow::new(-1.0, 1.0, -1.0, 1.0),
            (0.0, 1.0),
            (2.0, 10.0),
            Vec::new(),
        );
        let p = PerspectiveFactory
            .create_projection(&mut env, &ParamList::new())
            .unwrap();
        let r = project_points(p.as_ref(), &[Point2::new(1.0, 1.0)], &[Point2::ZERO], &[0.0])[0];
        assert!(((r.direction * r.min_dist).z - 2.0).abs() < 1e-5);
        assert!(((r.direction * r.max_dist).z - 10.0).abs() < 1e-4);
    }

    #[test]
    fn bad_parameters_name_the_plugin_and_parameter() {
        let cases = [
            ("float fov", "0", "\"fov\" = 0 is out of range"),
            ("float fov", "180", "expected a value in [0.001, 180)"),
            ("float focalDistance", "-1", "\"focalDistance\""),
            ("float fovv", "40", "did you mean \"fov\""),
        ];
        assert_refused(&PerspectiveFactory, "PxrPerspective", Format::new(8, 8), &cases);
    }
}
