//! The layout of a reset's or step's outputs: every array row-major, world first, named as the
//! Python binding names them ([`OutputSpec`]); owned ([`StepOutput`]) or borrowed from the
//! caller ([`StepBuffers`]); and each world's pieces of them ([`SlotOut`]), found from the
//! world's index by the task that steps it ([`OutPieces`]).

use std::mem::MaybeUninit;

use super::schedule::Disjoint;
use super::BatchEnv;
use crate::error::{Error, Result};
use crate::reward::{nearest_target_distance, nearest_wolf_distance};
use crate::world::{Outcome, World};

/// Declares the output arrays' types from their one list ([`for_each_output!`]):
/// [`StepOutput`] (owned), [`StepBuffers`] (borrowed), the conversion between them and each
/// array's key, in one order.
macro_rules! outputs {
    ($($(#[$doc:meta])* $name:ident: $t:ty,)*) => {
        /// The outputs of one reset or step, for the whole batch (row-major, world first), in
        /// vectors of their own ([`BatchEnv::output_specs`] gives every length and shape).
        #[derive(Debug, Clone, Default)]
        pub struct StepOutput {
            $($(#[$doc])* pub $name: Vec<$t>,)*
        }

        /// The same arrays as [`StepOutput`], owned by the caller and written in place by
        /// [`BatchEnv::step_into`] and the other `*_into` calls: every element of every array is
        /// written, whatever it held before. An array this batch does not write (a scripted
        /// side's observations, final observations without autoreset, states without
        /// [`BatchEnv::set_with_state`]) is empty.
        #[derive(Debug)]
        pub struct StepBuffers<'a> {
            $($(#[$doc])* pub $name: &'a mut [$t],)*
        }

        impl StepOutput {
            /// Its arrays, borrowed: what the `*_into` calls write.
            pub fn buffers(&mut self) -> StepBuffers<'_> {
                StepBuffers { $($name: &mut self.$name,)* }
            }
        }

        /// The number of output arrays of a reset or step.
        pub const OUTPUTS: usize = [$(stringify!($name),)*].len();

        impl StepBuffers<'_> {
            /// Each array's key and length, in declaration order.
            fn lens(&self) -> [(&'static str, usize); OUTPUTS] {
                [$((stringify!($name), self.$name.len()),)*]
            }
        }
    };
}

/// Calls the macro `$callback` with every output array's declaration, `$(#[doc] name: type,)*`,
/// in the one order that [`StepOutput`], [`StepBuffers`] and [`BatchEnv::output_specs`] share:
/// the one list of the outputs, from which the core declares its types and the Python binding
/// its views and dicts (its name is the key Python sees).
#[macro_export]
macro_rules! for_each_output {
    ($callback:ident) => {
        $callback! {
        /// [E, N, Dw] when wolves learn, else empty.
        obs_wolves: f32,
        /// [E, M, Dt] when targets learn, else empty.
        obs_targets: f32,
        /// [E, N]: both sides always (the scripted side's too, for evaluation).
        rewards_wolves: f32,
        /// [E, M].
        rewards_targets: f32,
        /// `[E]`: the episode ended by capture (or cornering, where it counts) or collision.
        terminated: bool,
        /// `[E]`: the episode ended at the step limit.
        truncated: bool,
        /// [E, N, Dw]: last observation of an episode that ended this step (autoreset only;
        /// zeros elsewhere).
        final_obs_wolves: f32,
        /// [E, M, Dt]: as `final_obs_wolves`.
        final_obs_targets: f32,
        /// [E, S] with [`BatchEnv::set_with_state`]: every world's global state ([`crate::state`])
        /// after this reset or step (and its autoreset), written by the world's own task.
        state: f32,
        /// [E, S]: the global state of a world whose episode ended this step, before its reset
        /// (autoreset with [`BatchEnv::set_with_state`] only; zeros elsewhere): what a centralised
        /// critic bootstraps from when the episode was truncated.
        final_state: f32,
        /// `[E]`: the infos of the episode this step belongs to (the finished one on an
        /// autoreset), from here on. [`Outcome`]'s code ([`outcome_code`]).
        outcome: u8,
        /// `[E]`: steps taken in the episode.
        steps: u32,
        /// [E, M]: step at which each target was captured (or, with `capture.cornered`,
        /// cornered), −1 if not.
        capture_step: i64,
        /// [E, M]: the first step at which each target was cornered (docs/world-and-laws.md §1.7),
        /// −1 if never.
        cornered_step: i64,
        /// [E, N+M]: accumulated energy (J).
        energy: f64,
        /// [E, N+M]: collision steps.
        collisions: u32,
        /// [E, N+M]: distance to the nearest uncaptured target (wolves; -1 when none is left) /
        /// nearest wolf (targets).
        distance: f64,
            }
    };
}

for_each_output!(outputs);

/// The element type of an output array.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dtype {
    F32,
    F64,
    Bool,
    U8,
    U32,
    I64,
}

/// One output array of a batch: its key, shape and element type. An array the batch does not
/// write has a zero in its shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutputSpec {
    pub name: &'static str,
    dims: [usize; 3],
    ndim: usize,
    pub dtype: Dtype,
}

impl OutputSpec {
    fn new(name: &'static str, shape: &[usize], dtype: Dtype) -> Self {
        let mut dims = [0; 3];
        dims[..shape.len()].copy_from_slice(shape);
        Self { name, dims, ndim: shape.len(), dtype }
    }
    /// The array's shape, world first.
    pub fn shape(&self) -> &[usize] {
        &self.dims[..self.ndim]
    }
    /// Elements in the array.
    pub fn len(&self) -> usize {
        self.shape().iter().product()
    }
    /// Whether the batch writes nothing here.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
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

/// One world's share of a [`StepBuffers`].
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
    /// Whether the final observation and state pieces may hold something else than zeros (the
    /// caller's arrays, not a fresh step's `calloc`'d ones).
    stale_finals: bool,
}

impl SlotOut<'_> {
    /// The outputs of a world that did not end this step: no final observation or state.
    pub(super) fn clear_finals(&mut self) {
        if self.stale_finals {
            self.fin_w.fill(0.0);
            self.fin_t.fill(0.0);
            self.fin_s.fill(0.0);
        }
    }
}

impl BatchEnv {
    /// Every output array of this batch's resets and steps, in [`StepOutput`]'s order: what a
    /// caller allocates once for [`BatchEnv::step_into`], and what the binding names.
    pub fn output_specs(&self) -> [OutputSpec; OUTPUTS] {
        let e = self.slots.len();
        let (n, m) = (self.n_wolves(), self.n_targets());
        let (l, autoreset) = (self.learners, self.autoreset);
        let dw = if l.wolves() { self.wolf_obs_dim() } else { 0 };
        let dt = if l.targets() { self.target_obs_dim() } else { 0 };
        let s = if self.with_state { self.state_dim() } else { 0 };
        let fin = usize::from(autoreset);
        let spec = OutputSpec::new;
        [
            spec("obs_wolves", &[e, n, dw], Dtype::F32),
            spec("obs_targets", &[e, m, dt], Dtype::F32),
            spec("rewards_wolves", &[e, n], Dtype::F32),
            spec("rewards_targets", &[e, m], Dtype::F32),
            spec("terminated", &[e], Dtype::Bool),
            spec("truncated", &[e], Dtype::Bool),
            spec("final_obs_wolves", &[e, n, dw * fin], Dtype::F32),
            spec("final_obs_targets", &[e, m, dt * fin], Dtype::F32),
            spec("state", &[e, s], Dtype::F32),
            spec("final_state", &[e, s * fin], Dtype::F32),
            spec("outcome", &[e], Dtype::U8),
            spec("steps", &[e], Dtype::U32),
            spec("capture_step", &[e, m], Dtype::I64),
            spec("cornered_step", &[e, m], Dtype::I64),
            spec("energy", &[e, n + m], Dtype::F64),
            spec("collisions", &[e, n + m], Dtype::U32),
            spec("distance", &[e, n + m], Dtype::F64),
        ]
    }

    /// Fresh, zeroed outputs of this batch's shapes (what a caller of the `*_into` calls
    /// allocates once).
    pub fn new_outputs(&self) -> StepOutput {
        let (mut out, lens) = self.alloc();
        out.obs_wolves.resize(lens.0[0], 0.0);
        out.obs_targets.resize(lens.0[1], 0.0);
        out
    }

    /// A step's fresh outputs, the two observation arrays allocated but still empty: their
    /// lengths come back separately, and each world's task zeroes and fills its own pieces
    /// ([`OutPieces::world`]). Zeroing them here, on the caller's thread, cost a few per cent
    /// of a two-thread step at large batches: the caller wrote every line before the other
    /// thread wrote it again (BENCHMARKS.md, "Optimisations"). The final observations stay
    /// `calloc`'d: a world writes its piece only when its episode ends. (The allocators reuse
    /// the last step's blocks and clear them with a `memset`, a few per cent of a one-thread
    /// step at E = 8,192; zeroing them in the worlds' tasks instead, as for the observations,
    /// measured no faster on one thread or two: BENCHMARKS.md, "Profile of the hot path".)
    pub(super) fn alloc(&self) -> (StepOutput, ObsLens) {
        let lens = self.output_specs().map(|s| s.len());
        let obs = ObsLens([lens[0], lens[1]]);
        let out = StepOutput {
            obs_wolves: Vec::with_capacity(lens[0]),
            obs_targets: Vec::with_capacity(lens[1]),
            rewards_wolves: vec![0.0; lens[2]],
            rewards_targets: vec![0.0; lens[3]],
            terminated: vec![false; lens[4]],
            truncated: vec![false; lens[5]],
            final_obs_wolves: vec![0.0; lens[6]],
            final_obs_targets: vec![0.0; lens[7]],
            state: vec![0.0; lens[8]],
            final_state: vec![0.0; lens[9]],
            outcome: vec![0; lens[10]],
            steps: vec![0; lens[11]],
            capture_step: vec![-1; lens[12]],
            cornered_step: vec![-1; lens[13]],
            energy: vec![0.0; lens[14]],
            collisions: vec![0; lens[15]],
            distance: vec![0.0; lens[16]],
        };
        (out, obs)
    }

    /// Checks that `b` holds exactly this batch's arrays ([`Self::output_specs`]; the two
    /// lists share one order, which a test checks): a wrong length is an error naming the
    /// array, before anything moves.
    pub(super) fn check_buffers(&self, b: &StepBuffers) -> Result<()> {
        for (spec, (name, len)) in self.output_specs().iter().zip(b.lens()) {
            if len != spec.len() {
                return Err(Error::Invalid(format!("output {name}: expected {} values {:?}, got {len}", spec.len(), spec.shape())));
            }
        }
        Ok(())
    }
}

/// The lengths of a fresh step's observation arrays, the wolves' and the targets', while their
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

/// A reset's or step's outputs as every world's pieces ([`OutPieces::world`]), each found from
/// the world's index by the task that steps it.
pub(super) struct OutPieces<'a> {
    /// Written only with initialised values: the caller's arrays, or a fresh step's spare
    /// capacity, which each world's task zeroes before anything else ([`OutPieces::world`]).
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
    stale_finals: bool,
}

impl<'a> OutPieces<'a> {
    /// The pieces of the caller's `b` (checked by [`BatchEnv::check_buffers`]) for `e` worlds
    /// of `n` wolves and `m` targets.
    pub(super) fn of_buffers(b: &'a mut StepBuffers<'_>, e: usize, n: usize, m: usize) -> Self {
        // SAFETY: MaybeUninit<f32> has f32's layout, and only initialised values are written
        // through these views, so the caller's arrays stay initialised.
        let (obs_w, obs_t) = unsafe { (&mut *(&mut *b.obs_wolves as *mut [f32] as *mut [MaybeUninit<f32>]), &mut *(&mut *b.obs_targets as *mut [f32] as *mut [MaybeUninit<f32>])) };
        Self::new(
            obs_w,
            obs_t,
            &mut *b.rewards_wolves,
            &mut *b.rewards_targets,
            &mut *b.terminated,
            &mut *b.truncated,
            &mut *b.final_obs_wolves,
            &mut *b.final_obs_targets,
            &mut *b.final_state,
            &mut *b.state,
            &mut *b.outcome,
            &mut *b.steps,
            &mut *b.capture_step,
            &mut *b.cornered_step,
            &mut *b.energy,
            &mut *b.collisions,
            &mut *b.distance,
            e,
            n,
            m,
            true,
        )
    }

    /// The pieces of a fresh `o` (from [`BatchEnv::alloc`], observation arrays `lens` long).
    pub(super) fn of_fresh(o: &'a mut StepOutput, lens: ObsLens, e: usize, n: usize, m: usize) -> Self {
        let obs_w = &mut o.obs_wolves.spare_capacity_mut()[..lens.0[0]];
        let obs_t = &mut o.obs_targets.spare_capacity_mut()[..lens.0[1]];
        Self::new(
            obs_w,
            obs_t,
            &mut o.rewards_wolves,
            &mut o.rewards_targets,
            &mut o.terminated,
            &mut o.truncated,
            &mut o.final_obs_wolves,
            &mut o.final_obs_targets,
            &mut o.final_state,
            &mut o.state,
            &mut o.outcome,
            &mut o.steps,
            &mut o.capture_step,
            &mut o.cornered_step,
            &mut o.energy,
            &mut o.collisions,
            &mut o.distance,
            e,
            n,
            m,
            false,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn new(
        obs_w: &'a mut [MaybeUninit<f32>],
        obs_t: &'a mut [MaybeUninit<f32>],
        rew_w: &'a mut [f32],
        rew_t: &'a mut [f32],
        term: &'a mut [bool],
        trunc: &'a mut [bool],
        fin_w: &'a mut [f32],
        fin_t: &'a mut [f32],
        fin_s: &'a mut [f32],
        state: &'a mut [f32],
        outcome: &'a mut [u8],
        steps: &'a mut [u32],
        capture_step: &'a mut [i64],
        cornered_step: &'a mut [i64],
        energy: &'a mut [f64],
        collisions: &'a mut [u32],
        distance: &'a mut [f64],
        e: usize,
        n: usize,
        m: usize,
        stale_finals: bool,
    ) -> Self {
        let per = |v: usize| v.checked_div(e).unwrap_or(0);
        let per = [per(obs_w.len()), per(obs_t.len()), per(rew_w.len()), per(rew_t.len()), per(fin_w.len()), per(fin_t.len()), per(fin_s.len()), per(state.len()), m, n + m];
        Self {
            obs_w: Disjoint::new(obs_w),
            obs_t: Disjoint::new(obs_t),
            rew_w: Disjoint::new(rew_w),
            rew_t: Disjoint::new(rew_t),
            term: Disjoint::new(term),
            trunc: Disjoint::new(trunc),
            fin_w: Disjoint::new(fin_w),
            fin_t: Disjoint::new(fin_t),
            fin_s: Disjoint::new(fin_s),
            state: Disjoint::new(state),
            outcome: Disjoint::new(outcome),
            steps: Disjoint::new(steps),
            capture_step: Disjoint::new(capture_step),
            cornered_step: Disjoint::new(cornered_step),
            energy: Disjoint::new(energy),
            collisions: Disjoint::new(collisions),
            distance: Disjoint::new(distance),
            per,
            stale_finals,
        }
    }

    /// World `i`'s pieces, its observation pieces zeroed here (the observers write only the
    /// entries they fill, and the caller's buffers hold the last step's values).
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
                stale_finals: self.stale_finals,
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
    fn the_specs_and_the_buffers_list_the_outputs_in_one_order() {
        let env = BatchEnv::new(crate::Params::default(), 2, super::super::Learners::Both, 0, true, Some(1)).unwrap();
        let names = StepOutput::default().buffers().lens().map(|(name, _)| name);
        assert_eq!(env.output_specs().map(|s| s.name), names);
        let mut out = env.new_outputs();
        let lens = out.buffers().lens().map(|(_, len)| len);
        assert_eq!(env.output_specs().map(|s| s.len()), lens);
    }

    #[test]
    fn an_outcome_code_is_its_index_in_the_list_of_outcomes() {
        for (k, o) in Outcome::ALL.into_iter().enumerate() {
            assert_eq!(usize::from(outcome_code(o)), k, "{}", o.as_str());
        }
    }
}
