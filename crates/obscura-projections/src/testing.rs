//! Test helpers: run a projection on hand-made samples.

use obscura_sdk::{Format, Point2, Projection, ProjectionContext, RayGeometry, Rgb, ScreenWindow};

/// Projects one batch of hand-made samples and returns the rays.
pub fn project_points(
    p: &dyn Projection,
    screen: &[Point2],
    aperture: &[Point2],
    time: &[f32],
) -> Vec<RayGeometry> {
    let n = screen.len();
    let lens: Vec<Point2> = aperture
        .iter()
        .map(|a| Point2::new(0.5 * a.x + 0.5, 0.5 * a.y + 0.5))
        .collect();
    let mut time = time.to_vec();
    let mut rays = vec![RayGeometry::CULLED; n];
    let mut tint = vec![Rgb::WHITE; n];
    let mut ctx = ProjectionContext::new(screen, &lens, aperture, &mut time, &mut rays, &mut tint).unwrap();
    p.project(&mut ctx);
    rays
}

/// The rays through every pixel centre of `format` with the default screen window, row by row.
pub fn pixel_centre_rays(p: &dyn Projection, format: Format) -> Vec<RayGeometry> {
    let w = ScreenWindow::default_for(format);
    let screen: Vec<Point2> = (0..format.height)
        .flat_map(|y| (0..format.width).map(move |x| (x, y)))
        .map(|(x, y)| w.raster_to_screen(format, x as f64 + 0.5, y as f64 + 0.5))
        .collect();
    let n = screen.len();
    project_points(p, &screen, &vec![Point2::ZERO; n], &vec![0.0; n])
}
