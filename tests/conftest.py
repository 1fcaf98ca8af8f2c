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


@pytest.fixture(autouse=True)
def _fk_route_read_per_test():
    """Every test starts a new FK "job": ``MECHKIN_JIT`` is read again and the rent-or-buy
    state of :mod:`mechkin.model.fk_accel` is forgotten (a process reads the flag once, so a
    test that set ``MECHKIN_JIT=1`` would otherwise leave batched FK compiled for the tests
    after it, and serial-vs-worker comparisons would differ in the last bits)."""
    from mechkin.model import fk_accel

    fk_accel.reset()
    yield


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


_MISSING_PACKAGE = ("could not import", "No module named", "not installed")


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """With ``MECHKIN_REQUIRE_EXTRAS=1`` (set by ``.ci/run``) a test skipped because a package
    is missing fails the run: every package the suite uses is in the ``[test]`` extra, so such a
    skip means the extra and the suite disagree. Skips on purpose (``MECHKIN_SLOW_TESTS``) pass."""
    if os.environ.get("MECHKIN_REQUIRE_EXTRAS") != "1":
        return
    missing = []
    for rep in terminalreporter.stats.get("skipped", []):
        reason = str(rep.longrepr[2] if isinstance(rep.longrepr, tuple) else rep.longrepr)
        if any(s in reason for s in _MISSING_PACKAGE):
            missing.append(f"{rep.nodeid}: {reason}")
    if missing:
        terminalreporter.write_line(
            f"{len(missing)} test(s) skipped for a missing package (add it to [test]):", red=True)
        for line in missing[:20]:
            terminalreporter.write_line("  " + line)
        terminalreporter._session.exitstatus = 1  # noqa: SLF001 (pytest has no public setter)
