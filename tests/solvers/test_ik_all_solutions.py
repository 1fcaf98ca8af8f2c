"""``solutions: all``: every distinct IK solution per target (mechkin.solvers.ik.all_solutions).

Cross-checks: the PUMA 560's eight classical branches from an independent closed form typed in
here (shoulder left / right, elbow up / down, wrist flip; Paul & Zhang 1986, Corke's
``Puma560.ikine_a`` written out for the DH table of mechanisms/puma560.yaml) and an independent
D-H product; the direct-drive arm's branches of kim1995's appendix; the Stewart platform's
unique leg lengths; the ik task's summary and CSV.
"""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.closed_form.all_solutions import closed_form_all
from mechkin.solvers.closed_form.direct_drive import direct_drive_branches
from mechkin.solvers.ik.all_solutions import multistart_all

ROOT = Path(__file__).resolve().parents[2]
MECH = ROOT / "mechanisms"

# PUMA 560, standard D-H (Robotics Toolbox for Python DH.Puma560, d1 = 0.67183 m)
D1, A2, A3, D3, D4 = 0.67183, 0.4318, 0.0203, 0.15005, 0.4318
DH = [(0, 90, D1), (A2, 0, 0), (A3, -90, D3), (0, 90, D4), (0, -90, 0), (0, 0, 0)]
POS, ORI = 1e-4, 1e-3  # verification: 0.1 mm, 1 mrad


def dh_fk(q: np.ndarray, upto: int = 6) -> np.ndarray:
    """T_0_6 of the PUMA by the product of standard D-H matrices (independent of mechkin)."""
    T = np.eye(4)
    for (a, al, d), th in zip(DH[:upto], q[:upto], strict=True):
        al = np.radians(al)
        ct, st, ca, sa = np.cos(th), np.sin(th), np.cos(al), np.sin(al)
        T = T @ np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],
                          [0, sa, ca, d], [0, 0, 0, 1]])
    return T


def puma_branches(T: np.ndarray) -> np.ndarray:
    """The 8 closed-form branches (8, 6): shoulder (q1: the wrist centre offset d3 to either
    side), elbow (q3: rho cos(q3 + atan2(d4, a3)) = K, both signs), wrist flip (R_36 =
    Rz(q4) Ry(-q5) Rz(q6), both signs of q5)."""
    p = T[:3, 3]  # the wrist centre (d5 = d6 = 0, no tool)
    r = np.hypot(p[0], p[1])
    out = []
    for q1 in (np.arctan2(p[1], p[0]) + np.arcsin(D3 / r),
               np.arctan2(p[1], p[0]) + np.pi - np.arcsin(D3 / r)):
        V = p[0] * np.cos(q1) + p[1] * np.sin(q1)
        Z = p[2] - D1
        K = (V**2 + Z**2 - A2**2 - A3**2 - D4**2) / (2 * A2)
        rho = np.hypot(A3, D4)
        for sgn in (1, -1):
            q3 = -np.arctan2(D4, A3) + sgn * np.arccos(np.clip(K / rho, -1, 1))
            x = A2 + A3 * np.cos(q3) - D4 * np.sin(q3)
            y = A3 * np.sin(q3) + D4 * np.cos(q3)
            q2 = np.arctan2(Z, V) - np.arctan2(y, x)
            R36 = dh_fk(np.array([q1, q2, q3, 0, 0, 0]), 3)[:3, :3].T @ T[:3, :3]
            for ws in (1, -1):
                b = ws * np.arccos(np.clip(R36[2, 2], -1, 1))
                q4 = np.arctan2(R36[1, 2] / np.sin(b), R36[0, 2] / np.sin(b))
                q6 = np.arctan2(R36[2, 1] / np.sin(b), -R36[2, 0] / np.sin(b))
                out.append(np.array([q1, q2, q3, q4, -b, q6]))
    return np.array(out)


def wrap(d: np.ndarray) -> np.ndarray:
    return (d + np.pi) % (2 * np.pi) - np.pi


def same_set(a: np.ndarray, b: np.ndarray, tol: float = 1e-5) -> bool:
    """Whether the rows of a and b are the same set modulo 2 pi."""
    if len(a) != len(b):
        return False
    used: set[int] = set()
    for x in a:
        hit = [j for j in range(len(b)) if j not in used and np.abs(wrap(x - b[j])).max() < tol]
        if not hit:
            return False
        used.add(hit[0])
    return True


def pairwise_distinct(q: np.ndarray, tol: float = 1e-2) -> bool:
    return all(np.abs(wrap(q[i] - q[j])).max() > tol
               for i in range(len(q)) for j in range(i + 1, len(q)))


def puma(limits: bool = True):
    mech = load_mechanism(MECH / "puma560.yaml")
    if limits:
        return mech
    n = mech.n
    return dataclasses.replace(mech, lower=np.full(n, -np.pi), upper=np.full(n, np.pi))


Q_GENERIC = np.radians([20.0, 30.0, -60.0, 40.0, 50.0, 30.0])  # well inside, not singular


def test_independent_closed_form_is_right():
    """The typed closed form: 8 branches, each reproducing the pose (D-H product), distinct,
    one of them the generating joints."""
    T = dh_fk(Q_GENERIC)
    B = puma_branches(T)
    assert len(B) == 8 and pairwise_distinct(B, 0.1)
    for b in B:
        assert np.abs(dh_fk(b) - T).max() < 1e-10
    assert min(np.abs(wrap(b - Q_GENERIC)).max() for b in B) < 1e-10
    # the model's FK agrees with the D-H product
    mech = puma()
    T_m = forward_kinematics(mech, B).frames(mech, [mech.end_effector])[:, 0]
    assert np.abs(T_m - T).max() < 1e-10


def test_puma_eight_solutions_without_limits():
    """A generic pose of the PUMA (limits opened to a full turn): exactly the 8 branches."""
    mech = puma(limits=False)
    T = dh_fk(Q_GENERIC)
    sols = multistart_all(mech, T, q_v0=Q_GENERIC, seed=3)
    assert sols.count == 8
    assert same_set(sols.q_v, puma_branches(T))
    assert pairwise_distinct(sols.q_v)
    for q in sols.q_v:  # each verified by the independent D-H product
        E = dh_fk(q)
        assert np.linalg.norm(E[:3, 3] - T[:3, 3]) < POS
        c = np.clip((np.trace(T[:3, :3].T @ E[:3, :3]) - 1) / 2, -1, 1)
        assert np.arccos(c) < ORI
    assert (sols.position_error < POS).all() and (sols.orientation_error < ORI).all()
    # ordered: the guess itself first (distance 0), then by distance
    assert np.abs(wrap(sols.q_v[0] - Q_GENERIC)).max() < 1e-6
    assert np.all(np.diff(sols.distance) >= -1e-12)


def test_puma_with_limits_keeps_the_branches_within_them():
    """The bundled PUMA (q2 +-110, q3 +-135, q5 +-100 deg): exactly the branches of the
    closed form that lie within the limits (modulo 2 pi), here the shoulder-left four."""
    mech = puma()
    T = dh_fk(Q_GENERIC)
    B = puma_branches(T)
    lo, hi = mech.lower, mech.upper
    inside = []
    for b in B:
        for k in np.array(np.meshgrid(*[[-1, 0, 1]] * 6)).reshape(6, -1).T:
            c = b + 2 * np.pi * k
            if np.all((c >= lo) & (c <= hi)):
                inside.append(b)
                break
    inside = np.array(inside)
    assert len(inside) == 4
    sols = multistart_all(mech, T, q_v0=Q_GENERIC)
    assert sols.count == len(inside)
    assert same_set(sols.q_v, inside)
    assert np.all((sols.q_v >= lo - 1e-9) & (sols.q_v <= hi + 1e-9))


def test_direct_drive_count_matches_the_appendix_branches():
    """kim1995's direct-drive arm: the orientation fixes q1 (s = (-sin q1, cos q1, 0)) and q2
    (a = -u(q2)), so of the 4 branches of the appendix exactly one reproduces a full pose."""
    mech = load_mechanism(MECH / "kim1995_direct_drive.yaml")
    for dq in ([0.3, 0.2, 0.4], [-0.5, 0.4, -0.3], [1.0, -0.6, 0.2]):
        qv = mech.home[mech.independent] + np.array(dq)
        res = solve_closure(mech, qv[None], mech.home[mech.dependent][None])
        T = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[0, 0]
        from mechkin.solvers.closed_form.recognise import check_closed_form

        br = direct_drive_branches(T[None], **check_closed_form(mech, "direct_drive").params)
        n_valid = len({tuple(np.round(wrap(q), 9)) for q in br.q[0][br.valid[0]]})
        sols = closed_form_all(mech, T, "direct_drive")
        assert sols.count == n_valid == 1
        assert np.abs(wrap(sols.q_v[0] - qv)).max() < 1e-8
        # the multi-start agrees with the closed form
        ms = multistart_all(mech, T, starts=32)
        assert ms.count == 1 and np.abs(wrap(ms.q_v[0] - qv)).max() < 1e-5


def test_stewart_exactly_one():
    mech = load_mechanism(MECH / "kim1995_stewart.yaml")
    qv = mech.home[mech.independent] + 0.01 * np.arange(mech.independent.size)
    res = solve_closure(mech, qv[None], mech.home[mech.dependent][None])
    assert res.ok[0]
    T = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[0, 0]
    sols = closed_form_all(mech, T, "stewart")
    assert sols.count == 1
    assert np.abs(sols.q_v[0] - qv).max() < 1e-7


def _write_scenario(tmp: Path, body: str) -> Path:
    p = tmp / "sc.yaml"
    p.write_text(body)
    return p


def test_ik_task_solutions_all(tmp_path):
    """The ik task: summary ``solutions`` / ``n_solutions`` per target and one CSV row per
    solution with ``solution`` and ``primary`` columns; the default stays one row per target."""
    from mechkin.api import run

    T = dh_fk(Q_GENERIC)
    rows = "\n".join(f"          - {json.dumps(list(map(float, r)))}" for r in T)
    body = f"""name: puma_all
task: ik
mechanism: {MECH / 'puma560.yaml'}
units: {{length: m, angle: rad}}
ik:
  solutions: all
  initial_guess: {{q1: 0.3, q2: 0.5, q3: -1.0, q4: 0.7, q5: 0.9, q6: 0.5}}
  targets:
    - name: A
      matrix:
{rows}
outputs: {{csv: true, plots: false, mcap: false}}
"""
    rep = run(_write_scenario(tmp_path, body))
    assert rep.status == "ok"
    tgt = rep.summary["targets"][0]
    assert tgt["n_solutions"] == 4 == len(tgt["solutions"])
    qs = np.array([[s["q_v"][f"q{k}"] for k in range(1, 7)] for s in tgt["solutions"]])
    assert pairwise_distinct(qs)
    for s, q in zip(tgt["solutions"], qs, strict=True):
        assert s["position_error"] < POS and s["orientation_error"] < ORI
        assert np.linalg.norm(dh_fk(q)[:3, 3] - T[:3, 3]) < POS
    assert rep.summary["solutions"]["n_solutions"] == [4]
    out = rep.write(tmp_path / "out", plots=False)
    with open(tmp_path / "out" / "ik.csv") as fh:
        table = list(csv.DictReader(fh))
    assert [int(r["solution"]) for r in table] == [0, 1, 2, 3]
    assert sum(int(r["primary"]) for r in table) == 1
    for r, q in zip(table, qs, strict=True):
        assert abs(float(r["q1_rad"]) - q[0]) < 1e-9
    assert out is not None
    # the default: one row per target, no solutions keys
    rep1 = run(_write_scenario(tmp_path, body.replace("  solutions: all\n", "")))
    assert "solutions" not in rep1.summary and "n_solutions" not in rep1.summary["targets"][0]


def test_bad_solutions_value(tmp_path):
    from mechkin.config.scenario import load_scenario
    from mechkin.errors import ConfigError

    body = f"""name: bad
task: ik
mechanism: {MECH / 'puma560.yaml'}
ik:
  solutions: every
  random_targets: {{count: 1}}
"""
    with pytest.raises(ConfigError, match=r"sc.yaml:\d+: ik.solutions"):
        load_scenario(_write_scenario(tmp_path, body))


def _circle_angles(c1, r1, c2, r2):
    """Angles about c1 of the two intersections of circles (c1, r1) and (c2, r2)."""
    d = np.linalg.norm(c2 - c1)
    a = (r1**2 - r2**2 + d**2) / (2 * d)
    h = np.sqrt(r1**2 - a**2)
    u = (c2 - c1) / d
    pts = c1 + a * u + np.outer([h, -h], [-u[1], u[0]])
    return np.arctan2(pts[:, 1] - c1[1], pts[:, 0] - c1[0])


@pytest.mark.parametrize("open_limits", [True, False])
def test_five_bar_leg_branches(open_limits):
    """A closed chain by multi-start (assembled random starts): the five-bar's 2 x 2 leg
    branches (each motor angle from a circle intersection: A_i, l1 = 0.25 and P, l2 = 0.35);
    the bundled elbow limits (r1 < 0 < r2) keep exactly one of them."""
    mech = load_mechanism(MECH / "five_bar.yaml")
    if open_limits:
        mech = dataclasses.replace(mech, lower=np.full(mech.n, -np.pi),
                                   upper=np.full(mech.n, np.pi))
    qv = mech.home[mech.independent] + 0.1
    res = solve_closure(mech, qv[None], mech.home[mech.dependent][None])
    T = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[0, 0]
    sols = multistart_all(mech, T, weights=np.array([1, 1, 1, 0, 0, 0.0]), seed=1)
    P = T[:2, 3]
    q1 = _circle_angles(np.array([-0.1, 0.0]), 0.25, P, 0.35)
    q2 = _circle_angles(np.array([0.1, 0.0]), 0.25, P, 0.35)
    ref = np.array([[a, b] for a in q1 for b in q2])
    if open_limits:
        assert sols.count == 4 and same_set(sols.q_v, ref)
    else:
        assert sols.count == 1 and same_set(sols.q_v, qv[None])
        assert min(np.abs(wrap(r - qv)).max() for r in ref) < 1e-6
    assert (sols.position_error < POS).all()


def test_lee_exactly_one():
    """lee's spherical mechanism: the plate orientation fixes the three leg lengths (lee Eq.
    (5)-(9)), so one solution; the multi-start finds no other."""
    from mechkin.solvers.closed_form.lee_spherical import inverse_position
    from mechkin.solvers.closed_form.recognise import check_closed_form

    mech = load_mechanism(MECH / "lee_spherical_rrps.yaml")
    geom = check_closed_form(mech, "lee_spherical").geometry
    qv = mech.home[mech.independent] + np.array([0.05, -0.03, 0.02])
    res = solve_closure(mech, qv[None], mech.home[mech.dependent][None])
    T = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[0, 0]
    sols = closed_form_all(mech, T, "lee_spherical")
    assert sols.count == 1 and np.abs(sols.q_v[0] - qv).max() < 1e-8
    mu = res.q[0, [mech.joint_index(f"plate_rpy_{k}") for k in (1, 2, 3)]]
    assert np.abs(np.asarray(inverse_position(geom, mu)).reshape(3) - qv).max() < 1e-8
