"""A budget for work: estimate a job's memory before allocating, refuse beyond the budget.

Every task estimates the peak memory of its job from the scenario (grid sizes x joints,
samples, targets, DP states x transitions) *before* it allocates or starts, and calls
:func:`check`. The budget is ``--max-memory`` (CLI), ``MECHKIN_MAX_MEMORY`` (environment,
e.g. ``8G``, ``512M``) or, by default, half of this machine's memory (or 80 % of what is
available now, whichever is smaller). A refused job is bad input (exit 2) with one line naming
the scenario key, the estimate and how to raise the budget.

Imports: the standard library and errors only.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
from collections.abc import Iterator
from typing import Any

from mechkin.errors import ConfigError, MechkinError

_LIMIT: contextvars.ContextVar[int | None] = contextvars.ContextVar("mechkin_budget",
                                                                    default=None)
#: The longest simulated time a table or CSV may reach (about 31 years).
MAX_TIME_S = 1e9
#: The largest size a budget may name (8 EiB: beyond it int(size) is meaningless).
MAX_SIZE = 2**63 - 1
_UNITS = {"": 1, "B": 1, "K": 1024, "M": 1024**2, "G": 1024**3, "T": 1024**4}


def parse_size(text: str) -> int:
    """``"8G"``, ``"512M"``, ``"1.5GiB"``, ``"1000000"`` -> bytes (ValueError if not a size)."""
    t = text.strip().upper().removesuffix("IB").removesuffix("B")
    unit = t[-1:] if t[-1:] in _UNITS and not t[-1:].isdigit() else ""
    num = float(t[: len(t) - len(unit)]) if unit else float(t)
    size = num * _UNITS[unit]
    if not 0 < size <= MAX_SIZE:  # NaN, inf, 1e308T
        raise ValueError(f"expected a positive size of at most 8E, got {text[:40]!r}")
    return int(size)


def _meminfo() -> dict[str, int]:
    out = {}
    with contextlib.suppress(OSError), open("/proc/meminfo") as f:
        for line in f:
            k, _, v = line.partition(":")
            parts = v.split()
            if parts and parts[0].isdigit():
                out[k] = int(parts[0]) * 1024
    return out


def default_limit() -> int:
    """Half the machine's memory, or 80 % of what is available now if that is less."""
    mi = _meminfo()
    total = mi.get("MemTotal")
    if total is None:
        try:
            total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
        except (ValueError, OSError, AttributeError):
            total = 8 * 1024**3
    limit = total // 2
    if "MemAvailable" in mi:
        limit = min(limit, int(mi["MemAvailable"] * 0.8))
    return max(limit, 256 * 1024**2)


def limit() -> int:
    """The budget in force [bytes]."""
    v = _LIMIT.get()
    if v is not None:
        return v
    env = os.environ.get("MECHKIN_MAX_MEMORY")
    if env:
        try:
            return parse_size(env)
        except ValueError:
            raise ConfigError(f"MECHKIN_MAX_MEMORY: expected a size like 8G or 512M, got "
                              f"{env[:40]!r}") from None
    return default_limit()


@contextlib.contextmanager
def memory_budget(max_bytes: int | None) -> Iterator[None]:
    """Run the block with ``max_bytes`` as the budget (None: the default)."""
    token = _LIMIT.set(max_bytes)
    try:
        yield
    finally:
        _LIMIT.reset(token)


def human(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(n) < 1024 or unit == "TiB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024
    return f"{n:.3g} TiB"  # pragma: no cover


def check(where: str, estimate_bytes: float, what: str) -> None:
    """Refuse a job whose estimated peak memory exceeds the budget.

    Parameters
    ----------
    where : str
        ``file:line: key.path`` of the scenario entry that sets the size.
    estimate_bytes : float
        Estimated peak memory of the job.
    what : str
        The job in words (``"201 fk steps of 6 joints"``).
    """
    lim = limit()
    if estimate_bytes > lim:
        raise ConfigError(f"{where}: {what} needs about {human(estimate_bytes)}, more than the "
                          f"memory budget of {human(lim)} (raise it with --max-memory SIZE or "
                          "MECHKIN_MAX_MEMORY, or make the job smaller)")


#: Memory of one local worker process (interpreter, numpy, mechkin, its share of a job).
WORKER_BYTES = 200 * 1024**2


def check_workers(where: str, workers: int) -> None:
    """Refuse more local worker processes than the machine can run: more than 4 per CPU, or
    more than the memory budget holds at :data:`WORKER_BYTES` each."""
    cpus = os.cpu_count() or 1
    if workers > 4 * cpus:
        raise ConfigError(f"{where}: {workers} worker processes on a machine with {cpus} CPUs "
                          f"(at most {4 * cpus}; use --scheduler for a cluster)")
    check(where, workers * WORKER_BYTES, f"{workers} worker processes")


# ---- time: an estimate before a long job, and --max-time ---------------------------------------

#: A job estimated beyond this many seconds prints its estimate on stderr before it starts.
NOTICE_S = 30.0
_TIME: contextvars.ContextVar[float | None] = contextvars.ContextVar("mechkin_time",
                                                                     default=None)
_ESTIMATES: contextvars.ContextVar[list[dict[str, Any]] | None] = contextvars.ContextVar(
    "mechkin_estimates", default=None)
_START: contextvars.ContextVar[float | None] = contextvars.ContextVar("mechkin_start",
                                                                      default=None)
_STOP: contextvars.ContextVar[dict[str, Any] | None] = contextvars.ContextVar("mechkin_stop",
                                                                              default=None)
_DURATION_UNITS = {"": 1.0, "s": 1.0, "m": 60.0, "min": 60.0, "h": 3600.0, "d": 86400.0}


def _clock() -> float:
    """The run's clock (``time.monotonic``; tests replace it to make a run overrun)."""
    import time

    return time.monotonic()


def parse_duration(text: str) -> float:
    """``"90"``, ``"90s"``, ``"5m"``, ``"1.5h"``, ``"2d"`` -> seconds (ValueError if not a
    positive finite duration of at most a year)."""
    t = text.strip().lower()
    unit = next((u for u in ("min", "s", "m", "h", "d") if t.endswith(u)), "")
    num = float(t[: len(t) - len(unit)] if unit else t)
    sec = num * _DURATION_UNITS[unit]
    if not 0 < sec <= 366 * 86400.0:
        raise ValueError(f"expected a duration like 90s, 5m or 2h, got {text[:40]!r}")
    return sec


def time_limit() -> float | None:
    """The run's ``--max-time`` in seconds, else ``MECHKIN_MAX_TIME``, else None (no limit)."""
    v = _TIME.get()
    if v is not None:
        return v
    env = os.environ.get("MECHKIN_MAX_TIME")
    if env:
        try:
            return parse_duration(env)
        except ValueError:
            raise ConfigError(f"MECHKIN_MAX_TIME: expected a duration like 90s, 5m or 2h, got "
                              f"{env[:40]!r}") from None
    return None


@contextlib.contextmanager
def time_budget(max_seconds: float | None) -> Iterator[list[dict[str, Any]]]:
    """Set the run's time limit (None: the environment's) and collect the run's estimates
    (``{"where", "what", "seconds"}``) in the yielded list."""
    found: list[dict[str, Any]] = []
    t1 = _TIME.set(max_seconds)
    t2 = _ESTIMATES.set(found)
    t3 = _START.set(_clock())
    t4 = _STOP.set({})
    try:
        yield found
    finally:
        _STOP.reset(t4)
        _START.reset(t3)
        _ESTIMATES.reset(t2)
        _TIME.reset(t1)


class TimeLimitExceeded(MechkinError):
    """The run went past ``--max-time`` on a path that keeps no partial result (a motion or a
    target sequence split over workers): stopped between two jobs, nothing written (exit 1)."""

    exit_code = 1


def _limit_now() -> float | None:
    """:func:`time_limit` (``--max-time``, else ``MECHKIN_MAX_TIME``), None if unusable (a bad
    ``MECHKIN_MAX_TIME`` is refused, with its line, where the run's estimates are checked)."""
    try:
        return time_limit()
    except ConfigError:
        return None


def overrun() -> bool:
    """True once the run has used its ``--max-time``: the task stops at its next safe point
    (between samples, targets, sweep chunks, DP stages), keeps the finished rows and says how
    many with :func:`note_done`; :func:`stop_info` then holds the stop for the summary."""
    lim, start, info = _limit_now(), _START.get(), _STOP.get()
    if lim is None or start is None or info is None:
        return False
    if info:
        return True
    used = _clock() - start
    if used <= lim:
        return False
    info.update({"reason": "max-time", "limit_s": lim, "after_s": round(used, 3)})
    return True


def note_done(done: int, total: int, unit: str) -> None:
    """After a stop: ``done`` of ``total`` rows (``unit``: steps, targets, poses, samples,
    grids) were finished and are kept."""
    info = _STOP.get()
    if info:
        info.update({"done": int(done), "total": int(total), "unit": unit})


def stop_info() -> dict[str, Any] | None:
    """The run's stop (``reason``, ``limit_s``, ``after_s`` and the rows done), or None."""
    info = _STOP.get()
    return dict(info) if info else None


def check_deadline() -> None:
    """Raise :class:`TimeLimitExceeded` once the run has used its ``--max-time`` (called
    between the jobs of a split run that keeps no partial result)."""
    lim, start = _limit_now(), _START.get()
    if lim is None or start is None:
        return
    used = _clock() - start
    if used > lim:
        raise TimeLimitExceeded(f"--max-time: stopped after {human_time(used)} (limit "
                                f"{human_time(lim)}) between two jobs; no output was changed")


def human_time(sec: float) -> str:
    if sec < 10:
        return f"{sec:.2g} s"
    if sec < 120:
        return f"{sec:.0f} s"
    if sec < 7200:
        return f"{sec / 60:.0f} min"
    if sec < 2 * 86400:
        return f"{sec / 3600:.1f} h"
    return f"{sec / 86400:.3g} days"


def estimate_time(where: str, seconds: float, what: str) -> None:
    """Before a job: refuse it when its estimated run time exceeds ``--max-time`` (one line,
    exit 2); keep it for the summary (``estimated_time_s``, the sum of the run's estimates);
    when it exceeds :data:`NOTICE_S`, print it on stderr. The estimate
    (:mod:`mechkin.tasks.estimates`) is within a factor of a few of this machine's time, so
    the refusal has a factor of 2 of slack."""
    import sys

    seconds = float(seconds) if seconds == seconds else 0.0
    lim = time_limit()
    if lim is not None and seconds > 2.0 * lim:
        raise ConfigError(f"{where}: {what} is estimated to take about {human_time(seconds)}, "
                          f"more than --max-time {human_time(lim)} (raise it, or make the job "
                          "smaller)")
    found = _ESTIMATES.get()
    if found is not None:
        found.append({"where": where, "what": what, "seconds": seconds})
    if seconds > NOTICE_S:
        sys.stderr.write(f"mechkin: {what}: estimated about {human_time(seconds)} "
                         f"({where.split(': ', 1)[0]}); --max-time bounds a run\n")
        sys.stderr.flush()


#: ``summary["status"]`` of a run stopped by ``--max-time`` (exit 1, the finished rows written).
STOPPED = "stopped: max-time"


def mark_stopped(rep: Any, path: Any) -> Any:
    """A task's report after :func:`overrun` stopped it: status :data:`STOPPED`, the stop under
    ``summary["stopped"]`` (``reason``, ``limit_s``, ``after_s``, ``done``, ``total``,
    ``unit``), no ``expect:`` results (a part of the job proves nothing), exit 1 and one line
    saying what was kept. The rows kept are complete (the task truncated its tables). A task
    that noted no partial result (:func:`note_done`) finished every row: its report stands."""
    info = stop_info()
    if info is None or "done" not in info:  # not stopped, or every row finished anyway
        return rep
    rep.summary["status"] = STOPPED
    rep.summary["stopped"] = info
    rep.summary.pop("expect", None)
    rep.checks = []
    rep.solver_ok = False
    kept = f"{info['done']} of {info['total']} {info['unit']} finished and written"
    rep.messages = [f"{path}: --max-time {human_time(info['limit_s'])}: stopped after "
                    f"{human_time(info['after_s'])} at a safe point; {kept} (status "
                    f"'{STOPPED}')"]
    return rep
