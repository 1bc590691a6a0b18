//! Glass: the refractive index of a lens medium as a function of wavelength.
//!
//! - [`Glass::Constant`]: one index at every wavelength (the four-column files, air);
//! - [`Glass::Abbe`]: `nd` and the Abbe number `Vd = (nd − 1)/(nF − nC)`, through Cauchy's two-term
//!   formula `n(λ) = A + B/λ²` fitted so that `n(587.56 nm) = nd` and `nF − nC = (nd − 1)/Vd`:
//!   `B = (nd − 1)/(Vd·(1/λF² − 1/λC²))`, `A = nd − B/λd²`;
//! - [`Glass::Sellmeier`]: `n²(λ) = 1 + Σᵢ Bᵢ·λ²/(λ² − Cᵢ)`, λ in µm, `Cᵢ` in µm² (Schott's form).
//!
//! [`catalogue`] holds a few glasses by their catalogue names with the Sellmeier coefficients, `nd`
//! and `Vd` Schott (and, for fused silica, Malitson 1965) publish.

/// The helium d line, nm: the wavelength of `nd`.
pub const LAMBDA_D: f64 = 587.5618;
/// The hydrogen F line, nm.
pub const LAMBDA_F: f64 = 486.1327;
/// The hydrogen C line, nm.
pub const LAMBDA_C: f64 = 656.2725;

/// The refractive index of one medium as a function of wavelength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Glass {
    /// The same index at every wavelength (no dispersion).
    Constant(f64),
    /// Cauchy's `n(λ) = a + b/λ²` (λ in nm), made from `nd` and `Vd` by [`Glass::from_abbe`].
    Abbe {
        /// Index at the d line.
        nd: f64,
        /// Abbe number.
        vd: f64,
        /// Cauchy's constant term.
        a: f64,
        /// Cauchy's λ⁻² term, nm².
        b: f64,
    },
    /// Sellmeier's three-term formula, λ in µm.
    Sellmeier {
        /// `B1, B2, B3`.
        b: [f64; 3],
        /// `C1, C2, C3`, µm².
        c: [f64; 3],
    },
}

impl Glass {
    /// Air (index 1).
    pub const AIR: Glass = Glass::Constant(1.0);

    /// A glass from its d-line index and Abbe number (Cauchy's two-term fit through nd, nF − nC).
    #[must_use]
    pub fn from_abbe(nd: f64, vd: f64) -> Glass {
        let b = (nd - 1.0) / (vd * (LAMBDA_F.powi(-2) - LAMBDA_C.powi(-2)));
        Glass::Abbe {
            nd,
            vd,
            a: nd - b / (LAMBDA_D * LAMBDA_D),
            b,
        }
    }

    /// The refractive index at `lambda_nm`.
    #[inline]
    #[must_use]
    pub fn index(&self, lambda_nm: f64) -> f64 {
        match *self {
            Glass::Constant(n) => n,
            Glass::Abbe { a, b, .. } => a + b / (lambda_nm * lambda_nm),
            Glass::Sellmeier { b, c } => {
                let l2 = (lambda_nm * 1e-3) * (lambda_nm * 1e-3);
                let s: f64 = (0..3).map(|i| b[i] * l2 / (l2 - c[i])).sum();
                (1.0 + s).sqrt()
            }
        }
    }

    /// True when the index changes with wavelength.
    #[must_use]
    pub fn is_dispersive(&self) -> bool {
        !matches!(self, Glass::Constant(_))
    }

    /// The index at the d line.
    #[must_use]
    pub fn nd(&self) -> f64 {
        self.index(LAMBDA_D)
    }

    /// The Abbe number `(nd − 1)/(nF − nC)`, or infinity for a constant index.
    #[must_use]
    pub fn vd(&self) -> f64 {
        let dn = self.index(LAMBDA_F) - self.index(LAMBDA_C);
        if dn == 0.0 {
            f64::INFINITY
        } else {
            (self.nd() - 1.0) / dn
        }
    }
}

/// One catalogue glass: its name, the catalogue's `nd` and `Vd`, and its Sellmeier coefficients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CatalogueGlass {
    /// The catalogue name (`N-BK7`).
    pub name: &'static str,
    /// The catalogue's d-line index.
    pub nd: f64,
    /// The catalogue's Abbe number.
    pub vd: f64,
    /// Sellmeier `B1..B3`.
    pub b: [f64; 3],
    /// Sellmeier `C1..C3`, µm².
    pub c: [f64; 3],
}

impl CatalogueGlass {
    /// The glass as a [`Glass::Sellmeier`].
    #[must_use]
    pub fn glass(&self) -> Glass {
        Glass::Sellmeier { b: self.b, c: self.c }
    }
}

/// The built-in glass table: Schott optical glass data sheets (nd, Vd, Sellmeier B1–B3, C1–C3) and,
/// for fused silica, I. H. Malitson, JOSA 55 (1965) 1205.
pub const CATALOGUE: &[CatalogueGlass] = &[
    CatalogueGlass {
        name: "N-BK7",
        nd: 1.51680,
        vd: 64.17,
        b: [1.03961212, 0.231792344, 1.01046945],
        c: [0.00600069867, 0.0200179144, 103.560653],
    },
    CatalogueGlass {
        name: "N-BAF10",
        nd: 1.67003,
        vd: 47.11,
        b: [1.5851495, 0.143559385, 1.08521269],
        c: [0.00926681282, 0.0424489805, 105.613573],
    },
    CatalogueGlass {
        name: "N-LAK9",
        nd: 1.69100,
        vd: 54.71,
        b: [1.46231905, 0.344399589, 1.15508372],
        c: [0.00724270156, 0.0243353131, 85.4686868],
    },
    CatalogueGlass {
        name: "N-SK16",
        nd: 1.62041,
        vd: 60.32,
        b: [1.34317774, 0.241144399, 0.994317969],
        c: [0.00704687339, 0.0229005, 92.7508526],
    },
    CatalogueGlass {
        name: "F2",
        nd: 1.62004,
        vd: 36.37,
        b: [1.34533359, 0.209073176, 0.937357162],
        c: [0.00997743871, 0.0470450767, 111.886764],
    },
    CatalogueGlass {
        name: "N-SF5",
        nd: 1.67270,
        vd: 32.25,
        b: [1.52481889, 0.187085527, 1.42729015],
        c: [0.011254756, 0.0588995392, 129.141675],
    },
    CatalogueGlass {
        name: "N-SF6",
        nd: 1.80518,
        vd: 25.36,
        b: [1.77931763, 0.338149866, 2.08734474],
        c: [0.0133714182, 0.0617533621, 174.01759],
    },
    CatalogueGlass {
        name: "N-SF11",
        nd: 1.78472,
        vd: 25.68,
        b: [1.73759695, 0.313747346, 1.89878101],
        c: [0.013188707, 0.0623068142, 155.23629],
    },
    CatalogueGlass {
        name: "FUSED-SILICA",
        nd: 1.45846,
        vd: 67.82,
        b: [0.6961663, 0.4079426, 0.8974794],
        c: [0.004679148, 0.013512063, 97.934003],
    },
];

/// The catalogue glass named `name` (case-insensitive), or `None`.
#[must_use]
pub fn catalogue(name: &str) -> Option<&'static CatalogueGlass> {
    CATALOGUE.iter().find(|g| g.name.eq_ignore_ascii_case(name))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_catalogue_glass_reproduces_its_published_nd_and_vd() {
        for g in CATALOGUE {
            let s = g.glass();
            assert!(
                (s.nd() - g.nd).abs() < 2e-4,
                "{}: nd {} vs {}",
                g.name,
                s.nd(),
                g.nd
            );
            assert!(
                (s.vd() - g.vd).abs() < 0.15,
                "{}: Vd {} vs {}",
                g.name,
                s.vd(),
                g.vd
            );
        }
    }

    #[test]
    fn the_abbe_glass_has_its_nd_and_vd() {
        let g = Glass::from_abbe(1.6, 40.0);
        assert!((g.nd() - 1.6).abs() < 1e-12);
        assert!((g.vd() - 40.0).abs() < 1e-9);
        assert!(g.index(450.0) > g.index(650.0));
        assert_eq!(Glass::Constant(1.5).vd(), f64::INFINITY);
    }
}
