"""Analytic IK of 6-DOF arms with prismatic joints and a spherical wrist, and of 5R arms with
a two-axis wrist (h4 meeting h5).

EAIK 1.2.2 and ssik 8.2.0 take revolute joints only (their D-H constructors have no joint
type), so the cross-checks are the model's tree FK at every solution (1000 random poses per
arm, the generating joints among the solutions) and numerical multi-start
(:func:`mechkin.solvers.ik.all_solutions.multistart_all`, 64 starts): every solution it finds
is in the analytic set, and the counts are equal.

Arms (standard D-H, metres and degrees; rows (type, a, alpha, d, theta)):

* ``stanford``: the Stanford arm's structure (R-R-P + spherical wrist, d1 = 0.412,
  d2 = 0.154, d6 = 0.263 m as in Spong, Hutchinson & Vidyasagar, "Robot Modeling and Control",
  Table 3.4; the stroke offset 0.3 m is ours);
* ``gantry`` (P-P-P), ``cylindrical`` (R-P-P), ``prr_par`` (a lift under two parallel
  revolute joints), ``prr_int`` (P-R-R with h2 meeting h3): constructed, each with the
  wrist (0, -90, 0), (0, 90, 0), (0, 0, d6).
"""

from __future__ import annotations

import numpy as np
import pytest

import mechkin
from mechkin.model import load_mechanism
from mechkin.model.kinematics import frame_poses
from mechkin.solvers.ik.all_solutions import multistart_all
from mechkin.solvers.ik.analytic.classify import NotDecomposable, classify
from mechkin.solvers.ik.analytic.solutions import analytic_batch
from tests.dh_arms import dh_arm_yaml

FK_TOL = 1e-10
WRIST = [("R", 0, -90, 0, 0), ("R", 0, 90, 0, 0), ("R", 0, 0, 0.1, 0)]
ARMS = {
    "stanford": [("R", 0, -90, 0.412, 0), ("R", 0, 90, 0.154, 0), ("P", 0, 0, 0.3, 0),
                 ("R", 0, -90, 0, 0), ("R", 0, 90, 0, 0), ("R", 0, 0, 0.263, 0)],
    "gantry": [("P", 0, -90, 0.5, 0), ("P", 0, -90, 0.2, -90), ("P", 0, 0, 0.1, 0)] + WRIST,
    "cylindrical": [("R", 0, 0, 0.3, 0), ("P", 0, -90, 0.2, 0), ("P", 0, 0, 0.3, 0)] + WRIST,
    "prr_par": [("P", 0, 0, 0.3, 0), ("R", 0.35, 0, 0, 0), ("R", 0.3, 90, 0, 0),
                ("R", 0, -90, 0.2, 0), ("R", 0, 90, 0, 0), ("R", 0, 0, 0.1, 0)],
    "prr_int": [("P", 0, -90, 0.3, 0), ("R", 0, 90, 0.1, 0), ("R", 0.4, 90, 0, 0),
                ("R", 0, -90, 0.3, 0), ("R", 0, 90, 0, 0), ("R", 0, 0, 0.1, 0)],
    "rpr": [("R", 0, -90, 0.4, 0), ("P", 0, 90, 0.1, 0), ("R", 0.3, -90, 0, 0)] + WRIST,
}
DESCRIPTION = {
    "stanford": "U-P-S: h1 meets h2, prismatic, spherical",
    "gantry": "P-P-P (gantry), spherical wrist",
    "cylindrical": "R-P-P (cylindrical), spherical wrist",
    "prr_par": "P-R-R, h2 || h3, spherical wrist",
    "prr_int": "P-R-R, h2 meets h3, spherical wrist",
}


def mech_yaml(name: str) -> str:
    return dh_arm_yaml(name, ARMS[name])


@pytest.fixture(scope="module")
def arms(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("prismatic_arms")
    out = {}
    for name in ARMS:
        (tmp / f"{name}.yaml").write_text(mech_yaml(name))
        out[name] = load_mechanism(tmp / f"{name}.yaml")
    return out


def _poses(mech, m, seed):
    iv = mech.independent
    q = np.random.default_rng(seed).uniform(mech.lower[iv], mech.upper[iv], (m, 6))
    return q, frame_poses(mech, q, [mech.end_effector])[:, 0]


def _dist(mech, a, b):
    """Max joint difference, revolute joints modulo 2 pi."""
    d = np.asarray(a) - np.asarray(b)
    rev = mech.s[mech.independent] == 0
    d[..., rev] = (d[..., rev] + np.pi) % (2 * np.pi) - np.pi
    return np.abs(d).max(axis=-1)


@pytest.mark.parametrize("name", list(DESCRIPTION))
def test_every_solution_exact_and_the_generating_joints_found(arms, name):
    mech = arms[name]
    assert classify(mech).description == DESCRIPTION[name]
    m = 1000
    q, T = _poses(mech, m, seed=1)
    b = analytic_batch(mech, classify(mech), T, np.zeros(6))
    ok = np.arange(8)[None] < b.count[:, None]
    assert np.all(b.count >= 1) and not np.isnan(b.q_v[ok]).any()
    T_E = frame_poses(mech, b.q_v[ok], [mech.end_effector])[:, 0]
    assert np.abs(T_E - np.repeat(T[:, None], 8, axis=1)[ok]).max() < FK_TOL
    iv = mech.independent
    assert np.all((b.q_v[ok] >= mech.lower[iv] - 1e-12) & (b.q_v[ok] <= mech.upper[iv] + 1e-12))
    assert np.all(np.nanmin(_dist(mech, b.q_v, q[:, None]), axis=1) < 1e-8)


@pytest.mark.parametrize("name", list(DESCRIPTION))
def test_solution_set_equals_numerical_multistart(arms, name):
    mech = arms[name]
    _, T = _poses(mech, 4, seed=5)
    b = analytic_batch(mech, classify(mech), T, np.zeros(6))
    for i in range(len(T)):
        found = multistart_all(mech, T[i], starts=64, seed=i).q_v
        mine = b.q_v[i, :b.count[i]]
        assert len(found) == len(mine), (name, i)
        for x in found:
            assert _dist(mech, mine, x).min() < 1e-4, (name, i, x)


def test_other_prismatic_patterns_are_refused_by_name(arms):
    with pytest.raises(NotDecomposable, match=r"prismatic joint\(s\) q2: with prismatic joints"):
        classify(arms["rpr"])


def test_auto_is_analytic_on_a_stanford_arm_and_singular_wrist_is_finite(arms):
    mech = arms["stanford"]
    q = np.array([0.4, -0.7, 0.2, 0.3, 0.0, -0.5])  # q5 = 0: wrist singular
    T = frame_poses(mech, q[None], [mech.end_effector])[0, 0]
    r = mechkin.ik(mech, T, q_v0=np.array([0.3, -0.6, 0.1, 0.9, 0.1, 0.0]))[0]
    assert r.ok and r.method == "analytic" and np.all(np.isfinite(r.q_v))
    assert r.q_v[3] == pytest.approx(0.9, abs=1e-12)  # the free q4 kept at the guess
    T_E = frame_poses(mech, r.q_v[None], [mech.end_effector])[0, 0]
    assert np.abs(T_E - T).max() < FK_TOL


# 5R arms whose last two axes meet (standard D-H rows (a, alpha, d), constructed): solved as
# the 6R spherical-wrist arm with a virtual q6 = 0 (mechkin.solvers.ik.analytic.arm5w)
ARMS5 = {"arm5_par23": [(0, 90, 0.4), (0.4, 0, 0), (0.05, 90, 0), (0, -90, 0.35), (0, 0, 0.1)],
         "arm5_gen": [(0.1, 90, 0.35), (0.4, 30, 0.05), (0.05, 90, 0), (0, -90, 0.4),
                      (0, 0, 0.1)]}


def arm5_yaml(name: str) -> str:
    return dh_arm_yaml(name, ARMS5[name])


@pytest.mark.parametrize("name", list(ARMS5))
def test_5r_with_a_two_axis_wrist_exact_and_complete(tmp_path, name):
    (tmp_path / "a.yaml").write_text(arm5_yaml(name))
    mech = load_mechanism(tmp_path / "a.yaml")
    chain = classify(mech)
    assert chain.description.startswith("5R: h4 meets h5 (two-axis wrist)")
    m = 1000
    q = np.random.default_rng(1).uniform(-np.pi, np.pi, (m, 5))
    T = frame_poses(mech, q, [mech.end_effector])[:, 0]
    b = analytic_batch(mech, chain, T, np.zeros(5))
    ok = np.arange(b.q_v.shape[1])[None] < b.count[:, None]
    assert np.all(b.count >= 1) and not np.isnan(b.q_v[ok]).any()
    T_E = frame_poses(mech, b.q_v[ok], [mech.end_effector])[:, 0]
    assert np.abs(T_E - np.repeat(T[:, None], b.q_v.shape[1], axis=1)[ok]).max() < FK_TOL
    assert np.all(np.nanmin(_dist(mech, b.q_v, q[:, None]), axis=1) < 1e-8)
    for i in range(3):
        found = multistart_all(mech, T[i], starts=64, seed=i).q_v
        mine = b.q_v[i, :b.count[i]]
        assert len(found) == len(mine)
        for x in found:
            assert _dist(mech, mine, x).min() < 1e-4
    # a pose off the arm's 5-D family: no solution (finite, status unreachable under analytic)
    T_off = T[0].copy()
    T_off[:3, :3] = T_off[:3, :3] @ np.array([[1, 0, 0], [0, 0.8, -0.6], [0, 0.6, 0.8]])
    assert analytic_batch(mech, chain, T_off[None], np.zeros(5)).count[0] == 0
    r = mechkin.ik(mech, T_off, method="analytic")[0]
    assert not r.ok and np.all(np.isfinite(r.q_v))


@pytest.mark.parametrize("name", ["stanford", "cylindrical", "arm5_gen"])
def test_auto_picks_analytic_and_solutions_all_is_complete(tmp_path, name):
    (tmp_path / "arm.yaml").write_text(arm5_yaml(name) if name in ARMS5 else mech_yaml(name))
    (tmp_path / "sc.yaml").write_text(f"""name: t_{name}
task: ik
mechanism: arm.yaml
units: {{length: m, angle: deg}}
ik:
  method: auto
  random_targets: {{count: 4, seed: 3}}
  solutions: all
  solution_starts: 64
""")
    s = mechkin.run(tmp_path / "sc.yaml").summary
    assert s["status"] == "ok" and s["methods_used"] == ["analytic"]
    assert s["solutions"]["complete"] is True and s["solutions"]["source"] == ["analytic"]
    mech = load_mechanism(tmp_path / "arm.yaml")
    for t in s["targets"]:
        q = np.array([[sol["q"][n] for n in mech.joint_names] for sol in t["solutions"]])
        T_E = frame_poses(mech, q, [mech.end_effector])[:, 0]
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = t["target"]["R"], t["target"]["xyz_m"]
        assert len(q) >= 1 and np.abs(T_E - T).max() < FK_TOL
