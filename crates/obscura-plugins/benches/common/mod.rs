//! What the plugin benches share: the 1920×1080 camera and its batch of samples.

use obscura_host::{Batch, CameraDesc};
use obscura_sdk::{Format, Point2};

/// A 1920×1080 camera with a shutter of one unit.
pub fn camera() -> CameraDesc {
    let mut c = CameraDesc::new(Format::new(1920, 1080));
    c.shutter = (0.0, 1.0);
    c
}

/// `n` screen samples spread over the frame (a 16-column grid), stratified lens and time samples.
pub fn samples(cam: &CameraDesc, n: usize) -> Batch {
    let mut b = Batch::with_capacity(n);
    let rows = n.div_ceil(16) as f64;
    for i in 0..n {
        let (x, y) = (
            (i % 16) as f64 * 120.0 + 60.0,
            ((i / 16) as f64 + 0.5) * 1080.0 / rows,
        );
        b.push(
            cam.raster_to_screen(x, y),
            Point2::new(((i * 37) % n) as f32 / n as f32, ((i * 91) % n) as f32 / n as f32),
            i as f32 / n as f32,
        );
    }
    b
}
