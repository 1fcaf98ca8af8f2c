import os
import sys
import tempfile
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")
# numba caches go to a temporary folder (kept between runs), never into the package directory;
# set before numba is imported, and inherited by the subprocesses the CLI tests start
_UID = getattr(os, "getuid", lambda: 0)()
os.environ.setdefault("NUMBA_CACHE_DIR",
                      os.path.join(tempfile.gettempdir(), f"mechkin-numba-cache-{_UID}"))
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


@pytest.fixture
def root() -> Path:
    return ROOT


@pytest.fixture
def mechanisms_dir() -> Path:
    return ROOT / "mechanisms"


@pytest.fixture
def scenarios_dir() -> Path:
    return ROOT / "scenarios"


@pytest.fixture(params=["compiled", "numpy"])
def lm_backend(request, monkeypatch):
    """The IK both ways: compiled kernels (numba, mechkin[fast]) and numpy on mechkin.model."""
    from mechkin.solvers.ik import accel

    if request.param == "compiled":
        pytest.importorskip("numba")
    monkeypatch.setattr(accel, "compiled_lm_available",
                        lambda: request.param == "compiled")
    return request.param
