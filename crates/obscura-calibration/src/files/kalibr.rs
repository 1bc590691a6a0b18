//! Kalibr's `camchain.yaml` (and the single-camera `camera.yaml` of the same layout): a mapping of
//! cameras `cam0`, `cam1`, … each with `camera_model`, `intrinsics`, `distortion_model`,
//! `distortion_coeffs` and `resolution`. The chain's extrinsics (`T_cn_cnm1`, each camera's pose from the
//! previous one) are read apart, by [`chain`], for camera rigs.
//!
//! Kalibr's intrinsics vectors are reordered into the target model's order:
//!
//! | Kalibr | intrinsics, distortion | model | params |
//! |---|---|---|---|
//! | pinhole-none | fu fv pu pv | `PINHOLE` | fx fy cx cy |
//! | pinhole-radtan | fu fv pu pv; k1 k2 r1 r2 | `OPENCV` | fx fy cx cy k1 k2 p1 p2 |
//! | pinhole-equi | fu fv pu pv; k1 k2 k3 k4 | `OPENCV_FISHEYE` | fx fy cx cy k1 k2 k3 k4 |
//! | pinhole-fov | fu fv pu pv; w | `FOV` | fx fy cx cy omega |
//! | omni-radtan | xi fu fv pu pv; k1 k2 r1 r2 | `OPENCV_OMNIDIR` | fx fy cx cy s=0 xi k1 k2 p1 p2 |
//! | omni-none | xi fu fv pu pv | `OPENCV_OMNIDIR` | fx fy cx cy 0 xi 0 0 0 0 |
//! | ds-none | xi alpha fu fv pu pv | `DOUBLE_SPHERE` | fx fy cx cy xi alpha |
//! | eucm-none | alpha beta fu fv pu pv | `EUCM` | fx fy cx cy alpha beta (COLMAP's order) |
//!
//! Kalibr's radtan is OpenCV's k1 k2 p1 p2 on the normalised plane, its equidistant model OpenCV's
//! fisheye, its FOV model Devernay–Faugeras as COLMAP's `FOV`, and its omni camera Mei's unified model
//! followed by radtan, as OpenCV's omnidir. Kalibr (aslam-cv) measures pixels as OpenCV does, centres
//! at integer coordinates: `pixelConvention` `opencv`.

use super::tree::Node;
use super::{Calibration, CalibrationFileError, FileFormat, Number, Src, choose_camera};

/// One camera of a Kalibr camchain with its extrinsics, in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainCamera {
    /// The entry's key (`cam0`, `cam1`, …).
    pub id: String,
    /// `T_cn_cnm1`: the 4×4 transform (rows) taking a point in the previous camera's frame to this
    /// one's (Kalibr's cameras are OpenCV's: +X right, +Y down, looking down +Z); `None` for the first
    /// camera, whose frame is the chain's.
    pub t_cn_cnm1: Option<[[f64; 4]; 4]>,
    /// The 1-based line of the entry (of `T_cn_cnm1` when present).
    pub line: usize,
}

/// Reads the cameras of a Kalibr camchain with their `T_cn_cnm1` (every camera after the first must
/// have one: a 4×4 list of rows whose last row is `0 0 0 1`).
///
/// # Errors
/// A [`CalibrationFileError`] naming the file, the line and the key: not a camchain, a camera after
/// the first without `T_cn_cnm1`, a matrix that is not 4×4 numbers or not rigid-shaped.
pub fn chain(text: &str, file: &str) -> Result<Vec<ChainCamera>, CalibrationFileError> {
    let src = Src { file };
    let root = super::tree::parse(&src, text)?;
    if !looks_like(&root) {
        return Err(src.whole(
            "not a Kalibr camchain: expected cam0: { camera_model, intrinsics, distortion_model, distortion_coeffs, resolution }, cam1: { …, T_cn_cnm1 }",
        ));
    }
    let mut out = Vec::new();
    for (id, cam) in root
        .entries()
        .unwrap_or_default()
        .iter()
        .filter(|(_, v)| is_camera(v))
    {
        let Some(node) = cam.get("T_cn_cnm1") else {
            if !out.is_empty() {
                return Err(src.err(
                    cam.line,
                    format!("{id}.T_cn_cnm1: missing; every camera after the first needs its pose from the previous one (a 4x4 matrix)"),
                ));
            }
            out.push(ChainCamera {
                id: id.clone(),
                t_cn_cnm1: None,
                line: cam.line,
            });
            continue;
        };
        let key = format!("{id}.T_cn_cnm1");
        let rows = node.items().filter(|r| r.len() == 4).ok_or_else(|| {
            src.err(
                node.line,
                format!(
                    "{key}: expected a 4x4 matrix (four rows of four numbers), got {}",
                    node.describe()
                ),
            )
        })?;
        let mut m = [[0.0; 4]; 4];
        for (r, row) in rows.iter().enumerate() {
            let items = row.items().filter(|i| i.len() == 4).ok_or_else(|| {
                src.err(
                    row.line,
                    format!(
                        "{key}: row {}: expected four numbers, got {}",
                        r + 1,
                        row.describe()
                    ),
                )
            })?;
            for (c, n) in src.numbers(items, &key)?.iter().enumerate() {
                m[r][c] = n.value;
            }
        }
        let last = m[3];
        if last
            .iter()
            .zip([0.0, 0.0, 0.0, 1.0])
            .any(|(a, b)| (a - b).abs() > 1e-9)
        {
            return Err(src.err(
                node.line,
                format!("{key}: the last row is {last:?}; expected [0, 0, 0, 1] (a rigid transform)"),
            ));
        }
        if out.is_empty() {
            return Err(src.err(
                node.line,
                format!("{key}: the first camera of the chain has no previous camera; expected no T_cn_cnm1"),
            ));
        }
        out.push(ChainCamera {
            id: id.clone(),
            t_cn_cnm1: Some(m),
            line: node.line,
        });
    }
    Ok(out)
}

/// True when `root` is a mapping holding at least one camera entry (a mapping with `camera_model` or
/// `intrinsics`).
pub(crate) fn looks_like(root: &Node) -> bool {
    root.entries()
        .is_some_and(|entries| entries.iter().any(|(_, v)| is_camera(v)))
}

fn is_camera(node: &Node) -> bool {
    node.get("camera_model").is_some() || node.get("intrinsics").is_some()
}

fn text_field<'a>(
    src: &Src<'_>,
    cam: &'a Node,
    id: &str,
    key: &str,
    what: &str,
) -> Result<(&'a str, usize), CalibrationFileError> {
    let node = cam
        .get(key)
        .ok_or_else(|| src.err(cam.line, format!("{id}.{key}: missing; expected {what}")))?;
    match node.text() {
        Some(t) => Ok((t.trim(), node.line)),
        None => Err(src.err(
            node.line,
            format!("{id}.{key}: expected {what}, got {}", node.describe()),
        )),
    }
}

fn list_field(
    src: &Src<'_>,
    cam: &Node,
    id: &str,
    key: &str,
    what: &str,
) -> Result<(Vec<Number>, usize), CalibrationFileError> {
    let node = cam
        .get(key)
        .ok_or_else(|| src.err(cam.line, format!("{id}.{key}: missing; expected {what}")))?;
    let items = node.items().ok_or_else(|| {
        src.err(
            node.line,
            format!("{id}.{key}: expected a list ({what}), got {}", node.describe()),
        )
    })?;
    let values = src.numbers(items, &format!("{id}.{key}"))?;
    Ok((values, node.line))
}

/// A zero written by us (for a parameter Kalibr's model lacks), attributed to `line`.
fn zero(line: usize) -> Number {
    Number {
        text: "0".into(),
        value: 0.0,
        line,
    }
}

/// Checks the list `values` (read at its line) holds one value per name, else says whose list it
/// is and what it should hold.
fn expect_names(
    src: &Src<'_>,
    (values, line): (&[Number], usize),
    names: &[&str],
    field: &str,
    whose: &str,
    noun: &str,
) -> Result<(), CalibrationFileError> {
    if values.len() == names.len() {
        return Ok(());
    }
    Err(src.err(
        line,
        format!(
            "{field}: {whose} has {} {noun} [{}], got {}",
            names.len(),
            names.join(" "),
            values.len()
        ),
    ))
}

/// A camera entry's model fields as read, for the translation into a model.
struct Entry<'a> {
    id: &'a str,
    camera_model: &'a str,
    model_line: usize,
    /// Kalibr's distortion model, `equi` spelled out.
    distortion: &'a str,
    dist_line: usize,
    intr: Vec<Number>,
    intr_line: usize,
    /// The distortion coefficients and their line.
    coeffs: (Vec<Number>, usize),
}

impl Entry<'_> {
    fn expect_intr(&self, src: &Src<'_>, names: &[&str]) -> Result<(), CalibrationFileError> {
        let Entry { id, camera_model, .. } = self;
        let (field, whose) = (
            format!("{id}.intrinsics"),
            format!("a Kalibr {camera_model} camera"),
        );
        expect_names(
            src,
            (&self.intr, self.intr_line),
            names,
            &field,
            &whose,
            "intrinsics",
        )
    }

    fn expect_coeffs(&self, src: &Src<'_>, names: &[&str]) -> Result<(), CalibrationFileError> {
        let Entry { id, distortion, .. } = self;
        let (field, whose) = (
            format!("{id}.distortion_coeffs"),
            format!("Kalibr's {distortion} distortion"),
        );
        let (coeffs, line) = &self.coeffs;
        expect_names(src, (coeffs, *line), names, &field, &whose, "coefficients")
    }

    fn unsupported(&self, src: &Src<'_>) -> CalibrationFileError {
        let Entry {
            id,
            camera_model,
            distortion,
            ..
        } = self;
        src.err(
            if *distortion == "none" {
                self.model_line
            } else {
                self.dist_line
            },
            format!(
                "{id}: Kalibr's {camera_model}-{distortion} is not supported; supported: pinhole-none, \
                 pinhole-radtan, pinhole-equi, pinhole-fov, omni-none, omni-radtan, ds-none, eucm-none"
            ),
        )
    }

    /// The model and its parameters in its order, from Kalibr's intrinsics and coefficients (see
    /// the module's table).
    fn model(&self, src: &Src<'_>) -> Result<(&'static str, Vec<Number>), CalibrationFileError> {
        let (id, distortion) = (self.id, self.distortion);
        let (intr_line, dist_line) = (self.intr_line, self.dist_line);
        let expect_intr = |names: &[&str]| self.expect_intr(src, names);
        let expect_coeffs = |names: &[&str]| self.expect_coeffs(src, names);
        let unsupported = || self.unsupported(src);
        let i = |k: usize| self.intr[k].clone();
        let (model, mut params) = match self.camera_model {
            "pinhole" => {
                expect_intr(&["fu", "fv", "pu", "pv"])?;
                let base = vec![i(0), i(1), i(2), i(3)];
                match distortion {
                    "none" => {
                        expect_coeffs(&[])?;
                        ("PINHOLE", base)
                    }
                    "radtan" => {
                        expect_coeffs(&["k1", "k2", "r1", "r2"])?;
                        ("OPENCV", base)
                    }
                    "equidistant" => {
                        expect_coeffs(&["k1", "k2", "k3", "k4"])?;
                        ("OPENCV_FISHEYE", base)
                    }
                    "fov" => {
                        expect_coeffs(&["w"])?;
                        ("FOV", base)
                    }
                    _ => return Err(unsupported()),
                }
            }
            "omni" => {
                expect_intr(&["xi", "fu", "fv", "pu", "pv"])?;
                let base = vec![i(1), i(2), i(3), i(4), zero(intr_line), i(0)];
                match distortion {
                    "none" => {
                        expect_coeffs(&[])?;
                        let mut p = base;
                        p.extend((0..4).map(|_| zero(dist_line)));
                        ("OPENCV_OMNIDIR", p)
                    }
                    "radtan" => {
                        expect_coeffs(&["k1", "k2", "r1", "r2"])?;
                        ("OPENCV_OMNIDIR", base)
                    }
                    _ => return Err(unsupported()),
                }
            }
            // Both models lead with their two shape parameters, which the models' order puts last.
            "ds" | "eucm" => {
                let (model, [s0, s1]) = if self.camera_model == "ds" {
                    ("DOUBLE_SPHERE", ["xi", "alpha"])
                } else {
                    ("EUCM", ["alpha", "beta"])
                };
                expect_intr(&[s0, s1, "fu", "fv", "pu", "pv"])?;
                if distortion != "none" {
                    return Err(unsupported());
                }
                expect_coeffs(&[])?;
                (model, vec![i(2), i(3), i(4), i(5), i(0), i(1)])
            }
            other => {
                return Err(src.err(
                    self.model_line,
                    format!("{id}.camera_model: unknown Kalibr camera model \"{other}\"; expected pinhole, omni, ds or eucm"),
                ));
            }
        };
        if !matches!(distortion, "none") {
            params.extend(self.coeffs.0.iter().cloned());
        }
        Ok((model, params))
    }
}

/// Reads the camera `camera` (a key such as `cam1`; the first camera when `None`) of a camchain.
///
/// # Errors
/// The line and field at fault: a missing field, an unknown or unsupported camera/distortion model
/// pair (with the supported ones), an intrinsics or distortion vector of the wrong length (with the
/// expected names), a resolution that is not two positive integers, or no camera `camera`.
pub(crate) fn read(
    src: &Src<'_>,
    root: &Node,
    camera: Option<&str>,
) -> Result<Calibration, CalibrationFileError> {
    let entries = root.entries().unwrap_or_default();
    let cams: Vec<&(String, Node)> = entries.iter().filter(|(_, v)| is_camera(v)).collect();
    let ids: Vec<String> = cams.iter().map(|(k, _)| k.clone()).collect();
    let (index, by_default) = choose_camera(src, "Kalibr camchain", &ids, camera)?;
    let (id, cam) = cams[index];
    let (camera_model, model_line) = text_field(src, cam, id, "camera_model", "pinhole, omni, ds or eucm")?;
    let (distortion, dist_line) = match cam.get("distortion_model") {
        None => ("none", cam.line),
        Some(_) => text_field(
            src,
            cam,
            id,
            "distortion_model",
            "radtan, equidistant, fov or none",
        )?,
    };
    let (intr, intr_line) = list_field(src, cam, id, "intrinsics", "the intrinsics vector")?;
    let coeffs = match cam.get("distortion_coeffs") {
        None => (Vec::new(), dist_line),
        Some(_) => list_field(src, cam, id, "distortion_coeffs", "the distortion coefficients")?,
    };
    let (res, res_line) = list_field(src, cam, id, "resolution", "[width, height] in pixels")?;
    if res.len() != 2 {
        return Err(src.err(
            res_line,
            format!(
                "{id}.resolution: expected [width, height], got {} values",
                res.len()
            ),
        ));
    }
    let width = src.size(&res[0].text, res[0].line, &format!("{id}.resolution width"))?;
    let height = src.size(&res[1].text, res[1].line, &format!("{id}.resolution height"))?;

    let entry = Entry {
        id,
        camera_model,
        model_line,
        distortion: match distortion {
            "equi" | "equidistant" => "equidistant",
            other => other,
        },
        dist_line,
        intr,
        intr_line,
        coeffs,
    };
    let (model, params) = entry.model(src)?;
    let distortion = entry.distortion;
    let mut notes = vec![format!(
        "Kalibr {camera_model}-{distortion} read as {model}, intrinsics reordered to the model's order"
    )];
    if cam
        .entries()
        .is_some_and(|e| e.iter().any(|(k, _)| k.starts_with("T_")))
    {
        notes.push(format!(
            "{id}: extrinsics (T_*) are not part of the projection and were ignored"
        ));
    }
    Ok(Calibration {
        camera: Some(id.clone()),
        cameras: ids,
        first_by_default: by_default,
        notes,
        ..src.calibration(FileFormat::Kalibr, cam.line, model, [width, height], params)
    })
}
