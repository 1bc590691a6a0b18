//! RenderMan's pixel filters (`PixelFilter "name" xwidth ywidth`).
//!
//! A filter weights a camera sample by its offset `(dx, dy)` (in pixels) from a pixel centre. The
//! support is the rectangle `|dx| ≤ xwidth/2`, `|dy| ≤ ywidth/2`; outside it every filter is 0. With
//! `u = |dx|/(xwidth/2)` and `v = |dy|/(ywidth/2)` (both in [0, 1] inside the support):
//!
//! | kind | weight | separable |
//! |---|---|---|
//! | box | 1 | yes |
//! | triangle | (1 − u)(1 − v) | yes |
//! | gaussian | exp(−2u²)·exp(−2v²), RenderMan's `exp(−2((2x/w)² + (2y/w)²))` | yes |
//! | catmull-rom | k(2·√(u² + v²)), the Mitchell–Netravali cubic k with B = 0, C = ½ | no (radial) |
//! | mitchell | k(2u)·k(2v), the Mitchell–Netravali cubic with B = C = ⅓ | yes |
//! | blackman-harris | h(u)·h(v), h(u) = a₀ + a₁cos(πu) + a₂cos(2πu) + a₃cos(3πu) | yes |
//!
//! The cubics are defined on [−2, 2] and **scaled to the width**, so every kernel reaches its own edge
//! exactly at the support edge (RenderMan's appendix E Catmull-Rom is instead fixed to [−2, 2] pixels
//! and truncated by the width; the two agree at width 4, which is why 4 is its default here).
//! RenderMan's Catmull-Rom is radial (`r = √(x² + y²)`) and PRMan offers a separate
//! `separable-catmull-rom`; we keep the radial one. Blackman–Harris is the 4-term window
//! (a₀ = 0.35875, a₁ = 0.48829, a₂ = 0.14128, a₃ = 0.01168) spread over the full width; it is
//! 1 at the centre and 6·10⁻⁵ (not exactly 0) at the edge.
//!
//! Weights are not normalised: the film divides by the sum of the weights.

use obscura_scene::{FilterKind, PixelFilter};

/// A pixel filter could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FilterError {
    /// A width was zero, negative, infinite or NaN.
    #[error(
        "PixelFilter \"{}\" {width_x} {width_y}: filter widths must be finite and greater than 0",
        renderman_name(*kind)
    )]
    InvalidWidth {
        /// Which filter.
        kind: FilterKind,
        /// The full width given in x, pixels.
        width_x: f32,
        /// The full width given in y, pixels.
        width_y: f32,
    },
}

/// The full width (pixels) used for `kind` when a scene names a filter without widths.
///
/// RenderMan documents one default, the 2×2 gaussian (RI specification, `PixelFilter`; RenderMan 21
/// "Filtering": "The default is a 2x2 pixel Gaussian"). The others are the widths at which each kernel
/// is its usual self in pixel units: box 1 and triangle 2 (a one-pixel box, a tent of radius one
/// pixel); catmull-rom 4 and mitchell 4 (the cubics' own [−2, 2] support, where our scaled kernels
/// equal RenderMan's appendix E Catmull-Rom and Mitchell–Netravali's filter); blackman-harris 3.
/// The last three are also OpenImageIO's defaults for these filters.
#[must_use]
pub fn default_width(kind: FilterKind) -> f32 {
    match kind {
        FilterKind::Box => 1.0,
        FilterKind::Triangle => 2.0,
        FilterKind::Gaussian => 2.0,
        FilterKind::CatmullRom => 4.0,
        FilterKind::Mitchell => 4.0,
        FilterKind::BlackmanHarris => 3.0,
    }
}

/// The name RenderMan gives a filter kind in RIB (`"catmull-rom"`).
fn renderman_name(kind: FilterKind) -> &'static str {
    match kind {
        FilterKind::Box => "box",
        FilterKind::Triangle => "triangle",
        FilterKind::Gaussian => "gaussian",
        FilterKind::CatmullRom => "catmull-rom",
        FilterKind::Mitchell => "mitchell",
        FilterKind::BlackmanHarris => "blackman-harris",
    }
}

/// A pixel filter: its kind and its half-widths (radii) in pixels. See the module documentation for
/// the formulas.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Filter {
    kind: FilterKind,
    radius_x: f32,
    radius_y: f32,
}

impl Filter {
    /// The filter a `PixelFilter` request describes.
    ///
    /// # Errors
    /// [`FilterError::InvalidWidth`] when a width is not finite or not greater than 0.
    pub fn new(spec: &PixelFilter) -> Result<Self, FilterError> {
        let valid = |w: f32| w.is_finite() && w > 0.0;
        if !valid(spec.width_x) || !valid(spec.width_y) {
            return Err(FilterError::InvalidWidth {
                kind: spec.kind,
                width_x: spec.width_x,
                width_y: spec.width_y,
            });
        }
        Ok(Filter {
            kind: spec.kind,
            radius_x: 0.5 * spec.width_x,
            radius_y: 0.5 * spec.width_y,
        })
    }

    /// Which filter.
    #[must_use]
    pub fn kind(&self) -> FilterKind {
        self.kind
    }

    /// The half-widths `(xwidth/2, ywidth/2)` in pixels: the filter is 0 beyond them.
    #[must_use]
    pub fn radius(&self) -> (f32, f32) {
        (self.radius_x, self.radius_y)
    }

    /// The weight of a sample at offset `(dx, dy)` pixels from a pixel centre.
    ///
    /// 0 outside the closed support `|dx| ≤ radius_x, |dy| ≤ radius_y` and for NaN offsets; may be
    /// negative inside it (catmull-rom, mitchell).
    #[must_use]
    pub fn eval(&self, dx: f32, dy: f32) -> f32 {
        let (ax, ay) = (dx.abs(), dy.abs());
        // Written so that NaN falls outside.
        if !(ax <= self.radius_x && ay <= self.radius_y) {
            return 0.0;
        }
        let (u, v) = (ax / self.radius_x, ay / self.radius_y);
        match self.kind {
            FilterKind::Box => 1.0,
            FilterKind::Triangle => (1.0 - u) * (1.0 - v),
            FilterKind::Gaussian => (-2.0 * (u * u + v * v)).exp(),
            FilterKind::CatmullRom => cubic(2.0 * (u * u + v * v).sqrt(), 0.0, 0.5),
            FilterKind::Mitchell => {
                const THIRD: f32 = 1.0 / 3.0;
                cubic(2.0 * u, THIRD, THIRD) * cubic(2.0 * v, THIRD, THIRD)
            }
            FilterKind::BlackmanHarris => blackman_harris(u) * blackman_harris(v),
        }
    }
}

/// The Mitchell–Netravali cubic (1988) with parameters `b`, `c` at `|x|`, 0 from 2 on.
fn cubic(x: f32, b: f32, c: f32) -> f32 {
    let x = x.abs();
    let (x2, x3) = (x * x, x * x * x);
    let k = if x < 1.0 {
        (12.0 - 9.0 * b - 6.0 * c) * x3 + (-18.0 + 12.0 * b + 6.0 * c) * x2 + (6.0 - 2.0 * b)
    } else if x < 2.0 {
        (-b - 6.0 * c) * x3 + (6.0 * b + 30.0 * c) * x2 + (-12.0 * b - 48.0 * c) * x + (8.0 * b + 24.0 * c)
    } else {
        0.0
    };
    k / 6.0
}

/// The 4-term Blackman–Harris window centred at 0, at `u` = offset / half-width in [0, 1].
fn blackman_harris(u: f32) -> f32 {
    const A: [f32; 4] = [0.35875, 0.48829, 0.14128, 0.01168];
    let t = std::f32::consts::PI * u;
    A[0] + A[1] * t.cos() + A[2] * (2.0 * t).cos() + A[3] * (3.0 * t).cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::ALL_FILTERS;

    fn filter(kind: FilterKind, wx: f32, wy: f32) -> Filter {
        Filter::new(&PixelFilter {
            kind,
            width_x: wx,
            width_y: wy,
        })
        .unwrap()
    }

    fn default_filter(kind: FilterKind) -> Filter {
        filter(kind, default_width(kind), default_width(kind))
    }

    #[test]
    fn values_at_the_centre() {
        let expected = [
            (FilterKind::Box, 1.0),
            (FilterKind::Triangle, 1.0),
            (FilterKind::Gaussian, 1.0),
            (FilterKind::CatmullRom, 1.0),
            // Mitchell–Netravali with B = C = 1/3: k(0) = (6 − 2B)/6 = 8/9 per axis.
            (FilterKind::Mitchell, 64.0 / 81.0),
            (FilterKind::BlackmanHarris, 1.0),
        ];
        for (kind, value) in expected {
            let f = default_filter(kind);
            assert!(
                (f.eval(0.0, 0.0) - value).abs() < 1e-6,
                "{kind:?}: {}",
                f.eval(0.0, 0.0)
            );
        }
    }

    #[test]
    fn values_at_and_beyond_the_support_edge() {
        for kind in ALL_FILTERS {
            let f = filter(kind, 3.0, 5.0);
            let (rx, ry) = f.radius();
            assert_eq!((rx, ry), (1.5, 2.5));
            let edge = match kind {
                FilterKind::Box => 1.0,
                // RenderMan's gaussian is cut off at exp(−2) by the width.
                FilterKind::Gaussian => (-2.0f32).exp(),
                FilterKind::BlackmanHarris => 0.35875 - 0.48829 + 0.14128 - 0.01168,
                FilterKind::Triangle | FilterKind::CatmullRom | FilterKind::Mitchell => 0.0,
            };
            // On the x edge with dy = 0; the y factor is the centre value of the separable ones.
            let centre_y = match kind {
                FilterKind::Mitchell => 8.0 / 9.0,
                _ => 1.0,
            };
            assert!(
                (f.eval(rx, 0.0) - edge * centre_y).abs() < 1e-6,
                "{kind:?} x edge"
            );
            assert!(
                (f.eval(0.0, -ry) - edge * centre_y).abs() < 1e-6,
                "{kind:?} y edge"
            );
            for (dx, dy) in [
                (rx * 1.0001, 0.0),
                (0.0, ry * 1.0001),
                (-2.0 * rx, 0.3),
                (f32::NAN, 0.0),
            ] {
                assert_eq!(f.eval(dx, dy), 0.0, "{kind:?} ({dx}, {dy})");
            }
        }
    }

    #[test]
    fn filters_are_symmetric() {
        for kind in ALL_FILTERS {
            let f = filter(kind, 2.5, 3.5);
            for i in 0..40 {
                let (dx, dy) = (-1.3 + 0.07 * i as f32, 1.7 - 0.09 * i as f32);
                let w = f.eval(dx, dy);
                assert_eq!(w, f.eval(-dx, dy), "{kind:?}");
                assert_eq!(w, f.eval(dx, -dy), "{kind:?}");
                assert_eq!(w, f.eval(-dx, -dy), "{kind:?}");
            }
        }
    }

    #[test]
    fn separable_filters_are_products_and_catmull_rom_is_radial() {
        for kind in ALL_FILTERS {
            let f = filter(kind, 4.0, 4.0);
            let (a, b) = (0.6, 1.3);
            let product = f.eval(a, 0.0) * f.eval(0.0, b) / f.eval(0.0, 0.0);
            if kind == FilterKind::CatmullRom {
                let r = (a * a + b * b).sqrt();
                assert!((f.eval(a, b) - f.eval(r, 0.0)).abs() < 1e-6);
                assert!((f.eval(a, b) - product).abs() > 1e-3);
            } else {
                assert!((f.eval(a, b) - product).abs() < 1e-6, "{kind:?}");
            }
        }
    }

    /// Midpoint rule over the support.
    fn integral(f: &Filter) -> f64 {
        let (rx, ry) = f.radius();
        let n = 400;
        let (hx, hy) = (2.0 * rx as f64 / n as f64, 2.0 * ry as f64 / n as f64);
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let x = -rx as f64 + (i as f64 + 0.5) * hx;
                let y = -ry as f64 + (j as f64 + 0.5) * hy;
                sum += f.eval(x as f32, y as f32) as f64;
            }
        }
        sum * hx * hy
    }

    #[test]
    fn filters_integrate_to_the_closed_forms() {
        // Box: the area; triangle: r_x·r_y; Mitchell–Netravali's cubic integrates to 1 over [−2, 2],
        // so the scaled one to (r_x/2)·(r_y/2); the radial Catmull-Rom to
        // 2π·(r/2)²·∫₀² k(s)·s ds = 2π·(r/2)²·(0.175 − 0.058333…).
        let expected = [
            (FilterKind::Box, 9.0),
            (FilterKind::Triangle, 2.25),
            (FilterKind::Mitchell, 0.5625),
            (
                FilterKind::CatmullRom,
                2.0 * std::f64::consts::PI * 0.5625 * (0.175 - 0.7 / 12.0),
            ),
        ];
        for (kind, value) in expected {
            let got = integral(&filter(kind, 3.0, 3.0));
            assert!((got - value).abs() < 2e-3 * value, "{kind:?}: {got} vs {value}");
        }
        for kind in ALL_FILTERS {
            assert!(integral(&filter(kind, 2.0, 3.0)) > 0.0, "{kind:?}");
        }
    }

    #[test]
    fn cubics_have_negative_lobes_where_expected() {
        for kind in [FilterKind::CatmullRom, FilterKind::Mitchell] {
            let f = filter(kind, 4.0, 4.0);
            // Kernel units equal pixels at width 4: positive inside |x| < 1, negative in (1, 2).
            assert!(f.eval(0.5, 0.0) > 0.0, "{kind:?}");
            assert!(f.eval(1.5, 0.0) < 0.0, "{kind:?}");
            assert!(f.eval(-1.5, 0.0) < 0.0, "{kind:?}");
        }
        // Catmull-Rom interpolates: 0 at the integers.
        let cr = filter(FilterKind::CatmullRom, 4.0, 4.0);
        assert!(cr.eval(1.0, 0.0).abs() < 1e-7);
        // Mitchell at x = 1.5 (closed form): (−7/3·3.375 + 12·2.25 − 20·1.5 + 32/3)/6 · 8/9.
        let m = filter(FilterKind::Mitchell, 4.0, 4.0);
        let k = (-7.0 / 3.0 * 3.375 + 12.0 * 2.25 - 20.0 * 1.5 + 32.0 / 3.0) / 6.0 * (8.0 / 9.0);
        assert!((m.eval(1.5, 0.0) - k).abs() < 1e-6);
        for kind in [
            FilterKind::Box,
            FilterKind::Triangle,
            FilterKind::Gaussian,
            FilterKind::BlackmanHarris,
        ] {
            let f = default_filter(kind);
            for i in 0..50 {
                let d = i as f32 * 0.03;
                assert!(f.eval(d, d * 0.5) >= 0.0, "{kind:?}");
            }
        }
    }

    #[test]
    fn gaussian_is_renderman_s_formula() {
        let f = filter(FilterKind::Gaussian, 2.0, 3.0);
        for (x, y) in [(0.3f32, 0.2f32), (0.9, -1.4), (-1.0, 1.5)] {
            let (xx, yy) = (x * 2.0 / 2.0, y * 2.0 / 3.0);
            let rman = (-2.0 * (xx * xx + yy * yy)).exp();
            assert!((f.eval(x, y) - rman).abs() < 1e-6);
        }
    }

    #[test]
    fn invalid_widths_are_errors() {
        for (wx, wy) in [
            (0.0, 2.0),
            (2.0, -1.0),
            (f32::NAN, 2.0),
            (2.0, f32::INFINITY),
            (-0.0, 1.0),
        ] {
            let spec = PixelFilter {
                kind: FilterKind::Mitchell,
                width_x: wx,
                width_y: wy,
            };
            let err = Filter::new(&spec).unwrap_err();
            assert!(matches!(err, FilterError::InvalidWidth { .. }));
            assert!(err.to_string().contains("PixelFilter \"mitchell\""), "{err}");
        }
        assert!(Filter::new(&PixelFilter::default()).is_ok());
    }

    #[test]
    fn default_widths() {
        assert_eq!(
            ALL_FILTERS.map(default_width),
            [1.0, 2.0, 2.0, 4.0, 4.0, 3.0],
            "box, triangle, gaussian, catmull-rom, mitchell, blackman-harris"
        );
        assert_eq!(
            default_width(PixelFilter::default().kind),
            PixelFilter::default().width_x
        );
    }
}
