//! The colour filter array: which channel (0 = R, 1 = G, 2 = B) each photosite sees.
//!
//! A Bayer pattern is named by its 2×2 cell read row by row from the top-left photosite: `RGGB` puts
//! R at (0, 0), G at (1, 0) and (0, 1), B at (1, 1) (x to the right, y down). The channel of pixel
//! `(x, y)` is `cell[y mod 2][x mod 2]`, in the full image's coordinates, so a crop keeps the phase of
//! the full frame.

/// A colour filter array.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cfa {
    /// No filter: a monochrome sensor, one panchromatic channel.
    None,
    /// R G / G B.
    Rggb,
    /// B G / G R.
    Bggr,
    /// G R / B G.
    Grbg,
    /// G B / R G.
    Gbrg,
}

impl Cfa {
    /// Reads `none`, `RGGB`, `BGGR`, `GRBG`, `GBRG` (any case).
    #[must_use]
    pub fn parse(s: &str) -> Option<Cfa> {
        match s.to_ascii_uppercase().as_str() {
            "NONE" => Some(Cfa::None),
            "RGGB" => Some(Cfa::Rggb),
            "BGGR" => Some(Cfa::Bggr),
            "GRBG" => Some(Cfa::Grbg),
            "GBRG" => Some(Cfa::Gbrg),
            _ => None,
        }
    }

    /// The name as [`Cfa::parse`] reads it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Cfa::None => "none",
            Cfa::Rggb => "RGGB",
            Cfa::Bggr => "BGGR",
            Cfa::Grbg => "GRBG",
            Cfa::Gbrg => "GBRG",
        }
    }

    /// The 2×2 cell, `cell[row][column]`; `None` for a monochrome sensor.
    #[must_use]
    pub fn cell(self) -> Option<[[u8; 2]; 2]> {
        match self {
            Cfa::None => None,
            Cfa::Rggb => Some([[0, 1], [1, 2]]),
            Cfa::Bggr => Some([[2, 1], [1, 0]]),
            Cfa::Grbg => Some([[1, 0], [2, 1]]),
            Cfa::Gbrg => Some([[1, 2], [0, 1]]),
        }
    }

    /// The channel of pixel `(x, y)` (full-image coordinates); `None` for a monochrome sensor.
    #[must_use]
    pub fn channel(self, x: u32, y: u32) -> Option<u8> {
        self.cell().map(|c| c[(y & 1) as usize][(x & 1) as usize])
    }

    /// The pattern seen from pixel `(x0, y0)` on (a crop's origin): the 2×2 cell starting there.
    #[must_use]
    pub fn at_origin(self, x0: u32, y0: u32) -> Option<[[u8; 2]; 2]> {
        let cell = self.cell()?;
        Some([0, 1].map(|r| [0, 1].map(|c| cell[((y0 + r) & 1) as usize][((x0 + c) & 1) as usize])))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_spell_the_cell() {
        for cfa in [Cfa::Rggb, Cfa::Bggr, Cfa::Grbg, Cfa::Gbrg] {
            let letters: String = cfa
                .cell()
                .unwrap()
                .iter()
                .flatten()
                .map(|&c| ['R', 'G', 'B'][c as usize])
                .collect();
            assert_eq!(letters, cfa.name());
            assert_eq!(Cfa::parse(&cfa.name().to_lowercase()), Some(cfa));
        }
        // One pixel over, RGGB reads as GRBG; one line down as GBRG; both, BGGR.
        assert_eq!(Cfa::Rggb.at_origin(1, 0), Cfa::Grbg.cell());
        assert_eq!(Cfa::Rggb.at_origin(0, 1), Cfa::Gbrg.cell());
        assert_eq!(Cfa::Rggb.at_origin(1, 1), Cfa::Bggr.cell());
    }
}
