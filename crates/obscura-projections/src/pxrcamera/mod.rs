//! `PxrCamera`: RenderMan's full-featured perspective camera — zoom, thin lens with a tilted
//! (Scheimpflug) plane of focus, lens shift, distortion, chromatic aberration, natural and optical
//! vignetting, rolling shutter and enhance.
//!
//! # Mapping
//!
//! For a screen sample `s = (sx, sy)`, an aperture sample `a ∈ [−1, 1]²` and the host's time `t`, in
//! this order:
//!
//! 1. **enhance** `(ex, ey, ez)`: `sₑ = (ex, ey) + s/ez`, a zoom by `ez` into screen point `(ex, ey)`
//!    of the un-enhanced camera. Everything below sees `sₑ`.
//! 2. **rolling shutter** ([`crate::rolling_shutter`], shared with `PxrRollingShutter`): `t' = σ·(1 − duration) + t·duration`, σ ∈ [0, 1] the position
//!    of `sₑ` along `sweep` over the screen window; `t'` is written back and used below.
//! 3. **zoom**: field of view `φ = fov + (fovEnd − fov)·t'` (`fov` throughout when `fovEnd` is 0),
//!    screen plane at `d = 1/tan(φ/2)`; `fov` spans the screen window's `[−1, 1]` square, i.e. the
//!    smaller image side with the default window, as in `PxrPerspective`.
//! 4. **chromatic channel**: when `transverse` or `axial` differ between channels, the ray takes one
//!    channel `c ∈ {R, G, B}` chosen by a hash of the bits of `s` (not of the lens or time samples,
//!    which already carry depth of field and motion), and `tint ·= 3·e_c`: each channel is chosen a
//!    third of the time, so the expected tint is white and an RGB host integrates real colour fringes.
//!    Otherwise `c = G` and the tint is untouched.
//! 5. **shift and magnification**: the sensor position relative to the optical axis is
//!    `p = (sₑ + (shiftX, shiftY))/transverse[c]` (screen units; a positive shift moves the lens right
//!    or up, so the view moves right or up without converging verticals; `transverse[c] > 1` magnifies
//!    channel `c`'s image).
//! 6. **distortion** (`distortion.rs`): the ideal position `u = F(p) = (x/Dx, y/Dy)`,
//!    `q = (x/squeeze)² + y²`, `Dx = 1 + (radial1 + assymX)·q + radial2·q²`,
//!    `Dy = 1 + (radial1 + assymY)·q + radial2·q²` (a division model: to first order the image radius
//!    is `ρ·(1 + radial1·ρ²)`, Brown–Conrady's term). `radial1 > 0` is pincushion, `< 0` barrel. Samples
//!    beyond the fold (`q ≥ q_max`, where the map stops being monotonic or meets a pole) are culled.
//! 7. **chief ray**: `w = normalize(u.x, u.y, d)`.
//! 8. **vignetting** (`vignetting.rs`): `tint ·= 1 + natural·(w.z⁴ − 1)` (cos⁴θ); with `optical > 0` the
//!    aperture is clipped by a unit disk centred at `b = −optical·(u.x, u.y)/d` (in aperture radii):
//!    `a` is moved into the intersection of the two disks and `tint ·= A(|b|)/π`, the exact area
//!    fraction of the intersection (a cat's-eye bokeh, darker corners, nothing culled).
//! 9. **thin lens** (on when `fStop` is finite and positive, `focalLength > 0` and `dofMult > 0`):
//!    lens radius `R = dofMult·½·focalLength/fStop`, `O = (R·ax, R·ay, 0)`. The plane of focus
//!    (`focal_plane.rs`) is `n·X = δ_c`, `δ_c = δ + axial[c]·n.z` (the plane moved along the axis by
//!    `axial[c]`). The focus point of the sample is where its chief ray meets the plane,
//!    `F = w·δ_c/(n·w)`, and the ray runs through `O` and `F`:
//!    `D = normalize(δ_c·w − (n·w)·O)` — the same line written without dividing by `n·w`, so a chief
//!    ray that meets a tilted plane only behind the camera (a virtual focus) or never (focus at
//!    infinity, `D = w`) still gives a ray, continuous across. Without a lens `O = 0`, `D = w`.
//! 10. **footprint**: `origin_radius = 0`. The per-pixel turn of the chief ray along screen x is
//!     `αx = Δx/(ez·transverse[c])·|w × (J₀₀, J₁₀, 0)|/|v|`, along y
//!     `αy = Δy/(ez·transverse[c])·|w × (J₀₁, J₁₁, 0)|/|v|`, with `v = (u.x, u.y, d)`, `J = ∂u/∂p` the
//!     distortion's Jacobian and `Δx, Δy` the pixel size in screen units (because
//!     `∂w/∂u = (I − w·wᵀ)/|v|` and `|(I − w·wᵀ)·x| = |w × x|`); `ray_spread = ½·sqrt(αx·αy)`. Through
//!     the lens the cone keeps the chief ray's radius at the focus point:
//!     `ray_spread ·= |F|/|F − O| = δ_c/|δ_c·w − (n·w)·O|`.
//! 11. **clipping**: `min_dist = near/D.z`, `max_dist = far/D.z` (`D.z > 0` always).
//!
//! # Inverse
//!
//! `unproject(P, t)` inverts the chief ray of the green channel (magnification `transverse.g`; green is
//! the reference channel, the one without chromatic aberration when only red and blue are set): for
//! `P.z > 0`, `u = (P.x, P.y)·d(t)/P.z`, `p = F⁻¹(u)` by Halley's form of Newton's method on one scalar
//! equation (`distortion.rs`: within 8 steps to 1e-6; `None` beyond what the monotonic region
//! reaches), `sₑ = p·transverse.g − (shiftX, shiftY)`, `s = (sₑ − (ex, ey))·ez`. `t` is the ray's own
//! time (after the rolling-shutter rewrite), at which the zoom is evaluated; whether the sweep
//! exposes that screen position at that time is not checked. With `optical > 0` and the lens on, the
//! lens-centre sample `a = 0` moves to the middle of the cat's eye, so the ray it makes is not the
//! chief ray that `unproject` inverts (they cross at the focus point).
//!
//! # Properties
//!
//! DicingHint Perspective; DeepMetric CameraZ; FieldOfView the angle the un-enhanced image spans
//! across the `[−1, 1]` square: `fov` itself (the narrower of `fov` and `fovEnd` during a zoom) unless
//! distortion, shift or the green `transverse` magnification reshape the image, and then the angle
//! between the green chief rays at screen `(±1, 0)` or `(0, ±1)`, the narrower pair — what the rays
//! really span, as `obscura check` measures it. Enhance leaves dicing alone, as RenderMan documents,
//! while the ray spread is the true, enhanced footprint. With the thin lens on: FStop `fStop/dofMult` (the
//! f-number of the lens actually used), FocalLength, FocalDistance (where the view axis meets the green
//! plane of focus).
//!
//! # Parameters decided here
//!
//! - `fStop` defaults to 16 as in RenderMan's PxrCamera, but `focalLength` defaults to 0 and, as for
//!   every Obscura projection ([`crate::dof`]), there is no lens without a positive focal length: the
//!   default camera is a pinhole, as RenderMan's is.
//! - `focus1`, `focus2`, `focus3` are camera-space points (RIB's `Projection` is issued while the
//!   current transform is camera space); given together they replace `tilt`, `roll` and
//!   `focalDistance`.
//! - `enhance` is a `float[3]`, not a `point`: it is a screen position and a zoom factor, which no
//!   transform should touch.
//! - `optical` is the clipping disk's offset in aperture radii per unit tangent of the field angle.

mod distortion;
mod focal_plane;
mod vignetting;

use std::sync::LazyLock;

use obscura_sdk::optics::screen_distance;
use obscura_sdk::{
    ContextParts, DeepMetric, DicingHint, ParamDecl, ParamList, ParamType, ParamValue, Params, PluginError,
    Point2, Projection, ProjectionContext, ProjectionEnvironment, ProjectionFactory, ProjectionProperty,
    PropertyValue, RayGeometry, Rgb, ValueRange, Vec3,
};

use crate::dof::{self, DepthOfField};
use crate::rolling_shutter::RollingShutter;
use crate::simd;
use distortion::Distortion;
use focal_plane::{FocalPlane, MAX_TILT_DEGREES};

/// The name scenes use.
pub const NAME: &str = "PxrCamera";

/// Any finite value.
const FINITE: ValueRange = ValueRange::open(f64::NEG_INFINITY, f64::INFINITY);
/// Finite and not negative.
const NON_NEGATIVE: ValueRange = ValueRange {
    min: 0.0,
    max: f64::INFINITY,
    min_inclusive: true,
    max_inclusive: false,
};

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    let [mut f_stop, focal_length, focal_distance] = dof::params();
    f_stop.default = ParamValue::Floats(vec![16.0]);
    f_stop.doc = "aperture f-number (RenderMan's PxrCamera default 16); depth of field needs focalLength > 0 too; inf or 0 = pinhole".into();
    let mut table = vec![
        ParamDecl::float("fov", 90.0)
            .range(ValueRange::open(0.0, 180.0))
            .doc("field of view in degrees across the screen window's [-1, 1] square (the smaller image side)"),
        ParamDecl::float("fovEnd", 0.0)
            .range(ValueRange {
                min: 0.0,
                max: 180.0,
                min_inclusive: true,
                max_inclusive: false,
            })
            .doc("field of view at shutter close, for zoom blur; 0 = same as fov"),
        f_stop,
        focal_length,
        focal_distance,
        ParamDecl::float("dofMult", 1.0)
            .range(NON_NEGATIVE)
            .doc("multiplies the lens radius: 0 = no depth of field, 2 = twice the blur"),
        ParamDecl::float("tilt", 0.0)
            .range(ValueRange::closed(-MAX_TILT_DEGREES, MAX_TILT_DEGREES))
            .doc("degrees between the plane of focus and the image plane; + brings the top of the plane closer (needs depth of field)"),
        ParamDecl::float("roll", 0.0)
            .range(FINITE)
            .doc("degrees the tilted plane of focus turns clockwise about the view axis"),
        ParamDecl::triple("focus1", ParamType::Point, Vec3::ZERO)
            .range(FINITE)
            .doc("first of three camera-space points on the plane of focus; all three replace tilt, roll and focalDistance"),
        ParamDecl::triple("focus2", ParamType::Point, Vec3::ZERO)
            .range(FINITE)
            .doc("second point on the plane of focus (with focus1, focus3)"),
        ParamDecl::triple("focus3", ParamType::Point, Vec3::ZERO)
            .range(FINITE)
            .doc("third point on the plane of focus (with focus1, focus2)"),
        ParamDecl::float("shiftX", 0.0)
            .range(FINITE)
            .doc("lens shift to the right in screen units (half the smaller image side = 1)"),
        ParamDecl::float("shiftY", 0.0)
            .range(FINITE)
            .doc("lens shift up in screen units; corrects keystoning without tilting the camera"),
        ParamDecl::float("radial1", 0.0)
            .range(FINITE)
            .doc("quadratic radial distortion: > 0 pincushion, < 0 barrel"),
        ParamDecl::float("radial2", 0.0)
            .range(FINITE)
            .doc("quartic radial distortion"),
        ParamDecl::float("assymX", 0.0)
            .range(FINITE)
            .doc("radial distortion of x only: horizontal lines stay straight"),
        ParamDecl::float("assymY", 0.0)
            .range(FINITE)
            .doc("radial distortion of y only: vertical lines stay straight"),
        ParamDecl::float("squeeze", 1.0)
            .range(ValueRange::greater_than(0.0))
            .doc("anamorphic squeeze of the distortion: the radius is measured with x/squeeze, so > 1 distorts x less"),
        ParamDecl::color("transverse", Rgb::WHITE)
            .range(ValueRange::greater_than(0.0))
            .doc("lateral chromatic aberration: magnification of the red, green and blue images"),
        ParamDecl::color("axial", Rgb::BLACK)
            .range(FINITE)
            .doc("longitudinal chromatic aberration: focal distance shift of red, green and blue, scene units"),
        ParamDecl::float("natural", 0.0)
            .range(ValueRange::closed(0.0, 1.0))
            .doc("natural (cos^4) vignetting: 0 off, 1 full"),
        ParamDecl::float("optical", 0.0)
            .range(NON_NEGATIVE)
            .doc("optical (cat's-eye) vignetting: offset of the clipping disk in aperture radii per unit tan(field angle)"),
        ParamDecl::float_array("enhance", &[0.0, 0.0, 1.0])
            .range(FINITE)
            .doc("zoom into screen point (x, y) by z without changing dicing: s -> (x, y) + s/z"),
    ];
    table.extend(RollingShutter::params());
    table
});

/// Creates [`PxrCamera`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct PxrCameraFactory;

impl ProjectionFactory for PxrCameraFactory {
    fn name(&self) -> &str {
        NAME
    }

    fn summary(&self) -> &str {
        "full-featured perspective: zoom, thin lens with tilted focal plane, shift, distortion, \
         chromatic aberration, vignetting, rolling shutter, enhance"
    }

    fn param_table(&self) -> &[ParamDecl] {
        &TABLE
    }

    fn create_projection(
        &self,
        env: &mut ProjectionEnvironment,
        params: &ParamList,
    ) -> Result<Box<dyn Projection>, PluginError> {
        let p = Params::resolve(NAME, &TABLE, params)?;
        let camera = PxrCamera::from_params(env, &p)?;
        env.set_deep_metric(DeepMetric::CameraZ);
        Ok(Box::new(camera))
    }
}

/// RenderMan's `PxrCamera` (see the module documentation for its mapping).
#[derive(Debug, Clone, PartialEq)]
pub struct PxrCamera {
    half_pixel: f32,
    near: f32,
    far: f32,
    fov: f32,
    /// `Some(fovEnd)` when the field of view changes during the shutter.
    fov_end: Option<f32>,
    d: f32,
    /// `(ex, ey, 1/ez)`.
    enhance: (f32, f32, f32),
    enhance_zoom: f64,
    shift: (f32, f32),
    distortion: Option<Distortion>,
    chromatic: bool,
    /// `1/transverse[c]`.
    inv_magnification: [f32; 3],
    magnification_green: f64,
    /// `δ_c`: the plane of focus of each channel.
    delta: [f32; 3],
    normal: Vec3,
    lens_radius: f32,
    natural: f32,
    optical: f32,
    shutter: Option<RollingShutter>,
    /// True when any of rolling shutter, zoom, chromatic aberration or vignetting is on.
    extra: bool,
    /// What the FStop, FocalLength, FocalDistance properties report.
    reported_dof: DepthOfField,
    /// What the FieldOfView property reports ([`PxrCamera::measured_field_of_view`]).
    field_of_view: f32,
}

/// Green: the reference channel when there is no chromatic aberration, and the one `unproject` inverts.
const GREEN: usize = 1;

impl PxrCamera {
    fn from_params(env: &ProjectionEnvironment, p: &Params) -> Result<Self, PluginError> {
        let invalid = |message: String| PluginError::Invalid {
            plugin: NAME.to_string(),
            message,
        };
        let (fov, fov_end) = (p.float("fov")?, p.float("fovEnd")?);
        let dof = DepthOfField::from_params(p)?;
        let dof_mult = p.float("dofMult")?;
        let lens_radius = dof.lens_radius() * dof_mult;

        let focus = ["focus1", "focus2", "focus3"];
        let given: Vec<&str> = focus.iter().copied().filter(|n| p.is_given(n)).collect();
        let plane = match given.len() {
            0 => FocalPlane::from_tilt_roll(
                dof.focal_distance as f64,
                p.float("tilt")? as f64,
                p.float("roll")? as f64,
            ),
            3 => FocalPlane::from_points([p.triple("focus1")?, p.triple("focus2")?, p.triple("focus3")?])
                .map_err(invalid)?,
            _ => {
                return Err(invalid(format!(
                    "focus1, focus2 and focus3 define the plane of focus together, but only {} {} given; \
                     give all three, or none and use focalDistance, tilt and roll",
                    given.join(" and "),
                    if given.len() == 1 { "was" } else { "were" }
                )));
            }
        };

        let transverse = p.color("transverse")?;
        let axial = p.color("axial")?;
        let (transverse, axial) = (
            [transverse.r, transverse.g, transverse.b],
            [axial.r, axial.g, axial.b],
        );
        let chromatic =
            transverse.iter().any(|&m| m != transverse[GREEN]) || axial.iter().any(|&a| a != axial[GREEN]);
        let axis = plane.axial_distance();
        let mut delta = [0.0f32; 3];
        for (c, name) in ["red", "green", "blue"].iter().enumerate() {
            if axis + axial[c] as f64 <= 0.0 {
                return Err(invalid(format!(
                    "\"axial\" moves the {name} plane of focus to {} (focal distance {axis} + {}): \
                     expected every channel's focal distance to stay positive",
                    axis + axial[c] as f64,
                    axial[c]
                )));
            }
            delta[c] = plane.shifted_delta(axial[c] as f64) as f32;
        }

        let enhance = p.floats("enhance", 3)?;
        if enhance[2].is_nan() || enhance[2] <= 0.0 {
            return Err(invalid(format!(
                "\"enhance\" = ({}, {}, {}): the third value is the zoom factor and must be positive \
                 (1 = no zoom)",
                enhance[0], enhance[1], enhance[2]
            )));
        }

        let reported_dof = DepthOfField {
            f_stop: if dof_mult > 0.0 {
                dof.f_stop / dof_mult
            } else {
                f32::INFINITY
            },
            focal_length: dof.focal_length,
            focal_distance: (axis + axial[GREEN] as f64) as f32,
        };
        let (px, py) = env.pixel_size();
        let shutter = Some(RollingShutter::from_params(p, env.screen_window())?).filter(|r| !r.is_global());
        let (natural, optical) = (p.float("natural")?, p.float("optical")?);
        let fov_end_on = fov_end > 0.0 && fov_end != fov;
        let mut camera = PxrCamera {
            half_pixel: 0.5 * (px * py).sqrt(),
            near: env.clipping_near(),
            far: env.clipping_far(),
            fov,
            fov_end: fov_end_on.then_some(fov_end),
            d: screen_distance(fov),
            enhance: (enhance[0], enhance[1], 1.0 / enhance[2]),
            enhance_zoom: enhance[2] as f64,
            shift: (p.float("shiftX")?, p.float("shiftY")?),
            distortion: Distortion::new(
                p.float("radial1")? as f64,
                p.float("radial2")? as f64,
                p.float("assymX")? as f64,
                p.float("assymY")? as f64,
                p.float("squeeze")? as f64,
            ),
            chromatic,
            inv_magnification: transverse.map(|m| 1.0 / m),
            magnification_green: transverse[GREEN] as f64,
            delta,
            normal: Vec3::new(
                plane.normal[0] as f32,
                plane.normal[1] as f32,
                plane.normal[2] as f32,
            ),
            lens_radius: if lens_radius > 0.0 && lens_radius.is_finite() {
                lens_radius
            } else {
                0.0
            },
            natural,
            optical,
            shutter,
            extra: shutter.is_some() || fov_end_on || chromatic || natural > 0.0 || optical > 0.0,
            reported_dof,
            field_of_view: fov,
        };
        camera.field_of_view = camera.measured_field_of_view();
        Ok(camera)
    }

    /// The angle the image actually spans across the `[−1, 1]` square: between the green chief rays
    /// (no lens, no enhance) at screen `(−1, 0)` and `(1, 0)`, and at `(0, −1)` and `(0, 1)`, the
    /// narrower of the two, at the narrower end of a zoom. It is `fov` unless distortion, shift or the
    /// green channel's `transverse` magnification reshape the image; a pair with an end beyond the
    /// distortion's fold is left out (and with both left out, `fov` stands).
    fn measured_field_of_view(&self) -> f32 {
        let narrower = self.fov_end.map_or(self.fov, |e| e.min(self.fov));
        let inv_m = f64::from(self.inv_magnification[GREEN]);
        if self.distortion.is_none() && self.shift == (0.0, 0.0) && inv_m == 1.0 {
            return narrower;
        }
        let chief = |s: [f64; 2], d: f64| -> Option<[f64; 3]> {
            let p = [
                (s[0] + f64::from(self.shift.0)) * inv_m,
                (s[1] + f64::from(self.shift.1)) * inv_m,
            ];
            let u = match &self.distortion {
                Some(dist) => dist.ideal(p)?,
                None => p,
            };
            let l = (u[0] * u[0] + u[1] * u[1] + d * d).sqrt();
            Some([u[0] / l, u[1] / l, d / l])
        };
        let angle = |a: [f64; 3], b: [f64; 3]| {
            let c = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            let sin = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            let cos = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            sin.atan2(cos).to_degrees()
        };
        let extent = |fov: f32| -> f32 {
            let d = f64::from(screen_distance(fov));
            [([-1.0, 0.0], [1.0, 0.0]), ([0.0, -1.0], [0.0, 1.0])]
                .into_iter()
                .filter_map(|(a, b)| Some(angle(chief(a, d)?, chief(b, d)?)))
                .fold(None, |m: Option<f64>, e| Some(m.map_or(e, |m| m.min(e))))
                .map_or(fov, |e| e as f32)
        };
        let start = extent(self.fov);
        self.fov_end.map_or(start, |end| start.min(extent(end)))
    }

    /// True when the thin lens is on.
    #[must_use]
    pub fn has_depth_of_field(&self) -> bool {
        self.lens_radius > 0.0
    }

    /// The screen-plane distance at shutter-normalised time `t` (after any rolling-shutter rewrite).
    #[inline]
    #[must_use]
    pub fn screen_distance_at(&self, t: f32) -> f32 {
        match self.fov_end {
            None => self.d,
            Some(end) => screen_distance(self.fov + (end - self.fov) * t),
        }
    }

    /// One sample: the rewritten time, and the ray with its tint factor (`None`: culled).
    #[inline(always)]
    ///
    /// `DIST`, `LENS` and `EXTRA` say whether distortion, the thin lens and any of rolling shutter,
    /// zoom, chromatic aberration and vignetting are on, so that each combination compiles to a loop
    /// without the others' branches.
    fn sample<const DIST: bool, const LENS: bool, const EXTRA: bool>(
        &self,
        s: Point2,
        a: Point2,
        t: f32,
    ) -> (f32, Option<(RayGeometry, Rgb)>) {
        let (ex, ey, inv_ez) = self.enhance;
        let se = Point2::new(ex + s.x * inv_ez, ey + s.y * inv_ez);
        let (t, d) = if EXTRA {
            let t = match &self.shutter {
                Some(rs) => rs.time(se, t),
                None => t,
            };
            (t, self.screen_distance_at(t))
        } else {
            (t, self.d)
        };
        let (c, mut tint) = if EXTRA && self.chromatic {
            let c = channel(s);
            let mut tint = Rgb::BLACK;
            match c {
                0 => tint.r = 3.0,
                1 => tint.g = 3.0,
                _ => tint.b = 3.0,
            }
            (c, tint)
        } else {
            (GREEN, Rgb::WHITE)
        };
        let inv_m = self.inv_magnification[c];
        let (x, y) = ((se.x + self.shift.0) * inv_m, (se.y + self.shift.1) * inv_m);
        let (u, j) = match &self.distortion {
            Some(dist) if DIST => match dist.forward(x, y) {
                Some(f) => (f.u, f.jacobian),
                None => return (t, None),
            },
            _ => ((x, y), [1.0, 0.0, 0.0, 1.0]),
        };
        let l2 = u.0 * u.0 + u.1 * u.1 + d * d;
        let inv_l = 1.0 / l2.sqrt();
        let w = Vec3::new(u.0 * inv_l, u.1 * inv_l, d * inv_l);
        let wz2 = w.z * w.z;
        let cross2 = |a0: f32, a1: f32| {
            let k = w.x * a1 - w.y * a0;
            wz2 * (a0 * a0 + a1 * a1) + k * k
        };
        let sx = cross2(j[0], j[2]);
        let sy = cross2(j[1], j[3]);
        let mut spread = self.half_pixel * inv_ez * inv_m * (sx * sy).sqrt().sqrt() * inv_l;

        let mut factor = 1.0;
        if EXTRA && self.natural > 0.0 {
            factor *= vignetting::natural_factor(self.natural, w.z);
        }
        let mut lens = (a.x, a.y);
        if EXTRA && self.optical > 0.0 {
            let k = -self.optical / d;
            let (moved, fraction) = vignetting::cat_eye((k * u.0, k * u.1), lens);
            lens = moved;
            factor *= fraction;
        }
        let (origin, dir) = if LENS {
            let delta = self.delta[c];
            let o = Vec3::new(self.lens_radius * lens.0, self.lens_radius * lens.1, 0.0);
            let h = w * delta - o * self.normal.dot(w);
            let inv_lh = 1.0 / h.length();
            spread *= delta * inv_lh;
            (o, h * inv_lh)
        } else {
            (Vec3::ZERO, w)
        };
        let inv_dz = 1.0 / dir.z;
        let (min_dist, max_dist) = (self.near * inv_dz, self.far * inv_dz);
        // Absurd parameters (a lens far wider than its focal distance, a pole of the distortion met
        // in f32) can leave nothing usable: cull rather than hand the host a broken ray.
        if !(dir.z > 0.0
            && dir.x.is_finite()
            && dir.y.is_finite()
            && spread.is_finite()
            && min_dist.is_finite())
        {
            return (t, None);
        }
        tint.r *= factor;
        tint.g *= factor;
        tint.b *= factor;
        let ray = RayGeometry {
            origin,
            origin_radius: 0.0,
            direction: dir,
            ray_spread: spread,
            min_dist,
            max_dist,
        };
        (t, Some((ray, tint)))
    }
}

impl PxrCamera {
    /// `project` for one combination of features.
    fn run<const DIST: bool, const LENS: bool, const EXTRA: bool>(&self, c: ContextParts<'_>) {
        simd::run(|| {
            for ((((s, a), t), r), tint) in c
                .screen
                .iter()
                .zip(c.aperture)
                .zip(c.time.iter_mut())
                .zip(c.rays.iter_mut())
                .zip(c.tint.iter_mut())
            {
                let (time, out) = self.sample::<DIST, LENS, EXTRA>(*s, *a, *t);
                *t = time;
                match out {
                    Some((ray, k)) => {
                        *r = ray;
                        if EXTRA {
                            tint.r *= k.r;
                            tint.g *= k.g;
                            tint.b *= k.b;
                        }
                    }
                    None => *r = RayGeometry::CULLED,
                }
            }
        });
    }
}

/// The chromatic channel of a screen sample: 0, 1 or 2 with equal probability, from a hash of its
/// bits (SplitMix64's finaliser, then the top 32 bits scaled to [0, 3)).
#[inline(always)]
fn channel(s: Point2) -> usize {
    let mut h = (s.x.to_bits() as u64) | ((s.y.to_bits() as u64) << 32);
    h ^= h >> 30;
    h = h.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    h ^= h >> 27;
    h = h.wrapping_mul(0x94d0_49bb_1331_11eb);
    h ^= h >> 31;
    (((h >> 32) * 3) >> 32) as usize
}

impl Projection for PxrCamera {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        match property {
            ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(DicingHint::Perspective)),
            ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(DeepMetric::CameraZ)),
            ProjectionProperty::FieldOfView => Some(PropertyValue::Float(self.field_of_view)),
            ProjectionProperty::FStop
            | ProjectionProperty::FocalLength
            | ProjectionProperty::FocalDistance
                if self.has_depth_of_field() =>
            {
                self.reported_dof.property(property)
            }
            _ => None,
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        match (self.distortion.is_some(), self.lens_radius > 0.0, self.extra) {
            (false, false, false) => self.run::<false, false, false>(c),
            (false, false, true) => self.run::<false, false, true>(c),
            (false, true, false) => self.run::<false, true, false>(c),
            (false, true, true) => self.run::<false, true, true>(c),
            (true, false, false) => self.run::<true, false, false>(c),
            (true, false, true) => self.run::<true, false, true>(c),
            (true, true, false) => self.run::<true, true, false>(c),
            (true, true, true) => self.run::<true, true, true>(c),
        }
    }

    fn unproject(&self, point: Vec3, time: f32) -> Option<Point2> {
        if !(point.is_finite() && point.z > 0.0) {
            return None;
        }
        let d = self.screen_distance_at(time) as f64;
        let k = d / point.z as f64;
        let u = [point.x as f64 * k, point.y as f64 * k];
        let p = match &self.distortion {
            None => u,
            Some(dist) => dist.undistort(u)?.p,
        };
        let m = self.magnification_green;
        let (ex, ey, _) = self.enhance;
        let sx = (p[0] * m - self.shift.0 as f64 - ex as f64) * self.enhance_zoom;
        let sy = (p[1] * m - self.shift.1 as f64 - ey as f64) * self.enhance_zoom;
        (sx.is_finite() && sy.is_finite()).then(|| Point2::new(sx as f32, sy as f32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{self, ContractTest, assert_contract, assert_refused};
    use obscura_sdk::Format;
    use proptest::prelude::*;

    fn try_make(params: &[(&str, &str)], format: Format) -> Result<Box<dyn Projection>, PluginError> {
        testing::try_make(&PxrCameraFactory, params, format)
    }

    fn make(params: &[(&str, &str)], format: Format) -> Box<dyn Projection> {
        try_make(params, format).unwrap()
    }

    /// Projects one batch; returns the rays, the rewritten times and the tints.
    fn run(
        p: &dyn Projection,
        screen: &[Point2],
        aperture: &[Point2],
        time: &[f32],
    ) -> (Vec<RayGeometry>, Vec<f32>, Vec<Rgb>) {
        let n = screen.len();
        let lens: Vec<Point2> = aperture
            .iter()
            .map(|a| Point2::new(0.5 * a.x + 0.5, 0.5 * a.y + 0.5))
            .collect();
        let mut time = time.to_vec();
        let mut rays = vec![RayGeometry::CULLED; n];
        let mut tint = vec![Rgb::WHITE; n];
        let mut ctx =
            ProjectionContext::new(screen, &lens, aperture, &mut time, &mut rays, &mut tint).unwrap();
        p.project(&mut ctx);
        (rays, time, tint)
    }

    fn one(p: &dyn Projection, s: Point2, a: Point2, t: f32) -> (RayGeometry, f32, Rgb) {
        let (r, t, c) = run(p, &[s], &[a], &[t]);
        (r[0], t[0], c[0])
    }

    fn f64v(v: Vec3) -> [f64; 3] {
        [v.x as f64, v.y as f64, v.z as f64]
    }

    fn fmt(x: f32) -> String {
        format!("{x}")
    }

    /// The plane-of-focus normal from tilt and roll, written out independently of `focal_plane`.
    fn plane_normal(tilt: f64, roll: f64) -> [f64; 3] {
        let (t, r) = (tilt.to_radians(), roll.to_radians());
        [t.sin() * r.sin(), t.sin() * r.cos(), t.cos()]
    }

    /// Where the line of ray `r` meets the plane `n·X = delta`.
    fn meet(r: &RayGeometry, n: [f64; 3], delta: f64) -> [f64; 3] {
        let (o, d) = (f64v(r.origin), f64v(r.direction));
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let t = (delta - dot(n, o)) / dot(n, d);
        [o[0] + d[0] * t, o[1] + d[1] * t, o[2] + d[2] * t]
    }

    fn dist3(a: [f64; 3], b: [f64; 3]) -> f64 {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    }

    proptest! {
        #[test]
        fn chief_rays_match_an_independent_f64_formula(
            fov in 20.0f32..150.0, shift in (-0.3f32..0.3, -0.3f32..0.3),
            k1 in -0.2f32..0.2, k2 in -0.05f32..0.05, ax in -0.05f32..0.05, ay in -0.05f32..0.05, sq in 0.7f32..1.5,
            e in (-0.5f32..0.5, -0.5f32..0.5, 0.5f32..4.0), sx in -2.0f32..2.0, sy in -1.2f32..1.2,
        ) {
            let p = make(&[
                ("float fov", &fmt(fov)), ("float shiftX", &fmt(shift.0)), ("float shiftY", &fmt(shift.1)),
                ("float radial1", &fmt(k1)), ("float radial2", &fmt(k2)), ("float assymX", &fmt(ax)),
                ("float assymY", &fmt(ay)), ("float squeeze", &fmt(sq)),
                ("float[3] enhance", &format!("{} {} {}", e.0, e.1, e.2)),
            ], Format::new(64, 48));
            let (r, _, _) = one(p.as_ref(), Point2::new(sx, sy), Point2::ZERO, 0.0);
            let (k1, k2, ax, ay, sq) = (k1 as f64, k2 as f64, ax as f64, ay as f64, sq as f64);
            let x = e.0 as f64 + sx as f64 / e.2 as f64 + shift.0 as f64;
            let y = e.1 as f64 + sy as f64 / e.2 as f64 + shift.1 as f64;
            let q = (x / sq).powi(2) + y * y;
            // Beyond the fold: some radius up to this one has a non-positive denominator or a
            // non-rising radial profile on one of the axes.
            let broken = |q: f64| [k1 + ax, k1 + ay].iter().any(|&c| 1.0 + c * q + k2 * q * q <= 0.0 || 1.0 - c * q - 3.0 * k2 * q * q <= 0.0);
            let folds_before = |q_end: f64| (0..=2000).any(|i| broken(q_end * i as f64 / 2000.0));
            if r.is_culled() {
                prop_assert!(folds_before(q * (1.0 + 1e-4)), "culled at q {} though the map is monotonic there", q);
            } else {
                prop_assert!(!folds_before(q * (1.0 - 1e-4)), "kept a sample beyond the fold, q {}", q);
                let dx = 1.0 + (k1 + ax) * q + k2 * q * q;
                let dy = 1.0 + (k1 + ay) * q + k2 * q * q;
                let d = 1.0 / (fov as f64 / 2.0).to_radians().tan();
                let v = [x / dx, y / dy, d];
                let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                let got = f64v(r.direction);
                for k in 0..3 {
                    prop_assert!((got[k] - v[k] / l).abs() < 2e-5, "{:?} vs {:?}", got, v.map(|c| c / l));
                }
                prop_assert_eq!(r.origin, Vec3::ZERO);
            }
        }

        #[test]
        fn thin_lens_rays_of_one_screen_point_meet_on_the_tilted_focal_plane(
            tilt in -60.0f64..60.0, roll in -180.0f64..180.0, fd in 0.5f64..50.0, f_stop in 1.0f32..16.0,
            sx in -1.4f32..1.4, sy in -1.0f32..1.0, k1 in -0.1f32..0.1,
            apertures in proptest::collection::vec((-1.0f32..1.0, -1.0f32..1.0), 4),
        ) {
            let p = make(&[
                ("float fov", "60"), ("float fStop", &fmt(f_stop)), ("float focalLength", "0.2"),
                ("float focalDistance", &fd.to_string()), ("float tilt", &tilt.to_string()),
                ("float roll", &roll.to_string()), ("float radial1", &fmt(k1)),
            ], Format::new(64, 48));
            let n = plane_normal(tilt, roll);
            let delta = fd * tilt.to_radians().cos();
            let s = Point2::new(sx, sy);
            let (chief, _, _) = one(p.as_ref(), s, Point2::ZERO, 0.0);
            prop_assume!(!chief.is_culled());
            let w = f64v(chief.direction);
            let nw = n[0] * w[0] + n[1] * w[1] + n[2] * w[2];
            prop_assume!(nw.abs() > 0.05);
            // The focus point: the chief ray meets the plane (in front, or behind for a virtual focus).
            let focus = w.map(|c| c * delta / nw);
            let scale = 1.0 + focus.iter().map(|c| c.abs()).fold(0.0, f64::max);
            for (ax, ay) in apertures {
                let (r, _, _) = one(p.as_ref(), s, Point2::new(ax, ay), 0.0);
                let radius = 0.5 * 0.2 / f_stop as f64;
                prop_assert!((r.origin.x as f64 - radius * ax as f64).abs() < 1e-6);
                prop_assert!((r.origin.y as f64 - radius * ay as f64).abs() < 1e-6);
                let hit = meet(&r, n, delta);
                prop_assert!(dist3(hit, focus) < 2e-5 * scale * scale / radius.clamp(0.05, 1.0), "{:?} vs {:?}", hit, focus);
            }
        }

        #[test]
        fn unproject_inverts_project_to_a_ten_thousandth_of_a_pixel(
            k1 in -0.12f32..0.12, k2 in -0.015f32..0.015, ax in -0.04f32..0.04, sq in 0.8f32..1.3,
            shift in (-0.2f32..0.2, -0.2f32..0.2), e in (-0.3f32..0.3, -0.3f32..0.3, 0.5f32..2.0),
            g in 0.9f32..1.1, t in 0.0f32..1.0, depth in 0.5f32..40.0,
            fx in 0.0f64..320.0, fy in 0.0f64..240.0,
        ) {
            let format = Format::new(320, 240);
            let p = make(&[
                ("float fov", "55"), ("float fovEnd", "40"),
                ("float radial1", &fmt(k1)), ("float radial2", &fmt(k2)), ("float assymX", &fmt(ax)),
                ("float squeeze", &fmt(sq)), ("float shiftX", &fmt(shift.0)), ("float shiftY", &fmt(shift.1)),
                ("float[3] enhance", &format!("{} {} {}", e.0, e.1, e.2)),
                ("color transverse", &format!("{g} {g} {g}")),
                ("float fStop", "2"), ("float focalLength", "0.1"), ("float focalDistance", "3"),
            ], format);
            let window = obscura_sdk::ScreenWindow::default_for(format);
            let s = window.raster_to_screen(format, fx, fy);
            let (r, t2, _) = one(p.as_ref(), s, Point2::ZERO, t);
            prop_assume!(!r.is_culled());
            // Close to a fold the radial profile flattens and a few f32 ulps of direction are more
            // than 1e-4 pixel of screen: keep to where the profile still rises at half its rate at
            // the centre (1 − c·q − 3·k2·q² on both axes ≥ 0.5). The f64 inverse itself is exact
            // everywhere (`distortion` tests).
            let x = (e.0 + s.x / e.2 + shift.0) as f64 / g as f64;
            let y = (e.1 + s.y / e.2 + shift.1) as f64 / g as f64;
            let q = (x / sq as f64).powi(2) + y * y;
            let (k1, k2) = (k1 as f64, k2 as f64);
            prop_assume!([k1 + ax as f64, k1].iter().all(|c| 1.0 - c * q - 3.0 * k2 * q * q >= 0.5));
            let back = p.unproject(r.origin + r.direction * depth, t2).expect("a point the camera sees");
            let (bx, by) = window.screen_to_raster(format, back);
            prop_assert!((bx - fx).abs() < 1e-4 && (by - fy).abs() < 1e-4, "({}, {}) vs ({}, {})", bx, by, fx, fy);
        }
    }

    #[test]
    fn focus_points_reproduce_the_plane_of_tilt_roll_and_focal_distance() {
        let (tilt, roll, fd) = (25.0f64, 30.0f64, 6.0f64);
        let n = plane_normal(tilt, roll);
        let delta = fd * tilt.to_radians().cos();
        let on = |x: f64, y: f64| {
            let z = (delta - n[0] * x - n[1] * y) / n[2];
            format!("{x} {y} {z}")
        };
        let lens = [("float fStop", "2.8"), ("float focalLength", "0.1")];
        let mut by_points = lens.to_vec();
        let (p1, p2, p3) = (on(0.5, 0.2), on(-2.0, 1.0), on(1.0, -3.0));
        by_points.extend([
            ("point focus1", p1.as_str()),
            ("point focus2", p2.as_str()),
            ("point focus3", p3.as_str()),
        ]);
        // tilt given too: the points win, as in RenderMan.
        by_points.push(("float tilt", "-10"));
        let mut by_angles = lens.to_vec();
        let (t, r, f) = (tilt.to_string(), roll.to_string(), fd.to_string());
        by_angles.extend([
            ("float tilt", t.as_str()),
            ("float roll", r.as_str()),
            ("float focalDistance", f.as_str()),
        ]);
        let format = Format::new(32, 32);
        let (a, b) = (make(&by_points, format), make(&by_angles, format));
        match a.property(ProjectionProperty::FocalDistance) {
            Some(PropertyValue::Float(got)) => assert!((got as f64 - fd).abs() < 1e-4, "{got}"),
            other => panic!("{other:?}"),
        }
        for i in 0..50 {
            let s = Point2::new((i as f32 * 0.37).sin(), (i as f32 * 0.71).cos());
            let ap = Point2::new((i as f32 * 1.3).cos(), (i as f32 * 0.9).sin() * 0.8);
            let (ra, _, _) = one(a.as_ref(), s, ap, 0.0);
            let (rb, _, _) = one(b.as_ref(), s, ap, 0.0);
            assert!((ra.direction - rb.direction).length() < 1e-5, "{ra:?} vs {rb:?}");
            assert_eq!(ra.origin, rb.origin);
        }
    }

    #[test]
    fn bad_focus_points_are_refused_naming_the_parameters() {
        let format = Format::new(8, 8);
        let err = |params: &[(&str, &str)]| try_make(params, format).err().expect("refused").to_string();
        let collinear = err(&[
            ("point focus1", "0 0 1"),
            ("point focus2", "1 1 2"),
            ("point focus3", "2 2 3"),
        ]);
        assert!(collinear.starts_with("PxrCamera: "), "{collinear}");
        assert!(
            collinear.contains("collinear")
                && collinear.contains("focus1 (0, 0, 1)")
                && collinear.contains("focus3"),
            "{collinear}"
        );
        let through = err(&[
            ("point focus1", "1 0 1"),
            ("point focus2", "-1 0 -1"),
            ("point focus3", "0 1 0"),
        ]);
        assert!(through.contains("passes through the camera"), "{through}");
        let parallel = err(&[
            ("point focus1", "1 0 1"),
            ("point focus2", "1 1 5"),
            ("point focus3", "1 -1 3"),
        ]);
        assert!(parallel.contains("parallel to the view"), "{parallel}");
        let partial = err(&[("point focus1", "0 0 1"), ("point focus3", "1 0 2")]);
        assert!(partial.contains("only focus1 and focus3 were given"), "{partial}");
    }

    #[test]
    fn chromatic_tints_average_to_white_and_each_channel_has_its_own_lens() {
        let format = Format::new(64, 64);
        let transverse = [0.97f64, 1.0, 1.03];
        let axial = [0.3f64, 0.0, -0.2];
        let p = make(
            &[
                ("float fov", "50"),
                ("color transverse", "0.97 1 1.03"),
                ("color axial", "0.3 0 -0.2"),
                ("float fStop", "2"),
                ("float focalLength", "0.2"),
                ("float focalDistance", "4"),
            ],
            format,
        );
        let n = 30_000;
        let screen: Vec<Point2> = (0..n)
            .map(|i| {
                Point2::new(
                    ((i as f32 * 0.618_034).fract() * 2.0 - 1.0) * 1.2,
                    (i as f32 * 0.754_877_7).fract() * 2.0 - 1.0,
                )
            })
            .collect();
        let aperture: Vec<Point2> = (0..n)
            .map(|i| Point2::new((i as f32 * 0.31).sin(), (i as f32 * 0.47).cos() * 0.7))
            .collect();
        let (rays, _, tints) = run(p.as_ref(), &screen, &aperture, &vec![0.0; n]);
        let mut sum = [0.0f64; 3];
        let d = 1.0 / 25f64.to_radians().tan();
        for ((s, r), c) in screen.iter().zip(&rays).zip(&tints) {
            let rgb = [c.r, c.g, c.b];
            let ch = (0..3).find(|&k| rgb[k] != 0.0).unwrap();
            assert_eq!(rgb.iter().filter(|&&v| v != 0.0).count(), 1);
            assert_eq!(rgb[ch], 3.0);
            for k in 0..3 {
                sum[k] += rgb[k] as f64;
            }
            // The channel's chief ray is magnified by transverse[c], and its lens focuses at
            // focalDistance + axial[c].
            let w = [s.x as f64 / transverse[ch], s.y as f64 / transverse[ch], d];
            let fz = 4.0 + axial[ch];
            let focus = [w[0] * fz / d, w[1] * fz / d, fz];
            let hit = meet(r, [0.0, 0.0, 1.0], fz);
            assert!(dist3(hit, focus) < 1e-4, "channel {ch}: {hit:?} vs {focus:?}");
        }
        for (k, total) in sum.iter().enumerate() {
            let mean = total / n as f64;
            assert!((mean - 1.0).abs() < 0.03, "channel {k} mean tint {mean}");
        }
        // The channel does not depend on the lens or time samples.
        let s = [Point2::new(0.3, 0.2); 2];
        let (_, _, c) = run(
            p.as_ref(),
            &s,
            &[Point2::new(0.5, 0.5), Point2::new(-0.9, 0.1)],
            &[0.1, 0.9],
        );
        assert_eq!(c[0], c[1]);
        // Without aberration nothing is tinted.
        let plain = make(&[("color transverse", "1.02 1.02 1.02")], format);
        let (_, _, c) = run(plain.as_ref(), &screen[..100], &aperture[..100], &[0.0; 100]);
        assert!(c.iter().all(|c| *c == Rgb::WHITE));
    }

    #[test]
    fn natural_vignetting_is_cos4_of_the_chief_ray() {
        let format = Format::new(64, 64);
        let full = make(
            &[
                ("float fov", "100"),
                ("float natural", "1"),
                ("float radial1", "-0.05"),
            ],
            format,
        );
        let half = make(
            &[
                ("float fov", "100"),
                ("float natural", "0.5"),
                ("float radial1", "-0.05"),
            ],
            format,
        );
        for i in 0..200 {
            let s = Point2::new((i as f32 * 0.13).sin() * 1.5, (i as f32 * 0.29).cos());
            let (r, _, c) = one(full.as_ref(), s, Point2::ZERO, 0.0);
            let cos4 = (r.direction.z as f64).powi(4);
            assert!(
                (c.r as f64 - cos4).abs() < 1e-6 && c.r == c.g && c.g == c.b,
                "{c:?} vs {cos4}"
            );
            let (_, _, c) = one(half.as_ref(), s, Point2::ZERO, 0.0);
            assert!((c.g as f64 - (1.0 + cos4) / 2.0).abs() < 1e-6);
        }
    }

    #[test]
    fn optical_vignetting_darkens_toward_the_corners_and_clips_the_aperture() {
        let format = Format::new(64, 48);
        let optical = 0.8f64;
        let p = make(
            &[
                ("float fov", "90"),
                ("float optical", "0.8"),
                ("float fStop", "2"),
                ("float focalLength", "0.2"),
                ("float focalDistance", "5"),
            ],
            format,
        );
        let radius = 0.05f64;
        let mut last = f64::INFINITY;
        for i in 0..=40 {
            let f = i as f32 / 40.0;
            let s = Point2::new(f * 4.0 / 3.0, f);
            let (r, _, c) = one(p.as_ref(), s, Point2::new(0.2, -0.3), 0.0);
            // Independent area fraction of two unit disks at distance δ = optical·tanθ (d = 1).
            let dist = optical * ((s.x as f64).powi(2) + (s.y as f64).powi(2)).sqrt();
            let expected = if dist >= 2.0 {
                0.0
            } else {
                (2.0 * (dist / 2.0).acos() - dist / 2.0 * (4.0 - dist * dist).sqrt()) / std::f64::consts::PI
            };
            assert!(
                (c.r as f64 - expected).abs() < 1e-5,
                "at {s:?}: {} vs {expected}",
                c.r
            );
            assert!(
                c.r as f64 <= last && (i == 0 || (c.r as f64) < last),
                "not darker toward the corner at {s:?}"
            );
            last = c.r as f64;
            // The lens point lies inside the aperture and inside the clipping disk.
            let o = [r.origin.x as f64 / radius, r.origin.y as f64 / radius];
            let b = [-optical * s.x as f64, -optical * s.y as f64];
            assert!(o[0].hypot(o[1]) <= 1.0 + 1e-4, "outside the aperture at {s:?}");
            assert!(
                (o[0] - b[0]).hypot(o[1] - b[1]) <= 1.0 + 1e-4,
                "outside the clipping disk at {s:?}"
            );
        }
        // The bokeh is clipped, not the focus: every lens ray still meets the chief ray's focus point.
        let s = Point2::new(0.9, 0.6);
        let (chief, _, _) = one(
            make(&[("float fov", "90")], format).as_ref(),
            s,
            Point2::ZERO,
            0.0,
        );
        let w = f64v(chief.direction);
        let focus = w.map(|c| c * 5.0 / w[2]);
        for a in [
            Point2::new(0.9, 0.0),
            Point2::new(-0.5, 0.5),
            Point2::new(0.0, -1.0),
        ] {
            let (r, _, _) = one(p.as_ref(), s, a, 0.0);
            assert!(dist3(meet(&r, [0.0, 0.0, 1.0], 5.0), focus) < 1e-4);
        }
    }

    #[test]
    fn rolling_shutter_rewrites_time_by_screen_position() {
        let format = Format::new(40, 20);
        let window = obscura_sdk::ScreenWindow::default_for(format);
        for (sweep, pos) in [
            ("down", (|s: Point2| (1.0 - s.y) / 2.0) as fn(Point2) -> f32),
            ("up", |s: Point2| (s.y + 1.0) / 2.0),
            ("left", |s: Point2| (2.0 - s.x) / 4.0),
            ("right", |s: Point2| (s.x + 2.0) / 4.0),
        ] {
            let p = make(&[("string sweep", sweep), ("float duration", "0.25")], format);
            assert_eq!((window.left, window.right), (-2.0, 2.0));
            for i in 0..50 {
                let s = Point2::new((i as f32 * 0.37).sin() * 2.0, (i as f32 * 0.53).cos());
                let t = (i as f32 * 0.618).fract();
                let (r, t2, _) = one(p.as_ref(), s, Point2::ZERO, t);
                let expected = pos(s) * 0.75 + t * 0.25;
                assert!(
                    (t2 - expected).abs() < 1e-6,
                    "{sweep} at {s:?}: {t2} vs {expected}"
                );
                assert!(!r.is_culled());
            }
        }
        // An ideal rolling shutter at the last line still keeps time below 1.
        let p = make(&[("float duration", "0")], format);
        let (_, t, _) = one(p.as_ref(), Point2::new(0.0, -1.5), Point2::ZERO, 0.999);
        assert!(t < 1.0 && t > 0.999_99);
        // Global shutter: time untouched.
        let p = make(&[], format);
        assert_eq!(one(p.as_ref(), Point2::new(0.3, 0.9), Point2::ZERO, 0.4).1, 0.4);
    }

    #[test]
    fn enhance_zooms_into_the_unenhanced_image() {
        let format = Format::new(64, 48);
        let base = [
            ("float fov", "70"),
            ("float radial1", "-0.08"),
            ("float shiftX", "0.1"),
        ];
        let mut zoomed = base.to_vec();
        zoomed.push(("float[3] enhance", "0.3 -0.2 4"));
        let (a, b) = (make(&zoomed, format), make(&base, format));
        for i in 0..100 {
            let s = Point2::new((i as f32 * 0.41).sin() * 1.3, (i as f32 * 0.23).cos());
            let (ra, _, _) = one(a.as_ref(), s, Point2::ZERO, 0.0);
            let (rb, _, _) = one(
                b.as_ref(),
                Point2::new(0.3 + s.x / 4.0, -0.2 + s.y / 4.0),
                Point2::ZERO,
                0.0,
            );
            assert!((ra.direction - rb.direction).length() < 1e-6);
            // The footprint is the true one: a pixel covers a quarter of the angle.
            assert!((ra.ray_spread / rb.ray_spread - 0.25).abs() < 1e-5);
        }
        // Dicing is that of the un-enhanced camera.
        assert_eq!(
            a.property(ProjectionProperty::FieldOfView),
            b.property(ProjectionProperty::FieldOfView)
        );
    }

    #[test]
    fn field_of_view_is_the_angle_the_rays_span() {
        let format = Format::new(64, 48);
        let fov =
            |params: &[(&str, &str)]| match make(params, format).property(ProjectionProperty::FieldOfView) {
                Some(PropertyValue::Float(f)) => f64::from(f),
                other => panic!("{other:?}"),
            };
        let half = (35f64).to_radians().tan();
        // Radial distortion: the square's edge (radius 1) is imaged from ideal radius 1/(1 + k1 + k2).
        for (k1, k2) in [(-0.2, 0.0), (0.15, 0.0), (0.05, -0.02)] {
            let want = 2.0 * (half / (1.0 + k1 + k2)).atan().to_degrees();
            let got = fov(&[
                ("float fov", "70"),
                ("float radial1", &k1.to_string()),
                ("float radial2", &k2.to_string()),
            ]);
            assert!((got - want).abs() < 1e-3, "k1 {k1} k2 {k2}: {got} vs {want}");
        }
        // Shift: the angle between the rays through (−1 + s, 0) and (1 + s, 0) on the plane at 1/half.
        let s = 0.4;
        let want = ((1.0 + s) * half).atan().to_degrees() - ((-1.0 + s) * half).atan().to_degrees();
        let got = fov(&[("float fov", "70"), ("float shiftX", "0.4")]);
        assert!((got - want).abs() < 1e-3, "{got} vs {want}");
        // The x axis alone is distorted: the undistorted y pair is the narrower.
        assert!((fov(&[("float fov", "70"), ("float assymX", "-0.3")]) - 70.0).abs() < 1e-3);
        // Green magnified by 1.1: the square sees 1/1.1 of the ideal plane.
        let want = 2.0 * (half / 1.1).atan().to_degrees();
        let got = fov(&[("float fov", "70"), ("color transverse", "1 1.1 1")]);
        assert!((got - want).abs() < 1e-3, "{got} vs {want}");
        // Without any of those, exactly fov (the narrower end of a zoom).
        assert_eq!(fov(&[("float fov", "70"), ("float fovEnd", "60")]), 60.0);
    }

    #[test]
    fn shift_moves_the_view_without_converging_verticals() {
        let format = Format::new(64, 48);
        let p = make(&[("float shiftY", "0.5")], format);
        let (r, _, _) = one(p.as_ref(), Point2::ZERO, Point2::ZERO, 0.0);
        assert!((r.direction.y / r.direction.z - 0.5).abs() < 1e-6);
        // A vertical screen line stays a vertical plane of directions: x/z constant along it.
        let ratios: Vec<f32> = (0..10)
            .map(|i| {
                let (r, _, _) = one(
                    p.as_ref(),
                    Point2::new(0.7, -1.0 + 0.2 * i as f32),
                    Point2::ZERO,
                    0.0,
                );
                r.direction.x / r.direction.z
            })
            .collect();
        assert!(ratios.iter().all(|x| (x - 0.7).abs() < 1e-6), "{ratios:?}");
    }

    #[test]
    fn nothing_is_nan_over_the_window_even_with_extreme_parameters() {
        let format = Format::new(48, 32);
        let window = obscura_sdk::ScreenWindow::default_for(format);
        let configs: &[&[(&str, &str)]] = &[
            &[("float fov", "179.99")],
            &[("float fov", "0.001"), ("float fovEnd", "179.9")],
            &[("float radial1", "100")],
            &[("float radial1", "-100"), ("float radial2", "-50")],
            &[
                ("float radial1", "-0.5"),
                ("float radial2", "0.01"),
                ("float assymX", "3"),
                ("float assymY", "-3"),
            ],
            &[("float radial1", "0.2"), ("float squeeze", "0.001")],
            &[("float radial1", "0.2"), ("float squeeze", "1000")],
            &[("float[3] enhance", "1e6 -1e6 1e-6")],
            &[("float[3] enhance", "0 0 1e30"), ("float radial1", "0.1")],
            &[("float shiftX", "1e30"), ("float shiftY", "-1e30")],
            &[
                ("color transverse", "1e-6 1 1e6"),
                ("color axial", "1e9 0 -0.999"),
                ("float fStop", "1"),
                ("float focalLength", "1"),
            ],
            &[
                ("float fStop", "1e-6"),
                ("float focalLength", "1e6"),
                ("float focalDistance", "1e-6"),
                ("float tilt", "89"),
                ("float roll", "1e6"),
            ],
            &[
                ("float fStop", "0.5"),
                ("float focalLength", "1"),
                ("float focalDistance", "1e30"),
                ("float tilt", "-89"),
                ("float optical", "1e9"),
                ("float natural", "1"),
            ],
            &[
                ("float optical", "1e30"),
                ("float natural", "1"),
                ("float fov", "179"),
            ],
            &[
                ("float duration", "0"),
                ("string sweep", "left"),
                ("float fovEnd", "1"),
            ],
            &[
                ("point focus1", "0 0 0.01"),
                ("point focus2", "1 0 0.01"),
                ("point focus3", "0 1 50"),
                ("float fStop", "1"),
                ("float focalLength", "10"),
            ],
        ];
        let mut screen = Vec::new();
        for j in -2..=34 {
            for i in -2..=50 {
                screen.push(window.raster_to_screen(format, i as f64, j as f64));
            }
        }
        screen.extend([
            Point2::new(1e30, -1e30),
            Point2::new(-3e38, 3e38),
            Point2::new(0.0, 1e-38),
        ]);
        let n = screen.len();
        let aperture: Vec<Point2> = (0..n)
            .map(|i| Point2::new((i as f32 * 0.7).sin(), (i as f32 * 0.3).cos()))
            .collect();
        let times: Vec<f32> = (0..n)
            .map(|i| (i as f32 * 0.618_034).fract().min(0.999_999))
            .collect();
        for params in configs {
            let p = try_make(params, format).unwrap_or_else(|e| panic!("{params:?}: {e}"));
            let (rays, ts, tints) = run(p.as_ref(), &screen, &aperture, &times);
            for ((r, t), c) in rays.iter().zip(&ts).zip(&tints) {
                let at = format!("{params:?}: {r:?} {c:?} {t}");
                assert!(
                    r.origin.is_finite() && r.direction.is_finite() && r.ray_spread.is_finite(),
                    "{at}"
                );
                assert!(
                    r.ray_spread >= 0.0
                        && r.min_dist >= 0.0
                        && r.min_dist.is_finite()
                        && r.min_dist <= r.max_dist,
                    "{at}"
                );
                assert!(r.is_culled() || (r.direction.length() - 1.0).abs() < 1e-5, "{at}");
                assert!(c.is_finite() && c.r >= 0.0 && c.g >= 0.0 && c.b >= 0.0, "{at}");
                assert!((0.0..1.0).contains(t), "{at}");
            }
            for s in &screen[..200] {
                if let Some(b) = p.unproject(Vec3::new(s.x, s.y, 1.0), 0.5) {
                    assert!(b.x.is_finite() && b.y.is_finite());
                }
            }
        }
    }

    #[test]
    fn the_contract_holds_for_several_configurations() {
        let format = Format::new(48, 32);
        let configs: &[&[(&str, &str)]] = &[
            &[],
            &[
                ("float fov", "40"),
                ("float radial1", "-0.12"),
                ("float radial2", "0.01"),
                ("float shiftX", "0.1"),
                ("float shiftY", "-0.05"),
                ("float squeeze", "1.2"),
                ("float assymX", "0.03"),
            ],
            &[
                ("float fov", "60"),
                ("float fovEnd", "45"),
                ("float radial1", "0.08"),
                ("float assymY", "-0.02"),
                ("float[3] enhance", "0.2 0.1 2"),
            ],
            &[
                ("float fStop", "2.8"),
                ("float focalLength", "0.05"),
                ("float focalDistance", "3"),
                ("float tilt", "20"),
                ("float roll", "30"),
                ("float natural", "1"),
                ("float radial1", "-0.05"),
            ],
            &[
                ("float optical", "0.7"),
                ("float natural", "0.5"),
                ("float duration", "0.3"),
                ("string sweep", "left"),
            ],
        ];
        for params in configs {
            let p = make(params, format);
            let stats = assert_contract(p.as_ref(), &ContractTest::new(format));
            assert!(
                stats.valid == stats.samples && stats.spread_checked > 1500 && stats.roundtrips > 1500,
                "{params:?}: {stats:?}"
            );
        }
        // A pincushion strong enough to fold inside the window culls the samples beyond the fold and keeps
        // the contract on the rest.
        let folded = make(&[("float radial1", "0.4")], format);
        let mut t = ContractTest::new(format);
        t.roundtrip_px = 1e-3;
        let stats = assert_contract(folded.as_ref(), &t);
        assert!(
            stats.valid < stats.samples && stats.valid > stats.samples / 2,
            "{stats:?}"
        );
    }

    #[test]
    fn properties_are_honest() {
        let format = Format::new(8, 8);
        let pin = make(&[("float fov", "50"), ("float fovEnd", "35")], format);
        assert_eq!(
            pin.property(ProjectionProperty::DicingHint),
            Some(PropertyValue::DicingHint(DicingHint::Perspective))
        );
        assert_eq!(
            pin.property(ProjectionProperty::DeepMetric),
            Some(PropertyValue::DeepMetric(DeepMetric::CameraZ))
        );
        assert_eq!(
            pin.property(ProjectionProperty::FieldOfView),
            Some(PropertyValue::Float(35.0))
        );
        // RenderMan's default fStop 16 without a focal length is a pinhole.
        assert_eq!(pin.property(ProjectionProperty::FStop), None);
        let lens = make(
            &[
                ("float focalLength", "0.05"),
                ("float focalDistance", "3"),
                ("float dofMult", "2"),
            ],
            format,
        );
        assert_eq!(
            lens.property(ProjectionProperty::FStop),
            Some(PropertyValue::Float(8.0))
        );
        assert_eq!(
            lens.property(ProjectionProperty::FocalLength),
            Some(PropertyValue::Float(0.05))
        );
        assert_eq!(
            lens.property(ProjectionProperty::FocalDistance),
            Some(PropertyValue::Float(3.0))
        );
        // dofMult multiplies the lens radius: R = 2·0.05/(2·16).
        let (r, _, _) = one(lens.as_ref(), Point2::ZERO, Point2::new(1.0, 0.0), 0.0);
        assert!((r.origin.x - 2.0 * 0.05 / 32.0).abs() < 1e-9);
        let off = make(&[("float focalLength", "0.05"), ("float dofMult", "0")], format);
        assert_eq!(off.property(ProjectionProperty::FStop), None);
        let mut env = ProjectionEnvironment::for_format(format);
        env.set_deep_metric(DeepMetric::RayLength);
        PxrCameraFactory
            .create_projection(&mut env, &ParamList::new())
            .unwrap();
        assert_eq!(env.deep_metric(), DeepMetric::CameraZ);
    }

    #[test]
    fn bad_parameters_name_the_plugin_and_parameter() {
        let cases = [
            (
                "float[3] enhance",
                "0 0 0",
                "\"enhance\" = (0, 0, 0): the third value is the zoom factor",
            ),
            ("float[3] enhance", "0 0 -2", "must be positive"),
            ("color axial", "0 -2 0", "green plane of focus to -1"),
            ("float tilt", "95", "\"tilt\""),
            ("string sweep", "sideways", "\"sweep\""),
            ("float squeeze", "0", "\"squeeze\""),
            ("float radial1", "inf", "\"radial1\""),
            ("float radail1", "0.1", "did you mean \"radial1\""),
        ];
        assert_refused(&PxrCameraFactory, "PxrCamera", Format::new(8, 8), &cases);
    }
}
