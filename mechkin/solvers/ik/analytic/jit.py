"""The compile decorator of the analytic IK kernels: numba's ``njit`` (cached on disk) when
:func:`mechkin.solvers.ik.accel.compiled_lm_available` says numba may be used, else the plain
Python function (the same code, slower). Chosen once, at import.

Caution (numba's disk cache): a compiled function is re-compiled when its own source file
changes, not when a function it calls in another module does. After editing
``subproblems.py`` or ``solve6r.py``, delete the cache folder (``NUMBA_CACHE_DIR``, or the
package's ``__pycache__``) or the callers in ``finish.py`` keep the old code. An installed
package is not affected (every file is new at install).

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports :mod:`mechkin.solvers.ik.accel` and, when
allowed, numba.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from mechkin.solvers.ik.accel import compiled_lm_available, configure_numba_cache

COMPILED = compiled_lm_available()

if COMPILED:
    configure_numba_cache()
    import numba

    def jit(fn: Callable[..., Any]) -> Callable[..., Any]:
        """numba.njit(cache=True, nogil=True) of ``fn``."""
        return numba.njit(cache=True, nogil=True)(fn)
else:  # pragma: no cover - exercised with MECHKIN_JIT=0

    def jit(fn: Callable[..., Any]) -> Callable[..., Any]:
        """``fn`` itself (numba unavailable or MECHKIN_JIT=0)."""
        return fn
