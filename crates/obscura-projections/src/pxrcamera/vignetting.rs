//! PxrCamera's vignetting, all of it through the tint (culled samples would not darken anything).
//!
//! **Natural** (`natural`): `tint ·= 1 + natural·(cos⁴θ − 1)`, θ the angle between the chief ray (the
//! pinhole direction `w`) and the view axis, `cosθ = w.z`.
//!
//! **Optical** (`optical`, the cat's eye): the aperture (the unit disk of the aperture samples) is
//! clipped by a second unit disk — the image of a front element or lens hood — whose centre is
//! `b = −optical·(w.x, w.y)/w.z`: displaced against the field direction in proportion to the tangent of
//! the field angle, as a stop `optical` lens radii in front of the aperture would be. The light that
//! passes is the intersection of the two disks, a symmetric lens whose area is, for centre distance
//! `δ = |b| < 2`,
//!
//! ```text
//! A(δ) = 2·acos(δ/2) − (δ/2)·√(4 − δ²)         (A(0) = π, A(≥ 2) = 0)
//! ```
//!
//! so `tint ·= A(δ)/π`, and each aperture sample is moved into the intersection so that the bokeh
//! takes its cat's-eye shape: in the frame `e₁ = b/δ`, `e₂ ⊥ e₁` the sample `(α, β)` goes to
//! `b/2 + ξ·e₁ + η·e₂` with
//!
//! ```text
//! η = k·β,  k = √(1 − δ²/4)                      the lens's half height
//! ξ = α·(√(1 − η²) − δ/2)/√(1 − β²)              the unit disk's chord at β onto the lens's chord at η
//! ```
//!
//! which maps the unit disk onto the lens one to one and keeps every sample inside both disks (it is
//! the identity at δ = 0). The mapping is not area-preserving, so a uniform aperture gives a lens with
//! gently varying density (brighter toward its tips); the tint, not the sample density, carries the
//! darkening.

/// The natural-vignetting factor `1 + natural·(cos⁴θ − 1)` for `cosθ = cos_theta`.
#[inline(always)]
pub(crate) fn natural_factor(natural: f32, cos_theta: f32) -> f32 {
    let c2 = cos_theta * cos_theta;
    1.0 + natural * (c2 * c2 - 1.0)
}

/// The fraction of a unit disk covered by its intersection with another unit disk whose centre lies
/// `distance` away: `A(δ)/π` (1 at 0, 0 from 2 on).
#[inline(always)]
pub(crate) fn disk_overlap_fraction(distance: f32) -> f32 {
    if distance >= 2.0 {
        return 0.0;
    }
    let h = 0.5 * distance.max(0.0);
    let area = 2.0 * h.acos() - h * 2.0 * (1.0 - h * h).max(0.0).sqrt();
    (area * std::f32::consts::FRAC_1_PI).clamp(0.0, 1.0)
}

/// Moves aperture sample `a` (inside the unit disk) into the intersection of the unit disk and the
/// unit disk centred at `b`, and returns it with the area fraction of that intersection.
#[inline(always)]
pub(crate) fn cat_eye(b: (f32, f32), a: (f32, f32)) -> ((f32, f32), f32) {
    let dist2 = b.0 * b.0 + b.1 * b.1;
    if dist2 <= 1e-24 {
        return (a, 1.0);
    }
    let dist = dist2.sqrt();
    if dist >= 2.0 {
        // No light passes: the tint is zero and the sample sits on the aperture's rim nearest the
        // clipping disk.
        return ((b.0 / dist, b.1 / dist), 0.0);
    }
    let e1 = (b.0 / dist, b.1 / dist);
    let alpha = a.0 * e1.0 + a.1 * e1.1;
    let beta = (a.1 * e1.0 - a.0 * e1.1).clamp(-1.0, 1.0);
    let half = 0.5 * dist;
    let k = (1.0 - half * half).max(0.0).sqrt();
    let eta = k * beta;
    let chord_disk = (1.0 - beta * beta).max(0.0).sqrt();
    let chord_lens = ((1.0 - eta * eta).max(0.0).sqrt() - half).max(0.0);
    let xi = if chord_disk > 0.0 {
        (alpha / chord_disk).clamp(-1.0, 1.0) * chord_lens
    } else {
        0.0
    };
    let mapped = (
        half * e1.0 + xi * e1.0 - eta * e1.1,
        half * e1.1 + xi * e1.1 + eta * e1.0,
    );
    (mapped, disk_overlap_fraction(dist))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn natural_is_cos4_at_one_and_off_at_zero() {
        for c in [1.0f32, 0.9, 0.5, 0.1] {
            assert!((natural_factor(1.0, c) - c.powi(4)).abs() < 1e-7);
            assert_eq!(natural_factor(0.0, c), 1.0);
            assert!((natural_factor(0.5, c) - (1.0 + c.powi(4)) / 2.0).abs() < 1e-7);
        }
    }

    #[test]
    fn overlap_fraction_matches_monte_carlo() {
        // A fixed 512×512 grid over the unit disk's bounding square: an independent area estimate.
        let n = 512;
        for dist in [0.0f32, 0.3, 0.8, 1.2, 1.7, 1.95, 2.0, 2.5] {
            let (mut inside_a, mut inside_both) = (0u32, 0u32);
            for i in 0..n {
                for j in 0..n {
                    let x = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                    let y = -1.0 + 2.0 * (j as f64 + 0.5) / n as f64;
                    if x * x + y * y <= 1.0 {
                        inside_a += 1;
                        if (x - dist as f64).powi(2) + y * y <= 1.0 {
                            inside_both += 1;
                        }
                    }
                }
            }
            let mc = inside_both as f64 / inside_a as f64;
            let exact = disk_overlap_fraction(dist) as f64;
            assert!(
                (mc - exact).abs() < 2e-3,
                "distance {dist}: grid {mc}, formula {exact}"
            );
        }
        assert_eq!(disk_overlap_fraction(0.0), 1.0);
    }

    proptest! {
        #[test]
        fn cat_eye_samples_stay_inside_both_disks(
            bx in -2.2f32..2.2, by in -2.2f32..2.2, r in 0.0f32..1.0, phi in 0.0f32..6.3,
        ) {
            let a = (r * phi.cos(), r * phi.sin());
            let ((x, y), frac) = cat_eye((bx, by), a);
            prop_assert!(x.is_finite() && y.is_finite() && (0.0..=1.0).contains(&frac));
            prop_assert!(x * x + y * y <= 1.0 + 1e-5, "outside the aperture: {x} {y}");
            // (When the disks do not meet, no point is in both: the tint is zero then.)
            prop_assert!(frac == 0.0 || (x - bx).powi(2) + (y - by).powi(2) <= 1.0 + 1e-5, "outside the clipping disk: {x} {y}");
            prop_assert_eq!(frac == 0.0, bx.hypot(by) >= 2.0);
        }

        #[test]
        fn cat_eye_is_one_to_one(dist in 0.0f32..1.9, psi in 0.0f32..6.3, r in 0.05f32..0.95, phi in 0.0f32..6.3) {
            let (bx, by) = (dist * psi.cos(), dist * psi.sin());
            // Two different samples never land on the same point: the map is monotonic along chords.
            let a = (r * phi.cos(), r * phi.sin());
            let b = (0.97 * a.0 + 0.01, 0.97 * a.1 - 0.01);
            let (p, _) = cat_eye((bx, by), a);
            let (q, _) = cat_eye((bx, by), b);
            prop_assert!((p.0 - q.0).abs() + (p.1 - q.1).abs() > 1e-6);
        }
    }

    #[test]
    fn cat_eye_fills_the_lens_out_to_its_tips() {
        // The extreme samples reach the lens's corners and edges.
        let b = (1.0, 0.0);
        let k = (1.0f32 - 0.25).sqrt();
        let ((x, y), frac) = cat_eye(b, (0.0, 1.0));
        assert!((x - 0.5).abs() < 1e-6 && (y - k).abs() < 1e-6, "{x} {y}");
        let ((x, _), _) = cat_eye(b, (1.0, 0.0));
        assert!((x - 1.0).abs() < 1e-6, "right tip {x}");
        let ((x, _), _) = cat_eye(b, (-1.0, 0.0));
        assert!(x.abs() < 1e-6, "left tip {x}");
        let exact = (2.0 * (0.5f64).acos() - 0.5 * 3f64.sqrt()) / std::f64::consts::PI;
        assert!((frac as f64 - exact).abs() < 1e-6);
        // No offset: the identity.
        assert_eq!(cat_eye((0.0, 0.0), (0.3, -0.2)), ((0.3, -0.2), 1.0));
    }
}
