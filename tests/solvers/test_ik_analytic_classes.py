"""IK-Geo subproblems 5 and 6 and the 6R classes that need them (mechkin.solvers.ik.analytic).

Subproblems: random instances built from known angles; every returned solution satisfies the
equation, and the generating angles are among them.

Arms: the D-H tables below are constructed (standard convention, metres and degrees) so that
each sits in exactly one of EAIK's kinematic classes (Ostermeier, Külz & Althoff, RA-L 2025,
arXiv 2409.14815; the class names are those EAIK 1.2.2 reports, asserted below):

* ``sph_general``: spherical wrist, h1..h3 neither parallel nor meeting
  (6R-SPHERICAL_NO_PARALLEL_NO_INTERSECTING; IK-Geo's Subproblem 5);
* ``sph_par12``: spherical wrist, h1 || h2 (6R-SPHERICAL_FIRST_TWO_PARALLEL);
* ``sph_int23``: spherical wrist, h2 meets h3 (6R-SPHERICAL_SECOND_TWO_INTERSECTING);
* ``par_general``: the UR5's D-H with a5 = 0.03 m, alpha5 = -90 deg, so h5 and h6 are skew
  (6R-THREE_INNER_PARALLEL; IK-Geo's Subproblem 6);
* ``base_general``: the first three axes meet (a spherical joint at the base), the rest
  general (reversed chain: Subproblem 5);
* ``par_base``: h3 || h4 || h5, h1 and h2 skew (reversed chain: Subproblem 6).

Cross-checks independent of the solver: the model's tree FK at every solution; EAIK's solution
sets (1000 poses per arm); ssik's (60 poses; ssik runs in Python; on ``sph_par12`` ssik 8.2.0
dispatches to its IK-Geo spherical solver and returns no solution at all, and on
``base_general`` it takes seconds per pose, so those two are checked against EAIK only).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechkin
from mechkin.model import load_mechanism
from mechkin.model.kinematics import frame_poses
from mechkin.solvers.ik.analytic.classify import classify
from mechkin.solvers.ik.analytic.solutions import analytic_batch
from mechkin.solvers.ik.analytic.subproblems56 import quartic_roots_pm1, sp5, sp6
from tests.dh_arms import dh_arm_yaml

FK_TOL = 1e-10  # [m] and entries of R
NEAR_SINGULAR = 1e-3  # [rad] |sin q5| below which a pose counts as near the wrist singularity

# (a [m], alpha [deg], d [m]) per joint
NEW = {
    "sph_general": [(0.1, 90, 0.35), (0.4, 30, 0.05), (0.05, 90, 0), (0, -90, 0.4),
                    (0, 90, 0), (0, 0, 0.1)],
    "sph_par12": [(0.3, 0, 0.4), (0.25, 90, 0.0), (0.05, -90, 0.1), (0, 90, 0.3),
                  (0, -90, 0), (0, 0, 0.08)],
    "sph_int23": [(0.1, 60, 0.4), (0, 90, 0.1), (0.3, 90, 0.05), (0, -90, 0.35),
                  (0, 90, 0), (0, 0, 0.08)],
    "par_general": [(0, 90, 0.089159), (-0.425, 0, 0), (-0.39225, 0, 0), (0, 90, 0.10915),
                    (0.03, -90, 0.09465), (0, 0, 0.0823)],
    "base_general": [(0, 90, 0.3), (0, -90, 0), (0.3, 30, 0.1), (0.25, 90, 0.05),
                     (0.1, -60, 0.02), (0, 0, 0.08)],
    "par_base": [(0.1, 90, 0.3), (0.05, -60, 0.1), (0.4, 0, 0), (0.35, 0, 0), (0, 90, 0.1),
                 (0, 0, 0.08)],
}
EAIK_FAMILY = {
    "sph_general": "6R-SPHERICAL_NO_PARALLEL_NO_INTERSECTING",
    "sph_par12": "6R-SPHERICAL_FIRST_TWO_PARALLEL",
    "sph_int23": "6R-SPHERICAL_SECOND_TWO_INTERSECTING",
    "par_general": "6R-THREE_INNER_PARALLEL",
    "base_general": "6R-SPHERICAL_NO_PARALLEL_NO_INTERSECTING",
    "par_base": "6R-THREE_INNER_PARALLEL",
}
DESCRIPTION = {
    "sph_general": "spherical wrist, h1..h3 neither parallel nor meeting (Subproblem 5)",
    "sph_par12": "spherical wrist, h1 || h2",
    "sph_int23": "spherical wrist, h2 meets h3",
    "par_general": "three parallel axes h2 || h3 || h4, h5 and h6 skew (Subproblem 6)",
    "base_general": "spherical wrist, h1..h3 neither parallel nor meeting (Subproblem 5) "
                    "(reversed chain: at the base)",
    "par_base": "three parallel axes h2 || h3 || h4, h5 and h6 skew (Subproblem 6) "
                "(reversed chain: at the base)",
}


def mech_yaml(name: str, limits: tuple[float, float] = (-180, 180)) -> str:
    return dh_arm_yaml(name, NEW[name], limits)


@pytest.fixture(scope="module")
def arms(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("new_arms")
    out = {}
    for name in NEW:
        (tmp / f"{name}.yaml").write_text(mech_yaml(name))
        out[name] = load_mechanism(tmp / f"{name}.yaml")
    return out


def rot(k, t):
    k = np.asarray(k, float)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(t) * K + (1 - math.cos(t)) * K @ K


def wrapped(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def tup(v):
    return tuple(float(x) for x in v)


def test_quartic_roots_in_the_interval_also_degenerate_and_double():
    out = np.empty(8)
    # (t - 0.5)(t + 0.25)(t - 0.9)(t - 3): three roots in [-1, 1]
    c = np.polynomial.polynomial.polyfromroots([0.5, -0.25, 0.9, 3.0])
    n = quartic_roots_pm1(c, out)
    np.testing.assert_allclose(out[:n], [-0.25, 0.5, 0.9], atol=1e-14)
    # leading coefficients zero: 2 t - 1
    n = quartic_roots_pm1(np.array([-1.0, 2.0, 0.0, 0.0, 0.0]), out)
    assert n == 1 and out[0] == pytest.approx(0.5, abs=1e-15)
    # a double root (tangency) at 0.3 and a simple one at -0.7: found whether round-off
    # splits it into two close roots, or lifts it off zero (then the critical point is kept)
    c = np.polynomial.polynomial.polyfromroots([0.3, 0.3, -0.7, 5.0])
    for lift in (0.0, -1e-13, 1e-13):
        n = quartic_roots_pm1(c + np.array([lift, 0, 0, 0, 0]), out)
        assert 2 <= n <= 3 and out[0] == pytest.approx(-0.7, abs=1e-12)
        np.testing.assert_allclose(out[1:n], 0.3, atol=1e-6)
    # lifted clearly off zero: only -0.7
    n = quartic_roots_pm1(c + np.array([-1e-6, 0, 0, 0, 0]), out)
    assert n == 1 and out[0] == pytest.approx(-0.7, abs=1e-6)
    # no real root: t^2 + 1
    assert quartic_roots_pm1(np.array([1.0, 0.0, 1.0, 0.0, 0.0]), out) == 0


def test_sp5_random_instances_exact_and_complete():
    rng = np.random.default_rng(7)
    out = np.empty((8, 3))
    worst, missed = 0.0, 0
    for _ in range(500):
        k1, k2, k3 = (v / np.linalg.norm(v) for v in rng.normal(size=(3, 3)))
        p1, p2, p3 = rng.normal(size=(3, 3))
        t = rng.uniform(-np.pi, np.pi, 3)
        p0 = rot(k2, t[1]) @ (p2 + rot(k3, t[2]) @ p3) - rot(k1, t[0]) @ p1
        n = sp5(tup(p0), tup(p1), tup(p2), tup(p3), tup(k1), tup(k2), tup(k3), 0.0, 0.0, 0.0,
                out)
        assert 1 <= n <= 8 and np.all(np.isfinite(out[:n]))
        for a, b, c in out[:n]:
            res = p0 + rot(k1, a) @ p1 - rot(k2, b) @ (p2 + rot(k3, c) @ p3)
            worst = max(worst, float(np.abs(res).max()))
        missed += not any(np.abs(wrapped(s - t)).max() < 1e-6 for s in out[:n])
    assert worst < 1e-10
    assert missed == 0


def test_sp5_degenerate_circle_keeps_the_default():
    """p1 on k1: theta1 is free (a continuum); the answer keeps the default, finite."""
    k1 = np.array([0.0, 0.0, 1.0])
    k2 = np.array([1.0, 0.0, 0.0])
    k3 = np.array([0.0, 1.0, 0.0])
    p1 = 0.4 * k1
    p2, p3 = np.array([0.1, 0.2, 0.3]), np.array([0.3, 0.0, 0.5])
    t2, t3 = 0.7, -0.4
    p0 = rot(k2, t2) @ (p2 + rot(k3, t3) @ p3) - p1
    out = np.empty((8, 3))
    n = sp5(tup(p0), tup(p1), tup(p2), tup(p3), tup(k1), tup(k2), tup(k3), 0.25, 0.0, 0.0,
            out)
    assert n >= 1 and np.all(np.isfinite(out[:n]))
    assert np.all(out[:n, 0] == 0.25)
    assert any(abs(wrapped(b - t2)) < 1e-9 and abs(wrapped(c - t3)) < 1e-9
               for _, b, c in out[:n])


def test_sp6_random_instances_exact_and_complete():
    rng = np.random.default_rng(8)
    out = np.empty((8, 2))
    worst, missed = 0.0, 0
    for _ in range(500):
        H = [v / np.linalg.norm(v) for v in rng.normal(size=(4, 3))]
        K = [v / np.linalg.norm(v) for v in rng.normal(size=(4, 3))]
        P = rng.normal(size=(4, 3))
        t = rng.uniform(-np.pi, np.pi, 2)
        d1 = H[0] @ rot(K[0], t[0]) @ P[0] + H[1] @ rot(K[1], t[1]) @ P[1]
        d2 = H[2] @ rot(K[2], t[0]) @ P[2] + H[3] @ rot(K[3], t[1]) @ P[3]
        n = sp6(*map(tup, H), *map(tup, K), *map(tup, P), d1, d2, 0.0, 0.0, out)
        assert 1 <= n <= 8 and np.all(np.isfinite(out[:n]))
        for a, b in out[:n]:
            e1 = H[0] @ rot(K[0], a) @ P[0] + H[1] @ rot(K[1], b) @ P[1] - d1
            e2 = H[2] @ rot(K[2], a) @ P[2] + H[3] @ rot(K[3], b) @ P[3] - d2
            worst = max(worst, abs(e1), abs(e2))
        missed += not any(np.abs(wrapped(s - t)).max() < 1e-6 for s in out[:n])
    assert worst < 1e-10
    assert missed == 0


@pytest.mark.parametrize("name", list(NEW))
def test_class_recognised_as_eaik_does(arms, name):
    from eaik.IK_DH import DhRobot

    assert classify(arms[name]).description == DESCRIPTION[name]
    dh = np.array(NEW[name], float)
    bot = DhRobot(np.radians(dh[:, 1]), dh[:, 0], dh[:, 2])
    assert bot.getKinematicFamily() == EAIK_FAMILY[name]


def _poses(mech, m, seed):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=(m, 6))
    return q, frame_poses(mech, q, [mech.end_effector])[:, 0]


@pytest.mark.parametrize("name", list(NEW))
def test_every_solution_exact_and_the_set_equals_eaik(arms, name):
    """1000 random poses: every solution by the model's FK (1e-10 away from the wrist
    singularity, 1e-8 at it), the generating joints found, and the set equal to EAIK's: no
    EAIK solution missed; none of ours outside EAIK's list except at poses where EAIK itself
    flags a least-squares (near-singular) answer."""
    from eaik.IK_DH import DhRobot

    mech = arms[name]
    m = 1000
    q, T = _poses(mech, m, seed=1)
    b = analytic_batch(mech, classify(mech), T, np.zeros(6))
    ok = np.arange(8)[None] < b.count[:, None]
    assert np.all(b.count >= 1) and not np.isnan(b.q_v[ok]).any()
    T_E = frame_poses(mech, b.q_v[ok], [mech.end_effector])[:, 0]
    err = np.abs(T_E - np.repeat(T[:, None], 8, axis=1)[ok]).max(axis=(1, 2))
    near = np.repeat(np.abs(np.sin(q[:, 4]))[:, None], 8, axis=1)[ok] < NEAR_SINGULAR
    assert err[~near].max() < FK_TOL and err.max() < 1e-8
    d = np.nanmin(np.abs(wrapped(b.q_v - q[:, None])).max(axis=-1), axis=1)
    # two exact solutions closer than SAME_TOL (1e-3 rad, near a tangency) are merged into
    # the one nearer the guess: the generating joints are then within 1e-3 of a solution
    merged = (d >= 1e-8) & (d < 1e-3)
    assert np.all((d < 1e-8) | merged | (np.abs(np.sin(q[:, 4])) < NEAR_SINGULAR))
    assert merged.sum() <= 3
    dh = np.array(NEW[name], float)
    bot = DhRobot(np.radians(dh[:, 1]), dh[:, 0], dh[:, 2])
    equal, flagged = 0, 0
    for i in range(m):
        sol = bot.IK(T[i])
        theirs = [s for s, ls in zip(sol.Q, sol.is_LS, strict=True)
                  if not ls and np.abs(bot.fwdKin(s) - T[i]).max() < 1e-8]
        mine = b.q_v[i, :b.count[i]]
        for s in theirs:
            assert any(np.abs(wrapped(s - x)).max() < 1e-3 for x in mine), (name, i, s)
        extra = [x for x in mine if not any(np.abs(wrapped(s - x)).max() < 1e-6
                                           for s in sol.Q)]
        if extra:
            assert any(sol.is_LS), (name, i, extra)
            flagged += 1
        else:
            equal += 1
    assert equal >= 995 and flagged <= 5, (equal, flagged)


@pytest.mark.parametrize("name", ["sph_general", "sph_int23", "par_general"])
def test_solution_set_equals_ssik(arms, name):
    import ssik

    mech = arms[name]
    dh = np.array(NEW[name], float)
    man = ssik.Manipulator.from_dh(np.radians(dh[:, 1]), dh[:, 0], dh[:, 2])
    m = 40
    _, T = _poses(mech, m, seed=2)
    b = analytic_batch(mech, classify(mech), T, np.zeros(6))
    for i in range(m):
        theirs = [s.q for s in man.solve(T[i], respect_limits=False, enumerate_windings=False)]
        mine = b.q_v[i, :b.count[i]]
        assert len(theirs) == len(mine), (name, i)
        for s in theirs:
            assert any(np.abs(wrapped(s - x)).max() < 1e-8 for x in mine), (name, i, s)


@pytest.mark.parametrize("name", ["sph_general", "par_general", "sph_par12"])
def test_wrist_singular_pose_is_finite_and_exact(arms, name):
    """q5 = 0: q4 and q6 (or their images) turn about one line; the answer is finite, exact
    by FK, and the sequence API returns it as ok."""
    mech = arms[name]
    q = np.array([0.3, -0.4, 0.5, 0.7, 0.0, -0.2])
    T = frame_poses(mech, q[None], [mech.end_effector])[0, 0]
    b = analytic_batch(mech, classify(mech), T[None], np.array([0.2, -0.3, 0.4, 1.1, 0.1, 0.0]))
    sols = b.q_v[0, :b.count[0]]
    assert len(sols) >= 1 and np.all(np.isfinite(sols))
    T_E = frame_poses(mech, sols, [mech.end_effector])[:, 0]
    assert np.abs(T_E - T).max() < 1e-8
    r = mechkin.ik(mech, T, q_v0=np.zeros(6))[0]
    assert r.ok and r.method == "analytic" and np.all(np.isfinite(r.q_v))


@pytest.mark.parametrize("name", ["sph_general", "par_general"])
def test_auto_picks_analytic_and_solutions_all_is_complete(tmp_path, name):
    (tmp_path / "arm.yaml").write_text(mech_yaml(name))
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
    rep = mechkin.run(tmp_path / "sc.yaml")
    s = rep.summary
    assert s["status"] == "ok" and s["methods_used"] == ["analytic"]
    assert s["solutions"]["complete"] is True and s["solutions"]["source"] == ["analytic"]
    mech = load_mechanism(tmp_path / "arm.yaml")
    for t in s["targets"]:
        q = np.array([[sol["q"][n] for n in mech.joint_names] for sol in t["solutions"]])
        T_E = frame_poses(mech, q, [mech.end_effector])[:, 0]
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = t["target"]["R"], t["target"]["xyz_m"]
        assert len(q) >= 1 and np.abs(T_E - T).max() < FK_TOL


@pytest.mark.parametrize("name", list(NEW))
def test_special_poses_are_finite_and_exact(arms, name):
    """Joints on the grid {0, +-pi/2, pi} (wrist and elbow singularities, axes made parallel):
    never NaN, every returned solution exact by FK (1e-8: double roots are accurate to the
    critical point), and a solution at every pose, except (three parallel axes with h5, h6
    skew) where h6 turns parallel to h2 || h3 || h4 (q4 = -pi/2 here) with the elbow stretched
    (q3 = 0): q6 is then free with the reach of the planar chain depending on it, and the
    guess kept for q6 can leave the elbow out of reach."""
    mech = arms[name]
    vals = np.array([0.0, np.pi / 2, -np.pi / 2, np.pi])
    rng = np.random.default_rng(0)
    grid = np.stack(np.meshgrid(*[vals] * 6, indexing="ij"), -1).reshape(-1, 6)
    q = grid[rng.random(len(grid)) < 0.25]
    T = frame_poses(mech, q, [mech.end_effector])[:, 0]
    b = analytic_batch(mech, classify(mech), T, np.zeros(6))
    ok = np.arange(8)[None] < b.count[:, None]
    assert not np.isnan(b.q_v[ok]).any()
    T_E = frame_poses(mech, b.q_v[ok], [mech.end_effector])[:, 0]
    assert np.abs(T_E - np.repeat(T[:, None], 8, axis=1)[ok]).max() < 1e-8
    none = b.count == 0
    if name == "par_general":
        assert np.all((q[none, 2] == 0.0) & (q[none, 3] == -np.pi / 2)) and none.sum() < 30
    else:
        assert not none.any()
