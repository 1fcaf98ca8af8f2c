"""kim1995 Tables 3, 6 and 9: inverse kinematics of the three mechanisms of §6.

Tolerances: half a unit of the last printed digit, except where PAPER_NOTES documents that the
printed inputs limit the reproduction (each case says why).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.kinematics import forward_kinematics
from mechkin.solvers.closed_form.direct_drive import direct_drive_ik
from mechkin.solvers.closed_form.stewart import leg_lengths, stewart_attachments
from mechkin.solvers.ik import IkOptions, IkStatus, pose_errors, solve_ik_sequence


def _polar(T):
    T = np.array(T, dtype=float)
    U, _, Vt = np.linalg.svd(T[:3, :3])
    T[:3, :3] = U @ Vt
    return T


# kim1995 Table 2, with the two misprints of point 2 corrected (PAPER_NOTES)
TABLE2 = [_polar(T) for T in (
    [[0, 0, -1, -0.4], [0, 1, 0, 0], [1, 0, 0, 0.8], [0, 0, 0, 1]],
    [[0.07276, -0.92978, -0.36086, -0.14434], [0.18378, 0.36812, -0.91143, -0.36457],
     [0.98027, 0.0, 0.19766, 0.87906], [0, 0, 0, 1]],
    [[-0.48994, -0.06278, 0.86949, 0.34780], [0.03082, -0.99803, -0.05470, -0.02188],
     [0.87121, 0.0, 0.49090, 0.99636], [0, 0, 0, 1]],
    [[0.18306, 0.96858, -0.16833, -0.06733], [-0.71297, 0.24869, 0.65561, 0.26224],
     [0.67688, 0.0, 0.73610, 1.09444], [0, 0, 0, 1]],
)]
# kim1995 Table 3, simulation results
TABLE3 = np.array([[0.00000, 0.00000, 0.00000], [1.19381, -0.19897, 0.00000],
                   [3.07876, -0.51312, 0.00000], [-1.31947, -0.82728, 0.00001]])
# kim1995 Table 3, analytical solution (point 4 q1 differs in the last digit)
TABLE3_ANALYTIC = TABLE3.copy()
TABLE3_ANALYTIC[3, 0] = -1.31946

# kim1995 Table 5 as read in PAPER_NOTES: Rz(90 deg) at four positions
TABLE5 = []
for p in [(0, 0, 8), (0, 0, 12), (2, 0, 15), (10, 0, 15)]:
    T = np.array([[0, -1, 0, p[0]], [1, 0, 0, p[1]], [0, 0, 1, p[2]], [0, 0, 0, 1]], float)
    TABLE5.append(T)
# kim1995 Table 6, legs 1-6 at points 1-4 (simulation = analytical)
TABLE6 = np.array([
    [12.586732, 12.586732, 13.914071, 11.987620, 11.987620, 13.914071],
    [15.441044, 15.441044, 16.540900, 14.956706, 14.956706, 16.540900],
    [18.048377, 18.048377, 19.779847, 16.545211, 16.545211, 19.779847],
    [20.760930, 20.760930, 24.855708, 15.162713, 15.162713, 24.855708],
])

# kim1995 Table 8 (point 4 as read in PAPER_NOTES) and Table 9
TABLE8 = [np.array(T, float) for T in (
    [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1.933], [0, 0, 0, 1]],
    [[0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 1.933], [0, 0, 0, 1]],
    [[0, -1, 0, 0], [0, 0, 1, 0], [-1, 0, 0, 1.933], [0, 0, 0, 1]],
    [[0, -1, 0, 0.201581], [0, 0, 1, 1.002186], [-1, 0, 0, 1.263049], [0, 0, 0, 1]],
)]
TABLE8_WEIGHTS = np.array([[0, 0, 0, 1, 1, 1]] * 3 + [[1, 1, 1, 1, 1, 1]], float)
TABLE9 = np.array([
    [1.570796, 1.570796, 0.000000, 0.500000, 0.500000, 0.500000],
    [1.570795, 2.912075, 0.000001, 0.454596, 0.522105, 0.522105],
    [0.522855, 2.285263, 1.371731, 0.394962, 0.700971, 0.394883],
    [0.343491, 1.765550, 1.536954, 0.483734, 0.628562, 0.540596],
])


@pytest.fixture(scope="module")
def mechs():
    root = Path(__file__).resolve().parents[2] / "mechanisms"
    return {n: load_mechanism(root / f"{n}.yaml") for n in
            ("kim1995_direct_drive", "kim1995_stewart", "kim1995_end_effector_robot")}


# kim1995 §6.1: ||grad f|| < 1e-7; §6.2: < 1e-8; §6.3: < 1e-7
GRAD_TOL = {"lm": 1e-12, "cg-golden": None}


@pytest.mark.parametrize("method", ["lm", "cg-golden"])
def test_table3_direct_drive(mechs, method, lm_backend):
    """Table 3 to 5 decimals within 1.5e-5: Table 2 is printed to 5 decimals (orthonormal to
    ~1e-5), and the least-squares solution of the printed points moves q by up to 1.2e-5
    (PAPER_NOTES: reproduces to 1e-5). The closed form gives the same to 1.5e-5."""
    mech = mechs["kim1995_direct_drive"]
    opts = IkOptions(method=method, grad_tol=GRAD_TOL[method] or 1e-7, tol_pos=1e-4,
                     tol_ori=1e-4)
    rs = solve_ik_sequence(mech, TABLE2, q_v0=np.zeros(3), options=opts)
    q = np.array([r.q_v for r in rs])
    assert all(r.status is IkStatus.OK for r in rs)
    np.testing.assert_allclose(q, TABLE3, atol=1.5e-5)
    q_cf, ok = direct_drive_ik(np.array(TABLE2), tol=1e-4)
    assert ok.all()
    np.testing.assert_allclose(q_cf, TABLE3_ANALYTIC, atol=1.5e-5)
    np.testing.assert_allclose(q, q_cf, atol=2e-5)


@pytest.mark.parametrize("method", ["lm", "cg-golden"])
def test_table6_stewart(mechs, method, lm_backend):
    """All 24 leg lengths of Table 6. The reconstructed geometry (Table 4 printed to 3-6
    digits) reproduces them to 2e-6 (PAPER_NOTES), so 6 decimals are checked at 2e-6; the
    numerical and closed-form solutions agree to 2e-6. kim1995 §6.2 stops cg-golden at
    ||grad f|| < 1e-8; here that leaves f = 2e-14 at point 3 (3e-6 in leg length, depending on
    the line-search path), so cg-golden is run to 1e-9."""
    mech = mechs["kim1995_stewart"]
    opts = IkOptions(method=method, grad_tol=GRAD_TOL[method] or 1e-9)
    rs = solve_ik_sequence(mech, TABLE5, options=opts)
    q = np.array([r.q_v for r in rs])
    assert all(r.status is IkStatus.OK for r in rs)
    np.testing.assert_allclose(q, TABLE6, atol=2e-6)
    a, b = stewart_attachments(mech)
    lengths = leg_lengths(np.array(TABLE5), a, b)
    np.testing.assert_allclose(lengths, TABLE6, atol=2e-6)
    np.testing.assert_allclose(q, lengths, atol=2e-6 if method == "cg-golden" else 1e-6)


def test_table9_end_effector_lm(mechs, lm_backend):
    """Table 9. Points 1-3 have position weight 0: only the orientation of {E} is determined
    (a 3-parameter family of q_v reaches it), so for them we check the orientation (Table 8)
    and, for point 1, whose start (home) already has f = 0, the joint values to 6 decimals.
    Point 4 (all weights 1) is determined: its 6 values are checked at 5e-5, the accuracy to
    which the reconstructed mechanism reproduces Table 8 point 4 from Table 9 (PAPER_NOTES)."""
    mech = mechs["kim1995_end_effector_robot"]
    # P2 is path-sensitive (the wrist-only answer is on the wrist_2 limit): restarts from a
    # seeded jitter of the start make the sequence robust to round-off (checked on
    # Python 3.10 / numpy 2.2 and 3.11 / numpy 2.4)
    rs = solve_ik_sequence(mech, TABLE8, weights=TABLE8_WEIGHTS,
                           options=IkOptions(grad_tol=1e-12, restarts=8, max_iter=200))
    assert all(r.status is IkStatus.OK for r in rs)
    np.testing.assert_allclose(rs[0].q_v, TABLE9[0], atol=5e-7)
    for r, T in zip(rs[:3], TABLE8[:3], strict=False):
        T_E = forward_kinematics(mech, r.q[None]).frames(mech, [mech.end_effector])[:, 0]
        np.testing.assert_allclose(T_E[0, :3, :3], T[:3, :3], atol=1e-8)  # lm stops at ~1e-9
    np.testing.assert_allclose(rs[3].q_v, TABLE9[3], atol=5e-5)
    for r in rs:  # every joint, passive ones too, within its limits (as Table 9's answers are)
        assert np.all(r.q >= mech.lower - 1e-9) and np.all(r.q <= mech.upper + 1e-9), r.q
    _, oe = pose_errors(np.array([forward_kinematics(mech, r.q[None]).frames(
        mech, [mech.end_effector])[0, 0] for r in rs]), np.array(TABLE8))
    assert np.all(oe < 1e-8)


@pytest.mark.parametrize("start", ["table9_point3", "near_point4"])
def test_table9_end_effector_cg_golden_point4(mechs, start, lm_backend):
    """cg-golden (§5.2, ||grad f|| < 1e-7) on the determined point 4 (all weights 1), warm
    started as the paper's sequence does from its point-3 answer (Table 9 point 3), and from
    0.01 away from Table 9 point 4. All six values within 5e-5, the accuracy to which the
    reconstructed mechanism reproduces Table 8 point 4 from Table 9 point 4 (PAPER_NOTES)."""
    from mechkin.model.closure import solve_closure

    if start == "table9_point3" and lm_backend == "numpy":
        pytest.skip("5000 evaluations take 30 s on numpy; the compiled run checks this path")
    mech = mechs["kim1995_end_effector_robot"]
    q0 = TABLE9[2] if start == "table9_point3" else TABLE9[3] + 0.01
    res = solve_closure(mech, q0[None], mech.home[mech.dependent][None])
    assert res.ok[0]
    rs = solve_ik_sequence(mech, TABLE8[3:], q_v0=q0, q_w0=res.q[0, mech.dependent],
                           options=IkOptions(method="cg-golden", grad_tol=1e-7, max_iter=500))
    assert rs[0].status is IkStatus.OK
    np.testing.assert_allclose(rs[0].q_v, TABLE9[3], atol=5e-5)


def test_table9_end_effector_cg_golden_points_1_2(mechs, lm_backend):
    """cg-golden (§5.2) from home through points 1-2 (position weight 0): the orientation of
    {E} is the determined part (Table 8). Plain §5.2 steepest descent drives the 3-RPS stage
    into the gimbal lock of spherical joint s1 here; with the passive limits kept by gradient
    projection it reaches point 2 (the legs share the tilt, the wrist does the rest)."""
    mech = mechs["kim1995_end_effector_robot"]
    rs = solve_ik_sequence(mech, TABLE8[:2], weights=TABLE8_WEIGHTS[:2],
                           options=IkOptions(method="cg-golden", grad_tol=1e-7, max_iter=50))
    assert all(r.status is IkStatus.OK for r in rs), [r.status for r in rs]
    np.testing.assert_allclose(rs[0].q_v, TABLE9[0], atol=5e-7)
    for r, T in zip(rs, TABLE8[:2], strict=True):
        T_E = forward_kinematics(mech, r.q[None]).frames(mech, [mech.end_effector])[0, 0]
        np.testing.assert_allclose(T_E[:3, :3], T[:3, :3], atol=1e-7)
        assert np.all(r.q >= mech.lower - 1e-9) and np.all(r.q <= mech.upper + 1e-9)


def _without_leg_strokes(tmp_path):
    """The end-effector robot with the leg strokes lifted: kim1995 gives no strokes, and its
    §5.2 has no joint limits; the bundled file's [0.3, 0.8] m are the reconstruction's. The
    bundled variant mechanisms/kim1995_end_effector_robot_no_strokes.yaml (checked against the
    bundled robot in test_kim1995_table9_readings.py)."""
    return load_mechanism(Path(__file__).resolve().parents[2] / "mechanisms" /
                          "kim1995_end_effector_robot_no_strokes.yaml")


def test_table9_end_effector_cg_golden_sequence_as_printed(tmp_path, lm_backend):
    """The whole Table 8 sequence by cg-golden from home (kim1995 §5.2, ||grad f|| < 1e-7), on
    the mechanism as the paper states it (no leg strokes): points 1-3 reach the Table 8
    orientation (position weight 0: only that is determined), point 4 gives Table 9 to 5e-5."""
    mech = _without_leg_strokes(tmp_path)
    rs = solve_ik_sequence(mech, TABLE8, weights=TABLE8_WEIGHTS,
                           options=IkOptions(method="cg-golden", grad_tol=1e-7, max_iter=500))
    assert all(r.status is IkStatus.OK for r in rs), [r.status for r in rs]
    np.testing.assert_allclose(rs[0].q_v, TABLE9[0], atol=5e-7)
    for r, T in zip(rs[:3], TABLE8[:3], strict=True):
        T_E = forward_kinematics(mech, r.q[None]).frames(mech, [mech.end_effector])[0, 0]
        np.testing.assert_allclose(T_E[:3, :3], T[:3, :3], atol=1e-6)
    np.testing.assert_allclose(rs[3].q_v, TABLE9[3], atol=5e-5)


@pytest.mark.xfail(reason="with the bundled leg strokes [0.3, 0.8] m (the paper gives none), "
                          "cg-golden's descent to point 3 ends on a constrained local minimum: "
                          "leg 2 on its 0.8 stroke, legs 1 and 3 at the stage's singular "
                          "boundary (status 'at a limit', f = 0.03); lm reaches it",
                   strict=True)
def test_table9_end_effector_cg_golden_sequence(mechs):
    mech = mechs["kim1995_end_effector_robot"]
    rs = solve_ik_sequence(mech, TABLE8[:3], weights=TABLE8_WEIGHTS[:3],
                           options=IkOptions(method="cg-golden", grad_tol=1e-7, max_iter=50))
    assert all(r.status is IkStatus.OK for r in rs)
