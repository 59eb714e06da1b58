//! The native batch: determinism over threads and batch splits, same-step autoreset, the
//! expert reproducing the scripted laws, and bad actions.

use std::alloc::{GlobalAlloc, Layout, System};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use wolfpack_core::batch::{BatchEnv, Learners, StepBuffers, StepOutput};
use wolfpack_core::config::{ActionMode, WolfPolicy};
use wolfpack_core::episode::run_episodes;
use wolfpack_core::world::Outcome;
use wolfpack_core::Params;

/// The system allocator, except that memory not asked for zeroed starts as 0xFF bytes (NaN as
/// f32 and f64, -1 as integers): an output the batch allocates uninitialised and then forgets to
/// write reads as NaN in these tests, instead of whatever the reused block happened to hold
/// (often zeros, which would pass).
struct Poisoned;

// SAFETY: every call is forwarded to `System`; `alloc` only writes inside the block it returns.
unsafe impl GlobalAlloc for Poisoned {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            unsafe { std::ptr::write_bytes(p, 0xFF, layout.size()) };
        }
        p
    }

    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        unsafe { System.dealloc(p, layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        unsafe { System.alloc_zeroed(layout) }
    }
}

#[global_allocator]
static POISONED: Poisoned = Poisoned;

fn random_actions(rng: &mut ChaCha8Rng, len: usize) -> Vec<f32> {
    (0..len).map(|_| rng.random_range(-1.2f32..1.2)).collect()
}

/// Everything a step returns, flattened to bits for exact comparison.
fn bits(o: &StepOutput) -> Vec<u64> {
    let mut v: Vec<u64> = Vec::new();
    v.extend(o.obs_wolves.iter().chain(&o.obs_targets).chain(&o.rewards_wolves).chain(&o.rewards_targets).chain(&o.final_obs_wolves).chain(&o.final_obs_targets).map(|x| x.to_bits() as u64));
    v.extend(o.terminated.iter().chain(&o.truncated).map(|&b| b as u64));
    v.extend(o.outcome.iter().map(|&x| x as u64));
    v.extend(o.energy.iter().chain(&o.distance).map(|x| x.to_bits()));
    v
}

fn rollout(params: &Params, e: usize, seed: u64, threads: usize, learners: Learners, steps: usize) -> Vec<Vec<u64>> {
    let mut env = BatchEnv::new(params.clone(), e, learners, seed, true, Some(threads)).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let (n, m) = (env.n_wolves(), env.n_targets());
    let mut out = vec![bits(&env.reset(Some(seed)).unwrap())];
    for _ in 0..steps {
        let wa = if learners.wolves() { random_actions(&mut rng, e * n * 2) } else { vec![] };
        let ta = if learners.targets() { random_actions(&mut rng, e * m * 2) } else { vec![] };
        out.push(bits(&env.step(&wa, &ta).unwrap()));
    }
    out
}

#[test]
fn thread_count_does_not_change_a_single_bit() {
    let p = Params::default();
    for learners in [Learners::Wolves, Learners::Targets, Learners::Both] {
        // 700 steps: every world finishes and autoresets at least twice. 6 worlds step on the
        // caller's thread whatever the thread count (batch::INLINE_BELOW); 37 are shared out in
        // uneven chunks between the caller and 1 or 2 workers.
        assert_eq!(rollout(&p, 6, 3, 1, learners, 700), rollout(&p, 6, 3, 2, learners, 700), "{learners:?}");
        let one = rollout(&p, 37, 3, 1, learners, 700);
        assert_eq!(one, rollout(&p, 37, 3, 2, learners, 700), "{learners:?}, 2 threads");
        assert_eq!(one, rollout(&p, 37, 3, 3, learners, 700), "{learners:?}, 3 threads");
    }
}

#[test]
fn splitting_the_batch_does_not_change_any_world() {
    // Worlds 0..4 of one batch seeded 10 == a batch of 2 seeded 10 and a batch of 2 seeded 12,
    // driven by the scripted laws on both sides (learners none), through several autoresets.
    let p = Params::default();
    let mut whole = BatchEnv::new(p.clone(), 4, Learners::None, 10, true, Some(2)).unwrap();
    let mut a = BatchEnv::new(p.clone(), 2, Learners::None, 10, true, Some(1)).unwrap();
    let mut b = BatchEnv::new(p, 2, Learners::None, 12, true, Some(1)).unwrap();
    for _ in 0..900 {
        let w = whole.step(&[], &[]).unwrap();
        let (x, y) = (a.step(&[], &[]).unwrap(), b.step(&[], &[]).unwrap());
        assert_eq!(w.energy, [x.energy, y.energy].concat());
        assert_eq!(w.outcome, [x.outcome, y.outcome].concat());
    }
    for k in 0..4 {
        let (env, i) = if k < 2 { (&mut a, k) } else { (&mut b, k - 2) };
        assert_eq!(whole.world_seed(k), env.world_seed(i));
        assert_eq!(whole.world(k).unwrap().wolves, env.world(i).unwrap().wolves);
    }
    assert!(whole.world_seed(0).unwrap().1 >= 2, "expected several episodes per world");
}

#[test]
fn autoreset_keeps_the_final_observation_and_starts_a_new_episode() {
    let mut p = Params::default();
    p.world.max_steps = 5;
    let mut env = BatchEnv::new(p, 2, Learners::Wolves, 0, true, Some(1)).unwrap();
    let first = env.reset(Some(0)).unwrap();
    let acts = vec![0.0f32; 2 * 5 * 2];
    let mut last = first.clone();
    for t in 1..=5 {
        let o = env.step(&acts, &[]).unwrap();
        if t < 5 {
            assert!(o.truncated.iter().all(|x| !x));
            last = o;
            continue;
        }
        assert_eq!(o.truncated, vec![true, true]);
        assert_eq!(o.terminated, vec![false, false]);
        assert_eq!(o.outcome, vec![3, 3]);
        assert_eq!(o.steps, vec![5, 5]);
        // The new episode's clock is 0; the final observation's clock is 5/5.
        let dw = env.wolf_obs_dim();
        assert_eq!(o.obs_wolves[8], 0.0);
        assert_eq!(o.final_obs_wolves[8], 1.0);
        // The final observation continues the previous one (clock 4/5 → 5/5) ...
        assert!((last.obs_wolves[8] - 0.8).abs() < 1e-6);
        // ... and the new episode is episode 1 of world 0's seed, not a copy of episode 0.
        assert_eq!(env.world_seed(0), Some((0, 1)));
        assert_ne!(&o.obs_wolves[..dw], &first.obs_wolves[..dw]);
    }
}

#[test]
fn final_observations_are_zero_where_no_episode_ended_and_filled_where_one_did() {
    // Each world's task writes its final-observation rows every step (zeros where its episode
    // went on): a caller's buffers hold the last step's rows, which must not show through.
    let mut p = Params::default();
    p.world.max_steps = 3;
    let mut env = BatchEnv::new(p, 3, Learners::Both, 0, true, Some(2)).unwrap();
    env.reset(Some(0)).unwrap();
    let (dw, dt) = (env.wolf_obs_dim(), env.target_obs_dim());
    let (wa, ta) = ([0.3f32; 3 * 5 * 2], [0.3f32; 3 * 2]);
    for t in 1..=3 {
        let o = env.step(&wa, &ta).unwrap();
        assert_eq!((o.final_obs_wolves.len(), o.final_obs_targets.len()), (3 * 5 * dw, 3 * dt));
        let ended: Vec<bool> = o.terminated.iter().zip(&o.truncated).map(|(a, b)| *a || *b).collect();
        for (w, &ended) in ended.iter().enumerate() {
            let (fw, ft) = (&o.final_obs_wolves[w * 5 * dw..(w + 1) * 5 * dw], &o.final_obs_targets[w * dt..(w + 1) * dt]);
            if ended {
                assert!(fw.iter().any(|x| *x != 0.0) && ft.iter().any(|x| *x != 0.0), "step {t}, world {w}: ended, its final observations are empty");
            } else {
                assert!(fw.iter().chain(ft).all(|x| *x == 0.0), "step {t}, world {w}: not ended, final observations not zero");
            }
        }
        if t == 3 {
            assert!(ended.iter().all(|e| *e), "max_steps = 3 ends every episode at step 3");
        }
    }
}

/// `b` filled with what a forgotten write would show: NaN, true, all ones.
fn poison(b: &mut StepBuffers) {
    for v in [&mut *b.obs_wolves, &mut *b.obs_targets, &mut *b.rewards_wolves, &mut *b.rewards_targets, &mut *b.final_obs_wolves, &mut *b.final_obs_targets, &mut *b.state, &mut *b.final_state] {
        v.fill(f32::NAN);
    }
    b.terminated.fill(true);
    b.truncated.fill(true);
    b.outcome.fill(u8::MAX);
    b.steps.fill(u32::MAX);
    b.collisions.fill(u32::MAX);
    b.capture_step.fill(i64::MAX);
    b.cornered_step.fill(i64::MAX);
    b.energy.fill(f64::NAN);
    b.distance.fill(f64::NAN);
}

#[test]
fn every_output_written_into_the_callers_buffers_is_the_fresh_steps() {
    // Poisoned buffers before every reset and step: an element some path forgets to write (a
    // finished world's rewards without autoreset, a world's final rows on a step it went on)
    // shows as NaN or all ones instead of the fresh step's value.
    let mut p = Params::default();
    p.world.max_steps = 6;
    for (learners, autoreset) in [(Learners::Wolves, true), (Learners::Targets, false), (Learners::Both, true), (Learners::None, false)] {
        let mut fresh = BatchEnv::new(p.clone(), 5, learners, 2, autoreset, Some(2)).unwrap();
        let mut into = BatchEnv::new(p.clone(), 5, learners, 2, autoreset, Some(2)).unwrap();
        into.set_with_state(true);
        fresh.set_with_state(true);
        let mut owned = into.reset(Some(2)).unwrap();
        let want = fresh.reset(Some(2)).unwrap();
        let mut buffers = owned.buffers();
        poison(&mut buffers);
        into.reset_into(Some(2), &std::sync::atomic::AtomicBool::new(false), &mut buffers).unwrap();
        fresh.reset(Some(2)).unwrap();
        assert_eq!(bits(&owned), bits(&want), "{learners:?}: reset");
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (n, m) = (fresh.n_wolves(), fresh.n_targets());
        for t in 0..14 {
            let wa = if learners.wolves() { random_actions(&mut rng, 5 * n * 2) } else { vec![] };
            let ta = if learners.targets() { random_actions(&mut rng, 5 * m * 2) } else { vec![] };
            let mut buffers = owned.buffers();
            poison(&mut buffers);
            into.step_into(&wa, &ta, &mut buffers).unwrap();
            let want = fresh.step(&wa, &ta).unwrap();
            let whole = |o: &StepOutput| {
                (bits(o), o.state.iter().chain(&o.final_state).map(|x| x.to_bits()).collect::<Vec<_>>(), o.steps.clone(), o.collisions.clone(), o.capture_step.clone(), o.cornered_step.clone())
            };
            assert_eq!(whole(&owned), whole(&want), "{learners:?}, step {t}");
        }
    }
}

#[test]
fn buffers_of_the_wrong_size_are_named_and_move_nothing() {
    let mut env = BatchEnv::new(Params::default(), 3, Learners::Wolves, 0, true, Some(1)).unwrap();
    let mut out = env.step(&[0.0; 30], &[]).unwrap();
    out.energy.pop();
    let e = env.step_into(&[0.0; 30], &[], &mut out.buffers()).unwrap_err().to_string();
    assert!(e.contains("energy") && e.contains("expected 18"), "{e}");
    assert_eq!(env.world(0).unwrap().t, 1);
    let specs = env.output_specs();
    assert_eq!(specs.iter().map(|s| s.name).collect::<Vec<_>>()[..3], ["obs_wolves", "obs_targets", "rewards_wolves"]);
    assert!(specs.iter().find(|s| s.name == "obs_targets").unwrap().is_empty(), "targets are scripted here");
}

#[test]
fn the_state_is_written_in_the_step_and_the_final_state_is_the_one_a_world_ended_in() {
    // A twin batch without autoreset keeps each world as its episode ended: its state() row is
    // what the autoreset batch must hand out as that world's final state, on the step it ended
    // (scripted laws on both sides, so both batches play the same episodes).
    let p = Params::default();
    let e = 6;
    let mut auto = BatchEnv::new(p.clone(), e, Learners::None, 3, true, Some(2)).unwrap();
    let mut kept = BatchEnv::new(p, e, Learners::None, 3, false, Some(1)).unwrap();
    let off = auto.step(&[], &[]).unwrap();
    assert!(off.final_state.is_empty() && off.state.is_empty(), "off by default");
    auto.set_with_state(true);
    kept.step(&[], &[]).unwrap();
    let d = auto.state_dim();
    let mut seen = vec![false; e];
    for t in 2..=1000 {
        let twin_ended: Vec<bool> = kept.step(&[], &[]).map(|o| o.outcome.iter().map(|&c| c != 0).collect()).unwrap();
        let o = auto.step(&[], &[]).unwrap();
        assert_eq!(o.final_state.len(), e * d);
        // The state written in the step is the state() of the worlds after it.
        assert!(o.state.iter().zip(&auto.state().unwrap()).all(|(a, b)| a.to_bits() == b.to_bits()), "step {t}: state differs from state()");
        let want = kept.state().unwrap();
        for w in 0..e {
            let ended = o.terminated[w] || o.truncated[w];
            let row = &o.final_state[w * d..(w + 1) * d];
            if ended && !seen[w] {
                assert!(twin_ended[w], "step {t}, world {w}: the twin's episode ended too");
                assert!(row.iter().zip(&want[w * d..(w + 1) * d]).all(|(a, b)| a.to_bits() == b.to_bits()), "step {t}, world {w}: final state differs from the ended world's state");
                seen[w] = true;
            } else if !ended {
                assert!(row.iter().all(|x| *x == 0.0), "step {t}, world {w}: no episode ended, final state not zero");
            }
        }
        if seen.iter().all(|s| *s) {
            return;
        }
    }
    panic!("some world never ended its first episode in 1,000 steps: {seen:?}");
}

#[test]
fn invalid_actions_are_named_and_move_nothing() {
    let mut env = BatchEnv::new(Params::default(), 3, Learners::Wolves, 0, true, Some(1)).unwrap();
    let before = env.world(1).unwrap().wolves.clone();
    let mut acts = vec![0.0f32; 3 * 5 * 2];
    acts[(5 + 2) * 2 + 1] = f32::NAN;
    let e = env.step(&acts, &[]).unwrap_err().to_string();
    assert!(e.contains("wolf_2") && e.contains("world 1"), "{e}");
    assert_eq!(env.world(1).unwrap().wolves, before);
    assert_eq!(env.world(0).unwrap().t, 0);
    let e = env.step(&acts[..4], &[]).unwrap_err().to_string();
    assert!(e.contains("expected 30"), "{e}");
    let e = env.step(&[0.0; 30], &[0.0, 0.0]).unwrap_err().to_string();
    assert!(e.contains("scripted"), "{e}");
}

/// Learners driven by `expert_actions` against the same seeds as the scripted run.
fn expert_capture_rate(mode: ActionMode, learners: Learners, episodes: usize) -> (usize, usize) {
    let mut p = Params::default();
    p.env.action_mode = mode;
    let mut env = BatchEnv::new(p.clone(), episodes, learners, 0, false, Some(2)).unwrap();
    env.reset(Some(0)).unwrap();
    for _ in 0..p.world.max_steps {
        let (wa, ta) = env.expert_actions();
        env.step(&wa, &ta).unwrap();
    }
    let expert = (0..episodes).filter(|&e| env.world(e).unwrap().outcome == Outcome::Captured).count();
    let scripted = run_episodes(&p, 0, 0, episodes as u64, None, false, Some(2)).unwrap().iter().filter(|r| r.outcome == Outcome::Captured).count();
    (expert, scripted)
}

#[test]
fn following_the_expert_reproduces_the_scripted_laws() {
    for (mode, learners) in [(ActionMode::Unicycle, Learners::Wolves), (ActionMode::Unicycle, Learners::Targets), (ActionMode::Velocity, Learners::Wolves), (ActionMode::Velocity, Learners::Both)] {
        let (expert, scripted) = expert_capture_rate(mode, learners, 100);
        assert!(expert.abs_diff(scripted) <= 3, "{mode:?} {learners:?}: expert {expert} vs scripted {scripted} of 100");
    }
}

#[test]
fn expert_in_unicycle_mode_tracks_the_scripted_trajectory_closely() {
    // Same seed, wolves learning from the expert vs all scripted: the first 50 steps agree to
    // f32 rounding of the actions (positions within 1e-3 m).
    let p = Params::default();
    let mut env = BatchEnv::new(p.clone(), 1, Learners::Wolves, 7, false, Some(1)).unwrap();
    let mut scripted = BatchEnv::new(p, 1, Learners::None, 7, false, Some(1)).unwrap();
    for t in 0..50 {
        let (wa, _) = env.expert_actions();
        env.step(&wa, &[]).unwrap();
        scripted.step(&[], &[]).unwrap();
        let (a, b) = (env.world(0).unwrap(), scripted.world(0).unwrap());
        for (x, y) in a.wolves.iter().zip(&b.wolves) {
            assert!((x.pos - y.pos).norm() < 1e-3, "step {t}: {:?} vs {:?}", x.pos, y.pos);
        }
        if b.is_done() {
            break;
        }
    }
}

/// 60 steps of a 24-world batch on rayon's global pool (threads = None), both sides scripted:
/// every step's energies.
fn global_pool_energies(seed: u64) -> Vec<Vec<f64>> {
    let mut env = BatchEnv::new(Params::default(), 24, Learners::None, seed, true, None).unwrap();
    (0..60).map(|_| env.step(&[], &[]).unwrap().energy).collect()
}

/// Batches stepped from inside rayon's global pool (their workers are that same pool) finish
/// and give the results of stepping them one by one.
#[test]
fn batches_stepped_inside_the_global_pool_do_not_wait_for_themselves() {
    use rayon::prelude::*;
    let (tx, rx) = std::sync::mpsc::channel();
    let inside = std::thread::spawn(move || {
        let out: Vec<_> = (0..4u64).into_par_iter().map(|s| global_pool_energies(100 * s)).collect();
        tx.send(out).unwrap();
    });
    // A worker spinning for a job queued on itself never returns: fail instead of hanging.
    let got = rx.recv_timeout(std::time::Duration::from_secs(120)).expect("batches stepped inside the global pool did not finish in 120 s");
    inside.join().unwrap();
    let outside: Vec<_> = (0..4u64).map(|s| global_pool_energies(100 * s)).collect();
    assert_eq!(got, outside);
}

/// Steps `env` `steps` times with the same random actions for its learning sides (`rng`
/// seeded 7), collecting every output's bits.
fn drive(env: &mut BatchEnv, steps: usize) -> Vec<Vec<u64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (e, n, m, l) = (env.num_envs(), env.n_wolves(), env.n_targets(), env.learners());
    (0..steps)
        .map(|_| {
            let wa = if l.wolves() { random_actions(&mut rng, e * n * 2) } else { vec![] };
            let ta = if l.targets() { random_actions(&mut rng, e * m * 2) } else { vec![] };
            bits(&env.step(&wa, &ta).unwrap())
        })
        .collect()
}

#[test]
fn each_side_reads_its_actions_in_its_own_mode() {
    // Wolves in velocity mode while env.action_mode stays unicycle == everything in velocity
    // mode, when only the wolves act (and the same for the targets); unicycle differs.
    let with = |mode: ActionMode, wolf: Option<ActionMode>, target: Option<ActionMode>| {
        let mut p = Params::default();
        p.env.action_mode = mode;
        p.env.wolf_action_mode = wolf;
        p.env.target_action_mode = target;
        p
    };
    let run = |p: Params, l: Learners| drive(&mut BatchEnv::new(p, 5, l, 4, true, Some(1)).unwrap(), 120);
    let (v, u) = (ActionMode::Velocity, ActionMode::Unicycle);
    assert_eq!(run(with(u, Some(v), None), Learners::Wolves), run(with(v, None, None), Learners::Wolves));
    assert_eq!(run(with(u, None, Some(v)), Learners::Targets), run(with(v, None, None), Learners::Targets));
    assert_eq!(run(with(v, Some(u), None), Learners::Wolves), run(with(u, None, None), Learners::Wolves));
    assert_ne!(run(with(u, Some(v), None), Learners::Wolves), run(with(u, None, None), Learners::Wolves));
    // Both sides at once, each in its own mode: the target's mode is the one that matters for it.
    assert_eq!(run(with(u, Some(v), Some(u)), Learners::Both), run(with(v, None, Some(u)), Learners::Both));
    assert_ne!(run(with(u, Some(v), Some(u)), Learners::Both), run(with(u, Some(v), Some(v)), Learners::Both));
}

#[test]
fn set_drivers_before_the_first_step_is_building_the_batch_that_way() {
    let mut bvc = Params::default();
    bvc.policies.wolves = WolfPolicy::Bvc;
    let mut swapped = BatchEnv::new(Params::default(), 9, Learners::Targets, 21, true, Some(2)).unwrap();
    swapped.set_drivers(Learners::Targets, bvc.clone()).unwrap();
    let mut built = BatchEnv::new(bvc.clone(), 9, Learners::Targets, 21, true, Some(2)).unwrap();
    assert_eq!(drive(&mut swapped, 400), drive(&mut built, 400), "a scripted law swapped in");
    // A scripted side handed to given actions, and the action mode changed with it.
    let mut vel = bvc.clone();
    vel.env.wolf_action_mode = Some(ActionMode::Velocity);
    let mut swapped = BatchEnv::new(bvc, 9, Learners::Targets, 21, true, Some(2)).unwrap();
    swapped.set_drivers(Learners::Both, vel.clone()).unwrap();
    let mut built = BatchEnv::new(vel, 9, Learners::Both, 21, true, Some(2)).unwrap();
    assert_eq!(drive(&mut swapped, 400), drive(&mut built, 400), "wolves given to a learner");
}

#[test]
fn set_drivers_keeps_the_worlds_mid_episode() {
    // The same drivers again change nothing; a new law takes over from the current state
    // (the first 50 steps are those of the old law, the next differ); other params are refused.
    let p = Params::default();
    let mut plain = BatchEnv::new(p.clone(), 6, Learners::None, 5, true, Some(1)).unwrap();
    let mut again = BatchEnv::new(p.clone(), 6, Learners::None, 5, true, Some(1)).unwrap();
    let mut swapped = BatchEnv::new(p.clone(), 6, Learners::None, 5, true, Some(1)).unwrap();
    let (a, b, c) = (drive(&mut plain, 50), drive(&mut again, 50), drive(&mut swapped, 50));
    assert!(a == b && b == c);
    again.set_drivers(Learners::None, p.clone()).unwrap();
    let mut formation = p.clone();
    formation.policies.wolves = WolfPolicy::Formation;
    swapped.set_drivers(Learners::None, formation).unwrap();
    let rest = drive(&mut plain, 60);
    assert_eq!(rest, drive(&mut again, 60), "the same drivers again");
    assert_ne!(rest, drive(&mut swapped, 60), "formation took over");
    assert_eq!(swapped.world(0).unwrap().params.policies.wolves, WolfPolicy::Formation);
    let mut bigger = p.clone();
    bigger.world.max_steps += 1;
    let e = again.set_drivers(Learners::None, bigger).unwrap_err().to_string();
    assert!(e.contains("policies") && e.contains("action_mode"), "{e}");
    assert_eq!(again.params(), &p, "a refused change changes nothing");
}

/// Every autoreset episode of a batch world is episode k of its seed, as a world built afresh
/// plays it: the batch respawns its worlds in place (in their own allocations), and nothing of
/// the old episode may leak into the new one.
#[test]
fn autoreset_episodes_are_the_episodes_of_fresh_worlds() {
    use wolfpack_core::World;
    let p = Params::default();
    for seed in [3u64, 40] {
        let mut env = BatchEnv::new(p.clone(), 1, Learners::None, seed, true, Some(1)).unwrap();
        let mut episodes = Vec::new();
        while episodes.len() < 4 {
            let o = env.step(&[], &[]).unwrap();
            if o.terminated[0] || o.truncated[0] {
                episodes.push((o.outcome[0], o.steps[0], o.energy.clone()));
            }
        }
        for (k, (outcome, steps, energy)) in episodes.into_iter().enumerate() {
            let mut w = World::new_episode(std::sync::Arc::new(p.clone()), seed, k as u64).unwrap();
            while w.step() == Outcome::Running {}
            let want_energy: Vec<f64> = w.wolves.iter().chain(&w.targets).map(|a| a.energy).collect();
            assert_eq!((outcome, steps), (wolfpack_core::batch::outcome_code(w.outcome), w.t), "seed {seed}, episode {k}");
            assert_eq!(energy.iter().map(|e| e.to_bits()).collect::<Vec<_>>(), want_energy.iter().map(|e| e.to_bits()).collect::<Vec<_>>(), "seed {seed}, episode {k}");
        }
    }
}
