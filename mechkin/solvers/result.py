"""The status every solver result carries (DESIGN.md: results are records with a Status).

One vocabulary for summary.json across fk, ik, track and workspace runs; loop-closure steps of
the model use ``mechkin.model.closure.ClosureStatus`` (converged, not converged, singular).
:func:`stop_point` is where a long solve may be stopped by its caller (:func:`stop_when`).
"""

from __future__ import annotations

import contextlib
import contextvars
import enum
from collections.abc import Callable, Iterator


class Status(enum.Enum):
    """Outcome of one solve (a precision point, a tracking problem, a leg)."""

    OK = "ok"
    NOT_CONVERGED = "not converged"
    SINGULAR = "singular"
    UNREACHABLE = "unreachable"
    AT_LIMIT = "at a limit"
    INFEASIBLE = "infeasible"


class Stopped(Exception):  # noqa: N818 - a stop the caller asked for, not an error
    """A long solve stopped at a safe point (between two DP stages) because the caller's stop
    hook said so (the run's ``--max-time``, :func:`stop_when`); nothing of it is kept."""


_STOP_HOOK: contextvars.ContextVar[Callable[[], bool] | None] = contextvars.ContextVar(
    "mechkin_stop_hook", default=None)


def stop_point() -> None:
    """A safe point of a long solve: raise :class:`Stopped` when the stop hook says so."""
    hook = _STOP_HOOK.get()
    if hook is not None and hook():
        raise Stopped


@contextlib.contextmanager
def stop_when(hook: Callable[[], bool] | None) -> Iterator[None]:
    """Solves in the block call ``hook()`` at their safe points and stop when it is True."""
    token = _STOP_HOOK.set(hook)
    try:
        yield
    finally:
        _STOP_HOOK.reset(token)
