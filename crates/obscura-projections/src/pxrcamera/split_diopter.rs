//! The split diopter: a focus distance that depends on where the sample lies on the screen.
//!
//! Diopter `i` covers the side of a straight edge across the image. The edge runs at `angle` degrees
//! clockwise from up; `ξ = ((sₑ − c)·m)/h` measures the position across it, with `c` the centre of
//! the screen window, `h` half its width (so the centre-to-left/right-edge distance is 1 when the edge
//! is vertical) and `m = (cos angle, −sin angle)` the edge's right-hand normal. Diopter 1 covers
//! `ξ > offset1`, diopter 2 `ξ < offset2`. Across a band of width `width_i` centred on the edge the
//! focus distance blends with the smoothstep `S(x) = 3x² − 2x³` of `x = clamp(½ + (ξ − offset1)/width1)`
//! for diopter 1 and of `x = clamp(½ − (ξ − offset2)/width2)` for diopter 2 (a hard step, `x ≥ ½`,
//! when the width is 0):
//!
//! `z(ξ) = lerp(lerp(z₀, focusDistance1, S₁), focusDistance2, S₂)` (`S₂ = 0` with one diopter),
//!
//! `z₀` the lens's own axial focus distance. Nested lerps of positive distances stay positive, and
//! where the two diopters overlap diopter 2 wins.

use obscura_sdk::{ParamDecl, Params, PluginError, Point2, ScreenWindow, ValueRange};

/// The Hydra names (`HdCameraTokens`) of the split-diopter parameters.
pub(super) const COUNT: &str = "splitDiopter:count";
/// See [`COUNT`].
pub(super) const ANGLE: &str = "splitDiopter:angle";
const OFFSET: [&str; 2] = ["splitDiopter:offset1", "splitDiopter:offset2"];
const WIDTH: [&str; 2] = ["splitDiopter:width1", "splitDiopter:width2"];
/// See [`COUNT`].
pub(super) const FOCUS: [&str; 2] = ["splitDiopter:focusDistance1", "splitDiopter:focusDistance2"];

/// The parameter declarations.
pub(super) fn params() -> Vec<ParamDecl> {
    let (finite, non_negative) = (super::FINITE, super::NON_NEGATIVE);
    let mut v = vec![
        ParamDecl::int(COUNT, 0)
            .range(ValueRange::closed(0.0, 2.0))
            .doc("split diopter: number of diopter regions, 0 (off), 1 or 2; needs depth of field"),
        ParamDecl::float(ANGLE, 0.0)
            .range(finite)
            .doc("degrees the diopters' edges turn clockwise from up (0 = vertical edges)"),
    ];
    for i in 0..2 {
        let n = i + 1;
        v.push(ParamDecl::float(OFFSET[i], 0.0).range(finite).doc(match n {
            1 => "edge of diopter 1 across the image (it covers the side right of the edge at angle 0); centre to left/right edge = 1",
            _ => "edge of diopter 2 across the image (it covers the side left of the edge at angle 0); centre to left/right edge = 1",
        }));
        v.push(ParamDecl::float(WIDTH[i], 0.0).range(non_negative).doc(match n {
            1 => "width of the band across diopter 1's edge over which the focus distance blends (smoothstep); 0 = hard edge",
            _ => "width of the band across diopter 2's edge over which the focus distance blends (smoothstep); 0 = hard edge",
        }));
        v.push(
            ParamDecl::float(FOCUS[i], 1.0)
                .range(ValueRange::greater_than(0.0))
                .doc(match n {
                    1 => "focus distance (along the view axis, scene units) where diopter 1 covers the image",
                    _ => "focus distance (along the view axis, scene units) where diopter 2 covers the image",
                }),
        );
    }
    v
}

/// One diopter.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Region {
    offset: f32,
    /// `1/width`, infinite for a hard edge.
    inv_width: f32,
    focus: f32,
    /// +1 for diopter 1 (covers ξ > offset), −1 for diopter 2.
    side: f32,
}

/// The split diopter of a `PxrCamera` (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct SplitDiopter {
    centre: Point2,
    /// `m/h`.
    across: (f32, f32),
    regions: Vec<Region>,
}

/// `3x² − 2x³` of `x` clamped to [0, 1].
#[inline(always)]
pub(super) fn smoothstep(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

impl SplitDiopter {
    /// The split diopter the parameters describe; `None` when `splitDiopter:count` is 0.
    pub(super) fn from_params(p: &Params, window: ScreenWindow) -> Result<Option<Self>, PluginError> {
        let count = p.int(COUNT)?;
        if count <= 0 {
            return Ok(None);
        }
        let angle = (p.float(ANGLE)? as f64).to_radians();
        let h = 0.5 * (window.right - window.left) as f64;
        let mut regions = Vec::new();
        for i in 0..(count.min(2) as usize) {
            let width = p.float(WIDTH[i])?;
            regions.push(Region {
                offset: p.float(OFFSET[i])?,
                inv_width: if width > 0.0 { 1.0 / width } else { f32::INFINITY },
                focus: p.float(FOCUS[i])?,
                side: if i == 0 { 1.0 } else { -1.0 },
            });
        }
        Ok(Some(SplitDiopter {
            centre: Point2::new(
                0.5 * (window.left + window.right),
                0.5 * (window.bottom + window.top),
            ),
            across: ((angle.cos() / h) as f32, (-angle.sin() / h) as f32),
            regions,
        }))
    }

    /// The focus distances the diopters set (to check them against `axial`).
    pub(super) fn focus_distances(&self) -> impl Iterator<Item = f32> + '_ {
        self.regions.iter().map(|r| r.focus)
    }

    /// `z(ξ)` at enhanced screen position `se`, with `main` the lens's own axial focus distance.
    #[inline(always)]
    pub(super) fn focus_distance(&self, se: Point2, main: f32) -> f32 {
        let xi = (se.x - self.centre.x) * self.across.0 + (se.y - self.centre.y) * self.across.1;
        let mut z = main;
        for r in &self.regions {
            let d = r.side * (xi - r.offset);
            let s = if r.inv_width.is_finite() {
                smoothstep(0.5 + d * r.inv_width)
            } else if d >= 0.0 {
                1.0
            } else {
                0.0
            };
            z += (r.focus - z) * s;
        }
        z
    }
}
