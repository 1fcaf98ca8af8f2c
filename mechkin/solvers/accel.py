"""Optional compiled kernels: whether they can be used (numba installed, not turned off)."""

from __future__ import annotations

import importlib.util
import os
from functools import lru_cache


@lru_cache(maxsize=1)
def compiled_lm_available() -> bool:
    """True when numba is installed (``pip install "mechkin[fast]"``) and the environment
    variable ``MECHKIN_JIT`` is not ``0``: open-chain ``lm`` then runs compiled
    (:mod:`mechkin.solvers.ik_serial_jit`)."""
    if os.environ.get("MECHKIN_JIT", "1") == "0":
        return False
    return importlib.util.find_spec("numba") is not None
