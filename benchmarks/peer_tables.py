"""The report of ``peers.py``: rates and ratios formatted, the ratios at each batch size
(of the medians, and round by round), and the tables printed without ``--json``."""

from __future__ import annotations

import os
from pathlib import Path

from machine import caches_text
from peer_scenarios import COUNTS

# Peer workers' pythons are shown relative to the repository.
ROOT = Path(__file__).resolve().parents[1]


def fmt_rate(x: float | None) -> str:
    return "-" if x is None else f"{x:,.0f}"


def fmt_ratio(x: float | None) -> str:
    if x is None:
        return "-"
    return f"{x:,.0f}x" if x >= 10 else f"{x:.2f}x"


def ratio(a: float | None, b: float | None) -> float | None:
    return a / b if a and b else None


def rate(entry: dict | None) -> float | None:
    return None if not entry or "skipped" in entry else entry.get("env_steps_per_second")


def round_rates(entry: dict | None) -> list[float]:
    """A contender's rate in each round, in round order (empty when it was skipped)."""
    return [] if not entry or "skipped" in entry else list(entry.get("rates") or [])


def paired_ratios(ours: dict | None, peers: list[dict | None]) -> list[float]:
    """Round by round, our rate over the best of the peers' rates in that same round: the
    contenders of a round run minutes apart at most, so a machine that speeds up or slows down
    between rounds (a VM's neighbours) moves both sides of each ratio alike. Rounds where we or
    every peer have no rate are left out."""
    mine = round_rates(ours)
    theirs = [round_rates(p) for p in peers]
    out = []
    for k, a in enumerate(mine):
        best = max((r[k] for r in theirs if k < len(r)), default=None)
        if a and best:
            out.append(a / best)
    return out


def size_ratios(row: dict, threads: list[int]) -> dict:
    tmax = max(threads)
    jax_best = max((r for r in (rate(row.get("jaxmarl_loop")), rate(row.get("jaxmarl_scan"))) if r), default=None)
    ours = row.get(f"batch_env_{tmax}t")
    out = {f"BatchEnv({tmax}t) / JaxMARL best": ratio(rate(ours), jax_best)}
    by_round = paired_ratios(ours, [row.get("jaxmarl_loop"), row.get("jaxmarl_scan")])
    out[f"BatchEnv({tmax}t) / JaxMARL best, each round"] = [round(x, 3) for x in by_round]
    out[f"BatchEnv({tmax}t) / JaxMARL best, lowest round"] = min(by_round, default=None)
    for t in threads:
        out[f"make_vec_env({t}t) / BatchEnv({t}t)"] = ratio(rate(row.get(f"vec_env_{t}t")), rate(row.get(f"batch_env_{t}t")))
    out[f"BatchEnv({tmax}t) / VMAS"] = ratio(rate(row.get(f"batch_env_{tmax}t")), rate(row.get("vmas")))
    return out


def tables(report: dict) -> str:
    m = report["machine"]
    threads = report["threads"]
    tmax = max(threads)
    out = [
        f"date: {report['date']}; command: {report['command']}",
        *([f"note: {report['note']}"] if report.get("note") else []),
        f"machine: {m['cpu']}, {m['cores']} cores{caches_text(m.get('caches'))}, {m['os']}, Python {m['python']}",
        "packages: " + ", ".join(f"{k} {v}" for k, v in m["packages"].items() if v),
    ]
    src = m.get("wolfpack_source") or {}
    if src:
        where = f"commit {src['commit']}{' + uncommitted changes' if src.get('dirty') else ''}" if src.get("commit") else "not in a git checkout"
        out.append(f"wolfpack from {src['package']} ({where}; extension built {src.get('extension_built', '?')})")
    pv = report.get("peers_venv") or {}
    by_exe: dict[str, tuple[list[str], dict]] = {}
    for peer, v in pv.get("versions", {}).items():
        by_exe.setdefault(v.get("executable", ""), ([], v))[0].append(peer)
    for exe, (peers, v) in by_exe.items():
        rel = os.path.relpath(exe, ROOT) if exe.startswith(str(ROOT)) else exe
        out.append(f"peer workers ({', '.join(peers)}) in {rel}: " + ", ".join(f"{k} {x}" for k, x in v.items() if x and k != "executable"))
    out += [
        f"scenario: {COUNTS['wolves']} pursuers, {COUNTS['targets']} evader, {COUNTS['obstacles']} obstacles; "
        f"{report['repeats']} interleaved rounds, median; ~{report['target_seconds']} s per measurement",
        f"load average (1, 5, 15 min) at the start: {m['load_average']}, at the end: {m.get('load_average_after')}",
        "per round, load before -> after (it counts this benchmark, 1-2 on 2 cores), and the cores other processes used: "
        + "; ".join(f"{r['round']}: {r['load_before']} -> {r['load_after']}, others {r['others_cores']} ({r['seconds']:.0f} s)" for r in report["rounds"]),
        "",
        "env-steps/s by batch size E (an env-step = one world advanced one step); ratios of the medians,"
        " and 'lowest round' the smallest of the ratios taken round by round (both sides of each from the same round):",
        "",
    ]
    cols = [f"batch_env_{t}t" for t in threads] + [f"vec_env_{t}t" for t in threads] + ["vmas", "jaxmarl_loop", "jaxmarl_scan"]
    heads = [f"BatchEnv {t}t" for t in threads] + [f"make_vec_env {t}t" for t in threads] + ["VMAS cpu", "JaxMARL jit+vmap loop", "JaxMARL lax.scan"]
    rkeys = [f"BatchEnv({tmax}t) / JaxMARL best", f"BatchEnv({tmax}t) / JaxMARL best, lowest round"] + [f"make_vec_env({t}t) / BatchEnv({t}t)" for t in threads]
    rheads = [f"BatchEnv {tmax}t / JaxMARL best", "lowest round"] + [f"vec / Batch {t}t" for t in threads]
    rows = [["E"] + heads + rheads]
    for E, row in report["batch"].items():
        rr = report["ratios_by_size"][E]
        rows.append([E] + [fmt_rate(rate(row.get(c))) for c in cols] + [fmt_ratio(rr.get(k)) for k in rkeys])
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    line = lambda r: "| " + " | ".join(x.rjust(w) for x, w in zip(r, widths)) + " |"  # noqa: E731
    out.append(line(rows[0]))
    out.append("|" + "|".join("-" * (w + 1) + ":" for w in widths) + "|")
    out += [line(r) for r in rows[1:]]

    # Once-per-run rows.
    out += ["", "no batch size (E = 1 or whole episodes):", ""]
    once = []
    wp = report["wolfpack"]
    for key in ("threads_1", "threads_all"):
        r = wp.get(key, {})
        if "skipped" in r or not r:
            once.append((f"wolfpack scripted run_episodes ({key})", "-", r.get("skipped", "")))
        else:
            once.append((f"wolfpack scripted run_episodes, {r['threads']}t", fmt_rate(r["env_steps_per_second"]), f"{r['episodes']} episodes, {r['total_steps']} steps"))
    r = report["mpe2"]
    if "skipped" in r:
        once.append(("mpe2 simple_tag (E = 1 only: one world)", "-", "skipped: " + r["skipped"]))
    else:
        once.append(("mpe2 simple_tag (E = 1 only: one world)", fmt_rate(r["env_steps_per_second"]), f"{r['steps']} env.step calls"))
        once.append(("mpe2 world.step() only", fmt_rate(r.get("physics_only_env_steps_per_second")), "physics alone: no obs, rewards, wrappers"))
    ref = report["reference"]
    once.append(
        (
            "Python reference impl. (quoted)",
            f"~{ref['env_steps_per_second']:.0f}",
            f"first snapshot {ref['first_snapshot_range'][0]:.0f}-{ref['first_snapshot_range'][1]:.0f}, latest {ref['latest_snapshot_range'][0]:.0f}-{ref['latest_snapshot_range'][1]:.0f}",
        )
    )
    w0 = max(len(a) for a, _, _ in once)
    w1 = max(len("env-steps/s"), *(len(b) for _, b, _ in once))
    out.append(f"| {'simulator':<{w0}} | {'env-steps/s':>{w1}} | notes |")
    out.append(f"|{'-' * (w0 + 2)}|{'-' * (w1 + 1)}:|---|")
    out += [f"| {a:<{w0}} | {b:>{w1}} | {c} |" for a, b, c in once]
    out.append("")
    for k, v in report["ratios"].items():
        out.append(f"{k}: {fmt_ratio(v)}")

    # Sizes and compile times.
    out += ["", "steps per measurement (env-steps = E x steps) and JaxMARL compile seconds:"]
    for E, row in report["batch"].items():
        parts = []
        for c in cols:
            r = row.get(c)
            if not r or "skipped" in r:
                continue
            s = f"{c} {r.get('steps_per_run')}"
            if c.startswith("jaxmarl") and r.get("compile_s") is not None:
                s += f" (compile {r['compile_s']:.1f} s)"
            parts.append(s)
        out.append(f"  E={E}: " + ", ".join(parts))
    skipped = sorted({f"{c}: {r['skipped']}" for row in report["batch"].values() for c, r in row.items() if "skipped" in r})
    if skipped:
        out += ["skipped:"] + [f"  {s}" for s in skipped]
    return "\n".join(out)
