//! A learner's action in `[-1, 1]²` ↔ the command it stands for, in either action mode
//! (`env.action_mode`, docs/interface.md).

use crate::config::ActionMode;
use crate::math::{atan2, unit, wrap, Vec2};
use crate::policies::saturator::saturate;
use crate::policies::Command;

/// A learner's action → command. Unicycle: v = (a₀+1)/2·v_max, ω = a₁·ω_max. Velocity: a is
/// a desired velocity in the agent frame in units of v_max (norm capped at 1), through the
/// saturator. Actions are clipped to [-1, 1] first.
pub fn decode(mode: ActionMode, theta: f64, a0: f32, a1: f32, v_max: f64, omega_max: f64, ts: f64) -> Command {
    let (a0, a1) = ((a0 as f64).clamp(-1.0, 1.0), (a1 as f64).clamp(-1.0, 1.0));
    match mode {
        ActionMode::Unicycle => Command { v: (a0 + 1.0) * 0.5 * v_max, omega: a1 * omega_max },
        ActionMode::Velocity => {
            let a = Vec2::new(a0, a1);
            let r = a.norm();
            let theta_d = if r > 0.0 { wrap(theta + atan2(a1, a0)) } else { theta };
            saturate(r.min(1.0) * v_max, theta_d, theta, v_max, omega_max, ts)
        }
    }
}

/// The inverse of [`decode`] for a law's desired (v_d, θ_d): unicycle encodes the saturated
/// command; velocity encodes the desired velocity itself (a zero speed keeps its direction as
/// a 1e-6 norm, so that the saturator still turns).
pub fn encode(mode: ActionMode, theta: f64, v_d: f64, theta_d: f64, v_max: f64, omega_max: f64, ts: f64) -> [f32; 2] {
    match mode {
        ActionMode::Unicycle => {
            let c = saturate(v_d, theta_d, theta, v_max, omega_max, ts);
            [((2.0 * c.v / v_max - 1.0).clamp(-1.0, 1.0)) as f32, ((c.omega / omega_max).clamp(-1.0, 1.0)) as f32]
        }
        ActionMode::Velocity => {
            let r = (v_d / v_max).clamp(1e-6, 1.0);
            let a = unit(theta_d - theta) * r;
            [a.x as f32, a.y as f32]
        }
    }
}
