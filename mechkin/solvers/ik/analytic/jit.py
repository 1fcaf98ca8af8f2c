"""The compile decorator of the analytic IK kernels: numba's ``njit`` (cached on disk) when
:func:`mechkin.solvers.ik.accel.compiled_lm_available` says numba may be used, else the plain
Python function (the same code, slower). Chosen once, at import.

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
