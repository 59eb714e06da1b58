//! Exact planar geometry of bodies and obstacles.
//!
//! parry supplies the primitive queries (point–segment projection, point-in-polygon); the
//! compositions the world needs — triangle vs. star-shaped polygon overlap, the angular extent
//! of a polygon's visible part — are built here on top of them, one small function each.

mod polygon;
mod ring;
mod triangle;

pub use polygon::{edges, polygon_closest_point, polygon_contains, polygon_visible_extent, segment_disc_clip};
pub use ring::{assign, hunting_points};
pub use triangle::{body_triangle, segments_intersect, triangle_contains, triangle_overlaps_circle, triangle_overlaps_polygon, triangles_overlap, BodyFrame};

/// An angular interval seen from a point: centre direction ψ, half-width Δ, and the surface
/// distance d of the nearest point of the item.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extent {
    pub psi: f64,
    pub delta: f64,
    pub dist: f64,
}
