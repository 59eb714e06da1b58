//! docs/world-and-laws.md §5 — the scripted target laws `escape` and `random` (`still` is
//! v = ω = 0 and is handled by the world).
//!
//! `escape`:
//! - before the target has ever sensed a wolf: wander, v ~ U(0, wander_speed),
//!   θ_d = wrap(θ + U(−wander_turn, wander_turn));
//! - from its first sighting t_seen on: if wolves are sensed now (within
//!   `agents.target.sense_radius`), θ_d = direction of Σ (p_0 − p_j) over them
//!   (un-normalised: nearer wolves do not weigh more, the sum just points away from the pack)
//!   and v_d = the fatigue curve `escape.fatigue_speed(t_seen, t)`; if none is sensed now, keep
//!   the heading and scale the current speed by the curve's ratio between t and t − 1;
//!
//! then avoidance (§4.8, target variant) and the saturator (§2). `random` is the
//! wander rule forever, then the same avoidance and saturator.
//!
//! Choices the sources leave open, as §5.1 settles them:
//! - Random numbers are drawn in a fixed order, speed first, then turn, two per wander step,
//!   as `u·wander_speed` and `(2u − 1)·wander_turn` with u ~ U[0, 1) — no range is ever
//!   empty, so a zero `wander_speed` or `wander_turn` cannot panic.
//! - "The current speed" is the speed the target executed in the last step (`AgentState::v`,
//!   after the world's feasibility filter).
//! - Sensed wolves whose sum Σ (p_0 − p_j) vanishes (a perfectly symmetric ring, or wolves on
//!   the target) give no direction: the target keeps its heading, still at the curve's speed.

use rand::Rng;

use super::avoidance;
use super::saturator::saturate;
use super::{Command, Snapshot};
use crate::config::EscapeParams;
use crate::math::{angle_of, wrap, Vec2};
/// The `escape` and `random` laws' memory: their emergency.
pub use crate::scene::EscapeMemory as Memory;
use crate::scene::LawMode;

/// The `escape` law for target `j`.
pub fn escape_command<R: Rng>(j: usize, snap: &Snapshot, mem: &mut Memory, rng: &mut R) -> Command {
    let (v_d, theta_d) = escape_desired(j, snap, mem, rng);
    saturate_target(j, snap, v_d, theta_d)
}

/// The `escape` law up to the saturator: the desired (v_d, θ_d) after avoidance.
pub fn escape_desired<R: Rng>(j: usize, snap: &Snapshot, mem: &mut Memory, rng: &mut R) -> (f64, f64) {
    let (v_d, theta_d, base) = match snap.target_seen_at[j] {
        None => {
            let (v, th) = wander(snap.targets[j].theta, &snap.params.escape, rng);
            (v, th, LawMode::Wander)
        }
        Some(t_seen) => flee_case(j, snap, t_seen),
    };
    let (v, th, mode) = avoidance::target_mode(j, snap, v_d, theta_d, &mut mem.danger);
    mem.mode = mode.law_mode(base);
    (v, th)
}

/// The `random` law for target `j`: the wander rule forever.
pub fn random_command<R: Rng>(j: usize, snap: &Snapshot, mem: &mut Memory, rng: &mut R) -> Command {
    let (v_d, theta_d) = random_desired(j, snap, mem, rng);
    saturate_target(j, snap, v_d, theta_d)
}

/// The `random` law up to the saturator.
pub fn random_desired<R: Rng>(j: usize, snap: &Snapshot, mem: &mut Memory, rng: &mut R) -> (f64, f64) {
    let (v_d, theta_d) = wander(snap.targets[j].theta, &snap.params.escape, rng);
    let (v, th, mode) = avoidance::target_mode(j, snap, v_d, theta_d, &mut mem.danger);
    mem.mode = mode.law_mode(LawMode::Wander);
    (v, th)
}

/// The saturator with the target's limits.
pub fn saturate_target(j: usize, snap: &Snapshot, v_d: f64, theta_d: f64) -> Command {
    let p = snap.params;
    let side = &p.agents.target;
    saturate(v_d, theta_d, snap.targets[j].theta, side.v_max, side.omega_max, p.world.ts)
}

/// The wander rule: (v ~ U(0, wander_speed), θ_d = wrap(θ + U(−wander_turn, wander_turn))).
/// Draws exactly two numbers, speed first.
pub fn wander<R: Rng>(theta: f64, e: &EscapeParams, rng: &mut R) -> (f64, f64) {
    let u_speed: f64 = rng.random();
    let u_turn: f64 = rng.random();
    (u_speed * e.wander_speed, wrap(theta + (2.0 * u_turn - 1.0) * e.wander_turn))
}

/// After the first sighting: flee the wolves sensed now at the fatigue speed, or coast.
pub fn flee(j: usize, snap: &Snapshot, t_seen: u32) -> (f64, f64) {
    let (v, th, _) = flee_case(j, snap, t_seen);
    (v, th)
}

/// [`flee`] and which case gave it: [`LawMode::Flee`] (wolves sensed now) or
/// [`LawMode::Coast`] (none).
pub fn flee_case(j: usize, snap: &Snapshot, t_seen: u32) -> (f64, f64, LawMode) {
    let p = snap.params;
    let me = snap.targets[j];
    let r = p.agents.target.sense_radius;
    let mut away = Vec2::zeros();
    let mut sensed = false;
    for w in snap.wolves {
        let d = me.pos - w.pos;
        if d.norm() <= r {
            away += d;
            sensed = true;
        }
    }
    if sensed {
        let theta_d = if away == Vec2::zeros() { me.theta } else { angle_of(away) };
        return (p.escape.fatigue_speed(t_seen, snap.t), theta_d, LawMode::Flee);
    }
    // None sensed now: keep heading; the speed follows the curve's relative decay. The curve
    // is positive everywhere (fatigue_base > 0, the bracket lies in (1, 2)), so the ratio is
    // finite. At t = 0 there is no previous step: ratio 1.
    let prev = snap.t.saturating_sub(1);
    let ratio = p.escape.fatigue_speed(t_seen, snap.t) / p.escape.fatigue_speed(t_seen, prev);
    (me.v * ratio, me.theta, LawMode::Coast)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{PI, TAU};
    use crate::scene::{AgentState, Obstacle};
    use rand::RngCore;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    /// Returns the given fractions of 2⁶⁴ in turn: `random::<f64>()` takes the top 53 bits,
    /// so 0.5 and 0.75 come back exactly.
    struct Fixed(Vec<f64>, usize);

    impl RngCore for Fixed {
        fn next_u32(&mut self) -> u32 {
            (self.next_u64() >> 32) as u32
        }
        fn next_u64(&mut self) -> u64 {
            let x = self.0[self.1 % self.0.len()];
            self.1 += 1;
            (x * 2f64.powi(64)) as u64
        }
        fn fill_bytes(&mut self, dst: &mut [u8]) {
            for b in dst {
                *b = self.next_u32() as u8;
            }
        }
    }

    use crate::policies::fixture::Scene as World;

    fn scene(wolves: &[(f64, f64)], target: AgentState, seen: Option<u32>, t: u32) -> World {
        let mut w = World::new(World::wolves_at(wolves), vec![target], vec![]);
        w.seen = vec![seen];
        w.t = t;
        w
    }

    #[test]
    fn wander_draws_speed_then_turn() {
        // u = 0.5 → v = 0.75; u = 0.75 → turn (2·0.75 − 1)·π/6 = π/12.
        let (v, th) = wander(0.0, &EscapeParams::default(), &mut Fixed(vec![0.5, 0.75], 0));
        assert!(close(v, 0.75) && close(th, PI / 12.0), "({v}, {th})");
        // u = 0 for the turn → −π/6, wrapped.
        let (_, th) = wander(0.1, &EscapeParams::default(), &mut Fixed(vec![0.5, 0.0], 0));
        assert!(close(th, TAU + 0.1 - PI / 6.0), "{th}");
    }

    #[test]
    fn escape_wanders_before_the_first_sighting() {
        // Never seen: θ_d = π/12, v_d = 0.75 → saturator: e = 2π − π/12 ≥ 2π − 0.7 →
        // ω = (π/12)/0.1 = 2.61799, v = 0.75·(1 − 1/12) = 0.6875.
        let w = scene(&[(1.0, 0.0)], AgentState::at(0.0, 0.0, 0.0), None, 7);
        let mut rng = Fixed(vec![0.5, 0.75], 0);
        let c = escape_command(0, &w.snap(), &mut Memory::default(), &mut rng);
        assert!(close(c.omega, PI / 12.0 / 0.1) && close(c.v, 0.6875), "{c:?}");
        assert_eq!(rng.1, 2, "two draws");
        // `random` wanders the same way even once seen.
        let w = scene(&[(1.0, 0.0)], AgentState::at(0.0, 0.0, 0.0), Some(0), 7);
        let c = random_command(0, &w.snap(), &mut Memory::default(), &mut Fixed(vec![0.5, 0.75], 0));
        assert!(close(c.omega, PI / 12.0 / 0.1) && close(c.v, 0.6875), "{c:?}");
    }

    #[test]
    fn escape_flees_the_sum_of_sensed_wolves() {
        // Wolves at (−1, 0) and (0, −2) are sensed (≤ 3), (5, 0) is not. Σ (p_0 − p_j) =
        // (1, 0) + (0, 2) = (1, 2) → θ_d = atan2(2, 1) = 1.10715. Seen at 0, now t = 10:
        // curve 0.9·(2 − 1/(1 + e^{22.5})) = 1.8 → capped 1.5. Heading 0: e = 2π − 1.10715 ∈
        // (π, 2π − 0.7) → ω = +7, v = 1.5·(1 − 1.10715/π) = 0.971375.
        let w = scene(&[(-1.0, 0.0), (0.0, -2.0), (5.0, 0.0)], AgentState::at(0.0, 0.0, 0.0), Some(0), 10);
        let (v, th) = flee(0, &w.snap(), 0);
        assert!((v - 1.8).abs() < 1e-9 && close(th, 2f64.atan2(1.0)), "({v}, {th})");
        let mut rng = Fixed(vec![0.9], 0);
        let c = escape_command(0, &w.snap(), &mut Memory::default(), &mut rng);
        assert!(close(c.omega, 7.0) && (c.v - 0.9713754).abs() < 1e-6, "{c:?}");
        assert_eq!(rng.1, 0, "no draws once seen");
    }

    #[test]
    fn fatigue_curve_sets_the_flight_speed() {
        // One wolf behind at (−1, 0), heading 0 = θ_d: no turn. Seen at 0, t = 120:
        // 0.9·(2 − 1/(1 + e^{−5})) = 0.906024.
        let w = scene(&[(-1.0, 0.0)], AgentState::at(0.0, 0.0, 0.0), Some(0), 120);
        let c = escape_command(0, &w.snap(), &mut Memory::default(), &mut Fixed(vec![0.0], 0));
        assert!((c.v - 0.9060236).abs() < 1e-6 && close(c.omega, 0.0), "{c:?}");
    }

    #[test]
    fn none_sensed_now_keeps_heading_and_scales_speed() {
        // Seen at 5, t = 110, last speed 1.0, heading 0.3, wolves out of range:
        // ratio f(110)/f(109) = 1.1004301/1.1420473 = 0.9635592 → v = 0.9635592, θ_d = 0.3.
        let mut a = AgentState::at(0.0, 0.0, 0.3);
        a.v = 1.0;
        let w = scene(&[(-4.0, 0.0)], a, Some(5), 110);
        let (v, th) = flee(0, &w.snap(), 5);
        assert!((v - 0.9635592).abs() < 1e-6 && close(th, 0.3), "({v}, {th})");
        let c = escape_command(0, &w.snap(), &mut Memory::default(), &mut Fixed(vec![0.0], 0));
        assert!((c.v - 0.9635592).abs() < 1e-6 && c.omega == 0.0, "{c:?}");
    }

    #[test]
    fn symmetric_wolves_keep_the_heading() {
        let w = scene(&[(-1.0, 0.0), (1.0, 0.0)], AgentState::at(0.0, 0.0, 2.0), Some(0), 3);
        let (_, th) = flee(0, &w.snap(), 0);
        assert_eq!(th, 2.0);
    }

    #[test]
    fn escape_then_avoids() {
        // Fleeing a wolf at (−1, −0.1) into a moving circle at (1.5, 0), r = 0.5 (d = 1.0):
        // θ_d = atan(0.1) = 0.0997; the heading 0.05 lies inside (−0.6797, 0.6797) (κ = 2.0,
        // Δ = asin(1/3)) and θ_d is nearer its upper edge → θ_d = 0.6897;
        // e = 2π − 0.6397 ≥ 2π − 0.7 → ω = 6.397.
        let mut w = scene(&[(-1.0, -0.1)], AgentState::at(0.0, 0.0, 0.05), Some(0), 200);
        w.obstacles.push(Obstacle::circle(Vec2::new(1.5, 0.0), 0.5, true));
        let c = escape_command(0, &w.snap(), &mut Memory::default(), &mut Fixed(vec![0.0], 0));
        let edge = 2.0 * (1.0f64 / 3.0).asin() + 0.01;
        assert!(close(c.omega, (edge - 0.05) / 0.1), "{c:?}");
    }

    // ---- the law's mode ----

    #[test]
    fn the_mode_is_wander_flee_or_coast_unless_avoidance_decides() {
        let mode = |w: &World, random: bool| {
            let mut mem = Memory::default();
            let mut rng = Fixed(vec![0.5, 0.75], 0);
            if random {
                random_desired(0, &w.snap(), &mut mem, &mut rng);
            } else {
                escape_desired(0, &w.snap(), &mut mem, &mut rng);
            }
            mem.mode
        };
        // Never seen: wander; seen, with a wolf 1 m away: flee; seen, none within 3 m: coast.
        assert_eq!(mode(&scene(&[(1.0, 0.0)], AgentState::at(0.0, 0.0, 0.0), None, 7), false), LawMode::Wander);
        assert_eq!(mode(&scene(&[(1.0, 0.0)], AgentState::at(0.0, 0.0, 0.0), Some(0), 7), false), LawMode::Flee);
        assert_eq!(mode(&scene(&[(4.0, 0.0)], AgentState::at(0.0, 0.0, 0.0), Some(0), 7), false), LawMode::Coast);
        // random wanders even once seen.
        assert_eq!(mode(&scene(&[(1.0, 0.0)], AgentState::at(0.0, 0.0, 0.0), Some(0), 7), true), LawMode::Wander);
        // Heading 0.05 into a moving circle 1 m ahead (no emergency): an edge.
        let mut w = scene(&[(-5.0, 0.0)], AgentState::at(0.0, 0.0, 0.05), None, 7);
        w.obstacles = vec![Obstacle::circle(Vec2::new(1.5, 0.0), 0.5, true)];
        assert_eq!(mode(&w, false), LawMode::AvoidEdge);
        // The circle at bearing 1 rad: its interval (0.32, 1.68) leaves the heading 0 free,
        // but fleeing the wolf below (θ_d = π/2) would turn into it within one step: hold.
        let mut w = scene(&[(0.0, -1.0)], AgentState::at(0.0, 0.0, 0.0), Some(0), 7);
        w.obstacles = vec![Obstacle::circle(Vec2::new(1.5 * 1f64.cos(), 1.5 * 1f64.sin()), 0.5, true)];
        assert_eq!(mode(&w, false), LawMode::AvoidHold);
        // A moving circle 0.1 m away: an emergency, whatever the law.
        let mut w = scene(&[(-5.0, 0.0)], AgentState::at(0.0, 0.0, 0.0), None, 7);
        w.obstacles = vec![Obstacle::circle(Vec2::new(0.6, 0.0), 0.5, true)];
        assert_eq!(mode(&w, false), LawMode::Emergency);
        assert_eq!(mode(&w, true), LawMode::Emergency);
    }

    #[test]
    fn still_and_ended_targets_note_their_mode() {
        use crate::config::TargetPolicy;
        use crate::policies::target_desired;
        let mut w = scene(&[(1.0, 0.0)], AgentState::at(0.0, 0.0, 0.0), Some(0), 7);
        let mut mem = Memory::default();
        w.params.policies.targets = TargetPolicy::Still;
        target_desired(0, &w.snap(), &mut mem, &mut Fixed(vec![0.5], 0));
        assert_eq!(mem.mode, LawMode::Still);
        w.params.policies.targets = TargetPolicy::Escape;
        w.captured = vec![true];
        target_desired(0, &w.snap(), &mut mem, &mut Fixed(vec![0.5], 0));
        assert_eq!(mem.mode, LawMode::Ended);
    }
}
