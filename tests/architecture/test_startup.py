"""A CLI that starts instantly: the light commands import no numerical, plotting or MCAP code.

Each command runs in a fresh interpreter that then reports ``sys.modules``; the assertion is on
what was imported, never on time.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("numpy", "scipy", "matplotlib", "mcap", "mechkin.solvers", "mechkin.model")
PLOTTING = ("matplotlib", "mcap", "mechkin.io.plots", "mechkin.io.mcap_out")

PROBE = """
import json, sys
sys.argv = ["mechkin"] + json.loads(sys.argv[1])
from mechkin.cli.app import app
try:
    app()
except SystemExit:
    pass
mods = sorted(m for m in sys.modules if m.split(".")[0] in {%s} or m.startswith("mechkin."))
sys.stderr.write("\\nMODULES " + json.dumps(mods) + "\\n")
"""


def _modules(args: list[str]) -> set[str]:
    roots = ", ".join(repr(h.split(".")[0]) for h in HEAVY)
    proc = subprocess.run([sys.executable, "-c", PROBE % roots, json.dumps(args)],
                          cwd=ROOT, capture_output=True, text=True, timeout=120,
                          env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin",
                               "NUMBA_CACHE_DIR": os.environ["NUMBA_CACHE_DIR"]})
    line = [ln for ln in proc.stderr.splitlines() if ln.startswith("MODULES ")]
    assert line, proc.stderr
    return set(json.loads(line[-1][len("MODULES "):]))


def _loaded(mods: set[str], prefixes: tuple[str, ...]) -> list[str]:
    return sorted(m for m in mods if any(m == p or m.startswith(p + ".") for p in prefixes))


@pytest.mark.parametrize("args", [["--help"], ["--version"], ["version"],
                                  ["schema", "mechanism"], ["schema", "scenario"],
                                  ["fk", "--help"], ["workspace", "--help"]])
def test_light_commands_import_nothing_heavy(args):
    mods = _modules(args)
    assert "mechkin.cli.app" in mods
    assert not _loaded(mods, HEAVY), _loaded(mods, HEAVY)


@pytest.mark.parametrize("args", [["check", "mechanisms/puma560.yaml"],
                                  ["info", "mechanisms/kim1995_direct_drive.yaml"]])
def test_check_and_info_import_no_plotting_or_mcap(args):
    mods = _modules(args)
    assert not _loaded(mods, PLOTTING), _loaded(mods, PLOTTING)


def test_version_option_prints_the_version():
    from mechkin import __version__

    out = subprocess.run([sys.executable, "-m", "mechkin", "--version"], cwd=ROOT,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == __version__
