//! A lens known only as an ST-map: each plate pixel's ray is the undistorted pinhole's ray through
//! the position the map gives.
//!
//! The map is the redistort map of Nuke's convention (what `obscura stmap --from-calibration LENS
//! --from-undistorted --to-calibration LENS` writes, and what a studio hands over for a lens it
//! describes only as a map): an image the size of the **plate** (`W × H`) whose red and green
//! channels are, per plate pixel, the position `(s, t) ∈ [0, 1]²` to read in the **undistorted**
//! image (`W_u × H_u`), `(0, 0)` its bottom-left corner, t up. With the map's samples at the plate's
//! pixel centres `(i + ½, j + ½)` (raster, y down) and the undistorted image's pinhole
//! `[f_x, f_y, c_x, c_y]` on its own raster (COLMAP's `PINHOLE`, pixel centres at `+½`):
//!
//! ```text
//! (S, T)(x, y) = bilinear interpolation of the samples at (x − ½, y − ½)   (linear extrapolation
//!                in the half-pixel border, so the whole frame [0, W] × [0, H] is covered)
//! q            = (W_u · S(x, y),  H_u · (1 − T(x, y)))          undistorted raster position
//! ray(x, y)    = ((q_x − c_x)/f_x,  (q_y − c_y)/f_y,  1)         camera space, y down, z forward
//! ```
//!
//! The inverse (a direction `d` → plate position) projects `d` with the pinhole to `q`, hence the
//! target `(s*, t*) = (q_x/W_u, 1 − q_y/H_u)`, and solves `(S, T)(x, y) = (s*, t*)` by Newton's
//! method on the piecewise-bilinear map (the Jacobian of the cell the iterate is in, steps halved
//! while the residual does not fall), started from the pinhole position `q·(W/W_u, H/H_u)` and,
//! if that fails, from the nearest sample of a coarse grid. A solution is accepted only when its
//! residual is below 1e-9 undistorted pixels and it lies inside the frame; otherwise `None`.
//!
//! # The projection
//!
//! [`StMapCamera`] (made by [`StMapCameraFactory`], name [`PROJECTION`]; a host registers it) takes
//! `string map` (the EXR, read by [`read_stmap_exr`]: channels R and G), `float[4] pinhole`
//! (`f_x f_y c_x c_y` of the undistorted image, its pixels) and `int[2] undistortedResolution`
//! (`W_u H_u`, default the map's size: the undistorted image of `obscura stmap --from-undistorted`
//! is the plate's size, s and t running past [0, 1] into the overscan). The plate spans the screen
//! window as `CalibratedCamera`'s calibration image does.
//!
//! # What a map must be
//!
//! [`StMapLens::new`] refuses (naming the pixel) a map whose size does not match its samples, a
//! sample that is not finite, and a map that is not one-to-one: `s` must grow left to right along
//! every row, `t` must fall from top to bottom along every column, and the Jacobian
//! `∂(s, t)/∂(x, y)` (forward differences) must have a negative determinant at every sample, so that
//! the bilinear map neither folds nor flips and its inverse is unique.

use crate::projection::angle_between as angle;

/// A lens given as an ST-map into its undistorted pinhole (see the module doc for the mapping).
#[derive(Debug, Clone, PartialEq)]
pub struct StMapLens {
    width: usize,
    height: usize,
    s: Vec<f64>,
    t: Vec<f64>,
    undistorted: [f64; 2],
    pinhole: [f64; 4],
}

/// Newton steps before giving up.
const MAX_STEPS: usize = 60;
/// Accepted residual, undistorted pixels.
const TOLERANCE_PX: f64 = 1e-9;
/// Seeds per axis of the fallback grid.
const SEED_GRID: usize = 24;

impl StMapLens {
    /// A lens from the map's `width × height` samples `s` and `t` (row by row from the top, as the
    /// EXR's R and G), the undistorted image's size `[W_u, H_u]` and its pinhole `[f_x, f_y, c_x,
    /// c_y]` on that image's raster.
    ///
    /// # Errors
    /// A message naming what is wrong and where (the pixel's column and row): see the module doc.
    pub fn new(
        width: usize,
        height: usize,
        s: &[f32],
        t: &[f32],
        undistorted: [f64; 2],
        pinhole: [f64; 4],
    ) -> Result<StMapLens, String> {
        if width < 2 || height < 2 {
            return Err(format!(
                "an ST-map needs at least 2x2 pixels, got {width}x{height}"
            ));
        }
        let n = width * height;
        if s.len() != n || t.len() != n {
            return Err(format!(
                "a {width}x{height} ST-map needs {n} s and t samples, got {} and {}",
                s.len(),
                t.len()
            ));
        }
        if !undistorted.iter().all(|v| v.is_finite() && *v > 0.0) {
            return Err(format!(
                "the undistorted image size must be positive, got {}x{}",
                undistorted[0], undistorted[1]
            ));
        }
        if !(pinhole[0] > 0.0 && pinhole[1] > 0.0 && pinhole.iter().all(|v| v.is_finite())) {
            return Err(format!(
                "the undistorted pinhole needs finite focal lengths > 0 (fx fy cx cy), got {pinhole:?}"
            ));
        }
        for (i, (&a, &b)) in s.iter().zip(t).enumerate() {
            if !(a.is_finite() && b.is_finite()) {
                return Err(format!(
                    "pixel {},{}: (s, t) = ({a}, {b}); an ST-map's R and G must be finite",
                    i % width,
                    i / width
                ));
            }
        }
        let at = |v: &[f32], x: usize, y: usize| f64::from(v[y * width + x]);
        for y in 0..height {
            for x in 0..width {
                let (xn, yn) = (x.min(width - 2), y.min(height - 2));
                let ds_dx = at(s, xn + 1, y) - at(s, xn, y);
                let dt_dy = at(t, x, yn + 1) - at(t, x, yn);
                if ds_dx <= 0.0 {
                    return Err(format!(
                        "pixel {},{y}: s does not grow left to right ({} then {}); an ST-map's R must \
                         increase along every row (the map must be one-to-one)",
                        xn + 1,
                        at(s, xn, y),
                        at(s, xn + 1, y)
                    ));
                }
                if dt_dy >= 0.0 {
                    return Err(format!(
                        "pixel {x},{}: t does not fall from top to bottom ({} then {}); an ST-map's G \
                         must decrease down every column (t is up)",
                        yn + 1,
                        at(t, x, yn),
                        at(t, x, yn + 1)
                    ));
                }
                let ds_dy = at(s, x, yn + 1) - at(s, x, yn);
                let dt_dx = at(t, xn + 1, y) - at(t, xn, y);
                if ds_dx * dt_dy - ds_dy * dt_dx >= 0.0 {
                    return Err(format!(
                        "pixel {x},{y}: the map folds (Jacobian determinant of (s, t) by (x, y) is not \
                         negative); an ST-map must be one-to-one"
                    ));
                }
            }
        }
        Ok(StMapLens {
            width,
            height,
            s: s.iter().map(|&v| f64::from(v)).collect(),
            t: t.iter().map(|&v| f64::from(v)).collect(),
            undistorted,
            pinhole,
        })
    }

    /// The plate's size `(W, H)`, the map's.
    #[must_use]
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// `(S, T)` at raster `(x, y)` with its Jacobian `[[∂S/∂x, ∂S/∂y], [∂T/∂x, ∂T/∂y]]`.
    fn st(&self, p: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
        let (u, v) = (p[0] - 0.5, p[1] - 0.5);
        let i = (u.floor().max(0.0) as usize).min(self.width - 2);
        let j = (v.floor().max(0.0) as usize).min(self.height - 2);
        let (fx, fy) = (u - i as f64, v - j as f64);
        let k = j * self.width + i;
        let w = self.width;
        let eval = |c: &[f64]| {
            let (a, b, c0, d) = (c[k], c[k + 1], c[k + w], c[k + w + 1]);
            let val = a + (b - a) * fx + (c0 - a) * fy + (a - b - c0 + d) * fx * fy;
            let dx = (b - a) + (a - b - c0 + d) * fy;
            let dy = (c0 - a) + (a - b - c0 + d) * fx;
            (val, [dx, dy])
        };
        let (sv, sd) = eval(&self.s);
        let (tv, td) = eval(&self.t);
        ([sv, tv], [sd, td])
    }

    /// The undistorted raster position the map gives for plate raster position `p` (y down).
    #[must_use]
    pub fn undistort(&self, p: [f64; 2]) -> [f64; 2] {
        let ([s, t], _) = self.st(p);
        [self.undistorted[0] * s, self.undistorted[1] * (1.0 - t)]
    }

    /// The ray (OpenCV camera space: y down, z forward, not unit) of plate raster position `p`, or
    /// `None` outside the frame `[0, W] × [0, H]`.
    #[must_use]
    pub fn pixel_to_ray(&self, p: [f64; 2]) -> Option<[f64; 3]> {
        if !self.inside(p) {
            return None;
        }
        let q = self.undistort(p);
        let [fx, fy, cx, cy] = self.pinhole;
        Some([(q[0] - cx) / fx, (q[1] - cy) / fy, 1.0])
    }

    fn inside(&self, p: [f64; 2]) -> bool {
        (0.0..=self.width as f64).contains(&p[0]) && (0.0..=self.height as f64).contains(&p[1])
    }

    /// The plate raster position whose ray is `d` (OpenCV camera space, any length), or `None` when
    /// `d` does not point forward, its position lies outside the frame, or Newton does not converge.
    #[must_use]
    pub fn ray_to_pixel(&self, d: [f64; 3]) -> Option<[f64; 2]> {
        if !d.iter().all(|v| v.is_finite()) || d[2] <= 0.0 {
            return None;
        }
        let [fx, fy, cx, cy] = self.pinhole;
        let q = [fx * d[0] / d[2] + cx, fy * d[1] / d[2] + cy];
        let target = [q[0] / self.undistorted[0], 1.0 - q[1] / self.undistorted[1]];
        let (w, h) = (self.width as f64, self.height as f64);
        let start = [q[0] * w / self.undistorted[0], q[1] * h / self.undistorted[1]];
        self.solve(target, start).or_else(|| {
            let mut best = (f64::INFINITY, start);
            for j in 0..=SEED_GRID {
                for i in 0..=SEED_GRID {
                    let p = [w * i as f64 / SEED_GRID as f64, h * j as f64 / SEED_GRID as f64];
                    let e = self.residual_px(p, target);
                    if e < best.0 {
                        best = (e, p);
                    }
                }
            }
            self.solve(target, best.1)
        })
    }

    /// `|(S, T)(p) − target|` in undistorted pixels.
    fn residual_px(&self, p: [f64; 2], target: [f64; 2]) -> f64 {
        let ([s, t], _) = self.st(p);
        ((s - target[0]) * self.undistorted[0]).hypot((t - target[1]) * self.undistorted[1])
    }

    fn solve(&self, target: [f64; 2], start: [f64; 2]) -> Option<[f64; 2]> {
        let (w, h) = (self.width as f64, self.height as f64);
        let mut p = [start[0].clamp(0.0, w), start[1].clamp(0.0, h)];
        let mut res = self.residual_px(p, target);
        for _ in 0..MAX_STEPS {
            if res <= TOLERANCE_PX {
                break;
            }
            let ([s, t], [[a, b], [c, d]]) = self.st(p);
            let det = a * d - b * c;
            if det == 0.0 || !det.is_finite() {
                return None;
            }
            let (es, et) = (target[0] - s, target[1] - t);
            let step = [(d * es - b * et) / det, (a * et - c * es) / det];
            let mut scale = 1.0;
            let mut moved = false;
            for _ in 0..30 {
                let cand = [p[0] + scale * step[0], p[1] + scale * step[1]];
                let r = self.residual_px(cand, target);
                if r < res {
                    (p, res, moved) = (cand, r, true);
                    break;
                }
                scale *= 0.5;
            }
            if !moved {
                break;
            }
        }
        (res <= TOLERANCE_PX && self.inside(p)).then_some(p)
    }
}

/// An ST-map read from an EXR: the map's size and its R (s) and G (t) samples, row by row from the
/// top (the layout `obscura stmap` writes and Nuke's `STMap` node reads).
#[derive(Debug, Clone, PartialEq)]
pub struct ReadStMap {
    /// Width of the map (the plate it is for), pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Nuke's s (channel R).
    pub s: Vec<f32>,
    /// Nuke's t (channel G).
    pub t: Vec<f32>,
}

/// An ST-map EXR could not be read: the file and what was expected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}: {message}")]
pub struct ReadStMapError {
    /// The file as named by the caller.
    pub file: String,
    /// What is wrong and what was expected.
    pub message: String,
}

/// Reads the ST-map in the first layer of the OpenEXR at `path`: channels `R` and `G` (half or
/// float), over the layer's data window.
///
/// # Errors
/// A [`ReadStMapError`] naming the file: unreadable, not an OpenEXR, no layer, no `R` or `G`
/// channel, integer samples.
pub fn read_stmap_exr(path: &std::path::Path) -> Result<ReadStMap, ReadStMapError> {
    let err = |message: String| ReadStMapError {
        file: path.display().to_string(),
        message,
    };
    let image = exr::prelude::read_all_flat_layers_from_file(path)
        .map_err(|e| err(format!("cannot read it as an OpenEXR ST-map: {e}")))?;
    let layer = image
        .layer_data
        .first()
        .ok_or_else(|| err("the OpenEXR holds no layer; expected an ST-map (R = s, G = t)".into()))?;
    let channel = |name: &str| -> Result<Vec<f32>, ReadStMapError> {
        let ch = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .ok_or_else(|| {
                let have: Vec<String> = layer
                    .channel_data
                    .list
                    .iter()
                    .map(|c| c.name.to_string())
                    .collect();
                err(format!(
                    "no channel {name}; an ST-map has R = s and G = t (channels present: {})",
                    have.join(", ")
                ))
            })?;
        match &ch.sample_data {
            exr::prelude::FlatSamples::F32(v) => Ok(v.clone()),
            exr::prelude::FlatSamples::F16(v) => Ok(v.iter().map(|h| h.to_f32()).collect()),
            exr::prelude::FlatSamples::U32(_) => Err(err(format!(
                "channel {name} holds integer samples; an ST-map's s and t are half or float in [0, 1]"
            ))),
        }
    };
    Ok(ReadStMap {
        width: layer.size.0,
        height: layer.size.1,
        s: channel("R")?,
        t: channel("G")?,
    })
}

/// The name scenes use for the ST-map camera projection.
pub const PROJECTION: &str = "StMapCamera";

static TABLE: std::sync::LazyLock<Vec<obscura_sdk::ParamDecl>> = std::sync::LazyLock::new(|| {
    use obscura_sdk::{ParamDecl, ValueRange};
    vec![
        ParamDecl::string("map", "")
            .doc("the ST-map EXR (required): per plate pixel, R = s, G = t of the position in the undistorted image (Nuke's STMap convention)"),
        ParamDecl::float_array("pinhole", &[0.0, 0.0, 0.0, 0.0])
            .doc("the undistorted image's pinhole fx fy cx cy, in its pixels (required)"),
        ParamDecl::int_array("undistortedResolution", &[0, 0])
            .range(ValueRange::closed(0.0, 1e6))
            .doc("width and height of the undistorted image the map reads, pixels [default: the map's size]"),
    ]
});

/// Creates [`StMapCamera`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct StMapCameraFactory;

impl obscura_sdk::ProjectionFactory for StMapCameraFactory {
    fn name(&self) -> &str {
        PROJECTION
    }

    fn summary(&self) -> &str {
        "a lens given as an ST-map (Nuke's redistort map into its undistorted pinhole), exact both ways to the map"
    }

    fn param_table(&self) -> &[obscura_sdk::ParamDecl] {
        &TABLE
    }

    fn create_projection(
        &self,
        env: &mut obscura_sdk::ProjectionEnvironment,
        params: &obscura_sdk::ParamList,
    ) -> Result<Box<dyn obscura_sdk::Projection>, obscura_sdk::PluginError> {
        let invalid = |message: String| obscura_sdk::PluginError::Invalid {
            plugin: PROJECTION.to_string(),
            message,
        };
        let p = obscura_sdk::Params::resolve(PROJECTION, &TABLE, params)?;
        let file = p.string("map")?;
        if file.is_empty() {
            return Err(invalid(
                "map is required: \"string map\" [\"file.exr\"], the ST-map EXR of the lens".into(),
            ));
        }
        if !p.is_given("pinhole") {
            return Err(invalid(
                "pinhole is required: \"float[4] pinhole\" [fx fy cx cy] of the undistorted image, in its pixels"
                    .into(),
            ));
        }
        let pinhole: Vec<f64> = p.floats("pinhole", 4)?.iter().map(|&v| f64::from(v)).collect();
        let read = read_stmap_exr(std::path::Path::new(file)).map_err(|e| invalid(e.to_string()))?;
        let size = match params.get("undistortedResolution").map(|e| &e.value) {
            Some(obscura_sdk::ParamValue::Ints(v)) if v.len() == 2 && v[0] > 0 && v[1] > 0 => {
                [f64::from(v[0]), f64::from(v[1])]
            }
            _ => [read.width as f64, read.height as f64],
        };
        let lens = StMapLens::new(
            read.width,
            read.height,
            &read.s,
            &read.t,
            size,
            [pinhole[0], pinhole[1], pinhole[2], pinhole[3]],
        )
        .map_err(|e| invalid(format!("{file}: {e}")))?;
        env.set_deep_metric(obscura_sdk::DeepMetric::CameraZ);
        Ok(Box::new(StMapCamera::new(env, lens)))
    }
}

/// A projection through an [`StMapLens`]: the plate spans the screen window, screen point
/// `(sx, sy)` is plate raster position `x = (sx − l)/(r − l)·W`, `y = (t − sy)/(t − b)·H`; its ray is
/// the lens's, y flipped to Obscura's camera space (y up). Rays leave the origin; `ray_spread` is half
/// the geometric mean of the angles the ray turns per render pixel along x and y (finite
/// differences); clipping planes `near/D.z`, `far/D.z` (every ray has z > 0: DeepMetric CameraZ,
/// DicingHint Perspective).
#[derive(Debug, Clone)]
pub struct StMapCamera {
    lens: StMapLens,
    /// Plate raster `x = su·sx + ou`, `y = sv·sy + ov`.
    su: f64,
    ou: f64,
    sv: f64,
    ov: f64,
    /// Plate pixels per render pixel, x and y.
    step: [f64; 2],
    near: f32,
    far: f32,
    fov: f32,
}

impl StMapCamera {
    /// The camera of `lens` placed on `env`'s screen window.
    #[must_use]
    pub fn new(env: &obscura_sdk::ProjectionEnvironment, lens: StMapLens) -> Self {
        let w = env.screen_window();
        let (pw, ph) = (lens.width as f64, lens.height as f64);
        let (l, r, b, t) = (
            f64::from(w.left),
            f64::from(w.right),
            f64::from(w.bottom),
            f64::from(w.top),
        );
        let su = pw / (r - l);
        let sv = -ph / (t - b);
        let mut cam = StMapCamera {
            su,
            ou: -l * su,
            sv,
            ov: t * ph / (t - b),
            step: [pw / f64::from(env.width()), ph / f64::from(env.height())],
            near: env.clipping_near(),
            far: env.clipping_far(),
            fov: 0.0,
            lens,
        };
        let unit = |p: [f64; 2]| cam.lens.pixel_to_ray(p).map(normalised);
        let (mx, my) = (0.5 * pw, 0.5 * ph);
        let ends = if pw <= ph {
            [[0.0, my], [pw, my]]
        } else {
            [[mx, 0.0], [mx, ph]]
        };
        cam.fov = match (unit(ends[0]), unit(ends[1])) {
            (Some(a), Some(b)) => angle(a, b).to_degrees() as f32,
            _ => 90.0,
        };
        cam
    }

    /// The lens.
    #[must_use]
    pub fn lens(&self) -> &StMapLens {
        &self.lens
    }

    fn ray(&self, s: obscura_sdk::Point2) -> obscura_sdk::RayGeometry {
        let p = [
            self.su * f64::from(s.x) + self.ou,
            self.sv * f64::from(s.y) + self.ov,
        ];
        let Some(d) = self.lens.pixel_to_ray(p).map(normalised) else {
            return obscura_sdk::RayGeometry::CULLED;
        };
        let turn = |k: usize| {
            let mut q = p;
            let h = self.step[k];
            // Step inward so the neighbour stays inside the frame.
            q[k] += if q[k] + h <= [self.lens.width, self.lens.height][k] as f64 {
                h
            } else {
                -h
            };
            self.lens.pixel_to_ray(q).map_or(0.0, |e| angle(d, normalised(e)))
        };
        let spread = 0.5 * (turn(0) * turn(1)).sqrt();
        let direction = obscura_sdk::Vec3::new(d[0] as f32, -d[1] as f32, d[2] as f32);
        let k = 1.0 / direction.z;
        obscura_sdk::RayGeometry {
            origin: obscura_sdk::Vec3::ZERO,
            origin_radius: 0.0,
            direction,
            ray_spread: if spread.is_finite() { spread as f32 } else { 0.0 },
            min_dist: self.near * k,
            max_dist: self.far * k,
        }
    }
}

fn normalised(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

impl obscura_sdk::Projection for StMapCamera {
    fn property(&self, property: obscura_sdk::ProjectionProperty) -> Option<obscura_sdk::PropertyValue> {
        use obscura_sdk::{DeepMetric, DicingHint, ProjectionProperty, PropertyValue};
        match property {
            ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(DicingHint::Perspective)),
            ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(DeepMetric::CameraZ)),
            ProjectionProperty::FieldOfView => Some(PropertyValue::Float(self.fov)),
            _ => None,
        }
    }

    fn project(&self, ctx: &mut obscura_sdk::ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        obscura_sdk::simd::map_screen(c.rays, c.screen, |s| self.ray(s));
    }

    fn unproject(&self, point: obscura_sdk::Vec3, _time: f32) -> Option<obscura_sdk::Point2> {
        if !point.is_finite() {
            return None;
        }
        let p = self
            .lens
            .ray_to_pixel([f64::from(point.x), -f64::from(point.y), f64::from(point.z)])?;
        let s = obscura_sdk::Point2::new(
            ((p[0] - self.ou) / self.su) as f32,
            ((p[1] - self.ov) / self.sv) as f32,
        );
        (s.x.is_finite() && s.y.is_finite()).then_some(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth one-to-one map: a barrel-like warp into an undistorted image 10 % larger.
    fn warp(w: usize, h: usize) -> (Vec<f32>, Vec<f32>) {
        let (mut s, mut t) = (Vec::new(), Vec::new());
        for j in 0..h {
            for i in 0..w {
                let (x, y) = (
                    (i as f64 + 0.5) / w as f64 - 0.5,
                    (j as f64 + 0.5) / h as f64 - 0.5,
                );
                let k = 1.0 + 0.1 * (x * x + y * y);
                s.push((0.5 + x * k / 1.1) as f32);
                t.push((0.5 - y * k / 1.1) as f32);
            }
        }
        (s, t)
    }

    #[test]
    fn samples_are_exact_at_pixel_centres_and_round_trips_hold() {
        let (w, h) = (40, 30);
        let (s, t) = warp(w, h);
        let lens = StMapLens::new(w, h, &s, &t, [44.0, 33.0], [40.0, 40.0, 22.0, 16.5]).unwrap();
        let q = lens.undistort([3.5, 7.5]);
        assert!((q[0] - 44.0 * f64::from(s[7 * w + 3])).abs() < 1e-12);
        assert!((q[1] - 33.0 * (1.0 - f64::from(t[7 * w + 3]))).abs() < 1e-12);
        for p in [[0.0, 0.0], [0.3, 29.9], [20.0, 15.0], [39.99, 0.01], [12.3, 17.8]] {
            let d = lens.pixel_to_ray(p).unwrap();
            let back = lens.ray_to_pixel([d[0] * 3.0, d[1] * 3.0, d[2] * 3.0]).unwrap();
            assert!(
                (back[0] - p[0]).abs() < 1e-6 && (back[1] - p[1]).abs() < 1e-6,
                "{p:?} -> {back:?}"
            );
        }
        assert_eq!(lens.ray_to_pixel([0.0, 0.0, -1.0]), None);
        assert_eq!(lens.ray_to_pixel([10.0, 0.0, 1.0]), None, "far outside the frame");
        assert_eq!(lens.pixel_to_ray([-0.1, 3.0]), None);
    }

    #[test]
    fn maps_that_are_not_st_maps_are_refused_with_the_pixel() {
        let (w, h) = (8, 6);
        let (s, t) = warp(w, h);
        let new = |s: &[f32], t: &[f32]| StMapLens::new(w, h, s, t, [8.0, 6.0], [8.0, 8.0, 4.0, 3.0]);
        let mut bad = s.clone();
        bad[2 * w + 5] = f32::NAN;
        let e = new(&bad, &t).unwrap_err();
        assert!(e.starts_with("pixel 5,2:") && e.contains("finite"), "{e}");
        let mut bad = s.clone();
        bad[w + 4] = bad[w + 3];
        let e = new(&bad, &t).unwrap_err();
        assert!(e.contains("s does not grow left to right"), "{e}");
        let flipped: Vec<f32> = t.iter().map(|v| 1.0 - v).collect();
        let e = new(&s, &flipped).unwrap_err();
        assert!(e.contains("t does not fall from top to bottom"), "{e}");
        let e = new(&s[1..], &t).unwrap_err();
        assert!(e.contains("needs 48 s and t samples"), "{e}");
        let e = StMapLens::new(w, h, &s, &t, [8.0, 6.0], [0.0, 8.0, 4.0, 3.0]).unwrap_err();
        assert!(e.contains("focal lengths > 0"), "{e}");
    }

    #[test]
    fn the_projection_refuses_bad_maps_naming_the_file_and_pixel() {
        use exr::prelude::{
            AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, WritableImage,
        };
        use obscura_sdk::{Format, ParamList, ProjectionEnvironment, ProjectionFactory};
        let dir = std::env::temp_dir().join(format!("obscura-stmap-camera-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (w, h) = (8, 6);
        let (mut s, t) = warp(w, h);
        s[3 * w + 2] = f32::NAN;
        let path = dir.join("nan.exr");
        let channels = vec![
            AnyChannel::new("R", FlatSamples::F32(s)),
            AnyChannel::new("G", FlatSamples::F32(t)),
        ];
        let layer = Layer::new(
            (w, h),
            LayerAttributes::default(),
            Encoding::UNCOMPRESSED,
            AnyChannels::sort(channels.into()),
        );
        Image::from_layer(layer).write().to_file(&path).unwrap();
        let create = |list: &[(&str, &str)]| {
            let mut l = ParamList::new();
            for (d, v) in list {
                l.push_text(d, &v.split(' ').collect::<Vec<_>>(), None).unwrap();
            }
            let mut env = ProjectionEnvironment::for_format(Format::new(8, 6));
            StMapCameraFactory
                .create_projection(&mut env, &l)
                .map(|_| ())
                .unwrap_err()
                .to_string()
        };
        let file = path.display().to_string();
        let e = create(&[("string map", file.as_str()), ("float[4] pinhole", "8 8 4 3")]);
        assert!(
            e.contains(&format!("{file}: pixel 2,3:")) && e.contains("must be finite"),
            "{e}"
        );
        let e = create(&[("float[4] pinhole", "8 8 4 3")]);
        assert!(e.contains("map is required"), "{e}");
        let e = create(&[("string map", file.as_str())]);
        assert!(e.contains("pinhole is required"), "{e}");
        let e = create(&[
            ("string map", "/nonexistent/map.exr"),
            ("float[4] pinhole", "8 8 4 3"),
        ]);
        assert!(
            e.contains("/nonexistent/map.exr: cannot read it as an OpenEXR ST-map"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
