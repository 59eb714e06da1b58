//! Memory soak: resident set size (VmRSS from /proc/self/status) over many scripted episodes of
//! the documented scenario, for each wolf law. A law whose memory is bounded stays flat after
//! warm-up; one that leaks grows with the episode count.
//!
//! ```text
//! cargo run --release -p wolfpack-core --example soak_rss -- [EPISODES] [EVERY] [MODE] [LAWS]
//! ```
//!
//! - EPISODES (default 43000): episodes per law; EVERY (default 2000): RSS is printed every so
//!   many episodes.
//! - MODE: `once` runs all EPISODES in one `run_episodes` call (what `wolfpack hunt` does
//!   without a terminal) and prints RSS and peak once, with the results held and dropped;
//!   `episodes` (default) runs `episode::run_episodes` in chunks of EVERY on the global
//!   rayon pool (the CLI's path) and keeps only each chunk's results; `batch` steps a
//!   `BatchEnv` of 64 worlds with autoreset (no learners: both sides scripted) until EPISODES
//!   episodes have finished; `single` runs `run_episode` one after the other on this thread.
//! - LAWS: comma-separated (default `seed000,bvc,formation`). Run one law per process to see
//!   each from a clean heap: `... -- 43000 2000 episodes formation`.
//!
//! Linux only (reads /proc). Prints `law mode episodes rss_mb` rows. A benchmark, not a test.
//!
//! Measured (2 cores, `-- 43000 4300 episodes`): seed000, bvc and formation all stay flat at
//! 6.5–6.6 MB over 43,000 episodes; `batch` (64 worlds, autoreset) and `single` stay flat too.
//! The core keeps nothing across episodes but the per-thread `LastCall` memos of bvc and
//! formation, one key and one answer each. The growth `wolfpack hunt` showed over 43,000
//! episodes (≈ 47 → 107 MB, the same for every law) was the CLI holding every result dict;
//! see BENCHMARKS.md, "Memory over long runs".

use std::sync::Arc;
use std::time::Instant;

use wolfpack_core::batch::{BatchEnv, Learners};
use wolfpack_core::config::WolfPolicy;
use wolfpack_core::episode::{run_episode, run_episodes};
use wolfpack_core::Params;

fn rss_mb() -> f64 {
    status_mb("VmRSS:")
}

fn hwm_mb() -> f64 {
    status_mb("VmHWM:")
}

fn status_mb(field: &str) -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let kb: f64 = status.lines().find_map(|l| l.strip_prefix(field)).and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok()).unwrap_or(f64::NAN);
    kb / 1024.0
}

fn law(name: &str) -> WolfPolicy {
    match name {
        "seed000" => WolfPolicy::Seed000,
        "bvc" => WolfPolicy::Bvc,
        "formation" => WolfPolicy::Formation,
        _ => panic!("unknown law {name:?} (seed000, bvc, formation)"),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let episodes: u64 = args.first().map(|s| s.parse().expect("EPISODES")).unwrap_or(43_000);
    let every: u64 = args.get(1).map(|s| s.parse().expect("EVERY")).unwrap_or(2_000).max(1);
    let mode = args.get(2).map(String::as_str).unwrap_or("episodes");
    let laws = args.get(3).map(String::as_str).unwrap_or("seed000,bvc,formation");
    println!("law mode episodes rss_mb");
    for name in laws.split(',') {
        let mut params = Params::default();
        params.policies.wolves = law(name);
        let start = Instant::now();
        println!("{name} {mode} 0 {:.1}", rss_mb());
        match mode {
            "episodes" => {
                let mut done = 0;
                while done < episodes {
                    let count = every.min(episodes - done);
                    let results = run_episodes(&params, 0, done, count, None, false, None).expect("episodes");
                    assert_eq!(results.len() as u64, count);
                    done += count;
                    println!("{name} {mode} {done} {:.1}", rss_mb());
                }
            }
            "once" => {
                // One call for every episode, results all held (the CLI without a terminal).
                let results = run_episodes(&params, 0, 0, episodes, None, false, None).expect("episodes");
                assert_eq!(results.len() as u64, episodes);
                println!("{name} {mode} {episodes} {:.1} (peak {:.1})", rss_mb(), hwm_mb());
                drop(results);
                println!("{name} {mode} dropped {:.1}", rss_mb());
            }
            "single" => {
                let p = Arc::new(params.clone());
                for k in 0..episodes {
                    run_episode(&p, k, None, false).expect("episode");
                    if (k + 1) % every == 0 || k + 1 == episodes {
                        println!("{name} {mode} {} {:.1}", k + 1, rss_mb());
                    }
                }
            }
            "batch" => {
                let num_envs = 64;
                let mut env = BatchEnv::new(params.clone(), num_envs, Learners::None, 0, true, None).expect("batch");
                env.reset(None).expect("reset");
                let (mut done, mut next) = (0u64, every);
                while done < episodes {
                    let out = env.step(&[], &[]).expect("step");
                    done += out.terminated.iter().zip(&out.truncated).filter(|(a, b)| **a || **b).count() as u64;
                    if done >= next.min(episodes) {
                        println!("{name} {mode} {done} {:.1}", rss_mb());
                        next += every;
                    }
                }
            }
            _ => panic!("unknown mode {mode:?} (episodes, once, batch, single)"),
        }
        eprintln!("{name}: {episodes} episodes in {:.1} s", start.elapsed().as_secs_f64());
    }
}
