//! The world of docs/world-and-laws.md §1: arena, agents, obstacles, sensing, one synchronous step.

mod expert;
mod layout;
mod spawn;
mod step;

pub use expert::Desired;
pub use layout::{Layout, LayoutObstacle};
pub(crate) use step::Controls;
// The types the world shares with the laws live below both (crate::scene); the world's
// users find them here as well.
pub use crate::scene::{cull_distance, near, AgentState, LawMode, Near, Neighbours, Obstacle, ObstacleKind, TargetMemory, WolfMemory};

use std::sync::Arc;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::config::Params;
use crate::error::Result;
use crate::geometry::{body_triangle, BodyFrame};
use crate::math::{sin_cos, Vec2};
use crate::scene::Command;

/// How an episode ended (docs/world-and-laws.md §1.7).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    Running,
    /// Every target captured.
    Captured,
    /// A wolf overlapped an obstacle or another wolf.
    Collision,
    /// `world.max_steps` reached.
    Timeout,
    /// Every target captured or cornered, at least one of them cornered (only with
    /// `capture.cornered`; docs/world-and-laws.md §1.7).
    Cornered,
}

impl Outcome {
    /// Every outcome, in the order of their codes (the batch's `outcome` array): a code is an
    /// index into this list.
    pub const ALL: [Outcome; 5] = [Self::Running, Self::Captured, Self::Collision, Self::Timeout, Self::Cornered];

    pub fn as_str(self) -> &'static str {
        match self {
            Self::Running => "running",
            Self::Captured => "captured",
            Self::Collision => "collision",
            Self::Timeout => "timeout",
            Self::Cornered => "cornered",
        }
    }

    /// The episode ended as a success: every target captured (or cornered, where that counts).
    pub fn is_success(self) -> bool {
        matches!(self, Self::Captured | Self::Cornered)
    }
}

// Streams of the per-world ChaCha generator: spawning, obstacle motion and the scripted laws
// draw from separate streams, so a learned controller (which draws nothing) sees the same
// obstacle motion as the scripted one for the same seed.
// Episode k of a world seeded `seed` uses streams 4k + 0..3 of the same key (episode 0 is the
// plain `seed`), so the batch's autoreset episodes of world i depend on its seed alone — not on
// the batch size or how the batch is split.
const STREAM_SPAWN: u64 = 0;
const STREAM_MOTION: u64 = 1;
const STREAM_POLICY: u64 = 2;
const STREAM_SENSING: u64 = 3;
const STREAMS_PER_EPISODE: u64 = 4;

fn stream(seed: u64, episode: u64, s: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(episode.wrapping_mul(STREAMS_PER_EPISODE).wrapping_add(s));
    r
}

/// One world: everything needed to step it, deterministic from (params, seed, layout).
#[derive(Debug, Clone)]
pub struct World {
    pub params: Arc<Params>,
    /// Steps completed.
    pub t: u32,
    pub wolves: Vec<AgentState>,
    pub targets: Vec<AgentState>,
    pub obstacles: Vec<Obstacle>,
    pub wolf_target: Vec<usize>,
    pub wolf_senses: Vec<bool>,
    pub target_seen_at: Vec<Option<u32>>,
    /// Where each target stood, and at which step, the last time any wolf sensed it (after a
    /// step's moves, as the observations see it). Kept only with `env.last_sighting` or the
    /// wolves' entity observations.
    pub target_last_sighting: Vec<Option<(Vec2, u32)>>,
    /// Whether each target's hunt is over: captured or, with `capture.cornered`, cornered. An
    /// ended target stands still, and wolves re-pick among the others.
    pub target_captured: Vec<bool>,
    /// The step each target's hunt ended (capture, or cornering where it counts).
    pub target_capture_step: Vec<Option<u32>>,
    /// The first step at which each target was cornered (docs/world-and-laws.md §1.7), whether or
    /// not `capture.cornered` makes that a success.
    pub target_cornered_step: Vec<Option<u32>>,
    /// Whether each ended target's hunt ended by cornering rather than capture.
    pub target_ended_cornered: Vec<bool>,
    pub wolf_memory: Vec<WolfMemory>,
    pub target_memory: Vec<TargetMemory>,
    /// This step's interaction matrix, (N+M)² row-major; rows/columns: wolves, then targets.
    pub interaction: Vec<u8>,
    /// The branch of each wolf's law that decided its command in the last step
    /// ([`LawMode::None`] before the first step, and where given commands drove the wolves).
    /// An output: nothing reads it back.
    pub wolf_mode: Vec<LawMode>,
    /// As `wolf_mode`, for the targets.
    pub target_mode: Vec<LawMode>,
    /// Steps each agent (wolves, then targets) spent overlapping an obstacle or a wolf.
    pub collisions: Vec<u32>,
    pub outcome: Outcome,
    /// Run the scripted law of a side even while given commands drive it, so that its memory
    /// follows the episode (for [`World::expert_desired`], imitation learning). Off by default:
    /// it costs a law evaluation per agent and step.
    pub track_laws: bool,
    /// Place a polygon's vertices only when an agent could reach it this step (its bounding
    /// disc within the cull distance of a pose point) instead of after every move: a sin_cos
    /// and a rotation of 7–15 vertices for each of the other polygons, several per cent of a
    /// step of the documented scenario (BENCHMARKS.md, "Optimisations"), and at large batches
    /// the memory traffic of writing them. Laws that read every obstacle (bvc, formation) get
    /// every polygon placed. Only the episode runner and the batch set it, on worlds whose
    /// every reader places what it reads first: the lidar ([`World::place_for_lidar`]),
    /// `BatchEnv::world` ([`World::settle_obstacles`]).
    pub(crate) lazy_obstacles: bool,
    /// Set when a step produced a non-finite command or pose (see [`World::fault`]); the world
    /// is then done and does not move again.
    fault: Option<String>,
    rng_motion: ChaCha8Rng,
    rng_policy: ChaCha8Rng,
    /// The observation noise's stream, never advanced: read at a position fixed by (step,
    /// agent) ([`World::sensing_rng`]).
    rng_sensing: ChaCha8Rng,
    // Per-step scratch, kept to avoid allocation on the hot path.
    wolf_cmds: Vec<Command>,
    target_cmds: Vec<Command>,
    /// The wolves' and the targets' bodies at their current poses, kept from step to step.
    wolf_bodies: Bodies,
    target_bodies: Bodies,
    scratch_row: Vec<u8>,
    /// This step's obstacles near each agent ([`Neighbours`]), built once after the obstacles
    /// move and shared by the laws, the feasibility filter and the judge.
    near: Neighbours,
}

impl World {
    /// A world spawned at random from `seed` (docs/world-and-laws.md §1.4).
    pub fn new(params: Arc<Params>, seed: u64) -> Result<Self> {
        Self::new_episode(params, seed, 0)
    }

    /// Episode `episode` of the world seeded `seed`: independent random streams for every
    /// episode; episode 0 is [`World::new`].
    pub fn new_episode(params: Arc<Params>, seed: u64, episode: u64) -> Result<Self> {
        params.validate()?;
        Self::new_episode_prevalidated(params, seed, episode)
    }

    /// [`World::new_episode`] for params the caller has validated already (the episode runner
    /// and the batch check them once, not at every spawn: validation walks every key and
    /// cost a couple of per cent of the documented scenario's throughput when repeated per
    /// episode; BENCHMARKS.md, "Optimisations").
    pub(crate) fn new_episode_prevalidated(params: Arc<Params>, seed: u64, episode: u64) -> Result<Self> {
        let mut rng = stream(seed, episode, STREAM_SPAWN);
        let (wolves, targets, obstacles) = spawn::spawn(&params, &mut rng)?;
        Ok(Self::assemble(params, seed, episode, wolves, targets, obstacles))
    }

    /// A world started from an explicit layout. The layout's agent counts replace
    /// `world.wolves` / `world.targets` (a `null` capture count follows them); its obstacles
    /// are the whole obstacle set. `seed` drives obstacle motion and the scripted laws.
    pub fn from_layout(params: Arc<Params>, seed: u64, layout: &Layout) -> Result<Self> {
        Self::from_layout_episode(params, seed, 0, layout)
    }

    /// [`World::from_layout`] with the random streams of episode `episode`.
    pub fn from_layout_episode(params: Arc<Params>, seed: u64, episode: u64, layout: &Layout) -> Result<Self> {
        let (n, m) = (layout.wolves.len(), layout.targets.len());
        if n == 0 || m == 0 {
            let who = if n == 0 { "wolf" } else { "target" };
            return Err(crate::error::Error::Layout(format!("needs at least one {who}")));
        }
        let params = if (params.world.wolves, params.world.targets) == (n, m) { params } else { Arc::new(params.with_counts(n, m)) };
        params.validate().map_err(|e| crate::error::Error::Layout(e.to_string()))?;
        let (wolves, targets, obstacles) = spawn::from_layout(&params, layout)?;
        Ok(Self::assemble(params, seed, episode, wolves, targets, obstacles))
    }

    fn assemble(params: Arc<Params>, seed: u64, episode: u64, wolves: Vec<AgentState>, targets: Vec<AgentState>, obstacles: Vec<Obstacle>) -> Self {
        // Empty lists, which `restart` fills: a field added to World is set there too (the
        // respawn test compares a respawned world with a fresh one, field by field).
        let mut w = Self {
            params: params.clone(),
            t: 0,
            wolves: Vec::new(),
            targets: Vec::new(),
            obstacles: Vec::new(),
            wolf_target: Vec::new(),
            wolf_senses: Vec::new(),
            target_seen_at: Vec::new(),
            target_last_sighting: Vec::new(),
            target_captured: Vec::new(),
            target_capture_step: Vec::new(),
            target_cornered_step: Vec::new(),
            target_ended_cornered: Vec::new(),
            wolf_memory: Vec::new(),
            target_memory: Vec::new(),
            interaction: Vec::new(),
            wolf_mode: Vec::new(),
            target_mode: Vec::new(),
            collisions: Vec::new(),
            outcome: Outcome::Running,
            track_laws: false,
            lazy_obstacles: false,
            fault: None,
            rng_motion: stream(seed, episode, STREAM_MOTION),
            rng_policy: stream(seed, episode, STREAM_POLICY),
            rng_sensing: stream(seed, episode, STREAM_SENSING),
            wolf_cmds: Vec::new(),
            target_cmds: Vec::new(),
            wolf_bodies: Bodies::default(),
            target_bodies: Bodies::default(),
            scratch_row: Vec::new(),
            near: Neighbours::default(),
        };
        w.restart(params, seed, episode, wolves, targets, obstacles);
        w
    }

    /// Starts episode `episode` of the world seeded `seed` in this world's own lists: the
    /// state [`World::new_episode`] would build, field for field (a test checks), with the
    /// settings its owner chose (`track_laws`, `lazy_obstacles`) kept. A batch respawns its
    /// worlds this way, at every autoreset: a fresh world's ≈ 50 lists would land wherever the
    /// allocator had room, scattered over the heap, and a batch that had run a few hundred steps
    /// stepped markedly slower than a freshly built one (BENCHMARKS.md, "Optimisations"). On a
    /// spawn error the world is untouched.
    pub(crate) fn respawn(&mut self, params: Arc<Params>, seed: u64, episode: u64) -> Result<()> {
        let mut rng = stream(seed, episode, STREAM_SPAWN);
        let (wolves, targets, obstacles) = spawn::spawn(&params, &mut rng)?;
        self.restart(params, seed, episode, wolves, targets, obstacles);
        Ok(())
    }

    /// The one definition of a world's first state (for [`World::assemble`] and
    /// [`World::respawn`]): the spawned agents and obstacles, every other list refilled to its
    /// start, the episode's random streams.
    fn restart(&mut self, params: Arc<Params>, seed: u64, episode: u64, wolves: Vec<AgentState>, targets: Vec<AgentState>, obstacles: Vec<Obstacle>) {
        let (n, m) = (wolves.len(), targets.len());
        let wolf_law = params.policies.wolves;
        self.params = params;
        self.t = 0;
        self.wolves.clone_from(&wolves);
        self.targets.clone_from(&targets);
        self.obstacles.truncate(obstacles.len());
        for (k, o) in obstacles.into_iter().enumerate() {
            match self.obstacles.get_mut(k) {
                Some(mine) => mine.adopt(o),
                None => self.obstacles.push(o),
            }
        }
        refill(&mut self.wolf_target, n, 0);
        refill(&mut self.wolf_senses, n, false);
        refill(&mut self.target_seen_at, m, None);
        refill(&mut self.target_last_sighting, m, None);
        refill(&mut self.target_captured, m, false);
        refill(&mut self.target_capture_step, m, None);
        refill(&mut self.target_cornered_step, m, None);
        refill(&mut self.target_ended_cornered, m, false);
        refill(&mut self.wolf_memory, n, WolfMemory::new(wolf_law));
        refill(&mut self.target_memory, m, TargetMemory::default());
        refill(&mut self.interaction, (n + m) * (n + m), 0);
        refill(&mut self.wolf_mode, n, LawMode::None);
        refill(&mut self.target_mode, m, LawMode::None);
        refill(&mut self.collisions, n + m, 0);
        self.outcome = Outcome::Running;
        self.fault = None;
        self.rng_motion = stream(seed, episode, STREAM_MOTION);
        self.rng_policy = stream(seed, episode, STREAM_POLICY);
        self.rng_sensing = stream(seed, episode, STREAM_SENSING);
        refill(&mut self.wolf_cmds, n, Command::default());
        refill(&mut self.target_cmds, m, Command::default());
        self.wolf_bodies.clear();
        self.target_bodies.clear();
        refill(&mut self.scratch_row, n + m, 0);
        self.near.clear();
        self.assign_targets();
        self.note_sightings();
    }

    /// The generator of agent `agent`'s observation noise at this step (wolves 0..N, then
    /// targets): the world's sensing stream at a position given by (t, agent) alone, so that
    /// the noise of an observation depends on the world's seed, episode, step and agent — not
    /// on how often, in which order or on which thread the agents are observed. Each (t, agent)
    /// owns 2^20 words of the stream, far more than a 1,024-ray lidar draws.
    pub(crate) fn sensing_rng(&self, agent: usize) -> ChaCha8Rng {
        let agents = (self.wolves.len() + self.targets.len()) as u128;
        let mut r = self.rng_sensing.clone();
        r.set_word_pos((u128::from(self.t) * agents + agent as u128) << 20);
        r
    }

    pub fn n_wolves(&self) -> usize {
        self.wolves.len()
    }

    pub fn n_targets(&self) -> usize {
        self.targets.len()
    }

    pub fn is_done(&self) -> bool {
        self.outcome != Outcome::Running || self.fault.is_some()
    }

    /// Why the world stopped with an error: a law (or given commands) produced a non-finite
    /// number. Episode runners and the batch turn it into [`crate::Error::NonFinite`].
    pub fn fault(&self) -> Option<&str> {
        self.fault.as_deref()
    }

    /// [`World::fault`] as an error, for `?`.
    pub fn check_fault(&self) -> crate::error::Result<()> {
        match &self.fault {
            Some(f) => Err(crate::error::Error::NonFinite(f.clone())),
            None => Ok(()),
        }
    }

    /// Asks the CPU to start loading the memory this world's next step reads (the agents, the
    /// obstacles and their vertex lists, the scratch lists), without waiting for it: the batch
    /// calls it for the next world while it steps this one, from a few thousand worlds per
    /// thread on (`batch::PREFETCH_FROM`), where a world's ≈ 50 small lists, which the hardware
    /// cannot predict, come from memory rather than from the caches. Changes no result.
    #[inline]
    pub fn prefetch(&self) {
        use crate::math::prefetch_slice as pf;
        pf(&self.wolves);
        pf(&self.targets);
        pf(&self.obstacles);
        for o in &self.obstacles {
            pf(&o.local);
            pf(&o.vertices);
        }
        pf(&self.wolf_memory);
        pf(&self.target_memory);
        pf(&self.wolf_target);
        pf(&self.interaction);
        pf(&self.collisions);
        pf(&self.wolf_cmds);
        pf(&self.target_cmds);
        self.wolf_bodies.prefetch();
        self.target_bodies.prefetch();
        self.near.prefetch();
    }

    /// `θ.sin_cos()` of agent `k` (wolves 0..N, then targets), bit for bit: from the body frame
    /// the last step left when it is that of the agent's current pose, else computed.
    #[inline]
    pub fn heading_sin_cos(&self, k: usize) -> (f64, f64) {
        let n = self.n_wolves();
        let (a, bodies, i) = if k < n { (&self.wolves[k], &self.wolf_bodies, k) } else { (&self.targets[k - n], &self.target_bodies, k - n) };
        match bodies.fwd_at(i, a) {
            Some(f) => (f.y, f.x),
            None => sin_cos(a.theta),
        }
    }

    /// Places the vertices of every polygon a lazy world left behind ([`Obstacle::vertices`]
    /// is then current for all of them); a no-op for any other world.
    pub fn settle_obstacles(&mut self) {
        self.obstacles.iter_mut().for_each(Obstacle::ensure_placed);
    }

    /// Places the polygons the lidar can reach from the observed agents (wolves and/or
    /// targets): those it does not cull by its own squared-distance test, `observe.rs`'s
    /// `lidar_reach`, which this shares so that both decide alike.
    pub(crate) fn place_for_lidar(&mut self, wolves: bool, targets: bool, range: f64) {
        let observed = |side: &[AgentState], on: bool| if on { side.len() } else { 0 };
        let (n, m) = (observed(&self.wolves, wolves), observed(&self.targets, targets));
        for o in &mut self.obstacles {
            if !o.placed && self.wolves[..n].iter().chain(&self.targets[..m]).any(|a| crate::observe::lidar_reaches(o, a.pos, range)) {
                o.ensure_placed();
            }
        }
    }

    /// The body triangle of an agent state.
    pub fn body(&self, a: &AgentState) -> [Vec2; 3] {
        let b = &self.params.agents.body;
        body_triangle(a.pos, a.theta, b.base, b.height)
    }

    /// Step at which the last target was captured, if the episode ended in a capture.
    pub fn capture_step(&self) -> Option<u32> {
        (self.outcome == Outcome::Captured).then(|| self.target_capture_step.iter().flatten().copied().max()).flatten()
    }

    /// The first step at which any target was cornered (docs/world-and-laws.md §1.7), if one ever
    /// was.
    pub fn cornered_step(&self) -> Option<u32> {
        self.target_cornered_step.iter().flatten().copied().min()
    }
}

/// The body triangles of one side's agents at the poses they were computed for, with each
/// agent's travel direction `unit(θ)`: a step reuses the last step's bodies and directions
/// instead of taking a `sin_cos` of every old heading again (the values are the same, bit for
/// bit, as computing them anew).
#[derive(Debug, Clone, Default)]
pub(crate) struct Bodies {
    tris: Vec<[Vec2; 3]>,
    /// (pose point, heading, unit(heading)) of each body.
    poses: Vec<(Vec2, f64, Vec2)>,
}

impl Bodies {
    /// Makes the bodies those of `agents`' current poses: kept where the poses are unchanged
    /// (the last step left them), rebuilt otherwise (spawns, layouts, tests moving agents).
    pub(crate) fn sync(&mut self, agents: &[AgentState], base: f64, height: f64) {
        let current = self.tris.len() == agents.len() && agents.iter().enumerate().all(|(i, a)| self.fwd_at(i, a).is_some());
        if !current {
            self.tris.clear();
            self.poses.clear();
            for a in agents {
                let frame = BodyFrame::new(a.theta, base, height);
                self.tris.push(frame.at(a.pos));
                self.poses.push((a.pos, a.theta, frame.fwd));
            }
        }
    }

    /// No bodies (a new episode's, until its first sync), keeping the lists.
    fn clear(&mut self) {
        self.tris.clear();
        self.poses.clear();
    }

    /// `unit(θ)` of agent `i` if the body kept for it is that of `a`'s pose.
    #[inline]
    fn fwd_at(&self, i: usize, a: &AgentState) -> Option<Vec2> {
        let (pos, theta, fwd) = *self.poses.get(i)?;
        (pos == a.pos && theta == a.theta).then_some(fwd)
    }

    /// Agent `i`'s travel direction `unit(θ)` at the synced pose.
    #[inline]
    pub(crate) fn dir(&self, i: usize) -> Vec2 {
        self.poses[i].2
    }

    #[inline]
    pub(crate) fn tri(&self, i: usize) -> &[Vec2; 3] {
        &self.tris[i]
    }

    pub(crate) fn tris(&self) -> &[[Vec2; 3]] {
        &self.tris
    }

    /// Agent `i` moved to `(pos, θ)`, whose body frame is `frame`.
    #[inline]
    pub(crate) fn set(&mut self, i: usize, pos: Vec2, theta: f64, frame: &BodyFrame) {
        self.tris[i] = frame.at(pos);
        self.poses[i] = (pos, theta, frame.fwd);
    }

    fn prefetch(&self) {
        crate::math::prefetch_slice(&self.tris);
        crate::math::prefetch_slice(&self.poses);
    }
}

impl Params {
    /// The same parameters with the agent counts replaced (e.g. by a layout's). An explicit
    /// `capture.count` larger than the new wolf count is an error at validation.
    pub fn with_counts(&self, wolves: usize, targets: usize) -> Params {
        let mut p = self.clone();
        p.world.wolves = wolves;
        p.world.targets = targets;
        p
    }
}

/// `list` as `vec![value; len]`, in its own allocation where that is large enough.
fn refill<T: Clone>(list: &mut Vec<T>, len: usize, value: T) {
    list.clear();
    list.resize(len, value);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `respawn` leaves a world in the very state of a fresh one, whatever it held before
    /// (longer or shorter lists, other polygons, a lazy world partly placed): the same fields,
    /// the same random streams, and the same trajectory afterwards.
    #[test]
    fn respawning_a_world_is_becoming_a_fresh_one() {
        let mut params = Params::default();
        // Varied list lengths: fewer agents and obstacles in one episode than the next.
        let small = {
            let mut p = params.clone();
            p.world.wolves = 3;
            (p.obstacles.static_polygons, p.obstacles.moving_polygons) = (1, 1);
            p.obstacles.polygon_vertices = [5, 6];
            Arc::new(p)
        };
        params.world.wolves = 6;
        params.env.last_sighting = true; // the first sightings are part of the first state
        let large = Arc::new(params);
        for (k, (before, after)) in [(small.clone(), large.clone()), (large.clone(), small.clone()), (large.clone(), large)].into_iter().enumerate() {
            for seed in 0..6u64 {
                let mut old = World::new_episode(before.clone(), 100 + seed, 0).unwrap();
                old.lazy_obstacles = seed % 2 == 0;
                old.track_laws = seed % 3 == 0;
                for _ in 0..(7 * seed as usize) {
                    old.step();
                }
                let mut want = World::new_episode(after.clone(), seed, 3).unwrap();
                (want.lazy_obstacles, want.track_laws) = (old.lazy_obstacles, old.track_laws);
                old.respawn(after.clone(), seed, 3).unwrap();
                assert_eq!(format!("{old:?}"), format!("{want:?}"), "case {k}, seed {seed}: state");
                assert!(old.rng_motion == want.rng_motion && old.rng_policy == want.rng_policy, "case {k}, seed {seed}: streams");
                for t in 0..40 {
                    assert_eq!(old.step(), want.step());
                    assert_eq!(format!("{old:?}"), format!("{want:?}"), "case {k}, seed {seed}: after step {t}");
                }
            }
        }
    }
}
