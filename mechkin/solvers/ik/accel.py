"""Whether the optional compiled IK kernels can be used (numba installed, not turned off).

Design
------
Part of the IK solver family :mod:`mechkin.solvers.ik`. Imports only the standard library
(never numba itself). :mod:`mechkin.solvers.ik.lm` and :mod:`mechkin.solvers.ik.cg_golden`
read ``accel.compiled_lm_available()`` at call time, so monkeypatching this module's attribute
switches the back end everywhere.
"""

from __future__ import annotations

import importlib.util
import os
from functools import lru_cache


@lru_cache(maxsize=1)
def compiled_lm_available() -> bool:
    """True when numba is installed (``pip install "mechkin[fast]"``) and the environment
    variable ``MECHKIN_JIT`` is not ``0``: open-chain ``lm`` then runs compiled
    (:mod:`mechkin.solvers.ik.serial_jit`), closed chains by :mod:`mechkin.solvers.ik.tree_jit`."""
    if os.environ.get("MECHKIN_JIT", "1") == "0":
        return False
    return importlib.util.find_spec("numba") is not None
