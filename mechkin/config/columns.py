"""Column names that can never collide (issue 28 item 8): a joint's table columns are its name
plus a unit suffix (``q1_rad``, ``slide_m``, ``q1_rad_s``, ...), beside the columns every task
writes itself (``t_s``, ``status``, ``ee_x_m`` ... ``ee_qz``, ``ee_wx_rad_s``,
``position_error_m``, ``closure_residual``, ``beta_rad``, ``contact_x_m``, ...). A prismatic
joint named ``ee_x`` would make ``ee_x_m`` and lose its column to the end effector's. So a
joint name whose columns fall in the tasks' own names is refused when the mechanism is read,
with one line naming the joint and the column it would overwrite.

Imports: the standard library and errors only.
"""

from __future__ import annotations

import re
from typing import Any

from mechkin.errors import ConfigError

#: The suffixes a joint's columns take (positions, rates, accelerations, efforts; the CSV
#: input units too).
JOINT_SUFFIXES = ("rad", "deg", "m", "mm", "rad_s", "m_s", "rad_s2", "m_s2", "nm", "n",
                  "N", "Nm")

#: The tasks' own columns (full names); everything the end effector, the time, the status
#: and the error/closure/contact/leg columns use.
_RESERVED = re.compile(
    r"(t_s|t|status|message|ee_.*|closure_.*|position_error_.*|orientation_error_.*"
    r"|beta_.*|contact_.*|branch|mode|reachable|converged|iterations)\Z")

_WHAT = (("ee_", "the end effector's"), ("t_s", "the time"), ("closure_", "the closure"),
         ("position_error", "the position error"), ("orientation_error", "the orientation "
                                                                         "error"))


def _suffixes(kind: str) -> tuple[str, ...]:
    if kind == "prismatic":
        return ("m", "m_s", "m_s2", "n", "mm")
    if kind == "revolute":
        return ("rad", "rad_s", "rad_s2", "nm", "deg")
    return JOINT_SUFFIXES


def column_clash(joint: str, kind: str = "") -> tuple[str, str] | None:
    """(the joint's column, whose column it is) if one of ``joint``'s columns (of a joint of
    type ``kind``) is a task's own column or in a task's name space, else None."""
    for suffix in _suffixes(kind):
        col = f"{joint}_{suffix}"
        if _RESERVED.match(col):
            owner = next((w for p, w in _WHAT if col.startswith(p)), "a task's")
            return col, owner
    return None


def check_joint_columns(spec: Any, doc: Any) -> None:
    """ConfigError (one line per joint) for joint names whose columns clash with a task's own
    (``doc.where`` locates them)."""
    problems = []
    for i, j in enumerate(getattr(spec, "joints", ()) or ()):
        name = str(getattr(j, "name", ""))
        clash = column_clash(name, str(getattr(j, "type", "")))
        if clash:
            col, owner = clash
            where = doc.where(("joints", i, "name")) if hasattr(doc, "where") else "joints"
            problems.append(f"{where}: joint {name[:40]!r} would write column {col!r}, a name "
                            f"of {owner} columns ({col!r} there); rename the joint")
    if problems:
        raise ConfigError(problems)
