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

from mechkin.errors import ConfigError

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
