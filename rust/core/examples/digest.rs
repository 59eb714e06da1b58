//! Bit-identity oracle for optimisations of the step and the observations: hashes, over many
//! episodes of each wolf law, every agent's and obstacle's state bits after every step (the
//! trajectory digest) and every agent's observation bits at every step (the observation
//! digest), and prints the outcome counts. A change whose digests are unchanged changed no bit
//! of any trajectory or observation; one that changes them must be checked against the oracles
//! (tests/test_alignment.py, tests/test_obs_alignment.py) and the outcome statistics instead
//! (BENCHMARKS.md, "Optimisations").
//!
//! ```text
//! cargo run --release -p wolfpack-core --example digest -- [EPISODES]   # default 200
//! ```
//!
//! Prints one `law  trajectory-digest  observation-digest  runner-digest
//! captured/collision/timeout` row per law. The runner digest hashes the recorded trajectories
//! of the same episodes run by `run_episodes` (the path of `wolfpack hunt`, which has fast
//! paths of its own). The digests are FNV-1a over the little-endian bytes, stable across Rust
//! versions.

use std::sync::Arc;

use wolfpack_core::config::WolfPolicy;
use wolfpack_core::episode::run_episodes;
use wolfpack_core::observe::{target_dim, wolf_dim, Observer};
use wolfpack_core::world::Outcome;
use wolfpack_core::{Params, World};

/// FNV-1a, 64 bit: fixed, simple and independent of std's hasher keys.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= u64::from(x);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn f64(&mut self, x: f64) {
        self.bytes(&x.to_le_bytes());
    }
}

fn main() {
    let episodes: u64 = std::env::args().nth(1).map(|s| s.parse().expect("EPISODES: an integer")).unwrap_or(200);
    for law in [WolfPolicy::Seed000, WolfPolicy::Bvc, WolfPolicy::Formation] {
        let mut p = Params::default();
        p.policies.wolves = law;
        let p = Arc::new(p);
        let (mut traj, mut obs) = (Fnv::new(), Fnv::new());
        let mut observer = Observer::default();
        let (mut ow, mut ot) = (vec![0f32; wolf_dim(&p)], vec![0f32; target_dim(&p)]);
        let mut counts = [0u32; 5];
        for seed in 0..episodes {
            let mut w = World::new(p.clone(), seed).expect("spawn");
            loop {
                observer.prepare(&w);
                for i in 0..w.n_wolves() {
                    observer.wolf(&w, i, &mut ow);
                    ow.iter().for_each(|x| obs.bytes(&x.to_le_bytes()));
                }
                for j in 0..w.n_targets() {
                    observer.target(&w, j, &mut ot);
                    ot.iter().for_each(|x| obs.bytes(&x.to_le_bytes()));
                }
                if w.is_done() {
                    break;
                }
                w.step();
                for a in w.wolves.iter().chain(&w.targets) {
                    for x in [a.pos.x, a.pos.y, a.theta, a.v, a.omega, a.energy] {
                        traj.f64(x);
                    }
                }
                for o in &w.obstacles {
                    for x in [o.center.x, o.center.y, o.angle] {
                        traj.f64(x);
                    }
                }
            }
            let k = match w.outcome {
                Outcome::Captured => 0,
                Outcome::Collision => 1,
                Outcome::Timeout => 2,
                Outcome::Cornered => 3,
                Outcome::Running => 4,
            };
            counts[k] += 1;
            traj.bytes(&w.t.to_le_bytes());
        }
        let mut runner = Fnv::new();
        for r in run_episodes(&p, 0, 0, episodes, None, true, Some(1)).expect("episodes") {
            let t = r.trajectory.expect("recorded");
            for x in t.wolves.iter().chain(&t.targets).chain(&t.energy).chain(&t.obstacles) {
                runner.f64(*x);
            }
            runner.bytes(&t.interaction);
            runner.bytes(&r.steps.to_le_bytes());
        }
        println!("{:<10} {:016x} {:016x} {:016x} captured {} collision {} timeout {}", format!("{law:?}"), traj.0, obs.0, runner.0, counts[0], counts[1], counts[2]);
    }
}
