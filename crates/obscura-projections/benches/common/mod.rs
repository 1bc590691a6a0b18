//! What the projection benches share: a batch of samples over a 1920×1080 frame in the layout the
//! renderer hands to `project`, and a projection made by name from `"type name"` parameters.

// Each bench is its own crate and uses its part of this module.
#![allow(dead_code)]

use obscura_sdk::{
    Format, ParamList, Point2, Projection, ProjectionContext, ProjectionEnvironment, RayGeometry, RaysSoa,
    Rgb, ScreenWindow, SoaContext, SoaFields,
};

/// The frame every bench covers.
pub const FORMAT: (u32, u32) = (1920, 1080);

/// How the host's lens samples become the aperture samples a projection sees.
#[derive(Clone, Copy)]
pub enum Aperture {
    /// `2·lens − 1`: the square [−1, 1]², what a thin lens maps itself.
    Square,
    /// A polar map onto the unit disk (the host's default circular aperture, not area-stratified
    /// like the concentric map, which the bench does not need).
    Disk,
}

/// Screen samples on a grid over the frame, stratified lens samples, a time ramp over the shutter,
/// and the output buffers.
pub struct Batch {
    /// The screen samples.
    pub screen: Vec<Point2>,
    lens: Vec<Point2>,
    aperture: Vec<Point2>,
    time: Vec<f32>,
    /// The rays of the last `run`.
    pub rays: Vec<RayGeometry>,
    /// The tints of the last `run`.
    pub tint: Vec<Rgb>,
    /// The ten arrays of `run_soa`, from the first 64-byte boundary of this buffer on.
    soa: Vec<f32>,
    /// The tints of `run_soa`, three arrays.
    soa_tint: Vec<f32>,
}

impl Batch {
    /// `n` samples, the aperture samples mapped as `aperture` says.
    pub fn new(n: usize, aperture: Aperture) -> Self {
        let format = Format::new(FORMAT.0, FORMAT.1);
        let (w, h) = (f64::from(FORMAT.0), f64::from(FORMAT.1));
        let window = ScreenWindow::default_for(format);
        let side = (n as f64).sqrt().ceil() as usize;
        let screen = (0..n)
            .map(|i| {
                let (x, y) = ((i % side) as f64 + 0.5, (i / side) as f64 + 0.5);
                window.raster_to_screen(format, x / side as f64 * w, y / side as f64 * h)
            })
            .collect();
        let lens: Vec<Point2> = (0..n)
            .map(|i| Point2::new(((i * 37) % n) as f32 / n as f32, ((i * 91) % n) as f32 / n as f32))
            .collect();
        let aperture = lens
            .iter()
            .map(|l| match aperture {
                Aperture::Square => Point2::new(2.0 * l.x - 1.0, 2.0 * l.y - 1.0),
                Aperture::Disk => {
                    let (r, phi) = (l.x.sqrt(), std::f32::consts::TAU * l.y);
                    Point2::new(r * phi.cos(), r * phi.sin())
                }
            })
            .collect();
        Batch {
            screen,
            lens,
            aperture,
            time: (0..n).map(|i| i as f32 / n as f32).collect(),
            rays: vec![RayGeometry::CULLED; n],
            tint: vec![Rgb::WHITE; n],
            soa: vec![0.0; 10 * n + 16],
            soa_tint: vec![1.0; 3 * n],
        }
    }

    /// One `project_soa` call over the whole batch asking for `fields`, into ten arrays of `n`
    /// floats that start on a cache line when `n` is a multiple of 16. False when not offered.
    pub fn run_soa(&mut self, p: &dyn Projection, fields: SoaFields) -> bool {
        let n = self.screen.len();
        let skip = self.soa.as_ptr().align_offset(64);
        let rays = RaysSoa::from_fields(&mut self.soa[skip..skip + 10 * n]).expect("ten arrays");
        let mut tint = self.soa_tint.chunks_exact_mut(n.max(1));
        let [r, g, b] = std::array::from_fn(|_| tint.next().unwrap_or_default());
        let mut ctx = SoaContext::new(
            &self.screen,
            &self.lens,
            &self.aperture,
            &mut self.time,
            rays,
            [r, g, b],
        )
        .expect("equal lengths")
        .with_fields(fields);
        p.project_soa(&mut ctx)
    }

    /// One `project` call over the whole batch.
    pub fn run(&mut self, p: &dyn Projection) {
        let mut ctx = ProjectionContext::new(
            &self.screen,
            &self.lens,
            &self.aperture,
            &mut self.time,
            &mut self.rays,
            &mut self.tint,
        )
        .expect("equal lengths");
        p.project(&mut ctx);
    }
}

/// The built-in projection `name` with `params` (`("float fov", "40")`; several values separated by
/// spaces), for the bench's frame.
pub fn projection(name: &str, params: &[(&str, &str)]) -> Box<dyn Projection> {
    let mut list = ParamList::new();
    for (decl, v) in params {
        let values: Vec<&str> = v.split_whitespace().collect();
        list.push_text(decl, &values, None)
            .expect("valid bench parameter");
    }
    let mut env = ProjectionEnvironment::for_format(Format::new(FORMAT.0, FORMAT.1));
    let mut registry = obscura_host::Registry::new();
    for factory in obscura_projections::factories() {
        registry.register(factory, "").expect("built-in names are unique");
    }
    registry
        .create(name, &mut env, &list)
        .expect("valid bench projection")
}

/// `PxrPerspective`'s pinhole and thin lens as the tier benches and `examples/project_rate.rs` set
/// them up: fov 60, and f/2.8, 50 mm, focused at 4.
pub const PERSPECTIVE: [(&str, &[(&str, &str)]); 2] = [
    ("pinhole", &[("float fov", "60")]),
    (
        "thin_lens",
        &[
            ("float fov", "60"),
            ("float fStop", "2.8"),
            ("float focalLength", "0.05"),
            ("float focalDistance", "4"),
        ],
    ),
];
