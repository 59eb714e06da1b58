//! Agent bodies (isosceles triangles) and their overlap tests.

use super::polygon::polygon_contains;
use crate::math::{cross, unit, Vec2};

/// The body of an agent at pose (p, θ) (docs/world-and-laws.md §1.2): the pose point is the base
/// midpoint, the apex lies `height` ahead, the base corners `base/2` to either side. Returns
/// `[apex, left corner, right corner]` (counter-clockwise).
#[inline]
pub fn body_triangle(p: Vec2, theta: f64, base: f64, height: f64) -> [Vec2; 3] {
    BodyFrame::new(theta, base, height).at(p)
}

/// A body's vertex offsets from its pose point at one heading. The feasibility filter tries
/// several positions at the same heading; building the frame once saves `body_triangle`'s two
/// `sin_cos` per try. `BodyFrame::new(θ, b, h).at(p)` is `body_triangle(p, θ, b, h)` bit for bit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyFrame {
    /// `unit(θ)`: kept, because the next step moves the agent along it.
    pub fwd: Vec2,
    ahead: Vec2,
    half_base: Vec2,
}

impl BodyFrame {
    #[inline]
    pub fn new(theta: f64, base: f64, height: f64) -> Self {
        let fwd = unit(theta);
        // unit(θ + π/2) is fwd turned a quarter: (−sin θ, cos θ), exactly, with no second
        // sin_cos (it differs from the rounded sin_cos(θ + π/2) in the last bit or so; the
        // documented body, §1.2, is the exact one).
        let side = Vec2::new(-fwd.y, fwd.x);
        Self { fwd, ahead: fwd * height, half_base: side * (0.5 * base) }
    }

    /// `[apex, left corner, right corner]` at pose point `p`.
    #[inline]
    pub fn at(&self, p: Vec2) -> [Vec2; 3] {
        [p + self.ahead, p + self.half_base, p - self.half_base]
    }
}

#[inline]
fn orient(a: Vec2, b: Vec2, c: Vec2) -> f64 {
    cross(b - a, c - a)
}

/// Closed segments [a, b] and [c, d] share a point.
pub fn segments_intersect(a: Vec2, b: Vec2, c: Vec2, d: Vec2) -> bool {
    let d1 = orient(c, d, a);
    let d2 = orient(c, d, b);
    let d3 = orient(a, b, c);
    let d4 = orient(a, b, d);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return true;
    }
    let on = |p: Vec2, q: Vec2, r: Vec2, o: f64| o == 0.0 && r.x >= p.x.min(q.x) && r.x <= p.x.max(q.x) && r.y >= p.y.min(q.y) && r.y <= p.y.max(q.y);
    on(c, d, a, d1) || on(c, d, b, d2) || on(a, b, c, d3) || on(a, b, d, d4)
}

/// Point inside or on a triangle (either winding).
pub fn triangle_contains(t: &[Vec2; 3], p: Vec2) -> bool {
    let a = orient(t[0], t[1], p);
    let b = orient(t[1], t[2], p);
    let c = orient(t[2], t[0], p);
    (a >= 0.0 && b >= 0.0 && c >= 0.0) || (a <= 0.0 && b <= 0.0 && c <= 0.0)
}

/// Two triangles share a point (edges cross, or one contains the other).
pub fn triangles_overlap(s: &[Vec2; 3], t: &[Vec2; 3]) -> bool {
    for i in 0..3 {
        for j in 0..3 {
            if segments_intersect(s[i], s[(i + 1) % 3], t[j], t[(j + 1) % 3]) {
                return true;
            }
        }
    }
    triangle_contains(s, t[0]) || triangle_contains(t, s[0])
}

/// A triangle and a closed disc share a point.
pub fn triangle_overlaps_circle(t: &[Vec2; 3], center: Vec2, radius: f64) -> bool {
    if triangle_contains(t, center) {
        return true;
    }
    (0..3).any(|i| (super::polygon::closest_on_segment(t[i], t[(i + 1) % 3], center) - center).norm() <= radius)
}

/// A triangle and a simple polygon (vertices in order, either winding) share a point.
pub fn triangle_overlaps_polygon(t: &[Vec2; 3], poly: &[Vec2]) -> bool {
    for (c, d) in super::polygon::edges(poly) {
        for i in 0..3 {
            if segments_intersect(t[i], t[(i + 1) % 3], c, d) {
                return true;
            }
        }
    }
    // No edges cross: either one lies inside the other or they are apart.
    polygon_contains(poly, t[0]) || triangle_contains(t, poly[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64) -> Vec2 {
        Vec2::new(x, y)
    }

    #[test]
    fn body_matches_spec_corners() {
        let t = body_triangle(v(1.0, 2.0), 0.0, 0.2, 0.2);
        assert!((t[0] - v(1.2, 2.0)).norm() < 1e-15);
        assert!((t[1] - v(1.0, 2.1)).norm() < 1e-15);
        assert!((t[2] - v(1.0, 1.9)).norm() < 1e-15);
    }

    #[test]
    fn triangle_overlaps() {
        let a = body_triangle(v(0.0, 0.0), 0.0, 0.2, 0.2);
        assert!(triangles_overlap(&a, &body_triangle(v(0.15, 0.0), 3.0, 0.2, 0.2)));
        assert!(!triangles_overlap(&a, &body_triangle(v(0.5, 0.0), 0.0, 0.2, 0.2)));
        // Apex touching the other's base edge counts as overlap (closed sets).
        assert!(triangles_overlap(&a, &body_triangle(v(0.2, 0.0), 0.0, 0.2, 0.2)));
        assert!(triangle_overlaps_circle(&a, v(0.5, 0.0), 0.31));
        assert!(!triangle_overlaps_circle(&a, v(0.5, 0.0), 0.29));
        assert!(triangle_overlaps_circle(&a, v(0.05, 0.0), 0.001));
    }

    #[test]
    fn triangle_inside_nonconvex_polygon() {
        // A "C" shape: the triangle sits in the notch (outside) or in the body (inside).
        let c = [v(0.0, 0.0), v(3.0, 0.0), v(3.0, 1.0), v(1.0, 1.0), v(1.0, 2.0), v(3.0, 2.0), v(3.0, 3.0), v(0.0, 3.0)];
        let in_notch = body_triangle(v(2.0, 1.5), 0.0, 0.2, 0.2);
        let in_body = body_triangle(v(0.5, 1.5), 0.0, 0.2, 0.2);
        let across = body_triangle(v(0.9, 1.5), 0.0, 0.2, 0.2);
        assert!(!triangle_overlaps_polygon(&in_notch, &c));
        assert!(triangle_overlaps_polygon(&in_body, &c));
        assert!(triangle_overlaps_polygon(&across, &c));
    }
}
