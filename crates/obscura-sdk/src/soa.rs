//! Rays in structure-of-arrays form, for consumers that want each field as its own array.
//!
//! RenderMan's contract, and [`Projection::project`](crate::Projection::project), hand a projection an
//! array of [`RayGeometry`] records (40 bytes each, fields side by side). A consumer such as numpy, a
//! wavefront tracer or a GPU upload wants the opposite layout: all origins' `x`, then all `y`, … .
//! [`Projection::project_soa`](crate::Projection::project_soa) lets a projection write that layout
//! directly, with no per-ray record built and copied; the host falls back to `project` and a scatter
//! for any projection that does not offer it (plugins, modifiers, the models not vectorised).
//!
//! A consumer that reads only some fields names them ([`SoaFields`], [`SoaContext::with_fields`]):
//! `PxrPerspective`'s kernels then store those arrays only — a tracer that wants direction and
//! `max_dist` gets 16 bytes a ray written instead of 40. Projections that ignore the selection
//! write every field, which the contract allows.
//!
//! | field of [`RaysSoa`] | [`RayGeometry`] field |
//! |---|---|
//! | `origin[0..3]` | `origin.x`, `origin.y`, `origin.z` |
//! | `origin_radius` | `origin_radius` |
//! | `direction[0..3]` | `direction.x`, `direction.y`, `direction.z` |
//! | `ray_spread` | `ray_spread` |
//! | `min_dist`, `max_dist` | `min_dist`, `max_dist` |

use crate::geometry::{Point2, Vec3};
use crate::ray::RayGeometry;

/// The ten fields of a batch of [`RayGeometry`], each its own array: ray `i` is
/// `(origin[0][i], origin[1][i], origin[2][i], origin_radius[i], direction[0][i], …, max_dist[i])`.
///
/// Every array has the same length; [`RaysSoa::new`] checks it once.
#[derive(Debug)]
pub struct RaysSoa<'a> {
    /// Origin `x`, `y`, `z` in camera space.
    pub origin: [&'a mut [f32]; 3],
    /// Footprint radius at the origin.
    pub origin_radius: &'a mut [f32],
    /// Unit direction `x`, `y`, `z` in camera space, or all three zero to cull.
    pub direction: [&'a mut [f32]; 3],
    /// Footprint radius growth per unit distance.
    pub ray_spread: &'a mut [f32],
    /// Nearest accepted hit distance.
    pub min_dist: &'a mut [f32],
    /// Farthest accepted hit distance.
    pub max_dist: &'a mut [f32],
}

/// An array handed to [`RaysSoa::new`] or [`SoaContext::new`] had another length than the batch's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("structure-of-arrays batch: `{field}` has {len} elements, the batch has {expected}")]
pub struct SoaLengthError {
    /// The array at fault.
    pub field: &'static str,
    /// Its length.
    pub len: usize,
    /// The batch's length (the first array's).
    pub expected: usize,
}

fn check(expected: usize, arrays: &[(&'static str, usize)]) -> Result<(), SoaLengthError> {
    match arrays.iter().find(|(_, len)| *len != expected) {
        Some(&(field, len)) => Err(SoaLengthError { field, len, expected }),
        None => Ok(()),
    }
}

impl<'a> RaysSoa<'a> {
    /// The fields' names in record order (the order of [`RaysSoa::fields_mut`] and
    /// [`SoaFields::has`]), for messages.
    pub const FIELD_NAMES: [&'static str; 10] = [
        "origin.x",
        "origin.y",
        "origin.z",
        "origin_radius",
        "direction.x",
        "direction.y",
        "direction.z",
        "ray_spread",
        "min_dist",
        "max_dist",
    ];

    /// Bundles ten arrays of one length (the order of [`RayGeometry`]'s fields). Fails naming the
    /// first array whose length differs from `origin[0]`'s.
    pub fn new(
        origin: [&'a mut [f32]; 3],
        origin_radius: &'a mut [f32],
        direction: [&'a mut [f32]; 3],
        ray_spread: &'a mut [f32],
        min_dist: &'a mut [f32],
        max_dist: &'a mut [f32],
    ) -> Result<Self, SoaLengthError> {
        check(
            origin[0].len(),
            &[
                ("origin.y", origin[1].len()),
                ("origin.z", origin[2].len()),
                ("origin_radius", origin_radius.len()),
                ("direction.x", direction[0].len()),
                ("direction.y", direction[1].len()),
                ("direction.z", direction[2].len()),
                ("ray_spread", ray_spread.len()),
                ("min_dist", min_dist.len()),
                ("max_dist", max_dist.len()),
            ],
        )?;
        Ok(RaysSoa {
            origin,
            origin_radius,
            direction,
            ray_spread,
            min_dist,
            max_dist,
        })
    }

    /// Splits one buffer of `10·n` floats into the ten arrays of `n` rays, field after field in
    /// [`RayGeometry`]'s order. `None` when the length is not a multiple of ten.
    pub fn from_fields(buffer: &'a mut [f32]) -> Option<Self> {
        if !buffer.len().is_multiple_of(10) {
            return None;
        }
        let n = buffer.len() / 10;
        let mut it = buffer.chunks_exact_mut(n.max(1));
        let mut next = || -> &'a mut [f32] {
            if n == 0 {
                &mut []
            } else {
                it.next().expect("ten chunks of n")
            }
        };
        let origin = [next(), next(), next()];
        let origin_radius = next();
        let direction = [next(), next(), next()];
        let (ray_spread, min_dist, max_dist) = (next(), next(), next());
        Some(RaysSoa {
            origin,
            origin_radius,
            direction,
            ray_spread,
            min_dist,
            max_dist,
        })
    }

    /// The number of rays.
    #[must_use]
    pub fn len(&self) -> usize {
        self.origin[0].len()
    }

    /// True when the batch holds no ray.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Ray `i` as a record. Panics when `i` is out of range.
    #[must_use]
    pub fn get(&self, i: usize) -> RayGeometry {
        RayGeometry {
            origin: Vec3::new(self.origin[0][i], self.origin[1][i], self.origin[2][i]),
            origin_radius: self.origin_radius[i],
            direction: Vec3::new(self.direction[0][i], self.direction[1][i], self.direction[2][i]),
            ray_spread: self.ray_spread[i],
            min_dist: self.min_dist[i],
            max_dist: self.max_dist[i],
        }
    }

    /// Writes `ray` as ray `i`. Panics when `i` is out of range.
    #[inline]
    pub fn set(&mut self, i: usize, ray: &RayGeometry) {
        self.origin[0][i] = ray.origin.x;
        self.origin[1][i] = ray.origin.y;
        self.origin[2][i] = ray.origin.z;
        self.origin_radius[i] = ray.origin_radius;
        self.direction[0][i] = ray.direction.x;
        self.direction[1][i] = ray.direction.y;
        self.direction[2][i] = ray.direction.z;
        self.ray_spread[i] = ray.ray_spread;
        self.min_dist[i] = ray.min_dist;
        self.max_dist[i] = ray.max_dist;
    }

    /// The ten arrays in [`RayGeometry`]'s field order — `origin.x`, `origin.y`, `origin.z`,
    /// `origin_radius`, `direction.x`, `direction.y`, `direction.z`, `ray_spread`, `min_dist`,
    /// `max_dist` — for a kernel that stores field `k` of a block of rays from its own register.
    pub fn fields_mut(&mut self) -> [&mut [f32]; 10] {
        let [ox, oy, oz] = &mut self.origin;
        let [dx, dy, dz] = &mut self.direction;
        [
            &mut **ox,
            &mut **oy,
            &mut **oz,
            &mut *self.origin_radius,
            &mut **dx,
            &mut **dy,
            &mut **dz,
            &mut *self.ray_spread,
            &mut *self.min_dist,
            &mut *self.max_dist,
        ]
    }

    /// Writes `rays` as rays `start..start + rays.len()` (the fallback path's scatter of one
    /// array-of-structs batch). Panics when the range is out of bounds.
    pub fn scatter(&mut self, start: usize, rays: &[RayGeometry]) {
        for (i, ray) in (start..).zip(rays) {
            self.set(i, ray);
        }
    }

    /// The rays `range` of this batch, as a batch of its own (a chunk for one worker thread).
    pub fn slice(&mut self, range: core::ops::Range<usize>) -> RaysSoa<'_> {
        let r = range;
        let [ox, oy, oz] = &mut self.origin;
        let [dx, dy, dz] = &mut self.direction;
        RaysSoa {
            origin: [&mut ox[r.clone()], &mut oy[r.clone()], &mut oz[r.clone()]],
            origin_radius: &mut self.origin_radius[r.clone()],
            direction: [&mut dx[r.clone()], &mut dy[r.clone()], &mut dz[r.clone()]],
            ray_spread: &mut self.ray_spread[r.clone()],
            min_dist: &mut self.min_dist[r.clone()],
            max_dist: &mut self.max_dist[r],
        }
    }
}

/// A set of [`RayGeometry`]'s fields, by their index in record order (`origin.x` = 0 … `max_dist` =
/// 9): which arrays a consumer of [`Projection::project_soa`](crate::Projection::project_soa) asks
/// for ([`SoaContext::with_fields`]). Combine with `|`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SoaFields(u16);

impl SoaFields {
    /// Every field (what [`SoaContext::new`] asks for).
    pub const ALL: SoaFields = SoaFields(0x3FF);
    /// `origin.x`, `origin.y`, `origin.z`.
    pub const ORIGIN: SoaFields = SoaFields(0b111);
    /// `origin_radius`.
    pub const ORIGIN_RADIUS: SoaFields = SoaFields(1 << 3);
    /// `direction.x`, `direction.y`, `direction.z`.
    pub const DIRECTION: SoaFields = SoaFields(0b111 << 4);
    /// `ray_spread`.
    pub const RAY_SPREAD: SoaFields = SoaFields(1 << 7);
    /// `min_dist`.
    pub const MIN_DIST: SoaFields = SoaFields(1 << 8);
    /// `max_dist`.
    pub const MAX_DIST: SoaFields = SoaFields(1 << 9);

    /// True when field `k` (record order, as [`RaysSoa::fields_mut`]) is in the set; false for `k ≥ 10`.
    #[must_use]
    pub const fn has(self, k: usize) -> bool {
        k < 10 && self.0 & (1 << k) != 0
    }

    /// True when every field of `other` is in the set.
    #[must_use]
    pub const fn contains(self, other: SoaFields) -> bool {
        self.0 & other.0 == other.0
    }
}

impl core::ops::BitOr for SoaFields {
    type Output = SoaFields;
    fn bitor(self, other: SoaFields) -> SoaFields {
        SoaFields(self.0 | other.0)
    }
}

/// The inputs and outputs of one [`Projection::project_soa`](crate::Projection::project_soa) call:
/// the inputs of a [`ProjectionContext`](crate::ProjectionContext), the rays as [`RaysSoa`] and the
/// tint as three arrays.
///
/// Unlike [`ProjectionContext`](crate::ProjectionContext), the rays are **not** pre-filled with the
/// host's default rays: their contents on entry are unspecified, and a projection that takes this
/// path writes every field of every ray. `time` arrives as the host's shutter-warped times (in/out,
/// as in `project`) and `tint` pre-filled with white (in/out).
///
/// **Field selection.** A consumer that reads only some fields (a tracer that needs direction and
/// `max_dist`, say) may say so with [`SoaContext::with_fields`]. The selected arrays get every ray,
/// bit for bit as always; the others' contents afterwards are unspecified — a projection may skip
/// them (`PxrPerspective`'s AVX-512 and AVX2 kernels do, and skip computing an unwanted
/// `ray_spread`) or write them as if selected (every other projection, and the host's fallback).
/// The arrays must still have the batch's length: one never written costs address space only.
#[derive(Debug)]
pub struct SoaContext<'a> {
    /// Screen samples (in).
    pub screen: &'a [Point2],
    /// Canonical lens samples in `[0, 1)²` (in).
    pub lens: &'a [Point2],
    /// Aperture samples in `[−1, 1]²` (in).
    pub aperture: &'a [Point2],
    /// Shutter-normalised times (in/out).
    pub time: &'a mut [f32],
    /// The rays (out: every field of every ray).
    pub rays: RaysSoa<'a>,
    /// Per-ray tint `r`, `g`, `b` (in/out, pre-filled with 1).
    pub tint: [&'a mut [f32]; 3],
    /// The fields the consumer reads ([`SoaFields::ALL`] unless [`SoaContext::with_fields`] says).
    fields: SoaFields,
}

impl<'a> SoaContext<'a> {
    /// Bundles one batch. Fails unless every array has the batch's length (`screen`'s).
    pub fn new(
        screen: &'a [Point2],
        lens: &'a [Point2],
        aperture: &'a [Point2],
        time: &'a mut [f32],
        rays: RaysSoa<'a>,
        tint: [&'a mut [f32]; 3],
    ) -> Result<Self, SoaLengthError> {
        check(
            screen.len(),
            &[
                ("lens", lens.len()),
                ("aperture", aperture.len()),
                ("time", time.len()),
                ("rays", rays.len()),
                ("tint.r", tint[0].len()),
                ("tint.g", tint[1].len()),
                ("tint.b", tint[2].len()),
            ],
        )?;
        Ok(SoaContext {
            screen,
            lens,
            aperture,
            time,
            rays,
            tint,
            fields: SoaFields::ALL,
        })
    }

    /// The number of rays in this batch.
    #[must_use]
    pub fn num_rays(&self) -> usize {
        self.screen.len()
    }

    /// Asks for `fields` only: the other arrays' contents afterwards are unspecified (see the type's
    /// documentation). `fields` is [`SoaFields::ALL`] for a context from [`SoaContext::new`].
    #[must_use]
    pub fn with_fields(mut self, fields: SoaFields) -> Self {
        self.fields = fields;
        self
    }

    /// The fields the consumer reads: a projection must write these arrays and may skip the rest.
    #[must_use]
    pub fn fields(&self) -> SoaFields {
        self.fields
    }
}

/// A bit pattern no projection writes (a NaN with a payload): [`check_project_soa`]'s arrays start out
/// holding it, so a field `project_soa` leaves unwritten shows as a difference.
pub const SOA_UNWRITTEN: u32 = 0x7FA5_5A5A;

/// Runs `p`'s [`project`](crate::Projection::project) and
/// [`project_soa`](crate::Projection::project_soa) on the same samples (the lens samples are the
/// aperture samples mapped back to `[0, 1)²`, the tints start white) and compares them bit for bit:
/// every field of every ray, the output times and the tints. The arrays start as [`SOA_UNWRITTEN`] and are
/// cut from one buffer one float past its start, so no array is 16-byte aligned.
///
/// `Ok(true)`: the two agree; `Ok(false)`: `p` does not offer `project_soa`. A projection's tests
/// (and a plugin author's) call it at every SIMD tier ([`crate::simd::with_level`]).
///
/// # Errors
/// The first difference, naming the ray, the field and both values, or a length mismatch among the
/// inputs.
pub fn check_project_soa(
    p: &dyn crate::Projection,
    screen: &[Point2],
    aperture: &[Point2],
    time: &[f32],
) -> Result<bool, String> {
    let n = screen.len();
    if aperture.len() != n || time.len() != n {
        return Err(format!(
            "check_project_soa: {n} screen samples but {} aperture samples and {} times",
            aperture.len(),
            time.len()
        ));
    }
    let lens: Vec<Point2> = aperture
        .iter()
        .map(|a| Point2::new(0.5 * a.x + 0.5, 0.5 * a.y + 0.5))
        .collect();
    let (mut want_time, mut rays, mut tint) = (
        time.to_vec(),
        vec![RayGeometry::CULLED; n],
        vec![crate::Rgb::WHITE; n],
    );
    let mut ctx =
        crate::ProjectionContext::new(screen, &lens, aperture, &mut want_time, &mut rays, &mut tint)
            .map_err(|e| e.to_string())?;
    p.project(&mut ctx);
    let mut got_time = time.to_vec();
    let mut buffer = vec![f32::from_bits(SOA_UNWRITTEN); 10 * n + 1];
    let [mut r, mut g, mut b] = [(); 3].map(|()| vec![1.0f32; n]);
    let soa = RaysSoa::from_fields(&mut buffer[1..]).expect("ten arrays of n");
    let mut ctx = SoaContext::new(
        screen,
        &lens,
        aperture,
        &mut got_time,
        soa,
        [&mut r, &mut g, &mut b],
    )
    .map_err(|e| e.to_string())?;
    if !p.project_soa(&mut ctx) {
        return Ok(false);
    }
    let got: Vec<RayGeometry> = (0..n).map(|i| ctx.rays.get(i)).collect();
    for (i, (got, want)) in got.iter().zip(&rays).enumerate() {
        for (k, (g, w)) in got.to_bits().into_iter().zip(want.to_bits()).enumerate() {
            if g != w {
                return Err(format!(
                    "ray {i} of {n}: {} is {:?} (bits {g:#010x}) from project_soa, {:?} (bits {w:#010x}) from project",
                    RaysSoa::FIELD_NAMES[k],
                    f32::from_bits(g),
                    f32::from_bits(w)
                ));
            }
        }
        let tints = [(r[i], tint[i].r), (g[i], tint[i].g), (b[i], tint[i].b)];
        if tints.iter().any(|(x, y)| x.to_bits() != y.to_bits()) {
            return Err(format!(
                "ray {i} of {n}: tint ({}, {}, {}) from project_soa, {:?} from project",
                r[i], g[i], b[i], tint[i]
            ));
        }
        if got_time[i].to_bits() != want_time[i].to_bits() {
            return Err(format!(
                "ray {i} of {n}: time {} from project_soa, {} from project",
                got_time[i], want_time[i]
            ));
        }
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(i: usize) -> RayGeometry {
        let f = |k: usize| (i * 10 + k) as f32;
        RayGeometry {
            origin: Vec3::new(f(0), f(1), f(2)),
            origin_radius: f(3),
            direction: Vec3::new(f(4), f(5), f(6)),
            ray_spread: f(7),
            min_dist: f(8),
            max_dist: f(9),
        }
    }

    #[test]
    fn fields_land_in_their_own_arrays_in_record_order() {
        let n = 7;
        let mut buffer = vec![0.0f32; 10 * n];
        let rays: Vec<_> = (0..n).map(ray).collect();
        let mut soa = RaysSoa::from_fields(&mut buffer).unwrap();
        soa.scatter(0, &rays);
        for (i, r) in rays.iter().enumerate() {
            assert_eq!(soa.get(i).to_bits(), r.to_bits());
        }
        // Field k of ray i sits at k·n + i, and its value is 10·i + k.
        for (j, v) in buffer.iter().enumerate() {
            let (k, i) = (j / n, j % n);
            assert_eq!(*v, (10 * i + k) as f32, "field {k} of ray {i}");
        }
    }

    #[test]
    fn a_slice_writes_through_to_its_rays_only() {
        let mut buffer = vec![0.0f32; 10 * 6];
        let mut soa = RaysSoa::from_fields(&mut buffer).unwrap();
        soa.slice(2..4).scatter(0, &[ray(2), ray(3)]);
        assert_eq!(soa.get(3).to_bits(), ray(3).to_bits());
        assert_eq!(soa.get(1).to_bits(), [0; 10]);
        assert_eq!(soa.get(4).to_bits(), [0; 10]);
    }

    /// A pinhole of its own: `D = normalize(sx, sy, 1)`, `max_dist` 100; its `project_soa` forgets
    /// `min_dist` when `forget` is set.
    struct Tiny {
        offer: bool,
        forget: bool,
    }

    impl Tiny {
        fn ray(s: Point2) -> RayGeometry {
            RayGeometry {
                direction: Vec3::new(s.x, s.y, 1.0).normalize_or_zero(),
                min_dist: 0.5,
                max_dist: 100.0,
                ..RayGeometry::CULLED
            }
        }
    }

    impl crate::Projection for Tiny {
        fn property(&self, _: crate::ProjectionProperty) -> Option<crate::PropertyValue> {
            None
        }

        fn project(&self, ctx: &mut crate::ProjectionContext<'_>) {
            let c = ctx.parts_mut();
            for (r, s) in c.rays.iter_mut().zip(c.screen) {
                *r = Tiny::ray(*s);
            }
        }

        fn project_soa(&self, ctx: &mut SoaContext<'_>) -> bool {
            if !self.offer {
                return false;
            }
            for (i, s) in ctx.screen.iter().enumerate() {
                let mut r = Tiny::ray(*s);
                if self.forget {
                    r.min_dist = ctx.rays.min_dist[i];
                }
                ctx.rays.set(i, &r);
            }
            true
        }
    }

    #[test]
    fn check_project_soa_finds_a_field_left_unwritten() {
        let screen = [
            Point2::new(0.1, 0.2),
            Point2::new(-0.3, 0.4),
            Point2::new(0.0, 0.0),
        ];
        let (a, t) = ([Point2::ZERO; 3], [0.0f32; 3]);
        let check = |offer, forget| check_project_soa(&Tiny { offer, forget }, &screen, &a, &t);
        assert_eq!(check(true, false), Ok(true));
        assert_eq!(check(false, false), Ok(false));
        let err = check(true, true).unwrap_err();
        assert!(
            err.starts_with("ray 0 of 3: min_dist is NaN (bits 0x7fa55a5a)"),
            "{err}"
        );
        assert!(
            check_project_soa(
                &Tiny {
                    offer: true,
                    forget: false
                },
                &screen,
                &a,
                &t[..2]
            )
            .is_err()
        );
    }

    #[test]
    fn field_sets_name_record_positions() {
        let like_mitsuba = SoaFields::DIRECTION | SoaFields::MAX_DIST;
        let has: Vec<usize> = (0..12).filter(|&k| like_mitsuba.has(k)).collect();
        assert_eq!(has, [4, 5, 6, 9]);
        let every = SoaFields::ORIGIN
            | SoaFields::ORIGIN_RADIUS
            | SoaFields::DIRECTION
            | SoaFields::RAY_SPREAD
            | SoaFields::MIN_DIST
            | SoaFields::MAX_DIST;
        assert_eq!(every, SoaFields::ALL);
        assert!(SoaFields::ALL.contains(like_mitsuba) && !like_mitsuba.contains(SoaFields::ORIGIN));
        let (mut t, mut r, mut g, mut b) = (vec![0.0; 2], vec![1.0; 2], vec![1.0; 2], vec![1.0; 2]);
        let mut buffer = vec![0.0f32; 20];
        let pts = [Point2::ZERO; 2];
        let rays = RaysSoa::from_fields(&mut buffer).unwrap();
        let ctx = SoaContext::new(&pts, &pts, &pts, &mut t, rays, [&mut r, &mut g, &mut b]).unwrap();
        assert_eq!(ctx.fields(), SoaFields::ALL);
        assert_eq!(ctx.with_fields(like_mitsuba).fields(), like_mitsuba);
    }

    #[test]
    fn fields_mut_lists_the_arrays_in_record_order() {
        let n = 3;
        let mut buffer = vec![0.0f32; 10 * n];
        let mut soa = RaysSoa::from_fields(&mut buffer).unwrap();
        for (k, field) in soa.fields_mut().into_iter().enumerate() {
            field[1] = k as f32;
        }
        assert_eq!(
            soa.get(1).to_bits(),
            std::array::from_fn(|k| (k as f32).to_bits())
        );
    }

    #[test]
    fn mismatched_lengths_name_the_array() {
        let (mut a, mut b) = (vec![0.0f32; 4], vec![0.0f32; 3]);
        let mut o = [
            vec![0.0f32; 4],
            vec![0.0; 4],
            vec![0.0; 4],
            vec![0.0; 4],
            vec![0.0; 4],
            vec![0.0; 4],
        ];
        let [o0, o1, o2, d0, d1, d2] = &mut o;
        let err = RaysSoa::new(
            [o0, o1, o2],
            &mut a,
            [d0, d1, d2],
            &mut b,
            &mut [0.0; 4],
            &mut [0.0; 4],
        )
        .unwrap_err();
        assert_eq!((err.field, err.len, err.expected), ("ray_spread", 3, 4));
        assert!(
            err.to_string()
                .contains("`ray_spread` has 3 elements, the batch has 4")
        );
        assert!(RaysSoa::from_fields(&mut [0.0; 11]).is_none());
        assert_eq!(RaysSoa::from_fields(&mut []).unwrap().len(), 0);
    }
}
