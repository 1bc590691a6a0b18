//! From radiance to raw codes: the physical exposure, then the noise and the ADC.
//!
//! # Exposure (radiance → expected photoelectrons)
//!
//! For a pixel of pitch `p` (area `A = p²`), an aperture of f-number `N`, exposure time `t` and linear
//! RGB radiance `L` (scene units; `responsivity·L` in W·sr⁻¹·m⁻²), the irradiance on the sensor is the
//! camera equation `E = π·responsivity·L/(4N²)` (on axis; times `cos⁴θ` of the chief ray when `cos4` is
//! set), and the photons a band delivers are `Φ = E·A·t·λ/(h·c)` at the reference wavelength
//! `λ = 555 nm` (`λ/(hc) = 2.794·10¹⁸ photons per joule`). The expected photoelectrons of channel `c`
//! are
//!
//! ```text
//! μₑ(c) = Σₖ M[c][k] · Φₖ           (M: quantum efficiency per channel and band, `response_matrix`)
//! ```
//!
//! A monochrome pixel (`cfa` none) sees the luminance mix `0.2126·M[0] + 0.7152·M[1] + 0.0722·M[2]`.
//!
//! # Noise and quantisation (per pixel, per frame, independent)
//!
//! ```text
//! μ_d   = dark_current · t                                     (dark electrons)
//! n     = min(Poisson(μₑ + μ_d), full_well)                     (shot noise, saturation)
//! v     = n + read_noise · 𝒩(0, 1)                              (read noise, electrons)
//! DN    = clamp(round(K·v) + black_level, 0, code_max)          (K = (iso/base_iso)/gain_e_per_dn)
//! code  = round(compand(DN))  when a companding curve is given
//! ```
//!
//! The random numbers of pixel `(x, y)` in frame `f` come from [`crate::rng::PixelRng`] keyed by
//! `(seed, f, y·W + x, channel)` (`W` the full image width), so a crop, a thread count or a tile order
//! never changes a pixel's noise. The noise-free image is `black_level + K·min(μₑ + μ_d, full_well)`.

use rayon::prelude::*;

use crate::cfa::Cfa;
use crate::color::{Mat3, apply};
use crate::config::{DEFAULT_F_NUMBER, SensorConfig};
use crate::noise::{gaussian, poisson};
use crate::rng::PixelRng;

/// Photons per joule at 555 nm: `λ/(h·c)` with `h = 6.626 070 15·10⁻³⁴ J·s`, `c = 299 792 458 m/s`.
pub const PHOTONS_PER_JOULE_555NM: f64 = 555e-9 / (6.626_070_15e-34 * 299_792_458.0);

/// Rec. 709 luminance weights (what a monochrome pixel's band mix follows).
pub const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Where the f-number came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FNumberSource {
    /// The sensor description's `f_number`.
    Description,
    /// The projection's `FStop` property.
    Projection,
    /// Neither gave one: [`DEFAULT_F_NUMBER`].
    Default,
}

impl FNumberSource {
    /// How the camera JSON spells it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            FNumberSource::Description => "sensor",
            FNumberSource::Projection => "projection fStop",
            FNumberSource::Default => "default",
        }
    }
}

/// A sensor ready to expose: the description with its f-number and response resolved.
#[derive(Debug, Clone)]
pub struct Sensor {
    config: SensorConfig,
    f_number: f64,
    f_number_source: FNumberSource,
    response: Mat3,
}

/// One frame read off the sensor, over a `width × height` window whose top-left pixel is `origin` in
/// the full image.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorFrame {
    /// Window width.
    pub width: u32,
    /// Window height.
    pub height: u32,
    /// The window's top-left pixel in the full image.
    pub origin: (u32, u32),
    /// The noise-free expected photoelectrons of each pixel's channel (dark current excluded).
    pub electrons: Vec<f32>,
    /// The stored codes (DN, after companding when there is a curve).
    pub raw: Vec<u16>,
    /// The noise-free linear DN (`black + K·min(μₑ + μ_d, full_well)`, not rounded nor clipped by the
    /// ADC): the clean image beside the noisy one.
    pub clean_dn: Vec<f32>,
}

impl Sensor {
    /// A sensor for `config`, with `projection_f_stop` the projection's `FStop` property if it has a
    /// finite positive one (used when the description gives no `f_number`).
    #[must_use]
    pub fn new(config: SensorConfig, projection_f_stop: Option<f64>) -> Sensor {
        let from_projection = projection_f_stop.filter(|f| f.is_finite() && *f > 0.0);
        let (f_number, f_number_source) = match (config.f_number, from_projection) {
            (Some(f), _) => (f, FNumberSource::Description),
            (None, Some(f)) => (f, FNumberSource::Projection),
            (None, None) => (DEFAULT_F_NUMBER, FNumberSource::Default),
        };
        let response = config.response_matrix();
        Sensor {
            config,
            f_number,
            f_number_source,
            response,
        }
    }

    /// The description.
    #[must_use]
    pub fn config(&self) -> &SensorConfig {
        &self.config
    }

    /// The f-number used and where it came from.
    #[must_use]
    pub fn f_number(&self) -> (f64, FNumberSource) {
        (self.f_number, self.f_number_source)
    }

    /// The response matrix `M`.
    #[must_use]
    pub fn response(&self) -> &Mat3 {
        &self.response
    }

    /// Photons per pixel per scene radiance unit of one band, on axis:
    /// `responsivity·π/(4N²)·p²·t·λ/(hc)`.
    #[must_use]
    pub fn photons_per_radiance(&self) -> f64 {
        let c = &self.config;
        let pitch_m = c.pixel_pitch_um * 1e-6;
        c.responsivity * std::f64::consts::PI / (4.0 * self.f_number * self.f_number)
            * pitch_m
            * pitch_m
            * c.exposure_time_s
            * PHOTONS_PER_JOULE_555NM
    }

    /// The expected photoelectrons of `channel` (0, 1, 2; `None` for a monochrome pixel) for radiance
    /// `rgb` with the chief ray at `cos_theta` to the axis (1 on axis; ignored unless `cos4`).
    #[must_use]
    pub fn expected_electrons(&self, rgb: [f64; 3], channel: Option<u8>, cos_theta: f64) -> f64 {
        let mut photons = rgb.map(|l| l * self.photons_per_radiance());
        if self.config.cos4 {
            let c2 = cos_theta * cos_theta;
            photons = photons.map(|p| p * c2 * c2);
        }
        let e = match channel {
            Some(c) => apply(&self.response, photons)[c as usize],
            None => {
                let m = &self.response;
                (0..3)
                    .map(|k| (0..3).map(|c| LUMINANCE[c] * m[c][k]).sum::<f64>() * photons[k])
                    .sum()
            }
        };
        e.max(0.0)
    }

    /// Dark electrons expected in one exposure: `dark_current · t`.
    #[must_use]
    pub fn dark_electrons(&self) -> f64 {
        self.config.dark_current_e_per_s * self.config.exposure_time_s
    }

    /// The stored code of one pixel with `mean_e` expected photoelectrons (see the module
    /// documentation), its noise drawn from `(seed, frame, pixel, channel)`.
    #[must_use]
    pub fn read_pixel(&self, mean_e: f64, frame: u64, pixel: u64, channel: u64) -> u16 {
        let c = &self.config;
        let mut rng = PixelRng::new(c.seed, frame, pixel, channel);
        let n = (poisson(&mut rng, mean_e + self.dark_electrons()) as f64).min(c.full_well_e.floor());
        let v = n + c.read_noise_e * gaussian(&mut rng);
        let dn = ((c.system_gain_dn_per_e() * v).round() + c.black_level_dn).clamp(0.0, c.linear_max_code());
        let code = match &c.companding {
            Some(curve) => curve.compress(dn).round(),
            None => dn,
        };
        code as u16
    }

    /// The noise-free linear DN of a pixel with `mean_e` expected photoelectrons.
    #[must_use]
    pub fn clean_dn(&self, mean_e: f64) -> f64 {
        let c = &self.config;
        c.black_level_dn + c.system_gain_dn_per_e() * (mean_e + self.dark_electrons()).min(c.full_well_e)
    }

    /// Exposes and reads a window of radiance (`rgb`, row by row, `width × height`, its top-left
    /// pixel at `origin` in an image `full_width` wide) as frame `frame`. `cos_theta`, when given,
    /// holds each pixel's chief-ray cosine (for `cos4`).
    ///
    /// # Panics
    /// When `rgb` (or `cos_theta`) does not hold `width × height` entries (a bug of the caller).
    #[must_use]
    #[allow(clippy::too_many_arguments)]
    pub fn capture(
        &self,
        rgb: &[[f32; 3]],
        width: u32,
        height: u32,
        origin: (u32, u32),
        full_width: u32,
        frame: u64,
        cos_theta: Option<&[f32]>,
    ) -> SensorFrame {
        let n = width as usize * height as usize;
        assert_eq!(rgb.len(), n, "one radiance per pixel");
        if let Some(c) = cos_theta {
            assert_eq!(c.len(), n, "one cosine per pixel");
        }
        let cfa: Cfa = self.config.cfa;
        let rows: Vec<(Vec<f32>, Vec<u16>, Vec<f32>)> = (0..height)
            .into_par_iter()
            .map(|j| {
                let y = origin.1 + j;
                let mut e_row = Vec::with_capacity(width as usize);
                let mut raw_row = Vec::with_capacity(width as usize);
                let mut clean_row = Vec::with_capacity(width as usize);
                for i in 0..width {
                    let x = origin.0 + i;
                    let k = (j * width + i) as usize;
                    let channel = cfa.channel(x, y);
                    let cos = cos_theta.map_or(1.0, |c| f64::from(c[k]));
                    let l = rgb[k].map(f64::from);
                    let mean = self.expected_electrons(l, channel, cos);
                    let pixel = u64::from(y) * u64::from(full_width) + u64::from(x);
                    raw_row.push(self.read_pixel(mean, frame, pixel, u64::from(channel.unwrap_or(3))));
                    e_row.push(mean as f32);
                    clean_row.push(self.clean_dn(mean) as f32);
                }
                (e_row, raw_row, clean_row)
            })
            .collect();
        let mut frame_out = SensorFrame {
            width,
            height,
            origin,
            electrons: Vec::with_capacity(n),
            raw: Vec::with_capacity(n),
            clean_dn: Vec::with_capacity(n),
        };
        for (e, r, c) in rows {
            frame_out.electrons.extend(e);
            frame_out.raw.extend(r);
            frame_out.clean_dn.extend(c);
        }
        frame_out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The camera equation against numbers worked by hand: L = 1 W/(sr·m²), N = 2.8, p = 3.45 µm,
    /// t = 1/60 s: E = π/(4·7.84) = 0.10017 W/m², energy 0.10017·1.19025e-11/60 = 1.98716e-14 J,
    /// photons = 1.98716e-14 · 2.79391e18 = 55 519.
    #[test]
    fn camera_equation_by_hand() {
        let config = SensorConfig {
            f_number: Some(2.8),
            exposure_time_s: 1.0 / 60.0,
            ..SensorConfig::default()
        };
        let s = Sensor::new(config, Some(8.0));
        assert_eq!(s.f_number(), (2.8, FNumberSource::Description));
        assert!(
            (s.photons_per_radiance() - 55_519.0).abs() < 5.0,
            "{}",
            s.photons_per_radiance()
        );
        // QE 0.6 on the red channel of pure red light.
        let e = s.expected_electrons([1.0, 0.0, 0.0], Some(0), 1.0);
        assert!((e - 0.6 * s.photons_per_radiance()).abs() < 1e-6);
        assert_eq!(s.expected_electrons([1.0, 0.0, 0.0], Some(1), 1.0), 0.0);
    }

    #[test]
    fn f_number_from_the_projection_then_the_default() {
        let s = Sensor::new(SensorConfig::default(), Some(5.6));
        assert_eq!(s.f_number(), (5.6, FNumberSource::Projection));
        let s = Sensor::new(SensorConfig::default(), Some(f64::INFINITY));
        assert_eq!(s.f_number(), (DEFAULT_F_NUMBER, FNumberSource::Default));
        // Halving the f-number gives four times the light.
        let a = Sensor::new(SensorConfig::default(), Some(4.0)).photons_per_radiance();
        let b = Sensor::new(SensorConfig::default(), Some(2.0)).photons_per_radiance();
        assert!((b / a - 4.0).abs() < 1e-12);
    }

    #[test]
    fn cos4_falls_off_as_the_fourth_power() {
        let config = SensorConfig {
            cos4: true,
            ..SensorConfig::default()
        };
        let s = Sensor::new(config, None);
        let on = s.expected_electrons([1.0; 3], Some(1), 1.0);
        let off = s.expected_electrons([1.0; 3], Some(1), 30f64.to_radians().cos());
        assert!((off / on - 0.5625).abs() < 1e-12);
    }

    #[test]
    fn capture_is_deterministic_and_crop_invariant() {
        let s = Sensor::new(SensorConfig::default(), None);
        let rgb: Vec<[f32; 3]> = (0..64).map(|i| [i as f32 * 0.01, 0.3, 0.2]).collect();
        let full = s.capture(&rgb, 8, 8, (0, 0), 8, 7, None);
        assert_eq!(full, s.capture(&rgb, 8, 8, (0, 0), 8, 7, None));
        // The window (2..6) × (3..7) of the same frame reads the same codes.
        let sub: Vec<[f32; 3]> = (3..7)
            .flat_map(|y| (2..6).map(move |x| (x, y)))
            .map(|(x, y)| rgb[y * 8 + x])
            .collect();
        let crop = s.capture(&sub, 4, 4, (2, 3), 8, 7, None);
        for j in 0..4 {
            for i in 0..4 {
                assert_eq!(crop.raw[j * 4 + i], full.raw[(j + 3) * 8 + i + 2]);
            }
        }
        // Another frame draws other noise.
        assert_ne!(full.raw, s.capture(&rgb, 8, 8, (0, 0), 8, 8, None).raw);
    }

    #[test]
    fn saturation_and_codes_stay_in_range() {
        let s = Sensor::new(SensorConfig::default(), None);
        let c = s.config();
        for mean in [0.0, 1e3, 1e9] {
            for p in 0..200 {
                let code = f64::from(s.read_pixel(mean, 0, p, 1));
                assert!(code <= c.max_code());
            }
        }
        let sat = f64::from(s.read_pixel(1e12, 0, 0, 1));
        let expect = (c.black_level_dn + c.full_well_e * c.system_gain_dn_per_e()).min(c.max_code());
        assert!((sat - expect).abs() <= 6.0 * c.read_noise_e * c.system_gain_dn_per_e() + 1.0);
    }
}
