"""A slow, plain re-derivation of the wolfpack world from docs/world-and-laws.md alone (the test oracle).

Scope: obstacle-free arenas, `seed000` wolves, `escape` (after its first sighting) or `still`
targets, the `count` capture rule. Every function cites the section of docs/world-and-laws.md it
re-derives (bare §n below). Nothing here is shared with the Rust core; `tests/test_alignment.py`
runs both from the same layout and compares every step. World rules of the step (command
clamping, §1.2; re-assignment when a hunted target is captured, §1.5; a captured target's zero
command, §1.6) follow docs/world-and-laws.md §1.6 as coded in rust/core/src/world/step.rs.

Readings taken where the laws' wording leaves room (each a plain choice, named so a disagreement
can be traced to it; those in READINGS can be flipped, and the test pins the flipped ones as known
failures):

- §3.1, the nearest other wolf that senses the target: a wolf j ≠ i within r_w of wolf i's target
  that also hunts it (READINGS["follow_same_target_only"]; literally any wolf sensing it; they
  differ only with M > 1).
- §3.1 lost (case 3): ν₁ = lost_speed · (unit direction of the last non-zero ν₁), α still
  multiplies it; zero while no non-zero ν₁ was ever computed.
- §3 a zero ν has no direction: θ_d := θ (READINGS["zero_velocity_keeps_heading"]).
- §3.2 / §1.5 repulsion neighbours p, q count (and are "used") only when closer than r_w.
- §1.5 partner wolves that are §4.1 avoidance items are information the law used, too
  (READINGS["partner_items_used"], as §1.5 lists them; flipped: only the followed partner and
  p, q).
- §4.3 / §4.5 only wall items carry a distance into the emergency test; partner items do not
  (READINGS["partners_trigger_emergency"], as §4.3 and §4.5 have it; flipped: a merged interval
  keeps the distance of its closest member, partners' centre distance included, and only static
  circles are exempt).
- §4.5 emergency applies to targets too; a new trigger while in danger restarts the count with
  the new bisector; the remembered heading is bisector + π of the triggering step.
- §4.5 "for this step and the next 2" counts world steps: a step skipped by an early exit
  (or without items) still uses one of them up.
- §4.7 normal mode at an exact tie (θ_d on the bisector, which happens whenever a wolf follows its
  nearest partner j, j is a partner item and L ∥ ν₁): §4.7 gives a tie to the lower edge, but
  rounding decides on which side of the bisector θ_d falls; `RefWorld.edge_tie` decides (the
  comparison accepts the edge the Rust world took).
- §4.8 target variant, θ_d := the nearer edge pushed out by 0.01: nearer to θ (a literal reading
  of the variant's wording) or, with the project switch `avoidance.target_edge_from_desired`
  (config.rs), nearer to θ_d; angular distances are circular, so θ_d may lie outside the interval.
- §5.1, no wolf sensed now: θ_d := θ and v_d := v · f(t)/f(t−1) with v the speed executed last step.

Project switches that depart from the literal readings (§8; config.rs, step.rs), followed when the
params carry them: `avoidance.wall_emergency: false` exempts walls from the emergency (the literal
reading of §4.5 excepts only static circles); a wolf whose speed fell below 0.01 does not turn on
the spot when the turned body would overlap a wolf (READINGS["turn_on_spot_checked"]; §1.6, the
filter's rule 4; without it the wolf only turns).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

# Readings of docs/world-and-laws.md that the Rust core may take differently (see the module docstring).
READINGS = {
    # §4.5: a partner item's centre distance counts towards the emergency (D_DANGER) test.
    "partners_trigger_emergency": False,
    # §1.5: partner wolves that are avoidance items count as information the law used.
    "partner_items_used": True,
    # §3: a zero ν has no direction; θ_d := θ (else angle 0).
    "zero_velocity_keeps_heading": True,
    # §1.6, the filter's rule 4 (a project rule, step.rs): a wolf whose speed fell below 0.01 does not turn
    # on the spot when the turned body would overlap another wolf and the unturned one would not.
    "turn_on_spot_checked": True,
    # §3.1 (M > 1): the followed partner must also hunt wolf i's target (not merely sense it).
    "follow_same_target_only": True,
}

PI = math.pi
TAU = 2.0 * math.pi


# --------------------------------------------------------------------------------------------
# Angles (docs/world-and-laws.md, Conventions: wrap maps into [0, 2π))
# --------------------------------------------------------------------------------------------
def wrap(a: float) -> float:
    r = a % TAU
    return 0.0 if r >= TAU else r


def wrap_pi(a: float) -> float:
    """Signed angle in (−π, π]."""
    r = wrap(a)
    return r - TAU if r > PI else r


def angle_of(v) -> float:
    """Direction of a vector in [0, 2π); the zero vector points along 0."""
    return wrap(math.atan2(v[1], v[0]))


# --------------------------------------------------------------------------------------------
# §2 The saturator
# --------------------------------------------------------------------------------------------
def saturate(theta: float, theta_d: float, v_d: float, v_max: float, omega_max: float, ts: float):
    """Desired (v_d, θ_d) → (v, ω) for an agent at heading θ (§2)."""
    theta, theta_d = wrap(theta), wrap(theta_d)
    k = omega_max * ts
    e = wrap(theta - theta_d)
    v_d = min(v_d, v_max)
    if e <= k:
        omega, v_d = (theta_d - theta) / ts, v_d * (1.0 - e / PI)
    elif e >= TAU - k:
        omega, v_d = (theta_d - theta) / ts, v_d * (1.0 - (TAU - e) / PI)
    elif e <= PI:
        omega, v_d = -omega_max, v_d * (1.0 - e / PI)
    else:
        omega, v_d = omega_max, v_d * (1.0 - (TAU - e) / PI)
    # unwrap ω into [−π/Ts, π/Ts]
    while omega > PI / ts:
        omega -= TAU / ts
    while omega < -PI / ts:
        omega += TAU / ts
    return min(v_d, v_max), omega


# --------------------------------------------------------------------------------------------
# §1.2 Body triangle and overlap (separating-axis test on closed triangles)
# --------------------------------------------------------------------------------------------
def body(x: float, y: float, theta: float, base: float, height: float) -> np.ndarray:
    p = np.array([x, y])
    fwd = np.array([math.cos(theta), math.sin(theta)])
    side = np.array([math.cos(theta + PI / 2), math.sin(theta + PI / 2)])
    return np.array([p + height * fwd, p + 0.5 * base * side, p - 0.5 * base * side])


def triangles_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Closed triangles share a point iff no edge normal of either separates them (SAT)."""
    for tri in (a, b):
        for k in range(3):
            e = tri[(k + 1) % 3] - tri[k]
            n = np.array([-e[1], e[0]])
            pa, pb = a @ n, b @ n
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


# --------------------------------------------------------------------------------------------
# §4.3 Danger intervals: circular merging and membership
# --------------------------------------------------------------------------------------------
@dataclass
class Arc:
    lo: float  # start angle in [0, 2π)
    width: float  # hi = lo + width
    dist: float  # distance of the closest member


def merge_arcs(items) -> list[Arc]:
    """items: (ψ, half-width, distance). Open intervals (ψ−h, ψ+h) that overlap circularly are
    merged; a merged interval keeps its closest member's distance (§4.3)."""
    arcs = sorted((Arc(wrap(psi - h), 2.0 * h, d) for psi, h, d in items), key=lambda a: a.lo)
    out: list[Arc] = []
    for a in arcs:
        if out and a.lo < out[-1].lo + out[-1].width:
            c = out[-1]
            c.width = max(c.width, a.lo + a.width - c.lo)
            c.dist = min(c.dist, a.dist)
        else:
            out.append(Arc(a.lo, a.width, a.dist))
    # the last arc may run past 2π into the first ones
    while len(out) > 1 and out[-1].lo + out[-1].width > out[0].lo + TAU:
        c, f = out[-1], out.pop(0)
        c.width = max(c.width, f.lo + TAU + f.width - c.lo)
        c.dist = min(c.dist, f.dist)
    for c in out:
        if c.width >= TAU:
            raise NotImplementedError("a merged danger interval covers the whole circle (not modelled here; §4.7)")
    return out


def strictly_inside(arc: Arc, a: float) -> bool:
    r = wrap(a - arc.lo)
    return 0.0 < r < arc.width


def edges_out(arc: Arc, margin: float) -> tuple[float, float]:
    """Both edges of `arc`, pushed outward by `margin`: (lower − margin, upper + margin)."""
    return wrap(arc.lo - margin), wrap(arc.lo + arc.width + margin)


def nearer_edge_gap(arc: Arc, a: float) -> float:
    """(angular distance of a to the lower edge) − (to the upper edge); < 0: lower is nearer.
    `a` may lie outside the arc (the target variant can measure from θ_d)."""
    return abs(wrap_pi(a - arc.lo)) - abs(wrap_pi(a - arc.lo - arc.width))


# |nearer_edge_gap| below this is an exact tie blurred by rounding: §4.7's tie rule cannot see it.
EDGE_TIE = 1e-9


def bisector(arc: Arc) -> float:
    return wrap(arc.lo + 0.5 * arc.width)


# --------------------------------------------------------------------------------------------
# The world (§1.2, §1.5, §1.6) with the laws (§3, §4, §5)
# --------------------------------------------------------------------------------------------
@dataclass
class Agent:
    x: float
    y: float
    th: float
    v: float = 0.0
    om: float = 0.0
    energy: float = 0.0

    @property
    def p(self) -> np.ndarray:
        return np.array([self.x, self.y])


@dataclass
class Memory:
    attraction_dir: np.ndarray | None = None  # §3.1 lost mode
    danger_until: int = -1  # §4.5 emergency: last step of the current danger
    danger_heading: float = 0.0


@dataclass
class RefWorld:
    P: dict
    layout: dict
    t: int = 0
    outcome: str = "running"
    wolves: list = field(default_factory=list)
    targets: list = field(default_factory=list)

    def __post_init__(self):
        P = self.P
        self.wolves = [Agent(x, y, wrap(th)) for x, y, th in self.layout["wolves"]]
        self.targets = [Agent(x, y, wrap(th)) for x, y, th in self.layout["targets"]]
        assert not self.layout.get("obstacles"), "the reference model covers obstacle-free arenas only"
        n, m = len(self.wolves), len(self.targets)
        self.n, self.m = n, m
        c = P["capture"]["count"]
        self.need = c if c is not None else max(1, math.ceil(0.8 * n))
        self.wolf_mem = [Memory() for _ in range(n)]
        self.target_mem = [Memory() for _ in range(m)]
        self.captured = [False] * m
        self.capture_step = [None] * m
        self.seen_at = [None] * m
        self.wolf_target = [0] * n
        self.wolf_senses = [False] * n
        self.interaction = np.zeros((n + m, n + m), dtype=np.uint8)
        self.hits = Counter()  # which branches of the laws ran (coverage of the comparison)
        self.assign_targets()

    # ---- §1.5 target assignment and sensing ---------------------------------------------
    def assign_targets(self):
        """Each wolf hunts its nearest uncaptured target (ties: lowest index)."""
        for i, w in enumerate(self.wolves):
            best = (math.inf, self.wolf_target[i])
            for j, t in enumerate(self.targets):
                d2 = (t.x - w.x) ** 2 + (t.y - w.y) ** 2
                if not self.captured[j] and d2 < best[0]:
                    best = (d2, j)
            self.wolf_target[i] = best[1]

    def sense(self):
        n, m = self.n, self.m
        rw, rt = self.P["agents"]["wolf"]["sense_radius"], self.P["agents"]["target"]["sense_radius"]
        self.interaction[:] = 0
        if any(self.captured[j] for j in self.wolf_target) and not all(self.captured):
            self.assign_targets()
        for i, w in enumerate(self.wolves):
            for j, t in enumerate(self.targets):
                d = float(np.linalg.norm(t.p - w.p))
                self.interaction[i, n + j] = d <= rw
                self.interaction[n + j, i] = d <= rt
            self.wolf_senses[i] = bool(self.interaction[i, n + self.wolf_target[i]])
        for j in range(m):
            if self.seen_at[j] is None and self.interaction[n + j, :n].any():
                self.seen_at[j] = self.t

    # ---- §5.1 fatigue curve --------------------------------------------------------------
    def fatigue(self, t_seen: int, t: int) -> float:
        e = self.P["escape"]
        return e["fatigue_base"] * (2.0 - 1.0 / (1.0 + math.exp(e["fatigue_slope"] * (e["fatigue_delay"] + t_seen - t))))

    # ---- §4.1 items ----------------------------------------------------------------------
    def wall_items(self, a: Agent):
        """Walls within wall_range: ψ perpendicular towards the wall, Δ = acos(d / range)."""
        x0, y0, x1, y1 = self.P["world"]["border"]
        rng = self.P["avoidance"]["wall_range"]
        out = []
        for d, psi in ((a.x - x0, PI), (x1 - a.x, 0.0), (a.y - y0, 1.5 * PI), (y1 - a.y, 0.5 * PI)):
            if d < rng:
                out.append(("wall", psi, math.acos(d / rng), d))
        return out

    def danger_dist(self, kind: str, d: float) -> float:
        """The distance an item brings to the emergency test (§4.5; ∞: it never triggers one).
        `avoidance.wall_emergency: false` (a documented project switch, config.rs) exempts walls,
        which the literal reading of §4.5 does not."""
        if kind == "wall":
            return d if self.P["avoidance"].get("wall_emergency", True) else math.inf
        return d if READINGS["partners_trigger_emergency"] else math.inf

    def emergency_or_none(self, a: Agent, mem: Memory, arcs, v_max: float):
        """§4.5 emergency: a merged interval closer than D_DANGER puts the agent in danger for this
        and the next danger_steps−1 steps; it heads away from that bisector at v_max (or 0 when
        that turn exceeds π/2). Returns (v, θ) while in danger, else None."""
        A = self.P["avoidance"]
        hot = [c for c in arcs if c.dist < A["danger_distance"]]
        if hot:
            c = min(hot, key=lambda c: c.dist)
            self.hits["emergency trigger" + (" (target)" if any(a is t for t in self.targets) else "")] += 1
            self.hits["emergency retrigger while in danger"] += self.t <= mem.danger_until
            mem.danger_until = self.t + A["danger_steps"] - 1
            mem.danger_heading = wrap(bisector(c) + PI)
        if self.t <= mem.danger_until:
            self.hits["emergency heading"] += 1
            th = mem.danger_heading
            return (v_max if abs(wrap_pi(th - a.th)) <= PI / 2 else 0.0), th
        return None

    # ---- §3 + §4: the seed000 wolf -----------------------------------------------------------
    def wolf_command(self, i: int):
        """§3: ν = α ν₁ + β ν₂, then §4 avoidance, then the §2 saturator. Returns
        ((v, ω), the wolves whose information was used (§1.5))."""
        P, S = self.P, self.P["seed000"]
        W = self.wolves
        me = W[i]
        pi_ = me.p
        rw = P["agents"]["wolf"]["sense_radius"]
        tgt = self.targets[self.wolf_target[i]]
        mem = self.wolf_mem[i]
        used = self.used = set()
        # attraction ν₁
        if self.wolf_senses[i]:
            d = float(np.linalg.norm(tgt.p - pi_))
            a1 = (d - S["radius"]) * (tgt.p - pi_) / d ** S["tau1"]
            self.hits["wolf senses"] += 1
        else:
            sensing = [(float(np.linalg.norm(W[j].p - pi_)), j) for j in range(self.n) if j != i and float(np.linalg.norm(tgt.p - W[j].p)) <= rw]
            hunting = [(d, j) for d, j in sensing if self.wolf_target[j] == self.wolf_target[i]]
            self.hits["follow readings differ (M > 1)"] += min(sensing, default=(0, None)) != min(hunting, default=(0, None))
            if READINGS["follow_same_target_only"]:
                sensing = hunting
            if sensing:
                dij, j = min(sensing)
                a1 = S["varsigma"] * (W[j].p - pi_) * dij ** S["tau2"]
                used.add(j)
                self.hits["wolf follows"] += 1
            elif mem.attraction_dir is not None:
                a1 = S["lost_speed"] * mem.attraction_dir
                self.hits["wolf lost"] += 1
            else:
                a1 = np.zeros(2)
                self.hits["wolf lost, zero"] += 1
        na1 = float(np.linalg.norm(a1))
        if na1 > 0:
            mem.attraction_dir = a1 / na1
        # repulsion ν₂ along x' (attraction rotated by −π/2)
        others = sorted((float(np.linalg.norm(W[k].p - pi_)), k) for k in range(self.n) if k != i)
        L = np.zeros(2)
        self.hits["p or q beyond r_w"] += any(d >= rw for d, _ in others[:2])
        for d, k in others[:2]:
            if d < rw:
                L += (pi_ - W[k].p) / d ** S["tau3"]
                used.add(k)
        u = np.array([a1[1], -a1[0]]) / na1 if na1 > 0 else np.array([0.0, -1.0])
        nu = S["alpha"] * a1 + S["beta"] * float(L @ u) * u
        v_d = float(np.linalg.norm(nu))
        # a zero desired velocity has no direction: keep the heading (§3)
        th_d = angle_of(nu) if v_d > 0 or not READINGS["zero_velocity_keeps_heading"] else me.th
        v_d, th_d = self.wolf_avoid(i, v_d, th_d)
        wp = P["agents"]["wolf"]
        return saturate(me.th, th_d, v_d, wp["v_max"], wp["omega_max"], P["world"]["ts"]), used

    def wolf_avoid(self, i: int, v_d: float, th_d: float):
        """§4 for a wolf in an obstacle-free arena: walls and partner wolves."""
        P, A, S = self.P, self.P["avoidance"], self.P["seed000"]
        me, mem = self.wolves[i], self.wolf_mem[i]
        items = self.wall_items(me)
        for k, o in enumerate(self.wolves):
            d = float(np.linalg.norm(o.p - me.p))
            if k != i and d < S["partner_range"]:
                items.append(("partner", angle_of(o.p - me.p), S["partner_half_angle"], d))
                if READINGS["partner_items_used"]:
                    self.used.add(k)
        # early exits
        tp = self.targets[self.wolf_target[i]].p
        ee = A["early_exit_distance"]
        near_me = float(np.linalg.norm(tp - me.p)) <= ee
        n_near = sum(float(np.linalg.norm(tp - w.p)) <= ee for w in self.wolves)
        if near_me and (n_near >= self.need or (len(items) == 1 and items[0][0] == "wall")):
            self.hits["in danger at early exit"] += self.t <= mem.danger_until
            self.hits["wolf early exit"] += 1
            return v_d, th_d
        if not items:
            self.hits["in danger, no item (wolf)"] += self.t <= mem.danger_until
            return v_d, th_d
        kappa = A["wolf_single"] if len(items) == 1 else A["wolf_multi"]
        self.hits.update(f"wolf {kind} item" for kind, *_ in items)
        arcs = merge_arcs([(psi, kappa["wall"] * delta if kind == "wall" else delta, self.danger_dist(kind, d)) for kind, psi, delta, d in items])
        v_max = P["agents"]["wolf"]["v_max"]
        self.hits["partner closer than D_DANGER"] += any(k == "partner" and d < A["danger_distance"] for k, _, _, d in items)
        em = self.emergency_or_none(me, mem, arcs, v_max)
        if em is not None:
            return em
        # close partner: within D_DANGER_W and ahead (within π/2 of θ_d)
        close = [o for k, o in enumerate(self.wolves) if k != i and float(np.linalg.norm(o.p - me.p)) < S["partner_danger"] and abs(wrap_pi(angle_of(o.p - me.p) - th_d)) < PI / 2]
        if close:
            self.hits["wolf close partner"] += 1
            s = sum(((me.p - o.p) / float((me.p - o.p) @ (me.p - o.p)) for o in close), np.zeros(2))
            th = angle_of(s)
            return (v_max if abs(wrap_pi(th - me.th)) <= PI / 2 else 0.0), th
        # normal mode: the nearer edge, pushed outward
        for c in arcs:
            if strictly_inside(c, th_d):
                self.hits["wolf edge"] += 1
                gap, (lower, upper) = nearer_edge_gap(c, th_d), edges_out(c, A["edge_margin"])
                if abs(gap) < EDGE_TIE:
                    # θ_d at the bisector: typically a wolf following its nearest partner j while
                    # j is a partner item and L ∥ ν₁; either edge is admissible.
                    self.hits["wolf edge tie"] += 1
                    return v_d, self.edge_tie(i, v_d, lower, upper)
                return v_d, lower if gap < 0 else upper
        return v_d, th_d

    def edge_tie(self, i: int, v_d: float, lower: float, upper: float) -> float:
        """Which edge a wolf takes at an exact tie; the comparison replaces this with the edge
        the Rust world took (either is admissible). Default: the upper (counter-clockwise) one."""
        return upper

    # ---- §5.1 + §4.8 target variant: the escape target -----------------------------------
    def target_command(self, j: int):
        """§5.1 escape (after the first sighting) or `still` (§5.3), then the §4.8 target variant, then §2."""
        P = self.P
        T = self.targets[j]
        tp_ = P["agents"]["target"]
        ts = P["world"]["ts"]
        if self.captured[j] or P["policies"]["targets"] == "still":
            return (0.0, 0.0)
        assert P["policies"]["targets"] == "escape"
        if self.seen_at[j] is None:
            raise NotImplementedError("wander (random) before the first sighting is not re-derived")
        sensed = [w for w in self.wolves if float(np.linalg.norm(w.p - T.p)) <= tp_["sense_radius"]]
        if sensed:
            s = sum((T.p - w.p for w in sensed), np.zeros(2))
            th_d, v_d = angle_of(s), self.fatigue(self.seen_at[j], self.t)
            self.hits["target flees"] += 1
        else:
            th_d = T.th
            self.hits["target coasts"] += 1
            v_d = T.v * self.fatigue(self.seen_at[j], self.t) / self.fatigue(self.seen_at[j], self.t - 1)
        v_d, th_d = self.target_avoid(j, v_d, th_d)
        return saturate(T.th, th_d, v_d, tp_["v_max"], tp_["omega_max"], ts)

    def target_avoid(self, j: int, v_d: float, th_d: float):
        """§4.8 target variant: walls only, the test uses the current heading θ."""
        P, A = self.P, self.P["avoidance"]
        T, mem = self.targets[j], self.target_mem[j]
        tp_ = P["agents"]["target"]
        items = self.wall_items(T)
        if not items:
            self.hits["in danger, no item (target)"] += self.t <= mem.danger_until
            return v_d, th_d
        kappa = A["target_single"] if len(items) == 1 else A["target_multi"]
        self.hits["target wall item"] += len(items)
        arcs = merge_arcs([(psi, kappa["wall"] * delta, self.danger_dist(kind, d)) for kind, psi, delta, d in items])
        em = self.emergency_or_none(T, mem, arcs, tp_["v_max"])
        if em is not None:
            return em
        for c in arcs:
            if strictly_inside(c, T.th):
                # "nearer edge": nearer to θ (the literal reading of §4.8) or, with the project switch
                # avoidance.target_edge_from_desired, nearer to θ_d (source eq. 13)
                self.hits["target edge"] += 1
                lower, upper = edges_out(c, A["edge_margin"])
                ref = th_d if A.get("target_edge_from_desired", False) else T.th
                return v_d, lower if nearer_edge_gap(c, ref) < 0 else upper
        _, om = saturate(T.th, th_d, v_d, tp_["v_max"], tp_["omega_max"], P["world"]["ts"])
        th_new = wrap(T.th + om * P["world"]["ts"])
        if any(strictly_inside(c, th_new) for c in arcs):
            self.hits["target keeps heading"] += 1
            return v_d, T.th
        return v_d, th_d

    # ---- §1.6 one synchronous step ---------------------------------------------------------
    def step(self) -> str:
        """§1.6: every controller reads the same snapshot; wolves move in index order through
        the feasibility filter, then targets; then outcomes."""
        if self.outcome != "running":
            return self.outcome
        P = self.P
        if self.t % P["world"]["retarget_period"] == 0:
            self.assign_targets()
        self.sense()
        # every controller reads the same snapshot
        wolf_cmds = []
        for i in range(self.n):
            cmd, used = self.wolf_command(i)
            wolf_cmds.append(cmd)
            for k in used:
                self.interaction[i, k] = 1
        target_cmds = [self.target_command(j) for j in range(self.m)]
        self.move_wolves(wolf_cmds)
        self.move_targets(target_cmds)
        self.t += 1
        self.judge()
        return self.outcome

    def move_wolves(self, cmds):
        P = self.P
        ts, b = P["world"]["ts"], P["agents"]["body"]
        side = P["agents"]["wolf"]
        x0, y0, x1, y1 = P["world"]["border"]
        bodies = [body(w.x, w.y, w.th, b["base"], b["height"]) for w in self.wolves]
        for i, (v, om) in enumerate(cmds):
            v = min(max(v, 0.0), side["v_max"])
            om = min(max(om, -side["omega_max"]), side["omega_max"])
            w = self.wolves[i]
            th = wrap(w.th + om * ts)

            def feasible(x, y, th):
                """Strictly inside the border, clear of the other wolves' current bodies."""
                me = body(x, y, th, b["base"], b["height"])
                return x0 < x < x1 and y0 < y < y1 and not any(triangles_overlap(me, bodies[k]) for k in range(self.n) if k != i)

            if P["world"]["feasibility_filter"]:
                # §1.6 step 3: a move feasible as commanded is made as commanded, however small
                # its v; the 0.01 floor applies only to a speed reached by halving.
                commanded = v
                while True:
                    x, y = w.x + v * math.cos(w.th) * ts, w.y + v * math.sin(w.th) * ts
                    inside = x0 < x < x1 and y0 < y < y1
                    if feasible(x, y, th):
                        if 0.0 < v < 0.01 and v == commanded:
                            self.hits["wolf tiny command made"] += 1
                            if self.t == 0:
                                self.hits["wolf tiny first command"] += 1
                        break
                    v *= 0.5
                    self.hits["wolf speed halved" + ("" if inside else " (border)")] += 1
                    if v < 0.01:
                        v = 0.0  # below 0.01 it only turns ...
                        if READINGS["turn_on_spot_checked"] and om != 0.0 and not feasible(w.x, w.y, th) and feasible(w.x, w.y, w.th):
                            th, om = w.th, 0.0  # ... unless that turn itself overlaps a wolf
                            self.hits["wolf turn refused"] += 1
                        break
            x, y = w.x + v * math.cos(w.th) * ts, w.y + v * math.sin(w.th) * ts
            self.wolves[i] = Agent(x, y, th, v, om, w.energy + 0.5 * side["mass"] * v * v)
            bodies[i] = body(x, y, th, b["base"], b["height"])
        self.bodies = bodies

    def move_targets(self, cmds):
        P = self.P
        ts, side = P["world"]["ts"], P["agents"]["target"]
        x0, y0, x1, y1 = P["world"]["border"]
        for j, (v, om) in enumerate(cmds):
            T = self.targets[j]
            v = min(max(v, 0.0), side["v_max"])
            om = min(max(om, -side["omega_max"]), side["omega_max"])
            if self.captured[j]:
                v, om = 0.0, 0.0
            if side["fatigue"] and self.seen_at[j] is not None:  # fatigue as a world rule (§5.2)
                v = min(v, self.fatigue(self.seen_at[j], self.t))
            th = wrap(T.th + om * ts)
            x, y = T.x + v * math.cos(T.th) * ts, T.y + v * math.sin(T.th) * ts
            if P["world"]["feasibility_filter"] and not (x0 < x < x1 and y0 < y < y1):
                v, x, y = 0.0, T.x, T.y  # an infeasible target only turns
                self.hits["target blocked"] += 1
            self.targets[j] = Agent(x, y, th, v, om, T.energy + 0.5 * side["mass"] * v * v)

    def judge(self):
        collided = any(triangles_overlap(self.bodies[i], self.bodies[k]) for i in range(self.n) for k in range(self.n) if k != i)
        cd = self.P["capture"]["distance"]
        for j, T in enumerate(self.targets):
            if not self.captured[j] and sum(float(np.linalg.norm(w.p - T.p)) <= cd for w in self.wolves) >= self.need:
                assert self.P["capture"]["rule"] == "count"
                self.captured[j], self.capture_step[j] = True, self.t
        if collided:
            self.outcome = "collision"
        elif all(self.captured):
            self.outcome = "captured"
        elif self.t >= self.P["world"]["max_steps"]:
            self.outcome = "timeout"

    # ---- logs -----------------------------------------------------------------------------
    def state(self) -> tuple[np.ndarray, np.ndarray]:
        f = lambda a: [a.x, a.y, a.th, a.v, a.om]  # noqa: E731
        return np.array([f(w) for w in self.wolves]), np.array([f(t) for t in self.targets])

    def energy(self) -> np.ndarray:
        return np.array([a.energy for a in self.wolves + self.targets])
