//! The tracer eight rays at a time, for `project`: spheres and planes in f32, lane by lane with the
//! same operations in every lane (so a ray does not depend on its place in the batch), written as
//! plain loops over fixed arrays that LLVM vectorises inside [`crate::simd::run`].
//!
//! The arithmetic is the closed form of [`super::surface::intersect_sphere`] and
//! [`super::surface::refract`]: relative to the vertex, `c·t² + 2b·t + cc = 0` with
//! `b = c·p₀·d + d_z`, `cc = c·|p₀|² + 2p₀_z`, root `t = −cc/(b + sign(b)·√(b² − c·cc))` (the other,
//! `−(b + sign(b)√…)/c`, where the first is off the vertex's cap), normal `c·p + ẑ` (unit on the
//! sphere), Snell with `η = n_film side / n_scene side`. Prescriptions with conics or aspheres take the
//! scalar f64 tracer instead.

use super::system::Lens;

/// Rays per lane group.
pub const LANES: usize = 8;

/// One surface's constants for the lanes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaneSurface {
    c: f32,
    zv: f32,
    semi2: f32,
}

/// The lens as the lanes see it: surfaces rear to front.
#[derive(Debug, Clone, PartialEq)]
pub struct LaneLens {
    surfaces: Vec<LaneSurface>,
}

impl LaneLens {
    /// The lane form of `lens`, or `None` when a surface is not a sphere or plane.
    #[must_use]
    pub fn new(lens: &Lens) -> Option<LaneLens> {
        if !lens.surfaces.iter().all(super::surface::Surface::is_spherical) {
            return None;
        }
        Some(LaneLens {
            surfaces: (0..lens.surfaces.len())
                .rev()
                .map(|i| {
                    let s = &lens.surfaces[i];
                    LaneSurface {
                        c: s.curvature() as f32,
                        zv: lens.z[i] as f32,
                        semi2: (s.semi_aperture * s.semi_aperture) as f32,
                    }
                })
                .collect(),
        })
    }

    /// `η = n_after/n_before` per surface, rear to front, from the indices of each surface's media.
    #[must_use]
    pub fn etas(before: &[f64], after: &[f64]) -> Vec<f32> {
        (0..before.len())
            .rev()
            .map(|i| (after[i] / before[i]) as f32)
            .collect()
    }
}

/// Eight rays: origins, directions (unit), and whether each still passes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Lanes {
    /// Origin x.
    pub ox: [f32; LANES],
    /// Origin y.
    pub oy: [f32; LANES],
    /// Origin z.
    pub oz: [f32; LANES],
    /// Direction x.
    pub dx: [f32; LANES],
    /// Direction y.
    pub dy: [f32; LANES],
    /// Direction z.
    pub dz: [f32; LANES],
    /// 1 while the ray passes, 0 once blocked.
    pub alive: [f32; LANES],
}

/// Traces the lanes from the film through every surface; `eta[l]` holds lane `l`'s `η` per surface
/// (rear to front).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // one index over several lane arrays: the vectorised form
pub fn trace(lens: &LaneLens, lanes: &mut Lanes, eta: &[&[f32]; LANES]) {
    for (k, s) in lens.surfaces.iter().enumerate() {
        let mut e = [0.0f32; LANES];
        for l in 0..LANES {
            e[l] = eta[l][k];
        }
        let (c, zv, semi2) = (s.c, s.zv, s.semi2);
        for l in 0..LANES {
            let (px, py, pz) = (lanes.ox[l], lanes.oy[l], lanes.oz[l] - zv);
            let (dx, dy, dz) = (lanes.dx[l], lanes.dy[l], lanes.dz[l]);
            let b = c * (px * dx + py * dy + pz * dz) + dz;
            let cc = c * (px * px + py * py + pz * pz) + 2.0 * pz;
            let disc = b * b - c * cc;
            let den = b + disc.max(0.0).sqrt().copysign(b);
            let t1 = -cc / den;
            let t2 = -den / c;
            let on_cap1 = 1.0 + c * (pz + t1 * dz) > 0.0;
            let t = if on_cap1 { t1 } else { t2 };
            let hx = px + t * dx;
            let hy = py + t * dy;
            let hz = pz + t * dz;
            let pass = disc >= 0.0 && t > 0.0 && hx * hx + hy * hy <= semi2 && 1.0 + c * hz > 0.0;
            // Snell with the normal c·p + ẑ turned against the ray.
            let (mut nx, mut ny, mut nz) = (c * hx, c * hy, 1.0 + c * hz);
            let mut cos_i = -(dx * nx + dy * ny + dz * nz);
            let flip = cos_i < 0.0;
            if flip {
                nx = -nx;
                ny = -ny;
                nz = -nz;
                cos_i = -cos_i;
            }
            let eta = e[l];
            let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
            let f = eta * cos_i - k.max(0.0).sqrt();
            let ok = pass && k >= 0.0;
            lanes.alive[l] = if ok { lanes.alive[l] } else { 0.0 };
            lanes.ox[l] = hx;
            lanes.oy[l] = hy;
            lanes.oz[l] = hz + zv;
            lanes.dx[l] = eta * dx + f * nx;
            lanes.dy[l] = eta * dy + f * ny;
            lanes.dz[l] = eta * dz + f * nz;
        }
    }
    // Lanes that died hold garbage; keep them finite.
    for l in 0..LANES {
        if lanes.alive[l] == 0.0
            || !(lanes.dx[l].is_finite() && lanes.dy[l].is_finite() && lanes.dz[l].is_finite())
        {
            lanes.alive[l] = 0.0;
        }
    }
}
