"""A run that overruns --max-time stops at its next safe point (between fk chunks, ik targets,
sweep chunks, DP stages), writes the rows finished so far as whole files with status
'stopped: max-time' and exits 1 (issue 28). The clock is replaced so that the time is used as
soon as the job starts: the partial shape is the same on any machine."""

from __future__ import annotations

import itertools
import json
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from mechkin.cli import shell
from mechkin.io.csv_out import read_csv
from mechkin.solvers.workspace.jobs import run_jobs
from mechkin.tasks import budget

ROOT = Path(__file__).resolve().parents[2]


def _scenario(tmp_path: Path, name: str, **section: object) -> Path:
    d = yaml.safe_load((ROOT / "scenarios" / name).read_text())
    d["mechanism"] = str((ROOT / "scenarios" / d["mechanism"]).resolve())
    sec = d["task"] if d["task"] != "ik" else "ik"
    for k, v in section.items():
        d[sec][k] = v
    d["outputs"] = {"csv": True, "plots": False, "mcap": False}
    p = tmp_path / name
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


@pytest.fixture
def time_is_up(monkeypatch):
    """The run's clock: 0 when the run starts, then 1e6 s (the limit is used at once)."""
    calls = itertools.count()
    monkeypatch.setattr(budget, "_clock", lambda: 0.0 if next(calls) == 0 else 1e6)


def _run(task: str, sc: Path, out: Path, capsys) -> tuple[int, dict, list[str]]:
    capsys.readouterr()
    code = shell.execute(task, sc, out, False, False, lambda s: s["status"], max_time="1h")
    err = capsys.readouterr().err.strip().splitlines()
    summary = json.loads((out / "summary.json").read_text())
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".")], "staging left"
    return code, summary, err


def _check_stop(summary: dict, err: list[str], sc: Path, done: int, total: int, unit: str):
    assert summary["status"] == "stopped: max-time"
    st = summary["stopped"]
    assert (st["reason"], st["done"], st["total"], st["unit"]) == ("max-time", done, total, unit)
    assert "expect" not in summary  # a part of the job proves nothing
    assert len(err) == 1 and sc.name in err[0] and "stopped" in err[0], err
    assert f"{done} of {total} {unit}" in err[0]


def test_fk_keeps_the_finished_chunks(tmp_path, time_is_up, capsys):
    sc = _scenario(tmp_path, "five_bar_fk.yaml", time={"start": 0, "stop": 2, "step": 0.0004})
    code, summary, err = _run("fk", sc, tmp_path / "o", capsys)
    assert code == 1
    _check_stop(summary, err, sc, 1000, 5001, "steps")
    assert summary["n_steps"] == 1000
    cols = read_csv(tmp_path / "o" / "fk.csv")
    assert len(cols["t_s"]) == 1000 and float(cols["t_s"][-1]) == pytest.approx(999 * 0.0004)
    assert set(cols["status"]) == {"converged"}


def test_ik_keeps_the_solved_targets(tmp_path, time_is_up, capsys):
    sc = _scenario(tmp_path, "puma560_random_ik.yaml", restarts=2)
    code, summary, err = _run("ik", sc, tmp_path / "o", capsys)
    assert code == 1
    _check_stop(summary, err, sc, 1, 50, "targets")
    assert summary["n_targets"] == 1 and len(summary["targets"]) == 1
    assert len(read_csv(tmp_path / "o" / "ik.csv")["t_s"]) == 1


def test_track_stops_between_dp_stages(tmp_path, time_is_up, capsys):
    sc = _scenario(tmp_path, "park_conveyor_torque.yaml")
    code, summary, err = _run("track", sc, tmp_path / "o", capsys)
    assert code == 1
    _check_stop(summary, err, sc, 0, 1, "plans")
    assert summary["files"] == ["summary.json"]  # no plan: no table


def test_joint_sweep_keeps_the_evaluated_chunks(tmp_path, time_is_up, capsys):
    sc = _scenario(tmp_path, "puma560_workspace.yaml", samples=3000, chunk=1000)
    code, summary, err = _run("workspace", sc, tmp_path / "o", capsys)
    assert code == 1
    _check_stop(summary, err, sc, 1000, 3000, "samples")
    assert summary["n_samples"] == 1000
    assert len(read_csv(tmp_path / "o" / "points.csv")["x_m"]) == 1000


def test_task_space_sweep_keeps_the_finished_chunks(tmp_path, time_is_up, capsys):
    sc = _scenario(tmp_path, "puma560_reachability.yaml", chunk=8, restarts=1, workers=1)
    code, summary, err = _run("workspace", sc, tmp_path / "o", capsys)
    assert code == 1
    _check_stop(summary, err, sc, 8, 121, "poses")
    assert summary["n_poses"] == 8
    assert len(read_csv(tmp_path / "o" / "task_points.csv")["x_m"]) == 8


def test_max_time_from_the_environment_stops_too(tmp_path, time_is_up, monkeypatch, capsys):
    monkeypatch.setenv("MECHKIN_MAX_TIME", "1h")
    sc = _scenario(tmp_path, "puma560_random_ik.yaml", restarts=2)
    capsys.readouterr()
    code = shell.execute("ik", sc, tmp_path / "o", False, False, lambda s: s["status"])
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert code == 1 and summary["stopped"]["done"] == 1, summary.get("stopped")


def test_a_run_within_its_time_is_not_stopped(tmp_path, capsys):
    sc = _scenario(tmp_path, "five_bar_fk.yaml")
    code, summary, err = _run("fk", sc, tmp_path / "o", capsys)
    assert code == 0 and summary["status"] == "ok" and "stopped" not in summary


def test_run_jobs_returns_the_finished_prefix_on_stop():
    asked = []

    def stop() -> bool:
        asked.append(1)
        return len(asked) >= 2

    assert run_jobs(abs, [-1, -2, -3, -4], workers=1, stop=stop) == [1, 2]
    assert run_jobs(abs, [-1, -2], workers=1, stop=lambda: False) == [1, 2]


def test_a_grid_study_keeps_the_grids_solved(tmp_path, monkeypatch, capsys):
    """The scenario's own grid solves, then the time is up: the study stops between two grids
    (never inside a study grid's DP), the plan and the grids done so far are kept."""
    from mechkin.tasks import track

    real = track._solve
    state = {"solved": 0}

    def solve_then_time_is_up(*args, **kw):
        res = real(*args, **kw)
        state["solved"] += 1
        monkeypatch.setattr(budget, "_clock", lambda: 1e6)  # used up after the first plan
        return res

    monkeypatch.setattr(budget, "_clock", lambda: 0.0)
    monkeypatch.setattr(track, "_solve", solve_then_time_is_up)
    sc = _scenario(tmp_path, "park_grid_study.yaml")
    code, summary, err = _run("track", sc, tmp_path / "o", capsys)
    assert code == 1
    st = summary["stopped"]
    assert (st["unit"], st["done"], st["total"]) == ("plans", 2, 3), st  # own grid, 30 x 50
    assert [(g["N1"], g["N2"]) for g in summary["grid_study"]] == [(30, 50), (50, 100)]
    assert summary["files"] and "track.csv" in summary["files"]


def _run_split(task: str, sc: Path, out: Path, capsys) -> tuple[int, dict, list[str]]:
    capsys.readouterr()
    code = shell.execute(task, sc, out, False, False, lambda s: s["status"], max_time="1h",
                         workers=2)
    err = capsys.readouterr().err.strip().splitlines()
    return code, json.loads((out / "summary.json").read_text()), err


def test_a_split_fk_motion_keeps_a_prefix_of_chunks():
    """solve_trajectory_chunks after a stop: run_jobs returned the first chunk only; the
    motion solved is that chunk's steps (the same rows as a whole run)."""
    from mechkin.model import load_mechanism
    from mechkin.solvers.distributed import solve_trajectory_chunks

    mech = load_mechanism(ROOT / "mechanisms" / "five_bar.yaml")
    t = np.linspace(0.0, 2.0, 5001)
    qv = np.column_stack([np.radians(135 + 15 * np.sin(np.pi * t)),
                          np.radians(45 + 15 * np.cos(np.pi * t))])
    q_w0 = mech.home[mech.dependent]
    whole, _ = solve_trajectory_chunks(mech, qv, q_w0, chunk_steps=2000,
                                       run_jobs=lambda fn, jobs, prog: [fn(j) for j in jobs])
    part, _ = solve_trajectory_chunks(mech, qv, q_w0, chunk_steps=2000,
                                      run_jobs=lambda fn, jobs, prog: [fn(jobs[0])])
    assert len(part.q) == 2000 and len(whole.q) == 5001
    np.testing.assert_allclose(part.q, whole.q[:2000], atol=1e-9)


def test_a_process_pool_stops_between_jobs():
    stop_now = []

    def stop() -> bool:
        stop_now.append(1)
        return True

    out = run_jobs(time.sleep, [0.3] * 24, workers=2, stop=stop)
    assert 1 <= len(out) < 24 and stop_now  # the jobs already handed to the pool finish


def test_a_split_ik_sequence_keeps_the_finished_chunks(tmp_path, time_is_up, capsys):
    sc = _scenario(tmp_path, "puma560_random_ik.yaml", restarts=2,
                   random_targets={"count": 200, "seed": 1})
    code, summary, err = _run_split("ik", sc, tmp_path / "o", capsys)
    st = summary["stopped"]
    assert code == 1 and st["total"] == 200 and st["unit"] == "targets", st
    assert 0 < st["done"] < 200 and st["done"] % 25 == 0, st  # whole chunks of 25 targets
    assert len(summary["targets"]) == st["done"]
