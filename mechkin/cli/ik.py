"""``mechkin ik SCENARIO.yaml``: independent joints that bring {E} onto each precision point
(or, with a ``biped:`` section, hwang2023's closed-form leg classes)."""

from __future__ import annotations

from typing import Any

from mechkin.cli.common import run_command


def _line(s: dict[str, Any]) -> str:
    if "counts" not in s:  # a biped run
        return f"{s['scenario']}: {s.get('status', '?')}; wrote {s['out_dir']}"
    c = s["counts"]
    return (f"{s['scenario']}: {s['status']} ({c.get('ok', 0)}/{s['n_targets']} targets ok, "
            f"max errors {s['max_position_error']:.3g} m, {s['max_orientation_error']:.3g} "
            f"rad); wrote {s['out_dir']}")


ik_cli = run_command(
    "ik",
    "Inverse kinematics: independent joints for every precision point (kim1995 §5.2).",
    _line,
)
