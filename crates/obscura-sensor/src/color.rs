//! 3×3 colour matrices: linear sRGB ↔ CIE XYZ (D65), published camera matrices, inverses.
//!
//! A camera's published colour matrix `C` (Adobe DNG's ColorMatrix under D65, as tabulated by dcraw
//! and LibRaw: XYZ → camera, ×10⁻⁴) gives the response to linear sRGB as `M = C·S` with `S` the
//! sRGB → XYZ matrix; it is scaled so that the strongest channel's response to white `(1, 1, 1)` is 1.
//! The DNG's own ColorMatrix1 for a response `M` is `M·S⁻¹`, scaled so that the D65 white `S·(1,1,1)`
//! maps to a camera vector whose largest component is 1.

/// A 3×3 matrix, rows first; it multiplies column vectors.
pub type Mat3 = [[f64; 3]; 3];

/// The identity.
pub const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Linear sRGB (Rec. 709 primaries, D65) → CIE XYZ (IEC 61966-2-1).
pub const SRGB_TO_XYZ: Mat3 = [
    [0.412_456_4, 0.357_576_1, 0.180_437_5],
    [0.212_672_9, 0.715_152_2, 0.072_175_0],
    [0.019_333_9, 0.119_192_0, 0.950_304_1],
];

/// Published cameras: name and XYZ → camera colour matrix ×10⁴ (Adobe's D65 matrices as dcraw lists
/// them).
pub const CAMERA_PRESETS: [(&str, [i32; 9]); 1] = [(
    "canon_eos_5d_mark_ii",
    [4716, 603, -830, -7798, 15474, 2480, -1496, 1937, 6651],
)];

/// The XYZ → camera matrix of a preset.
#[must_use]
pub fn camera_preset(name: &str) -> Option<Mat3> {
    let (_, c) = CAMERA_PRESETS.iter().find(|p| p.0 == name)?;
    Some([0, 1, 2].map(|r| [0, 1, 2].map(|k| f64::from(c[3 * r + k]) / 10_000.0)))
}

/// `a·b`.
#[must_use]
pub fn mul(a: Mat3, b: Mat3) -> Mat3 {
    [0, 1, 2].map(|r| [0, 1, 2].map(|c| (0..3).map(|k| a[r][k] * b[k][c]).sum()))
}

/// `m·v`.
#[must_use]
pub fn apply(m: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

/// `s·m`.
#[must_use]
pub fn scale(m: Mat3, s: f64) -> Mat3 {
    m.map(|row| row.map(|x| x * s))
}

/// The inverse (adjugate over determinant); `None` when singular.
#[must_use]
pub fn inverse(m: &Mat3) -> Option<Mat3> {
    let c = |r: usize, k: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
        m[r1][k1] * m[r2][k2] - m[r1][k2] * m[r2][k1]
    };
    let det = m[0][0] * c(0, 0) + m[0][1] * c(0, 1) + m[0][2] * c(0, 2);
    if det.abs() < 1e-12 || !det.is_finite() {
        return None;
    }
    Some([0, 1, 2].map(|r| [0, 1, 2].map(|k| c(k, r) / det)))
}

/// The response to linear sRGB of a camera with XYZ → camera matrix `c`, white's largest channel 1.
#[must_use]
pub fn srgb_response_of_color_matrix(c: Mat3) -> Mat3 {
    let m = mul(c, SRGB_TO_XYZ);
    let white = apply(&m, [1.0; 3]);
    scale(m, 1.0 / white.iter().copied().fold(f64::MIN, f64::max))
}

/// DNG's ColorMatrix1 (XYZ → camera, D65) for a response `m` to linear sRGB; `None` when `m` is
/// singular.
#[must_use]
pub fn dng_color_matrix(m: &Mat3) -> Option<Mat3> {
    let xyz_to_srgb = inverse(&SRGB_TO_XYZ)?;
    let c = mul(*m, xyz_to_srgb);
    inverse(&c)?;
    let white = apply(&c, apply(&SRGB_TO_XYZ, [1.0; 3]));
    let peak = white.iter().copied().fold(f64::MIN, f64::max);
    (peak > 0.0).then(|| scale(c, 1.0 / peak))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_is_exact() {
        for m in [SRGB_TO_XYZ, camera_preset("canon_eos_5d_mark_ii").unwrap()] {
            let p = mul(m, inverse(&m).unwrap());
            for r in 0..3 {
                for c in 0..3 {
                    assert!((p[r][c] - IDENTITY[r][c]).abs() < 1e-12);
                }
            }
        }
        assert!(inverse(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]).is_none());
    }

    /// sRGB white is D65: x = 0.3127, y = 0.3290.
    #[test]
    fn srgb_white_is_d65() {
        let w = apply(&SRGB_TO_XYZ, [1.0; 3]);
        let s = w[0] + w[1] + w[2];
        assert!((w[0] / s - 0.3127).abs() < 1e-4 && (w[1] / s - 0.3290).abs() < 1e-4);
    }

    /// The DNG matrix of a preset's response is the preset again, up to its normalisation.
    #[test]
    fn dng_matrix_round_trips_a_preset() {
        let c = camera_preset("canon_eos_5d_mark_ii").unwrap();
        let back = dng_color_matrix(&srgb_response_of_color_matrix(c)).unwrap();
        let ratio = back[1][1] / c[1][1];
        for r in 0..3 {
            for k in 0..3 {
                assert!((back[r][k] - ratio * c[r][k]).abs() < 1e-9);
            }
        }
    }
}
