//! The ceiling for one batch of E worlds on two threads: two separate batches of E/2 worlds,
//! one per thread, stepped in lockstep (the second thread spins until the first starts a
//! step; the first spins until both are done). Nothing is shared but the two counters, no world
//! ever changes threads, and each half allocates its own outputs, so this is what the shared
//! batch's scheduling (crew, home runs, stealing) could at best reach (BENCHMARKS.md,
//! "Optimisations").
//!
//! ```text
//! cargo build --release -p wolfpack-core --example lockstep_halves
//! target/release/examples/lockstep_halves 64
//! ```

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

use wolfpack_core::batch::{BatchEnv, Learners};
use wolfpack_core::Params;

fn main() {
    let e: usize = std::env::args().nth(1).map(|s| s.parse().expect("E: an even integer")).unwrap_or(64);
    let seconds = 1.5;
    let half = e / 2;
    // `started`: steps the first thread has started; `finished`: steps the second has done.
    let (started, finished, stop) = (Arc::new(AtomicUsize::new(0)), Arc::new(AtomicUsize::new(0)), Arc::new(AtomicBool::new(false)));
    let second = {
        let (started, finished, stop) = (started.clone(), finished.clone(), stop.clone());
        std::thread::spawn(move || {
            let mut b = BatchEnv::new(Params::default(), half, Learners::Wolves, 1_000_000, true, Some(1)).expect("batch");
            let actions = vec![0f32; half * b.n_wolves() * 2];
            let mut seen = 0;
            loop {
                while started.load(Ordering::Acquire) == seen {
                    if stop.load(Ordering::Relaxed) {
                        return;
                    }
                    std::hint::spin_loop();
                }
                seen += 1;
                std::hint::black_box(b.step(&actions, &[]).expect("step"));
                finished.fetch_add(1, Ordering::Release);
            }
        })
    };
    let mut b = BatchEnv::new(Params::default(), half, Learners::Wolves, 0, true, Some(1)).expect("batch");
    let actions = vec![0f32; half * b.n_wolves() * 2];
    let (start, mut steps) = (Instant::now(), 0usize);
    while start.elapsed().as_secs_f64() < seconds {
        started.fetch_add(1, Ordering::Release);
        std::hint::black_box(b.step(&actions, &[]).expect("step"));
        steps += 1;
        while finished.load(Ordering::Acquire) < steps {
            std::hint::spin_loop();
        }
    }
    stop.store(true, Ordering::Relaxed);
    second.join().expect("second thread");
    println!("E={e}: two lockstep halves of {half} worlds, {:.0} k env-steps/s", (steps * e) as f64 / start.elapsed().as_secs_f64() / 1e3);
}
