"""``mechkin fk SCENARIO.yaml``: motion of every joint and frame from the independent joints."""

from __future__ import annotations

from mechkin.cli.common import run_command
from mechkin.cli.lines import fk_line as _line

fk_cli = run_command(
    "fk",
    "Forward kinematics: every joint and frame from the motion of the independent joints.",
    _line,
)
