//! What the scripted laws would do now: the expert of imitation learning.
//!
//! [`World::expert_desired`] evaluates every agent's scripted law on exactly the snapshot the
//! next step will show its controllers — obstacles advanced by the next step's motion (drawn
//! from a copy of the world's motion stream, which nothing else touches), targets re-assigned
//! and sensing updated as the step will do — with copies of the laws' memories and random
//! stream. Nothing in the world changes, so calling it any number of times is harmless, and a
//! learner that executes its answer reproduces the scripted episode.

use super::step::nearest_uncaptured;
use super::World;
use crate::policies::{self, Snapshot};

impl World {
    /// The desired (v_d, θ_d) of every wolf and every target under the configured laws (before
    /// the saturator), as the next step would compute them. Lengths: N and M.
    ///
    /// The laws' memories (a lost wolf's remembered direction, a running emergency) are the
    /// world's: they follow the episode only where the scripted law drove the side, or where
    /// [`World::track_laws`] is set. Allocates; meant for imitation, not the hot path.
    pub fn expert_desired(&self) -> (Vec<(f64, f64)>, Vec<(f64, f64)>) {
        let p = &*self.params;
        let (n, m) = (self.n_wolves(), self.n_targets());
        if self.is_done() {
            let rest = |a: &super::AgentState| (0.0, a.theta);
            return (self.wolves.iter().map(rest).collect(), self.targets.iter().map(rest).collect());
        }
        // 1. Obstacles as the next step will move them.
        let mut obstacles = self.obstacles.clone();
        let mut rng_motion = self.rng_motion.clone();
        for o in &mut obstacles {
            o.advance(&mut rng_motion, &p.obstacles, p.world.ts, &p.world.border);
        }
        // 2. Assignment and sensing as `step` computes them (see `sense`).
        let mut wolf_target = self.wolf_target.clone();
        if self.t % p.world.retarget_period == 0 {
            nearest_uncaptured(&self.wolves, &self.targets, &self.target_captured, &mut wolf_target);
        }
        if wolf_target.iter().any(|&j| self.target_captured[j]) && !self.target_captured.iter().all(|&c| c) {
            nearest_uncaptured(&self.wolves, &self.targets, &self.target_captured, &mut wolf_target);
        }
        let rw = p.agents.wolf.sense_radius;
        let rt = p.agents.target.sense_radius;
        let wolf_senses: Vec<bool> = (0..n).map(|i| (self.targets[wolf_target[i]].pos - self.wolves[i].pos).norm() <= rw).collect();
        let mut seen = self.target_seen_at.clone();
        for (j, s) in seen.iter_mut().enumerate() {
            if s.is_none() && self.wolves.iter().any(|w| (self.targets[j].pos - w.pos).norm() <= rt) {
                *s = Some(self.t);
            }
        }
        let snap = Snapshot {
            params: p,
            t: self.t,
            wolves: &self.wolves,
            targets: &self.targets,
            obstacles: &obstacles,
            wolf_target: &wolf_target,
            wolf_senses: &wolf_senses,
            target_seen_at: &seen,
            target_captured: &self.target_captured,
        };
        // 3. The laws, on copies of their memories and random stream.
        let mut row = vec![0u8; n + m];
        let wolves = (0..n)
            .map(|i| {
                let mut mem = self.wolf_memory[i];
                policies::wolf_desired(i, &snap, &mut mem, &mut row)
            })
            .collect();
        let mut rng = self.rng_policy.clone();
        let targets = (0..m)
            .map(|j| {
                let mut mem = self.target_memory[j];
                policies::target_desired(j, &snap, &mut mem, &mut rng)
            })
            .collect();
        (wolves, targets)
    }
}
