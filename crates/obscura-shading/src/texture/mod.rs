//! Textures filtered by the camera ray's footprint.
//!
//! A [`Texture`] is a mip pyramid of RGBA texels read as linear values: level 0 is the image as
//! decoded (`image::decode`: sRGB or linear as the format and the texture's colour space say), and
//! each further level halves each side (rounding down, at least 1) with an exact box average of the
//! level above **in linear space** (a texel straddling two target texels is split by area), so a
//! level's mean equals the image's mean. 8-bit images stay 8-bit in memory (sRGB-encoded when they are
//! colour, each level encoded again after averaging), deeper ones are kept as `f32`.
//!
//! A lookup takes a [`Footprint`]: the ellipse of texture space that the ray's cone covers at the hit
//! ([`footprint`]), centre `c` and two conjugate semi-axes `a`, `b` in texture coordinates. The filter
//! is EWA (Heckbert 1989) with a Gaussian weight:
//!
//! - the minor axis is lengthened so the ellipse is at most [`MAX_ANISOTROPY`] times longer than wide;
//! - the level is `ℓ = L − 1 + log₂(minor)` (`L` levels): the one where the minor axis spans about a
//!   texel; the two levels around `ℓ` are filtered and blended linearly (trilinear across levels);
//! - on a level `W × H`, with the axes in texels `(a_x, a_y) = (a_u W, a_v H)` (same for `b`), the
//!   quadratic form `Q(x, y) = A x² + B x y + C y²` with `A = a_y² + b_y² + 1`,
//!   `B = −2(a_x a_y + b_x b_y)`, `C = a_x² + b_x² + 1`, divided by `F = AC − B²/4`, is below 1
//!   inside the ellipse widened by one texel (the reconstruction term); every texel centre with
//!   `Q < 1` is weighted by `exp(−2 Q)` (tabulated in 128 steps) and the weights normalised.
//!
//! A footprint whose axes differ by less than 2× is filtered trilinearly instead: bilinear on
//! the two levels around `ℓ = L − 1 + log₂(1.22·√(ab))`, where a texel is 1.22 footprint radii and the
//! bilinear tent spreads like the Gaussian (σ = 0.41 texel = r/2); EWA costs several times more for a
//! result within a few per cent.
//!
//! Wrap modes apply per texel index (repeat, clamp to edge, mirror). A sampler asking for `NEAREST`
//! magnification returns the nearest level-0 texel when the whole footprint (its major axis) is
//! smaller than a texel, and filters like any other texture when minifying in any direction.

pub mod footprint;
pub mod image;
mod storage;

use glam::{Vec2, Vec4};
use obscura_scene::texture::Wrap;

pub use footprint::Footprint;
pub(crate) use storage::Texels;

/// The longest ratio of the footprint ellipse's axes the filter honours; longer ellipses are widened
/// (pbrt's choice: beyond this, EWA's cost grows without a visible difference).
pub const MAX_ANISOTROPY: f32 = 16.0;

/// One level of the pyramid.
#[derive(Debug, Clone, PartialEq)]
struct Level {
    width: u32,
    height: u32,
    texels: Texels,
}

impl Level {
    /// The texel at integer coordinates `(x, y)` after wrapping.
    #[inline]
    fn texel(&self, x: i64, y: i64, wrap: (Wrap, Wrap)) -> Vec4 {
        let x = wrap_index(x, self.width, wrap.0);
        let y = wrap_index(y, self.height, wrap.1);
        self.texels.get(y * self.width as usize + x)
    }

    /// Bilinear interpolation at texture coordinates `uv` (texel centres at `(i + ½)/W`).
    fn bilinear(&self, uv: Vec2, wrap: (Wrap, Wrap)) -> Vec4 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        // Each row and column index wrapped once, not once per texel.
        let (xa, xb) = (
            wrap_index(x0, self.width, wrap.0),
            wrap_index(x0 + 1, self.width, wrap.0),
        );
        let w = self.width as usize;
        let ya = wrap_index(y0, self.height, wrap.1) * w;
        let yb = wrap_index(y0 + 1, self.height, wrap.1) * w;
        let t = |i: usize| self.texels.get(i);
        let top = t(ya + xa).lerp(t(ya + xb), fx);
        let bottom = t(yb + xa).lerp(t(yb + xb), fx);
        top.lerp(bottom, fy)
    }

    /// The next smaller level: each side halved (rounded down, at least 1) by an exact box average.
    fn halve(&self) -> Level {
        let (w, h) = ((self.width / 2).max(1), (self.height / 2).max(1));
        let wx = box_weights(self.width, w);
        let wy = box_weights(self.height, h);
        let linear = self.texels.decode();
        let mut rows = vec![Vec4::ZERO; (w * self.height) as usize];
        for y in 0..self.height as usize {
            let src = &linear[y * self.width as usize..(y + 1) * self.width as usize];
            for (x, taps) in wx.iter().enumerate() {
                rows[y * w as usize + x] = taps.iter().map(|&(i, k)| src[i] * k).sum();
            }
        }
        let mut texels = vec![Vec4::ZERO; (w * h) as usize];
        for (y, taps) in wy.iter().enumerate() {
            for x in 0..w as usize {
                texels[y * w as usize + x] = taps.iter().map(|&(j, k)| rows[j * w as usize + x] * k).sum();
            }
        }
        Level {
            width: w,
            height: h,
            texels: self.texels.encode_like(texels),
        }
    }
}

/// For each of `to` target texels, the source texels of a length-`from` row it covers and the share
/// of each (summing to 1): the exact box filter from `from` to `to` texels.
fn box_weights(from: u32, to: u32) -> Vec<Vec<(usize, f32)>> {
    let scale = f64::from(from) / f64::from(to);
    (0..to)
        .map(|i| {
            let (lo, hi) = (f64::from(i) * scale, f64::from(i + 1) * scale);
            let mut taps = Vec::new();
            let mut j = lo.floor() as usize;
            while (j as f64) < hi && j < from as usize {
                let overlap = hi.min(j as f64 + 1.0) - lo.max(j as f64);
                if overlap > 0.0 {
                    taps.push((j, (overlap / scale) as f32));
                }
                j += 1;
            }
            taps
        })
        .collect()
}

/// Footprints whose axes differ by less than this ratio are filtered trilinearly, at a quarter of
/// EWA's cost and within a few per cent of its result (a surface seen within 60° of head-on).
const ISOTROPIC: f32 = 2.0;

/// The texel size, in footprint radii, at which a bilinear tent (σ ≈ 0.41 texel) spreads like the
/// footprint's Gaussian (σ = r/2).
const TENT_TEXELS_PER_RADIUS: f32 = 1.22;

/// Entries of the Gaussian weight table over `Q ∈ [0, 1)`.
const WEIGHTS: usize = 128;

/// `exp(−2Q)` for `Q ∈ [0, 1)` from a table of [`WEIGHTS`] entries (pbrt's choice: the filter's
/// shape needs no more precision, and `exp` per texel is most of EWA's cost).
#[inline]
fn gaussian(q: f32) -> f32 {
    static TABLE: std::sync::OnceLock<[f32; WEIGHTS]> = std::sync::OnceLock::new();
    let table =
        TABLE.get_or_init(|| std::array::from_fn(|i| (-2.0 * (i as f32 + 0.5) / WEIGHTS as f32).exp()));
    table[((q * WEIGHTS as f32) as usize).min(WEIGHTS - 1)]
}

/// Texel index `i` of a row of `n` wrapped by `wrap`.
#[inline]
fn wrap_index(i: i64, n: u32, wrap: Wrap) -> usize {
    let n = i64::from(n);
    if (0..n).contains(&i) {
        return i as usize;
    }
    let r = match wrap {
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Mirror => {
            let m = i.rem_euclid(2 * n);
            if m < n { m } else { 2 * n - 1 - m }
        }
    };
    r as usize
}

/// A mip-mapped texture in linear RGBA with its wrap modes.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    levels: Vec<Level>,
    wrap: (Wrap, Wrap),
    nearest: bool,
}

impl Texture {
    /// The pyramid of `image` (see the module documentation). An empty image becomes one black
    /// texel.
    #[must_use]
    pub fn new(image: image::LinearImage, wrap: (Wrap, Wrap), nearest: bool) -> Texture {
        let texels = Texels::Float(image.texels.into_iter().map(Vec4::from).collect());
        Self::from_texels(image.width, image.height, texels, wrap, nearest)
    }

    /// The pyramid of a decoded image kept as `texels` (level 0 as given, each further level in the
    /// same storage).
    pub(crate) fn from_texels(
        width: u32,
        height: u32,
        texels: Texels,
        wrap: (Wrap, Wrap),
        nearest: bool,
    ) -> Texture {
        let mut level = if width == 0 || height == 0 || texels.len() != width as usize * height as usize {
            Level {
                width: 1,
                height: 1,
                texels: Texels::Float(vec![Vec4::new(0.0, 0.0, 0.0, 1.0)]),
            }
        } else {
            Level {
                width,
                height,
                texels,
            }
        };
        let mut levels = Vec::new();
        while level.width > 1 || level.height > 1 {
            let next = level.halve();
            levels.push(level);
            level = next;
        }
        levels.push(level);
        Texture {
            levels,
            wrap,
            nearest,
        }
    }

    /// The number of mip levels.
    #[must_use]
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// `(width, height)` of level `level` (clamped to the last level).
    #[must_use]
    pub fn level_size(&self, level: usize) -> (u32, u32) {
        let l = &self.levels[level.min(self.levels.len() - 1)];
        (l.width, l.height)
    }

    /// The texel `(x, y)` of level `level`, wrapped.
    #[must_use]
    pub fn texel(&self, level: usize, x: i64, y: i64) -> Vec4 {
        self.levels[level.min(self.levels.len() - 1)].texel(x, y, self.wrap)
    }

    /// Bytes held by the texels of every level.
    #[must_use]
    pub fn memory_bytes(&self) -> usize {
        self.levels.iter().map(|l| l.texels.bytes()).sum()
    }

    /// The unfiltered texel of level 0 under `uv`: what a lookup without a footprint sees.
    #[must_use]
    pub fn nearest(&self, uv: Vec2) -> Vec4 {
        let l = &self.levels[0];
        let x = (uv.x * l.width as f32).floor();
        let y = (uv.y * l.height as f32).floor();
        if !(x.is_finite() && y.is_finite()) {
            return Vec4::ZERO;
        }
        l.texel(x as i64, y as i64, self.wrap)
    }

    /// The texture filtered over `footprint` (see the module documentation).
    #[must_use]
    pub fn filter(&self, footprint: &Footprint) -> Vec4 {
        let c = footprint.center;
        if !c.is_finite() {
            return Vec4::ZERO;
        }
        let (mut a, mut b) = (footprint.a, footprint.b);
        if !(a.is_finite() && b.is_finite()) {
            return self.levels[0].bilinear(c, self.wrap);
        }
        if a.length_squared() < b.length_squared() {
            std::mem::swap(&mut a, &mut b);
        }
        let (major, mut minor) = (a.length(), b.length());
        if major == 0.0 {
            return if self.nearest {
                self.nearest(c)
            } else {
                self.levels[0].bilinear(c, self.wrap)
            };
        }
        if minor * MAX_ANISOTROPY < major {
            let widened = major / MAX_ANISOTROPY;
            b = if minor > 0.0 {
                b * (widened / minor)
            } else {
                a.perp() * (widened / major)
            };
            minor = widened;
        }
        let top = (self.levels.len() - 1) as f32;
        if self.nearest && top + major.log2() <= 0.0 {
            return self.nearest(c);
        }
        if major <= ISOTROPIC * minor {
            return self.trilinear(c, (major * minor).sqrt());
        }
        let lod = top + minor.log2();
        let lod = lod.clamp(0.0, top);
        let l0 = lod.floor() as usize;
        let f = lod - l0 as f32;
        let v0 = self.ewa(l0, c, a, b);
        if f == 0.0 || l0 + 1 >= self.levels.len() {
            return v0;
        }
        v0.lerp(self.ewa(l0 + 1, c, a, b), f)
    }

    /// The texture filtered trilinearly over a round footprint of radius `radius` (texture units)
    /// at `c`: bilinear on the two levels where a texel is about 1.22 radii, so the tent's spread
    /// matches the footprint's Gaussian (σ = r/2 against 0.41 texel). What [`Texture::filter`] does
    /// for near-circular footprints.
    #[must_use]
    pub fn trilinear(&self, c: Vec2, radius: f32) -> Vec4 {
        if !c.is_finite() {
            return Vec4::ZERO;
        }
        let lod = self.tent_lod(radius);
        let l0 = lod.floor() as usize;
        let f = lod - l0 as f32;
        let v0 = self.levels[l0].bilinear(c, self.wrap);
        if f == 0.0 || l0 + 1 >= self.levels.len() {
            return v0;
        }
        v0.lerp(self.levels[l0 + 1].bilinear(c, self.wrap), f)
    }

    /// The texture over a round footprint of radius `radius` (texture units) at `c`, on one level:
    /// bilinear on the level nearest to [`Texture::trilinear`]'s (rounded, not blended). What
    /// secondary rays read: their cones are already wide, and the level's half-step of blur is far
    /// below what a bounce averages over, at half trilinear's texel reads.
    #[must_use]
    pub fn bilinear_at(&self, c: Vec2, radius: f32) -> Vec4 {
        if !c.is_finite() {
            return Vec4::ZERO;
        }
        self.levels[self.tent_lod(radius).round() as usize].bilinear(c, self.wrap)
    }

    /// The (fractional) mip level where a texel is [`TENT_TEXELS_PER_RADIUS`] footprint radii of
    /// `radius` (texture units), within the pyramid; 0 for a radius that is not a number.
    fn tent_lod(&self, radius: f32) -> f32 {
        let top = (self.levels.len() - 1) as f32;
        let lod = top + (TENT_TEXELS_PER_RADIUS * radius).log2();
        if lod.is_nan() { 0.0 } else { lod.clamp(0.0, top) }
    }

    /// True when every texel the box `lo..hi` (texture coordinates) can read is black (RGB 0), judged
    /// on the level where the box, grown by one level-0 texel for bilinear reconstruction, spans at
    /// most 8 texels (a coarser texel is the average of the finer ones it covers, so it is black
    /// only where they all are, up to 8-bit rounding). False for a box that is not finite or spans
    /// more than the level can check.
    #[must_use]
    pub fn is_black_over(&self, lo: Vec2, hi: Vec2) -> bool {
        let base = &self.levels[0];
        let size0 = Vec2::new(base.width as f32, base.height as f32);
        let (lo, hi) = (lo - size0.recip(), hi + size0.recip());
        if !(lo.is_finite() && hi.is_finite()) {
            return false;
        }
        let span = ((hi - lo) * size0).max_element();
        let top = self.levels.len() - 1;
        let level = ((span / 8.0).log2().ceil().max(0.0) as usize).min(top);
        let l = &self.levels[level];
        let size = Vec2::new(l.width as f32, l.height as f32);
        let (x0, y0) = ((lo.x * size.x).floor() as i64, (lo.y * size.y).floor() as i64);
        let (x1, y1) = ((hi.x * size.x).floor() as i64, (hi.y * size.y).floor() as i64);
        if x1 - x0 > 16 || y1 - y0 > 16 {
            return false;
        }
        (y0..=y1).all(|y| {
            (x0..=x1).all(|x| {
                let t = l.texel(x, y, self.wrap);
                t.x <= 0.0 && t.y <= 0.0 && t.z <= 0.0
            })
        })
    }

    /// EWA over level `level` (see the module documentation).
    fn ewa(&self, level: usize, c: Vec2, a: Vec2, b: Vec2) -> Vec4 {
        let l = &self.levels[level];
        let size = Vec2::new(l.width as f32, l.height as f32);
        let (a, b) = (a * size, b * size);
        let s = c * size - Vec2::splat(0.5);
        let mut qa = a.y * a.y + b.y * b.y + 1.0;
        let mut qb = -2.0 * (a.x * a.y + b.x * b.y);
        let mut qc = a.x * a.x + b.x * b.x + 1.0;
        let f = qa * qc - 0.25 * qb * qb;
        if !(f > 0.0 && f.is_finite()) {
            return l.bilinear(c, self.wrap);
        }
        (qa, qb, qc) = (qa / f, qb / f, qc / f);
        // The ellipse's bounding box: |x| ≤ 2√(C·det)/det, |y| ≤ 2√(A·det)/det with det = 4AC − B².
        let det = 4.0 * qa * qc - qb * qb;
        let half_x = 2.0 * (qc * det).sqrt() / det;
        let half_y = 2.0 * (qa * det).sqrt() / det;
        // Bound the work for footprints the level cannot hold (a miscomputed huge ellipse).
        let (half_x, half_y) = (half_x.min(size.x.max(8.0)), half_y.min(size.y.max(8.0)));
        let (y0, y1) = ((s.y - half_y).ceil() as i64, (s.y + half_y).floor() as i64);
        let mut sum = Vec4::ZERO;
        let mut weight = 0.0f32;
        let w = l.width as usize;
        for y in y0..=y1 {
            let dy = y as f32 - s.y;
            // The row's texels inside the ellipse: A·dx² + B·dy·dx + C·dy² < 1 between the roots,
            // so a thin, tilted ellipse costs its own area rather than its bounding box's.
            let (b, c) = (qb * dy, qc * dy * dy - 1.0);
            let disc = b * b - 4.0 * qa * c;
            if disc.is_nan() || disc <= 0.0 {
                continue;
            }
            let root = disc.sqrt();
            let lo = (-b - root) / (2.0 * qa);
            let hi = (-b + root) / (2.0 * qa);
            let x0 = ((s.x + lo.max(-half_x)).ceil()) as i64;
            let x1 = ((s.x + hi.min(half_x)).floor()) as i64;
            let row = wrap_index(y, l.height, self.wrap.1) * w;
            for x in x0..=x1 {
                let dx = x as f32 - s.x;
                let q = qa * dx * dx + qb * dx * dy + qc * dy * dy;
                if q < 1.0 {
                    let g = gaussian(q);
                    sum += l.texels.get(row + wrap_index(x, l.width, self.wrap.0)) * g;
                    weight += g;
                }
            }
        }
        if weight > 0.0 {
            sum / weight
        } else {
            l.bilinear(c, self.wrap)
        }
    }
}

#[cfg(test)]
mod tests;
