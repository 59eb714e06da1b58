//! The layout of a step's outputs: every array of [`StepOutput`] row-major, world first, and
//! each world's pieces of them ([`SlotOut`]), found from the world's index by the task that
//! steps it ([`OutPieces`]).

use std::mem::MaybeUninit;

use super::schedule::Disjoint;
use super::BatchEnv;
use crate::reward::{nearest_target_distance, nearest_wolf_distance};
use crate::world::{Outcome, World};

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
    /// [E, S] with [`BatchEnv::set_with_state`]: every world's global state ([`crate::state`])
    /// after this reset or step (and its autoreset), written by the world's own task.
    pub state: Vec<f32>,
    /// [E, S]: the global state of a world whose episode ended this step, before its reset
    /// (autoreset with [`BatchEnv::set_with_state`] only; zeros elsewhere): what a centralised
    /// critic bootstraps from when the episode was truncated.
    pub final_state: Vec<f32>,
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

/// `o`'s code in the batch's `outcome` array: its index in [`Outcome::ALL`].
pub fn outcome_code(o: Outcome) -> u8 {
    match o {
        Outcome::Running => 0,
        Outcome::Captured => 1,
        Outcome::Collision => 2,
        Outcome::Timeout => 3,
        Outcome::Cornered => 4,
    }
}

/// One world's share of a [`StepOutput`].
pub(super) struct SlotOut<'a> {
    pub(super) obs_w: &'a mut [f32],
    pub(super) obs_t: &'a mut [f32],
    pub(super) rew_w: &'a mut [f32],
    pub(super) rew_t: &'a mut [f32],
    pub(super) term: &'a mut bool,
    pub(super) trunc: &'a mut bool,
    pub(super) fin_w: &'a mut [f32],
    pub(super) fin_t: &'a mut [f32],
    pub(super) fin_s: &'a mut [f32],
    pub(super) state: &'a mut [f32],
    pub(super) outcome: &'a mut u8,
    pub(super) steps: &'a mut u32,
    pub(super) capture_step: &'a mut [i64],
    pub(super) cornered_step: &'a mut [i64],
    pub(super) energy: &'a mut [f64],
    pub(super) collisions: &'a mut [u32],
    pub(super) distance: &'a mut [f64],
}

/// The lengths of a step's observation arrays, the wolves' and the targets', while their
/// worlds' tasks fill them ([`BatchEnv::alloc`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct ObsLens([usize; 2]);

impl ObsLens {
    /// Gives the two arrays of `o` their lengths.
    ///
    /// # Safety
    /// The first `len` elements of each array's spare capacity must have been written.
    pub(super) unsafe fn set(self, o: &mut StepOutput) {
        for (v, len) in [&mut o.obs_wolves, &mut o.obs_targets].into_iter().zip(self.0) {
            debug_assert!(v.is_empty() && v.capacity() >= len);
            // SAFETY: capacity ≥ len (`alloc`), and the caller vouches for the contents.
            unsafe { v.set_len(len) };
        }
    }
}

impl BatchEnv {
    /// A step's outputs, the two observation arrays allocated but still empty: their lengths
    /// come back separately, and each world's task zeroes and fills its own pieces
    /// ([`OutPieces::world`]). Zeroing them here, on the caller's thread, cost ≈ 5 % of a
    /// two-thread step: the caller wrote every line before the other thread wrote it again.
    /// The final observations stay `calloc`'d: a world writes its piece only when its episode
    /// ends. (The allocators reuse the last step's blocks and clear them with a `memset`, 3 % of
    /// a one-thread step at E = 8,192; zeroing them in the worlds' tasks instead, as for the
    /// observations, measured no faster on one thread or two: BENCHMARKS.md, "Optimisations".)
    pub(super) fn alloc(&self) -> (StepOutput, ObsLens) {
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
            state: if self.with_state { vec![0.0; e * self.state_dim()] } else { Vec::new() },
            final_state: if self.autoreset && self.with_state { vec![0.0; e * self.state_dim()] } else { Vec::new() },
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
}

/// A step's outputs as every world's pieces ([`OutPieces::world`]), each found from the world's
/// index by the task that steps it.
pub(super) struct OutPieces<'a> {
    obs_w: Disjoint<'a, MaybeUninit<f32>>,
    obs_t: Disjoint<'a, MaybeUninit<f32>>,
    rew_w: Disjoint<'a, f32>,
    rew_t: Disjoint<'a, f32>,
    term: Disjoint<'a, bool>,
    trunc: Disjoint<'a, bool>,
    fin_w: Disjoint<'a, f32>,
    fin_t: Disjoint<'a, f32>,
    fin_s: Disjoint<'a, f32>,
    state: Disjoint<'a, f32>,
    outcome: Disjoint<'a, u8>,
    steps: Disjoint<'a, u32>,
    capture_step: Disjoint<'a, i64>,
    cornered_step: Disjoint<'a, i64>,
    energy: Disjoint<'a, f64>,
    collisions: Disjoint<'a, u32>,
    distance: Disjoint<'a, f64>,
    /// Per world: obs, rewards and final obs of each side; final state; state; targets; agents.
    per: [usize; 10],
}

impl<'a> OutPieces<'a> {
    /// The pieces of `o` (from [`BatchEnv::alloc`], observation arrays `lens` long) for `e`
    /// worlds of `n` wolves and `m` targets.
    pub(super) fn new(o: &'a mut StepOutput, lens: ObsLens, e: usize, n: usize, m: usize) -> Self {
        let per = |v: usize| v.checked_div(e).unwrap_or(0);
        let [dw, dt] = lens.0.map(per);
        let per =
            [dw, dt, per(o.rewards_wolves.len()), per(o.rewards_targets.len()), per(o.final_obs_wolves.len()), per(o.final_obs_targets.len()), per(o.final_state.len()), per(o.state.len()), m, n + m];
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
            fin_s: Disjoint::new(&mut o.final_state),
            state: Disjoint::new(&mut o.state),
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
    pub(super) unsafe fn world(&self, i: usize) -> SlotOut<'a> {
        let [dw, dt, rw, rt, fw, ft, fs, st, m, agents] = self.per;
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
                fin_s: self.fin_s.piece(i, fs),
                state: self.state.piece(i, st),
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

pub(super) fn write_infos(w: &World, o: &mut SlotOut) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_outcome_code_is_its_index_in_the_list_of_outcomes() {
        for (k, o) in Outcome::ALL.into_iter().enumerate() {
            assert_eq!(usize::from(outcome_code(o)), k, "{}", o.as_str());
        }
    }
}
