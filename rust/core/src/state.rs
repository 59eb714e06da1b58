//! The global state of a world for centralised critics (CTDE, MAPPO): one fixed-size float32
//! row per world, every entry in [−1, 1].
//!
//! Layout (N wolves, M targets, K obstacle slots = the params' obstacle count), in order:
//!
//! | block | entries per item | meaning |
//! |---|---|---|
//! | wolves, by index | 6 | x̂, ŷ, cos θ, sin θ, v / v_max, ω / ω_max |
//! | targets, by index | 7 | as wolves (target limits), then 1 once its hunt ended (captured, or cornered where that counts), else 0 |
//! | obstacles, by index | 5 | 1 (present), x̂, ŷ, cos φ, sin φ of its centre and angle; all 0 for an empty slot |
//! | clock | 1 | t / max_steps |
//!
//! x̂ = (x − c_x) / h_x, ŷ = (y − c_y) / h_y with c the arena's centre and h its half-extents, so
//! the arena maps onto [−1, 1]². A world started from a layout with fewer obstacles than the
//! params leaves the remaining slots empty; one with more does not fit (an error naming both).
//!
//! With `env.state: entities` the row is instead `max_wolves` wolf rows then `max_targets`
//! target rows of [`ENTITY_STATE_FIELDS`] (by index, the unused ones all 0), then the clock:
//! its size follows the capacities, not the team sizes, as the entity observations do. It holds
//! no obstacles: a centralised critic reads it beside the agent's own observation, whose rows
//! hold the obstacles near that agent.

use crate::config::{ObservationKind, Params};
use crate::error::{Error, Result};
use crate::math::sin_cos;
use crate::world::World;

pub const WOLF_ENTRIES: usize = 6;
pub const TARGET_ENTRIES: usize = 7;
pub const OBSTACLE_ENTRIES: usize = 5;

/// The entries of one agent row of the entity state, in order (x, y as x̂, ŷ above).
pub const ENTITY_STATE_FIELDS: [&str; 10] = ["present", "wolf", "target", "x", "y", "cos_heading", "sin_heading", "speed", "turn_rate", "ended"];

/// Entries in one world's state row.
pub fn state_dim(params: &Params) -> usize {
    if params.env.state == ObservationKind::Entities {
        let e = &params.env.entities;
        return ENTITY_STATE_FIELDS.len() * (e.max_wolves + e.max_targets) + 1;
    }
    WOLF_ENTRIES * params.world.wolves + TARGET_ENTRIES * params.world.targets + OBSTACLE_ENTRIES * params.obstacles.total() + 1
}

/// Writes world `w`'s state row (length [`state_dim`] of the batch's params) into `out`.
pub fn write_state(w: &World, params: &Params, out: &mut [f32]) -> Result<()> {
    if params.env.state == ObservationKind::Entities {
        write_entity_state(w, params, out);
        return Ok(());
    }
    let slots = params.obstacles.total();
    if w.obstacles.len() > slots {
        return Err(Error::Invalid(format!(
            "state: the world has {} obstacles, the state holds {slots} (the params' obstacle counts); give the params at least as many obstacles as the layout",
            w.obstacles.len()
        )));
    }
    debug_assert_eq!(out.len(), state_dim(params));
    let [x0, y0, x1, y1] = params.world.border;
    let (cx, cy, hx, hy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0, (x1 - x0) / 2.0, (y1 - y0) / 2.0);
    let mut k = 0;
    let mut put = |x: f64| {
        out[k] = x as f32;
        k += 1;
    };
    // The headings' sines and cosines from the bodies the step placed (World::heading_sin_cos,
    // the same bits): libm's trigonometry was most of this row's cost.
    let wolf = &params.agents.wolf;
    for (i, a) in w.wolves.iter().enumerate() {
        let (s, c) = w.heading_sin_cos(i);
        for x in [(a.pos.x - cx) / hx, (a.pos.y - cy) / hy, c, s, a.v / wolf.v_max, a.omega / wolf.omega_max] {
            put(x);
        }
    }
    let target = &params.agents.target;
    let n = w.n_wolves();
    for (j, (a, &ended)) in w.targets.iter().zip(&w.target_captured).enumerate() {
        let (s, c) = w.heading_sin_cos(n + j);
        for x in [(a.pos.x - cx) / hx, (a.pos.y - cy) / hy, c, s, a.v / target.v_max, a.omega / target.omega_max, f64::from(u8::from(ended))] {
            put(x);
        }
    }
    for slot in 0..slots {
        match w.obstacles.get(slot) {
            Some(o) => {
                let (s, c) = sin_cos(o.angle);
                for x in [1.0, (o.center.x - cx) / hx, (o.center.y - cy) / hy, c, s] {
                    put(x);
                }
            }
            None => {
                for _ in 0..OBSTACLE_ENTRIES {
                    put(0.0);
                }
            }
        }
    }
    put(f64::from(w.t) / f64::from(params.world.max_steps));
    Ok(())
}

/// The entity form of the state (module docs); the world's agents fit the capacities (the
/// params' validation checks the team sizes against them).
fn write_entity_state(w: &World, params: &Params, out: &mut [f32]) {
    let [x0, y0, x1, y1] = params.world.border;
    let (cx, cy, hx, hy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0, (x1 - x0) / 2.0, (y1 - y0) / 2.0);
    let e = &params.env.entities;
    let width = ENTITY_STATE_FIELDS.len();
    let n = w.n_wolves();
    let (wolf, target) = (&params.agents.wolf, &params.agents.target);
    out.fill(0.0);
    let agents = w.wolves.iter().enumerate().map(|(i, a)| (i, a, i, 1, (wolf.v_max, wolf.omega_max), false));
    let targets = w.targets.iter().enumerate().map(|(j, a)| (n + j, a, e.max_wolves + j, 2, (target.v_max, target.omega_max), w.target_captured[j]));
    for (k, a, slot, kind, (v_max, omega_max), ended) in agents.chain(targets) {
        let (s, c) = w.heading_sin_cos(k);
        let row = &mut out[slot * width..(slot + 1) * width];
        row[0] = 1.0;
        row[kind] = 1.0;
        for (o, x) in row[3..].iter_mut().zip([(a.pos.x - cx) / hx, (a.pos.y - cy) / hy, c, s, a.v / v_max, a.omega / omega_max, f64::from(u8::from(ended))]) {
            *o = x as f32;
        }
    }
    out[width * (e.max_wolves + e.max_targets)] = (f64::from(w.t) / f64::from(params.world.max_steps)) as f32;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{Layout, LayoutObstacle};
    use std::sync::Arc;

    /// After steps (when the headings' sines and cosines come from the bodies the step placed),
    /// each agent's heading entries are cos θ and sin θ of its pose, bit for bit, and each
    /// obstacle's those of its angle.
    #[test]
    fn heading_entries_are_the_poses_cos_and_sin() {
        use crate::math::{cos, sin};
        let mut w = World::new(Arc::new(Params::default()), 7).unwrap();
        let p = w.params.clone();
        let mut row = vec![0.0f32; state_dim(&p)];
        for t in 0..60 {
            w.step();
            write_state(&w, &p, &mut row).unwrap();
            let agents = w.wolves.iter().map(|a| (a.theta, WOLF_ENTRIES)).chain(w.targets.iter().map(|a| (a.theta, TARGET_ENTRIES)));
            let mut k = 0;
            for (i, (theta, entries)) in agents.enumerate() {
                assert_eq!((row[k + 2], row[k + 3]), (cos(theta) as f32, sin(theta) as f32), "step {t}, agent {i}");
                k += entries;
            }
            for (i, o) in w.obstacles.iter().enumerate() {
                let at = k + i * OBSTACLE_ENTRIES;
                assert_eq!((row[at + 3], row[at + 4]), (cos(o.angle) as f32, sin(o.angle) as f32), "step {t}, obstacle {i}");
            }
        }
    }

    #[test]
    fn state_row_by_hand() {
        // Arena [-10, -10, 10, 10] → centre 0, half-extents 10. One wolf at (5, -2) heading
        // π/2, one target at (-10 + 1, 4) heading 0, one circle at (0, 8); params hold 2
        // obstacle slots, so the second is empty.
        let mut p = Params::default();
        p.obstacles.static_circles = 1;
        p.obstacles.moving_circles = 1;
        p.obstacles.static_polygons = 0;
        p.obstacles.moving_polygons = 0;
        let l = Layout {
            wolves: vec![[5.0, -2.0, std::f64::consts::FRAC_PI_2]],
            targets: vec![[-9.0, 4.0, 0.0]],
            obstacles: vec![LayoutObstacle::Circle { center: [0.0, 8.0], radius: 0.5, moving: false }],
        };
        let w = World::from_layout(Arc::new(p.clone()), 0, &l).unwrap();
        let p1 = w.params.as_ref();
        assert_eq!(state_dim(p1), 6 + 7 + 2 * 5 + 1);
        let mut row = vec![9.0f32; state_dim(p1)];
        write_state(&w, p1, &mut row).unwrap();
        let want = [0.5, -0.2, 0.0, 1.0, 0.0, 0.0, -0.9, 0.4, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.8, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        for (k, (g, e)) in row.iter().zip(want).enumerate() {
            assert!((g - e).abs() < 1e-6, "entry {k}: {g} vs {e}");
        }
        // More obstacles than slots: an error, not a truncated state.
        let mut few = p;
        few.obstacles.moving_circles = 0;
        let w =
            World::from_layout(Arc::new(few.clone()), 0, &Layout { obstacles: vec![l.obstacles[0].clone(), LayoutObstacle::Circle { center: [0.0, -8.0], radius: 0.5, moving: false }], ..l }).unwrap();
        let pw = w.params.clone();
        let mut row = vec![0.0f32; state_dim(&pw)];
        assert!(write_state(&w, &pw, &mut row).unwrap_err().to_string().contains("2 obstacles"));
    }
}
