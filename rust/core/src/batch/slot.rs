//! One world of the batch: its state beside the world itself (seed, episode, rewards, the
//! observer's scratch, the commands), its step with the outputs it writes, and its respawn.

use std::sync::Arc;

use super::actions::decode;
use super::output::{write_infos, SlotOut};
use super::Learners;
use crate::config::Params;
use crate::error::Result;
use crate::observe::Observer;
use crate::policies::Command;
use crate::reward::RewardState;
use crate::world::{Layout, Outcome, World};

pub(super) struct Slot {
    pub(super) world: World,
    pub(super) seed: u64,
    pub(super) episode: u64,
    pub(super) rewards: RewardState,
    pub(super) observer: Observer,
    pub(super) wolf_cmds: Vec<Command>,
    pub(super) target_cmds: Vec<Command>,
}

impl Slot {
    /// Starts episode `episode` of this slot's world in place ([`World::respawn`]): the slot
    /// `env_slot` would make for it (the observer's scratch aside, which holds nothing from one
    /// use to the next), in this slot's own allocations.
    pub(super) fn respawn(&mut self, params: &Arc<Params>, episode: u64, track: bool) -> Result<()> {
        self.world.respawn(params.clone(), self.seed, episode)?;
        self.world.track_laws = track;
        self.episode = episode;
        // RewardState::new is reset on a default state: the same lists, kept.
        self.rewards.reset(&self.world);
        let (n, m) = (self.world.n_wolves(), self.world.n_targets());
        self.wolf_cmds.clear();
        self.wolf_cmds.resize(n, Command::default());
        self.target_cmds.clear();
        self.target_cmds.resize(m, Command::default());
        Ok(())
    }

    /// [`World::prefetch`] and the slot's own lists.
    #[inline]
    pub(super) fn prefetch(&self) {
        self.world.prefetch();
        self.observer.prefetch();
        self.rewards.prefetch();
        crate::math::prefetch_slice(&self.wolf_cmds);
        crate::math::prefetch_slice(&self.target_cmds);
    }
}

pub(super) fn env_slot(params: &Arc<Params>, seed: u64, episode: u64, layout: Option<&Layout>) -> Result<Slot> {
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
pub(super) fn step_slot(s: &mut Slot, mut o: SlotOut, wa: &[f32], ta: &[f32], learners: Learners, autoreset: bool, params: &Arc<Params>, track: bool) -> Result<()> {
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
    } else {
        // A finished world (no autoreset) earns nothing.
        o.rew_w.fill(0.0);
        o.rew_t.fill(0.0);
    }
    // A faulted world (a law overflowed) fails this step and every later one until it is reset.
    s.world.check_fault()?;
    let outcome = s.world.outcome;
    *o.term = matches!(outcome, Outcome::Captured | Outcome::Cornered | Outcome::Collision);
    *o.trunc = outcome == Outcome::Timeout;
    write_infos(&s.world, &mut o);
    if autoreset && outcome != Outcome::Running {
        write_obs(s, o.fin_w, o.fin_t);
        if !o.fin_s.is_empty() {
            crate::state::write_state(&s.world, p, o.fin_s)?;
        }
        s.respawn(params, s.episode + 1, track)?;
    } else {
        o.clear_finals();
    }
    write_obs(s, o.obs_w, o.obs_t);
    if !o.state.is_empty() {
        crate::state::write_state(&s.world, p, o.state)?;
    }
    Ok(())
}

pub(super) fn write_obs(s: &mut Slot, obs_w: &mut [f32], obs_t: &mut [f32]) {
    if obs_w.is_empty() && obs_t.is_empty() {
        return;
    }
    // The lidar and the entity rows read the vertices of the polygons within their ranges:
    // place those of a lazy world (the step placed only the ones the agents could touch or
    // avoid).
    let env = &s.world.params.env;
    let lidar = if env.lidar.rays > 0 { env.lidar.range } else { 0.0 };
    let entities = if env.observes_entities() { env.entities.range } else { 0.0 };
    let range = lidar.max(entities);
    if range > 0.0 {
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
