//! The `bvc` hunting law (docs/world-and-laws.md §6; source `001_d2e86cb3825e307d.txt`): buffered
//! Voronoi cells with a Hungarian assignment of hunting points.
//!
//! - Hunting points ([`hunting_points`]): N points evenly spaced on the ring of radius r_h
//!   around the wolf's target, the first at angle 0.
//! - Assignment ([`assign`]): minimum total wolf→point distance, by the Kuhn–Munkres algorithm
//!   of the `pathfinding` crate, re-solved every `bvc.assignment_period` steps. Every wolf
//!   solves the same problem from the same snapshot, so the assignment is consistent.
//! - Cell ([`cell`]): the convex polygon of points wolf i may occupy this step — the sensing
//!   disc (a regular polygon inscribed in it), the arena shrunk by r_s, and one half-plane per
//!   other wolf (the bisector of p_i p_j shifted towards i by r_s; wolves communicate
//!   globally, so every other wolf counts and cells of different wolves never overlap) and per
//!   obstacle within sensing range (the max-margin line between p_i and the obstacle's convex
//!   hull — through the midpoint of p_i and the hull's closest point, normal along that
//!   segment — shifted by r_s). If the buffers leave nothing (wolves closer than 2 r_s), the
//!   unbuffered cell is used, which always contains p_i. A wolf closer than 2 r_s to an
//!   obstacle's hull lies outside its own (non-empty) cell: its goal is then a point of the
//!   cell, which takes it away from the obstacle.
//! - Goal ([`closest_point`]): the hunting point if the cell contains it, else the cell's
//!   closest point to it, on an edge (projection parameter λ ∈ [0, 1]) or at a vertex.
//! - Command: within `bvc.d_min` of an obstacle or of another wolf (a reading, §8: the source names
//!   only obstacles, but a straight run at another wolf is what the cell exists to prevent), head
//!   for the goal; otherwise straight for the hunting point. Speed v_max, capped so as not to
//!   overshoot in one step (v ≤ distance / Ts). Then the saturator.
//! - Sensing: a wolf knows its target's position when it or any other wolf senses it (global
//!   communication); when nobody does, it heads for the last position known, and before any
//!   it stays.

use super::Snapshot;
pub use crate::geometry::{assign, hunting_points};
use crate::geometry::{edges, polygon_closest_point};
use crate::math::{angle_of, cos, cross, sin, Point2, Vec2};
/// The bvc law's memory: the pack's last sighting and the assigned hunting point.
pub use crate::scene::BvcMemory as Memory;
use crate::scene::{LawMode, Obstacle};

/// [`assign`], memoised per thread: every wolf of the pack solves the same problem.
fn assign_memoised(wolves: &[Vec2], points: &[Vec2]) -> Vec<usize> {
    let key: Vec<f64> = wolves.iter().chain(points).flat_map(|p| [p.x, p.y]).chain([wolves.len() as f64]).collect();
    thread_local! {
        static LAST: std::cell::RefCell<super::LastCall<Vec<usize>>> = const { std::cell::RefCell::new(super::LastCall::new()) };
    }
    LAST.with(|c| c.borrow_mut().get_or(key, || assign(wolves, points)))
}

/// The half-plane {x : a·x ≤ b}.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HalfPlane {
    pub a: Vec2,
    pub b: f64,
}

impl HalfPlane {
    /// The side of the line through `m` with unit normal `n` that `n` points away from,
    /// shifted by `buffer` against `n`: {x : n·x ≤ n·m − buffer}.
    pub fn behind(m: Vec2, n: Vec2, buffer: f64) -> Self {
        HalfPlane { a: n, b: n.dot(&m) - buffer }
    }

    pub fn contains(&self, x: Vec2, eps: f64) -> bool {
        self.a.dot(&x) <= self.b + eps
    }
}

/// A convex polygon clipped by a half-plane (Sutherland–Hodgman, one plane).
pub fn clip(poly: &[Vec2], h: &HalfPlane) -> Vec<Vec2> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (p, q) in edges(poly) {
        let (fp, fq) = (h.a.dot(&p) - h.b, h.a.dot(&q) - h.b);
        if fp <= 0.0 {
            out.push(p);
        }
        if (fp < 0.0 && fq > 0.0) || (fp > 0.0 && fq < 0.0) {
            out.push(p + (q - p) * (fp / (fp - fq)));
        }
    }
    out
}

/// The closest point of obstacle `ob`'s convex hull to `p`, and whether `p` lies inside it.
fn hull_closest_point(ob: &Obstacle, p: Vec2) -> (Vec2, bool) {
    if !ob.is_polygon() {
        let d = p - ob.center;
        let n = d.norm();
        let u = if n > 0.0 { d / n } else { Vec2::new(1.0, 0.0) };
        return (ob.center + ob.radius * u, n < ob.radius);
    }
    let points: Vec<Point2> = ob.vertices.iter().map(|v| Point2::new(v.x, v.y)).collect();
    let hull: Vec<Vec2> = parry2d_f64::transformation::convex_hull(&points).iter().map(|q| Vec2::new(q.x, q.y)).collect();
    let inside = hull.len() >= 3 && edges(&hull).all(|(a, b)| cross(b - a, p - a) >= 0.0);
    let best = closest_on_boundary(&hull, p).0;
    (best, inside)
}

/// Where [`closest_point`] found the goal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GoalCase {
    /// The hunting point lies in the cell.
    Inside,
    /// On an edge: the projection parameter λ ∈ [0, 1].
    Edge,
    /// At a vertex.
    Vertex,
}

impl GoalCase {
    /// The law's mode when this case decides the goal.
    pub fn law_mode(self) -> LawMode {
        match self {
            GoalCase::Inside => LawMode::CellInside,
            GoalCase::Edge => LawMode::CellEdge,
            GoalCase::Vertex => LawMode::CellVertex,
        }
    }
}

/// The closest point of the polygon's boundary to `q`, and whether it is on an edge's interior
/// (λ ∈ (0, 1)) or a vertex.
fn closest_on_boundary(poly: &[Vec2], q: Vec2) -> (Vec2, GoalCase) {
    let mut best = (poly.first().copied().unwrap_or(q), GoalCase::Vertex, f64::INFINITY);
    for (a, b) in edges(poly) {
        let ab = b - a;
        let len2 = ab.norm_squared();
        let lambda = if len2 > 0.0 { (q - a).dot(&ab) / len2 } else { 0.0 };
        let (point, case) = if lambda <= 0.0 {
            (a, GoalCase::Vertex)
        } else if lambda >= 1.0 {
            (b, GoalCase::Vertex)
        } else {
            (a + lambda * ab, GoalCase::Edge)
        };
        let d = (point - q).norm_squared();
        if d < best.2 {
            best = (point, case, d);
        }
    }
    (best.0, best.1)
}

/// The point of convex polygon `cell` (counter-clockwise) closest to `q`: `q` itself when
/// inside, else on an edge or at a vertex (source steps ①–⑤).
pub fn closest_point(cell: &[Vec2], q: Vec2) -> (Vec2, GoalCase) {
    let inside = cell.len() >= 3 && edges(cell).all(|(a, b)| cross(b - a, q - a) >= -1e-12);
    if inside {
        return (q, GoalCase::Inside);
    }
    closest_on_boundary(cell, q)
}

/// The constraints of wolf i's cell apart from the sensing disc: arena, other wolves,
/// obstacles within sensing range; each with the index of the wolf it comes from, if any.
fn constraints(i: usize, wolves: &[Vec2], obstacles: &[Obstacle], border: [f64; 4], sense: f64, buffer: f64) -> Vec<(HalfPlane, Option<usize>)> {
    let p = wolves[i];
    let [x0, y0, x1, y1] = border;
    let mut hs = vec![
        (HalfPlane { a: Vec2::new(-1.0, 0.0), b: -(x0 + buffer) }, None),
        (HalfPlane { a: Vec2::new(1.0, 0.0), b: x1 - buffer }, None),
        (HalfPlane { a: Vec2::new(0.0, -1.0), b: -(y0 + buffer) }, None),
        (HalfPlane { a: Vec2::new(0.0, 1.0), b: y1 - buffer }, None),
    ];
    for (j, &q) in wolves.iter().enumerate() {
        let d = q - p;
        let n = d.norm();
        if j != i && n > 0.0 {
            hs.push((HalfPlane::behind((p + q) / 2.0, d / n, buffer), Some(j)));
        }
    }
    for ob in obstacles {
        if ob.distance(p) > sense {
            continue;
        }
        let (q, inside) = hull_closest_point(ob, p);
        // Inside the hull of a non-convex polygon (in a pocket): separate from the polygon's
        // own closest boundary point instead.
        let q = if inside && ob.is_polygon() { polygon_closest_point(&ob.vertices, p).0 } else { q };
        let d = q - p;
        let n = d.norm();
        if n > 0.0 {
            hs.push((HalfPlane::behind((p + q) / 2.0, d / n, buffer), None));
        }
    }
    hs
}

/// Wolf i's buffered Voronoi cell (convex, counter-clockwise), and the wolves whose bisector
/// cut it (the information it used). Falls back to the unbuffered cell when the buffered one
/// is empty.
pub fn cell(i: usize, wolves: &[Vec2], obstacles: &[Obstacle], border: [f64; 4], sense: f64, buffer: f64, disc_sides: usize) -> (Vec<Vec2>, Vec<usize>) {
    for b in [buffer, 0.0] {
        let p = wolves[i];
        let mut poly: Vec<Vec2> = (0..disc_sides)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / disc_sides as f64;
                p + sense * Vec2::new(cos(a), sin(a))
            })
            .collect();
        let mut used = Vec::new();
        for (h, from) in constraints(i, wolves, obstacles, border, sense, b) {
            let before = poly.len();
            let cut = poly.iter().any(|x| !h.contains(*x, 0.0));
            poly = clip(&poly, &h);
            if let (Some(j), true) = (from, cut || poly.len() != before) {
                used.push(j);
            }
            if poly.len() < 3 {
                break;
            }
        }
        if poly.len() >= 3 {
            return (poly, used);
        }
    }
    (vec![wolves[i]], Vec::new())
}

/// The bvc law up to the saturator: wolf i's desired (v_d, θ_d).
pub fn wolf_desired(i: usize, snap: &Snapshot, mem: &mut Memory, row: &mut [u8]) -> (f64, f64) {
    let p = snap.params;
    let b = &p.bvc;
    let me = snap.wolves[i];
    let n = snap.wolves.len();
    let Some(target_pos) = mem.sighting.share(i, snap).map(|t| t.pos) else {
        mem.mode = LawMode::Wait;
        return (0.0, me.theta);
    };
    let positions: Vec<Vec2> = snap.wolves.iter().map(|w| w.pos).collect();
    let points = hunting_points(target_pos, n, b.radius);
    let period = b.assignment_period.max(1);
    if mem.point.is_none() || snap.t % period == 0 {
        mem.point = Some(assign_memoised(&positions, &points)[i]);
    }
    let hunt = points[mem.point.unwrap_or(i) % n];

    let near_obstacle = snap.obstacles.iter().map(|o| o.distance(me.pos)).fold(f64::INFINITY, f64::min);
    let near_wolf = positions.iter().enumerate().filter(|&(j, _)| j != i).map(|(_, q)| (q - me.pos).norm()).fold(f64::INFINITY, f64::min);
    let (goal, case) = if near_obstacle.min(near_wolf) < b.d_min {
        let (poly, used) = cell(i, &positions, snap.obstacles, p.world.border, p.agents.wolf.sense_radius, b.safety_radius, b.disc_sides);
        for j in used {
            row[j] = 1;
        }
        let (goal, case) = closest_point(&poly, hunt);
        (goal, case.law_mode())
    } else {
        (hunt, LawMode::Direct)
    };
    // While nobody senses the target, the hunt is around its last sighting: that is the mode.
    mem.mode = if mem.sighting.is_now(snap) { case } else { LawMode::Lost };
    let to = goal - me.pos;
    let d = to.norm();
    if d <= 1e-9 {
        return (0.0, me.theta);
    }
    let v = p.agents.wolf.v_max.min(d / p.world.ts);
    (v, angle_of(to))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn v(x: f64, y: f64) -> Vec2 {
        Vec2::new(x, y)
    }

    fn brute_force(wolves: &[Vec2], points: &[Vec2]) -> f64 {
        fn perms(k: usize, used: &mut Vec<bool>, acc: f64, w: &[Vec2], p: &[Vec2], best: &mut f64) {
            if k == w.len() {
                *best = best.min(acc);
                return;
            }
            for j in 0..p.len() {
                if !used[j] {
                    used[j] = true;
                    perms(k + 1, used, acc + (w[k] - p[j]).norm(), w, p, best);
                    used[j] = false;
                }
            }
        }
        let mut best = f64::INFINITY;
        perms(0, &mut vec![false; points.len()], 0.0, wolves, points, &mut best);
        best
    }

    proptest! {
        #[test]
        fn assignment_is_optimal_against_brute_force(xs in prop::collection::vec((-10.0..10.0f64, -10.0..10.0f64), 1..7), cx in -5.0..5.0f64, cy in -5.0..5.0f64) {
            let wolves: Vec<Vec2> = xs.iter().map(|&(x, y)| v(x, y)).collect();
            let points = hunting_points(v(cx, cy), wolves.len(), 0.65);
            let a = assign(&wolves, &points);
            let mut seen = a.clone();
            seen.sort();
            seen.dedup();
            prop_assert_eq!(seen.len(), wolves.len(), "a permutation");
            let total: f64 = a.iter().enumerate().map(|(i, &j)| (wolves[i] - points[j]).norm()).sum();
            // within the micrometre rounding of the weights
            prop_assert!(total <= brute_force(&wolves, &points) + 1e-5 * wolves.len() as f64);
        }
    }

    #[test]
    fn hunting_points_are_evenly_spaced_on_the_ring() {
        let pts = hunting_points(v(1.0, 2.0), 4, 0.5);
        let want = [v(1.5, 2.0), v(1.0, 2.5), v(0.5, 2.0), v(1.0, 1.5)];
        for (p, w) in pts.iter().zip(want) {
            assert!((p - w).norm() < 1e-12, "{p:?} vs {w:?}");
        }
    }

    #[test]
    fn closest_point_inside_on_an_edge_and_at_a_vertex() {
        let square = [v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)];
        assert_eq!(closest_point(&square, v(0.3, 0.6)), (v(0.3, 0.6), GoalCase::Inside));
        // right of the square: projection onto the edge x = 1 with λ = 0.4
        assert_eq!(closest_point(&square, v(2.0, 0.4)), (v(1.0, 0.4), GoalCase::Edge));
        // beyond the corner (1, 1): both projections fall outside [0, 1]
        assert_eq!(closest_point(&square, v(3.0, 2.0)), (v(1.0, 1.0), GoalCase::Vertex));
    }

    #[test]
    fn clip_keeps_the_inner_side() {
        let square = [v(0.0, 0.0), v(2.0, 0.0), v(2.0, 2.0), v(0.0, 2.0)];
        let h = HalfPlane::behind(v(1.0, 0.0), v(1.0, 0.0), 0.25); // x <= 0.75
        let out = clip(&square, &h);
        assert!(out.iter().all(|p| p.x <= 0.75 + 1e-12));
        let area: f64 = (0..out.len()).map(|k| cross(out[k], out[(k + 1) % out.len()])).sum::<f64>() / 2.0;
        assert!((area - 1.5).abs() < 1e-12, "{area}");
    }

    fn inside(poly: &[Vec2], q: Vec2, eps: f64) -> bool {
        (0..poly.len()).all(|k| cross(poly[(k + 1) % poly.len()] - poly[k], q - poly[k]) >= -eps)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// Random wolves at least 2 r_s + 0.1 apart and circles clear of them: every cell holds
        /// its wolf, keeps r_s from every other wolf, leaves every obstacle out (its vertices are
        /// outside every circle), and cells of different wolves do not overlap (no vertex of one
        /// lies strictly inside another).
        #[test]
        fn cells_contain_their_wolf_and_exclude_buffers_obstacles_and_each_other(
            pts in prop::collection::vec((-9.0..9.0f64, -9.0..9.0f64), 2..7),
            circles in prop::collection::vec((-9.0..9.0f64, -9.0..9.0f64, 0.2..1.2f64), 0..4),
            polygons in prop::collection::vec((-9.0..9.0f64, -9.0..9.0f64, any::<u64>()), 0..4),
        ) {
            let rs = 0.2;
            let wolves: Vec<Vec2> = pts.iter().map(|&(x, y)| v(x, y)).collect();
            for a in 0..wolves.len() {
                for b in 0..a {
                    prop_assume!((wolves[a] - wolves[b]).norm() > 2.0 * rs + 0.1);
                }
            }
            let mut obstacles: Vec<Obstacle> = circles.iter().map(|&(x, y, r)| Obstacle::circle(v(x, y), r, false)).collect();
            let shapes = crate::config::ObstacleParams::default();
            for &(x, y, seed) in &polygons {
                // the world's own random (generally non-convex) polygons
                let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(seed);
                obstacles.push(Obstacle::random_polygon(&mut rng, v(x, y), false, &shapes));
            }
            for o in &obstacles {
                for w in &wolves {
                    prop_assume!(o.distance(*w) > 2.0 * rs + 0.1);
                    // Beyond the buffer of the separating line too: that line is drawn to the
                    // convex hull, which can come closer than the polygon itself. A wolf
                    // inside a hull's buffer is (by construction) outside its own cell and
                    // heads for it, away from the obstacle; a wolf in a pocket (inside the
                    // hull) is separated from the polygon instead.
                    let (q, in_hull) = hull_closest_point(o, *w);
                    prop_assume!(in_hull || (q - w).norm() > 2.0 * rs + 0.1);
                }
            }
            let border = [-10.0, -10.0, 10.0, 10.0];
            let cells: Vec<Vec<Vec2>> = (0..wolves.len()).map(|i| cell(i, &wolves, &obstacles, border, 3.0, rs, 32).0).collect();
            for (i, c) in cells.iter().enumerate() {
                prop_assert!(c.len() >= 3, "wolf {} has an empty cell", i);
                prop_assert!(inside(c, wolves[i], 1e-9), "wolf {} outside its cell", i);
                for (j, w) in wolves.iter().enumerate() {
                    if j != i {
                        // beyond the bisector plus the buffer: half the distance plus r_s
                        let (q, _) = closest_point(c, *w);
                        let half = (wolves[i] - w).norm() / 2.0;
                        prop_assert!((q - w).norm() >= half + rs - 1e-9, "cell {} within r_s of the bisector with wolf {}", i, j);
                    }
                }
                for o in &obstacles {
                    // r_s clear of every obstacle the wolf senses, clear of the others
                    let clearance = if o.distance(wolves[i]) <= 3.0 { rs } else { 0.0 };
                    if o.is_polygon() {
                        for corner in &o.vertices {
                            let (q, _) = closest_point(c, *corner);
                            prop_assert!((q - corner).norm() >= clearance - 1e-9, "cell {} reaches a polygon's corner", i);
                        }
                        for x in c {
                            prop_assert!(o.distance(*x) >= clearance - 1e-9, "a corner of cell {} is in a polygon", i);
                        }
                    } else {
                        // a sensed circle: beyond the max-margin line (half the wolf's surface
                        // distance) plus the buffer r_s
                        let margin = if clearance > 0.0 { o.distance(wolves[i]) / 2.0 + rs } else { 0.0 };
                        let (q, _) = closest_point(c, o.center);
                        prop_assert!((q - o.center).norm() >= o.radius + margin - 1e-9, "cell {} reaches into a circle or its buffer", i);
                    }
                }
                for (j, other) in cells.iter().enumerate() {
                    if j != i {
                        for x in other {
                            prop_assert!(!inside(c, *x, -1e-6), "cells {} and {} overlap", i, j);
                        }
                    }
                }
            }
        }
    }

    // ---- the law's mode ----

    use crate::policies::fixture::Scene;
    use crate::scene::AgentState;

    /// Wolves at `wolves` hunting one target at `target`, every wolf sensing it.
    fn hunt(wolves: &[(f64, f64)], target: (f64, f64)) -> Scene {
        let mut s = Scene::new(Scene::wolves_at(wolves), vec![AgentState::at(target.0, target.1, 0.0)], vec![]);
        s.wolf_senses = vec![true; wolves.len()];
        s
    }

    fn mode_of(s: &Scene) -> LawMode {
        let mut mem = Memory::default();
        wolf_desired(0, &s.snap(), &mut mem, &mut s.row());
        mem.mode
    }

    #[test]
    fn the_mode_is_the_goal_case() {
        // Nothing within d_min: straight for the hunting point.
        assert_eq!(mode_of(&hunt(&[(0.0, 0.0)], (2.0, 0.0))), LawMode::Direct);
        // Wolf 1 0.9 m away (within d_min): the cell is y ≤ 0.25 around wolf 0, whose assigned
        // point (1.4, 0) lies inside it.
        assert_eq!(mode_of(&hunt(&[(0.0, 0.0), (0.0, 0.9)], (2.0, 0.0))), LawMode::CellInside);
        // A circle 0.7 m below: the cell is y ≥ −0.15. The point (1.6, −2) projects onto that
        // edge's interior; the point (4, −1) is nearest the corner where the edge meets the
        // sensing disc.
        let mut s = hunt(&[(0.0, 0.0)], (1.0, -2.0));
        s.obstacles = vec![Obstacle::circle(v(0.0, -1.2), 0.5, false)];
        assert_eq!(mode_of(&s), LawMode::CellEdge);
        s.targets[0] = AgentState::at(3.4, -1.0, 0.0);
        assert_eq!(mode_of(&s), LawMode::CellVertex);
    }

    #[test]
    fn waiting_before_any_sighting_then_lost_when_nobody_senses() {
        let mut s = hunt(&[(0.0, 0.0)], (2.0, 0.0));
        s.wolf_senses = vec![false];
        let mut mem = Memory::default();
        assert_eq!(wolf_desired(0, &s.snap(), &mut mem, &mut s.row()), (0.0, 0.0));
        assert_eq!(mem.mode, LawMode::Wait);
        // Sensed at step 0, then not at step 1: the pack hunts around the last sighting.
        s.wolf_senses = vec![true];
        wolf_desired(0, &s.snap(), &mut mem, &mut s.row());
        assert_eq!(mem.mode, LawMode::Direct);
        (s.wolf_senses, s.t) = (vec![false], 1);
        let lost = wolf_desired(0, &s.snap(), &mut mem, &mut s.row());
        assert_eq!(mem.mode, LawMode::Lost);
        // ... with the very command of the sighting it remembers.
        s.wolf_senses = vec![true];
        assert_eq!(wolf_desired(0, &s.snap(), &mut Memory::default(), &mut s.row()), lost);
    }
}
