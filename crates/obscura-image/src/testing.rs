//! Fixtures the tests of several modules share.

use obscura_host::PixelRect;
use obscura_scene::FilterKind;

/// Every pixel filter kind.
pub(crate) const ALL_FILTERS: [FilterKind; 6] = [
    FilterKind::Box,
    FilterKind::Triangle,
    FilterKind::Gaussian,
    FilterKind::CatmullRom,
    FilterKind::Mitchell,
    FilterKind::BlackmanHarris,
];

/// The pixels `x0..x1` × `y0..y1`.
pub(crate) fn rect(x0: u32, x1: u32, y0: u32, y1: u32) -> PixelRect {
    PixelRect { x0, x1, y0, y1 }
}
