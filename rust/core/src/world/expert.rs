//! What the scripted laws would do now: the expert of imitation learning.
//!
//! [`World::expert_desired`] evaluates every agent's scripted law on exactly the snapshot the
//! next step will show its controllers — obstacles advanced by the next step's motion (drawn
//! from a copy of the world's motion stream, which nothing else touches), targets re-assigned
//! and sensing updated as the step will do — with copies of the laws' memories and random
//! stream. Nothing in the world changes, so calling it any number of times is harmless, and a
//! learner that executes its answer reproduces the scripted episode.

use super::step::sense_into;
use super::World;
use crate::policies::{self, Snapshot};

/// One agent's desired (v_d, θ_d): speed (m/s) and heading (rad), before the saturator.
pub type Desired = (f64, f64);

impl World {
    /// The desired (v_d, θ_d) of every wolf and every target under the configured laws (before
    /// the saturator), as the next step would compute them. Lengths: N and M.
    ///
    /// The laws' memories (a lost wolf's remembered direction, a running emergency) are the
    /// world's: they follow the episode only where the scripted law drove the side, or where
    /// [`World::track_laws`] is set. Allocates; meant for imitation, not the hot path.
    pub fn expert_desired(&self) -> (Vec<Desired>, Vec<Desired>) {
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
        // 2. Assignment and sensing exactly as the step computes them.
        let mut wolf_target = self.wolf_target.clone();
        let mut wolf_senses = vec![false; n];
        let mut seen = self.target_seen_at.clone();
        let mut interaction = vec![0u8; (n + m) * (n + m)];
        sense_into(p, self.t, &self.wolves, &self.targets, &self.target_captured, &mut wolf_target, &mut wolf_senses, &mut seen, &mut interaction);
        let snap = Snapshot {
            params: p,
            t: self.t,
            wolves: &self.wolves,
            targets: &self.targets,
            obstacles: &obstacles,
            near: None,
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
