//! What the world and the analytic laws share, below both: the agents' and obstacles' state,
//! the per-step neighbour lists, the [`Snapshot`] a law reads and the [`Command`] it returns.
//! The world (`crate::world`) owns and steps these; the laws (`crate::policies`) read them; neither
//! module imports the other's types for this, and the laws never import the world.

mod memory;
mod mode;
mod near;
mod obstacles;

pub use memory::{BvcMemory, DangerMemory, EscapeMemory, FormationMemory, Seed000Memory, Sighting, TargetMemory, WolfMemory};
pub use mode::LawMode;
pub use near::{cull_distance, near, Near, Neighbours};
pub(crate) use obstacles::PolygonDraw;
pub use obstacles::{Obstacle, ObstacleKind};

use crate::config::Params;
use crate::math::Vec2;

/// Pose and last command of one unicycle agent, plus its accumulated energy.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AgentState {
    pub pos: Vec2,
    /// Heading in [0, 2π).
    pub theta: f64,
    /// Linear speed executed in the last step (m/s).
    pub v: f64,
    /// Turn rate executed in the last step (rad/s).
    pub omega: f64,
    /// Σ ½ m v² over the steps so far (J; per step, no Ts factor — docs/world-and-laws.md §1.2).
    pub energy: f64,
}

impl AgentState {
    pub fn at(x: f64, y: f64, theta: f64) -> Self {
        Self { pos: Vec2::new(x, y), theta: crate::math::wrap(theta), ..Default::default() }
    }
}

/// What a controller asks of an agent for one step: linear speed v ≥ 0 and turn rate ω.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Command {
    pub v: f64,
    pub omega: f64,
}

/// The read-only state every controller sees at the start of a step (after obstacles moved).
#[derive(Debug, Clone, Copy)]
pub struct Snapshot<'a> {
    pub params: &'a Params,
    /// Steps completed before this one: 0 at the first step of an episode.
    pub t: u32,
    pub wolves: &'a [AgentState],
    pub targets: &'a [AgentState],
    pub obstacles: &'a [Obstacle],
    /// The obstacles near each agent this step (wolves, then targets); `None` means "look at
    /// every obstacle" — the same answers, only slower ([`Neighbours`]).
    pub near: Option<&'a Neighbours>,
    /// The target each wolf hunts (its nearest uncaptured target, re-picked every
    /// `world.retarget_period` steps).
    pub wolf_target: &'a [usize],
    /// Wolf i senses its own target: distance ≤ `agents.wolf.sense_radius`.
    pub wolf_senses: &'a [bool],
    /// First step at which target j sensed a wolf (`None`: never yet).
    pub target_seen_at: &'a [Option<u32>],
    pub target_captured: &'a [bool],
}
