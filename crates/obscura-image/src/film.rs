//! The film: AOV accumulation with the pixel filter, tile by tile.
//!
//! Every camera sample is splatted onto the pixels its filter reaches: pixel `(i, j)` receives the
//! weight `w = filter.eval(i + 0.5 − x, j + 0.5 − y)` and adds `w·Ci` and `w·alpha`; the resolved
//! value is `Σ w·Ci / Σ w` (0 where `Σ w ≤ 0`, which negative lobes make possible, or where no sample
//! reached). `z`, `N`, `P`, `cameraDirection`, `albedo` and `uv` are not filtered (a filtered depth is a depth of
//! nothing): each pixel keeps the values of the sample nearest its centre among the samples that
//! landed inside the pixel itself, RenderMan's "closest" behaviour. A miss is a sample like any other
//! with `z = +∞` and `N = P = 0` ([`SampleValues::EMPTY`] with its camera direction), so a pixel
//! whose nearest sample missed reports `z = +∞`; ties in distance go to the smaller `z`.
//!
//! Threads fill [`FilmTile`]s, each covering a rectangle of pixels plus a margin of
//! `ceil(filter radius)` pixels, so that splats reaching into the neighbours are kept, then
//! [`Film::merge`] adds the weighted sums. Sums are kept in `f64`, so the order in which tiles are
//! merged changes a result by far less than an `f32` ulp.

use glam::{Vec2, Vec3};
use obscura_host::PixelRect;
use obscura_scene::Exposure;
use obscura_sdk::Rgb;

use crate::filter::Filter;
use crate::samples::FlowPixel;
use crate::samples::Truth;

/// What one camera sample contributes. Ci already multiplied by the projection's tint (the renderer
/// does that); everything else untinted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleValues {
    /// Beauty, premultiplied by coverage, times the projection's tint.
    pub ci: Rgb,
    /// Coverage: 1 for a hit, 0 for a miss.
    pub alpha: f32,
    /// Depth in the projection's deep metric; `+∞` for a miss.
    pub z: f32,
    /// Shading normal, world space; 0 for a miss.
    pub n: Vec3,
    /// Hit position, world space; 0 for a miss.
    pub p: Vec3,
    /// The camera ray's direction, world space (0 for a culled sample).
    pub camera_direction: Vec3,
    /// The textured base colour at the hit, linear (the material's colour when untextured); 0 for a
    /// miss.
    pub albedo: Rgb,
    /// The first texture coordinate set at the hit, as stored in the file; 0 for a miss or a surface
    /// without coordinates.
    pub uv: Vec2,
    /// Depths, camera-space position and normal, IDs: unfiltered, like `z`.
    pub truth: Truth,
    /// The pixel's optical flow: not a per-sample value; [`Film::pixel`] fills it from the flow pass
    /// ([`Film::set_flow`]).
    pub flow: FlowPixel,
    /// The sensor's values of the pixel: not a per-sample value; [`Film::pixel`] fills it from the
    /// sensor stage ([`Film::set_sensor`]).
    pub sensor: SensorPixel,
}

/// A pixel's values from the sensor stage (`obscura_sensor`): zero when no sensor is configured.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SensorPixel {
    /// The raw code in DN.
    pub raw: f32,
    /// The noise-free expected photoelectrons of the pixel's channel.
    pub electrons: f32,
}

/// The sensor stage's result over the film's crop, row by row: the processed beauty that replaces the
/// film's, and the planes of [`SensorPixel`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SensorPlanes {
    /// The ISP's linear output, reported as Ci.
    pub ci: Vec<Rgb>,
    /// Raw codes, DN.
    pub raw: Vec<f32>,
    /// Expected photoelectrons.
    pub electrons: Vec<f32>,
}

impl SampleValues {
    /// Nothing: black, alpha 0, `z = +∞`, zero vectors. What [`Film::pixel`] reports for a pixel no
    /// sample reached, and (with its `camera_direction` set) what a missed ray contributes.
    pub const EMPTY: SampleValues = SampleValues {
        ci: Rgb::BLACK,
        alpha: 0.0,
        z: f32::INFINITY,
        n: Vec3::ZERO,
        p: Vec3::ZERO,
        camera_direction: Vec3::ZERO,
        albedo: Rgb::BLACK,
        uv: Vec2::ZERO,
        truth: Truth::EMPTY,
        flow: FlowPixel::NONE,
        sensor: SensorPixel {
            raw: 0.0,
            electrons: 0.0,
        },
    };
}

/// One pixel's running sums and its nearest sample.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Accum {
    weight: f64,
    ci: [f64; 3],
    alpha: f64,
    /// Samples that landed inside this pixel.
    samples: u32,
    /// Squared distance of the nearest of them to the pixel centre (`+∞` before the first).
    nearest: f32,
    z: f32,
    n: Vec3,
    p: Vec3,
    camera_direction: Vec3,
    albedo: Rgb,
    uv: Vec2,
    truth: Truth,
}

impl Accum {
    const ZERO: Accum = Accum {
        weight: 0.0,
        ci: [0.0; 3],
        alpha: 0.0,
        samples: 0,
        nearest: f32::INFINITY,
        z: f32::INFINITY,
        n: Vec3::ZERO,
        p: Vec3::ZERO,
        camera_direction: Vec3::ZERO,
        albedo: Rgb::BLACK,
        uv: Vec2::ZERO,
        truth: Truth::EMPTY,
    };

    fn splat(&mut self, w: f32, v: &SampleValues) {
        let w = w as f64;
        self.weight += w;
        self.ci[0] += w * v.ci.r as f64;
        self.ci[1] += w * v.ci.g as f64;
        self.ci[2] += w * v.ci.b as f64;
        self.alpha += w * v.alpha as f64;
    }

    /// Whether a sample at squared distance `d2` with depth `z` beats the current nearest one.
    /// Deterministic whatever the order the candidates come in.
    fn is_nearer(&self, d2: f32, z: f32) -> bool {
        d2 < self.nearest || (d2 == self.nearest && z.total_cmp(&self.z).is_lt())
    }

    fn keep_if_nearer(&mut self, d2: f32, v: &SampleValues) {
        self.samples = self.samples.saturating_add(1);
        if self.is_nearer(d2, v.z) {
            self.nearest = d2;
            self.z = v.z;
            self.n = v.n;
            self.p = v.p;
            self.camera_direction = v.camera_direction;
            self.albedo = v.albedo;
            self.uv = v.uv;
            self.truth = v.truth;
        }
    }

    fn merge(&mut self, o: &Accum) {
        self.weight += o.weight;
        for c in 0..3 {
            self.ci[c] += o.ci[c];
        }
        self.alpha += o.alpha;
        self.samples = self.samples.saturating_add(o.samples);
        if o.samples > 0 && self.is_nearer(o.nearest, o.z) {
            self.nearest = o.nearest;
            self.z = o.z;
            self.n = o.n;
            self.p = o.p;
            self.camera_direction = o.camera_direction;
            self.albedo = o.albedo;
            self.uv = o.uv;
            self.truth = o.truth;
        }
    }

    fn resolve(&self) -> SampleValues {
        let mut v = SampleValues::EMPTY;
        if self.weight > 0.0 {
            let inv = 1.0 / self.weight;
            v.ci = Rgb::new(
                (self.ci[0] * inv) as f32,
                (self.ci[1] * inv) as f32,
                (self.ci[2] * inv) as f32,
            );
            v.alpha = (self.alpha * inv) as f32;
        }
        if self.samples > 0 {
            v.z = self.z;
            v.n = self.n;
            v.p = self.p;
            v.camera_direction = self.camera_direction;
            v.albedo = self.albedo;
            v.uv = self.uv;
            v.truth = self.truth;
        }
        v
    }
}

/// `r` clipped to `bounds`; an inverted or disjoint rectangle becomes an empty one (never one whose
/// `width()` would underflow).
fn clip(r: PixelRect, bounds: PixelRect) -> PixelRect {
    let x0 = r.x0.clamp(bounds.x0, bounds.x1);
    let y0 = r.y0.clamp(bounds.y0, bounds.y1);
    PixelRect {
        x0,
        x1: r.x1.clamp(x0, bounds.x1),
        y0,
        y1: r.y1.clamp(y0, bounds.y1),
    }
}

/// Index of absolute pixel `(x, y)` in row-major storage over `r`, if inside.
fn index_in(r: PixelRect, x: i64, y: i64) -> Option<usize> {
    let inside = x >= r.x0 as i64 && x < r.x1 as i64 && y >= r.y0 as i64 && y < r.y1 as i64;
    inside.then(|| (y - r.y0 as i64) as usize * r.width() as usize + (x - r.x0 as i64) as usize)
}

/// The accumulated image: the full format size (for the display window) and the pixels of the crop.
#[derive(Debug, Clone)]
pub struct Film {
    width: u32,
    height: u32,
    crop: PixelRect,
    filter: Filter,
    pixels: Vec<Accum>,
    /// The flow pass's result over the crop, row by row, once set.
    flow: Option<Vec<FlowPixel>>,
    /// `Exposure`, applied to Ci when a pixel is resolved.
    exposure: Exposure,
    /// The sensor stage's planes over the crop, once set.
    sensor: Option<SensorPlanes>,
}

impl Film {
    /// The bytes the film stores per pixel of its crop (for the memory estimate of a job).
    pub const BYTES_PER_PIXEL: usize = std::mem::size_of::<Accum>();

    /// An empty film of format `width`×`height` that stores the pixels of `crop`.
    ///
    /// A crop reaching past the format is clipped to it; an inverted one is empty.
    #[must_use]
    pub fn new(width: u32, height: u32, crop: PixelRect, filter: Filter) -> Self {
        let format = PixelRect {
            x0: 0,
            x1: width,
            y0: 0,
            y1: height,
        };
        let crop = clip(crop, format);
        Film {
            width,
            height,
            crop,
            filter,
            pixels: vec![Accum::ZERO; crop.len()],
            flow: None,
            exposure: Exposure::default(),
            sensor: None,
        }
    }

    /// Sets the `Exposure` every resolved pixel's Ci goes through, `(c·gain)^(1/gamma)` per component
    /// after the pixel filter (RISpec 3.2 §4.1.2). Alpha, depth and the other AOVs, albedo included
    /// (a reflectance, not light), are not exposed.
    pub fn set_exposure(&mut self, exposure: Exposure) {
        self.exposure = exposure;
    }

    /// Stores the flow pass's pixels (the crop's, row by row), reported by [`Film::pixel`].
    ///
    /// # Panics
    /// When `flow` does not hold one entry per crop pixel (a bug of the caller).
    pub fn set_flow(&mut self, flow: Vec<FlowPixel>) {
        assert_eq!(flow.len(), self.pixels.len(), "one flow pixel per crop pixel");
        self.flow = Some(flow);
    }

    /// Stores the sensor stage's planes (the crop's, row by row): from then on [`Film::pixel`] reports
    /// their processed beauty as Ci (in place of the exposed film's) and their raw and electron values.
    ///
    /// # Panics
    /// When a plane does not hold one entry per crop pixel (a bug of the caller).
    pub fn set_sensor(&mut self, planes: SensorPlanes) {
        let n = self.pixels.len();
        assert!(
            planes.ci.len() == n && planes.raw.len() == n && planes.electrons.len() == n,
            "one sensor value per crop pixel"
        );
        self.sensor = Some(planes);
    }

    /// The format size `(W, H)`: the display window.
    #[must_use]
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The pixels stored: the data window.
    #[must_use]
    pub fn crop(&self) -> PixelRect {
        self.crop
    }

    /// The pixel filter.
    #[must_use]
    pub fn filter(&self) -> &Filter {
        &self.filter
    }

    /// A tile accumulator covering `rect` (pixels), to be filled by one thread, then merged.
    ///
    /// `rect` is clipped to the crop. The tile also stores a margin of `ceil(filter radius)` pixels
    /// around it (inside the crop), enough for every splat of a sample that lies in `rect`.
    #[must_use]
    pub fn tile(&self, rect: PixelRect) -> FilmTile {
        let rect = clip(rect, self.crop);
        let (rx, ry) = self.filter.radius();
        // Saturating float → int casts: an absurd filter gives a margin covering the whole crop.
        let (mx, my) = (rx.ceil() as u32, ry.ceil() as u32);
        let region = if rect.is_empty() {
            rect
        } else {
            clip(
                PixelRect {
                    x0: rect.x0.saturating_sub(mx),
                    x1: rect.x1.saturating_add(mx),
                    y0: rect.y0.saturating_sub(my),
                    y1: rect.y1.saturating_add(my),
                },
                self.crop,
            )
        };
        FilmTile {
            rect,
            region,
            filter: self.filter,
            pixels: vec![Accum::ZERO; region.len()],
        }
    }

    /// Adds a finished tile's sums into the film (in any order; the result does not depend on it
    /// beyond `f64` rounding).
    pub fn merge(&mut self, tile: FilmTile) {
        let region = clip(tile.region, self.crop);
        for y in region.y0..region.y1 {
            for x in region.x0..region.x1 {
                let (Some(src), Some(dst)) = (
                    index_in(tile.region, x as i64, y as i64),
                    index_in(self.crop, x as i64, y as i64),
                ) else {
                    continue;
                };
                self.pixels[dst].merge(&tile.pixels[src]);
            }
        }
    }

    /// Resolved values of pixel (x, y) (absolute pixel coordinates inside the crop), Ci exposed
    /// ([`Film::set_exposure`]).
    ///
    /// [`SampleValues::EMPTY`] outside the crop and where nothing was recorded.
    #[must_use]
    pub fn pixel(&self, x: u32, y: u32) -> SampleValues {
        index_in(self.crop, x as i64, y as i64).map_or(SampleValues::EMPTY, |i| {
            let mut v = self.pixels[i].resolve();
            if let Some(flow) = &self.flow {
                v.flow = flow[i];
            }
            v.ci = self.exposed(v.ci);
            if let Some(s) = &self.sensor {
                v.ci = s.ci[i];
                v.sensor = SensorPixel {
                    raw: s.raw[i],
                    electrons: s.electrons[i],
                };
            }
            v
        })
    }

    /// The film's own Ci at pixel (x, y), exposed but without the sensor stage's processed beauty (the
    /// noiseless linear image the sensor was given); black outside the crop.
    #[must_use]
    pub fn resolved_ci(&self, x: u32, y: u32) -> Rgb {
        index_in(self.crop, x as i64, y as i64)
            .map_or(Rgb::BLACK, |i| self.exposed(self.pixels[i].resolve().ci))
    }

    /// `c` through the film's `Exposure` (unchanged when it is the identity).
    fn exposed(&self, c: Rgb) -> Rgb {
        let e = self.exposure;
        if e.is_identity() {
            c
        } else {
            Rgb::new(e.apply(c.r), e.apply(c.g), e.apply(c.b))
        }
    }

    /// Fraction of the crop's pixels in which at least one sample landed (0 for an empty crop): how
    /// far an interrupted render got.
    #[must_use]
    pub fn coverage(&self) -> f32 {
        if self.pixels.is_empty() {
            return 0.0;
        }
        let covered = self.pixels.iter().filter(|p| p.samples > 0).count();
        (covered as f64 / self.pixels.len() as f64) as f32
    }
}

/// The sums for one rectangle of pixels plus a margin, filled by one thread.
#[derive(Debug, Clone)]
pub struct FilmTile {
    rect: PixelRect,
    region: PixelRect,
    filter: Filter,
    pixels: Vec<Accum>,
}

impl FilmTile {
    /// The pixels this tile was made for (clipped to the crop).
    #[must_use]
    pub fn rect(&self) -> PixelRect {
        self.rect
    }

    /// Adds a sample at absolute raster position (x, y) (pixel centres at i+0.5).
    ///
    /// Ci and alpha are splatted with the filter to every pixel of the tile and its margin within the
    /// filter radius (weight `Filter::eval(pixel centre − position)`); pixels outside the crop get
    /// nothing. The sample also competes for the unfiltered channels of the pixel it lies in (the
    /// pixel `(floor x, floor y)`), where the sample nearest the centre wins. A non-finite position
    /// is ignored.
    ///
    /// Each sample goes to one tile: the one whose [`rect`](Self::rect) contains its position clamped
    /// into the crop. Samples of pixels outside the crop (up to `ceil(radius)` pixels out, as
    /// RenderMan takes them so that a cropped render equals the same region of a full one) thus reach
    /// the crop's edge pixels; splats that would land beyond a tile's margin are dropped.
    pub fn add_sample(&mut self, x: f32, y: f32, v: &SampleValues) {
        if !x.is_finite() || !y.is_finite() || self.region.is_empty() {
            return;
        }
        let (rx, ry) = self.filter.radius();
        // Candidate columns: centres i + 0.5 with |i + 0.5 − x| ≤ rx, widened by one so that
        // rounding never drops a pixel; `eval` decides the support exactly.
        let span = |p: f32, r: f32, lo: u32, hi: u32| {
            let (p, r) = (p as f64, r as f64);
            let first = ((p - 0.5 - r).ceil() - 1.0).max(lo as f64) as i64;
            let last = ((p - 0.5 + r).floor() + 1.0).min(hi as f64 - 1.0) as i64;
            (first, last)
        };
        let (cx0, cx1) = span(x, rx, self.region.x0, self.region.x1);
        let (cy0, cy1) = span(y, ry, self.region.y0, self.region.y1);
        let width = self.region.width() as usize;
        for j in cy0..=cy1 {
            let dy = (j as f32 + 0.5) - y;
            let row = (j - self.region.y0 as i64) as usize * width;
            for i in cx0..=cx1 {
                let w = self.filter.eval((i as f32 + 0.5) - x, dy);
                if w != 0.0 {
                    self.pixels[row + (i - self.region.x0 as i64) as usize].splat(w, v);
                }
            }
        }
        let (px, py) = (x.floor() as i64, y.floor() as i64);
        if let Some(k) = index_in(self.region, px, py) {
            let (dx, dy) = (px as f32 + 0.5 - x, py as f32 + 0.5 - y);
            self.pixels[k].keep_if_nearer(dx * dx + dy * dy, v);
        }
    }
}

#[cfg(test)]
mod tests;
