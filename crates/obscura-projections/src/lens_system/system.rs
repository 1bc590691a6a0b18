//! A prescription placed in front of the film: vertex positions, the stop, real-ray tracing at any
//! wavelength, and the paraxial (ray-transfer-matrix) solution: focal lengths, pupils, focus.
//!
//! Lens frame, mm: the film is the plane `z = 0`, the axis is `z`, increasing toward the scene. The
//! rear vertex sits at `z = b` (the back distance that [`Lens::focus`] solves for) and each vertex in
//! front of it at `z_i = z_(i+1) + t_i`.
//!
//! Paraxial optics uses reduced ray-transfer matrices on `(y, n·u)`, light travelling from the scene
//! to the film: refraction at surface `i` is `[[1, 0], [−φᵢ, 1]]` with `φᵢ = (n′ − n)·cᵢ`, a gap of
//! thickness `t` in index `n` is `[[1, t/n], [0, 1]]`. For the front-vertex-to-rear-vertex matrix
//! `[[A, B], [C, D]]`: `EFL = −1/C`, `BFL = −A/C` (rear vertex to the rear focal point),
//! `FFL = −D/C` (front vertex to the front focal point, positive toward the scene).
//! Entrance pupil: with `[[A, B], [C, D]]` from the front vertex to the stop, the stop's conjugate lies
//! `−B/A` in front of the front vertex and is `1/|A|` times the stop. Exit pupil: with the matrix from
//! the stop to the rear vertex, `−B/D` behind the rear vertex, `1/|D|` times the stop.

use super::glass::{Glass, LAMBDA_D};
use super::prescription::Prescription;
use super::surface::{Ray, Surface, intersect, refract};

/// 2×2 matrix `[[a, b], [c, d]]`.
pub type Mat2 = [[f64; 2]; 2];

fn mul(x: Mat2, y: Mat2) -> Mat2 {
    [
        [
            x[0][0] * y[0][0] + x[0][1] * y[1][0],
            x[0][0] * y[0][1] + x[0][1] * y[1][1],
        ],
        [
            x[1][0] * y[0][0] + x[1][1] * y[1][0],
            x[1][0] * y[0][1] + x[1][1] * y[1][1],
        ],
    ]
}

const IDENTITY: Mat2 = [[1.0, 0.0], [0.0, 1.0]];

/// Why a traced ray does not reach the scene (or the stop).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Blocked {
    /// It misses surface `i` or falls outside its clear aperture (the stop included).
    Aperture(usize),
    /// Total internal reflection at surface `i`.
    Reflected(usize),
}

/// The paraxial figures of a lens at one wavelength, mm (positions along the axis from the rear
/// vertex, positive toward the film).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Paraxial {
    /// Effective focal length.
    pub efl: f64,
    /// Rear vertex to the rear focal point.
    pub bfl: f64,
    /// Front vertex to the front focal point, positive toward the scene.
    pub ffl: f64,
    /// Entrance pupil position (from the rear vertex, positive toward the film).
    pub entrance_pupil_position: f64,
    /// Entrance pupil diameter.
    pub entrance_pupil_diameter: f64,
    /// Exit pupil position (from the rear vertex, positive toward the film).
    pub exit_pupil_position: f64,
    /// Exit pupil diameter.
    pub exit_pupil_diameter: f64,
    /// `EFL / entrance pupil diameter` (object at infinity).
    pub f_number: f64,
}

/// A prescription with its stop size chosen, ready to place and trace.
#[derive(Debug, Clone, PartialEq)]
pub struct Lens {
    /// The interfaces, front to rear.
    pub surfaces: Vec<Surface>,
    /// Index of the stop.
    pub stop: usize,
    /// Vertex `z` of each surface, mm (film at 0).
    pub z: Vec<f64>,
    /// Index of the medium on the scene side of each surface at the d line (`n_before[0] = 1`).
    pub n_before: Vec<f64>,
    /// Index of the medium on the film side of each surface at the d line.
    pub n_after: Vec<f64>,
}

impl Lens {
    /// The lens of `p` with its rear vertex at `back` mm from the film.
    #[must_use]
    pub fn new(p: &Prescription, back: f64) -> Lens {
        let mut lens = Lens {
            surfaces: p.surfaces.clone(),
            stop: p.stop,
            z: Vec::new(),
            n_before: Vec::new(),
            n_after: Vec::new(),
        };
        (lens.n_before, lens.n_after) = lens.indices(LAMBDA_D);
        lens.place(back);
        lens
    }

    /// Moves the lens so that its rear vertex is `back` mm from the film.
    pub fn place(&mut self, back: f64) {
        let n = self.surfaces.len();
        self.z = vec![0.0; n];
        self.z[n - 1] = back;
        for i in (0..n - 1).rev() {
            self.z[i] = self.z[i + 1] + self.surfaces[i].thickness;
        }
    }

    /// The rear vertex's distance from the film, mm.
    #[must_use]
    pub fn back(&self) -> f64 {
        self.z[self.z.len() - 1]
    }

    /// Front vertex to rear vertex, mm.
    #[must_use]
    pub fn track(&self) -> f64 {
        self.z[0] - self.back()
    }

    /// The media's indices on the scene and film side of each surface at `lambda_nm`.
    #[must_use]
    pub fn indices(&self, lambda_nm: f64) -> (Vec<f64>, Vec<f64>) {
        let after: Vec<f64> = self.surfaces.iter().map(|s| s.glass.index(lambda_nm)).collect();
        let mut before = vec![1.0];
        before.extend_from_slice(&after[..after.len() - 1]);
        (before, after)
    }

    /// The glass behind each surface.
    pub fn glasses(&self) -> impl Iterator<Item = Glass> + '_ {
        self.surfaces.iter().map(|s| s.glass)
    }

    /// Traces `ray` (lens frame, mm, on the film side of surface `last`) toward the scene through
    /// surfaces `last` down to `first` (inclusive, `first ≤ last`), with the media's indices
    /// `before`/`after` (scene and film side of each surface); `clip` checks the clear apertures.
    /// Returns the ray leaving surface `first`.
    ///
    /// # Errors
    /// Where the ray is blocked.
    #[inline]
    pub fn trace_range(
        &self,
        mut ray: Ray,
        first: usize,
        last: usize,
        (before, after): (&[f64], &[f64]),
        clip: bool,
    ) -> Result<Ray, Blocked> {
        for i in (first..=last).rev() {
            let s = &self.surfaces[i];
            let (p, n) = intersect(s, self.z[i], &ray).ok_or(Blocked::Aperture(i))?;
            if clip && p[0] * p[0] + p[1] * p[1] > s.semi_aperture * s.semi_aperture {
                return Err(Blocked::Aperture(i));
            }
            let d = if after[i] == before[i] {
                ray.d
            } else {
                refract(ray.d, n, after[i], before[i]).ok_or(Blocked::Reflected(i))?
            };
            ray = Ray { o: p, d };
        }
        Ok(ray)
    }

    /// The points where `ray` (from the film, d line) meets each surface, rear to front, as far as it
    /// gets, and the ray leaving the front surface when it passes (for lens diagrams).
    #[must_use]
    pub fn trace_path(&self, ray: Ray) -> (Vec<[f64; 3]>, Option<Ray>) {
        let mut points = vec![ray.o];
        let mut r = ray;
        for i in (0..self.surfaces.len()).rev() {
            match self.trace_range(r, i, i, (&self.n_before, &self.n_after), true) {
                Ok(next) => {
                    points.push(next.o);
                    r = next;
                }
                Err(Blocked::Aperture(_)) => return (points, None),
                Err(Blocked::Reflected(_)) => {
                    if let Some((p, _)) = super::surface::intersect(&self.surfaces[i], self.z[i], &r) {
                        points.push(p);
                    }
                    return (points, None);
                }
            }
        }
        (points, Some(r))
    }

    /// Traces a ray from the film through every surface into the scene at the d line.
    ///
    /// # Errors
    /// Where the ray is blocked.
    pub fn trace(&self, ray: Ray) -> Result<Ray, Blocked> {
        let n = self.surfaces.len();
        self.trace_range(ray, 0, n - 1, (&self.n_before, &self.n_after), true)
    }

    /// The paraxial matrix of surfaces `first..=last` (light from the scene), starting at surface
    /// `first`'s vertex and ending just after surface `last` plus `tail` mm of that medium.
    #[must_use]
    pub fn matrix(&self, first: usize, last: usize, lambda_nm: f64, tail: f64) -> Mat2 {
        let (before, after) = self.indices(lambda_nm);
        let mut m = IDENTITY;
        for i in first..=last {
            let phi = (after[i] - before[i]) * self.surfaces[i].curvature();
            m = mul([[1.0, 0.0], [-phi, 1.0]], m);
            let t = if i < last {
                self.surfaces[i].thickness
            } else {
                tail
            };
            m = mul([[1.0, t / after[i]], [0.0, 1.0]], m);
        }
        m
    }

    /// The paraxial figures at `lambda_nm` for a stop of diameter `stop_diameter`.
    #[must_use]
    pub fn paraxial(&self, lambda_nm: f64, stop_diameter: f64) -> Paraxial {
        let n = self.surfaces.len();
        let m = self.matrix(0, n - 1, lambda_nm, 0.0);
        let efl = -1.0 / m[1][0];
        let (bfl, ffl) = (-m[0][0] / m[1][0], -m[1][1] / m[1][0]);
        let track = self.track();
        let (ep_pos, ep_dia) = if self.stop == 0 {
            (-track, stop_diameter)
        } else {
            let f = self.matrix(
                0,
                self.stop - 1,
                lambda_nm,
                self.surfaces[self.stop - 1].thickness,
            );
            let s = -f[0][1] / f[0][0];
            (-(track + s), stop_diameter / f[0][0].abs())
        };
        let (xp_pos, xp_dia) = if self.stop == n - 1 {
            (0.0, stop_diameter)
        } else {
            let r = self.matrix(self.stop, n - 1, lambda_nm, 0.0);
            (-r[0][1] / r[1][1], stop_diameter / r[1][1].abs())
        };
        Paraxial {
            efl,
            bfl,
            ffl,
            entrance_pupil_position: ep_pos,
            entrance_pupil_diameter: ep_dia,
            exit_pupil_position: xp_pos,
            exit_pupil_diameter: xp_dia,
            f_number: efl / ep_dia,
        }
    }

    /// The back distance (rear vertex to film, mm) that puts the paraxial image of the plane
    /// `distance` mm in front of the film on the film at `lambda_nm`; infinity focuses at the BFL.
    ///
    /// With `[[A, B], [C, D]]` from the front vertex to the rear vertex, track `L` and object distance
    /// `s = distance − b − L` from the front vertex, the image condition `A·s + B + b·(C·s + D) = 0`
    /// is the quadratic `C·b² + (A − C·K − D)·b − (A·K + B) = 0`, `K = distance − L`; of its roots the
    /// one with `b > 0` and `s > 0` nearest the BFL.
    ///
    /// # Errors
    /// When no such root exists: the plane is nearer than the lens can focus.
    pub fn focus_back(&self, distance: f64, lambda_nm: f64) -> Result<f64, String> {
        let n = self.surfaces.len();
        let [[a, b], [c, d]] = self.matrix(0, n - 1, lambda_nm, 0.0);
        let bfl = -a / c;
        if !distance.is_finite() {
            return Ok(bfl);
        }
        let track = self.track();
        let k = distance - track;
        let (qa, qb, qc) = (c, a - c * k - d, -(a * k + b));
        let disc = qb * qb - 4.0 * qa * qc;
        let too_near = || {
            format!(
                "cannot focus at {distance:.1} mm from the film: nearer than this lens can focus \
                 (the paraxial image would not reach the film)"
            )
        };
        if disc < 0.0 {
            return Err(too_near());
        }
        let q = -0.5 * (qb + disc.sqrt().copysign(qb));
        let roots = [q / qa, if q != 0.0 { qc / q } else { f64::NAN }];
        roots
            .into_iter()
            .filter(|&r| r.is_finite() && r > 0.0 && distance - r - track > 0.0)
            .min_by(|x, y| (x - bfl).abs().total_cmp(&(y - bfl).abs()))
            .ok_or_else(too_near)
    }

    /// Moves the lens to focus on the plane `distance` mm in front of the film (infinite: infinity).
    ///
    /// # Errors
    /// As [`Lens::focus_back`].
    pub fn focus(&mut self, distance: f64) -> Result<(), String> {
        let b = self.focus_back(distance, LAMBDA_D)?;
        self.place(b);
        Ok(())
    }

    /// The paraxial working f-number for the object plane `distance` mm in front of the film
    /// (infinite: `EFL/EPD`): `1/(2|u′|)` of the marginal ray through the stop's edge.
    #[must_use]
    pub fn working_f_number(&self, stop_diameter: f64, distance: f64) -> f64 {
        let n = self.surfaces.len();
        let m = self.matrix(0, n - 1, LAMBDA_D, 0.0);
        let f = if self.stop == 0 {
            IDENTITY
        } else {
            self.matrix(0, self.stop - 1, LAMBDA_D, self.surfaces[self.stop - 1].thickness)
        };
        let (y0, u0) = if distance.is_finite() {
            // From the axial object point, s in front of the front vertex, slope u0 = 1.
            let s = distance - self.back() - self.track();
            (s, 1.0)
        } else {
            (1.0, 0.0) // height 1 at the front vertex, parallel
        };
        // (y, u) at the front vertex: from the object point the ray has travelled s with slope 1.
        let at_stop = f[0][0] * y0 + f[0][1] * u0;
        let scale = 0.5 * stop_diameter / at_stop.abs();
        let u_image = (m[1][0] * y0 + m[1][1] * u0) * scale;
        1.0 / (2.0 * u_image.abs())
    }
}
