//! Throughput of scripted stepping (BENCHMARKS.md; run with
//! `cargo bench -p wolfpack-bench --bench step -- --measurement-time 5`).
//!
//! - `step/documented`: one `World::step()` of the documented scenario (`Params::default()`:
//!   5 seed000 wolves, 1 escaping target, 12 obstacles, 20 m arena). Criterion reports time per
//!   step and steps/s. When an episode ends, the next world (next seed) is spawned outside the
//!   timed region, so the figure is pure stepping over the whole episode mix.
//! - `episode/documented`: whole `episode::run_episode`s (spawn + steps, no recording) of a fixed
//!   batch of seeds; the throughput is the batch's exact step count, so criterion's elements/s
//!   is again steps/s, spawning included.
//! - `step/scaled`: 20 wolves, 4 targets, 48 obstacles in a 40 m arena, to show the scaling.

use std::hint::black_box;
use std::sync::Arc;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use wolfpack_core::episode::run_episode;
use wolfpack_core::{Params, World};

/// Seeds cycled through by every benchmark (episodes of varied length and outcome).
const SEEDS: u64 = 64;

fn documented() -> Params {
    Params::default()
}

/// 20 wolves, 4 targets, 48 obstacles (4× each kind) in a 40 m × 40 m arena (4× the area, so
/// the obstacle density is the documented one). A target needs 4 wolves, as documented.
fn scaled() -> Params {
    let mut p = Params::default();
    p.world.border = [-20.0, -20.0, 20.0, 20.0];
    p.world.wolves = 20;
    p.world.targets = 4;
    p.obstacles.static_circles = 4;
    p.obstacles.moving_circles = 4;
    p.obstacles.static_polygons = 20;
    p.obstacles.moving_polygons = 20;
    p.capture.count = Some(4);
    p
}

/// Steps `iters` times, spawning a fresh world (next seed) untimed whenever one finishes.
fn timed_steps(params: &Arc<Params>, seed: &mut u64, world: &mut World, iters: u64) -> Duration {
    let mut total = Duration::ZERO;
    let mut left = iters;
    while left > 0 {
        if world.is_done() {
            *seed = (*seed + 1) % SEEDS;
            *world = World::new(params.clone(), *seed).expect("spawn");
        }
        let start = Instant::now();
        while left > 0 && !world.is_done() {
            black_box(world.step());
            left -= 1;
        }
        total += start.elapsed();
    }
    total
}

/// Runs the episodes of seeds `0..batch`; returns their summed step count.
fn run_batch(params: &Arc<Params>, batch: u64) -> u64 {
    (0..batch).map(|s| u64::from(black_box(run_episode(params, s, None, false).expect("episode")).steps)).sum()
}

fn bench_step(c: &mut Criterion) {
    let mut g = c.benchmark_group("step");
    g.sample_size(20);
    g.throughput(Throughput::Elements(1));
    for (name, params) in [("documented", documented()), ("scaled", scaled())] {
        let params = Arc::new(params);
        let mut seed = 0;
        let mut world = World::new(params.clone(), seed).expect("spawn");
        g.bench_function(BenchmarkId::from_parameter(name), |b| b.iter_custom(|iters| timed_steps(&params, &mut seed, &mut world, iters)));
    }
    g.finish();
}

fn bench_episode(c: &mut Criterion) {
    let mut g = c.benchmark_group("episode");
    g.sample_size(20);
    // One iteration = the episodes of seeds 0..batch (a mix of outcomes and lengths).
    for (name, params, batch) in [("documented", documented(), 16), ("scaled", scaled(), 4)] {
        let params = Arc::new(params);
        g.throughput(Throughput::Elements(run_batch(&params, batch)));
        g.bench_function(BenchmarkId::from_parameter(name), |b| b.iter(|| run_batch(&params, batch)));
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(5));
    targets = bench_step, bench_episode
}
criterion_main!(benches);
