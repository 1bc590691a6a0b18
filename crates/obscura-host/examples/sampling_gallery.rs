//! Draws `docs/sampling.png`: what the host's aperture and shutter warps hand a projection.
//!
//! Top row: 6000 aperture samples each (Owen-scrambled Sobol lens samples through the warp) for eight
//! aperture descriptions. Bottom row: four shutter-opening descriptions, each as its efficiency curve
//! e(t) (white) over a histogram of 200 000 warped time samples (blue), which must follow the curve.
//!
//! Run: `cargo run -p obscura-host --example sampling_gallery -- docs/sampling.png`

use std::io::BufWriter;

use obscura_host::aperture::{ApertureDesc, ApertureWarp};
use obscura_host::sampler::Sampler;
use obscura_host::shutter::{ShutterDesc, ShutterWarp};
use obscura_sdk::Point2;

const PANEL: usize = 200;
const GAP: usize = 8;
const COLS: usize = 8;

struct Canvas {
    w: usize,
    h: usize,
    px: Vec<[u8; 3]>,
}

impl Canvas {
    fn new(w: usize, h: usize) -> Self {
        Canvas {
            w,
            h,
            px: vec![[24, 24, 28]; w * h],
        }
    }
    fn put(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as usize) < self.w && (y as usize) < self.h {
            self.px[y as usize * self.w + x as usize] = c;
        }
    }
    fn fill(&mut self, x0: usize, y0: usize, w: usize, h: usize, c: [u8; 3]) {
        for y in y0..y0 + h {
            for x in x0..x0 + w {
                self.put(x as i64, y as i64, c);
            }
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "docs/sampling.png".into());
    let apertures = [
        ApertureDesc::default(),
        ApertureDesc {
            n_sides: 5,
            roundness: 0.0,
            ..Default::default()
        },
        ApertureDesc {
            n_sides: 5,
            roundness: 0.0,
            angle_deg: 36.0,
            ..Default::default()
        },
        ApertureDesc {
            n_sides: 6,
            roundness: 0.5,
            ..Default::default()
        },
        ApertureDesc {
            n_sides: 6,
            roundness: -1.0,
            ..Default::default()
        },
        ApertureDesc {
            density: 1.0,
            ..Default::default()
        },
        ApertureDesc {
            density: -1.0,
            ..Default::default()
        },
        ApertureDesc {
            dof_aspect: 2.0,
            ..Default::default()
        },
    ];
    let shutters = [
        ShutterDesc::default(),
        ShutterDesc {
            open_time: 0.25,
            close_time: 0.75,
            ..Default::default()
        },
        ShutterDesc {
            open_time: 0.0,
            close_time: 0.0,
            ..Default::default()
        },
        ShutterDesc {
            open_time: 1.0,
            close_time: 1.0,
            opening: [0.8, 0.1, 0.9, 0.2, 1.0, 1.0, 1.0, 1.0],
        },
    ];
    let width = COLS * PANEL + (COLS + 1) * GAP;
    let height = 2 * PANEL + 3 * GAP;
    let mut c = Canvas::new(width, height);
    let sampler = Sampler::new(0);

    for (i, desc) in apertures.iter().enumerate() {
        let warp = ApertureWarp::new(desc)?;
        let (x0, y0) = (GAP + i * (PANEL + GAP), GAP);
        c.fill(x0, y0, PANEL, PANEL, [0, 0, 0]);
        for k in 0..6000 {
            let s = sampler.sample(0, 0, k);
            let p = warp.warp(Point2::new(s.lens.0, s.lens.1));
            let half = (PANEL / 2) as f32 - 4.0;
            let x = x0 as i64 + (PANEL / 2) as i64 + (p.x * half).round() as i64;
            let y = y0 as i64 + (PANEL / 2) as i64 - (p.y * half).round() as i64;
            c.put(x, y, [255, 214, 120]);
        }
    }

    let panel_w = (width - 5 * GAP) / 4;
    for (i, desc) in shutters.iter().enumerate() {
        let warp = ShutterWarp::new(desc)?;
        let (x0, y0) = (GAP + i * (panel_w + GAP), 2 * GAP + PANEL);
        c.fill(x0, y0, panel_w, PANEL, [0, 0, 0]);
        let bins = 80;
        let mut hist = vec![0u32; bins];
        let n = 200_000;
        for k in 0..n {
            let t = warp.warp((k as f32 + 0.5) / n as f32);
            hist[((t * bins as f32) as usize).min(bins - 1)] += 1;
        }
        // Scale so that a density equal to the curve's peak efficiency fills the panel height.
        let area: f64 = (0..1000)
            .map(|j| warp.efficiency((j as f32 + 0.5) / 1000.0) as f64)
            .sum::<f64>()
            / 1000.0;
        let plot_h = (PANEL - 20) as f64;
        for (b, count) in hist.iter().enumerate() {
            let density = *count as f64 / n as f64 * bins as f64 * area;
            let h = (density * plot_h).round() as usize;
            let bx = x0 + b * panel_w / bins;
            let bw = (panel_w / bins).max(1) - 1;
            c.fill(
                bx,
                y0 + PANEL - 10 - h.min(PANEL - 10),
                bw.max(1),
                h.min(PANEL - 10),
                [60, 110, 200],
            );
        }
        for x in 0..panel_w {
            let e = warp.efficiency((x as f32 + 0.5) / panel_w as f32) as f64;
            let y = (y0 + PANEL - 10) as i64 - (e * plot_h).round() as i64;
            c.put((x0 + x) as i64, y, [255, 255, 255]);
            c.put((x0 + x) as i64, y + 1, [255, 255, 255]);
        }
    }

    let file = std::fs::File::create(&path)?;
    let mut enc = png::Encoder::new(BufWriter::new(file), width as u32, height as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let data: Vec<u8> = c.px.iter().flatten().copied().collect();
    enc.write_header()?.write_image_data(&data)?;
    println!("wrote {path}");
    Ok(())
}
