"""FK of a floating-base robot (issue 25): the six base joints are FK inputs; one without a
motion rests at the base pose of the file (its keyframe), the others follow their motions."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import mechkin
from mechkin.model.kinematics import forward_kinematics

ROOT = Path(__file__).resolve().parents[2]
LEGS = "\n".join(f"    {s}_{j}: {{type: constant, value: {0.3 if j == 'knee' else 0}}}"
                 for s in ("left", "right")
                 for j in ("hip_1", "hip_2", "hip_3", "knee", "ankle", "ankle_roll"))


def test_base_joints_are_inputs_and_rest_at_the_keyframe(tmp_path):
    p = tmp_path / "fk.yaml"
    p.write_text(f"""name: biped_fk
task: fk
mechanism: {ROOT / 'mechanisms' / 'biped_floating.xml'}
fk:
  time: {{start: 0, stop: 1, step: 0.5}}
  motion:
    base_z: {{type: ramp, from: 0.9, to: 1.0}}
{LEGS}
outputs: {{csv: false, plots: false, mcap: false}}
""")
    rep = mechkin.run(p)
    assert rep.summary["status"] == "ok"
    mech = mechkin.load_mechanism(ROOT / "mechanisms" / "biped_floating.xml")
    q = rep.data.q
    assert np.allclose(q[:, mech.joint_index("base_z")], [0.9, 0.95, 1.0], atol=1e-15)
    for n in ("base_x", "base_y", "base_yaw", "base_pitch", "base_roll"):  # the keyframe's
        assert np.all(q[:, mech.joint_index(n)] == mech.home[mech.joint_index(n)])
    assert mech.home[mech.joint_index("base_x")] == 0.1  # keyframe qpos[0]
    pel = forward_kinematics(mech, q).frames(mech, [mech.frame_index("pelvis")])[:, 0]
    assert np.allclose(pel[:, 2, 3], [0.9, 0.95, 1.0], atol=1e-15)
