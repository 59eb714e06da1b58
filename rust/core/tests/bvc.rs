//! The bvc law in the world: with a still target in an obstacle-free arena the wolves settle on
//! distinct hunting points (docs/world-and-laws.md §6; issue: within 0.05 m).

use std::sync::Arc;

use wolfpack_core::config::{TargetPolicy, WolfPolicy};
use wolfpack_core::policies::bvc::hunting_points;
use wolfpack_core::world::{Layout, World};
use wolfpack_core::Params;

#[test]
fn wolves_settle_on_distinct_hunting_points_around_a_still_target() {
    let mut p = Params::default();
    p.policies.wolves = WolfPolicy::Bvc;
    p.policies.targets = TargetPolicy::Still;
    p.capture.distance = 0.01; // no capture: let the pack settle
    p.world.max_steps = 400;
    let layouts = [
        vec![[-2.0, -1.0, 0.0], [3.0, -4.0, 1.0], [4.0, 4.0, 2.0], [-3.0, 4.0, 3.0], [0.0, -6.0, 4.0]],
        vec![[-1.0, 0.0, 0.0], [-1.5, 0.5, 0.5], [-1.5, -0.5, 1.0], [-2.0, 0.0, 1.5], [-2.5, 0.8, 2.0]],
    ];
    for wolves in layouts {
        let target = [0.0, 0.0, 0.0];
        let layout = Layout { wolves: wolves.clone(), targets: vec![target], obstacles: vec![] };
        let mut w = World::from_layout(Arc::new(p.clone()), 0, &layout).unwrap();
        // The wolves must start within sensing range of the target or of a partner that senses
        // it; the layouts put at least one wolf within 3 m.
        while !w.is_done() {
            w.step();
        }
        let points = hunting_points(w.targets[0].pos, w.n_wolves(), p.bvc.radius);
        let mut taken = vec![false; points.len()];
        for (i, a) in w.wolves.iter().enumerate() {
            let (k, d) = points.iter().enumerate().map(|(k, q)| (k, (q - a.pos).norm())).min_by(|x, y| x.1.total_cmp(&y.1)).unwrap();
            assert!(d < 0.05, "wolf {i} is {d:.3} m from the nearest hunting point (layout {wolves:?})");
            assert!(!taken[k], "two wolves on hunting point {k}");
            taken[k] = true;
        }
        assert_eq!(w.collisions.iter().sum::<u32>(), 0, "no collisions");
    }
}
