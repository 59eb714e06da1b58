"""The browser viewer: episodes written as one self-contained HTML page (``wolfpack view``,
``wolfpack hunt --out DIR``'s ``index.html``, ``wolfpack replay --html``).

- :mod:`~wolfpack.viewer.encode`: episodes packed compactly (positions to 1 mm, angles to
  0.001 rad; the precision table is there);
- :mod:`~wolfpack.viewer.page`: the page (``page.html``, ``page.js`` and ``page.css``, inlined);
- :mod:`~wolfpack.viewer.sources`: the runs and ``trajectory.npz`` files it reads, checked;
- :mod:`~wolfpack.viewer.play`: policies played on the same episodes (``--compare``);
- :mod:`~wolfpack.cli.view`: the ``wolfpack view`` command.

The page's script interface is ``window.wolfpack`` (read-only): ``state(step, pane=0)`` →
``{step, wolves: [[x, y, heading], …], targets: [[x, y, heading], …], wolf_modes: [name, …],
target_modes: [name, …]}`` in metres and radians (each agent's law mode at that step, null
where the episode records none), and ``ready``, ``step()``, ``lastStep()``, ``playing()``, ``item()``, ``items()``,
``episodes()``, ``panes()``, ``toScreen(x, y, pane=0)``, ``colours()``, ``selected()``.
"""

from __future__ import annotations

from wolfpack.viewer.encode import decode_episode, encode_episode
from wolfpack.viewer.page import page_data, render_page, write_page

__all__ = ["decode_episode", "encode_episode", "page_data", "render_page", "write_page"]
