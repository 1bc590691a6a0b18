//! `PxrCamera`: RenderMan's full-featured perspective camera — zoom, thin lens with a tilted
//! (Scheimpflug) plane of focus, split diopter, lens shift, distortion, chromatic aberration,
//! natural and optical vignetting, rolling shutter and enhance.
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
//!    **Split diopter** (`split_diopter.rs`, with `splitDiopter:count` 1 or 2): the plane moves
//!    along the axis to the focus distance `z(ξ)` of the sample's position `ξ` across the diopters'
//!    edges, `δ_c = δ + (z(ξ) − z₀ + axial[c])·n.z`, `z₀ = δ/n.z` the lens's own axial focus distance:
//!    `ξ = ((sₑ − c)·(cos angle, −sin angle))/h` (`c` the screen window's centre, `h` half its width,
//!    `angle` clockwise from up), `S(x) = 3x² − 2x³` of
//!    `x = clamp(½ + (ξ − offset1)/width1)` for diopter 1 (covering `ξ > offset1`) and
//!    `x = clamp(½ − (ξ − offset2)/width2)` for diopter 2 (covering `ξ < offset2`), a hard step at
//!    width 0, and `z(ξ) = lerp(lerp(z₀, focusDistance1, S₁), focusDistance2, S₂)`. Every ray of the
//!    sample then meets at `F = w·δ_c/(n·w)` as above.
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
//! - The split-diopter parameters carry USD/Hydra's names (`HdCameraTokens`: `splitDiopter:count`,
//!   `splitDiopter:angle`, `splitDiopter:offset1`, `splitDiopter:width1`,
//!   `splitDiopter:focusDistance1`, `…2`); RenderMan 27's own RIB names for PxrCamera are not in
//!   public material. Which side each diopter covers, that `width` is the full width of the blend
//!   band centred on the edge, the smoothstep, the order of the nested lerps and the normalisation
//!   by half the screen window's width are ours. `focusDistance1/2` default to 1 (Hydra's 0 would be
//!   refused: a focus distance must be positive). Without depth of field the diopters change nothing.

mod distortion;
mod focal_plane;
mod split_diopter;
mod vignetting;

use std::sync::LazyLock;

use obscura_sdk::optics::screen_distance;
use obscura_sdk::{
    ContextParts, DeepMetric, DicingHint, ParamDecl, ParamType, ParamValue, Params, PluginError, Point2,
    Projection, ProjectionContext, ProjectionEnvironment, ProjectionProperty, PropertyValue, RayGeometry,
    Rgb, ValueRange, Vec3,
};

use crate::dof::{self, DepthOfField};
use crate::panorama::angle_between;
use crate::perspective::Zoom;
use crate::rolling_shutter::RollingShutter;
use crate::{screen, simd};
use distortion::Distortion;
use focal_plane::{FocalPlane, MAX_TILT_DEGREES};
use split_diopter::SplitDiopter;

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

/// A float parameter that takes any finite value, 0 by default (off).
fn finite(name: &'static str, doc: &'static str) -> ParamDecl {
    ParamDecl::float(name, 0.0).range(FINITE).doc(doc)
}

/// A camera-space point on the plane of focus, any finite position.
fn focus_point(name: &'static str, doc: &'static str) -> ParamDecl {
    ParamDecl::triple(name, ParamType::Point, Vec3::ZERO)
        .range(FINITE)
        .doc(doc)
}

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    let [mut f_stop, focal_length, focal_distance] = dof::params();
    f_stop.default = ParamValue::Floats(vec![16.0]);
    f_stop.doc = "aperture f-number (RenderMan's PxrCamera default 16); depth of field needs focalLength > 0 too; inf or 0 = pinhole".into();
    let [fov, fov_end] = crate::perspective::zoom_params();
    let mut table = vec![
        fov,
        fov_end,
        f_stop,
        focal_length,
        focal_distance,
        ParamDecl::float("dofMult", 1.0)
            .range(NON_NEGATIVE)
            .doc("multiplies the lens radius: 0 = no depth of field, 2 = twice the blur"),
        ParamDecl::float("tilt", 0.0)
            .range(ValueRange::closed(-MAX_TILT_DEGREES, MAX_TILT_DEGREES))
            .doc("degrees between the plane of focus and the image plane; + brings the top of the plane closer (needs depth of field)"),
        finite("roll", "degrees the tilted plane of focus turns clockwise about the view axis"),
        focus_point(
            "focus1",
            "first of three camera-space points on the plane of focus; all three replace tilt, roll and focalDistance",
        ),
        focus_point("focus2", "second point on the plane of focus (with focus1, focus3)"),
        focus_point("focus3", "third point on the plane of focus (with focus1, focus2)"),
        finite("shiftX", "lens shift to the right in screen units (half the smaller image side = 1)"),
        finite("shiftY", "lens shift up in screen units; corrects keystoning without tilting the camera"),
        finite("radial1", "quadratic radial distortion: > 0 pincushion, < 0 barrel"),
        finite("radial2", "quartic radial distortion"),
        finite("assymX", "radial distortion of x only: horizontal lines stay straight"),
        finite("assymY", "radial distortion of y only: vertical lines stay straight"),
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
    table.extend(split_diopter::params());
    table
});

/// Creates [`PxrCamera`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct PxrCameraFactory;

projection_factory!(
    PxrCameraFactory,
    "full-featured perspective: zoom, thin lens with tilted focal plane, shift, distortion, \
     chromatic aberration, vignetting, rolling shutter, enhance",
    |env, p| {
        let camera = PxrCamera::from_params(env, p)?;
        env.set_deep_metric(DeepMetric::CameraZ);
        Ok(Box::new(camera))
    }
);

/// RenderMan's `PxrCamera` (see the module documentation for its mapping).
#[derive(Debug, Clone, PartialEq)]
pub struct PxrCamera {
    half_pixel: f32,
    near: f32,
    far: f32,
    zoom: Zoom,
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
    /// `z₀`: the axial distance of the plane of focus (before `axial`).
    axis: f32,
    split: Option<SplitDiopter>,
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
        let invalid = |message: String| crate::invalid(NAME, message);
        let (fov, fov_end) = (p.float("fov")?, p.float("fovEnd")?);
        crate::perspective::check_fov_end(NAME, fov_end)?;
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

        let split = SplitDiopter::from_params(p, env.screen_window())?;
        if let Some(sd) = &split {
            for (i, z) in sd.focus_distances().enumerate() {
                for (c, name) in ["red", "green", "blue"].iter().enumerate() {
                    if z as f64 + axial[c] as f64 <= 0.0 {
                        return Err(invalid(format!(
                            "\"axial\" moves diopter {}'s {name} focus to {} ({} = {z}, + {}): \
                             expected every channel's focal distance to stay positive",
                            i + 1,
                            z as f64 + axial[c] as f64,
                            split_diopter::FOCUS[i],
                            axial[c]
                        )));
                    }
                }
            }
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
        let shutter = Some(RollingShutter::from_params(p, env.screen_window())?).filter(|r| !r.is_global());
        let (natural, optical) = (p.float("natural")?, p.float("optical")?);
        let zoom = Zoom::new(fov, fov_end);
        let mut camera = PxrCamera {
            half_pixel: screen::half_pixel(env),
            near: env.clipping_near(),
            far: env.clipping_far(),
            zoom,
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
            axis: axis as f32,
            split,
            lens_radius: if lens_radius > 0.0 && lens_radius.is_finite() {
                lens_radius
            } else {
                0.0
            },
            natural,
            optical,
            shutter,
            extra: shutter.is_some() || zoom.fov_end.is_some() || chromatic || natural > 0.0 || optical > 0.0,
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
        let narrower = self.zoom.narrowest();
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
        let extent = |fov: f32| -> f32 {
            let d = f64::from(screen_distance(fov));
            [([-1.0, 0.0], [1.0, 0.0]), ([0.0, -1.0], [0.0, 1.0])]
                .into_iter()
                .filter_map(|(a, b)| Some(angle_between(chief(a, d)?, chief(b, d)?).to_degrees()))
                .fold(None, |m: Option<f64>, e| Some(m.map_or(e, |m| m.min(e))))
                .map_or(fov, |e| e as f32)
        };
        let start = extent(self.zoom.fov);
        self.zoom.fov_end.map_or(start, |end| start.min(extent(end)))
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
        self.zoom.screen_distance_at(t)
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
            (t, self.zoom.d)
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
            let delta = match &self.split {
                Some(sd) => self.delta[c] + (sd.focus_distance(se, self.axis) - self.axis) * self.normal.z,
                None => self.delta[c],
            };
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
mod tests;
