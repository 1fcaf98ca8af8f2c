"""The run commands read without typer (mechkin.cli.fast) mean what the typer app reads.

Each argument list is given to the typer app with ``execute`` replaced by a recorder, and to
:func:`mechkin.cli.fast.parse_run_args`: where the fast reader accepts it, both hand the same
values to the same function; where it declines, typer reads it as before. End to end, a run
through ``python -m mechkin`` gives the same stdout, stderr, exit code and files with the fast
reader on and off (``MECHKIN_FAST_CLI=0``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from mechkin.cli import fast
from mechkin.cli.app import app

ROOT = Path(__file__).resolve().parents[2]

ACCEPTED = [
    ["ik", "s.yaml"],
    ["fk", "s.yaml", "--no-plots"],
    ["track", "s.yaml", "--plots"],
    ["workspace", "s.yaml", "-o", "out dir", "--json"],
    ["ik", "--no-plots", "s.yaml", "--out=o/x", "--force"],
    ["fk", "s.yaml", "--max-memory", "512M", "--progress"],
    ["workspace", "s.yaml", "--no-progress", "-j", "3", "--scheduler", "tcp://h:8786"],
    ["ik", "s.yaml", "--workers", "12", "--json", "--no-plots", "-o", "o"],
    ["ik", "s.yaml", "--workers=2", "--max-memory=8G", "--scheduler=tcp://a:1"],
    ["track", "dir with space/s ü.yaml", "--out", "a=b"],
]

DECLINED = [
    [],
    ["--help"],
    ["--version"],
    ["info", "m.yaml"],
    ["check", "s.yaml"],
    ["ik"],
    ["ik", "--help"],
    ["ik", "s.yaml", "--help"],
    ["ik", "a.yaml", "b.yaml"],
    ["ik", "s.yaml", "--out"],
    ["ik", "s.yaml", "-o", "--json"],
    ["ik", "s.yaml", "--out="],
    ["ik", "s.yaml", "-o=x"],
    ["ik", "s.yaml", "-ox"],
    ["ik", "s.yaml", "--json=1"],
    ["ik", "s.yaml", "--no-plots", "--plots"],
    ["ik", "s.yaml", "--workers", "0"],
    ["ik", "s.yaml", "--workers", "007"],
    ["ik", "s.yaml", "--workers", "two"],
    ["ik", "s.yaml", "-j", "-1"],
    ["ik", "s.yaml", "--plot"],
    ["ik", "s.yaml", "--"],
    ["ik", "-"],
    ["ik", "s.yaml", "-x"],
]


def _typer_reading(monkeypatch, argv: list[str]) -> tuple[int, dict | None]:
    """What the typer app hands to ``execute`` for ``argv`` (None if it does not call it)."""
    import mechkin.cli.common as common
    import mechkin.cli.workspace as workspace

    seen: dict = {}

    def record(task, scenario, out, json_out, plots, line, *, force=False, max_memory=None,
               **options):
        seen.update(task=task, scenario=scenario, out=out, json_out=json_out, plots=plots,
                    line=line.__name__, force=force, max_memory=max_memory, **options)
        return 0

    monkeypatch.setattr(common, "execute", record)
    monkeypatch.setattr(workspace, "execute", record)
    res = CliRunner().invoke(app, argv)
    return res.exit_code, (seen or None)


@pytest.mark.parametrize("argv", ACCEPTED, ids=" ".join)
def test_fast_reading_is_typers(monkeypatch, argv):
    parsed = fast.parse_run_args(argv)
    assert parsed is not None
    task, kw = parsed
    code, seen = _typer_reading(monkeypatch, argv)
    assert code == 0 and seen is not None
    mine = dict(kw, task=task, line=f"{task}_line")
    for key, value in mine.items():
        assert seen[key] == value and type(seen[key]) is type(value), key
    assert set(seen) == set(mine)


@pytest.mark.parametrize("argv", DECLINED, ids=lambda a: " ".join(a) or "(none)")
def test_fast_reader_leaves_the_rest_to_typer(argv):
    assert fast.parse_run_args(argv) is None


def _run(args: list[str], cwd: Path, fast_on: bool) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg",
               MECHKIN_FAST_CLI="1" if fast_on else "0")
    return subprocess.run([sys.executable, "-m", "mechkin", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())
            if p.suffix in (".csv", ".json") and p.name != "summary.json"}


def _untimed(obj):
    """``obj`` without its wall-time entries (``*time*_s``) and ``out_dir``."""
    if isinstance(obj, dict):
        return {k: _untimed(v) for k, v in obj.items()
                if k != "out_dir" and not ("time" in k and k.endswith("_s"))}
    if isinstance(obj, list):
        return [_untimed(v) for v in obj]
    return obj


def _summary(folder: Path) -> dict:
    return _untimed(json.loads((folder / "summary.json").read_text()))


def test_a_run_is_the_same_with_and_without_the_fast_reader(tmp_path):
    scenario = ROOT / "scenarios" / "kim1995_direct_drive_fk.yaml"
    runs = []
    for fast_on in (True, False):
        out = tmp_path / ("fast" if fast_on else "typer")
        res = _run(["fk", str(scenario), "--no-plots", "-o", str(out)], tmp_path, fast_on)
        runs.append((res.returncode, res.stdout.replace(str(out), "OUT"), res.stderr,
                     _files(out), _summary(out)))
    assert runs[0][0] == 0
    assert runs[0] == runs[1]


@pytest.mark.parametrize("case", ["missing file", "bad yaml", "wrong task", "bad size",
                                  "out is a file"])
def test_errors_are_the_same_with_and_without_the_fast_reader(tmp_path, case):
    scenario = ROOT / "scenarios" / "kim1995_direct_drive_fk.yaml"
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\ntask: fk\nfk: [\n")
    afile = tmp_path / "afile"
    afile.write_text("x")
    args = {"missing file": ["fk", str(tmp_path / "none.yaml")],
            "bad yaml": ["fk", str(bad)],
            "wrong task": ["ik", str(scenario), "--no-plots"],
            "bad size": ["fk", str(scenario), "--max-memory", "lots"],
            "out is a file": ["fk", str(scenario), "-o", str(afile)]}[case]
    a, b = _run(args, tmp_path, True), _run(args, tmp_path, False)
    assert a.returncode == 2
    assert (a.returncode, a.stdout, a.stderr) == (b.returncode, b.stdout, b.stderr)


FILE_ACCEPTED = [["info", "m.yaml"], ["info", "--json", "m.yaml"], ["info", "m.yaml", "--json"],
                 ["check", "a.yaml"], ["check", "a.yaml", "b dir/c.urdf", "d.yaml"]]
FILE_DECLINED = [["info"], ["info", "a.yaml", "b.yaml"], ["info", "m.yaml", "--help"],
                 ["info", "m.yaml", "--json", "--json"], ["info", "-"], ["check"],
                 ["check", "a.yaml", "--help"], ["check", "--", "a.yaml"], ["fk", "s.yaml"]]


@pytest.mark.parametrize("argv", FILE_ACCEPTED, ids=" ".join)
def test_fast_reading_of_info_and_check_is_typers(monkeypatch, argv):
    import mechkin.cli.check as check
    import mechkin.cli.info as info

    seen: dict = {}
    monkeypatch.setattr(info, "show_info",
                        lambda mechanism, json_out: seen.update(mechanism=mechanism,
                                                                json_out=json_out))
    monkeypatch.setattr(check, "run_check", lambda files: seen.update(files=files) or 0)
    res = CliRunner().invoke(app, argv)
    assert res.exit_code == 0, res.output
    parsed = fast.parse_file_args(argv)
    assert parsed is not None and parsed[0] == argv[0]
    assert parsed[1] == seen
    for key, value in parsed[1].items():
        assert type(seen[key]) is type(value), key


@pytest.mark.parametrize("argv", FILE_DECLINED, ids=lambda a: " ".join(a))
def test_fast_reader_leaves_other_info_and_check_calls_to_typer(argv):
    assert fast.parse_file_args(argv) is None


@pytest.mark.parametrize("args", [
    ["info", "mechanisms/kim1995_direct_drive.yaml"],
    ["info", "mechanisms/kim1995_stewart.yaml", "--json"],
    ["info", "scenarios/puma560_random_ik.yaml"],
    ["info", "mechanisms/none.yaml"],
    ["check", "mechanisms/puma560.yaml", "scenarios/kim1995_direct_drive_fk.yaml"],
    ["check", "scenarios/ur5_ik.yaml", "mechanisms/none.yaml"],
])
def test_info_and_check_are_the_same_with_and_without_the_fast_reader(args):
    a, b = _run(args, ROOT, True), _run(args, ROOT, False)
    assert (a.returncode, a.stdout, a.stderr) == (b.returncode, b.stdout, b.stderr)
    assert a.stdout or a.stderr


def test_leaving_runs_atexit_handlers_and_flushes(tmp_path):
    """mechkin.cli.app.leave skips the interpreter teardown, not the atexit handlers."""
    code = ("import atexit, sys\n"
            "atexit.register(lambda: sys.stdout.write('handler ran\\n'))\n"
            "sys.argv = ['mechkin', 'info', sys.argv[1]]\n"
            "from mechkin.cli.app import main\n"
            "main()\n"
            "print('not reached')\n")
    mech = ROOT / "mechanisms" / "planar3r.yaml"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    res = subprocess.run([sys.executable, "-c", code, str(mech)], capture_output=True,
                         text=True, env=env, cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr
    assert res.stdout.endswith("handler ran\n") and "not reached" not in res.stdout
    assert "degrees of freedom" in res.stdout


def test_a_profiled_run_writes_its_profile(tmp_path):
    """Under a profiler mechkin exits as Python does, so ``python -m cProfile -o`` works."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = tmp_path / "p.out"
    res = subprocess.run([sys.executable, "-m", "cProfile", "-o", str(out), "-m", "mechkin",
                          "check", str(ROOT / "mechanisms" / "planar3r.yaml")],
                         capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr
    assert out.is_file() and out.stat().st_size > 0
