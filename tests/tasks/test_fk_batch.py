"""The fk run's batched open-chain path (tasks/fk_batch.py) against the general one.

``open_chain_derivatives`` must equal ``motion_derivatives`` field by field (bit for bit, and
the rates to 1e-12 in any case) on random motions of the bundled open chains, singular
configurations included; the vectorised classes, counts and masks must equal ``classify``'s
per-step ones; and a whole fk run through the batched path must give the same summary and CSV
columns as the same run forced through ``motion_derivatives``.
"""

from __future__ import annotations

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.differential import motion_derivatives
from mechkin.model.kinematics import forward_kinematics
from mechkin.model.singularity import classify
from mechkin.tasks import fk_batch
from mechkin.tasks.fk_batch import (
    classify_levels,
    is_open_chain,
    label_counts,
    open_chain_derivatives,
    singular_masks,
    status_values,
)
from tests.conftest import ROOT

OPEN = ["puma560", "ur5", "panda"]


def _motion(mech, m: int, seed: int):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (m, mech.n))
    q[::5, 4] = 0.0  # PUMA / UR5 wrist singularities among the samples
    q[::7, 2] = 0.0  # elbow stretched
    qd = rng.normal(size=(m, mech.n))
    qdd = rng.normal(size=(m, mech.n))
    return q, qd, qdd


@pytest.mark.parametrize("chunk", [None, 37])
@pytest.mark.parametrize("name", OPEN)
def test_open_chain_derivatives_equal_motion_derivatives(name: str, chunk, monkeypatch) -> None:
    """Field by field, bit for bit; in one piece and in chunks of 37 samples (with and
    without the axes already cached on the kinematics)."""
    if chunk is not None:
        monkeypatch.setattr(fk_batch, "RATE_CHUNK", chunk)
    mech = load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")
    assert is_open_chain(mech)
    q, qd, qdd = _motion(mech, 400, seed=len(name))
    ee = [int(mech.end_effector)]
    ref = motion_derivatives(mech, q, qd, qdd, frames=ee)
    kin = forward_kinematics(mech, q)
    if chunk is not None and name == "ur5":
        kin.axes()  # the chunks take their slice of the cached axes
    new = open_chain_derivatives(mech, kin, qd, qdd, ee)
    for f in ("q", "qd", "qdd", "twists", "accelerations", "positions", "S", "gamma",
              "closure_rate_residual", "closure_accel_residual", "frames"):
        a, b = getattr(ref, f), getattr(new, f)
        assert a.shape == b.shape, f
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12, err_msg=f)
        assert np.array_equal(a, b), f"{f}: not bit for bit"
    assert new.frame_names == ref.frame_names
    rs, ns = ref.singularity, new.singularity
    for f in ("cond_constraint", "cond_reduced"):
        assert np.array_equal(getattr(rs, f), getattr(ns, f), equal_nan=True), f
    for f in ("constraint_level", "inverse_level", "kind", "label"):
        assert getattr(rs, f).tolist() == getattr(ns, f).tolist(), f
    assert (rs.length_scale, rs.tol_singular, rs.tol_near, rs.end_effector) == (
        ns.length_scale, ns.tol_singular, ns.tol_near, ns.end_effector)
    assert np.array_equal(rs.cond_closure, ns.cond_closure)
    assert np.array_equal(rs.singular, ns.singular) and np.array_equal(rs.near, ns.near)
    # the samples reach all three levels of the reduced Jacobian (the test can fail)
    assert {"regular", "near", "singular"} <= set(ns.inverse_level.tolist()) or name == "panda"


def test_open_chain_derivatives_refuse_a_closed_chain() -> None:
    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_stewart.yaml")
    assert not is_open_chain(mech)
    with pytest.raises(ValueError, match="not an open chain"):
        open_chain_derivatives(mech, None, np.zeros((1, 6)), np.zeros((1, 6)), [])


def test_rates_against_finite_differences() -> None:
    """The end-effector twist is the time derivative of its pose along a smooth motion
    (central differences of the FK, h = 1e-5 s): an independent check of the batched rates."""
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    t = np.linspace(0.0, 1.0, 9)
    w = np.arange(1, mech.n + 1) * 0.7

    def q_of(tt):
        return np.sin(w * tt[:, None])

    h = 1e-5
    ee = [int(mech.end_effector)]
    md = open_chain_derivatives(mech, forward_kinematics(mech, q_of(t)),
                                w * np.cos(w * t[:, None]), -w * w * np.sin(w * t[:, None]), ee)
    p = [forward_kinematics(mech, q_of(t + s * h)).frames(mech, ee)[:, 0, :3, 3]
         for s in (-1, 1)]
    v_fd = (p[1] - p[0]) / (2 * h)
    np.testing.assert_allclose(md.twists[:, 0, 3:], v_fd, atol=1e-7)


def test_classify_levels_every_combination() -> None:
    levels = np.array(["regular", "near", "singular"], dtype=object)
    lc = np.repeat(levels, 3)
    li = np.tile(levels, 3)
    kind, label = classify_levels(lc, li)
    # classify's loop, typed in: the label rule of mechkin.model.singularity.classify
    assert label.tolist() == [
        "regular", "near inverse-kinematic singularity", "inverse-kinematic singularity",
        "near constraint singularity",
        "near constraint singularity; near inverse-kinematic singularity",
        "inverse-kinematic singularity; near constraint singularity",
        "constraint singularity", "constraint singularity; near inverse-kinematic singularity",
        "constraint and inverse-kinematic singularity"]
    assert [k.value for k in kind][-1] == "constraint and inverse-kinematic singularity"


def test_masks_and_counts_of_a_closed_chain_report() -> None:
    """The vectorised masks and counts equal the report's per-step properties, with
    undefined (non-finite) steps, on a closed chain's classify."""
    from mechkin.model.closure import solve_trajectory

    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_direct_drive.yaml")
    qv = np.linspace(mech.home[mech.independent], mech.home[mech.independent] + 0.4, 30)
    res = solve_trajectory(mech, qv, mech.home[mech.dependent])
    q = res.q.copy()
    q[4] = np.nan
    rep = classify(mech, q)
    singular, near = singular_masks(rep)
    assert np.array_equal(singular, rep.singular) and np.array_equal(near, rep.near)
    labels = [str(x) for x in rep.label]
    expect: dict[str, int] = {}
    for lab in labels:
        expect[lab] = expect.get(lab, 0) + 1
    assert list(label_counts(rep.label).items()) == list(expect.items())
    assert "undefined" in expect


def test_status_values() -> None:
    from mechkin.model.closure import ClosureStatus

    st = np.array([ClosureStatus.CONVERGED, ClosureStatus.SINGULAR,
                   ClosureStatus.NOT_CONVERGED, ClosureStatus.CONVERGED], dtype=object)
    vals, masks = status_values(st, ClosureStatus)
    assert vals.tolist() == [s.value for s in st]
    assert masks[ClosureStatus.CONVERGED].tolist() == [True, False, False, True]


@pytest.mark.parametrize("name", ["puma560_wave_fk", "ur5_fk"])
def test_fk_run_same_through_both_paths(name: str, monkeypatch) -> None:
    """A bundled open-chain fk run: the batched path and motion_derivatives give the same
    summary (but for the timings) and the same CSV text."""
    from mechkin.config.scenario import load_scenario
    from mechkin.io.csv_out import format_csv
    from mechkin.tasks import fk

    sc = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
    new = fk.run(sc)
    monkeypatch.setattr(fk, "is_open_chain", lambda mech: False)
    calls = []
    real = fk_batch.open_chain_derivatives
    monkeypatch.setattr(fk, "open_chain_derivatives",
                        lambda *a, **k: calls.append(1) or real(*a, **k))
    old = fk.run(sc)
    assert not calls

    def strip(s):
        return {k: v for k, v in s.items() if not k.endswith("time_s")
                and k != "time_per_step_s"}

    assert strip(new.summary) == strip(old.summary)
    assert format_csv(new.data.columns) == format_csv(old.data.columns)


def test_batched_rates_equal_per_sample_rates() -> None:
    """The batched open-chain rates and classes equal motion_derivatives run one
    configuration at a time (to 1e-12; the classes the same)."""
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    q, qd, qdd = _motion(mech, 40, seed=5)
    ee = [int(mech.end_effector)]
    new = open_chain_derivatives(mech, forward_kinematics(mech, q), qd, qdd, ee)
    for k in range(len(q)):
        one = motion_derivatives(mech, q[k:k + 1], qd[k:k + 1], qdd[k:k + 1], frames=ee)
        for f in ("qd", "qdd", "twists", "accelerations"):
            np.testing.assert_allclose(getattr(new, f)[k], getattr(one, f)[0], rtol=1e-12,
                                       atol=1e-12, err_msg=f"{f} at sample {k}")
        c_new, c_one = new.singularity.cond_reduced[k], one.singularity.cond_reduced[0]
        if c_one < 1e6:  # well conditioned: the condition number itself to 1e-12
            np.testing.assert_allclose(c_new, c_one, rtol=1e-12)
        assert new.singularity.label[k] == one.singularity.label[0]
