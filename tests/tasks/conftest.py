"""``@pytest.mark.slow`` tests (several worker pools, CLI runs) run with ``-m slow`` or
``MECHKIN_SLOW_TESTS=1``; the default suite skips them."""

import os

import pytest


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: a test of more than ~20 s (run with -m slow)")


def pytest_collection_modifyitems(config, items):
    if os.environ.get("MECHKIN_SLOW_TESTS") or "slow" in (config.getoption("-m") or ""):
        return
    skip = pytest.mark.skip(reason="slow: run with -m slow or MECHKIN_SLOW_TESTS=1")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
