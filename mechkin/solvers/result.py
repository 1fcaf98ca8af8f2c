"""The status every solver result carries (DESIGN.md: results are records with a Status).

One vocabulary for summary.json across fk, ik, track and workspace runs; loop-closure steps of
the model use ``mechkin.model.closure.ClosureStatus`` (converged, not converged, singular).
"""

from __future__ import annotations

import enum


class Status(enum.Enum):
    """Outcome of one solve (a precision point, a tracking problem, a leg)."""

    OK = "ok"
    NOT_CONVERGED = "not converged"
    SINGULAR = "singular"
    UNREACHABLE = "unreachable"
    AT_LIMIT = "at a limit"
    INFEASIBLE = "infeasible"
