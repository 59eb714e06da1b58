//! Queries on simple polygons (the irregular obstacles): containment, closest point, and the
//! angular extent of the part within a sensing disc.

use arrayvec::ArrayVec;

use super::Extent;
use crate::math::{angle_of, wrap, wrap_pi, Vec2, FRAC_PI_2};

/// The edges `(v[i], v[i + 1])` of a closed polygon, the last one back to `v[0]`, in order.
/// Without the `(i + 1) % n` of an index loop: an integer division per edge was a sizeable
/// share of a polygon query's cycles.
/// (An index and a wrap test per edge: the `zip`/`chain` of slice iterators this replaced
/// compiled to a state machine of many instructions per edge, a large share of a
/// closest-point query; BENCHMARKS.md, "Optimisations".)
#[inline]
pub fn edges(v: &[Vec2]) -> Edges<'_> {
    Edges { v, i: 0 }
}

/// The iterator of [`edges`].
#[derive(Debug, Clone)]
pub struct Edges<'a> {
    v: &'a [Vec2],
    i: usize,
}

impl Iterator for Edges<'_> {
    type Item = (Vec2, Vec2);

    #[inline]
    fn next(&mut self) -> Option<(Vec2, Vec2)> {
        let i = self.i;
        let a = *self.v.get(i)?;
        self.i = i + 1;
        let b = match self.v.get(i + 1) {
            Some(&b) => b,
            None => self.v[0],
        };
        Some((a, b))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.v.len().saturating_sub(self.i);
        (left, Some(left))
    }
}

/// Even–odd point-in-polygon test (boundary points may go either way; callers that need the
/// closed set also test the distance to the boundary).
pub fn polygon_contains(poly: &[Vec2], p: Vec2) -> bool {
    let mut inside = false;
    let n = poly.len();
    let mut j = n - 1;
    for i in 0..n {
        if crosses(poly[i], poly[j], p) {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// The even–odd test's crossing of edge (a, b) by the ray from `p` towards +x. Not symmetric
/// in rounding: [`polygon_contains`] passes each vertex with its predecessor.
#[inline]
fn crosses(a: Vec2, b: Vec2, p: Vec2) -> bool {
    (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x
}

/// The point of segment [a, b] closest to `p`: parry's `Segment::project_local_point`, the
/// same arithmetic bit for bit (a test checks), without its out-of-line call and the
/// `relative_eq!` "inside" flag it computes for every projection (a large part of a polygon
/// query: BENCHMARKS.md, "Optimisations").
#[inline]
pub fn closest_on_segment(a: Vec2, b: Vec2, p: Vec2) -> Vec2 {
    let ab = b - a;
    let ab_ap = ab.dot(&(p - a));
    let sqnab = ab.norm_squared();
    if ab_ap <= 0.0 {
        a
    } else if ab_ap >= sqnab {
        b
    } else {
        a + ab * (ab_ap / sqnab)
    }
}

/// The point of the polygon's boundary closest to `p`, and its distance.
pub fn polygon_closest_point(poly: &[Vec2], p: Vec2) -> (Vec2, f64) {
    // Squared distances compared, one square root at the end: sqrt is monotone, so the
    // distance is the same; the point differs only where two edges' squared distances differ
    // but round to the same root (then the later edge's point, at the same distance).
    let mut best = (poly[0], f64::INFINITY);
    for (a, b) in edges(poly) {
        let q = closest_on_segment(a, b, p);
        let d2 = (q - p).norm_squared();
        if d2 < best.1 {
            best = (q, d2);
        }
    }
    (best.0, best.1.sqrt())
}

/// The part of segment [a, b] inside the closed disc (c, r), if any.
pub fn segment_disc_clip(a: Vec2, b: Vec2, c: Vec2, r: f64) -> Option<(Vec2, Vec2)> {
    let d = b - a;
    let f = a - c;
    let qa = d.dot(&d);
    let qb = 2.0 * f.dot(&d);
    let qc = f.dot(&f) - r * r;
    if qa == 0.0 {
        return (qc <= 0.0).then_some((a, a));
    }
    let disc = qb * qb - 4.0 * qa * qc;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let t0 = ((-qb - s) / (2.0 * qa)).max(0.0);
    let t1 = ((-qb + s) / (2.0 * qa)).min(1.0);
    (t0 <= t1).then(|| (a + d * t0, a + d * t1))
}

/// Angular extent of `polygon ∩ disc(p, range)` seen from `p` (the polygon item of
/// docs/world-and-laws.md §4.1): the two tangent rays bound the directions in which a ray from p
/// meets the polygon within `range`.
///
/// Returns `None` when the polygon is farther than `range`. The directions are measured as
/// offsets from the direction ψ₀ of the closest boundary point (which is always inside the
/// set), so the interval never straddles a 0/2π seam. When `p` is inside the polygon (only a
/// moving obstacle can put it there), the whole forward half-plane towards the polygon's
/// `center` is reported: ψ = direction to the centre, Δ = π/2, d = 0.
pub fn polygon_visible_extent(poly: &[Vec2], center: Vec2, p: Vec2, range: f64) -> Option<Extent> {
    // One pass over the edges does the three walks of [`visible_extent_by_passes`] — closest
    // point, containment, clipping by the disc — and keeps the clipped endpoints; the rest is
    // that function's, on the same numbers in the same order, so the result is the same bit
    // for bit (a test checks). It saved little of a scripted step's instructions: the edges'
    // arithmetic, not the walking, is what a query costs.
    // Stack lists that are not zeroed: initialising 64 + 64 slots per query cost a few per
    // cent of its instructions (both: BENCHMARKS.md, "Optimisations").
    const ENDS: usize = 64;
    let mut ends: ArrayVec<Vec2, ENDS> = ArrayVec::new();
    let mut best = (poly[0], f64::INFINITY);
    let mut inside = false;
    let far2 = outside_disc_squared(range);
    for (v0, v1) in edges(poly) {
        let q = closest_on_segment(v0, v1, p);
        let d2 = (q - p).norm_squared();
        if d2 < best.1 {
            best = (q, d2);
        }
        // polygon_contains takes each vertex with its predecessor.
        if crosses(v1, v0, p) {
            inside = !inside;
        }
        if d2 > far2 {
            // Clearly outside the disc: the clip would find nothing.
            continue;
        }
        if let Some((a, b)) = segment_disc_clip(v0, v1, p, range) {
            if ends.len() == ENDS {
                // A polygon with more than 32 edges within range: the plain way.
                return visible_extent_by_passes(poly, center, p, range);
            }
            ends.push(a);
            ends.push(b);
        }
    }
    let (closest, dist) = (best.0, best.1.sqrt());
    if dist >= range {
        return None;
    }
    if inside || dist == 0.0 {
        return Some(Extent { psi: angle_of(center - p), delta: FRAC_PI_2, dist: 0.0 });
    }
    let psi0 = angle_of(closest - p);
    let r = closest - p;
    let mut keys: ArrayVec<f64, ENDS> = ArrayVec::new();
    let (mut lo_key, mut hi_key) = (0.0f64, 0.0f64);
    for q in &ends {
        let key = pseudo_angle(r, q - p);
        keys.push(key);
        lo_key = lo_key.min(key);
        hi_key = hi_key.max(key);
    }
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for (&key, q) in keys.iter().zip(&ends) {
        if key <= lo_key + KEY_SLACK || key >= hi_key - KEY_SLACK {
            let off = wrap_pi(angle_of(q - p) - psi0);
            lo = lo.min(off);
            hi = hi.max(off);
        }
    }
    Some(Extent { psi: wrap(psi0 + 0.5 * (lo + hi)), delta: 0.5 * (hi - lo), dist })
}

/// A squared distance from the disc's centre beyond which a segment's closest point puts the
/// whole segment outside the disc of radius `range`, so that [`segment_disc_clip`] finds
/// nothing there: the margin (a relative 1e-6) is far above the clip's rounding, whose worst
/// case, a line tangent near a segment's end, moves a root by ≈ √ε of the distances.
#[inline]
fn outside_disc_squared(range: f64) -> f64 {
    range * range * (1.0 + 1e-6) + 1e-12
}

/// Only the endpoints whose pseudo-angle (no trigonometry) is within this of an extreme get an
/// angle (see [`visible_extent_by_passes`]).
const KEY_SLACK: f64 = 1e-9;

/// [`polygon_visible_extent`] as three walks over the edges, for polygons with more clipped
/// edges than the one-pass version keeps, and as its reference in the tests.
fn visible_extent_by_passes(poly: &[Vec2], center: Vec2, p: Vec2, range: f64) -> Option<Extent> {
    let (closest, dist) = polygon_closest_point(poly, p);
    if dist >= range {
        return None;
    }
    if polygon_contains(poly, p) {
        return Some(Extent { psi: angle_of(center - p), delta: FRAC_PI_2, dist: 0.0 });
    }
    if dist == 0.0 {
        // On the boundary: the tangent directions are those of the touching edges.
        return Some(Extent { psi: angle_of(center - p), delta: FRAC_PI_2, dist: 0.0 });
    }
    let psi0 = angle_of(closest - p);
    // lo / hi: the extreme angular offsets from ψ₀ of the clipped edges' endpoints. Only the
    // endpoints whose pseudo-angle (no trigonometry) is within KEY_SLACK of an extreme get an
    // angle, and lo / hi are the min / max of those angles: the same numbers, bit for bit, as
    // taking the angle of every endpoint, for ≈ 2 atan2 per call instead of ≈ 12. The slack
    // covers the pseudo-angle's own rounding, so near-ties are decided by the angles as before.
    const KEPT: usize = 64;
    let r = closest - p;
    let mut kept = [(0.0f64, Vec2::zeros()); KEPT];
    let (mut count, mut lo_key, mut hi_key) = (0usize, 0.0f64, 0.0f64);
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for (v0, v1) in edges(poly) {
        if let Some((a, b)) = segment_disc_clip(v0, v1, p, range) {
            for q in [a, b] {
                let key = pseudo_angle(r, q - p);
                lo_key = lo_key.min(key);
                hi_key = hi_key.max(key);
                if count < KEPT {
                    kept[count] = (key, q);
                } else {
                    // More endpoints than kept (a polygon of > 32 edges within range): the
                    // plain way for this one.
                    let off = wrap_pi(angle_of(q - p) - psi0);
                    lo = lo.min(off);
                    hi = hi.max(off);
                }
                count += 1;
            }
        }
    }
    for &(key, q) in &kept[..count.min(KEPT)] {
        if key <= lo_key + KEY_SLACK || key >= hi_key - KEY_SLACK {
            let off = wrap_pi(angle_of(q - p) - psi0);
            lo = lo.min(off);
            hi = hi.max(off);
        }
    }
    Some(Extent { psi: wrap(psi0 + 0.5 * (lo + hi)), delta: 0.5 * (hi - lo), dist })
}

/// A number that orders directions `u` by their signed angle from `r` in (−π, π] exactly as
/// the angle does, without trigonometry ("diamond angle"): in (−2, 2], 0 along `r`, ±1 at right
/// angles.
#[inline]
fn pseudo_angle(r: Vec2, u: Vec2) -> f64 {
    let (c, d) = (r.x * u.y - r.y * u.x, r.dot(&u));
    let s = c / (c.abs() + d.abs());
    if d >= 0.0 {
        s
    } else if c >= 0.0 {
        2.0 - s
    } else {
        -2.0 - s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{PI, TAU};

    fn v(x: f64, y: f64) -> Vec2 {
        Vec2::new(x, y)
    }

    fn square(c: Vec2, h: f64) -> Vec<Vec2> {
        vec![c + v(-h, -h), c + v(h, -h), c + v(h, h), c + v(-h, h)]
    }

    #[test]
    fn edges_close_the_polygon_in_order() {
        let t = [v(0.0, 0.0), v(1.0, 0.0), v(0.0, 2.0)];
        let e: Vec<(Vec2, Vec2)> = edges(&t).collect();
        assert_eq!(e, vec![(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]);
        assert_eq!(edges(&[]).count(), 0);
    }

    #[test]
    fn containment_and_distance() {
        let s = square(v(0.0, 0.0), 1.0);
        assert!(polygon_contains(&s, v(0.5, 0.5)));
        assert!(!polygon_contains(&s, v(1.5, 0.5)));
        let (q, d) = polygon_closest_point(&s, v(3.0, 0.5));
        assert!((d - 2.0).abs() < 1e-12 && (q - v(1.0, 0.5)).norm() < 1e-12);
    }

    #[test]
    fn closest_on_segment_is_parrys_projection_bit_for_bit() {
        use crate::math::Point2;
        use parry2d_f64::query::PointQuery;
        use parry2d_f64::shape::Segment;
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for k in 0..20_000 {
            let a = v(rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0));
            // Some degenerate and axis-aligned segments among the random ones.
            let b = match k % 10 {
                0 => a,
                1 => v(a.x, rng.random_range(-3.0..3.0)),
                _ => v(rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0)),
            };
            let p = if k % 7 == 0 { a + (b - a) * rng.random_range(-0.5..1.5) } else { v(rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0)) };
            let want = Segment::new(Point2::from(a), Point2::from(b)).project_local_point(&Point2::from(p), true).point.coords;
            let got = closest_on_segment(a, b, p);
            assert_eq!((got.x.to_bits(), got.y.to_bits()), (want.x.to_bits(), want.y.to_bits()), "{a} {b} {p}");
        }
    }

    #[test]
    fn the_one_pass_extent_equals_the_three_walks_bit_for_bit() {
        use crate::config::ObstacleParams;
        use crate::scene::Obstacle;
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let shapes = ObstacleParams::default();
        let big = ObstacleParams { polygon_vertices: [40, 60], polygon_size: [3.0, 4.0], ..ObstacleParams::default() };
        let (mut some, mut inside) = (0, 0);
        for k in 0..20_000 {
            // Many-sided polygons too: those with more clipped edges than the one pass keeps
            // take the three walks themselves.
            let o = Obstacle::random_polygon(&mut rng, v(0.0, 0.0), false, if k % 10 == 0 { &big } else { &shapes });
            let p = match k % 5 {
                0 => o.vertices[rng.random_range(0..o.vertices.len())] * rng.random_range(0.9..1.1),
                _ => v(rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0)),
            };
            let mut range = rng.random_range(0.2..3.0);
            if k % 7 == 3 {
                // The disc's edge just beyond, on or just within some edge's closest point:
                // where the one pass skips a clip, the clip must have found nothing.
                let (a, b) = edges(&o.vertices).nth(rng.random_range(0..o.vertices.len())).unwrap();
                let d = (closest_on_segment(a, b, p) - p).norm();
                range = d * (1.0 + [-1e-6, -1e-9, 0.0, 1e-12, 1e-9, 5e-7, 1e-6, 2e-6][k % 8]);
                if range <= 0.0 {
                    continue;
                }
            }
            let (got, want) = (polygon_visible_extent(&o.vertices, o.center, p, range), visible_extent_by_passes(&o.vertices, o.center, p, range));
            let bits = |e: Option<Extent>| e.map(|e| (e.psi.to_bits(), e.delta.to_bits(), e.dist.to_bits()));
            assert_eq!(bits(got), bits(want), "polygon {k}, p = {p}, range {range}");
            some += usize::from(got.is_some());
            inside += usize::from(got.is_some_and(|e| e.dist == 0.0));
        }
        assert!(some > 5_000 && inside > 100, "the cases are exercised: {some} extents, {inside} from inside");
    }

    #[test]
    fn disc_clip() {
        let (a, b) = segment_disc_clip(v(-2.0, 0.0), v(2.0, 0.0), v(0.0, 0.0), 1.0).unwrap();
        assert!((a - v(-1.0, 0.0)).norm() < 1e-12 && (b - v(1.0, 0.0)).norm() < 1e-12);
        assert!(segment_disc_clip(v(-2.0, 2.0), v(2.0, 2.0), v(0.0, 0.0), 1.0).is_none());
        let (a, b) = segment_disc_clip(v(0.0, 0.0), v(0.5, 0.0), v(0.0, 0.0), 1.0).unwrap();
        assert!((a - v(0.0, 0.0)).norm() < 1e-12 && (b - v(0.5, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn extent_of_a_wide_wall_is_clipped_by_the_disc() {
        // A long thin box 1 m to the right: visible part is a chord of the r=2 disc.
        let poly = vec![v(1.0, -10.0), v(1.5, -10.0), v(1.5, 10.0), v(1.0, 10.0)];
        let e = polygon_visible_extent(&poly, v(1.25, 0.0), v(0.0, 0.0), 2.0).unwrap();
        assert!((e.dist - 1.0).abs() < 1e-12);
        assert!(e.psi.abs() < 1e-12 || (e.psi - 2.0 * PI).abs() < 1e-12);
        // Chord endpoints at x = 1, y = ±√3 → half-angle 60°.
        assert!((e.delta - PI / 3.0).abs() < 1e-12, "{}", e.delta);
    }

    #[test]
    fn extent_of_a_small_square_is_its_tangent_cone() {
        let s = square(v(0.0, 3.0), 0.5);
        let e = polygon_visible_extent(&s, v(0.0, 3.0), v(0.0, 0.0), 10.0).unwrap();
        assert!((e.psi - PI / 2.0).abs() < 1e-12);
        // Tangent rays through the near corners (±0.5, 2.5).
        assert!((e.delta - (0.5f64 / 2.5).atan()).abs() < 1e-12);
        assert!(polygon_visible_extent(&s, v(0.0, 3.0), v(0.0, 0.0), 2.4).is_none());
    }

    /// The plain definition: the angle of every clipped endpoint.
    fn extent_by_every_angle(poly: &[Vec2], center: Vec2, p: Vec2, range: f64) -> Option<Extent> {
        let (closest, dist) = polygon_closest_point(poly, p);
        if dist >= range || polygon_contains(poly, p) || dist == 0.0 {
            return polygon_visible_extent(poly, center, p, range);
        }
        let psi0 = angle_of(closest - p);
        let (mut lo, mut hi) = (0.0f64, 0.0f64);
        for i in 0..poly.len() {
            if let Some((a, b)) = segment_disc_clip(poly[i], poly[(i + 1) % poly.len()], p, range) {
                for q in [a, b] {
                    let off = wrap_pi(angle_of(q - p) - psi0);
                    lo = lo.min(off);
                    hi = hi.max(off);
                }
            }
        }
        Some(Extent { psi: wrap(psi0 + 0.5 * (lo + hi)), delta: 0.5 * (hi - lo), dist })
    }

    #[test]
    fn pseudo_angle_selection_gives_the_angles_bit_for_bit() {
        use crate::config::ObstacleParams;
        use crate::scene::Obstacle;
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let shapes = ObstacleParams::default();
        let mut compared = 0;
        for _ in 0..3000 {
            let o = Obstacle::random_polygon(&mut rng, v(0.0, 0.0), false, &shapes);
            let p = v(rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0));
            let range = rng.random_range(0.2..4.0);
            let (got, want) = (polygon_visible_extent(&o.vertices, o.center, p, range), extent_by_every_angle(&o.vertices, o.center, p, range));
            assert_eq!(got.map(|e| (e.psi.to_bits(), e.delta.to_bits(), e.dist.to_bits())), want.map(|e| (e.psi.to_bits(), e.delta.to_bits(), e.dist.to_bits())), "p {p:?} range {range}");
            compared += usize::from(got.is_some());
        }
        assert!(compared > 500, "{compared}");
    }

    #[test]
    fn pseudo_angle_orders_like_the_angle() {
        let r = v(0.3, -0.7);
        let mut prev = f64::NEG_INFINITY;
        for k in 1..720 {
            let a = -PI + k as f64 * (TAU / 720.0);
            let key = pseudo_angle(r, crate::math::na::Rotation2::new(a) * r * 2.5);
            assert!(key > prev, "{a}");
            prev = key;
        }
    }

    #[test]
    fn extent_straddling_zero_direction() {
        let s = square(v(3.0, 0.0), 0.5);
        let e = polygon_visible_extent(&s, v(3.0, 0.0), v(0.0, 0.0), 10.0).unwrap();
        assert!(wrap_pi(e.psi).abs() < 1e-12);
        assert!((e.delta - (0.5f64 / 2.5).atan()).abs() < 1e-12);
    }
}
