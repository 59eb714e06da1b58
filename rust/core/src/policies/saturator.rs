//! docs/world-and-laws.md §2 — from a desired velocity (speed v_d, direction θ_d) to a command
//! (v, ω).
//!
//! With heading θ, `k = ω_max Ts` (the largest turn one step can make) and
//! `e = wrap(θ − θ_d)` (how far θ_d lies clockwise of θ):
//!
//! | case | ω | speed factor |
//! |---|---|---|
//! | `k < e ≤ π` | −ω_max | `1 − e/π` |
//! | `π < e < 2π − k` | +ω_max | `1 − (2π − e)/π` |
//! | `e ≤ k` | `(θ_d − θ)/Ts` | `1 − e/π` |
//! | `e ≥ 2π − k` | `(θ_d − θ)/Ts` | `1 − (2π − e)/π` |
//!
//! then ω is unwrapped into [−π/Ts, π/Ts] and `v = min(v_d, v_max)` (v_d is also capped at
//! v_max before the factor). The speed factor is `1 − dif(θ, θ_d)/π` in every case (source
//! eq. 2's `dif`): the agent slows down the more it has to turn, and stops for a U-turn.

use super::Command;
use crate::math::{wrap, wrap_pi, PI, TAU};

/// The saturator of docs/world-and-laws.md §2. Pure; every analytic law ends with it.
///
/// Non-finite or negative `v_d` gives v = 0 (no reverse motion); the result never panics.
pub fn saturate(v_d: f64, theta_d: f64, theta: f64, v_max: f64, omega_max: f64, ts: f64) -> Command {
    let k = omega_max * ts;
    let e = wrap(theta - theta_d);
    // dif(θ, θ_d) of source eq. 2: the unsigned angle between the two headings, in [0, π].
    let dif = if e <= PI { e } else { TAU - e };
    let omega = if e <= k || e >= TAU - k {
        // θ_d is reachable within one step: turn exactly onto it.
        (wrap(theta_d) - wrap(theta)) / ts
    } else if e <= PI {
        // θ_d lies clockwise of θ: turn clockwise at full rate.
        -omega_max
    } else {
        omega_max
    };
    let v_d = if v_d.is_finite() { v_d.clamp(0.0, v_max) } else { 0.0 };
    let v = (v_d * (1.0 - dif / PI)).clamp(0.0, v_max);
    Command { v, omega: unwrap_omega(omega, ts) }
}

/// Maps a turn rate into [−π/Ts, π/Ts] by adding whole turns per step: `(θ_d − θ)/Ts` of two
/// wrapped angles can be up to 2π/Ts in magnitude, and turning the short way round is meant.
#[inline]
pub fn unwrap_omega(omega: f64, ts: f64) -> f64 {
    wrap_pi(omega * ts) / ts
}

/// The heading the agent would have after one step of `saturate`'s turn (the target variant of
/// docs/world-and-laws.md §4.8 simulates it).
#[inline]
pub fn next_heading(theta: f64, cmd: Command, ts: f64) -> f64 {
    wrap(theta + cmd.omega * ts)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TS: f64 = 0.1;
    const WMAX: f64 = 7.0; // k = 0.7 rad
    const VMAX: f64 = 1.5;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn small_clockwise_error_turns_exactly_onto_theta_d() {
        // θ = 1.0, θ_d = 0.5: e = 0.5 ≤ k → ω = (0.5 − 1)/0.1 = −5, v = 1.0·(1 − 0.5/π).
        let c = saturate(1.0, 0.5, 1.0, VMAX, WMAX, TS);
        assert!(close(c.omega, -5.0), "{c:?}");
        assert!(close(c.v, 1.0 - 0.5 / PI), "{c:?}");
    }

    #[test]
    fn small_anticlockwise_error_turns_exactly_onto_theta_d() {
        // θ = 0.5, θ_d = 1.0: e = wrap(−0.5) = 2π − 0.5 ≥ 2π − k → ω = +5,
        // v = 1.0·(1 − (2π − e)/π) = 1 − 0.5/π.
        let c = saturate(1.0, 1.0, 0.5, VMAX, WMAX, TS);
        assert!(close(c.omega, 5.0), "{c:?}");
        assert!(close(c.v, 1.0 - 0.5 / PI), "{c:?}");
    }

    #[test]
    fn large_clockwise_error_turns_at_minus_omega_max() {
        // θ = 2.0, θ_d = 0.0: e = 2.0 ∈ (k, π] → ω = −7, v = 1.2·(1 − 2/π).
        let c = saturate(1.2, 0.0, 2.0, VMAX, WMAX, TS);
        assert!(close(c.omega, -7.0), "{c:?}");
        assert!(close(c.v, 1.2 * (1.0 - 2.0 / PI)), "{c:?}");
    }

    #[test]
    fn large_anticlockwise_error_turns_at_plus_omega_max() {
        // θ = 0, θ_d = 2.0: e = 2π − 2 ∈ (π, 2π − k) → ω = +7, v = 1.2·(1 − 2/π).
        let c = saturate(1.2, 2.0, 0.0, VMAX, WMAX, TS);
        assert!(close(c.omega, 7.0), "{c:?}");
        assert!(close(c.v, 1.2 * (1.0 - 2.0 / PI)), "{c:?}");
    }

    #[test]
    fn exactly_pi_turns_clockwise_and_stops() {
        // e = π falls in the first case (k < e ≤ π): ω = −ω_max, factor 0.
        let c = saturate(1.0, PI, 0.0, VMAX, WMAX, TS);
        assert!(close(c.omega, -7.0) && c.v == 0.0, "{c:?}");
    }

    #[test]
    fn omega_is_unwrapped_across_the_seam() {
        // θ = 0.05, θ_d = 6.2: raw (θ_d − θ)/Ts = 61.5 rad/s; the short way is clockwise by
        // 2π − 6.15 = 0.1332 rad → ω = −1.3319 rad/s.
        let c = saturate(1.0, 6.2, 0.05, VMAX, WMAX, TS);
        let want = (6.2 - 0.05 - TAU) / TS;
        assert!(close(c.omega, want), "{c:?} vs {want}");
        assert!(c.omega.abs() <= PI / TS);
        // And the other way: θ = 6.2, θ_d = 0.05 → +1.3319.
        let c = saturate(1.0, 0.05, 6.2, VMAX, WMAX, TS);
        assert!(close(c.omega, -want), "{c:?}");
    }

    #[test]
    fn unwrap_maps_into_plus_minus_pi_over_ts() {
        assert!(close(unwrap_omega(61.5, TS), (6.15 - TAU) / TS));
        assert!(close(unwrap_omega(-61.5, TS), (TAU - 6.15) / TS));
        assert!(close(unwrap_omega(7.0, TS), 7.0));
    }

    #[test]
    fn speed_is_capped_before_and_after() {
        // v_d = 10 → capped at 1.5 first, then ×(1 − 0.3/π).
        let c = saturate(10.0, 0.0, 0.3, VMAX, WMAX, TS);
        assert!(close(c.v, 1.5 * (1.0 - 0.3 / PI)), "{c:?}");
        let c = saturate(10.0, 0.4, 0.4, VMAX, WMAX, TS);
        assert!(close(c.v, 1.5) && c.omega == 0.0, "{c:?}");
    }

    #[test]
    fn bad_speeds_do_not_reverse_or_panic() {
        assert_eq!(saturate(-1.0, 0.0, 0.0, VMAX, WMAX, TS).v, 0.0);
        assert_eq!(saturate(f64::NAN, 0.0, 0.0, VMAX, WMAX, TS).v, 0.0);
    }

    #[test]
    fn next_heading_applies_one_step() {
        let c = saturate(1.0, 2.0, 0.0, VMAX, WMAX, TS);
        assert!(close(next_heading(0.0, c, TS), 0.7));
    }
}
