//! One synchronous step (docs/world-and-laws.md §1.6): obstacles move; every controller reads the
//! same snapshot; agents move through the feasibility filter; outcomes; the clock advances.

use parry2d_f64::transformation::convex_hull;
use rand_chacha::ChaCha8Rng;

use super::{AgentState, Outcome, World};
use crate::config::{CaptureRule, Params, SideParams, WolfPolicy};
use crate::geometry::{triangle_contains, triangles_overlap, BodyFrame};
use crate::math::{wrap, Point2, Vec2};
use crate::scene::{Command, LawMode, Snapshot, TargetMemory, WolfMemory};

/// What a step's controllers read (the snapshot) and write, borrowed apart from the world
/// ([`World::controls`]).
pub(crate) struct Controls<'a> {
    pub snap: Snapshot<'a>,
    pub wolf_memory: &'a mut [WolfMemory],
    pub target_memory: &'a mut [TargetMemory],
    pub wolf_cmds: &'a mut [Command],
    pub target_cmds: &'a mut [Command],
    /// The interaction matrix, (N+M)² row-major: a law marks the agents whose information it used.
    pub interaction: &'a mut [u8],
    /// A row for a law that runs only to keep its memory (`track_laws`), whose marks are dropped.
    pub scratch_row: &'a mut [u8],
    /// The branch of each agent's law that decided its command ([`World::wolf_mode`]).
    pub wolf_mode: &'a mut [LawMode],
    pub target_mode: &'a mut [LawMode],
    pub rng_policy: &'a mut ChaCha8Rng,
    pub track_laws: bool,
}

/// A speed reached by halving below this stops the wolf: it only turns (§1.6). A
/// commanded speed below it is made as commanded when feasible.
const MIN_HALVED_SPEED: f64 = 0.01;

impl World {
    /// The first stage of a step (§1.6 steps 1–2, up to the controllers): obstacles move,
    /// the step's near lists, then target assignment and sensing. False, and nothing moves,
    /// when the world is done. The controllers come next ([`World::controls`]), then
    /// [`World::finish_step`]; `crate::pipeline` runs the three.
    pub(crate) fn begin_step(&mut self) -> bool {
        if self.is_done() {
            return false;
        }
        // 1. Obstacles move.
        self.move_obstacles();
        let cut = super::cull_distance(&self.params);
        self.near.build(self.wolves.iter().chain(&self.targets).map(|a| a.pos), &self.obstacles, cut);
        if self.lazy_obstacles {
            self.place_reachable_obstacles();
        }
        // 2. Assignment and sensing: what the snapshot every controller reads holds.
        self.sense();
        true
    }

    /// What the controllers of a step read and write: the snapshot, and the laws' memories,
    /// random stream, command buffers and interaction rows, borrowed apart.
    pub(crate) fn controls(&mut self) -> Controls<'_> {
        Controls {
            snap: Snapshot {
                params: &self.params,
                t: self.t,
                wolves: &self.wolves,
                targets: &self.targets,
                obstacles: &self.obstacles,
                near: Some(&self.near),
                wolf_target: &self.wolf_target,
                wolf_senses: &self.wolf_senses,
                target_seen_at: &self.target_seen_at,
                target_captured: &self.target_captured,
            },
            wolf_memory: &mut self.wolf_memory,
            target_memory: &mut self.target_memory,
            wolf_cmds: &mut self.wolf_cmds,
            target_cmds: &mut self.target_cmds,
            interaction: &mut self.interaction,
            scratch_row: &mut self.scratch_row,
            wolf_mode: &mut self.wolf_mode,
            target_mode: &mut self.target_mode,
            rng_policy: &mut self.rng_policy,
            track_laws: self.track_laws,
        }
    }

    /// The last stage of a step (§1.6 steps 3–4), once the controllers have written this
    /// step's commands: moves through the feasibility filter, outcomes, the clock.
    /// `wolves_given` / `targets_given` say which sides were driven by given commands (for the
    /// fault message of a non-finite one).
    pub(crate) fn finish_step(&mut self, wolves_given: bool, targets_given: bool) -> Outcome {
        // A non-finite command would never leave the feasibility filter's halving loop (inf
        // halves to inf, NaN compares false) and would poison every later number: stop here.
        if let Some(fault) = self.non_finite_command(wolves_given, targets_given) {
            self.fault = Some(fault);
            return self.outcome;
        }
        // 3. Moves through the feasibility filter: wolves in index order, then targets.
        self.move_wolves();
        self.move_targets();
        // 4. Outcomes.
        self.t += 1;
        self.judge();
        self.note_sightings();
        if let Some(fault) = self.non_finite_state() {
            self.fault = Some(fault);
        }
        self.outcome
    }

    // The phases below are kept out of line: each runs once per step, and callgrind profiles
    // (BENCHMARKS.md) attribute the step's cost to them by name.
    #[inline(never)]
    fn move_obstacles(&mut self) {
        let p = &*self.params;
        for o in &mut self.obstacles {
            if self.lazy_obstacles {
                o.advance_pose(&mut self.rng_motion, &p.obstacles, p.world.ts, &p.world.border);
            } else {
                o.advance(&mut self.rng_motion, &p.obstacles, p.world.ts, &p.world.border);
            }
        }
    }

    /// With `lazy_obstacles`: places the polygons in some agent's near list, which are all the
    /// seed000 and target laws, the feasibility filter and the judge read; every polygon for
    /// the wolf laws that look at all obstacles.
    #[inline(never)]
    fn place_reachable_obstacles(&mut self) {
        if self.params.policies.wolves == WolfPolicy::Seed000 {
            for &k in self.near.all() {
                self.obstacles[k as usize].ensure_placed();
            }
        } else {
            self.settle_obstacles();
        }
    }

    /// The first agent whose command this step is not finite, as a one-line message naming
    /// who computed it.
    fn non_finite_command(&self, wolves_given: bool, targets_given: bool) -> Option<String> {
        let p = &self.params;
        let sides = [("wolf", &self.wolf_cmds, wolves_given, p.policies.wolves.as_str()), ("target", &self.target_cmds, targets_given, p.policies.targets.as_str())];
        for (side, cmds, given, law) in sides {
            if let Some((i, c)) = cmds.iter().enumerate().find(|(_, c)| !(c.v.is_finite() && c.omega.is_finite())) {
                let (who, why) = if given {
                    ("the given commands".to_string(), "")
                } else {
                    (format!("the {law}{} law", if side == "target" { " target" } else { "" }), ": its parameters make the arithmetic overflow here; bring them closer to the documented values")
                };
                return Some(format!("{who} produced a non-finite command for {side} {i} at step {} (v = {}, omega = {}){why}", self.t, c.v, c.omega));
            }
        }
        None
    }

    /// Defence in depth after the move: inside the documented ranges every pose and energy
    /// stays finite, so this names a bug or an unforeseen overflow instead of passing NaN on.
    fn non_finite_state(&self) -> Option<String> {
        let bad = |a: &AgentState| !(a.pos.x.is_finite() && a.pos.y.is_finite() && a.theta.is_finite() && a.energy.is_finite());
        if let Some(i) = self.wolves.iter().position(bad) {
            return Some(format!("wolf {i}'s state became non-finite at step {} (law {})", self.t, self.params.policies.wolves.as_str()));
        }
        if let Some(j) = self.targets.iter().position(bad) {
            return Some(format!("target {j}'s state became non-finite at step {} (law {})", self.t, self.params.policies.targets.as_str()));
        }
        if let Some(k) = self.obstacles.iter().position(|o| !(o.center.x.is_finite() && o.center.y.is_finite() && o.angle.is_finite())) {
            return Some(format!("obstacle {k}'s pose became non-finite at step {}", self.t));
        }
        None
    }

    /// Each wolf hunts its nearest uncaptured target (ties: lowest index).
    pub(super) fn assign_targets(&mut self) {
        nearest_uncaptured(&self.wolves, &self.targets, &self.target_captured, &mut self.wolf_target);
    }

    /// With `env.last_sighting` or entity observations for the wolves (whose target rows show
    /// the sighting), records where each target stands now if any wolf senses it (distance ≤
    /// r_w, the sensing of the observations).
    pub(super) fn note_sightings(&mut self) {
        let env = &self.params.env;
        if !env.last_sighting && env.wolf_observation_kind() != crate::config::ObservationKind::Entities {
            return;
        }
        let r = self.params.agents.wolf.sense_radius;
        for (j, t) in self.targets.iter().enumerate() {
            if self.wolves.iter().any(|w| (t.pos - w.pos).norm() <= r) {
                self.target_last_sighting[j] = Some((t.pos, self.t));
            }
        }
    }

    /// Target assignment, sensing flags, first sightings and the sensing entries of the
    /// interaction matrix, for the step about to be taken.
    #[inline(never)]
    fn sense(&mut self) {
        sense_into(&self.params, self.t, &self.wolves, &self.targets, &self.target_captured, &mut self.wolf_target, &mut self.wolf_senses, &mut self.target_seen_at, &mut self.interaction);
    }

    #[inline(never)]
    fn move_wolves(&mut self) {
        // A borrow, not an Arc clone: every world of a batch shares one Params, and its
        // reference count is one cache line that threads stepping worlds would fight over.
        let p = &*self.params;
        let b = &p.agents.body;
        let ts = p.world.ts;
        // The bodies the last step left are those of the current poses, unless someone moved a
        // wolf in between (tests, layouts).
        let n = self.wolves.len();
        self.wolf_bodies.sync(&self.wolves, b.base, b.height);
        for i in 0..n {
            let cmd = clamp(self.wolf_cmds[i], &p.agents.wolf);
            let w = self.wolves[i];
            let mut theta = wrap(w.theta + cmd.omega * ts);
            let mut omega = cmd.omega;
            let mut v = cmd.v;
            // The direction of travel is the last step's `unit(θ)` (kept with the body), and
            // the new body takes one sin_cos whatever the number of halvings.
            let dir = self.wolf_bodies.dir(i);
            let mut frame = BodyFrame::new(theta, b.base, b.height);
            if p.world.feasibility_filter {
                // docs/world-and-laws.md §1.6: a move feasible as commanded is made as commanded,
                // however small its v; only a speed reached by halving is floored at 0.01.
                loop {
                    let pos = w.pos + dir * (v * ts);
                    if self.wolf_pose_feasible(i, pos, &frame) {
                        break;
                    }
                    v *= 0.5;
                    if v < MIN_HALVED_SPEED {
                        v = 0.0;
                        // §1.6: below 0.01 it stands and only turns. A turn on the spot that would
                        // itself touch a wolf or an obstacle is not made either (the reference let
                        // it happen; every wolf–wolf collision measured here came from one).
                        if omega != 0.0 && !self.wolf_pose_feasible(i, w.pos, &frame) {
                            let unturned = BodyFrame::new(w.theta, b.base, b.height);
                            if self.wolf_pose_feasible(i, w.pos, &unturned) {
                                theta = w.theta;
                                omega = 0.0;
                                frame = unturned;
                            }
                        }
                        break;
                    }
                }
            }
            let mut pos = w.pos + dir * (v * ts);
            if !inside(pos, &p.world.border) {
                // Without the filter the walls still hold (nothing leaves the arena, whose walls
                // every observation and law assume): the move is not made, the wolf only turns.
                v = 0.0;
                pos = w.pos;
            }
            let mass = p.agents.wolf.mass;
            self.wolves[i] = AgentState { pos, theta, v, omega, energy: w.energy + 0.5 * mass * v * v };
            self.wolf_bodies.set(i, pos, theta, &frame);
        }
    }

    /// New pose strictly inside the border, body clear of obstacles and of the other wolves'
    /// current bodies.
    fn wolf_pose_feasible(&self, i: usize, pos: Vec2, frame: &BodyFrame) -> bool {
        let p = &self.params;
        let [x0, y0, x1, y1] = p.world.border;
        if !(pos.x > x0 && pos.x < x1 && pos.y > y0 && pos.y < y1) {
            return false;
        }
        let body = frame.at(pos);
        let reach = p.agents.body.reach();
        if super::near(&self.obstacles, Some(&self.near), i).any(|o| o.overlaps_triangle(&body)) {
            return false;
        }
        !self.wolf_bodies.tris().iter().enumerate().any(|(j, other)| j != i && (self.wolves[j].pos - pos).norm() <= reach && triangles_overlap(&body, other))
    }

    #[inline(never)]
    fn move_targets(&mut self) {
        let p = &*self.params;
        let b = &p.agents.body;
        let ts = p.world.ts;
        let side = p.agents.target.side();
        let [x0, y0, x1, y1] = p.world.border;
        let n = self.wolves.len();
        self.target_bodies.sync(&self.targets, b.base, b.height);
        for j in 0..self.targets.len() {
            let t = self.targets[j];
            let mut cmd = clamp(self.target_cmds[j], &side);
            if self.target_captured[j] {
                cmd = Command::default();
            }
            if p.agents.target.fatigue {
                if let Some(seen) = self.target_seen_at[j] {
                    cmd.v = cmd.v.min(p.escape.fatigue_speed(seen, self.t));
                }
            }
            let theta = wrap(t.theta + cmd.omega * ts);
            let mut v = cmd.v;
            // As for wolves: the last step's `unit(θ)`, and one frame for the new heading that
            // serves the filter and, through `target_bodies`, the judge.
            let dir = self.target_bodies.dir(j);
            let frame = BodyFrame::new(theta, b.base, b.height);
            let pos = t.pos + dir * (v * ts);
            if p.world.feasibility_filter && v > 0.0 {
                let inside = pos.x > x0 && pos.x < x1 && pos.y > y0 && pos.y < y1;
                let body = frame.at(pos);
                if !inside || super::near(&self.obstacles, Some(&self.near), n + j).any(|o| o.overlaps_triangle(&body)) {
                    v = 0.0; // §1.6: a target whose move is infeasible only turns.
                }
            }
            let mut pos = t.pos + dir * (v * ts);
            if !inside(pos, &p.world.border) {
                v = 0.0; // the walls hold without the filter too (see move_wolves)
                pos = t.pos;
            }
            let mass = side.mass;
            self.targets[j] = AgentState { pos, theta, v, omega: cmd.omega, energy: t.energy + 0.5 * mass * v * v };
            self.target_bodies.set(j, pos, theta, &frame);
        }
    }

    /// Step 4: collisions, captures, the episode's end.
    #[inline(never)]
    fn judge(&mut self) {
        let p = &*self.params;
        let n = self.n_wolves();
        let reach = p.agents.body.reach();
        let mut wolf_collided = false;
        for i in 0..n {
            let body = self.wolf_bodies.tri(i);
            let hit_obstacle = super::near(&self.obstacles, Some(&self.near), i).any(|o| o.overlaps_triangle(body));
            let hit_wolf = (0..n).any(|j| j != i && (self.wolves[j].pos - self.wolves[i].pos).norm() <= reach && triangles_overlap(body, self.wolf_bodies.tri(j)));
            if hit_obstacle || hit_wolf {
                self.collisions[i] += 1;
                wolf_collided = true;
            }
        }
        for j in 0..self.targets.len() {
            // The body move_targets left (this step's pose).
            let body = self.target_bodies.tri(j);
            if super::near(&self.obstacles, Some(&self.near), n + j).any(|o| o.overlaps_triangle(body)) {
                self.collisions[n + j] += 1;
            }
        }
        let need = p.capture_count();
        let border = p.world.border;
        for j in 0..self.targets.len() {
            if self.target_captured[j] {
                continue;
            }
            let tp = self.targets[j].pos;
            let captured = match p.capture.rule {
                CaptureRule::Count => within(&self.wolves, tp, p.capture.distance).count() >= need,
                // Rare path (only once enough wolves are close): allocation is fine here.
                CaptureRule::Encircle => within(&self.wolves, tp, p.capture.distance).count() >= need && encircled(&within(&self.wolves, tp, p.capture.distance).collect::<Vec<_>>(), tp),
                CaptureRule::HuntingPoints => self.at_hunting_points(j, p.bvc.radius, p.capture.arrive_tolerance),
            };
            let cornered = !captured && cornered(&self.wolves, tp, border, p.capture.distance);
            if cornered && self.target_cornered_step[j].is_none() {
                self.target_cornered_step[j] = Some(self.t);
            }
            if captured || (cornered && p.capture.cornered) {
                self.target_captured[j] = true;
                self.target_capture_step[j] = Some(self.t);
                self.target_ended_cornered[j] = !captured;
            }
        }
        // A wolf collision ends the episode as a failure even if the same step captured.
        self.outcome = if wolf_collided {
            Outcome::Collision
        } else if self.target_captured.iter().all(|&c| c) {
            if self.target_ended_cornered.iter().any(|&c| c) {
                Outcome::Cornered
            } else {
                Outcome::Captured
            }
        } else if self.t >= p.world.max_steps {
            Outcome::Timeout
        } else {
            Outcome::Running
        };
    }

    /// `capture.rule: hunting_points` for target j: every wolf hunting it lies within `tol` of
    /// its hunting point (the N_j points on the ring of radius `r_h` around the target, first
    /// at angle 0, assigned by minimum total distance as the bvc law assigns them).
    fn at_hunting_points(&self, j: usize, r_h: f64, tol: f64) -> bool {
        let tp = self.targets[j].pos;
        let hunters: Vec<Vec2> = self.wolves.iter().zip(&self.wolf_target).filter(|(_, &t)| t == j).map(|(w, _)| w.pos).collect();
        // Cheap necessary condition first: every hunter within r_h + tol of the target.
        let reach = r_h + tol;
        if hunters.is_empty() || hunters.iter().any(|q| (q - tp).norm_squared() > reach * reach) {
            return false;
        }
        let points = crate::geometry::hunting_points(tp, hunters.len(), r_h);
        let assignment = crate::geometry::assign(&hunters, &points);
        hunters.iter().zip(&assignment).all(|(q, &k)| (q - points[k]).norm() <= tol)
    }
}

/// docs/world-and-laws.md §1.7, for every law: the target at `tp` is cornered when it lies within
/// `d` of at least one wall, at least 2 wolves are within `d` of it, and it lies inside (or on) the
/// convex hull of those wolves together with its closest points on every wall within `d` — the
/// `encircle` test with the near walls standing in for wolves.
pub(crate) fn cornered(wolves: &[AgentState], tp: Vec2, border: [f64; 4], d: f64) -> bool {
    let [x0, y0, x1, y1] = border;
    // The closest point of each wall: the target's projection onto it (the target is inside).
    let walls = [(tp.x - x0, Vec2::new(x0, tp.y)), (x1 - tp.x, Vec2::new(x1, tp.y)), (tp.y - y0, Vec2::new(tp.x, y0)), (y1 - tp.y, Vec2::new(tp.x, y1))];
    if !walls.iter().any(|&(dist, _)| dist <= d) {
        return false;
    }
    if within(wolves, tp, d).count() < 2 {
        return false;
    }
    // Rare path (a target near a wall with two wolves at it): allocation is fine here.
    let mut points: Vec<Vec2> = within(wolves, tp, d).collect();
    points.extend(walls.iter().filter(|&&(dist, _)| dist <= d).map(|&(_, q)| q));
    encircled(&points, tp)
}

/// The positions of the wolves within `r` of `p` (the capture and cornered tests' "near" wolves).
fn within(wolves: &[AgentState], p: Vec2, r: f64) -> impl Iterator<Item = Vec2> + '_ {
    wolves.iter().map(|w| w.pos).filter(move |q| (q - p).norm() <= r)
}

/// The target lies inside (or on) the convex hull of the given points (wolves, and for the
/// cornered test wall points).
fn encircled(wolves: &[Vec2], target: Vec2) -> bool {
    if wolves.len() < 3 {
        return false;
    }
    let pts: Vec<Point2> = wolves.iter().map(|w| Point2::from(*w)).collect();
    let hull = convex_hull(&pts);
    if hull.len() < 3 {
        return false;
    }
    // Fan from the first hull vertex covers the convex hull exactly.
    (1..hull.len() - 1).any(|k| triangle_contains(&[hull[0].coords, hull[k].coords, hull[k + 1].coords], target))
}

/// Strictly inside the arena.
fn inside(pos: Vec2, border: &[f64; 4]) -> bool {
    let [x0, y0, x1, y1] = *border;
    pos.x > x0 && pos.x < x1 && pos.y > y0 && pos.y < y1
}

/// Applies a side's limits: v ∈ [0, v_max] (no reverse), |ω| ≤ ω_max.
fn clamp(c: Command, s: &SideParams) -> Command {
    Command { v: c.v.clamp(0.0, s.v_max), omega: c.omega.clamp(-s.omega_max, s.omega_max) }
}

/// Step 2's bookkeeping before any controller runs (docs/world-and-laws.md §1.5), shared by the
/// step and by `World::expert_desired` so that the expert sees exactly what the step will: every
/// `retarget_period` steps (and whenever a wolf's own target has been captured) each wolf re-picks
/// its nearest uncaptured target; then the sensing flags, the first sightings at step `t`, and the
/// sensing entries of the (zeroed) interaction matrix.
// The sightings loop indexes `seen` and a row of `interaction` by j, and tests the row with
// `iter().any` rather than `contains` (a memchr call for five bytes): this is the step's
// sensing, profiled as it stands.
#[allow(clippy::too_many_arguments, clippy::needless_range_loop, clippy::manual_contains)]
pub(super) fn sense_into(
    p: &Params,
    t: u32,
    wolves: &[AgentState],
    targets: &[AgentState],
    captured: &[bool],
    wolf_target: &mut [usize],
    wolf_senses: &mut [bool],
    seen: &mut [Option<u32>],
    interaction: &mut [u8],
) {
    let (n, m) = (wolves.len(), targets.len());
    let k = n + m;
    let rw = p.agents.wolf.sense_radius;
    let rt = p.agents.target.sense_radius;
    if t % p.world.retarget_period == 0 {
        nearest_uncaptured(wolves, targets, captured, wolf_target);
    }
    // A wolf's own target may have been captured since the last re-assignment.
    if wolf_target.iter().any(|&j| captured[j]) && !captured.iter().all(|&c| c) {
        nearest_uncaptured(wolves, targets, captured, wolf_target);
    }
    interaction.fill(0);
    for i in 0..n {
        let wp = wolves[i].pos;
        for j in 0..m {
            let d = (targets[j].pos - wp).norm();
            if d <= rw {
                interaction[i * k + n + j] = 1;
            }
            if d <= rt {
                interaction[(n + j) * k + i] = 1;
            }
        }
        wolf_senses[i] = interaction[i * k + n + wolf_target[i]] == 1;
    }
    for j in 0..m {
        let row = (n + j) * k;
        if seen[j].is_none() && interaction[row..row + n].iter().any(|&x| x == 1) {
            seen[j] = Some(t);
        }
    }
}

/// Each wolf's nearest uncaptured target (ties: lowest index); a wolf keeps its entry when
/// every target is captured.
pub(super) fn nearest_uncaptured(wolves: &[AgentState], targets: &[AgentState], captured: &[bool], wolf_target: &mut [usize]) {
    for (i, w) in wolves.iter().enumerate() {
        let mut best = (f64::INFINITY, wolf_target[i]);
        for (j, t) in targets.iter().enumerate() {
            if captured[j] {
                continue;
            }
            let d = (t.pos - w.pos).norm_squared();
            if d < best.0 {
                best = (d, j);
            }
        }
        wolf_target[i] = best.1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::TargetPolicy;
    use crate::world::Layout;
    use std::sync::Arc;

    const BORDER: [f64; 4] = [-10.0, -10.0, 10.0, 10.0];
    const D: f64 = 0.8;

    fn at(points: &[(f64, f64)]) -> Vec<AgentState> {
        points.iter().map(|&(x, y)| AgentState::at(x, y, 0.0)).collect()
    }

    fn small_world() -> World {
        let l = Layout { wolves: vec![[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]], targets: vec![[5.0, 5.0, 0.0]], obstacles: vec![] };
        World::from_layout(Arc::new(Params::default()), 0, &l).unwrap()
    }

    #[test]
    fn a_nan_command_faults_the_world_instead_of_looping_in_the_filter() {
        // NaN survives the clamp and compares false with the halving floor: before the check,
        // this step never returned.
        let mut w = small_world();
        let bad = [Command { v: f64::NAN, omega: 0.0 }, Command::default()];
        w.step_with(Some(&bad), None);
        let fault = w.fault().expect("faulted");
        assert!(fault.starts_with("the given commands produced a non-finite command for wolf 0 at step 0"), "{fault}");
        assert!(w.is_done());
        let before = w.wolves.clone();
        w.step_with(None, None);
        assert_eq!(w.wolves, before, "a faulted world does not move");
        assert!(matches!(w.check_fault(), Err(crate::Error::NonFinite(_))));
    }

    #[test]
    fn a_law_that_yields_nan_is_named() {
        let mut w = small_world();
        let bad = [Command { v: 1.0, omega: f64::NAN }];
        w.step_with(None, Some(&bad));
        assert!(w.fault().unwrap().starts_with("the given commands produced a non-finite command for target 0"));
        // A scripted law's fault names the law.
        let mut w = small_world();
        w.target_cmds[0] = Command { v: f64::NAN, omega: 0.0 };
        let msg = w.non_finite_command(false, false).unwrap();
        assert!(msg.starts_with("the escape target law produced a non-finite command for target 0"), "{msg}");
    }

    #[test]
    fn cornered_in_a_corner_by_two_wolves() {
        // Target 0.5 m from the top and right walls; wall points (10, 9.5), (9.5, 10). Wolves
        // at (9.0, 9.6) and (9.6, 9.0), 0.51 m away: the hull's inner edge x + y = 18.6 passes
        // below-left of the target (x + y = 19), so the target is inside.
        let tp = Vec2::new(9.5, 9.5);
        assert!(cornered(&at(&[(9.0, 9.6), (9.6, 9.0), (0.0, 0.0)]), tp, BORDER, D));
        // One wolf is not enough.
        assert!(!cornered(&at(&[(9.0, 9.6), (0.0, 0.0)]), tp, BORDER, D));
        // Wolves on the wrong side: both up-left of the target, the hull's lower edge from
        // (9.0, 9.6) to (10, 9.5) passes above it (y = 9.55 at x = 9.5).
        assert!(!cornered(&at(&[(9.0, 9.6), (9.2, 9.9)]), tp, BORDER, D));
        // A wolf just beyond the capture distance does not count: (9.6, 8.69) is 0.816 m away.
        assert!(!cornered(&at(&[(9.0, 9.6), (9.6, 8.69)]), tp, BORDER, D));
    }

    #[test]
    fn cornered_against_one_wall_by_three_wolves() {
        // Target 0.5 m below the top wall (wall point (0, 10)); three wolves 0.6 m around its
        // lower side close the hull.
        let tp = Vec2::new(0.0, 9.5);
        let wolves = at(&[(-0.6, 9.4), (0.0, 8.9), (0.6, 9.4)]);
        assert!(cornered(&wolves, tp, BORDER, D));
        // Near miss: the same formation 0.85 m from the wall (farther than the capture distance
        // from every wall) is not cornered.
        let shifted: Vec<AgentState> = wolves.iter().map(|w| AgentState::at(w.pos.x, w.pos.y - 0.35, 0.0)).collect();
        assert!(!cornered(&shifted, Vec2::new(0.0, 9.15), BORDER, D));
        // Wrong side: three wolves between the target and the wall.
        assert!(!cornered(&at(&[(-0.5, 9.8), (0.5, 9.8), (0.0, 9.9)]), tp, BORDER, D));
        // Every wall counts: the same scene mirrored against the bottom wall, with an arena
        // whose walls are not at ±10.
        let b = [-3.0, -20.0, 7.0, 1.0];
        assert!(cornered(&at(&[(1.4, -19.4), (2.0, -18.9), (2.6, -19.4)]), Vec2::new(2.0, -19.5), b, D));
    }

    fn still_world(wolves: &[(f64, f64)], target: (f64, f64), edit: impl FnOnce(&mut Params)) -> World {
        let mut p = Params::default();
        p.policies.targets = TargetPolicy::Still;
        p.obstacles.static_circles = 0;
        edit(&mut p);
        let l = Layout { wolves: wolves.iter().map(|&(x, y)| [x, y, 0.0]).collect(), targets: vec![[target.0, target.1, 0.0]], obstacles: vec![] };
        World::from_layout(Arc::new(p), 0, &l).unwrap()
    }

    /// One step with every wolf commanded to stand still.
    fn stand(w: &mut World) -> Outcome {
        let cmds = vec![Command::default(); w.n_wolves()];
        w.step_with(Some(&cmds), None)
    }

    #[test]
    fn cornered_ends_the_episode_only_when_it_counts() {
        let wolves = [(9.0, 9.6), (9.6, 9.0), (-5.0, -5.0), (-5.0, 5.0), (5.0, -5.0)];
        let mut w = still_world(&wolves, (9.5, 9.5), |_| {});
        assert_eq!(stand(&mut w), Outcome::Running, "capture.cornered is off by default");
        assert_eq!(w.cornered_step(), Some(1));
        assert_eq!(stand(&mut w), Outcome::Running);
        assert_eq!(w.cornered_step(), Some(1), "the first cornered step is kept");
        let mut w = still_world(&wolves, (9.5, 9.5), |p| p.capture.cornered = true);
        assert_eq!(stand(&mut w), Outcome::Cornered);
        assert!(w.outcome.is_success() && w.target_captured[0] && w.target_ended_cornered[0]);
        assert_eq!((w.target_capture_step[0], w.capture_step(), w.cornered_step()), (Some(1), None, Some(1)));
        // A capture takes precedence over cornering at the same step.
        let four = [(9.0, 9.6), (9.6, 9.0), (9.2, 9.2), (9.7, 9.2), (-5.0, 5.0)];
        let mut w = still_world(&four, (9.5, 9.5), |p| p.capture.cornered = true);
        assert_eq!(stand(&mut w), Outcome::Captured);
        assert_eq!((w.capture_step(), w.cornered_step()), (Some(1), None));
    }

    #[test]
    fn hunting_points_rule_needs_every_wolf_at_its_point() {
        // Three wolves, bvc ring 0.6 around (1, 2): points at angles 0, 2π/3, 4π/3. Each wolf
        // 0.15 m off its own point (tolerance 0.2) — but listed out of order, so only the
        // assignment matches them up.
        let tp = (1.0, 2.0);
        let point = |k: usize, off: f64| {
            let a = std::f64::consts::TAU * k as f64 / 3.0;
            (tp.0 + (0.6 + off) * a.cos(), tp.1 + (0.6 + off) * a.sin())
        };
        let set = |p: &mut Params| {
            p.capture.rule = CaptureRule::HuntingPoints;
            p.world.wolves = 3;
        };
        let mut w = still_world(&[point(2, 0.15), point(0, 0.15), point(1, -0.15)], tp, set);
        assert_eq!(stand(&mut w), Outcome::Captured);
        // One wolf 0.25 m off: not yet, though all three are within capture.distance.
        let mut w = still_world(&[point(2, 0.15), point(0, 0.25), point(1, -0.15)], tp, set);
        assert_eq!(stand(&mut w), Outcome::Running);
        // Three wolves bunched around point 0 are within the capture distance (the count rule
        // would capture) but only one is at a hunting point.
        let mut w = still_world(&[(1.6, 2.0), (1.6, 2.25), (1.6, 1.75)], tp, |p| {
            set(p);
            p.capture.count = Some(3);
        });
        assert_eq!(stand(&mut w), Outcome::Running);
    }

    #[test]
    fn encircle_needs_the_target_inside_the_hull() {
        let ring = [Vec2::new(1.0, 0.0), Vec2::new(-0.5, 0.8), Vec2::new(-0.5, -0.8)];
        assert!(encircled(&ring, Vec2::zeros()));
        assert!(!encircled(&ring, Vec2::new(2.0, 0.0)));
        assert!(!encircled(&ring[..2], Vec2::zeros()));
    }
}
