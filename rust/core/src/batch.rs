//! The native batch: E worlds stepped together on the caller's thread and a crew of its own
//! ([`crate::crew`]) — the one engine behind the
//! PettingZoo, Gymnasium and SB3 adapters.
//!
//! - World i is seeded `seed + i`; its k-th episode uses the random streams of episode k of that
//!   seed ([`World::new_episode`]), so every world's sequence of episodes depends on its own
//!   seed alone: results are bit-identical for any thread count and any way the batch is split.
//! - Learners (one side, both or none) act through `[-1, 1]²` actions (params `env.action_mode`);
//!   the other side is driven by its scripted law inside the core.
//! - With `autoreset`, a world that finishes is reset in the same step (SB3's convention): the
//!   step returns the new episode's first observation, the finished episode's last observation
//!   in `final_obs_*`, and the finished episode's infos.
//! - Every step returns fresh output vectors (the binding hands them to numpy without copying).

use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use crate::config::{ActionMode, Params};
use crate::crew::Crew;
use crate::error::{Error, Result};
use crate::math::{atan2, unit, wrap, Vec2};
use crate::observe::{target_dim, wolf_dim, Observer};
use crate::policies::saturator::saturate;
use crate::policies::{Command, WolfMemory};
use crate::reward::{nearest_target_distance, nearest_wolf_distance, RewardState};
use crate::world::{Layout, Outcome, World};

/// Which side learns; the other is scripted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Learners {
    Wolves,
    Targets,
    All,
    None,
}

impl Learners {
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "wolves" => Ok(Self::Wolves),
            "targets" => Ok(Self::Targets),
            "all" => Ok(Self::All),
            "none" => Ok(Self::None),
            _ => Err(Error::Invalid(format!("learners must be one of 'wolves', 'targets', 'all', 'none', got {s:?}"))),
        }
    }

    pub fn wolves(self) -> bool {
        matches!(self, Self::Wolves | Self::All)
    }

    pub fn targets(self) -> bool {
        matches!(self, Self::Targets | Self::All)
    }
}

/// The outputs of one reset or step, for the whole batch (row-major, world first).
#[derive(Debug, Clone, Default)]
pub struct StepOutput {
    /// [E, N, Dw] when wolves learn, else empty.
    pub obs_wolves: Vec<f32>,
    /// [E, M, Dt] when targets learn, else empty.
    pub obs_targets: Vec<f32>,
    /// [E, N] / [E, M], both sides always (the scripted side's too, for evaluation).
    pub rewards_wolves: Vec<f32>,
    pub rewards_targets: Vec<f32>,
    /// `[E]`: the episode ended by capture (or cornering, where it counts) or collision / by
    /// the step limit.
    pub terminated: Vec<bool>,
    pub truncated: Vec<bool>,
    /// Last observation of an episode that ended this step (autoreset only; zeros elsewhere).
    pub final_obs_wolves: Vec<f32>,
    pub final_obs_targets: Vec<f32>,
    /// Infos of the episode this step belongs to (the finished one on an autoreset).
    /// `[E]`: `Outcome` as 0 running, 1 captured, 2 collision, 3 timeout, 4 cornered.
    pub outcome: Vec<u8>,
    /// `[E]`: steps taken in the episode.
    pub steps: Vec<u32>,
    /// [E, M]: step at which each target was captured (or, with `capture.cornered`,
    /// cornered), −1 if not.
    pub capture_step: Vec<i64>,
    /// [E, M]: the first step at which each target was cornered (SPEC §6), −1 if never.
    pub cornered_step: Vec<i64>,
    /// [E, N+M]: accumulated energy (J), collision steps, and distance to the nearest
    /// uncaptured target (wolves; -1 when none is left) / nearest wolf (targets).
    pub energy: Vec<f64>,
    pub collisions: Vec<u32>,
    pub distance: Vec<f64>,
}

pub fn outcome_code(o: Outcome) -> u8 {
    match o {
        Outcome::Running => 0,
        Outcome::Captured => 1,
        Outcome::Collision => 2,
        Outcome::Timeout => 3,
        Outcome::Cornered => 4,
    }
}

/// Batches of fewer worlds step on the caller's thread whatever the thread count
/// (`BatchEnv::steps_inline`).
pub const INLINE_BELOW: usize = 8;

/// Most worlds in one claim of a shared step ([`BatchEnv::chunk`]): at large batches a claim
/// (an atomic update, ≈ 20 ns unless another thread is stealing from the same run) every 16
/// worlds is free, and a thread that runs out steals at most ≈ 50 µs of work at a time.
const MAX_CHUNK: usize = 16;
/// Below this many items a job does not wake the crew's parked members ([`Crew::run_with`]):
/// 32 worlds are ≈ 150 µs of one thread's stepping, several times a member's wake-up on a VM
/// (tens of µs), so a member woken for them still finds worlds to step; fewer are done, or
/// nearly, by the time it comes.
const WAKE_FROM: usize = 32;

/// Worlds per thread from which a step asks the CPU to load each next world's memory while it
/// steps the current one ([`Slot::prefetch`]). Below, a thread's worlds are still in the
/// caches the last step left them in, and the hints only cost: without them, E = 1,024 ran
/// 2–5 % faster on one thread and 4–9 % on two, E = 64 4 %; above, the worlds come from memory
/// and the hints pay: E = 4,096 on one thread +17 %, E = 8,192 +8 % on one thread and +2–3 % on
/// two; at 2,048 per thread it was even (steady-state runs after 1.5 M env-steps of warm-up,
/// interleaved, BENCHMARKS.md, "Optimisations").
const PREFETCH_FROM: usize = 2048;

/// Most worlds one batch may hold.
pub const MAX_ENVS: usize = 1 << 17;

/// Most agents (worlds × (N + M)) one batch may hold: its outputs are sized by them.
pub const MAX_BATCH_AGENTS: usize = 1 << 24;

struct Slot {
    world: World,
    seed: u64,
    episode: u64,
    rewards: RewardState,
    observer: Observer,
    wolf_cmds: Vec<Command>,
    target_cmds: Vec<Command>,
}

impl Slot {
    /// Starts episode `episode` of this slot's world in place: the slot `env_slot` makes for
    /// it (the observer's scratch aside, which holds nothing from one use to the next), in this
    /// slot's own allocations ([`World::adopt`]).
    fn respawn(&mut self, params: &Arc<Params>, episode: u64, track: bool) -> Result<()> {
        let Slot { world, seed: _, episode, rewards: _, observer: _, wolf_cmds, target_cmds } = env_slot(params, self.seed, episode, None)?;
        self.world.adopt(world);
        self.world.track_laws = track;
        self.episode = episode;
        // RewardState::new is reset on a default state: the same lists, kept.
        self.rewards.reset(&self.world);
        self.wolf_cmds.clone_from(&wolf_cmds);
        self.target_cmds.clone_from(&target_cmds);
        Ok(())
    }

    /// [`World::prefetch`] and the slot's own lists.
    #[inline]
    fn prefetch(&self) {
        self.world.prefetch();
        self.observer.prefetch();
        self.rewards.prefetch();
        crate::math::prefetch_slice(&self.wolf_cmds);
        crate::math::prefetch_slice(&self.target_cmds);
    }
}

/// One world's share of a [`StepOutput`].
struct SlotOut<'a> {
    obs_w: &'a mut [f32],
    obs_t: &'a mut [f32],
    rew_w: &'a mut [f32],
    rew_t: &'a mut [f32],
    term: &'a mut bool,
    trunc: &'a mut bool,
    fin_w: &'a mut [f32],
    fin_t: &'a mut [f32],
    outcome: &'a mut u8,
    steps: &'a mut u32,
    capture_step: &'a mut [i64],
    cornered_step: &'a mut [i64],
    energy: &'a mut [f64],
    collisions: &'a mut [u32],
    distance: &'a mut [f64],
}

/// The lengths of a step's observation arrays, the wolves' and the targets', while their
/// worlds' tasks fill them ([`BatchEnv::alloc`]).
#[derive(Debug, Clone, Copy)]
struct ObsLens([usize; 2]);

impl ObsLens {
    /// Gives the two arrays of `o` their lengths.
    ///
    /// # Safety
    /// The first `len` elements of each array's spare capacity must have been written.
    unsafe fn set(self, o: &mut StepOutput) {
        for (v, len) in [&mut o.obs_wolves, &mut o.obs_targets].into_iter().zip(self.0) {
            debug_assert!(v.is_empty() && v.capacity() >= len);
            // SAFETY: capacity ≥ len (`alloc`), and the caller vouches for the contents.
            unsafe { v.set_len(len) };
        }
    }
}

pub struct BatchEnv {
    params: Arc<Params>,
    learners: Learners,
    autoreset: bool,
    slots: Vec<Slot>,
    /// The threads besides the calling thread (`threads − 1` of them, all cores' worth when
    /// `threads` is None); `None` with one thread, which steps on the caller's thread alone.
    crew: Option<Crew>,
    track_laws: bool,
}

impl BatchEnv {
    /// `num_envs` worlds seeded `seed + i`. `threads`: None = all cores, or `RAYON_NUM_THREADS`
    /// ([`crate::episode::default_threads`]).
    pub fn new(params: Params, num_envs: usize, learners: Learners, seed: u64, autoreset: bool, threads: Option<usize>) -> Result<Self> {
        Self::new_until(params, num_envs, learners, seed, autoreset, threads, &AtomicBool::new(false))
    }

    /// [`BatchEnv::new`] that gives up with [`Error::Interrupted`] once `stop` is set (checked
    /// before each world is spawned; building the largest batch takes seconds).
    pub fn new_until(params: Params, num_envs: usize, learners: Learners, seed: u64, autoreset: bool, threads: Option<usize>, stop: &AtomicBool) -> Result<Self> {
        params.validate()?;
        if num_envs == 0 {
            return Err(Error::Invalid("num_envs must be >= 1".into()));
        }
        if num_envs > MAX_ENVS {
            return Err(Error::Invalid(format!("num_envs must be <= {MAX_ENVS} (a world of the documented scenario holds about 8 KB, and spawning one takes about 0.1 ms), got {num_envs}")));
        }
        crate::episode::check_threads(threads)?;
        let agents = num_envs * (params.world.wolves + params.world.targets);
        if agents > MAX_BATCH_AGENTS {
            return Err(Error::Invalid(format!(
                "num_envs: {num_envs} worlds of {} agents are {agents} agents; a batch holds at most {MAX_BATCH_AGENTS} (each step writes an observation per agent)",
                params.world.wolves + params.world.targets
            )));
        }
        // The calling thread steps worlds too ([`share`]): t threads are the caller and a
        // crew of t − 1.
        let t = threads.unwrap_or_else(crate::episode::default_threads).max(1);
        let crew = match t {
            1 => None,
            t => Some(Crew::new(t - 1).map_err(|e| Error::Invalid(format!("cannot start {t} threads: {e}")))?),
        };
        let params = Arc::new(params);
        let mut env = Self { params, learners, autoreset, slots: Vec::new(), crew, track_laws: false };
        let participants = env.participants();
        let g = |i: usize| if stop.load(Ordering::Relaxed) { Err(Error::Interrupted) } else { env_slot(&env.params, seed.wrapping_add(i as u64), 0, None) };
        let worlds: Vec<Result<Slot>> = share(env.crew.as_mut(), participants, (0..num_envs).collect(), MAX_CHUNK, g);
        env.slots = worlds.into_iter().collect::<Result<_>>()?;
        Ok(env)
    }

    /// Whether a step runs on the caller's thread: with one thread, and for batches too small
    /// to share (waking the crew and handing work back costs ≈ 10–20 µs, a world's step with
    /// observations ≈ 5–10 µs: below [`INLINE_BELOW`] worlds more threads only make it slower).
    fn steps_inline(&self) -> bool {
        self.participants() == 1 || self.slots.len() < INLINE_BELOW
    }

    /// How a step shares out its worlds ([`par_for`]): participants and chunk size, one
    /// participant with every world in one chunk when it steps inline.
    fn schedule(&self) -> (usize, usize) {
        if self.steps_inline() {
            (1, self.slots.len())
        } else {
            (self.participants(), self.chunk())
        }
    }

    /// Threads that step worlds: the caller and its crew ([`share`]).
    fn participants(&self) -> usize {
        1 + self.crew.as_ref().map_or(0, Crew::members)
    }

    /// Worlds per claim of [`par_for`]: 32 claims per thread and at most [`MAX_CHUNK`] worlds
    /// each, so one world at a time below 64 worlds per thread. The threads then finish within
    /// about a world's step of each other, and a thread that runs out moves as few worlds off
    /// the other's core as it can (a world stolen is a world whose ≈ 9 KB of state crosses
    /// between the cores' caches, there and back the next step). Against 8 worlds per claim
    /// at E = 64 on 2 threads: 533 → 600 k env-steps/s with the crew (`examples/batch_threads`,
    /// medians of 7 interleaved runs).
    fn chunk(&self) -> usize {
        (self.slots.len() / (32 * self.participants())).clamp(1, MAX_CHUNK)
    }

    pub fn params(&self) -> &Params {
        &self.params
    }
    pub fn num_envs(&self) -> usize {
        self.slots.len()
    }
    pub fn learners(&self) -> Learners {
        self.learners
    }
    pub fn n_wolves(&self) -> usize {
        self.params.world.wolves
    }
    pub fn n_targets(&self) -> usize {
        self.params.world.targets
    }
    pub fn wolf_obs_dim(&self) -> usize {
        wolf_dim(&self.params)
    }
    pub fn target_obs_dim(&self) -> usize {
        target_dim(&self.params)
    }
    /// World `e`, with every polygon's vertices at its current pose (the batch places only
    /// the polygons its agents can reach or see while stepping; this places the rest).
    pub fn world(&mut self, e: usize) -> Option<&World> {
        let s = self.slots.get_mut(e)?;
        s.world.settle_obstacles();
        Some(&s.world)
    }
    /// Entries in one world's global state row ([`crate::state`]).
    pub fn state_dim(&self) -> usize {
        crate::state::state_dim(&self.params)
    }

    /// Every world's global state, [E, state_dim] row-major ([`crate::state`] has the layout).
    pub fn state(&self) -> Result<Vec<f32>> {
        let d = self.state_dim();
        let mut out = vec![0.0f32; self.slots.len() * d];
        for (s, row) in self.slots.iter().zip(out.chunks_mut(d)) {
            crate::state::write_state(&s.world, &self.params, row)?;
        }
        Ok(out)
    }

    /// Seed of world `e` and the index of its current episode under that seed.
    pub fn world_seed(&self, e: usize) -> Option<(u64, u64)> {
        self.slots.get(e).map(|s| (s.seed, s.episode))
    }

    /// Resets every world: with `seed`, world i is re-seeded `seed + i` (episode 0); without,
    /// each world starts its next episode.
    pub fn reset(&mut self, seed: Option<u64>) -> Result<StepOutput> {
        self.reset_until(seed, &AtomicBool::new(false))
    }

    /// [`BatchEnv::reset`] that gives up with [`Error::Interrupted`] once `stop` is set; the
    /// batch is then exactly as before the call (the fresh worlds replace the old ones only
    /// when all of them are built).
    pub fn reset_until(&mut self, seed: Option<u64>, stop: &AtomicBool) -> Result<StepOutput> {
        let params = self.params.clone();
        let track = self.track_laws;
        let g = |(i, s): (usize, &Slot)| {
            if stop.load(Ordering::Relaxed) {
                return Err(Error::Interrupted);
            }
            let (sd, ep) = match seed {
                Some(b) => (b.wrapping_add(i as u64), 0),
                None => (s.seed, s.episode + 1),
            };
            env_slot(&params, sd, ep, None)
        };
        let participants = self.participants();
        let fresh: Vec<Result<Slot>> = share(self.crew.as_mut(), participants, self.slots.iter().enumerate().collect(), MAX_CHUNK, g);
        self.slots = fresh.into_iter().collect::<Result<_>>()?;
        for s in &mut self.slots {
            s.world.track_laws = track;
        }
        Ok(self.observe_all())
    }

    /// Resets world `e` alone, optionally from an explicit layout (whose agent counts must
    /// equal this batch's). `seed` as in [`BatchEnv::reset`] but for this world: `seed` itself.
    pub fn reset_world(&mut self, e: usize, seed: Option<u64>, layout: Option<&Layout>) -> Result<StepOutput> {
        let (cur_seed, cur_ep) = self.world_seed(e).ok_or_else(|| Error::Invalid(format!("world index {e} out of range (num_envs = {})", self.num_envs())))?;
        if let Some(l) = layout {
            let (n, m) = (self.n_wolves(), self.n_targets());
            if l.wolves.len() != n || l.targets.len() != m {
                return Err(Error::Layout(format!(
                    "layout has {} wolves and {} targets; this environment was built for {n} and {m} (its spaces depend on them)",
                    l.wolves.len(),
                    l.targets.len()
                )));
            }
        }
        let (sd, ep) = match seed {
            Some(s) => (s, 0),
            None => (cur_seed, cur_ep + 1),
        };
        let mut slot = env_slot(&self.params, sd, ep, layout)?;
        slot.world.track_laws = self.track_laws;
        self.slots[e] = slot;
        Ok(self.observe_all())
    }

    /// Observations of the current states (as a reset returns them): obs and infos filled,
    /// rewards zero, no episode end.
    pub fn observe_all(&mut self) -> StepOutput {
        let (mut out, lens) = self.alloc();
        let e = self.slots.len();
        let (n, m) = (self.n_wolves(), self.n_targets());
        let (participants, chunk) = self.schedule();
        let outs = OutPieces::new(&mut out, lens, e, n, m);
        let slots = Disjoint::new(&mut self.slots);
        par_for(self.crew.as_mut(), participants, e, chunk, |_| {}, |i| {
            // SAFETY: par_for hands out each world index once.
            let (s, mut o) = unsafe { (slots.item(i), outs.world(i)) };
            write_obs(s, o.obs_w, o.obs_t);
            write_infos(&s.world, &mut o);
        });
        // SAFETY: every world's task zeroed its pieces of the observation arrays
        // (`OutPieces::world`), and the pieces tile them.
        unsafe { lens.set(&mut out) };
        out
    }

    /// A step's outputs, the two observation arrays allocated but still empty: their lengths
    /// come back separately, and each world's task zeroes and fills its own pieces
    /// ([`OutPieces::world`]). Zeroing them here, on the caller's thread, cost ≈ 5 % of a
    /// two-thread step: the caller wrote every line before the other thread wrote it again.
    /// The final observations stay `calloc`'d: a world writes its piece only when its episode
    /// ends. (The allocators reuse the last step's blocks and clear them with a `memset`, 3 % of
    /// a one-thread step at E = 8,192; zeroing them in the worlds' tasks instead, as for the
    /// observations, measured no faster on one thread or two: BENCHMARKS.md, "Optimisations".)
    fn alloc(&self) -> (StepOutput, ObsLens) {
        let e = self.slots.len();
        let (n, m) = (self.n_wolves(), self.n_targets());
        let dw = if self.learners.wolves() { n * self.wolf_obs_dim() } else { 0 };
        let dt = if self.learners.targets() { m * self.target_obs_dim() } else { 0 };
        // Rewards of both sides, always: evaluation reports the scripted side's return too.
        let (rw, rt) = (n, m);
        let lens = ObsLens([e * dw, e * dt]);
        let out = StepOutput {
            obs_wolves: Vec::with_capacity(lens.0[0]),
            obs_targets: Vec::with_capacity(lens.0[1]),
            rewards_wolves: vec![0.0; e * rw],
            rewards_targets: vec![0.0; e * rt],
            terminated: vec![false; e],
            truncated: vec![false; e],
            final_obs_wolves: if self.autoreset { vec![0.0; e * dw] } else { Vec::new() },
            final_obs_targets: if self.autoreset { vec![0.0; e * dt] } else { Vec::new() },
            outcome: vec![0; e],
            steps: vec![0; e],
            capture_step: vec![-1; e * m],
            cornered_step: vec![-1; e * m],
            energy: vec![0.0; e * (n + m)],
            collisions: vec![0; e * (n + m)],
            distance: vec![0.0; e * (n + m)],
        };
        (out, lens)
    }

    /// Checks an action array of one side: its length and that every entry is finite. The
    /// error names the world and the agent.
    fn check_actions(&self, actions: &[f32], side: &str, per_world: usize) -> Result<()> {
        let e = self.slots.len();
        if actions.len() != e * per_world * 2 {
            return Err(Error::Invalid(format!("{side} actions: expected {} values ({e} worlds x {per_world} agents x 2), got {}", e * per_world * 2, actions.len())));
        }
        if let Some(k) = actions.iter().position(|a| !a.is_finite()) {
            let (w, a) = (k / 2 / per_world, k / 2 % per_world);
            let name = if side == "wolf" { "wolf" } else { "target" };
            return Err(Error::Invalid(format!("action of {name}_{a} in world {w} is not finite: {}", actions[k])));
        }
        Ok(())
    }

    /// One step of every world. `wolf_actions` ([E, N, 2]) / `target_actions` ([E, M, 2]) are
    /// required for (and only for) the learning sides; values are clipped to [-1, 1]. Nothing
    /// moves when the actions are invalid. Without autoreset, a finished world stays as it is.
    pub fn step(&mut self, wolf_actions: &[f32], target_actions: &[f32]) -> Result<StepOutput> {
        let (n, m) = (self.n_wolves(), self.n_targets());
        for (learns, acts, side, per) in [(self.learners.wolves(), wolf_actions, "wolf", n), (self.learners.targets(), target_actions, "target", m)] {
            if learns {
                self.check_actions(acts, side, per)?;
            } else if !acts.is_empty() {
                return Err(Error::Invalid(format!("{side}s are scripted here (learners = {:?}); pass no {side} actions", self.learners)));
            }
        }
        let (mut out, lens) = self.alloc();
        let e = self.slots.len();
        let learners = self.learners;
        let autoreset = self.autoreset;
        let params = self.params.clone();
        let track = self.track_laws;
        let (participants, chunk) = self.schedule();
        let outs = OutPieces::new(&mut out, lens, e, n, m);
        let slots = Disjoint::new(&mut self.slots);
        // The error of the lowest-numbered world that failed, whichever thread saw it first.
        let failed: Mutex<Option<(usize, Error)>> = Mutex::new(None);
        let f = |i: usize| {
            // SAFETY: par_for hands out each world index once.
            let (s, o) = unsafe { (slots.item(i), outs.world(i)) };
            let wa = if learners.wolves() { &wolf_actions[i * n * 2..(i + 1) * n * 2] } else { &[][..] };
            let ta = if learners.targets() { &target_actions[i * m * 2..(i + 1) * m * 2] } else { &[][..] };
            let (seed, episode) = (s.seed, s.episode);
            if let Err(err) = step_slot(s, o, wa, ta, learners, autoreset, &params, track) {
                let err = match err {
                    Error::NonFinite(m) => Error::NonFinite(format!("world {i} (seed {seed}, episode {episode}): {m}")),
                    other => other,
                };
                let mut first = failed.lock().unwrap_or_else(|p| p.into_inner());
                if first.as_ref().is_none_or(|(k, _)| i < *k) {
                    *first = Some((i, err));
                }
            }
        };
        // SAFETY (the hint): par_for hints only an index the calling thread has claimed and
        // steps next, which no other thread touches.
        let prefetch = e / participants >= PREFETCH_FROM;
        let ahead = |i: usize| {
            if prefetch {
                unsafe { slots.item(i) }.prefetch()
            }
        };
        par_for(self.crew.as_mut(), participants, e, chunk, ahead, f);
        if let Some((_, err)) = failed.into_inner().unwrap_or_else(|p| p.into_inner()) {
            return Err(err);
        }
        // SAFETY: every world's task zeroed its pieces of the observation arrays before
        // anything else (`OutPieces::world`), and the pieces tile them.
        unsafe { lens.set(&mut out) };
        Ok(out)
    }

    /// Changes who drives each side from the next step on, keeping every world as it is (for
    /// leagues that swap opponents between rollouts): `learners` (the sides given actions)
    /// and `params`, which may differ from this batch's only in `policies.*` (the scripted
    /// laws) and `env.*action_mode` (how each side's actions are read). A side that becomes
    /// scripted, or changes law, starts its law's memory afresh at the current state (a law
    /// tracked since the episode began, see [`BatchEnv::expert_actions`], keeps its memory
    /// when the law is unchanged). Nothing changes when the params differ elsewhere.
    pub fn set_drivers(&mut self, learners: Learners, params: Params) -> Result<()> {
        params.validate()?;
        let mut same_elsewhere = params.resolved();
        same_elsewhere.policies = self.params.policies.clone();
        same_elsewhere.env.action_mode = self.params.env.action_mode;
        same_elsewhere.env.wolf_action_mode = self.params.env.wolf_action_mode;
        same_elsewhere.env.target_action_mode = self.params.env.target_action_mode;
        if same_elsewhere != self.params.resolved() {
            return Err(Error::Invalid(
                "set_drivers: the params may differ only in policies.* and env.*action_mode (the world itself cannot change mid-episode; build a new batch)".into(),
            ));
        }
        // A side's law starts afresh when it takes over from given actions without having
        // followed them (untracked), or when its law changes.
        let fresh = |was_driven: bool, now_driven: bool, law_changed: bool| !now_driven && ((was_driven && !self.track_laws) || law_changed);
        let fresh_wolves = fresh(self.learners.wolves(), learners.wolves(), params.policies.wolves != self.params.policies.wolves);
        let fresh_targets = fresh(self.learners.targets(), learners.targets(), params.policies.targets != self.params.policies.targets);
        let params = Arc::new(params);
        for s in &mut self.slots {
            s.world.params = params.clone();
            if fresh_wolves {
                s.world.wolf_memory.iter_mut().for_each(|m| *m = WolfMemory::new(params.policies.wolves));
            }
            if fresh_targets {
                s.world.target_memory.iter_mut().for_each(|m| *m = Default::default());
            }
        }
        self.params = params;
        self.learners = learners;
        Ok(())
    }

    /// What the scripted law of each learning side would do now, as actions in this batch's
    /// action space: ([E, N, 2] or empty, [E, M, 2] or empty). The first call switches on
    /// law tracking: from then on the laws' memories follow every episode (see
    /// [`World::track_laws`]).
    pub fn expert_actions(&mut self) -> (Vec<f32>, Vec<f32>) {
        if !self.track_laws {
            self.track_laws = true;
            for s in &mut self.slots {
                s.world.track_laws = true;
            }
        }
        let (n, m) = (self.n_wolves(), self.n_targets());
        let learners = self.learners;
        let (wolf_mode, target_mode) = (self.params.env.wolf_mode(), self.params.env.target_mode());
        let f = |s: &Slot| {
            let w = &s.world;
            let (dw, dt) = w.expert_desired();
            let p = &w.params;
            let mut aw = Vec::new();
            if learners.wolves() {
                for (a, &(v, th)) in w.wolves.iter().zip(&dw) {
                    aw.extend(encode(wolf_mode, a.theta, v, th, p.agents.wolf.v_max, p.agents.wolf.omega_max, p.world.ts));
                }
            }
            let mut at = Vec::new();
            if learners.targets() {
                let side = &p.agents.target;
                for (a, &(v, th)) in w.targets.iter().zip(&dt) {
                    at.extend(encode(target_mode, a.theta, v, th, side.v_max, side.omega_max, p.world.ts));
                }
            }
            (aw, at)
        };
        let (participants, chunk) = (self.participants(), self.chunk());
        let per: Vec<(Vec<f32>, Vec<f32>)> = share(self.crew.as_mut(), participants, self.slots.iter().collect(), chunk, f);
        let mut aw = Vec::with_capacity(self.slots.len() * n * 2);
        let mut at = Vec::with_capacity(self.slots.len() * m * 2);
        for (w, t) in per {
            aw.extend(w);
            at.extend(t);
        }
        (aw, at)
    }
}

/// Maps `f` over `items` on `participants` threads (see [`par_for`]); the results come back
/// in item order, so nothing depends on which thread ran what.
fn share<T: Send, R: Send>(crew: Option<&mut Crew>, participants: usize, items: Vec<T>, chunk: usize, f: impl Fn(T) -> R + Sync) -> Vec<R> {
    let n = items.len();
    let mut items: Vec<Option<T>> = items.into_iter().map(Some).collect();
    let mut results: Vec<Option<R>> = std::iter::repeat_with(|| None).take(n).collect();
    let (cells, out) = (Disjoint::new(&mut items), Disjoint::new(&mut results));
    par_for(crew, participants, n, chunk, |_| {}, |i| {
        // SAFETY: par_for hands out each index once.
        let (item, result) = unsafe { (cells.item(i), out.item(i)) };
        *result = item.take().map(&f);
    });
    results.into_iter().map(|r| r.expect("par_for calls f once for every index")).collect()
}

/// Calls `f(i)` once for every `i` in `0..n`, on `participants` threads: the calling thread
/// and the members of `crew` ([`Crew::run`]; the caller alone without one, or with one
/// participant). Indices are claimed in chunks of `chunk`. Before `f` takes an index, the
/// index the same thread will take next is hinted to `ahead` (the step uses it to start
/// loading the next world's memory, [`Slot::prefetch`]); a thread claims its next chunk before
/// the last index of the current one, so what it hints is always its own.
///
/// Each participant has a home share of the chunks — a contiguous run, the same run every
/// call — and takes its own chunks first, front to back; one that runs out takes the last
/// chunk of the participant with the most left ([`HomeRuns`], lock-free). So a world is stepped
/// by the same thread step after step and its memory stays in that core's cache, while a slow
/// world (one that spawns its next episode) is still balanced out. (With one shared queue the
/// worlds moved between the cores every step: two threads stepped 64 worlds 1.4× as fast as
/// one, against 2.0× for two separate batches of 32.)
///
/// Only indices are handed out: each task finds its world and its pieces of the outputs from
/// the index ([`Disjoint`], [`OutPieces`]). Building a list of per-world items and output
/// slices first was serial work on the caller, ≈ 6 % of a two-thread step at E = 8192.
///
/// Why not `pool.install(par_iter)`: the caller (Python's thread) then only waits, and every
/// step pays for waking all workers and for waking the caller again (≈ 40–80 µs on this VM,
/// as much as 16 worlds' work); here the caller starts at once and the crew's members join as
/// they wake, or not at all for fewer than [`WAKE_FROM`] items (see [`crate::crew`] for why
/// not a rayon scope).
fn par_for(crew: Option<&mut Crew>, participants: usize, n: usize, chunk: usize, ahead: impl Fn(usize) + Sync, f: impl Fn(usize) + Sync) {
    let crew = match crew {
        Some(c) if participants > 1 && n > 0 => c,
        // One thread: the caller's, with no crew to hand anything to.
        _ => {
            for i in 0..n {
                if i + 1 < n {
                    ahead(i + 1);
                }
                f(i);
            }
            return;
        }
    };
    let runs = HomeRuns::new(n, chunk, participants);
    // Participant `home` (the caller 0, crew member w its w) drains its home run, then helps.
    // It claims its next chunk before it runs the last index of the current one, so that the
    // index it hints is always one it holds (a world another thread steps is never touched).
    crew.run_with(&|home: usize| {
        let mut current = runs.take(home);
        while let Some(range) = current {
            let next = runs.take(home);
            for i in range.clone() {
                let hint = if i + 1 < range.end { Some(i + 1) } else { next.as_ref().map(|r| r.start) };
                if let Some(h) = hint {
                    ahead(h);
                }
                f(i);
            }
            current = next;
        }
    }, n >= WAKE_FROM);
}

/// Shared access, from many threads, to distinct elements of a slice borrowed for `'a`: the
/// callers promise (unsafely) that no element is taken twice at once — [`par_for`] hands out
/// each index once.
struct Disjoint<'a, T> {
    ptr: *mut T,
    len: usize,
    _borrow: std::marker::PhantomData<&'a mut [T]>,
}

// SAFETY: a Disjoint is a `&mut [T]` whose elements go to different threads.
unsafe impl<T: Send> Send for Disjoint<'_, T> {}
unsafe impl<T: Send> Sync for Disjoint<'_, T> {}

impl<'a, T> Disjoint<'a, T> {
    fn new(s: &'a mut [T]) -> Self {
        Self { ptr: s.as_mut_ptr(), len: s.len(), _borrow: std::marker::PhantomData }
    }

    /// Element `i`.
    ///
    /// # Safety
    /// No other reference to element `i` may be alive while this one is.
    #[inline]
    unsafe fn item(&self, i: usize) -> &'a mut T {
        assert!(i < self.len, "index {i} of {}", self.len);
        // SAFETY: in bounds; exclusive by the caller's promise.
        unsafe { &mut *self.ptr.add(i) }
    }

    /// Elements `i·per .. (i+1)·per` (empty when `per` is 0).
    ///
    /// # Safety
    /// No other reference to any of these elements may be alive while this one is.
    #[inline]
    unsafe fn piece(&self, i: usize, per: usize) -> &'a mut [T] {
        if per == 0 {
            return &mut [];
        }
        assert!((i + 1) * per <= self.len, "piece {i} of {per} in {}", self.len);
        // SAFETY: in bounds; exclusive by the caller's promise.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(i * per), per) }
    }
}

/// A step's outputs as every world's pieces ([`OutPieces::world`]), each found from the world's
/// index by the task that steps it.
struct OutPieces<'a> {
    obs_w: Disjoint<'a, MaybeUninit<f32>>,
    obs_t: Disjoint<'a, MaybeUninit<f32>>,
    rew_w: Disjoint<'a, f32>,
    rew_t: Disjoint<'a, f32>,
    term: Disjoint<'a, bool>,
    trunc: Disjoint<'a, bool>,
    fin_w: Disjoint<'a, f32>,
    fin_t: Disjoint<'a, f32>,
    outcome: Disjoint<'a, u8>,
    steps: Disjoint<'a, u32>,
    capture_step: Disjoint<'a, i64>,
    cornered_step: Disjoint<'a, i64>,
    energy: Disjoint<'a, f64>,
    collisions: Disjoint<'a, u32>,
    distance: Disjoint<'a, f64>,
    /// Per world: obs, rewards and final obs of each side; targets; agents.
    per: [usize; 8],
}

impl<'a> OutPieces<'a> {
    /// The pieces of `o` (from [`BatchEnv::alloc`], observation arrays `lens` long) for `e`
    /// worlds of `n` wolves and `m` targets.
    fn new(o: &'a mut StepOutput, lens: ObsLens, e: usize, n: usize, m: usize) -> Self {
        let per = |v: usize| v.checked_div(e).unwrap_or(0);
        let [dw, dt] = lens.0.map(per);
        let per = [dw, dt, per(o.rewards_wolves.len()), per(o.rewards_targets.len()), per(o.final_obs_wolves.len()), per(o.final_obs_targets.len()), m, n + m];
        let unfilled = |v: &'a mut Vec<f32>, len: usize| Disjoint::new(&mut v.spare_capacity_mut()[..len]);
        Self {
            obs_w: unfilled(&mut o.obs_wolves, lens.0[0]),
            obs_t: unfilled(&mut o.obs_targets, lens.0[1]),
            rew_w: Disjoint::new(&mut o.rewards_wolves),
            rew_t: Disjoint::new(&mut o.rewards_targets),
            term: Disjoint::new(&mut o.terminated),
            trunc: Disjoint::new(&mut o.truncated),
            fin_w: Disjoint::new(&mut o.final_obs_wolves),
            fin_t: Disjoint::new(&mut o.final_obs_targets),
            outcome: Disjoint::new(&mut o.outcome),
            steps: Disjoint::new(&mut o.steps),
            capture_step: Disjoint::new(&mut o.capture_step),
            cornered_step: Disjoint::new(&mut o.cornered_step),
            energy: Disjoint::new(&mut o.energy),
            collisions: Disjoint::new(&mut o.collisions),
            distance: Disjoint::new(&mut o.distance),
            per,
        }
    }

    /// World `i`'s pieces, its observation pieces zeroed here (by the world's own task, not
    /// by the caller before the tasks start: see [`BatchEnv::alloc`]).
    ///
    /// # Safety
    /// No other reference to world `i`'s pieces may be alive while these are.
    #[inline]
    unsafe fn world(&self, i: usize) -> SlotOut<'a> {
        let [dw, dt, rw, rt, fw, ft, m, agents] = self.per;
        let zeroed = |piece: &'a mut [MaybeUninit<f32>]| {
            piece.fill(MaybeUninit::new(0.0));
            // SAFETY: every element was just written; MaybeUninit<f32> has f32's layout.
            unsafe { &mut *(piece as *mut [MaybeUninit<f32>] as *mut [f32]) }
        };
        // SAFETY: distinct worlds' pieces are disjoint; world i's are exclusive by the caller.
        unsafe {
            SlotOut {
                obs_w: zeroed(self.obs_w.piece(i, dw)),
                obs_t: zeroed(self.obs_t.piece(i, dt)),
                rew_w: self.rew_w.piece(i, rw),
                rew_t: self.rew_t.piece(i, rt),
                term: self.term.item(i),
                trunc: self.trunc.item(i),
                fin_w: self.fin_w.piece(i, fw),
                fin_t: self.fin_t.piece(i, ft),
                outcome: self.outcome.item(i),
                steps: self.steps.item(i),
                capture_step: self.capture_step.piece(i, m),
                cornered_step: self.cornered_step.piece(i, m),
                energy: self.energy.piece(i, agents),
                collisions: self.collisions.piece(i, agents),
                distance: self.distance.piece(i, agents),
            }
        }
    }
}

/// The chunks of [`par_for`]: chunk k is indices `k·chunk .. min((k+1)·chunk, n)`, and
/// participant p's home is the run `front..back` of the chunks it has not taken (one atomic
/// word per home, on a cache line of its own: taking one's own next chunk touches no line
/// another thread writes, unless that thread is stealing from it).
struct HomeRuns {
    n: usize,
    chunk: usize,
    homes: Vec<HomeRun>,
}

/// `front << 32 | back`, in chunks.
#[repr(align(64))]
struct HomeRun(std::sync::atomic::AtomicU64);

fn pack(front: usize, back: usize) -> u64 {
    ((front as u64) << 32) | back as u64
}

fn unpack(v: u64) -> (usize, usize) {
    ((v >> 32) as usize, (v & 0xffff_ffff) as usize)
}

impl HomeRuns {
    /// `0..n` in chunks of `chunk` (at least 1), dealt in order to `participants` homes of as
    /// equal a count of chunks as can be.
    fn new(n: usize, chunk: usize, participants: usize) -> Self {
        let chunk = chunk.max(1);
        let c = n.div_ceil(chunk);
        assert!(c < 1 << 32, "{c} chunks");
        let homes = (0..participants).map(|p| HomeRun(std::sync::atomic::AtomicU64::new(pack(p * c / participants, (p + 1) * c / participants)))).collect();
        Self { n, chunk, homes }
    }

    /// The next chunk for participant `home` (taken modulo the participants): the front of its
    /// own run, else the back of the longest run left; `None` when every chunk is taken.
    fn take(&self, home: usize) -> Option<std::ops::Range<usize>> {
        let own = &self.homes[home % self.homes.len()].0;
        let mut v = own.load(Ordering::Acquire);
        let k = loop {
            let (front, back) = unpack(v);
            if front < back {
                match own.compare_exchange_weak(v, pack(front + 1, back), Ordering::AcqRel, Ordering::Acquire) {
                    Ok(_) => break front,
                    Err(now) => v = now,
                }
                continue;
            }
            // Own run done: the back of the longest run left (the lowest-numbered of equals).
            let (victim, (f, b)) = self.homes.iter().map(|h| unpack(h.0.load(Ordering::Acquire))).enumerate().max_by_key(|&(p, (f, b))| (b.saturating_sub(f), std::cmp::Reverse(p)))?;
            if f >= b {
                return None;
            }
            if self.homes[victim].0.compare_exchange(pack(f, b), pack(f, b - 1), Ordering::AcqRel, Ordering::Acquire).is_ok() {
                break b - 1;
            }
            v = own.load(Ordering::Acquire);
        };
        Some(k * self.chunk..((k + 1) * self.chunk).min(self.n))
    }
}

fn env_slot(params: &Arc<Params>, seed: u64, episode: u64, layout: Option<&Layout>) -> Result<Slot> {
    let mut world = match layout {
        Some(l) => World::from_layout_episode(params.clone(), seed, episode, l)?,
        // BatchEnv::new validated the params; they are immutable behind the Arc since.
        None => World::new_episode_prevalidated(params.clone(), seed, episode)?,
    };
    // Every reader of a batch world's polygons places what it reads (write_obs, world()).
    world.lazy_obstacles = true;
    let (n, m) = (world.n_wolves(), world.n_targets());
    Ok(Slot { rewards: RewardState::new(&world), world, seed, episode, observer: Observer::default(), wolf_cmds: vec![Command::default(); n], target_cmds: vec![Command::default(); m] })
}

#[allow(clippy::too_many_arguments)]
fn step_slot(s: &mut Slot, mut o: SlotOut, wa: &[f32], ta: &[f32], learners: Learners, autoreset: bool, params: &Arc<Params>, track: bool) -> Result<()> {
    let p = &**params;
    let (wolf_mode, target_mode) = (p.env.wolf_mode(), p.env.target_mode());
    if !s.world.is_done() {
        for (k, a) in s.world.wolves.iter().enumerate().take(wa.len() / 2) {
            s.wolf_cmds[k] = decode(wolf_mode, a.theta, wa[2 * k], wa[2 * k + 1], p.agents.wolf.v_max, p.agents.wolf.omega_max, p.world.ts);
        }
        let side = &p.agents.target;
        for (k, a) in s.world.targets.iter().enumerate().take(ta.len() / 2) {
            s.target_cmds[k] = decode(target_mode, a.theta, ta[2 * k], ta[2 * k + 1], side.v_max, side.omega_max, p.world.ts);
        }
        let wc = learners.wolves().then_some(&s.wolf_cmds[..]);
        let tc = learners.targets().then_some(&s.target_cmds[..]);
        s.world.step_with(wc, tc);
        if s.world.fault().is_none() {
            s.rewards.step(&s.world, o.rew_w, o.rew_t);
        }
    }
    // A faulted world (a law overflowed) fails this step and every later one until it is reset.
    s.world.check_fault()?;
    let outcome = s.world.outcome;
    *o.term = matches!(outcome, Outcome::Captured | Outcome::Cornered | Outcome::Collision);
    *o.trunc = outcome == Outcome::Timeout;
    write_infos(&s.world, &mut o);
    if autoreset && outcome != Outcome::Running {
        write_obs(s, o.fin_w, o.fin_t);
        s.respawn(params, s.episode + 1, track)?;
    }
    write_obs(s, o.obs_w, o.obs_t);
    Ok(())
}

fn write_obs(s: &mut Slot, obs_w: &mut [f32], obs_t: &mut [f32]) {
    if obs_w.is_empty() && obs_t.is_empty() {
        return;
    }
    // The lidar reads the vertices of the polygons within its range: place those of a lazy
    // world (the step placed only the ones the agents could touch or avoid).
    let lidar = &s.world.params.env.lidar;
    if lidar.rays > 0 {
        let range = lidar.range;
        s.world.place_for_lidar(!obs_w.is_empty(), !obs_t.is_empty(), range);
    }
    let w = &s.world;
    s.observer.prepare(w);
    if !obs_w.is_empty() {
        let d = obs_w.len() / w.n_wolves();
        for (i, chunk) in obs_w.chunks_mut(d).enumerate() {
            s.observer.wolf(w, i, chunk);
        }
    }
    if !obs_t.is_empty() {
        let d = obs_t.len() / w.n_targets();
        for (j, chunk) in obs_t.chunks_mut(d).enumerate() {
            s.observer.target(w, j, chunk);
        }
    }
}

fn write_infos(w: &World, o: &mut SlotOut) {
    *o.outcome = outcome_code(w.outcome);
    *o.steps = w.t;
    for (c, s) in o.capture_step.iter_mut().zip(&w.target_capture_step) {
        *c = s.map_or(-1, i64::from);
    }
    for (c, s) in o.cornered_step.iter_mut().zip(&w.target_cornered_step) {
        *c = s.map_or(-1, i64::from);
    }
    let (energy, collisions, distance) = (&mut *o.energy, &mut *o.collisions, &mut *o.distance);
    let n = w.n_wolves();
    for (k, e) in energy.iter_mut().enumerate() {
        *e = if k < n { w.wolves[k].energy } else { w.targets[k - n].energy };
    }
    collisions.copy_from_slice(&w.collisions);
    for (k, d) in distance.iter_mut().enumerate() {
        *d = if k < n {
            let x = nearest_target_distance(w, k);
            // -1 when no target is left (like capture_step's -1): infos stay finite, so
            // loggers and running means never meet a NaN.
            if x.is_finite() {
                x
            } else {
                -1.0
            }
        } else {
            nearest_wolf_distance(w, k - n)
        };
    }
}

/// A learner's action → command. Unicycle: v = (a₀+1)/2·v_max, ω = a₁·ω_max. Velocity: a is
/// a desired velocity in the agent frame in units of v_max (norm capped at 1), through the
/// saturator. Actions are clipped to [-1, 1] first.
pub fn decode(mode: ActionMode, theta: f64, a0: f32, a1: f32, v_max: f64, omega_max: f64, ts: f64) -> Command {
    let (a0, a1) = ((a0 as f64).clamp(-1.0, 1.0), (a1 as f64).clamp(-1.0, 1.0));
    match mode {
        ActionMode::Unicycle => Command { v: (a0 + 1.0) * 0.5 * v_max, omega: a1 * omega_max },
        ActionMode::Velocity => {
            let a = Vec2::new(a0, a1);
            let r = a.norm();
            let theta_d = if r > 0.0 { wrap(theta + atan2(a1, a0)) } else { theta };
            saturate(r.min(1.0) * v_max, theta_d, theta, v_max, omega_max, ts)
        }
    }
}

/// The inverse of [`decode`] for a law's desired (v_d, θ_d): unicycle encodes the saturated
/// command; velocity encodes the desired velocity itself (a zero speed keeps its direction as
/// a 1e-6 norm, so that the saturator still turns).
pub fn encode(mode: ActionMode, theta: f64, v_d: f64, theta_d: f64, v_max: f64, omega_max: f64, ts: f64) -> [f32; 2] {
    match mode {
        ActionMode::Unicycle => {
            let c = saturate(v_d, theta_d, theta, v_max, omega_max, ts);
            [((2.0 * c.v / v_max - 1.0).clamp(-1.0, 1.0)) as f32, ((c.omega / omega_max).clamp(-1.0, 1.0)) as f32]
        }
        ActionMode::Velocity => {
            let r = (v_d / v_max).clamp(1e-6, 1.0);
            let a = unit(theta_d - theta) * r;
            [a.x as f32, a.y as f32]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// The batch's worlds place only the polygons their agents can reach or see: every
    /// observation it writes must equal, bit for bit, the observation of the same world with
    /// every polygon placed. Many polygons, a long lidar and learned (random) actions on both
    /// sides, through autoresets.
    #[test]
    fn lazily_placed_polygons_change_no_observation() {
        use rand::{Rng, SeedableRng};
        let mut p = Params::default();
        p.obstacles.static_polygons = 8;
        p.obstacles.moving_polygons = 8;
        p.env.lidar.range = 4.0;
        let (e, n, m) = (4, p.world.wolves, p.world.targets);
        let mut env = BatchEnv::new(p.clone(), e, Learners::All, 9, true, Some(1)).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let (dw, dt) = (env.wolf_obs_dim(), env.target_obs_dim());
        let (mut stale_seen, mut checked) = (0, 0);
        for _ in 0..400 {
            let wa: Vec<f32> = (0..e * n * 2).map(|_| rng.random_range(-1.0..1.0)).collect();
            let ta: Vec<f32> = (0..e * m * 2).map(|_| rng.random_range(-1.0..1.0)).collect();
            let out = env.step(&wa, &ta).unwrap();
            for (k, s) in env.slots.iter().enumerate() {
                stale_seen += s.world.obstacles.iter().filter(|o| !o.placed).count();
                let mut w = s.world.clone();
                w.settle_obstacles();
                let mut observer = Observer::default();
                observer.prepare(&w);
                let mut want = vec![0f32; dw];
                for i in 0..n {
                    observer.wolf(&w, i, &mut want);
                    let got = &out.obs_wolves[(k * n + i) * dw..(k * n + i + 1) * dw];
                    assert!(got.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits()), "world {k} wolf {i}");
                }
                let mut want = vec![0f32; dt];
                for j in 0..m {
                    observer.target(&w, j, &mut want);
                    let got = &out.obs_targets[(k * m + j) * dt..(k * m + j + 1) * dt];
                    assert!(got.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits()), "world {k} target {j}");
                }
                checked += 1;
            }
        }
        assert!(stale_seen > 1000 && checked == 1600, "polygons were left unplaced {stale_seen} times");
        // world() hands out every polygon placed.
        assert!(env.world(0).unwrap().obstacles.iter().all(|o| o.placed));
    }

    #[test]
    fn share_maps_in_item_order_whatever_the_threads_and_chunks() {
        let mut crew = Crew::new(2).unwrap();
        let want: Vec<usize> = (0..1000).map(|k| 3 * k).collect();
        for (participants, chunk) in [(1, 1), (2, 7), (3, 16), (3, 1000)] {
            assert_eq!(share(Some(&mut crew), participants, (0..1000).collect(), chunk, |k: usize| 3 * k), want, "{participants} threads, chunk {chunk}");
        }
        assert_eq!(share(None, 2, (0..10).collect(), 3, |k: usize| k), (0..10).collect::<Vec<_>>());
    }

    #[test]
    fn each_participant_takes_its_home_chunks_first_then_the_back_of_the_longest_run() {
        // 10 indices in chunks of 2: chunks 0..5 start at 0, 2, 4, 6, 8; homes of 2
        // participants are chunks 0..2 and 2..5.
        let q = HomeRuns::new(10, 2, 2);
        assert_eq!(q.take(1), Some(4..6));
        assert_eq!(q.take(0), Some(0..2));
        assert_eq!(q.take(0), Some(2..4));
        // Participant 0's run is done: it takes the last chunk of participant 1's.
        assert_eq!(q.take(0), Some(8..10));
        assert_eq!(q.take(1), Some(6..8));
        assert_eq!(q.take(1), None);
        assert_eq!(q.take(0), None);
        // Homes beyond the participants wrap; a last short chunk; more participants than
        // chunks: every index is still handed out exactly once.
        for (participants, chunk, n) in [(3, 1, 2), (4, 3, 10), (2, 1, 0), (5, 7, 100)] {
            let q = HomeRuns::new(n, chunk, participants);
            let mut seen = Vec::new();
            for round in 0.. {
                match q.take(round * 7) {
                    Some(range) => {
                        assert!(!range.is_empty() && range.len() <= chunk && range.start % chunk == 0);
                        seen.extend(range);
                    }
                    None => break,
                }
            }
            seen.sort_unstable();
            assert_eq!(seen, (0..n).collect::<Vec<_>>(), "{participants} participants, chunk {chunk}, {n} indices");
        }
    }

    #[test]
    fn par_for_hints_each_index_once_just_before_the_one_it_runs_before_it() {
        let log = Mutex::new(Vec::new());
        let push = |s: String| log.lock().unwrap().push(s);
        par_for(None, 1, 5, 5, |next| push(format!("ahead {next}")), |i| push(format!("run {i}")));
        let want = ["ahead 1", "run 0", "ahead 2", "run 1", "ahead 3", "run 2", "ahead 4", "run 3", "run 4"];
        assert_eq!(*log.lock().unwrap(), want);
        // Threads: every index runs once, and the index a thread hints is the next one that
        // same thread runs (a world that another thread may be stepping is never touched).
        let mut crew = Crew::new(2).unwrap();
        for (n, chunk) in [(100, 7), (64, 1), (5, 16), (1000, 3)] {
            let events = Mutex::new(Vec::new());
            let me = || format!("{:?}", std::thread::current().id());
            par_for(Some(&mut crew), 3, n, chunk, |next| events.lock().unwrap().push((me(), true, next)), |i| {
                // Long enough for the threads to interleave and to steal from each other.
                std::thread::sleep(Duration::from_micros(if i % 5 == 0 { 200 } else { 20 }));
                events.lock().unwrap().push((me(), false, i));
            });
            let events = events.into_inner().unwrap();
            let mut ran: Vec<usize> = events.iter().filter(|e| !e.1).map(|e| e.2).collect();
            ran.sort_unstable();
            assert_eq!(ran, (0..n).collect::<Vec<_>>(), "n {n}, chunk {chunk}: each index once");
            let mut threads: Vec<String> = events.iter().map(|e| e.0.clone()).collect();
            threads.sort();
            threads.dedup();
            for t in threads {
                let mine: Vec<(bool, usize)> = events.iter().filter(|e| e.0 == t).map(|e| (e.1, e.2)).collect();
                for (k, &(hint, h)) in mine.iter().enumerate() {
                    if hint {
                        // ahead h, run i, then the thread's next run is h.
                        let next_run = mine[k + 1..].iter().filter(|e| !e.0).nth(1).map(|e| e.1);
                        assert_eq!(next_run, Some(h), "n {n}, chunk {chunk}: thread {t} hinted {h}: {mine:?}");
                    }
                }
            }
        }
        par_for(Some(&mut crew), 3, 0, 4, |_| panic!("nothing to hint"), |_| panic!("nothing to run"));
    }

    /// A task that panics on a worker reaches the caller as a panic (the binding turns it
    /// into an exception) instead of leaving the caller waiting for that worker forever.
    #[test]
    fn a_panic_on_a_worker_is_handed_on_not_waited_for() {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut crew = Crew::new(1).unwrap();
            let work = |k: usize| {
                std::thread::sleep(Duration::from_millis(1)); // long enough for the worker to take tasks
                if std::thread::current().name().is_some_and(|n| n.starts_with("wolfpack-crew")) {
                    panic!("task {k} on the worker");
                }
                k
            };
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| share(Some(&mut crew), 2, (0..64).collect(), 1, work)));
            tx.send(r.is_err()).unwrap();
        });
        let panicked = rx.recv_timeout(Duration::from_secs(60)).expect("share still waiting 60 s after a worker's task panicked");
        assert!(panicked, "the worker's panic was not handed on");
    }
}
