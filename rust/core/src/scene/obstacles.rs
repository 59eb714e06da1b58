//! Obstacles (docs/world-and-laws.md §1.3): circles and irregular star-shaped polygons, static or
//! moving.

use rand::Rng;

use crate::config::ObstacleParams;
use crate::geometry::{self, Extent};
use crate::math::{angle_of, asin, rem_euclid_tau, sin_cos, unit, Vec2, FRAC_PI_2, TAU};
use crate::normal::standard_normal;

/// What an obstacle is, for the avoidance law's κ table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObstacleKind {
    StaticCircle,
    MovingCircle,
    StaticPolygon,
    MovingPolygon,
}

impl ObstacleKind {
    pub fn is_circle(self) -> bool {
        matches!(self, Self::StaticCircle | Self::MovingCircle)
    }
    pub fn is_moving(self) -> bool {
        matches!(self, Self::MovingCircle | Self::MovingPolygon)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Obstacle {
    pub kind: ObstacleKind,
    pub center: Vec2,
    /// Circle radius, or the polygon's bounding radius about `center` (for culling).
    pub radius: f64,
    /// Polygon orientation (rad) relative to `local`.
    pub angle: f64,
    /// Polygon vertices relative to the centre at angle 0 (empty for circles).
    pub local: Vec<Vec2>,
    /// Polygon vertices in world coordinates at the current pose (empty for circles).
    pub vertices: Vec<Vec2>,
    /// Whether `vertices` are those of the current pose. Always true, except in lazy worlds
    /// (the episode runner's and the batch's, see `World::lazy_obstacles`), whose polygons
    /// are placed only when something reads them.
    pub(crate) placed: bool,
}

impl Obstacle {
    pub fn circle(center: Vec2, radius: f64, moving: bool) -> Self {
        let kind = if moving { ObstacleKind::MovingCircle } else { ObstacleKind::StaticCircle };
        Self { kind, center, radius, angle: 0.0, local: Vec::new(), vertices: Vec::new(), placed: true }
    }

    /// A polygon from world-coordinate vertices around `center`.
    pub fn polygon(center: Vec2, vertices: Vec<Vec2>, moving: bool) -> Self {
        let kind = if moving { ObstacleKind::MovingPolygon } else { ObstacleKind::StaticPolygon };
        let local: Vec<Vec2> = vertices.iter().map(|v| v - center).collect();
        let radius = local.iter().map(|v| v.norm()).fold(0.0, f64::max);
        Self { kind, center, radius, angle: 0.0, local, vertices, placed: true }
    }

    /// The random irregular polygon of §1.3: size R, n vertices whose polar angles cover
    /// every quadrant, radii `sqrt(U(inner, 1))·R`, joined in angular order (star-shaped).
    pub fn random_polygon<R: Rng>(rng: &mut R, center: Vec2, moving: bool, p: &ObstacleParams) -> Self {
        let mut draw = PolygonDraw::default();
        draw.redraw(rng, p);
        draw.build(center, moving)
    }

    /// Becomes `fresh`, keeping this obstacle's vertex lists where they are large enough
    /// (a world's respawn, [`crate::world::World::respawn`]).
    pub(crate) fn adopt(&mut self, fresh: Obstacle) {
        let Obstacle { kind, center, radius, angle, local, vertices, placed } = fresh;
        (self.kind, self.center, self.radius, self.angle, self.placed) = (kind, center, radius, angle, placed);
        self.local.clone_from(&local);
        self.vertices.clone_from(&vertices);
    }

    pub fn is_polygon(&self) -> bool {
        !self.local.is_empty()
    }

    /// Re-computes world vertices from centre and angle.
    fn place(&mut self) {
        let (s, c) = sin_cos(self.angle);
        for (w, l) in self.vertices.iter_mut().zip(&self.local) {
            *w = self.center + Vec2::new(c * l.x - s * l.y, s * l.x + c * l.y);
        }
        self.placed = true;
    }

    /// Places the vertices at the current pose if [`Obstacle::advance_pose`] left them behind:
    /// the same numbers, bit for bit, as placing them when the obstacle moved.
    #[inline]
    pub(crate) fn ensure_placed(&mut self) {
        if !self.placed {
            self.place();
        }
    }

    /// One step of obstacle motion (§1.3): polygons rotate by U(−rot, rot); moving ones
    /// translate by v·Ts with v ~ N(0, σ²) per axis, reflected so they stay inside the border.
    /// Draws are made in a fixed order for every obstacle so the stream is layout-independent.
    pub fn advance<R: Rng>(&mut self, rng: &mut R, p: &ObstacleParams, ts: f64, border: &[f64; 4]) {
        self.advance_pose(rng, p, ts, border);
        self.ensure_placed();
    }

    /// [`Obstacle::advance`] without placing a polygon's vertices (a sin_cos and a rotation of
    /// every vertex): they stay behind until [`Obstacle::ensure_placed`].
    pub(crate) fn advance_pose<R: Rng>(&mut self, rng: &mut R, p: &ObstacleParams, ts: f64, border: &[f64; 4]) {
        let turn = if p.rotation_max > 0.0 { rng.random_range(-p.rotation_max..=p.rotation_max) } else { 0.0 };
        let (vx, vy) = if p.speed_std > 0.0 {
            // N(0, σ²) as rand_distr's Normal draws it: σ·z, x before y.
            let vx = p.speed_std * standard_normal(rng);
            (vx, p.speed_std * standard_normal(rng))
        } else {
            (0.0, 0.0)
        };
        if self.is_polygon() {
            self.angle = rem_euclid_tau(self.angle + turn);
        }
        if self.kind.is_moving() {
            let r = self.radius;
            self.center.x = reflect(self.center.x + vx * ts, border[0] + r, border[2] - r);
            self.center.y = reflect(self.center.y + vy * ts, border[1] + r, border[3] - r);
        }
        if self.is_polygon() {
            self.placed = false;
        }
    }

    /// Surface distance from `p` (0 inside).
    pub fn distance(&self, p: Vec2) -> f64 {
        if self.is_polygon() {
            if geometry::polygon_contains(&self.vertices, p) {
                0.0
            } else {
                geometry::polygon_closest_point(&self.vertices, p).1
            }
        } else {
            ((p - self.center).norm() - self.radius).max(0.0)
        }
    }

    /// The point of the obstacle's surface nearest `p` and its distance ([`Obstacle::distance`]
    /// with the point; `p` itself and 0 from inside). The polygon's vertices must be placed.
    pub fn nearest_point(&self, p: Vec2) -> (Vec2, f64) {
        if self.is_polygon() {
            if geometry::polygon_contains(&self.vertices, p) {
                (p, 0.0)
            } else {
                geometry::polygon_closest_point(&self.vertices, p)
            }
        } else {
            let to = self.center - p;
            let dc = to.norm();
            if dc <= self.radius {
                (p, 0.0)
            } else {
                (p + to * ((dc - self.radius) / dc), dc - self.radius)
            }
        }
    }

    /// The avoidance item this obstacle makes for an agent at `p` (docs/world-and-laws.md §4.1), if
    /// it is within `range` (surface distance). Circles: ψ towards the centre, Δ = asin(R/(d+R))
    /// (the exact tangent cone); polygons: the tangent rays of the part within `range`.
    pub fn extent(&self, p: Vec2, range: f64) -> Option<Extent> {
        // Cull by bounding radius before any exact work.
        let dc = (p - self.center).norm();
        if dc - self.radius >= range {
            return None;
        }
        if self.is_polygon() {
            geometry::polygon_visible_extent(&self.vertices, self.center, p, range)
        } else {
            let d = dc - self.radius;
            if d <= 0.0 {
                return Some(Extent { psi: angle_of(self.center - p), delta: FRAC_PI_2, dist: 0.0 });
            }
            Some(Extent { psi: angle_of(self.center - p), delta: asin(self.radius / dc), dist: d })
        }
    }

    /// Whether a body triangle overlaps the obstacle.
    pub fn overlaps_triangle(&self, tri: &[Vec2; 3]) -> bool {
        // Every vertex of a body lies within `height` of its pose point; culling by bounding
        // discs (triangle centroid ± its circumradius) avoids the exact test almost always.
        let c = (tri[0] + tri[1] + tri[2]) / 3.0;
        let rt = tri.iter().map(|v| (v - c).norm()).fold(0.0, f64::max);
        if (c - self.center).norm() > self.radius + rt {
            return false;
        }
        if self.is_polygon() {
            geometry::triangle_overlaps_polygon(tri, &self.vertices)
        } else {
            geometry::triangle_overlaps_circle(tri, self.center, self.radius)
        }
    }
}

/// The random draws of one [`Obstacle::random_polygon`], apart from the polygon built from
/// them: spawning rejects most candidate polygons for lack of room, and a rejection needs only
/// a bound on the bounding radius, not the sorted angles, the sin/cos of each and two vertex
/// lists. Spawning drew and built every candidate (≈ 50 per world spawned); with the bound
/// it builds only those that may fit, from the same draws in the same order. That halved
/// spawning's instructions, a few per cent of a scripted episode's and of a batch step's
/// (BENCHMARKS.md, "Optimisations").
#[derive(Debug, Clone, Default)]
pub(crate) struct PolygonDraw {
    size: f64,
    /// Polar angles in the order drawn (the first four one per quadrant).
    angles: Vec<f64>,
    /// `u ~ U(inner, 1)` for each vertex, in the order drawn: the square of its radius as a
    /// fraction of `size` (radius `sqrt(u)·size`). The k-th goes to the k-th smallest angle.
    radii_squared: Vec<f64>,
}

impl PolygonDraw {
    /// Draws a new polygon's numbers from `rng`, reusing this draw's lists.
    pub(crate) fn redraw<R: Rng>(&mut self, rng: &mut R, p: &ObstacleParams) {
        self.size = rng.random_range(p.polygon_size[0]..=p.polygon_size[1]);
        let n = rng.random_range(p.polygon_vertices[0]..=p.polygon_vertices[1]) as usize;
        self.angles.clear();
        self.angles.extend((0..n).map(|k| if k < 4 { (k as f64 + rng.random::<f64>()) * FRAC_PI_2 } else { rng.random::<f64>() * TAU }));
        self.radii_squared.clear();
        self.radii_squared.extend((0..n).map(|_| rng.random_range(p.polygon_inner..=1.0)));
    }

    /// A lower bound on the bounding radius [`PolygonDraw::build`] gives at `center`: the
    /// largest vertex radius `sqrt(u)·R` less a slack far above the rounding of the unit
    /// vector, the product and the shift by the centre and back (a few ulps of |centre| + R),
    /// so that a candidate too close to something at this radius is too close at its own.
    pub(crate) fn radius_lower_bound(&self, center: Vec2) -> f64 {
        let largest = self.radii_squared.iter().copied().fold(0.0, f64::max).sqrt() * self.size;
        largest - 1e-9 * (largest + center.x.abs() + center.y.abs())
    }

    /// The polygon at `center`: the angles sorted, each with its radius draw.
    pub(crate) fn build(&mut self, center: Vec2, moving: bool) -> Obstacle {
        self.angles.sort_by(f64::total_cmp);
        let vertices = self.angles.iter().zip(&self.radii_squared).map(|(&a, &u)| center + unit(a) * u.sqrt() * self.size).collect();
        Obstacle::polygon(center, vertices, moving)
    }
}

/// Mirror `x` into [lo, hi] (a bounce off the wall); degenerate ranges clamp to the middle.
fn reflect(x: f64, lo: f64, hi: f64) -> f64 {
    if lo >= hi {
        return 0.5 * (lo + hi);
    }
    let mut x = x;
    // A step is far shorter than the arena, so at most one bounce per side occurs; the loop
    // is bounded anyway.
    for _ in 0..4 {
        if x < lo {
            x = 2.0 * lo - x;
        } else if x > hi {
            x = 2.0 * hi - x;
        } else {
            return x;
        }
    }
    x.clamp(lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::PI;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn random_polygon_matches_spec_shape() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let p = ObstacleParams::default();
        for _ in 0..200 {
            let o = Obstacle::random_polygon(&mut rng, Vec2::new(1.0, -2.0), false, &p);
            let n = o.local.len();
            assert!((7..=15).contains(&n));
            // Every quadrant holds a vertex; angles increase (star-shaped about the centre).
            let angles: Vec<f64> = o.local.iter().map(|v| angle_of(*v)).collect();
            for q in 0..4 {
                assert!(angles.iter().any(|a| (a / FRAC_PI_2).floor() as usize == q));
            }
            assert!(angles.windows(2).all(|w| w[0] <= w[1]));
            assert!(o.radius <= 1.25 + 1e-12 && o.radius >= (0.07f64).sqrt() * 0.5 - 1e-12);
        }
    }

    /// Spawning rejects a candidate polygon at `radius_lower_bound` before building it: the
    /// bound must never exceed the radius of the polygon built (or spawning would reject
    /// polygons that fit and change the episodes), and should be tight enough to reject.
    #[test]
    fn the_radius_bound_of_a_draw_is_below_and_close_to_its_polygons_radius() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut draw = PolygonDraw::default();
        for k in 0..5000 {
            let p = if k % 2 == 0 { ObstacleParams::default() } else { ObstacleParams { polygon_size: [0.01, 400.0], polygon_vertices: [4, 60], polygon_inner: 0.9, ..Default::default() } };
            let c = Vec2::new(rng.random_range(-1e3..1e3), rng.random_range(-1e3..1e3));
            draw.redraw(&mut rng, &p);
            let bound = draw.radius_lower_bound(c);
            let o = draw.build(c, false);
            assert!(bound <= o.radius, "bound {bound} above the radius {}", o.radius);
            assert!(bound >= o.radius - 1e-6 * (1.0 + c.norm()), "bound {bound} far below the radius {}", o.radius);
        }
    }

    #[test]
    fn rotation_is_rigid_and_motion_stays_inside() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let p = ObstacleParams { speed_std: 50.0, ..Default::default() };
        let border = [-10.0, -10.0, 10.0, 10.0];
        let mut o = Obstacle::random_polygon(&mut rng, Vec2::new(8.0, 8.0), true, &p);
        let radii: Vec<f64> = o.local.iter().map(|v| v.norm()).collect();
        for _ in 0..500 {
            o.advance(&mut rng, &p, 0.1, &border);
            for (w, r) in o.vertices.iter().zip(&radii) {
                assert!(((w - o.center).norm() - r).abs() < 1e-9);
                assert!(w.x.abs() <= 10.0 + 1e-9 && w.y.abs() <= 10.0 + 1e-9);
            }
        }
    }

    #[test]
    fn circle_extent_is_the_tangent_cone() {
        let o = Obstacle::circle(Vec2::new(0.0, 2.0), 1.0, false);
        let e = o.extent(Vec2::zeros(), 1.6).unwrap();
        assert!((e.psi - PI / 2.0).abs() < 1e-12);
        assert!((e.dist - 1.0).abs() < 1e-12);
        assert!((e.delta - (0.5f64).asin()).abs() < 1e-12);
        assert!(o.extent(Vec2::zeros(), 0.9).is_none());
    }
}
