"""Every task estimates its job's time before it starts (mechkin.tasks.estimates, issue 28): the
estimates follow the job's size (their scaling laws), reach summary.json and `mechkin check`,
and on a medium job land within a factor of 5 of the time the job took on this machine (the
duration measured in the test, never a bound on wall time itself)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from mechkin.config.scenario import OutputsSpec
from mechkin.model import load_mechanism
from mechkin.tasks import estimates as est

ROOT = Path(__file__).resolve().parents[2]
OUT = OutputsSpec(csv=True, plots=False, mcap=True)


@pytest.fixture(scope="module")
def mechs():
    return {n: load_mechanism(ROOT / "mechanisms" / f"{n}.yaml")
            for n in ("puma560", "five_bar", "kim1995_stewart")}


def _job(s: float) -> float:
    return s - est.RUN_OVERHEAD_S


def test_fk_is_linear_in_steps_and_closed_chains_cost_more(mechs):
    for m in mechs.values():
        assert _job(est.fk_seconds(m, 20_000, OUT)) == pytest.approx(
            2 * _job(est.fk_seconds(m, 10_000, OUT)))
    per = {k: _job(est.fk_seconds(m, 1, OUT)) for k, m in mechs.items()}
    assert per["puma560"] < per["five_bar"] < per["kim1995_stewart"]
    no_files = OutputsSpec(csv=False, plots=False, mcap=False)
    assert est.fk_seconds(mechs["puma560"], 10_000, no_files) < est.fk_seconds(
        mechs["puma560"], 10_000, OUT)


def test_ik_is_linear_in_targets_and_grows_with_restarts_and_method(mechs):
    puma = mechs["puma560"]
    one = est.ik_seconds(puma, 100, "lm", 0, OUT)
    assert _job(est.ik_seconds(puma, 200, "lm", 0, OUT)) == pytest.approx(2 * _job(one))
    assert est.ik_seconds(puma, 100, "lm", 30, OUT) > 3 * _job(one)
    assert (est.ik_seconds(puma, 10_000, "analytic", 0, OUT)
            < est.ik_seconds(puma, 10_000, "lm", 0, OUT)
            < est.ik_seconds(puma, 10_000, "cg-golden", 0, OUT))
    assert (est.ik_seconds(mechs["kim1995_stewart"], 100, "lm", 0, OUT)
            > est.ik_seconds(mechs["five_bar"], 100, "lm", 0, OUT))


def test_sweeps_and_dp_follow_their_size(mechs):
    five = mechs["five_bar"]
    def sweep(m: int) -> float:
        return _job(est.joint_sweep_seconds(five, m)) - est.COMPILED_LOAD_S

    assert sweep(40_000) == pytest.approx(2 * sweep(20_000))
    assert est.joint_sweep_seconds(five, 10_000) > est.joint_sweep_seconds(mechs["puma560"],
                                                                           10_000)
    assert _job(est.task_space_seconds(200, 9)) == pytest.approx(3 * _job(
        est.task_space_seconds(200, 3)))
    # large grids: N1 x N2^2 transitions of the compiled stage
    big = est.dp_seconds(1000, 2000, first=False) - est.COMPILED_LOAD_S
    assert big == pytest.approx(est.DP_S_PER_TRANSITION * 1000 * 2000**2)
    assert est.dp_seconds(2000, 2000, first=False) - est.COMPILED_LOAD_S == pytest.approx(2 * big)
    assert est.dp_seconds(50, 100) < est.dp_seconds(50, 500)  # the numpy stage when small


def _env(tmp_path: Path) -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")


def test_a_medium_fk_job_is_estimated_within_a_factor_of_5(tmp_path):
    d = yaml.safe_load((ROOT / "scenarios" / "five_bar_fk.yaml").read_text())
    d["mechanism"] = str(ROOT / "mechanisms" / "five_bar.yaml")
    d["fk"]["time"] = {"start": 0, "stop": 2, "step": 2 / 7999}  # 8000 steps
    d.pop("expect")
    sc = tmp_path / "medium.yaml"
    sc.write_text(yaml.safe_dump(d))
    cmd = [sys.executable, "-m", "mechkin"]
    t0 = time.perf_counter()  # the command's start-up: `check` loads the same files
    r = subprocess.run([*cmd, "check", str(sc)], capture_output=True, text=True,
                       env=_env(tmp_path), timeout=300)
    startup = time.perf_counter() - t0
    assert r.returncode == 0 and "estimated to take about" in r.stdout, r.stdout + r.stderr
    t0 = time.perf_counter()
    r = subprocess.run([*cmd, "fk", str(sc), "--out", str(tmp_path / "o"), "--no-plots",
                        "--json"], capture_output=True, text=True, env=_env(tmp_path),
                       timeout=600)
    took = time.perf_counter() - t0 - startup
    assert r.returncode == 0, r.stderr
    estimate = json.loads(r.stdout)["estimated_time_s"]
    assert took / 5 <= estimate <= 5 * max(took, 0.5), (estimate, took)
