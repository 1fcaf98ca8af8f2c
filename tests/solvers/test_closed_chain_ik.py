"""IK of closed chains (issue 24): passive limits are constraints and sequential solving never
loses a target the same defaults solve alone."""

from __future__ import annotations

import numpy as np
import pytest

import mechkin
from tests.model import closed_chain_models as M
from tests.model.test_continuation import load, random_qv

W_POS = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])  # the leg's toe position (2 actuators)


def _passive_inside(mech, q):
    from mechkin.model.continuation import within_limits

    return within_limits(mech, np.atleast_2d(q))[1]


def test_sequential_ik_solves_every_target_solved_alone(tmp_path):
    # narrow rod limits: some targets are reachable only in another knee branch
    mech, _ = load(tmp_path, M.CASSIE, **{"limits: [-90, 90]": "limits: [-60, 10]"})
    qv = random_qv(mech, 12, seed=11)
    fk = mechkin.fk(mech, qv)
    T = fk.poses["end_effector"]
    seq = mechkin.ik(mech, T, weights=W_POS, restarts=4)
    alone = [mechkin.ik(mech, T[k], weights=W_POS, restarts=4)[0] for k in range(len(T))]
    ok_alone = [r.status.value == "ok" for r in alone]
    ok_seq = [r.status.value == "ok" for r in seq]
    assert sum(ok_alone) >= 6
    assert all(s for s, a in zip(ok_seq, ok_alone, strict=True) if a)
    for r in seq + alone:  # no ok answer with a passive joint outside its limits
        if r.status.value == "ok":
            assert _passive_inside(mech, r.q)[0]
        elif r.status.value == "at a limit":
            assert r.at_limit


def test_batch_ik_never_reports_ok_outside_passive_limits(tmp_path):
    mech, _ = load(tmp_path, M.CASSIE, **{"limits: [-90, 90]": "limits: [-60, 10]"})
    qv = random_qv(mech, 16, seed=12)
    T = mechkin.fk(mech, qv).poses["end_effector"]
    res = mechkin.ik(mech, T, weights=W_POS, batch=True, restarts=3)
    for r in res:
        if r.status.value == "ok":
            assert _passive_inside(mech, r.q)[0]
        if not _passive_inside(mech, r.q)[0]:
            assert r.status.value != "ok" and r.at_limit


@pytest.mark.parametrize("name", ["xarm", "robotiq", "cassie", "slider", "watt"])
def test_sequential_ik_with_the_defaults_loses_no_target(tmp_path, name):
    # the five models (default passive limits), targets at random within-limit q_v: the same
    # defaults (no restarts given) solve every target alone, in a warm-started sequence and in a
    # batch
    text = {"xarm": M.XARM, "robotiq": M.ROBOTIQ, "cassie": M.CASSIE, "slider": M.SLIDER,
            "watt": M.WATT}[name]
    mech, _ = load(tmp_path, text)
    T = mechkin.fk(mech, random_qv(mech, 10, seed=7)).poses["end_effector"]
    alone = [mechkin.ik(mech, T[k], weights=W_POS)[0].status.value for k in range(len(T))]
    seq = [r.status.value for r in mechkin.ik(mech, T, weights=W_POS,
                                              q_v0=mech.home[mech.independent])]
    batch = [r.status.value for r in mechkin.ik(mech, T, weights=W_POS, batch=True)]
    assert alone == ["ok"] * len(T)
    assert seq == alone and batch == alone


def test_a_passive_limit_that_blocks_the_target_is_reported_at_a_limit(tmp_path):
    # the xArm gripper's finger joint limited to [0, 0.5] rad: driver 0.7 puts the pad where
    # the parallelogram needs finger_joint = 0.7 (its limit blocks it); single, sequential and
    # batch IK all say "at a limit" and name the joint (single used to say "unreachable")
    mech, _ = load(tmp_path, M.XARM, **{"[0.035465, 0.042039, 0]}, limits: [0, 0.85]":
                                         "[0.035465, 0.042039, 0]}, limits: [0, 0.5]"})
    assert mech.upper[mech.joint_index("finger_joint")] == 0.5
    fk = mechkin.fk(mech, [[0.7], [0.3]])
    assert fk.status == ["outside limits", "converged"]
    T = fk.poses["end_effector"]
    runs = {"single": mechkin.ik(mech, T[0], weights=W_POS),
            "sequence": mechkin.ik(mech, T, weights=W_POS, q_v0=[0.0]),
            "batch": mechkin.ik(mech, T, weights=W_POS, batch=True)}
    for how, res in runs.items():
        r = res[0]
        assert r.status.value == "at a limit", how
        assert "finger_joint" in r.at_limit, how
        assert r.position_error > 1e-4, how  # the target is not reached: never ok
        if len(res) > 1:
            assert res[1].status.value == "ok", how


def test_the_ik_task_names_the_passive_joint_at_its_limit_for_every_target(tmp_path):
    # mechkin ik on the xArm gripper (finger_joint limited to 0.5 rad): a target the finger
    # limit blocks, then one beyond any reach (answered with the previous joints): both name
    # finger_joint in joints_at_limit (the far one used to name none)
    load(tmp_path, M.XARM, "xarm.yaml", **{"[0.035465, 0.042039, 0]}, limits: [0, 0.85]":
                                           "[0.035465, 0.042039, 0]}, limits: [0, 0.5]"})
    mech = mechkin.load_mechanism(tmp_path / "xarm.yaml")
    p = mechkin.fk(mech, [[0.7]]).poses["end_effector"][0, :3, 3].tolist()
    sc = tmp_path / "ik.yaml"
    sc.write_text("name: xarm_ik\ntask: ik\nmechanism: xarm.yaml\n"
                  "units: {length: m, angle: rad}\nik:\n  weights: [1, 1, 1, 0, 0, 0]\n"
                  "  targets:\n"
                  f"    - {{name: blocked, xyz: [{p[0]!r}, {p[1]!r}, 0.0], "
                  "euler: {convention: XYZ, angles: [0, 0, 0]}}\n"
                  "    - {name: far, xyz: [2.0, 2.0, 0.0], euler: {convention: XYZ, "
                  "angles: [0, 0, 0]}}\n"
                  "outputs: {plots: false, mcap: false, csv: false}\n")
    rep = mechkin.run(sc)
    t = {x["name"]: x for x in rep.summary["targets"]}
    assert t["blocked"]["status"] == "at a limit" and t["far"]["status"] == "unreachable"
    for x in t.values():
        assert "finger_joint" in x["joints_at_limit"], x
    assert rep.exit_code == 1


def test_a_lone_closed_chain_target_within_the_limits_is_not_lost(tmp_path):
    # the Cassie-like leg with rod limits [-30, 30] deg: every target at a configuration whose
    # loops close within the limits is solved alone with the defaults (5 of 59 were lost: the
    # lone solve's restarts jittered about home; now a failed lone target is tried once more as
    # a one-target batch, whose restarts start from random q_v within the limits)
    mech, _ = load(tmp_path, M.CASSIE, **{"limits: [-90, 90]": "limits: [-30, 30]"})
    qv = random_qv(mech, 60, seed=3)
    fk = mechkin.fk(mech, qv)
    T = fk.poses["end_effector"]
    inside = [k for k, s in enumerate(fk.status) if s == "converged"]
    assert len(inside) >= 50
    for k in inside:
        r = mechkin.ik(mech, T[k], weights=W_POS)[0]
        assert r.status.value == "ok", (k, r.status.value)
        assert _passive_inside(mech, r.q)[0] and r.position_error <= 1e-9


def test_passive_limits_hold_on_every_route_and_the_status_is_the_targets(tmp_path):
    # the Robotiq-like four-bar with its passive joints limited to [-0.3, 0.3] rad, targets at
    # configurations beyond those limits: the batch used to return passive joints up to 0.47
    # rad outside them ("at a limit", a lower f from a restart kept over a feasible answer),
    # the lone solve up to 0.1 % of the range outside ("not converged") for the same targets
    mech, _ = load(tmp_path, M.ROBOTIQ,
                   **{"limits: [-0.872664, 0.872664]": "limits: [-0.3, 0.3]"})
    iv = mech.independent
    qv = np.linspace(mech.lower[iv] - 0.3, mech.upper[iv] + 0.3, 12)
    fk = mechkin.fk(mech, qv)
    T = fk.poses["end_effector"][[k for k, s in enumerate(fk.status)
                                  if s in ("converged", "outside limits")]]
    assert len(T) >= 8 and "outside limits" in fk.status
    batch = mechkin.ik(mech, T, weights=W_POS, batch=True, restarts=1)
    alone = [mechkin.ik(mech, Tk, weights=W_POS, restarts=1)[0] for Tk in T]
    seq = mechkin.ik(mech, T, weights=W_POS, restarts=1, q_v0=mech.home[iv])
    assert [r.status.value for r in alone] == [r.status.value for r in batch]
    assert {r.status.value for r in alone} >= {"ok", "at a limit"}
    j = mech.dependent
    for r in batch + alone + seq:
        assert r.status.value != "singular"
        x = r.q[j]
        assert np.all(x >= mech.lower[j] - 1e-9) and np.all(x <= mech.upper[j] + 1e-9), r.q
        if r.status.value == "at a limit":
            assert r.at_limit  # names the joint (the driver's or a passive one)
    assert any(set(r.at_limit) & {mech.joint_names[k] for k in j} for r in batch)


def test_cg_golden_from_a_start_beyond_a_passive_limit_returns_within_it(tmp_path):
    # cg-golden (robust) keeps passive limits in its line searches but used to return its start
    # when no step improved on it: here a start with finger_joint at 0.7 > 0.5 rad, the target
    # its own pose. The answer is on the limit (0.5), at a limit, never outside
    from mechkin.solvers.ik import IkOptions, solve_ik

    mech, _ = load(tmp_path, M.XARM, **{"[0.035465, 0.042039, 0]}, limits: [0, 0.85]":
                                         "[0.035465, 0.042039, 0]}, limits: [0, 0.5]"})
    fk = mechkin.fk(mech, [[0.7]])
    assert fk.status == ["outside limits"]
    iv, j = mech.independent, mech.dependent
    r = solve_ik(mech, fk.poses["end_effector"][0], q_v0=fk.q[0, iv], q_w0=fk.q[0, j],
                 weights=W_POS, options=IkOptions(method="cg-golden"))
    assert r.status.value == "at a limit" and "finger_joint" in r.at_limit
    assert np.all(r.q[j] <= mech.upper[j] + 1e-9) and np.all(r.q[j] >= mech.lower[j] - 1e-9)
    assert abs(r.q[mech.joint_index("finger_joint")] - 0.5) <= 1e-9
