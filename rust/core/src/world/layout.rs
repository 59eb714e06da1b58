//! Explicit layouts (API.md LAYOUT): start a world from a given state instead of spawning.

use serde::{Deserialize, Serialize};

use crate::math::Vec2;

/// `{"wolves": [[x, y, θ], ...], "targets": [...], "obstacles": [...]}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Layout {
    pub wolves: Vec<[f64; 3]>,
    pub targets: Vec<[f64; 3]>,
    #[serde(default)]
    pub obstacles: Vec<LayoutObstacle>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum LayoutObstacle {
    Circle {
        center: [f64; 2],
        radius: f64,
        #[serde(default)]
        moving: bool,
    },
    /// Vertices in world coordinates, in order around `center` (a simple polygon).
    Polygon {
        center: [f64; 2],
        vertices: Vec<[f64; 2]>,
        #[serde(default)]
        moving: bool,
    },
}

pub(crate) fn v2(a: [f64; 2]) -> Vec2 {
    Vec2::new(a[0], a[1])
}
