"""A budget for work: the largest jobs the schema accepts are refused before any work, with one
line naming the key, the estimate and how to raise the budget; nothing is written; each refusal
is quick and small. The budget is set explicitly (MECHKIN_MAX_MEMORY) so the test does not
depend on this machine's memory."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from mechkin.tasks.budget import default_limit, human, parse_size

ROOT = Path(__file__).resolve().parents[2]


def _edit(name: str, change) -> dict:
    d = yaml.safe_load((ROOT / "scenarios" / name).read_text())
    d["mechanism"] = str((ROOT / "scenarios" / d["mechanism"]).resolve()) if d.get(
        "mechanism") else None
    if d["mechanism"] is None:
        d.pop("mechanism")
    change(d)
    d.pop("expect", None)
    return d


def _fk(d):
    d["fk"]["time"] = {"start": 0.0, "stop": 9.99998, "step": 1.0e-5}  # 999,999 steps


def _ik(d):
    d["ik"]["random_targets"] = {"count": 1_000_000, "seed": 1}


def _track(d):
    d["track"]["grid"] = {"N1": 5000, "N2": 5000, "nt_fraction": 0.8}


def _sweep(d):
    d["workspace"]["samples"] = 10_000_000


def _task_space(d):
    d["workspace"]["positions"] = {k: {"range": [-0.8, 0.8], "n": 101} for k in "xyz"}


def _lee(d):
    d["workspace"]["alpha"] = {"range": [-90, 90], "n": 100_001}
    d["workspace"]["beta"] = {"range": [-90, 90], "n": 100_001}


def _workers(d):
    d["workspace"]["workers"] = 1024


CASES = {
    "fk 999999 steps": ("fk", "puma560_wave_fk.yaml", _fk, "fk"),
    "ik 1e6 targets": ("ik", "puma560_random_ik.yaml", _ik, "ik.random_targets.count"),
    "track 5000x5000": ("track", "park_conveyor_none.yaml", _track, "track.grid"),
    "joint sweep 1e7": ("workspace", "puma560_workspace.yaml", _sweep, "workspace"),
    "task space 101^3": ("workspace", "puma560_reachability.yaml", _task_space, "workspace"),
    "lee 100001^2": ("workspace", "lee_fig5_isotropy_r075.yaml", _lee, "workspace"),
    "1024 workers": ("workspace", "lee_design_sweep_r.yaml", _workers, "workspace.workers"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_oversized_job_is_refused_before_any_work(tmp_path, case):
    task, name, change, key = CASES[case]
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(_edit(name, change), sort_keys=False))
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(ROOT), MECHKIN_MAX_MEMORY="2G", MECHKIN_JIT="0",
               MPLBACKEND="Agg")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    # the run under a fresh parent whose only child it is: RUSAGE_CHILDREN's ru_maxrss of this
    # test process is the largest child it ever had (worker pools of earlier tests)
    r = subprocess.run([sys.executable, "-c", _PEAK, sys.executable, "-m", "mechkin", task,
                        str(p), "--out", str(out)],
                       capture_output=True, text=True, timeout=120, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    assert r.returncode == 2, (r.returncode, r.stderr[-500:])
    *rest, peak_line = r.stderr.strip().splitlines()
    assert peak_line.startswith("PEAK_RSS_KIB "), r.stderr[-500:]
    peak_kib = int(peak_line.split()[1])
    lines = "\n".join(rest).strip().splitlines()
    assert len(lines) == 1 and len(lines[0]) <= 300, lines
    assert "Traceback" not in r.stderr
    assert "s.yaml:" in lines[0] and key in lines[0]
    assert not out.exists()
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    assert cpu < 10.0 and wall < 60, (cpu, wall)  # refused at once (imports dominate)
    assert peak_kib < 400 * 1024, peak_kib  # peak RSS of the run [KiB]
    # mechkin check makes the same refusal (check-ok means the run will not refuse it)
    c = subprocess.run([sys.executable, "-m", "mechkin", "check", str(p)], capture_output=True,
                       text=True, timeout=120, env=env)
    assert c.returncode == 2 and key in c.stderr, c.stderr[-300:]


_PEAK = ("import resource, subprocess, sys\n"
         "r = subprocess.run(sys.argv[1:])\n"
         "peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss\n"
         "sys.stderr.write(f'\\nPEAK_RSS_KIB {peak}\\n')\n"
         "sys.exit(r.returncode)\n")


def test_budget_message_says_how_to_raise_it(tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(_edit("puma560_wave_fk.yaml", lambda d: None), sort_keys=False))
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    r = subprocess.run([sys.executable, "-m", "mechkin", "fk", str(p), "--out",
                        str(tmp_path / "o"), "--max-memory", "64K"], capture_output=True,
                       text=True, timeout=120, env=env)
    assert r.returncode == 2
    assert "--max-memory" in r.stderr and "MECHKIN_MAX_MEMORY" in r.stderr
    r = subprocess.run([sys.executable, "-m", "mechkin", "fk", str(p), "--out",
                        str(tmp_path / "o"), "--max-memory", "1G", "--no-plots"],
                       capture_output=True, text=True, timeout=300, env=env)
    assert r.returncode == 0, r.stderr


def test_sizes_parse():
    assert parse_size("8G") == 8 * 1024**3
    assert parse_size("512M") == 512 * 1024**2
    assert parse_size("1.5GiB") == int(1.5 * 1024**3)
    assert parse_size("1000") == 1000
    for bad in ("", "-1G", "1Q", "G", "nan"):
        with pytest.raises(ValueError):
            parse_size(bad)
    assert default_limit() >= 256 * 1024**2
    assert human(3 * 1024**3) == "3 GiB"
