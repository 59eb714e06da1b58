//! Observations of the learning interface: fixed-size, egocentric, f32. This module writes
//! the flat layout below; [`entities`] the entity layout (`env.observation: entities`).
//!
//! Relative positions are in the observer's frame (x ahead, y to the left); relative headings
//! are sin/cos of (other θ − own θ). Layout (N wolves, M targets, K lidar rays; `S` the larger
//! arena side, `r` the observer side's sensing radius):
//!
//! | slice | wolf | target | meaning |
//! |---|---|---|---|
//! | 0 | v / v_max | same | own speed executed in the last step |
//! | 1 | ω / ω_max | same | own turn rate |
//! | 2–3 | sin θ, cos θ | same | own heading (world frame) |
//! | 4–7 | wall distances | same | (x − x_min)/W, (x_max − x)/W, (y − y_min)/H, (y_max − y)/H |
//! | 8 | t / max_steps | same | episode clock |
//! | wolf: 9 … +5M | per target (index order): sensed, dx/r, dy/r, sin Δθ, cos Δθ | | all zero unless the wolf senses it now (d ≤ r_w): the sensing topology |
//! | wolf: … +5(N−1) | other wolves by distance: senses, dx/S, dy/S, sin Δθ, cos Δθ | | global communication; `senses` = 1 when that wolf senses a target now (d ≤ r_w), the flag the seed000 law follows partners by |
//! | target: 9 | | speed cap / v_max | the fatigue cap in force (1 before the first sighting or without fatigue) |
//! | target: 10 … +5N | | wolves by distance: in range, dx/r, dy/r, sin Δθ, cos Δθ | sensed wolves first; the rest all zero |
//! | next K | lidar | same | ray k at θ + 2πk/K: distance to the first obstacle or wall / range, 1 = nothing |
//! | wolf: next 4M (optional) | per target: sighted, dx/S, dy/S, age / max_steps | | the pack's latest sighting (`env.last_sighting`): where the target stood the last time any wolf sensed it, in this wolf's frame; all zero before the first |
//! | last N+M (optional) | interaction row | same | the agent's row of the last step's interaction matrix |
//!
//! Lidar rays are exact: the first hit on a circle, on any edge of a polygon (non-convex shapes
//! included; 0 from inside) or on the arena's walls from inside. They are direct 2-D formulas
//! (ray–circle quadratic, ray–segment by cross products, ray–box by slabs): parry's generic
//! casts (a support-map march for a `Segment`) cost ≈ 8 k instructions per env-step here, the
//! formulas a tenth of that. The tests check them against parry's `Ball`, `Segment` and `Aabb`
//! casts, which stay the reference.

mod entities;

pub use entities::{capacities as entity_capacities, side_uses_entities, FIELDS as ENTITY_FIELDS, ROW as ENTITY_ROW, SCALE as ENTITY_SCALE, WALLS as ENTITY_WALLS};

use crate::config::Params;
use crate::math::{cross, Vec2};
use crate::world::{AgentState, Obstacle, World};

/// Entries in the shared block (speed, turn rate, heading, walls, clock).
pub const COMMON: usize = 9;

/// Observation sizes of both sides for these params (either layout).
pub fn wolf_dim(p: &Params) -> usize {
    side_dim(p, "wolves")
}

pub fn target_dim(p: &Params) -> usize {
    side_dim(p, "targets")
}

fn side_dim(p: &Params, side: &str) -> usize {
    layout(p, side).and_then(|blocks| blocks.last().map(|b| b.start + b.len)).unwrap_or(0)
}

/// One block of an observation: `len` entries from `start`, named as the table of
/// docs/interface.md ("Observations") names its rows. An entity layout's row blocks hold
/// `rows` rows of [`ENTITY_ROW`] entries each; `rows` is 0 for every other block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Block {
    pub name: &'static str,
    pub start: usize,
    pub len: usize,
    pub rows: usize,
}

/// The blocks of `side`'s observation ("wolves" or "targets") for these params, in order:
/// they tile `0..wolf_dim(p)` / `0..target_dim(p)`, optional blocks left out where the params
/// turn them off. The one description of the layout that the Python side and the documents'
/// test read.
pub fn layout(p: &Params, side: &str) -> Option<Vec<Block>> {
    let (n, m, k) = (p.world.wolves, p.world.targets, p.env.lidar.rays);
    let mut sizes: Vec<(&'static str, usize)> = vec![("speed", 1), ("turn_rate", 1), ("heading", 2), ("walls", 4), ("clock", 1)];
    if matches!(side, "wolves" | "targets") && side_uses_entities(p, side) {
        if side == "targets" {
            sizes.push(("speed_cap", 1));
        }
        sizes.push(("lidar", k));
        let (cw, ct, co, cwall) = entity_capacities(p, side);
        let rows = [("wolf_rows", cw), ("target_rows", ct), ("obstacle_rows", co), ("wall_rows", cwall)];
        return Some(tile(sizes.into_iter().map(|(name, len)| (name, len, 0)).chain(rows.into_iter().map(|(name, r)| (name, r * ENTITY_ROW, r)))));
    }
    match side {
        "wolves" => {
            sizes.extend([("targets", 5 * m), ("wolves", 5 * (n - 1)), ("lidar", k)]);
            if sighting_len(p) > 0 {
                sizes.push(("last_sighting", sighting_len(p)));
            }
        }
        "targets" => sizes.extend([("speed_cap", 1), ("wolves", 5 * n), ("lidar", k)]),
        _ => return None,
    }
    if extra(p) > 0 {
        sizes.push(("interaction", extra(p)));
    }
    Some(tile(sizes.into_iter().map(|(name, len)| (name, len, 0))))
}

/// Blocks of (name, len, rows) laid end to end from 0.
fn tile(sizes: impl Iterator<Item = (&'static str, usize, usize)>) -> Vec<Block> {
    let mut start = 0;
    sizes
        .map(|(name, len, rows)| {
            let b = Block { name, start, len, rows };
            start += len;
            b
        })
        .collect()
}

/// Entries of the last-sighting block (wolves only).
fn sighting_len(p: &Params) -> usize {
    if p.env.last_sighting {
        4 * p.world.targets
    } else {
        0
    }
}

fn extra(p: &Params) -> usize {
    if p.env.interaction_row {
        p.world.wolves + p.world.targets
    } else {
        0
    }
}

/// Writes observations; keeps a scratch buffer so that observing allocates nothing.
#[derive(Debug, Clone, Default)]
pub struct Observer {
    by_distance: Vec<(f64, usize)>,
    /// (sin θ, cos θ) of every wolf, then every target, for the world being observed.
    trig: Vec<(f64, f64)>,
    /// The lidar's turn between neighbouring rays, (sin, cos) of 2π/K, and the K it is for.
    ray_turn: (usize, (f64, f64)),
    /// The lidar's per-ray scratch, kept between calls.
    rays: Rays,
    /// The entity layout's scratch.
    entities: entities::EntityScratch,
}

impl Observer {
    /// Starts loading this observer's lists (see [`crate::world::World::prefetch`]).
    #[inline]
    pub fn prefetch(&self) {
        crate::math::prefetch_slice(&self.by_distance);
        crate::math::prefetch_slice(&self.trig);
    }

    /// Computes what every observation of this world state shares (each agent's sin/cos);
    /// call it once per state before [`Observer::wolf`] / [`Observer::target`].
    pub fn prepare(&mut self, w: &World) {
        self.trig.clear();
        // The step's body frames hold unit(θ) of every pose they were made for, from the same
        // sin_cos: take it from there ([`World::heading_sin_cos`]), one sin_cos per agent less.
        let n = w.n_wolves();
        self.trig.extend((0..n + w.n_targets()).map(|k| w.heading_sin_cos(k)));
        let rays = w.params.env.lidar.rays;
        if self.ray_turn.0 != rays {
            self.ray_turn = (rays, ray_turn(rays));
        }
    }

    /// Wolf `i`'s observation into `out` (length [`wolf_dim`]), in the wolves' layout.
    pub fn wolf(&mut self, w: &World, i: usize, out: &mut [f32]) {
        let p = &*w.params;
        if p.env.wolf_observation_kind() == crate::config::ObservationKind::Entities {
            return self.wolf_entities(w, i, out);
        }
        let me = w.wolves[i];
        let mut k = common(p, w.t, &me, self.trig[i], p.agents.wolf.v_max, p.agents.wolf.omega_max, out);
        let r = p.agents.wolf.sense_radius;
        let n = w.n_wolves();
        let mine = self.trig[i];
        for (j, t) in w.targets.iter().enumerate() {
            let d = t.pos - me.pos;
            if d.norm() <= r {
                write_relative(&me, mine, t, self.trig[n + j], 1.0 / r, &mut out[k..k + 5], true);
            } else {
                out[k..k + 5].fill(0.0);
            }
            k += 5;
        }
        let scale = 1.0 / arena_scale(p);
        self.sort_by_distance(me.pos, &w.wolves, Some(i));
        for &(_, j) in &self.by_distance {
            // Global communication includes whether the partner has a target in sight: a wolf
            // that sees none follows the nearest partner that does (docs/world-and-laws.md §3.1).
            let partner = w.wolves[j].pos;
            let senses = w.targets.iter().any(|t| (t.pos - partner).norm() <= r);
            write_relative(&me, mine, &w.wolves[j], self.trig[j], scale, &mut out[k..k + 5], true);
            out[k] = if senses { 1.0 } else { 0.0 };
            k += 5;
        }
        k += self.lidar_into(w, &me, mine, i, &mut out[k..]);
        if p.env.last_sighting {
            for sighting in &w.target_last_sighting {
                let block = &mut out[k..k + 4];
                match *sighting {
                    Some((pos, at)) => {
                        let (s, c) = mine;
                        let d = pos - me.pos;
                        let age = f64::from(w.t - at) / f64::from(p.world.max_steps);
                        for (o, v) in block.iter_mut().zip([1.0, (c * d.x + s * d.y) * scale, (-s * d.x + c * d.y) * scale, age]) {
                            *o = v as f32;
                        }
                    }
                    None => block.fill(0.0),
                }
                k += 4;
            }
        }
        interaction_row(w, i, &mut out[k..]);
    }

    /// Target `j`'s observation into `out` (length [`target_dim`]), in the targets' layout.
    pub fn target(&mut self, w: &World, j: usize, out: &mut [f32]) {
        let p = &*w.params;
        if p.env.target_observation_kind() == crate::config::ObservationKind::Entities {
            return self.target_entities(w, j, out);
        }
        let me = w.targets[j];
        let side = &p.agents.target;
        let mine = self.trig[w.n_wolves() + j];
        let mut k = common(p, w.t, &me, mine, side.v_max, side.omega_max, out);
        out[k] = speed_cap(w, j) as f32;
        k += 1;
        let r = side.sense_radius;
        self.sort_by_distance(me.pos, &w.wolves, None);
        for &(d, i) in &self.by_distance {
            if d <= r {
                write_relative(&me, mine, &w.wolves[i], self.trig[i], 1.0 / r, &mut out[k..k + 5], true);
            } else {
                out[k..k + 5].fill(0.0);
            }
            k += 5;
        }
        k += self.lidar_into(w, &me, mine, w.n_wolves() + j, &mut out[k..]);
        interaction_row(w, w.n_wolves() + j, &mut out[k..]);
    }

    /// Agent `agent`'s lidar (pose `me`, heading sin/cos `mine`) into the first rays of `out`,
    /// with its noise; returns the ray count.
    fn lidar_into(&mut self, w: &World, me: &AgentState, mine: (f64, f64), agent: usize, out: &mut [f32]) -> usize {
        let p = &*w.params;
        let k = lidar_turned(p, me, mine, self.ray_turn.1, &w.obstacles, &mut self.rays, &mut out[..p.env.lidar.rays]);
        add_lidar_noise(w, agent, &mut out[..k]);
        k
    }

    /// Agents by distance from `from` (ties: lower index), leaving out index `skip`.
    fn sort_by_distance(&mut self, from: Vec2, agents: &[AgentState], skip: Option<usize>) {
        self.by_distance.clear();
        self.by_distance.extend(agents.iter().enumerate().filter(|&(j, _)| Some(j) != skip).map(|(j, a)| ((a.pos - from).norm(), j)));
        self.by_distance.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    }
}

/// Target `j`'s fatigue cap in force as a fraction of its v_max (1 before the first sighting or
/// without fatigue).
fn speed_cap(w: &World, j: usize) -> f64 {
    let p = &*w.params;
    let side = &p.agents.target;
    let cap = match w.target_seen_at[j] {
        Some(seen) if side.fatigue => p.escape.fatigue_speed(seen, w.t).min(side.v_max),
        _ => side.v_max,
    };
    cap / side.v_max
}

/// `env.lidar.noise`: adds N(0, noise²) to each of agent `agent`'s lidar `readings` and clips
/// the sums to [0, 1] (a reading stays a fraction of the range). Nothing when the noise is 0.
fn add_lidar_noise(w: &World, agent: usize, readings: &mut [f32]) {
    let sigma = w.params.env.lidar.noise;
    if sigma <= 0.0 || readings.is_empty() {
        return;
    }
    let mut rng = w.sensing_rng(agent);
    for r in readings {
        let z = crate::normal::standard_normal(&mut rng);
        *r = (f64::from(*r) + sigma * z).clamp(0.0, 1.0) as f32;
    }
}

fn arena_scale(p: &Params) -> f64 {
    let [x0, y0, x1, y1] = p.world.border;
    (x1 - x0).max(y1 - y0)
}

/// The shared block; returns the next free index.
fn common(p: &Params, t: u32, me: &AgentState, (s, c): (f64, f64), v_max: f64, omega_max: f64, out: &mut [f32]) -> usize {
    let [x0, y0, x1, y1] = p.world.border;
    let (w, h) = (x1 - x0, y1 - y0);
    let values = [me.v / v_max, me.omega / omega_max, s, c, (me.pos.x - x0) / w, (x1 - me.pos.x) / w, (me.pos.y - y0) / h, (y1 - me.pos.y) / h, t as f64 / p.world.max_steps as f64];
    for (o, v) in out.iter_mut().zip(values) {
        *o = v as f32;
    }
    COMMON
}

/// `other` in `me`'s frame: [flag,] dx·scale, dy·scale, sin Δθ, cos Δθ; `(s, c)` and
/// `(so, co)` are the sin/cos of the two headings (Δθ's by the difference formulas).
fn write_relative(me: &AgentState, (s, c): (f64, f64), other: &AgentState, (so, co): (f64, f64), scale: f64, out: &mut [f32], flag: bool) {
    let d = other.pos - me.pos;
    let ahead = c * d.x + s * d.y;
    let left = -s * d.x + c * d.y;
    let (ds, dc) = (so * c - co * s, co * c + so * s);
    let values = [ahead * scale, left * scale, ds, dc];
    let out = if flag {
        out[0] = 1.0;
        &mut out[1..]
    } else {
        out
    };
    for (o, v) in out.iter_mut().zip(values) {
        *o = v as f32;
    }
}

/// [`lidar_turned`] computing the heading's sin/cos and the rays' turn itself (tests).
#[cfg(test)]
fn lidar(p: &Params, me: &AgentState, obstacles: &[Obstacle], out: &mut [f32]) -> usize {
    lidar_turned(p, me, me.theta.sin_cos(), ray_turn(out.len()), obstacles, &mut Rays::default(), out)
}

/// (sin, cos) of the angle between neighbouring rays of a `rays`-ray lidar.
fn ray_turn(rays: usize) -> (f64, f64) {
    if rays == 0 {
        return (0.0, 1.0);
    }
    crate::math::sin_cos(std::f64::consts::TAU / rays as f64)
}

/// The lidar's rays as columns — direction x, direction y, nearest hit so far (metres) —
/// kept by the observer between calls: no 64-slot array zeroed per call, and the rays an
/// obstacle could shorten are picked by one tight loop over the columns.
#[derive(Debug, Clone, Default)]
struct Rays {
    dx: Vec<f64>,
    dy: Vec<f64>,
    best: Vec<f64>,
}

/// Lidar rays into `out` (its length is the ray count); returns that count. `(hs, hc)` is
/// `(sin θ, cos θ)` of the agent's heading and `(s, c)` the rays' turn ([`ray_turn`]), both
/// computed once by the observer.
///
/// Each obstacle is tested only against the rays inside the cone of its bounding disc, and
/// only where it could still beat the ray's nearest hit so far: the exact casts run a few
/// times per agent instead of rays × obstacles times. Each obstacle first marks the rays it
/// could shorten (a loop without branches over [`Rays`]' columns); the casts then run for
/// the marked rays only.
#[inline(never)]
fn lidar_turned(p: &Params, me: &AgentState, (hs, hc): (f64, f64), (s, c): (f64, f64), obstacles: &[Obstacle], rays: &mut Rays, out: &mut [f32]) -> usize {
    let n = out.len();
    if n == 0 {
        return 0;
    }
    let range = p.env.lidar.range;
    let origin = me.pos;
    for col in [&mut rays.dx, &mut rays.dy, &mut rays.best] {
        col.resize(n, 0.0);
    }
    let (dx, dy, best) = (&mut rays.dx[..n], &mut rays.dy[..n], &mut rays.best[..n]);
    // Ray k+1 is ray k turned by the rays' step (the observer's `ray_turn`): no sin/cos per
    // ray, and none per agent (the heading's comes from the observer too). `unit(θ)` first.
    let mut d = Vec2::new(hc, hs);
    for (x, y) in dx.iter_mut().zip(dy.iter_mut()) {
        (*x, *y) = (d.x, d.y);
        d = Vec2::new(c * d.x - s * d.y, s * d.x + c * d.y);
    }
    // The walls first.
    for ((b, &x), &y) in best.iter_mut().zip(dx.iter()).zip(dy.iter()) {
        *b = ray_walls(origin, Vec2::new(x, y), &p.world.border).min(range);
    }
    for ob in obstacles {
        if !lidar_reaches(ob, me.pos, range) {
            continue;
        }
        let to = ob.center - me.pos;
        let dc = to.norm();
        let near = dc - ob.radius;
        if near >= range {
            continue;
        }
        // A ray can meet the obstacle only if its direction lies in the bounding disc's cone,
        // d·to ≥ √(dc² − R²) (dc times the cosine of the cone's half-angle asin(R/dc)): a dot
        // product per ray instead of an atan2 and an asin per obstacle. The slack, far above
        // the rounding and far below any geometry, keeps every ray that touches the disc, so
        // each ray sees the hits it saw with an angular window (digests unchanged).
        let cone = if dc <= ob.radius { f64::NEG_INFINITY } else { (dc * dc - ob.radius * ob.radius).sqrt() - 1e-9 * (1.0 + dc) };
        // From inside (only a moving obstacle can put an agent there) every ray reads 0; the
        // test is made once per obstacle, not per ray.
        let inside = if ob.is_polygon() { dc <= ob.radius && crate::geometry::polygon_contains(&ob.vertices, origin) } else { dc <= ob.radius };
        for block in (0..n).step_by(64) {
            let end = (block + 64).min(n);
            // The rays this obstacle could still shorten, as bits.
            let mut marked = 0u64;
            for k in block..end {
                let keep = (near < best[k]) & (dx[k] * to.x + dy[k] * to.y >= cone);
                marked |= u64::from(keep) << (k - block);
            }
            while marked != 0 {
                let k = block + marked.trailing_zeros() as usize;
                marked &= marked - 1;
                let dir = Vec2::new(dx[k], dy[k]);
                let hit = if inside {
                    Some(0.0)
                } else if ob.is_polygon() {
                    // dc + R bounds |v − origin| over the polygon's vertices.
                    ray_polygon_boundary_filtered(&ob.vertices, edge_filter_tolerance(dc + ob.radius), origin, dir, best[k])
                } else {
                    ray_circle(origin, dir, ob.center, ob.radius, best[k])
                };
                if let Some(t) = hit {
                    best[k] = best[k].min(t);
                }
            }
        }
    }
    for (o, b) in out.iter_mut().zip(best.iter()) {
        *o = (b / range).clamp(0.0, 1.0) as f32;
    }
    n
}

/// Whether the lidar of an agent at `p` looks at obstacle `ob` at all: its bounding disc is not
/// beyond `range` by the squared distance (no square root; the slack keeps this on the safe
/// side of the exact test that follows it). A lazy world places exactly these polygons before
/// observing ([`World::place_for_lidar`]).
#[inline]
pub(crate) fn lidar_reaches(ob: &Obstacle, p: Vec2, range: f64) -> bool {
    let reach = (range + ob.radius) * (1.0 + 1e-9) + 1e-9;
    (ob.center - p).norm_squared() <= reach * reach
}

/// Distance from `o` (inside the arena) along the unit direction `d` to the arena's boundary.
#[inline]
pub fn ray_walls(o: Vec2, d: Vec2, border: &[f64; 4]) -> f64 {
    let [x0, y0, x1, y1] = *border;
    // Slabs: along each axis the wall ahead; an axis the ray runs parallel to never ends it.
    let tx = if d.x > 0.0 {
        (x1 - o.x) / d.x
    } else if d.x < 0.0 {
        (x0 - o.x) / d.x
    } else {
        f64::INFINITY
    };
    let ty = if d.y > 0.0 {
        (y1 - o.y) / d.y
    } else if d.y < 0.0 {
        (y0 - o.y) / d.y
    } else {
        f64::INFINITY
    };
    tx.min(ty).max(0.0)
}

/// First hit of the ray from `o` along the unit direction `d` on an obstacle's exact shape
/// within `max` (0 when `o` is inside the obstacle).
pub fn ray_obstacle(ob: &Obstacle, o: Vec2, d: Vec2, max: f64) -> Option<f64> {
    if !ob.is_polygon() {
        return ray_circle(o, d, ob.center, ob.radius, max);
    }
    if crate::geometry::polygon_contains(&ob.vertices, o) {
        return Some(0.0);
    }
    ray_polygon_boundary(&ob.vertices, o, d, max)
}

/// The nearest crossing within `max` of the ray with any edge of the closed polygon `v`.
#[inline]
fn ray_polygon_boundary(v: &[Vec2], o: Vec2, d: Vec2, max: f64) -> Option<f64> {
    ray_polygon_boundary_filtered(v, f64::INFINITY, o, d, max)
}

/// The tolerance of [`ray_polygon_boundary_filtered`]'s edge filter for a polygon whose
/// vertices all lie within `scale` of the ray's origin: far above the rounding of the cross
/// products (≈ 1e-16·`scale`), far below any geometry.
fn edge_filter_tolerance(scale: f64) -> f64 {
    1e-9 * (1.0 + scale)
}

/// [`ray_polygon_boundary`] with a cheap test first: an edge can only be hit when the ray's
/// line separates its two ends, i.e. the cross products `d × (v − o)` of its ends differ in
/// sign by more than `tol` (one multiply-subtract per vertex instead of the exact test's two
/// divisions per edge; `tol` = ∞ tests every edge). With [`edge_filter_tolerance`] the exact
/// test still sees every edge it could accept, in the same order: the result is the same bit
/// for bit (test `filtered_polygon_casts_equal_the_exact_ones`).
#[inline]
fn ray_polygon_boundary_filtered(v: &[Vec2], tol: f64, o: Vec2, d: Vec2, max: f64) -> Option<f64> {
    let mut best = max;
    let mut hit = false;
    let mut a = v[v.len() - 1];
    let mut sa = cross(d, a - o);
    for &b in v {
        let sb = cross(d, b - o);
        if sa.min(sb) <= tol && sa.max(sb) >= -tol {
            if let Some(t) = ray_segment(o, d, a, b) {
                if t <= best {
                    best = t;
                    hit = true;
                }
            }
        }
        a = b;
        sa = sb;
    }
    hit.then_some(best)
}

/// Ray (origin `o`, unit direction `d`) against the solid disc (c, r): 0 from inside.
#[inline]
fn ray_circle(o: Vec2, d: Vec2, c: Vec2, r: f64, max: f64) -> Option<f64> {
    let to = c - o;
    let dist2 = to.norm_squared();
    if dist2 <= r * r {
        return Some(0.0);
    }
    let along = to.dot(&d);
    if along < 0.0 {
        return None; // outside and heading away
    }
    let miss2 = dist2 - along * along;
    if miss2 > r * r {
        return None;
    }
    let t = along - (r * r - miss2).sqrt();
    (t <= max).then_some(t.max(0.0))
}

/// Ray (origin `o`, unit direction `d`) against the closed segment [a, b]: the ray parameter of
/// the crossing, if any. A ray along the segment's own line meets the neighbouring edges at its
/// ends, so the parallel case is left to them.
#[inline]
fn ray_segment(o: Vec2, d: Vec2, a: Vec2, b: Vec2) -> Option<f64> {
    let e = b - a;
    let denom = cross(d, e);
    if denom == 0.0 {
        return None;
    }
    let ao = a - o;
    let t = cross(ao, e) / denom;
    let u = cross(ao, d) / denom;
    (t >= 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
}

fn interaction_row(w: &World, agent: usize, out: &mut [f32]) {
    if out.is_empty() {
        return;
    }
    let k = w.n_wolves() + w.n_targets();
    for (o, &x) in out.iter_mut().zip(&w.interaction[agent * k..(agent + 1) * k]) {
        *o = x as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::unit;
    use std::sync::Arc;

    use crate::world::{Layout, LayoutObstacle};

    fn world(wolves: Vec<[f64; 3]>, targets: Vec<[f64; 3]>, obstacles: Vec<LayoutObstacle>) -> World {
        let layout = Layout { wolves, targets, obstacles };
        World::from_layout(Arc::new(Params::default()), 0, &layout).unwrap()
    }

    fn observer(w: &World) -> Observer {
        let mut o = Observer::default();
        o.prepare(w);
        o
    }

    /// The layout's blocks tile each side's observation, whatever the optional blocks.
    #[test]
    fn the_layout_tiles_each_observation() {
        for (sighting, row) in [(false, false), (true, false), (false, true), (true, true)] {
            let mut p = Params::default();
            p.world.wolves = 4;
            p.world.targets = 2;
            p.env.last_sighting = sighting;
            p.env.interaction_row = row;
            for (side, dim) in [("wolves", wolf_dim(&p)), ("targets", target_dim(&p))] {
                let blocks = layout(&p, side).unwrap();
                let mut next = 0;
                for b in &blocks {
                    assert_eq!(b.start, next, "{side}: {} starts after the block before it", b.name);
                    next += b.len;
                }
                assert_eq!(next, dim, "{side} with last_sighting {sighting}, interaction_row {row}");
                assert_eq!(blocks.iter().any(|b| b.name == "interaction"), row);
            }
        }
        assert_eq!(layout(&Params::default(), "dogs"), None);
    }

    #[test]
    fn lidar_noise_is_fixed_by_step_and_agent_and_stays_a_fraction() {
        let layout = Layout { wolves: vec![[1.0, 0.0, 0.0], [0.0, 5.0, 1.0]], targets: vec![[0.0, 0.0, 0.0]], obstacles: vec![] };
        let mut p = Params::default();
        p.world.wolves = 2;
        let exact = World::from_layout(Arc::new(p.clone()), 7, &layout).unwrap();
        p.env.lidar.noise = 0.2;
        let noisy = World::from_layout(Arc::new(p.clone()), 7, &layout).unwrap();
        let d = wolf_dim(&p);
        let lidar_at = d - p.env.lidar.rays..d;
        let observe = |w: &World, i: usize| {
            let mut out = vec![0f32; d];
            observer(w).wolf(w, i, &mut out);
            out
        };
        let (clean, first) = (observe(&exact, 1), observe(&noisy, 1));
        // The target's observation in between: the wolf's noise does not depend on who else was observed.
        observer(&noisy).target(&noisy, 0, &mut vec![0f32; target_dim(&p)]);
        assert_eq!(first, observe(&noisy, 1), "the same step and agent draw the same noise");
        assert_eq!(clean[..lidar_at.start], first[..lidar_at.start], "only the lidar is noisy");
        assert!(first[lidar_at.clone()].iter().all(|r| (0.0..=1.0).contains(r)));
        let moved = clean[lidar_at.clone()].iter().zip(&first[lidar_at.clone()]).filter(|(a, b)| a != b).count();
        assert!(moved >= p.env.lidar.rays / 2, "most readings move ({moved} of {})", p.env.lidar.rays);
        assert_ne!(first[lidar_at.clone()], observe(&noisy, 0)[lidar_at.clone()], "each agent draws its own noise");
        let other_seed = World::from_layout(Arc::new(p), 8, &layout).unwrap();
        assert_ne!(first[lidar_at.clone()], observe(&other_seed, 1)[lidar_at], "each seed draws its own noise");
    }

    #[test]
    fn dimensions_match_the_table() {
        let p = Params::default();
        assert_eq!(wolf_dim(&p), 9 + 5 + 20 + 16);
        assert_eq!(target_dim(&p), 9 + 1 + 25 + 16);
        let mut q = p.clone();
        q.env.interaction_row = true;
        q.env.lidar.rays = 4;
        assert_eq!(wolf_dim(&q), 9 + 5 + 20 + 4 + 6);
    }

    #[test]
    fn wolf_sees_the_target_in_its_own_frame_only_within_range() {
        // Wolf at the origin facing +y; target 2 m ahead (in range), heading −x.
        let half_pi = std::f64::consts::FRAC_PI_2;
        let far = [[0.0, 0.0, half_pi], [5.0, 5.0, 0.0], [-5.0, 5.0, 0.0], [5.0, -5.0, 0.0], [-5.0, -5.0, 0.0]];
        let w = world(far.to_vec(), vec![[0.0, 2.0, std::f64::consts::PI]], vec![]);
        let mut out = vec![9.0f32; wolf_dim(&w.params)];
        observer(&w).wolf(&w, 0, &mut out);
        let t = &out[9..14];
        assert_eq!(t[0], 1.0);
        assert!((t[1] - 2.0 / 3.0).abs() < 1e-6 && t[2].abs() < 1e-6, "{t:?}");
        // Δθ = π − π/2 = π/2: sin 1, cos 0.
        assert!((t[3] - 1.0).abs() < 1e-6 && t[4].abs() < 1e-6, "{t:?}");
        // Wall distances: x = 0 → 0.5 each; clock 0.
        assert_eq!(&out[4..9], &[0.5, 0.5, 0.5, 0.5, 0.0]);
        // Move the target out of range: the whole block is zero.
        let w = world(far.to_vec(), vec![[0.0, 3.5, 0.0]], vec![]);
        observer(&w).wolf(&w, 0, &mut out);
        assert_eq!(&out[9..14], &[0.0; 5]);
    }

    #[test]
    fn other_wolves_are_sorted_by_distance() {
        // The target at (4, 2) is within r_w = 3 of wolf 1 only (2 m; wolf 2 is 3.61 m away).
        let w = world(vec![[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, -2.0, 0.0], [-8.0, 0.0, 0.0]], vec![[4.0, 2.0, 0.0]], vec![]);
        let mut out = vec![0f32; wolf_dim(&w.params)];
        observer(&w).wolf(&w, 0, &mut out);
        assert_eq!(&out[9..14], &[0.0; 5], "the observer itself is 4.47 m from the target");
        let xs: Vec<(f32, f32)> = (0..4).map(|k| (out[15 + 5 * k] * 20.0, out[16 + 5 * k] * 20.0)).collect();
        let want = [(1.0, 0.0), (0.0, -2.0), (4.0, 0.0), (-8.0, 0.0)];
        for (g, w) in xs.iter().zip(want) {
            assert!((g.0 - w.0).abs() < 1e-5 && (g.1 - w.1).abs() < 1e-5, "{xs:?}");
        }
        let senses: Vec<f32> = (0..4).map(|k| out[14 + 5 * k]).collect();
        assert_eq!(senses, [0.0, 0.0, 1.0, 0.0], "only wolf 1 (third nearest) senses the target");
    }

    #[test]
    fn target_masks_wolves_out_of_range() {
        let w = world(vec![[1.0, 0.0, 0.0], [0.0, 5.0, 0.0]], vec![[0.0, 0.0, 0.0]], vec![]);
        let mut out = vec![0f32; target_dim(&w.params)];
        observer(&w).target(&w, 0, &mut out);
        assert_eq!(out[9], 1.0, "no sighting yet: no fatigue cap");
        assert_eq!(&out[10..15], &[1.0, 1.0 / 3.0, 0.0, 0.0, 1.0]);
        assert_eq!(&out[15..20], &[0.0; 5]);
    }

    #[test]
    fn lidar_reads_walls_circles_and_polygons() {
        // Wolf at (8.5, 0) facing +x: the wall is 1.5 ahead. A circle of radius 0.5 centred 2 m
        // behind it (−x): surface at 1.5. A square polygon 1 m to the left (+y), edge at 1.0.
        let square = LayoutObstacle::Polygon { center: [8.5, 2.0], vertices: vec![[8.0, 1.0], [9.0, 1.0], [9.0, 3.0], [8.0, 3.0]], moving: false };
        let circle = LayoutObstacle::Circle { center: [6.5, 0.0], radius: 0.5, moving: false };
        let w = world(vec![[8.5, 0.0, 0.0]], vec![[0.0, -6.0, 0.0]], vec![square, circle]);
        let mut p = (*w.params).clone();
        p.env.lidar.rays = 4;
        let mut out = [0f32; 4];
        lidar(&p, &w.wolves[0], &w.obstacles, &mut out);
        let want = [1.5 / 3.0, 1.0 / 3.0, 1.5 / 3.0, 1.0];
        for (g, w) in out.iter().zip(want) {
            assert!((*g as f64 - w).abs() < 1e-6, "{out:?}");
        }
    }

    use parry2d_f64::bounding_volume::Aabb;
    use parry2d_f64::query::{Ray, RayCast};
    use parry2d_f64::shape::{Ball, Segment};

    use crate::math::Point2;

    /// The reference: parry's casts (`Ball` solid, each edge's `Segment`, the arena's `Aabb`
    /// from inside), which the lidar used before its direct formulas.
    fn parry_ray_obstacle(ob: &Obstacle, ray: &Ray, max: f64) -> Option<f64> {
        if !ob.is_polygon() {
            let local = Ray::new(ray.origin - ob.center, ray.dir);
            return Ball::new(ob.radius).cast_local_ray(&local, max, true);
        }
        if crate::geometry::polygon_contains(&ob.vertices, ray.origin.coords) {
            return Some(0.0);
        }
        let v = &ob.vertices;
        let mut best: Option<f64> = None;
        for e in 0..v.len() {
            let seg = Segment::new(Point2::from(v[e]), Point2::from(v[(e + 1) % v.len()]));
            if let Some(t) = seg.cast_local_ray(ray, best.unwrap_or(max), true) {
                best = Some(best.map_or(t, |b| b.min(t)));
            }
        }
        best
    }

    /// The direct ray formulas agree with parry's casts to 1e-9 m, hit for hit.
    #[test]
    fn direct_ray_casts_match_parry() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let shapes = crate::config::ObstacleParams::default();
        let border = [-10.0, -10.0, 10.0, 10.0];
        let arena = Aabb::new(Point2::new(-10.0, -10.0), Point2::new(10.0, 10.0));
        let (mut hits, mut inside) = (0, 0);
        for k in 0..20000 {
            let ob = if k % 3 == 0 {
                Obstacle::circle(Vec2::new(rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0)), rng.random_range(0.1..1.5), false)
            } else {
                let c = Vec2::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
                Obstacle::random_polygon(&mut rng, c, false, &shapes)
            };
            let o = Vec2::new(rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0));
            let d = unit(rng.random_range(0.0..std::f64::consts::TAU));
            let max = rng.random_range(0.5..4.0);
            let ray = Ray::new(Point2::from(o), d);
            let (got, want) = (ray_obstacle(&ob, o, d, max), parry_ray_obstacle(&ob, &ray, max));
            match (got, want) {
                (Some(g), Some(w)) => {
                    assert!((g - w).abs() < 1e-9, "{k}: {g} vs {w}");
                    hits += 1;
                    inside += usize::from(w == 0.0);
                }
                (None, None) => {}
                _ => panic!("{k}: {got:?} vs {want:?} ({ob:?}, o {o:?}, d {d:?}, max {max})"),
            }
            let walls = arena.cast_local_ray(&ray, 100.0, false).unwrap();
            assert!((ray_walls(o, d, &border) - walls).abs() < 1e-9, "{k}");
        }
        assert!(hits > 2000 && inside > 500, "{hits} hits, {inside} from inside");
    }

    /// The lidar's edge filter never changes a cast: on random polygons, with rays aimed at
    /// random points, at vertices (grazing) and along edges, the filtered cast equals the
    /// exact one bit for bit.
    #[test]
    fn filtered_polygon_casts_equal_the_exact_ones() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        let shapes = crate::config::ObstacleParams::default();
        let mut hits = 0;
        for k in 0..30000 {
            let c = Vec2::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            let ob = Obstacle::random_polygon(&mut rng, c, false, &shapes);
            let v = &ob.vertices;
            let o = Vec2::new(rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0));
            let aim = match k % 3 {
                0 => c + Vec2::new(rng.random_range(-1.5..1.5), rng.random_range(-1.5..1.5)),
                1 => v[rng.random_range(0..v.len())],
                _ => {
                    let i = rng.random_range(0..v.len());
                    v[i] + (v[(i + 1) % v.len()] - v[i]) * rng.random_range(0.0..1.0)
                }
            };
            if (aim - o).norm() < 1e-6 {
                continue;
            }
            let d = (aim - o).normalize();
            let max = rng.random_range(0.5..8.0);
            let tol = edge_filter_tolerance((c - o).norm() + ob.radius);
            let exact = ray_polygon_boundary(v, o, d, max);
            let filtered = ray_polygon_boundary_filtered(v, tol, o, d, max);
            assert_eq!(exact.map(f64::to_bits), filtered.map(f64::to_bits), "{k}: {exact:?} vs {filtered:?}");
            hits += usize::from(exact.is_some());
        }
        assert!(hits > 10000, "{hits} hits");
    }

    /// The culled lidar equals casting every ray against every obstacle with parry.
    #[test]
    fn culled_lidar_equals_brute_force() {
        let mut p = Params::default();
        p.env.lidar.rays = 37;
        let p = Arc::new(p);
        for seed in 0..40 {
            let mut w = World::new(p.clone(), seed).unwrap();
            for _ in 0..(seed % 7) * 10 {
                w.step();
            }
            for a in w.wolves.iter().chain(&w.targets) {
                let mut fast = vec![0f32; 37];
                lidar(&p, a, &w.obstacles, &mut fast);
                let [x0, y0, x1, y1] = p.world.border;
                let arena = Aabb::new(Point2::new(x0, y0), Point2::new(x1, y1));
                for (k, f) in fast.iter().enumerate() {
                    let ray = Ray::new(Point2::from(a.pos), unit(a.theta + std::f64::consts::TAU * k as f64 / 37.0));
                    let mut best = arena.cast_local_ray(&ray, 3.0, false).unwrap_or(3.0);
                    for ob in &w.obstacles {
                        if let Some(t) = parry_ray_obstacle(ob, &ray, 3.0) {
                            best = best.min(t);
                        }
                    }
                    // Directions differ from `unit(θ + k·step)` by rounding only (~1e-15).
                    assert!((*f - (best / 3.0).clamp(0.0, 1.0) as f32).abs() < 1e-5, "seed {seed} ray {k}: {f} vs {best}");
                }
            }
        }
    }
}
