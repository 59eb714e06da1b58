//! Initial states: random spawning (docs/world-and-laws.md §1.4) and explicit layouts, both
//! validated.
//!
//! Random spawning is rejection sampling with a fixed budget (`world.spawn_attempts` tries per
//! item, `world.spawn_restarts` whole-layout restarts), all draws from the world's spawn
//! stream: reproducible from the seed alone, never unbounded, never the wall clock.

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::layout::{v2, Layout, LayoutObstacle};
use super::{AgentState, Obstacle};
use crate::config::Params;
use crate::error::{Error, Result};
use crate::geometry::{body_triangle, triangles_overlap};
use crate::math::{unit, Vec2, TAU};
use crate::scene::PolygonDraw;

/// Minimum centre distance between two spawned wolves (their bodies cannot touch, and no wolf
/// starts in close-partner steering): the larger of twice the body size and 0.5 m.
fn wolf_spacing(p: &Params) -> f64 {
    p.agents.body.reach().max(0.5)
}

type Spawned = (Vec<AgentState>, Vec<AgentState>, Vec<Obstacle>);

pub(super) fn spawn(p: &Params, rng: &mut ChaCha8Rng) -> Result<Spawned> {
    let mut last = String::new();
    for _ in 0..p.world.spawn_restarts {
        match try_spawn(p, rng) {
            Ok(s) => return Ok(s),
            Err(why) => last = why,
        }
    }
    let o = &p.obstacles;
    Err(Error::Spawn(format!(
        "{last} (after {} attempts each, {} restarts): the arena world.border = {:?} is too small for world.wolves = {}, world.targets = {} and \
         obstacles.static_circles / moving_circles / static_polygons / moving_polygons = {} / {} / {} / {} at world.init_clearance = {} m; \
         lower one of them or widen world.border",
        p.world.spawn_attempts,
        p.world.spawn_restarts,
        p.world.border,
        p.world.wolves,
        p.world.targets,
        o.static_circles,
        o.moving_circles,
        o.static_polygons,
        o.moving_polygons,
        p.world.init_clearance
    )))
}

fn try_spawn(p: &Params, rng: &mut ChaCha8Rng) -> std::result::Result<Spawned, String> {
    let [x0, y0, x1, y1] = p.world.border;
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let (hw, hh) = (0.375 * (x1 - x0), 0.375 * (y1 - y0));
    let attempts = p.world.spawn_attempts;
    let spacing = wolf_spacing(p);

    // Wolves: uniform in the central ¾ of the arena, heading U(0, 2π), not touching.
    let mut wolves: Vec<AgentState> = Vec::with_capacity(p.world.wolves);
    for i in 0..p.world.wolves {
        let mut placed = false;
        for _ in 0..attempts {
            let pos = Vec2::new(rng.random_range(cx - hw..=cx + hw), rng.random_range(cy - hh..=cy + hh));
            let theta = rng.random_range(0.0..TAU);
            if wolves.iter().all(|w| (w.pos - pos).norm() > spacing) {
                wolves.push(AgentState { pos, theta, ..Default::default() });
                placed = true;
                break;
            }
        }
        if !placed {
            return Err(format!("could not place wolf {i} of {} at spacing {spacing} m", p.world.wolves));
        }
    }

    // Targets: uniform by area in the sensing disc of a random wolf, inside the arena.
    let r_w = p.agents.wolf.sense_radius;
    let mut targets = Vec::with_capacity(p.world.targets);
    for j in 0..p.world.targets {
        let mut placed = false;
        for _ in 0..attempts {
            let host = wolves[rng.random_range(0..wolves.len())].pos;
            let r = r_w * rng.random::<f64>().sqrt();
            let pos = host + unit(rng.random_range(0.0..TAU)) * r;
            let theta = rng.random_range(0.0..TAU);
            let inside = pos.x > x0 && pos.x < x1 && pos.y > y0 && pos.y < y1;
            if inside && wolves.iter().all(|w| (w.pos - pos).norm() > spacing) {
                targets.push(AgentState { pos, theta, ..Default::default() });
                placed = true;
                break;
            }
        }
        if !placed {
            return Err(format!("could not place target {j} of {}", p.world.targets));
        }
    }

    // Obstacles: centres uniform in the arena shrunk by 2 m; kinds in a fixed order.
    let o = &p.obstacles;
    let d0 = p.world.init_clearance;
    let (sx0, sy0, sx1, sy1) = (x0 + 2.0, y0 + 2.0, x1 - 2.0, y1 - 2.0);
    if (sx0 >= sx1 || sy0 >= sy1) && o.total() > 0 {
        return Err("arena shrunk by 2 m for obstacle centres is empty".into());
    }
    let kinds = [
        ("static circle", o.static_circles, false, false),
        ("moving circle", o.moving_circles, false, true),
        ("static polygon", o.static_polygons, true, false),
        ("moving polygon", o.moving_polygons, true, true),
    ];
    let mut obstacles: Vec<Obstacle> = Vec::with_capacity(o.total());
    let mut draw = PolygonDraw::default();
    for (name, count, polygon, moving) in kinds {
        for k in 0..count {
            let mut placed = false;
            for _ in 0..attempts {
                let c = Vec2::new(rng.random_range(sx0..=sx1), rng.random_range(sy0..=sy1));
                // Whether a disc of radius r at c keeps its clearance. The comparisons are
                // monotone in r (rounding included), so a candidate that fails at a lower bound
                // of its radius fails at the radius itself.
                let clear = |r: f64| wolves.iter().chain(&targets).all(|a| (a.pos - c).norm() > r + d0) && obstacles.iter().all(|q| (q.center - c).norm() > r + d0 + q.radius);
                let ob = if polygon {
                    draw.redraw(rng, o);
                    if !clear(draw.radius_lower_bound(c)) {
                        continue;
                    }
                    draw.build(c, moving)
                } else {
                    Obstacle::circle(c, rng.random_range(o.circle_radius[0]..=o.circle_radius[1]), moving)
                };
                if clear(ob.radius) {
                    obstacles.push(ob);
                    placed = true;
                    break;
                }
            }
            if !placed {
                return Err(format!(
                    "could not place {name} {} of {count} {d0} m clear of the {} wolves, {} targets and {} obstacles placed before it",
                    k + 1,
                    wolves.len(),
                    targets.len(),
                    obstacles.len()
                ));
            }
        }
    }
    Ok((wolves, targets, obstacles))
}

fn check_pose(what: &str, pose: [f64; 3], p: &Params) -> Result<AgentState> {
    if pose.iter().any(|x| !x.is_finite()) {
        return Err(Error::Layout(format!("{what}: pose {pose:?} is not finite")));
    }
    let [x0, y0, x1, y1] = p.world.border;
    let (x, y) = (pose[0], pose[1]);
    if !(x > x0 && x < x1 && y > y0 && y < y1) {
        return Err(Error::Layout(format!("{what} at ({x}, {y}) is outside the arena {:?}", p.world.border)));
    }
    Ok(AgentState::at(x, y, pose[2]))
}

fn check_obstacle(k: usize, o: &LayoutObstacle, p: &Params) -> Result<Obstacle> {
    let [x0, y0, x1, y1] = p.world.border;
    let inside = |q: [f64; 2]| q[0].is_finite() && q[1].is_finite() && q[0] >= x0 && q[0] <= x1 && q[1] >= y0 && q[1] <= y1;
    match o {
        LayoutObstacle::Circle { center, radius, moving } => {
            if !inside(*center) {
                return Err(Error::Layout(format!("obstacle {k}: centre {center:?} is outside the arena")));
            }
            if !(radius.is_finite() && *radius > 0.0 && *radius <= MAX_LAYOUT_RADIUS) {
                return Err(Error::Layout(format!("obstacle {k}: radius must be in (0, {MAX_LAYOUT_RADIUS}] m, got {radius}")));
            }
            let [cx, cy] = *center;
            if cx - radius < x0 || cx + radius > x1 || cy - radius < y0 || cy + radius > y1 {
                return Err(Error::Layout(format!("obstacle {k}: the circle at {center:?} with radius {radius} crosses the arena's wall")));
            }
            Ok(Obstacle::circle(v2(*center), *radius, *moving))
        }
        LayoutObstacle::Polygon { center, vertices, moving } => {
            if !inside(*center) {
                return Err(Error::Layout(format!("obstacle {k}: centre {center:?} is outside the arena")));
            }
            if vertices.len() < 3 || vertices.len() > MAX_LAYOUT_VERTICES {
                return Err(Error::Layout(format!("obstacle {k}: a polygon needs 3..={MAX_LAYOUT_VERTICES} vertices, got {}", vertices.len())));
            }
            if let Some(v) = vertices.iter().find(|v| !inside(**v)) {
                return Err(Error::Layout(format!("obstacle {k}: vertex {v:?} is outside the arena")));
            }
            let verts: Vec<Vec2> = vertices.iter().map(|v| v2(*v)).collect();
            if let Some(why) = degenerate(&verts) {
                return Err(Error::Layout(format!("obstacle {k}: degenerate polygon ({why})")));
            }
            Ok(Obstacle::polygon(v2(*center), verts, *moving))
        }
    }
}

/// Largest circle radius and vertex count a layout may use (those of spawned obstacles are far
/// smaller; see `obstacles.circle_radius`, `obstacles.polygon_vertices`).
const MAX_LAYOUT_RADIUS: f64 = 1000.0;
const MAX_LAYOUT_VERTICES: usize = 1024;
const MAX_LAYOUT_OBSTACLES: usize = 10_000;

/// Why a vertex ring does not bound a proper polygon: repeated consecutive vertices, three
/// consecutive vertices on one line, crossing edges, or no area. Tolerances are relative to the polygon's size,
/// so the test means the same at any scale; such rings break the convex hulls and tangent
/// computations of the laws.
fn degenerate(v: &[Vec2]) -> Option<String> {
    let n = v.len();
    let c = v.iter().fold(Vec2::zeros(), |a, b| a + b) / n as f64;
    let scale = v.iter().map(|p| (p - c).norm()).fold(0.0, f64::max);
    if scale == 0.0 {
        return Some("all vertices coincide".into());
    }
    for i in 0..n {
        let (a, b, d) = (v[(i + n - 1) % n], v[i], v[(i + 1) % n]);
        if (d - b).norm() <= 1e-9 * scale {
            return Some(format!("vertices {i} and {} coincide", (i + 1) % n));
        }
        let (e1, e2) = (b - a, d - b);
        if (e1.x * e2.y - e1.y * e2.x).abs() <= 1e-9 * scale * scale {
            return Some(format!("vertices {}, {i} and {} are collinear", (i + n - 1) % n, (i + 1) % n));
        }
    }
    if !is_simple(v) {
        return Some("edges cross: vertices must go around the polygon in order".into());
    }
    let area2: f64 = (0..n).map(|i| v[i].x * v[(i + 1) % n].y - v[(i + 1) % n].x * v[i].y).sum();
    if area2.abs() <= 1e-9 * scale * scale {
        return Some("zero area".into());
    }
    None
}

/// Whether two layout obstacles overlap: discs by distance, a disc and a polygon by the
/// polygon's surface distance from the centre, two polygons by crossing edges or a vertex of
/// one inside the other.
fn obstacles_overlap(a: &Obstacle, b: &Obstacle) -> bool {
    if (a.center - b.center).norm() > a.radius + b.radius {
        return false; // bounding discs apart
    }
    match (a.is_polygon(), b.is_polygon()) {
        (false, false) => true,
        (true, false) => a.distance(b.center) < b.radius,
        (false, true) => b.distance(a.center) < a.radius,
        (true, true) => {
            let (p, q) = (&a.vertices, &b.vertices);
            let crossing = (0..p.len()).any(|i| (0..q.len()).any(|j| crate::geometry::segments_intersect(p[i], p[(i + 1) % p.len()], q[j], q[(j + 1) % q.len()])));
            crossing || crate::geometry::polygon_contains(q, p[0]) || crate::geometry::polygon_contains(p, q[0])
        }
    }
}

/// No two non-adjacent edges share a point.
fn is_simple(v: &[Vec2]) -> bool {
    let n = v.len();
    for i in 0..n {
        for j in (i + 2)..n {
            if i == 0 && j == n - 1 {
                continue;
            }
            if crate::geometry::segments_intersect(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n]) {
                return false;
            }
        }
    }
    true
}

pub(super) fn from_layout(p: &Params, layout: &Layout) -> Result<Spawned> {
    let wolves = layout.wolves.iter().enumerate().map(|(i, w)| check_pose(&format!("wolf {i}"), *w, p)).collect::<Result<Vec<_>>>()?;
    let targets = layout.targets.iter().enumerate().map(|(j, t)| check_pose(&format!("target {j}"), *t, p)).collect::<Result<Vec<_>>>()?;
    if layout.obstacles.len() > MAX_LAYOUT_OBSTACLES {
        return Err(Error::Layout(format!("at most {MAX_LAYOUT_OBSTACLES} obstacles, got {}", layout.obstacles.len())));
    }
    let obstacles = layout.obstacles.iter().enumerate().map(|(k, o)| check_obstacle(k, o, p)).collect::<Result<Vec<_>>>()?;
    for (k, o) in obstacles.iter().enumerate() {
        if let Some(j) = obstacles[..k].iter().position(|other| obstacles_overlap(o, other)) {
            return Err(Error::Layout(format!("obstacle {k} overlaps obstacle {j}")));
        }
    }
    let b = &p.agents.body;
    let bodies: Vec<[Vec2; 3]> = wolves.iter().map(|w| body_triangle(w.pos, w.theta, b.base, b.height)).collect();
    for (i, wb) in bodies.iter().enumerate() {
        if let Some(k) = obstacles.iter().position(|o| o.overlaps_triangle(wb)) {
            return Err(Error::Layout(format!("wolf {i} overlaps obstacle {k}")));
        }
        if let Some(j) = bodies[..i].iter().position(|other| triangles_overlap(wb, other)) {
            return Err(Error::Layout(format!("wolf {i} overlaps wolf {j}")));
        }
    }
    let target_bodies: Vec<[Vec2; 3]> = targets.iter().map(|t| body_triangle(t.pos, t.theta, b.base, b.height)).collect();
    for (j, tb) in target_bodies.iter().enumerate() {
        if let Some(k) = obstacles.iter().position(|o| o.overlaps_triangle(tb)) {
            return Err(Error::Layout(format!("target {j} overlaps obstacle {k}")));
        }
        if let Some(i) = bodies.iter().position(|wb| triangles_overlap(tb, wb)) {
            return Err(Error::Layout(format!("target {j} overlaps wolf {i}")));
        }
        if let Some(i) = target_bodies[..j].iter().position(|other| triangles_overlap(tb, other)) {
            return Err(Error::Layout(format!("target {j} overlaps target {i}")));
        }
    }
    Ok((wolves, targets, obstacles))
}
