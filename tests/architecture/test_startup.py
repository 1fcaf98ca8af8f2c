"""A CLI that starts instantly: the light commands import no numerical, plotting or MCAP code,
and a run imports only what it uses (issue 15: the cost of one ``mechkin`` call).

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


# ---- what a run imports (through mechkin.cli.app.main, as `mechkin` and `python -m mechkin`) ----

MAIN_PROBE = """
import json, sys
sys.argv = ["mechkin"] + json.loads(sys.argv[1])
from mechkin.cli.app import main
code = None
try:
    main()
except SystemExit as exc:
    code = exc.code
mods = sorted(sys.modules)
sys.stderr.write("\\nMODULES " + json.dumps({"code": code, "mods": mods}) + "\\n")
"""

# typer is the one argument reader (issue 23); a call registers only its own subcommand, and
# typer's rich help stays unloaded unless MECHKIN_RICH_HELP=1
CLI_FRAMEWORK = ("rich",)
OTHER_COMMANDS = ("mechkin.cli.fk", "mechkin.cli.ik", "mechkin.cli.track",
                  "mechkin.cli.workspace", "mechkin.cli.run", "mechkin.cli.info",
                  "mechkin.cli.check", "mechkin.cli.import_export", "mechkin.cli.warmup")


def _others(command: str) -> tuple[str, ...]:
    """The modules of every subcommand but ``command``."""
    return tuple(m for m in OTHER_COMMANDS if m != f"mechkin.cli.{command}")
OTHER_SPECS = ("mechkin.config.track_spec", "mechkin.config.workspace_spec",
               "mechkin.config.biped_spec")


def _run_modules(args: list[str], cwd: Path) -> tuple[int, set[str]]:
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg",
           "NUMBA_CACHE_DIR": os.environ["NUMBA_CACHE_DIR"], "MECHKIN_JIT": "0",
           "MECHKIN_FAST_EXIT": "0"}  # report sys.modules before leaving
    proc = subprocess.run([sys.executable, "-c", MAIN_PROBE, json.dumps(args)], cwd=cwd,
                          capture_output=True, text=True, timeout=300, env=env)
    line = [ln for ln in proc.stderr.splitlines() if ln.startswith("MODULES ")]
    assert line, proc.stderr
    got = json.loads(line[-1][len("MODULES "):])
    return got["code"], set(got["mods"])


def _ur5_ik(tmp_path: Path, outputs: str = "") -> Path:
    text = (ROOT / "scenarios" / "ur5_ik.yaml").read_text().replace(
        "../mechanisms/", f"{ROOT / 'mechanisms'}/")
    p = tmp_path / "ur5_ik.yaml"
    p.write_text(text + outputs)
    return p


def test_ik_without_plots_imports_no_plotting_no_rich_no_other_commands_or_specs(tmp_path):
    code, mods = _run_modules(["ik", str(_ur5_ik(tmp_path)), "--no-plots", "-o",
                               str(tmp_path / "out")], tmp_path)
    assert code == 0
    assert (tmp_path / "out" / "ik.mcap").is_file()
    for group in (("matplotlib", "mechkin.io.plots", "mechkin.io.workspace_plots"),
                  CLI_FRAMEWORK, _others("ik"), OTHER_SPECS,
                  ("mechkin.tasks.fk", "mechkin.tasks.track", "mechkin.tasks.workspace")):
        assert not _loaded(mods, group), _loaded(mods, group)
    assert "mechkin.config.ik_spec" in mods  # its own section


def test_ik_without_mcap_output_imports_no_mcap_or_protobuf(tmp_path):
    code, mods = _run_modules(["ik", str(_ur5_ik(tmp_path, "outputs: {mcap: false}\n")),
                               "--no-plots", "-o", str(tmp_path / "out")], tmp_path)
    assert code == 0
    assert not (tmp_path / "out" / "ik.mcap").exists()
    bad = _loaded(mods, ("mcap", "mcap_protobuf", "google.protobuf",
                         "foxglove_schemas_protobuf", "mechkin.io.mcap_out", "matplotlib"))
    assert not bad, bad


def test_fk_without_plots_imports_no_plotting_rich_or_other_commands(tmp_path):
    code, mods = _run_modules(["fk", str(ROOT / "scenarios" / "kim1995_direct_drive_fk.yaml"),
                               "--no-plots", "-o", str(tmp_path / "out")], tmp_path)
    assert code == 0
    bad = _loaded(mods, ("matplotlib", "mechkin.io.plots") + CLI_FRAMEWORK + OTHER_SPECS
                  + ("mechkin.config.ik_spec",) + _others("fk"))
    assert not bad, bad


@pytest.mark.parametrize("args", [["--help"], ["ik", "--help"], ["ik", "s.yaml", "--bogus"]])
def test_every_call_goes_through_typer(tmp_path, args):
    code, mods = _run_modules(args, tmp_path)
    assert "typer" in mods and "mechkin.cli.commands" in mods
    assert code == (2 if "--bogus" in args else 0)


@pytest.mark.parametrize("args", [["check", "mechanisms/puma560.yaml"],
                                  ["info", "mechanisms/kim1995_direct_drive.yaml", "--json"]])
def test_check_and_info_import_no_rich_plotting_or_other_commands(args):
    code, mods = _run_modules(args, ROOT)
    assert code == 0
    bad = _loaded(mods, CLI_FRAMEWORK + PLOTTING + _others(args[0]))
    assert not bad, bad
