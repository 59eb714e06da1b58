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
//! - Every reset and step writes its outputs into arrays the caller owns ([`StepBuffers`], laid
//!   out by [`BatchEnv::output_specs`]: the binding's numpy arrays, allocated once by a trainer),
//!   or into fresh vectors ([`StepOutput`]).
//!
//! | module | its one job |
//! |---|---|
//! | this one | the API: [`BatchEnv`] |
//! | `slot` | one world of the batch (`Slot`): its step, its respawn, its observations |
//! | `schedule` | spreading a step's worlds over the caller and the crew ([`crate::crew`]) |
//! | `output` | the layout of a step's outputs ([`OutputSpec`], [`StepBuffers`]) and each world's pieces of it |
//! | `actions` | a learner's action ↔ a command ([`decode`], [`encode`]) |

mod actions;
mod output;
mod schedule;
mod slot;

pub use actions::{decode, encode};
pub use output::{outcome_code, Dtype, OutputSpec, StepBuffers, StepOutput};

use output::{write_infos, OutPieces};
use schedule::{par_for, share, Disjoint, FirstFailure};
use slot::{env_slot, step_slot, write_obs, Slot};

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crate::config::Params;
use crate::crew::Crew;
use crate::error::{Error, Result};
use crate::observe::{target_dim, wolf_dim};
use crate::policies::WolfMemory;
use crate::world::{Layout, World};

/// Which side learns; the other is scripted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Learners {
    Wolves,
    Targets,
    /// Both sides learn ("both"; the Python interface also takes "all", its first name).
    Both,
    None,
}

impl Learners {
    /// Every value, in the order the interface lists them.
    pub const ALL: [Self; 4] = [Self::Wolves, Self::Targets, Self::Both, Self::None];

    /// The name the interface uses (`learners="wolves"`).
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Wolves => "wolves",
            Self::Targets => "targets",
            Self::Both => "both",
            Self::None => "none",
        }
    }

    pub fn parse(s: &str) -> Result<Self> {
        Self::ALL.into_iter().find(|l| l.as_str() == s).ok_or_else(|| {
            let names: Vec<String> = Self::ALL.iter().map(|l| format!("'{}'", l.as_str())).collect();
            Error::Invalid(format!("learners must be one of {}, got {s:?}", names.join(", ")))
        })
    }

    pub fn wolves(self) -> bool {
        matches!(self, Self::Wolves | Self::Both)
    }

    pub fn targets(self) -> bool {
        matches!(self, Self::Targets | Self::Both)
    }
}

/// Batches of fewer worlds step on the caller's thread whatever the thread count
/// (`BatchEnv::steps_inline`).
pub const INLINE_BELOW: usize = 8;

/// Most worlds in one claim of a shared step ([`BatchEnv::chunk`]): at large batches a claim
/// (one atomic update, nanoseconds unless another thread is stealing from the same run) every
/// 16 worlds is free next to their steps, and a thread that runs out steals at most 16 worlds'
/// work at a time (BENCHMARKS.md, "Optimisations").
const MAX_CHUNK: usize = 16;

/// Worlds per thread from which a step asks the CPU to load each next world's memory while it
/// steps the current one ([`Slot::prefetch`]). Below, a thread's worlds are still in the
/// caches the last step left them in, and the hints only cost: without them, E = 64 and
/// E = 1,024 ran a few per cent faster on one thread and on two; above, the worlds come from
/// memory and the hints pay, most on one thread and a little on two; at 2,048 per thread it
/// was even (steady-state runs, interleaved: BENCHMARKS.md, "Optimisations").
const PREFETCH_FROM: usize = 2048;

/// Most worlds one batch may hold.
pub const MAX_ENVS: usize = 1 << 17;

/// Most agents (worlds × (N + M)) one batch may hold: its outputs are sized by them.
pub const MAX_BATCH_AGENTS: usize = 1 << 24;

pub struct BatchEnv {
    params: Arc<Params>,
    learners: Learners,
    autoreset: bool,
    slots: Vec<Slot>,
    /// The threads besides the calling thread (`threads − 1` of them, all cores' worth when
    /// `threads` is None); `None` with one thread, which steps on the caller's thread alone.
    crew: Option<Crew>,
    track_laws: bool,
    /// Whether outputs carry [`StepOutput::state`] and, on autoreset steps,
    /// [`StepOutput::final_state`].
    with_state: bool,
    /// The wolves' and the targets' observation sizes: fixed with the params' layout, which
    /// [`BatchEnv::set_drivers`] cannot change, and read by every step's buffer check (the
    /// layout they come from is a list built per call).
    obs_dims: (usize, usize),
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
        let obs_dims = (wolf_dim(&params), target_dim(&params));
        let mut env = Self { params, learners, autoreset, slots: Vec::new(), crew, track_laws: false, with_state: false, obs_dims };
        let participants = env.participants();
        let g = |i: usize| if stop.load(Ordering::Relaxed) { Err(Error::Interrupted) } else { env_slot(&env.params, seed.wrapping_add(i as u64), 0, None) };
        let worlds: Vec<Result<Slot>> = share(env.crew.as_mut(), participants, (0..num_envs).collect(), MAX_CHUNK, g);
        env.slots = worlds.into_iter().collect::<Result<_>>()?;
        Ok(env)
    }

    /// Whether a step runs on the caller's thread: with one thread, and for batches too small
    /// to share (waking the crew and handing work back costs about two worlds' steps with
    /// observations: below [`INLINE_BELOW`] worlds more threads only make it slower;
    /// BENCHMARKS.md, "Optimisations").
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
    /// the other's core as it can (a world stolen is a world whose several KB of state crosses
    /// between the cores' caches, there and back the next step). Against 8 worlds per claim
    /// it steps E = 64 on 2 threads about an eighth faster with the crew (BENCHMARKS.md,
    /// "Optimisations").
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
        self.obs_dims.0
    }
    pub fn target_obs_dim(&self) -> usize {
        self.obs_dims.1
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

    /// Whether every reset and step also writes each world's global state
    /// ([`StepOutput::state`], in the worlds' own tasks rather than a pass of [`Self::state`]
    /// after them) and, on autoreset steps, the state each ended episode finished in
    /// ([`StepOutput::final_state`]). Off by default: one or two [E, state_dim] arrays more per
    /// step, which only centralised critics read.
    pub fn set_with_state(&mut self, on: bool) {
        self.with_state = on;
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
        let mut out = self.new_outputs();
        self.reset_into(seed, stop, &mut out.buffers())?;
        Ok(out)
    }

    /// [`BatchEnv::reset_until`] writing into `out` (of [`Self::output_specs`]' shapes).
    pub fn reset_into(&mut self, seed: Option<u64>, stop: &AtomicBool, out: &mut StepBuffers) -> Result<()> {
        self.check_buffers(out)?;
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
        self.observe_into(out)
    }

    /// Resets world `e` alone, optionally from an explicit layout (whose agent counts must
    /// equal this batch's). `seed` as in [`BatchEnv::reset`] but for this world: `seed` itself.
    pub fn reset_world(&mut self, e: usize, seed: Option<u64>, layout: Option<&Layout>) -> Result<StepOutput> {
        let mut out = self.new_outputs();
        self.reset_world_into(e, seed, layout, &mut out.buffers())?;
        Ok(out)
    }

    /// [`BatchEnv::reset_world`] writing into `out` (of [`Self::output_specs`]' shapes): every
    /// world's current observations, world `e`'s fresh.
    pub fn reset_world_into(&mut self, e: usize, seed: Option<u64>, layout: Option<&Layout>, out: &mut StepBuffers) -> Result<()> {
        self.check_buffers(out)?;
        let (cur_seed, cur_ep) = self.world_seed(e).ok_or_else(|| Error::Invalid(format!("world index {e} out of range (num_envs = {})", self.num_envs())))?;
        if let Some(l) = layout {
            let (n, m) = (self.n_wolves(), self.n_targets());
            if l.wolves.len() != n || l.targets.len() != m {
                return Err(Error::Layout(format!("layout has {} wolves and {} targets; this environment was built for {n} and {m} (its spaces depend on them)", l.wolves.len(), l.targets.len())));
            }
        }
        let (sd, ep) = match seed {
            Some(s) => (s, 0),
            None => (cur_seed, cur_ep + 1),
        };
        let mut slot = env_slot(&self.params, sd, ep, layout)?;
        slot.world.track_laws = self.track_laws;
        self.slots[e] = slot;
        self.observe_into(out)
    }

    /// Observations of the current states (as a reset returns them): obs, infos and (with
    /// [`Self::set_with_state`]) states filled, rewards zero, no episode end. Fails where a
    /// state cannot be written ([`Self::state`]'s error).
    pub fn observe_all(&mut self) -> Result<StepOutput> {
        let mut out = self.new_outputs();
        self.observe_into(&mut out.buffers())?;
        Ok(out)
    }

    /// [`BatchEnv::observe_all`] writing into `out` (of [`Self::output_specs`]' shapes).
    pub fn observe_into(&mut self, out: &mut StepBuffers) -> Result<()> {
        self.check_buffers(out)?;
        let e = self.slots.len();
        let (n, m) = (self.n_wolves(), self.n_targets());
        let (participants, chunk) = self.schedule();
        let params = self.params.clone();
        let outs = OutPieces::of_buffers(out, e, n, m);
        let slots = Disjoint::new(&mut self.slots);
        let failed = FirstFailure::default();
        par_for(
            self.crew.as_mut(),
            participants,
            e,
            chunk,
            |_| {},
            |i| {
                // SAFETY: par_for hands out each world index once.
                let (s, mut o) = unsafe { (slots.item(i), outs.world(i)) };
                write_obs(s, o.obs_w, o.obs_t);
                write_infos(&s.world, &mut o);
                o.rew_w.fill(0.0);
                o.rew_t.fill(0.0);
                (*o.term, *o.trunc) = (false, false);
                o.clear_finals();
                if !o.state.is_empty() {
                    if let Err(err) = crate::state::write_state(&s.world, &params, o.state) {
                        failed.record(i, err);
                    }
                }
            },
        );
        failed.into_result()
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

    /// One step of every world, into fresh outputs ([`BatchEnv::step_into`]).
    pub fn step(&mut self, wolf_actions: &[f32], target_actions: &[f32]) -> Result<StepOutput> {
        self.check_step_actions(wolf_actions, target_actions)?;
        let (e, n, m) = (self.slots.len(), self.n_wolves(), self.n_targets());
        let (mut out, lens) = self.alloc();
        self.step_pieces(wolf_actions, target_actions, OutPieces::of_fresh(&mut out, lens, e, n, m))?;
        // SAFETY: every world's task zeroed its pieces of the observation arrays before
        // anything else (`OutPieces::world`), and the pieces tile them.
        unsafe { lens.set(&mut out) };
        Ok(out)
    }

    /// One step of every world, its outputs written into `out` (of [`Self::output_specs`]'
    /// shapes; every element is written). `wolf_actions` ([E, N, 2]) / `target_actions`
    /// ([E, M, 2]) are required for (and only for) the learning sides; values are clipped to
    /// [-1, 1]. Nothing moves, and `out` is untouched, when the actions or the buffers are
    /// invalid; after an error of the step itself (a world's law failed) `out` holds no
    /// usable step. Without autoreset, a finished world stays as it is.
    pub fn step_into(&mut self, wolf_actions: &[f32], target_actions: &[f32], out: &mut StepBuffers) -> Result<()> {
        self.check_step_actions(wolf_actions, target_actions)?;
        self.check_buffers(out)?;
        let (e, n, m) = (self.slots.len(), self.n_wolves(), self.n_targets());
        self.step_pieces(wolf_actions, target_actions, OutPieces::of_buffers(out, e, n, m))
    }

    /// The actions of both sides as [`Self::step_into`] takes them, or the error naming what
    /// is wrong.
    fn check_step_actions(&self, wolf_actions: &[f32], target_actions: &[f32]) -> Result<()> {
        let (n, m) = (self.n_wolves(), self.n_targets());
        for (learns, acts, side, per) in [(self.learners.wolves(), wolf_actions, "wolf", n), (self.learners.targets(), target_actions, "target", m)] {
            if learns {
                self.check_actions(acts, side, per)?;
            } else if !acts.is_empty() {
                return Err(Error::Invalid(format!("{side}s are scripted here (learners = {:?}); pass no {side} actions", self.learners)));
            }
        }
        Ok(())
    }

    /// Steps every world into `outs` (checked actions).
    fn step_pieces(&mut self, wolf_actions: &[f32], target_actions: &[f32], outs: OutPieces) -> Result<()> {
        let (n, m) = (self.n_wolves(), self.n_targets());
        let e = self.slots.len();
        let learners = self.learners;
        let autoreset = self.autoreset;
        let params = self.params.clone();
        let track = self.track_laws;
        let (participants, chunk) = self.schedule();
        let slots = Disjoint::new(&mut self.slots);
        let failed = FirstFailure::default();
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
                failed.record(i, err);
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
        failed.into_result()
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
            return Err(Error::Invalid("set_drivers: the params may differ only in policies.* and env.*action_mode (the world itself cannot change mid-episode; build a new batch)".into()));
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::Observer;

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
        let mut env = BatchEnv::new(p.clone(), e, Learners::Both, 9, true, Some(1)).unwrap();
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
}
