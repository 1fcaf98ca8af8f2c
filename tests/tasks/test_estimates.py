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


def test_lee_maps_and_biped_follow_their_size():
    one = est.lee_seconds(181 * 181 * 6, 0, 0) - est.RUN_OVERHEAD_S
    assert est.lee_seconds(2 * 181 * 181 * 6, 0, 0) - est.RUN_OVERHEAD_S == pytest.approx(2 * one)
    assert est.lee_seconds(181 * 181 * 6, 0, 0, values=3) - est.RUN_OVERHEAD_S == pytest.approx(
        3 * one)  # a design sweep: the maps once per value
    assert est.lee_seconds(0, 91 * 91 * 361, 0) < est.lee_seconds(91 * 91 * 361, 0, 0)
    assert est.lee_seconds(1000, 0, 2) > est.lee_seconds(1000, 0, 0) + 2  # the PNGs
    b = est.biped_seconds(4001) - est.biped_seconds(1)
    assert b == pytest.approx(4000 * est.BIPED_FRAME_S) and 30 < b < 300  # 79 s measured


@pytest.mark.parametrize(("name", "lo", "hi"), [
    # measured 2026-12-03 at load 5 with plots: 12.4 s, 12.1 s, 8.8 s; biped 4.8 s, 4.0 s
    ("lee_design_sweep_r", 5, 30), ("lee_fig2_gamma_range_r075", 5, 30),
    ("lee_fig3_isotropy_r025", 3, 20), ("hwang2023_walk_skate_roll_unroll", 2, 10),
    ("hwang2023_fig7_a", 1.5, 10)])
def test_lee_maps_and_biped_are_estimated_by_check_and_the_run(tmp_path, name, lo, hi,
                                                                 capsys):
    """`check` prints the estimate; the run makes it before any work, so a --max-time below it
    refuses the run at once (exit 2, nothing written)."""
    from mechkin.cli import shell
    from mechkin.cli.check_files import check_file_status, run_check
    from mechkin.tasks import budget

    sc = ROOT / "scenarios" / f"{name}.yaml"
    with budget.time_budget(None) as found:
        assert check_file_status(sc) == ([], False)
    assert len(found) == 1 and lo <= found[0]["seconds"] <= hi, found
    assert run_check([sc]) == 0 and "estimated to take about" in capsys.readouterr().out
    task = "ik" if name.startswith("hwang") else "workspace"
    with pytest.raises(shell.Exit) as exc:
        shell.handle_errors(shell._execute)(task, sc, tmp_path / "o", False, False,
                                            lambda s: "", False, None, max_time="1s")
    assert exc.value.code == 2 and not (tmp_path / "o").exists()
    assert "> --max-time 1 s" in capsys.readouterr().err


def test_a_biped_run_records_its_estimate_once(tmp_path):
    from mechkin.cli import shell

    sc = ROOT / "scenarios" / "hwang2023_fig7_a.yaml"
    code = shell.execute("ik", sc, tmp_path / "o", False, False, lambda s: "")
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert code == 0 and summary["estimated_time_s"] == pytest.approx(est.biped_seconds(1),
                                                                      rel=1e-2)
