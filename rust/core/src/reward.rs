//! Rewards of the learning interface (params `rewards.*`), per agent and step.
//!
//! Wolves, each: `−time_penalty`; `+capture_bonus` for every target captured this step (a
//! team reward: every wolf gets it); `−collision_penalty` if its body overlaps an obstacle or
//! another wolf after the step; potential-based shaping `shaping · (Φ(s') − Φ(s))` with
//! `Φ = −|d − r_h|`, d the distance to the wolf's focus target and r_h `seed000.radius`
//! (the hunting ring) — the focus is the wolf's nearest uncaptured target, or with
//! `shaping_focus: pack` the uncaptured target with the least total distance to the pack — and Φ = 0 in a terminal state (capture or collision) so that shaping
//! does not change which policies are optimal (Ng et al., 1999). A timeout is a truncation,
//! not a terminal state: Φ(s') keeps its value.
//!
//! Targets, each, until captured: `+survival` per step survived; `−capture_penalty` at the step
//! it is captured; `−collision_penalty` at a step its body overlaps an obstacle. A captured
//! target gets 0 afterwards.

use crate::config::ShapingFocus;
use crate::world::{Outcome, World};

/// What the rewards remember between steps of one world.
#[derive(Debug, Clone, Default)]
pub struct RewardState {
    potential: Vec<f64>,
    collisions: Vec<u32>,
    captured: Vec<bool>,
}

impl RewardState {
    /// Starts loading this state's lists (see [`crate::world::World::prefetch`]).
    #[inline]
    pub fn prefetch(&self) {
        crate::math::prefetch_slice(&self.potential);
        crate::math::prefetch_slice(&self.collisions);
        crate::math::prefetch_slice(&self.captured);
    }

    /// The state at the start of an episode.
    pub fn new(w: &World) -> Self {
        let mut s = Self::default();
        s.reset(w);
        s
    }

    pub fn reset(&mut self, w: &World) {
        let focus = pack_focus(w);
        self.potential.clear();
        self.potential.extend((0..w.n_wolves()).map(|i| potential(w, i, focus)));
        self.collisions.clear();
        self.collisions.extend_from_slice(&w.collisions);
        self.captured.clear();
        self.captured.extend_from_slice(&w.target_captured);
    }

    /// The rewards of the step that led to `w`'s current state. Either output may be empty
    /// (that side is not learning); otherwise its length is N or M.
    pub fn step(&mut self, w: &World, wolves: &mut [f32], targets: &mut [f32]) {
        let r = &w.params.rewards;
        let n = w.n_wolves();
        let newly_captured = w.target_captured.iter().zip(&self.captured).filter(|(now, before)| **now && !**before).count();
        let terminal = w.outcome.is_success() || w.outcome == Outcome::Collision;
        let focus = if terminal { None } else { pack_focus(w) };
        for i in 0..n {
            let phi = if terminal { 0.0 } else { potential(w, i, focus) };
            if !wolves.is_empty() {
                let collided = w.collisions[i] > self.collisions[i];
                let mut x = -r.wolves.time_penalty + r.wolves.capture_bonus * newly_captured as f64 + r.wolves.shaping * (phi - self.potential[i]);
                if collided {
                    x -= r.wolves.collision_penalty;
                }
                wolves[i] = x as f32;
            }
            self.potential[i] = phi;
        }
        for j in 0..w.n_targets() {
            if !targets.is_empty() {
                let x = if self.captured[j] {
                    0.0
                } else {
                    let mut x = if w.target_captured[j] { -r.targets.capture_penalty } else { r.targets.survival };
                    if w.collisions[n + j] > self.collisions[n + j] {
                        x -= r.targets.collision_penalty;
                    }
                    x
                };
                targets[j] = x as f32;
            }
        }
        self.collisions.copy_from_slice(&w.collisions);
        self.captured.copy_from_slice(&w.target_captured);
    }
}

/// Φ of wolf i: minus its distance from the hunting ring of its focus target (`focus`, the pack's
/// target under `shaping_focus: pack`, else its own nearest uncaptured target).
fn potential(w: &World, i: usize, focus: Option<usize>) -> f64 {
    let d = match focus {
        Some(j) => (w.targets[j].pos - w.wolves[i].pos).norm(),
        None => nearest_target_distance(w, i),
    };
    if d.is_finite() {
        -(d - w.params.seed000.radius).abs()
    } else {
        0.0
    }
}

/// The pack's focus under `shaping_focus: pack`: the uncaptured target with the least total
/// distance to the wolves (the lowest index on a tie). None under `nearest`, or when every target
/// is captured.
fn pack_focus(w: &World) -> Option<usize> {
    if w.params.rewards.wolves.shaping_focus != ShapingFocus::Pack {
        return None;
    }
    let total = |j: usize| w.wolves.iter().map(|a| (w.targets[j].pos - a.pos).norm()).sum::<f64>();
    (0..w.n_targets())
        .filter(|&j| !w.target_captured[j])
        .map(|j| (j, total(j)))
        .fold(None, |best: Option<(usize, f64)>, (j, d)| match best {
            Some((_, b)) if b <= d => best,
            _ => Some((j, d)),
        })
        .map(|(j, _)| j)
}

/// Distance from wolf i to the nearest uncaptured target (∞ when every target is captured).
pub fn nearest_target_distance(w: &World, i: usize) -> f64 {
    let p = w.wolves[i].pos;
    w.targets.iter().zip(&w.target_captured).filter(|(_, c)| !**c).map(|(t, _)| (t.pos - p).norm()).fold(f64::INFINITY, f64::min)
}

/// Distance from target j to the nearest wolf.
pub fn nearest_wolf_distance(w: &World, j: usize) -> f64 {
    let p = w.targets[j].pos;
    w.wolves.iter().map(|a| (a.pos - p).norm()).fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    use crate::config::Params;
    use crate::policies::Command;
    use crate::world::Layout;

    fn still_world(wolves: Vec<[f64; 3]>, target: [f64; 3]) -> World {
        let mut p = Params::default();
        p.policies.targets = crate::config::TargetPolicy::Still;
        World::from_layout(Arc::new(p), 0, &Layout { wolves, targets: vec![target], obstacles: vec![] }).unwrap()
    }

    #[test]
    fn shaping_time_penalty_and_survival_by_hand() {
        // One wolf 3 m from a still target, driving straight at it at 1 m/s for one step:
        // d 3.0 → 2.9, Φ −2.35 → −2.25, shaping +0.1; reward 0.1 − 0.01 = 0.09.
        let mut w = still_world(vec![[-3.0, 0.0, 0.0]], [0.0, 0.0, 0.0]);
        let mut s = RewardState::new(&w);
        w.step_with(Some(&[Command { v: 1.0, omega: 0.0 }]), None);
        let (mut rw, mut rt) = ([0f32; 1], [0f32; 1]);
        s.step(&w, &mut rw, &mut rt);
        assert!((rw[0] - 0.09).abs() < 1e-6, "{rw:?}");
        assert!((rt[0] - 0.1).abs() < 1e-6, "{rt:?}");
    }

    #[test]
    #[allow(clippy::approx_constant)] // headings rounded by hand: any heading will do here
    fn capture_pays_the_bonus_and_zeroes_the_potential() {
        // Four wolves at 0.75 m around the target, one of them steps in: captured at step 1.
        let ring = vec![[0.75, 0.0, 3.14159], [-0.75, 0.0, 0.0], [0.0, 0.75, 4.712], [0.0, -0.75, 1.5708], [5.0, 5.0, 0.0]];
        let mut w = still_world(ring, [0.0, 0.0, 0.0]);
        let mut s = RewardState::new(&w);
        let stay = [Command::default(); 5];
        w.step_with(Some(&stay), None);
        assert_eq!(w.outcome, Outcome::Captured);
        let (mut rw, mut rt) = ([0f32; 5], [0f32; 1]);
        s.step(&w, &mut rw, &mut rt);
        // Wolf 0: Φ −0.1 → 0: +0.1 shaping, +10 bonus, −0.01 time.
        assert!((rw[0] - 10.09).abs() < 1e-5, "{rw:?}");
        // Wolf 4: d = √50, Φ = −(√50 − 0.65) → 0.
        let want = 10.0 - 0.01 + (50f64.sqrt() - 0.65);
        assert!((rw[4] as f64 - want).abs() < 1e-4, "{rw:?}");
        assert_eq!(rt[0], -10.0);
        // After the capture the target's reward is 0.
        s.step(&w, &mut rw, &mut rt);
        assert_eq!(rt[0], 0.0);
    }

    #[test]
    fn pack_focus_measures_every_wolf_against_the_packs_target() {
        // Two still targets: A at the origin, B at (6, 0). Wolves 0-2 sit near A, wolves 3-4 near
        // B; A has the least total distance. Wolf 4 steps 0.1 m towards B (away from A).
        let mut p = Params::default();
        p.policies.targets = crate::config::TargetPolicy::Still;
        p.world.targets = 2;
        let wolves = vec![[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [5.0, 1.0, 0.0], [5.0, 0.0, 0.0]];
        let layout = Layout { wolves, targets: vec![[0.0, 0.0, 0.0], [6.0, 0.0, 0.0]], obstacles: vec![] };
        let step_wolf_4 = |focus: ShapingFocus| {
            let mut q = p.clone();
            q.rewards.wolves.shaping_focus = focus;
            let mut w = World::from_layout(Arc::new(q), 0, &layout).unwrap();
            let mut s = RewardState::new(&w);
            let mut cmd = [Command::default(); 5];
            cmd[4] = Command { v: 1.0, omega: 0.0 };
            w.step_with(Some(&cmd), None);
            let (mut rw, mut rt) = ([0f32; 5], [0f32; 2]);
            s.step(&w, &mut rw, &mut rt);
            rw[4]
        };
        // nearest: d to B 1.0 → 0.9, Φ −0.35 → −0.25: +0.1 − 0.01.
        assert!((step_wolf_4(ShapingFocus::Nearest) - 0.09).abs() < 1e-5);
        // pack: d to A 5.0 → 5.1, Φ −4.35 → −4.45: −0.1 − 0.01.
        assert!((step_wolf_4(ShapingFocus::Pack) + 0.11).abs() < 1e-5);
    }

    #[test]
    fn a_cornered_ending_pays_like_a_capture() {
        // capture.cornered: target 0.5 m from the top and right walls, two wolves at 0.51 m
        // closing the hull with the wall points (the hand-built corner scene of world::step).
        let mut p = Params::default();
        p.policies.targets = crate::config::TargetPolicy::Still;
        p.capture.cornered = true;
        let wolves = vec![[9.0, 9.6, 0.0], [9.6, 9.0, 0.0], [-5.0, -5.0, 0.0], [-5.0, 5.0, 0.0], [5.0, -5.0, 0.0]];
        let mut w = World::from_layout(Arc::new(p), 0, &Layout { wolves, targets: vec![[9.5, 9.5, 0.0]], obstacles: vec![] }).unwrap();
        let mut s = RewardState::new(&w);
        w.step_with(Some(&[Command::default(); 5]), None);
        assert_eq!(w.outcome, Outcome::Cornered);
        let (mut rw, mut rt) = ([0f32; 5], [0f32; 1]);
        s.step(&w, &mut rw, &mut rt);
        // Wolf 2: d = √(14.5² + 14.5²), Φ = −(d − 0.65) → 0 at the terminal state; +10 bonus.
        let d = (2.0f64 * 14.5 * 14.5).sqrt();
        assert!((rw[2] as f64 - (10.0 - 0.01 + (d - 0.65))).abs() < 1e-4, "{rw:?}");
        assert_eq!(rt[0], -10.0);
    }
}
