"""``mechkin ik SCENARIO.yaml``: independent joints that bring {E} onto each precision point
(or, with a ``biped:`` section, hwang2023's closed-form leg classes)."""

from __future__ import annotations

from mechkin.cli.common import run_command
from mechkin.cli.lines import ik_line as _line

ik_cli = run_command(
    "ik",
    "Inverse kinematics: independent joints for every precision point (kim1995 §5.2).",
    _line,
)
