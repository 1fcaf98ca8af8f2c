"""MuJoCo's own loop equations at mechkin's closed-chain answers (issue 24).

The two grippers of tests/model/closed_chain_models.py written as MJCF in the Menagerie's own
coordinates (the (y, z) plane, joint axes along x; meshes, inertias and actuators left out):
MuJoCo's ``connect`` equality is the loop. At every answer of ``mechkin.fk`` for 100 random
driver angles MuJoCo's constraint violation (``efc_pos`` of the equality rows after
``mj_forward``) is below 1e-10 m: an independent evaluation of the same loop closure. Which
assembly mode it is, is checked against the closed forms in test_continuation.py.
"""

from __future__ import annotations

import numpy as np
import pytest

import mechkin
from tests.model import closed_chain_models as M
from tests.model.test_continuation import load, random_qv

mujoco = pytest.importorskip("mujoco")

XARM_MJCF = """<mujoco><compiler angle="radian" autolimits="true"/>
<worldbody><body name="base">
 <body name="left_outer_knuckle" pos="0 0.035 0.059098">
  <joint name="left_driver_joint" axis="1 0 0" range="0 0.85"/><geom size="0.001" mass="0.01"/>
  <body name="left_finger" pos="0 0.035465 0.042039">
   <joint name="left_finger_joint" axis="-1 0 0" range="0 0.85"/>
   <geom size="0.001" mass="0.01"/>
  </body></body>
 <body name="left_inner_knuckle" pos="0 0.02 0.074098">
  <joint name="left_inner_knuckle_joint" axis="1 0 0" range="0 0.85"/>
  <geom size="0.001" mass="0.01"/>
 </body></body></worldbody>
<equality><connect anchor="0 -0.015 0.015" body1="left_finger" body2="left_inner_knuckle"/>
</equality></mujoco>"""

# right side of the 2F-85; the coupler joint held at 0 (the coupler body fixed to the driver)
ROBOTIQ_MJCF = """<mujoco><compiler angle="radian" autolimits="true"/>
<worldbody><body name="base">
 <body name="right_driver" pos="0 0.0306011 0.054904">
  <joint name="right_driver_joint" axis="1 0 0" range="0 0.8"/><geom size="0.001" mass="0.01"/>
  <body name="right_coupler" pos="0 0.0315 -0.0041"><geom size="0.001" mass="0.01"/></body>
 </body>
 <body name="right_spring_link" pos="0 0.0132 0.0609">
  <joint name="right_spring_link_joint" axis="1 0 0" range="-0.29670597283 0.8"/>
  <geom size="0.001" mass="0.01"/>
  <body name="right_follower" pos="0 0.055 0.0375">
   <joint name="right_follower_joint" axis="1 0 0" pos="0 -0.018 0.0065"
          range="-0.872664 0.872664"/>
   <geom size="0.001" mass="0.01"/>
  </body></body></body></worldbody>
<equality><connect anchor="0 0 0" body1="right_follower" body2="right_coupler"/></equality>
</mujoco>"""


@pytest.mark.parametrize("text, mjcf", [(M.XARM, XARM_MJCF), (M.ROBOTIQ, ROBOTIQ_MJCF)],
                         ids=["xarm_gripper", "robotiq_fourbar"])
def test_mujoco_loop_equations_hold_at_mechkin_answers(tmp_path, text, mjcf):
    mech, _ = load(tmp_path, text)
    model = mujoco.MjModel.from_xml_string(mjcf)
    data = mujoco.MjData(model)
    assert model.nq == mech.n
    res = mechkin.fk(mech, random_qv(mech))
    assert res.status == ["converged"] * 100
    worst = 0.0
    for q in res.q:  # same joint order: driver, then the passive joints
        data.qpos[:] = q
        mujoco.mj_forward(model, data)
        assert data.ne == 3
        worst = max(worst, float(np.abs(data.efc_pos[:data.ne]).max()))
    assert worst <= 1e-10
    # a configuration off the loop is seen by MuJoCo (the check can fail)
    data.qpos[:] = res.q[0] + np.array([0.0, 0.05, 0.0])
    mujoco.mj_forward(model, data)
    assert np.abs(data.efc_pos[:data.ne]).max() > 1e-4
