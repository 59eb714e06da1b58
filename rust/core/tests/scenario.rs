//! The documented scenario end to end (acceptance criterion of the analytic laws): seed000
//! wolves vs. the escape target, `Params::default()`, seed 0, 200 episodes.
//!
//! Run in release: `cargo test --release -p wolfpack-core --test scenario -- --nocapture`.
//! Reference implementation: 96% captured, 4% wolf collisions, median capture at step 166 (≈ 97%
//! captured in its published figures). The acceptance bar is ≥ 97% captured, ≤ 1% collisions,
//! median ≤ 170. Measured here (defaults: the target's wall κ 1.6 / 1.3 as the reference,
//! docs/world-and-laws.md §4.2): 98.0% / 0.0% / 160 on these 200 episodes, 98.1% / 0.1% / 160 on
//! 1000. With the source document's κ 1.2 for the target's walls: 94.0% / 0.0% / 179 and
//! 95.4% / 0.2% / 186 (docs/scenario.md).
//!
//! The `#[ignore]`d tests are diagnostics (run with `-- --ignored --nocapture`): `sweep` (a
//! larger sample, `N` episodes), `failures` (what ended each failed episode), `trace` (which
//! rule of §4.4 decided each wolf's heading, `SEED`, `FROM`, `TO`).

use wolfpack_core::episode::run_episodes;
use wolfpack_core::world::Outcome;
use wolfpack_core::Params;

fn median(mut steps: Vec<u32>) -> f64 {
    steps.sort_unstable();
    if steps.is_empty() {
        f64::NAN
    } else if steps.len() % 2 == 1 {
        steps[steps.len() / 2] as f64
    } else {
        0.5 * (steps[steps.len() / 2 - 1] + steps[steps.len() / 2]) as f64
    }
}

#[test]
fn documented_scenario_captures_reliably() {
    let n = 200;
    let res = run_episodes(&Params::default(), 0, 0, n, None, false, None).unwrap();
    let count = |o: Outcome| res.iter().filter(|r| r.outcome == o).count();
    let (captured, collided, timeout) = (count(Outcome::Captured), count(Outcome::Collision), count(Outcome::Timeout));
    let median = median(res.iter().filter_map(|r| r.capture_step).collect());
    let rate = |k: usize| k as f64 / n as f64;
    println!("episodes {n}: captured {:.1}%, collision {:.1}%, timeout {:.1}%, median capture step {median}", 100.0 * rate(captured), 100.0 * rate(collided), 100.0 * rate(timeout));
    let failed: Vec<(u64, &str)> = res.iter().filter(|r| r.outcome != Outcome::Captured).map(|r| (r.seed, r.outcome.as_str())).collect();
    println!("not captured: {failed:?}");
    assert!(rate(captured) >= 0.97, "capture rate {:.3} < 0.97", rate(captured));
    assert!(rate(collided) <= 0.01, "collision rate {:.3} > 0.01", rate(collided));
    assert!(median <= 170.0, "median capture step {median} > 170");
    assert_eq!(count(Outcome::Cornered), 0, "capture.cornered is off by default");
}

/// docs/world-and-laws.md §1.7: with `capture.cornered` a cornered target is a success of its own,
/// so bvc's success rate (captured + cornered) is at least its capture rate without it, on the same
/// episodes; without it, cornering is only counted.
#[test]
fn cornered_targets_count_as_successes_only_when_asked() {
    let n = 200;
    let mut p = Params::default();
    p.policies.wolves = wolfpack_core::config::WolfPolicy::Bvc;
    let plain = run_episodes(&p, 0, 0, n, None, false, None).unwrap();
    p.capture.cornered = true;
    let with = run_episodes(&p, 0, 0, n, None, false, None).unwrap();
    let count = |r: &[wolfpack_core::episode::EpisodeResult], o: Outcome| r.iter().filter(|x| x.outcome == o).count();
    let ever = |r: &[wolfpack_core::episode::EpisodeResult]| r.iter().filter(|x| x.cornered_step.is_some()).count();
    println!(
        "bvc: captured {} (ever cornered {}); with capture.cornered: captured {} + cornered {} (ever cornered {})",
        count(&plain, Outcome::Captured),
        ever(&plain),
        count(&with, Outcome::Captured),
        count(&with, Outcome::Cornered),
        ever(&with)
    );
    assert_eq!(count(&plain, Outcome::Cornered), 0);
    assert!(ever(&plain) > 0, "no bvc episode ever cornered its target");
    assert!(count(&with, Outcome::Cornered) > 0);
    assert!(count(&with, Outcome::Captured) + count(&with, Outcome::Cornered) >= count(&plain, Outcome::Captured));
    // An episode that ended cornered was cornered at its last step, and first cornered then.
    for r in with.iter().filter(|x| x.outcome == Outcome::Cornered) {
        assert_eq!(r.cornered_step, Some(r.steps), "seed {}", r.seed);
    }
}

/// Larger sample: `N=1000 cargo test --release -p wolfpack-core --test scenario sweep -- --ignored --nocapture`.
#[test]
#[ignore]
fn sweep() {
    let n: u64 = std::env::var("N").ok().map(|s| s.parse().unwrap()).unwrap_or(1000);
    let res = run_episodes(&Params::default(), 0, 0, n, None, false, None).unwrap();
    let count = |o: Outcome| res.iter().filter(|r| r.outcome == o).count() as f64 / n as f64 * 100.0;
    let mut steps: Vec<u32> = res.iter().filter_map(|r| r.capture_step).collect();
    steps.sort_unstable();
    println!("SWEEP {n}: captured {:.1}% collision {:.1}% timeout {:.1}% median {}", count(Outcome::Captured), count(Outcome::Collision), count(Outcome::Timeout), steps[steps.len() / 2]);
}

/// What the failures are: `N=200 cargo test --release -p wolfpack-core --test scenario failures -- --ignored --nocapture`.
#[test]
#[ignore]
fn failures() {
    use std::sync::Arc;
    use wolfpack_core::geometry::{body_triangle, triangles_overlap};
    use wolfpack_core::World;
    let n: u64 = std::env::var("N").ok().map(|s| s.parse().unwrap()).unwrap_or(200);
    let p = Arc::new(Params::default());
    let mut lost_hist = [0usize; 6];
    let mut close_hist = [0usize; 6];
    for seed in 0..n {
        let mut w = World::new(p.clone(), seed).unwrap();
        let mut prev = w.clone();
        while !w.is_done() {
            prev = w.clone();
            w.step();
        }
        let tp = w.targets[0].pos;
        match w.outcome {
            Outcome::Collision => {
                let b = &p.agents.body;
                for i in 0..w.wolves.len() {
                    let a = w.wolves[i];
                    let body = body_triangle(a.pos, a.theta, b.base, b.height);
                    for o in &w.obstacles {
                        if o.overlaps_triangle(&body) {
                            let po = prev.wolves[i];
                            println!("seed {seed} t{}: wolf {i} hit {:?} (dist before {:.3}, v {:.2}, d_target {:.2})", w.t, o.kind, o.distance(po.pos), a.v, (a.pos - tp).norm());
                        }
                    }
                    for j in 0..w.wolves.len() {
                        let c = w.wolves[j];
                        if j > i && triangles_overlap(&body, &body_triangle(c.pos, c.theta, b.base, b.height)) {
                            println!("seed {seed} t{}: wolves {i} and {j} collide (v {:.2} {:.2}, d_target {:.2} {:.2})", w.t, a.v, c.v, (a.pos - tp).norm(), (c.pos - tp).norm());
                        }
                    }
                }
            }
            Outcome::Timeout => {
                let lost = w.wolves.iter().filter(|a| (a.pos - tp).norm() > 3.0).count();
                let close = w.wolves.iter().filter(|a| (a.pos - tp).norm() <= 0.8).count();
                lost_hist[lost] += 1;
                close_hist[close] += 1;
                let wall = (10.0 - tp.x.abs()).min(10.0 - tp.y.abs());
                println!("seed {seed} timeout: lost {lost}, within 0.8: {close}, target wall distance {wall:.2}, seen at {:?}", w.target_seen_at[0]);
            }
            _ => {}
        }
    }
    println!("timeouts by lost wolves {lost_hist:?}, by wolves within 0.8 {close_hist:?}");
}

/// Per-step decisions of every wolf (which rule of §4.4 decided), for one seed:
/// `SEED=1 FROM=80 TO=110 cargo test --release -p wolfpack-core --test scenario trace -- --ignored --nocapture`.
#[test]
#[ignore]
fn trace() {
    use std::sync::Arc;
    use wolfpack_core::math::angle_of;
    use wolfpack_core::policies::{avoidance, seed000, Snapshot, WolfMemory};
    use wolfpack_core::World;
    let env = |k: &str, d: u64| std::env::var(k).ok().map(|s| s.parse().unwrap()).unwrap_or(d);
    let (seed, from, to) = (env("SEED", 1), env("FROM", 0) as u32, env("TO", 300) as u32);
    let mut w = World::new(Arc::new(Params::default()), seed).unwrap();
    while !w.is_done() {
        let (wolves, targets, mems) = (w.wolves.clone(), w.targets.clone(), w.wolf_memory.clone());
        let t = w.t;
        w.step();
        if t < from || t > to {
            continue;
        }
        let snap = Snapshot {
            params: &w.params,
            t,
            wolves: &wolves,
            targets: &targets,
            obstacles: &w.obstacles,
            near: None,
            wolf_target: &w.wolf_target,
            wolf_senses: &w.wolf_senses,
            target_seen_at: &w.target_seen_at,
            target_captured: &w.target_captured,
        };
        let mut line = format!("t{t:3} T({:.2},{:.2})", targets[0].pos.x, targets[0].pos.y);
        for i in 0..wolves.len() {
            let mut row = vec![0u8; wolves.len() + 1];
            let WolfMemory::Seed000(mut mem) = mems[i] else { unreachable!("the default scenario's wolves run seed000") };
            let nu1 = seed000::attraction(i, &snap, mem.last_attraction, &mut row);
            let nu2 = seed000::repulsion(i, &snap, nu1, &mut row);
            let s = &snap.params.seed000;
            let nu = s.alpha * nu1 + s.beta * nu2;
            let (v, th, mode) = avoidance::wolf_mode(i, &snap, nu.norm(), angle_of(nu), &mut mem.danger, &mut row);
            let d = (wolves[i].pos - targets[0].pos).norm();
            line += &format!(" | w{i} d{d:.2} h{:.2} nu{:.2}/{:.2} -> {v:.2}/{th:.2} {mode:?} => v{:.2}", wolves[i].theta, nu.norm(), angle_of(nu), w.wolves[i].v);
        }
        println!("{line}");
    }
    println!("{:?} at {}", w.outcome, w.t);
}
