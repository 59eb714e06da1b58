//! What the scripted laws carry from one step to the next, per agent: each law's own memory
//! (the law's module names it `Memory`), held by the world between steps and handed back to
//! the law. Plain data, so that the world can hold it without knowing the laws.

use super::{AgentState, LawMode, Snapshot};
use crate::config::WolfPolicy;
use crate::math::Vec2;

/// An emergency (docs/world-and-laws.md §4.5) lasts several steps: what the avoidance of a law
/// remembers between them (part of the memories of seed000, escape and random).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DangerMemory {
    /// Steps of the current emergency still to run, this one included (0: none).
    pub steps_left: u32,
    /// Heading (rad) straight away from the dangerous interval's bisector.
    pub away: f64,
}

/// What the seed000 law carries from one step to the next for one wolf.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Seed000Memory {
    /// The previous step's attraction vector ν₁ (zero before the first step).
    pub last_attraction: Vec2,
    pub danger: DangerMemory,
    /// The branch that decided the last command (an output: the law never reads it).
    pub mode: LawMode,
}

/// What the `escape` and `random` laws carry from one step to the next for one target.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EscapeMemory {
    pub danger: DangerMemory,
    /// The branch that decided the last command (an output: the law never reads it).
    pub mode: LawMode,
}

/// What the bvc law carries from one step to the next for one wolf.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BvcMemory {
    pub sighting: Sighting,
    /// The hunting point assigned at the last assignment.
    pub point: Option<usize>,
    /// The branch that decided the last command (an output: the law never reads it).
    pub mode: LawMode,
}

/// What the formation law carries from one step to the next for one wolf.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FormationMemory {
    pub sighting: Sighting,
    /// The branch that decided the last command (an output: the law never reads it).
    pub mode: LawMode,
}

/// The pack's last sighting of a wolf's target, for the laws that hunt a position (bvc,
/// formation).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Sighting {
    /// The target as the pack last sensed it (None before any sighting)...
    pub target: Option<AgentState>,
    /// ... and the step of that sighting (formation predicts where it went since).
    pub t: u32,
}

impl Sighting {
    /// Global communication (docs/world-and-laws.md §1.5): when any wolf hunting wolf i's target
    /// senses it, the whole pack learns the target's state and the step; returns the target as last
    /// sensed (None before any sighting).
    pub fn share(&mut self, i: usize, snap: &Snapshot) -> Option<AgentState> {
        let target = snap.wolf_target[i];
        if snap.wolf_senses.iter().zip(snap.wolf_target).any(|(&s, &t)| s && t == target) {
            self.target = Some(snap.targets[target]);
            self.t = snap.t;
        }
        self.target
    }

    /// Whether this step's [`Sighting::share`] found the target sensed (rather than
    /// remembering an older sighting).
    pub fn is_now(&self, snap: &Snapshot) -> bool {
        self.target.is_some() && self.t == snap.t
    }
}

/// What a wolf's law carries from one step to the next: the configured law's own memory, one
/// variant per wolf law. The world holds one per wolf between steps and hands it back to the law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WolfMemory {
    Seed000(Seed000Memory),
    Bvc(BvcMemory),
    Formation(FormationMemory),
}

impl WolfMemory {
    /// The memory of `law` before an episode's first step.
    pub fn new(law: WolfPolicy) -> Self {
        match law {
            WolfPolicy::Seed000 => Self::Seed000(Default::default()),
            WolfPolicy::Bvc => Self::Bvc(Default::default()),
            WolfPolicy::Formation => Self::Formation(Default::default()),
        }
    }

    /// The branch of the law that decided its last command (none before its first).
    pub fn mode(&self) -> LawMode {
        match self {
            Self::Seed000(m) => m.mode,
            Self::Bvc(m) => m.mode,
            Self::Formation(m) => m.mode,
        }
    }

    /// The law this memory belongs to.
    pub fn law(&self) -> WolfPolicy {
        match self {
            Self::Seed000(_) => WolfPolicy::Seed000,
            Self::Bvc(_) => WolfPolicy::Bvc,
            Self::Formation(_) => WolfPolicy::Formation,
        }
    }
}

/// What a target's law carries from one step to the next (`escape` and `random` share it;
/// `still` needs none).
pub type TargetMemory = EscapeMemory;
