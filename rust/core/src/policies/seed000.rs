//! docs/world-and-laws.md §3 — the `seed000` hunting law (source §1.4, eqs. 4–8).
//!
//! ν_i = α·ν_i1 + β·ν_i2:
//!
//! - attraction ν_i1 ([`attraction`]): towards the target when wolf i senses it,
//!   `(d_ti − r_h)(p_0 − p_i)/d_ti^τ1`; else towards the nearest wolf that senses the same
//!   target, `ς (p_j − p_i) d_ij^τ2`; else the previous step's direction at `lost_speed`
//!   (zero at the very first step);
//! - repulsion ν_i2 ([`repulsion`]): the two nearest other wolves within r_w push along the
//!   x' axis only, `(L·u) u` with `L = Σ (p_i − p_k)/d_ik^τ3` and u the attraction direction
//!   rotated by −π/2 (u = (0, −1) when the attraction is zero);
//!
//! then obstacle avoidance (§4, [`avoidance::wolf`]) and the saturator (§2).
//!
//! Choices the source leaves open, as §3 and §8 settle them:
//! - The fallback's speed 1.5 (`lost_speed`) is the magnitude of ν_i1 itself (before α), so the
//!   fallback keeps the same α/β balance as the other branches; the saturator caps the speed.
//! - Coincident agents (zero distance) contribute a zero vector instead of 0·∞ = NaN.
//! - A zero ν (nothing to do) keeps the current heading as θ_d, with v_d = 0.
//! - Ties in distance go to the lower wolf index (deterministic, never a panic).

use super::avoidance;
use super::saturator::saturate;
use super::{Command, Snapshot};
use crate::math::{angle_of, pow, Vec2};
use crate::scene::LawMode;
/// The seed000 law's memory: its last attraction and its emergency.
pub use crate::scene::Seed000Memory as Memory;

/// The command of wolf `i` for this step. Marks in `row` (wolf i's row of the interaction
/// matrix) every other wolf whose information the law used.
pub fn wolf_command(i: usize, snap: &Snapshot, mem: &mut Memory, row: &mut [u8]) -> Command {
    let (v_d, theta_d) = wolf_desired(i, snap, mem, row);
    let p = snap.params;
    let side = &p.agents.wolf;
    saturate(v_d, theta_d, snap.wolves[i].theta, side.v_max, side.omega_max, p.world.ts)
}

/// The law up to the saturator: the desired (v_d, θ_d) after obstacle avoidance. This is what
/// a learner in `velocity` action mode imitates.
pub fn wolf_desired(i: usize, snap: &Snapshot, mem: &mut Memory, row: &mut [u8]) -> (f64, f64) {
    let p = snap.params;
    let s = &p.seed000;
    let me = snap.wolves[i];

    let (nu1, case) = attraction_case(i, snap, mem.last_attraction, row);
    mem.last_attraction = nu1;
    let nu2 = repulsion(i, snap, nu1, row);
    let nu = s.alpha * nu1 + s.beta * nu2;

    let (v_d, theta_d) = if nu == Vec2::zeros() { (0.0, me.theta) } else { (nu.norm(), angle_of(nu)) };
    let (v, th, mode) = avoidance::wolf_mode(i, snap, v_d, theta_d, &mut mem.danger, row);
    mem.mode = mode.law_mode(case);
    (v, th)
}

/// Attraction ν_i1 (docs/world-and-laws.md §3.1, source eq. 5). `last` is the previous step's ν_i1.
pub fn attraction(i: usize, snap: &Snapshot, last: Vec2, row: &mut [u8]) -> Vec2 {
    attraction_case(i, snap, last, row).0
}

/// [`attraction`] and which of its three cases gave it: [`LawMode::Chase`] (wolf i senses its
/// target), [`LawMode::Follow`] (a partner does) or [`LawMode::Lost`] (nobody does).
pub fn attraction_case(i: usize, snap: &Snapshot, last: Vec2, row: &mut [u8]) -> (Vec2, LawMode) {
    let s = &snap.params.seed000;
    let pi = snap.wolves[i].pos;
    let target = snap.wolf_target[i];
    if snap.wolf_senses[i] {
        let to = snap.targets[target].pos - pi;
        let d = to.norm();
        return (if d > 0.0 { to * ((d - s.radius) / pow(d, s.tau1)) } else { Vec2::zeros() }, LawMode::Chase);
    }
    // Flags from the same snapshot: the nearest wolf that senses wolf i's target.
    if let Some(j) = nearest(i, snap, |j| snap.wolf_senses[j] && snap.wolf_target[j] == target) {
        row[j] = 1;
        let to = snap.wolves[j].pos - pi;
        let d = to.norm();
        return (if d > 0.0 { to * (s.varsigma * pow(d, s.tau2)) } else { Vec2::zeros() }, LawMode::Follow);
    }
    // Nothing sensed: the remembered direction at `lost_speed`; zero before any attraction.
    let n = last.norm();
    (if n > 0.0 { last * (s.lost_speed / n) } else { Vec2::zeros() }, LawMode::Lost)
}

/// The nearest other wolf satisfying `ok` (ties: lowest index).
fn nearest(i: usize, snap: &Snapshot, ok: impl Fn(usize) -> bool) -> Option<usize> {
    let pi = snap.wolves[i].pos;
    let mut best: Option<(f64, usize)> = None;
    for (j, w) in snap.wolves.iter().enumerate() {
        if j == i || !ok(j) {
            continue;
        }
        let d = (w.pos - pi).norm_squared();
        if best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, j));
        }
    }
    best.map(|(_, j)| j)
}

/// The unit vector u of the x' axis: the attraction direction rotated by −π/2 (clockwise);
/// (0, −1) when the attraction is zero (as if it pointed along +y).
pub fn x_axis(nu1: Vec2) -> Vec2 {
    let n = nu1.norm();
    if n > 0.0 {
        Vec2::new(nu1.y, -nu1.x) / n
    } else {
        Vec2::new(0.0, -1.0)
    }
}

/// Repulsion ν_i2 (docs/world-and-laws.md §3.2, source eqs. 6–8, without β): p, q the nearest and
/// second-nearest other wolves; each within r_w adds (p_i − p_k)/d_ik^τ3 to L (and is marked in
/// `row`); ν_i2 = (L·u) u.
pub fn repulsion(i: usize, snap: &Snapshot, nu1: Vec2, row: &mut [u8]) -> Vec2 {
    let s = &snap.params.seed000;
    let rw = snap.params.agents.wolf.sense_radius;
    let pi = snap.wolves[i].pos;
    // The two nearest, by a single pass (ties keep the lower index first).
    let mut two: [Option<(f64, usize)>; 2] = [None, None];
    for (k, w) in snap.wolves.iter().enumerate() {
        if k == i {
            continue;
        }
        let d = (w.pos - pi).norm();
        if two[0].is_none_or(|(b, _)| d < b) {
            two[1] = two[0];
            two[0] = Some((d, k));
        } else if two[1].is_none_or(|(b, _)| d < b) {
            two[1] = Some((d, k));
        }
    }
    let mut l = Vec2::zeros();
    for &(d, k) in two.iter().flatten() {
        if d < rw {
            row[k] = 1;
            if d > 0.0 {
                l += (pi - snap.wolves[k].pos) / pow(d, s.tau3);
            }
        }
    }
    let u = x_axis(nu1);
    u * l.dot(&u)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{FRAC_PI_2, PI};
    use crate::policies::saturator::saturate;
    use crate::scene::{AgentState, Obstacle};

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    fn vclose(a: Vec2, b: Vec2) -> bool {
        (a - b).norm() < 1e-9
    }

    use crate::policies::fixture::Scene as World;

    /// Wolves at the given points (heading 0), one target; sensing flags from r_w = 3.
    fn scene(wolves: &[(f64, f64)], target: (f64, f64)) -> World {
        let t = AgentState::at(target.0, target.1, 0.0);
        let mut w = World::new(World::wolves_at(wolves), vec![t], vec![]);
        w.wolf_senses = w.wolves.iter().map(|a| (a.pos - t.pos).norm() <= 3.0).collect();
        w
    }

    const TAU1: f64 = 2.114010945835207;
    const TAU2: f64 = -0.6788510831700431;
    const TAU3: f64 = 1.0300341638172719;

    // ---- attraction ----

    #[test]
    fn attraction_towards_a_sensed_target() {
        // d = 2: (2 − 0.65)·(2, 0)/2^τ1 = (2.7/2^τ1, 0) = (0.623711…, 0).
        let w = scene(&[(0.0, 0.0)], (2.0, 0.0));
        let mut row = w.row();
        let a = attraction(0, &w.snap(), Vec2::new(5.0, 5.0), &mut row);
        assert!(vclose(a, Vec2::new(2.7 / 2f64.powf(TAU1), 0.0)), "{a}");
        assert!((a.x - 0.6237105).abs() < 1e-6, "{a}");
        assert_eq!(row, [0, 0]);
        // Inside r_h (d = 0.5) the attraction points away: (0.5 − 0.65)·(0.5, 0)/0.5^τ1.
        let w = scene(&[(0.0, 0.0)], (0.5, 0.0));
        let a = attraction(0, &w.snap(), Vec2::zeros(), &mut w.row());
        assert!(vclose(a, Vec2::new(-0.15 * 0.5 / 0.5f64.powf(TAU1), 0.0)), "{a}");
        assert!(a.x < 0.0);
    }

    #[test]
    fn attraction_follows_the_nearest_sensing_partner() {
        // Target at (6, 0), 6 away from wolf 0: not sensed. Wolves 1 (at (6, 2.5), 6.5 from
        // wolf 0) and 2 (at (4, 0), 4 from wolf 0) sense it; wolf 3 at (1, 0) is nearest but
        // does not. Follow wolf 2: ς·(4, 0)·4^τ2 = (0.38694·4·4^−0.67885, 0) = (0.603942, 0).
        let w = scene(&[(0.0, 0.0), (6.0, 2.5), (4.0, 0.0), (1.0, 0.0)], (6.0, 0.0));
        assert_eq!(w.wolf_senses, [false, true, true, false]);
        let mut row = w.row();
        let a = attraction(0, &w.snap(), Vec2::zeros(), &mut row);
        let want = 0.3869405500381927 * 4.0 * 4f64.powf(TAU2);
        assert!((want - 0.603942).abs() < 1e-6, "{want}");
        assert!(vclose(a, Vec2::new(want, 0.0)), "{a} vs {want}");
        assert_eq!(row, [0, 0, 1, 0, 0], "the followed partner is marked");
    }

    #[test]
    fn a_partner_hunting_another_target_is_not_followed() {
        let mut w = scene(&[(0.0, 0.0), (8.0, 0.0)], (10.0, 0.0));
        w.targets.push(AgentState::at(-10.0, 0.0, 0.0));
        w.wolf_target = vec![1, 0];
        w.wolf_senses = vec![false, true];
        let last = Vec2::new(0.0, -2.0);
        let a = attraction(0, &w.snap(), last, &mut [0u8; 4]);
        assert!(vclose(a, Vec2::new(0.0, -1.5)), "fallback, not wolf 1: {a}");
    }

    #[test]
    fn attraction_fallback_keeps_the_direction_at_lost_speed() {
        // Nobody senses: previous (3, 4) → 1.5·(0.6, 0.8) = (0.9, 1.2).
        let w = scene(&[(0.0, 0.0), (1.0, 0.0)], (9.0, 9.0));
        let mut row = w.row();
        let a = attraction(0, &w.snap(), Vec2::new(3.0, 4.0), &mut row);
        assert!(vclose(a, Vec2::new(0.9, 1.2)), "{a}");
        assert_eq!(row, [0, 0, 0]);
        // At the very first step (no previous attraction): zero.
        assert_eq!(attraction(0, &w.snap(), Vec2::zeros(), &mut row), Vec2::zeros());
    }

    #[test]
    fn coincident_agents_do_not_make_nan() {
        let w = scene(&[(1.0, 1.0), (1.0, 1.0)], (1.0, 1.0));
        let a = attraction(0, &w.snap(), Vec2::zeros(), &mut w.row());
        assert_eq!(a, Vec2::zeros());
        let r = repulsion(0, &w.snap(), a, &mut w.row());
        assert_eq!(r, Vec2::zeros());
        let mut mem = Memory::default();
        let c = wolf_command(0, &w.snap(), &mut mem, &mut w.row());
        assert!(c.v.is_finite() && c.omega.is_finite(), "{c:?}");
    }

    // ---- repulsion ----

    #[test]
    fn x_axis_is_attraction_rotated_clockwise() {
        // Attraction along +x → u = (0, −1); along +y → u = (1, 0); zero → (0, −1).
        assert!(vclose(x_axis(Vec2::new(2.0, 0.0)), Vec2::new(0.0, -1.0)));
        assert!(vclose(x_axis(Vec2::new(0.0, 0.5)), Vec2::new(1.0, 0.0)));
        assert_eq!(x_axis(Vec2::zeros()), Vec2::new(0.0, -1.0));
    }

    #[test]
    fn repulsion_with_no_neighbour_in_range() {
        let w = scene(&[(0.0, 0.0), (5.0, 0.0), (0.0, -4.0)], (9.0, 9.0));
        let mut row = w.row();
        assert_eq!(repulsion(0, &w.snap(), Vec2::new(1.0, 0.0), &mut row), Vec2::zeros());
        assert_eq!(row, [0, 0, 0, 0]);
    }

    #[test]
    fn repulsion_with_one_neighbour_in_range() {
        // Attraction +x → u = (0, −1). Neighbour p at (1, 2) (d = √5 < 3), q at (0, −4)
        // (d = 4, out of range). L = (−1, −2)/√5^τ3; L·u = 2/√5^τ3; ν2 = (0, −2/√5^τ3).
        let w = scene(&[(0.0, 0.0), (1.0, 2.0), (0.0, -4.0)], (9.0, 9.0));
        let mut row = w.row();
        let r = repulsion(0, &w.snap(), Vec2::new(1.0, 0.0), &mut row);
        let want = -2.0 / 5f64.sqrt().powf(TAU3);
        assert!(vclose(r, Vec2::new(0.0, want)), "{r} vs {want}");
        assert!((want + 0.873069).abs() < 1e-6, "{want}");
        assert_eq!(row, [0, 1, 0, 0]);
    }

    #[test]
    fn repulsion_with_two_neighbours_in_range_and_a_third_ignored() {
        // Attraction +y → u = (1, 0): only x components count.
        // p = (1, 0) (d = 1): (−1, 0)/1 → −1; q = (−2, 0) (d = 2): (2, 0)/2^τ3 → +2/2^τ3;
        // a third at (0, 2.5) is not among the two nearest. ν2 = (−1 + 2^(1−τ3), 0).
        let w = scene(&[(0.0, 0.0), (1.0, 0.0), (-2.0, 0.0), (0.0, 2.5)], (0.0, 2.0));
        let mut row = w.row();
        let r = repulsion(0, &w.snap(), Vec2::new(0.0, 1.0), &mut row);
        let want = -1.0 + 2f64.powf(1.0 - TAU3);
        assert!(vclose(r, Vec2::new(want, 0.0)), "{r} vs {want}");
        assert_eq!(row, [0, 1, 1, 0, 0]);
    }

    #[test]
    fn repulsion_with_zero_attraction_uses_minus_y() {
        // u = (0, −1); neighbour at (0, 1): L = (0, −1) → L·u = 1 → ν2 = (0, −1).
        let w = scene(&[(0.0, 0.0), (0.0, 1.0)], (9.0, 9.0));
        let r = repulsion(0, &w.snap(), Vec2::zeros(), &mut w.row());
        assert!(vclose(r, Vec2::new(0.0, -1.0)), "{r}");
    }

    #[test]
    fn equal_distances_do_not_panic_and_pick_lower_indices() {
        // Three neighbours at distance 1: p = wolf 1, q = wolf 2 (lowest indices).
        let w = scene(&[(0.0, 0.0), (1.0, 0.0), (-1.0, 0.0), (0.0, 1.0)], (9.0, 9.0));
        let mut row = w.row();
        // u = (0, −1): wolves 1 and 2 push along x only → L·u = 0.
        let r = repulsion(0, &w.snap(), Vec2::new(1.0, 0.0), &mut row);
        assert!(vclose(r, Vec2::zeros()), "{r}");
        assert_eq!(row, [0, 1, 1, 0, 0]);
    }

    // ---- the whole law ----

    #[test]
    fn command_combines_alpha_and_beta_then_saturates() {
        // Wolf 0 at origin heading 0, target at (2, 0); wolf 1 at (0, 2) (d = 2 < r_w).
        // ν1 = (2.7/2^τ1, 0); u = (0, −1); L = (0, −2)/2^τ3 → ν2 = (0, −2/2^τ3).
        // ν = α ν1 + β ν2; no item (wolf 1 is 2 m away, walls far) → saturator.
        let mut w = scene(&[(0.0, 0.0), (0.0, 2.0)], (2.0, 0.0));
        w.wolves[0].theta = 0.0;
        let s = &w.params.seed000;
        let nu = Vec2::new(s.alpha * 2.7 / 2f64.powf(TAU1), -s.beta * 2.0 / 2f64.powf(TAU3));
        let want = saturate(nu.norm(), angle_of(nu), 0.0, 1.5, 7.0, 0.1);
        let mut mem = Memory::default();
        let mut row = w.row();
        let c = wolf_command(0, &w.snap(), &mut mem, &mut row);
        assert!(close(c.v, want.v) && close(c.omega, want.omega), "{c:?} vs {want:?}");
        // Hand values: ν = (3.149962, −2.279580) → θ_d = 2π − 0.626446, e = 0.626446 ≤ k = 0.7
        // → ω = −6.26446; v = min(1.5, 3.888)·(1 − 0.626446/π) = 1.200894.
        assert!((nu.x - 3.149962).abs() < 1e-6 && (nu.y + 2.279580).abs() < 1e-6, "{nu}");
        assert!((c.omega + 6.264457).abs() < 1e-6 && (c.v - 1.200894).abs() < 1e-6, "{c:?}");
        assert_eq!(row, [0, 1, 0], "the repulsion neighbour is marked");
        assert!(vclose(mem.last_attraction, Vec2::new(2.7 / 2f64.powf(TAU1), 0.0)));
    }

    #[test]
    fn zero_desire_keeps_heading_and_stands() {
        // First step, nothing sensed, no neighbour in range: ν = 0 → v = 0, ω = 0.
        let mut w = scene(&[(0.0, 0.0), (5.0, 5.0)], (9.0, -9.0));
        w.wolves[0].theta = FRAC_PI_2;
        let c = wolf_command(0, &w.snap(), &mut Memory::default(), &mut w.row());
        assert_eq!(c, Command { v: 0.0, omega: 0.0 });
    }

    #[test]
    fn fallback_remembers_across_steps() {
        // Sensed at step 1, lost at step 2: the direction of step 1 at 1.5 (then α·1.5 = 7.6
        // → v_max after the saturator when aligned).
        let mut w = scene(&[(0.0, 0.0)], (0.0, 2.0));
        w.wolves[0].theta = FRAC_PI_2;
        let mut mem = Memory::default();
        wolf_command(0, &w.snap(), &mut mem, &mut w.row());
        assert!(mem.last_attraction.y > 0.0 && mem.last_attraction.x == 0.0);
        w.wolf_senses[0] = false;
        let c = wolf_command(0, &w.snap(), &mut mem, &mut w.row());
        assert!(vclose(mem.last_attraction, Vec2::new(0.0, 1.5)));
        assert!(close(c.v, 1.5) && close(c.omega, 0.0), "{c:?}");
        let _ = PI;
    }

    // ---- the law's mode ----

    /// The mode wolf 0's law notes for one step of the scene.
    fn mode_of(w: &World, last: Vec2) -> LawMode {
        let mut mem = Memory { last_attraction: last, ..Default::default() };
        wolf_desired(0, &w.snap(), &mut mem, &mut w.row());
        mem.mode
    }

    #[test]
    fn the_mode_is_the_attraction_case_unless_avoidance_decides() {
        // Senses its target 2 m ahead, nothing in range: chase.
        assert_eq!(mode_of(&scene(&[(0.0, 0.0)], (2.0, 0.0)), Vec2::zeros()), LawMode::Chase);
        // Wolf 2 senses the target, wolf 0 does not; wolf 3 is exactly at partner range (no
        // item) and its push lies across the attraction: follow.
        assert_eq!(mode_of(&scene(&[(0.0, 0.0), (6.0, 2.5), (4.0, 0.0), (1.0, 0.0)], (6.0, 0.0)), Vec2::zeros()), LawMode::Follow);
        // Nobody senses: lost (and at the very first step, with no attraction to keep, too).
        assert_eq!(mode_of(&scene(&[(0.0, 0.0)], (8.0, 0.0)), Vec2::new(1.0, 0.0)), LawMode::Lost);
        assert_eq!(mode_of(&scene(&[(0.0, 0.0)], (8.0, 0.0)), Vec2::zeros()), LawMode::Lost);
        // A static circle straight ahead (no emergency): the heading goes to an edge.
        let mut w = scene(&[(0.0, 0.0)], (2.0, 0.0));
        w.obstacles = vec![Obstacle::circle(Vec2::new(0.7, 0.0), 0.5, false)];
        assert_eq!(mode_of(&w, Vec2::zeros()), LawMode::AvoidEdge);
        // The same circle moving: 0.2 m away, an emergency.
        w.obstacles = vec![Obstacle::circle(Vec2::new(0.7, 0.0), 0.5, true)];
        assert_eq!(mode_of(&w, Vec2::zeros()), LawMode::Emergency);
        // A partner 0.3 m ahead on the way to the target: close-partner steering.
        assert_eq!(mode_of(&scene(&[(0.0, 0.0), (0.3, 0.0)], (2.0, 0.0)), Vec2::zeros()), LawMode::ClosePartner);
        // Four wolves within 0.8 m of the target and a moving circle by wolf 0: early exit.
        let mut w = scene(&[(-0.5, 0.0), (0.5, 0.3), (0.0, 0.6), (0.0, -0.6)], (0.0, 0.0));
        w.obstacles = vec![Obstacle::circle(Vec2::new(-1.2, 0.0), 0.5, true)];
        assert_eq!(mode_of(&w, Vec2::zeros()), LawMode::EarlyExit);
    }

    #[test]
    fn noting_the_mode_changes_no_number() {
        // The law's desired velocity equals avoidance's answer to the attraction and repulsion
        // computed by hand, and the memory's other fields are what they were without a mode.
        let mut w = scene(&[(0.0, 0.0), (0.3, 0.4)], (2.0, 0.0));
        w.obstacles = vec![Obstacle::circle(Vec2::new(0.9, -0.1), 0.5, false)];
        let mut mem = Memory::default();
        let got = wolf_desired(0, &w.snap(), &mut mem, &mut w.row());
        let s = &w.params.seed000;
        let nu1 = attraction(0, &w.snap(), Vec2::zeros(), &mut w.row());
        let nu = s.alpha * nu1 + s.beta * repulsion(0, &w.snap(), nu1, &mut w.row());
        let want = avoidance::wolf(0, &w.snap(), nu.norm(), angle_of(nu), &mut Default::default(), &mut w.row());
        assert_eq!((got.0.to_bits(), got.1.to_bits()), (want.0.to_bits(), want.1.to_bits()));
        assert_eq!(Memory { mode: LawMode::None, ..mem }, Memory { last_attraction: nu1, ..Default::default() });
    }
}
