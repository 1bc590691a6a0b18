//! The camera a render used, written as a `.usda` layer for Omniverse, Isaac Sim and USD tools.
//!
//! One `Camera` prim `/ObscuraCamera` (the stage's `defaultPrim`) with:
//!
//! - `xformOp:transform`: camera-to-world in USD's row-vector form, `(diag(1, 1, −1, 1)·W)⁻¹` of each
//!   frame's world-to-camera `W` (Obscura looks down +Z, USD down −Z), time-sampled at each frame's
//!   time code when there are several;
//! - the gate: `focalLength` 50 (tenths of a scene unit) and, for a screen window `[l, r] × [b, t]`
//!   through `PxrPerspective` with field of view `fov`, `horizontalAperture = (r − l)·k`,
//!   `horizontalApertureOffset = (r + l)/2·k` (likewise vertical) with `k = 50·tan(fov/2)`, so each
//!   screen point keeps its ray; an orthographic window `×10` (tenths of a scene unit);
//! - `clippingRange`, `shutter:open/close`, and `fStop`/`focusDistance` when the lens has depth of field;
//! - for `PxrCamera` with distortion, Hydra's `lensDistortion:k1`, `k2`, `anaSq`, `asym` (the inverse of
//!   [`crate::ri::LensDistortion`]) when its screen window spans `x ∈ [−1, 1]`, where hdPrman's
//!   normalisation to half the horizontal aperture is the same; otherwise the export is refused;
//! - for `CalibratedCamera` with `OPENCV_PINHOLE`, `KANNALA_BRANDT`/`OPENCV_FISHEYE` or `FTHETA`, the
//!   matching `OmniLensDistortion*API` applied with every attribute (the inverse of [`crate::lens`]).
//!
//! Other projections have no USD camera: the export is refused with a message naming it.

use std::fmt::Write as _;

use glam::{DMat4, Mat4};
use obscura_scene::Scene;
use obscura_sdk::ParamValue;

use crate::camera::flip_z;

/// One rendered frame: its time code and the scene as rendered.
pub struct Frame<'a> {
    /// The frame's time code.
    pub time_code: f64,
    /// The scene, after every override.
    pub scene: &'a Scene,
}

/// The `.usda` text of the camera of `frames` (at least one), at `time_codes_per_second`.
///
/// # Errors
/// A projection USD cannot describe, named.
pub fn camera_usda(frames: &[Frame<'_>], time_codes_per_second: f64) -> Result<String, String> {
    if frames.is_empty() {
        return Err("no frame to export".into());
    }
    // Each frame's attributes as (declaration, value) in order; a value that differs between frames
    // is written as time samples.
    let per_frame = frames
        .iter()
        .map(|f| attributes(f.scene))
        .collect::<Result<Vec<_>, _>>()?;
    let (first, api) = &per_frame[0];
    let mut body = String::new();
    for (i, (decl, value)) in first.iter().enumerate() {
        let values: Vec<&String> = per_frame
            .iter()
            .map(|(a, _)| a.get(i).map_or(value, |(_, v)| v))
            .collect();
        if frames.len() == 1 || decl.starts_with("uniform") || values.iter().all(|v| *v == value) {
            let _ = writeln!(body, "    {decl} = {value}");
        } else {
            let _ = writeln!(body, "    {decl}.timeSamples = {{");
            for (f, v) in frames.iter().zip(values) {
                let _ = writeln!(body, "        {}: {v},", num(f.time_code));
            }
            body.push_str("    }\n");
        }
    }
    let mut out = String::from("#usda 1.0\n(\n    defaultPrim = \"ObscuraCamera\"\n");
    if frames.len() > 1 {
        let _ = writeln!(out, "    startTimeCode = {}", num(frames[0].time_code));
        let _ = writeln!(
            out,
            "    endTimeCode = {}",
            num(frames[frames.len() - 1].time_code)
        );
    }
    let _ = writeln!(out, "    timeCodesPerSecond = {}", num(time_codes_per_second));
    out.push_str("    upAxis = \"Y\"\n    doc = \"The camera Obscura rendered with\"\n)\n\n");
    out.push_str("def Camera \"ObscuraCamera\"");
    if api.is_empty() {
        out.push('\n');
    } else {
        let list: Vec<String> = api.iter().map(|a| format!("\"{a}\"")).collect();
        let _ = write!(out, " (\n    prepend apiSchemas = [{}]\n)\n", list.join(", "));
    }
    out.push_str("{\n");
    out.push_str(&body);
    out.push_str("}\n");
    Ok(out)
}

/// The attributes of one frame's camera as (declaration, value), and the API schemas to apply.
type Attributes = (Vec<(String, String)>, Vec<&'static str>);

fn attributes(scene: &Scene) -> Result<Attributes, String> {
    let floats = |name: &str| match scene.projection_params.get(name).map(|e| &e.value) {
        Some(ParamValue::Floats(v)) => Some(v.iter().map(|&x| f64::from(x)).collect::<Vec<_>>()),
        _ => None,
    };
    let string = |name: &str| match scene.projection_params.get(name).map(|e| &e.value) {
        Some(ParamValue::Strings(v)) => v.first().cloned(),
        _ => None,
    };
    let window = scene.camera.screen_window();
    let (l, r, b, t) = (
        f64::from(window.left),
        f64::from(window.right),
        f64::from(window.bottom),
        f64::from(window.top),
    );
    let focal = 50.0;
    let mut lines: Vec<String> = Vec::new();
    let mut api = Vec::new();
    let mut attr = |line: String| lines.push(line);
    match scene.projection.as_str() {
        "PxrPerspective" | "PxrCamera" => {
            let fov = floats("fov").and_then(|v| v.first().copied()).unwrap_or(90.0);
            let k = focal * (fov.to_radians() / 2.0).tan();
            attr("token projection = \"perspective\"".into());
            attr(format!("float focalLength = {focal}"));
            attr(format!("float horizontalAperture = {}", num((r - l) * k)));
            attr(format!("float verticalAperture = {}", num((t - b) * k)));
            attr(format!(
                "float horizontalApertureOffset = {}",
                num((r + l) / 2.0 * k)
            ));
            attr(format!(
                "float verticalApertureOffset = {}",
                num((t + b) / 2.0 * k)
            ));
            if scene.projection == "PxrCamera" {
                // PxrCamera's distortion as Hydra's lensDistortion:*, the inverse of
                // `ri::LensDistortion` (hdPrman normalises it to half the horizontal aperture).
                let one = |n: &str, d: f64| floats(n).and_then(|v| v.first().copied()).unwrap_or(d);
                let d = [
                    one("radial1", 0.0),
                    one("radial2", 0.0),
                    one("squeeze", 1.0),
                    one("assymX", 0.0),
                    one("assymY", 0.0),
                ];
                if d != [0.0, 0.0, 1.0, 0.0, 0.0] {
                    if (l + 1.0).abs() > 1e-6 || (r - 1.0).abs() > 1e-6 {
                        return Err(format!(
                            "PxrCamera's distortion (radial1, radial2, squeeze, assymX, assymY) is measured on its screen \
                             window [{l}, {r}] across; USD's lensDistortion:* on half the horizontal aperture, so it \
                             is exported only for a window spanning x from -1 to 1"
                        ));
                    }
                    attr(format!("float lensDistortion:k1 = {}", num(d[0])));
                    attr(format!("float lensDistortion:k2 = {}", num(d[1])));
                    attr(format!("float lensDistortion:anaSq = {}", num(d[2])));
                    attr(format!(
                        "float2 lensDistortion:asym = ({}, {})",
                        num(d[3]),
                        num(d[4])
                    ));
                }
            }
            let f_stop = floats("fStop").and_then(|v| v.first().copied());
            let distance = floats("focalDistance").and_then(|v| v.first().copied());
            if let (Some(f), Some(d)) = (f_stop, distance)
                && f.is_finite()
                && f > 0.0
            {
                attr(format!("float fStop = {}", num(f)));
                attr(format!("float focusDistance = {}", num(d)));
            }
        }
        "PxrOrthographic" => {
            attr("token projection = \"orthographic\"".into());
            attr(format!("float horizontalAperture = {}", num((r - l) * 10.0)));
            attr(format!("float verticalAperture = {}", num((t - b) * 10.0)));
            attr(format!(
                "float horizontalApertureOffset = {}",
                num((r + l) / 2.0 * 10.0)
            ));
            attr(format!(
                "float verticalApertureOffset = {}",
                num((t + b) / 2.0 * 10.0)
            ));
        }
        "CalibratedCamera" => {
            let model = string("model").unwrap_or_default();
            let p = floats("params").unwrap_or_default();
            let res = match scene.projection_params.get("resolution").map(|e| &e.value) {
                Some(ParamValue::Ints(v)) if v.len() == 2 => [v[0], v[1]],
                _ => return Err("CalibratedCamera without resolution: cannot state the image size".into()),
            };
            let ns = "omni:lensdistortion";
            let mut put = |m: &str, names: &[&str], values: &[f64]| {
                for (n, v) in names.iter().zip(values) {
                    attr(format!("float {ns}:{m}:{n} = {}", num(*v)));
                }
            };
            match model.as_str() {
                "OPENCV_PINHOLE" if p.len() >= 4 => {
                    api.push("OmniLensDistortionOpenCvPinholeAPI");
                    let mut all = p.clone();
                    all.resize(16, 0.0);
                    put(
                        "opencvPinhole",
                        &[
                            "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1",
                            "s2", "s3", "s4",
                        ],
                        &all,
                    );
                    attr(format!(
                        "int2 {ns}:opencvPinhole:imageSize = ({}, {})",
                        res[0], res[1]
                    ));
                    attr(format!("token {ns}:model = \"opencvPinhole\""));
                }
                "KANNALA_BRANDT" | "OPENCV_FISHEYE" if p.len() == 8 => {
                    api.push("OmniLensDistortionOpenCvFisheyeAPI");
                    put(
                        "opencvFisheye",
                        &["fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"],
                        &p,
                    );
                    attr(format!(
                        "int2 {ns}:opencvFisheye:imageSize = ({}, {})",
                        res[0], res[1]
                    ));
                    attr(format!("token {ns}:model = \"opencvFisheye\""));
                }
                "FTHETA" if p.len() >= 2 => {
                    api.push("OmniLensDistortionFthetaAPI");
                    let mut poly = floats("polynomial").ok_or("FTHETA without its polynomial")?;
                    if poly.len() > 5 {
                        return Err(format!(
                            "FTHETA polynomial of degree {}: the schema holds k0…k4",
                            poly.len() - 1
                        ));
                    }
                    poly.resize(5, 0.0);
                    put("ftheta", &["k0", "k1", "k2", "k3", "k4"], &poly);
                    put(
                        "ftheta",
                        &["nominalWidth", "nominalHeight"],
                        &[f64::from(res[0]), f64::from(res[1])],
                    );
                    attr(format!(
                        "float2 {ns}:ftheta:opticalCenter = ({}, {})",
                        num(p[0]),
                        num(p[1])
                    ));
                    let max_angle = p.get(2).copied().unwrap_or(std::f64::consts::PI);
                    attr(format!(
                        "float {ns}:ftheta:maxFov = {}",
                        num(2.0 * max_angle.to_degrees())
                    ));
                    attr(format!("token {ns}:model = \"ftheta\""));
                }
                other => {
                    return Err(format!(
                        "CalibratedCamera model {other}: no OmniLensDistortion schema holds it \
                         (OPENCV_PINHOLE, KANNALA_BRANDT/OPENCV_FISHEYE and FTHETA do)"
                    ));
                }
            }
            if p.len() >= 2 {
                // The gate of the undistorted pinhole with the same focal length in pixels.
                let fx = if model == "FTHETA" { 0.0 } else { p[0] };
                if fx > 0.0 {
                    attr(format!("float focalLength = {focal}"));
                    attr(format!(
                        "float horizontalAperture = {}",
                        num(focal * f64::from(res[0]) / fx)
                    ));
                    attr(format!(
                        "float verticalAperture = {}",
                        num(focal * f64::from(res[1]) / p[1])
                    ));
                }
            }
        }
        other => {
            return Err(format!(
                "projection {other}: a USD camera cannot describe it (perspective, orthographic and \
                 CalibratedCamera's OpenCV, fisheye and f-theta models can)"
            ));
        }
    }
    let (near, far) = scene.camera.clipping;
    let far = if far.is_finite() { f64::from(far) } else { 1.0e6 };
    attr(format!(
        "float2 clippingRange = ({}, {})",
        num(f64::from(near)),
        num(far)
    ));
    let (open, close) = scene.camera.shutter;
    attr(format!("double shutter:open = {}", num(f64::from(open))));
    attr(format!("double shutter:close = {}", num(f64::from(close))));
    let w = scene
        .camera
        .world_to_camera
        .first()
        .map_or(Mat4::IDENTITY, |m| Mat4::from_cols_array_2d(&m.world_to_camera.0));
    let m = flip_z() * w.as_dmat4();
    if m.determinant().abs() < 1e-300 {
        return Err("the camera's world-to-camera transform is singular".into());
    }
    attr(format!(
        "matrix4d xformOp:transform = {}",
        usd_matrix(m.inverse())
    ));
    attr("uniform token[] xformOpOrder = [\"xformOp:transform\"]".into());
    let pairs = lines
        .into_iter()
        .map(|l| {
            let (decl, value) = l.split_once(" = ").unwrap_or((l.as_str(), ""));
            (decl.to_string(), value.to_string())
        })
        .collect();
    Ok((pairs, api))
}

/// A column-vector matrix in USD's row-vector spelling `( (..), (..), (..), (..) )`.
fn usd_matrix(m: DMat4) -> String {
    let a = m.to_cols_array();
    let rows: Vec<String> = (0..4)
        .map(|i| {
            format!(
                "({}, {}, {}, {})",
                num(a[4 * i]),
                num(a[4 * i + 1]),
                num(a[4 * i + 2]),
                num(a[4 * i + 3])
            )
        })
        .collect();
    format!("( {} )", rows.join(", "))
}

/// A number written to round-trip (shortest form that reads back to the same f64).
fn num(v: f64) -> String {
    if v == 0.0 { "0".into() } else { format!("{v}") }
}
