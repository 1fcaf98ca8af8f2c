"""One IK kernel (and seed codebook) per mechanism object; restart rows stop at the first
converged row in every back end."""

import dataclasses

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.ik import IkOptions, kernel_for, solve_ik, solve_ik_batch
from mechkin.solvers.ik.lm import lm_batch


def _pose(mech, q):
    return forward_kinematics(mech, np.atleast_2d(q)).frames(mech, [mech.end_effector])[:, 0]


def test_kernel_and_codebook_are_built_once_per_mechanism(root):
    mech = load_mechanism(root / "mechanisms" / "puma560.yaml")
    kern = kernel_for(mech)
    assert kernel_for(mech) is kern and kernel_for(mech, mech.end_effector) is kern
    T = _pose(mech, np.radians([10, 40, -60, 20, 30, 40]))
    assert solve_ik(mech, T[0]).ok  # seedless: builds the codebook on the shared kernel
    books = dict(kern.__dict__["_codebooks"])
    assert books
    assert solve_ik(mech, T[0]).ok and solve_ik_batch(mech, np.repeat(T, 3, 0)).ok.all()
    for key, book in kern.__dict__["_codebooks"].items():
        assert books[key] is book  # reused, not rebuilt
    other = dataclasses.replace(mech)  # an equal but distinct mechanism object
    assert kernel_for(other) is not kern and kernel_for(other).mech is other


@pytest.mark.parametrize("closed", [False, True])
def test_restart_rows_stop_at_the_first_converged_row(root, lm_backend, closed):
    """Rows = several starts for one target: with stop_on_first nothing runs after (compiled,
    row by row) or beyond the iteration of (numpy, in lockstep) the first converged row; the
    rows up to it are those of the run without stop_on_first."""
    name = "kim1995_stewart" if closed else "puma560"
    mech = load_mechanism(root / "mechanisms" / f"{name}.yaml")
    kern = kernel_for(mech)
    iv, iw = mech.independent, mech.dependent
    if closed:
        q_true = mech.home[iv] + 0.05
        res = solve_closure(mech, q_true[None], mech.home[iw][None])
        assert res.ok[0]
        T = _pose(mech, res.q[0])
        starts = np.stack([q_true + 0.3, q_true + 0.01, q_true - 0.3, q_true + 0.2])
        qw = np.repeat(res.q[:, iw], 4, 0)
    else:
        q_true = np.radians([10, 40, -60, 20, 30, 40])
        T = _pose(mech, q_true)
        starts = np.stack([q_true + [2.5, -2.0, 2.0, 1.0, 0.0, 0.0],
                           q_true + 0.02, q_true + 1.0, q_true - 1.0])
        qw = np.zeros((4, 0))
    Ts, w = np.repeat(T, 4, 0), np.ones((4, 6))
    opts = IkOptions(restarts=3)
    full = lm_batch(kern, starts, qw, Ts, w, opts)
    stop = lm_batch(kern, starts, qw, Ts, w, opts, stop_on_first=True)
    f_abs = 0.5 * (1e-3 * 1e-6) ** 2
    assert (stop["f"] < f_abs).sum() >= 1
    first = int(np.flatnonzero(full["f"] < f_abs)[0])
    if lm_backend == "compiled":
        np.testing.assert_array_equal(stop["q"][: first + 1], full["q"][: first + 1])
        np.testing.assert_array_equal(stop["iters"][: first + 1], full["iters"][: first + 1])
        assert np.all(stop["iters"][first + 1:] == 0) and np.all(np.isinf(stop["f"][first + 1:]))
    else:
        assert stop["iters"].max() <= full["iters"][full["f"] < f_abs].min()
    assert stop["iters"].sum() < full["iters"].sum()
