//! The snapshot the next step will show its controllers, for the expert of imitation learning
//! (`World::expert_desired`, in `crate::pipeline`), computed without changing the world.

use rand_chacha::ChaCha8Rng;

use super::step::sense_into;
use super::World;
use crate::scene::Snapshot;

/// One agent's desired (v_d, θ_d): speed (m/s) and heading (rad), before the saturator.
pub type Desired = (f64, f64);

impl World {
    /// Calls `f` with the snapshot the next step will show its controllers (obstacles advanced
    /// by the next step's motion, drawn from a copy of the motion stream; targets re-assigned
    /// and sensing updated as the step will do), without changing the world. `None` when the
    /// world is done.
    pub(crate) fn with_next_snapshot<R>(&self, f: impl FnOnce(&Snapshot) -> R) -> Option<R> {
        if self.is_done() {
            return None;
        }
        let p = &*self.params;
        let (n, m) = (self.n_wolves(), self.n_targets());
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
        Some(f(&Snapshot {
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
        }))
    }

    /// A copy of the scripted laws' random stream, as the next step will draw from it.
    pub(crate) fn policy_rng(&self) -> ChaCha8Rng {
        self.rng_policy.clone()
    }
}
