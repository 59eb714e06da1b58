//! The documented range of every numeric parameter (docs/world-and-laws.md, Appendix,
//! "Parameter ranges").
//!
//! Each range is chosen from what the world and the laws can compute, not merely "> 0": inside
//! it every quantity a step produces — poses, speeds, law terms such as d^τ, energies over a
//! whole episode, rewards summed over an episode — stays a finite `f64`, and the work a
//! parameter implies (spawn attempts, threads, recorded trajectories) stays bounded. The table is
//! the single source: [`check`] walks every numeric leaf of the serialized params and looks its
//! key up here, so a new numeric key without a range fails the unit test that serializes the
//! defaults; `wolfpack._core.param_limits()` hands the same table to Python (docs, tests).

use serde_json::Value;

use crate::error::{Error, Result};
use crate::math::PI;

/// One key's allowed closed range `[lo, hi]`; `lo` is excluded when `open_lo` (a quantity that
/// must be strictly positive). `integer` keys also reject fractions (serde does that already).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limit {
    /// Dotted key path; array elements share their array's key (`world.border`).
    pub key: &'static str,
    pub lo: f64,
    pub hi: f64,
    pub open_lo: bool,
    /// Unit or reading of the bound, shown in the error message.
    pub unit: &'static str,
}

const fn closed(key: &'static str, lo: f64, hi: f64, unit: &'static str) -> Limit {
    Limit { key, lo, hi, open_lo: false, unit }
}

const fn positive(key: &'static str, hi: f64, unit: &'static str) -> Limit {
    Limit { key, lo: 0.0, hi, open_lo: true, unit }
}

/// Law exponents: d^τ for surface distances between 1e-9 m and the largest arena diagonal
/// (~3e4 m) stays within 1e±90, far from overflow even after the gains multiply it.
const EXPONENT: f64 = 10.0;
/// Gains of the laws: with exponents bounded as above, a gain of 1e3 keeps every term < 1e100.
const GAIN: f64 = 1e3;
/// Speeds of agents and obstacles (m/s): a step moves at most 100 m at Ts = 1 s.
const SPEED: f64 = 100.0;
/// Radii and distances of the laws and of sensing (m): the largest arena is 1e4 m across.
const DISTANCE: f64 = 1e4;
/// Reward weights: summed over the longest episode (1e6 steps) they stay below 1e12.
const REWARD: f64 = 1e6;

/// The table. Keep it in the order of `params.yaml`.
pub const LIMITS: &[Limit] = &[
    // world
    closed("world.border", -1e4, 1e4, "m (each coordinate; width and height 1 .. 1e4 m)"),
    positive("world.ts", 1.0, "s"),
    closed("world.max_steps", 1.0, 1e6, "steps (a recorded episode holds a pose per agent per step)"),
    closed("world.wolves", 1.0, 1024.0, "wolves (wolves + targets <= 1024)"),
    closed("world.targets", 1.0, 1024.0, "targets (wolves + targets <= 1024)"),
    closed("world.init_clearance", 0.0, 100.0, "m"),
    closed("world.retarget_period", 1.0, 1e6, "steps"),
    closed("world.spawn_attempts", 1.0, 1e4, "tries per item (bounds the time a failing spawn takes)"),
    closed("world.spawn_restarts", 1.0, 100.0, "layout restarts (bounds the time a failing spawn takes)"),
    // agents
    positive("agents.wolf.v_max", SPEED, "m/s"),
    positive("agents.wolf.omega_max", 100.0, "rad/s"),
    positive("agents.wolf.mass", 1e6, "kg"),
    positive("agents.wolf.sense_radius", DISTANCE, "m"),
    positive("agents.target.v_max", SPEED, "m/s"),
    positive("agents.target.omega_max", 100.0, "rad/s"),
    positive("agents.target.mass", 1e6, "kg"),
    positive("agents.target.sense_radius", DISTANCE, "m"),
    positive("agents.body.base", 10.0, "m"),
    positive("agents.body.height", 10.0, "m"),
    // obstacles
    closed("obstacles.static_circles", 0.0, 10_000.0, "obstacles (all kinds together <= 10000)"),
    closed("obstacles.moving_circles", 0.0, 10_000.0, "obstacles (all kinds together <= 10000)"),
    closed("obstacles.static_polygons", 0.0, 10_000.0, "obstacles (all kinds together <= 10000)"),
    closed("obstacles.moving_polygons", 0.0, 10_000.0, "obstacles (all kinds together <= 10000)"),
    positive("obstacles.circle_radius", 1000.0, "m"),
    positive("obstacles.polygon_size", 1000.0, "m"),
    closed("obstacles.polygon_vertices", 4.0, 256.0, "vertices"),
    positive("obstacles.polygon_inner", 1.0, "(fraction of the radius)"),
    closed("obstacles.rotation_max", 0.0, PI, "rad per step (a larger turn is the same turn the other way)"),
    closed("obstacles.speed_std", 0.0, SPEED, "m/s"),
    // capture
    positive("capture.distance", DISTANCE, "m"),
    closed("capture.count", 1.0, 1024.0, "wolves (at most world.wolves)"),
    positive("capture.arrive_tolerance", DISTANCE, "m"),
    // seed000 (world-and-laws §3)
    closed("seed000.alpha", 0.0, GAIN, "(gain)"),
    closed("seed000.varsigma", 0.0, GAIN, "(gain)"),
    closed("seed000.tau1", -EXPONENT, EXPONENT, "(exponent of d)"),
    closed("seed000.tau2", -EXPONENT, EXPONENT, "(exponent of d)"),
    closed("seed000.tau3", -EXPONENT, EXPONENT, "(exponent of d)"),
    closed("seed000.beta", 0.0, GAIN, "(gain)"),
    positive("seed000.radius", 100.0, "m"),
    closed("seed000.lost_speed", 0.0, SPEED, "m/s"),
    closed("seed000.partner_range", 0.0, DISTANCE, "m"),
    closed("seed000.partner_half_angle", 0.0, PI / 2.0, "rad"),
    closed("seed000.partner_danger", 0.0, 100.0, "m"),
    // bvc (§6)
    positive("bvc.radius", 100.0, "m"),
    closed("bvc.safety_radius", 0.0, 10.0, "m"),
    closed("bvc.d_min", 0.0, 100.0, "m"),
    closed("bvc.assignment_period", 1.0, 1e6, "steps"),
    closed("bvc.disc_sides", 8.0, 1024.0, "sides"),
    // formation (§7)
    positive("formation.radius", 100.0, "m"),
    positive("formation.spacing", 100.0, "m"),
    positive("formation.comm_radius", DISTANCE, "m"),
    positive("formation.detect_radius", DISTANCE, "m"),
    closed("formation.alpha", 0.0, GAIN, "(gain)"),
    closed("formation.beta", 0.0, GAIN, "(gain)"),
    closed("formation.gamma", 0.0, GAIN, "(gain)"),
    closed("formation.k_spacing", 0.0, GAIN, "(gain)"),
    closed("formation.k_obstacle", 0.0, GAIN, "(gain)"),
    positive("formation.bump_delta", 0.999, "(fraction, below 1)"),
    positive("formation.lead", DISTANCE, "m"),
    closed("formation.leader_speed", 0.0, SPEED, "m/s"),
    closed("formation.wolf_diameter", 0.0, 10.0, "m"),
    closed("formation.clearance", 0.0, 100.0, "m"),
    closed("formation.ring_points", 4.0, 256.0, "waypoints"),
    // avoidance (§4)
    positive("avoidance.obstacle_range", 100.0, "m"),
    positive("avoidance.wall_range", 100.0, "m"),
    closed("avoidance.danger_distance", 0.0, 100.0, "m"),
    closed("avoidance.danger_steps", 0.0, 1e6, "steps"),
    closed("avoidance.edge_margin", 0.0, PI / 2.0, "rad"),
    closed("avoidance.early_exit_distance", 0.0, 100.0, "m"),
    positive("avoidance.wolf_single", 100.0, "(widening factor κ)"),
    positive("avoidance.wolf_multi", 100.0, "(widening factor κ)"),
    positive("avoidance.target_single", 100.0, "(widening factor κ)"),
    positive("avoidance.target_multi", 100.0, "(widening factor κ)"),
    // escape (§5)
    closed("escape.wander_speed", 0.0, SPEED, "m/s"),
    closed("escape.wander_turn", 0.0, PI, "rad"),
    positive("escape.fatigue_base", 10.0, "(fraction of v_max)"),
    closed("escape.fatigue_slope", -100.0, 100.0, "1/s"),
    closed("escape.fatigue_delay", -1e6, 1e6, "s"),
    // env
    closed("env.lidar.rays", 0.0, 1024.0, "rays"),
    positive("env.lidar.range", DISTANCE, "m"),
    closed("env.lidar.noise", 0.0, 1.0, "(standard deviation, in units of the range)"),
    closed("env.entities.max_wolves", 1.0, 1024.0, "rows"),
    closed("env.entities.max_targets", 1.0, 1024.0, "rows"),
    closed("env.entities.max_obstacles", 0.0, 1024.0, "rows"),
    positive("env.entities.range", DISTANCE, "m"),
    // rewards
    closed("rewards.wolves.capture_bonus", -REWARD, REWARD, "per event"),
    closed("rewards.wolves.shaping", -REWARD, REWARD, "(weight)"),
    closed("rewards.wolves.collision_penalty", -REWARD, REWARD, "per step"),
    closed("rewards.wolves.time_penalty", -REWARD, REWARD, "per step"),
    closed("rewards.targets.survival", -REWARD, REWARD, "per step"),
    closed("rewards.targets.capture_penalty", -REWARD, REWARD, "per event"),
    closed("rewards.targets.collision_penalty", -REWARD, REWARD, "per step"),
];

/// The limit of a dotted key. Keys of a nested table (the κ rows `avoidance.wolf_single.wall`)
/// fall back to their parent's entry.
pub fn limit_of(key: &str) -> Option<&'static Limit> {
    let mut k = key;
    loop {
        if let Some(l) = LIMITS.iter().find(|l| l.key == k) {
            return Some(l);
        }
        k = &k[..k.rfind('.')?];
    }
}

impl Limit {
    pub fn contains(&self, x: f64) -> bool {
        x.is_finite() && x <= self.hi && if self.open_lo { x > self.lo } else { x >= self.lo }
    }

    /// `(0, 1] s`, `[-10, 10] (exponent of d)`.
    pub fn describe(&self) -> String {
        let open = if self.open_lo { "(" } else { "[" };
        format!("{open}{}, {}] {}", fmt(self.lo), fmt(self.hi), self.unit)
    }
}

fn fmt(x: f64) -> String {
    for (v, name) in [(PI, "pi"), (PI / 2.0, "pi/2")] {
        if x == v {
            return name.into();
        }
    }
    if x != 0.0 && (x.abs() >= 1e4 || x.abs() < 1e-3) {
        format!("{x:e}")
    } else {
        format!("{}", (x * 1e6).round() / 1e6)
    }
}

/// A value exactly as given, in scientific notation when it is very large or small.
fn value(x: f64) -> String {
    if x.is_finite() && x != 0.0 && (x.abs() >= 1e6 || x.abs() < 1e-4) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// Checks every numeric leaf of a serialized params tree against [`LIMITS`]. The error names
/// the key, the allowed range and the value.
pub fn check(tree: &Value) -> Result<()> {
    let mut path = String::new();
    walk(tree, &mut path)
}

fn walk(v: &Value, path: &mut String) -> Result<()> {
    match v {
        Value::Object(map) => {
            for (k, child) in map {
                let len = path.len();
                if !path.is_empty() {
                    path.push('.');
                }
                path.push_str(k);
                walk(child, path)?;
                path.truncate(len);
            }
            Ok(())
        }
        Value::Array(items) => items.iter().enumerate().try_for_each(|(i, child)| {
            let len = path.len();
            path.push_str(&format!("[{i}]"));
            // An element shares its array's limit.
            let r = match child {
                Value::Number(n) => check_number(path, &path[..len], n.as_f64().unwrap_or(f64::NAN)),
                other => walk(other, path),
            };
            path.truncate(len);
            r
        }),
        Value::Number(n) => check_number(path, path, n.as_f64().unwrap_or(f64::NAN)),
        _ => Ok(()),
    }
}

fn check_number(shown: &str, key: &str, x: f64) -> Result<()> {
    let limit = limit_of(key).ok_or_else(|| Error::Params(format!("{shown}: no documented range (a bug: add it to wolfpack_core::limits::LIMITS)")))?;
    if limit.contains(x) {
        Ok(())
    } else {
        Err(Error::Params(format!("{shown}: must be in {}, got {}", limit.describe(), value(x))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Params;

    #[test]
    fn every_numeric_key_of_the_defaults_has_a_range_that_holds_its_default() {
        let tree = serde_json::to_value(Params::default()).unwrap();
        check(&tree).unwrap();
    }

    #[test]
    fn every_entry_names_a_real_key() {
        let tree = serde_json::to_value(Params::default()).unwrap();
        for l in LIMITS {
            let node = l.key.split('.').try_fold(&tree, |node, part| node.get(part));
            assert!(node.is_some(), "{} is not a params key", l.key);
        }
    }

    #[test]
    fn bounds_are_enforced_with_the_key_and_range_named() {
        let mut tree = serde_json::to_value(Params::default()).unwrap();
        tree["seed000"]["tau1"] = 300.0.into();
        let e = check(&tree).unwrap_err().to_string();
        assert!(e.starts_with("seed000.tau1: must be in [-10, 10]"), "{e}");
        tree["seed000"]["tau1"] = 10.0.into();
        check(&tree).unwrap();
        tree["world"]["ts"] = 0.0.into();
        assert!(check(&tree).unwrap_err().to_string().starts_with("world.ts: must be in (0, 1] s"));
        tree["world"]["ts"] = 1.0.into();
        tree["world"]["border"][2] = 2e4.into();
        assert!(check(&tree).unwrap_err().to_string().starts_with("world.border[2]: must be in [-1e4, 1e4]"));
        tree["world"]["border"][2] = 10.0.into();
        tree["avoidance"]["wolf_multi"]["wall"] = 1e308.into();
        assert!(check(&tree).unwrap_err().to_string().starts_with("avoidance.wolf_multi.wall: must be in (0, 100]"));
    }
}
