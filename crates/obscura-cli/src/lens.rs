//! `obscura lens FILE`: a lens prescription's paraxial data and real-ray figures, as text or JSON, and
//! its drawing with traced ray fans (SVG or PNG).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::stdout::{out, outln};

use clap::Args;
use obscura_image::atomic::write_atomically;
use obscura_projections::lens_system::glass::LAMBDA_D;
use obscura_projections::lens_system::prescription::Prescription;
use obscura_projections::lens_system::{LensSystem, Settings};
use obscura_sdk::{Format, ProjectionEnvironment};

/// Arguments of `obscura lens`.
#[derive(Args, Debug)]
pub struct LensArgs {
    /// The prescription: a .json or four-column .dat file, or a shipped lens's name (dgauss.50mm, …).
    pub file: String,
    /// Print the figures as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Draw the lens with traced ray fans: .svg or .png.
    #[arg(long, value_name = "FILE")]
    pub diagram: Option<PathBuf>,
    /// Film diagonal, mm.
    #[arg(long, default_value_t = 35.0)]
    pub film_diagonal: f64,
    /// Film aspect ratio (width / height).
    #[arg(long, default_value_t = 1.5)]
    pub aspect: f64,
    /// Distance in focus from the film, metres (0 = infinity).
    #[arg(long, default_value_t = 0.0)]
    pub focus_distance: f64,
}

/// The figures `obscura lens` prints.
struct Figures {
    name: String,
    source: String,
    efl: f64,
    bfl: f64,
    ffl: f64,
    f_number: f64,
    fov_deg: f64,
    ep: (f64, f64),
    xp: (f64, f64),
    distortion_percent: Option<f64>,
    relative_illumination: f64,
    blocked_fraction: f64,
    corner_mm: f64,
    /// The film radius of the widest chief ray (the corner, or the image circle's edge).
    field_mm: f64,
    track: f64,
}

/// Runs `obscura lens`.
///
/// # Errors
/// A message naming the file and what is wrong.
pub fn run(a: &LensArgs) -> Result<(), String> {
    let prescription = Prescription::load(&a.file)?;
    if !(a.film_diagonal > 0.0 && a.aspect > 0.0 && a.focus_distance >= 0.0) {
        return Err("--film-diagonal and --aspect must be positive, --focus-distance at least 0".into());
    }
    let height = 1000u32;
    let width = ((f64::from(height) * a.aspect).round() as u32).max(1);
    let env = ProjectionEnvironment::for_format(Format::new(width, height));
    let settings = Settings {
        focus_distance: a.focus_distance,
        film_diagonal: a.film_diagonal,
        dispersion: false,
        ..Settings::default()
    };
    let cam = LensSystem::new(&prescription, settings, &env).map_err(|e| format!("{}: {e}", a.file))?;
    let f = figures(&prescription, &cam, a.film_diagonal);
    if a.json {
        outln!("{}", json(&f));
    } else {
        out!("{}", text(&f));
    }
    if let Some(path) = &a.diagram {
        let drawing = diagram(&cam, f.corner_mm, f.field_mm);
        match path.extension().and_then(|e| e.to_str()) {
            Some("svg") => write_atomically(path, |w| std::io::Write::write_all(w, drawing.svg().as_bytes()))
                .map_err(|e| e.to_string())?,
            Some("png") => write_png(path, &drawing)?,
            _ => {
                return Err(format!(
                    "--diagram {}: expected a .svg or .png file",
                    path.display()
                ));
            }
        }
    }
    Ok(())
}

fn figures(p: &Prescription, cam: &LensSystem, film_diagonal: f64) -> Figures {
    let lens = cam.lens();
    let par = lens.paraxial(LAMBDA_D, 2.0 * cam.stop_radius());
    let corner = 0.5 * film_diagonal;
    // The widest chief ray on the film: the corner's, or the image circle's edge when the corner is
    // dark (a circular fisheye).
    let mut r = corner;
    let mut chief = cam.chief_ray(r);
    while chief.is_none() && r > 0.01 * corner {
        r *= 0.995;
        chief = cam.chief_ray(r);
    }
    let theta = chief.map_or(0.0, |c| c.d[0].hypot(c.d[1]).atan2(c.d[2]));
    let ideal = par.efl * theta.tan();
    let distortion_percent =
        (theta < 89f64.to_radians() && ideal != 0.0).then(|| 100.0 * (r - ideal) / ideal);
    Figures {
        name: p.name.clone(),
        source: p.source.clone(),
        efl: par.efl,
        bfl: par.bfl,
        ffl: par.ffl,
        f_number: par.f_number,
        fov_deg: 2.0 * theta.to_degrees(),
        ep: (par.entrance_pupil_position, par.entrance_pupil_diameter),
        xp: (par.exit_pupil_position, par.exit_pupil_diameter),
        distortion_percent,
        relative_illumination: cam.relative_illumination(corner, 128),
        blocked_fraction: cam.blocked_fraction(corner, 128),
        corner_mm: corner,
        field_mm: r,
        track: lens.track(),
    }
}

fn text(f: &Figures) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{}", f.name);
    if !f.source.is_empty() {
        let _ = writeln!(s, "  {}", f.source);
    }
    let _ = writeln!(s, "effective focal length   {:10.3} mm", f.efl);
    let _ = writeln!(
        s,
        "back focal distance      {:10.3} mm   (rear vertex to focus)",
        f.bfl
    );
    let _ = writeln!(
        s,
        "front focal distance     {:10.3} mm   (front vertex to front focus, + toward the scene)",
        f.ffl
    );
    let _ = writeln!(s, "f-number                 {:10.3}", f.f_number);
    let _ = writeln!(
        s,
        "entrance pupil           {:10.3} mm from the rear vertex, {:.3} mm across",
        f.ep.0, f.ep.1
    );
    let _ = writeln!(
        s,
        "exit pupil               {:10.3} mm from the rear vertex, {:.3} mm across",
        f.xp.0, f.xp.1
    );
    let _ = writeln!(s, "length (front to rear)   {:10.3} mm", f.track);
    let _ = writeln!(
        s,
        "field of view            {:10.3} deg across the {:.1} mm diagonal",
        f.fov_deg,
        2.0 * f.corner_mm
    );
    match f.distortion_percent {
        Some(d) => {
            let _ = writeln!(
                s,
                "distortion at the corner {d:10.3} %  (chief ray against EFL·tan θ)"
            );
        }
        None => {
            let _ = writeln!(s, "distortion at the corner        n/a  (field beyond 90°)");
        }
    }
    let _ = writeln!(
        s,
        "relative illumination    {:10.3}    at the corner (centre = 1)",
        f.relative_illumination
    );
    let _ = writeln!(
        s,
        "blocked at the corner    {:10.1} %  of the aperture samples",
        100.0 * f.blocked_fraction
    );
    s
}

fn json(f: &Figures) -> String {
    serde_json::json!({
        "lens": f.name,
        "efl_mm": f.efl,
        "bfl_mm": f.bfl,
        "ffl_mm": f.ffl,
        "f_number": f.f_number,
        "fov_deg": f.fov_deg,
        "entrance_pupil_mm": {"position": f.ep.0, "diameter": f.ep.1},
        "exit_pupil_mm": {"position": f.xp.0, "diameter": f.xp.1},
        "distortion_percent": f.distortion_percent,
        "relative_illumination": f.relative_illumination,
        "blocked_fraction_corner": f.blocked_fraction,
        "track_mm": f.track,
    })
    .to_string()
}

/// A lens drawing: polylines in lens millimetres (z toward the scene, y up) with a colour each.
struct Drawing {
    lines: Vec<(Vec<[f64; 2]>, [u8; 3], f64)>,
    bounds: [f64; 4],
}

fn diagram(cam: &LensSystem, corner: f64, field: f64) -> Drawing {
    let lens = cam.lens();
    let mut lines = Vec::new();
    let grey = [40, 40, 40];
    // Surfaces, element edges and the stop.
    let profile = |i: usize| -> Vec<[f64; 2]> {
        let s = &lens.surfaces[i];
        (0..=40)
            .map(|k| {
                let y = s.semi_aperture * (-1.0 + 2.0 * f64::from(k) / 40.0);
                let sag = s.sag(y * y).map_or(0.0, |v| v.0);
                [lens.z[i] - sag, y]
            })
            .collect()
    };
    for i in 0..lens.surfaces.len() {
        let s = &lens.surfaces[i];
        if s.stop {
            let (z, h) = (lens.z[i], cam.stop_radius());
            let top = h + 0.25 * h.max(2.0);
            lines.push((vec![[z, h], [z, top]], grey, 2.0));
            lines.push((vec![[z, -h], [z, -top]], grey, 2.0));
            continue;
        }
        lines.push((profile(i), grey, 1.5));
        if i + 1 < lens.surfaces.len() && s.glass.nd() > 1.0 {
            let (a, b) = (profile(i), profile(i + 1));
            for (pa, pb) in [(a[0], b[0]), (a[40], b[40])] {
                lines.push((vec![pa, pb], grey, 1.5));
            }
        }
    }
    let z_front = lens.z[0];
    let reach = 0.35 * z_front.max(10.0);
    // Ray fans from three film heights: the axis, 70 % and the edge of the field (the corner, or the
    // image circle's edge), 9 rays across the pupil.
    let colours = [[30, 90, 220], [20, 150, 60], [220, 60, 40]];
    for (k, frac) in [0.0, 0.7, 1.0].into_iter().enumerate() {
        let r = -frac * field;
        for j in 0..9 {
            let u = -1.0 + 2.0 * f64::from(j) / 8.0;
            // The film point at −r·x in the lens frame is the table's r on +x mirrored.
            let Some(ray) = cam.film_side_ray(-r, [-u, 0.0]) else {
                continue;
            };
            let ray = obscura_projections::lens_system::surface::Ray {
                o: [-ray.o[0], 0.0, ray.o[2]],
                d: [-ray.d[0], 0.0, ray.d[2]],
            };
            let (points, out) = lens.trace_path(ray);
            let mut poly: Vec<[f64; 2]> = points.iter().map(|p| [p[2], p[0]]).collect();
            if let Some(o) = out {
                let t = reach;
                poly.push([o.o[2] + t * o.d[2], o.o[0] + t * o.d[0]]);
            }
            lines.push((poly, colours[k], 0.8));
        }
    }
    // The film.
    lines.push((vec![[0.0, -corner], [0.0, corner]], [0, 0, 0], 2.5));
    let mut b = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
    for (poly, _, _) in &lines {
        for p in poly {
            b = [b[0].min(p[0]), b[1].min(p[1]), b[2].max(p[0]), b[3].max(p[1])];
        }
    }
    let m = 0.04 * (b[2] - b[0]).max(b[3] - b[1]);
    Drawing {
        lines,
        bounds: [b[0] - m, b[1] - m, b[2] + m, b[3] + m],
    }
}

impl Drawing {
    /// Pixels per mm for an image `width` pixels wide, and the image height.
    fn scale(&self, width: f64) -> (f64, f64) {
        let s = width / (self.bounds[2] - self.bounds[0]);
        (s, (self.bounds[3] - self.bounds[1]) * s)
    }

    /// Image coordinates of a lens point: the scene on the left, the film on the right, y up.
    fn to_image(&self, p: [f64; 2], s: f64) -> (f64, f64) {
        ((self.bounds[2] - p[0]) * s, (self.bounds[3] - p[1]) * s)
    }

    fn svg(&self) -> String {
        let (s, h) = self.scale(900.0);
        let mut out = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"900\" height=\"{h:.0}\" viewBox=\"0 0 900 {h:.0}\">\n\
             <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
        );
        for (poly, c, wdt) in &self.lines {
            let pts: Vec<String> = poly
                .iter()
                .map(|p| {
                    let (x, y) = self.to_image(*p, s);
                    format!("{x:.2},{y:.2}")
                })
                .collect();
            let _ = writeln!(
                out,
                "<polyline fill=\"none\" stroke=\"rgb({},{},{})\" stroke-width=\"{wdt}\" points=\"{}\"/>",
                c[0],
                c[1],
                c[2],
                pts.join(" ")
            );
        }
        out.push_str("</svg>\n");
        out
    }

    /// An RGB raster 900 pixels wide: each segment drawn as a disk-brushed line, 3×3 supersampled.
    #[allow(clippy::needless_range_loop)] // the channel indexes nine samples of the block
    fn raster(&self) -> (u32, u32, Vec<u8>) {
        let ss = 3.0;
        let (s, h) = self.scale(900.0 * ss);
        let (w, hh) = ((900.0 * ss) as usize, h.ceil() as usize + 1);
        let mut cover = vec![[255u8; 3]; w * hh];
        for (poly, c, wdt) in &self.lines {
            let rad = 0.5 * wdt * ss;
            for seg in poly.windows(2) {
                let (a, b) = (self.to_image(seg[0], s), self.to_image(seg[1], s));
                let len = (b.0 - a.0).hypot(b.1 - a.1);
                let steps = (len / 0.5).ceil().max(1.0) as usize;
                for k in 0..=steps {
                    let t = k as f64 / steps as f64;
                    let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
                    let (x0, x1) = (
                        (x - rad).floor().max(0.0) as usize,
                        ((x + rad).ceil() as usize).min(w - 1),
                    );
                    let (y0, y1) = (
                        (y - rad).floor().max(0.0) as usize,
                        ((y + rad).ceil() as usize).min(hh - 1),
                    );
                    for py in y0..=y1 {
                        for px in x0..=x1 {
                            if (px as f64 + 0.5 - x).hypot(py as f64 + 0.5 - y) <= rad.max(0.75) {
                                cover[py * w + px] = *c;
                            }
                        }
                    }
                }
            }
        }
        let (ow, oh) = (w / 3, hh / 3);
        let mut data = Vec::with_capacity(ow * oh * 3);
        for y in 0..oh {
            for x in 0..ow {
                for ch in 0..3 {
                    let mut sum = 0u32;
                    for dy in 0..3 {
                        for dx in 0..3 {
                            sum += u32::from(cover[(3 * y + dy) * w + 3 * x + dx][ch]);
                        }
                    }
                    data.push((sum / 9) as u8);
                }
            }
        }
        (ow as u32, oh as u32, data)
    }
}

fn write_png(path: &Path, d: &Drawing) -> Result<(), String> {
    let (w, h, data) = d.raster();
    write_atomically(path, |out| {
        let mut encoder = png::Encoder::new(out, w, h);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
        writer.write_image_data(&data).map_err(std::io::Error::other)?;
        writer.finish().map_err(std::io::Error::other)
    })
    .map_err(|e| e.to_string())
}
