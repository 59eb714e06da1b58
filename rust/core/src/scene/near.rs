//! The step's one culling pass: which obstacles each agent could touch or sense this step.
//!
//! After the obstacles move, every agent's pose point is tested once against every obstacle's
//! bounding disc with a squared distance (no square root). The lists are then shared by the
//! avoidance law (obstacles within its sensing range), the feasibility filter (the body at any
//! pose reachable in one step) and the judge (the body after the move). An obstacle left out
//! is provably beyond each consumer's own exact test, so every consumer reaches the same
//! decisions, in the same order, as a scan of all obstacles: trajectories are unchanged bit
//! for bit (`examples/digest.rs`).

use super::Obstacle;
use crate::config::Params;
use crate::math::Vec2;

/// Relative and absolute slack on the cull radius: the consumers compare rounded square roots
/// (`|p − c| − R ≥ range`), this pass rounded squares; the slack (far above both roundings,
/// far below any distance that matters) keeps the cull on the safe side of every such test.
const SLACK_REL: f64 = 1e-9;
const SLACK_ABS: f64 = 1e-9;

/// Obstacles near each agent (wolves first, then targets), in obstacle index order.
#[derive(Debug, Clone, Default)]
pub struct Neighbours {
    /// Agent a's obstacles are `index[start[a]..start[a + 1]]`.
    start: Vec<u32>,
    index: Vec<u32>,
    /// Each obstacle's squared cull radius this step (scratch of `build`).
    reach2: Vec<f64>,
}

/// How far beyond an obstacle's bounding disc an agent's pose point must be for that obstacle
/// to matter to nobody this step: the avoidance law's sensing range, or one step at the
/// fastest side's top speed plus the body's own radius, whichever is larger.
pub fn cull_distance(p: &Params) -> f64 {
    let b = &p.agents.body;
    let body_radius = b.height.max(0.5 * b.base);
    let step = p.agents.wolf.v_max.max(p.agents.target.v_max) * p.world.ts;
    p.avoidance.obstacle_range.max(step + body_radius)
}

impl Neighbours {
    /// No lists (a new episode's, until its first build), keeping the allocations.
    pub(crate) fn clear(&mut self) {
        self.start.clear();
        self.index.clear();
        self.reach2.clear();
    }

    /// Rebuilds the lists for agents at `points` with cull distance `cut` ([`cull_distance`]).
    pub fn build(&mut self, points: impl Iterator<Item = Vec2>, obstacles: &[Obstacle], cut: f64) {
        self.start.clear();
        self.index.clear();
        self.start.push(0);
        // The radii once per obstacle, not once per agent and obstacle.
        self.reach2.clear();
        self.reach2.extend(obstacles.iter().map(|o| {
            let r = (o.radius + cut) * (1.0 + SLACK_REL) + SLACK_ABS;
            r * r
        }));
        for p in points {
            for (k, (o, &r2)) in obstacles.iter().zip(&self.reach2).enumerate() {
                if (p - o.center).norm_squared() <= r2 {
                    self.index.push(k as u32);
                }
            }
            self.start.push(self.index.len() as u32);
        }
    }

    /// [`crate::world::World::prefetch`]'s share.
    #[inline]
    pub fn prefetch(&self) {
        crate::math::prefetch_slice(&self.start);
        crate::math::prefetch_slice(&self.index);
    }

    /// Every agent's list, one after the other (an obstacle near several agents appears once
    /// per agent).
    #[inline]
    pub fn all(&self) -> &[u32] {
        &self.index
    }

    /// Indices of the obstacles near agent `a` (wolves 0..N, then targets N..N+M).
    #[inline]
    pub fn of(&self, a: usize) -> &[u32] {
        &self.index[self.start[a] as usize..self.start[a + 1] as usize]
    }
}

/// The obstacles near agent `a`, or all of them without lists (tests, the expert's look-ahead:
/// the result is the same, only slower).
#[inline]
pub fn near<'a>(obstacles: &'a [Obstacle], lists: Option<&'a Neighbours>, a: usize) -> Near<'a> {
    Near { obstacles, list: lists.map(|n| n.of(a)), i: 0 }
}

/// The iterator of [`near`]. (A plain cursor: the `chain` of two flattened options it replaced
/// compiled to a few per cent of a step of iterator state, and did not always inline:
/// BENCHMARKS.md, "Optimisations".)
#[derive(Debug, Clone)]
pub struct Near<'a> {
    obstacles: &'a [Obstacle],
    /// The agent's list, or `None` for every obstacle.
    list: Option<&'a [u32]>,
    i: usize,
}

impl<'a> Iterator for Near<'a> {
    type Item = &'a Obstacle;

    #[inline]
    fn next(&mut self) -> Option<&'a Obstacle> {
        let k = match self.list {
            Some(l) => *l.get(self.i)? as usize,
            None => self.i,
        };
        self.i += 1;
        self.obstacles.get(k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_hold_exactly_the_obstacles_within_reach_in_index_order() {
        let obstacles = vec![Obstacle::circle(Vec2::new(0.0, 0.0), 1.0, false), Obstacle::circle(Vec2::new(5.0, 0.0), 0.5, false), Obstacle::circle(Vec2::new(2.4, 0.0), 0.3, true)];
        let mut n = Neighbours::default();
        // Agent 0 at (2, 0), cut 1: disc 0 (centre 2 away, R + cut = 2) just in, disc 1 (3 away,
        // 1.5) out, disc 2 in. Agent 1 far from all.
        n.build([Vec2::new(2.0, 0.0), Vec2::new(-8.0, 8.0)].into_iter(), &obstacles, 1.0);
        assert_eq!(n.of(0), &[0, 2]);
        assert!(n.of(1).is_empty());
        let picked: Vec<f64> = near(&obstacles, Some(&n), 0).map(|o| o.radius).collect();
        assert_eq!(picked, vec![1.0, 0.3]);
        assert_eq!(near(&obstacles, None, 1).count(), 3);
    }

    #[test]
    fn the_cull_distance_covers_sensing_and_one_step() {
        let mut p = Params::default();
        assert_eq!(cull_distance(&p), p.avoidance.obstacle_range);
        p.agents.wolf.v_max = 100.0;
        assert!((cull_distance(&p) - (100.0 * p.world.ts + 0.2)).abs() < 1e-12);
    }
}
