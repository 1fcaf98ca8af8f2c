"""The Robotiq-like four-bar gripper with a coupling (issue 24): both fingers, one motor.

Both sides of tests/model/closed_chain_models.ROBOTIQ (the left side its mirror image in the
y axis, joint axes reversed, as in MuJoCo Menagerie's ``robotiq_2f85/2f85.xml``), closed by one
pin cut each, and the left driver coupled to the right one (``left_driver_joint = 1 *
driver_joint``, Menagerie's driver joint equality): one independent joint, two loops and a
coupling row in phi. By the mirror symmetry every left joint equals its right twin, and both
equal the typed-in closed form of one side (``robotiq_closed_form``): checked for 100 random
drivers within limits (<= 1e-10 rad), with both pads mirror images, and passive limits applied
on both sides.
"""

from __future__ import annotations

import numpy as np

import mechkin
from tests.model import closed_chain_models as M
from tests.model.test_continuation import load, random_qv

LEFT = """
  - name: left_driver
    frames:
      - {name: left_coupler_anchor, xyz: [-0.0375989, 0.043496, 0]}
  - name: left_spring_link
  - name: left_follower
    frames:
      - {name: left_follower_anchor, xyz: [-0.018, -0.0065, 0]}
      - {name: left_pad, xyz: [0.0009, -0.01245, 0]}
joints:"""
LEFT_JOINTS = """
  - {name: left_driver_joint, type: revolute, parent: base, child: left_driver,
     axis: [0, 0, -1], origin: {xyz: [-0.0306011, 0.054904, 0]}, limits: [0, 0.8], home: 0}
  - {name: left_spring_link_joint, type: revolute, parent: left_spring_pivot,
     child: left_spring_link, axis: [0, 0, -1], limits: [-0.29670597283, 0.8], home: 0}
  - {name: left_follower_joint, type: revolute, parent: left_spring_link, child: left_follower,
     axis: [0, 0, -1], origin: {xyz: [-0.037, 0.044, 0]}, limits: [-0.872664, 0.872664],
     home: 0}
cuts:"""
COUPLED = (M.ROBOTIQ
           .replace("name: robotiq_fourbar", "name: robotiq_two_fingers")
           .replace("      - {name: spring_pivot, xyz: [0.0132, 0.0609, 0]}",
                    "      - {name: spring_pivot, xyz: [0.0132, 0.0609, 0]}\n"
                    "      - {name: left_spring_pivot, xyz: [-0.0132, 0.0609, 0]}")
           .replace("\njoints:", LEFT, 1)
           .replace("\ncuts:", LEFT_JOINTS, 1)
           .replace("independent: [driver_joint]",
                    "  - {name: left_pin, frames: [left_coupler_anchor, left_follower_anchor],"
                    " mask: [x, y]}\ncouplings:\n"
                    "  - {joint: left_driver_joint, master: driver_joint, multiplier: 1.0, "
                    "offset: 0.0}\nindependent: [driver_joint]"))


def test_two_fingers_one_motor_match_the_closed_form(tmp_path):
    mech, _ = load(tmp_path, COUPLED)
    assert mech.independent_names == ["driver_joint"] and mech.n_cuts == 2
    assert mech.n_equations == 5  # two pins (x, y) and the coupling row
    qv = random_qv(mech, 100, seed=24)
    res = mechkin.fk(mech, qv, frames=["pad", "left_pad"])
    assert res.status == ["converged"] * 100
    ref = M.robotiq_closed_form(qv)
    names = ["driver_joint", "spring_link_joint", "follower_joint"]
    for prefix in ("", "left_"):
        cols = [mech.joint_index(prefix + n) for n in names]
        assert np.abs(M.wrap(res.q[:, cols] - ref)).max() <= 1e-10, prefix
    right, left = res.poses["pad"][:, :3, 3], res.poses["left_pad"][:, :3, 3]
    np.testing.assert_allclose(left, right * [-1.0, 1.0, 1.0], atol=1e-12)
    # the pads close towards each other as the motor turns (the check can fail)
    order = np.argsort(qv[:, 0])
    assert np.all(np.diff(right[order, 0]) < 0)


def test_passive_limits_apply_to_both_fingers(tmp_path):
    # only the left follower narrowed: its loop, reached through the coupling, decides
    mech, _ = load(tmp_path, COUPLED.replace(
        "axis: [0, 0, -1], origin: {xyz: [-0.037, 0.044, 0]}, limits: [-0.872664, 0.872664]",
        "axis: [0, 0, -1], origin: {xyz: [-0.037, 0.044, 0]}, limits: [-0.3, 0.3]"))
    qv = np.linspace(0.0, 0.8, 41)[:, None]
    res = mechkin.fk(mech, qv)
    beyond = np.abs(M.robotiq_closed_form(qv)[:, 2]) > 0.3 + 1e-9
    assert beyond.any() and not beyond.all()
    assert res.status == ["outside limits" if b else "converged" for b in beyond]
    assert res.within_limits == (~beyond).tolist()
