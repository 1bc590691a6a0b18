//! `LensSystem`: camera rays traced from the film through every interface of a real lens
//! prescription (spheres, planes, even aspheres), with dispersion, to the scene.
//!
//! Mapping, for screen sample `s = (sx, sy)`, aperture sample `a ∈ [−1, 1]²` and wavelength sample `u`:
//!
//! 1. film point (mm): `f = −s·k`, `k = filmDiagonal / diag(screen window)` mm per screen unit (the
//!    minus sign: a lens forms an inverted image, read out upright);
//! 2. film-side slope: in the frame turned so that `f` lies on +x (radius `r = |f|`), the aiming table
//!    ([`pupil`]) maps the stop point `a·R_stop` to a slope `t` with Jacobian `|∂t/∂a|`; the ray leaves
//!    `(f, 0)` along `normalize(t, 1)`. At `a = (0, 0)` the slope is solved exactly (Newton): the
//!    **chief ray** through the stop's centre at the d line, so `obscura rays` and ST-maps show the
//!    lens's real distortion;
//! 3. wavelength: `λ = 400 + 300·u` nm, `u` a hash of the sample's bits ([`spectrum`]); each medium's
//!    index is its glass at λ (`dispersion 0`, or a lens without dispersive glass: the d line);
//! 4. the ray is traced through every surface from the rear to the front ([`surface`]): exact
//!    intersection, the clear aperture of each (the stop's is `R_stop`), Snell's law, total internal
//!    reflection blocks;
//! 5. camera ray: origin = the exit point on the front surface, `/(1000·metersPerUnit)` (mm → scene
//!    units), direction = the exit direction (camera +Z = toward the scene);
//! 6. tint: `(1 + |t|²)⁻²·|∂t/∂a| / N₀ · w(λ)` with `N₀` that weight's mean over the unit disk at the
//!    film centre (so the centre of the image has mean tint 1 for a circular aperture) and `w(λ)` the
//!    wavelength's RGB weight (mean white). A sample the glass blocks keeps a valid ray (the chief ray
//!    of its film point) with **tint 0**: it darkens the pixel, as a real lens's vignetting does,
//!    while alpha and depth still see the scene;
//! 7. footprint: `origin_radius = 0`, `ray_spread = ½·√(α_r·α_t)·pixel_mm` from the chief ray's angle
//!    `θ(r)`: `α_r = |dθ/dr|`, `α_t = sin θ / r`;
//! 8. clipping: by the deep metric from the ray's origin.
//!
//! Focus: `focusDistance` (scene units from the film plane; 0 = infinity) moves the whole lens so the
//! paraxial d-line image of that plane lies on the film ([`system::Lens::focus_back`], a quadratic in
//! the back distance), so the field of view breathes with focus as a real lens's does.
//!
//! Inverse: `unproject` finds the film radius whose chief ray passes through the point (in the
//! meridional plane of the point's azimuth: bracketing on the chief-ray table, then bisection on the
//! exact chief ray to 10⁻⁹ mm).
//!
//! Properties: FocalLength = EFL (scene units); FStop = the paraxial working f-number at the focus
//! distance; FocalDistance = `focusDistance` (none at infinity); FieldOfView = twice the chief ray's
//! angle at the screen's `x = 1` (the [−1, 1] square's edge); DicingHint Spherical (a real lens has no
//! single centre of projection: the entrance pupil moves with the field angle, so the chief rays do
//! not share an origin); DeepMetric CameraZ while every chief ray of the window stays within 60° of
//! the axis, else RayLength (fisheyes).

pub mod batch;
pub mod glass;
pub mod prescription;
pub mod pupil;
pub mod spectrum;
pub mod surface;
pub mod system;
#[cfg(test)]
mod tests;

use std::sync::LazyLock;

use obscura_sdk::contract::clipping_distances;
use obscura_sdk::{
    DeepMetric, DicingHint, ParamDecl, Point2, Projection, ProjectionContext, ProjectionEnvironment,
    ProjectionProperty, PropertyValue, RayGeometry, Rgb, ValueRange, Vec3,
};

use glass::LAMBDA_D;
use prescription::Prescription;
use pupil::{PupilTable, aim, film_ray};
use surface::Ray;
use system::{Lens, Paraxial};

/// The name scenes use.
pub const NAME: &str = "LensSystem";

/// Film radii in the aiming table.
const RADII: usize = 64;
/// Wavelength samples of each medium's index table (1 nm steps over 400–700 nm).
const INDEX_STEPS: usize = 300;

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    vec![
        ParamDecl::string("lens", "dgauss.50mm").doc(
            "the prescription: a file (.json: Obscura's format with glass and aspheres; else the \
             four-column radius/thickness/index/aperture format) or a shipped lens by name: dgauss.50mm, \
             dgauss.50mm.dat, fisheye.10mm, fisheye.10mm.dat, fisheye.16mm, telephoto.250mm.dat, wide.100mm.dat, \
             asphere.50mm, masterprime.100mm",
        ),
        ParamDecl::float("focusDistance", 0.0)
            .range(ValueRange::at_least(0.0))
            .doc("distance of the plane in focus from the film plane, scene units; 0 = infinity"),
        ParamDecl::float("filmDiagonal", 35.0)
            .range(ValueRange::greater_than(0.0))
            .doc("film diagonal in mm, spanning the screen window's diagonal"),
        ParamDecl::float("fStop", 0.0)
            .range(ValueRange::at_least(0.0))
            .doc("f-number the stop closes to (object at infinity); 0 = wide open, as designed"),
        ParamDecl::int("dispersion", 1)
            .range(ValueRange::closed(0.0, 1.0))
            .doc("1: each ray takes a wavelength and the glasses' indices follow it; 0: the d line only"),
        ParamDecl::float("metersPerUnit", 1.0)
            .range(ValueRange::greater_than(0.0))
            .doc("metres per scene unit (USD's metersPerUnit); the prescription is in mm"),
    ]
});

/// Creates [`LensSystem`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct LensSystemFactory;

projection_factory!(
    LensSystemFactory,
    "real lens: rays traced from the film through a prescription's spheres, planes and aspheres, \
     with dispersion, vignetting and the lens's own distortion",
    |env, p| {
        let invalid = |message: String| crate::invalid(NAME, message);
        let lens_name = p.string("lens")?.to_string();
        let prescription =
            Prescription::load(&lens_name).map_err(|e| invalid(format!("parameter \"lens\": {e}")))?;
        let settings = Settings {
            focus_distance: f64::from(p.float("focusDistance")?),
            film_diagonal: f64::from(p.float("filmDiagonal")?),
            f_stop: f64::from(p.float("fStop")?),
            dispersion: p.int("dispersion")? == 1,
            meters_per_unit: f64::from(p.float("metersPerUnit")?),
        };
        let camera = LensSystem::new(&prescription, settings, env).map_err(invalid)?;
        env.set_deep_metric(camera.metric);
        Ok(Box::new(camera))
    }
);

/// What a [`LensSystem`] is made from besides its prescription.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Plane in focus, scene units from the film (0 or ∞: infinity).
    pub focus_distance: f64,
    /// Film diagonal, mm.
    pub film_diagonal: f64,
    /// Stop-down f-number (0: as designed).
    pub f_stop: f64,
    /// Trace each ray at its own wavelength.
    pub dispersion: bool,
    /// Metres per scene unit.
    pub meters_per_unit: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            focus_distance: 0.0,
            film_diagonal: 35.0,
            f_stop: 0.0,
            dispersion: true,
            meters_per_unit: 1.0,
        }
    }
}

/// The chief ray of one table radius (film point on +x), lens frame.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Chief {
    ray: Option<Ray>,
    /// Angle to the axis, radians.
    theta: f64,
    /// `½·√(α_r·α_t)`, radians per mm of film.
    spread_per_mm: f64,
}

/// A real lens camera (see the module documentation).
#[derive(Debug, Clone)]
pub struct LensSystem {
    lens: Lens,
    table: PupilTable,
    chief: Vec<Chief>,
    paraxial: Paraxial,
    /// mm of film per screen unit.
    k: f64,
    /// Scene units per mm.
    unit: f64,
    stop_radius: f64,
    norm: f64,
    dispersive: bool,
    /// Per 1 nm wavelength step, the indices before and after each surface.
    index_table: Vec<(Vec<f64>, Vec<f64>)>,
    /// The eight-lane tracer, when every surface is a sphere or plane.
    lane_lens: Option<batch::LaneLens>,
    /// `η` per surface (rear to front) at the d line and per 1 nm step, for the lanes.
    eta_d: Vec<f32>,
    eta_table: Vec<Vec<f32>>,
    focus_mm: f64,
    metric: DeepMetric,
    near: f32,
    far: f32,
    pixel_mm: f64,
    working_f_number: f64,
    field_of_view: f64,
}

impl LensSystem {
    /// Places, focuses and tabulates `prescription` for `env`.
    ///
    /// # Errors
    /// A message naming the parameter when the lens cannot focus there, cannot stop down to `f_stop`
    /// or passes no light.
    pub fn new(
        prescription: &Prescription,
        s: Settings,
        env: &ProjectionEnvironment,
    ) -> Result<LensSystem, String> {
        let mm_per_unit = 1000.0 * s.meters_per_unit;
        let mut lens = Lens::new(prescription, 0.0);
        let design_stop = prescription.surfaces[prescription.stop].semi_aperture;
        let design = lens.paraxial(LAMBDA_D, 2.0 * design_stop);
        if !(design.efl.is_finite() && design.efl > 0.0) {
            return Err(format!(
                "{}: the lens has no positive focal length (EFL {:.3} mm): it cannot form an image on film",
                prescription.name, design.efl
            ));
        }
        let stop_radius = if s.f_stop > 0.0 {
            if s.f_stop < design.f_number * (1.0 - 1e-6) {
                return Err(format!(
                    "parameter \"fStop\" = {}: this lens opens only to f/{:.3}",
                    s.f_stop, design.f_number
                ));
            }
            design_stop * design.f_number / s.f_stop
        } else {
            design_stop
        };
        lens.surfaces[lens.stop].semi_aperture = stop_radius * (1.0 + 1e-3);
        let focus_mm = if s.focus_distance > 0.0 && s.focus_distance.is_finite() {
            s.focus_distance * mm_per_unit
        } else {
            f64::INFINITY
        };
        lens.focus(focus_mm)
            .map_err(|e| format!("parameter \"focusDistance\" = {}: {e}", s.focus_distance))?;
        let paraxial = lens.paraxial(LAMBDA_D, 2.0 * stop_radius);
        let w = env.screen_window();
        let (sw, sh) = (f64::from(w.right - w.left), f64::from(w.top - w.bottom));
        let k = s.film_diagonal / sw.hypot(sh);
        // Screen samples reach a little past the window (pixel filters): cover 10 % more.
        let half_diag = 0.5 * s.film_diagonal;
        let table = PupilTable::build(&lens, stop_radius, 1.1 * half_diag, RADII);
        let chief = chief_table(&lens, &table);
        let mut camera = LensSystem {
            lens,
            table,
            chief,
            paraxial,
            k,
            unit: 1.0 / mm_per_unit,
            stop_radius,
            norm: 1.0,
            dispersive: s.dispersion && prescription.is_dispersive(),
            index_table: Vec::new(),
            lane_lens: None,
            eta_d: Vec::new(),
            eta_table: Vec::new(),
            focus_mm,
            metric: DeepMetric::CameraZ,
            near: env.clipping_near(),
            far: env.clipping_far(),
            pixel_mm: {
                let (dx, dy) = env.pixel_size();
                (f64::from(dx) * f64::from(dy)).sqrt() * k
            },
            working_f_number: 0.0,
            field_of_view: 0.0,
        };
        camera.index_table = (0..=INDEX_STEPS)
            .map(|i| {
                camera
                    .lens
                    .indices(spectrum::wavelength(i as f64 / INDEX_STEPS as f64))
            })
            .collect();
        camera.lane_lens = batch::LaneLens::new(&camera.lens);
        camera.eta_d = batch::LaneLens::etas(&camera.lens.n_before, &camera.lens.n_after);
        camera.eta_table = camera
            .index_table
            .iter()
            .map(|(b, a)| batch::LaneLens::etas(b, a))
            .collect();
        camera.norm = camera.centre_weight();
        if camera.norm.is_nan() || camera.norm <= 0.0 {
            return Err(format!(
                "{}: no light reaches the film centre through this lens",
                prescription.name
            ));
        }
        let max_theta = camera
            .chief
            .iter()
            .take_while(|c| c.ray.is_some())
            .enumerate()
            .filter(|(j, _)| *j as f64 * camera.table.dr <= half_diag * 1.05)
            .map(|(_, c)| c.theta)
            .fold(0.0, f64::max);
        if max_theta > 60f64.to_radians() {
            camera.metric = DeepMetric::RayLength;
        }
        camera.working_f_number = camera.lens.working_f_number(2.0 * stop_radius, focus_mm);
        camera.field_of_view = 2.0 * camera.chief_theta(k).unwrap_or(max_theta).to_degrees();
        Ok(camera)
    }

    /// The paraxial figures (d line) of the lens as focused.
    #[must_use]
    pub fn paraxial(&self) -> &Paraxial {
        &self.paraxial
    }

    /// The placed lens.
    #[must_use]
    pub fn lens(&self) -> &Lens {
        &self.lens
    }

    /// The stop radius in use, mm.
    #[must_use]
    pub fn stop_radius(&self) -> f64 {
        self.stop_radius
    }

    /// mm of film per screen unit.
    #[must_use]
    pub fn mm_per_screen_unit(&self) -> f64 {
        self.k
    }

    /// The mean of the unnormalised weight over the unit disk at the film centre (128² midpoints).
    fn centre_weight(&self) -> f64 {
        let n = 128;
        disk_grid(n)
            .filter_map(|a| self.trace_sample(0.0, a, None))
            .map(|(_, w)| w)
            .sum::<f64>()
            / disk_grid(n).count() as f64
    }

    /// Traces the sample at film radius `r` (film point on +x) through aperture point `a` (same frame):
    /// the ray leaving the lens and its unnormalised weight `(1 + |t|²)⁻²·|∂t/∂a|`, or `None` when the
    /// glass blocks it. `lambda_step` picks the media's indices (`None`: the d line).
    #[inline]
    fn trace_sample(&self, r: f64, a: [f64; 2], lambda_step: Option<f64>) -> Option<(Ray, f64)> {
        let aimed = self.table.lookup(r, a)?;
        let mut t = aimed.t;
        if a == [0.0, 0.0] {
            t = aim(&self.lens, r, [0.0, 0.0], t)?;
        }
        let ray = film_ray(r, t);
        let n = self.lens.surfaces.len();
        let out = match lambda_step {
            None => self.lens.trace(ray),
            // The nearest 1 nm step's indices (within ~10⁻⁵ of the exact wavelength's).
            Some(x) => {
                let (before, after) = &self.index_table[(x.round() as usize).min(INDEX_STEPS)];
                self.lens.trace_range(ray, 0, n - 1, (before, after), true)
            }
        }
        .ok()?;
        let t2 = t[0] * t[0] + t[1] * t[1];
        Some((out, aimed.jacobian / ((1.0 + t2) * (1.0 + t2))))
    }

    /// The film-side ray (lens frame) from film point `(r, 0)` toward stop point `a·R_stop`, from the
    /// aiming table, before any surface: for diagrams of ray fans.
    #[must_use]
    pub fn film_side_ray(&self, r: f64, a: [f64; 2]) -> Option<Ray> {
        let t = self.table.lookup(r, a)?.t;
        Some(film_ray(r, t))
    }

    /// The exact chief ray (d line) from film point `(r, 0)`, lens frame, or `None` when blocked.
    #[must_use]
    pub fn chief_ray(&self, r: f64) -> Option<Ray> {
        self.trace_sample(r, [0.0, 0.0], None).map(|(ray, _)| ray)
    }

    /// The chief ray's angle to the axis at film radius `r`, from the table.
    fn chief_theta(&self, r: f64) -> Option<f64> {
        let x = r / self.table.dr;
        let j = (x as usize).min(self.table.radii - 2);
        let (a, b) = (&self.chief[j], &self.chief[j + 1]);
        (a.ray.is_some() && b.ray.is_some()).then_some(a.theta + (b.theta - a.theta) * (x - j as f64))
    }

    /// The camera ray of a lens-frame ray leaving the front element.
    #[inline]
    fn camera_ray(&self, out: &Ray, spread: f32) -> Option<RayGeometry> {
        let origin = Vec3::new(
            (out.o[0] * self.unit) as f32,
            (out.o[1] * self.unit) as f32,
            (out.o[2] * self.unit) as f32,
        );
        let direction = Vec3::new(out.d[0] as f32, out.d[1] as f32, out.d[2] as f32).normalize_or_zero();
        let (min_dist, max_dist) = clipping_distances(origin, direction, self.metric, self.near, self.far)?;
        Some(RayGeometry {
            origin,
            origin_radius: 0.0,
            direction,
            ray_spread: spread,
            min_dist,
            max_dist,
        })
    }

    /// The ray and tint of one sample.
    #[inline]
    fn sample(&self, s: Point2, a: Point2, lens: Point2) -> (RayGeometry, Rgb) {
        let frame = self.film_frame(s);
        let (r, local) = (frame.r, frame.local(a));
        // The lens-centre sample is the chief ray at the d line (the ray maps' main layer).
        let (lambda_step, rgb) = if self.dispersive && local != [0.0, 0.0] {
            let u = spectrum::hash_unit(s.x, s.y, lens.x, lens.y);
            (Some(u * INDEX_STEPS as f64), spectrum::weight(u))
        } else {
            (None, [1.0; 3])
        };
        let spread = self.spread(r);
        if let Some((out, w)) = self.trace_sample(r, local, lambda_step)
            && let Some(ray) = self.camera_ray(&frame.turn_back(out), spread)
        {
            let w = (w / self.norm) as f32;
            return (ray, Rgb::new(w * rgb[0], w * rgb[1], w * rgb[2]));
        }
        // Blocked: the chief ray of this film point, carrying nothing.
        match self
            .chief_interpolated(r)
            .and_then(|ch| self.camera_ray(&frame.turn_back(ch), spread))
        {
            Some(ray) => (ray, Rgb::new(0.0, 0.0, 0.0)),
            None => (RayGeometry::CULLED, Rgb::new(0.0, 0.0, 0.0)),
        }
    }

    fn spread(&self, r: f64) -> f32 {
        let x = (r / self.table.dr).min((self.table.radii - 1) as f64);
        let j = (x as usize).min(self.table.radii - 2);
        let (a, b) = (self.chief[j].spread_per_mm, self.chief[j + 1].spread_per_mm);
        ((a + (b - a) * (x - j as f64)) * self.pixel_mm) as f32
    }

    /// The chief ray at radius `r` interpolated between table radii (for blocked samples).
    fn chief_interpolated(&self, r: f64) -> Option<Ray> {
        let x = r / self.table.dr;
        if x > (self.table.radii - 1) as f64 {
            return None;
        }
        let j = (x as usize).min(self.table.radii - 2);
        let w = x - j as f64;
        let (a, b) = (self.chief[j].ray?, self.chief[j + 1].ray?);
        let mix = |p: [f64; 3], q: [f64; 3]| {
            [
                p[0] + (q[0] - p[0]) * w,
                p[1] + (q[1] - p[1]) * w,
                p[2] + (q[2] - p[2]) * w,
            ]
        };
        let d = mix(a.d, b.d);
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        Some(Ray {
            o: mix(a.o, b.o),
            d: [d[0] / l, d[1] / l, d[2] / l],
        })
    }

    /// The mean tint (d line, luminance-free) at film radius `r` mm over an `n × n` grid of the unit
    /// disk: the relative illumination the renderer's image shows there.
    #[must_use]
    pub fn relative_illumination(&self, r: f64, n: usize) -> f64 {
        disk_grid(n)
            .filter_map(|a| self.trace_sample(r, a, None))
            .map(|(_, w)| w)
            .sum::<f64>()
            / disk_grid(n).count() as f64
            / self.norm
    }

    /// The fraction of aperture samples (unit disk, `n × n` grid) the glass blocks at film radius `r`.
    #[must_use]
    pub fn blocked_fraction(&self, r: f64, n: usize) -> f64 {
        let blocked = disk_grid(n)
            .filter(|&a| self.trace_sample(r, a, None).is_none())
            .count();
        blocked as f64 / disk_grid(n).count() as f64
    }
}

/// A film point in the lens frame turned about the axis so that it lies on +x: every table (aiming,
/// chief rays) is meridional, so a sample is looked up there and its ray turned back.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FilmFrame {
    /// Film radius, mm.
    r: f64,
    /// Cosine and sine of the film point's azimuth.
    c: f64,
    sn: f64,
}

impl FilmFrame {
    /// The film centre, whose azimuth is taken as +x.
    const CENTRE: FilmFrame = FilmFrame {
        r: 0.0,
        c: 1.0,
        sn: 0.0,
    };

    /// Aperture sample `a` in this frame.
    #[inline]
    fn local(&self, a: Point2) -> [f64; 2] {
        let a = [f64::from(a.x), f64::from(a.y)];
        [self.c * a[0] + self.sn * a[1], -self.sn * a[0] + self.c * a[1]]
    }

    /// A ray of this frame turned back into the lens's own frame.
    #[inline]
    fn turn_back(&self, ray: Ray) -> Ray {
        let (c, sn) = (self.c, self.sn);
        let turn = |v: [f64; 3]| [c * v[0] - sn * v[1], sn * v[0] + c * v[1], v[2]];
        Ray {
            o: turn(ray.o),
            d: turn(ray.d),
        }
    }
}

/// The midpoints of an `n × n` grid over `[−1, 1]²` that lie in the unit disk: aperture samples for
/// the deterministic integrals (normalisation, relative illumination).
fn disk_grid(n: usize) -> impl Iterator<Item = [f64; 2]> {
    let at = move |i: usize| -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
    (0..n * n)
        .map(move |k| [at(k / n), at(k % n)])
        .filter(|a| a[0] * a[0] + a[1] * a[1] <= 1.0)
}

fn chief_table(lens: &Lens, table: &PupilTable) -> Vec<Chief> {
    let mut out: Vec<Chief> = (0..table.radii)
        .map(|j| {
            let r = j as f64 * table.dr;
            let ray = table
                .lookup(r, [0.0, 0.0])
                .and_then(|a| aim(lens, r, [0.0, 0.0], a.t))
                .and_then(|t| lens.trace(film_ray(r, t)).ok());
            let theta = ray.map_or(0.0, |r| r.d[0].hypot(r.d[1]).atan2(r.d[2]));
            Chief {
                ray,
                theta,
                spread_per_mm: 0.0,
            }
        })
        .collect();
    for j in 0..out.len() {
        let (lo, hi) = (j.saturating_sub(1), (j + 1).min(out.len() - 1));
        let usable = |i: usize| out[i].ray.is_some();
        let (lo, hi) = match (usable(lo), usable(hi)) {
            (true, true) => (lo, hi),
            (true, false) => (lo, j),
            (false, true) => (j, hi),
            _ => (j, j),
        };
        let dtheta = if hi > lo {
            ((out[hi].theta - out[lo].theta) / ((hi - lo) as f64 * table.dr)).abs()
        } else {
            0.0
        };
        let r = j as f64 * table.dr;
        let tangential = if r > 0.0 { out[j].theta.sin() / r } else { dtheta };
        out[j].spread_per_mm = 0.5 * (dtheta * tangential).sqrt();
    }
    out
}

impl Projection for LensSystem {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        Some(match property {
            ProjectionProperty::DicingHint => PropertyValue::DicingHint(DicingHint::Spherical),
            ProjectionProperty::DeepMetric => PropertyValue::DeepMetric(self.metric),
            ProjectionProperty::FieldOfView => PropertyValue::Float(self.field_of_view as f32),
            ProjectionProperty::FStop => PropertyValue::Float(self.working_f_number as f32),
            ProjectionProperty::FocalLength => PropertyValue::Float((self.paraxial.efl * self.unit) as f32),
            ProjectionProperty::FocalDistance => {
                if self.focus_mm.is_finite() {
                    PropertyValue::Float((self.focus_mm * self.unit) as f32)
                } else {
                    return None;
                }
            }
        })
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        match &self.lane_lens {
            Some(lanes) => {
                crate::simd::run(|| self.project_lanes(lanes, c.screen, c.aperture, c.lens, c.rays, c.tint))
            }
            None => {
                for i in 0..c.rays.len() {
                    let (ray, tint) = self.sample(c.screen[i], c.aperture[i], c.lens[i]);
                    c.rays[i] = ray;
                    c.tint[i] = tint;
                }
            }
        }
    }

    fn unproject(&self, point: Vec3, _time: f32) -> Option<Point2> {
        if !point.is_finite() {
            return None;
        }
        let mm = 1.0 / self.unit;
        let p = [
            f64::from(point.x) * mm,
            f64::from(point.y) * mm,
            f64::from(point.z) * mm,
        ];
        let rho = p[0].hypot(p[1]);
        // In the frame with the film point on +x the scene point lies on −x (the image is inverted).
        let target = [-rho, p[2]];
        let residual = |ray: &Ray| {
            let (dx, dz) = (ray.d[0], ray.d[2]);
            let (vx, vz) = (target[0] - ray.o[0], target[1] - ray.o[2]);
            (dx * vz - dz * vx, dx * vx + dz * vz)
        };
        // Bracket on the table's exact chief rays, then bisect on the exact chief ray.
        let bisect = |mut a: f64, mut b: f64, mut ga: f64| -> Option<Point2> {
            for _ in 0..80 {
                let m = 0.5 * (a + b);
                let (gm, _) = residual(&self.chief_ray(m)?);
                if (gm > 0.0) == (ga > 0.0) {
                    a = m;
                    ga = gm;
                } else {
                    b = m;
                }
                if b - a < 1e-10 {
                    break;
                }
            }
            self.film_to_screen(0.5 * (a + b), p)
        };
        let mut lo: Option<(f64, f64)> = None;
        for j in 0..self.table.radii {
            let r = j as f64 * self.table.dr;
            let Some(ray) = self.chief[j].ray else {
                // Past the last table radius with a chief ray: the field ends between the two. Find
                // its edge by bisection on whether the chief ray passes, and bracket up to there.
                let (r0, g0) = lo?;
                let (mut a, mut b) = (r0, r);
                for _ in 0..50 {
                    let m = 0.5 * (a + b);
                    if self.chief_ray(m).is_some() { a = m } else { b = m }
                }
                let (ga, along) = residual(&self.chief_ray(a)?);
                return ((ga > 0.0) != (g0 > 0.0) && along > 0.0)
                    .then(|| bisect(r0, a, g0))
                    .flatten();
            };
            let (g, along) = residual(&ray);
            if along <= 0.0 {
                continue;
            }
            if g == 0.0 {
                return self.film_to_screen(r, p);
            }
            match lo {
                Some((r0, g0)) if (g0 > 0.0) != (g > 0.0) => return bisect(r0, r, g0),
                _ => lo = Some((r, g)),
            }
        }
        None
    }
}

impl LensSystem {
    /// `project` eight rays at a time through [`batch::trace`]: per ray, the film point, the aiming
    /// table and the wavelength as in [`LensSystem::sample`]; the lens-centre samples (the exact chief
    /// ray) go through `sample` itself.
    #[inline(always)]
    fn project_lanes(
        &self,
        lane_lens: &batch::LaneLens,
        screen: &[Point2],
        aperture: &[Point2],
        lens: &[Point2],
        rays: &mut [RayGeometry],
        tint: &mut [Rgb],
    ) {
        use batch::LANES;
        let n = rays.len();
        let mut start = 0;
        while start < n {
            let mut lanes = batch::Lanes::default();
            let mut eta: [&[f32]; LANES] = [&self.eta_d; LANES];
            let mut setup = [(FilmFrame::CENTRE, 0.0f64, [1.0f32; 3]); LANES];
            let mut todo = [false; LANES];
            for l in 0..LANES {
                let i = start + l;
                if i >= n {
                    continue;
                }
                let s = screen[i];
                let frame = self.film_frame(s);
                let (r, local) = (frame.r, frame.local(aperture[i]));
                if local == [0.0, 0.0] {
                    (rays[i], tint[i]) = self.sample(s, aperture[i], lens[i]);
                    continue;
                }
                let rgb = if self.dispersive {
                    let u = spectrum::hash_unit(s.x, s.y, lens[i].x, lens[i].y);
                    eta[l] = &self.eta_table[((u * INDEX_STEPS as f64).round() as usize).min(INDEX_STEPS)];
                    spectrum::weight(u)
                } else {
                    [1.0; 3]
                };
                todo[l] = true;
                let Some(aimed) = self.table.lookup(r, local) else {
                    setup[l] = (frame, 0.0, rgb);
                    continue;
                };
                let t = aimed.t;
                let t2 = t[0] * t[0] + t[1] * t[1];
                let ray = film_ray(r, t);
                lanes.ox[l] = r as f32;
                lanes.dx[l] = ray.d[0] as f32;
                lanes.dy[l] = ray.d[1] as f32;
                lanes.dz[l] = ray.d[2] as f32;
                lanes.alive[l] = 1.0;
                setup[l] = (frame, aimed.jacobian / ((1.0 + t2) * (1.0 + t2)) / self.norm, rgb);
            }
            batch::trace(lane_lens, &mut lanes, &eta);
            for l in 0..LANES {
                if !todo[l] {
                    continue;
                }
                let i = start + l;
                let (frame, w, rgb) = setup[l];
                let spread = self.spread(frame.r);
                let out = frame.turn_back(Ray {
                    o: [
                        f64::from(lanes.ox[l]),
                        f64::from(lanes.oy[l]),
                        f64::from(lanes.oz[l]),
                    ],
                    d: [
                        f64::from(lanes.dx[l]),
                        f64::from(lanes.dy[l]),
                        f64::from(lanes.dz[l]),
                    ],
                });
                if lanes.alive[l] != 0.0
                    && let Some(ray) = self.camera_ray(&out, spread)
                {
                    let w = w as f32;
                    rays[i] = ray;
                    tint[i] = Rgb::new(w * rgb[0], w * rgb[1], w * rgb[2]);
                    continue;
                }
                rays[i] = match self
                    .chief_interpolated(frame.r)
                    .and_then(|ch| self.camera_ray(&frame.turn_back(ch), spread))
                {
                    Some(ray) => ray,
                    None => RayGeometry::CULLED,
                };
                tint[i] = Rgb::new(0.0, 0.0, 0.0);
            }
            start += LANES;
        }
    }

    /// The film point of screen sample `s` as its radius and the frame turned so that it lies on +x.
    #[inline]
    fn film_frame(&self, s: Point2) -> FilmFrame {
        let f = [-f64::from(s.x) * self.k, -f64::from(s.y) * self.k];
        let r = f[0].hypot(f[1]);
        let (c, sn) = if r > 0.0 { (f[0] / r, f[1] / r) } else { (1.0, 0.0) };
        FilmFrame { r, c, sn }
    }

    fn film_to_screen(&self, r: f64, p: [f64; 3]) -> Option<Point2> {
        let rho = p[0].hypot(p[1]);
        let (c, s) = if rho > 0.0 {
            (p[0] / rho, p[1] / rho)
        } else {
            (1.0, 0.0)
        };
        // Film point −r·(c, s)... the scene point's azimuth plus π; screen = −film/k.
        Some(Point2::new((r * c / self.k) as f32, (r * s / self.k) as f32))
    }
}
