//! PxrCamera's plane of focus: `focalDistance` with the Scheimpflug `tilt` and `roll`, or three points
//! `focus1`, `focus2`, `focus3`.
//!
//! The plane is `{X : n·X = δ}` with unit normal `n` and `δ > 0`, `n.z > 0`.
//!
//! - From `tilt` τ, `roll` ρ and `focalDistance` f: the plane through the axis point `(0, 0, f)` with
//!   `n = (sin τ·sin ρ, sin τ·cos ρ, cos τ)` and `δ = f·cos τ`. `tilt > 0` turns the plane about the
//!   camera's x axis so that its top comes closer (RenderMan: "+ tilts up, top focus closer"); `roll`
//!   then turns it clockwise about the view axis (the near side moves from the top toward the right).
//!   `tilt` is the angle between the plane of focus and the image plane.
//! - From three points: `n ∝ (P₂ − P₁) × (P₃ − P₁)`, `δ = n·P₁`, oriented so that `δ > 0`. The
//!   equivalent `focalDistance` (where the view axis meets the plane) is `δ/n.z`, `tilt = acos(n.z)`,
//!   `roll = atan2(n.x, n.y)`. Refused: coincident or collinear points (no plane), a plane through the
//!   camera (no ray can focus on it) and a plane tilted more than [`MAX_TILT_DEGREES`] (the view axis
//!   meets it behind the camera, or never).

use obscura_sdk::Vec3;

/// The largest angle between the plane of focus and the image plane, in degrees.
pub(crate) const MAX_TILT_DEGREES: f64 = 89.0;

/// A plane of focus `n·X = δ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FocalPlane {
    /// Unit normal, `n.z > 0`.
    pub normal: [f64; 3],
    /// Distance from the camera, `δ > 0`.
    pub delta: f64,
}

impl FocalPlane {
    /// The plane through `(0, 0, focal_distance)` tilted by `tilt` and rolled by `roll` (degrees).
    pub(crate) fn from_tilt_roll(focal_distance: f64, tilt: f64, roll: f64) -> Self {
        let (st, ct) = tilt.to_radians().sin_cos();
        let (sr, cr) = roll.to_radians().sin_cos();
        FocalPlane {
            normal: [st * sr, st * cr, ct],
            delta: focal_distance * ct,
        }
    }

    /// The plane through three camera-space points.
    ///
    /// # Errors
    /// A message naming `focus1`, `focus2`, `focus3` and what is wrong with them.
    pub(crate) fn from_points(p: [Vec3; 3]) -> Result<Self, String> {
        let f = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
        let [a, b, c] = p.map(f);
        let shown = format!(
            "focus1 ({}, {}, {}), focus2 ({}, {}, {}), focus3 ({}, {}, {})",
            a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]
        );
        let e1 = sub(b, a);
        let e2 = sub(c, a);
        let n = cross(e1, e2);
        let (l1, l2, ln) = (norm(e1), norm(e2), norm(n));
        // |e1 × e2| = |e1||e2| sin(angle): collinear when the angle is below ~1e-6 rad.
        if ln.is_nan() || ln <= 1e-6 * l1 * l2 || l1 == 0.0 || l2 == 0.0 {
            return Err(format!(
                "{shown} are collinear or coincide, so they define no focal plane; expected three points \
                 (camera space) that span a plane"
            ));
        }
        let mut n = [n[0] / ln, n[1] / ln, n[2] / ln];
        let mut delta = dot(n, a);
        let extent = norm(a).max(norm(b)).max(norm(c));
        if delta.abs() <= 1e-6 * extent {
            return Err(format!(
                "the plane through {shown} passes through the camera, where no ray can focus; expected a \
                 plane in front of the camera"
            ));
        }
        if delta < 0.0 {
            n = n.map(|x| -x);
            delta = -delta;
        }
        let tilt = n[2].clamp(-1.0, 1.0).acos().to_degrees();
        if tilt > MAX_TILT_DEGREES {
            return Err(format!(
                "the plane through {shown} is tilted {tilt:.2}° from the image plane, so the view axis \
                 meets it {}; expected a plane tilted at most {MAX_TILT_DEGREES}° that the view axis crosses \
                 in front of the camera",
                if n[2].abs() < 1e-9 {
                    "never (it is parallel to the view)"
                } else if n[2] > 0.0 {
                    "only far off, at a grazing angle"
                } else {
                    "behind the camera"
                }
            ));
        }
        Ok(FocalPlane { normal: n, delta })
    }

    /// Where the view axis meets the plane: the equivalent `focalDistance`.
    pub(crate) fn axial_distance(&self) -> f64 {
        self.delta / self.normal[2]
    }

    /// The plane moved along the view axis by `shift` (its axial distance becomes `axial + shift`).
    pub(crate) fn shifted_delta(&self, shift: f64) -> f64 {
        self.delta + shift * self.normal[2]
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positive_tilt_brings_the_top_closer_and_roll_turns_it_clockwise() {
        let p = FocalPlane::from_tilt_roll(10.0, 20.0, 0.0);
        // z of the plane above and below the axis point.
        let z_at =
            |p: &FocalPlane, x: f64, y: f64| (p.delta - p.normal[0] * x - p.normal[1] * y) / p.normal[2];
        assert!(z_at(&p, 0.0, 1.0) < 10.0 && z_at(&p, 0.0, -1.0) > 10.0);
        assert!((p.axial_distance() - 10.0).abs() < 1e-12);
        let rolled = FocalPlane::from_tilt_roll(10.0, 20.0, 90.0);
        assert!(z_at(&rolled, 1.0, 0.0) < 10.0 && (z_at(&rolled, 0.0, 1.0) - 10.0).abs() < 1e-12);
    }

    #[test]
    fn three_points_reproduce_a_tilted_plane() {
        let plane = FocalPlane::from_tilt_roll(7.0, 30.0, -40.0);
        // Three points on it: the axis point and two more.
        let n = plane.normal;
        let on = |x: f64, y: f64| {
            let z = (plane.delta - n[0] * x - n[1] * y) / n[2];
            Vec3::new(x as f32, y as f32, z as f32)
        };
        for pts in [
            [on(0.0, 0.0), on(2.0, 0.5), on(-1.0, 3.0)],
            [on(-1.0, 3.0), on(2.0, 0.5), on(0.0, 0.0)],
        ] {
            let got = FocalPlane::from_points(pts).unwrap();
            for (g, e) in got.normal.iter().zip(n) {
                assert!((g - e).abs() < 1e-6, "{got:?} vs {plane:?}");
            }
            assert!((got.axial_distance() - 7.0).abs() < 1e-5);
        }
    }

    #[test]
    fn bad_points_are_refused_with_the_parameters_named() {
        let v = |x, y, z| Vec3::new(x, y, z);
        let collinear =
            FocalPlane::from_points([v(0.0, 0.0, 1.0), v(1.0, 1.0, 2.0), v(2.0, 2.0, 3.0)]).unwrap_err();
        assert!(
            collinear.contains("collinear") && collinear.contains("focus1 (0, 0, 1)"),
            "{collinear}"
        );
        assert!(collinear.contains("focus3 (2, 2, 3)"), "{collinear}");
        let same =
            FocalPlane::from_points([v(0.0, 0.0, 1.0), v(0.0, 0.0, 1.0), v(2.0, 2.0, 3.0)]).unwrap_err();
        assert!(same.contains("collinear or coincide"), "{same}");
        let through =
            FocalPlane::from_points([v(1.0, 0.0, 1.0), v(-1.0, 0.0, -1.0), v(0.0, 1.0, 0.0)]).unwrap_err();
        assert!(through.contains("passes through the camera"), "{through}");
        // The plane x = 1 contains the view direction: never met by the axis.
        let parallel =
            FocalPlane::from_points([v(1.0, 0.0, 1.0), v(1.0, 1.0, 5.0), v(1.0, -1.0, 3.0)]).unwrap_err();
        assert!(
            parallel.contains("tilted 90.00°") && parallel.contains("focus2"),
            "{parallel}"
        );
    }
}
