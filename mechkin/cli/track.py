"""``mechkin track SCENARIO.yaml``: conveyor tracking by DP in the phase plane (park §2-§5).

The task is :mod:`mechkin.tasks.track`; the files (``summary.json``, ``track.csv``, plots like
park Figs. 4-8, ``track.mcap``) are written by :mod:`mechkin.io.track_out`.
"""

from __future__ import annotations

from typing import Any

from mechkin.cli.common import run_command


def _line(s: dict[str, Any]) -> str:
    if s["status"] != "ok":
        return f"{s['scenario']}: {s['status']}; wrote {s['out_dir']}"
    head = (f"t_a = {s['t_a_s']:.4g} s" if s["t_a_s"] is not None
            else f"duration {s['duration_s']:.4g} s")
    peaks = ", ".join(f"{v:.4g}" for v in s["peak_torque"])
    act, by = s.get("actuated_joints"), s.get("peak_torque_by_joint")
    if act and by and len(act) < len(by):  # a closed chain: the motors (passive joints: 0)
        peaks = ", ".join(f"{n} {by[n]:.4g}" for n in act)
    g = s["grid"]
    how = (f"TOPP-RA on {g['N1'] + 1} points" if s.get("planner") == "topp"
           else f"{g['N1']}x{g['N2']} grid")
    return (f"{s['scenario']}: ok, {head}, peak torques [{peaks}], limits "
            f"{'ok' if s['limits_ok'] else 'EXCEEDED'}, {how} "
            f"in {s['solve_time_s']:.3g} s; wrote {s['out_dir']}")


track_cli = run_command(
    "track",
    "Conveyor tracking (or minimum time) along a straight hand line by DP (park §2-§5).",
    _line,
)
