"""hwang2023 §2.2 closed form against the general inverse kinematics (kim1995 objective, lm) on
the bundled biped: both find the same leg angles for the same foot pose."""

from pathlib import Path

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.kinematics import frame_poses
from mechkin.solvers.biped import leg as bl
from mechkin.solvers.ik import IkOptions, IkStatus, solve_ik

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("side", ["right", "left"])
def test_closed_form_equals_general_ik(side):
    mech = load_mechanism(ROOT / "mechanisms" / "hwang2023_biped.yaml")
    s = side[0]
    idx = [mech.joint_index(f"{s}_theta{k}") for k in range(1, 7)]
    frame = mech.frame_index(f"foot_{s}")
    # the paper's 0_6' frame: the foot frame of the file times this flip (Eq. 3, Table 1)
    flip = np.diag([1.0, -1, -1, 1]) if side == "right" else np.eye(4)
    rng = np.random.default_rng(11)
    geo = bl.HWANG2023_ESTIMATED
    checked = 0
    for _ in range(6):
        q = mech.home.copy()
        q[idx] = rng.uniform(np.deg2rad([-40, -30, -40, -120, -40, -40]),
                             np.deg2rad([40, 30, 40, -10, 40, 40]))
        T = frame_poses(mech, q[None], [frame])[0, 0]
        sols = bl.solve_known_pose(geo, side, T @ flip, np.eye(4), "foot")
        assert any(np.allclose(sol.q, q[idx], atol=1e-9) for sol in sols if sol.ok)
        start = q.copy()
        start[idx] += 0.05  # near the pose: the general solver converges to the same branch
        r = solve_ik(mech, T, q_v0=start[mech.independent], frame=frame,
                     options=IkOptions(tol_pos=1e-10, tol_ori=1e-10))
        assert r.status is IkStatus.OK
        np.testing.assert_allclose(r.q[idx], q[idx], atol=1e-7)
        other = [j for j in range(mech.n) if j not in idx]
        np.testing.assert_allclose(r.q[other], start[other], atol=1e-12)
        checked += 1
    assert checked == 6
