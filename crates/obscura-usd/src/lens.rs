//! Distorted cameras: NVIDIA's `OmniLensDistortion*API` schemas (and the older
//! `cameraProjectionType`/`ftheta*` attributes) onto Obscura's `CalibratedCamera`.
//!
//! When a lens-distortion schema is applied its intrinsics replace the camera's apertures and focal
//! length for the projection (NVIDIA's rule); depth of field still uses `fStop`/`focusDistance`.
//! Pixel positions are NVIDIA's: pixel indices at pixel centres, i.e. OpenCV's convention.
//!
//! | `omni:lensdistortion:model` | CalibratedCamera | mapping |
//! |---|---|---|
//! | `opencvPinhole` | `OPENCV_PINHOLE` fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4 | `x' = x·(1+k1r²+k2r⁴+k3r⁶)/(1+k4r²+k5r⁴+k6r⁶) + 2p1xy + p2(r²+2x²) + s1r² + s2r⁴`, likewise y with p1/p2 swapped and s3, s4; `u = fx·x' + cx` |
//! | `opencvFisheye` | `KANNALA_BRANDT` fx fy cx cy k1 k2 k3 k4 | `θd = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸)`, `u = fx·θd·x/r + cx` |
//! | `ftheta` | `FTHETA` cx cy maxAngle, polynomial k0 … k4 | `θ = k0 + k1·ρ + k2·ρ² + k3·ρ³ + k4·ρ⁴` (ρ = pixel distance from `opticalCenter`), θ ≤ maxFov/2 |
//! | legacy `cameraProjectionType = "fisheyePolynomial"` | `FTHETA` | `fthetaCx/Cy`, `fthetaPolyA…E` as k0…k4, `fthetaMaxFov` |
//!
//! The image size is the schema's `imageSize` (OpenCV models) or `nominalWidth × nominalHeight`.
//! The intrinsics (image size, focal lengths, centre) must be authored: a missing one is an error
//! naming the prim and the attribute, never the schema's example value. Distortion coefficients
//! default to 0 (no distortion), their schema fallback. `kannalaBrandtK3`, `radTanThinPrism` and
//! `lut` are recognised and refused with a message: NVIDIA's documentation gives their attributes but
//! not the focal-length convention that turns them into rays, so no exact mapping can be stated.

use obscura_sdk::{ParamList, ParamValue};

use crate::UsdError;
use crate::values::{Time, Values};

/// The calibrated camera a distorted USD camera renders through.
#[derive(Debug, Clone, PartialEq)]
pub struct LensModel {
    /// The schema (`OmniLensDistortionOpenCvPinholeAPI`, …, or `cameraProjectionType`).
    pub schema: String,
    /// CalibratedCamera's `model`.
    pub model: &'static str,
    /// CalibratedCamera's `params`.
    pub params: Vec<f64>,
    /// CalibratedCamera's `polynomial` (f-theta).
    pub polynomial: Vec<f64>,
    /// The calibration image size.
    pub resolution: [u32; 2],
}

impl LensModel {
    /// CalibratedCamera's parameter list.
    #[must_use]
    pub fn param_list(&self, origin: &str) -> ParamList {
        let mut list = ParamList::new();
        let f = |v: &[f64]| ParamValue::Floats(v.iter().map(|&x| x as f32).collect());
        let o = Some(origin.to_string());
        // The declarations are CalibratedCamera's own; pushing them cannot fail.
        let _ = list.push(
            "string model",
            ParamValue::Strings(vec![self.model.into()]),
            o.clone(),
        );
        let _ = list.push("float[] params", f(&self.params), o.clone());
        if !self.polynomial.is_empty() {
            let _ = list.push("float[] polynomial", f(&self.polynomial), o.clone());
        }
        let _ = list.push(
            "int[2] resolution",
            ParamValue::Ints(vec![self.resolution[0] as i32, self.resolution[1] as i32]),
            o.clone(),
        );
        let _ = list.push(
            "string pixelConvention",
            ParamValue::Strings(vec!["opencv".into()]),
            o,
        );
        list
    }
}

const NS: &str = "omni:lensdistortion:";

/// The applied schema's API name of each model token.
pub const MODELS: [(&str, &str); 6] = [
    ("opencvPinhole", "OmniLensDistortionOpenCvPinholeAPI"),
    ("opencvFisheye", "OmniLensDistortionOpenCvFisheyeAPI"),
    ("ftheta", "OmniLensDistortionFthetaAPI"),
    ("kannalaBrandtK3", "OmniLensDistortionKannalaBrandtK3API"),
    ("radTanThinPrism", "OmniLensDistortionRadTanThinPrismAPI"),
    ("lut", "OmniLensDistortionLutAPI"),
];

/// The lens model of camera `prim` at `time`, `None` for an undistorted camera.
pub(crate) fn read(
    values: &Values<'_>,
    prim: &str,
    time: Time,
    api_schemas: &[String],
) -> Result<Option<LensModel>, UsdError> {
    let token = values.token_opt(prim, &format!("{NS}model"), time)?;
    let applied = MODELS
        .iter()
        .find(|(_, api)| api_schemas.iter().any(|s| s == api));
    let model = match (token.as_deref(), applied) {
        (Some(t), _) => match MODELS.iter().find(|(m, _)| *m == t) {
            Some(m) => *m,
            None => {
                return Err(values.error(
                    prim,
                    &format!("{NS}model"),
                    format!(
                        "unknown lens-distortion model {t:?}; expected one of {}",
                        MODELS.map(|m| m.0).join(", ")
                    ),
                ));
            }
        },
        (None, Some(m)) => *m,
        (None, None) => return legacy(values, prim, time),
    };
    let (name, api) = model;
    let attr = |a: &str| format!("{NS}{name}:{a}");
    let need = |a: &str, what: &str| -> Result<f64, UsdError> {
        values.real_opt(prim, &attr(a), time)?.ok_or_else(|| {
            UsdError::at(
                values.file,
                prim,
                format!(
                    "{api}: attribute '{}' is not authored; expected a float ({what})",
                    attr(a)
                ),
            )
        })
    };
    let coef = |a: &str| values.real(prim, &attr(a), time, 0.0);
    let size = |values: &Values<'_>| -> Result<[u32; 2], UsdError> {
        let r = values
            .reals_opt(prim, &attr("imageSize"), time, 2)?
            .ok_or_else(|| {
                UsdError::at(
                    values.file,
                    prim,
                    format!(
                        "{api}: attribute '{}' is not authored; expected an int2 (pixels)",
                        attr("imageSize")
                    ),
                )
            })?;
        pixels(values, prim, &attr("imageSize"), r[0], r[1])
    };
    match name {
        "opencvPinhole" => {
            let mut params = vec![
                need("fx", "pixels")?,
                need("fy", "pixels")?,
                need("cx", "pixels")?,
                need("cy", "pixels")?,
            ];
            for c in [
                "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4",
            ] {
                params.push(coef(c)?);
            }
            Ok(Some(LensModel {
                schema: api.into(),
                model: "OPENCV_PINHOLE",
                params,
                polynomial: Vec::new(),
                resolution: size(values)?,
            }))
        }
        "opencvFisheye" => {
            let mut params = vec![
                need("fx", "pixels")?,
                need("fy", "pixels")?,
                need("cx", "pixels")?,
                need("cy", "pixels")?,
            ];
            for c in ["k1", "k2", "k3", "k4"] {
                params.push(coef(c)?);
            }
            Ok(Some(LensModel {
                schema: api.into(),
                model: "KANNALA_BRANDT",
                params,
                polynomial: Vec::new(),
                resolution: size(values)?,
            }))
        }
        "ftheta" => {
            let w = need("nominalWidth", "pixels")?;
            let h = need("nominalHeight", "pixels")?;
            let centre = values
                .reals_opt(prim, &attr("opticalCenter"), time, 2)?
                .ok_or_else(|| {
                    UsdError::at(
                        values.file,
                        prim,
                        format!(
                            "{api}: attribute '{}' is not authored; expected a float2 (pixels)",
                            attr("opticalCenter")
                        ),
                    )
                })?;
            let max_fov = need("maxFov", "degrees")?;
            let polynomial = ["k0", "k1", "k2", "k3", "k4"]
                .iter()
                .map(|c| coef(c))
                .collect::<Result<Vec<_>, _>>()?;
            Ok(Some(LensModel {
                schema: api.into(),
                model: "FTHETA",
                params: vec![centre[0], centre[1], (max_fov / 2.0).to_radians()],
                polynomial,
                resolution: pixels(values, prim, &attr("nominalWidth"), w, h)?,
            }))
        }
        other => Err(UsdError::at(
            values.file,
            prim,
            format!(
                "{api} ({NS}model = {other:?}) is not supported: NVIDIA documents its attributes but not the \
                 focal-length convention that makes them rays; supported are opencvPinhole, opencvFisheye and ftheta"
            ),
        )),
    }
}

/// Isaac Sim's attributes before the schemas (`cameraProjectionType = "fisheyePolynomial"`).
fn legacy(values: &Values<'_>, prim: &str, time: Time) -> Result<Option<LensModel>, UsdError> {
    let kind = values.token_opt(prim, "cameraProjectionType", time)?;
    match kind.as_deref() {
        None | Some("pinhole") => Ok(None),
        Some("fisheyePolynomial") => {
            let need = |a: &str| -> Result<f64, UsdError> {
                values.real_opt(prim, a, time)?.ok_or_else(|| {
                    UsdError::at(
                        values.file,
                        prim,
                        format!("cameraProjectionType \"fisheyePolynomial\": attribute '{a}' is not authored; expected a float"),
                    )
                })
            };
            let (w, h) = (need("fthetaWidth")?, need("fthetaHeight")?);
            let polynomial = [
                "fthetaPolyA",
                "fthetaPolyB",
                "fthetaPolyC",
                "fthetaPolyD",
                "fthetaPolyE",
            ]
            .iter()
            .map(|a| values.real(prim, a, time, 0.0))
            .collect::<Result<Vec<_>, _>>()?;
            Ok(Some(LensModel {
                schema: "cameraProjectionType".into(),
                model: "FTHETA",
                params: vec![
                    need("fthetaCx")?,
                    need("fthetaCy")?,
                    (need("fthetaMaxFov")? / 2.0).to_radians(),
                ],
                polynomial,
                resolution: pixels(values, prim, "fthetaWidth", w, h)?,
            }))
        }
        Some(other) => Err(values.error(
            prim,
            "cameraProjectionType",
            format!("unsupported projection type {other:?}; expected pinhole or fisheyePolynomial"),
        )),
    }
}

fn pixels(values: &Values<'_>, prim: &str, name: &str, w: f64, h: f64) -> Result<[u32; 2], UsdError> {
    let ok = |v: f64| (1.0..=65536.0).contains(&v) && v.fract() == 0.0;
    if ok(w) && ok(h) {
        Ok([w as u32, h as u32])
    } else {
        Err(values.error(
            prim,
            name,
            format!("expected a whole image size in pixels, found {w} x {h}"),
        ))
    }
}
