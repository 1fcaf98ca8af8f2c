"""Closed chains assemble where the robot is (issue 24): continuation from home, passive limits.

Five models after published geometry (tests/model/closed_chain_models.py) against their closed
forms (circle intersections on the home assembly's side): for 100 random within-limit q_v each,
the API's batched fk, the single-row fk and the fk task (a table of big, unordered steps) give
the assembly connected to home within 1e-10, or a status saying why not.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import mechkin
from mechkin.model import load_mechanism
from mechkin.model.closure import ClosureStatus
from mechkin.model.continuation import continue_closure, home_assembly, solve_motion
from tests.model import closed_chain_models as M

ATOL = 1e-10

# the closed form's branch of each home assembly (the side of the home values in the YAML)
MODELS = {
    "xarm_gripper": (M.XARM, M.xarm_closed_form),
    "robotiq_fourbar": (M.ROBOTIQ, M.robotiq_closed_form),
    "cassie_leg": (M.CASSIE, lambda q: M.cassie_closed_form(q, -1.0)),
    "slider_crank": (M.SLIDER, M.slider_closed_form),
    "watt_six_bar": (M.WATT, lambda q: M.watt_closed_form(q, -1.0, -1.0)),
}


def load(tmp_path: Path, text: str, name: str = "m.yaml", **replace: str):
    for a, b in replace.items():
        text = text.replace(a, b)
    p = tmp_path / name
    p.write_text(text)
    return load_mechanism(p), p


def random_qv(mech, n=100, seed=0):
    iv = mech.independent
    lo = np.where(np.isfinite(mech.lower[iv]), mech.lower[iv], -np.pi)
    hi = np.where(np.isfinite(mech.upper[iv]), mech.upper[iv], np.pi)
    return np.random.default_rng(seed).uniform(lo, hi, (n, len(iv)))


def joint_error(q, ref):
    return np.abs(M.wrap(q - ref)).max()


@pytest.mark.parametrize("name", list(MODELS))
def test_api_fk_gives_the_assembly_connected_to_home(tmp_path, name):
    text, closed_form = MODELS[name]
    mech, _ = load(tmp_path, text)
    qv = random_qv(mech)
    res = mechkin.fk(mech, qv)
    ref = closed_form(qv)
    assert res.status == ["converged"] * len(qv)
    assert res.within_limits == [True] * len(qv) and res.assembly_from == "home"
    assert joint_error(res.q, ref) <= ATOL
    for k in range(3):  # one row at a time: the same rows
        one = mechkin.fk(mech, qv[k])
        assert one.status == ["converged"] and joint_error(one.q, ref[k:k + 1]) <= ATOL


@pytest.mark.parametrize("name", ["robotiq_fourbar", "watt_six_bar", "cassie_leg"])
def test_motion_of_big_unordered_steps_stays_on_the_home_assembly(tmp_path, name):
    text, closed_form = MODELS[name]
    mech, _ = load(tmp_path, text)
    qv = random_qv(mech, 40, seed=3)
    res = solve_motion(mech, qv)
    assert all(s is ClosureStatus.CONVERGED for s in res.status)
    assert joint_error(res.q, closed_form(qv)) <= ATOL


def test_fk_task_on_a_table_of_random_configurations(tmp_path):
    mech, mpath = load(tmp_path, M.WATT, "watt.yaml")
    qv = random_qv(mech, 30, seed=5)
    sc = tmp_path / "fk.yaml"
    sc.write_text(
        "name: watt_random\ntask: fk\nmechanism: watt.yaml\nunits: {length: m, angle: deg}\n"
        "fk:\n  table:\n    t: " + json.dumps(list(range(30))) + "\n    crank_joint: "
        + json.dumps(np.degrees(qv[:, 0]).tolist()) + "\n")
    rep = mechkin.run(sc)
    assert rep.summary["status"] == "ok" and rep.summary["assembly_start"] == "home"
    q = rep.data.q if hasattr(rep.data, "q") else None
    last = np.array(list(rep.summary["final"]["q"].values()))
    assert joint_error(last[None], M.watt_closed_form(qv[-1:], -1.0, -1.0)) <= ATOL
    if q is not None:
        assert joint_error(np.asarray(q), M.watt_closed_form(qv, -1.0, -1.0)) <= ATOL


def test_a_path_beyond_a_fold_stops_with_a_constraint_singularity(tmp_path):
    # the slider drives: its stroke ends at the dead centres x = sqrt((l + r)^2 - e^2)
    mech, _ = load(tmp_path, M.SLIDER, **{"independent: [crank_joint]": "independent: [slide]",
                                           "limits: [0.14, 0.26]": "limits: [0.1, 0.3]"})
    h = home_assembly(mech)
    assert h.ok[0]
    x_max = np.sqrt(0.25**2 - 0.01**2)
    r = continue_closure(mech, np.array([[x_max + 0.01], [x_max - 0.01]]), h.q[0])
    assert r.status[0] is ClosureStatus.CONSTRAINT_SINGULAR
    assert abs(r.q[0, mech.joint_index("slide")] - x_max) < 1e-4  # stopped at the fold
    assert r.status[1] is ClosureStatus.CONVERGED
    res = mechkin.fk(mech, [[x_max + 0.01]])
    assert res.status == ["constraint singularity"]


def test_no_result_reports_converged_with_a_passive_joint_outside_its_limits(tmp_path):
    # narrower passive limits than the motion needs: some rows must come out "outside limits"
    cases = [
        (M.SLIDER, {"limits: [0.14, 0.26], home: 0.24": "limits: [0.17, 0.23], home: 0.196",
                    "home: 30}": "home: 90}", "home: -30": "home: -101.5"}),
        (M.ROBOTIQ, {"limits: [-0.872664, 0.872664]": "limits: [-0.3, 0.3]"}),
        (M.CASSIE, {"limits: [-90, 90]": "limits: [-90, 5]"}),
    ]
    for i, (text, rep) in enumerate(cases):
        mech, _ = load(tmp_path, text, f"m{i}.yaml", **rep)
        qv = random_qv(mech, 100, seed=i)
        for res in (mechkin.fk(mech, qv), ):
            conv = np.array([s == "converged" for s in res.status])
            out = np.array([s == "outside limits" for s in res.status])
            iw = mech.dependent
            q = res.q[:, iw]
            inside = np.all((q >= mech.lower[iw] - 1e-9) & (q <= mech.upper[iw] + 1e-9), axis=1)
            assert inside[conv].all()
            assert out.any() and not inside[out].any()
            assert res.within_limits == inside.tolist()
        mo = solve_motion(mech, qv[:25])
        from mechkin.model.continuation import with_limits

        mo = with_limits(mech, mo)
        q = mo.q[:, mech.dependent]
        inside = np.all((q >= mech.lower[mech.dependent] - 1e-9)
                        & (q <= mech.upper[mech.dependent] + 1e-9), axis=1)
        assert inside[mo.ok].all()


def test_fk_task_reports_outside_limits_and_fails(tmp_path):
    mech, _ = load(tmp_path, M.ROBOTIQ, "rq.yaml",
                   **{"limits: [-0.872664, 0.872664]": "limits: [-0.3, 0.3]"})
    sc = tmp_path / "fk.yaml"
    sc.write_text("name: rq\ntask: fk\nmechanism: rq.yaml\nunits: {length: m, angle: rad}\n"
                  "fk:\n  time: {start: 0, stop: 1, step: 0.05}\n  motion:\n"
                  "    driver_joint: {type: ramp, from: 0, to: 0.8}\n")
    rep = mechkin.run(sc)
    ref = M.robotiq_closed_form(np.linspace(0, 0.8, 21))
    outside = np.abs(ref[:, 2]) > 0.3
    assert outside.any() and not outside.all()
    assert rep.summary["steps"]["outside limits"] == int(outside.sum())
    assert rep.summary["steps"]["converged"] == int((~outside).sum())
    assert rep.summary["status"] == "outside limits" and rep.exit_code == 1
    assert "follower_joint" in rep.summary["joints_outside_limits"]


def test_step_to_step_newton_that_jumps_branch_is_caught(tmp_path):
    # the Watt six-bar's crank turning by 0.3 rad a sample: plain Newton from the first-order
    # predictor jumps to the other second-loop mode within a turn (kim1995 §5.1 step to step)
    mech, _ = load(tmp_path, M.WATT)
    qv = (np.arange(60) * 0.3)[:, None]
    res = solve_motion(mech, qv)
    assert all(s is ClosureStatus.CONVERGED for s in res.status)
    assert joint_error(res.q, M.watt_closed_form(qv, -1.0, -1.0)) <= ATOL


def test_bad_and_far_rows_are_answered_not_hung(tmp_path):
    mech, _ = load(tmp_path, M.SLIDER)
    with pytest.raises(mechkin.ConfigError, match="q_v: row 0 is not finite"):
        mechkin.fk(mech, [[np.nan]])
    res = mechkin.fk(mech, [[1e6], [1e300], [0.5]])  # paths longer than 100 rad: refused
    assert res.status == ["not converged", "not converged", "converged"]
