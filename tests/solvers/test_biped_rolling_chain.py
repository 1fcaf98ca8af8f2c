"""hwang2023 §2.3 as a loop closure (virtual rolling chain + cut) vs the closed forms.

Fig. 7 (c), (d) use the ESTIMATED geometry and body heights (as tests/papers/test_hwang2023_table6);
the comparisons themselves (closure vs closed form) depend on no estimate: both use the same legs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mechkin.config.mechanism_file import read_mechanism_spec
from mechkin.solvers.biped.leg import (
    HWANG2023_ESTIMATED,
    InclinedPlane,
    LegTask,
    body_transform,
    contact_below_hip,
    leg_fk,
    psi_from_ee_rotation,
    solve_biped_case,
    solve_known_position,
)
from mechkin.solvers.biped.rolling_chain import solve_blade_tilt_by_closure
from mechkin.spatial.rotations import rot_y
from mechkin.spatial.transforms import T_from

ROOT = Path(__file__).resolve().parents[2]
G = HWANG2023_ESTIMATED
SPEC, _ = read_mechanism_spec(ROOT / "mechanisms" / "hwang2023_biped.yaml")
JOINTS = {s: [f"{s[0]}_theta{i}" for i in range(1, 7)] for s in ("right", "left")}
BLADE = {"right": "blade_r", "left": "blade_l"}
PLANE_A = InclinedPlane(lam_y=np.deg2rad(15.0))
PLANE_B = InclinedPlane(lam_x=np.deg2rad(15.0), lam_y=np.deg2rad(15.0))


def _closure(side, E, Delta, TG, theta6, q_guess, beta_guess=0.0):
    T_bc = np.linalg.inv(TG) @ T_from(Delta, np.asarray(E, float))
    return solve_blade_tilt_by_closure(SPEC, leg_joints=JOINTS[side], blade_frame=BLADE[side],
                                       side=side, T_base_contact=T_bc, theta6=theta6,
                                       q_guess=q_guess, beta_guess=beta_guess)


@pytest.mark.parametrize(("case", "plane", "z"), [("c", PLANE_A, 0.677205),
                                                  ("d", PLANE_B, 0.66516)])
@pytest.mark.parametrize("side", ["right", "left"])
def test_fig7_c_d_closure_equals_closed_form(case, plane, z, side):
    """(c) on plane (a) (Table 3 (b), P3 = 0) and (d) on plane (b) (Table 3 (c), P3 != 0)."""
    TG = body_transform([0.0, 0.0, z])
    E = {s: tuple(contact_below_hip(G, plane, TG, s)) for s in ("right", "left")}
    t6 = np.deg2rad(20.0)
    roll = solve_biped_case(plane, "roll", T_0_G=TG, right=LegTask(E["right"], theta6=t6),
                            left=LegTask(E["left"], theta6=t6))
    ref = roll.legs[side]
    Delta = plane.contact_base(side, 0.0)
    # start from the knee-bent home pose, not from the answer
    sol = _closure(side, ref.T_0_E[:3, 3], Delta, TG, t6, np.deg2rad([0, 0, 20, -40, 20, 0]))
    assert sol.ok and sol.residual < 1e-10
    closed = solve_known_position(G, side, ref.T_0_E[:3, 3], Delta, t6, TG)
    err = min(np.max(np.abs(sol.q_leg - a.q)) + abs(sol.beta - a.beta) for a in closed if a.ok)
    assert err < 1e-9
    np.testing.assert_allclose(sol.q_leg, ref.q, atol=1e-9)
    assert sol.beta == pytest.approx(ref.beta, abs=1e-9)


@pytest.mark.parametrize("side", ["right", "left"])
def test_random_poses_closure_finds_the_closed_form_branches(side):
    """Random legs within the ranges: the blade pose defines Delta (any beta_Y); from a guess
    near each closed-form branch the closure converges to that branch, to 1e-9."""
    rng = np.random.default_rng(23 if side == "right" else 24)
    TG = body_transform([0.01, -0.02, 0.65], 0.1)
    n_checked = 0
    for _ in range(8):
        q = rng.uniform(np.deg2rad([-40, -30, -60, -120, -60, -60]),
                        np.deg2rad([40, 30, 60, -10, 60, 60]))
        T = leg_fk(G, side, q[None], TG, "blade")[0]
        Psi = psi_from_ee_rotation(T[:3, :3], side)
        beta = rng.uniform(-0.6, 0.6)
        Delta = Psi @ (rot_y(beta) if side == "right" else rot_y(-beta))  # Table 1
        closed = [a for a in solve_known_position(G, side, T[:3, 3], Delta, q[5], TG) if a.ok]
        assert any(np.max(np.abs(a.q - q)) < 1e-9 and abs(a.beta - beta) < 1e-9 for a in closed)
        for a in closed:
            guess = a.q + rng.normal(0.0, 0.03, 6)
            sol = _closure(side, T[:3, 3], Delta, TG, q[5], guess, a.beta + 0.03)
            assert sol.ok
            np.testing.assert_allclose(sol.q_leg, a.q, atol=1e-9)
            assert sol.beta == pytest.approx(a.beta, abs=1e-9)
            n_checked += 1
    assert n_checked >= 8


def test_the_virtual_chain_is_a_loop_with_six_equations():
    TG = body_transform([0.0, 0.0, 0.677205])
    E = contact_below_hip(G, PLANE_A, TG, "right")
    sol = _closure("right", E, PLANE_A.contact_base("right", 0.0), TG, 0.0,
                   np.deg2rad([0, 0, 20, -40, 20, 0]))
    m = sol.mechanism
    assert m.n_cuts == 1 and m.n_equations == 6
    assert set(m.dependent_names) == set(JOINTS["right"][:5]) | {"contact_beta"}
    assert "r_theta6" in m.independent_names and "l_theta3" in m.independent_names
