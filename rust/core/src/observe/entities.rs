//! Entity observations (`env.observation: entities`): the agent's own features, then a padded
//! set of entity rows with a mask, so that the observation's size follows the capacities of
//! `env.entities` and not the team sizes or the obstacle count (docs/interface.md, "Entity
//! observations").
//!
//! Own features: the shared block (speed, turn rate, heading, walls, clock), the target's
//! fatigue cap (targets only) and the lidar. Then the rows, each [`ROW`] entries named by
//! [`FIELDS`], in blocks of fixed capacity:
//!
//! | block | rows (wolf observer) | rows (target observer) | a row is present when |
//! |---|---|---|---|
//! | `wolf_rows` | `max_wolves − 1`, every other wolf, nearest first | `max_wolves`, nearest first | wolves: always (global communication); targets: the wolf is within its sensing radius |
//! | `target_rows` | `max_targets`, by index | `max_targets − 1`, the others by index | wolves: it senses the target now, or the pack has sighted it before (then the row is that sighting); targets: within its sensing radius |
//! | `obstacle_rows` | `max_obstacles` | same | its surface lies within `env.entities.range`; nearest first, the rest left out |
//! | `wall_rows` | 4 | 4 | always: x_min, x_max, y_min, y_max |
//!
//! A row that is not present is all zeros (`present` = 0). Positions are those of the entity's
//! point nearest the observer (an agent's centre; an obstacle's nearest surface point, the
//! observer's own position from inside; a wall's foot of the perpendicular) in the observer's
//! frame (x ahead, y left), in units of [`SCALE`] metres — a fixed length, not the arena's,
//! so that a policy reads distances alike in every arena. Velocities are in the observer's
//! frame in units of the observer's own `v_max`. Obstacle drift is drawn afresh every step
//! (white noise), so an obstacle row says whether it moves, not how.

use crate::config::{ObservationKind, Params};
use crate::math::Vec2;
use crate::world::{AgentState, World};

/// The entries of one entity row, in order.
pub const FIELDS: [&str; 18] = [
    "present",
    "wolf",
    "target",
    "obstacle",
    "wall", // the mask, then the type (one-hot)
    "x",
    "y",
    "distance", // the nearest point, in the observer's frame, / SCALE
    "sin_heading",
    "cos_heading", // an agent's heading relative to the observer's
    "vx",
    "vy",      // an agent's velocity in the observer's frame / the observer's v_max
    "extent",  // an obstacle's bounding radius / SCALE
    "sensing", // wolf rows: that wolf senses a target now; target rows: the observer senses it now
    "age",     // target rows seen through the pack's last sighting: its age / max_steps
    "ended",   // target rows: that target's hunt is over (captured)
    "moving",
    "polygon", // obstacle rows: it drifts; it is a polygon (else a circle)
];

/// Entries in one entity row.
pub const ROW: usize = FIELDS.len();

/// Metres per unit of the rows' positions, distances and extents.
pub const SCALE: f64 = 10.0;

/// Wall rows: the arena's four walls close every entity observation, in the order x_min,
/// x_max, y_min, y_max.
pub const WALLS: usize = 4;

const WOLF: usize = 1;
const TARGET: usize = 2;
const OBSTACLE: usize = 3;
const WALL: usize = 4;

/// Whether `side` ("wolves" or "targets") observes entity rows under these params.
pub fn side_uses_entities(p: &Params, side: &str) -> bool {
    let kind = if side == "wolves" { p.env.wolf_observation_kind() } else { p.env.target_observation_kind() };
    kind == ObservationKind::Entities
}

/// Row capacities of `side`'s blocks: (wolf rows, target rows, obstacle rows, wall rows).
pub fn capacities(p: &Params, side: &str) -> (usize, usize, usize, usize) {
    let e = &p.env.entities;
    if side == "wolves" {
        (e.max_wolves - 1, e.max_targets, e.max_obstacles, WALLS)
    } else {
        (e.max_wolves, e.max_targets - 1, e.max_obstacles, WALLS)
    }
}

/// The scratch an entity observation needs, kept between calls so that observing allocates
/// nothing after the first world.
#[derive(Debug, Clone, Default)]
pub(super) struct EntityScratch {
    /// (surface distance, obstacle index, nearest point) of the obstacles within range.
    near: Vec<(f64, usize, Vec2)>,
}

/// One row: `kind` one-hot, the point `d` (world frame, relative to the observer) turned into
/// the observer's frame, and the remaining fields from `heading` on.
struct RowWriter<'a> {
    out: &'a mut [f32],
    k: usize,
    /// sin, cos of the observer's heading.
    frame: (f64, f64),
}

impl RowWriter<'_> {
    /// Writes the next row; `rest` is `FIELDS[8..]` (sin_heading … polygon).
    fn put(&mut self, kind: usize, d: Vec2, rest: [f64; ROW - 8]) {
        let (s, c) = self.frame;
        let row = &mut self.out[self.k..self.k + ROW];
        row[..5].fill(0.0);
        row[0] = 1.0;
        row[kind] = 1.0;
        let (x, y) = ((c * d.x + s * d.y) / SCALE, (-s * d.x + c * d.y) / SCALE);
        row[5] = x as f32;
        row[6] = y as f32;
        row[7] = (d.norm() / SCALE) as f32;
        for (o, v) in row[8..].iter_mut().zip(rest) {
            *o = v as f32;
        }
        self.k += ROW;
    }

    /// Zero rows up to the end of a block of `rows` rows that started at `start`.
    fn pad_to(&mut self, start: usize, rows: usize) {
        let end = start + rows * ROW;
        self.out[self.k..end].fill(0.0);
        self.k = end;
    }
}

/// The fields of an agent row from sensing on: heading, velocity, no extent, and the flags.
fn agent_fields(other: &AgentState, (s, c): (f64, f64), (so, co): (f64, f64), v_scale: f64, sensing: bool, ended: bool) -> [f64; ROW - 8] {
    let (ds, dc) = (so * c - co * s, co * c + so * s);
    let v = other.v * v_scale;
    [ds, dc, v * dc, v * ds, 0.0, f64::from(u8::from(sensing)), 0.0, f64::from(u8::from(ended)), 0.0, 0.0]
}

impl super::Observer {
    /// Wolf `i`'s entity observation into `out` (length [`super::wolf_dim`]).
    pub(super) fn wolf_entities(&mut self, w: &World, i: usize, out: &mut [f32]) {
        let p = &*w.params;
        let me = w.wolves[i];
        let mine = self.trig[i];
        let mut k = super::common(p, w.t, &me, mine, p.agents.wolf.v_max, p.agents.wolf.omega_max, out);
        k += self.lidar_into(w, &me, mine, i, &mut out[k..]);
        let (cw, ct, co, _) = capacities(p, "wolves");
        let r = p.agents.wolf.sense_radius;
        let v_scale = 1.0 / p.agents.wolf.v_max;
        let n = w.n_wolves();
        let mut rows = RowWriter { out, k, frame: mine };

        let start = rows.k;
        self.sort_by_distance(me.pos, &w.wolves, Some(i));
        for &(_, j) in &self.by_distance {
            let partner = w.wolves[j].pos;
            let senses = w.targets.iter().any(|t| (t.pos - partner).norm() <= r);
            rows.put(WOLF, partner - me.pos, agent_fields(&w.wolves[j], mine, self.trig[j], v_scale, senses, false));
        }
        rows.pad_to(start, cw);

        let start = rows.k;
        for (j, t) in w.targets.iter().enumerate() {
            let ended = w.target_captured[j];
            if (t.pos - me.pos).norm() <= r {
                rows.put(TARGET, t.pos - me.pos, agent_fields(t, mine, self.trig[n + j], v_scale, true, ended));
            } else if let Some((pos, at)) = w.target_last_sighting[j] {
                let age = f64::from(w.t - at) / f64::from(p.world.max_steps);
                rows.put(TARGET, pos - me.pos, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, age, f64::from(u8::from(ended)), 0.0, 0.0]);
            }
        }
        rows.pad_to(start, ct);

        self.obstacle_rows(w, me.pos, &mut rows, co);
        wall_rows(p, me.pos, &mut rows);
    }

    /// Target `j`'s entity observation into `out` (length [`super::target_dim`]).
    pub(super) fn target_entities(&mut self, w: &World, j: usize, out: &mut [f32]) {
        let p = &*w.params;
        let me = w.targets[j];
        let side = &p.agents.target;
        let n = w.n_wolves();
        let mine = self.trig[n + j];
        let mut k = super::common(p, w.t, &me, mine, side.v_max, side.omega_max, out);
        out[k] = super::speed_cap(w, j) as f32;
        k += 1;
        k += self.lidar_into(w, &me, mine, n + j, &mut out[k..]);
        let (cw, ct, co, _) = capacities(p, "targets");
        let r = side.sense_radius;
        let v_scale = 1.0 / side.v_max;
        let mut rows = RowWriter { out, k, frame: mine };

        let start = rows.k;
        self.sort_by_distance(me.pos, &w.wolves, None);
        for &(d, i) in &self.by_distance {
            if d > r {
                break; // nearest first: the rest are farther still
            }
            rows.put(WOLF, w.wolves[i].pos - me.pos, agent_fields(&w.wolves[i], mine, self.trig[i], v_scale, false, false));
        }
        rows.pad_to(start, cw);

        let start = rows.k;
        for (o, t) in w.targets.iter().enumerate() {
            if o != j && (t.pos - me.pos).norm() <= r {
                rows.put(TARGET, t.pos - me.pos, agent_fields(t, mine, self.trig[n + o], v_scale, true, w.target_captured[o]));
            }
        }
        rows.pad_to(start, ct);

        self.obstacle_rows(w, me.pos, &mut rows, co);
        wall_rows(p, me.pos, &mut rows);
    }

    /// The `capacity` nearest obstacles whose surface lies within `env.entities.range` of
    /// `from`, nearest first (ties: lower index), then padding.
    fn obstacle_rows(&mut self, w: &World, from: Vec2, rows: &mut RowWriter<'_>, capacity: usize) {
        let range = w.params.env.entities.range;
        let near = &mut self.entities.near;
        near.clear();
        for (k, ob) in w.obstacles.iter().enumerate() {
            if (ob.center - from).norm() - ob.radius > range {
                continue; // the bounding disc is out of range, so is the shape
            }
            let (point, d) = ob.nearest_point(from);
            if d <= range {
                near.push((d, k, point));
            }
        }
        near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let start = rows.k;
        for &(_, k, point) in near.iter().take(capacity) {
            let ob = &w.obstacles[k];
            let flag = |b: bool| f64::from(u8::from(b));
            rows.put(OBSTACLE, point - from, [0.0, 0.0, 0.0, 0.0, ob.radius / SCALE, 0.0, 0.0, 0.0, flag(ob.kind.is_moving()), flag(ob.is_polygon())]);
        }
        rows.pad_to(start, capacity);
    }
}

/// The four walls' nearest points: x_min, x_max, y_min, y_max.
fn wall_rows(p: &Params, from: Vec2, rows: &mut RowWriter<'_>) {
    let [x0, y0, x1, y1] = p.world.border;
    let feet: [Vec2; WALLS] = [Vec2::new(x0, from.y), Vec2::new(x1, from.y), Vec2::new(from.x, y0), Vec2::new(from.x, y1)];
    for foot in feet {
        rows.put(WALL, foot - from, [0.0; ROW - 8]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::{layout, target_dim, wolf_dim, Observer};
    use crate::world::{Layout, LayoutObstacle};
    use std::sync::Arc;

    fn entity_params(wolves: usize, targets: usize) -> Params {
        let mut p = Params::default();
        p.env.observation = ObservationKind::Entities;
        p.world.wolves = wolves;
        p.world.targets = targets;
        p
    }

    fn observe(w: &World, side: &str, k: usize) -> Vec<f32> {
        let mut o = Observer::default();
        o.prepare(w);
        let mut out = vec![f32::NAN; if side == "wolves" { wolf_dim(&w.params) } else { target_dim(&w.params) }];
        if side == "wolves" {
            o.wolf(w, k, &mut out);
        } else {
            o.target(w, k, &mut out);
        }
        out
    }

    /// The rows of block `name` of `side`'s observation `obs`.
    fn rows<'a>(p: &Params, side: &str, obs: &'a [f32], name: &str) -> Vec<&'a [f32]> {
        let b = layout(p, side).unwrap().into_iter().find(|b| b.name == name).unwrap();
        obs[b.start..b.start + b.len].chunks(ROW).collect()
    }

    #[test]
    fn the_size_follows_the_capacities_not_the_teams() {
        let sizes: Vec<(usize, usize)> = [(3, 1), (5, 1), (8, 3)].iter().map(|&(n, m)| (wolf_dim(&entity_params(n, m)), target_dim(&entity_params(n, m)))).collect();
        assert!(sizes.windows(2).all(|s| s[0] == s[1]), "{sizes:?}");
        let p = entity_params(5, 1);
        let rows = |side| layout(&p, side).unwrap().iter().map(|b| b.rows).sum::<usize>();
        assert_eq!((rows("wolves"), rows("targets")), (7 + 3 + 8 + 4, 8 + 2 + 8 + 4));
        assert_eq!(wolf_dim(&p), 9 + 16 + 22 * ROW);
        assert_eq!(target_dim(&p), 10 + 16 + 22 * ROW);
        let mut q = p.clone();
        q.env.wolf_observation = Some(ObservationKind::Flat);
        assert_eq!(wolf_dim(&q), wolf_dim(&Params::default()), "a side can keep the flat layout");
        assert_eq!(target_dim(&q), target_dim(&p));
    }

    #[test]
    fn capacities_below_the_scenario_and_the_interaction_row_are_refused() {
        let mut p = entity_params(9, 1);
        assert!(p.validate().unwrap_err().to_string().contains("env.entities.max_wolves"));
        p.world.wolves = 5;
        p.world.targets = 4;
        assert!(p.validate().unwrap_err().to_string().contains("env.entities.max_targets"));
        p.world.targets = 1;
        p.validate().unwrap();
        p.env.interaction_row = true;
        assert!(p.validate().unwrap_err().to_string().contains("env.interaction_row"));
    }

    /// A world laid out by hand, its rows checked entry by entry.
    #[test]
    fn rows_by_hand() {
        let half_pi = std::f64::consts::FRAC_PI_2;
        // Wolf 0 at the origin facing +y (ahead = +y, left = −x). Wolf 1 4 m to its right,
        // heading +x; wolf 2 far away. The target 2 m ahead (within r_w = 3), heading −x.
        // A circle of radius 1 centred 3 m behind it: its nearest point 2 m behind.
        let l = Layout {
            wolves: vec![[0.0, 0.0, half_pi], [4.0, 0.0, 0.0], [-8.0, -8.0, 0.0]],
            targets: vec![[0.0, 2.0, std::f64::consts::PI]],
            obstacles: vec![LayoutObstacle::Circle { center: [0.0, -3.0], radius: 1.0, moving: true }],
        };
        let p = entity_params(3, 1);
        let w = World::from_layout(Arc::new(p), 0, &l).unwrap();
        let p = w.params.clone();
        let obs = observe(&w, "wolves", 0);
        assert!(obs.iter().all(|x| x.is_finite()));
        let near = |a: &[f32], b: &[f64]| a.iter().zip(b).all(|(x, y)| (f64::from(*x) - y).abs() < 1e-6);
        let wolves = rows(&p, "wolves", &obs, "wolf_rows");
        assert_eq!(wolves.len(), 7);
        // Wolf 1: 4 m to the right = (ahead 0, left −4); heading 0 − π/2: sin −1, cos 0.
        assert!(near(wolves[0], &[1.0, 1.0, 0.0, 0.0, 0.0, 0.0, -0.4, 0.4, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]), "{:?}", wolves[0]);
        assert_eq!(wolves[1][0], 1.0, "the far wolf is present too (global communication)");
        assert!(wolves[2..].iter().all(|r| r.iter().all(|&x| x == 0.0)), "padding is all zero");
        let targets = rows(&p, "wolves", &obs, "target_rows");
        // 2 m ahead, heading π − π/2: sin 1, cos 0; sensed now.
        assert!(near(targets[0], &[1.0, 0.0, 1.0, 0.0, 0.0, 0.2, 0.0, 0.2, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]), "{:?}", targets[0]);
        let obstacles = rows(&p, "wolves", &obs, "obstacle_rows");
        assert!(near(obstacles[0], &[1.0, 0.0, 0.0, 1.0, 0.0, -0.2, 0.0, 0.2, 0.0, 0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 1.0, 0.0]), "{:?}", obstacles[0]);
        assert_eq!(obstacles[1][0], 0.0);
        // Walls of the [-10, 10]² arena from the origin facing +y: x_min 10 m to the left.
        let walls = rows(&p, "wolves", &obs, "wall_rows");
        for (row, (x, y)) in walls.iter().zip([(0.0, 1.0), (0.0, -1.0), (-1.0, 0.0), (1.0, 0.0)]) {
            assert!(near(&row[..8], &[1.0, 0.0, 0.0, 0.0, 1.0, x, y, 1.0]), "{row:?}");
        }
        // The target (facing −x, so its left is −y) senses wolf 0 (2 m to its left) only: r_t = 3.
        let tobs = observe(&w, "targets", 0);
        let seen = rows(&p, "targets", &tobs, "wolf_rows");
        assert_eq!(seen.iter().filter(|r| r[0] == 1.0).count(), 1);
        assert!(near(&seen[0][..8], &[1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.2, 0.2]), "{:?}", seen[0]);
    }

    /// A target no wolf senses is shown where the pack last sighted it, with its age; before
    /// any sighting it has no row.
    #[test]
    fn unsensed_targets_are_the_packs_last_sighting() {
        let l = Layout { wolves: vec![[0.0, 0.0, 0.0], [5.0, 5.0, 0.0]], targets: vec![[2.0, 0.0, 0.0]], obstacles: vec![] };
        let mut p = entity_params(2, 1);
        p.policies.targets = crate::config::TargetPolicy::Still;
        let mut w = World::from_layout(Arc::new(p), 0, &l).unwrap();
        let p = w.params.clone();
        w.step();
        assert!(w.target_last_sighting[0].is_some(), "entity observations keep the sighting");
        let seen_at = w.target_last_sighting[0].unwrap().0;
        // Move the wolves away by hand: nobody senses the target any more.
        w.wolves[0].pos = crate::math::Vec2::new(-8.0, 0.0);
        w.wolves[1].pos = crate::math::Vec2::new(-8.0, 5.0);
        w.t += 30;
        let obs = observe(&w, "wolves", 0);
        let t = rows(&p, "wolves", &obs, "target_rows")[0];
        assert_eq!((t[0], t[2], t[13]), (1.0, 1.0, 0.0), "present, a target, not sensed now");
        let age = f64::from(t[14]) * f64::from(p.world.max_steps);
        assert!((age - 30.0).abs() < 1e-3, "age {age}");
        let x = f64::from(t[5]) * SCALE;
        assert!((x - (seen_at.x + 8.0)).abs() < 1e-5, "{x}");
        let fresh = World::from_layout(Arc::new((*p).clone()), 0, &Layout { wolves: vec![[-8.0, 0.0, 0.0], [-8.0, 5.0, 0.0]], ..l }).unwrap();
        let obs = observe(&fresh, "wolves", 0);
        assert!(rows(&p, "wolves", &obs, "target_rows").iter().all(|r| r[0] == 0.0), "never sighted: no row");
    }

    /// Obstacle rows: within range only, nearest first, truncated at the capacity.
    #[test]
    fn obstacles_nearest_first_within_range() {
        let circle = |x: f64| LayoutObstacle::Circle { center: [x, 0.0], radius: 0.5, moving: false };
        let l = Layout { wolves: vec![[0.0, 0.0, 0.0]], targets: vec![[0.0, 8.0, 0.0]], obstacles: vec![circle(7.0), circle(2.0), circle(-4.0), circle(5.0)] };
        let mut p = entity_params(1, 1);
        p.env.entities.max_obstacles = 2;
        let w = World::from_layout(Arc::new(p), 0, &l).unwrap();
        let p = w.params.clone();
        let obs = observe(&w, "wolves", 0);
        let d: Vec<f64> = rows(&p, "wolves", &obs, "obstacle_rows").iter().map(|r| f64::from(r[7]) * SCALE).collect();
        assert!((d[0] - 1.5).abs() < 1e-5 && (d[1] - 3.5).abs() < 1e-5, "{d:?}");
        let mut wide = (*p).clone();
        wide.env.entities.max_obstacles = 8;
        let w = World::from_layout(Arc::new(wide), 0, &l).unwrap();
        let p = w.params.clone();
        let obs = observe(&w, "wolves", 0);
        let present = rows(&p, "wolves", &obs, "obstacle_rows").iter().filter(|r| r[0] == 1.0).count();
        assert_eq!(present, 3, "the circle 6.5 m away is beyond the 5 m range");
    }
}
