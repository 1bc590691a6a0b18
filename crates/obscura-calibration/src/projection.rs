//! `CalibratedCamera`: render exactly through a real camera's calibration.
//!
//! # Parameters
//!
//! | parameter | meaning |
//! |---|---|
//! | `string model` | one of [`MODEL_NAMES`]: COLMAP's names for its ids 0–17, then `OPENCV_PINHOLE`, `OPENCV_OMNIDIR`, `UCM`, `DOUBLE_SPHERE`, `KANNALA_BRANDT`, `OCAMCALIB`, `FTHETA`, and 3DEqualizer's eight models |
//! | `float[] params` | the model's scalars in the source library's order and units ([`MODELS`] lists each model's names) |
//! | `float[] polynomial` | OCAMCALIB's `pol` (a0 … aN, ascending, as `calib_results.txt`'s first polynomial line without its count); FTHETA's backward polynomial (pixel distance → angle, radians) |
//! | `float[] inversePolynomial` | OCAMCALIB's `invpol`; FTHETA's forward polynomial (angle → pixel distance) |
//! | `int[2] resolution` | width and height of the calibration image, in pixels |
//! | `string pixelConvention` | `auto`, `colmap`, `opencv` or `matlab` |
//!
//! Parameter lists per model (in order):
//!
//! - COLMAP ids 0–17, exactly as COLMAP's `models.h`: `SIMPLE_PINHOLE` f cx cy; `PINHOLE` fx fy cx cy;
//!   `SIMPLE_RADIAL` f cx cy k; `RADIAL` f cx cy k1 k2; `OPENCV` fx fy cx cy k1 k2 p1 p2;
//!   `OPENCV_FISHEYE` fx fy cx cy k1 k2 k3 k4; `FULL_OPENCV` fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6;
//!   `FOV` fx fy cx cy omega; `SIMPLE_RADIAL_FISHEYE` f cx cy k; `RADIAL_FISHEYE` f cx cy k1 k2;
//!   `THIN_PRISM_FISHEYE` fx fy cx cy k1 k2 p1 p2 k3 k4 sx1 sy1; `RAD_TAN_THIN_PRISM_FISHEYE` fx fy
//!   cx cy k0 … k5 p0 p1 s0 … s3; `SIMPLE_DIVISION` f cx cy k; `DIVISION` fx fy cx cy k;
//!   `SIMPLE_FISHEYE` f cx cy; `FISHEYE` fx fy cx cy; `EUCM` fx fy cx cy alpha beta;
//!   `EQUIRECTANGULAR` w h.
//! - `OPENCV_PINHOLE`: fx fy cx cy, then OpenCV's `distCoeffs` in OpenCV's order
//!   k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [τx τy]]]] — 4, 5, 8, 12 or 14 coefficients (τ in radians).
//! - `OPENCV_OMNIDIR` (Mei's unified model as `cv::omnidir`): fx fy cx cy s xi k1 k2 p1 p2, with the
//!   skew `s` as `K = [[fx, s, cx], [0, fy, cy]]`.
//! - `UCM` fx fy cx cy alpha — Usenko et al.'s formulation `u = fx·x/(α·d + (1 − α)·z) + cx`,
//!   `d = |X|`. The classic ξ form (Geyer, Mei: `u = γx·x/(z + ξ·d) + cx`) is the same camera with
//!   `α = ξ/(1 + ξ)` and `fx = γx/(1 + ξ)` (likewise fy).
//! - `DOUBLE_SPHERE` fx fy cx cy xi alpha (Usenko et al. 2018). `KANNALA_BRANDT` = `OPENCV_FISHEYE`
//!   (fx fy cx cy k1 k2 k3 k4) with OpenCV's pixel convention.
//! - `OCAMCALIB` xc yc c d e, with `polynomial` = `pol` and `inversePolynomial` = `invpol`
//!   (optional). As in OCamCalib, **xc is the row and yc the column** of the centre, and a sensor
//!   point (x, y) is seen at row `c·x + d·y + xc`, column `e·x + y + yc`; the ray of a pixel is
//!   `(x, y, pol(ρ))` in OCamCalib's frame (x along rows, y along columns, looking down −z), i.e.
//!   `(y, x, −pol(ρ))` in OpenCV's.
//! - 3DEqualizer's models, by 3DE's names (`3DE Classic LD Model`, `3DE4 Radial - Standard, Degree 4`,
//!   `3DE4 Anamorphic - Standard, Degree 4`/`6`, `3DE4 Anamorphic - Rescaled, Degree 4`/`6`,
//!   `3DE4 Anamorphic, Degree 6`, `3DE4 Radial - Fisheye, Degree 8`): the built-in knobs
//!   `tde4_focal_length_cm tde4_filmback_width_cm tde4_filmback_height_cm
//!   tde4_lens_center_offset_x_cm tde4_lens_center_offset_y_cm tde4_pixel_aspect
//!   field_of_view_xa_unit field_of_view_xb_unit field_of_view_ya_unit field_of_view_yb_unit`, then
//!   the model's parameters in 3DE's order ([`crate::lens3de`] gives the mapping); `resolution` is the
//!   plate's size, and model pixels are raster positions (3DE's unit coordinates are corner-based).
//! - `FTHETA` (NVIDIA) cx cy [maxAngle [c d e]]: principal point, largest ray angle (radians,
//!   default π) and the linear term `[c d; e 1]` (default identity): a sensor offset `m` is seen at
//!   `(u, v) = [c d; e 1]·m + (cx, cy)`, at angle θ from the axis with `θ = polynomial(|m|)`. When
//!   `polynomial` is given it is the reference and `inversePolynomial` only seeds the exact inverse;
//!   with `inversePolynomial` alone, `|m| = inversePolynomial(θ)` is the reference.
//!
//! # Pixel conventions
//!
//! `colmap`: the top-left pixel's centre is (0.5, 0.5) (pixel (i, j) spans [i, i+1)), i.e. model
//! pixel = raster position. `opencv`: the centre is (0, 0), model pixel = raster − 0.5. `matlab`:
//! the centre is (1, 1), model pixel = raster + 0.5. `auto` picks colmap for COLMAP's ids 0–17, and
//! opencv for OPENCV_PINHOLE, OPENCV_OMNIDIR, UCM, DOUBLE_SPHERE, KANNALA_BRANDT, FTHETA (NVIDIA counts
//! pixel indices at pixel centres) and OCAMCALIB: OCamCalib itself is 1-based MATLAB, but its
//! exported `calib_results.txt` subtracts 1 ("starting from 0 (C convention)"), so values from that
//! file are opencv; values copied from MATLAB's `ocam_model` struct need `matlab`.
//!
//! # Placement
//!
//! The calibrated image spans the screen window exactly: the screen point `(sx, sy)` is the
//! calibration raster position
//!
//! ```text
//! u = (sx − l)/(r − l)·W_cal,    v = (t − sy)/(t − b)·H_cal
//! ```
//!
//! (y down, continuous), then shifted to the model's pixel convention. A render at another
//! resolution therefore shows the same camera (half size, 4K: same rays at corresponding screen
//! points). A render whose frame aspect differs from the calibration's shows the calibrated image
//! **resized** to the render's format, exactly as resizing the photograph would (COLMAP's
//! `CameraModelRescale` with per-axis factors, OpenCV's `K` scaled by `W/W_cal`, `H/H_cal`): the
//! mapping stays exact, the picture is stretched. To match pixel for pixel, render at the
//! calibration's aspect (the CLI's `--calibration` sets the format from the file).
//!
//! # Camera space
//!
//! OpenCV and COLMAP use +Y **down** (and +Z forward); Obscura uses +Y up. The flip happens in one
//! place: `project` writes `(X, −Y, Z)` of the model's unit ray, and `unproject` hands the model
//! `(x, −y, z)` of the camera-space point. A point above the principal point (smaller v) appears at +Y.
//!
//! # Exactness
//!
//! Everything is evaluated in f64. Iterative inverses (the rad-tan and fisheye distortions,
//! OCamCalib's and f-theta's polynomials) use Newton with analytic Jacobians, bracketed by bisection
//! in one dimension and a trust region in two, iterate to the last bits (at most 100 steps) and
//! accept a solution only when its residual is below 1e-11 in normalised coordinates; otherwise the
//! sample is culled. Where a forward map folds over (a rational or polynomial distortion past its
//! monotonic range, a polynomial angle map past its maximum), the region beyond the fold is invalid in
//! both directions: `project` culls it, `unproject` returns `None`. No field of view is clamped to
//! 180°: equidistant-type models reach θ = π (or their fold), unified/EUCM/double sphere/Mei reach
//! their validity bounds, equirectangular covers the sphere.
//!
//! # Properties
//!
//! - FieldOfView: the angle across the narrower calibrated image side, through the principal point
//!   (the angle from the principal ray to each edge midpoint's ray, summed; a culled edge point is
//!   replaced by the last valid point on the way there). It may exceed 180°.
//! - DicingHint Perspective for the pinhole-plane models (every ray `(x, y, 1)`: pinhole, radial,
//!   OpenCV, FULL_OPENCV, OPENCV_PINHOLE), else Spherical.
//! - DeepMetric RayLength when some valid ray may point at or behind the camera plane, else CameraZ.
//! - Rays start at the origin (`origin_radius` 0); `ray_spread = ½·sqrt(αx·αy)` with αx, αy the
//!   angle the direction turns per render pixel along x and y, from the analytic Jacobian.
//! - Clipping follows the deep metric (`obscura_sdk::contract::clipping_distances`): planes
//!   (`near/D.z`, `far/D.z`) for CameraZ, spheres (`near`, `far`) for RayLength.

use std::sync::LazyLock;

use obscura_sdk::{
    DeepMetric, DicingHint, ParamDecl, ParamList, ParamValue, Params, PluginError, Point2, Projection,
    ProjectionContext, ProjectionEnvironment, ProjectionFactory, ProjectionProperty, PropertyValue,
    RayGeometry, RaysSoa, SoaContext, ValueRange, Vec3, simd,
};

use crate::NAME;
use crate::models::{CHUNK, CameraModel, LaneRay, MODEL_NAMES, MODELS, PixelConvention, PixelRay, RayKernel};
use crate::solve;

/// The default camera: a 90° (horizontal) pinhole on a 640×480 image.
const DEFAULT_PARAMS: [f32; 4] = [320.0, 320.0, 320.0, 240.0];

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    vec![
        ParamDecl::string("model", "PINHOLE")
            .choices(&MODEL_NAMES)
            .doc("camera model: COLMAP's names (ids 0-17), OPENCV_PINHOLE, OPENCV_OMNIDIR, UCM, DOUBLE_SPHERE, KANNALA_BRANDT, OCAMCALIB, FTHETA, 3DEqualizer's models by their 3DE names"),
        ParamDecl::float_list("params", &DEFAULT_PARAMS)
            .doc("the model's parameters in the source library's order and units (e.g. PINHOLE: fx fy cx cy)"),
        ParamDecl::float_list("polynomial", &[])
            .doc("OCAMCALIB: pol a0..aN (ascending); FTHETA: backward polynomial, pixel distance -> angle (rad)"),
        ParamDecl::float_list("inversePolynomial", &[])
            .doc("OCAMCALIB: invpol (ascending); FTHETA: forward polynomial, angle (rad) -> pixel distance"),
        ParamDecl::int_array("resolution", &[640, 480])
            .range(ValueRange::closed(1.0, 1e6))
            .doc("width and height of the calibration image in pixels (required with model or params)"),
        ParamDecl::string("pixelConvention", "auto")
            .choices(&["auto", "colmap", "opencv", "matlab"])
            .doc("pixel centres: colmap (top-left at 0.5,0.5), opencv (at 0,0), matlab (at 1,1); auto = the model's library"),
    ]
});

/// Creates [`CalibratedCamera`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct CalibratedCameraFactory;

fn invalid(message: String) -> PluginError {
    PluginError::Invalid {
        plugin: NAME.to_string(),
        message,
    }
}

impl ProjectionFactory for CalibratedCameraFactory {
    fn name(&self) -> &str {
        NAME
    }

    fn summary(&self) -> &str {
        "a real camera's calibration (COLMAP, OpenCV, Kalibr, OCamCalib, f-theta, 3DEqualizer models), exact both ways"
    }

    fn param_table(&self) -> &[ParamDecl] {
        &TABLE
    }

    /// Each model's `params`, by name and in order, and the pixel convention "auto" picks for it.
    fn listing_notes(&self) -> Vec<String> {
        let width = MODELS.iter().map(|m| m.name.len()).max().unwrap_or(0);
        let mut lines = vec!["params of each model (in order; [ ] = optional tail):".to_string()];
        lines.extend(MODELS.iter().enumerate().map(|(i, m)| {
            let id = if i < 18 {
                format!("COLMAP {i:>2}")
            } else {
                "         ".to_string()
            };
            let extra = if m.polynomials {
                " + polynomial, inversePolynomial"
            } else {
                ""
            };
            let convention = match m.convention {
                PixelConvention::Colmap => "colmap",
                PixelConvention::OpenCv => "opencv",
                PixelConvention::Matlab => "matlab",
            };
            format!(
                "  {:width$}  {id}  pixels {convention:6}  {}{extra}",
                m.name, m.params
            )
        }));
        lines
    }

    fn create_projection(
        &self,
        env: &mut ProjectionEnvironment,
        params: &ParamList,
    ) -> Result<Box<dyn Projection>, PluginError> {
        let p = Params::resolve(NAME, &TABLE, params)?;
        let model = p.string("model")?;
        if (p.is_given("model") || p.is_given("params")) && !p.is_given("resolution") {
            return Err(invalid(format!(
                "resolution is required with a calibration (model {model}): give \"int[2] resolution\" [width height] of the calibration image"
            )));
        }
        let resolution = match params.get("resolution").map(|e| &e.value) {
            Some(ParamValue::Ints(v)) if v.len() == 2 => [v[0], v[1]],
            _ => [640, 480],
        };
        let to64 = |v: &[f32]| v.iter().map(|&x| x as f64).collect::<Vec<f64>>();
        let convention = match p.string("pixelConvention")? {
            "colmap" => Some(PixelConvention::Colmap),
            "opencv" => Some(PixelConvention::OpenCv),
            "matlab" => Some(PixelConvention::Matlab),
            _ => None,
        };
        let camera = CameraModel::new(
            model,
            &to64(p.float_list("params")?),
            &to64(p.float_list("polynomial")?),
            &to64(p.float_list("inversePolynomial")?),
            resolution[0] as f64,
            resolution[1] as f64,
        )
        .map_err(invalid)?;
        let c = CalibratedCamera::new(env, camera, resolution, convention);
        env.set_deep_metric(c.deep_metric);
        Ok(Box::new(c))
    }
}

/// A projection through a calibrated camera model (see the module documentation).
#[derive(Debug, Clone)]
pub struct CalibratedCamera {
    model: CameraModel,
    convention: PixelConvention,
    /// Model pixel `u = su·sx + ou`, `v = sv·sy + ov`.
    su: f64,
    ou: f64,
    sv: f64,
    ov: f64,
    /// `sqrt` of the product of the calibration pixels per render pixel along x and y.
    pixel_scale: f64,
    planar: bool,
    /// Clipping planes (DeepMetric CameraZ) rather than spheres (RayLength).
    clip_planes: bool,
    near: f32,
    far: f32,
    fov: f32,
    deep_metric: DeepMetric,
}

impl CalibratedCamera {
    /// A projection of `model` for a calibration image of `resolution` (width, height), placed on
    /// `env`'s screen window; `convention` `None` is the model's own (`auto`).
    #[must_use]
    pub fn new(
        env: &ProjectionEnvironment,
        model: CameraModel,
        resolution: [i32; 2],
        convention: Option<PixelConvention>,
    ) -> Self {
        let convention = convention.unwrap_or(model.info().convention);
        let w = env.screen_window();
        let (wc, hc) = (resolution[0] as f64, resolution[1] as f64);
        let (l, r, b, t) = (w.left as f64, w.right as f64, w.bottom as f64, w.top as f64);
        let shift = convention.shift();
        let su = wc / (r - l);
        let sv = -hc / (t - b);
        let planar = model.is_planar();
        let deep_metric = if model.may_leave_front() {
            DeepMetric::RayLength
        } else {
            DeepMetric::CameraZ
        };
        let mut cam = CalibratedCamera {
            su,
            ou: -l * su + shift,
            sv,
            ov: t * hc / (t - b) + shift,
            pixel_scale: (wc / env.width() as f64 * hc / env.height() as f64).sqrt(),
            planar,
            clip_planes: deep_metric == DeepMetric::CameraZ,
            near: env.clipping_near(),
            far: env.clipping_far(),
            fov: 90.0,
            deep_metric,
            model,
            convention,
        };
        cam.fov = cam.field_of_view(wc, hc) as f32;
        cam
    }

    /// The calibration model.
    #[must_use]
    pub fn model(&self) -> &CameraModel {
        &self.model
    }

    /// The pixel convention in use (after `auto` is resolved).
    #[must_use]
    pub fn convention(&self) -> PixelConvention {
        self.convention
    }

    /// The unit ray (OpenCV camera space) at calibration raster position `(u, v)`.
    fn raster_ray(&self, u: f64, v: f64) -> Option<[f64; 3]> {
        let s = self.convention.shift();
        let r = self.model.pixel_to_ray([u + s, v + s])?;
        let n = (r.v[0] * r.v[0] + r.v[1] * r.v[1] + r.v[2] * r.v[2]).sqrt();
        (n > 0.0 && n.is_finite()).then(|| [r.v[0] / n, r.v[1] / n, r.v[2] / n])
    }

    /// The angle across the narrower calibrated side through the principal point, in degrees.
    fn field_of_view(&self, wc: f64, hc: f64) -> f64 {
        let s = self.convention.shift();
        let pp = self
            .model
            .ray_to_pixel([0.0, 0.0, 1.0])
            .map(|p| [p[0] - s, p[1] - s])
            .filter(|p| self.raster_ray(p[0], p[1]).is_some())
            .unwrap_or([0.5 * wc, 0.5 * hc]);
        let Some(axis) = self.raster_ray(pp[0], pp[1]) else {
            return 90.0;
        };
        let ends = if wc <= hc {
            [[0.0, pp[1]], [wc, pp[1]]]
        } else {
            [[pp[0], 0.0], [pp[0], hc]]
        };
        let mut total = 0.0;
        for e in ends {
            let at = |f: f64| self.raster_ray(pp[0] + f * (e[0] - pp[0]), pp[1] + f * (e[1] - pp[1]));
            let ray = at(1.0).or_else(|| at(solve::bisect(0.0, 1.0, 50, |f| at(f).is_some())));
            if let Some(d) = ray {
                total += angle_between(axis, d);
            }
        }
        let deg = total.to_degrees();
        if deg.is_finite() && deg > 1e-3 { deg } else { 90.0 }
    }

    /// The ray geometry of a model ray `r`, or the culled ray: the per-ray reference of the batch
    /// loop's geometry stage (which the tests hold it to, bit for bit).
    #[cfg(test)]
    fn geometry(&self, r: PixelRay) -> RayGeometry {
        let [x, y, z] = r.v;
        let n2 = x * x + y * y + z * z;
        if !(n2 > 0.0 && n2.is_finite()) {
            return RayGeometry::CULLED;
        }
        let inv = 1.0 / n2.sqrt();
        // Squared turn of the unit direction per model pixel along u and v,
        // |∂V − D(D·∂V)|²/|V|² = (|∂V|²·|V|² − (V·∂V)²)/|V|⁴; spread = ½·sqrt(αx·αy) with
        // αx = turn_u·(pixels per render pixel in x), likewise y.
        let turn = |c: usize| {
            let dv = [r.dv[0][c], r.dv[1][c], r.dv[2][c]];
            let k = x * dv[0] + y * dv[1] + z * dv[2];
            ((dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]) * n2 - k * k).max(0.0)
        };
        // αx²·αy² (rad⁴ per model pixel⁴) is formed in f64 and its fourth root taken in f32: the
        // spread is an f32, and any real camera's per-pixel angle (1e-9 … 1 rad) keeps the product
        // well inside f32's range; a non-finite result gives spread 0 below.
        let i4 = (inv * inv) * (inv * inv);
        let product = (turn(0) * turn(1) * i4 * i4) as f32;
        let spread = 0.5 * product.sqrt().sqrt() * self.pixel_scale as f32;
        let direction = Vec3::new((x * inv) as f32, -(y * inv) as f32, (z * inv) as f32);
        let (min_dist, max_dist) = if self.clip_planes {
            let k = 1.0 / direction.z;
            (self.near * k, self.far * k)
        } else {
            (self.near, self.far)
        };
        RayGeometry {
            origin: Vec3::ZERO,
            origin_radius: 0.0,
            direction,
            ray_spread: if spread.is_finite() { spread } else { 0.0 },
            min_dist,
            max_dist,
        }
    }
}

/// One `project` (or `project_soa`) batch, run with the model's specialised pixel → ray map.
struct Batch<'a, O: RaysOut> {
    camera: &'a CalibratedCamera,
    screen: &'a [Point2],
    rays: O,
}

/// Where a batch's rays go: RenderMan's records (`project`) or one array per field (`project_soa`).
trait RaysOut {
    /// The number of rays.
    fn len(&self) -> usize;

    /// Writes rays `start .. start + n` (`n ≤ CHUNK`) from a chunk's lanes: where `valid`, origin and
    /// origin radius 0 and `out` = (direction x, y, z, spread, min, max); elsewhere the culled ray.
    fn put(&mut self, start: usize, n: usize, valid: &[bool; CHUNK], out: &[[f32; CHUNK]; 6]);
}

impl RaysOut for &mut [RayGeometry] {
    fn len(&self) -> usize {
        <[RayGeometry]>::len(self)
    }

    #[inline(always)]
    fn put(&mut self, start: usize, n: usize, valid: &[bool; CHUNK], out: &[[f32; CHUNK]; 6]) {
        for (i, ray) in self[start..start + n].iter_mut().enumerate() {
            *ray = if valid[i] {
                RayGeometry {
                    origin: Vec3::ZERO,
                    origin_radius: 0.0,
                    direction: Vec3::new(out[0][i], out[1][i], out[2][i]),
                    ray_spread: out[3][i],
                    min_dist: out[4][i],
                    max_dist: out[5][i],
                }
            } else {
                RayGeometry::CULLED
            };
        }
    }
}

impl RaysOut for &mut RaysSoa<'_> {
    fn len(&self) -> usize {
        RaysSoa::len(self)
    }

    #[inline(always)]
    fn put(&mut self, start: usize, n: usize, valid: &[bool; CHUNK], out: &[[f32; CHUNK]; 6]) {
        let culled = RayGeometry::CULLED.to_bits().map(f32::from_bits);
        for (k, field) in self.fields_mut().into_iter().enumerate() {
            // Fields 0–3 (origin, origin radius) are 0 on every ray, culled or not; 4–9 from `out`.
            for (i, f) in field[start..start + n].iter_mut().enumerate() {
                *f = if k >= 4 && valid[i] {
                    out[k - 4][i]
                } else {
                    culled[k]
                };
            }
        }
    }
}

/// A chunk of model rays, structure-of-arrays: `v[k][i]` is component k of lane i's ray, `dv[2k + c]`
/// its derivative by pixel coordinate c.
struct Lanes {
    ok: [bool; CHUNK],
    redo: [bool; CHUNK],
    v: [[f64; CHUNK]; 3],
    dv: [[f64; CHUNK]; 6],
}

impl Lanes {
    #[inline(always)]
    fn set(&mut self, i: usize, ok: bool, r: &PixelRay) {
        self.ok[i] = ok;
        for k in 0..3 {
            self.v[k][i] = r.v[k];
            self.dv[2 * k][i] = r.dv[k][0];
            self.dv[2 * k + 1][i] = r.dv[k][1];
        }
    }
}

impl<O: RaysOut> Batch<'_, O> {
    /// The batch loop: per chunk, the model pixels, then the model rays of every lane (`fill`: a
    /// branch-free loop over lanes that vectorises, or a whole-chunk kernel; lanes flagged `redo`
    /// recomputed with `scalar`), then
    /// the ray geometry of every lane (branch-free as well), then the rays written out. Run in
    /// the widest instruction set the CPU has (AVX2 + FMA where present): Rust never contracts
    /// `a*b + c` on its own, so every path gives the same bits as [`CalibratedCamera::geometry`]
    /// of [`CameraModel::pixel_to_ray`].
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // lockstep loops over several lane arrays vectorise
    fn run(
        self,
        fill: impl Fn(&[f64; CHUNK], &[f64; CHUNK], &mut Lanes),
        scalar: impl Fn([f64; 2]) -> Option<PixelRay>,
    ) {
        let c = self.camera;
        let (mut rays, screen) = (self.rays, self.screen);
        let screen = &screen[..screen.len().min(rays.len())];
        let ps = c.pixel_scale as f32;
        let (near, far, planar) = (c.near, c.far, c.clip_planes);
        simd::run(
            #[inline(always)]
            move || {
                let mut l = Lanes {
                    ok: [false; CHUNK],
                    redo: [false; CHUNK],
                    v: [[0.0; CHUNK]; 3],
                    dv: [[0.0; CHUNK]; 6],
                };
                let (mut u, mut v) = ([0.0f64; CHUNK], [0.0f64; CHUNK]);
                let mut out = [[0.0f32; CHUNK]; 6];
                let mut valid = [false; CHUNK];
                for (start, screen) in (0..).step_by(CHUNK).zip(screen.chunks(CHUNK)) {
                    for ((u, v), s) in u.iter_mut().zip(v.iter_mut()).zip(screen) {
                        *u = c.su * s.x as f64 + c.ou;
                        *v = c.sv * s.y as f64 + c.ov;
                    }
                    fill(&u, &v, &mut l);
                    if l.redo.iter().any(|&r| r) {
                        for i in 0..screen.len() {
                            if l.redo[i] {
                                match scalar([u[i], v[i]]) {
                                    Some(r) => l.set(i, true, &r),
                                    None => l.ok[i] = false,
                                }
                            }
                        }
                    }
                    // `CalibratedCamera::geometry`, lane by lane, without branches.
                    for i in 0..CHUNK {
                        let (x, y, z) = (l.v[0][i], l.v[1][i], l.v[2][i]);
                        let n2 = x * x + y * y + z * z;
                        valid[i] = l.ok[i] & (n2 > 0.0) & n2.is_finite();
                        let inv = 1.0 / n2.sqrt();
                        let turn = |c: usize| {
                            let dv = [l.dv[c][i], l.dv[2 + c][i], l.dv[4 + c][i]];
                            let k = x * dv[0] + y * dv[1] + z * dv[2];
                            ((dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]) * n2 - k * k).max(0.0)
                        };
                        let i4 = (inv * inv) * (inv * inv);
                        let product = (turn(0) * turn(1) * i4 * i4) as f32;
                        let spread = 0.5 * product.sqrt().sqrt() * ps;
                        let dz = (z * inv) as f32;
                        let k = 1.0 / dz;
                        out[0][i] = (x * inv) as f32;
                        out[1][i] = -(y * inv) as f32;
                        out[2][i] = dz;
                        out[3][i] = if spread.is_finite() { spread } else { 0.0 };
                        out[4][i] = if planar { near * k } else { near };
                        out[5][i] = if planar { far * k } else { far };
                    }
                    rays.put(start, screen.len(), &valid, &out);
                }
            },
        );
    }
}

impl<O: RaysOut> RayKernel for Batch<'_, O> {
    #[inline(always)]
    fn visit(self, kernel: impl Fn([f64; 2]) -> Option<PixelRay>) {
        const NONE: PixelRay = LaneRay::NONE.ray;
        self.visit_lanes(
            |px| match kernel(px) {
                Some(ray) => LaneRay {
                    ok: true,
                    redo: false,
                    ray,
                },
                None => LaneRay {
                    ok: false,
                    redo: false,
                    ray: NONE,
                },
            },
            |_| None,
        );
    }

    #[inline(always)]
    fn visit_lanes(self, lanes: impl Fn([f64; 2]) -> LaneRay, scalar: impl Fn([f64; 2]) -> Option<PixelRay>) {
        self.run(
            #[inline(always)]
            |u, v, l| {
                for i in 0..CHUNK {
                    let r = lanes([u[i], v[i]]);
                    l.set(i, r.ok, &r.ray);
                    l.redo[i] = r.redo;
                }
            },
            scalar,
        );
    }

    #[inline(always)]
    fn visit_chunks(
        self,
        chunk: impl Fn(&[[f64; 2]; CHUNK], &mut [LaneRay; CHUNK]),
        scalar: impl Fn([f64; 2]) -> Option<PixelRay>,
    ) {
        self.run(
            #[inline(always)]
            |u, v, l| {
                let px: [[f64; 2]; CHUNK] = std::array::from_fn(|i| [u[i], v[i]]);
                let mut out = [LaneRay::NONE; CHUNK];
                chunk(&px, &mut out);
                for (i, r) in out.iter().enumerate() {
                    l.set(i, r.ok, &r.ray);
                    l.redo[i] = r.redo;
                }
            },
            scalar,
        );
    }
}

/// The angle between `a` and `b` (any lengths), accurate at any angle (unlike `acos` of the dot
/// product near 0 and π).
pub(crate) fn angle_between(a: [f64; 3], b: [f64; 3]) -> f64 {
    let c = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    (c[0] * c[0] + c[1] * c[1] + c[2] * c[2])
        .sqrt()
        .atan2(a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
}

impl Projection for CalibratedCamera {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        match property {
            ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(if self.planar {
                DicingHint::Perspective
            } else {
                DicingHint::Spherical
            })),
            ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(self.deep_metric)),
            ProjectionProperty::FieldOfView => Some(PropertyValue::Float(self.fov)),
            _ => None,
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        let batch = Batch {
            camera: self,
            screen: c.screen,
            rays: c.rays,
        };
        self.model.with_kernel(batch);
    }

    /// The rays of `project`, bit for bit, written one array per field by the same batch loop (only
    /// the chunk's write-out differs).
    fn project_soa(&self, ctx: &mut SoaContext<'_>) -> bool {
        let batch = Batch {
            camera: self,
            screen: ctx.screen,
            rays: &mut ctx.rays,
        };
        self.model.with_kernel(batch);
        true
    }

    fn unproject(&self, point: Vec3, _time: f32) -> Option<Point2> {
        if !point.is_finite() {
            return None;
        }
        let px = self
            .model
            .ray_to_pixel([point.x as f64, -(point.y as f64), point.z as f64])?;
        let sx = (px[0] - self.ou) / self.su;
        let sy = (px[1] - self.ov) / self.sv;
        let s = Point2::new(sx as f32, sy as f32);
        (s.x.is_finite() && s.y.is_finite()).then_some(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::{Format, Rgb, ScreenWindow};

    /// Every model family's batch kernel computes exactly what the per-pixel API does (the same
    /// f64 ray, bit for bit, so the projection is the API in f32).
    #[test]
    fn the_batch_kernels_are_the_per_pixel_map() {
        let cases: [(&str, &[f64]); 8] = [
            ("PINHOLE", &[500.0, 490.0, 320.0, 240.0]),
            (
                "OPENCV",
                &[500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005],
            ),
            (
                "KANNALA_BRANDT",
                &[300.0, 300.0, 320.0, 240.0, -0.01, 0.02, -0.003, 0.0005],
            ),
            ("EUCM", &[350.0, 350.0, 320.0, 240.0, 0.6, 1.1]),
            ("DOUBLE_SPHERE", &[250.0, 250.0, 320.0, 240.0, -0.2, 0.59]),
            ("FOV", &[300.0, 300.0, 320.0, 240.0, 0.9]),
            ("EQUIRECTANGULAR", &[640.0, 480.0]),
            (
                "OPENCV_OMNIDIR",
                &[400.0, 400.0, 320.0, 240.0, 0.5, 1.2, -0.1, 0.02, 0.001, -0.0005],
            ),
        ];
        let n = 2000;
        let screen = spread_over_640x480(n, 30.0);
        for (model, params) in cases {
            let valid = batch_matches_per_pixel(model, params, &[], &[], &screen);
            assert!(valid > n / 2, "{model}: {valid}");
        }
    }

    /// `n` screen positions spread over a 640×480 frame and a margin of `margin_x` pixels left and
    /// right (three quarters of that above and below) by a golden-ratio sequence.
    fn spread_over_640x480(n: usize, margin_x: f64) -> Vec<Point2> {
        let format = Format::new(640, 480);
        let w = ScreenWindow::default_for(format);
        let margin_y = 0.75 * margin_x;
        (0..n)
            .map(|i| {
                let fx = (i as f64 * 0.618_033_988_75).fract();
                let fy = (i as f64 * 0.754_877_666_25).fract();
                w.raster_to_screen(
                    format,
                    fx * (640.0 + 2.0 * margin_x) - margin_x,
                    fy * (480.0 + 2.0 * margin_y) - margin_y,
                )
            })
            .collect()
    }

    /// Projects `screen` through a model and checks every ray against the per-pixel API, bit for
    /// bit; returns the number of valid rays.
    fn batch_matches_per_pixel(
        model: &str,
        params: &[f64],
        pol: &[f64],
        inv: &[f64],
        screen: &[Point2],
    ) -> usize {
        let format = Format::new(640, 480);
        let env = ProjectionEnvironment::for_format(format);
        let m = CameraModel::new(model, params, pol, inv, 640.0, 480.0).unwrap();
        let cam = CalibratedCamera::new(&env, m, [640, 480], None);
        let n = screen.len();
        let (lens, mut time) = (vec![Point2::ZERO; n], vec![0.0; n]);
        let (mut rays, mut tint) = (vec![RayGeometry::CULLED; n], vec![Rgb::WHITE; n]);
        let mut ctx = ProjectionContext::new(screen, &lens, &lens, &mut time, &mut rays, &mut tint).unwrap();
        cam.project(&mut ctx);
        let mut valid = 0;
        for (s, r) in screen.iter().zip(&rays) {
            let px = [cam.su * s.x as f64 + cam.ou, cam.sv * s.y as f64 + cam.ov];
            let expected = cam
                .model
                .pixel_to_ray(px)
                .map_or(RayGeometry::CULLED, |p| cam.geometry(p));
            assert_eq!(*r, expected, "{model} at {s:?}");
            valid += usize::from(!r.is_culled());
        }
        // `project_soa` writes the same rays bit for bit at every tier, for every tail of the
        // 32-lane chunks and for the whole batch (the culled samples beyond the frame included).
        for level in simd::Level::ALL.into_iter().filter(|l| l.is_available()) {
            for m in (0..=CHUNK + 2).chain([n]).filter(|&m| m <= n) {
                let (s, l, t) = (&screen[..m], &lens[..m], &time[..m]);
                let check = simd::with_level(level, || obscura_sdk::check_project_soa(&cam, s, l, t));
                assert_eq!(
                    check,
                    Ok(true),
                    "{model}: project_soa of {m} samples, tier {level}"
                );
            }
        }
        valid
    }

    /// The vectorised closed-form kernels (and the scalar ones behind them) of every family not in
    /// `the_batch_kernels_are_the_per_pixel_map`, including the lanes that fall back to the
    /// per-pixel map: an equirectangular azimuth beyond the fast sine's range, an OCamCalib
    /// polynomial too long for the fixed-length kernels. Batch lengths that are not a multiple of
    /// the chunk exercise the tail.
    #[test]
    fn every_family_batch_is_its_per_pixel_map() {
        let format = Format::new(640, 480);
        let w = ScreenWindow::default_for(format);
        let n = 1001;
        let screen = spread_over_640x480(n, 80.0);
        let pol5 = [-206.517, 0.0, 2.207161e-03, -4.879622e-06, 1.865656e-08];
        let pol8 = [-206.517, 0.0, 2.2e-03, -4.9e-06, 1.9e-08, 1e-12, -1e-15, 1e-19];
        let mut pol14 = pol5.to_vec();
        pol14.resize(14, 0.0);
        pol14[13] = 1e-40;
        let ocam = [239.5, 319.5, 1.00033, 0.000219, 0.000257];
        /// (model, params, polynomial, inversePolynomial).
        type Case<'a> = (&'a str, &'a [f64], &'a [f64], &'a [f64]);
        let cases: [Case; 19] = [
            ("SIMPLE_PINHOLE", &[500.0, 320.0, 240.0], &[], &[]),
            ("FISHEYE", &[200.0, 210.0, 320.0, 240.0], &[], &[]),
            ("DIVISION", &[400.0, 405.0, 320.0, 240.0, -0.15], &[], &[]),
            ("SIMPLE_DIVISION", &[400.0, 320.0, 240.0, 0.3], &[], &[]),
            ("UCM", &[300.0, 300.0, 320.0, 240.0, 0.58], &[], &[]),
            ("DOUBLE_SPHERE", &[200.0, 200.0, 320.0, 240.0, 0.4, 0.3], &[], &[]),
            ("FOV", &[250.0, 250.0, 320.0, 240.0, 1.2], &[], &[]),
            ("EQUIRECTANGULAR", &[640.0, 480.0], &[], &[]),
            ("OCAMCALIB", &ocam, &pol5, &[]),
            ("OCAMCALIB", &ocam, &pol8, &[]),
            ("OCAMCALIB", &ocam, &pol14, &[]),
            ("RADIAL", &[500.0, 320.0, 240.0, -0.2, 0.05], &[], &[]),
            (
                "FULL_OPENCV",
                &[
                    500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005, -0.002, 0.01, 0.003, 0.0002,
                ],
                &[],
                &[],
            ),
            ("FTHETA", &[319.5, 239.5, 1.7], &[], &[0.0, 250.0, -5.0, 1.0]),
            // The chunked Newton kernels: OpenCV order with rational, prism and tilt terms; the
            // Kannala–Brandt θ-plane; Aria order; Mei's sphere with radial-tangential terms.
            (
                "OPENCV_PINHOLE",
                &[
                    500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005, -0.002, 0.01, 0.003, 0.0002,
                    0.001, -0.0002, 0.0008, 0.0001, 0.01, -0.008,
                ],
                &[],
                &[],
            ),
            (
                "OPENCV",
                &[500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005],
                &[],
                &[],
            ),
            (
                "KANNALA_BRANDT",
                &[300.0, 300.0, 320.0, 240.0, -0.01, 0.02, -0.003, 0.0005],
                &[],
                &[],
            ),
            (
                "RAD_TAN_THIN_PRISM_FISHEYE",
                &[
                    240.0, 241.0, 320.0, 240.0, 0.02, -0.004, 0.0005, -0.0001, 0.00002, -0.000003, 0.0008,
                    -0.0006, 0.0004, -0.0001, 0.0003, 0.00005,
                ],
                &[],
                &[],
            ),
            (
                "OPENCV_OMNIDIR",
                &[400.0, 400.0, 320.0, 240.0, 0.5, 1.2, -0.1, 0.02, 0.001, -0.0005],
                &[],
                &[],
            ),
        ];
        for (model, params, pol, inv) in cases {
            let valid = batch_matches_per_pixel(model, params, pol, inv, &screen);
            assert!(valid > n / 3, "{model}: {valid}");
        }
        // Equirectangular azimuths far beyond ±π (and beyond the fast sine's 1e5 rad) wrap around.
        let far: Vec<Point2> = (0..77)
            .map(|i| {
                w.raster_to_screen(
                    format,
                    1e7 * (i as f64 - 38.0) + 0.37 * i as f64,
                    240.0 + i as f64,
                )
            })
            .collect();
        let valid = batch_matches_per_pixel("EQUIRECTANGULAR", &[640.0, 480.0], &[], &[], &far);
        assert_eq!(valid, far.len());
    }
}
