//! `TinyPlanet`: a stereographic "tiny planet" projection, shipped as a plugin.
//!
//! This crate is the example of a third-party projection written in Rust: it implements the SDK's
//! traits exactly as the built-ins do and ends with `obscura_sdk::export_projection!(TinyPlanetFactory);`,
//! which makes the `cdylib` a plugin. Rename `libobscura_example_tiny_planet.so` to `TinyPlanet.so`,
//! put it on `OBSCURA_PLUGIN_PATH` (or pass `--plugin-path`), and `obscura render -p TinyPlanet` uses it.
//!
//! # Mapping
//!
//! A screen sample `s = (sx, sy)` at radius `r = |s|` and azimuth `ψ = atan2(sy, sx)` looks at the angle
//!
//! ```text
//! θ = 2·atan(r·k),   k = tan(fov/4)
//! ```
//!
//! from the axis `c` of the frame `(c, u, v)`:
//!
//! ```text
//! D = cos θ · c + sin θ · (cos ψ · u + sin ψ · v)
//! ```
//!
//! so the unit circle of screen space spans `fov`, and the whole sphere but the antipode of `c` is on
//! the (infinite) screen plane: nothing is culled. `axis "down"` (the tiny planet) has `c = −Y`,
//! `u = +X`, `v = +Z`: the ground is in the centre, the horizon a circle, and screen up is camera
//! forward, unmirrored. `axis "forward"` has `c = +Z`, `u = +X`, `v = +Y`: a plain stereographic
//! fisheye.
//!
//! # Footprint
//!
//! The stereographic projection is conformal: a screen step of length `ds` turns the direction by
//! `A·ds` in every direction, `A = dθ/dr = 2k/(1 + r²k²)`. For a pixel of `Δx × Δy` screen units the
//! per-pixel turns are `αx = A·Δx`, `αy = A·Δy`, and `ray_spread = ½·sqrt(αx·αy) = ½·A·sqrt(Δx·Δy)`.
//! `origin = 0`, `origin_radius = 0`; clipping is spherical (`min_dist = near`, `max_dist = far`), since
//! rays go in every direction.
//!
//! # Inverse
//!
//! A camera-space point `P ≠ 0` with unit direction `d` is seen at `θ = acos(d·c)`,
//! `r = tan(θ/2)/k`, `s = r·(d·u, d·v)/|(d·u, d·v)|` (`s = 0` on the axis); the antipode of `c`
//! (θ within 10⁻⁶ of 180°) has no finite screen point and gives `None`.
//!
//! # Properties
//!
//! DicingHint Spherical; DeepMetric RayLength; FieldOfView the angle across the screen window's
//! shorter side through the centre, `2·θ(min(r − l, t − b)/2)` (exactly `fov` with the default window).

#![forbid(unsafe_code)]

use std::sync::LazyLock;

use obscura_sdk::{
    DeepMetric, DicingHint, ParamDecl, ParamList, Params, PluginError, Point2, Projection, ProjectionContext,
    ProjectionEnvironment, ProjectionFactory, ProjectionProperty, PropertyValue, RayGeometry, ValueRange,
    Vec3,
};

/// The name scenes use.
pub const NAME: &str = "TinyPlanet";

static TABLE: LazyLock<Vec<ParamDecl>> = LazyLock::new(|| {
    vec![
        ParamDecl::float("fov", 240.0)
            .range(ValueRange::open(0.0, 360.0))
            .doc("angle in degrees across the unit circle of screen space (the smaller image side)"),
        ParamDecl::string("axis", "down")
            .choices(&["down", "forward"])
            .doc("the direction at the image centre: down (-Y, a tiny planet) or forward (+Z)"),
    ]
});

/// Creates [`TinyPlanet`] projections.
#[derive(Debug, Default, Clone, Copy)]
pub struct TinyPlanetFactory;

impl ProjectionFactory for TinyPlanetFactory {
    fn name(&self) -> &str {
        NAME
    }

    fn summary(&self) -> &str {
        "stereographic tiny planet: theta = 2 atan(r tan(fov/4)) from straight down (plugin example)"
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
        let fov = p.float("fov")?;
        let frame = match p.string("axis")? {
            "forward" => Frame {
                c: Vec3::Z,
                u: Vec3::new(1.0, 0.0, 0.0),
                v: Vec3::new(0.0, 1.0, 0.0),
            },
            _ => Frame {
                c: Vec3::new(0.0, -1.0, 0.0),
                u: Vec3::new(1.0, 0.0, 0.0),
                v: Vec3::Z,
            },
        };
        let (px, py) = env.pixel_size();
        let w = env.screen_window();
        let k = (fov.to_radians() / 4.0).tan();
        let shorter = w.width().abs().min(w.height().abs());
        env.set_deep_metric(DeepMetric::RayLength);
        Ok(Box::new(TinyPlanet {
            k,
            frame,
            sqrt_pixel: (px.abs() * py.abs()).sqrt(),
            near: env.clipping_near(),
            far: env.clipping_far(),
            field_of_view: 2.0 * (2.0 * (0.5 * shorter * k).atan()).to_degrees(),
        }))
    }
}

/// The orthonormal frame of the mapping: axis `c`, screen x along `u`, screen y along `v`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Frame {
    c: Vec3,
    u: Vec3,
    v: Vec3,
}

/// One camera's stereographic projection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TinyPlanet {
    k: f32,
    frame: Frame,
    sqrt_pixel: f32,
    near: f32,
    far: f32,
    field_of_view: f32,
}

impl TinyPlanet {
    /// The ray through screen point `s`.
    #[must_use]
    pub fn ray(&self, s: Point2) -> RayGeometry {
        let r2 = s.x * s.x + s.y * s.y;
        let r = r2.sqrt();
        let rk = r * self.k;
        // cos θ and sin θ of θ = 2·atan(rk), without trigonometry.
        let cos_t = (1.0 - rk * rk) / (1.0 + rk * rk);
        let sin_t = 2.0 * rk / (1.0 + rk * rk);
        let (cos_p, sin_p) = if r > 0.0 { (s.x / r, s.y / r) } else { (1.0, 0.0) };
        let f = self.frame;
        let d = f.c * cos_t + (f.u * cos_p + f.v * sin_p) * sin_t;
        let a = 2.0 * self.k / (1.0 + rk * rk);
        RayGeometry {
            origin: Vec3::ZERO,
            origin_radius: 0.0,
            direction: d.normalize_or_zero(),
            ray_spread: 0.5 * a * self.sqrt_pixel,
            min_dist: self.near,
            max_dist: self.far,
        }
    }
}

impl Projection for TinyPlanet {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        match property {
            ProjectionProperty::DicingHint => Some(PropertyValue::DicingHint(DicingHint::Spherical)),
            ProjectionProperty::DeepMetric => Some(PropertyValue::DeepMetric(DeepMetric::RayLength)),
            ProjectionProperty::FieldOfView => Some(PropertyValue::Float(self.field_of_view)),
            _ => None,
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        for (ray, s) in c.rays.iter_mut().zip(c.screen) {
            *ray = self.ray(*s);
        }
    }

    fn unproject(&self, point: Vec3, _time: f32) -> Option<Point2> {
        let d = point.normalize_or_zero();
        if d == Vec3::ZERO {
            return None;
        }
        let f = self.frame;
        let theta = d.dot(f.c).clamp(-1.0, 1.0).acos();
        if theta >= std::f32::consts::PI - 1e-6 {
            return None;
        }
        let r = (0.5 * theta).tan() / self.k;
        let (du, dv) = (d.dot(f.u), d.dot(f.v));
        let rho = (du * du + dv * dv).sqrt();
        if rho == 0.0 {
            return Some(Point2::ZERO);
        }
        Some(Point2::new(r * du / rho, r * dv / rho))
    }
}

obscura_sdk::export_projection!(TinyPlanetFactory);

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::{Format, Rgb};
    use proptest::prelude::*;

    fn planet(fov: f32, axis: &str) -> Box<dyn Projection> {
        let mut env = ProjectionEnvironment::for_format(Format::new(160, 90));
        let mut list = ParamList::new();
        list.push_text("float fov", &[&fov.to_string()], None).unwrap();
        list.push_text("string axis", &[axis], None).unwrap();
        let p = TinyPlanetFactory.create_projection(&mut env, &list).unwrap();
        assert_eq!(env.deep_metric(), DeepMetric::RayLength);
        p
    }

    fn project_one(p: &dyn Projection, s: Point2) -> RayGeometry {
        let screen = [s];
        let mut time = [0.0];
        let mut rays = [RayGeometry::CULLED];
        let mut tint = [Rgb::WHITE];
        let mut ctx =
            ProjectionContext::new(&screen, &screen, &screen, &mut time, &mut rays, &mut tint).unwrap();
        p.project(&mut ctx);
        rays[0]
    }

    /// The mapping written with trigonometry, independently of `ray`'s half-angle identities.
    fn reference(fov: f32, down: bool, s: Point2) -> Vec3 {
        let (sx, sy) = (f64::from(s.x), f64::from(s.y));
        let r = sx.hypot(sy);
        let theta = 2.0 * (r * (f64::from(fov).to_radians() / 4.0).tan()).atan();
        let psi = sy.atan2(sx);
        let (a, b, c) = (theta.sin() * psi.cos(), theta.sin() * psi.sin(), theta.cos());
        let (x, y, z) = if down { (a, -c, b) } else { (a, b, c) };
        Vec3::new(x as f32, y as f32, z as f32)
    }

    #[test]
    fn the_centre_looks_down_and_the_unit_circle_spans_the_fov() {
        let p = planet(240.0, "down");
        assert_eq!(
            project_one(p.as_ref(), Point2::ZERO).direction,
            Vec3::new(0.0, -1.0, 0.0)
        );
        // At r = 1 the angle from straight down is fov/2 = 120°: 30° above the horizon.
        let d = project_one(p.as_ref(), Point2::new(0.0, 1.0)).direction;
        assert!(
            (d.y - 0.5).abs() < 1e-6 && (d.z - 0.75f32.sqrt()).abs() < 1e-6,
            "{d:?}"
        );
        let Some(PropertyValue::Float(fov)) = p.property(ProjectionProperty::FieldOfView) else {
            panic!("no field of view");
        };
        assert!((fov - 240.0).abs() < 1e-3, "{fov}");
    }

    proptest! {
        #[test]
        fn rays_match_the_trigonometric_formula_and_invert(
            sx in -3.0f32..3.0, sy in -3.0f32..3.0, fov in 10.0f32..350.0, down in any::<bool>()
        ) {
            let p = planet(fov, if down { "down" } else { "forward" });
            let s = Point2::new(sx, sy);
            let ray = project_one(p.as_ref(), s);
            let want = reference(fov, down, s);
            prop_assert!((ray.direction - want).length() < 2e-5, "{:?} vs {:?}", ray.direction, want);
            prop_assert!((ray.direction.length() - 1.0).abs() < 1e-5);
            prop_assert!(ray.ray_spread > 0.0 && ray.ray_spread.is_finite());
            let back = p.unproject(ray.direction * 7.0, 0.0).unwrap();
            let tol = 1e-3 * (1.0 + sx.hypot(sy)).powi(2);
            prop_assert!((back.x - sx).abs() < tol && (back.y - sy).abs() < tol, "{back:?} vs {s:?}");
        }
    }

    #[test]
    fn ray_spread_is_half_the_angle_between_neighbouring_pixels() {
        let p = planet(240.0, "down");
        let px = 2.0 / 90.0; // 160×90: the screen window is 2 units tall
        for s in [
            Point2::new(0.0, 0.0),
            Point2::new(0.7, -0.4),
            Point2::new(1.5, 0.9),
        ] {
            let r0 = project_one(p.as_ref(), s);
            let rx = project_one(p.as_ref(), Point2::new(s.x + px, s.y));
            let ry = project_one(p.as_ref(), Point2::new(s.x, s.y + px));
            let ax = r0.direction.dot(rx.direction).clamp(-1.0, 1.0).acos();
            let ay = r0.direction.dot(ry.direction).clamp(-1.0, 1.0).acos();
            let measured = 0.5 * (ax * ay).sqrt();
            assert!(
                (r0.ray_spread / measured - 1.0).abs() < 0.02,
                "{s:?}: {} vs {measured}",
                r0.ray_spread
            );
        }
    }

    #[test]
    fn the_antipode_has_no_screen_point_and_bad_parameters_are_named() {
        let p = planet(240.0, "down");
        assert_eq!(p.unproject(Vec3::new(0.0, 1.0, 0.0), 0.0), None);
        assert_eq!(p.unproject(Vec3::ZERO, 0.0), None);
        let mut env = ProjectionEnvironment::for_format(Format::new(4, 4));
        let mut list = ParamList::new();
        list.push_text("string axis", &["up"], None).unwrap();
        let e = TinyPlanetFactory
            .create_projection(&mut env, &list)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("TinyPlanet") && e.contains("axis"), "{e}");
    }
}
