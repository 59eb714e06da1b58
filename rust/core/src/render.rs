//! Headless rendering of one world state into an RGB frame (tiny-skia, no display server).
//!
//! The scene is plain data ([`Scene`]) so that a live world and a saved trajectory draw the
//! same frame: the Python side builds it from `world_state()` or from `trajectory.npz`.
//!
//! What is drawn, back to front: the arena (white inside, grey outside), trails (each agent's
//! recent positions as a polyline in its colour), sensing circles (optional), obstacles with
//! their exact shapes (static: dark grey; moving: brown, both with a darker outline), the
//! capture ring around every uncaptured target, interaction links (optional, observer →
//! observed), wolves and targets as oriented triangles (apex ahead; every wolf its own colour,
//! targets red), and the step count in the top-left corner.

use serde::Deserialize;

use crate::math::{cos, sin, sin_cos};
use tiny_skia::{Color, FillRule, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform};

/// An RGB colour.
pub type Rgb = [u8; 3];

/// Colours of wolf i (cycled) — matplotlib's tab10 without its red, which is the targets'.
pub const WOLF_COLOURS: [Rgb; 9] = [[31, 119, 180], [44, 160, 44], [148, 103, 189], [255, 127, 14], [140, 86, 75], [227, 119, 194], [127, 127, 127], [188, 189, 34], [23, 190, 207]];
pub const TARGET_COLOUR: Rgb = [214, 39, 40];
pub const BACKGROUND: Rgb = [255, 255, 255];
pub const OUTSIDE: Rgb = [225, 225, 225];
pub const STATIC_OBSTACLE: Rgb = [90, 90, 90];
pub const MOVING_OBSTACLE: Rgb = [176, 122, 72];

/// The colour of wolf `i`.
pub fn wolf_colour(i: usize) -> Rgb {
    WOLF_COLOURS[i % WOLF_COLOURS.len()]
}

/// An obstacle at its current pose. Polygons come as their constant local vertices (relative to
/// the centre at angle 0) and the pose, exactly as `world_state()` and `trajectory.npz` store
/// them, so that a live run and its replay draw the same pixels.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneObstacle {
    /// "circle" or "polygon".
    pub kind: String,
    #[serde(default)]
    pub moving: bool,
    pub center: [f64; 2],
    #[serde(default)]
    pub angle: f64,
    /// Circle radius (polygons: ignored).
    #[serde(default)]
    pub radius: f64,
    /// Polygon vertices relative to the centre at angle 0, in order.
    #[serde(default)]
    pub local: Vec<[f64; 2]>,
}

impl SceneObstacle {
    pub fn circle(center: [f64; 2], radius: f64, moving: bool) -> Self {
        SceneObstacle { kind: "circle".into(), moving, center, angle: 0.0, radius, local: vec![] }
    }

    pub fn polygon(center: [f64; 2], angle: f64, local: Vec<[f64; 2]>, moving: bool) -> Self {
        SceneObstacle { kind: "polygon".into(), moving, center, angle, radius: 0.0, local }
    }

    /// World vertices at the current pose.
    pub fn vertices(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        let (s, c) = sin_cos(self.angle);
        self.local.iter().map(move |v| [self.center[0] + c * v[0] - s * v[1], self.center[1] + s * v[0] + c * v[1]])
    }
}

/// Everything one frame shows (deserialisable: the Python side hands it over as a dict).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Scene {
    /// `[x_min, y_min, x_max, y_max]`.
    pub border: [f64; 4],
    /// Poses (x, y, θ).
    pub wolves: Vec<[f64; 3]>,
    pub targets: Vec<[f64; 3]>,
    /// Captured targets get no capture ring (and are drawn hollow).
    pub target_captured: Vec<bool>,
    pub obstacles: Vec<SceneObstacle>,
    /// Recent positions per agent (wolves first, then targets), oldest first.
    pub trails: Vec<Vec<[f64; 2]>>,
    /// Interaction links (observer, observed) over agents indexed wolves first, then targets.
    pub links: Vec<(usize, usize)>,
    /// Radius of the capture ring (0: none).
    pub capture_distance: f64,
    /// Radius of the sensing circle drawn around every agent (0: none).
    pub sense_radius: f64,
    /// Body size: triangle height = base (m).
    pub body: f64,
    /// The step count shown in the corner (None: nothing).
    pub step: Option<u64>,
}

/// Frame size limits (pixels per side).
pub const MIN_SIDE: u32 = 16;
pub const MAX_SIDE: u32 = 4096;

/// Renders `scene` into a new `height × width × 3` RGB buffer (row-major, top row first).
// `!(x1 > x0 && y1 > y0)` on purpose: a negated comparison is true for NaN, which clippy's
// simpler `x1 <= x0 || y1 <= y0` would let through.
#[allow(clippy::nonminimal_bool)]
pub fn render(scene: &Scene, width: u32, height: u32) -> Result<Vec<u8>, String> {
    if !(MIN_SIDE..=MAX_SIDE).contains(&width) || !(MIN_SIDE..=MAX_SIDE).contains(&height) {
        return Err(format!("frame size must be between {MIN_SIDE} and {MAX_SIDE} pixels per side, got {width}x{height}"));
    }
    let [x0, y0, x1, y1] = scene.border;
    if !(x1 > x0 && y1 > y0) || !scene.border.iter().all(|v| v.is_finite()) {
        return Err(format!("border must be finite with x_max > x_min and y_max > y_min, got {:?}", scene.border));
    }
    if let Some(bad) = scene.obstacles.iter().find(|o| o.kind != "circle" && o.kind != "polygon") {
        return Err(format!("obstacle kind must be 'circle' or 'polygon', got {:?}", bad.kind));
    }
    // One drawing surface per thread, reused while the size stays: a fresh 2 MB buffer per
    // frame costs a page fault per 4 kB (about a third of an empty frame's time).
    SURFACE.with(|cell| {
        let mut slot = cell.borrow_mut();
        if slot.as_ref().is_none_or(|p| p.width() != width || p.height() != height) {
            *slot = Some(Pixmap::new(width, height).ok_or("cannot allocate the frame")?);
        }
        let pixmap = slot.as_mut().expect("just set");
        draw(scene, pixmap);
        Ok(rgba_to_rgb(pixmap.data()))
    })
}

thread_local! {
    static SURFACE: std::cell::RefCell<Option<Pixmap>> = const { std::cell::RefCell::new(None) };
}

fn draw(scene: &Scene, pixmap: &mut Pixmap) {
    let (width, height) = (pixmap.width(), pixmap.height());
    pixmap.fill(colour(OUTSIDE, 255));
    let view = View::new(scene.border, width, height);
    let mut canvas = Canvas { pixmap, view };

    canvas.arena(scene.border);
    for (k, trail) in scene.trails.iter().enumerate() {
        // 1 px lines take tiny-skia's anti-aliased hairline path, several times cheaper
        // than its stroker (profiled: trails were a quarter of a frame at width 1.5).
        canvas.polyline(trail, agent_colour(scene, k), 150, 1.0);
    }
    if scene.sense_radius > 0.0 {
        for (k, p) in all_poses(scene).enumerate() {
            canvas.circle_outline([p[0], p[1]], scene.sense_radius, agent_colour(scene, k), 60, 1.0);
        }
    }
    for ob in &scene.obstacles {
        canvas.obstacle(ob);
    }
    if scene.capture_distance > 0.0 {
        for (t, captured) in scene.targets.iter().zip(scene.target_captured.iter().chain(std::iter::repeat(&false))) {
            if !captured {
                canvas.circle_outline([t[0], t[1]], scene.capture_distance, TARGET_COLOUR, 160, 1.0);
            }
        }
    }
    let poses: Vec<[f64; 3]> = all_poses(scene).collect();
    for &(a, b) in &scene.links {
        if a < poses.len() && b < poses.len() {
            canvas.segment([poses[a][0], poses[a][1]], [poses[b][0], poses[b][1]], [40, 40, 40], 90, 1.0);
        }
    }
    // Bodies at true scale, but never smaller than 9 px, so that agents stay visible.
    let min_height = 9.0 / canvas.view.scale;
    let h = scene.body.max(min_height);
    for (k, p) in poses.iter().enumerate() {
        let hollow = k >= scene.wolves.len() && scene.target_captured.get(k - scene.wolves.len()).copied().unwrap_or(false);
        canvas.triangle(*p, h, agent_colour(scene, k), hollow);
    }
    // The band above the arena: the step counter on the left, the legend on the right, so that
    // neither ever covers the border or an agent.
    let top = canvas.view.px([scene.border[0], scene.border[3]]).1;
    let mut used = 0.0;
    if let Some(step) = scene.step {
        // Digits as tall as the band allows, 1–4 px per cell.
        let size = band_cell(top).clamp(1.0, 4.0);
        canvas.number(step, 4.0 + size, ((top - 5.0 * size) / 2.0).max(size), size);
        used = 4.0 + size + 4.0 * size * step.to_string().len() as f32;
    }
    canvas.legend(top, used, width as f32);
}

/// The largest glyph cell (px) that fits a band `top` px tall: 5 cells of glyph plus a cell of
/// backdrop above and below, and 2 px for the arena's border line.
fn band_cell(top: f32) -> f32 {
    ((top - 2.0) / 7.0).floor()
}

/// What the legend names, in order: a swatch kind, its colour, its label.
enum Swatch {
    Triangle,
    Ring,
    Square,
}

const LEGEND: [(Swatch, Rgb, &str); 5] = [
    (Swatch::Triangle, WOLF_COLOURS[0], "WOLF"),
    (Swatch::Triangle, TARGET_COLOUR, "TARGET"),
    (Swatch::Ring, TARGET_COLOUR, "CAPTURE"),
    (Swatch::Square, MOVING_OBSTACLE, "MOVING"),
    (Swatch::Square, STATIC_OBSTACLE, "STATIC"),
];

/// Drops every fourth byte (the background is opaque, so premultiplied RGBA = straight RGBA).
/// Four pixels at a time as 32-bit words: 16 bytes in, 12 out (over twice as fast as per
/// pixel: BENCHMARKS.md, "Optimisations").
fn rgba_to_rgb(rgba: &[u8]) -> Vec<u8> {
    let mut rgb = vec![0u8; rgba.len() / 4 * 3];
    let word = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    let mut out = rgb.chunks_exact_mut(12);
    let mut src = rgba.chunks_exact(16);
    for (d, s) in (&mut out).zip(&mut src) {
        let (p0, p1, p2, p3) = (word(&s[0..4]), word(&s[4..8]), word(&s[8..12]), word(&s[12..16]));
        d[0..4].copy_from_slice(&((p0 & 0x00ff_ffff) | (p1 << 24)).to_le_bytes());
        d[4..8].copy_from_slice(&(((p1 >> 8) & 0xffff) | (p2 << 16)).to_le_bytes());
        d[8..12].copy_from_slice(&(((p2 >> 16) & 0xff) | (p3 << 8)).to_le_bytes());
    }
    for (d, s) in out.into_remainder().chunks_exact_mut(3).zip(src.remainder().chunks_exact(4)) {
        d.copy_from_slice(&s[..3]);
    }
    rgb
}

/// The triangle's centroid for pose `p` and body height `h` — where a test finds the colour.
pub fn body_centroid(p: [f64; 3], h: f64) -> [f64; 2] {
    [p[0] + h / 3.0 * cos(p[2]), p[1] + h / 3.0 * sin(p[2])]
}

fn all_poses(scene: &Scene) -> impl Iterator<Item = [f64; 3]> + '_ {
    scene.wolves.iter().chain(&scene.targets).copied()
}

fn agent_colour(scene: &Scene, k: usize) -> Rgb {
    if k < scene.wolves.len() {
        wolf_colour(k)
    } else {
        TARGET_COLOUR
    }
}

fn colour(c: Rgb, alpha: u8) -> Color {
    Color::from_rgba8(c[0], c[1], c[2], alpha)
}

fn paint(c: Rgb, alpha: u8) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color(colour(c, alpha));
    p.anti_alias = true;
    p
}

/// Height (px) of the status band above the arena: 5 % of the frame, 8–40 px.
pub fn status_band(height: u32) -> f64 {
    (height as f64 * 0.05).round().clamp(8.0, 40.0)
}

/// World → pixel mapping: below the status band, the arena fills 94 % of the rest, centred,
/// aspect kept, y up.
#[derive(Debug, Clone, Copy)]
pub struct View {
    pub scale: f64,
    ox: f64,
    oy: f64,
    height: f64,
}

impl View {
    pub fn new([x0, y0, x1, y1]: [f64; 4], width: u32, height: u32) -> Self {
        let (w, h) = (width as f64, height as f64);
        // A status band on top (the step counter) that the arena never reaches; the arena
        // fills 94 % of the rest, centred.
        let below = h - status_band(height);
        let scale = 0.94 * (w / (x1 - x0)).min(below / (y1 - y0));
        let ox = (w - scale * (x1 - x0)) / 2.0 - scale * x0;
        let oy = (below - scale * (y1 - y0)) / 2.0 - scale * y0;
        View { scale, ox, oy, height: h }
    }

    /// Pixel coordinates (x right, y down) of world point `p`.
    pub fn px(&self, p: [f64; 2]) -> (f32, f32) {
        ((self.ox + self.scale * p[0]) as f32, (self.height - (self.oy + self.scale * p[1])) as f32)
    }
}

struct Canvas<'a> {
    pixmap: &'a mut Pixmap,
    view: View,
}

impl Canvas<'_> {
    fn fill(&mut self, pb: PathBuilder, c: Rgb, alpha: u8) {
        self.fill_with(pb, c, alpha, true);
    }

    fn fill_with(&mut self, pb: PathBuilder, c: Rgb, alpha: u8, anti_alias: bool) {
        if let Some(path) = pb.finish() {
            let mut p = paint(c, alpha);
            p.anti_alias = anti_alias;
            self.pixmap.fill_path(&path, &p, FillRule::EvenOdd, Transform::identity(), None);
        }
    }

    fn stroke(&mut self, pb: PathBuilder, c: Rgb, alpha: u8, width: f32) {
        if let Some(path) = pb.finish() {
            let stroke = Stroke { width, ..Stroke::default() };
            self.pixmap.stroke_path(&path, &paint(c, alpha), &stroke, Transform::identity(), None);
        }
    }

    fn arena(&mut self, [x0, y0, x1, y1]: [f64; 4]) {
        let (a, b) = (self.view.px([x0, y1]), self.view.px([x1, y0]));
        if let Some(rect) = Rect::from_ltrb(a.0, a.1, b.0, b.1) {
            let mut inside = paint(BACKGROUND, 255);
            inside.anti_alias = false; // axis-aligned, and the border line covers its edges
            self.pixmap.fill_rect(rect, &inside, Transform::identity(), None);
            let mut pb = PathBuilder::new();
            pb.push_rect(rect);
            self.stroke(pb, [0, 0, 0], 255, 2.0);
        }
    }

    fn polygon_path(&self, points: impl IntoIterator<Item = [f64; 2]>) -> PathBuilder {
        let mut pb = PathBuilder::new();
        for (i, p) in points.into_iter().enumerate() {
            let (x, y) = self.view.px(p);
            if i == 0 {
                pb.move_to(x, y);
            } else {
                pb.line_to(x, y);
            }
        }
        pb.close();
        pb
    }

    fn circle_path(&self, center: [f64; 2], radius: f64) -> PathBuilder {
        let (x, y) = self.view.px(center);
        let mut pb = PathBuilder::new();
        pb.push_circle(x, y, (radius * self.view.scale).max(0.5) as f32);
        pb
    }

    fn obstacle(&mut self, ob: &SceneObstacle) {
        let (fill, edge) = if ob.moving { (MOVING_OBSTACLE, [110, 70, 35]) } else { (STATIC_OBSTACLE, [40, 40, 40]) };
        let path = || if ob.kind == "circle" { self.circle_path(ob.center, ob.radius) } else { self.polygon_path(ob.vertices()) };
        let (a, b) = (path(), path());
        // Aliased fill, anti-aliased 1 px outline over its edge: looks anti-aliased and costs
        // half of an anti-aliased fill (obstacles had been a third of a frame).
        self.fill_with(a, fill, 255, false);
        self.stroke(b, edge, 255, 1.0);
    }

    fn circle_outline(&mut self, center: [f64; 2], radius: f64, c: Rgb, alpha: u8, width: f32) {
        let pb = self.circle_path(center, radius);
        self.stroke(pb, c, alpha, width);
    }

    fn segment(&mut self, a: [f64; 2], b: [f64; 2], c: Rgb, alpha: u8, width: f32) {
        let (pa, pb_) = (self.view.px(a), self.view.px(b));
        let mut pb = PathBuilder::new();
        pb.move_to(pa.0, pa.1);
        pb.line_to(pb_.0, pb_.1);
        self.stroke(pb, c, alpha, width);
    }

    fn polyline(&mut self, points: &[[f64; 2]], c: Rgb, alpha: u8, width: f32) {
        if points.len() < 2 {
            return;
        }
        let mut pb = PathBuilder::new();
        for (i, p) in points.iter().enumerate() {
            let (x, y) = self.view.px(*p);
            if i == 0 {
                pb.move_to(x, y);
            } else {
                pb.line_to(x, y);
            }
        }
        self.stroke(pb, c, alpha, width);
    }

    /// The isosceles body of docs/world-and-laws.md §1.2 scaled to height = base = `h`: apex ahead,
    /// base through the pose point.
    fn triangle(&mut self, [x, y, th]: [f64; 3], h: f64, c: Rgb, hollow: bool) {
        let (s, co) = sin_cos(th);
        let apex = [x + h * co, y + h * s];
        let left = [x - h / 2.0 * s, y + h / 2.0 * co];
        let right = [x + h / 2.0 * s, y - h / 2.0 * co];
        let outline = self.polygon_path([apex, left, right]);
        if !hollow {
            let body = self.polygon_path([apex, left, right]);
            self.fill(body, c, 255);
        }
        self.stroke(outline, if hollow { c } else { [0, 0, 0] }, 255, 1.0);
    }

    /// The legend, right-aligned in the band above the arena (`top` px tall) after `used` px of
    /// it: a swatch and a label per entry of [`LEGEND`], in 3 × 5 letters of 1–2 px cells. Left
    /// out when the band is too narrow or too low for it.
    fn legend(&mut self, top: f32, used: f32, width: f32) {
        let size = band_cell(top).min(2.0);
        if size < 1.0 {
            return;
        }
        let (cell, swatch, gap) = (4.0 * size, 5.0 * size, 3.0 * size);
        let total: f32 = LEGEND.iter().map(|(_, _, label)| swatch + size + cell * label.len() as f32 + gap).sum::<f32>() - gap;
        let x0 = width - 4.0 - total;
        if x0 < used + 8.0 {
            return;
        }
        let y = ((top - 5.0 * size) / 2.0).max(size);
        if let Some(r) = Rect::from_xywh(x0 - size, y - size, total + 2.0 * size, 7.0 * size) {
            self.pixmap.fill_rect(r, &paint(BACKGROUND, 200), Transform::identity(), None);
        }
        let mut x = x0;
        for (kind, c, label) in LEGEND {
            let mut pb = PathBuilder::new();
            match kind {
                Swatch::Triangle => {
                    pb.move_to(x, y + swatch);
                    pb.line_to(x + swatch / 2.0, y);
                    pb.line_to(x + swatch, y + swatch);
                    pb.close();
                    self.fill(pb, c, 255);
                }
                Swatch::Square => {
                    pb.push_rect(Rect::from_xywh(x, y, swatch, swatch).expect("positive size"));
                    self.fill(pb, c, 255);
                }
                Swatch::Ring => {
                    pb.push_circle(x + swatch / 2.0, y + swatch / 2.0, swatch / 2.0 - 0.5);
                    self.stroke(pb, c, 220, 1.0);
                }
            }
            x += swatch + size;
            self.text(label, x, y, size);
            x += cell * label.len() as f32 + gap;
        }
    }

    /// `text` (digits and the upper-case letters of [`LEGEND`]) in the 3 × 5 pixel font, cells of
    /// `size` px, top-left corner at (x, y).
    fn text(&mut self, text: &str, x: f32, y: f32, size: f32) {
        let ink = paint([0, 0, 0], 255);
        for (k, ch) in text.chars().enumerate() {
            let Some(glyph) = glyph(ch) else { continue };
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..3 {
                    if bits & (0b100 >> col) != 0 {
                        if let Some(r) = Rect::from_xywh(x + k as f32 * 4.0 * size + col as f32 * size, y + row as f32 * size, size, size) {
                            self.pixmap.fill_rect(r, &ink, Transform::identity(), None);
                        }
                    }
                }
            }
        }
    }

    /// `n` in a 3 × 5 pixel font scaled by `size`, top-left corner at (x, y).
    fn number(&mut self, n: u64, x: f32, y: f32, size: f32) {
        let digits = n.to_string();
        let backdrop = Rect::from_xywh(x - size, y - size, 4.0 * size * digits.len() as f32 + size, 7.0 * size);
        if let Some(r) = backdrop {
            self.pixmap.fill_rect(r, &paint(BACKGROUND, 200), Transform::identity(), None);
        }
        self.text(&digits, x, y, size);
    }
}

/// The 3 × 5 glyph of a digit or of a letter of the legend, as [`DIGITS`].
fn glyph(ch: char) -> Option<[u8; 5]> {
    Some(match ch {
        '0'..='9' => DIGITS[ch as usize - '0' as usize],
        'A' => [0b010, 0b101, 0b111, 0b101, 0b101],
        'C' => [0b011, 0b100, 0b100, 0b100, 0b011],
        'E' => [0b111, 0b100, 0b110, 0b100, 0b111],
        'F' => [0b111, 0b100, 0b110, 0b100, 0b100],
        'G' => [0b011, 0b100, 0b101, 0b101, 0b011],
        'I' => [0b111, 0b010, 0b010, 0b010, 0b111],
        'L' => [0b100, 0b100, 0b100, 0b100, 0b111],
        'M' => [0b101, 0b111, 0b111, 0b101, 0b101],
        'N' => [0b101, 0b111, 0b111, 0b111, 0b101],
        'O' => [0b010, 0b101, 0b101, 0b101, 0b010],
        'P' => [0b110, 0b101, 0b110, 0b100, 0b100],
        'R' => [0b110, 0b101, 0b110, 0b101, 0b101],
        'S' => [0b011, 0b100, 0b010, 0b001, 0b110],
        'T' => [0b111, 0b010, 0b010, 0b010, 0b010],
        'U' => [0b101, 0b101, 0b101, 0b101, 0b111],
        'V' => [0b101, 0b101, 0b101, 0b101, 0b010],
        'W' => [0b101, 0b101, 0b111, 0b111, 0b101],
        _ => return None,
    })
}

/// 3 × 5 digit glyphs, one row per entry, bit 2 = left column. (No font library for ten
/// glyphs: tiny-skia draws no text, and a font file would be the larger dependency.)
const DIGITS: [[u8; 5]; 10] = [
    [0b111, 0b101, 0b101, 0b101, 0b111],
    [0b010, 0b110, 0b010, 0b010, 0b111],
    [0b111, 0b001, 0b111, 0b100, 0b111],
    [0b111, 0b001, 0b111, 0b001, 0b111],
    [0b101, 0b101, 0b111, 0b001, 0b001],
    [0b111, 0b100, 0b111, 0b001, 0b111],
    [0b111, 0b100, 0b111, 0b101, 0b111],
    [0b111, 0b001, 0b010, 0b010, 0b010],
    [0b111, 0b101, 0b111, 0b101, 0b111],
    [0b111, 0b101, 0b111, 0b001, 0b111],
];

#[cfg(test)]
mod tests {
    use super::*;

    fn pixel(frame: &[u8], width: u32, (x, y): (f32, f32)) -> Rgb {
        let (x, y) = (x.floor() as usize, y.floor() as usize);
        let i = 3 * (y * width as usize + x);
        [frame[i], frame[i + 1], frame[i + 2]]
    }

    fn scene() -> Scene {
        Scene {
            border: [-10.0, -10.0, 10.0, 10.0],
            wolves: vec![[-5.0, -5.0, 0.0], [5.0, 5.0, 1.0]],
            targets: vec![[0.0, 6.0, 2.0]],
            target_captured: vec![false],
            obstacles: vec![
                SceneObstacle::circle([3.0, -3.0], 1.0, false),
                // the triangle (-4, 2), (-2, 2), (-3, 4), stored rotated by -π/2 and posed at +π/2
                SceneObstacle::polygon([-3.0, 3.0], std::f64::consts::FRAC_PI_2, vec![[-1.0, 1.0], [-1.0, -1.0], [1.0, 0.0]], true),
            ],
            capture_distance: 0.8,
            body: 0.2,
            step: Some(123),
            ..Scene::default()
        }
    }

    #[test]
    fn pixels_have_the_colours_of_what_is_there() {
        let s = scene();
        let (w, h) = (300, 200);
        let frame = render(&s, w, h).unwrap();
        assert_eq!(frame.len(), (w * h * 3) as usize);
        let view = View::new(s.border, w, h);
        let body = s.body.max(9.0 / view.scale);
        for (i, p) in s.wolves.iter().enumerate() {
            assert_eq!(pixel(&frame, w, view.px(body_centroid(*p, body))), wolf_colour(i), "wolf {i}");
        }
        assert_eq!(pixel(&frame, w, view.px(body_centroid(s.targets[0], body))), TARGET_COLOUR);
        assert_eq!(pixel(&frame, w, view.px([3.0, -3.0])), STATIC_OBSTACLE);
        assert_eq!(pixel(&frame, w, view.px([-3.0, 2.7])), MOVING_OBSTACLE);
        assert_eq!(pixel(&frame, w, view.px([0.0, -8.0])), BACKGROUND);
        assert_eq!(pixel(&frame, w, (2.0, h as f32 / 2.0)), OUTSIDE, "the 300x200 frame pads a square arena left and right");
    }

    #[test]
    fn rgba_to_rgb_drops_the_alpha_bytes_of_every_pixel() {
        for pixels in [0usize, 1, 3, 4, 5, 9] {
            let rgba: Vec<u8> = (0..4 * pixels).map(|i| (i * 7 % 251) as u8).collect();
            let want: Vec<u8> = rgba.chunks_exact(4).flat_map(|p| p[..3].to_vec()).collect();
            assert_eq!(rgba_to_rgb(&rgba), want, "{pixels} pixels");
        }
    }

    #[test]
    fn polygon_vertices_follow_the_pose() {
        let ob = SceneObstacle::polygon([-3.0, 3.0], std::f64::consts::FRAC_PI_2, vec![[-1.0, 1.0], [-1.0, -1.0], [1.0, 0.0]], true);
        let want = [[-4.0, 2.0], [-2.0, 2.0], [-3.0, 4.0]];
        for (v, w) in ob.vertices().zip(want) {
            assert!((v[0] - w[0]).abs() < 1e-12 && (v[1] - w[1]).abs() < 1e-12, "{v:?} vs {w:?}");
        }
    }

    #[test]
    fn step_count_and_captured_targets_change_the_frame() {
        let s = scene();
        let a = render(&s, 120, 120).unwrap();
        let mut t = s.clone();
        t.step = Some(124);
        assert_ne!(a, render(&t, 120, 120).unwrap());
        let mut c = s.clone();
        c.target_captured = vec![true];
        assert_ne!(a, render(&c, 120, 120).unwrap());
    }

    #[test]
    fn the_step_counter_sits_above_the_arena() {
        // The counter's ink and backdrop stay in the band above the arena: the arena's pixels
        // are the same with or without it, at any frame size.
        for (w, h) in [(512, 512), (700, 700), (800, 400), (1024, 600), (120, 120), (16, 16)] {
            let mut s = scene();
            s.step = None;
            let plain = render(&s, w, h).unwrap();
            s.step = Some(288);
            let counted = render(&s, w, h).unwrap();
            let top = View::new(s.border, w, h).px([s.border[0], s.border[3]]).1.floor() as usize;
            let row = 3 * w as usize;
            assert!(plain[..top * row] != counted[..top * row], "{w}x{h}: no counter drawn in the band");
            assert!(plain[top * row..] == counted[top * row..], "{w}x{h}: the counter reaches into the arena");
        }
    }

    #[test]
    fn the_legend_has_a_glyph_for_every_letter_and_fits_the_band() {
        for (_, _, label) in LEGEND {
            assert!(label.chars().all(|c| glyph(c).is_some()), "{label}");
        }
        // 512 px: drawn, in the band (the arena untouched, as for the counter), left of the
        // right edge; the band has legend ink (black) near its right end.
        let s = scene();
        let (w, h) = (512u32, 512u32);
        let frame = render(&s, w, h).unwrap();
        let top = View::new(s.border, w, h).px([s.border[0], s.border[3]]).1.floor() as usize;
        let inked = (0..top).any(|y| (w as usize / 2..w as usize - 2).any(|x| pixel(&frame, w, (x as f32, y as f32)) == [0, 0, 0]));
        assert!(inked, "no legend text in the band's right half");
    }

    #[test]
    fn bad_sizes_and_borders_are_errors() {
        assert!(render(&scene(), 8, 100).unwrap_err().contains("frame size"));
        let mut s = scene();
        s.border = [0.0, 0.0, 0.0, 1.0];
        assert!(render(&s, 100, 100).unwrap_err().contains("border"));
    }
}
