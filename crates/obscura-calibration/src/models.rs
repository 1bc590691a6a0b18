//! Every calibration model, as one pipeline in f64.
//!
//! Pixel → ray (what rendering needs, "unprojection" in computer-vision terms):
//!
//! ```text
//! pixel (u, v) ─A⁻¹─▶ m_t ─tilt⁻¹─▶ m_d ─undistort─▶ m ─lift─▶ V (camera space, y down)
//! ```
//!
//! - `A`, `c`: the intrinsic affine map `pixel = A·m_t + c` (`A = [[fx, s], [0, fy]]` for the
//!   pinhole family, OCamCalib's `[c d; e 1]` with its row/column swap, f-theta's linear term);
//! - tilt: OpenCV's tilted-sensor homography (14-coefficient model only);
//! - undistort: the exact inverse of the model's polynomial distortion
//!   (`distortion.rs`), on the perspective plane (`m = (x/z, y/z)`) or the equidistant plane
//!   (`m = θ·(x, y)/|(x, y)|`) of COLMAP's fisheye models;
//! - lift: the model's ray of `m` (`lift.rs`): pinhole, equidistant, unified/EUCM, Mei,
//!   double sphere, division, FOV, equirectangular, OCamCalib's `pol`, f-theta's angle polynomial.
//!
//! Ray → pixel ("projection" in CV terms) runs the same stages forward. Each stage's Jacobian is
//! chained analytically so the projection can size each ray's footprint.
//!
//! Pixel coordinates here are the model's own (its library's pixel convention); the projection
//! converts from raster space.

use crate::distortion::{Distortion, SEEDED_ITERATIONS, Tilt};
use crate::lens3de::{self, Kind};
use crate::lift::{self, Forward, Lift, Lifted};
use crate::solve::{self, Mat2, Mat32, apply2, inv2, mul2, mul32};

/// Where a library puts pixel centres, relative to raster space (top-left image corner at (0, 0)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PixelConvention {
    /// COLMAP: the top-left pixel's centre is (0.5, 0.5); model pixel = raster position.
    Colmap,
    /// OpenCV (and Kalibr, basalt, OCamCalib's `calib_results.txt`, NVIDIA): the top-left pixel's
    /// centre is (0, 0); model pixel = raster position − 0.5.
    OpenCv,
    /// MATLAB (OCamCalib's workspace values, 1-based): the top-left pixel's centre is (1, 1); model
    /// pixel = raster position + 0.5.
    Matlab,
}

impl PixelConvention {
    /// The name the `pixelConvention` parameter uses.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            PixelConvention::Colmap => "colmap",
            PixelConvention::OpenCv => "opencv",
            PixelConvention::Matlab => "matlab",
        }
    }

    /// Model pixel coordinate minus raster coordinate.
    #[must_use]
    pub fn shift(self) -> f64 {
        match self {
            PixelConvention::Colmap => 0.0,
            PixelConvention::OpenCv => -0.5,
            PixelConvention::Matlab => 0.5,
        }
    }
}

/// One model the `model` parameter names: its parameters in the source library's order, and how
/// [`CameraModel::new`] builds it from them.
#[derive(Debug, Clone, Copy)]
pub struct ModelInfo {
    /// The name (COLMAP's for ids 0–17).
    pub name: &'static str,
    /// The parameter names in order, as the source library lists them.
    pub params: &'static str,
    /// The accepted `params` counts.
    pub counts: &'static [usize],
    /// The pixel convention `pixelConvention "auto"` picks.
    pub convention: PixelConvention,
    /// True for the models that take `polynomial`/`inversePolynomial`.
    pub polynomials: bool,
    /// The model's stages from its parameters.
    build: Build,
}

/// Each name stands once in [`MODELS`], so it identifies the entry (the builder, a function
/// pointer, has no meaningful equality of its own).
impl PartialEq for ModelInfo {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

impl Eq for ModelInfo {}

/// A model's builder: its pipeline stages from its parameters, whose count, finiteness and
/// polynomials [`CameraModel::new`] has already checked against the table.
type Build = fn(&Args<'_>) -> Result<Stages, String>;

const fn info(
    name: &'static str,
    params: &'static str,
    counts: &'static [usize],
    convention: PixelConvention,
    polynomials: bool,
    build: Build,
) -> ModelInfo {
    ModelInfo {
        name,
        params,
        counts,
        convention,
        polynomials,
        build,
    }
}

use PixelConvention::{Colmap as C, OpenCv as O};

/// Every model, COLMAP's ids 0–17 first in id order.
pub const MODELS: [ModelInfo; 33] = [
    info("SIMPLE_PINHOLE", "f, cx, cy", &[3], C, false, |s| s.focal()),
    info("PINHOLE", "fx, fy, cx, cy", &[4], C, false, |s| s.focals()),
    info(
        "SIMPLE_RADIAL",
        "f, cx, cy, k",
        &[4],
        C,
        false,
        radial_perspective,
    ),
    info("RADIAL", "f, cx, cy, k1, k2", &[5], C, false, radial_perspective),
    info("OPENCV", "fx, fy, cx, cy, k1, k2, p1, p2", &[8], C, false, |s| {
        let d = Distortion::new(radial(&s.p[4..6]), [0.0; 3], [s.p[6], s.p[7]], [0.0; 4], false);
        Ok(s.focals()?.distorted(d))
    }),
    info(
        "OPENCV_FISHEYE",
        "fx, fy, cx, cy, k1, k2, k3, k4",
        &[8],
        C,
        false,
        kannala_brandt,
    ),
    info(
        "FULL_OPENCV",
        "fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6",
        &[12],
        C,
        false,
        |s| {
            let p = s.p;
            let d = Distortion::new(
                radial(&[p[4], p[5], p[8]]),
                [p[9], p[10], p[11]],
                [p[6], p[7]],
                [0.0; 4],
                false,
            );
            Ok(s.focals()?.distorted(d))
        },
    ),
    info("FOV", "fx, fy, cx, cy, omega", &[5], C, false, fov),
    info(
        "SIMPLE_RADIAL_FISHEYE",
        "f, cx, cy, k",
        &[4],
        C,
        false,
        radial_fisheye,
    ),
    info(
        "RADIAL_FISHEYE",
        "f, cx, cy, k1, k2",
        &[5],
        C,
        false,
        radial_fisheye,
    ),
    info(
        "THIN_PRISM_FISHEYE",
        "fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1",
        &[12],
        C,
        false,
        |s| {
            let p = s.p;
            let d = Distortion::new(
                radial(&[p[4], p[5], p[8], p[9]]),
                [0.0; 3],
                [p[6], p[7]],
                [p[10], 0.0, p[11], 0.0],
                false,
            );
            Ok(s.focals()?.distorted(d).lift(Lift::Equidistant))
        },
    ),
    info(
        "RAD_TAN_THIN_PRISM_FISHEYE",
        "fx, fy, cx, cy, k0, k1, k2, k3, k4, k5, p0, p1, s0, s1, s2, s3",
        &[16],
        C,
        false,
        |s| {
            let p = s.p;
            // Aria's p0 multiplies (r² + 2x²) (OpenCV's p2), its p1 (r² + 2y²) (OpenCV's p1).
            let d = Distortion::new(
                radial(&p[4..10]),
                [0.0; 3],
                [p[11], p[10]],
                [p[12], p[13], p[14], p[15]],
                true,
            );
            Ok(s.focals()?.distorted(d).lift(Lift::Equidistant))
        },
    ),
    info("SIMPLE_DIVISION", "f, cx, cy, k", &[4], C, false, |s| {
        Ok(s.focal()?.lift(Lift::Division { k: s.p[3] }))
    }),
    info("DIVISION", "fx, fy, cx, cy, k", &[5], C, false, |s| {
        Ok(s.focals()?.lift(Lift::Division { k: s.p[4] }))
    }),
    info("SIMPLE_FISHEYE", "f, cx, cy", &[3], C, false, |s| {
        Ok(s.focal()?.lift(Lift::Equidistant))
    }),
    info("FISHEYE", "fx, fy, cx, cy", &[4], C, false, |s| {
        Ok(s.focals()?.lift(Lift::Equidistant))
    }),
    info("EUCM", "fx, fy, cx, cy, alpha, beta", &[6], C, false, |s| {
        let stages = s.focals()?;
        let alpha = s.within("alpha", s.p[4], 0.0, 1.0)?;
        let beta = s.positive("beta", s.p[5])?;
        Ok(stages.lift(Lift::Unified { alpha, beta }))
    }),
    info("EQUIRECTANGULAR", "w, h", &[2], C, false, |s| {
        let (w, h) = (s.positive("w", s.p[0])?, s.positive("h", s.p[1])?);
        Ok(Stages::new(solve::I2, [0.0, 0.0]).lift(Lift::Equirect { w, h }))
    }),
    info(
        "OPENCV_PINHOLE",
        "fx, fy, cx, cy, k1, k2, p1, p2 [, k3 [, k4, k5, k6 [, s1, s2, s3, s4 [, taux, tauy]]]]",
        &[8, 9, 12, 16, 18],
        O,
        false,
        opencv_pinhole,
    ),
    info(
        "OPENCV_OMNIDIR",
        "fx, fy, cx, cy, s, xi, k1, k2, p1, p2",
        &[10],
        O,
        false,
        opencv_omnidir,
    ),
    info("UCM", "fx, fy, cx, cy, alpha", &[5], O, false, |s| {
        let stages = s.focals()?;
        let alpha = s.within("alpha", s.p[4], 0.0, 1.0)?;
        Ok(stages.lift(Lift::Unified { alpha, beta: 1.0 }))
    }),
    info(
        "DOUBLE_SPHERE",
        "fx, fy, cx, cy, xi, alpha",
        &[6],
        O,
        false,
        |s| {
            let stages = s.focals()?;
            let xi = s.within("xi", s.p[4], -1.0, 1.0)?;
            let alpha = s.within("alpha", s.p[5], 0.0, 1.0)?;
            Ok(stages.lift(Lift::DoubleSphere { xi, alpha }))
        },
    ),
    info(
        "KANNALA_BRANDT",
        "fx, fy, cx, cy, k1, k2, k3, k4",
        &[8],
        O,
        false,
        kannala_brandt,
    ),
    info("OCAMCALIB", "xc, yc, c, d, e", &[5], O, true, ocamcalib),
    info(
        "FTHETA",
        "cx, cy [, maxAngle [, c, d, e]]",
        &[2, 3, 6],
        O,
        true,
        ftheta,
    ),
    // 3DEqualizer's models (`lens3de`): the 10 built-in knobs, then the model's parameters, named
    // as 3DE names them; pixels are 3DE's corner-based unit coordinates times the plate size.
    info(
        "3DE Classic LD Model",
        "tde4_focal_length_cm, tde4_filmback_width_cm, tde4_filmback_height_cm, tde4_lens_center_offset_x_cm, tde4_lens_center_offset_y_cm, tde4_pixel_aspect, field_of_view_xa_unit, field_of_view_xb_unit, field_of_view_ya_unit, field_of_view_yb_unit, Distortion, Anamorphic Squeeze, Curvature X, Curvature Y, Quartic Distortion",
        &[15],
        C,
        false,
        |s| tde(Kind::Classic, s),
    ),
    info(
        "3DE4 Radial - Standard, Degree 4",
        "tde4_focal_length_cm, tde4_filmback_width_cm, tde4_filmback_height_cm, tde4_lens_center_offset_x_cm, tde4_lens_center_offset_y_cm, tde4_pixel_aspect, field_of_view_xa_unit, field_of_view_xb_unit, field_of_view_ya_unit, field_of_view_yb_unit, Distortion - Degree 2, U - Degree 2, V - Degree 2, Quartic Distortion - Degree 4, U - Degree 4, V - Degree 4, Phi - Cylindric Direction, B - Cylindric Bending",
        &[18],
        C,
        false,
        |s| tde(Kind::RadialStandard4, s),
    ),
    info(
        "3DE4 Anamorphic - Standard, Degree 4",
        "tde4_focal_length_cm, tde4_filmback_width_cm, tde4_filmback_height_cm, tde4_lens_center_offset_x_cm, tde4_lens_center_offset_y_cm, tde4_pixel_aspect, field_of_view_xa_unit, field_of_view_xb_unit, field_of_view_ya_unit, field_of_view_yb_unit, Cx02 - Degree 2, Cy02 - Degree 2, Cx22 - Degree 2, Cy22 - Degree 2, Cx04 - Degree 4, Cy04 - Degree 4, Cx24 - Degree 4, Cy24 - Degree 4, Cx44 - Degree 4, Cy44 - Degree 4, Lens Rotation, Squeeze-X, Squeeze-Y",
        &[23],
        C,
        false,
        |s| tde(Kind::AnamorphicStandard4, s),
    ),
    info(
        "3DE4 Anamorphic - Standard, Degree 6",
        "tde4_focal_length_cm, tde4_filmback_width_cm, tde4_filmback_height_cm, tde4_lens_center_offset_x_cm, tde4_lens_center_offset_y_cm, tde4_pixel_aspect, field_of_view_xa_unit, field_of_view_xb_unit, field_of_view_ya_unit, field_of_view_yb_unit, Cx02 - Degree 2, Cy02 - Degree 2, Cx22 - Degree 2, Cy22 - Degree 2, Cx04 - Degree 4, Cy04 - Degree 4, Cx24 - Degree 4, Cy24 - Degree 4, Cx44 - Degree 4, Cy44 - Degree 4, Cx06 - Degree 6, Cy06 - Degree 6, Cx26 - Degree 6, Cy26 - Degree 6, Cx46 - Degree 6, Cy46 - Degree 6, Cx66 - Degree 6, Cy66 - Degree 6, Lens Rotation, Squeeze-X, Squeeze-Y",
        &[31],
        C,
        false,
        |s| tde(Kind::AnamorphicStandard6, s),
    ),
    info(
        "3DE4 Anamorphic - Rescaled, Degree 4",
        "tde4_focal_length_cm, tde4_filmback_width_cm, tde4_filmback_height_cm, tde4_lens_center_offset_x_cm, tde4_lens_center_offset_y_cm, tde4_pixel_aspect, field_of_view_xa_unit, field_of_view_xb_unit, field_of_view_ya_unit, field_of_view_yb_unit, Cx02 - Degree 2, Cy02 - Degree 2, Cx22 - Degree 2, Cy22 - Degree 2, Cx04 - Degree 4, Cy04 - Degree 4, Cx24 - Degree 4, Cy24 - Degree 4, Cx44 - Degree 4, Cy44 - Degree 4, Lens Rotation, Squeeze-X, Squeeze-Y, Rescale",
        &[24],
        C,
        false,
        |s| tde(Kind::AnamorphicRescaled4, s),
    ),
    info(
        "3DE4 Anamorphic - Rescaled, Degree 6",
        "tde4_focal_length_cm, tde4_filmback_width_cm, tde4_filmback_height_cm, tde4_lens_center_offset_x_cm, tde4_lens_center_offset_y_cm, tde4_pixel_aspect, field_of_view_xa_unit, field_of_view_xb_unit, field_of_view_ya_unit, field_of_view_yb_unit, Cx02 - Degree 2, Cy02 - Degree 2, Cx22 - Degree 2, Cy22 - Degree 2, Cx04 - Degree 4, Cy04 - Degree 4, Cx24 - Degree 4, Cy24 - Degree 4, Cx44 - Degree 4, Cy44 - Degree 4, Cx06 - Degree 6, Cy06 - Degree 6, Cx26 - Degree 6, Cy26 - Degree 6, Cx46 - Degree 6, Cy46 - Degree 6, Cx66 - Degree 6, Cy66 - Degree 6, Lens Rotation, Squeeze-X, Squeeze-Y, Rescale",
        &[32],
        C,
        false,
        |s| tde(Kind::AnamorphicRescaled6, s),
    ),
    info(
        "3DE4 Anamorphic, Degree 6",
        "tde4_focal_length_cm, tde4_filmback_width_cm, tde4_filmback_height_cm, tde4_lens_center_offset_x_cm, tde4_lens_center_offset_y_cm, tde4_pixel_aspect, field_of_view_xa_unit, field_of_view_xb_unit, field_of_view_ya_unit, field_of_view_yb_unit, Cx02 - Degree 2, Cy02 - Degree 2, Cx22 - Degree 2, Cy22 - Degree 2, Cx04 - Degree 4, Cy04 - Degree 4, Cx24 - Degree 4, Cy24 - Degree 4, Cx44 - Degree 4, Cy44 - Degree 4, Cx06 - Degree 6, Cy06 - Degree 6, Cx26 - Degree 6, Cy26 - Degree 6, Cx46 - Degree 6, Cy46 - Degree 6, Cx66 - Degree 6, Cy66 - Degree 6",
        &[28],
        C,
        false,
        |s| tde(Kind::Anamorphic6, s),
    ),
    info(
        "3DE4 Radial - Fisheye, Degree 8",
        "tde4_focal_length_cm, tde4_filmback_width_cm, tde4_filmback_height_cm, tde4_lens_center_offset_x_cm, tde4_lens_center_offset_y_cm, tde4_pixel_aspect, field_of_view_xa_unit, field_of_view_xb_unit, field_of_view_ya_unit, field_of_view_yb_unit, Distortion - Degree 2, Quartic Distortion - Degree 4, Degree 6, Degree 8",
        &[14],
        C,
        false,
        |s| tde(Kind::RadialFisheye8, s),
    ),
];

/// The names of [`MODELS`], in order.
pub const MODEL_NAMES: [&str; MODELS.len()] = {
    let mut names = [""; MODELS.len()];
    let mut i = 0;
    while i < MODELS.len() {
        names[i] = MODELS[i].name;
        i += 1;
    }
    names
};

/// Looks a model up by name.
#[must_use]
pub fn model_info(name: &str) -> Option<&'static ModelInfo> {
    MODELS.iter().find(|m| m.name == name)
}

/// A model's parameters as [`CameraModel::new`] received them, for its [`Build`].
struct Args<'a> {
    /// The model's name, for messages.
    model: &'a str,
    /// `params`, in the source library's order.
    p: &'a [f64],
    polynomial: &'a [f64],
    inverse_polynomial: &'a [f64],
    /// The calibration image's size, in pixels.
    width: f64,
    height: f64,
}

/// What a [`Build`] makes: the stages of the pipeline in the module documentation.
struct Stages {
    a: Mat2,
    c: [f64; 2],
    tilt: Option<Tilt>,
    distortion: Option<Distortion>,
    lift: Lift,
}

impl Stages {
    /// The affine map alone, with a pinhole lift.
    fn new(a: Mat2, c: [f64; 2]) -> Self {
        Stages {
            a,
            c,
            tilt: None,
            distortion: None,
            lift: Lift::Perspective,
        }
    }

    fn distorted(self, distortion: Distortion) -> Self {
        Stages {
            distortion: Some(distortion),
            ..self
        }
    }

    fn lift(self, lift: Lift) -> Self {
        Stages { lift, ..self }
    }
}

impl Args<'_> {
    /// Checks a value is positive.
    fn positive(&self, name: &str, x: f64) -> Result<f64, String> {
        if x > 0.0 {
            Ok(x)
        } else {
            Err(format!("model {}: {name} must be > 0, got {x}", self.model))
        }
    }

    fn within(&self, name: &str, x: f64, lo: f64, hi: f64) -> Result<f64, String> {
        if (lo..=hi).contains(&x) {
            Ok(x)
        } else {
            Err(format!(
                "model {}: {name} must lie in [{lo}, {hi}], got {x}",
                self.model
            ))
        }
    }

    /// The stages of COLMAP's `f, cx, cy, …` models: one focal length.
    fn focal(&self) -> Result<Stages, String> {
        let f = self.positive("f", self.p[0])?;
        Ok(Stages::new(diag(f, f), [self.p[1], self.p[2]]))
    }

    /// The stages of the `fx, fy, cx, cy, …` models.
    fn focals(&self) -> Result<Stages, String> {
        let a = diag(self.positive("fx", self.p[0])?, self.positive("fy", self.p[1])?);
        Ok(Stages::new(a, [self.p[2], self.p[3]]))
    }
}

fn diag(fx: f64, fy: f64) -> Mat2 {
    [[fx, 0.0], [0.0, fy]]
}

/// The numerator coefficients of a radial distortion whose leading ones are `k`.
fn radial(k: &[f64]) -> [f64; 6] {
    let mut n = [0.0; 6];
    n[..k.len()].copy_from_slice(k);
    n
}

/// A purely radial polynomial distortion.
fn plain(k: &[f64]) -> Distortion {
    Distortion::new(radial(k), [0.0; 3], [0.0; 2], [0.0; 4], false)
}

/// SIMPLE_RADIAL and RADIAL.
fn radial_perspective(s: &Args<'_>) -> Result<Stages, String> {
    Ok(s.focal()?.distorted(plain(&s.p[3..])))
}

/// SIMPLE_RADIAL_FISHEYE and RADIAL_FISHEYE.
fn radial_fisheye(s: &Args<'_>) -> Result<Stages, String> {
    Ok(radial_perspective(s)?.lift(Lift::Equidistant))
}

/// OPENCV_FISHEYE and KANNALA_BRANDT.
fn kannala_brandt(s: &Args<'_>) -> Result<Stages, String> {
    Ok(s.focals()?.distorted(plain(&s.p[4..8])).lift(Lift::Equidistant))
}

fn fov(s: &Args<'_>) -> Result<Stages, String> {
    let omega = s.p[4];
    if !(omega > 0.0 && omega < std::f64::consts::PI) {
        return Err(format!(
            "model FOV: omega must lie in (0, π) radians, got {omega}"
        ));
    }
    let c = 2.0 * (0.5 * omega).tan();
    Ok(s.focals()?.lift(Lift::Fov { omega, c }))
}

fn opencv_pinhole(s: &Args<'_>) -> Result<Stages, String> {
    let p = s.p;
    let k = |i: usize| p.get(i).copied().unwrap_or(0.0);
    let d = Distortion::new(
        radial(&[k(4), k(5), k(8)]),
        [k(9), k(10), k(11)],
        [k(6), k(7)],
        [k(12), k(13), k(14), k(15)],
        false,
    );
    let tilt = if p.len() == 18 {
        Some(Tilt::new(p[16], p[17]).ok_or_else(|| {
            format!(
                "model {}: the sensor tilt taux {}, tauy {} is degenerate",
                s.model, p[16], p[17]
            )
        })?)
    } else {
        None
    };
    Ok(Stages {
        tilt,
        ..s.focals()?.distorted(d)
    })
}

fn opencv_omnidir(s: &Args<'_>) -> Result<Stages, String> {
    let p = s.p;
    let a = [[s.positive("fx", p[0])?, p[4]], [0.0, s.positive("fy", p[1])?]];
    let xi = p[5];
    if xi < 0.0 {
        return Err(format!("model {}: xi must be ≥ 0, got {xi}", s.model));
    }
    let d = Distortion::new(radial(&p[6..8]), [0.0; 3], [p[8], p[9]], [0.0; 4], false);
    Ok(Stages::new(a, [p[2], p[3]]).distorted(d).lift(Lift::Mei { xi }))
}

fn ocamcalib(s: &Args<'_>) -> Result<Stages, String> {
    let (model, polynomial) = (s.model, s.polynomial);
    let (xc, yc, cc, dd, ee) = (s.p[0], s.p[1], s.p[2], s.p[3], s.p[4]);
    if polynomial.is_empty() {
        return Err(format!(
            "model {model} needs polynomial (OCamCalib's pol a0 a1 … aN, ascending, without the count)"
        ));
    }
    if polynomial[0] >= 0.0 {
        return Err(format!(
            "model {model}: pol's a0 must be < 0 (OCamCalib's camera looks down its −z axis), got {}",
            polynomial[0]
        ));
    }
    // OCamCalib: row = c·x + d·y + xc, column = e·x + y + yc, with (x, y) its sensor
    // frame. With m = (y, x) (x right, y down): u = m.x + e·m.y + yc, v = d·m.x + c·m.y + xc.
    let a = [[1.0, ee], [dd, cc]];
    let rho_limit = 2.0 * s.width.hypot(s.height);
    let pol = polynomial.to_vec();
    let rho_max = fold_1d(rho_limit, |r| {
        let (pv, dp) = solve::poly(&pol, r);
        -pv + r * dp > 0.0 && pv.is_finite()
    });
    let lift = Lift::OCam {
        pol,
        invpol: s.inverse_polynomial.to_vec(),
        rho_max,
    };
    Ok(Stages::new(a, [yc, xc]).lift(lift))
}

fn ftheta(s: &Args<'_>) -> Result<Stages, String> {
    let (model, p) = (s.model, s.p);
    let max_angle = if p.len() >= 3 { p[2] } else { std::f64::consts::PI };
    if max_angle <= 0.0 {
        return Err(format!(
            "model {model}: maxAngle must be > 0 radians, got {max_angle}"
        ));
    }
    let (cc, dd, ee) = if p.len() == 6 {
        (p[3], p[4], p[5])
    } else {
        (1.0, 0.0, 0.0)
    };
    let a = [[cc, dd], [ee, 1.0]];
    let (bw, fw) = (
        (!s.polynomial.is_empty()).then(|| s.polynomial.to_vec()),
        (!s.inverse_polynomial.is_empty()).then(|| s.inverse_polynomial.to_vec()),
    );
    for (poly, what) in [
        (&bw, "polynomial (pixel distance → angle)"),
        (&fw, "inversePolynomial (angle → pixel distance)"),
    ] {
        if let Some(c) = poly
            && c[0].abs() > 1e-6
        {
            return Err(format!(
                "model {model}: {what} must be 0 at 0 (its constant term is {})",
                c[0]
            ));
        }
    }
    let theta_limit = max_angle.min(std::f64::consts::PI);
    let rho_limit = 2.0 * s.width.hypot(s.height);
    let (rho_max, theta_max) = match (&bw, &fw) {
        (Some(b), _) => {
            let r = fold_1d(rho_limit, |r| {
                let (t, dt) = solve::poly(b, r);
                dt > 0.0 && t <= theta_limit
            });
            (r, solve::poly(b, r).0.min(theta_limit))
        }
        (None, Some(f)) => {
            let t = fold_1d(theta_limit, |t| {
                let (r, dr) = solve::poly(f, t);
                dr > 0.0 && r <= rho_limit
            });
            (solve::poly(f, t).0, t)
        }
        (None, None) => {
            return Err(format!(
                "model {model} needs polynomial (backward: pixel distance → angle) or inversePolynomial (forward: angle → pixel distance)"
            ));
        }
    };
    let fw = fw.map(|c| {
        let mut f = Forward::new(c);
        if bw.is_none() {
            f.tabulate(theta_max);
        }
        f
    });
    let lift = Lift::FTheta {
        bw,
        fw,
        rho_max,
        theta_max,
    };
    Ok(Stages::new(a, [p[0], p[1]]).lift(lift))
}

/// A 3DEqualizer model on the plate the calibration's size gives: the lens is the lift of the
/// plate's raster position (model pixels are raster positions, 3DE's unit coordinates being
/// corner-based).
fn tde(kind: Kind, s: &Args<'_>) -> Result<Stages, String> {
    let lens = lens3de::Lens::new(kind, s.p, s.width, s.height)?;
    Ok(Stages::new(solve::I2, [0.0, 0.0]).lift(Lift::Lens3de(Box::new(lens))))
}

/// A calibrated camera model, ready to map pixels to rays and back, exactly.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraModel {
    info: &'static ModelInfo,
    a: Mat2,
    a_inv: Mat2,
    c: [f64; 2],
    tilt: Option<Tilt>,
    distortion: Option<Distortion>,
    lift: Lift,
}

/// A ray of a pixel with its derivative: `v` is the (not unit) ray in OpenCV camera space (y down),
/// `dv` its derivative by the model pixel `(u, v)` (columns).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelRay {
    /// The ray, any positive length.
    pub v: [f64; 3],
    /// `∂v/∂u` and `∂v/∂v` as the two columns of a 3×2 matrix, row-major.
    pub dv: [[f64; 2]; 3],
}

impl CameraModel {
    /// Builds a model from its parameters in the source library's order (see [`MODELS`]);
    /// `polynomial` and `inverse_polynomial` only for OCAMCALIB (`pol`, `invpol`) and FTHETA (the
    /// backward pixel-distance → angle and forward angle → pixel-distance polynomials), ascending.
    /// `width` and `height` are the calibration image's size, in pixels.
    ///
    /// # Errors
    /// A message naming the model and what is wrong: an unknown model, a wrong parameter count (with
    /// the expected names), a parameter out of its range, a polynomial given to a model without one.
    pub fn new(
        model: &str,
        params: &[f64],
        polynomial: &[f64],
        inverse_polynomial: &[f64],
        width: f64,
        height: f64,
    ) -> Result<Self, String> {
        let info = model_info(model).ok_or_else(|| {
            let hint = obscura_sdk::did_you_mean(model, MODEL_NAMES)
                .map(|h| format!(" (did you mean \"{h}\"?)"))
                .unwrap_or_default();
            format!(
                "unknown model \"{model}\"{hint}; known models: {}",
                MODEL_NAMES.join(", ")
            )
        })?;
        if !info.counts.contains(&params.len()) {
            let counts: Vec<String> = info.counts.iter().map(|c| c.to_string()).collect();
            return Err(format!(
                "model {model} takes {} params ({}), got {}",
                counts.join(", ").replace(", ", " or "),
                info.params,
                params.len()
            ));
        }
        if let Some(bad) = params.iter().find(|x| !x.is_finite()) {
            return Err(format!("model {model}: params must be finite, got {bad}"));
        }
        if !info.polynomials && (!polynomial.is_empty() || !inverse_polynomial.is_empty()) {
            return Err(format!(
                "model {model} takes no polynomial or inversePolynomial (only OCAMCALIB and FTHETA do)"
            ));
        }
        let args = Args {
            model,
            p: params,
            polynomial,
            inverse_polynomial,
            width,
            height,
        };
        let Stages {
            a,
            c,
            tilt,
            distortion,
            lift,
        } = (info.build)(&args)?;
        let a_inv =
            inv2(&a).ok_or_else(|| format!("model {model}: the intrinsic matrix {a:?} is singular"))?;
        if a[0][0] * a[1][1] - a[0][1] * a[1][0] < 0.0 {
            return Err(format!(
                "model {model}: the intrinsic matrix {a:?} mirrors the image"
            ));
        }
        let distortion = match distortion {
            Some(d) if !d.is_identity() => {
                let mut d = d;
                d.finish(lift.plane_limit());
                Some(d)
            }
            _ => None,
        };
        let mut model = CameraModel {
            info,
            a,
            a_inv,
            c,
            tilt,
            distortion: None,
            lift,
        };
        if let Some(mut d) = distortion {
            d.tabulate(model.image_extent(width, height));
            model.distortion = Some(d);
        }
        Ok(model)
    }

    /// The largest `|m_d|` (distorted normalised radius) over the calibration image with a pixel of
    /// margin, from its border (the map from pixels is affine, or projective with a tilt, so the
    /// largest radius is on the border).
    fn image_extent(&self, width: f64, height: f64) -> f64 {
        const STEPS: usize = 64;
        let mut extent: f64 = 0.0;
        for i in 0..=STEPS {
            let f = i as f64 / STEPS as f64;
            let (x, y) = (-1.0 + f * (width + 2.0), -1.0 + f * (height + 2.0));
            for px in [[x, -1.0], [x, height + 1.0], [-1.0, y], [width + 1.0, y]] {
                if let Some(md) = self.distorted_point(px) {
                    extent = extent.max(md[0].hypot(md[1]));
                }
            }
        }
        extent
    }

    /// The distorted normalised point `m_d` of model pixel `px` (before undistortion), with
    /// `∂m_d/∂px`.
    #[inline(always)]
    fn distorted_point_jacobian(&self, px: [f64; 2]) -> Option<([f64; 2], Mat2)> {
        let mt = apply2(&self.a_inv, [px[0] - self.c[0], px[1] - self.c[1]]);
        match &self.tilt {
            Some(t) => {
                let (md, jt) = t.inverse(mt)?;
                Some((md, mul2(&jt, &self.a_inv)))
            }
            None => Some((mt, self.a_inv)),
        }
    }

    fn distorted_point(&self, px: [f64; 2]) -> Option<[f64; 2]> {
        self.distorted_point_jacobian(px).map(|(md, _)| md)
    }

    /// The model's table entry.
    #[must_use]
    pub fn info(&self) -> &'static ModelInfo {
        self.info
    }

    /// The largest radius of the undistorted plane that is valid (the fold or the plane's end).
    #[must_use]
    pub fn max_radius(&self) -> f64 {
        let plane = self.lift.plane_limit();
        self.distortion
            .as_ref()
            .map_or(plane, |d| d.max_radius.min(plane))
    }

    /// True for the models whose rays are all pinhole rays through an image plane (`V = (x, y, 1)`).
    #[must_use]
    pub fn is_planar(&self) -> bool {
        self.lift == Lift::Perspective || matches!(self.lift, Lift::Lens3de(_))
    }

    /// The 3DEqualizer lens, for the 3DE models.
    #[must_use]
    pub fn lens3de(&self) -> Option<&lens3de::Lens> {
        match &self.lift {
            Lift::Lens3de(lens) => Some(lens),
            _ => None,
        }
    }

    /// True when some valid ray may point at or behind the camera plane (z ≤ 0).
    #[must_use]
    pub fn may_leave_front(&self) -> bool {
        self.lift.may_leave_front(self.max_radius())
    }

    /// The ray through model pixel `(u, v)` with its derivative, or `None` where the model has no
    /// ray (beyond a fold, outside a unified model's circle, past a pole, …).
    #[inline]
    #[must_use]
    pub fn pixel_to_ray(&self, px: [f64; 2]) -> Option<PixelRay> {
        self.pixel_to_ray_with(px, |m| self.lift.lift(m))
    }

    /// [`CameraModel::pixel_to_ray`] with the lift given (so a batch loop can inline it).
    #[inline(always)]
    fn pixel_to_ray_with(&self, px: [f64; 2], lift: impl Fn([f64; 2]) -> Option<Lifted>) -> Option<PixelRay> {
        let (md, mut jac) = self.distorted_point_jacobian(px)?;
        let m = match &self.distortion {
            Some(d) => {
                let (m, jd) = d.inverse(md)?;
                jac = mul2(&jd, &jac);
                m
            }
            None => md,
        };
        let (v, jl): ([f64; 3], Mat32) = lift(m)?;
        Some(PixelRay {
            v,
            dv: mul32(&jl, &jac),
        })
    }

    /// [`CameraModel::pixel_to_ray_with`] for a chunk of lanes of a model with `distortion` (and
    /// perhaps a tilt) and a branch-free `lift`, breadth first and structure-of-arrays: every lane's
    /// tilt and seed, then Newton step after Newton step over all lanes (branch-free, the distortion's
    /// shape fixed at compile time, so the loop vectorises; lanes that stopped keep their values),
    /// then every lane's lift. The same operations as the per-pixel map, so the same bits; a lane
    /// the seeded path cannot solve is flagged `redo`.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // lockstep loops over several lane arrays vectorise
    fn distortion_chunk<const RATIONAL: bool, const ARIA: bool>(
        &self,
        d: &Distortion,
        lift: impl Fn([f64; 2]) -> lift::LaneLifted,
        px: &[[f64; 2]; CHUNK],
        out: &mut [LaneRay; CHUNK],
    ) {
        let zero = [0.0; CHUNK];
        let (mut md, mut m, mut scale) = ([zero; 2], [zero; 2], zero);
        // ∂m_d/∂pixel (the tilt's and A⁻¹) and ∂m/∂m_d, row-major.
        let (mut jac, mut ji) = ([zero; 4], [zero; 4]);
        let (mut running, mut solved) = ([false; CHUNK], [false; CHUNK]);
        for i in 0..CHUNK {
            let p = px[i];
            let mt = apply2(&self.a_inv, [p[0] - self.c[0], p[1] - self.c[1]]);
            let (tilted, d_md, j) = match &self.tilt {
                Some(t) => match t.inverse(mt) {
                    Some((d_md, jt)) => (true, d_md, mul2(&jt, &self.a_inv)),
                    None => (false, mt, self.a_inv),
                },
                None => (true, mt, self.a_inv),
            };
            let (seeded, at) = d.seed_first(d_md);
            (md[0][i], md[1][i], m[0][i], m[1][i]) = (d_md[0], d_md[1], at[0], at[1]);
            (jac[0][i], jac[1][i], jac[2][i], jac[3][i]) = (j[0][0], j[0][1], j[1][0], j[1][1]);
            scale[i] = 1.0 + d_md[0].abs() + d_md[1].abs();
            running[i] = tilted & seeded;
        }
        // The seed's second table look-up, in its own pass: one long chain per lane is two short ones.
        for i in 0..CHUNK {
            let (ok, seed) = d.seed_second([md[0][i], md[1][i]], [m[0][i], m[1][i]]);
            (m[0][i], m[1][i]) = (seed[0], seed[1]);
            running[i] &= ok;
        }
        for _ in 0..SEEDED_ITERATIONS {
            let mut any = false;
            for i in 0..CHUNK {
                let (usable, converged, next, j) =
                    d.newton_lane::<RATIONAL, ARIA>([md[0][i], md[1][i]], scale[i], [m[0][i], m[1][i]]);
                let moved = running[i] & usable;
                let take = moved & converged;
                for k in 0..2 {
                    m[k][i] = if moved { next[k] } else { m[k][i] };
                }
                let j = [j[0][0], j[0][1], j[1][0], j[1][1]];
                for k in 0..4 {
                    ji[k][i] = if take { j[k] } else { ji[k][i] };
                }
                solved[i] |= take & d.inside(next);
                running[i] = moved & !converged;
                any |= running[i];
            }
            if !any {
                break;
            }
        }
        for i in 0..CHUNK {
            let (lifted, (v, jl)) = lift([m[0][i], m[1][i]]);
            let jd = [[ji[0][i], ji[1][i]], [ji[2][i], ji[3][i]]];
            let jp = [[jac[0][i], jac[1][i]], [jac[2][i], jac[3][i]]];
            out[i] = LaneRay {
                ok: solved[i] & lifted,
                redo: !solved[i],
                ray: PixelRay {
                    v,
                    dv: mul32(&jl, &mul2(&jd, &jp)),
                },
            };
        }
    }

    /// Runs `visitor` with [`CameraModel::distortion_chunk`] for `d`'s shape and `lift`.
    #[inline(always)]
    fn visit_distortion<V: RayKernel, L: Fn([f64; 2]) -> lift::LaneLifted + Copy>(
        &self,
        visitor: V,
        d: &Distortion,
        lift: L,
    ) {
        let scalar = |px| self.pixel_to_ray(px);
        match d.shape() {
            (false, false) => visitor.visit_chunks(
                #[inline(always)]
                |px, o| self.distortion_chunk::<false, false>(d, lift, px, o),
                scalar,
            ),
            (true, false) => visitor.visit_chunks(
                #[inline(always)]
                |px, o| self.distortion_chunk::<true, false>(d, lift, px, o),
                scalar,
            ),
            (false, true) => visitor.visit_chunks(
                #[inline(always)]
                |px, o| self.distortion_chunk::<false, true>(d, lift, px, o),
                scalar,
            ),
            (true, true) => visitor.visit_chunks(
                #[inline(always)]
                |px, o| self.distortion_chunk::<true, true>(d, lift, px, o),
                scalar,
            ),
        }
    }

    /// Hands `visitor` this model's pixel → ray function, specialised: one closure type per model
    /// family, so the visitor's loop over a batch is compiled once per family with the lift inlined
    /// and no per-ray dispatch. Every kernel computes exactly what [`CameraModel::pixel_to_ray`]
    /// does.
    #[inline]
    pub(crate) fn with_kernel<V: RayKernel>(&self, visitor: V) {
        if let Some(d) = &self.distortion {
            // The seeded Newton path of the exact inverse, a chunk of lanes at a time; a lane that
            // needs the safeguarded path is redone by `pixel_to_ray`.
            match &self.lift {
                Lift::Perspective => return self.visit_distortion(visitor, d, lift::perspective_lane),
                Lift::Equidistant => return self.visit_distortion(visitor, d, lift::equidistant_lane),
                &Lift::Mei { xi } => {
                    return self.visit_distortion(visitor, d, move |m| lift::mei_lane(xi, m));
                }
                _ => {}
            }
        }
        if self.tilt.is_some() || self.distortion.is_some() {
            match &self.lift {
                Lift::Perspective => visitor.visit(
                    #[inline(always)]
                    |px| self.pixel_to_ray_with(px, lift::perspective),
                ),
                Lift::Equidistant => visitor.visit(
                    #[inline(always)]
                    |px| self.pixel_to_ray_with(px, lift::equidistant),
                ),
                _ => visitor.visit(
                    #[inline(always)]
                    |px| self.pixel_to_ray_with(px, |m| self.lift.lift(m)),
                ),
            }
            return;
        }
        let (ai, c) = (self.a_inv, self.c);
        let scalar = |px| self.pixel_to_ray(px);
        match &self.lift {
            Lift::Perspective => visitor.visit_lanes(
                closed_form_lanes(ai, c, |m| no_redo(lift::perspective_lane(m))),
                scalar,
            ),
            Lift::Equidistant => visitor.visit_lanes(
                closed_form_lanes(ai, c, |m| no_redo(lift::equidistant_lane(m))),
                scalar,
            ),
            &Lift::Unified { alpha, beta } => visitor.visit_lanes(
                closed_form_lanes(ai, c, move |m| no_redo(lift::unified_lane(alpha, beta, m))),
                scalar,
            ),
            &Lift::Mei { xi } => visitor.visit_lanes(
                closed_form_lanes(ai, c, move |m| no_redo(lift::mei_lane(xi, m))),
                scalar,
            ),
            &Lift::DoubleSphere { xi, alpha } => visitor.visit_lanes(
                closed_form_lanes(ai, c, move |m| no_redo(lift::double_sphere_lane(xi, alpha, m))),
                scalar,
            ),
            &Lift::Division { k } => {
                visitor.visit_lanes(
                    closed_form_lanes(ai, c, move |m| no_redo(lift::division_lane(k, m))),
                    scalar,
                );
            }
            &Lift::Fov { omega, c: cc } => visitor.visit_lanes(
                closed_form_lanes(ai, c, move |m| no_redo(lift::fov_lane(omega, cc, m))),
                scalar,
            ),
            &Lift::Equirect { w, h } => {
                visitor.visit_lanes(
                    closed_form_lanes(ai, c, move |m| lift::equirect_lane(w, h, m)),
                    scalar,
                );
            }
            Lift::OCam { pol, rho_max, .. } => {
                let rho_max = *rho_max;
                // A fixed-length polynomial, so the loop over lanes vectorises.
                if let Some(p) = solve::padded::<6>(pol) {
                    visitor.visit_lanes(
                        closed_form_lanes(ai, c, move |m| no_redo(lift::ocam_lane(&p, rho_max, m))),
                        scalar,
                    );
                } else if let Some(p) = solve::padded::<12>(pol) {
                    visitor.visit_lanes(
                        closed_form_lanes(ai, c, move |m| no_redo(lift::ocam_lane(&p, rho_max, m))),
                        scalar,
                    );
                } else {
                    visitor.visit(closed_form(ai, c, move |m| lift::ocam(pol, rho_max, m)));
                }
            }
            &Lift::FTheta {
                bw: None,
                fw: Some(ref fw),
                rho_max,
                theta_max,
            } => visitor.visit_chunks(
                #[inline(always)]
                |px, out| forward_ftheta_chunk(fw, rho_max, theta_max, ai, c, px, out),
                scalar,
            ),
            Lift::FTheta { .. } | Lift::Lens3de(_) => visitor.visit(closed_form(
                ai,
                c,
                #[inline(always)]
                |m| self.lift.lift(m),
            )),
        }
    }

    /// The model pixel where the ray `d` (OpenCV camera space, any length) is seen, or `None` when
    /// the model does not see it.
    #[inline]
    #[must_use]
    pub fn ray_to_pixel(&self, d: [f64; 3]) -> Option<[f64; 2]> {
        let m = self.lift.unlift(d)?;
        let md = match &self.distortion {
            Some(dist) => {
                if m[0] * m[0] + m[1] * m[1] > dist.max_radius * dist.max_radius {
                    return None;
                }
                dist.forward(m).0
            }
            None => m,
        };
        let mt = match &self.tilt {
            Some(t) => t.forward(md)?.0,
            None => md,
        };
        let p = apply2(&self.a, mt);
        let px = [p[0] + self.c[0], p[1] + self.c[1]];
        (px[0].is_finite() && px[1].is_finite()).then_some(px)
    }
}

/// The pixel → ray map of a model without distortion or tilt: the intrinsic affine map, then the
/// lift.
#[inline(always)]
fn closed_form(
    a_inv: Mat2,
    c: [f64; 2],
    lift: impl Fn([f64; 2]) -> Option<Lifted>,
) -> impl Fn([f64; 2]) -> Option<PixelRay> {
    move |px| {
        let m = apply2(&a_inv, [px[0] - c[0], px[1] - c[1]]);
        let (v, jl) = lift(m)?;
        Some(PixelRay {
            v,
            dv: mul32(&jl, &a_inv),
        })
    }
}

/// [`closed_form`] of f-theta given only its forward polynomial, for a chunk of lanes breadth first:
/// every lane's pixel distance and table seed, then every lane's Newton solve (independent lanes, so
/// their latencies overlap), then every lane's ray. The same operations as [`lift::ftheta`], so the
/// same bits; a lane beyond the seed table is flagged `redo`.
#[inline(always)]
fn forward_ftheta_chunk(
    fw: &lift::Forward,
    rho_max: f64,
    theta_max: f64,
    a_inv: Mat2,
    c: [f64; 2],
    px: &[[f64; 2]; CHUNK],
    out: &mut [LaneRay; CHUNK],
) {
    let m: [[f64; 2]; CHUNK] = std::array::from_fn(|i| apply2(&a_inv, [px[i][0] - c[0], px[i][1] - c[1]]));
    let rho: [f64; CHUNK] = std::array::from_fn(|i| (m[i][0] * m[i][0] + m[i][1] * m[i][1]).sqrt());
    // Some(seed) to solve, None for a lane outside the view (rho beyond rho_max) or to redo.
    let seed: [Option<f64>; CHUNK] =
        std::array::from_fn(|i| (rho[i] <= rho_max).then(|| fw.seed(rho[i])).flatten());
    let theta: [f64; CHUNK] =
        std::array::from_fn(|i| seed[i].map_or(0.0, |s| fw.solve_from(rho[i], theta_max, s)));
    for i in 0..CHUNK {
        out[i] = match seed[i] {
            Some(_) => {
                let (v, jl) = fw.lift_at(m[i], rho[i], theta[i]);
                LaneRay {
                    ok: true,
                    redo: false,
                    ray: PixelRay {
                        v,
                        dv: mul32(&jl, &a_inv),
                    },
                }
            }
            None => LaneRay {
                redo: rho[i] <= rho_max,
                ..LaneRay::NONE
            },
        };
    }
}

/// A lane's lifted ray without a redo flag.
#[inline(always)]
fn no_redo((ok, l): lift::LaneLifted) -> (bool, bool, Lifted) {
    (ok, false, l)
}

/// [`closed_form`] per lane: `(valid, redo, ray)` computed without branches (garbage where not
/// valid); `redo` asks for the lane to be recomputed by [`CameraModel::pixel_to_ray`] (an
/// argument beyond the fast path's range).
#[inline(always)]
fn closed_form_lanes(
    a_inv: Mat2,
    c: [f64; 2],
    lift: impl Fn([f64; 2]) -> (bool, bool, Lifted),
) -> impl Fn([f64; 2]) -> LaneRay {
    #[inline(always)]
    move |px| {
        let m = apply2(&a_inv, [px[0] - c[0], px[1] - c[1]]);
        let (ok, redo, (v, jl)) = lift(m);
        LaneRay {
            ok,
            redo,
            ray: PixelRay {
                v,
                dv: mul32(&jl, &a_inv),
            },
        }
    }
}

/// One lane of a batch kernel: the ray, whether it is valid, whether it must be redone by the
/// per-pixel map.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LaneRay {
    /// The pixel has a ray (`ray` is meaningless otherwise).
    pub ok: bool,
    /// The lane's arguments are beyond the branch-free path's range: recompute it with
    /// [`CameraModel::pixel_to_ray`].
    pub redo: bool,
    /// The ray with its derivative.
    pub ray: PixelRay,
}

impl LaneRay {
    /// An invalid lane (nothing to redo).
    pub const NONE: LaneRay = LaneRay {
        ok: false,
        redo: false,
        ray: PixelRay {
            v: [0.0; 3],
            dv: [[0.0; 2]; 3],
        },
    };
}

/// Lanes per chunk of a batch: a batch kernel holds one chunk's lanes as structure-of-arrays on the
/// stack, and a whole-chunk kernel ([`RayKernel::visit_chunks`]) advances them together.
pub(crate) const CHUNK: usize = 32;

/// Something run with a model's pixel → ray function ([`CameraModel::with_kernel`]): generic
/// methods, so each model family gets its own compiled copy.
pub(crate) trait RayKernel {
    /// Runs with `kernel`, the model pixel → ray map.
    fn visit(self, kernel: impl Fn([f64; 2]) -> Option<PixelRay>);

    /// Runs with `lanes`, the map as a branch-free [`LaneRay`] (for a loop that vectorises), and
    /// `scalar`, the exact per-pixel map for the lanes it flags `redo`. Valid lanes must be
    /// exactly what `scalar` gives.
    fn visit_lanes(self, lanes: impl Fn([f64; 2]) -> LaneRay, scalar: impl Fn([f64; 2]) -> Option<PixelRay>);

    /// Runs with `chunk`, the map of [`CHUNK`] model pixels at once (for iterative maps: the lanes
    /// advance together, so their long dependency chains overlap), and `scalar` for the lanes it
    /// flags `redo`. Valid lanes must be exactly what `scalar` gives.
    fn visit_chunks(
        self,
        chunk: impl Fn(&[[f64; 2]; CHUNK], &mut [LaneRay; CHUNK]),
        scalar: impl Fn([f64; 2]) -> Option<PixelRay>,
    );
}

/// The first value in `(0, limit]` where `ok` fails (scanned in 4096 steps, then bisected), or
/// `limit` when it holds throughout.
fn fold_1d(limit: f64, ok: impl Fn(f64) -> bool) -> f64 {
    const STEPS: usize = 4096;
    let points = (1..=STEPS).map(|i| limit * i as f64 / STEPS as f64);
    solve::first_failure(points, ok).unwrap_or(limit)
}
