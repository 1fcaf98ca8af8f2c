"""When :func:`mechkin.model.kinematics.frame_poses` runs compiled: availability, job size,
cache folder, warm-up.

* :func:`compiled_fk_available`: numba installed and ``MECHKIN_JIT`` not ``0``.
* :func:`kernel_for_job`: the compiled kernel (:func:`mechkin.model.fk_jit.plan_poses`) or None
  (the numpy / plain-Python routes), by the same rent-or-buy rule as the IK
  (:mod:`mechkin.solvers.ik.accel`): loading numba and the cached kernel costs a fixed time per
  process, so a process runs the numpy routes while their estimated time so far plus this
  call's stays below that cost, then loads the kernel for good (at most twice the better
  choice). ``MECHKIN_JIT=1`` loads it on the first call, ``MECHKIN_JIT=0`` never. Work is
  counted in estimated seconds from call, path-joint and row counts (constants below,
  measured), never timed at run time, so the route does not depend on the machine's load.
* :func:`configure_numba_cache`: the cache folder rule of the IK kernels, for this package
  folder (``NUMBA_CACHE_DIR`` when set; else numba's ``__pycache__`` next to the source when
  writable; else the user cache folder, ``~/.cache/mechkin/numba`` on Linux).
* :func:`warm`: compile or load the kernel now (for ``mechkin warmup``).

Results do not depend on the route a process took: by rent or buy the kernel serves single
configurations only, where it performs the plain-Python route's operations in the same order
(the same bits; tests/model/test_fk_routes.py); batches and the tree FK
(:func:`mechkin.model.kinematics.forward_kinematics`) run compiled only with
``MECHKIN_JIT=1`` (other operation orders: equal to 1e-12, not bit for bit), so a serial run
and its distributed workers give identical output.

``MECHKIN_JIT`` is read on the first call of a job (a process, or since :func:`reset`); once
loaded, the kernel serves the rest of the job (:func:`reset` forgets it and the flag).

Design
------
Part of :mod:`mechkin.model`. Imports only the standard library at module level (never numba
itself: :mod:`mechkin.model.fk_jit` does, when the kernel is loaded).
"""

from __future__ import annotations

import importlib.util
import os
import sys
import tempfile
import threading
import time
from functools import lru_cache
from pathlib import Path

#: The model package folder: numba's default cache is its ``__pycache__``.
PACKAGE_DIR = Path(__file__).resolve().parent

# Rent or buy (measured 2026-12-02, 2 cores, numba 0.68, warm cache; PUMA 560, 6 path joints):
# numpy / plain-Python frame_poses: 1 configuration 5-8 us (the generated straight-line
# function: about 1.5 us plus 0.8 us per path joint), 2-127 configurations 35-165 us (4x4
# products), from PLAN_LARGE_BATCH on 0.45-0.7 us per configuration (0.08-0.12 us per path
# joint and configuration). Loading the compiled kernel: 0.9-1.6 s in a fresh process (numba
# import 0.4-0.6 s, numba's CPU target set-up, cache load), 0.01-0.03 s once another compiled
# kernel (e.g. the IK's) has set numba up. Compiled: 1.5-2.5 us per single call, 0.3 us per
# configuration in batches.
LOAD_S = 0.9  # first compiled call in a process where numba is not set up yet [s]
LOAD_WARM_S = 0.03  # ... where numba's CPU target is set up already [s]
SINGLE_CALL_S = 1.5e-6  # numpy routes, one configuration: per call [s] ...
SINGLE_STEP_S = 0.8e-6  # ... and per path joint [s]
BATCH_CALL_S = 3.5e-5  # numpy routes, several configurations: per call [s] ...
STEP_ROW_S = 1.0e-7  # ... and per path joint and configuration [s]

#: Compile time of the kernel on a cold cache (measured 2026-12-02 on the 2-core machine).
EXPECTED_COMPILE_S = 3.0
quiet = False  # ``mechkin warmup`` prints its own progress lines
_lock = threading.Lock()
_spent = 0.0  # estimated numpy seconds so far in this process
_flag: str | None = None  # MECHKIN_JIT as read on the job's first call ("0" without numba)
#: The loaded kernel (None: not loaded), a numba dispatcher (checks its argument types).
KERNEL = None
#: Its compiled entry point (no type dispatch: the caller passes exactly float64 (m, n),
#: (p + k, 16), (m, k, 4, 4) arrays, C-ordered, aligned and writable); frame_poses reads this
#: attribute on every call. The dispatcher when numba does not expose it.
ENTRY = None
#: Whether the kernel serves batches and the tree FK too (``MECHKIN_JIT=1``); by rent or buy
#: it serves single configurations only, where it gives the numpy route's bits exactly.
EVERYWHERE = False


@lru_cache(maxsize=1)
def _numba_installed() -> bool:
    return importlib.util.find_spec("numba") is not None


def compiled_fk_available() -> bool:
    """True when numba is installed (``pip install "mechkin[fast]"``) and ``MECHKIN_JIT`` is
    not ``0``."""
    if os.environ.get("MECHKIN_JIT", "auto") == "0":
        return False
    return _numba_installed()


def estimate_s(path_joints: int, rows: int) -> float:
    """Estimated time [s] of one numpy-route ``frame_poses`` call (model constants above)."""
    if rows <= 1:
        return SINGLE_CALL_S + SINGLE_STEP_S * path_joints
    return BATCH_CALL_S + STEP_ROW_S * path_joints * int(rows)


def _numba_set_up() -> bool:
    """Whether numba's CPU target is initialised in this process (a compiled kernel ran)."""
    reg = sys.modules.get("numba.core.registry")
    try:
        return reg is not None and "_toplevel_target_context" in vars(reg.cpu_target)
    except Exception:  # noqa: BLE001 - numba internals: assume the full cost
        return False


def load_cost_s() -> float:
    """The fixed cost [s] of loading the compiled kernel in this process now."""
    return LOAD_WARM_S if _numba_set_up() else LOAD_S


def kernel_for_job(path_joints: int, rows: int):
    """The compiled kernel when this call should run compiled, else None (see the module
    docstring: rent or buy; ``MECHKIN_JIT=1`` always, ``=0`` never)."""
    global _spent, _flag
    if KERNEL is not None and (rows == 1 or EVERYWHERE):
        return KERNEL
    flag = _flag
    if flag is None:  # read once per job (os.environ costs about 0.5 us per lookup)
        flag = _flag = os.environ.get("MECHKIN_JIT", "auto")
        if flag != "0" and not _numba_installed():
            flag = _flag = "0"
    if flag == "0":
        return None
    if flag != "1":
        if rows != 1:  # batches: the numpy routes (the same bits in every process)
            return None
        est = estimate_s(path_joints, rows)
        if _spent + est <= load_cost_s():
            _spent += est  # a race between threads only shifts the switch by one call
            return None
    return load()


def load():
    """Import (and on a cold cache compile) the kernel; it serves every later call."""
    global KERNEL, ENTRY, EVERYWHERE
    EVERYWHERE = os.environ.get("MECHKIN_JIT") == "1"
    if KERNEL is None:
        fk_jit = _jit_module()
        if not quiet and is_cached() is False:
            where = os.environ.get("NUMBA_CACHE_DIR") or str(PACKAGE_DIR / "__pycache__")
            sys.stderr.write(
                f"mechkin: compiling the numba kernel fk_jit.plan_poses (first use; about "
                f"{EXPECTED_COMPILE_S:.0f} s, then cached in {where}; `mechkin warmup` "
                "compiles ahead)\n")
            sys.stderr.flush()
        kern = fk_jit.ready()
        try:
            entry = kern.overloads[kern.signatures[0]].entry_point
        except (AttributeError, IndexError, KeyError):  # numba internals: the dispatcher
            entry = kern
        KERNEL, ENTRY = kern, entry
    return KERNEL


def _jit_module():
    """mechkin.model.fk_jit (imports numba), after choosing numba's cache folder."""
    configure_numba_cache()
    from mechkin.model import fk_jit

    return fk_jit


def reset() -> None:
    """Forget the loaded kernel, the numpy time spent and the MECHKIN_JIT flag read (tests;
    a new job)."""
    global KERNEL, ENTRY, EVERYWHERE, _spent, _flag
    with _lock:
        KERNEL = ENTRY = None
        EVERYWHERE = False
        _spent = 0.0
        _flag = None


def is_cached() -> bool | None:
    """Whether numba's cache holds the kernel for its current source (None: cannot tell)."""
    try:
        disp = _jit_module().plan_poses
        if disp.signatures:
            return True
        return bool(disp._cache._cache_file._load_index())
    except Exception:  # noqa: BLE001 - numba internals: no answer rather than an error
        return None


def warm() -> tuple[float, bool | None]:
    """Compile or load the kernel now and run it once on a one-joint plan: (seconds, whether
    numba's cache held it before). For ``mechkin warmup``."""
    import numpy as np

    global quiet
    t0 = time.perf_counter()
    cached = is_cached()
    was, quiet = quiet, True  # the caller prints its own progress line
    try:
        kern = load()
    finally:
        quiet = was
    plan = np.zeros((2, 16))
    plan[:, [0, 5, 10]] = 1.0
    plan[0, 13], plan[0, 14] = 1.0, -1.0
    out = np.empty((1, 1, 4, 4))
    kern(np.zeros((1, 1)), plan, out)
    return time.perf_counter() - t0, cached


def _writable(folder: Path) -> bool:
    """Whether numba can write its cache into ``folder/__pycache__`` (as numba tests it)."""
    target = folder / "__pycache__"
    try:
        target.mkdir(exist_ok=True)
        with tempfile.TemporaryFile(dir=target):
            pass
    except OSError:
        return False
    return True


def user_cache_dir() -> Path:
    """The per-user folder for compiled kernels (the IK's rule,
    :func:`mechkin.solvers.ik.accel.user_cache_dir`)."""
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
        return base / "mechkin" / "Cache" / "numba"
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches" / "mechkin" / "numba"
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg) if xdg and os.path.isabs(xdg) else Path.home() / ".cache"
    return base / "mechkin" / "numba"


def configure_numba_cache(package_dir: Path | None = None, writable=None) -> str | None:
    """Choose numba's cache folder before numba is imported; returns it (None: numba's
    default, this package's ``__pycache__``). ``NUMBA_CACHE_DIR`` set by the user is kept;
    a read-only package folder (``writable``, default :func:`_writable`) sends the cache to
    :func:`user_cache_dir`. The IK kernels' rule too
    (:func:`mechkin.solvers.ik.accel.configure_numba_cache`)."""
    given = os.environ.get("NUMBA_CACHE_DIR")
    if given:
        return given
    if (writable or _writable)(package_dir or PACKAGE_DIR):
        return None
    folder = user_cache_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None  # numba falls back to its own user-wide locator
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    cfg = sys.modules.get("numba.core.config")
    if cfg is not None:
        cfg.CACHE_DIR = str(folder)
    return str(folder)
