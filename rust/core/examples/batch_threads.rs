//! Wall-clock env-steps/s of `BatchEnv::step` (wolves learning, observations, autoreset) for
//! several batch sizes and thread counts, in Rust alone (no Python): separates the core's
//! thread scaling from the binding's overhead (BENCHMARKS.md, "Threads").
//!
//! ```text
//! cargo run --release -p wolfpack-core --example batch_threads -- [SIZES] [THREADS] [SECONDS]
//! ```
//! Defaults: sizes `1,8,64,1024,8192`, threads `1,2`, 1.5 s per measurement.

use std::time::Instant;

use wolfpack_core::batch::{BatchEnv, Learners};
use wolfpack_core::Params;

fn list(arg: Option<String>, default: &str) -> Vec<usize> {
    arg.unwrap_or_else(|| default.into()).split(',').map(|s| s.parse().expect("a comma-separated list of integers")).collect()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let sizes = list(args.next(), "1,8,64,1024,8192");
    let threads = list(args.next(), "1,2");
    let seconds: f64 = args.next().map(|s| s.parse().expect("SECONDS")).unwrap_or(1.5);
    for &e in &sizes {
        let mut row = format!("E={e:<5}");
        for &t in &threads {
            let mut b = BatchEnv::new(Params::default(), e, Learners::Wolves, 0, true, Some(t)).expect("batch");
            let actions = vec![0f32; e * b.n_wolves() * 2];
            for _ in 0..3 {
                b.step(&actions, &[]).expect("step");
            }
            let (start, mut steps) = (Instant::now(), 0u64);
            while start.elapsed().as_secs_f64() < seconds {
                std::hint::black_box(b.step(&actions, &[]).expect("step"));
                steps += 1;
            }
            let rate = (steps * e as u64) as f64 / start.elapsed().as_secs_f64();
            row += &format!("  {t} threads {:>8.0} k/s", rate / 1e3);
        }
        println!("{row}");
    }
}
