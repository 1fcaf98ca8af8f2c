"""Sweeps: job execution (sequential, processes, Dask), lee design sweeps, task-space sweeps."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from mechkin.solvers.workspace.maps import lee_workspace
from mechkin.solvers.workspace.sweeps import (
    COND_CAP,
    design_comparison,
    dexterity,
    lee_design_sweep,
    run_jobs,
    task_space_grid,
    task_space_random,
    task_space_sweep,
)

ROOT = Path(__file__).resolve().parents[2]
PUMA = ROOT / "mechanisms" / "puma560.yaml"
DEG = math.pi / 180.0
SMALL = {"gamma_sets": {"text": [20 * DEG, 40 * DEG]}, "n_alpha": 11, "n_beta": 9,
         "gamma_sweep": (-math.pi, math.pi), "n_gamma_sweep": 13, "n_alpha_sweep": 5,
         "n_beta_sweep": 5}


def _square(x: int) -> int:
    return x * x


def test_run_jobs_keeps_order_and_reports_progress():
    seen: list[tuple[int, int]] = []
    assert run_jobs(_square, [3, 1, 2], workers=1, progress=lambda d, t: seen.append((d, t))) \
        == [9, 1, 4]
    assert seen == [(0, 3), (1, 3), (2, 3), (3, 3)]
    assert run_jobs(_square, [], workers=2) == []


def _assert_same_sweep(a, b) -> None:
    assert a.values == b.values and a.comparison == b.comparison
    for ra, rb in zip(a.records, b.records, strict=True):
        assert ra.summary == rb.summary
        for name in ra.isotropy:
            assert_array_equal(ra.isotropy[name].sigma, rb.isotropy[name].sigma)
            assert_array_equal(ra.isotropy[name].in_workspace, rb.isotropy[name].in_workspace)
        assert_array_equal(ra.gamma_range.gamma_min, rb.gamma_range.gamma_min)


def test_design_sweep_one_and_two_workers_identical():
    one = lee_design_sweep("r", [0.25, 0.5, 0.75], workers=1, **SMALL)
    two = lee_design_sweep("r", [0.25, 0.5, 0.75], workers=2, **SMALL)
    _assert_same_sweep(one, two)
    # each value equals a direct lee_workspace run with that r
    ref = lee_workspace(r=0.5, **SMALL)
    assert_array_equal(one.records[1].isotropy["text"].sigma, ref.isotropy["text"].sigma)
    assert [rec.geometry.r for rec in one.records] == [0.25, 0.5, 0.75]
    # sigma_KI at the origin does not depend on r (PAPER_NOTES closed form)
    rows = [row for row in one.comparison if row["gamma_deg"] == 20.0]
    assert len(rows) == 3
    for row in rows:
        assert row["sigma_ki_at_origin"] == pytest.approx(0.483690, abs=5e-7)
        assert 0 < row["area_fraction"] <= 1 and 0 < row["volume_fraction"] <= 1


def test_design_sweep_stroke_parameter():
    sw = lee_design_sweep("l_max", [1.6, 2.0], workers=1, r=0.75,
                          gamma_sets={"g": [30 * DEG]}, n_alpha=9, n_beta=9)
    assert [rec.geometry.l_max for rec in sw.records] == [1.6, 2.0]
    f = [row["volume_fraction"] for row in sw.comparison]
    assert f[0] < f[1]  # a longer stroke can only add workspace
    with pytest.raises(ValueError, match="l_min < l_max"):
        lee_design_sweep("l_max", [0.4], workers=1, r=0.5, gamma_sets={"g": [0.5]},
                         n_alpha=3, n_beta=3)
    rows = design_comparison("r", [0.5], [lee_workspace(r=0.5, gamma_sweep=(-1.0, 1.0),
                                                        n_gamma_sweep=5, n_alpha_sweep=3,
                                                        n_beta_sweep=3)])
    assert rows[0]["gamma_set"] == "" and 0 <= rows[0]["gamma_range_defined_fraction"] <= 1


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
@pytest.mark.filterwarnings("ignore::ResourceWarning")
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_design_sweep_on_dask_local_cluster():
    pytest.importorskip("dask")
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address="127.0.0.1:0") as cluster:
        seen: list[int] = []
        sw = lee_design_sweep("r", [0.25, 0.75], address=cluster.scheduler_address,
                              progress=lambda d, t: seen.append(d), **SMALL)
    _assert_same_sweep(sw, lee_design_sweep("r", [0.25, 0.75], workers=1, **SMALL))
    assert seen[0] == 0 and seen[-1] == 2


def test_dexterity_of_known_jacobians():
    J = np.zeros((3, 6, 6))
    J[0] = np.eye(6)
    J[1] = np.diag([1, 1, 1, 2, 2, 4.0])
    J[2] = np.diag([1, 1, 1, 1, 1, 0.0])  # singular
    d = dexterity(J)
    assert_allclose(d["isotropy"], [1.0, 0.25, 0.0])
    assert_allclose(d["isotropy_position"], [1.0, 0.5, 0.0])
    assert_allclose(d["condition_number"], [1.0, 4.0, COND_CAP])
    assert_allclose(d["manipulability"], [1.0, 16.0, 0.0])
    assert all(np.all(np.isfinite(v)) for v in d.values())


def test_pose_generators():
    T = task_space_grid([np.array([0.1, 0.2]), np.array([0.0]), np.array([1.0, 2.0, 3.0])],
                        np.eye(3))
    assert T.shape == (6, 4, 4)
    assert_allclose(T[:, 2, 3], [1, 2, 3, 1, 2, 3])
    a = task_space_random([(0, 1), (2, 2), (-1, 1)], 50, 7, None)
    b = task_space_random([(0, 1), (2, 2), (-1, 1)], 50, 7, None)
    assert_array_equal(a, b)
    R = a[:, :3, :3]
    assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    assert np.all(a[:, 1, 3] == 2.0) and np.all((a[:, 0, 3] >= 0) & (a[:, 0, 3] <= 1))


def test_task_space_sweep_puma_few_poses(monkeypatch):
    """Reachable poses from forward kinematics are reached; far ones are marked, not dropped;
    the result does not depend on the number of workers (bitwise with the lm back end pinned:
    the automatic choice depends on the work a process has done, tests/tasks/conftest.py)."""
    from mechkin.model import load_mechanism
    from mechkin.solvers.ik import accel

    monkeypatch.setenv("MECHKIN_JIT", "0")
    accel.reset_job()
    from mechkin.model.kinematics import forward_kinematics

    mech = load_mechanism(PUMA)
    rng = np.random.default_rng(3)
    q = rng.uniform(mech.lower * 0.6, mech.upper * 0.6, size=(6, mech.n))
    T_ok = forward_kinematics(mech, q).frames(mech, [mech.end_effector])[:, 0]
    T_far = T_ok[:2].copy()
    T_far[:, :3, 3] = [[2.0, 0.0, 0.5], [0.0, -3.0, 0.0]]  # beyond the reach (~0.9 m)
    T_P = np.concatenate([T_ok, T_far])
    one = task_space_sweep(PUMA, T_P, restarts=4, chunk=3, workers=1)
    two = task_space_sweep(PUMA, T_P, restarts=4, chunk=3, workers=2)
    for k in ("q_v", "status", "reachable", "isotropy", "manipulability", "condition_number"):
        assert_array_equal(getattr(one, k), getattr(two, k))
    assert one.reachable.tolist() == [True] * 6 + [False] * 2
    assert one.position_error[:6].max() < 1e-6
    assert np.all((one.isotropy[:6] > 0) & (one.isotropy[:6] <= 1))
    assert np.all(one.isotropy[6:] == 0) and np.all(one.manipulability[6:] == 0)
    # the dexterity reported is that of the Jacobian at the returned joints
    from mechkin.model.kinematics import frame_jacobian

    qs = np.zeros((6, mech.n))
    qs[:, mech.independent] = one.q_v[:6]
    J = frame_jacobian(mech, forward_kinematics(mech, qs), mech.end_effector)
    assert_allclose(dexterity(J)["manipulability"], one.manipulability[:6], rtol=1e-12)


def test_task_space_jobs_carry_the_mechanism_not_its_path(tmp_path, monkeypatch):
    """A worker without the scenario's file system: the jobs hold the mechanism spec, and
    they still run after the file is gone."""
    import shutil

    import mechkin.solvers.workspace.task_space as sw
    from mechkin.model import load_mechanism
    from mechkin.model.kinematics import forward_kinematics

    path = tmp_path / "puma_copy.yaml"
    shutil.copy(PUMA, path)
    mech = load_mechanism(path)
    q = np.zeros((2, mech.n))
    q[1, :3] = [0.3, -0.4, 0.5]
    T_P = forward_kinematics(mech, q).frames(mech, [mech.end_effector])[:, 0]
    captured = []
    real = sw.run_jobs

    def spy(fn, jobs, **kw):
        captured.extend(jobs)
        path.unlink()  # the workers' side has no such file
        import pickle

        return real(fn, [pickle.loads(pickle.dumps(j)) for j in jobs], **kw)

    monkeypatch.setattr(sw, "run_jobs", spy)
    rec = task_space_sweep(path, T_P, restarts=2, chunk=1, workers=1)
    assert len(captured) == 2
    for job in captured:
        assert not isinstance(job["mechanism"], (str, Path))
        assert str(path) not in repr(job["mechanism"])
    assert rec.reachable.all() and rec.position_error.max() < 1e-6
