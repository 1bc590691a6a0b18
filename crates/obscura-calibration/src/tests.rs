//! Tests of every model: closed forms written out from each library's own formula, published example
//! values, round trips (f64 on the model, f32 through the projection), folds, pixel conventions, the
//! y flip, resolution independence, footprints and bad parameters.

use obscura_sdk::{
    DeepMetric, DicingHint, Format, ParamList, Point2, Projection, ProjectionContext, ProjectionEnvironment,
    ProjectionFactory, ProjectionProperty, PropertyValue, RayGeometry, Rgb, ScreenWindow, Vec3,
};
use proptest::prelude::*;

use crate::models::{CameraModel, MODELS, PixelConvention};
use crate::projection::CalibratedCameraFactory;

/// One test camera: model, params, polynomials, calibration size.
struct Case {
    model: &'static str,
    params: Vec<f64>,
    pol: Vec<f64>,
    invpol: Vec<f64>,
    size: [i32; 2],
}

fn case(model: &'static str, params: &[f64]) -> Case {
    Case {
        model,
        params: params.to_vec(),
        pol: vec![],
        invpol: vec![],
        size: [640, 480],
    }
}

/// OCamCalib's published example `calib_results.txt` (752×480 camera; pol, invpol, centre, affine).
fn ocam_example() -> Case {
    Case {
        model: "OCAMCALIB",
        params: vec![241.800066, 394.552874, 1.000330, 0.000219, 0.000257],
        pol: vec![-2.065170e+02, 0.0, 2.207161e-03, -4.879622e-06, 1.865656e-08],
        invpol: vec![
            294.182260, 152.289570, -12.191217, 27.959546, 8.241525, -1.970397, 10.689256, 1.871609,
            -6.437684, 0.430037, 3.215544, 0.921484,
        ],
        size: [752, 480],
    }
}

fn cases() -> Vec<Case> {
    let opencv8 = [500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005];
    let full = [
        500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005, -0.002, 0.01, 0.003, 0.0002,
    ];
    let kb = [300.0, 300.0, 320.0, 240.0, -0.01, 0.02, -0.003, 0.0005];
    let mut v = vec![
        case("SIMPLE_PINHOLE", &[500.0, 320.0, 240.0]),
        case("PINHOLE", &[500.0, 480.0, 321.5, 238.2]),
        case("SIMPLE_RADIAL", &[500.0, 320.0, 240.0, -0.12]),
        case("RADIAL", &[500.0, 320.0, 240.0, -0.2, 0.05]),
        case("OPENCV", &opencv8),
        case("OPENCV_FISHEYE", &kb),
        case("FULL_OPENCV", &full),
        case("FOV", &[300.0, 300.0, 320.0, 240.0, 0.9]),
        case("SIMPLE_RADIAL_FISHEYE", &[250.0, 320.0, 240.0, 0.02]),
        case("RADIAL_FISHEYE", &[250.0, 320.0, 240.0, 0.02, -0.004]),
        case(
            "THIN_PRISM_FISHEYE",
            &[
                250.0, 252.0, 320.0, 240.0, 0.02, -0.004, 0.001, -0.0008, 0.0005, -0.0001, 0.0007, -0.0004,
            ],
        ),
        case(
            "RAD_TAN_THIN_PRISM_FISHEYE",
            &[
                240.0, 241.0, 320.0, 240.0, 0.02, -0.004, 0.0005, -0.0001, 0.00002, -0.000003, 0.0008,
                -0.0006, 0.0004, -0.0001, 0.0003, 0.00005,
            ],
        ),
        case("SIMPLE_DIVISION", &[400.0, 320.0, 240.0, -0.15]),
        case("DIVISION", &[400.0, 405.0, 320.0, 240.0, 0.1]),
        case("SIMPLE_FISHEYE", &[200.0, 320.0, 240.0]),
        case("FISHEYE", &[200.0, 210.0, 320.0, 240.0]),
        case("EUCM", &[350.0, 350.0, 320.0, 240.0, 0.6, 1.1]),
        Case {
            size: [640, 320],
            ..case("EQUIRECTANGULAR", &[640.0, 320.0])
        },
        case("OPENCV_PINHOLE", &opencv8[..8]),
        case(
            "OPENCV_PINHOLE",
            &[500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005, -0.002],
        ),
        case("OPENCV_PINHOLE", &full),
        case(
            "OPENCV_PINHOLE",
            &[
                500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005, -0.002, 0.01, 0.003, 0.0002, 0.001,
                -0.0002, 0.0008, 0.0001,
            ],
        ),
        case(
            "OPENCV_PINHOLE",
            &[
                500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005, -0.002, 0.01, 0.003, 0.0002, 0.001,
                -0.0002, 0.0008, 0.0001, 0.01, -0.008,
            ],
        ),
        case(
            "OPENCV_OMNIDIR",
            &[400.0, 400.0, 320.0, 240.0, 0.5, 1.2, -0.1, 0.02, 0.001, -0.0005],
        ),
        case("UCM", &[300.0, 300.0, 320.0, 240.0, 0.58]),
        case("DOUBLE_SPHERE", &[250.0, 250.0, 320.0, 240.0, -0.2, 0.59]),
        case("KANNALA_BRANDT", &kb),
        ocam_example(),
        Case {
            pol: vec![0.0, 0.004, 1e-7, -2e-10],
            ..case("FTHETA", &[319.5, 239.5])
        },
        Case {
            pol: vec![0.0, 0.004, 1e-7, -2e-10],
            invpol: vec![0.0, 250.0, -5.0, 1.0],
            ..case("FTHETA", &[319.5, 239.5, 1.7, 1.001, 0.0005, -0.0003])
        },
        Case {
            invpol: vec![0.0, 250.0, -5.0, 1.0],
            ..case("FTHETA", &[319.5, 239.5, 1.7])
        },
    ];
    v.extend(lens3de_cases());
    // Every model of the table has at least one case.
    for m in MODELS {
        assert!(v.iter().any(|c| c.model == m.name), "no test case for {}", m.name);
    }
    v.shrink_to_fit();
    v
}

/// One case per 3DEqualizer model: a 640×480 plate (a 2× squeezed 640×545 one for the anamorphic
/// models), film back, lens-centre offset and moderate distortion; the formulas themselves are
/// checked in `lens3de`'s tests.
fn lens3de_cases() -> Vec<Case> {
    use crate::lens3de::{KINDS, Kind};
    KINDS
        .iter()
        .map(|&kind| {
            let anamorphic = !matches!(kind, Kind::Classic | Kind::RadialStandard4 | Kind::RadialFisheye8);
            let (size, back) = if anamorphic {
                ([640, 545], [4.3872, 1.8672])
            } else {
                ([640, 480], [2.4, 1.8])
            };
            let params = kind
                .all_params()
                .iter()
                .enumerate()
                .map(|(i, &(name, default))| match name {
                    "tde4_focal_length_cm" => {
                        if kind == Kind::RadialFisheye8 {
                            1.5
                        } else {
                            3.5
                        }
                    }
                    "tde4_filmback_width_cm" => back[0],
                    "tde4_filmback_height_cm" => back[1],
                    "tde4_lens_center_offset_x_cm" => 0.03,
                    "tde4_lens_center_offset_y_cm" => -0.02,
                    "tde4_pixel_aspect" => {
                        if anamorphic {
                            2.0
                        } else {
                            1.0
                        }
                    }
                    "Lens Rotation" => 1.5,
                    "Squeeze-X" => 1.02,
                    "Squeeze-Y" => 0.98,
                    "Anamorphic Squeeze" => 1.3,
                    "Phi - Cylindric Direction" => 25.0,
                    "B - Cylindric Bending" => 0.03,
                    _ if name.starts_with("field_of_view") || name == "Rescale" => default,
                    // The fisheye: mild terms in its rectilinear space (which the equisolid plate
                    // already stretches).
                    _ if kind == Kind::RadialFisheye8 => [0.01, -0.001, 0.0001, 0.0001][i - 10],
                    // Barrel in the first two coefficients, small higher terms.
                    _ if i < 12 => -0.04,
                    _ => {
                        if i % 2 == 0 {
                            -0.003
                        } else {
                            0.002
                        }
                    }
                })
                .collect();
            Case {
                model: kind.name(),
                params,
                pol: vec![],
                invpol: vec![],
                size,
            }
        })
        .collect()
}

fn model(c: &Case) -> CameraModel {
    CameraModel::new(
        c.model,
        &c.params,
        &c.pol,
        &c.invpol,
        c.size[0] as f64,
        c.size[1] as f64,
    )
    .unwrap_or_else(|e| panic!("{}: {e}", c.model))
}

fn fmt_list(v: &[f64]) -> Vec<String> {
    v.iter().map(|x| format!("{x}")).collect()
}

fn param_list(c: &Case, extra: &[(&str, &[&str])]) -> ParamList {
    let mut l = ParamList::new();
    let push = |l: &mut ParamList, decl: &str, vals: &[String]| {
        let vals: Vec<&str> = vals.iter().map(String::as_str).collect();
        l.push_text(decl, &vals, None).unwrap();
    };
    push(&mut l, "string model", &[c.model.to_string()]);
    push(&mut l, "float[] params", &fmt_list(&c.params));
    if !c.pol.is_empty() {
        push(&mut l, "float[] polynomial", &fmt_list(&c.pol));
    }
    if !c.invpol.is_empty() {
        push(&mut l, "float[] inversePolynomial", &fmt_list(&c.invpol));
    }
    push(
        &mut l,
        "int[2] resolution",
        &[c.size[0].to_string(), c.size[1].to_string()],
    );
    for (decl, vals) in extra {
        let vals: Vec<String> = vals.iter().map(|s| s.to_string()).collect();
        push(&mut l, decl, &vals);
    }
    l
}

fn projection(c: &Case, format: Format, extra: &[(&str, &[&str])]) -> Box<dyn Projection> {
    let mut env = ProjectionEnvironment::for_format(format);
    CalibratedCameraFactory
        .create_projection(&mut env, &param_list(c, extra))
        .unwrap_or_else(|e| panic!("{}: {e}", c.model))
}

fn project(p: &dyn Projection, screen: &[Point2]) -> Vec<RayGeometry> {
    let n = screen.len();
    let lens = vec![Point2::new(0.5, 0.5); n];
    let aperture = vec![Point2::ZERO; n];
    let mut time = vec![0.0; n];
    let mut rays = vec![RayGeometry::CULLED; n];
    let mut tint = vec![Rgb::WHITE; n];
    let mut ctx = ProjectionContext::new(screen, &lens, &aperture, &mut time, &mut rays, &mut tint).unwrap();
    p.project(&mut ctx);
    rays
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    crate::projection::angle_between(unit(a), unit(b))
}

/// OpenCV `projectPoints`' distorted normalised point (rational, thin prism and tilt) of the
/// perspective point `(a, b)`, for the OpenCV models' `params`.
fn opencv_distorted(p: &[f64], a: f64, b: f64) -> (f64, f64) {
    let r2 = a * a + b * b;
    let k = |i: usize| p.get(i).copied().unwrap_or(0.0);
    let (k1, k2c, p1, p2, k3, k4, k5, k6) = (k(4), k(5), k(6), k(7), k(8), k(9), k(10), k(11));
    let (s1, s2, s3, s4) = (k(12), k(13), k(14), k(15));
    let radial = (1.0 + k1 * r2 + k2c * r2 * r2 + k3 * r2 * r2 * r2)
        / (1.0 + k4 * r2 + k5 * r2 * r2 + k6 * r2 * r2 * r2);
    let mut xd = a * radial + 2.0 * p1 * a * b + p2 * (r2 + 2.0 * a * a) + s1 * r2 + s2 * r2 * r2;
    let mut yd = b * radial + p1 * (r2 + 2.0 * b * b) + 2.0 * p2 * a * b + s3 * r2 + s4 * r2 * r2;
    if p.len() == 18 {
        // OpenCV's tilt: R = Ry(τy)·Rx(τx), H = [[R33, 0, −R13], [0, R33, −R23], [0, 0, 1]]·R.
        let (tx, ty) = (p[16], p[17]);
        let (ctx, stx, cty, sty) = (tx.cos(), tx.sin(), ty.cos(), ty.sin());
        let r = [
            [cty, sty * stx, -sty * ctx],
            [0.0, ctx, stx],
            [sty, -cty * stx, cty * ctx],
        ];
        let h = [
            [
                r[2][2] * r[0][0] - r[0][2] * r[2][0],
                r[2][2] * r[0][1] - r[0][2] * r[2][1],
                0.0,
            ],
            [
                r[2][2] * r[1][0] - r[1][2] * r[2][0],
                r[2][2] * r[1][1] - r[1][2] * r[2][1],
                0.0,
            ],
            [r[2][0], r[2][1], r[2][2]],
        ];
        let hv = |i: usize| h[i][0] * xd + h[i][1] * yd + h[i][2];
        let w = hv(2);
        (xd, yd) = (hv(0) / w, hv(1) / w);
    }
    (xd, yd)
}

/// The forward projection of each model written out independently, straight from the source
/// library's formula (COLMAP `ImgFromCam`, OpenCV `projectPoints` and `omnidir::projectPoints`, basalt's
/// UCM and double sphere, NVIDIA's f-theta), for points in front of the camera. `None` where the
/// library refuses the point.
fn reference_pixel(c: &Case, x: f64, y: f64, z: f64) -> Option<[f64; 2]> {
    let p = &c.params;
    let (a, b) = (x / z, y / z);
    let r2 = a * a + b * b;
    let r = r2.sqrt();
    // COLMAP FisheyeFromNormal: θ = atan(r), (uu, vv) = θ/r·(u, v).
    let fish = || {
        let t = r.atan();
        if r > f64::EPSILON {
            (a * t / r, b * t / r)
        } else {
            (a, b)
        }
    };
    let k_f = |f: f64, cx: f64, cy: f64, u: f64, v: f64| Some([f * u + cx, f * v + cy]);
    let k2 = |u: f64, v: f64| Some([p[0] * u + p[2], p[1] * v + p[3]]);
    match c.model {
        "SIMPLE_PINHOLE" => k_f(p[0], p[1], p[2], a, b),
        "PINHOLE" => k2(a, b),
        "SIMPLE_RADIAL" => k_f(p[0], p[1], p[2], a * (1.0 + p[3] * r2), b * (1.0 + p[3] * r2)),
        "RADIAL" => {
            let rad = p[3] * r2 + p[4] * r2 * r2;
            k_f(p[0], p[1], p[2], a * (1.0 + rad), b * (1.0 + rad))
        }
        "OPENCV" | "FULL_OPENCV" | "OPENCV_PINHOLE" => {
            let (xd, yd) = opencv_distorted(p, a, b);
            k2(xd, yd)
        }
        "OPENCV_FISHEYE" | "KANNALA_BRANDT" => {
            let (uu, vv) = fish();
            let t2 = uu * uu + vv * vv;
            let rad = p[4] * t2 + p[5] * t2 * t2 + p[6] * t2.powi(3) + p[7] * t2.powi(4);
            k2(uu * (1.0 + rad), vv * (1.0 + rad))
        }
        "FOV" => {
            let w = p[4];
            let f = (r * 2.0 * (w / 2.0).tan()).atan() / (r * w);
            k2(a * f, b * f)
        }
        "SIMPLE_RADIAL_FISHEYE" | "RADIAL_FISHEYE" => {
            let (uu, vv) = fish();
            let t2 = uu * uu + vv * vv;
            let rad = p[3] * t2 + p.get(4).map_or(0.0, |k2| k2 * t2 * t2);
            k_f(p[0], p[1], p[2], uu * (1.0 + rad), vv * (1.0 + rad))
        }
        "THIN_PRISM_FISHEYE" => {
            let (u, v) = fish();
            let (k1, k2c, p1, p2, k3, k4, sx1, sy1) = (p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11]);
            let r2 = u * u + v * v;
            let rad = k1 * r2 + k2c * r2 * r2 + k3 * r2.powi(3) + k4 * r2.powi(4);
            let du = u * rad + 2.0 * p1 * u * v + p2 * (r2 + 2.0 * u * u) + sx1 * r2;
            let dv = v * rad + 2.0 * p2 * u * v + p1 * (r2 + 2.0 * v * v) + sy1 * r2;
            k2(u + du, v + dv)
        }
        "RAD_TAN_THIN_PRISM_FISHEYE" => {
            let (u, v) = fish();
            let t2 = u * u + v * v;
            let mut th = 1.0;
            let mut pw = 1.0;
            for k in &p[4..10] {
                pw *= t2;
                th += k * pw;
            }
            let (x, y) = (th * u, th * v);
            let (p0, p1, s0, s1, s2, s3) = (p[10], p[11], p[12], p[13], p[14], p[15]);
            let r2 = x * x + y * y;
            let dx = 2.0 * p1 * x * y + p0 * (r2 + 2.0 * x * x) + s0 * r2 + s1 * r2 * r2;
            let dy = 2.0 * p0 * x * y + p1 * (r2 + 2.0 * y * y) + s2 * r2 + s3 * r2 * r2;
            k2(x + dx, y + dy)
        }
        "SIMPLE_DIVISION" | "DIVISION" => {
            let (k, (fx, fy, cx, cy)) = if c.model == "DIVISION" {
                (p[4], (p[0], p[1], p[2], p[3]))
            } else {
                (p[3], (p[0], p[0], p[1], p[2]))
            };
            let rho = x.hypot(y);
            let disc = z * z - 4.0 * rho * rho * k;
            if disc < 0.0 {
                return None;
            }
            let s = 2.0 / (z + disc.sqrt());
            Some([fx * s * x + cx, fy * s * y + cy])
        }
        "SIMPLE_FISHEYE" => {
            let (u, v) = fish();
            k_f(p[0], p[1], p[2], u, v)
        }
        "FISHEYE" => {
            let (u, v) = fish();
            k2(u, v)
        }
        "EUCM" | "UCM" => {
            let (alpha, beta) = (
                p[4],
                p.get(5).copied().filter(|_| c.model == "EUCM").unwrap_or(1.0),
            );
            let den = alpha * (beta * (x * x + y * y) + z * z).sqrt() + (1.0 - alpha) * z;
            k2(x / den, y / den)
        }
        "EQUIRECTANGULAR" => {
            let theta = x.atan2(z);
            let phi = (-y).atan2(x.hypot(z));
            Some([
                (theta / std::f64::consts::TAU + 0.5) * p[0],
                (0.5 - phi / std::f64::consts::PI) * p[1],
            ])
        }
        "OPENCV_OMNIDIR" => {
            let n = (x * x + y * y + z * z).sqrt();
            let (xs, ys, zs) = (x / n, y / n, z / n);
            let (xu, yu) = (xs / (zs + p[5]), ys / (zs + p[5]));
            let (k1, k2c, p1, p2) = (p[6], p[7], p[8], p[9]);
            let r2 = xu * xu + yu * yu;
            let rad = 1.0 + k1 * r2 + k2c * r2 * r2;
            let xd = xu * rad + 2.0 * p1 * xu * yu + p2 * (r2 + 2.0 * xu * xu);
            let yd = yu * rad + p1 * (r2 + 2.0 * yu * yu) + 2.0 * p2 * xu * yu;
            Some([p[0] * xd + p[4] * yd + p[2], p[1] * yd + p[3]])
        }
        "DOUBLE_SPHERE" => {
            let (xi, alpha) = (p[4], p[5]);
            let d1 = (x * x + y * y + z * z).sqrt();
            let zz = xi * d1 + z;
            let d2 = (x * x + y * y + zz * zz).sqrt();
            let den = alpha * d2 + (1.0 - alpha) * zz;
            k2(x / den, y / den)
        }
        "OCAMCALIB" => {
            // OCamCalib world2cam with invpol (a fitted approximation of the exact inverse), in its
            // frame: x along rows (= OpenCV y), y along columns (= OpenCV x), z = −OpenCV z.
            let (xo, yo, zo) = (y, x, -z);
            let norm = xo.hypot(yo);
            let theta = (zo / norm).atan();
            let rho: f64 = c.invpol.iter().rev().fold(0.0, |acc, k| acc * theta + k);
            let (u, v) = (xo / norm * rho, yo / norm * rho);
            let (xc, yc, cc, dd, ee) = (p[0], p[1], p[2], p[3], p[4]);
            let row = u * cc + v * dd + xc;
            let col = u * ee + v + yc;
            Some([col, row])
        }
        _ => None,
    }
}

/// Model pixels spread over the calibration image (and a little beyond), deterministic.
fn image_pixels(c: &Case, n: usize) -> Vec<[f64; 2]> {
    let (w, h) = (c.size[0] as f64, c.size[1] as f64);
    (0..n)
        .map(|i| {
            let fx = (i as f64 * 0.618_033_988_75).fract();
            let fy = (i as f64 * 0.754_877_666_25).fract();
            [fx * w, fy * h]
        })
        .collect()
}

#[test]
fn every_model_matches_its_librarys_forward_formula() {
    for c in cases() {
        // 3DE's formulas are the pixel → ray direction; `lens3de`'s tests check them against the
        // LDPK supplement's figures and independent forms.
        if c.model.starts_with("3DE") {
            continue;
        }
        let m = model(&c);
        let tol = if c.model == "OCAMCALIB" { 0.5 } else { 1e-7 };
        let mut compared = 0;
        for px in image_pixels(&c, 4000) {
            let Some(r) = m.pixel_to_ray(px) else { continue };
            let [x, y, z] = unit(r.v);
            // The libraries' own formulas only see the front hemisphere.
            if z < 0.05 {
                continue;
            }
            let Some(reference) = reference_pixel(&c, x, y, z) else {
                if c.model.starts_with("FTHETA") {
                    continue;
                }
                panic!(
                    "{}: the library refuses the valid ray {:?} of pixel {px:?}",
                    c.model,
                    [x, y, z]
                );
            };
            let err = (reference[0] - px[0]).hypot(reference[1] - px[1]);
            assert!(
                err < tol,
                "{} {:?}: pixel {px:?} → ray → library pixel {reference:?} ({err} px)",
                c.model,
                c.params
            );
            compared += 1;
        }
        if !c.model.starts_with("FTHETA") {
            assert!(compared > 1000, "{}: only {compared} comparisons", c.model);
        }
    }
}

#[test]
fn ocamcalib_pixel_to_ray_is_cam2world() {
    // cam2world from OCamCalib's C code, on the published example: A⁻¹ on (row − xc, col − yc), then
    // (x', y', pol(ρ)) in OCamCalib's frame.
    let c = ocam_example();
    let m = model(&c);
    let (xc, yc, cc, dd, ee) = (c.params[0], c.params[1], c.params[2], c.params[3], c.params[4]);
    for px in image_pixels(&c, 500) {
        let (row, col) = (px[1], px[0]);
        let inv_det = 1.0 / (cc - dd * ee);
        let xp = inv_det * ((row - xc) - dd * (col - yc));
        let yp = inv_det * (-ee * (row - xc) + cc * (col - yc));
        let rho = xp.hypot(yp);
        let zp: f64 = c.pol.iter().rev().fold(0.0, |acc, k| acc * rho + k);
        // OCamCalib (x', y', z') → OpenCV (y', x', −z').
        let expected = [yp, xp, -zp];
        let got = m.pixel_to_ray(px).unwrap().v;
        assert!(angle(expected, got) < 1e-12, "{px:?}: {expected:?} vs {got:?}");
    }
}

#[test]
fn ftheta_pixel_to_ray_is_the_backward_polynomial() {
    let c = Case {
        pol: vec![0.0, 0.004, 1e-7, -2e-10],
        ..case("FTHETA", &[319.5, 239.5])
    };
    let m = model(&c);
    for px in image_pixels(&c, 300) {
        let (du, dv) = (px[0] - 319.5, px[1] - 239.5);
        let rho = du.hypot(dv);
        let theta = 0.004 * rho + 1e-7 * rho * rho - 2e-10 * rho.powi(3);
        let expected = [theta.sin() * du / rho, theta.sin() * dv / rho, theta.cos()];
        let got = m.pixel_to_ray(px).unwrap().v;
        assert!(angle(expected, got) < 1e-12, "{px:?}");
    }
}

#[test]
fn closed_form_values() {
    // An equidistant fisheye sees 120° off axis at f·(2π/3) pixels: beyond 180° of field.
    let m = CameraModel::new("SIMPLE_FISHEYE", &[200.0, 320.0, 240.0], &[], &[], 640.0, 480.0).unwrap();
    let px = m
        .ray_to_pixel([120f64.to_radians().sin(), 0.0, 120f64.to_radians().cos()])
        .unwrap();
    assert!(
        (px[0] - (320.0 + 200.0 * 2.0 * std::f64::consts::PI / 3.0)).abs() < 1e-9,
        "{px:?}"
    );
    // Equirectangular (COLMAP): +X is three quarters across, straight up (−Y) the top row.
    let e = CameraModel::new("EQUIRECTANGULAR", &[640.0, 320.0], &[], &[], 640.0, 320.0).unwrap();
    let px = e.ray_to_pixel([1.0, 0.0, 0.0]).unwrap();
    assert!(
        (px[0] - 480.0).abs() < 1e-9 && (px[1] - 160.0).abs() < 1e-9,
        "{px:?}"
    );
    assert!(e.ray_to_pixel([0.0, -1.0, 0.0]).unwrap()[1].abs() < 1e-9);
    // Double sphere with ξ = 0 and α = 0.5 is UCM with α = 0.5 (both one sphere, one projection centre).
    let ds = CameraModel::new(
        "DOUBLE_SPHERE",
        &[300.0, 300.0, 320.0, 240.0, 0.0, 0.5],
        &[],
        &[],
        640.0,
        480.0,
    )
    .unwrap();
    let ucm = CameraModel::new("UCM", &[300.0, 300.0, 320.0, 240.0, 0.5], &[], &[], 640.0, 480.0).unwrap();
    for d in [[0.3, -0.2, 1.0], [0.9, 0.5, -0.2]] {
        let (a, b) = (ds.ray_to_pixel(d).unwrap(), ucm.ray_to_pixel(d).unwrap());
        assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9);
    }
    // UCM's ξ form: α = ξ/(1 + ξ), fx = γ/(1 + ξ) gives u = γ·x/(z + ξ·|X|) + cx.
    let (xi, gamma) = (0.8, 540.0);
    let u = CameraModel::new(
        "UCM",
        &[
            gamma / (1.0 + xi),
            gamma / (1.0 + xi),
            320.0,
            240.0,
            xi / (1.0 + xi),
        ],
        &[],
        &[],
        640.0,
        480.0,
    )
    .unwrap();
    let d = [0.4f64, 0.1, 0.7];
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let px = u.ray_to_pixel(d).unwrap();
    assert!((px[0] - (gamma * d[0] / (d[2] + xi * n) + 320.0)).abs() < 1e-9);
}

/// Relative to the calibration raster, every valid pixel's ray maps back to the pixel.
fn roundtrip_f64(c: &Case, px: [f64; 2]) -> Result<(), TestCaseError> {
    let m = model(c);
    if let Some(r) = m.pixel_to_ray(px) {
        let back = m.ray_to_pixel(r.v);
        prop_assert!(
            back.is_some(),
            "{}: valid pixel {:?} has ray {:?} that does not project",
            c.model,
            px,
            r.v
        );
        let back = back.unwrap();
        let err = (back[0] - px[0]).hypot(back[1] - px[1]);
        prop_assert!(
            err <= 1e-6,
            "{} {:?}: pixel {:?} came back as {:?} ({} px)",
            c.model,
            c.params,
            px,
            back,
            err
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn pixel_ray_pixel_round_trips_to_a_micro_pixel(fx in 0.0f64..1.0, fy in 0.0f64..1.0) {
        for c in cases() {
            let px = [fx * c.size[0] as f64, fy * c.size[1] as f64];
            roundtrip_f64(&c, px)?;
        }
    }

    #[test]
    fn ray_pixel_ray_round_trips(x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0) {
        prop_assume!(x * x + y * y + z * z > 1e-4);
        for c in cases() {
            let m = model(&c);
            let Some(px) = m.ray_to_pixel([x, y, z]) else { continue };
            let r = m.pixel_to_ray(px);
            prop_assert!(r.is_some(), "{}: the ray {:?} projects to {:?}, which has no ray", c.model, [x, y, z], px);
            let a = angle(r.unwrap().v, [x, y, z]);
            prop_assert!(a < 1e-9, "{}: ray {:?} → pixel {:?} → ray off by {} rad", c.model, [x, y, z], px, a);
        }
    }

    #[test]
    fn the_f32_projection_round_trips_to_a_thousandth_of_a_pixel(fx in 0.0f32..1.0, fy in 0.0f32..1.0, depth in 0.5f32..50.0) {
        for c in cases() {
            let format = Format::new(c.size[0] as u32, c.size[1] as u32);
            let p = projection(&c, format, &[]);
            let w = ScreenWindow::default_for(format);
            let s = w.raster_to_screen(format, fx as f64 * format.width as f64, fy as f64 * format.height as f64);
            let r = project(p.as_ref(), &[s])[0];
            if r.is_culled() {
                continue;
            }
            prop_assert!((r.direction.length() - 1.0).abs() < 1e-6);
            let back = p.unproject(r.origin + r.direction * depth, 0.0);
            prop_assert!(back.is_some(), "{}: valid screen point {:?} does not unproject", c.model, s);
            let back = back.unwrap();
            let (px, py) = w.pixel_size(format);
            let err = (((back.x - s.x) / px) as f64).hypot(((back.y - s.y) / py) as f64);
            prop_assert!(err <= 1e-3, "{}: screen {:?} came back as {:?} ({} px)", c.model, s, back, err);
        }
    }
}

#[test]
fn most_of_each_image_is_valid_and_wide_models_see_past_180_degrees() {
    for c in cases() {
        let m = model(&c);
        let px = image_pixels(&c, 2000);
        let valid = px.iter().filter(|p| m.pixel_to_ray(**p).is_some()).count();
        // OPENCV-type rational models with strong barrel fold inside the image corners.
        assert!(valid > 1200, "{}: only {valid} of 2000 pixels valid", c.model);
    }
    for (name, params) in [
        ("SIMPLE_FISHEYE", vec![100.0, 320.0, 240.0]),
        (
            "OPENCV_OMNIDIR",
            vec![200.0, 200.0, 320.0, 240.0, 0.0, 1.5, 0.0, 0.0, 0.0, 0.0],
        ),
        ("DOUBLE_SPHERE", vec![120.0, 120.0, 320.0, 240.0, -0.2, 0.59]),
        ("EUCM", vec![150.0, 150.0, 320.0, 240.0, 0.6, 1.1]),
        ("UCM", vec![150.0, 150.0, 320.0, 240.0, 0.6]),
        ("SIMPLE_DIVISION", vec![150.0, 320.0, 240.0, -0.5]),
    ] {
        let m = CameraModel::new(name, &params, &[], &[], 640.0, 480.0).unwrap();
        // Some pixel of the image sees behind the camera.
        let behind = (0..640).any(|u| {
            m.pixel_to_ray([u as f64, 240.0])
                .is_some_and(|r| unit(r.v)[2] < -0.1)
        });
        assert!(behind, "{name} should see more than 180°");
        assert!(m.may_leave_front(), "{name}");
    }
}

#[test]
fn fold_over_regions_are_invalid_in_both_directions() {
    // OPENCV with k1 = −0.5: r·(1 − 0.5r²) folds at r = sqrt(2/3), whose image is r_d = sqrt(2/3)·2/3.
    let (f, cx, cy) = (500.0, 320.0, 240.0);
    let c = case("OPENCV", &[f, f, cx, cy, -0.5, 0.0, 0.0, 0.0]);
    let m = model(&c);
    let r_fold = (2.0f64 / 3.0).sqrt();
    let rd_max = r_fold * 2.0 / 3.0;
    assert!((m.max_radius() - r_fold).abs() < 1e-6, "{}", m.max_radius());
    assert!(m.pixel_to_ray([cx + f * rd_max * 0.999, cy]).is_some());
    assert!(m.pixel_to_ray([cx + f * rd_max * 1.001, cy]).is_none());
    assert!(
        m.pixel_to_ray([0.0, 0.0]).is_none(),
        "the image corner is beyond the fold"
    );
    // A direction beyond the fold angle does not project; one inside does.
    assert!(m.ray_to_pixel([r_fold * 1.01, 0.0, 1.0]).is_none());
    assert!(m.ray_to_pixel([r_fold * 0.99, 0.0, 1.0]).is_some());
    // Through the projection: culled samples are exactly zero.
    let format = Format::new(640, 480);
    let p = projection(&c, format, &[]);
    let w = ScreenWindow::default_for(format);
    let rays = project(
        p.as_ref(),
        &[
            w.raster_to_screen(format, 1.0, 1.0),
            w.raster_to_screen(format, 320.0, 240.0),
        ],
    );
    assert_eq!(rays[0].direction, Vec3::ZERO);
    assert!(!rays[1].is_culled());
    assert!(
        p.unproject(Vec3::new(r_fold as f32 * 1.01, 0.0, 1.0), 0.0)
            .is_none()
    );
    // A Kannala–Brandt polynomial past its monotonic range folds too: θ(1 − 0.1θ²) peaks at θ = sqrt(10/3).
    let kb = CameraModel::new(
        "KANNALA_BRANDT",
        &[200.0, 200.0, 320.0, 240.0, -0.1, 0.0, 0.0, 0.0],
        &[],
        &[],
        640.0,
        480.0,
    )
    .unwrap();
    assert!(
        (kb.max_radius() - (10.0f64 / 3.0).sqrt()).abs() < 1e-6,
        "{}",
        kb.max_radius()
    );
}

#[test]
fn pixel_conventions_differ_by_exactly_half_a_pixel() {
    let c = case("PINHOLE", &[500.0, 480.0, 321.5, 238.2]);
    let format = Format::new(640, 480);
    let w = ScreenWindow::default_for(format);
    let colmap = projection(&c, format, &[("string pixelConvention", &["colmap"])]);
    let opencv = projection(&c, format, &[("string pixelConvention", &["opencv"])]);
    let matlab = projection(&c, format, &[("string pixelConvention", &["matlab"])]);
    for (u, v) in [(10.5, 20.5), (320.0, 240.0), (639.5, 479.5)] {
        // The same principal point is half a pixel further right and down under OpenCV's convention.
        let a = project(opencv.as_ref(), &[w.raster_to_screen(format, u, v)])[0];
        let b = project(colmap.as_ref(), &[w.raster_to_screen(format, u - 0.5, v - 0.5)])[0];
        let m = project(matlab.as_ref(), &[w.raster_to_screen(format, u - 1.0, v - 1.0)])[0];
        assert!((a.direction - b.direction).length() < 1e-6 && (a.direction - m.direction).length() < 1e-6);
        let same = project(colmap.as_ref(), &[w.raster_to_screen(format, u, v)])[0];
        let shift = (same.direction - a.direction).length();
        assert!(shift > 1e-4, "the conventions must differ");
    }
    // The ray through the centre of pixel (0, 0) under COLMAP is at model pixel (0.5, 0.5).
    let centre = w.raster_to_screen(format, 0.5, 0.5);
    let d = project(colmap.as_ref(), &[centre])[0].direction;
    let expected = unit([(0.5 - 321.5) / 500.0, -(0.5 - 238.2) / 480.0, 1.0]);
    assert!((d.x as f64 - expected[0]).abs() < 1e-6 && (d.y as f64 - expected[1]).abs() < 1e-6);
    // `auto`: COLMAP models use colmap, the OpenCV-family and NVIDIA's use opencv.
    for (name, expected) in [
        ("PINHOLE", PixelConvention::Colmap),
        ("EQUIRECTANGULAR", PixelConvention::Colmap),
        ("OPENCV_PINHOLE", PixelConvention::OpenCv),
        ("KANNALA_BRANDT", PixelConvention::OpenCv),
        ("OCAMCALIB", PixelConvention::OpenCv),
        ("FTHETA", PixelConvention::OpenCv),
    ] {
        assert_eq!(crate::model_info(name).unwrap().convention, expected, "{name}");
    }
}

#[test]
fn a_point_above_the_principal_point_is_at_plus_y() {
    let c = case("PINHOLE", &[500.0, 500.0, 320.0, 240.0]);
    let format = Format::new(640, 480);
    let p = projection(&c, format, &[]);
    let w = ScreenWindow::default_for(format);
    // Raster row 100 is above the principal point's row 240 (smaller v).
    let r = project(p.as_ref(), &[w.raster_to_screen(format, 320.0, 100.0)])[0];
    assert!(
        r.direction.y > 0.1 && r.direction.x.abs() < 1e-6,
        "{:?}",
        r.direction
    );
    // And back: a point at +Y is seen above the centre (positive screen y).
    let s = p.unproject(Vec3::new(0.0, 1.0, 5.0), 0.0).unwrap();
    assert!(s.y > 0.0 && s.x.abs() < 1e-6);
}

#[test]
fn a_half_size_render_has_the_same_rays_at_corresponding_points() {
    for c in [
        case(
            "OPENCV",
            &[500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005],
        ),
        case("EUCM", &[350.0, 350.0, 320.0, 240.0, 0.6, 1.1]),
    ] {
        let full = Format::new(640, 480);
        let half = Format::new(320, 240);
        let pf = projection(&c, full, &[]);
        let ph = projection(&c, half, &[]);
        let (wf, wh) = (ScreenWindow::default_for(full), ScreenWindow::default_for(half));
        for (i, j) in [(0u32, 0u32), (17, 33), (160, 120), (319, 239)] {
            // Half-size pixel (i, j) covers full-size pixels (2i..2i+2, 2j..2j+2): same centre.
            let sh = wh.raster_to_screen(half, i as f64 + 0.5, j as f64 + 0.5);
            let sf = wf.raster_to_screen(full, 2.0 * i as f64 + 1.0, 2.0 * j as f64 + 1.0);
            let (a, b) = (project(ph.as_ref(), &[sh])[0], project(pf.as_ref(), &[sf])[0]);
            assert!(
                (a.direction - b.direction).length() < 1e-6,
                "{} ({i}, {j})",
                c.model
            );
            // The footprint doubles with the pixel.
            if !a.is_culled() {
                assert!(
                    (a.ray_spread / b.ray_spread - 2.0).abs() < 0.01,
                    "{} {} {}",
                    c.model,
                    a.ray_spread,
                    b.ray_spread
                );
            }
        }
    }
}

#[test]
fn ray_spread_is_half_the_per_pixel_angle() {
    for c in cases() {
        let format = Format::new(c.size[0] as u32, c.size[1] as u32);
        let p = projection(&c, format, &[]);
        let w = ScreenWindow::default_for(format);
        let (px, py) = w.pixel_size(format);
        let h = 0.05f32;
        let mut checked = 0;
        for raster in image_pixels(&c, 200) {
            let s = w.raster_to_screen(format, raster[0], raster[1]);
            let pts = [
                s,
                Point2::new(s.x + h * px, s.y),
                Point2::new(s.x - h * px, s.y),
                Point2::new(s.x, s.y + h * py),
                Point2::new(s.x, s.y - h * py),
            ];
            let r = project(p.as_ref(), &pts);
            if r.iter().any(RayGeometry::is_culled) {
                continue;
            }
            let v = |d: Vec3| [d.x as f64, d.y as f64, d.z as f64];
            let ax = angle(v(r[1].direction), v(r[2].direction)) / (2.0 * h as f64);
            let ay = angle(v(r[3].direction), v(r[4].direction)) / (2.0 * h as f64);
            let expected = 0.5 * (ax * ay).sqrt();
            let got = r[0].ray_spread as f64;
            assert!(
                (got / expected - 1.0).abs() < 0.02,
                "{}: spread {got} vs {expected} at {raster:?}",
                c.model
            );
            checked += 1;
        }
        assert!(checked > 100, "{}: {checked}", c.model);
    }
}

#[test]
fn properties_are_honest() {
    for c in cases() {
        let format = Format::new(c.size[0] as u32, c.size[1] as u32);
        let p = projection(&c, format, &[]);
        let hint = p.property(ProjectionProperty::DicingHint);
        let metric = p.property(ProjectionProperty::DeepMetric);
        let Some(PropertyValue::Float(fov)) = p.property(ProjectionProperty::FieldOfView) else {
            panic!("{}: no field of view", c.model)
        };
        assert!(fov > 1.0 && fov < 360.0, "{}: fov {fov}", c.model);
        let w = ScreenWindow::default_for(format);
        let mut screen = Vec::new();
        for j in (-4..=c.size[1] + 4).step_by(4) {
            for i in (-4..=c.size[0] + 4).step_by(4) {
                screen.push(w.raster_to_screen(format, i as f64, j as f64));
            }
        }
        for r in project(p.as_ref(), &screen) {
            if r.is_culled() {
                continue;
            }
            assert!(
                (r.direction.length() - 1.0).abs() < 1e-5 && r.ray_spread.is_finite() && r.ray_spread >= 0.0
            );
            assert!(
                r.min_dist >= 0.0 && r.min_dist <= r.max_dist,
                "{}: {r:?}",
                c.model
            );
            if r.direction.z <= 0.0 {
                assert_eq!(
                    metric,
                    Some(PropertyValue::DeepMetric(DeepMetric::RayLength)),
                    "{}",
                    c.model
                );
                assert_eq!(
                    hint,
                    Some(PropertyValue::DicingHint(DicingHint::Spherical)),
                    "{}",
                    c.model
                );
            }
        }
    }
    // A 90° pinhole across the width (the default camera) reports 75° across the narrower height.
    let p = CalibratedCameraFactory
        .create_projection(
            &mut ProjectionEnvironment::for_format(Format::new(640, 480)),
            &ParamList::new(),
        )
        .unwrap();
    let Some(PropertyValue::Float(fov)) = p.property(ProjectionProperty::FieldOfView) else {
        panic!()
    };
    assert!(
        (fov as f64 - 2.0 * (240.0f64 / 320.0).atan().to_degrees()).abs() < 1e-3,
        "{fov}"
    );
    assert_eq!(
        p.property(ProjectionProperty::DicingHint),
        Some(PropertyValue::DicingHint(DicingHint::Perspective))
    );
    // The equirectangular camera sees 180° across its height.
    let c = cases()
        .into_iter()
        .find(|c| c.model == "EQUIRECTANGULAR")
        .unwrap();
    let p = projection(&c, Format::new(640, 320), &[]);
    let Some(PropertyValue::Float(fov)) = p.property(ProjectionProperty::FieldOfView) else {
        panic!()
    };
    assert!((fov - 180.0).abs() < 1e-3, "{fov}");
}

#[test]
fn the_default_camera_works_at_any_format() {
    for format in [Format::new(48, 32), Format::new(16, 16), Format::new(640, 480)] {
        let mut env = ProjectionEnvironment::for_format(format);
        let p = CalibratedCameraFactory
            .create_projection(&mut env, &ParamList::new())
            .unwrap();
        let w = ScreenWindow::default_for(format);
        let s = [w.raster_to_screen(format, 0.0, 0.0), Point2::ZERO];
        let r = project(p.as_ref(), &s);
        assert!(r.iter().all(|r| !r.is_culled()));
        let back = p.unproject(r[0].direction * 3.0, 0.0).unwrap();
        assert!((back.x - s[0].x).abs() < 1e-5 && (back.y - s[0].y).abs() < 1e-5);
    }
}

fn create_err(list: &ParamList) -> String {
    let mut env = ProjectionEnvironment::for_format(Format::new(640, 480));
    CalibratedCameraFactory
        .create_projection(&mut env, list)
        .err()
        .expect("an error")
        .to_string()
}

#[test]
fn bad_parameters_get_clear_errors() {
    // Wrong count: the model and its parameter names.
    let mut c = case("OPENCV", &[500.0, 500.0, 320.0, 240.0, 0.1]);
    let e = create_err(&param_list(&c, &[]));
    assert!(
        e.contains("CalibratedCamera")
            && e.contains("OPENCV takes 8 params (fx, fy, cx, cy, k1, k2, p1, p2), got 5"),
        "{e}"
    );
    c = case(
        "OPENCV_PINHOLE",
        &[500.0, 500.0, 320.0, 240.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    let e = create_err(&param_list(&c, &[]));
    assert!(e.contains("8 or 9 or 12 or 16 or 18 params"), "{e}");
    // A polynomial given to a model without one.
    let mut c = case("PINHOLE", &[500.0, 500.0, 320.0, 240.0]);
    c.pol = vec![1.0, 2.0];
    assert!(create_err(&param_list(&c, &[])).contains("takes no polynomial"));
    // OCAMCALIB without its polynomial.
    let mut c = ocam_example();
    c.pol.clear();
    assert!(create_err(&param_list(&c, &[])).contains("needs polynomial"));
    // Unknown model: did-you-mean from the choices.
    let mut l = ParamList::new();
    l.push_text("string model", &["PINHOL"], None).unwrap();
    let e = create_err(&l);
    assert!(e.contains("did you mean \"PINHOLE\""), "{e}");
    // Resolution missing with a calibration, or zero.
    let mut l = ParamList::new();
    l.push_text("string model", &["PINHOLE"], None).unwrap();
    l.push_text("float[] params", &["500", "500", "320", "240"], None)
        .unwrap();
    let e = create_err(&l);
    assert!(e.contains("resolution is required"), "{e}");
    l.push_text("int[2] resolution", &["0", "480"], None).unwrap();
    let e = create_err(&l);
    assert!(e.contains("resolution"), "{e}");
    // Out-of-range model parameters.
    for (c, what) in [
        (case("PINHOLE", &[-500.0, 500.0, 320.0, 240.0]), "fx must be > 0"),
        (
            case("EUCM", &[300.0, 300.0, 320.0, 240.0, 1.5, 1.0]),
            "alpha must lie in [0, 1]",
        ),
        (
            case("DOUBLE_SPHERE", &[300.0, 300.0, 320.0, 240.0, 2.0, 0.5]),
            "xi must lie in [-1, 1]",
        ),
        (case("FOV", &[300.0, 300.0, 320.0, 240.0, 0.0]), "omega"),
    ] {
        let e = create_err(&param_list(&c, &[]));
        assert!(e.contains(what), "{e}");
    }
}

#[test]
fn the_shared_contract_checker_passes_every_model() {
    use obscura_check::{CheckOptions, check_factory};
    // The default camera at the checker's default format (another aspect: the resized camera).
    let report = check_factory(
        &CalibratedCameraFactory,
        &ParamList::new(),
        &CheckOptions::default(),
    )
    .unwrap();
    assert!(
        report.is_clean(),
        "default camera: {:?}\n{}",
        report.failed(),
        report.to_json()
    );
    for c in cases() {
        let opts = CheckOptions {
            format: Format::new(c.size[0] as u32 / 8, c.size[1] as u32 / 8),
            samples_per_pixel: 2,
            ..CheckOptions::default()
        };
        let report = check_factory(&CalibratedCameraFactory, &param_list(&c, &[]), &opts).unwrap();
        assert!(
            report.is_clean(),
            "{} {:?}: {:?}\n{}",
            c.model,
            c.params,
            report.failed(),
            report.to_json()
        );
    }
}

/// The hot models of the SIMD tier tests: OpenCV's pinhole family (with rational, thin-prism and tilt
/// terms), Kannala–Brandt / OpenCV fisheye, COLMAP's equidistant fisheye, equirectangular, Mei's
/// omnidirectional model, and two lenses that fold inside the image (culled beyond the fold).
fn tier_cases() -> Vec<Case> {
    let mut v = vec![
        case(
            "OPENCV",
            &[500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005],
        ),
        case(
            "FULL_OPENCV",
            &[
                500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005, -0.002, 0.01, 0.003, 0.0002,
            ],
        ),
        case(
            "OPENCV_PINHOLE",
            &[
                500.0, 490.0, 322.0, 241.0, -0.28, 0.07, 0.001, -0.0005, -0.002, 0.01, 0.003, 0.0002, 0.001,
                -0.0002, 0.0008, 0.0001, 0.01, -0.008,
            ],
        ),
        case(
            "KANNALA_BRANDT",
            &[300.0, 300.0, 320.0, 240.0, -0.01, 0.02, -0.003, 0.0005],
        ),
        case(
            "OPENCV_FISHEYE",
            &[300.0, 300.0, 320.0, 240.0, -0.01, 0.02, -0.003, 0.0005],
        ),
        case("FISHEYE", &[200.0, 210.0, 320.0, 240.0]),
        case("EQUIRECTANGULAR", &[640.0, 480.0]),
        case(
            "OPENCV_OMNIDIR",
            &[400.0, 400.0, 320.0, 240.0, 0.5, 1.2, -0.1, 0.02, 0.001, -0.0005],
        ),
        // r·(1 − 0.5r²) folds at r = sqrt(2/3), inside the image; θ(1 − 0.1θ²) at θ = sqrt(10/3).
        case("OPENCV", &[500.0, 500.0, 320.0, 240.0, -0.5, 0.0, 0.0, 0.0]),
        case(
            "KANNALA_BRANDT",
            &[200.0, 200.0, 320.0, 240.0, -0.1, 0.0, 0.0, 0.0],
        ),
    ];
    v.push(case("RADIAL", &[500.0, 320.0, 240.0, -0.2, 0.05]));
    v
}

fn ray_bits(rays: &[RayGeometry]) -> Vec<[u32; 10]> {
    rays.iter().map(RayGeometry::to_bits).collect()
}

/// Every SIMD tier ([`obscura_sdk::simd::Level`]: portable, AVX2 + FMA, AVX-512; a tier the CPU lacks
/// runs as the widest it has) gives the portable tier's rays bit for bit, for screen samples over the
/// whole image and a third of it beyond every side (past both folds, outside the fisheyes' circles),
/// and a culled sample is exactly the culled ray. The kernels use IEEE operations only (no fused
/// multiply-adds, no approximate reciprocals), so every lane width rounds the same.
#[test]
fn tiers_every_model_is_the_portable_tier_bit_for_bit() {
    use obscura_sdk::simd::{Level, with_level};
    let format = Format::new(640, 480);
    let w = ScreenWindow::default_for(format);
    // 1001 samples: the last chunk of 32 lanes is partial.
    let screen: Vec<Point2> = (0..1001)
        .map(|i| {
            let fx = (i as f64 * 0.618_033_988_75).fract();
            let fy = (i as f64 * 0.754_877_666_25).fract();
            w.raster_to_screen(format, (1.667 * fx - 0.333) * 640.0, (1.667 * fy - 0.333) * 480.0)
        })
        .collect();
    for c in tier_cases() {
        let p = projection(&c, format, &[]);
        let portable = with_level(Level::Portable, || project(p.as_ref(), &screen));
        let culled = portable.iter().filter(|r| r.is_culled()).count();
        assert!(
            culled < screen.len(),
            "{} {:?}: everything culled",
            c.model,
            c.params
        );
        for r in portable.iter().filter(|r| r.is_culled()) {
            assert_eq!(ray_bits(&[*r]), ray_bits(&[RayGeometry::CULLED]), "{}", c.model);
        }
        for level in Level::ALL {
            let rays = with_level(level, || project(p.as_ref(), &screen));
            assert_eq!(
                ray_bits(&rays),
                ray_bits(&portable),
                "{} {:?}: tier {level}",
                c.model,
                c.params
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Anywhere on the image and a third of it beyond (fold regions included), at every tier: the ray
    /// is the portable tier's bit for bit and the per-pixel model's (`pixel_to_ray`; culled exactly where
    /// it has no ray), and a valid ray unprojects to its screen point within a thousandth of a pixel.
    #[test]
    fn tiers_random_points_match_the_per_pixel_model_and_round_trip(
        fx in -0.333f64..1.333, fy in -0.333f64..1.333, depth in 0.5f32..50.0,
    ) {
        use obscura_sdk::simd::{Level, with_level};
        let format = Format::new(640, 480);
        let w = ScreenWindow::default_for(format);
        let s = w.raster_to_screen(format, fx * 640.0, fy * 480.0);
        let (px, py) = w.pixel_size(format);
        for c in tier_cases() {
            let p = projection(&c, format, &[]);
            let m = model(&c);
            // Batches of 33: the sample in a full chunk of 32 lanes and alone in the partial one.
            let portable = with_level(Level::Portable, || project(p.as_ref(), &[s; 33]));
            prop_assert_eq!(ray_bits(&portable[..1]), ray_bits(&portable[32..]));
            for level in Level::ALL {
                let rays = with_level(level, || project(p.as_ref(), &[s; 33]));
                prop_assert_eq!(ray_bits(&rays), ray_bits(&portable), "{} tier {}", c.model, level);
            }
            let r = portable[0];
            // Raster → model pixel as the projection places it (both conventions' shift included).
            let shift = m.info().convention.shift();
            let model_px = [fx * 640.0 + shift, fy * 480.0 + shift];
            prop_assert_eq!(r.is_culled(), m.pixel_to_ray(model_px).is_none(), "{} at {:?}", c.model, model_px);
            if r.is_culled() {
                continue;
            }
            let back = p.unproject(r.direction * depth, 0.0);
            prop_assert!(back.is_some(), "{}: valid {:?} does not unproject", c.model, s);
            let back = back.unwrap();
            // Beyond the image the equirectangular model wraps around: the same direction is seen
            // inside it. Near its poles the column is ill-conditioned (a pole is one direction).
            let inside = (0.0..=1.0).contains(&fx) && (0.0..=1.0).contains(&fy);
            let polar = c.model == "EQUIRECTANGULAR" && !(0.01..=0.99).contains(&fy);
            if !inside || polar {
                let again = project(p.as_ref(), &[back])[0];
                let a = angle(
                    [f64::from(again.direction.x), f64::from(again.direction.y), f64::from(again.direction.z)],
                    [f64::from(r.direction.x), f64::from(r.direction.y), f64::from(r.direction.z)],
                );
                prop_assert!(a < 1e-5, "{}: {:?} → {:?}: {} rad", c.model, s, back, a);
                continue;
            }
            let err = (((back.x - s.x) / px) as f64).hypot(((back.y - s.y) / py) as f64);
            prop_assert!(err <= 1e-3, "{}: {:?} came back as {:?} ({} px)", c.model, s, back, err);
        }
    }
}
