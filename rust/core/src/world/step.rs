//! One synchronous step (SPEC §1.5): obstacles move; every controller reads the same snapshot;
//! agents move through the feasibility filter; outcomes; the clock advances.

use parry2d_f64::transformation::convex_hull;

use super::{AgentState, Outcome, World};
use crate::config::{CaptureRule, Params, SideParams};
use crate::geometry::{body_triangle, triangle_contains, triangles_overlap};
use crate::math::{unit, wrap, Point2, Vec2};
use crate::policies::saturator::saturate;
use crate::policies::{self, Command, Snapshot};

/// Below this speed an infeasible wolf stops halving and only turns (SPEC §1.5).
const MIN_HALVED_SPEED: f64 = 0.01;

impl World {
    /// Advances one step with every agent driven by its side's scripted law.
    pub fn step(&mut self) -> Outcome {
        self.step_with(None, None)
    }

    /// Advances one step. `wolf_cmds` / `target_cmds`, when given, replace the scripted law of
    /// that side (one command per agent; learned controllers). Commands are clamped to the
    /// side's limits. A finished world does not move.
    pub fn step_with(&mut self, wolf_cmds: Option<&[Command]>, target_cmds: Option<&[Command]>) -> Outcome {
        if self.is_done() {
            return self.outcome;
        }
        let p = self.params.clone();
        // 1. Obstacles move.
        for o in &mut self.obstacles {
            o.advance(&mut self.rng_motion, &p.obstacles, p.world.ts, &p.world.border);
        }
        // 2. Assignment, sensing and the snapshot every controller reads.
        self.sense();
        self.control(wolf_cmds, target_cmds);
        // 3. Moves through the feasibility filter: wolves in index order, then targets.
        self.move_wolves();
        self.move_targets();
        // 4. Outcomes.
        self.t += 1;
        self.judge();
        self.outcome
    }

    /// Each wolf hunts its nearest uncaptured target (ties: lowest index).
    pub(super) fn assign_targets(&mut self) {
        nearest_uncaptured(&self.wolves, &self.targets, &self.target_captured, &mut self.wolf_target);
    }

    /// Target assignment, sensing flags, first sightings and the sensing entries of the
    /// interaction matrix, for the step about to be taken.
    fn sense(&mut self) {
        sense_into(&self.params, self.t, &self.wolves, &self.targets, &self.target_captured, &mut self.wolf_target, &mut self.wolf_senses, &mut self.target_seen_at, &mut self.interaction);
    }

    /// Step 2: every controller reads the same snapshot; commands land in the scratch buffers.
    /// A side driven by given commands still runs its law when `track_laws` is set, so that
    /// the law's memory (and its random stream) follows the episode for `expert_desired`.
    fn control(&mut self, wolf_cmds: Option<&[Command]>, target_cmds: Option<&[Command]>) {
        let (n, k) = (self.n_wolves(), self.n_wolves() + self.n_targets());
        let snap = Snapshot {
            params: &self.params,
            t: self.t,
            wolves: &self.wolves,
            targets: &self.targets,
            obstacles: &self.obstacles,
            wolf_target: &self.wolf_target,
            wolf_senses: &self.wolf_senses,
            target_seen_at: &self.target_seen_at,
            target_captured: &self.target_captured,
        };
        let wolf_side = &self.params.agents.wolf;
        let target_side = &self.params.agents.target;
        let ts = self.params.world.ts;
        if let Some(c) = wolf_cmds {
            self.wolf_cmds.copy_from_slice(c);
        }
        if wolf_cmds.is_none() || self.track_laws {
            for i in 0..n {
                // A tracked (not driving) law must not mark the interaction matrix.
                let row: &mut [u8] = if wolf_cmds.is_none() { &mut self.interaction[i * k..(i + 1) * k] } else { &mut self.scratch_row };
                let (v_d, theta_d) = policies::wolf_desired(i, &snap, &mut self.wolf_memory[i], row);
                if wolf_cmds.is_none() {
                    self.wolf_cmds[i] = saturate(v_d, theta_d, snap.wolves[i].theta, wolf_side.v_max, wolf_side.omega_max, ts);
                }
            }
        }
        if let Some(c) = target_cmds {
            self.target_cmds.copy_from_slice(c);
        }
        if target_cmds.is_none() || self.track_laws {
            for j in 0..self.targets.len() {
                let (v_d, theta_d) = policies::target_desired(j, &snap, &mut self.target_memory[j], &mut self.rng_policy);
                if target_cmds.is_none() {
                    self.target_cmds[j] = saturate(v_d, theta_d, snap.targets[j].theta, target_side.v_max, target_side.omega_max, ts);
                }
            }
        }
    }

    fn move_wolves(&mut self) {
        let p = self.params.clone();
        let b = &p.agents.body;
        let ts = p.world.ts;
        self.bodies.clear();
        self.bodies.extend(self.wolves.iter().map(|w| body_triangle(w.pos, w.theta, b.base, b.height)));
        for i in 0..self.wolves.len() {
            let cmd = clamp(self.wolf_cmds[i], &p.agents.wolf);
            let w = self.wolves[i];
            let mut theta = wrap(w.theta + cmd.omega * ts);
            let mut omega = cmd.omega;
            let mut v = cmd.v;
            if p.world.feasibility_filter {
                loop {
                    if v < MIN_HALVED_SPEED {
                        v = 0.0;
                        // SPEC: below 0.01 it only turns. A turn on the spot that would itself
                        // touch a wolf or an obstacle is not made either (the reference let it
                        // happen; every wolf–wolf collision measured here came from one).
                        if omega != 0.0 && !self.wolf_pose_feasible(i, w.pos, theta) && self.wolf_pose_feasible(i, w.pos, w.theta) {
                            theta = w.theta;
                            omega = 0.0;
                        }
                        break;
                    }
                    let pos = w.pos + unit(w.theta) * (v * ts);
                    if self.wolf_pose_feasible(i, pos, theta) {
                        break;
                    }
                    v *= 0.5;
                }
            }
            let pos = w.pos + unit(w.theta) * (v * ts);
            let mass = p.agents.wolf.mass;
            self.wolves[i] = AgentState { pos, theta, v, omega, energy: w.energy + 0.5 * mass * v * v };
            self.bodies[i] = body_triangle(pos, theta, b.base, b.height);
        }
    }

    /// New pose strictly inside the border, body clear of obstacles and of the other wolves'
    /// current bodies.
    fn wolf_pose_feasible(&self, i: usize, pos: Vec2, theta: f64) -> bool {
        let p = &self.params;
        let [x0, y0, x1, y1] = p.world.border;
        if !(pos.x > x0 && pos.x < x1 && pos.y > y0 && pos.y < y1) {
            return false;
        }
        let body = body_triangle(pos, theta, p.agents.body.base, p.agents.body.height);
        let reach = p.agents.body.reach();
        if self.obstacles.iter().any(|o| o.overlaps_triangle(&body)) {
            return false;
        }
        !self.bodies.iter().enumerate().any(|(j, other)| j != i && (self.wolves[j].pos - pos).norm() <= reach && triangles_overlap(&body, other))
    }

    fn move_targets(&mut self) {
        let p = self.params.clone();
        let b = &p.agents.body;
        let ts = p.world.ts;
        let side = p.agents.target.side();
        let [x0, y0, x1, y1] = p.world.border;
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
            let pos = t.pos + unit(t.theta) * (v * ts);
            if p.world.feasibility_filter && v > 0.0 {
                let inside = pos.x > x0 && pos.x < x1 && pos.y > y0 && pos.y < y1;
                let body = body_triangle(pos, theta, b.base, b.height);
                if !inside || self.obstacles.iter().any(|o| o.overlaps_triangle(&body)) {
                    v = 0.0; // SPEC: a target that cannot move feasibly only turns.
                }
            }
            let pos = t.pos + unit(t.theta) * (v * ts);
            let mass = side.mass;
            self.targets[j] = AgentState { pos, theta, v, omega: cmd.omega, energy: t.energy + 0.5 * mass * v * v };
        }
    }

    /// Step 4: collisions, captures, the episode's end.
    fn judge(&mut self) {
        let p = self.params.clone();
        let n = self.n_wolves();
        let reach = p.agents.body.reach();
        let mut wolf_collided = false;
        for i in 0..n {
            let body = self.bodies[i];
            let hit_obstacle = self.obstacles.iter().any(|o| o.overlaps_triangle(&body));
            let hit_wolf = (0..n).any(|j| j != i && (self.wolves[j].pos - self.wolves[i].pos).norm() <= reach && triangles_overlap(&body, &self.bodies[j]));
            if hit_obstacle || hit_wolf {
                self.collisions[i] += 1;
                wolf_collided = true;
            }
        }
        for j in 0..self.targets.len() {
            let body = self.body(&self.targets[j]);
            if self.obstacles.iter().any(|o| o.overlaps_triangle(&body)) {
                self.collisions[n + j] += 1;
            }
        }
        let need = p.capture_count();
        for j in 0..self.targets.len() {
            if self.target_captured[j] {
                continue;
            }
            let tp = self.targets[j].pos;
            let near = |q: &Vec2| (q - tp).norm() <= p.capture.distance;
            let captured = self.wolves.iter().filter(|w| near(&w.pos)).count() >= need
                && match p.capture.rule {
                    CaptureRule::Count => true,
                    // Rare path (only once enough wolves are close): allocation is fine here.
                    CaptureRule::Encircle => encircled(&self.wolves.iter().map(|w| w.pos).filter(near).collect::<Vec<_>>(), tp),
                };
            if captured {
                self.target_captured[j] = true;
                self.target_capture_step[j] = Some(self.t);
            }
        }
        // A wolf collision ends the episode as a failure even if the same step captured.
        self.outcome = if wolf_collided {
            Outcome::Collision
        } else if self.target_captured.iter().all(|&c| c) {
            Outcome::Captured
        } else if self.t >= p.world.max_steps {
            Outcome::Timeout
        } else {
            Outcome::Running
        };
    }
}

/// The target lies inside (or on) the convex hull of the given wolves.
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

/// Applies a side's limits: v ∈ [0, v_max] (no reverse), |ω| ≤ ω_max.
fn clamp(c: Command, s: &SideParams) -> Command {
    Command { v: c.v.clamp(0.0, s.v_max), omega: c.omega.clamp(-s.omega_max, s.omega_max) }
}

/// Step 2's bookkeeping before any controller runs (SPEC §1.4), shared by the step and by
/// `World::expert_desired` so that the expert sees exactly what the step will: every
/// `retarget_period` steps (and whenever a wolf's own target has been captured) each wolf
/// re-picks its nearest uncaptured target; then the sensing flags, the first sightings at step
/// `t`, and the sensing entries of the (zeroed) interaction matrix.
#[allow(clippy::too_many_arguments)]
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

    #[test]
    fn encircle_needs_the_target_inside_the_hull() {
        let ring = [Vec2::new(1.0, 0.0), Vec2::new(-0.5, 0.8), Vec2::new(-0.5, -0.8)];
        assert!(encircled(&ring, Vec2::zeros()));
        assert!(!encircled(&ring, Vec2::new(2.0, 0.0)));
        assert!(!encircled(&ring[..2], Vec2::zeros()));
    }
}

