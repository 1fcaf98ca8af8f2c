"""``@pytest.mark.slow`` tests (several worker pools, CLI runs) run with ``-m slow`` or
``MECHKIN_SLOW_TESTS=1``; the default suite skips them.

Every test here pins the lm back end to numpy (``MECHKIN_JIT=0``, inherited by the worker
processes): the automatic choice (numpy for jobs too small to repay loading the compiled
kernels, :func:`mechkin.solvers.ik.accel.use_compiled`) depends on how much work a process has
done, so a single process and a worker may pick different back ends, which agree to round-off
but not bit for bit; with the back end pinned the split runs must equal the single run
bitwise."""

import os

import pytest


@pytest.fixture(autouse=True)
def _numpy_back_end(monkeypatch):
    from mechkin.solvers.ik import accel

    monkeypatch.setenv("MECHKIN_JIT", "0")
    accel.reset_job()
    yield
    accel.reset_job()


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: a test of more than ~20 s (run with -m slow)")


def pytest_collection_modifyitems(config, items):
    if os.environ.get("MECHKIN_SLOW_TESTS") or "slow" in (config.getoption("-m") or ""):
        return
    skip = pytest.mark.skip(reason="slow: run with -m slow or MECHKIN_SLOW_TESTS=1")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
