//! `threads: None`: every core unless `RAYON_NUM_THREADS` says otherwise, and a batch built with
//! it starts its own crew and nothing else — in particular not rayon's global pool, whose threads
//! it would never use. One test in its own binary, so that no other test's thread comes or goes
//! while the process's threads are counted.

use wolfpack_core::batch::{BatchEnv, Learners};
use wolfpack_core::episode::{default_threads, MAX_THREADS};
use wolfpack_core::Params;

#[test]
fn the_default_thread_count_and_a_default_batch_starts_only_its_crew() {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let from_env = std::env::var("RAYON_NUM_THREADS").ok().and_then(|v| v.parse::<usize>().ok()).filter(|&n| n > 0);
    let t = default_threads();
    assert_eq!(t, from_env.unwrap_or(cores).min(MAX_THREADS));

    #[cfg(target_os = "linux")]
    {
        let threads_of_this_process = || std::fs::read_dir("/proc/self/task").expect("/proc/self/task").count();
        let before = threads_of_this_process();
        // Enough worlds that every thread gets some (small batches step on the caller alone).
        let mut b = BatchEnv::new(Params::default(), 64 * t, Learners::Wolves, 0, true, None).expect("batch");
        let actions = vec![0f32; b.num_envs() * b.n_wolves() * 2];
        for _ in 0..3 {
            b.step(&actions, &[]).expect("step");
        }
        // The caller steps too: a crew of t − 1.
        assert_eq!(threads_of_this_process() - before, t - 1, "threads started by a batch of {t} threads");
    }
}
