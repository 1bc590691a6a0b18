//! Ray maps: every pixel's camera ray, written as OpenEXR channels (`obscura rays`).
//!
//! The main layer holds the **chief ray** of every pixel: through the pixel centre, from the lens centre
//! (aperture sample (0, 0), canonical lens sample (½, ½)), at shutter open (time 0). Its channels are
//! `origin.{X,Y,Z}`, `direction.{X,Y,Z}`, `originRadius`, `raySpread`, `minDist`, `maxDist`,
//! `tint.{R,G,B}` and `valid` (1 where the ray exists, 0 where it was culled). With `samples = N`,
//! layers `sample1` … `sampleN` hold the same channels for the renderer's own N samples of every pixel
//! (Owen-scrambled Sobol positions inside the pixel, warped lens and time samples), plus `screen.{X,Y}`
//! and `time`. The data window is the crop; the display window the full format. The file is written
//! with [`crate::atomic::write_atomically`], so a reader never sees half a file.

use std::path::Path;

use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, IntegerBounds, Layer, LayerAttributes, Vec2,
};
use obscura_sdk::{Point2, RayGeometry, Rgb, Vec3};
use rayon::prelude::*;

use obscura_host::camera::PixelRect;
use obscura_host::driver::{Batch, CameraStage, ContractReport};
use obscura_host::sampler::{MAX_SAMPLES, Sampler};

use crate::atomic::AtomicWriteError;
use crate::output::{add_text_attributes, write_exr_image};

/// One layer of a ray map: one ray per pixel of the crop, row by row.
#[derive(Debug, Clone, PartialEq)]
pub struct RayLayer {
    /// Channel-name prefix: empty for the chief rays, `sample1`… for the samples.
    pub name: String,
    /// Screen position of each ray's sample.
    pub screen: Vec<Point2>,
    /// The rays (culled ones have a zero direction).
    pub rays: Vec<RayGeometry>,
    /// Tints.
    pub tint: Vec<Rgb>,
    /// Shutter-normalised times after the projection.
    pub time: Vec<f32>,
}

/// Every layer of a ray map.
#[derive(Debug, Clone, PartialEq)]
pub struct RayMap {
    /// The pixels covered (the crop).
    pub pixels: PixelRect,
    /// The chief-ray layer, then one per sample.
    pub layers: Vec<RayLayer>,
}

/// A ray map could not be made or written.
#[derive(Debug, thiserror::Error)]
pub enum RayMapError {
    /// Too many samples.
    #[error("--samples {0}: at most {MAX_SAMPLES} samples per pixel are supported")]
    TooManySamples(u32),
    /// Writing the file failed.
    #[error(transparent)]
    Output(#[from] AtomicWriteError),
}

/// Computes the chief-ray layer and `samples` sample layers over the stage's crop window.
///
/// # Errors
/// [`RayMapError::TooManySamples`] above [`MAX_SAMPLES`].
pub fn trace_ray_map(
    stage: &CameraStage,
    samples: u32,
    seed: u32,
) -> Result<(RayMap, ContractReport), RayMapError> {
    if samples > MAX_SAMPLES {
        return Err(RayMapError::TooManySamples(samples));
    }
    let cam = stage.camera();
    let rect = cam.pixels();
    let sampler = Sampler::new(seed);
    let mut report = ContractReport::default();
    let mut layers = Vec::new();
    for layer in 0..=samples {
        let rows: Vec<(Batch, ContractReport)> = (rect.y0..rect.y1)
            .into_par_iter()
            .map(|y| {
                let mut b = Batch::with_capacity(rect.width() as usize);
                for x in rect.x0..rect.x1 {
                    if layer == 0 {
                        b.push(
                            cam.raster_to_screen(x as f64 + 0.5, y as f64 + 0.5),
                            Point2::new(0.5, 0.5),
                            0.0,
                        );
                        b.aperture.push(Point2::ZERO);
                    } else {
                        let s = sampler.sample(x, y, layer - 1);
                        let p =
                            cam.raster_to_screen(x as f64 + s.pixel.0 as f64, y as f64 + s.pixel.1 as f64);
                        b.push(p, Point2::new(s.lens.0, s.lens.1), s.time);
                    }
                }
                let r = if layer == 0 {
                    stage.run_prepared(&mut b)
                } else {
                    stage.run(&mut b)
                };
                (b, r)
            })
            .collect();
        let mut out = RayLayer {
            name: if layer == 0 {
                String::new()
            } else {
                format!("sample{layer}")
            },
            screen: Vec::with_capacity(rect.len()),
            rays: Vec::with_capacity(rect.len()),
            tint: Vec::with_capacity(rect.len()),
            time: Vec::with_capacity(rect.len()),
        };
        for (b, r) in rows {
            report.merge(&r);
            out.screen.extend(b.screen);
            out.rays.extend(b.rays);
            out.tint.extend(b.tint);
            out.time.extend(b.time);
        }
        layers.push(out);
    }
    Ok((RayMap { pixels: rect, layers }, report))
}

/// Writes `map` as a 32-bit float OpenEXR (ZIP compressed), atomically; `attributes` are stored as
/// header strings (the projection's name and parameters, for the record).
///
/// # Errors
/// [`RayMapError::Output`] naming the file.
pub fn write_exr(
    map: &RayMap,
    format: obscura_sdk::Format,
    screen_window: obscura_sdk::ScreenWindow,
    attributes: &[(&str, String)],
    path: &Path,
) -> Result<(), RayMapError> {
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
    for layer in &map.layers {
        let prefix = if layer.name.is_empty() {
            String::new()
        } else {
            format!("{}.", layer.name)
        };
        let mut add = |name: &str, values: Vec<f32>| {
            channels.push(AnyChannel::new(
                format!("{prefix}{name}").as_str(),
                FlatSamples::F32(values),
            ));
        };
        let rays = &layer.rays;
        let comp = |f: fn(&RayGeometry) -> f32| rays.iter().map(f).collect::<Vec<f32>>();
        add("origin.X", comp(|r| r.origin.x));
        add("origin.Y", comp(|r| r.origin.y));
        add("origin.Z", comp(|r| r.origin.z));
        add("direction.X", comp(|r| r.direction.x));
        add("direction.Y", comp(|r| r.direction.y));
        add("direction.Z", comp(|r| r.direction.z));
        add("originRadius", comp(|r| r.origin_radius));
        add("raySpread", comp(|r| r.ray_spread));
        add("minDist", comp(|r| r.min_dist));
        add("maxDist", comp(|r| r.max_dist));
        add(
            "valid",
            comp(|r| if r.direction == Vec3::ZERO { 0.0 } else { 1.0 }),
        );
        add("tint.R", layer.tint.iter().map(|t| t.r).collect());
        add("tint.G", layer.tint.iter().map(|t| t.g).collect());
        add("tint.B", layer.tint.iter().map(|t| t.b).collect());
        if !layer.name.is_empty() {
            add("screen.X", layer.screen.iter().map(|s| s.x).collect());
            add("screen.Y", layer.screen.iter().map(|s| s.y).collect());
            add("time", layer.time.clone());
        }
    }
    let size = (map.pixels.width() as usize, map.pixels.height() as usize);
    let mut layer = Layer::new(
        size,
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels.into()),
    );
    layer.attributes.layer_position = Vec2(map.pixels.x0 as i32, map.pixels.y0 as i32);
    // OpenEXR's screen window is centred at the origin with height 2 in NDC-like units: record ours.
    layer.attributes.screen_window_width = screen_window.width();
    layer.attributes.screen_window_center = Vec2(
        0.5 * (screen_window.left + screen_window.right),
        0.5 * (screen_window.bottom + screen_window.top),
    );
    add_text_attributes(&mut layer.attributes, attributes);
    let mut image = Image::from_layer(layer);
    image.attributes.display_window =
        IntegerBounds::new((0, 0), (format.width as usize, format.height as usize));
    image.attributes.pixel_aspect = format.pixel_aspect;
    Ok(write_exr_image(image, path)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_host::camera::{CameraDesc, CropWindow};
    use obscura_plugins::builtin_registry;
    use obscura_sdk::{Format, ParamList};

    fn stage(cam: &CameraDesc, params: &[(&str, &str)]) -> CameraStage {
        let mut list = ParamList::new();
        for (d, v) in params {
            list.push_text(d, &[v], None).unwrap();
        }
        CameraStage::new(&mut builtin_registry(), "PxrPerspective", &list, cam).unwrap()
    }

    #[test]
    fn chief_rays_match_the_closed_form_and_crops_are_the_same_region() {
        let mut cam = CameraDesc::new(Format::new(32, 24));
        let full = trace_ray_map(&stage(&cam, &[("float fov", "50")]), 0, 0)
            .unwrap()
            .0;
        let d = 1.0 / (25.0f64.to_radians()).tan();
        for (i, r) in full.layers[0].rays.iter().enumerate() {
            let (x, y) = ((i % 32) as f64 + 0.5, (i / 32) as f64 + 0.5);
            let (sx, sy) = (-4.0 / 3.0 + x / 32.0 * 8.0 / 3.0, 1.0 - y / 24.0 * 2.0);
            let l = (sx * sx + sy * sy + d * d).sqrt();
            assert!(
                (r.direction.x as f64 - sx / l).abs() < 1e-6 && (r.direction.y as f64 - sy / l).abs() < 1e-6
            );
        }
        cam.crop_window = CropWindow {
            x_min: 0.25,
            x_max: 0.75,
            y_min: 0.5,
            y_max: 1.0,
        };
        let crop = trace_ray_map(&stage(&cam, &[("float fov", "50")]), 0, 0)
            .unwrap()
            .0;
        assert_eq!(
            crop.pixels,
            PixelRect {
                x0: 8,
                x1: 24,
                y0: 12,
                y1: 24
            }
        );
        for (i, r) in crop.layers[0].rays.iter().enumerate() {
            let (x, y) = (8 + i % 16, 12 + i / 16);
            assert_eq!(*r, full.layers[0].rays[y * 32 + x]);
        }
    }

    #[test]
    fn sample_layers_stay_inside_their_pixels() {
        let cam = CameraDesc::new(Format::new(16, 16));
        let (map, report) = trace_ray_map(&stage(&cam, &[]), 4, 9).unwrap();
        assert!(report.is_clean());
        assert_eq!(map.layers.len(), 5);
        assert_eq!(map.layers[3].name, "sample3");
        let w = cam.screen_window();
        for layer in &map.layers[1..] {
            for (i, s) in layer.screen.iter().enumerate() {
                let (x, y) = w.screen_to_raster(cam.format, *s);
                assert_eq!(
                    ((x.floor() as usize), (y.floor() as usize)),
                    (i % 16, i / 16),
                    "{s:?}"
                );
            }
        }
        assert_ne!(map.layers[1].screen, map.layers[2].screen);
    }

    #[test]
    fn too_many_samples_is_an_error() {
        let cam = CameraDesc::new(Format::new(4, 4));
        assert!(matches!(
            trace_ray_map(&stage(&cam, &[]), MAX_SAMPLES + 1, 0),
            Err(RayMapError::TooManySamples(_))
        ));
    }

    #[test]
    fn a_failed_write_leaves_no_file_and_names_the_path() {
        let cam = CameraDesc::new(Format::new(4, 4));
        let (map, _) = trace_ray_map(&stage(&cam, &[]), 0, 0).unwrap();
        let path = Path::new("/nonexistent-dir/rays.exr");
        let err = write_exr(&map, cam.format, cam.screen_window(), &[], path).unwrap_err();
        assert!(err.to_string().contains("/nonexistent-dir/rays.exr"), "{err}");
        assert!(crate::atomic::temporaries(path).is_empty());
    }
}
