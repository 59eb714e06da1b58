//! The `formation` law (SPEC §7; source `002_1b59bc6eab955b77.txt`): obstacle graph,
//! visibility path for a virtual leader, potential-field formation.
//!
//! This file holds the planning half so far (issue 7 is open; the control terms f_α, f_β,
//! f_γ and the law's entry point come next):
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
//!   source's tangent polylines up to the ring's resolution and cannot cross a structure.

use pathfinding::directed::dijkstra::dijkstra;
use pathfinding::undirected::connected_components::connected_components;

use crate::math::Vec2;
use crate::world::Obstacle;

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
    (0..nodes.len())
        .map(|i| (0..nodes.len()).filter(|&j| j != i && (nodes[i].center - nodes[j].center).norm() <= nodes[i].radius + nodes[j].radius + wolf_diameter).collect())
        .collect()
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
    let stretch = 1.0 / (std::f64::consts::PI / k as f64).cos() * (1.0 + 1e-9);
    let mut points = vec![start, goal];
    for d in &discs {
        for m in 0..k {
            let a = std::f64::consts::TAU * m as f64 / k as f64;
            let p = d.center + (d.radius + clearance) * stretch * Vec2::new(a.cos(), a.sin());
            if !discs.iter().any(|o| (p - o.center).norm() < o.radius + clearance) {
                points.push(p);
            }
        }
    }
    let cost = |a: Vec2, b: Vec2| ((a - b).norm() / COST_UNIT).round() as u64;
    let found = dijkstra(
        &0usize,
        |&i| (0..points.len()).filter(|&j| j != i && !blocked(points[i], points[j], &discs, clearance)).map(|j| (j, cost(points[i], points[j]))).collect::<Vec<_>>(),
        |&i| i == 1,
    );
    match found {
        Some((path, _)) => path.into_iter().map(|i| points[i]).collect(),
        None => vec![start, goal],
    }
}

/// Length of a polyline.
pub fn path_length(path: &[Vec2]) -> f64 {
    path.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
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
}
