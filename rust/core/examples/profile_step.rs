//! A fixed workload for instruction-count profiles of the hot path (BENCHMARKS.md, "Profile of
//! the hot path"): one thread, no criterion, so callgrind sees only stepping.
//!
//! ```text
//! cargo build --release -p wolfpack-core --example profile_step
//! valgrind --tool=callgrind --callgrind-out-file=cg.out target/release/examples/profile_step hunt 100
//! valgrind --tool=callgrind --callgrind-out-file=cg.out target/release/examples/profile_step batch 4000
//! callgrind_annotate --inclusive=yes cg.out | head -60
//! ```
//!
//! - `hunt N`: the scripted episodes of seeds 0..N of the documented scenario, as
//!   `wolfpack hunt` runs them (spawn included, no recording).
//! - `batch N [E]`: N steps of an E-world (default 64) `BatchEnv` with the wolves learning (zero actions) and
//!   their observations written, autoreset on: the learning interface's work per step.
//!
//! Prints the env-steps done, so the per-step figures can be read off the totals.

use wolfpack_core::batch::{BatchEnv, Learners};
use wolfpack_core::episode::run_episodes;
use wolfpack_core::Params;

fn main() {
    let mut args = std::env::args().skip(1);
    let mode = args.next().unwrap_or_else(|| "hunt".into());
    let n: u64 = args.next().map(|s| s.parse().expect("N: an integer")).unwrap_or(100);
    match mode.as_str() {
        "hunt" => {
            let p = Params::default();
            let steps: u64 = run_episodes(&p, 0, 0, n, None, false, Some(1)).expect("episodes").iter().map(|r| u64::from(r.steps)).sum();
            println!("hunt: {n} episodes, {steps} env-steps");
        }
        "batch" => {
            let e: usize = args.next().map(|s| s.parse().expect("E: an integer")).unwrap_or(64);
            let mut b = BatchEnv::new(Params::default(), e, Learners::Wolves, 0, true, Some(1)).expect("batch");
            let actions = vec![0f32; e * b.n_wolves() * 2];
            for _ in 0..n {
                std::hint::black_box(b.step(&actions, &[]).expect("step"));
            }
            println!("batch: {e} worlds x {n} steps = {} env-steps", e as u64 * n);
        }
        other => panic!("mode must be hunt or batch, got {other:?}"),
    }
}
