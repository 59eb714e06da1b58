//! The analytic laws. Each reads the same [`Snapshot`] of the world (docs/world-and-laws.md §1.6
//! step 2) and returns a [`Command`] (v, ω) that has been through the saturator (§2).
//!
//! | module | docs/world-and-laws.md | who |
//! |---|---|---|
//! | [`saturator`] | §2 | everyone: desired velocity → (v, ω) |
//! | [`seed000`] | §3 | wolves: attraction + tangential repulsion |
//! | [`avoidance`] | §4 | wolves and targets: heading-based obstacle avoidance |
//! | [`bvc`] | §6 | wolves: buffered Voronoi cells + Hungarian assignment of hunting points |
//! | [`formation`] | §7 | wolves: obstacle graph, virtual leader's path, potential-field formation |
//! | [`escape`] | §5 | targets: `escape`, `random`, `still` |

pub mod avoidance;
pub mod bvc;
pub mod escape;
pub mod formation;
pub mod saturator;
pub mod seed000;

use rand::Rng;

use crate::config::TargetPolicy;

pub use crate::scene::{Command, LawMode, Sighting, Snapshot, TargetMemory, WolfMemory};

/// The configured wolf law up to the saturator: wolf i's desired (v_d, θ_d). A memory of
/// another law (the law was changed) starts afresh as the configured law's. The law notes in
/// `mem` the branch that decided ([`WolfMemory::mode`]).
pub fn wolf_desired(i: usize, snap: &Snapshot, mem: &mut WolfMemory, row: &mut [u8]) -> (f64, f64) {
    let law = snap.params.policies.wolves;
    if mem.law() != law {
        *mem = WolfMemory::new(law);
    }
    match mem {
        WolfMemory::Seed000(m) => seed000::wolf_desired(i, snap, m, row),
        WolfMemory::Bvc(m) => bvc::wolf_desired(i, snap, m, row),
        WolfMemory::Formation(m) => formation::wolf_desired(i, snap, m, row),
    }
}

/// The configured target law up to the saturator: target j's desired (v_d, θ_d). A captured
/// target and `still` ask for nothing (v_d = 0 along the current heading: v = ω = 0). The law
/// notes in `mem.mode` the branch that decided.
pub fn target_desired<R: Rng>(j: usize, snap: &Snapshot, mem: &mut TargetMemory, rng: &mut R) -> (f64, f64) {
    if snap.target_captured[j] {
        mem.mode = LawMode::Ended;
        return (0.0, snap.targets[j].theta);
    }
    match snap.params.policies.targets {
        TargetPolicy::Escape => escape::escape_desired(j, snap, mem, rng),
        TargetPolicy::Random => escape::random_desired(j, snap, mem, rng),
        TargetPolicy::Still => {
            mem.mode = LawMode::Still;
            (0.0, snap.targets[j].theta)
        }
    }
}

/// The last call of a pure computation and its answer, for a per-thread memo: every wolf of a
/// pack asks the same question in the same step (the pack's assignment, the virtual leader).
/// The key must hold every input of the computation (as f64); a hit needs bit-identical keys,
/// so answering from here changes no result and determinism holds for any thread count.
#[derive(Debug)]
pub struct LastCall<V> {
    key: Vec<f64>,
    value: Option<V>,
}

impl<V: Clone> Default for LastCall<V> {
    fn default() -> Self {
        Self::new()
    }
}

impl<V: Clone> LastCall<V> {
    pub const fn new() -> Self {
        LastCall { key: Vec::new(), value: None }
    }

    /// `compute()`, or the stored answer when `key` equals the last call's bit for bit.
    pub fn get_or(&mut self, key: Vec<f64>, compute: impl FnOnce() -> V) -> V {
        let same = self.key.len() == key.len() && self.key.iter().zip(&key).all(|(a, b)| a.to_bits() == b.to_bits());
        match &self.value {
            Some(v) if same => v.clone(),
            _ => {
                let v = compute();
                self.key = key;
                self.value = Some(v.clone());
                v
            }
        }
    }
}

/// A hand-made scene for the laws' unit tests: owns what a [`Snapshot`] borrows.
#[cfg(test)]
pub(crate) mod fixture {
    use super::Snapshot;
    use crate::config::Params;
    use crate::scene::{AgentState, Obstacle};

    pub struct Scene {
        pub params: Params,
        pub wolves: Vec<AgentState>,
        pub targets: Vec<AgentState>,
        pub obstacles: Vec<Obstacle>,
        pub wolf_target: Vec<usize>,
        pub wolf_senses: Vec<bool>,
        pub seen: Vec<Option<u32>>,
        pub captured: Vec<bool>,
        pub t: u32,
    }

    impl Scene {
        /// Default params, step 0; every wolf hunts target 0 and senses nothing; no target
        /// has sighted a wolf or been captured. Tests set the fields they need.
        pub fn new(wolves: Vec<AgentState>, targets: Vec<AgentState>, obstacles: Vec<Obstacle>) -> Self {
            let (n, m) = (wolves.len(), targets.len());
            Self { params: Params::default(), wolves, targets, obstacles, wolf_target: vec![0; n], wolf_senses: vec![false; n], seen: vec![None; m], captured: vec![false; m], t: 0 }
        }

        /// Wolves at the given points, heading 0.
        pub fn wolves_at(points: &[(f64, f64)]) -> Vec<AgentState> {
            points.iter().map(|&(x, y)| AgentState::at(x, y, 0.0)).collect()
        }

        pub fn snap(&self) -> Snapshot<'_> {
            Snapshot {
                params: &self.params,
                t: self.t,
                wolves: &self.wolves,
                targets: &self.targets,
                obstacles: &self.obstacles,
                near: None,
                wolf_target: &self.wolf_target,
                wolf_senses: &self.wolf_senses,
                target_seen_at: &self.seen,
                target_captured: &self.captured,
            }
        }

        /// A zeroed interaction-matrix row.
        pub fn row(&self) -> Vec<u8> {
            vec![0; self.wolves.len() + self.targets.len()]
        }
    }
}
