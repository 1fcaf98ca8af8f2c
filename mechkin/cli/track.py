"""``mechkin track SCENARIO.yaml``: conveyor tracking by DP in the phase plane (park §2-§5).

The task is :mod:`mechkin.tasks.track`; the files (``summary.json``, ``track.csv``, plots like
park Figs. 4-8, ``track.mcap``) are written by :mod:`mechkin.io.track_out`.
"""

from __future__ import annotations

from mechkin.cli.common import run_command
from mechkin.cli.lines import track_line as _line

track_cli = run_command(
    "track",
    "Conveyor tracking (or minimum time) along a straight hand line by DP (park §2-§5).",
    _line,
)
