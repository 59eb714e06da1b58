//! One step of a world as a pipeline of stages (docs/world-and-laws.md §1.6): the world's own
//! stages ([`World::begin_step`]: obstacles, near lists, sensing; [`World::finish_step`]: the
//! feasibility filter, the judge) around the controllers — the scripted laws of
//! `crate::policies`, or commands given by a learner. The world never calls the laws itself, and
//! the laws never see the world, only its [`Snapshot`]: this module is the one place that knows
//! both.

use crate::policies::{self, saturator::saturate};
use crate::scene::{Command, LawMode};
use crate::world::{Controls, Desired, Outcome, World};

impl World {
    /// Advances one step with every agent driven by its side's scripted law.
    pub fn step(&mut self) -> Outcome {
        self.step_with(None, None)
    }

    /// Advances one step. `wolf_cmds` / `target_cmds`, when given, replace the scripted law of
    /// that side (one command per agent; learned controllers). Commands are clamped to the
    /// side's limits. A finished world does not move.
    pub fn step_with(&mut self, wolf_cmds: Option<&[Command]>, target_cmds: Option<&[Command]>) -> Outcome {
        if !self.begin_step() {
            return self.outcome;
        }
        control(self.controls(), wolf_cmds, target_cmds);
        self.finish_step(wolf_cmds.is_some(), target_cmds.is_some())
    }

    /// The desired (v_d, θ_d) of every wolf and every target under the configured laws (before
    /// the saturator), as the next step would compute them: the expert of imitation learning.
    /// Lengths: N and M. Each law runs on exactly the snapshot the next step will show it, with
    /// copies of its memory and random stream: nothing in the world changes, so calling this
    /// any number of times is harmless, and a learner that executes its answer reproduces the
    /// scripted episode.
    ///
    /// The laws' memories (a lost wolf's remembered direction, a running emergency) are the
    /// world's: they follow the episode only where the scripted law drove the side, or where
    /// [`World::track_laws`] is set. Allocates; meant for imitation, not the hot path. A finished
    /// world's agents desire to stand.
    pub fn expert_desired(&self) -> (Vec<Desired>, Vec<Desired>) {
        let (n, m) = (self.n_wolves(), self.n_targets());
        let laws = self.with_next_snapshot(|snap| {
            let mut row = vec![0u8; n + m];
            let wolves = (0..n)
                .map(|i| {
                    let mut mem = self.wolf_memory[i];
                    policies::wolf_desired(i, snap, &mut mem, &mut row)
                })
                .collect();
            let mut rng = self.policy_rng();
            let targets = (0..m)
                .map(|j| {
                    let mut mem = self.target_memory[j];
                    policies::target_desired(j, snap, &mut mem, &mut rng)
                })
                .collect();
            (wolves, targets)
        });
        laws.unwrap_or_else(|| {
            let rest = |a: &crate::scene::AgentState| (0.0, a.theta);
            (self.wolves.iter().map(rest).collect(), self.targets.iter().map(rest).collect())
        })
    }
}

/// Every controller reads the same snapshot; the step's commands land in the world's command
/// buffers, and the branch of each law that decided in `wolf_mode` / `target_mode` (none for a
/// side driven by given commands). A side driven by given commands still runs its law when `track_laws` is set, so that
/// the law's memory (and its random stream) follows the episode for `expert_desired`. Kept out
/// of line: callgrind profiles (BENCHMARKS.md) attribute the step's cost to it by name.
#[inline(never)]
fn control(c: Controls, wolf_cmds: Option<&[Command]>, target_cmds: Option<&[Command]>) {
    let Controls { snap, wolf_memory, target_memory, wolf_cmds: wolf_out, target_cmds: target_out, interaction, scratch_row, wolf_mode, target_mode, rng_policy, track_laws } = c;
    let (n, k) = (snap.wolves.len(), snap.wolves.len() + snap.targets.len());
    let wolf_side = &snap.params.agents.wolf;
    let target_side = &snap.params.agents.target;
    let ts = snap.params.world.ts;
    if let Some(c) = wolf_cmds {
        wolf_out.copy_from_slice(c);
        // No law decided, even where one runs to keep its memory.
        wolf_mode.fill(LawMode::None);
    }
    if wolf_cmds.is_none() || track_laws {
        for i in 0..n {
            // A tracked (not driving) law must not mark the interaction matrix.
            let row: &mut [u8] = if wolf_cmds.is_none() { &mut interaction[i * k..(i + 1) * k] } else { &mut *scratch_row };
            let (v_d, theta_d) = policies::wolf_desired(i, &snap, &mut wolf_memory[i], row);
            if wolf_cmds.is_none() {
                wolf_out[i] = saturate(v_d, theta_d, snap.wolves[i].theta, wolf_side.v_max, wolf_side.omega_max, ts);
                wolf_mode[i] = wolf_memory[i].mode();
            }
        }
    }
    if let Some(c) = target_cmds {
        target_out.copy_from_slice(c);
        target_mode.fill(LawMode::None);
    }
    if target_cmds.is_none() || track_laws {
        for j in 0..snap.targets.len() {
            let (v_d, theta_d) = policies::target_desired(j, &snap, &mut target_memory[j], rng_policy);
            if target_cmds.is_none() {
                target_out[j] = saturate(v_d, theta_d, snap.targets[j].theta, target_side.v_max, target_side.omega_max, ts);
                target_mode[j] = target_memory[j].mode;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use crate::config::{Params, TargetPolicy, WolfPolicy};
    use crate::scene::{Command, LawMode};
    use crate::world::World;

    #[test]
    fn each_step_notes_the_mode_of_every_law_that_drove() {
        for (wolves, targets) in [(WolfPolicy::Seed000, TargetPolicy::Escape), (WolfPolicy::Bvc, TargetPolicy::Random), (WolfPolicy::Formation, TargetPolicy::Still)] {
            let mut p = Params::default();
            (p.policies.wolves, p.policies.targets) = (wolves, targets);
            let mut w = World::new(Arc::new(p), 5).unwrap();
            assert!(w.wolf_mode.iter().chain(&w.target_mode).all(|&m| m == LawMode::None), "before the first step");
            w.step();
            assert!(w.wolf_mode.iter().chain(&w.target_mode).all(|&m| m != LawMode::None), "{wolves:?}: {:?} {:?}", w.wolf_mode, w.target_mode);
            assert_eq!(w.wolf_mode, w.wolf_memory.iter().map(|m| m.mode()).collect::<Vec<_>>());
            // Given commands drive the wolves: no law decided for them, even a tracked one.
            for track in [false, true] {
                w.track_laws = track;
                w.step_with(Some(&vec![Command::default(); w.n_wolves()]), None);
                assert!(w.wolf_mode.iter().all(|&m| m == LawMode::None), "{wolves:?}, tracked {track}");
                assert!(w.target_mode.iter().all(|&m| m != LawMode::None));
            }
            w.step_with(None, Some(&vec![Command::default(); w.n_targets()]));
            assert!(w.wolf_mode.iter().all(|&m| m != LawMode::None) && w.target_mode.iter().all(|&m| m == LawMode::None));
        }
    }
}
