//! The formation law in the world: with a still target in an obstacle-free arena the
//! formation converges to the ring of slots around it (docs/world-and-laws.md §7.1).

use std::sync::Arc;

use wolfpack_core::config::{TargetPolicy, WolfPolicy};
use wolfpack_core::world::{Layout, World};
use wolfpack_core::Params;

#[test]
fn formation_converges_to_the_ring_around_a_still_target() {
    let mut p = Params::default();
    p.policies.wolves = WolfPolicy::Formation;
    p.policies.targets = TargetPolicy::Still;
    p.capture.distance = 0.01; // no capture: let the formation settle
    p.world.max_steps = 400;
    let wolves = vec![[-2.0, -1.0, 0.0], [3.0, -4.0, 1.0], [4.0, 4.0, 2.0], [-3.0, 4.0, 3.0], [0.0, -6.0, 4.0]];
    let layout = Layout { wolves, targets: vec![[0.5, 0.5, 0.0]], obstacles: vec![] };
    let mut w = World::from_layout(Arc::new(p.clone()), 0, &layout).unwrap();
    while !w.is_done() {
        w.step();
    }
    let n = w.n_wolves();
    let target = w.targets[0].pos;
    for (i, a) in w.wolves.iter().enumerate() {
        let angle = std::f64::consts::TAU * i as f64 / n as f64;
        let slot = target + p.formation.radius * wolfpack_core::math::Vec2::new(angle.cos(), angle.sin());
        let off = (a.pos - slot).norm();
        assert!(off < 0.1, "wolf {i} is {off:.3} m from its slot");
        assert!(a.v < 0.05, "wolf {i} still moving at {:.3} m/s", a.v);
    }
    assert_eq!(w.collisions.iter().sum::<u32>(), 0);
}
