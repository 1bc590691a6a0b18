//! Fixtures the tests of several modules share.

/// The six faces of a cube whose corner `k` sits at the `k & 1`, `k >> 1 & 1`, `k >> 2 & 1` ends of
/// x, y and z, as quads wound counter-clockwise seen from outside.
pub(crate) const CUBE_QUADS: [[u32; 4]; 6] = [
    [0, 2, 3, 1],
    [4, 5, 7, 6],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 4, 6, 2],
    [1, 3, 7, 5],
];
