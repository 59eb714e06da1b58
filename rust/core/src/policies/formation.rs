//! The `formation` law (docs/world-and-laws.md §7; source `002_1b59bc6eab955b77.txt`): obstacle
//! graph, visibility path for a virtual leader, potential-field formation.
//!
//! Planning:
//!
//! - [`obstacle_nodes`]: every obstacle is a node, its bounding disc (source step 13).
//! - [`adjacency`]: two nodes are joined when a wolf cannot pass between them — centre
//!   distance ≤ r_i + r_j + the wolf's largest diameter (r_safe of step 13).
//! - [`structures`]: the connected components ("merged structures", step 2).
//! - [`plan_path`]: the virtual leader's path (step 3). The source draws tangent segments from
//!   the leader to the outermost nodes of the structure in the way, drops those that cross it,
//!   repeats from every tangent node until the goal is visible, and keeps the shortest
//!   polyline. Here the candidate polylines are all polylines through points on a ring around
//!   every node (K points on a circle circumscribing the node's disc inflated by a clearance, so
//!   that the chord between neighbouring points stays outside it) whose segments cross no node;
//!   the shortest is found exactly by Dijkstra's algorithm (`pathfinding`). It contains the
//!   source's tangent polylines up to the ring's resolution and cannot cross a structure:
//!   every disc is inflated by the clearance, which validation keeps ≥ half the wolf's
//!   diameter, so no path passes between two members of a merged structure (their gap is at
//!   most the diameter).
//!
//! Control (step 6), for wolf i with position q_i and velocity p_i (its unicycle velocity):
//!
//! - Virtual leader: the point `formation.lead` metres along the planned path from the pack's
//!   centroid to the target (the target itself when nearer), moving at `formation.leader_speed`
//!   along the path. It is a function of the snapshot (every wolf computes the same leader;
//!   nothing is carried between steps), re-planned every step as the target moves.
//! - Slots: wolf i's slot is q_r + r_h (cos(2πi/N), sin(2πi/N)), a ring of radius r_h around
//!   the leader; on arrival the leader is the target and the ring encircles it.
//! - u_i = f_α + f_β + f_γ with
//!   f_α = −Σ_j a_ij [φ1(‖q_i − q_j‖) h(‖q_i − q_j‖ / r) (q_i − q_j) + γ (p_i − p_j)],
//!   f_β = −Σ_k b_ik [φ2(s_ik) h(s_ik / r′) (q_i − q_ok) / ‖q_i − q_ok‖ + β p_i],
//!   f_γ = −α [(q_i − q_slot) + γ (p_i − p_r)];
//!   a_ij = 1 within the communication radius r, b_ik = 1 when obstacle k's surface is within
//!   the detection radius r′ (s_ik: surface distance).
//! - Potentials (the source shows them only as images; §7.2 takes standard smooth forms):
//!   spacing φ1(z) = k_α (1 − d/z), the gradient of ½ k_α (z − d)² along q_i − q_j, so the
//!   spacing potential has its minimum at the spacing d; obstacle φ2(s) = −k_β (1/s − 1/r′) / s²
//!   (the classic repulsive potential ½ k_β (1/s − 1/r′)², zero at r′); bump h(x) = 1 on
//!   [0, δ), ½ (1 + cos(π (x − δ)/(1 − δ))) on [δ, 1], 0 beyond (Olfati-Saber 2006).
//! - Double integrator: the desired velocity is p_i + u_i Ts (norm capped at v_max), then the
//!   saturator (§2).

use pathfinding::directed::dijkstra::dijkstra;
use pathfinding::undirected::connected_components::connected_components;

use super::Snapshot;
use crate::config::FormationParams;
use crate::math::{angle_of, cos, sin, unit, Vec2};
/// The formation law's memory: the pack's last sighting.
pub use crate::scene::FormationMemory as Memory;
use crate::scene::{LawMode, Obstacle};

/// A node of the obstacle graph: an obstacle's bounding disc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disc {
    pub center: Vec2,
    pub radius: f64,
}

/// The bounding disc of every obstacle, in obstacle order.
pub fn obstacle_nodes(obstacles: &[Obstacle]) -> Vec<Disc> {
    obstacles.iter().map(|o| Disc { center: o.center, radius: o.radius }).collect()
}

/// Neighbours of every node: j is a neighbour of i when the gap between their discs is at
/// most `wolf_diameter` (no wolf fits through).
pub fn adjacency(nodes: &[Disc], wolf_diameter: f64) -> Vec<Vec<usize>> {
    (0..nodes.len()).map(|i| (0..nodes.len()).filter(|&j| j != i && (nodes[i].center - nodes[j].center).norm() <= nodes[i].radius + nodes[j].radius + wolf_diameter).collect()).collect()
}

/// The merged structures: connected components of the obstacle graph, each sorted, ordered by
/// their smallest node (deterministic, whatever the hash order inside `pathfinding`).
pub fn structures(adjacency: &[Vec<usize>]) -> Vec<Vec<usize>> {
    let starts: Vec<usize> = (0..adjacency.len()).collect();
    let mut out: Vec<Vec<usize>> = connected_components(&starts, |&i| adjacency[i].clone())
        .into_iter()
        .map(|set| {
            let mut v: Vec<usize> = set.into_iter().collect();
            v.sort_unstable();
            v
        })
        .collect();
    out.sort_by_key(|v| v[0]);
    out
}

/// Distance from point `c` to the segment `a`–`b`.
pub fn segment_point_distance(a: Vec2, b: Vec2, c: Vec2) -> f64 {
    let ab = b - a;
    let len2 = ab.norm_squared();
    let t = if len2 > 0.0 { ((c - a).dot(&ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (a + t * ab - c).norm()
}

/// Whether segment `a`–`b` comes closer than `radius` to `center`.
fn blocked(a: Vec2, b: Vec2, discs: &[Disc], clearance: f64) -> bool {
    discs.iter().any(|d| segment_point_distance(a, b, d.center) < d.radius + clearance)
}

/// Path lengths are compared in whole micrometres (Dijkstra needs ordered costs).
const COST_UNIT: f64 = 1e-6;

/// The virtual leader's path from `start` to `goal` around the `nodes`, keeping `clearance`
/// from every disc: a polyline (start first, goal last) whose segments cross no inflated disc,
/// the shortest over the candidates through `ring_points` points around every disc. Discs
/// whose inflated interior holds the start or the goal are ignored (the leader is already
/// there, or the target sits against an obstacle). With no collision-free candidate the path
/// is the straight segment.
pub fn plan_path(start: Vec2, goal: Vec2, nodes: &[Disc], clearance: f64, ring_points: usize) -> Vec<Vec2> {
    let discs: Vec<Disc> = nodes.iter().copied().filter(|d| (start - d.center).norm() >= d.radius + clearance && (goal - d.center).norm() >= d.radius + clearance).collect();
    if !blocked(start, goal, &discs, clearance) {
        return vec![start, goal];
    }
    // Waypoints: start (0), goal (1), then the rings. A ring point lies on a circle of radius
    // (r + clearance) / cos(π/K), a hair beyond, so that chords between neighbours clear the
    // inflated disc; points inside another inflated disc are useless and dropped.
    let k = ring_points.max(3);
    let stretch = 1.0 / cos(std::f64::consts::PI / k as f64) * (1.0 + 1e-9);
    let mut points = vec![start, goal];
    for d in &discs {
        for m in 0..k {
            let a = std::f64::consts::TAU * m as f64 / k as f64;
            let p = d.center + (d.radius + clearance) * stretch * Vec2::new(cos(a), sin(a));
            if !discs.iter().any(|o| (p - o.center).norm() < o.radius + clearance) {
                points.push(p);
            }
        }
    }
    let cost = |a: Vec2, b: Vec2| ((a - b).norm() / COST_UNIT).round() as u64;
    let found =
        dijkstra(&0usize, |&i| (0..points.len()).filter(|&j| j != i && !blocked(points[i], points[j], &discs, clearance)).map(|j| (j, cost(points[i], points[j]))).collect::<Vec<_>>(), |&i| i == 1);
    match found {
        Some((path, _)) => path.into_iter().map(|i| points[i]).collect(),
        None => vec![start, goal],
    }
}

/// Length of a polyline.
pub fn path_length(path: &[Vec2]) -> f64 {
    path.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
}

/// The bump function h(x) with parameter δ ∈ (0, 1).
pub fn bump(x: f64, delta: f64) -> f64 {
    if x < delta {
        1.0 // x < 0 included
    } else if x <= 1.0 {
        0.5 * (1.0 + cos(std::f64::consts::PI * (x - delta) / (1.0 - delta)))
    } else {
        0.0
    }
}

/// The spacing term φ1(z) = k (1 − d/z): negative (repulsive) below the spacing d, positive
/// (attractive) above; φ1(z)·z is the derivative of ½ k (z − d)².
pub fn phi1(z: f64, spacing: f64, k: f64) -> f64 {
    k * (1.0 - spacing / z.max(1e-9))
}

/// The obstacle term φ2(s) = −k (1/s − 1/r′) / s² for a surface distance s < r′, else 0.
pub fn phi2(s: f64, detect: f64, k: f64) -> f64 {
    let s = s.max(1e-3);
    if s >= detect {
        0.0
    } else {
        -k * (1.0 / s - 1.0 / detect) / (s * s)
    }
}

/// The spacing potential ½ k (z − d)², whose gradient gives [`phi1`] (for tests and plots).
pub fn spacing_potential(z: f64, spacing: f64, k: f64) -> f64 {
    0.5 * k * (z - spacing).powi(2)
}

/// The virtual leader for a pack centred at `centroid` hunting at `target`: its position and
/// velocity, and whether it is the target itself (the path is shorter than `formation.lead`).
/// Memoised per thread (every wolf of the pack asks for the same leader each step: one path
/// search per pack instead of one per wolf, no result changes; BENCHMARKS.md, "Optimisations").
pub fn leader(centroid: Vec2, target: Vec2, obstacles: &[Obstacle], f: &FormationParams) -> (Vec2, Vec2, bool) {
    let mut key = vec![centroid.x, centroid.y, target.x, target.y, f.clearance, f.lead, f.leader_speed, f.ring_points as f64];
    key.extend(obstacles.iter().flat_map(|o| [o.center.x, o.center.y, o.radius]));
    thread_local! {
        static LAST: std::cell::RefCell<super::LastCall<(Vec2, Vec2, bool)>> = const { std::cell::RefCell::new(super::LastCall::new()) };
    }
    LAST.with(|c| c.borrow_mut().get_or(key, || leader_uncached(centroid, target, obstacles, f)))
}

fn leader_uncached(centroid: Vec2, target: Vec2, obstacles: &[Obstacle], f: &FormationParams) -> (Vec2, Vec2, bool) {
    let path = plan_path(centroid, target, &obstacle_nodes(obstacles), f.clearance, f.ring_points);
    // The point `lead` metres along the path (or the target).
    let mut left = f.lead;
    for w in path.windows(2) {
        let seg = w[1] - w[0];
        let len = seg.norm();
        if len >= left && len > 0.0 {
            let dir = seg / len;
            return (w[0] + dir * left, dir * f.leader_speed, false);
        }
        left -= len;
    }
    (target, Vec2::zeros(), true)
}

fn velocity(a: &crate::scene::AgentState) -> Vec2 {
    a.v * unit(a.theta)
}

/// The formation law up to the saturator: wolf i's desired (v_d, θ_d).
pub fn wolf_desired(i: usize, snap: &Snapshot, mem: &mut Memory, row: &mut [u8]) -> (f64, f64) {
    let p = snap.params;
    let f = &p.formation;
    let me = snap.wolves[i];
    let n = snap.wolves.len();
    let Some(seen) = mem.sighting.share(i, snap) else {
        mem.mode = LawMode::Wait;
        return (0.0, me.theta);
    };
    // While nobody senses the target, the pack heads for where it would be had it kept its
    // last sensed velocity (inside the arena), not for where it was last seen.
    let [x0, y0, x1, y1] = p.world.border;
    let since = snap.t.saturating_sub(mem.sighting.t) as f64 * p.world.ts;
    let predicted = seen.pos + velocity(&seen) * since;
    let target_pos = Vec2::new(predicted.x.clamp(x0, x1), predicted.y.clamp(y0, y1));
    let centroid = snap.wolves.iter().map(|w| w.pos).sum::<Vec2>() / n as f64;
    let (q_r, p_r, at_target) = leader(centroid, target_pos, snap.obstacles, f);
    mem.mode = match (mem.sighting.is_now(snap), at_target) {
        (false, _) => LawMode::Lost,
        (true, true) => LawMode::Encircle,
        (true, false) => LawMode::Lead,
    };
    let angle = std::f64::consts::TAU * i as f64 / n as f64;
    // A slot beyond a wall (the target against it) moves inside, along the wall: a wolf
    // driving at the wall only stalls in the feasibility filter.
    let ring = q_r + f.radius * Vec2::new(cos(angle), sin(angle));
    // The margin never exceeds half the arena (a clearance wider than a small arena would make
    // an empty clamp range): then the slot sits on the arena's middle line.
    let (mx, my) = (f.clearance.min((x1 - x0) / 2.0), f.clearance.min((y1 - y0) / 2.0));
    let slot = Vec2::new(ring.x.clamp(x0 + mx, x1 - mx), ring.y.clamp(y0 + my, y1 - my));
    let (q_i, p_i) = (me.pos, velocity(&me));

    let mut u = -f.alpha * ((q_i - slot) + f.gamma * (p_i - p_r));
    for (j, other) in snap.wolves.iter().enumerate() {
        let d = q_i - other.pos;
        let z = d.norm();
        if j == i || z > f.comm_radius {
            continue;
        }
        row[j] = 1;
        u -= phi1(z, f.spacing, f.k_spacing) * bump(z / f.comm_radius, f.bump_delta) * d + f.gamma * (p_i - velocity(other));
    }
    for ob in snap.obstacles {
        let s = ob.distance(q_i);
        if s > f.detect_radius {
            continue;
        }
        let d = q_i - ob.center;
        let z = d.norm().max(1e-9);
        u -= phi2(s, f.detect_radius, f.k_obstacle) * bump(s / f.detect_radius, f.bump_delta) * (d / z) + f.beta * p_i;
    }
    let mut desired = p_i + u * p.world.ts;
    let v_max = p.agents.wolf.v_max;
    if desired.norm() > v_max {
        desired *= v_max / desired.norm();
    }
    // Arrive without overshooting the slot when the leader stands still.
    let v = desired.norm();
    if v <= 1e-9 {
        return (0.0, me.theta);
    }
    (v, angle_of(desired))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn v(x: f64, y: f64) -> Vec2 {
        Vec2::new(x, y)
    }

    fn disc(x: f64, y: f64, r: f64) -> Disc {
        Disc { center: v(x, y), radius: r }
    }

    #[test]
    fn graph_and_structures_on_a_hand_built_layout() {
        // 0–1: gap 0.2 ≤ 0.3 (joined); 1–2: gap 0.25 (joined); 2–3: gap 0.5 (apart);
        // 4 far away; 5 overlaps 4.
        let nodes = [disc(0.0, 0.0, 1.0), disc(2.2, 0.0, 1.0), disc(3.95, 0.0, 0.5), disc(5.0, 0.0, 0.05), disc(10.0, 10.0, 1.0), disc(10.5, 10.0, 1.0)];
        let adj = adjacency(&nodes, 0.3);
        assert_eq!(adj[0], vec![1]);
        assert_eq!(adj[1], vec![0, 2]);
        assert_eq!(adj[2], vec![1]);
        assert!(adj[3].is_empty());
        assert_eq!(adj[4], vec![5]);
        assert_eq!(structures(&adj), vec![vec![0, 1, 2], vec![3], vec![4, 5]]);
    }

    #[test]
    fn straight_when_nothing_is_in_the_way() {
        let path = plan_path(v(-5.0, 0.0), v(5.0, 0.0), &[disc(0.0, 3.0, 1.0)], 0.2, 16);
        assert_eq!(path, vec![v(-5.0, 0.0), v(5.0, 0.0)]);
    }

    #[test]
    fn around_one_disc_the_path_is_the_tangent_arc_path_up_to_the_ring() {
        // Start and goal 5 m either side of a disc of radius 1 (+ clearance 0.2): the shortest
        // path is two tangents and an arc, 2·sqrt(d² − R²) + R·(π − 2·acos(R/d)).
        let (d, r) = (5.0f64, 1.2f64);
        let exact = 2.0 * (d * d - r * r).sqrt() + r * (std::f64::consts::PI - 2.0 * (r / d).acos());
        let path = plan_path(v(-d, 0.0), v(d, 0.0), &[disc(0.0, 0.0, 1.0)], 0.2, 32);
        let len = path_length(&path);
        assert!(len >= exact - 1e-9, "{len} shorter than the exact {exact}");
        assert!(len <= exact * 1.01, "{len} vs exact {exact}");
        for w in path.windows(2) {
            assert!(segment_point_distance(w[0], w[1], v(0.0, 0.0)) >= 1.2 - 1e-9);
        }
    }

    #[test]
    fn the_shorter_side_of_a_merged_wall_is_taken() {
        // A wall of three touching discs from y = -1 to y = 5: going round the bottom end is
        // shorter than round the top.
        let wall = [disc(0.0, 0.0, 1.0), disc(0.0, 2.0, 1.0), disc(0.0, 4.0, 1.0)];
        let path = plan_path(v(-4.0, 0.0), v(4.0, 0.0), &wall, 0.2, 24);
        assert!(path.iter().all(|p| p.y < 1.0), "went round the top: {path:?}");
        assert_eq!(structures(&adjacency(&wall, 0.3)), vec![vec![0, 1, 2]]);
    }

    #[test]
    fn spacing_potential_has_its_minimum_at_the_spacing() {
        let (d, k) = (0.7, 1.3);
        let at = spacing_potential(d, d, k);
        for z in [0.2, 0.5, 0.69, 0.71, 1.0, 2.0] {
            assert!(spacing_potential(z, d, k) > at);
        }
        // φ1 changes sign there: repulsive below, attractive above, zero at d
        assert!(phi1(0.5, d, k) < 0.0 && phi1(1.0, d, k) > 0.0 && phi1(d, d, k).abs() < 1e-12);
        // φ1(z)·z is the potential's derivative (central difference)
        let z = 1.1;
        let numeric = (spacing_potential(z + 1e-6, d, k) - spacing_potential(z - 1e-6, d, k)) / 2e-6;
        assert!((phi1(z, d, k) * z - numeric).abs() < 1e-6);
    }

    #[test]
    fn bump_and_obstacle_terms() {
        assert_eq!(bump(0.1, 0.2), 1.0);
        assert!((bump(0.6, 0.2) - 0.5).abs() < 1e-12);
        assert_eq!(bump(1.0, 0.2), 0.0);
        assert_eq!(bump(1.5, 0.2), 0.0);
        assert_eq!(phi2(1.5, 1.5, 1.0), 0.0);
        assert!(phi2(0.5, 1.5, 1.0) < phi2(1.0, 1.5, 1.0) && phi2(1.0, 1.5, 1.0) < 0.0, "repulsion grows towards the obstacle");
    }

    proptest! {
        #[test]
        fn planned_paths_never_cross_a_disc(
            discs in prop::collection::vec((-8.0..8.0f64, -8.0..8.0f64, 0.2..1.5f64), 1..8),
            sx in -9.0..9.0f64, sy in -9.0..9.0f64, gx in -9.0..9.0f64, gy in -9.0..9.0f64,
        ) {
            let nodes: Vec<Disc> = discs.iter().map(|&(x, y, r)| disc(x, y, r)).collect();
            let (start, goal, clearance) = (v(sx, sy), v(gx, gy), 0.2);
            for d in &nodes {
                prop_assume!((start - d.center).norm() > d.radius + clearance + 1e-3);
                prop_assume!((goal - d.center).norm() > d.radius + clearance + 1e-3);
            }
            let path = plan_path(start, goal, &nodes, clearance, 16);
            prop_assert_eq!(path[0], start);
            prop_assert_eq!(*path.last().unwrap(), goal);
            let straight = (goal - start).norm();
            prop_assert!(path_length(&path) >= straight - 1e-9);
            if path.len() > 2 || !blocked(start, goal, &nodes, clearance) {
                for w in path.windows(2) {
                    for d in &nodes {
                        prop_assert!(segment_point_distance(w[0], w[1], d.center) >= d.radius + clearance - 1e-6, "segment {:?} crosses {:?}", w, d);
                    }
                }
            }
        }
    }

    // ---- the law's mode ----

    use crate::policies::fixture::Scene;
    use crate::scene::AgentState;

    #[test]
    fn the_mode_follows_the_leader_case_and_the_sighting() {
        let mut s = Scene::new(Scene::wolves_at(&[(0.0, 0.0), (0.5, 0.0)]), vec![AgentState::at(8.0, 0.0, 0.0)], vec![]);
        let mut mem = Memory::default();
        // No sighting yet: stand.
        assert_eq!(wolf_desired(0, &s.snap(), &mut mem, &mut s.row()), (0.0, 0.0));
        assert_eq!(mem.mode, LawMode::Wait);
        // Sensed 8 m away: the leader runs 5 m along the path, short of the target.
        s.wolf_senses = vec![false, true];
        wolf_desired(0, &s.snap(), &mut mem, &mut s.row());
        assert_eq!(mem.mode, LawMode::Lead);
        // Sensed 2 m away: the path is shorter than the lead, the leader is the target.
        s.targets[0] = AgentState::at(2.0, 0.0, 0.0);
        wolf_desired(0, &s.snap(), &mut mem, &mut s.row());
        assert_eq!(mem.mode, LawMode::Encircle);
        // Nobody senses it at the next step: heading for where it would be.
        (s.wolf_senses, s.t) = (vec![false, false], 1);
        wolf_desired(0, &s.snap(), &mut mem, &mut s.row());
        assert_eq!(mem.mode, LawMode::Lost);
    }
}
