//! One batch of samples in and rays out (`RixProjectionContext`).

use crate::geometry::{Point2, Rgb};
use crate::ray::RayGeometry;

/// The inputs and outputs of one [`crate::Projection::project`] call.
///
/// Every array has the same length, [`ProjectionContext::num_rays`]; the constructor checks it once,
/// so a projection may index them all with the same `i` without further checks.
///
/// | field | RenderMan | direction | meaning |
/// |---|---|---|---|
/// | `screen` | `screen` | in | screen-space sample positions (see conventions) |
/// | `lens` | `lens` | in | raw stratified samples in `[0, 1)²` |
/// | `aperture` | `aperture` | in | the lens samples warped by the host's aperture description into `[−1, 1]²` |
/// | `time` | `time` | in/out | shutter-normalised times in `[0, 1)`; a projection may rewrite them |
/// | `rays` | `rays` | out | pre-filled with the host's default camera rays; the projection writes its own |
/// | `tint` | `tint` | in/out | pre-filled with white; multiplies the beauty before the pixel filter |
#[derive(Debug)]
pub struct ProjectionContext<'a> {
    screen: &'a [Point2],
    lens: &'a [Point2],
    aperture: &'a [Point2],
    time: &'a mut [f32],
    rays: &'a mut [RayGeometry],
    tint: &'a mut [Rgb],
}

/// The arrays of a [`ProjectionContext`] borrowed all at once, so a projection can read its inputs
/// while it writes its outputs. All have the same length.
#[derive(Debug)]
pub struct ContextParts<'c> {
    /// Screen samples (in).
    pub screen: &'c [Point2],
    /// Canonical lens samples in `[0, 1)²` (in).
    pub lens: &'c [Point2],
    /// Aperture samples in `[−1, 1]²` (in).
    pub aperture: &'c [Point2],
    /// Shutter-normalised time (in/out).
    pub time: &'c mut [f32],
    /// Camera rays (out).
    pub rays: &'c mut [RayGeometry],
    /// Per-ray tint of the beauty (in/out).
    pub tint: &'c mut [Rgb],
}

/// The arrays handed to [`ProjectionContext::new`] were not all the same length.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "projection context arrays differ in length: screen {screen}, lens {lens}, aperture {aperture}, \
     time {time}, rays {rays}, tint {tint}"
)]
pub struct ContextLengthError {
    /// Length of `screen`.
    pub screen: usize,
    /// Length of `lens`.
    pub lens: usize,
    /// Length of `aperture`.
    pub aperture: usize,
    /// Length of `time`.
    pub time: usize,
    /// Length of `rays`.
    pub rays: usize,
    /// Length of `tint`.
    pub tint: usize,
}

impl<'a> ProjectionContext<'a> {
    /// Bundles one batch. Fails unless every array has the same length.
    pub fn new(
        screen: &'a [Point2],
        lens: &'a [Point2],
        aperture: &'a [Point2],
        time: &'a mut [f32],
        rays: &'a mut [RayGeometry],
        tint: &'a mut [Rgb],
    ) -> Result<Self, ContextLengthError> {
        let n = screen.len();
        if [lens.len(), aperture.len(), time.len(), rays.len(), tint.len()]
            .iter()
            .any(|&l| l != n)
        {
            return Err(ContextLengthError {
                screen: n,
                lens: lens.len(),
                aperture: aperture.len(),
                time: time.len(),
                rays: rays.len(),
                tint: tint.len(),
            });
        }
        Ok(ProjectionContext {
            screen,
            lens,
            aperture,
            time,
            rays,
            tint,
        })
    }

    /// The number of rays in this batch (`numRays`).
    #[must_use]
    pub fn num_rays(&self) -> usize {
        self.screen.len()
    }

    /// Screen samples.
    #[must_use]
    pub fn screen(&self) -> &[Point2] {
        self.screen
    }

    /// Canonical lens samples.
    #[must_use]
    pub fn lens(&self) -> &[Point2] {
        self.lens
    }

    /// Warped aperture samples.
    #[must_use]
    pub fn aperture(&self) -> &[Point2] {
        self.aperture
    }

    /// Times, as they stand.
    #[must_use]
    pub fn time(&self) -> &[f32] {
        self.time
    }

    /// Rays, as they stand.
    #[must_use]
    pub fn rays(&self) -> &[RayGeometry] {
        self.rays
    }

    /// Tints, as they stand.
    #[must_use]
    pub fn tint(&self) -> &[Rgb] {
        self.tint
    }

    /// All arrays at once: read the inputs, write the outputs.
    pub fn parts_mut(&mut self) -> ContextParts<'_> {
        ContextParts {
            screen: self.screen,
            lens: self.lens,
            aperture: self.aperture,
            time: self.time,
            rays: self.rays,
            tint: self.tint,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mismatched_lengths_are_refused_with_every_length_named() {
        let s = [Point2::ZERO; 3];
        let mut t = [0.0; 2];
        let mut r = [RayGeometry::CULLED; 3];
        let mut c = [Rgb::WHITE; 3];
        let err = ProjectionContext::new(&s, &s, &s, &mut t, &mut r, &mut c).unwrap_err();
        assert_eq!(err.time, 2);
        assert!(err.to_string().contains("time 2"));
    }

    #[test]
    fn parts_share_one_length() {
        let s = [Point2::ZERO; 5];
        let mut t = [0.0; 5];
        let mut r = [RayGeometry::CULLED; 5];
        let mut c = [Rgb::WHITE; 5];
        let mut ctx = ProjectionContext::new(&s, &s, &s, &mut t, &mut r, &mut c).unwrap();
        assert_eq!(ctx.num_rays(), 5);
        let p = ctx.parts_mut();
        assert_eq!(p.rays.len(), p.screen.len());
        p.time[4] = 0.5;
        assert_eq!(ctx.time()[4], 0.5);
    }
}
