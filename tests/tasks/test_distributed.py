"""Every long job on workers gives the single-process result (issue 16 item 6).

For each job kind (ik batches and sequential chunks, warm-started ik chains, joint sweeps,
single lee maps, track grid studies, long closed-chain fk) the run on ``--workers 2`` local
processes and on a Dask LocalCluster (two in-process workers bound to 127.0.0.1, dashboard
on a free 127.0.0.1 port, stopped by the fixture) is compared with the run in one process:
bitwise where every job solves from the same start as the single run, to the solver's
tolerance where a chunk starts from its own warm-up (warm-started ik chains, fk chunks).
Progress bars: forced on, captured from stderr; off when stderr is not a terminal.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from mechkin.tasks import run
from mechkin.tasks.common import load_task_scenario
from mechkin.tasks.distributed import Execution, current, execution

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "scenarios"
MECH = ROOT / "mechanisms"

# summary keys that measure time or the executor, not the result
VOLATILE = {"solve_time_s", "median_time_per_target_s", "compute_time_s", "time_s",
            "execution", "rates_time_s", "time_per_step_s"}


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    # in-process workers on TCP sockets bound to 127.0.0.1 (jobs pickled over the wire); the
    # dashboard on a free port of 127.0.0.1 (None still binds its HTTP server to 8787)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  protocol="tcp://", host="127.0.0.1",
                                  dashboard_address="127.0.0.1:0") as c:
        yield c


def _strip(obj):
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if k not in VOLATILE}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    return obj


def _same_arrays(a, b, names=None):
    """Fields of two records that differ (bitwise, NaN equal to NaN)."""
    bad = []
    for f in dataclasses.fields(a):
        if names is not None and f.name not in names:
            continue
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            same = (np.array_equal(x, y) if x.dtype == object
                    else x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True))
        elif isinstance(x, dict):
            same = x.keys() == y.keys() and all(
                not _same_arrays(x[k], y[k]) if dataclasses.is_dataclass(x[k])
                else np.array_equal(x[k], y[k]) for k in x)
        elif dataclasses.is_dataclass(x):
            same = not _same_arrays(x, y)
        elif isinstance(x, float) and math.isnan(x):
            same = isinstance(y, float) and math.isnan(y)
        else:
            same = x == y
        if not same:
            bad.append(f.name)
    return bad


def _write(tmp_path: Path, name: str, doc: dict) -> Path:
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    return p


def _runs(path: Path, task: str, cluster, **kw):
    """(single process, --workers 2, --scheduler) reports of one scenario."""
    sc = load_task_scenario(path, task)
    one = run(sc, **kw)
    with execution(workers=2):
        two = run(sc, **kw)
    with execution(scheduler=cluster.scheduler_address):
        dask = run(sc, **kw)
    return one, two, dask


def _copy(name: str, tmp_path: Path, edit) -> Path:
    d = yaml.safe_load((SCEN / name).read_text())
    d["mechanism"] = str((SCEN / d["mechanism"]).resolve())
    edit(d)
    return _write(tmp_path, d["name"], d)


# --------------------------------------------------------------------------- options


def test_execution_context_is_scoped_and_checked():
    assert current() == Execution()
    with execution(workers=2, progress=True) as ex:
        assert current() is ex and ex.split and ex.n_workers() == 2
    assert current() == Execution() and not Execution(workers=1).split
    from mechkin.errors import ConfigError

    with pytest.raises(ConfigError, match="--workers: 100000 worker processes"), \
            execution(workers=100_000):
        pass


# --------------------------------------------------------------------------- ik


@pytest.fixture
def small_chunks(monkeypatch):
    from mechkin.tasks import ik_solve

    monkeypatch.setattr(ik_solve, "SEQUENCE_MIN_CHUNK", 6)


def _puma_random(tmp_path: Path, count: int, seed: int, **kw) -> Path:
    return _copy("puma560_random_ik.yaml", tmp_path, lambda d: (d["ik"].update(
        random_targets={"count": count, "seed": seed}, **kw), d.update(expect=[])))


def test_ik_independent_targets_bitwise(tmp_path, cluster, small_chunks):
    one, two, dask = _runs(_puma_random(tmp_path, 12, 4), "ik", cluster)
    assert one.summary["counts"]["ok"] >= 10
    assert "execution" not in one.summary
    assert two.summary["execution"]["jobs"] >= 2 and two.summary["execution"]["workers"] == 2
    assert dask.summary["execution"]["executor"] == "dask"
    for other in (two, dask):
        assert _strip(other.summary) == _strip(one.summary)
        np.testing.assert_array_equal(other.data.q, one.data.q)


def test_ik_batch_chunks_bitwise(tmp_path, cluster, monkeypatch):
    from mechkin.tasks import ik_solve

    monkeypatch.setattr(ik_solve, "BATCH_CHUNK", 8)  # 3 jobs (in one process too)
    one, two, dask = _runs(_puma_random(tmp_path, 24, 2, batch=True, restarts=3), "ik",
                           cluster)
    assert two.summary["execution"]["jobs"] == 3
    for other in (two, dask):
        assert _strip(other.summary) == _strip(one.summary)
        np.testing.assert_array_equal(other.data.q, one.data.q)


def _puma_line(tmp_path: Path, n: int) -> Path:
    """A warm-started chain: n PUMA 560 flange poses along a smooth joint path (FK of the
    model, so every pose is reachable), matrices typed into the scenario."""
    from mechkin.model import load_mechanism
    from mechkin.model.kinematics import forward_kinematics

    mech = load_mechanism(MECH / "puma560.yaml")
    s = np.linspace(0.0, 1.0, n)[:, None]
    q = mech.home[None] + s * np.array([0.6, -0.4, 0.5, 0.3, -0.5, 0.4])[None]
    T = forward_kinematics(mech, q).frames(mech, [mech.end_effector])[:, 0]
    doc = {"name": "puma_chain", "task": "ik", "mechanism": str(MECH / "puma560.yaml"),
           "units": {"length": "m", "angle": "rad"},
           "ik": {"method": "lm", "warm_start": True, "restarts": 2,
                  "targets": [{"name": f"P{i}", "matrix": T[i].tolist()} for i in range(n)]}}
    return _write(tmp_path, "puma_chain", doc)


def test_ik_warm_chain_within_tolerance(tmp_path, cluster, small_chunks):
    one, two, dask = _runs(_puma_line(tmp_path, 18), "ik", cluster)
    assert one.summary["counts"] == {"ok": 18}
    for other in (two, dask):
        ex = other.summary["execution"]
        assert ex["jobs"] >= 2 and ex["overlap"] == 8
        assert other.summary["counts"] == one.summary["counts"]
        # the same branch; joints within the ik tolerance scale (1e-6 m / rad)
        np.testing.assert_allclose(other.data.q, one.data.q, atol=1e-6, rtol=0)
        assert other.summary["max_position_error"] < 1e-6


# --------------------------------------------------------------------------- workspace


@pytest.mark.parametrize("name,edit", [
    # closed: continuation subtrees on a grid, then evaluation blocks of 100
    ("five_bar_workspace.yaml", lambda d: d["workspace"].update(chunk=100)),
    ("five_bar_workspace.yaml", lambda d: d["workspace"].update(
        method="monte_carlo", samples=400, seed=3, chunk=100, joints={
            "q1": {"range": [115, 155]}, "q2": {"range": [25, 65]}})),  # KD-tree tree
    ("five_bar_workspace.yaml", lambda d: d["workspace"].update(chunk=50, seed_from="home")),
    ("puma560_workspace.yaml", lambda d: d["workspace"].update(samples=600, chunk=100)),
])
def test_joint_sweep_bitwise(tmp_path, cluster, name, edit):
    p = _copy(name, tmp_path, edit)
    one, two, dask = _runs(p, "workspace", cluster)
    assert two.summary["execution"]["workers"] == 2
    for other in (two, dask):
        assert _strip(other.summary) == _strip(one.summary)
        assert _same_arrays(one.data.record, other.data.record) == []


def test_single_lee_map_bitwise(tmp_path, cluster):
    def coarse(d):
        ws = d["workspace"]
        for ax in ("alpha", "beta"):
            ws[ax]["n"] = 31
        ws["gamma_range"] = {"range": [-60, 60], "n": 41, "n_alpha": 15, "n_beta": 15}
        d["expect"] = []

    p = _copy("lee_fig4_isotropy_r050.yaml", tmp_path, coarse)
    one, two, dask = _runs(p, "workspace", cluster, progress=False)
    n_maps = len(one.summary["isotropy"]) + 1
    assert two.summary["execution"]["jobs"] == n_maps
    for other in (two, dask):
        assert _strip(other.summary) == _strip(one.summary)
        # key order of summary.json too
        assert [k for k in other.summary if k != "execution"] == list(one.summary)
        assert _same_arrays(one.data.record, other.data.record) == []


def test_lee_maps_on_a_cluster_stop_at_max_time_with_the_maps_finished_in_a_row(
        tmp_path, cluster, monkeypatch, capsys):
    """--max-time used as soon as the jobs start: on the cluster the maps after the first one
    finished are cancelled, those before it waited for, and the maps finished in a row are
    written; exit 1 and one line, never a traceback."""
    import itertools
    import json

    from mechkin.cli import shell
    from mechkin.tasks import budget

    def coarse(d):
        ws = d["workspace"]
        ws["alpha"]["n"] = ws["beta"]["n"] = 61
        ws["isotropy_maps"] = {f"s{k}": [20 + k] for k in range(12)}
        d["expect"] = []

    p = _copy("lee_fig4_isotropy_r050.yaml", tmp_path, coarse)
    calls = itertools.count()
    monkeypatch.setattr(budget, "_clock", lambda: 0.0 if next(calls) == 0 else 1e6)
    out = tmp_path / "o"
    capsys.readouterr()
    code = shell.execute("workspace", p, out, False, False, lambda s: s["status"],
                         max_time="1h", scheduler=cluster.scheduler_address)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1, err
    st = json.loads((out / "summary.json").read_text())["stopped"]
    assert (st["unit"], st["total"]) == ("maps", 12) and 1 <= st["done"] < 12, st
    assert f"{st['done']} of 12 maps" in err[0]


# --------------------------------------------------------------------------- track


def test_track_grid_study_bitwise(tmp_path, cluster):
    p = _copy("park_grid_study.yaml", tmp_path, lambda d: None)
    one, two, dask = _runs(p, "track", cluster)
    assert len(one.summary["grid_study"]) == 3
    for other in (two, dask):
        assert _strip(other.summary) == _strip(one.summary)
        for a, b in zip(one.data.study, other.data.study, strict=True):
            np.testing.assert_array_equal(a.r, b.r)
            np.testing.assert_array_equal(a.rd, b.rd)


# --------------------------------------------------------------------------- fk


def test_long_closed_chain_fk_chunks(tmp_path, cluster, monkeypatch):
    from mechkin.tasks import fk

    monkeypatch.setattr(fk, "SPLIT_MIN_STEPS", 300)  # 2001 steps: chunks of 500
    p = _copy("five_bar_fk.yaml", tmp_path, lambda d: (
        d["fk"]["time"].update(step=0.001), d.update(expect=[])))
    one, two, dask = _runs(p, "fk", cluster)
    assert one.summary["n_steps"] == 2001 and one.summary["status"] == "ok"
    for other in (two, dask):
        assert other.summary["steps"] == one.summary["steps"]
        # the same assembly mode; joints equal to the closure tolerance (1e-12)
        np.testing.assert_allclose(other.data.q, one.data.q, atol=1e-10, rtol=0)


def test_fk_chunks_follow_the_assembly_mode_of_a_single_run(monkeypatch):
    """Chunks whose coarse warm start lands on another branch are repaired: the five-bar
    started elbow-down in every chunk but the first still follows the first chunk's mode."""
    from mechkin.model import load_mechanism
    from mechkin.model.closure import solve_trajectory
    from mechkin.solvers.distributed import solve_trajectory_chunks
    from mechkin.solvers.workspace.sweeps import run_jobs

    mech = load_mechanism(MECH / "five_bar.yaml")
    t = np.linspace(0.0, 2.0, 1200)
    qv = np.column_stack([np.radians(135 + 15 * np.sin(np.pi * t)),
                          np.radians(45 + 15 * np.cos(np.pi * t))])
    q_w0 = mech.home[mech.dependent]
    ref = solve_trajectory(mech, qv, q_w0)
    res, info = solve_trajectory_chunks(
        mech, qv, q_w0, chunk_steps=300,
        run_jobs=lambda fn, jobs, prog: run_jobs(fn, jobs, workers=1, progress=prog))
    assert info["chunks"] == 4 and info["repaired_chunks"] == []
    np.testing.assert_allclose(res.q, ref.q, atol=1e-10, rtol=0)
    import mechkin.solvers.distributed as d

    # a chunk whose warm start lands on another assembly mode is detected at the seam and
    # solved again from the previous chunk's end
    real = d.trajectory_job

    from mechkin.solvers.assembly import assembly_modes

    def elsewhere(job):  # start the chunk on the assembly mode farthest from its warm start
        if job["skip"]:
            modes = assembly_modes(mech, job["q_v"][0], q_w0=job["q_w0"], starts=16)
            far = modes.q[np.argmax(modes.distance)][mech.dependent]
            job = {**job, "q_w0": far}
        return real(job)

    monkeypatch.setattr(d, "trajectory_job", elsewhere)
    res2, info2 = solve_trajectory_chunks(
        mech, qv, q_w0, chunk_steps=300,
        run_jobs=lambda fn, jobs, prog: run_jobs(fn, jobs, workers=1, progress=prog))
    assert info2["repaired_chunks"]
    np.testing.assert_allclose(res2.q, ref.q, atol=1e-10, rtol=0)


# --------------------------------------------------------------------------- progress


def test_progress_bars_forced_on(tmp_path, capsys, small_chunks, cluster):
    with execution(scheduler=cluster.scheduler_address, progress=True):
        run(load_task_scenario(_puma_random(tmp_path, 12, 4), "ik"))
    err = capsys.readouterr().err
    assert "ik: 12 targets" in err and "2/2" in err
    g = _copy("park_grid_study.yaml", tmp_path, lambda d: None)
    with execution(progress=True):
        run(load_task_scenario(g, "track"))
    err = capsys.readouterr().err
    assert "track: grid study (2 grids)" in err and "2/2" in err
    js = _copy("five_bar_workspace.yaml", tmp_path, lambda d: d["workspace"].update(chunk=100))
    with execution(scheduler=cluster.scheduler_address, progress=True):
        run(load_task_scenario(js, "workspace"), progress=None)
    err = capsys.readouterr().err
    assert "five_bar_workspace: jobs" in err
    fk_p = _copy("five_bar_fk.yaml", tmp_path, lambda d: (
        d["fk"]["time"].update(step=0.001), d.update(expect=[])))
    from mechkin.tasks import fk

    with execution(scheduler=cluster.scheduler_address, progress=True):
        fk.SPLIT_MIN_STEPS, old = 300, fk.SPLIT_MIN_STEPS
        try:
            run(load_task_scenario(fk_p, "fk"))
        finally:
            fk.SPLIT_MIN_STEPS = old
    err = capsys.readouterr().err
    assert "fk: 2001 steps in chunks" in err


def test_progress_off_when_stderr_is_not_a_terminal(tmp_path, capsys, cluster):
    g = _copy("park_grid_study.yaml", tmp_path, lambda d: None)
    run(load_task_scenario(g, "track"))
    js = _copy("five_bar_workspace.yaml", tmp_path, lambda d: d["workspace"].update(chunk=100))
    with execution(scheduler=cluster.scheduler_address):
        run(load_task_scenario(js, "workspace"), progress=None)
    assert capsys.readouterr().err == ""


@pytest.mark.slow
def test_cli_workers_and_scheduler(tmp_path, cluster, small_chunks):
    """`mechkin ik --workers 2` and `--scheduler`: same ik.csv as one process."""
    from typer.testing import CliRunner

    from mechkin.cli.app import app

    p = _puma_random(tmp_path, 12, 5)
    outs = []
    for extra in ([], ["--workers", "2"], ["--scheduler", cluster.scheduler_address]):
        out = tmp_path / f"o{len(outs)}"
        res = CliRunner().invoke(app, ["ik", str(p), "-o", str(out), "--no-plots", "--json",
                                       *extra])
        assert res.exit_code == 0, res.output
        outs.append(out)
    ref = (outs[0] / "ik.csv").read_text()
    for o in outs[1:]:
        assert (o / "ik.csv").read_text() == ref
        s = json.loads((o / "summary.json").read_text())
        assert s["execution"]["jobs"] >= 2
