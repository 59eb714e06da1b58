//! Whole episodes: run a world to its end, record what docs/world-and-laws.md §1.7 lists per
//! episode and per step, and run many episodes in parallel with results independent of the
//! thread count (episode k uses seed `seed + k`).

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use rayon::prelude::*;

use crate::config::Params;
use crate::error::{Error, Result};
use crate::world::{Layout, ObstacleKind, Outcome, World};

/// Per-step logs of one episode, flat row-major buffers (T = steps taken).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trajectory {
    /// [T+1, N, 5]: x, y, θ, v, ω; row 0 is the initial state.
    pub wolves: Vec<f64>,
    /// [T+1, M, 5].
    pub targets: Vec<f64>,
    /// [T+1, N+M] accumulated energy.
    pub energy: Vec<f64>,
    /// [T, N+M, N+M] interaction matrices.
    pub interaction: Vec<u8>,
    /// [T+1, N]: the [`LawMode`](crate::scene::LawMode) code of each wolf's law in the step
    /// that led to each state; row 0 (no step yet) is 0, none.
    pub wolf_modes: Vec<u8>,
    /// [T+1, M], as `wolf_modes`.
    pub target_modes: Vec<u8>,
    /// [T+1, K, 3]: obstacle centre x, y and polygon angle (rad), for plots and replays.
    pub obstacles: Vec<f64>,
    /// The K obstacles' shapes (constant over the episode).
    pub obstacle_shapes: Vec<ObstacleShape>,
}

/// An obstacle's constant shape: kind, radius (bounding radius for polygons) and polygon
/// vertices relative to the centre at angle 0.
#[derive(Debug, Clone, PartialEq)]
pub struct ObstacleShape {
    pub kind: &'static str,
    pub radius: f64,
    pub local: Vec<[f64; 2]>,
}

impl Trajectory {
    fn push(&mut self, w: &World) {
        for a in &w.wolves {
            self.wolves.extend_from_slice(&[a.pos.x, a.pos.y, a.theta, a.v, a.omega]);
        }
        for a in &w.targets {
            self.targets.extend_from_slice(&[a.pos.x, a.pos.y, a.theta, a.v, a.omega]);
        }
        self.energy.extend(w.wolves.iter().chain(&w.targets).map(|a| a.energy));
        self.wolf_modes.extend(w.wolf_mode.iter().map(|&m| m as u8));
        self.target_modes.extend(w.target_mode.iter().map(|&m| m as u8));
        for o in &w.obstacles {
            self.obstacles.extend_from_slice(&[o.center.x, o.center.y, o.angle]);
        }
    }

    fn shapes(w: &World) -> Vec<ObstacleShape> {
        w.obstacles
            .iter()
            .map(|o| ObstacleShape {
                kind: match o.kind {
                    ObstacleKind::StaticCircle => "static_circle",
                    ObstacleKind::MovingCircle => "moving_circle",
                    ObstacleKind::StaticPolygon => "static_polygon",
                    ObstacleKind::MovingPolygon => "moving_polygon",
                },
                radius: o.radius,
                local: o.local.iter().map(|v| [v.x, v.y]).collect(),
            })
            .collect()
    }
}

/// What one episode came to (docs/world-and-laws.md §1.7).
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeResult {
    pub seed: u64,
    pub outcome: Outcome,
    pub steps: u32,
    /// Step of the last capture, for captured episodes.
    pub capture_step: Option<u32>,
    /// Per target: the step its hunt ended (captured, or cornered where `capture.cornered`
    /// counts it), `None` if it never ended.
    pub target_capture_steps: Vec<Option<u32>>,
    /// The first step at which any target was cornered (docs/world-and-laws.md §1.7), whether or
    /// not that ended the episode; `None` if no target ever was.
    pub cornered_step: Option<u32>,
    /// Per agent (wolves, then targets), J.
    pub energy: Vec<f64>,
    /// Per agent, steps spent overlapping an obstacle or (wolves) a wolf.
    pub collisions: Vec<u32>,
    pub wolves: usize,
    pub targets: usize,
    pub trajectory: Option<Trajectory>,
}

/// Trajectory rows reserved up front when recording (the documented episode has <= 301).
const RESERVED_ROWS: usize = 512;

/// The most memory one recorded episode may need (its worst case, at `world.max_steps`).
pub const MAX_RECORDED_EPISODE_BYTES: u64 = 2 << 30;

/// Most threads a pool may have: each reserves a stack, and more threads than cores only slow
/// the work down.
pub const MAX_THREADS: usize = 256;

/// What `threads: None` means: `RAYON_NUM_THREADS` when it is a positive integer (rayon's own
/// rule, which [`run_episodes`] follows through rayon's global pool), else every core this
/// process may use (its affinity mask and cgroup quota), at most [`MAX_THREADS`]. Worked out
/// without rayon: asking rayon would start its global pool, whose threads a batch, stepping
/// on a crew of its own, would never use.
pub fn default_threads() -> usize {
    let from_env = std::env::var("RAYON_NUM_THREADS").ok().and_then(|v| v.parse::<usize>().ok()).filter(|&n| n > 0);
    from_env.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())).clamp(1, MAX_THREADS)
}

/// Checks a thread count (`None`: all cores).
pub fn check_threads(threads: Option<usize>) -> Result<()> {
    match threads {
        Some(t) if !(1..=MAX_THREADS).contains(&t) => Err(Error::Invalid(format!("threads must be in 1..={MAX_THREADS}, got {t}"))),
        _ => Ok(()),
    }
}

fn at_seed(e: Error, seed: u64) -> Error {
    match e {
        Error::NonFinite(m) => Error::NonFinite(format!("{m} (episode seed {seed})")),
        other => other,
    }
}

/// Runs one scripted episode.
pub fn run_episode(params: &Arc<Params>, seed: u64, layout: Option<&Layout>, record: bool) -> Result<EpisodeResult> {
    run_episode_until(params, seed, layout, record, &AtomicBool::new(false))
}

/// [`run_episode`] that gives up with [`Error::Interrupted`] as soon as `stop` is set (checked
/// every step: one relaxed load).
pub fn run_episode_until(params: &Arc<Params>, seed: u64, layout: Option<&Layout>, record: bool, stop: &AtomicBool) -> Result<EpisodeResult> {
    params.validate()?;
    run_prevalidated(params, seed, layout, record, stop)
}

/// [`run_episode_until`] for params validated by the caller.
fn run_prevalidated(params: &Arc<Params>, seed: u64, layout: Option<&Layout>, record: bool, stop: &AtomicBool) -> Result<EpisodeResult> {
    let mut world = match layout {
        Some(l) => World::from_layout(params.clone(), seed, l)?,
        None => World::new_episode_prevalidated(params.clone(), seed, 0)?,
    };
    // Nothing outside this function sees the world, and the recorder keeps obstacle poses,
    // not vertices: the polygons nobody can reach need not be placed.
    world.lazy_obstacles = true;
    let (n, m) = (world.n_wolves(), world.n_targets());
    let mut traj = record.then(|| {
        // Capacity for a typical episode; the vectors grow if it runs longer. Preallocating
        // for max_steps would reserve up to gigabytes per episode that ends after 150 steps.
        let rows = (world.params.world.max_steps as usize + 1).min(RESERVED_ROWS);
        let mut t = Trajectory {
            wolves: Vec::with_capacity(rows * n * 5),
            targets: Vec::with_capacity(rows * m * 5),
            energy: Vec::with_capacity(rows * (n + m)),
            interaction: Vec::with_capacity((rows - 1) * (n + m) * (n + m)),
            wolf_modes: Vec::with_capacity(rows * n),
            target_modes: Vec::with_capacity(rows * m),
            obstacles: Vec::with_capacity(rows * world.obstacles.len() * 3),
            obstacle_shapes: Trajectory::shapes(&world),
        };
        t.push(&world);
        t
    });
    while !world.is_done() {
        if stop.load(Ordering::Relaxed) {
            return Err(Error::Interrupted);
        }
        world.step();
        world.check_fault().map_err(|e| at_seed(e, seed))?;
        if let Some(t) = traj.as_mut() {
            t.push(&world);
            t.interaction.extend_from_slice(&world.interaction);
        }
    }
    Ok(EpisodeResult {
        seed,
        outcome: world.outcome,
        steps: world.t,
        capture_step: world.capture_step(),
        target_capture_steps: world.target_capture_step.clone(),
        cornered_step: world.cornered_step(),
        energy: world.wolves.iter().chain(&world.targets).map(|a| a.energy).collect(),
        collisions: world.collisions.clone(),
        wolves: n,
        targets: m,
        trajectory: traj,
    })
}

/// Runs episodes `first .. first + count` (seeds `seed + k`) on a rayon pool of `threads`
/// threads (`None`: all cores). Results come back in episode order and do not depend on the
/// thread count: each episode owns its generator.
pub fn run_episodes(params: &Params, seed: u64, first: u64, count: u64, layout: Option<&Layout>, record: bool, threads: Option<usize>) -> Result<Vec<EpisodeResult>> {
    run_episodes_until(params, seed, first, count, layout, record, threads, &AtomicBool::new(false))
}

/// [`run_episodes`] that stops within a step of every running episode once `stop` is set, and
/// then returns [`Error::Interrupted`] (the Python binding sets it on Ctrl-C).
#[allow(clippy::too_many_arguments)]
pub fn run_episodes_until(params: &Params, seed: u64, first: u64, count: u64, layout: Option<&Layout>, record: bool, threads: Option<usize>, stop: &AtomicBool) -> Result<Vec<EpisodeResult>> {
    params.validate()?;
    check_threads(threads)?;
    if record && params.recorded_episode_bytes() > MAX_RECORDED_EPISODE_BYTES {
        return Err(Error::Params(format!(
            "world.max_steps: a recorded episode of {} steps with these agent and obstacle counts needs up to {:.1} GiB (limit {} GiB); lower world.max_steps or record fewer agents",
            params.world.max_steps,
            params.recorded_episode_bytes() as f64 / (1u64 << 30) as f64,
            MAX_RECORDED_EPISODE_BYTES >> 30
        )));
    }
    let params = Arc::new(params.clone());
    let work = || (first..first + count).into_par_iter().map(|k| run_prevalidated(&params, seed.wrapping_add(k), layout, record, stop)).collect::<Result<Vec<_>>>();
    match threads {
        None => work(),
        Some(t) => pool(t)?.install(work),
    }
}

/// A pool of `t` threads, started on first use and kept: `wolfpack hunt` calls the runner once
/// per chunk of episodes, and starting the threads anew on every call is a cost per thread and
/// call that a kept pool pays once (BENCHMARKS.md, "Optimisations"). At most one pool per
/// thread count (≤ [`MAX_THREADS`] of them). The pools belong to the process that started
/// them: a forked child (Python's multiprocessing) has none of their threads, so it starts its
/// own instead of waiting forever on the parent's.
fn pool(t: usize) -> Result<Arc<rayon::ThreadPool>> {
    type Pools = (u32, BTreeMap<usize, Arc<rayon::ThreadPool>>);
    static POOLS: Mutex<Pools> = Mutex::new((0, BTreeMap::new()));
    let mut guard = POOLS.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let (owner, pools) = &mut *guard;
    if *owner != std::process::id() {
        // Inherited from the parent across a fork: their threads do not exist here. Forget
        // them (dropping would signal threads that are not there).
        std::mem::forget(std::mem::take(pools));
        *owner = std::process::id();
    }
    if let Some(p) = pools.get(&t) {
        return Ok(p.clone());
    }
    let p = Arc::new(rayon::ThreadPoolBuilder::new().num_threads(t.max(1)).build().map_err(|e| Error::Invalid(format!("could not start {t} threads: {e}")))?);
    pools.insert(t, p.clone());
    Ok(p)
}
