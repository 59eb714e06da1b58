//! What the scripted laws carry from one step to the next, per agent. The world holds these
//! between steps (`World::wolf_memory`, `World::target_memory`) and hands each law its own;
//! they are plain data, defined here beside the rest of the world's state so that the world's
//! types come from the world, and the laws (`crate::policies`, which re-exports them) use them.

use super::AgentState;
use crate::math::Vec2;

/// An emergency (SPEC §4) lasts several steps; the law remembers where it flees.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DangerMemory {
    /// Steps of the current emergency still to run, this one included (0: none).
    pub steps_left: u32,
    /// Heading (rad) straight away from the dangerous interval's bisector.
    pub away: f64,
}

/// What the seed000 law carries from one step to the next for one wolf.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WolfMemory {
    /// The previous step's attraction vector ν₁ (zero before the first step).
    pub last_attraction: Vec2,
    pub danger: DangerMemory,
    /// bvc and formation: the target as the pack last sensed it (None before any sighting)...
    pub known_target: Option<AgentState>,
    /// ... and the step of that sighting (formation predicts where it went since).
    pub last_seen_t: u32,
    /// bvc: the hunting point assigned at the last assignment.
    pub bvc_point: Option<usize>,
}

/// What the scripted target laws carry from one step to the next for one target.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TargetMemory {
    pub danger: DangerMemory,
}
