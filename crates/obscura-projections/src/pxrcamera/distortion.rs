//! PxrCamera's lens distortion (`radial1`, `radial2`, `assymX`, `assymY`, `squeeze`): a division model
//! mapping the distorted image position to the ideal (pinhole) one in closed form.
//!
//! For a sensor position `p = (x, y)` in screen units (relative to the optical axis), with
//! `k1 = radial1`, `k2 = radial2`, `σ = squeeze`:
//!
//! ```text
//! q    = (x/σ)² + y²
//! Dx   = 1 + (k1 + assymX)·q + k2·q²
//! Dy   = 1 + (k1 + assymY)·q + k2·q²
//! u    = F(p) = (x/Dx, y/Dy)                 the ideal position on the screen plane
//! ```
//!
//! A point at ideal radius ρ is imaged at radius `r` with `ρ = r/(1 + k1 r² + k2 r⁴)` (σ = 1, no
//! assymetry): to first order `r = ρ·(1 + k1 ρ²)`, the usual Brown–Conrady radial term, so `radial1 > 0`
//! magnifies the edges more than the centre — **pincushion** — and `radial1 < 0` gives **barrel**, as
//! RenderMan documents. `assymX` adds a radial term to x only (`y` is untouched by it, so horizontal
//! lines stay straight), `assymY` to y only. `squeeze > 1` measures the radius with x compressed, so
//! the distortion acts less along x (anamorphic lenses).
//!
//! **Fold.** With `c = k1 + assymX` (or `k1 + assymY`), the Jacobian determinant of `F` on the ellipse
//! `q = const` is smallest on its axes, where it is positive exactly while both
//! `1 + c·q + k2·q² > 0` (no pole) and `1 − c·q − 3·k2·q² > 0` (the radial profile still rising). The
//! smallest positive root of those four quadratics is `q_max`: on `q < q_max` the map is monotonic and
//! invertible; samples with `q ≥ q_max` lie beyond a fold (or a pole) and are culled.
//!
//! **Inverse.** `F(p) = u` holds exactly when `p = (ux·Dx(q), uy·Dy(q))` with `q` the squeezed squared
//! radius of that same `p`, so the 2-D inverse reduces to one scalar equation in `q`:
//! `ψ(q) = |(ux·Dx(q)/σ, uy·Dy(q))| − √q = 0`, solved in f64 by Halley's form of Newton's method kept
//! inside a bracket
//! of `[0, q_max)` (see [`Distortion::newton`]); it reaches 1e-6 within 8 steps over the monotonic
//! region.

/// The distortion's coefficients with everything `project` needs precomputed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Distortion {
    cx: f64,
    cy: f64,
    k2: f64,
    inv_sq2: f64,
    q_max: f64,
    cx32: f32,
    cy32: f32,
    k2_32: f32,
    inv_sq2_32: f32,
    q_max32: f32,
}

/// The forward map at one point: the ideal position and the 2×2 Jacobian `∂u/∂p`, row-major
/// `[∂ux/∂x, ∂ux/∂y, ∂uy/∂x, ∂uy/∂y]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Forward {
    pub u: (f32, f32),
    pub jacobian: [f32; 4],
}

/// What [`Distortion::undistort`] found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Inverse {
    /// The distorted (sensor) position.
    pub p: [f64; 2],
    /// Newton updates taken.
    pub steps: usize,
}

/// Newton updates allowed before giving up (8 suffice over the monotonic region; the rest are for
/// points hugging the fold, where the root is nearly double).
const MAX_STEPS: usize = 64;

impl Distortion {
    /// The distortion for these coefficients, or `None` when it is the identity (all terms zero).
    pub(crate) fn new(radial1: f64, radial2: f64, assym_x: f64, assym_y: f64, squeeze: f64) -> Option<Self> {
        if radial1 == 0.0 && radial2 == 0.0 && assym_x == 0.0 && assym_y == 0.0 {
            return None;
        }
        let (cx, cy, k2) = (radial1 + assym_x, radial1 + assym_y, radial2);
        let q_max = [
            first_positive_root(k2, cx),
            first_positive_root(-3.0 * k2, -cx),
            first_positive_root(k2, cy),
            first_positive_root(-3.0 * k2, -cy),
        ]
        .into_iter()
        .fold(f64::INFINITY, f64::min);
        let inv_sq2 = 1.0 / (squeeze * squeeze);
        Some(Distortion {
            cx,
            cy,
            k2,
            inv_sq2,
            q_max,
            cx32: cx as f32,
            cy32: cy as f32,
            k2_32: k2 as f32,
            inv_sq2_32: inv_sq2 as f32,
            // Rounded down so that a sample f32 lets through is inside the f64 region too.
            q_max32: next_down(q_max as f32, q_max),
        })
    }

    /// `q_max`: samples with `(x/σ)² + y² ≥ q_max` are beyond the fold (∞ when there is none).
    #[cfg(test)]
    pub(crate) fn q_max(&self) -> f64 {
        self.q_max
    }

    /// `q = (x/σ)² + y²`, the squeezed squared radius the distortion is a function of.
    pub(crate) fn q(&self, p: [f64; 2]) -> f64 {
        p[0] * p[0] * self.inv_sq2 + p[1] * p[1]
    }

    /// The forward map and its Jacobian at sensor position `(x, y)`, or `None` beyond the fold.
    #[inline(always)]
    pub(crate) fn forward(&self, x: f32, y: f32) -> Option<Forward> {
        let q = x * x * self.inv_sq2_32 + y * y;
        // `!(q < q_max)` also refuses NaN.
        if q.is_nan() || q >= self.q_max32 {
            return None;
        }
        let dx = 1.0 + q * (self.cx32 + self.k2_32 * q);
        let dy = 1.0 + q * (self.cy32 + self.k2_32 * q);
        if dx <= 0.0 || dy <= 0.0 {
            return None;
        }
        let (ix, iy) = (1.0 / dx, 1.0 / dy);
        let (ux, uy) = (x * ix, y * iy);
        // D'(q)/D for each axis; ∂q/∂x = 2x/σ², ∂q/∂y = 2y.
        let two_k2q = 2.0 * self.k2_32 * q;
        let gx = (self.cx32 + two_k2q) * ix;
        let gy = (self.cy32 + two_k2q) * iy;
        let (qx, qy) = (2.0 * x * self.inv_sq2_32, 2.0 * y);
        Some(Forward {
            u: (ux, uy),
            jacobian: [ix - ux * gx * qx, -ux * gx * qy, -uy * gy * qx, iy - uy * gy * qy],
        })
    }

    /// The ideal position of sensor position `p` in f64, or `None` beyond the fold (as [`forward`]
    /// decides in f32).
    ///
    /// [`forward`]: Distortion::forward
    pub(crate) fn ideal(&self, p: [f64; 2]) -> Option<[f64; 2]> {
        let q = self.q(p);
        // NaN fails this too.
        if q.is_nan() || q >= self.q_max {
            return None;
        }
        let dx = 1.0 + q * (self.cx + self.k2 * q);
        let dy = 1.0 + q * (self.cy + self.k2 * q);
        (dx > 0.0 && dy > 0.0).then(|| [p[0] / dx, p[1] / dy])
    }

    /// The forward map and its Jacobian in f64 (no fold check).
    pub(crate) fn forward_f64(&self, p: [f64; 2]) -> ([f64; 2], [f64; 4]) {
        let [x, y] = p;
        let q = self.q(p);
        let dx = 1.0 + q * (self.cx + self.k2 * q);
        let dy = 1.0 + q * (self.cy + self.k2 * q);
        let (ix, iy) = (1.0 / dx, 1.0 / dy);
        let (ux, uy) = (x * ix, y * iy);
        let two_k2q = 2.0 * self.k2 * q;
        let gx = (self.cx + two_k2q) * ix;
        let gy = (self.cy + two_k2q) * iy;
        let (qx, qy) = (2.0 * x * self.inv_sq2, 2.0 * y);
        (
            [ux, uy],
            [ix - ux * gx * qx, -ux * gx * qy, -uy * gy * qx, iy - uy * gy * qy],
        )
    }

    /// `F⁻¹(u)`: the sensor position whose ideal position is `u`, by Newton's method, or `None` when
    /// `u` lies beyond what the monotonic region reaches.
    pub(crate) fn undistort(&self, u: [f64; 2]) -> Option<Inverse> {
        self.newton(u, MAX_STEPS)
    }

    /// Solves `F(p) = u` with at most `max_steps` updates of Halley's method (Newton's method with
    /// its second-order correction).
    ///
    /// `F(p) = u` means `p = (ux·Dx(q), uy·Dy(q))` for the `q` of `p`, so the problem is the scalar
    /// equation `ψ(q) = N(q) − √q = 0` on `(0, q_max)`, `N(q) = |(ux·Dx(q)/σ, uy·Dy(q))|`. `ψ(0⁺) =
    /// |u|_σ > 0` and `ψ` changes sign exactly once on the monotonic region (`√q/D(q)` rises from 0
    /// to the pole's ∞ or the fold's peak), so every step is kept inside a shrinking bracket
    /// (bisecting when a step leaves it) and cannot miss the root. (The square-root form is nearly
    /// linear next to a pole, where the squared form `N² − q` has a near-double root.) The step is
    /// `q ← q − 2ψψ'/(2ψ'² − ψψ'')`, from the first-order guess `q₀ = |(ux·Dx(q_u), uy·Dy(q_u))|²_σ`,
    /// `q_u = |u|²_σ`, or the bracket's middle when that guess is outside it.
    pub(crate) fn newton(&self, u: [f64; 2], max_steps: usize) -> Option<Inverse> {
        if !(u[0].is_finite() && u[1].is_finite()) {
            return None;
        }
        let (a, b) = (u[0] * u[0] * self.inv_sq2, u[1] * u[1]);
        if a + b == 0.0 {
            return Some(Inverse {
                p: [0.0, 0.0],
                steps: 0,
            });
        }
        let (cx, cy, k2) = (self.cx, self.cy, self.k2);
        let (dx, dy) = (|q: f64| 1.0 + q * (cx + k2 * q), |q: f64| 1.0 + q * (cy + k2 * q));
        // ψ(q) and the Halley step from q.
        let halley = |q: f64| {
            let (ex, ey) = (dx(q), dy(q));
            let (ex1, ey1) = (cx + 2.0 * k2 * q, cy + 2.0 * k2 * q);
            let s = a * ex * ex + b * ey * ey;
            let s1 = 2.0 * (a * ex * ex1 + b * ey * ey1);
            let s2 = 2.0 * (a * (ex1 * ex1 + 2.0 * k2 * ex) + b * (ey1 * ey1 + 2.0 * k2 * ey));
            let (n, rq) = (s.sqrt(), q.sqrt());
            let v = n - rq;
            let d1 = s1 / (2.0 * n) - 0.5 / rq;
            let d2 = s2 / (2.0 * n) - s1 * s1 / (4.0 * n * n * n) + 0.25 / (q * rq);
            (v, q - 2.0 * v * d1 / (2.0 * d1 * d1 - v * d2))
        };
        let (mut lo, mut hi) = (0.0, self.q_max);
        let qu = a + b;
        let guess = a * dx(qu).powi(2) + b * dy(qu).powi(2);
        let mut q = if guess > lo && guess < hi {
            guess
        } else {
            0.5 * (lo + hi)
        };
        if !q.is_finite() {
            // No fold and no pole on an axis that carries u: cannot happen for a non-identity map
            // (q_max is finite then), but refuse rather than loop.
            return None;
        }
        let mut steps = 0;
        loop {
            let (v, next) = halley(q);
            if v == 0.0 {
                break;
            }
            if v > 0.0 {
                lo = q;
            } else {
                hi = q;
            }
            if steps == max_steps {
                break;
            }
            steps += 1;
            // Converged: the step is down to rounding (test before the bracket, which rounding may
            // already have crossed).
            if (next - q).abs() <= 1e-15 * (1.0 + q) {
                if next > 0.0 && next < self.q_max {
                    q = next;
                }
                break;
            }
            q = if next > lo && next < hi {
                next
            } else {
                0.5 * (lo + hi)
            };
        }
        if q.is_nan() || q >= self.q_max {
            return None;
        }
        let p = [u[0] * dx(q), u[1] * dy(q)];
        // Beyond the reach of the monotonic region ψ keeps its sign and q runs to the edge: the
        // residual tells.
        let (f, _) = self.forward_f64(p);
        let scale = 1.0 + u[0].abs().max(u[1].abs());
        let residual = (f[0] - u[0]).abs().max((f[1] - u[1]).abs());
        (residual <= 1e-9 * scale).then_some(Inverse { p, steps })
    }
}

/// The smallest positive root of `a·q² + b·q + 1`, or ∞ when it has none (it is 1 at `q = 0`).
fn first_positive_root(a: f64, b: f64) -> f64 {
    if a == 0.0 {
        return if b < 0.0 { -1.0 / b } else { f64::INFINITY };
    }
    let disc = b * b - 4.0 * a;
    if disc < 0.0 {
        return f64::INFINITY;
    }
    // Roots 2/(−b ∓ √disc): the form without cancellation for a constant term of 1.
    let s = disc.sqrt();
    [2.0 / (-b - s), 2.0 / (-b + s)]
        .into_iter()
        .filter(|r| *r > 0.0 && r.is_finite())
        .fold(f64::INFINITY, f64::min)
}

/// The largest f32 not above `exact` (∞ stays ∞).
fn next_down(rounded: f32, exact: f64) -> f32 {
    if rounded.is_infinite() || (rounded as f64) <= exact {
        rounded
    } else {
        f32::from_bits(rounded.to_bits() - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn distortion() -> impl Strategy<Value = Distortion> {
        (
            -0.3f64..0.3,
            -0.08f64..0.08,
            -0.1f64..0.1,
            -0.1f64..0.1,
            0.5f64..2.0,
        )
            .prop_filter_map("not the identity", |(k1, k2, ax, ay, sq)| {
                Distortion::new(k1, k2, ax, ay, sq)
            })
    }

    /// A sensor position inside the monotonic region: `fraction` of the way to the fold (or to radius
    /// 3 when there is none) along direction `angle`.
    fn inside(d: &Distortion, angle: f64, fraction: f64, sq: f64) -> [f64; 2] {
        let q = d.q_max().min(9.0) * fraction;
        let r = q.sqrt();
        // q = (x/σ)² + y² with x = σ·r·cos, y = r·sin.
        [sq * r * angle.cos(), r * angle.sin()]
    }

    fn squeeze_of(d: &Distortion) -> f64 {
        (1.0 / d.inv_sq2).sqrt()
    }

    #[test]
    fn radial1_positive_is_pincushion_negative_is_barrel() {
        // Pincushion: image radius grows faster than the ideal one (edges magnified).
        let pin = Distortion::new(0.1, 0.0, 0.0, 0.0, 1.0).unwrap();
        let barrel = Distortion::new(-0.1, 0.0, 0.0, 0.0, 1.0).unwrap();
        let image_radius_for = |d: &Distortion, rho: f64| d.undistort([rho, 0.0]).unwrap().p[0];
        let mag = |d: &Distortion, rho: f64| image_radius_for(d, rho) / rho;
        assert!(mag(&pin, 1.0) > mag(&pin, 0.1) && mag(&pin, 0.1) > 1.0);
        assert!(mag(&barrel, 1.0) < mag(&barrel, 0.1) && mag(&barrel, 0.1) < 1.0);
        // First order: r ≈ ρ(1 + k1 ρ²), the Brown–Conrady term with the same k1.
        let rho = 0.05;
        // The next term is 2·k1²·ρ⁴ = 1.25e-7.
        assert!((image_radius_for(&pin, rho) / (rho * (1.0 + 0.1 * rho * rho)) - 1.0).abs() < 2e-7);
    }

    #[test]
    fn assym_x_keeps_horizontal_lines_straight() {
        let d = Distortion::new(0.0, 0.0, 0.2, 0.0, 1.0).unwrap();
        for x in [-1.5f32, -0.3, 0.0, 0.7, 1.4] {
            let f = d.forward(x, 0.6).unwrap();
            assert_eq!(f.u.1, 0.6, "y moved at x {x}");
        }
        // ... and bends vertical ones.
        assert!(d.forward(1.0, 0.0).unwrap().u.0 != d.forward(1.0, 0.8).unwrap().u.0);
    }

    #[test]
    fn the_fold_is_where_the_radial_profile_stops_rising() {
        // ρ(r) = r/(1 + k1 r²) with k1 = 0.2 peaks at r² = 1/k1 = 5.
        let d = Distortion::new(0.2, 0.0, 0.0, 0.0, 1.0).unwrap();
        assert!((d.q_max() - 5.0).abs() < 1e-12);
        assert!(d.forward(2.2, 0.0).is_some() && d.forward(2.25, 0.0).is_none());
        // Barrel with a pole: 1 − 0.25 q = 0 at q = 4 (the ideal position runs off to infinity).
        let pole = Distortion::new(-0.25, 0.0, 0.0, 0.0, 1.0).unwrap();
        assert!((pole.q_max() - 4.0).abs() < 1e-12);
        // A quartic term: 1 − 0.1 q − 3·0.05 q² = 0 at q = (−0.1 + √(0.01 + 0.6))/0.3.
        let quartic = Distortion::new(0.1, 0.05, 0.0, 0.0, 1.0).unwrap();
        let expected = (-0.1 + (0.01f64 + 0.6).sqrt()) / 0.3;
        assert!((quartic.q_max() - expected).abs() < 1e-12);
        // Mild barrel with a positive quartic never folds.
        assert!(
            Distortion::new(-0.05, 0.0, 0.0, 0.0, 1.0)
                .unwrap()
                .q_max()
                .is_finite()
        );
        assert_eq!(Distortion::new(0.0, 0.0, 0.0, 0.0, 1.0), None);
    }

    #[test]
    fn jacobian_is_positive_inside_the_fold_and_vanishes_on_it() {
        let d = Distortion::new(0.15, 0.02, 0.05, -0.04, 1.3).unwrap();
        let sq = 1.3;
        for i in 0..64 {
            let angle = i as f64 * std::f64::consts::TAU / 64.0;
            let (_, j) = d.forward_f64(inside(&d, angle, 0.999, sq));
            assert!(j[0] * j[3] - j[1] * j[2] > 0.0, "at angle {angle}");
        }
        // On the axes the determinant reaches zero exactly at q_max for the binding axis.
        let at = |angle: f64| {
            let (_, j) = d.forward_f64(inside(&d, angle, 1.0, sq));
            j[0] * j[3] - j[1] * j[2]
        };
        assert!(at(0.0).abs().min(at(std::f64::consts::FRAC_PI_2).abs()) < 1e-9);
    }

    proptest! {
        #[test]
        fn analytic_jacobian_matches_central_differences(d in distortion(), angle in 0.0f64..6.3, f in 0.0f64..0.95) {
            let p = inside(&d, angle, f, squeeze_of(&d));
            let (_, j) = d.forward_f64(p);
            let h = 1e-6;
            let fx = |dx: f64, dy: f64| d.forward_f64([p[0] + dx, p[1] + dy]).0;
            let (a, b) = (fx(h, 0.0), fx(-h, 0.0));
            let (c, e) = (fx(0.0, h), fx(0.0, -h));
            let num = [(a[0] - b[0]) / (2.0 * h), (c[0] - e[0]) / (2.0 * h), (a[1] - b[1]) / (2.0 * h), (c[1] - e[1]) / (2.0 * h)];
            for k in 0..4 {
                prop_assert!((num[k] - j[k]).abs() < 1e-6 * (1.0 + j[k].abs()), "{k}: {} vs {}", num[k], j[k]);
            }
            // The f32 kernel agrees with the f64 one.
            let f32j = d.forward(p[0] as f32, p[1] as f32).unwrap().jacobian;
            for k in 0..4 {
                prop_assert!((f32j[k] as f64 - j[k]).abs() < 1e-4 * (1.0 + j[k].abs()));
            }
        }

        #[test]
        fn inverse_round_trips_to_a_ten_thousandth_of_a_pixel(d in distortion(), angle in 0.0f64..6.3, f in 0.0f64..0.999) {
            // 1e-4 pixel of a 4K-wide frame of the default window (8 screen units across 3840 px).
            let tol = 1e-4 * 8.0 / 3840.0;
            let p = inside(&d, angle, f, squeeze_of(&d));
            let (u, _) = d.forward_f64(p);
            let back = d.undistort(u).expect("inside the monotonic region");
            prop_assert!((back.p[0] - p[0]).abs() < tol && (back.p[1] - p[1]).abs() < tol, "{:?} vs {:?}", back.p, p);
        }

        #[test]
        fn newton_reaches_1e_6_within_8_steps(d in distortion(), angle in 0.0f64..6.3, f in 0.0f64..0.98) {
            let p = inside(&d, angle, f, squeeze_of(&d));
            let (u, _) = d.forward_f64(p);
            let inv = d.newton(u, 8).expect("converges within 8 steps");
            prop_assert!(inv.steps <= 8);
            prop_assert!((inv.p[0] - p[0]).abs() < 1e-6 && (inv.p[1] - p[1]).abs() < 1e-6, "{:?} vs {:?} after {}", inv.p, p, inv.steps);
        }
    }

    #[test]
    fn points_beyond_the_reach_of_the_monotonic_region_have_no_inverse() {
        // Pincushion k1 = 0.2: the ideal radius peaks at √5/(1 + 1) = 1.118.
        let d = Distortion::new(0.2, 0.0, 0.0, 0.0, 1.0).unwrap();
        assert!(d.undistort([1.1, 0.0]).is_some());
        assert!(d.undistort([1.2, 0.0]).is_none());
        assert!(d.undistort([f64::NAN, 0.0]).is_none());
    }
}
