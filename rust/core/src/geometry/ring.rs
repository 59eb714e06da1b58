//! The ring of hunting points around a target and the wolves' assignment to them: the bvc law hunts
//! with them (docs/world-and-laws.md §6), and the world's `capture.rule: hunting_points` judges
//! with the same points and the same assignment (§1.7).

use pathfinding::kuhn_munkres::kuhn_munkres_min;
use pathfinding::matrix::Matrix;

use crate::math::{cos, sin, Vec2};

/// N hunting points on the circle of radius `r_h` around `target`, point k at angle 2πk/N.
pub fn hunting_points(target: Vec2, n: usize, r_h: f64) -> Vec<Vec2> {
    (0..n)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            target + r_h * Vec2::new(cos(a), sin(a))
        })
        .collect()
}

/// Distances are compared in whole micrometres: Kuhn–Munkres needs totally ordered weights,
/// and a micrometre is far below anything the world resolves.
const ASSIGNMENT_UNIT: f64 = 1e-6;

/// The assignment of wolves to points (`result[i]` = wolf i's point) minimising the total
/// wolf→point distance. Needs `points.len() >= wolves.len()`.
pub fn assign(wolves: &[Vec2], points: &[Vec2]) -> Vec<usize> {
    if wolves.is_empty() {
        return Vec::new();
    }
    let weights: Vec<i64> = wolves.iter().flat_map(|w| points.iter().map(move |p| ((w - p).norm() / ASSIGNMENT_UNIT).round() as i64)).collect();
    let matrix = Matrix::from_vec(wolves.len(), points.len(), weights).expect("rows x columns weights");
    kuhn_munkres_min(&matrix).1
}
