//! The world of docs/world-and-laws.md §1 without the scripted laws: spawning, layouts, kinematics,
//! the feasibility filter, energy, collisions, capture rules and the clock. Commands are given
//! explicitly (`step_with`), so these tests pin the world alone.

use std::sync::Arc;

use proptest::prelude::*;
use wolfpack_core::config::{CaptureRule, Params};
use wolfpack_core::error::Error;
use wolfpack_core::policies::Command;
use wolfpack_core::world::{Layout, LayoutObstacle, Outcome, World};

fn params() -> Params {
    Params::default()
}

fn layout(wolves: Vec<[f64; 3]>, targets: Vec<[f64; 3]>, obstacles: Vec<LayoutObstacle>) -> Layout {
    Layout { wolves, targets, obstacles }
}

fn cmds(n: usize, v: f64, omega: f64) -> Vec<Command> {
    vec![Command { v, omega }; n]
}

#[test]
fn spawning_is_reproducible_from_the_seed_alone() {
    let p = Arc::new(params());
    let a = World::new(p.clone(), 42).unwrap();
    let b = World::new(p.clone(), 42).unwrap();
    let c = World::new(p, 43).unwrap();
    assert_eq!(a.wolves, b.wolves);
    assert_eq!(a.obstacles, b.obstacles);
    assert_ne!(a.wolves, c.wolves);
}

#[test]
fn spawned_layouts_follow_the_spawn_rules() {
    let p = Arc::new(params());
    for seed in 0..100 {
        let w = World::new(p.clone(), seed).unwrap();
        assert_eq!((w.wolves.len(), w.targets.len(), w.obstacles.len()), (5, 1, 12));
        for a in &w.wolves {
            // central ¾ of [-10, 10]²
            assert!(a.pos.x.abs() <= 7.5 && a.pos.y.abs() <= 7.5, "{:?}", a.pos);
        }
        let t = w.targets[0].pos;
        assert!(w.wolves.iter().any(|a| (a.pos - t).norm() <= 3.0));
        for (k, o) in w.obstacles.iter().enumerate() {
            assert!(o.center.x.abs() <= 8.0 && o.center.y.abs() <= 8.0);
            for a in w.wolves.iter().chain(&w.targets) {
                assert!((a.pos - o.center).norm() > o.radius + 1.5);
            }
            for q in &w.obstacles[..k] {
                assert!((q.center - o.center).norm() > o.radius + 1.5 + q.radius);
            }
        }
        let kinds: Vec<_> = w.obstacles.iter().map(|o| (o.kind.is_circle(), o.kind.is_moving())).collect();
        assert_eq!(kinds.iter().filter(|k| **k == (true, false)).count(), 1);
        assert_eq!(kinds.iter().filter(|k| **k == (false, true)).count(), 5);
    }
}

#[test]
fn an_impossible_layout_fails_quickly_with_a_named_reason() {
    let mut p = params();
    p.obstacles.static_polygons = 500;
    let t0 = std::time::Instant::now();
    let e = World::new(Arc::new(p), 0).unwrap_err();
    assert!(matches!(e, Error::Spawn(_)));
    assert!(e.to_string().contains("static polygon"), "{e}");
    // Bounded by attempts, not by time: generous limit, only to catch a hang.
    assert!(t0.elapsed().as_secs() < 60);
}

#[test]
fn layout_errors_name_the_problem() {
    let p = Arc::new(params());
    let circle = LayoutObstacle::Circle { center: [2.0, 0.0], radius: 1.0, moving: false };
    let cases = [
        (layout(vec![[11.0, 0.0, 0.0]], vec![[0.0, 0.0, 0.0]], vec![]), "outside the arena"),
        (layout(vec![[2.0, 0.5, 0.0]], vec![[0.0, 0.0, 0.0]], vec![circle.clone()]), "wolf 0 overlaps obstacle 0"),
        (layout(vec![[-5.0, 0.0, 0.0]], vec![[2.0, 0.0, 0.0]], vec![circle]), "target 0 overlaps obstacle 0"),
        (layout(vec![[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]], vec![[5.0, 0.0, 0.0]], vec![]), "wolf 1 overlaps wolf 0"),
        (layout(vec![], vec![[5.0, 0.0, 0.0]], vec![]), "at least one wolf"),
        (
            layout(
                vec![[-5.0, 0.0, 0.0]],
                vec![[5.0, 0.0, 0.0]],
                vec![LayoutObstacle::Polygon { center: [0.0, 0.0], vertices: vec![[-1.0, -1.0], [1.0, 1.0], [1.0, -1.0], [-1.0, 1.0]], moving: false }],
            ),
            "edges cross",
        ),
    ];
    for (l, needle) in cases {
        let e = World::from_layout(p.clone(), 0, &l).unwrap_err();
        assert!(matches!(e, Error::Layout(_)), "{e}");
        assert!(e.to_string().contains(needle), "{e} lacks {needle}");
    }
}

#[test]
fn degenerate_or_overlapping_layouts_are_refused_with_the_obstacle_named() {
    let p = Arc::new(params());
    let poly = |center: [f64; 2], vertices: Vec<[f64; 2]>| LayoutObstacle::Polygon { center, vertices, moving: false };
    let square = |cx: f64| poly([cx, 0.0], vec![[cx - 1.0, -1.0], [cx + 1.0, -1.0], [cx + 1.0, 1.0], [cx - 1.0, 1.0]]);
    let agents = |obstacles| layout(vec![[-8.0, -8.0, 0.0]], vec![[8.0, 8.0, 0.0]], obstacles);
    let cases = [
        // The ring bvc's convex hull choked on: a repeated vertex.
        (agents(vec![poly([0.0, 0.0], vec![[-1.0, -1.0], [1.0, -1.0], [1.0, -1.0], [0.0, 1.0]])]), "obstacle 0: degenerate polygon (vertices 1 and 2 coincide)"),
        (agents(vec![poly([0.0, 0.0], vec![[-1.0, 0.0], [0.0, 0.0], [1.0, 0.0]])]), "obstacle 0: degenerate polygon (vertices 2, 0 and 1 are collinear)"),
        (agents(vec![poly([0.0, 0.0], vec![[-1.0, -1.0], [0.0, -1.0], [1.0, -1.0], [0.0, 1.0]])]), "vertices 0, 1 and 2 are collinear"),
        (agents(vec![poly([0.0, 0.0], vec![[0.0, 0.0]; 4])]), "all vertices coincide"),
        (agents(vec![square(0.0), square(1.5)]), "obstacle 1 overlaps obstacle 0"),
        (agents(vec![square(0.0), LayoutObstacle::Circle { center: [0.0, 1.8], radius: 1.0, moving: false }]), "obstacle 1 overlaps obstacle 0"),
        (agents(vec![square(0.0), LayoutObstacle::Circle { center: [0.0, 0.0], radius: 0.2, moving: true }]), "obstacle 1 overlaps obstacle 0"),
        (agents(vec![LayoutObstacle::Circle { center: [9.5, 0.0], radius: 1.0, moving: false }]), "obstacle 0: the circle at [9.5, 0.0] with radius 1 crosses the arena's wall"),
        (agents(vec![LayoutObstacle::Circle { center: [0.0, 0.0], radius: 1e39, moving: false }]), "obstacle 0: radius must be in (0, 1000] m"),
        (layout(vec![[0.0, 0.0, 0.0]], vec![[0.05, 0.0, 0.0]], vec![]), "target 0 overlaps wolf 0"),
        (layout(vec![[0.0, 0.0, 0.0]], vec![[5.0, 0.0, 0.0], [5.05, 0.0, 0.0]], vec![]), "target 1 overlaps target 0"),
    ];
    for (l, needle) in cases {
        let e = World::from_layout(p.clone(), 0, &l).unwrap_err();
        assert!(matches!(e, Error::Layout(_)), "{e}");
        assert!(e.to_string().contains(needle), "{e} lacks {needle}");
    }
    // Neighbours that do not touch are fine, and so is a circle tangent to nothing.
    let ok = agents(vec![square(0.0), square(2.5), LayoutObstacle::Circle { center: [0.0, 3.0], radius: 0.9, moving: false }]);
    World::from_layout(p, 0, &ok).unwrap();
}

#[test]
fn a_layout_sets_the_agent_counts_and_the_derived_capture_count() {
    let l = layout(vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], vec![[5.0, 0.0, 0.0], [-5.0, 0.0, 0.0]], vec![]);
    let w = World::from_layout(Arc::new(params()), 0, &l).unwrap();
    assert_eq!((w.n_wolves(), w.n_targets()), (3, 2));
    assert_eq!(w.params.capture_count(), 3);
    assert_eq!(w.interaction.len(), 25);
}

#[test]
fn unicycle_moves_along_the_old_heading_and_accumulates_energy() {
    let l = layout(vec![[0.0, 0.0, 0.0]], vec![[5.0, 5.0, 0.0]], vec![]);
    let mut w = World::from_layout(Arc::new(params()), 0, &l).unwrap();
    w.step_with(Some(&cmds(1, 1.0, 5.0)), Some(&cmds(1, 0.0, 0.0)));
    let a = w.wolves[0];
    // x += v cos θ_old Ts = 0.1; θ = 0 + 5 · 0.1 = 0.5; energy ½ · 1 · 1².
    assert!((a.pos.x - 0.1).abs() < 1e-15 && a.pos.y.abs() < 1e-15);
    assert!((a.theta - 0.5).abs() < 1e-15);
    assert_eq!((a.v, a.omega), (1.0, 5.0));
    assert!((a.energy - 0.5).abs() < 1e-15);
    w.step_with(Some(&cmds(1, 1.0, 0.0)), Some(&cmds(1, 0.0, 0.0)));
    let b = w.wolves[0];
    assert!((b.pos.x - (0.1 + 0.1 * 0.5f64.cos())).abs() < 1e-15);
    assert!((b.pos.y - 0.1 * 0.5f64.sin()).abs() < 1e-15);
    assert!((b.energy - 1.0).abs() < 1e-15);
}

#[test]
fn commands_are_clamped_to_the_side_limits() {
    let l = layout(vec![[0.0, 0.0, 0.0]], vec![[5.0, 5.0, 0.0]], vec![]);
    let mut w = World::from_layout(Arc::new(params()), 0, &l).unwrap();
    w.step_with(Some(&cmds(1, 9.0, -100.0)), Some(&cmds(1, -3.0, 0.0)));
    assert_eq!(w.wolves[0].v, 1.5);
    assert_eq!(w.wolves[0].omega, -7.0);
    assert_eq!(w.targets[0].v, 0.0);
}

#[test]
fn feasibility_filter_halves_the_speed_until_the_move_fits() {
    // Wolf 0.1 m from the right wall, heading into it at 1.5 m/s (0.15 m per step): halved to
    // 0.75 (0.075 m) which stays strictly inside.
    let l = layout(vec![[9.9, 0.0, 0.0]], vec![[0.0, 5.0, 0.0]], vec![]);
    let mut w = World::from_layout(Arc::new(params()), 0, &l).unwrap();
    w.step_with(Some(&cmds(1, 1.5, 0.0)), Some(&cmds(1, 0.0, 0.0)));
    assert_eq!(w.wolves[0].v, 0.75);
    assert!((w.wolves[0].pos.x - 9.975).abs() < 1e-12);
    // Against the wall: below 0.01 the wolf only turns.
    let l = layout(vec![[9.9999, 0.0, 0.0]], vec![[0.0, 5.0, 0.0]], vec![]);
    let mut w = World::from_layout(Arc::new(params()), 0, &l).unwrap();
    w.step_with(Some(&cmds(1, 1.5, 2.0)), Some(&cmds(1, 0.0, 0.0)));
    assert_eq!(w.wolves[0].v, 0.0);
    assert!((w.wolves[0].theta - 0.2).abs() < 1e-15);
    assert_eq!(w.outcome, Outcome::Running);
}

#[test]
fn feasibility_filter_keeps_wolves_apart_and_off_obstacles() {
    // Wolf 0 drives at wolf 1 (0.35 m ahead, facing away); wolf 1 drives at a circle.
    let circle = LayoutObstacle::Circle { center: [3.0, 0.0], radius: 0.5, moving: false };
    let l = layout(vec![[0.0, 0.0, 0.0], [0.35, 0.0, 0.0]], vec![[-5.0, 5.0, 0.0]], vec![circle]);
    let mut p = params();
    p.obstacles.rotation_max = 0.0;
    let mut w = World::from_layout(Arc::new(p), 0, &l).unwrap();
    for _ in 0..40 {
        w.step_with(Some(&[Command { v: 1.5, omega: 0.0 }, Command { v: 1.5, omega: 0.0 }]), Some(&cmds(1, 0.0, 0.0)));
        assert_eq!(w.outcome, Outcome::Running, "step {}", w.t);
    }
    // Wolf 1's apex (0.2 ahead) stays short of the circle at x = 2.5; wolf 0 behind it.
    assert!(w.wolves[1].pos.x + 0.2 < 2.5 && w.wolves[1].pos.x > 2.2);
    assert!(w.wolves[0].pos.x + 0.2 < w.wolves[1].pos.x);
}

#[test]
fn without_the_filter_a_wolf_can_collide() {
    let circle = LayoutObstacle::Circle { center: [1.0, 0.0], radius: 0.5, moving: false };
    let l = layout(vec![[0.0, 0.0, 0.0]], vec![[-5.0, 5.0, 0.0]], vec![circle]);
    let mut p = params();
    p.world.feasibility_filter = false;
    let mut w = World::from_layout(Arc::new(p), 0, &l).unwrap();
    let mut steps = 0;
    while w.step_with(Some(&cmds(1, 1.5, 0.0)), Some(&cmds(1, 0.0, 0.0))) == Outcome::Running {
        steps += 1;
    }
    assert_eq!(w.outcome, Outcome::Collision);
    // Apex reaches x = 0.5 after 0.3 m of travel: step 2 (0.15 per step).
    assert_eq!(steps + 1, 2);
    assert_eq!(w.collisions[0], 1);
}

#[test]
fn without_the_filter_the_walls_still_hold() {
    // Wolf 0.05 m from the east wall heading into it, target 0.05 m from the north wall.
    let l = layout(vec![[9.95, 0.0, 0.0]], vec![[0.0, 9.95, std::f64::consts::FRAC_PI_2]], vec![]);
    let mut p = params();
    p.world.feasibility_filter = false;
    let mut w = World::from_layout(Arc::new(p), 0, &l).unwrap();
    w.step_with(Some(&cmds(1, 1.5, 2.0)), Some(&cmds(1, 1.5, 0.0)));
    let (a, t) = (w.wolves[0], w.targets[0]);
    assert_eq!((a.pos.x, a.pos.y, a.v), (9.95, 0.0, 0.0), "the wolf stays, only turning");
    assert!((a.theta - 0.2).abs() < 1e-15);
    assert_eq!((t.pos.x, t.pos.y, t.v), (0.0, 9.95, 0.0));
    // A move that stays inside is made as commanded, without halving.
    w.step_with(Some(&cmds(1, 0.2, 0.0)), Some(&cmds(1, 0.0, 0.0)));
    assert!((w.wolves[0].pos.x - (9.95 + 0.02 * 0.2f64.cos())).abs() < 1e-12);
}

fn ring(n: usize, r: f64) -> Vec<[f64; 3]> {
    (0..n)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / n as f64;
            [r * a.cos(), r * a.sin(), a]
        })
        .collect()
}

#[test]
fn capture_needs_count_wolves_within_the_distance() {
    let p = Arc::new(params()); // count = ⌈0.8·5⌉ = 4, distance 0.8
    let mut wolves = ring(3, 0.7);
    wolves.extend([[5.0, 5.0, 0.0], [-5.0, 5.0, 0.0]]);
    let mut w = World::from_layout(p.clone(), 0, &layout(wolves.clone(), vec![[0.0, 0.0, 0.0]], vec![])).unwrap();
    w.step_with(Some(&cmds(5, 0.0, 0.0)), Some(&cmds(1, 0.0, 0.0)));
    assert_eq!(w.outcome, Outcome::Running);
    wolves[3] = [0.0, -0.79, 0.0];
    let mut w = World::from_layout(p, 0, &layout(wolves, vec![[0.0, 0.0, 0.0]], vec![])).unwrap();
    w.step_with(Some(&cmds(5, 0.0, 0.0)), Some(&cmds(1, 0.0, 0.0)));
    assert_eq!(w.outcome, Outcome::Captured);
    assert_eq!(w.capture_step(), Some(1));
}

#[test]
fn encircle_rule_also_needs_the_target_inside_the_hull() {
    let mut p = params();
    p.capture.rule = CaptureRule::Encircle;
    p.capture.count = Some(3);
    let p = Arc::new(p);
    // Three wolves on one side of the target: count met, hull misses the target.
    let one_side = vec![[0.5, -0.5, 0.0], [0.6, 0.0, 0.0], [0.5, 0.5, 0.0], [5.0, 5.0, 0.0], [-5.0, 5.0, 0.0]];
    let mut w = World::from_layout(p.clone(), 0, &layout(one_side, vec![[0.0, 0.0, 0.0]], vec![])).unwrap();
    w.step_with(Some(&cmds(5, 0.0, 0.0)), Some(&cmds(1, 0.0, 0.0)));
    assert_eq!(w.outcome, Outcome::Running);
    let mut around = ring(3, 0.7);
    around.extend([[5.0, 5.0, 0.0], [-5.0, 5.0, 0.0]]);
    let mut w = World::from_layout(p, 0, &layout(around, vec![[0.0, 0.0, 0.0]], vec![])).unwrap();
    w.step_with(Some(&cmds(5, 0.0, 0.0)), Some(&cmds(1, 0.0, 0.0)));
    assert_eq!(w.outcome, Outcome::Captured);
}

#[test]
fn episode_times_out_at_max_steps() {
    let mut p = params();
    p.world.max_steps = 7;
    let l = layout(vec![[0.0, 0.0, 0.0]], vec![[5.0, 5.0, 0.0]], vec![]);
    let mut w = World::from_layout(Arc::new(p), 0, &l).unwrap();
    let mut n = 0;
    while w.step_with(Some(&cmds(1, 0.0, 1.0)), Some(&cmds(1, 0.0, 0.0))) == Outcome::Running {
        n += 1;
    }
    assert_eq!((n + 1, w.t, w.outcome), (7, 7, Outcome::Timeout));
    // A finished world stays put.
    let before = w.wolves.clone();
    w.step_with(Some(&cmds(1, 1.0, 1.0)), Some(&cmds(1, 0.0, 0.0)));
    assert_eq!((w.t, &w.wolves), (7, &before));
}

#[test]
// `row * k + col` spelled out, row 0 and column 0 included, as the matrix is laid out.
#[allow(clippy::erasing_op, clippy::identity_op)]
fn sensing_fills_the_interaction_matrix_and_first_sighting() {
    // Wolf 0 at 2.9 m (senses), wolf 1 at 3.1 m (does not).
    let l = layout(vec![[-2.9, 0.0, 0.0], [3.1, 0.0, 0.0]], vec![[0.0, 0.0, 1.0]], vec![]);
    let mut w = World::from_layout(Arc::new(params()), 0, &l).unwrap();
    w.step_with(Some(&cmds(2, 0.0, 0.0)), Some(&cmds(1, 0.0, 0.0)));
    let k = 3;
    assert_eq!(w.interaction[0 * k + 2], 1);
    assert_eq!(w.interaction[1 * k + 2], 0);
    assert_eq!(w.interaction[2 * k + 0], 1);
    assert_eq!(w.interaction[2 * k + 1], 0);
    assert_eq!(w.target_seen_at[0], Some(0));
    assert_eq!(w.wolf_senses, vec![true, false]);
}

#[test]
fn moving_obstacles_follow_the_seeded_motion_stream() {
    let p = Arc::new(params());
    let mut a = World::new(p.clone(), 9).unwrap();
    let mut b = World::new(p, 9).unwrap();
    // Different controllers, same obstacle motion: motion has its own stream.
    for _ in 0..20 {
        a.step_with(Some(&cmds(5, 0.0, 0.0)), Some(&cmds(1, 0.0, 0.0)));
        b.step_with(Some(&cmds(5, 0.0, 1.0)), Some(&cmds(1, 0.0, -1.0)));
    }
    assert_eq!(a.obstacles, b.obstacles);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// With the feasibility filter on, no command sequence takes a wolf out of the arena, and
    /// headings stay in [0, 2π); obstacles stay inside the arena.
    #[test]
    fn wolves_and_obstacles_stay_inside(seed in 0u64..1000, cmds_seq in proptest::collection::vec((0.0f64..2.0, -8.0f64..8.0), 1..60)) {
        let mut w = World::new(Arc::new(params()), seed).unwrap();
        for (v, om) in cmds_seq {
            let c = vec![Command { v, omega: om }; 5];
            w.step_with(Some(&c), Some(&[Command { v, omega: -om }]));
            for a in w.wolves.iter().chain(&w.targets) {
                prop_assert!(a.pos.x > -10.0 && a.pos.x < 10.0 && a.pos.y > -10.0 && a.pos.y < 10.0);
                prop_assert!(a.theta >= 0.0 && a.theta < std::f64::consts::TAU);
                prop_assert!(a.v >= 0.0 && a.v <= 1.5);
            }
            for o in &w.obstacles {
                prop_assert!(o.center.x.abs() <= 10.0 - o.radius + 1e-9);
                prop_assert!(o.center.y.abs() <= 10.0 - o.radius + 1e-9);
            }
            if w.is_done() { break; }
        }
    }
}

/// The episode runner places only the polygons some agent can reach (`World::lazy_obstacles`):
/// its recorded episodes must equal, bit for bit, the same seeds stepped by hand on worlds
/// that place every polygon after every move, for every wolf law (seed000 is lazy, bvc and
/// formation read every obstacle and get them all placed) and a few obstacle-heavy scenes.
#[test]
fn the_episode_runner_equals_stepping_by_hand_bit_for_bit() {
    use wolfpack_core::config::WolfPolicy;
    use wolfpack_core::episode::run_episodes;
    for (law, polygons) in [(WolfPolicy::Seed000, 5), (WolfPolicy::Seed000, 9), (WolfPolicy::Bvc, 5), (WolfPolicy::Formation, 5)] {
        let mut p = params();
        p.policies.wolves = law;
        p.obstacles.static_polygons = polygons;
        p.obstacles.moving_polygons = polygons;
        p.world.max_steps = 120;
        let runs = run_episodes(&p, 3, 0, 6, None, true, Some(1)).unwrap();
        let p = Arc::new(p);
        for (k, r) in runs.iter().enumerate() {
            let mut w = World::new(p.clone(), 3 + k as u64).unwrap();
            let mut bits = Vec::new();
            let push = |w: &World, bits: &mut Vec<u64>| {
                for a in w.wolves.iter().chain(&w.targets) {
                    bits.extend([a.pos.x, a.pos.y, a.theta, a.v, a.omega].map(f64::to_bits));
                }
            };
            push(&w, &mut bits);
            while !w.is_done() {
                w.step();
                push(&w, &mut bits);
            }
            let t = r.trajectory.as_ref().unwrap();
            let (n, m) = (w.n_wolves(), w.n_targets());
            let mut recorded = Vec::new();
            for row in 0..=r.steps as usize {
                for a in 0..n {
                    recorded.extend(t.wolves[(row * n + a) * 5..(row * n + a + 1) * 5].iter().map(|x| x.to_bits()));
                }
                for a in 0..m {
                    recorded.extend(t.targets[(row * m + a) * 5..(row * m + a + 1) * 5].iter().map(|x| x.to_bits()));
                }
            }
            assert_eq!((r.steps, r.outcome), (w.t, w.outcome), "{law:?} episode {k}");
            assert!(recorded == bits, "{law:?} with {polygons} polygons of each kind, episode {k}: the runner's trajectory differs");
        }
    }
}

/// The recorded law modes (`Trajectory::wolf_modes` / `target_modes`): row 0 is none, every
/// later row holds the mode the world noted in that step, and over an episode each wolf law
/// passes through several of its modes.
#[test]
fn recorded_modes_are_the_steps_modes() {
    use wolfpack_core::config::WolfPolicy;
    use wolfpack_core::episode::run_episodes;
    use wolfpack_core::world::LawMode;
    for law in [WolfPolicy::Seed000, WolfPolicy::Bvc, WolfPolicy::Formation] {
        let mut p = params();
        p.policies.wolves = law;
        p.world.max_steps = 150;
        let runs = run_episodes(&p, 7, 0, 3, None, true, Some(1)).unwrap();
        let p = Arc::new(p);
        let mut seen = std::collections::BTreeSet::new();
        for (k, r) in runs.iter().enumerate() {
            let t = r.trajectory.as_ref().unwrap();
            let (n, m, rows) = (r.wolves, r.targets, r.steps as usize + 1);
            assert_eq!((t.wolf_modes.len(), t.target_modes.len()), (rows * n, rows * m), "{law:?} episode {k}");
            let mut w = World::new(p.clone(), 7 + k as u64).unwrap();
            let mut by_hand: (Vec<u8>, Vec<u8>) = (vec![0; n], vec![0; m]);
            while !w.is_done() {
                w.step();
                by_hand.0.extend(w.wolf_mode.iter().map(|&x| x as u8));
                by_hand.1.extend(w.target_mode.iter().map(|&x| x as u8));
            }
            assert_eq!((&t.wolf_modes, &t.target_modes), (&by_hand.0, &by_hand.1), "{law:?} episode {k}");
            assert!(t.wolf_modes[n..].iter().chain(&t.target_modes[m..]).all(|&c| c != 0 && LawMode::from_code(c).is_some()), "{law:?}: a scripted step without a mode");
            seen.extend(t.wolf_modes[n..].iter().map(|&c| LawMode::from_code(c).unwrap()));
        }
        assert!(seen.len() >= 2, "{law:?} wolves only ever in {seen:?}");
    }
}
