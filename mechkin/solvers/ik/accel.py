"""Whether the optional compiled IK kernels are used: availability, cache folder, job size.

* :func:`compiled_lm_available`: numba installed and ``MECHKIN_JIT`` not ``0``.
* :func:`configure_numba_cache`: where numba keeps the compiled kernels. ``NUMBA_CACHE_DIR``
  when the user set it; else numba's own ``__pycache__`` next to the package's source when that
  folder is writable; else a user cache folder (:func:`user_cache_dir`,
  ``~/.cache/mechkin/numba`` on Linux), set as ``NUMBA_CACHE_DIR`` before numba is imported.
* :func:`use_compiled`: the numpy path for jobs too small to repay loading the compiled
  kernels (a rent-or-buy rule, see the constants below); ``MECHKIN_JIT=1`` always compiles.
* :func:`announce`: the one stderr line before a kernel is compiled (not cached yet).

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. Imports only the standard library and
:mod:`mechkin.model.fk_accel` (the shared cache-folder rule; never numba itself).
:mod:`mechkin.solvers.ik.lm` and :mod:`mechkin.solvers.ik.cg_golden` read
``accel.compiled_lm_available()`` at call time, so monkeypatching this module's attribute
switches the back end everywhere (a patched function is obeyed as it is: no job-size rule).
"""

from __future__ import annotations

import importlib.util
import os
import sys
import threading
from functools import lru_cache
from pathlib import Path

from mechkin.model import fk_accel as _fk_accel

#: The IK package folder: numba's default cache is its ``__pycache__``.
PACKAGE_DIR = Path(__file__).resolve().parent


@lru_cache(maxsize=1)
def _numba_installed() -> bool:
    return importlib.util.find_spec("numba") is not None


def compiled_lm_available() -> bool:
    """True when numba is installed (``pip install "mechkin[fast]"``) and the environment
    variable ``MECHKIN_JIT`` is not ``0``: open-chain ``lm`` then runs compiled
    (:mod:`mechkin.solvers.ik.serial_jit`), closed chains by :mod:`mechkin.solvers.ik.tree_jit`."""
    if os.environ.get("MECHKIN_JIT", "auto") == "0":
        return False
    return _numba_installed()


_AVAILABLE = compiled_lm_available


# ---- cache folder ------------------------------------------------------------------------------


# One cache-folder rule for the FK and IK kernels (mechkin.model.fk_accel, standard library
# only): the user cache folder and the writability test are shared.
user_cache_dir = _fk_accel.user_cache_dir
_writable = _fk_accel._writable


def configure_numba_cache(package_dir: Path | None = None) -> str | None:
    """Choose numba's cache folder before numba is imported; returns it (None: numba's
    default, the package's own ``__pycache__``).

    ``NUMBA_CACHE_DIR`` set by the user is kept as it is. Otherwise, when the package folder
    is not writable (a system or read-only install), ``NUMBA_CACHE_DIR`` is set to
    :func:`user_cache_dir` (created), so the kernels compile once per user instead of in
    every process. If numba is already imported its config is updated too."""
    return _fk_accel.configure_numba_cache(package_dir or PACKAGE_DIR, writable=_writable)


# ---- which back end for this job ---------------------------------------------------------------

# Rent or buy. Loading the compiled kernels costs a fixed time per process (numba import and
# cache load, or a compile on a cold cache); the numpy lm costs per call and per row. A job
# runs numpy while the numpy time it has spent, plus this call's estimate, stays below the
# load cost, then loads the kernels for good (at most twice the better choice). Work is
# counted in estimated seconds from call and row counts, never measured at run time, so the
# choice (and the result) does not depend on the machine's load.
# Measured 2026-12-02 (2 cores, numba 0.68, warm cache; benchmarks/speed_table.py
# --measure-breakeven repeats it): solve_ik_batch, PUMA 560, restarts 3, codebook already
# built: numpy 6 ms (m = 1), 40 ms (m = 10), 43 ms (m = 100), 285 ms (m = 1000); compiled
# 0.8-1.0 s more on the first call of a process (numba import ~0.45 s + cache load), then
# 2-26 ms. Panda: 0.6 s more. Break-even about 3,500 open-chain rows in one call.
# kim1995 end-effector robot (closed): numpy 0.3 s (m = 1), 2.0 s (m = 10), 3.9 s (m = 100);
# compiled 1.0 s on the first call (cache load), 3-73 ms after: break-even 2-3 rows.
# Open chains, measured again 2026-12-02 03:30 (issue 15; `mechkin ik
# scenarios/puma560_random_ik.yaml`: 50 single solves from the guess, 31 of them restarted):
# numpy lm 9.6 ms per one-row call (21 iterations), 6.4 ms per 30-row restart call that stops
# at the first success, 0.68 s in all; compiled: numba import 0.25-0.45 s + cache load
# 0.55-0.9 s, then 0.02 s for the 50 solves. End to end (several interleaved rounds)
# MECHKIN_JIT=0 was the faster, so this job must stay numpy: per call 8 ms, restart rows of
# one target count as one row (lm.lm_batch), estimate 0.67 s < 0.9 s.
OPEN_LOAD_S = 0.9  # first compiled open-chain call in a process, warm cache [s]
OPEN_CALL_S = 0.008  # numpy lm_batch, open chain: per call [s] ...
OPEN_ROW_S = 2.5e-4  # ... and per row [s]
CLOSED_LOAD_S = 0.8  # first compiled closed-chain call, warm cache, beyond numpy's m = 1 [s]
CLOSED_CALL_S = 0.3  # numpy lm_batch, closed chain: per call [s] ...
CLOSED_ROW_S = 0.04  # ... and per row [s]

_COSTS = {"open": (OPEN_LOAD_S, OPEN_CALL_S, OPEN_ROW_S),
          "closed": (CLOSED_LOAD_S, CLOSED_CALL_S, CLOSED_ROW_S)}
_spent = {"open": 0.0, "closed": 0.0}  # estimated numpy seconds so far in this process
_loaded: set[str] = set()  # kinds whose compiled kernels this process has run
_lock = threading.Lock()


def mark_loaded(kind: str) -> None:
    """Record that the compiled kernels of ``kind`` ("open", "closed") are loaded."""
    _loaded.add(kind)


def is_loaded(kind: str) -> bool:
    """Whether this process has run the compiled kernels of ``kind`` ("open", "closed") and
    may use them (``MECHKIN_JIT=0`` turns them off even then)."""
    return kind in _loaded and compiled_lm_available()


def _settled(kind: str) -> bool | None:
    """The answer of :func:`use_compiled` when it does not depend on the job's size: False
    without numba or with ``MECHKIN_JIT=0``; True when the availability check is patched
    (tests choosing a back end), with ``MECHKIN_JIT=1`` or once the kernels are loaded; else
    None (rent or buy decides)."""
    if not compiled_lm_available():
        return False
    if compiled_lm_available is not _AVAILABLE or os.environ.get("MECHKIN_JIT") == "1":
        return True
    return True if kind in _loaded else None


def use_compiled(kind: str, rows: int) -> bool:
    """Whether an lm call of ``rows`` rows on a ``kind`` ("open" or "closed") chain runs
    compiled.

    False when :func:`compiled_lm_available` says no. True when that function is
    monkeypatched (tests choosing a back end), with ``MECHKIN_JIT=1``, once the kernels are
    loaded in this process, or when the numpy time of this job so far plus this call's
    would exceed the load cost (module constants, measured); else the numpy path, and its
    estimated time is added to the job's."""
    settled = _settled(kind)
    if settled is not None:
        return settled
    load, per_call, per_row = _COSTS[kind]
    est = per_call + per_row * max(int(rows), 0)
    with _lock:
        if _spent[kind] + est <= load:
            _spent[kind] += est
            return False
    return True


def compiled_next(kind: str, rows: int) -> bool:
    """Whether :func:`use_compiled` would answer True for this call, without counting the
    call's numpy estimate (a peek: the fast single-solve path of
    :func:`mechkin.solvers.ik.solve.solve_ik` is taken only then, so the job's choice of back
    end is the same as without it)."""
    settled = _settled(kind)
    if settled is not None:
        return settled
    load, per_call, per_row = _COSTS[kind]
    with _lock:
        return _spent[kind] + per_call + per_row * max(int(rows), 0) > load


def reset_job() -> None:
    """Forget the numpy time spent (tests; a new job in a long-lived process)."""
    with _lock:
        for k in _spent:
            _spent[k] = 0.0


# ---- first-use note ----------------------------------------------------------------------------

#: Compile time of each entry kernel on a cold cache (measured 2026-12-02 on the 2-core
#: machine of the README speed table; ``mechkin warmup`` prints the actual times).
EXPECTED_COMPILE_S = {"serial_jit.lm": 15.0, "serial_jit.solve_rows": 20.0,
                      "serial_jit.verify_rows": 5.0, "serial_jit.lm_verify": 20.0,
                      "tree_jit.lm_closed": 30.0, "coupled_jit.lm_coupled": 20.0,
                      "tree_jit.evaluate_one": 40.0}
_announced: set[str] = set()
quiet = False  # ``mechkin warmup`` prints its own progress lines


def is_cached(dispatcher) -> bool | None:
    """Whether numba's cache holds a compiled version of ``dispatcher`` for its current
    source (None when that cannot be told)."""
    try:
        if dispatcher.signatures:  # compiled or loaded in this process already
            return True
        cache = dispatcher._cache
        return bool(cache._cache_file._load_index())
    except Exception:  # noqa: BLE001 - numba internals: no note rather than an error
        return None


def announce(dispatcher, name: str) -> None:
    """Before the first call of a compiled entry kernel in this process: one stderr line
    naming it and the expected compile time when numba's cache does not hold it."""
    if name in _announced:
        return
    _announced.add(name)
    if quiet or is_cached(dispatcher) is not False:
        return
    where = os.environ.get("NUMBA_CACHE_DIR") or str(PACKAGE_DIR / "__pycache__")
    sys.stderr.write(
        f"mechkin: compiling the numba kernel {name} (first use; about "
        f"{EXPECTED_COMPILE_S.get(name, 20.0):.0f} s, then cached in {where}; "
        f"`mechkin warmup` compiles ahead)\n")
    sys.stderr.flush()
