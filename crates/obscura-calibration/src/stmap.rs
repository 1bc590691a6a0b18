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
//! # What a map must be
//!
//! [`StMapLens::new`] refuses (naming the pixel) a map whose size does not match its samples, a
//! sample that is not finite, and a map that is not one-to-one: `s` must grow left to right along
//! every row, `t` must fall from top to bottom along every column, and the Jacobian
//! `∂(s, t)/∂(x, y)` (forward differences) must have a negative determinant at every sample, so that
//! the bilinear map neither folds nor flips and its inverse is unique.

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
}
