//! Polygon triangulation: a convex polygon is fanned; a concave one, or one with holes, is joined into
//! one ring by bridges from each hole and ear-clipped.

use glam::{Vec2, Vec3};

/// A polygon vertex projected to the polygon's plane: its index into the positions and its 2-D point.
#[derive(Debug, Clone, Copy, PartialEq)]
struct RingVertex {
    index: u32,
    p: Vec2,
}

/// The z component of the 3-D cross product of `a` and `b`.
fn cross2(a: Vec2, b: Vec2) -> f32 {
    a.x * b.y - a.y * b.x
}

/// Twice the signed area (positive counter-clockwise).
fn signed_area2(ring: &[RingVertex]) -> f32 {
    let n = ring.len();
    (0..n).map(|i| cross2(ring[i].p, ring[(i + 1) % n].p)).sum()
}

/// The turn at vertex `i` of a ring: positive when convex in a counter-clockwise ring.
fn turn(ring: &[RingVertex], i: usize) -> f32 {
    let n = ring.len();
    let (a, b, c) = (ring[(i + n - 1) % n].p, ring[i].p, ring[(i + 1) % n].p);
    cross2(b - a, c - b)
}

/// Triangulates one polygon: `loops[0]` the outline, the others holes, as indices into `positions`.
/// Triangles keep the outline's winding. `None` when the polygon is degenerate (fewer than 3 distinct
/// vertices, or no area).
///
/// The polygon is projected onto the axis plane of the largest component of its Newell normal. A convex
/// polygon without holes is fanned; otherwise each hole (in order of decreasing rightmost x) is joined to
/// the outline by a bridge from its rightmost vertex to the nearest visible outline vertex, and the
/// resulting simple ring is ear-clipped.
pub(super) fn triangulate(positions: &[Vec3], loops: &[Vec<u32>]) -> Option<Vec<[u32; 3]>> {
    let point = |i: u32| positions.get(i as usize).copied();
    let cleaned = loops
        .iter()
        .map(|l| clean_loop(positions, l))
        .collect::<Option<Vec<_>>>()?;
    let outline = cleaned.first().filter(|o| o.len() >= 3)?;
    let pts: Vec<Vec3> = outline.iter().filter_map(|&i| point(i)).collect();
    let axes = plane_axes(&pts)?;
    let ring_of = |l: &[u32]| -> Vec<RingVertex> {
        l.iter()
            .filter_map(|&i| {
                Some(RingVertex {
                    index: i,
                    p: project(axes, point(i)?),
                })
            })
            .collect()
    };
    let mut ring = ring_of(outline);
    // Mirror the plane, not the order, so that the outline runs counter-clockwise and the triangles keep
    // the winding the file gave.
    let mirror = signed_area2(&ring) < 0.0;
    let flip = |r: &mut Vec<RingVertex>| {
        if mirror {
            for v in r.iter_mut() {
                v.p.x = -v.p.x;
            }
        }
    };
    flip(&mut ring);
    if signed_area2(&ring).is_nan() || signed_area2(&ring) <= 0.0 {
        return None;
    }
    let mut holes: Vec<Vec<RingVertex>> = Vec::new();
    for l in cleaned.iter().skip(1).filter(|l| l.len() >= 3) {
        let mut h = ring_of(l);
        flip(&mut h);
        let area = signed_area2(&h);
        if area == 0.0 {
            continue;
        }
        if area > 0.0 {
            h.reverse(); // holes run clockwise
        }
        holes.push(h);
    }
    if holes.is_empty() && (0..ring.len()).all(|i| turn(&ring, i) >= 0.0) {
        let r0 = ring[0].index;
        return Some(
            ring.windows(2)
                .skip(1)
                .map(|w| [r0, w[0].index, w[1].index])
                .collect(),
        );
    }
    let max_x = |h: &[RingVertex]| h.iter().map(|v| v.p.x).fold(f32::NEG_INFINITY, f32::max);
    holes.sort_by(|a, b| max_x(b).total_cmp(&max_x(a)));
    for h in &holes {
        ring = bridge(ring, h);
    }
    Some(ear_clip(&ring))
}

/// A loop without consecutive repeated points (nor a last point repeating the first); `None` when an
/// index is out of range.
fn clean_loop(positions: &[Vec3], l: &[u32]) -> Option<Vec<u32>> {
    let point = |i: u32| positions.get(i as usize).copied();
    let mut out: Vec<u32> = Vec::with_capacity(l.len());
    for &i in l {
        let p = point(i)?;
        if out.last().and_then(|&j| point(j)) != Some(p) {
            out.push(i);
        }
    }
    while out.len() > 1 && point(out[0]) == out.last().and_then(|&j| point(j)) {
        out.pop();
    }
    Some(out)
}

/// The absolute Newell normal of the outline `pts`, which picks the plane to project onto; `None` when
/// the outline has no area (relative to its extent).
fn plane_axes(pts: &[Vec3]) -> Option<Vec3> {
    let mut normal = Vec3::ZERO;
    for (k, a) in pts.iter().enumerate() {
        let b = pts[(k + 1) % pts.len()];
        normal += Vec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    let (lo, hi) = pts
        .iter()
        .fold((pts[0], pts[0]), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let extent = (hi - lo).max_element();
    if !(normal.is_finite() && normal.length() > 1e-7 * extent * extent) {
        return None;
    }
    Some(normal.abs())
}

/// `p` projected onto the axis plane of the largest component of `axes` (see [`plane_axes`]).
fn project(axes: Vec3, p: Vec3) -> Vec2 {
    let a = axes;
    if a.x >= a.y && a.x >= a.z {
        Vec2::new(p.y, p.z)
    } else if a.y >= a.z {
        Vec2::new(p.z, p.x)
    } else {
        Vec2::new(p.x, p.y)
    }
}

/// True when the segments `p1–p2` and `q1–q2` cross at a point interior to both.
fn segments_cross(p1: Vec2, p2: Vec2, q1: Vec2, q2: Vec2) -> bool {
    let d1 = cross2(q2 - q1, p1 - q1);
    let d2 = cross2(q2 - q1, p2 - q1);
    let d3 = cross2(p2 - p1, q1 - p1);
    let d4 = cross2(p2 - p1, q2 - p1);
    d1 * d2 < 0.0 && d3 * d4 < 0.0
}

/// True when the direction from ring vertex `k` towards `m` points into the polygon's interior at `k`.
fn in_wedge(ring: &[RingVertex], k: usize, m: Vec2) -> bool {
    let n = ring.len();
    let v = ring[k].p;
    let (prev, next) = (ring[(k + n - 1) % n].p - v, ring[(k + 1) % n].p - v);
    let d = m - v;
    if cross2(next, prev) >= 0.0 {
        cross2(next, d) > 0.0 && cross2(d, prev) > 0.0
    } else {
        !(cross2(prev, d) >= 0.0 && cross2(d, next) >= 0.0)
    }
}

/// Joins a clockwise hole to a counter-clockwise ring: from the hole's rightmost vertex to the nearest
/// ring vertex it sees (preferring those to its right, where no unjoined hole can be in the way).
fn bridge(ring: Vec<RingVertex>, hole: &[RingVertex]) -> Vec<RingVertex> {
    let Some(mi) = (0..hole.len()).max_by(|&a, &b| hole[a].p.x.total_cmp(&hole[b].p.x)) else {
        return ring;
    };
    let m = hole[mi].p;
    let n = ring.len();
    let mut candidates: Vec<usize> = (0..n).collect();
    candidates.sort_by(|&a, &b| {
        let key = |i: usize| (ring[i].p.x < m.x, ring[i].p.distance_squared(m));
        let (ka, kb) = (key(a), key(b));
        ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
    });
    let visible = |k: usize| {
        let v = ring[k].p;
        (0..n).all(|j| {
            let (a, b) = (ring[j].p, ring[(j + 1) % n].p);
            a == v || b == v || a == m || b == m || !segments_cross(m, v, a, b)
        })
    };
    let pick = candidates
        .iter()
        .copied()
        .find(|&k| visible(k) && in_wedge(&ring, k, m))
        .or_else(|| candidates.iter().copied().find(|&k| visible(k)))
        .or_else(|| candidates.first().copied());
    let Some(k) = pick else {
        return ring;
    };
    let mut out = Vec::with_capacity(n + hole.len() + 2);
    out.extend_from_slice(&ring[..=k]);
    out.extend_from_slice(&hole[mi..]);
    out.extend_from_slice(&hole[..=mi]);
    out.extend_from_slice(&ring[k..]);
    out
}

/// True when `p` lies inside or on the counter-clockwise triangle `a b c`.
fn in_triangle(p: Vec2, a: Vec2, b: Vec2, c: Vec2) -> bool {
    cross2(b - a, p - a) >= 0.0 && cross2(c - b, p - b) >= 0.0 && cross2(a - c, p - c) >= 0.0
}

/// Ear clipping of a counter-clockwise ring (which may touch itself along hole bridges).
fn ear_clip(ring: &[RingVertex]) -> Vec<[u32; 3]> {
    let mut live = ring.to_vec();
    let mut tris = Vec::with_capacity(ring.len().saturating_sub(2));
    let mut i = 0usize;
    let mut misses = 0usize;
    while live.len() > 3 {
        let n = live.len();
        i %= n;
        let (a, b, c) = (live[(i + n - 1) % n], live[i], live[(i + 1) % n]);
        let is_ear = turn(&live, i) > 0.0
            && live
                .iter()
                .all(|v| v.p == a.p || v.p == b.p || v.p == c.p || !in_triangle(v.p, a.p, b.p, c.p));
        if is_ear {
            tris.push([a.index, b.index, c.index]);
            live.remove(i);
            misses = 0;
            // Step back: the previous vertex has a new neighbour and may have become an ear.
            i = (i + live.len() - 1) % live.len();
            continue;
        }
        i += 1;
        misses += 1;
        if misses >= n {
            // No clean ear in a whole pass: straight vertices or rounding. Remove the flattest
            // non-reflex vertex (a straight one adds no area).
            let k = (0..n)
                .map(|k| (k, turn(&live, k)))
                .filter(|(_, t)| *t >= 0.0)
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .map_or(i % n, |(k, _)| k);
            if turn(&live, k) > 0.0 {
                tris.push([
                    live[(k + n - 1) % n].index,
                    live[k].index,
                    live[(k + 1) % n].index,
                ]);
            }
            live.remove(k);
            misses = 0;
            i = k;
        }
    }
    if live.len() == 3 && turn(&live, 1) > 0.0 {
        tris.push([live[0].index, live[1].index, live[2].index]);
    }
    tris
}
