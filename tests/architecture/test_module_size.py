"""No module of the package over 600 lines (DESIGN.md: split by reading, files that fit in a
head; issue 23)."""

from __future__ import annotations

from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[2] / "mechkin"
MAX_LINES = 600
MODULES = sorted(PKG.rglob("*.py"))


def test_the_package_has_modules():
    assert len(MODULES) > 50


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PKG.parent)))
def test_module_fits_in_a_head(path):
    n = len(path.read_text(encoding="utf-8").splitlines())
    assert n <= MAX_LINES, f"{path.relative_to(PKG.parent)}: {n} lines (at most {MAX_LINES})"
