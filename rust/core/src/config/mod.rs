//! Parameters of a scenario: the single source of truth for `params.yaml`.
//!
//! Python reads YAML and hands the dict over; serde rejects unknown keys and wrong types, and
//! [`Params::validate`] checks ranges and cross-field rules. Every default is the documented
//! scenario (docs/world-and-laws.md §1–§5); `params.yaml` at the repository root spells the
//! same values out and a test keeps the two equal. Derived quantities (the capture count when left `null`, the
//! Δ-widening table's row) are computed, not stored.

mod laws;

pub use laws::{AvoidanceParams, BvcParams, EscapeParams, FormationParams, KappaRow, Seed000Params};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::math::PI;

/// The whole scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    pub world: WorldParams,
    pub agents: AgentsParams,
    pub obstacles: ObstacleParams,
    pub capture: CaptureParams,
    pub policies: PolicyParams,
    pub seed000: Seed000Params,
    pub bvc: BvcParams,
    pub formation: FormationParams,
    pub avoidance: AvoidanceParams,
    pub escape: EscapeParams,
    /// The learning interface: action mode and observations.
    pub env: EnvParams,
    /// Rewards of the learning interface, per side.
    pub rewards: RewardParams,
}

/// Arena, clock, agent counts and spawning (docs/world-and-laws.md §1.1–§1.4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WorldParams {
    /// `[x_min, y_min, x_max, y_max]` in metres.
    pub border: [f64; 4],
    /// Sampling time Ts in seconds.
    pub ts: f64,
    /// Episode limit TOTSTEP in steps.
    pub max_steps: u32,
    /// Number of wolves N ≥ 1.
    pub wolves: usize,
    /// Number of targets M ≥ 1.
    pub targets: usize,
    /// INIT_D: clearance between spawned obstacles and agents / other obstacles (m).
    pub init_clearance: f64,
    /// The feasibility filter (docs/world-and-laws.md §1.6 step 3): halve infeasible wolf speeds /
    /// freeze infeasible targets.
    pub feasibility_filter: bool,
    /// With several targets, wolves re-pick their nearest target every this many steps.
    pub retarget_period: u32,
    /// Rejection-sampling budget: tries per agent or obstacle before a layout restart.
    pub spawn_attempts: u32,
    /// Whole-layout restarts before spawning gives up with an error.
    pub spawn_restarts: u32,
}

impl Default for WorldParams {
    fn default() -> Self {
        Self {
            border: [-10.0, -10.0, 10.0, 10.0],
            ts: 0.1,
            max_steps: 300,
            wolves: 5,
            targets: 1,
            init_clearance: 1.5,
            feasibility_filter: true,
            retarget_period: 5,
            spawn_attempts: 1000,
            spawn_restarts: 20,
        }
    }
}

/// Kinematic limits and sensing of one side.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SideParams {
    /// Maximum linear speed (m/s); no reverse motion.
    pub v_max: f64,
    /// Maximum |ω| (rad/s).
    pub omega_max: f64,
    /// Mass for the energy ½ m v² per step (kg).
    pub mass: f64,
    /// Sensing radius r_w (m): a wolf senses a target, a target senses wolves, within it.
    pub sense_radius: f64,
}

impl Default for SideParams {
    fn default() -> Self {
        Self { v_max: 1.5, omega_max: 7.0, mass: 1.0, sense_radius: 3.0 }
    }
}

/// Target side: as [`SideParams`] plus the fatigue rule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TargetSideParams {
    pub v_max: f64,
    pub omega_max: f64,
    pub mass: f64,
    pub sense_radius: f64,
    /// Fatigue as a world rule (docs/world-and-laws.md §5.2): from its first sighting on, a
    /// target's speed is capped by the fatigue curve whoever controls it.
    pub fatigue: bool,
}

impl Default for TargetSideParams {
    fn default() -> Self {
        let s = SideParams::default();
        Self { v_max: s.v_max, omega_max: s.omega_max, mass: s.mass, sense_radius: s.sense_radius, fatigue: true }
    }
}

impl TargetSideParams {
    pub fn side(&self) -> SideParams {
        SideParams { v_max: self.v_max, omega_max: self.omega_max, mass: self.mass, sense_radius: self.sense_radius }
    }
}

/// Body triangle, shared by wolves and targets (docs/world-and-laws.md §1.2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BodyParams {
    pub base: f64,
    pub height: f64,
}

impl Default for BodyParams {
    fn default() -> Self {
        Self { base: 0.2, height: 0.2 }
    }
}

impl BodyParams {
    /// Two bodies whose pose points are farther apart than this cannot touch (every vertex lies
    /// within max(height, base) of its pose point): the cheap cull before an exact overlap test.
    pub fn reach(&self) -> f64 {
        2.0 * self.height.max(self.base)
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct AgentsParams {
    pub wolf: SideParams,
    pub target: TargetSideParams,
    pub body: BodyParams,
}

/// Obstacle counts and their random shapes and motion (docs/world-and-laws.md §1.3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ObstacleParams {
    pub static_circles: usize,
    pub moving_circles: usize,
    pub static_polygons: usize,
    pub moving_polygons: usize,
    /// Circle radius ~ U(lo, hi).
    pub circle_radius: [f64; 2],
    /// Polygon size R ~ U(lo, hi).
    pub polygon_size: [f64; 2],
    /// Vertex count ~ uniform integer in [lo, hi] (lo ≥ 4: one per quadrant).
    pub polygon_vertices: [u32; 2],
    /// Vertex radius = sqrt(U(inner, 1)) · R.
    pub polygon_inner: f64,
    /// Every polygon rotates by U(−rotation_max, rotation_max) rad each step.
    pub rotation_max: f64,
    /// Moving obstacles translate by v Ts with v ~ N(0, speed_std²) per axis each step.
    pub speed_std: f64,
}

impl Default for ObstacleParams {
    fn default() -> Self {
        Self {
            static_circles: 1,
            moving_circles: 1,
            static_polygons: 5,
            moving_polygons: 5,
            circle_radius: [0.25, 1.25],
            polygon_size: [0.5, 1.25],
            polygon_vertices: [7, 15],
            polygon_inner: 0.07,
            rotation_max: PI / 16.0,
            speed_std: 0.5,
        }
    }
}

impl ObstacleParams {
    pub fn total(&self) -> usize {
        self.static_circles + self.moving_circles + self.static_polygons + self.moving_polygons
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CaptureRule {
    /// At least `count` wolves within `distance`.
    Count,
    /// As `count`, and the target inside the convex hull of those wolves.
    Encircle,
    /// The source of the `bvc` law's stopping rule (docs/world-and-laws.md §1.7): every wolf
    /// hunting the target is within `arrive_tolerance` of its hunting point — N points evenly
    /// spaced on the `bvc.radius` ring around the target, the first at angle 0, assigned to the
    /// wolves by minimum total distance as `bvc` assigns them (re-solved on the positions after the
    /// move). The same test for every law; `count` plays no part in it.
    HuntingPoints,
}

/// Success criteria (docs/world-and-laws.md §1.7): world rules, the same for every law.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CaptureParams {
    /// R_ATTACKED (m).
    pub distance: f64,
    /// Wolves needed within `distance`; `null` means ⌈0.8 N⌉ (4 for 5 wolves).
    pub count: Option<usize>,
    pub rule: CaptureRule,
    /// Whether a *cornered* target ends as a success with its own outcome `cornered`. A target is
    /// cornered when it lies within `distance` of at least one wall, at least 2 wolves are within
    /// `distance` of it, and it lies inside the convex hull of those wolves together with its
    /// closest points on every wall within `distance` (docs/world-and-laws.md §1.7). Off (the
    /// default) keeps the documented scenario's outcomes; every episode still records whether (and
    /// when first) its target was cornered.
    pub cornered: bool,
    /// `rule: hunting_points`: how close (m) each wolf must be to its hunting point.
    pub arrive_tolerance: f64,
}

impl Default for CaptureParams {
    fn default() -> Self {
        Self { distance: 0.8, count: None, rule: CaptureRule::Count, cornered: false, arrive_tolerance: 0.2 }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WolfPolicy {
    Seed000,
    Bvc,
    Formation,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TargetPolicy {
    Escape,
    Random,
    Still,
}

impl WolfPolicy {
    /// Every wolf law, in the order the documents and the CLI list them.
    pub const ALL: [WolfPolicy; 3] = [Self::Seed000, Self::Bvc, Self::Formation];

    /// The name `policies.wolves` takes.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Seed000 => "seed000",
            Self::Bvc => "bvc",
            Self::Formation => "formation",
        }
    }
}

impl TargetPolicy {
    /// Every target law, in the order the documents and the CLI list them.
    pub const ALL: [TargetPolicy; 3] = [Self::Escape, Self::Random, Self::Still];

    /// The name `policies.targets` takes.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Escape => "escape",
            Self::Random => "random",
            Self::Still => "still",
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PolicyParams {
    pub wolves: WolfPolicy,
    pub targets: TargetPolicy,
}

impl Default for PolicyParams {
    fn default() -> Self {
        Self { wolves: WolfPolicy::Seed000, targets: TargetPolicy::Escape }
    }
}

/// How a learner's action `a ∈ [-1, 1]²` becomes a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ActionMode {
    /// `v = (a₀ + 1)/2 · v_max`, `ω = a₁ · ω_max`.
    Unicycle,
    /// `a` is a desired velocity in the agent frame (x ahead, y left) in units of v_max (norm
    /// capped at 1); it goes through the saturator (docs/world-and-laws.md §2) like an analytic
    /// law's.
    Velocity,
}

/// Lidar of the observations: `rays` rays evenly spaced from the heading, counter-clockwise,
/// cast against obstacles and walls up to `range`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LidarParams {
    pub rays: usize,
    /// Metres; a ray that hits nothing reads 1 (distance / range).
    pub range: f64,
    /// Standard deviation of the Gaussian noise added to every reading (in units of `range`),
    /// the sum clipped to [0, 1]; 0 = exact readings. Only what learners observe is noisy: the
    /// scripted laws sense the world exactly. The draws come from a stream of their own
    /// ([`crate::world::World::sensing_rng`]), so noise never changes an episode's motion.
    pub noise: f64,
}

impl Default for LidarParams {
    fn default() -> Self {
        Self { rays: 16, range: 3.0, noise: 0.0 }
    }
}

/// How a side's observation (or the world's global state) is laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ObservationKind {
    /// One fixed vector whose size follows the team sizes (docs/interface.md, "Observations").
    Flat,
    /// The agent's own features and a padded set of entity rows with a mask
    /// (docs/interface.md, "Entity observations"): the size follows `env.entities`' capacities
    /// only, so one model plays any team size, target count and obstacle count within them.
    Entities,
}

/// The capacities and reach of entity observations (`env.observation: entities`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EntityParams {
    /// Wolf rows: a wolf sees the other `max_wolves − 1`, a target up to `max_wolves`; must be
    /// at least `world.wolves`.
    pub max_wolves: usize,
    /// Target rows; must be at least `world.targets`.
    pub max_targets: usize,
    /// Obstacle rows: the nearest obstacles whose surface lies within `range`, nearest first;
    /// obstacles beyond the capacity are left out (the lidar still sees them).
    pub max_obstacles: usize,
    /// Metres: how far an obstacle's surface may be to get a row.
    pub range: f64,
}

impl Default for EntityParams {
    fn default() -> Self {
        Self { max_wolves: 8, max_targets: 3, max_obstacles: 8, range: 5.0 }
    }
}

/// The learning interface: action mapping and observation content.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EnvParams {
    pub action_mode: ActionMode,
    /// The wolves' action mode when it differs from `action_mode` (None: `action_mode`); a
    /// learned opponent trained in another mode keeps its own.
    pub wolf_action_mode: Option<ActionMode>,
    /// The targets' action mode when it differs from `action_mode` (None: `action_mode`).
    pub target_action_mode: Option<ActionMode>,
    pub lidar: LidarParams,
    /// Append the agent's row of the interaction matrix (N+M entries, 0/1, from the last step).
    pub interaction_row: bool,
    /// Append to each wolf's observation, per target, the pack's latest sighting of it
    /// (sighted, dx/S, dy/S in the wolf's frame, age / max_steps): what global communication
    /// tells a wolf that senses nothing now, and what seed000's "remembered attraction" keeps.
    pub last_sighting: bool,
    /// Both sides' observation layout unless a side has its own.
    pub observation: ObservationKind,
    /// The wolves' own layout when it differs from `observation` (None: `observation`); a
    /// learned opponent keeps the one it was trained with, as with the action modes.
    pub wolf_observation: Option<ObservationKind>,
    /// The targets' own layout when it differs from `observation` (None: `observation`).
    pub target_observation: Option<ObservationKind>,
    /// The global state's layout (`BatchEnv.state()`, MAPPO's critic): `flat` (every agent and
    /// obstacle by index) or `entities` (one row per agent, padded to the capacities).
    pub state: ObservationKind,
    pub entities: EntityParams,
}

impl Default for EnvParams {
    fn default() -> Self {
        Self {
            action_mode: ActionMode::Unicycle,
            wolf_action_mode: None,
            target_action_mode: None,
            lidar: LidarParams::default(),
            interaction_row: false,
            last_sighting: false,
            observation: ObservationKind::Flat,
            wolf_observation: None,
            target_observation: None,
            state: ObservationKind::Flat,
            entities: EntityParams::default(),
        }
    }
}

impl EnvParams {
    /// How the wolves' actions become commands.
    pub fn wolf_mode(&self) -> ActionMode {
        self.wolf_action_mode.unwrap_or(self.action_mode)
    }

    /// How the targets' actions become commands.
    pub fn target_mode(&self) -> ActionMode {
        self.target_action_mode.unwrap_or(self.action_mode)
    }

    /// The wolves' observation layout.
    pub fn wolf_observation_kind(&self) -> ObservationKind {
        self.wolf_observation.unwrap_or(self.observation)
    }

    /// The targets' observation layout.
    pub fn target_observation_kind(&self) -> ObservationKind {
        self.target_observation.unwrap_or(self.observation)
    }

    /// Whether either side observes entity rows.
    pub fn observes_entities(&self) -> bool {
        [self.wolf_observation_kind(), self.target_observation_kind()].contains(&ObservationKind::Entities)
    }

    /// Whether any observation or the state uses entity rows (the capacities then bind).
    pub fn uses_entities(&self) -> bool {
        self.observes_entities() || self.state == ObservationKind::Entities
    }
}

/// Wolf rewards (each wolf, each step).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WolfRewards {
    /// To every wolf at the step a target is captured (team reward).
    pub capture_bonus: f64,
    /// Potential-based shaping `shaping · (Φ(s') − Φ(s))` with `Φ = −|d − r_h|`, d the wolf's
    /// distance to its target and r_h `seed000.radius`; Φ = 0 in a terminal state.
    pub shaping: f64,
    /// Subtracted from a wolf at a step its body overlaps an obstacle or another wolf.
    pub collision_penalty: f64,
    /// Subtracted from every wolf at every step.
    pub time_penalty: f64,
    /// Which target the shaping measures each wolf's distance to.
    pub shaping_focus: ShapingFocus,
}

impl Default for WolfRewards {
    fn default() -> Self {
        Self { capture_bonus: 10.0, shaping: 1.0, collision_penalty: 10.0, time_penalty: 0.01, shaping_focus: ShapingFocus::Nearest }
    }
}

/// The target a wolf's shaping potential measures its distance to (`rewards.wolves.shaping_focus`).
/// With one target both are the same; with several, `nearest` pulls each wolf towards its own
/// nearest target and so splits the pack, while a capture needs `capture.count` wolves on one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ShapingFocus {
    /// Each wolf's own nearest uncaptured target.
    #[default]
    Nearest,
    /// One target for the whole pack: the uncaptured target with the least total distance to
    /// the wolves (ties to the lower index).
    Pack,
}

/// Target rewards (each target, each step).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TargetRewards {
    /// Per step survived uncaptured.
    pub survival: f64,
    /// Subtracted at the step the target is captured.
    pub capture_penalty: f64,
    /// Subtracted at a step its body overlaps an obstacle (a moving obstacle can hit it).
    pub collision_penalty: f64,
}

impl Default for TargetRewards {
    fn default() -> Self {
        Self { survival: 0.1, capture_penalty: 10.0, collision_penalty: 10.0 }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct RewardParams {
    pub wolves: WolfRewards,
    pub targets: TargetRewards,
}

fn bad(key: &str, why: impl std::fmt::Display) -> Error {
    Error::Params(format!("{key}: {why}"))
}

fn ordered(key: &str, r: [f64; 2]) -> Result<()> {
    if r[0] > r[1] {
        return Err(bad(key, format!("lower bound {} exceeds upper bound {}", r[0], r[1])));
    }
    Ok(())
}

/// serde's wording of a value of the wrong type or range (`invalid value: integer `-3`,
/// expected usize`) in the project's words, with the key's documented range where it has one
/// (`must be an integer in [1, 1024] wolves (wolves + targets <= 1024), got -3`). Messages of
/// other kinds (unknown fields, missing keys) pass unchanged.
pub fn plain_words(key: &str, message: &str) -> String {
    let Some(rest) = message.strip_prefix("invalid type: ").or_else(|| message.strip_prefix("invalid value: ")) else {
        return message.to_string();
    };
    let Some((got, expected)) = rest.rsplit_once(", expected ") else {
        return message.to_string();
    };
    let range = crate::limits::limit_of(key).map(|l| format!(" in {}", l.describe())).unwrap_or_default();
    let wanted = match expected {
        "usize" | "u64" | "u32" | "u16" | "u8" => format!("an integer{}", if range.is_empty() { " >= 0".to_string() } else { range }),
        "i64" | "i32" => format!("an integer{range}"),
        "f64" | "f32" => format!("a number{range}"),
        "a boolean" => "true or false".to_string(),
        "a sequence" => "a list".to_string(),
        "a map" | "struct Params" => "a mapping".to_string(),
        other => other.to_string(),
    };
    // serde names the value's kind and quotes it with backticks: `integer `-3``, `string "abc"`.
    let shown = match got.split_once(' ') {
        Some((kind, value)) if ["integer", "floating", "boolean"].contains(&kind) => value.rsplit(' ').next().unwrap_or(value).trim_matches('`').to_string(),
        Some(("string", value)) => value.to_string(),
        _ => match got {
            "map" => "a mapping".to_string(),
            "sequence" => "a list".to_string(),
            "unit value" | "null" => "null".to_string(),
            other => other.to_string(),
        },
    };
    format!("must be {wanted}, got {shown}")
}

impl Params {
    /// Parses a value tree (from YAML/JSON via Python, or serde_json in tests) and validates it.
    /// Errors name the offending key path, e.g. `world.wolvs: unknown field ...`.
    pub fn from_deserializer<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Self> {
        let p: Params = serde_path_to_error::deserialize(d).map_err(|e| {
            let path = e.path().to_string();
            let inner = plain_words(&path, &e.into_inner().to_string());
            if path.is_empty() || path == "." {
                Error::Params(inner)
            } else {
                Error::Params(format!("{path}: {inner}"))
            }
        })?;
        p.validate()?;
        Ok(p)
    }

    /// Wolves needed for a capture: `capture.count`, or ⌈0.8 N⌉ when left `null`.
    pub fn capture_count(&self) -> usize {
        self.capture.count.unwrap_or_else(|| ((0.8 * self.world.wolves as f64).ceil() as usize).max(1))
    }

    /// The derived copy that tools show: `capture.count` filled in.
    pub fn resolved(&self) -> Params {
        let mut p = self.clone();
        p.capture.count = Some(self.capture_count());
        p
    }

    /// Range and cross-field checks. Each error names its key and, for a range, the allowed
    /// interval ([`crate::limits::LIMITS`]: every numeric key has one).
    pub fn validate(&self) -> Result<()> {
        let tree = serde_json::to_value(self).map_err(|e| Error::Params(format!("params: {e}")))?;
        crate::limits::check(&tree)?;

        let w = &self.world;
        let [x0, y0, x1, y1] = w.border;
        for (axis, size) in [("width x_max - x_min", x1 - x0), ("height y_max - y_min", y1 - y0)] {
            if !(1.0..=1e4).contains(&size) {
                return Err(bad("world.border", format!("{axis} must be in [1, 1e4] m, got {size}")));
            }
        }
        // Bounded so that per-step (N+M)² work and logs stay sane; far beyond the field's use.
        if w.wolves + w.targets > 1024 {
            return Err(bad("world.wolves", format!("wolves + targets must be <= 1024, got {} + {}", w.wolves, w.targets)));
        }

        let o = &self.obstacles;
        ordered("obstacles.circle_radius", o.circle_radius)?;
        ordered("obstacles.polygon_size", o.polygon_size)?;
        let [lo, hi] = o.polygon_vertices;
        if lo > hi {
            return Err(bad("obstacles.polygon_vertices", format!("lower bound {lo} exceeds upper bound {hi}")));
        }
        if o.total() > 10_000 {
            return Err(bad("obstacles", format!("more than 10000 obstacles ({})", o.total())));
        }

        if let Some(c) = self.capture.count {
            if c > w.wolves {
                return Err(bad("capture.count", format!("{c} exceeds world.wolves = {}", w.wolves)));
            }
        }

        let e = &self.env.entities;
        if self.env.uses_entities() {
            // The wolves' and targets' rows are every agent: a scenario with more than the
            // capacity would silently drop some (obstacle rows are a nearest-first selection).
            if e.max_wolves < w.wolves {
                return Err(bad("env.entities.max_wolves", format!("{} is below world.wolves = {}: the entity rows cannot hold every wolf", e.max_wolves, w.wolves)));
            }
            if e.max_targets < w.targets {
                return Err(bad("env.entities.max_targets", format!("{} is below world.targets = {}: the entity rows cannot hold every target", e.max_targets, w.targets)));
            }
        }
        if self.env.interaction_row && self.env.observes_entities() {
            // The interaction row has N + M entries: it would tie an entity observation's size
            // to the team sizes again.
            return Err(bad("env.interaction_row", "is not available with entity observations (its size follows the team sizes)"));
        }

        let f = &self.formation;
        if f.clearance < f.wolf_diameter / 2.0 {
            // With this the path search, which inflates each disc by the clearance, can never
            // pass between two members of a merged structure (gap <= wolf_diameter).
            return Err(bad("formation.clearance", format!("must be at least formation.wolf_diameter / 2 = {}, got {}", f.wolf_diameter / 2.0, f.clearance)));
        }
        Ok(())
    }

    /// Bytes one recorded episode needs at most (poses, energies, interaction matrices, law
    /// modes and obstacle poses for every step up to `world.max_steps`), checked before
    /// recording.
    pub fn recorded_episode_bytes(&self) -> u64 {
        let (n, m, k) = (self.world.wolves as u64, self.world.targets as u64, self.obstacles.total() as u64);
        let rows = self.world.max_steps as u64 + 1;
        rows * (8 * (5 * (n + m) + (n + m) + 3 * k) + (n + m)) + (rows - 1) * (n + m) * (n + m)
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn serde_wording_becomes_the_projects() {
        let err = |tree: serde_json::Value| Params::from_deserializer(tree).unwrap_err().to_string();
        let e = err(serde_json::json!({"world": {"wolves": -3}}));
        assert!(e.contains("world.wolves: must be an integer in [1, 1024] wolves") && e.ends_with("got -3"), "{e}");
        let e = err(serde_json::json!({"world": {"wolves": 2.5}}));
        assert!(e.contains("world.wolves: must be an integer in [1, 1024]") && e.ends_with("got 2.5"), "{e}");
        let e = err(serde_json::json!({"world": {"ts": "abc"}}));
        assert!(e.contains("world.ts: must be a number in (0, 1] s, got \"abc\""), "{e}");
        let e = err(serde_json::json!({"env": {"last_sighting": 3}}));
        assert!(e.ends_with("env.last_sighting: must be true or false, got 3"), "{e}");
        let e = err(serde_json::json!({"world": {"border": 3}}));
        assert!(!e.contains("usize") && !e.contains("f64") && e.contains("must be"), "{e}");
        // Other messages pass through.
        assert_eq!(plain_words("world", "unknown field `wolvs`"), "unknown field `wolvs`");
    }
    use super::*;

    fn parse(json: &str) -> Result<Params> {
        let mut de = serde_json::Deserializer::from_str(json);
        Params::from_deserializer(&mut de)
    }

    #[test]
    fn empty_document_is_the_documented_scenario() {
        let p = parse("{}").unwrap();
        assert_eq!(p, Params::default());
        assert_eq!(p.capture_count(), 4);
        assert_eq!(p.obstacles.total(), 12);
    }

    #[test]
    fn unknown_key_is_named_with_its_path() {
        let e = parse(r#"{"world": {"wolvs": 3}}"#).unwrap_err().to_string();
        assert!(e.contains("world") && e.contains("wolvs"), "{e}");
    }

    #[test]
    fn wrong_type_is_named() {
        let e = parse(r#"{"world": {"wolves": "five"}}"#).unwrap_err().to_string();
        assert!(e.starts_with("world.wolves"), "{e}");
    }

    #[test]
    fn ranges_are_checked() {
        for (doc, key) in [
            (r#"{"world": {"ts": 0}}"#, "world.ts"),
            (r#"{"world": {"ts": -0.1}}"#, "world.ts"),
            (r#"{"world": {"max_steps": 0}}"#, "world.max_steps"),
            (r#"{"world": {"wolves": 0}}"#, "world.wolves"),
            (r#"{"world": {"border": [5, -10, 5, 10]}}"#, "world.border"),
            (r#"{"capture": {"count": 6}}"#, "capture.count"),
            (r#"{"capture": {"arrive_tolerance": 0}}"#, "capture.arrive_tolerance"),
            (r#"{"capture": {"arrive_tolerance": -0.1}}"#, "capture.arrive_tolerance"),
            (r#"{"capture": {"cornered": 1}}"#, "capture.cornered"),
            (r#"{"capture": {"cornered": "yes"}}"#, "capture.cornered"),
            (r#"{"capture": {"rule": "surround"}}"#, "capture.rule"),
            (r#"{"agents": {"wolf": {"v_max": -1}}}"#, "agents.wolf.v_max"),
            (r#"{"obstacles": {"circle_radius": [0, 1]}}"#, "obstacles.circle_radius"),
            (r#"{"formation": {"bump_delta": 1.0}}"#, "formation.bump_delta"),
            (r#"{"formation": {"ring_points": 2}}"#, "formation.ring_points"),
            (r#"{"formation": {"spacing": 0}}"#, "formation.spacing"),
            (r#"{"formation": {"clearance": 0.1}}"#, "formation.clearance"),
            (r#"{"bvc": {"safety_radius": -0.1}}"#, "bvc.safety_radius"),
            (r#"{"bvc": {"assignment_period": 0}}"#, "bvc.assignment_period"),
            (r#"{"bvc": {"disc_sides": 3}}"#, "bvc.disc_sides"),
            (r#"{"bvc": {"radius": 0}}"#, "bvc.radius"),
            (r#"{"bvc": {"speed": 1}}"#, "bvc.speed"),
        ] {
            let e = parse(doc).unwrap_err().to_string();
            assert!(e.starts_with(key), "{doc}: {e}");
        }
    }

    #[test]
    fn unknown_policy_is_named() {
        let e = parse(r#"{"policies": {"targets": "flee"}}"#).unwrap_err().to_string();
        assert!(e.starts_with("policies.targets") && e.contains("flee"), "{e}");
    }

    #[test]
    fn capture_count_derives_from_wolves() {
        let p = parse(r#"{"world": {"wolves": 3}}"#).unwrap();
        assert_eq!(p.capture_count(), 3);
        let p = parse(r#"{"world": {"wolves": 10}}"#).unwrap();
        assert_eq!(p.capture_count(), 8);
    }

    #[test]
    fn fatigue_curve_caps_then_falls_to_base() {
        let e = EscapeParams::default();
        assert!(e.fatigue_speed(0, 0) > 1.79);
        // 0.9·(2 − 1/(1+e^{0.25·3})) at t − t_seen = 97: just above 1.5.
        let v97 = 0.9 * (2.0 - 1.0 / (1.0 + (0.75f64).exp()));
        assert!((e.fatigue_speed(10, 107) - v97).abs() < 1e-12);
        assert!(v97 > 1.5 && e.fatigue_speed(0, 98) < 1.5);
        assert!((e.fatigue_speed(0, 400) - 0.9).abs() < 1e-6);
    }
}
