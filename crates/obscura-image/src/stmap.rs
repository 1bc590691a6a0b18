//! ST-maps between two projections (`obscura stmap --from A --to B`).
//!
//! An ST-map is an image the size of the **output** B whose red and green channels say, for every
//! pixel of B, where in the **source** image A to look up the colour — Nuke's `STMap` node reads it so.
//! Feeding a plate shot through projection A into the STMap node's `src` input and this map into its
//! `stmap` input gives the plate as projection B would have seen it: how a compositor applies or
//! removes a lens, or turns a fisheye into a latlong.
//!
//! # Convention (Nuke's)
//!
//! Nuke's STMap documentation: the U and V values are the absolute position of the source pixel,
//! normalised to `[0, 1]`, where `(0, 0)` is the **bottom-left corner** of the input image and
//! `(1, 1)` its top-right corner. Corners, not pixel centres: pixel column `i` of A spans
//! `[i/W, (i+1)/W]` and its centre is at `(i + ½)/W` (the well-known half-pixel shift of maps built
//! as `x/width` in an Expression node comes from forgetting this). With A's continuous raster
//! position `(x_A, y_A)` (conventions.md: origin at the top-left corner, y down, pixel centres at
//! `+½`):
//!
//! ```text
//! s = x_A / W_A          t = 1 − y_A / H_A
//! ```
//!
//! # How a pixel of B is mapped
//!
//! 1. B's chief ray of the pixel: through the pixel centre, from the lens centre (aperture (0, 0)),
//!    at shutter open (time 0) — the same ray as the main layer of `obscura rays`.
//! 2. The point `P = origin + distance·direction` on it.
//! 3. A's exact inverse, `unproject(P, 0)`, gives the screen position of A whose ray passes through
//!    `P`; A's screen window and format turn it into `(x_A, y_A)` and then `(s, t)`.
//! 4. A's own ray at that position is traced and checked to pass through `P` (to 1/20 of A's pixel
//!    footprint), so a projection whose inverse disagrees with its `project` is reported rather than
//!    trusted silently.
//!
//! ST-maps relate *directions*: for cameras whose rays all leave one point (pinholes, fisheyes,
//! spheres) the map does not depend on `distance` at all. Where a projection's ray origins are spread
//! out (omnidirectional stereo, orthographic) the map is exact only for scene points at that distance;
//! the default 10⁴ scene units treats everything as far away. Depth of field plays no part: chief rays
//! leave the lens centre.
//!
//! # Channels
//!
//! | case | R | G | B | A |
//! |---|---|---|---|---|
//! | A sees the direction inside its frame | s | t | 0 | 1 |
//! | A sees it outside its frame, or A culls its own ray there | s | t | 0 | 0 |
//! | B culls the pixel, or A cannot see the direction (`unproject` is `None`) | 0 | 0 | 0 | 0 |
//!
//! Keeping `(s, t)` where the position exists but lies outside A's image lets overscan workflows use
//! it; the alpha says whether A's image holds the colour.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, IntegerBounds, Layer, LayerAttributes,
};
use obscura_host::Registry;
use obscura_host::contract::panic_message;
use obscura_sdk::{Format, ParamList, Point2, RayGeometry, Vec3};
use rayon::prelude::*;

use crate::atomic::AtomicWriteError;
use crate::output::{add_text_attributes, write_exr_image};
use obscura_host::camera::CameraDesc;
use obscura_host::driver::{Batch, CameraStage, ContractReport, HostError};

/// The default distance along B's rays of the point handed to A's inverse: far enough that scene
/// content reads as "at infinity" for stereo and other offset-origin cameras.
pub const DEFAULT_DISTANCE: f32 = 1.0e4;

/// A's ray at the looked-up position must pass this close to the point, in A's pixels (the footprint
/// cone, `origin_radius + ray_spread·t`, is half a pixel).
pub const CONSISTENCY_PX: f64 = 0.05;

/// Pixel centres probed (per axis) to decide whether A offers an inverse at all.
const PROBE_GRID: u32 = 9;

/// An ST-map: for each pixel of B (row by row from the top), where in A the same direction is seen.
#[derive(Debug, Clone, PartialEq)]
pub struct StMap {
    /// B's format: the size of the map.
    pub format: Format,
    /// A's format: the image the map looks up.
    pub from_format: Format,
    /// Nuke's s (red): `x_A / W_A`.
    pub s: Vec<f32>,
    /// Nuke's t (green): `1 − y_A / H_A`.
    pub t: Vec<f32>,
    /// 1 where A's image holds the direction, else 0 (see the module's channel table).
    pub alpha: Vec<f32>,
    /// What happened to the pixels.
    pub stats: StMapStats,
}

/// Pixel counts of an ST-map, by outcome.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StMapStats {
    /// Pixels of B.
    pub pixels: u64,
    /// Pixels with alpha 1.
    pub mapped: u64,
    /// Pixels whose ray B culls.
    pub culled_by_b: u64,
    /// Pixels whose direction A cannot see (`unproject` returned `None`).
    pub unseen_by_a: u64,
    /// Pixels whose position in A lies outside A's frame.
    pub outside_a: u64,
    /// Pixels whose position in A is inside the frame but where A culls its own ray.
    pub culled_by_a: u64,
    /// Pixels where A's ray at the looked-up position misses the point by more than
    /// [`CONSISTENCY_PX`] of A's pixels: A's `unproject` disagrees with its `project`.
    pub inconsistent: u64,
    /// The largest such miss, in A's pixels, and the pixel of B (column, row) where it happened.
    pub worst_miss: Option<(f64, (u32, u32))>,
    /// Pixels where A's `unproject` panicked (or a plugin's returned a failure): left unmapped.
    pub unproject_failed: u64,
    /// The first such failure's message.
    pub unproject_failure: Option<String>,
    /// Contract breaches of B's rays (culled and counted by the driver).
    pub b_report: ContractReport,
    /// Contract breaches of A's rays traced for the consistency check.
    pub a_report: ContractReport,
}

impl StMapStats {
    fn merge(&mut self, o: &StMapStats) {
        self.pixels += o.pixels;
        self.mapped += o.mapped;
        self.culled_by_b += o.culled_by_b;
        self.unseen_by_a += o.unseen_by_a;
        self.outside_a += o.outside_a;
        self.culled_by_a += o.culled_by_a;
        self.inconsistent += o.inconsistent;
        self.unproject_failed += o.unproject_failed;
        if self.unproject_failure.is_none() {
            self.unproject_failure.clone_from(&o.unproject_failure);
        }
        if let Some((m, at)) = o.worst_miss
            && self.worst_miss.is_none_or(|(w, _)| m > w)
        {
            self.worst_miss = Some((m, at));
        }
        self.b_report.merge(&o.b_report);
        self.a_report.merge(&o.a_report);
    }

    /// One warning line when A's `unproject` failed at some pixels, else `None`.
    #[must_use]
    pub fn unproject_warning(&self, from: &str) -> Option<String> {
        (self.unproject_failed > 0).then(|| {
            format!(
                "warning: {from}: unproject failed at {} pixel{} (left unmapped, alpha 0); first: {}",
                self.unproject_failed,
                if self.unproject_failed == 1 { "" } else { "s" },
                self.unproject_failure.as_deref().unwrap_or("no message")
            )
        })
    }

    /// One warning line when A's inverse disagreed with its rays, else `None`.
    #[must_use]
    pub fn consistency_warning(&self, from: &str) -> Option<String> {
        let (miss, (x, y)) = self.worst_miss?;
        (self.inconsistent > 0).then(|| {
            format!(
                "warning: {from}: at {} pixel{} the ray of the position its unproject returned misses the \
                 point by more than {CONSISTENCY_PX} pixel (worst {miss:.3} pixel, at output pixel {x},{y}); \
                 its inverse disagrees with its project",
                self.inconsistent,
                if self.inconsistent == 1 { "" } else { "s" }
            )
        })
    }
}

/// An ST-map could not be made or written.
#[derive(Debug, thiserror::Error)]
pub enum StMapError {
    /// The distance is not a positive finite number.
    #[error(
        "--distance {0}: expected a positive finite distance in scene units (default {DEFAULT_DISTANCE})"
    )]
    Distance(f32),
    /// A's camera stage could not be set up.
    #[error("--from {name}: {source}")]
    From {
        /// The projection.
        name: String,
        /// Why.
        source: Box<HostError>,
    },
    /// B's camera stage could not be set up.
    #[error("--to {name}: {source}")]
    To {
        /// The projection.
        name: String,
        /// Why.
        source: Box<HostError>,
    },
    /// A has no inverse.
    #[error(
        "--from {projection}: {projection} offers no inverse (its unproject finds none of its own rays); \
         ST-maps need one. Swap --from and --to for the opposite map if the other projection has one"
    )]
    NoInverse {
        /// The projection.
        projection: String,
    },
    /// A's inverse found none of its own rays, and failed (panicked, or a plugin's call returned a
    /// failure) on some of them.
    #[error("--from {projection}: its unproject failed: {message}")]
    UnprojectFailed {
        /// The projection.
        projection: String,
        /// The panic's or the plugin's message.
        message: String,
    },
    /// Writing the file failed.
    #[error(transparent)]
    Output(#[from] AtomicWriteError),
}

/// A's `unproject(p, 0)`, with a panic (or a plugin's failed call, which its adapter raises as one)
/// as `Err(message)`.
fn unproject_caught(a: &CameraStage, p: Vec3) -> Result<Option<Point2>, String> {
    catch_unwind(AssertUnwindSafe(|| a.projection().unproject(p, 0.0)))
        .map_err(|payload| panic_message(payload.as_ref()))
}

/// The two stages of an ST-map made from a registry: `(A, B)`. Each camera uses RenderMan's defaults
/// for its format (default screen window, no crop).
///
/// # Errors
/// [`StMapError::From`] or [`StMapError::To`] naming the projection (unknown name, bad parameter).
pub fn stages(
    registry: &mut Registry,
    from: (&str, &ParamList, Format),
    to: (&str, &ParamList, Format),
) -> Result<(CameraStage, CameraStage), StMapError> {
    let a = CameraStage::new(registry, from.0, from.1, &CameraDesc::new(from.2)).map_err(|e| {
        StMapError::From {
            name: from.0.to_string(),
            source: Box::new(e),
        }
    })?;
    let b = CameraStage::new(registry, to.0, to.1, &CameraDesc::new(to.2)).map_err(|e| StMapError::To {
        name: to.0.to_string(),
        source: Box::new(e),
    })?;
    Ok((a, b))
}

/// Computes the ST-map that turns images of `from` (A) into images of `to` (B), over B's whole format.
///
/// # Errors
/// [`StMapError::Distance`] for a distance that is not positive and finite; [`StMapError::NoInverse`]
/// when A's `unproject` finds none of A's own rays.
pub fn compute_stmap(from: &CameraStage, to: &CameraStage, distance: f32) -> Result<StMap, StMapError> {
    if !(distance.is_finite() && distance > 0.0) {
        return Err(StMapError::Distance(distance));
    }
    check_inverse(from, distance)?;
    let format = to.camera().format;
    let from_format = from.camera().format;
    let rows: Vec<(Vec<[f32; 3]>, StMapStats)> = (0..format.height)
        .into_par_iter()
        .map(|y| map_row(from, to, distance, y))
        .collect();
    let n = format.width as usize * format.height as usize;
    let mut map = StMap {
        format,
        from_format,
        s: Vec::with_capacity(n),
        t: Vec::with_capacity(n),
        alpha: Vec::with_capacity(n),
        stats: StMapStats::default(),
    };
    for (row, stats) in rows {
        for [s, t, a] in row {
            map.s.push(s);
            map.t.push(t);
            map.alpha.push(a);
        }
        map.stats.merge(&stats);
    }
    Ok(map)
}

/// Chief rays (lens centre, time 0) of `stage` at `screen` positions.
fn chief_rays(stage: &CameraStage, screen: &[Point2]) -> (Vec<RayGeometry>, ContractReport) {
    let mut b = Batch::with_capacity(screen.len());
    for p in screen {
        b.push(*p, Point2::new(0.5, 0.5), 0.0);
        b.aperture.push(Point2::ZERO);
    }
    let report = stage.run_prepared(&mut b);
    (b.rays, report)
}

/// A projection that offers an inverse finds its own rays: probe a grid of A's pixel centres.
fn check_inverse(from: &CameraStage, distance: f32) -> Result<(), StMapError> {
    let cam = from.camera();
    let f = cam.format;
    let screen: Vec<Point2> = (0..PROBE_GRID)
        .flat_map(|j| (0..PROBE_GRID).map(move |i| (i, j)))
        .map(|(i, j)| {
            let x = (f.width as f64 * (i as f64 + 0.5) / PROBE_GRID as f64).floor() + 0.5;
            let y = (f.height as f64 * (j as f64 + 0.5) / PROBE_GRID as f64).floor() + 0.5;
            cam.raster_to_screen(x, y)
        })
        .collect();
    let (rays, _) = chief_rays(from, &screen);
    let live: Vec<&RayGeometry> = rays.iter().filter(|r| r.direction != Vec3::ZERO).collect();
    let mut found = live.is_empty();
    let mut failure = None;
    for r in live {
        match unproject_caught(from, r.origin + r.direction * distance) {
            Ok(Some(_)) => {
                found = true;
                break;
            }
            Ok(None) => {}
            Err(message) => failure = failure.or(Some(message)),
        }
    }
    // Some failures are counted pixel by pixel later; only an inverse that never answers is an error.
    match (found, failure) {
        (true, _) => Ok(()),
        (false, Some(message)) => Err(StMapError::UnprojectFailed {
            projection: from.name().to_string(),
            message,
        }),
        (false, None) => Err(StMapError::NoInverse {
            projection: from.name().to_string(),
        }),
    }
}

/// How far (in A's pixels) `p` lies from A's ray `r`: the perpendicular distance over the footprint's
/// diameter at that depth. Infinite when the point is behind the ray's origin.
fn miss_in_pixels(r: &RayGeometry, p: Vec3) -> f64 {
    let d = [r.direction.x as f64, r.direction.y as f64, r.direction.z as f64];
    let v = [
        p.x as f64 - r.origin.x as f64,
        p.y as f64 - r.origin.y as f64,
        p.z as f64 - r.origin.z as f64,
    ];
    let along = v[0] * d[0] + v[1] * d[1] + v[2] * d[2];
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if along <= 0.0 {
        return f64::INFINITY;
    }
    let perp = [v[0] - d[0] * along, v[1] - d[1] * along, v[2] - d[2] * along];
    let perp = (perp[0] * perp[0] + perp[1] * perp[1] + perp[2] * perp[2]).sqrt();
    let footprint = 2.0 * (r.origin_radius as f64 + r.ray_spread as f64 * along);
    if footprint > 0.0 {
        perp / footprint
    } else if perp <= 1e-5 * len.max(1.0) {
        // A projection that reports no footprint: only round-off may separate point and ray.
        0.0
    } else {
        f64::INFINITY
    }
}

fn map_row(from: &CameraStage, to: &CameraStage, distance: f32, y: u32) -> (Vec<[f32; 3]>, StMapStats) {
    let bcam = to.camera();
    let acam = from.camera();
    let (af, aw) = (acam.format, acam.screen_window());
    let width = bcam.format.width;
    let screen: Vec<Point2> = (0..width)
        .map(|x| bcam.raster_to_screen(x as f64 + 0.5, y as f64 + 0.5))
        .collect();
    let (b_rays, b_report) = chief_rays(to, &screen);
    let mut stats = StMapStats {
        pixels: width as u64,
        b_report,
        ..StMapStats::default()
    };
    let mut out = vec![[0.0f32; 3]; width as usize];
    // Pixels with a position in A: (column, point P, A's screen position, s, t).
    let mut found: Vec<(usize, Vec3, Point2, f32, f32)> = Vec::with_capacity(width as usize);
    for (x, r) in b_rays.iter().enumerate() {
        if r.direction == Vec3::ZERO {
            stats.culled_by_b += 1;
            continue;
        }
        let p = r.origin + r.direction * distance;
        let sa = match unproject_caught(from, p) {
            Ok(Some(sa)) => sa,
            Ok(None) => {
                stats.unseen_by_a += 1;
                continue;
            }
            Err(message) => {
                stats.unproject_failed += 1;
                stats.unproject_failure.get_or_insert(message);
                continue;
            }
        };
        let (xa, ya) = aw.screen_to_raster(af, sa);
        let s = xa / af.width as f64;
        let t = 1.0 - ya / af.height as f64;
        if !(s.is_finite() && t.is_finite() && sa.x.is_finite() && sa.y.is_finite()) {
            stats.unseen_by_a += 1;
            continue;
        }
        let inside = (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t);
        out[x] = [s as f32, t as f32, 0.0];
        if inside {
            found.push((x, p, sa, s as f32, t as f32));
        } else {
            stats.outside_a += 1;
        }
    }
    let a_screen: Vec<Point2> = found.iter().map(|f| f.2).collect();
    let (a_rays, a_report) = chief_rays(from, &a_screen);
    stats.a_report = a_report;
    for ((x, p, _, _, _), r) in found.iter().zip(&a_rays) {
        if r.direction == Vec3::ZERO {
            stats.culled_by_a += 1;
            continue;
        }
        out[*x][2] = 1.0;
        stats.mapped += 1;
        let miss = miss_in_pixels(r, *p);
        if miss > CONSISTENCY_PX {
            stats.inconsistent += 1;
            if stats.worst_miss.is_none_or(|(w, _)| miss > w) {
                stats.worst_miss = Some((miss, (*x as u32, y)));
            }
        }
    }
    (out, stats)
}

/// Writes `map` as a 32-bit float OpenEXR (ZIP compressed) with channels R = s, G = t, B = 0, A = alpha,
/// atomically ([`crate::atomic::write_atomically`]). The display and data windows are
/// B's format; `attributes` are stored as header strings (the projections and their parameters).
///
/// # Errors
/// [`StMapError::Output`] naming the file.
pub fn write_stmap_exr(map: &StMap, attributes: &[(&str, String)], path: &Path) -> Result<(), StMapError> {
    let n = map.s.len();
    let channels: Vec<AnyChannel<FlatSamples>> = vec![
        AnyChannel::new("R", FlatSamples::F32(map.s.clone())),
        AnyChannel::new("G", FlatSamples::F32(map.t.clone())),
        AnyChannel::new("B", FlatSamples::F32(vec![0.0; n])),
        AnyChannel::new("A", FlatSamples::F32(map.alpha.clone())),
    ];
    let size = (map.format.width as usize, map.format.height as usize);
    let mut layer = Layer::new(
        size,
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels.into()),
    );
    add_text_attributes(&mut layer.attributes, attributes);
    let mut image = Image::from_layer(layer);
    image.attributes.display_window = IntegerBounds::new((0, 0), size);
    image.attributes.pixel_aspect = map.format.pixel_aspect;
    Ok(write_exr_image(image, path)?)
}

#[cfg(test)]
mod tests;
