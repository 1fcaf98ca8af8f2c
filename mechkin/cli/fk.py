"""``mechkin fk SCENARIO.yaml``: motion of every joint and frame from the independent joints."""

from __future__ import annotations

from typing import Any

from mechkin.cli.common import run_command


def _line(s: dict[str, Any]) -> str:
    return (f"{s['scenario']}: {s['status']} ({s['n_steps']} steps, max ||phi|| "
            f"{s['closure']['max_residual']:.3g}); wrote {s['out_dir']}")


fk_cli = run_command(
    "fk",
    "Forward kinematics: every joint and frame from the motion of the independent joints.",
    _line,
)
