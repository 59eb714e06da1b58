"""The curves of an imitation run (``training/imitate.py``'s ``imitation.json``)."""

from __future__ import annotations

from pathlib import Path


def plot(out: Path, history: list[dict], side: str, path: Path | None = None) -> None:
    """The held-out capture rate and the cloning loss per DAgger round, into ``path`` (default
    ``out/imitation.png``); the title names the run folder ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.6))
    rounds = [h["round"] for h in history]
    key = "capture_rate"
    a.plot(rounds, [100 * h["held_out"][key] for h in history], marker="o")
    a.fill_between(rounds, [100 * h["held_out"]["capture_rate_ci95"][0] for h in history], [100 * h["held_out"]["capture_rate_ci95"][1] for h in history], alpha=0.2)
    a.set_xlabel("DAgger round")
    a.set_ylabel("held-out capture rate (%)")
    a.set_ylim(0, 100)
    a.grid(alpha=0.3)
    b.semilogy(rounds, [h["loss"] for h in history], marker="o")
    b.set_xlabel("DAgger round")
    b.set_ylabel("behaviour-cloning loss (MSE)")
    b.grid(alpha=0.3)
    fig.suptitle(f"{out.name}: imitation ({side})")
    fig.tight_layout()
    fig.savefig(path or out / "imitation.png", dpi=120)
    plt.close(fig)
