"""Workspace sweeps of arms with joints without limits (issue 25): such a revolute joint is
swept over a full turn by default and the summary says so; a range given for some joints does not
drop the others from a monte_carlo sweep."""

from __future__ import annotations

import mechkin

MECH = """name: rr
units: {length: m, angle: deg}
links:
  - name: base
  - name: l1
  - name: l2
    frames: [{name: tip, xyz: [0.5, 0, 0]}]
joints:
  - {name: q1, type: revolute, parent: base, child: l1}
  - {name: q2, type: revolute, parent: l1, child: l2, origin: {xyz: [1.0, 0, 0]},
     limits: [-90, 90]}
end_effector: tip
"""

SCEN = """name: rr_ws
task: workspace
mechanism: rr.yaml
units: {{length: m, angle: deg}}
workspace:
  kind: joint_sweep
  method: monte_carlo
  samples: 4000
  seed: 3
{joints}
outputs: {{csv: false, plots: false, mcap: false}}
"""


def _run(tmp_path, joints: str):
    (tmp_path / "rr.yaml").write_text(MECH)
    p = tmp_path / "ws.yaml"
    p.write_text(SCEN.format(joints=joints))
    return mechkin.run(p).summary


def test_unlimited_joint_is_swept_over_a_full_turn(tmp_path):
    s = _run(tmp_path, "")
    assert s["swept_joints"] == ["q1", "q2"] and s["full_turn_joints"] == ["q1"]
    # q1 over a full turn: the tip (radius 1.1 .. 1.5) reaches both sides of the base
    assert s["bounding_box"]["max_m"][0] > 1.1 and s["bounding_box"]["min_m"][0] < -1.1


def test_a_range_for_one_joint_keeps_the_others(tmp_path):
    s = _run(tmp_path, "  joints:\n    q2: {range: [-10, 10]}")
    assert s["swept_joints"] == ["q1", "q2"] and s["full_turn_joints"] == ["q1"]
    assert s["bounding_box"]["min_m"][0] < -1.4  # q1 swept too: the tip goes round
