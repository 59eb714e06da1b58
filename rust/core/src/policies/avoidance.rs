//! docs/world-and-laws.md §4 — heading-based obstacle avoidance (source §1.5, eqs. 9–13).
//!
//! An agent at p with a desired velocity (v_d, θ_d) looks at the *items* around it:
//!
//! - each wall closer than `avoidance.wall_range`: ψ perpendicular towards it,
//!   Δ = acos(d / wall_range);
//! - each obstacle whose surface is closer than `avoidance.obstacle_range` (r_a): ψ, Δ from
//!   [`Obstacle::extent`] (exact tangent cone of a circle, tangent rays of a polygon's visible
//!   part);
//! - (wolves only) each other wolf whose centre is closer than `seed000.partner_range`:
//!   ψ towards it, Δ = `seed000.partner_half_angle`, not widened.
//!
//! Every non-partner Δ is widened by κ from the table row chosen by who is avoiding (wolf or
//! target) and whether one or several items are in range (partners count). The danger intervals
//! (ψ − κΔ, ψ + κΔ) are merged circularly; then, in this order of precedence:
//!
//! 1. early exits (wolves): no avoidance near a target that is being captured;
//! 2. emergency: a merged interval closer than `danger_distance` (static circles excepted)
//!    makes the agent flee straight away from it for `danger_steps` steps;
//! 3. close partner (wolves): steer away from partners closer than `partner_danger` ahead;
//! 4. normal mode (eqs. 11–13): θ_d inside an interval → nearer edge pushed out by
//!    `edge_margin`; the target variant tests its current heading instead (§4.8).
//!
//! Choices the sources leave open, settled in §4.3–§4.8 and §8 (each repeated where it is coded):
//! - Emergency beats close-partner steering, which beats normal mode: an obstacle contact ends
//!   the episode, so fleeing it comes first; a partner ahead is the next nearest hazard.
//! - Early exits skip the whole of avoidance, a running emergency included (its clock still
//!   runs): near a target being captured the hunt matters more than the margin.
//! - Partner items never trigger an emergency (their distance is a centre distance, and
//!   close-partner steering is the dedicated rule); in a merged interval they do not count for
//!   its distance.
//! - Two readings are parameters, documented with their measured effect in config/laws.rs
//!   (`AvoidanceParams::wall_emergency`, `AvoidanceParams::target_edge_from_desired`): whether
//!   walls can trigger emergencies, and whether the target variant's nearer edge is measured
//!   from θ_d (eq. 13 of the source) or from the heading θ.
//! - An emergency keeps steering for its whole duration even if its cause left the range
//!   (§4.5).
//! - Intervals that touch are merged (a gap of zero width is no way through).
//! - A merged interval covering the whole circle has no edge: normal mode keeps θ_d.
//! - Ties for the "nearer edge" go to the lower (clockwise) edge.
//! - A partner is ahead when strictly less than π/2 lies between θ_d and the direction to it
//!   (§4.6); a flight or steering direction more than π/2 from the current heading θ (the turn
//!   the saturator would have to make) means v = 0 (§4.5, §4.6).
//! - Coincident agents (zero distance) give no direction and are no partner item.
//!
//! No allocation: items and intervals live in fixed stack buffers of [`MAX_ITEMS`]; beyond it
//! the farthest items are dropped (they still count for κ).

use arrayvec::ArrayVec;

use super::Snapshot;
use crate::config::{AvoidanceParams, KappaRow};
use crate::math::{acos, angle_of, wrap, Vec2, FRAC_PI_2, PI, TAU};
use crate::policies::saturator::{next_heading, saturate};
pub use crate::scene::DangerMemory;
use crate::scene::{LawMode, Obstacle, ObstacleKind};

/// Items kept per agent and step; more are dropped farthest first (12 obstacles + 4 walls +
/// a few partners in the documented scenario).
pub const MAX_ITEMS: usize = 32;

/// What an item is, for its κ.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ItemKind {
    Wall,
    Obstacle(ObstacleKind),
    /// Another wolf (its index), wolves only.
    Partner(usize),
}

/// One thing to avoid: direction ψ, un-widened half-angle Δ, distance (surface distance for
/// walls and obstacles, centre distance for partners).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Item {
    pub kind: ItemKind,
    pub psi: f64,
    pub delta: f64,
    pub dist: f64,
}

/// The items in range, on the stack.
#[derive(Debug, Clone)]
pub struct Items {
    // ArrayVec: no initialisation of the 32 slots (initialising them from a constant array cost
    // a 1.3 KB memcpy per agent and step, a few per cent of the documented step: BENCHMARKS.md,
    // "Optimisations").
    buf: ArrayVec<Item, MAX_ITEMS>,
    /// Items seen, dropped ones included: the count that picks the κ row.
    seen: usize,
}

impl Default for Items {
    fn default() -> Self {
        Self { buf: ArrayVec::new(), seen: 0 }
    }
}

impl Items {
    /// Adds an item; when the buffer is full the farthest item gives way to a closer one.
    pub fn push(&mut self, it: Item) {
        self.seen += 1;
        if !self.buf.is_full() {
            self.buf.push(it);
            return;
        }
        let (far, _) = self.buf.iter().enumerate().fold((0, f64::NEG_INFINITY), |b, (k, x)| if x.dist > b.1 { (k, x.dist) } else { b });
        if it.dist < self.buf[far].dist {
            self.buf[far] = it;
        }
    }

    pub fn as_slice(&self) -> &[Item] {
        &self.buf
    }

    /// Items in range, for the κ row (docs/world-and-laws.md §4.2: partners included in the count).
    pub fn count(&self) -> usize {
        self.seen
    }
}

/// Walls closer than `range`: ψ = outward normal of the wall (towards it), Δ = acos(d/range).
pub fn collect_walls(p: Vec2, border: &[f64; 4], range: f64, items: &mut Items) {
    let [x0, y0, x1, y1] = *border;
    for (d, psi) in [(p.x - x0, PI), (x1 - p.x, 0.0), (p.y - y0, 1.5 * PI), (y1 - p.y, FRAC_PI_2)] {
        if d < range {
            // Outside the arena (never, for a feasible agent) counts as touching.
            let d = d.max(0.0);
            items.push(Item { kind: ItemKind::Wall, psi, delta: acos(d / range), dist: d });
        }
    }
}

/// Obstacles whose surface is closer than `range`.
pub fn collect_obstacles<'a>(p: Vec2, obstacles: impl IntoIterator<Item = &'a Obstacle>, range: f64, items: &mut Items) {
    for o in obstacles {
        if let Some(e) = o.extent(p, range) {
            items.push(Item { kind: ItemKind::Obstacle(o.kind), psi: e.psi, delta: e.delta, dist: e.dist });
        }
    }
}

/// Other wolves whose centre is closer than `range` (wolf `i` itself and coincident wolves
/// excluded: no direction).
pub fn collect_partners(i: usize, wolves: &[crate::scene::AgentState], range: f64, half_angle: f64, items: &mut Items) {
    let p = wolves[i].pos;
    for (k, w) in wolves.iter().enumerate() {
        let d = (w.pos - p).norm();
        if k != i && d > 0.0 && d < range {
            items.push(Item { kind: ItemKind::Partner(k), psi: angle_of(w.pos - p), delta: half_angle, dist: d });
        }
    }
}

/// κ of an item from a table row; partners are not widened.
pub fn kappa(row: &KappaRow, kind: ItemKind) -> f64 {
    match kind {
        ItemKind::Wall => row.wall,
        ItemKind::Obstacle(ObstacleKind::StaticCircle | ObstacleKind::MovingCircle) => row.circle,
        ItemKind::Obstacle(ObstacleKind::StaticPolygon) => row.static_polygon,
        ItemKind::Obstacle(ObstacleKind::MovingPolygon) => row.moving_polygon,
        ItemKind::Partner(_) => 1.0,
    }
}

/// The κ row: wolf or target, one item or several.
pub fn kappa_row(a: &AvoidanceParams, wolf: bool, count: usize) -> &KappaRow {
    match (wolf, count <= 1) {
        (true, true) => &a.wolf_single,
        (true, false) => &a.wolf_multi,
        (false, true) => &a.target_single,
        (false, false) => &a.target_multi,
    }
}

/// A danger interval (lo, hi) read anticlockwise, lo ∈ [0, 2π), lo ≤ hi ≤ lo + 2π (unwrapped
/// upper end). `dist` is the distance of its closest (non-partner) member; `exempt` whether
/// that member can make no emergency (a static circle; a wall unless `wall_emergency`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
    pub dist: f64,
    pub exempt: bool,
}

impl Interval {
    /// (ψ − κΔ, ψ + κΔ); a half-width beyond π covers the whole circle.
    pub fn of(it: &Item, kappa: f64, wall_emergency: bool) -> Self {
        let h = (kappa * it.delta).clamp(0.0, PI);
        let lo = wrap(it.psi - h);
        let (dist, exempt) = match it.kind {
            // Partners never make an emergency and do not count for the distance.
            ItemKind::Partner(_) => (f64::INFINITY, true),
            ItemKind::Obstacle(k) => (it.dist, k == ObstacleKind::StaticCircle),
            ItemKind::Wall => (it.dist, !wall_emergency),
        };
        Self { lo, hi: lo + 2.0 * h, dist, exempt }
    }

    pub fn width(&self) -> f64 {
        self.hi - self.lo
    }

    pub fn is_full(&self) -> bool {
        self.width() >= TAU
    }

    /// Direction of the bisector.
    pub fn bisector(&self) -> f64 {
        wrap(0.5 * (self.lo + self.hi))
    }

    /// `a` lies strictly inside (the open interval).
    pub fn contains(&self, a: f64) -> bool {
        let off = wrap(a - self.lo);
        off > 0.0 && off < self.width()
    }

    /// The edge nearer to `a` (eq. 13's argmin of dif; ties: the lower edge), pushed outward
    /// by `margin`. `a` may lie outside the interval (the target variant measures from θ_d).
    pub fn nearer_edge(&self, a: f64, margin: f64) -> f64 {
        if dif(a, self.lo) <= dif(a, self.hi) {
            wrap(self.lo - margin)
        } else {
            wrap(self.hi + margin)
        }
    }

    /// Takes `other` (which starts at or before this one's end) into this one.
    fn absorb(&mut self, other: &Interval, other_hi: f64) {
        self.hi = self.hi.max(other_hi).min(self.lo + TAU);
        // Keep the closest member; on a tie prefer the one that can trigger an emergency.
        if other.dist < self.dist || (other.dist == self.dist && !other.exempt) {
            self.dist = other.dist;
            self.exempt = other.exempt;
        }
    }
}

/// The merged danger intervals of one agent and step, on the stack.
#[derive(Debug, Clone)]
pub struct Merged {
    buf: ArrayVec<Interval, MAX_ITEMS>,
}

impl Merged {
    /// Widens every item by its κ and merges overlapping (or touching) intervals circularly.
    pub fn new(items: &[Item], row: &KappaRow, wall_emergency: bool) -> Self {
        let mut m = Self::empty();
        m.fill(items, row, wall_emergency);
        m
    }

    /// No interval: the buffer [`Merged::fill`] writes into.
    pub fn empty() -> Self {
        Self { buf: ArrayVec::new() }
    }

    /// [`Merged::new`] into this buffer, in place. The laws call this on a buffer of their
    /// own stack frame: returning the 1 KB buffer by value cost a `memcpy` per agent and step,
    /// a small share of a step's instructions (BENCHMARKS.md, "Optimisations").
    pub fn fill(&mut self, items: &[Item], row: &KappaRow, wall_emergency: bool) {
        self.buf.clear();
        for it in items.iter().take(MAX_ITEMS) {
            self.buf.push(Interval::of(it, kappa(row, it.kind), wall_emergency));
        }
        self.merge();
    }

    pub fn as_slice(&self) -> &[Interval] {
        &self.buf
    }

    fn merge(&mut self) {
        let v = &mut self.buf[..];
        // Insertion sort by start: a handful of items, no allocation.
        for a in 1..v.len() {
            let mut b = a;
            while b > 0 && v[b - 1].lo > v[b].lo {
                v.swap(b - 1, b);
                b -= 1;
            }
        }
        // Linear sweep on the unwrapped line.
        let mut w = 0;
        for r in 0..v.len() {
            if w > 0 && v[r].lo <= v[w - 1].hi {
                let x = v[r];
                v[w - 1].absorb(&x, x.hi);
            } else {
                v[w] = v[r];
                w += 1;
            }
        }
        // Across 0/2π: the last interval may run past 2π into the first ones.
        while w > 1 && v[w - 1].hi - TAU >= v[0].lo {
            let first = v[0];
            v[w - 1].absorb(&first, first.hi + TAU);
            v.copy_within(1..w, 0);
            w -= 1;
        }
        self.buf.truncate(w);
    }

    /// The interval that strictly contains `a`, if any.
    pub fn containing(&self, a: f64) -> Option<&Interval> {
        self.as_slice().iter().find(|iv| iv.contains(a))
    }

    /// The closest merged interval nearer than `d_danger` whose closest member is not exempt
    /// (static circles): the emergency's cause. Returns the heading straight away from
    /// its bisector.
    pub fn emergency(&self, d_danger: f64) -> Option<f64> {
        self.as_slice().iter().filter(|iv| iv.dist < d_danger && !iv.exempt).min_by(|a, b| a.dist.total_cmp(&b.dist)).map(|iv| wrap(iv.bisector() + PI))
    }
}

/// Unsigned angle between two directions, in [0, π] (source eq. 2).
#[inline]
pub fn dif(a: f64, b: f64) -> f64 {
    let e = wrap(a - b);
    if e > PI {
        TAU - e
    } else {
        e
    }
}

/// Heads for `dir` at `v_max`, or stands (v = 0) if that is more than a quarter turn from the
/// current heading `theta` (docs/world-and-laws.md §4.5, §4.6).
fn dash(dir: f64, theta: f64, v_max: f64) -> (f64, f64) {
    (if dif(dir, theta) > FRAC_PI_2 { 0.0 } else { v_max }, dir)
}

/// Emergency bookkeeping: a new trigger (re)starts the clock at `steps`; while steps are left
/// one is spent and the flight heading returned. With `steps` = 3 the agent flees on the
/// triggering step and the 2 after it.
pub fn tick_danger(danger: &mut DangerMemory, trigger: Option<f64>, steps: u32) -> Option<f64> {
    if let Some(away) = trigger {
        danger.steps_left = steps;
        danger.away = away;
    }
    if danger.steps_left > 0 {
        danger.steps_left -= 1;
        Some(danger.away)
    } else {
        None
    }
}

/// Early exits of docs/world-and-laws.md §4.4.1 (wolves): within `early_exit_distance` of its
/// target while at least `capture_count` wolves are (this one included), or when the only item is a
/// wall.
fn early_exit(i: usize, snap: &Snapshot, items: &Items) -> bool {
    let p = snap.params;
    let r = p.avoidance.early_exit_distance;
    let target = snap.targets[snap.wolf_target[i]].pos;
    if (snap.wolves[i].pos - target).norm() > r {
        return false;
    }
    let only_wall = items.count() == 1 && items.as_slice().first().is_some_and(|it| it.kind == ItemKind::Wall);
    only_wall || snap.wolves.iter().filter(|w| (w.pos - target).norm() <= r).count() >= p.capture_count()
}

/// Close-partner steering (docs/world-and-laws.md §4.6): the direction of
/// Σ (p_i − p_k)/‖p_i − p_k‖² over the partners closer than `partner_danger` and ahead of θ_d
/// (each marked in `row`). Note the true inverse-square vector, not the reference's element-wise
/// reciprocal. `None` when no partner qualifies or the sum vanishes (symmetric partners:
/// nothing to prefer).
fn close_partner(i: usize, snap: &Snapshot, theta_d: f64, row: &mut [u8]) -> Option<f64> {
    let p = snap.wolves[i].pos;
    let r2 = snap.params.seed000.partner_danger.powi(2);
    let mut sum = Vec2::zeros();
    for (k, w) in snap.wolves.iter().enumerate() {
        let d = p - w.pos;
        let n2 = d.norm_squared();
        if k == i || n2 == 0.0 || n2 >= r2 || dif(angle_of(-d), theta_d) >= FRAC_PI_2 {
            continue;
        }
        sum += d / n2;
        row[k] = 1;
    }
    (sum != Vec2::zeros()).then(|| angle_of(sum))
}

/// Which rule of docs/world-and-laws.md §4.4 decided an agent's heading (for tests, diagnostics and
/// the law's [`LawMode`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Early exit: avoidance skipped.
    EarlyExit,
    /// Fleeing an emergency (new or still running).
    Emergency,
    /// Steering away from partners ahead.
    ClosePartner,
    /// Normal mode; `true` when θ_d was moved to an interval edge.
    Normal(bool),
    /// The target variant kept the current heading: a step towards θ_d would turn into an
    /// interval.
    Hold,
}

impl Mode {
    /// The law's mode once avoidance has run: avoidance's own where it changed the desired
    /// velocity or skipped itself, else `base`, the branch of the law that asked for it.
    pub fn law_mode(self, base: LawMode) -> LawMode {
        match self {
            Mode::EarlyExit => LawMode::EarlyExit,
            Mode::Emergency => LawMode::Emergency,
            Mode::ClosePartner => LawMode::ClosePartner,
            Mode::Normal(true) => LawMode::AvoidEdge,
            Mode::Normal(false) => base,
            Mode::Hold => LawMode::AvoidHold,
        }
    }
}

/// Avoidance for wolf `i` (docs/world-and-laws.md §4, wolf rows). Returns the new (v_d, θ_d) for
/// the saturator and marks in `row` the partners whose positions it used.
pub fn wolf(i: usize, snap: &Snapshot, v_d: f64, theta_d: f64, danger: &mut DangerMemory, row: &mut [u8]) -> (f64, f64) {
    let (v, th, _) = wolf_mode(i, snap, v_d, theta_d, danger, row);
    (v, th)
}

/// [`wolf`], also telling which rule decided.
pub fn wolf_mode(i: usize, snap: &Snapshot, v_d: f64, theta_d: f64, danger: &mut DangerMemory, row: &mut [u8]) -> (f64, f64, Mode) {
    let p = snap.params;
    let a = &p.avoidance;
    let me = snap.wolves[i];
    let mut items = Items::default();
    collect_walls(me.pos, &p.world.border, a.wall_range, &mut items);
    collect_obstacles(me.pos, crate::scene::near(snap.obstacles, snap.near, i), a.obstacle_range, &mut items);
    collect_partners(i, snap.wolves, p.seed000.partner_range, p.seed000.partner_half_angle, &mut items);

    if early_exit(i, snap, &items) {
        // No avoidance at all; a running emergency's clock still runs.
        tick_danger(danger, None, a.danger_steps);
        return (v_d, theta_d, Mode::EarlyExit);
    }
    for it in items.as_slice() {
        if let ItemKind::Partner(k) = it.kind {
            row[k] = 1;
        }
    }
    let mut merged = Merged::empty();
    merged.fill(items.as_slice(), kappa_row(a, true, items.count()), a.wall_emergency);

    if let Some(away) = tick_danger(danger, merged.emergency(a.danger_distance), a.danger_steps) {
        let (v, th) = dash(away, me.theta, p.agents.wolf.v_max);
        return (v, th, Mode::Emergency);
    }
    if let Some(dir) = close_partner(i, snap, theta_d, row) {
        let (v, th) = dash(dir, me.theta, p.agents.wolf.v_max);
        return (v, th, Mode::ClosePartner);
    }
    let th = normal_mode(&merged, theta_d, a.edge_margin);
    (v_d, th, Mode::Normal(th != theta_d))
}

/// Normal mode (eqs. 11–13): θ_d strictly inside a merged interval → its nearer edge pushed
/// outward by `margin`; a full-circle interval has no edge and leaves θ_d alone.
pub fn normal_mode(merged: &Merged, theta_d: f64, margin: f64) -> f64 {
    match merged.containing(theta_d) {
        Some(iv) if !iv.is_full() => iv.nearer_edge(theta_d, margin),
        _ => theta_d,
    }
}

/// Avoidance for target `j` (docs/world-and-laws.md §4.2 target rows, §4.8 target variant). Wolves
/// are not obstacles for the target.
pub fn target(j: usize, snap: &Snapshot, v_d: f64, theta_d: f64, danger: &mut DangerMemory) -> (f64, f64) {
    let (v, th, _) = target_mode(j, snap, v_d, theta_d, danger);
    (v, th)
}

/// [`target`], also telling which rule decided.
pub fn target_mode(j: usize, snap: &Snapshot, v_d: f64, theta_d: f64, danger: &mut DangerMemory) -> (f64, f64, Mode) {
    let p = snap.params;
    let a = &p.avoidance;
    let me = snap.targets[j];
    let side = &p.agents.target;
    let mut items = Items::default();
    collect_walls(me.pos, &p.world.border, a.wall_range, &mut items);
    collect_obstacles(me.pos, crate::scene::near(snap.obstacles, snap.near, snap.wolves.len() + j), a.obstacle_range, &mut items);
    let mut merged = Merged::empty();
    merged.fill(items.as_slice(), kappa_row(a, false, items.count()), a.wall_emergency);

    if let Some(away) = tick_danger(danger, merged.emergency(a.danger_distance), a.danger_steps) {
        let (v, th) = dash(away, me.theta, side.v_max);
        return (v, th, Mode::Emergency);
    }
    let (th, mode) = target_variant_mode(&merged, v_d, theta_d, me.theta, side.v_max, side.omega_max, p.world.ts, a.edge_margin, a.target_edge_from_desired);
    (v_d, th, mode)
}

/// The target variant of normal mode: test the current heading θ, not θ_d. θ inside an
/// interval → that interval's edge nearer to θ_d (`from_desired`, eq. 13) or to θ,
/// pushed out; otherwise, if one saturator step towards θ_d would turn into an interval, keep
/// the current heading.
#[allow(clippy::too_many_arguments)]
pub fn target_variant(merged: &Merged, v_d: f64, theta_d: f64, theta: f64, v_max: f64, omega_max: f64, ts: f64, margin: f64, from_desired: bool) -> f64 {
    target_variant_mode(merged, v_d, theta_d, theta, v_max, omega_max, ts, margin, from_desired).0
}

/// [`target_variant`], also telling which rule decided: `Normal(true)` (an edge), `Hold` (the
/// current heading kept) or `Normal(false)` (θ_d kept).
#[allow(clippy::too_many_arguments)]
pub fn target_variant_mode(merged: &Merged, v_d: f64, theta_d: f64, theta: f64, v_max: f64, omega_max: f64, ts: f64, margin: f64, from_desired: bool) -> (f64, Mode) {
    if let Some(iv) = merged.containing(theta) {
        let from = if from_desired { theta_d } else { theta };
        return if iv.is_full() { (theta_d, Mode::Normal(false)) } else { (iv.nearer_edge(from, margin), Mode::Normal(true)) };
    }
    let next = next_heading(theta, saturate(v_d, theta_d, theta, v_max, omega_max, ts), ts);
    if merged.containing(next).is_some() {
        (theta, Mode::Hold)
    } else {
        (theta_d, Mode::Normal(false))
    }
}

#[cfg(test)]
mod tests {
    use super::DangerMemory;
    use super::*;
    use crate::scene::AgentState;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    /// Equal as directions (2π − ε and 0 are the same heading).
    fn aclose(a: f64, b: f64) -> bool {
        dif(a, b) < 1e-9
    }

    fn v(x: f64, y: f64) -> Vec2 {
        Vec2::new(x, y)
    }

    use crate::policies::fixture::Scene as World;

    fn item(kind: ItemKind, psi: f64, delta: f64, dist: f64) -> Item {
        Item { kind, psi, delta, dist }
    }

    // ---- items ----

    #[test]
    fn wall_item_is_perpendicular_with_acos_half_angle() {
        // At (9.3, 0): right wall at d = 0.7 < 1.4 → ψ = 0, Δ = acos(0.5) = π/3.
        let mut items = Items::default();
        collect_walls(v(9.3, 0.0), &[-10.0, -10.0, 10.0, 10.0], 1.4, &mut items);
        assert_eq!(items.count(), 1);
        let it = items.as_slice()[0];
        assert_eq!(it.kind, ItemKind::Wall);
        assert!(close(it.psi, 0.0) && close(it.delta, PI / 3.0) && close(it.dist, 0.7), "{it:?}");
        // Corner (−9, −9.65): left (d=1, ψ=π, Δ=acos(1/1.4)) and bottom (d=0.35, ψ=3π/2,
        // Δ=acos(0.25)).
        let mut items = Items::default();
        collect_walls(v(-9.0, -9.65), &[-10.0, -10.0, 10.0, 10.0], 1.4, &mut items);
        let s = items.as_slice();
        assert_eq!(s.len(), 2);
        assert!(close(s[0].psi, PI) && close(s[0].delta, (1.0f64 / 1.4).acos()));
        assert!(close(s[1].psi, 1.5 * PI) && close(s[1].delta, (0.25f64).acos()));
    }

    #[test]
    fn circle_item_uses_the_exact_tangent() {
        // Circle radius 0.5 centred 1.5 above: d = 1.0 < r_a, ψ = π/2, Δ = asin(0.5/1.5).
        let obs = [Obstacle::circle(v(0.0, 1.5), 0.5, false), Obstacle::circle(v(0.0, -3.0), 0.5, true)];
        let mut items = Items::default();
        collect_obstacles(v(0.0, 0.0), &obs, 1.6479672158640435, &mut items);
        assert_eq!(items.count(), 1, "the far circle (d = 2.5) is out of range");
        let it = items.as_slice()[0];
        assert_eq!(it.kind, ItemKind::Obstacle(ObstacleKind::StaticCircle));
        assert!(close(it.psi, FRAC_PI_2) && close(it.delta, (1.0f64 / 3.0).asin()) && close(it.dist, 1.0));
    }

    #[test]
    fn polygon_items_are_the_tangent_cone_of_the_visible_part() {
        // Square of half-side 0.5 centred at (2, 0): d = 1.5; tangent rays through the near
        // corners (1.5, ±0.5) → ψ = 0, Δ = atan(0.5/1.5). Static and moving kinds kept.
        let sq = |c: Vec2| vec![c + v(-0.5, -0.5), c + v(0.5, -0.5), c + v(0.5, 0.5), c + v(-0.5, 0.5)];
        let obs = [Obstacle::polygon(v(2.0, 0.0), sq(v(2.0, 0.0)), false), Obstacle::polygon(v(0.0, -2.0), sq(v(0.0, -2.0)), true)];
        let mut items = Items::default();
        collect_obstacles(v(0.0, 0.0), &obs, 1.6479672158640435, &mut items);
        let s = items.as_slice();
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].kind, ItemKind::Obstacle(ObstacleKind::StaticPolygon));
        assert!(close(wrap(s[0].psi + 0.1) - 0.1, 0.0) && close(s[0].delta, (1.0f64 / 3.0).atan()) && close(s[0].dist, 1.5), "{:?}", s[0]);
        assert_eq!(s[1].kind, ItemKind::Obstacle(ObstacleKind::MovingPolygon));
        assert!(close(s[1].psi, 1.5 * PI) && close(s[1].delta, (1.0f64 / 3.0).atan()));
    }

    #[test]
    fn partner_items_within_range_only() {
        // Wolf 0 at origin; wolf 1 at (0, 0.8): partner, ψ = π/2, Δ = π/12; wolf 2 at 1.2: not.
        let wolves = [AgentState::at(0.0, 0.0, 0.0), AgentState::at(0.0, 0.8, 0.0), AgentState::at(1.2, 0.0, 0.0), AgentState::at(0.0, 0.0, 1.0)];
        let mut items = Items::default();
        collect_partners(0, &wolves, 1.0, PI / 12.0, &mut items);
        assert_eq!(items.count(), 1, "coincident wolf 3 gives no direction");
        let it = items.as_slice()[0];
        assert_eq!(it.kind, ItemKind::Partner(1));
        assert!(close(it.psi, FRAC_PI_2) && close(it.delta, PI / 12.0) && close(it.dist, 0.8));
    }

    #[test]
    fn items_buffer_keeps_the_closest_when_full() {
        let mut items = Items::default();
        for k in 0..MAX_ITEMS + 5 {
            items.push(item(ItemKind::Wall, 0.0, 0.1, 100.0 - k as f64));
        }
        assert_eq!(items.count(), MAX_ITEMS + 5);
        assert_eq!(items.as_slice().len(), MAX_ITEMS);
        let far = items.as_slice().iter().map(|i| i.dist).fold(0.0, f64::max);
        assert_eq!(far, 100.0 - 5.0, "the five farthest were dropped");
    }

    // ---- κ table ----

    #[test]
    fn kappa_rows_follow_the_table() {
        let a = AvoidanceParams::default();
        let c = ItemKind::Obstacle(ObstacleKind::MovingCircle);
        let sp = ItemKind::Obstacle(ObstacleKind::StaticPolygon);
        let mp = ItemKind::Obstacle(ObstacleKind::MovingPolygon);
        let w = ItemKind::Wall;
        let rows = [(true, 1, [1.6, 2.4, 2.4, 3.2]), (true, 2, [1.3, 1.8, 1.8, 2.2]), (false, 1, [1.6, 2.0, 2.0, 2.8]), (false, 3, [1.3, 1.6, 1.6, 2.0])];
        for (wolf, n, want) in rows {
            let r = kappa_row(&a, wolf, n);
            assert_eq!([kappa(r, w), kappa(r, c), kappa(r, sp), kappa(r, mp)], want, "wolf={wolf} n={n}");
            assert_eq!(kappa(r, ItemKind::Partner(0)), 1.0);
        }
        assert_eq!(kappa(kappa_row(&a, true, 1), ItemKind::Obstacle(ObstacleKind::StaticCircle)), 2.4);
    }

    #[test]
    fn partner_counts_for_the_row_but_is_not_widened() {
        // A circle (Δ = 0.2) and a partner (Δ = π/12): two items → wolf_multi, circle κ = 1.8.
        let items = [item(ItemKind::Obstacle(ObstacleKind::MovingCircle), 1.0, 0.2, 1.0), item(ItemKind::Partner(3), 4.0, PI / 12.0, 0.7)];
        let a = AvoidanceParams::default();
        let m = Merged::new(&items, kappa_row(&a, true, 2), true);
        let s = m.as_slice();
        assert_eq!(s.len(), 2);
        assert!(close(s[0].lo, 1.0 - 0.36) && close(s[0].hi, 1.0 + 0.36), "{s:?}");
        assert!(close(s[1].lo, 4.0 - PI / 12.0) && close(s[1].hi, 4.0 + PI / 12.0), "{s:?}");
        assert_eq!(s[1].dist, f64::INFINITY, "partners never make an emergency");
    }

    // ---- merging ----

    #[test]
    fn overlapping_intervals_merge_and_keep_the_closest_distance() {
        let row = KappaRow { wall: 1.0, circle: 1.0, static_polygon: 1.0, moving_polygon: 1.0 };
        // (0.5, 1.5) d=1.0 static circle, (1.2, 2.0) d=0.5 polygon, (3, 4) apart.
        let items = [
            item(ItemKind::Obstacle(ObstacleKind::StaticCircle), 1.0, 0.5, 1.0),
            item(ItemKind::Obstacle(ObstacleKind::StaticPolygon), 1.6, 0.4, 0.5),
            item(ItemKind::Obstacle(ObstacleKind::StaticCircle), 3.5, 0.5, 0.1),
        ];
        let m = Merged::new(&items, &row, true);
        let s = m.as_slice();
        assert_eq!(s.len(), 2, "{s:?}");
        assert!(close(s[0].lo, 0.5) && close(s[0].hi, 2.0) && close(s[0].dist, 0.5) && !s[0].exempt, "{s:?}");
        assert!(close(s[1].lo, 3.0) && close(s[1].hi, 4.0) && s[1].exempt);
        assert!(close(s[0].bisector(), 1.25));
    }

    #[test]
    fn intervals_merge_across_zero() {
        let row = KappaRow { wall: 1.0, circle: 1.0, static_polygon: 1.0, moving_polygon: 1.0 };
        // (2π − 0.3, 2π + 0.1), (0.05, 0.5) and (5.9, 6.1): sorted by start (0.05..0.5),
        // (5.9..6.1), (5.983..6.383); the last two merge into (5.9, 6.383), which runs 0.1
        // past 2π over the start 0.05 of the first → one interval (5.9, 2π + 0.5) of width
        // 0.883 and distance min(1.0, 0.9, 0.8) = 0.8.
        let items = [item(ItemKind::Wall, TAU - 0.1, 0.2, 1.0), item(ItemKind::Wall, 0.275, 0.225, 0.9), item(ItemKind::Wall, 6.0, 0.1, 0.8)];
        let m = Merged::new(&items, &row, true);
        let s = m.as_slice();
        assert_eq!(s.len(), 1, "{s:?}");
        assert!(close(s[0].lo, 5.9) && close(s[0].hi, TAU + 0.5), "{s:?}");
        assert!(close(s[0].dist, 0.8));
        assert!(close(s[0].bisector(), wrap(0.5 * (5.9 + TAU + 0.5))));
        assert!(s[0].contains(0.0) && s[0].contains(6.1) && s[0].contains(0.4) && !s[0].contains(0.6));
        // Nearer edge of 0.4 is the upper one (0.5 + 0.01); of 6.0 the lower one (5.9 − 0.01).
        assert!(close(s[0].nearer_edge(0.4, 0.01), 0.51));
        assert!(close(s[0].nearer_edge(6.0, 0.01), 5.89));
    }

    #[test]
    fn a_wide_interval_wrapping_covers_following_ones() {
        let row = KappaRow { wall: 1.0, circle: 1.0, static_polygon: 1.0, moving_polygon: 1.0 };
        // (4, 4 + 3) = (4, 7.0) wraps to 0.717; (0.2, 0.4) lies under it; (1.0, 1.2) apart.
        let items = [item(ItemKind::Wall, 5.5, 1.5, 1.0), item(ItemKind::Wall, 0.3, 0.1, 0.2), item(ItemKind::Wall, 1.1, 0.1, 0.3)];
        let m = Merged::new(&items, &row, true);
        let s = m.as_slice();
        assert_eq!(s.len(), 2, "{s:?}");
        assert!(close(s[0].lo, 1.0) && close(s[0].hi, 1.2));
        assert!(close(s[1].lo, 4.0) && close(s[1].hi, 7.0) && close(s[1].dist, 0.2), "{s:?}");
    }

    #[test]
    fn widening_beyond_pi_covers_the_circle_and_keeps_theta_d() {
        let row = KappaRow { wall: 3.0, circle: 1.0, static_polygon: 1.0, moving_polygon: 1.0 };
        let m = Merged::new(&[item(ItemKind::Wall, 1.0, 1.2, 0.5)], &row, true);
        assert!(m.as_slice()[0].is_full());
        assert_eq!(normal_mode(&m, 2.0, 0.01), 2.0);
    }

    // ---- normal mode ----

    #[test]
    fn normal_mode_moves_theta_d_to_the_nearer_edge() {
        let row = KappaRow { wall: 1.0, circle: 2.0, static_polygon: 1.0, moving_polygon: 1.0 };
        // Circle ψ = 1.0, Δ = 0.25, κ = 2 → (0.5, 1.5).
        let m = Merged::new(&[item(ItemKind::Obstacle(ObstacleKind::MovingCircle), 1.0, 0.25, 1.0)], &row, true);
        assert!(close(normal_mode(&m, 0.9, 0.01), 0.49));
        assert!(close(normal_mode(&m, 1.2, 0.01), 1.51));
        assert_eq!(normal_mode(&m, 1.6, 0.01), 1.6, "outside: unchanged");
        assert_eq!(normal_mode(&m, 0.5, 0.01), 0.5, "on the edge is not strictly inside");
        // Exactly at the bisector (off = 0.5 = width − off): the lower edge.
        assert!(close(normal_mode(&m, 1.0, 0.01), 0.49));
    }

    // ---- emergency ----

    #[test]
    fn emergency_flees_the_closest_interval_but_not_a_static_circle() {
        let row = KappaRow { wall: 1.0, circle: 1.0, static_polygon: 1.0, moving_polygon: 1.0 };
        let sc = ItemKind::Obstacle(ObstacleKind::StaticCircle);
        let mc = ItemKind::Obstacle(ObstacleKind::MovingCircle);
        // Static circle at 0.1 → excepted; moving circle at 0.2 at ψ = π/2 → flee to 3π/2.
        let m = Merged::new(&[item(sc, 0.0, 0.2, 0.1), item(mc, FRAC_PI_2, 0.2, 0.2)], &row, true);
        assert!(close(m.emergency(0.28489136293795562).unwrap(), 1.5 * PI));
        let m = Merged::new(&[item(sc, 0.0, 0.2, 0.1)], &row, true);
        assert_eq!(m.emergency(0.28489136293795562), None);
        // 0.29 is not closer than D_DANGER.
        let m = Merged::new(&[item(mc, 0.0, 0.2, 0.29)], &row, true);
        assert_eq!(m.emergency(0.28489136293795562), None);
        // A static circle at 0.1 merged with a moving one at 0.2: the closest member decides,
        // so the merged interval is exempt.
        let m = Merged::new(&[item(sc, 0.0, 0.2, 0.1), item(mc, 0.3, 0.2, 0.2)], &row, true);
        assert_eq!(m.as_slice().len(), 1);
        assert_eq!(m.emergency(0.28489136293795562), None);
    }

    #[test]
    fn wall_emergency_follows_the_switch() {
        // A wolf 0.1 from the right wall (ψ = 0), heading π/2 + 0.1, target far away.
        for wall_emergency in [true, false] {
            let mut w = World::new(vec![AgentState::at(9.9, 0.0, FRAC_PI_2 + 0.1)], vec![AgentState::at(0.0, 5.0, 0.0)], vec![]);
            w.params.avoidance.wall_emergency = wall_emergency;
            let mut d = DangerMemory::default();
            let (v, th, mode) = wolf_mode(0, &w.snap(), 1.0, 0.1, &mut d, &mut [0u8; 2]);
            if wall_emergency {
                // Flee straight away from the wall (π); the turn from π/2 + 0.1 is π/2 − 0.1
                // → v_max; the clock has two steps left.
                assert_eq!(mode, Mode::Emergency);
                assert!(aclose(th, PI) && v == 1.5, "({v}, {th})");
                assert_eq!(d.steps_left, 2);
            } else {
                // Normal mode: Δ = acos(0.1/1.4) = 1.4993, κ = 1.6 → half-width 2.3989; θ_d = 0.1
                // is nearer the upper edge → 2.3989 + 0.01; no clock.
                assert_eq!(mode, Mode::Normal(true));
                assert!(close(th, 1.6 * (0.1f64 / 1.4).acos() + 0.01) && v == 1.0, "({v}, {th})");
                assert_eq!(d.steps_left, 0);
            }
        }
    }

    #[test]
    fn emergency_lasts_exactly_danger_steps() {
        let mut d = DangerMemory::default();
        assert_eq!(tick_danger(&mut d, Some(2.0), 3), Some(2.0));
        assert_eq!(tick_danger(&mut d, None, 3), Some(2.0));
        assert_eq!(tick_danger(&mut d, None, 3), Some(2.0));
        assert_eq!(tick_danger(&mut d, None, 3), None);
        assert_eq!(d.steps_left, 0);
        // A new trigger while in danger restarts the clock with the new heading.
        tick_danger(&mut d, Some(1.0), 3);
        assert_eq!(tick_danger(&mut d, Some(4.0), 3), Some(4.0));
        assert_eq!(d.steps_left, 2);
    }

    #[test]
    fn wolf_emergency_in_the_world_is_sticky_and_stops_for_a_large_turn() {
        // Moving circle r = 0.5 centred at (0.7, 0): surface distance 0.2 < D_DANGER, ψ = 0,
        // a single item. Flee towards π at v_max — wolf heading 0 → the turn is π > π/2 → v = 0.
        let mut w = World::new(vec![AgentState::at(0.0, 0.0, 0.0)], vec![AgentState::at(5.0, 5.0, 0.0)], vec![Obstacle::circle(v(0.7, 0.0), 0.5, true)]);
        let mut d = DangerMemory::default();
        let mut row = [0u8; 2];
        let (vd, th) = wolf(0, &w.snap(), 1.0, 0.3, &mut d, &mut row);
        assert!(aclose(th, PI) && vd == 0.0, "({vd}, {th})");
        // Heading 2.5 rad: turn to π is 0.64 < π/2 → v_max. The obstacle is gone now, yet
        // the emergency runs this step and the next (3 in all), then normal mode returns.
        w.obstacles.clear();
        w.wolves[0].theta = 2.5;
        for _ in 0..2 {
            let (vd, th) = wolf(0, &w.snap(), 1.0, 0.3, &mut d, &mut row);
            assert!(aclose(th, PI) && vd == 1.5, "({vd}, {th})");
        }
        assert_eq!(wolf(0, &w.snap(), 1.0, 0.3, &mut d, &mut row), (1.0, 0.3));
    }

    #[test]
    fn static_circle_is_no_emergency_in_the_world() {
        // The same circle, static: normal mode instead. Single item, κ = 2.4,
        // Δ = asin(0.5/0.7) → half-width h = 2.4·0.7956 = 1.9094; θ_d = 0.3 is 1.609 from the
        // upper edge and 2.209 from the lower → h + 0.01 = 1.9194.
        let w = World::new(vec![AgentState::at(0.0, 0.0, 0.0)], vec![AgentState::at(5.0, 5.0, 0.0)], vec![Obstacle::circle(v(0.7, 0.0), 0.5, false)]);
        let mut d = DangerMemory::default();
        let (vd, th) = wolf(0, &w.snap(), 1.0, 0.3, &mut d, &mut [0u8; 2]);
        let h = 2.4 * (0.5f64 / 0.7).asin();
        assert!(close(vd, 1.0) && close(th, h + 0.01), "({vd}, {th})");
        assert_eq!(d.steps_left, 0);
    }

    // ---- early exits ----

    #[test]
    fn early_exit_when_enough_wolves_are_at_the_target() {
        // Four wolves within 0.8 of the target at the origin, wolf 0 next to a moving circle
        // that would otherwise make an emergency.
        let wolves = vec![AgentState::at(-0.5, 0.0, 0.0), AgentState::at(0.5, 0.3, 0.0), AgentState::at(0.0, 0.6, 0.0), AgentState::at(0.0, -0.6, 0.0)];
        let mut w = World::new(wolves, vec![AgentState::at(0.0, 0.0, 0.0)], vec![Obstacle::circle(v(-1.2, 0.0), 0.5, true)]);
        let mut d = DangerMemory::default();
        let mut row = [0u8; 5];
        assert_eq!(wolf(0, &w.snap(), 1.0, 0.0, &mut d, &mut row), (1.0, 0.0));
        assert_eq!(row, [0; 5], "early exit uses no partner");
        // One wolf fewer than capture_count (4): avoidance runs and the emergency fires
        // (obstacle at ψ = π → flee to 0).
        w.wolves[3] = AgentState::at(0.0, -0.9, 0.0);
        let (vd, th) = wolf(0, &w.snap(), 1.0, 0.0, &mut d, &mut row);
        assert!(aclose(th, 0.0) && vd == 1.5, "({vd}, {th})");
        assert_eq!(row, [0, 0, 1, 0, 0], "wolf 2 (0.78 away) is a partner item");
    }

    #[test]
    fn early_exit_when_the_only_item_is_a_wall() {
        // Wolf at (9.5, 0) heading into the wall (θ_d = 0) with the target 0.5 away: exit.
        let w = World::new(vec![AgentState::at(9.5, 0.0, 0.0)], vec![AgentState::at(9.5, 0.5, 0.0)], vec![]);
        let mut d = DangerMemory::default();
        assert_eq!(wolf(0, &w.snap(), 1.0, 0.0, &mut d, &mut [0u8; 2]), (1.0, 0.0));
        // Target 1.0 away: no exit. Wall d = 0.5, Δ = acos(0.5/1.4) = 1.2054, κ = 1.6 →
        // (−1.9287, 1.9287); θ_d = 0.05 is nearer the upper edge → 1.9287 + 0.01.
        let w = World::new(vec![AgentState::at(9.5, 0.0, 0.0)], vec![AgentState::at(9.5, 1.0, 0.0)], vec![]);
        let (vd, th) = wolf(0, &w.snap(), 1.0, 0.05, &mut d, &mut [0u8; 2]);
        assert!(close(vd, 1.0) && close(th, 1.6 * (0.5f64 / 1.4).acos() + 0.01), "{th}");
        // A wall and a partner 0.9 below: two items, no exit; wolf_multi κ = 1.3 → wall
        // (−1.567, 1.567) merges with the partner's (3π/2 ± π/12) into (4.451, 2π + 1.567);
        // θ_d = 0 is 1.567 from the upper edge, 1.833 from the lower → 1.567 + 0.01.
        let w = World::new(vec![AgentState::at(9.5, 0.0, 0.0), AgentState::at(9.5, -0.9, 0.0)], vec![AgentState::at(9.5, 0.5, 0.0)], vec![]);
        let mut row = [0u8; 3];
        let (_, th) = wolf(0, &w.snap(), 1.0, 0.0, &mut d, &mut row);
        assert!(close(th, 1.3 * (0.5f64 / 1.4).acos() + 0.01), "{th}");
        assert_eq!(row, [0, 1, 0], "the partner item is marked");
    }

    // ---- close partner ----

    #[test]
    fn close_partner_steers_along_the_inverse_square_sum() {
        // Wolf 0 at origin, θ_d = 0. Partners ahead: (0.4, 0) and (0.2, 0.2); one behind
        // (−0.3, 0) is ignored. Σ (p_i − p_k)/‖·‖² = (−0.4, 0)/0.16 + (−0.2, −0.2)/0.08
        // = (−2.5, 0) + (−2.5, −2.5) = (−5, −2.5) → direction atan2(−2.5, −5) = π + 0.46365.
        // The element-wise reciprocal would give (−1/0.4 − 1/0.2, −∞…): not this.
        let wolves = vec![AgentState::at(0.0, 0.0, PI + 0.3), AgentState::at(0.4, 0.0, 0.0), AgentState::at(0.2, 0.2, 0.0), AgentState::at(-0.3, 0.0, 0.0)];
        let w = World::new(wolves, vec![AgentState::at(-5.0, -5.0, 0.0)], vec![]);
        let mut row = [0u8; 5];
        let dir = close_partner(0, &w.snap(), 0.0, &mut row).unwrap();
        assert!(close(dir, PI + (0.5f64).atan()), "{dir}");
        assert_eq!(row, [0, 1, 1, 0, 0]);
        // Through the whole avoidance: heading π + 0.3 is within π/2 of the new direction →
        // v_max. Partner items (0.4, 0.283, 0.3 away) are not inside the way back.
        let mut d = DangerMemory::default();
        let (vd, th) = wolf(0, &w.snap(), 1.0, 0.0, &mut d, &mut row);
        assert!(close(vd, 1.5) && close(th, PI + (0.5f64).atan()), "({vd}, {th})");
        // Heading 0: the turn is more than π/2 → stand and turn.
        let mut w = w;
        w.wolves[0].theta = 0.0;
        let (vd, _) = wolf(0, &w.snap(), 1.0, 0.0, &mut d, &mut row);
        assert_eq!(vd, 0.0);
    }

    #[test]
    fn close_partner_weighs_by_inverse_distance_not_reciprocal_components() {
        // One partner at (0.3, 0.1): (p_i − p_k)/‖·‖² = (−0.3, −0.1)/0.1 = (−3, −1) → angle
        // π + atan(1/3). Element-wise reciprocal (−1/0.3, −1/0.1) = (−3.33, −10) would point
        // at π + atan(3): clearly different.
        let wolves = vec![AgentState::at(0.0, 0.0, 0.0), AgentState::at(0.3, 0.1, 0.0)];
        let w = World::new(wolves, vec![AgentState::at(-5.0, -5.0, 0.0)], vec![]);
        let dir = close_partner(0, &w.snap(), 0.0, &mut [0u8; 3]).unwrap();
        assert!(close(dir, PI + (1.0f64 / 3.0).atan()), "{dir}");
        assert!(!close(dir, PI + 3.0f64.atan()));
    }

    #[test]
    fn emergency_beats_close_partner() {
        // A partner ahead at 0.3 and a moving circle 0.1 away behind (ψ = π): flee to 0.
        let wolves = vec![AgentState::at(0.0, 0.0, 0.0), AgentState::at(0.3, 0.0, 0.0)];
        let w = World::new(wolves, vec![AgentState::at(5.0, 5.0, 0.0)], vec![Obstacle::circle(v(-0.6, 0.0), 0.5, true)]);
        let (vd, th) = wolf(0, &w.snap(), 1.0, 0.0, &mut DangerMemory::default(), &mut [0u8; 3]);
        assert!(aclose(th, 0.0) && vd == 1.5, "({vd}, {th})");
    }

    // ---- target variant ----

    #[test]
    fn target_variant_tests_the_current_heading() {
        let row = KappaRow { wall: 1.0, circle: 1.0, static_polygon: 1.0, moving_polygon: 1.0 };
        // Interval (0.5, 1.5).
        let m = Merged::new(&[item(ItemKind::Obstacle(ObstacleKind::MovingCircle), 1.0, 0.5, 1.0)], &row, true);
        // θ = 1.3 inside → an edge pushed out. θ_d = 3.0: both θ (0.2 from the upper edge,
        // 0.8 from the lower) and θ_d (1.5 vs 2.5) are nearer the upper one → 1.51.
        assert!(close(target_variant(&m, 1.0, 3.0, 1.3, 1.5, 7.0, 0.1, 0.01, true), 1.51));
        // θ_d = 0.2 is nearer the lower edge (0.3 vs 1.3), θ the upper: the reading decides.
        assert!(close(target_variant(&m, 1.0, 0.2, 1.3, 1.5, 7.0, 0.1, 0.01, true), 0.49));
        assert!(close(target_variant(&m, 1.0, 0.2, 1.3, 1.5, 7.0, 0.1, 0.01, false), 1.51));
        // θ = 0.6 nearer the lower edge; θ_d = 6.0 (wraps) 0.783 from the lower, 1.783 from
        // the upper → 0.49 either way.
        assert!(close(target_variant(&m, 1.0, 6.0, 0.6, 1.5, 7.0, 0.1, 0.01, true), 0.49));
        // θ = 0.0 outside, θ_d = 1.0: one saturator step turns by k = 0.7 → 0.7, inside →
        // keep θ_d := θ = 0.
        assert_eq!(target_variant(&m, 1.0, 1.0, 0.0, 1.5, 7.0, 0.1, 0.01, true), 0.0);
        // θ = 0.0, θ_d = 0.3: the step lands on 0.3, outside → θ_d unchanged, even though θ_d
        // would be fine in any case.
        assert_eq!(target_variant(&m, 1.0, 0.3, 0.0, 1.5, 7.0, 0.1, 0.01, true), 0.3);
        // θ = 0.0, θ_d = 1.0 (inside!): one step only reaches 0.7 — still inside → keep θ.
        // θ = 2.0, θ_d = 1.0 (inside): the step reaches 1.3 — inside → keep θ = 2.0.
        assert_eq!(target_variant(&m, 1.0, 1.0, 2.0, 1.5, 7.0, 0.1, 0.01, true), 2.0);
    }

    #[test]
    fn target_uses_target_rows_and_ignores_wolves() {
        // Target at (0,0), heading 0.05, moving circle r = 0.5 at (1.5, 0): d = 1.0, one
        // item, κ = 2.0 (target_single), Δ = asin(0.5/1.5) → interval ±0.6797. θ = 0.05 is
        // inside and, like θ_d = 3.0, nearer the upper edge → 0.6797 + 0.01. A wolf right
        // ahead changes nothing.
        let mut w = World::new(vec![AgentState::at(0.3, 0.0, 0.0)], vec![AgentState::at(0.0, 0.0, 0.05)], vec![Obstacle::circle(v(1.5, 0.0), 0.5, true)]);
        let h = 2.0 * (1.0f64 / 3.0).asin();
        let (vd, th) = target(0, &w.snap(), 1.2, 3.0, &mut DangerMemory::default());
        assert!(close(vd, 1.2) && close(th, h + 0.01), "({vd}, {th})");
        // Add a wall item (target at (8.8, 0) → right wall d = 1.2 < 1.4): target_multi,
        // circle κ = 1.6.
        w.targets[0] = AgentState::at(8.8, 0.0, 0.0);
        w.obstacles[0] = Obstacle::circle(v(8.8, 1.5), 0.5, true);
        // Heading π/2 − 0.1 towards the circle: circle interval π/2 ± 1.6·0.3398 =
        // (1.0271, 2.1145); wall interval 0 ± 1.3·acos(1.2/1.4) = ±0.7034: separate. θ and
        // θ_d = π/2 − 0.2 are nearer the lower edge → π/2 − 0.5437 − 0.01 (with
        // target_single's κ = 2.0 it would be π/2 − 0.6797 − 0.01).
        w.targets[0].theta = FRAC_PI_2 - 0.1;
        let (_, th) = target(0, &w.snap(), 1.0, FRAC_PI_2 - 0.2, &mut DangerMemory::default());
        assert!(close(th, FRAC_PI_2 - 1.6 * (1.0f64 / 3.0).asin() - 0.01), "{th}");
    }

    #[test]
    fn target_emergency_flees() {
        // Moving polygon 0.1 away at ψ = 0 → flee to π; heading π → v = target v_max.
        let sq = vec![v(0.6, -0.5), v(1.6, -0.5), v(1.6, 0.5), v(0.6, 0.5)];
        let w = World::new(vec![AgentState::at(-5.0, 0.0, 0.0)], vec![AgentState::at(0.5, 0.0, PI)], vec![Obstacle::polygon(v(1.1, 0.0), sq, true)]);
        let mut d = DangerMemory::default();
        let (vd, th) = target(0, &w.snap(), 0.3, 0.0, &mut d);
        assert!(aclose(th, PI) && vd == 1.5, "({vd}, {th})");
        assert_eq!(d.steps_left, 2);
    }
}
