//! The exact description of a frame's camera model, and its exact equivalent (or the reason there is
//! none) in each format vision tools train with: COLMAP, OpenCV, nerfstudio and gsplat/3DGUT.
//!
//! This is the one equivalence table of the project: the camera JSON carries its answers
//! (`camera_model`, `equivalents`), and the exports of `obscura-dataset` only format them.
//!
//! # Conventions
//!
//! Intrinsics are in **raster pixels of the render** (x right, y down, the top-left pixel's centre at
//! (0.5, 0.5)): COLMAP's, nerfstudio's (`pixel_offset = 0.5` in `Cameras.get_image_coords`) and
//! gsplat's (`element_to_image_point` returns `(j + 0.5, i + 0.5)`) convention; OpenCV's pixel is
//! the raster position − ½, so its `cx`, `cy` are ours − ½. Camera axes are OpenCV's (x right, y down,
//! z forward): `(x, y, z)_cv = (X, −Y, Z)` of Obscura's camera space.
//!
//! With the screen window `(l, r, b, t)` and the image `W × H`, a screen point `(sx, sy)` is at
//! `u = ax·(sx − l)`, `v = ay·(t − sy)`, `ax = W/(r − l)`, `ay = H/(t − b)`.
//!
//! # The lens of each model (all exact; `m = (x/z, y/z)`, `θ = atan2(|(x, y)|, z)`)
//!
//! | source | lens | intrinsics |
//! |---|---|---|
//! | `PxrPerspective` (pinhole, no `fovEnd` zoom), `PxrRollingShutter` base perspective | pinhole | `fx = ax·d`, `fy = ay·d`, `cx = −ax·l`, `cy = ay·t`, `d = 1/tan(fov/2)` |
//! | `Fisheye` `equidistant` | Kannala–Brandt, `k = 0` | `fx = ax·2/fov`, `fy = ay·2/fov` (fov in radians), `cx = −ax·l`, `cy = ay·t` |
//! | `Fisheye` `polynomial` (square pixels) | f-theta, `θ = P(ρ)` | `P_i = −k_i·(sensorWidthMm/(r − l)/ax)^i`, centre as above |
//! | `PxrSphereCamera` | equirectangular | azimuth `φ = (u − u0)/su`, elevation `(v0 − v)/sv`: `su = ax·hw/(hsweep/2)`, `u0 = ax·(cxw − l)`, `sv = ay·hh/(vsweep/2)`, `v0 = ay·(t − cyw)` |
//! | `OmnidirectionalStereo` `center` (or IPD 0) | equirectangular | as `PxrSphereCamera` |
//! | `OmnidirectionalStereo` left/right, IPD 0.064 m, parallel eyes, `poleMergeFrom` ≥ 90° | nerfstudio's ODS eye | as `PxrSphereCamera`, origins `∓0.032·(cos φ, 0, −sin φ)` (left −, right +) |
//! | `CalibratedCamera` | its own model | `f·(W/W_cal, H/H_cal)`, `(c − shift)·(W/W_cal, H/H_cal)` (`shift` the model's pixel convention) |
//!
//! A calibrated model keeps its own name and parameters where the format has it; otherwise it is
//! rewritten as the format's model only where the two are the same function: COLMAP
//! `SIMPLE_RADIAL`/`RADIAL` = OpenCV with `k1 (k2)`; `SIMPLE_FISHEYE`/`FISHEYE` =
//! `OPENCV_FISHEYE` with `k = 0`; `SIMPLE_RADIAL_FISHEYE`/`RADIAL_FISHEYE` = `OPENCV_FISHEYE` with
//! `k1 (k2)` (both are `θd = θ·(1 + k1·θ² + k2·θ⁴)`); `KANNALA_BRANDT` = `OPENCV_FISHEYE`; `UCM`
//! = `EUCM` with `β = 1`; `OPENCV_PINHOLE` = `PINHOLE`/`OPENCV`/`FULL_OPENCV` by its coefficients.
//!
//! # Formats
//!
//! - **COLMAP** (`cameras.txt`, pycolmap ≥ 3.12/4.x): every model by its name and parameter order
//!   (`models.h`); equirectangular as `EQUIRECTANGULAR w h` (`φ = 2π(u/w − ½)`, elevation
//!   `π(½ − v/h)`), so only a full 360° × 180° window centred on the image.
//! - **OpenCV**: `cv::projectPoints` (`pinhole`, `K`, `dist` = k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4) or
//!   `cv::fisheye` (`fisheye`, `D` = k1…k4), pixel centre at (0, 0).
//! - **nerfstudio** (`transforms.json`; `nerfstudio/cameras/cameras.py`,
//!   `camera_utils.py`, `data/dataparsers/nerfstudio_dataparser.py`): `OPENCV` is a *polynomial*
//!   radial `1 + k1r² + k2r⁴ + k3r⁶ + k4r⁸` with OpenCV's tangential `p1 p2` (so OpenCV's rational
//!   `k4…k6` and thin prism have no equivalent); `OPENCV_FISHEYE` is `θd = θ(1 + k1θ² + … + k4θ⁸)`;
//!   `FISHEYE624` takes `distortion_params` = k0…k5 p0 p1 s0…s3 (Aria's order, COLMAP's
//!   `RAD_TAN_THIN_PRISM_FISHEYE`); `EQUIRECTANGULAR` maps `(u − cx)/fl_x` to azimuth `π·(u − cx)/fl_x`
//!   and `(v − cy)/fl_y` to elevation `−π·(v − cy)/fl_y`, so any latitude–longitude window is exact.
//!   `OMNIDIRECTIONALSTEREO_L/R` are the same directions from origins `σ·(0.064/2)·(cos θ, 0, sin θ)`
//!   (OpenGL axes, `θ = −π(u − cx)/fl_x`, σ = −1 left, +1 right; `vr_ipd = 0.064` is fixed in
//!   `_compute_rays_for_omnidirectional_stereo`), which is Obscura's ODS eye with that IPD, parallel
//!   eyes and no pole merging. `VR180_L/R` (a 180° equirectangular eye offset by ±0.032 m from the
//!   written pose) is not produced: a VR180 eye rendered with `PxrSphereCamera` (hsweep 180) from the
//!   eye's own position is already exact as `EQUIRECTANGULAR` with the eye's pose.
//! - **gsplat/3DGUT** (`gsplat/rendering.py` `rasterization`, `gsplat/cuda/include/Cameras.cuh`):
//!   `pinhole` with `radial_coeffs` k1…k6 (rational, numerator k1…k3, denominator k4…k6),
//!   `tangential_coeffs` p1 p2, `thin_prism_coeffs` s1…s4 (OpenCV's); `fisheye` with `radial_coeffs`
//!   k1…k4 (Kannala–Brandt, no tangential); `ftheta` with `FThetaCameraDistortionParameters`
//!   (`reference_poly`, `pixeldist_to_angle_poly` c0…c5, `angle_to_pixeldist_poly`, `max_angle`,
//!   `linear_cde`).
//!
//! Everything else (Fisheye equisolid/stereographic/orthographic, cylinders, panini, omnistereo,
//! mirror ball, cubemaps, octahedral, lens systems, plugins, 3DEqualizer's models, zooms and depth
//! of field's lens positions) has no closed form in these formats: the entry is `{"model": null,
//! "reason": …}` and the reason points to `obscura rays`, the exact per-pixel ray map.

use obscura_scene::Scene;
use obscura_sdk::ParamValue;
use serde_json::{Value, json};

/// Why a camera whose rays leave different points has no model in COLMAP, OpenCV or gsplat.
const NOT_CENTRAL: &str = "the rays leave a circle of origins (not a central camera), which COLMAP, OpenCV and gsplat cannot describe";

/// What to do instead when a format has no exact equivalent.
pub const USE_RAYS: &str = "use `obscura rays` for the exact per-pixel ray map";

/// The domain of COLMAP's models that project through `(x/z, y/z)`: a fisheye's rays past 90° (a field
/// of view over 180°) have no COLMAP pixel.
pub const FRONT_ONLY: &str = "exact for rays in front of the camera (z > 0, θ < 90°): COLMAP projects through (x/z, y/z); a field of view over 180° is beyond it";

/// The pixel and axis conventions of every intrinsic in `equivalents`.
pub const CONVENTION: &str = "raster pixels of the render: x right, y down, the top-left pixel's centre at (0.5, 0.5) (COLMAP, nerfstudio, gsplat; OpenCV's cx, cy are these − 0.5); camera axes x right, y down, z forward (OpenCV's)";

/// A camera model as one function from an OpenCV-axes camera-space direction to a raster pixel.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Lens {
    /// `m = (x/z, y/z)`, OpenCV's full distortion `m_d = m·(1 + k1r² + k2r⁴ + k3r⁶)/(1 + k4r² +
    /// k5r⁴ + k6r⁶) + tangential(p1, p2) + (s1r² + s2r⁴, s3r² + s4r⁴)`, `u = fx·m_d.x + cx`.
    Pinhole {
        f: [f64; 2],
        c: [f64; 2],
        k: [f64; 6],
        p: [f64; 2],
        s: [f64; 4],
    },
    /// Kannala–Brandt: `θd = θ·(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸)`, `u = fx·θd·x/ρ + cx`.
    KannalaBrandt { f: [f64; 2], c: [f64; 2], k: [f64; 4] },
    /// Aria's Fisheye624 = COLMAP's `RAD_TAN_THIN_PRISM_FISHEYE` (params in COLMAP's order after
    /// fx fy cx cy: k0…k5 p0 p1 s0…s3).
    Fisheye624 { f: [f64; 2], c: [f64; 2], d: [f64; 12] },
    /// f-theta: `θ = P(ρ)`, `ρ = |(u, v) − c|` in pixels, `P` ascending.
    FTheta {
        c: [f64; 2],
        bw: Vec<f64>,
        max_angle: f64,
    },
    /// Latitude–longitude: azimuth `(u − u0)/su` (toward +x), elevation `(v0 − v)/sv` (toward −y).
    Equirect { s: [f64; 2], c: [f64; 2] },
    /// One eye of an omnidirectional-stereo panorama with nerfstudio's geometry: the latitude–longitude
    /// directions of [`Lens::Equirect`] from origins on the viewing circle, `σ·(IPD/2)·right(φ)`
    /// (σ = −1 left, +1 right), parallel eyes, no pole merging.
    Ods { s: [f64; 2], c: [f64; 2], right: bool },
    /// A COLMAP model with no counterpart among the above (FOV, DIVISION, EUCM, THIN_PRISM_FISHEYE),
    /// its parameters at the render's size.
    Colmap { model: String, params: Vec<f64> },
}

/// The lens of `scene`'s camera, or why it has no closed form.
pub(crate) fn lens(scene: &Scene, field_of_view: Option<f32>) -> Result<Lens, String> {
    let cam = &scene.camera;
    let (w, h) = (cam.format.width as f64, cam.format.height as f64);
    let win = cam.screen_window();
    let (l, r, b, t) = (
        win.left as f64,
        win.right as f64,
        win.bottom as f64,
        win.top as f64,
    );
    let (ax, ay) = (w / (r - l), h / (t - b));
    let centre = [-ax * l, ay * t];
    let p = Reader(scene);
    let name = scene.projection.as_str();
    match name {
        "PxrPerspective" | "PxrRollingShutter" => {
            if name == "PxrRollingShutter"
                && p.string("base").as_deref().unwrap_or("perspective") != "perspective"
            {
                return Err("an orthographic camera is not a central projection".into());
            }
            let fov_end = p.float("fovEnd").unwrap_or(0.0);
            let fov = field_of_view
                .map(f64::from)
                .ok_or("the projection reports no field of view")?;
            if fov_end != 0.0 && (fov_end - p.float("fov").unwrap_or(90.0)).abs() > 0.0 {
                return Err(format!(
                    "the field of view zooms from {fov}° to {fov_end}° during the shutter (fovEnd): one frame has no single focal length"
                ));
            }
            let d = 1.0 / (fov.to_radians() / 2.0).tan();
            Ok(Lens::Pinhole {
                f: [ax * d, ay * d],
                c: centre,
                k: [0.0; 6],
                p: [0.0; 2],
                s: [0.0; 4],
            })
        }
        "Fisheye" => {
            let mapping = p.string("mapping").unwrap_or_else(|| "equidistant".into());
            let fov = p.float("fov").unwrap_or(180.0).to_radians();
            match mapping.as_str() {
                "equidistant" => Ok(Lens::KannalaBrandt {
                    f: [ax * 2.0 / fov, ay * 2.0 / fov],
                    c: centre,
                    k: [0.0; 4],
                }),
                "polynomial" => {
                    if (ax - ay).abs() > 1e-9 * ax {
                        return Err(
                            "a polynomial fisheye on non-square raster pixels is not radial in pixels".into(),
                        );
                    }
                    let k = p
                        .floats("polynomial")
                        .unwrap_or_else(|| vec![0.0, -1.0 / 10.5, 0.0, 0.0, 0.0]);
                    let mm_per_px = p.float("sensorWidthMm").unwrap_or(36.0) / (r - l) / ax;
                    let bw = (k.iter().enumerate())
                        .map(|(i, k)| -k * mm_per_px.powi(i as i32))
                        .collect();
                    Ok(Lens::FTheta {
                        c: centre,
                        bw,
                        max_angle: (fov / 2.0).min(std::f64::consts::PI),
                    })
                }
                other => Err(format!(
                    "the {other} fisheye mapping is not a polynomial in the ray angle"
                )),
            }
        }
        "OmnidirectionalStereo" => {
            let eye = p.string("eye").unwrap_or_else(|| "left".into());
            let ipd = p.float("interpupilaryDistance").unwrap_or(0.0635);
            let convergence = p.float("convergenceDistance").unwrap_or(f64::INFINITY);
            let merge_from = p.float("poleMergeFrom").unwrap_or(60.0);
            let (s, c) = lat_long(&p, [ax, ay], [l, r, b, t]);
            if eye == "center" || ipd == 0.0 {
                return Ok(Lens::Equirect { s, c });
            }
            // nerfstudio's OMNIDIRECTIONALSTEREO_L/R (cameras.py): vr_ipd = 0.064, parallel eyes,
            // no pole merging.
            if (ipd - 0.064).abs() > 1e-7
                || (convergence.is_finite() && convergence != 0.0)
                || merge_from < 90.0
            {
                return Err(format!(
                    "an omnidirectional-stereo eye is not a central camera, and nerfstudio's OMNIDIRECTIONALSTEREO fixes IPD 0.064 m, parallel eyes and no pole merging (this one: interpupilaryDistance {ipd}, convergenceDistance {convergence}, poleMergeFrom {merge_from}°)"
                ));
            }
            Ok(Lens::Ods {
                s,
                c,
                right: eye == "right",
            })
        }
        "PxrSphereCamera" => {
            let (s, c) = lat_long(&p, [ax, ay], [l, r, b, t]);
            Ok(Lens::Equirect { s, c })
        }
        "CalibratedCamera" => calibrated(&p, w, h),
        _ => Err(format!("{name} has no closed-form camera model in these formats")),
    }
}

/// The scales and centre of the latitude–longitude lens ([`Lens::Equirect`]) of a panorama's `hsweep`, `vsweep` over the window `[l, r, b, t]`.
fn lat_long(p: &Reader<'_>, [ax, ay]: [f64; 2], [l, r, b, t]: [f64; 4]) -> ([f64; 2], [f64; 2]) {
    let hsweep = p.float("hsweep").unwrap_or(360.0).to_radians();
    let vsweep = p.float("vsweep").unwrap_or(180.0).to_radians();
    let (cxw, cyw, hw, hh) = ((l + r) / 2.0, (b + t) / 2.0, (r - l) / 2.0, (t - b) / 2.0);
    (
        [ax * hw / (hsweep / 2.0), ay * hh / (vsweep / 2.0)],
        [ax * (cxw - l), ay * (t - cyw)],
    )
}

/// Reads the scene's projection parameters (defaults are the caller's).
struct Reader<'a>(&'a Scene);

impl Reader<'_> {
    fn value(&self, name: &str) -> Option<&ParamValue> {
        Some(&self.0.projection_params.get(name)?.value)
    }

    fn string(&self, name: &str) -> Option<String> {
        match self.value(name)? {
            ParamValue::Strings(v) => v.first().cloned(),
            _ => None,
        }
    }

    fn floats(&self, name: &str) -> Option<Vec<f64>> {
        match self.value(name)? {
            ParamValue::Floats(v) => Some(v.iter().map(|&x| f64::from(x)).collect()),
            ParamValue::Ints(v) => Some(v.iter().map(|&x| f64::from(x)).collect()),
            ParamValue::Strings(_) => None,
        }
    }

    fn float(&self, name: &str) -> Option<f64> {
        self.floats(name)?.first().copied()
    }
}

/// A calibrated camera's lens at the render's size `w × h`.
fn calibrated(p: &Reader<'_>, w: f64, h: f64) -> Result<Lens, String> {
    let model = p.string("model").unwrap_or_else(|| "PINHOLE".into());
    let q = p
        .floats("params")
        .unwrap_or_else(|| vec![320.0, 320.0, 320.0, 240.0]);
    let res = p.floats("resolution").unwrap_or_else(|| vec![640.0, 480.0]);
    let info = obscura_calibration::models::model_info(&model)
        .ok_or_else(|| format!("unknown calibration model {model}"))?;
    if !info.counts.contains(&q.len()) || res.len() != 2 {
        return Err(format!("model {model}: {} parameters", q.len()));
    }
    let convention = match p.string("pixelConvention").as_deref().unwrap_or("auto") {
        "colmap" => obscura_calibration::models::PixelConvention::Colmap,
        "opencv" => obscura_calibration::models::PixelConvention::OpenCv,
        "matlab" => obscura_calibration::models::PixelConvention::Matlab,
        _ => info.convention,
    };
    // raster = model pixel − shift; then the render's size.
    let shift = convention.shift();
    let (sx, sy) = (w / res[0], h / res[1]);
    let single = info.params.starts_with("f,");
    let f = if single {
        [q[0] * sx, q[0] * sy]
    } else {
        [q[0] * sx, q[1] * sy]
    };
    let ci = if single { 1 } else { 2 };
    let at = |i: usize| q.get(i).copied().unwrap_or(0.0);
    let c = || [(at(ci) - shift) * sx, (at(ci + 1) - shift) * sy];
    let rest = |from: usize| q[from..].to_vec();
    let pinhole = |k: [f64; 6], p: [f64; 2], s: [f64; 4]| Lens::Pinhole { f, c: c(), k, p, s };
    let kb = |k: [f64; 4]| Lens::KannalaBrandt { f, c: c(), k };
    Ok(match model.as_str() {
        "SIMPLE_PINHOLE" | "PINHOLE" => pinhole([0.0; 6], [0.0; 2], [0.0; 4]),
        "SIMPLE_RADIAL" => pinhole([q[3], 0.0, 0.0, 0.0, 0.0, 0.0], [0.0; 2], [0.0; 4]),
        "RADIAL" => pinhole([q[3], q[4], 0.0, 0.0, 0.0, 0.0], [0.0; 2], [0.0; 4]),
        "OPENCV" => pinhole([q[4], q[5], 0.0, 0.0, 0.0, 0.0], [q[6], q[7]], [0.0; 4]),
        "FULL_OPENCV" => pinhole([q[4], q[5], q[8], q[9], q[10], q[11]], [q[6], q[7]], [0.0; 4]),
        "OPENCV_PINHOLE" if q.len() <= 16 => pinhole(
            [at(4), at(5), at(8), at(9), at(10), at(11)],
            [at(6), at(7)],
            [at(12), at(13), at(14), at(15)],
        ),
        "OPENCV_PINHOLE" => {
            return Err("OpenCV's tilted-sensor model (taux, tauy) is in no training format".into());
        }
        "OPENCV_FISHEYE" | "KANNALA_BRANDT" => kb([q[4], q[5], q[6], q[7]]),
        "SIMPLE_FISHEYE" | "FISHEYE" => kb([0.0; 4]),
        "SIMPLE_RADIAL_FISHEYE" => kb([q[3], 0.0, 0.0, 0.0]),
        "RADIAL_FISHEYE" => kb([q[3], q[4], 0.0, 0.0]),
        "RAD_TAN_THIN_PRISM_FISHEYE" => {
            let mut d = [0.0; 12];
            d.copy_from_slice(&q[4..16]);
            Lens::Fisheye624 { f, c: c(), d }
        }
        "EQUIRECTANGULAR" => {
            // COLMAP: azimuth 2π(u/w − ½), elevation π(½ − v/h) on model pixels.
            let (ew, eh) = (q[0] * sx, q[1] * sy);
            Lens::Equirect {
                s: [ew / std::f64::consts::TAU, eh / std::f64::consts::PI],
                c: [(q[0] / 2.0 - shift) * sx, (q[1] / 2.0 - shift) * sy],
            }
        }
        "FOV" | "DIVISION" | "EUCM" | "THIN_PRISM_FISHEYE" => {
            let mut params = vec![f[0], f[1], c()[0], c()[1]];
            params.extend(rest(4));
            Lens::Colmap { model, params }
        }
        "SIMPLE_DIVISION" => Lens::Colmap {
            model: "DIVISION".into(),
            params: vec![f[0], f[1], c()[0], c()[1], q[3]],
        },
        "UCM" => Lens::Colmap {
            model: "EUCM".into(),
            params: vec![f[0], f[1], c()[0], c()[1], q[4], 1.0],
        },
        "FTHETA" => {
            let bw = p.floats("polynomial").unwrap_or_default();
            let linear = q.len() == 6 && (q[3] != 1.0 || q[4] != 0.0 || q[5] != 0.0);
            if bw.is_empty() || linear || (sx - sy).abs() > 1e-12 * sx {
                return Err("this f-theta calibration (forward polynomial only, a linear term, or a non-uniform resize) has no exact equivalent".into());
            }
            let bw = (bw.iter().enumerate())
                .map(|(i, k)| k / sx.powi(i as i32))
                .collect();
            Lens::FTheta {
                c: [(q[0] - shift) * sx, (q[1] - shift) * sy],
                bw,
                max_angle: q.get(2).copied().unwrap_or(std::f64::consts::PI),
            }
        }
        other => {
            return Err(format!(
                "the calibration model {other} is in none of these formats"
            ));
        }
    })
}

/// `{"model": null, "reason": …}`.
fn none(reason: &str) -> Value {
    json!({"model": null, "reason": format!("{reason}; {USE_RAYS}")})
}

fn all_zero(v: &[f64]) -> bool {
    v.iter().all(|&x| x == 0.0)
}

/// The COLMAP camera (`model`, `params`, `width`, `height`) of `lens`, or `None` with the reason.
pub(crate) fn colmap(lens: &Result<Lens, String>, width: u32, height: u32) -> Value {
    let lens = match lens {
        Ok(l) => l,
        Err(e) => return none(e),
    };
    let (model, params): (&str, Vec<f64>) = match lens {
        Lens::Pinhole { f, c, k, p, s } => {
            if !all_zero(s) {
                return none("COLMAP has no perspective model with thin-prism distortion");
            }
            let base = vec![f[0], f[1], c[0], c[1]];
            if all_zero(k) && all_zero(p) {
                ("PINHOLE", base)
            } else if all_zero(&k[2..]) {
                ("OPENCV", [base, vec![k[0], k[1], p[0], p[1]]].concat())
            } else {
                let d = vec![k[0], k[1], p[0], p[1], k[2], k[3], k[4], k[5]];
                ("FULL_OPENCV", [base, d].concat())
            }
        }
        Lens::KannalaBrandt { f, c, k } => (
            "OPENCV_FISHEYE",
            [f[0], f[1], c[0], c[1], k[0], k[1], k[2], k[3]].to_vec(),
        ),
        Lens::Fisheye624 { f, c, d } => (
            "RAD_TAN_THIN_PRISM_FISHEYE",
            [&[f[0], f[1], c[0], c[1]][..], d].concat(),
        ),
        Lens::FTheta { .. } => return none("COLMAP has no f-theta (polynomial angle) model"),
        Lens::Equirect { s, c } => {
            let (ew, eh) = (s[0] * std::f64::consts::TAU, s[1] * std::f64::consts::PI);
            let tol = 1e-9 * ew.max(eh);
            if (c[0] - ew / 2.0).abs() > tol || (c[1] - eh / 2.0).abs() > tol {
                return none(
                    "COLMAP's EQUIRECTANGULAR puts azimuth 0 and the horizon at the image centre; this window is off-centre",
                );
            }
            ("EQUIRECTANGULAR", vec![ew, eh])
        }
        Lens::Ods { .. } => return none(NOT_CENTRAL),
        Lens::Colmap { model, params } => (model.as_str(), params.clone()),
    };
    let mut j = json!({"model": model, "width": width, "height": height, "params": params});
    if matches!(lens, Lens::KannalaBrandt { .. } | Lens::Fisheye624 { .. })
        || ["FOV", "DIVISION", "THIN_PRISM_FISHEYE"].contains(&model)
    {
        j["domain"] = json!(FRONT_ONLY);
    }
    j
}

/// The OpenCV camera (`model` pinhole/fisheye, `K`, `dist`), pixel centre at (0, 0).
pub(crate) fn opencv(lens: &Result<Lens, String>) -> Value {
    let k_matrix = |f: &[f64; 2], c: &[f64; 2]| {
        json!([[f[0], 0.0, c[0] - 0.5], [0.0, f[1], c[1] - 0.5], [0.0, 0.0, 1.0]])
    };
    match lens {
        Err(e) => none(e),
        Ok(Lens::Pinhole { f, c, k, p, s }) => {
            let mut d = vec![
                k[0], k[1], p[0], p[1], k[2], k[3], k[4], k[5], s[0], s[1], s[2], s[3],
            ];
            let keep = [4, 5, 8, 12]
                .into_iter()
                .find(|&n| all_zero(&d[n..]))
                .unwrap_or(12);
            d.truncate(keep);
            json!({"model": "pinhole", "K": k_matrix(f, c), "dist": d})
        }
        Ok(Lens::KannalaBrandt { f, c, k }) => json!({"model": "fisheye", "K": k_matrix(f, c), "dist": k}),
        Ok(Lens::Fisheye624 { .. }) => {
            none("OpenCV has no fisheye model with tangential and thin-prism terms")
        }
        Ok(Lens::FTheta { .. }) => none("OpenCV has no f-theta model"),
        Ok(Lens::Equirect { .. }) => none("OpenCV has no equirectangular model"),
        Ok(Lens::Ods { .. }) => none(NOT_CENTRAL),
        Ok(Lens::Colmap { model, .. }) => none(&format!("OpenCV has no {model} model")),
    }
}

/// The nerfstudio intrinsics (`camera_model`, `fl_x`, `fl_y`, `cx`, `cy`, distortion keys).
pub(crate) fn nerfstudio(lens: &Result<Lens, String>, width: u32, height: u32) -> Value {
    let lens = match lens {
        Ok(l) => l,
        Err(e) => return json!({"camera_model": null, "reason": format!("{e}; {USE_RAYS}")}),
    };
    let base = |model: &str, f: &[f64; 2], c: &[f64; 2]| json!({"camera_model": model, "fl_x": f[0], "fl_y": f[1], "cx": c[0], "cy": c[1], "w": width, "h": height});
    let no = |reason: &str| json!({"camera_model": null, "reason": format!("{reason}; {USE_RAYS}")});
    match lens {
        Lens::Pinhole { f, c, k, p, s } => {
            if !all_zero(&k[3..]) || !all_zero(s) {
                return no(
                    "nerfstudio's OPENCV radial distortion is a polynomial (1 + k1r² + … + k4r⁸) without OpenCV's rational denominator (k4…k6) or thin prism",
                );
            }
            let mut j = base("OPENCV", f, c);
            for (name, v) in [
                ("k1", k[0]),
                ("k2", k[1]),
                ("k3", k[2]),
                ("k4", 0.0),
                ("p1", p[0]),
                ("p2", p[1]),
            ] {
                j[name] = json!(v);
            }
            j
        }
        Lens::KannalaBrandt { f, c, k } => {
            let mut j = base("OPENCV_FISHEYE", f, c);
            for (i, v) in k.iter().enumerate() {
                j[format!("k{}", i + 1)] = json!(v);
            }
            j
        }
        Lens::Fisheye624 { f, c, d } => {
            let mut j = base("FISHEYE624", f, c);
            j["distortion_params"] = json!(d);
            j
        }
        Lens::Equirect { s, c } => {
            let pi = std::f64::consts::PI;
            base("EQUIRECTANGULAR", &[pi * s[0], pi * s[1]], c)
        }
        Lens::Ods { s, c, right } => {
            let pi = std::f64::consts::PI;
            let model = if *right {
                "OMNIDIRECTIONALSTEREO_R"
            } else {
                "OMNIDIRECTIONALSTEREO_L"
            };
            base(model, &[pi * s[0], pi * s[1]], c)
        }
        Lens::FTheta { c, bw, .. } => {
            // θ = bw(ρ) is nerfstudio's OPENCV_FISHEYE only when it is linear (equidistant).
            if bw.len() >= 2 && bw[0] == 0.0 && all_zero(&bw[2..]) && bw[1] > 0.0 {
                let f = 1.0 / bw[1];
                let mut j = base("OPENCV_FISHEYE", &[f, f], c);
                for i in 1..=4 {
                    j[format!("k{i}")] = json!(0.0);
                }
                j
            } else {
                no("nerfstudio has no f-theta (polynomial angle) model")
            }
        }
        Lens::Colmap { model, .. } => no(&format!("nerfstudio has no {model} camera")),
    }
}

/// The gsplat/3DGUT camera arguments of `lens` (`camera_model`, `K`, coefficients).
pub(crate) fn gsplat(lens: &Result<Lens, String>, width: u32, height: u32) -> Value {
    let lens = match lens {
        Ok(l) => l,
        Err(e) => return none(e),
    };
    let k_matrix =
        |f: &[f64; 2], c: &[f64; 2]| json!([[f[0], 0.0, c[0]], [0.0, f[1], c[1]], [0.0, 0.0, 1.0]]);
    let size = json!([width, height]);
    match lens {
        Lens::Pinhole { f, c, k, p, s } => json!({
            "model": "pinhole", "camera_model": "pinhole", "width": width, "height": height, "K": k_matrix(f, c),
            "radial_coeffs": k, "tangential_coeffs": p, "thin_prism_coeffs": s,
        }),
        Lens::KannalaBrandt { f, c, k } => json!({
            "model": "fisheye", "camera_model": "fisheye", "width": width, "height": height, "K": k_matrix(f, c),
            "radial_coeffs": k,
        }),
        Lens::Fisheye624 { f, c, d } if all_zero(&d[4..]) => json!({
            "model": "fisheye", "camera_model": "fisheye", "width": width, "height": height, "K": k_matrix(f, c),
            "radial_coeffs": [d[0], d[1], d[2], d[3]],
        }),
        Lens::Fisheye624 { .. } => {
            none("gsplat's fisheye has four radial coefficients and no tangential or thin-prism terms")
        }
        Lens::FTheta { c, bw, max_angle } => {
            if bw.len() > 6 {
                return none("gsplat's f-theta polynomials have six coefficients");
            }
            let mut poly = [0.0; 6];
            poly[..bw.len()].copy_from_slice(bw);
            // gsplat inverts the reference by Newton's method seeded with the other polynomial: the
            // seed is the inverse of the reference's linear term.
            let mut seed = [0.0; 6];
            if poly[1] != 0.0 {
                seed[1] = 1.0 / poly[1];
            }
            json!({
                "model": "ftheta", "camera_model": "ftheta", "width": width, "height": height,
                "K": [[1.0, 0.0, c[0]], [0.0, 1.0, c[1]], [0.0, 0.0, 1.0]],
                "ftheta_coeffs": {
                    "reference_poly": "PIXELDIST_TO_ANGLE",
                    "pixeldist_to_angle_poly": poly,
                    "angle_to_pixeldist_poly": seed,
                    "angle_to_pixeldist_poly_is": "the Newton seed only (the reference is pixeldist_to_angle_poly)",
                    "max_angle": max_angle,
                    "linear_cde": [1.0, 0.0, 0.0],
                },
                "resolution": size,
            })
        }
        Lens::Equirect { .. } => none("gsplat has no equirectangular camera"),
        Lens::Ods { .. } => none(NOT_CENTRAL),
        Lens::Colmap { model, .. } => none(&format!("gsplat has no {model} camera")),
    }
}

/// The `camera_model` section: the lens as one closed form in raster pixels, or why there is none.
fn describe(lens: &Result<Lens, String>) -> Value {
    match lens {
        Err(e) => json!({"lens": null, "reason": format!("{e}; {USE_RAYS}")}),
        Ok(Lens::Pinhole { f, c, k, p, s }) => json!({
            "lens": "pinhole", "fx": f[0], "fy": f[1], "cx": c[0], "cy": c[1],
            "k": k, "p": p, "s": s,
            "formula": "m = (x/z, y/z); m_d = m(1 + k1 r² + k2 r⁴ + k3 r⁶)/(1 + k4 r² + k5 r⁴ + k6 r⁶) + (2p1 mx my + p2(r² + 2mx²) + s1 r² + s2 r⁴, p1(r² + 2my²) + 2p2 mx my + s3 r² + s4 r⁴); u = fx m_d.x + cx, v = fy m_d.y + cy",
        }),
        Ok(Lens::KannalaBrandt { f, c, k }) => json!({
            "lens": "kannala_brandt", "fx": f[0], "fy": f[1], "cx": c[0], "cy": c[1], "k": k,
            "formula": "θ = atan2(√(x² + y²), z); θd = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸); u = fx θd x/√(x² + y²) + cx, v = fy θd y/√(x² + y²) + cy",
        }),
        Ok(Lens::Fisheye624 { f, c, d }) => json!({
            "lens": "fisheye624", "fx": f[0], "fy": f[1], "cx": c[0], "cy": c[1], "params": d,
            "formula": "COLMAP's RAD_TAN_THIN_PRISM_FISHEYE (Aria's Fisheye624): k0…k5 p0 p1 s0…s3",
        }),
        Ok(Lens::FTheta { c, bw, max_angle }) => json!({
            "lens": "ftheta", "cx": c[0], "cy": c[1], "pixeldist_to_angle": bw, "max_angle": max_angle,
            "formula": "ρ = |(u − cx, v − cy)|; θ = Σ P_i ρ^i; the pixel lies along the ray's azimuth",
        }),
        Ok(Lens::Equirect { s, c }) => json!({
            "lens": "equirectangular", "su": s[0], "sv": s[1], "u0": c[0], "v0": c[1],
            "formula": "azimuth φ = atan2(x, z) = (u − u0)/su, elevation = atan2(−y, √(x² + z²)) = (v0 − v)/sv",
        }),
        Ok(Lens::Ods { s, c, right }) => json!({
            "lens": "omnidirectional_stereo", "su": s[0], "sv": s[1], "u0": c[0], "v0": c[1],
            "eye": if *right { "right" } else { "left" }, "interpupillary_distance": 0.064,
            "formula": "as equirectangular, from the origin ±(IPD/2)·(cos φ, 0, −sin φ) in OpenCV axes (+ right eye, − left)",
        }),
        Ok(Lens::Colmap { model, params }) => json!({
            "lens": "colmap", "model": model, "params": params,
            "formula": "COLMAP's camera model of that name (models.h)",
        }),
    }
}

/// The `camera_model` and `equivalents` sections of the camera JSON.
pub(crate) fn sections(scene: &Scene, field_of_view: Option<f32>) -> (Value, Value) {
    let lens = lens(scene, field_of_view);
    let (w, h) = (scene.camera.format.width, scene.camera.format.height);
    let mut model = describe(&lens);
    model["projection"] = json!(scene.projection);
    model["width"] = json!(w);
    model["height"] = json!(h);
    model["convention"] = json!(CONVENTION);
    let equivalents = json!({
        "convention": CONVENTION,
        "colmap": colmap(&lens, w, h),
        "opencv": opencv(&lens),
        "nerfstudio": nerfstudio(&lens, w, h),
        "gsplat": gsplat(&lens, w, h),
    });
    (model, equivalents)
}
