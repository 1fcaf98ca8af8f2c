"""Analytic IK by subproblem decomposition (mechkin.solvers.ik.analytic).

Cross-checks, all independent of the solver: forward kinematics of the model (the tree FK, not
the solver's product of exponentials) at every returned solution; the solution sets of EAIK
(Ostermeier et al., arXiv 2409.14815) and ssik built from the same D-H tables; random poses from
forward kinematics of random joints within the limits (the generating joints must be found).

D-H tables (standard convention, typed in with their sources):
* PUMA 560 and UR5: the bundled mechanisms (mechanisms/puma560.yaml: Robotics Toolbox for
  Python DH.Puma560; mechanisms/ur5.yaml: Universal Robots' published D-H parameters);
* ABB IRB 140: ABB product specification IRB 140 (d1 = 352, a1 = 70, a2 = 360, d4 = 380,
  d6 = 65 mm), the D-H frames of Craig-style textbooks (alpha = -90, 0, 90, -90, 90, 0 deg);
* KUKA KR 6 R900 sixx (Agilus): KUKA specification (d1 = 400, a1 = 25, a2 = 455, a3 = 35,
  d4 = 420, d6 = 80 mm), alpha = -90, 0, -90, 90, -90, 0 deg;
* Kinova Jaco (6 DOF, 60 deg wrist, non-spherical): Kinova's "Jaco 6DOF classic" D-H
  (D1 = 0.2755, D2 = 0.41, e2 = 0.0098, D4b = 0.2501, D5b = 0.0856, D6b = 0.2116 m,
  alpha = 90, 180, 90, 60, 60, 180 deg): no subproblem decomposition.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import mechkin
from mechkin.errors import ConfigError
from mechkin.model import load_mechanism
from mechkin.model.kinematics import frame_poses
from mechkin.solvers.ik.all_solutions import first_of_clusters, wrapped
from mechkin.solvers.ik.analytic.classify import NotDecomposable, classify
from mechkin.solvers.ik.analytic.solutions import analytic_batch

ROOT = Path(__file__).resolve().parents[2]
FK_TOL = 1e-10  # [m] and entries of R: every analytic solution by the model's FK
SAME = 1e-6  # [rad] two solutions are the same (modulo 2 pi)

# (a [m], alpha [deg], d [m]) per joint, limits [deg]
ARMS = {
    "abb_irb140": ([(0.070, -90, 0.352), (0.360, 0, 0), (0, 90, 0), (0, -90, 0.380),
                    (0, 90, 0), (0, 0, 0.065)],
                   [(-180, 180), (-90, 110), (-230, 50), (-200, 200), (-115, 115),
                    (-400, 400)]),
    "kuka_kr6_r900": ([(0.025, -90, 0.400), (0.455, 0, 0), (0.035, -90, 0), (0, 90, 0.420),
                       (0, -90, 0), (0, 0, 0.080)],
                      [(-170, 170), (-190, 45), (-120, 156), (-185, 185), (-120, 120),
                       (-350, 350)]),
    "jaco_offset_wrist": ([(0, 90, 0.2755), (0.41, 180, 0), (0, 90, -0.0098),
                           (0, 60, -0.2501), (0, 60, -0.0856), (0, 180, -0.2116)],
                          [(-360, 360)] * 6),
}
BUNDLED_DH = {
    "puma560": [(0, 90, 0.67183), (0.4318, 0, 0), (0.0203, -90, 0.15005), (0, 90, 0.4318),
                (0, -90, 0), (0, 0, 0)],
    "ur5": [(0, 90, 0.089159), (-0.425, 0, 0), (-0.39225, 0, 0), (0, 90, 0.10915),
            (0, -90, 0.09465), (0, 0, 0.0823)],
}


def write_arm(tmp: Path, name: str) -> Path:
    """A mechanism file of a 6R D-H arm of ARMS."""
    dh, lim = ARMS[name]
    lines = [f"name: {name}", "units: {length: m, angle: deg}", "dh_convention: standard",
             "links:", "  - name: base"]
    lines += [f"  - name: l{i + 1}" for i in range(5)]
    lines += ["  - name: l6", "    frames:", "      - {name: tool, xyz: [0, 0, 0]}", "joints:"]
    parents = ["base"] + [f"l{i + 1}" for i in range(5)]
    for i, ((a, al, d), (lo, hi)) in enumerate(zip(dh, lim, strict=True)):
        lines.append(f"  - {{name: q{i + 1}, type: revolute, parent: {parents[i]}, "
                     f"child: l{i + 1}, dh: {{a: {a}, alpha: {al}, d: {d}}}, "
                     f"limits: [{lo}, {hi}]}}")
    lines += ["independent: [q1, q2, q3, q4, q5, q6]", "end_effector: tool"]
    path = tmp / f"{name}.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def arms(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("arms")
    out = {n: load_mechanism(ROOT / "mechanisms" / f"{n}.yaml") for n in BUNDLED_DH}
    out.update({n: load_mechanism(write_arm(tmp, n)) for n in ARMS})
    return out


def dh_of(name):
    return BUNDLED_DH[name] if name in BUNDLED_DH else ARMS[name][0]


def random_poses(mech, m, seed=0):
    rng = np.random.default_rng(seed)
    iv = mech.independent
    lo = np.maximum(mech.lower[iv], -np.pi)
    hi = np.minimum(mech.upper[iv], np.pi)
    q = rng.uniform(lo, hi, size=(m, len(iv)))
    return q, frame_poses(mech, q, [mech.end_effector])[:, 0]


def within_limits_rep(mech, q):
    """Whether some q + 2 pi k (per joint) lies within the limits (test-local rule)."""
    iv = mech.independent
    lo, hi = mech.lower[iv], mech.upper[iv]
    k_lo = np.ceil((lo - q) / (2 * np.pi) - 1e-12)
    return bool(np.all(q + 2 * np.pi * k_lo <= hi + 1e-9))


def same_mod_2pi(a, b, tol=SAME):
    return bool(np.abs((a - b + np.pi) % (2 * np.pi) - np.pi).max() < tol)


DECOMPOSABLE = ["puma560", "ur5", "abb_irb140", "kuka_kr6_r900"]


@pytest.mark.parametrize("name", DECOMPOSABLE)
def test_every_solution_exact_and_the_generating_joints_found(arms, name):
    mech = arms[name]
    m = 1000
    q, T = random_poses(mech, m)
    b = analytic_batch(mech, classify(mech), T, mech.home[mech.independent])
    assert np.all(b.count >= 1)
    ok = np.arange(8)[None] < b.count[:, None]
    T_E = frame_poses(mech, b.q_v[ok], [mech.end_effector])[:, 0]
    T_ref = np.repeat(T[:, None], 8, axis=1)[ok]
    assert np.abs(T_E[:, :3, 3] - T_ref[:, :3, 3]).max() < FK_TOL
    assert np.abs(T_E[:, :3, :3] - T_ref[:, :3, :3]).max() < FK_TOL
    iv = mech.independent
    assert np.all((b.q_v[ok] >= mech.lower[iv] - 1e-12) & (b.q_v[ok] <= mech.upper[iv] + 1e-12))
    d = np.abs((b.q_v - q[:, None] + np.pi) % (2 * np.pi) - np.pi).max(axis=-1)
    assert np.all(np.nanmin(d, axis=1) < 1e-8)  # the joints that made the pose are a solution
    assert not np.isnan(b.q_v[ok]).any() and np.all(np.isinf(b.distance[~ok]))


@pytest.mark.parametrize("name", DECOMPOSABLE)
def test_solution_set_equals_eaik_within_limits(arms, name):
    from eaik.IK_DH import DhRobot

    mech = arms[name]
    dh = np.array(dh_of(name), dtype=float)
    bot = DhRobot(np.radians(dh[:, 1]), dh[:, 0], dh[:, 2])
    m = 1000
    _, T = random_poses(mech, m, seed=1)
    b = analytic_batch(mech, classify(mech), T, mech.home[mech.independent])
    for i in range(m):
        sol = bot.IK(T[i])
        theirs = [s for s, ls in zip(sol.Q, sol.is_LS, strict=True)
                  if not ls and within_limits_rep(mech, s)
                  and np.abs(bot.fwdKin(s) - T[i]).max() < 1e-8]
        mine = b.q_v[i, :b.count[i]]
        for s in theirs:  # no EAIK solution missed (or merged with one within SAME_TOL)
            assert any(same_mod_2pi(s, x, 1e-3) for x in mine), (name, i, s)
        for x in mine:  # nothing EAIK does not have
            assert any(same_mod_2pi(s, x) for s in sol.Q), (name, i, x)


@pytest.mark.parametrize("name", DECOMPOSABLE)
def test_solution_set_equals_ssik_within_limits(arms, name):
    import ssik

    mech = arms[name]
    dh = np.array(dh_of(name), dtype=float)
    man = ssik.Manipulator.from_dh(np.radians(dh[:, 1]), dh[:, 0], dh[:, 2])
    m = 60  # ssik runs in Python: ~4 ms per pose here
    _, T = random_poses(mech, m, seed=2)
    b = analytic_batch(mech, classify(mech), T, mech.home[mech.independent])
    for i in range(m):
        theirs = [s.q for s in man.solve(T[i], respect_limits=False, enumerate_windings=False)
                  if within_limits_rep(mech, s.q)]
        mine = b.q_v[i, :b.count[i]]
        for s in theirs:
            assert any(same_mod_2pi(s, x, 1e-3) for x in mine), (name, i, s)
        for x in mine:
            assert any(same_mod_2pi(s, x, 1e-8) for s in theirs), (name, i, x)


def test_classes_by_structure(arms):
    assert "spherical wrist" in classify(arms["puma560"]).description
    assert "three parallel" in classify(arms["ur5"]).description
    assert "h2 || h3" in classify(arms["kuka_kr6_r900"]).description
    with pytest.raises(NotDecomposable, match=r"axes of q4, q5, q6 miss a common point"):
        classify(arms["jaco_offset_wrist"])
    with pytest.raises(NotDecomposable, match="closed chain"):
        classify(load_mechanism(ROOT / "mechanisms" / "kim1995_stewart.yaml"))
    with pytest.raises(NotDecomposable, match="7 joints"):
        classify(load_mechanism(ROOT / "mechanisms" / "panda.yaml"))


def test_wrist_singularity_keeps_q4_at_the_guess(arms):
    """q5 = 0: q4 and q6 turn about one line; the answer keeps q4 at the guess and solves
    q4 + q6 exactly (documented in mechkin.solvers.ik.analytic.solutions)."""
    mech = arms["puma560"]
    q = np.array([0.3, -0.4, 0.5, 0.7, 0.0, -0.2])
    T = frame_poses(mech, q[None], [mech.end_effector])[0, 0]
    guess = np.array([0.2, -0.3, 0.4, 1.1, 0.1, 0.0])
    b = analytic_batch(mech, classify(mech), T[None], guess)
    sols = b.q_v[0, :b.count[0]]
    assert len(sols) >= 1 and np.all(np.isfinite(sols))
    T_E = frame_poses(mech, sols, [mech.end_effector])[:, 0]
    assert np.abs(T_E - T).max() < FK_TOL
    near = sols[0]
    assert near[3] == pytest.approx(1.1, abs=1e-12)
    assert near[3] + near[5] == pytest.approx(q[3] + q[5], abs=1e-9)
    r = mechkin.ik(mech, T, q_v0=guess)[0]
    assert r.ok and r.method == "analytic" and np.all(np.isfinite(r.q_v))


def test_shoulder_singularity_keeps_q1_at_the_guess(tmp_path):
    """Wrist centre on the first axis (an arm without shoulder offsets): q1 is free; the answer
    keeps it at the guess, finite and exact."""
    (tmp_path / "elbow.yaml").write_text("""name: elbow
units: {length: m, angle: deg}
dh_convention: standard
links: [{name: base}, {name: l1}, {name: l2}, {name: l3}, {name: l4}, {name: l5},
        {name: l6, frames: [{name: tool, xyz: [0, 0, 0]}]}]
joints:
  - {name: q1, type: revolute, parent: base, child: l1, dh: {a: 0, alpha: 90, d: 0.4}}
  - {name: q2, type: revolute, parent: l1, child: l2, dh: {a: 0.5, alpha: 0, d: 0}}
  - {name: q3, type: revolute, parent: l2, child: l3, dh: {a: 0, alpha: 90, d: 0}}
  - {name: q4, type: revolute, parent: l3, child: l4, dh: {a: 0, alpha: -90, d: 0.5}}
  - {name: q5, type: revolute, parent: l4, child: l5, dh: {a: 0, alpha: 90, d: 0}}
  - {name: q6, type: revolute, parent: l5, child: l6, dh: {a: 0, alpha: 0, d: 0.1}}
independent: [q1, q2, q3, q4, q5, q6]
end_effector: tool
""")
    mech = load_mechanism(tmp_path / "elbow.yaml")
    assert "spherical wrist" in classify(mech).description
    rng = np.random.default_rng(3)
    q = rng.uniform(-2, 2, 6)
    R = frame_poses(mech, q[None], [mech.end_effector])[0, 0, :3, :3]
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.array([0.0, 0.0, 0.9]) + 0.1 * R[:, 2]  # wrist centre on the z0 axis
    guess = np.array([0.7, 0.0, 0.0, 0.0, 0.0, 0.0])
    b = analytic_batch(mech, classify(mech), T[None], guess)
    sols = b.q_v[0, :b.count[0]]
    assert len(sols) >= 1 and np.all(np.isfinite(sols))
    T_E = frame_poses(mech, sols, [mech.end_effector])[:, 0]
    assert np.abs(T_E - T).max() < FK_TOL
    assert np.any(np.abs(sols[:, 0] - 0.7) < 1e-12)


def test_auto_is_analytic_and_sequences_stay_on_their_branch(arms):
    mech = arms["ur5"]
    q0 = np.array([0.4, -1.2, 1.3, -1.5, -1.4, 0.3])
    t = np.linspace(0.0, 1.0, 40)[:, None]
    qs = q0 + t * np.array([0.5, 0.3, -0.4, 0.6, 0.2, -0.5])
    T = frame_poses(mech, qs, [mech.end_effector])[:, 0]
    res = mechkin.ik(mech, T, q_v0=q0)
    assert all(r.ok and r.method == "analytic" for r in res)
    assert np.abs(np.array([r.q_v for r in res]) - qs).max() < 1e-9
    batch = mechkin.ik(mech, T, q_v0=q0, batch=True)
    assert all(r.ok and r.method == "analytic" for r in batch)
    lm = mechkin.ik(mech, T[:3], q_v0=q0, method="lm")
    assert all(r.method == "lm" for r in lm)


def test_auto_falls_back_to_lm_and_analytic_refuses(arms):
    mech = arms["jaco_offset_wrist"]
    q, T = random_poses(mech, 3, seed=4)
    res = mechkin.ik(mech, T, q_v0=q[0] + 0.05)
    assert all(r.method == "lm" for r in res)
    with pytest.raises(ConfigError, match=r"method: analytic: no subproblem decomposition: "
                                          r"the axes of q4, q5, q6"):
        mechkin.ik(mech, T, method="analytic")


def _scenario(tmp_path, mech_path, method, extra=""):
    p = tmp_path / f"sc_{method}.yaml"
    p.write_text(f"""name: t_{method}
task: ik
mechanism: {mech_path}
units: {{length: m, angle: deg}}
ik:
  method: {method}
  random_targets: {{count: 4, seed: 3}}
  solutions: all
  solution_starts: 64
{extra}""")
    return p


def test_task_solutions_all_complete_for_decomposable(tmp_path):
    rep = mechkin.run(_scenario(tmp_path, ROOT / "mechanisms" / "puma560.yaml", "auto"))
    s = rep.summary
    assert s["status"] == "ok" and s["methods_used"] == ["analytic"]
    assert s["solutions"]["complete"] is True and s["solutions"]["source"] == ["analytic"]
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    for t in s["targets"]:
        q = np.array([[sol["q"][n] for n in mech.joint_names] for sol in t["solutions"]])
        T_E = frame_poses(mech, q, [mech.end_effector])[:, 0]
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = t["target"]["R"], t["target"]["xyz_m"]
        assert np.abs(T_E - T).max() < FK_TOL
    json.dumps(s)


def test_task_non_decomposable_is_lm_and_not_complete(tmp_path, arms):
    path = write_arm(tmp_path, "jaco_offset_wrist")
    rep = mechkin.run(_scenario(tmp_path, path, "auto"))
    assert rep.summary["methods_used"] == ["lm"]
    assert rep.summary["solutions"]["complete"] is False
    from mechkin.cli.app import app  # noqa: F401 - the CLI maps the error to exit 2

    with pytest.raises(ConfigError, match=r"ik\.method: analytic: no subproblem decomposition"):
        mechkin.run(_scenario(tmp_path, path, "analytic"))


def test_vectorised_merge_is_the_greedy_rule(arms):
    mech = arms["puma560"]
    iv = mech.independent
    rng = np.random.default_rng(5)
    centres = rng.uniform(-3, 3, size=(6, 6))
    qv = centres[rng.integers(0, 6, 300)] + rng.normal(0, 2e-4, size=(300, 6))
    qv[::7] += 2 * np.pi  # the same solutions a turn away
    keep: list[int] = []
    for i in range(len(qv)):
        if not any(np.abs(wrapped(mech, iv, qv[i] - qv[j])).max() < 1e-3 for j in keep):
            keep.append(i)
    assert first_of_clusters(mech, iv, qv, 1e-3).tolist() == keep
    assert len(keep) == 6
    assert math.isfinite(float(qv.sum()))


SCARA = """name: scara
description: SCARA (Epson LS6-like reach 0.325 + 0.275 m, 0.2 m stroke), R-R-P-R
units: {length: m, angle: deg}
links: [{name: base}, {name: l1}, {name: l2}, {name: l3},
        {name: l4, frames: [{name: tool, xyz: [0, 0, -0.05]}]}]
joints:
  - {name: q1, type: revolute, parent: base, child: l1, origin: {xyz: [0, 0, 0.4]},
     axis: [0, 0, 1], limits: [-170, 170]}
  - {name: q2, type: revolute, parent: l1, child: l2, origin: {xyz: [0.325, 0, 0]},
     axis: [0, 0, 1], limits: [-145, 145]}
  - {name: d3, type: prismatic, parent: l2, child: l3, origin: {xyz: [0.275, 0, 0]},
     axis: [0, 0, -1], limits: [0, 0.2]}
  - {name: q4, type: revolute, parent: l3, child: l4, axis: [0, 0, 1], limits: [-360, 360]}
independent: [q1, q2, d3, q4]
end_effector: tool
"""


def test_scara_both_elbows_exact(tmp_path):
    """A 4-DOF SCARA: both elbow branches of random reachable poses, exact by the model's
    FK; the generating joints are one of them; lm from the guess lands on one of them."""
    (tmp_path / "scara.yaml").write_text(SCARA)
    mech = load_mechanism(tmp_path / "scara.yaml")
    chain = classify(mech)
    assert "SCARA" in chain.description
    rng = np.random.default_rng(6)
    iv = mech.independent
    m = 1000
    q = rng.uniform(mech.lower[iv], np.minimum(mech.upper[iv], np.pi), size=(m, 4))
    T = frame_poses(mech, q, [mech.end_effector])[:, 0]
    b = analytic_batch(mech, chain, T, mech.home[iv])
    assert np.all(b.count >= 1) and np.all(b.count <= 2)
    ok = np.arange(2)[None] < b.count[:, None]
    T_E = frame_poses(mech, b.q_v[:, :2][ok], [mech.end_effector])[:, 0]
    assert np.abs(T_E - np.repeat(T[:, None], 2, axis=1)[ok]).max() < FK_TOL
    d = np.abs(b.q_v[:, :2] - q[:, None])
    d[..., [0, 1, 3]] = (d[..., [0, 1, 3]] + np.pi) % (2 * np.pi) - np.pi
    assert np.all(np.nanmin(np.abs(d).max(axis=-1), axis=1) < 1e-9)
    # both elbows where both are within the limits: the mirror branch has q2 -> -q2
    both = b.count == 2
    assert both.mean() > 0.3
    assert np.allclose(b.q_v[both, 0, 1], -b.q_v[both, 1, 1], atol=1e-9)
    lm = mechkin.ik(mech, T[:5], q_v0=q[0], method="lm")
    for i, r in enumerate(lm):
        if r.ok:
            assert any(np.abs(wrapped(mech, iv, r.q_v - x)).max() < 1e-5
                       for x in b.q_v[i, :b.count[i]])
    tilted = T[0].copy()
    tilted[:3, :3] = tilted[:3, :3] @ np.array([[1, 0, 0], [0, 0.8, -0.6], [0, 0.6, 0.8]])
    r = mechkin.ik(mech, tilted, method="analytic")[0]
    assert r.status.value == "unreachable" and np.all(np.isfinite(r.q_v))


def test_panda_with_q7_held_equals_eaik():
    """A 7R arm (Panda, Franka's modified D-H) with its last joint held: the remaining 6R has
    a spherical joint at the base (q1, q2, q3 meet) and q5 meeting q6: every solution, equal to
    EAIK's with the same axis held (H-P form, arXiv 2409.14815), exact by the model's FK."""
    from eaik.IK_HP import HPRobot

    from mechkin.solvers.ik.analytic.api_ik import all_solutions_sampled
    from mechkin.solvers.ik.analytic.classify import held_chain, zero_config

    mech = load_mechanism(ROOT / "mechanisms" / "panda.yaml")
    iv = mech.independent
    _, H, P, M = zero_config(mech, mech.end_effector)
    offsets = np.vstack([P[0], np.diff(P, axis=0), M[:3, 3] - P[-1]])
    rng = np.random.default_rng(7)
    q = rng.uniform(mech.lower[iv], mech.upper[iv], size=(100, 7))
    T = frame_poses(mech, q, [mech.end_effector])[:, 0]
    for i in range(len(q)):
        v = float(q[i, 6])
        chain = held_chain(mech, {"q7": v})
        b = analytic_batch(mech, chain, T[i][None], mech.home[iv])
        mine = b.q_v[0, :b.count[0]]
        assert np.all(mine[:, 6] == v)
        T_E = frame_poses(mech, mine, [mech.end_effector])[:, 0]
        assert np.abs(T_E - T[i]).max() < FK_TOL
        assert any(same_mod_2pi(x, q[i], 1e-8) for x in mine)
        bot = HPRobot(H, offsets, fixed_axes=[(6, v)])
        Te = T[i].copy()
        Te[:3, :3] = T[i][:3, :3] @ M[:3, :3].T
        sol = bot.IK(Te)
        theirs = [s for s, ls in zip(sol.Q, sol.is_LS, strict=True)
                  if not ls and within_limits_rep(mech, s)]
        for s in theirs:
            assert any(same_mod_2pi(s, x, 1e-3) for x in mine), (i, s)
        for x in mine:
            assert any(same_mod_2pi(s, x, 1e-6) for s in sol.Q), (i, x)
    r = mechkin.ik(mech, T[0], q_v0=q[0] + 0.01, fixed={"q7": float(q[0, 6])},
                   method="analytic")[0]
    assert r.ok and np.abs(r.q_v - q[0]).max() < 1e-9  # the branch nearest the guess
    Q, idx = all_solutions_sampled(mech, T[1], "q7", np.linspace(-2.8, 2.8, 15))
    assert len(Q) == len(idx) > 0
    assert np.abs(frame_poses(mech, Q, [mech.end_effector])[:, 0] - T[1]).max() < FK_TOL
    with pytest.raises(ConfigError, match=r"fixed: no subproblem decomposition.*\(q1 held\)"):
        mechkin.ik(mech, T[0], fixed={"q1": 0.1})


def test_cli_analytic_on_a_non_decomposable_arm_is_one_line_exit_2(tmp_path):
    from typer.testing import CliRunner

    from mechkin.cli.app import app

    path = write_arm(tmp_path, "jaco_offset_wrist")
    sc = _scenario(tmp_path, path, "analytic")
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["ik", str(sc), "--out", str(out), "--no-plots"])
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in res.output
    assert "sc_analytic.yaml:" in lines[0] and "ik.method: analytic: no subproblem " \
        "decomposition: the axes of q4, q5, q6 miss a common point" in lines[0]
    assert not out.exists()


def test_stewart_legs_equal_the_closed_form():
    """Each U-P-S leg of kim1995's Stewart platform from the platform pose (solved like an arm:
    two meeting axes, the stroke from a quadratic, the spherical joint by SP2 + SP1): the leg
    lengths equal today's closed form (mechkin.solvers.closed_form.stewart) to 1e-12 and every
    joint, passive ones included, equals the loop-closure FK that made the pose."""
    from mechkin.model.closure import solve_closure
    from mechkin.model.kinematics import closure_residual, forward_kinematics
    from mechkin.solvers.closed_form.recognise import closed_form_ik
    from mechkin.solvers.ik.analytic.legs import platform_legs, solve_legs

    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_stewart.yaml")
    legs = platform_legs(mech)
    assert len(legs) == 6 and all("U-P-S" in leg.chain.description for leg in legs)
    iv = mech.independent
    rng = np.random.default_rng(8)
    qv = mech.home[iv] + rng.uniform(-1.5, 1.5, size=(30, 6))
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent], (30, 30)).copy())
    T = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[:, 0]
    cf, _ = closed_form_ik(mech, T, "stewart", tol=1e-4)
    assert res.ok.sum() >= 20
    for i in np.flatnonzero(res.ok):
        q, ok = solve_legs(mech, legs, T[i], mech.home)
        assert ok
        assert np.abs(q[iv] - cf[i]).max() < 1e-12
        assert np.abs(q - res.q[i]).max() < 1e-9
        phi = closure_residual(mech, forward_kinematics(mech, q[None]))
        assert np.abs(phi).max() < 1e-10
    with pytest.raises(NotDecomposable, match="legs need a platform"):
        platform_legs(load_mechanism(ROOT / "mechanisms" / "puma560.yaml"))


def test_lee_rrps_legs_equal_the_closed_form():
    """lee's spherical RRPS mechanism from the plate pose: the central spherical joint by
    Subproblems 2 and 1, the three U-P-S legs like the Stewart's: the leg lengths equal
    today's closed form (mechkin.solvers.closed_form, lee_spherical) to 1e-12."""
    from mechkin.model.closure import solve_closure
    from mechkin.model.kinematics import forward_kinematics
    from mechkin.solvers.closed_form.recognise import closed_form_ik
    from mechkin.solvers.ik.analytic.legs import platform_legs, solve_legs

    mech = load_mechanism(ROOT / "mechanisms" / "lee_spherical_rrps.yaml")
    legs = platform_legs(mech)
    assert [leg.kind for leg in legs] == ["spherical3", "chain", "chain", "chain"]
    iv = mech.independent
    rng = np.random.default_rng(13)
    m = 30
    qv = mech.home[iv] + rng.uniform(-0.2, 0.2, size=(m, len(iv)))
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent],
                                                  (m, len(mech.dependent))).copy())
    T = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[:, 0]
    cf, _ = closed_form_ik(mech, T, "lee_spherical", tol=1e-4)
    assert res.ok.sum() >= 20
    for i in np.flatnonzero(res.ok):
        q, ok = solve_legs(mech, legs, T[i], mech.home)
        assert ok
        assert np.abs(q[iv] - cf[i]).max() < 1e-12
        assert np.abs(q - res.q[i]).max() < 1e-9


def test_task_fixed_joint_of_a_7r_arm(tmp_path):
    """``ik: fixed: {q7: 20}`` (deg) on the Panda: every target solved with q7 held, complete
    solutions, each exact by FK; a held set that does not decompose is one line of bad input."""
    mech = load_mechanism(ROOT / "mechanisms" / "panda.yaml")
    iv = mech.independent
    rng = np.random.default_rng(9)
    q = rng.uniform(mech.lower[iv] * 0.8, mech.upper[iv] * 0.8, size=(3, 7))
    q[:, 6] = np.radians(20.0)
    T = frame_poses(mech, q, [mech.end_effector])[:, 0]
    rows = "\n".join(f"    - {{name: P{i}, matrix: {np.round(t, 15).tolist()}}}"
                     for i, t in enumerate(T))
    p = tmp_path / "panda_fixed.yaml"
    p.write_text(f"""name: panda_fixed
task: ik
mechanism: {ROOT / "mechanisms" / "panda.yaml"}
units: {{length: m, angle: deg}}
ik:
  method: analytic
  fixed: {{q7: 20}}
  solutions: all
  targets:
{rows}
""")
    s = mechkin.run(p).summary
    assert s["status"] == "ok" and s["methods_used"] == ["analytic"]
    assert s["solutions"]["complete"] is True
    for t in s["targets"]:
        assert t["q_v"]["q7"] == pytest.approx(np.radians(20.0), abs=1e-15)
        assert t["position_error"] < 1e-9
        assert all(sol["q"]["q7"] == pytest.approx(np.radians(20.0), abs=1e-15)
                   for sol in t["solutions"])
    p.write_text(p.read_text().replace("fixed: {q7: 20}", "fixed: {q1: 20}"))
    with pytest.raises(ConfigError, match=r"ik\.fixed: no subproblem decomposition"):
        mechkin.run(p)


ARM5 = """name: arm5
description: 5R desktop arm (Lynxmotion AL5D-like D-H), h2 || h3 || h4, wrist roll
units: {length: m, angle: deg}
dh_convention: standard
links: [{name: base}, {name: l1}, {name: l2}, {name: l3}, {name: l4},
        {name: l5, frames: [{name: tool, xyz: [0, 0, 0]}]}]
joints:
  - {name: q1, type: revolute, parent: base, child: l1, dh: {a: 0, alpha: 90, d: 0.07}}
  - {name: q2, type: revolute, parent: l1, child: l2, dh: {a: 0.146, alpha: 0, d: 0}}
  - {name: q3, type: revolute, parent: l2, child: l3, dh: {a: 0.187, alpha: 0, d: 0}}
  - {name: q4, type: revolute, parent: l3, child: l4, dh: {a: 0, alpha: 90, d: 0}}
  - {name: q5, type: revolute, parent: l4, child: l5, dh: {a: 0, alpha: 0, d: 0.1}}
independent: [q1, q2, q3, q4, q5]
end_effector: tool
"""


def test_5r_arm_every_branch_exact(tmp_path):
    (tmp_path / "arm5.yaml").write_text(ARM5)
    mech = load_mechanism(tmp_path / "arm5.yaml")
    chain = classify(mech)
    assert "5R" in chain.description
    q, T = random_poses(mech, 500, seed=10)
    b = analytic_batch(mech, chain, T, mech.home[mech.independent])
    assert np.all(b.count >= 1) and np.all(b.count <= 4)
    ok = np.arange(8)[None] < b.count[:, None]
    ok = ok[:, :b.q_v.shape[1]]
    T_E = frame_poses(mech, b.q_v[ok], [mech.end_effector])[:, 0]
    assert np.abs(T_E - np.repeat(T[:, None], ok.shape[1], axis=1)[ok]).max() < FK_TOL
    d = np.abs((b.q_v - q[:, None] + np.pi) % (2 * np.pi) - np.pi).max(axis=-1)
    assert np.all(np.nanmin(d, axis=1) < 1e-8)
    assert (b.count == 4).mean() > 0.5
    lm = mechkin.ik(mech, T[:5], q_v0=q[0], method="lm")
    for i, r in enumerate(lm):
        if r.ok:
            assert any(same_mod_2pi(r.q_v, x, 1e-5) for x in b.q_v[i, :b.count[i]])


def test_ur5_wrist_singularity_keeps_q6_at_the_guess(arms):
    """UR5 with q5 = 0 (h6 parallel to h2, h3, h4): q6 turns with q2 + q3 + q4; the answer keeps
    q6 at the guess, finite and exact by the model's FK."""
    mech = arms["ur5"]
    q = np.array([0.3, -1.2, 1.1, -0.5, 0.0, 0.4])
    T = frame_poses(mech, q[None], [mech.end_effector])[0, 0]
    guess = q + 0.05
    b = analytic_batch(mech, classify(mech), T[None], guess)
    sols = b.q_v[0, :b.count[0]]
    assert len(sols) >= 1 and np.all(np.isfinite(sols))
    assert np.abs(frame_poses(mech, sols, [mech.end_effector])[:, 0] - T).max() < FK_TOL
    singular = np.abs(np.sin(sols[:, 4])) < 1e-9  # the other shoulder branch is regular
    assert singular.any() and np.allclose(sols[singular, 5], guess[5], atol=1e-12)


def test_warmup_covers_the_analytic_signatures(tmp_path, monkeypatch):
    """``mechkin warmup`` compiles the analytic kernels with the signatures mechkin.ik and
    solutions: all use (one pose, many poses, the numpy classes' finishing)."""
    pytest.importorskip("numba")
    monkeypatch.setenv("MECHKIN_JIT", "1")
    from mechkin.solvers.ik import warm
    from mechkin.solvers.ik.analytic import finish

    (tmp_path / "open.yaml").write_text(warm.TINY_OPEN)
    names = [n for n, _ in warm.kernels_for(load_mechanism(tmp_path / "open.yaml"))]
    assert {"finish.solve_one_into", "finish.solve_finish", "finish.finish_batch"} <= set(names)
    for name in ("finish.solve_one_into", "finish.solve_finish", "finish.finish_batch"):
        warm._analytic_runner(name)()
    if not hasattr(finish.solve_one_into, "signatures"):
        pytest.skip("compiled kernels off (MECHKIN_JIT=0 at import)")
    sigs = [list(getattr(finish, f).signatures) for f in ("solve_one_into", "solve_finish")]
    mech = load_mechanism(ROOT / "mechanisms" / "puma560.yaml")
    _, T = random_poses(mech, 3)
    mechkin.ik(mech, T[0])
    analytic_batch(mech, classify(mech), T, mech.home[mech.independent])
    assert [list(getattr(finish, f).signatures) for f in ("solve_one_into",
                                                          "solve_finish")] == sigs


def test_3rrr_legs_equal_the_closed_form():
    """The planar 3-RRR from the platform pose: the leg carrying the platform (three parallel
    axes, a pose) and the two pinned legs (two parallel axes, a point) by Subproblems 3 and 1:
    the motor angles equal the closed form of tests/mechanisms/reference_closed_forms.py
    (rrr_ik) to 1e-12, every joint equals the loop-closure FK that made the pose."""
    from mechkin.model.closure import solve_closure
    from mechkin.model.kinematics import forward_kinematics
    from mechkin.solvers.ik.analytic.legs import platform_legs, solve_legs
    from tests.mechanisms import reference_closed_forms as ref

    mech = load_mechanism(ROOT / "mechanisms" / "planar_3rrr.yaml")
    legs = platform_legs(mech)
    assert [leg.kind for leg in legs] == ["planar3", "point2r", "point2r"]
    iv = mech.independent
    rng = np.random.default_rng(11)
    m = 40
    qv = mech.home[iv] + rng.uniform(-0.15, 0.15, size=(m, 3))
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent],
                                                  (m, len(mech.dependent))).copy())
    T = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[:, 0]
    assert res.ok.sum() >= 30
    for i in np.flatnonzero(res.ok):
        q, ok = solve_legs(mech, legs, T[i], mech.home)
        assert ok
        x = np.array([T[i][0, 3], T[i][1, 3], np.arctan2(T[i][1, 0], T[i][0, 0])])
        assert np.abs(same_mod := (q[iv] - ref.rrr_ik(x)[0] + np.pi) % (2 * np.pi) - np.pi
                      ).max() < 1e-12, same_mod
        assert np.abs(q - res.q[i]).max() < 1e-9


def test_delta_legs_equal_the_closed_form():
    """The Delta's R-U-U legs from the platform pose (the elbow on a sphere about the wrist:
    Subproblem 3; the forearm by Subproblem 2 about the elbow; the wrist by Subproblem 1): the
    motor angles equal the closed form of tests/mechanisms/reference_closed_forms.py
    (delta_ik) to 1e-12, every joint equals the loop-closure FK that made the pose."""
    from mechkin.model.closure import solve_closure
    from mechkin.model.kinematics import forward_kinematics
    from mechkin.solvers.ik.analytic.legs import platform_legs, solve_legs
    from tests.mechanisms import reference_closed_forms as ref

    mech = load_mechanism(ROOT / "mechanisms" / "delta.yaml")
    legs = platform_legs(mech)
    assert [leg.kind for leg in legs] == ["uu"] * 3
    iv = mech.independent
    rng = np.random.default_rng(12)
    m = 40
    qv = mech.home[iv] + rng.uniform(-0.2, 0.2, size=(m, 3))
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent],
                                                  (m, len(mech.dependent))).copy())
    T = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[:, 0]
    assert res.ok.sum() >= 30
    for i in np.flatnonzero(res.ok):
        q, ok = solve_legs(mech, legs, T[i], mech.home)
        assert ok
        assert np.abs(q[iv] - ref.delta_ik(T[i][:3, 3])[0]).max() < 1e-12
        assert np.abs(q - res.q[i]).max() < 1e-9


@pytest.mark.parametrize("name", ["kim1995_stewart", "delta", "planar_3rrr",
                                  "lee_spherical_rrps"])
def test_auto_solves_parallel_mechanisms_by_their_legs(name):
    """``mechkin.ik`` (method auto) on a parallel mechanism whose legs decompose: the legs'
    branches nearest the guess, verified by the model's FK and loop closure; the joints that
    made the pose (loop-closure FK from nearby actuated joints) come back to 1e-9."""
    from mechkin.model.closure import solve_closure
    from mechkin.model.kinematics import forward_kinematics

    mech = load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")
    iv = mech.independent
    rng = np.random.default_rng(14)
    qv = mech.home[iv] + rng.uniform(-0.1, 0.1, size=(6, len(iv)))
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent],
                                                  (6, len(mech.dependent))).copy())
    T = forward_kinematics(mech, res.q).frames(mech, [mech.end_effector])[:, 0]
    rs = mechkin.ik(mech, T[res.ok])
    assert len(rs) >= 4
    for r, q in zip(rs, res.q[res.ok], strict=True):
        assert r.ok and r.method == "analytic legs"
        assert np.abs(r.q - q).max() < 1e-9


@pytest.mark.parametrize("name", ["delta", "planar_3rrr"])
def test_task_solutions_all_of_a_parallel_mechanism_by_its_legs(tmp_path, name):
    """``solutions: all`` on a parallel mechanism whose legs decompose: every combination of
    the legs' branches within the limits, verified (FK, loop closure), ``complete: true``;
    multi-start lm from 64 starts finds no solution outside that list."""
    from mechkin.model.closure import solve_closure
    from mechkin.model.kinematics import forward_kinematics
    from mechkin.solvers.ik.all_solutions import multistart_all

    mech = load_mechanism(ROOT / "mechanisms" / f"{name}.yaml")
    iv = mech.independent
    qv = mech.home[iv] + np.random.default_rng(15).uniform(-0.1, 0.1, size=(3, len(iv)))
    res = solve_closure(mech, qv, np.broadcast_to(mech.home[mech.dependent],
                                                  (3, len(mech.dependent))).copy())
    T_all = forward_kinematics(mech, res.q[res.ok]).frames(mech, [mech.end_effector])[:, 0]
    rows = "\n".join(f"    - {{name: P{i}, matrix: {np.round(t, 15).tolist()}}}"
                     for i, t in enumerate(T_all))
    sc = tmp_path / "legs_all.yaml"
    sc.write_text(f"""name: legs_all
task: ik
mechanism: {ROOT / "mechanisms" / f"{name}.yaml"}
units: {{length: m, angle: deg}}
ik:
  solutions: all
  solution_starts: 64
  targets:
{rows}
""")
    s = mechkin.run(sc).summary
    assert s["status"] == "ok" and s["methods_used"] == ["analytic legs"]
    assert s["solutions"]["complete"] is True
    assert s["solutions"]["source"] == ["analytic legs"]
    for t in s["targets"]:
        assert t["n_solutions"] >= 1
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = t["target"]["R"], t["target"]["xyz_m"]
        mine = np.array([[sol["q_v"][n] for n in mech.independent_names]
                         for sol in t["solutions"]])
        ms = multistart_all(mech, T, starts=64, seed=1)
        for x in ms.q_v:
            assert any(same_mod_2pi(x, y, 1e-3) for y in mine), (t["name"], x)
