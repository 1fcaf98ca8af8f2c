"""hwang2023 biped leg: Eq. (1) forward kinematics and the closed forms of §2.2-§2.4.

Round trips: closed form -> forward kinematics -> closed form, every class and branch, seeded
random poses within the joint ranges, to 1e-9. Geometry: HWANG2023_ESTIMATED (the round trips
hold for any geometry; the estimates only make the poses realistic).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import brentq

from mechkin.solvers.biped.leg import (
    HWANG2023_ESTIMATED,
    Q_MAX,
    Q_MIN,
    STATUS_UNREACHABLE,
    InclinedPlane,
    LegTask,
    biped_polylines,
    body_transform,
    contact_below_hip,
    ee_rotation_from_psi,
    leg_fk,
    leg_frames,
    psi_from_ee_rotation,
    rolled_position,
    solve_biped_case,
    solve_known_pose,
    solve_known_pose_batch,
    solve_known_position,
    solve_rolling,
)
from mechkin.spatial.rotations import rot_y
from mechkin.spatial.transforms import T_from

ATOL_Q = 1e-9  # [rad] round trips
G = HWANG2023_ESTIMATED
SIDES = ("right", "left")
_S4 = np.diag([-1.0, 1.0, 1.0, 1.0])
_D4 = np.diag([1.0, -1.0, 1.0, 1.0])


def _random_body(rng: np.random.Generator) -> np.ndarray:
    return body_transform(rng.normal(0.0, 0.1, 3), rng.uniform(-1.0, 1.0))


def _best(sols, q: np.ndarray, beta: float | None = None) -> float:
    errs = [float(np.max(np.abs(s.q - q))) + (0.0 if beta is None else abs(s.beta - beta))
            for s in sols if s.ok]
    return min(errs, default=math.inf)


# --------------------------------------------------------------------------- Eq. (1)


def test_zero_pose_hangs_straight_down() -> None:
    TG = body_transform([0.0, 0.0, 1.0])
    for side, x in (("right", 0.110), ("left", -0.110)):
        T = leg_fk(G, side, np.zeros((1, 6)), TG)[0]
        assert_allclose(T[:3, 3], [x, 0.0, 1.0 - sum(G.lengths)], atol=1e-15)
        assert_allclose(T[:3, 2], [0.0, 0.0, -1.0], atol=1e-15)  # z_6' down both sides


def test_left_leg_is_the_mirror_image() -> None:
    rng = np.random.default_rng(10)
    q = rng.uniform(Q_MIN, Q_MAX, (20, 6))
    TG = _random_body(rng)
    Fl = leg_frames(G, "left", q, TG)
    Fr = leg_frames(G, "right", q, _S4 @ TG @ _S4)
    assert_allclose(Fl[:, 1:], _S4 @ Fr[:, 1:] @ _D4, atol=1e-14)
    assert np.allclose(np.linalg.det(Fl[:, :, :3, :3]), 1.0)


@pytest.mark.parametrize("side", SIDES)
def test_joint_sign_meanings(side: str) -> None:
    """JRx + lifts forward, JRy + lifts outward, JRz + turns outward (§2.2), both legs."""
    TG = np.eye(4)
    out = 1.0 if side == "right" else -1.0
    p0 = leg_fk(G, side, np.zeros((1, 6)), TG)[0, :3, 3]

    def moved(i: int) -> np.ndarray:
        q = np.zeros((1, 6))
        q[0, i] = 0.2
        return leg_fk(G, side, q, TG)[0]

    assert moved(2)[1, 3] > p0[1]  # theta3: foot forward (+y)
    assert (moved(1)[0, 3] - p0[0]) * out > 0.0  # theta2: foot outward
    toe = moved(0)[:3, 1] * (-1.0 if side == "right" else 1.0)
    assert toe[0] * out > 0.0  # theta1: toe turns outward


def test_foot_end_effector_is_longer() -> None:
    q = np.zeros((1, 6))
    d = leg_fk(G, "right", q, np.eye(4), "blade")[0, 2, 3] - leg_fk(G, "right", q, np.eye(4),
                                                                    "foot")[0, 2, 3]
    assert d == pytest.approx(G.foot_extension)


# --------------------------------------------------------------------------- §2.2


@pytest.mark.parametrize("side", SIDES)
@pytest.mark.parametrize("kind", ["foot", "blade"])
def test_known_pose_round_trip_batch(side: str, kind: str) -> None:
    rng = np.random.default_rng(11)
    m = 500
    q = rng.uniform(Q_MIN, Q_MAX, (m, 6))
    TG = np.stack([_random_body(rng) for _ in range(m)])
    T = leg_fk(G, side, q, TG, kind)
    qs, ok, pe, oe = solve_known_pose_batch(G, side, T, TG, kind)
    err = np.where(ok, np.max(np.abs(qs - q[:, None]), axis=-1), np.inf).min(axis=1)
    assert np.all(err < ATOL_Q)
    assert np.all(pe[ok] < 1e-9) and np.all(oe[ok] < 1e-9)
    assert np.all(qs[ok[:, 0], 0, 3] <= 0.0) and np.all(qs[ok[:, 1], 1, 3] >= 0.0)
    assert ok[:, 1].any()  # the knee-forward branch occurs


def test_known_pose_knee_back_first_and_unreachable() -> None:
    TG = body_transform([0.0, 0.0, 0.7])
    q = np.deg2rad([5.0, 3.0, 20.0, -40.0, 20.0, -3.0])
    T = leg_fk(G, "right", q[None], TG)[0]
    sols = solve_known_pose(G, "right", T, TG)
    assert [s.branch for s in sols] == ["knee back", "knee forward"]
    assert_allclose(sols[0].q, q, atol=ATOL_Q)
    far = T.copy()
    far[2, 3] -= 1.0
    (bad,) = solve_known_pose(G, "right", far, TG)
    assert bad.status == STATUS_UNREACHABLE and not bad.ok


# --------------------------------------------------------------------------- §2.3


def _delta_for(T: np.ndarray, side: str, beta: float) -> np.ndarray:
    """Delta_i with Psi_i = Delta_i Rot(-+Y, beta) (Eq. 21) for the FK pose T."""
    Psi = psi_from_ee_rotation(T[:3, :3], side)
    return Psi @ rot_y(beta if side == "right" else -beta)


@pytest.mark.parametrize("side", SIDES)
@pytest.mark.parametrize("zero_theta6", [True, False])
def test_known_position_round_trip_random(side: str, zero_theta6: bool) -> None:
    """Table 3 (a) theta6 = 0 and (c) theta6 != 0, P3 != 0 from random joint angles."""
    rng = np.random.default_rng(12)
    case = "theta6 = 0" if zero_theta6 else "theta6 != 0, P3 != 0"
    for _ in range(60):
        q = rng.uniform(Q_MIN, Q_MAX)
        if zero_theta6:
            q[5] = 0.0
        TG = _random_body(rng)
        T = leg_fk(G, side, q[None], TG)[0]
        beta = rng.uniform(-1.5, 1.5)
        sols = solve_known_position(G, side, T[:3, 3], _delta_for(T, side, beta), q[5], TG)
        assert case in sols[0].method
        assert _best(sols, q, beta) < ATOL_Q
        assert all(s.position_error < 1e-9 and s.orientation_error < 1e-9 for s in sols)


@pytest.mark.parametrize("side", SIDES)
def test_known_position_round_trip_p3_zero(side: str) -> None:
    """Table 3 (b): theta6 != 0, P3 = 0 (plane tilted about Y only, beta_Z = 0).

    Targets from the closed form of §2.2 (every branch), then §2.3 with theta6 of that branch.
    """
    rng = np.random.default_rng(13)
    n = 0
    for _ in range(80):
        q0 = rng.uniform(Q_MIN / 2, Q_MAX / 2)
        TG = body_transform(rng.normal(0.0, 0.05, 3), rng.uniform(-0.5, 0.5))
        E = leg_fk(G, side, q0[None], TG)[0, :3, 3]
        plane = InclinedPlane(lam_y=rng.uniform(-0.5, 0.5))
        beta = rng.uniform(-1.2, 1.2)
        T = T_from(ee_rotation_from_psi(plane.contact_rotation(side, "blade", 0.0, beta), side), E)
        for s22 in solve_known_pose(G, side, T, TG):
            if not s22.ok:
                continue
            sols = solve_known_position(G, side, E, plane.contact_base(side, 0.0), s22.q[5], TG)
            assert "P3 = 0" in sols[0].method
            assert _best(sols, s22.q, beta) < ATOL_Q
            n += 1
    assert n > 20


# --------------------------------------------------------------------------- §2.4


def _theta6_of_beta(side, pa, beta_a, Delta, n, TG, beta):
    """Independent route: for a tilt beta, place E by Eq. (36) and solve §2.2 for theta6."""
    pb = rolled_position(pa, Delta[:, 0], n, G.wheel_radius, beta_a, beta)
    Psi = Delta @ rot_y(-beta if side == "right" else beta)
    T = T_from(ee_rotation_from_psi(Psi, side), pb)
    q, ok, _, _ = solve_known_pose_batch(G, side, T[None], TG)
    return q[0, 0, 5]


@pytest.mark.parametrize("side", SIDES)
@pytest.mark.parametrize("plane", [InclinedPlane(lam_y=np.deg2rad(15.0)),
                                   InclinedPlane(lam_x=np.deg2rad(12.0), lam_y=np.deg2rad(-8.0))])
def test_rolling_against_beta_parametrisation_and_back(side: str, plane: InclinedPlane) -> None:
    """§2.4 (P3 = 0 and P3 != 0): rolling to theta6 = 0 matches a root search in beta over
    §2.2, and rolling back to the start theta6 returns the start state."""
    TG = body_transform([0.0, 0.0, 0.66])
    E_a = contact_below_hip(G, plane, TG, side)
    Delta = plane.contact_base(side, 0.0 if plane.lam_x == 0.0 else 0.05)  # P3 = 0 iff beta_Z = 0
    Psi = Delta  # beta_Ya = 0
    T = T_from(ee_rotation_from_psi(Psi, side), E_a)
    (start, *_) = solve_known_pose(G, side, T, TG)
    assert start.ok and abs(start.q[5]) > 0.1
    sols = solve_rolling(G, side, E_a, 0.0, Delta, plane.normal, 0.0, TG)
    rb = sols[0]
    assert rb.ok and rb.position_error < 1e-9 and rb.orientation_error < 1e-9
    assert ("P3 = 0" in rb.method) == (plane.lam_x == 0.0)
    ref = brentq(lambda b: _theta6_of_beta(side, E_a, 0.0, Delta, plane.normal, TG, b),
                 -1.2, 1.2, xtol=1e-15)
    assert rb.beta == pytest.approx(ref, abs=1e-9)
    assert_allclose(rb.T_0_E[:3, 3], rolled_position(E_a, Delta[:, 0], plane.normal,
                                                     G.wheel_radius, 0.0, rb.beta), atol=1e-12)
    back = solve_rolling(G, side, rb.T_0_E[:3, 3], rb.beta, Delta, plane.normal, start.q[5], TG)
    assert _best(back, start.q, 0.0) < ATOL_Q


@pytest.mark.parametrize("side", SIDES)
def test_rolling_round_trip_random(side: str) -> None:
    """Random start states (beta_Ya, theta6 targets from random joint angles) on random planes."""
    rng = np.random.default_rng(14)
    n = 0
    for _ in range(25):
        plane = InclinedPlane(lam_x=rng.uniform(-0.3, 0.3), lam_y=rng.uniform(-0.3, 0.3))
        TG = body_transform([0.0, 0.0, 0.68])
        bz = rng.uniform(-0.3, 0.3)
        Delta = plane.contact_base(side, bz)
        E_a = contact_below_hip(G, plane, TG, side, rng.normal(0.0, 0.03, 2))
        beta_a = rng.uniform(-0.4, 0.4)
        T = T_from(ee_rotation_from_psi(plane.contact_rotation(side, "blade", bz, beta_a),
                                        side), E_a)
        starts = [s for s in solve_known_pose(G, side, T, TG) if s.ok]
        if not starts:
            continue
        t6 = rng.uniform(-0.3, 0.3)
        for rb in solve_rolling(G, side, E_a, beta_a, Delta, plane.normal, t6, TG):
            if not rb.ok:
                continue
            assert abs(rb.q[5] - t6) < 1e-12
            back = solve_rolling(G, side, rb.T_0_E[:3, 3], rb.beta, Delta, plane.normal,
                                 starts[0].q[5], TG)
            assert abs(min(abs(b.beta - beta_a) for b in back if b.ok)) < ATOL_Q
            n += 1
    assert n >= 10


# --------------------------------------------------------------------------- plain entry points


def test_solve_biped_case_modes_and_polylines() -> None:
    plane = InclinedPlane(lam_y=np.deg2rad(15.0))
    TG = body_transform([0.0, 0.0, 0.6772])
    E = {s: tuple(contact_below_hip(G, plane, TG, s)) for s in SIDES}
    walk = solve_biped_case(plane, "walk", T_0_G=TG, right=LegTask(E["right"]),
                            left=LegTask(E["left"]))
    assert walk.status == "ok" and walk.kind == "foot"
    skate = solve_biped_case(plane, "skate", T_0_G=TG, right=LegTask(E["right"]),
                             left=LegTask(E["left"]))
    t6 = {s: skate.legs[s].q[5] for s in SIDES}
    known = solve_biped_case(plane, "skate", T_0_G=TG,
                             right=LegTask(E["right"], beta=None, theta6=t6["right"]),
                             left=LegTask(E["left"], beta=None, theta6=t6["left"]),
                             previous={s: skate.legs[s].q for s in SIDES})
    for s in SIDES:
        assert_allclose(known.legs[s].q, skate.legs[s].q, atol=ATOL_Q)
        assert abs(known.legs[s].beta) < ATOL_Q
        assert_allclose(skate.legs[s].p_contact, E[s], atol=1e-12)  # upright: C = E
    roll = solve_biped_case(plane, "roll", T_0_G=TG, right=LegTask(E["right"], theta6=0.0),
                            left=LegTask(E["left"], theta6=0.0))
    for s in SIDES:
        leg = roll.legs[s]
        assert leg.ok and abs(leg.q[5]) < 1e-12
        # the wheel rim touches the plane (Fig. 5): contact point on the plane
        assert abs(plane.normal @ leg.p_contact) < 1e-12
    lines = biped_polylines(G, TG, roll.legs["right"].q, roll.legs["left"].q, plane=plane)
    assert set(lines) == {"body", "leg_right", "leg_left", "blade_right", "blade_left", "plane"}
    assert lines["leg_right"].shape == (8, 3) and lines["body"].shape == (3, 3)
    assert_allclose(lines["plane"][0], lines["plane"][-1])
    feet = biped_polylines(G, TG, walk.legs["right"].q, walk.legs["left"].q, kind="foot")
    assert feet["foot_left"].shape == (5, 3)


def test_bad_inputs() -> None:
    with pytest.raises(ValueError, match="expected side"):
        leg_fk(G, "middle", np.zeros((1, 6)), np.eye(4))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"expected q of shape \(m, 6\)"):
        leg_fk(G, "right", np.zeros(6), np.eye(4))
    with pytest.raises(ValueError, match="expected mode"):
        solve_biped_case(InclinedPlane(), "fly", T_0_G=np.eye(4),  # type: ignore[arg-type]
                         right=LegTask((0, 0, 0)), left=LegTask((0, 0, 0)))
