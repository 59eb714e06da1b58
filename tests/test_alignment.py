"""The Rust world against an independent NumPy re-derivation of docs/world-and-laws.md (tests/reference_model.py).

Random obstacle-free layouts (seeded numpy Generator) are run by the Rust core and by the
reference model from the same initial state; the full state (x, y, θ, v, ω of every agent),
the energies and the interaction matrices must agree at every step, and so must the outcome and
the capture step. The escape target always senses a wolf at step 0, so its law is deterministic
(the random wander before a first sighting is never used).

Tolerance: 1e-9 absolute. Over these 200-step episodes the two sides drift apart by at most
~4e-11 (rounding only); a wrong branch shows up as ≥ 1e-3. Each case also names branches of the
reference it must exercise, so a layout that stops covering them fails loudly. Where rounding
admits more than one outcome (an exact tie between the two edges of a danger interval,
docs/world-and-laws.md §4.7), the comparison accepts the one the Rust world took; readings of the
laws' wording that the Rust core does not take are pinned as strict xfails at the end.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
import wolfpack
from reference_model import RefWorld, saturate, wrap_pi
from wolfpack import _core

ATOL = 1e-9
SLOW_SPEED = 1e-3  # m/s: below it an agent's heading is not compared (see _first_mismatch)
MAX_STEPS = 200
FIELDS = ("x", "y", "θ", "v", "ω")
DEVIATION = [0.0]  # largest |rust − reference| over every compared entry (diagnostics)


def _spread(rng, n, lo, hi, min_gap, placed=()):
    """n points uniform in the box lo..hi (per axis), pairwise ≥ min_gap apart."""
    pts = list(placed)
    out = []
    for _ in range(100_000):
        if len(out) == n:
            return out
        p = rng.uniform(lo, hi)
        if all(np.hypot(*(p - q)) >= min_gap for q in pts):
            pts.append(p)
            out.append(p)
    raise AssertionError("layout generator: cannot place the wolves")


def make_layout(rng, n_wolves=5, n_targets=1, box=((-6.0, -6.0), (6.0, 6.0)), near=(0.7, 2.5), target_box=None):
    """Wolves in `box`, pairwise ≥ 0.6 apart, random headings; each target at a distance in
    `near` of a random wolf (so the targets sense a wolf at step 0), inside the arena — or,
    with `target_box`, uniform in that box and within `near` of some wolf."""
    lo, hi = np.array(box[0]), np.array(box[1])
    wolves = _spread(rng, n_wolves, lo, hi, 0.6)
    targets = []
    for _ in range(100_000):
        if len(targets) == n_targets:
            break
        if target_box is None:
            w = wolves[rng.integers(n_wolves)]
            r, a = rng.uniform(*near), rng.uniform(0, 2 * math.pi)
            p = w + r * np.array([math.cos(a), math.sin(a)])
        else:
            p = rng.uniform(*target_box)
        nearest = min(np.hypot(*(p - q)) for q in wolves)
        if np.all(np.abs(p) < 9.9) and near[0] <= nearest <= near[1] and all(np.hypot(*(p - q)) >= 0.6 for q in targets):
            targets.append(p)
    assert len(targets) == n_targets, "layout generator: cannot place the targets"
    pose = lambda p: [float(p[0]), float(p[1]), float(rng.uniform(0, 2 * math.pi))]  # noqa: E731
    return {"wolves": [pose(p) for p in wolves], "targets": [pose(p) for p in targets], "obstacles": []}


def make_close_layout(rng, n_wolves=5, near=(1.4, 2.4)):
    """The published reference's start: one target uniform in the central box, every wolf at a
    distance in `near` of it (random direction, pairwise >= 0.5 apart), random headings. From
    such starts a wolf facing away from the target is commanded a tiny first speed (the
    saturator's 1 − e/π), which the feasibility filter must make as commanded
    (docs/world-and-laws.md §1.6)."""
    for _ in range(10_000):
        target = rng.uniform(-6.0, 6.0, size=2)
        wolves = []
        for _ in range(1000):
            if len(wolves) == n_wolves:
                break
            r, a = rng.uniform(*near), rng.uniform(0, 2 * math.pi)
            p = target + r * np.array([math.cos(a), math.sin(a)])
            if all(np.hypot(*(p - q)) >= 0.5 for q in wolves):
                wolves.append(p)
        if len(wolves) == n_wolves:
            break
    pose = lambda p: [float(p[0]), float(p[1]), float(rng.uniform(0, 2 * math.pi))]  # noqa: E731
    return {"wolves": [pose(p) for p in wolves], "targets": [pose(target)], "obstacles": []}


CLOSE_STARTS = 30  # docs/world-and-laws.md §1.6 step 3 and the published reference's close starts

# (name, layout builder args, params overrides, reference branches the case must exercise)
CASES = []
for s in range(8):
    CASES.append((f"open-{s}", dict(seed=100 + s), {}, ["wolf follows", "wolf edge"] + (["wolf close partner"] if s not in (3, 5) else [])))
# Around a still target a wolf can settle on its ring, where its desired velocity vanishes:
# the direction of a near-zero vector is rounding noise, and the two sides' deviation doubles
# every step or so (still-0: 1e-12 at step 21, 1e-9 at step 34 — both sides equally right).
# Such cases are compared up to the step before the noise reaches 1e-10 (SETTLES).
SETTLES = {"still-0": 30, "two-targets-still-0": 37, "two-targets-still-1": 36}
for s in range(3):
    CASES.append((f"still-{s}", dict(seed=200 + s), {"policies.targets": "still"}, ["wolf follows"]))
for s in range(4):  # wolves and target squeezed against a wall or into a corner
    box = [((5.5, -9.6), (9.6, 9.6)), ((-9.6, -9.6), (-5.5, -5.5)), ((-9.6, 6.5), (9.6, 9.6)), ((6.0, 6.0), (9.6, 9.6))][s]
    CASES.append((f"wall-{s}", dict(seed=300 + s, box=box, near=(0.7, 2.0)), {}, ["wolf wall item", "emergency trigger"]))
for s in range(2):  # the target starts closer to a wall than D_DANGER: its emergency
    tbox = [((9.72, -3.0), (9.9, 3.0)), ((-3.0, -9.9), (3.0, -9.72))][s]
    wbox = [((6.0, -3.0), (9.0, 3.0)), ((-3.0, -9.0), (3.0, -6.0))][s]
    CASES.append((f"target-at-wall-{s}", dict(seed=350 + s, box=wbox, target_box=tbox), {}, ["emergency trigger (target)"]))
for s in range(3):  # wolves hunt their nearest target, re-assigned every retarget_period steps
    CASES.append((f"two-targets-{s}", dict(seed=400 + s, n_targets=2), {}, ["target keeps heading"]))
# a wolf j that senses wolf i's target but hunts the other one (the followed-partner reading)
CASES.append(("two-targets-3", dict(seed=1017, n_targets=2), {}, ["follow readings differ (M > 1)"]))
for s in range(2):  # one target is captured (and freezes) well before the other: re-assignment
    CASES.append((f"two-targets-still-{s}", dict(seed=450 + s, n_targets=2), {"policies.targets": "still", "capture.count": 3}, ["wolf follows"]))
for s in range(3):  # the project's defaults: walls exempt from the emergency
    CASES.append((f"defaults-{s}", dict(seed=800 + s, box=[((5.5, -9.6), (9.6, 9.6)), ((-6.0, -6.0), (6.0, 6.0))][s % 2]), {"avoidance.wall_emergency": False}, ["wolf wall item", "target edge"]))
for s in range(2):  # the target variant's "nearer edge" measured from θ (the literal wording, docs/world-and-laws.md §4.8) instead of θ_d
    CASES.append((f"target-edge-from-heading-{s}", dict(seed=850 + s, box=((5.5, -9.6), (9.6, 9.6))), {"avoidance.target_edge_from_desired": False}, ["target edge", "emergency trigger"]))
CASES.append(("eight-wolves", dict(seed=700, n_wolves=8, box=((-4.0, -4.0), (4.0, 4.0))), {}, ["wolf close partner"]))
for s in range(2):
    CASES.append((f"three-wolves-{s}", dict(seed=500 + s, n_wolves=3), {"capture.count": 3}, ["wolf early exit"]))
# the target senses from farther than the wolves: wolves start lost (zero attraction)
CASES.append(("lost-start", dict(seed=600, near=(3.2, 4.3)), {"agents.target.sense_radius": 4.5}, ["wolf lost, zero", "target coasts"]))
for s, seed in enumerate([610, 611]):  # slow wolves: the target outruns them, they go on lost
    CASES.append((f"lost-later-{s}", dict(seed=seed, n_wolves=3), {"agents.wolf.v_max": 0.8, "agents.target.sense_radius": 6.0}, ["wolf lost", "target coasts"]))
for s in range(CLOSE_STARTS):  # wolves 1.4–2.4 m from the target, as the reference starts them
    CASES.append((f"close-start-{s}", dict(seed=2000 + s, close=True), {}, []))
# close starts (found by scanning seeds) where a wolf facing away from the target is commanded
# a first speed below 0.01 m/s (down to 7.5e-5) that is feasible: made as commanded, not zeroed
for seed in (2038, 2073, 2134, 2439, 2753):
    CASES.append((f"close-start-tiny-{seed}", dict(seed=seed, close=True), {}, ["wolf tiny first command"]))
# θ_d exactly on a partner interval's bisector (an edge tie; the Rust world's rounding picks either edge)
CASES.append(("edge-tie-0", dict(seed=1012, box=((6.0, -3.0), (9.0, 3.0)), target_box=((9.72, -3.0), (9.9, 3.0))), {}, ["wolf edge tie"]))
CASES.append(("edge-tie-1", dict(seed=1000, n_wolves=3), {"agents.wolf.v_max": 0.8, "agents.target.sense_radius": 6.0}, ["wolf edge tie"]))

CASES = [(n, a, {**o, "world.max_steps": SETTLES[n]} if n in SETTLES else o, h) for n, a, o, h in CASES]


# Project switches (config.rs; docs/world-and-laws.md §8) that depart from the laws' literal wording
# are set to the literal reading for the comparison; the project's defaults are compared too, in the
# `defaults-*` cases. A switch the core does not (or no longer) know is left out.
LITERAL_READING_SWITCHES = {"avoidance.wall_emergency": True}
PROJECT_SWITCHES = {"avoidance.wall_emergency", "avoidance.target_edge_from_desired"}


@functools.lru_cache(maxsize=None)
def _known(key):
    section, name = key.split(".")
    return name in wolfpack.load_params()[section]


def _build(args, overrides):
    args = dict(args)
    rng = np.random.default_rng(args.pop("seed"))
    layout = make_close_layout(rng, **{k: v for k, v in args.items() if k != "close"}) if args.get("close") else make_layout(rng, **args)
    n = len(layout["wolves"])
    over = {"world.max_steps": MAX_STEPS, "world.wolves": n, "world.targets": len(layout["targets"])}
    over.update({k: v for k, v in LITERAL_READING_SWITCHES.items() if _known(k)})
    over.update({k: v for k, v in overrides.items() if k not in PROJECT_SWITCHES or _known(k)})
    if "capture.count" not in over:
        over["capture.count"] = None
    return wolfpack.load_params(overrides=over), layout


def _first_mismatch(name, t, got, want, kind):
    """Index and message of the first differing entry of [agents, 5] arrays, or None."""
    diff = np.abs(got - want)
    diff[:, 2] = np.abs([wrap_pi(a - b) for a, b in zip(got[:, 2], want[:, 2])])
    DEVIATION[0] = max(DEVIATION[0], float(diff.max(initial=0.0)))
    # An agent creeping at under SLOW_SPEED sits where its desired velocity nearly vanishes (a
    # wolf on its ring around a still target): the direction of a near-zero vector is decided
    # by rounding, and the two sides' headings wander apart (1e-6 rad after 50 such steps at
    # v ~ 1e-9 m/s). Its θ and ω are not compared there; x, y and v still are, at ATOL, and a
    # heading that differs once the agent moves again shows up in its position.
    tol = np.full(diff.shape, ATOL)
    slow = np.minimum(got[:, 3], want[:, 3]) < SLOW_SPEED
    tol[slow, 2] = np.inf
    tol[slow, 4] = np.inf
    bad = np.argwhere(diff > tol)
    if bad.size == 0:
        return None
    a, f = bad[0]
    return f"{name}: step {t}: {kind} {a} {FIELDS[f]}: rust {got[a, f]!r} vs reference {want[a, f]!r} (|Δ| = {diff[a, f]:.3g}); rust row {got[a].tolist()}, reference row {want[a].tolist()}"


def compare(name, params, layout, seed=0):
    """Runs both; returns (steps compared, list of mismatch messages — empty when aligned)."""
    res = _core.run_episodes(params, seed, 0, 1, layout, True)[0]
    tr = res["trajectory"]
    ref = RefWorld(params, layout)
    n = len(layout["wolves"])
    wp, ts = params["agents"]["wolf"], params["world"]["ts"]

    def rust_edge(i, v_d, lower, upper):
        """At an exact tie (θ_d on the bisector) rounding admits either edge (docs/world-and-laws.md
        §4.7): take the one whose command the Rust world executed (v may since have been halved by
        the filter)."""
        if ref.t + 1 >= tr["wolves"].shape[0]:
            return upper
        v_r, om_r = tr["wolves"][ref.t + 1][i][3:]

        def score(edge):
            v, om = saturate(ref.wolves[i].th, edge, v_d, wp["v_max"], wp["omega_max"], ts)
            return int(abs(om - om_r) <= ATOL) + int(abs(v - v_r) <= ATOL)

        edge = lower if score(lower) > score(upper) else upper
        ref.hits["wolf edge tie: rust took " + ("lower" if edge == lower else "upper")] += 1
        return edge

    ref.edge_tie = rust_edge
    problems = []
    T = tr["wolves"].shape[0] - 1
    for t in range(T + 1):
        if t > 0:
            if ref.outcome != "running":
                problems.append(f"{name}: reference ended ({ref.outcome}) at step {ref.t}, rust ran on to {T}")
                break
            ref.step()
        w, g = ref.state()
        for kind, got, want in (("wolf", tr["wolves"][t], w), ("target", tr["targets"][t], g)):
            msg = _first_mismatch(name, t, got, want, kind)
            if msg:
                problems.append(msg)
        if not np.allclose(tr["energy"][t], ref.energy(), rtol=0, atol=ATOL):
            problems.append(f"{name}: step {t}: energy rust {tr['energy'][t].tolist()} vs reference {ref.energy().tolist()}")
        if t > 0:
            got_i, want_i = tr["interaction"][t - 1], ref.interaction
            if not np.array_equal(got_i, want_i):
                r, c = np.argwhere(got_i != want_i)[0]
                who = lambda k: f"wolf {k}" if k < n else f"target {k - n}"  # noqa: E731
                problems.append(f"{name}: step {t}: interaction [{who(r)}][{who(c)}] rust {got_i[r, c]} vs reference {want_i[r, c]}; rust\n{got_i}\nreference\n{want_i}")
        if problems:
            return t, problems, ref
    if ref.outcome != res["outcome"]:
        problems.append(f"{name}: outcome rust {res['outcome']} vs reference {ref.outcome} (steps {res['steps']} vs {ref.t})")
    ref_capture = max(ref.capture_step) if ref.outcome == "captured" else None
    if res["capture_step"] != ref_capture:
        problems.append(f"{name}: capture step rust {res['capture_step']} vs reference {ref_capture}")
    if res["steps"] != ref.t:
        problems.append(f"{name}: steps rust {res['steps']} vs reference {ref.t}")
    return T, problems, ref


@functools.lru_cache(maxsize=None)
def _compare_case(name):
    """compare() of the named case, once per test session: (steps, problems, branch hits)."""
    _, args, overrides, _ = next(c for c in CASES if c[0] == name)
    steps, problems, ref = compare(name, *_build(args, overrides))
    return steps, tuple(problems), dict(ref.hits)


@pytest.mark.parametrize("name,args,overrides,must_hit", CASES, ids=[c[0] for c in CASES])
def test_rust_world_matches_the_reference_model(name, args, overrides, must_hit):
    steps, problems, hits = _compare_case(name)
    assert not problems, "\n".join(problems[:3])
    assert steps >= 1
    missing = [b for b in must_hit if not hits.get(b)]
    assert not missing, f"{name}: the layout no longer exercises {missing} (hits: {hits})"


def test_close_starts_are_compared_long_enough_and_make_tiny_first_moves():
    """docs/world-and-laws.md §1.6 step 3 on the reference's close starts: at least 30 layouts, each
    compared over at least 60 moves, and among them first moves commanded below 0.01 m/s that are
    feasible and must be made as commanded (a filter that stops them drifts from the first step)."""
    names = [c[0] for c in CASES if c[0].startswith("close-start-")]
    assert len(names) >= 30 + 1
    runs = {n: _compare_case(n) for n in names}
    short = {n: r[0] for n, r in runs.items() if r[0] < 60}
    assert not short, f"close starts compared over fewer than 60 moves: {short}"
    bad = [p for r in runs.values() for p in r[1]]
    assert not bad, "\n".join(bad[:3])
    tiny_first = sum(r[2].get("wolf tiny first command", 0) for r in runs.values())
    assert tiny_first >= 1, "no close start commands a tiny, feasible first move"


def test_two_targets_are_captured_at_different_steps():
    """The re-assignment after a capture is compared only if a case captures one target first:
    a layout whose wolves never settle on a ring, so the whole episode is compared (captures at
    steps 25 and 65)."""
    params, layout = _build(dict(seed=454, n_targets=2), {"policies.targets": "still", "capture.count": 3})
    _, problems, ref = compare("two-targets-still-454", params, layout)
    assert not problems and ref.outcome == "captured" and len(set(ref.capture_step)) == 2


# Readings of the laws' wording that the Rust core does not take (see reference_model's
# docstring). Each flipped reading is pinned here: it must keep failing on a case that exercises it.
AMBIGUOUS = [
    (
        "partners_trigger_emergency",
        True,
        "eight-wolves",
        "docs/world-and-laws.md §4.3, §4.5: read literally, a merged interval keeps the distance of its closest member, "
        "partners included, and only static circles are exempt from the emergency, so a partner wolf "
        "closer than D_DANGER (centre distance) would trigger it; the Rust core lets only walls/obstacles "
        "trigger it and leaves close partners to the close-partner rule",
    ),
    (
        "follow_same_target_only",
        False,
        "two-targets-3",
        "docs/world-and-laws.md §3.1 ambiguity (M > 1): j is the nearest other wolf that senses the target — literally any wolf within r_w of wolf i's target; the Rust core follows only wolves that also hunt it",
    ),
    (
        "partner_items_used",
        False,
        "open-0",
        "docs/world-and-laws.md §1.5: the information a wolf used includes partner wolves that are §4.1 avoidance items, which the Rust core marks; the flipped reading marks only the followed partner and the repulsion neighbours p, q",
    ),
]


@pytest.mark.parametrize("key,value,case", [pytest.param(key, value, case, id=key, marks=pytest.mark.xfail(strict=True, reason=reason)) for key, value, case, reason in AMBIGUOUS])
def test_flipped_reading_diverges(monkeypatch, key, value, case):
    import reference_model

    monkeypatch.setitem(reference_model.READINGS, key, value)
    name, args, overrides, _ = next(c for c in CASES if c[0] == case)
    _, problems, _ = compare(name, *_build(args, overrides))
    assert not problems, "\n".join(problems[:1])
